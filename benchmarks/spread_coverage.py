"""The sequence intervals' coverage by the per-frame ups' spread (decision 0090).

    python -m benchmarks.spread_coverage --data ../shared/data

Sequence mode's intervals are the up model's posterior for a static camera, calibrated on the
validation recordings (docs/up_model.md). Its note fires when the low-passed per-frame ups
spread more than ``MODE_THRESHOLD_DEG`` (:func:`pcnet.stages.temporal.up_spread_deg`), the
threshold that no static camera of the validation data passed (benchmarks/fit_camera_mode.py).
A static recording above it is outside the data the intervals were calibrated on. This script
counts, per set, the static-camera recordings at or below the threshold and above it, and the
share whose pitch and roll intervals both hold the truth (:func:`benchmarks.ablation.interval_hits`
of the shipped chain, :data:`benchmarks.ablation.VARIANTS` ``[0]``): the validation sets of
benchmarks/fit_up_model.py and the held-out mocap sets of benchmarks/ablation.py (static
cameras, lifter noise, at most ``--max-clips`` clips each; their caches).

Writes benchmarks/results/spread_coverage.txt.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from pcnet.stages import temporal

RESULT = Path(__file__).resolve().parent / "results" / "spread_coverage.txt"
COMMAND = "python -m benchmarks.spread_coverage --data ../shared/data"


def strata(evs: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """``(spread (n,) deg, both hold (n,) bool)`` of the recordings of ``evs`` that the shipped
    chain reads static with intervals."""
    spread, hold = [], []
    for ev in evs:
        out = A.run_variant(ev, A.VARIANTS[0])
        if out.get("interval") is None:
            continue
        R, ok = A.shipped_rotations(ev)
        spread.append(temporal.up_spread_deg(R, ok, ev["fps"]))
        hold.append(bool(A.interval_hits([out], [ev]).all()))
    return np.array(spread), np.array(hold, bool)


def row(title: str, spread: np.ndarray, hold: np.ndarray) -> str:
    above = spread > temporal.MODE_THRESHOLD_DEG
    cells = []
    for part in (~above, above):
        n = int(part.sum())
        cells.append(f"{n:>6}{(100 * hold[part].mean() if n else float('nan')):>9.1f}")
    return f"{title:<44}" + "".join(cells)


def main(argv=None) -> int:
    args = A.heldout_arguments(argv, __doc__, "spread_coverage", RESULT)
    t0 = time.time()
    threshold = temporal.MODE_THRESHOLD_DEG
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", "",
             f"static-camera recordings read static with intervals; spread threshold {threshold:g} deg",
             f"{'set':<44}{'<= n':>6}{'hold %':>9}{'> n':>6}{'hold %':>9}"]
    every = []
    val = F.validation_sets(args.data, args.cache)
    for (tag, views), evs in val.items():
        spread, hold = strata(evs)
        lines.append(row(f"validation {tag} {views}", spread, hold))
        every.append(("validation", spread, hold))
    for title, file, split in A.MOCAP_SETS:
        spread, hold = strata(A.mocap_set(args.data, args.cache, file, split, args.max_clips))
        lines.append(row(f"held out: {title}", spread, hold))
        every.append(("held out", spread, hold))
    for which in ("validation", "held out"):
        spread = np.concatenate([s for w, s, _ in every if w == which])
        hold = np.concatenate([h for w, _, h in every if w == which])
        lines.append(row(f"all {which}", spread, hold))
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
