"""Joint angles with and without the network's residual, against mocap truth (decision 0100).

    python -m benchmarks.kinematics_residual --data ../shared/data --sets validation
    python -m benchmarks.kinematics_residual --data ../shared/data --sets heldout

In frame and smooth modes ``pcnet run`` computed the kinematics from the canonical poses
``(X - pelvis) @ R + residual``, the residual being 3DPCNet's non-rigid correction (paper
section 2.1.2); in sequence mode from the input turned rigidly into the world frame. This
script measures, per mode, the angles of ``Kinematics.angles`` (stages/kinematics.py: the ISB
joint angles, the unsigned segment-to-segment angles, the inclinations to gravity) of

- ``residual``: the canonical poses as the network gives them;
- ``rigid``: the same per-frame rotation of the same input, no residual,

against the same angles of the truth (the clean mocap in its true canonical frame), as the
mean absolute difference in degrees (wrapped modulo 360) over the frames where the rotation
is valid and the truth and both candidates are defined. One clip's score is the mean of its
angles' errors; ``residual - rigid`` per clip is bootstrapped over clips (the ablation's
paired verdict, benchmarks/ablation.py: "better" / "worse" for the residual, "same" within
0.05 deg or an interval that holds 0).

Recordings: the ablation's protocol (``benchmarks.ablation.static_camera_clips``: at most
``--max-clips`` clips per set, one static "paper" camera each, seed 0), with lifter-like
noise (models/lifter_noise.py, what the shipped weights trained on) and again with
frame-independent noise (``models.datasets.Noise``, which they did not), the rotations
through the shipped pair and the chain ``pcnet run`` uses (heading as
``resolve_heading_source("pcnet")``), modes ``frame`` and ``smooth``, no bootstrap.
``--sets validation``: the training mix's motion-style validation split (Bandai, CMU);
``--sets heldout``: the ablation's held-out mocap (Bandai motion-style test, CMU test
subjects, DeepMimic less the clips the shipped weights trained on). The lying rows pool the
frames whose true trunk (pelvis -> thorax) is more than ``LYING_TRUNK_DEG`` from vertical, one
score per clip with at least ``MIN_LYING_FRAMES`` of them.

The yoga rows (real VideoPose3D output, no truth): per asana, the files ``pcnet run``'s auto
mode reads as smooth (where the residual reached ``kinematics.csv``), the residual's size
(median and max over joints and frames, cm) and the mean absolute difference between the two
candidates' angles.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from benchmarks.ablation import (LYING_TRUNK_DEG, MOCAP_SETS, _Fixed, camera_view_joints, static_camera_clips,
                                 trained_clip_names, verdict)
from benchmarks.report import SHARED_DATA, print_and_save, require_folder
from benchmarks.world_kinematics import wrapped_diff
from pcnet.models.datasets import Noise, load_mocap, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.pipeline.rectification import make_estimator, resolve_heading_source
from pcnet.stages.core.canonical import to_canonical
from pcnet.stages.core.conventions import PELVIS, THORAX
from pcnet.stages.kinematics import compute_kinematics
from pcnet.stages.rectify import HeadingStep, Rectification, SequenceEvidence

RESULT_DIR = Path(__file__).resolve().parent / "results"
MODES = ("frame", "smooth")
NOISES = {"lifter noise": LifterNoise, "frame noise": Noise}
CANDIDATES = ("residual", "rigid")
MIN_LYING_FRAMES = 10
VALIDATION_SETS = (("Bandai motion-style validation", "bandai_h36m17.npz", "val"),
                   ("CMU validation subjects", "cmu_train_h36m17.npz", "val"))


def trunk_from_vertical_deg(poses: np.ndarray) -> np.ndarray:
    """``(T,)`` angle (deg) between the pelvis -> thorax line of Y-up poses ``(T, 17, 3)`` and +Y."""
    trunk = poses[:, THORAX] - poses[:, PELVIS]
    cos = trunk[:, 1] / np.linalg.norm(trunk, axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def clip_scores(X: np.ndarray, truth: np.ndarray, fps: float, estimator) -> dict:
    """One recording ``X`` ``(T, 17, 3)`` (camera frame, metres) against its truth ``(T, 17, 3)``
    (canonical frame): ``{mode: {"all" | "lying": {candidate: score or NaN}}}``, per angle group
    too (``{mode: {"groups": {group: {candidate: score}}}}``), and the residual's size."""
    estimate = estimator(X, fps)
    true_angles = compute_kinematics(truth, fps).angles
    lying = trunk_from_vertical_deg(truth) > LYING_TRUNK_DEG
    out = {}
    for mode in MODES:
        chain = Rectification(_Fixed(estimate), SequenceEvidence(mode, n_bootstrap=0),
                              HeadingStep(resolve_heading_source("pcnet", None)))
        rect = chain(X, fps)
        poses = {"residual": np.asarray(rect.canonical, np.float64), "rigid": to_canonical(X, rect.rotation)}
        angles = {c: compute_kinematics(p, fps, check_up=False).angles for c, p in poses.items()}
        errors = {c: [] for c in CANDIDATES}  # per angle: (T,) absolute errors, NaN where not compared
        names = []
        for name, t in true_angles.items():
            ok = rect.valid & np.isfinite(t) & np.isfinite(angles["residual"][name]) & np.isfinite(angles["rigid"][name])
            if not ok.any():
                continue
            names.append(name)
            for c in CANDIDATES:
                errors[c].append(np.where(ok, np.abs(wrapped_diff(angles[c][name], t)), np.nan))
        E = {c: np.array(errors[c]) for c in CANDIDATES}  # (angles, T)
        res = {}
        for subset, frames in (("all", np.ones(len(X), bool)), ("lying", lying)):
            enough = frames.sum() >= (1 if subset == "all" else MIN_LYING_FRAMES)
            res[subset] = {c: _score(E[c][:, frames]) if enough else np.nan for c in CANDIDATES}
        res["groups"] = {g: {c: _score(E[c][[group_of(n) == g for n in names]]) for c in CANDIDATES}
                         for g in GROUPS}
        size = np.linalg.norm(poses["residual"] - poses["rigid"], axis=-1)[rect.valid]
        res["residual_cm"] = 100 * np.nanmedian(size) if size.size else np.nan
        out[mode] = res
    out["lying_frames"] = int(lying.sum())
    return out


def _score(E: np.ndarray) -> float:
    """Mean over angles of each angle's mean error over its compared frames ``E`` ``(angles, T)``."""
    with np.errstate(all="ignore"):
        per_angle = np.nanmean(E, axis=1) if E.size else np.array([])
    per_angle = per_angle[np.isfinite(per_angle)]
    return float(per_angle.mean()) if per_angle.size else float("nan")


GROUPS = ("ISB joint", "unsigned", "inclination")


def group_of(name: str) -> str:
    if name.endswith("_inclination") or name.endswith("_to_gravity"):
        return "inclination"
    return "unsigned" if name.endswith("_unsigned") else "ISB joint"


def score_set(clips: list, max_clips: int, noise, estimator) -> list[dict]:
    out = []
    for clip, X, R, frames in static_camera_clips(clips, max_clips, noise=noise):
        if len(X) < 30:
            continue
        truth = to_canonical(camera_view_joints(clip, frames, R), R)
        scores = clip_scores(np.asarray(X, np.float64), truth, clip.fps, estimator)
        scores["name"] = clip.name
        out.append(scores)
    return out


def set_lines(title: str, scored: list[dict], subset: str = "all") -> list[str]:
    lines = []
    for mode in MODES:
        r = np.array([s[mode][subset]["residual"] for s in scored])
        g = np.array([s[mode][subset]["rigid"] for s in scored])
        keep = np.isfinite(r) & np.isfinite(g)
        if not keep.any():
            lines.append(f"| {title} | {mode} | 0 | - | - | - | - |")
            continue
        size = np.nanmedian([s[mode]["residual_cm"] for s in scored])
        lines.append(f"| {title} | {mode} | {keep.sum()} | {r[keep].mean():.2f} | {g[keep].mean():.2f} | "
                     f"{verdict('alternative', r[keep] - g[keep])} | {size:.1f} |")
    return lines


def group_lines(title: str, scored: list[dict]) -> list[str]:
    lines = []
    for mode in MODES:
        cells = []
        for grp in GROUPS:
            r = np.array([s[mode]["groups"][grp]["residual"] for s in scored])
            g = np.array([s[mode]["groups"][grp]["rigid"] for s in scored])
            k = np.isfinite(r) & np.isfinite(g)
            cells.append(f"{r[k].mean():.2f} / {g[k].mean():.2f}")
        lines.append(f"| {title} | {mode} | " + " | ".join(cells) + " |")
    return lines


def yoga_lines(data: Path, estimator) -> list[str]:
    from benchmarks.yoga_physics import FPS, parse_name

    from pcnet.adapters import load_videopose3d
    from pcnet.stages.core.conventions import root_relative

    rows = defaultdict(lambda: {"files": 0, "smooth": 0, "res": [], "res_max": [], "diff": []})
    for path in sorted((data / "real" / "yoga_videopose3d").glob("*.npy")):
        X, _ = root_relative(load_videopose3d(path).joints)
        X = np.asarray(X, np.float64)
        estimate = estimator(X, FPS)
        rect = Rectification(_Fixed(estimate), SequenceEvidence("auto", n_bootstrap=0),
                             HeadingStep(resolve_heading_source("pcnet", None)))(X, FPS)
        row = rows[parse_name(path)[1]]
        row["files"] += 1
        if rect.mode != "smooth":
            continue
        row["smooth"] += 1
        residual, rigid = np.asarray(rect.canonical, np.float64), to_canonical(X, rect.rotation)
        size = 100 * np.linalg.norm(residual - rigid, axis=-1)[rect.valid]
        row["res"].append(np.nanmedian(size))
        row["res_max"].append(np.nanmax(size))
        a = compute_kinematics(residual, FPS, check_up=False).angles
        b = compute_kinematics(rigid, FPS, check_up=False).angles
        d = [np.nanmean(np.abs(wrapped_diff(a[n], b[n]))[rect.valid]) for n in a
             if np.isfinite(a[n][rect.valid]).any() and np.isfinite(b[n][rect.valid]).any()]
        row["diff"].append(float(np.mean(d)))
    lines = ["| asana | files | read smooth by auto | residual median / max (cm) | angles: mean abs difference (deg) |",
             "|---|---:|---:|---:|---:|"]
    for asana, r in sorted(rows.items()):
        if r["smooth"]:
            lines.append(f"| {asana} | {r['files']} | {r['smooth']} | {np.median(r['res']):.1f} / "
                         f"{np.max(r['res_max']):.1f} | {np.mean(r['diff']):.1f} |")
        else:
            lines.append(f"| {asana} | {r['files']} | 0 | - | - |")
    return lines


def sets_arguments(argv, doc: str, name: str) -> tuple[argparse.Namespace, Path, list[tuple[str, list]]]:
    """The command line of a ``--sets validation|heldout`` script ``benchmarks.{name}`` (``--data``,
    ``--max-clips``, ``--out``, default ``results/{name}_{sets}.txt``), the output path and the
    sets' ``(title, clips)``: :data:`VALIDATION_SETS`, or the ablation's held-out
    :data:`benchmarks.ablation.MOCAP_SETS` less the clips the shipped weights trained on."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--sets", choices=("validation", "heldout"), required=True)
    ap.add_argument("--max-clips", type=int, default=200, help="per set, as benchmarks/ablation.py's")
    ap.add_argument("--out", type=Path, default=None, help=f"default results/{name}_{{sets}}.txt")
    args = ap.parse_args(argv)
    require_folder(args.data, f"benchmarks.{name}")
    out = args.out or RESULT_DIR / f"{name}_{args.sets}.txt"
    if args.sets == "validation":
        return args, out, [(t, select_split(load_mocap(args.data / "mocap" / f), s, "motion-style"))
                           for t, f, s in VALIDATION_SETS]
    trained = trained_clip_names()
    return args, out, [(t, [c for c in select_split(load_mocap(args.data / "mocap" / f), s, "motion-style")
                            if c.name not in trained]) for t, f, s in MOCAP_SETS]


def main(argv=None) -> None:
    args, out, sets = sets_arguments(argv, __doc__, "kinematics_residual")
    t0 = time.perf_counter()
    estimator = make_estimator("pcnet")
    lines = [__doc__.splitlines()[0], "",
             f"    python -m benchmarks.kinematics_residual --data {args.data} --sets {args.sets} "
             f"--max-clips {args.max_clips}", "",
             "Mean over clips of the clip's mean angle error (deg); verdict of residual - rigid per clip (paired bootstrap",
             "over clips, 95 %); residual = median over clips of the residual's median size per joint (cm).", "",
             "| set | mode | clips | residual | rigid | residual - rigid | residual (cm) |", "|---|---|---:|---:|---:|---|---:|"]
    groups = ["", "Per angle group, residual / rigid (mean over clips, deg):", "",
              "| set | mode | ISB joint | unsigned | inclination |", "|---|---|---|---|---|"]
    for noise_name, noise in NOISES.items():
        pooled = []
        for title, clips in sets:
            scored = score_set(clips, args.max_clips, noise(), estimator)
            pooled += scored
            label = f"{title}, {noise_name}"
            lines += set_lines(label, scored)
            groups += group_lines(label, scored)
            print(f"  {label}: {len(scored)} clips ({time.perf_counter() - t0:.0f} s)", flush=True)
        n_lying = sum(s["lying_frames"] for s in pooled)
        lines += set_lines(f"lying frames of the sets above ({n_lying} frames), {noise_name}", pooled, "lying")
    lines += groups
    if args.sets == "heldout":
        lines += ["", "Yoga (real VideoPose3D, no truth): the files auto mode reads as smooth:", ""]
        lines += yoga_lines(args.data, estimator)
    lines += ["", f"run time {time.perf_counter() - t0:.0f} s"]
    print_and_save(lines, out)


if __name__ == "__main__":
    main()
