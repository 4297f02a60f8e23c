"""Kinematics of canonical poses: low-pass filtering, derivatives and plane-decomposed
joint angles.

The angles here are projections onto the planes of the canonical frame
(``docs/CONVENTIONS.md``: +X anterior, +Y up, +Z the subject's right, pelvis origin), so they
depend on that frame: in the camera frame "sagittal" would mean "the image's x-z plane"
and a camera tilt would read as trunk lean. That is why pcnet rectifies first.

Frame and smooth modes place each frame with its own rotation: :func:`compute_kinematics`'s
``rotation`` low-passes the camera-frame poses and the rotations apart (:func:`lowpass_rotations`)
and then composes them, so that the rotations' frame-to-frame noise never reaches the angles
between segments (decision 0102).

NaN policy: NaN never turns into a number. Filters and derivatives work on each
contiguous run of finite samples separately and never bridge a gap. Derivatives are
central differences only, so the first and last sample of every run (the recording's
ends and both sides of a gap) and samples the filter had to leave raw get no velocity or
acceleration (NaN) rather than a one-sided or noise-amplified estimate; the per-joint
flags :attr:`Kinematics.missing` / :attr:`Kinematics.unfiltered` and
:func:`flag_counts` say where and how often that happened.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType
from typing import Iterable, Iterator, Literal, Mapping

import numpy as np
from scipy.signal import butter, sos2zpk, sosfiltfilt

from .core.conventions import (
    H36M_JOINTS,
    L_ANKLE,
    L_ELBOW,
    L_HIP,
    L_KNEE,
    L_SHOULDER,
    L_WRIST,
    METRES_PER_LENGTH_UNIT,
    PELVIS,
    R_ANKLE,
    R_ELBOW,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_WRIST,
    REFUSED_THIGH_M,
    THIGH_RANGE_M,
    THORAX,
    UNSCALED_UNITS,
    check_poses,
    fill_pelvis_from_hips,
    thigh_beyond_metres,
    validate_fps,
)
from .core.canonical import canonical_rotation, to_canonical
from .isb_angles import MAX_KNEE_HYPEREXTENSION_DEG, isb_joint_angles
from .core.rotations import angle_between, procrustes_rotation
from .core.errors import InputError
from .core.framestore import arrays_repr, frame_blocks, freeze_arrays, restore_frozen, true_runs

# ---------------------------------------------------------------------------------------
# contiguous finite runs


def _by_mask(x2: np.ndarray):
    """Group the columns of ``x2`` ``(T, C)`` by their finite-sample pattern.

    Yields ``(columns, runs)``; columns sharing a pattern (the x, y, z of a joint, or
    every column of a gap-free sequence) are processed together, which keeps a
    36,000 x 51 array at a handful of vectorised calls.
    """
    finite = np.isfinite(x2)
    # Keyed on the packed bytes of each column: np.unique(axis=0) sorts and is ~10x slower.
    packed = np.packbits(finite, axis=0)
    groups: dict[bytes, list[int]] = {}
    for c in range(x2.shape[1]):
        groups.setdefault(packed[:, c].tobytes(), []).append(c)
    for cols in groups.values():
        yield np.asarray(cols), true_runs(finite[:, cols[0]])


def _as_2d(x: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 0:
        raise InputError("expected an array with time on axis 0, got a scalar")
    if x.shape[0] == 0:
        raise InputError(f"expected at least one sample on axis 0, got shape {x.shape}")
    return x.reshape(x.shape[0], -1), x.shape


# ---------------------------------------------------------------------------------------
# filtering


def _design_cutoff(fps: float, cutoff_hz: float, passes: int, order_per_pass: int) -> float:
    """Cutoff to design each pass with so that the multi-pass filter is -3 dB at
    ``cutoff_hz`` (Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed.,
    2009, ch. 3, cutoff correction for multiple-pass filters; generalised to order ``p``
    per pass:
    ``C = (2^(1/n) - 1)^(1/(2p))``, applied to the pre-warped digital frequency
    ``tan(pi f / fs)``)."""
    C = (2.0 ** (1.0 / passes) - 1.0) ** (1.0 / (2 * order_per_pass))
    warped = np.tan(np.pi * cutoff_hz / fps) / C
    return float(fps / np.pi * np.arctan(warped))


def _lowpass_design(fps: float, cutoff_hz: float, order: int) -> tuple[np.ndarray, int]:
    """(second-order sections of one pass, ``sosfiltfilt``'s default ``padlen``), after the
    argument checks of :func:`butterworth_lowpass`."""
    fps = validate_fps(fps, "fps")
    if isinstance(cutoff_hz, (bool, np.bool_)) or not isinstance(cutoff_hz, (int, float, np.integer, np.floating)):
        raise InputError(f"cutoff_hz: expected a number of Hz in (0, fps/2) = (0, {fps / 2:g}), got "
                         f"{type(cutoff_hz).__name__} {cutoff_hz!r}"[:300])
    if not 0 < cutoff_hz < fps / 2:
        raise InputError(
            f"cutoff_hz must lie in (0, fps/2) = (0, {fps / 2:g}) Hz (Nyquist), got {cutoff_hz!r}"
        )
    if not isinstance(order, (int, np.integer)) or isinstance(order, bool) or order < 2 or order % 2:
        raise InputError(
            f"order is the order of the zero-phase (dual-pass) result and must be an even integer "
            f">= 2, got {type(order).__name__} {order!r}"[:300]
        )
    per_pass = order // 2
    design = _design_cutoff(fps, cutoff_hz, passes=2, order_per_pass=per_pass)
    sos = butter(per_pass, design, btype="low", fs=fps, output="sos")
    # sosfiltfilt's own default padlen, so "too short" means what scipy means.
    padlen = 3 * (2 * len(sos) + 1 - min((sos[:, 2] == 0).sum(), (sos[:, 5] == 0).sum()))
    return sos, int(padlen)


#: The low-pass's order as applied: a 2nd-order Butterworth run forward and backward (zero
#: lag), its cutoff corrected so that the pair is -3 dB there (:func:`_design_cutoff`, Winter's
#: correction for multiple passes): the "4th-order zero-lag Butterworth" of gait analysis,
#: every pcnet filter's default.
FILTER_ORDER = 4


def shortest_filtered_run(fps: float, cutoff_hz: float, order: int = FILTER_ORDER) -> int:
    """Frames of the shortest run of present samples :func:`butterworth_lowpass` filters
    (``sosfiltfilt``'s ``padlen`` + 1); shorter runs stay raw and are flagged ``unfiltered``.

    Raises:
        InputError: as :func:`butterworth_lowpass`'s arguments.
    """
    return _lowpass_design(fps, cutoff_hz, order)[1] + 1


def butterworth_lowpass(
    x: np.ndarray,
    fps: float,
    cutoff_hz: float = 6.0,
    order: int = FILTER_ORDER,
    *,
    return_unfiltered: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Zero-phase Butterworth low-pass filter along axis 0, NaN-gap aware.

    **Order convention** (the biomechanics one, Winter 2009 ch. 3): ``order`` is
    the order of the final zero-phase filter. Each pass of ``scipy.signal.sosfiltfilt`` is
    a Butterworth of ``order // 2`` (default 2), and the forward plus backward pass
    doubles it, so ``order=4`` is the "4th-order zero-lag Butterworth" of the gait
    literature. The per-pass cutoff is corrected (Winter's ``C = 0.802`` for two passes
    of a 2nd-order filter, see :func:`_design_cutoff`) so that the **final** response is
    -3 dB (gain 1/sqrt(2)) at ``cutoff_hz``, not the -6 dB an uncorrected dual pass gives.

    **Gaps**: each contiguous run of finite samples of each channel is filtered on its
    own (edges padded by ``sosfiltfilt``'s default odd extension). Nothing is
    interpolated across a gap and NaN stays NaN. A run no longer than the filter's
    ``padlen`` cannot be filtered: it is returned unchanged and flagged.

    Args:
        x: ``(T, ...)`` samples along axis 0 (e.g. ``(T, 17, 3)`` positions), any units.
        fps: sampling rate in Hz (> 0).
        cutoff_hz: -3 dB frequency of the final filter in Hz; 6 Hz is a common choice
            for human movement (Winter 2009).
        order: even order of the final zero-phase filter (>= 2).
        return_unfiltered: also return the flag array.

    Returns:
        float64 array shaped like ``x``; with ``return_unfiltered=True`` also a bool array
        shaped like ``x``, True where a finite sample was left unfiltered because its run
        was too short.

    Raises:
        ValueError: ``fps`` not a frame rate (:func:`~pcnet.stages.core.conventions.validate_fps`), no
            sample, ``cutoff_hz`` not in ``(0, fps/2)``, or ``order`` odd
            or < 2.
    """
    sos, padlen = _lowpass_design(fps, cutoff_hz, order)

    x2, shape = _as_2d(x)
    out = np.full_like(x2, np.nan)
    unfiltered = np.zeros(x2.shape, dtype=bool)
    for cols, runs in _by_mask(x2):
        for a, b in runs:
            seg = x2[a:b][:, cols]
            if b - a <= padlen:
                out[a:b, cols] = seg
                unfiltered[a:b, cols] = True
            else:
                out[a:b, cols] = sosfiltfilt(sos, seg, axis=0)
    out = out.reshape(shape)
    if return_unfiltered:
        return out, unfiltered.reshape(shape)
    return out


#: Band of the Nyquist frequency over which the residual is taken as noise and fitted by a
#: line (:func:`residual_analysis`).
RESIDUAL_FIT_BAND = (0.5, 0.9)


@dataclass(frozen=True, eq=False)
class ResidualAnalysis:
    """Winter's residual analysis of a recording (:func:`residual_analysis`).

    Attributes:
        cutoff_hz: the recording's cutoff, the median of ``per_signal_hz``.
        per_signal_hz: ``(C,)`` cutoff of each signal (NaN: too short or constant).
        frequencies_hz: ``(F,)`` cutoffs tried.
        residual: ``(F,)`` median over signals of the RMS residual, input units.
        noise: median over signals of the fitted noise level (the line's intercept).
    """

    cutoff_hz: float
    per_signal_hz: np.ndarray
    frequencies_hz: np.ndarray
    residual: np.ndarray
    noise: float


def residual_analysis(x: np.ndarray, fps: float, order: int = FILTER_ORDER, n_frequencies: int = 40) -> ResidualAnalysis:
    """The low-pass cutoff by Winter's residual analysis (Winter, *Biomechanics and Motor
    Control of Human Movement*, 4th ed., 2009, sec. 3.4.4.3), per signal.

    For cutoffs ``f`` from 0.5 Hz to 0.95 x Nyquist, the RMS residual ``R(f)`` between a
    signal and its :func:`butterworth_lowpass` (same ``order``) is computed over its filtered
    samples. Where only noise is removed, ``R(f)`` falls as a straight line to 0 at the Nyquist
    frequency; the line fitted over :data:`RESIDUAL_FIT_BAND` of Nyquist meets ``f = 0`` at
    the noise level ``a``, and the cutoff is the lowest ``f`` with ``R(f) <= a``: below it the
    filter would remove signal as well as noise. Each signal (a joint's x, y or z) gets its
    own cutoff; the recording's is their median (one filter for all joints keeps joint angles
    consistent).

    Args:
        x: ``(T, ...)`` samples along axis 0 (e.g. ``(T, 17, 3)`` positions), NaN = missing.
        fps: sampling rate in Hz.
        order: order of the zero-phase filter, as :func:`butterworth_lowpass`.
        n_frequencies: cutoffs tried.

    Returns:
        :class:`ResidualAnalysis`.

    Raises:
        InputError: ``fps`` not a frame rate (:func:`~pcnet.stages.core.conventions.validate_fps`),
            or no signal long enough to filter (more than the filter's pad length of finite
            samples in a run).
    """
    fps = validate_fps(fps, "fps")
    x2, _ = _as_2d(x)
    nyquist = fps / 2
    freqs = np.linspace(0.5, 0.95 * nyquist, n_frequencies)
    residual = np.full((len(freqs), x2.shape[1]), np.nan)
    for i, f in enumerate(freqs):
        smooth, raw = butterworth_lowpass(x2, fps, float(f), order, return_unfiltered=True)
        diff = np.where(raw, np.nan, x2 - smooth)
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN signals stay NaN
            residual[i] = np.sqrt(np.nanmean(diff**2, axis=0))
    band = (freqs >= RESIDUAL_FIT_BAND[0] * nyquist) & (freqs <= RESIDUAL_FIT_BAND[1] * nyquist)
    per_signal = np.full(x2.shape[1], np.nan)
    noise = np.full(x2.shape[1], np.nan)
    for c in range(x2.shape[1]):
        r = residual[:, c]
        if not np.isfinite(r).all() or not r[0] > 0:
            continue
        slope, intercept = np.polyfit(freqs[band], r[band], 1)
        below = np.flatnonzero(r <= intercept)
        noise[c] = intercept
        per_signal[c] = freqs[below[0]] if len(below) else freqs[-1]
    if not np.isfinite(per_signal).any():
        raise InputError("residual analysis: no signal has a run of finite samples long enough to filter")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        curve = np.nanmedian(residual, axis=1)
    return ResidualAnalysis(float(np.nanmedian(per_signal)), per_signal, freqs, curve, float(np.nanmedian(noise)))


# ---------------------------------------------------------------------------------------
# derivatives


def derivatives(
    x: np.ndarray, fps: float, *, edges: Literal["nan", "one-sided"] = "nan"
) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration by finite differences along axis 0, within finite runs.

    Inside a run of finite samples: the central first difference
    ``v[i] = (x[i+1] - x[i-1]) / (2 dt)`` and the central second difference
    ``a[i] = (x[i+1] - 2 x[i] + x[i-1]) / dt^2`` (the finite differences of Winter,
    *Biomechanics and Motor Control of Human Movement*, 4th ed., 2009, ch. 3). Both are
    exact for quadratic trajectories.

    **Run edges** (``edges="nan"``, the default): the central stencil needs both
    neighbours, so the first and last sample of every finite run (the recording's first
    and last frame and each sample next to a gap) get NaN velocity and acceleration, as
    do runs shorter than three samples. Why not one-sided differences: they are a
    different, noisier estimator (the second-order one-sided velocity
    ``(-3 x0 + 4 x1 - x2) / (2 dt)`` has 13x the white-noise variance of the central one:
    ``(9 + 16 + 1) / 4`` vs ``(1 + 1) / 4``), applied exactly where the data are worst: the
    zero-phase filter of :func:`butterworth_lowpass` pads a run by odd reflection about its
    end sample, so that sample comes out with its raw noise unchanged. Winter (2009,
    ch. 3) differentiates with these central differences and therefore has no derivative
    at the first and last data point; the same holds at every gap here. Which samples are
    blank follows from the positions' NaN pattern alone.

    ``edges="one-sided"`` restores the older behaviour: ``numpy.gradient`` with
    second-order one-sided velocity at run ends (forward difference for a two-sample
    run) and each run end's acceleration copied from its neighbour.

    Args:
        x: ``(T, ...)`` samples, any units ``u``; NaN = missing.
        fps: sampling rate in Hz (> 0).
        edges: ``"nan"`` (default) or ``"one-sided"``, see above.

    Returns:
        ``(velocity, acceleration)`` float64 shaped like ``x``, in ``u/s`` and ``u/s^2``;
        NaN wherever the stencil is incomplete.

    Raises:
        ValueError: ``fps`` not a frame rate (:func:`~pcnet.stages.core.conventions.validate_fps`), no
            sample, or an unknown ``edges``.
    """
    fps = validate_fps(fps, "fps")
    if edges not in ("nan", "one-sided"):
        raise InputError(f"edges must be 'nan' or 'one-sided', got {edges!r}")
    dt = 1.0 / fps
    x2, shape = _as_2d(x)
    vel = np.full_like(x2, np.nan)
    acc = np.full_like(x2, np.nan)
    if edges == "nan":
        # NaN propagates through the stencils; only the velocity skips x[i] and needs it
        # masked, so a lone missing sample between two finite ones stays missing.
        centre = x2[1:-1]
        vel[1:-1] = np.where(np.isfinite(centre), (x2[2:] - x2[:-2]) / (2.0 * dt), np.nan)
        acc[1:-1] = (x2[2:] - 2.0 * centre + x2[:-2]) / dt**2
        return vel.reshape(shape), acc.reshape(shape)
    for cols, runs in _by_mask(x2):
        for a, b in runs:
            seg = x2[a:b][:, cols]
            n = b - a
            if n >= 2:
                vel[a:b, cols] = np.gradient(seg, dt, axis=0, edge_order=2 if n >= 3 else 1)
            if n >= 3:
                second = (seg[2:] - 2.0 * seg[1:-1] + seg[:-2]) / dt**2
                acc[a + 1 : b - 1, cols] = second
                acc[a, cols] = second[0]
                acc[b - 1, cols] = second[-1]
    return vel.reshape(shape), acc.reshape(shape)


# ---------------------------------------------------------------------------------------
# joint angles

#: A segment whose projection onto a plane is shorter than this fraction of its length
#: lies within 14.5 deg of the plane's normal: its in-plane angle is undefined, so NaN.
MIN_PROJECTED_FRACTION = 0.25

# Canonical axes (docs/CONVENTIONS.md).
_X, _Y, _Z = 0, 1, 2


def _plane_angle(
    forward: np.ndarray, reference: np.ndarray, length: np.ndarray, wrap_below: float | None
) -> np.ndarray:
    """In-plane angle (deg) ``atan2(forward, reference)`` of a segment whose components
    along the plane's two axes are ``forward`` and ``reference`` ``(T,)``.

    With ``wrap_below`` set, angles <= it get +360 (limbs use -90: the range becomes
    (-90, 270], so flexion past overhead keeps increasing instead of jumping to -180).
    NaN where the in-plane projection is shorter than ``MIN_PROJECTED_FRACTION * length``.
    """
    ang = np.degrees(np.arctan2(forward, reference))
    if wrap_below is not None:
        ang = np.where(ang <= wrap_below, ang + 360.0, ang)
    proj = np.hypot(forward, reference)
    with np.errstate(invalid="ignore"):
        ok = (proj >= MIN_PROJECTED_FRACTION * length) & (length > 0)
    return np.where(ok, ang, np.nan)


def _limb_angle(X: np.ndarray, proximal: int, distal: int, axis: int, sign: float) -> np.ndarray:
    """Segment proximal->distal from straight down (-Y) towards ``sign * axis``."""
    v = X[:, distal] - X[:, proximal]
    return _plane_angle(sign * v[:, axis], -v[:, _Y], np.linalg.norm(v, axis=-1), -90.0)


def _inter_segment(X: np.ndarray, a: int, b: int, c: int) -> np.ndarray:
    """Flexion at ``b`` of the chain a-b-c: ``180 - angle(a-b, c-b)`` = angle between
    ``b - a`` and ``c - b``; 0 = straight."""
    return np.degrees(angle_between(X[:, b] - X[:, a], X[:, c] - X[:, b]))


_RIGHT, _LEFT = 1.0, -1.0

#: Names of :func:`joint_angles` outputs, in output order; all in degrees.
ANGLE_NAMES: tuple[str, ...] = (
    "trunk_inclination",
    "trunk_sagittal_inclination",
    "trunk_frontal_inclination",
    "left_thigh_sagittal_inclination",
    "right_thigh_sagittal_inclination",
    "left_thigh_frontal_inclination",
    "right_thigh_frontal_inclination",
    "left_knee_flexion_unsigned",
    "right_knee_flexion_unsigned",
    "left_upper_arm_sagittal_inclination",
    "right_upper_arm_sagittal_inclination",
    "left_upper_arm_frontal_inclination",
    "right_upper_arm_frontal_inclination",
    "left_elbow_flexion_unsigned",
    "right_elbow_flexion_unsigned",
)


def joint_angles(canonical: np.ndarray, heading_free: dict[str, np.ndarray] | None = None,
                 check_up: bool = True) -> dict[str, np.ndarray]:
    """Segment inclinations (plane projections of a segment against gravity) and the
    unsigned knee and elbow flexion of canonical poses, in degrees. Named for what they
    are, not as clinical joint angles: those, with ISB conventions, are
    :func:`pcnet.stages.isb_angles.isb_joint_angles`.

    Input frame: canonical (+X anterior, +Y up against gravity, +Z subject's right).
    "Sagittal plane" = X-Y, "frontal plane" = Z-Y. Segment angles are **absolute**
    (segment vs. gravity in the pelvis-heading frame; no pelvic tilt is removed), not
    the ISB joint coordinate system angles between two segment frames (Wu et al. 2002,
    2005), which H36M-17's joint centres cannot define (no marker sets a segment's
    axial rotation).

    * ``trunk_inclination``: angle between pelvis->thorax and +Y, in [0, 180];
      0 = upright, 90 = horizontal (lying), unsigned.
    * ``trunk_sagittal_inclination``: ``v = thorax - pelvis`` in the sagittal plane, angle from +Y
      ``atan2(v_x, v_y)`` in (-180, 180]: positive = leaning anterior, negative = back.
    * ``trunk_frontal_inclination``: the same in the frontal plane, ``atan2(v_z, v_y)``:
      positive = leaning towards the subject's right.
    * ``{side}_thigh_sagittal_inclination``: thigh ``v = knee - hip`` in the sagittal plane, angle from
      -Y (hanging straight down) ``atan2(v_x, -v_y)``: positive = flexion (knee in front
      of the hip), negative = extension; 90 = thigh horizontal forward.
    * ``{side}_thigh_frontal_inclination``: thigh in the frontal plane, ``atan2(s v_z, -v_y)`` with
      ``s = +1`` right, ``-1`` left (the Z axis points to the subject's right, so the
      sign is mirrored for the left side): positive = abduction (knee away from the
      midline), negative = adduction (crossing the midline).
    * ``{side}_upper_arm_sagittal_inclination`` / ``{side}_upper_arm_frontal_inclination``: the same two
      definitions for the upper arm ``v = elbow - shoulder``: 0 = arm hanging, 90 = arm
      horizontal forward / sideways, 180 = overhead.
    * ``{side}_knee_flexion_unsigned``: ``180 - angle(hip-knee-ankle)``, i.e. the angle between
      thigh and shank; 0 = straight, unsigned in [0, 180], frame-independent.
    * ``{side}_elbow_flexion_unsigned``: ``180 - angle(shoulder-elbow-wrist)``; 0 = straight.

    Limb plane angles are wrapped to (-90, 270] so that motion through overhead does not
    jump by 360. A segment whose projection onto the plane is shorter than
    :data:`MIN_PROJECTED_FRACTION` of its length (within 14.5 deg of the plane normal,
    e.g. the frontal-plane angle of a thigh pointing straight forward) gets NaN, as does
    any angle with a NaN joint.

    Args:
        canonical: ``(T, 17, 3)`` or ``(17, 3)`` H36M-17 canonical poses, any units.
        heading_free: :func:`heading_free_angles` already taken from the same poses in another
            Y-up frame (they do not depend on the heading, and need no hip line), used
            instead of computing them from ``canonical``.
        check_up: refuse poses whose trunk points down in most frames (:func:`require_y_up`:
            camera-frame poses, +Y down); False for a body inverted for most of the recording.

    Returns:
        dict ``name -> (T,)`` float64 degrees, keys in :data:`ANGLE_NAMES` order.

    Raises:
        ValueError: wrong shape, or ``heading_free`` arrays not ``(T,)`` like the poses.
        InputError (a ValueError): with ``check_up``, poses that are not Y-up.
    """
    X = check_poses(canonical, "canonical").astype(np.float64)
    if check_up:
        require_y_up(X, "canonical")
    if heading_free is not None:
        wrong = {k: np.shape(v) for k, v in heading_free.items() if np.shape(v) != (len(X),)}
        if wrong:
            name, shape = next(iter(wrong.items()))
            raise InputError(f"heading_free: expected ({len(X)},) arrays like canonical's frames, got {name} of "
                             f"shape {shape}")
    trunk = X[:, THORAX] - X[:, PELVIS]
    trunk_len = np.linalg.norm(trunk, axis=-1)
    out = {
        **(heading_free_angles(X) if heading_free is None else heading_free),
        "trunk_sagittal_inclination": _plane_angle(trunk[:, _X], trunk[:, _Y], trunk_len, None),
        "trunk_frontal_inclination": _plane_angle(trunk[:, _Z], trunk[:, _Y], trunk_len, None),
    }
    for side, s, hip, knee, sho, elb in (
        ("left", _LEFT, L_HIP, L_KNEE, L_SHOULDER, L_ELBOW),
        ("right", _RIGHT, R_HIP, R_KNEE, R_SHOULDER, R_ELBOW),
    ):
        out[f"{side}_thigh_sagittal_inclination"] = _limb_angle(X, hip, knee, _X, 1.0)
        out[f"{side}_thigh_frontal_inclination"] = _limb_angle(X, hip, knee, _Z, s)
        out[f"{side}_upper_arm_sagittal_inclination"] = _limb_angle(X, sho, elb, _X, 1.0)
        out[f"{side}_upper_arm_frontal_inclination"] = _limb_angle(X, sho, elb, _Z, s)
    return {name: out[name] for name in ANGLE_NAMES}


def heading_free_angles(poses: np.ndarray) -> dict[str, np.ndarray]:
    """The angles of :func:`joint_angles` that do not depend on the heading about +Y:
    ``trunk_inclination`` (from +Y) and the unsigned knee and elbow flexion, in degrees.

    They need no hip line, so they stay defined for a body lying on its side, whose hip
    line is vertical and leaves the pelvis-heading frame (and every plane inclination)
    undefined.

    Args:
        poses: ``(T, 17, 3)`` H36M-17 poses with +Y up (world or canonical frame), any units.

    Returns:
        dict ``name -> (T,)`` float64 degrees; NaN where a joint is missing.

    Raises:
        InputError (a ValueError): poses not ``(T, 17, 3)`` or ``(17, 3)``.
    """
    check_poses(poses, "poses")  # the shape; the values keep their precision
    X = np.asarray(poses, np.float64)
    X = X[None] if X.ndim == 2 else X
    out = {"trunk_inclination": np.degrees(angle_between(X[:, THORAX] - X[:, PELVIS], np.array([0.0, 1.0, 0.0])))}
    for side, hip, knee, ankle, sho, elb, wri in (
        ("left", L_HIP, L_KNEE, L_ANKLE, L_SHOULDER, L_ELBOW, L_WRIST),
        ("right", R_HIP, R_KNEE, R_ANKLE, R_SHOULDER, R_ELBOW, R_WRIST),
    ):
        out[f"{side}_knee_flexion_unsigned"] = _inter_segment(X, hip, knee, ankle)
        out[f"{side}_elbow_flexion_unsigned"] = _inter_segment(X, sho, elb, wri)
    return out


# ---------------------------------------------------------------------------------------
# continuity in time


#: Angles that are periodic (an ``atan2`` or the first/third angle of an Euler/Cardan
#: sequence, so they wrap by 360 deg) -> the lower end of the 360-deg range each run's median
#: is brought into: ``-180`` = (-180, 180]; ``-90`` = (-90, 270] for the upper-arm
#: inclinations, whose 180 (arm overhead) is common and must not read as -180. Names without
#: the ``_deg`` suffix, ``{side}`` = left / right. The unsigned angles (``*_unsigned``,
#: ``trunk_inclination``, ``shoulder_elevation``, elbow flexion) and the middle Cardan angles
#: (in [-90, 90]: adduction, lateral bending / tilt) cannot wrap and are left as they are.
PERIODIC_ANGLES: Mapping[str, float] = MappingProxyType({
    **{name: -180.0 for name in (
        "trunk_sagittal_inclination", "trunk_frontal_inclination",
        "trunk_flexion_to_pelvis", "trunk_axial_rotation_to_pelvis", "trunk_flexion_to_gravity")},
    **{f"{side}_{name}": level for side in ("left", "right") for name, level in (
        ("thigh_sagittal_inclination", -180.0), ("thigh_frontal_inclination", -180.0),
        ("upper_arm_sagittal_inclination", -90.0), ("upper_arm_frontal_inclination", -90.0),
        ("hip_flexion", -180.0), ("hip_internal_rotation", -180.0),
        ("shoulder_plane_of_elevation", -180.0), ("shoulder_axial_rotation", -180.0))},
})


def _wrap180(deg: np.ndarray) -> np.ndarray:
    return (deg + 180.0) % 360.0 - 180.0


def _knee_reading(rot: np.ndarray, knee: np.ndarray, previous: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    """Hip internal rotation and signed knee flexion of one side, with the knee's sign
    chosen continuously in time (:func:`continuous_angles`)."""
    rot, knee = rot.copy(), knee.copy()
    ok = np.isfinite(rot) & np.isfinite(knee)
    for a, b in true_runs(ok):
        # A step of more than 90 deg reads as the other, 180-deg-turned reading (the thigh
        # Z flipped): continuity keeps the reading, so the parity flips there.
        step = np.abs(_wrap180(np.diff(rot[a:b])))
        parity = np.concatenate([[0], np.cumsum(step > 90.0) % 2])
        if a > 0 or previous is None or not np.isfinite(previous).all():
            # Per run, the reading with fewer frames of a knee hyperextended beyond
            # MAX_KNEE_HYPEREXTENSION_DEG, and among equals the one that agrees with
            # isb_angles' per-frame choice in more frames.
            too_far = knee[a:b] > MAX_KNEE_HYPEREXTENSION_DEG  # flipped, these would be hyperextended that far
            score_keep = (-np.sum(too_far & (parity == 1)), np.sum(parity == 0))
            score_flip = (-np.sum(too_far & (parity == 0)), np.sum(parity == 1))
            flip0 = score_flip > score_keep
        else:  # continues the previous chunk's last frame
            flip0 = abs(_wrap180(rot[a] - previous[0])) > 90.0
        flip = (parity == 1) != flip0
        # A knee cannot hyperextend that far: where the run's reading would, the knee is read
        # flexed and the hip rotation, which the run's reading and the knee then contradict, is
        # left empty (a lifter's hip line that turned 86 deg in one frame, under the 90 deg
        # step, had kept a cyclist's knee at -101 deg).
        impossible = np.where(flip, knee[a:b], -knee[a:b]) > MAX_KNEE_HYPEREXTENSION_DEG
        rot[a:b] = np.where(impossible, np.nan, np.where(flip, rot[a:b] + 180.0, rot[a:b]))
        knee[a:b] = np.where(impossible, np.abs(knee[a:b]), np.where(flip, -knee[a:b], knee[a:b]))
    return rot, knee


#: The fastest each periodic angle turns in the training motion capture (deg/s), fitted by
#: ``python -m benchmarks.fit_angle_speeds --data ../shared/data``
#: (``benchmarks/results/fit_angle_speeds.txt``): :func:`continuous_angles` splits a run that
#: unwrapping would wind a whole turn from its reading at its steps faster than these.
ANGLE_SPEED_LIMITS_PATH = Path(__file__).resolve().parent / "data" / "angle_speed_limits.json"


def angle_kind(name: str) -> str:
    """A periodic angle's name without its side (``left_`` / ``right_``) and ``_deg`` suffix:
    the key of :data:`ANGLE_SPEED_LIMITS_PATH`'s limits."""
    short = name.removesuffix("_deg")
    for side in ("left_", "right_"):
        short = short.removeprefix(side)
    return short


@lru_cache(maxsize=1)
def angle_speed_limits() -> Mapping[str, float]:
    """The shipped limits, angle kind -> deg/s (:data:`ANGLE_SPEED_LIMITS_PATH`).

    Raises:
        InputError: the file lacks a kind of :data:`PERIODIC_ANGLES` or holds a non-positive
            limit.
    """
    limits = json.loads(ANGLE_SPEED_LIMITS_PATH.read_text())["limits"]
    out = {}
    for kind in sorted({angle_kind(n) for n in PERIODIC_ANGLES}):
        value = limits.get(kind, {}).get("deg_per_s")
        if not isinstance(value, (int, float)) or not value > 0:
            raise InputError(f"{ANGLE_SPEED_LIMITS_PATH.name}: limits.{kind}.deg_per_s: expected > 0, got {value!r}")
        out[kind] = float(value)
    return MappingProxyType(out)


def _unwrap_runs(x: np.ndarray, lower: float, previous: float | None, max_step: float = np.inf) -> np.ndarray:
    """``x`` unwrapped (360-deg period) per run of finite samples, each run shifted by the
    multiple of 360 that puts its median in ``(lower, lower + 360]``, or, for a run at index
    0 when ``previous`` (the sample just before ``x``) is finite, that continues it. A run
    that would then put a sample more than half a turn beyond that range (wound a whole turn
    away from its own reading) is split at its steps larger than ``max_step`` (deg, wrapped
    into [-180, 180)), each piece levelled so, the first continuing ``previous`` only within
    ``max_step`` of it."""
    out = x.copy()
    jump = np.abs(_wrap180(np.diff(x))) > max_step  # NaN steps are False: the finite runs end there anyway
    for a, b in true_runs(np.isfinite(x)):
        whole = _levelled(x[a:b], lower, previous if a == 0 else None, np.inf)
        if _in_band(whole, lower):
            out[a:b] = whole
            continue
        cuts = [a, *(a + 1 + np.flatnonzero(jump[a:b - 1])), b]
        for c, d in zip(cuts[:-1], cuts[1:]):
            level = _levelled_in_band if np.isfinite(max_step) else _levelled  # no frame rate: no step ends a run
            out[c:d] = level(x[c:d], lower, previous if c == 0 else None, max_step)
    return out


def _in_band(run: np.ndarray, lower: float) -> bool:
    """Whether no sample of ``run`` lies more than half a turn beyond ``(lower, lower + 360]``."""
    return bool(np.all((run > lower - 180.0) & (run <= lower + 540.0)))


def _levelled_in_band(x: np.ndarray, lower: float, previous: float | None, max_step: float) -> np.ndarray:
    """:func:`_levelled`, and where that still leaves the band (:func:`_in_band`: steps no
    faster than any training motion that wound whole turns, as a recording of several takes
    joined, or a chunk continuing the previous one's winding, had done, reading the same
    pose a turn apart in a long session), split at its largest step and each side levelled
    so in turn (the first continuing ``previous``; a lone sample that cannot, on its own)."""
    out = np.empty_like(x)
    pieces = [(0, len(x))]  # a stack, first piece on top: no recursion depth for a long run
    while pieces:
        a, b = pieces.pop()
        run = _levelled(x[a:b], lower, previous if a == 0 else None, max_step)
        if not _in_band(run, lower):
            if b - a == 1:
                run = _levelled(x[a:b], lower, None, max_step)
            else:
                cut = a + 1 + int(np.argmax(np.abs(_wrap180(np.diff(x[a:b])))))
                pieces += [(cut, b), (a, cut)]
                continue
        out[a:b] = run
    return out


def _levelled(x: np.ndarray, lower: float, previous: float | None, max_step: float) -> np.ndarray:
    """One run of finite samples unwrapped and shifted as :func:`_unwrap_runs` says."""
    run = np.unwrap(x, period=360.0)
    if previous is not None and np.isfinite(previous) and abs(_wrap180(x[0] - previous)) <= max_step:
        ref = previous - run[0]
    else:
        ref = (lower + 180.0) - float(np.median(run))  # the shift to the range's centre
    return run + 360.0 * np.round(ref / 360.0)


def continuous_angles(angles: Mapping[str, np.ndarray],
                      previous: Mapping[str, float] | None = None, fps: float | None = None) -> dict[str, np.ndarray]:
    """Angles made continuous in time: no wrap by 360 deg, and no 180-deg switch of the
    knee's reading, between two consecutive present frames.

    Per-frame decompositions wrap: ``atan2`` and the first and third angles of an
    Euler/Cardan sequence (:mod:`pcnet.stages.isb_angles`) live on a circle and are reported
    in one 360-deg window, so motion through the window's edge (an arm through overhead in a
    plane inclination, a noisy axial rotation near +-180, a lying body's thigh) jumps by up
    to 360 deg in one frame. No single window avoids it: ISB's own sequences (Wu et al.
    2002, J Biomech 35:543; 2005, J Biomech 38:981) and Grood & Suntay's (1983) joint
    coordinate system put the wrap outside the joint's range of motion only for the segment
    frames their anatomical landmarks define; from joint centres (axial rotations from a
    limb's own plane, segment directions against gravity) nothing bounds the angles, so they
    are made continuous over time instead, as motion-capture software does with Euler
    angles:

    * every column of :data:`PERIODIC_ANGLES` is unwrapped (``np.unwrap``, period 360 deg)
      over each run of consecutive finite frames; a NaN frame ends a run and stays NaN (no
      gap is bridged), and each run is shifted by the multiple of 360 deg that puts its
      median in the column's range ((-180, 180], or (-90, 270] for the upper-arm
      inclinations), so its values keep their usual reading; with ``fps``, a run that would
      then hold a value more than half a turn beyond its range (unwound a whole turn from its
      own reading) is split at its steps faster than the angle ever turns in the training
      motion capture (:func:`angle_speed_limits`): there a lifter's jump, not motion, had
      carried the unwrapping round; a piece still beyond it (steps no faster, as takes joined
      into one file wind, or a long session's chunks continuing each other had) is split at
      its largest step, and so on until every piece keeps within half a turn of its range (a
      long-recording trial read one pose 360 deg apart in a ten-minute session);
    * hip internal rotation and signed knee flexion have two posture hypotheses in every frame
      (:mod:`pcnet.stages.isb_angles`: a flexed knee, or a hyperextended one with the thigh
      turned 180 deg about its axis, ``(rotation, knee) ~ (rotation + 180, -knee)``), which
      ``isb_joint_angles`` chooses per frame by plausibility; here the reading is kept over
      each run (it switches only where the rotation would otherwise step by more than
      90 deg between two frames, i.e. where the limb plane's normal flipped), and each run
      takes the reading ``isb_joint_angles`` chose in the majority of its frames; a frame
      whose kept reading would hyperextend the knee beyond ``MAX_KNEE_HYPEREXTENSION_DEG``
      reads the knee flexed and leaves the hip rotation empty (NaN).

    What is left: a per-frame step of up to 90 deg in hip rotation (from noise where the
    knee is nearly straight) and up to 180 deg in the first/third angle of a sequence near
    its gimbal lock (the shoulder's plane of elevation with the arm just above
    ``GIMBAL_MARGIN_DEG`` of elevation), where the angle is ill-defined rather than wrapped.
    A run that winds a whole turn (an arm circled through overhead and down behind) ends
    360 deg from where it started, as its motion did.

    Args:
        angles: ``name -> (T,)`` degrees, names as :attr:`Kinematics.angles` (or with the
            ``_deg`` suffix); names not periodic are returned unchanged.
        previous: ``name -> degrees`` of the frame just before these (the previous chunk of
            :func:`kinematics_chunks`): a run that starts at frame 0 continues it instead of
            being levelled on its own median.
        fps: the frame rate (Hz) that turns :func:`angle_speed_limits` into steps; ``None``:
            no run ends at a step.

    Returns:
        a new dict, same keys and order, float64 arrays.
    """
    out = {name: np.asarray(v, np.float64) for name, v in angles.items()}
    previous = previous or {}
    base = {name.removesuffix("_deg"): name for name in out}
    for side in ("left", "right"):
        rot, knee = base.get(f"{side}_hip_internal_rotation"), base.get(f"{side}_knee_flexion")
        if rot is not None and knee is not None:
            prev = (previous.get(rot, np.nan), previous.get(knee, np.nan))
            out[rot], out[knee] = _knee_reading(out[rot], out[knee], prev)
    limits = angle_speed_limits() if fps is not None else {}
    for short, name in base.items():
        if short in PERIODIC_ANGLES:
            max_step = limits[angle_kind(short)] / fps if fps is not None else np.inf
            out[name] = _unwrap_runs(out[name], PERIODIC_ANGLES[short], previous.get(name), max_step)
    return out


# ---------------------------------------------------------------------------------------
# bundle


@dataclass(frozen=True, eq=False)
class Kinematics:
    """Filtered canonical positions and their derivatives and angles, with per-joint flags
    saying which positions are missing or raw; its arrays are read-only.

    Attributes:
        positions: ``(T, 17, 3)`` float64 filtered canonical positions, ``units``; raw
            where ``unfiltered``, NaN where ``missing``.
        velocity: ``(T, 17, 3)`` float64, ``velocity_units``; NaN where ``missing`` or
            ``unfiltered``, and at the first and last sample of every finite run
            (:func:`derivatives`, central differences only).
        acceleration: ``(T, 17, 3)`` float64, ``acceleration_units``; NaN as ``velocity``.
        speed: ``(T, 17)`` float64 ``|velocity|``, ``velocity_units``.
        angles: ``name -> (T,)`` degrees, read-only: the segment inclinations of
            :func:`joint_angles` (computed in the pelvis-heading frame,
            :func:`pelvis_heading_frame`, so they do not depend on the world heading and may
            differ from ``joint_angles(positions)`` by a few degrees) and the ISB joint angles of
            :func:`pcnet.stages.isb_angles.isb_joint_angles`, all from ``positions`` (so an angle
            uses raw positions where a joint is ``unfiltered``).
        unfiltered: ``(T, 17)`` bool, True where the joint's position is finite but left
            raw because its run of finite samples (on any of the 3 axes) was too short
            for the Butterworth filter (:func:`butterworth_lowpass`). All False when
            ``cutoff_hz`` is None (nothing was filtered, by request).
        missing: ``(T, 17)`` bool, True where the joint's position is NaN (any axis) in
            that frame: masked by the 2D confidence, dropped by the lifter, or a frame
            without a pose. ``missing`` and ``unfiltered`` never both hold.
        fps, cutoff_hz: sampling rate and filter cutoff (None = not filtered).
        units, velocity_units, acceleration_units: e.g. ``"m"``, ``"m/s"``, ``"m/s^2"``.
        joint_names: H36M-17 names, index-aligned with axis 1.
        angle_rates: ``name -> (T,)`` deg/s, read-only, the same names as ``angles``: each
            angle's rate of change (:func:`angle_rates`), the joint angular velocity of an ISB
            angle; empty (no names) where not computed (``compute_kinematics(...,
            continuous=False)``).
    """

    positions: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    speed: np.ndarray
    angles: Mapping[str, np.ndarray]
    unfiltered: np.ndarray
    missing: np.ndarray
    fps: float
    cutoff_hz: float | None
    units: str
    velocity_units: str
    acceleration_units: str
    joint_names: tuple[str, ...] = field(default=H36M_JOINTS)
    angle_rates: Mapping[str, np.ndarray] = field(default_factory=lambda: MappingProxyType({}))

    def __post_init__(self) -> None:
        freeze_arrays(self)

    def __setstate__(self, state: dict) -> None:
        restore_frozen(self, state)

    def __repr__(self) -> str:
        return arrays_repr(self)

    @property
    def num_frames(self) -> int:
        return int(self.positions.shape[0])

    def __reduce__(self):
        # ``angles`` is a read-only view, which pickle and deepcopy cannot copy: rebuild it (a
        # worker process returns its Kinematics this way).
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(angles=dict(self.angles), angle_rates=dict(self.angle_rates))
        return _kinematics_from, (values,)


def _kinematics_from(values: dict) -> Kinematics:
    return Kinematics(**{**values, "angles": MappingProxyType(values["angles"]),
                         "angle_rates": MappingProxyType(values["angle_rates"])})


def angle_rates(k: Kinematics, before: Kinematics | None = None, after: Kinematics | None = None
                ) -> dict[str, np.ndarray]:
    """Each angle's rate of change, deg/s: the central difference of the angle at the frames
    either side, ``(theta[t+1] - theta[t-1]) * fps / 2`` (the positions' rule,
    :func:`derivatives`), for a periodic angle (:data:`PERIODIC_ANGLES`) taken modulo 360 deg
    into (-180, 180] so that a run :func:`continuous_angles` split at a lifter's jump, whose
    pieces may sit a turn apart, does not read a turn as motion. Applied to the ISB angles it
    is the joint angular velocity of their rotation sequence's coordinate (Wu et al. 2002,
    J Biomech 35:543), for the inclinations the segment's in-plane angular velocity.

    Empty (NaN), as the positions' velocities are within their runs of present frames
    (:func:`derivatives`), where the angle is empty in the frame or either neighbour (a run's
    first and last frame, a gap: a frame without a pose between two people of a switched 2D
    track has no rate), and where the angle in any of those three frames is computed from a raw
    (``unfiltered``) joint position: the difference of angles from unfiltered positions
    amplifies their noise, as the positions' velocity would (:func:`compute_kinematics`), so
    none is given. Which angles a raw joint reaches is read from the angles themselves: those
    that have no value once the raw positions are taken out.

    Args:
        k: a :class:`Kinematics` of all 17 H36M-17 joints whose ``angles`` are continuous in
            time (:func:`continuous_angles`).
        before, after: the blocks just before and after ``k`` of the same recording
            (:func:`kinematics_chunks`), whose last and first frame are ``k``'s first and last
            frame's neighbours; ``None`` at the recording's start or end.

    Returns:
        ``name -> (T,)`` float64 deg/s, the names and order of ``k.angles``.
    """
    def edge(block: Kinematics | None, at: int) -> dict[str, float]:
        """The angles of one frame of a neighbouring block, NaN where raw."""
        if block is None or not block.num_frames:
            return {}
        one = select_frames(block, at % block.num_frames, at % block.num_frames + 1)
        raw = _angles_from_raw(one)
        return {n: np.nan if raw[n][0] else float(v[0]) for n, v in one.angles.items()}

    first, last, raw = edge(before, -1), edge(after, 0), _angles_from_raw(k)
    out = {}
    for name, v in k.angles.items():
        theta = np.concatenate([[first.get(name, np.nan)], np.where(raw[name], np.nan, v), [last.get(name, np.nan)]])
        step = theta[2:] - theta[:-2]
        if name.removesuffix("_deg") in PERIODIC_ANGLES:
            step = 180.0 - np.mod(180.0 - step, 360.0)
        out[name] = np.where(np.isfinite(theta[1:-1]), step * k.fps / 2.0, np.nan)
    return out


def _angles_from_raw(k: Kinematics) -> dict[str, np.ndarray]:
    """``name -> (T,)`` bool: where ``k``'s angle has a value that needs a raw (``unfiltered``)
    joint position, i.e. has none from the filtered positions alone."""
    raw = np.asarray(k.unfiltered, bool)
    out = {name: np.zeros(k.num_frames, dtype=bool) for name in k.angles}
    rows = np.flatnonzero(raw.any(axis=1))  # each frame's angles are its own: only these can need one
    if rows.size:
        positions = np.asarray(k.positions, np.float64)[rows]
        filtered_only = _angles(np.where(raw[rows, :, None], np.nan, positions), k.fps, False)
        for name, v in k.angles.items():
            out[name][rows] = np.isfinite(np.asarray(v)[rows]) & ~np.isfinite(filtered_only[name])
    return out


def with_angle_rates(k: Kinematics, before: Kinematics | None = None, after: Kinematics | None = None) -> Kinematics:
    """``k`` with its :attr:`Kinematics.angle_rates` (:func:`angle_rates`)."""
    return replace(k, angle_rates=MappingProxyType(angle_rates(k, before, after)))


def pelvis_heading_frame(poses: np.ndarray) -> np.ndarray:
    """Y-up poses turned about +Y, per frame, into the canonical frame's axes
    (:func:`pcnet.stages.core.canonical.canonical_rotation` with up = +Y: +Z along the horizontal
    part of the hip line, docs/CONVENTIONS.md), without moving the origin: applied to
    world-frame (or canonical) poses, for angles that must not depend on the world heading.

    Args:
        poses: ``(T, 17, 3)`` H36M-17 poses with +Y up (world or canonical frame), any units.

    Returns:
        ``(T, 17, 3)`` float64; NaN for frames whose hip line is missing or within
        :func:`~pcnet.stages.core.canonical.canonical_rotation`'s limit of vertical.
    """
    X = np.asarray(poses, np.float64)
    R, _ = canonical_rotation(X, (0.0, 1.0, 0.0))
    return X @ R


def lowpass_rotations(R: np.ndarray, fps: float, cutoff_hz: float | None = 6.0, order: int = FILTER_ORDER
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Low-pass a rotation sequence with the filter of the poses: each of the nine entries
    through :func:`butterworth_lowpass`, then each frame's nearest rotation in the Frobenius
    norm, ``U diag(1, 1, det(U V^T)) V^T`` of the filtered matrix's SVD ``U S V^T`` (the
    orthogonal Procrustes solution, :func:`~pcnet.stages.core.rotations.procrustes_rotation`;
    Higham 1989, "Matrix nearness problems", sec. 3). A
    rotation constant over a run passes unchanged; so does each run's ``unfiltered`` share.

    Args:
        R: ``(T, 3, 3)`` rotations (e.g. canonical -> camera), NaN = none that frame.
        fps, cutoff_hz, order: as :func:`butterworth_lowpass` (``cutoff_hz`` None = no filter).

    Returns:
        ``(rotations, unfiltered)``: float64 ``(T, 3, 3)`` (NaN where ``R`` is not finite) and
        bool ``(T,)``, True where a frame's run of finite rotations was too short to filter
        (its rotation kept raw).

    Raises:
        InputError: ``R`` not ``(T, 3, 3)``; as :func:`butterworth_lowpass` for the filter.
    """
    R = np.asarray(R, np.float64)
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise InputError(f"R: expected (T, 3, 3) rotations, got shape {R.shape}")
    if cutoff_hz is None:
        return R.copy(), np.zeros(len(R), dtype=bool)
    F, raw = butterworth_lowpass(R.reshape(len(R), 9), fps, cutoff_hz, order, return_unfiltered=True)
    F = F.reshape(-1, 3, 3)
    out = np.full(F.shape, np.nan)
    ok = np.isfinite(F).all(axis=(1, 2))
    # the rotation nearest F: Kabsch's best turn of the identity's rows onto F's
    out[ok] = procrustes_rotation(np.broadcast_to(np.eye(3), F[ok].shape), F[ok])[0]
    return out, raw.any(axis=1)


def stretches(num_frames: int, breaks: tuple[int, ...] = ()) -> list[tuple[int, int]]:
    """The ``[start, stop)`` stretches of ``num_frames`` frames between ``breaks`` (frames where
    a lifter's output restarts, :attr:`pcnet.adapters.Poses3D.breaks`; those outside
    ``1..num_frames - 1`` ignored); one stretch where there is none."""
    edges = sorted({0, num_frames, *(int(b) for b in breaks if 0 < b < num_frames)})
    return list(zip(edges[:-1], edges[1:]))


def filtered_derivatives(
    x: np.ndarray, fps: float, cutoff_hz: float | None = 6.0, order: int = FILTER_ORDER, breaks: tuple[int, ...] = ()
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Low-pass, then differentiate, with :func:`compute_kinematics`'s rules: samples the
    filter left raw get no velocity or acceleration.

    Args:
        x: ``(T, ...)`` samples along axis 0 (e.g. some joints' positions), NaN = missing.
        fps, cutoff_hz, order: as :func:`compute_kinematics` (``cutoff_hz`` None = no filter).
        breaks: frames where the samples restart (:attr:`pcnet.adapters.Poses3D.breaks`):
            each stretch between two is filtered and differentiated on its own, as the runs
            between missing frames are.

    Returns:
        ``(positions, unfiltered, velocity, acceleration)`` shaped like ``x``: float64 filtered
        positions, bool raw-sample flags, and their derivatives in units/s and units/s^2.

    Raises:
        InputError: ``fps`` not a frame rate or an invalid cutoff/order.
    """
    fps = validate_fps(fps, "fps")
    x = np.asarray(x, np.float64)
    edges = stretches(len(x), breaks)
    if len(edges) > 1:
        parts = [filtered_derivatives(x[a:b], fps, cutoff_hz, order) for a, b in edges]
        return tuple(np.concatenate(arrays) for arrays in zip(*parts))
    if cutoff_hz is None:
        pos, raw = x.copy(), np.zeros(x.shape, dtype=bool)
    else:
        pos, raw = butterworth_lowpass(x, fps, cutoff_hz, order, return_unfiltered=True)
    vel, acc = derivatives(np.where(raw, np.nan, pos), fps)
    return pos, raw, vel, acc


def _filtered_about_pelvis(X: np.ndarray, fps: float, cutoff_hz: float | None,
                           order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`filtered_derivatives` of Y-up poses ``X`` ``(T, 17, 3)`` as the pelvis's path
    plus each joint about it, low-passed apart: the pelvis (the hips' midpoint where it is
    missing, the H36M rule) over its own runs of frames, each joint about it over the joint's.
    The filter being linear, this is filtering ``X`` where a joint has the pelvis's runs; where
    it has shorter ones (a gap, or a run too short for the filter and kept raw), a segment
    between two joints is theirs alone, not also the difference of the path filtered over two
    runs (an estimator-swapping trial: elbow flexion moved 1.2 deg beside a masked wrist when
    only the pelvis path changed). Frames without a pelvis are filtered whole."""
    P = fill_pelvis_from_hips(X)[0][:, PELVIS]
    placed = np.isfinite(P).all(axis=-1)
    if cutoff_hz is None or not placed.any():
        return filtered_derivatives(X, fps, cutoff_hz, order)
    path, path_raw = butterworth_lowpass(P, fps, cutoff_hz, order, return_unfiltered=True)
    about, raw = butterworth_lowpass(X - P[:, None], fps, cutoff_hz, order, return_unfiltered=True)
    pos, raw = about + path[:, None], raw | path_raw[:, None]
    if not placed.all():
        whole, whole_raw = butterworth_lowpass(X, fps, cutoff_hz, order, return_unfiltered=True)
        pos[~placed], raw[~placed] = whole[~placed], whole_raw[~placed]
    vel, acc = derivatives(np.where(raw, np.nan, pos), fps)
    return pos, raw, vel, acc


def _angles(pos: np.ndarray, fps: float, continuous: bool = True) -> dict[str, np.ndarray]:
    """Every angle of :attr:`Kinematics.angles` from filtered Y-up positions at ``fps``."""
    # the heading-free angles from the poses themselves: a body on its side has no heading
    # checked once for the whole recording by compute_kinematics (or not, check_up=False)
    out = {**joint_angles(pelvis_heading_frame(pos), heading_free_angles(pos), check_up=False),
           **{k.removesuffix("_deg"): v for k, v in isb_joint_angles(pos, check_up=False).items()}}
    return continuous_angles(out, fps=fps) if continuous else out


def _require_units(X, units: object, field: str) -> None:
    """Refuse a ``units`` that is not a unit's name, and poses ``X`` (argument ``field``) said to
    be in a length unit (:data:`~pcnet.stages.core.conventions.METRES_PER_LENGTH_UNIT`) whose
    median thigh in it is no person's
    (:func:`~pcnet.stages.core.conventions.thigh_beyond_metres`): their speeds would be wrong a
    hundredfold (a user trial's centimetres gave a wrist at 152 m/s; a notebook trial's metres
    declared as "mm" were labelled mm/s)."""
    known = (*METRES_PER_LENGTH_UNIT, *UNSCALED_UNITS)
    if not isinstance(units, str) or units not in known:
        raise InputError(f"units: expected a length unit's name (one of {', '.join(map(repr, known))}), got {units!r}")
    scale = METRES_PER_LENGTH_UNIT.get(units)
    thigh = thigh_beyond_metres(X, scale) if scale is not None else None
    if thigh == 0.0:  # rectify calls these placeholders too (validate_poses)
        raise InputError(f"{field}: expected poses with a body's size, got every thigh 0 long: a writer's "
                         f"placeholders (zeros) for missing joints? give missing joints as NaN")
    if thigh is not None:
        said = "metres" if units == "m" else f"{units!r}"
        smaller = "centimetres or millimetres" if units == "m" else "a smaller unit"
        raise InputError(f"{field}: expected poses in {said} (units {units!r}: a median thigh length of "
                         f"{THIGH_RANGE_M[0]}-{THIGH_RANGE_M[1]} m), got {thigh:.3g} m: "
                         f"{smaller if thigh > REFUSED_THIGH_M[1] else 'another unit or joint order'} "
                         f"given as {said}? scale the poses, or pass their units")


def inverted_trunk_bound_deg() -> float:
    """The median trunk inclination (pelvis -> thorax from +Y, deg) beyond which Y-up poses
    are taken to be upside down rather than lying: ``90 + 1.96 sigma_lie``, the up model's
    fitted spread of a lying trunk's elevation (``lying_elevation_deg``,
    :mod:`pcnet.stages.up_model`), its two-sided 95 % quantile (a lying trunk's frame passes it
    one time in 40). An upright body in a camera frame (+Y down) lies near 180 deg less the
    camera's pitch."""
    from .up_model import default_parameters  # the fitted parameter's one source

    return 90.0 + 1.96 * default_parameters().lying_elevation_deg


def require_y_up(X: np.ndarray, field: str) -> None:
    """Refuse poses ``X`` (argument ``field``) whose trunk points down in most frames (median
    inclination beyond :func:`inverted_trunk_bound_deg`): camera-frame poses (+Y down) given
    where Y-up ones are expected (a developer's trial got a trunk inclination of 178 deg)."""
    trunk = X[:, THORAX] - X[:, PELVIS]
    with np.errstate(invalid="ignore", divide="ignore"):
        inclination = np.degrees(np.arccos(np.clip(trunk[:, 1] / np.linalg.norm(trunk, axis=1), -1.0, 1.0)))
    inclination = inclination[np.isfinite(inclination)]
    bound = inverted_trunk_bound_deg()
    if len(inclination) and np.median(inclination) > bound:
        raise InputError(f"{field}: expected Y-up poses (the world or canonical frame), got a trunk pointing down in "
                         f"most frames (median inclination {np.median(inclination):.0f} deg, beyond {bound:.0f}): "
                         f"camera-frame poses (+Y down)? rectify them first (pcnet.pipeline.rectify, to_world); a "
                         f"body inverted for most of the recording: pass check_up=False")


def compute_kinematics(
    canonical: np.ndarray,
    fps: float,
    cutoff_hz: float | None = 6.0,
    units: str = "m",
    order: int = FILTER_ORDER,
    continuous: bool = True,
    check_up: bool = True,
    rotation: np.ndarray | None = None,
) -> Kinematics:
    """Filter Y-up poses, then differentiate and compute angles.

    Order of operations follows Winter (2009, ch. 3): low-pass the coordinates
    (:func:`butterworth_lowpass`; the pelvis's path and each joint about it apart, so that a
    joint with a gap is not filtered over other frames than the path, :func:`_filtered_about_pelvis`),
    then differentiate (:func:`derivatives`) and compute
    angles from the filtered coordinates: the segment inclinations of :func:`joint_angles`
    (turned into the pelvis heading frame, :func:`pelvis_heading_frame`, so they mean the
    same from world or canonical poses) and the ISB joint angles of
    :func:`pcnet.stages.isb_angles.isb_joint_angles` (names without their ``_deg`` suffix). Positions, velocities and accelerations are in the input's frame: the
    recording's world frame (:mod:`pcnet.stages.world_frame`) for anything differentiated in
    time; the canonical frame turns with the pelvis and adds rotating-frame terms.

    Samples the filter had to leave raw (runs of finite samples too short for it, e.g. a
    few frames between two masked frames) keep their raw position, flagged in
    ``unfiltered``, but get NaN velocity and acceleration: differentiating unfiltered
    coordinates amplifies their noise by ``(2 pi f)^2`` at frequency ``f`` for the
    acceleration (Winter 2009, ch. 3), which is what produced 79 m/s^2 at frame 0 of the
    demo's right wrist (a 4-frame raw run before a masked frame). A derivative from
    filtered and raw samples mixed would be neither, so none is given.

    Residual edge effect (not blanked): the second sample of a filtered run uses the
    run's end sample, which keeps its raw noise (see :func:`derivatives`); on white noise
    its acceleration noise is about 1.6x that of the run's interior.

    Args:
        canonical: ``(T, 17, 3)`` H36M-17 poses with +Y up (world frame, or canonical:
            pelvis origin), NaN for missing; a writer's placeholder (a joint written as
            zeros) must be NaN before they were turned into this frame (what
            :func:`pcnet.stages.core.conventions.validate_poses` does to camera-frame poses):
            here it is a position.
        fps: sampling rate in Hz.
        cutoff_hz: -3 dB cutoff of the zero-phase filter; None skips filtering (then
            nothing is flagged ``unfiltered`` and every finite run is differentiated).
        units: length unit of ``canonical``: ``"m"`` when metric, else e.g.
            ``"normalised"``; velocity units are then ``"<units>/s"``.
        order: order of the zero-phase filter (see :func:`butterworth_lowpass`).
        continuous: make the angles continuous in time (:func:`continuous_angles`: unwrapped
            per run of present frames, the knee's reading kept); False leaves each frame's
            own decomposition (what :func:`kinematics_chunks` stitches itself).
        check_up: refuse poses whose trunk points down in most frames
            (:func:`inverted_trunk_bound_deg`): camera-frame poses (+Y down) given by mistake;
            False for a body that is inverted for most of the recording (a handstand), which
            no trunk angle tells from them, or a world frame under test.
        rotation: optional ``(T, 3, 3)`` canonical -> camera rotations, one per frame (frame
            and smooth modes' ``Rectified.rotation``): ``canonical`` are then the camera-frame
            poses (OpenCV axes), low-passed there and turned into the canonical frame,
            ``(X - pelvis) @ R``, by the rotations low-passed with the same filter
            (:func:`lowpass_rotations`), so that the rotations' frame-to-frame noise does
            not reach the angles between segments (decision 0102). For one rotation this
            equals filtering ``(X - pelvis) @ R``. A missing pelvis is the hips' midpoint (the
            H36M rule rectification applies, :func:`~pcnet.stages.core.conventions.fill_pelvis_from_hips`);
            a frame without a rotation (any entry not finite) is missing in every joint.

    Returns:
        a frozen :class:`Kinematics`; :func:`flag_counts` / :func:`format_flag_counts`
        summarise its flags.

    Raises:
        ValueError: wrong shape, no frame or no finite coordinate, ``fps`` not a number in [1, 10000] Hz
            (:func:`~pcnet.stages.core.conventions.validate_fps`), an invalid cutoff/order,
            ``units`` not a unit's name, poses in ``"m"`` whose median thigh is no
            person's (centimetres given as metres), or (``check_up``) poses whose trunk points
            down in most frames (:func:`inverted_trunk_bound_deg`: camera-frame poses, +Y down),
            ``rotation`` not ``(T, 3, 3)`` or a frame of it not a proper rotation (a reflection,
            zeros, a scaled matrix; within :data:`ROTATION_TOLERANCE`).
    """
    X = check_poses(canonical, "canonical").astype(np.float64)
    if not len(X):
        raise InputError("canonical: expected at least one frame, got 0")
    if not np.isfinite(X).any():  # rectify refuses the same input; an all-NaN result says nothing
        raise InputError("canonical: expected some finite joint coordinates, got only NaN/inf")
    fps = validate_fps(fps, "fps")
    _require_units(X, units, "canonical")
    if rotation is not None:
        rotation = _proper_rotations(_checked_rotation(rotation, len(X)))
    if check_up:
        require_y_up(X if rotation is None else to_canonical(fill_pelvis_from_hips(X)[0], rotation), "canonical")
    return _kinematics(X, fps, cutoff_hz, units, order, continuous, rotation)


#: Largest entry of ``R R^T - I`` a rotation may carry: float32 rounding (about 1e-7) with room
#: to spare; a matrix beyond it is not a rotation (zeros, a scaled or sheared matrix).
ROTATION_TOLERANCE = 1e-4


def _canonical_in_blocks(X, rotation) -> np.ndarray:
    """Camera-frame poses ``X`` turned into the canonical frame by ``rotation`` (each ``(T, ...)``,
    in memory or on disk) a block of frames at a time, as :func:`compute_kinematics`' up check
    reads them (a frame without a proper rotation NaN)."""
    out = np.full((len(X), *np.shape(X)[1:]), np.nan)
    for rows in frame_blocks(len(X)):
        turn = _proper_rotations(rotation[rows], rows.start)
        out[rows] = to_canonical(fill_pelvis_from_hips(np.asarray(X[rows], np.float64))[0], turn)
    return out


def _proper_rotations(R: np.ndarray, first_frame: int = 0) -> np.ndarray:
    """``R`` ``(T, 3, 3)`` (frames from ``first_frame`` on) as float64, a frame with any
    non-finite entry all NaN (no rotation).

    Raises:
        InputError: a finite frame that is not a proper rotation (orthonormal within
            :data:`ROTATION_TOLERANCE`, determinant +1): a reflection, zeros, a scaled matrix.
    """
    R = np.array(R, np.float64)
    ok = np.isfinite(R).all(axis=(1, 2))
    R[~ok] = np.nan
    if ok.any():
        off = np.abs(R[ok] @ np.swapaxes(R[ok], 1, 2) - np.eye(3)).max(axis=(1, 2))
        det = np.linalg.det(R[ok])
        bad = (off > ROTATION_TOLERANCE) | (det < 0)
        if bad.any():
            i = int(np.argmax(bad))
            frame = first_frame + int(np.flatnonzero(ok)[i])
            raise InputError(f"rotation: expected proper rotations (R R^T = I, det +1), got frame {frame} with "
                             f"R R^T - I up to {off[i]:.3g} and det {det[i]:.3g}")
    return R


def _checked_rotation(rotation, frames: int):
    """``rotation`` if it is ``(frames, 3, 3)`` (in memory or on disk), else an InputError."""
    shape = tuple(getattr(rotation, "shape", np.shape(rotation)))
    if shape != (frames, 3, 3):
        raise InputError(f"rotation: expected ({frames}, 3, 3) rotations, one per frame of the poses, got shape {shape}")
    return rotation


def _kinematics(X: np.ndarray, fps: float, cutoff_hz: float | None, units: str, order: int,
                continuous: bool, rotation: np.ndarray | None = None) -> Kinematics:
    """:func:`compute_kinematics` of checked float64 poses ``X`` ``(T, 17, 3)`` (camera-frame
    ones placed by ``rotation`` ``(T, 3, 3)``, if given)."""
    if rotation is None:
        missing = ~np.isfinite(X).all(axis=-1)
        pos, raw, vel, acc = _filtered_about_pelvis(X, fps, cutoff_hz, order)
    else:
        X = fill_pelvis_from_hips(X)[0]  # the H36M pelvis rule, as rectification placed the poses
        if cutoff_hz is None:
            cam, raw = X, np.zeros(X.shape, dtype=bool)
        else:
            cam, raw = butterworth_lowpass(X, fps, cutoff_hz, order, return_unfiltered=True)
        R, raw_rotation = lowpass_rotations(rotation, fps, cutoff_hz, order)
        pos = np.einsum("tjk,tkl->tjl", cam - cam[:, PELVIS:PELVIS + 1], R)
        missing = ~np.isfinite(pos).all(axis=-1)
        # a canonical position is raw where its joint, the pelvis or the rotation was
        raw = raw | raw[:, PELVIS:PELVIS + 1] | raw_rotation[:, None, None]
        vel, acc = derivatives(np.where(raw, np.nan, pos), fps)
    k = Kinematics(
        positions=pos,
        velocity=vel,
        acceleration=acc,
        speed=np.linalg.norm(vel, axis=-1),
        # the heading-free angles from the poses themselves: a body on its side has no heading
        angles=MappingProxyType(_angles(pos, fps, continuous)),
        unfiltered=raw.any(axis=-1) & ~missing,
        missing=missing,
        fps=float(fps),
        cutoff_hz=None if cutoff_hz is None else float(cutoff_hz),
        units=units,
        velocity_units=f"{units}/s",
        acceleration_units=f"{units}/s^2",
    )
    # a rate needs the angles' final continuity: kinematics_chunks adds them after stitching
    return with_angle_rates(k) if continuous else k


# ---------------------------------------------------------------------------------------
# long recordings in chunks

#: Frames per chunk of :func:`kinematics_chunks`: about 2 min at 30 fps, so a chunk's
#: arrays (and the CSV rows formatted from them) stay in the tens of MB.
CHUNK_FRAMES = 4096


def settle_frames(fps: float, cutoff_hz: float | None, order: int = FILTER_ORDER, tol: float = 1e-12) -> int:
    """Frames of context on each side that make a chunk's kinematics equal those of the whole
    recording to a relative ``tol``.

    A zero-phase filter started at a chunk edge (``sosfiltfilt``'s odd extension and
    steady-state initial conditions) differs from the same filter run through the edge by
    a transient that decays as ``r^n`` after ``n`` samples, ``r`` the largest pole radius
    of one pass (a stable IIR filter's impulse response, Oppenheim & Schafer,
    *Discrete-Time Signal Processing*, 3rd ed., 2010, sec. 3.3); the central differences of
    :func:`derivatives` need one more sample. The count also exceeds the filter's
    ``padlen``, so a finite run cut at a chunk edge is never mistaken for one too short to
    filter.

    Args:
        fps, cutoff_hz, order: as :func:`butterworth_lowpass`; ``cutoff_hz`` None = no filter.
        tol: relative size of the transient left at the kept samples.

    Returns:
        frames (int >= 2).

    Raises:
        InputError: as :func:`butterworth_lowpass` for an invalid filter.
    """
    if cutoff_hz is None:
        return 2
    sos, padlen = _lowpass_design(fps, cutoff_hz, order)
    radius = float(np.abs(sos2zpk(sos)[1]).max())
    decay = int(np.ceil(np.log(tol) / np.log(radius))) if radius > 0 else 1
    return max(decay, padlen + 1) + 2


def select_frames(kinematics: Kinematics, start: int, stop: int, joints: Iterable[str] | None = None,
                  dtype: type | None = None) -> Kinematics:
    """Frames ``[start, stop)`` (and optionally only the named ``joints``, in that order) of a
    :class:`Kinematics`; angles keep every angle. ``dtype`` (e.g. ``np.float32``, half the
    memory for what a long recording keeps for its plots) converts the float arrays.

    Raises:
        InputError: an unknown joint name.
    """
    k = kinematics
    names = list(k.joint_names)
    chosen = names if joints is None else list(joints)
    unknown = [j for j in chosen if j not in names]
    if unknown:
        raise InputError(f"select_frames: unknown joints {unknown}; known: {names}")
    idx = [names.index(j) for j in chosen]
    cut = slice(start, stop)

    def take(a: np.ndarray) -> np.ndarray:
        a = a[cut][:, idx]
        return a if dtype is None else a.astype(dtype)

    return replace(
        k, positions=take(k.positions), velocity=take(k.velocity),
        acceleration=take(k.acceleration), speed=take(k.speed),
        angles=MappingProxyType({n: v[cut] if dtype is None else v[cut].astype(dtype) for n, v in k.angles.items()}),
        angle_rates=MappingProxyType({n: v[cut] if dtype is None else v[cut].astype(dtype)
                                      for n, v in k.angle_rates.items()}),
        unfiltered=k.unfiltered[cut][:, idx], missing=k.missing[cut][:, idx], joint_names=tuple(chosen),
    )


_FRAME_ARRAYS = ("positions", "velocity", "acceleration", "speed", "unfiltered", "missing")


class FrameGatherer:
    """Consecutive :class:`Kinematics` blocks of one recording (e.g. from
    :func:`kinematics_chunks`), written into arrays allocated once for ``num_frames`` frames:
    no list of per-block copies and no concatenation, so what a long recording keeps takes
    only its final memory. ``joints`` keeps only those joints (in that order; angles keep every
    angle) and ``dtype`` converts the float arrays (:func:`select_frames`). ``allocate(name,
    shape, dtype)`` makes each array (default in memory; ``pcnet run`` gives a
    :class:`~pcnet.stages.core.framestore.FrameStore`'s, so a long recording's stay on disk).

    ``add(block)`` appends a block; ``result()`` returns the gathered :class:`Kinematics`.

    Raises:
        RuntimeError: blocks that differ in joints, angles, units, rate or cutoff, more frames
            than ``num_frames``, or ``result()`` before exactly ``num_frames`` frames came (a
            caller's bug, not bad input).
    """

    def __init__(self, num_frames: int, joints: Iterable[str] | None = None, dtype: type | None = None,
                 allocate=None):
        self.num_frames = int(num_frames)
        self.allocate = allocate or (lambda name, shape, dtype: np.empty(shape, dtype))
        self.joints = None if joints is None else tuple(joints)
        self.dtype = dtype
        self.filled = 0
        self._first: Kinematics | None = None
        self._arrays: dict[str, np.ndarray] = {}
        self._angles: dict[str, np.ndarray] = {}
        self._rates: dict[str, np.ndarray] = {}

    def add(self, block: Kinematics) -> None:
        k = select_frames(block, 0, block.num_frames, self.joints, self.dtype)
        if self._first is None:
            self._first = k
            self._arrays = {n: self.allocate(f"kept_{n}", (self.num_frames,) + getattr(k, n).shape[1:],
                                             getattr(k, n).dtype) for n in _FRAME_ARRAYS}
            self._angles = {n: self.allocate(f"kept_angle_{n}", (self.num_frames,), v.dtype)
                            for n, v in k.angles.items()}
            self._rates = {n: self.allocate(f"kept_angle_rate_{n}", (self.num_frames,), v.dtype)
                           for n, v in k.angle_rates.items()}
        elif (k.joint_names, tuple(k.angles), tuple(k.angle_rates), k.units, k.fps, k.cutoff_hz) != (
                self._first.joint_names, tuple(self._first.angles), tuple(self._first.angle_rates),
                self._first.units, self._first.fps, self._first.cutoff_hz):
            raise RuntimeError("FrameGatherer: blocks differ in joints, angles, units, rate or cutoff")
        stop = self.filled + k.num_frames
        if stop > self.num_frames:
            raise RuntimeError(f"FrameGatherer: more than the {self.num_frames} frames announced")
        rows = slice(self.filled, stop)
        for n in _FRAME_ARRAYS:
            self._arrays[n][rows] = getattr(k, n)
        for n, v in k.angles.items():
            self._angles[n][rows] = v
        for n, v in k.angle_rates.items():
            self._rates[n][rows] = v
        self.filled = stop

    def result(self) -> Kinematics:
        if self._first is None or self.filled != self.num_frames:
            raise RuntimeError(f"FrameGatherer: {self.filled} of {self.num_frames} frames gathered")
        return replace(self._first, **self._arrays, angles=MappingProxyType(self._angles),
                       angle_rates=MappingProxyType(self._rates))


def kinematics_chunks(
    poses: np.ndarray,
    fps: float,
    cutoff_hz: float | None = 6.0,
    units: str = "m",
    order: int = FILTER_ORDER,
    chunk_frames: int | None = None,
    rotation: np.ndarray | None = None,
    check_up: bool = True,
    breaks: tuple[int, ...] = (),
) -> Iterator[Kinematics]:
    """:func:`compute_kinematics` of a long recording as consecutive chunks of at most
    ``chunk_frames`` frames, so memory stays bounded by the chunk, not the recording.

    Each chunk is computed on itself plus :func:`settle_frames` of context on both sides and
    cut back, so the concatenated chunks equal ``compute_kinematics(poses, ...)`` to about
    1e-12 relative (filter transients; tested in ``tests/test_kinematics_exports.py``), with
    identical NaN and flag patterns. Angles are made continuous (:func:`continuous_angles`) across
    chunks: a run of present frames that crosses a chunk's start continues the previous
    chunk's last frame, so only a run's level (its median's range, its knee reading) is
    chosen from the chunk where the run starts rather than from the whole run.

    Args:
        poses: ``(T, 17, 3)`` Y-up poses, as :func:`compute_kinematics`; in memory or a
            :class:`~pcnet.stages.core.framestore.FrameArray` (read a chunk at a time).
        fps, cutoff_hz, units, order: as :func:`compute_kinematics`.
        chunk_frames: frames per yielded chunk (> 0); default :data:`CHUNK_FRAMES`.
        rotation: optional ``(T, 3, 3)`` canonical -> camera rotations (in memory or on disk):
            ``poses`` are then camera-frame poses, as :func:`compute_kinematics`'s ``rotation``.
        check_up: as :func:`compute_kinematics`' (over the whole recording, before the first
            chunk).
        breaks: frames where the lifter's output restarts (:attr:`pcnet.adapters.Poses3D.breaks`,
            MotionBERT's clip starts): a chunk ends at each and takes no context across it, so
            the filter, the velocities, accelerations and angle rates treat it as a recording's
            end (a trial's cycling clip read a knee extending at 397 deg/s across one), and the
            angles after it are levelled and read (the knee's posture hypothesis) on their own.

    Yields:
        :class:`Kinematics` of frames ``[0, c), [c, 2c), ...``, with their
        :attr:`~Kinematics.angle_rates` across the chunks' seams (each chunk is yielded once
        the next is computed: its last frame's rate needs the next one's first angle).

    Raises:
        InputError: as :func:`compute_kinematics` (the units, the finite coordinates and the
            up checked once, over the whole recording, before the first chunk), or
            ``chunk_frames`` not an integer >= 1.
    """
    X = check_poses(poses, "poses")
    if rotation is not None:
        rotation = _checked_rotation(rotation, len(X))
    chunk_frames = CHUNK_FRAMES if chunk_frames is None else chunk_frames
    if not isinstance(chunk_frames, (int, np.integer)) or isinstance(chunk_frames, bool) or chunk_frames < 1:
        raise InputError(f"chunk_frames: expected an integer >= 1, got {type(chunk_frames).__name__} {chunk_frames!r}"[:300])
    if not len(X):
        raise InputError("poses: expected at least one frame, got 0")
    fps = validate_fps(fps, "fps")
    if not any(np.isfinite(X[rows]).any() for rows in frame_blocks(len(X))):  # as compute_kinematics
        raise InputError("poses: expected some finite joint coordinates, got only NaN/inf")
    _require_units(X, units, "poses")  # once, over the whole recording: a chunk's median is not the recording's
    if check_up:
        require_y_up(X if rotation is None else _canonical_in_blocks(X, rotation), "poses")
    pad = settle_frames(fps, cutoff_hz, order)
    T = len(X)
    previous: dict[str, float] | None = None  # the last frame's angles, continued by the next chunk
    # a chunk's last angle rate needs the next chunk's first angle: each is yielded one chunk late
    before = held = None
    for first, last in stretches(T, breaks):
        for start in range(first, last, chunk_frames):
            stop = min(last, start + chunk_frames)
            lo, hi = max(first, start - pad), min(last, stop + pad)
            chunk = check_poses(X[lo:hi], "poses").astype(np.float64)
            turn = None if rotation is None else _proper_rotations(rotation[lo:hi], lo)
            k = select_frames(_kinematics(chunk, fps, cutoff_hz, units, order, False, turn), start - lo, stop - lo)
            # a stretch after a break starts afresh: the jump there is the lifter's, and carrying the
            # knee's reading over it flipped a cyclist's knee (an API trial)
            angles = continuous_angles(k.angles, None if start == first else previous, fps)
            previous = {name: float(v[-1]) for name, v in angles.items()}
            k = replace(k, angles=MappingProxyType(angles))
            if held is not None:
                across = start == first  # a break between them: no rate across it
                yield with_angle_rates(held, before, None if across else k)
                before = None if across else select_frames(held, held.num_frames - 1, held.num_frames)
            held = k
    yield with_angle_rates(held, before, None)


# ---------------------------------------------------------------------------------------
# flag summary


def flag_counts(kinematics: Kinematics) -> dict:
    """Per-joint and total counts of the ``missing`` and ``unfiltered`` flags, for a run
    summary or a JSON report (plain ``int``/``dict``/``str``, JSON-serialisable).

    Args:
        kinematics: a :class:`Kinematics` with ``T`` frames (:func:`count_flags` takes
            the two flag arrays alone, e.g. gathered from :func:`kinematics_chunks`).

    Returns:
        dict with

        * ``"frames"``: ``T``;
        * ``"missing"``: ``joint name -> frames`` in which that joint is NaN, only joints
          with at least one, in H36M-17 order;
        * ``"missing_with_pose"``: the same, counting only frames in which some other
          joint is present (a joint masked on its own rather than a frame without a pose);
        * ``"frames_without_pose"``: frames in which every joint is missing;
        * ``"unfiltered"``: ``joint name -> frames`` in which its position is raw
          (run too short for the filter), only joints with at least one;
        * ``"missing_total"``, ``"unfiltered_total"``: joint-frames flagged, summed over
          joints;
        * ``"frames_with_missing"``, ``"frames_with_unfiltered"``: frames with at least
          one flagged joint.
    """
    return count_flags(kinematics.missing, kinematics.unfiltered, kinematics.joint_names)


def count_flags(missing: np.ndarray, unfiltered: np.ndarray, joint_names: Iterable[str] = H36M_JOINTS) -> dict:
    """:func:`flag_counts` from ``(T, J)`` bool ``missing`` and ``unfiltered`` flags
    (:attr:`Kinematics.missing`, :attr:`Kinematics.unfiltered`) of joints ``joint_names``."""
    missing = np.asarray(missing, dtype=bool)
    unfiltered = np.asarray(unfiltered, dtype=bool)
    no_pose = missing.all(axis=1)
    names = list(joint_names)

    def per_joint(flags: np.ndarray) -> dict[str, int]:
        n = flags.sum(axis=0)
        return {names[j]: int(n[j]) for j in np.flatnonzero(n)}

    return {
        "frames": int(missing.shape[0]),
        "missing": per_joint(missing),
        "missing_with_pose": per_joint(missing & ~no_pose[:, None]),
        "frames_without_pose": int(no_pose.sum()),
        "unfiltered": per_joint(unfiltered),
        "missing_total": int(missing.sum()),
        "unfiltered_total": int(unfiltered.sum()),
        "frames_with_missing": int(missing.any(axis=1).sum()),
        "frames_with_unfiltered": int(unfiltered.any(axis=1).sum()),
    }


def frames_phrase(n: int, total: int | None = None) -> str:
    """``"1 frame"``, ``"4 frames"``, or with the recording's length ``"283 of 301 frames"``
    (how much of the recording a flag covers)."""
    if total:
        return f"{n} of {total} frames"
    return f"{n} frame" if n == 1 else f"{n} frames"


def format_flag_counts(counts: Kinematics | Mapping, input_note: str = "") -> str:
    """One line for a run summary, ``''`` when nothing is flagged.

    Example: ``"missing: right_wrist 1 of 301 frames; no joint at all: 3 frames; unfiltered: right_wrist
    4 of 301 frames (runs shorter than the filter needs; no velocity/acceleration there)"``
    (``"1 frame"`` where the counts do not give the recording's length).
    Joints missing only in frames without any pose are reported once, as ``no joint at all``.

    Args:
        counts: the dict of :func:`flag_counts`, or a :class:`Kinematics` (counted here).
        input_note: the caller's words on what the input held as missing (the lifter file's
            ``inf``/NaN per joint), put after ``missing``/``no joint at all``; ``''`` for none.

    Returns:
        the line, without a trailing newline.
    """
    c = flag_counts(counts) if isinstance(counts, Kinematics) else counts
    total = c.get("frames")
    parts = []
    if c["missing_with_pose"]:
        parts.append("missing: " + ", ".join(f"{j} {frames_phrase(n, total)}"
                                             for j, n in c["missing_with_pose"].items()))
    if c["frames_without_pose"]:
        parts.append(f"no joint at all: {frames_phrase(c['frames_without_pose'])}")
    if input_note:
        parts.append(input_note)
    if c["unfiltered"]:
        parts.append(
            "unfiltered: " + ", ".join(f"{j} {frames_phrase(n, total)}" for j, n in c["unfiltered"].items())
            + " (runs shorter than the filter needs; no velocity/acceleration there)"
        )
    return "; ".join(parts)
