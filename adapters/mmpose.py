"""MMPose / RTMPose prediction JSON -> :class:`Keypoints2D` (open-mmlab/mmpose).

Two writers exist:

* ``demo/topdown_demo_with_mmdet.py --save-predictions``:
  ``{"meta_info": {...}, "instance_info": [{"frame_id": i, "instances": [...]}]}`` with
  **1-based** ``frame_id`` for video;
* ``MMPoseInferencer(pred_out_dir=...)``: ``[{"frame_id": i, "instances": [...]}]`` with
  **0-based** ``frame_id``; for a single image, just the list of instances.

An instance is ``{"keypoints": [[x, y], ...], "keypoint_scores": [...], "bbox": [[x1, y1,
x2, y2]], "bbox_score": s}``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pcnet.stages.core.conventions import get_layout

from .registry import register_2d
from .types import AdapterError, Keypoints2D
from .validate import (
    as_path,
    checked_keypoints,
    frame_count_for,
    json_numbers,
    layout_from_count,
    read_json,
    require_option_int,
)

# 133 = COCO-WholeBody, whose first 17 joints are COCO-17.
_LAYOUT_BY_COUNT = {17: "coco17", 26: "halpe26", 133: "coco17"}


def _frames(p: Path, data: Any) -> tuple[list[tuple[int, list, str]], str]:
    """Return ([(0-based frame, instances, field path)], writer description)."""
    if isinstance(data, dict):
        if "instance_info" not in data:
            raise AdapterError(p, "instance_info", "an MMPose predictions object with 'instance_info' (MMPose topdown_demo_with_mmdet.py)",
                               f"keys {sorted(data)[:6]}")
        records, base, where = data["instance_info"], 1, "instance_info"
        writer = "topdown_demo_with_mmdet --save-predictions (1-based frame_id)"
    elif isinstance(data, list):
        if data and all(isinstance(r, dict) and "keypoint_scores" in r for r in data):
            return [(0, data, "")], "MMPoseInferencer image predictions (one frame)"
        records, base, where = data, 0, ""
        writer = "MMPoseInferencer video predictions (0-based frame_id)"
    else:
        raise AdapterError(p, "top level", "an MMPose predictions object or list", type(data).__name__)
    if not isinstance(records, list) or not records:
        raise AdapterError(p, where or "top level", "a non-empty list of {frame_id, instances}",
                           "an empty list" if isinstance(records, list) else type(records).__name__)
    out = []
    for i, rec in enumerate(records):
        field = f"{where}[{i}]"
        if not isinstance(rec, dict) or "frame_id" not in rec or "instances" not in rec:
            got = f"keys {sorted(rec)[:6]}" if isinstance(rec, dict) else type(rec).__name__
            raise AdapterError(p, field, "a frame record with 'frame_id' and 'instances' (MMPose prediction JSON)", got)
        fid = rec["frame_id"]
        if isinstance(fid, bool) or not isinstance(fid, int) or fid < base:
            raise AdapterError(p, f"{field}.frame_id", f"an integer >= {base}", repr(fid)[:80])
        if not isinstance(rec["instances"], list):
            raise AdapterError(p, f"{field}.instances", "a list", type(rec["instances"]).__name__)
        out.append((fid - base, rec["instances"], f"{field}.instances"))
    return out, writer


def _instance(p: Path, field: str, inst: Any, count: int | None) -> np.ndarray:
    """One instance as float64 ``(K, 3)`` x, y, score."""
    if not isinstance(inst, dict) or "keypoints" not in inst or "keypoint_scores" not in inst:
        got = f"keys {sorted(inst)[:6]}" if isinstance(inst, dict) else type(inst).__name__
        raise AdapterError(p, field, "an instance with 'keypoints' and 'keypoint_scores'", got)
    xy = json_numbers(p, f"{field}.keypoints", inst["keypoints"], depth=2)
    sc = json_numbers(p, f"{field}.keypoint_scores", inst["keypoint_scores"])
    if xy.ndim != 2 or xy.shape[1] != 2 or sc.shape != (xy.shape[0],):
        raise AdapterError(p, f"{field}.keypoints", "[[x, y], ...] with one keypoint_scores value per joint",
                           f"keypoints {xy.shape}, keypoint_scores {sc.shape}")
    if count is not None and xy.shape[0] != count:
        raise AdapterError(p, f"{field}.keypoints", f"{count} joints like the first instance", f"{xy.shape[0]}")
    return np.concatenate([xy, sc[:, None]], 1)


def _mean_score(kp: np.ndarray) -> float:
    """Mean of the finite keypoint scores (-inf without any): inf/NaN scores are missing,
    and an instance without a score never wins over one with a score."""
    sc = kp[:, 2][np.isfinite(kp[:, 2])]
    if not sc.size:
        return -np.inf
    with np.errstate(over="ignore"):  # scores near 1e308 sum to inf, still the largest
        return float(sc.mean())


def load_mmpose(path: str | Path, person: int | None = None, num_frames: int | None = None,
                frame_count: int | None = None) -> Keypoints2D:
    """Read MMPose/RTMPose prediction JSON (either writer) into ``Keypoints2D``.

    Args:
        path: the JSON file.
        person: index of the instance to keep **within each frame's list** (MMPose writes no
            track ids, so this is only stable when the list order is); a frame with fewer
            instances is NaN. ``None`` keeps, per frame, the instance with the highest mean
            ``keypoint_scores`` (ties: the earlier instance).
        num_frames: length ``T``; default: largest 0-based frame index + 1.
        frame_count: the video's frame count, when known (the pipeline passes it): every
            0-based frame index must be below it. Without it, an index above
            ``100 * frame records + 10000`` is refused as implausible for the file's size
            (:func:`~pcnet.adapters.validate.frame_count_for`). It does not change ``T``.

    Returns:
        ``Keypoints2D``: ``points`` float32 ``(T, J, 3)`` x_px, y_px, score clipped to [0, 1]
        (RTMPose SimCC scores are not bounded by 1); layout from the joint count: 17 ->
        ``coco17``, 26 -> ``halpe26``, 133 (COCO-WholeBody) -> its first 17 joints, ``coco17``.
        Frames with no instance are NaN. ``track_id`` is ``None``.

    Raises:
        AdapterError: missing/empty/invalid JSON; neither writer's structure (e.g. an
            AlphaPose list); a bad ``frame_id``; malformed instances (values that are not
            numbers); a joint count other than 17/26/133; a bad ``person``; a frame index
            ``>= num_frames``, ``>= frame_count`` or implausible without it; ``|x|``/``|y|``
            beyond 1e5 px (naming frame and joint); nothing finite. ``inf``/``NaN`` values
            are missing data: the joint is NaN.

    Source of the format facts: open-mmlab/mmpose (commit 759b39c)
    ``demo/topdown_demo_with_mmdet.py`` L233/L277-290,
    ``mmpose/apis/inferencers/base_mmpose_inferencer.py`` L678-691,
    ``mmpose/structures/utils.py`` ``split_instances``.
    """
    p = as_path(path)
    person = require_option_int(p, "person", person, 0)
    frames, writer = _frames(p, read_json(p))
    count = None
    chosen: dict[int, list[np.ndarray]] = {}
    for frame, instances, field in frames:
        parsed = []
        for j, inst in enumerate(instances):
            arr = _instance(p, f"{field}[{j}]", inst, count)
            if count is None:
                layout_from_count(p, f"{field}[{j}].keypoints", arr.shape[0], _LAYOUT_BY_COUNT)
                count = arr.shape[0]
            parsed.append(arr)
        if frame in chosen:  # MMPose's writers give each frame one record: a repeat is another file's or an edit's
            raise AdapterError(p, f"{field.removesuffix('.instances')}.frame_id", "one record per frame",
                               f"a frame_id an earlier record has (video frame {frame}, 0-based)")
        chosen[frame] = parsed
    if count is None:
        raise AdapterError(p, "instances", "at least one instance in some frame", "no instances")

    max_frame = max(chosen)
    num_frames = frame_count_for(p, "frame_id", max_frame, len(frames), frame_count, num_frames)
    layout = _LAYOUT_BY_COUNT[count]
    n_joints = get_layout(layout).num_joints
    points = np.full((num_frames, n_joints, 3), np.nan)
    for frame, parsed in chosen.items():
        if not parsed:
            continue
        if person is not None:
            if person < len(parsed):
                points[frame] = parsed[person][:n_joints]
            continue
        points[frame] = parsed[int(np.argmax([_mean_score(a) for a in parsed]))][:n_joints]
    points, raw_max = checked_keypoints(p, "keypoints", points, layout)

    empty = int(np.isnan(points).all(axis=(1, 2)).sum())
    notes = [f"MMPose JSON from {writer}, {count} joints -> {layout}",
             f"instance index {person} per frame" if person is not None else "per frame the instance with the highest mean keypoint score"]
    if count != n_joints:
        notes.append(f"kept the first {n_joints} of {count} joints (COCO body part)")
    if empty:
        notes.append(f"{empty} of {num_frames} frames without an instance -> NaN")
    notes.append(f"confidence clipped to [0, 1] (raw max {raw_max:.3f})")
    crowded = sum(len(parsed) > 1 for parsed in chosen.values())
    choice = f"{notes[1]} ({crowded} of {num_frames} frames have several instances)" if crowded or person is not None else ""
    return Keypoints2D(points, layout, str(p), track_id=None, notes="; ".join(notes), choice=choice)


@register_2d("mmpose", records_fps=False, multi_track="MMPose instance")
class MMPoseAdapter:
    """Registry entry for :func:`load_mmpose` (options: ``person``, ``num_frames``,
    ``frame_count``)."""

    def load(self, path: str | Path, *, person: int | None = None, num_frames: int | None = None,
             frame_count: int | None = None) -> Keypoints2D:
        return load_mmpose(path, person=person, num_frames=num_frames, frame_count=frame_count)
