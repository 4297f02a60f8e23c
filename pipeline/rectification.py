"""Rectification composed: the pipeline picks the per-frame estimator (the geometric
baseline, or 3DPCNet through :mod:`pcnet.models.inference`, :func:`make_estimator`) and hands
it to the chain of steps in :mod:`pcnet.stages.rectify` (:class:`~pcnet.stages.rectify.Rectification`:
estimate -> sequence evidence -> heading).

It lives in the pipeline because it is the one room allowed to use both ``models`` and
``stages`` (docs/architecture.md): the stages never import the network.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace

import numpy as np

from pcnet.models.inference import get_session
from pcnet.models.view_gate import quarter_turn_matrices
from pcnet.adapters.validate import ROOT_RELATIVE_MAX
from pcnet.pipeline.config import unit_camera_up
from pcnet.stages.core.conventions import PELVIS, check_poses, fill_pelvis_from_hips, validate_fps, validate_poses
from pcnet.stages.core.errors import InputError, shown_value
from pcnet.stages.core.framestore import frame_blocks, in_memory
from pcnet.stages.rectify import (METHODS, MODES, Allocate, FrameEstimate, FrameEstimator, GeometricEstimator, HeadingStep,
                                  Rectification, Rectified, SequenceEvidence, check_method_weights,
                                  check_posture, no_valid_frame_reason, resolve_heading_source)
from pcnet.stages.uncertainty import FRAME_TILT_95_DEG
from pcnet.stages.up_model import UpEvidence


@dataclass(frozen=True)
class NetworkEstimator:
    """3DPCNet as step 1 (:class:`pcnet.stages.rectify.FrameEstimator`): the shipped ensemble gated
    by camera orientation (:class:`pcnet.models.inference.ViewGatedPCNet`, ``weights=None``;
    ``fps`` sets the gate's window, one recording per call) or one network's ``weights``
    (``.onnx``). ``rigid`` drops the residual (method ``pcnet-rigid``: a rigid rotation of the
    input). The per-frame tilt bound is calibrated for the shipped weights only."""

    weights: str | None = None
    rigid: bool = False

    @property
    def name(self) -> str:
        return "pcnet-rigid" if self.rigid else "pcnet"

    @property
    def frame_tilt_bound_base_deg(self) -> float:
        return FRAME_TILT_95_DEG if self.weights is None else float("nan")

    def __call__(self, joints_cam: np.ndarray, fps: float = 30.0, allocate: Allocate | None = None) -> FrameEstimate:
        X = check_poses(joints_cam, "joints_cam")
        session = get_session(None if self.weights is None else str(self.weights))
        if self.weights is None:
            R, residual, valid, gate, disagreement, turns, ups = session.predict_gated(X, fps, allocate)
            # Each frame at its own quarter turn (decision 0074); the gate's running window is frame and smooth modes'.
            evidence = UpEvidence.of(np.where(valid[:, None], ups.camera, np.nan), np.where(valid[:, None], ups.body, np.nan),
                                     quarter_turn_matrices(ups.turns) if ups.turns.any() else None)
        else:
            residual = (allocate or in_memory)("residual", X.shape, np.float64)
            (R, residual, valid), gate, disagreement, turns = session.predict(X, residual=residual), None, None, None
            evidence = None
        if self.rigid:
            for rows in frame_blocks(len(valid)):
                residual[rows] = np.where(valid[rows, None, None], 0.0, np.nan)
        return FrameEstimate(R, residual, valid, gate, disagreement, turns, evidence)


def make_estimator(method: str = "pcnet", weights: str | None = None) -> FrameEstimator:
    """Step 1 for ``method`` (:data:`pcnet.stages.rectify.METHODS`): ``pcnet`` (3DPCNet with its
    residual), ``pcnet-rigid`` (the same rotation, no residual), ``geometric`` (paper 2.3).

    Raises:
        InputError: unknown method, or ``weights`` with ``geometric``.
    """
    check_method_weights(method, weights)
    if method == "geometric":
        return GeometricEstimator()
    if method in ("pcnet", "pcnet-rigid"):
        return NetworkEstimator(None if weights is None else str(weights), rigid=method == "pcnet-rigid")
    raise InputError(f"unknown rectification method {method!r}; expected one of {METHODS}")


#: Frame rate :func:`rectify` assumes in frame mode when none is given: it sets only the view
#: gate's running window there.
VIEW_GATE_DEFAULT_FPS = 30.0


def check_measured_root(root_cam: np.ndarray, who: str, advice: str) -> None:
    """Refuse a "measured" pelvis path ``root_cam`` ``(T, 3)`` (metric, camera frame) that stays at
    the camera's origin (median distance within
    :data:`pcnet.adapters.validate.ROOT_RELATIVE_MAX`): a root-relative export has no path to
    keep, and the floor fit would take the pelvis as standing at the lens.

    Raises:
        InputError: naming ``who``, the pelvis's median distance and ``advice``.
    """
    distance = np.linalg.norm(root_cam, axis=1)
    distance = distance[np.isfinite(distance)]
    if len(distance) and np.median(distance) <= ROOT_RELATIVE_MAX:
        raise InputError(f"{who}: expected a measured pelvis path (the pelvis where the person is), got a pelvis at "
                         f"the camera's origin (median distance {np.median(distance):.2g}): root-relative joints; {advice}")


def rectify(
    joints_cam: np.ndarray,
    method: str = "pcnet",
    weights: str | None = None,
    mode: str = "frame",
    fps: float | None = None,
    heading: str | None = None,
    camera_prior: bool = True,
    measured_root: bool = False,
    posture: str = "auto",
    camera_up=None,
) -> Rectified:
    """Rectify camera-frame H36M-17 poses ``(T, 17, 3)`` into the canonical frame
    (``docs/CONVENTIONS.md``): ``canonical = (X - pelvis) @ R + residual``, the residual being the
    network's non-rigid correction (not returned: ``canonical - (X - pelvis) @ R``, about 0.5 cm a
    joint on upright bodies, over 10 cm on a prone one; zero for ``pcnet-rigid`` and ``geometric``;
    ``pcnet run``'s kinematics leave it out, decision 0100). NaN joints stay NaN.

    ``mode``: ``frame`` (each frame alone, the paper), ``sequence`` (one up direction for a
    static camera), ``smooth`` (SO(3) smoothing for a moving camera) or
    ``auto`` (:class:`pcnet.stages.rectify.SequenceEvidence`). ``fps``: the recording's frame
    rate in Hz; every mode but ``frame`` pools frames over seconds, so it needs it (a 60 fps
    recording read as 30 fps would smooth and decide over twice the time); ``frame`` mode reads
    it only for the view gate's running window and takes 30 when it is not given. The steps are
    :class:`pcnet.stages.rectify.Rectification`'s with :func:`make_estimator`'s estimator. ``heading``: where the
    heading about that up comes from, ``predicted`` (the method's rotation), ``hips`` (the
    input's hip line, the canonical frame's definition) or ``auto`` (hips when they are
    precise, :func:`pcnet.stages.heading.apply_heading`); ``None`` =
    :func:`resolve_heading_source`. ``camera_prior``: sequence mode of the shipped ensemble is the
    up model's posterior (:mod:`pcnet.stages.up_model`) with its declared camera prior and lying
    reading; False = the poses alone (a uniform prior, upright). Other methods' sequence mode
    is the robust mean of their per-frame ups with its bootstrap, no prior (with
    ``heading="predicted"`` and ``weights`` one 3DPCNet's ONNX, the paper's model alone).
    ``posture``: ``auto`` (the up model's priors decide), or ``upright`` / ``lying`` where the
    user knows it (:data:`pcnet.stages.rectify.POSTURES`): a body lying under a level camera and
    an upright one under a camera turned a quarter turn give the same poses, so only the priors
    or the user can tell them apart (docs/up_model.md); only the shipped ensemble's sequence up
    (``method`` pcnet or pcnet-rigid without ``weights``, mode sequence) reads it.
    ``measured_root``: the joints keep a camera-frame root path (a depth sensor's, or one
    recovered from 2D keypoints by :func:`pcnet.stages.root_path.root_from_keypoints`, as
    ``pcnet run`` does), so sequence mode also weighs the floor contacts
    (:mod:`pcnet.stages.ground_plane`); root-relative joints carry no floor. ``camera_up``: the
    static camera's up where it is known, ``(3,)`` in the camera frame (any length; a
    calibration's, a gravity sensor's), for mode ``sequence``: each frame's rotation is turned to
    it instead of an estimated one (:class:`pcnet.stages.rectify.SequenceEvidence`). ``report`` says
    what ran (:class:`pcnet.stages.rectification_report.RectificationReport`; ``as_record()``
    gives the keys of docs/outputs.md's ``report`` that rectification sets, and sequence mode's
    intervals are ``report.sequence.camera_pitch_interval_deg`` and ``..._roll_...``); the
    camera's tilt, pitch and roll, which ``pcnet run`` adds to its report, are
    ``pcnet.pipeline.checks.CameraTilt.of(result.rotation, result.valid)`` (a developer trial
    looked for ``camera_tilt_deg`` in ``as_record()``).

    Input rules shared with ``pcnet run`` and ``pcnet rectify``:
    :func:`pcnet.stages.core.conventions.validate_poses` (real-valued ``(T, 17, 3)``, at least
    one frame and one finite value, non-finite or masked = missing; here and in ``pcnet
    rectify`` a single ``(17, 3)`` pose is read as one frame, while ``pcnet run``'s lifter
    files hold ``(T, J, 3)`` as their formats do) and the pelvis rule
    :func:`pcnet.stages.core.conventions.fill_pelvis_from_hips` (a missing pelvis is the hip
    midpoint; a frame still without a pelvis is invalid). The report's
    ``pelvis_from_hips_frames`` counts the filled frames; its ``weights``
    (:class:`~pcnet.stages.rectification_report.EnsembleWeights`, a summary) and
    ``camera_frame_weight`` (``(T,)`` per frame) say how far the shipped camera-frame network
    was trusted (3DPCNet methods without ``weights``). The warnings ``pcnet run`` would give these poses
    alone (a mirrored skeleton, the camera's orientation, ...) are
    :func:`pcnet.pipeline.checks.pose_checks` of the poses and the result.

    Raises:
        InputError (a ValueError): bad input array (see above), unknown method, mode,
            heading source or posture, a posture declared where nothing reads it
            (:func:`pcnet.stages.rectify.check_posture`), an option of another type
            (``camera_prior``, ``measured_root`` not a bool; ``fps`` not a number: ``"no"``
            would read as true), no ``fps`` for a mode other than ``frame``, ``camera_up`` not three
            finite numbers, not all 0, or outside mode ``sequence`` or with a declared posture,
            ``measured_root`` over root-relative joints
            (:func:`check_measured_root`), or no valid frame (none with the hips, thorax and
            shoulders; in sequence mode also none with a heading about the sequence up, the
            input's axes wrong: :func:`pcnet.stages.rectify.no_valid_frame_reason`).
    """
    for name, value in (("camera_prior", camera_prior), ("measured_root", measured_root)):
        if not isinstance(value, (bool, np.bool_)):
            raise InputError(f"rectify: {name}: expected True or False, got {shown_value(value)} "
                             f"({type(value).__name__})")
    # names before anything compares them (a developer trial's arrays met numpy's "truth value
    # is ambiguous" and, as weights, "File name too long")
    for name, value in (("method", method), ("mode", mode), ("heading", heading), ("posture", posture)):
        if not isinstance(value, str) and not (name == "heading" and value is None):
            raise InputError(f"rectify: {name}: expected a name (str), got {shown_value(value)}")
    if weights is not None and not isinstance(weights, (str, os.PathLike)):
        raise InputError(f"rectify: weights: expected None or the path of an .onnx file (str or Path), got "
                         f"{shown_value(weights)}")
    check_posture(posture, method, weights, mode, camera_prior, "rectify: posture")
    if fps is None and mode in MODES and mode != "frame":
        raise InputError(f"rectify: mode {mode!r} pools frames over seconds: give fps, the recording's frame rate (Hz)")
    fps = VIEW_GATE_DEFAULT_FPS if fps is None else validate_fps(fps, "rectify: fps")
    joints_cam, pelvis_filled = fill_pelvis_from_hips(validate_poses(joints_cam, "joints_cam"))
    if measured_root:
        check_measured_root(joints_cam[:, PELVIS], "rectify: measured_root", "pass measured_root=False")
    result = rectify_checked(joints_cam, method, weights, mode, fps, heading, camera_prior, measured_root=measured_root,
                             posture=posture,
                             camera_up=None if camera_up is None else unit_camera_up(camera_up, "rectify: camera_up",
                                                                                     "(x, y, z)"))
    if not result.valid.any():
        # the same refusal as pcnet run's, in every mode: an answer of NaN rows alone reads as a
        # result (a trial's frame-mode call without hips returned one, and no finding)
        raise InputError(no_valid_frame_reason(result.report))
    return replace(result, report=replace(result.report, pelvis_from_hips_frames=int(pelvis_filled.sum())))


def rectify_checked(joints_cam, method: str = "pcnet", weights: str | None = None, mode: str = "frame",
                    fps: float | None = None, heading: str | None = None, camera_prior: bool = True,
                    allocate: Allocate | None = None, decide_on: np.ndarray | None = None,
                    measured_root: bool = False, posture: str = "auto",
                    camera_up: tuple[float, float, float] | None = None,
                    camera_up_interval_deg: tuple[float, float] | None = None) -> Rectified:
    """:func:`rectify` of poses that already passed its input rules (``pcnet run`` applies
    them a block at a time), in memory or a
    :class:`~pcnet.stages.core.framestore.FrameArray`; ``allocate`` makes the residual and
    canonical arrays (:data:`pcnet.stages.rectify.Allocate`; default in memory); ``decide_on``
    ``(T,)`` bool, one person's stretch of a 2D track that switches people: the frames mode
    ``auto`` decides on and the only ones whose feet the floor contacts read
    (:class:`pcnet.stages.rectify.SequenceEvidence`). ``fps`` is required in every mode (no
    default here: the caller knows the rate); ``camera_up`` a unit ``(x, y, z)``
    (:func:`pcnet.pipeline.config.unit_camera_up`), ``camera_up_interval_deg`` its own 95 %
    pitch and roll half-widths where it is another run's estimate (``--camera-up-from``).
    No ``pelvis_from_hips_frames`` in the report.

    Raises:
        InputError: as :func:`rectify`, but for the input rules; no ``fps``.
    """
    heading_step = HeadingStep(resolve_heading_source(method, heading))
    chain = Rectification(make_estimator(method, weights),
                          SequenceEvidence(mode, camera_prior, measured_root=measured_root, posture=posture,
                                           camera_up=camera_up, camera_up_interval_deg=camera_up_interval_deg),
                          heading_step, allocate)
    return chain(joints_cam, validate_fps(fps), decide_on)
