"""Per-frame up error by the subject's true trunk lean, for one or more 3DPCNet weights.

    python -m benchmarks.lean_bins --weights A.onnx [B.onnx ...] [--data ../shared/data] [--out benchmarks/results/lean_bins.txt]

The training mix (Bandai + CMU train subjects) is mostly upright: 89 % of its frames lean
under 10 deg. Held-out motions lean more, and a network that learned the upright prior reads
a leaning trunk as a tilted camera. This table shows, per set and per weights file, the share
of frames in each band of true trunk lean and the mean per-frame tilt error there, so a
training change aimed at leaning poses (``lean_balance_cap``, models/MODEL_CARD.md) can be
seen where it acts and where it costs.

- trunk lean: angle of pelvis -> thorax from the true up in the canonical frame
  (:func:`pcnet.stages.core.canonical.trunk_lean_deg`), degrees;
- tilt error: angle between the estimated and the true up
  (:func:`pcnet.stages.core.metrics.tilt_error_deg`), one network alone
  (:class:`pcnet.models.inference.PCNetSession`), per frame, clean poses, a new "paper" camera
  every frame (``make_pairs(clips, views="paper", seed=0)``: the held-out table's protocol).

Sets: the training mix's motion-style test split, Bandai and CMU (test subjects 10, 14)
apart, and DeepMimic (another dataset). The first rows give, for reference, the training
mix's train split's lean distribution (every 4th frame, what the configs train on) and the
share a lean-balanced epoch draws from each band (every frame, with the proportion
augmentation, the CMU clips twice as the configs' ``data_repeats``, weighted by
:func:`pcnet.models.datasets.lean_balance_weights`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import SHARED_DATA, print_and_save

from pcnet.models.datasets import (
    Augmentation, clip_subject, lean_balance_weights, load_mocap, make_pairs)
from pcnet.models.inference import PCNetSession
from pcnet.stages.core.canonical import trunk_lean_deg
from pcnet.stages.core.metrics import tilt_error_deg

DEFAULT = SHARED_DATA
BANDS_DEG = (0, 5, 10, 15, 20, 30, 45, 90, 180)


#: The ``lean_balance_cap`` values of configs/pcnet_camera_lean*.toml, whose drawn shares are shown.
CAPS = (3.0, 10.0)


def _band_table_row(label: str, lean: np.ndarray, err: np.ndarray | None, weights: np.ndarray | None = None) -> str:
    band = np.digitize(lean, BANDS_DEG) - 1
    weights = np.ones(len(lean)) if weights is None else weights
    cells = []
    for k in range(len(BANDS_DEG) - 1):
        sel = band == k
        share = f"{100 * weights[sel].sum() / weights.sum():.1f} %"
        cells.append(share if err is None else (f"{np.nanmean(err[sel]):.2f} ({share})" if sel.any() else "-"))
    total = "" if err is None else f"{np.nanmean(err):.2f}"
    return f"| {label} | {total} | " + " | ".join(cells) + " |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--weights", nargs="+", required=True, help="exported 3DPCNet ONNX files")
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results" / "lean_bins.txt")
    args = ap.parse_args()

    train, test = training_mix_splits(args.data, "train", "test")
    train_lean = trunk_lean_deg(make_pairs(train, views="paper", seed=0, frame_stride=4).canonical)
    # what a balanced epoch draws from: every frame, proportions augmented (models/train.py)
    # CMU twice, as the configs' data_repeats = [1, 2]
    repeated = train + [c for c in train if clip_subject(c) is not None]
    pool_lean = trunk_lean_deg(make_pairs(repeated, views="paper", seed=0, augmentation=Augmentation()).canonical)
    sets = {
        "Bandai motion-style test": [c for c in test if clip_subject(c) is None],
        "CMU test subjects": [c for c in test if clip_subject(c) is not None],
        "DeepMimic (another dataset)": load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz"),
    }
    sessions = {Path(w).name: PCNetSession(w) for w in args.weights}
    head = " | ".join(f"lean {a}-{b}" for a, b in zip(BANDS_DEG, BANDS_DEG[1:]))
    lines = [
        "python -m benchmarks.lean_bins --weights " + " ".join(args.weights),
        "",
        "Mean per-frame tilt error (deg) by true trunk lean band; in brackets the set's share of frames",
        "in the band. One network alone, clean poses, a new paper camera every frame, seed 0.",
        "",
        f"| set / weights | mean | {head} |",
        "|---|---|" + "---|" * (len(BANDS_DEG) - 1),
        _band_table_row("training mix train split (share of frames)", train_lean, None),
        *(_band_table_row(f"drawn with lean_balance_cap = {cap:g} (expected share)", pool_lean, None,
                          lean_balance_weights(pool_lean, cap)) for cap in CAPS),
    ]
    for name, clips in sets.items():
        pairs = make_pairs(clips, views="paper", seed=0)
        lean = trunk_lean_deg(pairs.canonical)
        for label, session in sessions.items():
            R, _, valid = session.predict(pairs.inputs)
            err = np.where(valid, tilt_error_deg(R, pairs.R), np.nan)
            lines.append(_band_table_row(f"{name}, {label}", lean, err))
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
