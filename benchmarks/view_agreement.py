"""How far four real cameras of one recording agree after pcnet: the canonical poses and the joint angles.

    python -m benchmarks.view_agreement [--data ../shared/data] [--out FILE]

Data: real/pose2sim_gravity/statictrial_camXX.npz, the four calibrated cameras of the Pose2Sim
demo lab (one man standing still in a T-pose, 11 frames at 60 fps), read as ``pcnet run
--lifter mediapipe`` reads them (:func:`benchmarks.gravity_benchmark.load_camera`). Each camera's
MediaPipe output is its own 3D estimate of the same body at the same instants.

For every pair of cameras, per frame: the RMS over joints of the distance between the two
pelvis-centred skeletons, (1) in the camera frames as the lifter gives them, (2) in pcnet's
canonical frame (``rectify``, sequence mode, the shipped ensemble: up from the poses, heading
from the hips), as ``canonical.npz``'s ``canonical`` holds it (the network's pose, its residual
included) and as the input turned rigidly, ``(X - pelvis) @ R`` (what ``pcnet run``'s world
frame and kinematics read, decision 0100), (3) in a canonical frame built from the lab's true
up (``up_camera``) with the same hip heading: what a perfect up would give. Then the angles between two segments at the
knees, hips and elbows (the 3D angle at the joint, the same in any frame of reference: no
rotation changes it): their RMS difference between the two cameras. Mean over the six pairs.
What is left in (3) is the estimator's own disagreement between views; pcnet can at best reach it.
Then the signed columns of ``kinematics.csv`` that users read (:data:`ISB_COLUMNS`, from
``compute_kinematics`` on each camera's input turned rigidly, as ``pcnet run`` reads it,
unfiltered: 11 frames of a still body): their RMS difference between two cameras. Knee flexion's sign and the hip's
flexion and adduction read the lifter's limb planes and pelvis (``stages/isb_angles.py``), and
trunk flexion to gravity adds each camera's up error, so they may agree less than the 3D angles
(a multi-camera user trial: a knee read flexed by three cameras and hyperextended by the fourth).
Last, the columns against gravity with each camera's true up (what ``--camera-up`` gives): the
up from the poses partly follows the lifter's own trunk, so a true up need not make them agree
better (a multi-camera trial's finding).
"""

from __future__ import annotations

import itertools
import time
from pathlib import Path

import numpy as np

from benchmarks.gravity_benchmark import load_camera
from benchmarks.report import print_and_save, trial_arguments
from pcnet.pipeline.rectification import rectify
from pcnet.stages.core.conventions import (L_ANKLE, L_ELBOW, L_HIP, L_KNEE, L_SHOULDER, L_WRIST, R_ANKLE, R_ELBOW,
                                           R_HIP, R_KNEE, R_SHOULDER, R_WRIST, SPINE)
from pcnet.stages.core.canonical import canonical_rotation, to_canonical
from pcnet.stages.core.rotations import angle_between
from pcnet.stages.kinematics import compute_kinematics

RESULT = Path(__file__).resolve().parent / "results" / "view_agreement.txt"
COMMAND = "python -m benchmarks.view_agreement --data ../shared/data"
CAMERAS = ("cam01", "cam02", "cam03", "cam04")
#: ``kinematics.csv`` columns (``Kinematics.angles`` names, deg) compared across cameras.
ISB_COLUMNS = ("left_knee_flexion", "right_knee_flexion", "left_hip_flexion", "right_hip_flexion",
               "left_hip_adduction", "right_hip_adduction", "left_elbow_flexion", "right_elbow_flexion",
               "trunk_flexion_to_gravity", "trunk_lateral_tilt_to_gravity")
#: Those of :data:`ISB_COLUMNS` read against gravity: compared again with each camera's true up.
GRAVITY_COLUMNS = ISB_COLUMNS[-2:]
#: (name, proximal joint, the joint, distal joint): the 3D angle at the joint.
SEGMENT_ANGLES = (("left knee", L_HIP, L_KNEE, L_ANKLE), ("right knee", R_HIP, R_KNEE, R_ANKLE),
                  ("left hip", SPINE, L_HIP, L_KNEE), ("right hip", SPINE, R_HIP, R_KNEE),
                  ("left elbow", L_SHOULDER, L_ELBOW, L_WRIST), ("right elbow", R_SHOULDER, R_ELBOW, R_WRIST))


def segment_angles_deg(joints: np.ndarray) -> np.ndarray:
    """``(T, len(SEGMENT_ANGLES))`` the 3D angle (deg) at each joint of :data:`SEGMENT_ANGLES`."""
    return np.stack([np.degrees(angle_between(joints[:, a] - joints[:, b], joints[:, c] - joints[:, b]))
                     for _, a, b, c in SEGMENT_ANGLES], -1)


def rms_distance_cm(a: np.ndarray, b: np.ndarray) -> float:
    """RMS over frames and joints of the distance between ``a`` and ``b`` ``(T, 17, 3)`` (m), cm."""
    return float(100 * np.sqrt(np.nanmean(np.sum((a - b) ** 2, -1))))


def column_rows(frames: dict, frame: str, names, fps: float, pairs) -> list[str]:
    """One line per ``kinematics.csv`` column of ``names``, computed on each camera's poses in
    ``frame`` (unfiltered): the RMS difference between two cameras, mean and max over ``pairs``,
    and each camera's mean."""
    columns = {cam: compute_kinematics(frames[cam][frame], fps, cutoff_hz=None).angles for cam in CAMERAS}
    lines = []
    for name in names:
        d = [float(np.sqrt(np.nanmean((columns[a][name] - columns[b][name]) ** 2))) for a, b in pairs]
        means = " / ".join(f"{np.nanmean(columns[cam][name]):+6.1f}" for cam in CAMERAS)
        lines.append(f"  {name:<30} {np.mean(d):6.1f} {np.max(d):6.1f}   {means}")
    return lines


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="view_agreement", needs="real/pose2sim_gravity")
    t0 = time.time()
    frames = {}
    for cam in CAMERAS:
        joints, up, fps = load_camera(args.data / "real" / "pose2sim_gravity" / f"statictrial_{cam}.npz")
        res = rectify(joints, mode="sequence", fps=fps)
        centred = joints - joints[:, :1]
        frames[cam] = {"camera frame": joints, "pcnet canonical": np.where(res.valid[:, None, None], res.canonical,
                                                                          np.nan),
                       "pcnet, input turned": np.where(res.valid[:, None, None], centred @ res.rotation, np.nan),
                       # the lab's up with the same hip heading (docs/CONVENTIONS.md canonical frame)
                       "canonical, true up": to_canonical(joints, canonical_rotation(joints, up)[0])}
    pairs = list(itertools.combinations(CAMERAS, 2))
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             "Pelvis-centred skeletons, RMS distance over joints and frames between two cameras (cm), "
             "mean and max over the 6 pairs:"]
    for frame in ("camera frame", "pcnet canonical", "pcnet, input turned", "canonical, true up"):
        d = [rms_distance_cm(frames[a][frame], frames[b][frame]) for a, b in pairs]
        lines.append(f"  {frame:<20} {np.mean(d):6.1f} {np.max(d):6.1f}")
    lines += ["", "Angle between two segments (3D, deg; no rotation changes it): "
                  "RMS difference between two cameras, mean and max over the 6 pairs:"]
    angles = {cam: segment_angles_deg(frames[cam]["camera frame"]) for cam in CAMERAS}
    for k, (name, *_) in enumerate(SEGMENT_ANGLES):
        d = [float(np.sqrt(np.nanmean((angles[a][:, k] - angles[b][:, k]) ** 2))) for a, b in pairs]
        lines.append(f"  {name:<12} {np.mean(d):6.1f} {np.max(d):6.1f}")
    lines += ["", "kinematics.csv's signed columns (deg; each camera's input turned rigidly, as pcnet run reads it): "
                  "RMS difference between two cameras, mean and max over the 6 pairs, and each camera's mean "
                  "(cam01 / cam02 / cam03 / cam04):"]
    lines += column_rows(frames, "pcnet, input turned", ISB_COLUMNS, fps, pairs)
    lines += ["", "The angles against gravity with each camera's true up instead (`pcnet run --camera-up`), the same "
                  "columns:"]
    lines += column_rows(frames, "canonical, true up", GRAVITY_COLUMNS, fps, pairs)
    lines += ["", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
