"""BVH export (:mod:`pcnet.stages.sinks.bvh`): written files read back with bvhio
(https://github.com/Wasserwecken/bvhio), an independent BVH reader and forward-kinematics
implementation, must reproduce real poses rigidified to their median bone lengths (and set on
the input's floor: each frame's lowest joint at the input's lowest joint height) within 1 mm;
a real ``pcnet run``'s BVH must stand on the floor of its TRC.

Real data: ``tests/fixtures/mocap_small.npz`` (Bandai Namco motion capture converted to
H36M-17, world frame +Y up, metres, 30 fps) and ``tests/fixtures/yoga_vp3d_Bhumi_Tadasana.npy``
(a VideoPose3D network output, camera frame, metres; its bone lengths vary from frame to
frame); see fixtures/README.md.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import FIXTURES
from pcnet.stages.floor import ANKLE_CLEARANCE_LEG
from pcnet.stages.scale import mean_leg_length
from pcnet.stages.sinks.bvh import bvh_motion, write_bvh
from pcnet.stages.core.conventions import H36M_BONES, H36M_JOINTS
from pcnet.stages.core.errors import InputError

with warnings.catch_warnings():  # bvhio imports PyGLM as "glm", which PyGLM marks as deprecated
    warnings.simplefilter("ignore", PendingDeprecationWarning)
    import bvhio  # the dev extra's BVH reader: an independent parser and forward kinematics

FPS = 30.0
CLIPS = ("dataset-2_walk-turn-left_active_001", "dataset-2_raise-up-both-hands_elderly_024",
         "dataset-2_run_masculine_037")
LINKS = ("pelvis_to_right_hip", "pelvis_to_left_hip", "thorax_to_neck_nose",
         "thorax_to_left_shoulder", "thorax_to_right_shoulder")


@pytest.fixture(scope="module")
def mocap() -> dict[str, np.ndarray]:
    """Real motion capture, world frame (+Y up, floor at the ankle-centre height), metres."""
    with np.load(FIXTURES / "mocap_small.npz") as d:
        return {k: d[k].astype(np.float64) for k in CLIPS}


@pytest.fixture(scope="module")
def yoga_world() -> np.ndarray:
    """Real VideoPose3D output (non-rigid bones), 90 frames, turned from the camera frame
    (y down, z forward) to a Y-up frame by a half turn about x (a level camera assumed)."""
    cam = np.load(FIXTURES / "yoga_vp3d_Bhumi_Tadasana.npy")[::10][:90].astype(np.float64)
    return cam * np.array([1.0, -1.0, -1.0])


def rigidify(X: np.ndarray) -> np.ndarray:
    """Each bone scaled to its median length over the complete frames, its direction kept,
    from the pelvis outwards, then each frame moved vertically so that its lowest joint is at
    the height of the input's lowest joint (the BVH's floor; written here independently of
    the module). A frame with a missing joint is not moved (its minimum is taken over the
    gap-filled pose, which the callers compare separately)."""
    complete = np.isfinite(X).all(axis=(1, 2))
    out = X.copy()
    for p, c in H36M_BONES:  # parents come before children in H36M-17 order
        v = X[:, c] - X[:, p]
        length = np.median(np.linalg.norm(v[complete], axis=-1))
        with np.errstate(invalid="ignore"):  # NaN stays NaN
            out[:, c] = out[:, p] + length * v / np.linalg.norm(v, axis=-1, keepdims=True)
    out[complete, :, 1] += (X[complete, :, 1].min(axis=1) - out[complete, :, 1].min(axis=1))[:, None]
    return out


def read_positions(path, names=H36M_JOINTS) -> np.ndarray:
    """World positions ``(T, 17, 3)`` of the named joints, by bvhio's forward kinematics."""
    root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, _, _ in root.layout()}
    frames = root.getKeyframeRange()[1] + 1
    out = np.empty((frames, len(names), 3))
    for f in range(frames):
        root.loadPose(f, recursive=True)
        out[f] = [tuple(joints[n].PositionWorld) for n in names]
    return out


@pytest.mark.parametrize("clip", CLIPS)
def test_roundtrip_mocap_within_1mm(tmp_path, mocap, clip):
    X = mocap[clip]
    path = write_bvh(tmp_path / "world.bvh", X, FPS)
    Y = read_positions(path)
    assert Y.shape == X.shape
    err_rigid = np.abs(Y - rigidify(X)).max()
    err_raw = np.linalg.norm(Y - X, axis=-1).max()
    print(f"{clip}: max error vs rigidified {err_rigid * 1e3:.4f} mm, vs raw {err_raw * 1e3:.2f} mm")
    assert err_rigid < 1e-3
    # mocap bones are nearly rigid: the raw poses are close too (midpoint joints vary by a few mm)
    assert err_raw < 0.02
    # the module's own account of what it wrote agrees with the reader
    m = bvh_motion(X)
    assert np.abs(m.positions - Y).max() < 1e-4
    np.testing.assert_allclose(np.nanmax(m.deviation), err_raw, atol=1e-4)
    assert not m.filled.any()


def test_roundtrip_network_output_within_1mm(tmp_path, yoga_world):
    X = yoga_world
    path = write_bvh(tmp_path / "world.bvh", X, FPS)
    Y = read_positions(path)
    err_rigid = np.abs(Y - rigidify(X)).max()
    err_raw = np.linalg.norm(Y - X, axis=-1)
    print(f"VideoPose3D: max error vs rigidified {err_rigid * 1e3:.4f} mm; vs raw "
          f"max {err_raw.max() * 1e3:.1f} mm, mean {err_raw.mean() * 1e3:.1f} mm")
    assert err_rigid < 1e-3
    assert err_raw.max() > 1e-3  # its bones do vary: the rigid comparison is the meaningful one


def test_header(tmp_path, mocap):
    X = mocap[CLIPS[1]][:40]
    fps = 29.97
    path = write_bvh(tmp_path / "canonical.bvh", X, fps)
    bvh = bvhio.readAsBvh(str(path))
    assert bvh.FrameCount == 40
    assert bvh.FrameTime == pytest.approx(1 / fps, rel=1e-8)
    joints = []

    def walk(j, depth):
        joints.append((j, depth))
        for c in j.Children:
            walk(c, depth + 1)

    walk(bvh.Root, 0)
    names = [j.Name for j, _ in joints]
    assert names[0] == "pelvis"
    assert sorted(names) == sorted(H36M_JOINTS + LINKS)
    channels = {j.Name: j.Channels for j, _ in joints}
    assert channels["pelvis"] == ["Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"]
    assert all(sorted(channels[n]) == ["Xrotation", "Yrotation", "Zrotation"] for n in names[1:])
    # per joint, the bone's rest axis in the middle: legs/trunk ZYX, arms XZY, thorax ZXY
    for n in ("right_hip", "left_knee", "spine", "neck_nose", "right_ankle"):
        assert channels[n] == ["Zrotation", "Yrotation", "Xrotation"], n
    for n in ("left_shoulder", "right_elbow", "pelvis_to_right_hip", "thorax_to_left_shoulder"):
        assert channels[n] == ["Xrotation", "Zrotation", "Yrotation"], n
    assert channels["thorax"] == ["Zrotation", "Xrotation", "Yrotation"]
    assert sorted(j.Name for j, _ in joints if not j.Children) == sorted(
        ["right_ankle", "left_ankle", "head", "left_wrist", "right_wrist"])
    offsets = {j.Name: np.array(tuple(j.Offset)) for j, _ in joints}
    for link in LINKS:
        assert np.abs(offsets[link]).max() == 0
    # T-pose rest: legs down, trunk up, arms out sideways (left -Z, right +Z)
    for n in ("right_knee", "right_ankle", "left_knee", "left_ankle"):
        assert offsets[n][1] < 0 and np.abs(offsets[n][[0, 2]]).max() == 0
    for n in ("spine", "thorax", "head"):
        assert offsets[n][1] > 0 and np.abs(offsets[n][[0, 2]]).max() == 0
    assert offsets["left_elbow"][2] < 0 and offsets["right_wrist"][2] > 0
    assert offsets["right_hip"][2] > 0 > offsets["left_hip"][2]
    text = path.read_text()
    assert "nan" not in text.lower()
    assert text.count("End Site") == 5


def test_rest_pose_has_zero_rotations(tmp_path, mocap):
    """The T-pose the offsets describe, written as a motion, gives zero rotation channels:
    the rotations are relative to the documented rest pose (and the Euler order matches
    the reader's: the positions come back too)."""
    m = bvh_motion(mocap[CLIPS[0]])
    rest = np.zeros((len(m.names), 3))
    for n in range(1, len(m.names)):
        rest[n] = rest[m.parents[n]] + m.offsets[n]
    pose = rest[[list(m.joint_index).index(j) for j in range(17)]] + np.array([0.0, 0.9, 0.0])
    X = np.repeat(pose[None], 3, axis=0)
    path = write_bvh(tmp_path / "rest.bvh", X, FPS)
    rows = np.loadtxt(path, skiprows=path.read_text().splitlines().index("MOTION") + 3, ndmin=2)
    assert rows.shape == (3, 6 + 3 * (len(m.names) - 1))
    assert np.abs(rows[:, 3:]).max() < 1e-4
    assert np.abs(read_positions(path) - X).max() < 1e-5


def test_missing_joints_are_filled_and_reported(tmp_path, mocap):
    X = mocap[CLIPS[0]][:30].copy()
    X[10] = np.nan  # a whole frame
    X[20, 13] = np.nan  # a wrist
    X[0, 3] = np.inf  # an ankle in the first frame: held from the next finite sample
    X = X.astype(np.float64)  # the writer reads float64 poses without a copy: it must not change them
    given = X.copy()
    m = bvh_motion(X)
    expect = np.zeros((30, 17), bool)
    expect[10] = True
    expect[20, 13] = expect[0, 3] = True
    np.testing.assert_array_equal(m.filled, expect)
    np.testing.assert_array_equal(np.flatnonzero(m.filled_frames), [0, 10, 20])
    path = write_bvh(tmp_path / "gaps.bvh", X, FPS)
    np.testing.assert_array_equal(X, given)
    assert "nan" not in path.read_text().lower() and "inf" not in path.read_text().lower()
    Y = read_positions(path)
    ok = ~expect.any(axis=1)
    assert np.abs(Y[ok] - rigidify(X)[ok]).max() < 1e-3
    # the filled whole frame is the interpolation of its neighbours (then rigidified)
    filled = X.copy()
    filled[10] = (X[9] + X[11]) / 2
    filled[20, 13] = (X[19, 13] + X[21, 13]) / 2
    filled[0, 3] = X[1, 3]
    assert np.abs(Y - rigidify(filled)).max() < 1e-3
    assert np.isnan(m.deviation[expect]).all()


def test_bad_input(tmp_path, mocap):
    X = mocap[CLIPS[0]][:5]
    out = tmp_path / "x.bvh"
    cases = [
        ({"poses": X[:, :16]}, r"\(T, 17, 3\).*\(5, 16, 3\)"),
        ({"poses": X[0]}, r"\(T, 17, 3\).*\(17, 3\)"),
        ({"poses": X[:0]}, r"T >= 1"),
        ({"poses": X.astype(str)}, "dtype"),
        ({"fps": 0.0}, r"fps.*got 0"),
        ({"fps": -30.0}, r"fps.*got -30"),
        ({"fps": float("nan")}, "fps"),
        ({"units": "inch"}, r"units.*'inch'"),
        ({"poses": np.full_like(X, np.nan)}, r"all 17 joints finite.*none of 5"),
        ({"joint_names": H36M_JOINTS[:16]}, "17 H36M-17 joint names"),
        ({"joint_names": ("left hip",) + H36M_JOINTS[1:]}, "without whitespace"),
        ({"joint_names": ("spine",) + H36M_JOINTS[1:]}, "unique"),
        ({"poses": np.zeros_like(X)}, "positive length"),
    ]
    for override, match in cases:
        kwargs = {"poses": X, "fps": FPS} | override
        with pytest.raises(InputError, match=match):
            write_bvh(out, kwargs.pop("poses"), kwargs.pop("fps"), **kwargs)
        assert not out.exists()
    with pytest.raises(InputError, match="existing destination folder"):
        write_bvh(tmp_path / "no" / "x.bvh", X, FPS)


def test_failed_write_leaves_the_old_file(tmp_path, mocap):
    out = write_bvh(tmp_path / "x.bvh", mocap[CLIPS[0]][:5], FPS)
    before = out.read_bytes()
    with pytest.raises(InputError):
        write_bvh(out, np.full((5, 17, 3), np.nan), FPS)
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.bvh"]


@pytest.mark.parametrize("clip", CLIPS)
def test_channels_are_continuous(mocap, clip):
    """Real motion capture at 30 fps turns no joint by more than ~30 degrees per frame: the
    channels must not jump either (no 360-degree wraps, no gimbal-lock flips: a single ZXY
    order for the arms would lock with the arms hanging, as in all three clips)."""
    m = bvh_motion(mocap[clip])
    step = np.abs(np.diff(m.euler_deg, axis=0))
    assert step.max() < 45, (m.names[np.unravel_index(step.argmax(), step.shape)[1]], step.max())


def test_written_in_blocks_equals_the_whole_recording(tmp_path, mocap, monkeypatch):
    """write_bvh streams its channels a block of frames at a time (bounded memory for long
    recordings); with tiny blocks the file must hold what bvh_motion computes at once,
    including the unwrapping and the holding of a degenerate pelvis frame across block edges."""
    import pcnet.stages.sinks.bvh as bvh

    X = np.concatenate([mocap[c] for c in CLIPS])
    X[40:45, 3] = np.nan
    X[63, 4] = X[63, 1] + (X[63, 7] - X[63, 0])  # first frame of a block: hip line along the spine, frame held
    m = bvh_motion(X)
    monkeypatch.setattr(bvh, "TEXT_BLOCK_ROWS", 7)
    path = write_bvh(tmp_path / "blocks.bvh", X, FPS)
    rows = path.read_text().split("Frame Time:")[1].splitlines()[1:]
    values = np.array([[float(v) for v in r.split()] for r in rows])
    expected = np.concatenate([m.root_position, m.euler_deg.reshape(len(X), -1)], axis=1)
    assert values.shape == expected.shape
    assert np.abs(values - expected).max() < 1e-6  # the file's 6 decimals
    # A long recording's poses are on disk: read a block at a time, the same file.
    from pcnet.stages.core.framestore import FrameStore

    with FrameStore(tmp_path) as store:
        on_disk = store.create("poses", X.shape, np.float64)
        on_disk[0 : len(X)] = X
        assert write_bvh(tmp_path / "disk.bvh", on_disk, FPS).read_text() == path.read_text()
        # ... and with the skeleton's per-frame samples on disk too (what pcnet run does)
        assert write_bvh(tmp_path / "disk2.bvh", on_disk, FPS, allocate=store.create).read_text() == path.read_text()


@pytest.mark.parametrize("lifter", ["mediapipe", "videopose3d"])
@pytest.mark.slow
def test_run_bvh_stands_on_the_trc_floor(tmp_path, lifter):
    """Issue 51: a real `pcnet run`'s world.bvh (read back by bvhio's forward kinematics)
    stands on the floor of its world.trc: in every frame the TRC has markers, the BVH's
    lowest joint (over those markers' joints) is at the TRC's lowest marker height within
    1 cm, so no BVH joint sinks below the floor (y = 0, the world frame's lowest joint). The
    BVH's bones have one (median) length, so the higher foot may differ from its marker by
    the legs' length variation; the lower foot's height agrees. Before the fix (root at the
    measured pelvis), MediaPipe's run put the feet up to 19 cm below the floor in 32 of 60
    frames, VideoPose3D's up to 10 cm."""
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main
    from pcnet.stages.opensim_ik import read_trc

    if lifter == "mediapipe":  # MediaPipe BlazePose world landmarks: bones vary by 20 cm and more
        given = FIXTURES / "mediapipe_blazepose33_f000-059.npz"
        more = []
    else:  # VideoPose3D's standing pose (Tadasana), the first 300 frames
        given = tmp_path / "vp3d.npy"
        np.save(given, np.load(FIXTURES / "yoga_vp3d_Bhumi_Tadasana.npy")[:300])
        more = ["--fps", "30"]
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--lifter", lifter, "--lifter-output", str(given), "--out", str(out),
                                    "--no-recording", *more])
    assert res.exit_code == 0, res.output
    _, trc, labels, units = read_trc(out / "world.trc")
    assert list(labels) == list(H36M_JOINTS) and units == "m"
    bvh = read_positions(out / "world.bvh")
    assert bvh.shape == trc.shape
    present = np.isfinite(trc).all(axis=-1)
    rows = present.any(axis=1)
    assert rows.sum() >= 0.9 * len(trc)
    # the world frame's ground (no pelvis path: per frame): the lowest joint centre stands the
    # fitted ankle clearance above y = 0 (stages/floor.py)
    clearance = ANKLE_CLEARANCE_LEG * np.nanmedian(mean_leg_length(trc))
    assert np.nanmin(trc[..., 1]) == pytest.approx(clearance, abs=1e-5) and clearance > 0.05
    low_trc = np.where(present, trc[..., 1], np.inf).min(axis=1)[rows]
    low_bvh = np.where(present, bvh[..., 1], np.inf).min(axis=1)[rows]
    gap = low_bvh - low_trc
    ankles = [H36M_JOINTS.index("right_ankle"), H36M_JOINTS.index("left_ankle")]
    both = present[:, ankles].all(axis=1)
    ankle_gap = bvh[both][:, ankles, 1] - trc[both][:, ankles, 1]
    foot_gap = bvh[both][:, ankles, 1].min(axis=1) - trc[both][:, ankles, 1].min(axis=1)
    print(f"{lifter}: lowest joint BVH - TRC max {np.abs(gap).max() * 1e3:.3f} mm; lower foot "
          f"{np.abs(foot_gap).max() * 1e3:.3f} mm; each ankle max {np.abs(ankle_gap).max() * 1e2:.1f} cm")
    worst = gap[np.abs(gap).argmax()]
    assert np.abs(gap).max() < 0.01, f"{int((np.abs(gap) >= 0.01).sum())} frames off the floor, worst {worst:+.3f} m"
    assert bvh[..., 1].min() > -0.01  # no foot (no joint) below the floor, gap-filled frames included
    # the feet's floor contact: the lower ankle's height (the higher ankle carries the legs' length error)
    assert np.abs(foot_gap).max() < 0.01
