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

So the world landmarks have the OpenCV camera's axis orientation (x right, y down, z forward),
as MediaPipe's maintainers state (google-ai-edge/mediapipe issue #4205). They are
camera-aligned, not gravity-aligned, and carry no global translation.

They are aligned with the camera MediaPipe's model sees, though: BlazePose's region of
interest is a crop centred on the mid-hip (Bazarevsky et al., "BlazePose: On-device Real-time
Body Pose tracking", CVPR Workshops 2020, section 3), and MediaPipe takes the world landmarks
out of that crop by undoing only the crop's in-plane rotation
(``mediapipe/calculators/util/world_landmark_projection_calculator.cc``), so they are seen by a
virtual camera looking along the ray through the mid-hip pixel, not along the real optical
axis (:mod:`pcnet.stages.core.perspective`). :func:`load_mediapipe_3d` turns each frame from that
virtual camera into the real one (``x = R_ray @ x_world``). Measured on the four calibrated
lab cameras of ``pose2sim_gravity`` (true intrinsics ``K`` in the file): MediaPipe's trunk
direction is 13.1 / 13.1 / 13.2 / 5.7 deg from gravity as delivered and 9.0 / 8.0 / 10.7 / 4.4
after the turn, each camera gaining nearly its whole ray angle (4.4 / 5.2 / 2.6 / 2.8 deg), as
a virtual camera predicts (``python -m benchmarks.gravity_benchmark``, "trunk" rows).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import BLAZEPOSE33, PELVIS
from pcnet.stages.core.perspective import (
    DEFAULT_FOCAL_35MM,
    focal_px_from_35mm,
    focal_px_problem,
    intrinsics,
    virtual_camera_rotation,
)

from .registry import register_2d, register_3d
from .types import AdapterError, Keypoints2D, Poses3D
from .validate import (
    NumpyArchive,
    archive_hint,
    checked_keypoints,
    checked_poses,
    describe_keys,
    nonfinite_frames,
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


def _read(path: str | Path, key: str) -> tuple[Path, np.ndarray, str, dict]:
    """(path, float32 array ``key`` (T, 33, 3) with inf as NaN, metadata text, scalars: ``fps``,
    ``width``, ``height`` (each a float or None))."""
    p = require_file(path, "a MediaPipe results .npz")
    archive = open_numpy(p)
    if not isinstance(archive, NumpyArchive):
        raise AdapterError(p, "content", "a .npz archive with keypoints_2d and world_3d", "a single .npy array")
    with archive:
        if key not in archive.files:
            raise AdapterError(p, key, f"an array named {key!r} (MediaPipe npz)",
                               describe_keys(archive.files) + archive_hint(archive.files))
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
    return p, arr, meta, scalars


def load_mediapipe_2d(path: str | Path) -> Keypoints2D:
    """Read ``keypoints_2d`` of a MediaPipe npz into ``Keypoints2D``.

    Returns:
        ``points`` float32 ``(T, 33, 3)``: x_px, y_px, MediaPipe ``visibility`` (a [0, 1]
        likelihood that the landmark is visible, not a detection score; clipped to [0, 1]
        defensively); layout ``blazepose33``; frames without a person stay NaN, and so
        does any joint with a non-finite value. ``fps`` is the file's ``fps`` field when
        present, else ``None``; ``image_size`` its ``width`` and ``height`` when both are.

    Raises:
        AdapterError: missing file, not an npz, no ``keypoints_2d``, a ``layout`` other than
            ``blazepose33``, wrong shape or dtype, all NaN, an ``fps``/``width``/``height``
            that is not one positive finite number, ``|x|``/``|y|`` beyond 1e5 px (naming
            frame and joint).
    """
    p, arr, meta, scalars = _read(path, "keypoints_2d")
    fps = scalars["fps"]
    points, raw_max = checked_keypoints(p, "keypoints_2d", arr, "blazepose33")
    empty = int(np.isnan(points).all(axis=(1, 2)).sum())
    notes = (f"MediaPipe BlazePose-33 keypoints_2d ({meta}); confidence = visibility "
             f"(raw max {raw_max:.3f}); {empty} frames without a person -> NaN")
    size = None if scalars["width"] is None or scalars["height"] is None else \
        (int(round(scalars["width"])), int(round(scalars["height"])))
    return Keypoints2D(points, "blazepose33", str(p), track_id=None, notes=notes, fps=fps, image_size=size)


def load_mediapipe_3d(path: str | Path, *, focal_px: float | None = None, real_camera: bool = True) -> Poses3D:
    """Read ``world_3d`` (MediaPipe pose_world_landmarks) into ``Poses3D``.

    Args:
        path: the MediaPipe ``.npz``.
        focal_px: the video's focal length in pixels (principal point at the image centre);
            ``None``: the file's ``K`` when it has one, else a smartphone main camera's
            (:data:`pcnet.stages.core.perspective.DEFAULT_FOCAL_35MM` mm, 35 mm equivalent).
        real_camera: turn each frame from the virtual camera looking at the mid-hip into the
            real camera (module docstring); ``False`` keeps the landmarks as delivered.

    Returns:
        ``joints`` float32 ``(T, 33, 3)``, metres, real camera frame (x right, y down, z away
        from the camera), each frame turned by the rotation from the virtual camera through
        its mid-hip pixel (``keypoints_2d`` of the same file; a frame without one takes the
        nearest frames' pixel, interpolated) to the real camera
        (:func:`pcnet.stages.core.perspective.virtual_camera_rotation`); origin the mid-hip
        point (H36M's pelvis after ``remap_to_h36m``); layout ``blazepose33`` (the caller
        remaps); frames without a person stay NaN, ``inf`` becomes NaN. ``fps`` is the file's
        ``fps`` field when present, else ``None``. ``summary_note`` says which focal length
        was used and how large the turn was.

    Raises:
        AdapterError: missing file, not an npz, no ``world_3d``, a ``layout`` other than
            ``blazepose33``, wrong shape or dtype, all NaN, an ``fps``/``width``/``height``
            that is not one positive finite number, a coordinate beyond 100 m (naming frame
            and joint); with ``real_camera``: a ``keypoints_2d`` whose shape differs from
            ``world_3d``'s, a ``K`` that is not a (3, 3) finite matrix with positive focal
            lengths, or a ``focal_px`` that is not a positive finite number or comes without
            ``width``/``height``. A file without ``keypoints_2d`` (or without a mid-hip pixel
            in any frame with a pose), or without ``K`` and image size, is read as delivered,
            and ``summary_note`` says so.
    """
    p, arr, meta, scalars = _read(path, "world_3d")
    # the file's inf/NaN; frames without any value are its "no person", said in the notes
    nonfinite = nonfinite_frames(arr, BLAZEPOSE33.joints, skip_empty_frames=True)
    arr = checked_poses(p, "world_3d", arr, "blazepose33", "m")
    empty = int(np.isnan(arr).all(axis=(1, 2)).sum())
    notes = (f"MediaPipe BlazePose-33 world landmarks ({meta}); metres, origin mid-hip; axes already "
             "x right / y down / z away from the camera (checked on real data); "
             f"camera-aligned, not gravity-aligned; {empty} frames without a person -> NaN")
    summary_note, turn_median, file_K = "", 0.0, None
    if real_camera:
        with open_numpy(p) as archive:  # _read checked that it is an npz
            K = archive["K"] if "K" in archive.files else None
            keypoints = archive["keypoints_2d"] if "keypoints_2d" in archive.files else None
        K, focal_source = _intrinsics(p, scalars, focal_px, K)
        file_K = K if focal_source == FILE_K else None
        hip_px, filled = _mid_hip_pixels(p, arr, keypoints)
        if K is None or hip_px is None:
            summary_note = ("MediaPipe world landmarks left in MediaPipe's virtual camera at the mid-hip, not turned "
                            f"into the real camera: {focal_source if K is None else filled} (a tilt error of up to "
                            "the person's angle off the image centre)")
        else:
            R = virtual_camera_rotation(hip_px, K)
            arr = np.einsum("tij,tkj->tki", R, arr).astype(np.float32)
            turn = np.degrees(np.arccos(np.clip(R[:, 2, 2], -1.0, 1.0)))
            turn = turn[np.isfinite(turn)]
            turn_median = float(np.median(turn))
            summary_note = (f"MediaPipe world landmarks turned from the virtual camera at the mid-hip into the real camera "
                            f"(focal length {K[0, 0]:.0f} px, {focal_source}; turn median {turn_median:.1f}, "
                            f"max {turn.max():.1f} deg" + (f"; mid-hip pixel interpolated in {filled} frames" if filled else "")
                            + ")")
        notes += "; " + summary_note
    return Poses3D(arr, "blazepose33", units="m", source=str(p), notes=notes, fps=scalars["fps"],
                   summary_note=summary_note, frame_turn_deg=turn_median, nonfinite=nonfinite, camera_matrix=file_K)


#: Where the focal length came from when the file's own ``K`` is used.
FILE_K = "the file's K"


def holds_keypoints_2d(path: str | Path) -> bool:
    """Whether the MediaPipe archive ``path`` (read by :func:`load_mediapipe_3d` already) holds
    the ``keypoints_2d`` that :func:`load_mediapipe_2d` reads."""
    with open_numpy(path) as archive:
        return "keypoints_2d" in archive.files


def focal_problems(focal_px: object = None) -> list[tuple[str, str, str]]:
    """``[(option, expected, found)]`` when ``focal_px`` is given but not a positive finite
    number of pixels (no file needed: a batch manifest's rows are checked before any runs)."""
    if focal_px is None or (not isinstance(focal_px, bool) and isinstance(focal_px, (int, float))
                            and math.isfinite(focal_px) and focal_px > 0):
        return []
    return [("focal_px", "a positive finite focal length in pixels", repr(focal_px))]


def _intrinsics(p: Path, scalars: dict, focal_px: float | None, K: np.ndarray | None) -> tuple[np.ndarray | None, str]:
    """``(K (3, 3), where its focal length came from)``: ``focal_px`` with the image centre,
    else the file's ``K`` (``None`` when it has none), else the default smartphone focal
    length with the image centre; ``(None, why)`` without ``K`` and without the image size."""
    width, height = scalars["width"], scalars["height"]
    if focal_px is not None:
        for option, expected, got in focal_problems(focal_px):
            raise AdapterError(p, option, expected, got)
        if width is None or height is None:
            raise AdapterError(p, "width/height", "the image size, to place the principal point for --focal-px",
                               "no such field")
        problem = focal_px_problem(float(focal_px), width, height)
        if problem is not None:
            raise AdapterError(p, "focal_px", *problem)
        return intrinsics(width, height, float(focal_px)), "given"
    if K is not None:
        K = require_numeric(p, "K", K).astype(np.float64)
        if K.shape != (3, 3) or not np.isfinite(K).all() or K[0, 0] <= 0 or K[1, 1] <= 0:
            found = f"shape {K.shape}" + (f", diagonal {np.diag(K).tolist()}" if K.shape == (3, 3) else "")
            raise AdapterError(p, "K", "a (3, 3) finite camera matrix with positive focal lengths", found)
        return K, FILE_K
    if width is None or height is None:
        return None, "the file has neither K nor width/height"
    focal = focal_px_from_35mm(width, height)
    return intrinsics(width, height, focal), (f"assumed: a phone's {DEFAULT_FOCAL_35MM:g} mm equivalent; "
                                              "give --focal-px for another camera")


def _mid_hip_pixels(p: Path, world: np.ndarray, keypoints: np.ndarray | None) -> tuple[np.ndarray | None, int | str]:
    """Each frame's mid-hip pixel ``(T, 2)`` from the same file's ``keypoints_2d`` (``None``
    when it has none): the H36M pelvis of BlazePose-33 (the mean of its two hips), linearly
    interpolated over frames with a pose but no pixel (NaN where there is no pose), and how
    many frames were interpolated; ``(None, why)`` where there is no usable pixel."""
    if keypoints is None:
        return None, "the file has no keypoints_2d"
    keypoints = require_numeric(p, "keypoints_2d", keypoints)
    if keypoints.ndim != 3 or keypoints.shape[1:] != (33, 3) or len(keypoints) != len(world):
        raise AdapterError(p, "keypoints_2d", f"shape ({len(world)}, 33, 3) like world_3d", f"shape {keypoints.shape}")
    with np.errstate(invalid="ignore"):
        pixel = keypoints[:, list(BLAZEPOSE33.to_h36m[PELVIS]), :2].astype(np.float64).mean(axis=1)
    known = np.isfinite(pixel).all(axis=1)
    posed = np.isfinite(world).any(axis=(1, 2))
    if not (known & posed).any():
        return None, "keypoints_2d has no mid-hip pixel in any frame with a pose"
    frames = np.arange(len(pixel))
    for axis in (0, 1):
        pixel[:, axis] = np.interp(frames, frames[known], pixel[known, axis])
    pixel[~posed] = np.nan
    return pixel, int((posed & ~known).sum())


@register_2d("mediapipe")
class MediaPipe2DAdapter:
    """Registry entry for :func:`load_mediapipe_2d` (no options)."""

    def load(self, path: str | Path) -> Keypoints2D:
        return load_mediapipe_2d(path)


@register_3d("mediapipe")
class MediaPipe3DAdapter:
    """Registry entry for :func:`load_mediapipe_3d` (option ``focal_px``)."""

    option_problems = staticmethod(focal_problems)

    def load(self, path: str | Path, *, focal_px: float | None = None) -> Poses3D:
        return load_mediapipe_3d(path, focal_px=focal_px)
