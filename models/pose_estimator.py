"""The embedded pose estimator of `pcnet run --video`: MediaPipe's BlazePose GHUM 3D (full)
over every frame of a video, on the CPU, offline.

MediaPipe's Tasks ``PoseLandmarker`` (google-ai-edge/mediapipe
``mediapipe/tasks/python/vision/pose_landmarker.py``, release 1.2.3) runs in ``VIDEO`` mode:
the detector finds the person once, then the landmark model tracks them from frame to frame
(re-running the detector where the track is lost), with MediaPipe's landmark smoothing
between frames. A frame whose pose came from the detector's box is seen once more, from the
crop its own landmarks give, as every tracked frame is. The model bundle ships with pcnet
(:data:`POSE_TASK`, built by ``benchmarks/build_pose_task.py`` from the Apache-2.0 models of
MediaPipe 0.10.21), so nothing is downloaded at run time.

Per frame it gives what the legacy ``solutions.pose`` gave (the shared reference files'
``mediapipe_extract.py``): 33 image landmarks (normalised x, y; visibility) and 33 world
landmarks (metres, origin between the hips, the axes of the camera the model sees:
:mod:`pcnet.adapters.mediapipe`). MediaPipe follows one person (``num_poses=1``): where
several people are in view, it may switch between them, which pcnet's 2D track check flags
(:func:`pcnet.stages.flags.track_switch_flag`); a region of the picture (``pcnet run --roi``)
keeps it on the person there.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from pcnet.adapters.video import opencv
from pcnet.stages.core.errors import InputError, import_extra

#: The model bundle: pose_detector.tflite + pose_landmarks_detector.tflite (BlazePose GHUM
#: 3D full; Apache-2.0, models/weights/LICENSE-mediapipe.txt).
POSE_TASK = Path(__file__).parent / "weights" / "pose_landmarker_full.task"
#: What a missing extra says.
MISSING_EXTRA = ('pcnet run --video without a lifter output needs the embedded estimator: pip install '
                 '"pcnet[video]" (MediaPipe 1.2.3: wheels for Linux x86_64 and aarch64 with glibc 2.28+, macOS on '
                 'Apple silicon, Windows x86_64; not Intel Macs)')
BLAZEPOSE_JOINTS = 33


def estimator_record() -> dict:
    """What identifies the embedded estimator in a run's report (``inputs.pose_estimator``): its
    model, the bundle's file name and sha256, and the installed MediaPipe's version (``None``
    where it is not installed). A product that swaps estimators can tell a video-alone run from
    a MediaPipe file given to ``--lifter mediapipe`` by it (an estimator-swapping trial found
    the two recorded alike).

    Raises:
        OSError: the shipped model bundle cannot be read.
    """
    import importlib.metadata

    from pcnet.stages.core.digest import sha256_file_version

    try:
        version = importlib.metadata.version("mediapipe")
    except importlib.metadata.PackageNotFoundError:
        version = None
    return {"model": "MediaPipe BlazePose GHUM 3D (full), pcnet's embedded estimator", "bundle": POSE_TASK.name,
            "bundle_sha256": sha256_file_version(POSE_TASK), "mediapipe_version": version}


@dataclass(frozen=True)
class BlazePoseTrack:
    """BlazePose-33 landmarks of one person over a video.

    Attributes:
        keypoints_2d: ``(T, 33, 3)`` float32: x, y in pixels of the decoded frame (OpenCV's
            decoding, which applies the container's display rotation), visibility in [0, 1];
            NaN rows where nobody was found.
        world_3d: ``(T, 33, 3)`` float32: MediaPipe's world landmarks in metres (origin
            between the hips, x right, y down, z away from the camera the model sees); NaN
            rows where nobody was found.
        fps: the container's frame rate.
        width, height: the decoded frame's size in pixels.
    """

    keypoints_2d: np.ndarray
    world_3d: np.ndarray
    fps: float
    width: int
    height: int

    @property
    def found(self) -> np.ndarray:
        """``(T,)`` bool: frames with a person."""
        return np.isfinite(self.keypoints_2d[:, 0, 0])


@contextlib.contextmanager
def _native_logs_silenced() -> Iterator[object]:
    """Send what native code writes to stderr (MediaPipe's and LiteRT's start-up logs: some
    50 INFO and WARNING lines per run that concern the model file, not the user's video) to
    the null device, and yield a text stream on the real stderr for the progress bar."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        with os.fdopen(os.dup(saved), "w") as real_stderr:
            yield real_stderr
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _open(video: Path) -> tuple[object, float, int]:
    """The opened video, its frame rate and its frame count (0 where the container does not say).

    Raises:
        InputError: the file is missing or no decoder opens it, or it states no frame rate.
    """
    if not video.is_file():
        raise InputError(f"{video}: expected a video file, got {'a folder' if video.is_dir() else 'no such file'}")
    cv2 = opencv()  # imported here: a run without a video never loads OpenCV (an API trial's 1 s)
    capture = cv2.VideoCapture(str(video))  # FFmpeg's log quieted before the first open
    if not capture.isOpened():
        raise InputError(f"{video}: expected a video OpenCV can decode (mp4, mov, avi, ...), got a file it cannot open")
    fps = capture.get(cv2.CAP_PROP_FPS)
    if not (math.isfinite(fps) and fps > 0):
        capture.release()
        raise InputError(f"{video}: expected a frame rate in the container, got {fps!r}; re-encode the video "
                         f"(ffmpeg -i IN -r 30 OUT.mp4)")
    return capture, float(fps), max(int(capture.get(cv2.CAP_PROP_FRAME_COUNT)), 0)


def estimate_video(video: str | Path, progress: bool = False,
                   region: tuple[int, int, int, int] | None = None, *, relook: bool = True) -> BlazePoseTrack:
    """Run BlazePose GHUM 3D (full) over every decodable frame of ``video``.

    Args:
        video: a video file OpenCV decodes.
        progress: a frame progress bar on stderr (where stderr is a terminal).
        region: ``(x, y, width, height)`` in pixels of the frames as decoded (displayed): the
            estimator sees only that part of each frame, so that it follows the person there
            and not another one elsewhere in view (``pcnet run --roi``). The landmarks are
            returned in the whole frame's pixels, so the camera's intrinsics (focal length,
            principal point at the frame's centre) stay the whole frame's. ``None``: the whole
            frame.
        relook: a frame whose pose came from the detector's box is seen once more, from the
            crop its own landmarks give (module docstring); ``False`` keeps the detector's
            frame as it came (the ablation of ``benchmarks/video_estimator.py``).

    Returns:
        :class:`BlazePoseTrack`.

    Raises:
        InputError: the extra is missing (:data:`MISSING_EXTRA`), the video cannot be
            decoded or has no frame, ``region`` does not lie inside the frames, or nobody was
            found in any frame.
        KeyboardInterrupt: Ctrl-C or SIGTERM (the caller removes what it staged).
    """
    import_extra("mediapipe", MISSING_EXTRA)
    from mediapipe.tasks.python.core.base_options import BaseOptions
    from mediapipe.tasks.python.vision import pose_landmarker
    from mediapipe.tasks.python.vision.core import image as mp_image
    from mediapipe.tasks.python.vision.core.vision_task_running_mode import VisionTaskRunningMode

    video = Path(video)
    capture, fps, count = _open(video)
    cv2 = opencv()  # imported by _open; bound once for the frame loop
    options = pose_landmarker.PoseLandmarkerOptions(
        base_options=BaseOptions(model_asset_path=str(POSE_TASK)), running_mode=VisionTaskRunningMode.VIDEO,
        num_poses=1, output_segmentation_masks=False)
    keypoints, world = [], []
    width = height = 0
    calls, tracked = 0, False
    try:
        with _native_logs_silenced() as stderr, pose_landmarker.PoseLandmarker.create_from_options(options) as landmarker, \
                tqdm(total=count or None, desc="MediaPipe", unit="frame", file=stderr,
                     disable=None if progress else True) as bar:
            while True:
                ok, frame = capture.read()
                if not ok:
                    break
                height, width = frame.shape[:2]
                x0, y0, seen_w, seen_h = region or (0, 0, width, height)
                if x0 + seen_w > width or y0 + seen_h > height:
                    raise InputError(f"--roi {x0},{y0},{seen_w},{seen_h}: expected a region inside {video}'s "
                                     f"{width}x{height} frames (as displayed), got one reaching x = {x0 + seen_w}, "
                                     f"y = {y0 + seen_h}")
                seen = frame[y0:y0 + seen_h, x0:x0 + seen_w]
                image = mp_image.Image(image_format=mp_image.ImageFormat.SRGB,
                                       data=np.ascontiguousarray(cv2.cvtColor(seen, cv2.COLOR_BGR2RGB)))
                # Where no pose was tracked into this frame, the detector's box is the landmark
                # model's crop; every later frame's crop comes from the landmarks before it. The
                # frame is seen again from its own landmarks' crop, so that every frame's pose is
                # a tracked one (a first frame 3-6 times further from the next than the median
                # step read as a still subject's peak speed: two user trials).
                for _ in range(1 if tracked or not relook else 2):
                    # VIDEO mode needs strictly increasing timestamps (ms), one frame interval apart
                    result = landmarker.detect_for_video(image, round(calls * 1000.0 / fps))
                    calls += 1
                    tracked = bool(result.pose_landmarks)
                    if not tracked:
                        break
                if result.pose_landmarks:
                    keypoints.append(np.array([[x0 + p.x * seen_w, y0 + p.y * seen_h, p.visibility]
                                               for p in result.pose_landmarks[0]], np.float32))
                    world.append(np.array([[p.x, p.y, p.z] for p in result.pose_world_landmarks[0]], np.float32))
                else:
                    keypoints.append(np.full((BLAZEPOSE_JOINTS, 3), np.nan, np.float32))
                    world.append(np.full((BLAZEPOSE_JOINTS, 3), np.nan, np.float32))
                bar.update()
    finally:
        capture.release()
    if not keypoints:
        raise InputError(f"{video}: expected decodable frames, got none (a damaged file or a codec OpenCV lacks?)")
    track = BlazePoseTrack(np.stack(keypoints), np.stack(world), fps, width, height)
    if not track.found.any():
        where = "" if region is None else f" inside --roi {','.join(map(str, region))}"
        raise InputError(f"{video}: expected a person in view{where}, got none in any of {len(keypoints)} frames "
                         f"(MediaPipe BlazePose)")
    return track
