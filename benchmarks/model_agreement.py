"""Is the remaining per-frame tilt error the model's or the poses'? Two 3DPCNet weight files
on the same frames: each one's mean tilt error, the correlation of their per-frame tilt
errors, and the tilt error of their averaged up vector (a two-model ensemble).

    python -m benchmarks.model_agreement A.onnx B.onnx [--split val] [--views paper] [--noise]

Errors that two differently trained networks share (correlation near 1, no ensemble gain)
belong to the poses: the same body configuration occurs with different true leans, and one
frame cannot tell a leaning body from a tilted camera. Uses the Bandai mocap, the cameras of
`pcnet evaluate` (seed 0, one camera per frame). A shipped file of an earlier release:
`git show COMMIT:models/weights/pcnet_small.onnx > old.onnx`.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.report import SHARED_DATA
from pcnet.models.datasets import Noise, load_mocap, make_pairs, select_split
from pcnet.models.inference import PCNetSession
from pcnet.stages.core.rotations import angle_between, normalize

DEFAULT = SHARED_DATA / "mocap" / "bandai_h36m17.npz"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("weights", nargs=2)
    ap.add_argument("--data", default=str(DEFAULT))
    ap.add_argument("--split", default="val")
    ap.add_argument("--views", default="paper")
    ap.add_argument("--noise", action="store_true")
    args = ap.parse_args()
    clips = select_split(load_mocap(args.data), args.split)
    pairs = make_pairs(clips, views=args.views, seed=0, noise=Noise() if args.noise else None)
    true_up = pairs.R[:, :, 1]
    ups, errors = [], []
    for w in args.weights:
        R = PCNetSession(w).predict(pairs.inputs)[0]
        ups.append(R[:, :, 1])
        errors.append(np.degrees(angle_between(R[:, :, 1], true_up)))
    ok = np.isfinite(errors[0]) & np.isfinite(errors[1])
    print(f"{args.split} split, {args.views} views, noise={args.noise}, {ok.sum()} frames; tilt error (deg)")
    for w, e in zip(args.weights, errors):
        print(f"  {w:<50} mean {e[ok].mean():.3f}")
    print(f"  correlation of the per-frame tilt errors        {np.corrcoef(errors[0][ok], errors[1][ok])[0, 1]:.3f}")
    ensemble = np.degrees(angle_between(normalize(ups[0] + ups[1]), true_up))
    print(f"  ensemble (normalised mean of the two up vectors) mean {ensemble[ok].mean():.3f}")


if __name__ == "__main__":
    main()
