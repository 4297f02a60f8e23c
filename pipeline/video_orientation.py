"""Which way up the lifter saw a video: a phone's portrait video is stored as landscape
frames plus a display rotation in its container (:func:`pcnet.adapters.probe_video`), and a 2D
detector may have read either the stored or the displayed frames. The 2D keypoints' extent
tells which, and the camera prior's level-camera up follows
(:func:`pcnet.stages.gravity_prior.level_up`)."""

from __future__ import annotations

import numpy as np

from pcnet.adapters import VideoInfo
from pcnet.stages.core.framestore import frame_blocks
from pcnet.stages.gravity_prior import IMAGE_UP, level_up

#: Share of the frame size by which 2D keypoints may lie beyond the image's edge and still be
#: taken as in that frame (detectors extrapolate joints of a body cut by the edge).
EDGE_MARGIN = 0.05


def keypoint_frame(video: VideoInfo, kp2d) -> str:
    """Which frames of a video stored turned from how it is displayed the 2D keypoints are in
    (:data:`pcnet.stages.gravity_prior.KEYPOINT_FRAMES`): the one whose size holds every
    present keypoint (within :data:`EDGE_MARGIN`), ``"unknown"`` when both or neither do."""
    if kp2d is None or video.rotation_deg == 0:
        return "unknown"
    top = np.full(2, -np.inf)
    for rows in frame_blocks(len(kp2d)):
        xy = np.asarray(kp2d[rows, :, :2], np.float64).reshape(-1, 2)
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy):
            top = np.maximum(top, xy.max(axis=0))
    fits = {frame: bool(np.all(top <= np.asarray(size) * (1.0 + EDGE_MARGIN)))
            for frame, size in (("displayed", (video.width, video.height)), ("stored", video.stored_size))}
    return next(iter(f for f, ok in fits.items() if ok)) if sum(fits.values()) == 1 else "unknown"


def _note(video, frame: str, level: tuple[float, float, float], have_keypoints: bool) -> str:
    where = {(-1.0, 0.0, 0.0): "left (-x)", (1.0, 0.0, 0.0): "right (+x)", (0.0, 1.0, 0.0): "bottom (+y)"}
    unknown = ("the camera prior takes the displayed image's up as a level camera's (if the lifter saw the stored "
               "frames, a standing body may be read as lying: compare --no-camera-prior)")
    said = {"stored": f"the 2D keypoints are in its stored frames, so the camera prior takes the displayed image's "
                      f"up, at the stored image's {where.get(level, level)}, as a level camera's",
            "displayed": "the 2D keypoints are in its displayed frames: the camera prior takes their up as a level "
                         "camera's",
            "unknown": (f"the 2D keypoints fit both the stored and the displayed frame size, so {unknown}"
                        if have_keypoints else f"no 2D keypoints tell which frames the lifter saw, so {unknown}")}
    return (f"{video.path}: displayed turned {video.rotation_deg} deg clockwise from how it is stored (its container's "
            f"display rotation; a phone's portrait video); {said[frame]}")



def camera_level(video: VideoInfo | None, kp2d) -> tuple[tuple[float, float, float], str, str]:
    """The camera prior's level-camera up for a recording, in the frame the lifter answered in.

    Args:
        video: the probed video or ``None``.
        kp2d: ``(T, 17, 3)`` H36M-17 2D keypoints (x_px, y_px, confidence; NaN = missing, in
            memory or on disk) or ``None``.

    Returns:
        ``(level up (x, y, z), keypoint frame, note)``: image up, ``"unknown"`` and no note
        (``""``) unless the video states a display rotation; then :func:`keypoint_frame`'s
        answer, :func:`pcnet.stages.gravity_prior.level_up` of it and a line for the run
        summary saying what was decided.
    """
    if video is None or not video.rotation_deg:
        return IMAGE_UP, "unknown", ""
    frame = keypoint_frame(video, kp2d)
    level = level_up(video.rotation_deg, frame)
    return level, frame, _note(video, frame, level, kp2d is not None)
