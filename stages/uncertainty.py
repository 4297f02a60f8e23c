"""Calibrated up uncertainty: camera pitch/roll intervals for sequence mode (static camera)
and a per-frame tilt bound.

The moving-block bootstrap of :func:`pcnet.stages.temporal.sequence_rectify` measures only how
much the frames of one recording disagree. A monocular lifter's error persists over a whole
clip (:mod:`pcnet.models.lifter_noise`) and moves every frame's up the same way, so the
bootstrap alone is far too narrow (on the held-out motion-style test clips it contained
the true pitch in 26 % of clips and the roll in 39 %, on the real Pose2Sim cameras in none). The interval here adds a
per-axis systematic error measured on data the shipped weights never trained on:

    half = sqrt(bootstrap_half^2 + (Z * SIGMA_SYS_DEG[axis])^2)

Provenance of the constants (``benchmarks/results/uncertainty.txt``, made by
``python -m benchmarks.calibrate_uncertainty --data ../shared/data``, 2026-11-22; re-run
with the shipped view-gate rule on 2026-11-23: the same constants; re-run with the sequence up
weighted by the per-frame bound on 2026-11-23: pitch 3.46 -> 3.44, roll
1.15 -> 1.12 (that weighting was deleted on 2026-11-26, docs/decisions/0035-ablation-deletions.md:
no effect on held-out data); re-run with errors divided by each clip-view's :func:`evidence_scale` on
2026-11-24: pitch 3.18, roll 1.02; re-run for the posture-augmented release's weights on
2026-11-24: pitch 3.24, roll 1.34; re-run for release 5's camera-frame network on 2026-11-26:
pitch 3.15, roll 1.41, but with the earlier ``FRAME_DISAGREEMENT_FACTOR`` 1.50 in force, which
sets :func:`evidence_scale`; re-run with the shipped 1.25 the same day: pitch 3.23, roll 1.44): the
motion-style *validation* split (Bandai validation groups and CMU validation subjects 12, 60,
206 clips; the shipped weights trained on the train split only) x seeds 0, 1, 2 = 618
clip-views, each a static "paper" camera with lifter-like noise
(``make_pairs(..., camera="static", noise=LifterNoise())``), rectified in sequence mode from
the poses alone (``rectify(joints, "pcnet", mode="sequence", camera_prior=False)``, 200
bootstrap replicates): the pose evidence's own error, which is also the pose std of the
camera-prior posterior (:data:`pcnet.stages.temporal.POSE_EVIDENCE_SIGMA_DEG`).
Per axis, ``s_i = sqrt(max(e_i^2 - b_i^2, 0)) / (Z r_i)`` (signed error ``e``, bootstrap
half-width ``b``, ``r`` the clip-view's :func:`evidence_scale`: 1.04 median, 1.32 at most on
these clips), and ``SIGMA_SYS_DEG`` is the conformal 95 % quantile of ``s_i``: the interval
``sqrt(b^2 + (Z SIGMA_SYS_DEG r)^2)`` then covers 95 % of those clip-views per axis, and is
wider where the two networks disagree over the whole recording (a pose unlike the training
data; the real seated lotus files of ``benchmarks/yoga_physics.py`` reach ``r`` = 1.3-3.1).

Per frame (:func:`frame_tilt_bound`): the shipped pair runs two 3DPCNets, and where they
disagree the pose is unlike what they learnt (on DeepMimic the tenth of frames with the largest
disagreement hold most of the large errors). The bound is
``w sqrt(FRAME_TILT_95_DEG^2 + (FRAME_DISAGREEMENT_FACTOR d)^2) + (1 - w) FRAME_TILT_95_BODY_DEG``,
``d`` the angle between
the two networks' ups and ``w`` the camera-frame network's weight (a rolled camera, ``w = 0``,
puts the camera-frame network outside its views, so its disagreement says nothing about the
pose; there the body-frame network answers and its own bound ``FRAME_TILT_95_BODY_DEG``
applies, the conformal 95 % quantile of its per-frame tilt errors on the same clips, valid
under any camera roll because that network is rotation-equivariant). On the same calibration
clips (frame mode, a new camera per frame, lifter noise):
``FRAME_DISAGREEMENT_FACTOR`` is the smallest factor on a 0.25 grid whose bound covers 95 %
of the tenth of frames with the largest ``d`` (conditional coverage where the networks
disagree), and ``FRAME_TILT_95_DEG`` then the conformal 95 % quantile of
``sqrt(max(e^2 - (k d)^2, 0))``, both fitted on the calibration frames the camera-frame
network answers alone (``w = 1``: 34,962 of 34,967 with the shipped gate), so the bound
covers 95 % of them.
Coverage on held-out data (the motion-style test split, DeepMimic, real Pose2Sim cameras) is
in ``benchmarks/results/frame_bound.txt`` (``python -m benchmarks.calibrate_frame_bound --data
../shared/data``) and ``benchmarks/results/uncertainty.txt`` (sequence intervals).

A body on the floor under a level camera (crawling, lying, getting up) reads to the body-frame
network as a camera turned a quarter turn, and both networks then answer for an upright body
under a rolled camera, agreeing with each other, so ``d`` cannot widen the bound there (release
5.1 widened the reported bound on those frames with the camera-frame network's reading of the
unturned poses; deleted on 2026-11-26, docs/decisions/0035-ablation-deletions.md: the bound's
coverage barely moved on held-out data).

A lying reading of the camera-prior posterior (:mod:`pcnet.stages.gravity_prior`) reports
the posterior's own interval instead. Where the reading not reported keeps at least
:data:`pcnet.stages.gravity_prior.OTHER_READING_P` (5 %) of that posterior, each half-width is
at least the posterior's 95 % half-width over both readings: a region holding 95 % must hold
some of it (stages/rectify.py; docs/experiments.md, "A 95 % interval that reaches the other
reading").

Scope: the constants were calibrated for the ``pcnet`` method with the shipped weights on
held-out mocap with simulated lifter-like noise (:mod:`pcnet.models.lifter_noise`, the noise
model the networks trained with); other methods get no calibrated interval (their sequence up
reports its bootstrap). The intervals are per axis (pitch, roll): both hold together in about
90 % of recordings. Real lifters' per-recording errors can be larger: on the four real
Pose2Sim cameras the roll interval missed two (README, "Targets").
"""
from __future__ import annotations

import numpy as np

#: Normal quantile of a two-sided 95 % interval.
Z = 1.96

#: Per-axis systematic (per-clip) error of the sequence up, degrees; see the module docstring.
SIGMA_SYS_DEG = {"pitch": 3.23, "roll": 1.44}

#: Per-frame tilt bound (deg) where the two networks agree: the base of :func:`frame_tilt_bound`
#: (module docstring; ``python -m benchmarks.calibrate_frame_bound --data ../shared/data``,
#: ``benchmarks/results/frame_bound.txt``).
FRAME_TILT_95_DEG = 7.40
#: How much of the two networks' disagreement (deg) is added to the per-frame bound.
FRAME_DISAGREEMENT_FACTOR = 1.25
#: Per-frame tilt bound (deg) of the body-frame network alone, which answers where the view gate
#: sets the camera-frame network aside (``w = 0``: a rolled camera, a body across the image).
FRAME_TILT_95_BODY_DEG = 9.03

#: Evidence scale above which the run summary says the poses are unlike the training data:
#: beyond every calibration clip-view's (1.32 at most, ``benchmarks/results/uncertainty.txt``).
UNFAMILIAR_EVIDENCE_SCALE = 1.5

#: What the interval is, for printed summaries.
LABEL = ("95 % interval per axis incl. the lifter's systematic error, calibrated on held-out mocap with simulated "
         "lifter noise")


def calibrated_interval(boot_half_deg, axis: str, sigma_sys_deg: float | None = None, scale=1.0):
    """Half-width (degrees) of the calibrated 95 % interval of the camera ``axis``
    (``"pitch"`` or ``"roll"``): ``sqrt(boot_half_deg^2 + (Z * sigma * scale)^2)``, with
    ``sigma`` = :data:`SIGMA_SYS_DEG` ``[axis]`` unless ``sigma_sys_deg`` is given and
    ``scale`` the recording's :func:`evidence_scale`.

    Args:
        boot_half_deg: the moving-block bootstrap's 95 % half-width(s), degrees (scalar or
            array; NaN stays NaN: no bootstrap, no interval).
        axis: ``"pitch"`` or ``"roll"``.
        sigma_sys_deg: override of the systematic error (for calibration scripts).
        scale: :func:`evidence_scale` of the recording(s), >= 0 (scalar or array
            broadcasting with ``boot_half_deg``); 1 = the calibration set's typical pose.

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
    half = np.sqrt(b ** 2 + (Z * sigma * np.asarray(scale, np.float64)) ** 2)
    return float(half) if half.ndim == 0 else half


def evidence_scale(bound_deg, base_deg: float = FRAME_TILT_95_DEG) -> float:
    """How much less certain a recording's pose evidence is than on the poses the
    calibration saw, as a factor on the systematic error of its sequence up:
    ``r = sum_t w_t (b_t / base) / sum_t w_t`` with inverse-variance weights
    ``w_t = (base / b_t)^2`` (:func:`bound_weights`), i.e. the mean per-frame bound
    :func:`frame_tilt_bound` ``b_t`` relative to ``base``, each frame weighed by its precision
    (sequence mode's up weighs its frames equally). Where the two networks agree ``r`` is 1; a recording of poses unlike the training
    data (the networks disagree on every frame) gets ``r`` > 1, and since one static pose
    errs the same way in every frame, its sequence error grows with the per-frame one rather
    than averaging out. ``SIGMA_SYS_DEG`` is calibrated on errors divided by ``r``
    (normalised non-conformity scores: Papadopoulos, Gammerman and Vovk, "Normalized
    nonconformity measures for regression conformal prediction", AIA 2008; Lei et al.,
    "Distribution-free predictive inference for regression", JASA 2018, section 5.2), so the
    interval stays a 95 % one while widening where the poses are unfamiliar.

    Args:
        bound_deg: ``(T,)`` per-frame bounds, degrees (NaN = invalid frame).
        base_deg: the bound where the networks agree; NaN (an uncalibrated method) gives 1.

    Returns:
        ``r`` >= 0 as a float; 1.0 when no frame has a finite positive bound.
    """
    w = bound_weights(bound_deg, base_deg) if np.isfinite(base_deg) else np.zeros(0)
    if not (w > 0).any():
        return 1.0
    return float(np.sum(np.sqrt(w)) / np.sum(w))


def frame_tilt_bound(disagreement_deg, camera_frame_weight, base_deg: float = FRAME_TILT_95_DEG,
                     factor: float = FRAME_DISAGREEMENT_FACTOR, body_deg: float = FRAME_TILT_95_BODY_DEG) -> np.ndarray:
    """Per-frame 95 % bound on the tilt error of the shipped pair's up, degrees:
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


def bound_weights(bound_deg, base_deg: float = FRAME_TILT_95_DEG) -> np.ndarray:
    """Per-frame weights of :func:`evidence_scale`'s mean from the per-frame tilt bound:
    ``(base_deg / bound)^2``, inverse variance when the bound is proportional to each frame's
    error std, so frames where the two networks disagree (poses unlike the training data)
    count less; 0 where the bound is not finite (invalid frames).

    Args:
        bound_deg: ``(T,)`` :func:`frame_tilt_bound`, degrees (NaN = invalid frame).
        base_deg: the bound where the networks agree (:data:`FRAME_TILT_95_DEG`); weight 1 there.

    Returns:
        ``(T,)`` float64 weights in ``[0, (base_deg / min bound)^2]``.
    """
    b = np.asarray(bound_deg, np.float64)
    ok = np.isfinite(b) & (b > 0)
    return np.where(ok, (base_deg / np.where(ok, b, 1.0)) ** 2, 0.0)
