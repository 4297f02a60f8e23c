"""VideoPose3D ``run.py --viz-export`` output -> :class:`Poses3D` (VideoPose3D ``INFERENCE.md``)."""

from __future__ import annotations

from pathlib import Path

from pcnet.stages.core.conventions import H36M_JOINTS

from .registry import register_3d
from .types import AdapterError, Poses3D
from .validate import (REBASED_WORLD_FRAME, ROOT_RELATIVE_MAX, as_path, checked_poses, finite_max_abs, load_npy,
                       nonfinite_frames, pelvis_offset, rebased_world_frame)

#: With VideoPose3D's trajectory model, run.py adds the predicted root trajectory before
#: exporting: the pelvis then lies in front of the camera, at this depth (m) or more (median).
MIN_TRAJECTORY_DEPTH_M = 0.5


def load_videopose3d(path: str | Path) -> Poses3D:
    """Read a VideoPose3D export ``(N, 17, 3)`` ``.npy`` into ``Poses3D``.

    Returns:
        ``Poses3D``: float32 ``(N, 17, 3)`` H36M-17, metres, camera frame (x right, y down,
        z forward: VideoPose3D ``common/camera.py`` projects ``f*X[:2]/X[2] + c`` to pixels),
        no axis changed. VideoPose3D is trained with a zero root target but does not zero
        the root in ``evaluate`` (``run.py`` L682-688), so the root is near, not exactly at,
        the origin (about 1e-4 m in the yoga exports); the caller centres it. A checkpoint with
        the trajectory model (``model_traj``) exports the root trajectory added: the pelvis
        then lies in front of the camera, also accepted.

        ``inf`` is missing data (NaN).

    Raises:
        AdapterError: missing/unreadable file, not ``(N, 17, 3)`` real numbers, all NaN, a
            coordinate beyond 100 m (naming frame and joint), a pelvis farther than
            :data:`~pcnet.adapters.validate.ROOT_RELATIVE_MAX` from the origin yet not
            :data:`MIN_TRAJECTORY_DEPTH_M` in front of the camera (medians over frames: not a VideoPose3D export).

    Source of the format facts: facebookresearch/VideoPose3D (commit 1afb1ca)
    ``INFERENCE.md`` step 5, ``data/prepare_data_h36m.py`` L73 "Meters instead of
    millimeters", ``common/camera.py`` ``project_to_2d`` (x right, y down, z forward).
    """
    p = as_path(path)
    arr = load_npy(p, ndim=3, num_joints=17, field="poses")
    nonfinite = nonfinite_frames(arr, H36M_JOINTS)  # the file's inf/NaN, before any check
    arr = checked_poses(p, "poses", arr, "h36m17", "m")
    off_origin, depth = pelvis_offset(arr)
    if rebased_world_frame(arr, off_origin):
        raise AdapterError(p, "poses", "a VideoPose3D export in the camera frame (x right, y down, z forward)",
                           REBASED_WORLD_FRAME)
    if off_origin > ROOT_RELATIVE_MAX and not depth >= MIN_TRAJECTORY_DEPTH_M:  # NaN (no pelvis): no verdict
        raise AdapterError(p, "poses", f"a VideoPose3D export: its pelvis within {ROOT_RELATIVE_MAX:g} m of the origin "
                           f"(root-relative) or, with the trajectory model, at least {MIN_TRAJECTORY_DEPTH_M:g} m in "
                           "front of the camera",
                           f"the pelvis {off_origin:.3g} m from the origin at depth {depth:.3g} m (medians over "
                           "frames): MotionBERT's infer_wild output? (--lifter motionbert), or joints in another "
                           "order than H36M-17's, whose joint 0 is then not the pelvis (--lifter generic --layout)")
    root = finite_max_abs(arr[:, 0])
    notes = ("VideoPose3D export (VideoPose3D INFERENCE.md), H36M-17, metres, camera frame x right / y down / z forward, "
             f"no axis changed; root as delivered (max |root| {root:.2g} m)")
    return Poses3D(arr, "h36m17", units="m", source=str(p), notes=notes, nonfinite=nonfinite)


@register_3d("videopose3d", records_fps=False)
class VideoPose3DAdapter:
    """Registry entry for :func:`load_videopose3d` (no options)."""

    def load(self, path: str | Path) -> Poses3D:
        return load_videopose3d(path)
