"""``pcnet evaluate``: rotation, tilt, heading, MPJPE and PA-MPJPE of a rectification
method on mocap with synthetic camera views (deterministic for a given seed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pcnet.models.datasets import Noise, load_mocap, make_pairs, select_split
from pcnet.stages.canonical import to_canonical
from pcnet.stages.metrics import METRICS, evaluate_rotations, summarize
from pcnet.stages.errors import InputError
from pcnet.stages.rectify import (estimate_rotations, finish_rotations, frame_refiner_for, resolve_heading_source,
                                  up_refiner_for)


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
    mode: str = "frame",
    heading: str | None = None,
    up_refiner: bool = True,
) -> dict:
    """Evaluate ``method`` on the ``split`` clips of a mocap npz.

    Pairs come from :func:`pcnet.models.datasets.make_pairs` (clean inputs unless
    ``noise``); ``mode`` other than ``"frame"`` post-processes each clip's per-frame
    rotations with :func:`pcnet.stages.temporal.rectify_sequence` (``sequence`` assumes a
    static camera, meaningful with ``camera="per-clip"``); ``heading`` then chooses each
    clip's heading source (:func:`pcnet.stages.heading.apply_heading`; ``None`` = the
    method's default, :func:`pcnet.stages.rectify.resolve_heading_source`), each clip being
    one recording whatever the camera protocol (both steps by
    :func:`pcnet.stages.rectify.finish_rotations`, as in ``rectify``, after the frame up
    refiner and with the static-camera up refiner in sequence mode when ``up_refiner`` and
    the method and weights allow them, :func:`pcnet.stages.rectify.frame_refiner_for`,
    :func:`pcnet.stages.rectify.up_refiner_for`; ``up_refiner=False`` scores the paper's
    3DPCNet alone). The canonical prediction is
    ``(X - pelvis) @ R_hat (+ residual)``, compared with the canonical target. Frames a
    method marks invalid are counted, not scored.

    Returns:
        ``{"method", "views", "split", "data", "seed", "camera", "noise", "mode",
        "heading", "frames", "invalid_frames", "clip_heading_sources" (clips per source
        used), "frame_refined_clips" (when the frame up refiner ran), "clip_modes" and "up_refined_clips" (sequence modes only), "<metric>": {"mean", "median", "p95"}
        ...}`` with the metrics of :data:`pcnet.stages.metrics.METRICS` (degrees, millimetres).

    Raises:
        ValueError: empty split, unknown method or heading source (before any inference).
    """
    heading = resolve_heading_source(method, heading)
    clips = select_split(load_mocap(data), split)
    if not clips:
        raise InputError(f"{data}: split {split!r} has no clips")
    pairs = make_pairs(clips, views=views, seed=seed, camera=camera, noise=Noise() if noise else None,
                       max_frames=max_frames)
    R_hat, residual, valid = estimate_rotations(pairs.inputs, method, weights)
    refiner = up_refiner_for(method, weights, up_refiner)
    frame_refiner = frame_refiner_for(method, weights, up_refiner)
    modes_run: dict[str, int] = {}
    refined_clips = frame_refined_clips = 0
    headings_run: dict[str, int] = {}
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)
        if len(sel) == 0:
            continue
        # Scores need the rotations only, not the camera-tilt uncertainty (bootstrap).
        R_hat[sel], valid[sel], report = finish_rotations(
            pairs.inputs[sel], R_hat[sel], valid[sel], mode, clip.fps, heading, n_bootstrap=0, up_refiner=refiner,
            frame_refiner=frame_refiner)
        frame_refined_clips += bool(report["frame_refined"])
        if mode != "frame":
            modes_run[report["mode"]] = modes_run.get(report["mode"], 0) + 1
            refined_clips += bool(report.get("up_refined"))
        headings_run[report["heading_source"]] = headings_run.get(report["heading_source"], 0) + 1
    canon_hat = to_canonical(pairs.inputs, R_hat, residual)
    errors = evaluate_rotations(R_hat, pairs.R, canon_hat, pairs.canonical)
    result = {
        "method": method, "views": views, "split": split, "data": str(data), "seed": seed,
        "camera": camera, "noise": noise, "mode": mode, "heading": heading,
        "frames": int(len(valid)), "invalid_frames": int((~valid).sum()),
    }
    if frame_refiner is not None:
        result["frame_refined_clips"] = frame_refined_clips
    if modes_run:
        result["clip_modes"] = modes_run
        result["up_refined_clips"] = refined_clips
    result["clip_heading_sources"] = headings_run
    result.update({name: summarize(errors[name]) for name in METRICS})
    return result


def format_table(result: dict) -> str:
    """The result as a plain-text table (one row per metric: mean, median, p95)."""
    sources = ",".join(f"{k}:{v}" for k, v in result.get("clip_heading_sources", {}).items())
    head = (f"method={result['method']} views={result['views']} split={result['split']} "
            f"camera={result['camera']} noise={result['noise']} mode={result['mode']} "
            f"heading={result.get('heading', 'predicted')} (clips {sources}) frames={result['frames']} "
            f"invalid={result['invalid_frames']} seed={result['seed']}")
    lines = [head, f"{'metric':<14}{'mean':>10}{'median':>10}{'p95':>10}"]
    for name in METRICS:
        s = result[name]
        lines.append(f"{name:<14}{s['mean']:>10.2f}{s['median']:>10.2f}{s['p95']:>10.2f}")
    return "\n".join(lines)
