"""Warnings pcnet must give instead of a silent answer: upside-down or axis-swapped input,
2D track switches; a camera tilt consistent with its pitch and roll."""

from __future__ import annotations

import csv
import json
import re

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES, ROOT, camera_up, rrd_summary, shared

from pcnet.pipeline.cli import main
from pcnet.stages.core.errors import InputError
from pcnet.stages.flags import (Kind, Severity, SwitchLimits, camera_tilt, lifter_frame_flag, load_side_swap_limit,
                                load_skeleton_limits, load_switch_limits, mirrored_skeleton_flag, one_person_frames,
                                orientation_flags, pelvis_jumps, place_in_picture, posture_flag, shortened,
                                side_agreement, side_extents, side_swap_flag, size_change_flag, track_present, track_segments,
                                track_switch_flag)
from pcnet.pipeline.rectification import rectify
from pcnet.stages.scale import height_chain_length
from pcnet.stages.remap import remap_to_h36m
from pcnet.stages.up_model import camera_outside_probability, default_parameters, log_camera_prior

TADASANA = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"  # real VideoPose3D, standing, camera frame
MEDIAPIPE = FIXTURES / "mediapipe_blazepose33_f000-059.npz"
BOX_AP = FIXTURES / "boxing_alphapose_f000-059.json"  # real AlphaPose of the boxing video
BOX_X3D = FIXTURES / "boxing_X3D_f000-059.npy"  # its real MotionBERT output


def _roll(X: np.ndarray, degrees: float) -> np.ndarray:
    """The same poses seen by a camera rolled about its optical axis."""
    a = np.radians(degrees)
    Q = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    return (X @ Q.T).astype(np.float32)


def test_camera_tilt_is_consistent_with_its_pitch_and_roll():
    rng = np.random.default_rng(0)
    up = rng.normal(size=(200, 3)) * [0.3, 1.0, 0.3] - [0, 1.0, 0]
    for chunk in np.array_split(up, 20):
        u = chunk / np.linalg.norm(chunk, axis=1, keepdims=True)
        tilt, pitch, roll = camera_tilt(u, np.ones(len(u), bool))
        assert np.cos(np.radians(tilt)) == pytest.approx(np.cos(np.radians(pitch)) * np.cos(np.radians(roll)), abs=1e-9)


@pytest.mark.slow
def test_smooth_mode_summary_prints_a_consistent_tilt(tmp_path):
    res = CliRunner().invoke(main, ["run", "--lifter", "generic", "--lifter-output", str(TADASANA), "--fps", "30",
                                    "--mode", "smooth", "--no-recording", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    tilt, pitch, roll = map(float, re.search(r"camera tilt\s+([\d.]+) deg from level(?:, looking (?:down|up))? \(pitch ([+-][\d.]+), roll "
                                             r"([+-][\d.]+)", res.output).groups())
    assert np.cos(np.radians(tilt)) == pytest.approx(np.cos(np.radians(pitch)) * np.cos(np.radians(roll)), abs=2e-3)
    # the up moves from frame to frame: the line says its number is the mean up's, and how the frames spread
    median, low, high = map(float, re.search(r"of the recording's mean up; per frame median ([\d.]+), 5-95 % "
                                             r"([\d.]+)-([\d.]+) deg", res.output).groups())
    with np.load(tmp_path / "o" / "canonical.npz") as out:
        per_frame = np.degrees(np.arccos(-out["up"][out["valid"].astype(bool), 1]))
    assert median == pytest.approx(np.median(per_frame), abs=0.05) and low <= median <= high
    assert "at 30 fps (--fps;" in res.output


@pytest.mark.parametrize("method", ["pcnet", "geometric"])
@pytest.mark.parametrize("degrees", [90, 180])
def test_rolled_or_upside_down_real_input_is_flagged(method, degrees):
    """A portrait or upside-down camera that nothing corrected: some warning must say so."""
    res = rectify(_roll(np.load(TADASANA), degrees), method, mode="sequence", fps=30.0)
    tilt, pitch, roll = camera_tilt(res.up, res.valid)
    warnings = orientation_flags(tilt, pitch, roll) + posture_flag(res.report.sequence)
    assert warnings, (method, degrees, tilt)


@pytest.mark.parametrize("degrees", [90, -90])
def test_a_portrait_camera_is_not_called_upside_down(degrees):
    """Real standing poses through a camera turned a quarter turn either way: one line saying
    so, never the upside-down or axes-wrong flag (which a tilt of 89.6 or 90.4 deg decided)."""
    res = rectify(_roll(np.load(TADASANA), degrees), "geometric", mode="frame")  # no camera prior
    tilt, pitch, roll = camera_tilt(res.up, res.valid)
    assert abs(abs(roll) - 90) < 20 and abs(tilt - 90) < 20
    flags = orientation_flags(tilt, pitch, roll)
    assert len(flags) == 1 and "quarter turn" in flags[0].detail and "upside down" not in flags[0].detail, flags
    # frame mode reads no --posture: the action says where it is read (a trial was refused following it)
    assert flags[0].action == ("if the subject lay and the camera stood still: --mode sequence --posture lying, with "
                               "the camera prior (a handheld camera has no posture option)")


def test_orientation_flags_judge_the_tilt_beyond_the_nearest_image_axis():
    assert "upside down" in orientation_flags(179.0, 0.0, 179.0)[0].detail
    # a joint order read as another is as likely as axes (a custom-lifter trial's H36M file read as COCO)
    assert "--layout" in orientation_flags(179.0, 0.0, 179.0)[0].action
    assert "upside down" in orientation_flags(100.0)[0].detail  # the tilt alone: beyond 90 deg from image-up
    assert "camera tilt 50 deg beyond a quarter turn" in orientation_flags(90.0, 50.0, 90.0)[0].detail
    assert "camera tilt 50 deg (" in orientation_flags(50.0, 50.0, 0.0)[0].detail
    assert orientation_flags(12.0, 10.0, 6.6) == []


def test_the_camera_tilt_flag_fires_where_the_declared_prior_holds_the_camera_unusual():
    """Decision 0064: one source for how cameras are held. The declared prior is narrower in
    roll (10 deg) than in pitch (12), so 40 deg of pitch is still a handheld camera by its odds
    and 40 deg of roll is not; the flag's probability is the prior's own outside share."""
    assert orientation_flags(40.0, 40.0, 0.0) == []
    assert orientation_flags(40.0, 0.0, 40.0)[0].kind == Kind.CAMERA_TILT
    p = default_parameters()
    for pitch, roll in ((0.0, 0.0), (30.0, -20.0), (-45.0, 10.0), (5.0, 38.0)):
        density = np.exp(log_camera_prior(camera_up(pitch, roll), p))
        outside = p.camera_prior_outside / (4 * np.pi) / density
        assert camera_outside_probability(pitch, roll, p) == pytest.approx(outside, rel=1e-9)


def test_upright_real_input_with_a_level_camera_is_not_flagged():
    res = rectify(np.load(TADASANA), "geometric", mode="sequence", fps=30.0)
    assert orientation_flags(*camera_tilt(res.up, res.valid)) == []


def _mediapipe_2d(path) -> tuple[np.ndarray, float]:
    with np.load(path) as d:
        return remap_to_h36m(d["keypoints_2d"].astype(np.float32), "blazepose33", confidence_channel=True), float(d["fps"])


def test_a_track_that_jumps_to_another_place_is_split():
    kp, fps = _mediapipe_2d(MEDIAPIPE)
    assert track_segments(kp, fps)[1] == []  # one real person walking: no jump
    jumped = kp.copy()
    jumped[30:, :, 0] += 600.0  # the tracker picks someone 600 px to the right
    segment, events = track_segments(jumped, fps)
    assert [f for f, _ in events] == [30] and (segment[:30] == 0).all() and (segment[30:] == 1).all()
    (flag,) = track_switch_flag(segment, events)
    assert "check --person" in flag.detail and flag.frames == ((30, len(kp)),)  # the frames of another person
    assert "re-run the tracker" in track_switch_flag(segment, events, person_option=False)[0].detail
    # pcnet's own estimator (--video alone) has no track to choose and no tracker to re-run (a user trial)
    (own,) = track_switch_flag(segment, events, person_option=False, own_estimator=True)
    assert own.action == "give --roi around the person (docs/video.md)"
    assert "run again with --roi X,Y,W,H" in own.detail and "tracker" not in own.detail
    # ... and one that saw a --roi already is told to narrow it (a coach's run was told to give one)
    (narrow,) = track_switch_flag(segment, events, person_option=False, own_estimator=True, roi_given=True)
    assert narrow.action == "narrow --roi to where the person stays (docs/video.md)"
    assert "another person enters the --roi given" in narrow.detail
    # with the keypoints, whom the results follow: a physiotherapist's run followed a bystander unsaid
    (named,) = track_switch_flag(segment, events, person_option=False, own_estimator=True, keypoints2d=jumped)
    followed = np.flatnonzero(one_person_frames(segment))
    x, y = np.round(np.nanmedian(jumped[followed, 0, :2], axis=0)).astype(int)
    assert named.headline == f"2D track switches at frame 30; followed the person at ({x}, {y}) px"
    assert f"frames {followed[0]}-{followed[-1]}, whose pelvis lies at about ({x}, {y}) px" in named.detail
    assert len(named.terminal_line()) <= 135
    # and with the picture's size, where that is in words (a coach could not tell whom "(644, 260) px" was)
    (placed,) = track_switch_flag(segment, events, person_option=False, own_estimator=True, keypoints2d=jumped,
                                  picture=(1920, 1080))
    place = place_in_picture((x, y), (1920, 1080))
    assert placed.headline == f"2D track switches at frame 30; followed the person at the {place}"
    assert f"whose pelvis lies at about ({x}, {y}) px in the picture, {place} (x" in placed.detail
    assert [place_in_picture(p, (900, 300)) for p in ((10, 10), (450, 150), (899, 299), (-5, 150), (450, 400))] == \
        ["top left", "centre", "bottom right", "middle left", "bottom centre"]
    # many switches in a long recording: the person followed stays in the headline (a review)
    many = [(1000 * k, 3.0) for k in range(1, 7)]
    (long,) = track_switch_flag(np.repeat(np.arange(7), 1000), many, person_option=False, own_estimator=True,
                                keypoints2d=np.zeros((7000, 17, 3)))
    assert long.headline == "2D track switches at frames 1000, 2000 +4 more; followed the person at (0, 0) px"
    assert shortened(long.headline) == long.headline and "frame 5000 (3.0 torso lengths) and 1 more" in long.detail


def test_pelvis_jumps_measure_torso_lengths_over_gaps_at_30_fps():
    kp = np.full((6, 17, 3), np.nan)
    kp[:, 0, :2] = [[0, 0], [10, 0], [np.nan, np.nan], [30, 0], [40, 0], [50, 0]]  # pelvis, x px
    kp[:, 8, :2] = kp[:, 0, :2] + [0, -100]  # thorax 100 px above: torso 100 px
    first, second, gap, jump = pelvis_jumps(kp, fps=60.0)
    assert first.tolist() == [0, 1, 3, 4] and second.tolist() == [1, 3, 4, 5]
    np.testing.assert_allclose(gap, [0.5, 1.0, 0.5, 0.5])  # frame 2 missing: a two-frame gap at 60 fps
    np.testing.assert_allclose(jump, [0.1, 0.2, 0.1, 0.1])
    first, second, gap, jump = pelvis_jumps(kp, fps=60.0, max_gap_30fps=1.0)  # every pair within a 30 fps frame
    assert sorted(zip(first.tolist(), second.tolist())) == [(0, 1), (1, 3), (3, 4), (3, 5), (4, 5)]


def test_the_switch_limit_grows_with_the_gap_and_decides_a_jump():
    limits = SwitchLimits(1.0, 0.5)
    np.testing.assert_allclose(limits.limit([0.5, 1.0, 3.0]), [1.0, 1.0, 2.0])
    kp = np.full((3, 17, 3), np.nan)
    kp[:, 0, :2] = [[0, 0], [150, 0], [np.nan, np.nan]]
    kp[:, 8, :2] = kp[:, 0, :2] + [0, -100]
    assert track_segments(kp, 30.0, limits)[1] == [(1, 1.5)]
    assert track_segments(kp, 15.0, limits)[1] == []  # the same jump over two frames at 30 fps: within 1.5


@pytest.mark.parametrize("load, command", [(load_switch_limits, "fit_track_switch"),
                                           (load_skeleton_limits, "fit_skeleton_limits"),
                                           (load_side_swap_limit, "fit_side_swap")])
def test_the_shipped_limits_state_their_fit(load, command):
    limits = load()
    assert limits.provenance["command"] == f"python -m benchmarks.{command} --data ../shared/data"
    assert "train split" in limits.provenance["data"]


def test_the_shipped_skeleton_limits_are_the_fits_printed_values():
    """Decision 0075: the JSON holds what ``fit_skeleton_limits`` printed (its results file)."""
    rows = (ROOT / "benchmarks" / "results" / "fit_skeleton_limits.txt").read_text().splitlines()
    printed = {r.split()[0]: float(r.split()[2]) for r in rows if r.startswith(("leg_asymmetry ", "size_change_ratio "))}
    limits = load_skeleton_limits()
    assert printed == {"leg_asymmetry": round(limits.leg_asymmetry, 3),
                       "size_change_ratio": round(limits.size_change_ratio, 3)}


def test_the_set_aside_share_is_the_fits_printed_value():
    """Decision 0079: the view gate's set-aside warning share is what ``fit_set_aside_share`` printed."""
    from pcnet.stages.flags import OUTSIDE_VIEWS_SHARE

    text = (ROOT / "benchmarks" / "results" / "fit_set_aside_share.txt").read_text()
    assert float(re.search(r"fitted share ([\d.]+) \(t = ", text).group(1)) == OUTSIDE_VIEWS_SHARE


def test_the_shipped_side_swap_limit_is_the_fits_printed_value():
    """Decision 0077: the JSON holds what ``fit_side_swap`` printed (its results file), rounded
    down from the smallest training agreement, so the clip that set it stays unflagged."""
    text = (ROOT / "benchmarks" / "results" / "fit_side_swap.txt").read_text()
    printed, smallest = map(float, re.search(r"limit \(the smallest\): (-?[\d.]+), .*\((-?[\d.]+) rounded down",
                                             text).groups())
    limit = load_side_swap_limit().agreement_limit
    assert printed == round(limit, 4) and limit <= smallest


@pytest.mark.parametrize("load, text, field", [
    (load_switch_limits, '{"per_extra_frame": 0.5}', "'jump_torsos'"),
    (load_switch_limits, '{"jump_torsos": -1, "per_extra_frame": 0.5}', "'jump_torsos'"),
    (load_switch_limits, '{"jump_torsos": 1, "per_extra_frame": "x"}', "'per_extra_frame'"),
    (load_switch_limits, "[1, 2]", "'jump_torsos'"),
    (load_switch_limits, "{", "unreadable JSON"),
    (load_skeleton_limits, '{"leg_asymmetry": 0.1}', "'size_change_ratio'"),
    (load_skeleton_limits, '{"leg_asymmetry": true, "size_change_ratio": 1.2}', "'leg_asymmetry'"),
    (load_side_swap_limit, '{"agreement_limit": -1.5}', "'agreement_limit'"),
    (load_side_swap_limit, '{"agreement_limit": NaN}', "'agreement_limit'"),
])
def test_bad_limits_name_the_file_and_field(tmp_path, load, text, field):
    path = tmp_path / "limits.json"
    path.write_text(text)
    with pytest.raises(InputError, match=re.escape(field)) as err:
        load(path)
    assert str(path) in str(err.value)


@pytest.mark.slow
def test_the_sports2d_track_switch_is_found_and_reported(tmp_path):
    """Sports2D demo: MediaPipe's track leaves the walking person around frame 169 and
    jumps again around frame 201 (two people in the video)."""
    path = shared("real", "sports2d_demo", "mediapipe_blazepose33.npz")
    kp, fps = _mediapipe_2d(path)
    _, events = track_segments(kp, fps)
    assert [f for f, _ in events] == [170, 202]
    out = tmp_path / "o"
    res = CliRunner().invoke(main, ["run", "--lifter", "mediapipe", "--lifter-output", str(path), "--keypoints2d",
                                    str(path), "--keypoints2d-format", "mediapipe", "--method", "geometric",
                                    "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "WARNING  2D track switches at frames 170, 202; followed the person at the top centre" in res.output
    assert "about (646, 260) px in the picture, top centre" in (out / "report.md").read_text()
    assert "--person" not in res.output  # MediaPipe has one track: nothing to choose
    with np.load(out / "canonical.npz") as npz:
        assert any("switches person" in str(f) for f in npz["flags"])
        segment = npz["track_segment"]
        # NaN where the track has no position, as the CSV's empty cells (a data-dictionary trial
        # found 0, the first person's segment, there: frames between and after the other person's)
        assert np.isnan(segment).sum() == len(segment) - sum(track_present(kp))
        assert np.bincount(segment[np.isfinite(segment)].astype(int)).tolist() == [166, 31, 25]
    with open(out / "kinematics.csv") as f:
        rows = list(csv.DictReader(f))
    with np.load(out / "canonical.npz") as npz:  # the CSV's empty cells: frames the 2D track has no position in
        assert [int(r["track_segment"]) if r["track_segment"] else None for r in rows] == [
            None if np.isnan(s) else int(s) for s in npz["track_segment"]]
    # the marker files, which have no track_segment column, hold the longest stretch alone (a trial
    # found the other person 1.4 m below the ground in world.trc); the CSV keeps every frame
    from pcnet.stages.opensim_ik import read_trc

    _, markers, _, _ = read_trc(out / "world.trc")
    empty = np.isnan(markers).all(axis=(1, 2))
    assert empty[segment > 0].all()  # the other person's, beside frames no pose was read in
    # the tracked person's frames hold markers where the pelvis path places them (the unplaced ones,
    # with no fitted path, are empty: kinematics.csv's positions are too)
    with np.load(out / "canonical.npz") as npz:
        unplaced = ~np.isfinite(npz["pelvis_path_std_world"]).all(axis=1)
    assert np.isfinite(markers[(segment == 0) & ~unplaced]).any(axis=(1, 2)).all()
    assert empty[(segment == 0) & unplaced].all() and ((segment == 0) & unplaced).sum() < 10
    assert sum(bool(r["pelvis_y_m"]) for r, s in zip(rows, segment) if s > 0) > 50  # the CSV keeps them
    assert "the 60 frames outside the 2D track's longest one-person stretch are left empty" in \
        (out / "report.md").read_text()
    # a BVH holds a pose there instead, which the note says (a trial's Blender body stood frozen)
    assert "world.bvh, which cannot leave a frame empty, interpolates across them" in (out / "report.md").read_text()
    rows_rrd, static, _, _ = rrd_summary(out / "recording.rrd")
    assert "/flags" in static
    # the viewer marks the switch on the timeline, and lists the track switch first (a problem), with its action
    assert rows_rrd["/series/status/track_segment"] == sum(track_present(kp))
    from rerun.chunk import RrdReader

    flags_chunk = next(ch for ch in RrdReader(out / "recording.rrd").stream() if ch.entity_path == "/flags")
    text = flags_chunk.to_record_batch().column("TextDocument:text").to_pylist()[0][0]
    assert text.startswith("- **problem**: ") and "switches person" in text.splitlines()[0] and "(action: " in text


def test_auto_mode_decides_on_one_persons_frames():
    """Real standing poses whose up readings drift by up to 40 deg after frame 40 (as the
    frames after a track switch can read): auto mode sees a moving camera, unless it decides
    on the first stretch, at any length (decision 0089)."""
    from pcnet.stages.rectify import SequenceEvidence
    from pcnet.stages.temporal import MODE_THRESHOLD_DEG

    res = rectify(np.load(TADASANA), "pcnet", mode="frame")
    angles = np.radians(np.clip((np.arange(len(res.rotation)) - 40) / 60, 0.0, 1.0) * 40.0)
    c, s = np.cos(angles), np.sin(angles)
    drift = np.zeros((len(angles), 3, 3))
    drift[:, 0, 0], drift[:, 1, 1], drift[:, 1, 2], drift[:, 2, 1], drift[:, 2, 2] = 1.0, c, -s, s, c
    R = drift @ res.rotation
    auto = SequenceEvidence("auto", n_bootstrap=0)
    fps = 8.0
    assert auto(None, R, res.valid, fps).mode.run == "smooth"
    first = np.arange(len(R)) < 40
    mode = auto(None, R, res.valid, fps, decide_on=first).mode
    assert mode.run == "sequence" and mode.spread_deg < 5.0 and mode.decided_on_frames == 40
    # a short stretch (1.3 s at 30 fps) decides too, as a 1.3 s recording would; one with fewer
    # than 2 valid frames cannot: every valid frame decides
    mode = auto(None, R, res.valid, 30.0, decide_on=first).mode
    assert mode.run == "sequence" and mode.decided_on_frames == 40
    assert auto(None, R, res.valid, fps, decide_on=~res.valid).mode.run == "smooth"
    assert auto(None, R, res.valid, fps, decide_on=np.arange(len(R)) == 0).mode.run == "smooth"
    # sequence mode's spread (its moving-camera note) is read over the same one person's frames
    sequence = SequenceEvidence("sequence", n_bootstrap=0)
    assert sequence(None, R, res.valid, fps).mode.spread_deg > MODE_THRESHOLD_DEG
    mode = sequence(None, R, res.valid, fps, decide_on=first).mode
    assert mode.spread_deg < MODE_THRESHOLD_DEG and mode.decided_on_frames == 40


@pytest.mark.slow
def test_the_sports2d_static_camera_is_found_despite_the_track_switch(tmp_path):
    """The Sports2D demo's camera does not move (its vanishing points give one gravity), but
    the jump to the second person read as camera motion (spread 5.5 deg over all frames):
    auto mode decides on the longest stretch and gives the recording its fixed world frame;
    the default sequence mode reads its moving-camera spread over the same stretch, so it no
    longer tells the user the static camera may have moved (a user trial), and fits the pelvis
    path of each one-person stretch on its own."""
    path = shared("real", "sports2d_demo", "mediapipe_blazepose33.npz")
    res = CliRunner().invoke(main, ["run", "--lifter", "mediapipe", "--lifter-output", str(path), "--keypoints2d",
                                    str(path), "--keypoints2d-format", "mediapipe", "--no-recording",
                                    "--mode", "auto", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert re.search(r"mode sequence \(requested auto; per-frame ups [\d.]+ deg from their own mean over the 166 frames of one "
                     r"person, within the [\d.]+ deg of a static camera\)", res.output), res.output
    assert "kinematics frame  world" in res.output
    default = CliRunner().invoke(main, ["run", "--lifter", "mediapipe", "--lifter-output", str(path), "--keypoints2d",
                                        str(path), "--keypoints2d-format", "mediapipe", "--no-recording",
                                        "--out", str(tmp_path / "d")])
    assert default.exit_code == 0 and "kinematics frame  world" in default.output, default.output
    assert re.search(r"mode sequence \(requested sequence; per-frame ups [\d.]+ deg from their own mean over the 166 frames of "
                     r"one person\)", default.output), default.output
    assert "per-frame up spreads" not in default.output
    # the walking person's pelvis stays at hip height up to the switch at frame 170: the path is
    # fitted per one-person stretch (fitted as one body, it sank to -0.58 m: a user trial)
    with np.load(tmp_path / "d" / "canonical.npz") as npz:
        assert np.nanmin(npz["joints_world"][150:170, 0, 1]) > 0.6


@pytest.mark.parametrize("scale, flagged", [(1.0, False), (10.0, True), (0.01, True), (1000.0, True)])
def test_metres_that_are_not_metres_are_flagged(scale, flagged):
    """Real VideoPose3D metres pass; the same poses x10, x0.01 (cm read as m?) or x1000 (mm) do not."""
    from pcnet.stages.flags import body_size_flag

    assert bool(body_size_flag(np.load(TADASANA) * scale, "m")) == flagged
    assert body_size_flag(np.load(TADASANA) * scale, "normalised") == []


def test_camera_tilt_matches_the_rotation_decomposition_on_real_poses():
    """Sequence mode has one up: the summary's pitch and roll equal those of
    decompose_camera_rotation on the rectified rotations (same convention, column 1 = up)."""
    from pcnet.stages.core.rotations import decompose_camera_rotation

    res = rectify(_roll(np.load(TADASANA), 20), "geometric", mode="sequence", fps=30.0)
    _, pitch, roll = decompose_camera_rotation(res.rotation[res.valid])
    tilt, p, r = camera_tilt(res.rotation[:, :, 1], res.valid)
    assert p == pytest.approx(np.degrees(pitch).mean(), abs=1e-3) and r == pytest.approx(np.degrees(roll).mean(), abs=1e-3)
    assert r == pytest.approx(20 + np.degrees(decompose_camera_rotation(
        rectify(np.load(TADASANA), "geometric", mode="sequence", fps=30.0).rotation[:1])[2][0]), abs=0.5)


def test_lifter_frame_flag_fires_only_beyond_the_stated_uncertainty():
    assert lifter_frame_flag(15.5, 7.4) and "15.5 deg" in lifter_frame_flag(15.5, 7.4)[0].detail
    assert lifter_frame_flag(4.4, 7.2) == []  # Pose2Sim cam01: calibrated K, person near the centre
    assert lifter_frame_flag(0.0, 1.0) == [] and lifter_frame_flag(15.0, float("nan")) == []
    # with the focal length known (--focal-px or the file's K) it no longer asks for it
    # where to find the focal length of a web clip's unknown camera (a user trial found no hint)
    assert lifter_frame_flag(15.5, 7.4)[0].action == "give --focal-px (docs/video.md)"
    (known,) = lifter_frame_flag(15.5, 7.4, focal_known=True)
    assert known.action == "take the tilt as uncertain by up to the turn" and "--focal-px" not in known.detail
    # and with nothing left to give it is a note, not a warning (a coach's trial met it on every phone clip)
    assert known.severity == Severity.INFO and lifter_frame_flag(15.5, 7.4)[0].severity == Severity.CHECK


def test_the_lifter_frame_flag_names_a_bootstrap_only_uncertainty_as_such():
    """--method geometric prints 'bootstrap alone +- 0.4, no 95 % interval': the flag must
    not call that figure the tilt's interval."""
    from pcnet.pipeline.checks import tilt_tolerance

    geometric = rectify(np.load(TADASANA), "geometric", mode="sequence", fps=30.0).report
    tolerance = tilt_tolerance(geometric)
    boot = max(geometric.sequence.camera_pitch_uncertainty_deg, geometric.sequence.camera_roll_uncertainty_deg)
    assert tolerance == (boot, "bootstrap-only uncertainty, no calibrated interval for this method")
    assert f"({boot:.1f} deg, bootstrap-only uncertainty" in lifter_frame_flag(boot + 5.0, *tolerance)[0].detail
    ensemble = rectify(np.load(TADASANA), "pcnet", mode="sequence", fps=30.0).report
    assert tilt_tolerance(ensemble) == (ensemble.sequence.camera_pitch_interval_deg, "95 % interval, the larger of pitch and roll")
    from dataclasses import replace

    from pcnet.stages.temporal import MODE_THRESHOLD_DEG

    wide = replace(ensemble, mode=replace(ensemble.mode, spread_deg=MODE_THRESHOLD_DEG + 1.0))  # decision 0090
    assert tilt_tolerance(wide)[1] == "interval, not calibrated for this spread of per-frame ups"
    frame = rectify(np.load(TADASANA), "pcnet", mode="frame").report
    assert tilt_tolerance(frame) == (frame.frame_tilt_bound_base_deg, "per-frame bound, not calibrated on real lifter output")


@pytest.mark.slow
def test_a_large_mediapipe_turn_is_flagged_and_a_negligible_one_is_not(tmp_path):
    """Real MediaPipe (Sports2D demo, the man on the box, above the image centre): with the
    assumed phone focal length his landmarks are turned by about 15 deg into the real camera,
    more than the run's tilt uncertainty; a (hypothetical) long lens turns them by under 1."""
    for focal, flagged in ((None, True), (100000.0, False)):
        out = tmp_path / f"o{focal}"
        args = ["run", "--lifter", "mediapipe", "--lifter-output", str(MEDIAPIPE), "--no-recording", "--out", str(out)]
        res = CliRunner().invoke(main, args + ([] if focal is None else ["--focal-px", str(focal)]))
        assert res.exit_code == 0, res.output
        assert ("lifter output turned" in res.output) is flagged, res.output
        with np.load(out / "canonical.npz") as npz:
            assert any("turned by a median" in str(f) for f in npz["flags"]) is flagged
    # a method without a calibrated interval measures the turn against its bootstrap
    res = CliRunner().invoke(main, ["run", "--lifter", "mediapipe", "--lifter-output", str(MEDIAPIPE), "--method",
                                    "geometric", "--mode", "sequence", "--no-recording", "--out", str(tmp_path / "g")])
    assert res.exit_code == 0 and "lifter output turned" in res.output, res.output


def test_limbs_out_of_proportion_are_flagged_a_wrong_joint_order_and_a_collapsed_arm():
    """A developer trial's joints in a shuffled order rectified without a word (roll 24.6 deg
    where the right order gives 0.6). Real VideoPose3D output: the standing Tadasana passes; the
    Vrikshasana whose right arm the lifter collapsed to 4 cm bones fires, naming it; the same
    Tadasana read in another joint order (shuffled, or COCO-17's order read as H36M-17's) fires."""
    from benchmarks.fit_skeleton_limits import coco_order

    from pcnet.stages.flags import limb_proportions, limb_proportions_flag, load_skeleton_limits

    tadasana = np.load(TADASANA).astype(np.float64)
    assert limb_proportions_flag(tadasana) == [] and limb_proportions(tadasana).ratio < 2.5
    (flag,) = limb_proportions_flag(np.load(FIXTURES / "yoga_Veena_Vrikshasana_f000-099.npy"))
    assert flag.headline.startswith("lifter's right upper arm is 10 % of its left thigh's length"), flag.headline
    assert flag.action == "check the joint order; treat the right upper arm's angles with care"
    assert "another joint order than H36M-17's" in flag.detail and "collapsed a limb" in flag.detail
    limit = load_skeleton_limits().limb_length_ratio
    assert f"at most {limit:.1f}-fold" in flag.detail
    # read by VideoPose3D's own reader the joint order is the format's: only the collapse is said
    # (a first-reader trial looked for a joint-order error that could not be there)
    (fixed,) = limb_proportions_flag(np.load(FIXTURES / "yoga_Veena_Vrikshasana_f000-099.npy"), order_fixed=True)
    assert fixed.action == "treat the right upper arm's angles and speeds with care: the lifter collapsed it"
    assert "joint order than" not in fixed.detail and "collapsed a limb" in fixed.detail
    assert limb_proportions_flag(coco_order(tadasana))
    rng = np.random.default_rng(0)
    fired = sum(bool(limb_proportions_flag(tadasana[:, rng.permutation(17)])) for _ in range(20))
    assert fired >= 15, fired
    assert np.isnan(limb_proportions(np.full((5, 17, 3), np.nan)).ratio)  # nothing measured: no flag
    assert limb_proportions_flag(np.full((5, 17, 3), np.nan)) == []


def test_a_lifters_asymmetric_legs_are_flagged():
    """MotionBERT's boxing output has a right leg about a fifth shorter than the left (its
    skeleton, not the boxer's); real VideoPose3D standing poses have near-equal legs."""
    from pcnet.stages.flags import leg_asymmetry_flag

    boxing = np.load(FIXTURES / "boxing_X3D_f000-059.npy")
    (flag,) = leg_asymmetry_flag(boxing)
    assert "legs differ by" in flag.detail and "the right one shorter" in flag.detail
    assert leg_asymmetry_flag(np.load(TADASANA)) == []
    mirrored = boxing[:, [0, 4, 5, 6, 1, 2, 3, *range(7, 17)]]  # legs swapped: the left one shorter
    assert "the left one shorter" in leg_asymmetry_flag(mirrored)[0].detail
    # a COCO-17 file read as MotionBERT's H36M-17 had legs of eyes and ears, told only to
    # "compare left and right with care" (a developer trial): the full text names the joint order
    assert "another joint order read as H36M-17" in flag.detail


def test_a_skeleton_that_changes_size_is_flagged():
    """A body keeps its size: metric poses whose skeleton grows 3-fold over the recording
    are flagged, the real recording as it is is not."""
    X = np.load(TADASANA)
    assert size_change_flag(X) == []
    grown = X * np.linspace(1.0, 3.0, len(X), dtype=np.float32)[:, None, None]
    (flag,) = size_change_flag(grown)
    assert "changes 2.7-fold" in flag.detail and "metric exports" in flag.detail
    # a lifter whose format fixes metres (not --lifter generic) is not told to declare image units
    (flag,) = size_change_flag(grown, units_declared=False)
    assert "--units" not in flag.action + flag.detail and "changes 2.7-fold" in flag.headline


@pytest.mark.slow
def test_a_rider_growing_in_the_image_gets_a_constant_size(tmp_path):
    """The real MotionBERT cycling clip whose rider grows 3-fold in the image (normalised
    output follows the person's size in the image): the run makes the size constant per
    frame and says so, instead of one scale leaving the metric exports off by up to half."""
    clip_b = np.load(shared("real", "cycling_motionbert", "clip_b_X3D.npy"))
    assert size_change_flag(clip_b)  # the lifter's own output
    res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output", str(
        shared("real", "cycling_motionbert", "clip_b_X3D.npy")), "--fps", "30", "--height", "1.75", "--no-recording",
        "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert "body size made constant per frame" in res.output and "skeleton's size changes" not in res.output
    with np.load(tmp_path / "o" / "canonical.npz") as out:
        chain = height_chain_length(out["joints_camera"])
    chain = chain[np.isfinite(chain)]
    assert np.percentile(chain, 95) / np.percentile(chain, 5) < 1.1


def test_real_lifter_files_beyond_an_ordinary_lifters_size_change_are_flagged():
    """Decision 0075: the limit is the largest size change the training mocap reaches through
    the lifter-noise model (1.18-fold). The real MotionBERT boxing and cycling clip_a outputs
    stay within it; VideoPose3D's lying Shavasana of one subject changes 1.44-fold, a lifter
    failure in metric output, and is flagged."""
    real = shared("real")
    assert not size_change_flag(np.load(real / "boxing_motionbert" / "X3D.npy"))
    assert not size_change_flag(np.load(real / "cycling_motionbert" / "clip_a_X3D.npy"))
    (flag,) = size_change_flag(np.load(real / "yoga_videopose3d" / "export_Veena_Shavasana.npy"))
    assert "changes 1.4-fold" in flag.detail
    # VideoPose3D's format is metric: no advice to declare image units (a clinician's trial)
    (flag,) = size_change_flag(np.load(real / "yoga_videopose3d" / "export_Veena_Shavasana.npy"), units_declared=False)
    assert flag.action == "check the lifter's output on the frames it sizes differently"
    assert "--units" not in flag.detail and "its format is metric" in flag.detail


def test_3d_sides_that_contradict_the_2d_keypoints_are_flagged():
    """Real boxing frames (MotionBERT 3D, AlphaPose 2D; the boxer stands nearly side-on):
    the sides agree (agreement +0.90, decision 0077); with the 3D columns' left and right
    swapped (a wrong joint order) the agreement is negated, below the fitted limit."""
    from pcnet.adapters.registry import get_2d_adapter

    kp = get_2d_adapter("alphapose").load(FIXTURES / "boxing_alphapose_f000-059.json")
    kp2d = remap_to_h36m(kp.points, kp.layout, confidence_channel=True)
    X = np.load(FIXTURES / "boxing_X3D_f000-059.npy")
    X = X - X[:, :1]
    assert side_swap_flag(kp2d, X) == []
    swapped = X[:, [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]]
    (flag,) = side_swap_flag(kp2d, swapped)
    assert "agreement -0.90" in flag.headline and "--layout" in flag.detail
    # the 2D keypoints' sides swapped instead (a detector's front and back confused side-on): the
    # 3D skeleton is a body by the mirror test, so its angles are not called backwards (a user trial)
    (flag,) = side_swap_flag(kp2d[:, [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]], X)
    assert flag.headline == "3D facing contradicts the 2D keypoints (agreement -0.90): front and back confused"
    assert flag.severity == Severity.CHECK and "joint angles stand" in flag.detail and "--layout" not in flag.detail
    assert side_agreement(*side_extents(kp2d, swapped)) == pytest.approx(-side_agreement(*side_extents(kp2d, X)))
    assert side_swap_flag(kp2d, np.full_like(X, np.nan)) == []  # nothing seen: no reading


def test_a_mirrored_3d_skeleton_is_flagged_from_the_pose_alone():
    """A depth axis of the wrong sign mirrors the body (every sagittal angle changes sign)
    and no rotation undoes it. The committed real files (standing, seated, lying, prone, a
    boxer) are bodies; mirrored in depth, or with left and right exchanged, they are flagged: their knees and elbows bend the other way."""
    swap = [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]
    for name in ("yoga_Abhay_Tadasana_f000-099.npy", "yoga_Abhay_Padmasana_f200-299.npy",
                 "yoga_Abhay_Shavasana_f200-299.npy", "yoga_Abhay_Bhujangasana_f150-249.npy", "boxing_X3D_f000-059.npy"):
        X = np.load(FIXTURES / name).astype(np.float64)
        assert mirrored_skeleton_flag(X) == [], name
        (flag,) = mirrored_skeleton_flag(X * np.array([1.0, 1.0, -1.0]))
        assert "mirror image" in flag.detail and "--axes" in flag.detail and "knees bend forward" in flag.detail, name
        assert mirrored_skeleton_flag(X[:, swap]), name
    assert mirrored_skeleton_flag(np.full((50, 17, 3), np.nan)) == []
    # a depth sensor's reader fixes axes and sides: asked whether the subject faced away, not told
    # to set the generic reader's options (an IMU trial's kinect_v1 run)
    (flag,) = mirrored_skeleton_flag(X * np.array([1.0, 1.0, -1.0]), depth_sensor=True)
    assert flag.action == "did the subject face away from the sensor?" and "--axes" not in flag.detail
    assert flag.severity == Severity.CHECK and "odds" not in flag.headline and "weak on a depth sensor" in flag.headline
    assert "docs/guide/warnings.md says how often" in flag.detail and len(flag.terminal_line()) <= 135


def test_the_mirror_flag_keeps_every_real_lifter_file_apart_from_its_mirror_image_and_spares_noseless_mocap():
    """Every real lifter file of the shared data (90 VideoPose3D yoga files, the MotionBERT
    boxing and cycling files) is read unmirrored and, mirrored in depth, mirrored. Bandai's
    skeletons put H36M's joint 9 on the neck (no nose): the nose rule this test replaced called
    a kick leaning back, and 36 of the 206 validation recordings with lifter noise, mirrored;
    the knee and elbow test calls the kick a body and its mirror image mirrored."""
    import glob

    real = shared("real")
    files = sorted(glob.glob(str(real / "yoga_videopose3d" / "*.npy")))
    files += sorted(glob.glob(str(real / "*motionbert" / "*.npy")))
    assert len(files) >= 94
    for path in files:
        X = np.load(path).astype(np.float64)
        assert mirrored_skeleton_flag(X) == [], path
        assert mirrored_skeleton_flag(X * np.array([1.0, 1.0, -1.0])), path
    with np.load(shared("mocap", "bandai_h36m17.npz")) as mocap:
        kick = mocap["dataset-1_kick_normal_001"]
    assert mirrored_skeleton_flag(kick) == []
    assert mirrored_skeleton_flag(kick * np.array([1.0, 1.0, -1.0]))


@pytest.mark.slow
def test_a_wrong_depth_sign_is_warned_about_in_a_run(tmp_path):
    res = CliRunner().invoke(main, ["run", "--lifter", "generic", "--lifter-output", str(TADASANA), "--axes", "RDB",
                                    "--fps", "30", "--method", "geometric", "--no-recording", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert "WARNING  3D skeleton mirrored" in res.output
    with np.load(tmp_path / "o" / "canonical.npz") as npz:
        assert any(f.startswith("the 3D skeleton is a mirror image") for f in npz["flags"])


@pytest.mark.slow
def test_exchanged_3d_sides_are_warned_about_in_a_run(tmp_path):
    """The real boxing pair through ``pcnet run`` with its 2D keypoints: the MotionBERT output as
    it is carries no side-swap warning; with its left and right columns exchanged (a wrong joint
    order) the summary says so once, and the npz keeps the text (decision 0077)."""
    exchanged = tmp_path / "exchanged.npy"
    np.save(exchanged, np.load(BOX_X3D)[:, [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]])
    outputs = {}
    for name, path in (("as_is", BOX_X3D), ("exchanged", exchanged)):
        res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output", str(path), "--keypoints2d",
                                        str(BOX_AP), "--keypoints2d-format", "alphapose", "--fps", "30",
                                        "--method", "geometric", "--no-recording", "--out", str(tmp_path / name)])
        assert res.exit_code == 0, res.output
        outputs[name] = res.output
    assert "sides swapped" not in outputs["as_is"]
    assert outputs["exchanged"].count("sides swapped") == 1, outputs["exchanged"]
    with np.load(tmp_path / "exchanged" / "canonical.npz") as npz:
        assert any("sides are probably swapped" in f for f in npz["flags"])


@pytest.mark.slow
def test_2d_keypoints_outside_the_video_are_warned(tmp_path):
    """The real boxing AlphaPose keypoints with the 10-frame cut of their video pass; the same
    keypoints scaled x3 (another resolution's) lie wholly outside the 854x480 frame: every joint
    they would mask is unseen, so the run is refused naming the file; a picture given too small
    (--image-size, no video) leaves a quarter of the trunk's keypoints outside it: warned (a
    review: only a note), and those joints are missing. Legs below a waist-up picture are not
    warned: its trunk is inside."""
    from pcnet.adapters import load_alphapose
    from pcnet.stages.flags import TRUNK_JOINTS, keypoints_outside_image_flag
    from pcnet.stages.remap import remap_to_h36m

    items = json.loads(BOX_AP.read_text())
    args = ["run", "--lifter", "motionbert", "--lifter-output", str(BOX_X3D), "--keypoints2d-format", "alphapose",
            "--video", str(FIXTURES / "boxing2_f000-009.mp4"), "--align", "truncate", "--method", "geometric",
            "--no-recording"]
    res = CliRunner().invoke(main, [*args, "--keypoints2d", str(BOX_AP), "--out", str(tmp_path / "a")])
    assert res.exit_code == 0 and "outside the video's" not in res.output, res.output
    scaled = [{**it, "keypoints": [v * 3 if i % 3 != 2 else v for i, v in enumerate(it["keypoints"])]} for it in items]
    (tmp_path / "x3.json").write_text(json.dumps(scaled))
    res = CliRunner().invoke(main, [*args, "--keypoints2d", str(tmp_path / "x3.json"), "--out", str(tmp_path / "b")])
    assert res.exit_code == 1 and not (tmp_path / "b").exists(), res.output
    assert (f"{tmp_path / 'x3.json'}: expected 2D keypoints inside the 854x480 picture, got every confident keypoint "
            f"of every frame outside it") in res.output
    small = ["run", "--lifter", "motionbert", "--lifter-output", str(BOX_X3D), "--keypoints2d-format", "alphapose",
             "--keypoints2d", str(BOX_AP), "--image-size", "500x240", "--fps", "30",
             "--no-recording", "--out", str(tmp_path / "c")]
    res = CliRunner().invoke(main, small)
    assert res.exit_code == 0 and "of 2D trunk keypoints lie outside the 500x240 picture" in res.output, res.output
    assert "whose 2D keypoint lies outside the 500x240 picture taken as missing" in res.output
    assert "width and height swapped" not in res.output
    # A user trial typed the 854x480 video's size the other way round: most joints were masked
    # by the one-pixel rule while the flag, counting beyond a 5 % margin, stayed silent. Here
    # no frame keeps its trunk, and the refusal names the picture.
    swapped = [*small[:small.index("--image-size") + 1], "480x854", *small[small.index("--image-size") + 2:-1],
               str(tmp_path / "d")]
    res = CliRunner().invoke(main, swapped)
    assert res.exit_code == 1 and not (tmp_path / "d").exists(), res.output
    assert "masked as their 2D keypoints lie outside the 480x854 picture" in res.output, res.output
    kp = remap_to_h36m(load_alphapose(BOX_AP).points, "halpe26", confidence_channel=True)
    found = keypoints_outside_image_flag(kp, (480, 854), size_typed=True)
    assert [f.headline for f in found] == [
        f"{found[0].headline.split(' %')[0]} % of 2D trunk keypoints lie outside the 480x854 picture: width and height "
        "swapped?"], found
    # a video's own size cannot be typed the other way round
    assert "swapped" not in keypoints_outside_image_flag(kp, (480, 854))[0].headline
    assert "swapped" not in " ".join(f.headline for f in keypoints_outside_image_flag(kp, (500, 240), size_typed=True))
    assert keypoints_outside_image_flag(kp, (854, 480)) == []
    # a body cut by the frame's edge (the legs below a waist-up picture) keeps its trunk inside: no flag
    waist_up = int(np.nanmax(kp[:, list(TRUNK_JOINTS), 1])) + 2
    assert np.nanmean(kp[:, [2, 3, 5, 6], 1] > waist_up) > 0.5  # most knee and ankle keypoints lie below it
    assert keypoints_outside_image_flag(kp, (854, waist_up), size_typed=True) == []
    assert keypoints_outside_image_flag(np.full((3, 17, 3), np.nan), (854, 480)) == []


def test_frames_without_hips_are_not_called_a_body_on_its_side():
    """Real standing poses with both hips missing in every 5th frame (a 2D detector's zero
    rows): those frames lack a pelvis heading because the hips are missing, which the note on
    bodies lying on their side must not count; laid on its side, the same clip is noted."""
    from pcnet.pipeline.runner import _headingless_note
    from pcnet.stages.core.conventions import L_HIP, R_HIP
    from pcnet.stages.kinematics import heading_free_angles, joint_angles, pelvis_heading_frame

    def angles(poses):  # as the run computes them (stages/kinematics.py: compute_kinematics)
        return joint_angles(pelvis_heading_frame(poses), heading_free_angles(poses))

    upright = np.load(TADASANA).astype(np.float64) * [1.0, -1.0, -1.0]  # camera frame -> +Y up
    gaps = upright.copy()
    gaps[::5, [R_HIP, L_HIP]] = np.nan  # the pelvis kept (a lifter's), so the trunk stays defined
    with_gaps = angles(gaps)
    assert np.isfinite(with_gaps["trunk_inclination"][::5]).all()
    assert not np.isfinite(with_gaps["trunk_sagittal_inclination"][::5]).any()
    assert _headingless_note(with_gaps, gaps) == []
    side = upright @ np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]).T  # laid on its side
    assert _headingless_note(angles(side), side)


def test_a_body_lying_on_its_side_is_noted_and_keeps_its_heading_free_angles(tmp_path):
    """A real standing pose laid on its side in front of a level camera (turned 90 deg about
    the optical axis), read as lying: its hip line is vertical, so the plane inclinations are
    empty; the summary says so and the CSV keeps trunk inclination and knee flexion."""
    X = np.load(TADASANA).astype(np.float64)
    np.save(tmp_path / "side.npy", _roll(X, 90.0).astype(np.float32))
    res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output", str(tmp_path / "side.npy"),
                                    "--fps", "30", "--mode", "sequence", "--no-recording", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert "body read as lying" in res.output and "note     no pelvis heading in" in res.output
    with open(tmp_path / "o" / "kinematics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert sum(r["trunk_sagittal_inclination_deg"] == "" for r in rows) > 0.5 * len(rows)
    assert all(r["trunk_inclination_deg"] and r["left_knee_flexion_unsigned_deg"] for r in rows)


def test_no_heading_about_the_sequence_up_names_the_axes_first():
    """A recording whose every frame's up is beyond the heading limit from the sequence up
    (a user trial: VideoPose3D output with y and z negated) is refused with the input's axes
    named before the upside-down camera; a recording with no valid frame says only that."""
    from types import SimpleNamespace

    from pcnet.stages.rectify import NO_VALID_FRAME, no_valid_frame_reason

    reason = no_valid_frame_reason(SimpleNamespace(sequence=SimpleNamespace(up_spread_deg=170.0)))
    assert "170 deg" in reason and reason.index("axes may be wrong") < reason.index("camera upside down")
    assert "--axes with --lifter generic" in reason and "--mode frame" in reason
    assert no_valid_frame_reason(SimpleNamespace(sequence=None)) == NO_VALID_FRAME


def test_gaps_that_leave_every_run_unfiltered_are_not_called_a_short_recording():
    """A user trial set every 10th frame of a 301-frame recording missing: the warning said
    "too short to filter ... use a longer recording". The gaps are the cause; a recording
    that is itself short keeps that advice."""
    from pcnet.stages.flags import unfiltered_flag
    from pcnet.stages.kinematics import compute_kinematics

    poses = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy").astype(np.float64) * [1.0, -1.0, -1.0]  # Y up
    gappy = poses.copy()
    gappy[::10] = np.nan
    k = compute_kinematics(gappy, 30.0)
    (found,) = unfiltered_flag(k.missing, k.unfiltered, 30.0, 6.0)
    assert found.headline.startswith("gaps too frequent to filter (longest run of a present joint 9 of 100 frames)")
    assert found.action == "check why joints are missing (report.md)"
    short = compute_kinematics(poses[:8], 30.0)
    (found,) = unfiltered_flag(short.missing, short.unfiltered, 30.0, 6.0)
    assert found.headline.startswith("too short to filter (8 frames)") and found.action == "use a longer recording"
    short = compute_kinematics(gappy[:9], 30.0)  # too short even without its gap at frame 0 (10 frames filter)
    (found,) = unfiltered_flag(short.missing, short.unfiltered, 30.0, 6.0)
    assert found.headline.startswith("too short to filter (9 frames)"), found.headline
    whole = compute_kinematics(poses, 30.0)
    assert unfiltered_flag(whole.missing, whole.unfiltered, 30.0, 6.0) == []


def test_videopose3d_world_output_given_as_camera_frame_is_warned_as_lying():
    """A real VideoPose3D file (the bundled standing Tadasana) turned into its z-up world frame,
    as VideoPose3D's camera_to_world writes it (common/camera.py, with the Human3.6M camera
    orientation its run.py renders in-the-wild output with), and passed as camera-frame poses
    is read as lying and warned. (The first 300 frames of the same file are read upright with no
    warning: decision 0093's candidate for them did not ship.)"""
    from scipy.spatial.transform import Rotation

    from pcnet.pipeline.checks import pose_checks

    camera = np.load(TADASANA, allow_pickle=False).astype(np.float64)
    w, x, y, z = 0.14070565, -0.15007018, -0.7552408, 0.62232804
    world = Rotation.from_quat([x, y, z, w]).apply(camera.reshape(-1, 3)).reshape(camera.shape)
    assert Kind.LYING in {f.kind for f in pose_checks(world, rectify(world, mode="sequence", fps=30.0))}


def test_a_level_pitch_prints_plus_zero_and_a_pitch_says_which_way_the_camera_looks():
    from pcnet.stages.flags import signed_deg, with_looking

    # an ergonomist's trial read "-0.0" for a level camera and could not tell "+8.6" down from up
    assert signed_deg(-0.04) == "+0.0" and signed_deg(-0.06) == "-0.1" and signed_deg(0.0) == "+0.0"
    line = "(pitch +8.6, roll +21.0 deg)"
    # beside the pitch it names (a clinic trial read "22 deg from level, looking up" as 22 deg up)
    assert with_looking(line, 8.6) == "(looking down: pitch +8.6, roll +21.0 deg)"
    assert with_looking(line, -3.0).startswith("(looking up: pitch")
    assert with_looking(line, -0.04) == line and with_looking(line, float("nan")) == line
    # a docs trial read "looking up" for -0.2 +- 6.9: an interval holding both directions says neither
    assert with_looking(line, -0.2, 6.9) == line and with_looking(line, 8.6, float("inf")) == line


def test_a_note_prints_as_a_note_and_is_no_warning_for_strict():
    """An API trial: pcnet rectify printed pose_checks' note on spread ups as "WARNING ... -> "
    with an empty action, and --strict exited 3 on it where pcnet run printed it as a note."""
    from pcnet.stages.flags import Finding, Severity, note_finding

    note = note_finding("per-frame up spreads 7.5 deg: a leaning body (no action) or a moving camera (--mode smooth)")
    assert note.severity is Severity.INFO and not note.is_warning
    assert note.terminal_line() == f"note     {note.headline}"
    warning = Finding(Severity.CHECK, "legs differ", "compare with care", "the legs differ")
    assert warning.is_warning and warning.terminal_line() == "WARNING  legs differ -> compare with care"
