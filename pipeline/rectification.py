"""Rectification composed: a per-frame estimator (the geometric baseline of
:mod:`pcnet.stages.core.geometric`, or 3DPCNet through :mod:`pcnet.models.inference`), then the
stages after it (:func:`pcnet.stages.rectify.finish_rotations`: sequence modes, heading) and
the canonical poses (:func:`pcnet.stages.core.canonical.to_canonical`).

It lives in the pipeline because it is the one room allowed to use both ``models`` and
``stages`` (docs/architecture.md): the stages never import the network.
"""

from __future__ import annotations

import numpy as np

from pcnet.models.inference import get_session
from pcnet.stages.core.canonical import to_canonical
from pcnet.stages.core.conventions import check_poses, fill_pelvis_from_hips, validate_fps, validate_poses
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.geometric import geometric_rotation
from pcnet.stages.rectify import (METHODS, Rectified, check_method_weights, finish_rotations, gate_report,
                                  resolve_heading_source)
from pcnet.stages.uncertainty import FRAME_TILT_95_DEG


def estimate_rotations(joints_cam: np.ndarray, method: str = "pcnet", weights: str | None = None,
                       fps: float = 30.0):
    """Per-frame canonical->camera rotations ``(T, 3, 3)``, residuals ``(T, 17, 3)`` (zeros
    unless ``method == "pcnet"``) and validity ``(T,)`` for camera-frame H36M-17 poses.

    Methods: ``pcnet`` (3DPCNet with its residual, onnxruntime), ``pcnet-rigid`` (the same
    rotation, residual dropped: a rigid rotation of the input), ``geometric`` (paper 2.3).
    Without ``weights`` the 3DPCNet methods run the shipped pair gated by camera orientation
    (:class:`pcnet.models.inference.ViewGatedPCNet`; ``fps`` sets its window, one recording
    per call). See :func:`estimate_rotations_gated` for the gate's weights.

    Raises:
        InputError: unknown method, wrong shape, or ``weights`` with ``geometric``.
    """
    return estimate_rotations_gated(joints_cam, method, weights, fps)[:3]


def estimate_rotations_gated(joints_cam: np.ndarray, method: str = "pcnet", weights: str | None = None,
                             fps: float = 30.0):
    """:func:`estimate_rotations` plus the camera-frame network's weight ``(T,)`` per frame
    (:func:`pcnet.models.view_gate.camera_frame_weight`; NaN where not valid), or ``None``
    when one estimator ran (``geometric``, or given ``weights``)."""
    X = check_poses(joints_cam, "joints_cam")
    check_method_weights(method, weights)
    if method == "geometric":
        R, valid = geometric_rotation(X)
        return R, np.zeros(X.shape, np.float64), valid, None
    if method in ("pcnet", "pcnet-rigid"):
        session = get_session(None if weights is None else str(weights))
        if weights is None:
            R, residual, valid, gate = session.predict_gated(X, fps)
        else:
            (R, residual, valid), gate = session.predict(X), None
        if method == "pcnet-rigid":
            residual = np.where(valid[:, None, None], 0.0, np.nan)
        return R, residual, valid, gate
    raise InputError(f"unknown rectification method {method!r}; expected one of {METHODS}")


def rectify(
    joints_cam: np.ndarray,
    method: str = "pcnet",
    weights: str | None = None,
    mode: str = "frame",
    fps: float = 30.0,
    heading: str | None = None,
    camera_prior: bool = True,
) -> Rectified:
    """Rectify camera-frame H36M-17 poses ``(T, 17, 3)`` into the canonical frame
    (``docs/CONVENTIONS.md``): ``canonical = (X - pelvis) @ R + residual``. NaN joints stay NaN.

    ``mode``: ``frame`` (each frame alone, the paper), ``sequence`` (one up direction for a
    static camera), ``smooth`` (SO(3) smoothing for a moving camera, needs ``fps``) or
    ``auto`` (:func:`pcnet.stages.temporal.rectify_sequence`). ``heading``: where the
    heading about that up comes from, ``predicted`` (the method's rotation), ``hips`` (the
    input's hip line, the canonical frame's definition) or ``auto`` (hips when they are
    precise, :func:`pcnet.stages.heading.apply_heading`); ``None`` =
    :func:`resolve_heading_source`. ``camera_prior``: in the sequence modes, weigh the
    pose evidence against a camera prior and a lying reading
    (:mod:`pcnet.stages.gravity_prior`; ``False`` with ``mode="frame"`` and
    ``heading="predicted"`` is the paper's model alone). ``report`` says what ran.

    Input rules shared with ``pcnet run`` and ``pcnet rectify``:
    :func:`pcnet.stages.core.conventions.validate_poses` (real-valued ``(T, 17, 3)``, at least
    one frame and one finite value, non-finite = missing) and the pelvis rule
    :func:`pcnet.stages.core.conventions.fill_pelvis_from_hips` (a missing pelvis is the hip
    midpoint; a frame still without a pelvis is invalid). The report's
    ``pelvis_from_hips_frames`` counts the filled frames; ``view_gate``
    (:func:`gate_report`) and ``camera_frame_weight`` ``(T,)`` say how far the shipped
    camera-frame network was trusted (3DPCNet methods without ``weights``).

    Raises:
        InputError (a ValueError): bad input array (see above), unknown method, mode or
            heading source, or (sequence modes) no valid frame.
    """
    heading = resolve_heading_source(method, heading)
    fps = validate_fps(fps)
    joints_cam, pelvis_filled = fill_pelvis_from_hips(validate_poses(joints_cam, "joints_cam"))
    R, residual, valid, gate = estimate_rotations_gated(joints_cam, method, weights, fps)
    R, valid, report = finish_rotations(joints_cam, R, valid, mode, fps, heading, camera_prior=camera_prior)
    report["pelvis_from_hips_frames"] = int(pelvis_filled.sum())
    report["view_gate"] = gate_report(gate, valid)
    if gate is not None:
        report["camera_frame_weight"] = np.where(valid, gate, np.nan)
    # A per-frame bound calibrated for the shipped weights only (other weights: none).
    report["frame_tilt_95_deg"] = FRAME_TILT_95_DEG if method != "geometric" and weights is None else float("nan")
    canonical = to_canonical(joints_cam, R, residual)
    return Rectified(R, canonical, R[:, :, 1].copy(), valid, method, report["mode"], report,
                     report["heading_source"])
