"""MotionBERT ``infer_wild.py`` output ``X3D.npy`` -> :class:`Poses3D` (Walter0807/MotionBERT)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import H36M_JOINTS

from .registry import register_3d
from .types import AdapterError, Poses3D
from .validate import (ROOT_RELATIVE_MAX, as_path, checked_poses, finite_max_abs, load_npy, nonfinite_frames,
                       pelvis_offset, require_option_int)

# Default-mode x, y come from 2D input clipped to [-1, 1] (MotionBERT
# lib/utils/utils_data.py:crop_scale, called from lib/data/dataset_wild.py); the network's
# outputs stay near that range. Pixel-mode x, y are image pixels, i.e. hundreds. A bound
# between the two catches a file read in the wrong mode.
_NORMALISED_BOUND = 4.0


def load_motionbert(path: str | Path, pixel: bool = False, clip_len: int = 243) -> Poses3D:
    """Read MotionBERT's ``X3D.npy`` into ``Poses3D``.

    Args:
        path: ``X3D.npy``, float32 ``(T, 17, 3)`` H36M-17.
        pixel: ``True`` for output of ``infer_wild.py --pixel``.
        clip_len: MotionBERT's clip length (``--clip_len``, 243), used for the notes.

    Returns:
        ``Poses3D`` with layout ``h36m17`` and frame ``camera`` (x right, y down as in the
        image; z depth in the same scale, increasing away from the camera: MotionBERT
        ``infer_wild.py`` and ``lib/data/datareader_h36m.py`` ``read_3d``; the z sign is
        derived, not stated upstream: Walter0807/MotionBERT issue #124, which asks it, is
        unanswered). No axis is changed.

        * default: units ``normalised`` (x, y about [-1, 1] of the sequence's square crop,
          z in the same scale);
        * ``pixel=True``: units ``px`` (x, y image pixels of the input video, z pixels).

        The root is **not** root-relative: it keeps its image position, and MotionBERT set
        the root z of the first frame of every ``clip_len``-frame clip to 0
        (``predicted_3d_pos[:,0,0,2] = 0``), so z can jump at frames ``clip_len``,
        ``2*clip_len``, ... Each clip is lifted without the frames of the one before it
        (``infer_wild.py`` splits the video into ``clip_len``-frame clips), so the
        pelvis-relative pose can jump there too. Subtract the pelvis per frame before use.

        ``inf`` values are missing data (NaN) and are ignored when checking the units.

    Raises:
        AdapterError: missing/unreadable file, not ``(T, 17, 3)`` real numbers, all NaN, x/y
            magnitudes that contradict ``pixel`` (normalised values above 4, or pixel values
            all within 4), a coordinate beyond the bound of its units (1e3 normalised, 1e5
            px; naming frame and joint), or ``clip_len`` not a positive integer. A pelvis within
            :data:`~pcnet.adapters.validate.ROOT_RELATIVE_MAX` of the origin (median over frames)
            is noted, not refused: ``infer_wild.py --rootrel`` writes one, and so do lifters
            whose output is in metres.

    Source of the format facts: Walter0807/MotionBERT (commit dccfe7b) ``infer_wild.py``
    L65-97 and ``lib/utils/utils_data.py`` ``crop_scale``; maintainer answers in
    Walter0807/MotionBERT issues #9 and #21.
    """
    p = as_path(path)
    clip_len = require_option_int(p, "clip_len", clip_len, 1, allow_none=False)
    arr = load_npy(p, ndim=3, num_joints=17, field="X3D")
    nonfinite = nonfinite_frames(arr, H36M_JOINTS)  # the file's inf/NaN, before any check
    xy_max = finite_max_abs(arr[..., :2])
    if not np.isfinite(xy_max):
        raise AdapterError(p, "X3D x/y values", "some finite x, y coordinates", "only NaN/inf")
    if pixel and xy_max <= _NORMALISED_BOUND:
        raise AdapterError(p, "X3D x/y values", "image pixels for pixel=True (infer_wild --pixel)",
                           f"max |x|,|y| {xy_max:.2f}, which looks normalised; drop --pixel (pixel=False)")
    if not pixel and xy_max > _NORMALISED_BOUND:
        raise AdapterError(p, "X3D x/y values", f"normalised coordinates within about [-1, 1] (|x|,|y| <= {_NORMALISED_BOUND})",
                           f"max {xy_max:.1f}, which looks like pixels; use --pixel (pixel=True)")
    _refuse_keypoints_input(p, arr)
    off_origin, _ = pelvis_offset(arr)
    # infer_wild.py --rootrel zeroes the root, so a root at the origin may be MotionBERT's;
    # it is also what VideoPose3D and D3DP export, in metres, not image-normalised units.
    # the hint first: a summary keeps a note's first clauses (a trial's summary cut it off)
    rootrel = (f"; pelvis at the origin: root-relative metres of another lifter? try --lifter videopose3d or ddhpose; "
               f"else infer_wild --rootrel output (median pelvis offset {off_origin:.2g})") \
        if off_origin <= ROOT_RELATIVE_MAX else ""
    clip_starts = list(range(0, arr.shape[0], clip_len))
    shown = ", ".join(map(str, clip_starts[:6])) + (", ..." if len(clip_starts) > 6 else "")
    units = "px" if pixel else "normalised"
    arr = checked_poses(p, "X3D", arr, "h36m17", units, in_place=True)
    notes = (f"MotionBERT X3D.npy (infer_wild.py), H36M-17, units {units}"
             + (" (x, y image pixels, z pixels)" if pixel else " (image-normalised, about [-1, 1])")
             + "; axes x right, y down, z away from the camera (z sign derived); no axis changed"
             + f"; root not centred: MotionBERT lifts each {clip_len}-frame clip on its own and zeroes its first "
             + f"frame's root z (frames {shown}), so the root's depth and the whole pose may jump there" + rootrel)
    return Poses3D(arr, "h36m17", units=units, source=str(p), notes=notes, summary_note=rootrel.removeprefix("; "),
                   nonfinite=nonfinite, breaks=tuple(clip_starts[1:]))


def _refuse_keypoints_input(p: Path, arr: np.ndarray) -> None:
    """Refuse MotionBERT's 2D input (x, y, confidence) given as its output: X3D.npy's z is a
    depth relative to the root, which infer_wild.py sets to 0 on the first frame
    (``predicted_3d_pos[:,0,0,2] = 0``), so joints lie in front of it (z < 0) and behind it;
    a third channel in [0, 1] everywhere with a root above 0 is confidences (a developer
    trial passed the 2D file and got a result)."""
    z = arr[..., 2][np.isfinite(arr[..., 2])]
    root = arr[:, 0, 2][np.isfinite(arr[:, 0, 2])]
    if len(z) and z.min() >= 0.0 and z.max() <= 1.0 and len(root) and root[0] > 0.0:
        raise AdapterError(p, "X3D z", "depths relative to the root (0 at the first frame's root, joints in front of "
                           "and behind it)", f"z in [{z.min():.2f}, {z.max():.2f}] everywhere, the first root at "
                           f"{root[0]:.2f}: 2D keypoints with confidences (MotionBERT's input), not its X3D.npy")


@register_3d("motionbert", records_fps=False, never_metric=True)
class MotionBERTAdapter:
    """Registry entry for :func:`load_motionbert` (options: ``pixel``, ``clip_len``)."""

    def load(self, path: str | Path, *, pixel: bool = False, clip_len: int = 243) -> Poses3D:
        return load_motionbert(path, pixel=pixel, clip_len=clip_len)
