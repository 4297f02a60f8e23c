"""The floor from foot contacts: one more likelihood term of the up model for recordings with a
camera-frame pelvis path (measured by a depth sensor or given in the file, or recovered from 2D
keypoints by :mod:`pcnet.stages.root_path`).
docs/up_model.md ("Floor contacts") writes the model down; issue 49.

Contacts. In a frame, an ankle is on the floor when it is within ``h_c L`` of that frame's
lower ankle along the current up and moves slower than ``v_c L`` per second (central
difference over ``+-w`` seconds); ``L`` is the median leg length (hip-knee-ankle). A run of
consecutive contact frames of one ankle is a footfall.

Floor model, in the tangent basis ``(e1, e2)`` = (pitch, roll) directions of
:func:`pcnet.stages.up_model.tangent_basis` at the poses' up ``u0``: the floor normal is
``n = normalize(u0 + a e1 + b e2)``; a footfall ``f`` of ankle ``k(f)`` lies at height::

    h_f = p_f . u0 = d + o_k(f) - a (p_f . e1) - b (p_f . e2) + e_f

``d`` the height of the support level the footfall rests on (flat prior; a stool, a step or a
platform is a level of its own: all are horizontal, so every level's footfalls carry the same
normal); ``o_k ~ N(0, (s_o L)^2)`` each ankle's persistent height error (a lifter's or a
sensor's per-joint bias: with the feet in place, it is what tilts the plane through them);
``e_f`` the footfall's own error, of scale ``sigma_f L``, with Tukey's biweight loss
``rho(e_f / (sigma_f L))`` against false contacts (Beaton & Tukey 1974, its 95 %-efficiency
constant ``c``).

Levels. Along the current floor normal, the footfalls' sorted heights start a new level where
they jump by more than ``c sigma_f L``: no footfall beyond the cut-off can be an inlier of the
level below (:func:`support_levels`). One plane through footfalls on two levels tilts towards
the higher one (measured: the CMU test subjects' stool and step takes, 7 of 28 clips beyond 20
deg; docs/decisions/0042).

Posterior. With the poses' posterior as the prior of the tilt, ``theta = (a, b) ~ N(0, C0)``,
the floor's MAP minimises::

    sum_f rho(e_f / (sigma_f L)) + o^T o / (2 (s_o L)^2) + theta^T C0^-1 theta / 2

by iteratively reweighted least squares, the levels re-assigned along each new normal until the
tilt stops moving. Its Laplace approximation, the levels and ``o_k`` marginalised, gives the
floor's information ``I`` and the up, ``theta* = (I + C0^-1)^-1 z``. The fused covariance
``(I + C0^-1)^-1`` is too narrow on validation
(``benchmarks/results/fit_floor_contacts.txt``), so the report keeps the up model's intervals.

Parameters ``h_c``, ``v_c``, ``w``, ``sigma_f`` and ``s_o`` are the up model's
(:class:`pcnet.stages.up_model.UpModelParameters`), fitted on validation data with a measured
root by ``python -m benchmarks.fit_floor_contacts --data ../shared/data``.

Shapes: joints ``(T, 17, 3)`` H36M-17 in the camera frame with the pelvis path added (any
length unit), unit ups ``(3,)``, covariances ``(2, 2)`` rad^2 in the (pitch, roll) basis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core.conventions import L_ANKLE, L_HIP, L_KNEE, PELVIS, R_ANKLE, R_HIP, R_KNEE
from .core.rotations import angle_between, normalize
from .spherical import TUKEY_C, tukey_weights
from .up_model import UpModelParameters, default_parameters, tangent_basis

_IRLS_STEPS = 20
#: Grid points per tilt axis of the coarse search (a resolution of half a prior standard
#: deviation; Newton-like IRLS refines from there).
_COARSE_STEPS = 13
#: The report's reason where the joints carry no pelvis path (measured, or recovered from 2D keypoints).
NO_PELVIS_PATH = ("no pelvis path: root-relative joints carry no floor (a measured root, or 2D keypoints with "
                  "metric poses, the lifter's metres or --height, give one)")
#: Why a recording with a pelvis path gets no floor when the up model reads the body as lying.
LYING_NO_FLOOR = ("body read as lying: the floor contacts are a term of the upright posture (feet at rest on a "
                  "support), so they did not weigh in")
#: Eigen-directions of the floor's information below this share of the prior's are treated as
#: unconstrained (numerical rank, not a tuning constant).
_RANK_TOL = 1e-6


def _joint(J, j: int, frames: np.ndarray | None = None) -> np.ndarray:
    """Joint ``j`` of ``(T, 17, 3)`` poses (in memory or a
    :class:`~pcnet.stages.core.framestore.FrameArray`) as float64 ``(T, 3)``, or only ``frames``."""
    x = np.asarray(J[:, j], np.float64)
    return x if frames is None else x[frames]


def leg_length(J, frames: np.ndarray) -> float:
    """Median hip-knee-ankle chain length over ``frames`` of ``(T, 17, 3)`` poses, both legs
    (the input's unit; NaN without a finite leg)."""
    R_hip, R_knee, R_ankle, L_hip, L_knee, L_ankle = (_joint(J, j, frames) for j in
                                                      (R_HIP, R_KNEE, R_ANKLE, L_HIP, L_KNEE, L_ANKLE))
    legs = [np.linalg.norm(R_hip - R_knee, axis=-1) + np.linalg.norm(R_knee - R_ankle, axis=-1),
            np.linalg.norm(L_hip - L_knee, axis=-1) + np.linalg.norm(L_knee - L_ankle, axis=-1)]
    legs = np.concatenate(legs)
    return float(np.median(legs[np.isfinite(legs)])) if np.isfinite(legs).any() else float("nan")


@dataclass(frozen=True)
class Contacts:
    """Floor contacts of one recording: ``points`` ``(K, 3)`` ankle positions (camera frame),
    ``frames`` ``(K,)`` their frame indices, ``ankle`` ``(K,)`` 0 right / 1 left, ``footfall``
    ``(K,)`` footfall ids (runs of consecutive contact frames of one ankle)."""

    points: np.ndarray
    frames: np.ndarray
    ankle: np.ndarray
    footfall: np.ndarray

    def repeated(self, counts: np.ndarray) -> Contacts:
        """Each contact repeated ``counts[frame]`` times (``counts`` ``(T,)``: a bootstrap's frame counts)."""
        rep = counts[self.frames]
        return Contacts(*(np.repeat(a, rep, 0) for a in (self.points, self.frames, self.ankle, self.footfall)))


def detect_contacts(J, ok: np.ndarray, up: np.ndarray, fps: float, leg: float,
                    p: UpModelParameters) -> Contacts:
    """The quasi-static lower ankles of ``ok`` frames of ``J`` ``(T, 17, 3)`` along unit ``up``
    ``(3,)`` (module docstring: ``h_c``, ``v_c``, ``w`` of ``p``; ``leg`` in the input's unit)."""
    T = len(J)
    ank = np.asarray(J[:, [R_ANKLE, L_ANKLE]], np.float64)
    h = ank @ up
    k = max(1, int(round(p.contact_speed_window_s * fps)))
    speed = np.full((T, 2), np.nan)
    if T > 2 * k:
        speed[k:-k] = np.linalg.norm(ank[2 * k:] - ank[:-2 * k], axis=-1) / (2 * k / fps)
    lowest = np.min(np.where(np.isfinite(h), h, np.inf), axis=1, keepdims=True)  # inf: no ankle in that frame
    with np.errstate(invalid="ignore"):
        low = h <= lowest + p.contact_height_leg * leg
        slow = speed < p.contact_speed_leg_s * leg
    contact = low & slow & ok[:, None] & np.isfinite(h)
    pts, frames, ankle, footfall = [], [], [], []
    next_id = 0
    for side in range(2):
        c = contact[:, side]
        start = c & ~np.r_[False, c[:-1]]
        idx = np.flatnonzero(c)
        pts.append(ank[idx, side])
        frames.append(idx)
        ankle.append(np.full(len(idx), side))
        footfall.append((np.cumsum(start) - 1 + next_id)[idx])
        next_id += int(start.sum())
    return Contacts(np.concatenate(pts), np.concatenate(frames), np.concatenate(ankle), np.concatenate(footfall))


@dataclass(frozen=True)
class FloorFit:
    """The floor's evidence fused with the poses' (module docstring).

    up: ``(3,)`` the posterior mode (``u0`` where the contacts constrain no tilt);
    cov: ``(2, 2)`` rad^2 its covariance in the (pitch, roll) basis at ``u0``;
    informative: how many tilt directions the contacts constrain (0, 1 or 2);
    residual: the footfalls' RMS height residual about their fitted levels (input unit);
    levels: how many support levels the footfalls rest on (:func:`support_levels`)."""

    up: np.ndarray
    cov: np.ndarray
    informative: int
    residual: float
    levels: int = 1


def footfalls(c: Contacts) -> tuple[np.ndarray, np.ndarray]:
    """``(points (F, 3), ankle (F,))``: each footfall's mean contact position and its ankle."""
    ids, inverse = np.unique(c.footfall, return_inverse=True)
    points = np.zeros((len(ids), 3))
    np.add.at(points, inverse, c.points)
    points /= np.bincount(inverse, minlength=len(ids))[:, None]
    ankle = np.zeros(len(ids), np.int64)
    ankle[inverse] = c.ankle
    return points, ankle


def support_levels(heights: np.ndarray, scale: float) -> np.ndarray:
    """``(F,)`` int level of each footfall height ``(F,)``: sorted heights start a new level
    where they jump by more than Tukey's cut-off ``TUKEY_C * scale`` (no footfall beyond it
    can be an inlier of the level below)."""
    order = np.argsort(heights)
    level = np.empty(len(heights), np.int64)
    level[order] = np.r_[0, np.cumsum(np.diff(heights[order]) > TUKEY_C * scale)]
    return level


def levels_objective(heights: np.ndarray, scale: float) -> float:
    """The floor's negative log-likelihood (module docstring) of footfall heights ``(F,)``
    along a candidate normal, the levels' heights at their medians and the ankles' errors at 0:
    Tukey's loss of each footfall about its level plus ``c^2 / 6`` (one unexplained footfall's
    cost) for each level beyond the first."""
    level = support_levels(heights, scale)
    n_levels = int(level.max()) + 1
    centre = np.array([np.median(heights[level == k]) for k in range(n_levels)])
    x = np.minimum(((heights - centre[level]) / (TUKEY_C * scale)) ** 2, 1.0)
    return float(np.sum(TUKEY_C ** 2 / 6 * (1 - (1 - x) ** 3)) + (n_levels - 1) * TUKEY_C ** 2 / 6)


def _coarse_tilt(h: np.ndarray, q: np.ndarray, scale: float, prior_cov: np.ndarray,
                 prior_inv: np.ndarray) -> np.ndarray:
    """``(2,)`` rad: the best tilt on a grid over +-3 prior standard deviations (the posterior
    is multimodal in the tilt: along a wrong normal a long walk's footfalls spread over
    several levels), by :func:`levels_objective` plus the prior's (``prior_inv`` the inverse of
    ``prior_cov``)."""
    sd = np.sqrt(np.max(np.linalg.eigvalsh(prior_cov)))
    axis = np.linspace(-3.0 * sd, 3.0 * sd, _COARSE_STEPS)
    tilts = np.stack(np.meshgrid(axis, axis, indexing="ij"), -1).reshape(-1, 2)
    cost = [levels_objective(h + q @ t, scale) + 0.5 * float(t @ prior_inv @ t) for t in tilts]
    return tilts[int(np.argmin(cost))]


def fit_floor(c: Contacts, u0: np.ndarray, prior_cov: np.ndarray, leg: float,
              p: UpModelParameters) -> FloorFit:
    """Fuse the floor contacts ``c`` with the poses' posterior ``N(u0, prior_cov)`` (module
    docstring). ``u0`` ``(3,)`` unit up, camera frame; ``prior_cov`` ``(2, 2)`` rad^2 in the
    (pitch, roll) basis of :func:`pcnet.stages.up_model.tangent_basis` at ``u0``; ``leg`` the
    leg length (input unit), which scales ``sigma_f`` and ``s_o``."""
    e1, e2 = (np.asarray(e, np.float64) for e in tangent_basis(u0))
    if len(c.points) == 0:
        return FloorFit(u0, prior_cov, 0, float("nan"), 0)
    P, ankle = footfalls(c)
    h, q = P @ u0, np.column_stack([P @ e1, P @ e2])
    scale = p.footfall_height_sd_leg * leg
    prior_inv = np.linalg.inv(prior_cov)
    tilt = _coarse_tilt(h, q, scale, prior_cov, prior_inv)
    for _ in range(_IRLS_STEPS):
        level = support_levels(h + q @ tilt, scale)
        n_levels = int(level.max()) + 1
        n_nuisance = n_levels + 2
        A = np.column_stack([np.eye(n_levels)[level], np.eye(2)[ankle], -q])
        # The prior (levels flat, the ankles' errors, the poses' tilt), in units of scale^2
        # so that the Tukey weights below enter unscaled.
        ridge = np.zeros((n_nuisance + 2, n_nuisance + 2))
        ridge[n_levels:n_nuisance, n_levels:n_nuisance] = np.eye(2) * (scale / (p.ankle_offset_leg * leg)) ** 2
        ridge[n_nuisance:, n_nuisance:] = prior_inv * scale ** 2
        theta = np.r_[[np.median((h + q @ tilt)[level == k]) for k in range(n_levels)], 0.0, 0.0, tilt]
        for _ in range(_IRLS_STEPS):
            x = (h - A @ theta) / scale
            wts = tukey_weights(x)
            new = np.linalg.lstsq((A.T * wts) @ A + ridge, (A.T * wts) @ h, rcond=None)[0]
            done = np.max(np.abs(new - theta)) < 1e-12
            theta = new
            if done:
                break
        moved = np.max(np.abs(theta[n_nuisance:] - tilt))
        tilt = theta[n_nuisance:]
        if moved < 1e-9:
            break
    # Laplace at the mode: the floor's own information on the tilt, the levels and the
    # ankles' errors marginalised, fused with the poses' posterior.
    M = (A.T * wts) @ A / scale ** 2
    v = (A.T * wts) @ h / scale ** 2
    M[:n_nuisance, :n_nuisance] += ridge[:n_nuisance, :n_nuisance] / scale ** 2
    Mnn_inv, Mnb, Mbb = np.linalg.pinv(M[:n_nuisance, :n_nuisance]), M[:n_nuisance, n_nuisance:], M[n_nuisance:, n_nuisance:]
    info = Mbb - Mnb.T @ Mnn_inv @ Mnb
    z = v[n_nuisance:] - Mnb.T @ Mnn_inv @ v[:n_nuisance]
    info = 0.5 * (info + info.T)
    keep = np.linalg.eigvalsh(info) * np.max(np.linalg.eigvalsh(prior_cov)) > _RANK_TOL
    k = int(keep.sum())
    residual = float(np.sqrt(np.mean((h - A @ theta) ** 2)))
    if k == 0:
        return FloorFit(u0, prior_cov, 0, residual, n_levels)
    cov = np.linalg.inv(info + prior_inv)
    a, b = cov @ z
    return FloorFit(normalize(u0 + a * e1 + b * e2), cov, k, residual, n_levels)


@dataclass(frozen=True)
class FloorOutcome:
    """:func:`ground_plane_up`'s answer: ``fit`` (``None`` where no contact was found or the
    joints cannot carry a floor), ``contacts`` (``None`` likewise) and ``info`` the report's
    diagnostics: ``used`` (the floor moved the up), ``reason`` (``ok`` or why not),
    ``n_contacts``, ``n_footfalls``, ``n_levels`` (support levels), ``residual_over_leg``, ``correction_deg``;
    ``leg`` the leg length the contacts were scaled by (input unit; NaN without legs)."""

    up: np.ndarray
    fit: FloorFit | None
    contacts: Contacts | None
    info: dict
    leg: float = float("nan")


def ground_plane_up(J, ok: np.ndarray, u0: np.ndarray, fps: float, prior_cov: np.ndarray,
                    p: UpModelParameters | None = None) -> FloorOutcome:
    """The up refined by the floor contacts of a recording with a pelvis path (measured, or
    recovered from 2D keypoints).

    Contacts are detected along ``u0``, the floor fused (:func:`fit_floor`), and the contacts
    re-detected once along the fused up and fused again (the prior stays ``u0``'s).

    Args:
        J: ``(T, 17, 3)`` float H36M-17 poses in the camera frame with the pelvis path added
            (any length unit); a pelvis exactly fixed on a camera axis (root-relative or
            depth-pinned joints) carries no floor and is refused with that reason.
        ok: ``(T,)`` bool, the frames to use.
        u0: ``(3,)`` unit up of the poses (camera frame).
        fps: frame rate, Hz.
        prior_cov: ``(2, 2)`` rad^2, the poses' posterior covariance in the (pitch, roll) basis at ``u0``.
        p: the up model's parameters (default: the shipped ones).

    Returns:
        :class:`FloorOutcome`.
    """
    p = default_parameters() if p is None else p
    fin = ok & np.isfinite(np.asarray(J[:, [PELVIS, R_ANKLE, L_ANKLE, R_HIP, L_HIP, R_KNEE, L_KNEE]])).all((1, 2))
    leg = leg_length(J, fin) if fin.any() else float("nan")
    if not np.isfinite(leg) or leg <= 0:
        return FloorOutcome(u0, None, None, {"used": False, "reason": "no frame with both legs"})
    if np.any(np.ptp(_joint(J, PELVIS, fin), axis=0) == 0):
        return FloorOutcome(u0, None, None, {"used": False, "reason": (
            "pelvis fixed on a camera axis: root-relative or depth-pinned joints carry no floor")}, leg)
    contacts = detect_contacts(J, fin, u0, fps, leg, p)
    fit = fit_floor(contacts, u0, prior_cov, leg, p)
    if fit.informative:
        again = detect_contacts(J, fin, fit.up, fps, leg, p)
        if len(again.points):
            contacts, fit = again, fit_floor(again, u0, prior_cov, leg, p)
    info = {"used": bool(fit.informative), "n_contacts": int(len(contacts.points)),
            "n_footfalls": int(len(np.unique(contacts.footfall))), "n_levels": fit.levels,
            "residual_over_leg": float(fit.residual / leg),
            "correction_deg": float(np.degrees(angle_between(fit.up, u0)))}
    if not len(contacts.points):
        info["reason"] = "no quasi-static foot contacts"
    elif not fit.informative:
        info["reason"] = "the contacts constrain no floor tilt"
    else:
        info["reason"] = "ok"
    return FloorOutcome(fit.up, fit, contacts, info, leg)
