"""`pcnet run --video V` alone: the embedded MediaPipe estimator (the ``video`` extra) makes
the poses, saves them with the outputs, and the rest of the run is the normal pipeline.
Tests that run the estimator skip where the extra is not installed; CI installs it."""

from __future__ import annotations

import json
import re
import sys

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES, shared

from pcnet.pipeline.cli import main
from pcnet.pipeline.video_estimate import ESTIMATE_FILE

CLIP = FIXTURES / "boxing2_f000-009.mp4"  # 10 real frames, 854x480, 30 fps (tests/fixtures/README.md)


def _invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _one_error_line(res) -> str:
    assert res.exit_code == 1 and isinstance(res.exception, SystemExit), (res.exit_code, res.output, res.exception)
    lines = [ln for ln in res.output.splitlines() if ln.startswith("Error: ")]
    assert len(lines) == 1 and "Traceback" not in res.output, res.output
    return lines[0]


@pytest.fixture
def video_extra():
    pytest.importorskip("mediapipe", reason='the video extra is not installed (pip install "pcnet[video]")')


@pytest.mark.slow
def test_a_video_alone_gives_every_output_and_its_poses_for_a_re_run(tmp_path, video_extra):
    res = _invoke("run", "--video", CLIP, "--out", tmp_path / "a")
    assert res.exit_code == 0, res.output
    made = {p.name for p in (tmp_path / "a").iterdir()}
    assert {"canonical.npz", "kinematics.csv", "world.trc", "recording.rrd", "angles.png", ESTIMATE_FILE} <= made
    assert "poses: MediaPipe BlazePose GHUM 3D (full) on the video, a person in 10 of 10 frames" in res.output
    estimate = tmp_path / "a" / ESTIMATE_FILE
    with np.load(estimate, allow_pickle=False) as f:
        assert f["keypoints_2d"].shape == f["world_3d"].shape == (10, 33, 3)
        assert float(f["fps"]) == 30.0 and int(f["width"]) == 854 and int(f["height"]) == 480
    # the run's record names the poses where they are kept, not the staged folder they were read from
    with np.load(tmp_path / "a" / "canonical.npz", allow_pickle=False) as f:
        report = json.loads(str(f["report"]))
    assert report["inputs"]["lifter_output"] == report["inputs"]["keypoints2d"] == str(estimate.resolve())
    assert f"3D {estimate.resolve()} (--lifter mediapipe" in (tmp_path / "a" / "report.md").read_text()
    # the saved poses are a lifter output and 2D keypoints as they stand: the same run again
    again = _invoke("run", "--video", CLIP, "--lifter", "mediapipe", "--lifter-output", estimate, "--keypoints2d",
                    estimate, "--keypoints2d-format", "mediapipe", "--out", tmp_path / "b")
    assert again.exit_code == 0, again.output
    assert (tmp_path / "a" / "kinematics.csv").read_bytes() == (tmp_path / "b" / "kinematics.csv").read_bytes()
    with np.load(tmp_path / "b" / "canonical.npz", allow_pickle=False) as f:  # poses from a file: no estimator ran
        assert "pose_estimator" not in json.loads(str(f["report"]))["inputs"] and "pose_estimator" in report["inputs"]


@pytest.mark.slow
def test_a_region_shows_the_estimator_part_of_the_picture_in_whole_frame_pixels(tmp_path, video_extra):
    """A coach's trial: the estimator followed the man on a box, not the walker, with no way to
    choose. --roi shows it one region; its landmarks come back in the whole frame's pixels (the
    camera geometry stays the whole frame's), and a region without the boxer finds nobody."""
    from pcnet.models.pose_estimator import estimate_video

    whole = estimate_video(CLIP)
    x, y = whole.keypoints_2d[..., 0], whole.keypoints_2d[..., 1]
    region = (250, 40, 400, 420)  # holds the boxer (x 328-555, y 89-404 px in these frames)
    assert region[0] < np.nanmin(x) and np.nanmax(x) < region[0] + region[2]
    assert region[1] < np.nanmin(y) and np.nanmax(y) < region[1] + region[3]
    seen = estimate_video(CLIP, region=region)
    assert (seen.width, seen.height) == (854, 480) and seen.found.all()
    moved = np.linalg.norm(seen.keypoints_2d[..., :2] - whole.keypoints_2d[..., :2], axis=-1)
    assert np.median(moved) < 3.0, np.median(moved)  # the same landmarks, not the region's own pixels
    res = _invoke("run", "--video", CLIP, "--roi", "250,40,400,420", "--out", tmp_path / "a", "--no-recording")
    assert res.exit_code == 0, res.output
    assert "on the video inside --roi 250,40,400,420, a person in 10 of 10 frames" in \
        (tmp_path / "a" / "report.md").read_text()
    with np.load(tmp_path / "a" / "canonical.npz", allow_pickle=False) as f:  # which person: in the record
        inputs = json.loads(str(f["report"]))["inputs"]
    assert inputs["roi"] == [250, 40, 400, 420]
    # which estimator made the poses (a swap trial found a video-alone run recorded as a MediaPipe file)
    import importlib.metadata

    from pcnet.models.pose_estimator import POSE_TASK
    from pcnet.stages.core.digest import sha256_file
    assert inputs["pose_estimator"]["bundle_sha256"] == sha256_file(POSE_TASK)
    assert inputs["pose_estimator"]["mediapipe_version"] == importlib.metadata.version("mediapipe")
    assert f"made from the video by pcnet's embedded estimator (mediapipe {importlib.metadata.version('mediapipe')})" \
        in (tmp_path / "a" / "report.md").read_text()
    from pcnet.pipeline import RunConfig  # a Python caller's four numbers are the command line's text

    assert RunConfig(video=str(CLIP), roi=(250, 40, 400, 420)).validate().roi == "250,40,400,420"
    outside = _one_error_line(_invoke("run", "--video", CLIP, "--roi", "700,0,200,200", "--out", tmp_path / "o"))
    assert outside.endswith("--roi 700,0,200,200: expected a region inside " + str(CLIP) + "'s 854x480 frames (as "
                            "displayed), got one reaching x = 900, y = 200")
    with_lifter = _one_error_line(_invoke("run", "--video", CLIP, "--lifter", "motionbert", "--lifter-output",
                                          FIXTURES / "boxing_X3D_f000-059.npy", "--roi", "0,0,10,10", "--out",
                                          tmp_path / "o"))
    assert "--roi: expected with a video alone (the embedded estimator follows the person inside it)" in with_lifter
    assert "expected X,Y,W,H in pixels" in _one_error_line(_invoke("run", "--video", CLIP, "--roi", "1,2,3",
                                                                   "--out", tmp_path / "o"))
    assert not (tmp_path / "o").exists()


def test_a_video_without_anyone_is_one_line(tmp_path, video_extra):
    blank = tmp_path / "empty_room.mp4"
    writer = cv2.VideoWriter(str(blank), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (320, 240))
    for _ in range(5):
        writer.write(np.full((240, 320, 3), 90, np.uint8))
    writer.release()
    line = _one_error_line(_invoke("run", "--video", blank, "--out", tmp_path / "o"))
    assert "empty_room.mp4: expected a person in view, got none in any of 5 frames" in line
    assert not (tmp_path / "o").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["empty_room.mp4"]


def test_a_file_that_is_no_video_is_one_line(tmp_path, video_extra):
    fake = tmp_path / "notes.mp4"
    fake.write_text("not a video")
    line = _one_error_line(_invoke("run", "--video", fake, "--out", tmp_path / "o"))
    # read before the estimator (its frame rate and size are checked first), as a lifter run reads it
    assert re.search(r"notes\.mp4': field 'video stream': expected a video file OpenCV can open", line), line
    assert not (tmp_path / "o").exists()


def test_without_the_extra_the_line_names_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "mediapipe", None)  # as if not installed: import raises ImportError
    line = _one_error_line(_invoke("run", "--video", CLIP, "--out", tmp_path / "o"))
    assert 'pip install "pcnet[video]"' in line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("args, needle", [
    ((), "expected --lifter and --lifter-output (a 3D lifter's file), or --video alone"),
    (("--keypoints2d", FIXTURES / "alphapose809_f130-159.json", "--keypoints2d-format", "alphapose"),
     "got only 2D keypoints (--keypoints2d): pcnet does not lift 2D keypoints to 3D; run a lifter"),
    (("--video", CLIP, "--keypoints2d", CLIP, "--keypoints2d-format", "mediapipe"),
     "--keypoints2d: expected none with --video alone"),
    (("--video", CLIP, "--lifter", "mediapipe"), "--lifter-output: expected a value with --lifter 'mediapipe'"),
    # the lifter's name is the user's to give: its choices (a coach's trial read only "expected a value")
    (("--lifter-output", FIXTURES / "boxing_X3D_f000-059.npy"),
     "--lifter: expected a value (one of motionbert, ddhpose, videopose3d, mediapipe,"),
    (("--video", CLIP, "--pixel"), "--pixel"),  # a MotionBERT option: not the estimator's
])
def test_inputs_that_do_not_make_a_run_are_refused(tmp_path, args, needle):
    line = _one_error_line(_invoke("run", *args, "--out", tmp_path / "o"))
    assert needle in line, line


def test_a_file_given_without_its_option_is_named_with_the_option():
    """A coach typed `pcnet run demo.mp4` and read only "Got unexpected extra argument"."""
    line = _one_error_line(_invoke("run", "demo.mp4"))
    assert line == "Error: Got unexpected extra argument (demo.mp4) (did you mean --video demo.mp4? see pcnet run --help)"
    assert "did you mean --lifter-output X3D.npy?" in _one_error_line(_invoke("run", "X3D.npy", "--lifter", "motionbert"))
    assert _one_error_line(_invoke("run", "a", "b")).endswith("(a b) (see pcnet run --help)")


@pytest.mark.parametrize("args, needle", [
    (("--focal-px", "26"), "--focal-px 26: expected a focal length in pixels of at least 204 px on this 854x480 picture"),
    (("--fps", "60"), "--fps 60: expected the rate"),
])
def test_a_video_alone_is_refused_before_the_estimator_runs(tmp_path, monkeypatch, args, needle):
    """A coach's trial waited 10-20 s of estimation for a --fps or --focal-px that the video's
    own rate and size refuse; both are read before the estimator is called."""
    import pcnet.pipeline.video_estimate as video_estimate

    def estimator_called(*_args, **_kwargs):
        raise AssertionError("the estimator ran")

    monkeypatch.setattr(video_estimate, "estimate_video", estimator_called)
    line = _one_error_line(_invoke("run", "--video", CLIP, *args, "--out", tmp_path / "o"))
    assert needle in line, line
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_a_batch_row_may_name_only_a_video(tmp_path, video_extra):
    (tmp_path / "clip.mp4").write_bytes(CLIP.read_bytes())
    (tmp_path / "m.csv").write_text("video,out,recording\nclip.mp4,o1,false\n")
    res = _invoke("batch", tmp_path / "m.csv", "--workers", "1")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "o1" / ESTIMATE_FILE).is_file() and (tmp_path / "o1" / "kinematics.csv").is_file()


@pytest.mark.slow
def test_calibrated_videos_agree_with_the_stored_files_and_the_lab(tmp_path, video_extra):
    """The four real calibrated cameras from the .mp4 against the stored MediaPipe 0.10.21
    files (same model, MediaPipe 1.2.3's Tasks graph). Measured (docs/video.md): the sequence
    ups 0.4 / 0.3 / 0.5 / 1.4 deg apart; against the lab's gravity the video's error is at most
    the stored file's + 0.1 deg (3.6 / 5.1 / 4.1 / 5.9 vs 4.0 / 5.3 / 4.0 / 6.8). Held here: three
    cameras within the issue's 1 deg, none worse than the stored file against the lab by more
    than 0.5 deg."""
    from pcnet.pipeline.config import RunConfig
    from pcnet.pipeline.runner import run_pipeline
    from pcnet.stages.core.rotations import angle_between

    def degrees(a, b):
        return float(np.degrees(angle_between(a, b)))

    folder = shared("real", "pose2sim_gravity")  # skips without ../shared/data
    apart = []
    for cam in ("cam01", "cam02", "cam03", "cam04"):
        stored = folder / f"statictrial_{cam}.npz"
        with np.load(stored) as f:
            focal, truth = float(f["K"][0, 0]), np.asarray(f["up_camera"], np.float64)
        ups = []
        for extra in ({"focal_px": focal},  # the camera's focal length, a run option
                      {"lifter": "mediapipe", "lifter_output": str(stored), "keypoints2d": str(stored),
                       "keypoints2d_format": "mediapipe"}):
            cfg = RunConfig(video=str(stored.with_suffix(".mp4")), mode="sequence", recording=False,
                            out=str(tmp_path / f"{cam}{len(ups)}"), **extra)
            ups.append(np.asarray(run_pipeline(cfg).report.rectification.sequence.up, np.float64))
        apart.append(degrees(*ups))
        assert degrees(ups[0], truth) <= degrees(ups[1], truth) + 0.5, (cam, ups, truth)
    assert sum(a <= 1.0 for a in apart) >= 3 and max(apart) < 2.0, apart


@pytest.mark.slow
def test_a_video_whose_estimator_follows_another_person_points_to_roi(tmp_path, video_extra):
    """The real Sports2D video alone: the embedded estimator follows the man on the box, then
    the walker. The track-switch warning asks for ``--roi`` around the person (a clinician's
    trial was told to re-run a tracker the run does not have: the run read the estimator's saved
    file as any 2D format's)."""
    video = shared("real", "sports2d_demo", "demo.mp4")  # skips without ../shared/data
    res = _invoke("run", "--video", video, "--out", tmp_path / "o", "--no-recording")
    assert res.exit_code == 0, res.output
    (line,) = [ln for ln in res.output.splitlines() if "2D track switches" in ln]
    assert line.endswith("-> give --roi around the person (docs/video.md)") and len(line) <= 135, line
    # whom the results follow: the man on the box, up in the picture (a physiotherapist's trial was not told;
    # a coach's could not tell whom pixels named: the words on the line, the pixels in report.md)
    assert "followed the person at the top " in line, line
    report = (tmp_path / "o" / "report.md").read_text()
    x, y = map(int, re.search(r"whose pelvis lies at about \((\d+), (\d+)\) px", report).groups())
    assert y < 994 / 2, report
    assert "tracker" not in report
