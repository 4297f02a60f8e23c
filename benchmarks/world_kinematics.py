"""Kinematics in one fixed world frame vs the per-frame canonical frame, against mocap truth.

    python benchmarks/world_kinematics.py --data ../shared/data [--max-clips 120]

Held-out mocap (Bandai motion-style test clips, CMU validation subjects 12 and 60; metres,
their own fps) seen by one static camera per clip ("paper" views,
`make_pairs(camera="static")`) with lifter-like noise (models/lifter_noise.py), rectified as
`pcnet run` does for a static camera (the shipped pair, sequence mode, camera prior, heading
auto; no bootstrap). Then the same kinematics code (stages/kinematics.py, Butterworth 6 Hz)
on:
- world (what pcnet writes now): the noisy poses in the recording's world frame
  (stages/world_frame.py, from the estimated rotations);
- canonical (what pcnet wrote before): the noisy poses in the per-frame canonical frame;
- truth: the mocap's own trajectories (true vertical pelvis motion, incl. flight phases; the
  horizontal root path removed, as no root-relative lifter has it; the floor at the 5th
  percentile of the clip's lowest joint centre) turned into the world frame built from the
  true rotations.
Errors over the valid frames with finite values, per joint group: position (world only;
the canonical frame has no floor), speed |v| and acceleration magnitude |a| (scalar, so a
constant heading offset between the estimated and the true world frame does not count),
and velocity as a vector (frame-dependent: includes that heading offset).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from pcnet.models.datasets import load_mocap, make_pairs, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.canonical import canonical_rotation, to_canonical
from pcnet.stages.conventions import H36M_JOINTS, PELVIS
from pcnet.stages.kinematics import compute_kinematics
from pcnet.stages.rectify import estimate_rotations, finish_rotations
from pcnet.stages.world_frame import to_world, world_frame

DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data"
RESULT = Path(__file__).resolve().parent / "results" / "world_kinematics.txt"
GROUPS = {"wrists": ("left_wrist", "right_wrist"), "ankles": ("left_ankle", "right_ankle"),
          "head": ("head",), "all 17 joints": tuple(H36M_JOINTS)}


def true_world(mocap: np.ndarray, R_true: np.ndarray, fps: float) -> np.ndarray:
    """The mocap poses ``(T, 17, 3)`` (world, Y up, metres) in the world frame pcnet would
    build from the true rotations, keeping their true heights (module docstring)."""
    R_world, _ = canonical_rotation(mocap, (0.0, 1.0, 0.0))
    to_camera = R_true[0] @ R_world[0].T  # the static camera's world->camera rotation
    W = world_frame(R_true, np.ones(len(R_true), bool), fps).rotation
    floor = np.percentile(np.nanmin(mocap[..., 1], axis=1), 5)
    rooted = mocap - np.stack([mocap[:, PELVIS, 0], np.full(len(mocap), floor), mocap[:, PELVIS, 2]], -1)[:, None]
    return rooted @ (W @ to_camera).T


def clip_errors(inputs, R_true, mocap, fps) -> dict[str, dict[str, np.ndarray]]:
    """Per-frame, per-joint absolute errors ``{frame_kind: {quantity: (T, 17)}}`` for one clip."""
    R_hat, residual, valid = estimate_rotations(inputs, "pcnet", fps=fps)
    R_hat, valid, _ = finish_rotations(inputs, R_hat, valid, "sequence", fps, "auto", n_bootstrap=0)
    truth = compute_kinematics(true_world(mocap, R_true, fps), fps)
    world = compute_kinematics(to_world(inputs, world_frame(R_hat, valid, fps)), fps)
    canonical = compute_kinematics(to_canonical(inputs, R_hat, residual), fps)
    out = {}
    for kind, k in (("world", world), ("canonical", canonical)):
        e = {"speed": np.abs(k.speed - truth.speed),
             "|a|": np.abs(np.linalg.norm(k.acceleration, axis=-1) - np.linalg.norm(truth.acceleration, axis=-1)),
             "velocity vector": np.linalg.norm(k.velocity - truth.velocity, axis=-1)}
        if kind == "world":
            e["position"] = np.linalg.norm(k.positions - truth.positions, axis=-1)
        out[kind] = {q: np.where(valid[:, None], v, np.nan) for q, v in e.items()}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--max-clips", type=int, default=120, help="per data set, evenly spaced over its clips")
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args()
    t0 = time.perf_counter()
    lines = [__doc__.splitlines()[0], "",
             f"    python benchmarks/world_kinematics.py --data {args.data} --max-clips {args.max_clips}", ""]
    for label, file, split in (("Bandai motion-style test", "bandai_h36m17.npz", "test"),
                               ("CMU validation subjects", "cmu_train_h36m17.npz", "val")):
        clips = select_split(load_mocap(args.data / "mocap" / file), split, "motion-style")
        keep = np.unique(np.linspace(0, len(clips) - 1, min(args.max_clips, len(clips))).round().astype(int))
        clips = [clips[i] for i in keep]
        pairs = make_pairs(clips, views="paper", seed=0, camera="static", noise=LifterNoise())
        acc: dict = {}
        for i, clip in enumerate(clips):
            sel = np.flatnonzero(pairs.clip == i)
            if len(sel) < 30:
                continue
            mocap = clip.joints[pairs.frame[sel]].astype(np.float64)
            for kind, qs in clip_errors(pairs.inputs[sel], pairs.R[sel], mocap, clip.fps).items():
                for q, v in qs.items():
                    acc.setdefault((kind, q), []).append(v)
        frames = sum(len(v) for v in acc[("world", "speed")])
        lines += [f"{label}: {len(clips)} clips, {frames} frames; mean absolute error (median over frames in brackets)",
                  f"  {'quantity':<24}{'joints':<16}{'world (now)':>22}{'canonical (before)':>24}"]
        for q, unit in (("position", "m"), ("speed", "m/s"), ("|a|", "m/s^2"), ("velocity vector", "m/s")):
            for group, names in GROUPS.items():
                cols = [H36M_JOINTS.index(n) for n in names]
                cells = ""
                for kind in ("world", "canonical"):
                    if (kind, q) not in acc:
                        cells += f"{'-':>22}" if kind == "world" else f"{'-':>24}"
                        continue
                    v = np.concatenate([a[:, cols] for a in acc[(kind, q)]]).ravel()
                    v = v[np.isfinite(v)]
                    cell = f"{v.mean():.3f} [{np.median(v):.3f}]"
                    cells += f"{cell:>22}" if kind == "world" else f"{cell:>24}"
                lines.append(f"  {q + ' (' + unit + ')':<24}{group:<16}{cells}")
        lines.append("")
        print("\n".join(lines[-19:]), flush=True)
    lines.append(f"run time {time.perf_counter() - t0:.0f} s")
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
