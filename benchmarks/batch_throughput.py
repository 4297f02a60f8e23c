"""Throughput of `pcnet batch` against the number of workers, local engine and Ray.

    python -m benchmarks.batch_throughput [--rows 8] [--tiles 1,20] [--engines local,ray] [--workers 1,2] [--repeat 1]

Manifests of ``--rows`` copies of the bundled real example (boxing video, AlphaPose
Halpe-26, MotionBERT; the demo's settings: 3DPCNet, every export, the rerun recording
with the video), and of the example tiled ``--tiles`` times in length (without the video
then, whose length is fixed): short rows show the fixed costs, long rows the scaling.
Each configuration runs `pcnet batch` as a user would, in a fresh process into fresh
output folders, and is timed from start to exit. ``engine start`` is
what the summary JSON reports for starting the engine (Ray's local instance; 0 for the
local engine, whose workers start while rows are dispatched); ``rows`` is the rest.
Speed-up is against one worker of the same engine, which gets every core's threads
(``max(1, cores // workers)``); ``vs 1x1 thread`` against one worker held to one thread
per library (the scaling of workers alone). ``other jobs CPU s``: CPU time other programs
used meanwhile (local engine only), the noise of a shared machine. Writes
benchmarks/results/batch_throughput.txt (``--no-save`` to skip).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import pcnet.pipeline
from pcnet.pipeline.batch_worker import THREAD_VARIABLES

EXAMPLE = Path(pcnet.pipeline.__file__).parent / "example_data"
RESULTS = Path(__file__).parent / "results" / "batch_throughput.txt"


def tiled_inputs(folder: Path, tile: int) -> dict[str, str]:
    """The example's inputs, ``tile`` times as long (``tile`` 1: the files themselves)."""
    if tile == 1:
        return {"lifter_output": str(EXAMPLE / "X3D.npy"), "keypoints2d": str(EXAMPLE / "alphapose-results.json"),
                "video": str(EXAMPLE / "boxing2.mp4")}
    x3d = np.load(EXAMPLE / "X3D.npy")
    items = json.loads((EXAMPLE / "alphapose-results.json").read_text())
    np.save(folder / "X3D.npy", np.tile(x3d, (tile, 1, 1)))
    tiled = [{**it, "image_id": f"{r * len(x3d) + int(it['image_id'].split('.')[0])}.jpg"}
             for r in range(tile) for it in items]
    (folder / "ap.json").write_text(json.dumps(tiled))
    return {"lifter_output": str(folder / "X3D.npy"), "keypoints2d": str(folder / "ap.json"), "video": ""}


def write_manifest(folder: Path, rows: int, inputs: dict[str, str]) -> Path:
    manifest = folder / "manifest.csv"
    lines = ["lifter,lifter_output,keypoints2d,keypoints2d_format,video,fps,height,out"]
    fps = "" if inputs["video"] else "30"
    lines += [f"motionbert,{inputs['lifter_output']},{inputs['keypoints2d']},alphapose,{inputs['video']},{fps},1.75,"
              f"out/{i:03d}" for i in range(rows)]
    manifest.write_text("\n".join(lines) + "\n")
    return manifest


def busy_cpu_seconds() -> float:
    """CPU seconds every process of the machine has used since boot (/proc/stat; 0 elsewhere)."""
    try:
        fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]
    except OSError:
        return 0.0
    user, nice, system, _idle, _iowait, irq, softirq = (int(v) for v in fields[:7])
    return (user + nice + system + irq + softirq) / os.sysconf("SC_CLK_TCK")


def children_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_once(folder: Path, manifest: Path, engine: str, workers: int, one_thread: bool = False) -> dict:
    """One `pcnet batch` run into fresh outputs: wall seconds, engine start, statuses, and
    the CPU seconds other jobs on the machine used meanwhile (a shared machine's noise:
    machine-wide busy time minus this run's processes)."""
    summary = folder / f"summary-{engine}-{workers}.json"
    cmd = [sys.executable, "-m", "pcnet.pipeline.entry", "batch", str(manifest), "--engine", engine,
           "--workers", str(workers), "--overwrite", "--summary-json", str(summary)]
    # pcnet batch keeps thread counts the user set: one thread per library, whatever the cores
    env = dict(os.environ, **dict.fromkeys(THREAD_VARIABLES, "1")) if one_thread else None
    busy0, ours0 = busy_cpu_seconds(), children_cpu_seconds()
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    # Ray's own processes are not this process's children: their CPU cannot be told apart.
    other = max(0.0, (busy_cpu_seconds() - busy0) - (children_cpu_seconds() - ours0)) if engine == "local" else None
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    data = json.loads(summary.read_text())
    ok = data["counts"]["ok"]
    frames = sum(r["frames"] for r in data["rows"])
    return {"engine": engine, "workers": workers, "wall": wall, "start": data.get("engine_start_seconds", 0.0),
            "ok": ok, "frames": frames, "threads": data["rows"][0].get("threads"), "other": other,
            "one_thread": one_thread}


def table(results: list[dict]) -> list[str]:
    """One line per configuration; speed-up against 1 worker of the same engine (which
    gets every core's threads), and against 1 worker held to 1 thread (scaling alone)."""
    lines = [f"{'engine':<7}{'workers':>8}{'threads':>8}{'wall s':>9}{'engine start s':>16}{'rows s':>9}"
             f"{'speed-up':>10}{'speed-up (rows)':>17}{'vs 1x1 thread':>15}{'frames/s':>10}{'other jobs CPU s':>18}"]
    for r in results:
        same = [b for b in results if b["engine"] == r["engine"] and b["workers"] == 1]
        base = next(b for b in same if not b["one_thread"])
        single = next((b for b in same if b["one_thread"]), None)
        rows_s, base_rows = r["wall"] - r["start"], base["wall"] - base["start"]
        other = "-" if r["other"] is None else f"{r['other']:.1f}"
        scaling = f"{single['wall'] / r['wall']:.2f}x" if single else "-"
        lines.append(f"{r['engine']:<7}{r['workers']:>8}{r['threads'] or '-':>8}{r['wall']:>9.1f}{r['start']:>16.1f}"
                     f"{rows_s:>9.1f}{base['wall'] / r['wall']:>9.2f}x{base_rows / rows_s:>16.2f}x{scaling:>15}"
                     f"{r['frames'] / r['wall']:>10.0f}{other:>18}")
    return lines


def perfect_scaling_bounds(results: list[dict]) -> list[str]:
    """Per engine, the speed-up N workers would reach against the one-worker baseline if
    they scaled perfectly: N single-threaded workers take T(1 worker, 1 thread) / N, and the
    baseline, which gets every core's threads, T(1 worker, cores threads); so the bound is
    N * T(1 worker, cores threads) / T(1 worker, 1 thread). The baseline's own use of the
    other cores (onnxruntime's intra-op threads) lowers it below N."""
    lines = []
    for engine in dict.fromkeys(r["engine"] for r in results):
        same = [r for r in results if r["engine"] == engine and r["workers"] == 1]
        base = next((r for r in same if not r["one_thread"]), None)
        single = next((r for r in same if r["one_thread"]), None)
        if base is None or single is None:
            continue
        for n in sorted({r["workers"] for r in results if r["engine"] == engine and r["workers"] > 1}):
            lines.append(f"{engine}: {n} workers scaling perfectly would give {n * base['wall'] / single['wall']:.2f}x "
                         f"(one worker is {single['wall'] / base['wall']:.2f}x faster with {base['threads']} threads "
                         f"than with 1)")
    return lines


def measure(folder: Path, rows: int, tile: int, engines: list[str], counts: list[int], repeat: int) -> list[str]:
    """Run every configuration on one manifest (``repeat`` rounds, configurations
    interleaved, the fastest run of each kept: other jobs on a shared machine only ever
    slow a run down); its description line and table."""
    sub = folder / f"tile{tile}"
    sub.mkdir()
    manifest = write_manifest(sub, rows, tiled_inputs(sub, tile))
    configs = [(engine, workers, one) for engine in engines for workers in counts
               for one in ((True, False) if workers == 1 else (False,))]
    best: dict[tuple, dict] = {}
    for _ in range(repeat):
        for config in configs:
            run = run_once(sub, manifest, *config)
            print(f"  tile {tile}: {config}: {run['wall']:.1f} s", file=sys.stderr)
            if config not in best or run["wall"] < best[config]["wall"]:
                best[config] = run
    results = [best[config] for config in configs]
    frames = results[0]["frames"] // rows
    what = "the bundled example with its video" if tile == 1 else f"the example tiled x{tile}, without the video"
    return [f"{rows} rows of {what} ({frames} frames each; 3DPCNet, every export, rerun recording)", *table(results),
            *perfect_scaling_bounds(results)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=8)
    ap.add_argument("--tiles", default="1,20", help="manifests to measure: the example tiled this many times in "
                                                     "length (1: as shipped, with its video)")
    ap.add_argument("--engines", default="local,ray")
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--repeat", type=int, default=1, help="rounds; the fastest run of each configuration is kept")
    ap.add_argument("--no-save", action="store_true")
    args = ap.parse_args()
    engines = args.engines.split(",")
    if "ray" in engines:
        try:
            import ray  # noqa: F401
        except ImportError:
            print('ray is not installed (pip install "pcnet[ray]"): local engine only', file=sys.stderr)
            engines.remove("ray")
    counts = [int(w) for w in args.workers.split(",")]
    lines = [f"    python -m benchmarks.batch_throughput --rows {args.rows} --tiles {args.tiles} "
             f"--engines {','.join(engines)} --workers {args.workers} --repeat {args.repeat}", "",
             f"{os.cpu_count()} CPU cores ({platform.machine()}), Python {platform.python_version()}; wall time of "
             f"the whole `pcnet batch` process, fastest of {args.repeat} run(s); speed-up against 1 worker of the "
             f"same engine"]
    with tempfile.TemporaryDirectory() as tmp:
        for tile in (int(t) for t in args.tiles.split(",")):
            lines += ["", *measure(Path(tmp), args.rows, tile, engines, counts, args.repeat)]
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_save:
        RESULTS.write_text(text)


if __name__ == "__main__":
    main()
