"""How much of a lean held for the whole recording reaches the output, and whether the intervals say so.

    python -m benchmarks.sustained_lean --data ../shared/data [--out benchmarks/results/sustained_lean.txt]

One pose cannot tell a body leaning forward under a level camera from an upright body under a
camera pitched down. Sequence mode's up model reads the trunks as evidence of the up, with the
trunk postures of its fitting data (mostly upright mocap), so a lean held for the whole
recording is partly read as camera pitch: the trunk's inclination against gravity comes out
smaller than it is, and the camera's pitch interval may miss the truth. This script adds a known
forward lean to real lifter output and measures both (a clinician's trial of four views found
a 40 deg lean read as about 26 deg, with no warning).

Data: the four Pose2Sim lab cameras (``real/pose2sim_gravity``: real MediaPipe 3D of one man
standing in a T-pose, 11 frames at 60 fps; truth: the calibration's up), read as
``pcnet run --lifter mediapipe`` reads them (:func:`benchmarks.gravity_benchmark.load_camera`).

Lean: the joints above the pelvis (spine, thorax, neck, head, shoulders and arms) turned forward
by ``L`` about the horizontal axis through the pelvis along the hip line (the hip line projected
on the true horizontal), ``L`` in :data:`LEANS_DEG`; legs and camera unchanged.

Per camera and lean: sequence mode by the shipped ensemble
(``pcnet.pipeline.rectify(..., "pcnet", mode="sequence")``, the up model's posterior as
``pcnet run`` computes it without a pelvis path), the up's error against the truth, whether the
camera pitch and roll 95 % intervals hold it, and the trunk's inclination against gravity: as
pcnet measures it (pelvis -> thorax from +Y of the canonical poses) and as it is (the same
vector against the true up), medians over the frames. Last: the least-squares slope of the
measured on the true inclination over every camera and lean (the share of a held lean that
reaches the output) and the intervals' coverage per lean. Nothing is fitted: a diagnosis.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.gravity_benchmark import FOLDER, deg_between, load_camera, pitch_roll_deg
from benchmarks.report import print_and_save, trial_arguments
from pcnet.pipeline import rectify
from pcnet.stages.core.conventions import L_HIP, PELVIS, R_HIP, SPINE, THORAX
from pcnet.stages.core.rotations import normalize

RESULT = Path(__file__).resolve().parent / "results" / "sustained_lean.txt"
#: The forward leans added (deg).
LEANS_DEG = (0.0, 10.0, 20.0, 30.0, 40.0)
#: The joints above the pelvis (H36M-17 indices: spine to right wrist).
UPPER_BODY = tuple(range(SPINE, 17))


def lean_forward(joints: np.ndarray, up: np.ndarray, lean_deg: float) -> np.ndarray:
    """Root-relative camera-frame poses ``(T, 17, 3)`` with the upper body turned forward by
    ``lean_deg`` about the horizontal hip axis through the pelvis (``up``: the true camera-frame
    up ``(3,)``); the forward side is the one the trunk's horizontal part does not face away from:
    the hip line's right-hand normal, as the canonical frame's +X = +Y x +Z."""
    out = np.array(joints, np.float64, copy=True)
    hips = np.nanmedian(joints[:, R_HIP] - joints[:, L_HIP], axis=0)
    axis = normalize(hips - np.dot(hips, up) * up)  # +Z, the subject's right, horizontal
    forward = np.cross(up, axis)  # +X = +Y x +Z
    a = np.radians(lean_deg)
    # turn up towards forward about the axis: v -> v cos a + (axis x v) sin a + axis (axis . v)(1 - cos a)
    k = -axis  # (-Z) x Y = +X: a positive turn about -Z takes the up to the front
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    Rot = np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K
    assert np.allclose(Rot @ up, np.cos(a) * up + np.sin(a) * forward)
    pelvis = out[:, PELVIS : PELVIS + 1]
    out[:, UPPER_BODY] = (out[:, UPPER_BODY] - pelvis) @ Rot.T + pelvis
    return out


def trunk_inclination(joints: np.ndarray, up: np.ndarray) -> float:
    """Median angle (deg) of pelvis -> thorax from ``up`` ``(3,)`` over the frames."""
    return float(np.nanmedian(deg_between(joints[:, THORAX] - joints[:, PELVIS], up[None])))


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv)
    paths = sorted(args.data.joinpath(*FOLDER).glob("statictrial_cam*.npz"))
    if not paths:
        raise SystemExit(f"{args.data.joinpath(*FOLDER)}: expected the Pose2Sim statictrial files, got none")
    lines = [__doc__.splitlines()[0], "", "    python -m benchmarks.sustained_lean --data ../shared/data", "",
             "Per camera and added lean: trunk inclination against gravity as it is (true) and as pcnet measures it; "
             "the up's error; camera pitch and roll, truth and pcnet's 95 % interval (held: both axes). Degrees.", "",
             "| camera | lean added | trunk, true | trunk, pcnet | up error | pitch true / pcnet | "
             "roll true / pcnet | held |", "|---|---|---|---|---|---|---|---|"]
    true_incl, measured, held = [], [], {lean: [] for lean in LEANS_DEG}
    for path in paths:
        joints, up, fps = load_camera(path)
        true_pitch, true_roll = pitch_roll_deg(up)
        for lean in LEANS_DEG:
            X = lean_forward(joints, up, lean)
            res = rectify(X, "pcnet", mode="sequence", fps=fps)
            seq = res.report.sequence
            got = trunk_inclination(res.canonical[res.valid], np.array([0.0, 1.0, 0.0]))
            truth = trunk_inclination(X, up)
            dp, dr = seq.camera_pitch_interval_deg, seq.camera_roll_interval_deg
            roll_off = abs((seq.camera_roll_deg - true_roll + 180.0) % 360.0 - 180.0)
            inside = bool(abs(seq.camera_pitch_deg - true_pitch) <= dp and roll_off <= dr)
            true_incl.append(truth)
            measured.append(got)
            held[lean].append(inside)
            lines.append(f"| {path.stem.removeprefix('statictrial_')} | {lean:.0f} | {truth:.1f} | {got:.1f} | "
                         f"{float(deg_between(seq.up, up)):.1f} | {true_pitch:+.1f} / {seq.camera_pitch_deg:+.1f} +- "
                         f"{dp:.1f} | {true_roll:+.1f} / {seq.camera_roll_deg:+.1f} +- {dr:.1f} | "
                         f"{'yes' if inside else 'no'} |")
    t, m = np.array(true_incl), np.array(measured)
    slope = float(np.polyfit(t, m, 1)[0])
    lines += ["", f"Slope of pcnet's trunk inclination on the true one over {len(t)} runs: {slope:.2f} "
                  f"(1 = the whole lean reaches the output).",
              "Intervals holding the truth (both axes), per added lean: "
              + ", ".join(f"{lean:.0f} deg {sum(h)} of {len(h)}" for lean, h in held.items()) + "."]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
