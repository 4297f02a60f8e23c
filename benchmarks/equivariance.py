"""Rotation equivariance on real poses: does the estimated up turn with the camera?

    python -m benchmarks.equivariance [--data ../shared/data] [--frames 300] [--out benchmarks/results/equivariance.txt]

A camera turned by Q about its centre sees the camera-frame poses X' = X @ Q.T, and the true up
turns with it (u' = Q u). An ideal estimator is equivariant: u'(X @ Q.T) = Q u(X). For every
clip, axis and angle, the "extra error" is the mean over frames (valid at 0 deg and at the angle)
of the angle between the up estimated from the rotated poses and Q times the up estimated at
0 deg (sequence modes: the one sequence up, so the mean is that single angle). It is 0 for an
equivariant method whatever its own error; it measures only what the camera's orientation adds.

Axes are the camera's: x = pitch (looking up/down), y = yaw (turning left/right, i.e. about the
image's vertical axis), z = roll about the optical axis (portrait/landscape/upside-down);
angles 0, 30, ..., 180 deg (pcnet.stages.core.rotations.axis_rotation, right-handed).

Clips (real, no ground truth needed): yoga_videopose3d Bhumi Tadasana / Padmasana / Bhujangasana /
Shavasana (VideoPose3D, metres, 30 fps assumed), boxing_motionbert/X3D.npy (MotionBERT,
normalised units, 30 fps), pose2sim_gravity/statictrial_cam01.npz (MediaPipe, 60 fps, 11 frames).
Each is read with its pcnet adapter and pelvis-centred; to bound the run time only the middle
`--frames` frames (default 300 = 10 s at 30 fps, consecutive, so sequence mode sees real motion)
are used.

Methods: geometric frame / sequence mode, pcnet frame / sequence mode.
Valid fraction: frames the method marks valid in the rotated view (flagged/invalid = the rest).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.configurations import CONFIGURATIONS, LABEL_WIDTH, Configuration
from benchmarks.gravity_benchmark import load_camera
from benchmarks.report import SHARED_DATA
from pcnet.adapters import load_motionbert, load_videopose3d
from pcnet.stages.core.conventions import root_relative
from pcnet.stages.core.rotations import angle_between, axis_rotation

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "equivariance.txt"
AXES = ("x", "y", "z")
AXIS_NAMES = {"x": "pitch", "y": "yaw", "z": "roll"}
ANGLES_DEG = (0, 30, 60, 90, 120, 150, 180)
# (label, method, mode)
CONFIGS = CONFIGURATIONS
YOGA = ("Bhumi_Tadasana", "Bhumi_Padmasana", "Bhumi_Bhujangasana", "Bhumi_Shavasana")


def middle(joints: np.ndarray, frames: int) -> np.ndarray:
    """The middle ``frames`` consecutive frames (all of them if there are fewer)."""
    start = max(0, (len(joints) - frames) // 2)
    return joints[start : start + frames]


def load_clips(data: Path, frames: int = 300) -> list[tuple[str, np.ndarray, float]]:
    """``[(name, pelvis-centred camera-frame joints (T, 17, 3), fps)]`` of the clips above."""
    real = data / "real"
    clips = []
    for name in YOGA:
        poses = load_videopose3d(real / "yoga_videopose3d" / f"export_{name}.npy")
        clips.append((f"yoga {name.replace('_', ' ')}", middle(root_relative(poses.joints)[0], frames), 30.0))
    poses = load_motionbert(real / "boxing_motionbert" / "X3D.npy")
    clips.append(("boxing MotionBERT", middle(root_relative(poses.joints)[0], frames), 30.0))
    joints, _, fps = load_camera(real / "pose2sim_gravity" / "statictrial_cam01.npz")
    clips.append(("pose2sim cam01", middle(joints, frames), fps))
    return clips


def rotate_view(joints: np.ndarray, axis: str, angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """``(X @ Q.T, Q)`` for the camera rotated by ``angle_deg`` about its ``axis``."""
    Q = axis_rotation(axis, np.radians(angle_deg))
    return joints @ Q.T, Q


def extra_error_deg(up0: np.ndarray, valid0: np.ndarray, up_rot: np.ndarray, valid_rot: np.ndarray,
                    Q: np.ndarray) -> float:
    """Mean over frames valid in both of the angle (deg) between ``up_rot`` ``(T, 3)`` and
    ``Q @ up0``; NaN when no frame is valid in both."""
    both = np.asarray(valid0, bool) & np.asarray(valid_rot, bool)
    if not both.any():
        return float("nan")
    return float(np.degrees(angle_between(up_rot[both], up0[both] @ Q.T)).mean())


def equivariance(joints: np.ndarray, fps: float, config: Configuration,
                 axes=AXES, angles=ANGLES_DEG) -> dict[tuple[str, int], tuple[float, float]]:
    """``{(axis, angle): (extra error deg, valid fraction)}`` for one clip and configuration."""
    base = config.rectify(joints, fps)
    out = {}
    for axis in axes:
        for angle in angles:
            X, Q = rotate_view(joints, axis, angle)
            res = base if angle == 0 else config.rectify(X, fps)
            out[(axis, angle)] = (extra_error_deg(base.up, base.valid, res.up, res.valid, Q), float(res.valid.mean()))
    return out


def run(data: Path, frames: int = 300) -> list[str]:
    clips = load_clips(data, frames)
    t0 = time.perf_counter()
    results = {(c.label, name): equivariance(J, fps, c) for name, J, fps in clips for c in CONFIGS}
    seconds = time.perf_counter() - t0
    lines = [__doc__.splitlines()[0], "",
             f"    python -m benchmarks.equivariance --data ../shared/data --frames {frames}", "",
             "Clips: " + "; ".join(f"{n} ({len(J)} frames, {fps:g} fps)" for n, J, fps in clips), ""]
    head = f"{'method':<{LABEL_WIDTH}}{'axis':<7}" + "".join(f"{a:>8}" for a in ANGLES_DEG)

    def table(title: str, cell):
        lines.extend([title, head])
        for c in CONFIGS:
            for axis in AXES:
                lines.append(f"{c.label:<{LABEL_WIDTH}}{AXIS_NAMES[axis]:<7}" + "".join(cell(c.label, axis, a) for a in ANGLES_DEG))
        lines.append("")

    def over_clips(label, axis, angle, i):
        return np.array([results[(label, n)][(axis, angle)][i] for n, _, _ in clips])

    table(f"Extra error (deg), mean over the {len(clips)} clips",
          lambda lab, ax, a: f"{np.nanmean(over_clips(lab, ax, a, 0)):>8.1f}")
    table("Extra error (deg), worst clip",
          lambda lab, ax, a: f"{np.nanmax(over_clips(lab, ax, a, 0)):>8.1f}")
    table("Valid fraction in the rotated view, lowest over clips (1 = no frame flagged)",
          lambda lab, ax, a: f"{np.min(over_clips(lab, ax, a, 1)):>8.2f}")
    lines.append("Per clip: extra error (deg) mean over the nonzero angles [worst angle] per axis")
    lines.append(f"{'clip':<26}{'method':<{LABEL_WIDTH}}" + "".join(f"{AXIS_NAMES[a]:>15}" for a in AXES))
    for name, _, _ in clips:
        for c in CONFIGS:
            r = results[(c.label, name)]
            cells = ""
            for axis in AXES:
                e = np.array([r[(axis, a)][0] for a in ANGLES_DEG if a != 0])
                cells += f"{np.nanmean(e):>8.1f} [{np.nanmax(e):>4.0f}]"
            lines.append(f"{name:<26}{c.label:<{LABEL_WIDTH}}{cells}")
    lines += ["", f"({seconds:.0f} s)"]
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DEFAULT), help="data root (default ../shared/data)")
    ap.add_argument("--frames", type=int, default=300, help="middle frames used per clip (default 300)")
    ap.add_argument("--out", default=str(RESULT), help="where the table is written too")
    args = ap.parse_args()
    data = Path(args.data)
    needed = [data / "real" / "yoga_videopose3d" / f"export_{n}.npy" for n in YOGA]
    needed += [data / "real" / "boxing_motionbert" / "X3D.npy", data / "real" / "pose2sim_gravity" / "statictrial_cam01.npz"]
    missing = [str(p) for p in needed if not p.exists()]
    if missing:
        sys.exit(f"equivariance: data not found ({missing[0]}{' and more' if len(missing) > 1 else ''}); "
                 "pass --data <data root>")
    if args.frames < 1:
        sys.exit("equivariance: --frames must be >= 1")
    text = "\n".join(line.rstrip() for line in run(data, args.frames)) + "\n"
    print(text, end="")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
