"""Keypoints-to-exports throughput and peak memory of `pcnet run` on long recordings.

    python benchmarks/pipeline_throughput.py [--minutes 20 60 120] [--fps 30] [--method pcnet] [--mode auto]

Tiles the bundled real boxing example (AlphaPose Halpe-26 JSON + MotionBERT X3D.npy) to each
length, runs the whole pipeline without the video (video decoding excluded) with 3DPCNet
rectification, kinematics, every export and the rerun recording, each length in a fresh
process, and prints frames/s, the per-stage time split and the process's peak resident
memory (``ru_maxrss``; the input files are written by the parent, so their generation does
not count). Bounded memory means the peak stays flat as the recording grows.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import pcnet.pipeline

EXAMPLE = Path(pcnet.pipeline.__file__).parent / "example_data"


def write_inputs(folder: Path, frames: int) -> tuple[Path, Path]:
    """The example tiled to ``frames`` frames: (AlphaPose JSON, MotionBERT X3D.npy)."""
    x3d = np.load(EXAMPLE / "X3D.npy")
    items = json.loads((EXAMPLE / "alphapose-results.json").read_text())
    reps = -(-frames // len(x3d))
    np.save(folder / "X3D.npy", np.tile(x3d, (reps, 1, 1))[:frames])
    with open(folder / "ap.json", "w") as fh:
        sep = "["
        for r in range(reps):
            for it in items:
                k = r * len(x3d) + int(it["image_id"].split(".")[0])
                if k < frames:
                    fh.write(sep + json.dumps({**it, "image_id": f"{k}.jpg"}))
                    sep = ","
        fh.write("]")
    return folder / "ap.json", folder / "X3D.npy"


def run_one(folder: Path, fps: float, method: str, mode: str) -> dict:
    """Run the pipeline on the files in ``folder`` in this process; what it measured."""
    from pcnet.pipeline.config import RunConfig
    from pcnet.pipeline.runner import run_pipeline

    cfg = RunConfig(lifter="motionbert", lifter_output=str(folder / "X3D.npy"), keypoints2d=str(folder / "ap.json"),
                    keypoints2d_format="alphapose", fps=fps, height=1.75, method=method, mode=mode,
                    out=str(folder / "out"))
    t0 = time.perf_counter()
    result = run_pipeline(cfg, progress=False)
    total = time.perf_counter() - t0
    return {
        "frames": result.frames, "mode": result.mode, "seconds": total,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "outputs_mb": sum(p.stat().st_size for p in (folder / "out").iterdir()) / 1e6,
        "stages": result.seconds,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[20, 60, 120])
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--method", default="pcnet")
    ap.add_argument("--mode", default="auto")
    ap.add_argument("--one", type=Path, help=argparse.SUPPRESS)  # child: run the files in this folder
    args = ap.parse_args()
    if args.one:
        print(json.dumps(run_one(args.one, args.fps, args.method, args.mode)))
        return
    rows = []
    for minutes in args.minutes:
        frames = int(round(minutes * 60 * args.fps))
        with tempfile.TemporaryDirectory() as tmp:
            write_inputs(Path(tmp), frames)
            child = subprocess.run([sys.executable, __file__, "--one", tmp, "--fps", str(args.fps),
                                    "--method", args.method, "--mode", args.mode],
                                   capture_output=True, text=True, check=True)
        r = json.loads(child.stdout.strip().splitlines()[-1])
        rows.append((minutes, r))
        stages = ", ".join(f"{k} {v:.1f}" for k, v in r["stages"].items())
        print(f"{minutes:g} min = {r['frames']} frames, method {args.method}, mode {r['mode']}: {r['seconds']:.1f} s, "
              f"{r['frames'] / r['seconds']:.0f} frames/s, peak RSS {r['peak_rss_mb']:.0f} MB, "
              f"outputs {r['outputs_mb']:.0f} MB; stages (s): {stages}", flush=True)
    print("\n| recording | frames | wall time | frames/s | peak RSS | outputs |\n|---|---|---|---|---|---|")
    for minutes, r in rows:
        print(f"| {minutes:g} min | {r['frames']:,} | {r['seconds']:.0f} s | {r['frames'] / r['seconds']:,.0f} | "
              f"{r['peak_rss_mb']:,.0f} MB | {r['outputs_mb']:,.0f} MB |")


if __name__ == "__main__":
    main()
