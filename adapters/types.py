"""What every adapter returns: 2D keypoints, 3D poses in the camera frame, video facts,
and the one error type adapters raise.

Contracts (``docs/CONVENTIONS.md``): arrays are float32 ``(T, J, 3)``; missing joints or frames
are NaN, never 0; 2D confidence lies in [0, 1]; 3D poses are in the OpenCV camera frame
(+x right in the image, +y down, +z forward, away from the camera).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pcnet.stages.core.conventions import LAYOUTS, UNSCALED_UNITS, get_layout
from pcnet.stages.core.errors import InputError

#: Units a :class:`Poses3D` may carry. ``normalised`` is MotionBERT's image-normalised
#: scale (about [-1, 1]); ``px`` is image pixels; both stay tagged until a later stage
#: scales them to metres.
POSE_UNITS: tuple[str, ...] = ("m", *UNSCALED_UNITS)


class AdapterError(InputError):
    """A foreign file could not be translated into pcnet's conventions.

    The message is one line and always names the file, the field and what was expected,
    e.g. ``file 'a.json': field 'keypoints': expected 51 or 78 values, got 40``; what was
    found is cut to 300 characters.

    Attributes:
        path: the offending file (or folder) as given.
        field: the key, column, axis or property that failed.
        expected: what the adapter needed.
        got: what it found, or ``None``.
    """

    def __init__(self, path: object, field: str, expected: str, got: object = None):
        self.path = str(path)
        self.field = field
        self.expected = expected
        self.got = got
        msg = f"file {self.path!r}: field {field!r}: expected {expected}"
        if got is not None:
            text = str(got)
            # Foreign content can be huge (a 4000-digit frame index): keep the line readable.
            msg += f", got {text if len(text) <= 300 else text[:297] + '...'}"
        # One line, so that log greps and test matches see file, field and expectation together.
        super().__init__(" ".join(msg.split()))


def _check_array(arr: np.ndarray, what: str, source: str, layout: str) -> None:
    if layout not in LAYOUTS:  # a custom adapter's slip, named with its file (a developer trial)
        raise AdapterError(source, "layout", f"one of {', '.join(sorted(LAYOUTS))}", repr(layout))
    lay = get_layout(layout)
    if not isinstance(arr, np.ndarray) or arr.dtype != np.float32:
        found = f"dtype {arr.dtype}" if isinstance(arr, np.ndarray) else type(arr).__name__
        raise AdapterError(source, what, "a float32 numpy array", found)
    if arr.ndim != 3 or arr.shape[1:] != (lay.num_joints, 3):
        raise AdapterError(source, what, f"shape (T, {lay.num_joints}, 3) for layout {lay.name}", arr.shape)


def _check_fps(fps: object, source: str) -> None:
    # bool is an int subclass, and True frames per second is never meant.
    if fps is None:
        return
    if isinstance(fps, bool) or not isinstance(fps, (int, float, np.integer, np.floating)) \
            or not math.isfinite(fps) or fps <= 0:
        raise ValueError(f"{source}: fps must be None or a positive finite number, got {fps!r}")


@dataclass(frozen=True, eq=False)
class Keypoints2D:
    """2D keypoints of one person over a video.

    Attributes:
        points: float32 ``(T, J, 3)``: x_px, y_px (image pixels, origin top-left, y down)
            and confidence in [0, 1]. A missing joint or frame is NaN in all three channels.
        layout: joint layout name understood by ``pcnet.stages.core.conventions.get_layout``
            (``coco17``, ``halpe26``, ``body25``, ``blazepose33``, ``h36m17``); ``J`` matches it.
        source: path of the file or folder read.
        track_id: the tracker id of the chosen person when the file has one, else ``None``.
        notes: what the adapter did (selection, clipping, fills), for provenance.
        choice: which person was kept, when the file holds several (empty otherwise): the
            run summary shows it, since another choice gives another subject.
        fps: frames per second when the file states it (MediaPipe npz), else ``None``: the
            caller then needs the video or ``--fps``.
        image_size: ``(width, height)`` in pixels of the frames the keypoints were detected
            on, when the file states it (MediaPipe npz), else ``None``.

    ``eq=False`` because numpy arrays have no single truth value; compare ``points``
    explicitly. The dataclass is frozen; the array itself is not copied or locked.
    """

    points: np.ndarray
    layout: str
    source: str
    track_id: int | None = None
    notes: str = ""
    choice: str = ""
    fps: float | None = None
    image_size: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        _check_array(self.points, "points", self.source, self.layout)
        _check_fps(self.fps, self.source)

    @property
    def num_frames(self) -> int:
        return int(self.points.shape[0])


@dataclass(frozen=True, eq=False)
class Poses3D:
    """3D joints of one person over a video, in the camera frame.

    Attributes:
        joints: float32 ``(T, J, 3)`` in the OpenCV camera frame (+x right in the image,
            +y down, +z forward, away from the camera). NaN marks missing joints/frames.
            The root is **as delivered by the source** (e.g. MotionBERT keeps the root's
            image position; D3DP zeroes it): the caller remaps to H36M-17 and subtracts the
            pelvis per frame to get the root-relative poses of ``docs/CONVENTIONS.md``
            (``pcnet.pipeline.io.lifter_joints``, then
            ``pcnet.stages.core.conventions.root_relative``, which returns the poses and a
            per-frame flag: take ``[0]``). For image-scaled units
            (``"normalised"``, ``"px"``) ``pcnet run`` then also makes the body's size constant
            per frame (``pcnet.stages.scale.size_normalising_factors``), so a library chain
            without that step differs from its output by the lifter's size changes.
        layout: joint layout name (see :class:`Keypoints2D`).
        frame: always ``"camera"``.
        units: ``"m"``, ``"normalised"`` (MotionBERT image-normalised) or ``"px"``.
        source: path of the file read.
        notes: how the source was converted (axis flips, units, hypothesis choice, caveats).
        fps: frames per second when the file states it (MediaPipe npz), else ``None``.
        root_translation: True when the root's camera-frame position is a measurement in
            ``units`` (a depth sensor's skeleton: Kinect v1, Azure Kinect), so the pipeline
            keeps the pelvis's path in the world frame; False when the root is zeroed,
            image-normalised or a fixed depth (monocular lifters), where the horizontal
            path is not observable.
        summary_note: one line the run summary should show about this conversion (a
            correction applied to the lifter's output, with the assumption it rests on);
            empty for none.
        frame_turn_deg: median angle (deg) by which the adapter turned each frame from the
            frame the lifter is assumed to answer in into the camera frame (MediaPipe: its
            virtual camera aimed at the person -> the real camera); 0 for none. The
            assumption cannot be checked from the file, so the pipeline flags a turn larger
            than its stated tilt uncertainty (:func:`pcnet.stages.flags.lifter_frame_flag`).
        nonfinite: joint name (of the file's layout, which may differ from ``layout``: a
            Kinect skeleton's) -> number of frames in which the file held a non-finite value
            (``inf``, NaN) for that joint, read as missing (NaN in ``joints``); only joints
            with one. Counted by the adapter where it reads the file
            (:func:`pcnet.adapters.validate.nonfinite_frames`), so joints missing for other
            reasons (not in the format, untracked, no person in the frame) are not in it.
            The run summary shows it (:func:`pcnet.adapters.validate.nonfinite_line`).
        camera_matrix: ``(3, 3)`` float64 intrinsics ``K`` of the camera the poses are in
            (pixels; OpenCV convention) when the file states them (a MediaPipe archive of a
            calibrated camera), else ``None``; the pipeline places the pelvis path from the
            2D keypoints with it.
        depth_sensor: the file is a depth sensor's own skeleton (Kinect v1, Azure Kinect),
            whose tracker labels the sides as if the subject faced the sensor: a mirrored
            skeleton then asks whether the subject faced away, not for other axes or layout.
        breaks: frames (ascending, in ``1..T-1``) where the lifter's output restarts, so the
            pose may jump there (MotionBERT lifts each 243-frame clip on its own: frames 243,
            486, ...); the pipeline takes no speed, acceleration or angle rate across one.
    """

    joints: np.ndarray
    layout: str
    frame: str = "camera"
    units: str = "m"
    source: str = ""
    notes: str = ""
    fps: float | None = None
    root_translation: bool = False
    summary_note: str = ""
    frame_turn_deg: float = 0.0
    nonfinite: dict[str, int] = field(default_factory=dict)
    camera_matrix: np.ndarray | None = None
    depth_sensor: bool = False
    breaks: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        _check_array(self.joints, "joints", self.source, self.layout)
        if list(self.breaks) != sorted(set(self.breaks)) or not all(
                isinstance(b, int) and not isinstance(b, bool) and 0 < b < self.num_frames for b in self.breaks):
            raise ValueError(f"{self.source}: breaks must be ascending frame indices in 1..{self.num_frames - 1}, "
                             f"got {self.breaks!r}"[:300])
        if self.camera_matrix is not None and np.shape(self.camera_matrix) != (3, 3):
            raise ValueError(f"{self.source}: camera_matrix must be (3, 3), got {np.shape(self.camera_matrix)}")
        _check_fps(self.fps, self.source)
        if not all(isinstance(k, str) and isinstance(v, int) and not isinstance(v, bool) and 0 < v <= self.num_frames
                   for k, v in self.nonfinite.items()):
            raise ValueError(f"{self.source}: nonfinite must map joint names to frame counts in 1..{self.num_frames}, "
                             f"got {self.nonfinite!r}"[:300])
        if self.frame != "camera":
            raise ValueError(f"{self.source}: frame must be 'camera', got {self.frame!r}")
        if self.units not in POSE_UNITS:
            raise ValueError(f"{self.source}: units must be one of {POSE_UNITS}, got {self.units!r}")

    @property
    def num_frames(self) -> int:
        return int(self.joints.shape[0])


@dataclass(frozen=True)
class VideoInfo:
    """Facts about a video file as OpenCV reports them.

    Attributes:
        path: the file.
        frame_count: number of frames; ``probe_video`` checks the container's count by
            decoding the last frame and counts by decoding when the container overstates.
        fps: frames per second (> 0).
        width, height: frame size in pixels, as displayed.
        rotation_deg: the container's display rotation, clockwise, one of 0, 90, 180, 270:
            the stored frames are the displayed ones turned by it counter-clockwise (a phone's
            portrait video stored as landscape frames: 90 or 270).
    """

    path: str
    frame_count: int
    fps: float
    width: int
    height: int
    rotation_deg: int = 0

    @property
    def stored_size(self) -> tuple[int, int]:
        """``(width, height)`` of the frames as stored in the file (before the display rotation)."""
        return (self.height, self.width) if self.rotation_deg in (90, 270) else (self.width, self.height)

    @property
    def duration_s(self) -> float:
        return self.frame_count / self.fps
