"""Two camera-frame 3DPCNets trained on different camera views, alone and gated with the
shipped body-frame network, per camera roll: does a camera-frame network that trained on
rolled cameras stay the more accurate one further from level?

    python -m benchmarks.camera_views CANDIDATE.onnx --data ../shared/data --split val \
        [--ramps 10,20 20,30] [--level-ramps 3,8] [--level-reading body] [--ensemble] [--stride 3]

Protocol of benchmarks/view_gate.py and view_gate_rule.py: each clip one recording, the
paper's camera distribution (a new camera every frame, docs/CONVENTIONS.md) rolled about the
optical axis by each roll (X' = X @ Q.T, true up u' = Q u), clean poses and lifter-like noise
(models/lifter_noise.py), every ``--stride``-th frame; per-frame tilt error, mean (deg). Rows:
each camera-frame network alone, and each gated with the shipped body-frame network by
:func:`pcnet.models.view_gate.camera_frame_weight` with each roll ramp of ``--ramps`` (the
shipped ramp is 10-20 deg). ``--level-ramps a,b`` adds three-network rows: the shipped gate
decides between the camera-frame side and the body-frame network, and on the camera-frame
side the shipped network answers while the body-frame network (``--level-reading camera``: the
shipped camera-frame network) reads under ``a`` deg of roll (its running median, as the gate's),
the candidate from ``b`` deg, blended between. ``--ensemble`` adds the two camera-frame
networks' mean (the geodesic midpoint of their rotations, :func:`blend_rotations` at 0.5; for a
candidate that is another seed of the shipped recipe), alone and gated. ``--split val`` is where a ramp may be chosen (the training mix's
motion-style validation split); ``test`` (the training mix's test split), ``cmu-test`` and
``deepmimic`` are held out.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import SHARED_DATA, print_and_save
from benchmarks.view_gate import rolled_views

from pcnet.models.datasets import load_mocap, select_split
from pcnet.models.inference import BODY_WEIGHTS, CAMERA_WEIGHTS, PCNetSession, normalized_in_chunks
from pcnet.models.view_gate import (ROLL_RAMP_DEG, blend_rotations, camera_frame_weight, camera_view_estimate,
                                    window_frames)
from pcnet.stages.core.rotations import angle_between

DEFAULT = SHARED_DATA
ROLLS_DEG = (0, 10, 15, 20, 30, 45, 90)
SPLITS = ("val", "test", "cmu-test", "deepmimic")


def load_clips(data: Path, split: str):
    """The clips of ``split`` (:data:`SPLITS`)."""
    if split == "deepmimic":
        return select_split(load_mocap(data / "mocap" / "deepmimic_h36m17.npz"), "all", "motion-style")
    if split == "cmu-test":
        return select_split(load_mocap(data / "mocap" / "cmu_train_h36m17.npz"), "test", "motion-style")
    return training_mix_splits(data, split)[0]


def tilt_by_estimator(clips, lifter: bool, stride: int, cameras: dict, body: PCNetSession,
                      ramps: list[tuple[float, float]], level_ramps: list[tuple[float, float]] = (),
                      level_reading: str = "body", ensemble: bool = False) -> dict:
    """``{(row, roll): (sum of tilt errors deg, frames)}``: each camera-frame network alone
    (row = its label) and gated with ``body`` under each ramp (row = ``label, ramp a-b``);
    with ``level_ramps`` the three-network rows of the module docstring (``cameras`` holds the
    shipped network first, the candidate second), on ``level_reading``'s roll reading; with
    ``ensemble`` the two camera-frame networks' mean alone and gated."""
    sums: dict = {}

    def add(row, roll, R, up, valid):
        e = np.degrees(angle_between(R[valid][:, :, 1], up[valid]))
        s, n = sums.get((row, roll), (0.0, 0))
        sums[(row, roll)] = (s + e.sum(), n + len(e))

    for fps, roll, X, up in rolled_views(clips, lifter, stride, ROLLS_DEG):
        normalized = normalized_in_chunks(X)
        R_body, _, valid = body.predict_normalized(*normalized)
        add("body-frame alone", roll, R_body, up, valid)
        answers = {}
        for label, session in cameras.items():
            R_cam, _, ok = session.predict_normalized(*normalized)
            both = valid & ok
            answers[label] = R_cam, both
            add(f"{label} alone", roll, R_cam, up, both)
            for ramp in ramps:
                w = camera_frame_weight(R_body, both, fps, R_cam, roll_ramp_deg=ramp)
                add(f"{label} + body, ramp {ramp[0]:g}-{ramp[1]:g}", roll, blend_rotations(R_body, R_cam, w), up, both)
        (R_ship, ok_ship), (R_cand, ok_cand) = answers.values()
        both = ok_ship & ok_cand
        if ensemble and both.any():
            R_mean = blend_rotations(R_ship, R_cand, np.full(len(both), 0.5))
            add("mean of the two alone", roll, R_mean, up, both)
            for ramp in ramps:
                w = camera_frame_weight(R_body, both, fps, R_mean, roll_ramp_deg=ramp)
                add(f"mean of the two + body, ramp {ramp[0]:g}-{ramp[1]:g}", roll, blend_rotations(R_body, R_mean, w), up, both)
        if level_ramps and both.any():
            w_cam = camera_frame_weight(R_body, both, fps, R_ship)
            reading = np.full(len(both), np.nan)
            R_read = R_body if level_reading == "body" else R_ship
            reading[both] = camera_view_estimate(R_read[both], window_frames(fps))[0]
            for ramp in level_ramps:
                w_level = np.clip((ramp[1] - reading) / (ramp[1] - ramp[0]), 0.0, 1.0)  # 1 = the shipped network
                R_side = blend_rotations(R_cand, R_ship, w_level)
                add(f"three networks, level ramp {ramp[0]:g}-{ramp[1]:g}", roll, blend_rotations(R_body, R_side, w_cam), up, both)
    return sums


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("candidate", type=Path, help="the other camera-frame network's ONNX weights")
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--split", choices=SPLITS, default="val")
    ap.add_argument("--ramps", nargs="+", default=[f"{ROLL_RAMP_DEG[0]:g},{ROLL_RAMP_DEG[1]:g}"],
                    help="roll ramps a,b (deg) of the gate")
    ap.add_argument("--level-ramps", nargs="*", default=[], help="three-network rows: roll ramps a,b (deg)")
    ap.add_argument("--level-reading", choices=("body", "camera"), default="body",
                    help="whose roll reading the three-network rows' ramp reads")
    ap.add_argument("--ensemble", action="store_true", help="rows of the two camera-frame networks' mean")
    ap.add_argument("--stride", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    ramps = [tuple(float(v) for v in r.split(",")) for r in args.ramps]
    level_ramps = [tuple(float(v) for v in r.split(",")) for r in args.level_ramps]
    clips = load_clips(args.data, args.split)
    cameras = {"shipped camera-frame": PCNetSession(CAMERA_WEIGHTS), "candidate": PCNetSession(args.candidate)}
    body = PCNetSession(BODY_WEIGHTS)
    command = (f"    python -m benchmarks.camera_views {args.candidate} --data {args.data} --split {args.split} "
               f"--ramps {' '.join(args.ramps)} "
               + (f"--level-ramps {' '.join(args.level_ramps)} --level-reading {args.level_reading} "
                  if args.level_ramps else "") + ("--ensemble " if args.ensemble else "") + f"--stride {args.stride}")
    lines = [command, "", f"candidate: {args.candidate}; mean per-frame tilt error (deg) per camera roll, "
                          f"{len(clips)} clips, every {args.stride}th frame", ""]
    for lifter in (False, True):
        sums = tilt_by_estimator(clips, lifter, args.stride, cameras, body, ramps, level_ramps, args.level_reading,
                                 args.ensemble)
        rows = sorted({row for row, _ in sums}, key=lambda r: (not r.startswith("body"), r))
        width = max(len(r) for r in rows) + 2
        lines.append(f"{'noise ' + ('lifter' if lifter else 'clean'):<{width}}" + "".join(f"{r:>8}" for r in ROLLS_DEG))
        for row in rows:
            lines.append(f"{row:<{width}}" + "".join(f"{sums[(row, r)][0] / sums[(row, r)][1]:>8.2f}" for r in ROLLS_DEG))
        lines.append("")
    out = args.out or Path(__file__).resolve().parent / "results" / f"camera_views_{args.split}.txt"
    print_and_save(lines, out)


if __name__ == "__main__":
    main()
