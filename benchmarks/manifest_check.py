"""Time `pcnet batch`'s check of a whole manifest before any work, and a row's output
staging beside as many finished outputs (issue 53).

    python -m benchmarks.manifest_check [--rows 100000] [--folder /tmp/pcnet_manifest_check] [--profile]

Builds a study folder as a big study has it: a few real recordings (the bundled boxing
example: video, AlphaPose JSON, MotionBERT X3D.npy, copied into ``recordings/r0`` ...
``recordings/r4``) named by ``--rows`` rows with relative paths, each row writing its own
``out`` under one parent folder (``outputs/s000001`` ...), with the subject's height, the
method and the mode. Then times, in this fresh process,
:func:`pcnet.pipeline.batch.plan_batch`: every check `pcnet batch MANIFEST` makes before it
writes the summary and starts its workers (`pcnet batch` has no check-only option; right
after the check it writes the summary, every row pending, and starts the engine). The time
includes the imports the first row's validation needs (SciPy, about 1 s). Prints the wall
and CPU time (CPU time: the check's own cost, on a machine shared with other jobs).
``--profile`` runs the check under cProfile and prints the top functions.

Then creates ``--rows`` empty folders in ``outputs/`` (the study's finished outputs) and times
what publishing one more row's output costs beside them, without the pipeline's own work:
:func:`~pcnet.pipeline.outdir.check_out_folder` and
:func:`~pcnet.pipeline.outdir.staged_output` (its clean-up of leftovers scans the folder),
the median of 5 rows.

Requirement: 100,000 rows checked in under 10 s on a 2-core machine; staging that does not
grow with the rows beyond a folder scan.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import shutil
import time
from pathlib import Path

import statistics

import pcnet.pipeline
from pcnet.pipeline.batch import BatchOptions, plan_batch
from pcnet.pipeline.outdir import check_out_folder, staged_output

EXAMPLE = Path(pcnet.pipeline.__file__).parent / "example_data"
HEADER = "lifter,lifter_output,keypoints2d,keypoints2d_format,video,height,method,mode,out"
RECORDINGS = 5


def build_study(folder: Path, rows: int) -> Path:
    """The study folder with ``rows`` rows over :data:`RECORDINGS` recordings (replacing
    ``folder``); returns the manifest."""
    if folder.exists():
        shutil.rmtree(folder)
    for r in range(RECORDINGS):
        recording = folder / "recordings" / f"r{r}"
        recording.mkdir(parents=True)
        for name in ("X3D.npy", "alphapose-results.json", "boxing2.mp4"):
            shutil.copyfile(EXAMPLE / name, recording / name)
    (folder / "outputs").mkdir()
    lines = [HEADER]
    for i in range(1, rows + 1):
        r = f"recordings/r{i % RECORDINGS}"
        lines.append(f"motionbert,{r}/X3D.npy,{r}/alphapose-results.json,alphapose,{r}/boxing2.mp4,"
                     f"{1.5 + (i % 50) / 100:.2f},pcnet,auto,outputs/s{i:06d}")
    manifest = folder / "manifest.csv"
    manifest.write_text("\n".join(lines) + "\n")
    return manifest


def time_check(manifest: Path, profile: bool = False) -> tuple[float, float]:
    """Wall and CPU seconds of :func:`plan_batch` on ``manifest`` (every row to run)."""
    profiler = cProfile.Profile() if profile else None
    wall, cpu = time.perf_counter(), time.process_time()
    if profiler:
        profiler.enable()
    planned, _ = plan_batch(manifest, BatchOptions())
    if profiler:
        profiler.disable()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    assert all(item.action == "run" for item in planned)
    if profiler:
        pstats.Stats(profiler).sort_stats("cumulative").print_stats(25)
        pstats.Stats(profiler).sort_stats("tottime").print_stats(15)
    return wall, cpu


def time_staging(outputs: Path, rows: int) -> float:
    """Median seconds to check and publish one row's (one-file) output in ``outputs`` once it
    holds ``rows`` finished outputs."""
    for i in range(1, rows + 1):
        (outputs / f"s{i:06d}").mkdir(exist_ok=True)
    seconds = []
    for n in range(5):
        start = time.perf_counter()
        with staged_output(check_out_folder(outputs / f"extra{n}")) as tmp:
            (tmp / "result.txt").write_text("x")
        seconds.append(time.perf_counter() - start)
    return statistics.median(seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=100_000)
    parser.add_argument("--folder", type=Path, default=Path("/tmp/pcnet_manifest_check"),
                        help="the study folder to create (replaced)")
    parser.add_argument("--profile", action="store_true", help="print cProfile's top functions")
    args = parser.parse_args()
    manifest = build_study(args.folder, args.rows)
    wall, cpu = time_check(manifest, args.profile)
    print(f"{args.rows} rows checked in {wall:.2f} s ({wall / args.rows * 1e6:.0f} us per row; CPU {cpu:.2f} s)"
          f"{' under cProfile' if args.profile else ''}")
    staging = time_staging(args.folder / "outputs", args.rows)
    print(f"staging one output beside {args.rows} others: {staging * 1e3:.0f} ms (median of 5)")


if __name__ == "__main__":
    main()
