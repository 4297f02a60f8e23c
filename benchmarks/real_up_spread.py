"""Static-camera real data, no ground truth: how much do per-frame up estimates scatter
(frame mode) compared with the single sequence estimate, and what does `auto` choose?

    python -m benchmarks.real_up_spread [--method pcnet] [--data ../shared/data/real]

Files: boxing_motionbert/X3D.npy (MotionBERT) and every yoga_videopose3d/*.npy
(VideoPose3D), all filmed by static cameras, 30 fps assumed for the yoga exports.
Columns: frame-mode spread of per-frame ups around their robust mean (median and p95, deg),
the sequence estimate's 95 % bootstrap cone (deg), its camera pitch/roll, and auto's choice.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.core.rotations import angle_between
from pcnet.stages.rectify import SequenceEvidence

DEFAULT = SHARED_DATA / "real"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="pcnet")
    ap.add_argument("--data", default=str(DEFAULT))
    args = ap.parse_args()
    data = Path(args.data)
    files = [data / "boxing_motionbert" / "X3D.npy"] + sorted((data / "yoga_videopose3d").glob("*.npy"))
    print(f"{'file':<34}{'frames':>7}{'spread med':>11}{'p95':>7}{'seq cone':>9}{'pitch':>7}{'roll':>7}  auto")
    choices = {}
    for path in files:
        joints = np.load(path)
        joints = joints - joints[:, :1]
        estimator = make_estimator(args.method)
        estimate = estimator(joints, 30.0)
        R, valid = estimate.rotation, estimate.valid
        seq = SequenceEvidence("sequence")(joints, R, valid, 30.0).up
        auto = SequenceEvidence("auto")(joints, R, valid, 30.0).mode
        dev = np.degrees(angle_between(R[valid][:, :, 1], seq.up[None]))
        choices[auto.run] = choices.get(auto.run, 0) + 1
        print(f"{path.parent.name[:6] + '/' + path.stem[:27]:<34}{len(joints):>7}{np.median(dev):>11.1f}"
              f"{np.percentile(dev, 95):>7.1f}{seq.up_uncertainty_deg:>9.2f}{seq.camera_pitch_deg:>7.1f}"
              f"{seq.camera_roll_deg:>7.1f}  {auto.run} ({auto.spread_deg:.1f})")
    print("auto chose:", choices)


if __name__ == "__main__":
    main()
