"""The floor from foot contacts: one more likelihood term of the up model for recordings whose
root is measured (a depth sensor; a file whose pelvis is a measured camera-frame path).
docs/up_model.md ("Floor contacts") writes the model down; issue 49.

Contacts. In a frame, an ankle is on the floor when it is within ``h_c L`` of that frame's
lower ankle along the current up and moves slower than ``v_c L`` per second (central
difference over ``+-w`` seconds); ``L`` is the median leg length (hip-knee-ankle). A run of
consecutive contact frames of one ankle is a footfall.

Floor model, in the tangent basis ``(e1, e2)`` = (pitch, roll) directions of
:func:`pcnet.stages.up_model.tangent_basis` at the poses' up ``u0``: the floor normal is
``n = normalize(u0 + a e1 + b e2)``; a footfall ``f`` of ankle ``k(f)`` lies at height::

    h_f = p_f . u0 = d + o_k(f) - a (p_f . e1) - b (p_f . e2) + e_f

``d`` the floor's offset (flat prior); ``o_k ~ N(0, (s_o L)^2)`` each ankle's persistent
height error (a lifter's or a sensor's per-joint bias: with the feet in place, it is what
tilts the plane through them); ``e_i ~ N(0, sigma^2)``, ``sigma`` the contacts' robust residual
scale, with Tukey-biweight weights against false contacts (Beaton & Tukey 1974), and, since
consecutive contacts of one footfall share most of their error, information scaled by
footfalls / contacts. Marginalising ``d`` and ``o_k`` gives the floor's information ``I`` and
vector ``z`` on ``theta = (a, b)``.

Fusion. The poses' posterior is ``theta ~ N(0, C0)``; the up is the product's mode
``theta* = (I + C0^-1)^-1 z``, with covariance ``(I + C0^-1)^-1``. A floor that is not one
plane (stairs, a ramp) is outside the model: the report's ``correction_deg`` and
``residual_over_leg`` show how far the floor moved the up and how well one plane fits the
footfalls. (A heavy-tailed floor term, "the floor is wrong" with some probability, was fitted
on validation and its share was not identifiable: the mean tilt error moved 0.02 deg from a
share of 0.001 to 0.3; docs/decisions/0042.)

Parameters ``h_c``, ``v_c``, ``w``, ``sigma_f`` and ``s_o`` are the up model's
(:class:`pcnet.stages.up_model.UpModelParameters`), fitted on validation data with a measured
root by ``python -m benchmarks.fit_floor_contacts --data ../shared/data``.

Shapes: joints ``(T, 17, 3)`` H36M-17 in the camera frame with the measured root kept (any
length unit), unit ups ``(3,)``, covariances ``(2, 2)`` rad^2 in the (pitch, roll) basis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core.conventions import L_ANKLE, L_HIP, L_KNEE, PELVIS, R_ANKLE, R_HIP, R_KNEE
from .core.rotations import angle_between, normalize
from .spherical import TUKEY_C
from .up_model import UpModelParameters, default_parameters, tangent_basis

_IRLS_STEPS = 20
#: The report's reason where the joints carry no measured root.
NO_MEASURED_ROOT = "no measured root: root-relative joints carry no floor"
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
    with np.errstate(invalid="ignore"):
        low = h <= np.nanmin(h, axis=1, keepdims=True) + p.contact_height_leg * leg
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
    residual: the footfalls' RMS height residual about the fitted floor (input unit)."""

    up: np.ndarray
    cov: np.ndarray
    informative: int
    residual: float


def footfalls(c: Contacts) -> tuple[np.ndarray, np.ndarray]:
    """``(points (F, 3), ankle (F,))``: each footfall's mean contact position and its ankle."""
    ids, inverse = np.unique(c.footfall, return_inverse=True)
    points = np.zeros((len(ids), 3))
    np.add.at(points, inverse, c.points)
    points /= np.bincount(inverse, minlength=len(ids))[:, None]
    ankle = np.zeros(len(ids), np.int64)
    ankle[inverse] = c.ankle
    return points, ankle


def fit_floor(c: Contacts, u0: np.ndarray, prior_cov: np.ndarray, leg: float,
              p: UpModelParameters) -> FloorFit:
    """Fuse the floor contacts ``c`` with the poses' posterior ``N(u0, prior_cov)`` (module
    docstring). ``u0`` ``(3,)`` unit up, camera frame; ``prior_cov`` ``(2, 2)`` rad^2 in the
    (pitch, roll) basis of :func:`pcnet.stages.up_model.tangent_basis` at ``u0``; ``leg`` the
    leg length (input unit), which scales ``sigma_f`` and ``s_o``."""
    e1, e2 = (np.asarray(e, np.float64) for e in tangent_basis(u0))
    if len(c.points) == 0:
        return FloorFit(u0, prior_cov, 0, float("nan"))
    P, ankle = footfalls(c)
    h = P @ u0
    A = np.column_stack([np.ones(len(P)), np.eye(2)[ankle], -(P @ e1), -(P @ e2)])
    scale = p.footfall_height_sd_leg * leg
    offset_info = 1.0 / (p.ankle_offset_leg * leg) ** 2
    nuisance_prior = np.diag([0.0, offset_info, offset_info])
    prior_inv = np.linalg.inv(prior_cov)
    # Robust weights from the floor's own fit (the poses' prior does not decide which contacts
    # are false): Tukey IRLS from the least-squares plane, the ankles' offsets under their prior.
    ridge = np.pad(nuisance_prior, ((0, 2), (0, 2)))
    theta = np.linalg.lstsq(A, h, rcond=None)[0]
    for _ in range(_IRLS_STEPS):
        x = (h - A @ theta) / (TUKEY_C * scale)
        wts = np.where(np.abs(x) < 1, (1 - x ** 2) ** 2, 0.0) / scale ** 2
        new = np.linalg.lstsq((A.T * wts) @ A + ridge, (A.T * wts) @ h, rcond=None)[0]
        done = np.max(np.abs(new - theta)) < 1e-12
        theta = new
        if done:
            break
    M, v = (A.T * wts) @ A, (A.T * wts) @ h
    # The floor's own information on the tilt: the offset and the ankles' errors marginalised.
    M = M + np.pad(nuisance_prior, ((0, 2), (0, 2)))
    Mnn_inv, Mnb, Mbb = np.linalg.pinv(M[:3, :3]), M[:3, 3:], M[3:, 3:]
    info = Mbb - Mnb.T @ Mnn_inv @ Mnb
    z = v[3:] - Mnb.T @ Mnn_inv @ v[:3]
    info = 0.5 * (info + info.T)
    keep = np.linalg.eigvalsh(info) * np.max(np.linalg.eigvalsh(prior_cov)) > _RANK_TOL
    k = int(keep.sum())
    residual = float(np.sqrt(np.mean((h - A @ theta) ** 2)))
    if k == 0:
        return FloorFit(u0, prior_cov, 0, residual)
    cov = np.linalg.inv(info + prior_inv)
    a, b = cov @ z
    return FloorFit(normalize(u0 + a * e1 + b * e2), cov, k, residual)


@dataclass(frozen=True)
class FloorOutcome:
    """:func:`ground_plane_up`'s answer: ``fit`` (``None`` where no contact was found or the
    joints cannot carry a floor), ``contacts`` (``None`` likewise) and ``info`` the report's
    diagnostics: ``used`` (the floor moved the up), ``reason`` (``ok`` or why not),
    ``n_contacts``, ``n_footfalls``, ``residual_over_leg``, ``correction_deg``;
    ``leg`` the leg length the contacts were scaled by (input unit; NaN without legs)."""

    up: np.ndarray
    fit: FloorFit | None
    contacts: Contacts | None
    info: dict
    leg: float = float("nan")


def ground_plane_up(J, ok: np.ndarray, u0: np.ndarray, fps: float, prior_cov: np.ndarray,
                    p: UpModelParameters | None = None) -> FloorOutcome:
    """The up refined by the floor contacts of a recording with a measured root.

    Contacts are detected along ``u0``, the floor fused (:func:`fit_floor`), and the contacts
    re-detected once along the fused up and fused again (the prior stays ``u0``'s).

    Args:
        J: ``(T, 17, 3)`` float H36M-17 poses in the camera frame with the measured root kept
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
            "n_footfalls": int(len(np.unique(contacts.footfall))),
            "residual_over_leg": float(fit.residual / leg),
            "correction_deg": float(np.degrees(angle_between(fit.up, u0)))}
    if not len(contacts.points):
        info["reason"] = "no quasi-static foot contacts"
    elif not fit.informative:
        info["reason"] = "the contacts constrain no floor tilt"
    else:
        info["reason"] = "ok"
    return FloorOutcome(fit.up, fit, contacts, info, leg)
