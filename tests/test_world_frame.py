"""One fixed world frame per recording (stages/world_frame.py) and kinematics in it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES

from pcnet.models.datasets import load_mocap
from pcnet.stages.core.canonical import canonical_rotation, to_canonical
from pcnet.stages.core.conventions import H36M_JOINTS, PELVIS
from pcnet.stages.core.errors import InputError
from pcnet.stages.flags import shortened
from pcnet.stages.kinematics import compute_kinematics
from pcnet.stages.core.rotations import axis_rotation
from pcnet.stages.floor import ANKLE_CLEARANCE_LEG
from pcnet.stages.scale import mean_leg_length
from pcnet.stages.world_frame import to_world, to_world_floor, world_frame

FPS = 30.0
R_WRIST = H36M_JOINTS.index("right_wrist")
CAMERA = axis_rotation("x", np.radians(-15.0)) @ axis_rotation("y", np.radians(40.0))  # world -> camera, tilted


def _filmed(world_joints: np.ndarray):
    """Pelvis-centred camera-frame poses of mocap ``(T, 17, 3)`` (Y up) seen by ``CAMERA``,
    with the true canonical->camera rotations."""
    rel = world_joints - world_joints[:, PELVIS : PELVIS + 1]
    cam = rel @ CAMERA.T
    R, valid = canonical_rotation(cam, CAMERA @ np.array([0.0, 1.0, 0.0]))
    assert valid.all()
    return cam, R


def test_world_frame_is_the_mocap_frame_turned_about_up_with_the_feet_on_the_floor():
    J = load_mocap(FIXTURES / "bandai_small.npz")[0].joints.astype(np.float64)
    cam, R = _filmed(J)
    frame = world_frame(R, np.ones(len(R), bool), FPS)
    W = frame.rotation
    np.testing.assert_allclose(W @ W.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(W), 1.0, atol=1e-12)
    turn = W @ CAMERA  # mocap world -> pcnet world: a turn about the vertical only
    np.testing.assert_allclose(turn[1], [0.0, 1.0, 0.0], atol=1e-9)
    assert frame.heading_frames == min(len(R), int(FPS))
    world, floor = to_world_floor(cam, frame)
    assert floor.kind == "per frame" and floor.reason == "no pelvis path" and floor.n_contacts == 0
    rel = J - J[:, PELVIS : PELVIS + 1]
    # heights above the lowest joint centre are the mocap's, which stands the ankle clearance
    # above the ground; the pelvis has no horizontal path
    clearance = ANKLE_CLEARANCE_LEG * np.median(mean_leg_length(J))
    assert floor.clearance == pytest.approx(clearance, rel=1e-9) and 0.09 < clearance < 0.12
    expected_y = rel[..., 1] - rel[..., 1].min(axis=1, keepdims=True) + clearance
    np.testing.assert_allclose(to_world(cam, frame), world, atol=0)  # the same poses without the Floor
    np.testing.assert_allclose(world[..., 1], expected_y, atol=1e-9)
    np.testing.assert_allclose(world[:, PELVIS, [0, 2]], 0.0, atol=1e-12)
    # +X is the subject's forward at the start: the first frames' canonical X has no sideways part
    forward = (W @ R[: int(FPS), :, 0].T).T
    assert abs(np.mean(forward[:, 2])) < 1e-9 and np.mean(forward[:, 0]) > 0.9


def test_a_subject_turning_on_the_spot_moves_in_the_world_frame_but_not_in_the_canonical_one():
    """The physics the world frame exists for: a body turning at 90 deg/s about the vertical
    has wrists that move (speed = omega x radius); the canonical frame turns with the pelvis,
    so there the wrist stands still (a rotating-frame artefact)."""
    J = load_mocap(FIXTURES / "bandai_small.npz")[0].joints.astype(np.float64)
    pose = J[0] - J[0, PELVIS]
    T, omega = 90, np.radians(90.0)
    turning = np.stack([pose @ axis_rotation("y", omega * t / FPS).T for t in range(T)])
    cam, R = _filmed(turning)
    world = to_world(cam, world_frame(R, np.ones(T, bool), FPS))
    kin_world = compute_kinematics(world, FPS, cutoff_hz=None)
    kin_canon = compute_kinematics(to_canonical(cam, R), FPS, cutoff_hz=None)
    radius = np.hypot(pose[R_WRIST, 0], pose[R_WRIST, 2])
    inner = slice(5, T - 5)
    np.testing.assert_allclose(kin_world.speed[inner, R_WRIST], omega * radius, rtol=2e-3)
    assert np.nanmax(kin_canon.speed[inner, R_WRIST]) < 1e-6
    # joint angles do not depend on the frame they are computed in
    for name, angle in kin_world.angles.items():
        np.testing.assert_allclose(angle, kin_canon.angles[name], atol=1e-4, err_msg=name)


def test_world_frame_refuses_what_has_no_up_or_heading():
    R = np.tile(np.eye(3), (10, 1, 1))
    with pytest.raises(InputError, match="no valid frame"):
        world_frame(R, np.zeros(10, bool), FPS)
    lying_face_up = np.tile(axis_rotation("z", np.radians(90.0)) @ axis_rotation("x", np.radians(90.0)), (10, 1, 1))
    lying_face_up[:, :, 1] = lying_face_up[:, :, 0]  # forward along the up: no horizontal part
    with pytest.raises(InputError, match="no horizontal part"):
        world_frame(lying_face_up, np.ones(10, bool), FPS)


def test_missing_joints_stay_missing_and_an_empty_frame_stays_nan():
    J = load_mocap(FIXTURES / "bandai_small.npz")[0].joints[:20].astype(np.float64)
    cam, R = _filmed(J)
    cam[3, R_WRIST] = np.nan
    cam[7] = np.nan
    world = to_world(cam, world_frame(R, np.ones(20, bool), FPS))
    assert np.isnan(world[3, R_WRIST]).all() and np.isfinite(np.delete(world[3], R_WRIST, 0)).all()
    assert np.isnan(world[7]).all()


def test_a_runs_flight_frames_are_not_counted_as_stance_contacts():
    """``Floor.n_contacts`` counts the frames that weighed in the ground fit: a real run's
    flight apexes (the lowest joint 8 cm or more above its lowest, by the mocap itself) are
    not among them (it counted every frame with an ankle), while a walk, always on a foot,
    keeps nearly all of its frames."""
    for clip, kept in (("dataset-2_run_masculine_037", None), ("dataset-2_walk-turn-left_active_001", 0.9)):
        with np.load(FIXTURES / "mocap_small.npz") as d:
            J = d[clip].astype(np.float64)  # real, metres, Y up
        cam, R = _filmed(J)
        root_cam = J[:, PELVIS] @ CAMERA.T + np.array([0.1, -0.2, 3.0])
        _, floor = to_world_floor(cam, world_frame(R, np.ones(len(R), bool), FPS), root_cam)
        assert floor.kind == "plane", clip
        lowest = J[..., 1].min(axis=1)
        if kept is None:
            flight = int(np.sum(lowest - lowest.min() >= 0.08))
            assert flight >= 5 and floor.n_contacts <= len(J) - flight, (floor.n_contacts, flight)
        else:
            assert kept * len(J) <= floor.n_contacts <= len(J), floor.n_contacts


def test_a_measured_root_path_is_kept_above_one_floor():
    """A depth sensor measures the pelvis (Poses3D.root_translation): the world frame keeps the
    real walk's path (turned about the vertical, starting at x = z = 0) and one floor for the
    recording, so a frame's lowest joint may leave it (swing, jumps) instead of being pinned."""
    with np.load(FIXTURES / "mocap_small.npz") as d:
        J = d["dataset-2_walk-turn-left_active_001"].astype(np.float64)  # real walk, metres, Y up
    cam, R = _filmed(J)
    root_cam = J[:, PELVIS] @ CAMERA.T + np.array([0.1, -0.2, 3.0])  # the sensor 3 m away
    frame = world_frame(R, np.ones(len(R), bool), FPS)
    world, floor = to_world_floor(cam, frame, root_cam)
    assert floor.kind == "plane" and floor.n_contacts >= len(J) // 3 and floor.residual < 0.02
    turn = frame.rotation @ CAMERA
    truth = (J - J[0, PELVIS] * np.array([1.0, 0.0, 1.0])) @ turn.T  # the mocap's ground is y = 0
    # the poses are the truth up to one vertical offset: the fitted ground's error, within 2 cm
    offset = world[..., 1] - truth[..., 1]
    np.testing.assert_allclose(offset, offset[0, 0], atol=1e-9)
    np.testing.assert_allclose(world[..., [0, 2]], truth[..., [0, 2]], atol=1e-9)
    assert abs(offset[0, 0]) < 0.02, f"ground {100 * offset[0, 0]:.1f} cm off"
    path = np.linalg.norm(world[-1, PELVIS, [0, 2]] - world[0, PELVIS, [0, 2]])
    assert path > 2.0  # the walk covers metres, which a root-relative lifter cannot show
    assert np.ptp(world[..., 1].min(axis=1)) > 0.01  # one floor: the lowest joint varies per frame
    missing = root_cam.copy()
    missing[5] = np.nan
    assert np.isnan(to_world(cam, frame, missing)[5]).all() and np.isfinite(to_world(cam, frame, missing)[6]).all()
    with pytest.raises(InputError, match="root_cam must have shape"):
        to_world(cam, frame, root_cam[:-1])


def test_frames_without_visible_feet_keep_the_floor_they_last_saw():
    """No visible ankle (masked, out of the picture): the lowest joint is not on the floor, so
    the pelvis's height above the floor is carried over from the frames that saw the feet; with
    no ankle anywhere there is no floor and heights are relative to the pelvis."""
    from pcnet.stages.core.conventions import L_ANKLE, R_ANKLE
    from pcnet.stages.world_frame import floor_heights

    J = load_mocap(FIXTURES / "bandai_small.npz")[0].joints[:60].astype(np.float64)
    cam, R = _filmed(J)
    frame = world_frame(R, np.ones(len(R), bool), FPS)
    full = to_world(cam, frame)
    hidden = cam.copy()
    hidden[20:30, [L_ANKLE, R_ANKLE]] = np.nan
    world = to_world(hidden, frame)
    _, feet = floor_heights(hidden @ frame.rotation.T)
    assert not feet[20:30].any() and feet[:20].all() and feet[30:].all()
    np.testing.assert_allclose(world[:20], full[:20], atol=1e-12)
    # the pelvis height there is interpolated between frames 19 and 30, not the knee's height
    pelvis = world[:, PELVIS, 1]
    np.testing.assert_allclose(pelvis[20:30], np.interp(np.arange(20, 30), [19, 30], pelvis[[19, 30]]), atol=1e-9)
    assert np.all(np.abs(pelvis[20:30] - full[20:30, PELVIS, 1]) < 0.05)  # close to the truth
    no_feet = cam.copy()
    no_feet[:, [L_ANKLE, R_ANKLE]] = np.nan
    pelvis_level, floor = to_world_floor(no_feet, frame)
    np.testing.assert_allclose(pelvis_level[:, PELVIS, 1], 0.0, atol=1e-12)
    assert floor.kind == "pelvis" and floor.clearance == 0.0 and "no ankle" in floor.reason


def test_public_kinematics_functions_refuse_mismatched_arguments_in_one_line():
    """Real rectified poses (the bundled MotionBERT clip) given to the public functions with
    the mistakes an API user makes: each gets an InputError naming the argument, never a
    numpy error or an answer computed from the wrong frames."""
    from pcnet.pipeline.rectification import rectify
    from pcnet.stages.core.errors import InputError
    from pcnet.stages.kinematics import compute_kinematics, heading_free_angles, joint_angles
    from pcnet.stages.remap import mask_low_confidence

    X = np.load(Path(__file__).parents[1] / "pipeline" / "example_data" / "X3D.npy")
    res = rectify(X)
    for args, name in (((res.rotation, res.valid[:10], 30.0), "valid"), ((res.rotation, res.valid, 0.0), "fps"),
                       ((res.rotation[:, :2], res.valid, 30.0), "R"), ((res.rotation, res.valid, np.nan), "fps")):
        with pytest.raises(InputError, match=f"world frame: {name}"):
            world_frame(*args)
    frame = world_frame(res.rotation.tolist(), res.valid, 30.0)  # a list works as the array
    as_column = world_frame(res.rotation, res.valid.astype(np.uint8), 30.0)  # kinematics.csv's 0/1 valid
    np.testing.assert_array_equal(as_column.rotation, frame.rotation)
    with pytest.raises(InputError, match=r"world frame: valid must be a \(301,\) bool \(or 0/1\) array"):
        world_frame(res.rotation, res.valid * 2, 30.0)
    with pytest.raises(InputError, match=r"joints_cam must have shape \(T, 17, 3\), got \(17, 3\)"):
        to_world(X[0], frame)
    W = to_world(X - X[:, :1], frame)
    with pytest.raises(InputError, match=r"heading_free: expected \(301,\)"):
        joint_angles(W, heading_free_angles(W[:5]))
    with pytest.raises(InputError, match="poses: expected shape"):
        heading_free_angles(W[:, :16])
    with pytest.raises(InputError, match="fps: expected a frame rate"):
        compute_kinematics(W, float("inf"))
    with pytest.raises(InputError, match=r"threshold: expected a confidence in \[0, 1\], got 50"):
        mask_low_confidence(X, np.ones(X.shape[:2]), 50)


def _walk_filmed(name: str = "dataset-2_walk-turn-left_active_001"):
    """A real Bandai walk (metres, Y up, ground y = 0) filmed by ``CAMERA`` from 4 m: the
    root-relative camera poses, the camera-frame pelvis path, the world frame and the turn
    from the mocap's world to pcnet's."""
    with np.load(FIXTURES / "mocap_small.npz") as d:
        J = d[name].astype(np.float64)
    cam, R = _filmed(J)
    root_cam = J[:, PELVIS] @ CAMERA.T + np.array([0.1, -0.2, 4.0])
    frame = world_frame(R, np.ones(len(R), bool), FPS)
    return J, cam, root_cam, frame


def _ground_error(J: np.ndarray, world: np.ndarray) -> float:
    """Median over frames of (pelvis height over the fitted ground - its true height), m."""
    return float(np.median(world[:, PELVIS, 1] - J[:, PELVIS, 1]))


def test_one_ground_plane_from_a_real_walk_is_within_2_cm_and_a_flight_phase_does_not_lift_it():
    """A real walk with its true pelvis path: one plane for the recording, within 2 cm of the
    mocap's ground (y = 0; Bandai's stance ankle centres stand 0.117 m above it, the fitted
    clearance of a CMU-trained 0.80 m leg is 0.106 m: 1.1 cm). A 0.3 m jump inserted for 0.4 s
    (the whole body lifted along the path, a flight phase the ankles rest in at its top) does
    not move the ground: it is rejected, not averaged in; the old median-of-lowest-joint floor
    would also hold, but a per-frame floor would pull the body down to it."""
    J, cam, root_cam, frame = _walk_filmed()
    world, floor = to_world_floor(cam, frame, root_cam)
    assert floor.kind == "plane"
    assert abs(_ground_error(J, world)) < 0.02
    jump = J.copy()
    flight = slice(40, 52)  # 0.4 s at 30 fps
    jump[flight, :, 1] += 0.3 * np.sin(np.linspace(0, np.pi, 12))[:, None]
    world_jump, floor_jump = to_world_floor(cam, frame, jump[:, PELVIS] @ CAMERA.T + np.array([0.1, -0.2, 4.0]))
    assert floor_jump.kind == "plane"
    assert abs(_ground_error(jump, world_jump) - _ground_error(J, world)) < 0.005
    # in flight the body is above the ground it left, by the jump's height
    np.testing.assert_allclose(world_jump[flight, PELVIS, 1] - world[flight, PELVIS, 1],
                               jump[flight, PELVIS, 1] - J[flight, PELVIS, 1], atol=0.005)


def test_a_five_percent_depth_scale_error_of_the_path_barely_moves_the_ground():
    """A pelvis path recovered from 2D keypoints may err by a few % in depth, which scales it
    along the camera rays about the camera centre. Every stance contact then moves by about
    the same k (h_pelvis - h_camera): an offset of the pelvis path, not a slope, so the pelvis
    height over the fitted ground moves by less than 5 mm (here 1.8 and 2.5 mm; over held-out
    clips 1 mm on average, benchmarks/results/fit_floor.txt). Scaling the depth alone does
    tilt the contacts under this 15 deg pitched camera (the walk covers 2 m in depth): the
    level ground then moves by less than 1 cm (here 6.8 mm)."""
    J, cam, root_cam, frame = _walk_filmed()
    base = _ground_error(J, to_world_floor(cam, frame, root_cam)[0])
    for scaled, bound in ((root_cam * 1.05, 0.005), (root_cam * 0.95, 0.005),
                          (root_cam * np.array([1.0, 1.0, 1.05]), 0.01)):
        world, floor = to_world_floor(cam, frame, scaled)
        assert floor.kind == "plane"
        assert abs(_ground_error(J, world) - base) < bound


def test_too_few_contacts_fall_back_to_the_per_frame_floor_and_say_so():
    """A path known in only two frames has no stance contacts to fit: the ground is taken per
    frame (the lowest joint centre at the clearance) and the Floor says why."""
    J, cam, root_cam, frame = _walk_filmed()
    sparse = np.full_like(root_cam, np.nan)
    sparse[[10, 60]] = root_cam[[10, 60]]
    world, floor = to_world_floor(cam, frame, sparse)
    assert floor.kind == "per frame" and "fewer than" in floor.reason and "per frame" in floor.note("m")
    assert f"{floor.clearance:.3g} m below" in floor.note("m")
    # a cycling trial read the pelvis bobbing with the pedals as saddle motion: the note says
    # what every height rests on, in the summary too
    assert shortened(floor.note("m")).endswith("lowest joint centre, assumed on the floor")
    assert f"{floor.clearance:.3g} normalised units below" in floor.note("normalised")
    assert "normalised units below" in shortened(floor.note("normalised"))  # the summary line keeps the unit
    ok = np.isfinite(world).all(axis=(1, 2))
    assert ok.sum() == 2
    np.testing.assert_allclose(world[ok].min(axis=1)[:, 1], floor.clearance, atol=1e-9)


@pytest.mark.skipif(not (Path(__file__).parents[2] / "shared" / "data" / "mocap" / "deepmimic_h36m17.npz").exists(),
                    reason="needs ../shared/data/mocap (the shared mocap data) for the held-out clips")
def test_held_out_jump_and_walk_grounds_with_the_true_path():
    """Held-out DeepMimic clips (never fitted on) with their true paths: the ground lies within
    the held-out error benchmarks/fit_floor.py measures (DeepMimic median 3.5 cm, p95 6.3 cm:
    the rigs place the ankle centre 5-8 cm above their floors, CMU training 10-13 cm), and a
    jump's flight does not lift it beyond that."""
    clips = {c.name: c for c in load_mocap(Path(__file__).parents[2] / "shared" / "data" / "mocap" /
                                           "deepmimic_h36m17.npz")}
    for name in ("humanoid3d_jump.txt", "humanoid3d_walk.txt", "humanoid3d_run.txt"):
        J = clips[name].joints.astype(np.float64)
        cam, R = _filmed(J)
        root_cam = J[:, PELVIS] @ CAMERA.T + np.array([0.0, -0.3, 4.0])
        world, floor = to_world_floor(cam, world_frame(R, np.ones(len(R), bool), clips[name].fps), root_cam)
        assert floor.kind == "plane", name
        assert abs(_ground_error(J, world)) < 0.065, (name, _ground_error(J, world))


def test_where_the_2d_track_switches_person_one_persons_feet_place_the_ground():
    """Decision 0068: the 2D track follows another person standing still on a box half a metre
    higher (72 frames), then a real walk (120 frames, the longest one-person stretch), then the
    other person again (72 frames: 144 in all, more than the walk's). With every frame's contacts
    the ground goes up onto the box, where most contacts are, and the walker walks 0.5 m under
    it; with the walker's frames alone (``floor_frames``) both people stand on what they stand on."""
    J, cam, root_cam, frame = _walk_filmed()
    k = 72
    with np.load(FIXTURES / "mocap_small.npz") as d:
        O = d["dataset-2_raise-up-both-hands_elderly_024"][:k].astype(np.float64)
    O += np.array([2.0, 0.5, 0.0])
    other_cam, other_path = _filmed(O)[0], O[:, PELVIS] @ CAMERA.T + np.array([0.1, -0.2, 4.0])
    both = np.concatenate([other_cam, cam, other_cam])
    path = np.concatenate([other_path, root_cam, other_path])
    walker = np.r_[np.zeros(k, bool), np.ones(len(J), bool), np.zeros(k, bool)]
    mixed = to_world_floor(both, frame, path)[0]
    assert _ground_error(J, mixed[walker]) < -0.4
    world, floor = to_world_floor(both, frame, path, floor_frames=walker)
    assert floor.kind == "plane" and floor.n_contacts <= len(J)
    assert abs(_ground_error(J, world[walker])) < 0.02 and abs(_ground_error(O, world[:k])) < 0.02
    with pytest.raises(InputError, match="floor_frames"):
        to_world_floor(both, frame, path, floor_frames=walker[1:])


# --------------------------------------------------------------------------- a given camera up


def test_a_given_camera_up_is_the_world_frames_up_and_each_frame_keeps_its_heading():
    """A developer comparing estimators had no way to give the camera's known up (a calibration,
    the filming phone's gravity sensor): each estimator's poses moved the estimated up, and with
    it every angle against gravity. With ``camera_up`` sequence mode takes it: every frame's up
    column is that up, each frame's heading is its own estimate's turned about it, and nothing
    is called an interval."""
    from pcnet.pipeline import rectify
    from pcnet.stages.rectify import GIVEN_UP
    from pcnet.stages.temporal import rotations_about_up

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")  # real VideoPose3D, camera frame
    given = np.array([0.1, -0.9, 0.3])
    up = given / np.linalg.norm(given)
    estimated = rectify(joints, mode="sequence", fps=30.0)
    res = rectify(joints, mode="sequence", fps=30.0, camera_up=given)  # any length
    assert res.valid.all() and res.report.sequence.evidence == GIVEN_UP
    np.testing.assert_allclose(res.rotation[:, :, 1], np.broadcast_to(up, (100, 3)), atol=1e-9)
    # the heading: each frame's own about the given up (within the turn between the two ups)
    turned = rotations_about_up(estimated.rotation, up)[0]
    heading_gap = np.degrees(np.arccos(np.clip(np.sum(res.rotation[:, :, 0] * turned[:, :, 0], -1), -1, 1)))
    assert heading_gap.max() < 1.0, heading_gap.max()
    seq = res.report.sequence
    assert np.isnan([seq.camera_pitch_interval_deg, seq.camera_roll_interval_deg, seq.up_uncertainty_deg]).all()
    assert 0 < seq.up_spread_deg < 90 and seq.ground_plane["used"] is False
    for bad, said in (((0, 0, 0), "expected \\(x, y, z\\)"), ((0, -1), "expected \\(x, y, z\\)"),
                      ((0, np.nan, 1), "expected \\(x, y, z\\)")):
        with pytest.raises(InputError, match=said):
            rectify(joints, mode="sequence", fps=30.0, camera_up=bad)
    with pytest.raises(InputError, match="camera_up: expected with mode sequence"):
        rectify(joints, mode="frame", fps=30.0, camera_up=given)


def test_pcnet_run_with_a_given_camera_up_says_so_and_its_world_heights_are_along_it(tmp_path):
    """`pcnet run --camera-up`: the tilt line says the up was given and how far the networks'
    ups lie from it; the world frame's heights are the camera-frame positions along it."""
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    poses = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"
    res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output", str(poses), "--fps", "30",
                                    "--camera-up", "0,-1,0", "--no-recording", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert re.search(r"camera tilt +0\.0 deg from level \(pitch \+0\.0, roll \+0\.0 deg; given, --camera-up; "
                     r"the per-frame ups lie a median \d+\.\d deg from it\)", res.output), res.output
    assert not re.search(r"^per-frame up +bound", res.output, re.M)  # no per-frame up is read
    with np.load(tmp_path / "o" / "canonical.npz", allow_pickle=False) as run:
        world = run["joints_world"]
    camera = np.load(poses).astype(np.float64)
    np.testing.assert_allclose(world[..., 1] - world[:, :1, 1], -(camera[..., 1] - camera[:, :1, 1]), atol=1e-5)
    # report.md names no interval the run has not got (a trial read the sequence intervals' keys, all n/a)
    report = (tmp_path / "o" / "report.md").read_text()
    assert "the camera's up was given, so it has no interval" in report and "key facts print" not in report
    # a TOML file gives it as an array of numbers too, as its docstring says (a trial's was refused as not a str)
    (tmp_path / "run.toml").write_text(f'lifter = "videopose3d"\nlifter_output = "{poses.as_posix()}"\nfps = 30\n'
                                       'camera_up = [0, -2, 0]\nrecording = false\nplots = false\n')
    res = CliRunner().invoke(main, ["run", "--config", str(tmp_path / "run.toml"), "--out", str(tmp_path / "t")])
    assert res.exit_code == 0 and "given, --camera-up" in res.output, res.output
    with np.load(tmp_path / "t" / "canonical.npz", allow_pickle=False) as run:
        np.testing.assert_allclose(run["joints_world"], world, atol=1e-6)
    res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output", str(poses), "--fps", "30",
                                    "--camera-up", "0,-1,0", "--mode", "smooth", "--out", str(tmp_path / "s")])
    assert res.exit_code == 1 and "--camera-up: expected with mode sequence" in res.output
    # pcnet rectify takes it too
    res = CliRunner().invoke(main, ["rectify", str(poses), "--out", str(tmp_path / "r.npz"), "--mode", "sequence",
                                    "--fps", "30", "--camera-up", "0,-2,0"])
    assert res.exit_code == 0 and "deg, of the one up; given, --camera-up)" in res.output, res.output
    with np.load(tmp_path / "r.npz", allow_pickle=False) as archive:
        np.testing.assert_allclose(archive["up"][archive["valid"]], np.broadcast_to([0.0, -1.0, 0.0], (100, 3)),
                                   atol=1e-6)


def test_a_given_up_the_poses_contradict_is_flagged_and_a_flipped_one_named(tmp_path):
    """A trial gave a level camera's up to a camera looking 20 deg down, and a sign-flipped up:
    the first ran with no warning (the camera prior's odds and a --posture advice instead), the
    second was blamed on the lifter's axes. Now the poses' own up (the up model's) is read
    beside the given one and a given up outside its 95 % interval is a CHECK; one no frame can
    be turned to names --camera-up."""
    from click.testing import CliRunner

    from pcnet.pipeline import pose_checks, rectify
    from pcnet.pipeline.cli import main
    from pcnet.stages.flags import Kind

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")  # its camera reads about 19 deg down
    estimated = rectify(joints, mode="sequence", fps=30.0)
    near = rectify(joints, mode="sequence", fps=30.0, camera_up=estimated.report.sequence.up)
    assert near.report.sequence.poses_estimate["outside_interval"] is False
    assert not [f for f in pose_checks(joints, near) if f.kind in (Kind.GIVEN_UP, Kind.CAMERA_TILT, Kind.QUARTER_TURN)]
    level = rectify(joints, mode="sequence", fps=30.0, camera_up=(0, -1, 0))
    est = level.report.sequence.poses_estimate
    assert est["outside_interval"] is True and est["angle_from_given_deg"] > 10
    (flag,) = [f for f in pose_checks(joints, level) if f.kind == Kind.GIVEN_UP]
    assert flag.terminal_line().startswith(f"WARNING  given camera up {est['angle_from_given_deg']:.0f} deg from the "
                                           f"poses' own, outside their 95 % interval -> check --camera-up's frame")
    assert level.report.as_record()["poses_estimate"] == est
    res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output",
                                    str(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"), "--fps", "30",
                                    "--camera-up", "0,1,0", "--no-recording", "--out", str(tmp_path / "o")])
    assert res.exit_code == 1 and not (tmp_path / "o").exists()
    assert re.search(r"^Error: --camera-up: expected an up the poses can be turned to, got one \d+ deg from their own "
                     r"in every frame \(its sign flipped\?", res.output, re.M), res.output


def test_camera_up_from_takes_a_standing_runs_up_and_refuses_one_its_poses_did_not_read(tmp_path):
    """A clinic films a standing trial, then a floor exercise, from one tripod: ``--camera-up-from``
    gives the second run the first one's up (its canonical.npz report's), and the tilt line names
    where it came from. A run whose up the poses did not read is refused with one line: a body
    read lying (its up is the camera prior's), a folder without a run, both options together."""
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main
    from pcnet.pipeline.config import RunConfig
    from pcnet.stages.rectification_report import why_up_not_reusable

    def run(poses: str, out: str, *more: str):
        return CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output", str(FIXTURES / poses),
                                         "--fps", "30", "--no-recording", "--no-plots", "--out", str(tmp_path / out),
                                         *more])

    res = run("yoga_Abhay_Tadasana_f000-099.npy", "standing")
    assert res.exit_code == 0, res.output
    with np.load(tmp_path / "standing" / "canonical.npz", allow_pickle=False) as z:
        standing = json.loads(str(z["report"]))
    assert why_up_not_reusable(standing) is None
    res = run("yoga_Abhay_Padmasana_f200-299.npy", "seated", "--camera-up-from", str(tmp_path / "standing"))
    assert res.exit_code == 0, res.output
    # the trial's own uncertainty beside the given up (a given up prints no interval of this run's)
    assert re.search(rf"given, --camera-up-from {re.escape(str(tmp_path / 'standing'))}, whose 95 % interval was "
                     rf"\+- {standing['camera_pitch_interval_deg']:.1f} / {standing['camera_roll_interval_deg']:.1f};",
                     res.output), res.output
    with np.load(tmp_path / "seated" / "canonical.npz", allow_pickle=False) as z:
        seated = json.loads(str(z["report"]))
    np.testing.assert_allclose(seated["up"], standing["up"], atol=1e-6)
    assert seated["evidence"] == "given" and seated["inputs"]["settings"]["camera_up_from"] == str(tmp_path / "standing")
    assert seated["inputs"]["camera_up_from"]["up"] == pytest.approx(standing["up"])
    # a supine body's up is the camera prior's: not one to give another recording
    assert run("yoga_Abhay_Shavasana_f200-299.npy", "lying").exit_code == 0
    res = run("yoga_Abhay_Padmasana_f200-299.npy", "x", "--camera-up-from", str(tmp_path / "lying"))
    assert res.exit_code == 1 and not (tmp_path / "x").exists()
    assert f"Error: --camera-up-from: {tmp_path / 'lying'}: expected a run whose up its poses read" in res.output
    assert "a body read lying, whose up is the camera prior's" in res.output, res.output
    # the trial's interval is the given up's: in the columns' uncertainty and the report's numbers
    columns = (tmp_path / "seated" / "kinematics_columns.csv").read_text()
    assert (f"uncertain by +-{standing['camera_pitch_interval_deg']:.1f} deg in the camera's pitch and "
            f"+-{standing['camera_roll_interval_deg']:.1f} deg in its roll (the standing trial's interval, "
            f"--camera-up-from)") in columns
    assert seated["camera_pitch_interval_deg"] == pytest.approx(standing["camera_pitch_interval_deg"])
    # a run that took a trial's up passes it on with its interval; one without the camera prior is a trial too
    res = run("yoga_Abhay_Padmasana_f200-299.npy", "chained", "--camera-up-from", str(tmp_path / "seated"))
    assert res.exit_code == 0 and "whose 95 % interval was +- " in res.output, res.output
    assert run("yoga_Abhay_Tadasana_f000-099.npy", "no_prior", "--no-camera-prior").exit_code == 0
    assert run("yoga_Abhay_Padmasana_f200-299.npy", "p2", "--camera-up-from", str(tmp_path / "no_prior")).exit_code == 0
    # never written over the trial it reads
    res = run("yoga_Abhay_Padmasana_f200-299.npy", "standing", "--camera-up-from", str(tmp_path / "standing"),
              "--overwrite")
    assert res.exit_code == 1 and "standing" in res.output and (tmp_path / "standing" / "canonical.npz").exists()
    with np.load(tmp_path / "standing" / "canonical.npz", allow_pickle=False) as z:
        assert json.loads(str(z["report"]))["up"] == standing["up"]
    res = run("yoga_Abhay_Padmasana_f200-299.npy", "x", "--camera-up-from", str(tmp_path))
    assert res.exit_code == 1 and "expected a pcnet run output folder with canonical.npz" in res.output
    res = run("yoga_Abhay_Padmasana_f200-299.npy", "x", "--camera-up-from", str(tmp_path / "nowhere"))
    assert res.exit_code == 1 and "(no such folder)" in res.output
    res = run("yoga_Abhay_Padmasana_f200-299.npy", "x", "--camera-up-from", str(tmp_path / "standing"),
              "--camera-up", "0,-1,0")
    assert res.exit_code == 1 and "--camera-up-from: expected instead of --camera-up (one known up), got both" in res.output
    with pytest.raises(InputError, match="field 'camera_up_from': expected with mode sequence"):
        RunConfig(lifter="videopose3d", lifter_output=str(FIXTURES / "yoga_Abhay_Padmasana_f200-299.npy"), fps=30,
                  mode="frame", camera_up_from=str(tmp_path / "standing")).validate()
