"""Fit the ankle clearance of the world frame's ground plane (stages/floor.py) and check the
floor on held-out mocap.

    python -m benchmarks.fit_floor --data ../shared/data

Fit (training data only): on ../shared/data/mocap/cmu_train_h36m17.npz, the motion-style
training subjects (models/datasets.py: ``select_split(clips, "train", "motion-style")``; the
world floor there is y = 0), each clip's contact plane ``a`` (stages/floor.py: Tukey
location of the frames' lowest joint heights where an ankle shows, on the true poses and path)
over its leg length ``L``; per subject the median over clips, and
``ANKLE_CLEARANCE_LEG`` = the median over subjects. The same ratio over the shank (knee ->
ankle) is printed too; since every CMU subject there has one retargeted skeleton, the
normaliser is chosen by which ratio differs less between the two training rigs (CMU train
and Bandai train, ``benchmarks/mocap_sets.py``'s training mix).

Held out (never fitted on): CMU validation subjects 12 and 60 and DeepMimic (all clips). Per
clip, a static camera 4 m in front of the start, 1.5 m high, pitched 10 deg down (OpenCV
axes), and the clip through ``to_world_floor`` with the true world frame:
- floor error = median over frames of (pelvis height over the fitted floor - true pelvis
  height over y = 0), in cm (positive: floor too low);
- "path": with the true pelvis path (the plane); "path x1.05 (rays)": the path scaled by
  1.05 about the camera centre (a recovered path's depth scale error moves it along the
  rays); "path z x1.05": only its depth scaled; "lifter noise": lifter-like errors
  (models/lifter_noise.py, seed = the clip's index) on the root-relative joints, true path;
  "no path": the per-frame fallback (pelvis height error per frame, median |.|);
- slope: the tilt (deg) of a plane fitted by weighted least squares to the contacts the
  biweight kept, with the true path: why the plane is kept horizontal.

Writes benchmarks/results/fit_floor.txt.
"""

from __future__ import annotations

import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from benchmarks.report import print_and_save, trial_arguments

from pcnet.models.datasets import group_key, load_mocap, select_split
from pcnet.models.lifter_noise import apply_lifter_errors, sample_lifter_errors
from pcnet.stages.core.canonical import canonical_rotation
from pcnet.stages.core.conventions import L_ANKLE, L_KNEE, PELVIS, R_ANKLE, R_KNEE
from pcnet.stages.core.rotations import axis_rotation
from pcnet.stages.floor import ANKLE_CLEARANCE_LEG, tukey_location
from pcnet.stages.spherical import TUKEY_C
from pcnet.stages.world_frame import _floor_evidence, to_world_floor, world_frame

RESULT = Path(__file__).resolve().parent / "results" / "fit_floor.txt"
# world -> OpenCV camera: x right, y down, z forward, looking along world +Z, pitched 10 deg down
CAMERA = axis_rotation("x", np.radians(-10.0)) @ np.diag([1.0, -1.0, -1.0]) @ axis_rotation("y", np.pi)


def contact_level(P: np.ndarray) -> tuple[float, float, float, np.ndarray]:
    """``(a, leg, shank, kept contact points (K, 3))`` of Y-up poses ``P`` ``(T, 17, 3)``:
    the contact plane's height as stages/floor.py fits it."""
    present, lowest, feet, pelvis_y, legs = _floor_evidence(P)
    c = feet & np.isfinite(lowest)
    a, scale = tukey_location(lowest[c])
    u = (lowest - a) / (TUKEY_C * max(scale, 1e-12))
    kept = c & (np.abs(u) < 1)
    low_j = np.nanargmin(np.where(np.isfinite(P[..., 1]), P[..., 1], np.inf), axis=1)
    pts = P[np.flatnonzero(kept), low_j[kept]]
    shank = float(np.nanmedian(np.linalg.norm(P[:, [R_KNEE, L_KNEE]] - P[:, [R_ANKLE, L_ANKLE]], axis=-1)))
    return a, float(np.nanmedian(legs)), shank, pts


def slope_deg(pts: np.ndarray) -> float:
    """Tilt of the least-squares plane y = b0 + b1 x + b2 z through contact points; NaN when
    they do not span an area."""
    if len(pts) < 3 or np.linalg.matrix_rank(np.c_[pts[:, 0] - pts[:, 0].mean(), pts[:, 2] - pts[:, 2].mean()]) < 2:
        return float("nan")
    A = np.c_[np.ones(len(pts)), pts[:, 0], pts[:, 2]]
    b = np.linalg.lstsq(A, pts[:, 1], rcond=None)[0]
    return float(np.degrees(np.arctan(np.hypot(b[1], b[2]))))


def filmed(J: np.ndarray, fps: float, noise_seed: int | None = None):
    """Camera-frame root-relative joints, the camera-frame pelvis path and the world frame of
    the true rotations for mocap ``J`` (Y up, metres) filmed by :data:`CAMERA` from 4 m in
    front of the start, 1.5 m high."""
    start = J[0, PELVIS]
    centre = np.array([start[0], 1.5, start[2] - 4.0])
    cam_all = (J - centre) @ CAMERA.T
    root = cam_all[:, PELVIS].copy()
    rel = cam_all - root[:, None]
    R, valid = canonical_rotation(rel, CAMERA @ np.array([0.0, 1.0, 0.0]))
    frame = world_frame(np.where(valid[:, None, None], R, np.nan), valid, fps)
    if noise_seed is not None:
        rel = apply_lifter_errors(rel, sample_lifter_errors(len(J), fps, np.random.default_rng(noise_seed)))
    return rel, root, frame


def floor_error_cm(J: np.ndarray, world: np.ndarray) -> float:
    """Median over frames of the pelvis height over the fitted floor minus the true one, cm."""
    return float(100 * np.nanmedian(world[:, PELVIS, 1] - J[:, PELVIS, 1]))


def held_out_rows(clips, label: str) -> list[str]:
    acc = defaultdict(list)
    for i, c in enumerate(clips):
        J = c.joints.astype(np.float64)
        if len(J) < 30:
            continue
        rel, root, frame = filmed(J, c.fps)
        turn = frame.rotation @ CAMERA  # true world -> pcnet world (about the vertical)
        if not np.allclose(turn[1], [0, 1, 0], atol=1e-6):
            continue
        for name, path, joints in (("path", root, rel), ("path x1.05 (rays)", root * 1.05, rel),
                                   ("path z x1.05", root * np.array([1.0, 1.0, 1.05]), rel),
                                   ("lifter noise", root, filmed(J, c.fps, noise_seed=i)[0])):
            world, floor = to_world_floor(joints, frame, path)
            acc[name].append(floor_error_cm(J, world))
            acc[name + " kind"].append(floor.kind == "plane")
        world, floor = to_world_floor(rel, frame)
        acc["no path"].append(float(100 * np.nanmedian(np.abs(world[:, PELVIS, 1] - J[:, PELVIS, 1]))))
        acc["slope"].append(slope_deg(contact_level(J)[3]))
    rows = []
    for name in ("path", "path x1.05 (rays)", "path z x1.05", "lifter noise", "no path"):
        e = np.array(acc[name])
        planes = int(np.sum(acc.get(name + " kind", [0])))
        rows.append(f"| {label} | {name} | {len(e)} | {planes if name != 'no path' else '-'} | {np.mean(e):+.1f} | "
                    f"{np.median(np.abs(e)):.1f} | {np.percentile(np.abs(e), 95):.1f} | {np.mean(np.abs(e) <= 2):.2f} |")
    s = np.array(acc["slope"])
    s = s[np.isfinite(s)]
    rows.append(f"| {label} | contact plane slope (deg), true path | {len(s)} | - | median {np.median(s):.2f} | "
                f"p90 {np.percentile(s, 90):.2f} | p95 {np.percentile(s, 95):.2f} | - |")
    return rows


def main() -> None:
    args = trial_arguments(__doc__, RESULT, script="fit_floor")
    t0 = time.perf_counter()
    mocap = args.data / "mocap"
    cmu = load_mocap(mocap / "cmu_train_h36m17.npz")
    lines = [" ".join(__doc__.splitlines()[:2]), "", f"    python -m benchmarks.fit_floor --data {args.data}", "",
             "## Fit: contact plane a over the leg L (and the shank), per training subject", "",
             "| subject | clips | median a (m) | median a/L | median a/shank |", "|---|---:|---:|---:|---:|"]
    per_subject = defaultdict(list)
    for c in select_split(cmu, "train", "motion-style"):
        if len(c.joints) < 30:
            continue
        a, leg, shank, _ = contact_level(c.joints.astype(np.float64))
        per_subject[group_key(c)].append((a, a / leg, a / shank))
    subj = {}
    for k in sorted(per_subject):
        v = np.array(per_subject[k])
        subj[k] = np.median(v, axis=0)
        lines.append(f"| {k} | {len(v)} | {subj[k][0]:.4f} | {subj[k][1]:.4f} | {subj[k][2]:.4f} |")
    m = np.array(list(subj.values()))
    fitted = float(np.median(m[:, 1]))
    lines += ["", f"ANKLE_CLEARANCE_LEG = median over subjects of a/L = {fitted:.4f} "
              f"(shipped {ANKLE_CLEARANCE_LEG}); over subjects: a/L std {np.std(m[:, 1]):.4f} "
              f"(cv {np.std(m[:, 1]) / np.mean(m[:, 1]):.3f}), a/shank cv {np.std(m[:, 2]) / np.mean(m[:, 2]):.3f}", ""]
    bandai = [c for c in select_split(load_mocap(mocap / "bandai_h36m17.npz"), "train", "motion-style")
              if len(c.joints) >= 30][::20]
    b = np.median([contact_level(c.joints.astype(np.float64))[:3] for c in bandai], axis=0)
    cmu_leg, cmu_shank = fitted, float(np.median(m[:, 2]))
    lines += ["Normaliser across the training rigs (Bandai train, every 20th clip, median):",
              f"- a/L: CMU train {cmu_leg:.4f}, Bandai train {b[0] / b[1]:.4f}: ratio {b[0] / b[1] / cmu_leg:.3f}",
              f"- a/shank: CMU train {cmu_shank:.4f}, Bandai train {b[0] / b[2]:.4f}: ratio {b[0] / b[2] / cmu_shank:.3f}",
              "", "## Held out: floor error (cm; + = floor too low, pelvis reads too high)", "",
              "| data | input | clips | planes | mean | median abs | p95 abs | share within 2 cm |",
              "|---|---|---:|---:|---:|---:|---:|---:|"]
    lines += held_out_rows(select_split(cmu, "val", "motion-style"), "CMU val (subjects 12, 60)")
    lines += held_out_rows(load_mocap(mocap / "deepmimic_h36m17.npz"), "DeepMimic (all)")
    lines += ["", f"run time {time.perf_counter() - t0:.0f} s"]
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
