"""Which of pcnet's two 3DPCNets to trust, from the camera orientation it reads.

pcnet ships two networks trained by the same recipe on the same data (models/MODEL_CARD.md):
the paper's camera-frame 3DPCNet (section 2.1, input in camera coordinates), more accurate
on held-out motion capture because it has learnt how cameras are usually held, and a
body-frame 3DPCNet (:func:`pcnet.models.network.body_frame`), exactly equivariant to camera
rotation, hence right for any camera roll but less accurate for level cameras. The
camera-frame network only knows cameras inside its training views ("paper" + "wide"
distributions, docs/CONVENTIONS.md: |roll| <= 25 deg, |pitch| <= 45 deg); outside them its
answer is pulled back towards a level camera (at 90 deg roll its tilt error is ~43 deg).

The gate reads the camera pitch and roll from the body-frame network's up (it has no
preference for level cameras, so its reading is not pulled into the range it tests; the
camera-frame network reads a lying body under a level camera as a camera rolled ~25 deg and
answers half-way), takes the running median over about two seconds (so a few hard poses do
not switch networks, while a phone turned during the recording does), and gives the
camera-frame network the weight 1 inside the range less a 5 deg margin, 0 beyond it plus
5 deg, linear in between. A body lying across the image reads as a rolled camera: the
body-frame network answers, and in sequence mode the camera prior weighs the lying reading
(:mod:`pcnet.stages.gravity_prior`). Measured on held-out motion capture
(benchmarks/results/view_gate.txt).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter
from scipy.spatial.transform import Rotation

from pcnet.stages.core.rotations import decompose_camera_rotation

#: Camera-frame network weight ramps (degrees): full weight up to the first value, none from
#: the second on; centred on the edges of the training views (|roll| 25, |pitch| 45).
ROLL_RAMP_DEG = (20.0, 30.0)
PITCH_RAMP_DEG = (40.0, 50.0)
#: Running-median window of the camera reading, seconds.
WINDOW_S = 2.0


def _ramp(x: np.ndarray, full: float, none: float) -> np.ndarray:
    return np.clip((none - x) / (none - full), 0.0, 1.0)


def camera_frame_weight(R_body_net: np.ndarray, valid: np.ndarray, fps: float = 30.0) -> np.ndarray:
    """Weight of the camera-frame network per frame, from the body-frame network's rotations.

    Args:
        R_body_net: ``(T, 3, 3)`` canonical->camera rotations of the body-frame 3DPCNet
            (docs/CONVENTIONS.md), NaN where not valid.
        valid: ``(T,)`` bool, the frames with a rotation.
        fps: frame rate (Hz) that sets the running-median window (:data:`WINDOW_S`); one
            recording per call.

    Returns:
        ``(T,)`` float64 in [0, 1]; NaN where not valid. Pitch and roll are
        :func:`pcnet.stages.core.rotations.decompose_camera_rotation`'s, their absolute values
        median-filtered over the valid frames in order.
    """
    weight = np.full(len(valid), np.nan)
    idx = np.flatnonzero(valid)
    if len(idx) == 0:
        return weight
    _, pitch, roll = decompose_camera_rotation(R_body_net[idx])
    size = max(1, int(round(WINDOW_S * fps)) | 1)
    roll_deg = median_filter(np.degrees(np.abs(roll)), size=size, mode="nearest")
    pitch_deg = median_filter(np.degrees(np.abs(pitch)), size=size, mode="nearest")
    weight[idx] = _ramp(roll_deg, *ROLL_RAMP_DEG) * _ramp(pitch_deg, *PITCH_RAMP_DEG)
    return weight


def blend_rotations(R_body: np.ndarray, R_camera: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Geodesic interpolation ``R_body exp(w log(R_body^T R_camera))`` per frame.

    Args:
        R_body, R_camera: ``(T, 3, 3)`` rotation matrices (any one convention, the same for
            both); weight: ``(T,)`` in [0, 1], 1 = ``R_camera``.

    Returns:
        ``(T, 3, 3)`` float64; NaN where either input or the weight is NaN.
    """
    out = np.full(R_body.shape, np.nan)
    ok = np.isfinite(R_body).all(axis=(1, 2)) & np.isfinite(R_camera).all(axis=(1, 2)) & np.isfinite(weight)
    if ok.any():
        relative = Rotation.from_matrix(np.swapaxes(R_body[ok], 1, 2) @ R_camera[ok]).as_rotvec()
        out[ok] = R_body[ok] @ Rotation.from_rotvec(relative * weight[ok, None]).as_matrix()
    return out
