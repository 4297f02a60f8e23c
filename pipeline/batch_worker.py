"""One manifest row, run inside a batch worker (a child process of the local engine or a Ray
worker): the same pipeline and output contract as ``pcnet run``, then the resume marker.

Only the standard library is imported at module level: a worker sets its thread counts
(:func:`thread_env`) before anything imports numpy or onnxruntime.
"""

from __future__ import annotations

import math
import os
import socket
import time
import traceback
from pathlib import Path

#: Thread-count variables set in every worker: numpy's BLAS (OpenMP, OpenBLAS, MKL) and
#: onnxruntime's intra-op pool (``PCNET_ORT_THREADS``, read by pcnet's ONNX session).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "PCNET_ORT_THREADS")
#: The key of a row's result holding its warnings as findings (:func:`finding_records`): kept
#: in the resume marker for the terminal's lines, left out of the JSON summary's rows.
FINDINGS = "findings"
#: What a row's run found that a skipped row shows again (from its resume marker or the
#: previous summary): frame counts, mode, where the world frame's pelvis path and floor came
#: from (report.md's ``root_path`` and ``floor.kind``), warnings, notes and, with ``opensim``, the
#: IK fit's marker RMS in centimetres (``opensim_fit.json``'s ``marker_rms_m``); the camera
#: tilt's uncertainty and what it is (:func:`pcnet.pipeline.checks.tilt_tolerance`: a batch trial
#: found "not calibrated for this recording" only by opening each report.md); each joint angle's
#: median, least and greatest value (report.md's table: a lab trial opened every kinematics.csv
#: to compare subjects), and each angle rate's least and greatest (its peaks either way: a study
#: trial opened every report.md for the peak angular velocities).
RESULT_FIELDS = ("frames", "valid", "mode", "units", "camera_tilt_deg", "camera_tilt_uncertainty_deg",
                 "camera_tilt_uncertainty", "posture", "root_path", "floor", "warnings", "notes", "opensim_rms_cm",
                 "angles", "angle_rates")
#: The fields that make a row's result large, left out of a big batch's rewrites while it runs.
PER_COLUMN_FIELDS = ("angles", "angle_rates")
#: How the row's output was made (its output's marker keeps them): a skipped row reports them (a
#: user trial: a no-op re-run lost every row's timing).
RUN_FIELDS = ("seconds", "host", "pid", "attempts", "threads")
#: Test hook, see :func:`_test_hook`.
TEST_HOOK = "PCNET_BATCH_TEST_HOOK"
_HOLD_LIMIT_S = 120.0


def cpu_cores() -> int:
    """CPU cores this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


def threads_per_worker(workers: int, cores: int | None = None) -> int:
    """Threads each of ``workers`` concurrent rows may use so that together they fill
    ``cores`` without oversubscribing them: ``max(1, cores // workers)``."""
    return max(1, (cores or cpu_cores()) // max(1, workers))


def thread_env(threads: int) -> dict[str, str]:
    """The worker environment for ``threads`` threads per library. A variable the user
    already set is kept: they may know their machine better (Ray follows the same rule for
    ``OMP_NUM_THREADS``)."""
    return {name: os.environ.get(name) or str(threads) for name in THREAD_VARIABLES}


def set_opencv_threads(threads: int) -> None:
    """OpenCV reads no environment variable for its pool; set it once numpy is allowed in."""
    try:
        import cv2
    except ImportError:
        return
    cv2.setNumThreads(threads)


def _test_hook(row: int) -> None:
    """Test hook for tests/test_batch.py, inert unless ``PCNET_BATCH_TEST_HOOK`` names a
    folder: each attempt at row ``row`` then creates ``started-<row>-<pid>`` there and waits
    while ``hold-<row>`` exists (at most two minutes), so that a test can kill or interrupt
    the worker running a known row at a known moment, without timing guesses."""
    folder = os.environ.get(TEST_HOOK)
    if not folder:
        return
    folder = Path(folder)
    (folder / f"started-{row}-{os.getpid()}").touch()
    deadline = time.monotonic() + _HOLD_LIMIT_S
    while (folder / f"hold-{row}").exists() and time.monotonic() < deadline:
        time.sleep(0.02)


def error_line(err: BaseException) -> str:
    """A failed row's one-line error: an expected error's own text (bad input, a file
    problem), any other exception with its type so that a bug is recognisable."""
    from pcnet.stages.core.errors import InputError, one_line

    text = one_line(err)
    return text if isinstance(err, (InputError, OSError)) else f"{type(err).__name__}: {text}"


def finding_records(findings) -> list[dict]:
    """:class:`pcnet.stages.flags.Finding` s as plain values (a row's result crosses a
    process or Ray boundary and is kept in the resume marker): severity and kind by name,
    headline, action, full text."""
    return [{"severity": f.severity.name, "kind": None if f.kind is None else f.kind.name, "headline": f.headline,
             "action": f.action, "detail": f.detail} for f in findings]


def _int_or_none(text: str | None) -> int | None:
    try:
        return int(text)
    except (TypeError, ValueError):
        return None


def _finite_or_none(value: float) -> float | None:
    """A number for the summary's JSON: rounded to 0.1, ``None`` where not finite."""
    return round(float(value), 1) if math.isfinite(value) else None


def _opensim_rms_cm(staged: Path, outputs: dict[str, Path]) -> float | None:
    """The OpenSim IK fit's marker RMS (cm, 2 decimals, as the run's note) from the
    ``opensim_fit.json`` the run wrote into ``staged`` (its ``outputs`` name the folder it is
    published as); ``None`` without one (no ``opensim``, or no world frame to fit)."""
    if "opensim_fit.json" not in outputs:
        return None
    import json

    rms = json.loads((staged / "opensim_fit.json").read_text()).get("marker_rms_m")  # null where not finite
    return None if rms is None else round(100 * rms, 2)


def angle_summary(ranges, median: bool = True) -> dict[str, dict[str, float]] | None:
    """``{column: {"median", "min", "max"}}`` (the columns' unit, 0.1; without ``median`` for
    rates, whose median says little) of a run's
    :class:`~pcnet.stages.column_ranges.ColumnRanges` (report.md's joint-angle or angular-velocity
    table, over the same frames), ``None`` without."""
    if ranges is None:
        return None
    return {r.name: {**({"median": round(r.median, 1)} if median else {}), "min": round(r.minimum, 1),
                     "max": round(r.maximum, 1)} for r in ranges.rows}


def execute_row(job: dict) -> dict:
    """Run one row and return its result (the per-row fields of the batch summary, and
    :data:`FINDINGS`, its warnings' short lines).

    ``job``: ``row`` (1-based), ``config`` (``dataclasses.asdict`` of the row's
    :class:`~pcnet.pipeline.config.RunConfig`, absolute paths), ``attempt``, ``manifest`` (where
    it lies seen from the output folder, recorded in the output's batch marker).

    Never raises for a failing row (bad input, a bug): the error is the result, with its
    traceback for unexpected exceptions. ``KeyboardInterrupt`` (the engine stopping the
    worker) propagates after ``run_pipeline`` has removed its half-written folder.
    """
    result = {"row": job["row"], "status": "failed", **dict.fromkeys(RESULT_FIELDS), "mode": "", "seconds": None,
              "error": "", "warnings": [], "notes": [], "host": socket.gethostname(), "pid": os.getpid(),
              "attempts": job.get("attempt", 1), "threads": _int_or_none(os.environ.get("PCNET_ORT_THREADS"))}
    _test_hook(job["row"])
    from pcnet.stages.core.errors import InputError

    from .batch_marker import input_hashes, write_batch_marker
    from .interrupt import came_from_interrupt

    started = time.perf_counter()
    try:
        from pcnet.pipeline.checks import GIVEN_TILT, tilt_tolerance
        from pcnet.pipeline.config import RunConfig
        from pcnet.pipeline.runner import run_pipeline

        started = time.perf_counter()  # after the imports: a fresh worker's first row is not slower
        config = job["config"]
        inputs = input_hashes(config)  # before the run: the marker must describe what was read

        def with_marker(staged: Path, run) -> None:  # published together with the output or not at all
            posture = run.report.rectification.posture
            # auto's choice beside what it chose (a trial read an auto row as a sequence-mode request)
            mode = run.mode + " (auto)" * (config.get("mode") == "auto")
            tolerance, what = tilt_tolerance(run.report.rectification)
            result.update(frames=run.frames, valid=run.valid_frames, mode=mode, units=run.units,
                          camera_tilt_deg=_finite_or_none(run.camera_tilt_deg),
                          camera_tilt_uncertainty_deg=_finite_or_none(tolerance),
                          # a given up has no uncertainty of pcnet's, and says so
                          camera_tilt_uncertainty=what if math.isfinite(tolerance) or what == GIVEN_TILT else None,
                          angles=angle_summary(run.angle_ranges),
                          angle_rates=angle_summary(run.rate_ranges, median=False),
                          posture=None if posture is None else posture.most_probable + " (declared)" * posture.declared,
                          root_path=run.report.root_path, floor=None if run.report.floor is None else run.report.floor.kind,
                          warnings=list(run.flags), notes=list(run.notes),
                          opensim_rms_cm=_opensim_rms_cm(staged, run.outputs), **{FINDINGS: finding_records(run.findings)})
            result["seconds"] = round(time.perf_counter() - started, 3)  # the run, without the publishing
            write_batch_marker(staged, config, inputs, result, job.get("manifest", ""))

        run_pipeline(RunConfig(**config), progress=False, before_publish=with_marker)
        result["status"] = "ok"
    except Exception as err:  # one row's failure is its result; the batch goes on
        if came_from_interrupt(err):  # the engine stopping the worker, not the row failing
            raise KeyboardInterrupt from err
        result.update(status="failed", error=error_line(err))
        if not isinstance(err, (InputError, OSError)):
            result["traceback"] = traceback.format_exc()
    result["seconds"] = round(time.perf_counter() - started, 3)
    return result
