"""Which way up the lifter saw a video. A phone stores a portrait video as landscape frames plus
a display rotation in its container (:func:`pcnet.adapters.probe_video`), and a 2D detector
may have read the stored frames or the displayed ones. The 2D keypoints' extent tells which;
keypoints and lifter output from the stored frames are turned into the displayed frame, so
the rest of the pipeline sees the picture as the phone showed it: the camera prior's level
camera (image up), the camera-frame network's training views, and the summary's pitch and
roll all refer to the displayed image.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from pcnet.adapters import VideoInfo
from pcnet.stages.core.conventions import PELVIS, THORAX
from pcnet.stages.core.framestore import frame_blocks

#: Share of the frame size by which 2D keypoints may lie beyond the image's edge and still be
#: taken as in that frame (detectors extrapolate joints of a body cut by the edge).
EDGE_MARGIN = 0.05
#: Which frames of a video stored turned from how it is displayed the 2D keypoints are in.
KeypointFrame = Literal["stored", "displayed", "unknown"]
#: A video displayed upside down from how it is stored keeps its frame size; then the body
#: tells: the share of frames whose 2D thorax lies more than half a torso length below the
#: pelvis (head-down in the stored frames: upright as displayed), or above it, needed to call it.
INVERTED_SHARE = 0.8


def display_turn(rotation_deg: int) -> np.ndarray:
    """``(3, 3)`` rotation ``Q`` taking the displayed camera's coordinates (OpenCV axes) to those
    of frames stored turned counter-clockwise by ``rotation_deg`` (``x_stored = Q @ x_displayed``):
    the displayed image's up ``(0, -1, 0)`` goes to ``(-sin a, -cos a, 0)``, so 90 deg puts it
    at the stored image's left.

    Raises:
        ValueError: a rotation other than 0, 90, 180 or 270.
    """
    if rotation_deg not in (0, 90, 180, 270):
        raise ValueError(f"rotation_deg: expected 0, 90, 180 or 270, got {rotation_deg!r}")
    c, s = round(np.cos(np.radians(rotation_deg))), round(np.sin(np.radians(rotation_deg)))
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def displayed_pixels(xy: np.ndarray, rotation_deg: int, width: int, height: int) -> np.ndarray:
    """Pixel coordinates ``(..., 2)`` in frames stored turned counter-clockwise by
    ``rotation_deg`` -> in the ``width x height`` displayed frame (the inverse of
    ``cv2.rotate``'s mapping; NaN stays NaN).

    Raises:
        ValueError: a rotation other than 0, 90, 180 or 270.
    """
    display_turn(rotation_deg)  # the check
    xs, ys = xy[..., 0], xy[..., 1]
    back = {0: (xs, ys), 90: (width - 1 - ys, xs), 180: (width - 1 - xs, height - 1 - ys), 270: (ys, height - 1 - xs)}
    return np.stack(back[rotation_deg], -1)


def stored_pixels(xy: np.ndarray, rotation_deg: int, width: int, height: int) -> np.ndarray:
    """Pixel coordinates ``(..., 2)`` of a ``width x height`` displayed frame -> in the frame
    stored turned counter-clockwise by ``rotation_deg`` (``cv2.rotate``'s mapping; the inverse
    of :func:`displayed_pixels`; NaN stays NaN).

    Raises:
        ValueError: a rotation other than 0, 90, 180 or 270.
    """
    display_turn(rotation_deg)  # the check
    x, y = xy[..., 0], xy[..., 1]
    turned = {0: (x, y), 90: (y, width - 1 - x), 180: (width - 1 - x, height - 1 - y), 270: (height - 1 - y, x)}
    return np.stack(turned[rotation_deg], -1)


def keypoints_extent(points) -> np.ndarray:
    """``(2,)`` the largest x and y (px) of the present keypoints of ``points`` ``(T, J, >=2)``
    (any layout; NaN = missing; read a block of frames at a time); ``-inf`` where none is."""
    top = np.full(2, -np.inf)
    for rows in frame_blocks(len(points)):
        xy = np.asarray(points[rows, :, :2], np.float64).reshape(-1, 2)
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy):
            top = np.maximum(top, xy.max(axis=0))
    return top


def keypoint_frame(video: VideoInfo, kp2d, image_size: tuple[int, int] | None = None,
                   extent: np.ndarray | None = None) -> KeypointFrame:
    """Which frames of a video stored turned from how it is displayed the 2D keypoints are in
    (:data:`KeypointFrame`): for a quarter turn, the one whose size the keypoint file states
    (``image_size``, ``(width, height)``), else the one whose size holds every present
    keypoint (within :data:`EDGE_MARGIN`; ``extent``, :func:`keypoints_extent` of every joint
    the file holds, feet and hands included, else that of ``kp2d``'s H36M-17 joints),
    ``"unknown"`` when both or neither do; for a half
    turn (same size), ``"stored"`` when the body stands on its head in at least
    :data:`INVERTED_SHARE` of the frames with a pelvis and thorax, ``"displayed"`` when it
    stands upright in as many (a body lying across the image, or inverted in the room, is
    ``"unknown"``); ``"unknown"`` without keypoints or a rotation."""
    if kp2d is None or video.rotation_deg == 0:
        return "unknown"
    if video.rotation_deg == 180:
        return _half_turn_frame(kp2d)
    sizes = {"displayed": (video.width, video.height), "stored": video.stored_size}
    if image_size is not None:
        named = [frame for frame, size in sizes.items() if tuple(image_size) == size]
        if len(named) == 1:
            return named[0]
    top = keypoints_extent(kp2d) if extent is None else np.asarray(extent, np.float64)
    fits = [frame for frame, size in sizes.items() if np.all(top <= np.asarray(size) * (1.0 + EDGE_MARGIN))]
    return fits[0] if len(fits) == 1 else "unknown"


def _half_turn_frame(kp2d) -> str:
    """:func:`keypoint_frame` for a half turn: the body's 2D trunk (pelvis -> thorax, y down)
    pointing down (on its head) or up in at least :data:`INVERTED_SHARE` of the frames."""
    down = up = seen = 0
    for rows in frame_blocks(len(kp2d)):
        trunk = np.asarray(kp2d[rows, THORAX, :2], np.float64) - np.asarray(kp2d[rows, PELVIS, :2], np.float64)
        length = np.linalg.norm(trunk, axis=1)
        ok = np.isfinite(length) & (length > 0)
        seen += int(ok.sum())
        down += int((trunk[ok, 1] > 0.5 * length[ok]).sum())
        up += int((trunk[ok, 1] < -0.5 * length[ok]).sum())
    if seen and down >= INVERTED_SHARE * seen:
        return "stored"
    return "displayed" if seen and up >= INVERTED_SHARE * seen else "unknown"


@dataclass(frozen=True)
class DisplayOrientation:
    """What :func:`display_orientation` decided for a recording.

    rotation_deg: the video's display rotation (0 without a video); keypoint_frame: one of
    :data:`KeypointFrame`; turn: :func:`display_turn` when the keypoints and lifter output
    are in the stored frames and are to be turned into the displayed one, else ``None``;
    note: a line for the run summary (empty without a display rotation); displayed_size:
    the video's ``(width, height)`` as displayed.
    """

    rotation_deg: int = 0
    keypoint_frame: KeypointFrame = "unknown"
    turn: np.ndarray | None = None
    note: str = ""
    displayed_size: tuple[int, int] = (0, 0)

    def joints(self, J: np.ndarray) -> np.ndarray:
        """Camera-frame joints ``(..., 3)`` into the displayed camera frame (as given when not turned)."""
        return J if self.turn is None else J @ self.turn

    def pixels(self, kp: np.ndarray) -> np.ndarray:
        """2D keypoints ``(..., 3)`` (x_px, y_px, confidence) into the displayed frame (as given
        when not turned)."""
        if self.turn is None:
            return kp
        out = np.array(kp, copy=True)
        out[..., :2] = displayed_pixels(out[..., :2], self.rotation_deg, *self.displayed_size)
        return out

    def recording_pixels(self, kp: np.ndarray) -> np.ndarray:
        """2D keypoints ``(..., 3)`` of the displayed frame (what :meth:`pixels` returns) -> the
        video's stored frames, where rerun's viewer draws them: it shows an MP4 as stored
        (re_video's MP4 demuxer, ``crates/utils/re_video/src/demux/mp4.rs`` ``load_mp4``, reads
        the samples and their coded size, not the track header's display matrix). As given
        when the video has no display rotation or the keypoints' frame is unknown."""
        if not self.recording_note:
            return kp
        out = np.array(kp, copy=True)
        out[..., :2] = stored_pixels(out[..., :2], self.rotation_deg, *self.displayed_size)
        return out

    @property
    def recording_note(self) -> str:
        """The summary's line about the recording's video view when :meth:`recording_pixels` moves
        the keypoints (empty otherwise)."""
        if not self.rotation_deg or self.keypoint_frame == "unknown":
            return ""
        return (f"recording.rrd: rerun's viewer shows the video as stored ({self.rotation_deg} deg from how a phone "
                f"displays it), so the 2D keypoints over it are drawn in the stored frames; keypoints2d in "
                f"canonical.npz are in the displayed frame")

    def report(self) -> dict:
        """JSON-ready ``report["display_rotation"]`` of the run (docs/outputs.md)."""
        return {"rotation_deg": self.rotation_deg, "keypoint_frame": self.keypoint_frame,
                "turned_into_displayed_frame": self.turn is not None}


def display_orientation(video: VideoInfo | None, kp2d, image_size: tuple[int, int] | None = None,
                        extent: np.ndarray | None = None) -> DisplayOrientation:
    """Whether to turn a recording's keypoints and lifter output into the displayed frame.

    Args:
        video: the probed video or ``None``.
        kp2d: ``(T, 17, 3)`` H36M-17 2D keypoints (x_px, y_px, confidence; NaN = missing, in
            memory or on disk) or ``None``.
        image_size: ``(width, height)`` the keypoint file states for its frames, or ``None``
            (:attr:`pcnet.adapters.Keypoints2D.image_size`).
        extent: :func:`keypoints_extent` of all the file's joints in its own layout (a
            foot beyond the displayed frame tells the stored one), or ``None``: ``kp2d``'s.

    Returns:
        :class:`DisplayOrientation`: nothing to do unless the video states a display
        rotation; then :func:`keypoint_frame`'s answer, the turn for ``"stored"``, and a note.
        ``"unknown"`` (keypoints inside both sizes, a half turn whose body is neither clearly
        upright nor on its head, no keypoints) leaves the input as it is: detectors that
        read video through OpenCV >= 4.5 or a player see the displayed frames.
    """
    if video is None or not video.rotation_deg:
        return DisplayOrientation()
    frame = keypoint_frame(video, kp2d, image_size, extent)
    kind = "upside down" if video.rotation_deg % 360 == 180 else "portrait"
    head = (f"{video.path}: displayed turned {video.rotation_deg} deg clockwise from how it is stored (its "
            f"container's display rotation; a phone's {kind} video); ")
    if frame == "stored":
        return DisplayOrientation(video.rotation_deg, frame, display_turn(video.rotation_deg),
                                  head + "the 2D keypoints are in its stored frames, so they and the lifter's output "
                                         "were turned into the displayed frame (camera pitch, roll and the camera-"
                                         "frame outputs refer to the picture as displayed)",
                                  (video.width, video.height))
    unknown = ("taken as they are (if the lifter saw the stored frames, a standing body may be read as lying: "
               "compare --no-camera-prior)")
    said = {"displayed": "the 2D keypoints are in its displayed frames, taken as they are",
            "unknown": (f"neither the keypoint file's image size, the 2D keypoints' extent nor (for a half turn) the "
                        f"body's orientation in them tells which frames they are in, so they are {unknown}"
                        if kp2d is not None else f"no 2D keypoints tell which frames the lifter saw; its output is "
                                                 f"{unknown}")}
    return DisplayOrientation(video.rotation_deg, frame, None, head + said[frame], (video.width, video.height))
