"""Real skeletons of people facing the sensor: each network's heading on the pair's up against the direction to the sensor.

    python -m benchmarks.heading_facing --data ../shared/data

Data: real/utd_mhad_imu/*.npz, 671 real Kinect v1 skeleton sequences (UTD-MHAD, Chen, Jafari
and Kehtarnavaz, ICIP 2015; research use, evaluation only), read as `pcnet run --lifter
kinect_v1` reads them (adapters/kinect.py: load_kinect_v1; OpenCV camera frame, metres,
positions relative to the sensor). The data's README: 8 subjects stand 2.8-3.4 m in front of a
fixed sensor and face it. Assumed truth: the body faces the sensor, so its forward direction
(canonical +X) points from the pelvis to the sensor, -pelvis in camera coordinates. Both
directions are taken on the plane perpendicular to the pair's up (ViewGatedPCNet.predict_gated,
so camera tilt and body lean do not enter) and the signed angle between them is the heading
error. Rows: the pair's up with the heading of (a) the camera-frame network, (b) the body-frame
network (each rotation turned by the shortest arc onto the pair's up, stages/core/rotations.py:
with_up). Per sequence the circular mean of its frames' signed errors; printed: the mean and
median absolute per-sequence error, the mean absolute per-frame error, per subject the mean
absolute per-sequence error. The assumption holds only roughly (people turn a little while
throwing or bowling, and need not stand square to the sensor): a check shared by both rows, not
a ground truth. Writes benchmarks/results/heading_facing.txt.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.headings import circular_mean_deg, pair_headings
from benchmarks.report import print_and_save, trial_arguments

from pcnet.adapters import load_kinect_v1
from pcnet.models.inference import ViewGatedPCNet
from pcnet.pipeline.io import lifter_joints
from pcnet.stages.core.conventions import PELVIS
from pcnet.stages.core.rotations import normalize

RESULT = Path(__file__).resolve().parent / "results" / "heading_facing.txt"
COMMAND = "python -m benchmarks.heading_facing --data ../shared/data"
ROWS = ("camera-frame heading", "body-frame heading")


def signed_heading_error_deg(forward: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Signed angle (deg, right-handed about ``up``) from ``target`` to ``forward``, both
    projected on the plane perpendicular to ``up``; all ``(T, 3)``."""
    f = normalize(forward - np.sum(forward * up, -1, keepdims=True) * up)
    t = normalize(target - np.sum(target * up, -1, keepdims=True) * up)
    return np.degrees(np.arctan2(np.sum(np.cross(t, f) * up, -1), np.sum(t * f, -1)))


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="heading_facing", needs="real/utd_mhad_imu")
    pair = ViewGatedPCNet()
    per_sequence: dict[str, list[float]] = {row: [] for row in ROWS}
    per_frame: dict[str, list[np.ndarray]] = {row: [] for row in ROWS}
    subjects: list[int] = []
    files = sorted(args.data.joinpath("real", "utd_mhad_imu").glob("a*_s*_t*.npz"))
    for path in files:
        poses = load_kinect_v1(path)
        joints = lifter_joints(poses, str(path)).astype(np.float64)
        to_sensor = -joints[:, PELVIS]
        ok, _, _, on_pair_up = pair_headings(pair, joints, poses.fps or 30.0)
        for row, R in zip(ROWS, on_pair_up):
            err = signed_heading_error_deg(R[:, :, 0], to_sensor, R[:, :, 1])[ok]
            per_frame[row].append(np.abs(err[np.isfinite(err)]))
            per_sequence[row].append(circular_mean_deg(err))
        with np.load(path) as f:
            subjects.append(int(f["subject"]))
    subject = np.asarray(subjects)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"{len(files)} sequences, {len(set(subjects))} subjects; heading error against facing the sensor (deg)", "",
             f"  {'row':<24}{'per sequence |mean|':>21}{'median':>9}{'per frame |mean|':>18}   "
             + "  ".join(f"s{s}" for s in sorted(set(subjects)))]
    for row in ROWS:
        seq = np.abs(np.asarray(per_sequence[row]))
        by_subject = "  ".join(f"{np.nanmean(seq[subject == s]):>4.1f}" for s in sorted(set(subjects)))
        lines.append(f"  {row:<24}{np.nanmean(seq):>21.2f}{np.nanmedian(seq):>9.2f}"
                     f"{np.concatenate(per_frame[row]).mean():>18.2f}   {by_subject}")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
