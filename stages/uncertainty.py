"""The per-frame tilt bound of the shipped ensemble of two 3DPCNets (frame mode and the per-frame
values of every mode).

The shipped ensemble runs two 3DPCNets, and where they disagree the pose is unlike what they learnt
(on DeepMimic the tenth of frames with the largest disagreement hold most of the large errors).
The bound is
``w sqrt(FRAME_TILT_95_DEG^2 + (FRAME_DISAGREEMENT_FACTOR d)^2) + (1 - w) FRAME_TILT_95_BODY_DEG``,
``d`` the angle between the two networks' ups and ``w`` the camera-frame network's weight (a
rolled camera, ``w = 0``, puts the camera-frame network outside its views, so its disagreement
says nothing about the pose; there the body-frame network answers and its own bound
``FRAME_TILT_95_BODY_DEG`` applies, the conformal 95 % quantile of its per-frame tilt errors,
valid under any camera roll because that network is rotation-equivariant). Calibration, on the
motion-style validation split (frame mode, a new camera per frame, lifter noise):
``FRAME_DISAGREEMENT_FACTOR`` is the smallest factor on a 0.25 grid whose bound covers 95 % of
the tenth of frames with the largest ``d``, and ``FRAME_TILT_95_DEG`` then the conformal 95 %
quantile of ``sqrt(max(e^2 - (k d)^2, 0))`` over the frames the camera-frame network answers
alone (``python -m benchmarks.calibrate_frame_bound --data ../shared/data``,
``benchmarks/results/frame_bound.txt``). On held-out mocap it held in 81-92 % of frames, so the
run says what it is rather than calling it a 95 % interval (docs/decisions/0036).

The sequence-mode intervals are the up model's posterior's (:mod:`pcnet.stages.up_model`,
docs/up_model.md).
"""
from __future__ import annotations

import numpy as np

#: Per-frame tilt bound (deg) where the two networks agree: the base of :func:`frame_tilt_bound`
#: (module docstring; ``python -m benchmarks.calibrate_frame_bound --data ../shared/data``,
#: ``benchmarks/results/frame_bound.txt``).
FRAME_TILT_95_DEG = 7.40
#: How much of the two networks' disagreement (deg) is added to the per-frame bound.
FRAME_DISAGREEMENT_FACTOR = 1.25
#: Per-frame tilt bound (deg) of the body-frame network alone, which answers where the view gate
#: sets the camera-frame network aside (``w = 0``: a rolled camera, a body across the image).
FRAME_TILT_95_BODY_DEG = 9.03


def frame_tilt_bound(disagreement_deg, camera_frame_weight, base_deg: float = FRAME_TILT_95_DEG,
                     factor: float = FRAME_DISAGREEMENT_FACTOR, body_deg: float = FRAME_TILT_95_BODY_DEG) -> np.ndarray:
    """Per-frame 95 % bound on the tilt error of the shipped ensemble's up, degrees:
    ``w sqrt(base^2 + (factor d)^2) + (1 - w) body`` (module docstring for the calibration): the
    camera-frame network's bound, widened by the two networks' disagreement ``d``, where the gate
    trusts it (``w = 1``), the body-frame network's own bound where it answers alone
    (``w = 0``), in between for blended frames.

    Args:
        disagreement_deg: ``(T,)`` angle between the camera-frame and body-frame networks' up
            directions, degrees (NaN = invalid frame, bound NaN).
        camera_frame_weight: ``(T,)`` the view gate's weight ``w`` in [0, 1]
            (:func:`pcnet.models.view_gate.camera_frame_weight`).
        base_deg, factor, body_deg: overrides of :data:`FRAME_TILT_95_DEG`,
            :data:`FRAME_DISAGREEMENT_FACTOR` and :data:`FRAME_TILT_95_BODY_DEG` (calibration scripts).

    Returns:
        ``(T,)`` float64 degrees, ``>= min(base_deg, body_deg)`` where finite.
    """
    w = np.asarray(camera_frame_weight, np.float64)
    d = np.asarray(disagreement_deg, np.float64)
    return w * np.sqrt(base_deg ** 2 + (factor * d) ** 2) + (1.0 - w) * body_deg
