"""`pcnet run --video` with the embedded estimator: accuracy on real calibrated cameras and
speed on this machine (issue 50; needs the ``video`` extra).

    python -m benchmarks.video_estimator --data ../shared/data [--out benchmarks/results/video_estimator.txt]

Accuracy: the four calibrated cameras of ``real/pose2sim_gravity`` (one man standing in a lab,
11 frames at 60 fps each; truth ``up_camera`` from the lab's calibration). Each camera's
``.mp4`` is run end to end as a user runs it (``pcnet run --video V --mode sequence
--focal-px F``, F the calibrated focal length, which a user of that lab has) and compared with
the same run from the stored MediaPipe 0.10.21 file (``--lifter mediapipe`` and
``--keypoints2d`` on the ``.npz``, which carries the calibration). Columns: the sequence up's
tilt error against the truth for each, and the angle between the two ups.

First frame: MediaPipe's landmark model crops each frame around the landmarks before it, but a
frame with no pose before it around the detector's box, and the first step of a still subject
read as a peak speed (two user trials). For each real video with a person in the shared data
(the four lab cameras, the boxing clip, the Sports2D clip), the mean 3D step of the world
landmarks from the first frame with a pose to the next, over the median step of the video's
consecutive frames with a pose, with the detector's frame seen once more from its own
landmarks' crop (``estimate_video``'s default, ``relook``) and as it came.

Speed: the bundled boxing clip (854x480, 30 fps, 301 frames) resized to 1280x720 and
1920x1080 (written as MPEG-4 part 2: OpenCV's wheels have no H.264 encoder). For each size,
the estimator alone (frames per second of :func:`pcnet.models.pose_estimator.estimate_video`,
decoding included) and the whole run (``pcnet run --video V`` with the recording, frames per
wall-clock second of :func:`pcnet.pipeline.runner.run_pipeline`, imports excluded).
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

import pcnet.pipeline
from benchmarks.real_intervals import scratch_run
from benchmarks.report import SHARED_DATA
from pcnet.models.pose_estimator import estimate_video
from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import run_pipeline
from pcnet.stages.core.rotations import angle_between

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "video_estimator.txt"
COMMAND = "python -m benchmarks.video_estimator --data ../shared/data"
EXAMPLE = Path(pcnet.pipeline.__file__).parent / "example_data" / "boxing2.mp4"
SIZES = ((1280, 720), (1920, 1080))


def sequence_up(cfg: RunConfig) -> np.ndarray:
    """The sequence up (camera frame) of one run, written to a throwaway folder."""
    return np.asarray(scratch_run(cfg).report.rectification.sequence.up, np.float64)


def accuracy_rows(data: Path) -> list[str]:
    rows = [f"{'camera':8s} {'video err':>10s} {'stored err':>11s} {'video vs stored':>16s}  (deg, sequence up)"]
    for cam in ("cam01", "cam02", "cam03", "cam04"):
        stored = data / "real" / "pose2sim_gravity" / f"statictrial_{cam}.npz"
        video = stored.with_suffix(".mp4")
        with np.load(stored) as f:
            truth = np.asarray(f["up_camera"], np.float64)
            focal = float(np.asarray(f["K"])[0, 0])
        from_video = sequence_up(RunConfig(video=str(video), mode="sequence", focal_px=focal))
        from_file = sequence_up(RunConfig(video=str(video), lifter="mediapipe", lifter_output=str(stored),
                                          keypoints2d=str(stored), keypoints2d_format="mediapipe", mode="sequence"))
        err_video, err_file, between = (float(np.degrees(angle_between(a, b))) for a, b in
                                        ((from_video, truth), (from_file, truth), (from_video, from_file)))
        rows.append(f"{cam:8s} {err_video:10.2f} {err_file:11.2f} {between:16.2f}")
    return rows


def first_step_rows(data: Path) -> list[str]:
    videos = [data / "real" / "pose2sim_gravity" / f"statictrial_{cam}.mp4" for cam in ("cam01", "cam02", "cam03", "cam04")]
    videos += [data / "real" / "boxing_motionbert" / "boxing2.mp4", data / "real" / "sports2d_demo" / "demo.mp4"]
    rows = [f"{'video':22s} {'relook':>7s} {'as it came':>11s}  (first step / median step)"]
    ratios = {True: [], False: []}
    for video in videos:
        for relook in (True, False):
            world = estimate_video(video, relook=relook).world_3d
            found = world[np.isfinite(world).all(axis=(1, 2))]
            steps = np.linalg.norm(np.diff(found, axis=0), axis=2).mean(axis=1)
            ratios[relook].append(float(steps[0] / np.median(steps)))
        rows.append(f"{video.name:22s} {ratios[True][-1]:7.1f} {ratios[False][-1]:11.1f}")
    rows.append(f"{'median':22s} {np.median(ratios[True]):7.1f} {np.median(ratios[False]):11.1f}")
    return rows


def resized_clip(folder: Path, size: tuple[int, int]) -> Path:
    """The bundled boxing clip resized to ``size`` (width, height)."""
    path = folder / f"boxing_{size[1]}p.mp4"
    source = cv2.VideoCapture(str(EXAMPLE))
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), source.get(cv2.CAP_PROP_FPS), size)
    while True:
        ok, frame = source.read()
        if not ok:
            break
        writer.write(cv2.resize(frame, size, interpolation=cv2.INTER_CUBIC))
    writer.release()
    source.release()
    return path


def speed_rows() -> list[str]:
    rows = [f"{'size':10s} {'frames':>7s} {'estimator fps':>14s} {'whole run fps':>14s}"]
    with tempfile.TemporaryDirectory() as tmp:
        estimate_video(EXAMPLE)  # warm: the model bundle's first load
        for size in SIZES:
            clip = resized_clip(Path(tmp), size)
            start = time.perf_counter()
            frames = len(estimate_video(clip).found)
            alone = frames / (time.perf_counter() - start)
            start = time.perf_counter()
            run_pipeline(RunConfig(video=str(clip), out=str(Path(tmp) / f"out{size[1]}")))
            whole = frames / (time.perf_counter() - start)
            rows.append(f"{size[0]}x{size[1]:<5d} {frames:7d} {alone:14.1f} {whole:14.1f}")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    parser.add_argument("--out", type=Path, default=RESULT)
    args = parser.parse_args()
    load = open("/proc/loadavg").read().split()[0] if Path("/proc/loadavg").is_file() else "?"
    lines = [f"# {COMMAND}", f"# {time.strftime('%Y-%m-%d')}, {os.cpu_count()} cores ({platform.processor() or platform.machine()}), "
             f"load average {load} at the start", "", "## Accuracy: pose2sim_gravity, from the .mp4 vs the stored MediaPipe 0.10.21 file",
             *accuracy_rows(args.data), "", "## First frame", *first_step_rows(args.data), "",
             "## Speed (frames per second)", *speed_rows()]
    text = "\n".join(lines) + "\n"
    print(text, end="")
    args.out.write_text(text)


if __name__ == "__main__":
    main()
