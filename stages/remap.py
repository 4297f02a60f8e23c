"""Remap keypoints from any known layout to H36M-17, and mask low-confidence joints."""

from __future__ import annotations

import numpy as np

from .core.conventions import Layout, get_layout
from .core.errors import InputError


def remap_to_h36m(points: np.ndarray, layout: Layout | str, confidence_channel: bool = False) -> np.ndarray:
    """Convert ``(T, J, C)`` keypoints of ``layout`` into H36M-17 ``(T, 17, C)`` float32.

    Coordinates of synthetic joints (pelvis, spine, thorax, head in COCO-17 ...) are the
    mean of their source joints (MotionBERT ``coco2h36m`` / ``halpe2h36m``); NaN sources
    give NaN. With ``confidence_channel`` the last channel is a confidence and takes the
    minimum over the sources, so one missing hip invalidates the pelvis (pcnet's own
    choice: MotionBERT's ``halpe2h36m`` in ``lib/data/dataset_wild.py`` and ``coco2h36m``
    in ``lib/data/dataset_action.py`` average the confidence like the coordinates).

    Raises:
        InputError (a ValueError): when ``J`` does not match the layout's joint count.
    """
    lay = get_layout(layout) if isinstance(layout, str) else layout
    pts = np.asarray(points, np.float32)
    if pts.ndim != 3 or pts.shape[1] != lay.num_joints:
        raise InputError(
            f"keypoints: layout {lay.name} expects (T, {lay.num_joints}, C), got {pts.shape}"
        )
    out = np.empty((pts.shape[0], 17, pts.shape[2]), np.float32)
    for k, src in enumerate(lay.to_h36m):
        sel = pts[:, list(src)]
        out[:, k] = sel.mean(1)
        if confidence_channel:
            out[:, k, -1] = sel[..., -1].min(1)
    return out


def built_joints(layout: Layout | str) -> list[str]:
    """The H36M-17 joint names that :func:`remap_to_h36m` builds from ``layout`` as a mean of
    several source joints rather than copies (COCO-17: pelvis, spine, thorax, head; none for
    H36M-17). Raises :class:`~pcnet.stages.core.errors.InputError` for an unknown layout name."""
    lay = get_layout(layout) if isinstance(layout, str) else layout
    names = get_layout("h36m17").joints
    return [names[k] for k, src in enumerate(lay.to_h36m) if len(src) > 1]


def outside_image(keypoints_xy: np.ndarray, image_size: tuple[int, int],
                  margin_px: tuple[float, float] = (1.0, 1.0)) -> np.ndarray:
    """``(...)`` bool: 2D keypoints ``(..., >=2)`` (pixels, x right, y down) that lie outside
    the ``(width, height)`` picture by more than ``margin_px`` ``(x, y)``. The default, a
    pixel, is the coordinate convention's own slack (pixel coordinates run over ``[0, w]`` or,
    as indices, ``[0, w - 1]``, and a turned video's maps ``y`` to ``w - 1 - y``): a detector
    that places a joint beyond it (MediaPipe extrapolates a body cut by the frame's edge, with
    confidences above any threshold) has not seen it, so the joint is missing, not measured.
    NaN keypoints are not outside.

    Raises:
        InputError: ``image_size`` not two positive numbers.
    """
    w, h = image_size
    if not (w > 0 and h > 0):
        raise InputError(f"image_size: expected (width, height) in pixels > 0, got {image_size!r}")
    mx, my = margin_px
    x, y = (np.asarray(keypoints_xy[..., i], np.float64) for i in (0, 1))
    with np.errstate(invalid="ignore"):
        return (x < -mx) | (x > w + mx) | (y < -my) | (y > h + my)


def mask_low_confidence(joints3d: np.ndarray, confidence: np.ndarray, threshold: float) -> np.ndarray:
    """Set 3D joints ``(T, 17, 3)`` to NaN where the 2D ``confidence`` ``(T, 17)`` is below
    ``threshold`` or NaN. Returns a new float32 array.

    Raises:
        InputError: ``joints3d`` not ``(T, 17, 3)``, ``confidence`` not ``(T, 17)`` like it, or
            ``threshold`` not a number in [0, 1] (confidences are probabilities, not percent).
    """
    out = np.array(joints3d, np.float32, copy=True)
    if out.ndim != 3 or out.shape[1:] != (17, 3):
        raise InputError(f"joints3d: expected shape (T, 17, 3), got {out.shape}")
    conf = np.asarray(confidence, np.float32)
    if conf.shape != out.shape[:2]:
        raise InputError(f"confidence: expected shape {out.shape[:2]}, got {conf.shape}")
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float, np.number)) or not 0 <= threshold <= 1:
        raise InputError(f"threshold: expected a confidence in [0, 1], got {threshold!r}")
    out[~(conf >= threshold)] = np.nan
    return out
