"""`pcnet opensim`: OpenSim scaling + inverse kinematics of a run's world.trc (stages/opensim_ik.py).

The real-clip test needs the optional extra (``pip install "pcnet[opensim]"``; CI installs it)
and is skipped with that reason otherwise. The error tests that need no OpenSim always run.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pcnet.pipeline.cli import main
from pcnet.stages.core.errors import InputError

EXAMPLE = Path(__file__).resolve().parent.parent / "pipeline" / "example_data"
FRAMES = 60  # 2 s of the bundled boxing clip
#: What the OpenSim fit writes (opensim_ik's tuple of outputs), spelled out so that a file
#: dropped from that tuple fails here.
OPENSIM_FILES = ["ik.mot", "ik_marker_errors.sto", "ik_markers.trc", "ik_setup.xml", "opensim_fit.json",
                 "scale_markers.trc", "scale_setup.xml", "scaled_model.osim"]


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def short_run(tmp_path_factory) -> Path:
    """`pcnet run` (pcnet, --height 1.75, no recording) on the first 60 frames of the bundled
    MotionBERT example, with its AlphaPose 2D keypoints."""
    tmp = tmp_path_factory.mktemp("opensim_run")
    x3d = tmp / "X3D_60.npy"
    np.save(x3d, np.load(EXAMPLE / "X3D.npy")[:FRAMES])
    out = tmp / "out"
    res = _cli("run", "--lifter", "motionbert", "--lifter-output", x3d, "--keypoints2d",
               EXAMPLE / "alphapose-results.json", "--keypoints2d-format", "alphapose", "--fps", 30,
               "--align", "truncate", "--height", 1.75, "--method", "pcnet", "--out", out, "--no-recording")
    assert res.exit_code == 0, res.output
    assert (out / "world.trc").is_file(), res.output
    return out


@pytest.fixture
def poor_fit(monkeypatch):
    """Every OpenSim fit is "poor": its warning and its finding both come from
    opensim_ik.marker_rms_flag."""
    import pcnet.stages.opensim_ik as opensim_ik

    monkeypatch.setattr(opensim_ik, "MAX_GOOD_MARKER_RMS_M", 0.001)


def test_scale_and_ik_on_a_short_real_clip(short_run, tmp_path):
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    from pcnet.stages.opensim_ik import ik_fit_flags, scale_and_ik

    out = tmp_path / "ik"
    out.mkdir()
    r = scale_and_ik(short_run / "world.trc", out, 1.75)
    assert sorted(p.name for p in out.iterdir()) == OPENSIM_FILES
    for name in OPENSIM_FILES:
        assert (out / name).stat().st_size > 0, name
    fit = json.loads((out / "opensim_fit.json").read_text())
    # the lifter's right leg is 19 % short here, and so is the model's: the fit says so itself
    (legs,) = fit["warnings"]
    assert fit["marker_rms_m"] == pytest.approx(r["marker_rms_m"]) and fit["warnings"] == r["warnings"]
    assert legs.startswith("the scaled model's legs differ by 19 % in length (right shorter"), legs
    assert r["frames"] == FRAMES
    # Measured 1.53 cm RMS / 3.95 cm max on these 60 frames (1.73 / 6.51 cm on all 301); the
    # issue's target is < 2 cm RMS.
    assert r["marker_rms_m"] < 0.02, r
    assert r["marker_max_m"] < 0.06, r
    assert ik_fit_flags(r) == [legs]  # a good fit of a lifter's short leg
    # the scaled model's limbs are the markers' own, each side on its own (a lifter's short leg
    # stays short in the model)
    from pcnet.stages.opensim_ik import LIMB_SEGMENTS, read_trc

    _, markers, names, _ = read_trc(short_run / "world.trc")
    assert sorted(fit["segment_lengths_m"]) == sorted(f"{side}_{s}" for side in ("left", "right") for s in LIMB_SEGMENTS)
    for side in ("left", "right"):
        for segment, (a, b) in LIMB_SEGMENTS.items():
            data = np.nanmedian(np.linalg.norm(markers[:, names.index(f"{side}_{a}")] - markers[:, names.index(f"{side}_{b}")],
                                            axis=-1))
            assert abs(fit["segment_lengths_m"][f"{side}_{segment}"] - data) < 0.02, (side, segment, data)
    assert np.isfinite(r["frames_per_s"]) and r["frames_per_s"] > 0
    # ik.mot: one row per frame and the model's coordinates.
    lines = (out / "ik.mot").read_text().splitlines()
    end = lines.index("endheader")
    cols = lines[end + 1].split("\t")
    assert "knee_angle_r" in cols and "hip_flexion_l" in cols
    assert len([line for line in lines[end + 2:] if line.strip()]) == FRAMES
    # the columns the note calls locked are 0 in every row, the others not (a user trial read a
    # locked ankle as a neutral one)
    from pcnet.stages.opensim_ik import locked_note

    table = np.array([[float(v) for v in line.split("\t")] for line in lines[end + 2:] if line.strip()])
    held = dict((name.strip(), float(value)) for group in locked_note().split(": ", 2)[2].split("; ")
                for names, value in [group.rsplit(" at ", 1)] for name in names.split(",")
                for value in [value.removesuffix(" deg")])
    assert held["ankle_angle_r"] == 0.0 and held["pro_sup_l"] == 89.95 and "knee_angle_r" not in held
    for name, value in held.items():
        np.testing.assert_allclose(table[:, cols.index(name)], value, atol=0.01, err_msg=name)
    assert np.ptp(table[:, cols.index("knee_angle_r")]) > 1.0
    # Existing outputs are refused without overwrite and replaced with it.
    with pytest.raises(InputError, match="--overwrite"):
        scale_and_ik(short_run / "world.trc", out, 1.75)
    scale_and_ik(short_run / "world.trc", out, 1.75, 70.0, overwrite=True)


def test_the_written_setups_re_run_in_opensim_to_the_same_fit(short_run, tmp_path, monkeypatch):
    """An OpenSim modeller had no setup files to re-run or edit the fit with. The ScaleTool's
    and the InverseKinematicsTool's setups are written as they ran, with their marker files:
    a copy of the folder re-runs both to pcnet's scaled model and ik.mot."""
    osim = pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    from pcnet.stages.opensim_ik import _parse_sto, scale_and_ik

    out = tmp_path / "ik"
    out.mkdir()
    scale_and_ik(short_run / "world.trc", out, 1.75, 70.0)
    again = tmp_path / "moved"
    again.mkdir()
    for name in ("scale_setup.xml", "scale_markers.trc", "ik_setup.xml", "ik_markers.trc"):
        (again / name).write_bytes((out / name).read_bytes())
    monkeypatch.chdir(tmp_path)  # the ScaleTool reads its names against its setup's folder
    assert osim.ScaleTool(str(again / "scale_setup.xml")).run()
    assert sorted(p.name for p in again.iterdir()) == ["ik_markers.trc", "ik_setup.xml", "scale_markers.trc",
                                                       "scale_setup.xml", "scaled_model.osim"]
    monkeypatch.chdir(again)  # the InverseKinematicsTool reads them against the working folder
    assert osim.InverseKinematicsTool("ik_setup.xml").run()
    (columns, ours), (rerun_columns, rerun) = _parse_sto(out / "ik.mot"), _parse_sto(again / "ik.mot")
    assert columns == rerun_columns and ours.shape == rerun.shape == (FRAMES, len(columns))
    kept = np.isfinite(ours)  # pcnet empties the cells no marker reaches; OpenSim writes them
    assert kept.mean() > 0.5
    np.testing.assert_allclose(rerun[kept], ours[kept], atol=1e-3)


def test_a_separate_static_trial_scales_the_model(short_run, tmp_path):
    """OpenSim's own workflow scales the model on a static standing trial, then solves IK on the
    motion; `pcnet opensim` could only scale on the recording itself. With --static-trial the
    ScaleTool reads the static trial (here the subject stands still in the recording's first
    pose, 10 % taller about the pelvis) and IK still solves every frame of the recording."""
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    import shutil

    from pcnet.stages.opensim_ik import LIMB_SEGMENTS, read_trc
    from pcnet.stages.sinks.exports import write_trc

    run = tmp_path / "run"
    shutil.copytree(short_run, run)
    times, markers, names, units = read_trc(run / "world.trc")
    pelvis = markers[0, names.index("pelvis")]
    standing = np.repeat(pelvis + 1.1 * (markers[:1] - pelvis), 30, axis=0)
    static = tmp_path / "standing"
    static.mkdir()
    write_trc(static / "world.trc", standing, 30.0, names, units)
    res = _cli("opensim", run, "--static-trial", static)
    assert res.exit_code == 0, res.output
    assert "scaled on the static trial standing/world.trc (30 frames with every marker)" in res.output
    fit = json.loads((run / "opensim_fit.json").read_text())
    assert fit["scale_trial"] == str((static / "world.trc").resolve()) and fit["scale_frames"] == 30
    assert fit["frames"] == FRAMES
    assert len(read_trc(run / "scale_markers.trc")[0]) == 30
    static_fit = fit
    res = _cli("opensim", run, "--overwrite")  # scaled on the recording itself again
    assert res.exit_code == 0, res.output
    fit = json.loads((run / "opensim_fit.json").read_text())
    assert fit["scale_trial"] is None
    # each model's limbs are its scaling trial's (the lifter's bones change length from frame
    # to frame, so the recording's mean is not its first frame's)
    for trial, poses in ((static_fit, standing), (fit, markers)):
        for side in ("left", "right"):
            for segment, (a, b) in LIMB_SEGMENTS.items():
                length = np.nanmean(np.linalg.norm(poses[:, names.index(f"{side}_{a}")]
                                                   - poses[:, names.index(f"{side}_{b}")], axis=-1))
                assert trial["segment_lengths_m"][f"{side}_{segment}"] == pytest.approx(length, abs=0.01), segment
    shanks = [static_fit["segment_lengths_m"][f"{side}_shank"] / fit["segment_lengths_m"][f"{side}_shank"]
              for side in ("left", "right")]
    assert min(shanks) > 1.02, shanks  # the taller static trial made a taller model
    for bad, found in ((tmp_path / "none", "no such file or folder"), (tmp_path, "a folder without one"),
                       (run / "kinematics.csv", "a .csv file")):
        res = _cli("opensim", run, "--static-trial", bad, "--overwrite")
        assert res.exit_code == 1 and found in res.output, res.output
    noseless = standing.copy()
    noseless[:, names.index("neck_nose")] = np.nan
    res = _cli("opensim", run, "--static-trial", write_trc(tmp_path / "noseless.trc", noseless, 30.0, names, units),
               "--overwrite")
    assert res.exit_code == 0, res.output
    assert json.loads((run / "opensim_fit.json").read_text())["markers_left_out"] == ["neck_nose"]
    assert "marker neck_nose left out (empty in every frame of the recording or of its static trial)" in \
        (run / "report.md").read_text()
    (static / "canonical.npz").write_bytes((run / "canonical.npz").read_bytes())
    assert _cli("opensim", run, "--static-trial", static, "--overwrite").exit_code == 0  # the same --height
    np.savez(static / "canonical.npz", subject_height_m=np.float64(1.6))
    res = _cli("opensim", run, "--static-trial", static, "--overwrite")
    assert res.exit_code == 1 and "expected a run scaled to the recording's subject height (1.75 m" in res.output, \
        res.output
    # its world.trc named instead of its folder is the same run's (a study trial's was taken unchecked)
    res = _cli("opensim", run, "--static-trial", static / "world.trc", "--overwrite")
    assert res.exit_code == 1 and "expected a run scaled to the recording's subject height (1.75 m" in res.output, \
        res.output
    mm = tmp_path / "mm.trc"
    write_trc(mm, standing * 1000.0, 30.0, names, "mm")
    res = _cli("opensim", run, "--static-trial", mm, "--overwrite")
    assert res.exit_code == 1 and "Units: expected the recording's 'm'" in res.output, res.output


def test_frames_without_any_marker_are_left_out_of_ik(short_run, tmp_path):
    """A frame with no marker at all (a lost track: the Sports2D demo has 8) made OpenSim's
    IK throw, a traceback; such frames now have no row in ik.mot, whose other rows keep the
    TRC's times."""
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    from pcnet.stages.opensim_ik import _parse_sto, read_trc, scale_and_ik
    from pcnet.stages.sinks.exports import write_trc

    times, markers, names, units = read_trc(short_run / "world.trc")
    markers[[10, 11, 40]] = np.nan
    trc = write_trc(tmp_path / "world.trc", markers, 30.0, names, units)
    out = tmp_path / "ik"
    out.mkdir()
    r = scale_and_ik(trc, out, 1.75)
    assert r["frames"] == FRAMES - 3 and r["frames_without_markers"] == 3
    cols, rows = _parse_sto(out / "ik.mot")
    kept = np.delete(times, [10, 11, 40])
    # exactly the TRC's times (printed to 6 decimals): a rate worked out again from those 6-decimal
    # times (30.0003) made them drift, 2e-5 s after 2 s, a frame after minutes at 120 fps
    np.testing.assert_allclose(rows[:, cols.index("time")], kept, atol=2e-6)
    assert r["marker_rms_m"] < 0.02, r
    # the frames above the RMS limit are counted from OpenSim's own per-frame errors
    e_cols, errors = _parse_sto(out / "ik_marker_errors.sto")
    assert r["frames_above_rms_limit"] == int(np.sum(errors[:, e_cols.index("marker_error_RMS")] > 0.02))
    assert sum(b - a for a, b in r["above_rms_limit_s"]) <= kept[-1] - kept[0]
    # without --mass the scaled model's weight is the generic one's scaled, and recorded
    fit = json.loads((out / "opensim_fit.json").read_text())
    assert fit["subject_mass_kg"] is None and 30.0 < fit["model_mass_kg"] < 150.0


def test_coordinates_no_marker_reaches_are_empty_in_ik_mot(short_run, tmp_path):
    """A user trial read a smooth right elbow in ik.mot over 253 frames in which the right
    elbow and wrist were never seen (the solver carries its last value on). Such a coordinate
    is now NaN in those frames and measured in the others; a missing wrist empties the elbow,
    a missing elbow and wrist the shoulder too, and the note says which."""
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    from pcnet.stages.opensim_ik import _parse_sto, read_trc, scale_and_ik, unobserved_coordinates_note
    from pcnet.stages.sinks.exports import write_trc

    times, markers, names, units = read_trc(short_run / "world.trc")
    markers[20:30, names.index("right_wrist")] = np.nan
    markers[25:30, names.index("right_elbow")] = np.nan
    trc = write_trc(tmp_path / "world.trc", markers, 30.0, names, units)
    out = tmp_path / "ik"
    out.mkdir()
    r = scale_and_ik(trc, out, 1.75)
    wrist_gone = ~np.isfinite(markers[:, names.index("right_wrist")]).all(axis=1)
    arm_gone = wrist_gone & ~np.isfinite(markers[:, names.index("right_elbow")]).all(axis=1)
    assert wrist_gone.sum() >= 10 and arm_gone.sum() >= 5  # the clip's own gaps besides these
    n_wrist, n_arm = int(wrist_gone.sum()), int(arm_gone.sum())
    assert r["coordinates_unobserved"] == {"arm_flex_r": n_arm, "arm_add_r": n_arm, "arm_rot_r": n_arm,
                                           "elbow_flex_r": n_wrist}
    cols, rows = _parse_sto(out / "ik.mot")
    empty = np.isnan(rows)
    assert (empty[:, cols.index("elbow_flex_r")] == wrist_gone).all()
    assert (empty[:, cols.index("arm_add_r")] == arm_gone).all()
    assert empty.sum() == n_wrist + 3 * n_arm  # no other coordinate, the left arm included
    assert np.isfinite(rows[:20, cols.index("elbow_flex_r")]).sum() >= 15  # measured where the wrist was seen
    assert unobserved_coordinates_note(r).startswith(
        f"ik.mot: elbow_flex_r empty (NaN) in {n_wrist} of {FRAMES} frames; arm_flex_r, arm_add_r, arm_rot_r empty "
        f"(NaN) in {n_arm} of {FRAMES} frames")


def test_cli_opensim_reports_and_keeps_the_folder_a_pcnet_output(short_run, tmp_path):
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    import shutil

    import socket

    out = tmp_path / "run"
    shutil.copytree(short_run, out)
    killed = out / f".pcnet-opensim-tmp-999999999@{socket.gethostname()}-0123456789ab"  # a killed run's
    killed.mkdir()
    res = _cli("opensim", out, "--height", 1.75)
    assert res.exit_code == 0, res.output
    assert not killed.exists() and not list(out.glob(".pcnet-opensim-tmp-*"))
    assert "marker RMS" in res.output and "frames/s" in res.output
    listed = json.loads((out / ".pcnet-output").read_text())["files"]
    assert {"scaled_model.osim", "ik.mot", "ik_marker_errors.sto", "opensim_fit.json"} <= set(listed)
    fit = json.loads((out / "opensim_fit.json").read_text())  # the fit and its warning, kept with the outputs
    assert (f"OpenSim IK: marker RMS {100 * fit['marker_rms_m']:.2f} cm to the lifter's joints over {fit['frames']} "
            f"frames") in res.output
    assert len(fit["warnings"]) == sum(ln.startswith("WARNING  ") for ln in res.output.splitlines())
    assert fit["subject_height_m"] == 1.75 and fit["subject_mass_kg"] is None  # what was given is recorded
    assert "pelvis_tilt and L5_S1_Flex_Ext are not observable" in res.output
    assert "ik.mot's angles are not kinematics.csv's" in res.output  # two hip flexions side by side, said why
    # the long form: the run's report.md gets the fit and its warnings in full, still pcnet's own file
    report = (out / "report.md").read_text()
    assert report.count("## OpenSim inverse kinematics (pcnet opensim)") == 1 and f"details: {out / 'report.md'}" \
        in res.output
    assert all(w in report for w in fit["warnings"]) and "report.md" in listed
    again = _cli("opensim", out)
    assert again.exit_code == 1 and "--overwrite" in again.output
    # A file of the same name that pcnet did not write is never replaced.
    (out / "ik.mot").write_text("mine\n")
    res = _cli("opensim", out, "--overwrite")
    assert res.exit_code == 1 and "ik.mot" in res.output
    assert (out / "ik.mot").read_text() == "mine\n"


@pytest.mark.slow
def test_cli_opensim_prints_a_line_per_warning_and_writes_it_in_full(short_run, tmp_path, poor_fit):
    """A poor fit: the terminal gets the warning's headline and its action, report.md its full
    text (a rerun replaces the section); a report.md pcnet did not write is left alone, the
    details then being opensim_fit.json's."""
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    import shutil

    out = tmp_path / "run"
    shutil.copytree(short_run, out)
    res = _cli("opensim", out)
    assert res.exit_code == 0, res.output
    warning, legs = json.loads((out / "opensim_fit.json").read_text())["warnings"]
    assert sorted(ln for ln in res.output.splitlines() if ln.startswith("WARNING")) == [
        "WARNING  OpenSim marker RMS " + warning.split("marker RMS ")[1].split(":")[0]
        + ": the model does not follow the poses -> read ik.mot's angles with care (ik_marker_errors.sto: "
        "which markers it misses)",
        "WARNING  OpenSim model's legs differ 19 % in length (right shorter): the lifter's -> compare left and "
        "right with care"]
    for text in (warning, legs):
        assert text not in res.output and text in (out / "report.md").read_text()
    # every frame is above the limit here: the fit line counts them and says when
    fit = json.loads((out / "opensim_fit.json").read_text())
    assert fit["frames_above_rms_limit"] == fit["frames"] and fit["above_rms_limit_s"][0][0] == 0.0
    assert f"{fit['frames']} frames above 0 cm RMS (0.00-" in res.output
    assert "the scaled model weighs" in (out / "report.md").read_text()
    assert _cli("opensim", out, "--overwrite").exit_code == 0
    assert (out / "report.md").read_text().count("pcnet opensim)") == 1
    (out / "report.md").write_text("mine\n")
    res = _cli("opensim", out, "--overwrite")
    assert res.exit_code == 0 and f"details: {out / 'opensim_fit.json'}" in res.output, res.output
    assert (out / "report.md").read_text() == "mine\n"


def test_cli_opensim_takes_the_runs_height_and_refuses_another(short_run, tmp_path):
    """The markers are scaled to `pcnet run --height`: `pcnet opensim --height` with another
    value is refused before any work (a user trial's opensim_fit.json recorded a 1.5 m subject
    for markers scaled to 1.70 m), and without --height the run's is recorded."""
    import shutil

    out = tmp_path / "run"
    shutil.copytree(short_run, out)
    with np.load(out / "canonical.npz", allow_pickle=False) as npz:
        assert float(npz["subject_height_m"]) == 1.75
    res = _cli("opensim", out, "--height", 1.5)
    assert res.exit_code == 1
    assert res.output.strip() == (f"Error: {out}: --height: expected the run's subject height, 1.75 m (pcnet run "
                                  f"--height scaled world.trc's markers to it), got 1.5; re-run pcnet run --height "
                                  f"1.5, or leave --height out")
    assert not (out / "opensim_fit.json").exists()
    # a damaged canonical.npz is one line naming it, not numpy's traceback (a review)
    good = (out / "canonical.npz").read_bytes()
    (out / "canonical.npz").write_text("garbage")
    res = _cli("opensim", out, "--height", 1.75)
    assert res.exit_code == 1 and "canonical.npz': field 'content': expected a numpy .npy/.npz file" in res.output
    (out / "canonical.npz").write_bytes(good)
    # a run given no height: its markers keep the lifter's scale, so any height is refused (a
    # trial's opensim_fit.json recorded 1.60 m for markers whose head was 1.28 m up)
    with np.load(out / "canonical.npz", allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    np.savez(out / "canonical.npz", **{**arrays, "subject_height_m": np.float64("nan")})
    res = _cli("opensim", out, "--height", 1.6)
    assert res.exit_code == 1 and res.output.strip() == (
        f"Error: {out}: --height: expected no height, as the run was given none (world.trc's markers keep the "
        f"lifter's own scale), got 1.6; re-run pcnet run --height 1.6 to scale them, or leave --height out")
    assert not (out / "opensim_fit.json").exists()
    (out / "canonical.npz").write_bytes(good)
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    res = _cli("opensim", out)
    assert res.exit_code == 0, res.output
    assert json.loads((out / "opensim_fit.json").read_text())["subject_height_m"] == 1.75


def test_cli_opensim_without_world_trc(tmp_path):
    res = _cli("opensim", tmp_path / "missing")
    assert res.exit_code == 1 and "no folder" in res.output
    empty = tmp_path / "empty"
    empty.mkdir()
    res = _cli("opensim", empty)
    assert res.exit_code == 1 and "world.trc" in res.output
    moving = tmp_path / "moving"
    moving.mkdir()
    (moving / "canonical.trc").write_text("")
    res = _cli("opensim", moving)
    assert res.exit_code == 1
    assert "has no fixed world frame for IK; if the camera stood still, rerun `pcnet run` with --mode sequence" in res.output
    assert len(res.output.strip().splitlines()) == 1
    # an OpenSim user gave the TRC itself and read click's "Directory ... is a file"
    res = _cli("opensim", moving / "canonical.trc")
    assert res.exit_code == 1 and len(res.output.strip().splitlines()) == 1
    assert f"expected a `pcnet run` output folder, got a file: give its folder, {moving}" in res.output


def test_missing_opensim_is_one_line(short_run, monkeypatch):
    monkeypatch.setitem(sys.modules, "opensim", None)  # `import opensim` raises ImportError
    res = _cli("opensim", short_run)
    assert res.exit_code == 1
    assert res.output.strip() == ('Error: OpenSim scaling and inverse kinematics (--opensim, pcnet opensim) need '
                                  'OpenSim: pip install "pcnet[opensim]"')


@pytest.mark.slow
def test_pcnet_run_with_opensim_writes_the_ik_beside_the_run(tmp_path):
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    x3d = tmp_path / "X3D_60.npy"
    np.save(x3d, np.load(EXAMPLE / "X3D.npy")[:FRAMES])
    out = tmp_path / "out"
    res = _cli("run", "--lifter", "motionbert", "--lifter-output", x3d, "--fps", 30, "--height", 1.75,
               "--out", out, "--no-recording", "--opensim", "--mass", 70)
    assert res.exit_code == 0, res.output
    assert "note     OpenSim IK: marker RMS" in res.output
    # the lifter's short right leg, which the model took: said once, by the run's own check
    assert res.output.count("legs differ") == 1 and "WARNING  lifter's legs differ" in res.output, res.output
    assert "the scaled model's legs differ" in json.loads((out / "opensim_fit.json").read_text())["warnings"][0]
    written = {"world.trc", *OPENSIM_FILES}
    assert written <= {p.name for p in out.iterdir()}
    # published with the run: pcnet's marker lists the OpenSim files, so --overwrite may replace them
    assert written <= set(json.loads((out / ".pcnet-output").read_text())["files"])


@pytest.mark.slow
def test_the_fits_warning_reaches_the_npz_and_a_moving_camera_is_said(tmp_path, poor_fit):
    """With --opensim the fit runs before the npz and the recording are written, so its
    warning is in them (not only on the terminal); a mode that gives no world.trc is refused
    before any work (a user trial got a whole run, then a warning that no fit was made)."""
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    x3d = tmp_path / "X3D_60.npy"
    np.save(x3d, np.load(EXAMPLE / "X3D.npy")[:FRAMES])
    args = ("run", "--lifter", "motionbert", "--lifter-output", x3d, "--fps", 30, "--height", 1.75, "--no-recording",
            "--opensim")
    res = _cli(*args, "--out", tmp_path / "a")
    assert res.exit_code == 0, res.output
    with np.load(tmp_path / "a" / "canonical.npz") as npz:
        assert any(f.startswith("marker RMS") for f in npz["flags"])
    assert "WARNING  OpenSim marker RMS" in res.output
    res = _cli(*args, "--mode", "smooth", "--out", tmp_path / "b")  # asked for no world frame: refused before work
    assert res.exit_code == 1 and "--opensim: expected with mode sequence or auto" in res.output, res.output
    assert not (tmp_path / "b").exists()


@pytest.mark.slow
def test_a_batch_row_can_ask_for_opensim(tmp_path):
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    x3d = tmp_path / "X3D_60.npy"
    np.save(x3d, np.load(EXAMPLE / "X3D.npy")[:FRAMES])
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"lifter,lifter_output,fps,height,out,recording,opensim,mass\n"
                        f"motionbert,{x3d},30,1.75,a,false,true,70\n")
    res = _cli("batch", manifest, "--workers", "1")
    assert res.exit_code == 0, res.output
    assert {"ik.mot", "opensim_fit.json"} <= {p.name for p in (tmp_path / "a").iterdir()}
    marker = json.loads((tmp_path / "a" / ".pcnet_batch.json").read_text())
    assert marker["settings"]["opensim"] is True and marker["settings"]["mass"] == 70.0
    rms = round(100 * json.loads((tmp_path / "a" / "opensim_fit.json").read_text())["marker_rms_m"], 2)
    (row,) = json.loads((tmp_path / "m.csv.pcnet_batch.json").read_text())["rows"]
    assert row["opensim_rms_cm"] == marker["result"]["opensim_rms_cm"] == rms
    assert f"OpenSim IK        marker RMS {rms:.2f} cm (line 2: a)" in res.output, res.output
    table = (tmp_path / "m.csv.pcnet_batch.md").read_text()
    # no 2D keypoints: no pelvis path, a floor under each frame's lowest joint (what a lab reads first)
    assert (row["root_path"], row["floor"]) == (marker["result"]["root_path"], marker["result"]["floor"]) == \
        ("not observable", "per frame")
    assert (f"| sequence | {row['units']} | {row['camera_tilt_deg']} | {row['camera_tilt_uncertainty_deg']} "
            f"({row['camera_tilt_uncertainty']}) | upright | {row['angles']['trunk_inclination_deg']['median']} | "
            f"not observable | per frame | {rms} |") in table
    res = _cli("batch", manifest, "--workers", "1")  # skipped: the marker's fit shown again
    assert res.exit_code == 0 and f"marker RMS {rms:.2f} cm (line 2: a)" in res.output, res.output
    manifest.write_text(f"lifter,lifter_output,fps,height,out,mass\nmotionbert,{x3d},30,1.75,b,70\n")
    res = _cli("batch", manifest)
    assert res.exit_code == 1 and "column mass: expected together with opensim" in res.output, res.output


def test_a_fit_without_the_subjects_mass_says_what_the_model_weighs():
    """A study trial's `pcnet run --opensim` rows without a mass got 85-89 kg models and no word
    of it (only `pcnet opensim`'s report section said so)."""
    from pcnet.stages.opensim_ik import opensim_notes

    fit = {"model_mass_kg": 89.31, "subject_mass_kg": None, "frames": 10}
    (note,) = [n for n in opensim_notes(fit) if "weighs" in n]
    assert note.startswith("the scaled model weighs 89.3 kg: the generic model's mass") and "--mass" in note
    assert not [n for n in opensim_notes({**fit, "subject_mass_kg": 70.0}) if "weighs" in n]


def test_the_fit_line_gives_a_one_frame_span_as_one_time():
    """A trial read "1.52-1.52 s" for one frame above the RMS limit."""
    from pcnet.stages.opensim_ik import opensim_fit_line

    fit = {"frames_without_markers": 0, "frames_above_rms_limit": 2, "above_rms_limit_s": [(1.52, 1.52), (2.0, 2.5)],
           "frames": 60, "marker_rms_m": 0.015, "marker_max_m": 0.04, "frames_per_s": 30.0, "scale_seconds": 1.0}
    assert "2 frames above 2 cm RMS (1.52 s, 2.00-2.50 s)" in opensim_fit_line(fit)


def test_a_poor_ik_fit_is_flagged():
    """OpenSim's best-practice checklist asks of IK an RMS marker error under ~2 cm; a fit as
    poor as a real cycling MotionBERT file's (17.1 cm RMS, 87.4 cm max, `pcnet run --opensim`)
    is warned about, the demo's (1.94 / 7.22 cm, benchmarks/results/opensim_ik.txt) is not."""
    from pcnet.stages.opensim_ik import ik_fit_flags, MAX_GOOD_MARKER_RMS_M

    assert ik_fit_flags({"marker_rms_m": 0.0194, "marker_max_m": 0.0722}) == []
    (line,) = ik_fit_flags({"marker_rms_m": 0.171, "marker_max_m": 0.874})
    assert "marker RMS 17.1 cm (max 87.4 cm)" in line and "check the joint angles" in line
    assert ik_fit_flags({"marker_rms_m": MAX_GOOD_MARKER_RMS_M, "marker_max_m": 0.05}) == []


def test_a_model_with_legs_out_of_proportion_is_flagged_and_the_run_warns_once():
    """A user trial's lifter had a right leg 18 % short, which the ScaleTool put into the model
    with no word in opensim_fit.json; the limit is the run's own leg check's (fitted on
    training mocap), and a run that already warns of the poses' legs does not warn twice."""
    from pcnet.stages.flags import Kind, load_skeleton_limits, opensim_fit_findings
    from pcnet.stages.opensim_ik import model_leg_asymmetry_flag

    limit = load_skeleton_limits().leg_asymmetry
    lengths = {f"{side}_{s}": 0.42 if s == "thigh" else 0.40 for side in ("left", "right") for s in ("thigh", "shank")}
    fit = {"marker_rms_m": 0.015, "marker_max_m": 0.04, "segment_lengths_m": lengths, "warnings": []}
    assert model_leg_asymmetry_flag(fit) is None and opensim_fit_findings(fit) == []
    short = (1.0 - 1.5 * limit) * 0.82 - 0.40  # the right thigh of a leg 1.5 limits short
    fit["segment_lengths_m"] = {**lengths, "right_thigh": short}
    text = model_leg_asymmetry_flag(fit)
    assert text.startswith(f"the scaled model's legs differ by {100 * 1.5 * limit:.0f} % in length (right shorter")
    (finding,) = opensim_fit_findings({**fit, "warnings": [text]})
    assert finding.kind is Kind.LEG_ASYMMETRY and finding.detail == text
    just_within = (1.0 - 0.99 * limit) * 0.82 - 0.40
    assert model_leg_asymmetry_flag({**fit, "segment_lengths_m": {**lengths, "right_thigh": just_within}}) is None
    assert model_leg_asymmetry_flag({**fit, "segment_lengths_m": {"left_thigh": 0.4}}) is None  # a leg unmeasured


def test_a_marker_in_no_frame_is_left_out_of_scaling_and_ik(short_run, tmp_path):
    """A skeleton without a joint (Kinect v1 has no nose: neck_nose is empty in every frame)
    was refused ("expected at least one frame with all 17 joint markers"); that marker is now
    left out of scaling and IK, and the fit says so. A marker whose every measurement pair is
    gone leaves that segment at the generic size, with a warning."""
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    from pcnet.stages.opensim_ik import opensim_fit_line, read_trc, scale_and_ik
    from pcnet.stages.sinks.exports import write_trc

    times, markers, names, units = read_trc(short_run / "world.trc")
    nose = markers.copy()
    nose[:, names.index("neck_nose")] = np.nan
    out = tmp_path / "nose"
    out.mkdir()
    r = scale_and_ik(write_trc(tmp_path / "nose.trc", nose, 30.0, names, units), out, 1.75)
    assert r["markers_left_out"] == ["neck_nose"] and r["segments_not_scaled"] == []
    assert [w.split(" (")[0] for w in r["warnings"]] == ["the scaled model's legs differ by 19 % in length"]  # the lifter's
    assert r["frames"] == FRAMES and r["marker_rms_m"] < 0.02, r
    fit = json.loads((out / "opensim_fit.json").read_text())
    assert fit["markers_left_out"] == ["neck_nose"]
    assert "; marker neck_nose left out (empty in every frame: the input skeleton has no such joint)" in \
        opensim_fit_line(r)
    wrist = markers.copy()
    wrist[:, names.index("right_wrist")] = np.nan  # the one pair of forearm_r's measurement
    out = tmp_path / "wrist"
    out.mkdir()
    r = scale_and_ik(write_trc(tmp_path / "wrist.trc", wrist, 30.0, names, units), out, 1.75)
    assert r["markers_left_out"] == ["right_wrist"] and r["segments_not_scaled"] == ["forearm_r"]
    assert r["warnings"][0].startswith("segments forearm_r keep the generic model's size"), r["warnings"]


@pytest.mark.slow
def test_pcnet_run_opensim_on_a_real_kinect_v1_recording(tmp_path):
    """`pcnet run --lifter kinect_v1 ... --opensim` on a real UTD-MHAD Kinect v1 sequence (no
    nose joint), read in place from ../shared/data (research licence, never copied here)."""
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    from conftest import shared

    path = shared("real", "utd_mhad_imu", "a01_s1_t1.npz")
    out = tmp_path / "out"
    res = _cli("run", "--lifter", "kinect_v1", "--lifter-output", path, "--out", out, "--no-recording", "--opensim")
    assert res.exit_code == 0, res.output
    assert "marker neck_nose left out (empty in every frame: the input skeleton has no such joint)" \
        in (out / "report.md").read_text()
    fit = json.loads((out / "opensim_fit.json").read_text())
    assert fit["markers_left_out"] == ["neck_nose"] and fit["segments_not_scaled"] == []
    assert fit["frames"] == 48 and fit["marker_rms_m"] < 0.03, fit  # measured 2.10 cm RMS


@pytest.mark.slow
def test_a_lifter_with_wide_hips_is_not_folded_at_l5(tmp_path):
    """Decision 0087: the pelvis is scaled across by the hip width and up and forward by the
    trunk. Scaled by the hip width on every axis, a real VideoPose3D Tadasana (hip centres 1.5
    times the model's apart) got a pelvis too tall for its trunk, and IK folded the standing
    body at L5_S1 (pelvis_tilt +28, L5_S1_Flex_Ext -57 deg; thigh to thorax 28 deg off pcnet's)."""
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    from pcnet.stages.isb_angles import isb_joint_angles
    from pcnet.stages.opensim_ik import read_trc

    from conftest import FIXTURES

    out = tmp_path / "tadasana"
    res = _cli("run", "--lifter", "videopose3d", "--lifter-output", FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy",
               "--fps", "30", "--opensim", "--no-recording", "--out", out)
    assert res.exit_code == 0, res.output
    lines = (out / "ik.mot").read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() == "endheader") + 1
    names = lines[start].split()
    mot = np.array([[float(v) for v in line.split()] for line in lines[start + 1:]])
    col = {n: mot[:, names.index(n)] for n in ("L5_S1_Flex_Ext", "hip_flexion_r", "hip_flexion_l")}
    # the fold is at L5 (pelvis_tilt also carries this short clip's 19 deg up error: the world frame's)
    assert abs(np.median(col["L5_S1_Flex_Ext"])) < 15, np.median(col["L5_S1_Flex_Ext"])
    _, markers, marker_names, _ = read_trc(out / "world.trc")
    from pcnet.stages.core.conventions import H36M_JOINTS

    angles = isb_joint_angles(markers[:, [marker_names.index(j) for j in H36M_JOINTS]])
    for side in ("r", "l"):
        name = "right" if side == "r" else "left"
        pcnet = angles[f"{name}_hip_flexion_deg"] + angles["trunk_flexion_to_pelvis_deg"]
        opensim = col[f"hip_flexion_{side}"] - col["L5_S1_Flex_Ext"]
        assert abs(np.nanmedian(pcnet - opensim)) < 12, (side, np.nanmedian(pcnet - opensim))


def test_the_report_gives_the_subjects_body_mass_index():
    """A clinician's trial typed a mass in pounds (154 at 1.72 m) and nothing showed it; the
    report's subject line gives the body-mass index where height and mass are both known."""
    from pcnet.stages.opensim_ik import _body_mass_index

    assert _body_mass_index({"subject_height_m": 1.72, "subject_mass_kg": 154.0}) == " (body-mass index 52.1 kg/m^2)"
    assert _body_mass_index({"subject_height_m": 1.72, "subject_mass_kg": None}) == ""


_MOT_HEADER = "ik\nversion=1\nnRows=5\nnColumns=5\ninDegrees={}\nendheader\n"


def test_ik_angles_in_gimbal_lock_are_empty(tmp_path):
    """An OpenSim trial's T-pose read arm_flex and arm_rot 86-113 deg apart between four
    cameras of one standing subject: with arm_add near -90 deg the shoulder's first and third
    axes line up and the solver's split between them is arbitrary. Those two are NaN where the
    middle angle lies within GIMBAL_MARGIN_DEG of +-90 (pcnet's own Euler angles' rule), the
    rest of the file byte for byte; radians are read as such."""
    from pcnet.stages.isb_angles import GIMBAL_MARGIN_DEG
    from pcnet.stages.opensim_ik import blank_gimbal_lock, gimbal_lock_note

    middle = [-84.0, -78.0, float("nan"), 95.0, 30.0]  # within 10 deg of -90, not, not observed, of +90, not
    for unit, scale in (("yes", 1.0), ("no", np.pi / 180)):
        rows = "".join(f"{0.1 * i:.1f}\t{10.0 + i}\t{m * scale}\t{20.0 + i}\t{i}\n" for i, m in enumerate(middle))
        mot = tmp_path / f"ik_{unit}.mot"
        mot.write_text(_MOT_HEADER.format(unit) + "time\tarm_flex_l\tarm_add_l\tarm_rot_l\televation\n" + rows)
        before = mot.read_text().splitlines()
        emptied = blank_gimbal_lock(mot, [("arm_flex_l", "arm_add_l", "arm_rot_l"), ("a", "absent", "b")])
        assert emptied == {"arm_flex_l": 2, "arm_rot_l": 2}, unit
        after = mot.read_text().splitlines()
        changed = [i for i, (a, b) in enumerate(zip(before, after)) if a != b]
        assert changed == [7, 10] and len(after) == len(before)  # the rows of -84 and 95 deg only
        assert [after[7].split("\t")[k] for k in (1, 2, 3, 4)] == ["NaN", str(middle[0] * scale), "NaN", "0"]
    assert blank_gimbal_lock(mot, [("elevation", "time", "arm_flex_l")]) == {}  # time never near 90: untouched
    note = gimbal_lock_note({"coordinates_gimbal_lock": emptied, "frames": 5})
    assert note.startswith("ik.mot: arm_flex_l, arm_rot_l empty (NaN) in 2 of 5 frames: the joint's middle angle")
    assert f"within {GIMBAL_MARGIN_DEG:g} deg of +-90" in note
    # what an empty cell does to the next OpenSim tool (an OpenSim trial's inverse dynamics stopped on one)
    assert note.endswith("OpenSim's inverse dynamics needs every cell (its GCVSpline error names none): fill or cut "
                         "those frames first")
    assert gimbal_lock_note({"coordinates_gimbal_lock": {}, "frames": 5}) is None


def test_the_shipped_models_euler_joints():
    pytest.importorskip("opensim", reason='OpenSim not installed (pip install "pcnet[opensim]")')
    import opensim as osim

    from pcnet.stages.opensim_ik import MODEL_FILE, euler_triplets

    model = osim.Model(str(Path(__file__).resolve().parent.parent / "stages" / "opensim_data" / MODEL_FILE))
    assert euler_triplets(model) == [
        ("pelvis_tilt", "pelvis_list", "pelvis_rotation"), ("hip_flexion_r", "hip_adduction_r", "hip_rotation_r"),
        ("hip_flexion_l", "hip_adduction_l", "hip_rotation_l"),
        ("L5_S1_Flex_Ext", "L5_S1_Lat_Bending", "L5_S1_axial_rotation"),
        ("neck_flexion", "neck_bending", "neck_rotation"), ("arm_flex_r", "arm_add_r", "arm_rot_r"),
        ("arm_flex_l", "arm_add_l", "arm_rot_l")]  # not the knees (one coordinate on three axes)
