"""The knee's hyperextended reading against a knee always read flexed, on mocap truth (decision 0101).

    python -m benchmarks.knee_reading --data ../shared/data --sets validation
    python -m benchmarks.knee_reading --data ../shared/data --sets heldout

From joint centres a knee's bend has two readings (stages/isb_angles.py): flexed, with the
hip's internal rotation ``r``, or hyperextended, with ``r + 180`` (the thigh frame turned about
its axis). The shipped reading takes the hyperextended one where the flexed one would turn
the hip beyond ``HYPEREXTENSION_HIP_ROTATION_DEG`` and the bend is at most
``MAX_KNEE_HYPEREXTENSION_DEG``, then keeps one reading over each run of frames
(stages/kinematics.py: ``_knee_reading``, a step of over 90 deg switches it; a kept reading
past the hyperextension limit reads flexed with the hip rotation empty). The alternative reads
every knee flexed (``knee_flexion = bend >= 0``, the hip rotation of that reading, unwrapped as
every periodic angle is).

The truth is the clean mocap's angles (no training frame reads hyperextended: see the
"truth" line); angles between segments do not depend on the frame, so the poses are turned
into the true canonical frame (no rectification). Per clip, per angle (left / right knee
flexion, left / right hip internal rotation): the mean absolute error (deg, differences
wrapped modulo 360) over the frames where the truth and both readings are defined; the clip's
score is the mean of its four angles; ``always flexed - shipped`` per clip gets the ablation's
paired verdict (benchmarks/ablation.py). Also per candidate: the share of the truth's frames it
leaves empty.

Recordings: the ablation's protocol (``benchmarks.ablation.static_camera_clips``, at most
``--max-clips`` per set, one static "paper" camera each, seed 0) with lifter-like noise
(models/lifter_noise.py) and with frame-independent noise (``models.datasets.Noise``).
``--sets validation``: the training mix's motion-style validation split; ``--sets heldout``:
Bandai motion-style test, CMU test subjects, DeepMimic less the clips the shipped weights
trained on. Real rows (no truth): the cycling MotionBERT clips, frames whose knee flexion
changes sign between consecutive frames with both beyond ``MIN_BEND_DEG``.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import numpy as np

import pcnet.stages.isb_angles as isb
import pcnet.stages.kinematics as kin
from benchmarks.ablation import camera_view_joints, static_camera_clips, verdict
from benchmarks.kinematics_residual import NOISES, sets_arguments
from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import print_and_save
from benchmarks.world_kinematics import wrapped_diff
from pcnet.stages.core.canonical import to_canonical

ANGLES = ("left_knee_flexion", "right_knee_flexion", "left_hip_internal_rotation", "right_hip_internal_rotation")
READINGS = ("shipped", "always flexed")


@contextlib.contextmanager
def reading(name: str):
    """The package's knee reading as shipped, or every knee read flexed (module docstring)."""
    if name == "shipped":
        yield
        return
    saved = isb.HYPEREXTENSION_HIP_ROTATION_DEG, kin._knee_reading
    isb.HYPEREXTENSION_HIP_ROTATION_DEG = 180.0  # cos 180 = -1: no flexed reading turns the hip further
    kin._knee_reading = lambda rot, knee, previous: (rot.copy(), knee.copy())
    try:
        yield
    finally:
        isb.HYPEREXTENSION_HIP_ROTATION_DEG, kin._knee_reading = saved


def angles_of(poses: np.ndarray, fps: float, name: str) -> dict[str, np.ndarray]:
    with reading(name):
        k = kin.compute_kinematics(poses, fps, check_up=False)
    return {a: np.asarray(k.angles[a]) for a in ANGLES}


def clip_row(noisy: np.ndarray, truth: np.ndarray, fps: float) -> dict:
    t = angles_of(truth, fps, "always flexed")
    est = {r: angles_of(noisy, fps, r) for r in READINGS}
    row = {"per_angle": {}, "empty": {r: 0 for r in READINGS}, "truth_frames": 0}
    for a in ANGLES:
        defined = np.isfinite(t[a])
        row["truth_frames"] += int(defined.sum())
        for r in READINGS:
            row["empty"][r] += int((defined & ~np.isfinite(est[r][a])).sum())
        ok = defined & np.isfinite(est["shipped"][a]) & np.isfinite(est["always flexed"][a])
        row["per_angle"][a] = {r: float(np.abs(wrapped_diff(est[r][a][ok], t[a][ok])).mean()) if ok.any() else np.nan
                               for r in READINGS}
    row["score"] = {r: float(np.nanmean([row["per_angle"][a][r] for a in ANGLES])) for r in READINGS}
    return row


def score_set(clips: list, max_clips: int, noise) -> list[dict]:
    rows = []
    for clip, X, R, frames in static_camera_clips(clips, max_clips, noise=noise):
        if len(X) < 30:
            continue
        truth = to_canonical(camera_view_joints(clip, frames, R), R)
        rows.append(clip_row(to_canonical(np.asarray(X, np.float64), R), truth, clip.fps))
    return rows


def set_lines(title: str, rows: list[dict]) -> list[str]:
    s = np.array([r["score"]["shipped"] for r in rows])
    f = np.array([r["score"]["always flexed"] for r in rows])
    keep = np.isfinite(s) & np.isfinite(f)
    frames = sum(r["truth_frames"] for r in rows)
    empty = {k: 100 * sum(r["empty"][k] for r in rows) / max(frames, 1) for k in READINGS}
    per = []
    for a in ANGLES:
        v = {k: np.nanmean([r["per_angle"][a][k] for r in rows]) for k in READINGS}
        per.append(f"{v['shipped']:.1f} / {v['always flexed']:.1f}")
    return [f"| {title} | {keep.sum()} | {s[keep].mean():.2f} | {f[keep].mean():.2f} | "
            f"{verdict('alternative', f[keep] - s[keep])} | {empty['shipped']:.1f} / {empty['always flexed']:.1f} | "
            + " | ".join(per) + " |"]


def truth_line(data: Path) -> str:
    """Share of the training mix's clean frames (bend of at least MIN_BEND_DEG) read hyperextended."""
    (train,) = training_mix_splits(data, "train")
    hyper = total = 0
    for clip in train:
        a = isb.isb_joint_angles(clip.joints.astype(np.float64))
        for side in ("left", "right"):
            k = a[f"{side}_knee_flexion_deg"]
            bent = np.isfinite(k) & (np.abs(k) >= isb.MIN_BEND_DEG)
            hyper += int((k[bent] < 0).sum())
            total += int(bent.sum())
    return (f"truth: {hyper} of {total} knee readings of the training mix's clean mocap (both sides, bend >= "
            f"{isb.MIN_BEND_DEG:g} deg) are hyperextended under the shipped reading")


def real_lines(data: Path) -> list[str]:
    from pcnet.adapters import load_motionbert

    lines = ["| real clip | frames | knee sign changes between frames, shipped / always flexed (left + right) |",
             "|---|---:|---:|"]
    y_up = np.diag([1.0, -1.0, -1.0])  # a proper rotation: camera (y down) to y up
    for path in sorted((data / "real" / "cycling_motionbert").glob("*.npy")):
        X = np.asarray(load_motionbert(path).joints, np.float64) @ y_up
        counts = []
        for r in READINGS:
            ang = angles_of(X, 30.0, r)
            n = 0
            for side in ("left", "right"):
                k = ang[f"{side}_knee_flexion"]
                big = np.abs(k) >= isb.MIN_BEND_DEG
                n += int(np.sum(big[1:] & big[:-1] & (np.sign(k[1:]) != np.sign(k[:-1]))))
            counts.append(n)
        lines.append(f"| {path.name} | {len(X)} | {counts[0]} / {counts[1]} |")
    return lines


def main(argv=None) -> None:
    args, out, sets = sets_arguments(argv, __doc__, "knee_reading")
    t0 = time.perf_counter()
    lines = [__doc__.splitlines()[0], "",
             f"    python -m benchmarks.knee_reading --data {args.data} --sets {args.sets} --max-clips {args.max_clips}",
             "", truth_line(args.data), "",
             "Score = mean over clips of the clip's mean error over the four angles (deg); verdict of always flexed -",
             "shipped per clip (paired bootstrap over clips, 95 %); empty = share of the truth's defined frames the",
             "reading leaves empty (%); then each angle's mean error over clips, shipped / always flexed.", "",
             "| set | clips | shipped | always flexed | always flexed - shipped | empty (%) | " + " | ".join(ANGLES) + " |",
             "|---|---:|---:|---:|---|---|" + "---|" * len(ANGLES)]
    for noise_name, noise in NOISES.items():
        for title, clips in sets:
            rows = score_set(clips, args.max_clips, noise())
            lines += set_lines(f"{title}, {noise_name}", rows)
            print(f"  {title}, {noise_name}: {len(rows)} clips ({time.perf_counter() - t0:.0f} s)", flush=True)
    lines += [""] + real_lines(args.data) + ["", f"run time {time.perf_counter() - t0:.0f} s"]
    print_and_save(lines, out)


if __name__ == "__main__":
    main()
