"""Sequence mode under a camera pitched steeply down: where the priors read an upright body as lying.

    python -m benchmarks.steep_camera --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

An upright body filmed from above (a camera on a ceiling rig or a balcony, pitched ``p`` deg down)
and a lying body filmed by a camera pitched about ``90 - p`` deg give the same camera-frame
skeleton, so no likelihood of the poses separates them and the up model's declared priors
decide (docs/up_model.md, "What the poses cannot tell"): the camera prior (pitch N(0, 12 deg),
5 % outside the handheld views) and the lying prior (5 %). This measures where that reading
flips on the held-out mocap (benchmarks/ablation.py's three sets, upright throughout except
DeepMimic's two truly lying clips) with the camera pitched a further :data:`PITCH_DEG` deg down
(:func:`benchmarks.ablation.pitched_recordings`; the sets' own "paper" views are within 25 deg
of level), in sequence mode as ``pcnet run`` runs it, without the lying hypothesis, and with
``--no-camera-prior`` (neither prior).

Per extra pitch and row: the mean and median over clips of the sequence tilt error (deg), the
clips read as lying, and the clips the run summary warns about (``stages/flags.py: posture_flag``: read as
lying, or the lying posture keeping at least 5 % so that the 95 % intervals reach it).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks.report import print_and_save

RESULT = Path(__file__).resolve().parent / "results" / "steep_camera.txt"
COMMAND = "python -m benchmarks.steep_camera --data ../shared/data"
#: The extra camera pitches (deg down) measured.
PITCH_DEG = (0.0, 20.0, 40.0, 60.0)
ROWS = (A.VARIANTS[0], next(v for v in A.VARIANTS if not v.lying and v.prior),
        next(v for v in A.VARIANTS if not v.prior))


def row(evs: list[dict], variant) -> str:
    """One row: mean / median tilt error, clips read as lying, clips warned about."""
    errors, lying, warned = [], 0, 0
    for ev in evs:
        out = A.run_variant(ev, variant)
        errors.append(A.clip_error(out["up"], ev["true_up"]))
        lying += out["posture"] == "lying"
        warned += out.get("posture_warned", False)
    e = np.array(errors)
    return (f"{variant.label:<46}{np.nanmean(e):>8.2f}{np.nanmedian(e):>8.2f}{lying:>7}"
            f"{warned if variant.lying else '-':>8}")


def main(argv: list[str] | None = None) -> int:
    args = A.heldout_arguments(argv, __doc__, "steep_camera", RESULT)
    t0 = time.time()
    static = [A.mocap_set(args.data, args.cache, file, split, args.max_clips) for _, file, split in A.MOCAP_SETS]
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"The held-out mocap ({', '.join(title for title, _, _ in A.MOCAP_SETS)}), a static camera per clip, "
             "lifter noise; sequence tilt error (deg) over clips.", ""]
    for pitch in PITCH_DEG:
        evs = [ev for s in static for ev in s] if pitch == 0 else A.pitched_recordings(args.cache, static,
                                                                                     args.max_clips, pitch)
        lines += [f"## Camera pitched a further {pitch:g} deg down: {len(evs)} clips",
                  f"{'row':<46}{'mean':>8}{'median':>8}{'lying':>7}{'warned':>8}",
                  *(row(evs, v) for v in ROWS), ""]
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
