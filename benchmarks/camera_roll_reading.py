"""What the shipped camera-frame 3DPCNet reads as camera roll on real recordings: rolled cameras against asymmetric poses.

    python -m benchmarks.camera_roll_reading [--data ../shared/data] [--stride 2]

The view gate (models/view_gate.py: camera_view_estimate) reads the camera's |roll| from a network's
per-frame up as a 2 s running median. A gate that hands rolled cameras to a network trained on
rolled views needs that reading to separate a rolled camera from a body that is not
left-right symmetric under a level camera. Here, for the shipped camera-frame network
(models/weights/pcnet_camera.onnx), the median reading per recording:
- the 4 real Pose2Sim lab cameras (real/pose2sim_gravity; MediaPipe, read as `pcnet run
  --lifter mediapipe` reads them), beside each camera's true roll from its calibration;
- the real VideoPose3D yoga exports (real/yoga_videopose3d, `export_<person>_<asana>.npy`
  only; static tripod-like cameras, no roll truth), per asana: the median over files and the
  files read above 3 and 6 deg (the ramp of the three-network candidate, models/MODEL_CARD.md,
  "Experiments"). Every `--stride`-th frame, the window in frames scaled to match (30 fps
  assumed for the yoga files, as benchmarks/yoga_physics.py).
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from benchmarks.gravity_benchmark import load_camera, pitch_roll_deg
from benchmarks.report import SHARED_DATA, data_arguments, print_and_save
from benchmarks.yoga_physics import ASANA_ORDER, FOLDER, FPS, plain_export, parse_name

from pcnet.adapters import load_videopose3d
from pcnet.models.inference import CAMERA_WEIGHTS, PCNetSession
from pcnet.models.view_gate import camera_view_estimate, window_frames
from pcnet.stages.core.conventions import root_relative

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "camera_roll_reading.txt"
THRESHOLDS_DEG = (3.0, 6.0)


def median_roll_reading(session: PCNetSession, joints: np.ndarray, fps: float) -> float:
    """Median over the valid frames of the running-median |roll| reading (deg); NaN if none."""
    R, _, valid = session.predict(joints)
    if not valid.any():
        return float("nan")
    return float(np.median(camera_view_estimate(R[valid], window_frames(fps))[0]))


def main() -> None:
    args = data_arguments(__doc__, DEFAULT, RESULT, stride=2)
    session = PCNetSession(CAMERA_WEIGHTS)
    lines = [__doc__.splitlines()[0], "",
             f"    python -m benchmarks.camera_roll_reading --data ../shared/data --stride {args.stride}", "",
             "Pose2Sim real cameras: true |roll| from the calibration, the camera-frame network's median |roll| reading (deg)"]
    for path in sorted(args.data.glob("real/pose2sim_gravity/statictrial_cam*.npz")):
        joints, up, fps = load_camera(path, real_camera=True)
        lines.append(f"  {path.stem:<22} true {abs(pitch_roll_deg(up)[1]):5.1f}   read "
                     f"{median_roll_reading(session, joints, fps):5.1f}")
    by_asana = defaultdict(list)
    for path in sorted(args.data.joinpath(*FOLDER).glob("export_*.npy")):
        if not plain_export(path):
            continue
        joints, _ = root_relative(load_videopose3d(path).joints[:: args.stride])
        by_asana[parse_name(path)[1]].append(median_roll_reading(session, joints, FPS / args.stride))
    lines += ["", "Yoga (VideoPose3D, no roll truth): per asana, median |roll| reading over files [min, max], files read above "
              + " / ".join(f"{t:g}" for t in THRESHOLDS_DEG) + " deg"]
    for asana in [a for a in ASANA_ORDER if a in by_asana]:
        r = np.asarray(by_asana[asana])
        above = " / ".join(str(int(np.sum(r > t))) for t in THRESHOLDS_DEG)
        lines.append(f"  {asana:<13}{len(r):>3} files   {np.median(r):5.1f} [{r.min():5.1f}, {r.max():5.1f}]   above: {above}")
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
