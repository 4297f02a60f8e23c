"""Rectification stage: camera-frame poses -> canonical poses, rotations, up vectors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .canonical import to_canonical
from .conventions import check_poses, fill_pelvis_from_hips, validate_fps, validate_poses
from .geometric import geometric_rotation
from .heading import HEADING_SOURCES, apply_heading
from .temporal import BOOTSTRAP_REPLICATES, rectify_sequence
from .uncertainty import FRAME_TILT_95_DEG
from .errors import InputError

METHODS = ("pcnet", "pcnet-rigid", "geometric")
NO_VALID_FRAME = "no frame has the hips, thorax and shoulders needed to rectify"


@dataclass(frozen=True)
class Rectified:
    """Output of :func:`rectify` for ``T`` frames.

    rotation ``(T, 3, 3)`` canonical->camera; canonical ``(T, 17, 3)`` pelvis-centred
    canonical poses in the input's units; up ``(T, 3)`` unit up direction in the camera
    frame (``rotation[:, :, 1]``); valid ``(T,)``; method name. Invalid frames are NaN.
    """

    rotation: np.ndarray
    canonical: np.ndarray
    up: np.ndarray
    valid: np.ndarray
    method: str
    mode: str = "frame"
    report: dict | None = None
    heading_source: str = "predicted"


def check_method_weights(method: str, weights: str | None, source: str = "weights") -> None:
    """Refuse ``weights`` given with a method that uses none (``geometric``): silently
    ignoring them would report the baseline as if it were the network.

    Raises:
        InputError: naming ``source``.
    """
    if weights is not None and method == "geometric":
        raise InputError(f"{source}: expected a 3DPCNet method (pcnet, pcnet-rigid), got method 'geometric', "
                         f"which uses no weights")


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
        from pcnet.models.inference import get_session

        session = get_session(None if weights is None else str(weights))
        if weights is None:
            R, residual, valid, gate = session.predict_gated(X, fps)
        else:
            (R, residual, valid), gate = session.predict(X), None
        if method == "pcnet-rigid":
            residual = np.where(valid[:, None, None], 0.0, np.nan)
        return R, residual, valid, gate
    raise InputError(f"unknown rectification method {method!r}; expected one of {METHODS}")


def gate_report(gate: np.ndarray | None, valid: np.ndarray) -> dict | None:
    """Summary of the camera-frame network's weights over the valid frames: its mean share
    and the frames where the body-frame network alone (weight 0) or a blend ran; ``None``
    when one estimator ran."""
    if gate is None:
        return None
    w = gate[valid]
    return {"camera_frame_share": float(np.mean(w)) if len(w) else float("nan"),
            "body_frame_frames": int(np.sum(w == 0.0)), "blended_frames": int(np.sum((w > 0.0) & (w < 1.0))),
            "frames": int(len(w))}


def resolve_heading_source(method: str, heading: str | None) -> str:
    """The heading source to use: ``heading`` itself, or for ``None`` the method's default,
    ``"auto"`` for the 3DPCNet methods and ``"predicted"`` for ``geometric``, which stays the
    paper's baseline (section 2.3: heading from the shoulder line).

    Raises:
        ValueError: ``heading`` is not ``None`` or one of
            :data:`pcnet.stages.heading.HEADING_SOURCES`.
    """
    if heading is None:
        return "predicted" if method == "geometric" else "auto"
    if heading not in HEADING_SOURCES:
        raise InputError(f"unknown heading source {heading!r}; expected one of {HEADING_SOURCES}")
    return heading


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
    :func:`pcnet.stages.conventions.validate_poses` (real-valued ``(T, 17, 3)``, at least
    one frame and one finite value, non-finite = missing) and the pelvis rule
    :func:`pcnet.stages.conventions.fill_pelvis_from_hips` (a missing pelvis is the hip
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


def finish_rotations(
    joints_cam: np.ndarray,
    R: np.ndarray,
    valid: np.ndarray,
    mode: str,
    fps: float,
    heading: str,
    n_bootstrap: int = BOOTSTRAP_REPLICATES,
    camera_prior: bool = True,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """The steps after a per-frame estimator, for one recording: the rectify ``mode``
    (:func:`pcnet.stages.temporal.rectify_sequence` unless ``"frame"``), then the ``heading``
    source (:func:`pcnet.stages.heading.apply_heading`; the up is kept).

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 camera-frame poses.
        R: ``(T, 3, 3)`` per-frame canonical->camera rotations; valid: ``(T,)`` bool.
        mode, fps: as :func:`rectify`; heading: one of
            :data:`pcnet.stages.heading.HEADING_SOURCES` (already resolved).
        n_bootstrap: sequence-mode uncertainty replicates (0 = none; rotations unchanged).
        camera_prior: as :func:`rectify` (sequence modes only).

    Returns:
        ``(R (T, 3, 3) float64, NaN where not valid; valid (T,) bool; report)`` with
        ``requested_mode``, ``mode`` and the sequence and heading reports.

    Raises:
        ValueError: unknown mode or heading source, or (sequence modes) no valid frame.
    """
    report: dict = {"requested_mode": mode, "mode": "frame"}
    if mode != "frame":
        if not valid.any():
            raise InputError(NO_VALID_FRAME)
        R, sequence_report = rectify_sequence(R, valid, mode, fps, joints_cam, n_bootstrap=n_bootstrap,
                                              camera_prior=camera_prior)
        report.update(sequence_report)
        valid = valid & np.asarray(report["valid"], bool)
        R = np.where(valid[:, None, None], R, np.nan)
    R, heading_report = apply_heading(joints_cam, R, valid, heading)
    report.update(heading_report)
    return R, valid, report
