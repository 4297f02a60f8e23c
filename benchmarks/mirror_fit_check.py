"""Decision 0103's trial: the mirror flag with and without the check that the mirror hypothesis fits.

    python -m benchmarks.mirror_fit_check --data ../shared/data --sets validation
    python -m benchmarks.mirror_fit_check --data ../shared/data --sets heldout

The shipped flag (stages/mirror.py) fires where the posterior odds of a mirror image reach
``MIRROR_ODDS``; a linear discriminant, so a recording that is neither a body nor its mirror
image (a depth sensor reading one subject's knees hyperextended while the elbows bend as a
body's) is called whichever it lies nearer along the discriminant. The variant also asks that
the mirror hypothesis fit: the recording's cues within the 95 % region of ``N(-mu, S)``
(benchmarks/fit_mirror_flag.py ``fires``, ``FIT_D2``). Each set is read as fit_mirror_flag
reads it (a recording, and its mirror image ``z -> -z``), with the shipped fit.

Sets. ``validation``: the training mix's validation split with lifter noise, the real
VideoPose3D yoga and MotionBERT files, and the real Kinect v1 files of UTD-MHAD (where the
question arose). ``heldout``: the ablation's held-out mocap (Bandai motion-style test, CMU test
subjects, DeepMimic) with lifter noise, each clip seen by one static "paper" camera.
"""

from __future__ import annotations

import argparse
import glob
import time
from pathlib import Path

import numpy as np

from benchmarks.ablation import MOCAP_SETS, heldout_clips
from benchmarks.fit_mirror_flag import noisy, reading
from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import SHARED_DATA, print_and_save, require_folder
from pcnet.adapters import load_kinect_v1
from pcnet.stages.core.conventions import PELVIS
from pcnet.stages.mirror import load_mirror_model

RESULTS = Path(__file__).resolve().parent / "results"


def validation_sets(data: Path) -> list[tuple[str, list]]:
    _, val = training_mix_splits(data, "train", "val")
    real = data / "real"
    sets = [("validation split, lifter noise", noisy(val))]
    for label, pattern in (("real VideoPose3D yoga files", "yoga_videopose3d/*.npy"),
                           ("real MotionBERT files (boxing, cycling)", "*motionbert/*.npy")):
        files = sorted(glob.glob(str(real / pattern)))
        sets.append((f"{label} ({len(files)})", [(Path(f).name, np.load(f, allow_pickle=False)) for f in files]))
    kinect = []
    for f in sorted(glob.glob(str(real / "utd_mhad_imu" / "*.npz"))):
        joints = load_kinect_v1(f).joints
        kinect.append((Path(f).name, joints - joints[:, PELVIS:PELVIS + 1]))
    sets.append((f"real Kinect v1 files, UTD-MHAD ({len(kinect)})", kinect))
    return sets


def heldout_sets(data: Path) -> list[tuple[str, list]]:
    return [(f"{label}, lifter noise", noisy(heldout_clips(data, file, split)))
            for label, file, split in MOCAP_SETS]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--sets", choices=("validation", "heldout"), required=True)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    require_folder(args.data, "mirror_fit_check")
    t0 = time.perf_counter()
    model = load_mirror_model()
    sets = validation_sets(args.data) if args.sets == "validation" else heldout_sets(args.data)
    lines = [__doc__.splitlines()[0], "", f"    python -m benchmarks.mirror_fit_check --data ../shared/data --sets "
             f"{args.sets}", ""]
    for variant, check in (("shipped (odds only)", False), ("with the fit check (decision 0103)", True)):
        lines += [f"{variant}:"]
        for label, series in sets:
            lines += reading(model, series, label, fit_check=check)
        lines += [""]
    lines += [f"({time.perf_counter() - t0:.0f} s)"]
    print_and_save(lines, args.out or RESULTS / f"mirror_fit_check_{args.sets}.txt")


if __name__ == "__main__":
    main()
