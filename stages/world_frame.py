"""One fixed gravity-aligned frame per recording (docs/CONVENTIONS.md, "World frame").

The canonical frame turns with the pelvis every frame, so anything differentiated in time in
it carries rotating-frame terms and the network's heading jitter. For a static camera
(sequence mode: one up for the whole recording) this module gives the recording one frame:
+Y up, +X the horizontal part of the subject's forward direction averaged over the first
valid second, +Z = X x Y (the subject's right then), and poses in it with the floor at
y = 0.

What a root-relative lifter (VideoPose3D, MediaPipe world landmarks, MotionBERT in
camera-normalised mode) cannot give: the pelvis's horizontal path. It stays at x = z = 0;
the vertical is measured from the floor, taken as the plane of the lowest joint centre in
each frame (a stance ankle when standing, H36M-17 has no sole or toe joint; the body's
lowest joint when lying), so the pelvis rises and falls with the legs but a flight phase
(both feet off the floor) reads as standing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError

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
        valid: ``(T,)`` bool.
        fps: frame rate (Hz).

    Returns:
        :class:`WorldFrame`.

    Raises:
        InputError: no valid frame, or the forward direction over the first second is
            vertical or cancels out (no heading).
    """
    idx = np.flatnonzero(valid)
    if len(idx) == 0:
        raise InputError("world frame: no valid frame to take the up and heading from")
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


def to_world(joints_cam: np.ndarray, frame: WorldFrame) -> np.ndarray:
    """Pelvis-centred camera-frame poses in the recording's world frame, floor at y = 0.

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 root-relative camera-frame poses (pelvis at the
            origin), any units; NaN = missing.
        frame: from :func:`world_frame`.

    Returns:
        ``(T, 17, 3)`` float64: ``x_w = W x_cam`` with each frame lifted so that its lowest
        joint centre lies at y = 0 (module docstring); the pelvis at x = z = 0. Frames
        without any finite joint stay NaN.
    """
    P = np.asarray(joints_cam, np.float64) @ frame.rotation.T
    present = np.isfinite(P[..., 1]).any(axis=1)
    lowest = np.full(len(P), np.nan)
    lowest[present] = np.nanmin(P[present, :, 1], axis=1)
    P[..., 1] -= lowest[:, None]
    return P
