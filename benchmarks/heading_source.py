"""Where would `--heading auto` take the heading from, on real lifter output and on mocap?

    python -m benchmarks.heading_source [--data ../shared/data]

Writes benchmarks/results/heading_source.txt.

Real files (no ground truth): boxing_motionbert/X3D.npy, cycling_motionbert/*.npy
(MotionBERT) and every yoga_videopose3d/*.npy (VideoPose3D). Mocap: every clip of the Bandai
test split and of DeepMimic, clean and with `pcnet evaluate --noise`'s upstream-like noise.
Columns: hip-width coefficient of variation (percent; what `auto` decides on, threshold
`AUTO_MAX_HIP_WIDTH_CV_PERCENT`), median |hip-line heading - 3DPCNet heading| (deg), choice.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA, print_and_save

from pcnet.adapters import load_motionbert, load_videopose3d
from pcnet.models.datasets import Noise, load_mocap, make_pairs, select_split
from pcnet.stages.heading import AUTO_MAX_HIP_WIDTH_CV_PERCENT, apply_heading
from pcnet.stages.rectification_report import HeadingChoice
from pcnet.pipeline.rectification import make_estimator

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "heading_source.txt"
COMMAND = "python -m benchmarks.heading_source --data ../shared/data"


def decide(joints: np.ndarray) -> HeadingChoice:
    estimate = make_estimator("pcnet")(joints, 30.0)
    return apply_heading(joints, estimate.rotation, estimate.valid, "auto")[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DEFAULT))
    data = Path(ap.parse_args().data)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"auto uses the hips when the hip width varies by <= {AUTO_MAX_HIP_WIDTH_CV_PERCENT} % (CV)", ""]
    lines.append(f"{'real file':<40}{'frames':>7}{'hip CV %':>9}{'|dh| med':>9}  heading from")
    real = [(load_motionbert, p) for p in sorted((data / "real").glob("*_motionbert/*X3D*.npy"))]
    real += [(load_videopose3d, p) for p in sorted((data / "real" / "yoga_videopose3d").glob("*.npy"))]
    chosen: dict[str, int] = {}
    for loader, path in real:
        poses = loader(path)
        joints = poses.joints - poses.joints[:, :1]
        rep = decide(joints)
        chosen[rep.source] = chosen.get(rep.source, 0) + 1
        lines.append(f"{path.parent.name[:8] + '/' + path.stem[:31]:<40}{len(joints):>7}{rep.hip_width_cv_percent:>9.2f}"
              f"{rep.difference_median_deg:>9.1f}  {rep.source}")
    lines.append(f"real files, heading from: {chosen}")
    lines.append(f"\n{'mocap clips':<34}{'hip CV % min / median / max':>30}  heading from")
    for name, split in (("bandai_h36m17.npz", "test"), ("deepmimic_h36m17.npz", "all")):
        clips = select_split(load_mocap(data / "mocap" / name), split)
        for noise in (None, Noise()):
            pairs = make_pairs(clips, views="paper", seed=0, noise=noise)
            cvs, srcs = [], {}
            for i in range(len(clips)):
                sel = pairs.clip == i
                if sel.sum() == 0:
                    continue
                rep = decide(pairs.inputs[sel])
                cvs.append(rep.hip_width_cv_percent)
                srcs[rep.source] = srcs.get(rep.source, 0) + 1
            lo, med, hi = np.nanpercentile(cvs, [0, 50, 100])
            label = f"{name.split('_')[0]} {split}, {'noise' if noise else 'clean'}"
            lines.append(f"{label:<34}{lo:>10.2f} / {med:>6.2f} / {hi:>6.2f}  {srcs}")
    print_and_save(lines, RESULT)


if __name__ == "__main__":
    main()
