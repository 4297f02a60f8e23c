"""Input normalisation shared by training, torch inference and onnxruntime inference.

numpy only, so run-time inference never needs torch.
"""

from __future__ import annotations

import numpy as np

from pcnet.stages.core.conventions import H36M_PARENTS, L_HIP, PELVIS, R_HIP, THORAX, check_poses

# Joints needed to define the body frame at all; a frame missing any is invalid.
_REQUIRED = (R_HIP, L_HIP, THORAX, 11, 14)


#: A hip line or spine shorter than this fraction of the pose's scale, or a hip line whose
#: part across the spine is, is degenerate (two joints on one point: a file's wrong layout
#: or a lifter's collapse); real hips are about 0.6 of the scale apart.
MIN_AXIS_FRACTION = 1e-3


def normalize_input(joints_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Prepare camera-frame poses for the network.

    1. Centre on the pelvis (the mid-hip stands in when the pelvis is NaN).
    2. Fill NaN joints with their parent's position (the bone collapses to zero length,
       which the network saw in training through dropped-joint noise); never with 0.
    3. Divide by the pose's scale ``s`` = the mean distance of the 16 non-root joints from
       the pelvis, so metric, millimetre and MotionBERT's normalised outputs all reach the
       network at unit size. Rotations are scale-free; a predicted residual is multiplied
       back by ``s`` so the output keeps the input's units.

    Args:
        joints_cam: ``(N, 17, 3)`` H36M-17 camera frame, any units.

    Returns:
        ``x`` ``(N, 17, 3)`` float32 normalised input (zeros for invalid frames),
        ``scale`` ``(N,)`` float64 in input units, ``valid`` ``(N,)`` bool: False where a
        hip, the thorax or a shoulder is NaN, the pose has zero size, or the hip line or
        the spine (pelvis -> thorax) is degenerate (:data:`MIN_AXIS_FRACTION`): the body
        frame is built from them (``models/network.py: body_frame``).

    Raises:
        ValueError: wrong shape.
    """
    X = check_poses(joints_cam, "joints_cam").astype(np.float64)
    pelvis = X[:, PELVIS]
    mid_hip = 0.5 * (X[:, R_HIP] + X[:, L_HIP])
    pelvis = np.where(np.isfinite(pelvis).all(-1, keepdims=True), pelvis, mid_hip)
    X = X - pelvis[:, None]
    valid = np.isfinite(X[:, list(_REQUIRED)]).all((1, 2)) & np.isfinite(pelvis).all(-1)
    X[:, PELVIS] = np.where(np.isfinite(X[:, PELVIS]), X[:, PELVIS], 0.0)
    for child, parent in enumerate(H36M_PARENTS):  # parents precede children
        if parent >= 0:
            miss = ~np.isfinite(X[:, child]).all(-1)
            X[miss, child] = X[miss, parent]
    scale = np.linalg.norm(X[:, 1:], axis=-1).mean(-1)
    valid &= np.isfinite(scale) & (scale > 1e-9)
    hips, spine = X[:, R_HIP] - X[:, L_HIP], X[:, THORAX]
    with np.errstate(invalid="ignore"):
        across = np.linalg.norm(np.cross(hips, spine), axis=-1) / np.maximum(np.linalg.norm(spine, axis=-1), 1e-12)
        valid &= (np.linalg.norm(hips, axis=-1) > MIN_AXIS_FRACTION * scale) & (
            np.linalg.norm(spine, axis=-1) > MIN_AXIS_FRACTION * scale) & (across > MIN_AXIS_FRACTION * scale)
    x = np.zeros_like(X, dtype=np.float32)
    x[valid] = (X[valid] / scale[valid, None, None]).astype(np.float32)
    return x, scale, valid
