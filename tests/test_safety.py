"""Safety of the commands as a user meets them: nothing the user wrote is ever deleted,
outputs appear whole or not at all (also under SIGKILL / SIGTERM), every bad input ends in
one line and exit 1, and the API and the command line agree on what a valid frame is."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES

from pcnet.pipeline import interrupt
from pcnet.pipeline.cli import main
from pcnet.pipeline.outdir import MARKER, TMP_TAG, TRASH_TAG, read_marker
from pcnet.stages.core.conventions import L_HIP, PELVIS
from pcnet.pipeline.rectification import rectify

POSES = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"  # VideoPose3D, (100, 17, 3) metres, camera frame
VIDEO = FIXTURES / "boxing2_f000-009.mp4"


def _invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _one_line_error(res, *needles: str) -> None:
    """Exit 1 with one 'Error: ...' line naming every needle, and no traceback."""
    assert res.exit_code == 1, (res.exit_code, res.output, res.exception)
    assert isinstance(res.exception, SystemExit), repr(res.exception)  # not an unexpected exception
    errors = [ln for ln in res.output.splitlines() if ln.startswith("Error: ")]
    assert len(errors) == 1 and "Traceback" not in res.output, res.output
    for needle in needles:
        assert needle in errors[0], (needle, errors[0])


@pytest.fixture
def user_folder(tmp_path, monkeypatch):
    """A user's working folder holding their input and a file of their own."""
    folder = tmp_path / "work"
    folder.mkdir()
    (folder / "poses.npy").write_bytes(POSES.read_bytes())
    (folder / "notes.txt").write_text("mine")
    monkeypatch.chdir(folder)
    return folder


def _contents(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


RUN = ("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30", "--method", "geometric",
       "--no-recording")


@pytest.mark.parametrize("out", [".", "sub/..", "..", "./"])
@pytest.mark.parametrize("command", ["demo", "run"])
def test_overwrite_never_empties_the_current_folder_or_its_parents(user_folder, command, out):
    before = _contents(user_folder.parent)
    args = ("demo", "--method", "geometric") if command == "demo" else RUN
    _one_line_error(_invoke(*args, "--out", out, "--overwrite"), f"--out {out}", "current folder")
    assert _contents(user_folder.parent) == before


def test_out_may_not_contain_an_input_or_a_folder_of_the_users(user_folder):
    sub = user_folder / "data"
    sub.mkdir()
    (sub / "poses.npy").write_bytes(POSES.read_bytes())
    args = ["run", "--lifter", "generic", "--lifter-output", "data/poses.npy", "--fps", "30", "--method", "geometric"]
    _one_line_error(_invoke(*args, "--out", "data", "--overwrite"), "input data/poses.npy")
    assert (sub / "poses.npy").read_bytes() == POSES.read_bytes()
    # A folder of the user's (no pcnet marker) is never replaced.
    theirs = user_folder / "results"
    theirs.mkdir()
    (theirs / "figure.png").write_bytes(b"png")
    _one_line_error(_invoke(*RUN, "--out", theirs, "--overwrite"), "did not write", "figure.png")
    assert (theirs / "figure.png").read_bytes() == b"png"


@pytest.mark.slow
def test_overwrite_replaces_a_previous_output_and_refuses_once_the_user_added_a_file(user_folder):
    assert _invoke(*RUN, "--out", "o").exit_code == 0
    marker = read_marker(user_folder / "o")
    assert marker["state"] == "complete" and "canonical.npz" in marker["files"]
    assert sorted(p.name for p in (user_folder / "o").iterdir()) == sorted([*marker["files"], MARKER])
    # a boxing analyst's rerun read "output folder exists", the one line without expected and got
    _one_line_error(_invoke(*RUN, "--out", "o"), "--out o: expected a new folder, got one that exists (a previous "
                    "pcnet output); choose another --out or pass --overwrite")
    res = _invoke(*RUN, "--out", "o", "--overwrite")
    assert res.exit_code == 0, res.output
    # An output the user edited (opened in a spreadsheet and saved) is theirs now.
    with open(user_folder / "o" / "kinematics.csv", "a") as fh:
        fh.write("my note\n")
    _one_line_error(_invoke(*RUN, "--out", "o", "--overwrite"), "kinematics.csv", "changed since")
    assert (user_folder / "o" / "kinematics.csv").read_text().endswith("my note\n")
    (user_folder / "o" / "kinematics.csv").unlink()
    (user_folder / "o" / "my_analysis.xlsx").write_text("mine")
    _one_line_error(_invoke(*RUN, "--out", "o", "--overwrite"), "my_analysis.xlsx")
    assert (user_folder / "o" / "my_analysis.xlsx").read_text() == "mine"
    assert not [p for p in user_folder.iterdir() if p.name.startswith(".")]  # no temp folder left


@pytest.mark.slow
def test_a_copied_output_folder_stays_pcnets_while_an_edit_of_the_same_size_does_not(user_folder):
    """`cp -r`, scp and sync tools give every file a new modification time: the copy is still
    pcnet's output (same bytes), so --overwrite replaces it; an edit that keeps a file's size
    makes it the user's."""
    import shutil

    assert _invoke(*RUN, "--out", "o").exit_code == 0
    shutil.copytree(user_folder / "o", user_folder / "copy")  # copy2: new times for the folder's files
    for path in (user_folder / "copy").iterdir():
        os.utime(path, ns=(path.stat().st_atime_ns, path.stat().st_mtime_ns + 10**9))
    res = _invoke(*RUN, "--out", "copy", "--overwrite")
    assert res.exit_code == 0, res.output
    csv = user_folder / "copy" / "kinematics.csv"
    text = csv.read_text()
    csv.write_text(text[:-2] + ("0" if text[-2] != "0" else "1") + text[-1])  # same size, another byte
    _one_line_error(_invoke(*RUN, "--out", "copy", "--overwrite"), "kinematics.csv", "changed since")


def test_overwrite_of_a_single_output_file_replaces_only_what_pcnet_wrote(user_folder):
    """rectify and evaluate --json write one file: --overwrite replaces their own earlier
    output and refuses a user's file of the same name, untouched (export: the next test)."""
    import numpy as np

    np.savez(user_folder / "theirs.npz", rotation=np.eye(3))
    (user_folder / "theirs.json").write_text('{"results": [1, 2]}')
    before = _contents(user_folder)
    rectify = ("rectify", "poses.npy", "--method", "geometric", "--overwrite", "--out")
    _one_line_error(_invoke(*rectify, "theirs.npz"), "theirs.npz", "did not write")
    evaluate = ("evaluate", "--method", "geometric", "--data", str(FIXTURES / "mocap_small.npz"), "--max-frames", "20",
                "--overwrite", "--json")
    _one_line_error(_invoke(*evaluate, "theirs.json"), "theirs.json", "did not write")
    assert _contents(user_folder) == before
    for args, out in ((rectify, "r.npz"), (evaluate, "e.json")):
        assert _invoke(*args, out).exit_code == 0
        res = _invoke(*args, out)  # its own output is recognised and replaced
        assert res.exit_code == 0, res.output


def test_overwrite_of_an_export_refuses_a_users_file_of_the_same_name(user_folder):
    """`pcnet export` writes the .onnx and its .json: --overwrite refuses a user's file of
    either name, untouched (export needs torch, the [train] extra; the rest of the test above
    runs without it)."""
    pytest.importorskip("torch", reason='pcnet export needs torch (pip install "pcnet[train]")')
    (user_folder / "theirs.json").write_text('{"results": [1, 2]}')
    (user_folder / "model.onnx").write_bytes(b"not ours")
    before = _contents(user_folder)
    _one_line_error(_invoke("export", "--checkpoint", "notes.txt", "--out", "theirs.onnx", "--overwrite"),
                    "theirs.json", "did not write")
    _one_line_error(_invoke("export", "--checkpoint", "notes.txt", "--out", "model.onnx", "--overwrite"),
                    "model.onnx", "did not write")
    # without --overwrite too: not told to pass a flag that would be refused next (an ML trial's
    # mocap sidecar ft.json beside --out ft.onnx)
    _one_line_error(_invoke("export", "--checkpoint", "notes.txt", "--out", "theirs.onnx"),
                    "theirs.json that it did not write; choose another --out")
    assert _contents(user_folder) == before


@pytest.mark.slow
def test_a_killed_opensim_runs_staging_folder_does_not_make_the_output_the_users(user_folder):
    """`pcnet opensim` works in a hidden folder inside the output; one left by a killed run
    (its process gone) is pcnet's, so --overwrite still replaces the output, while one of a
    live process (or of another host sharing the folder) still counts."""
    import socket

    assert _invoke(*RUN, "--out", "o").exit_code == 0
    for live in (f"1@{socket.gethostname()}", "999999999@another-host"):
        staging = user_folder / "o" / f".pcnet-opensim-tmp-{live}-0123456789ab"
        staging.mkdir()
        _one_line_error(_invoke(*RUN, "--out", "o", "--overwrite"), staging.name)
        staging.rmdir()
    killed = user_folder / "o" / f".pcnet-opensim-tmp-999999999@{socket.gethostname()}-0123456789ab"
    killed.mkdir()
    (killed / "scale_frames.trc").write_text("half")
    res = _invoke(*RUN, "--out", "o", "--overwrite")
    assert res.exit_code == 0, res.output
    assert not killed.exists()


def test_a_file_the_user_adds_to_the_old_output_during_an_overwrite_is_kept(user_folder):
    """--overwrite replaces the old output only if it still holds pcnet's files alone when the
    new one is ready: a file added while the run worked is the user's."""
    from pcnet.pipeline.outdir import register_files, staged_output
    from pcnet.stages.core.errors import InputError

    with staged_output("o") as tmp:
        (tmp / "canonical.npz").write_bytes(b"old")
        register_files(tmp, ["canonical.npz"])
    with pytest.raises(InputError, match="my_notes.txt added or changed during the run"):
        with staged_output("o") as tmp:
            (tmp / "canonical.npz").write_bytes(b"new")
            register_files(tmp, ["canonical.npz"])
            (user_folder / "o" / "my_notes.txt").write_text("mine")
    assert (user_folder / "o" / "my_notes.txt").read_text() == "mine"
    assert (user_folder / "o" / "canonical.npz").read_bytes() == b"old"
    assert not [p for p in user_folder.iterdir() if p.name.startswith(".")]  # no temp folder left


def _replace_world_trc(user_folder: Path, monkeypatch) -> list[str]:
    """Replace output ``o`` with a new world.trc under ``--overwrite`` while ``monkeypatch``'s
    patches hold, then undo them; the new file is there; returns what the run said it left."""
    from pcnet.pipeline.outdir import register_files, staged_output

    left: list[str] = []
    with staged_output(user_folder / "o", True, left) as tmp:
        (tmp / "world.trc").write_bytes(b"new")
        register_files(tmp, ["world.trc"])
    monkeypatch.undo()  # the chdir too: paths below are absolute
    assert (user_folder / "o" / "world.trc").read_bytes() == b"new"
    return left


def test_a_file_added_after_the_last_check_of_an_overwrite_is_kept_and_said(user_folder, monkeypatch):
    """A file-safety trial wrote a note into the old output just as a run replacing it ended,
    after its last look for the user's files: the swap renamed the folder aside and deleted it
    whole, the note with it, exit 0 and nothing said (6 of 11 tries). The trash now loses only
    the files its marker lists, unchanged; what else is there stays, unmarked (so no later run
    deletes it), and the run says where."""
    from pcnet.pipeline import outdir
    from pcnet.pipeline.outdir import clean_stale, register_files, staged_output

    with staged_output("o") as tmp:
        (tmp / "world.trc").write_bytes(b"old")
        register_files(tmp, ["world.trc"])
    swap_in = outdir._swap_in

    def note_first(tmp, target, overwrite, given):  # the user's write lands between the check and the swap
        (target / "notes.txt").write_text("mine")
        return swap_in(tmp, target, overwrite, given)

    monkeypatch.setattr(outdir, "_swap_in", note_first)
    left = _replace_world_trc(user_folder, monkeypatch)
    (trash,) = [p for p in user_folder.iterdir() if TRASH_TAG in p.name]
    assert sorted(p.name for p in trash.iterdir()) == ["notes.txt"] and (trash / "notes.txt").read_text() == "mine"
    assert len(left) == 1 and left[0].startswith("notes.txt appeared in --out ") and left[0].endswith(
        f" while this run replaced it: kept, not deleted, in {trash} (hidden, beside it): move them back"), left
    # no marker: the next run of that output leaves it alone
    assert clean_stale(user_folder / "o") == [] and (trash / "notes.txt").read_text() == "mine"
    # an output nobody touched goes whole, marker and folder
    with staged_output(user_folder / "o", True, left) as tmp:
        (tmp / "world.trc").write_bytes(b"newer")
        register_files(tmp, ["world.trc"])
    assert [p for p in user_folder.iterdir() if TRASH_TAG in p.name] == [trash] and len(left) == 1


def test_overwrite_keeps_the_folders_permissions_group_and_extended_attributes(user_folder):
    """A file-safety trial's shared output folder (group-writable, setgid to the team's group)
    came back from --overwrite with the umask's mode and the user's own group: later writes by
    the team failed. The new output takes the old folder's mode, group and extended attributes
    (ACLs are such), and its files the group, as a folder rewritten in place would."""
    from pcnet.pipeline.outdir import register_files, staged_output

    with staged_output("o") as tmp:
        (tmp / "world.trc").write_bytes(b"old")
        register_files(tmp, ["world.trc"])
    out = user_folder / "o"
    group = next((g for g in os.getgroups() if g != os.stat(out).st_gid), None) if os.geteuid() else 12345
    if group is None:
        pytest.skip("needs a second group to give the folder (root, or a user in two groups)")
    os.chown(out, -1, group)
    os.chmod(out, 0o2770)
    try:
        os.setxattr(out, "user.team", b"gait lab")
    except OSError:
        pytest.skip("the file system keeps no user extended attributes")
    with staged_output("o", True) as tmp:
        (tmp / "world.trc").write_bytes(b"new")
        register_files(tmp, ["world.trc"])
    assert (out / "world.trc").read_bytes() == b"new"
    assert oct(os.stat(out).st_mode & 0o7777) == oct(0o2770) and os.stat(out).st_gid == group
    assert os.getxattr(out, "user.team") == b"gait lab" and os.stat(out / "world.trc").st_gid == group
    assert time.time() - os.stat(out).st_mtime < 60  # the new output's own times, not the old folder's


def test_overwrite_keeps_a_private_folders_mode_where_its_group_cannot_be_given(user_folder, monkeypatch):
    """A second file-safety trial: a private 0700 output folder whose group the user is not in
    came back 0755, readable by anyone, because the failed change of group skipped the mode too."""
    from pcnet.pipeline import outdir
    from pcnet.pipeline.outdir import register_files, staged_output

    with staged_output("o") as tmp:
        (tmp / "world.trc").write_bytes(b"old")
        register_files(tmp, ["world.trc"])
    os.chmod(user_folder / "o", 0o700)

    def not_a_member(*args, **kwargs):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(outdir.os, "chown", not_a_member)
    with staged_output("o", True) as tmp:
        (tmp / "world.trc").write_bytes(b"new")
        register_files(tmp, ["world.trc"])
    assert oct(os.stat(user_folder / "o").st_mode & 0o7777) == oct(0o700)


def test_an_interrupt_during_publication_waits_for_it_and_says_the_output_is_whole(user_folder, monkeypatch):
    """A second file-safety trial signalled runs at the instant they published: "nothing
    half-written was left behind" beside the new output, and with --overwrite a trash folder
    left without its marker, which no run removes. The swap and the old output's removal now
    run whole, and the interrupt then says the output is whole (exit 130)."""
    from pcnet.pipeline import outdir

    assert _invoke(*RUN, "--out", "o").exit_code == 0
    swap_in = outdir._swap_in

    def signalled(tmp, target, overwrite, given):  # SIGTERM arrives as the swap starts
        os.kill(os.getpid(), signal.SIGTERM)
        return swap_in(tmp, target, overwrite, given)

    monkeypatch.setattr(outdir, "_swap_in", signalled)
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, *interrupt.STOP_SIGNALS)}
    try:
        res = _invoke(*RUN, "--out", "o", "--overwrite")
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
        interrupt._interrupted.clear()
    assert res.exit_code == 130 and "Traceback" not in res.output, (res.output, res.exception)
    assert re.search(r"^pcnet: interrupted after --out \S*o was written whole$", res.output, re.M), res.output
    assert _complete(user_folder / "o") and not [p for p in user_folder.iterdir() if TRASH_TAG in p.name]


def test_an_out_that_cannot_be_moved_aside_is_one_line_naming_out(user_folder, monkeypatch):
    """--overwrite of an --out that is a mount point: the old output cannot be renamed aside
    (EBUSY), and a user trial got the rename's two paths, one of them pcnet's hidden trash."""
    import errno

    from pcnet.pipeline import outdir
    from pcnet.pipeline.outdir import register_files, staged_output
    from pcnet.stages.core.errors import InputError

    with staged_output("o") as tmp:
        (tmp / "world.trc").write_bytes(b"old")
        register_files(tmp, ["world.trc"])
    marker = (user_folder / "o" / MARKER).read_bytes()
    rename = os.rename

    def busy(src, dst, *args, **kwargs):
        if os.fsdecode(src).endswith("/o") or os.fsdecode(src) == "o":
            raise OSError(errno.EBUSY, "Device or resource busy", os.fsdecode(src), os.fsdecode(dst))
        return rename(src, dst, *args, **kwargs)

    monkeypatch.setattr(outdir.os, "rename", busy)
    with pytest.raises(InputError) as err:
        with staged_output("o", overwrite=True) as tmp:
            (tmp / "world.trc").write_bytes(b"new")
            register_files(tmp, ["world.trc"])
    assert str(err.value) == ("--out o: cannot move the earlier output aside to replace it (Device or resource busy; "
                              "a mount point or a folder in use? write into a new folder inside it, or elsewhere); "
                              "left as it was, and this run's output not written")
    assert (user_folder / "o" / "world.trc").read_bytes() == b"old"
    # its marker too, which claimed it for this run (a second file-safety trial found it rewritten)
    assert (user_folder / "o" / MARKER).read_bytes() == marker
    assert not [p for p in user_folder.iterdir() if p.name.startswith(".")]  # no temp or trash folder left


def test_an_old_output_file_that_cannot_be_removed_is_said(user_folder, monkeypatch):
    """--overwrite swaps the new output in and then deletes the old one; a file of the old one
    that cannot be deleted (a bad-input trial: `chattr +i`) was left in a hidden folder unsaid."""
    from pcnet.pipeline.outdir import register_files, staged_output

    with staged_output("o") as tmp:
        (tmp / "world.trc").write_bytes(b"old")
        register_files(tmp, ["world.trc"])
    unlink = os.unlink

    def refusing(path, *args, **kwargs):
        if os.fsdecode(path).endswith("world.trc"):
            raise PermissionError(1, "Operation not permitted", os.fsdecode(path))
        return unlink(path, *args, **kwargs)

    monkeypatch.setattr(os, "unlink", refusing)
    left = _replace_world_trc(user_folder, monkeypatch)
    trash = [p for p in user_folder.iterdir() if TRASH_TAG in p.name]
    assert len(trash) == 1 and len(left) == 1 and str(trash[0]) in left[0], (trash, left)
    assert "world.trc: Operation not permitted" in left[0], left
    assert f"beside --out {user_folder / 'o'}: remove that folder" in left[0], left


def test_poses_without_pelvis_or_hips_are_refused_naming_them(user_folder):
    X = np.load(POSES)
    X[:, [PELVIS, L_HIP, 1]] = np.nan
    np.save(user_folder / "nohips.npy", X)
    res = _invoke("run", "--lifter", "videopose3d", "--lifter-output", "nohips.npy", "--fps", "30", "--out", "o")
    _one_line_error(res, "nohips.npy", "pelvis or both hips")
    assert "None" not in res.output and not (user_folder / "o").exists()


@pytest.mark.parametrize("option", ["--c3d", "--opensim"])
def test_metric_exports_of_unscaled_poses_are_refused_before_anything_is_written(user_folder, option):
    """Poses in pixels without --height are not metric: the C3D file was silently left out, and
    --opensim failed after a complete output had been written. MotionBERT's poses are never in
    metres, which its registered facts say, so that run is refused before its file is read (a
    study's manifest check let such rows through to fail at once); the generic reader's units
    are known only once its file and options are read."""
    pytest.importorskip("ezc3d" if option == "--c3d" else "opensim", reason="the extra is not installed")
    res = _invoke("run", "--lifter", "motionbert", "--lifter-output", "poses.npy", "--fps", "30", "--no-recording",
                  option, "--out", "o")
    _one_line_error(res, option, "expected metric poses", "lifter motionbert, whose poses are never in metres")
    res = _invoke(*RUN, "--units", "px", option, "--out", "o")
    _one_line_error(res, "poses.npy", option, "expected metric poses", "got px poses")
    assert not (user_folder / "o").exists()


@pytest.mark.parametrize("mode", ["frame", "sequence"])
def test_a_frame_whose_hips_coincide_is_invalid_not_an_error(mode):
    """Two hip columns on one point (a wrong --layout, a lifter's collapse) leave no body
    frame: that frame is invalid; it had stopped the whole run with scipy's 'non-positive
    determinant', or in frame mode given a rank-1 'rotation' marked valid."""
    X = np.load(POSES)
    X[10, L_HIP] = X[10, 1]
    res = rectify(X, "pcnet", mode=mode, fps=30.0)
    assert not res.valid[10] and res.valid.sum() == len(X) - 1
    ok = res.rotation[res.valid]
    np.testing.assert_allclose(np.linalg.det(ok), 1.0, atol=1e-6)


def test_output_folders_follow_the_umask(user_folder):
    old = os.umask(0o022)
    try:
        assert _invoke(*RUN, "--out", "o").exit_code == 0
    finally:
        os.umask(old)
    assert (user_folder / "o").stat().st_mode & 0o777 == 0o755


@pytest.mark.parametrize("field, value", [("overwrite", '"false"'), ("recording", '"false"'), ("fps", '"30"'),
                                          ("height", "true"), ("person", "1.5")])
def test_toml_fields_are_type_checked(user_folder, field, value):
    (user_folder / "o").mkdir()
    (user_folder / "o" / "precious.txt").write_text("mine")
    lines = {"lifter": '"generic"', "lifter_output": '"poses.npy"', "fps": "30", "out": '"o"', field: value}
    (user_folder / "run.toml").write_text("".join(f"{k} = {v}\n" for k, v in lines.items()))
    _one_line_error(_invoke("run", "--config", "run.toml"), "run.toml", f"field {field!r}", "expected")
    assert (user_folder / "o" / "precious.txt").read_text() == "mine"


def _run_cli(folder: Path, *args: str, hangup: object = getattr(signal, "SIG_DFL")) -> subprocess.Popen:
    """``pcnet`` in a process of its own, with SIGHUP's handling ``hangup`` (a terminal's default:
    a test run under nohup would pass its ignore on)."""
    def child() -> None:
        if hasattr(signal, "SIGHUP"):
            signal.signal(signal.SIGHUP, hangup)
    return subprocess.Popen([sys.executable, "-m", "pcnet.pipeline.cli", *args], cwd=folder,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=child)


def _complete(out: Path) -> bool:
    info = read_marker(out)
    return info.get("state") == "complete" and all((out / f).is_file() for f in info["files"])


@pytest.mark.slow
def test_sigkill_during_overwrite_leaves_the_old_or_the_new_output_whole(user_folder):
    """Kill `pcnet run --overwrite` at spread-out instants: `out` is always a complete
    result (or, between the two renames, absent with the old one whole in the trash), and the
    next run removes every leftover."""
    args = [*RUN, "--out", "o", "--overwrite"]
    first = _run_cli(user_folder, *args[:-1])
    assert first.wait(60) == 0, first.stderr.read()
    killed_late = 0
    for delay in (0.2, 0.5, 0.8, 1.0, 1.2, 1.4, 1.7):
        proc = _run_cli(user_folder, *args)
        time.sleep(delay)
        proc.kill()
        proc.wait(30)
        killed_late += proc.returncode == -signal.SIGKILL
        trash = list(user_folder.glob(f".o{TRASH_TAG}*"))
        assert _complete(user_folder / "o") or (not (user_folder / "o").exists() and len(trash) == 1
                                                 and _complete(trash[0]))
    assert killed_late >= 3  # the kills landed while the runs were working
    last = _run_cli(user_folder, *args)
    assert last.wait(60) == 0, last.stderr.read()
    assert _complete(user_folder / "o")
    leftovers = [p.name for p in user_folder.iterdir() if TMP_TAG in p.name or TRASH_TAG in p.name]
    assert leftovers == [], leftovers
    assert (user_folder / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("signum", interrupt.STOP_SIGNALS)
def test_sigterm_is_handled_like_ctrl_c(user_folder, signum):
    """SIGTERM (or a closed terminal's SIGHUP) while the recording is written: exit 130, one
    line, no temp folder, no out."""
    proc = _run_cli(user_folder, "run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30",
                    "--out", "o")
    deadline = time.time() + 60
    while time.time() < deadline and not list(user_folder.glob(f".o{TMP_TAG}*")):
        time.sleep(0.01)  # wait until it is writing its outputs
    assert list(user_folder.glob(f".o{TMP_TAG}*")), "the run never started writing"
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert not (user_folder / "o").exists()
    assert not [p for p in user_folder.iterdir() if p.name.startswith(".")]


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="no SIGHUP on this platform")
def test_a_run_under_nohup_keeps_running_after_a_hang_up(user_folder):
    """``nohup pcnet ...`` ignores SIGHUP so that a run outlives its terminal: pcnet must not
    turn that ignored hang-up into an interrupt."""
    proc = _run_cli(user_folder, "run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30",
                    "--out", "o", hangup=signal.SIG_IGN)
    deadline = time.time() + 60
    while time.time() < deadline and not list(user_folder.glob(f".o{TMP_TAG}*")):
        time.sleep(0.01)
    proc.send_signal(signal.SIGHUP)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert _complete(user_folder / "o")


def test_an_interrupt_after_the_output_is_published_says_it_is_whole(user_folder, monkeypatch):
    """SIGTERM in the moment after a run published its output, while the summary was made, read
    "interrupted; nothing half-written was left behind" with exit 130 (a file-safety trial):
    the output is whole, and the line says so."""
    from pcnet.pipeline.runner import RunResult

    def interrupted(self, *args, **kwargs):
        raise KeyboardInterrupt("signal 15")

    monkeypatch.setattr(RunResult, "summary", interrupted)
    res = _invoke(*RUN, "--out", "o")
    assert res.exit_code == 130 and "Traceback" not in res.output, res.output
    assert "pcnet: interrupted after --out o was written whole (its report.md holds the summary)" in res.output
    assert _complete(user_folder / "o") and (user_folder / "o" / "report.md").is_file()


def test_an_interrupt_after_rectify_wrote_its_archive_says_it_is_whole(user_folder, monkeypatch):
    """pcnet rectify interrupted while printing its summary said "nothing half-written was
    left behind" beside its complete .npz (a second file-safety trial)."""
    from pcnet.stages import flags

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt("signal 15")

    monkeypatch.setattr(flags, "with_looking", interrupted)
    res = _invoke("rectify", "poses.npy", "--out", "r.npz", "--method", "geometric")
    assert res.exit_code == 130 and "pcnet: interrupted after r.npz was written whole" in res.output, res.output
    with np.load(user_folder / "r.npz", allow_pickle=False) as archive:
        assert archive["rotation"].shape == (100, 3, 3)


def test_an_interrupt_inside_an_extension_import_is_still_an_interrupt(user_folder, monkeypatch):
    """SIGTERM during onnxruntime's import came out as its "ImportError: initialization
    failed" (caused by the KeyboardInterrupt): exit 130 and one line, like any interrupt."""
    from pcnet.pipeline import runner

    def interrupted_import(cfg, **options):
        try:
            raise KeyboardInterrupt("signal 15")
        except KeyboardInterrupt as stop:
            raise ImportError("initialization failed") from stop

    monkeypatch.setattr(runner, "run_pipeline", interrupted_import)
    res = _invoke(*RUN, "--out", "o")
    assert res.exit_code == 130 and "interrupted" in res.output and "Traceback" not in res.output, res.output
    monkeypatch.setattr(runner, "run_pipeline", lambda cfg, **options: (_ for _ in ()).throw(ImportError("a real import bug")))
    assert isinstance(_invoke(*RUN, "--out", "o").exception, ImportError)  # a bug keeps its traceback


def test_stale_temp_folders_of_killed_runs_are_removed_but_nothing_else(user_folder):
    stale = user_folder / f".o{TMP_TAG}0123456789ab"
    stale.mkdir()
    (stale / MARKER).write_text(json.dumps({"writer": "pcnet", "state": "writing", "pid": 2**22 + 7,
                                            "host": os.uname().nodename, "files": []}))
    (stale / "canonical.npz").write_bytes(b"x" * 1000)
    lookalike = user_folder / f".o{TMP_TAG}users"  # no pcnet marker: not ours
    lookalike.mkdir()
    (lookalike / "thesis.tex").write_text("mine")
    assert _invoke(*RUN, "--out", "o").exit_code == 0
    assert not stale.exists()
    assert (lookalike / "thesis.tex").read_text() == "mine"


@pytest.mark.slow
def test_a_replacement_killed_between_its_renames_is_kept_by_other_runs_and_restored_by_its_own(user_folder):
    """`--overwrite` into X killed after X became trash and before the new output took its
    name: a later run into Y in the same folder leaves X's only copy alone (it had deleted it);
    the next run into X renames it back; a name that only contains the tag is not a leftover."""
    assert _invoke(*RUN, "--out", "X").exit_code == 0
    old = sorted(p.name for p in (user_folder / "X").iterdir())
    trash = user_folder / f".X{TRASH_TAG}0123456789ab"
    (user_folder / "X").rename(trash)
    marker = json.loads((trash / MARKER).read_text())
    (trash / MARKER).write_text(json.dumps({**marker, "pid": 2**22 + 7}))  # its run is dead
    lookalike = user_folder / f".Y{TRASH_TAG}0123456789ab-copy"  # not a name pcnet makes
    lookalike.mkdir()
    (lookalike / MARKER).write_text(json.dumps({**marker, "pid": 2**22 + 7}))
    assert _invoke(*RUN, "--out", "Y").exit_code == 0
    assert trash.is_dir() and lookalike.is_dir() and not (user_folder / "X").exists()
    before = (trash / "canonical.npz").read_bytes()
    res = _invoke(*RUN, "--out", "X")  # no --overwrite: the old output comes back and is kept
    assert res.exit_code == 1 and "killed while replacing it, now put back there; pass --overwrite" in res.output
    assert (user_folder / "X" / "canonical.npz").read_bytes() == before and not trash.exists()
    (user_folder / "X").rename(trash)
    assert _invoke(*RUN, "--out", "X", "--overwrite").exit_code == 0
    assert sorted(p.name for p in (user_folder / "X").iterdir()) == old and not trash.exists()


def test_a_killed_replacement_of_an_output_named_with_a_newline_is_restored(user_folder):
    """Leftover names are matched whole, a newline in the output's name included."""
    from pcnet.pipeline.outdir import clean_stale

    target = user_folder / "a\nb"
    trash = user_folder / f".a\nb{TRASH_TAG}0123456789ab"
    trash.mkdir()
    (trash / MARKER).write_text(json.dumps({"writer": "pcnet", "state": "complete", "pid": 2**22 + 7,
                                            "host": os.uname().nodename, "files": []}))
    assert clean_stale(target) == [] and target.is_dir() and not trash.exists()


def test_a_symlink_loop_as_input_or_output_is_one_line(user_folder):
    odd = user_folder / "it's"  # a quote in the path: named as it is, not as Python quotes it
    odd.mkdir()
    (odd / "loopA").symlink_to("loopB")
    (odd / "loopB").symlink_to("loopA")
    for args in (("run", "--lifter", "generic", "--lifter-output", "it's/loopA", "--fps", "30", "--no-recording",
                  "--out", "o"), (*RUN, "--out", "it's/loopA"), ("rectify", "poses.npy", "--out", "it's/loopA")):
        res = _invoke(*args)
        assert res.exit_code == 1 and "Traceback" not in res.output, res.output
        assert f"Error: {odd / 'loopA'}: expected a file or folder, got a symlink loop" in res.output, res.output
    assert not (user_folder / "o").exists()


def test_a_full_disk_is_one_line_and_leaves_no_output(user_folder):
    """A real run that fails writing an export the way numpy does on a full disk (OSError
    without a file name, ``ulimit -f`` gives EFBIG alike): one line saying why, exit 1, and the
    output folder not published."""
    import errno

    from pcnet.stages.sinks import result

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(result, "write_trc", full)
        res = _invoke(*RUN, "--out", "o")
    assert res.exit_code == 1 and "Traceback" not in res.output, res.output
    assert f"--out {user_folder / 'o'}: cannot write the outputs there (No space left on device; the disk, its " \
           f"inodes or your quota are full: free space there or write elsewhere); left as it was" in res.output, \
        res.output
    assert not (user_folder / "o").exists()
    assert not [p for p in user_folder.iterdir() if TMP_TAG in p.name]


def test_an_output_where_pcnet_cannot_write_is_refused_before_any_work(user_folder, monkeypatch):
    """An API trial running as another user computed the whole run before the staging folder
    met a read-only parent. The nearest existing folder above --out is checked first
    (``access(2)``: as root only a read-only file system fails it, so the test denies it)."""
    import pcnet.pipeline.runner as runner

    import errno
    import tempfile

    (user_folder / "locked").mkdir()
    access, mkdtemp = os.access, tempfile.mkdtemp
    monkeypatch.setattr(os, "access", lambda path, mode, **kw: Path(path) != user_folder / "locked" and access(path, mode))

    def denied(*args, dir=None, **kwargs):
        if Path(dir) == user_folder / "locked":
            raise PermissionError(errno.EACCES, "Permission denied", str(dir))
        return mkdtemp(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkdtemp", denied)
    real_adapter = runner.get_3d_adapter
    monkeypatch.setattr(runner, "get_3d_adapter", lambda *a, **kw: pytest.fail("read the input before refusing"))
    for out in ("locked/run1", "locked/new/run1"):
        _one_line_error(_invoke(*RUN, "--out", out),
                        f"--out {out}: expected a place pcnet can write in, got {user_folder / 'locked'} "
                        f"(Permission denied; ", "); choose another --out")
    assert sorted(p.name for p in (user_folder / "locked").iterdir()) == []
    # where access(2) says no but the folder takes a new entry after all (an ACL it cannot read), the run goes on
    monkeypatch.setattr(tempfile, "mkdtemp", mkdtemp)
    monkeypatch.setattr(runner, "get_3d_adapter", real_adapter)
    assert _invoke(*RUN, "--out", "locked/run1").exit_code == 0
    assert sorted(p.name for p in (user_folder / "locked").iterdir()) == ["run1"]


def test_an_output_under_a_file_names_that_file(user_folder):
    (user_folder / "notes.txt").write_text("mine")
    res = _invoke(*RUN, "--out", "notes.txt/run1")
    assert res.exit_code == 1 and "Traceback" not in res.output, res.output
    assert f"run1: cannot create the output folder there ({user_folder / 'notes.txt'} is a file, not a folder)" \
        in res.output
    assert (user_folder / "notes.txt").read_text() == "mine"
    # the file itself as --out: pcnet's line with the way out, not click's "Directory 'notes.txt' is a file." (a
    # coach's trial), with or without --overwrite, for run and demo; the file is left as it was
    for args in (RUN, (*RUN, "--overwrite"), ("demo", "--method", "geometric")):
        _one_line_error(_invoke(*args, "--out", "notes.txt"),
                        "--out notes.txt: expected a folder for pcnet's outputs, got an existing file; choose another --out")
    assert (user_folder / "notes.txt").read_text() == "mine"


@pytest.mark.slow
def test_two_runs_in_threads_of_one_process_keep_each_others_staging(user_folder):
    """The Python API from two threads, outputs side by side: a run's clean-up of killed runs'
    leftovers must not take the other thread's live staging folder for one (it carries the
    same process id); both finish with the same results as alone."""
    from concurrent.futures import ThreadPoolExecutor

    from pcnet.pipeline.config import RunConfig
    from pcnet.pipeline.outdir import staged_output
    from pcnet.pipeline.runner import run_pipeline

    def run(out):
        cfg = RunConfig(lifter="generic", lifter_output=str(user_folder / "poses.npy"), fps=30.0, method="geometric",
                        recording=False, out=str(user_folder / out))
        return run_pipeline(cfg.validate(), progress=False).frames

    with staged_output(user_folder / "held") as live:  # a live staging folder of this process
        assert run("alone") > 0 and live.is_dir()
        with ThreadPoolExecutor(2) as pool:
            assert len(set(pool.map(run, ["a", "b", "c", "d"]))) == 1
        assert live.is_dir()
    for out in ("a", "b", "c", "d"):
        assert (user_folder / out / "canonical.npz").is_file()


def test_a_live_replacement_in_another_thread_keeps_its_trash(user_folder, monkeypatch):
    """Between the two renames of a replacement, the old output is a trash folder marked with
    this process's id: another thread's clean-up of the same output must leave it (taken back,
    the replacement's second rename would fail and its new output be lost)."""
    from pcnet.pipeline import outdir

    out = user_folder / "X"
    with outdir.staged_output(out) as tmp:
        (tmp / "first.txt").write_text("1")
    seen = []
    real_rename = os.rename

    def rename(src, dst):
        if TRASH_TAG in Path(dst).name:  # the old output has just become trash
            real_rename(src, dst)
            seen.append(outdir.clean_stale(out))  # as another thread's run into X would, now
            return
        real_rename(src, dst)

    monkeypatch.setattr(outdir.os, "rename", rename)
    with outdir.staged_output(out, overwrite=True) as tmp:
        (tmp / "second.txt").write_text("2")
    assert seen == [[]] and (out / "second.txt").is_file() and not (out / "first.txt").exists()
    assert not [p for p in user_folder.iterdir() if TRASH_TAG in p.name]


def _poses_with_gaps(folder: Path) -> Path:
    X = np.load(POSES).astype(np.float32)
    X[5:10, PELVIS] = np.nan  # pelvis missing, hips present: pelvis = hip midpoint
    X[20:23, PELVIS] = np.nan
    X[20:23, L_HIP] = np.nan  # pelvis and a hip missing: invalid everywhere
    X[30, 3, 0] = np.inf  # non-finite = missing, never exported as inf
    path = folder / "gaps.npy"
    np.save(path, X)
    return path


def test_api_and_command_line_agree_on_valid_frames(user_folder):
    path = _poses_with_gaps(user_folder)
    api = rectify(np.load(path), "geometric")
    assert api.valid[5:10].all() and np.isfinite(api.canonical[5:10]).all()
    assert not api.valid[20:23].any()
    assert api.report.pelvis_from_hips_frames == 5
    res = _invoke("run", "--lifter", "generic", "--lifter-output", path, "--fps", "30", "--method", "geometric",
                  "--no-recording", "--out", "o")
    assert res.exit_code == 0, res.output
    assert "pelvis missing in 5 frames" in res.output
    with np.load(user_folder / "o" / "canonical.npz") as npz:
        np.testing.assert_array_equal(npz["valid"], api.valid)
        assert not np.isinf(npz["canonical"]).any() and not np.isinf(npz["joints_camera"]).any()
    (trc,) = (user_folder / "o").glob("*.trc")  # world.trc (static camera) or canonical.trc
    text = trc.read_text() + (user_folder / "o" / "kinematics.csv").read_text()
    assert "inf" not in text.lower()
    res = _invoke("rectify", path, "--out", "r.npz", "--method", "geometric")
    assert res.exit_code == 0, res.output
    with np.load(user_folder / "r.npz") as npz:
        np.testing.assert_array_equal(npz["valid"], api.valid)


@pytest.mark.parametrize("bad, needles", [
    (lambda X: X.astype(bool), ["dtype bool"]),
    (lambda X: X.astype(np.complex64), ["dtype complex64"]),
    (lambda X: X.astype(str), ["dtype <U"]),
    (lambda X: X[:0], ["at least one frame"]),
    (lambda X: np.full_like(X, np.nan), ["finite"]),
    (lambda X: np.where(np.arange(100)[:, None, None] == 42, 1e30, X), ["frame 42", "pelvis", "1e+30"]),
])
def test_rectify_api_and_cli_refuse_the_same_arrays(user_folder, bad, needles):
    X = bad(np.load(POSES))
    with pytest.raises(ValueError) as err:
        rectify(X, "geometric")
    for needle in needles:
        assert needle in str(err.value)
    np.save(user_folder / "bad.npy", X)
    _one_line_error(_invoke("rectify", "bad.npy", "--out", "r.npz", "--method", "geometric"), "bad.npy", *needles)
    assert not (user_folder / "r.npz").exists()


def test_rectify_given_a_path_or_none_says_it_takes_an_array():
    """An API trial passed a file's path and None, and was told "got dtype object"."""
    for given, got in ((POSES, f"a path ('{POSES}')"), (str(POSES), f"a path ('{POSES}')"), (None, "None")):
        with pytest.raises(ValueError, match=r"^joints_cam: expected an array of joint coordinates \(T, 17, 3\), got "
                                             + re.escape(got) + r"; load it first \(np\.load for such an array; "
                                             r"run_pipeline reads a lifter's own file\)$"):
            rectify(given, "geometric")


@pytest.mark.slow
def test_fps_must_match_the_video_unless_overridden(user_folder):
    args = ["run", "--video", VIDEO, "--lifter", "generic", "--lifter-output", "short.npy", "--method", "geometric",
            "--no-recording"]
    np.save(user_folder / "short.npy", np.load(POSES)[:10])
    _one_line_error(_invoke(*args, "--fps", "60", "--out", "o"), "--fps 60", "--fps-override")
    assert not (user_folder / "o").exists()
    res = _invoke(*args, "--fps", "60", "--fps-override", "--out", "o")
    assert res.exit_code == 0, res.output
    with np.load(user_folder / "o" / "canonical.npz") as npz:
        assert float(npz["fps"]) == 60.0


@pytest.mark.parametrize("args, needles", [
    (("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "0", "--out", "o"), ["fps", "got 0.0"]),
    (("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30", "--height", "1e38", "--out", "o"),
     ["height", "1e+38"]),
    (("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--out", "o"), ["fps"]),
    (("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30", "--weights", "notes.txt",
      "--out", "o"), ["notes.txt"]),
    (("run", "--lifter", "generic", "--lifter-output", "nothere.npy", "--fps", "30", "--out", "o"), ["nothere.npy"]),
    (("rectify", "poses.npy", "--out", "nodir/x.npz"), ["nodir"]),
    (("rectify", "poses.npy", "--out", "notes.txt/x.npz"), ["notes.txt"]),
    (("rectify", "poses.npy", "--out", "poses.npy"), ["the input poses.npy itself"]),
    (("rectify", "poses.npy", "--out", "r.npy"), ["--out r.npy", "ending in .npz", "got .npy"]),
    (("rectify", "poses.npy", "--out", "r.npz", "--key", "joints"), ["--key", "single-array"]),
    (("rectify", "nohips.npy", "--out", "r.npz"), ["nohips.npy", "hips"]),
    (("run", "--lifter", "videopose3d", "--lifter-output", "poses.npy", "--fps", "30", "--weights", "notes.txt",
      "--out", "o"), ["Error: notes.txt: not an ONNX model"]),
    (("rectify", ".", "--out", "r.npz"), ["."]),
    (("evaluate", "--method", "geometric", "--data", str(FIXTURES / "mocap_small.npz"), "--weights", "notes.txt"),
     ["--weights", "geometric"]),
    (("evaluate", "--method", "geometric", "--data", str(FIXTURES / "mocap_small.npz"), "--json", "notes.txt"),
     ["notes.txt", "--overwrite"]),
    (("export", "--checkpoint", "notes.txt", "--out", "notes.txt"), ["input notes.txt itself"]),
    (("evaluate", "--method", "geometric", "--data", str(FIXTURES / "mocap_small.npz"), "--seed", "-1"), ["--seed"]),
    (("batch", "m.csv", "--workers", "0"), ["--workers"]),
    (("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30", "--person", "1", "--out", "o"),
     ["person"]),
    (("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30", "--method", "geometric",
      "--weights", "notes.txt", "--out", "o"), ["weights", "geometric"]),
    (("run", "--lifter", "mediapipe", "--lifter-output", str(FIXTURES / "mediapipe_blazepose33_f000-059.npz"),
      "--fps", "60", "--out", "o"), ["--fps 60", "30 fps", "--fps-override"]),
    (("rectify", "poses.npy", "--out", "notes.txt"), ["notes.txt", "--overwrite"]),
    (("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30", "--height", "2.8", "--opensim",
      "--out", "o"), ["--height", "[0.5, 2.5]", "OpenSim"]),
    (("run", "--lifter", "generic", "--lifter-output", "poses.npy", "--fps", "30", "--hypothesis", "²", "--out", "o"),
     ["hypothesis"]),
    (("rectify", "poses.npy", "--out", "r.npz", "--fps", "1e12", "--mode", "smooth"), ["fps", "1e+12"]),
    (("evaluate", "--method", "geometric", "--data", str(FIXTURES / "mocap_small.npz"), "--json", "nodir/x.json"),
     ["--json", "nodir"]),
])
def test_bad_options_end_in_one_line(user_folder, args, needles):
    if args[0] == "export":  # pcnet export checks its torch first (test_training_and_export_without_torch_...)
        pytest.importorskip("torch", reason='pcnet export needs torch (pip install "pcnet[train]")')
    X = np.load(POSES)
    X[:, [1, 4]] = np.nan  # no hips: no frame can be rectified
    np.save(user_folder / "nohips.npy", X)
    before = _contents(user_folder)
    _one_line_error(_invoke(*args), *needles)
    assert _contents(user_folder) == before


def test_lifter_options_are_type_checked_against_the_adapter(user_folder):
    (user_folder / "run.toml").write_text(f'lifter = "motionbert"\nlifter_output = "{FIXTURES / "boxing_X3D_f000-059.npy"}"'
                                          '\nfps = 30\nout = "o"\n[lifter_options]\npixel = "yes"\n')
    _one_line_error(_invoke("run", "--config", "run.toml"), "pixel", "expected bool", "'yes'")
    (user_folder / "m.csv").write_text("lifter,lifter_output,fps,lifter_options\ngeneric,poses.npy,30,x\n")
    _one_line_error(_invoke("batch", "m.csv"), "m.csv", "line 1", "unknown columns ['lifter_options']",
                    "a manifest gives each as a column of its own")


def test_a_flag_given_with_a_config_is_named_as_the_flag(user_folder):
    (user_folder / "run.toml").write_text(f'lifter = "motionbert"\nlifter_output = "{FIXTURES / "boxing_X3D_f000-059.npy"}"'
                                          '\nfps = 30\nout = "o"\n')
    # (--focal-px, this test's flag before, is a run option for every lifter since focal_px became the camera's)
    _one_line_error(_invoke("run", "--config", "run.toml", "--layout", "coco17"),
                    "--layout: expected only the options --lifter motionbert takes")
    assert not (user_folder / "o").exists()


def test_unknown_lifter_options_in_toml_end_in_one_line(user_folder):
    (user_folder / "run.toml").write_text('lifter = "generic"\nlifter_output = "poses.npy"\nfps = 30\n'
                                          'out = "o"\n[lifter_options]\nfoo = 1\n')
    _one_line_error(_invoke("run", "--config", "run.toml"), "foo")
    assert not (user_folder / "o").exists()


@pytest.mark.parametrize("content, needle", [(b"", "empty"), (b"\x00\xff\xfe\x89PNG\x00" * 20, "binary"),
                                             (b"lifter,lifter_output,fps,out\ngeneric,poses.npy,30,a\ngeneric,poses.npy,30,a\n",
                                              "line 3"),
                                             (b"lifter,out\ngeneric,o\n", "lifter_output"),
                                             (b"lifter,lifter_output,out\n", "at least one row"),
                                             (b"lifter,out\ngeneric,o,extra,cells\n", "line 2")])
def test_bad_batch_manifests_end_in_one_line(user_folder, content, needle):
    (user_folder / "m.csv").write_bytes(content)
    _one_line_error(_invoke("batch", "m.csv"), "m.csv", needle)


def test_unexpected_errors_keep_their_traceback(user_folder, monkeypatch):
    """The error boundary turns only expected errors into one line: a bug stays visible."""
    import pcnet.pipeline.runner as runner

    def broken(*_args, **_kwargs):
        raise RuntimeError("a bug")

    monkeypatch.setattr(runner, "kinematics_chunks", broken)
    res = _invoke(*RUN, "--out", "o")
    assert isinstance(res.exception, RuntimeError)
    assert not (user_folder / "o").exists()


@pytest.mark.slow
def test_inputs_that_carry_their_frame_rate_need_no_fps(user_folder):
    """A MediaPipe npz stores its fps: `pcnet run` takes it from there."""
    res = _invoke("run", "--lifter", "mediapipe", "--lifter-output", FIXTURES / "mediapipe_blazepose33_f000-059.npz",
                  "--method", "geometric", "--no-recording", "--out", "o")
    assert res.exit_code == 0, res.output
    with np.load(user_folder / "o" / "canonical.npz") as npz, np.load(FIXTURES / "mediapipe_blazepose33_f000-059.npz") as mp:
        assert float(npz["fps"]) == float(mp["fps"])


def test_ctrl_c_while_click_parses_the_arguments_is_exit_130(user_folder, monkeypatch, capsys):
    """An interrupt that lands while click parses the command line (outside any command's
    body, where click itself would print "Aborted!" and exit 1) still ends in one line and
    exit 130. Deterministic counterpart of the timed subprocess test below."""
    from pcnet.pipeline import entry

    def interrupted_parse(*args, **kwargs):
        entry.raise_interrupt(signal.SIGINT, None)

    monkeypatch.setattr(main, "make_context", interrupted_parse)
    monkeypatch.setattr(sys, "argv", ["pcnet", *RUN, "--out", "o"])
    monkeypatch.setattr(sys, "unraisablehook", sys.unraisablehook)  # entry.main replaces it
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, *interrupt.STOP_SIGNALS)}
    try:
        with pytest.raises(SystemExit) as stop:
            entry.main()
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
        interrupt._interrupted.clear()
    err = capsys.readouterr().err
    assert stop.value.code == 130
    assert err.strip() == "pcnet: interrupted; nothing half-written was left behind"
    assert not (user_folder / "o").exists()


def test_an_interrupt_a_library_turns_into_another_error_is_still_exit_130(user_folder, monkeypatch):
    """numpy's fromfile, interrupted inside its isinstance check of the file object, drops the
    KeyboardInterrupt and raises "TypeError: expected str, bytes or os.PathLike" (a SIGTERM in
    CI ended in that traceback and exit 1). Once an interrupt arrived, whatever unwinds is that
    interrupt: one line, exit 130, no output. Without one, the same TypeError stays a bug with
    its traceback. Deterministic counterpart of test_sigterm_is_handled_like_ctrl_c."""

    def interrupted_fromfile(*args, **kwargs):
        try:
            interrupt.raise_interrupt(signal.SIGTERM, None)
        except KeyboardInterrupt:
            pass  # what numpy does with it
        raise TypeError("expected str, bytes or os.PathLike object, not BufferedRandom")

    monkeypatch.setattr(np, "fromfile", interrupted_fromfile)
    try:
        res = _invoke(*RUN, "--out", "o")
    finally:
        interrupt._interrupted.clear()
    assert res.exit_code == 130, (res.output, res.exception)
    assert res.output.strip() == "pcnet: interrupted; nothing half-written was left behind"
    assert not (user_folder / "o").exists()
    assert [p.name for p in user_folder.iterdir() if TMP_TAG in p.name] == []

    monkeypatch.setattr(np, "fromfile", lambda *a, **k: (_ for _ in ()).throw(TypeError("a bug")))
    res = _invoke(*RUN, "--out", "o")
    assert isinstance(res.exception, TypeError) and res.exit_code == 1


def test_the_command_line_installs_the_quiet_hook_once(monkeypatch):
    """`python -m pcnet.pipeline.cli` (what the timed signal tests run) had the signal handlers
    but not the entry point's quiet hook: a fresh clone's SIGHUP landing in an import lock's
    callback printed "Exception ignored ... Traceback". The group installs it, once however many
    commands run in one process."""
    from pcnet.pipeline.cli import main

    monkeypatch.setattr(sys, "unraisablehook", sys.__unraisablehook__)
    assert CliRunner().invoke(main, ["docs"]).exit_code == 0
    installed = sys.unraisablehook
    assert getattr(installed, "quiet_interrupts", False)
    assert CliRunner().invoke(main, ["docs"]).exit_code == 0 and sys.unraisablehook is installed


def test_an_interrupt_python_cannot_raise_prints_no_traceback():
    """A Ctrl-C that lands in a weakref callback (importlib's module-lock clean-up while the
    command line imports its libraries, seen in CI) is dropped quietly, not printed as
    "Exception ignored in ... Traceback"; other unraisable errors still reach the default hook.
    Deterministic counterpart of the timed subprocess test below."""
    import weakref

    from pcnet.pipeline.interrupt import quiet_interrupt_hook

    seen = []
    hook = quiet_interrupt_hook(seen.append)

    class Target:
        pass

    for error in (KeyboardInterrupt, ValueError):
        def callback(_, error=error):
            raise error("in a callback")
        target = Target()
        ref = weakref.ref(target, callback)
        previous, sys.unraisablehook = sys.unraisablehook, hook
        try:
            del target
        finally:
            sys.unraisablehook = previous
        del ref
    assert [type(item.exc_value) for item in seen] == [ValueError]  # the interrupt dropped, the error passed on


def test_a_batch_worker_stopped_inside_an_import_exits_without_a_traceback(monkeypatch):
    """The engine's SIGTERM can land while a fresh worker imports OpenCV or numpy, which report
    it as their own ImportError (a timed Ctrl-C trial printed the worker's traceback): the
    worker ends quietly. An ImportError with no interrupt behind it is still raised."""
    from pcnet.pipeline import batch_local

    def interrupted_import(threads):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as stop:
            raise ImportError("initialization failed") from stop

    monkeypatch.setattr(sys, "unraisablehook", sys.unraisablehook)  # the worker replaces it
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, *interrupt.STOP_SIGNALS)}
    try:
        monkeypatch.setattr(batch_local, "set_opencv_threads", interrupted_import)
        assert batch_local._worker_main(None, 1) is None
        monkeypatch.setattr(batch_local, "set_opencv_threads", lambda threads: __import__("no_such_module_pcnet"))
        with pytest.raises(ImportError):
            batch_local._worker_main(None, 1)
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


def _wait_for_pcnet_handlers(pid: int, timeout: float = 60.0) -> None:
    """Until the process catches SIGTERM, which Python itself never does: pcnet's entry point
    has then installed its handlers (Linux ``/proc/PID/status`` ``SigCgt`` mask; elsewhere a
    fixed 0.5 s)."""
    status = Path(f"/proc/{pid}/status")
    if not status.exists():
        time.sleep(0.5)
        return
    bit = 1 << (signal.SIGTERM - 1)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        caught = [line.split()[1] for line in status.read_text().splitlines() if line.startswith("SigCgt:")]
        if caught and int(caught[0], 16) & bit:
            return
        time.sleep(0.002)
    raise AssertionError(f"pcnet did not install its signal handlers within {timeout} s")


@pytest.mark.parametrize("delay", [0.0, 0.4])
def test_ctrl_c_while_starting_is_one_line(user_folder, delay):
    """Ctrl-C while the command line is still importing its libraries (about 1 s after the
    entry point starts): exit 130, no traceback, nothing written. The signal is sent
    ``delay`` s after the entry point installed its handling (the interpreter's own start-up,
    before any pcnet code runs, is outside pcnet's reach, and a fixed delay from launch
    landed there on a cold start)."""
    command = Path(sys.executable).with_name("pcnet")  # the console script users run
    proc = subprocess.Popen([str(command), *RUN, "--out", "o"], cwd=user_folder,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_pcnet_handlers(proc.pid)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert "Traceback" not in err, err
    assert proc.returncode in (130, 0), (proc.returncode, err)  # 0: it finished before the signal
    if proc.returncode == 130:
        assert "interrupted" in err and not (user_folder / "o").exists()


def test_an_interrupted_import_of_an_optional_extra_is_an_interrupt_not_a_missing_extra(monkeypatch):
    """A Ctrl-C inside ezc3d's (or Ray's, OpenSim's) import is not 'pip install pcnet[c3d]'."""
    import importlib

    from pcnet.stages.core.errors import InputError, import_extra

    def interrupted(name):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as stop:
            raise ImportError("initialization failed") from stop

    monkeypatch.setattr(importlib, "import_module", interrupted)
    with pytest.raises(KeyboardInterrupt):
        import_extra("ezc3d", "C3D export needs ezc3d")
    monkeypatch.setattr(importlib, "import_module", lambda name: (_ for _ in ()).throw(ImportError(name)))
    with pytest.raises(InputError, match="C3D export needs ezc3d"):
        import_extra("ezc3d", "C3D export needs ezc3d")


def test_training_and_export_without_torch_end_in_one_line(user_folder, monkeypatch):
    """A plain install (`pip install .`, inference only) has no torch: `train` and `export`
    say which extra they need, as the other extras do, instead of a traceback."""
    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` raises ImportError
    _one_line_error(_invoke("export", "--checkpoint", "notes.txt", "--out", "m.onnx"),
                    'pcnet export needs torch: pip install "pcnet[train]" --extra-index-url '
                    'https://download.pytorch.org/whl/cpu (the CPU build)')
    (user_folder / "t.toml").write_text("")
    _one_line_error(_invoke("train", "--config", "t.toml"), 'pcnet train needs torch: pip install "pcnet[train]" '
                    '--extra-index-url https://download.pytorch.org/whl/cpu (the CPU build)')


def test_a_folder_given_for_an_input_file_is_named_as_such(user_folder):
    """A bad-input trial gave the Python API a folder as ``lifter_output``: it was refused as an
    ``--out`` lying inside the input, which hid the real mistake."""
    from pcnet.pipeline import InputError, RunConfig, run_pipeline

    (user_folder / "poses_dir").mkdir()
    with pytest.raises(InputError, match=r"^--lifter-output: expected a file, got a folder \(.*poses_dir\)$"):
        run_pipeline(RunConfig(lifter="videopose3d", lifter_output=str(user_folder / "poses_dir"), fps=30.0,
                               out=str(user_folder / "poses_dir" / "o"), recording=False), progress=False)
    assert not (user_folder / "poses_dir" / "o").exists()


def test_a_run_without_2d_keypoints_says_which_checks_it_lacks(user_folder):
    """An estimator-swapping trial never read that a run without 2D keypoints checks neither the
    left and right sides nor a switch to another person: the pelvis-path note says so."""
    res = _invoke(*RUN, "--out", "o")
    assert res.exit_code == 0, res.output
    assert ("no 2D keypoints to place the root-relative poses in the image (give --keypoints2d); without them the left "
            "and right sides and a switch to another person are not checked either") in \
        (user_folder / "o" / "report.md").read_text()


def test_no_plots_leaves_the_png_files_out(user_folder):
    """A scale trial's batch of short Kinect files spent about half of each file's output time
    on the three PNG plots: --no-plots (a manifest's plots column) leaves them out."""
    res = _invoke(*RUN, "--no-plots", "--out", "o")
    assert res.exit_code == 0, res.output
    assert not list((user_folder / "o").glob("*.png")) and (user_folder / "o" / "kinematics.csv").is_file()
    assert ".png" not in res.output
    res = _invoke(*RUN, "--out", "p")
    assert sorted(p.name for p in (user_folder / "p").glob("*.png")) == ["angles.png", "speeds.png", "wrists.png"]


def test_a_dangling_symlink_as_out_is_refused(user_folder):
    """A file-safety trial planted `dangling -> target_not_there` and ran `--out dangling`: the
    output was made at the link's target, exit 0 (in a shared folder, anyone could redirect a
    colleague's output). Refused in one line; nothing made."""
    os.symlink(user_folder / "target_not_there", user_folder / "dangling")
    res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output", "poses.npy", "--fps", "30",
                                    "--no-recording", "--out", "dangling"])
    assert res.exit_code == 1 and "Error: --out dangling: expected a new folder or an existing one, got a symbolic " \
        "link to a missing path" in res.output, res.output
    assert not (user_folder / "target_not_there").exists() and os.path.islink(user_folder / "dangling")



@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX's")
def test_a_named_pipe_as_manifest_or_config_is_one_line_not_a_wait(user_folder):
    """A second file-safety trial: a named pipe with no writer given as the batch manifest or
    the --config waited forever (the lifter output's was refused)."""
    for name in ("m.csv", "run.toml"):
        os.mkfifo(name)
    _one_line_error(CliRunner().invoke(main, ["batch", "m.csv"]), "m.csv", "a special file (a named pipe or device)")
    _one_line_error(_invoke("run", "--config", "run.toml"), "run.toml", "a special file (a named pipe or device)")
