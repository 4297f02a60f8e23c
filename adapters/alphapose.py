"""AlphaPose results JSON -> :class:`Keypoints2D` (AlphaPose ``docs/output.md``).

The file is a flat list, one entry per detected person per image::

    {"image_id": "<k>.jpg", "category_id": 1, "keypoints": [x1, y1, c1, ...],
     "score": float, "box": [x, y, w, h], "idx": track id}

For video input ``k`` is the 0-based frame index (AlphaPose ``alphapose/utils/detector.py``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from pcnet.stages.core.conventions import MAX_ABS_COORDINATE, get_layout

from .registry import register_2d
from .types import AdapterError, Keypoints2D
from .validate import as_path, checked_keypoints, frame_count_for, iter_json_array, json_numbers, layout_from_count

# Keypoints per detection -> layout. 133 (COCO-WholeBody) starts with COCO-17 and 136
# (Halpe-136) with the 26 Halpe body joints, so those keep only their body part.
_LAYOUT_BY_COUNT = {17: "coco17", 26: "halpe26", 133: "coco17", 136: "halpe26"}
_IMAGE_ID = re.compile(r"(\d{1,18})\.[A-Za-z0-9]+")


def _frame_index(p: Path, i: int, image_id: Any) -> int:
    if isinstance(image_id, int) and not isinstance(image_id, bool) and image_id >= 0:
        return image_id
    # Only strings are parsed: str(3.5) would read as frame 3. 18 digits keep int() far
    # from Python's digit limit; frame_count_for bounds the value.
    m = _IMAGE_ID.fullmatch(image_id) if isinstance(image_id, str) else None
    if m is None:
        raise AdapterError(p, f"[{i}].image_id", "'<k>.jpg' or an integer k, a 0-based frame index of at most 18 digits",
                           repr(image_id)[:80])
    return int(m.group(1))


def _score(p: Path, i: int, score: Any, kp: np.ndarray) -> tuple[float, bool]:
    """(detection score, whether it was missing). A missing or non-finite score is unknown:
    the mean finite keypoint confidence stands in (0 when there is none)."""
    if score is not None and (isinstance(score, bool) or not isinstance(score, (int, float))):
        raise AdapterError(p, f"[{i}].score", "a number", repr(score)[:80])
    if score is not None:
        try:
            value = float(score)
        except OverflowError:
            raise AdapterError(p, f"[{i}].score", "a number within float range", "a larger integer") from None
        if math.isfinite(value):
            return value, False
    conf = kp[:, 2][np.isfinite(kp[:, 2])]
    if not conf.size:
        return 0.0, True
    with np.errstate(over="ignore"):  # scores near 1e308 sum to inf, still the largest
        return float(conf.mean()), True


def _track_id(p: Path, i: int, idx: Any) -> int | None:
    """AlphaPose writes ``idx`` as an int track id with ``--pose_track``/PoseFlow; without a
    tracker it writes the pose-NMS proposal ids as a (nested) list such as ``[0.0]`` or
    ``[[0.0], [0.0]]`` (one element per merged proposal). The first id is used then."""
    if idx is None:
        return None
    flat = idx
    while isinstance(flat, list):
        if not flat:
            return None
        flat = flat[0]
    if isinstance(flat, bool) or not isinstance(flat, (int, float)) or (isinstance(flat, float) and not math.isfinite(flat)):
        raise AdapterError(p, f"[{i}].idx", "an integer track id or a list of ids", repr(idx)[:80])
    return int(flat)


TOP_LEVEL = "a list of detections (AlphaPose results JSON, AlphaPose docs/output.md)"


@dataclass
class _Scan:
    """Pass 1 over the file: what choosing the track and sizing the output needs, no keypoints."""

    count: int | None = None
    entries: int = 0
    max_frame: int = -1
    list_idx: bool = False
    missing_score: bool = False
    #: best detection score per (track, frame); the file order decides only exact ties
    best: dict = field(default_factory=dict)
    duplicates: dict = field(default_factory=dict)


def _detections(p: Path, items: Iterator[Any], scan: _Scan) -> Iterator[tuple[int, int | None, float, np.ndarray]]:
    """``(frame, track, score, keypoints (K, 3) float64)`` of every detection, checked, with
    ``scan`` updated as they come (the file's top-level items, :func:`iter_json_array`)."""
    for i, det in enumerate(items):
        if not isinstance(det, dict) or "image_id" not in det or "keypoints" not in det:
            got = f"keys {sorted(det)[:6]}" if isinstance(det, dict) else type(det).__name__
            raise AdapterError(p, f"[{i}]", "a detection with 'image_id' and 'keypoints'", got)
        kp = det["keypoints"]
        if not isinstance(kp, list):
            raise AdapterError(p, f"[{i}].keypoints", "a flat list of numbers x1,y1,c1,...", type(kp).__name__)
        if len(kp) % 3:
            raise AdapterError(p, f"[{i}].keypoints", "a multiple of 3 values (x, y, score per joint)", f"{len(kp)} values")
        n = len(kp) // 3
        if scan.count is None:
            layout_from_count(p, f"[{i}].keypoints", n, _LAYOUT_BY_COUNT)
            scan.count = n
        elif n != scan.count:
            raise AdapterError(p, f"[{i}].keypoints", f"{3 * scan.count} values like the first detection", f"{len(kp)}")
        arr = json_numbers(p, f"[{i}].keypoints", kp).reshape(n, 3)
        score, no_score = _score(p, i, det.get("score"), arr)
        scan.missing_score |= no_score
        scan.list_idx |= isinstance(det.get("idx"), list)
        frame, track = _frame_index(p, i, det["image_id"]), _track_id(p, i, det.get("idx"))
        scan.entries += 1
        scan.max_frame = max(scan.max_frame, frame)
        yield frame, track, score, arr


def _scan(p: Path) -> _Scan:
    """Pass 1: check every detection and keep each track's best score per frame."""
    scan = _Scan()
    for frame, track, score, _ in _detections(p, iter_json_array(p, TOP_LEVEL), scan):
        per_frame = scan.best.setdefault(track, {})
        if frame in per_frame:
            scan.duplicates.setdefault(track, set()).add(frame)
            if score <= per_frame[frame]:
                continue
        per_frame[frame] = score
    if not scan.entries:
        raise AdapterError(p, "top level", "at least one detection", "an empty list")
    return scan


#: float32's largest value: a keypoint coordinate beyond it cannot be held in the float32
#: output (it would become inf, i.e. missing) and is refused as beyond the pixel bound.
_FLOAT32_MAX = float(np.finfo(np.float32).max)


def _collect(p: Path, track: int | None, best: dict[int, float], points: np.ndarray, layout: str) -> None:
    """Pass 2: the chosen track's best detection per frame into ``points`` ``(T, J, 3)``
    float32: the first detection in file order with the frame's best score, as pass 1 kept it."""
    taken = np.zeros(len(points), bool)
    n_joints = points.shape[1]
    for frame, t, score, kp in _detections(p, iter_json_array(p, TOP_LEVEL), _Scan()):
        if t != track or taken[frame] or score != best[frame]:
            continue
        kp = kp[:n_joints]
        huge = np.isfinite(kp[:, :2]) & (np.abs(kp[:, :2]) > _FLOAT32_MAX)
        if huge.any():
            j = int(np.argwhere(huge)[0][0])
            raise AdapterError(p, f"keypoints (frame {frame}, joint {get_layout(layout).joints[j]})",
                               f"|coordinate| <= {MAX_ABS_COORDINATE['px']:g} px", f"{kp[j, :2][huge[j]][0]:.4g}")
        # A confidence beyond float32 is clipped at its largest value (then to 1); inf and NaN
        # stay non-finite: missing.
        points[frame] = np.where(np.isfinite(kp), np.clip(kp, -_FLOAT32_MAX, _FLOAT32_MAX), kp)
        taken[frame] = True


def load_alphapose(path: str | Path, person: int | None = None, num_frames: int | None = None,
                   frame_count: int | None = None) -> Keypoints2D:
    """Read an AlphaPose results JSON (``alphapose-results.json``) into ``Keypoints2D``.

    Args:
        path: the JSON file.
        person: track id (the ``idx`` field) to keep. ``None`` keeps the track with the
            highest summed score over the sequence, where a track's score in one frame is its
            best detection ``score`` there (so duplicate detections do not count twice);
            ties go to the lower id. Entries without ``idx`` form one track (id ``None``).
        num_frames: length ``T`` of the output; default: largest frame index + 1.
        frame_count: the video's frame count, when known (the pipeline passes it): every
            frame index must be below it. Without it, a frame index above
            ``100 * detections + 10000`` is refused as implausible for the file's size
            (:func:`~pcnet.adapters.validate.frame_count_for`), so a damaged ``image_id``
            never allocates gigabytes. It does not change ``T``.

    Returns:
        ``Keypoints2D`` with ``points`` float32 ``(T, J, 3)`` (x_px, y_px, confidence),
        layout ``coco17`` (51 values per detection) or ``halpe26`` (78 values; 399 and 408
        values keep their first 17 / 26 body joints), ``track_id`` the chosen id.
        Frames with no detection of the chosen track are NaN. When a frame has several
        detections of that track (AlphaPose without a tracker gives every person the same
        ``idx``), the one with the highest ``score`` is kept. Confidences are clipped to
        [0, 1]: AlphaPose's keypoint scores are not normalised (its docs give [0, 6] for
        COCO; the real files here reach 1.13).

    Raises:
        AdapterError: missing/empty/invalid JSON; not a list of detections (e.g. an MMPose
            file); an ``image_id`` that is neither ``<k>.<ext>`` nor a non-negative integer ``k``
            (``k`` the 0-based frame index); a keypoint count other than
            17/26/133/136 joints; keypoints that are not numbers; an unknown ``person``; a
            frame index ``>= num_frames``, ``>= frame_count`` or implausible without it;
            ``|x|``/``|y|`` beyond 1e5 px (naming frame and joint); no finite keypoint.
            ``inf`` and ``NaN`` values are missing data: the joint is NaN.

    Source of the format facts: MVIG-SJTU/AlphaPose ``docs/output.md`` and its writer
    ``alphapose/utils/pPose_nms.py`` ``write_json``; MotionBERT's reader
    (``lib/data/dataset_wild.py`` ``read_input``) ignores ``image_id``, which is why this
    adapter groups by it.
    """
    p = as_path(path)
    if person is not None and (isinstance(person, bool) or not isinstance(person, int)):
        raise AdapterError(p, "person", "an integer track id or None", repr(person))
    # Two passes over the file, so that only the chosen track's keypoints are ever held (a
    # long file's every detection would be GBs): scores per track and frame, then keypoints.
    scan = _scan(p)
    best, duplicates, count = scan.best, scan.duplicates, scan.count
    totals = {t: sum(frames.values()) for t, frames in best.items()}
    if person is not None:
        if person not in best:
            known = sorted(t for t in best if t is not None)
            raise AdapterError(p, "idx", f"track id person={person} to be present", f"track ids {known}")
        track = person
        how = f"track {person} chosen by person="
    else:
        # Highest summed score first, then the lower id; id None sorts last.
        track = min(best, key=lambda t: (-totals[t], t is None, t if t is not None else 0))
        how = f"track {track} chosen as the highest summed per-frame score ({totals[track]:.1f} over {len(best[track])} frames)"
        if len(best) > 1:
            others = ", ".join(f"{t}: {totals[t]:.1f}" for t in sorted(best, key=lambda t: (t is None, t or 0)) if t != track)
            how += f"; other tracks {others}"

    num_frames = frame_count_for(p, "image_id", scan.max_frame, scan.entries, frame_count, num_frames)
    layout = _LAYOUT_BY_COUNT[count]
    n_joints = get_layout(layout).num_joints
    points = np.full((num_frames, n_joints, 3), np.nan, np.float32)
    _collect(p, track, best[track], points, layout)
    found = len(best[track])
    points, raw_max = checked_keypoints(p, "keypoints", points, layout, in_place=True)

    notes = [f"AlphaPose results JSON (AlphaPose docs/output.md), {count} keypoints -> {layout}", how]
    if count != n_joints:
        notes.append(f"kept the first {n_joints} of {count} joints (body part)")
    if scan.list_idx:
        notes.append("idx is list-form (AlphaPose without a tracker: pose-NMS proposal ids, not a real track); first id used")
    if scan.missing_score:
        notes.append("entries without 'score' scored by their mean keypoint confidence")
    dup = sorted(duplicates.get(track, ()))
    if dup:
        notes.append(f"frames with several detections of track {track}: {dup}; highest score kept")
    missing = num_frames - found
    if missing:
        notes.append(f"{missing} of {num_frames} frames without a detection -> NaN")
    notes.append(f"confidence clipped to [0, 1] (raw max {raw_max:.3f})")
    choice = how if len(best) > 1 or person is not None else ""
    if dup:  # several people under one id (no tracker): the highest score per frame
        untracked = ("; AlphaPose ran without a tracker (list-form idx, one id for everyone), so --person cannot "
                     "choose another: its --pose_track option (AlphaPose trackers/README.md) follows each person"
                     if scan.list_idx else "")
        choice = "; ".join(c for c in (choice, f"{len(dup)} frame{'s' * (len(dup) != 1)} with several detections of "
                                                 f"track {track}: the highest-scored one kept{untracked}") if c)
    return Keypoints2D(points, layout, str(p), track_id=track, notes="; ".join(notes), choice=choice)


@register_2d("alphapose", records_fps=False, multi_track="AlphaPose idx")
class AlphaPoseAdapter:
    """Registry entry for :func:`load_alphapose` (options: ``person``, ``num_frames``,
    ``frame_count``)."""

    def load(self, path: str | Path, *, person: int | None = None, num_frames: int | None = None,
             frame_count: int | None = None) -> Keypoints2D:
        return load_alphapose(path, person=person, num_frames=num_frames, frame_count=frame_count)
