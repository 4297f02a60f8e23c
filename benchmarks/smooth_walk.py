"""Smooth mode: the up model's random walk against the Gaussian kernel on SO(3) (decision 0055).

    python -m benchmarks.smooth_walk --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Smooth mode (a moving camera) as shipped smooths the view gate's per-frame rotations with a
Gaussian kernel (``pcnet.stages.temporal.smooth_rotations``, std ``SMOOTH_TIME_CONSTANT_S``).
The candidate is the up model's moving camera (docs/up_model.md, "Moving camera";
``benchmarks.up_model_variants.random_walk``): a random walk of the up at rate ``q``, observed
through the per-frame summaries ``g_hat_t``, smoothed by Kalman and Rauch-Tung-Striebel. ``q``
is fitted here by maximum marginal likelihood on the validation clips whose camera pitch sweeps
30 deg (Bandai motion-style val and CMU val subjects, "paper" views; the data
benchmarks/fit_camera_mode.py fits the kernel on).

Printed per set: the mean over clips of each clip's mean per-frame tilt error (deg) of the
kernel and of the walk over the frames both answer, the paired difference (walk minus kernel)
with its 95 % bootstrap interval over clips (:func:`benchmarks.ablation.paired_interval`), and
the share of frames whose walk error lies within the walk's 95 % disc (``R95`` times its RMS
axis standard deviation). Validation sweeps first (where ``q`` is fitted), then the held-out
sets of benchmarks/ablation.py from its cache. The decision rule is
docs/decisions/0055-smooth-mode-random-walk.md's.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from benchmarks.up_model_variants import R95, fit_rate, random_walk, summarise_frames
from pcnet.stages import temporal
from pcnet.stages.up_model import default_parameters

RESULT = Path(__file__).resolve().parent / "results" / "smooth_walk.txt"
COMMAND = "python -m benchmarks.smooth_walk --data ../shared/data"


def clip_scores(ev: dict, q: float) -> tuple[float, float, np.ndarray]:
    """``(kernel error, walk error, walk inside its 95 % disc per frame)`` of one recording:
    mean per-frame tilt errors (deg) over the frames both answer."""
    p = default_parameters()
    R, ok = A.shipped_rotations(ev)
    kernel = temporal.smooth_rotations(R, ok, ev["fps"], temporal.SMOOTH_TIME_CONSTANT_S)[:, :, 1]
    kernel[~ok] = np.nan
    walk = random_walk(summarise_frames(A.evidence_of(ev), p), ev["fps"], p, q)
    ek, ew = A.deg(kernel, ev["true_up"]), A.deg(walk.up, ev["true_up"])
    both = np.isfinite(ek) & np.isfinite(ew)
    if not both.any():
        return float("nan"), float("nan"), np.zeros(0, bool)
    return float(ek[both].mean()), float(ew[both].mean()), ew[both] <= R95 * walk.std_deg[both]


def row(title: str, evs: list[dict], q: float) -> str:
    scores = [clip_scores(ev, q) for ev in evs]
    kernel = np.array([s[0] for s in scores])
    walk = np.array([s[1] for s in scores])
    inside = np.concatenate([s[2] for s in scores])
    mean, lo, hi = A.paired_interval(walk - kernel)
    return (f"{title:<44}{len(evs):>6}{np.nanmean(kernel):>8.2f}{np.nanmean(walk):>8.2f}"
            f"  {mean:+.2f} [{lo:+.2f}, {hi:+.2f}]{100 * inside.mean():>9.1f}")


def main(argv: list[str] | None = None) -> int:
    args = A.heldout_arguments(argv, __doc__, "smooth_walk", RESULT)
    t0 = time.time()
    val = F.validation_sets(args.data, args.cache)
    sweeps = F.validation_sweeps(args.cache, val)
    q = fit_rate(sweeps, default_parameters(), None)
    head = (f"{'set':<44}{'clips':>6}{'kernel':>8}{'walk':>8}  walk - kernel [95 % CI], deg"
            f"{'walk 95%':>9}")
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"Walk rate q = {q:.3f} deg/sqrt(s): maximum marginal likelihood on {len(sweeps)} validation clips "
             f"with the camera pitch sweeping {A.SWEEP_DEG:g} deg; kernel std "
             f"{temporal.SMOOTH_TIME_CONSTANT_S:g} s (benchmarks/fit_camera_mode.py).",
             "Mean over clips of each clip's mean per-frame tilt error (deg); walk 95%: frames within the walk's "
             "95 % disc.", "", "## Validation (q fitted here)", head,
             row(f"validation sweep ({A.SWEEP_DEG:g} deg)", sweeps, q),
             "", "## Held out (benchmarks/ablation.py's recordings, every clip run as smooth mode)", head]
    lines += [row(title, evs, q) for title, evs in A.heldout_recordings(args.data, args.cache, args.max_clips)]
    lines += ["", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
