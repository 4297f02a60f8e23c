"""Where a still body touches the floor, in real yoga: two exploratory measurements, not used by pcnet.

    python -m benchmarks.contact_leads [--data ../shared/data]

Why: the up model has no evidence of how a body that is not standing or lying rests on the
floor, and it fails there on real files: a seated lotus (Padmasana) reads 8-50 deg from upright
in 11 of 14 files, and a side bend (Trikonasana) reads as a camera rolled 12-30 deg
(benchmarks/yoga_physics.py, a user trial). Issue 49 names the physics: stance feet, a body's
contact points. Two contact geometries, measured on the same real files as leads:

1. Seated on the floor, the body rests on its buttocks and knees, so the plane through the
   pelvis and both knees (H36M joints 0, 2, 5) is near level whatever the camera. Per frame its
   unit normal, turned to the thorax's side; per file the normalised median of the frames'.
   Columns (deg): that normal against the trunk (pelvis -> thorax, median direction), and the
   shipped pair's sequence up (`pcnet run`'s default) against the trunk, the number
   yoga_physics.py tests against 15 deg. Padmasana, and Tadasana for contrast (hanging thighs:
   the plane is near vertical).
2. Standing on both feet, the ankles are at one height, so the line between them is level. Per
   file, the median roll of that line in the image (its angle from the image's x axis, folded
   into [-90, 90)): a level camera's roll where the feet are level and the line runs across the
   view; against the shipped pair's sequence camera roll. Trikonasana (feet a stride apart),
   Tadasana (together) and, for contrast, Vrikshasana (one foot on the other thigh: the line is
   not level).

Data: real/yoga_videopose3d, read as `pcnet run --lifter videopose3d` does (pelvis-centred, camera
frame: x right, y down, z forward). No gravity truth: the asanas define the references.

Writes benchmarks/results/contact_leads.txt.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from benchmarks.report import print_and_save, trial_arguments
from benchmarks.yoga_physics import FOLDER, FPS, parse_name, plain_export
from pcnet.adapters import load_videopose3d
from pcnet.pipeline.rectification import rectify
from pcnet.stages.core.conventions import L_ANKLE, L_KNEE, PELVIS, R_ANKLE, R_KNEE, THORAX
from pcnet.stages.core.rotations import angle_between, camera_pitch_roll, normalize

RESULT = Path(__file__).resolve().parent / "results" / "contact_leads.txt"
COMMAND = "python -m benchmarks.contact_leads --data ../shared/data"
#: yoga_physics.py's Padmasana target: trunk within this of vertical (deg).
SEATED_TRUNK_DEG = 15.0


def median_direction(v: np.ndarray) -> np.ndarray:
    """The normalised coordinate-wise median of the finite unit vectors ``v`` ``(T, 3)``."""
    v = v[np.isfinite(v).all(axis=1)]
    return normalize(np.median(v, axis=0))


def sequence_up(joints: np.ndarray) -> np.ndarray:
    """``(3,)`` the shipped pair's sequence-mode up of pelvis-centred camera-frame poses."""
    res = rectify(joints.astype(np.float32), "pcnet", mode="sequence", fps=FPS)
    return median_direction(res.up[res.valid])


def seated_row(joints: np.ndarray) -> tuple[float, float]:
    """``(thigh plane vs trunk, pcnet's up vs trunk)``, deg (lead 1)."""
    pelvis = joints[:, PELVIS]
    trunk = normalize(joints[:, THORAX] - pelvis)
    normal = normalize(np.cross(joints[:, R_KNEE] - pelvis, joints[:, L_KNEE] - pelvis))
    normal *= np.sign(np.sum(normal * trunk, axis=1, keepdims=True))
    trunk_median = median_direction(trunk)
    return (float(np.degrees(angle_between(median_direction(normal), trunk_median))),
            float(np.degrees(angle_between(sequence_up(joints), trunk_median))))


def stance_row(joints: np.ndarray) -> tuple[float, float, float]:
    """``(ankle separation m, the ankle line's roll in the image deg, pcnet's camera roll deg)`` (lead 2)."""
    line = joints[:, L_ANKLE] - joints[:, R_ANKLE]
    roll = (np.degrees(np.arctan2(line[:, 1], line[:, 0])) + 90.0) % 180.0 - 90.0
    _, camera_roll = camera_pitch_roll(sequence_up(joints))
    return (float(np.nanmedian(np.linalg.norm(line, axis=1))), float(np.nanmedian(roll)),
            float(np.degrees(camera_roll)))


def files(data: Path, asana: str) -> list[tuple[str, np.ndarray]]:
    """``(person, pelvis-centred poses)`` of the asana's plain export files."""
    out = []
    for path in sorted(data.joinpath(*FOLDER).glob(f"export_*_{asana}.npy")):
        if plain_export(path):
            poses = load_videopose3d(path).joints.astype(np.float64)
            out.append((parse_name(path)[0], poses - poses[:, PELVIS:PELVIS + 1]))
    return out


def section(data: Path, asanas: tuple[str, ...], row, cells, summary) -> list[str]:
    """One line per file of each asana (``cells`` of its ``row``), then the asana's ``summary`` of its rows."""
    lines = []
    for asana in asanas:
        rows = []
        for person, joints in files(data, asana):
            rows.append(row(joints))
            lines.append(f"{person + ' ' + asana:<28}" + cells(rows[-1]))
        lines += [f"{asana}: {len(rows)} files; " + summary(np.array(rows)), ""]
    return lines


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv)
    folder = args.data.joinpath(*FOLDER)
    if not any(folder.glob("export_*.npy")):
        sys.exit(f"contact_leads: no export_*.npy files under {folder}; pass --data <data root>")
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", "", "1. the thigh plane of a body seated on the floor",
             f"{'file':<28}{'plane-trunk':>12}{'pcnet-trunk':>12}   (deg)"]
    lines += section(args.data, ("Padmasana", "Tadasana"), seated_row, lambda r: f"{r[0]:>12.1f}{r[1]:>12.1f}",
                     lambda r: f"trunk within {SEATED_TRUNK_DEG:g} deg of the plane's normal in "
                               f"{int(np.sum(r[:, 0] <= SEATED_TRUNK_DEG))}, of pcnet's up in "
                               f"{int(np.sum(r[:, 1] <= SEATED_TRUNK_DEG))}; median plane-trunk "
                               f"{np.median(r[:, 0]):.1f}, pcnet-trunk {np.median(r[:, 1]):.1f}")
    lines += ["2. the ankle line of a body standing on both feet",
              f"{'file':<28}{'ankles m':>9}{'line roll':>10}{'pcnet roll':>11}   (deg)"]
    lines += section(args.data, ("Trikonasana", "Tadasana", "Vrikshasana"), stance_row,
                     lambda r: f"{r[0]:>9.2f}{r[1]:>10.1f}{r[2]:>11.1f}",
                     lambda r: f"|line roll| median {np.median(np.abs(r[:, 1])):.1f} (max {np.max(np.abs(r[:, 1])):.1f}), "
                               f"|pcnet roll| median {np.median(np.abs(r[:, 2])):.1f} (max {np.max(np.abs(r[:, 2])):.1f})")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
