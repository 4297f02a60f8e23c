"""Could balance tell a lying body under a level camera from a standing body under a camera
rolled 90 deg? A measured experiment, not shipped code.

    python -m benchmarks.balance_reading [--data ../shared/data] [--out benchmarks/results/balance_reading.txt]

Sequence mode's camera prior (stages/gravity_prior.py) reads a straight body lying across
the image as lying, whether it lies under a level camera or stands under a rolled one: the
skeletons are the same. A body at rest is balanced: its centre of mass lies above its support.
So each reading's up implies a support (the joints within 0.1 leg lengths of the lowest along
that up) and a horizontal offset of the centre of mass from the support's convex hull
(de Leva 1996 segment masses, benchmarks/balance_evidence.py; per frame, median over up to 60
frames evenly spaced, in leg lengths). A T-pose read as lying on its side rests on one hand
half a body away from its centre of mass; a supine body rests on its whole back. If lying
bodies always balance under the lying reading and rolled standing bodies do not, the offset
could veto the lying reading.

The lying reading's up here is the direction across the mean trunk closest to a level
camera's (the mode of the posterior's lying part when the level camera dominates). Rows: the
real lying VideoPose3D yoga files (Shavasana supine, Bhujangasana prone cobra) as filmed;
standing bodies seen through a camera rolled +-90 deg (real: Pose2Sim's T-pose in 4 cameras
with MediaPipe, the standing Tadasana files; mocap: the motion-style validation split of the
training mix with lifter-like noise, a static camera of the paper's distribution per clip,
at the lying reading's up and, for reference, at the true up); DeepMimic's floor clips (trunk
over 60 deg from the true up in most frames) at their true up. Columns: clips, offset median /
p90 / max, and the share above the largest offset of any real lying file (what a veto that
keeps every real lying file lying would catch).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay, QhullError

from benchmarks.balance_evidence import centre_of_mass
from benchmarks.gravity_benchmark import load_camera
from benchmarks.yoga_physics import FOLDER, parse_name
from pcnet.adapters import load_videopose3d
from pcnet.models.datasets import load_mocap, make_pairs, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.core.conventions import L_ANKLE, L_HIP, L_KNEE, PELVIS, THORAX, root_relative
from pcnet.stages.core.rotations import axis_rotation, normalize
from pcnet.stages.temporal import mean_trunk
from benchmarks.mocap_sets import training_mix_splits

DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data"
RESULT = Path(__file__).resolve().parent / "results" / "balance_reading.txt"
COMMAND = "python -m benchmarks.balance_reading --data ../shared/data"
LEVEL = np.array([0.0, -1.0, 0.0])
#: Joints this close to the lowest along the up (leg lengths) are the support.
SUPPORT_TOLERANCE = 0.1
FRAMES = 60
ROLLS_DEG = (90, -90)


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = np.clip(np.dot(p - a, ab) / max(float(np.dot(ab, ab)), 1e-12), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * ab)))


def hull_distance(p: np.ndarray, points: np.ndarray) -> float:
    """Distance from 2D point ``p`` to the convex hull of ``points`` ``(n, 2)`` (0 inside)."""
    if len(points) >= 3:
        try:
            if Delaunay(points).find_simplex(p) >= 0:
                return 0.0
        except QhullError:  # collinear points: the hull is a segment
            pass
    if len(points) == 1:
        return float(np.linalg.norm(p - points[0]))
    return min(_segment_distance(p, points[i], points[j]) for i in range(len(points)) for j in range(i + 1, len(points)))


def support_offset(J: np.ndarray, up: np.ndarray) -> float:
    """Median over up to :data:`FRAMES` frames of the centre of mass's horizontal distance
    from the support's hull, in leg lengths, for camera-frame joints ``(T, 17, 3)`` and up."""
    J = J[np.isfinite(J).all(axis=(1, 2))]
    J = J[np.linspace(0, len(J) - 1, min(FRAMES, len(J))).astype(int)]
    leg = np.median(np.linalg.norm(J[:, L_HIP] - J[:, L_KNEE], axis=-1) + np.linalg.norm(J[:, L_KNEE] - J[:, L_ANKLE], axis=-1))
    up = normalize(np.asarray(up, np.float64))
    a = normalize(np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0]))
    b = np.cross(up, a)
    com = centre_of_mass(J)
    out = []
    for pose, c in zip(J, com):
        h = pose @ up
        s = pose[h <= h.min() + SUPPORT_TOLERANCE * leg]
        out.append(hull_distance(np.array([c @ a, c @ b]), np.stack([s @ a, s @ b], -1)) / leg)
    return float(np.median(out))


def lying_up(J: np.ndarray) -> np.ndarray:
    """The direction across the mean trunk closest to a level camera's up."""
    t = normalize(mean_trunk(J, np.isfinite(J).all(axis=(1, 2))))
    return normalize(LEVEL - (LEVEL @ t) * t)


def rolled(J: np.ndarray, roll_deg: float) -> tuple[np.ndarray, np.ndarray]:
    Q = axis_rotation("z", np.radians(roll_deg))
    return J @ Q.T, Q


def row(label: str, values: list[float], limit: float | None) -> str:
    v = np.array(values)
    above = "-" if limit is None else f"{100 * np.mean(v > limit):.0f} %"
    return f"| {label} | {len(v)} | {np.median(v):.2f} / {np.percentile(v, 90):.2f} / {v.max():.2f} | {above} |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT, help="data root (default ../shared/data)")
    ap.add_argument("--out", type=Path, default=RESULT, help=f"where the table is written too (default {RESULT})")
    args = ap.parse_args()
    yoga = sorted((args.data / Path(*FOLDER)).glob("export_*.npy"))
    if not yoga:
        sys.exit(f"balance_reading: no yoga files under {args.data / Path(*FOLDER)}; pass --data <data root>")
    t0 = time.perf_counter()
    by_asana: dict[str, list[np.ndarray]] = {}
    for path in yoga:
        by_asana.setdefault(parse_name(path)[1], []).append(root_relative(load_videopose3d(path).joints[::3])[0])
    lying = {a: [support_offset(J, lying_up(J)) for J in by_asana[a]] for a in ("Shavasana", "Bhujangasana")}
    limit = max(max(v) for v in lying.values())
    rows = [row(f"real lying, {a} (VideoPose3D), lying reading", v, None) for a, v in lying.items()]

    pose2sim = [load_camera(p)[0] for p in sorted((args.data / "real" / "pose2sim_gravity").glob("statictrial_cam*.npz"))]
    for name, clips in (("Pose2Sim T-pose (MediaPipe), 4 cameras", pose2sim), ("Tadasana (VideoPose3D)", by_asana["Tadasana"])):
        rows.append(row(f"real standing, camera rolled +-90: {name}, lying reading",
                        [support_offset(X, lying_up(X)) for J in clips for X, _ in (rolled(J, r) for r in ROLLS_DEG)], limit))

    val = [c for part in training_mix_splits(args.data, "val") for c in part]
    pairs = make_pairs(val, views="paper", seed=0, camera="static", noise=LifterNoise())
    at_lying, at_truth = [], []
    for i in range(len(val)):
        sel = np.flatnonzero(pairs.clip == i)
        if len(sel) < 30:
            continue
        for r in ROLLS_DEG:
            X, Q = rolled(pairs.inputs[sel].astype(np.float64), r)
            at_lying.append(support_offset(X, lying_up(X)))
            at_truth.append(support_offset(X, Q @ pairs.R[sel[0]][:, 1]))
    rows.append(row("mocap standing (motion-style val, lifter noise), camera rolled +-90, lying reading", at_lying, limit))
    rows.append(row("the same, at the true up", at_truth, limit))

    deepmimic = select_split(load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz"), "all")
    floor = make_pairs(deepmimic, views="paper", seed=0, camera="static")
    values = []
    for i in range(len(deepmimic)):
        sel = np.flatnonzero(floor.clip == i)
        canon = floor.canonical[sel]
        trunk = canon[:, THORAX] - canon[:, PELVIS]
        if len(sel) < 30 or np.median(trunk[:, 1] / np.linalg.norm(trunk, axis=-1)) > np.cos(np.radians(60)):
            continue
        values.append(support_offset(floor.inputs[sel].astype(np.float64), floor.R[sel[0]][:, 1]))
    rows.append(row("DeepMimic floor clips (trunk > 60 deg from up), clean, at the true up", values, limit))

    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             "Centre of mass offset from the support's hull, leg lengths (median / p90 / max over clips); share above "
             f"{limit:.2f}, the largest of any real lying file:", "",
             "| data | clips | offset median / p90 / max | above every real lying file |", "|---|---|---|---|", *rows,
             "", f"({time.perf_counter() - t0:.0f} s)"]
    print("\n".join(lines))
    args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
