"""The geometric canonicalisation baseline of the 3DPCNet paper, section 2.3."""

from __future__ import annotations

import numpy as np

from .conventions import L_HIP, L_SHOULDER, R_HIP, R_SHOULDER, check_poses
from .rotations import normalize

_TORSO = [R_HIP, L_HIP, R_SHOULDER, L_SHOULDER]
# Shoulder or hip pairs closer than this fraction of the torso height count as coincident.
_MIN_WIDTH_FRACTION = 0.05


def geometric_rotation(joints_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Estimate canonical->camera rotations from torso landmarks (paper section 2.3).

    Step 1: the least-squares plane through both hips and both shoulders; its normal,
    oriented anterior (``(shoulder_mid - hip_mid) x right``), becomes canonical +X.
    Step 2: the shoulder line ``right_shoulder - left_shoulder`` projected onto that plane
    becomes canonical +Z (the subject's right). +Y = Z x X completes the right-handed frame,
    so Y is the trunk's long axis: the method assumes an upright trunk, which is its bias.

    Args:
        joints_cam: ``(N, 17, 3)`` or ``(17, 3)`` H36M-17, camera frame, any units.

    Returns:
        ``R`` ``(N, 3, 3)`` float64 canonical->camera (``x_cam = R @ x_canon``) and
        ``valid`` ``(N,)`` bool. Frames with a NaN torso joint, coincident hips or shoulders,
        or a zero-size torso get NaN rotations and ``valid = False``.

    Raises:
        ValueError: wrong shape.
    """
    X = check_poses(joints_cam, "joints_cam")  # in memory or on disk: four joints read
    torso = np.asarray(X[:, _TORSO], np.float64)  # (N, 4, 3)
    finite = np.isfinite(torso).all((1, 2))
    torso = np.where(finite[:, None, None], torso, 0.0)
    centred = torso - torso.mean(1, keepdims=True)
    _, _, Vt = np.linalg.svd(centred)
    normal = Vt[:, 2]
    hip_mid = 0.5 * (torso[:, 0] + torso[:, 1])
    sho_mid = 0.5 * (torso[:, 2] + torso[:, 3])
    right = (torso[:, 0] - torso[:, 1]) + (torso[:, 2] - torso[:, 3])
    anterior = np.cross(sho_mid - hip_mid, right)
    normal = normal * np.where(np.sum(normal * anterior, -1) < 0, -1.0, 1.0)[:, None]
    shoulder = torso[:, 2] - torso[:, 3]
    z = normalize(shoulder - np.sum(shoulder * normal, -1, keepdims=True) * normal)
    y = np.cross(z, normal)
    R = np.stack([normal, y, z], axis=-1)

    height = np.linalg.norm(sho_mid - hip_mid, axis=-1)
    scale = np.maximum(height, 1e-12)
    hip_w = np.linalg.norm(torso[:, 0] - torso[:, 1], axis=-1) / scale
    sho_w = np.linalg.norm(shoulder, axis=-1) / scale
    valid = (
        finite
        & (height > 1e-9)
        & (hip_w > _MIN_WIDTH_FRACTION)
        & (sho_w > _MIN_WIDTH_FRACTION)
        & np.isfinite(R).all((1, 2))
    )
    R[~valid] = np.nan
    return R, valid
