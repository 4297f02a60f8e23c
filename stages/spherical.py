"""Robust statistics of directions on the unit sphere: the weighted robust mean direction
(Weiszfeld geometric median, then Tukey-biweight IRLS) that sequence mode pools per-frame up
vectors with (:mod:`pcnet.stages.temporal`), and weighted quantiles.

Shapes: directions ``(N, 3)`` or ``(B, N, 3)`` unit vectors (any frame), weights ``(N,)`` /
``(B, N)``; angles in radians internally, degrees in public constants.
"""

from __future__ import annotations

import numpy as np

from .core.errors import InputError
from .core.rotations import normalize

# Tukey biweight tuning constant (95% efficiency at the Gaussian, Beaton & Tukey 1974).
TUKEY_C = 4.685
# Median of a Rayleigh(sigma) variable is sigma * sqrt(2 ln 2): the angular residual of an
# isotropic 2D Gaussian error in the tangent plane is Rayleigh, so median/1.1774 estimates sigma.
_RAYLEIGH_MEDIAN = float(np.sqrt(2.0 * np.log(2.0)))
# Scale floor: with (near-)exact predictions the residual scale collapses to 0 and every
# weight would become 0/0; 0.25 deg is far below any real estimator's per-frame noise.
MIN_SCALE_DEG = 0.25
_MAX_ITER = 100
# Weiszfeld only provides the start and the scale, so a loose tolerance suffices; the
# Tukey stage converges quickly (and its result is what is returned).
_TOL_WEISZFELD_RAD = 1e-6
_TOL_RAD = 1e-9


def tukey_weights(z: np.ndarray) -> np.ndarray:
    """Tukey's biweight IRLS weights ``(1 - (z / c)^2)^2`` for ``|z| < c``, else 0, with
    ``c =`` :data:`TUKEY_C` (Beaton & Tukey 1974).

    Args:
        z: residuals divided by their scale (any shape; NaN gives weight 0).

    Returns:
        float64 weights in [0, 1], ``z``'s shape.
    """
    r = np.asarray(z, np.float64) / TUKEY_C
    with np.errstate(invalid="ignore"):
        return np.where(np.abs(r) < 1.0, (1.0 - r * r) ** 2, 0.0)


def _angles(m: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Angles ``(B, N)`` (radians) between ``m`` ``(B, 3)`` and unit ``u`` ``(B, N, 3)``,
    with their cosines and sines."""
    cos = np.clip(np.matmul(u, m[:, :, None])[..., 0], -1.0, 1.0)
    sin = np.sqrt(1.0 - cos * cos)
    return np.arctan2(sin, cos), cos, sin


def _tangent_step(m: np.ndarray, u: np.ndarray, coef: np.ndarray, cos: np.ndarray) -> np.ndarray:
    """``sum_i coef_i perp_i`` with ``perp_i = u_i - (u_i.m) m`` (the unnormalised log-map
    direction), without materialising ``perp``: ``coef @ u - (coef . cos) m``."""
    return np.matmul(coef[:, None, :], u)[:, 0] - np.sum(coef * cos, -1)[:, None] * m


def _exp_map(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Exp map of S^2 at ``m`` ``(B, 3)`` of tangent vectors ``v`` ``(B, 3)``."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        direction = np.where(n > 1e-15, v / n, 0.0)
    out = np.cos(n) * m + np.sin(n) * direction
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def weighted_quantile(x: np.ndarray, w: np.ndarray, q: float) -> np.ndarray:
    """Weighted ``q``-quantile along the last axis of ``x`` ``(B, N)`` with weights ``w``
    (zero weights ignored); NaN where all weights are zero. Lower weighted quantile (the
    smallest x whose cumulative weight reaches q), so it is a data value."""
    order = np.argsort(x, axis=-1)
    xs = np.take_along_axis(x, order, -1)
    ws = np.take_along_axis(w, order, -1)
    cw = np.cumsum(ws, -1)
    total = cw[..., -1:]
    idx = np.argmax(cw >= q * total - 1e-12 * total, axis=-1)
    out = np.take_along_axis(xs, idx[..., None], -1)[..., 0]
    return np.where(total[..., 0] > 0, out, np.nan)


def _irls(m: np.ndarray, u: np.ndarray, w: np.ndarray, weight_fn, tol: float) -> np.ndarray:
    """Iteratively reweighted tangent-space mean on S^2: ``m <- exp_m(sum a_i log_m(u_i) /
    sum a_i)`` with ``a = weight_fn(theta, w, rows)``, until the step is below ``tol``
    radians (at most ``_MAX_ITER`` steps). Only unconverged rows of the batch keep iterating."""
    m = m.copy()
    act = np.arange(len(m))
    for _ in range(_MAX_ITER):
        mu, uu = m[act], u[act]
        th, cos, sin = _angles(mu, uu)
        # log_m(u_i) = (theta_i / sin_i) perp_i; below 1e-7 rad the ratio is 1.
        ratio = np.where(sin > 1e-7, th / np.maximum(sin, 1e-300), 1.0)
        a = weight_fn(th, w[act], act)
        tot = a.sum(-1)
        step = _tangent_step(mu, uu, a * ratio, cos) / np.maximum(tot, 1e-300)[:, None]
        step = np.where((tot > 0)[:, None], step, 0.0)
        m[act] = _exp_map(mu, step)
        act = act[np.linalg.norm(step, axis=-1) >= tol]
        if len(act) == 0:
            break
    return m


def robust_mean_direction(
    u: np.ndarray, w: np.ndarray | None = None, init: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Robust mean of unit vectors on the sphere S^2.

    Two stages, both intrinsic (tangent-space updates at the current estimate):

    1. Geometric median by the Riemannian Weiszfeld iteration with unit step (Fletcher,
       Venkatasubramanian & Joshi 2009, "The geometric median on Riemannian manifolds with
       application to robust atlas estimation", NeuroImage 45: S143-S152): breakdown point
       50%, used as the start and to set the residual scale.
    2. Tukey-biweight M-estimate by iteratively reweighted least squares in the tangent space
       (weights ``w_i (1 - (theta_i/c)^2)^2`` for ``theta_i < c``, else 0;
       ``c = 4.685 sigma``), with ``sigma = max(median(theta)/sqrt(2 ln 2), 0.25 deg)``
       fixed from the geometric median's residuals (Rayleigh-consistent scale for isotropic
       tangent-plane noise). Frames beyond ``c`` (about 4 x the median residual) get zero
       weight: a gross outlier does not move the estimate at all.

    Args:
        u: ``(N, 3)`` or ``(B, N, 3)`` unit vectors (NaN rows are ignored).
        w: optional ``(N,)`` / ``(B, N)`` non-negative confidence weights.
        init: optional ``(3,)`` / ``(B, 3)`` start for the Weiszfeld iteration (default:
            the normalised weighted mean); only speeds up convergence.

    Returns:
        ``(m, sigma)``: ``m`` ``(3,)`` / ``(B, 3)`` unit mean direction (NaN if no usable
        vector), ``sigma`` ``()`` / ``(B,)`` the residual scale in radians.

    Raises:
        InputError: ``u`` not ``(N, 3)`` or ``(B, N, 3)``.
    """
    single = np.ndim(u) == 2
    u = np.asarray(u, np.float64)
    if single:
        u = u[None]
    if u.ndim != 3 or u.shape[-1] != 3:
        raise InputError(f"u: expected shape (N, 3) or (B, N, 3), got {np.shape(u)}")
    w = np.ones(u.shape[:2]) if w is None else np.broadcast_to(np.asarray(w, np.float64), u.shape[:2])
    ok = np.isfinite(u).all(-1) & np.isfinite(w) & (w > 0)
    u = np.where(ok[..., None], u, 0.0)
    w = np.where(ok, w, 0.0)
    has = w.sum(-1) > 0

    # Start: normalised weighted mean; if it nearly cancels (antipodal clusters) use the
    # principal axis of the scatter matrix, oriented to the heavier side.
    s = np.matmul(w[:, None, :], u)[:, 0]
    m = normalize(s)
    bad = ~(np.linalg.norm(s, axis=-1) > 1e-6 * np.maximum(w.sum(-1), 1e-300))
    if np.any(bad & has):
        S = np.einsum("bn,bni,bnj->bij", w, u, u)
        ax = np.linalg.eigh(S)[1][..., -1]
        sgn = np.where(np.sum(w * np.sign(np.matmul(u, ax[:, :, None])[..., 0]), -1) < 0, -1.0, 1.0)
        m = np.where((bad & has)[:, None], ax * sgn[:, None], m)
    if init is not None:
        m = np.broadcast_to(normalize(np.asarray(init, np.float64)), m.shape)
    m = np.where(has[:, None] & np.isfinite(m), m, np.array([0.0, 0.0, 1.0]))

    m = _irls(m, u, w, lambda th, ww, sel: ww / np.maximum(th, 1e-12), _TOL_WEISZFELD_RAD)  # Weiszfeld

    th = _angles(m, u)[0]
    sigma = np.maximum(weighted_quantile(th, w, 0.5) / _RAYLEIGH_MEDIAN, np.radians(MIN_SCALE_DEG))
    sigma = np.where(has, sigma, np.nan)
    scale = np.where(has, sigma, 1.0)

    def tukey(th, ww, sel):
        return ww * tukey_weights(th / scale[sel, None])

    m = _irls(m, u, w, tukey, _TOL_RAD)
    m = np.where(has[:, None], m, np.nan)
    return (m[0], sigma[0]) if single else (m, sigma)
