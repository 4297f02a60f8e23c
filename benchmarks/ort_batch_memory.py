"""Speed and memory of one shipped 3DPCNet in onnxruntime by batch size, each size in a fresh
process (onnxruntime's CPU arena keeps the largest batch's buffers for the session's life).

    python -m benchmarks.ort_batch_memory [--poses 20000] [--batches 128 256 512 1024 4096]

Inputs are real Bandai poses from the committed test fixture, tiled to ``--poses``. Prints
poses/s of ``PCNetSession.predict`` (models/inference.py) and the process's peak RSS; why
``predict`` batches 256 poses.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

FIXTURE = Path(__file__).resolve().parent.parent / "tests" / "fixtures" / "bandai_small.npz"


def run_one(poses: int, batch: int) -> dict:
    from pcnet.models.inference import CAMERA_WEIGHTS, PCNetSession
    from pcnet.stages.core.conventions import PELVIS

    with np.load(FIXTURE) as d:
        X = np.concatenate([d[k] for k in d.files]).astype(np.float32)
    X = np.tile(X, (-(-poses // len(X)), 1, 1))[:poses]
    X = X - X[:, PELVIS : PELVIS + 1]
    session = PCNetSession(CAMERA_WEIGHTS)
    session.predict(X[:batch], batch_size=batch)  # warm-up
    t0 = time.perf_counter()
    session.predict(X, batch_size=batch)
    seconds = time.perf_counter() - t0
    return {"batch": batch, "poses_per_s": poses / seconds,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=20000)
    ap.add_argument("--batches", type=int, nargs="+", default=[128, 256, 512, 1024, 4096])
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(run_one(args.poses, args.one)))
        return
    print("| batch | poses/s | peak RSS |\n|---|---|---|")
    for batch in args.batches:
        out = subprocess.run([sys.executable, __file__, "--poses", str(args.poses), "--one", str(batch)],
                             capture_output=True, text=True, check=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        print(f"| {r['batch']} | {r['poses_per_s']:,.0f} | {r['peak_rss_mb']:,.0f} MB |", flush=True)


if __name__ == "__main__":
    main()
