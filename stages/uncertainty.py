"""Calibrated up uncertainty: camera pitch/roll intervals for sequence mode (static camera)
and a per-frame tilt bound.

The moving-block bootstrap of :func:`pcnet.stages.temporal.sequence_rectify` measures only how
much the frames of one recording disagree. A monocular lifter's error persists over a whole
clip (:mod:`pcnet.models.lifter_noise`) and moves every frame's up the same way, so the
bootstrap alone is far too narrow (on held-out clips it contained the true pitch and roll in
about 30 % of clips, on the real Pose2Sim cameras in none). The interval here adds a
per-axis systematic error measured on data the shipped weights never trained on:

    half = sqrt(bootstrap_half^2 + (Z * SIGMA_SYS_DEG[axis])^2)

Provenance of the constants (``benchmarks/results/uncertainty.txt``, made by
``python benchmarks/calibrate_uncertainty.py --data ../shared/data``, 2026-11-22): the
motion-style *validation* split (Bandai validation groups and CMU validation subjects 12, 60,
206 clips; the shipped weights trained on the train split only) x seeds 0, 1, 2 = 618
clip-views, each a static "paper" camera with lifter-like noise
(``make_pairs(..., camera="static", noise=LifterNoise())``), rectified in sequence mode from
the poses alone (``rectify(joints, "pcnet", mode="sequence", camera_prior=False)``, 200
bootstrap replicates): the pose evidence's own error, which is also the pose std of the
camera-prior posterior (:data:`pcnet.stages.temporal.POSE_EVIDENCE_SIGMA_DEG`).
Per axis, ``s_i = sqrt(max(e_i^2 - b_i^2, 0)) / Z`` (signed error ``e``, bootstrap half-width
``b``), and ``SIGMA_SYS_DEG`` is the conformal 95 % quantile of ``s_i``: the interval then
covers 95 % of those clip-views per axis. ``FRAME_TILT_95_DEG`` is the conformal 95 % quantile
of the per-frame tilt errors of the same clips (frame mode, a new camera per frame, lifter
noise). Coverage on held-out data (the motion-style test split, DeepMimic, real Pose2Sim
cameras) is in the results file.

A lying reading of the camera-prior posterior (:mod:`pcnet.stages.gravity_prior`) reports
the posterior's own interval instead.

Scope: the constants were calibrated for the ``pcnet`` method with the shipped weights on
lifter-like inputs; other methods get the same widening without their own calibration.
"""
from __future__ import annotations

import numpy as np

#: Normal quantile of a two-sided 95 % interval.
Z = 1.96

#: Per-axis systematic (per-clip) error of the sequence up, degrees; see the module docstring.
SIGMA_SYS_DEG = {"pitch": 3.46, "roll": 1.15}

#: Per-frame tilt error (deg) that 95 % of frames stay within: conformal 95 % quantile of the
#: shipped weights' per-frame tilt errors on the calibration split (frame mode, lifter-like
#: noise, a new camera per frame); see ``benchmarks/results/uncertainty.txt``.
FRAME_TILT_95_DEG = 7.82

#: What the interval is, for printed summaries.
LABEL = "95 % interval incl. the lifter's systematic error, calibrated on held-out mocap"


def calibrated_interval(boot_half_deg, axis: str, sigma_sys_deg: float | None = None):
    """Half-width (degrees) of the calibrated 95 % interval of the camera ``axis``
    (``"pitch"`` or ``"roll"``): ``sqrt(boot_half_deg^2 + (Z * sigma)^2)``, with ``sigma``
    = :data:`SIGMA_SYS_DEG` ``[axis]`` unless ``sigma_sys_deg`` is given.

    Args:
        boot_half_deg: the moving-block bootstrap's 95 % half-width(s), degrees (scalar or
            array; NaN stays NaN: no bootstrap, no interval).
        axis: ``"pitch"`` or ``"roll"``.
        sigma_sys_deg: override of the systematic error (for calibration scripts).

    Returns:
        float for a scalar input, else an array of the input's shape; always
        ``>= boot_half_deg`` and increasing in it.

    Raises:
        ValueError: unknown axis.
    """
    if axis not in SIGMA_SYS_DEG:
        raise ValueError(f"axis: expected one of {tuple(SIGMA_SYS_DEG)}, got {axis!r}")
    sigma = SIGMA_SYS_DEG[axis] if sigma_sys_deg is None else float(sigma_sys_deg)
    b = np.asarray(boot_half_deg, np.float64)
    half = np.sqrt(b ** 2 + (Z * sigma) ** 2)
    return float(half) if half.ndim == 0 else half
