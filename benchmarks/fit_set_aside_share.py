"""The view gate's set-aside warning share fitted on validation, and its check on held-out recordings.

    python -m benchmarks.fit_set_aside_share --data ../shared/data [--cache DIR]

Decision 0079. The warning (``stages/flags.ensemble_weights_flag``, frame and smooth modes)
fires where more than a share of a recording's valid frames had the camera-frame network set
aside. Fit: on the up model's validation recordings (``benchmarks/fit_up_model.validation_sets``),
each recording's set-aside share and its per-frame bound's hit (the share of valid frames whose
tilt error is within the bound; :func:`benchmarks.ablation.run_variant` of the default variant);
every distinct share below the largest is a candidate, the warning firing above it, and the
fitted share is the one with the largest two-sample t statistic of the hit between the
recordings where it does not fire and where it does (each group at least two recordings).
Check: decision 0078's held-out recordings (the ablation's three mocap sets, the same rolled 30
and 90 deg, the real calibrated cameras in 16 views): mean hit where it fires and where it does
not, the difference with a 95 % two-sample bootstrap interval, for the fitted and the hand-set
share (5 %), and the rule's verdict.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks.fit_up_model import validation_sets
from benchmarks.report import BOOTSTRAP, print_and_save, shipped_limit
from pcnet.stages.rectification_report import EnsembleWeights

RESULT = Path(__file__).resolve().parent / "results" / "fit_set_aside_share.txt"
COMMAND = "python -m benchmarks.fit_set_aside_share --data ../shared/data"
#: The share before decision 0079 (hand-set).
HAND_SET = 0.05


def reading(ev: dict) -> tuple[float, float]:
    """``(set-aside share, per-frame bound hit)`` of one recording under the default chain."""
    o = A.run_variant(ev, A.VARIANTS[0])
    _, valid, weight, _ = A.per_frame(ev, A.VARIANTS[0])
    w = EnsembleWeights.of(weight, valid, ev["turns"])
    err = A.deg(o["frame_up"], ev["true_up"])
    ok = np.isfinite(err) & np.isfinite(o["bound"])
    share = w.set_aside_frames / w.frames if w.frames else float("nan")
    return share, float(np.mean(err[ok] <= o["bound"][ok])) if ok.any() else float("nan")


def t_statistic(quiet: np.ndarray, fired: np.ndarray) -> float:
    """Welch's two-sample t of ``mean(quiet) - mean(fired)``; NaN with fewer than two in a group
    or no spread."""
    if len(quiet) < 2 or len(fired) < 2:
        return float("nan")
    se = np.sqrt(quiet.var(ddof=1) / len(quiet) + fired.var(ddof=1) / len(fired))
    return float((quiet.mean() - fired.mean()) / se) if se > 0 else float("nan")


def fit_share(shares: np.ndarray, hits: np.ndarray) -> tuple[float, float]:
    """The candidate share with the largest :func:`t_statistic`, and that statistic."""
    best = (float("nan"), -np.inf)
    for s in np.unique(shares)[:-1]:
        t = t_statistic(hits[shares <= s], hits[shares > s])
        if np.isfinite(t) and t > best[1]:
            best = (float(s), t)
    return best


def difference_interval(quiet: np.ndarray, fired: np.ndarray, seed: int = 0) -> tuple[float, float, float]:
    """Mean ``quiet`` - mean ``fired`` and its 95 % two-sample bootstrap interval."""
    rng = np.random.default_rng(seed)
    draws = (quiet[rng.integers(0, len(quiet), (BOOTSTRAP, len(quiet)))].mean(1)
             - fired[rng.integers(0, len(fired), (BOOTSTRAP, len(fired)))].mean(1))
    return float(quiet.mean() - fired.mean()), float(np.percentile(draws, 2.5)), float(np.percentile(draws, 97.5))


def read_all(evs) -> np.ndarray:
    """``(N, 2)`` share and hit of the recordings with both finite."""
    r = np.array([reading(ev) for ev in evs], float).reshape(-1, 2)
    return r[np.isfinite(r).all(1)]


def main(argv=None) -> int:
    args = A.heldout_arguments(argv, __doc__, "fit_set_aside_share", RESULT)
    t0 = time.time()
    val = np.concatenate([read_all(evs) for evs in validation_sets(args.data, args.cache).values()])
    split, t = fit_share(val[:, 0], val[:, 1])
    share = shipped_limit(split, 4)  # the warning fires above it: rounded up, the split stays
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"Fit: {len(val)} validation recordings; recordings with any frame set aside: "
             f"{int(np.sum(val[:, 0] > 0))}; fitted share {share:.4f} (t = {t:.2f}, the split at {split:.6f} "
             f"rounded up to 0.0001; fires on {int(np.sum(val[:, 0] > share))} of them; the hand-set "
             f"{HAND_SET:g}: t = {t_statistic(val[val[:, 0] <= HAND_SET, 1], val[val[:, 0] > HAND_SET, 1]):.2f})", "",
             f"Held out (decision 0078's recordings): {'set':<44}{'recs':>6}{'fires, fitted':>15}{'hand-set':>10}"]
    held = []
    for title, evs in A.heldout_recordings(args.data, args.cache, args.max_clips, quarter=True):
        if title.startswith("moving camera"):
            continue  # no static truth
        r = read_all(evs)
        held.append(r)
        fired, fired_hand = int(np.sum(r[:, 0] > share)), int(np.sum(r[:, 0] > HAND_SET))
        lines.append(f"{'':<40}{title:<44}{len(r):>6}{fired:>15}{fired_hand:>10}")
    held = np.concatenate(held)
    verdict = False
    for label, s in (("fitted", share), ("hand-set", HAND_SET)):
        fired = held[:, 0] > s
        d, lo, hi = difference_interval(held[~fired, 1], held[fired, 1])
        lines.append(f"{label} share {s:.4f}: fires on {int(fired.sum())} of {len(held)}; frames within the bound where it "
                     f"fires {100 * held[fired, 1].mean():.1f} %, where it does not {100 * held[~fired, 1].mean():.1f} %; "
                     f"difference {100 * d:+.1f} [{100 * lo:+.1f}, {100 * hi:+.1f}] points")
        if label == "fitted":
            verdict = lo > 0
    lines += ["", f"Decision 0079's rule: the fitted share {'ships' if verdict else 'does not carry information: the warning goes'}",
              "", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
