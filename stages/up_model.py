"""One posterior over the up direction of a recording: the evidence of both 3DPCNets, the
lifter's systematic error, the body's posture and a declared camera prior, in one model
(docs/up_model.md writes it down; issue 49).

Notation. ``g`` is the unit up direction (against gravity) in the camera frame (OpenCV axes:
x right, y down, z forward; docs/CONVENTIONS.md), ``L = (0, -1, 0)`` a level camera's up.
Per valid frame ``t`` the two networks give ups ``c_t`` (the paper's camera-frame 3DPCNet,
run on the input turned by ``Q_t``, a quarter turn about the optical axis or none) and
``b_t`` (the body-frame 3DPCNet, equivariant to camera rotation).

Per-frame likelihood (upright body). Each network reads the up with a heavy-tailed error,
a von Mises-Fisher (vMF) density mixed with a uniform outlier share ``eps``::

    p(u | h, kappa) = (1 - eps) vMF(u; h, kappa) + eps / (4 pi)

Both networks read with one precision ``kappa = 1 / sigma^2`` (one scatter for both: the
validation likelihood cannot tell theirs apart, decision 0059). The body-frame network reads
``h = g``. The camera-frame network reads ``g`` too, but it learnt how cameras are held: for a
camera tilted by ``psi`` from level in its input frame (``psi`` = angle between ``g`` and
``L_t = Q_t^T L``) far outside its training views, it falls back to the level camera it knows:
with probability ``lambda(psi) = 1 / (1 + exp(-(psi - psi0) / w))`` it reads ``L_t`` instead
of ``g``. So ``l_t(g) = log[(1 - lambda) p(c_t | g, kappa) + lambda
p(c_t | L_t, kappa)] + log p(b_t | g, kappa)``.

Frames are not independent (a held pose errs the same way for a while): the recording's
log-likelihood is ``F(g) = sum_t l_t(g) / m`` with ``m = max(1, tau fps)`` frames per
independent error, ``tau`` the errors' integrated autocorrelation time (a power likelihood).
Its maximiser ``g_hat`` and the inverse of its negative Hessian ``C_L`` (2x2, tangent plane)
summarise the poses (Laplace's approximation).

Systematic error. The lifter's error moves every frame's up the same way, so on top of
``C_L`` the summary errs by ``delta ~ N(0, S)`` with ``S = diag(s_pitch^2, s_roll^2)`` in
the (pitch, roll) directions at ``g``.

Posture. Upright: ``g_hat ~ N(g, C_L + S)``. Lying: both networks read the trunk as up,
which then lies in the floor plane: ``g_hat`` is uniform in azimuth about ``g`` with elevation
``asin(g_hat . g) ~ N(0, sigma_lie^2 + tr(C_L + S) / 2)``. Prior ``P(lying) = rho``.

Camera prior (declared, docs/CONVENTIONS.md's "paper" frontal pitch and "handheld" roll): camera
pitch ``N(0, prior_pitch^2)`` and roll ``N(0, prior_roll^2)`` with a uniform share ``eps_cam``
for cameras outside them (declared from no data: decision 0038).

Floor contacts. Where the joints carry a pelvis path (a depth sensor's, or one recovered from
2D keypoints), the resting ankles trace the floor, whose normal is ``g``. Their likelihood, at
a learning rate ``t_f`` (footfalls err together), weighs in the posture's posterior on the
sphere grid (:func:`posture_log_weights`), and :mod:`pcnet.stages.ground_plane` then fuses it
with an upright posterior (its parameters are this model's too).

Answers. Static camera (``sequence``): the posterior ``p(g, posture | g_hat)`` on a sphere grid
gives the more probable posture and its mode; the 95 % intervals are the
posterior's. Per-frame answers and a moving camera (a random walk of the up) are the same model
with one frame's likelihood or a time-varying ``g``; both were measured and are not shipped
(docs/up_model.md, ``benchmarks/up_model_variants.py``): frame mode and smooth mode keep the
ensemble's per-frame estimate (:mod:`pcnet.models.view_gate`).

Every number above but the declared camera and posture priors is fitted on validation or training data by
``python -m benchmarks.fit_up_model --data ../shared/data`` into ``stages/data/up_model.json``,
which records each value's provenance (:class:`UpModelParameters`), except the floor contacts'
``sigma_f`` and ``t_f``, fitted on its posterior by ``benchmarks.fit_floor_contacts`` and then
``benchmarks.fit_floor_power``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, fields
from importlib import resources

import numpy as np

from .core.errors import InputError
from .core.rotations import UPSIDE_DOWN_TILT_DEG, camera_pitch_roll, camera_tilt_deg, normalize
from .spherical import robust_mean_direction, weighted_quantile

LEVEL_UP = np.array([0.0, -1.0, 0.0])
#: Normal quantile of a two-sided 95 % interval.
Z95 = 1.959964
_FD_STEP = 1e-4  # rad, finite differences of the Laplace step
_NEWTON_STEPS = 25
_GRID_POINTS = 40_000  # about 1 deg between neighbours
#: The coarse grid whose best point starts one more ascent of ``F`` (about 4.5 deg apart), and
#: the most frames (evenly spaced) it is scored on: that start only has to land in the right basin.
_START_GRID_POINTS = 2_000
_START_GRID_FRAMES = 2_000
_START_GRID_CHUNK = 100  # grid points scored at once: (100, 2000, 3) float64 arrays, about 5 MB
#: A posture not reported that keeps at least this posterior probability is reached by the 95 %
#: intervals (a region holding 95 % must hold some of it; decision 0024).
OTHER_POSTURE_P = 0.05
#: Grid points holding less than this share of the largest weight of the poses' posterior are
#: left out once the floor weighs in (all of them together hold at most 4e-8 of its largest weight).
_FLOOR_SUPPORT = 1e-12


# ============================================================================ parameters


@dataclass(frozen=True)
class UpModelParameters:
    """The model's parameters (module docstring); angles in degrees.

    Attributes:
        network_sigma_deg: ``sigma``, both networks' scatter. camera_fallback_deg,
        camera_fallback_width_deg: ``psi0``, ``w``.
        outlier_share: ``eps``. error_time_s: ``tau``. systematic_pitch_deg,
        systematic_roll_deg: ``s_pitch``, ``s_roll``. lying_elevation_deg: ``sigma_lie``.
        lying_prior: ``rho``. camera_prior_pitch_deg,
        camera_prior_roll_deg, camera_prior_outside: the declared camera prior.
        footfall_height_sd_leg: the floor contacts' ``sigma_f`` (leg lengths);
        footfall_posture_power: ``t_f``, the
        footfalls' learning rate in the posture's posterior (:mod:`pcnet.stages.ground_plane`).
        provenance: for each name, where its value comes from (split, command, or "declared").
    """

    network_sigma_deg: float
    camera_fallback_deg: float
    camera_fallback_width_deg: float
    outlier_share: float
    error_time_s: float
    systematic_pitch_deg: float
    systematic_roll_deg: float
    lying_elevation_deg: float
    lying_prior: float
    camera_prior_pitch_deg: float
    camera_prior_roll_deg: float
    camera_prior_outside: float
    footfall_height_sd_leg: float
    footfall_posture_power: float
    provenance: dict

    @classmethod
    def load(cls, text: str | None = None) -> UpModelParameters:
        """Parse ``stages/data/up_model.json`` (or ``text`` in its format:
        ``{"parameters": {name: {"value": float, "provenance": str}}}``).

        Raises:
            InputError: a missing or non-finite parameter, or one outside its range.
        """
        if text is None:
            text = resources.files("pcnet.stages").joinpath("data/up_model.json").read_text()
        entries = json.loads(text)["parameters"]
        names = [f.name for f in fields(cls) if f.name != "provenance"]
        values, provenance = {}, {}
        for name in names:
            entry = entries.get(name)
            if not isinstance(entry, dict) or not isinstance(entry.get("value"), (int, float)) \
                    or not np.isfinite(entry["value"]):
                raise InputError(f"up_model.json: parameters.{name}: expected a finite value, got {entry!r}")
            values[name], provenance[name] = float(entry["value"]), str(entry.get("provenance", ""))
        out = cls(**values, provenance=provenance)
        for name in ("network_sigma_deg", "error_time_s", "systematic_pitch_deg",
                     "systematic_roll_deg", "lying_elevation_deg", "camera_prior_pitch_deg", "camera_prior_roll_deg",
                     "camera_fallback_width_deg", "footfall_height_sd_leg", "footfall_posture_power"):
            if not getattr(out, name) > 0:
                raise InputError(f"up_model.json: parameters.{name}: expected > 0, got {getattr(out, name)}")
        for name in ("outlier_share", "lying_prior", "camera_prior_outside"):
            if not 0 <= getattr(out, name) < 1:
                raise InputError(f"up_model.json: parameters.{name}: expected in [0, 1), got {getattr(out, name)}")
        return out


_DEFAULT: UpModelParameters | None = None


def default_parameters() -> UpModelParameters:
    """The shipped :class:`UpModelParameters` (loaded once)."""
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = UpModelParameters.load()
    return _DEFAULT


# ============================================================================ evidence


@dataclass(frozen=True, eq=False)
class UpEvidence:
    """What the networks say about one recording of ``T`` frames.

    camera_up, body_up: ``(T, 3)`` float64 unit ups in the camera frame from the camera-frame
    and body-frame 3DPCNet (NaN = that network gave none). camera_turn: ``(T, 3, 3)`` the
    quarter turn ``Q_t`` the camera-frame network's input was turned by (``X @ Q_t.T``), or
    ``None`` for none. valid: ``(T,)`` bool, frames with at least one up."""

    camera_up: np.ndarray
    body_up: np.ndarray
    camera_turn: np.ndarray | None
    valid: np.ndarray

    @classmethod
    def of(cls, camera_up, body_up, camera_turn=None) -> UpEvidence:
        """Checked evidence: shapes, NaN for non-finite rows.

        Raises:
            InputError: ``camera_up`` / ``body_up`` not ``(T, 3)`` alike, or ``camera_turn`` not ``(T, 3, 3)``.
        """
        c, b = (np.asarray(a, np.float64) for a in (camera_up, body_up))
        if c.ndim != 2 or c.shape[1] != 3 or b.shape != c.shape:
            raise InputError(f"camera_up, body_up: expected two (T, 3) arrays, got {c.shape} and {b.shape}")
        if camera_turn is not None:
            camera_turn = np.asarray(camera_turn, np.float64)
            if camera_turn.shape != (len(c), 3, 3):
                raise InputError(f"camera_turn: expected ({len(c)}, 3, 3), got {camera_turn.shape}")
        c, b = normalize(c), normalize(b)
        c[~np.isfinite(c).all(-1)] = np.nan
        b[~np.isfinite(b).all(-1)] = np.nan
        valid = np.isfinite(c).all(-1) | np.isfinite(b).all(-1)
        return cls(c, b, camera_turn, valid)

    def frames(self, keep: np.ndarray) -> UpEvidence:
        """The evidence of the frames ``keep`` (bool ``(T,)`` or indices)."""
        turn = None if self.camera_turn is None else self.camera_turn[keep]
        return UpEvidence(self.camera_up[keep], self.body_up[keep], turn, self.valid[keep])

    def level_up(self) -> np.ndarray:
        """``(T, 3)`` the camera-frame network's level up ``L_t = Q_t^T L`` in camera coordinates."""
        if self.camera_turn is None:
            return np.broadcast_to(LEVEL_UP, self.camera_up.shape)
        return np.einsum("tji,j->ti", self.camera_turn, LEVEL_UP)


# ============================================================================ geometry


def tangent_basis(g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(d_pitch, d_roll)`` each ``(..., 3)``: unit tangents at unit ``g`` ``(..., 3)`` along
    which the camera's roll (about the optical axis z) and pitch change; ``d_roll = z x g``
    normalised (x x g where g is along z), ``d_pitch = g x d_roll``."""
    g = np.asarray(g, np.float64)
    d = np.cross(np.array([0.0, 0.0, 1.0]), g)
    n = np.linalg.norm(d, axis=-1, keepdims=True)
    alt = np.cross(np.array([1.0, 0.0, 0.0]), g)
    d = np.where(n > 1e-6, d, alt)
    d_roll = normalize(d)
    return np.cross(g, d_roll), d_roll


def tangent_per_pitch_roll(g: np.ndarray) -> np.ndarray:
    """``(2,)`` radians of arc along the tangent basis at unit ``g`` ``(3,)`` (camera frame,
    :func:`tangent_basis`) per radian of camera pitch and of camera roll
    (:func:`pcnet.stages.core.rotations.camera_pitch_roll`): ``(1, cos pitch)``. Roll turns
    ``g`` about the optical axis, on a circle of radius ``cos pitch``, so a roll interval is
    ``1 / cos pitch`` times wider than the same spread of ups along the tangent; pitch moves
    ``g`` along a great circle."""
    pitch, _ = camera_pitch_roll(np.asarray(g, np.float64))
    return np.array([1.0, np.cos(pitch)])


def exp_map(g: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Points ``(..., 3)`` at tangent coordinates ``x`` ``(..., 2)`` (radians, (pitch, roll)
    basis of :func:`tangent_basis`) from ``g`` ``(..., 3)``."""
    dp, dr = tangent_basis(g)
    v = x[..., :1] * dp + x[..., 1:] * dr
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.cos(n) * g + np.where(n > 0, np.sin(n) / n, 1.0) * v


def log_map(g: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Tangent coordinates ``(..., 2)`` (radians) of unit ``u`` at unit ``g`` (inverse of :func:`exp_map`)."""
    dp, dr = tangent_basis(g)
    cos = np.clip(np.sum(u * g, -1, keepdims=True), -1.0, 1.0)
    v = u - cos * g
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(s > 1e-12, np.arctan2(s, cos) / s, 1.0)
    v = v * scale
    return np.stack([np.sum(v * dp, -1), np.sum(v * dr, -1)], -1)


def fibonacci_sphere(n: int) -> np.ndarray:
    """``(n, 3)`` float64 near-uniform unit vectors (Fibonacci lattice; Gonzalez 2010, "Measurement
    of areas on a sphere using Fibonacci and latitude-longitude lattices", Math. Geosci. 42)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    phi = np.pi * (1.0 + 5.0 ** 0.5) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)


# ============================================================================ likelihood


def log_vmf_mixture(cos: np.ndarray, kappa: np.ndarray, eps: float) -> np.ndarray:
    """``log((1 - eps) vMF + eps / (4 pi))`` of directions at cosine ``cos`` from the mean, with
    concentration ``kappa`` (> 0, broadcast); vMF on S^2: ``kappa exp(kappa (cos - 1)) / (2 pi (1 - exp(-2 kappa)))``."""
    kappa = np.asarray(kappa, np.float64)
    a = np.log1p(-eps) + np.log(kappa) - np.log(2 * np.pi) - np.log1p(-np.exp(-2 * kappa)) + kappa * (cos - 1.0)
    return a if eps == 0 else np.logaddexp(a, np.log(eps) - np.log(4 * np.pi))


def camera_view_estimate(g: np.ndarray, level: np.ndarray, p: UpModelParameters) -> tuple[np.ndarray, np.ndarray]:
    """For true ups ``g`` ``(T, 3)`` and the camera-frame network's input-frame level ups
    ``level`` ``(T, 3)``: the view tilt ``psi`` ``(T,)`` (rad) and the fallback probability
    ``lambda`` ``(T,)`` (module docstring)."""
    psi = np.arccos(np.clip(np.sum(g * level, -1), -1.0, 1.0))
    lam = 1.0 / (1.0 + np.exp(-(np.degrees(psi) - p.camera_fallback_deg) / p.camera_fallback_width_deg))
    return psi, lam


def frame_log_likelihood(g: np.ndarray, ev: UpEvidence, p: UpModelParameters) -> np.ndarray:
    """``l_t(g)`` ``(..., T)`` of the module docstring for candidate ups ``g`` ``(..., T, 3)``
    (one per frame; a ``(3,)`` or ``(N, 1, 3)`` broadcasts: one up for every frame, or ``N``
    of them); 0 where a network gave nothing, NaN-free."""
    g = np.asarray(g, np.float64)
    g = np.broadcast_to(g, np.broadcast_shapes(g.shape, ev.camera_up.shape))
    level = ev.level_up()
    _, lam = camera_view_estimate(g, level, p)
    kappa = 1.0 / np.radians(p.network_sigma_deg) ** 2
    cos_c = np.sum(ev.camera_up * g, -1)
    cos_b = np.sum(ev.body_up * g, -1)
    with np.errstate(divide="ignore"):
        lc = np.logaddexp(np.log1p(-lam) + log_vmf_mixture(np.nan_to_num(cos_c), kappa, p.outlier_share),
                          np.log(lam) + log_vmf_mixture(np.nan_to_num(np.sum(ev.camera_up * level, -1)), kappa,
                                                        p.outlier_share))
    lb = log_vmf_mixture(np.nan_to_num(cos_b), kappa, p.outlier_share)
    return np.where(np.isfinite(cos_c), lc, 0.0) + np.where(np.isfinite(cos_b), lb, 0.0)


def _derivatives(objective, g: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(value (B,), gradient (B, 2), negative Hessian (B, 2, 2))`` of ``objective`` at ``g``
    ``(B, 3)`` in the (pitch, roll) tangent coordinates, by central differences."""
    h = _FD_STEP
    offsets = np.array([[0, 0], [h, 0], [-h, 0], [0, h], [0, -h], [h, h], [-h, -h]])
    vals = np.stack([objective(exp_map(g, np.broadcast_to(o, (len(g), 2)))) for o in offsets])
    f0 = vals[0]
    grad = np.stack([(vals[1] - vals[2]), (vals[3] - vals[4])], -1) / (2 * h)
    hpp = (vals[1] - 2 * f0 + vals[2]) / h ** 2
    hrr = (vals[3] - 2 * f0 + vals[4]) / h ** 2
    hpr = (vals[5] - vals[1] - vals[3] + 2 * f0 - vals[2] - vals[4] + vals[6]) / (2 * h ** 2)
    return f0, grad, -np.stack([np.stack([hpp, hpr], -1), np.stack([hpr, hrr], -1)], -2)


def maximise_on_sphere(objective, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Damped Newton ascent on S^2 for ``B`` independent 2-parameter problems.

    ``objective(G (B, 3)) -> (B,)`` takes ``B`` unit ups (camera frame, as everywhere in this
    module) and returns one value per problem; ``starts`` ``(S, B, 3)`` candidate starts
    (normalised here; the best result per problem is kept). Derivatives by central differences
    (step ``1e-4`` rad) in the (pitch, roll) tangent plane of :func:`tangent_basis`.
    Returns ``(g (B, 3), value (B,), negative Hessian (B, 2, 2))`` at the maximiser, the Hessian
    in rad^-2 in that tangent basis at ``g``."""
    best_g = best_v = best_h = None
    for g in starts:
        g = normalize(g)
        for _ in range(_NEWTON_STEPS):
            f0, grad, H = _derivatives(objective, g)
            # Levenberg: a positive definite step matrix even away from the maximum.
            lam = np.maximum(0.0, -np.linalg.eigvalsh(H)[:, 0]) + 1e-3 * np.abs(np.trace(H, axis1=1, axis2=2)) + 1e-9
            step = np.linalg.solve(H + lam[:, None, None] * np.eye(2), grad[..., None])[..., 0]
            norm = np.linalg.norm(step, axis=-1, keepdims=True)
            step = np.where(norm > 0.3, step * 0.3 / np.maximum(norm, 1e-12), step)  # trust region, rad
            best = g.copy(), f0.copy()
            for frac in (1.0, 0.5, 0.25, 0.1):  # the best of these fractions of the step
                cand = exp_map(g, frac * step)
                val = objective(cand)
                better = val > best[1]
                best = (np.where(better[:, None], cand, best[0]), np.where(better, val, best[1]))
            moved = np.degrees(np.arccos(np.clip(np.sum(best[0] * g, -1), -1, 1)))
            g = best[0]
            if np.all(moved < 1e-4):
                break
        f0, _, H = _derivatives(objective, g)
        if best_g is None:
            best_g, best_v, best_h = g, f0, H
        else:
            take = f0 > best_v
            best_g = np.where(take[:, None], g, best_g)
            best_v = np.where(take, f0, best_v)
            best_h = np.where(take[:, None, None], H, best_h)
    return best_g, best_v, best_h


def frame_starts(ev: UpEvidence) -> np.ndarray:
    """``(3, T, 3)`` starts per frame for :func:`maximise_on_sphere`: each network's up (camera
    frame; the camera-frame network's, then the body-frame network's) and their normalised mean,
    a missing one (NaN) replaced by the other; NaN where neither network answered."""
    c = np.where(np.isfinite(ev.camera_up), ev.camera_up, ev.body_up)
    b = np.where(np.isfinite(ev.body_up), ev.body_up, ev.camera_up)
    return np.stack([c, b, normalize(c + b)])


def frames_per_error(fps: float, p: UpModelParameters) -> float:
    """``m = max(1, tau fps)``: frames per independent error of the power likelihood."""
    return max(1.0, p.error_time_s * fps)


@dataclass(frozen=True, eq=False)
class PoseSummary:
    """Laplace summary of the poses' likelihood: ``up`` ``(..., 3)`` its maximiser ``g_hat``,
    ``cov`` ``(..., 2, 2)`` ``C_L`` in the (pitch, roll) tangent basis at ``up`` (rad^2)."""

    up: np.ndarray
    cov: np.ndarray


def pd_inverse(H: np.ndarray) -> np.ndarray:
    """Inverse ``(..., 2, 2)`` of symmetric ``H`` ``(..., 2, 2)`` with its eigenvalues floored at
    ``1e-6`` (a flat likelihood -> wide cov): a negative Hessian (rad^-2, (pitch, roll) tangent
    basis) of :func:`maximise_on_sphere` into a positive definite covariance (rad^2, same basis)."""
    w, V = np.linalg.eigh(H)
    w = np.maximum(w, 1e-6)
    return np.einsum("...ij,...j,...kj->...ik", V, 1.0 / w, V)


def likelihood_grid_start(ev: UpEvidence, p: UpModelParameters) -> np.ndarray:
    """``(3,)`` the point of a coarse sphere grid (:func:`fibonacci_sphere`, about 4.5 deg apart)
    where ``F`` is largest among cameras that are not upside down (tilt from image-up below
    :data:`pcnet.stages.core.rotations.UPSIDE_DOWN_TILT_DEG`, as the upside-down warning
    assumes), scored on at most ``_START_GRID_FRAMES`` evenly spaced frames of ``ev`` (valid
    frames only). The networks' robust means can sit between two peaks of ``F`` when they
    disagree over part of a recording (a CMU test clip: 11-19 deg from the truth, the ascent
    from each stopping on a peak whose up was 17 deg off while ``F``'s largest lies 5 deg from
    it); this start reaches the largest."""
    grid = fibonacci_sphere(_START_GRID_POINTS)
    grid = grid[camera_tilt_deg(grid) < UPSIDE_DOWN_TILT_DEG]
    rows = np.unique(np.linspace(0, len(ev.valid) - 1, min(len(ev.valid), _START_GRID_FRAMES)).astype(int))
    frames = ev.frames(rows)
    scores = np.concatenate([frame_log_likelihood(grid[i:i + _START_GRID_CHUNK, None], frames, p).sum(-1)
                             for i in range(0, len(grid), _START_GRID_CHUNK)])
    return grid[int(np.argmax(scores))]


def summarise_recording(ev: UpEvidence, fps: float, p: UpModelParameters) -> PoseSummary:
    """``g_hat`` and ``C_L`` of the whole recording's power likelihood ``F`` (static camera): the
    best of the ascents (:func:`maximise_on_sphere`) from :func:`likelihood_grid_start` and from
    the robust means of :func:`frame_starts`.

    Raises:
        InputError: no valid frame."""
    e = ev.frames(ev.valid)
    if not len(e.valid):
        raise InputError("no frame has an up from either network")
    m = frames_per_error(fps, p)
    seeds = [likelihood_grid_start(e, p)]
    for start in frame_starts(e):  # starts within 0.5 deg of an earlier one lead to the same maximum
        seed = robust_mean_direction(start)[0]
        if all(np.dot(seed, other) < np.cos(np.radians(0.5)) for other in seeds):
            seeds.append(seed)
    seeds = np.stack(seeds)[:, None]
    g, _, H = maximise_on_sphere(lambda G: np.array([frame_log_likelihood(G[0], e, p).sum() / m]), seeds)
    return PoseSummary(g[0], pd_inverse(H[0]))


# ============================================================================ prior and posterior


def _log_handheld(pitch: np.ndarray, roll: np.ndarray, p: UpModelParameters) -> np.ndarray:
    """``log[(1 - eps_cam) N(pitch; 0, prior_pitch) N(roll; 0, prior_roll)]`` (radians in, per
    steradian: near level d(pitch) d(roll) is the area element)."""
    sp, sr = np.radians(p.camera_prior_pitch_deg), np.radians(p.camera_prior_roll_deg)
    return (-0.5 * (pitch / sp) ** 2 - 0.5 * (roll / sr) ** 2 - np.log(2 * np.pi * sp * sr)
            + np.log1p(-p.camera_prior_outside))


def _log_outside(p: UpModelParameters) -> float:
    """``log[eps_cam / (4 pi)]``: the uniform share's density, per steradian."""
    return float(np.log(p.camera_prior_outside) - np.log(4 * np.pi))


def log_camera_prior(g: np.ndarray, p: UpModelParameters) -> np.ndarray:
    """Declared camera prior density (per steradian) at ups ``g`` ``(..., 3)``: pitch and roll
    independent normals (near level, where d(pitch) d(roll) is the area element) mixed with
    a uniform share ``camera_prior_outside``."""
    if p.camera_prior_outside >= 1.0:  # uniform: no prior (the poses alone)
        return np.full(np.shape(g)[:-1], -np.log(4 * np.pi))
    inside = _log_handheld(*camera_pitch_roll(g), p)
    if p.camera_prior_outside == 0:
        return inside
    return np.logaddexp(inside, _log_outside(p))


def camera_outside_probability(pitch_deg, roll_deg, p: UpModelParameters | None = None) -> np.ndarray:
    """How probably the declared camera prior takes a camera of this pitch and roll for one of
    the cameras outside its handheld views: the uniform share's responsibility
    ``eps_cam / (4 pi) / [eps_cam / (4 pi) + (1 - eps_cam) N(pitch) N(roll)]`` (module
    docstring, "Camera prior"; :func:`log_camera_prior`'s two components).

    Args:
        pitch_deg, roll_deg: the camera's pitch and roll (degrees, any broadcastable shapes;
            :func:`pcnet.stages.core.rotations.camera_pitch_roll`'s meaning).
        p: the parameters (default :func:`default_parameters`: the declared prior).

    Returns:
        float64 in [0, 1], the broadcast shape; 1 where the prior is uniform
        (``camera_prior_outside`` 1), 0 where it has no outside share.
    """
    p = p or default_parameters()
    if p.camera_prior_outside >= 1.0:
        return np.ones(np.broadcast(pitch_deg, roll_deg).shape)
    if p.camera_prior_outside == 0:
        return np.zeros(np.broadcast(pitch_deg, roll_deg).shape)
    log_inside = _log_handheld(np.radians(pitch_deg), np.radians(roll_deg), p)
    return 1.0 / (1.0 + np.exp(log_inside - _log_outside(p)))


def systematic_cov(p: UpModelParameters) -> np.ndarray:
    """``S`` ``(2, 2)`` rad^2 in the (pitch, roll) basis."""
    return np.diag(np.radians([p.systematic_pitch_deg, p.systematic_roll_deg]) ** 2)


def _log_normal2(x: np.ndarray, cov: np.ndarray) -> np.ndarray:
    inv = np.linalg.inv(cov)
    return -0.5 * np.einsum("...i,...ij,...j->...", x, inv, x) - np.log(2 * np.pi) - 0.5 * np.log(np.linalg.det(cov))


def log_upright(g: np.ndarray, s: PoseSummary, p: UpModelParameters) -> np.ndarray:
    """``log N(g_hat; g, C_L + S)`` at candidate ups ``g`` ``(..., 3)`` (density of the summary
    per steradian; the tangent coordinates of ``g_hat`` at each ``g``)."""
    return _log_normal2(log_map(g, s.up), s.cov + systematic_cov(p))


def log_lying(g: np.ndarray, s: PoseSummary, p: UpModelParameters) -> np.ndarray:
    """Density of ``g_hat`` per steradian at candidate ups ``g`` ``(..., 3)`` under a lying
    body: uniform azimuth, elevation ``asin(g_hat . g)`` normal with variance
    ``sigma_lie^2 + tr(C_L + S) / 2``."""
    var = np.radians(p.lying_elevation_deg) ** 2 + 0.5 * np.trace(s.cov + systematic_cov(p))
    e = np.arcsin(np.clip(np.sum(g * s.up, -1), -1.0, 1.0))
    return -0.5 * e ** 2 / var - 0.5 * np.log(2 * np.pi * var) - np.log(2 * np.pi * np.maximum(np.cos(e), 1e-6))


@dataclass(frozen=True, eq=False)
class StaticPosterior:
    """The static-camera answer (module docstring).

    up: ``(3,)`` the posterior mode of the posture; posture: ``"upright"`` or ``"lying"``, the
    more probable;
    p_lying: posterior probability of the lying hypothesis; pitch_half_deg, roll_half_deg: 95 %
    half-widths of the camera pitch and roll (that posture's posterior, widened to the whole
    posterior where the other posture keeps at least 5 %); summary: the poses'
    :class:`PoseSummary`; upright_half_deg: the upright hypothesis's own (pitch, roll) 95 %
    half-widths, not widened (NaN where lying is the more probable)."""

    up: np.ndarray
    posture: str
    p_lying: float
    pitch_half_deg: float
    roll_half_deg: float
    summary: PoseSummary
    upright_half_deg: tuple[float, float] = (float("nan"), float("nan"))

    def upright_cov(self) -> np.ndarray:
        """``(2, 2)`` rad^2: the normal covariance in the (pitch, roll) tangent basis at
        :attr:`up` whose 95 % half-widths are the upright hypothesis's own (``upright_half_deg``,
        camera pitch and roll angles, not widened to the other posture), turned into tangent
        radians by :func:`tangent_per_pitch_roll`: the prior the floor contacts are fused with."""
        return np.diag((np.radians(self.upright_half_deg) * tangent_per_pitch_roll(self.up)) ** 2) / Z95 ** 2


_GRID: np.ndarray | None = None


def _grid() -> np.ndarray:
    global _GRID
    if _GRID is None:
        _GRID = fibonacci_sphere(_GRID_POINTS)
    return _GRID


def _half_widths(points: np.ndarray, weights: np.ndarray, mode: np.ndarray) -> tuple[float, float]:
    """95 % half-widths (deg) of pitch and roll about ``mode`` over weighted ``points``."""
    pitch, roll = camera_pitch_roll(points)
    p0, r0 = camera_pitch_roll(mode)
    dp = np.abs(pitch - p0)
    dr = np.abs(np.angle(np.exp(1j * (roll - r0))))
    w = weights[None]
    return (float(np.degrees(weighted_quantile(dp[None], w, 0.95)[0])),
            float(np.degrees(weighted_quantile(dr[None], w, 0.95)[0])))


def posture_log_weights(s: PoseSummary, p: UpModelParameters, lying: bool = True,
                        floor: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(log upright, log lying)`` each ``(G,)``: the unnormalised log posterior of each
    posture at the points of the ~1 deg sphere grid (:func:`fibonacci_sphere`, camera frame).

    ``floor``: the floor's negative log-likelihood at unit ups ``(N, 3) -> (N,)``
    (:class:`pcnet.stages.ground_plane.FloorEnergy`), the same for both postures; it is
    evaluated where either posture holds more than :data:`_FLOOR_SUPPORT` of the largest
    weight, and the rest of the grid is left out (-inf). ``lying=False`` gives the lying
    posture no prior mass (an ablation switch)."""
    grid = _grid()
    prior = log_camera_prior(grid, p)
    with np.errstate(divide="ignore"):  # a declared posture: rho = 0 or 1 (``--posture``)
        lu = np.log1p(-p.lying_prior) + log_upright(grid, s, p) + prior
        ll = np.log(p.lying_prior) + log_lying(grid, s, p) + prior if lying else np.full(len(grid), -np.inf)
    if floor is not None:
        top = max(lu.max(), ll.max())
        keep = np.maximum(lu, ll) > top + np.log(_FLOOR_SUPPORT)
        energy = np.full(len(grid), np.inf)
        energy[keep] = floor(grid[keep])
        energy -= energy[keep].min()
        lu, ll = lu - energy, ll - energy
    return lu, ll


def static_posterior(s: PoseSummary, p: UpModelParameters, lying: bool = True,
                     floor: Callable[[np.ndarray], np.ndarray] | None = None) -> StaticPosterior:
    """Posterior over ``g`` and posture given the recording's :class:`PoseSummary` (module
    docstring), on a ~1 deg sphere grid (:func:`posture_log_weights`; ``lying`` and ``floor``
    as there); the upright mode refined by Newton's method on the poses' terms (the floor's
    fine fit is :func:`pcnet.stages.ground_plane.ground_plane_up`'s)."""
    grid = _grid()
    lu, ll = posture_log_weights(s, p, lying, floor)
    top = max(lu.max(), ll.max())
    w_upright, w_lying = np.exp(lu - top), np.exp(ll - top)
    p_lying = float(w_lying.sum() / (w_upright.sum() + w_lying.sum()))
    both = min(p_lying, 1 - p_lying) >= OTHER_POSTURE_P
    if p_lying > 0.5:
        up, posture = grid[int(np.argmax(ll))], "lying"
        pitch_half, roll_half = _half_widths(grid, w_upright + w_lying if both else w_lying, up)
    else:
        objective = lambda G: log_upright(G, s, p) + log_camera_prior(G, p)  # noqa: E731
        up = maximise_on_sphere(objective, np.stack([s.up, grid[int(np.argmax(lu))]])[:, None])[0][0]
        posture = "upright"
        local = _local_half_widths(s, p, up)
        pitch_half, roll_half = _half_widths(grid, w_upright + w_lying, up) if both else local
        return StaticPosterior(up, posture, p_lying, pitch_half, roll_half, s, local)
    return StaticPosterior(up, posture, p_lying, pitch_half, roll_half, s)


def _local_half_widths(s: PoseSummary, p: UpModelParameters, mode: np.ndarray, n: int = 121) -> tuple[float, float]:
    """Upright posterior's 95 % pitch / roll half-widths on a fine tangent grid at ``mode``
    (the global grid is too coarse for intervals of a few degrees)."""
    sd = np.sqrt(np.max(np.linalg.eigvalsh(s.cov + systematic_cov(p))))
    r = np.linspace(-6 * sd, 6 * sd, n)
    X = np.stack(np.meshgrid(r, r, indexing="ij"), -1).reshape(-1, 2)
    pts = exp_map(np.broadcast_to(mode, (len(X), 3)), X)
    lp = log_upright(pts, s, p) + log_camera_prior(pts, p)
    return _half_widths(pts, np.exp(lp - lp.max()), mode)
