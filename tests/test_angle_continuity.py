"""Angles continuous in time (issue 51): no 360-deg wraps and no 180-deg knee-reading switches
between consecutive present frames; NaN stays NaN; an angle the input layout cannot measure
(trunk flexion to the pelvis without a spine joint of its own) is empty with a summary note."""

from __future__ import annotations

import csv

import numpy as np
from scipy.spatial.transform import Rotation

from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import run_pipeline
from pcnet.stages.kinematics import (PERIODIC_ANGLES, compute_kinematics, continuous_angles, kinematics_chunks)

from conftest import FIXTURES, shared

FPS = 30.0
MAX_STEP_DEG = 90.0


def _somersault(frames: int = 100, turn_deg: float = 300.0) -> np.ndarray:
    """The real standing yoga poses (VideoPose3D, Tadasana) turned forward about the
    subject's left-right axis by an angle growing linearly to ``turn_deg``: through lying
    prone, head down and lying supine, as a roll would take them (Y up, metres)."""
    X = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:frames].astype(np.float64)
    X = X * np.array([1.0, -1.0, -1.0])  # camera (x right, y down, z forward) -> y up
    X = X - X[:, :1]
    hip = np.median(X[:, 1] - X[:, 4], axis=0)  # right hip - left hip: the roll axis
    axis = hip / np.linalg.norm(hip)
    angles = np.radians(np.linspace(0.0, turn_deg, frames))
    R = Rotation.from_rotvec(angles[:, None] * axis).as_matrix()
    return np.einsum("tij,tkj->tki", R, X)


def _max_step(angles) -> dict[str, float]:
    out = {}
    for name, v in angles.items():
        d = np.abs(np.diff(np.asarray(v, np.float64)))
        d = d[np.isfinite(d)]
        if d.size:
            out[name] = float(d.max())
    return out


def test_somersault_wraps_without_and_is_continuous_with_unwrapping():
    poses = _somersault()
    raw = compute_kinematics(poses, FPS, continuous=False).angles
    cont = compute_kinematics(poses, FPS).angles
    before, after = _max_step(raw), _max_step(cont)
    assert max(before.values()) > 300.0, before  # the per-frame decomposition wraps (the bug)
    assert max(after.values()) < MAX_STEP_DEG, {k: v for k, v in after.items() if v >= MAX_STEP_DEG}
    for name in raw:  # the same angles, only moved by whole turns (or the knee's other reading)
        a, b = np.asarray(raw[name]), np.asarray(cont[name])
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        ok = np.isfinite(a)
        if name.endswith(("hip_internal_rotation", "knee_flexion")):
            continue
        assert np.allclose(np.cos(np.radians(a[ok] - b[ok])), 1.0, atol=1e-9), name


def test_nan_gaps_stay_gaps_and_each_run_is_levelled():
    poses = _somersault()
    poses[40:43] = np.nan  # a gap: runs on either side are unwrapped and levelled separately
    poses[70, 2] = np.nan  # a missing right knee
    raw = compute_kinematics(poses, FPS, continuous=False).angles
    cont = compute_kinematics(poses, FPS).angles
    for name in raw:
        assert np.array_equal(np.isnan(raw[name]), np.isnan(cont[name])), name
        assert np.isnan(cont[name][40:43]).all(), name
    assert max(_max_step(cont).values()) < MAX_STEP_DEG
    for name, lower in PERIODIC_ANGLES.items():
        v = np.asarray(cont[name])
        for run in (v[:40], v[43:]):
            run = run[np.isfinite(run)]
            if run.size:
                assert lower < np.median(run) <= lower + 360.0, name


def test_chunks_continue_across_their_edges():
    poses = _somersault()
    whole = compute_kinematics(poses, FPS).angles
    chunks = list(kinematics_chunks(poses, FPS, chunk_frames=17))
    for name, v in whole.items():
        stitched = np.concatenate([np.asarray(k.angles[name]) for k in chunks])
        assert np.array_equal(np.isnan(stitched), np.isnan(v)), name
        assert max(_max_step({name: stitched}).values(), default=0.0) < MAX_STEP_DEG, name


def test_knee_reading_kept_over_a_run():
    # A real Kinect case (UTD-MHAD a01_s1_t1, right leg, frames 43-46): the per-frame rule
    # switched from a hyperextended knee with 70 deg hip rotation to a flexed knee with -110.
    rot = np.array([69.1, 69.8, -109.7, -109.3, np.nan, -109.0])
    knee = np.array([-6.7, -6.7, 6.7, 6.7, np.nan, 6.7])
    out = continuous_angles({"right_hip_internal_rotation": rot, "right_knee_flexion": knee})
    r, k = out["right_hip_internal_rotation"], out["right_knee_flexion"]
    assert np.isnan(r[4]) and np.isnan(k[4])
    assert np.abs(np.diff(r[:4])).max() < 5.0 and np.abs(np.diff(k[:4])).max() < 1e-9
    assert np.allclose(np.abs(k[np.isfinite(k)]), 6.7)
    # a knee bent beyond MAX_KNEE_HYPEREXTENSION_DEG is never read as hyperextended
    out = continuous_angles({"left_hip_internal_rotation": np.array([10.0, 20.0, -150.0]),
                             "left_knee_flexion_deg": np.array([40.0, 40.0, -40.0])})
    assert np.allclose(out["left_knee_flexion_deg"], 40.0)
    assert np.allclose(out["left_hip_internal_rotation"], [10.0, 20.0, 30.0])
    # ... not even inside a run whose reading continuity keeps: a real MotionBERT cyclist
    # (clip_b, right leg, frames 377-387) whose hip line turned 86 deg in one frame, under the
    # 90 deg step that changes the reading, had read a knee hyperextended by up to 101 deg
    out = continuous_angles({"right_hip_internal_rotation": np.array([-10.0, -11.0, -96.8, 80.0, 70.0]),
                             "right_knee_flexion": np.array([40.0, 30.0, -15.0, 64.5, 100.0])})
    assert np.allclose(out["right_knee_flexion"], [40.0, 30.0, -15.0, 64.5, 100.0])
    assert np.isnan(out["right_hip_internal_rotation"][3:]).all()  # the reading contradicts the knee there
    # one such frame in a steady run leaves a gap, not a 180 deg spike or a wound turn at a low rate (a review)
    for fps in (30.0, 5.0, None):
        out = continuous_angles({"right_hip_internal_rotation": np.array([-10.0, -11.0, -11.0, -12.0, -12.0, -13.0]),
                                 "right_knee_flexion": np.array([20.0, 20.0, -30.0, 20.0, 20.0, 20.0])}, fps=fps)
        np.testing.assert_allclose(out["right_hip_internal_rotation"], [-10.0, -11.0, np.nan, -12.0, -12.0, -13.0])
        np.testing.assert_allclose(out["right_knee_flexion"], [20.0, 20.0, 30.0, 20.0, 20.0, 20.0])


def test_angles_figure_draws_no_wrap():
    from pcnet.stages.sinks.plots import joint_angles_figure

    poses = _somersault()
    poses[40:43] = np.nan
    kin = compute_kinematics(poses, FPS)
    fig = joint_angles_figure(kin, FPS)
    drawn = 0
    for ax in fig.axes:
        for line in ax.get_lines():
            y = np.asarray(line.get_ydata(), np.float64)
            if y.size < 2 or not np.isfinite(y).any():
                continue
            drawn += 1
            d = np.abs(np.diff(y))
            assert np.nanmax(d) < MAX_STEP_DEG, line.get_label()
            assert np.isnan(y[40:43]).all(), line.get_label()  # the gap stays a gap
    assert drawn > 10


def _csv_angles(path) -> dict[str, np.ndarray]:
    rows = list(csv.reader(open(path)))
    cols = {h: np.array([float(r[j]) if r[j] not in ("", "nan") else np.nan for r in rows[1:]])
            for j, h in enumerate(rows[0]) if h.endswith("_deg") and h != "heading_deg"}
    return cols


def test_layout_without_spine_leaves_trunk_flexion_to_pelvis_empty(tmp_path):
    run = run_pipeline(RunConfig(lifter="mediapipe", lifter_output=str(FIXTURES / "mediapipe_blazepose33_f000-059.npz"),
                                 out=str(tmp_path / "mp"), recording=False), progress=False)
    angles = _csv_angles(tmp_path / "mp" / "kinematics.csv")
    assert np.isnan(angles["trunk_flexion_to_pelvis_deg"]).all()
    assert np.isfinite(angles["trunk_axial_rotation_to_pelvis_deg"]).any()
    notes = [n for n in run.notes if n.startswith("trunk_flexion_to_pelvis_deg left empty")]
    assert len(notes) == 1
    # and the data dictionary says so for this run (a user trial found only the generic definition)
    rows = {r[0]: r for r in csv.reader(open(tmp_path / "mp" / "kinematics_columns.csv"))}
    assert "empty in this run: the input's spine joint lies on the pelvis-thorax line" in \
        rows["trunk_flexion_to_pelvis_deg"][3]
    assert "empty in this run" not in rows["trunk_axial_rotation_to_pelvis_deg"][3]


def test_lifter_with_spine_keeps_trunk_flexion_to_pelvis(tmp_path):
    run = run_pipeline(RunConfig(lifter="videopose3d", lifter_output=str(FIXTURES / "yoga_Abhay_Shavasana_f200-299.npy"),
                                 fps=30, out=str(tmp_path / "vp"), recording=False), progress=False)
    angles = _csv_angles(tmp_path / "vp" / "kinematics.csv")
    assert np.isfinite(angles["trunk_flexion_to_pelvis_deg"]).any()
    assert not any("trunk_flexion_to_pelvis_deg left empty" in n for n in run.notes)


def test_kinect_recording_has_no_wrap(tmp_path):
    path = shared("real", "utd_mhad_imu", "a01_s1_t1.npz")
    run_pipeline(RunConfig(lifter="kinect_v1", lifter_output=str(path), out=str(tmp_path / "k"), recording=False),
                 progress=False)
    angles = _csv_angles(tmp_path / "k" / "kinematics.csv")
    steps = _max_step(angles)
    # before issue 51: right_upper_arm_frontal_inclination 357 deg, right_hip_internal_rotation 180 deg
    assert max(steps.values()) < MAX_STEP_DEG, steps
    assert np.isnan(angles["trunk_flexion_to_pelvis_deg"]).all()


def test_a_step_faster_than_any_training_motion_ends_the_run():
    # A lifter's arm flipping between two readings (the pattern of a real MotionBERT cycling
    # clip's occluded left arm): unwrapped through the flips, the run's median level put its
    # first frames, the arm hanging at -16 deg, a whole turn away at -376.
    x = np.concatenate([np.full(10, -16.0), np.full(10, 154.0), np.full(30, -40.0)])
    name = "left_upper_arm_sagittal_inclination"
    through = continuous_angles({name: x})[name]
    assert np.allclose(through[:10], -376.0)  # without a frame rate no step ends a run
    split = continuous_angles({name: x}, fps=FPS)[name]
    assert np.allclose(split, x)  # 170 and 166 deg in a frame: far beyond the fitted 106 at 30 fps
    # a chunk's first frame continues the previous chunk only within the limit
    assert continuous_angles({name: x[10:]}, {name: -16.0 + 360.0}, fps=FPS)[name][0] == 154.0
    assert continuous_angles({name: x[:10]}, {name: 344.0 - 10.0}, fps=FPS)[name][0] == 344.0


def test_the_shipped_angle_speed_limits_are_the_printed_fit():
    from pathlib import Path

    from pcnet.stages.kinematics import angle_speed_limits

    printed = {}
    for line in (Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "fit_angle_speeds.txt").read_text().splitlines():
        parts = line.split()
        if len(parts) > 3 and parts[0] in angle_speed_limits():
            printed[parts[0]] = float(parts[1])
    assert printed == dict(angle_speed_limits())


def test_a_fast_step_that_winds_nothing_keeps_the_run_continuous():
    # A lying thigh's frontal inclination near +-180 stepping 33 deg in a frame (a real VideoPose3D
    # Shavasana, faster than any training motion's 28 at 30 fps): no value winds half a turn
    # beyond the range, so the run stays continuous (split there, it had jumped 327 deg).
    x = np.concatenate([np.full(10, 151.8), np.full(10, -175.5)])
    out = continuous_angles({"right_thigh_frontal_inclination": x}, fps=FPS)["right_thigh_frontal_inclination"]
    assert np.allclose(out, np.concatenate([np.full(10, 151.8), np.full(10, 184.5)]))


def test_a_long_session_of_joined_takes_reads_each_pose_within_a_turn():
    # A long-recording trial joined real takes into a ten-minute file: at each join the arm's
    # inclination swept slower than any training motion across the wrap, and unwrapping wound a
    # turn each time, so one pose read 131 deg in one take and 491 in its repeat (-186 to +497
    # over the session). A run wound beyond half a turn past its range is split at its largest
    # steps until every piece keeps within it.
    hold_a, hold_b = np.full(40, 130.0), np.full(40, -30.0)
    up_a = np.linspace(130.0, 330.0, 8)[1:-1]  # +200 deg in 7 steps of 28.6 (under the 106 limit)
    up_b = np.linspace(-30.0, 130.0, 8)[1:-1]
    cycle = np.concatenate([hold_a, up_a, hold_b, up_b])
    x = _wrap180_array(np.tile(cycle, 12))  # as read per frame: within one 360-deg window
    name = "left_upper_arm_sagittal_inclination"
    lower = PERIODIC_ANGLES[name]
    for out in (continuous_angles({name: x}, fps=FPS)[name],
                np.concatenate([k.angles[name] for k in _chunked_angles(name, x)])):
        assert np.all((out > lower - 180.0) & (out <= lower + 540.0)), (out.min(), out.max())
        np.testing.assert_allclose((out - x + 180.0) % 360.0 - 180.0, 0.0, atol=1e-9)  # only whole turns added
        holds = np.tile(np.r_[np.ones(40, bool), np.zeros(6, bool), np.ones(40, bool), np.zeros(6, bool)], 12)
        assert set(np.round(out[holds]).astype(int)) <= {130, -30, 330, -230}


def _wrap180_array(x: np.ndarray) -> np.ndarray:
    return (x + 180.0) % 360.0 - 180.0


def _chunked_angles(name: str, x: np.ndarray):
    """``continuous_angles`` over chunks of 100 frames, each continuing the previous, as
    ``kinematics_chunks`` runs it on a long recording."""
    from types import SimpleNamespace

    previous = None
    for start in range(0, len(x), 100):
        angles = continuous_angles({name: x[start:start + 100]}, previous, FPS)
        previous = {name: float(angles[name][-1])}
        yield SimpleNamespace(angles=angles)
