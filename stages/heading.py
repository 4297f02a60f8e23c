"""Heading from the hip line: the canonical frame's own definition of heading.

``docs/CONVENTIONS.md`` defines canonical +Z as the horizontal part of ``right_hip - left_hip``.
Once the up direction is known, the heading is therefore a function of the input's hips,
not something to estimate. 3DPCNet (paper section 2.1) predicts the whole rotation, so its
heading carries the network's error (about 1.7 deg mean on clean mocap) although the hips
in a clean input give it exactly. With a monocular lifter's hips the opposite holds: their
jitter and depth error (tens of millimetres over a ~0.25 m hip width) make the hip line far
worse than the network, which reads heading from the whole body.

This stage keeps a rotation's up (column 1) and replaces its heading by the hip line's when
asked (``"hips"``), keeps it (``"predicted"``), or decides per sequence (``"auto"``) from how
precise the hip joints are: the pelvis is rigid, so the distance between the hips is constant
in a real body and its frame-to-frame variation measures the hip joints' noise. A relative
variation (coefficient of variation, CV) ``c`` means about ``c`` radians of noise on the hip
line's direction; "auto" uses the hips when ``c <= 1 %`` (about 0.6 deg, half the network's
median heading error on clean mocap).

Shapes and frames: ``R`` ``(T, 3, 3)`` canonical->camera (``x_cam = R @ x_canon``); joints
``(T, 17, 3)`` H36M-17, camera frame (OpenCV axes), any length unit; angles in degrees.
"""

from __future__ import annotations

import numpy as np

from .core.canonical import canonical_rotation
from .core.conventions import L_HIP, R_HIP, check_poses
from .core.errors import InputError
from .rectification_report import HeadingChoice

HEADING_SOURCES = ("auto", "predicted", "hips")

#: Largest hip-width coefficient of variation (percent) for which "auto" trusts the hips:
#: fitted on validation clips under lifter noise of several sizes (the least mean heading error
#: of the choice; decision 0085), by ``python -m benchmarks.fit_heading_source --data
#: ../shared/data`` (``benchmarks/results/fit_heading_source.txt``; tests/test_heading.py checks
#: the two agree). Where real lifter files fall: ``python -m benchmarks.heading_source``.
AUTO_MAX_HIP_WIDTH_CV_PERCENT = 1.2037
#: Fewest valid frames from which "auto" reads the CV (fewer: the prediction): a lifter's errors
#: are correlated in time, so a few frames' width varies little even on noisy hips. Fitted on the
#: same validation recordings cut to their first 2-30 frames (the least mean heading error;
#: decision 0088) by the same command; tests/test_heading.py checks the two agree.
AUTO_MIN_FRAMES = 8


def precise_hips(joints_cam: np.ndarray, valid: np.ndarray, max_cv_percent: float = AUTO_MAX_HIP_WIDTH_CV_PERCENT):
    """``(precise, cv)``: whether a recording's hips are mocap-precise, i.e. it has at least
    :data:`AUTO_MIN_FRAMES` valid frames and a :func:`hip_width_cv_percent` of at most
    ``max_cv_percent`` (the pelvis is rigid, so its width should not change), and that CV.

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 poses, any frame and length unit.
        valid: ``(T,)`` bool.
        max_cv_percent: the largest hip-width coefficient of variation, percent.

    Returns:
        ``(bool, float)``: precise or not, and the CV in percent (NaN with fewer than 2
        frames having both hips).

    Raises:
        ValueError: wrong joint shape.
    """
    cv = hip_width_cv_percent(joints_cam, valid)
    return bool(np.asarray(valid, bool).sum() >= AUTO_MIN_FRAMES and cv <= max_cv_percent), cv


def hip_width_cv_percent(joints_cam: np.ndarray, valid: np.ndarray | None = None) -> float:
    """Coefficient of variation (std / mean, percent) of the hip width
    ``|right_hip - left_hip|`` over the valid frames of ``(T, 17, 3)`` poses: 0 for a rigid
    pelvis (mocap), large for noisy hip joints. NaN with fewer than 2 frames having both hips.

    Raises:
        ValueError: wrong joint shape.
    """
    X = check_poses(joints_cam, "joints_cam")
    width = np.linalg.norm(np.asarray(X[:, R_HIP], np.float64) - np.asarray(X[:, L_HIP], np.float64), axis=-1)
    keep = np.isfinite(width) & (True if valid is None else np.asarray(valid, bool))
    if keep.sum() < 2 or not width[keep].mean() > 0:
        return float("nan")
    return float(100.0 * width[keep].std() / width[keep].mean())


def hip_line_rotations(joints_cam: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations with the up of ``R`` and the heading of the input's hip line.

    Column 1 (up) is kept; +Z becomes the normalised horizontal part of
    ``right_hip - left_hip`` and +X = Y x Z (``docs/CONVENTIONS.md``, canonical frame), via
    :func:`pcnet.stages.core.canonical.canonical_rotation`.

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 camera-frame poses, any unit.
        R: ``(T, 3, 3)`` canonical->camera rotations (NaN rows allowed).

    Returns:
        ``(R_hips (T, 3, 3) float64, ok (T,) bool)``; NaN where a hip is missing, ``R`` is
        NaN, or the hip line is within 5.7 deg of the up axis (heading undefined).

    Raises:
        ValueError: wrong joint shape, or ``R`` not ``(T, 3, 3)`` for the same ``T``.
    """
    X = check_poses(joints_cam, "joints_cam")
    R = np.asarray(R, np.float64)
    if R.shape != (len(X), 3, 3):
        raise InputError(f"R: expected shape ({len(X)}, 3, 3), got {R.shape}")
    return canonical_rotation(X, R[:, :, 1])


def heading_difference_deg(R: np.ndarray, R_other: np.ndarray) -> np.ndarray:
    """Signed angle ``(T,)`` in degrees, in (-180, 180], from the anterior axis ``R[:, :, 0]``
    to ``R_other[:, :, 0]`` about the shared up ``R[:, :, 1]`` (right-hand rule). Both
    rotations must share their up column; NaN where either is NaN."""
    a, b, up = R[:, :, 0], R_other[:, :, 0], R[:, :, 1]
    return np.degrees(np.arctan2(np.sum(up * np.cross(a, b), -1), np.sum(a * b, -1)))


def apply_heading(
    joints_cam: np.ndarray,
    R: np.ndarray,
    valid: np.ndarray,
    source: str = "auto",
    max_cv_percent: float = AUTO_MAX_HIP_WIDTH_CV_PERCENT,
) -> tuple[np.ndarray, HeadingChoice]:
    """Choose where a sequence's heading comes from; the up directions are never changed.

    ``"predicted"`` returns ``R``; ``"hips"`` takes the heading of the hip line in every
    frame where it is defined (other valid frames keep ``R``, counted in the report);
    ``"auto"`` does the same as ``"hips"`` when the sequence has at least
    :data:`AUTO_MIN_FRAMES` valid frames and its :func:`hip_width_cv_percent` is at most
    ``max_cv_percent``, else ``"predicted"``. Pass one recording at a time (one subject,
    one lifter): the statistic assumes one pelvis.

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 camera-frame poses, any unit.
        R: ``(T, 3, 3)`` canonical->camera rotations (any estimator, any rectify mode).
        valid: ``(T,)`` bool, frames with a rotation.
        source: one of :data:`HEADING_SOURCES`.
        max_cv_percent: the ``"auto"`` threshold (percent).

    Returns:
        ``(rotations (T, 3, 3) float64, choice)``: the
        :class:`~pcnet.stages.rectification_report.HeadingChoice` (the source used,
        ``"predicted"`` or ``"hips"``, and its statistics).

    Raises:
        ValueError: unknown ``source`` or mismatched shapes.
    """
    if source not in HEADING_SOURCES:
        raise InputError(f"unknown heading source {source!r}; expected one of {HEADING_SOURCES}")
    R = np.asarray(R, np.float64)
    valid = np.asarray(valid, bool)
    precise, cv = precise_hips(joints_cam, valid, max_cv_percent)
    R_hips, ok = hip_line_rotations(joints_cam, R)
    ok &= valid
    difference = float(np.median(np.abs(heading_difference_deg(R[ok], R_hips[ok])))) if ok.any() else float("nan")
    used = ("hips" if precise else "predicted") if source == "auto" else source
    choice = HeadingChoice(used, source, cv, difference, int((valid & ~ok).sum()) if used == "hips" else 0)
    if used == "predicted":
        return R, choice
    return np.where(ok[:, None, None], R_hips, R), choice
