"""Rectification steps after a per-frame estimator: the sequence modes and the heading source
(:func:`finish_rotations`), the result type and the option checks.

The estimators themselves (the geometric baseline, 3DPCNet through onnxruntime) and the
composed :func:`pcnet.pipeline.rectification.rectify` live in the pipeline, which is the room
allowed to use both ``stages`` and ``models`` (docs/architecture.md)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .heading import HEADING_SOURCES, apply_heading
from .temporal import BOOTSTRAP_REPLICATES, rectify_sequence
from .core.errors import InputError

METHODS = ("pcnet", "pcnet-rigid", "geometric")
NO_VALID_FRAME = "no frame has the hips, thorax and shoulders needed to rectify"


@dataclass(frozen=True)
class Rectified:
    """Output of :func:`pcnet.pipeline.rectification.rectify` for ``T`` frames.

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
        mode, fps: as :func:`pcnet.pipeline.rectification.rectify`; heading: one of
            :data:`pcnet.stages.heading.HEADING_SOURCES` (already resolved).
        n_bootstrap: sequence-mode uncertainty replicates (0 = none; rotations unchanged).
        camera_prior: as :func:`pcnet.pipeline.rectification.rectify` (sequence modes only).

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
