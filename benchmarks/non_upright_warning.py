"""Decision 0076's trial: does the non-upright warning say more than the uncertainty pcnet prints?

    python -m benchmarks.non_upright_warning --data ../shared/data [--max-clips 200] [--cache DIR]

On the ablation's cached held-out recordings with a truth and a static camera (the three mocap
sets, the same with the camera rolled 30 deg, the real calibrated cameras in 16 views), the
default chain (:func:`benchmarks.ablation.run_variant` of the default variant). Per recording
and mode, whether ``stages/flags.non_upright_flag`` fires (more than half of the valid frames'
trunk, pelvis -> thorax of the input poses, more than ``NON_UPRIGHT_TRUNK_DEG`` from the
answer's up; in sequence mode not where the posture reads lying) and the printed uncertainty's
hit (sequence: both 95 % intervals hold the true camera; frame: the share of frames whose tilt
error is within the per-frame bound). Per mode: mean hit where it fires and where it does not,
their difference (does not - fires) with a 95 % two-sample bootstrap interval over recordings,
and the rule's verdict.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks.report import BOOTSTRAP, print_and_save
from pcnet.stages.core.conventions import PELVIS, THORAX
from pcnet.stages.flags import NON_UPRIGHT_TRUNK_DEG

RESULT = Path(__file__).resolve().parent / "results" / "non_upright_warning.txt"
COMMAND = "python -m benchmarks.non_upright_warning --data ../shared/data"
MODES = ("sequence", "frame")


def fires(ev: dict, up: np.ndarray) -> bool:
    """Whether more than half of the frames with an answer have their trunk beyond the limit."""
    J = ev["J"].astype(np.float64)
    ok = np.isfinite(up).all(-1)
    if not ok.any():
        return False
    return bool(np.mean(A.deg(J[ok, THORAX] - J[ok, PELVIS], up[ok]) > NON_UPRIGHT_TRUNK_DEG) > 0.5)


def reading(ev: dict) -> dict[str, tuple[bool, float]]:
    """``mode -> (fires, hit)`` of one recording under the default chain."""
    o = A.run_variant(ev, A.VARIANTS[0])
    seq_hit = A.interval_hits([o], [ev])
    frame_err = A.deg(o["frame_up"], ev["true_up"])
    ok = np.isfinite(frame_err) & np.isfinite(o["bound"])
    return {"sequence": (fires(ev, o["up"]) and o["posture"] != "lying",
                         float(seq_hit.all(1)[0]) if len(seq_hit) else float("nan")),
            "frame": (fires(ev, o["frame_up"]), float(np.mean(frame_err[ok] <= o["bound"][ok])) if ok.any() else float("nan"))}


def difference_interval(quiet: np.ndarray, fired: np.ndarray, seed: int = 0) -> tuple[float, float, float]:
    """Mean ``quiet`` - mean ``fired`` and its 95 % two-sample bootstrap interval."""
    rng = np.random.default_rng(seed)
    draws = (quiet[rng.integers(0, len(quiet), (BOOTSTRAP, len(quiet)))].mean(1)
             - fired[rng.integers(0, len(fired), (BOOTSTRAP, len(fired)))].mean(1))
    return float(quiet.mean() - fired.mean()), float(np.percentile(draws, 2.5)), float(np.percentile(draws, 97.5))


def main(argv=None) -> int:
    args = A.heldout_arguments(argv, __doc__, "non_upright_warning", RESULT)
    t0 = time.time()
    rows = {m: [] for m in MODES}
    names = {m: [] for m in MODES}
    counts = []
    for title, evs in A.heldout_recordings(args.data, args.cache, args.max_clips):
        if title.startswith("moving camera"):
            continue  # no static truth for a sequence interval
        n_fired = dict.fromkeys(MODES, 0)
        for ev in evs:
            for mode, (fired, hit) in reading(ev).items():
                if np.isfinite(hit):
                    rows[mode].append((fired, hit))
                    n_fired[mode] += fired
                    if fired:
                        names[mode].append(f"{ev['name']} ({hit:.2f})")
        counts.append(f"{title:<46}{len(evs):>6}{n_fired['sequence']:>14}{n_fired['frame']:>8}")
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND} --max-clips {args.max_clips}", "",
             f"{'set':<46}{'recs':>6}{'fires: seq':>14}{'frame':>8}", *counts, ""]
    for mode in MODES:
        r = np.array(rows[mode], float).reshape(-1, 2)
        fired, quiet = r[r[:, 0] > 0, 1], r[r[:, 0] == 0, 1]
        what = "both 95 % intervals hold the truth" if mode == "sequence" else "frames within the per-frame bound"
        lines.append(f"{mode} mode ({what}): fires on {len(fired)} of {len(r)} recordings")
        if len(fired) and len(quiet):
            d, lo, hi = difference_interval(quiet, fired)
            stays = lo > 0
            lines.append(f"  hit where it fires {100 * fired.mean():.1f} %, where it does not {100 * quiet.mean():.1f} %; "
                         f"difference {100 * d:+.1f} [{100 * lo:+.1f}, {100 * hi:+.1f}] points")
        else:
            stays = False
        lines.append(f"  fired on: {', '.join(names[mode]) or 'none'}")
        lines.append(f"  decision 0076's rule: the warning {'stays' if stays else 'goes'} in {mode} mode")
        lines.append("")
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
