"""Decision 0078's trial: do the view gate's two warnings say more than the per-frame bound?

    python -m benchmarks.view_gate_warnings --data ../shared/data [--max-clips 200] [--cache DIR]

On the ablation's cached held-out recordings with a static truth (the three mocap sets, the same
with the camera rolled 30 and 90 deg, the real calibrated cameras in 16 views), the default
per-frame chain (:func:`benchmarks.ablation.run_variant` of the default variant). Per recording:
which of ``stages/flags.ensemble_weights_flag``'s warnings fire (on
``EnsembleWeights.of(weight, valid, quarter turns)`` of the gate), and the per-frame bound's hit
(the share of valid frames whose tilt error is within the bound). Per warning: the mean hit
where it fires and where it does not, their difference (does not - fires) with a 95 %
two-sample bootstrap interval over recordings, and the rule's verdict.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks.report import BOOTSTRAP, print_and_save
from pcnet.stages.flags import Kind, ensemble_weights_flag
from pcnet.stages.rectification_report import EnsembleWeights

RESULT = Path(__file__).resolve().parent / "results" / "view_gate_warnings.txt"
COMMAND = "python -m benchmarks.view_gate_warnings --data ../shared/data"
WARNINGS = (Kind.QUARTER_TURN, Kind.VIEWS_SET_ASIDE)


def reading(ev: dict) -> tuple[set, float]:
    """The warnings that fire on one recording and its per-frame bound's hit."""
    o = A.run_variant(ev, A.VARIANTS[0])
    _, valid, weight, _ = A.per_frame(ev, A.VARIANTS[0])
    kinds = {f.kind for f in ensemble_weights_flag(EnsembleWeights.of(weight, valid, ev["turns"]))}
    err = A.deg(o["frame_up"], ev["true_up"])
    ok = np.isfinite(err) & np.isfinite(o["bound"])
    return kinds, float(np.mean(err[ok] <= o["bound"][ok])) if ok.any() else float("nan")


def difference_interval(quiet: np.ndarray, fired: np.ndarray, seed: int = 0) -> tuple[float, float, float]:
    """Mean ``quiet`` - mean ``fired`` and its 95 % two-sample bootstrap interval."""
    rng = np.random.default_rng(seed)
    draws = (quiet[rng.integers(0, len(quiet), (BOOTSTRAP, len(quiet)))].mean(1)
             - fired[rng.integers(0, len(fired), (BOOTSTRAP, len(fired)))].mean(1))
    return float(quiet.mean() - fired.mean()), float(np.percentile(draws, 2.5)), float(np.percentile(draws, 97.5))


def main(argv=None) -> int:
    args = A.heldout_arguments(argv, __doc__, "view_gate_warnings", RESULT)
    t0 = time.time()
    rows, counts = [], []
    for title, evs in A.heldout_recordings(args.data, args.cache, args.max_clips, quarter=True):
        if title.startswith("moving camera"):
            continue  # no static truth
        read = [reading(ev) for ev in evs]
        rows += [r for r in read if np.isfinite(r[1])]
        counts.append(f"{title:<46}{len(evs):>6}" + "".join(f"{sum(k in r[0] for r in read):>18}" for k in WARNINGS))
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND} --max-clips {args.max_clips}", "",
             f"{'set':<46}{'recs':>6}" + "".join(f"{k.name:>18}" for k in WARNINGS), *counts, ""]
    hits = np.array([h for _, h in rows])
    for kind in WARNINGS:
        fired = np.array([kind in k for k, _ in rows])
        lines.append(f"{kind.name}: fires on {int(fired.sum())} of {len(rows)} recordings")
        stays = False
        if fired.any() and (~fired).any():
            d, lo, hi = difference_interval(hits[~fired], hits[fired])
            stays = lo > 0
            lines.append(f"  frames within the per-frame bound where it fires {100 * hits[fired].mean():.1f} %, where it "
                         f"does not {100 * hits[~fired].mean():.1f} %; difference {100 * d:+.1f} [{100 * lo:+.1f}, "
                         f"{100 * hi:+.1f}] points")
        lines.append(f"  decision 0078's rule: the warning {'stays' if stays else 'goes'}")
        lines.append("")
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
