"""MediaPipe BlazePose-33 results (.npz) -> :class:`Keypoints2D` and :class:`Poses3D`.

MediaPipe has no file format of its own (its results are in-memory objects:
google-ai-edge/mediapipe ``mediapipe/tasks/python/vision/pose_landmarker.py``
``PoseLandmarkerResult``; ``docs/solutions/pose.md`` "Output"). pcnet reads the ``.npz``
written by ``shared/data/tools/mediapipe_extract.py`` (MediaPipe 0.10.21 Pose)::

    keypoints_2d  (T, 33, 3) float32  x_px, y_px, visibility
    world_3d      (T, 33, 3) float32  pose_world_landmarks: metres, origin mid-hip
    fps, width, height                scalars
    layout        "blazepose33"

Frames where MediaPipe found nobody are NaN rows in both arrays. MediaPipe tracks one person.

Axes of ``world_3d``, checked on the real file ``sports2d_demo/mediapipe_blazepose33.npz``
(frames 3-59: one person standing on a box, facing the camera):

* left hip at larger x than right hip in 93% of frames (left shoulder too), like the 2D
  keypoints (93%): +x is image right;
* nose above the ankles (smaller y) in 95%: +y is image down;
* nose nearer the camera than the mid-hip (smaller z) in 93%: +z points away from the camera.

So the world landmarks are already in the OpenCV camera orientation (x right, y down,
z forward), as MediaPipe's maintainers state (google-ai-edge/mediapipe
issue #4205), and the adapter applies the identity. They are camera-aligned, not
gravity-aligned, and carry no global translation.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .registry import register_2d, register_3d
from .types import AdapterError, Keypoints2D, Poses3D
from .validate import (
    NumpyArchive,
    checked_keypoints,
    checked_poses,
    describe_keys,
    open_numpy,
    require_file,
    require_numeric,
    require_some_finite,
)


def _positive_scalar(p: Path, archive: NumpyArchive, key: str) -> float | None:
    """Scalar ``key`` of the archive (``fps``, ``width``, ``height``) or ``None`` when absent."""
    if key not in archive.files:
        return None
    v = archive[key]
    if v.size != 1 or v.dtype.kind not in "iuf":
        raise AdapterError(p, key, "a single number", f"dtype {v.dtype}, shape {v.shape}")
    value = float(v.reshape(()))
    if not (math.isfinite(value) and value > 0):
        raise AdapterError(p, key, "a positive finite number", repr(value))
    return value


def _read(path: str | Path, key: str) -> tuple[Path, np.ndarray, str, float | None]:
    """(path, float32 array ``key`` (T, 33, 3) with inf as NaN, metadata text, fps or None)."""
    p = require_file(path, "a MediaPipe results .npz")
    archive = open_numpy(p)
    if not isinstance(archive, NumpyArchive):
        raise AdapterError(p, "content", "a .npz archive with keypoints_2d and world_3d", "a single .npy array")
    with archive:
        if key not in archive.files:
            raise AdapterError(p, key, f"an array named {key!r} (MediaPipe npz)", describe_keys(archive.files))
        if "layout" in archive.files:
            layout = archive["layout"]
            if layout.dtype.kind not in "US" or layout.size != 1 or str(layout.reshape(())) != "blazepose33":
                raise AdapterError(p, "layout", "'blazepose33'", f"{layout.dtype} {str(layout)[:40]!r}")
        arr = require_numeric(p, key, archive[key])
        scalars = {k: _positive_scalar(p, archive, k) for k in ("fps", "width", "height")}
    meta = ", ".join(f"{k}={v:g}" for k, v in scalars.items() if v is not None) or "no fps/width/height"
    if arr.ndim != 3 or arr.shape[1:] != (33, 3):
        raise AdapterError(p, key, "shape (T, 33, 3) BlazePose-33", f"shape {arr.shape}")
    require_some_finite(p, key, arr)
    return p, arr, meta, scalars["fps"]


def load_mediapipe_2d(path: str | Path) -> Keypoints2D:
    """Read ``keypoints_2d`` of a MediaPipe npz into ``Keypoints2D``.

    Returns:
        ``points`` float32 ``(T, 33, 3)``: x_px, y_px, MediaPipe ``visibility`` (a [0, 1]
        likelihood that the landmark is visible, not a detection score; clipped to [0, 1]
        defensively); layout ``blazepose33``; frames without a person stay NaN, and so
        does any joint with a non-finite value. ``fps`` is the file's ``fps`` field when
        present, else ``None``.

    Raises:
        AdapterError: missing file, not an npz, no ``keypoints_2d``, a ``layout`` other than
            ``blazepose33``, wrong shape or dtype, all NaN, an ``fps``/``width``/``height``
            that is not one positive finite number, ``|x|``/``|y|`` beyond 1e5 px (naming
            frame and joint).
    """
    p, arr, meta, fps = _read(path, "keypoints_2d")
    points, raw_max = checked_keypoints(p, "keypoints_2d", arr, "blazepose33")
    empty = int(np.isnan(points).all(axis=(1, 2)).sum())
    notes = (f"MediaPipe BlazePose-33 keypoints_2d ({meta}); confidence = visibility "
             f"(raw max {raw_max:.3f}); {empty} frames without a person -> NaN")
    return Keypoints2D(points, "blazepose33", str(p), track_id=None, notes=notes, fps=fps)


def load_mediapipe_3d(path: str | Path) -> Poses3D:
    """Read ``world_3d`` (MediaPipe pose_world_landmarks) into ``Poses3D``.

    Returns:
        ``joints`` float32 ``(T, 33, 3)``, metres, camera frame (x right, y down, z away
        from the camera: MediaPipe's world axes already are, see the module docstring for
        the check on real data; no flip applied), origin the mid-hip point as MediaPipe
        delivers it (which is H36M's pelvis after ``remap_to_h36m``); layout ``blazepose33``
        (the caller remaps); frames without a person stay NaN, ``inf`` becomes NaN. ``fps``
        is the file's ``fps`` field when present, else ``None``.

    Raises:
        AdapterError: missing file, not an npz, no ``world_3d``, a ``layout`` other than
            ``blazepose33``, wrong shape or dtype, all NaN, an ``fps``/``width``/``height``
            that is not one positive finite number, a coordinate beyond 100 m (naming frame
            and joint).
    """
    p, arr, meta, fps = _read(path, "world_3d")
    arr = checked_poses(p, "world_3d", arr, "blazepose33", "m")
    empty = int(np.isnan(arr).all(axis=(1, 2)).sum())
    notes = (f"MediaPipe BlazePose-33 world landmarks ({meta}); metres, origin mid-hip; axes already "
             "x right / y down / z away from the camera (checked on real data, identity applied); "
             f"camera-aligned, not gravity-aligned; {empty} frames without a person -> NaN")
    return Poses3D(arr, "blazepose33", units="m", source=str(p), notes=notes, fps=fps)


@register_2d("mediapipe")
class MediaPipe2DAdapter:
    """Registry entry for :func:`load_mediapipe_2d` (no options)."""

    def load(self, path: str | Path) -> Keypoints2D:
        return load_mediapipe_2d(path)


@register_3d("mediapipe")
class MediaPipe3DAdapter:
    """Registry entry for :func:`load_mediapipe_3d` (no options)."""

    def load(self, path: str | Path) -> Poses3D:
        return load_mediapipe_3d(path)
