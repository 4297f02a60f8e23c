"""D3DP / DDHPose-style diffusion lifter output -> :class:`Poses3D`.

DDHPose itself has no in-the-wild output format (Andyen512/DDHPose ``main.py``
``--viz-export`` needs H36M ground truth and ``-d custom`` imports a
``common/custom_dataset.py`` the repository lacks); the natural file is D3DP's
in-the-wild ``test_3d_{video}_output.npy`` (written by paTRICK-swk/D3DP
``in_the_wild/videopose_diffusion.py``: ``(K_steps, H_hyp, N, 17, 3)``, camera space,
metres, root zeroed) or an export of it with fewer axes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import H36M_JOINTS
from pcnet.stages.core.framestore import frame_blocks

from .registry import register_3d
from .types import AdapterError, Poses3D
from .validate import (REBASED_WORLD_FRAME, ROOT_RELATIVE_MAX, as_path, checked_poses, load_npy, nonfinite_frames,
                       pelvis_offset, rebased_world_frame, require_some_finite)


def _pick(p: Path, name: str, value: object, size: int, also: str = "") -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not -size <= value < size:
        raise AdapterError(p, name, f"{also}an integer index in [-{size}, {size})", repr(value))
    return int(value) % size


def load_ddhpose(path: str | Path, step: int = -1, hypothesis: int | str = "mean") -> Poses3D:
    """Read a D3DP/DDHPose prediction array into ``Poses3D``.

    Args:
        path: ``.npy`` of shape ``(K, H, N, 17, 3)`` (sampling steps, hypotheses, frames),
            ``(H, N, 17, 3)`` or ``(N, 17, 3)``.
        step: sampling step to keep for 5-D input; default the last (the final denoised
            sample). Ignored for fewer axes.
        hypothesis: ``"mean"`` (default: the mean over hypotheses, pcnet's own choice,
            not an upstream convention; per joint over the hypotheses where it is finite,
            NaN where none is) or an integer index.
            Must be ``"mean"`` for ``(N, 17, 3)`` input.

    Returns:
        ``Poses3D``: ``(N, 17, 3)`` float32 H36M-17, metres, camera frame (x right, y down,
        z forward; D3DP's camera space is VideoPose3D's, so no axis changes). Root as
        delivered (D3DP zeroes it).

    Raises:
        AdapterError: missing/unreadable file, a ``.mat`` (DDHPose's 3DHP output is in the
            MPI-INF-3DHP-17 layout), a ``_postprocess`` file (world z-up frame for display),
            wrong rank, dtype or joint count, more hypotheses than frames (the axes swapped, or a
            clip shorter than its hypotheses count, which the shape cannot tell apart), a
            bad ``step``/``hypothesis``, all NaN, a coordinate beyond 100 m (naming frame and
            joint), a pelvis farther than :data:`~pcnet.adapters.validate.ROOT_RELATIVE_MAX` from
            the origin (median over frames: not root-relative, so not D3DP's output). ``inf`` is missing data (NaN).

    Source of the format facts: paTRICK-swk/D3DP (commit afcdd05)
    ``in_the_wild/videopose_diffusion.py``, ``in_the_wild/utils.py`` L286
    (``evaluate_diffusion`` zeroes the root) and README "Testing on in-the-wild videos";
    Andyen512/DDHPose ``main.py`` and ``main_3dhp.py`` (the ``.mat`` output).
    """
    p = as_path(path)
    if p.suffix.lower() == ".mat":
        raise AdapterError(p, "format", "a .npy in H36M-17 (DDHPose main_3dhp .mat files use MPI-INF-3DHP-17)", ".mat")
    if "_postprocess" in p.name:
        raise AdapterError(p, "file", "the camera-space test_3d_<video>_output.npy",
                           "a _postprocess file (camera_to_world, z up, height rebased: display only)")
    arr = load_npy(p, ndim=(3, 4, 5), num_joints=17, field="predictions")
    notes = [f"D3DP/DDHPose predictions {arr.shape} (D3DP in_the_wild output), H36M-17, metres, camera frame, no axis changed"]
    if arr.ndim == 5:
        k = _pick(p, "step", step, arr.shape[0])
        notes.append(f"sampling step {k} of 0..{arr.shape[0] - 1}")
        arr = arr[k]
    if arr.ndim == 4:
        if arr.shape[0] > arr.shape[1]:  # D3DP draws a handful of hypotheses (num_proposals) per frame
            raise AdapterError(p, "predictions", "(hypotheses, frames, 17, 3), fewer hypotheses than "
                               "frames", f"{arr.shape[0]} 'hypotheses' of {arr.shape[1]} frames: frames first? "
                               f"np.swapaxes(a, -4, -3) puts the hypotheses first; a clip shorter than its "
                               f"hypotheses count looks the same: save one of them, a[h], or their mean as (N, 17, 3)")
        if isinstance(hypothesis, str) and hypothesis == "mean":
            hypotheses = arr.shape[0]
            arr, partial = _mean_over_hypotheses(arr)
            notes.append(f"mean over {hypotheses} hypotheses" + (
                f" ({partial} joint positions from the hypotheses that have them)" if partial else ""))
        else:
            h = _pick(p, "hypothesis", hypothesis, arr.shape[0], "'mean' or ")
            notes.append(f"hypothesis {h} of 0..{arr.shape[0] - 1}")
            arr = arr[h]
    elif not (isinstance(hypothesis, str) and hypothesis == "mean"):
        raise AdapterError(p, "hypothesis", "'mean' for a (N, 17, 3) file without a hypothesis axis", repr(hypothesis))
    # the file's inf/NaN in the poses kept (the chosen hypothesis; for the mean, in every one)
    nonfinite = nonfinite_frames(arr, H36M_JOINTS)
    require_some_finite(p, "predictions", arr)
    # the size check first: a millimetre file's pelvis lies 1000 times further from the origin
    arr = checked_poses(p, "predictions", arr, "h36m17", "m")
    off_origin, _ = pelvis_offset(arr)
    if rebased_world_frame(arr, off_origin):
        raise AdapterError(p, "predictions", "D3DP/DDHPose predictions in the camera frame (the "
                           "test_3d_<video>_output.npy)", REBASED_WORLD_FRAME)
    if off_origin > ROOT_RELATIVE_MAX:
        raise AdapterError(p, "predictions", f"D3DP/DDHPose predictions, root-relative (evaluate_diffusion zeroes the "
                           f"root: the pelvis within {ROOT_RELATIVE_MAX:g} m of the origin)",
                           f"the pelvis {off_origin:.3g} from the origin (median over frames): MotionBERT's infer_wild "
                           "output? (--lifter motionbert)")
    notes.append("root as delivered (D3DP zeroes it)")
    return Poses3D(np.ascontiguousarray(arr), "h36m17", units="m", source=str(p), notes="; ".join(notes),
                   nonfinite=nonfinite)


def _mean_over_hypotheses(arr: np.ndarray) -> tuple[np.ndarray, int]:
    """``(H, N, 17, 3)`` -> ``(N, 17, 3)`` float64: per joint the mean over the hypotheses
    where it is finite (non-finite is missing data), NaN where none is; and the count of
    joint positions that some but not all hypotheses have. A block of frames at a time, so
    memory stays near the output's size."""
    out = np.full(arr.shape[1:], np.nan)
    partial = 0
    for rows in frame_blocks(arr.shape[1]):
        block = np.asarray(arr[:, rows], np.float64)  # float64: huge values must not overflow
        present = np.isfinite(block).all(-1, keepdims=True)
        count = present.sum(0)
        total = np.where(present, block, 0.0).sum(0)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[rows] = np.where(count > 0, total / count, np.nan)
        partial += int(((count > 0) & (count < len(arr))).sum())
    return out, partial


@register_3d("ddhpose", records_fps=False)
class DDHPoseAdapter:
    """Registry entry for :func:`load_ddhpose` (options: ``step``, ``hypothesis``)."""

    def load(self, path: str | Path, *, step: int = -1, hypothesis: int | str = "mean") -> Poses3D:
        return load_ddhpose(path, step=step, hypothesis=hypothesis)
