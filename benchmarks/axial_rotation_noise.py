"""How far a lifter's noise moves the hip's and shoulder's axial rotations, by knee or elbow bend (decision 0086).

    python -m benchmarks.axial_rotation_noise --data ../shared/data

An axial rotation (``*_hip_internal_rotation_deg``, ``*_shoulder_axial_rotation_deg``) is read
from the plane of the limb's two segments, which a straight limb leaves undefined:
``MIN_BEND_DEG`` (stages/isb_angles.py, hand-set at 5 deg) blanks it below that bend. Here, per
bend band, the error of the reading under lifter noise against the spread of the angle itself.
A reading whose error exceeds the spread tells less than the motions' mean would.

Recordings: each clip of a set seen by one static "paper" camera
(:func:`benchmarks.ablation.static_camera_clips`, the laboratory-level
:class:`pcnet.models.lifter_noise.LifterNoise`); the angles of the noisy input against those of
the clean joints in the same camera (:func:`benchmarks.ablation.camera_view_joints`), both by
:func:`pcnet.stages.isb_angles.isb_joint_angles` with no bend limit. Bands by the clean limb's
bend (unsigned knee flexion, elbow flexion); left and right pooled. Error: RMS of the wrapped
difference, deg. Spread: the standard deviation of the clean angle over the set's frames.
Sets: the validation split (Bandai motion-style val, CMU validation subjects; at most 120 clips
each) and the held-out sets of benchmarks/ablation.py (at most 200 clips each).

Writes benchmarks/results/axial_rotation_noise.txt.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import pcnet.stages.isb_angles as isb
from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save, trial_arguments
from pcnet.models.datasets import load_mocap, select_split

RESULT = Path(__file__).resolve().parent / "results" / "axial_rotation_noise.txt"
COMMAND = "python -m benchmarks.axial_rotation_noise --data ../shared/data"
EDGES_DEG = (0.0, 5.0, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 90.0, 180.0)
#: Bands with fewer frames are not printed.
MIN_FRAMES = 200
#: ``(rotation column, bend column)`` without the side prefix.
ROTATIONS = (("hip_internal_rotation_deg", "knee_flexion_deg"), ("shoulder_axial_rotation_deg", "elbow_flexion_deg"))


def unlimited_angles(joints: np.ndarray) -> dict[str, np.ndarray]:
    """:func:`pcnet.stages.isb_angles.isb_joint_angles` with no bend limit (``MIN_BEND_DEG`` 0)."""
    kept = isb.MIN_BEND_DEG
    isb.MIN_BEND_DEG = 0.0
    try:
        return isb.isb_joint_angles(joints, check_up=False)  # camera-frame views: between-segment angles only
    finally:
        isb.MIN_BEND_DEG = kept


def set_rows(clips: list, max_clips: int) -> dict[str, np.ndarray]:
    """Per rotation, ``(N, 3)`` rows of (clean bend, wrapped error, clean angle), deg."""
    out: dict[str, list] = {rot: [] for rot, _ in ROTATIONS}
    for clip, X, R, frames in A.static_camera_clips(clips, max_clips):
        clean = unlimited_angles(A.camera_view_joints(clip, frames, R))
        noisy = unlimited_angles(np.asarray(X, np.float64))
        for rot, bend in ROTATIONS:
            for side in ("left", "right"):
                a, b = clean[f"{side}_{rot}"], noisy[f"{side}_{rot}"]
                out[rot].append(np.stack([np.abs(clean[f"{side}_{bend}"]), (b - a + 180.0) % 360.0 - 180.0, a], 1))
    return {rot: np.concatenate(rows) for rot, rows in out.items()}


def table(title: str, rows: dict[str, np.ndarray]) -> list[str]:
    lines = [title]
    for rot, v in rows.items():
        v = v[np.isfinite(v).all(axis=1)]
        spread = float(np.std(v[:, 2]))
        cells = []
        for lo, hi in zip(EDGES_DEG[:-1], EDGES_DEG[1:]):
            band = v[(v[:, 0] >= lo) & (v[:, 0] < hi)]
            if len(band) >= MIN_FRAMES:
                rms = float(np.sqrt(np.mean(band[:, 1] ** 2)))
                cells.append(f"{lo:g}-{hi:g}: {rms:.1f}{' <' if rms < spread else ''}")
        lines.append(f"  {rot:<30} spread {spread:5.1f}  error by bend (deg; '<' below the spread): " + ", ".join(cells))
    return lines


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="axial_rotation_noise")
    mocap = args.data / "mocap"
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", ""]
    val = [select_split(load_mocap(mocap / file), "val", "motion-style") for _, file in F.VAL_SETS]
    lines += table("validation (Bandai val + CMU val)", _merged([set_rows(c, F.VAL_MAX_CLIPS) for c in val]))
    for title, file, split in A.MOCAP_SETS:
        lines += table(title, set_rows(A.heldout_clips(args.data, file, split), 200))
    print_and_save(lines, args.out)
    return 0


def _merged(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    return {rot: np.concatenate([p[rot] for p in parts]) for rot in parts[0]}


if __name__ == "__main__":
    raise SystemExit(main())
