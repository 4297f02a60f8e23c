"""Auto mode's static/moving decision with its threshold scaled by the recording's evidence scale (tried, not shipped).

    python -m benchmarks.auto_mode_threshold [--data ../shared/data]

`auto` reads a static camera when the spread of the smoothed per-frame ups is at most 5 deg
(stages/temporal.py: choose_mode). Unfamiliar poses (the two networks disagreeing) scatter
the per-frame ups of a static camera too, so a candidate scales the threshold by the
recording's evidence scale (stages/uncertainty.py: evidence_scale; 1 where the networks
agree). Rule written before the mocap rows were run: ship if, on held-out mocap with
lifter-like noise (the motion-style test split and DeepMimic, up to 60 clips of >= 150 frames
each, seed 0), static clips read as static do not drop and clips whose camera pitch sweeps
30 deg over the clip read as moving drop by at most 5 percentage points on every set.
First rows: the real static-camera files (boxing, every yoga file), read as static.
Writes benchmarks/results/auto_mode_threshold.txt.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import data_arguments, print_and_save

from pcnet.models.datasets import load_mocap, make_pairs
from pcnet.models.lifter_noise import LifterNoise
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.core.rotations import axis_rotation
from pcnet.stages.rectify import frame_bound
from pcnet.stages.temporal import MODE_THRESHOLD_DEG, up_spread_deg
from pcnet.stages.uncertainty import evidence_scale

DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data"
RESULT = Path(__file__).resolve().parent / "results" / "auto_mode_threshold.txt"
COMMAND = "python -m benchmarks.auto_mode_threshold --data ../shared/data"
SWEEP_DEG = 30.0
MAX_CLIPS = 60
MIN_FRAMES = 150


def static_reads(estimator, joints: np.ndarray, fps: float) -> tuple[bool, bool]:
    """``(shipped, candidate)``: whether each threshold reads the camera as static."""
    est = estimator(joints, fps)
    bound = frame_bound(est, estimator.frame_tilt_95_deg)
    spread = up_spread_deg(est.rotation, est.valid, fps)
    return spread <= MODE_THRESHOLD_DEG, spread <= MODE_THRESHOLD_DEG * evidence_scale(bound, estimator.frame_tilt_95_deg)


def main() -> None:
    args = data_arguments(__doc__, DEFAULT, RESULT, 1)
    estimator = make_estimator("pcnet")
    real = args.data / "real"
    files = [real / "boxing_motionbert" / "X3D.npy"] + sorted((real / "yoga_videopose3d").glob("*.npy"))
    counts = np.zeros(2, int)
    for path in files:
        joints = np.load(path)
        counts += static_reads(estimator, joints - joints[:, :1], 30.0)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"real static-camera files read as static: shipped {counts[0]}, candidate {counts[1]} of {len(files)}"]
    (test,) = training_mix_splits(args.data, "test")
    deepmimic = load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz")
    rng = np.random.default_rng(0)
    for name, clips in (("motion-style test", test), ("DeepMimic", deepmimic)):
        clips = [c for c in clips if len(c.joints) >= MIN_FRAMES]
        clips = [clips[i] for i in sorted(rng.choice(len(clips), min(MAX_CLIPS, len(clips)), replace=False))]
        pairs = make_pairs(clips, views="paper", seed=0, camera="static", noise=LifterNoise())
        static, moving, n = np.zeros(2, int), np.zeros(2, int), 0
        for i, clip in enumerate(clips):
            X = pairs.inputs[pairs.clip == i]
            if len(X) < MIN_FRAMES:
                continue
            sweep = np.stack([axis_rotation("x", a) for a in np.radians(np.linspace(-1, 1, len(X)) * SWEEP_DEG / 2)])
            static += static_reads(estimator, X, clip.fps)
            moving += ~np.array(static_reads(estimator, np.einsum("tij,tkj->tki", sweep, X).astype(np.float32), clip.fps))
            n += 1
        lines.append(f"{name}, {n} clips: static read as static shipped {static[0]}, candidate {static[1]}; "
                     f"{SWEEP_DEG:.0f} deg sweep read as moving shipped {moving[0]}, candidate {moving[1]}")
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
