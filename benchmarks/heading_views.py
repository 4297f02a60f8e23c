"""Does the body's heading agree across calibrated cameras? One real person, four lab cameras: the body's facing direction in the lab frame, per camera, from each network's heading on the pair's up.

    python -m benchmarks.heading_views --data ../shared/data

Data: real/pose2sim_gravity/statictrial_cam01-04.npz (a man standing still in a T-pose, filmed
by four calibrated cameras; MediaPipe per camera, read as `pcnet run --lifter mediapipe` reads
it, turned into the real camera: benchmarks/gravity_benchmark.py: load_camera). The truth is
not the heading itself (unknown) but that all four cameras see the same body: its facing
direction in the lab frame, R_world_to_cam^T R[:, 0] (canonical +X, anterior) projected on the
lab's floor (Qualisys +Z up), must be the same in every view. Per frame the pair's up
(ViewGatedPCNet.predict_gated) with the heading of (a) the camera-frame network, (b) the
body-frame network (the rotation turned by the shortest arc onto the pair's up,
stages/core/rotations.py: with_up); per camera the circular mean over its 11 frames; the spread
is the largest difference between two cameras. Four views of one pose: a check, not a
tuning set. Writes benchmarks/results/heading_views.txt.
"""

from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np

from benchmarks.gravity_benchmark import load_camera
from benchmarks.headings import circular_mean_deg, pair_headings, wrapped_deg
from benchmarks.report import print_and_save, trial_arguments

from pcnet.models.inference import ViewGatedPCNet

RESULT = Path(__file__).resolve().parent / "results" / "heading_views.txt"
COMMAND = "python -m benchmarks.heading_views --data ../shared/data"
ROWS = ("camera-frame heading", "body-frame heading")


def lab_headings(R: np.ndarray, R_world_to_cam: np.ndarray) -> np.ndarray:
    """Facing direction on the lab floor (deg, atan2 of its world y over x) of each frame's
    canonical +X, ``R`` ``(T, 3, 3)`` canonical -> camera."""
    forward = np.einsum("ji,tj->ti", R_world_to_cam, R[:, :, 0])  # R_world_to_cam^T @ x
    return np.degrees(np.arctan2(forward[:, 1], forward[:, 0]))


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="heading_views", needs="real/pose2sim_gravity")
    pair = ViewGatedPCNet()
    means: dict[str, dict[str, float]] = {row: {} for row in ROWS}
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             "Per camera: the body's facing direction on the lab floor (deg), circular mean over frames "
             "[per-frame range]", ""]
    for path in sorted(args.data.joinpath("real", "pose2sim_gravity").glob("statictrial_cam*.npz")):
        joints, _, fps = load_camera(path)
        with np.load(path) as f:
            R_wc = np.asarray(f["R_world_to_cam"], np.float64)
        ok, _, _, on_pair_up = pair_headings(pair, joints, fps)
        for row, R in zip(ROWS, on_pair_up):
            h = lab_headings(R[ok], R_wc)
            mean = means[row][path.stem] = circular_mean_deg(h)
            spread = wrapped_deg(h - mean)
            lines.append(f"  {path.stem:<20}{row:<22}{mean:>8.1f}  [{spread.min():+.1f}, {spread.max():+.1f}]")
    lines += ["", "Spread across the cameras (largest difference between two cameras' means, deg):"]
    for row in ROWS:
        values = list(means[row].values())
        spread = max(abs(float(wrapped_deg(a - b))) for a, b in combinations(values, 2))
        lines.append(f"  {row:<22}{spread:>8.1f}")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
