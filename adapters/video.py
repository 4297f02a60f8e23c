"""Video files through OpenCV: probe, read one frame, iterate frames.

Frames are BGR ``uint8`` ``(H, W, 3)`` arrays, OpenCV's native order (convert with
``frame[..., ::-1]`` for RGB).

OpenCV is imported when pcnet first opens a video, not with :mod:`pcnet.adapters`. At that
moment pcnet sets ``OPENCV_FFMPEG_LOGLEVEL=-8`` (quiet) for the process unless the variable is
already set: FFmpeg's decoder messages (thousands of lines for one damaged file) would bury the
one-line error pcnet gives for a video it cannot decode. A host application that wants FFmpeg's
diagnostics sets the variable first.
"""

from __future__ import annotations

import math
import os
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Iterator

import numpy as np

from .types import AdapterError, VideoInfo
from .validate import require_file

if TYPE_CHECKING:
    import cv2


def opencv():
    """``cv2``, FFmpeg's log quieted unless the user set its level (module docstring): call it
    before opening any video, since OpenCV reads the level when its FFmpeg backend opens the
    first one (the embedded pose estimator opens its own, ``models/pose_estimator.py``)."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    import cv2

    return cv2


@contextmanager
def _capture(p: Path) -> Iterator[cv2.VideoCapture]:
    cap = opencv().VideoCapture(str(p))
    try:
        if not cap.isOpened():
            raise AdapterError(p, "video stream", "a video file OpenCV can open", "it does not open")
        yield cap
    finally:
        cap.release()


def _prop(cap: cv2.VideoCapture, prop: int) -> float:
    """A capture property; 0 when OpenCV reports NaN/inf (damaged containers do), so that
    the checks below refuse it instead of int() raising."""
    value = float(cap.get(prop))
    return value if math.isfinite(value) else 0.0


#: Share of the container's frame count below which a video whose decoding stops early is
#: refused as damaged rather than taken as cut by an edit list (``boxing2.mp4``: 301 of 360, 0.84).
DECODABLE_SHARE = 0.5


def _count_by_decoding(p: Path) -> int:
    """Frames of ``p`` that decode from its start, read by a capture of their own: seeking
    back to frame 0 fails in some files (a one-frame MP4 counted 0 after its frame was read)."""
    n = 0
    with _capture(p) as cap:
        while cap.grab():
            n += 1
    return n


def probe_video(path: str | Path, verify: bool = True) -> VideoInfo:
    """Frame count, frame rate, size and display rotation of a video.

    Phones store a portrait video as landscape frames plus a display rotation in the
    container (the MP4 track header's matrix, ISO/IEC 14496-12 section 8.3.2, ``tkhd``); a
    player, and OpenCV since 4.5 (``CAP_PROP_ORIENTATION_AUTO``, on by default), turns the
    frames by it. ``rotation_deg`` is that rotation (``CAP_PROP_ORIENTATION_META``, clockwise,
    rounded to a multiple of 90) and ``width``/``height`` the size as displayed.

    Args:
        path: the video file.
        verify: check that the container's frame count is real by decoding its last
            frame; if that fails, count the frames by decoding them all. The container's
            count can exceed what plays: the real ``boxing2.mp4`` stores 360 frames and its
            MP4 edit list plays 301 (:func:`first_shown_frame`), the count AlphaPose and
            MotionBERT saw. ``False`` trusts the container (no decoding
            beyond the first frame).

    Returns:
        :class:`VideoInfo`.

    Raises:
        AdapterError: missing/unreadable file (field ``path``), a file OpenCV cannot open
            (``video stream``: any non-video file), no decodable frame, or fewer than
            :data:`DECODABLE_SHARE` of the frames the container states (``frame_count``), a
            non-positive or non-finite frame rate (``fps``) or size (``width/height``).
    """
    p = require_file(path, "a video file")
    with _capture(p) as cap:
        cv2 = opencv()
        count = int(_prop(cap, cv2.CAP_PROP_FRAME_COUNT))
        fps = _prop(cap, cv2.CAP_PROP_FPS)
        width = int(_prop(cap, cv2.CAP_PROP_FRAME_WIDTH))
        height = int(_prop(cap, cv2.CAP_PROP_FRAME_HEIGHT))
        rotation = int(round(_prop(cap, cv2.CAP_PROP_ORIENTATION_META) / 90.0)) * 90 % 360
        ok, _ = cap.read()
        if ok and verify:
            last_ok = count == 1  # the one frame, just read
            if count > 1:
                cap.set(cv2.CAP_PROP_POS_FRAMES, count - 1)
                last_ok = cap.grab()
            if not last_ok:
                stated, count = count, _count_by_decoding(p)
                if 0 < count < DECODABLE_SHARE * stated:
                    raise AdapterError(p, "frame_count", f"most of the {stated} frames its container states",
                                       f"{count} decodable, then a decoding error: a damaged or truncated file")
    if count <= 0 or not ok:
        raise AdapterError(p, "frame_count", "at least one decodable frame", f"{count} frames, first frame {'read' if ok else 'unreadable'}")
    if not fps > 0:
        raise AdapterError(p, "fps", "a positive finite frame rate", fps)
    if width <= 0 or height <= 0:
        raise AdapterError(p, "width/height", "a positive frame size", f"{width}x{height}")
    return VideoInfo(str(p), count, fps, width, height, rotation)


#: Raw frames searched for the first frame a player shows, and how many consecutive frames
#: must match (a still intro can repeat one picture).
EDIT_LIST_SEARCH_FRAMES = 600
EDIT_LIST_MATCH_FRAMES = 5
#: Mean absolute difference (8-bit levels) under which two decodings of a frame are the same.
SAME_FRAME_LEVELS = 0.5


def first_shown_frame(path: str | Path) -> int:
    """Index, among the frames stored in the container (in presentation order), of the first
    frame a player shows: 0 unless an MP4 edit list (ISO/IEC 14496-12 section 8.6.6,
    ``elst``) starts playback later.

    FFmpeg (and so OpenCV, and the 2D detectors that decode through them) honours the edit
    list; a reader that lists the stored samples does not (rerun's ``AssetVideo`` frame table:
    the bundled ``boxing2.mp4`` stores 360 frames and plays 301 from stored frame 59). The
    frames are decoded once with FFmpeg's ``ignore_editlist`` and matched to the first
    :data:`EDIT_LIST_MATCH_FRAMES` frames as played (mean difference below
    :data:`SAME_FRAME_LEVELS`), over the first :data:`EDIT_LIST_SEARCH_FRAMES` stored frames;
    without a match (or a still intro longer than the search) it is 0.

    Raises:
        AdapterError: as :func:`probe_video` for a file that does not open.
    """
    p = require_file(path, "a video file")
    with _capture(p) as cap:
        shown = [frame for _, frame in zip(range(EDIT_LIST_MATCH_FRAMES), _frames(cap))]
    if not shown:
        return 0
    key = "OPENCV_FFMPEG_CAPTURE_OPTIONS"
    before = os.environ.get(key)
    os.environ[key] = "ignore_editlist;1"  # read when the capture opens
    try:
        with _capture(p) as cap:
            window: list[np.ndarray] = []  # the stored frames from the candidate k on
            for index, frame in zip(range(EDIT_LIST_SEARCH_FRAMES + len(shown)), _frames(cap)):
                window.append(frame)
                while window and not _same(window[-1], shown[len(window) - 1]):
                    window.pop(0)  # the candidate fails: try the next stored frame as the start
                    while window and not all(_same(a, b) for a, b in zip(window, shown)):
                        window.pop(0)
                if len(window) == len(shown):
                    return index - len(shown) + 1
    finally:
        if before is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = before
    return 0


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.abs(a.astype(np.int16) - b).mean() < SAME_FRAME_LEVELS


def _frames(cap: cv2.VideoCapture) -> Iterator[np.ndarray]:
    while True:
        ok, frame = cap.read()
        if not ok:
            return
        yield frame


def read_frame(path: str | Path, index: int) -> np.ndarray:
    """Frame ``index`` (0-based) of a video as BGR ``uint8`` ``(H, W, 3)``.

    Seeks with ``CAP_PROP_POS_FRAMES``, which is frame-exact for the constant-rate MP4s
    pcnet reads (checked in the tests against :func:`iter_frames`). For many frames in
    order, :func:`iter_frames` is much faster.

    Raises:
        AdapterError: missing/unreadable file, a file OpenCV cannot open, a negative or
            non-integer ``index``, or an index past the last decodable frame (field ``index``).
    """
    p = require_file(path, "a video file")
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
        raise AdapterError(p, "index", "a non-negative integer frame index", repr(index))
    with _capture(p) as cap:
        cap.set(opencv().CAP_PROP_POS_FRAMES, int(index))
        ok, frame = cap.read()
    if not ok or frame is None:
        raise AdapterError(p, "index", f"frame {index} to exist and decode (see probe_video for the count)", "no frame")
    return frame


def iter_frames(path: str | Path, start: int = 0, stop: int | None = None) -> Iterator[np.ndarray]:
    """Iterator over frames ``start`` .. ``stop - 1`` (default: to the last decodable frame)
    as BGR ``uint8`` ``(H, W, 3)``, decoded sequentially; the capture is released when the
    iterator is exhausted, closed or garbage-collected.

    Raises:
        AdapterError: at call time, for a missing/unreadable file or one OpenCV cannot open.
    """
    p = require_file(path, "a video file")
    with _capture(p):
        pass  # fail now, not at the first next()

    def frames() -> Iterator[np.ndarray]:
        with _capture(p) as cap:
            if start:
                cap.set(opencv().CAP_PROP_POS_FRAMES, int(start))
            index = start
            while stop is None or index < stop:
                ok, frame = cap.read()
                if not ok:
                    return
                yield frame
                index += 1

    return frames()
