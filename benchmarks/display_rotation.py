"""Phone videos stored turned: does `pcnet run` find gravity when the 2D detector read the frames
as stored rather than as displayed?

    python -m benchmarks.display_rotation [--data ../shared/data] [--out benchmarks/results/display_rotation.txt]

A phone films portrait video as landscape frames plus a display rotation in the MP4 track
header (ISO/IEC 14496-12 section 8.3.2, the ``tkhd`` matrix); players and OpenCV >= 4.5 turn
the frames by it, detectors that read the stored frames see the person lying across the image.
The real boxing recording (MotionBERT on AlphaPose, ../shared/data/real/boxing_motionbert),
whose true up is known from its vanishing points (benchmarks/vanishing_gravity.py), is
re-stored the way a phone stores it: every frame turned counter-clockwise by 90, 180 or 270 deg
and the rotation written into the container, so that OpenCV shows the original frames. The
2D keypoints and the lifter's 3D output are then given either in the stored frames (what a
detector that ignores the rotation delivers: pixels and camera axes turned exactly like the
frames) or as displayed (a detector that applies it); a last variant drops the container's
rotation (a re-encode that lost it). Rows: tilt error of `pcnet run`'s camera up (defaults,
sequence mode when its auto mode picks it: the report's sequence up) against the truth in
pcnet's camera frame (the displayed one where it turned the inputs into it, else the lifter's),
the keypoint frame pcnet decided, whether it turned the inputs, the reading of the body, and
whether the printed 95 % pitch and roll intervals contain the truth.

Only the storage is synthetic: poses, video and truth are the real recording's. What the
turn cannot reproduce: a detector run on turned pixels gives slightly different keypoints.
"""

from __future__ import annotations

import json
import struct
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from benchmarks.gravity_benchmark import deg_between, pitch_roll_deg
from benchmarks.vanishing_gravity import LINES, RECORDINGS, truth
from benchmarks.report import trial_arguments
from pcnet.adapters import iter_frames, probe_video
from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import run_pipeline
from pcnet.pipeline.video_orientation import display_turn, stored_pixels
from pcnet.stages.core.perspective import focal_px_from_35mm

HERE = Path(__file__).resolve().parent
RESULT = HERE / "results" / "display_rotation.txt"
COMMAND = "python -m benchmarks.display_rotation --data ../shared/data"
#: cv2.rotate code that stores a displayed frame for each clockwise display rotation.
STORE = {90: cv2.ROTATE_90_COUNTERCLOCKWISE, 180: cv2.ROTATE_180, 270: cv2.ROTATE_90_CLOCKWISE}
#: (label, display rotation, rotation written in the container, keypoints and 3D in the stored frames)
CASES = (
    ("original, shown as stored", 0, 0, False),
    ("stored turned 90, keypoints in stored frames", 90, 90, True),
    ("stored turned 180, keypoints in stored frames", 180, 180, True),
    ("stored turned 270, keypoints in stored frames", 270, 270, True),
    ("stored turned 90, keypoints as displayed", 90, 90, False),
    ("stored turned 180, keypoints as displayed", 180, 180, False),
    ("stored turned 90, rotation lost, keypoints in stored frames", 90, 0, True),
)
#: The portrait cameras: as filmed, stored turned as a phone stores portrait video (with and
#: without the archive's image size), and lost.
POSE2SIM_CASES = (CASES[0], CASES[1], ("stored turned 90, keypoints in stored frames, no image size in the archive",
                                       90, 90, True), CASES[-1])
TABLE_HEAD = ("| case | tilt error (deg) | mode | reading | keypoint frame found | turned into the displayed frame | "
              "95 % intervals contain the truth |", "|---|---|---|---|---|---|---|")


def tkhd_matrix(rotation_deg: int) -> bytes:
    """The track header's display matrix for a clockwise rotation (16.16 fixed point, the last
    column 2.30; ISO/IEC 14496-12 section 6.2.2)."""
    a = np.radians(rotation_deg)
    c, s = round(np.cos(a)), round(np.sin(a))
    one = 1 << 16
    return struct.pack(">9i", c * one, s * one, 0, -s * one, c * one, 0, 0, 0, 1 << 30)


def write_stored_video(src: Path, dst: Path, rotation_deg: int, tag_deg: int) -> None:
    """``src``'s frames turned counter-clockwise by ``rotation_deg`` into ``dst`` (MPEG-4 Part 2),
    with ``tag_deg`` written as the display rotation of its one video track."""
    info = probe_video(src)
    frames = (f if rotation_deg == 0 else cv2.rotate(f, STORE[rotation_deg]) for f in iter_frames(src))
    first = next(frames)
    writer = cv2.VideoWriter(str(dst), cv2.VideoWriter_fourcc(*"mp4v"), info.fps, (first.shape[1], first.shape[0]))
    writer.write(first)
    for frame in frames:
        writer.write(frame)
    writer.release()
    data = bytearray(dst.read_bytes())
    at = data.find(b"tkhd")
    if at < 0 or data.find(b"tkhd", at + 4) >= 0:
        raise RuntimeError(f"{dst}: expected one track header")
    # from the box type: version/flags 4, times, track id and duration 20 (version 1: 32),
    # reserved 8, layer, group, volume and reserved 8, then the matrix
    offset = at + (44 if data[at + 4] == 0 else 56)
    data[offset : offset + 36] = tkhd_matrix(tag_deg)
    dst.write_bytes(bytes(data))


def write_stored_inputs(run: dict, data: Path, tmp: Path, rotation_deg: int, width: int, height: int) -> dict:
    """The AlphaPose JSON and MotionBERT X3D of ``run`` turned into the stored frames."""
    people = json.loads((data / run["keypoints2d"]).read_text())
    for person in people:
        kp = np.asarray(person["keypoints"], np.float64).reshape(-1, 3)
        kp[:, :2] = stored_pixels(kp[:, :2], rotation_deg, width, height)
        person["keypoints"] = kp.ravel().tolist()
        x, y, w, h = person["box"]
        corners = stored_pixels(np.array([[x, y], [x + w, y + h]], np.float64), rotation_deg, width, height)
        lo, hi = corners.min(0), corners.max(0)
        person["box"] = [float(lo[0]), float(lo[1]), float(hi[0] - lo[0]), float(hi[1] - lo[1])]
    keypoints = tmp / "alphapose-results.json"
    keypoints.write_text(json.dumps(people))
    X = np.load(data / run["lifter_output"], allow_pickle=False)
    lifter = tmp / "X3D.npy"
    np.save(lifter, (X @ display_turn(rotation_deg).T).astype(np.float32))
    return dict(run, keypoints2d=str(keypoints), lifter_output=str(lifter))


def write_stored_mediapipe(src: Path, dst: Path, rotation_deg: int, keep_size: bool = True) -> None:
    """A Pose2Sim MediaPipe archive as MediaPipe would have written it on the stored frames:
    2D pixels, the camera matrix, the image size, the world landmarks (camera axes) and the
    calibration's up and pose turned with the frames; ``keep_size=False`` drops ``width``
    and ``height`` (a keypoint file that states no image size; the camera matrix stays)."""
    with np.load(src, allow_pickle=False) as f:
        arrays = {k: f[k] for k in f.files}
    width, height = int(arrays["width"]), int(arrays["height"])
    Q = display_turn(rotation_deg)
    kp = arrays["keypoints_2d"].astype(np.float64)
    kp[..., :2] = stored_pixels(kp[..., :2], rotation_deg, width, height)
    K = arrays["K"].copy()
    K[:2, 2] = stored_pixels(K[:2, 2], rotation_deg, width, height)
    if rotation_deg in (90, 270):
        K[0, 0], K[1, 1] = K[1, 1], K[0, 0]
        arrays.update(width=np.int64(height), height=np.int64(width), calib_size=arrays["calib_size"][::-1].copy())
    arrays.update(keypoints_2d=kp.astype(np.float32), K=K, world_3d=(arrays["world_3d"] @ Q.T).astype(np.float32),
                  up_camera=Q @ arrays["up_camera"], R_world_to_cam=Q @ arrays["R_world_to_cam"],
                  t_world_to_cam=Q @ arrays["t_world_to_cam"])
    if not keep_size:
        del arrays["width"], arrays["height"]
    np.savez(dst, **arrays)


def run_case(label: str, video_src: Path, inputs: dict, tmp: Path, case: tuple, up_true: np.ndarray) -> str:
    """`pcnet run` on ``video_src`` re-stored as ``case`` says, with ``inputs`` (already in the
    frames the case names); one table row."""
    _, rotation, tag, stored = case
    video = tmp / "video.mp4"
    write_stored_video(video_src, video, rotation, tag)
    result = run_pipeline(RunConfig(**dict(inputs, video=str(video)), out=str(tmp / "out"), recording=False),
                          progress=False)
    rep = result.report.as_record()
    # pcnet's camera frame: the displayed one where it turned the inputs, else the lifter's
    turned = (rep.get("display_rotation") or {}).get("turned_into_displayed_frame", False)
    truth_here = up_true if turned else display_turn(rotation if stored else 0) @ up_true
    tp, tr = pitch_roll_deg(truth_here)
    dp, dr = rep.get("camera_pitch_interval_deg", np.nan), rep.get("camera_roll_interval_deg", np.nan)
    droll = (result.camera_roll_deg - tr + 180.0) % 360.0 - 180.0
    inside = "-" if not np.isfinite(dp + dr) else ("yes" if abs(result.camera_pitch_deg - tp) <= dp and abs(droll) <= dr else "NO")
    posture = rep.get("posture") or {}
    frame = (rep.get("display_rotation") or {}).get("keypoint_frame", "-")
    return (f"| {label} | {deg_between(rep['up'], truth_here):.1f} | {result.mode} | {posture.get('most_probable', '-')} "
            f"(p lying {posture.get('p_lying', float('nan')):.2f}) | {frame} | {'yes' if turned else 'no'} | {inside} |")


def main() -> None:
    args = trial_arguments(__doc__, RESULT)
    run = RECORDINGS["boxing"]["run"]
    if not (args.data / run["lifter_output"]).is_file():
        sys.exit(f"display_rotation: {args.data / run['lifter_output']} not found; pass --data <data root>")
    spec = json.loads(LINES.read_text())["boxing"]
    up_true = truth(spec, focal_px_from_35mm(spec["width"], spec["height"]), np.random.default_rng(0))["up"]
    info = probe_video(args.data / run["video"])
    t0 = time.perf_counter()
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"boxing (MotionBERT), true up as displayed: pitch {pitch_roll_deg(up_true)[0]:+.1f}, roll "
             f"{pitch_roll_deg(up_true)[1]:+.1f} (benchmarks/vanishing_gravity.py)", "",
             *TABLE_HEAD]
    print("\n".join(lines), flush=True)
    for case in CASES:
        with tempfile.TemporaryDirectory() as name:
            tmp = Path(name)
            inputs = write_stored_inputs(run, args.data, tmp, case[1] if case[3] else 0, info.width, info.height)
            lines.append(run_case(f"boxing, {case[0]}", args.data / run["video"], inputs, tmp, case, up_true))
        print(lines[-1], flush=True)
    lines += ["", "Pose2Sim's four calibrated portrait cameras (MediaPipe; true up from the calibration), the same "
              "storage with the archive turned as MediaPipe run on the stored frames would write it:", "",
              *TABLE_HEAD]
    for path in sorted((args.data / "real" / "pose2sim_gravity").glob("statictrial_cam*.npz")):
        with np.load(path, allow_pickle=False) as f:
            up_cam = np.asarray(f["up_camera"], np.float64)
        for case in POSE2SIM_CASES:
            with tempfile.TemporaryDirectory() as name:
                tmp = Path(name)
                npz = tmp / path.name
                write_stored_mediapipe(path, npz, case[1] if case[3] else 0, keep_size="no image size" not in case[0])
                inputs = dict(keypoints2d=str(npz), keypoints2d_format="mediapipe", lifter="mediapipe",
                              lifter_output=str(npz))
                lines.append(run_case(f"{path.stem.split('_')[-1]}, {case[0]}", path.with_suffix(".mp4"), inputs,
                                      tmp, case, up_cam / np.linalg.norm(up_cam)))
            print(lines[-1], flush=True)
    lines.append(f"({time.perf_counter() - t0:.0f} s)")
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
