"""How far two upstream estimators' joint angles lie apart on one real video, through the
same `pcnet run`: what swapping the estimator changes, beyond anything pcnet does.

    python -m benchmarks.estimator_agreement [--out benchmarks/results/estimator_agreement.txt]

The bundled boxing clip (pipeline/example_data: 301 frames, one person shadow-boxing, a static
camera; ATTRIBUTION.md) run twice with `pcnet run`'s defaults and no recording:

- MotionBERT's output on AlphaPose's 2D keypoints, the files the README's demo reads;
- the embedded MediaPipe BlazePose GHUM 3D on the video alone (`pcnet run --video`; needs the
  `video` extra).

For every ISB joint angle of `kinematics.csv` (stages/isb_angles.py) and the two unsigned
flexions, over the frames where both runs have a value: the RMS and the median absolute
difference (deg) and the frames compared. Both runs rectify the same camera, so the angles
between segments depend on the two estimators' poses alone and the angles against gravity on
those and on each run's up. No truth: this is agreement, not accuracy. A joint one estimator
loses (MediaPipe's hidden right elbow) is compared only where both see it.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pcnet.pipeline import RunConfig, run_pipeline
from pcnet.stages.isb_angles import NAMES

EXAMPLE = Path(__file__).resolve().parents[1] / "pipeline" / "example_data"
RESULT = Path(__file__).resolve().parent / "results" / "estimator_agreement.txt"
UNSIGNED = tuple(f"{side}_{joint}_flexion_unsigned_deg" for joint in ("knee", "elbow") for side in ("left", "right"))


def angle_columns(folder: Path) -> dict[str, np.ndarray]:
    """``kinematics.csv``'s ISB and unsigned-flexion columns of a run's output ``folder``, NaN where empty."""
    with open(folder / "kinematics.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return {name: np.array([float(r[name]) if r[name] else np.nan for r in rows]) for name in (*NAMES, *UNSIGNED)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    video = EXAMPLE / "boxing2.mp4"
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        runs = {
            "MotionBERT on AlphaPose": RunConfig(video=str(video), keypoints2d=str(EXAMPLE / "alphapose-results.json"),
                                                 keypoints2d_format="alphapose", lifter="motionbert",
                                                 lifter_output=str(EXAMPLE / "X3D.npy"), recording=False,
                                                 out=str(Path(tmp) / "motionbert")),
            "MediaPipe from the video": RunConfig(video=str(video), recording=False, out=str(Path(tmp) / "mediapipe")),
        }
        angles = {}
        for name, cfg in runs.items():
            run_pipeline(cfg.validate(), progress=False)
            angles[name] = angle_columns(Path(cfg.out))
    a, b = angles.values()
    lines = [__doc__.splitlines()[0], "", "    python -m benchmarks.estimator_agreement", "",
             f"{' - '.join(runs)}, boxing clip ({len(next(iter(a.values())))} frames): difference per angle, deg",
             f"{'angle':<40} {'RMS':>6} {'median |d|':>11} {'frames':>7}"]
    for name in (*NAMES, *UNSIGNED):
        both = np.isfinite(a[name]) & np.isfinite(b[name])
        if not both.any():
            lines.append(f"{name:<40} {'-':>6} {'-':>11} {0:>7}")
            continue
        d = a[name][both] - b[name][both]
        lines.append(f"{name:<40} {np.sqrt(np.mean(d ** 2)):>6.1f} {np.median(np.abs(d)):>11.1f} {int(both.sum()):>7}")
    lines += ["", f"({time.time() - t0:.0f} s)"]
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
