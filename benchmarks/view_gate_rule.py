"""The view gate's rule, measured where it was chosen: the shipped rule (models/view_gate.py)
against the two earlier releases' rules, per-frame tilt error with the camera rolled 0-180 deg.

    python -m benchmarks.view_gate_rule --data ../shared/data [--split val] [--stride 3]

Rules (w = the camera-frame network's weight; in(x) = 1 up to 20 deg roll / 40 deg pitch, 0
from 30 / 50, linear between):
- release 1, body reading: w = in(body-frame reading);
- release 2, both readings: w = max(in(body), in(camera-frame reading) * near(body)), near =
  1 below 45 deg roll / 60 deg pitch of the body-frame reading, 0 from 60 / 75;
- release 4, roll 10-20: models/view_gate.py: camera_frame_weight, release 2 with both
  readings' roll ramp at 10-20 deg (in(x) = 1 up to 10 deg roll, 0 from 20);
- shipped: that rule in the camera frame turned back by the quarter turns the body-frame
  network reads (models/view_gate.py: quarter_turns; ViewGatedPCNet.predict_gated).

`--split val` (default) is the motion-style validation split of the training mix (Bandai
validation groups, CMU subjects 12 and 60), on which the rules and their limits were chosen
(the 10-20 deg roll ramp with exploratory runs on `test` and `deepmimic` in view too: README);
`test` the motion-style test split, `deepmimic` every DeepMimic clip. Same protocol as
benchmarks/view_gate.py (the paper's camera distribution, a new camera every frame, clean
poses and lifter-like noise, every `--stride`-th frame).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import SHARED_DATA, print_and_save
from benchmarks.view_gate import rolled_views

from pcnet.models.datasets import load_mocap, select_split
from pcnet.models.inference import ViewGatedPCNet, normalized_in_chunks
from pcnet.models.view_gate import blend_rotations, camera_frame_weight
from pcnet.stages.core.rotations import angle_between

DEFAULT = SHARED_DATA
ROLLS_DEG = (0, 15, 30, 45, 60, 90, 180)
RULES = ("camera-frame alone", "body-frame alone", "release 1: body reading", "release 2: both readings",
         "release 4: roll 10-20", "shipped: quarter turns")


#: The roll ramp (deg) of releases 1 and 2.
EARLIER_ROLL_RAMP_DEG = (20.0, 30.0)


def tilt_by_rule(clips, lifter: bool, stride: int, pair: ViewGatedPCNet) -> dict:
    """``{(rule, roll): (sum of tilt errors deg, frames)}`` over ``clips``."""
    sums: dict = {}
    for fps, roll, X, up in rolled_views(clips, lifter, stride, ROLLS_DEG):
        normalized = normalized_in_chunks(X)
        R_cam, _, valid = pair.camera.predict_normalized(*normalized)
        R_body, _, _ = pair.body.predict_normalized(*normalized)
        w1 = camera_frame_weight(R_body, valid, fps, roll_ramp_deg=EARLIER_ROLL_RAMP_DEG)
        w2 = camera_frame_weight(R_body, valid, fps, R_cam, roll_ramp_deg=EARLIER_ROLL_RAMP_DEG)
        estimates = (R_cam, R_body, blend_rotations(R_body, R_cam, w1), blend_rotations(R_body, R_cam, w2),
                     blend_rotations(R_body, R_cam, camera_frame_weight(R_body, valid, fps, R_cam)),
                     pair.predict_gated(X, fps)[0])
        for rule, R in zip(RULES, estimates):
            e = np.degrees(angle_between(R[valid][:, :, 1], up[valid]))
            s, n = sums.get((rule, roll), (0.0, 0))
            sums[(rule, roll)] = (s + e.sum(), n + len(e))
    return sums


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--split", choices=("val", "test", "deepmimic"), default="val")
    ap.add_argument("--stride", type=int, default=3)
    args = ap.parse_args()
    if args.split == "deepmimic":
        clips = select_split(load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz"), "all", "motion-style")
    else:
        clips = training_mix_splits(args.data, args.split)[0]
    pair = ViewGatedPCNet()
    lines = [f"    python -m benchmarks.view_gate_rule --data {args.data} --split {args.split} --stride {args.stride}", "",
             f"Mean tilt error (deg) per camera roll, {len(clips)} clips", ""]
    for lifter in (False, True):
        sums = tilt_by_rule(clips, lifter, args.stride, pair)
        lines.append(f"{'noise ' + ('lifter' if lifter else 'clean'):<28}" + "".join(f"{r:>8}" for r in ROLLS_DEG))
        for rule in RULES:
            lines.append(f"{rule:<28}" + "".join(f"{sums[(rule, r)][0] / sums[(rule, r)][1]:>8.2f}" for r in ROLLS_DEG))
        lines.append("")
    print_and_save(lines, Path(__file__).resolve().parent / "results" / f"view_gate_rule_{args.split}.txt")


if __name__ == "__main__":
    main()
