"""The floor from foot contacts: a plane fitted to the quasi-static lowest ankles of a
sequence whose pelvis really moves (a measured root, e.g. a depth sensor), with the pose-based
up as a Gaussian prior (:func:`ground_plane_up`); sequence mode uses it to refine the up
(:func:`pcnet.stages.temporal.sequence_rectify`).

Shapes: joints ``(T, 17, 3)`` H36M-17 in the camera frame (any length unit), unit up vectors
``(3,)``; angles in degrees at the interface.
"""

from __future__ import annotations

import numpy as np

from .core.conventions import L_ANKLE, L_HIP, L_KNEE, PELVIS, R_ANKLE, R_HIP, R_KNEE
from .core.rotations import angle_between, normalize
from .spherical import TUKEY_C

# Max angle between the pose-based up and the refined up: larger disagreements mean one of the
# two is grossly wrong (stairs, a ramp, feet floating in depth) and we cannot tell which.
# Not smaller: the geometric baseline's trunk-lean bias alone reaches ~15 deg when running.
GROUND_GATE_DEG = 20.0
POSE_PRIOR_DEG = 5.0  # prior std of the pose-based up's systematic tilt error (see ground_plane_up)
_CONTACT_HEIGHT_FRAC = 0.05  # of leg length: "as low as the lowest ankle in that frame"
_CONTACT_SPEED_FRAC = 1.0  # leg lengths per second: quasi-static foot
_SPEED_HALF_WINDOW_S = 0.1  # central difference over +-0.1 s (averages detector jitter)
_MAX_RESIDUAL_FRAC = 0.05  # robust plane residual / leg length: the contacts are coplanar
_MIN_CONTACTS = 20
# A pelvis that moves less than this (std, leg lengths) on some camera axis is taken as
# pinned there: MotionBERT's root depth has std 0.002-0.009 leg lengths over the shared real
# clips. Conservative: a subject walking exactly across the image (constant depth) is also
# skipped, which only costs the refinement.
_MIN_PELVIS_STD_FRAC = 0.02
_MIN_FOOTFALLS = 4
#: The report's reason where the input carries no measured root (root-relative joints).
NO_MEASURED_ROOT = "no measured root: root-relative joints carry no floor"




def _joint(J, j: int, frames: np.ndarray | None = None) -> np.ndarray:
    """Joint ``j`` of ``(T, 17, 3)`` poses (in memory or a
    :class:`~pcnet.stages.core.framestore.FrameArray`) as float64 ``(T, 3)``, or only ``frames``."""
    x = np.asarray(J[:, j], np.float64)
    return x if frames is None else x[frames]


def _leg_length(J, frames: np.ndarray) -> float:
    R_hip, R_knee, R_ankle, L_hip, L_knee, L_ankle = (_joint(J, j, frames) for j in
                                                      (R_HIP, R_KNEE, R_ANKLE, L_HIP, L_KNEE, L_ANKLE))
    legs = [
        np.linalg.norm(R_hip - R_knee, axis=-1) + np.linalg.norm(R_knee - R_ankle, axis=-1),
        np.linalg.norm(L_hip - L_knee, axis=-1) + np.linalg.norm(L_knee - L_ankle, axis=-1),
    ]
    return float(np.nanmedian(np.concatenate(legs)))


def _tangent_basis(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = normalize(helper - np.dot(helper, u) * u)
    return e1, np.cross(u, e1)


def _detect_contacts(J: np.ndarray, ok: np.ndarray, up: np.ndarray, fps: float, leg: float):
    """Quasi-static lowest ankles. Returns points ``(K, 3)``, their frame index ``(K,)`` and
    a footfall id ``(K,)`` (runs of consecutive contact frames of one ankle)."""
    T = len(J)
    ank = np.asarray(J[:, [R_ANKLE, L_ANKLE]], np.float64)  # (T, 2, 3)
    h = ank @ up
    k = max(1, int(round(_SPEED_HALF_WINDOW_S * fps)))
    speed = np.full((T, 2), np.nan)
    if T > 2 * k:
        speed[k:-k] = np.linalg.norm(ank[2 * k :] - ank[: -2 * k], axis=-1) / (2 * k / fps)
    with np.errstate(invalid="ignore"):
        low = h <= np.nanmin(h, axis=1, keepdims=True) + _CONTACT_HEIGHT_FRAC * leg
        slow = speed < _CONTACT_SPEED_FRAC * leg
    contact = low & slow & ok[:, None] & np.isfinite(h)
    pts, frames, foot_ids = [], [], []
    next_id = 0
    for side in range(2):
        c = contact[:, side]
        starts = np.flatnonzero(c & ~np.r_[False, c[:-1]])
        run = np.cumsum(c & ~np.r_[False, c[:-1]]) - 1 + next_id
        idx = np.flatnonzero(c)
        pts.append(ank[idx, side])
        frames.append(idx)
        foot_ids.append(run[idx])
        next_id += len(starts)
    return np.concatenate(pts), np.concatenate(frames), np.concatenate(foot_ids)


def fit_plane_map(P: np.ndarray, foot: np.ndarray, u_pose: np.ndarray, prior_rad: float):
    """MAP tilt of the floor from contact points, with the pose-based up as prior.

    Model: ``n = normalize(u + a e1 + b e2)`` (``e1, e2`` span the plane perpendicular to
    the pose up ``u``); a contact ``p`` on the plane ``n.p = d`` has height
    ``h = p.u = d - a q1 - b q2`` with ``q = (p.e1, p.e2)``. Linear least squares in
    ``(d, a, b)`` with a Gaussian prior ``a, b ~ N(0, prior^2)`` and Tukey-biweight IRLS
    against false contacts. Consecutive contacts of one footfall share most of their error,
    so the data information is scaled by (number of footfalls / number of contacts).
    Returns ``(n, residual_scale, data_std_min_rad)`` or ``None`` if it cannot be fitted.
    """
    e1, e2 = _tangent_basis(u_pose)
    h = P @ u_pose
    A = np.stack([np.ones(len(P)), -(P @ e1), -(P @ e2)], -1)
    n_foot = len(np.unique(foot))
    eff = n_foot / len(P)
    prior = np.diag([0.0, 1.0, 1.0]) / prior_rad**2
    wts = np.ones(len(P))
    theta = np.linalg.lstsq(A, h, rcond=None)[0]
    scale = None
    for _ in range(20):
        r = h - A @ theta
        if scale is None:  # scale from the unregularised fit, fixed afterwards (as above)
            scale = max(1.4826 * np.median(np.abs(r - np.median(r))), 1e-9)
        x = r / (TUKEY_C * scale)
        wts = np.where(np.abs(x) < 1, (1 - x**2) ** 2, 0.0)
        info = eff * (A.T * wts) @ A / scale**2
        new = np.linalg.solve(info + prior, eff * (A.T * wts) @ h / scale**2)
        done = np.max(np.abs(new - theta)) < 1e-12
        theta = new
        if done:
            break
    info = eff * (A.T * wts) @ A / scale**2
    # The data-only angular std along the best-constrained tilt direction: marginalise d.
    try:
        cov_data = np.linalg.inv(info)[1:, 1:]
        data_std = float(np.sqrt(np.min(np.linalg.eigvalsh(cov_data))))
    except np.linalg.LinAlgError:
        data_std = np.inf
    n = normalize(u_pose + theta[1] * e1 + theta[2] * e2)
    return n, float(scale), data_std


def ground_plane_up(J, ok, u_pose, fps, prior_deg, gate_deg):
    """Ground-plane refinement of the up direction from quasi-static foot contacts.

    The contacts (ankles at rest, :func:`_detect_contacts`) are fitted by a plane whose normal
    has a Gaussian prior of std ``prior_deg`` around the pose-based up (:func:`fit_plane_map`),
    refitted once on the contacts re-detected along the refined up.

    Args:
        J: ``(T, 17, 3)`` float H36M-17 poses in the camera frame with an absolute root
            trajectory (any length unit); a root-relative or depth-pinned pelvis is refused.
        ok: ``(T,)`` bool, the frames to use.
        u_pose: ``(3,)`` unit pose-based up, camera frame.
        fps: frame rate, Hz.
        prior_deg: std of the prior on the normal around ``u_pose``, degrees.
        gate_deg: the most the plane normal may differ from ``u_pose``, degrees.

    Returns:
        ``(up, info)``: ``(3,)`` unit up in the camera frame (``u_pose`` itself when the
        plane is not used) and a dict with ``used`` (bool), ``reason`` (why not, or ``ok``),
        ``n_contacts``, ``n_footfalls``, ``residual_over_leg``, ``plane_best_std_deg``,
        ``correction_deg`` (angle between the plane normal and ``u_pose``) when a plane was
        fitted, and ``_contacts`` ``(points, frames, foot)`` when it is used.
    """
    info: dict = {"used": False}
    fin = ok & np.isfinite(J[:, [PELVIS, R_ANKLE, L_ANKLE, R_HIP, L_HIP, R_KNEE, L_KNEE]]).all((1, 2))
    if fin.sum() < _MIN_CONTACTS:
        info["reason"] = "too few frames with finite legs"
        return u_pose, info
    leg = _leg_length(J, fin)
    if not np.isfinite(leg) or leg <= 0:
        info["reason"] = "leg length undefined"
        return u_pose, info
    # Root-relative lifters (VideoPose3D, MotionBERT's root z = 0) pin the pelvis on some axis:
    # feet are then placed relative to the pelvis, and their height below it changes with knee
    # flexion and pelvis bob, so contacts do not trace the floor. Only a pelvis that moves
    # freely in all three axes counts as an absolute trajectory.
    pel_std = np.std(_joint(J, PELVIS, fin), axis=0)
    if np.any(pel_std < _MIN_PELVIS_STD_FRAC * leg):
        info["reason"] = (
            "pelvis (nearly) fixed on a camera axis: root-relative or depth-pinned joints, a subject "
            "in place, or a walk across the view with little vertical or depth motion; foot contacts "
            "cannot span the floor"
        )
        return u_pose, info
    P, frames, foot = _detect_contacts(J, fin, u_pose, fps, leg)
    info.update(n_contacts=int(len(P)), n_footfalls=int(len(np.unique(foot))) if len(P) else 0)
    if len(P) < _MIN_CONTACTS or info["n_footfalls"] < _MIN_FOOTFALLS:
        info["reason"] = f"too few quasi-static foot contacts ({len(P)} contacts, {info['n_footfalls']} footfalls)"
        return u_pose, info
    prior = np.radians(prior_deg)
    n, scale, data_std = fit_plane_map(P, foot, u_pose, prior)
    # One more pass: contacts re-detected along the refined up, prior still the pose up.
    P2, frames2, foot2 = _detect_contacts(J, fin, n, fps, leg)
    if len(P2) >= _MIN_CONTACTS and len(np.unique(foot2)) >= _MIN_FOOTFALLS:
        P, frames, foot = P2, frames2, foot2
        n, scale, data_std = fit_plane_map(P, foot, u_pose, prior)
    tilt = float(np.degrees(angle_between(n, u_pose)))
    info.update(
        n_contacts=int(len(P)),
        n_footfalls=int(len(np.unique(foot))),
        residual_over_leg=scale / leg,
        plane_best_std_deg=float(np.degrees(data_std)),
        correction_deg=tilt,
    )
    if scale > _MAX_RESIDUAL_FRAC * leg:
        info["reason"] = f"contacts not coplanar (residual {scale / leg:.3f} leg lengths)"
    elif data_std > prior:
        info["reason"] = "contacts span too small an area to constrain the tilt"
    elif tilt > gate_deg:
        info["reason"] = f"plane normal {tilt:.1f} deg from the pose-based up (> {gate_deg} deg)"
    else:
        info["used"] = True
        info["reason"] = "ok"
        info["_contacts"] = (P, frames, foot)
        return n, info
    return u_pose, info
