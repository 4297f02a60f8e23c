"""Where the shipped pair's two 3DPCNets disagree on real lifter output: which recordings the
disagreement warning (stages/flags.py: disagreement_flag) names.

    python benchmarks/disagreement_real.py --data ../shared/data

Real files without gravity truth: the 88 VideoPose3D yoga files (by asana), the MotionBERT
boxing demo and the MotionBERT cycling clips; pelvis-centred, 30 fps assumed (as
benchmarks/yoga_physics.py). Per file: the share of valid frames whose per-frame bound
(stages/uncertainty.py: frame_tilt_bound) the networks' disagreement at least doubles, the
median disagreement between the two networks' ups, the mean view-gate weight w (0 = the
body-frame network answered alone: a body across the image, whose disagreement is not used);
per group the files the warning names (share > 5 %). Writes
benchmarks/results/disagreement_real.txt.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np

from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.flags import DISAGREEMENT_SHARE
from pcnet.stages.uncertainty import FRAME_TILT_95_DEG, frame_tilt_bound

DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data"
RESULT = Path(__file__).resolve().parent / "results" / "disagreement_real.txt"


def group_of(path: Path) -> str:
    if path.parent.name == "yoga_videopose3d":
        return "yoga " + path.stem.split("_")[-1].replace(".mp4", "")
    return f"{path.parent.name.split('_')[0]} (MotionBERT)"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    args = ap.parse_args()
    real = args.data / "real"
    files = (sorted((real / "yoga_videopose3d").glob("*.npy")) + [real / "boxing_motionbert" / "X3D.npy"]
             + sorted((real / "cycling_motionbert").glob("*.npy")))
    estimator = make_estimator("pcnet")
    groups: dict[str, list] = defaultdict(list)
    for path in files:
        X = np.load(path, allow_pickle=False).astype(np.float64)
        X = X - X[:, :1]
        est = estimator(X, 30.0)
        ok = est.valid
        bound = frame_tilt_bound(est.disagreement_deg, est.camera_frame_weight, alternative_deg=est.level_view_deg)[ok]
        groups[group_of(path)].append((np.mean(bound >= 2 * FRAME_TILT_95_DEG), np.median(est.disagreement_deg[ok]),
                                       np.mean(est.camera_frame_weight[ok])))
    lines = ["python benchmarks/disagreement_real.py --data ../shared/data",
             "| recordings | files | named by the warning | median share of frames | median disagreement, deg | mean w |",
             "|---|---|---|---|---|---|"]
    for name, rows in groups.items():
        r = np.array(rows)
        lines.append(f"| {name} | {len(r)} | {int(np.sum(r[:, 0] > DISAGREEMENT_SHARE))} | {np.median(r[:, 0]):.2f} | "
                     f"{np.median(r[:, 1]):.1f} | {np.mean(r[:, 2]):.2f} |")
        print(lines[-1], flush=True)
    RESULT.write_text("\n".join(lines) + "\n")
    print(f"wrote {RESULT}")


if __name__ == "__main__":
    main()
