"""Fit the view gate's four pitch constants on validation views that include steep cameras (decision 0063).

    python -m benchmarks.fit_gate_pitch --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

The view gate (models/view_gate.py) has a pitch ramp for the camera-frame network (full weight
up to ``pitch_full``, none from ``pitch_full + pitch_width``) and a pitch limit on the
body-frame estimate beyond which the camera-frame network's own estimate no longer keeps it in
(``body_pitch_full``, ``body_pitch_width``). They act only where a camera is pitched beyond the
training views, which no validation set held (decision 0061), so here one is made: each
"paper"-view recording of the Bandai motion-style validation split and the CMU validation
subjects (benchmarks/fit_up_model.py's) with the camera pitched a further ``U(30, 80)`` deg
down (one angle per clip, :data:`SEED`; benchmarks/ablation.py's ``pitched_evidence``), cached
under ``val_{tag}_steep``.

Fit: benchmarks/fit_view_gate.py's coordinate descent (mean per-frame tilt error, equal weight
per set: the six validation sets of fit_view_gate and the two steep ones), over :data:`GRIDS`
for the four pitch constants only; the roll constants and the window stay as shipped.

Check (decision 0063's rule): on each held-out set of benchmarks/view_gate_pieces.py (the
ablation's held-out recordings with the camera rolled 30 and 90 deg, and the camera pitched 60
deg down, which decision 0061 had already looked at), the mean over clips of each clip's mean
per-frame tilt error, shipped and fitted, and their paired difference with its 95 % bootstrap
interval (:func:`benchmarks.ablation.paired_interval`). The fit ships if no set is worse by more
than 0.10 deg with the interval above zero.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks import fit_view_gate as V
from benchmarks.report import print_and_save
from benchmarks.view_gate_pieces import heldout_sets, worse

RESULT = Path(__file__).resolve().parent / "results" / "fit_gate_pitch.txt"
COMMAND = "python -m benchmarks.fit_gate_pitch --data ../shared/data"
#: The steep validation views: a further pitch drawn from ``U(*STEEP_DEG)`` per clip, seeded.
STEEP_DEG = (30.0, 80.0)
SEED = 0
#: The gate's constants before decision 0063 (fit_view_gate.NAMES order), hand-set: the fit's start and
#: the held-out check's baseline, so that a rerun after the fitted values shipped reproduces the decision.
HAND_SET = (10.0, 10.0, 40.0, 10.0, 45.0, 15.0, 60.0, 15.0, 2.0)
#: Grids of the four pitch constants (indices into fit_view_gate.NAMES).
GRIDS = {V.NAMES.index("pitch_full"): tuple(float(v) for v in range(25, 71, 5)),
         V.NAMES.index("pitch_width"): (5.0, 10.0, 15.0, 20.0),
         V.NAMES.index("body_pitch_full"): (*(float(v) for v in range(45, 91, 5)), 180.0),
         V.NAMES.index("body_pitch_width"): (5.0, 15.0, 30.0)}


def steep_validation(data: Path, cache: Path) -> dict[str, list[dict]]:
    """The steep validation views (module docstring), keyed ``"{tag} val, steep views"``."""
    val = F.validation_sets(data, cache)
    rng = np.random.default_rng(SEED)
    out = {}
    for tag in sorted({tag for tag, _ in val}):
        evs = val[tag, "paper"]
        angles = rng.uniform(*STEEP_DEG, len(evs))
        out[f"{tag} val, steep views"] = A.cached(cache, f"val_{tag}_steep", lambda e=evs, a=angles: A.pitched_evidence([e], a))
    return out


def main(argv: list[str] | None = None) -> int:
    args = A.heldout_arguments(argv, __doc__, "fit_gate_pitch", RESULT)
    t0 = time.time()
    val = V.validation_clips(args.data, args.cache)
    val.update({name: V.prepared(evs) for name, evs in steep_validation(args.data, args.cache).items()})
    fitted, score, log = V.fit(val, GRIDS, HAND_SET)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"constants: {', '.join(V.NAMES)} (fitted: {', '.join(V.NAMES[i] for i in GRIDS)})", "",
             "Validation (equal weight per set), per set: mean per-frame tilt error (deg) hand-set -> fitted"]
    for name, clips in val.items():
        lines.append(f"  {name:<28}{len(clips):>5}{V.clip_errors(clips, HAND_SET).mean():>8.2f} ->"
                     f"{V.clip_errors(clips, fitted).mean():>6.2f}")
    lines += ["", "Coordinate descent:", *log, "", f"fitted: pitch ramp {fitted[2]:g}-{fitted[2] + fitted[3]:g} deg, "
              f"body-frame estimate's pitch limit {fitted[6]:g}-{fitted[6] + fitted[7]:g} deg "
              f"(hand-set {HAND_SET[2]:g}-{HAND_SET[2] + HAND_SET[3]:g}, {HAND_SET[6]:g}-{HAND_SET[6] + HAND_SET[7]:g}; "
              f"models/view_gate.py ships {V.SHIPPED[2]:g}-{V.SHIPPED[2] + V.SHIPPED[3]:g}, "
              f"{V.SHIPPED[6]:g}-{V.SHIPPED[6] + V.SHIPPED[7]:g})",
              "", "## Held out (decision 0063's check; the pitched set was seen in decision 0061)",
              f"{'set':<46}{'clips':>6}{'hand-set':>9}{'fitted':>8}  fitted - hand-set [95 % CI]"]
    worse_on, worst = [], []
    for title, evs in heldout_sets(args):
        clips = V.prepared(evs)
        hand_set, new = V.clip_errors(clips, HAND_SET), V.clip_errors(clips, fitted)
        diff = new - hand_set
        i = int(np.argmax(diff))
        if diff[i] > A.CHANGED_DEG:
            worst.append(f"{title.split(' (')[0]}: {int(np.sum(diff > A.CHANGED_DEG))} worse by > "
                         f"{A.CHANGED_DEG:g}, most {clips[i]['name']} {diff[i]:+.2f}")
        bad, cell = worse(diff)
        if bad:
            worse_on.append(title)
        lines.append(f"{title:<46}{len(clips):>6}{hand_set.mean():>9.2f}{new.mean():>8.2f}  {cell}")
    lines += ["", "verdict: " + (f"worse on {', '.join(worse_on)}: not shipped" if worse_on else
                                 "not worse on any held-out set: the fitted constants ship"),
              "worst clips per set (fitted - hand-set, deg): " + "; ".join(worst),
              "", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
