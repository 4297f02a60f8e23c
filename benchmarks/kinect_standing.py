"""What a depth sensor's skeleton reads for a person standing at rest: Kinect v1 (UTD-MHAD).

    python -m benchmarks.kinect_standing --data ../shared/data [--trials 1]

A wrist-IMU trial (a rehabilitation researcher) read every UTD-MHAD subject standing still as
leaning back 8-11 deg with hips 15-19 deg extended and knees 6-10 deg hyperextended, with no
word in the output that a Kinect v1 skeleton reads quiet standing that way. This measures it.

Kinect v1: ``real/utd_mhad_imu/`` (UTD-MHAD, research licence, evaluation only; subjects start
each action standing with their arms at their sides, facing a fixed sensor about 3 m away).
Each sequence goes through ``pcnet run``'s own chain (:func:`pcnet.pipeline.run_pipeline`,
``--lifter kinect_v1`` with the defaults, no recording); the statistic is each angle's median
over the frames of the first :data:`REST_S` seconds of its ``kinematics.csv`` (left and right
pooled per recording), then the median and quartiles over recordings and the median per subject.

The trunk's sagittal inclination carries the up pcnet estimated (the sensor's tilt was not
recorded); hip and knee flexion are angles between segments and do not
depend on it. No reference of other people standing is measured here: the training mocap's
clips seldom start at rest.

Writes ``benchmarks/results/kinect_standing.txt``.
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA, print_and_save

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "kinect_standing.txt"

#: The first seconds of a recording read as its rest pose.
REST_S = 0.5
#: (name, kinematics.csv columns pooled).
ANGLES = (("trunk_sagittal_inclination", ("trunk_sagittal_inclination_deg",)),
          ("hip_flexion", ("left_hip_flexion_deg", "right_hip_flexion_deg")),
          ("knee_flexion", ("left_knee_flexion_deg", "right_knee_flexion_deg")))


def kinect_rest(path: Path, work: Path) -> dict[str, float]:
    """One UTD-MHAD file through ``pcnet run``'s chain: each of :data:`ANGLES`' median over the
    first :data:`REST_S` s (NaN where no frame there has it)."""
    from pcnet.pipeline import RunConfig, run_pipeline

    out = work / path.stem
    run_pipeline(RunConfig(lifter="kinect_v1", lifter_output=str(path), out=str(out), recording=False).validate(),
                 progress=False)
    with open(out / "kinematics.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if float(r["time_s"]) < REST_S]
    return {name: _median([float(r[c]) for r in rows for c in columns if r[c] != ""]) for name, columns in ANGLES}


def _median(values) -> float:
    values = np.asarray(values, np.float64)
    values = values[np.isfinite(values)]
    return float(np.median(values)) if len(values) else float("nan")


def _row(label: str, rests: list[dict[str, float]]) -> str:
    cells = []
    for name, _ in ANGLES:
        v = np.array([r[name] for r in rests])
        v = v[np.isfinite(v)]
        cells.append(f"{np.median(v):7.1f} [{np.percentile(v, 25):6.1f}, {np.percentile(v, 75):6.1f}]" if len(v)
                     else f"{'-':>23}")
    return f"{label:<44} {len(rests):5d}  " + "  ".join(cells)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA, help="the shared data folder")
    ap.add_argument("--trials", type=int, nargs="+", default=[1, 2, 3, 4], help="UTD-MHAD trials to read (1-4)")
    args = ap.parse_args(argv)
    start = time.time()
    files = sorted(f for t in args.trials for f in (args.data / "real" / "utd_mhad_imu").glob(f"a*_s*_t{t}.npz"))
    if not files:
        raise SystemExit(f"{args.data}/real/utd_mhad_imu: no a*_s*_t*.npz files of trials {args.trials}")
    kinect, subjects = [], {}
    with tempfile.TemporaryDirectory() as work:
        for f in files:
            rest = kinect_rest(f, Path(work))
            kinect.append(rest)
            subjects.setdefault(int(f.stem.split("_")[1][1:]), []).append(rest)
    lines = [__doc__.splitlines()[0], "",
             "    python -m benchmarks.kinect_standing --data ../shared/data"
             + (f" --trials {' '.join(map(str, args.trials))}" if args.trials != [1, 2, 3, 4] else ""), "",
             f"Each angle's median over a recording's first {REST_S:g} s (left and right pooled); median "
             f"[quartiles] over recordings, deg.", "",
             f"{'set':<44} {'n':>5}  " + "  ".join(f"{name:>23}" for name, _ in ANGLES),
             _row("Kinect v1, UTD-MHAD, pcnet run", kinect)]
    lines += ["", "Kinect v1 per subject (median over its recordings):"]
    lines += [f"  subject {subject}: " + ", ".join(f"{name} {_median([r[name] for r in rests]):.1f}"
                                                  for name, _ in ANGLES) for subject, rests in sorted(subjects.items())]
    lines += ["", f"({time.time() - start:.0f} s)"]
    print_and_save(lines, RESULT)

if __name__ == "__main__":
    main()
