"""The up model's per-frame and moving-camera variants: measured, not shipped (docs/up_model.md).

    python -m benchmarks.up_model_variants --data ../shared/data

The shipped up model (pcnet.stages.up_model) answers a static camera. The same model answers
one frame (its per-frame likelihood, ``m = 1``, with the prior and the systematic error) and a
moving camera (a random walk of the up: a Kalman filter and Rauch-Tung-Striebel smoother on
the per-frame summaries, each an outlier with the networks' outlier share), and auto mode
becomes a Bayes factor between a static camera, whose summaries still wander at a rate ``q0``,
and a moving one, ``sqrt(q0^2 + q1^2)``. This script fits the two walk rates on validation
data (``q0``: static "paper" and "wide" validation views of benchmarks/fit_up_model.py; ``q1``:
the validation clips with the camera pitch sweeping 30 deg, ``q0`` held; maximum marginal
likelihood, bounded scalar searches) and measures, on the held-out sets of
benchmarks/ablation.py (same caches): per-frame tilt error and the 95 % disc's coverage against
the pair's per-frame estimate (the view gate), static clips read as moving by the Bayes factor,
and the random walk's tilt error on the moving camera. Writes
benchmarks/results/up_model_variants.txt.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from benchmarks import ablation as A
from benchmarks.report import print_and_save, require_folder
from benchmarks import fit_up_model as F
from pcnet.stages.up_model import (PoseSummary, UpEvidence, UpModelParameters, default_parameters, exp_map,
                                   frame_log_likelihood, frame_starts, frames_per_error, log_camera_prior, log_map,
                                   log_upright, maximise_on_sphere, pd_inverse, systematic_cov)

RESULT = Path(__file__).resolve().parent / "results" / "up_model_variants.txt"
#: Radius of a 95 % disc of a 2D standard normal (sqrt of the chi-square(2) 95 % quantile).
R95 = 2.447747
LEVEL_UP = np.array([0.0, -1.0, 0.0])


@dataclass(frozen=True)
class WalkRates:
    """Random-walk rates of the up, deg/sqrt(s): ``static`` (q0) and ``camera`` (q1)."""

    static: float
    camera: float


def summarise_frames(ev: UpEvidence, p: UpModelParameters) -> PoseSummary:
    """Per-frame ``g_hat_t`` ``(T, 3)`` and ``C_L,t`` ``(T, 2, 2)`` (NaN where not valid)."""
    T = len(ev.valid)
    up, cov = np.full((T, 3), np.nan), np.full((T, 2, 2), np.nan)
    if ev.valid.any():
        e = ev.frames(ev.valid)
        g, _, H = maximise_on_sphere(lambda G: frame_log_likelihood(G, e, p), frame_starts(e))
        up[ev.valid], cov[ev.valid] = g, pd_inverse(H)
    return PoseSummary(up, cov)




def frame_posterior(s: PoseSummary, p: UpModelParameters) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame mode ``(T, 3)`` of ``N(g_hat_t; g, C_L,t + S) x prior`` (upright) and the
    radius (deg) ``(T,)`` of its 95 % disc (Laplace; ``R95`` times the RMS axis std). NaN where
    the summary is NaN."""
    T = len(s.up)
    up, radius = np.full((T, 3), np.nan), np.full(T, np.nan)
    ok = np.isfinite(s.up).all(-1)
    if ok.any():
        sub = PoseSummary(s.up[ok], s.cov[ok])
        objective = lambda G: log_upright(G, sub, p) + log_camera_prior(G, p)  # noqa: E731
        g, _, H = maximise_on_sphere(objective, s.up[ok][None])
        cov = pd_inverse(H)
        up[ok] = g
        radius[ok] = np.degrees(R95 * np.sqrt(0.5 * np.trace(cov, axis1=1, axis2=2)))
    return up, radius




# ============================================================================ moving camera


@dataclass(frozen=True)
class WalkResult:
    """Kalman smoother of the random-walk up (module docstring). up ``(T, 3)`` (NaN where not
    valid), std_deg ``(T,)`` RMS axis std of each frame's up, log_evidence (nats)."""

    up: np.ndarray
    std_deg: np.ndarray
    log_evidence: float


def random_walk(s: PoseSummary, fps: float, p: UpModelParameters, rate_deg_per_sqrt_s: float) -> WalkResult:
    """Kalman filter and Rauch-Tung-Striebel smoother of the up's tangent coordinates at the
    summaries' robust mean: state ``y_t = y_{t-1} + w``, ``w ~ N(0, q^2 dt I)``; observations
    the per-frame summaries ``g_hat_t`` with covariance ``m C_L,t`` (``m`` frames per
    independent error), each an outlier (uniform on the sphere) with probability ``eps`` (the
    networks' outlier share; the update weighs a frame by its posterior inlier probability);
    ``y_0 ~ N(level, prior + S)`` (the camera prior's normals and the
    systematic error); walk rate ``rate_deg_per_sqrt_s``."""
    from pcnet.stages.spherical import robust_mean_direction

    q = rate_deg_per_sqrt_s
    ok = np.isfinite(s.up).all(-1)
    T = len(ok)
    up_out, std_out = np.full((T, 3), np.nan), np.full(T, np.nan)
    if not ok.any():
        return WalkResult(up_out, std_out, float("nan"))
    mu, _ = robust_mean_direction(s.up[ok])
    z = log_map(np.broadcast_to(mu, (ok.sum(), 3)), s.up[ok])
    m = frames_per_error(fps, p)
    R = m * s.cov[ok]  # basis at g_hat_t ~ basis at mu for the small angles a recording spans
    idx = np.flatnonzero(ok)
    dt = np.diff(idx, prepend=idx[0]) / fps
    Qrate = np.radians(q) ** 2
    x = log_map(mu, LEVEL_UP)
    P = np.diag(np.radians([p.camera_prior_pitch_deg, p.camera_prior_roll_deg]) ** 2) + systematic_cov(p)
    n = len(idx)
    eps = p.outlier_share
    xf, Pf, xp, Pp = np.zeros((n, 2)), np.zeros((n, 2, 2)), np.zeros((n, 2)), np.zeros((n, 2, 2))
    loglik = 0.0
    eye = np.eye(2)
    for k in range(n):
        if k:
            P = P + Qrate * dt[k] * eye
        xp[k], Pp[k] = x, P
        Sk = P + R[k]
        r = z[k] - x
        Sinv = np.linalg.inv(Sk)
        log_in = np.log1p(-eps) - 0.5 * r @ Sinv @ r - np.log(2 * np.pi) - 0.5 * np.log(np.linalg.det(Sk))
        log_out = np.log(eps) - np.log(4 * np.pi) if eps > 0 else -np.inf
        log_both = np.logaddexp(log_in, log_out)
        loglik += log_both
        # An outlier frame (posterior share 1 - w of the uniform) moves the state by w of the
        # Kalman step: the assumed-density (moment-matched) update of the two-component mixture,
        # mean only, keeping the walk robust to the frames both networks misread.
        w = np.exp(log_in - log_both)
        Sinv = w * Sinv
        K = P @ Sinv
        x = x + K @ r
        P = (eye - K) @ P
        xf[k], Pf[k] = x, P
    xs, Ps = xf.copy(), Pf.copy()
    for k in range(n - 2, -1, -1):
        G = Pf[k] @ np.linalg.inv(Pp[k + 1])
        xs[k] = xf[k] + G @ (xs[k + 1] - xp[k + 1])
        Ps[k] = Pf[k] + G @ (Ps[k + 1] - Pp[k + 1]) @ G.T
    up_out[idx] = exp_map(np.broadcast_to(mu, (n, 3)), xs)
    std_out[idx] = np.degrees(np.sqrt(0.5 * np.trace(Ps, axis1=1, axis2=2)))
    return WalkResult(up_out, std_out, float(loglik))


def camera_moves(s: PoseSummary, fps: float, p: UpModelParameters, rates: WalkRates) -> tuple[bool, float]:
    """``(moving, log Bayes factor)``: the moving camera's walk (``sqrt(q0^2 + q1^2)``) against
    the static camera's (``q0``, the slow wander of the pose-driven error), even prior odds."""
    bf = (random_walk(s, fps, p, float(np.hypot(rates.static, rates.camera))).log_evidence
          - random_walk(s, fps, p, rates.static).log_evidence)
    return bool(bf > 0), float(bf)


def fit_rate(evs, p: UpModelParameters, other: float | None) -> float:
    """Maximum marginal likelihood walk rate: ``q0`` (``other`` None) or ``q1`` with ``q0 = other``."""
    summaries = [(summarise_frames(A.evidence_of(ev), p), ev["fps"]) for ev in evs]

    def nll(log_q):
        q = float(np.exp(log_q))
        rate = q if other is None else float(np.hypot(other, q))
        return -sum(random_walk(s, fps, p, rate).log_evidence for s, fps in summaries)

    return float(np.exp(minimize_scalar(nll, bounds=(np.log(0.01), np.log(50.0)), method="bounded").x))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=A.DEFAULT)
    ap.add_argument("--cache", type=Path, default=A.CACHE)
    ap.add_argument("--max-clips", type=int, default=200)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    require_folder(args.data, "up_model_variants")
    t0 = time.time()
    p = default_parameters()
    val = F.validation_sets(args.data, args.cache)
    static = [e for (tag, views), evs in val.items() if views != "rolled" for e in evs]
    sweeps = F.validation_sweeps(args.cache, val)
    q0 = fit_rate(static, p, None)
    rates = WalkRates(q0, fit_rate(sweeps, p, q0))
    lines = [__doc__.split("\n")[0], "", "    python -m benchmarks.up_model_variants --data ../shared/data", "",
             f"Walk rates (validation): q0 = {rates.static:.3f} deg/sqrt(s) (static 'paper' + 'wide' views, "
             f"{len(static)} clips), q1 = {rates.camera:.3f} (camera pitch sweeping 30 deg, {len(sweeps)} clips)", "",
             f"{'held-out set':<28}{'clips':>6}{'frame err':>10}{'gate':>7}{'95% disc':>9}{'read moving':>12}"
             f"{'walk err':>9}"]
    sets = [(label, A.mocap_set(args.data, args.cache, file, split, args.max_clips))
            for label, file, split in A.MOCAP_SETS]
    sets.append(("Moving camera (30 deg sweep)", A.heldout_sweep(args.cache, [e for _, e in sets], args.max_clips)))
    for label, evs in sets:
        err, gate, inside, moving, walk = [], [], [], 0, []
        for ev in evs:
            s = summarise_frames(A.evidence_of(ev), p)
            up, radius = frame_posterior(s, p)
            e = A.deg(up, ev["true_up"])
            ok = np.isfinite(e)
            err.append(float(np.mean(e[ok])))
            inside.append(e[ok] <= radius[ok])
            gate.append(A.clip_error(ev["frame_up"], ev["true_up"]))
            moving += camera_moves(s, ev["fps"], p, rates)[0]
            walk.append(A.clip_error(random_walk(s, ev["fps"], p, float(np.hypot(*vars(rates).values()))).up,
                                     ev["true_up"]))
        lines.append(f"{label:<28}{len(evs):>6}{np.mean(err):>10.2f}{np.nanmean(gate):>7.2f}"
                     f"{100 * np.mean(np.concatenate(inside)):>8.1f}%{moving:>12}{np.nanmean(walk):>9.2f}")
    lines += ["", "frame err / gate: mean over clips of each clip's mean per-frame tilt error (deg), the up model's "
              "per-frame posterior mode / the pair's per-frame estimate that pcnet ships (view gate); 95% disc: "
              "frames whose error is within the per-frame posterior's 95 % radius; read moving: clips whose Bayes "
              "factor favours the moving camera; walk err: the random walk's tilt error (deg), mean over clips.",
              f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
