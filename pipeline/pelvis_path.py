"""Where a run's pelvis path comes from: measured by the input (a depth sensor,
``--measured-root``), recovered from the 2D keypoints by a perspective fit
(:func:`pcnet.stages.root_path.root_from_keypoints`), or not observable; and the camera
intrinsics that fit needs.

The camera's focal length is ``--focal-px`` when given, else the ``K`` a lifter file states
(MediaPipe archives of calibrated cameras), else a phone's 26 mm equivalent
(:data:`pcnet.stages.core.perspective.DEFAULT_FOCAL_35MM`) on the image size of the video or
of the keypoint file; the principal point is the image centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pcnet.models.lifter_noise import BONE_SCALE_SIGMA
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.framestore import per_frame, present_frames
from pcnet.stages.core.perspective import focal_px_from_35mm, focal_px_problem, intrinsics
from pcnet.stages.kinematics import frames_phrase
from pcnet.stages.root_path import root_from_keypoints, stretch_starts

#: ``report["root_path"]``: where the pelvis path of a world-frame run came from.
PATH_KINDS = ("measured", "from 2D keypoints", "not observable")


@dataclass(frozen=True)
class Intrinsics:
    """``matrix``: ``(3, 3)`` float64 ``K`` (pixels), or ``None`` when the image size is not
    known; ``source``: where its focal length came from, or why there is none."""

    matrix: np.ndarray | None
    source: str


def camera_intrinsics(focal_px: float | None, file_matrix: np.ndarray | None,
                      image_size: tuple[int, int] | None) -> Intrinsics:
    """The camera's ``K`` for the 2D keypoints (module docstring for the order of sources).

    Args:
        focal_px: ``--focal-px`` (pixels) or ``None``.
        file_matrix: the lifter file's ``(3, 3)`` ``K`` or ``None``
            (:attr:`pcnet.adapters.Poses3D.camera_matrix`).
        image_size: ``(width, height)`` in pixels of the frames the keypoints are in, or ``None``.

    Raises:
        InputError: a given focal length shorter than any rectilinear lens's on that picture
            (:func:`pcnet.stages.core.perspective.focal_px_problem`).
    """
    if focal_px is not None and image_size is not None:
        problem = focal_px_problem(focal_px, *image_size)
        if problem is not None:
            raise InputError(f"--focal-px {focal_px:g}: expected {problem[0]}, got {problem[1]}")
        return Intrinsics(intrinsics(*image_size, focal_px), f"focal length {focal_px:g} px, given")
    if file_matrix is not None:
        return Intrinsics(np.asarray(file_matrix, np.float64), f"the lifter file's K (focal length "
                                                                f"{file_matrix[0][0]:.0f} px)")
    if image_size is None:
        return Intrinsics(None, "the image size is unknown (give --video or --image-size)")
    focal = focal_px_from_35mm(*image_size)
    return Intrinsics(intrinsics(*image_size, focal), f"focal length {focal:.0f} px assumed (a phone's 26 mm "
                                                      f"equivalent; give --focal-px)")


@dataclass(frozen=True)
class PelvisPath:
    """``kind``: one of :data:`PATH_KINDS`; ``camera``: ``(T, 3)`` float64 camera-frame pelvis
    positions (m for a recovered path, the input's units for a measured one; NaN where
    unknown) or ``None``; ``covariance``: ``(T, 3, 3)`` camera-frame covariance of a recovered
    path (NaN where unknown) or ``None``; ``note``: one summary line (empty for a measured
    path); ``refused``: why given 2D keypoints placed no frame's pelvis (empty otherwise)."""

    kind: str
    camera: np.ndarray | None = None
    covariance: np.ndarray | None = None
    note: str = ""
    refused: str = ""

    def world_std(self, rotation: np.ndarray) -> np.ndarray | None:
        """``(T, 3)`` 1-sigma of the path along the world axes of ``rotation`` (``(3, 3)``
        camera->world, :class:`pcnet.stages.world_frame.WorldFrame`), or ``None`` when the
        path has no covariance: ``sqrt(diag(W C W^T))``."""
        if self.covariance is None:
            return None
        W = np.asarray(rotation, np.float64)
        return np.sqrt(np.einsum("ij,tjk,ik->ti", W, self.covariance, W))


def _require_body_in_front(position_z: np.ndarray, joints_cam, camera: Intrinsics) -> None:
    """Refuse a focal length whose pelvis path puts the body behind the camera: a pinhole
    camera sees only points in front of it, so where the nearest joint of the median fitted
    frame lies at a depth of 0 or less, the focal length (or the picture it was given for) is
    wrong, by far (a sprint coach's ``--focal-px 26``, the lens's millimetres, read 17 m/s walks).

    Raises:
        InputError: naming the focal length's source and the pixels a phone's lens would give.
    """
    nearest_rel = per_frame(lambda J: np.min(J[..., 2], axis=1, initial=np.inf, where=np.isfinite(J[..., 2])),
                            joints_cam)
    nearest = np.asarray(position_z, np.float64) + np.where(np.isfinite(nearest_rel), nearest_rel, np.nan)
    fitted = nearest[np.isfinite(nearest)]
    if not len(fitted) or np.median(fitted) > 0:
        return
    width, height = 2 * camera.matrix[0, 2], 2 * camera.matrix[1, 2]
    phone = focal_px_from_35mm(width, height)
    given = f"--focal-px {camera.matrix[0, 0]:g}" if camera.source.endswith(", given") else camera.source
    raise InputError(f"{given}: expected a focal length that puts the body in front of the camera, got "
                     f"one that puts its nearest joint {-np.median(fitted):.2f} m behind it in the median frame: a "
                     f"focal length in millimetres? in pixels it is the 35 mm-equivalent focal length x the "
                     f"picture's diagonal / 43.27 (a phone's 26 mm: {phone:.0f} px on this {width:.0f}x{height:.0f} "
                     f"picture)")


def pelvis_path(measured: np.ndarray | None, joints_cam, keypoints2d, camera: Intrinsics, units: str, fps: float,
                min_confidence: float, segment: np.ndarray | None = None) -> PelvisPath:
    """The run's pelvis path.

    Args:
        measured: ``(T, 3)`` the input's measured camera-frame pelvis path, or ``None``.
        joints_cam: ``(T, 17, 3)`` root-relative camera-frame poses in ``units``.
        keypoints2d: ``(T, 17, 3)`` H36M-17 pixels and confidence in the frames ``camera``
            describes, or ``None``.
        camera: :func:`camera_intrinsics`.
        units: the poses' units; a path is recovered only from metric poses.
        fps: frame rate (Hz).
        min_confidence: the run's 2D confidence threshold.
        segment: ``(T,)`` int, the one-body stretches of a 2D track that switches person
            (:func:`pcnet.stages.flags.track_segments`), each fitted on its own; ``None``: one body.

    The recovered path's covariance includes a body-size spread of
    :data:`pcnet.models.lifter_noise.BONE_SCALE_SIGMA` (a lifter's limbs are a few percent
    off any one subject's: that model's assumption, not fitted), which scales the whole path
    (depth most); other lifter errors that persist over time are not in it, so on real lifter
    output it is a lower bound (:mod:`pcnet.stages.root_path`).
    """
    if measured is not None:
        return PelvisPath("measured", measured)
    if keypoints2d is None:
        metres = "" if units == "m" else f", and --height for poses in {units}"
        # what else the keypoints would check, said once here (an estimator-swapping trial never read it)
        return PelvisPath("not observable", note=f"pelvis path not observable: no 2D keypoints to place the "
                                                 f"root-relative poses in the image (give --keypoints2d{metres}); "
                                                 f"without them the left and right sides and a switch to another "
                                                 f"person are not checked either")
    if units != "m":
        return PelvisPath("not observable", note=f"pelvis path not observable: the poses are in {units}, not metres "
                                                 f"(give --height)")
    if camera.matrix is None:
        return PelvisPath("not observable", note=f"pelvis path not observable: {camera.source}")
    try:
        path = root_from_keypoints(joints_cam, keypoints2d, camera.matrix, fps, min_confidence=min_confidence,
                                   size_std_fraction=BONE_SCALE_SIGMA, segment=segment)
    except InputError as err:  # too few joints seen in 2D and 3D alike: the run goes on without a path
        return PelvisPath("not observable", refused=str(err))  # a warning, not a note (stages.flags.keypoints_unused_flag)
    _require_body_in_front(position_z=path.position[:, 2], joints_cam=joints_cam, camera=camera)
    position, held = _held_at_the_ends(path.position, present_frames(joints_cam), segment)
    accepted = path.frames_fitted - path.frames_rejected
    bridged = int(np.isfinite(path.position).all(axis=1).sum()) - accepted  # gaps and outliers inside the span
    return PelvisPath("from 2D keypoints", position, path.cov,
                      # the focal length's source outside parentheses: the summary's headline keeps it (a
                      # boxing analyst's read "fitted in 294 of 301 frames..." and missed the assumed focal)
                      f"pelvis path fitted to the 2D keypoints in {accepted} of {len(position)} frames, "
                      f"{camera.source}: depth 1-sigma median {path.depth_std_median:.2f} m with a "
                      f"{100 * BONE_SCALE_SIGMA:g} % body-size spread (a lower bound on real lifter output)"
                      + (f"; {frames_phrase(path.frames_rejected)} rejected as "
                         f"{'outliers' if path.frames_rejected != 1 else 'an outlier'}" if path.frames_rejected else "")
                      + (f"; bridged across {frames_phrase(bridged)} without an accepted fit" if bridged > 0 else "")
                      + (f"; held at its first/last fitted position in {frames_phrase(held)} with a pose "
                         f"but no accepted fit at the ends (pelvis_path_std_world empty there): their world "
                         f"positions do not follow the body's travel, so kinematics.csv and the marker files leave "
                         f"their positions empty (the angles are kept; joints_world holds them)" if held else ""))


def _held_at_the_ends(position: np.ndarray, posed: np.ndarray,
                      segment: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """``position`` ``(T, 3)`` with the frames before the first and after the last known one
    that have a pose (``posed`` ``(T,)`` bool) holding that known position, so their joints
    stay in the world frame; and how many were held. With ``segment`` ``(T,)`` (one body per
    stretch of equal values) each stretch's ends are held to its own path. The smoother
    bridges gaps inside each fitted span itself (:mod:`pcnet.stages.root_path`)."""
    out, held = position.copy(), 0
    starts = stretch_starts(segment, len(position))
    for a, b in zip(starts, [*starts[1:], len(position)]):
        known = a + np.flatnonzero(np.isfinite(position[a:b]).all(axis=1))
        if not len(known):
            continue
        head = a + np.flatnonzero(posed[a: known[0]])
        tail = known[-1] + 1 + np.flatnonzero(posed[known[-1] + 1: b])
        out[head], out[tail] = position[known[0]], position[known[-1]]
        held += len(head) + len(tail)
    return out, held
