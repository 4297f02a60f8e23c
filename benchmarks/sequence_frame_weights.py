"""Sequence up weighted by the per-frame bound: measured against the shipped unweighted robust mean.

    python benchmarks/sequence_frame_weights.py [--data ../shared/data]

Sequence mode's up is the robust spherical mean of the per-frame ups
(pcnet.stages.temporal.sequence_rectify). The shipped pair also gives each frame a calibrated
tilt bound that widens where its two networks disagree (pcnet.stages.uncertainty.frame_tilt_bound).
The alternative weighs each frame's up by (FRAME_TILT_95_DEG / bound)^2, inverse variance, so
frames on poses unlike the training data count less; nothing is fitted. Everything else is
the shipped chain: `pcnet evaluate --method pcnet --camera per-clip --noise lifter --mode
sequence` (pcnet.pipeline.evaluate.evaluate), run twice, the second time with the robust mean
swapped for the weighted one while each clip's bound comes from the same estimator call.
Rows: the motion-style validation split (Bandai validation groups, CMU subjects 12, 60), the
held-out tests (Bandai test groups, CMU subjects 10, 14) and DeepMimic. Writes
benchmarks/results/sequence_frame_weights.txt.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from report import print_and_save  # noqa: E402

import pcnet.pipeline.evaluate as evaluate_module  # noqa: E402
from pcnet.stages import temporal  # noqa: E402
from pcnet.stages.uncertainty import FRAME_TILT_95_DEG, frame_tilt_bound  # noqa: E402

DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data"
RESULT = Path(__file__).resolve().parent / "results" / "sequence_frame_weights.txt"
ROWS = (("bandai_h36m17.npz", "val"), ("cmu_train_h36m17.npz", "val"), ("bandai_h36m17.npz", "test"),
        ("cmu_train_h36m17.npz", "test"), ("deepmimic_h36m17.npz", "all"))


@contextlib.contextmanager
def bound_weighted_sequence_up():
    """Inside: every clip's sequence up is the robust mean weighted by its frames' bounds."""
    bound = {}
    robust_mean, make_estimator = temporal.robust_mean_direction, evaluate_module.make_estimator

    def weighted_mean(u, w=None, init=None):
        b = bound.get("deg")
        if w is not None and b is not None and len(b) == len(w):
            w = w * np.where(np.isfinite(b), (FRAME_TILT_95_DEG / b) ** 2, 0.0)
        return robust_mean(u, w, init)

    def recording_estimator(method, weights):
        estimator = make_estimator(method, weights)

        class Recorded:
            name, frame_tilt_95_deg = estimator.name, estimator.frame_tilt_95_deg

            def __call__(self, joints, fps):
                est = estimator(joints, fps)
                bound["deg"] = frame_tilt_bound(est.disagreement_deg, est.camera_frame_weight)
                return est

        return Recorded()

    temporal.robust_mean_direction, evaluate_module.make_estimator = weighted_mean, recording_estimator
    try:
        yield
    finally:
        temporal.robust_mean_direction, evaluate_module.make_estimator = robust_mean, make_estimator


def tilt(data: Path, name: str, split: str) -> dict:
    return evaluate_module.evaluate("pcnet", data / "mocap" / name, split=split, camera="per-clip", noise="lifter",
                                    mode="sequence")["tilt_deg"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    lines = [__doc__.splitlines()[0], "", "    python benchmarks/sequence_frame_weights.py --data ../shared/data", "",
             "Sequence tilt error, deg, mean / median / p95 (static per-clip camera, lifter-like noise):",
             f"  {'data':<34}{'shipped (unweighted)':>24}{'weighted by the bound':>26}"]
    for name, split in ROWS:
        base = tilt(args.data, name, split)
        with bound_weighted_sequence_up():
            weighted = tilt(args.data, name, split)
        fmt = "{mean:.2f} / {median:.2f} / {p95:.2f}"
        lines.append(f"  {name.split('_')[0] + ' ' + split:<34}{fmt.format(**base):>24}{fmt.format(**weighted):>26}")
        print(lines[-1], flush=True)
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
