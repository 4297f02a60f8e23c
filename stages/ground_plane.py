"""The floor from foot contacts: one more likelihood term of the up model for recordings with a
camera-frame pelvis path (measured by a depth sensor or given in the file, or recovered from 2D
keypoints by :mod:`pcnet.stages.root_path`).
docs/up_model.md ("Floor contacts") writes the model down; issue 49.

Contacts. In a frame, the lower of the two ankles along the current up is on the floor; a run
of consecutive frames in which one ankle is the lower is a footfall. A foot in swing is seldom
the lower one, and a frame with both feet off the ground (a run's flight, a jump) gives a false
contact that the footfalls' robust loss below discounts. A height band about the lower ankle
and a speed criterion were both switched off on held-out data, and neither helped: they went,
with their three parameters (decision 0065). ``L`` is the median leg length (hip-knee-ankle).

Floor model, in the tangent basis ``(e1, e2)`` = (pitch, roll) directions of
:func:`pcnet.stages.up_model.tangent_basis` at the poses' up ``u0``: the floor normal is
``n = normalize(u0 + a e1 + b e2)``; a footfall ``f`` of ankle ``k(f)`` lies at height::

    h_f = p_f . u0 = d - a (p_f . e1) - b (p_f . e2) + e_f

``d`` the height of the support level the footfall rests on (flat prior; a stool, a step or a
platform is a level of its own: all are horizontal, so every level's footfalls carry the same
normal); ``e_f`` the footfall's own error, of scale ``sigma_f L``, with Tukey's biweight loss
``rho(e_f / (sigma_f L))`` against false contacts (Beaton & Tukey 1974, its 95 %-efficiency
constant ``c``).

Levels. Along the current floor normal, the footfalls' sorted heights start a new level where
they jump by more than ``c sigma_f L``: no footfall beyond the cut-off can be an inlier of the
level below (:func:`support_levels`). One plane through footfalls on two levels tilts towards
the higher one (measured: the CMU test subjects' stool and step takes, 7 of 28 clips beyond 20
deg; docs/decisions/0042).

Posture. The footfalls, detected once along the poses' up, are scored along every candidate up
of either posture (:class:`FloorEnergy`, :func:`pcnet.stages.up_model.posture_log_weights`):
along a lying body's up a walk climbs a support level at every step. Comparing postures over the
whole sphere, the footfalls' loss enters at a learning rate ``t_f`` (``footfall_posture_power``;
a power likelihood, as for a misspecified model: footfalls err together, through a lifter's
per-joint bias and a path's drift), fitted on validation by the log score of the true posture
(``python -m benchmarks.fit_floor_power --data ../shared/data``; decision 0048). The cost of
each level beyond the first is a prior over support levels and is not tempered.

Upright fine fit. With the poses' posterior as the prior of the tilt, ``theta = (a, b) ~ N(0, C0)``,
the floor's MAP minimises, at the same learning rate (one tempered posterior; decision 0081)::

    t_f sum_f rho(e_f / (sigma_f L)) + theta^T C0^-1 theta / 2

by iteratively reweighted least squares, the levels re-assigned along each new normal until the
tilt stops moving. Its Laplace approximation, the levels marginalised, gives the
floor's information ``I`` and the up, ``theta* = (I + C0^-1)^-1 z``. The fused covariance
``(I + C0^-1)^-1`` holds the truth too rarely on held-out data (82-90 % on the CMU test subjects
and DeepMimic, ``benchmarks/results/floor_fine_power.txt``), so the report keeps the up model's
intervals.

A per-ankle persistent height error (``o_k ~ N(0, (s_o L)^2)``, a lifter's per-joint bias) was
part of the model until decision 0091: switched off, no held-out set moved by more than 0.01 deg.

Parameters ``sigma_f`` and ``t_f`` are the up model's
(:class:`pcnet.stages.up_model.UpModelParameters`), fitted on validation data with a pelvis
path by ``python -m benchmarks.fit_floor_contacts --data ../shared/data`` and then
``python -m benchmarks.fit_floor_power --data ../shared/data``.

Shapes: joints ``(T, 17, 3)`` H36M-17 in the camera frame with the pelvis path added (any
length unit), unit ups ``(3,)``, covariances ``(2, 2)`` rad^2 in the (pitch, roll) basis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core.conventions import L_ANKLE, L_HIP, L_KNEE, PELVIS, R_ANKLE, R_HIP, R_KNEE
from .core.rotations import angle_between, normalize
from .spherical import TUKEY_C, tukey_weights
from .up_model import PoseSummary, StaticPosterior, UpModelParameters, default_parameters, static_posterior, tangent_basis

_IRLS_STEPS = 20
#: Grid points per tilt axis of the coarse search (a resolution of half a prior standard
#: deviation; Newton-like IRLS refines from there).
_COARSE_STEPS = 13
#: The report's reason where the joints carry no pelvis path (measured, or recovered from 2D keypoints).
NO_PELVIS_PATH = ("no pelvis path: root-relative joints carry no floor (a measured root, or 2D keypoints with "
                  "metric poses, the lifter's metres or --height, give one)")
#: Why a recording with a pelvis path gets no floor when the up model reads the body as lying.
LYING_NO_FLOOR = ("body read as lying: the footfalls weighed in the posture and its up on the posterior's grid "
                  "(about 1 deg); the fine floor fit is the upright posture's")
#: Why a body read as lying has no floor where the footfalls were left out of its posture (ablation).
FOOTFALLS_LEFT_OUT = "body read as lying: the footfalls were left out of the posture"
#: Why the joints of a recording with a pelvis path give no footfall.
NO_CONTACTS = "no foot contacts (no frame with an ankle)"
#: Candidate ups scored at once by :class:`FloorEnergy` (bounds its (chunk, footfalls) arrays).
_ENERGY_CHUNK = 2_000
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


@dataclass(frozen=True, eq=False)
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


def detect_contacts(J, ok: np.ndarray, up: np.ndarray) -> Contacts:
    """The lower ankle of each ``ok`` frame of ``J`` ``(T, 17, 3)`` along unit ``up`` ``(3,)``
    (module docstring, "Contacts"; both ankles where they are level)."""
    ank = np.asarray(J[:, [R_ANKLE, L_ANKLE]], np.float64)
    h = ank @ up
    lowest = np.min(np.where(np.isfinite(h), h, np.inf), axis=1, keepdims=True)  # inf: no ankle in that frame
    with np.errstate(invalid="ignore"):
        contact = (h <= lowest) & ok[:, None] & np.isfinite(h)
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


@dataclass(frozen=True, eq=False)
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


def levels_terms(heights: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """``(loss, level cost)`` each ``(...)`` of footfall heights ``(..., F)`` along candidate
    normals: the sum of Tukey's loss of each footfall about its level (:func:`support_levels`;
    the levels at their medians), and ``c^2 / 6`` (one unexplained
    footfall's cost) for each level beyond the first, the prior over support levels."""
    S = np.sort(np.asarray(heights, np.float64), axis=-1)
    F = S.shape[-1]
    new = np.concatenate([np.ones(S.shape[:-1] + (1,), bool), np.diff(S, axis=-1) > TUKEY_C * scale], -1)
    idx = np.broadcast_to(np.arange(F), S.shape)
    # Each sorted height's level is a run [start, end) of the sorted heights: its median is the
    # mean of the run's two middle elements (one element for an odd run).
    start = np.maximum.accumulate(np.where(new, idx, 0), axis=-1)
    last = np.concatenate([new[..., 1:], np.ones(S.shape[:-1] + (1,), bool)], -1)
    end = np.flip(np.minimum.accumulate(np.flip(np.where(last, idx, F), -1), axis=-1), -1) + 1
    centre = 0.5 * (np.take_along_axis(S, (start + end - 1) // 2, -1) + np.take_along_axis(S, (start + end) // 2, -1))
    x = np.minimum(((S - centre) / (TUKEY_C * scale)) ** 2, 1.0)
    return np.sum(TUKEY_C ** 2 / 6 * (1 - (1 - x) ** 3), -1), (new.sum(-1) - 1) * TUKEY_C ** 2 / 6


def levels_objective(heights: np.ndarray, scale: float, power: float = 1.0) -> np.ndarray:
    """The floor's negative log-posterior (module docstring) of footfall heights ``(..., F)``
    along candidate normals, ``(...)``: ``power`` (``t_f``) times the footfalls' loss plus the
    levels' cost (:func:`levels_terms`), which the power leaves as it is."""
    loss, levels = levels_terms(heights, scale)
    return power * loss + levels


def _coarse_tilt(h: np.ndarray, q: np.ndarray, scale: float, prior_cov: np.ndarray,
                 prior_inv: np.ndarray, power: float) -> np.ndarray:
    """``(2,)`` rad: the best tilt on a grid over +-3 prior standard deviations (the posterior
    is multimodal in the tilt: along a wrong normal a long walk's footfalls spread over
    several levels), by :func:`levels_objective` at learning rate ``power`` plus the prior's
    (``prior_inv`` the inverse of ``prior_cov``)."""
    sd = np.sqrt(np.max(np.linalg.eigvalsh(prior_cov)))
    axis = np.linspace(-3.0 * sd, 3.0 * sd, _COARSE_STEPS)
    tilts = np.stack(np.meshgrid(axis, axis, indexing="ij"), -1).reshape(-1, 2)
    cost = levels_objective(h + tilts @ q.T, scale, power) + 0.5 * np.einsum("ni,ij,nj->n", tilts, prior_inv, tilts)
    return tilts[int(np.argmin(cost))]


def fit_floor(c: Contacts, u0: np.ndarray, prior_cov: np.ndarray, leg: float,
              p: UpModelParameters) -> FloorFit:
    """Fuse the floor contacts ``c`` with the poses' posterior ``N(u0, prior_cov)`` (module
    docstring). ``u0`` ``(3,)`` unit up, camera frame; ``prior_cov`` ``(2, 2)`` rad^2 in the
    (pitch, roll) basis of :func:`pcnet.stages.up_model.tangent_basis` at ``u0``; ``leg`` the
    leg length (input unit), which scales ``sigma_f``. The footfalls' loss enters at the
    learning rate ``t_f`` (``p.footfall_posture_power``), as in the posture's posterior
    (decision 0081); the prior at full weight."""
    e1, e2 = (np.asarray(e, np.float64) for e in tangent_basis(u0))
    if len(c.points) == 0:
        return FloorFit(u0, prior_cov, 0, float("nan"), 0)
    P = footfalls(c)[0]
    h, q = P @ u0, np.column_stack([P @ e1, P @ e2])
    scale = p.footfall_height_sd_leg * leg
    rate = p.footfall_posture_power
    prior_inv = np.linalg.inv(prior_cov)
    tilt = _coarse_tilt(h, q, scale, prior_cov, prior_inv, rate)
    for _ in range(_IRLS_STEPS):
        level = support_levels(h + q @ tilt, scale)
        n_levels = int(level.max()) + 1
        A = np.column_stack([np.eye(n_levels)[level], -q])
        # The prior (levels flat, the poses' tilt), in units of scale^2 so that the Tukey
        # weights below enter unscaled.
        ridge = np.zeros((n_levels + 2, n_levels + 2))
        ridge[n_levels:, n_levels:] = prior_inv * scale ** 2
        theta = np.r_[[np.median((h + q @ tilt)[level == k]) for k in range(n_levels)], tilt]
        for _ in range(_IRLS_STEPS):
            x = (h - A @ theta) / scale
            wts = rate * tukey_weights(x)
            new = np.linalg.lstsq((A.T * wts) @ A + ridge, (A.T * wts) @ h, rcond=None)[0]
            done = np.max(np.abs(new - theta)) < 1e-12
            theta = new
            if done:
                break
        moved = np.max(np.abs(theta[n_levels:] - tilt))
        tilt = theta[n_levels:]
        if moved < 1e-9:
            break
    # Laplace at the mode: the floor's own information on the tilt, the levels (flat prior)
    # marginalised, fused with the poses' posterior.
    M = (A.T * wts) @ A / scale ** 2
    v = (A.T * wts) @ h / scale ** 2
    Mnn_inv, Mnb, Mbb = np.linalg.pinv(M[:n_levels, :n_levels]), M[:n_levels, n_levels:], M[n_levels:, n_levels:]
    info = Mbb - Mnb.T @ Mnn_inv @ Mnb
    z = v[n_levels:] - Mnb.T @ Mnn_inv @ v[:n_levels]
    info = 0.5 * (info + info.T)
    keep = np.linalg.eigvalsh(info) * np.max(np.linalg.eigvalsh(prior_cov)) > _RANK_TOL
    k = int(keep.sum())
    residual = float(np.sqrt(np.mean((h - A @ theta) ** 2)))
    if k == 0:
        return FloorFit(u0, prior_cov, 0, residual, n_levels)
    cov = np.linalg.inv(info + prior_inv)
    a, b = cov @ z
    return FloorFit(normalize(u0 + a * e1 + b * e2), cov, k, residual, n_levels)


@dataclass(frozen=True, eq=False)
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


def _floor_frames(J, ok: np.ndarray) -> tuple[np.ndarray, float, str | None]:
    """``(frames (T,) bool, leg length, why no floor or None)``: the ``ok`` frames of ``J``
    ``(T, 17, 3)`` with a pelvis and both legs, their leg length (:func:`leg_length`)."""
    fin = ok & np.isfinite(np.asarray(J[:, [PELVIS, R_ANKLE, L_ANKLE, R_HIP, L_HIP, R_KNEE, L_KNEE]])).all((1, 2))
    leg = leg_length(J, fin) if fin.any() else float("nan")
    if not np.isfinite(leg) or leg <= 0:
        return fin, leg, "no frame with both legs"
    if np.any(np.ptp(_joint(J, PELVIS, fin), axis=0) == 0):
        return fin, leg, "pelvis fixed on a camera axis: root-relative or depth-pinned joints carry no floor"
    return fin, leg, None


@dataclass(frozen=True, eq=False)
class FloorEnergy:
    """The floor's negative log-likelihood at any candidate up, for the posture's posterior.

    The footfalls are detected once, along the poses' up (:func:`detect_contacts`), so every
    candidate scores the same observations: ``points`` ``(F, 3)`` their mean positions (camera
    frame, input unit), ``scale`` ``sigma_f L`` and ``power`` ``t_f``. Calling it with unit ups
    ``(N, 3)`` gives :func:`levels_objective` at the power of the footfalls' heights along each,
    ``(N,)``: support levels are horizontal whatever the posture, so a walk read along the wrong
    up climbs a level at every step."""

    points: np.ndarray
    scale: float
    power: float

    def terms(self, ups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`levels_terms` ``(loss (N,), level cost (N,))`` along unit ups ``(N, 3)``."""
        ups = np.asarray(ups, np.float64)
        parts = [levels_terms(ups[i:i + _ENERGY_CHUNK] @ self.points.T, self.scale)
                 for i in range(0, len(ups), _ENERGY_CHUNK)]
        return (np.concatenate([a for a, _ in parts]), np.concatenate([b for _, b in parts])) if parts else \
            (np.zeros(0), np.zeros(0))

    def __call__(self, ups: np.ndarray) -> np.ndarray:
        loss, levels = self.terms(ups)
        return self.power * loss + levels


def floor_energy(J, ok: np.ndarray, u0: np.ndarray,
                 p: UpModelParameters | None = None) -> tuple[FloorEnergy | None, str]:
    """``(energy, why)``: the :class:`FloorEnergy` of a recording with a pelvis path (``J``,
    ``ok`` as :func:`ground_plane_up`'s), its footfalls detected along the poses' unit
    up ``u0`` ``(3,)`` (camera frame), and ``"ok"``; or ``None`` and why the joints carry no
    floor or no footfall."""
    p = default_parameters() if p is None else p
    fin, leg, refused = _floor_frames(J, ok)
    if refused:
        return None, refused
    contacts = detect_contacts(J, fin, u0)
    if not len(contacts.points):
        return None, NO_CONTACTS
    return FloorEnergy(footfalls(contacts)[0], p.footfall_height_sd_leg * leg, p.footfall_posture_power), "ok"


def ground_plane_up(J, ok: np.ndarray, u0: np.ndarray, prior_cov: np.ndarray,
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
        prior_cov: ``(2, 2)`` rad^2, the poses' posterior covariance in the (pitch, roll) basis at ``u0``.
        p: the up model's parameters (default: the shipped ones).

    Returns:
        :class:`FloorOutcome`.
    """
    p = default_parameters() if p is None else p
    fin, leg, refused = _floor_frames(J, ok)
    if refused:
        return FloorOutcome(u0, None, None, {"used": False, "reason": refused}, leg)
    contacts = detect_contacts(J, fin, u0)
    fit = fit_floor(contacts, u0, prior_cov, leg, p)
    if fit.informative:
        again = detect_contacts(J, fin, fit.up)
        if len(again.points):
            contacts, fit = again, fit_floor(again, u0, prior_cov, leg, p)
    info = {"used": bool(fit.informative), "n_contacts": int(len(contacts.points)),
            "n_footfalls": int(len(np.unique(contacts.footfall))), "n_levels": fit.levels,
            "residual_over_leg": float(fit.residual / leg),
            "correction_deg": float(np.degrees(angle_between(fit.up, u0)))}
    if not len(contacts.points):
        info["reason"] = NO_CONTACTS
    elif not fit.informative:
        # a subject standing in place: its feet give the floor's height, not its tilt (an IMU
        # trial read "constrain no floor tilt" beside a fitted floor plane)
        info["reason"] = ("one footfall: feet that stay in one place give the floor's height, not its tilt"
                          if info["n_footfalls"] == 1 else "the contacts constrain no floor tilt")
    else:
        info["reason"] = "ok"
    return FloorOutcome(fit.up, fit, contacts, info, leg)


@dataclass(frozen=True, eq=False)
class PostureFloorUp:
    """:func:`posture_and_floor_up`'s answer: the up model's ``posterior`` (posture and
    intervals), the recording's unit ``up`` ``(3,)`` (camera frame: an upright posture's after
    the fine floor fit, else the posterior's) and ``ground``, the report's ``ground_plane``
    diagnostics (:class:`FloorOutcome`'s ``info``, or ``used`` False and why not)."""

    posterior: StaticPosterior
    up: np.ndarray
    ground: dict


def posture_and_floor_up(summary: PoseSummary, J, ok: np.ndarray, p: UpModelParameters,
                         lying: bool = True, footfalls: bool = True) -> PostureFloorUp:
    """The up of a static camera from the poses and, where ``J`` carries a pelvis path, the
    floor: the footfalls weigh in the posture's posterior (:func:`floor_energy` along the poses'
    up, :func:`pcnet.stages.up_model.static_posterior`; decision 0048), then an upright
    posture's up is fused with the floor contacts (:func:`ground_plane_up`, the upright
    hypothesis's own covariance as its prior; decision 0043).

    Args:
        summary: the recording's :class:`~pcnet.stages.up_model.PoseSummary`.
        J: ``(T, 17, 3)`` float camera-frame poses with the pelvis path added, as
            :func:`ground_plane_up`'s; ``None`` for root-relative joints (no floor).
        ok: ``(T,)`` bool, the frames to use.
        p: the up model's parameters.
        lying: whether the lying posture is a hypothesis (``False`` with ``--no-camera-prior``).
        footfalls: ``False`` leaves the footfalls out of the posture (the chain before decision
            0048, kept for the ablation).
    """
    if J is None:
        energy, reason = None, NO_PELVIS_PATH
    elif not footfalls:
        energy, reason = None, FOOTFALLS_LEFT_OUT
    else:  # the reason stands only where the body reads as lying (an upright one gets the fine fit's)
        energy, why = floor_energy(J, ok, summary.up, p)
        reason = LYING_NO_FLOOR if energy is not None else f"body read as lying; no floor: {why}"
    post = static_posterior(summary, p, lying=lying, floor=energy)
    if J is not None and post.posture == "upright":
        floor = ground_plane_up(J, ok, post.up, post.upright_cov(), p)
        return PostureFloorUp(post, floor.up, floor.info)
    return PostureFloorUp(post, post.up, {"used": False, "reason": reason})
