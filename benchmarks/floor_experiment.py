"""Floor motions in training: the shipped pair against the same pair with one candidate network.

    python -m benchmarks.floor_experiment --body runs/pcnet_body_floor.onnx [--data ../shared/data] [--stride 2]
    python -m benchmarks.floor_experiment --camera runs/pcnet_camera_floor.onnx --out benchmarks/results/floor_experiment_camera.txt

The candidate (configs/pcnet_body_floor.toml, configs/pcnet_camera_floor.toml) is a shipped
recipe with three of DeepMimic's four floor motions in training
(benchmarks/deepmimic_floor_subset.py). Both pairs keep the other shipped network and the view
gate (models/inference.py: ViewGatedPCNet); only the candidate's network differs, and that
network alone is scored too. Rows,
per frame, clean, "paper" views, a new camera every frame (pcnet evaluate's protocol, seed 0):

- DeepMimic, by group: the three floor clips trained on (a check that training reached them,
  not a held-out number), the floor roll held out, the acrobatics (cartwheel, backflip,
  sideflip: bodies upside down, never trained on), and every other clip (walks, runs, kicks,
  dances): the cross-dataset test that stays one.
- Bandai motion-style test and the CMU test subjects: the held-out motions and people of the
  README's held-out table, which the candidate must not lose.
- Real VideoPose3D yoga files (no ground truth; physics): per file the median angle of the
  rectified trunk (pelvis -> thorax) from vertical, per frame (frame mode) and in the default
  sequence mode; lying Shavasana should read >= 80 deg, prone Bhujangasana's lower trunk
  near horizontal, standing Tadasana <= 6 deg (benchmarks/yoga_physics.py's targets).

Writes benchmarks/results/floor_experiment.txt (``--out``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.deepmimic_floor_subset import FLOOR_HELD_OUT, FLOOR_TRAIN
from benchmarks.report import SHARED_DATA, print_and_save
from benchmarks.yoga_physics import plain_export, median_trunk_deg, parse_name

import pcnet.models.inference as inference
from pcnet.adapters import load_videopose3d
from pcnet.pipeline.evaluate import evaluate
from pcnet.pipeline.rectification import rectify
from pcnet.stages.core.conventions import root_relative

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "floor_experiment.txt"
ACROBATICS = ("humanoid3d_cartwheel.txt", "humanoid3d_backflip.txt", "humanoid3d_sideflip.txt")
ASANAS = ("Tadasana", "Padmasana", "Bhujangasana", "Shavasana")


def use_network(kind: str, path: Path) -> None:
    """Make the pair (``--method pcnet`` without weights) use ``path`` as its ``kind``
    (``"body"`` or ``"camera"``) network."""
    setattr(inference, f"{kind.upper()}_WEIGHTS", Path(path))
    inference._cached_session.cache_clear()


def deepmimic_groups(result: dict) -> dict[str, dict[str, float]]:
    """Mean rotation and tilt error (deg) per DeepMimic group from ``evaluate(..., details=True)``."""
    names = np.array([c["name"] for c in result["per_clip"]])
    frames = result["per_frame"]
    clip_names = names[frames["clip"]]
    groups = {"floor, trained": np.isin(clip_names, FLOOR_TRAIN), "floor roll, held out": np.isin(clip_names, FLOOR_HELD_OUT),
              "acrobatics": np.isin(clip_names, ACROBATICS)}
    groups["all other clips"] = ~np.any(list(groups.values()), axis=0)
    groups["all but the trained clips"] = ~groups["floor, trained"]
    out = {}
    for name, sel in groups.items():
        ok = sel & frames["valid"]
        out[name] = {"frames": int(sel.sum()), "rotation": float(np.nanmean(frames["rotation_deg"][ok])),
                     "tilt": float(np.nanmean(frames["tilt_deg"][ok]))}
    return out


def held_out_rows(data: Path, weights: str | None) -> list[tuple[str, dict]]:
    mocap = data / "mocap"
    rows = []
    dm = evaluate("pcnet", mocap / "deepmimic_h36m17.npz", split="all", weights=weights, details=True)
    rows += [(f"DeepMimic, {name}", value) for name, value in deepmimic_groups(dm).items()]
    for label, file in (("Bandai motion-style test", "bandai_h36m17.npz"), ("CMU test subjects", "cmu_train_h36m17.npz")):
        res = evaluate("pcnet", mocap / file, split="test", weights=weights)
        rows.append((label, {"frames": res["valid_frames"], "rotation": res["rotation_deg"]["mean"],
                             "tilt": res["tilt_deg"]["mean"]}))
    return rows


def yoga_rows(data: Path, stride: int) -> dict[str, list[tuple[float, float, float]]]:
    """asana -> per file (frame-mode trunk, frame-mode lower trunk, sequence-mode trunk), deg."""
    out: dict[str, list] = {a: [] for a in ASANAS}
    for path in sorted((data / "real" / "yoga_videopose3d").glob("export_*.npy")):
        person, asana = parse_name(path)
        if asana not in out or not plain_export(path):
            continue
        joints, _ = root_relative(load_videopose3d(path).joints[::stride])
        fps = 30.0 / stride
        frame = rectify(joints, "pcnet", fps=fps, mode="frame")
        seq = rectify(joints, "pcnet", fps=fps, mode="sequence")
        out[asana].append((median_trunk_deg(frame.canonical, frame.valid),
                           median_trunk_deg(frame.canonical, frame.valid, lower=True),
                           median_trunk_deg(seq.canonical, seq.valid)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    which = ap.add_mutually_exclusive_group(required=True)
    which.add_argument("--body", type=Path, help="a candidate body-frame network (.onnx)")
    which.add_argument("--camera", type=Path, help="a candidate camera-frame network (.onnx)")
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--stride", type=int, default=2, help="yoga files: every k-th frame (default 2)")
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args()
    kind = "body" if args.body else "camera"
    candidate = args.body or args.camera
    for needed, what in ((args.data / "mocap" / "deepmimic_h36m17.npz", "--data"), (candidate, f"--{kind}")):
        if not needed.is_file():
            sys.exit(f"{what}: expected {needed} (--data: the shared data root, ../shared/data/README.md; --{kind}: "
                     f"an exported {kind}-frame network), got no such file")
    started = time.time()
    variants = {"shipped": getattr(inference, f"{kind.upper()}_WEIGHTS"), "candidate": candidate}
    mocap, yoga = {}, {}
    for name, weights in variants.items():
        use_network(kind, weights)
        mocap[(name, "pair")] = held_out_rows(args.data, None)
        mocap[(name, "alone")] = held_out_rows(args.data, str(weights))
        yoga[name] = yoga_rows(args.data, args.stride)
    out = "" if args.out == RESULT else f" --out {args.out}"
    lines = [__doc__.splitlines()[0], "", f"    python -m benchmarks.floor_experiment --{kind} {candidate} --data "
             f"../shared/data --stride {args.stride}{out}", "",
             "Held-out mocap, per frame, clean: mean rotation / tilt error (deg)", "",
             f"| rows | frames | shipped pair | candidate pair | shipped {kind}-net | candidate {kind}-net |",
             "|---|---:|---:|---:|---:|---:|"]
    for i, (label, first) in enumerate(mocap[("shipped", "pair")]):
        cells = [f"{mocap[key][i][1]['rotation']:.2f} / {mocap[key][i][1]['tilt']:.2f}"
                 for key in (("shipped", "pair"), ("candidate", "pair"), ("shipped", "alone"), ("candidate", "alone"))]
        lines.append(f"| {label} | {first['frames']} | " + " | ".join(cells) + " |")
    lines += ["", f"Real yoga (VideoPose3D, every {args.stride}. frame): per file median trunk angle from vertical (deg), "
              "median over files [min, max]; pass = files meeting the target", "",
              "| asana (files), target | shipped frame | candidate frame | shipped sequence | candidate sequence |",
              "|---|---|---|---|---|"]
    targets = {"Tadasana": ("<=", 6.0), "Padmasana": ("<=", 15.0), "Shavasana": (">=", 80.0)}
    for asana in ASANAS:
        cells = []
        for column in (0, 2):  # frame mode, then sequence mode, as the header
            for name in variants:
                values = np.array([row[column] for row in yoga[name][asana]])
                passed = ""
                if asana in targets:
                    op, threshold = targets[asana]
                    count = int(np.sum(values >= threshold if op == ">=" else values <= threshold))
                    passed = f", pass {count}/{len(values)}"
                cells.append(f"{np.median(values):.1f} [{values.min():.0f}, {values.max():.0f}]{passed}")
        target = f"{targets[asana][0]} {targets[asana][1]:g}" if asana in targets else "no target"
        label = f"{asana} ({len(yoga['shipped'][asana])}), {target}"
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lower = {name: np.array([row[1] for row in yoga[name]["Bhujangasana"]]) for name in variants}
    lines += ["", "Bhujangasana (prone cobra), frame mode, lower trunk (pelvis -> spine) from vertical, median over "
              f"files [min, max]: shipped {np.median(lower['shipped']):.1f} [{lower['shipped'].min():.0f}, "
              f"{lower['shipped'].max():.0f}], candidate {np.median(lower['candidate']):.1f} "
              f"[{lower['candidate'].min():.0f}, {lower['candidate'].max():.0f}] (a prone lower trunk lies near 90)",
              "", f"run time {time.time() - started:.0f} s"]
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
