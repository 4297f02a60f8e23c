"""pcnet's ISB joint angles against OpenSim inverse kinematics on the same poses.

    python -m benchmarks.isb_opensim_agreement [--data ../shared/data] [--clips 8] [--max-frames 300]

What is compared. The same H36M-17 joint centres go two ways:
- pcnet: :func:`pcnet.stages.isb_angles.isb_joint_angles` (ISB: Wu et al. 2002/2005, knee per
  Grood & Suntay 1983; segment frames from joint centres, docs/joint_angles.md);
- OpenSim: the poses written as TRC (:func:`pcnet.stages.sinks.exports.write_trc`), then
  :func:`pcnet.stages.opensim_ik.scale_and_ik` (the shipped Model_H36M17.osim = Pose2Sim's
  Model_Pose2Sim_simple, after Rajagopal et al. 2016; one scaled model per recording), its
  ``ik.mot``.

Recordings (per data set, one table each):
- demo: ``pcnet demo`` (bundled boxing clip, MotionBERT + AlphaPose, 3DPCNet, 1.75 m), its
  world.trc (its kinematics.csv ISB columns are checked against isb_joint_angles of the csv's
  own, 6 Hz filtered, positions; world.trc holds the unfiltered poses OpenSim fits);
- real MediaPipe (Pose2Sim's static trial, four calibrated cameras,
  ``real/pose2sim_gravity``): ``pcnet run --lifter mediapipe`` on each camera's stored
  landmarks, its world.trc (the metric lifter a clinic runs from a video; MediaPipe has no spine
  joint, so pcnet's trunk flexion to the pelvis is 0 and its hip flexion is the thigh relative
  to the trunk, docs/joint_angles.md);
- Bandai motion-style test clips and CMU validation subjects (12, 60): the held-out splits of
  benchmarks/world_kinematics.py (:func:`pcnet.models.datasets.select_split`, scheme
  "motion-style"), ``--clips`` clips per data set evenly spaced over the split, the first
  ``--max-frames`` frames of each, moved to the floor frame as benchmarks/opensim_ik.py does.
  Without ../shared/data: tests/fixtures/mocap_small.npz (Bandai) instead.

Pairs and the sign mapping applied (``pcnet ~= sign * OpenSim``; the sign is checked below on
the unscaled model itself, "model check"):

| angle | pcnet ISB column | OpenSim coordinate | sign mapping |
|---|---|---|---|
| hip flexion R/L | {right,left}_hip_flexion_deg | hip_flexion_{r,l} | +1 (flexion +) |
| hip adduction R/L | {side}_hip_adduction_deg | hip_adduction_{r,l} | +1 (adduction +, both sides) |
| hip rotation R/L | {side}_hip_internal_rotation_deg | hip_rotation_{r,l} | +1 (internal +) |
| knee flexion R/L | {side}_knee_flexion_deg | knee_angle_{r,l} | +1: this model's walker knee (Rajagopal) is positive in flexion, range 0..155 deg; gait2392-family models are negative in flexion (would be -1) |
| elbow flexion R/L | {side}_elbow_flexion_deg | elbow_flex_{r,l} | +1 |
| trunk flexion / pelvis | trunk_flexion_to_pelvis_deg | L5_S1_Flex_Ext | -1: the model's coordinate is a right-hand rotation about the pelvis Z, positive = extension |
| trunk lateral bending / pelvis | trunk_lateral_bending_to_pelvis_deg | L5_S1_Lat_Bending | +1 (to the right +) |
| trunk axial rotation / pelvis | trunk_axial_rotation_to_pelvis_deg | L5_S1_axial_rotation | +1 (thorax turned to the left +) |
| trunk flexion / gravity | trunk_flexion_to_gravity_deg | derived: torso body frame in ground (FK of ik.mot), pcnet's heading-frame Z-X'-Y'' | +1 |
| trunk lateral tilt / gravity | trunk_lateral_tilt_to_gravity_deg | derived, as above | +1 |
| shoulder plane of elevation R/L | {side}_shoulder_plane_of_elevation_deg | derived: humerus body frame in torso frame (FK), ISB Y-X'-Y'' as pcnet (left mirrored) | +1 |
| shoulder elevation R/L | {side}_shoulder_elevation_deg | derived, as above | +1 |
| shoulder axial rotation R/L | {side}_shoulder_axial_rotation_deg | derived, as above | +1 |
| thigh / thorax flexion R/L | {side}_hip_flexion_deg + trunk_flexion_to_pelvis_deg | hip_flexion_{r,l} - L5_S1_Flex_Ext | +1 (the sagittal angle both measure robustly: see below) |
| shoulder (raw coordinates) | - | arm_flex, arm_add, arm_rot | not compared: intrinsic Z-X'-Y'' Euler angles of the humerus in the torso with arm_add -90 deg = arm horizontal, not ISB Y-X'-Y''; no sign/offset map makes them equal, so the shoulder rows above re-decompose OpenSim's humerus-in-torso rotation the ISB way instead |

Statistics per data set, pooled over its recordings' frames where both angles are finite
(pcnet's NaN rules: hip rotation needs a knee bent >= 5 deg, shoulder plane/axial rotation an
elevation in 10..170 deg and an elbow bent >= 5 deg): d = pcnet - sign * OpenSim, taken as the
smallest signed difference modulo 360; MAE = mean |d|; bias = mean d; centred MAE = mean
|d - bias of its recording| (the bias removed per recording, since each recording has its own
scaled model and marker placement); r = Pearson correlation of pcnet and sign * OpenSim.

Why a constant offset is expected: the two zero poses differ. OpenSim's zero is the model's
neutral (segment body frames of the generic Rajagopal geometry, scaled; the four trunk/head
markers placed on the subject's static window), whereas pcnet's zero is "segment frames built
from joint centres coincide" (pelvis Y = pelvis -> spine, thorax Y = spine -> thorax, thigh
Y = knee -> hip, ...). E.g. the model's femur Y axis is not the hip-knee line (knee centre 8 mm
posterior of it, and the walker knee translates with flexion), the torso's Y is not the spine ->
thorax line of the placed markers, the elbow axis is turned 13 deg about the humerus Y. A constant offset is a definition difference, not
an error: the centred MAE and r measure whether both follow the same motion.

Why hip flexion and trunk flexion to the pelvis are not separately comparable (not a sign
issue): pcnet's pelvis Y is pelvis -> spine, and the H36M ``spine`` joint sits on OpenSim's
torso (lumbar region), not on its pelvis. On the model itself (model check) pcnet's hip flexion
is ~ hip_flexion - 0.47 * L5_S1_Flex_Ext and its trunk flexion ~ -0.54 * L5_S1_Flex_Ext; and
in the IK, OpenSim's pelvis tilt is weakly determined, because its only markers (pelvis, both
hips) lie on the hip axis: rotation about that axis is set only through the lumbar joint's
position. So the sagittal motion between thigh and thorax is split differently between "hip"
and "lumbar" (bow, squat, bend). Their sum, thigh relative to thorax (hip flexion + trunk
flexion to pelvis in pcnet; hip_flexion - L5_S1_Flex_Ext in OpenSim), is the same quantity in
both (model check: slope 1.00, residual 0.1 deg) and is reported as its own row.

Model check (no data, no IK): the unscaled model posed at random coordinate values within
its ranges, its 17 joint-centre markers (Markers_H36M17.xml) by forward kinematics, pcnet's
angles on them, and a least-squares line pcnet = slope * (sign * OpenSim) + offset per pair:
a slope of +1 confirms the sign mapping; a slope far from 1 or a large residual shows where the
joint-centre definition does not measure the model's coordinate.

Writes benchmarks/results/isb_opensim_agreement.txt with the command at the top.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.report import SHARED_DATA
import numpy as np
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "isb_opensim_agreement.txt"
FIXTURE = ROOT / "tests" / "fixtures" / "mocap_small.npz"

#: (angle, pcnet column, OpenSim coordinate or "derived:<key>", sign): pcnet ~= sign * OpenSim.
PAIRS: tuple[tuple[str, str, str, int], ...] = (
    *((f"hip flexion {s.upper()}", f"{side}_hip_flexion_deg", f"hip_flexion_{s}", 1) for side, s in (("right", "r"), ("left", "l"))),
    *((f"hip adduction {s.upper()}", f"{side}_hip_adduction_deg", f"hip_adduction_{s}", 1) for side, s in (("right", "r"), ("left", "l"))),
    *((f"hip rotation {s.upper()}", f"{side}_hip_internal_rotation_deg", f"hip_rotation_{s}", 1) for side, s in (("right", "r"), ("left", "l"))),
    *((f"knee flexion {s.upper()}", f"{side}_knee_flexion_deg", f"knee_angle_{s}", 1) for side, s in (("right", "r"), ("left", "l"))),
    *((f"elbow flexion {s.upper()}", f"{side}_elbow_flexion_deg", f"elbow_flex_{s}", 1) for side, s in (("right", "r"), ("left", "l"))),
    ("trunk flexion / pelvis", "trunk_flexion_to_pelvis_deg", "L5_S1_Flex_Ext", -1),
    ("trunk lateral bending / pelvis", "trunk_lateral_bending_to_pelvis_deg", "L5_S1_Lat_Bending", 1),
    ("trunk axial rotation / pelvis", "trunk_axial_rotation_to_pelvis_deg", "L5_S1_axial_rotation", 1),
    ("trunk flexion / gravity", "trunk_flexion_to_gravity_deg", "derived:torso_flexion_to_gravity", 1),
    ("trunk lateral tilt / gravity", "trunk_lateral_tilt_to_gravity_deg", "derived:torso_lateral_tilt_to_gravity", 1),
    *((f"shoulder plane of elevation {s.upper()}", f"{side}_shoulder_plane_of_elevation_deg", f"derived:plane_of_elevation_{s}", 1) for side, s in (("right", "r"), ("left", "l"))),
    *((f"shoulder elevation {s.upper()}", f"{side}_shoulder_elevation_deg", f"derived:elevation_{s}", 1) for side, s in (("right", "r"), ("left", "l"))),
    *((f"shoulder axial rotation {s.upper()}", f"{side}_shoulder_axial_rotation_deg", f"derived:axial_rotation_{s}", 1) for side, s in (("right", "r"), ("left", "l"))),
    *((f"thigh / thorax flexion {s.upper()} (hip + trunk flexion)", f"{side}_hip_flexion_deg + trunk_flexion_to_pelvis_deg",
       f"hip_flexion_{s} - L5_S1_Flex_Ext", 1) for side, s in (("right", "r"), ("left", "l"))),
)
NOT_COMPARED = ("shoulder (raw coordinates)", "-", "arm_flex, arm_add, arm_rot",
                "not comparable: Z-X'-Y'' Euler of humerus in torso (arm_add -90 = horizontal), not ISB Y-X'-Y''; see the derived rows")

#: Ranges (deg) of the random poses of the model check: (low, high) per unlocked coordinate.
CHECK_RANGES = {
    "hip_flexion": (-20, 70), "hip_adduction": (-25, 20), "hip_rotation": (-35, 30), "knee_angle": (10, 100),
    "L5_S1_Flex_Ext": (-25, 15), "L5_S1_Lat_Bending": (-20, 20), "L5_S1_axial_rotation": (-25, 25),
    "arm_flex": (-40, 80), "arm_add": (-80, -5), "arm_rot": (-40, 40), "elbow_flex": (15, 120),
    "pelvis_tilt": (-20, 20), "pelvis_list": (-15, 15), "pelvis_rotation": (-90, 90),
}
_MIRROR = np.diag([1.0, 1.0, -1.0])
_UP = np.array([0.0, 1.0, 0.0])


# ---------------------------------------------------------------- OpenSim-side derived angles

def _euler(R: np.ndarray, seq: str) -> np.ndarray:
    out = np.full(R.shape[:-2] + (3,), np.nan)
    ok = np.isfinite(R).all(axis=(-2, -1))
    if ok.any():
        out[ok] = Rotation.from_matrix(R[ok]).as_euler(seq, degrees=True)
    return out


def _wrap(deg: np.ndarray) -> np.ndarray:
    return (deg + 180.0) % 360.0 - 180.0


def derived_angles(torso: np.ndarray, humerus_r: np.ndarray, humerus_l: np.ndarray) -> dict[str, np.ndarray]:
    """The ISB-style angles pcnet reports, from OpenSim body frames (``(T, 3, 3)``, columns =
    body X, Y, Z in ground): trunk to gravity (torso in pcnet's heading frame, Z-X'-Y'') and
    the shoulder (humerus in torso, Y-X'-Y'', the left side mirrored), with pcnet's sign and
    range conventions and gimbal masks (10 deg)."""
    out: dict[str, np.ndarray] = {}
    z = torso[:, :, 2] - (torso[:, :, 2] @ _UP)[:, None] * _UP
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    up = np.broadcast_to(_UP, z.shape)
    heading = np.stack([np.cross(up, z), up, z], axis=-1)
    tg = _euler(np.einsum("tji,tjk->tik", heading, torso), "ZXY")
    lock = np.abs(tg[:, 1]) > 80.0
    out["torso_flexion_to_gravity"] = np.where(lock, np.nan, -tg[:, 0])
    out["torso_lateral_tilt_to_gravity"] = tg[:, 1]
    for s, hum in (("r", humerus_r), ("l", humerus_l)):
        rel = np.einsum("tji,tjk->tik", torso, hum)
        if s == "l":
            rel = _MIRROR @ rel @ _MIRROR
        sh = _euler(rel, "YXY")
        lock = (sh[:, 1] < 10.0) | (sh[:, 1] > 170.0)
        out[f"plane_of_elevation_{s}"] = np.where(lock, np.nan, _wrap(sh[:, 0] - 180.0))
        out[f"elevation_{s}"] = sh[:, 1]
        out[f"axial_rotation_{s}"] = np.where(lock, np.nan, _wrap(sh[:, 2] - 180.0))
    return out


class ModelPoser:
    """Forward kinematics of an OpenSim model: body frames and marker positions for given
    coordinate values (rotations in degrees, translations in metres, as in ik.mot)."""

    def __init__(self, osim, model_path: Path, marker_file: Path | None = None):
        self.model = osim.Model(str(model_path))
        if marker_file is not None:
            self.model.updateMarkerSet(osim.MarkerSet(str(marker_file)))
        self.state = self.model.initSystem()
        cs = self.model.getCoordinateSet()
        self.coords = {cs.get(i).getName(): cs.get(i) for i in range(cs.getSize())}
        self.rotational = {n: c.getMotionType() == 1 for n, c in self.coords.items()}  # 1 = Rotational
        self.unlocked = [n for n, c in self.coords.items() if not c.getDefaultLocked()]

    def set(self, values: dict[str, float]) -> None:
        for name in self.unlocked:
            c = self.coords[name]
            v = values.get(name, np.degrees(c.getDefaultValue()) if self.rotational[name] else c.getDefaultValue())
            c.setValue(self.state, float(np.radians(v)) if self.rotational[name] else float(v), False)
        self.model.realizePosition(self.state)

    def body_rotation(self, body: str) -> np.ndarray:
        R = self.model.getBodySet().get(body).getTransformInGround(self.state).R()
        return np.array([[R.get(i, j) for j in range(3)] for i in range(3)])

    def markers(self, names) -> np.ndarray:
        ms = self.model.getMarkerSet()
        return np.array([[ms.get(n).getLocationInGround(self.state).get(i) for i in range(3)] for n in names])


def read_mot(path: Path) -> dict[str, np.ndarray]:
    lines = Path(path).read_text().splitlines()
    end = next(i for i, line in enumerate(lines) if line.strip().lower() == "endheader")
    cols = [c.strip() for c in lines[end + 1].split("\t")]
    rows = np.array([[float(x) for x in line.split("\t")] for line in lines[end + 2:] if line.strip()])
    return {c: rows[:, i] for i, c in enumerate(cols)}


def opensim_angles(osim, model_path: Path, mot: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The OpenSim coordinates of ik.mot plus the derived angles (FK of the scaled model)."""
    poser = ModelPoser(osim, model_path)
    T = len(mot["time"])
    frames = {b: np.empty((T, 3, 3)) for b in ("torso", "humerus_r", "humerus_l")}
    for t in range(T):
        poser.set({n: mot[n][t] for n in poser.unlocked if n in mot})
        for b, arr in frames.items():
            arr[t] = poser.body_rotation(b)
    out = {k: v for k, v in mot.items() if k != "time"}
    out.update({f"derived:{k}": v for k, v in derived_angles(frames["torso"], frames["humerus_r"], frames["humerus_l"]).items()})
    return out


# ---------------------------------------------------------------- statistics

def _value(values: dict[str, np.ndarray], expr: str) -> np.ndarray:
    """A column, or a sum / difference of columns written "a + b" / "a - b"."""
    for op, f in ((" + ", np.add), (" - ", np.subtract)):
        if op in expr:
            left, right = expr.split(op, 1)
            return f(_value(values, left), _value(values, right))
    return np.asarray(values[expr], float)


def pair_values(pcnet: dict[str, np.ndarray], osim_vals: dict[str, np.ndarray], column: str, coord: str, sign: int):
    a = _value(pcnet, column)
    b = sign * _value(osim_vals, coord)
    ok = np.isfinite(a) & np.isfinite(b)
    return a[ok], b[ok]


def agreement(per_recording: list[tuple[np.ndarray, np.ndarray]]) -> dict[str, float]:
    """MAE, bias, centred MAE (bias removed per recording), Pearson r and frames, pooled."""
    d_all, dc_all, a_all, b_all = [], [], [], []
    for a, b in per_recording:
        if len(a) == 0:
            continue
        d = _wrap(a - b)
        d_all.append(d)
        dc_all.append(d - d.mean())
        a_all.append(a)
        b_all.append(a - d)  # b unwrapped onto a's branch
    n = int(sum(len(d) for d in d_all))
    if n == 0:
        return {"mae": np.nan, "bias": np.nan, "cmae": np.nan, "r": np.nan, "frames": 0}
    d, dc, a, b = (np.concatenate(x) for x in (d_all, dc_all, a_all, b_all))
    r = float(np.corrcoef(a, b)[0, 1]) if n > 2 and a.std() > 1e-9 and b.std() > 1e-9 else np.nan
    return {"mae": float(np.mean(np.abs(d))), "bias": float(np.mean(d)), "cmae": float(np.mean(np.abs(dc))),
            "r": r, "frames": n}


def table(rows: list[tuple[str, str, str, str, dict]]) -> list[str]:
    out = ["| angle | pcnet ISB name | OpenSim coordinate | sign mapping | MAE deg | bias deg | centred MAE deg | r | frames |",
           "|---|---|---|---|---:|---:|---:|---:|---:|"]
    for angle, col, coord, mapping, s in rows:
        if s is None or s["frames"] == 0:
            out.append(f"| {angle} | {col} | {coord} | {mapping} | - | - | - | - | 0 |")
            continue
        out.append(f"| {angle} | {col} | {coord} | {mapping} | {s['mae']:.1f} | {s['bias']:+.1f} | "
                   f"{s['cmae']:.1f} | {s['r']:.2f} | {s['frames']} |")
    return out


def mapping_text(coord: str, sign: int) -> str:
    name = coord.removeprefix("derived:")
    src = f"FK {name}" if coord.startswith("derived:") else name
    if " + " in src or " - " in src:
        src = f"({src})"
    return f"pcnet = {'+' if sign > 0 else '-'}{src}"


# ---------------------------------------------------------------- model check

def model_check_stats(osim, n_poses: int = 300, seed: int = 0) -> dict[str, dict[str, float]]:
    """pcnet angles on the unscaled model's joint-centre markers at random coordinates vs the
    coordinates, per pair (angle label): least-squares ``slope`` and ``offset`` of
    pcnet = slope * (sign * OpenSim) + offset, ``residual`` MAE (deg), ``r``, ``poses``."""
    from pcnet.stages.core.conventions import H36M_JOINTS
    from pcnet.stages.isb_angles import isb_joint_angles
    from pcnet.stages.opensim_ik import DATA_DIR, MARKER_FILE, MODEL_FILE

    poser = ModelPoser(osim, DATA_DIR / MODEL_FILE, DATA_DIR / MARKER_FILE)
    rng = np.random.default_rng(seed)
    X = np.empty((n_poses, 17, 3))
    values = {n: np.zeros(n_poses) for n in poser.unlocked}
    frames = {b: np.empty((n_poses, 3, 3)) for b in ("torso", "humerus_r", "humerus_l")}
    for t in range(n_poses):
        v = {}
        for name in poser.unlocked:
            key = name.removesuffix("_r").removesuffix("_l")
            if key in CHECK_RANGES:
                v[name] = rng.uniform(*CHECK_RANGES[key])
        poser.set(v)
        for name in poser.unlocked:
            c = poser.coords[name]
            values[name][t] = np.degrees(c.getValue(poser.state)) if poser.rotational[name] else c.getValue(poser.state)
        X[t] = poser.markers(H36M_JOINTS)
        for b, arr in frames.items():
            arr[t] = poser.body_rotation(b)
    pc = isb_joint_angles(X)
    ov = dict(values)
    ov.update({f"derived:{k}": v for k, v in derived_angles(frames["torso"], frames["humerus_r"], frames["humerus_l"]).items()})
    stats = {}
    for angle, col, coord, sign in PAIRS:
        a, b = pair_values(pc, ov, col, coord, sign)
        b = a - _wrap(a - b)
        st = {"slope": np.nan, "offset": np.nan, "residual": np.nan, "r": np.nan, "poses": len(a)}
        if len(a) > 2:
            slope, offset = np.polyfit(b, a, 1)
            st.update(slope=float(slope), offset=float(offset),
                      residual=float(np.mean(np.abs(a - (slope * b + offset)))), r=float(np.corrcoef(a, b)[0, 1]))
        stats[angle] = st
    return stats


def model_check(osim, n_poses: int = 300, seed: int = 0) -> list[str]:
    """The model check as text lines (:func:`model_check_stats`)."""
    stats = model_check_stats(osim, n_poses, seed)
    ranges = ", ".join(f"{k} {lo}..{hi}" for k, (lo, hi) in CHECK_RANGES.items())
    intro = (f"Model check: the unscaled Model_H36M17.osim at {n_poses} random poses (coordinates uniform in "
             f"{ranges} deg, left and right drawn independently), pcnet's angles on its 17 joint-centre markers; "
             "least squares pcnet = slope * (sign * OpenSim) + offset. No IK, no data: the exact relation between "
             "the two definitions.")
    lines = [intro, "",
             "| angle | sign mapping | slope | offset deg | residual MAE deg | r | poses |", "|---|---|---:|---:|---:|---:|---:|"]
    for angle, _, coord, sign in PAIRS:
        st = stats[angle]
        if st["poses"] > 2:
            lines.append(f"| {angle} | {mapping_text(coord, sign)} | {st['slope']:+.2f} | {st['offset']:+.1f} | "
                         f"{st['residual']:.1f} | {st['r']:.2f} | {st['poses']} |")
        else:
            lines.append(f"| {angle} | {mapping_text(coord, sign)} | - | - | - | - | {st['poses']} |")
    return lines


# ---------------------------------------------------------------- recordings

def to_floor_frame(joints: np.ndarray) -> np.ndarray:
    """As benchmarks/opensim_ik.py: pelvis of the first frame at x = z = 0, floor (5th
    percentile of the lowest joint centre) at y = 0."""
    out = joints.copy()
    out[..., 0] -= joints[0, 0, 0]
    out[..., 2] -= joints[0, 0, 2]
    out[..., 1] -= np.nanpercentile(np.nanmin(joints[..., 1], axis=1), 5)
    return out


def mocap_sets(data: Path, n_clips: int, max_frames: int) -> list[tuple[str, list[tuple[str, np.ndarray, float]]]]:
    from pcnet.models.datasets import load_mocap, select_split

    sets = []
    for label, file, split in (("Bandai motion-style test", "bandai_h36m17.npz", "test"),
                               ("CMU validation subjects 12, 60", "cmu_train_h36m17.npz", "val")):
        path = data / "mocap" / file
        if not path.is_file():
            continue
        clips = [c for c in select_split(load_mocap(path), split, "motion-style") if len(c.joints) >= 30]
        keep = np.unique(np.linspace(0, len(clips) - 1, min(n_clips, len(clips))).round().astype(int))
        sets.append((label, [(clips[i].name, np.asarray(clips[i].joints, float)[:max_frames], clips[i].fps) for i in keep]))
    if not sets:
        clips = load_mocap(FIXTURE)[:n_clips]
        sets.append(("fixture mocap_small (Bandai)", [(c.name, np.asarray(c.joints, float)[:max_frames], c.fps) for c in clips]))
    return sets


def mocap_trcs(data: Path, n_clips: int, max_frames: int, tmp: Path) -> list[tuple[str, list[tuple[str, Path]]]]:
    """:func:`mocap_sets` written as TRC files in ``tmp`` (floor frame, :func:`to_floor_frame`):
    ``[(label, [(clip name, trc path)])]``."""
    from pcnet.stages.sinks.exports import write_trc

    sets = []
    for label, clips in mocap_sets(data, n_clips, max_frames):
        recs = []
        for name, joints, fps in clips:
            path = tmp / f"{len(recs)}_{label.split()[0]}.trc"
            write_trc(path, to_floor_frame(joints), fps)
            recs.append((name, path))
        sets.append((label, recs))
    return sets


def run_demo(tmp: Path) -> tuple[Path, Path]:
    out = tmp / "demo"
    subprocess.run([sys.executable, "-m", "pcnet.pipeline.entry", "demo", "--out", str(out)],
                   check=True, capture_output=True, text=True)
    return out / "world.trc", out / "kinematics.csv"


def pose2sim_trcs(data: Path, tmp: Path) -> list[tuple[str, list[tuple[str, Path]]]]:
    """``pcnet run`` on each Pose2Sim camera's MediaPipe landmarks (with its video, for the
    frame rate and picture): ``[(label, [(camera, world.trc)])]``, empty where the data lacks
    them."""
    folder = data / "real" / "pose2sim_gravity"
    recs = []
    for npz in sorted(folder.glob("statictrial_cam*.npz")):
        out = tmp / f"pose2sim_{npz.stem}"
        subprocess.run([sys.executable, "-m", "pcnet.pipeline.entry", "run", "--lifter", "mediapipe",
                        "--lifter-output", str(npz), "--keypoints2d", str(npz), "--keypoints2d-format", "mediapipe",
                        "--video", str(npz.with_suffix(".mp4")), "--out", str(out), "--no-recording"],
                       check=True, capture_output=True, text=True)
        recs.append((npz.stem.removeprefix("statictrial_"), out / "world.trc"))
    return [("real MediaPipe (Pose2Sim static trial, four cameras: pcnet run --lifter mediapipe, world.trc)", recs)] \
        if recs else []


def compare_recording(osim, trc: Path, work: Path) -> tuple[dict, dict, dict]:
    """pcnet angles of the TRC's poses, OpenSim's (coordinates + derived) and scale_and_ik's result."""
    from pcnet.stages.core.conventions import H36M_JOINTS
    from pcnet.stages.isb_angles import isb_joint_angles
    from pcnet.stages.opensim_ik import read_trc, scale_and_ik

    _, markers, names, _ = read_trc(trc)
    poses = markers[:, [names.index(j) for j in H36M_JOINTS]]
    work.mkdir(parents=True, exist_ok=True)
    res = scale_and_ik(trc, work, None)
    mot = read_mot(Path(res["outputs"]["ik.mot"]))
    ov = opensim_angles(osim, Path(res["outputs"]["scaled_model.osim"]), mot)
    pc = isb_joint_angles(poses)
    if len(mot["time"]) != len(poses):
        raise RuntimeError(f"{trc}: ik.mot has {len(mot['time'])} frames, the TRC {len(poses)}")
    return pc, ov, res


def demo_csv_check(csv: Path, pc: dict[str, np.ndarray]) -> str:
    """kinematics.csv's ISB columns against isb_joint_angles of (a) the csv's own positions
    (6 Hz Butterworth-filtered, as stages/kinematics.py computes the angles) and (b) world.trc's
    unfiltered poses (``pc``, what OpenSim gets): the largest |difference| (deg) of each."""
    import csv as csvmod

    from pcnet.stages.core.conventions import H36M_JOINTS
    from pcnet.stages.isb_angles import isb_joint_angles

    with open(csv, newline="") as f:
        rows = list(csvmod.DictReader(f))

    def col(key: str) -> np.ndarray:
        return np.array([float(r[key]) if r[key] not in ("", "nan", "NaN") else np.nan for r in rows])

    filtered = np.stack([np.stack([col(f"{j}_{a}_m") for a in "xyz"], axis=-1) for j in H36M_JOINTS], axis=1)
    own = isb_joint_angles(filtered)
    worst, checked = {"own": 0.0, "trc": 0.0}, 0
    for name, trc_angle in pc.items():
        key = next((k for k in (name, name.removesuffix("_deg")) if k in rows[0]), None)
        if key is None:
            continue
        checked += 1
        c = col(key)
        for which, ref in (("own", own[name]), ("trc", trc_angle)):
            both = np.isfinite(c) & np.isfinite(ref)
            if both.any():
                worst[which] = max(worst[which], float(np.max(np.abs(_wrap(c[both] - ref[both])))))
    return (f"demo: kinematics.csv's {checked} ISB columns vs isb_joint_angles of the csv's own (6 Hz filtered) positions: "
            f"largest difference {worst['own']:.2g} deg; vs isb_joint_angles(world.trc) (unfiltered, what OpenSim "
            f"fits and what is compared below): {worst['trc']:.2g} deg (the filter)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(SHARED_DATA))
    ap.add_argument("--clips", type=int, default=8, help="clips per mocap data set, evenly spaced over its held-out split")
    ap.add_argument("--max-frames", type=int, default=300, help="first frames of each mocap clip")
    ap.add_argument("--no-demo", action="store_true")
    args = ap.parse_args()
    from pcnet.stages.opensim_ik import import_opensim

    t0 = time.perf_counter()
    osim = import_opensim()
    command = "python -m benchmarks.isb_opensim_agreement" + "".join(f" {a}" for a in sys.argv[1:])
    machine = (f"{os.cpu_count()} CPU cores ({platform.machine()}), Python {platform.python_version()}, "
               f"OpenSim {osim.__version__}; model stages/opensim_data/Model_H36M17.osim")
    doc = __doc__.split("Pairs and the sign mapping applied", 1)[1]
    lines = [f"    {command}", "", machine, "", "Pairs and the sign mapping applied" + doc.split("Writes benchmarks/")[0].rstrip(), ""]
    lines += model_check(osim) + [""]
    print("\n".join(lines), flush=True)

    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        sets: list[tuple[str, list[tuple[str, Path]]]] = []
        demo_note = ""
        if not args.no_demo:
            trc, csv = run_demo(tmp)
            sets.append(("demo (pcnet demo: boxing, MotionBERT + AlphaPose, 3DPCNet, world.trc)", [("demo", trc)]))
        sets += pose2sim_trcs(Path(args.data), tmp)
        sets += mocap_trcs(Path(args.data), args.clips, args.max_frames, tmp)
        for label, recs in sets:
            per_pair: dict[int, list] = {i: [] for i in range(len(PAIRS))}
            info, n_frames = [], 0
            for k, (name, trc) in enumerate(recs):
                pc, ov, res = compare_recording(osim, trc, tmp / f"ik_{label.split()[0]}_{k}")
                if name == "demo":
                    demo_note = demo_csv_check(csv, pc)
                for i, (_, col, coord, sign) in enumerate(PAIRS):
                    per_pair[i].append(pair_values(pc, ov, col, coord, sign))
                info.append(f"{name} ({res['frames']} frames, IK marker RMS {100 * res['marker_rms_m']:.1f} cm)")
                n_frames += res["frames"]
                print(f"  {label}: {info[-1]}", flush=True)
            rows = [(angle, col, coord, mapping_text(coord, sign), agreement(per_pair[i]))
                    for i, (angle, col, coord, sign) in enumerate(PAIRS)]
            rows.append((*NOT_COMPARED[:3], NOT_COMPARED[3], None))
            block = [f"## {label}: {len(recs)} recording(s), {n_frames} frames", "",
                     "Recordings: " + "; ".join(info), ""] + table(rows) + [""]
            if demo_note and label.startswith("demo"):
                block.insert(2, demo_note)
                block.insert(3, "")
            print("\n".join(block), flush=True)
            lines += block
    lines.append(f"Runtime: {time.perf_counter() - t0:.0f} s")
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text("\n".join(lines) + "\n")
    print(lines[-1])
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
