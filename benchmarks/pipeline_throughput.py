"""Keypoints-to-exports throughput and peak memory of `pcnet run` on long recordings.

    python -m benchmarks.pipeline_throughput [--minutes 20 60 120] [--fps 30] [--method pcnet] [--mode auto]
                                             [--stage-memory]

Tiles the bundled real boxing example (AlphaPose Halpe-26 JSON + MotionBERT X3D.npy) to each
length, runs the whole pipeline without the video (video decoding excluded) with 3DPCNet
rectification, kinematics, every export and the rerun recording, each length in a fresh
process, and prints frames/s, the per-stage time split and the process's peak resident
memory (``ru_maxrss``; the input files are written by the parent, so their generation does
not count). Bounded memory means the peak stays flat as the recording grows; the
whole-recording arrays go to disk beside the output while the run lasts (their size is
printed). ``--stage-memory`` also prints where the peak is reached, step by step.
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


#: The runner's steps whose resident memory ``--stage-memory`` reports (pipeline/runner.py).
STEPS = ("_load_inputs", "_camera_frame", "rectify_checked", "to_world_floor", "write_kinematics_table", "write_arrays", "write_motion_files",
         "write_figures", "write_rerun")


def _rss_mb() -> float:
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) / 1024 for line in fh if line.startswith("VmRSS"))


def watch_steps(runner) -> list[dict]:
    """Wrap :data:`STEPS` in ``runner`` so that each call records the resident memory (MB,
    ``/proc/self/status`` VmRSS, Linux) before, after and at its highest during the call
    (sampled every 20 ms by a thread); the list fills as the run goes."""
    import threading

    rows: list[dict] = []
    current = {"peak": 0.0}

    def sample() -> None:
        while True:
            current["peak"] = max(current["peak"], _rss_mb())
            time.sleep(0.02)

    threading.Thread(target=sample, daemon=True).start()

    def wrapped(name, f):
        def call(*args, **kwargs):
            before = current["peak"] = _rss_mb()
            out = f(*args, **kwargs)
            rows.append({"step": name, "before_mb": before, "peak_mb": max(current["peak"], _rss_mb()),
                         "after_mb": _rss_mb()})
            return out
        return call

    for name in STEPS:
        setattr(runner, name, wrapped(name, getattr(runner, name)))
    return rows


def run_one(folder: Path, fps: float, method: str, mode: str, stage_memory: bool = False) -> dict:
    """Run the pipeline on the files in ``folder`` in this process; what it measured."""
    from pcnet.pipeline import runner
    from pcnet.pipeline.config import RunConfig
    from pcnet.stages.core.framestore import FrameStore

    steps = watch_steps(runner) if stage_memory else []
    store_bytes = [0]
    close = FrameStore.close

    def measured_close(store) -> None:  # the disk the whole-recording arrays took, before removal
        store_bytes[0] = max(store_bytes[0], sum(f.stat().st_size for f in store.folder.iterdir()))
        close(store)

    FrameStore.close = measured_close
    cfg = RunConfig(lifter="motionbert", lifter_output=str(folder / "X3D.npy"), keypoints2d=str(folder / "ap.json"),
                    keypoints2d_format="alphapose", fps=fps, height=1.75, method=method, mode=mode,
                    out=str(folder / "out"))
    t0 = time.perf_counter()
    result = runner.run_pipeline(cfg, progress=False)
    total = time.perf_counter() - t0
    return {
        "frames": result.frames, "mode": result.mode, "seconds": total,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "outputs_mb": sum(p.stat().st_size for p in (folder / "out").iterdir()) / 1e6,
        "store_mb": store_bytes[0] / 1e6,
        "stages": result.seconds, "steps": steps,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[20, 60, 120])
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--method", default="pcnet")
    ap.add_argument("--mode", default="auto")
    ap.add_argument("--stage-memory", action="store_true",
                    help="also print each step's resident memory before, at its peak and after (Linux)")
    ap.add_argument("--one", type=Path, help=argparse.SUPPRESS)  # child: run the files in this folder
    args = ap.parse_args()
    if args.one:
        print(json.dumps(run_one(args.one, args.fps, args.method, args.mode, args.stage_memory)))
        return
    rows = []
    for minutes in args.minutes:
        frames = int(round(minutes * 60 * args.fps))
        with tempfile.TemporaryDirectory() as tmp:
            write_inputs(Path(tmp), frames)
            child = subprocess.run([sys.executable, __file__, "--one", tmp, "--fps", str(args.fps),
                                    "--method", args.method, "--mode", args.mode]
                                   + (["--stage-memory"] if args.stage_memory else []),
                                   capture_output=True, text=True, check=True)
        r = json.loads(child.stdout.strip().splitlines()[-1])
        rows.append((minutes, r))
        stages = ", ".join(f"{k} {v:.1f}" for k, v in r["stages"].items())
        print(f"{minutes:g} min = {r['frames']} frames, method {args.method}, mode {r['mode']}: {r['seconds']:.1f} s, "
              f"{r['frames'] / r['seconds']:.0f} frames/s, peak RSS {r['peak_rss_mb']:.0f} MB, "
              f"outputs {r['outputs_mb']:.0f} MB, arrays on disk while running {r['store_mb']:.0f} MB; "
              f"stages (s): {stages}", flush=True)
        for st in r["steps"]:
            print(f"    {st['step']:<24} RSS before {st['before_mb']:6.0f}  peak {st['peak_mb']:6.0f}  "
                  f"after {st['after_mb']:6.0f} MB", flush=True)
    print("\n| recording | frames | wall time | frames/s | peak RSS | outputs |\n|---|---|---|---|---|---|")
    for minutes, r in rows:
        print(f"| {minutes:g} min | {r['frames']:,} | {r['seconds']:.0f} s | {r['frames'] / r['seconds']:,.0f} | "
              f"{r['peak_rss_mb']:,.0f} MB | {r['outputs_mb']:,.0f} MB |")


if __name__ == "__main__":
    main()
