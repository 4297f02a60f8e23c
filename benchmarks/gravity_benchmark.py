"""Tilt error against a lab-calibrated gravity direction: real MediaPipe poses, 4 real cameras.

    python -m benchmarks.gravity_benchmark [--data ../shared/data] [--out benchmarks/results/gravity_benchmark.txt]

Data: real/pose2sim_gravity/statictrial_camXX.npz (Pose2Sim demo lab, 4 calibrated static
portrait cameras looking down 18-25 deg, 60 fps, one man standing still in a T-pose, 11 frames;
../shared/data/README.md section "real/pose2sim_gravity/"). Truth: `up_camera`, world up
(Qualisys +Z) in the camera's OpenCV frame, = R[:, 1] under docs/CONVENTIONS.md (R maps
canonical -> camera); its pitch = asin(-u_z) (positive = camera looking down) and roll =
atan2(u_x, -u_y) (pcnet.stages.core.rotations.decompose_camera_rotation).

Poses are read as `pcnet run --lifter mediapipe` reads them (pipeline/runner.py `_load_inputs`):
load_mediapipe_3d (which turns each frame from MediaPipe's virtual camera at the mid-hip into the
real camera with the file's calibrated K, adapters/mediapipe.py) -> pcnet.pipeline.io.lifter_joints
(H36M-17, validated) -> pcnet.stages.core.conventions.root_relative (pelvis from the hips, centred). `--as-delivered` reads the world
landmarks untouched instead (`load_mediapipe_3d(..., real_camera=False)`), `--focal-px F`
ignores the file's K and assumes F with the image centre (`pcnet run --focal-px`), and
`--assumed-focal` the default a recording without K gets (a phone's 26 mm equivalent).

Methods (rows): pcnet frame / sequence mode, the geometric baseline (paper 2.3) in frame and
sequence mode, and three trivial baselines: a level camera (up = -y) and MediaPipe's own trunk
(pelvis -> thorax = mid-hip -> mid-shoulder) as up, as read (`trunk (real cam)`) and as
MediaPipe delivered it (`trunk (delivered)`).

Columns: `err` = tilt error (angle between estimated and true up, deg): frame modes and the
trunk = mean over valid frames of the per-frame error (`max` = the worst frame); sequence modes
= the one sequence up. `pitch`/`roll` of the estimate (frame modes: of the normalised mean of
the per-frame ups). Sequence mode only: the report's 95 % moving-block-bootstrap cone
(`up_uncertainty_deg`, the resampling spread alone) and whether it contains the truth (`in`),
and the pitch/roll 95 % half-widths `pcnet run` prints (`camera_pitch/roll_interval_deg`:
the bootstrap's with the lifter's systematic error calibrated on held-out mocap, scaled by
the recording's evidence scale; stages/uncertainty.py) and whether both intervals contain the
true pitch and roll (`in`).

Orientation robustness: the same poses seen by the camera rolled about its optical axis by a
further 90, 180 and -90 deg (a phone held the other way: X' = X @ Qz.T, true up' = Qz @ up).
This rotates the lifter's 3D output; a real rolled video would also change what MediaPipe sees.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from benchmarks.configurations import CONFIGURATIONS, LABEL_WIDTH
from benchmarks.report import SHARED_DATA
from pcnet.adapters import load_mediapipe_3d
from pcnet.pipeline.io import lifter_joints
from pcnet.stages.core.conventions import PELVIS, THORAX, root_relative
from pcnet.stages.core.perspective import focal_px_from_35mm
from pcnet.stages.core.rotations import angle_between, axis_rotation, camera_pitch_roll, normalize

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "gravity_benchmark.txt"
COMMAND = "python -m benchmarks.gravity_benchmark --data ../shared/data"
FOLDER = ("real", "pose2sim_gravity")
ROLLS_DEG = (0, 90, 180, -90)
# (label, method, mode)
CONFIGS = CONFIGURATIONS
BASELINES = ("level camera (-y)", "trunk (real cam)", "trunk (delivered)")
IMAGE_UP = np.array([0.0, -1.0, 0.0])


def load_camera(path: str | Path, **options) -> tuple[np.ndarray, np.ndarray, float]:
    """``(joints (T, 17, 3) float64 pelvis-centred camera frame, true up (3,), fps)`` of one
    statictrial npz, read the way ``pcnet run --lifter mediapipe`` reads it (``options`` go to
    :func:`load_mediapipe_3d`: ``focal_px``, ``real_camera``)."""
    poses = load_mediapipe_3d(path, **options)
    joints, _ = root_relative(lifter_joints(poses, str(path)))
    with np.load(path) as f:
        up = np.asarray(f["up_camera"], np.float64)
    return joints, up / np.linalg.norm(up), float(poses.fps or 60.0)


def deg_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle in degrees between vectors ``(..., 3)`` (NaN stays NaN)."""
    return np.degrees(angle_between(np.asarray(u, np.float64), np.asarray(v, np.float64)))


def pitch_roll_deg(up: np.ndarray) -> tuple[float, float]:
    """Camera pitch and roll (degrees) of an up vector of any length:
    :func:`pcnet.stages.core.rotations.camera_pitch_roll` of its unit vector."""
    pitch, roll = np.degrees(camera_pitch_roll(normalize(np.asarray(up, np.float64))))
    return float(pitch), float(roll)


def trunk_directions(joints: np.ndarray) -> np.ndarray:
    """Unit pelvis -> thorax directions ``(T, 3)`` (NaN where missing)."""
    return normalize(joints[:, THORAX] - joints[:, PELVIS])


def roll_view(joints: np.ndarray, up: np.ndarray, roll_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The poses and the true up seen by the camera rolled about its optical (z) axis:
    ``X' = X @ Q.T``, ``up' = Q @ up`` with ``Q = axis_rotation("z", roll)``."""
    Q = axis_rotation("z", np.radians(roll_deg))
    return joints @ Q.T, Q @ up


def evaluate_view(joints: np.ndarray, up_true: np.ndarray, fps: float, delivered: np.ndarray) -> list[dict]:
    """Every method's and baseline's row for one camera view (see the module docstring);
    ``delivered``: the same poses as MediaPipe delivered them, for the last baseline."""
    rows = []
    T = len(joints)
    true_pitch, true_roll = pitch_roll_deg(up_true)
    for config in CONFIGS:
        out = config.rectify(joints, fps)
        rep = out.report.as_record()
        mode = config.mode
        row = {"method": config.label, "valid": int(out.valid.sum()), "frames": T}
        if mode == "frame":
            ups = out.up[out.valid]
            err = deg_between(ups, up_true[None])
            row.update(err=float(err.mean()) if len(err) else np.nan, max=float(err.max()) if len(err) else np.nan)
            mean_up = normalize(ups.mean(0)) if len(ups) else np.full(3, np.nan)
        else:
            mean_up = np.asarray(rep["up"], np.float64)
            err = float(deg_between(mean_up, up_true))
            row.update(err=err, max=err)
            cone = rep.get("up_uncertainty_deg", np.nan)
            dp, dr = rep.get("camera_pitch_interval_deg", np.nan), rep.get("camera_roll_interval_deg", np.nan)
            p, r = rep["camera_pitch_deg"], rep["camera_roll_deg"]
            droll = abs((r - true_roll + 180.0) % 360.0 - 180.0)
            row.update(cone=cone, in_cone=bool(err <= cone) if np.isfinite(cone) else None,
                       pr_halfwidth=(dp, dr),
                       in_pr=bool(abs(p - true_pitch) <= dp and droll <= dr) if np.isfinite(dp + dr) else None)
        row["pitch"], row["roll"] = pitch_roll_deg(mean_up)
        rows.append(row)
    level = float(deg_between(IMAGE_UP, up_true))
    p, r = pitch_roll_deg(IMAGE_UP)
    rows.append({"method": BASELINES[0], "valid": T, "frames": T, "err": level, "max": level,
                 "pitch": p, "roll": r})
    for label, poses in zip(BASELINES[1:], (joints, delivered)):
        trunk = trunk_directions(poses)
        ok = np.isfinite(trunk).all(1)
        err = deg_between(trunk[ok], up_true[None])
        p, r = pitch_roll_deg(normalize(trunk[ok].mean(0)))
        rows.append({"method": label, "valid": int(ok.sum()), "frames": T, "err": float(err.mean()),
                     "max": float(err.max()), "pitch": p, "roll": r})
    return rows


def _yn(v) -> str:
    return "-" if v is None else ("yes" if v else "NO")


def format_rows(camera: str, roll: int, up_true: np.ndarray, rows: list[dict]) -> list[str]:
    p, r = pitch_roll_deg(up_true)
    lines = [(f"{camera} + roll {roll:+d} deg: true up ({up_true[0]:+.3f}, {up_true[1]:+.3f}, {up_true[2]:+.3f}), "
              f"pitch {p:+.1f}, roll {r:+.1f}")]
    for row in rows:
        seq = "cone" in row
        cone = f"{row['cone']:6.2f} {_yn(row['in_cone']):>3}" if seq else f"{'-':>6} {'':>3}"
        calibrated = seq and np.isfinite(row["pr_halfwidth"]).all()  # the geometric baseline has none
        pr = (f"+-{row['pr_halfwidth'][0]:.2f}/{row['pr_halfwidth'][1]:.2f} {_yn(row['in_pr']):>3}" if calibrated
              else f"{'-':>13} {'':>3}")
        lines.append(f"  {row['method']:<{LABEL_WIDTH}}{row['valid']:>3}/{row['frames']:<3}{row['err']:>7.1f}{row['max']:>7.1f}"
                     f"{row['pitch']:>7.1f}{row['roll']:>8.1f}   {cone}  {pr:>17}")
    return lines


HEADER = (f"  {'method':<{LABEL_WIDTH}}{'valid':>7}{'err':>7}{'max':>7}{'pitch':>7}{'roll':>8}   {'cone95 in':>10}"
          f"  {'pitch/roll 95 in':>17}")


def run(data: Path, options: dict | None = None, command: str = COMMAND) -> list[str]:
    """The report's lines; ``options`` go to :func:`load_camera` (how the poses are read)."""
    folder = data.joinpath(*FOLDER)
    paths = sorted(folder.glob("statictrial_cam*.npz"))
    lines = [__doc__.splitlines()[0], "", f"    {command}", "",
             "Tilt error (deg) vs the calibrated up; see the script's docstring for every column.", "", HEADER]
    summary: dict[tuple[str, int], list[dict]] = {}
    for path in paths:
        joints, up, fps = load_camera(path, **(options or {}))
        delivered = load_camera(path, real_camera=False)[0]
        camera = path.stem.replace("statictrial_", "")
        for roll in ROLLS_DEG:
            J, u = roll_view(joints, up, roll)
            rows = evaluate_view(J, u, fps, roll_view(delivered, up, roll)[0])
            lines += format_rows(camera, roll, u, rows)
            for row in rows:
                summary.setdefault((row["method"], roll), []).append(row)
        lines.append("")
    lines.append(f"Summary over the {len(paths)} cameras: mean tilt error (deg) [worst camera]; "
                 "sequence modes: cameras whose 95 % cone / pitch-roll intervals contain the truth")
    labels = [c.label for c in CONFIGS] + list(BASELINES)
    lines.append(f"  {'method':<{LABEL_WIDTH}}" + "".join(f"{'roll ' + format(r, '+d'):>17}" for r in ROLLS_DEG)
                 + "   in cone / in pitch-roll (all rolls)")
    for label in labels:
        cells, cover = "", ""
        for roll in ROLLS_DEG:
            rs = summary[(label, roll)]
            e = np.array([x["err"] for x in rs])
            cells += f"{np.nanmean(e):>10.1f} [{np.nanmax(e):>4.1f}]"
        rs = [x for roll in ROLLS_DEG for x in summary[(label, roll)]]
        if "cone" in rs[0]:
            cover = (f"   {sum(bool(x['in_cone']) for x in rs)}/{len(rs)}"
                     f" / {sum(bool(x['in_pr']) for x in rs)}/{len(rs)}")
        lines.append(f"  {label:<{LABEL_WIDTH}}{cells}{cover}")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DEFAULT), help="data root (default ../shared/data)")
    ap.add_argument("--out", default=None, help=f"where the table is written too (default {RESULT}, "
                    "or beside it with the reading's name as a suffix)")
    how = ap.add_mutually_exclusive_group()
    how.add_argument("--as-delivered", action="store_true", help="MediaPipe's world landmarks untouched")
    how.add_argument("--focal-px", type=float, default=None, help="assume this focal length (px) instead of the file's K")
    how.add_argument("--assumed-focal", action="store_true",
                     help="assume the default a recording without K gets (a phone's 26 mm equivalent)")
    args = ap.parse_args()
    folder = Path(args.data).joinpath(*FOLDER)
    if not sorted(folder.glob("statictrial_cam*.npz")):
        sys.exit(f"gravity_benchmark: no statictrial_cam*.npz under {folder}; pass --data <data root>")
    options, suffix, command = {}, "", COMMAND
    if args.as_delivered:
        options, suffix, command = {"real_camera": False}, "_as_delivered", COMMAND + " --as-delivered"
    elif args.focal_px is not None:
        options, suffix, command = {"focal_px": args.focal_px}, f"_focal{args.focal_px:g}", f"{COMMAND} --focal-px {args.focal_px:g}"
    elif args.assumed_focal:
        with np.load(min(folder.glob("statictrial_cam*.npz"))) as f:
            width, height = float(f["width"]), float(f["height"])
        options = {"focal_px": focal_px_from_35mm(width, height)}
        suffix, command = "_assumed_focal", COMMAND + " --assumed-focal"
    out = args.out or str(RESULT.with_name(RESULT.stem + suffix + RESULT.suffix))
    text = "\n".join(line.rstrip() for line in run(Path(args.data), options, command)) + "\n"
    print(text, end="")
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(text)


if __name__ == "__main__":
    main()
