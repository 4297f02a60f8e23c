"""Fit the static/moving camera models of benchmarks/camera_motion_model.py on validation clips, and compare the Bayes-factor rule with the spread threshold on held-out data.

    python -m benchmarks.fit_camera_motion --data ../shared/data            # fit
    python -m benchmarks.fit_camera_motion --data ../shared/data --evaluate # held-out comparison

Issue 49, "Static or moving". Per-frame ups: the shipped estimator's per-frame chain of
``pcnet run`` (view-gated pair of networks, quarter turns), rebuilt from the cached network
outputs of benchmarks/ablation.py (its ``extract``/``cached``/``per_frame``; same cache
directory, same format and version), then ``temporal.check_rotations``: exactly the
rotations :func:`pcnet.stages.temporal.choose_mode` sees.

Fit (writes benchmarks/results/fit_camera_motion.txt), VALIDATION data only:
- static camera: the Bandai motion-style validation split (``--fit-clips`` seeded clips,
  ablation.py's subset rule) and the CMU validation subjects (12, 60: every clip), each seen
  by one static "paper" camera with lifter-like noise (``make_pairs(views="paper", seed=0,
  camera="static", noise=LifterNoise())``); maximum likelihood of the static model M0 over
  the white std, the persistent std and time constant, and the Huber corner (Nelder-Mead on
  their logs; the likelihood of the clips is the sum of their log-likelihoods);
- moving camera: the same validation clips with at least 150 frames, the camera pitch
  sweeping linearly through 30 deg over each clip (ablation.py's ``sweep_evidence``);
  maximum likelihood of the moving model M1's random-walk rate with the error parameters
  held, each clip's scale profiled (bounded scalar search on its log).

Evaluate (``--evaluate``; writes benchmarks/results/camera_motion.txt), HELD-OUT data only,
built exactly as benchmarks/ablation.py builds them (``--max-clips 200``, same seeds and cache
keys): Bandai motion-style test, CMU test subjects, DeepMimic (static cameras) and the
moving camera (30 deg pitch sweep over the Bandai test and DeepMimic clips of >= 150 frames).
Per set and rule (the spread threshold of ``choose_mode``, the Bayes factor): clips read
moving / static, and the sequence tilt error (ablation.py's ``run_variant``: the sequence
up with the camera prior for clips read static, smooth mode's per-frame ups for clips read
moving; mean over each clip's valid frames, then mean / median / p95 over clips), with the
paired bootstrap of ablation.py on the difference.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.optimize import minimize, minimize_scalar

from benchmarks import ablation as A

import pcnet.stages.temporal as temporal
from benchmarks.camera_motion_model import (LOG_PRIOR_ODDS, MotionParams, decide_camera_motion,
                                        hierarchical_log_marginal, pack_series, profile_scale, scale_grid,
                                        tangent_coordinates)

DEFAULT = A.DEFAULT
FIT_RESULT = Path(__file__).resolve().parent / "results" / "fit_camera_motion.txt"
EVAL_RESULT = Path(__file__).resolve().parent / "results" / "camera_motion.txt"
FIT_MAX_CLIPS = 40
VAL_SETS = (("Bandai motion-style validation", "bandai_h36m17.npz", "val"),
            ("CMU validation subjects", "cmu_train_h36m17.npz", "val"))
HELDOUT_MAX_CLIPS = 200  # ablation.py's default, so its cache is shared


def validation_evidence(data: Path, max_clips: int, cache: Path = A.CACHE) -> tuple[list[list[dict]], list[dict]]:
    """``(static sets, moving)``: ablation.py's cached evidence of the validation clips."""
    static = []
    for _, file, split in VAL_SETS:
        static.append(A.mocap_set(data, cache, file, split, max_clips))
    moving = A.cached(cache, f"sweep_val_{max_clips}", lambda: A.sweep_evidence(static))
    return static, moving


def heldout_evidence(data: Path, cache: Path = A.CACHE) -> list[tuple[str, list[dict]]]:
    """The four held-out sets exactly as ablation.py's ``main`` builds (and caches) them."""
    sets, static = [], []
    for title, file, split in A.MOCAP_SETS:
        evs = A.mocap_set(data, cache, file, split, HELDOUT_MAX_CLIPS)
        sets.append((title, evs))
        static.append(evs)
    moving = A.heldout_sweep(cache, static, HELDOUT_MAX_CLIPS)
    sets.append((f"Moving camera ({A.SWEEP_DEG:g} deg pitch sweep)", moving))
    return sets


def series(ev: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """``(ups (T, 3), y (T, 2), ok (T,), fps)``: the default chain's per-frame ups of one clip."""
    R, ok = A.shipped_rotations(ev)
    ups = np.where(ok[:, None], R[:, :, 1], np.nan)
    y, ok, _ = tangent_coordinates(ups, ok)
    return ups, y, ok, ev["fps"]


def total_ll(data: list, p: MotionParams, moving: bool) -> float:
    """Sum over clips of each clip's log-likelihood with its error scale profiled."""
    return float(sum(profile_scale(y, ok, fps, p, moving)[0] for _, y, ok, fps in data if ok.sum() >= 2))


def fit_static(data: list) -> tuple[MotionParams, float]:
    """Maximum likelihood of M0 over (white ratio, tau, Huber k), on logs, each clip's scale profiled."""
    def nll(th):
        r, tau, k = np.exp(th)
        return -total_ll(data, MotionParams(r, tau, k, 0.0), False)

    res = minimize(nll, np.log([0.3, 0.9, 3.0]), method="Nelder-Mead",
                   options={"xatol": 2e-2, "fatol": 0.1, "maxiter": 200})
    r, tau, k = np.exp(res.x)
    return MotionParams(float(r), float(tau), float(k), 0.0), float(-res.fun)


def fit_walk(data: list, p: MotionParams) -> tuple[MotionParams, float]:
    """Maximum likelihood of M1's random-walk rate with the parameters of ``p`` held, each clip's scale profiled."""
    res = minimize_scalar(lambda lq: -total_ll(data, replace(p, walk_rate_deg=float(np.exp(lq))), True),
                          bounds=(np.log(0.05), np.log(50.0)), method="bounded", options={"xatol": 0.02})
    return replace(p, walk_rate_deg=float(np.exp(res.x))), float(-res.fun)


SLOW_TAUS_S = (3.0, 10.0, 30.0)  # time constants of the second (slow) error component tried


def fit_alternatives(data: list, p0: MotionParams) -> list[str]:
    """Validation log-likelihoods of the alternative error models (report lines):
    - two Ornstein-Uhlenbeck components, each slow time constant of SLOW_TAUS_S: maximum
      likelihood over (slow fraction, fast tau, white ratio, Huber k), each clip's scale profiled;
    - hierarchical scales: each clip's log scale integrated over a normal prior across clips,
      whose (mu, sigma) are fitted by maximum marginal likelihood (the other parameters at p0's)."""
    fps = {f for _, _, _, f in data}
    assert len(fps) == 1, fps
    fps = fps.pop()
    Y, OK = pack_series([(y, ok) for _, y, ok, _ in data if ok.sum() >= 2])
    base = (0.0, p0.persistent_tau_s, 1.0, p0.white_ratio, p0.huber_k, 0.0)
    prof0, _, grid, ll = scale_grid(Y, OK, fps, base, False)
    n = len(Y)
    out = [f"  one OU component, scales profiled (the model): log L = {prof0.sum():.1f} with {n} + 3 parameters "
           f"(AIC-penalised {prof0.sum() - n - 3:.1f})"]
    for tau2 in SLOW_TAUS_S:
        def nll(th, tau2=tau2):
            pars = (1.0 / (1.0 + np.exp(-th[0])), float(np.exp(th[1])), tau2, float(np.exp(th[2])), float(np.exp(th[3])), 0.0)
            return -scale_grid(Y, OK, fps, pars, False)[0].sum()
        res = minimize(nll, [-1.0, np.log(0.7), np.log(1e-3), np.log(p0.huber_k)], method="Nelder-Mead",
                       options={"xatol": 1e-2, "fatol": 0.02, "maxfev": 250})
        f, t1, w, k = 1.0 / (1.0 + np.exp(-res.x[0])), *np.exp(res.x[1:])
        out.append(f"  two OU components, slow tau {tau2:g} s: log L = {-res.fun:.1f} with {n} + 4 parameters "
                   f"(slow fraction {f:.3f}, fast tau {t1:.3f} s, white ratio {w:.2g}, Huber k {k:.3f})")
    res = minimize(lambda h: -hierarchical_log_marginal(grid, ll, h[0], float(np.exp(h[1]))).sum(),
                   [float(np.mean(grid)), np.log(0.5)], method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-4})
    out.append(f"  one OU component, hierarchical scales: marginal log L = {-res.fun:.1f} with 2 + 3 parameters "
               f"(AIC-penalised {-res.fun - 5:.1f}; prior of the log scale: median {np.exp(res.x[0]):.2f} deg, "
               f"sigma {np.exp(res.x[1]):.3f})")
    return out


def fit_prior_odds(lbf_static: np.ndarray, lbf_moving: np.ndarray) -> tuple[float, float, float, int]:
    """``(log prior odds, lo, hi, misreads)``: minus the midpoint of the widest interval ``[lo, hi)``
    of thresholds on the log Bayes factor that minimise static-read-moving + moving-read-static."""
    c = np.unique(np.r_[lbf_static, lbf_moving])
    miss = np.array([(lbf_static > t).sum() + (lbf_moving <= t).sum() for t in c])
    best = miss.min()
    cand = [(c[i + 1] - c[i], c[i], c[i + 1]) for i in range(len(c) - 1) if miss[i] == best]
    _, lo, hi = max(cand)
    return -0.5 * (lo + hi), float(lo), float(hi), int(best)


def log_bf(ev: dict) -> float:
    u, _, ok, fps = series(ev)
    return decide_camera_motion(u, ok, fps).log_bayes_factor


def spread_moving(ev: dict) -> bool:
    R, ok = A.shipped_rotations(ev)
    return temporal.choose_mode(R, ok, temporal.MODE_THRESHOLD_DEG, ev["fps"])[0] == "smooth"


def fit(args) -> int:
    t0 = time.time()
    static_sets, moving = validation_evidence(args.data, args.fit_clips)
    static = [series(ev) for evs in static_sets for ev in evs]
    sweep = [series(ev) for ev in moving]
    nf = sum(int(ok.sum()) for _, _, ok, _ in static)
    p0, ll0 = fit_static(static)
    p1, ll1 = fit_walk(sweep, p0)
    lines = [__doc__.splitlines()[0], "",
             f"    python -m benchmarks.fit_camera_motion --data ../shared/data --fit-clips {args.fit_clips}", "",
             "Static camera (model M0), validation clips: "
             + ", ".join(f"{title} {len(evs)} clips" for (title, _, _), evs in zip(VAL_SETS, static_sets))
             + f"; {nf} valid frames; maximum log-likelihood {ll0:.1f}",
             f"  WHITE_RATIO          = {p0.white_ratio:.3g}   (white error std / persistent error std)",
             f"  PERSISTENT_TAU_S     = {p0.persistent_tau_s:.4f}   (time constant of the Ornstein-Uhlenbeck error, s)",
             f"  HUBER_K              = {p0.huber_k:.4f}   (Huber corner of the innovation density)",
             "  (each clip's error scale s_b profiled out, per model; median over these clips "
             f"{np.median([profile_scale(y, ok, fps, p0, False)[1] for _, y, ok, fps in static]):.2f} deg)",
             f"Moving camera (model M1), the validation clips of >= {A.SWEEP_MIN_FRAMES} frames with the pitch sweeping "
             f"{A.SWEEP_DEG:g} deg over each: {len(sweep)} clips; maximum log-likelihood {ll1:.1f}",
             f"  WALK_RATE_DEG        = {p1.walk_rate_deg:.4f}   (random-walk rate of the tilt, deg/sqrt(s))",
             ]
    lb_static = np.array([decide_camera_motion(u, ok, fps, p1).log_bayes_factor for u, _, ok, fps in static])
    lb_sweep = np.array([decide_camera_motion(u, ok, fps, p1).log_bayes_factor for u, _, ok, fps in sweep])
    odds, lo, hi, miss = fit_prior_odds(lb_static, lb_sweep)
    lines += [f"  LOG_PRIOR_ODDS       = {odds:.3f}   (fitted: minus the midpoint of [{lo:.2f}, {hi:.2f}), the widest interval of "
              f"log-BF thresholds with the fewest validation misreads, {miss} of {len(static) + len(sweep)}; "
              f"equal odds would misread {int((lb_static > 0).sum() + (lb_sweep <= 0).sum())})",
              "", "Alternative error models, static model M0 on the same validation clips (validation log-likelihoods):"]
    lines += fit_alternatives(static, p0)
    lines += ["", "In-sample check (the fitting clips themselves; the held-out numbers are in camera_motion.txt):"]
    dm_static = lb_static + odds > 0
    dm_sweep = lb_sweep + odds > 0
    sp_static = np.array([spread_moving(ev) for evs in static_sets for ev in evs])
    sp_sweep = np.array([spread_moving(ev) for ev in moving])
    lines += [f"  Bayes factor:     static clips read moving {int(dm_static.sum())} of {len(static)}, "
              f"swept clips read static {int((~dm_sweep).sum())} of {len(sweep)}",
              f"  spread <= {temporal.MODE_THRESHOLD_DEG:g} deg: static clips read moving {int(sp_static.sum())} of "
              f"{len(static)}, swept clips read static {int((~sp_sweep).sum())} of {len(sweep)}",
              "", f"(wall time {time.time() - t0:.0f} s; 2 shared CPU cores)"]
    print("\n".join(lines))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    return 0


def evaluate(args) -> int:
    t0 = time.time()
    rules = (("spread <= 5 deg (shipped)", next(v for v in A.VARIANTS if v.mode_constants == (5.0, 0.5, 0.2))),
             ("Bayes factor", next(v for v in A.VARIANTS if v.mode_rule == "bayes")),
             ("always static (sequence)", A.VARIANTS[0]))
    lines = ["Static or moving camera on held-out data: the Bayes factor of benchmarks/camera_motion_model.py vs the spread "
             "threshold of choose_mode (issue 49).", "",
             "    python -m benchmarks.fit_camera_motion --data ../shared/data --evaluate", "",
             f"Parameters: {MotionParams()}; log prior odds {LOG_PRIOR_ODDS:g} (benchmarks/camera_motion_model.py, fitted on "
             "validation clips: fit_camera_motion.txt).",
             "Columns: clips read moving (smooth mode) / static (sequence mode); sequence tilt error (deg) over clips; "
             "the last column: paired bootstrap of the difference to the shipped rule (95 % CI) over clips.", ""]
    for title, evs in heldout_evidence(args.data):
        is_moving = title.startswith("Moving")
        lines.append(f"## {title}: {len(evs)} clips ({'the camera moves' if is_moving else 'static camera'})")
        lines.append(f"{'rule':<30}{'read moving':>12}{'read static':>12}{'mean':>8}{'median':>8}{'p95':>8}"
                     "  mean diff vs shipped [95 % CI], deg")
        base = None
        for label, v in rules:
            out = [A.run_variant(ev, v) for ev in evs]
            err = np.array([A.clip_error(o["up"], ev["true_up"]) for o, ev in zip(out, evs)])
            mv = sum(o["mode"] == "smooth" for o in out)
            if base is None:
                base = err
                ver = "-"
            else:
                m, lo, hi = A.paired_interval(err - base)
                ver = f"{m:+.2f} [{lo:+.2f}, {hi:+.2f}]"
            lines.append(f"{label:<30}{mv:>12}{len(evs) - mv:>12}{np.nanmean(err):>8.2f}{np.nanmedian(err):>8.2f}"
                         f"{np.nanpercentile(err, 95):>8.2f}  {ver}")
        lbf = np.array([log_bf(ev) for ev in evs])
        lines.append(f"log Bayes factor over clips: min {lbf.min():.1f}, median {np.median(lbf):.1f}, max {lbf.max():.1f}; "
                     f"read moving at the fitted odds (log BF > {-LOG_PRIOR_ODDS:.2f}) {int((lbf + LOG_PRIOR_ODDS > 0).sum())}, "
                     f"at equal odds (log BF > 0, first attempt; information only) {int((lbf > 0).sum())}")
        lines.append("")
        print("\n".join(lines[-7:]), flush=True)
    lines.append(f"(wall time {time.time() - t0:.0f} s including cache reads; 2 shared CPU cores)")
    args.eval_out.parent.mkdir(parents=True, exist_ok=True)
    args.eval_out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.eval_out}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--fit-clips", type=int, default=FIT_MAX_CLIPS, help="Bandai validation clips (seeded subset)")
    ap.add_argument("--evaluate", action="store_true", help="held-out comparison instead of the fit")
    ap.add_argument("--out", type=Path, default=FIT_RESULT)
    ap.add_argument("--eval-out", type=Path, default=EVAL_RESULT)
    args = ap.parse_args(argv)
    return evaluate(args) if args.evaluate else fit(args)


if __name__ == "__main__":
    raise SystemExit(main())
