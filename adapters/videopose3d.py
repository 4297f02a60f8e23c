"""VideoPose3D ``run.py --viz-export`` output -> :class:`Poses3D` (VideoPose3D ``INFERENCE.md``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .registry import register_3d
from .types import AdapterError, Poses3D
from .validate import checked_poses, finite_max_abs, load_npy

#: The farthest a VideoPose3D export's pelvis lies from the origin, median over frames (m):
#: the real exports' is about 1e-4 m (root-relative training target, not zeroed at inference);
#: MotionBERT's infer_wild output keeps the root's image position (0.1-1 normalised units).
MAX_ROOT_M = 0.01


def load_videopose3d(path: str | Path) -> Poses3D:
    """Read a VideoPose3D export ``(N, 17, 3)`` ``.npy`` into ``Poses3D``.

    Returns:
        ``Poses3D``: float32 ``(N, 17, 3)`` H36M-17, metres, camera frame (x right, y down,
        z forward: VideoPose3D ``common/camera.py`` projects ``f*X[:2]/X[2] + c`` to pixels),
        no axis changed. VideoPose3D is trained with a zero root target but does not zero
        the root in ``evaluate`` (``run.py`` L682-688), so the root is near, not exactly at,
        the origin (about 1e-4 m in the yoga exports); the caller centres it.

        ``inf`` is missing data (NaN).

    Raises:
        AdapterError: missing/unreadable file, not ``(N, 17, 3)`` real numbers, all NaN, a
            coordinate beyond 100 m (naming frame and joint), a pelvis farther than
            :data:`MAX_ROOT_M` from the origin (median over frames: not a VideoPose3D export).

    Source of the format facts: facebookresearch/VideoPose3D (commit 1afb1ca)
    ``INFERENCE.md`` step 5, ``data/prepare_data_h36m.py`` L73 "Meters instead of
    millimeters", ``common/camera.py`` ``project_to_2d`` (x right, y down, z forward).
    """
    p = Path(path)
    arr = checked_poses(p, "poses", load_npy(p, ndim=3, num_joints=17, field="poses"), "h36m17", "m")
    root_distance = np.linalg.norm(arr[:, 0], axis=-1)
    if np.isfinite(root_distance).any() and np.nanmedian(root_distance) > MAX_ROOT_M:
        raise AdapterError(p, "poses", f"a VideoPose3D export, its pelvis within {MAX_ROOT_M:g} m of the origin "
                           "(run.py predicts root-relative poses)",
                           f"the pelvis {np.nanmedian(root_distance):.3g} from it (median over frames): MotionBERT's "
                           "infer_wild output (--lifter motionbert) or camera-frame metres with the root "
                           "(--lifter generic)?")
    root = finite_max_abs(arr[:, 0])
    notes = ("VideoPose3D export (VideoPose3D INFERENCE.md), H36M-17, metres, camera frame x right / y down / z forward, "
             f"no axis changed; root as delivered (max |root| {root:.2g} m)")
    return Poses3D(arr, "h36m17", units="m", source=str(p), notes=notes)


@register_3d("videopose3d")
class VideoPose3DAdapter:
    """Registry entry for :func:`load_videopose3d` (no options)."""

    def load(self, path: str | Path) -> Poses3D:
        return load_videopose3d(path)
