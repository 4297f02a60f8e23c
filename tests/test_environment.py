"""Hostile environments: a full disk or inode table, a read-only or immutable folder, too
many open files, very long paths, signals and racing runs. Under each, pcnet prints one line
naming the user's path and what to do, exits 1 (130 for a signal), leaves nothing it created
(parent folders included) and never replaces what it did not write or was not asked to
overwrite (docs/safety.md). Mounts and ``chattr`` need root; those tests skip without it."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES

from pcnet.pipeline.cli import main
from pcnet.pipeline.outdir import MARKER, TMP_TAG, TRASH_TAG, clean_stale, read_marker, staged_output
from pcnet.stages.core.atomic import NAME_MAX, atomic_path, hidden_name
from pcnet.stages.core.errors import InputError

POSES = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"  # VideoPose3D, (100, 17, 3) metres, camera frame
RUN = ("run", "--lifter", "generic", "--fps", "30", "--method", "geometric", "--no-recording")


@pytest.fixture
def user_folder(tmp_path, monkeypatch):
    folder = tmp_path / "work"
    folder.mkdir()
    (folder / "poses.npy").write_bytes(POSES.read_bytes())
    monkeypatch.chdir(folder)
    return folder


def _invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _error_line(res) -> str:
    """The one ``Error:`` line of a refused command (exit 1, no traceback)."""
    assert res.exit_code == 1, (res.exit_code, res.output, res.exception)
    assert isinstance(res.exception, SystemExit), repr(res.exception)
    lines = [ln for ln in res.output.splitlines() if ln.startswith("Error: ")]
    assert len(lines) == 1 and "Traceback" not in res.output, res.output
    return lines[0]


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _complete(out: Path) -> bool:
    info = read_marker(out)
    return info.get("state") == "complete" and all((out / f).is_file() for f in info["files"])


@contextlib.contextmanager
def _mounted(where: Path, *options: str):
    """A tmpfs (or bind) mount at ``where`` for the test; skipped where mounting is not allowed."""
    where.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a small or read-only file system needs root and mount(8)")
    done = subprocess.run(["mount", *options, str(where)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"mount refused here ({done.stderr.strip()})")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


# --- the disk and the file system ------------------------------------------------------------

@pytest.mark.parametrize("limit", ["size=64k", "nr_inodes=3"], ids=["disk full", "inodes full"])
def test_a_full_disk_or_inode_table_is_one_line_naming_out(user_folder, limit):
    """A real ENOSPC from the kernel (not a monkeypatched one): the line names --out, says the
    disk or its inodes are full, never the hidden temporary, and the small disk is left empty."""
    with _mounted(user_folder / "disk", "-t", "tmpfs", "-o", limit, "tmpfs"):
        line = _error_line(_invoke(*RUN, "--lifter-output", "poses.npy", "--out", "disk/run1"))
        assert line.startswith(f"Error: --out {user_folder / 'disk' / 'run1'}: cannot write "), line
        assert "there (No space left on device" in line or "there (a write stopped short" in line, line
        assert "free space there or write elsewhere" in line, line
        assert TMP_TAG not in line
        assert _listing(user_folder / "disk") == []


def test_a_read_only_file_system_is_one_line_and_leaves_nothing(user_folder):
    (user_folder / "shared").mkdir()
    (user_folder / "shared" / "theirs.txt").write_text("theirs")
    with _mounted(user_folder / "ro", "--bind", "-o", "ro", str(user_folder / "shared")):
        line = _error_line(_invoke(*RUN, "--lifter-output", "poses.npy", "--out", "ro/a/b"))
        assert "--out ro/a/b" in line or f"--out {user_folder / 'ro' / 'a' / 'b'}" in line, line
        assert "Read-only file system" in line and "write elsewhere" in line, line
        line = _error_line(_invoke("rectify", "poses.npy", "--method", "geometric", "--out", "ro/r.npz"))
        assert "ro/r.npz" in line, line
    assert _listing(user_folder / "shared") == ["theirs.txt"]


def test_an_immutable_folder_is_one_line_and_keeps_its_files(user_folder):
    folder = user_folder / "locked"
    folder.mkdir()
    (folder / "keep.txt").write_text("keep")
    if os.geteuid() != 0 or shutil.which("chattr") is None:
        pytest.skip("chattr +i needs root and e2fsprogs")
    if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode != 0:
        pytest.skip("this file system has no immutable attribute")
    try:
        line = _error_line(_invoke(*RUN, "--lifter-output", "poses.npy", "--out", "locked/run"))
        assert "locked/run" in line and "Operation not permitted" in line, line
    finally:
        subprocess.run(["chattr", "-i", str(folder)], check=False)
    assert _listing(folder) == ["keep.txt"]


def test_too_many_open_files_is_one_line(user_folder):
    """A run under a small ``ulimit -n``: one line saying to raise the limit, nothing left."""
    import resource

    script = ("import resource, sys; from pcnet.pipeline.entry import main; "
              "import pcnet.pipeline.runner, pcnet.pipeline.cli, onnxruntime, cv2, matplotlib.pyplot; "
              "n = len(__import__('os').listdir('/proc/self/fd')); "
              "resource.setrlimit(resource.RLIMIT_NOFILE, (n + 2, resource.getrlimit(resource.RLIMIT_NOFILE)[1])); "
              "sys.argv = ['pcnet', *sys.argv[1:]]; main()")
    if not Path("/proc/self/fd").is_dir() or resource.getrlimit(resource.RLIMIT_NOFILE)[0] < 64:
        pytest.skip("needs /proc/self/fd to set a limit just above what the imports opened")
    done = subprocess.run([sys.executable, "-c", script, *RUN, "--lifter-output", "poses.npy", "--out", "o"],
                          cwd=user_folder, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Too many open files" in lines[0] and "ulimit -n" in lines[0], done.stderr
    assert _listing(user_folder) == ["poses.npy"]


# --- paths -------------------------------------------------------------------------------------

@pytest.mark.slow
def test_a_name_of_240_characters_is_a_legal_out(user_folder):
    """The hidden staging and trash names of a long --out are shortened to fit 255 bytes, and
    a replacement still finds its own leftovers by them."""
    name = "r" * 240
    assert _invoke(*RUN, "--lifter-output", "poses.npy", "--out", name).exit_code == 0
    assert _complete(user_folder / name)
    assert _invoke(*RUN, "--lifter-output", "poses.npy", "--out", name, "--overwrite").exit_code == 0
    assert _complete(user_folder / name) and _listing(user_folder) == sorted(
        ["poses.npy", name, *(f"{name}/{f}" for f in os.listdir(user_folder / name))])
    # a trash folder of this output left by a killed replacement is put back by the next run
    target = (user_folder / name).resolve()
    trash = target.parent / hidden_name(name, f"{TRASH_TAG}0123456789ab")
    assert len(os.fsencode(trash.name)) <= NAME_MAX
    marker = read_marker(target)
    target.rename(trash)
    (trash / MARKER).write_text(__import__("json").dumps({**marker, "pid": 2**22 + 7}))
    assert clean_stale(target) == [] and _complete(target) and not trash.exists()


def test_hidden_names_fit_and_stay_distinct():
    for name in ("a", "é" * 120, "x" * 255, "x" * 254 + "y"):
        for tail in (".0123456789abcdef0123456789abcdef.tmp", f"{TMP_TAG}0123456789ab"):
            hidden = hidden_name(name, tail)
            assert len(os.fsencode(hidden)) <= NAME_MAX and hidden.endswith(tail) and hidden.startswith(".")
            hidden.encode("utf-8")  # never half a character
    assert hidden_name("x" * 255, ".t") != hidden_name("x" * 254 + "y", ".t")
    assert hidden_name("short", ".t") == ".short.t"


def test_a_4000_character_out_is_one_short_line_and_leaves_no_folder(user_folder):
    deep = "/".join(["d" * 200] * 20)  # every name legal, the whole beyond what the kernel takes with pcnet's files
    line = _error_line(_invoke(*RUN, "--lifter-output", "poses.npy", "--out", deep))
    assert len(line) < 400 and "choose a shorter --out" in line, line
    assert _listing(user_folder) == ["poses.npy"]
    line = _error_line(_invoke(*RUN, "--lifter-output", "poses.npy", "--out", "n" * 300))
    assert "at most 255 bytes" in line and len(line) < 400, line
    assert _listing(user_folder) == ["poses.npy"]


def test_a_failed_run_removes_the_parent_folders_it_created(user_folder):
    """A run into results/2024/out refused mid-way (the input is bad) leaves no results/."""
    np.save(user_folder / "bad.npy", np.full((10, 17, 3), np.nan))
    _error_line(_invoke(*RUN, "--lifter-output", "bad.npy", "--out", "results/2024/out"))
    assert not (user_folder / "results").exists()
    # a parent that exists is the user's: it stays, with what else is in it
    (user_folder / "results").mkdir()
    _error_line(_invoke(*RUN, "--lifter-output", "bad.npy", "--out", "results/2024/out"))
    assert _listing(user_folder / "results") == []


def test_sigterm_into_a_new_nested_out_leaves_no_parent_folders(user_folder):
    proc = subprocess.Popen([sys.executable, "-m", "pcnet.pipeline.cli", "run", "--lifter", "generic",
                             "--lifter-output", "poses.npy", "--fps", "30", "--out", "results/2024/out"],
                            cwd=user_folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and not list(user_folder.glob(f"results/2024/.out{TMP_TAG}*")):
        time.sleep(0.01)  # until it writes its outputs
    assert list(user_folder.glob(f"results/2024/.out{TMP_TAG}*")), "the run never started writing"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert _listing(user_folder) == ["poses.npy"]


# --- racing writers ----------------------------------------------------------------------------

def test_of_two_runs_into_one_new_out_the_later_refuses(user_folder):
    """Run B started before run A finished, neither with --overwrite: B does not replace A's
    output (it did: both exited 0 and A's printed paths held B's files)."""
    with pytest.raises(InputError, match="another run .* made there while this run worked; left as it is"):
        with staged_output(user_folder / "o") as a:  # A starts first
            with staged_output(user_folder / "o") as b:  # B starts later and finishes first
                (b / "from_b.txt").write_text("b")
            (a / "from_a.txt").write_text("a")
    assert sorted(os.listdir(user_folder / "o")) == [MARKER, "from_b.txt"]
    assert not [p for p in user_folder.iterdir() if p.name.startswith(".")]


@pytest.mark.slow
def test_two_real_runs_racing_to_one_out_leave_one_whole_output(user_folder):
    procs = [subprocess.Popen([sys.executable, "-m", "pcnet.pipeline.cli", *RUN, "--lifter-output", "poses.npy",
                               "--out", "o"], cwd=user_folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(2)]
    results = [(p.wait(120), p.stderr.read()) for p in procs]
    assert sorted(code for code, _ in results) == [0, 1], results
    refused = next(err for code, err in results if code == 1)
    assert len(refused.strip().splitlines()) == 1 and "--out" in refused and "Traceback" not in refused, refused
    assert _complete(user_folder / "o")
    assert sorted(p.name for p in user_folder.iterdir()) == ["o", "poses.npy"]


def test_a_file_that_appears_while_pcnet_writes_it_is_kept(tmp_path):
    """`pcnet rectify`/`export`/`evaluate --json` without --overwrite: another run's file that
    appears at the name meanwhile is kept and this call refused; with --overwrite it is replaced."""
    target = tmp_path / "r.npz"
    with pytest.raises(InputError, match="r.npz: expected a new file, got one written there while pcnet worked"):
        with atomic_path(target, replace=False) as tmp:
            tmp.write_bytes(b"mine")
            target.write_bytes(b"theirs")
    assert target.read_bytes() == b"theirs" and sorted(os.listdir(tmp_path)) == ["r.npz"]
    with atomic_path(target, replace=True) as tmp:
        tmp.write_bytes(b"mine")
    assert target.read_bytes() == b"mine"


@pytest.mark.parametrize("error", [MemoryError, RecursionError])
def test_memory_and_recursion_errors_are_one_line(user_folder, monkeypatch, error):
    """The last resort for what slips past the readers' own bounds: one line naming the
    command, exit 1, no output left."""
    import pcnet.pipeline.rectification as rectification

    def exhausted(*args, **kwargs):
        raise error()

    monkeypatch.setattr(rectification, "rectify", exhausted)
    line = _error_line(_invoke("rectify", "poses.npy", "--out", "r.npz"))
    assert line.startswith("Error: pcnet rectify: ") and ("out of memory" in line or "nested too deeply" in line), line
    assert _listing(user_folder) == ["poses.npy"]


def test_a_disk_that_fills_while_the_recording_is_written_is_one_line_and_ends(user_folder):
    """A file-safety trial's disk filled while recording.rrd was written: rerun's writer stopped,
    its flush waited forever, deaf to SIGTERM, until SIGKILL left the temp folder on the full
    disk. The CSVs fit in this 1000 kB tmpfs and the recording does not: one line naming --out,
    exit 1, the disk left empty, within a bound (a subprocess: the run leaves with os._exit)."""
    with _mounted(user_folder / "disk", "-t", "tmpfs", "-o", "size=1000k", "tmpfs"):
        done = subprocess.run([sys.executable, "-m", "pcnet.pipeline.cli", "run", "--lifter", "generic", "--fps", "30",
                               "--method", "geometric", "--no-plots", "--lifter-output", "poses.npy", "--out",
                               "disk/run1"], capture_output=True, text=True, timeout=150)
        lines = [ln for ln in done.stderr.splitlines() if ln.startswith("Error: ")]
        assert done.returncode == 1 and len(lines) == 1 and "Traceback" not in done.stderr, done.stderr[-2000:]
        assert lines[0].startswith(f"Error: --out {user_folder / 'disk' / 'run1'}: cannot write ") and \
            "free space there or write elsewhere" in lines[0], lines[0]
        assert _listing(user_folder / "disk") == []


def test_a_file_name_that_is_not_utf8_is_one_line(user_folder):
    """A Latin-1 file name (bytes that are not UTF-8) as the input or as --out: a file-safety
    trial got a 60-line UnicodeEncodeError traceback from the report's and rerun's writers.
    One line asking to rename it, exit 1, nothing written."""
    latin = b"lat\xe9in"
    (user_folder / os.fsdecode(latin + b".npy")).write_bytes(POSES.read_bytes())
    for source, out in ((latin + b".npy", b"o1"), (b"poses.npy", latin)):
        done = subprocess.run([sys.executable, "-m", "pcnet.pipeline.cli", "run", "--lifter", "videopose3d",
                               "--lifter-output", source, "--fps", "30", "--no-plots", "--no-recording", "--out", out],
                              capture_output=True, timeout=150)
        err = done.stderr.decode("utf-8", "replace")
        lines = [ln for ln in err.splitlines() if ln.startswith("Error: ")]
        assert done.returncode == 1 and len(lines) == 1 and "Traceback" not in err, err[-2000:]
        assert "expected input and output file and folder names in UTF-8" in lines[0] and "rename it" in lines[0]
    assert sorted(os.listdir(os.fsencode(user_folder))) == sorted([latin + b".npy", b"poses.npy"])


def test_rectifying_writes_nothing_into_home(tmp_path):
    """A developer trial found onnxruntime's device id and telemetry queue under
    ~/.cache/Microsoft after one rectify: pcnet opens its sessions with telemetry off
    (ORT_DISABLE_TELEMETRY, unless the user set it), so nothing is written there."""
    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "ORT_DISABLE_TELEMETRY"}
    code = ("import numpy as np; from pcnet.pipeline import rectify; "
            f"rectify(np.load({str(FIXTURES / 'yoga_Abhay_Tadasana_f000-099.npy')!r}))")
    subprocess.run([sys.executable, "-c", code], env={**env, "HOME": str(home)}, check=True, timeout=120)
    assert [p for p in home.rglob("*")] == []


def test_the_pipeline_imports_no_opencv_until_a_video_is_read():
    """An API trial: importing run_pipeline loaded OpenCV (about 1 s), whose wheel also set
    LD_LIBRARY_PATH and Qt variables in the host's environment, for runs without a video."""
    code = "import sys; from pcnet.pipeline import run_pipeline, rectify; print('cv2' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.strip() == "False", out.stdout
