"""Non-finite values (inf, NaN) in a lifter's file are missing data, and `pcnet run` and
`pcnet rectify` say so: per joint, the frames in which the file held one, counted where the
file is read (not recomputed from the NaNs later, which would mix in joints missing for
other reasons: untracked, not in the format, no person in the frame)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES

from pcnet.adapters import get_3d_adapter
from pcnet.adapters.validate import nonfinite_line
from pcnet.pipeline.cli import EXAMPLE_DIR, main
from pcnet.pipeline.io import read_pose_array
from pcnet.stages.core.conventions import BLAZEPOSE33, H36M_JOINTS, L_ANKLE, L_WRIST, R_ANKLE, R_WRIST

BOX_3D = FIXTURES / "boxing_X3D_f000-059.npy"
MEDIAPIPE = FIXTURES / "mediapipe_blazepose33_f000-059.npz"
YOGA = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"
LINE = "input: non-finite values (inf/NaN) read as missing: right_ankle 10 frames, left_wrist 2 frames"


def _damaged(src: Path, dst: Path) -> Path:
    """The real poses of ``src`` with right_ankle inf (one coordinate, or all three) in
    frames 5-14 and left_wrist NaN in frames 20-21."""
    poses = np.load(src)
    poses[5:10, R_ANKLE, 2] = np.inf
    poses[10:15, R_ANKLE] = -np.inf
    poses[20:22, L_WRIST, 1] = np.nan
    np.save(dst, poses)
    return dst


def _invoke(*args: object):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_rectify_names_the_joints_and_frames_the_file_held_as_inf_or_nan(tmp_path):
    assert H36M_JOINTS[R_ANKLE] == "right_ankle" and H36M_JOINTS[L_WRIST] == "left_wrist"
    src = _damaged(EXAMPLE_DIR / "X3D.npy", tmp_path / "x.npy")
    res = _invoke("rectify", src, "--out", tmp_path / "r.npz")
    assert res.exit_code == 0, res.output
    lines = [line for line in res.output.splitlines() if not line.startswith("WARNING  ")]  # the poses' own
    assert lines[-1] == LINE, res.output
    assert len(lines) == 3 and lines[1].startswith("camera tilt ")  # the rectification's lines, and this one
    assert np.load(tmp_path / "r.npz")["valid"].all()  # one missing ankle does not cost the frame

    # a file without inf/NaN: no such line
    clean = _invoke("rectify", EXAMPLE_DIR / "X3D.npy", "--out", tmp_path / "c.npz")
    assert clean.exit_code == 0, clean.output
    assert "non-finite" not in clean.output
    assert len([line for line in clean.output.splitlines() if not line.startswith("WARNING  ")]) == 2  # and the tilt


def test_read_pose_array_counts_per_joint_from_an_npz_key(tmp_path):
    poses = np.load(BOX_3D)
    poses[3, 0, 0] = np.inf  # the pelvis, one frame
    np.savez(tmp_path / "p.npz", poses=poses, other=np.zeros(3))
    joints, counts, placeholders = read_pose_array(tmp_path / "p.npz", key="poses")
    assert counts == {"pelvis": 1} and np.isnan(joints[3, 0, 0]) and placeholders == {}
    assert nonfinite_line(counts) == "input: non-finite values (inf/NaN) read as missing: pelvis 1 frame"


def test_pcnet_rectify_names_a_writers_zeros_as_placeholders_not_inf_or_nan(tmp_path):
    """A bad-input trial's wrists written as zeros were read as missing (right) but called
    "non-finite values (inf/NaN)" (wrong)."""
    poses = np.load(BOX_3D)
    poses[:, [13, 16]] = 0.0  # both wrists, every frame
    poses[5, 2, 1] = np.nan  # and one knee's NaN
    np.save(tmp_path / "zeros.npy", poses)
    joints, counts, placeholders = read_pose_array(tmp_path / "zeros.npy")
    assert counts == {"right_knee": 1} and placeholders == {"left_wrist": len(poses), "right_wrist": len(poses)}
    assert np.isnan(joints[:, [13, 16]]).all()
    res = _invoke("rectify", tmp_path / "zeros.npy", "--out", tmp_path / "r.npz")
    assert res.exit_code == 0, res.output
    assert "input: non-finite values (inf/NaN) read as missing: right_knee 1 frame\n" in res.output
    assert (f"input: a writer's placeholders for joints not found (zeros, or a frame on one point) read as missing: "
            f"left_wrist {len(poses)} frames, right_wrist {len(poses)} frames") in res.output


def test_run_summary_extends_its_missing_line_with_the_files_nonfinite_values(tmp_path):
    src = _damaged(BOX_3D, tmp_path / "X3D.npy")
    res = _invoke("run", "--lifter", "motionbert", "--lifter-output", src, "--fps", "30", "--no-recording",
                  "--out", tmp_path / "out")
    assert res.exit_code == 0, res.output
    missing = [ln for ln in res.output.splitlines() if "missing:" in ln]
    assert len(missing) == 1, res.output  # one line: what is missing, and which of it was inf/NaN in the file
    assert missing[0].startswith("note     missing: 2 joints (most: right_ankle 10 of 60 frames); inf/NaN in the input: 2 joints")
    assert "missing: right_ankle 10 of 60 frames, left_wrist 2 of 60 frames; " + LINE in (tmp_path / "out" / "report.md").read_text()
    assert "non-finite" not in res.output.replace(missing[0], "")


def test_mediapipe_frames_without_a_person_are_not_counted_but_inf_is(tmp_path):
    """The real MediaPipe file: frames 0-2 are NaN (no person found: the format's own
    "absent"), not non-finite values read as missing; an inf in a frame with a person is."""
    with np.load(MEDIAPIPE) as data:
        arrays = {k: data[k] for k in data.files}
    assert np.isnan(arrays["world_3d"][:3]).all()
    adapter = get_3d_adapter("mediapipe")
    assert adapter.load(MEDIAPIPE).nonfinite == {}
    ankle = BLAZEPOSE33.joints.index("left_ankle")
    arrays["world_3d"][10:14, ankle, 0] = np.inf  # 4 frames
    np.savez(tmp_path / "mp.npz", **arrays)
    poses = adapter.load(tmp_path / "mp.npz")
    assert poses.nonfinite == {"left_ankle": 4}
    assert np.isnan(poses.joints[10:14, ankle]).all()


def test_generic_csv_empty_cells_are_missing_but_not_nonfinite(tmp_path):
    """An empty CSV cell is the format's "missing"; an ``inf`` or ``nan`` cell is a
    non-finite value the file held."""
    rows = np.load(YOGA).reshape(100, 51).astype(np.float64)
    text = [[repr(float(v)) for v in row] for row in rows]
    for t in range(5):
        text[t][3 * R_WRIST:3 * R_WRIST + 3] = ["", "", ""]  # right_wrist empty in frames 0-4
    for t in range(7, 10):
        text[t][3 * L_ANKLE] = "inf"  # left_ankle's x: inf in frames 7-9
    text[50][3 * R_ANKLE + 1] = "nan"  # right_ankle's y: nan in frame 50
    path = tmp_path / "poses.csv"
    path.write_text("\n".join(",".join(r) for r in text) + "\n")
    poses = get_3d_adapter("generic").load(path)
    assert poses.nonfinite == {"right_ankle": 1, "left_ankle": 3}
    assert np.isnan(poses.joints[:5, R_WRIST]).all() and np.isnan(poses.joints[7:10, L_ANKLE, 0]).all()


def test_nonfinite_line_is_short_for_many_joints():
    counts = {name: i + 1 for i, name in enumerate(H36M_JOINTS)}
    line = nonfinite_line(counts)
    assert line == ("input: non-finite values (inf/NaN) read as missing: right_wrist 17 frames, right_elbow 16 frames, "
                    "right_shoulder 15 frames, left_wrist 14 frames, left_elbow 13 frames, left_shoulder 12 frames, "
                    "11 more joints (66 frames)")
    assert nonfinite_line({}) == ""


def test_summary_counts_every_joint_of_a_long_nonfinite_list(tmp_path):
    """Ten joints of inf/NaN (a CLI fuzz found the summary counting only the six the note
    names): the summary's line is made from the counts, not from the note's text, so the
    joints its "4 more joints" tail only counts are counted too."""
    poses = np.load(BOX_3D)
    poses[-1, 1:11, 0] = np.nan  # ten joints in the last frame, the first of them in the one before too
    poses[-2, 1, 0] = np.nan
    np.save(tmp_path / "X3D.npy", poses)
    res = _invoke("run", "--lifter", "motionbert", "--lifter-output", tmp_path / "X3D.npy", "--fps", "30",
                  "--no-recording", "--out", tmp_path / "out")
    assert res.exit_code == 0, res.output
    (line,) = [ln for ln in res.output.splitlines() if ln.startswith("note     missing:")]
    assert line == "note     missing: 10 joints (most: right_hip 2 of 60 frames); inf/NaN in the input: 10 joints", line
    assert "4 more joints (4 frames)" in (tmp_path / "out" / "report.md").read_text()


@pytest.mark.parametrize("counts", [{"right_ankle": 0}, {"right_ankle": 61}, {"right_ankle": 1.0}])
def test_poses3d_refuses_a_count_that_is_no_frame_count(counts):
    from pcnet.adapters import Poses3D

    with pytest.raises(ValueError, match="nonfinite"):
        Poses3D(np.load(BOX_3D), "h36m17", units="normalised", nonfinite=counts)


def test_placeholder_joints_are_missing_and_the_root_of_root_relative_poses_is_kept():
    """A writer's "not detected" (a frame of zeros, several joints at (0, 0, 0)) is missing
    data like NaN; the real poses around them are untouched, and the pelvis of root-relative
    H36M-17 poses (VideoPose3D: at the origin in every frame) stays."""
    from pcnet.stages.core.conventions import PELVIS, validate_poses

    real = np.load(YOGA)
    real[:, PELVIS] = 0.0  # within 1e-4 m of it in VideoPose3D's export; exactly there in D3DP's
    poses = real.copy()
    poses[20:30] = 0.0  # frames written as zeros
    poses[40:45] = poses[40:45, :1]  # frames collapsed onto the root
    poses[:, [L_WRIST, R_WRIST]] = 0.0  # two joints never tracked
    out = validate_poses(poses, "p.npy", "m")
    missing = np.isnan(out).any(axis=2)
    assert missing[20:30].all() and missing[40:45].all()
    assert missing[:, [L_WRIST, R_WRIST]].all()
    kept = np.ones_like(missing)
    kept[20:30] = kept[40:45] = False
    kept[:, [L_WRIST, R_WRIST]] = False
    np.testing.assert_array_equal(out[kept], real[kept].astype(np.float32))  # the pelvis among them
    assert np.isfinite(validate_poses(real, "p.npy", "m")).all()  # the file as written: nothing taken away
    one = real.copy()
    one[:, L_WRIST] = 0.0  # one joint never tracked (a user trial: kept at the pelvis in every frame)
    out = validate_poses(one, "p.npy", "m")
    assert np.isnan(out[:, L_WRIST]).all() and np.isfinite(np.delete(out, L_WRIST, axis=1)).all()
    moved = np.load(YOGA)  # not root-relative: the pelvis off the origin, a wrist alone on it
    moved[:, L_WRIST] = 0.0
    assert np.isnan(validate_poses(moved, "p.npy", "m")[:, L_WRIST]).all()


def test_keypoints_at_pixel_zero_are_missing(tmp_path):
    """OpenPose-style ``0, 0, 0`` for an undetected joint (and a frame whose keypoints all sit
    on one pixel) in the real MediaPipe file: NaN in all three channels; the rest kept."""
    from pcnet.adapters.validate import checked_keypoints

    with np.load(MEDIAPIPE, allow_pickle=False) as f:
        points = np.asarray(f["keypoints_2d"], np.float32)
    damaged = points.copy()
    damaged[10:12, :, :2] = 0.0
    damaged[30:32, :, :2] = damaged[30:32, :1, :2]
    damaged[:, 15, :2] = 0.0
    out, _ = checked_keypoints(MEDIAPIPE, "keypoints_2d", damaged, "blazepose33")
    blank = np.zeros(points.shape[:2], bool)
    blank[10:12] = blank[30:32] = True
    blank[:, 15] = True
    assert np.isnan(out[blank]).all()
    np.testing.assert_array_equal(out[~blank & np.isfinite(points).all(axis=2)],
                                  points[~blank & np.isfinite(points).all(axis=2)])


def test_run_reads_frames_of_zeros_as_missing_in_its_kinematics(tmp_path):
    """A lifter file with frames written as zeros: those frames are missing in the kinematics
    (flagged, no numbers), not a skeleton collapsed onto the ground."""
    poses = np.load(BOX_3D)
    poses[20:25] = 0.0
    np.save(tmp_path / "X3D.npy", poses)
    res = _invoke("run", "--lifter", "motionbert", "--lifter-output", tmp_path / "X3D.npy", "--fps", "30",
                  "--no-recording", "--out", tmp_path / "out")
    assert res.exit_code == 0, res.output
    import csv

    with open(tmp_path / "out" / "kinematics.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for row in rows[20:25]:
        assert row["valid"] == "0" and row["head_missing"] == "1" and row["head_y_normalised"] == "", row
    assert all(row["head_missing"] == "0" and row["head_y_normalised"] != "" for row in rows[:20])


def test_a_masked_arrays_masked_joints_are_missing():
    """A numpy masked array's mask marks missing joints: NaN, never the values it hides (a
    user trial: a masked wrist held at the origin was rectified as a real position)."""
    from pcnet.pipeline.rectification import rectify
    from pcnet.stages.core.conventions import check_poses, validate_poses

    poses = np.load(FIXTURES / "boxing_X3D_f000-059.npy").astype(np.float64)
    mask = np.zeros(poses.shape, bool)
    mask[10:20, R_WRIST] = True
    masked = np.ma.array(np.where(mask, 0.0, poses), mask=mask)
    for checked in (validate_poses(masked), check_poses(masked)):
        assert np.isnan(checked[10:20, R_WRIST]).all() and np.isfinite(checked[:10]).all()
    res = rectify(masked)
    assert np.isnan(res.canonical[10:20, R_WRIST]).all() and res.valid[10:20].all()
    with pytest.raises(ValueError, match="real-valued"):  # a masked complex array is still no pose
        validate_poses(np.ma.array(poses.astype(complex), mask=False))
