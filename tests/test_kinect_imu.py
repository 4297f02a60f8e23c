"""Kinect adapters (adapters/kinect.py) and the skeleton-vs-IMU benchmark (benchmarks/imu_check.py).

Synthetic skeletons (built here, by hand) check the mapping and axis logic; real UTD-MHAD
sequences (research licence: read in place from ../shared/data, never copied into the
repository) check physical facts and skip when ../shared/data is absent.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from conftest import ROOT, shared
from pcnet.adapters import AdapterError, available_3d, get_3d_adapter
from pcnet.adapters.kinect import (
    AZURE_KINECT_JOINTS,
    KINECT_V1_JOINTS_SDK,
    KINECT_V1_JOINTS_UTD,
    azure_kinect_to_h36m,
    kinect_v1_to_h36m,
    load_azure_kinect,
    load_kinect_v1,
)
from pcnet.stages.core.conventions import (
    HEAD,
    L_HIP,
    L_SHOULDER,
    NECK_NOSE,
    PELVIS,
    R_ANKLE,
    R_ELBOW,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_WRIST,
    SPINE,
    THORAX,
)

if str(ROOT) not in sys.path:  # benchmarks/ is a package of the repository, not of the installed pcnet
    sys.path.append(str(ROOT))
from benchmarks import imu_check  # noqa: E402

UTD = ("real", "utd_mhad_imu")

# A standing subject 3 m in front of a Kinect v1, facing it, in skeleton space (+x the
# sensor's left = the subject's right, +y up, +z away from the sensor), metres.
_V1_POSE = {
    "head": (0.00, 0.70, 3.00), "shoulder_center": (0.00, 0.50, 3.00), "spine": (0.00, 0.15, 3.02),
    "hip_center": (0.00, 0.07, 3.00), "left_shoulder": (-0.18, 0.40, 3.00), "left_elbow": (-0.22, 0.12, 3.00),
    "left_wrist": (-0.24, -0.12, 3.00), "left_hand": (-0.25, -0.19, 3.00), "right_shoulder": (0.18, 0.40, 3.00),
    "right_elbow": (0.22, 0.12, 3.00), "right_wrist": (0.24, -0.12, 3.00), "right_hand": (0.25, -0.19, 3.00),
    "left_hip": (-0.08, 0.00, 3.00), "left_knee": (-0.09, -0.45, 3.00), "left_ankle": (-0.10, -0.85, 3.05),
    "left_foot": (-0.10, -0.90, 2.95), "right_hip": (0.08, 0.00, 3.00), "right_knee": (0.09, -0.45, 3.00),
    "right_ankle": (0.10, -0.85, 3.05), "right_foot": (0.10, -0.90, 2.95),
}


def _v1(order=KINECT_V1_JOINTS_UTD, frames=3):
    one = np.array([_V1_POSE[n] for n in order], np.float32)
    return np.repeat(one[None], frames, axis=0)


def _cv(name):
    x, y, z = _V1_POSE[name]
    return np.array([-x, -y, z], np.float32)


# --------------------------------------------------------------------------- Kinect v1, synthetic


def test_kinect_v1_axes_and_mapping():
    h = kinect_v1_to_h36m(_v1())
    assert h.shape == (3, 17, 3) and h.dtype == np.float32
    np.testing.assert_allclose(h[0, R_SHOULDER], _cv("right_shoulder"), atol=1e-6)
    np.testing.assert_allclose(h[0, R_WRIST], _cv("right_wrist"), atol=1e-6)  # wrist, not hand
    np.testing.assert_allclose(h[0, R_ANKLE], _cv("right_ankle"), atol=1e-6)  # ankle, not foot
    np.testing.assert_allclose(h[0, PELVIS], 0.5 * (_cv("left_hip") + _cv("right_hip")), atol=1e-6)
    np.testing.assert_allclose(h[0, THORAX], _cv("shoulder_center"), atol=1e-6)
    np.testing.assert_allclose(h[0, SPINE], 0.5 * (h[0, PELVIS] + h[0, THORAX]), atol=1e-6)
    np.testing.assert_allclose(h[0, HEAD], _cv("head"), atol=1e-6)
    assert np.isnan(h[:, NECK_NOSE]).all()  # no nose on a Kinect v1: NaN, never 0
    assert np.isfinite(np.delete(h, NECK_NOSE, axis=1)).all()
    # physical reading in the OpenCV frame: head above the pelvis (-y), subject facing the
    # camera so their right side is on the image's left (-x), depth positive
    assert h[0, HEAD, 1] < h[0, PELVIS, 1] - 0.5
    assert h[0, R_SHOULDER, 0] < h[0, L_SHOULDER, 0] and h[0, R_HIP, 0] < h[0, L_HIP, 0]
    assert (h[0, :, 2][np.isfinite(h[0, :, 2])] > 2.5).all()


def test_kinect_v1_sdk_order_gives_the_same_pose():
    np.testing.assert_array_equal(kinect_v1_to_h36m(_v1(KINECT_V1_JOINTS_SDK), layout="sdk"), kinect_v1_to_h36m(_v1()))

def test_kinect_v1_joints_in_the_other_order_are_refused(tmp_path):
    """A user trial read UTD-MHAD's order as the SDK's: head on hip_center, the thorax on the
    spine, and pcnet ran with no word but a tilt 2.5 deg off. Each order read as the other is
    refused, naming the order the joints read as."""
    for joints, stated, found in ((KINECT_V1_JOINTS_SDK, "utd", "sdk"), (KINECT_V1_JOINTS_UTD, "sdk", "utd")):
        with pytest.raises(AdapterError, match=rf"'{stated}' order.*joint \d \d\.\d\d m from the hips' midpoint "
                                               rf"and joint \d \d\.\d\d m: the '{found}' order \(--layout {found}\)"):
            kinect_v1_to_h36m(_v1(joints), layout=stated)


def test_a_real_utd_sequence_in_the_sdk_order_is_refused(tmp_path):
    real = shared(*UTD, "a05_s1_t1.npz")
    skeleton = np.load(real, allow_pickle=False)["skeleton"]
    np.save(tmp_path / "a05_s1_t1.npy", skeleton)
    assert load_kinect_v1(tmp_path / "a05_s1_t1.npy").joints.shape == (len(skeleton), 17, 3)
    with pytest.raises(AdapterError, match=r"a05_s1_t1\.npy.*joint 0 0\.[6-9]\d m .* joint 3 0\.0\d m: "
                                           r"the 'utd' order"):
        load_kinect_v1(tmp_path / "a05_s1_t1.npy", layout="sdk")


def test_kinect_v1_untracked_zero_joints_become_nan():
    sk = _v1()
    sk[1, KINECT_V1_JOINTS_UTD.index("right_elbow")] = 0.0  # the SDK's "not tracked"
    sk[2, KINECT_V1_JOINTS_UTD.index("left_hip")] = np.inf
    h = kinect_v1_to_h36m(sk)
    assert np.isnan(h[1, R_ELBOW]).all() and np.isfinite(h[0, R_ELBOW]).all()
    assert np.isnan(h[2, L_HIP]).all() and np.isnan(h[2, PELVIS]).all() and np.isnan(h[2, SPINE]).all()
    assert np.isfinite(h[2, R_HIP]).all()
    # nothing in front of the sensor is said as such, not as "only NaN/inf" (a bad-input trial)
    with pytest.raises(AdapterError, match=r"expected some joints in front of the sensor \(z > 0\), got every "
                                           r"finite joint at z <= 0"):
        kinect_v1_to_h36m(np.zeros_like(sk))


def test_kinect_v1_files_npy_npz_mat_and_registry(tmp_path):
    sk = _v1()
    np.save(tmp_path / "s.npy", sk)
    np.savez(tmp_path / "s.npz", skeleton=sk, skeleton_fps=np.float64(19.0), other=np.zeros(3))
    from scipy.io import savemat

    savemat(tmp_path / "s_skeleton.mat", {"d_skel": np.transpose(sk, (1, 2, 0)).astype(np.float64)})
    expected = kinect_v1_to_h36m(sk)
    a = load_kinect_v1(tmp_path / "s.npy")
    b = load_kinect_v1(tmp_path / "s.npz")
    c = get_3d_adapter("kinect_v1").load(tmp_path / "s_skeleton.mat")
    for p in (a, b, c):
        np.testing.assert_allclose(p.joints, expected, atol=1e-6)
        assert p.layout == "h36m17" and p.units == "m" and p.frame == "camera"
    assert a.fps is None and b.fps == 19.0
    assert "(-x, -y, z)" in a.notes
    assert {"kinect_v1", "azure_kinect"} <= set(available_3d())


def test_kinect_v1_archive_joint_names_set_the_order(tmp_path):
    """An archive that declares its joint order in ``joint_names`` is read in that order (the
    SDK order had been read as UTD-MHAD's, head and pelvis swapped); a layout= that
    contradicts it, or names that are no Kinect v1 order, are refused."""
    expected = kinect_v1_to_h36m(_v1())
    np.savez(tmp_path / "sdk.npz", skeleton=_v1(KINECT_V1_JOINTS_SDK), joint_names=np.array(KINECT_V1_JOINTS_SDK))
    np.testing.assert_allclose(load_kinect_v1(tmp_path / "sdk.npz").joints, expected, atol=1e-6)
    np.testing.assert_allclose(load_kinect_v1(tmp_path / "sdk.npz", layout="sdk").joints, expected, atol=1e-6)
    with pytest.raises(AdapterError, match="joint_names.*'utd' joint order"):
        load_kinect_v1(tmp_path / "sdk.npz", layout="utd")
    np.savez(tmp_path / "odd.npz", skeleton=_v1(), joint_names=np.array(["a"] * 20))
    with pytest.raises(AdapterError, match="joint_names"):
        load_kinect_v1(tmp_path / "odd.npz")
    np.testing.assert_allclose(load_kinect_v1(tmp_path / "odd.npz", layout="utd").joints, expected, atol=1e-6)
    # the same names as bytes, or in another spelling, are the same order
    for names in (np.array(KINECT_V1_JOINTS_SDK, dtype="S"), np.array([n.replace("_", " ").title() for n in KINECT_V1_JOINTS_SDK])):
        np.savez(tmp_path / "spelt.npz", skeleton=_v1(KINECT_V1_JOINTS_SDK), joint_names=names)
        np.testing.assert_allclose(load_kinect_v1(tmp_path / "spelt.npz").joints, expected, atol=1e-6)


@pytest.mark.parametrize("shape", [(5, 25, 3), (5, 20, 2), (20, 3)])
def test_kinect_v1_wrong_shape_is_one_clear_error(tmp_path, shape):
    path = tmp_path / "bad.npy"
    np.save(path, np.ones(shape, np.float32))
    with pytest.raises(AdapterError) as err:
        load_kinect_v1(path)
    msg = str(err.value)
    assert "bad.npy" in msg and "(T, 20, 3)" in msg and str(shape) in msg and "\n" not in msg
    assert err.value.field == "content"


def test_kinect_v1_bad_options_and_content(tmp_path):
    np.save(tmp_path / "s.npy", _v1())
    with pytest.raises(AdapterError, match="layout"):
        load_kinect_v1(tmp_path / "s.npy", layout="kinect2")
    np.savez(tmp_path / "two.npz", a=_v1(), b=_v1())
    with pytest.raises(AdapterError, match="key"):
        load_kinect_v1(tmp_path / "two.npz")
    np.save(tmp_path / "nan.npy", np.full((2, 20, 3), np.nan, np.float32))
    with pytest.raises(AdapterError, match="finite"):
        load_kinect_v1(tmp_path / "nan.npy")
    far = _v1()
    far[0, 0, 2] = 500.0  # 500 m: a unit error, not a pose
    np.save(tmp_path / "far.npy", far)
    with pytest.raises(AdapterError, match="frame 0, joint"):
        load_kinect_v1(tmp_path / "far.npy")
    from scipy.io import savemat

    savemat(tmp_path / "x.mat", {"d_depth": np.zeros((2, 2))})
    with pytest.raises(AdapterError, match="d_skel"):
        load_kinect_v1(tmp_path / "x.mat")


# --------------------------------------------------------------------------- Azure Kinect, synthetic


def test_azure_kinect_mm_to_m_no_axis_flip_and_nose():
    rng = np.random.default_rng(0)
    joints = rng.uniform(-800, 800, (4, 32, 3)).astype(np.float32)
    joints[..., 2] += 2500.0  # in front of the camera
    h = azure_kinect_to_h36m(joints)
    J = {n: joints[:, i] * 1e-3 for i, n in enumerate(AZURE_KINECT_JOINTS)}
    np.testing.assert_allclose(h[:, R_WRIST], J["wrist_right"], atol=1e-6)
    np.testing.assert_allclose(h[:, L_SHOULDER], J["shoulder_left"], atol=1e-6)
    np.testing.assert_allclose(h[:, R_KNEE], J["knee_right"], atol=1e-6)
    np.testing.assert_allclose(h[:, NECK_NOSE], J["nose"], atol=1e-6)
    np.testing.assert_allclose(h[:, HEAD], J["head"], atol=1e-6)
    np.testing.assert_allclose(h[:, PELVIS], 0.5 * (J["hip_left"] + J["hip_right"]), atol=1e-6)
    np.testing.assert_allclose(h[:, THORAX], 0.5 * (J["shoulder_left"] + J["shoulder_right"]), atol=1e-6)
    np.testing.assert_allclose(h[:, SPINE], 0.5 * (h[:, PELVIS] + h[:, THORAX]), atol=1e-6)


def test_azure_kinect_file_and_wrong_count(tmp_path):
    joints = np.zeros((2, 32, 3), np.float32)
    joints[..., 0] = np.linspace(-300.0, 300.0, 32)  # distinct joints: one point for all is a placeholder frame
    joints[..., 1] = 300.0 * np.cos(np.arange(32))  # and a body in 3D, not on one plane (a 2D projection)
    joints[..., 2] = 2000.0 + 50.0 * np.sin(np.arange(32))
    joints[:, [18, 22], 2] = 2000.0  # the hips, whose midpoint is H36M-17's pelvis
    np.savez(tmp_path / "bt.npz", joints=joints)
    p = load_azure_kinect(tmp_path / "bt.npz")
    assert p.joints.shape == (2, 17, 3) and np.allclose(p.joints[:, PELVIS, 2], 2.0)
    np.save(tmp_path / "v1.npy", _v1())  # a Kinect v1 file given to the Azure adapter
    with pytest.raises(AdapterError) as err:
        get_3d_adapter("azure_kinect").load(tmp_path / "v1.npy")
    assert "v1.npy" in str(err.value) and "(T, 32, 3)" in str(err.value) and "(3, 20, 3)" in str(err.value)


# --------------------------------------------------------------------------- Kinect v1, real UTD-MHAD


@pytest.mark.parametrize("name", ["a01_s1_t1", "a18_s6_t3"])
def test_kinect_v1_real_utd_sequences(name):
    path = shared(*UTD, f"{name}.npz")
    p = load_kinect_v1(path)
    with np.load(path) as d:
        assert p.fps == pytest.approx(float(d["skeleton_fps"]))
        assert p.num_frames == d["skeleton"].shape[0]
    X = p.joints - p.joints[:, PELVIS:PELVIS + 1]
    assert np.isnan(X[:, NECK_NOSE]).all()
    assert (X[:, HEAD, 1] < -0.45).all()  # head above the pelvis in the OpenCV frame (y down)
    assert (X[:, R_ANKLE, 1] > 0.5).all()  # ankles below it
    # subjects face the sensor: their right side is on the image's left
    assert (X[:, R_SHOULDER, 0] < X[:, L_SHOULDER, 0] - 0.2).all()
    assert (X[:, R_HIP, 0] < X[:, L_HIP, 0]).all()
    assert (p.joints[:, PELVIS, 2] > 2.0).all() and (p.joints[:, PELVIS, 2] < 4.5).all()  # 2.8-3.4 m away

    def bone(a, b):
        return float(np.median(np.linalg.norm(X[:, a] - X[:, b], axis=-1)))

    assert 0.20 < bone(R_SHOULDER, R_ELBOW) < 0.40
    assert 0.15 < bone(R_ELBOW, R_WRIST) < 0.35
    assert 0.30 < bone(R_HIP, R_KNEE) < 0.65  # Kinect v1 places its hip joints high
    assert 0.30 < bone(R_KNEE, R_ANKLE) < 0.60
    assert 0.35 < bone(PELVIS, THORAX) < 0.65


# --------------------------------------------------------------------------- benchmark functions


def test_specific_force_is_one_g_at_rest_and_adds_vertical_acceleration():
    fps, T = 20.0, 60
    joints = np.repeat(kinect_v1_to_h36m(_v1(frames=1)), T, axis=0)
    joints = joints - joints[:, PELVIS:PELVIS + 1]
    f = imu_check.wrist_specific_force(joints, np.array([0.0, -1.0, 0.0]), fps, 3.0)
    np.testing.assert_allclose(f[np.isfinite(f)], 1.0, atol=1e-9)
    # the wrist accelerating upwards (-y_cv) at 2 m/s^2: an accelerometer reads (9.81 + 2) / 9.81 g
    t = np.arange(T) / fps
    moving = joints.copy()
    moving[:, R_WRIST, 1] -= 0.5 * 2.0 * t**2
    f = imu_check.wrist_specific_force(moving, np.array([0.0, -1.0, 0.0]), fps, 3.0)
    mid = f[15:45]
    np.testing.assert_allclose(mid, (9.81 + 2.0) / 9.81, atol=2e-3)
    # a horizontal acceleration adds in quadrature, and a tilted up changes it through a.g only
    sideways = joints.copy()
    sideways[:, R_WRIST, 0] += 0.5 * 3.0 * t**2
    f = imu_check.wrist_specific_force(sideways, np.array([0.0, -1.0, 0.0]), fps, 3.0)[15:45]
    np.testing.assert_allclose(f, np.hypot(9.81, 3.0) / 9.81, atol=2e-3)
    tilt = np.radians(10.0)
    f_tilt = imu_check.wrist_specific_force(sideways, np.array([np.sin(tilt), -np.cos(tilt), 0.0]), fps, 3.0)[15:45]
    expect = np.linalg.norm(np.array([3.0, 0, 0]) + 9.81 * np.array([np.sin(tilt), -np.cos(tilt), 0])) / 9.81
    np.testing.assert_allclose(f_tilt, expect, atol=2e-3)
    assert abs(expect - np.hypot(9.81, 3.0) / 9.81) > 0.03


def test_compare_recovers_a_known_lag_and_excludes_saturation():
    imu_fps, fps = 50.0, 19.0
    t_imu = np.arange(200) / imu_fps
    imu = 1.0 + 0.5 * np.sin(2 * np.pi * 1.3 * t_imu) + 0.2 * np.sin(2 * np.pi * 0.4 * t_imu)
    lag = 0.05  # the skeleton is 0.05 s late: skel(t + lag) = imu(t)
    t_sk = np.arange(int(4.0 * fps)) / fps
    skel = 1.0 + 0.5 * np.sin(2 * np.pi * 1.3 * (t_sk - lag)) + 0.2 * np.sin(2 * np.pi * 0.4 * (t_sk - lag))
    res = imu_check.compare(skel, fps, imu, imu_fps, np.zeros(200, bool))
    assert res["lag_s"] == pytest.approx(lag, abs=0.011)
    assert res["r"] > 0.99 and res["rms_g"] < 0.02
    sat = np.zeros(200, bool)
    sat[100] = True
    res_sat = imu_check.compare(skel, fps, imu, imu_fps, sat)
    assert res_sat["samples"] <= res["samples"] - 11  # +-0.1 s around the clipped sample dropped


def test_imu_check_one_real_sequence():
    path = shared(*UTD, "a05_s1_t1.npz")  # right arm throw
    seq = imu_check.load_sequence(path)
    res = imu_check.evaluate_sequence(seq, 3.0)
    assert set(imu_check.METHODS) <= set(res)
    for m in imu_check.METHODS:
        row = res[m]
        assert row["r"] > 0.5, (m, row["r"])  # the skeleton's wrist dynamics follow the IMU
        assert 0.0 < row["rms_g"] < 0.8
        assert abs(row["lag_s"]) <= imu_check.LAG_WINDOW_S + 1e-9
        assert row["valid_frames"] == len(seq["joints"])
    assert res["level"]["up_vs_kinect_deg"] == 0.0
    for m in ("geometric", "pcnet frame", "pcnet sequence"):
        assert 0.0 < res[m]["up_vs_kinect_deg"] < 15.0  # Kinect's -y is level to within a few degrees
    # at rest before the throw the wrist reads about 1 g, as the IMU does
    up = np.array([0.0, -1.0, 0.0])
    f = imu_check.wrist_specific_force(seq["joints"], up, seq["fps"], 3.0)
    assert 0.85 < np.nanmedian(f[: int(0.4 * seq["fps"])]) < 1.15
    summary = imu_check.summarise([{"name": seq["name"], "action": seq["action"], "action_name": seq["action_name"],
                                    "methods": res}], imu_check.METHODS)
    assert summary["overall"]["sequences"] == 1
    assert "| **overall (median)** | 1 |" in imu_check.markdown_table(summary)


def test_the_rest_note_gives_the_numbers_its_benchmark_printed():
    """A Kinect v1 run's note on how its skeleton reads quiet standing (a wrist-IMU trial took
    the skeleton's extended hips for the subjects') quotes benchmarks/kinect_standing.py's
    committed result, rounded to the degree."""
    import re

    from pcnet.adapters.kinect import KINECT_V1_REST_NOTE

    text = (ROOT / "benchmarks" / "results" / "kinect_standing.txt").read_text()
    row = next(ln for ln in text.splitlines() if ln.startswith("Kinect v1, UTD-MHAD, pcnet run"))
    n, trunk, hip, knee = (float(v) for v in re.findall(r"(-?\d+(?:\.\d+)?)(?: \[|\s*$| )", row.split("run", 1)[1])[:4])
    assert f"hips {-hip:.0f} deg extended, knees {-knee:.0f} deg hyperextended and the trunk {-trunk:.0f} deg back " \
           f"(medians of {n:.0f} UTD-MHAD recordings" in KINECT_V1_REST_NOTE, (row, KINECT_V1_REST_NOTE)
