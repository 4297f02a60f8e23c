"""How much does the heading jitter from frame to frame on real lifter output? Each network's heading on the pair's up, on the real yoga, boxing and cycling files.

    python -m benchmarks.heading_jitter --data ../shared/data

Data: every real/yoga_videopose3d/*.npy (VideoPose3D; held poses: the body's heading barely
changes within a file) and the MotionBERT boxing and cycling files (real/*_motionbert/*X3D*.npy),
read as `pcnet run` reads them, pelvis-centred. Per frame the pair's up
(ViewGatedPCNet.predict_gated) with the heading of (a) the camera-frame network, (b) the
body-frame network (each turned by the shortest arc onto the pair's up,
stages/core/rotations.py: with_up); the heading is the angle of canonical +X about the up,
measured from the camera's optical axis projected on the plane perpendicular to the up. Per
file: the median absolute change of that heading from one frame to the next (deg per frame) and
its circular standard deviation over the file (deg). No ground truth: a lower frame-to-frame
change is steadier, not necessarily more accurate. Writes benchmarks/results/heading_jitter.txt.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.headings import pair_headings, wrapped_deg
from benchmarks.report import print_and_save, trial_arguments

from pcnet.adapters import load_motionbert, load_videopose3d
from pcnet.models.inference import ViewGatedPCNet
from pcnet.pipeline.io import lifter_joints
from pcnet.stages.core.conventions import root_relative
from pcnet.stages.core.rotations import normalize

RESULT = Path(__file__).resolve().parent / "results" / "heading_jitter.txt"
COMMAND = "python -m benchmarks.heading_jitter --data ../shared/data"
ROWS = ("camera-frame", "body-frame")


def heading_about_up_deg(R: np.ndarray) -> np.ndarray:
    """Angle (deg) of each rotation's +X about its up, from the optical axis (+z) projected on
    the plane perpendicular to the up; ``R`` ``(T, 3, 3)``."""
    up, x = R[:, :, 1], R[:, :, 0]
    ref = normalize(np.array([0.0, 0.0, 1.0]) - up[:, 2:3] * up)
    return np.degrees(np.arctan2(np.sum(np.cross(ref, x) * up, -1), np.sum(ref * x, -1)))


def jitter(h: np.ndarray) -> tuple[float, float]:
    """(median |frame-to-frame change|, circular std) in degrees of headings ``h`` (deg)."""
    h = h[np.isfinite(h)]
    step = wrapped_deg(np.diff(h))
    r = np.radians(h)
    R = np.hypot(np.sin(r).mean(), np.cos(r).mean())
    return float(np.median(np.abs(step))), float(np.degrees(np.sqrt(-2.0 * np.log(max(R, 1e-12)))))


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="heading_jitter", needs="real")
    pair = ViewGatedPCNet()
    real = args.data / "real"
    files = [(load_videopose3d, p) for p in sorted((real / "yoga_videopose3d").glob("*.npy"))]
    files += [(load_motionbert, p) for p in sorted(real.glob("*_motionbert/*X3D*.npy"))]
    groups: dict[str, dict[str, list[tuple[float, float]]]] = {}
    for loader, path in files:
        poses = loader(path)
        joints, _ = root_relative(lifter_joints(poses, str(path)))
        ok, _, _, on_pair_up = pair_headings(pair, joints, 30.0)
        group = path.stem.split("_")[-1] if path.parent.name == "yoga_videopose3d" else path.parent.name
        for row, R in zip(ROWS, on_pair_up):
            groups.setdefault(group, {r: [] for r in ROWS})[row].append(jitter(heading_about_up_deg(R[ok])))
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             "Per group of files: median over files of the median |frame-to-frame heading change| (deg/frame) "
             "and of the circular std over the file (deg)", "",
             f"  {'files':<28}{'n':>4}" + "".join(f"{r + ' step':>20}{r + ' std':>19}" for r in ROWS)]
    for group, rows in groups.items():
        cells = "".join(f"{np.median([s for s, _ in rows[r]]):>20.2f}{np.median([d for _, d in rows[r]]):>19.1f}"
                        for r in ROWS)
        lines.append(f"  {group:<28}{len(rows[ROWS[0]]):>4}{cells}")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
