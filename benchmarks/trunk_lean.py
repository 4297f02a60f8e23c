"""How much of the up error follows the subject's own trunk lean (the lean-vs-tilt ambiguity).

    python -m benchmarks.trunk_lean [--data ../shared/data] [--out benchmarks/results/trunk_lean.txt]

A single pose cannot tell a body leaning forward under a level camera from an upright body
under a camera pitched down; a network that learned the trunk postures of its training data
leans its up with a subject who leans more than they did. This script measures that, per
clip, on held-out mocap:

- trunk lean: the forward (sagittal) angle of pelvis -> thorax from the true up, in the
  canonical frame of docs/CONVENTIONS.md (x anterior, y up), degrees, median over the clip's
  frames (positive = leaning forward);
- up error, sagittal part: the shipped pair's per-frame up (``rectify(..., "pcnet",
  mode="frame")``, one call per clip so the view gate sees the clip as a recording) written
  in the true canonical frame, ``atan2(u_x, u_y)``, degrees, median over the clip's frames
  (positive = the estimated up leans forward of the truth); the lateral part
  ``atan2(u_z, u_y)`` likewise;
- per set: clips, median trunk lean, median sagittal error, the Pearson correlation and the
  least-squares slope of the clips' sagittal error on their trunk lean (deg of up error per
  deg of lean); then per band of trunk lean (:data:`LEAN_BANDS_DEG`) the clips and their
  median sagittal error, so a few extreme clips cannot carry the slope alone.

Views: one static "paper" camera per clip (``make_pairs(clips, views="paper", seed=0,
camera="static")``), clean poses. Sets: the training mix's motion-style *train* split
(the lean the networks learned; Bandai + CMU train, what configs/pcnet_*.toml train on, every
8th clip to keep the run short), its *test* split (held out by motion and style) and
DeepMimic (another dataset; the camera-frame network trained on three of its floor clips). Nothing is fitted: it is a diagnosis.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import print_and_save, trial_arguments

from pcnet.models.datasets import load_mocap, make_pairs
from pcnet.pipeline.rectification import rectify
from pcnet.stages.core.conventions import PELVIS, THORAX

RESULT = Path(__file__).resolve().parent / "results" / "trunk_lean.txt"
COMMAND = "python -m benchmarks.trunk_lean --data ../shared/data"
TRAIN_EVERY = 8
#: Bands of the clips' median forward trunk lean, degrees.
LEAN_BANDS_DEG = (-90, 0, 5, 10, 20, 45, 90)


def clip_rows(clips) -> np.ndarray:
    """``(n_clips, 3)``: median trunk lean, median sagittal and lateral up error (deg)."""
    pairs = make_pairs(clips, views="paper", seed=0, camera="static")
    rows = []
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)
        if len(sel) < 2:
            continue
        res = rectify(pairs.inputs[sel].astype(np.float64), "pcnet", mode="frame", fps=clip.fps)
        ok = res.valid
        if not ok.any():
            continue
        # estimated up in the true canonical frame: R_true^T u_est
        u = np.einsum("nji,nj->ni", pairs.R[sel][ok], res.up[ok])
        canonical = pairs.canonical[sel][ok]
        trunk = canonical[:, THORAX] - canonical[:, PELVIS]
        rows.append((np.median(np.degrees(np.arctan2(trunk[:, 0], trunk[:, 1]))),
                     np.median(np.degrees(np.arctan2(u[:, 0], u[:, 1]))),
                     np.median(np.degrees(np.arctan2(u[:, 2], u[:, 1])))))
    return np.array(rows, np.float64)


def summary(name: str, rows: np.ndarray) -> str:
    lean, sag, lat = rows.T
    r = float(np.corrcoef(lean, sag)[0, 1])
    slope = float(np.polyfit(lean, sag, 1)[0])
    return (f"| {name} | {len(rows)} | {np.median(lean):+.1f} [{np.percentile(lean, 10):+.1f}, "
            f"{np.percentile(lean, 90):+.1f}] | {np.median(sag):+.2f} | {np.median(lat):+.2f} | {r:+.2f} | {slope:+.2f} |")


def main() -> None:
    args = trial_arguments(__doc__, RESULT, script="trunk_lean")
    train, test = training_mix_splits(args.data, "train", "test")
    sets = [("training mix, motion-style train (every 8th clip)", train[::TRAIN_EVERY]),
            ("training mix, motion-style test", test),
            ("DeepMimic (another dataset)", load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz"))]
    lines = [COMMAND, "",
             "Per clip: trunk lean = median forward angle of pelvis->thorax from the true up; up error = median",
             "sagittal (+ = estimate leans forward of the truth) and lateral part of the shipped pair's per-frame",
             "up (frame mode, clean, one static paper camera per clip, seed 0); r and slope: clips' sagittal",
             "error against their trunk lean. Degrees.", "",
             "| set | clips | trunk lean, median [p10, p90] | sagittal up error, median | lateral, median | r | slope |",
             "|---|---|---|---|---|---|---|"]
    measured = []
    for name, clips in sets:
        measured.append((name, clip_rows(clips)))
        lines.append(summary(*measured[-1]))
        print(lines[-1], flush=True)
    bands = list(zip(LEAN_BANDS_DEG[:-1], LEAN_BANDS_DEG[1:]))
    lines += ["", "Median sagittal up error (deg) of the clips whose trunk lean falls in each band (clips in brackets):", "",
              "| set | " + " | ".join(f"lean {lo:+d} to {hi:+d}" for lo, hi in bands) + " |",
              "|---|" + "---|" * len(bands)]
    for name, rows in measured:
        cells = []
        for lo, hi in bands:
            inside = rows[(rows[:, 0] >= lo) & (rows[:, 0] < hi)]
            cells.append(f"{np.median(inside[:, 1]):+.1f} ({len(inside)})" if len(inside) else "- (0)")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
