"""One fixed gravity-aligned frame per recording (docs/CONVENTIONS.md, "World frame").

The canonical frame turns with the pelvis every frame, so anything differentiated in time in
it carries rotating-frame terms and the network's heading jitter. For a static camera
(sequence mode: one up for the whole recording) this module gives the recording one frame:
+Y up, +X the horizontal part of the subject's forward direction averaged over the first
valid second, +Z = X x Y (the subject's right then), and poses in it with the ground at
y = 0 (:mod:`pcnet.stages.floor`).

With a pelvis path (a depth sensor's measured pelvis, ``Poses3D.root_translation``, or one
recovered from 2D keypoints) the pelvis follows it (x = z = 0 at the start) above ONE ground
plane for the whole recording, fitted to the stance contacts; H36M-17 has no sole or toe
joint, so ankle centres at rest stand the fitted clearance above it. What a root-relative
lifter (VideoPose3D, MediaPipe world landmarks, MotionBERT in camera-normalised mode) cannot
give: the pelvis's path. It stays at x = z = 0; the ground is then taken per frame, the
clearance below the lowest joint centre (a stance ankle when standing; the body's lowest
joint when lying), so the pelvis rises and falls with the legs but a flight phase (both feet
off the floor) reads as standing. :func:`to_world_floor` says which (:class:`Floor`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core.conventions import L_ANKLE, PELVIS, R_ANKLE, validate_fps
from .core.errors import InputError
from .core.framestore import frame_blocks
from .floor import ANKLE_CLEARANCE_LEG, Floor, fit_ground  # noqa: F401 (Floor: re-exported)
from .scale import mean_leg_length

#: Seconds at the start of the recording whose forward direction sets the world heading.
HEADING_WINDOW_S = 1.0
#: Below this horizontal length (unit vectors) the forward direction has no heading.
MIN_HORIZONTAL = 1e-3


@dataclass(frozen=True, eq=False)
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
    """Pelvis-centred camera-frame poses in the recording's world frame, ground at y = 0:
    :func:`to_world_floor` without the :class:`~pcnet.stages.floor.Floor` (same arguments,
    result and errors)."""
    return to_world_floor(joints_cam, frame, root_cam, out)[0]


#: A pelvis within this fraction of the block's largest coordinate from the origin is at the
#: origin: a lifter's own rounding of its root (a developer trial's VideoPose3D exports hold it
#: up to 5e-5 of their largest coordinate away, float32 arithmetic), while poses whose root
#: was not subtracted hold it at a large fraction of the body's size or beyond.
ROOT_AT_ORIGIN_FRACTION = 1e-3


def _require_root_relative(J: np.ndarray, rows: slice) -> None:
    """Refuse a block of poses ``(n, 17, 3)`` whose present pelvis is not at the origin
    (within :data:`ROOT_AT_ORIGIN_FRACTION` of the largest coordinate)."""
    pelvis = J[:, PELVIS]
    scale = max(np.nanmax(np.abs(J), initial=0.0), 1e-30)
    off = np.isfinite(pelvis).all(axis=1) & (np.abs(pelvis).max(axis=1, initial=0.0) > ROOT_AT_ORIGIN_FRACTION * scale)
    if off.any():
        i = int(np.flatnonzero(off)[0])
        raise InputError(f"world frame: joints_cam: expected root-relative poses (pelvis at the origin), got the "
                         f"pelvis at {[float(f'{v:.3g}') for v in pelvis[i]]} in frame {i + (rows.start or 0)}; subtract "
                         f"it and give its path as root_cam")


def to_world_floor(joints_cam: np.ndarray, frame: WorldFrame, root_cam: np.ndarray | None = None,
                   out: np.ndarray | None = None, floor_frames: np.ndarray | None = None) -> tuple[np.ndarray, Floor]:
    """Pelvis-centred camera-frame poses in the recording's world frame, ground at y = 0,
    and how that ground was found.

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 root-relative camera-frame poses (pelvis at the
            origin), any units; NaN = missing.
        frame: from :func:`world_frame`.
        root_cam: optional ``(T, 3)`` camera-frame pelvis path in the same units (measured by
            a depth sensor, ``Poses3D.root_translation``, or recovered from 2D keypoints);
            NaN = unknown.
        out: optional float64 ``(T, 17, 3)`` array taking slice assignment to write into (a
            long recording's :class:`~pcnet.stages.core.framestore.FrameArray`);
            ``joints_cam`` may be one too: both are read and written a block of frames at a
            time.
        floor_frames: optional ``(T,)`` bool, the frames whose contacts may place the ground
            plane (default: every frame): where a 2D track switches person, its longest
            one-person stretch (:func:`pcnet.stages.flags.one_person_frames`; decision 0068),
            so that one person's feet define the ground under both.

    Returns:
        ``(poses, floor)``: ``(T, 17, 3)`` float64 ``x_w = W x_cam`` (+ the path) with the
        ground at ``y = 0``, and a :class:`~pcnet.stages.floor.Floor`.

        With ``root_cam``: the pelvis follows its path, x = z = 0 at the first frame with a
        root, above ONE horizontal ground plane for the recording fitted to the stance
        contacts (:mod:`pcnet.stages.floor`: robust to flight phases and false contacts), so
        ankle centres at rest stand ``floor.clearance`` above y = 0 and a jump lifts the whole
        body; a frame without a root is NaN. Fewer than
        :data:`~pcnet.stages.floor.MIN_CONTACTS` contacts: the per-frame floor below
        (``floor.kind == "per frame"``, with the reason); no ankle in any frame: the pelvis's
        median height is y = 0 (``"pelvis"``).

        Without ``root_cam`` (a root-relative lifter: the pelvis height above the ground is
        not observable from translation): ``floor.kind == "per frame"``, each frame lifted so
        that its lowest joint centre stands ``floor.clearance`` above y = 0 (a stance ankle's
        height above the ground) and the pelvis at x = z = 0; a flight phase reads as
        standing. Frames without a visible ankle take the pelvis's height above the floor
        interpolated from the frames that saw one (:func:`floor_heights`); with no ankle in
        any frame the pelvis is at y = 0 (``"pelvis"``). Frames without any finite joint stay
        NaN.

    Raises:
        InputError: ``joints_cam`` not ``(T, 17, 3)`` or not root-relative (a pelvis away from
            the origin: a lifter's raw output keeps its image position, which would read as a
            path), ``root_cam`` or ``floor_frames`` of the wrong shape, ``root_cam`` without a
            finite frame.
    """
    if isinstance(joints_cam, tuple):  # root_relative's (poses, root) passed whole (a notebook trial)
        raise InputError(f"world frame: joints_cam: expected a (T, 17, 3) array, got a tuple of {len(joints_cam)} "
                         f"(root_relative returns (poses, root): pass poses, and root as root_cam)")
    shape = tuple(getattr(joints_cam, "shape", np.shape(joints_cam)))
    if len(shape) != 3 or shape[1:] != (17, 3):
        raise InputError(f"world frame: joints_cam must have shape (T, 17, 3), got {shape}")
    T = len(joints_cam)
    if floor_frames is not None and np.shape(floor_frames) != (T,):
        raise InputError(f"world frame: floor_frames must have shape ({T},), got {np.shape(floor_frames)}")
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

    def rotated(rows: slice, check: bool = False) -> np.ndarray:
        J = np.asarray(joints_cam[rows], np.float64)
        if check:  # once, in the first pass
            _require_root_relative(J, rows)
        P = J @ frame.rotation.T
        if root is not None:
            P += root[rows, None]
        return P

    # Two passes over the frames: the floor needs the whole recording's evidence (the plane,
    # or a gap's neighbours), then every frame is shifted onto it.
    present, lowest, feet, pelvis_y, legs = (np.concatenate(s) for s in zip(
        *(_floor_evidence(rotated(r, check=True)) for r in frame_blocks(T))))
    leg = float(np.nanmedian(legs)) if np.isfinite(legs).any() else float("nan")
    clearance = ANKLE_CLEARANCE_LEG * leg if np.isfinite(leg) else 0.0
    floor = None
    if not feet.any():
        floor = Floor("pelvis", 0.0, leg, reason="no ankle visible in any frame")
        shift = np.full(T, np.nanmedian(pelvis_y)) if root is not None else np.where(present, pelvis_y, np.nan)
    elif root is not None:
        usable = feet & np.isfinite(pelvis_y)
        if floor_frames is not None:
            usable &= np.asarray(floor_frames, bool)
        ground, floor = fit_ground(lowest, usable, leg)
        shift = np.full(T, ground)
    if floor is None or floor.kind == "per frame":
        floor = floor or Floor("per frame", clearance, leg, reason="no pelvis path")
        shift = _floor_from(present, lowest, feet, pelvis_y)[0] - clearance
    out = np.empty((T, 17, 3)) if out is None else out
    for rows in frame_blocks(T):
        P = rotated(rows)
        P[..., 1] -= shift[rows, None]
        out[rows] = P
    return out, floor


def _floor_evidence(P: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per frame of Y-up poses ``P`` ``(T, 17, 3)``: ``(present, lowest joint height (NaN when
    absent), feet visible, pelvis height, leg length)``."""
    Y = P[:, :, 1]
    present = np.isfinite(Y).any(axis=1)
    lowest = np.full(len(P), np.nan)
    lowest[present] = np.nanmin(Y[present], axis=1)
    return present, lowest, feet_visible(P), P[:, PELVIS, 1].copy(), mean_leg_length(P)  # a view would keep the block


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
    """Per frame, the height of the contact (ankle-centre) plane under poses ``P``
    ``(T, 17, 3)`` (+Y up) and whether it was seen: the per-frame floor of
    :func:`to_world_floor` without a pelvis path, which puts the ground
    :data:`~pcnet.stages.floor.ANKLE_CLEARANCE_LEG` leg lengths below it.

    The contact plane is the lowest joint centre of a frame in which an ankle is visible (finite):
    the stance foot, or the lowest body part when lying. Without a visible ankle the lowest
    joint is not on the floor (a knee, a hip: the feet are out of the picture or masked), so
    those frames take the pelvis's height above the floor interpolated in time from the
    nearest frames that saw it (held at the ends); when no frame shows an ankle there is no
    floor and heights are relative to the pelvis (its y is the floor's). Frames without any
    finite joint are NaN.

    Returns:
        ``(floor_y (T,), feet_visible (T,) bool)``.
    """
    return _floor_from(*_floor_evidence(np.asarray(P, np.float64))[:4])


def feet_visible(poses: np.ndarray) -> np.ndarray:
    """``(T,)`` bool: frames of ``(T, 17, 3)`` poses (any frame: a rotation keeps a joint finite
    or missing) with at least one ankle present, the frames in which the floor is seen."""
    return np.isfinite(poses[:, [L_ANKLE, R_ANKLE]]).all(axis=-1).any(axis=1)
