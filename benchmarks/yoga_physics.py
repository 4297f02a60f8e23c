"""Physics checks on real VideoPose3D yoga output: is the canonical trunk where the asana puts it?

    python -m benchmarks.yoga_physics [--data ../shared/data] [--stride 2] [--out benchmarks/results/yoga_physics.txt]

Data: real/yoga_videopose3d/*.npy (90 real VideoPose3D exports, 18 people, camera frame x right /
y down / z forward, metres, root-relative; `export_<person>_<asana>.npy`, plus `demo.npy` whose
asana is not named). Two files repeat another's poses exactly (export_Santosh_Tadasana.mp4.npy =
export_Santosh_Tadasana.npy, demo.npy = export_Veena_Vrikshasana.npy): a file whose poses repeat
an `export_<person>_<asana>.npy` file is skipped (named below the table), leaving 88.
No ground truth; static cameras, 30 fps assumed (as benchmarks/real_up_spread.py).
Read with pcnet.adapters.load_videopose3d and pelvis-centred (what `pcnet run --lifter videopose3d` does).

Trunk angle from vertical: the angle between pelvis -> thorax (H36M joints 0 -> 8;
pcnet.stages.core.conventions PELVIS, THORAX) and up, per frame, then the median over the method's
valid frames. Up is canonical +Y for the rectified poses (`Rectified.canonical`, pcnet's residual
included) and image up (-y) for the camera-frame input itself (assumes a level camera). The
lower trunk is pelvis -> spine (0 -> 7).

Methods (columns): `input` (camera frame, image up = -y), geometric frame and sequence mode
(paper 2.3 baseline), pcnet frame / sequence mode.

Physical targets (trunk from vertical, per file): Shavasana (lying supine) >= 80 deg,
Padmasana (seated lotus) <= 15 deg, Tadasana (standing) <= 6 deg. Bhujangasana (prone cobra):
lower trunk near horizontal expected, reported without a target; Trikonasana and Vrikshasana
are reported without a target. A method with no valid frame in a file counts as n/a.
The geometric baseline's canonical +Y IS the trunk's long axis (torso plane, paper 2.3), so its
trunk angle is small by construction: it passes the upright targets and fails Shavasana whatever
the camera; read its column as a check of the metric, not as evidence about gravity.
`--stride k` keeps every k-th frame (fps / k) to save time: default 2 (15 fps, 58,176 frames,
about 3 min on 2 CPU cores); `--stride 1` (all 116,307 frames, about 5 min) gave the same
PASS/FAIL counts and per-asana medians within 0.1 deg, except geo seq on Trikonasana (trunk median
23.5 deg at stride 1 vs 32.7 at stride 2: the sequence up of a pose held off-vertical is fragile).
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.configurations import CONFIGURATIONS, LABEL_WIDTH
from benchmarks.report import SHARED_DATA
from pcnet.adapters import load_videopose3d
from pcnet.stages.core.conventions import PELVIS, SPINE, THORAX, root_relative
from pcnet.stages.core.rotations import angle_between

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "yoga_physics.txt"
FOLDER = ("real", "yoga_videopose3d")
FPS = 30.0
CANONICAL_UP = np.array([0.0, 1.0, 0.0])
IMAGE_UP = np.array([0.0, -1.0, 0.0])
# (label, method, mode); None = the camera-frame input itself
CONFIGS = (None, *CONFIGURATIONS)  # None: the camera-frame input itself ("input" column)
# asana -> (comparison, threshold deg) for the whole-trunk angle from vertical
TARGETS = {"Shavasana": (">=", 80.0), "Padmasana": ("<=", 15.0), "Tadasana": ("<=", 6.0)}
#: :func:`side_gap_deg`: a frame leans to a side beyond this (deg), and a file holds both sides
#: where each has this share of its frames. Definitions of the report's reading, not fitted:
#: they decide only which files the line counts.
SIDE_LEAN_DEG = 10.0
SIDE_SHARE = 0.1
SIDE_BENDS = ("Trikonasana",)
ASANA_ORDER = ("Tadasana", "Vrikshasana", "Trikonasana", "Padmasana", "Bhujangasana", "Shavasana", "demo")


def trunk_angles_deg(joints: np.ndarray, up: np.ndarray = CANONICAL_UP, lower: bool = False) -> np.ndarray:
    """Per-frame angle (deg) between pelvis -> thorax (``lower``: pelvis -> spine) of
    ``joints`` ``(T, 17, 3)`` and the unit ``up`` ``(3,)``; NaN where a joint is missing."""
    J = np.asarray(joints, np.float64)
    top = SPINE if lower else THORAX
    return np.degrees(angle_between(J[:, top] - J[:, PELVIS], np.broadcast_to(np.asarray(up, np.float64), J[:, 0].shape)))


def median_trunk_deg(joints: np.ndarray, valid: np.ndarray | None = None, up: np.ndarray = CANONICAL_UP,
                     lower: bool = False) -> float:
    """Median over ``valid`` frames (default: all) with a finite trunk of :func:`trunk_angles_deg`;
    NaN when there is none."""
    a = trunk_angles_deg(joints, up, lower)
    if valid is not None:
        a = a[np.asarray(valid, bool)]
    a = a[np.isfinite(a)]
    return float(np.median(a)) if len(a) else float("nan")


def side_gap_deg(joints: np.ndarray, valid: np.ndarray | None = None, camera_frame: bool = False) -> float:
    """How differently the two sides of a sideways bend read: the trunk's lean towards the
    subject's right (canonical: atan2 of pelvis -> thorax along +Z and +Y; ``camera_frame``:
    along image right +x and image up -y), per frame; where at least :data:`SIDE_SHARE` of the
    frames lean more than :data:`SIDE_LEAN_DEG` to each side, ``|median right lean - median
    left lean|`` (deg; a person bending alike both ways reads 0 under a static camera read
    right), else NaN (one side only). A wrong camera roll adds to one side's lean and takes
    from the other's: the gap is about twice the roll error."""
    J = np.asarray(joints, np.float64)
    trunk = J[:, THORAX] - J[:, PELVIS]
    if valid is not None:
        trunk = trunk[np.asarray(valid, bool)]
    side, up = (trunk[:, 0], -trunk[:, 1]) if camera_frame else (trunk[:, 2], trunk[:, 1])
    lean = np.degrees(np.arctan2(side, up))
    lean = lean[np.isfinite(lean)]
    right, left = lean[lean > SIDE_LEAN_DEG], -lean[lean < -SIDE_LEAN_DEG]
    if min(len(right), len(left)) < SIDE_SHARE * max(len(lean), 1):
        return float("nan")
    return float(abs(np.median(right) - np.median(left)))


def parse_name(path: Path) -> tuple[str, str]:
    """``(person, asana)`` from ``export_<person>_<asana>[.mp4].npy``; ``("-", stem)`` otherwise."""
    stem = path.name.removesuffix(".npy").removesuffix(".mp4")
    parts = stem.split("_")
    if len(parts) == 3 and parts[0] == "export":
        return parts[1], parts[2]
    return "-", stem


def plain_export(path: Path) -> bool:
    """Whether ``path`` is named exactly ``export_<person>_<asana>.npy``."""
    return path.name.count(".") == 1 and parse_name(path)[0] != "-"


def verdict(asana: str, angle: float) -> str | None:
    """``"PASS"``/``"FAIL"`` against :data:`TARGETS`, ``"n/a"`` for NaN, ``None`` without a target."""
    if asana not in TARGETS:
        return None
    if not np.isfinite(angle):
        return "n/a"
    op, thr = TARGETS[asana]
    return "PASS" if (angle >= thr if op == ">=" else angle <= thr) else "FAIL"


def evaluate_file(joints: np.ndarray, fps: float) -> dict[str, dict]:
    """``{label: {"trunk", "lower", "valid_frac"}}`` for every configuration."""
    out = {}
    for config in CONFIGS:
        if config is None:
            out["input"] = {"trunk": median_trunk_deg(joints, None, IMAGE_UP),
                            "lower": median_trunk_deg(joints, None, IMAGE_UP, lower=True), "valid_frac": 1.0,
                            "side_gap": side_gap_deg(joints, camera_frame=True)}
            continue
        res = config.rectify(joints, fps)
        out[config.label] = {"trunk": median_trunk_deg(res.canonical, res.valid),
                             "lower": median_trunk_deg(res.canonical, res.valid, lower=True),
                             "valid_frac": float(np.mean(res.valid)),
                             "side_gap": side_gap_deg(res.canonical, res.valid),
                             "pitch_half": (res.report.sequence.camera_pitch_interval_deg
                                            if res.report.sequence is not None else float("nan"))}
    return out


def _summary(lines: list[str], title: str, results: list[tuple[str, str, int, dict]], key: str) -> None:
    labels = ["input" if c is None else c.label for c in CONFIGS]
    lines += ["", title, f"{'asana':<13}{'n':>3}  " + "".join(f"{lab:>{LABEL_WIDTH}}" for lab in labels)]
    asanas = [a for a in ASANA_ORDER if any(r[1] == a for r in results)]
    asanas += sorted({r[1] for r in results} - set(asanas))
    for asana in asanas:
        rows = [r for r in results if r[1] == asana]
        cells = ""
        for lab in labels:
            v = np.array([r[3][lab][key] for r in rows])
            v = v[np.isfinite(v)]
            cell = f"{np.median(v):.1f} [{v.min():>3.0f},{v.max():>3.0f}]" if len(v) else "n/a"
            cells += f"{cell:>{LABEL_WIDTH}}"
        lines.append(f"{asana:<13}{len(rows):>3}  {cells}")


def run(data: Path, stride: int = 2) -> list[str]:
    # Named exports first, so that a duplicate is dropped under its less informative name.
    paths = sorted(data.joinpath(*FOLDER).glob("*.npy"), key=lambda p: (not plain_export(p), p.name))
    labels = ["input" if c is None else c.label for c in CONFIGS]
    cmd = f"python -m benchmarks.yoga_physics --data ../shared/data --stride {stride}"
    lines = [__doc__.splitlines()[0], "", f"    {cmd}", "",
             (f"{len(paths)} files (repeats skipped, see below), {FPS:g} fps / stride {stride}. Median trunk angle "
              "from vertical (deg) per file; `*` = under half of the frames valid for that method."),
             ("Targets: " + ", ".join(f"{a} {op} {t:g}" for a, (op, t) in TARGETS.items()) + ". "
              "geo: +Y is the trunk axis by construction (small angles whatever the pose)."), "",
             f"{'file (person asana)':<28}{'frames':>7}" + "".join(f"{lab:>{LABEL_WIDTH}}" for lab in labels)]
    results, seen, skipped = [], {}, []
    t0 = time.perf_counter()
    for path in paths:
        person, asana = parse_name(path)
        poses = load_videopose3d(path)
        digest = hashlib.sha1(np.ascontiguousarray(poses.joints).tobytes()).hexdigest()
        if digest in seen:
            skipped.append(f"{path.name} (= {seen[digest]})")
            continue
        seen[digest] = path.name
        joints, _ = root_relative(poses.joints[::stride])
        res = evaluate_file(joints, FPS / stride)
        results.append((person, asana, len(joints), res))
        cells = "".join(f"{res[lab]['trunk']:>{LABEL_WIDTH - 1}.1f}{'*' if res[lab]['valid_frac'] < 0.5 else ' '}"
                        for lab in labels)
        lines.append(f"{(person + ' ' + asana)[:27]:<28}{len(joints):>7}{cells}")
    seconds = time.perf_counter() - t0
    if skipped:
        lines.append("skipped, same poses as an earlier file: " + ", ".join(skipped))
    _summary(lines, "Per asana, trunk from vertical: median [min, max] over files (deg)", results, "trunk")
    _summary(lines, "Per asana, lower trunk (pelvis -> spine) from vertical: median [min, max] over files (deg)",
             results, "lower")
    default = CONFIGURATIONS[-1].label
    lines += ["", f"Per asana, {default} (the default): the printed 95 % camera pitch half-width (deg; the up "
              "model's posterior), median [min, max] over files"]
    for asana in [a for a in ASANA_ORDER if any(r[1] == a for r in results)]:
        rows = [r[3][default] for r in results if r[1] == asana]
        v = np.array([row["pitch_half"] for row in rows], np.float64)
        v = v[np.isfinite(v)]
        cell = f"{np.median(v):.1f} [{v.min():.1f}, {v.max():.1f}]" if len(v) else "n/a"
        lines.append(f"{asana:<13}{len(rows):>3}  pitch +- {cell}")
    lines += ["", (f"Sideways bends to both sides in one file ({', '.join(SIDE_BENDS)}): the two sides' trunk lean "
                   f"differs by |median right - median left| (deg; about twice the camera roll error, 0 for a person "
                   f"bending alike both ways), median [min, max] over the files with both sides (n of them)"),
              f"{'asana':<13}{'':>3}  " + "".join(f"{lab:>{LABEL_WIDTH}}" for lab in labels)]
    for asana in SIDE_BENDS:
        cells = ""
        for lab in labels:
            v = np.array([r[3][lab]["side_gap"] for r in results if r[1] == asana], np.float64)
            v = v[np.isfinite(v)]
            cell = f"{np.median(v):.0f} [{v.min():.0f},{v.max():.0f}] {len(v)}" if len(v) else "n/a"
            cells += f"{cell:>{LABEL_WIDTH}}"
        lines.append(f"{asana:<13}{'':>3}  {cells}")
    lines += ["", "Physics targets, files PASS / FAIL (n/a = no valid frame)",
              f"{'asana':<13}{'target':>9}  " + "".join(f"{lab:>{LABEL_WIDTH}}" for lab in labels)]
    for asana, (op, thr) in TARGETS.items():
        rows = [r for r in results if r[1] == asana]
        cells = ""
        for lab in labels:
            v = [verdict(asana, r[3][lab]["trunk"]) for r in rows]
            na = v.count("n/a")
            cell = f"{v.count('PASS')} / {v.count('FAIL'):<2}" + (f"+{na}na" if na else "   ")
            cells += f"{cell:>{LABEL_WIDTH}}"
        lines.append(f"{asana:<13}{op + ' ' + format(thr, 'g'):>9}  {cells}")
    lines += ["", f"({len(results)} distinct files, {sum(r[2] for r in results)} frames, {seconds:.0f} s)"]
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DEFAULT), help="data root (default ../shared/data)")
    ap.add_argument("--stride", type=int, default=2, help="keep every k-th frame (fps / k); default 2")
    ap.add_argument("--out", default=str(RESULT), help="where the table is written too")
    args = ap.parse_args()
    if args.stride < 1:
        sys.exit("yoga_physics: --stride must be >= 1")
    folder = Path(args.data).joinpath(*FOLDER)
    if not sorted(folder.glob("*.npy")):
        sys.exit(f"yoga_physics: no .npy files under {folder}; pass --data <data root>")
    text = "\n".join(line.rstrip() for line in run(Path(args.data), args.stride)) + "\n"
    print(text, end="")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
