"""``pcnet evaluate``: rotation, tilt, heading, MPJPE and PA-MPJPE of a rectification
method on mocap with synthetic camera views (deterministic for a given seed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pcnet.models.datasets import Noise, load_mocap, make_pairs, select_split
from pcnet.stages.canonical import to_canonical
from pcnet.stages.metrics import METRICS, evaluate_rotations, summarize
from pcnet.stages.rectify import estimate_rotations


def evaluate(
    method: str,
    data: str | Path,
    split: str = "test",
    views: str = "paper",
    seed: int = 0,
    max_frames: int | None = None,
    weights: str | None = None,
    camera: str = "per-frame",
    noise: bool = False,
) -> dict:
    """Evaluate ``method`` on the ``split`` clips of a mocap npz.

    Pairs come from :func:`pcnet.models.datasets.make_pairs` (clean inputs unless
    ``noise``); the canonical prediction is ``(X - pelvis) @ R_hat (+ residual)``, compared
    with the canonical target. Frames a method marks invalid are counted, not scored.

    Returns:
        ``{"method", "views", "split", "data", "seed", "camera", "noise", "frames",
        "invalid_frames", "<metric>": {"mean", "median", "p95"} ...}`` with the metrics of
        :data:`pcnet.stages.metrics.METRICS` (degrees, millimetres).
    """
    clips = select_split(load_mocap(data), split)
    if not clips:
        raise ValueError(f"{data}: split {split!r} has no clips")
    pairs = make_pairs(clips, views=views, seed=seed, camera=camera, noise=Noise() if noise else None,
                       max_frames=max_frames)
    R_hat, residual, valid = estimate_rotations(pairs.inputs, method, weights)
    canon_hat = to_canonical(pairs.inputs, R_hat, residual)
    errors = evaluate_rotations(R_hat, pairs.R, canon_hat, pairs.canonical)
    result = {
        "method": method, "views": views, "split": split, "data": str(data), "seed": seed,
        "camera": camera, "noise": noise, "frames": int(len(valid)), "invalid_frames": int((~valid).sum()),
    }
    result.update({name: summarize(errors[name]) for name in METRICS})
    return result


def format_table(result: dict) -> str:
    """The result as a plain-text table (one row per metric: mean, median, p95)."""
    head = (f"method={result['method']} views={result['views']} split={result['split']} "
            f"camera={result['camera']} noise={result['noise']} frames={result['frames']} "
            f"invalid={result['invalid_frames']} seed={result['seed']}")
    lines = [head, f"{'metric':<14}{'mean':>10}{'median':>10}{'p95':>10}"]
    for name in METRICS:
        s = result[name]
        lines.append(f"{name:<14}{s['mean']:>10.2f}{s['median']:>10.2f}{s['p95']:>10.2f}")
    return "\n".join(lines)
