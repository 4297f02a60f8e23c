"""Write the DeepMimic floor motions that configs/pcnet_body_floor.toml trains on.

    python -m benchmarks.deepmimic_floor_subset --data ../shared/data [--out runs/deepmimic_floor_train.npz]

No training set of the shipped weights holds a body on the floor; DeepMimic, the
cross-dataset test, holds four floor motions. Issue "Generalise honestly" allows moving a
documented subset of them into training while the rest stays a cross-dataset test: this
script takes :data:`FLOOR_TRAIN` (crawling on hands and knees, getting up from lying face
down and face up) and leaves :data:`FLOOR_HELD_OUT` (rolling on the floor) and every other
DeepMimic clip out, so an evaluation can still score one floor motion never trained on. The
clips and their sidecar metadata (fps, licence, source) are copied unchanged; all three are
from the DeepMimic repository (MIT; motion from CMU/SFU mocap per the DeepMimic paper).
The output stays under runs/ (git-ignored): it is derived data, remade by this command.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

#: The DeepMimic clips moved into training (``deepmimic_h36m17.npz`` names).
FLOOR_TRAIN = ("humanoid3d_crawl.txt", "humanoid3d_getup_facedown.txt", "humanoid3d_getup_faceup.txt")
#: DeepMimic's other floor motion, kept out of training as a floor motion never seen.
FLOOR_HELD_OUT = ("humanoid3d_roll.txt",)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"), help="data root (default ../shared/data)")
    ap.add_argument("--out", type=Path, default=Path("runs/deepmimic_floor_train.npz"))
    ap.add_argument("--overwrite", action="store_true", help="replace an existing --out and its .json")
    args = ap.parse_args()
    taken = [p for p in (args.out, args.out.with_suffix(".json")) if p.exists()]
    if taken and not args.overwrite:
        print(f"--out {args.out}: expected a new file, got existing {', '.join(map(str, taken))}; pass --overwrite to "
              f"replace them", file=sys.stderr)
        return 1
    source = args.data / "mocap" / "deepmimic_h36m17.npz"
    if not source.is_file():
        print(f"{source}: expected DeepMimic's mocap file (../shared/data/README.md), got no such file", file=sys.stderr)
        return 1
    meta = json.loads(source.with_suffix(".json").read_text())
    with np.load(source, allow_pickle=False) as archive:
        clips = {name: archive[name] for name in FLOOR_TRAIN}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    np.savez(args.out, **clips)
    args.out.with_suffix(".json").write_text(json.dumps({name: meta[name] for name in FLOOR_TRAIN}, indent=1) + "\n")
    frames = sum(len(v) for v in clips.values())
    print(f"{args.out}: {len(clips)} DeepMimic floor clips, {frames} frames ({', '.join(FLOOR_TRAIN)}); "
          f"held out: {', '.join(FLOOR_HELD_OUT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
