"""The canonical frame of ``docs/CONVENTIONS.md`` built from poses whose up direction is known,
and the maps between camera and canonical coordinates.
"""

from __future__ import annotations

import numpy as np

from .conventions import L_HIP, PELVIS, R_HIP, THORAX, check_poses
from .errors import InputError
from .framestore import frame_blocks
from .rotations import normalize

# A hip line closer than this to the up axis (|horizontal part| / |hip line|) leaves the
# heading undefined (sin 5.7 deg): such frames are flagged invalid, never guessed.
MIN_HORIZONTAL_HIP_FRACTION = 0.1


def canonical_rotation(joints: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation from the canonical frame to the frame of ``joints``, given that frame's up.

    Per ``docs/CONVENTIONS.md``: +Y = ``up``; +Z = the horizontal component (perpendicular to Y)
    of ``right_hip - left_hip``, normalised; +X = Y x Z. The columns of the returned matrix
    are those axes expressed in the input frame, so ``x_in = R @ x_canon``.

    Args:
        joints: ``(N, 17, 3)`` or ``(17, 3)`` H36M-17 poses in any right-handed frame.
        up: ``(3,)`` or ``(N, 3)`` the up direction (against gravity) in that frame.

    Returns:
        ``R`` ``(N, 3, 3)`` float64 and ``valid`` ``(N,)`` bool. Frames whose hips are NaN,
        coincident, or whose hip line is within 5.7 deg of vertical get a NaN ``R`` and
        ``valid = False``.

    Raises:
        ValueError: wrong joint shape.
    """
    X = check_poses(joints, "joints")  # left as given: on disk for a long recording
    up = normalize(np.broadcast_to(np.asarray(up, np.float64), (X.shape[0], 3)))
    hip = np.asarray(X[:, R_HIP], np.float64) - np.asarray(X[:, L_HIP], np.float64)
    horizontal = hip - np.sum(hip * up, -1, keepdims=True) * up
    hip_len = np.linalg.norm(hip, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.linalg.norm(horizontal, axis=-1) / hip_len
    valid = np.isfinite(frac) & (frac > MIN_HORIZONTAL_HIP_FRACTION) & np.isfinite(up).all(-1)
    z = normalize(horizontal)
    x = np.cross(up, z)
    R = np.stack([x, up, z], axis=-1)
    R[~valid] = np.nan
    return R, valid


def to_canonical(joints_cam: np.ndarray, R: np.ndarray, residual: np.ndarray | None = None,
                 out: np.ndarray | None = None, residual_frame: np.ndarray | None = None) -> np.ndarray:
    """Camera-frame poses -> canonical poses: ``X_canon = (X_cam - pelvis) @ R (+ residual)``.

    Args:
        joints_cam: ``(N, J, 3)`` camera frame, any units.
        R: ``(N, 3, 3)`` canonical->camera, or one ``(3, 3)`` for every frame.
        residual: optional ``(N, J, 3)`` correction added in the canonical frame
            (3DPCNet's Delta, paper section 2.1.2).
        out: optional float32 ``(N, J, 3)`` array to write into (a
            :class:`~pcnet.stages.core.framestore.FrameArray` for a long recording).
        residual_frame: optional ``(N, 3, 3)`` canonical->camera rotations of the canonical
            frame ``residual`` is expressed in (the network's own per-frame rotation, where a
            sequence mode answers with another ``R``): the residual is turned into ``R``'s
            frame, ``residual @ residual_frame^T @ R``, so that it reshapes the same body
            whichever rotation places it; where ``residual_frame`` is not finite (a frame the
            network left out, residual 0) it is added as given.
        ``joints_cam``, ``R`` and ``residual`` may be on disk too: they are read a block at a time.

    Returns:
        ``(N, J, 3)`` pelvis-centred canonical poses, same units, float32 (``out`` if given).

    Raises:
        InputError: ``joints_cam`` not ``(N, J, 3)``, or ``R`` neither ``(3, 3)`` nor
            ``(N, 3, 3)``.
    """
    R = R if hasattr(R, "shape") else np.asarray(R)
    shape = tuple(joints_cam.shape)
    if len(shape) != 3 or shape[-1] != 3:
        raise InputError(f"joints_cam: expected (N, J, 3) poses, got shape {shape}")
    if tuple(R.shape) not in ((3, 3), (shape[0], 3, 3)):
        raise InputError(f"R: expected (3, 3) or ({shape[0]}, 3, 3) rotations for {shape[0]} poses, got shape "
                         f"{tuple(R.shape)}")
    out = np.empty(joints_cam.shape, np.float32) if out is None else out
    # A block of frames at a time: each frame's arithmetic is its own, and a long recording's
    # float64 temporaries stay a block long.
    for rows in frame_blocks(len(out)):
        X = np.asarray(joints_cam[rows], np.float64)
        R_block = np.asarray(R[rows] if len(R.shape) == 3 else R, np.float64)
        block = (X - X[:, PELVIS : PELVIS + 1]) @ R_block
        if residual is not None:
            delta = np.asarray(residual[rows], np.float64)
            if residual_frame is not None:
                own = np.asarray(residual_frame[rows], np.float64)
                turned = delta @ np.swapaxes(own, -1, -2) @ R_block
                delta = np.where(np.isfinite(own).all(axis=(1, 2))[:, None, None], turned, delta)
            block += delta
        out[rows] = block
    return out


def to_camera(joints_canon: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Canonical poses ``(N, J, 3)`` -> camera frame: ``X_cam = X_canon @ R^T``; float32."""
    return (np.asarray(joints_canon, np.float64) @ np.swapaxes(R, -1, -2)).astype(np.float32)


def world_to_canonical(joints_world: np.ndarray, up: np.ndarray = (0.0, 1.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """World-frame mocap ``(N, 17, 3)`` with known ``up`` -> pelvis-centred canonical poses
    ``(N, 17, 3)`` float32 and ``valid`` ``(N,)``; invalid frames are NaN."""
    R, valid = canonical_rotation(joints_world, up)
    return to_canonical(joints_world, R), valid


def trunk_lean_deg(canonical: np.ndarray) -> np.ndarray:
    """Angle between the trunk (pelvis -> thorax) and gravity up, degrees, ``(N,)`` float64,
    of canonical-frame poses ``(N, 17, 3)`` (any units; +Y up, docs/CONVENTIONS.md), an array
    or a :class:`~.framestore.FrameArray` (only its two joint columns are read); NaN where the
    trunk has no length or a joint is missing."""
    trunk = np.asarray(canonical[:, THORAX], np.float64) - np.asarray(canonical[:, PELVIS], np.float64)
    length = np.linalg.norm(trunk, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.where(length > 0, trunk[:, 1] / length, np.nan)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
