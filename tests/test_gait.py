"""Gait events and spatiotemporal parameters (stages/gait.py) and `pcnet gait` (pipeline/gait.py).

Real motion: the Bandai walk-turn clip of tests/fixtures/mocap_small.npz (120 frames at 30 fps,
about 3.5 m walked while turning), its in-place raise-both-hands clip, and the twelve Bandai
test-split clips of bandai_test_clips.npz (fixtures/README.md).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pcnet.pipeline.cli import main
from pcnet.stages.core.conventions import L_ANKLE, PELVIS, R_ANKLE
from pcnet.stages.gait import gait_events, GaitError, SIDES, steps, summarise

FIXTURES = Path(__file__).resolve().parent / "fixtures"
WALK = "dataset-2_walk-turn-left_active_001"
FPS = 30.0


def _clip(name: str, file: str = "mocap_small.npz") -> np.ndarray:
    with np.load(FIXTURES / file) as d:
        return np.asarray(d[name], np.float64)


def _walk_summary(joints: np.ndarray, fps: float = FPS):
    events = gait_events(joints, fps)
    step_list = steps(events, joints, np.ones(len(joints), bool))
    return events, step_list, summarise(events, step_list)


def test_a_walks_strikes_alternate_and_land_near_the_ground():
    joints = _clip(WALK)
    events, step_list, summary = _walk_summary(joints)
    order = [s.side for s in step_list]
    assert len(order) >= 6 and all(a != b for a, b in zip(order, order[1:])), order
    lowest = {"left": np.nanmin(joints[:, L_ANKLE, 1]), "right": np.nanmin(joints[:, R_ANKLE, 1])}
    for s in step_list:  # a strike: the foot on the ground, not mid-swing (swing lifts the ankle ~10 cm)
        ankle = joints[int(round(s.time_s * FPS)), L_ANKLE if s.side == "left" else R_ANKLE, 1]
        assert ankle - lowest[s.side] < 0.04, (s, ankle)
    # every foot off lies inside the stance that the strike before it began
    for side in SIDES:
        strikes, offs = events.foot(side).strikes_s, events.foot(side).offs_s
        for a, b in zip(strikes, strikes[1:]):
            assert ((offs > a) & (offs < b)).sum() == 1
    assert 55 < summary.left.stance_percent < 70 and 55 < summary.right.stance_percent < 70  # walking: ~60 %


@pytest.mark.parametrize("name", [WALK, "dataset-2_run_masculine_037"])
def test_footprint_step_lengths_give_the_pelvis_speed(name):
    """Step length (footprint to footprint) and step time give the speed at which the pelvis
    itself travels: two independent readings of one walk or run. They agree within 6 % on
    this turning walk's five steps (its curve) and 2 % on the straight run; the ankles'
    separation at the strikes, which the footprints replaced, falls further short."""
    joints = _clip(name)
    _, step_list, summary = _walk_summary(joints)
    timed = [s for s in step_list if np.isfinite(s.step_length)]
    t0, t1 = timed[0].time_s - timed[0].step_time_s, timed[-1].time_s
    k = np.arange(int(round(t0 * FPS)), int(round(t1 * FPS)) + 1)
    path = np.linalg.norm(np.diff(joints[k, PELVIS][:, [0, 2]], axis=0), axis=1).sum()
    assert summary.walking_speed == pytest.approx(path / (k[-1] - k[0]) * FPS, rel=0.07 if name == WALK else 0.02)
    if name != WALK:
        return
    assert 0.5 < np.mean([s.step_length for s in timed]) < 1.0
    # without a path (a root-relative pose) there is no step length, and no speed
    unseen = summarise(*(lambda e: (e, steps(e, joints, np.zeros(len(joints), bool))))(gait_events(joints, FPS)))
    assert np.isnan(unseen.walking_speed) and np.isnan(unseen.left.step_length)
    assert unseen.cadence_steps_per_min == pytest.approx(summary.cadence_steps_per_min)


def test_events_hold_between_frames_at_half_the_rate():
    """The three-point refinement: every other frame (15 fps) moves the strikes by less than
    half a frame at 15 fps (a frame's quantisation alone would be up to 33 ms)."""
    joints = _clip(WALK)
    full, half = gait_events(joints, FPS), gait_events(joints[::2], FPS / 2)
    for side in SIDES:
        a, b = full.foot(side).strikes_s, half.foot(side).strikes_s
        near = np.array([np.min(np.abs(a - t)) for t in b])
        assert near.max() < 0.5 / (FPS / 2), (side, near)
        assert np.median(near) < 0.02, (side, near)


@pytest.mark.parametrize("name,file", [("dataset-2_raise-up-both-hands_elderly_024", "mocap_small.npz"),
                                       ("dataset-1_bow_active_001", "bandai_small.npz"),
                                       ("dataset-2_wave-both-hands_active_032", "bandai_test_clips.npz")])
def test_motion_in_place_is_refused(name, file):
    with pytest.raises(GaitError, match="expected a walk or run"):
        gait_events(_clip(name, file), FPS)


def test_a_stance_with_one_foot_always_ahead_has_no_steps():
    """A boxer's or fencer's stance: the feet in antiphase, one always ahead. Built from the
    walk with its right ankle moved a metre back (more than the feet ever part): its maxima come behind the left foot."""
    joints = _clip(WALK)
    from pcnet.stages.gait import forward_axes

    moved = joints.copy()
    moved[:, R_ANKLE] -= 1.0 * forward_axes(joints)
    with pytest.raises(GaitError, match="expected steps"):
        gait_events(moved, FPS)


def test_a_walk_backward_is_refused_and_a_few_backward_steps_are_noted():
    """A gait trial's backward walk read a speed of -1.06 m/s with strikes and offs swapped,
    unflagged. The walk played backward is a backward walk (the body faces where it came
    from): its steps all go backward and it is refused; the walk with a reversed stretch at
    its end keeps a minority of backward steps, which the note counts."""
    from pcnet.stages.gait import backward_steps, check_forward

    joints = _clip(WALK)
    _, forward_steps, _ = _walk_summary(joints)
    assert check_forward(forward_steps) is None and backward_steps(forward_steps)[0] == 0
    reversed_walk = joints[::-1].copy()
    _, back, _ = _walk_summary(reversed_walk)
    with pytest.raises(GaitError, match=r"expected a walk or run forward, got (\d+) of \1 steps going backward"):
        check_forward(back)
    there_and_back = np.concatenate([joints, joints[::-1][:45]])
    _, mixed, _ = _walk_summary(there_and_back)
    backward, measured = backward_steps(mixed)
    assert 0 < 2 * backward <= measured
    assert check_forward(mixed).startswith(f"{backward} of {measured} steps go backward")


def test_a_recording_without_a_stride_is_refused():
    """A gait trial's 2.3 s walk kept one strike of each foot: a cadence from one step, no
    stride, stance or gait cycle. A foot must strike twice."""
    joints = _clip(WALK)
    events, _, _ = _walk_summary(joints)
    first = {side: events.foot(side).strikes_s[0] for side in SIDES}
    # cut after the first strike of each foot, plus half a stride: no foot strikes twice
    end = int((max(first.values()) + events.stride_period_s * 0.75) * FPS)
    with pytest.raises(GaitError, match=r"expected at least one stride \(a foot striking twice"):
        gait_events(joints[:end], FPS)


def test_bad_input():
    with pytest.raises(GaitError, match="expected a walk or run"):
        gait_events(np.full((60, 17, 3), np.nan), FPS)
    with pytest.raises(ValueError, match=r"expected \(T, 17, 3\)"):
        gait_events(np.zeros((60, 16, 3)), FPS)
    with pytest.raises(ValueError, match="positive frame rate"):
        gait_events(_clip(WALK), 0.0)
    # a one-frame run read "a correlation of +nan over 1 frames"
    with pytest.raises(GaitError, match="expected a walk or run, several frames with both ankles, got 1$"):
        gait_events(_clip(WALK)[:1], FPS)


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def walk_run(tmp_path_factory) -> Path:
    """`pcnet run --mode sequence` on the walk filmed by one static camera (VideoPose3D 3D,
    AlphaPose 2D, a black video for the image size: benchmarks/world_validation.py's inputs)."""
    pytest.importorskip("cv2", reason="OpenCV writes the black video that gives the image size")
    from benchmarks.world_validation import focal_route, make_inputs, place_camera, run_pcnet, truth_world

    world = truth_world(_clip(WALK), FPS)
    cam = place_camera(world, np.random.default_rng(0))
    rel, px = make_inputs(world, cam, FPS, False, np.random.default_rng(1))
    out, _ = run_pcnet(tmp_path_factory.mktemp("gait_run"), rel, px, FPS, False, focal_route()[0], True,
                       mode="sequence")
    return out


@pytest.mark.slow
def test_pcnet_gait_on_a_run(walk_run):
    res = _cli("gait", walk_run)
    assert res.exit_code == 0, res.output
    assert "cadence" in res.output and "steps/min" in res.output
    summary = json.loads((walk_run / "gait.json").read_text())
    _, _, truth = _walk_summary(_clip(WALK))
    assert summary["cadence_steps_per_min"] == pytest.approx(truth.cadence_steps_per_min, rel=0.03)
    assert summary["walking_speed_per_s"] == pytest.approx(truth.walking_speed, rel=0.1)
    assert summary["root_path"] == "from 2D keypoints" and summary["length_unit"] == "m"
    cycles = (walk_run / "gait_cycles.csv").read_text().splitlines()
    assert cycles[0] == "side,angle,stride,strike_time_s,percent,value_deg" and len(cycles) > 6 * 101
    assert (walk_run / "gait_cycles.png").stat().st_size > 10_000
    rows = (walk_run / "gait_events.csv").read_text().splitlines()
    assert rows[0] == "time_s,frame,side,event,step_time_s,stride_time_s,stance_percent,step_length_m"
    assert {r.split(",")[3] for r in rows[1:]} == {"foot_strike", "foot_off"}
    report = (walk_run / "report.md").read_text()
    assert report.count("## Gait (pcnet gait)") == 1
    again = _cli("gait", walk_run)  # earlier outputs: refused without --overwrite, replaced with it
    assert again.exit_code == 1 and "pass --overwrite" in again.output
    assert _cli("gait", walk_run, "--overwrite").exit_code == 0
    assert (walk_run / "report.md").read_text().count("## Gait (pcnet gait)") == 1
    # pcnet still owns the folder: `pcnet run --overwrite` may replace it
    from pcnet.pipeline.outdir import is_owned
    assert all(is_owned(walk_run, n) for n in ("gait.json", "gait_events.csv", "report.md"))
    (walk_run / "gait.json").write_text("{}\n")  # someone else's edit: not replaced
    foreign = _cli("gait", walk_run, "--overwrite")
    assert foreign.exit_code == 1 and "written or changed by someone else" in foreign.output


@pytest.mark.slow
def test_pcnet_gait_on_several_folders_writes_a_study_table(walk_run, tmp_path):
    import shutil

    walk_run = Path(shutil.copytree(walk_run, tmp_path / "run"))  # the other test's gait files may be there
    for name in ("gait.json", "gait_events.csv", "gait_cycles.csv", "gait_cycles.png"):
        (walk_run / name).unlink(missing_ok=True)
    table = tmp_path / "study.csv"
    res = _cli("gait", walk_run, tmp_path / "none", "--table", table, "--overwrite")
    assert res.exit_code == 1, res.output  # one folder failed: the other is still done
    import csv
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["folder"] for r in rows] == [str(walk_run), str(tmp_path / "none")]
    assert float(rows[0]["cadence_steps_per_min"]) == pytest.approx(
        json.loads((walk_run / "gait.json").read_text())["cadence_steps_per_min"])
    assert rows[0]["refused"] == "" and rows[1]["cadence_steps_per_min"] == ""
    assert "expected a `pcnet run` output folder, got no folder" in rows[1]["refused"]
    again = _cli("gait", walk_run, "--table", table, "--overwrite")
    assert again.exit_code == 0, again.output  # its own table is replaced
    table.write_text("a,b\n1,2\n")  # someone else's file: not replaced
    foreign = _cli("gait", walk_run, "--table", table, "--overwrite")
    assert foreign.exit_code == 1 and "that it did not write" in foreign.output


def test_another_report_section_survives_a_new_gait_section(tmp_path):
    """report.md's appended sections (OpenSim, gait) replace only their own heading's text."""
    from pcnet.pipeline.cli import _section_into_report
    from pcnet.pipeline.outdir import _write_marker, register_files

    (tmp_path / "report.md").write_text("# run\n\nbody\n")
    _write_marker(tmp_path, "done")
    register_files(tmp_path, ["report.md"])
    _section_into_report(tmp_path, "## A", "## A\n\nfirst\n")
    register_files(tmp_path, ["report.md"])
    _section_into_report(tmp_path, "## B", "## B\n\nb\n")
    register_files(tmp_path, ["report.md"])
    _section_into_report(tmp_path, "## A", "## A\n\nsecond\n")
    text = (tmp_path / "report.md").read_text()
    assert text == "# run\n\nbody\n\n## B\n\nb\n\n## A\n\nsecond\n", text


def _run_folder(folder: Path, joints: np.ndarray, segment: np.ndarray, root_path: str | None = None) -> Path:
    """A run folder with only what ``pcnet gait`` reads: canonical.npz's fields (no path: NaN
    pelvis_path_std_world) and kinematics.csv's hip and knee angles (the run's code,
    stages/kinematics.py: compute_kinematics)."""
    from pcnet.pipeline.gait import CYCLE_ANGLES
    from pcnet.stages.kinematics import compute_kinematics

    folder.mkdir()
    np.savez(folder / "canonical.npz", joints_world=joints, fps=FPS, units="m",
             pelvis_path_std_world=np.full((len(joints), 3), np.nan), track_segment=segment,
             report=json.dumps({"root_path": root_path, "cutoff_hz": 6.0}))
    angles = compute_kinematics(joints, FPS).angles
    names = [f"{side}_{a}" for side in SIDES for a in CYCLE_ANGLES]
    rows = [",".join(f"{n}_deg" for n in names)] + [
        ",".join("" if np.isnan(angles[n][t]) else f"{angles[n][t]:.3f}" for n in names) for t in range(len(joints))]
    (folder / "kinematics.csv").write_text("\n".join(rows) + "\n")
    return folder


def test_the_knee_flexes_most_in_swing(tmp_path):
    """The gait cycle's shape: cut at the strikes, the knee's largest flexion comes after the
    foot off (in swing), the hip's largest flexion near the strikes (the leg reaching forward);
    strikes and offs swapped, or cycles cut elsewhere, would put them wrong."""
    from pcnet.pipeline.gait import analyse

    result = analyse(_run_folder(tmp_path / "r", _clip(WALK), np.zeros(0)))
    for side in SIDES:
        stance = getattr(result.summary, side).stance_percent
        knee = np.nanmean(result.cycles[f"{side}_knee_flexion_deg"], axis=0)
        hip = np.nanmean(result.cycles[f"{side}_hip_flexion_deg"], axis=0)
        assert result.cycles[f"{side}_knee_flexion_deg"].shape[1] == 101
        assert stance < np.argmax(knee) < 95, (side, stance, np.argmax(knee))
        assert np.argmax(hip) > 80 or np.argmax(hip) < 10, (side, np.argmax(hip))
        assert np.argmin(hip) == pytest.approx(stance, abs=15)  # the hip most extended at foot off


def test_a_run_without_2d_keypoints_has_cadence_but_no_step_length(tmp_path):
    """No 2D keypoints: track_segment is empty (0,) and the pelvis path not observable (a
    trial's cycling run crashed here)."""
    from pcnet.pipeline.gait import analyse

    result = analyse(_run_folder(tmp_path / "r", _clip(WALK), np.zeros(0), "not observable"))
    assert "no pelvis path" in result.length_empty_because
    assert np.isnan(result.summary.walking_speed) and result.summary.cadence_steps_per_min > 60
    assert result.run.one_person_frames == len(_clip(WALK))


def test_only_the_longest_stretch_of_a_jumping_2d_track_is_analysed(tmp_path):
    """A 2D track that jumped to another person for the first 30 frames: those frames are
    another body's, left out as world.trc leaves them out."""
    from pcnet.pipeline.gait import analyse

    joints = _clip(WALK)
    segment = np.where(np.arange(len(joints)) < 30, 0.0, 1.0)
    segment[:3] = np.nan  # frames without a 2D position
    result = analyse(_run_folder(tmp_path / "r", joints, segment))
    assert result.run.one_person_frames == len(joints) - 30
    assert np.isnan(result.run.joints[:30]).all() and np.isfinite(result.run.joints[30:, 0]).all()
    assert min(s.time_s for s in result.steps) > 30 / FPS


def test_pcnet_gait_refuses_what_it_cannot_read(tmp_path):
    res = _cli("gait", tmp_path / "none")
    assert res.exit_code == 1 and "expected a `pcnet run` output folder, got no folder" in res.output
    res = _cli("gait", tmp_path)
    assert res.exit_code == 1 and "with canonical.npz, got none" in res.output
    np.savez(tmp_path / "canonical.npz", joints_world=np.zeros((0, 17, 3)), fps=30.0, units="m",
             pelvis_path_std_world=np.zeros((0, 3)), report=json.dumps({"root_path": None}))
    res = _cli("gait", tmp_path)
    assert res.exit_code == 1 and "field 'joints_world': expected world-frame poses" in res.output
    assert len(res.output.strip().splitlines()) == 1
    walk = _clip(WALK)
    for field, value, said in (("fps", np.zeros(3), "field 'fps': expected one positive frame rate, got shape (3,)"),
                               ("fps", 0.0, "field 'fps': expected one positive frame rate, got 0.0"),
                               ("report", "not json", "field 'report': expected the run's report")):
        fields = dict(joints_world=walk, fps=FPS, units="m", pelvis_path_std_world=np.zeros((len(walk), 3)),
                      report=json.dumps({}))
        np.savez(tmp_path / "canonical.npz", **{**fields, field: value})
        res = _cli("gait", tmp_path)
        assert res.exit_code == 1 and said in res.output and "Traceback" not in res.output, res.output


def test_a_stride_across_a_gap_is_not_one(tmp_path):
    """The person out of view for half a second in mid-walk: no step, stride or cycle spans the
    gap (the walk, the gap, then the walk again: each side has strikes)."""
    from pcnet.pipeline.gait import analyse

    walk = _clip(WALK)
    joints = np.concatenate([walk, np.full((15, 17, 3), np.nan), walk])
    result = analyse(_run_folder(tmp_path / "r", joints, np.zeros(0)))
    gap = (len(walk) / FPS, (len(walk) + 15) / FPS)
    for side in SIDES:
        strikes = result.events.foot(side).strikes_s
        assert (strikes < gap[0]).sum() >= 2 and (strikes > gap[1]).sum() >= 2
    for s in result.steps:
        for start in (s.time_s - s.step_time_s, s.time_s):
            end = s.time_s if start < s.time_s else s.time_s + s.stride_time_s
            if np.isfinite(start) and np.isfinite(end):
                assert end <= gap[0] or start >= gap[1], s
    assert max(s.stride_time_s for s in result.steps if np.isfinite(s.stride_time_s)) < 1.5
    for side in SIDES:
        strikes = result.events.foot(side).strikes_s
        rows = result.cycles[f"{side}_knee_flexion_deg"]
        for (a, b), row in zip(zip(strikes, strikes[1:]), rows):
            assert np.isnan(row).all() == (a < gap[1] and b > gap[0])


def test_pcnet_gait_names_a_kinematics_csv_without_the_angles(tmp_path):
    folder = _run_folder(tmp_path / "r", _clip(WALK), np.zeros(0))
    (folder / "kinematics.csv").write_text("frame,time_s\n0,0.0\n")
    res = _cli("gait", folder)
    assert res.exit_code == 1
    assert "kinematics.csv: field 'left_hip_flexion_deg': expected the ISB joint angle column" in res.output
    assert not (folder / "gait.json").exists()  # nothing half-written
