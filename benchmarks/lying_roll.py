"""Physics check on real lying poses: does a supine body come out lying on its back?

    python -m benchmarks.lying_roll [--data ../shared/data] [--stride 2] [--out benchmarks/results/lying_roll.txt]

benchmarks/yoga_physics.py checks that a lying Shavasana trunk comes out horizontal (>= 80 deg
from vertical). A body lying on its back also has its hips and shoulders level: the hip line
(left_hip -> right_hip) and the shoulder line lie in the floor plane, 0 deg from horizontal;
lying on the side puts them near 90. Per real VideoPose3D Shavasana file (supine, the same 15
files as yoga_physics.py, read as `pcnet run --lifter videopose3d` reads them, 30 fps assumed,
every `--stride`-th frame), the median over valid frames of the trunk's angle from vertical and
of the hip and shoulder lines' angles from horizontal (asin of their vertical part), for the
camera-frame input (up = image up, a level camera assumed) and the sequence-mode configurations
of benchmarks/configurations.py. No ground truth: the asana is the reference.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from benchmarks.configurations import CONFIGURATIONS
from benchmarks.report import SHARED_DATA, data_arguments, print_and_save
from benchmarks.yoga_physics import CANONICAL_UP, FOLDER, FPS, IMAGE_UP, plain_export, parse_name, trunk_angles_deg

from pcnet.adapters import load_videopose3d
from pcnet.stages.core.conventions import L_HIP, L_SHOULDER, R_HIP, R_SHOULDER, root_relative

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "lying_roll.txt"
SEQUENCE = [c for c in CONFIGURATIONS if c.mode == "sequence"]
COMMAND = "    python -m benchmarks.lying_roll --data ../shared/data --stride 2"


def line_tilt_deg(joints: np.ndarray, a: int, b: int, up: np.ndarray) -> np.ndarray:
    """``(T,)`` angle (deg) of the ``a -> b`` line of poses ``(T, 17, 3)`` from the plane
    normal to ``up`` (0 = horizontal); NaN where a joint is missing."""
    v = joints[:, b] - joints[:, a]
    n = np.linalg.norm(v, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.degrees(np.arcsin(np.clip(np.abs(v @ up) / n, 0.0, 1.0)))


def medians(joints: np.ndarray, valid: np.ndarray, up: np.ndarray) -> tuple[float, float, float]:
    """Median trunk from vertical, hip line and shoulder line from horizontal (deg)."""
    keep = valid & np.isfinite(joints).all(axis=(1, 2))
    if not keep.any():
        return float("nan"), float("nan"), float("nan")
    X = joints[keep]
    return (float(np.median(trunk_angles_deg(X, up))), float(np.median(line_tilt_deg(X, L_HIP, R_HIP, up))),
            float(np.median(line_tilt_deg(X, L_SHOULDER, R_SHOULDER, up))))


def main() -> None:
    args = data_arguments(__doc__, DEFAULT, RESULT, stride=2)
    files = sorted(p for p in args.data.joinpath(*FOLDER).glob("export_*_Shavasana.npy") if plain_export(p))
    if not files:
        sys.exit(f"lying_roll: no export_*_Shavasana.npy under {args.data.joinpath(*FOLDER)}; pass --data <data root>")
    labels = ["input", *(c.label for c in SEQUENCE)]
    lines = [COMMAND, "", f"{len(files)} real VideoPose3D Shavasana (supine) files, {FPS / args.stride:g} fps.",
             "Per file, median over valid frames: trunk from vertical / hip line from horizontal / shoulder line from",
             "horizontal (deg). Lying on the back: about 90 / 0 / 0; on the side: about 90 / 90 / 90.", "",
             "| person | " + " | ".join(labels) + " |", "|---|" + "---|" * len(labels)]
    table = {label: [] for label in labels}
    for path in files:
        joints = root_relative(load_videopose3d(path).joints[:: args.stride].astype(np.float64))[0]
        cells = {"input": medians(joints, np.ones(len(joints), bool), IMAGE_UP)}
        for config in SEQUENCE:
            res = config.rectify(joints, FPS / args.stride)
            cells[config.label] = medians(res.canonical, res.valid, CANONICAL_UP)
        for label in labels:
            table[label].append(cells[label])
        lines.append(f"| {parse_name(path)[0]} | " + " | ".join("{:.0f} / {:.0f} / {:.0f}".format(*cells[label])
                                                              for label in labels) + " |")
        print(lines[-1], flush=True)
    lines += ["", "Median over files [min, max] of the hip line from horizontal:"]
    for label in labels:
        hips = np.array([row[1] for row in table[label]])
        lines.append(f"  {label:<16} {np.nanmedian(hips):5.1f} [{np.nanmin(hips):.1f}, {np.nanmax(hips):.1f}]")
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
