"""Tilt error against gravity read from the scene: two real videos, two real lifters, truth from vanishing points.

    python -m benchmarks.vanishing_gravity --data ../shared/data [--overlay DIR]

Why: pose2sim_gravity (benchmarks/gravity_benchmark.py) is the only recording with calibrated
gravity, one lab and one lifter. Man-made scenes carry their own gravity: vertical edges meet
in the vertical vanishing point, horizontal edges in vanishing points on the horizon. This
script reads the camera's true up from the line segments of benchmarks/vanishing_lines.json
(how they were found and chosen is written there) and scores pcnet on the lifter outputs of
the same videos:

- boxing (real/boxing_motionbert: MotionBERT on AlphaPose, 301 frames, static camera):
  up = the vertical vanishing point back-projected, ``u ~ K^-1 v`` (Hartley and Zisserman,
  Multiple View Geometry, 2nd ed., section 8.6.1); focal length from the vertical and the
  left wall's vanishing points, which belong to orthogonal directions:
  ``f^2 = -(v1 - p).(v2 - p)`` (ibid. section 8.8, calibration from orthogonal vanishing
  points; principal point p at the image centre, square pixels).
- sports2d (real/sports2d_demo: MediaPipe BlazePose, 230 frames, static camera): the camera
  is nearly level, so vertical edges are nearly parallel and their vanishing point is badly
  conditioned; up = the normal of the horizon line ``u ~ K^T l`` (ibid. section 8.6.2,
  vanishing lines), the horizon through the vanishing points of two horizontal directions
  (a building's facade and the box's louvres). No orthogonal pair fixes the focal length, so the truth is computed
  with the one `pcnet run` assumes for this file (a phone's 26 mm equivalent,
  stages/core/perspective.py) and its sensitivity to 0.7x and 1.4x that focal length is
  printed. Only the first 169 frames are scored: MediaPipe follows the man on the box until
  frame 170, where `pcnet run` flags a track switch.

Each vanishing point is the least-squares intersection of its segments' lines (the smallest
right singular vector of the stacked unit line vectors, weighted by segment length). The
truth's own uncertainty: 2000 bootstrap resamples of the segments of every group; printed
are the 95 % percentile intervals of its pitch and roll and the 95th percentile of the
resampled ups' angle from the estimate. Assumptions not checked here: no lens distortion,
principal point at the image centre, the chosen edges truly vertical or horizontal.

Rows per recording: the configurations of benchmarks/configurations.py on the poses read as
`pcnet run` reads them (the lifter's adapter -> H36M-17 -> pelvis-centred; sports2d also as
MediaPipe delivered them, without the turn into the real camera), and `pcnet run` itself with
its defaults (2D confidences, track segments, mode auto), whose 95 % pitch/roll intervals are
checked against the truth's point estimate. pitch = asin(-u_z) (positive: camera looking
down), roll = atan2(u_x, -u_y) (docs/CONVENTIONS.md, camera frame x right, y down, z forward).
A check, not a tuning set: two recordings, two gravity directions.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from benchmarks.configurations import CONFIGURATIONS, LABEL_WIDTH
from benchmarks.gravity_benchmark import deg_between, pitch_roll_deg
from benchmarks.real_intervals import check_run
from benchmarks.report import BOOTSTRAP, SHARED_DATA
from pcnet.adapters import load_mediapipe_3d
from pcnet.adapters.registry import get_3d_adapter
from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.io import lifter_joints
from pcnet.stages.core.conventions import root_relative
from pcnet.stages.core.perspective import focal_px_from_35mm
from pcnet.stages.core.rotations import normalize

HERE = Path(__file__).resolve().parent
DEFAULT = SHARED_DATA
LINES = HERE / "vanishing_lines.json"
RESULT = HERE / "results" / "vanishing_gravity.txt"
COMMAND = "python -m benchmarks.vanishing_gravity --data ../shared/data"
FOCAL_SENSITIVITY = (0.7, 1.4)

#: How `pcnet run` is called on each recording (paths under the data root) and which frames
#: the configuration rows score.
RECORDINGS = {
    "boxing": dict(
        run=dict(video="real/boxing_motionbert/boxing2.mp4", keypoints2d="real/boxing_motionbert/alphapose-results.json",
                 keypoints2d_format="alphapose", lifter="motionbert", lifter_output="real/boxing_motionbert/X3D.npy"),
        frames=slice(None), readings={"MotionBERT": {}},
        # the README's demo: MotionBERT's normalised units made metric by the subject's height
        also_run=({"height": 1.75},)),
    "sports2d": dict(
        run=dict(video="real/sports2d_demo/demo.mp4", keypoints2d="real/sports2d_demo/mediapipe_blazepose33.npz",
                 keypoints2d_format="mediapipe", lifter="mediapipe", lifter_output="real/sports2d_demo/mediapipe_blazepose33.npz"),
        frames=slice(0, 169),
        readings={"MediaPipe, turned into the real camera (pcnet run)": {},
                  "MediaPipe as delivered": {"real_camera": False}}),
}


def line_vectors(segments: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Homogeneous lines ``(N, 3)`` (unit norm) through ``(N, 4)`` pixel segments x1, y1, x2, y2,
    in coordinates centred on ``centre`` (px), and the segments' lengths ``(N,)`` px."""
    p1 = np.c_[segments[:, :2] - centre, np.ones(len(segments))]
    p2 = np.c_[segments[:, 2:] - centre, np.ones(len(segments))]
    lines = np.cross(p1, p2)
    return normalize(lines), np.linalg.norm(segments[:, 2:] - segments[:, :2], axis=1)


def vanishing_point(segments: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Least-squares common point ``(3,)`` (homogeneous, unit norm, centred pixel coordinates)
    of the lines through ``(N, 4)`` segments, each weighted by its length; may lie at infinity."""
    lines, length = line_vectors(segments, centre)
    return np.linalg.svd(lines * np.sqrt(length)[:, None])[2][-1]


def focal_from_orthogonal(v1: np.ndarray, v2: np.ndarray) -> float:
    """Focal length (px) from the vanishing points ``(3,)`` (centred) of two orthogonal
    directions, ``f^2 = -(v1 - p).(v2 - p)`` with p the principal point (the origin here);
    NaN when the points do not allow one (a point at infinity, or a non-negative product)."""
    if abs(v1[2]) < 1e-12 or abs(v2[2]) < 1e-12:
        return float("nan")
    product = float(np.dot(v1[:2] / v1[2], v2[:2] / v2[2]))
    return float(np.sqrt(-product)) if product < 0 else float("nan")


def up_towards_image_top(u: np.ndarray) -> np.ndarray:
    """``u`` or ``-u``, whichever points to the image's top (camera -y), as a unit vector."""
    u = normalize(np.asarray(u, np.float64))
    return -u if u[1] > 0 else u


def true_up(spec: dict, groups: dict[str, np.ndarray], centre: np.ndarray, focal: float | None) -> tuple[np.ndarray, float]:
    """``(up (3,) unit, camera frame; focal length px)`` from one recording's segment groups
    (module docstring); ``focal`` overrides the one the spec derives."""
    vps = {name: vanishing_point(seg, centre) for name, seg in groups.items()}
    if focal is None:
        focal = focal_from_orthogonal(*(vps[g] for g in spec["focal_from"]))
    K_inv_scale = np.array([1.0, 1.0, focal])
    if spec["up_from"] == "vertical":
        # K^-1 v with p at the origin is (x, y, w f) up to scale
        return up_towards_image_top(vps["vertical"] * K_inv_scale), focal
    a, b = (vps[g] for g in spec["horizon"])
    # K^T l with p at the origin is (l1 f, l2 f, l3) up to scale, i.e. (l1, l2, l3 / f)
    return up_towards_image_top(np.cross(a, b) / K_inv_scale), focal


def truth(spec: dict, default_focal: float | None, rng: np.random.Generator) -> dict:
    """Point estimate, bootstrap intervals and (without orthogonal pairs) focal sensitivity."""
    centre = np.array([spec["width"], spec["height"]], np.float64) / 2
    used = set([spec["up_from"]] if spec["up_from"] == "vertical" else spec["horizon"]) | set(spec["focal_from"] or ())
    # Sorted: a set's order follows Python's per-process string hashing, and the bootstrap
    # draws from the groups in this order.
    groups = {g: np.array(spec["groups"][g]["segments"], np.float64) for g in sorted(used)}
    focal = None if spec["focal_from"] else default_focal
    up, f = true_up(spec, groups, centre, focal)
    boot = []
    for _ in range(BOOTSTRAP):
        resampled = {g: s[rng.integers(0, len(s), len(s))] for g, s in groups.items()}
        boot.append(true_up(spec, resampled, centre, focal))
    ups = np.array([u for u, _ in boot])
    failed = int((~np.isfinite(ups).all(1)).sum())  # a resample whose vanishing points give no focal length
    ups = ups[np.isfinite(ups).all(1)]
    pr = np.array([pitch_roll_deg(u) for u in ups])
    out = {"up": up, "focal": f, "pitch_roll": pitch_roll_deg(up),
           "pitch_95": np.percentile(pr[:, 0], [2.5, 97.5]), "roll_95": np.percentile(pr[:, 1], [2.5, 97.5]),
           "cone_95": float(np.percentile(deg_between(ups, up[None]), 95)),
           "focal_95": np.nanpercentile([b for _, b in boot], [2.5, 97.5]), "failed": failed}
    if not spec["focal_from"]:
        out["sensitivity"] = {k: pitch_roll_deg(true_up(spec, groups, centre, k * f)[0]) for k in FOCAL_SENSITIVITY}
    if "vertical" in spec["groups"] and spec["up_from"] != "vertical":
        vertical = np.array(spec["groups"]["vertical"]["segments"], np.float64)
        out["vertical_check"] = lambda u: edge_residual_deg(vertical, u, f, centre)
    return out


def edge_residual_deg(segments: np.ndarray, up: np.ndarray, focal: float, centre: np.ndarray) -> float:
    """Median angle (deg) between ``(N, 4)`` pixel segments of vertical edges and the image
    lines an up direction ``(3,)`` predicts through their midpoints (towards its vanishing
    point ``K u``): how well those edges agree with that up."""
    vp = np.array([up[0] * focal, up[1] * focal, up[2]])
    mid = np.c_[(segments[:, :2] + segments[:, 2:]) / 2 - centre, np.ones(len(segments))]
    predicted = np.cross(mid, vp)[:, :2] @ np.array([[0.0, -1.0], [1.0, 0.0]])  # line normal -> direction
    d = segments[:, 2:] - segments[:, :2]
    cos = np.abs(np.sum(normalize(d) * normalize(predicted), axis=1))
    return float(np.median(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))))


def read_poses(data: Path, run: dict, options: dict) -> tuple[np.ndarray, float]:
    """The lifter output read as ``pcnet run`` reads it: adapter -> H36M-17 -> validated,
    pelvis filled from the hips, pelvis-centred; ``(joints (T, 17, 3) float64, fps)``."""
    path = data / run["lifter_output"]
    # the adapter's options are pcnet run's; the untouched MediaPipe reading is the loader's own
    poses = load_mediapipe_3d(path, **options) if "real_camera" in options else get_3d_adapter(run["lifter"]).load(path, **options)
    joints, _ = root_relative(lifter_joints(poses, str(path)))
    return joints, float(poses.fps or 30.0)


def config_rows(joints: np.ndarray, fps: float, up_true: np.ndarray) -> list[str]:
    """One line per configuration: valid frames, tilt error (deg), pitch, roll."""
    lines = []
    for config in CONFIGURATIONS:
        out = config.rectify(joints, fps)
        if config.mode == "frame":
            ups = out.up[out.valid]
            err = deg_between(ups, up_true[None])
            up = normalize(ups.mean(0))
            cell = f"{err.mean():7.1f}{np.percentile(err, 95):7.1f}"
        else:
            up = np.asarray(out.report.sequence.up, np.float64)
            cell = f"{deg_between(up, up_true):7.1f}{'-':>7}"
        p, r = pitch_roll_deg(up)
        lines.append(f"  {config.label:<{LABEL_WIDTH}}{int(out.valid.sum()):>4}/{len(joints):<4}{cell}{p:>7.1f}{r:>7.1f}")
    return lines


def pcnet_run_row(data: Path, run: dict, up_true: np.ndarray, **options) -> tuple[str, np.ndarray]:
    """`pcnet run` with its defaults (and ``options``) on the whole recording: its camera up
    against the truth (the line, and the up its summary's pitch and roll describe)."""
    cfg = RunConfig(**{k: str(data / v) if k in ("video", "keypoints2d", "lifter_output") else v
                       for k, v in run.items()}, **options)
    c = check_run(cfg, up_true)
    inside = "-" if not c.has_interval else ("yes" if c.holds else "NO")
    label = " ".join(["pcnet run", *(f"--{k} {v}" for k, v in options.items())])
    return (f"  {label:<{max(LABEL_WIDTH, len(label) + 1)}}mode {c.mode}: tilt error {c.tilt_error:.1f}, pitch "
            f"{c.pitch:+.1f} +- {c.pitch_half:.1f}, roll {c.roll:+.1f} +- {c.roll_half:.1f}; intervals contain the "
            f"truth: {inside}"), c.up


def overlay(data: Path, name: str, spec: dict, out_dir: Path) -> Path:
    """A PNG of the video's median frame with the chosen segments drawn per group (for checking)."""
    import cv2

    capture = cv2.VideoCapture(str(data / spec["video"]))
    frames = []
    ok, frame = capture.read()
    while ok:
        frames.append(frame)
        ok, frame = capture.read()
    image = np.median(np.array(frames[::5]), axis=0).astype(np.uint8)
    colours = ((0, 0, 255), (0, 200, 0), (255, 0, 0))
    for colour, group in zip(colours, spec["groups"].values()):
        for x1, y1, x2, y2 in group["segments"]:
            cv2.line(image, (round(x1), round(y1)), (round(x2), round(y2)), colour, 2)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{name}_lines.png"
    cv2.imwrite(str(path), image)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT, help="data root (default ../shared/data)")
    ap.add_argument("--out", type=Path, default=RESULT, help=f"where the report is written too (default {RESULT})")
    ap.add_argument("--overlay", type=Path, default=None, help="also write each video's chosen segments as a PNG here")
    args = ap.parse_args()
    spec_all = json.loads(LINES.read_text())
    missing = [n for n, r in RECORDINGS.items() if not (args.data / r["run"]["lifter_output"]).is_file()]
    if missing:
        sys.exit(f"vanishing_gravity: {', '.join(missing)}: lifter output not found under {args.data}; pass --data <data root>")
    rng = np.random.default_rng(0)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", ""]
    for name, rec in RECORDINGS.items():
        spec = spec_all[name]
        default_focal = focal_px_from_35mm(spec["width"], spec["height"])
        t = truth(spec, default_focal, rng)
        p, r = t["pitch_roll"]
        u = t["up"]
        lines.append(f"{name}: true up ({u[0]:+.3f}, {u[1]:+.3f}, {u[2]:+.3f}) from the {spec['up_from']} "
                     f"({', '.join(g['what'] for g in spec['groups'].values())})")
        focal_note = (f"focal {t['focal']:.0f} px [{t['focal_95'][0]:.0f}, {t['focal_95'][1]:.0f}] from the orthogonal "
                      f"{' and '.join(spec['focal_from'])} vanishing points" if spec["focal_from"]
                      else f"focal {t['focal']:.0f} px assumed (pcnet run's 26 mm equivalent)")
        failed = f", {t['failed']} of {BOOTSTRAP} resamples without a focal length" if t["failed"] else ""
        lines.append(f"  pitch {p:+.1f} [{t['pitch_95'][0]:+.1f}, {t['pitch_95'][1]:+.1f}], roll {r:+.1f} "
                     f"[{t['roll_95'][0]:+.1f}, {t['roll_95'][1]:+.1f}], 95 % cone {t['cone_95']:.1f} deg "
                     f"(segment bootstrap{failed}); {focal_note}")
        for k, (sp, sr) in t.get("sensitivity", {}).items():
            lines.append(f"  with {k:g} x the focal length: pitch {sp:+.1f}, roll {sr:+.1f}")
        check = t.get("vertical_check")
        if check:
            lines.append(f"  cross-check, the {len(spec['groups']['vertical']['segments'])} vertical edges: median "
                         f"{check(u):.2f} deg from the lines this up predicts (a level camera's up: {check(np.array([0.0, -1.0, 0.0])):.2f})")
        for reading, options in rec["readings"].items():
            joints, fps = read_poses(args.data, rec["run"], options)
            joints = joints[rec["frames"]]
            lines.append(f"  {reading}, {len(joints)} frames: {'method':<{LABEL_WIDTH - 2}}{'valid':>9}{'err':>7}"
                         f"{'p95':>7}{'pitch':>7}{'roll':>7}")
            lines += config_rows(joints, fps, u)
        row, run_up = pcnet_run_row(args.data, rec["run"], u)
        lines.append(row + (f"; its up puts the vertical edges {check(run_up):.2f} deg off" if check else ""))
        for options in rec.get("also_run", ()):
            lines.append(pcnet_run_row(args.data, rec["run"], u, **options)[0])
        if args.overlay:
            lines.append(f"  overlay: {overlay(args.data, name, spec, args.overlay)}")
        lines.append("")
    lines.append("err: tilt error (deg; frame modes: mean over valid frames, p95 its 95th percentile; sequence modes: "
                 "the one sequence up); pitch/roll of the estimate (frame modes: of the mean per-frame up).")
    text = "\n".join(lines) + "\n"
    print(text, end="")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)


if __name__ == "__main__":
    main()
