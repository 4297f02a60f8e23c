"""Vertical motion from a root-relative lifter: the world frame's per-frame floor against a pelvis
held at one height, against mocap truth.

    python -m benchmarks.vertical_motion --data ../shared/data [--max-clips 60]

A root-relative lifter (every one but a depth sensor) gives no pelvis height. ``pcnet run``
puts the floor under each frame's lowest joint centre (``stages/world_frame.py: to_world``), so
the pelvis rises and falls with the lowest joint; the alternative holds the pelvis at its median
height over the clip (one shift per recording, no vertical pelvis motion at all). Which of the
two gives vertical velocities and accelerations closer to the truth?

Held-out mocap (Bandai motion-style test clips, CMU validation subjects 12 and 60, DeepMimic,
another dataset; evenly spaced clips, at most ``--max-clips`` per set, clips of at least 30
frames), one static "paper" camera per clip (``make_pairs(camera="static")``), clean and with
lifter-like noise (models/lifter_noise.py), rectified as ``pcnet run`` does for a static camera
(the shipped pair, sequence mode, camera prior, heading auto; no bootstrap); world frame from
the estimated rotations. Truth: the mocap's own trajectories in the world frame of the true
rotations with their true heights (``world_kinematics.true_world``). Kinematics: the same code
(stages/kinematics.py, Butterworth 6 Hz, central differences). Reported: mean absolute error of
the vertical (world +Y) velocity and acceleration, of the pelvis and of all 17 joints, and of
the joints' heights above the floor, over valid frames; "truth" is the mean absolute value of
the true quantity (the error of reporting zero).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from pcnet.models.datasets import load_mocap, make_pairs, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.core.conventions import PELVIS
from pcnet.stages.kinematics import compute_kinematics
from pcnet.stages.rectify import HeadingStep, Rectification, SequenceEvidence
from pcnet.stages.world_frame import to_world, world_frame
from benchmarks.world_kinematics import true_world
from benchmarks.report import SHARED_DATA

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "vertical_motion.txt"
SETS = (("Bandai motion-style test", "bandai_h36m17.npz", "test"),
        ("CMU validation subjects", "cmu_train_h36m17.npz", "val"),
        ("DeepMimic (another dataset)", "deepmimic_h36m17.npz", "all"))
FLOORS = ("per-frame floor (now)", "pelvis at one height")
QUANTITIES = ("pelvis v_y (m/s)", "all v_y (m/s)", "pelvis a_y (m/s^2)", "all a_y (m/s^2)", "all height (m)")


def vertical_errors(world: np.ndarray, truth, valid: np.ndarray, fps: float) -> dict[str, np.ndarray]:
    """Absolute errors per quantity of :data:`QUANTITIES`, over valid frames, for world poses
    ``(T, 17, 3)`` (+Y up) against the truth's ``Kinematics``."""
    k = compute_kinematics(world, fps, check_up=False)  # an estimated frame under test
    out = {}
    for name, est, ref in (("v_y", k.velocity[..., 1], truth.velocity[..., 1]),
                           ("a_y", k.acceleration[..., 1], truth.acceleration[..., 1]),
                           ("height", k.positions[..., 1], truth.positions[..., 1])):
        e = np.abs(est - ref)[valid]
        if name != "height":
            out[f"pelvis {name} ({'m/s' if name == 'v_y' else 'm/s^2'})"] = e[:, PELVIS]
        out[f"all {name} ({'m/s' if name == 'v_y' else 'm/s^2' if name == 'a_y' else 'm'})"] = e.ravel()
    return out


def truth_magnitudes(truth, valid: np.ndarray) -> dict[str, np.ndarray]:
    """|true quantity| per quantity of :data:`QUANTITIES` (the error of reporting zero motion)."""
    v, a = truth.velocity[valid][..., 1], truth.acceleration[valid][..., 1]
    return {"pelvis v_y (m/s)": np.abs(v[:, PELVIS]), "all v_y (m/s)": np.abs(v).ravel(),
            "pelvis a_y (m/s^2)": np.abs(a[:, PELVIS]), "all a_y (m/s^2)": np.abs(a).ravel(),
            "all height (m)": np.full(1, np.nan)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--max-clips", type=int, default=60, help="per data set, evenly spaced over its clips")
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args()
    t0 = time.perf_counter()
    lines = [__doc__.splitlines()[0] + " " + __doc__.splitlines()[1], "",
             f"    python -m benchmarks.vertical_motion --data {args.data} --max-clips {args.max_clips}", "",
             "Mean absolute error over valid frames (truth: mean |true value|, the error of reporting no motion).", "",
             "| data | input | clips | frames | quantity | truth | " + " | ".join(FLOORS) + " |",
             "|---|---|---:|---:|---|---:|" + "---:|" * len(FLOORS)]
    chain = Rectification(make_estimator("pcnet"), SequenceEvidence("sequence", n_bootstrap=0), HeadingStep("auto"))
    for label, file, split in SETS:
        clips = select_split(load_mocap(args.data / "mocap" / file), split, "motion-style")
        keep = np.unique(np.linspace(0, len(clips) - 1, min(args.max_clips, len(clips))).round().astype(int))
        clips = [clips[i] for i in keep]
        for noise_label, noise in (("clean", None), ("lifter noise", LifterNoise())):
            pairs = make_pairs(clips, views="paper", seed=0, camera="static", noise=noise)
            acc: dict = {}
            n_clips = n_frames = 0
            for i, clip in enumerate(clips):
                sel = np.flatnonzero(pairs.clip == i)
                if len(sel) < 30:
                    continue
                mocap = clip.joints[pairs.frame[sel]].astype(np.float64)
                inputs = pairs.inputs[sel]
                res = chain(inputs, clip.fps)
                valid = np.asarray(res.valid, bool)
                truth = compute_kinematics(true_world(mocap, pairs.R[sel], clip.fps), clip.fps)
                per_frame = to_world(inputs, world_frame(res.rotation, valid, clip.fps))
                pelvis_y = per_frame[:, PELVIS, 1]
                one_height = per_frame.copy()
                one_height[..., 1] -= (pelvis_y - np.nanmedian(pelvis_y))[:, None]
                for floor, world in zip(FLOORS, (per_frame, one_height)):
                    for q, e in vertical_errors(world, truth, valid, clip.fps).items():
                        acc.setdefault((floor, q), []).append(e)
                for q, e in truth_magnitudes(truth, valid).items():
                    acc.setdefault(("truth", q), []).append(e)
                n_clips += 1
                n_frames += int(valid.sum())
            for q in QUANTITIES:
                cells = []
                for kind in ("truth", *FLOORS):
                    v = np.concatenate(acc[(kind, q)])
                    v = v[np.isfinite(v)]
                    cells.append(f"{v.mean():.3f}" if len(v) else "-")
                lines.append(f"| {label} | {noise_label} | {n_clips} | {n_frames} | {q} | " + " | ".join(cells) + " |")
            print("\n".join(lines[-len(QUANTITIES):]), flush=True)
    lines += ["", f"run time {time.perf_counter() - t0:.0f} s"]
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
