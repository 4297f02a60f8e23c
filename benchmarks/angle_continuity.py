"""The largest per-frame step of every joint-angle column of `kinematics.csv` on real
recordings (issue 51, "Continuous joint angles"; docs/joint_angles.md).

    python -m benchmarks.angle_continuity --data ../shared/data

Runs `pcnet run ... --no-recording` as a user would on a UTD-MHAD Kinect v1 sequence (a01, a
right-arm swipe), the Sports2D demo's MediaPipe file (230 frames), the MediaPipe and the yoga
Shavasana fixtures of `tests/fixtures`, then prints, per recording, the largest absolute
difference between consecutive frames over the `*_deg` angle columns (heading excluded) and
the three columns with the largest. Run it at an earlier commit for the values before a change.
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.report import SHARED_DATA
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = SHARED_DATA
FIXTURES = ROOT / "tests" / "fixtures"


def cases(data: Path) -> dict[str, list[str]]:
    return {
        "Kinect v1 UTD-MHAD a01_s1_t1": ["--lifter", "kinect_v1", "--lifter-output",
                                         str(data / "real" / "utd_mhad_imu" / "a01_s1_t1.npz")],
        "MediaPipe Sports2D demo": ["--lifter", "mediapipe", "--lifter-output",
                                    str(data / "real" / "sports2d_demo" / "mediapipe_blazepose33.npz")],
        "MediaPipe fixture": ["--lifter", "mediapipe", "--lifter-output",
                              str(FIXTURES / "mediapipe_blazepose33_f000-059.npz")],
        "VideoPose3D Shavasana fixture": ["--lifter", "videopose3d", "--lifter-output",
                                          str(FIXTURES / "yoga_Abhay_Shavasana_f200-299.npy"), "--fps", "30"],
    }


def largest_steps(table: Path) -> dict[str, float]:
    """Column -> largest |step| between consecutive frames with values, over the angle columns."""
    with open(table, newline="") as fh:
        rows = list(csv.reader(fh))
    header, values = rows[0], np.array([[float(v) if v else np.nan for v in row] for row in rows[1:]])
    steps = {}
    for j, name in enumerate(header):
        if name.endswith("_deg") and "heading" not in name:
            d = np.abs(np.diff(values[:, j]))
            if np.isfinite(d).any():
                steps[name] = float(np.nanmax(d))
    return steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    args = parser.parse_args()
    pcnet = Path(sys.executable).with_name("pcnet")
    with tempfile.TemporaryDirectory() as tmp:
        for name, options in cases(args.data).items():
            out = Path(tmp) / str(abs(hash(name)))
            done = subprocess.run([str(pcnet), "run", *options, "--no-recording", "--out", str(out)],
                                  capture_output=True, text=True)
            if done.returncode:
                print(f"{name}: run failed: {done.stderr.strip().splitlines()[-1]}")
                continue
            steps = sorted(largest_steps(out / "kinematics.csv").items(), key=lambda kv: -kv[1])
            top = ", ".join(f"{column} {step:.1f}" for column, step in steps[:3])
            print(f"{name}: largest step {steps[0][1]:.1f} deg ({top})")


if __name__ == "__main__":
    main()
