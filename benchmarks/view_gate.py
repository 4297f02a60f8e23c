"""The view gate on held-out motion capture: per-frame tilt error of the camera-frame
3DPCNet, the body-frame 3DPCNet and the shipped gated pair, with the camera rolled about its
optical axis (portrait = 90 deg).

    python -m benchmarks.view_gate --data ../shared/data [--stride 3]

Each clip is one recording (the gate's running median runs over its frames in order), seen
by the paper's camera distribution (a new camera every frame, docs/CONVENTIONS.md) and then
by that camera rolled by 0..180 deg: X' = X @ Q.T, true up u' = Q u. Clean poses and
lifter-like noise (models/lifter_noise.py). Clips: DeepMimic (all; another dataset, of which the camera-frame network trained on
three floor clips), Bandai
motion-style test split, CMU test subjects. `--stride` keeps every k-th frame of each clip
(fps divided by k) to bound the run time.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA, data_arguments

from pcnet.models.datasets import load_mocap, make_pairs, select_split
from pcnet.models.inference import BODY_WEIGHTS, CAMERA_WEIGHTS, ViewGatedPCNet
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.core.rotations import angle_between, axis_rotation

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "view_gate.txt"
ROLLS_DEG = (0, 30, 45, 60, 90, 180)
SETS = (("DeepMimic all", "deepmimic_h36m17.npz", "all", False), ("Bandai test", "bandai_h36m17.npz", "test", False),
        ("CMU test", "cmu_train_h36m17.npz", "test", False), ("DeepMimic all lifter", "deepmimic_h36m17.npz", "all", True),
        ("Bandai test lifter", "bandai_h36m17.npz", "test", True))


def rolled_views(clips, lifter: bool, stride: int, rolls=ROLLS_DEG):
    """Per clip and roll: ``(fps, roll, X (N, 17, 3) camera-frame poses, up (N, 3) true up)``,
    the clip seen by the paper's per-frame cameras rolled by ``roll`` deg about the optical
    axis (X' = X @ Q.T, u' = Q u), every ``stride``-th frame."""
    pairs = make_pairs(clips, views="paper", seed=0, camera="per-frame", noise=LifterNoise() if lifter else None)
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)[::stride]
        for roll in rolls:
            Q = axis_rotation("z", np.radians(roll))
            yield clip.fps / stride, roll, pairs.inputs[sel] @ Q.T, pairs.R[sel][:, :, 1] @ Q.T


def tilt_by_roll(path: Path, split: str, lifter: bool, stride: int, gated: ViewGatedPCNet) -> dict:
    """``{(estimator, roll): (sum of tilt errors deg, frames)}`` over the split's clips."""
    clips = select_split(load_mocap(path), split, "motion-style")
    sums: dict = {}
    for fps, roll, X, up in rolled_views(clips, lifter, stride):
        R, _, valid, weight, *_ = gated.predict_gated(X, fps)
        R_cam, R_body = gated.camera.predict(X)[0], gated.body.predict(X)[0]
        for name, est in (("camera-frame", R_cam), ("body-frame", R_body), ("gated", R)):
            e = np.degrees(angle_between(est[valid][:, :, 1], up[valid]))
            s, n = sums.get((name, roll), (0.0, 0))
            sums[(name, roll)] = (s + e.sum(), n + len(e))
        s, n = sums.get(("share", roll), (0.0, 0))
        sums[("share", roll)] = (s + weight[valid].sum(), n + int(valid.sum()))
    return sums


def main() -> None:
    args = data_arguments(__doc__, DEFAULT, RESULT, stride=3)
    gated = ViewGatedPCNet()
    assert gated.camera.path == CAMERA_WEIGHTS and gated.body.path == BODY_WEIGHTS
    t0 = time.perf_counter()
    lines = [__doc__.splitlines()[0], __doc__.splitlines()[1], "",
             f"    python -m benchmarks.view_gate --data {args.data} --stride {args.stride}", "",
             "Mean tilt error (deg) per roll of the camera; 'cam share' = mean camera-frame weight of the gate", "",
             f"{'data':<22}{'estimator':<14}" + "".join(f"{r:>8}" for r in ROLLS_DEG)]
    for label, file, split, lifter in SETS:
        sums = tilt_by_roll(args.data / "mocap" / file, split, lifter, args.stride, gated)
        for name in ("camera-frame", "body-frame", "gated", "share"):
            cells = "".join(f"{sums[(name, r)][0] / max(sums[(name, r)][1], 1):>8.2f}" for r in ROLLS_DEG)
            lines.append(f"{label:<22}{'cam share' if name == 'share' else name:<14}{cells}")
        lines.append("")
        print("\n".join(lines[-5:]), flush=True)
    lines.append(f"run time {time.perf_counter() - t0:.0f} s")
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
