"""`pcnet batch` on real inputs (the boxing fixture: AlphaPose + MotionBERT, 60 frames):
validation before any work, isolation from dead workers (local and Ray), resume and
--retry-failed, Ctrl-C, the JSON summary.

Rows that must be killed or interrupted at a known moment use the worker's test hook
(``PCNET_BATCH_TEST_HOOK``, pipeline/batch_worker.py): the worker running row i creates
``started-<i>-<pid>`` and waits while ``hold-<i>`` exists.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES, ROOT

from pcnet.pipeline.batch import BatchOptions, plan_batch, report_path, run_batch
from pcnet.pipeline.batch_marker import BATCH_MARKER
from pcnet.pipeline.batch_worker import TEST_HOOK, cpu_cores
from pcnet.pipeline.cli import main
from pcnet.pipeline.outdir import MARKER, TMP_TAG, read_marker

BOX_2D = FIXTURES / "boxing_alphapose_f000-059.json"
BOX_3D = FIXTURES / "boxing_X3D_f000-059.npy"
MEDIAPIPE = FIXTURES / "mediapipe_blazepose33_f000-059.npz"
HEADER = "lifter,lifter_output,keypoints2d,keypoints2d_format,fps,out,method,recording"


def _row(out: str, lifter_output=BOX_3D, method: str = "geometric") -> str:
    return f"motionbert,{lifter_output},{BOX_2D},alphapose,30,{out},{method},false"


def _manifest(folder: Path, *rows: str, name: str = "m.csv") -> Path:
    path = folder / name
    path.write_text("\n".join((HEADER, *rows)) + "\n")
    return path


def _invoke(*args):
    return CliRunner().invoke(main, ["batch", *[str(a) for a in args]])


def _summary(manifest: Path) -> dict:
    return json.loads(manifest.with_name(manifest.name + ".pcnet_batch.json").read_text())


def _report(manifest: Path) -> str:
    """The batch's Markdown report beside its JSON summary."""
    return manifest.with_name(manifest.name + ".pcnet_batch.md").read_text()


def _statuses(manifest: Path) -> list[str]:
    return [r["status"] for r in _summary(manifest)["rows"]]


def _interrupt(proc, signum: int = signal.SIGINT) -> tuple[str, str, float]:
    """Ctrl-C to a running `pcnet batch` (or ``signum`` to its whole process group, as a closed
    terminal sends SIGHUP): its stdout, stderr and seconds until it exited."""
    sent = time.monotonic()
    if signum == signal.SIGINT:
        proc.send_signal(signum)
    else:
        os.killpg(proc.pid, signum)
    out, err = proc.communicate(timeout=30)
    return out, err, time.monotonic() - sent


def _wait_for(predicate, timeout: float = 60.0, what: str = "") -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.02)


def _started(hook: Path, row: int) -> list[int]:
    """PIDs of the workers that started row ``row`` (test hook files)."""
    return [int(p.name.rsplit("-", 1)[1]) for p in hook.glob(f"started-{row}-*")]


def _spawn_batch(*args, hook: Path) -> subprocess.Popen:
    """`pcnet batch` in its own process, as a user starts it (entry point, signal handlers), in a
    process group of its own as a terminal's job is (a closed terminal signals the group)."""
    env = dict(os.environ, **{TEST_HOOK: str(hook)})

    def child() -> None:  # a terminal's default (a test run under nohup would pass its ignore on)
        if hasattr(signal, "SIGHUP"):
            signal.signal(signal.SIGHUP, signal.SIG_DFL)
    return subprocess.Popen([sys.executable, "-m", "pcnet.pipeline.entry", "batch", *[str(a) for a in args]],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, process_group=0,
                            preexec_fn=child)


@pytest.fixture
def hook(tmp_path):
    folder = tmp_path / "hook"
    folder.mkdir()
    return folder


@pytest.mark.slow
def test_rows_run_in_workers_and_one_failing_row_does_not_stop_the_others(tmp_path):
    """Same outputs as `pcnet run` per row, a marker in each, the table and the summary;
    a row that fails while it runs (all joints NaN) fails alone, its `out` never created."""
    nan = tmp_path / "nan.npy"
    np.save(nan, np.full((60, 17, 3), np.nan, np.float32))
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"{HEADER}\n{_row('b1', method='pcnet')}\n{_row('b2', lifter_output=nan)}\n"
                        f"mediapipe,{MEDIAPIPE},{MEDIAPIPE},mediapipe,30,b3,geometric,false\n")
    res = _invoke(manifest, "--workers", "2")
    assert res.exit_code == 1, res.output  # one row failed
    assert "2 of 3 recordings have complete outputs (2 ok, 0 skipped, 1 failed, 0 cancelled)" in res.output
    summary = _summary(manifest)
    assert [r["status"] for r in summary["rows"]] == ["ok", "failed", "ok"]
    b1, b2, b3 = summary["rows"]
    assert "nan.npy" in b2["error"] and "only NaN" in b2["error"] and "traceback" not in b2
    assert b1["frames"] == 60 and b1["valid"] == 60 and b1["attempts"] == 1 and b1["host"] and b1["pid"] != os.getpid()
    # the run's camera tilt and posture, as its own summary and canonical.npz give them
    with np.load(tmp_path / "b1" / "canonical.npz", allow_pickle=False) as f:
        record = json.loads(str(f["report"]))
    assert b1["camera_tilt_deg"] == round(record["camera_tilt_deg"], 1) and b1["posture"] == "upright"
    assert b3["posture"] is None and b3["camera_tilt_deg"] is not None  # geometric: no up model, a tilt all the same
    # how far the tilt may be off, and what that number is (a lab trial found "not calibrated" only in report.md)
    assert b1["camera_tilt_uncertainty"] == "95 % interval, the larger of pitch and roll" and b1["camera_tilt_uncertainty_deg"] == round(max(
        record["camera_pitch_interval_deg"], record["camera_roll_interval_deg"]), 1)
    assert b3["camera_tilt_uncertainty"].startswith("bootstrap-only") and b2["camera_tilt_uncertainty"] is None
    # each angle's median and extremes, as the row's kinematics.csv gives them (a lab trial opened each one)
    with open(tmp_path / "b1" / "kinematics.csv", newline="") as fh:
        knee = np.array([float(r["left_knee_flexion_deg"] or "nan") for r in csv.DictReader(fh)])
    assert b1["angles"]["left_knee_flexion_deg"] == {"median": round(float(np.nanmedian(knee)), 1),
                                                     "min": round(float(np.nanmin(knee)), 1),
                                                     "max": round(float(np.nanmax(knee)), 1)}
    assert b2["angles"] is None
    with open(tmp_path / "b1" / "kinematics.csv", newline="") as fh:
        rate = np.array([float(r["left_knee_flexion_deg_per_s"] or "nan") for r in csv.DictReader(fh)])
    assert b1["angle_rates"]["left_knee_flexion_deg_per_s"] == {"min": round(float(np.nanmin(rate)), 1),
                                                                "max": round(float(np.nanmax(rate)), 1)}
    assert b2["angle_rates"] is None
    assert "| tilt +- deg (what) |" in report_path(tmp_path / "m.csv.pcnet_batch.json").read_text()
    # the thread count reached the worker's environment (a value the user set is kept)
    assert b1["threads"] == int(os.environ.get("PCNET_ORT_THREADS") or max(1, cpu_cores() // 2))
    assert summary["counts"] == {"ok": 2, "skipped": 0, "failed": 1, "cancelled": 0, "pending": 0}
    for out in ("b1", "b3"):
        assert {"canonical.npz", "kinematics.csv", BATCH_MARKER} <= {p.name for p in (tmp_path / out).iterdir()}
        assert BATCH_MARKER in read_marker(tmp_path / out)["files"]  # --overwrite may replace it later
    assert not (tmp_path / "b2").exists()
    marker = json.loads((tmp_path / "b1" / BATCH_MARKER).read_text())
    assert marker["settings"]["method"] == "pcnet" and len(marker["inputs"]["lifter_output"]["sha256"]) == 64
    # every field of a row is documented in docs/cluster.md's table, and nothing else is listed
    table = (ROOT / "docs" / "cluster.md").read_text().split("## Results")[1].split("\n## ")[0]
    documented = set(re.findall(r"`(\w+)`", "".join(ln.split(" | ")[0] for ln in table.splitlines()
                                                      if ln.startswith("| `"))))
    assert set(b1) | {"traceback"} == documented


def test_the_whole_manifest_is_checked_before_any_work(tmp_path):
    """One line per problem (manifest, line, column, expected, found), exit 1, nothing
    written: not even the rows without a problem ran."""
    inputs = tmp_path / "in"
    inputs.mkdir()
    x3d = inputs / "x.npy"
    x3d.write_bytes(BOX_3D.read_bytes())
    (tmp_path / "theirs").mkdir()
    (tmp_path / "theirs" / "notes.txt").write_text("mine")
    manifest = _manifest(
        tmp_path,
        _row("ok1", lifter_output=x3d),                 # line 2: fine
        _row("o2", lifter_output=inputs / "x.npz"),  # line 3: missing input, a typo of x3d's
        _row("in", lifter_output=x3d),                  # line 4: out is the input's folder
        _row(".", lifter_output=x3d),                   # line 5: out contains the input's folder
        _row("same", lifter_output=x3d),                # line 6
        _row("same", lifter_output=x3d),                # line 7: shares line 6's out
        _row("theirs", lifter_output=x3d),              # line 8: an existing folder pcnet did not write
        _row("o9", lifter_output=x3d, method="bogus"),  # line 9: bad value
    )
    before = sorted(p.name for p in tmp_path.iterdir())
    res = _invoke(manifest)
    assert res.exit_code == 1 and "Traceback" not in res.output, res.output
    errors = [ln for ln in res.output.splitlines() if ln.startswith("Error: ")]
    assert len(errors) == 6, res.output
    expected = [("line 3", "column lifter_output", "expected an existing file", "x.npz",
                 f"; a close name there: {x3d.name}"),
                ("line 4", "column out", "expected a folder apart from the inputs", "'in', which is the folder of"),
                ("line 5", "column out", "'.', which contains the folder of"),
                ("line 7", "column out", "expected a folder of its own", "'same', which line 6 also writes"),
                ("line 8", "column out", "a folder holding files pcnet did not write", "notes.txt", "choose another out"),
                ("line 9", "column method", "expected one of", "'bogus'")]
    for needles in expected:
        assert any(all(n in e for n in needles) for e in errors), (needles, errors)
    assert all(str(manifest) in e for e in errors)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no output, no summary
    assert (tmp_path / "theirs" / "notes.txt").read_text() == "mine"


def test_a_row_with_a_missing_file_and_a_shared_out_is_told_both(tmp_path):
    """A trial fixed a missing file and was then told the row's out was another row's: both
    problems of a row are named in the first pass."""
    manifest = _manifest(tmp_path, _row("same"), _row("same", lifter_output=tmp_path / "absent.npy"))
    res = _invoke(manifest)
    assert res.exit_code == 1 and "line 3: column lifter_output" in res.output, res.output
    assert "line 3: column out: expected a folder of its own, got 'same', which line 2 also writes" in res.output
    assert not (tmp_path / "same").exists()
    # a row whose settings are refused still writes its out: the row after it sharing that out is
    # told so at once (a yoga trial's missing file and rate hid the shared out until both were fixed)
    manifest = _manifest(tmp_path, _row("same", lifter_output=tmp_path / "absent.npy").replace(",30,", ",,"),
                         _row("same"), name="m2.csv")
    res = _invoke(manifest)
    assert res.exit_code == 1 and "line 2: column fps" in res.output, res.output
    assert "line 3: column out: expected a folder of its own, got 'same', which line 2 also writes" in res.output


def test_every_bad_cell_of_a_row_is_named_at_once(tmp_path):
    """A user trial fixed one row three times, one refused cell per run: every cell no column
    reads and every choice or range the config refuses is named, one line each; a cell that
    did not read (fps 'abc') is not named again as missing."""
    manifest = tmp_path / "m.csv"
    manifest.write_text("lifter,lifter_output,fps,recording,mode,out,height\n"
                        f"lifterx,{BOX_3D},30,maybe,sideways,a,170\n"
                        f"motionbert,{BOX_3D},abc,false,frame,b,\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and "Traceback" not in res.output, res.output
    errors = [ln for ln in res.output.splitlines() if ln.startswith("Error: ")]
    expected = [("line 2", "column recording", "expected true/false", "'maybe'"),
                ("line 2", "column lifter", "expected one of", "'lifterx'"),
                ("line 2", "column mode", "expected one of", "'sideways'"),
                ("line 2", "column height", "expected a value in [0.5, 3] m", "centimetres? give metres: 1.7"),
                ("line 3", "column fps", "expected a number, got 'abc'")]
    assert len(errors) == len(expected), res.output
    for needles in expected:
        assert any(all(n in e for n in needles) for e in errors), (needles, errors)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv"]


def test_settings_a_row_would_ignore_are_refused_before_any_work(tmp_path):
    """A 2D confidence threshold without 2D keypoints, a fixed cutoff beside the residual
    analysis, a lifter option the lifter does not take, a cutoff at or above Nyquist, a rate
    too low for the default cutoff: one line each, naming the columns."""
    manifest = tmp_path / "m.csv"
    manifest.write_text("lifter,lifter_output,fps,out,confidence_threshold,cutoff_hz,residual_cutoff,layout\n"
                        f"motionbert,{BOX_3D},30,a,0.5,,false,\n"
                        f"motionbert,{BOX_3D},30,b,,4,true,\n"
                        f"motionbert,{BOX_3D},30,c,,,false,coco17\n"
                        f"motionbert,{BOX_3D},30,d,,15,false,\n"
                        f"motionbert,{BOX_3D},10,e,,,false,\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and "Traceback" not in res.output, res.output
    errors = [ln for ln in res.output.splitlines() if ln.startswith("Error: ")]
    expected = [("line 2", "column confidence_threshold", "expected together with 2D keypoints"),
                ("line 3", "columns cutoff_hz and residual_cutoff", "expected one of the two"),
                ("line 4", "column layout", "expected only options --lifter motionbert takes (pixel, clip_len)"),
                ("line 5", "column cutoff_hz", "below half the frame rate (Nyquist: 15 Hz at fps 30), got 15"),
                ("line 6", "column fps", "above 12 fps for the default low-pass cutoff 6 Hz", "cutoff_hz below 5")]
    for needles in expected:
        assert any(all(n in e for n in needles) for e in errors), (needles, errors)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv"]


def test_c3d_rows_without_ezc3d_are_refused_before_any_work(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ezc3d", None)  # `import ezc3d` raises ImportError
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"lifter,lifter_output,fps,out,height,c3d\nmotionbert,{BOX_3D},30,a,1.75,true\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and 'C3D export needs ezc3d: pip install "pcnet[c3d]"' in res.output, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv"]


@pytest.mark.slow
def test_retry_failed_runs_a_row_whose_output_was_deleted_since(tmp_path):
    manifest = _manifest(tmp_path, _row("a"), _row("b"))
    first = _invoke(manifest, "--workers", "1")
    assert first.exit_code == 0
    warned = sorted(t for t in first.output.splitlines() if t.startswith(("WARNING", "CHECK")))
    shutil.rmtree(tmp_path / "b")
    res = _invoke(manifest, "--workers", "1", "--retry-failed")
    assert res.exit_code == 0 and _statuses(manifest) == ["skipped", "ok"], res.output
    assert (tmp_path / "b" / BATCH_MARKER).is_file()
    # the skipped row keeps its warnings as raised, action and all (a user trial: "-> see report.md")
    assert warned and sorted(t for t in res.output.splitlines() if t.startswith(("WARNING", "CHECK"))) == warned, \
        (warned, res.output)
    # a row whose settings changed since is not called complete: it runs again (a user trial)
    _manifest(tmp_path, _row("a", method="pcnet"), _row("b"))
    res = _invoke(manifest, "--workers", "1", "--retry-failed")
    assert res.exit_code == 0 and _statuses(manifest) == ["ok", "skipped"], res.output
    assert "setting method changed since its earlier output" in res.output, res.output
    # another file named (a trial swapped two rows' recordings and kept the old numbers): its bytes
    # decide, as a plain re-run's check does; the same bytes elsewhere (a moved folder) still match
    same, other = tmp_path / "same.npy", tmp_path / "other.npy"
    same.write_bytes(BOX_3D.read_bytes())
    np.save(other, np.load(BOX_3D) * 1.01)
    _manifest(tmp_path, _row("a", lifter_output=same, method="pcnet"), _row("b", lifter_output=other))
    res = _invoke(manifest, "--workers", "1", "--retry-failed")
    assert res.exit_code == 0 and _statuses(manifest) == ["skipped", "ok"], res.output
    assert "input lifter_output changed since its earlier output" in res.output, res.output


def test_shared_out_is_refused_even_with_several_workers(tmp_path):
    """Issue 16: two rows with one `out` both reported ok with --workers 2."""
    manifest = _manifest(tmp_path, _row("a"), _row("a"))
    res = _invoke(manifest, "--workers", "2")
    assert res.exit_code == 1 and "line 3: column out: expected a folder of its own" in res.output
    assert not (tmp_path / "a").exists()


def test_a_second_batch_of_a_running_manifest_is_refused_before_any_work(tmp_path):
    """A file-safety trial started one manifest's batch twice: both failed the rows the other
    was writing, and one summary, wrong, was left between them. While a batch holds the
    manifest (flock), another is one line, exit 1, and writes nothing."""
    fcntl = pytest.importorskip("fcntl", reason="flock(2) is POSIX's")
    manifest = _manifest(tmp_path, _row("a"))
    with open(manifest, "rb") as running:  # what the first batch holds while it runs
        fcntl.flock(running, fcntl.LOCK_EX | fcntl.LOCK_NB)
        res = _invoke(manifest, "--workers", "1")
        assert res.exit_code == 1 and "Traceback" not in res.output, res.output
        assert (f"{manifest}: expected no other pcnet batch of this manifest running, got one running it now; let "
                f"it finish (or stop it), then run again") in res.output
        assert not (tmp_path / "a").exists() and not manifest.with_name(manifest.name + ".pcnet_batch.json").exists()
    res = _invoke(manifest, "--workers", "1")  # once it ended, the manifest runs
    assert res.exit_code == 0 and (tmp_path / "a").is_dir(), res.output


@pytest.mark.slow
def test_resume_skips_complete_rows_and_reruns_changed_ones(tmp_path):
    x3d = tmp_path / "x.npy"
    x3d.write_bytes(BOX_3D.read_bytes())
    manifest = _manifest(tmp_path, _row("r1"), _row("r2", lifter_output=x3d))
    assert _invoke(manifest, "--workers", "1").exit_code == 0
    first = (tmp_path / "r2" / "kinematics.csv").stat().st_mtime_ns
    ran = _summary(manifest)["rows"][1]

    res = _invoke(manifest, "--workers", "1")  # nothing changed: both skipped, nothing rewritten
    assert res.exit_code == 0 and _statuses(manifest) == ["skipped", "skipped"], res.output
    assert _summary(manifest)["rows"][1]["frames"] == 60  # what the skipped row had produced
    # ... and how: a no-op re-run had lost every row's timing (a user trial)
    kept = _summary(manifest)["rows"][1]
    assert 0 < kept["seconds"] <= ran["seconds"] and (kept["pid"], kept["attempts"]) == (ran["pid"], 1), (kept, ran)
    assert (tmp_path / "r2" / "kinematics.csv").stat().st_mtime_ns == first

    poses = np.load(x3d)
    np.save(x3d, poses * 1.01)  # same shape, new content: only row 2 runs again, over its own output
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 0 and _statuses(manifest) == ["skipped", "ok"], res.output
    assert (tmp_path / "r2" / "kinematics.csv").stat().st_mtime_ns != first
    # said as it ends: replacing an earlier output (an OpenSim fit among it) had been silent (a user trial)
    # ... naming what changed (a user trial: "its inputs, settings or pcnet version changed")
    assert "(ran again: input lifter_output changed since its earlier output; its earlier output replaced)" \
        in res.output, res.output
    # ... and kept: a study manager found the reason only on stderr, not in the saved summaries
    assert [r["ran_again"] for r in _summary(manifest)["rows"]] == ["", "input lifter_output changed since its "
                                                                       "earlier output"]
    assert "- line 3 (row 2, ok): input lifter_output changed since its earlier output" in _report(manifest)

    from pcnet.pipeline.outdir import register_files

    (tmp_path / "r1" / "gait.json").write_text("{}")  # as `pcnet gait r1` leaves it, made from r1's run
    register_files(tmp_path / "r1", ("gait.json",))
    manifest.write_text(manifest.read_text().replace("r1,geometric", "r1,pcnet"))  # a setting changed
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 0 and _statuses(manifest) == ["ok", "skipped"], res.output
    assert "(ran again: setting method changed since its earlier output" in res.output, res.output
    # what was made from the replaced output goes with it, said (a study trial lost its gait results unsaid)
    assert "with what pcnet gait or pcnet opensim made from it (gait.json): run them again)" in res.output, res.output
    assert not (tmp_path / "r1" / "gait.json").exists()
    assert json.loads((tmp_path / "r1" / BATCH_MARKER).read_text())["settings"]["method"] == "pcnet"

    res = _invoke(manifest, "--workers", "2", "--overwrite")
    assert res.exit_code == 0 and _statuses(manifest) == ["ok", "ok"], (res.output, _statuses(manifest))

    # a file of the user's own in an output folder is never deleted: re-running that row is refused
    (tmp_path / "r2" / "notes.txt").write_text("mine")
    np.save(x3d, poses)
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 1 and "line 3: column out" in res.output and "notes.txt" in res.output, res.output
    assert (tmp_path / "r2" / "notes.txt").read_text() == "mine"


@pytest.mark.slow
def test_a_rows_own_overwrite_column_runs_it_again(tmp_path):
    """The manifest's ``overwrite`` column is that row's ``--overwrite`` (a user trial: set on
    one row, it did nothing, the row skipped as complete); it still refuses a file of the
    user's own."""
    manifest = _manifest(tmp_path, _row("o1"), _row("o2"))
    assert _invoke(manifest, "--workers", "1").exit_code == 0
    header, first, second = manifest.read_text().splitlines()
    manifest.write_text("\n".join([header + ",overwrite", first + ",false", second + ",true"]) + "\n")
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 0 and _statuses(manifest) == ["skipped", "ok"], res.output
    (tmp_path / "o2" / "notes.txt").write_text("mine")
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 1 and "notes.txt" in res.output, res.output
    assert (tmp_path / "o2" / "notes.txt").read_text() == "mine"


@pytest.mark.slow
def test_a_moved_study_folder_is_still_complete(tmp_path):
    """Inputs count by their bytes: a study folder with a relative manifest, moved (or
    mounted elsewhere), skips its finished rows."""
    study = tmp_path / "study"
    (study / "in").mkdir(parents=True)
    shutil.copy(BOX_3D, study / "in" / "x.npy")
    shutil.copy(BOX_2D, study / "in" / "kp.json")
    manifest = study / "m.csv"
    manifest.write_text(f"{HEADER}\nmotionbert,in/x.npy,in/kp.json,alphapose,30,out/a,geometric,false\n")
    assert _invoke(manifest, "--workers", "1").exit_code == 0
    moved = tmp_path / "moved"
    shutil.copytree(study, moved, copy_function=shutil.copy2)
    res = _invoke(moved / "m.csv", "--workers", "1")
    assert res.exit_code == 0 and _statuses(moved / "m.csv") == ["skipped"], res.output
    np.save(moved / "in" / "x.npy", np.load(BOX_3D) * 1.01)  # new bytes under the same name: runs again
    res = _invoke(moved / "m.csv", "--workers", "1")
    assert res.exit_code == 0 and _statuses(moved / "m.csv") == ["ok"], res.output


def test_the_resume_marker_is_published_with_the_output(tmp_path, monkeypatch):
    """The worker writes its marker into the staged output before the swap, so an interrupt
    or a kill between the two can never leave a complete output without one (which would make
    the next run refuse the row's folder as not pcnet batch's)."""
    import pcnet.pipeline.outdir as outdir
    from pcnet.pipeline.batch_worker import execute_row
    from pcnet.pipeline.config import RunConfig

    seen = {}
    swap = outdir._swap_in

    def checking_swap(tmp, *rest):
        seen["marker"] = (tmp / BATCH_MARKER).is_file()
        seen["listed"] = BATCH_MARKER in read_marker(tmp)["files"]
        return swap(tmp, *rest)

    monkeypatch.setattr(outdir, "_swap_in", checking_swap)
    import pcnet.stages.core.digest as digest
    read = []
    hash_file = digest.sha256_file
    monkeypatch.setattr(digest, "sha256_file", lambda path: read.append(Path(path).name) or hash_file(path))
    lifter_output = tmp_path / "x.npy"  # a file of its own: no earlier test's digest of it is kept
    shutil.copyfile(BOX_3D, lifter_output)
    config = RunConfig(lifter="motionbert", lifter_output=str(lifter_output), fps=30.0, out=str(tmp_path / "o"),
                       method="geometric", recording=False)
    result = execute_row({"row": 1, "config": dataclasses.asdict(config), "attempt": 1})
    assert result["status"] == "ok", result
    assert seen == {"marker": True, "listed": True}
    marker = json.loads((tmp_path / "o" / BATCH_MARKER).read_text())
    assert marker["result"]["frames"] == 60
    # the input is read once for the marker and the run's report alike
    assert read.count("x.npy") == 1, read
    with np.load(tmp_path / "o" / "canonical.npz") as npz:
        report = json.loads(str(npz["report"]))
    assert report["inputs"]["sha256"]["lifter_output"] == marker["inputs"]["lifter_output"]["sha256"]


def test_a_rows_notes_and_auto_modes_choice_reach_the_summary_and_report(tmp_path):
    """A developer's trial read a VideoPose3D file as MotionBERT's in a batch: the note naming
    the likely lifter was in that row's report.md alone; and an auto row read as if sequence
    mode had been asked for. The row keeps its notes (the report lists them, flags as columns)
    and its mode says auto chose it."""
    from pcnet.pipeline.batch import BatchReport, PlannedRow, _row_summary, batch_markdown
    from pcnet.pipeline.batch_worker import execute_row
    from pcnet.pipeline.config import RunConfig

    vp3d = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"  # real VideoPose3D output: metres, pelvis at the origin
    config = RunConfig(lifter="motionbert", lifter_output=str(vp3d), fps=30.0, out=str(tmp_path / "o"),
                       mode="auto", recording=False)
    result = execute_row({"row": 1, "config": dataclasses.asdict(config), "attempt": 1})
    assert result["status"] == "ok", result
    assert result["mode"] in ("sequence (auto)", "smooth (auto)")
    (note,) = [n for n in result["notes"] if "pelvis at the origin" in n]
    item = PlannedRow(1, 2, config=dataclasses.asdict(config))
    row = _row_summary(item, result, "ok")
    assert row["notes"] == result["notes"]
    md = batch_markdown(BatchReport([row], False, tmp_path / "m.csv.pcnet_batch.json", 1.0, settings={}))
    notes = md[md.index("## Notes"):md.index("## Restarts")]
    assert "column lifter videopose3d" in notes and "### line 2 (row 1, ok)" in notes, notes
    assert f"| {result['mode']} | normalised |" in md


def test_a_row_published_just_before_ctrl_c_is_ok_not_cancelled(tmp_path):
    """Ctrl-C between a worker publishing a row's output and its result reaching the batch:
    the output and this run's marker are complete, so the row is ok, not cancelled ("left as
    it was"); an output from before this batch started does not count."""
    from pcnet.pipeline.batch import PlannedRow, _published_before_the_stop
    from pcnet.pipeline.batch_worker import execute_row
    from pcnet.pipeline.config import RunConfig

    config = dataclasses.asdict(RunConfig(lifter="motionbert", lifter_output=str(BOX_3D), fps=30.0,
                                          out=str(tmp_path / "o"), method="geometric", recording=False))
    planned = [PlannedRow(row=1, line=2, config=config)]
    started = time.time()
    assert execute_row({"row": 1, "config": config, "attempt": 1})["status"] == "ok"
    found = _published_before_the_stop(planned, {}, since=started)
    assert found[1]["status"] == "ok" and found[1]["frames"] == 60 and found[1]["pid"] == os.getpid()
    assert _published_before_the_stop(planned, {}, since=time.time() + 1) == {}
    assert _published_before_the_stop(planned, {1: {"status": "failed"}}, since=started) == {}


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie (Linux ``/proc``)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="reads process states from Linux /proc")
def test_workers_stop_when_the_batch_is_killed(tmp_path, hook):
    """The batch killed by SIGKILL (which it cannot pass on) while a worker runs row 1: the
    worker unwinds as on SIGTERM instead of running its row on and publishing it (a user
    trial's orphan published a row and raced the batch started again)."""
    manifest = _manifest(tmp_path, _row("s1"), _row("s2"))
    (hook / "hold-1").touch()
    proc = _spawn_batch(manifest, "--workers", "1", hook=hook)
    try:
        _wait_for(lambda: _started(hook, 1), what="row 1 to start")
        worker = _started(hook, 1)[0]
        proc.kill()
        proc.communicate(timeout=30)
        _wait_for(lambda: not _running(worker), timeout=30, what=f"worker {worker} to stop")
    finally:
        proc.kill()
        (hook / "hold-1").unlink(missing_ok=True)
    assert not (tmp_path / "s1").exists() and not list(tmp_path.glob(f".*{TMP_TAG}*"))
    # The summary it could not finish says so and names the driver that no longer runs (a
    # user's "pending" rows read as still running).
    summary = _summary(manifest)
    assert summary["finished"] is False and _statuses(manifest) == ["pending", "pending"]
    assert summary["driver_pid"] == proc.pid and not _running(proc.pid)


@pytest.mark.parametrize("retries", [0, 1])
@pytest.mark.slow
def test_a_killed_worker_fails_or_retries_only_its_row(tmp_path, hook, retries):
    """A worker killed by the OS (SIGKILL, as an out-of-memory kill) while running row 2:
    the batch completes; without retries row 2 fails alone and --retry-failed then runs
    only it; with --retries 1 it runs again in a fresh worker and succeeds."""
    manifest = _manifest(tmp_path, *(_row(f"k{i}") for i in range(1, 5)))
    (hook / "hold-2").touch()
    proc = _spawn_batch(manifest, "--workers", "2", "--retries", retries, hook=hook)
    try:
        _wait_for(lambda: _started(hook, 2), what="row 2 to start")
        victim = _started(hook, 2)[0]
        os.kill(victim, signal.SIGKILL)
        (hook / "hold-2").unlink()  # a retry must not wait
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    rows = _summary(manifest)["rows"]
    if retries:
        assert proc.returncode == 0, out + err
        assert [r["status"] for r in rows] == ["ok"] * 4
        assert rows[1]["attempts"] == 2 and rows[1]["pid"] != victim and len(_started(hook, 2)) == 2
        assert f"line 3: worker process {victim} was killed by SIGKILL" in err and "(attempt 2 of 2)" in err, err
        return
    assert proc.returncode == 1, out + err
    assert [r["status"] for r in rows] == ["ok", "failed", "ok", "ok"]
    assert f"worker process {victim} was killed by SIGKILL" in rows[1]["error"] and rows[1]["pid"] == victim
    assert "3 of 4 recordings have complete outputs" in out and not (tmp_path / "k2").exists()
    assert not list(tmp_path.glob(f".k2{TMP_TAG}*"))

    res = _invoke(manifest, "--retry-failed")
    assert res.exit_code == 0, res.output
    assert _statuses(manifest) == ["skipped", "ok", "skipped", "skipped"]
    assert (tmp_path / "k2" / "canonical.npz").is_file()


def test_the_summary_replaces_only_an_earlier_summary(tmp_path):
    manifest = _manifest(tmp_path, _row("a"))
    theirs = tmp_path / "m.csv.pcnet_batch.json"
    theirs.write_text("my notes")
    res = _invoke(manifest)
    assert res.exit_code == 1 and "--summary-json" in res.output and "pcnet did not write" in res.output
    assert theirs.read_text() == "my notes" and not (tmp_path / "a").exists()


@pytest.mark.slow
def test_the_report_replaces_only_an_earlier_report(tmp_path):
    """The Markdown report beside the summary is refused before any work where a file pcnet
    did not write has its name, and replaced where it is an earlier batch's."""
    manifest = _manifest(tmp_path, _row("a"))
    theirs = tmp_path / "m.csv.pcnet_batch.md"
    theirs.write_text("# my notes\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and f"--summary-json {tmp_path / 'm.csv.pcnet_batch.json'} (its report beside it, " \
        "m.csv.pcnet_batch.md): expected a new file or an earlier pcnet batch report" in res.output, res.output
    assert theirs.read_text() == "# my notes\n" and not (tmp_path / "a").exists()
    res = _invoke(manifest, "--summary-json", tmp_path / "r.json")  # its report: r.md
    assert res.exit_code == 0 and _report(manifest).startswith("# my notes"), res.output
    assert (tmp_path / "r.md").read_text().startswith(f"# pcnet batch: {manifest}")
    assert _invoke(manifest, "--summary-json", tmp_path / "r.json").exit_code == 0  # its own report: replaced


def test_the_terminal_summary_is_short_and_the_report_has_every_row():
    """The summary: counts, a line per failed row and per distinct warning (most severe first,
    with its action and lines), each list cut at SUMMARY_LINES; the report: every row, every
    error (a bug's traceback too), every warning in full, the restarts."""
    from pcnet.pipeline.batch import SUMMARY_LINES, BatchReport, batch_markdown, format_summary
    from pcnet.pipeline.batch_worker import finding_records
    from pcnet.stages.flags import leg_asymmetry_flag, track_switch_flag

    joints = np.zeros((10, 17, 3))
    joints[:, 1:4, 1] = [-0.3, -0.7, -1.1]  # hip, knee, ankle: a right leg of 0.8, a left of 0.6
    joints[:, 4:7, 1] = [-0.3, -0.6, -0.9]
    (legs_found,) = leg_asymmetry_flag(joints)
    (switch_found,) = track_switch_flag(np.repeat([0, 1], [20, 40]), [(20, 3.1)], person_option=True)
    legs, switch = legs_found.detail, switch_found.detail

    def row(i, status, warnings=(), error="", **extra):
        return {"row": i, "line": i + 1, "out": f"/study/out/r{i}", "status": status, "frames": 60, "valid": 60,
                "mode": "sequence", "units": "m", "camera_tilt_deg": 4.2, "posture": "upright", "seconds": 1.0,
                "error": error,
                "warnings": list(warnings), "host": "h", "pid": 100 + i, "attempts": 1, "threads": 2, **extra}

    rows = [row(1, "ok", [legs, switch]), row(2, "skipped", [legs]), row(3, "skipped", [legs]),
            row(4, "failed", error="ValueError: boom", traceback="Traceback (most recent call last):\n  boom"),
            *(row(i, "failed", error=f"file 'x{i}.npy': no such file") for i in range(5, 7 + SUMMARY_LINES))]
    # row 3 was skipped by --retry-failed: its previous summary has its warnings' texts only
    findings = {1: finding_records([legs_found, switch_found]), 2: finding_records([legs_found])}
    report = BatchReport(rows, False, Path("/study/m.csv.pcnet_batch.json"), 3.0, settings={"manifest": "/study/m.csv"},
                         restarts=["line 5: worker process 7 was killed by SIGKILL; starting it again (attempt 2 of 2)"],
                         report_path=Path("/study/m.csv.pcnet_batch.md"), findings=findings)
    text = format_summary(report)
    failed = len(rows) - 3
    assert text.splitlines()[:2] == [
        f"3 of {len(rows)} recordings have complete outputs (1 ok, 2 skipped, {failed} failed, 0 cancelled) in 3.0 s",
        "FAILED   line 5: ValueError: boom"]
    assert f"... and {failed - SUMMARY_LINES} more failed rows: /study/m.csv.pcnet_batch.md" in text
    legs_line = f"WARNING  {legs_found.headline} -> {legs_found.action}"
    assert (f"\nWARNING  {switch_found.headline} -> check column person (line 2: r1)\n{legs_line} (lines 2: r1, "
            f"3: r2)\n"
            f"WARNING  the lifter's left and right legs differ by 25 % in length, more than") in text
    assert "-> see report.md (line 4: r3)\n" in text  # row 3's text, shortened: a line of its own
    assert "\noutputs           /study/out (3 folders)\n" in text
    assert text.endswith("summary           /study/m.csv.pcnet_batch.json\ndetails: /study/m.csv.pcnet_batch.md")
    # what to do once fixed (a batch trial's FAILED lines named no next step)
    assert "\nonce fixed, --retry-failed runs the failed and cancelled rows alone\n" in text
    assert len(text.splitlines()) == 1 + SUMMARY_LINES + 1 + 1 + 3 + 3
    md = batch_markdown(report)
    assert md.startswith("# pcnet batch: /study/m.csv\n")
    # the units, camera tilt and posture of each row beside it (a batch trial compared 34 yoga files by opening
    # each; another could not tell a row without height was not in metres)
    warned = {r["row"]: len(r.get("warnings") or []) if r["status"] in ("ok", "skipped") else "-" for r in rows}
    assert all(f"| {r['row']} | {r['line']} | {r['status']} | {warned[r['row']]} | 1 | 60 | 60 | sequence | m | 4.2 | - "
               f"| upright | - | - | - | - | 1.0 | h:{r['pid']} | 2 | {r['out']} |" in md for r in rows)
    assert "OpenSim" not in text  # no row asked for a fit
    assert all(r["error"] in md for r in rows[3:]) and "Traceback (most recent call last):\n  boom" in md
    # a warning's full text once, the rows after it pointing to it (a yoga trial read 120 words a row)
    assert md.count(legs) == 1 and md.count(switch) == 1 and md.index(switch) < md.index(legs)
    assert md.count("The text of line 2's, with this row's numbers.") == 2
    assert "- line 5: worker process 7 was killed by SIGKILL" in md


def test_the_summary_gives_the_opensim_fits_marker_rms():
    """Rows with an OpenSim fit: its marker RMS in the report's table, and their range with the
    worst row's line in the terminal summary (a user trial: the summary had no IK fit at all)."""
    from pcnet.pipeline.batch import BatchReport, batch_markdown, format_summary

    rows = [{"row": i, "line": i + 1, "out": f"/s/r{i}", "status": status, "frames": 9, "valid": 9, "mode": "sequence",
             "seconds": 1.0, "error": "", "warnings": [], "host": "h", "pid": 1, "attempts": 1, "threads": 1,
             "opensim_rms_cm": rms} for i, (status, rms) in enumerate(
        [("ok", 1.74), ("skipped", 3.5), ("ok", None), ("failed", 9.0)], 1)]
    report = BatchReport(rows, False, Path("/s/m.pcnet_batch.json"), 1.0,
                         settings={"engine": "local", "workers": 1, "retries": 0})
    assert "- **engine**: local, 1 worker, retries 0;" in batch_markdown(report)  # a user trial: "1 workers"
    assert "\nOpenSim IK        marker RMS 1.74-3.50 cm over 2 rows (largest: line 3: r2)\n" in format_summary(report)
    assert "| 1 | 2 | ok | 0 | 1 | 9 | 9 | sequence | - | - | - | - | - | - | - | 1.74 | 1.0 |" in batch_markdown(report)
    rows[1]["status"] = "failed"
    assert "\nOpenSim IK        marker RMS 1.74 cm (line 2: r1)\n" in format_summary(report)


def test_the_summary_names_the_rows_whose_outputs_are_not_in_metres():
    """A row without ``height`` for a lifter whose output is not metric ran "ok" with columns
    named ``pelvis_y_normalised``, said only in its report.md's notes (a user trial): the
    summary names those rows and the column that scales them; an all-metric batch has no line."""
    from pcnet.pipeline.batch import BatchReport, format_summary

    rows = [{"row": i, "line": i + 1, "out": f"/s/r{i}", "status": status, "frames": 9, "valid": 9, "mode": "sequence",
             "units": units, "seconds": 1.0, "error": "", "warnings": [], "host": "h", "pid": 1, "attempts": 1,
             "threads": 1, "opensim_rms_cm": None} for i, (status, units) in enumerate(
        [("ok", "m"), ("ok", "normalised"), ("skipped", "m"), ("failed", None), ("skipped", None)], 1)]
    report = BatchReport(rows, False, Path("/s/m.pcnet_batch.json"), 1.0,
                         settings={"engine": "local", "workers": 1, "retries": 0})
    assert ("\nunits             normalised in line 3, not metres (column height scales them); m in 2 rows\n"
            in format_summary(report)), format_summary(report)
    rows[1]["units"] = "m"
    assert "units " not in format_summary(report)


def test_the_summary_says_which_rows_got_a_metric_pelvis_path_and_a_floor_plane():
    """A lab's first question of a batch (a user trial opened every report.md to answer it):
    which rows' world frames have a pelvis path and a fitted floor. The summary groups the
    complete rows by them; the report's table has a column each."""
    from pcnet.pipeline.batch import BatchReport, batch_markdown, format_summary

    kinds = [("ok", "from 2D keypoints", "plane"), ("ok", "not observable", "per frame"),
             ("skipped", "not observable", "per frame"), ("ok", None, None), ("failed", None, None)]
    rows = [{"row": i, "line": i + 1, "out": f"/s/r{i}", "status": status, "frames": 9, "valid": 9, "mode": "sequence",
             "units": "m", "root_path": path, "floor": floor, "seconds": 1.0, "error": "", "warnings": [],
             "host": "h", "pid": 1, "attempts": 1, "threads": 1, "opensim_rms_cm": None}
            for i, (status, path, floor) in enumerate(kinds, 1)]
    report = BatchReport(rows, False, Path("/s/m.pcnet_batch.json"), 1.0, settings={})
    assert ("\nworld frame       pelvis path from 2D keypoints, floor plane in line 2; pelvis path not observable, "
            "floor per frame in lines 3, 4\n" in format_summary(report)), format_summary(report)
    assert "| sequence | m | - | - | - | - | from 2D keypoints | plane | - |" in batch_markdown(report)
    # the trunk's median lean beside the posture (a seated row read 26 deg looked as sound as a standing one)
    rows[0]["angles"] = {"trunk_inclination_deg": {"median": 25.8, "min": 20.1, "max": 31.0}}
    assert "| sequence | m | - | - | - | 25.8 | from 2D keypoints | plane | - |" in batch_markdown(report)
    # each row's warnings counted where it finished (a physiotherapist's trial found no row's trouble in the table)
    rows[1]["warnings"] = ["lifter's legs differ", "body read as lying"]
    table = [ln for ln in batch_markdown(report).splitlines() if ln.startswith("| ")]
    assert [ln.split(" | ")[3] for ln in table[1:]] == ["0", "2", "0", "0", "-"], table
    for r in rows:
        r["root_path"] = None
    assert "world frame" not in format_summary(report)


def test_the_summary_groups_one_kind_of_warning_whose_numbers_differ_by_row():
    """Fifteen rows with the same warning but their own numbers make one summary line, not
    fifteen that push every other warning out of the cut (a user trial: 15 Shavasana files)."""
    from pcnet.pipeline.batch import SUMMARY_LINES, BatchReport, format_summary
    from pcnet.pipeline.batch_worker import finding_records
    from pcnet.stages.flags import leg_asymmetry_flag

    def legs(right_ankle_y):
        joints = np.zeros((10, 17, 3))
        joints[:, 1:4, 1] = [-0.3, -0.7, right_ankle_y]
        joints[:, 4:7, 1] = [-0.3, -0.6, -0.9]
        return leg_asymmetry_flag(joints)[0]

    found = {i: legs(-1.1 - 0.02 * i) for i in range(1, 16)}
    rows = [{"row": i, "line": i + 1, "out": f"/study/out/r{i}", "status": "ok", "frames": 10, "valid": 10,
             "mode": "sequence", "seconds": 1.0, "error": "", "warnings": [f.detail], "host": "h", "pid": 1,
             "attempts": 1, "threads": 1} for i, f in found.items()]
    assert len({f.headline for f in found.values()}) > 1
    report = BatchReport(rows, False, Path("/study/m.json"), 1.0, settings={},
                         findings={i: finding_records([f]) for i, f in found.items()})
    (line,) = [t for t in format_summary(report).splitlines() if t.startswith("WARNING")]
    assert line.startswith(f"WARNING  {found[1].headline}")
    lines = ", ".join(str(i + 1) for i in range(1, 1 + SUMMARY_LINES))
    assert line.endswith(f"(lines {lines} and {15 - SUMMARY_LINES} more; 15 rows, the first's text shown, the batch report has each)")


def test_the_summary_keeps_speed_and_acceleration_apart_and_counts_each_row_once():
    """Two rows with implausible speed, one of them with implausible acceleration too: two
    summary lines, each naming its rows once (a user trial: "lines 3, 3, 5, 5; 4 rows" for two
    rows, the acceleration folded into the speed line)."""
    from pcnet.pipeline.batch import BatchReport, format_summary
    from pcnet.pipeline.batch_worker import finding_records
    from pcnet.stages.flags import implausible_motion_findings
    from pcnet.stages.plausibility import ImplausibleMotion

    def motion(quantity, peak):
        limit, unit = (8.0, "m/s") if quantity == "speed" else (140.0, "m/s^2")
        return ImplausibleMotion("right_wrist", quantity, 10, 12, peak, 11, limit, unit)

    found = {1: implausible_motion_findings([motion("speed", 9.0), motion("acceleration", 400.0)]),
             2: implausible_motion_findings([motion("speed", 12.0)])}
    rows = [{"row": i, "line": i + 2, "out": f"/study/out/r{i}", "status": "ok", "frames": 20, "valid": 20,
             "mode": "sequence", "seconds": 1.0, "error": "", "warnings": [f.detail for f in fs], "host": "h",
             "pid": 1, "attempts": 1, "threads": 1} for i, fs in found.items()]
    report = BatchReport(rows, False, Path("/study/m.json"), 1.0, settings={},
                         findings={i: finding_records(fs) for i, fs in found.items()})
    lines = [t for t in format_summary(report).splitlines() if t.startswith("WARNING")]
    assert len(lines) == 2 and "implausible speed" in lines[0] and "implausible acceleration" in lines[1], lines
    assert lines[0].endswith("(lines 3: r1, 4: r2; 2 rows, the first's text shown, the batch report has each)"), lines
    assert lines[1].endswith("(line 3: r1)"), lines


def test_run_flags_in_an_action_read_as_manifest_columns():
    from pcnet.pipeline.batch import in_manifest_terms

    assert in_manifest_terms("check the lifter, or its units (--lifter generic --units)") == \
        "check the lifter, or its units (column lifter generic, column units)"
    assert in_manifest_terms("--no-camera-prior if standing under a tilted camera") == \
        "column camera_prior false if standing under a tilted camera"
    # a sentence's words between flags are no flag's value (a review: "column axes and, column layout")
    assert in_manifest_terms("check --axes and --layout") == "check column axes and column layout"
    assert in_manifest_terms("check --axes, --layout (--lifter generic)") == ("check column axes, column layout "
                                                                             "(column lifter generic)")
    assert in_manifest_terms("(--axes with --lifter generic)") == "(column axes with column lifter generic)"
    assert in_manifest_terms("millimetres? --units mm, or read it with pcnet run --lifter generic --units mm") == \
        "millimetres? column units mm, or read it with column lifter generic, column units mm"
    # the findings' own actions name a generic lifter's option "with --lifter generic" (a user trial read
    # "column lifter generic, column units" as garbled)
    from pcnet.stages.flags import size_change_flag

    joints = np.zeros((40, 17, 3))
    joints[:, :, 1] = np.linspace(0.0, -1.6, 17)
    joints[20:] *= 2.0
    (found,) = size_change_flag(joints)
    # and say when to switch to the generic lifter (a batch trial read it as "always switch")
    # ... in an order that reads in both (a trial: "read with column units px or normalised with column lifter
    # generic" read as garbled)
    assert in_manifest_terms(found.action) == ("check the lifter's output; for output in image units give column "
                                               "lifter generic with column units px or normalised")
    assert in_manifest_terms("--mode smooth --no-camera-prior") == "column mode smooth, column camera_prior false"
    assert in_manifest_terms("pass --fps-override to use --fps anyway") == \
        "set column fps_override to true to use column fps anyway"


def test_retry_failed_needs_a_previous_summary(tmp_path):
    manifest = _manifest(tmp_path, _row("a"))
    res = _invoke(manifest, "--retry-failed")
    assert res.exit_code == 1 and "--retry-failed" in res.output and "m.csv.pcnet_batch.json" in res.output
    assert not (tmp_path / "a").exists()


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, getattr(signal, "SIGHUP", signal.SIGINT)], ids=["ctrl-c", "hangup"])
def test_ctrl_c_stops_at_once_and_prints_what_finished(tmp_path, hook, signum):
    """SIGINT while rows 2 and 3 run (row 1 done, row 4 waiting): exit 130 within ~2 s,
    the table printed, rows 2-4 cancelled, no output or staged folder left for them. A closed
    terminal's SIGHUP to the batch and its workers stops it the same way (a user trial: the
    batch died at once, leaving two staged folders and a summary of rows "pending")."""
    manifest = _manifest(tmp_path, *(_row(f"c{i}") for i in range(1, 5)))
    (hook / "hold-2").touch()
    (hook / "hold-3").touch()
    proc = _spawn_batch(manifest, "--workers", "2", hook=hook)
    try:
        _wait_for(lambda: _started(hook, 2) and _started(hook, 3), what="rows 2 and 3 to start")
        out, err, took = _interrupt(proc, signum)
    finally:
        proc.kill()
    assert proc.returncode == 130, out + err
    assert took < 3.0, took
    assert "interrupted" in out and "1 of 4 recordings have complete outputs (1 ok, 0 skipped, 0 failed, 3 cancelled)" in out
    summary = _summary(manifest)
    assert summary["interrupted"] is True and _statuses(manifest) == ["ok", "cancelled", "cancelled", "cancelled"]
    # the rows stopped while running say which attempt and worker they were in; row 4 never started
    assert [(r["attempts"], r["pid"]) for r in summary["rows"][1:3]] == [(1, _started(hook, 2)[0]),
                                                                          (1, _started(hook, 3)[0])]
    assert (summary["rows"][3]["attempts"], summary["rows"][3]["pid"]) == (0, None)
    assert (tmp_path / "c1" / MARKER).is_file()
    assert not any((tmp_path / f"c{i}").exists() for i in (2, 3, 4))
    assert not list(tmp_path.glob(f".*{TMP_TAG}*"))
    for pid in _started(hook, 2) + _started(hook, 3):  # the running rows' workers are gone
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_ray_engine_without_ray_says_how_to_get_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    manifest = _manifest(tmp_path, _row("a"))
    res = _invoke(manifest, "--engine", "ray")
    assert res.exit_code == 1
    assert res.output.strip() == 'Error: pcnet batch --engine ray needs Ray: pip install "pcnet[ray]"'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv"]


def test_address_needs_the_ray_engine(tmp_path):
    res = _invoke(_manifest(tmp_path, _row("a")), "--address", "auto")
    assert res.exit_code == 1 and "--address" in res.output and "--engine ray" in res.output


def _needs_ray():
    pytest.importorskip("ray", reason='Ray is not installed (pip install "pcnet[ray]"): the Ray engine is tested '
                                      'where it is (.ci/run installs it)')


@pytest.mark.slow
def test_ray_engine_starts_its_own_instance_beside_a_running_cluster(tmp_path):
    """Without --address, --engine ray starts its own local instance even where `ray start
    --head` runs on this machine (ray.init would join that cluster and refuse num_cpus)."""
    _needs_ray()
    ray_cli = Path(sys.executable).with_name("ray")
    started = subprocess.run([str(ray_cli), "start", "--head", "--port=6391", "--num-cpus=1",
                              "--include-dashboard=false"], capture_output=True, text=True, timeout=120)
    assert started.returncode == 0, started.stdout + started.stderr
    try:
        manifest = _manifest(tmp_path, _row("a"))
        res = _invoke(manifest, "--engine", "ray", "--workers", "1")
        assert res.exit_code == 0 and _statuses(manifest) == ["ok"], res.output
    finally:
        subprocess.run([str(ray_cli), "stop"], capture_output=True, timeout=120)


@pytest.mark.slow
def test_ray_engine_retries_a_killed_worker_and_the_batch_succeeds(tmp_path, hook):
    """Issue 16's measurement, on a local Ray instance (`ray.init(num_cpus=2)`): a Ray worker
    process killed by PID while running row 2; Ray runs the task again (max_retries), the
    batch completes with exit 0 and the summary says row 2 took two attempts."""
    _needs_ray()
    manifest = _manifest(tmp_path, *(_row(f"y{i}", method="pcnet" if i == 1 else "geometric") for i in range(1, 5)))
    (hook / "hold-2").touch()
    proc = _spawn_batch(manifest, "--engine", "ray", "--workers", "2", "--retries", "1", hook=hook)
    try:
        _wait_for(lambda: _started(hook, 2), what="row 2 to start on Ray")
        victim = _started(hook, 2)[0]
        os.kill(victim, signal.SIGKILL)
        (hook / "hold-2").unlink()
        # The retried row restarts a Ray worker; on a loaded 2-core machine that took over 90 s.
        out, err = proc.communicate(timeout=240)
    finally:
        proc.kill()
    assert proc.returncode == 0, out + err
    assert "line 3: its Ray worker died; starting it again" in err and "attempt 2 of 2" in err, err
    summary = _summary(manifest)
    rows = summary["rows"]
    assert summary["engine"] == "ray" and [r["status"] for r in rows] == ["ok"] * 4
    assert rows[1]["attempts"] == 2 and rows[1]["pid"] != victim and len(_started(hook, 2)) == 2
    assert all(r["attempts"] == 1 for i, r in enumerate(rows) if i != 1)
    assert rows[0]["threads"] == int(os.environ.get("PCNET_ORT_THREADS") or max(1, cpu_cores() // 2))
    for i in range(1, 5):
        assert (tmp_path / f"y{i}" / "canonical.npz").is_file() and (tmp_path / f"y{i}" / BATCH_MARKER).is_file()

    again = run_batch(manifest, BatchOptions(engine="ray", workers=2))  # resume on Ray: nothing to run
    assert [r["status"] for r in again.rows] == ["skipped"] * 4


@pytest.mark.slow
def test_ray_engine_reports_a_failing_row_and_stops_on_ctrl_c(tmp_path, hook):
    """A row's own error is its result (not retried, even with --retries); Ctrl-C cancels the
    running tasks (ray.cancel(force=True)), prints the table and exits 130."""
    _needs_ray()
    nan = tmp_path / "nan.npy"
    np.save(nan, np.full((60, 17, 3), np.nan, np.float32))
    manifest = _manifest(tmp_path, _row("z1", lifter_output=nan), _row("z2"), _row("z3"))
    (hook / "hold-2").touch()
    (hook / "hold-3").touch()
    proc = _spawn_batch(manifest, "--engine", "ray", "--workers", "2", "--retries", "1", hook=hook)
    try:
        # Ray starts row 3 as soon as row 1 has failed, maybe before the driver has taken row 1's
        # result: wait for that too (the summary is rewritten at every result).
        _wait_for(lambda: _started(hook, 2) and _started(hook, 3) and _statuses(manifest)[0] == "failed",
                  what="rows 2 and 3 to start on Ray, row 1 to fail")
        out, err, took = _interrupt(proc)
    finally:
        proc.kill()
    assert proc.returncode == 130, out + err
    assert took < 5.0, took  # cancelling and stopping the local Ray instance
    rows = _summary(manifest)["rows"]
    assert [r["status"] for r in rows] == ["failed", "cancelled", "cancelled"], out
    assert "only NaN" in rows[0]["error"] and rows[0]["attempts"] == 1
    assert "cancelled" in out and not (tmp_path / "z2").exists() and not list(tmp_path.glob(f".*{TMP_TAG}*"))


def test_staged_folders_of_rows_on_other_hosts_and_unmarked_files_are_left_alone(tmp_path):
    """A cluster node cannot check a process on another node: its staged folder may belong
    to a row still running there, so it is kept; a dead local process's is removed."""
    import json as _json
    import socket

    from pcnet.pipeline.outdir import EMPTY_STAGED_GRACE_S, MARKER, TMP_TAG, clean_stale

    def staged(name: str, host: str, pid: int):
        folder = tmp_path / f".out{TMP_TAG}{name * 12}"  # the 12 hex digits pcnet names it with
        folder.mkdir()
        (folder / MARKER).write_text(_json.dumps({"writer": "pcnet", "host": host, "pid": pid}))
        return folder

    remote = staged("a", "another-node", 12345)
    dead = staged("b", socket.gethostname(), 2**22 + 7)  # above any pid this kernel hands out
    empty = tmp_path / f".out{TMP_TAG}cccccccccccc"  # killed between mkdir and its marker
    empty.mkdir()
    long_ago = time.time() - EMPTY_STAGED_GRACE_S - 1
    os.utime(empty, (long_ago, long_ago))
    starting = tmp_path / f".out{TMP_TAG}eeeeeeeeeeee"  # another row's, created just now: marker on its way
    starting.mkdir()
    unmarked = tmp_path / f".out{TMP_TAG}dddddddddddd"  # not provably pcnet's: never touched
    unmarked.mkdir()
    (unmarked / "data.bin").write_bytes(b"x")
    removed = clean_stale(tmp_path / "out")
    assert sorted(removed) == [dead, empty] and remote.is_dir() and unmarked.is_dir() and starting.is_dir()


@pytest.mark.slow
def test_a_complete_output_missing_a_file_runs_again(tmp_path):
    """A re-run skips a row only while every file pcnet wrote for it is there unchanged; a
    file of the user's beside them does not stop the skip (nothing would be replaced)."""
    manifest = _manifest(tmp_path, _row("r1"), _row("r2"))
    assert _invoke(manifest, "--workers", "1").exit_code == 0
    (tmp_path / "r1" / "kinematics.csv").unlink()
    (tmp_path / "r2" / "notes.txt").write_text("mine")
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 0 and _statuses(manifest) == ["ok", "skipped"], res.output
    assert (tmp_path / "r1" / "kinematics.csv").is_file() and (tmp_path / "r2" / "notes.txt").read_text() == "mine"
    # an output the user edited is theirs: still complete, skipped, never replaced
    edited = tmp_path / "r1" / "kinematics.csv"
    edited.write_text(edited.read_text() + "\n")
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 0 and _statuses(manifest) == ["skipped", "skipped"], res.output
    # incomplete and holding the user's file: that row is refused, naming both, without --overwrite advice
    (tmp_path / "r2" / "kinematics.csv").unlink()
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 1 and "line 3: column out: expected to run this row again (its earlier output lacks " \
        "kinematics.csv), got its folder also holding files pcnet did not write or that changed since (notes.txt)" \
        in res.output and "--overwrite" not in res.output, res.output
    assert (tmp_path / "r2" / "notes.txt").read_text() == "mine"


def test_manifest_layout_mistakes_are_named_by_their_file_line(tmp_path):
    """Blank lines do not shift the line numbers; the header's problems are line 1's, once;
    a row with fewer cells than the header is refused (its missing out went to pcnet_out),
    and the other rows are still checked."""
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"{HEADER}\n\n{_row('a')}\n\n{_row('b', method='bogus')}\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and f"{manifest}: line 5: column method: expected one of" in res.output, res.output
    manifest.write_text(f"{HEADER},lifter\n{_row('a')},generic\n{_row('b')},generic\n")
    res = _invoke(manifest)
    assert res.output.count("Error: ") == 1 and f"{manifest}: line 1: expected each column once, got lifter more than " \
        "once" in res.output, res.output
    # a spreadsheet's exports (a user trial): empty columns beside the table, Latin-1, tabs
    manifest.write_text(f"{HEADER},,\n{_row('a')},,\n")
    res = _invoke(manifest)
    assert "line 1: expected a name for every column, got 2 unnamed columns" in res.output, res.output
    manifest.write_bytes(f"{HEADER}\n{_row('a')}\n".replace("a,", "M\u00fcller,", 1).encode("latin-1"))
    res = _invoke(manifest)
    assert "got a byte that is not UTF-8 at offset" in res.output and "CSV UTF-8" in res.output, res.output
    manifest.write_text(HEADER.replace(",", "\t") + "\n" + _row("a").replace(",", "\t") + "\n")
    res = _invoke(manifest)
    assert "columns separated by tabs?" in res.output, res.output
    manifest.write_text(HEADER.replace(",", ";") + "\n" + _row("a").replace(",", ";") + "\n")
    res = _invoke(manifest)  # the separator is the hint, not a near column name (a user trial: "lifter_output?")
    assert "(columns separated by ';'? a manifest separates them by commas)" in res.output and "?)" not in \
        res.output.split("(columns separated")[0], res.output
    manifest.write_text(HEADER.replace("fps", "FPS") + f"\n{_row('a')}\n{_row('b')}\n")
    res = _invoke(manifest)
    assert res.output.count("Error: ") == 1 and "line 1: unknown columns ['FPS'] (FPS: fps?)" in res.output, res.output
    manifest.write_text(HEADER.replace("fps", "frame_rate") + f"\n{_row('a')}\n")  # another name spelling misses
    assert "unknown columns ['frame_rate'] (frame_rate: fps?)" in _invoke(manifest).output
    # a choice in any case reads as the name (a yoga trial's "VideoPose3D", as its authors write it);
    # a misspelt one lists the choices plainly with the close one
    manifest.write_text(f"{HEADER}\n{_row('a').replace('motionbert', 'MotionBERT')}\n"
                        f"{_row('b').replace('motionbert', 'MotionBRT')}\n")
    res = _invoke(manifest)
    assert res.output.count("Error: ") == 1 and "line 3: column lifter: expected one of motionbert, ddhpose" in \
        res.output and "got 'MotionBRT' (MotionBRT: motionbert?)" in res.output, res.output
    manifest.write_text(f"{HEADER}\n{_row('a').rsplit(',', 3)[0]}\n")
    res = _invoke(manifest)
    assert f"{manifest}: line 2: expected 8 cells (the header's), got 5" in res.output, res.output
    # a row of the wrong length does not hide the other rows' problems
    manifest.write_text(f"{HEADER}\n{_row('a').rsplit(',', 3)[0]}\n{_row('b', method='bogus')}\n{_row('c')},extra\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and res.output.count("Error: ") == 3, res.output
    assert "line 3: column method: expected one of" in res.output and "line 4: expected 8 cells" in res.output
    manifest.write_text("[[row]]\nlifter = 'motionbert'\n")
    assert "(a TOML file? a manifest is CSV)" in _invoke(manifest).output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv"]


def test_nested_outs_a_summary_inside_an_out_and_bad_option_values_are_refused_before_any_work(tmp_path):
    manifest = _manifest(tmp_path, _row("o/a"), _row("o/a/b"), _row("p/c/d"), _row("p/c"))
    res = _invoke(manifest)
    assert res.exit_code == 1 and "line 3: column out: expected a folder of its own, got 'o/a/b', inside line 2's " \
        "output folder" in res.output and "line 5: column out: expected a folder of its own, got 'p/c', which holds " \
        "line 4's output folder" in res.output, res.output
    manifest = _manifest(tmp_path, _row("o/a"))
    res = _invoke(manifest, "--summary-json", tmp_path / "o" / "a" / "s.json")
    assert res.exit_code == 1 and "expected a place outside the rows' output folders" in res.output, res.output
    manifest = tmp_path / "g.csv"
    manifest.write_text(f"lifter,lifter_output,fps,units,out\ngeneric,{BOX_3D},30,m,g1\ngeneric,{BOX_3D},30,feet,g2\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and "line 3: column units: expected one of ['cm', 'm', 'mm', 'normalised', 'px'] for " \
        "--lifter generic, got 'feet'" in res.output, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.csv", "m.csv"]


def test_an_unreachable_cluster_address_is_refused_at_once(tmp_path):
    import socket

    _needs_ray()  # without Ray the batch stops earlier, saying how to install it

    with socket.socket() as s:  # a port nothing listens on: bound, never listening
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        manifest = _manifest(tmp_path, _row("a"))
        res = _invoke(manifest, "--engine", "ray", "--address", f"127.0.0.1:{port}")
    assert res.exit_code == 1 and f"--address 127.0.0.1:{port}: expected a running Ray cluster's head" in res.output
    from pcnet.pipeline.batch_ray import check_reachable

    check_reachable(f"ray://127.0.0.1:{port}")  # Ray Client and `auto`: left to Ray
    check_reachable("auto")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv"]


def test_an_engine_that_fails_to_start_leaves_no_pending_rows(tmp_path, monkeypatch):
    """The summary is written as pending when the batch starts; if the engine itself fails
    (Ray refusing to start, say), its rows end cancelled with the error, not pending."""
    from pcnet.pipeline import batch_local
    from pcnet.stages.core.errors import InputError

    def refuse(self, jobs):
        raise InputError("--address x: expected a Ray cluster this machine may join, got none")

    monkeypatch.setattr(batch_local.LocalEngine, "run", refuse)
    manifest = _manifest(tmp_path, _row("a"), _row("b"))
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 1 and "expected a Ray cluster" in res.output
    summary = _summary(manifest)
    assert _statuses(manifest) == ["cancelled", "cancelled"] and "expected a Ray cluster" in summary["error"]
    assert summary["finished"] is True and summary["driver_pid"] == os.getpid()


@pytest.mark.slow
def test_a_rows_warnings_reach_the_summary(tmp_path):
    """What `pcnet run` warns of for a recording (its WARNING lines, in full in its npz and
    report.md) is in the row's summary (and on stderr as the row ends): a batch user reads no
    per-row terminal output."""
    lying = FIXTURES / "yoga_Abhay_Shavasana_f200-299.npy"  # real VideoPose3D output of a lying body
    manifest = tmp_path / "w.csv"
    manifest.write_text(f"lifter,lifter_output,fps,out,recording\ngeneric,{lying},30,w1,false\n")
    res = _invoke(manifest)
    assert res.exit_code == 0, res.output
    (row,) = _summary(manifest)["rows"]
    single = CliRunner().invoke(main, ["run", "--lifter", "generic", "--lifter-output", str(lying), "--fps", "30",
                                       "--no-recording", "--out", str(tmp_path / "single")])
    with np.load(tmp_path / "single" / "canonical.npz") as npz:
        expected = [str(f) for f in npz["flags"]]
    assert sum(ln.startswith("WARNING") for ln in single.output.splitlines()) == len(expected)
    assert expected and row["warnings"] == expected
    # the terminal: one short line per warning (headline -> action) as `pcnet run` prints it,
    # its flags named as columns, under the row's line; the batch report keeps them in full
    from pcnet.pipeline.batch import in_manifest_terms

    short = [f"    {in_manifest_terms(ln)}" for ln in single.output.splitlines() if ln.startswith("WARNING")]
    lines = res.output.splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.startswith("[1/1] line 2 ok"))
    assert lines[at + 1:at + 1 + len(short)] == short, res.output
    assert all(w not in res.output for w in expected if len(w) > 100)
    assert all(w in _report(manifest) for w in expected)
    # where each row's provenance lies (a trial found none in the summary or the report)
    from pcnet.pipeline.config import pcnet_version

    assert f"- **provenance**: pcnet {pcnet_version()}; each complete row's input digests (sha256), settings and " \
        f"pcnet version in its output's {BATCH_MARKER}" in _report(manifest)
    res = _invoke(manifest)  # skipped on a re-run: its warnings stay in the summary, their lines in the terminal's
    (row,) = _summary(manifest)["rows"]
    assert res.exit_code == 0 and row["status"] == "skipped" and row["warnings"] == expected
    assert all(f"{ln.strip()} (line 2: w1)" in res.output for ln in short) and all(w in _report(manifest) for w in expected)


def test_a_frame_rate_that_contradicts_the_video_is_refused_before_any_row_runs(tmp_path):
    """The real example video records 30 fps, the row says 25: refused with the manifest's
    columns before any row runs (a user trial: it failed only when its row started, after the
    rows before it had run; `pcnet run`'s own wording reaches a manifest user in the same terms,
    ``test_run_flags_in_an_action_read_as_manifest_columns``)."""
    example = Path(__file__).resolve().parent.parent / "pipeline" / "example_data"
    manifest = tmp_path / "f.csv"
    manifest.write_text(f"lifter,lifter_output,video,fps,out,recording\n"
                        f"motionbert,{example / 'X3D.npy'},{example / 'boxing2.mp4'},30,f0,false\n"
                        f"motionbert,{example / 'X3D.npy'},{example / 'boxing2.mp4'},25,f1,false\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and res.output.count("Error: ") == 1, res.output
    assert f"{manifest}: line 3: column fps 25: expected the rate {example / 'boxing2.mp4'} records (30 fps), " \
        "got 25 fps; set column fps_override to true to use column fps anyway" in res.output, res.output
    assert not (tmp_path / "f0").exists() and not (tmp_path / "f1").exists()
    manifest.write_text(manifest.read_text().replace("recording\n", "recording,fps_override\n")
                        .replace("false\n", "false,true\n"))
    plan, _ = plan_batch(manifest, BatchOptions())
    assert [item.action for item in plan] == ["run", "run"]


def test_a_row_without_any_frame_rate_is_refused_before_any_work(tmp_path):
    """No video, no fps column and a lifter whose files record no rate: refused with the
    other rows' problems, not failed after the others ran."""
    manifest = tmp_path / "r.csv"
    manifest.write_text(f"lifter,lifter_output,fps,out\nmotionbert,{BOX_3D},30,a\nmotionbert,{BOX_3D},,b\n"
                        f"mediapipe,{MEDIAPIPE},,c\nmotionbert,absent.npy,,d\n")
    res = _invoke(manifest)
    assert res.exit_code == 1 and res.output.count("Error: ") == 3 and "line 3: column fps: expected the frame rate " \
        "(no video is given and motionbert files do not record one), got none" in res.output, res.output
    # a missing file is named with it, first (a review: the rate's refusal had hidden it)
    missing = res.output.index("line 5: column lifter_output: expected an existing file, got 'absent.npy'")
    assert missing < res.output.index("line 5: column fps: expected the frame rate"), res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv"]


def test_a_row_that_runs_out_of_disk_says_so_as_pcnet_run_does():
    """numpy writes without naming the file: a row's error is the same one line `pcnet run`
    prints, and a bug keeps its type."""
    import errno

    from pcnet.pipeline.batch_worker import error_line

    assert error_line(OSError(errno.EFBIG, "File too large")) == \
        "writing the outputs failed (File too large; the disk, its inodes or your quota are full: free space there " \
        "or write elsewhere)"
    assert error_line(ZeroDivisionError("division by zero")) == "ZeroDivisionError: division by zero"


def test_a_ray_task_lost_to_the_memory_monitor_or_a_dead_node_is_named_so():
    """Ray's memory monitor and a node's death fail a task with their own errors, not a
    worker crash: each row says which, with its attempts."""
    ray = pytest.importorskip("ray")
    from pcnet.pipeline.batch_ray import _death_line

    last = {"attempts": 2, "pid": 4242, "host": "node-7"}
    assert _death_line(ray, ray.exceptions.OutOfMemoryError("low memory"), last) == (
        "its Ray worker process (pid 4242) was killed by Ray's memory monitor (the node ran low on memory) while "
        "running the row, after 2 attempt(s)")
    assert _death_line(ray, ray.exceptions.NodeDiedError("gone"), last) == \
        "the Ray node running it (node-7) died while running the row, after 2 attempt(s)"
    assert _death_line(ray, ray.exceptions.WorkerCrashedError(), last).startswith(
        "its Ray worker process (pid 4242) died (killed, as an out-of-memory kill does) while running the row")


def test_rows_sharing_their_settings_and_folders_are_each_still_checked(tmp_path):
    """The check validates the rows that differ only in their paths once and resolves each
    folder once (issue 53): every row's own problems are still found, an ``out`` spelled
    otherwise or reached through a link included."""
    from pcnet.pipeline.batch import ManifestError, plan_batch

    (tmp_path / "rec").mkdir()
    shutil.copyfile(BOX_3D, tmp_path / "rec" / "x.npy")
    shutil.copyfile(BOX_2D, tmp_path / "rec" / "k.json")
    (tmp_path / "outputs").mkdir()
    (tmp_path / "outputs" / "link").symlink_to(tmp_path / "outputs" / "s2")

    def row(out, x="rec/x.npy", k="rec/k.json", fps="30"):
        return f"motionbert,{x},{k},alphapose,{fps},{out},geometric,false"

    manifest = _manifest(tmp_path,
                         row("outputs/s1"),                       # line 2: fine
                         row("outputs/s2"),                       # line 3: fine
                         row("outputs/s3", k=""),                 # line 4: a format without its keypoints
                         row("outputs/s4", x="rec/nothere.npy"),  # line 5: a missing input
                         row("outputs/s1"),                       # line 6: line 2's out
                         row("outputs/link"),                     # line 7: line 3's out, through a link
                         row("outputs/s7", fps="0.5"),            # line 8: a bad value
                         row("rec"),                              # line 9: the inputs' folder
                         row("outputs/./s9/../s1"),               # line 10: line 2's out, spelled otherwise
                         row("outputs/s10"))                      # line 11: fine
    with pytest.raises(ManifestError) as refused:
        plan_batch(manifest, BatchOptions())
    problems = {int(re.search(r": line (\d+): ", ln).group(1)): ln for ln in refused.value.lines}
    assert sorted(problems) == [4, 5, 6, 7, 8, 9, 10], refused.value.lines
    for line, needles in {4: ("columns keypoints2d and keypoints2d_format", "expected both or neither"),
                          5: ("column lifter_output: expected an existing file", "nothere.npy"),
                          6: ("expected a folder of its own", "which line 2 also writes"),
                          7: ("'outputs/link', which line 3 also writes",),
                          8: ("column fps: expected a value in",),
                          9: ("expected a folder apart from the inputs", "'rec', which is the folder of"),
                          10: ("which line 2 also writes",)}.items():
        assert all(n in problems[line] for n in needles), (needles, problems[line])


def _study(folder: Path, rows: int) -> Path:
    """A manifest of ``rows`` rows over one recording (relative paths), each row writing its
    own ``out`` in one folder, as a big study has them."""
    (folder / "rec").mkdir(parents=True)
    shutil.copyfile(BOX_3D, folder / "rec" / "x.npy")
    shutil.copyfile(BOX_2D, folder / "rec" / "k.json")
    (folder / "outputs").mkdir()
    return _manifest(folder, *(f"motionbert,rec/x.npy,rec/k.json,alphapose,{24 + i % 7},outputs/s{i:06d},"
                               f"geometric,false" for i in range(rows)))


def _check_cpu_seconds(manifest: Path, rows: int) -> float:
    import gc

    from pcnet.pipeline.batch import plan_batch

    # the objects earlier tests of this process left are frozen out of the collector's scans, so
    # that the check's own time is timed (after test_batch.py's other tests it read 156 us a row, over
    # the bound, where it passed alone)
    gc.collect()
    gc.freeze()
    try:
        started = time.process_time()
        planned, _ = plan_batch(manifest, BatchOptions())
        seconds = time.process_time() - started
    finally:
        gc.unfreeze()
    assert len(planned) == rows and all(item.action == "run" for item in planned)
    return seconds


def _stat_each_output_cpu_seconds(folder: Path, rows: int) -> float:
    """CPU seconds of the least a check of ``rows`` outputs does: join each row's folder
    name and ``lstat`` it (this machine's speed, in the same process as the check)."""
    missing = {}
    started = time.process_time()
    for i in range(rows):
        path = folder / f"s{i:06d}"
        try:
            os.lstat(path)
        except FileNotFoundError:
            missing[str(path)] = False
    return time.process_time() - started


@pytest.mark.slow
def test_checking_a_large_manifest_takes_time_linear_in_its_rows(tmp_path):
    """Issue 53: 100,000 rows are checked in seconds (benchmarks/manifest_check.py times them).
    Here 5,000 and 40,000 rows: eight times the rows take less than sixteen times as long
    (anything quadratic, such as each row listing or comparing with all the others, takes 64
    times), and a row's check costs at most eight times a path join and ``lstat`` per row
    timed beside it. CPU time, so that other jobs on a loaded machine do not count, and the
    least of two checks. Rows eight-fold apart, because the per-row time itself moves by up to
    1.6-fold between sizes (the garbage collector's thresholds, cache and clock contention on a
    2-core machine), so a doubling of rows under a threefold bound failed once in CI (0.56 s,
    then 1.73 s). Against the machine's own stat, not a fixed time: this VM's speed moved
    threefold between days (the same code: 57 us a row on 2026-11-26, 186 us on 2026-12-01, and
    a bound of 150 us failed CI), while the ratio read 4.4-4.9 on 2026-12-01 (7.2-7.7 before
    that day's savings of a second stat and of Path building per row)."""
    _check_cpu_seconds(_study(tmp_path / "warm", 1), 1)  # the validation's imports, out of the timing
    small = min(_check_cpu_seconds(_study(tmp_path / f"small{i}", 5_000), 5_000) for i in range(2))
    large, reference = math.inf, math.inf
    for i in range(2):
        study = _study(tmp_path / f"large{i}", 40_000)
        reference = min(reference, _stat_each_output_cpu_seconds(study.parent / "outputs", 40_000))
        large = min(large, _check_cpu_seconds(study, 40_000))
    assert large < 16 * small, f"5,000 rows: {small:.2f} s, 40,000 rows: {large:.2f} s"
    assert large < 8 * reference, (f"40,000 rows: {large:.2f} s, {large / reference:.1f} times a path join and "
                                   f"lstat per row ({reference / 40_000 * 1e6:.0f} us)")


def test_the_code_digest_changes_with_any_package_file_but_not_with_caches_or_the_example(tmp_path):
    from pcnet.pipeline.config import code_digest
    (tmp_path / "pkg" / "data").mkdir(parents=True)
    (tmp_path / "pkg" / "run.py").write_text("x = 1\n")
    (tmp_path / "pkg" / "data" / "up_model.json").write_text("{}")
    roots = {"pcnet.pkg": tmp_path / "pkg"}
    first = code_digest(roots)
    # caches, the bundled example, pages, licences and an editor's or a system's hidden files are not code
    for ignored in ("__pycache__/run.cpython-311.pyc", "example_data/X3D.npy", "MODEL_CARD.md", "LICENSE-x.txt",
                    ".run.py.swp", "data/.DS_Store"):
        (tmp_path / "pkg" / ignored).parent.mkdir(exist_ok=True)
        (tmp_path / "pkg" / ignored).write_bytes(b"\0")
    assert code_digest(roots) == first
    (tmp_path / "pkg" / "data" / "up_model.json").write_text('{"sigma": 1}')
    changed = code_digest(roots)
    assert changed != first
    (tmp_path / "pkg" / "data" / "up_model.json").rename(tmp_path / "pkg" / "data" / "up_model2.json")
    assert code_digest(roots) not in (first, changed)
    # a package that is no folder of files (a zip import) has no digest, rather than the empty one
    with pytest.raises(OSError, match="no code files"):
        code_digest({**roots, "pcnet.zipped": tmp_path / "pcnet.zip" / "pcnet" / "models"})


def test_record_status_names_what_changed_and_survives_a_damaged_record(tmp_path, monkeypatch):
    """Why a row's own earlier output is not current, as one phrase; a batch record whose
    settings are not a table is read as unreadable, not a crash (a review)."""
    import pcnet.pipeline.batch_marker as bm

    monkeypatch.setattr(bm, "read_marker", lambda out: {"state": "complete"})
    monkeypatch.setattr(bm, "listed_files_missing", lambda out: [])
    src = tmp_path / "x.npy"
    src.write_bytes(BOX_3D.read_bytes())
    config = {"lifter": "motionbert", "lifter_output": str(src), "method": "pcnet"}
    record = {"writer": "pcnet batch", "pcnet_version": bm.pcnet_version(), "settings": bm.settings_of(config),
              "inputs": bm.input_hashes(config)}
    write = lambda r: (tmp_path / bm.BATCH_MARKER).write_text(json.dumps(r))  # noqa: E731
    write(record)
    assert bm.record_status(tmp_path, config) == (record, "")
    assert bm.record_status(tmp_path, {**config, "method": "geometric"})[1] == \
        "setting method changed since its earlier output"
    write({**record, "settings": ["method"]})
    assert bm.record_status(tmp_path, config) == (None, "its earlier output's settings are unreadable")
    write({**record, "pcnet_version": "0.0"})
    assert bm.record_status(tmp_path, config)[1] == f"pcnet 0.0 -> {bm.pcnet_version()} since its earlier output"
    # The same release with other code (an editable install, a reinstall from a newer checkout)
    # runs again: the version carries a digest of the package's files.
    release, code = bm.pcnet_version().split("+code.")
    write({**record, "pcnet_version": f"{release}+code.000000000000"})
    assert bm.record_status(tmp_path, config)[1] == \
        f"pcnet's code changed since its earlier output (pcnet {release}+code.000000000000 -> {bm.pcnet_version()})"
    assert len(code) == 12 and int(code, 16) >= 0
    # code that cannot be read is never taken for an earlier output's, even where the labels agree
    monkeypatch.setattr(bm, "pcnet_version", lambda: f"{release}+code.unknown")
    write({**record, "pcnet_version": f"{release}+code.unknown"})
    assert bm.record_status(tmp_path, config)[1] == \
        f"pcnet's code cannot be read to compare with its earlier output's (pcnet {release}+code.unknown)"


@pytest.mark.slow
def test_another_manifests_output_is_replaced_only_with_overwrite(tmp_path):
    """A user trial's second manifest named the first's output folder for another recording:
    it replaced the first's result unasked, saying only that a setting changed. Resume runs a
    changed row again over its own manifest's earlier output; another manifest's needs
    --overwrite, and the reason names the inputs named anew as well."""
    first = _manifest(tmp_path, _row("a"))
    assert _invoke(first, "--workers", "1").exit_code == 0
    made = (tmp_path / "a" / "kinematics.csv").read_bytes()
    other_input = tmp_path / "other.npy"
    np.save(other_input, np.load(BOX_3D) * 1.01)
    (tmp_path / "second").mkdir()
    second = _manifest(tmp_path / "second", _row("../a", lifter_output=other_input, method="pcnet"), name="m2.csv")
    res = _invoke(second, "--workers", "1")
    assert res.exit_code == 1, res.output
    assert ("line 2: column out: expected this manifest's own earlier output to run this row again (setting method "
            f"changed since its earlier output; it names another lifter_output), got the output of another manifest's "
            f"row ({first.resolve()}); pass --overwrite") in " ".join(res.output.split()), res.output
    assert (tmp_path / "a" / "kinematics.csv").read_bytes() == made
    res = _invoke(second, "--workers", "1", "--overwrite")
    assert res.exit_code == 0 and _statuses(second) == ["ok"], res.output
    # the first manifest's own row, changed, runs again over what is now the second's output only when told
    assert _invoke(first, "--workers", "1").exit_code == 1


def test_cancelled_rows_that_keep_an_earlier_complete_output_are_counted_and_every_row_has_units(tmp_path):
    """A batch trial's Ctrl-C under --overwrite read "0 of 13 recordings have complete outputs"
    with every earlier output intact, and its cancelled rows lacked the documented units key."""
    from pcnet.pipeline.batch import BatchReport, PlannedRow, _row_summary, format_summary
    from pcnet.pipeline.outdir import _write_marker

    kept, gone = tmp_path / "kept", tmp_path / "gone"
    kept.mkdir()
    (kept / "kinematics.csv").write_text("frame\n0\n")
    _write_marker(kept, "complete")
    rows = [_row_summary(PlannedRow(row=i, line=i + 1, config={"out": str(out)}), None, "cancelled")
            for i, out in enumerate((kept, gone), 1)]
    assert all("units" in r and r["units"] is None for r in rows)
    text = format_summary(BatchReport(rows, True, tmp_path / "s.json", 1.0))
    assert text.splitlines()[:2] == [
        "0 of 2 recordings have complete outputs (0 ok, 0 skipped, 0 failed, 2 cancelled) in 1.0 s; 1 cancelled row "
        "(line 2) still holds an earlier complete output, not this run's",
        "interrupted: no further row started; cancelled rows left their output folders as they were; the same command "
        "runs them"]
    # a failed row (a killed worker) leaves its earlier output too, and was not said to (a batch trial)
    failed = _row_summary(PlannedRow(row=3, line=4, config={"out": str(kept)}), None, "failed")
    text = format_summary(BatchReport([*rows, failed], False, tmp_path / "s.json", 1.0))
    assert text.splitlines()[0].endswith("; 1 cancelled row (line 2) and 1 failed row (line 4) still hold an earlier "
                                         "complete output, not this run's")
    from pcnet.pipeline.batch import _lines_text

    assert _lines_text([3, 7, 9, 12, 15, 20, 21]) == "lines 3, 7, 9, 12, 15 and 2 more"


def test_an_interrupted_overwrite_says_how_to_run_only_the_rows_it_left():
    """After Ctrl-C under ``--overwrite`` the same command would run the finished rows again,
    and a plain one skips the cancelled rows that still hold their earlier output (a user
    trial followed "the same command runs them")."""
    from types import SimpleNamespace

    from pcnet.pipeline.batch import _interrupted_line

    assert _interrupted_line(SimpleNamespace(settings={"overwrite": True})).endswith(
        "--retry-failed --overwrite runs them alone")
    assert _interrupted_line(SimpleNamespace(settings={"overwrite": False})).endswith("the same command runs them")


def test_a_large_batchs_rewrites_leave_the_angles_for_the_final_summary(tmp_path):
    """Each row's angles make it about five times larger: a batch of over 200 rows rewrites its
    summary while it runs without them (10,000 rows took 5.8 s to write with them), and its
    final summary has them; a small batch's every rewrite has them."""
    from pcnet.pipeline.batch import SUMMARY_EVERY_RESULT_ROWS, _SummaryWriter

    def rows(n):
        return [{"row": i, "status": "ok", "angles": {"left_knee_flexion_deg": {"median": 1.0}},
                 "angle_rates": {"left_knee_flexion_deg_per_s": {"min": -1.0, "max": 1.0}}} for i in range(n)]

    path = tmp_path / "s.json"
    for n, finished, kept in ((SUMMARY_EVERY_RESULT_ROWS + 1, False, False), (SUMMARY_EVERY_RESULT_ROWS + 1, True, True),
                              (3, False, True)):
        _SummaryWriter(path, {"writer": "test"}).write(rows(n), force=True, **({"finished": True} if finished else {}))
        written = json.loads(path.read_text())["rows"]
        assert len(written) == n and all(("angles" in r) == ("angle_rates" in r) == kept for r in written), (n, finished)


def test_an_openpose_folder_runs_and_a_change_to_one_of_its_files_runs_the_row_again(tmp_path):
    """OpenPose writes one JSON file per frame (``--write_json``): a bad-input trial's folder
    stopped `pcnet run` at the report's digest ("Is a directory") and was refused by `pcnet
    batch` as "expected an existing file". The folder is one input: its digest covers every file,
    so a changed frame file runs the row again."""
    from pcnet.stages.core.digest import sha256_path

    folder = tmp_path / "op"
    folder.mkdir()
    for entry in json.loads(BOX_2D.read_text()):
        doc = {"version": 1.3, "people": [{"person_id": [-1], "pose_keypoints_2d": entry["keypoints"]}]}
        (folder / f"box_{int(entry['image_id'][:-4]):012d}_keypoints.json").write_text(json.dumps(doc))
    manifest = tmp_path / "m.csv"
    manifest.write_text("lifter,lifter_output,keypoints2d,keypoints2d_format,image_size,fps,out,method,recording\n"
                        f"motionbert,{BOX_3D},{folder},openpose,854x480,30,o,geometric,false\n")
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 0 and _statuses(manifest) == ["ok"], res.output
    digest = sha256_path(folder)
    assert f"| inputs.sha256.keypoints2d | {digest} |" in (tmp_path / "o" / "report.md").read_text()
    assert _invoke(manifest, "--workers", "1").exit_code == 0 and _statuses(manifest) == ["skipped"]
    first = sorted(folder.iterdir())[0]
    first.write_text(first.read_text().replace('"version": 1.3', '"version": 1.4'))
    assert sha256_path(folder, cached=False) != digest
    res = _invoke(manifest, "--workers", "1")
    assert res.exit_code == 0 and _statuses(manifest) == ["ok"], res.output
    assert "input keypoints2d changed" in res.output, res.output


def test_a_row_taking_a_standing_trials_up_runs_again_when_the_trial_changes(tmp_path):
    """A clinic re-filmed a bad standing trial and re-ran its batch: the exercise row that took
    its up (``camera_up_from``) was skipped, its report naming a folder that held another up.
    The trial's canonical.npz is one of the row's inputs now; and a trial written by another row
    of the same manifest is named as such."""
    tadasana, padmasana = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy", FIXTURES / "yoga_Abhay_Padmasana_f200-299.npy"
    trial = tmp_path / "trial.csv"
    trial.write_text(f"lifter,lifter_output,fps,out,plots,recording\nvideopose3d,{tadasana},30,tad,false,false\n")
    exercise = tmp_path / "exercise.csv"
    exercise.write_text("lifter,lifter_output,fps,out,camera_up_from,plots,recording\n"
                        f"videopose3d,{padmasana},30,pad,tad,false,false\n")
    both = tmp_path / "both.csv"
    both.write_text("lifter,lifter_output,fps,out,camera_up_from,plots,recording\n"
                    f"videopose3d,{tadasana},30,tad2,,false,false\nvideopose3d,{padmasana},30,pad2,tad2,false,false\n")
    res = _invoke(both)
    assert res.exit_code == 1 and (f"{both}: line 3: column camera_up_from: line 2 of this manifest writes 'tad2': run "
                                   f"that row in a batch of its own first, then this one") in res.output, res.output
    assert _invoke(trial).exit_code == 0 and _invoke(exercise).exit_code == 0
    assert _statuses(exercise) == ["ok"] and _invoke(exercise).exit_code == 0 and _statuses(exercise) == ["skipped"]
    trial.write_text(trial.read_text().replace(str(tadasana), str(FIXTURES / "yoga_vp3d_Bhumi_Tadasana.npy")))
    assert _invoke(trial, "--overwrite").exit_code == 0
    res = _invoke(exercise)
    assert res.exit_code == 0 and _statuses(exercise) == ["ok"], res.output
    assert "ran again: input camera_up_from changed" in res.output, res.output
    with np.load(tmp_path / "tad" / "canonical.npz", allow_pickle=False) as z:
        up = json.loads(str(z["report"]))["up"]
    with np.load(tmp_path / "pad" / "canonical.npz", allow_pickle=False) as z:
        assert json.loads(str(z["report"]))["up"] == pytest.approx(up)
