"""The shipped per-frame tilt bound under one static camera per clip, as users film, against
the calibration protocol's new camera every frame; coverage per frame and per clip.

    python -m benchmarks.frame_bound_static --data ../shared/data

The bound (pcnet.stages.uncertainty.frame_tilt_bound, shipped constants) was calibrated by
benchmarks/calibrate_frame_bound.py with a new "paper" camera every frame
(make_pairs(camera="per-frame")). A recording has one camera: make_pairs(camera="static") draws
one "paper" camera per clip (same seed, same lifter-like noise). Both protocols run on the
motion-style test split and DeepMimic (the shipped pair, frame mode, every valid frame). Per
protocol: the share of frames within their bound, and, since frames cluster by clip, the clips'
own coverage: median, 10th percentile, and the share of clips covered in fewer than 80 % and
50 % of their frames. Writes benchmarks/results/frame_bound_static.txt.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.calibrate_frame_bound import frames_of, mocap_views
from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import print_and_save, trial_arguments

from pcnet.models.datasets import load_mocap
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages import uncertainty

RESULT = Path(__file__).resolve().parent / "results" / "frame_bound_static.txt"
COMMAND = "python -m benchmarks.frame_bound_static --data ../shared/data"


def clip_coverage(estimator, clips, camera: str) -> list[np.ndarray]:
    """Per clip, a bool array: each valid frame's tilt error within its shipped bound."""
    covered = []
    for view in mocap_views(clips, camera=camera):
        e, d, w = frames_of(estimator, [view])
        if len(e):
            covered.append(e <= uncertainty.frame_tilt_bound(d, w))
    return covered


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="frame_bound_static")
    estimator = make_estimator("pcnet")
    (test,) = training_mix_splits(args.data, "test")
    sets = {"motion-style test": test, "DeepMimic": load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz")}
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"  {'data':<20}{'camera':<12}{'clips':>6}{'frames':>8}{'frames covered':>16}{'clip median':>13}"
             f"{'clip p10':>10}{'clips < 80 %':>14}{'clips < 50 %':>14}"]
    for name, clips in sets.items():
        for camera in ("per-frame", "static"):
            per_clip = clip_coverage(estimator, clips, camera)
            share = np.array([c.mean() for c in per_clip])
            frames = np.concatenate(per_clip)
            lines.append(f"  {name:<20}{camera:<12}{len(per_clip):>6}{len(frames):>8}{frames.mean():>16.1%}"
                         f"{np.median(share):>13.1%}{np.percentile(share, 10):>10.1%}{np.mean(share < 0.8):>14.1%}"
                         f"{np.mean(share < 0.5):>14.1%}")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
