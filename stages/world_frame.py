"""One fixed gravity-aligned frame per recording (docs/CONVENTIONS.md, "World frame").

The canonical frame turns with the pelvis every frame, so anything differentiated in time in
it carries rotating-frame terms and the network's heading jitter. For a static camera
(sequence mode: one up for the whole recording) this module gives the recording one frame:
+Y up, +X the horizontal part of the subject's forward direction averaged over the first
valid second, +Z = X x Y (the subject's right then), and poses in it with the floor at
y = 0.

A depth sensor's skeleton (Kinect v1, Azure Kinect: ``Poses3D.root_translation``) measures
the pelvis's camera-frame position: the pelvis then follows its path (x = z = 0 at the start)
above one floor for the whole recording. What a root-relative lifter (VideoPose3D, MediaPipe
world landmarks, MotionBERT in camera-normalised mode) cannot give: the pelvis's horizontal path. It stays at x = z = 0;
the vertical is measured from the floor, taken as the plane of the lowest joint centre in
each frame (a stance ankle when standing, H36M-17 has no sole or toe joint; the body's
lowest joint when lying), so the pelvis rises and falls with the legs but a flight phase
(both feet off the floor) reads as standing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core.conventions import L_ANKLE, PELVIS, R_ANKLE, validate_fps
from .core.errors import InputError
from .core.framestore import frame_blocks

#: Seconds at the start of the recording whose forward direction sets the world heading.
HEADING_WINDOW_S = 1.0
#: Below this horizontal length (unit vectors) the forward direction has no heading.
MIN_HORIZONTAL = 1e-3


@dataclass(frozen=True)
class WorldFrame:
    """``rotation`` ``(3, 3)`` float64 camera->world (rows: the world X, Y, Z axes in camera
    coordinates), ``heading_frames``: the valid frames whose forward direction was averaged."""

    rotation: np.ndarray
    heading_frames: int


def world_frame(R: np.ndarray, valid: np.ndarray, fps: float) -> WorldFrame:
    """The recording's world frame from rectified rotations.

    Args:
        R: ``(T, 3, 3)`` canonical->camera rotations (docs/CONVENTIONS.md), NaN where not
            valid; the up ``R[:, :, 1]`` is averaged over the valid frames (one direction in
            sequence mode), the forward ``R[:, :, 0]`` over the valid frames of the first
            :data:`HEADING_WINDOW_S` seconds after the first valid frame.
        valid: ``(T,)`` bool, or 0/1 integers (as ``kinematics.csv``'s ``valid`` column).
        fps: frame rate (Hz).

    Returns:
        :class:`WorldFrame`.

    Raises:
        InputError: ``R`` not ``(T, 3, 3)``, ``valid`` not ``(T,)``, ``fps`` not a frame rate
            (:func:`~pcnet.stages.core.conventions.validate_fps`), a valid frame whose rotation
            is not finite, no valid frame, or the forward direction over the first second is
            vertical or cancels out (no heading).
    """
    R = R if hasattr(R, "shape") else np.asarray(R, np.float64)
    if len(R.shape) != 3 or R.shape[1:] != (3, 3):
        raise InputError(f"world frame: R must have shape (T, 3, 3), got {tuple(R.shape)}")
    valid = np.asarray(valid)
    if valid.dtype != bool and np.issubdtype(valid.dtype, np.integer) and np.isin(valid, (0, 1)).all():
        valid = valid.astype(bool)  # a 0/1 column, as kinematics.csv's valid
    if tuple(valid.shape) != (R.shape[0],) or valid.dtype != bool:
        raise InputError(f"world frame: valid must be a ({R.shape[0]},) bool (or 0/1) array like R's frames, got "
                         f"{valid.dtype} {valid.shape}")
    fps = validate_fps(fps, "world frame: fps")
    idx = np.flatnonzero(valid)
    if len(idx) == 0:
        raise InputError("world frame: no valid frame to take the up and heading from")
    if not np.isfinite(R[idx]).all():
        raise InputError("world frame: R must be finite in every frame valid marks, got NaN or inf there")
    up = np.mean(R[idx, :, 1], axis=0)
    up /= np.linalg.norm(up)
    first = idx[idx < idx[0] + max(1, int(round(HEADING_WINDOW_S * fps)))]
    forward = np.mean(R[first, :, 0], axis=0)
    forward -= forward @ up * up
    length = np.linalg.norm(forward)
    if not length > MIN_HORIZONTAL:
        raise InputError("world frame: the subject's forward direction over the first second has no horizontal "
                         "part (lying face up or down, or turning through 360 deg), so no heading can be fixed")
    x = forward / length
    return WorldFrame(np.stack([x, up, np.cross(x, up)]), len(first))


def to_world(joints_cam: np.ndarray, frame: WorldFrame, root_cam: np.ndarray | None = None,
             out: np.ndarray | None = None) -> np.ndarray:
    """Pelvis-centred camera-frame poses in the recording's world frame, floor at y = 0.

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 root-relative camera-frame poses (pelvis at the
            origin), any units; NaN = missing.
        frame: from :func:`world_frame`.
        root_cam: optional ``(T, 3)`` measured camera-frame pelvis positions in the same
            units (a depth sensor's skeleton, ``Poses3D.root_translation``); NaN = unknown.

    Returns:
        ``(T, 17, 3)`` float64, ``x_w = W x_cam``. Without ``root_cam``: each frame lifted so
        that its lowest joint centre lies at y = 0 and the pelvis at x = z = 0 (module
        docstring). With ``root_cam``: the pelvis follows its measured path, x = z = 0 at the
        first frame with a root, and one floor for the recording at the median over frames of
        the lowest joint centre (the subject is on the floor most of the time, so a jump
        lifts the whole body); a frame without a root is NaN. Frames without any finite joint
        stay NaN. Written into ``out`` when given (any float64 ``(T, 17, 3)`` array taking
        slice assignment: a long recording's is a
        :class:`~pcnet.stages.core.framestore.FrameArray`); ``joints_cam`` may be one too:
        both are read and written a block of frames at a time.

    Raises:
        InputError: ``joints_cam`` not ``(T, 17, 3)``, ``root_cam`` of the wrong shape or
            without a finite frame.
    """
    shape = tuple(getattr(joints_cam, "shape", np.shape(joints_cam)))
    if len(shape) != 3 or shape[1:] != (17, 3):
        raise InputError(f"world frame: joints_cam must have shape (T, 17, 3), got {shape}")
    T = len(joints_cam)
    root = None
    if root_cam is not None:
        root = np.asarray(root_cam, np.float64)
        if root.shape != (T, 3):
            raise InputError(f"world frame: root_cam must have shape ({T}, 3), got {root.shape}")
        root = root @ frame.rotation.T
        known = np.flatnonzero(np.isfinite(root).all(axis=1))
        if not len(known):
            raise InputError("world frame: the root's camera-frame position is missing in every frame")
        root[:, [0, 2]] -= root[known[0], [0, 2]]

    def rotated(rows: slice) -> np.ndarray:
        P = np.asarray(joints_cam[rows], np.float64) @ frame.rotation.T
        if root is not None:
            P += root[rows, None]
        return P

    # Two passes over the frames: the floor under each frame needs its neighbours' (a gap
    # is interpolated), then every frame is shifted onto it.
    summaries = [_floor_evidence(rotated(rows)) for rows in frame_blocks(T)]
    lowest, feet = _floor_from(*(np.concatenate(s) for s in zip(*summaries)))
    if root is None:
        shift = lowest
    else:
        pelvis_y = np.concatenate([s[3] for s in summaries])
        shift = np.full(T, np.median(lowest[feet]) if feet.any() else np.nanmedian(pelvis_y))
    out = np.empty((T, 17, 3)) if out is None else out
    for rows in frame_blocks(T):
        P = rotated(rows)
        P[..., 1] -= shift[rows, None]
        out[rows] = P
    return out


def _floor_evidence(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per frame of Y-up poses ``(T, 17, 3)``: ``(present, lowest joint height (NaN when
    absent), feet visible, pelvis height)``, what :func:`floor_heights` needs."""
    present = np.isfinite(P[..., 1]).any(axis=1)
    lowest = np.full(len(P), np.nan)
    lowest[present] = np.nanmin(P[present, :, 1], axis=1)
    return present, lowest, feet_visible(P), P[:, PELVIS, 1].copy()  # a view would keep the block


def _floor_from(present: np.ndarray, lowest: np.ndarray, feet: np.ndarray,
                pelvis_y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    seen = np.flatnonzero(feet & np.isfinite(pelvis_y))
    above = pelvis_y - lowest  # the pelvis's height above the floor where the feet show it
    if len(seen):
        frames = np.arange(len(lowest))
        lowest = np.where(feet, lowest, pelvis_y - np.interp(frames, seen, above[seen]))
    else:
        lowest = np.where(present, pelvis_y, np.nan)
    return lowest, feet


def floor_heights(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame, the floor's height under poses ``P`` ``(T, 17, 3)`` (+Y up) and whether it
    was seen.

    The floor is the lowest joint centre of a frame in which an ankle is visible (finite):
    the stance foot, or the lowest body part when lying. Without a visible ankle the lowest
    joint is not on the floor (a knee, a hip: the feet are out of the picture or masked), so
    those frames take the pelvis's height above the floor interpolated in time from the
    nearest frames that saw it (held at the ends); when no frame shows an ankle there is no
    floor and heights are relative to the pelvis (its y is the floor's). Frames without any
    finite joint are NaN.

    Returns:
        ``(floor_y (T,), feet_visible (T,) bool)``.
    """
    return _floor_from(*_floor_evidence(np.asarray(P, np.float64)))


def feet_visible(poses: np.ndarray) -> np.ndarray:
    """``(T,)`` bool: frames of ``(T, 17, 3)`` poses (any frame: a rotation keeps a joint finite
    or missing) with at least one ankle present, the frames in which the floor is seen."""
    return np.isfinite(poses[:, [L_ANKLE, R_ANKLE]]).all(axis=-1).any(axis=1)
