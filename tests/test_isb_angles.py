"""ISB joint angles (pcnet.stages.isb_angles): known motions applied to a neutral skeleton
give the expected angles and signs, global rotations change nothing they should not, NaN
and bad shapes are handled, and real mocap gives physically plausible ranges."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import FIXTURES, shared
from pcnet.models.datasets import load_mocap
from pcnet.stages.core.conventions import (
    L_ANKLE,
    PELVIS,
    L_ELBOW,
    L_HIP,
    L_KNEE,
    L_SHOULDER,
    L_WRIST,
    R_ANKLE,
    R_ELBOW,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_WRIST,
    SPINE,
    THORAX,
)
from pcnet.stages.isb_angles import (
    DEFINITIONS,
    MAX_KNEE_HYPEREXTENSION_DEG,
    MIN_BEND_DEG,
    NAMES,
    NEEDS_SPINE_JOINT,
    POSITIVE_SIGN,
    SPINE_ON_LINE_FRACTION,
    isb_joint_angles,
    isb_segment_frames,
    spine_off_trunk_line,
)
from scipy.spatial.transform import Rotation

# Joints moved with each chain (the distal joints of a rotation about a proximal joint).
R_LEG, L_LEG = [R_KNEE, R_ANKLE], [L_KNEE, L_ANKLE]
R_ARM, L_ARM = [R_ELBOW, R_WRIST], [L_ELBOW, L_WRIST]
UPPER_BODY = list(range(THORAX, 17))  # thorax, neck/nose, head, both arms
GRAVITY = ("trunk_flexion_to_gravity_deg", "trunk_lateral_tilt_to_gravity_deg")
SEGMENT_ANGLES = tuple(n for n in NAMES if n not in GRAVITY)
X_AXIS, Y_AXIS, Z_AXIS = np.eye(3)


def neutral() -> np.ndarray:
    """An upright synthetic H36M-17 skeleton in the canonical frame (metres): +X anterior,
    +Y up, +Z the subject's right; straight limbs hanging, arms along the trunk."""
    return np.array([
        [0, 0, 0], [0, 0, 0.1], [0, -0.42, 0.1], [0, -0.82, 0.1],        # pelvis, right leg
        [0, 0, -0.1], [0, -0.42, -0.1], [0, -0.82, -0.1],                # left leg
        [0, 0.25, 0], [0, 0.5, 0], [0.05, 0.6, 0], [0, 0.7, 0],          # spine .. head
        [0, 0.48, -0.18], [0, 0.2, -0.18], [0, -0.05, -0.18],            # left arm
        [0, 0.48, 0.18], [0, 0.2, 0.18], [0, -0.05, 0.18],               # right arm
    ], dtype=np.float64)


def rotate(pose: np.ndarray, joints, centre: int, axis, deg: float) -> np.ndarray:
    """Rotate ``joints`` of a ``(17, 3)`` pose about the line through joint ``centre`` with
    direction ``axis`` by ``deg`` (right-hand rule)."""
    out = np.array(pose, dtype=np.float64, copy=True)
    axis = np.asarray(axis, dtype=np.float64)
    rot = Rotation.from_rotvec(np.radians(deg) * axis / np.linalg.norm(axis))
    out[joints] = rot.apply(out[joints] - out[centre]) + out[centre]
    return out


def angles(pose: np.ndarray) -> dict[str, float]:
    return {k: float(v[0]) for k, v in isb_joint_angles(pose).items()}


def real_clips() -> list:
    return load_mocap(FIXTURES / "bandai_small.npz") + load_mocap(FIXTURES / "deepmimic_small.npz")


@pytest.fixture(scope="module")
def real_frame() -> np.ndarray:
    """A real, nearly neutral standing frame: the first frame of the Bandai bow clip
    (knees and elbows slightly bent, so every angle is defined), pelvis at the origin."""
    clip = next(c for c in load_mocap(FIXTURES / "bandai_small.npz") if "bow" in c.name)
    pose = clip.joints[0].astype(np.float64)
    return pose - pose[0]


# ---------------------------------------------------------------------------------------
# API


def test_names_and_data_dictionary():
    assert len(NAMES) == len(set(NAMES)) == 21
    assert all(n.endswith("_deg") for n in NAMES)
    assert set(POSITIVE_SIGN) == set(DEFINITIONS) == set(NAMES)
    out = isb_joint_angles(np.stack([neutral()] * 4))
    assert list(out) == list(NAMES)
    assert all(v.shape == (4,) and v.dtype == np.float64 for v in out.values())
    # a single pose is one frame
    assert all(v.shape == (1,) for v in isb_joint_angles(neutral()).values())


def test_neutral_skeleton_is_zero():
    a = angles(rotate(rotate(neutral(), [R_ANKLE], R_KNEE, Z_AXIS, -20), [L_ANKLE], L_KNEE, Z_AXIS, -20))
    for side in ("left", "right"):
        assert a[f"{side}_hip_flexion_deg"] == pytest.approx(0, abs=1e-6)
        assert a[f"{side}_hip_adduction_deg"] == pytest.approx(0, abs=1e-6)
        assert a[f"{side}_hip_internal_rotation_deg"] == pytest.approx(0, abs=1e-6)
        assert a[f"{side}_knee_flexion_deg"] == pytest.approx(20, abs=1e-6)
        assert a[f"{side}_shoulder_elevation_deg"] == pytest.approx(0, abs=1e-6)
        assert a[f"{side}_elbow_flexion_deg"] == pytest.approx(0, abs=1e-6)
    for name in ("trunk_lateral_bending_to_pelvis_deg", "trunk_axial_rotation_to_pelvis_deg", *GRAVITY):
        assert a[name] == pytest.approx(0, abs=1e-6)
    # this skeleton's spine lies on the pelvis-thorax line, where that flexion is 0 by construction
    assert np.isnan(a["trunk_flexion_to_pelvis_deg"])


# ---------------------------------------------------------------------------------------
# known motions: hip and knee


@pytest.mark.parametrize("deg", [30.0, -15.0, 90.0])
def test_hip_flexion_same_sign_both_sides(deg):
    # The whole leg rotated about the pelvis Z axis (+Z, the subject's right) through the
    # hip centre: positive = knee forward = flexion, on both sides.
    pose = rotate(neutral(), R_LEG, R_HIP, Z_AXIS, deg)
    pose = rotate(pose, L_LEG, L_HIP, Z_AXIS, deg)
    assert pose[R_KNEE, 0] * np.sign(deg) > 0  # the knee did move anteriorly for deg > 0
    a = angles(pose)
    for side in ("left", "right"):
        assert a[f"{side}_hip_flexion_deg"] == pytest.approx(deg, abs=1e-6)
        assert a[f"{side}_hip_adduction_deg"] == pytest.approx(0, abs=1e-6)
        assert a[f"{side}_knee_flexion_deg"] == pytest.approx(0, abs=1e-6)
        # straight knee: the thigh's axial rotation is undefined
        assert np.isnan(a[f"{side}_hip_internal_rotation_deg"])


def test_hip_abduction_is_negative_adduction():
    # Knee moved away from the midline: right leg to +Z, left leg to -Z.
    pose = rotate(neutral(), R_LEG, R_HIP, X_AXIS, -20)
    pose = rotate(pose, L_LEG, L_HIP, X_AXIS, 20)
    assert pose[R_KNEE, 2] > pose[R_HIP, 2] and pose[L_KNEE, 2] < pose[L_HIP, 2]
    a = angles(pose)
    for side in ("left", "right"):
        assert a[f"{side}_hip_adduction_deg"] == pytest.approx(-20, abs=1e-6)
        assert a[f"{side}_hip_flexion_deg"] == pytest.approx(0, abs=1e-6)
    # crossing the midline is adduction (+)
    b = angles(rotate(neutral(), R_LEG, R_HIP, X_AXIS, 10))
    assert b["right_hip_adduction_deg"] == pytest.approx(10, abs=1e-6)


def test_knee_flexion_and_hyperextension():
    # Shank swung posteriorly about the knee (-Z rotation) = flexion, on both sides.
    for deg in (45.0, 110.0, -10.0):
        pose = rotate(neutral(), [R_ANKLE], R_KNEE, Z_AXIS, -deg)
        pose = rotate(pose, [L_ANKLE], L_KNEE, Z_AXIS, -deg)
        a = angles(pose)
        assert a["right_knee_flexion_deg"] == pytest.approx(deg, abs=1e-6)
        assert a["left_knee_flexion_deg"] == pytest.approx(deg, abs=1e-6)
        assert a["right_hip_flexion_deg"] == pytest.approx(0, abs=1e-6)
        # the knee plane now fixes the thigh's axial rotation: neutral
        assert a["right_hip_internal_rotation_deg"] == pytest.approx(0, abs=1e-6)
        assert a["left_hip_internal_rotation_deg"] == pytest.approx(0, abs=1e-6)


def test_a_knee_is_read_as_hyperextended_only_where_flexion_needs_an_impossible_hip():
    """The same bent leg turned about the thigh: hyperextension needs flexion to imply the
    hip turned beyond 110 deg, and never beyond 25 deg of bend (knees do not bend backwards
    that far: a lifter's hip line had read a cyclist's knee as -101 deg)."""
    for turn, bend, expected in ((80.0, 40.0, 40.0), (100.0, 40.0, 40.0), (150.0, 15.0, -15.0), (150.0, 60.0, 60.0)):
        pose = rotate(neutral(), [R_ANKLE], R_KNEE, Z_AXIS, -bend)
        pose = rotate(pose, R_LEG, R_HIP, Y_AXIS, turn)
        assert angles(pose)["right_knee_flexion_deg"] == pytest.approx(expected, abs=1e-6), (turn, bend)


def test_a_real_cyclists_knees_never_read_as_impossibly_hyperextended():
    for clip in ("clip_a_X3D.npy", "clip_b_X3D.npy"):
        # camera frame: a rotation of the world frame, so the between-segment angles are the same
        # (only those against gravity need +Y up: check_up=False says so)
        a = isb_joint_angles(np.load(shared("real", "cycling_motionbert", clip)).astype(np.float64), check_up=False)
        knees = np.concatenate([a["left_knee_flexion_deg"], a["right_knee_flexion_deg"]])
        assert np.nanmin(knees) >= -MAX_KNEE_HYPEREXTENSION_DEG, clip
        assert np.nanmax(knees) > 70, clip  # pedalling


def test_hip_internal_rotation_mirrored():
    # Knee flexed 60, then the leg turned about the vertical thigh axis: internal rotation
    # turns the anterior face (and the foot) towards the midline: +Y for the right leg,
    # -Y for the left leg.
    pose = rotate(neutral(), [R_ANKLE], R_KNEE, Z_AXIS, -60)
    pose = rotate(pose, [L_ANKLE], L_KNEE, Z_AXIS, -60)
    pose = rotate(pose, R_LEG, R_HIP, Y_AXIS, 25)
    pose = rotate(pose, L_LEG, L_HIP, Y_AXIS, -25)
    assert pose[R_ANKLE, 2] > pose[R_KNEE, 2]  # right foot swung laterally: internal rotation
    a = angles(pose)
    for side in ("left", "right"):
        assert a[f"{side}_hip_internal_rotation_deg"] == pytest.approx(25, abs=1e-6)
        assert a[f"{side}_hip_flexion_deg"] == pytest.approx(0, abs=1e-6)
        assert a[f"{side}_knee_flexion_deg"] == pytest.approx(60, abs=1e-6)


def test_hip_jcs_sequence_composes():
    # flexion 40 about the pelvis Z, then adduction 15 about the floating axis, then
    # rotation -20 about the thigh Y: Z-X'-Y'' composition of the whole leg about the hip.
    pose = rotate(neutral(), [R_ANKLE], R_KNEE, Z_AXIS, -30)
    rot = Rotation.from_euler("ZXY", [40, 15, -20], degrees=True)
    pose[R_LEG] = rot.apply(pose[R_LEG] - pose[R_HIP]) + pose[R_HIP]
    a = angles(pose)
    assert a["right_hip_flexion_deg"] == pytest.approx(40, abs=1e-6)
    assert a["right_hip_adduction_deg"] == pytest.approx(15, abs=1e-6)
    assert a["right_hip_internal_rotation_deg"] == pytest.approx(-20, abs=1e-6)
    assert a["right_knee_flexion_deg"] == pytest.approx(30, abs=1e-6)


def test_real_frame_hip_flexion_adds_exactly(real_frame):
    # A real standing frame: rotating the leg about the subject's own pelvis Z through the
    # hip centre adds exactly that flexion and leaves the other angles unchanged.
    base = angles(real_frame)
    zp = isb_segment_frames(real_frame)["pelvis"][0][:, 2]
    pose = rotate(real_frame, R_LEG, R_HIP, zp, 30)
    pose = rotate(pose, L_LEG, L_HIP, zp, 30)
    a = angles(pose)
    for side in ("left", "right"):
        assert a[f"{side}_hip_flexion_deg"] == pytest.approx(base[f"{side}_hip_flexion_deg"] + 30, abs=1e-4)
        for key in ("hip_adduction_deg", "hip_internal_rotation_deg", "knee_flexion_deg"):
            assert a[f"{side}_{key}"] == pytest.approx(base[f"{side}_{key}"], abs=1e-4)
    assert base["right_hip_flexion_deg"] == pytest.approx(0, abs=10)  # it is near neutral
    # flexing the knee by 45 about the thigh's Z adds 45 to the knee only
    zt = isb_segment_frames(real_frame)["right_thigh"][0][:, 2]
    b = angles(rotate(real_frame, [R_ANKLE], R_KNEE, zt, -45))
    assert b["right_knee_flexion_deg"] == pytest.approx(base["right_knee_flexion_deg"] + 45, abs=1e-4)
    assert b["right_hip_internal_rotation_deg"] == pytest.approx(base["right_hip_internal_rotation_deg"], abs=1e-4)


# ---------------------------------------------------------------------------------------
# known motions: shoulder and elbow


def test_shoulder_abduction_and_flexion_90():
    # Abduction in the frontal plane: right arm to +Z, left arm to -Z.
    pose = rotate(neutral(), R_ARM, R_SHOULDER, X_AXIS, -90)
    pose = rotate(pose, L_ARM, L_SHOULDER, X_AXIS, 90)
    a = angles(pose)
    for side in ("left", "right"):
        assert a[f"{side}_shoulder_elevation_deg"] == pytest.approx(90, abs=1e-6)
        assert a[f"{side}_shoulder_plane_of_elevation_deg"] == pytest.approx(0, abs=1e-6)
    # Forward flexion: plane of elevation 90; 150 deg of elevation.
    pose = rotate(neutral(), R_ARM, R_SHOULDER, Z_AXIS, 150)
    pose = rotate(pose, L_ARM, L_SHOULDER, Z_AXIS, 150)
    a = angles(pose)
    for side in ("left", "right"):
        assert a[f"{side}_shoulder_elevation_deg"] == pytest.approx(150, abs=1e-6)
        assert a[f"{side}_shoulder_plane_of_elevation_deg"] == pytest.approx(90, abs=1e-6)
    # Scapular plane (30 deg anterior to the frontal plane), elevation 90: the hanging arm
    # (-Y) swung to the horizontal direction 30 deg forward of lateral.
    s30, c30 = np.sin(np.radians(30)), np.cos(np.radians(30))
    pose = rotate(neutral(), R_ARM, R_SHOULDER, np.cross(-Y_AXIS, [s30, 0, c30]), 90)
    pose = rotate(pose, L_ARM, L_SHOULDER, np.cross(-Y_AXIS, [s30, 0, -c30]), 90)
    np.testing.assert_allclose((pose[R_ELBOW] - pose[R_SHOULDER]) / 0.28, [s30, 0, c30], atol=1e-9)
    a = angles(pose)
    for side in ("left", "right"):
        assert a[f"{side}_shoulder_elevation_deg"] == pytest.approx(90, abs=1e-6)
        assert a[f"{side}_shoulder_plane_of_elevation_deg"] == pytest.approx(30, abs=1e-6)


@pytest.mark.parametrize("forearm,expected", [("forward", 0.0), ("up", -90.0), ("down", 90.0)])
def test_shoulder_axial_rotation_and_elbow_90(forearm, expected):
    # Arms abducted 90, elbows flexed 90; forearm forward = neutral, up = external (-),
    # down = internal (+).
    pose = rotate(neutral(), R_ARM, R_SHOULDER, X_AXIS, -90)
    pose = rotate(pose, L_ARM, L_SHOULDER, X_AXIS, 90)
    axis_r, axis_l = {"forward": (Y_AXIS, -Y_AXIS), "up": (-X_AXIS, X_AXIS), "down": (X_AXIS, -X_AXIS)}[forearm]
    pose = rotate(pose, [R_WRIST], R_ELBOW, axis_r, 90)
    pose = rotate(pose, [L_WRIST], L_ELBOW, axis_l, 90)
    direction = {"forward": X_AXIS, "up": Y_AXIS, "down": -Y_AXIS}[forearm]
    for w, e in ((R_WRIST, R_ELBOW), (L_WRIST, L_ELBOW)):
        np.testing.assert_allclose((pose[w] - pose[e]) / 0.25, direction, atol=1e-9)
    a = angles(pose)
    for side in ("left", "right"):
        assert a[f"{side}_elbow_flexion_deg"] == pytest.approx(90, abs=1e-6)
        assert a[f"{side}_shoulder_axial_rotation_deg"] == pytest.approx(expected, abs=1e-6)
        assert a[f"{side}_shoulder_elevation_deg"] == pytest.approx(90, abs=1e-6)


def test_elbow_flexion_with_arm_hanging():
    pose = rotate(neutral(), [R_WRIST], R_ELBOW, Z_AXIS, 90)
    pose = rotate(pose, [L_WRIST], L_ELBOW, Z_AXIS, 135)
    a = angles(pose)
    assert a["right_elbow_flexion_deg"] == pytest.approx(90, abs=1e-6)
    assert a["left_elbow_flexion_deg"] == pytest.approx(135, abs=1e-6)
    # arm along the trunk: gimbal lock of Y-X-Y, so only the elevation is defined
    assert a["right_shoulder_elevation_deg"] == pytest.approx(0, abs=1e-6)
    assert np.isnan(a["right_shoulder_plane_of_elevation_deg"])
    assert np.isnan(a["right_shoulder_axial_rotation_deg"])


# ---------------------------------------------------------------------------------------
# trunk


def test_trunk_relative_to_pelvis_and_gravity():
    # Upper body flexed 20 forward about the spine joint (rotation about -Z).
    a = angles(rotate(neutral(), UPPER_BODY, SPINE, Z_AXIS, -20))
    assert a["trunk_flexion_to_pelvis_deg"] == pytest.approx(20, abs=1e-6)
    assert a["trunk_flexion_to_gravity_deg"] == pytest.approx(20, abs=1e-6)
    assert a["trunk_lateral_bending_to_pelvis_deg"] == pytest.approx(0, abs=1e-6)
    # arms went with the thorax: shoulder angles unchanged (still hanging along it)
    assert a["right_shoulder_elevation_deg"] == pytest.approx(0, abs=1e-6)
    # bent 10 to the right (thorax Y towards +Z)
    a = angles(rotate(neutral(), UPPER_BODY, SPINE, X_AXIS, 10))
    assert a["trunk_lateral_bending_to_pelvis_deg"] == pytest.approx(10, abs=1e-6)
    assert a["trunk_lateral_tilt_to_gravity_deg"] == pytest.approx(10, abs=1e-6)
    assert a["trunk_flexion_to_pelvis_deg"] == pytest.approx(0, abs=1e-6)
    # turned 15 to the left (counter-clockwise from above, right shoulder forward)
    pose = rotate(neutral(), UPPER_BODY, SPINE, Y_AXIS, 15)
    assert pose[R_SHOULDER, 0] > 0
    a = angles(pose)
    assert a["trunk_axial_rotation_to_pelvis_deg"] == pytest.approx(15, abs=1e-6)
    assert a["trunk_flexion_to_gravity_deg"] == pytest.approx(0, abs=1e-6)
    # The whole body pitched 25 forward: trunk-to-gravity sees it, trunk-to-pelvis does not.
    whole = Rotation.from_rotvec(np.radians(-25) * Z_AXIS).apply(neutral())
    a = angles(whole)
    assert a["trunk_flexion_to_gravity_deg"] == pytest.approx(25, abs=1e-6)
    assert np.isnan(a["trunk_flexion_to_pelvis_deg"])  # the spine on the trunk line: not measured
    assert a["right_hip_flexion_deg"] == pytest.approx(0, abs=1e-6)


# ---------------------------------------------------------------------------------------
# invariance and symmetry


def _assert_same(a: dict, b: dict, names, atol: float = 1e-6):
    for n in names:
        np.testing.assert_allclose(a[n], b[n], atol=atol, equal_nan=True, err_msg=n)


def test_invariance_to_global_rotation():
    rng = np.random.default_rng(0)
    poses = np.concatenate([c.joints[::3] for c in real_clips()]).astype(np.float64)
    base = isb_joint_angles(poses)
    # rotation about the vertical (a different heading) plus a translation and a unit
    # change: every angle unchanged, trunk-to-gravity too
    yaw = Rotation.from_rotvec([0.0, 1.234, 0.0])
    moved = 1000.0 * (yaw.apply(poses.reshape(-1, 3)).reshape(poses.shape) + np.array([3.0, 0.5, -2.0]))
    _assert_same(base, isb_joint_angles(moved), NAMES)
    # arbitrary rotation: the segment-to-segment angles are unchanged, the gravity ones not
    tilt = Rotation.from_rotvec(rng.normal(size=3))
    tilted = tilt.apply(poses.reshape(-1, 3)).reshape(poses.shape)
    out = isb_joint_angles(tilted)
    _assert_same(base, out, SEGMENT_ANGLES)
    assert not np.allclose(base["trunk_flexion_to_gravity_deg"], out["trunk_flexion_to_gravity_deg"], equal_nan=True)
    assert np.isfinite(base["right_hip_internal_rotation_deg"]).mean() > 0.8


def test_mirror_image_swaps_sides():
    poses = np.concatenate([c.joints[::3] for c in real_clips()]).astype(np.float64)
    swap = [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]
    mirrored = (poses * np.array([1.0, 1.0, -1.0]))[:, swap]
    a, m = isb_joint_angles(poses), isb_joint_angles(mirrored)
    for n in NAMES:
        if n.startswith("left_"):
            np.testing.assert_allclose(m[n], a["right_" + n[5:]], atol=1e-6, equal_nan=True, err_msg=n)
        elif n.startswith("right_"):
            np.testing.assert_allclose(m[n], a["left_" + n[6:]], atol=1e-6, equal_nan=True, err_msg=n)
        elif "flexion" in n:
            np.testing.assert_allclose(m[n], a[n], atol=1e-6, equal_nan=True, err_msg=n)
        else:  # lateral bending/tilt and axial rotation change direction
            np.testing.assert_allclose(m[n], -a[n], atol=1e-6, equal_nan=True, err_msg=n)


def test_segment_frames_are_rotations_and_match_angles():
    poses = np.concatenate([c.joints[::3] for c in real_clips()]).astype(np.float64)
    frames = isb_segment_frames(poses)
    for name, R in frames.items():
        ok = np.isfinite(R).all(axis=(1, 2))
        assert ok.mean() > 0.9, name
        np.testing.assert_allclose(R[ok].transpose(0, 2, 1) @ R[ok], np.broadcast_to(np.eye(3), R[ok].shape), atol=1e-9)
        np.testing.assert_allclose(np.linalg.det(R[ok]), 1.0, atol=1e-9)
    a = isb_joint_angles(poses)
    # right hip = Z-X-Y of thigh in pelvis; left hip = the same with the 2nd and 3rd angles
    # negated (the frames are right-handed with Z to the right on both sides)
    for side, s in (("right", 1.0), ("left", -1.0)):
        rel = frames["pelvis"].transpose(0, 2, 1) @ frames[f"{side}_thigh"]
        eul = Rotation.from_matrix(rel).as_euler("ZXY", degrees=True)
        np.testing.assert_allclose(eul[:, 0], a[f"{side}_hip_flexion_deg"], atol=1e-6)
        np.testing.assert_allclose(s * eul[:, 1], a[f"{side}_hip_adduction_deg"], atol=1e-6)
        rot = a[f"{side}_hip_internal_rotation_deg"]
        ok = np.isfinite(rot)
        np.testing.assert_allclose(s * eul[ok, 2], rot[ok], atol=1e-6)
        # knee / elbow flexion are the Grood & Suntay / Wu 2005 flexion angles (where the
        # limb plane defines the proximal Z; below MIN_BEND_DEG that Z is a placeholder)
        kf = a[f"{side}_knee_flexion_deg"]
        ok = np.abs(kf) >= MIN_BEND_DEG
        knee = Rotation.from_matrix(frames[f"{side}_thigh"][ok].transpose(0, 2, 1) @ frames[f"{side}_shank"][ok])
        eul = knee.as_euler("ZXY", degrees=True)
        np.testing.assert_allclose(-eul[:, 0], kf[ok], atol=1e-6)
        np.testing.assert_allclose(eul[:, 1:], 0.0, atol=1e-6)  # a hinge: no ad/abduction, rotation
        ef = a[f"{side}_elbow_flexion_deg"]
        ok = ef >= MIN_BEND_DEG
        elbow = Rotation.from_matrix(frames[f"{side}_upper_arm"][ok].transpose(0, 2, 1) @ frames[f"{side}_forearm"][ok])
        eul = elbow.as_euler("ZXY", degrees=True)
        np.testing.assert_allclose(eul[:, 0], ef[ok], atol=1e-6)
        np.testing.assert_allclose(eul[:, 1:], 0.0, atol=1e-6)


# ---------------------------------------------------------------------------------------
# NaN, degenerate frames and bad input


def test_nan_joint_gives_nan_angles_only_where_needed():
    pose = rotate(neutral(), UPPER_BODY, SPINE, Z_AXIS, -10)  # a spine off the trunk line: every angle measured
    pose = rotate(pose, [R_ANKLE], R_KNEE, Z_AXIS, -30)
    pose = rotate(pose, [L_ANKLE], L_KNEE, Z_AXIS, -30)
    pose = rotate(pose, R_ARM, R_SHOULDER, X_AXIS, -45)
    pose = rotate(pose, L_ARM, L_SHOULDER, X_AXIS, 45)
    pose = rotate(pose, [R_WRIST], R_ELBOW, Z_AXIS, 60)
    pose = rotate(pose, [L_WRIST], L_ELBOW, Z_AXIS, 60)
    seq = np.stack([pose, pose])
    assert all(np.isfinite(v).all() for v in isb_joint_angles(seq).values())
    seq[1, R_ANKLE] = np.nan
    out = isb_joint_angles(seq)
    assert all(np.isfinite(v[0]) for v in out.values())  # frame 0 untouched
    nan_now = {n for n, v in out.items() if np.isnan(v[1])}
    assert nan_now == {"right_knee_flexion_deg", "right_hip_internal_rotation_deg"}
    seq[1] = pose
    seq[1, L_WRIST, 0] = np.nan  # one coordinate is enough
    out = isb_joint_angles(seq)
    assert {n for n, v in out.items() if np.isnan(v[1])} == {
        "left_elbow_flexion_deg", "left_shoulder_axial_rotation_deg"}
    seq[1] = np.nan  # a missing frame
    out = isb_joint_angles(seq)
    assert all(np.isnan(v[1]) and np.isfinite(v[0]) for v in out.values())
    seq[1] = pose
    seq[1, R_SHOULDER] = np.inf  # inf is missing data as well
    out = isb_joint_angles(seq)
    assert np.isnan(out["trunk_flexion_to_pelvis_deg"][1]) and np.isnan(out["right_elbow_flexion_deg"][1])
    assert np.isfinite(out["left_elbow_flexion_deg"][1]) and np.isfinite(out["right_hip_flexion_deg"][1])


def test_degenerate_frames_are_nan():
    # Hips on top of each other (hip line along pelvis -> spine): no pelvis frame.
    pose = neutral()
    pose[R_HIP] = [0, -0.05, 0.0]
    pose[L_HIP] = [0, 0.05, 0.0]
    out = angles(pose)
    assert np.isnan(out["right_hip_flexion_deg"]) and np.isnan(out["trunk_flexion_to_pelvis_deg"])
    assert np.isnan(out["right_knee_flexion_deg"])  # its sign needs the pelvis
    assert out["right_elbow_flexion_deg"] == pytest.approx(0, abs=1e-6)
    # Two coincident joints (a zero-length thigh)
    pose = neutral()
    pose[R_KNEE] = pose[R_HIP]
    out = angles(pose)
    assert np.isnan(out["right_hip_flexion_deg"]) and np.isnan(out["right_knee_flexion_deg"])
    assert np.isfinite(out["left_hip_flexion_deg"])
    # Knee bent less than MIN_BEND_DEG: axial rotation undefined, flexion kept
    pose = rotate(neutral(), [R_ANKLE], R_KNEE, Z_AXIS, -(MIN_BEND_DEG - 1))
    out = angles(pose)
    assert np.isnan(out["right_hip_internal_rotation_deg"])
    assert out["right_knee_flexion_deg"] == pytest.approx(MIN_BEND_DEG - 1, abs=1e-6)
    # Thorax lying on its side (thorax Z vertical): no heading, trunk-to-gravity NaN
    side = Rotation.from_rotvec(np.radians(90) * X_AXIS).apply(rotate(neutral(), UPPER_BODY, SPINE, Z_AXIS, -10))
    out = angles(side)
    assert np.isnan(out["trunk_flexion_to_gravity_deg"])
    assert out["trunk_flexion_to_pelvis_deg"] == pytest.approx(10, abs=1e-6)  # relative to the pelvis: kept


@pytest.mark.parametrize("bad", [np.zeros((5, 16, 3)), np.zeros((5, 17, 2)), np.zeros(17), np.zeros((2, 3, 17, 3))])
def test_wrong_shape_raises_naming_the_argument(bad):
    with pytest.raises(ValueError, match="joints"):
        isb_joint_angles(bad)
    with pytest.raises(ValueError, match="joints"):
        isb_segment_frames(bad)


def test_wrong_dtype_raises():
    with pytest.raises(ValueError, match="joints"):
        isb_joint_angles(np.full((2, 17, 3), "a"))
    with pytest.raises(ValueError, match="joints"):
        isb_joint_angles(np.zeros((2, 17, 3), dtype=bool))


def test_empty_and_integer_input():
    out = isb_joint_angles(np.zeros((0, 17, 3)))
    assert all(v.shape == (0,) for v in out.values())
    ints = isb_joint_angles(np.round(neutral() * 1000).astype(np.int32))
    assert ints["right_hip_flexion_deg"][0] == pytest.approx(0, abs=1e-6)


# ---------------------------------------------------------------------------------------
# real mocap


@pytest.mark.parametrize("clip", real_clips(), ids=lambda c: c.name)
def test_real_mocap_ranges(clip):
    out = isb_joint_angles(clip.joints)
    built = np.nanmax(spine_off_trunk_line(clip.joints)) <= SPINE_ON_LINE_FRACTION  # DeepMimic's H36M-17 spine
    for n, v in out.items():
        if built and n in NEEDS_SPINE_JOINT:
            assert np.isnan(v).all(), f"{clip.name}: {n} measured without a spine of its own"
            continue
        assert np.isfinite(v).any(), f"{clip.name}: {n} is all NaN"
    for side in ("left", "right"):
        knee = out[f"{side}_knee_flexion_deg"]
        elbow = out[f"{side}_elbow_flexion_deg"]
        assert np.isfinite(knee).all() and np.isfinite(elbow).all()
        assert -15 <= knee.min() and knee.max() <= 160, (clip.name, side, knee.min(), knee.max())
        assert -10 <= elbow.min() and elbow.max() <= 170, (clip.name, side, elbow.min(), elbow.max())
        assert np.nanmax(np.abs(out[f"{side}_hip_internal_rotation_deg"])) < 90
        assert np.nanmin(out[f"{side}_shoulder_elevation_deg"]) >= 0
        hip = out[f"{side}_hip_flexion_deg"]
        assert -40 <= np.nanmin(hip) and np.nanmax(hip) <= 140, (clip.name, side)
    if "walk" in clip.name:
        # walking: hip flexion spans roughly -10..+35, the knee swings past 50 deg
        for side in ("left", "right"):
            hip = out[f"{side}_hip_flexion_deg"]
            assert np.nanmin(hip) < 0 and 20 < np.nanmax(hip) < 45
            assert np.nanmax(out[f"{side}_knee_flexion_deg"]) > 50
        assert np.nanmax(np.abs(out["trunk_flexion_to_gravity_deg"])) < 15


def test_a_spine_built_on_the_trunk_line_leaves_trunk_flexion_to_pelvis_empty():
    """Kinect's and MediaPipe's conversions build the spine on the pelvis-thorax line, where the
    thorax's flexion relative to the pelvis is 0 by construction: a developer trial got that
    constant from the API while `pcnet run` left the column empty. Real mocap keeps it."""
    from pcnet.stages.kinematics import compute_kinematics

    clip = next(c for c in load_mocap(FIXTURES / "bandai_small.npz") if "bow" in c.name)
    X = clip.joints.astype(np.float64)
    built = X.copy()
    built[:, SPINE] = 0.5 * (X[:, PELVIS] + X[:, THORAX])
    built[:10, SPINE] += 0.02  # a spine of its own in the first frames
    own, on_line = isb_joint_angles(X)["trunk_flexion_to_pelvis_deg"], isb_joint_angles(built)["trunk_flexion_to_pelvis_deg"]
    assert np.isfinite(own).all() and np.ptp(own) > 5.0
    assert np.isfinite(on_line[:10]).all() and np.isnan(on_line[10:]).all()
    rates = compute_kinematics(built, clip.fps, cutoff_hz=None).angle_rates["trunk_flexion_to_pelvis"]
    assert np.isnan(rates[10:]).all()
    assert np.isfinite(isb_joint_angles(built)["trunk_axial_rotation_to_pelvis_deg"]).all()
