"""Where a run's pelvis path comes from (pipeline/pelvis_path.py) and the camera it needs:
the focal length's and image size's sources, the reasons a path is not observable, and the
frames held at the ends of a fitted path."""

from __future__ import annotations

import re

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES

from pcnet.pipeline.cli import main
from pcnet.pipeline.pelvis_path import Intrinsics, camera_intrinsics, pelvis_path
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.perspective import focal_px_from_35mm, intrinsics
from pcnet.stages.flags import note_finding

BOX_2D = FIXTURES / "boxing_alphapose_f000-059.json"
BOX_3D = FIXTURES / "boxing_X3D_f000-059.npy"
MOCAP = FIXTURES / "mocap_small.npz"


def test_the_focal_length_comes_from_the_user_then_the_file_then_a_phone():
    file_K = np.array([[1500.0, 0, 500], [0, 1500.0, 400], [0, 0, 1]])
    given = camera_intrinsics(1000.0, file_K, (1920, 1080))
    assert given.matrix[0, 0] == 1000.0 and tuple(given.matrix[:2, 2]) == (960.0, 540.0) and "given" in given.source
    assert camera_intrinsics(None, file_K, (1920, 1080)).matrix is not None
    np.testing.assert_array_equal(camera_intrinsics(None, file_K, None).matrix, file_K)
    assumed = camera_intrinsics(None, None, (1920, 1080))
    assert assumed.matrix[0, 0] == pytest.approx(focal_px_from_35mm(1920, 1080)) and "--focal-px" in assumed.source
    unknown = camera_intrinsics(1000.0, None, None)
    assert unknown.matrix is None and "--image-size" in unknown.source


def _projected_walk(T: int = 90):
    """A real mocap walk (Bandai fixture) 5 m in front of a level camera: root-relative camera-frame
    joints (m) and their exact 2D projection (confidence 1), the true pelvis path, and K."""
    with np.load(MOCAP) as z:
        world = z["dataset-2_walk-turn-left_active_001"][:T].astype(np.float64)
    cam = world * np.array([1.0, -1.0, -1.0]) + np.array([0.0, 1.0, 5.0])  # Y up -> y down, facing the camera
    K = camera_intrinsics(None, None, (1920, 1080)).matrix
    uv = cam @ K.T
    kp = np.concatenate([uv[..., :2] / uv[..., 2:], np.ones((T, 17, 1))], axis=-1)
    return cam - cam[:, :1], kp, cam[:, 0], K


def test_a_fitted_path_holds_its_ends_where_the_2d_keypoints_have_no_fit():
    rel, kp, pelvis, _ = _projected_walk()
    kp[:3] = np.nan  # no detection in the first three frames: the 3D pose is there, the path is not
    path = pelvis_path(None, rel, kp, camera_intrinsics(None, None, (1920, 1080)), "m", 30.0, 0.3)
    assert path.kind == "from 2D keypoints" and "held at its first/last fitted position in 3 frames" in path.note
    np.testing.assert_allclose(path.camera[3:], pelvis[3:], atol=0.01)  # exact projection: the fit is the truth
    np.testing.assert_array_equal(path.camera[:3], np.repeat(path.camera[3:4], 3, axis=0))
    std = path.world_std(np.eye(3))
    assert std.shape == (90, 3) and np.all(std[3:, 2] > std[3:, 0])  # depth is the weak axis


def test_the_path_note_counts_fitted_frames_apart_from_bridged_ones():
    """Frames with nobody in the 2D keypoints inside the fitted span are bridged by the
    smoother, not counted as fitted (a user trial read "297 of 301 frames" with ten blanked)."""
    rel, kp, _, _ = _projected_walk()
    kp[40:50] = np.nan
    path = pelvis_path(None, rel, kp, camera_intrinsics(None, None, (1920, 1080)), "m", 30.0, 0.3)
    fitted = int(re.search(r"keypoints in (\d+) of 90 frames", path.note).group(1))
    bridged = int(re.search(r"bridged across (\d+) frames? without an accepted fit", path.note).group(1))
    assert fitted <= 80 and bridged >= 10 and fitted + bridged == 90, path.note
    assert np.isfinite(path.camera[40:50]).all()
    # the summary's headline keeps the assumed focal length (a boxing analyst's read only the frames)
    focal = round(focal_px_from_35mm(1920, 1080))
    assert note_finding(path.note).headline == (f"pelvis path fitted to the 2D keypoints in {fitted} of 90 frames, "
                                                f"focal length {focal} px assumed...")  # report.md has the rest


def test_no_path_without_keypoints_metres_or_an_image_size():
    rel, kp, root, _ = _projected_walk(30)
    camera = camera_intrinsics(None, None, (1920, 1080))
    assert pelvis_path(root, rel, kp, camera, "m", 30.0, 0.3).kind == "measured"
    for keypoints, units, cam, why in ((None, "m", camera, "--keypoints2d"), (kp, "normalised", camera, "--height"),
                                       (kp, "m", camera_intrinsics(None, None, None), "--image-size")):
        path = pelvis_path(None, rel, keypoints, cam, units, 30.0, 0.3)
        assert path.kind == "not observable" and path.camera is None and why in path.note


@pytest.mark.parametrize("size, message", [
    ("1920", "--image-size: expected WIDTHxHEIGHT in pixels (e.g. 1920x1080), got '1920'"),
    ("0x1080", "--image-size: expected WIDTHxHEIGHT in pixels"),
])
def test_a_malformed_image_size_is_refused_before_any_work(tmp_path, size, message):
    res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output", str(BOX_3D), "--keypoints2d",
                                    str(BOX_2D), "--keypoints2d-format", "alphapose", "--fps", "30", "--image-size",
                                    size, "--out", str(tmp_path / "o")])
    assert res.exit_code == 1 and message in res.output and not (tmp_path / "o").exists()


def test_an_image_size_contradicting_the_video_is_refused(tmp_path):
    video = FIXTURES / "boxing2_f000-009.mp4"
    res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output", str(BOX_3D), "--video",
                                    str(video), "--image-size", "800x480", "--out", str(tmp_path / "o")])
    assert res.exit_code == 1 and "--image-size 800x480: expected the size of" in res.output and "(854x480)" in res.output
    assert not (tmp_path / "o").exists()


def test_the_path_std_is_turned_into_the_world_by_the_camera_to_world_rotation():
    """``W C W^T``, not ``W^T C W``: with W taking camera z (depth, the weak axis) to world X
    and camera x to world Y, the world X std is the depth std."""
    from pcnet.pipeline.pelvis_path import PelvisPath

    cov = np.diag([1.0, 4.0, 100.0])[None]  # camera x, y, z variances
    W = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # rows: world X, Y, Z in camera coordinates
    std = PelvisPath("from 2D keypoints", np.zeros((1, 3)), cov).world_std(W)
    np.testing.assert_allclose(std, [[10.0, 1.0, 2.0]])


def test_a_focal_length_that_puts_the_body_behind_the_camera_is_refused():
    """A sprint coach gave the lens's millimetres as --focal-px 26 and read a walker at 17 m/s:
    a pinhole camera sees nothing behind it, so the path's body must lie in front of it."""
    rel, kp, pelvis, K = _projected_walk()

    def given(focal: float) -> Intrinsics:  # past camera_intrinsics' lens bound, which refuses 26 px first
        return Intrinsics(intrinsics(1920, 1080, focal), f"focal length {focal:g} px, given")

    with pytest.raises(InputError, match=r"^--focal-px 26: expected a focal length that puts the body in front of the "
                                         r"camera, got one that puts its nearest joint 0\.\d\d m behind it in the median "
                                         r"frame: a focal length in millimetres\? .* \(a phone's 26 mm: "
                                         rf"{focal_px_from_35mm(1920, 1080):.0f} px on this 1920x1080 picture\)"):
        pelvis_path(None, rel, kp, given(26.0), "m", 30.0, 0.3)
    # the true focal length, and one a fifth of it, keep the body in front: a path, no error
    for focal in (K[0, 0], K[0, 0] / 5):
        assert pelvis_path(None, rel, kp, given(focal), "m", 30.0, 0.3).kind == "from 2D keypoints"


def test_a_focal_length_shorter_than_any_lenss_is_refused_before_the_estimator(tmp_path):
    """A coach gave a phone's "26 mm" as --focal-px 26: the body stayed in front of the camera,
    the walker read 18 m/s and the warnings blamed the axes. No rectilinear lens is wider than
    a 9 mm 35 mm equivalent (135 deg across the diagonal), so a shorter focal length is refused
    with the pixels a phone's lens gives; a video alone is refused before the estimator runs."""
    shortest = focal_px_from_35mm(1920, 1080, 9.0)
    assert camera_intrinsics(shortest, None, (1920, 1080)).matrix[0, 0] == shortest  # the widest lens is one
    with pytest.raises(InputError, match=rf"^--focal-px 26: expected a focal length in pixels of at least "
                                         rf"{shortest:.0f} px on this 1920x1080 picture \(a 9 mm 35 mm equivalent, 135 deg "
                                         r"across the diagonal: the widest rectilinear lenses\), got 26 px, a 0\.51 mm "
                                         r"equivalent: a focal length in millimetres\? .*\(a phone's 26 mm: 1324 px here\)"):
        camera_intrinsics(26.0, None, (1920, 1080))
    res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output", str(BOX_3D), "--keypoints2d",
                                    str(BOX_2D), "--keypoints2d-format", "alphapose", "--fps", "30", "--image-size",
                                    "854x480", "--focal-px", "26", "--out", str(tmp_path / "o")])
    assert res.exit_code == 1 and "--focal-px 26: expected a focal length in pixels of at least 204 px" in res.output
    assert not (tmp_path / "o").exists()
