"""Keypoints-to-exports throughput of `pcnet run` for a 20-minute recording at 30 fps.

    python benchmarks/pipeline_throughput.py [--frames 36000] [--method pcnet] [--mode auto]

Tiles the bundled real boxing example (AlphaPose Halpe-26 JSON + MotionBERT X3D.npy) to
``--frames`` frames, runs the whole pipeline without the video (video decoding excluded),
with 3DPCNet rectification, kinematics, every export and the rerun recording, and prints
frames/s, the per-stage time split and the peak resident memory of the process.
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

import pcnet.pipeline
from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import run_pipeline

EXAMPLE = Path(pcnet.pipeline.__file__).parent / "example_data"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=36000)
    ap.add_argument("--method", default="pcnet")
    ap.add_argument("--mode", default="auto")
    args = ap.parse_args()
    x3d = np.load(EXAMPLE / "X3D.npy")
    items = json.loads((EXAMPLE / "alphapose-results.json").read_text())
    reps = -(-args.frames // len(x3d))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        np.save(tmp / "X3D.npy", np.tile(x3d, (reps, 1, 1))[: args.frames])
        # Streamed so the input generation does not set this process's peak memory.
        with open(tmp / "ap.json", "w") as fh:
            sep = "["
            for r in range(reps):
                for it in items:
                    k = r * len(x3d) + int(it["image_id"].split(".")[0])
                    if k < args.frames:
                        fh.write(sep + json.dumps({**it, "image_id": f"{k}.jpg"}))
                        sep = ","
            fh.write("]")
        del items
        cfg = RunConfig(lifter="motionbert", lifter_output=str(tmp / "X3D.npy"), keypoints2d=str(tmp / "ap.json"),
                        keypoints2d_format="alphapose", fps=30.0, height=1.75, method=args.method, mode=args.mode,
                        out=str(tmp / "out"))
        t0 = time.perf_counter()
        result = run_pipeline(cfg, progress=False)
        total = time.perf_counter() - t0
        size = sum(p.stat().st_size for p in (tmp / "out").iterdir()) / 1e6
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{args.frames} frames, method {args.method}, mode {result.mode}: {total:.1f} s, "
          f"{args.frames / total:.0f} frames/s, peak RSS {peak_mb:.0f} MB, outputs {size:.0f} MB")
    for name, sec in result.seconds.items():
        print(f"  {name:<11}{sec:7.2f} s  {100 * sec / total:5.1f} %")


if __name__ == "__main__":
    main()
