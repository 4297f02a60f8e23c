"""Sequence up weighted by the per-frame bound (shipped) against equal weights.

    python benchmarks/sequence_frame_weights.py [--data ../shared/data]

Sequence mode's up is the robust spherical mean of the per-frame ups
(pcnet.stages.temporal.sequence_rectify). The shipped pair also gives each frame a calibrated
tilt bound that widens where its two networks disagree (pcnet.stages.uncertainty.frame_tilt_bound),
and the shipped chain weighs each frame's up by (FRAME_TILT_95_DEG / bound)^2, inverse variance
(pcnet.stages.rectify.frame_bound_and_weights), so frames on poses unlike the training data
count less; nothing is fitted. This script runs `pcnet evaluate --method pcnet --camera
per-clip --noise lifter --mode sequence` (pcnet.pipeline.evaluate.evaluate) as shipped and
again with every frame weighted equally (the release before). Rows: the motion-style
validation split (Bandai validation groups, CMU subjects 12, 60), the held-out tests (Bandai
test groups, CMU subjects 10, 14) and DeepMimic. Writes
benchmarks/results/sequence_frame_weights.txt.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from report import print_and_save  # noqa: E402

import pcnet.pipeline.evaluate as evaluate_module  # noqa: E402
import pcnet.stages.rectify as rectify_module  # noqa: E402

DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data"
RESULT = Path(__file__).resolve().parent / "results" / "sequence_frame_weights.txt"
ROWS = (("bandai_h36m17.npz", "val"), ("cmu_train_h36m17.npz", "val"), ("bandai_h36m17.npz", "test"),
        ("cmu_train_h36m17.npz", "test"), ("deepmimic_h36m17.npz", "all"))


@contextlib.contextmanager
def equal_frame_weights():
    """Inside: every clip's sequence up weighs its frames equally (the bound is still computed)."""
    shipped = rectify_module.frame_bound_and_weights
    rectify_module.frame_bound_and_weights = lambda estimate, base: (shipped(estimate, base)[0], None)
    try:
        yield
    finally:
        rectify_module.frame_bound_and_weights = shipped


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
             f"  {'data':<34}{'equal weights':>24}{'weighted by the bound (shipped)':>34}"]
    for name, split in ROWS:
        weighted = tilt(args.data, name, split)
        with equal_frame_weights():
            base = tilt(args.data, name, split)
        fmt = "{mean:.2f} / {median:.2f} / {p95:.2f}"
        lines.append(f"  {name.split('_')[0] + ' ' + split:<34}{fmt.format(**base):>24}{fmt.format(**weighted):>34}")
        print(lines[-1], flush=True)
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
