"""Left-right mirror test-time averaging: each network's up averaged with its answer for the mirrored pose.

    python -m benchmarks.mirror_tta [--data ../shared/data] [--out benchmarks/results/mirror_tta.txt]

The mirror image of a pose seen by a camera is a pose a person could make, seen by the same
camera: x_cam -> -x_cam with every left joint swapped for its right one
(:data:`pcnet.stages.core.conventions.H36M_MIRROR_ORDER`). Its true up is the original's with ``u_x``
negated, so a network's answer for the mirrored pose, mirrored back, is a second estimate of
the same up; their normalised sum is the test-time average. Costs one more network pass per
network (the pair: 4 instead of 2).

Per frame tilt error (deg, angle between estimated and true up; mean, p95) of each shipped
network alone (``PCNetSession``), plain, mirrored back and averaged, on frames both passes
call valid. Sets: the motion-style validation split (Bandai val groups, CMU val subjects),
where a change would be chosen, and DeepMimic (another dataset), clean and with lifter-like
noise (:class:`pcnet.models.lifter_noise.LifterNoise`); per-frame "paper" cameras, seed 0, at
most 40,000 frames per set (evenly spaced, ``make_pairs(max_frames=...)``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import print_and_save, trial_arguments

from pcnet.models.datasets import load_mocap, make_pairs
from pcnet.models.inference import BODY_WEIGHTS, CAMERA_WEIGHTS, PCNetSession
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.core.conventions import H36M_MIRROR_ORDER
from pcnet.stages.core.rotations import angle_between

RESULT = Path(__file__).resolve().parent / "results" / "mirror_tta.txt"
COMMAND = "python -m benchmarks.mirror_tta --data ../shared/data"
MIRROR_X = np.array([-1.0, 1.0, 1.0])
MAX_FRAMES = 40_000


def rows_for(name: str, clips, sessions) -> list[str]:
    out = []
    for noise in (None, LifterNoise()):
        pairs = make_pairs(clips, views="paper", seed=0, camera="per-frame", noise=noise, max_frames=MAX_FRAMES)
        X = pairs.inputs.astype(np.float64)
        truth = pairs.R[:, :, 1]
        mirrored = (X * MIRROR_X)[:, list(H36M_MIRROR_ORDER)]
        for net, session in sessions:
            R, _, ok = session.predict(X)
            Rm, _, ok_m = session.predict(mirrored)
            up, up_back = R[:, :, 1], Rm[:, :, 1] * MIRROR_X
            mean = up + up_back
            mean /= np.linalg.norm(mean, axis=1, keepdims=True)
            both = ok & ok_m
            cells = [np.degrees(angle_between(u, truth))[both] for u in (up, up_back, mean)]
            out.append(f"| {name} | {'lifter noise' if noise else 'clean'} | {net} | {int(both.sum())} | "
                       + " | ".join(f"{c.mean():.2f} / {np.percentile(c, 95):.2f}" for c in cells) + " |")
            print(out[-1], flush=True)
    return out


def main() -> None:
    args = trial_arguments(__doc__, RESULT, script="mirror_tta")
    sessions = [("camera-frame", PCNetSession(CAMERA_WEIGHTS)), ("body-frame", PCNetSession(BODY_WEIGHTS))]
    (val,) = training_mix_splits(args.data, "val")
    lines = [COMMAND, "", "Per-frame tilt error, deg, mean / p95, on frames both passes call valid.", "",
             "| set | input | network | frames | plain | mirrored back | averaged |", "|---|---|---|---|---|---|---|"]
    lines += rows_for("motion-style val", val, sessions)
    lines += rows_for("DeepMimic", load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz"), sessions)
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
