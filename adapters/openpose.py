"""OpenPose ``--write_json`` folder -> :class:`Keypoints2D` (OpenPose ``doc/02_output.md``).

OpenPose writes one file per frame, ``<video>_<12-digit frame>_keypoints.json``::

    {"version": 1.3, "people": [{"person_id": [-1], "pose_keypoints_2d": [x, y, c, ...], ...}]}

Undetected joints are ``0, 0, 0``. Pose2Sim/Sports2D write the same schema with their own
model's layout, so the layout comes from the joint count (or ``layout=``), not the key name.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import get_layout

from .registry import register_2d
from .types import AdapterError, Keypoints2D
from .validate import as_path, checked_keypoints, frame_count_for, json_numbers, layout_from_count, read_json

_LAYOUT_BY_COUNT = {25: "body25", 26: "halpe26", 33: "blazepose33", 17: "coco17"}
# The frame number is the digit run right before "_keypoints.json" (12 digits for OpenPose).
_FRAME_NUMBER = re.compile(r"(\d+)_keypoints\.json$")
# Longer digit runs are no frame number; the bound also keeps int() cheap.
_MAX_DIGITS = 18


def _frame_files(folder: Path) -> list[tuple[int, Path]]:
    if not folder.exists():
        raise AdapterError(folder, "path", "a folder of *_keypoints.json files", "no such folder")
    if not folder.is_dir():
        raise AdapterError(folder, "path", "a folder of *_keypoints.json files (OpenPose --write_json)", "a file")
    files = []
    for f in folder.glob("*_keypoints.json"):
        m = _FRAME_NUMBER.search(f.name)
        if m is None or len(m.group(1).lstrip("0")) > _MAX_DIGITS:
            raise AdapterError(f, "file name", f"'<video>_<frame number of at most {_MAX_DIGITS} digits>_keypoints.json'",
                               repr(f.name))
        files.append((int(m.group(1)), f))
    if not files:
        raise AdapterError(folder, "*_keypoints.json", "at least one OpenPose per-frame JSON file", "none")
    files.sort()
    for (a, fa), (b, fb) in zip(files, files[1:]):
        if a == b:
            raise AdapterError(fb, "file name", f"one file per frame number (also {fa.name})", f"frame {b} twice")
    return files


def load_openpose(path: str | Path, layout: str | None = None, num_frames: int | None = None,
                  frame_count: int | None = None) -> Keypoints2D:
    """Read a folder of OpenPose-schema per-frame JSON files into ``Keypoints2D``.

    Args:
        path: the folder written by ``--write_json`` (or Pose2Sim/Sports2D).
        layout: force a layout name; default: inferred from the joint count
            (25 -> ``body25``, 26 -> ``halpe26``, 33 -> ``blazepose33``, 17 -> ``coco17``).
            OpenPose's 18-joint COCO model is not supported (no such layout in pcnet).
        num_frames: length ``T``; default: largest frame number + 1.
        frame_count: the video's frame count, when known (the pipeline passes it): every
            frame number must be below it. Without it, a frame number above
            ``100 * files + 10000`` is refused as implausible
            (:func:`~pcnet.adapters.validate.frame_count_for`). It does not change ``T``.

    Returns:
        ``Keypoints2D``: ``points`` float32 ``(T, J, 3)``. Row ``k`` is the file with frame
        number ``k`` (OpenPose numbers from 0); frames without a file or without people are
        NaN. Joints with confidence 0 (OpenPose writes ``0, 0, 0`` for undetected joints) are
        NaN. Per frame the person with the highest summed confidence is kept (OpenPose's
        ``person_id`` is ``-1`` without tracking, so there is nothing to follow); confidence
        is clipped to [0, 1]. ``track_id`` is ``None``.

    Raises:
        AdapterError: missing folder, no ``*_keypoints.json`` files, a file that is not
            JSON or has no ``people`` list, a keypoint list whose length is not a multiple of
            3, holds values that are not numbers, or whose joint count differs between files
            or from ``layout``; a frame number ``>= num_frames``, ``>= frame_count`` or
            implausible without it; ``|x|``/``|y|`` beyond 1e5 px (naming frame and joint);
            nothing finite. The message names the offending file. ``inf``/``NaN`` values are
            missing data: the joint is NaN.

    Source of the format facts: CMU-Perceptual-Computing-Lab/openpose (commit 5c5d965)
    ``doc/02_output.md`` (JSON schema; undetected joints are ``0, 0, 0``, hence 0 score =
    missing), ``src/openpose/producer/videoCaptureReader.cpp`` L78 (12-digit frame number),
    ``include/openpose/filestream/wPeopleJsonSaver.hpp`` L67 (``_keypoints`` suffix).
    """
    folder = as_path(path, "an OpenPose folder or JSON file")
    if layout is not None:
        try:
            if not isinstance(layout, str):
                raise ValueError(layout)
            layout = get_layout(layout).name
        except ValueError as exc:
            raise AdapterError(folder, "layout", "a known layout name", repr(layout)) from exc
    files = _frame_files(folder)
    count = None
    chosen: dict[int, np.ndarray] = {}
    crowded = 0  # frames holding more than one body
    for frame, f in files:
        data = read_json(f)
        if not isinstance(data, dict) or not isinstance(data.get("people"), list):
            got = f"keys {sorted(data)[:6]}" if isinstance(data, dict) else type(data).__name__
            raise AdapterError(f, "people", "an OpenPose frame object with a 'people' list", got)
        best, best_sum, bodies = None, -np.inf, 0
        for i, person in enumerate(data["people"]):
            kp = person.get("pose_keypoints_2d") if isinstance(person, dict) else None
            if not isinstance(kp, list):
                raise AdapterError(f, f"people[{i}].pose_keypoints_2d", "a list of numbers", type(kp).__name__)
            if not kp:
                continue  # people entries with only face/hand keypoints carry no body
            bodies += 1
            if len(kp) % 3:
                raise AdapterError(f, f"people[{i}].pose_keypoints_2d", "a multiple of 3 values", f"{len(kp)} values")
            n = len(kp) // 3
            if count is None:
                if layout is None:
                    layout = layout_from_count(f, f"people[{i}].pose_keypoints_2d", n, _LAYOUT_BY_COUNT)
                elif get_layout(layout).num_joints != n:
                    raise AdapterError(f, f"people[{i}].pose_keypoints_2d",
                                       f"{get_layout(layout).num_joints} joints for layout={layout!r}", f"{n} joints")
                count = n
            elif n != count:
                raise AdapterError(f, f"people[{i}].pose_keypoints_2d", f"{count} joints like the other files", f"{n} joints")
            arr = json_numbers(f, f"people[{i}].pose_keypoints_2d", kp).reshape(n, 3)
            conf = arr[:, 2][np.isfinite(arr[:, 2])]
            with np.errstate(over="ignore"):  # sums near 1e308 overflow to inf, still the largest
                total = float(conf.sum())
            if total > best_sum:
                best, best_sum = arr, total
        crowded += bodies > 1
        if best is not None:
            chosen[frame] = best
    if count is None:
        raise AdapterError(folder, "people", "at least one person in some frame", f"no people in {len(files)} files")

    max_frame = files[-1][0]
    num_frames = frame_count_for(files[-1][1], "frame number", max_frame, len(files), frame_count, num_frames)
    layout = get_layout(layout).name
    points = np.full((num_frames, count, 3), np.nan)
    for frame, arr in chosen.items():
        points[frame] = arr
    undetected = points[..., 2] == 0
    points[undetected] = np.nan
    if not np.isfinite(points).any():
        raise AdapterError(folder, "pose_keypoints_2d", "some detected joints", "only 0,0,0 joints")
    points, raw_max = checked_keypoints(folder, "pose_keypoints_2d", points, layout)

    empty = int(np.isnan(points).all(axis=(1, 2)).sum())
    notes = [f"OpenPose per-frame JSON (OpenPose doc/02_output.md), {len(files)} files, {count} joints -> {layout}",
             "per frame the person with the highest summed confidence",
             f"{int(undetected.sum())} joints with confidence 0 -> NaN"]
    if empty:
        notes.append(f"{empty} of {num_frames} frames without a file or person -> NaN")
    notes.append(f"confidence clipped to [0, 1] (raw max {raw_max:.3f})")
    # OpenPose has no track ids: the kept person may change from frame to frame
    choice = (f"per frame the person with the highest summed confidence, in {crowded} frame{'s' * (crowded != 1)} "
              f"holding several people (OpenPose has no track ids: --person cannot follow one)") if crowded else ""
    return Keypoints2D(points, layout, str(folder), track_id=None, notes="; ".join(notes), choice=choice)


@register_2d("openpose", records_fps=False, folder_input=True)
class OpenPoseAdapter:
    """Registry entry for :func:`load_openpose` (options: ``layout``, ``num_frames``,
    ``frame_count``)."""

    def load(self, path: str | Path, *, layout: str | None = None, num_frames: int | None = None,
             frame_count: int | None = None) -> Keypoints2D:
        return load_openpose(path, layout=layout, num_frames=num_frames, frame_count=frame_count)
