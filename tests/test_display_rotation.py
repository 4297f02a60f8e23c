"""Phone videos stored turned from how they are displayed (MP4 display rotation): probing the
rotation, telling which frames the 2D keypoints are in, and turning them into the displayed frame,
on the real boxing fixtures re-stored the way a phone stores a portrait video."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from conftest import FIXTURES, ROOT
from pcnet.adapters import VideoInfo, get_2d_adapter, iter_frames, probe_video
from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import run_pipeline
from pcnet.stages.remap import remap_to_h36m
from pcnet.pipeline.video_orientation import (DisplayOrientation, display_turn, displayed_pixels, keypoint_frame,
                                              keypoints_extent, stored_pixels)
from pcnet.stages.core.rotations import angle_between

if str(ROOT) not in sys.path:  # benchmarks/ is a package of the repository, not of the installed pcnet
    sys.path.append(str(ROOT))
from benchmarks import display_rotation  # noqa: E402

CLIP = FIXTURES / "boxing2_f000-009.mp4"
RUN = dict(keypoints2d=str(FIXTURES / "boxing_alphapose_f000-059.json"), keypoints2d_format="alphapose",
           lifter="motionbert", lifter_output=str(FIXTURES / "boxing_X3D_f000-059.npy"))


@pytest.mark.parametrize("rotation", [90, 180, 270])
def test_probe_reads_the_display_rotation_a_phone_writes(tmp_path, rotation):
    """Frames stored turned counter-clockwise, the rotation in the track header: OpenCV shows
    the original frames, and the probe reports the rotation and both sizes."""
    video = tmp_path / "phone.mp4"
    display_rotation.write_stored_video(CLIP, video, rotation, rotation)
    info = probe_video(video)
    assert (info.rotation_deg, info.width, info.height, info.frame_count) == (rotation, 854, 480, 10)
    assert info.stored_size == ((480, 854) if rotation in (90, 270) else (854, 480))
    shown, original = next(iter(iter_frames(video))), next(iter(iter_frames(CLIP)))
    assert shown.shape == original.shape
    assert np.abs(shown.astype(int) - original).mean() < 8  # the same picture, re-encoded
    assert probe_video(CLIP).rotation_deg == 0


@pytest.mark.parametrize("rotation", [90, 180, 270])
def test_display_turn_and_pixels_undo_the_storage(rotation):
    """Pixels and camera axes turn together: the displayed image's up, as pixels moved into the
    stored frame, points where the display turn puts the camera's up, and both mappings
    return to the displayed frame exactly."""
    top, bottom = np.array([400.0, 100.0]), np.array([400.0, 300.0])  # displayed: top above bottom
    stored = stored_pixels(np.stack([top, bottom]), rotation, 854, 480)
    up_px = (stored[0] - stored[1]) / np.linalg.norm(stored[0] - stored[1])
    Q = display_turn(rotation)
    np.testing.assert_allclose(up_px, (Q @ [0.0, -1.0, 0.0])[:2], atol=1e-12)
    np.testing.assert_allclose(displayed_pixels(stored, rotation, 854, 480), np.stack([top, bottom]), atol=1e-12)
    image = np.zeros((480, 854), np.uint8)
    image[100, 400] = 255  # the displayed frame's pixel (x 400, y 100), stored the way a phone stores it
    row, col = np.argwhere(cv2.rotate(image, display_rotation.STORE[rotation]))[0]
    np.testing.assert_array_equal(stored[0], [col, row])
    X = np.load(RUN["lifter_output"])[:5].astype(np.float64)
    turned = DisplayOrientation(rotation, "stored", Q)
    np.testing.assert_allclose(turned.joints(X @ Q.T), X, atol=1e-12)
    assert DisplayOrientation().joints(X) is X
    with pytest.raises(ValueError, match="rotation_deg"):
        display_turn(45)


def test_keypoint_frame_is_the_one_whose_size_holds_the_keypoints():
    video = VideoInfo("phone.mp4", 10, 30.0, 1080, 1920, rotation_deg=90)  # portrait as displayed
    kp = np.full((2, 17, 3), np.nan)
    kp[0, :3, :2] = [[100, 200], [1500, 300], [900, 1000]]  # x beyond the displayed width: stored
    assert keypoint_frame(video, kp) == "stored"
    kp[0, :3, :2] = [[100, 200], [1000, 1700], [900, 1000]]  # y beyond the stored height: displayed
    assert keypoint_frame(video, kp) == "displayed"
    kp[0, :3, :2] = [[100, 200], [1000, 1100], [900, 1000]]  # fits both (within the 5 % edge margin)
    assert keypoint_frame(video, kp) == "unknown"
    # the keypoint file's own image size (MediaPipe's archive states it) tells
    assert keypoint_frame(video, kp, image_size=(1920, 1080)) == "stored"
    assert keypoint_frame(video, kp, image_size=(1080, 1920)) == "displayed"
    assert keypoint_frame(video, kp, image_size=(640, 480)) == "unknown"
    kp[0, :3, :2] = [[100, 200], [3000, 3000], [900, 1000]]  # fits neither: not this video's pixels
    assert keypoint_frame(video, kp) == "unknown"
    assert keypoint_frame(VideoInfo("landscape.mp4", 10, 30.0, 854, 480), kp) == "unknown"
    # the H36M-17 joints fit both frames, but the file's own feet (beyond the remap) reach
    # past the displayed width: the stored frame (Pose2Sim cam02, whose MediaPipe heels do)
    kp[0, :3, :2] = [[100, 200], [1000, 1100], [900, 1000]]
    feet = np.full((2, 33, 3), np.nan)
    feet[0, :3, :2], feet[0, 30, :2] = kp[0, :3, :2], [1167, 1050]
    assert keypoint_frame(video, kp) == "unknown"
    assert keypoints_extent(feet).tolist() == [1167.0, 1100.0]
    assert keypoint_frame(video, kp, extent=keypoints_extent(feet)) == "stored"



def test_a_half_turn_is_told_by_the_body_standing_on_its_head():
    """Landscape filmed with the phone the other way round: the frame size does not change, so
    the real keypoints of the boxing fixture tell, upright as displayed or upside down as
    stored; a body lying across the image tells nothing."""
    from pcnet.adapters import load_alphapose
    from pcnet.stages.remap import remap_to_h36m

    kp = load_alphapose(RUN["keypoints2d"])
    kp2d = remap_to_h36m(kp.points, kp.layout, confidence_channel=True)
    video = VideoInfo("phone.mp4", 60, 30.0, 854, 480, rotation_deg=180)
    assert keypoint_frame(video, kp2d) == "displayed"
    stored = kp2d.copy()
    stored[..., :2] = stored_pixels(kp2d[..., :2], 180, 854, 480)
    assert keypoint_frame(video, stored) == "stored"
    lying = kp2d.copy()
    lying[..., :2] = stored_pixels(kp2d[..., :2], 90, 854, 480)
    assert keypoint_frame(video, lying) == "unknown"


def _clip_inputs(tmp_path) -> dict:
    """The fixture's keypoints and lifter output cut to the video fixture's 10 frames."""
    people = [p for p in json.loads(Path(RUN["keypoints2d"]).read_text()) if int(p["image_id"].split(".")[0]) < 10]
    (tmp_path / "kp.json").write_text(json.dumps(people))
    np.save(tmp_path / "X3D.npy", np.load(RUN["lifter_output"])[:10])
    return dict(RUN, keypoints2d=str(tmp_path / "kp.json"), lifter_output=str(tmp_path / "X3D.npy"))


def _run(tmp_path, name: str, rotation: int, tag: int, stored: bool):
    folder = tmp_path / name
    folder.mkdir()
    video = folder / "video.mp4"
    display_rotation.write_stored_video(CLIP, video, rotation, tag)
    run = display_rotation.write_stored_inputs(_clip_inputs(tmp_path), tmp_path, folder, rotation if stored else 0,
                                               854, 480)
    cfg = RunConfig(**dict(run, video=str(video)), out=str(folder / "out"), mode="sequence", recording=False)
    return run_pipeline(cfg, progress=False)


@pytest.mark.slow
def test_pcnet_run_on_a_phone_video_whose_frames_the_detector_read_as_stored(tmp_path):
    """Real MotionBERT poses of the boxing fixture, re-stored turned 90 deg with the rotation in
    the container and the keypoints in the stored frames: pcnet turns them back into the
    displayed frame, so the run is the original's (same up, pitch, roll and camera-frame
    outputs) and says what it did. With the rotation lost the same poses are read as a body
    lying under a level camera (the documented limit)."""
    original = _run(tmp_path, "original", 0, 0, False)
    turned = _run(tmp_path, "turned", 90, 90, True)
    lost = _run(tmp_path, "lost", 90, 0, True)
    up = original.report.rectification.sequence.up
    assert original.report.rectification.posture.most_probable == "upright" and not turned.report.rectification.lying
    assert np.degrees(angle_between(turned.report.rectification.sequence.up, up)) < 0.01
    assert abs(turned.camera_pitch_deg - original.camera_pitch_deg) < 0.01
    assert abs(turned.camera_roll_deg - original.camera_roll_deg) < 0.01
    assert turned.report.display_rotation == {"rotation_deg": 90, "keypoint_frame": "stored",
                                                 "turned_into_displayed_frame": True}
    assert any("turned into the displayed frame" in n for n in turned.notes), turned.notes
    a, b = (np.load(r.outputs["canonical.npz"]) for r in (original, turned))
    np.testing.assert_allclose(b["joints_camera"], a["joints_camera"], atol=1e-5)
    np.testing.assert_allclose(b["keypoints2d"], a["keypoints2d"], atol=1e-3)
    assert original.report.display_rotation is None and lost.report.display_rotation is None
    assert lost.report.rectification.lying
    assert np.degrees(angle_between(lost.report.rectification.sequence.up, display_turn(90) @ up)) > 45.0



@pytest.mark.slow
def test_the_recording_draws_the_keypoints_where_rerun_shows_the_video(tmp_path):
    """rerun's viewer shows an MP4 as stored, without its display rotation, so the recording's
    2D overlay is in the stored frames (the keypoint file's own pixels here), while
    canonical.npz keeps them in the displayed frame; the summary says so."""
    from conftest import rrd_summary

    folder = tmp_path / "turned"
    folder.mkdir()
    video = folder / "video.mp4"
    display_rotation.write_stored_video(CLIP, video, 90, 90)
    run = display_rotation.write_stored_inputs(_clip_inputs(tmp_path), tmp_path, folder, 90, 854, 480)
    result = run_pipeline(RunConfig(**dict(run, video=str(video)), out=str(folder / "out")), progress=False)
    assert any("shows the video as stored" in n for n in result.notes), result.notes
    _, _, chunks, _ = rrd_summary(folder / "out" / "recording.rrd")
    stored = get_2d_adapter("alphapose").load(run["keypoints2d"])
    stored_h36m = remap_to_h36m(stored.points, stored.layout, confidence_channel=True)
    drawn = 0
    for ch in chunks["/video/keypoints"]:
        rb = ch.to_record_batch()
        for t, ids, xy in zip(*(rb.column(c).to_pylist() for c in ("frame", "Points2D:keypoint_ids", "Points2D:positions"))):
            np.testing.assert_allclose(np.array(xy), stored_h36m[t, ids, :2], atol=1e-3)
            drawn += len(ids)
    assert drawn > 100
    displayed = np.load(result.outputs["canonical.npz"])["keypoints2d"][..., :2]
    np.testing.assert_allclose(displayed, displayed_pixels(stored_h36m[:10, :, :2], 90, 854, 480), atol=1e-3)


def test_without_keypoints_a_display_rotation_leaves_the_input_and_says_why(tmp_path):
    """A 3D file and a turned video but no 2D keypoints: nothing tells which frames the lifter
    saw, so its output is taken as it is and the note says so."""
    video = tmp_path / "video.mp4"
    display_rotation.write_stored_video(CLIP, video, 90, 90)
    run = _clip_inputs(tmp_path)
    cfg = RunConfig(video=str(video), lifter=run["lifter"], lifter_output=run["lifter_output"], out=str(tmp_path / "out"),
                    mode="sequence", recording=False)
    result = run_pipeline(cfg, progress=False)
    assert result.report.display_rotation == {"rotation_deg": 90, "keypoint_frame": "unknown",
                                                 "turned_into_displayed_frame": False}
    assert any("no 2D keypoints tell which frames" in n for n in result.notes), result.notes


@pytest.mark.slow
def test_a_video_rerun_cannot_play_is_left_out_of_the_recording_with_a_note(tmp_path):
    """The video fixture is MPEG-4 Part 2 (``mp4v``, what OpenCV's own writer makes), which
    rerun does not decode: the run still writes everything, the recording without the
    picture (but with the 2D keypoints), and says so."""
    from conftest import rrd_summary

    run = _clip_inputs(tmp_path)
    result = run_pipeline(RunConfig(**dict(run, video=str(CLIP)), out=str(tmp_path / "out")), progress=False)
    assert any("recording.rrd" in n and "left out" in n and "mp4v" in n for n in result.notes), result.notes
    rows, static, _, _ = rrd_summary(tmp_path / "out" / "recording.rrd")
    assert "/video" not in static and "/video" not in rows
    assert rows["/video/keypoints"] == 10


def test_mediapipe_archive_states_the_frames_it_was_detected_on():
    """The MediaPipe 2D adapter reports the archive's width and height, which decide the frame
    where the keypoints' extent cannot."""
    from pcnet.adapters import load_mediapipe_2d

    kp = load_mediapipe_2d(FIXTURES / "mediapipe_blazepose33_f000-059.npz")
    with np.load(FIXTURES / "mediapipe_blazepose33_f000-059.npz", allow_pickle=False) as f:
        assert kp.image_size == (int(f["width"]), int(f["height"]))
