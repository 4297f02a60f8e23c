"""Is the thigh plane level in real seated yoga? An exploratory measurement, not used by pcnet.

    python -m benchmarks.thigh_plane [--data ../shared/data]

Why: the up model reads a seated lotus (Padmasana) 8-50 deg from upright in 11 of 14 real files
(benchmarks/yoga_physics.py), and no evidence in it describes a seated body. A body seated on
the floor rests on its buttocks and knees, so the plane through the pelvis and both knees is
near level, whatever the camera. This script measures how near, on the same real files, as a
lead for a seated posture hypothesis (issue 49: the lying body's contact points and the stance
feet are the physics it names).

Data: real/yoga_videopose3d Padmasana files (seated) and, for contrast, Tadasana (standing,
where the thighs hang and the plane is near vertical), read as `pcnet run --lifter videopose3d`
does (pelvis-centred, camera frame: x right, y down, z forward). Per frame, the unit normal of the
plane through the pelvis and the two knees (H36M joints 0, 2, 5), turned to the thorax's side;
per file, the median of the frames' normals. Columns (deg): that normal against the trunk
(pelvis -> thorax, its median direction), against image up (-y: the camera tilt the plane implies
if it is level), and the shipped pair's sequence up (`pcnet run`'s default) against the trunk, the
number benchmarks/yoga_physics.py tests against 15 deg. No gravity truth: the trunk of a lotus is
upright by the asana's definition, the only reference here.

Writes benchmarks/results/thigh_plane.txt.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA, print_and_save
from benchmarks.yoga_physics import FOLDER, FPS, IMAGE_UP, parse_name, plain_export
from pcnet.adapters import load_videopose3d
from pcnet.pipeline.rectification import rectify
from pcnet.stages.core.conventions import L_KNEE, PELVIS, R_KNEE, THORAX
from pcnet.stages.core.rotations import angle_between, normalize

RESULT = Path(__file__).resolve().parent / "results" / "thigh_plane.txt"
COMMAND = "python -m benchmarks.thigh_plane --data ../shared/data"
ASANAS = ("Padmasana", "Tadasana")
#: yoga_physics.py's Padmasana target: trunk within this of vertical (deg).
SEATED_TRUNK_DEG = 15.0


def median_direction(v: np.ndarray) -> np.ndarray:
    """The normalised coordinate-wise median of the finite unit vectors ``v`` ``(T, 3)``."""
    v = v[np.isfinite(v).all(axis=1)]
    return normalize(np.median(v, axis=0))


def file_row(joints: np.ndarray) -> tuple[float, float, float]:
    """``(plane vs trunk, plane vs image up, pcnet's up vs trunk)`` in degrees for one file's
    pelvis-centred camera-frame poses ``(T, 17, 3)``."""
    pelvis = joints[:, PELVIS]
    trunk = normalize(joints[:, THORAX] - pelvis)
    normal = normalize(np.cross(joints[:, R_KNEE] - pelvis, joints[:, L_KNEE] - pelvis))
    normal *= np.sign(np.sum(normal * trunk, axis=1, keepdims=True))
    plane, trunk_median = median_direction(normal), median_direction(trunk)
    res = rectify(joints.astype(np.float32), "pcnet", mode="sequence", fps=FPS)
    up = median_direction(res.up[res.valid])
    return (float(np.degrees(angle_between(plane, trunk_median))), float(np.degrees(angle_between(plane, IMAGE_UP))),
            float(np.degrees(angle_between(up, trunk_median))))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", "",
             f"{'file':<34}{'plane-trunk':>12}{'plane tilt':>11}{'pcnet-trunk':>12}   (deg)"]
    for asana in ASANAS:
        rows = []
        for path in sorted((args.data.joinpath(*FOLDER)).glob(f"export_*_{asana}.npy")):
            if not plain_export(path):
                continue
            poses = load_videopose3d(path).joints.astype(np.float64)
            row = file_row(poses - poses[:, PELVIS:PELVIS + 1])
            rows.append(row)
            lines.append(f"{parse_name(path)[0] + ' ' + asana:<34}{row[0]:>12.1f}{row[1]:>11.1f}{row[2]:>12.1f}")
        r = np.array(rows)
        lines.append(f"{asana}: {len(r)} files; trunk within {SEATED_TRUNK_DEG:g} deg of the plane's normal in "
                     f"{int(np.sum(r[:, 0] <= SEATED_TRUNK_DEG))}, of pcnet's up in {int(np.sum(r[:, 2] <= SEATED_TRUNK_DEG))}; "
                     f"median plane-trunk {np.median(r[:, 0]):.1f}, pcnet-trunk {np.median(r[:, 2]):.1f}")
        lines.append("")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
