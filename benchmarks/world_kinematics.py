"""Kinematics in one fixed world frame vs the per-frame canonical frame, against mocap truth.

    python -m benchmarks.world_kinematics --data ../shared/data [--max-clips 120]

Held-out mocap (Bandai motion-style test clips, CMU validation subjects 12 and 60; metres,
their own fps) seen by one static camera per clip ("paper" views,
`make_pairs(camera="static")`) with lifter-like noise (models/lifter_noise.py), rectified as
`pcnet run` does for a static camera (the shipped pair, sequence mode, camera prior, heading
auto; no bootstrap). Then the same kinematics code (stages/kinematics.py, Butterworth 6 Hz)
on:
- world (what pcnet writes now): the noisy poses in the recording's world frame
  (stages/world_frame.py, from the estimated rotations);
- canonical (what pcnet wrote before): the noisy poses in the per-frame canonical frame;
- truth: the mocap's own trajectories (true vertical pelvis motion, incl. flight phases; the
  horizontal root path removed, as no root-relative lifter has it; heights above the mocap's
  own ground, y = 0, as pcnet's world frame puts its floor under the ankle centres, not at
  them) turned into the world frame built from the true rotations.
Errors over the valid frames with finite values, per joint group: position (world only;
the canonical frame has no floor), speed |v| and acceleration magnitude |a| (scalar, so a
constant heading offset between the estimated and the true world frame does not count),
and velocity as a vector (frame-dependent: includes that heading offset).

Angles (``--angles-out``, default results/world_kinematics_angles.txt): every angle of
``Kinematics.angles`` (the ISB joint angles of stages/isb_angles.py and the segment
inclinations of stages/kinematics.py), world and canonical, against the same angle of the
truth, as the mean absolute difference in degrees over the valid frames where both are
defined; every difference is taken as the smallest signed one modulo 360 (a no-op for
angles whose range is at most 180 deg wide; it matters for Euler first/third angles and
plane angles, e.g. axial rotations, the plane of elevation, limb plane angles in
(-90, 270]). Angles between two segments do not depend on the frame (world and canonical
differ only by the canonical residual and by filtering in a rotating frame); inclinations
to gravity depend on the estimated up direction.

Angle rates (the same file, ``kinematics.csv``'s ``*_deg_per_s``,
``Kinematics.angle_rates``): per angle, world against the truth's rate, the mean absolute
difference in deg/s over the valid frames where both are defined, beside the truth's own
mean absolute rate (the scale an error compares with), and each clip's peak absolute rate
against the truth's (median over clips of the ratio, clips whose true peak is at least
30 deg/s): how far a peak angular velocity read from the table can be trusted.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA
from pcnet.models.datasets import load_mocap, make_pairs, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.core.canonical import canonical_rotation, to_canonical
from pcnet.stages.core.conventions import H36M_JOINTS, PELVIS
from pcnet.stages.kinematics import compute_kinematics
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.rectify import HeadingStep, Rectification, SequenceEvidence
from pcnet.stages.world_frame import to_world, world_frame

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "world_kinematics.txt"
ANGLES_RESULT = RESULT.with_name("world_kinematics_angles.txt")
GROUPS = {"wrists": ("left_wrist", "right_wrist"), "ankles": ("left_ankle", "right_ankle"),
          "head": ("head",), "all 17 joints": tuple(H36M_JOINTS)}


def true_world(mocap: np.ndarray, R_true: np.ndarray, fps: float) -> np.ndarray:
    """The mocap poses ``(T, 17, 3)`` (world, Y up, metres) in the world frame pcnet would
    build from the true rotations, keeping their true heights (module docstring)."""
    R_world, _ = canonical_rotation(mocap, (0.0, 1.0, 0.0))
    to_camera = R_true[0] @ R_world[0].T  # the static camera's world->camera rotation
    W = world_frame(R_true, np.ones(len(R_true), bool), fps).rotation
    rooted = mocap - np.stack([mocap[:, PELVIS, 0], np.zeros(len(mocap)), mocap[:, PELVIS, 2]], -1)[:, None]
    return rooted @ (W @ to_camera).T


def clip_errors(inputs, R_true, mocap, fps) -> tuple[dict[str, dict[str, np.ndarray]], dict]:
    """Per-frame, per-joint absolute errors ``{frame_kind: {quantity: (T, 17)}}`` for one clip,
    and its angles ``{"truth" | "world" | "canonical" | "world_true_rotation" |
    "canonical_no_residual": {name: (T,)}, "valid": (T,), "up_error_deg": float}``."""
    chain = Rectification(make_estimator("pcnet"), SequenceEvidence("sequence", n_bootstrap=0), HeadingStep("auto"))
    rectified = chain(inputs, fps)
    R_hat, valid = rectified.rotation, rectified.valid
    truth = compute_kinematics(true_world(mocap, R_true, fps), fps)
    frame = world_frame(R_hat, valid, fps)
    world = compute_kinematics(to_world(inputs, frame), fps, check_up=False)
    canonical = compute_kinematics(rectified.canonical, fps, check_up=False)
    out = {}
    for kind, k in (("world", world), ("canonical", canonical)):
        e = {"speed": np.abs(k.speed - truth.speed),
             "|a|": np.abs(np.linalg.norm(k.acceleration, axis=-1) - np.linalg.norm(truth.acceleration, axis=-1)),
             "velocity vector": np.linalg.norm(k.velocity - truth.velocity, axis=-1)}
        if kind == "world":
            e["position"] = np.linalg.norm(k.positions - truth.positions, axis=-1)
        out[kind] = {q: np.where(valid[:, None], v, np.nan) for q, v in e.items()}
    # Diagnostics for the angles only: the noisy poses in the world frame built from the true
    # camera rotations (the true camera up; not an oracle for the noisy poses, whose lifter
    # noise leans them per clip), and the canonical poses without the network's residual (a
    # pure per-frame rotation of the same poses).
    true_frame = world_frame(R_true, np.ones(len(R_true), bool), fps)
    world_true = compute_kinematics(to_world(inputs, true_frame), fps)
    canonical_rigid = compute_kinematics(to_canonical(inputs, R_hat), fps, check_up=False)
    angles = {kind: dict(k.angles) for kind, k in (
        ("truth", truth), ("world", world), ("canonical", canonical),
        ("world_true_rotation", world_true), ("canonical_no_residual", canonical_rigid))}
    angles["truth_rate"], angles["world_rate"] = dict(truth.angle_rates), dict(world.angle_rates)
    angles["valid"] = np.asarray(valid, bool)
    # Angle between the estimated up and the true camera's up (camera coordinates).
    angles["up_error_deg"] = float(np.degrees(np.arccos(np.clip(frame.rotation[1] @ true_frame.rotation[1], -1.0, 1.0))))
    return out, angles


def angle_group(name: str) -> str:
    """Which table group an angle of ``Kinematics.angles`` belongs to."""
    if name.endswith("_inclination") or name.endswith("_to_gravity"):
        return "inclination to gravity (depends on the up estimate)"
    if name.endswith("_unsigned"):
        return "segment to segment, unsigned (stages/kinematics.py)"
    return "ISB joint angle, segment to segment (stages/isb_angles.py)"


GROUP_ORDER = ("ISB joint angle, segment to segment (stages/isb_angles.py)",
               "segment to segment, unsigned (stages/kinematics.py)",
               "inclination to gravity (depends on the up estimate)")


def wrapped_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smallest signed difference ``a - b`` modulo 360, in [-180, 180) degrees."""
    return (a - b + 180.0) % 360.0 - 180.0


def angle_rows(acc: dict) -> list[dict]:
    """Per angle: MAE world / canonical vs truth, world vs canonical, defined fractions."""
    valid = np.concatenate(acc["valid"])
    truth = {n: np.concatenate(v) for n, v in acc["truth"].items()}
    rows = []
    for name in truth:
        t = truth[name]
        est = {kind: np.concatenate(acc[kind][name]) for kind in ("world", "canonical")}
        est["world_true_rotation"] = np.concatenate(acc["world_true_rotation"][name])
        row = {"name": name, "group": angle_group(name), "frames": len(t),
               "truth_defined": np.mean(valid & np.isfinite(t))}
        for kind, e in est.items():
            ok = valid & np.isfinite(e) & np.isfinite(t)
            raw = e[ok] - t[ok]
            d = np.abs(wrapped_diff(e[ok], t[ok]))
            row[kind] = d.mean() if ok.any() else np.nan
            row[kind + "_defined"] = ok.mean()
            row[kind + "_wrapped"] = int((np.abs(raw) > 180.0).sum())
        for key, other in (("world_vs_canonical", "canonical"), ("world_vs_rigid", "canonical_no_residual")):
            o = np.concatenate(acc[other][name])
            ok = valid & np.isfinite(est["world"]) & np.isfinite(o)
            row[key] = np.abs(wrapped_diff(est["world"][ok], o[ok])).mean()
        rows.append(row)
    return rows


#: A clip's true peak rate below this (deg/s) is no peak to compare: the angle barely moves.
PEAK_FLOOR_DEG_S = 30.0


def _peak(rate: np.ndarray, valid: np.ndarray) -> float:
    """Largest absolute rate over the valid frames with one; NaN without any."""
    r = np.abs(rate[valid & np.isfinite(rate)])
    return float(r.max()) if len(r) else float("nan")


def rate_table(label: str, short_label: str, acc: dict) -> list[str]:
    """Markdown table of the angle rates' errors (module docstring) for one data set."""
    lines = [f"{label}: angle rates (deg/s) against the truth's, over the valid frames where both are defined;",
             "  truth |rate| = the truth's mean absolute rate; MAE = mean absolute error of pcnet's (world);",
             f"  peak ratio = median over clips of pcnet's peak |rate| / the truth's (clips whose true peak >= "
             f"{PEAK_FLOOR_DEG_S:.0f} deg/s).", "",
             "| data | group | angle | truth mean abs rate | MAE | peak ratio | clips |", "|---|---|---|---:|---:|---:|---:|"]
    short = {GROUP_ORDER[0]: "ISB joint", GROUP_ORDER[1]: "seg-to-seg unsigned", GROUP_ORDER[2]: "inclination"}
    rows = []
    for name in acc["truth_rate"]:
        truth, est, valid = acc["truth_rate"][name], acc["world_rate"][name], acc["valid"]
        t, e, ok = (np.concatenate(x) for x in (truth, est, valid))
        ok = ok & np.isfinite(t) & np.isfinite(e)
        if not ok.any():  # the truth never defines it
            continue
        peaks = [(_peak(a, v), _peak(b, v)) for a, b, v in zip(truth, est, valid)]
        ratios = [b / a for a, b in peaks if a >= PEAK_FLOOR_DEG_S and np.isfinite(b)]
        rows.append((angle_group(name), name, np.abs(t[ok]).mean(), np.abs(e[ok] - t[ok]).mean(),
                     np.median(ratios) if ratios else np.nan, len(ratios)))
    for group in GROUP_ORDER:
        lines += [f"| {short_label} | {short[group]} | {name} | {scale:.0f} | {mae:.0f} | {ratio:.2f} | {n} |"
                  for g, name, scale, mae, ratio, n in rows if g == group]
    return lines


def angle_table(label: str, short_label: str, rows: list[dict]) -> list[str]:
    """Markdown table and per-group medians for one data set."""
    lines = [f"{label}: mean absolute angle error (degrees) against the truth's angle, over the valid frames",
             "where both are defined; differences wrapped modulo 360.",
             "  MAE world = pcnet now; MAE canonical (old) = the per-frame canonical frame (with the network's residual);",
             "  world, true rotation = the same noisy poses in the world frame built from the TRUE camera rotations:",
             "    joint angles must equal MAE world (one rigid rotation per clip), inclinations change with the up;",
             "    not an oracle: the lifter noise leans each clip's poses (models/lifter_noise.py, per-clip lean),",
             "    which the true camera up keeps as inclination error and the estimated up partly absorbs;",
             "  world vs canonical = MAE between the two estimates; w/o residual = against the canonical poses without",
             "    the network's residual (a pure per-frame rotation of the same poses; in this static-camera sequence",
             "    mode both pipelines share one up, so only filtering in a rotating frame remains: ~0 for every angle);",
             "  frames defined = share of all frames defined in estimate and truth (world / canonical);",
             "  wrapped = frames whose raw difference exceeded 180 deg (world / canonical).", "",
             "| data | group | angle | MAE world | MAE canonical (old) | world, true rotation | world vs canonical "
             "| world vs canonical w/o residual | frames defined | wrapped |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    short = {GROUP_ORDER[0]: "ISB joint", GROUP_ORDER[1]: "seg-to-seg unsigned", GROUP_ORDER[2]: "inclination"}
    for group in GROUP_ORDER:
        for r in (r for r in rows if r["group"] == group):
            lines.append(f"| {short_label} | {short[group]} | {r['name']} | {r['world']:.1f} | {r['canonical']:.1f} | "
                         f"{r['world_true_rotation']:.1f} | {r['world_vs_canonical']:.1f} | {r['world_vs_rigid']:.2f} | "
                         f"{100 * r['world_defined']:.1f}% / {100 * r['canonical_defined']:.1f}% | "
                         f"{r['world_wrapped']} / {r['canonical_wrapped']} |")
    lines += ["", f"{label}: summary over angles (median [mean] of the per-angle MAE, degrees; angles the truth "
              f"defines in some frame)",
              "| data | group | angles | MAE world | MAE canonical (old) | world, true rotation | world vs canonical "
              "| world vs canonical w/o residual |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for group in GROUP_ORDER:
        # an angle the truth never defines (CMU's and DeepMimic's spine is built on the trunk line) has no error
        g = [r for r in rows if r["group"] == group and np.isfinite(r["world"])]
        cell = lambda key, f=".1f": f"{np.median([r[key] for r in g]):{f}} [{np.mean([r[key] for r in g]):{f}}]"
        lines.append(f"| {short_label} | {group} | {len(g)} | {cell('world')} | {cell('canonical')} | "
                     f"{cell('world_true_rotation')} | {cell('world_vs_canonical')} | {cell('world_vs_rigid', '.2f')} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--max-clips", type=int, default=120, help="per data set, evenly spaced over its clips")
    ap.add_argument("--out", type=Path, default=RESULT)
    ap.add_argument("--angles-out", type=Path, default=ANGLES_RESULT)
    args = ap.parse_args()
    t0 = time.perf_counter()
    lines = [__doc__.splitlines()[0], "",
             f"    python -m benchmarks.world_kinematics --data {args.data} --max-clips {args.max_clips}", ""]
    angle_lines = ["Angles in one fixed world frame vs the per-frame canonical frame, against the same angles of mocap truth.",
                   "", lines[2], "",
                   "Setup as results/world_kinematics.txt (module docstring of benchmarks/world_kinematics.py).", ""]
    for label, file, split in (("Bandai motion-style test", "bandai_h36m17.npz", "test"),
                               ("CMU validation subjects", "cmu_train_h36m17.npz", "val")):
        short_label = {"Bandai motion-style test": "Bandai test", "CMU validation subjects": "CMU val"}[label]
        clips = select_split(load_mocap(args.data / "mocap" / file), split, "motion-style")
        keep = np.unique(np.linspace(0, len(clips) - 1, min(args.max_clips, len(clips))).round().astype(int))
        clips = [clips[i] for i in keep]
        pairs = make_pairs(clips, views="paper", seed=0, camera="static", noise=LifterNoise())
        acc: dict = {}
        ang: dict = {kind: {} for kind in ("truth", "world", "canonical", "world_true_rotation", "canonical_no_residual",
                                           "truth_rate", "world_rate")} | {"valid": [], "up_error_deg": []}
        for i, clip in enumerate(clips):
            sel = np.flatnonzero(pairs.clip == i)
            if len(sel) < 30:
                continue
            mocap = clip.joints[pairs.frame[sel]].astype(np.float64)
            errors, angles = clip_errors(pairs.inputs[sel], pairs.R[sel], mocap, clip.fps)
            for kind, qs in errors.items():
                for q, v in qs.items():
                    acc.setdefault((kind, q), []).append(v)
            ang["valid"].append(angles["valid"])
            ang["up_error_deg"].append(angles["up_error_deg"])
            for kind in ("truth", "world", "canonical", "world_true_rotation", "canonical_no_residual",
                         "truth_rate", "world_rate"):
                for name, v in angles[kind].items():
                    ang[kind].setdefault(name, []).append(v)
        frames = sum(len(v) for v in acc[("world", "speed")])
        lines += [f"{label}: {len(clips)} clips, {frames} frames; mean absolute error (median over frames in brackets)",
                  f"  {'quantity':<24}{'joints':<16}{'world (now)':>22}{'canonical (before)':>24}"]
        for q, unit in (("position", "m"), ("speed", "m/s"), ("|a|", "m/s^2"), ("velocity vector", "m/s")):
            for group, names in GROUPS.items():
                cols = [H36M_JOINTS.index(n) for n in names]
                cells = ""
                for kind in ("world", "canonical"):
                    if (kind, q) not in acc:
                        cells += f"{'-':>22}" if kind == "world" else f"{'-':>24}"
                        continue
                    v = np.concatenate([a[:, cols] for a in acc[(kind, q)]]).ravel()
                    v = v[np.isfinite(v)]
                    cell = f"{v.mean():.3f} [{np.median(v):.3f}]"
                    cells += f"{cell:>22}" if kind == "world" else f"{cell:>24}"
                lines.append(f"  {q + ' (' + unit + ')':<24}{group:<16}{cells}")
        lines.append("")
        print("\n".join(lines[-19:]), flush=True)
        valid = np.concatenate(ang["valid"])
        block = [f"{label}: {len(clips)} clips, {len(valid)} frames, {valid.sum()} with a valid rotation "
                 f"({100 * valid.mean():.1f}%); angle between the estimated up and the true camera's up over clips: mean "
                 f"{np.mean(ang['up_error_deg']):.2f} deg, median {np.median(ang['up_error_deg']):.2f}, "
                 f"max {np.max(ang['up_error_deg']):.2f}", ""] + angle_table(label, short_label, angle_rows(ang)) + [""] \
            + rate_table(label, short_label, ang) + [""]
        angle_lines += block
        print("\n".join(block), flush=True)
    run_time = f"run time {time.perf_counter() - t0:.0f} s"
    lines.append(run_time)
    angle_lines.append(run_time + " (both files, one run)")
    args.out.write_text("\n".join(lines) + "\n")
    args.angles_out.write_text("\n".join(angle_lines) + "\n")
    print(f"wrote {args.out} and {args.angles_out}")


if __name__ == "__main__":
    main()
