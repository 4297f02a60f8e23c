"""The pelvis path in the camera frame, in metres, from a root-relative metric pose and its 2D
keypoints: a robust perspective fit per frame, then a Rauch-Tung-Striebel smoother over the
sequence with outlier-frame rejection.

Frame and units: the camera frame of ``docs/CONVENTIONS.md`` (OpenCV axes: +x right, +y down,
+z forward, away from the camera), the joints' length unit (metres: the smoother's process
noise :data:`PROCESS_NOISE_Q` is in m^2/s^3), pixels for the keypoints of the image whose
intrinsics are ``K``. NaN = missing, never 0.

Model (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., sec. 6.1, eq. 6.1 with the
calibration matrix ``K`` of that section): a root-relative joint ``X_j`` of frame ``k`` is seen
at ``u_j = pi(K (X_j + t_k))``, ``pi(a, b, c) = (a / c, b / c)``, where ``t_k`` is the pelvis
position in the camera frame. Per frame ``t_k`` has 3 unknowns and each joint gives 2
equations, so 3 joints (:data:`MIN_JOINTS`) are the least that fix it.

1. Per-frame fit (vectorised over frames): a linear start (the projection multiplied out by
   the depth, ``fx (X + tx) + s (Y + ty) - (u - cx)(Z + tz) = 0`` and likewise for ``v``), then
   Gauss-Newton on the reprojection error in pixels with iteratively re-weighted robust
   weights (Huber, then Tukey's biweight at the Huber stage's scale, as in MM-estimation,
   Yohai 1987), each joint also weighted by its 2D confidence. The pixel error, not the linear
   form, is what is minimised: the linear residual is the pixel residual times the joint's
   depth ``Z + tz`` (and ``fx``), so it weights far joints more and has no noise model; the
   pixel error with Gaussian detector noise is the maximum-likelihood criterion.
   Covariance: ``s^2 (J^T W J)^-1`` at the solution (the Gauss-Newton normal matrix), ``s^2``
   the weighted pixel residual variance with ``2 n - 3`` degrees of freedom; so that a frame
   with few joints and a lucky small residual is not over-trusted, ``s^2`` is at least the
   sequence's median frame variance.
2. Smoother: a constant-velocity (Wiener velocity, white-noise acceleration) model per axis,
   process-noise spectral density :data:`PROCESS_NOISE_Q` fitted by maximum likelihood on
   CMU training-subject pelvis trajectories; Kalman filter + Rauch-Tung-Striebel smoother
   (Rauch, Tung & Striebel 1965; Särkkä, *Bayesian Filtering and Smoothing*, 2013, ch. 4 for
   the filter and the discretised Wiener velocity model, ch. 8 for the smoother), with each
   frame's fit covariance as its measurement covariance. Frames without a fit inside the
   fitted span are bridged, their uncertainty growing with the distance to the nearest fit.
   Frames before the first / after the last accepted fit stay NaN: extrapolating a walking
   person's path with a constant-velocity model is a guess, not a measurement.
3. Outlier frames (a 2D track that jumps to another person, a fit on wrong joints): a frame's
   fit is tested against the smoothed path with its smoothed residual ``e = z - p_s``, whose
   covariance is ``R - P_s`` for a frame the smoother used and ``R + P_s`` for one it left out
   (de Jong 1989, "Smoothing and interpolation with the state-space model", JASA 84); a frame
   is rejected where ``e^T C^-1 e`` exceeds the chi-square quantile :data:`OUTLIER_QUANTILE`
   with as many degrees of freedom as ``C`` has usable directions (3, fewer where the path
   cannot check the frame), and the path is smoothed again, until the set of rejected frames
   stops changing (rejected frames are re-tested and may come back; where neighbouring frames
   reject and re-admit each other in a cycle, every frame rejected within the cycle stays out).
   A track switch that lasts long enough to form its own smooth path cannot be
   told from the true one by this test.
4. Body size: a metric pose whose size is off by a fraction ``f`` puts the whole position
   (depth most, in metres) off by the same fraction, in every frame alike; the fit cannot see
   it, so ``size_std_fraction`` (given by the caller) adds ``f^2 t t^T`` to every frame's
   covariance after smoothing (it is a per-recording bias, not per-frame noise).

What the reported uncertainty does not contain: errors of the 3D pose that are correlated
over time (a lifter's slow per-joint offsets, a wrong lean in depth) look like per-frame
noise to the fit but do not average out over frames as the smoother assumes, so on real
lifter output the std is a lower bound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from .core.errors import InputError
from .core.framestore import per_frame
from .spherical import tukey_weights

#: Process-noise spectral density (m^2/s^3, per axis, isotropic) of the constant-velocity
#: model of the pelvis: maximum-likelihood fit of the Wiener velocity model to the exact pelvis
#: trajectories of the CMU training subjects (8, 9, 11, 13, 61: ``select_split(...,
#: "train", "motion-style")``; 62 clips, 18,261 frames at 30 fps) of
#: ``shared/data/mocap/cmu_train_h36m17.npz``, pooled over the three world axes, by
#: ``python -m benchmarks.fit_root_path --data ../shared/data`` (benchmarks/results/fit_root_path.txt;
#: per axis 1.31 / 1.71 / 1.14 with y vertical; 1.63 when the clips are subsampled to 15 fps).
PROCESS_NOISE_Q = 1.384
#: Prior standard deviation (m/s, per axis) of the pelvis velocity at the first fitted frame:
#: the RMS pelvis velocity per axis of the same training clips (same command and file).
VELOCITY_PRIOR_STD = 0.642
#: Fewest joints that determine a frame's position (3 unknowns, 2 equations per joint).
MIN_JOINTS = 3
#: Default 2D confidence below which a joint is not used: pcnet's ``--confidence-threshold``
#: default (``pipeline/config.py`` DEFAULT_CONFIDENCE, restated here because stages do not
#: import the pipeline); callers should pass their own threshold.
DEFAULT_MIN_CONFIDENCE = 0.3
#: Chi-square quantile of the outlier-frame test: a good frame is rejected with probability
#: 1e-3 where the noise model holds.
OUTLIER_QUANTILE = 0.999
#: Huber tuning constant: 95 % efficiency at the Gaussian (Holland & Welsch 1977).
HUBER_K = 1.345
#: Pixel scale floor: only keeps the robust weights defined when residuals vanish (exact
#: synthetic projection); far below any detector's error.
MIN_SCALE_PX = 1e-3
#: Median of a Rayleigh(sigma) variable is sigma * sqrt(2 ln 2): a 2D isotropic Gaussian pixel
#: error's length is Rayleigh, so median / 1.1774 estimates sigma (as in stages/spherical.py).
_RAYLEIGH_MEDIAN = float(np.sqrt(2.0 * np.log(2.0)))
_HUBER_ITERS = 6
_MAX_ITERS = 40
_TOL_M = 1e-9
_MAX_OUTLIER_PASSES = 10


@dataclass(frozen=True, eq=False)
class RootPath:
    """The pelvis path of :func:`root_from_keypoints`.

    position: ``(T, 3)`` float64, camera-frame pelvis position, the joints' length unit; NaN
        where not recovered (before the first / after the last accepted fit).
    std: ``(T, 3)`` float64, 1-sigma uncertainty per camera axis (x, y, z), same unit; NaN
        where ``position`` is NaN.
    frames_fitted: frames with a per-frame perspective fit (accepted or rejected).
    depth_std_median: median of ``std[:, 2]`` over recovered frames (NaN if none).
    cov: ``(T, 3, 3)`` float64 full covariance (depth is correlated with x and y off the
        optical axis; needed to carry the uncertainty into another frame: ``R cov R^T``);
        NaN where ``position`` is NaN.
    frames_rejected: fitted frames rejected as outliers by the smoother's test.
    """

    position: np.ndarray
    std: np.ndarray
    frames_fitted: int
    depth_std_median: float
    cov: np.ndarray | None = None
    frames_rejected: int = 0


def _check_K(K) -> np.ndarray:
    try:
        K = np.asarray(K, np.float64)
    except (TypeError, ValueError):
        raise InputError(f"K: expected a (3, 3) intrinsic matrix of numbers, got {type(K).__name__}") from None
    if K.shape != (3, 3) or not np.isfinite(K).all():
        raise InputError(f"K: expected a finite (3, 3) intrinsic matrix, got shape {K.shape}")
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise InputError(f"K: expected positive focal lengths fx, fy (K[0, 0], K[1, 1]), got {K[0, 0]:g}, {K[1, 1]:g}")
    if not np.allclose(K[2], (0.0, 0.0, 1.0)) or K[1, 0] != 0.0:
        raise InputError(f"K: expected an upper-triangular intrinsic matrix with last row (0, 0, 1), got {K.tolist()}")
    return K


def _project(P: np.ndarray, K: np.ndarray):
    """Pixels ``(n, J)`` u, v of camera-frame points ``P`` ``(n, J, 3)`` and the Jacobians
    ``(n, J, 3)`` of u and v with respect to a translation of ``P`` (H&Z eq. 6.1)."""
    fx, s, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
    iz = 1.0 / P[..., 2]
    x, y = P[..., 0] * iz, P[..., 1] * iz
    u, v = fx * x + s * y + cx, fy * y + cy
    Ju = np.stack([fx * iz, s * iz, -(fx * x + s * y) * iz], -1)
    Jv = np.stack([np.zeros_like(iz), fy * iz, -fy * y * iz], -1)
    return u, v, Ju, Jv


def _row_median(a: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Median of ``a`` over the ``ok`` entries of each row (NaN for a row with none)."""
    n = ok.sum(1)
    srt = np.sort(np.where(ok, a, np.inf), axis=1)
    lo = np.take_along_axis(srt, np.maximum((n - 1) // 2, 0)[:, None], 1)[:, 0]
    hi = np.take_along_axis(srt, np.maximum(n // 2, 0)[:, None], 1)[:, 0]
    return np.where(n > 0, 0.5 * (lo + hi), np.nan)


def _inv3(H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses of symmetric 3 x 3 matrices ``(n, 3, 3)`` by the adjugate (elementwise, much
    faster than LAPACK on many tiny matrices), and which are invertible: ``|det| >
    1e-15 ||H||_F^3`` (that ratio is at most the reciprocal condition number)."""
    a, b, c = H[:, 0, 0], H[:, 0, 1], H[:, 0, 2]
    d, e, f = H[:, 1, 1], H[:, 1, 2], H[:, 2, 2]
    A, B, C = d * f - e * e, c * e - b * f, b * e - c * d
    det = a * A + b * B + c * C
    with np.errstate(invalid="ignore", over="ignore"):
        ok = np.abs(det) > 1e-15 * np.sqrt((H * H).sum((1, 2))) ** 3
    adj = np.stack([A, B, C, B, a * f - c * c, b * c - a * e, C, b * c - a * e, a * d - b * b], -1).reshape(-1, 3, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = adj / np.where(ok, det, 1.0)[:, None, None]
    return inv, ok & np.isfinite(inv).all((1, 2))


def _solve3(H: np.ndarray, g: np.ndarray, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``H^-1 g`` per frame for symmetric ``H`` where ``ok`` and ``H`` is invertible; ``ok``
    narrowed to those."""
    inv, good = _inv3(H)
    ok = ok & good
    return np.where(ok[:, None], (inv @ np.where(ok[:, None], g, 0.0)[..., None])[..., 0], 0.0), ok


def _normal(w: np.ndarray, Ju: np.ndarray, Jv: np.ndarray, ru: np.ndarray, rv: np.ndarray):
    """Gauss-Newton normal matrix ``sum_j w J^T J`` ``(n, 3, 3)`` and gradient ``sum_j w J^T r``
    ``(n, 3)`` of the weighted pixel residuals."""
    wu, wv = (Ju * w[..., None]).swapaxes(1, 2), (Jv * w[..., None]).swapaxes(1, 2)
    H = wu @ Ju + wv @ Jv
    g = (wu @ ru[..., None] + wv @ rv[..., None])[..., 0]
    return H, g


def _residuals(X, t, valid, uo, vo, K):
    P = X + t[:, None, :]
    front = valid & (P[..., 2] > 0)
    u, v, Ju, Jv = _project(np.where(front[..., None], P, (0.0, 0.0, 1.0)), K)
    return front, np.where(front, u - uo, 0.0), np.where(front, v - vo, 0.0), Ju, Jv


def _fit_block(X: np.ndarray, kp: np.ndarray, K: np.ndarray, min_conf: float) -> np.ndarray:
    """Per-frame robust fit of ``n`` frames: ``(n, 15)`` = t (3), ``(J^T W J)^-1`` (9),
    residual variance per unit weight s^2 (px^2), its degrees of freedom, joints used; NaN
    t for frames without a fit."""
    X = np.asarray(X, np.float64)
    kp = np.asarray(kp, np.float64)
    n = len(X)
    out = np.full((n, 15), np.nan)
    if n == 0:
        return out
    conf = kp[..., 2]
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(X).all(-1) & np.isfinite(kp).all(-1) & (conf >= min_conf) & (conf > 0)
    c = np.where(valid, np.clip(np.nan_to_num(conf), 0.0, 1.0), 0.0)
    X = np.where(valid[..., None], X, 0.0)
    uo = np.where(valid, kp[..., 0], 0.0)
    vo = np.where(valid, kp[..., 1], 0.0)
    ok = valid.sum(1) >= MIN_JOINTS
    fx, s, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]

    # Linear start: the projection multiplied out by the depth (exact for noise-free data).
    a_u = np.stack([np.full_like(uo, fx), np.full_like(uo, s), cx - uo], -1)
    b_u = (uo - cx) * X[..., 2] - fx * X[..., 0] - s * X[..., 1]
    a_v = np.stack([np.zeros_like(vo), np.full_like(vo, fy), cy - vo], -1)
    b_v = (vo - cy) * X[..., 2] - fy * X[..., 1]
    H, g = _normal(c, a_u, a_v, b_u, b_v)
    t, ok = _solve3(H, g, ok)
    t = np.where(ok[:, None], t, np.nan)
    # Joints that the start puts behind the camera are left out (they have no projection);
    # a frame left with fewer than MIN_JOINTS has no fit.
    sigma = np.full(n, np.nan)
    done = ~ok
    for it in range(_MAX_ITERS):
        a = np.flatnonzero(~done)  # only frames still moving are iterated
        if not len(a):
            break
        Xa, ca, ta = X[a], c[a], t[a]
        front, ru, rv, Ju, Jv = _residuals(Xa, ta, valid[a], uo[a], vo[a], K)
        rn = np.sqrt(ca * (ru * ru + rv * rv))  # residual length per unit weight
        if it <= _HUBER_ITERS:
            # The monotone Huber stage re-estimates the scale; the redescending Tukey stage
            # keeps the last one (MM-estimation): a scale re-estimated under redescending
            # weights can collapse onto a subset of the joints.
            sigma[a] = np.maximum(_row_median(rn, front) / _RAYLEIGH_MEDIAN, MIN_SCALE_PX)
        z = rn / sigma[a, None]
        if it < _HUBER_ITERS:
            wr = np.minimum(1.0, HUBER_K / np.maximum(z, 1e-300))
        else:
            wr = tukey_weights(z)
        w = np.where(front, ca * wr, 0.0)
        H, gr = _normal(w, Ju, Jv, ru, rv)
        step, good = _solve3(H, -gr, (w > 0).sum(1) >= MIN_JOINTS)
        # Step halving keeps every used joint in front of the camera.
        alpha = np.ones(len(a))
        for _ in range(8):
            zmin = np.where(front, Xa[..., 2] + ta[:, None, 2] + alpha[:, None] * step[:, None, 2], np.inf).min(1)
            alpha = np.where(zmin > 0, alpha, alpha * 0.5)
        t[a] = np.where(good[:, None], ta + alpha[:, None] * step, ta)
        ok[a] = good
        small = np.abs(alpha[:, None] * step).max(1) < _TOL_M
        done[a] = ~good | (small & (it >= _HUBER_ITERS))

    front, ru, rv, Ju, Jv = _residuals(X, np.nan_to_num(t), valid, uo, vo, K)
    with np.errstate(invalid="ignore"):
        z = np.sqrt(c * (ru * ru + rv * rv)) / sigma[:, None]
        wt = tukey_weights(z)
        w = np.where(front & (wt > 0), c * wt, 0.0)
    used = (w > 0).sum(1)
    ok = ok & (used >= MIN_JOINTS) & (np.nan_to_num(t[:, 2]) > 0)
    H, _ = _normal(w, Ju, Jv, ru, rv)
    Hinv, good = _inv3(H)
    ok = ok & good
    Hinv = np.where(ok[:, None, None], Hinv, np.nan)
    dof = 2.0 * used - 3.0
    s2 = (w * (ru * ru + rv * rv)).sum(1) / np.maximum(dof, 1.0)
    out[:, :3] = np.where(ok[:, None], t, np.nan)
    out[:, 3:12] = Hinv.reshape(n, 9)
    out[:, 12] = np.where(ok, np.maximum(s2, MIN_SCALE_PX ** 2), np.nan)
    out[:, 13] = np.where(ok, dof, np.nan)
    out[:, 14] = np.where(ok, used, valid.sum(1))
    return out


def _wiener_velocity(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """Transition ``F`` and process covariance ``Q`` (6 x 6, state [p, v]) of the discretised
    Wiener velocity model (Särkkä 2013, ch. 4): ``Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]`` per axis."""
    I = np.eye(3)
    F = np.block([[I, dt * I], [0 * I, I]])
    Q = q * np.block([[dt**3 / 3 * I, dt**2 / 2 * I], [dt**2 / 2 * I, dt * I]])
    return F, Q


def _rts(z: np.ndarray, R: np.ndarray, use: np.ndarray, F: np.ndarray, Q: np.ndarray, v0: float):
    """Kalman filter + Rauch-Tung-Striebel smoother (Särkkä 2013, ch. 4 and 8) over frames
    ``k0..k1`` (the first and last ``use`` frame), measurement ``z_k = H x_k + r_k``,
    ``H = [I 0]``, ``r_k ~ N(0, R_k)``, state ``x = [p, v]``.

    ``z`` ``(T, 3)`` measured positions, ``R`` ``(T, 3, 3)`` their covariances, ``use`` ``(T,)``
    which to use. Returns smoothed positions ``(T, 3)`` and covariances ``(T, 3, 3)``, NaN
    outside ``k0..k1``. (A parallel associative-scan form was tried: with numpy's batched 6 x 6
    solves it was slower than this loop, about 0.2-0.3 s per 10^4 frames.)"""
    T = len(z)
    pos = np.full((T, 3), np.nan)
    cov = np.full((T, 3, 3), np.nan)
    idx = np.flatnonzero(use)
    if not len(idx):
        return pos, cov
    k0, k1 = idx[0], idx[-1]
    m = k1 - k0 + 1
    zs, Rs, us = z[k0:k1 + 1], R[k0:k1 + 1], use[k0:k1 + 1].tolist()
    xp = np.empty((m, 6)); Pp = np.empty((m, 6, 6))
    xf = np.empty((m, 6)); Pf = np.empty((m, 6, 6))
    # A diffuse position prior updated with the first measurement, and the training set's
    # velocity spread: exactly N([z0, 0], diag(R0, v0^2 I)).
    x = np.concatenate([zs[0], np.zeros(3)])
    P = np.zeros((6, 6)); P[:3, :3] = Rs[0]; P[3:, 3:] = np.eye(3) * v0**2
    xp[0], Pp[0], xf[0], Pf[0] = x, P, x, P
    FT, matmul = F.T, np.matmul
    for i in range(1, m):
        x = matmul(F, x)
        P = matmul(matmul(F, P), FT) + Q
        xp[i], Pp[i] = x, P
        if us[i]:
            Kg = matmul(P[:, :3], np.linalg.inv(P[:3, :3] + Rs[i]))
            x = x + matmul(Kg, zs[i] - x[:3])
            P = P - matmul(Kg, P[:3])
            P = 0.5 * (P + P.T)  # the asymmetric rounding error would otherwise grow
        xf[i], Pf[i] = x, P
    pos[k1], cov[k1] = xf[-1, :3], Pf[-1, :3, :3]
    if m > 1:
        # Smoother gains G_i = Pf_i F^T Pp_{i+1}^-1 do not depend on the backward pass: one batch.
        G = np.linalg.solve(Pp[1:], matmul(F, Pf[:-1])).transpose(0, 2, 1)
        xs, Ps = xf[-1], Pf[-1]
        for i in range(m - 2, -1, -1):
            Gi = G[i]
            xs = xf[i] + matmul(Gi, xs - xp[i + 1])
            Ps = Pf[i] + matmul(matmul(Gi, Ps - Pp[i + 1]), Gi.T)
            pos[k0 + i], cov[k0 + i] = xs[:3], Ps[:3, :3]
    return pos, 0.5 * (cov + cov.transpose(0, 2, 1))


def stretch_starts(segment, T: int) -> np.ndarray:
    """``(S,)`` int: the first frame of each of the ``S`` stretches of equal values of
    ``segment`` ``(T,)`` (:func:`pcnet.stages.flags.track_segments`'s one-body stretches;
    ``[0]`` for ``None``, one stretch).

    Raises:
        InputError: ``segment`` not of shape ``(T,)``.
    """
    if segment is None:
        return np.zeros(1, int)
    segment = np.asarray(segment)
    if segment.shape != (T,):
        raise InputError(f"segment: expected shape ({T},) like joints_cam's frames, got {segment.shape}")
    return np.concatenate([[0], 1 + np.flatnonzero(segment[1:] != segment[:-1])])


def _rts_stretches(z: np.ndarray, R: np.ndarray, use: np.ndarray, F: np.ndarray, Q: np.ndarray, v0: float,
                   starts: np.ndarray):
    """:func:`_rts` over each stretch from ``starts[i]`` to the next start, independently."""
    if len(starts) == 1:
        return _rts(z, R, use, F, Q, v0)
    pos, cov = np.full((len(z), 3), np.nan), np.full((len(z), 3, 3), np.nan)
    for a, b in zip(starts, [*starts[1:], len(z)]):
        pos[a:b], cov[a:b] = _rts(z[a:b], R[a:b], use[a:b], F, Q, v0)
    return pos, cov


def _outlier_stat(e: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``e^T C^+ e`` ``(n,)`` over the directions where ``C`` ``(n, 3, 3)`` is usable, and
    their count (the chi-square degrees of freedom)."""
    lam, V = np.linalg.eigh(C)
    usable = lam > 1e-9 * np.maximum(lam[:, -1:], 1e-300)
    proj = np.einsum("nij,ni->nj", V, e)
    return np.where(usable, proj**2 / np.where(usable, lam, 1.0), 0.0).sum(1), usable.sum(1)


def root_from_keypoints(joints_cam, keypoints2d, K, fps, *, min_confidence: float = DEFAULT_MIN_CONFIDENCE,
                        size_std_fraction: float = 0.0, segment: np.ndarray | None = None) -> RootPath:
    """The camera-frame pelvis path of a root-relative metric pose sequence seen in 2D.

    Args:
        joints_cam: ``(T, 17, 3)`` float, root-relative camera-frame poses (OpenCV axes, pelvis at
            the origin), metres, already scaled to the subject; NaN = missing joint. A numpy
            array or a memmap-like array sliced ``[rows]`` (read in blocks of frames). The
            result is the position of the poses' origin, which is the pelvis for root-relative
            input.
        keypoints2d: ``(T, 17, 3)`` float, x_px, y_px, confidence in [0, 1], in the image whose
            intrinsics are ``K``; NaN = missing.
        K: ``(3, 3)`` intrinsics ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` in pixels, no
            distortion (undistort the keypoints first).
        fps: frame rate (Hz) of the sequence, > 0.
        min_confidence: joints with a 2D confidence below it (or 0, or NaN) are not used; pass
            the run's confidence threshold.
        size_std_fraction: 1-sigma relative error of the pose's metric size (e.g. 0.05 for a
            height known to 5 %); it scales the whole position, depth most, alike in every
            frame, and is added to ``cov``/``std`` after smoothing. 0 (default): the size is
            taken as exact; the caller decides from what the size came from.
        segment: optional ``(T,)`` int, the stretch of one body each frame belongs to (a 2D
            track that switches person: :func:`pcnet.stages.flags.track_segments`). The
            smoother starts afresh wherever it changes, so no stretch's path is pulled towards
            another body's. ``None``: one body throughout.

    Returns:
        :class:`RootPath`: float64 ``position``/``std`` ``(T, 3)`` (and ``cov`` ``(T, 3, 3)``) in
        the joints' unit, NaN before the first and after the last accepted fit (of each
        ``segment`` stretch); frames inside that span without a fit (fewer than :data:`MIN_JOINTS` finite joints at or above
        ``min_confidence``, or rejected as outliers) are bridged by the smoother with a larger
        std.

    Raises:
        InputError: ``joints_cam`` or ``keypoints2d`` not ``(T, 17, 3)`` with the same ``T >= 1``;
            ``K`` not a finite ``(3, 3)`` upper-triangular matrix with positive focal lengths;
            ``segment`` not ``(T,)``;
            ``fps``, ``min_confidence`` or ``size_std_fraction`` out of range; no frame with
            :data:`MIN_JOINTS` usable joints, or none that could be fitted.

    Speed: about 0.5-1 s for 10^4 frames on one core (the per-frame fits are vectorised; the
    smoother is a Python loop of about 20 us per frame and pass, 1-4 passes).

    Formulas: pinhole projection Hartley & Zisserman 2nd ed. eq. 6.1; Tukey biweight (Beaton &
    Tukey 1974) and Huber (1964) weights; Kalman filter and RTS smoother (Rauch, Tung & Striebel
    1965; Särkkä 2013, ch. 4 and 8); smoothed-residual outlier test (de Jong 1989). Details in
    the module docstring.
    """
    shape_j = tuple(getattr(joints_cam, "shape", np.shape(joints_cam)))
    shape_k = tuple(getattr(keypoints2d, "shape", np.shape(keypoints2d)))
    if len(shape_j) != 3 or shape_j[1:] != (17, 3) or shape_j[0] < 1:
        raise InputError(f"joints_cam: expected shape (T, 17, 3) with T >= 1, got {shape_j}")
    if shape_k != shape_j:
        raise InputError(f"keypoints2d: expected shape {shape_j} like joints_cam (x_px, y_px, confidence), got {shape_k}")
    K = _check_K(K)
    try:
        fps = float(fps)
        min_confidence = float(min_confidence)
        size_std_fraction = float(size_std_fraction)
    except (TypeError, ValueError):
        raise InputError(f"fps, min_confidence, size_std_fraction: expected numbers, got {fps!r}, "
                         f"{min_confidence!r}, {size_std_fraction!r}") from None
    if not (np.isfinite(fps) and fps > 0):
        raise InputError(f"fps: expected a frame rate > 0, got {fps}")
    if not 0.0 <= min_confidence <= 1.0:
        raise InputError(f"min_confidence: expected a number in [0, 1], got {min_confidence}")
    if not (np.isfinite(size_std_fraction) and size_std_fraction >= 0):
        raise InputError(f"size_std_fraction: expected a number >= 0, got {size_std_fraction}")
    T = shape_j[0]
    starts = stretch_starts(segment, T)

    class _Pair:  # one sliceable view of both inputs, so per_frame reads them block by block
        def __len__(self):
            return T

        def __getitem__(self, rows):
            return np.concatenate([np.asarray(joints_cam[rows], np.float64),
                                   np.asarray(keypoints2d[rows], np.float64)], -1)

    fit = per_frame(lambda b: _fit_block(b[..., :3], b[..., 3:], K, min_confidence), _Pair())
    t = fit[:, :3]
    Hinv = fit[:, 3:12].reshape(T, 3, 3)
    s2, dof, used = fit[:, 12], fit[:, 13], fit[:, 14]
    fitted = np.isfinite(t).all(1)
    if not fitted.any():
        most = int(np.nanmax(used)) if np.isfinite(used).any() else 0
        if most < MIN_JOINTS:
            raise InputError(f"root path: no frame with enough joints: needed {MIN_JOINTS} finite joints with 2D "
                             f"confidence >= {min_confidence:g} in one frame, found at most {most}")
        raise InputError(f"root path: no frame could be fitted (of {T}, some with {most} usable joints): the "
                         f"2D keypoints do not match the 3D poses seen through K in front of the camera")

    # Sequence-level pixel variance: median frame variance, divided by the median of
    # chi2_nu / nu (Wilson-Hilferty) so that it estimates the mean, not the median.
    nu = float(np.median(dof[fitted]))
    s2_seq = float(np.median(s2[fitted])) / (1.0 - 2.0 / (9.0 * nu)) ** 3
    R = np.maximum(s2, s2_seq)[:, None, None] * Hinv
    z = np.where(fitted[:, None], t, 0.0)
    R = np.where(fitted[:, None, None], R, np.eye(3))

    F, Q = _wiener_velocity(1.0 / fps, PROCESS_NOISE_Q)
    use = fitted.copy()
    crit = chi2.ppf(OUTLIER_QUANTILE, np.arange(4).clip(1))  # by degrees of freedom 0..3
    seen = [use]
    for _ in range(_MAX_OUTLIER_PASSES):
        pos, cov = _rts_stretches(z, R, use, F, Q, VELOCITY_PRIOR_STD, starts)
        # Frames outside the smoothed span (rejected at its ends in an earlier pass) keep
        # their status: there is no path there to test them against.
        test = fitted & np.isfinite(pos).all(1)
        e = z[test] - pos[test]
        C = np.where(use[test][:, None, None], R[test] - cov[test], R[test] + cov[test])
        d2, k = _outlier_stat(e, C)
        new = use.copy()
        new[test] = (d2 <= crit[k]) | (k == 0)
        if not new.any():  # never reject every frame: keep the best-fitting one
            new[np.flatnonzero(test)[np.argmin(d2)]] = True
        if np.array_equal(new, use):
            break
        cycle = [i for i, old in enumerate(seen) if np.array_equal(old, new)]
        if cycle:
            # Neighbouring frames that reject and re-admit each other in turn: drop every
            # frame rejected anywhere in the cycle (conservative: the path is bridged there).
            use = np.logical_and.reduce(seen[cycle[0]:] + [new])
            pos, cov = _rts_stretches(z, R, use, F, Q, VELOCITY_PRIOR_STD, starts)
            break
        use = new
        seen.append(use)
    else:  # not settled within the passes: the path of the last set
        pos, cov = _rts_stretches(z, R, use, F, Q, VELOCITY_PRIOR_STD, starts)

    if size_std_fraction > 0:
        cov = cov + size_std_fraction**2 * pos[:, :, None] * pos[:, None, :]
    std = np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2), 0.0, None))
    std = np.where(np.isfinite(pos), std, np.nan)
    rec = np.isfinite(pos).all(1)
    return RootPath(position=pos, std=std, frames_fitted=int(fitted.sum()),
                    depth_std_median=float(np.median(std[rec, 2])) if rec.any() else float("nan"),
                    cov=cov, frames_rejected=int((fitted & ~use).sum()))
