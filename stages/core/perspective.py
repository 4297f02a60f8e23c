"""Pinhole intrinsics and the virtual camera of a crop-based 3D pose model.

A model that lifts a person from an image crop (MediaPipe BlazePose's world landmarks) sees
the person through a *virtual camera* looking along the ray through the crop's centre: it
cannot know where in the full image the crop was, so its 3D output is oriented relative to
that ray, not to the real camera's optical axis. For a person off the image centre the two
differ by the angle between the optical axis and the ray (a few degrees in a typical
recording, tens near the edge of a wide-angle view). The virtual camera is the one of
Yu et al., "PCLs: Geometry-aware Neural Reconstruction of 3D Pose with Perspective Crop
Layers", CVPR 2021 (section 3), and the full-frame correction the one CLIFF applies to
crop-based estimates (Li et al., "CLIFF: Carrying Location Information in Full Frames into
Human Pose and Shape Estimation", ECCV 2022, section 3.2).

Conventions: OpenCV camera frame (x right, y down, z forward), pixels ``(u, v)`` with the
origin at the image's top-left corner, ``K = [[f, 0, cx], [0, f, cy], [0, 0, 1]]``; rotation
matrices act on column vectors (``docs/CONVENTIONS.md``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from .errors import InputError

#: Diagonal of the 35 mm film frame (36 x 24 mm), in mm: the reference of a "35 mm equivalent"
#: focal length (CIPA DC-008 / Exif 2.3, tag FocalLengthIn35mmFilm: same diagonal angle of view).
FULL_FRAME_DIAGONAL_MM = math.hypot(36.0, 24.0)
#: The focal length assumed when a recording states none: a smartphone's main camera, whose
#: 35 mm equivalent is 24-28 mm on current phones (a horizontal field of view of about 70 deg
#: on 16:9 video). Override it with the recording's own value where known.
DEFAULT_FOCAL_35MM = 26.0


#: The shortest 35 mm-equivalent focal length (mm) of a rectilinear (pinhole) lens: 9 mm, 135 deg
#: across the diagonal, as the widest full-frame rectilinear lenses made (Venus Optics Laowa
#: 9 mm f/5.6 FF RL, 2019). A shorter one is a fisheye's, which no pinhole model describes, or
#: a focal length in millimetres given as pixels (a coach's ``--focal-px 26``).
WIDEST_RECTILINEAR_35MM = 9.0


def focal_px_problem(focal_px: float, width: float, height: float) -> tuple[str, str] | None:
    """``(expected, found)`` where ``focal_px`` (pixels) is shorter than any rectilinear
    lens's on a ``width`` x ``height`` px picture (:data:`WIDEST_RECTILINEAR_35MM`), else
    ``None``: the two halves of the caller's refusal, which names the option or field.

    Raises:
        InputError: a size that is not a positive finite number (:func:`focal_px_from_35mm`).
    """
    shortest = focal_px_from_35mm(width, height, WIDEST_RECTILINEAR_35MM)
    if focal_px >= shortest:
        return None
    equivalent = focal_px / math.hypot(width, height) * FULL_FRAME_DIAGONAL_MM
    expected = (f"a focal length in pixels of at least {shortest:.0f} px on this {width:g}x{height:g} picture (a "
                f"{WIDEST_RECTILINEAR_35MM:g} mm 35 mm equivalent, 135 deg across the diagonal: the widest "
                f"rectilinear lenses)")
    found = (f"{focal_px:g} px, a {equivalent:.2g} mm equivalent: a focal length in millimetres? In pixels it is the "
             f"35 mm-equivalent focal length x the picture's diagonal / 43.27 (a phone's {DEFAULT_FOCAL_35MM:g} mm: "
             f"{focal_px_from_35mm(width, height):.0f} px here)")
    return expected, found


def focal_px_from_35mm(width: float, height: float, focal_35mm: float = DEFAULT_FOCAL_35MM) -> float:
    """Focal length in pixels of an image ``width`` x ``height`` px whose lens has the 35 mm
    equivalent focal length ``focal_35mm`` (mm): ``f = focal_35mm / 43.27 * hypot(width, height)``
    (equal diagonal angle of view, CIPA DC-008 / Exif 2.3 FocalLengthIn35mmFilm).

    Raises:
        InputError: a size or focal length that is not a positive finite number.
    """
    for name, value in (("width", width), ("height", height), ("focal_35mm", focal_35mm)):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"focal_px_from_35mm: {name}: expected a positive finite number, got {value!r}")
    return focal_35mm / FULL_FRAME_DIAGONAL_MM * math.hypot(width, height)


def intrinsics(width: float, height: float, focal_px: float) -> np.ndarray:
    """``K`` ``(3, 3)`` float64 of a pinhole camera with square pixels, focal length
    ``focal_px`` (pixels) and the principal point at the image centre ``(width / 2, height / 2)``.

    Raises:
        InputError: a size or focal length that is not a positive finite number.
    """
    for name, value in (("width", width), ("height", height), ("focal_px", focal_px)):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"intrinsics: {name}: expected a positive finite number, got {value!r}")
    return np.array([[focal_px, 0.0, width / 2.0], [0.0, focal_px, height / 2.0], [0.0, 0.0, 1.0]])


def virtual_camera_rotation(pixels: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Rotations ``(N, 3, 3)`` float64 from the virtual camera looking through ``pixels`` to
    the real camera: ``x_camera = R @ x_virtual``.

    Args:
        pixels: ``(N, 2)`` image points ``(u, v)`` in pixels (the crop centres, e.g. each
            frame's mid-hip); a row with NaN gives a NaN rotation.
        K: ``(3, 3)`` intrinsics of the real camera.

    ``R`` turns the optical axis ``+z`` onto the unit ray ``K^-1 (u, v, 1)`` by the smallest
    rotation (about ``z x ray``), so the virtual camera has no roll of its own about its axis
    relative to the real one; at the principal point ``R`` is the identity.
    """
    pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
    rays = np.linalg.solve(np.asarray(K, np.float64), np.column_stack([pixels, np.ones(len(pixels))]).T).T
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    axis = np.column_stack([-rays[:, 1], rays[:, 0], np.zeros(len(rays))])  # z x ray
    sin = np.linalg.norm(axis, axis=1, keepdims=True)
    angle = np.arctan2(sin[:, 0], rays[:, 2])
    with np.errstate(invalid="ignore", divide="ignore"):
        rotvec = np.where(sin > 1e-12, axis / sin, 0.0) * angle[:, None]
    R = np.full((len(pixels), 3, 3), np.nan)
    ok = np.isfinite(rotvec).all(axis=1)
    if ok.any():
        R[ok] = Rotation.from_rotvec(rotvec[ok]).as_matrix()
    return R
