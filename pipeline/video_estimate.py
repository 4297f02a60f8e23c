"""`pcnet run --video V` with no lifter output: the embedded estimator's poses become the
run's inputs, saved in the output folder in the format the MediaPipe adapter reads, so that a
re-run can take them as they are (``--lifter mediapipe --lifter-output OUT/FILE
--keypoints2d OUT/FILE --keypoints2d-format mediapipe``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from pcnet.models.pose_estimator import estimate_video
from pcnet.stages.sinks.exports import write_npz

from .config import ESTIMATOR_LIFTER, RunConfig

#: The estimator's results in the output folder: the ``.npz`` of :mod:`pcnet.adapters.mediapipe`.
ESTIMATE_FILE = "mediapipe_blazepose33.npz"


def estimated_inputs(cfg: RunConfig, folder: Path, progress: bool = False) -> tuple[RunConfig, str]:
    """Run :func:`pcnet.models.pose_estimator.estimate_video` on ``cfg.video``, write its
    landmarks to ``folder / ESTIMATE_FILE`` and return ``cfg`` reading them (as MediaPipe's 3D
    output and 2D keypoints) with the summary's line on where the poses came from.

    Args:
        cfg: a config with a video and neither a lifter output nor 2D keypoints.
        folder: the run's staged output folder.
        progress: a frame progress bar where stderr is a terminal.

    Raises:
        InputError: as :func:`~pcnet.models.pose_estimator.estimate_video`.
    """
    track = estimate_video(cfg.video, progress, cfg.roi_px)
    path = write_npz(folder / ESTIMATE_FILE, keypoints_2d=track.keypoints_2d, world_3d=track.world_3d,
                     fps=np.float64(track.fps), width=np.int64(track.width), height=np.int64(track.height),
                     layout=np.array("blazepose33"))
    found = int(track.found.sum())
    region = "" if cfg.roi is None else f" inside --roi {cfg.roi}"
    note = (f"poses: MediaPipe BlazePose GHUM 3D (full) on the video{region}, a person in {found} of "
            f"{len(track.found)} frames; saved as {ESTIMATE_FILE} (re-use it with --lifter mediapipe --lifter-output "
            f"and --keypoints2d with --keypoints2d-format mediapipe)")
    return dataclasses.replace(cfg, lifter=ESTIMATOR_LIFTER, lifter_output=str(path), keypoints2d=str(path),
                               keypoints2d_format=ESTIMATOR_LIFTER), note
