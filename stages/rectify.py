"""Rectification as a chain of steps, each a small object with one contract, composed by
:class:`Rectification`:

1. **estimate per frame**: a :class:`FrameEstimator` (``joints_cam, fps -> FrameEstimate``):
   :class:`GeometricEstimator` (paper section 2.3) here, 3DPCNet through onnxruntime built
   by the pipeline (:func:`pcnet.pipeline.rectification.make_estimator`), so that stages never
   import the network;
2. **sequence evidence**: :class:`SequenceEvidence` (``"frame"`` = none, the paper; the
   static-camera sequence up with floor contacts and camera prior, or SO(3) smoothing, the
   estimators in :mod:`pcnet.stages.temporal`);
3. **heading**: :class:`HeadingStep` (predicted or hip line, :func:`pcnet.stages.heading.apply_heading`);
4. **world frame**: one gravity-aligned frame per recording, built by the pipeline from the
   result (:func:`pcnet.stages.world_frame.world_frame`), after scaling.

Shapes and frames: ``joints_cam`` ``(T, 17, 3)`` H36M-17, OpenCV camera frame, any unit;
rotations ``(T, 3, 3)`` canonical->camera (docs/CONVENTIONS.md); invalid frames NaN."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from .core.canonical import to_canonical
from .core.conventions import check_poses
from .core.errors import InputError
from .core.framestore import arrays_repr, frame_blocks, freeze_arrays, in_memory, restore_frozen
from .core.geometric import geometric_rotation
from .ground_plane import posture_and_floor_up
from .core.rotations import angle_between, camera_pitch_roll, normalize
from .heading import HEADING_SOURCES, apply_heading
from .rectification_report import (GIVEN_UP, EnsembleWeights, HeadingChoice, ModeChoice, PostureHypotheses,
                                   RectificationReport, SequenceUp)
from .temporal import (BOOTSTRAP_REPLICATES, HEADING_LIMIT_DEG, MODE_THRESHOLD_DEG, MODES, SMOOTH_TIME_CONSTANT_S,
                       check_rotations, choose_mode, rotations_about_up, sequence_rectify, smooth_rotations,
                       up_spread_deg)
from .uncertainty import frame_tilt_bound
from .up_model import (OTHER_POSTURE_P, Z95, UpEvidence, UpModelParameters, default_parameters,
                       summarise_recording, tangent_per_pitch_roll)

METHODS = ("pcnet", "pcnet-rigid", "geometric")
#: The body's posture in sequence mode's up model: ``auto`` (the posterior decides, with the
#: declared prior ``lying_prior``) or one the user declares (a prior of 0 or 1 on lying).
POSTURES = ("auto", "upright", "lying")
# "apart": a bad-input trial's coinciding hips read as hips missing
NO_VALID_FRAME = "no frame has the hips, thorax and shoulders needed to rectify (each present, the two hips apart)"


def check_posture(posture: object, method: str, weights: str | None, mode: str, camera_prior: bool, who: str) -> None:
    """Refuse a ``posture`` (:data:`POSTURES`) that is not one, or one
    declared (``upright``/``lying``) where nothing would read it: only the up model's posture
    hypotheses do, in sequence mode of the shipped ensemble (``method`` pcnet or pcnet-rigid
    without ``weights``) with its camera prior. Auto mode is refused too: where it chooses
    smooth mode the declaration would be dropped (a user trial). ``who`` names the option.

    Raises:
        InputError: one line naming ``who``, what was expected and what was given.
    """
    if posture not in POSTURES:
        raise InputError(f"{who}: expected one of {', '.join(POSTURES)}, got {posture!r}")
    if posture == "auto":
        return
    if method not in ("pcnet", "pcnet-rigid"):
        why = "another method's sequence up has no posture hypotheses"
    elif weights is not None:
        why = "one network's weights have no posture hypotheses"
    elif mode == "auto":
        why = "mode auto may choose smooth mode, which has no posture hypotheses"
    elif mode != "sequence":
        why = f"mode {mode} has no posture hypotheses"
    elif not camera_prior:
        why = "the lying posture's up comes from the camera prior"
    else:
        return
    raise InputError(f"{who}: expected with the shipped ensemble's sequence mode and its camera prior ({why}), "
                     f"got posture {posture}")


def no_valid_frame_reason(report: RectificationReport) -> str:
    """Why a rectified recording kept no frame: :data:`NO_VALID_FRAME`, or, where sequence mode
    chose an up further than :data:`pcnet.stages.temporal.HEADING_LIMIT_DEG` from the frames'
    own ups (median), that no frame has a heading about it
    (:func:`pcnet.stages.temporal.rotations_about_up`), with the way out."""
    seq = report.sequence
    if seq is None or not seq.up_spread_deg > HEADING_LIMIT_DEG:
        return NO_VALID_FRAME
    return (f"every frame's own up is more than {HEADING_LIMIT_DEG:.0f} deg from the sequence up (median "
            f"{seq.up_spread_deg:.0f} deg), so no frame has a heading about it: the input's axes may be wrong (check "
            "the lifter's axis convention; --axes with --lifter generic), or the camera upside down, which sequence "
            "mode's camera prior reads as a level camera (--mode frame answers each frame alone)")

#: ``allocate(name, shape, dtype)``: a new NaN-filled ``(T, ...)`` array for a whole-recording
#: result (the residual, the canonical poses):
#: :func:`~pcnet.stages.core.framestore.in_memory`, or a
#: :class:`~pcnet.stages.core.framestore.FrameStore`'s ``create`` for a long recording.
Allocate = Callable[[str, tuple, type], np.ndarray]


@dataclass(frozen=True, eq=False)
class Rectified:
    """Output of :class:`Rectification` for ``T`` frames.

    rotation ``(T, 3, 3)`` float64 canonical->camera; canonical ``(T, 17, 3)`` float32 whatever
    the input's dtype (the precision every lifter writes, half the memory of a long recording) canonical
    poses in the input's units, pelvis-centred before the network's residual (turned into this
    frame; about 0.5 cm a joint on upright bodies, over 10 cm on a prone one, and the pelvis moves
    with it; docs/outputs.md); up ``(T, 3)`` float64 unit up direction in the
    camera frame (``rotation[:, :, 1]``); valid ``(T,)`` bool; method name; report: what was decided and
    why (:class:`~pcnet.stages.rectification_report.RectificationReport`). Invalid frames are NaN.
    Its in-memory arrays are read-only, unpickled too (a long recording's on disk are the store's).
    """

    rotation: np.ndarray
    canonical: np.ndarray
    up: np.ndarray
    valid: np.ndarray
    method: str
    report: RectificationReport

    def __post_init__(self) -> None:
        freeze_arrays(self)

    def __setstate__(self, state: dict) -> None:
        restore_frozen(self, state)

    def __repr__(self) -> str:
        return arrays_repr(self)

    @property
    def mode(self) -> str:
        """The temporal mode that ran (``auto`` resolved)."""
        return self.report.mode.run

    @property
    def heading_source(self) -> str:
        """Where the heading came from: ``"predicted"`` or ``"hips"``."""
        return self.report.heading.source


def check_method_weights(method: str, weights: str | None, source: str = "weights") -> None:
    """Refuse ``weights`` given with a method that uses none (``geometric``): silently
    ignoring them would report the baseline as if it were the network.

    Raises:
        InputError: naming ``source``.
    """
    if weights is not None and method == "geometric":
        raise InputError(f"{source}: expected a 3DPCNet method (pcnet, pcnet-rigid), got method 'geometric', "
                         f"which uses no weights")


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


@dataclass(frozen=True, eq=False)
class FrameEstimate:
    """Step 1's output for ``T`` frames: ``rotation`` ``(T, 3, 3)`` float64 canonical->camera,
    ``residual`` ``(T, 17, 3)`` the non-rigid correction in the canonical frame and the
    input's units (the paper's Delta; zeros for estimators without one), ``valid`` ``(T,)``
    bool (NaN rotations where False), ``camera_frame_weight`` ``(T,)`` the shipped ensemble's
    trust in its camera-frame network per frame (:mod:`pcnet.models.view_gate`) and
    ``disagreement_deg`` ``(T,)`` the angle between its two networks' ups and
    ``quarter_turns`` ``(T,)`` int, the quarter turns about the optical axis the camera-frame
    network's input was turned back by, 0, 1 or 3 and ``evidence`` the two networks' own ups
    (:class:`pcnet.stages.up_model.UpEvidence`; each ``None`` when one estimator ran)."""

    rotation: np.ndarray
    residual: np.ndarray
    valid: np.ndarray
    camera_frame_weight: np.ndarray | None = None
    disagreement_deg: np.ndarray | None = None
    quarter_turns: np.ndarray | None = None
    evidence: UpEvidence | None = None


class FrameEstimator(Protocol):
    """Step 1: per-frame canonical->camera rotations of one recording.

    ``name`` is the method name reported (:data:`METHODS`); ``frame_tilt_bound_base_deg`` the
    per-frame tilt bound calibrated for it (:data:`pcnet.stages.uncertainty.FRAME_TILT_95_DEG`
    for the shipped weights; NaN when none was calibrated)."""

    name: str
    frame_tilt_bound_base_deg: float

    def __call__(self, joints_cam: np.ndarray, fps: float, allocate: Allocate | None = None) -> FrameEstimate:
        """``allocate`` (optional; only passed when the chain has one) makes the residual
        array (:data:`Allocate`)."""


@dataclass(frozen=True)
class GeometricEstimator:
    """The paper's geometric baseline (section 2.3; :func:`pcnet.stages.core.geometric.geometric_rotation`):
    up from the trunk, heading from the shoulder line, no residual."""

    name: str = "geometric"
    frame_tilt_bound_base_deg: float = float("nan")

    def __call__(self, joints_cam: np.ndarray, fps: float = 30.0, allocate: Allocate | None = None) -> FrameEstimate:
        X = check_poses(joints_cam, "joints_cam")
        R, valid = geometric_rotation(X)
        residual = (allocate or in_memory)("residual", X.shape, np.float64)
        for rows in frame_blocks(len(X)):
            residual[rows] = 0.0
        return FrameEstimate(R, residual, valid)


@dataclass(frozen=True, eq=False)
class SequenceOutcome:
    """Step 2's output for ``T`` frames: ``rotation`` ``(T, 3, 3)`` canonical->camera (NaN
    where not valid; frame mode: as given), ``valid`` ``(T,)`` bool, the ``mode`` choice and,
    in sequence mode, the static camera's ``up`` (else ``None``)."""

    rotation: np.ndarray
    valid: np.ndarray
    mode: ModeChoice
    up: SequenceUp | None = None


@dataclass(frozen=True)
class SequenceEvidence:
    """Step 2: what the whole recording says beyond each frame.

    ``mode``: ``"frame"`` (nothing; the paper's per-frame rotations, returned as given),
    ``"sequence"`` (static camera: one up; the shipped ensemble's by the up model,
    :func:`up_model_sequence`, another method's by :func:`pcnet.stages.temporal.sequence_rectify`;
    floor contacts when the root is measured), ``"smooth"`` (moving camera:
    :func:`pcnet.stages.temporal.smooth_rotations`, kernel
    :data:`pcnet.stages.temporal.SMOOTH_TIME_CONSTANT_S`) or ``"auto"`` (one of the last two by
    :func:`pcnet.stages.temporal.choose_mode`; ``"frame"`` for a recording with one valid
    frame, with that reason). ``camera_prior``: the up model's declared priors (False: the
    poses alone). ``posture``: :data:`POSTURES`, the up model's posture hypotheses
    (:func:`up_model_sequence`). ``n_bootstrap``: replicates of another method's sequence-mode
    uncertainty (0 = none, NaN; the rotations do not depend on it). ``measured_root``: the joints carry a
    camera-frame pelvis path (a depth sensor's, or one recovered from 2D keypoints,
    :mod:`pcnet.stages.root_path`), so sequence mode fuses the floor contacts
    (:mod:`pcnet.stages.ground_plane`); root-relative joints carry no floor. ``camera_up``: the
    static camera's up where it is known, a unit ``(x, y, z)`` in the camera frame (a
    calibration's, a gravity sensor's): sequence mode then turns each frame's rotation to it
    (:func:`pcnet.stages.temporal.rotations_about_up`, each keeping its heading) instead of
    estimating one; its :class:`SequenceUp` has ``evidence`` ``"given"``, no interval (NaN)
    unless ``camera_up_interval_deg`` gives the given up's own 95 % pitch and roll half-widths
    (another run's estimate), and the per-frame ups' angles from it as its spread.

    Raises:
        InputError: unknown ``mode`` or ``posture``; a declared posture without the camera prior
            (the lying hypothesis's up comes from it); ``camera_up`` not a unit 3-vector, or
            given outside sequence mode or with a declared posture.
    """

    mode: str = "frame"
    camera_prior: bool = True
    n_bootstrap: int = BOOTSTRAP_REPLICATES
    measured_root: bool = False
    posture: str = "auto"
    camera_up: tuple[float, float, float] | None = None
    camera_up_interval_deg: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise InputError(f"unknown mode {self.mode!r}; expected one of {MODES}")
        if self.posture not in POSTURES:
            raise InputError(f"posture: expected one of {', '.join(POSTURES)}, got {self.posture!r}")
        if self.posture != "auto" and not self.camera_prior:
            raise InputError(f"posture {self.posture}: expected with the camera prior (the lying posture's up comes "
                             f"from it), got camera_prior False")
        if self.camera_up is not None:
            up = np.asarray(self.camera_up, np.float64)
            if up.shape != (3,) or not np.isfinite(up).all() or abs(np.linalg.norm(up) - 1.0) > 1e-6:
                raise InputError(f"camera_up: expected a unit (x, y, z) in the camera frame, got {self.camera_up!r}")
            if self.mode != "sequence" or self.posture != "auto":
                raise InputError(f"camera_up: expected with mode sequence and posture auto (one given up for a static "
                                 f"camera), got mode {self.mode}, posture {self.posture}")

    def __call__(self, joints_cam: np.ndarray | None, R: np.ndarray, valid: np.ndarray | None,
                 fps: float, decide_on: np.ndarray | None = None, calibrated: bool = True,
                 evidence: UpEvidence | None = None) -> SequenceOutcome:
        """Apply the mode to one recording.

        Args:
            joints_cam: ``(T, 17, 3)`` camera-frame joints (floor contacts in sequence mode
                where they carry a pelvis path, ``measured_root``) or ``None``. evidence: the two networks' own ups (the shipped ensemble):
                sequence mode is then the up model's static posterior (:func:`up_model_sequence`).
            R: ``(T, 3, 3)`` per-frame canonical->camera rotations; valid: ``(T,)`` bool or
                ``None`` (all). fps: frame rate, > 0. decide_on:
                optional ``(T,)`` bool, one person's stretch of a 2D track that switches
                people (:func:`pcnet.stages.flags.one_person_frames`): the frames ``"auto"``
                decides on and sequence and smooth modes' spread is read over, at any length
                (decision 0089; every valid frame when ``None`` or when fewer than 2 of its
                frames are valid), and the only frames
                whose feet the shipped ensemble's floor contacts read (decision 0066). calibrated: the
                lifter's systematic error is calibrated for the estimator (the shipped ensemble
                only); otherwise the sequence up has its bootstrap and NaN intervals.

        Raises:
            InputError: bad shapes, non-positive fps, or (not frame mode) no valid frame.
        """
        if self.mode == "frame":
            return SequenceOutcome(R, valid, ModeChoice(self.mode, "frame"))
        R, ok = check_rotations(R, valid)
        if not ok.any():
            raise InputError(NO_VALID_FRAME)
        if not fps > 0:
            raise InputError(f"fps must be positive, got {fps}")
        if self.mode == "auto" and ok.sum() < 2:
            # One pose shows neither a static nor a moving camera, and pools nothing: its
            # per-frame answer, with the per-frame bound as its uncertainty.
            return SequenceOutcome(R, ok, ModeChoice(self.mode, "frame", reason="one valid frame"))
        # Another person's poses and the jump to them read as camera motion: one person's stretch
        # decides, whatever its length, as a recording of that length alone would (decision 0089).
        # Sequence mode's spread (its moving-camera note) is read over the same frames.
        subset = decide_on is not None and (ok & decide_on).sum() >= 2
        decide = ok & decide_on if subset else ok
        decided_on = int(decide.sum()) if subset else None
        if self.mode == "auto":
            run, spread = choose_mode(R, decide, MODE_THRESHOLD_DEG, fps)
        else:
            run, spread = self.mode, up_spread_deg(R, decide, fps)
        if run == "smooth":
            out = smooth_rotations(R, ok, fps, SMOOTH_TIME_CONSTANT_S)
            mode = ModeChoice(self.mode, run, spread_deg=spread, decided_on_frames=decided_on,
                              smooth_time_constant_s=SMOOTH_TIME_CONSTANT_S)
            valid = ok & np.isfinite(out).all((1, 2))
            return SequenceOutcome(np.where(valid[:, None, None], out, np.nan), valid, mode)
        mode = ModeChoice(self.mode, run, spread_deg=spread, decided_on_frames=decided_on)
        located = joints_cam if self.measured_root else None
        if self.camera_up is not None:
            # the poses' own reading beside it, so that a given up the poses contradict is told
            estimate = up_model_sequence(R, ok, evidence, fps, self.camera_prior, located, floor_frames=decide_on)[2] \
                if evidence is not None and calibrated else None
            out, valid, up = given_up_sequence(R, ok, np.asarray(self.camera_up, np.float64), estimate,
                                               self.camera_up_interval_deg)
            return SequenceOutcome(np.where(valid[:, None, None], out, np.nan), valid, mode, up)
        if evidence is not None and calibrated:
            # A path that jumps to another person is not one body's: the floor reads one person's feet (decision 0066).
            out, valid, up = up_model_sequence(R, ok, evidence, fps, self.camera_prior, located, floor_frames=decide_on,
                                               posture=self.posture)
        else:  # another method's sequence up: its bootstrap, no calibrated interval
            res = sequence_rectify(R, ok, located, fps=fps, n_bootstrap=self.n_bootstrap)
            out, valid = res.rotations, res.valid
            up = SequenceUp(
                evidence=res.evidence, up=res.up, camera_pitch_deg=res.camera_pitch_deg,
                camera_roll_deg=res.camera_roll_deg, camera_pitch_interval_deg=float("nan"),
                camera_roll_interval_deg=float("nan"), up_uncertainty_deg=res.up_uncertainty_deg,
                camera_pitch_uncertainty_deg=res.camera_pitch_uncertainty_deg,
                camera_roll_uncertainty_deg=res.camera_roll_uncertainty_deg, interval_reaches_other_posture_p=None,
                posture=None, up_spread_deg=res.up_spread_deg, up_spread_p95_deg=res.up_spread_p95_deg,
                ground_plane=res.ground_plane)
        valid = ok & np.asarray(valid, bool)
        return SequenceOutcome(np.where(valid[:, None, None], out, np.nan), valid, mode, up)


def given_up_sequence(R: np.ndarray, ok: np.ndarray, up: np.ndarray, estimate: SequenceUp | None = None,
                      interval_deg: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray, SequenceUp]:
    """Sequence mode with the camera's up given: each valid frame's rotation turned to ``up``
    (:func:`pcnet.stages.temporal.rotations_about_up`, its heading kept), ``(T, 3, 3)``; the
    frames where that is defined ``(T,)`` bool; and the :class:`SequenceUp` (``evidence``
    ``"given"``, pitch and roll of ``up``, no interval or uncertainty: NaN; the spread the
    median and 95th percentile angle of the valid per-frame ups from ``up``, deg;
    ``poses_estimate`` from ``estimate``, the poses' own up, where it has a 95 % interval).
    ``interval_deg``: the given up's own 95 % pitch and roll half-widths where it is an
    estimate (another run's: ``--camera-up-from``), its interval then; ``up_uncertainty_deg``
    their combination, as an estimated up's.

    Args:
        R: ``(T, 3, 3)`` per-frame canonical->camera rotations; ok: ``(T,)`` bool, the valid ones.
        up: ``(3,)`` unit up, camera frame (OpenCV axes).
        estimate: the up model's reading of the same poses, or ``None``.

    Raises:
        InputError: no valid frame can be turned to ``up`` (it points nearly opposite to every
            frame's own up: a sign flipped).
    """
    out, made = rotations_about_up(R, up)
    valid = ok & made
    angles = np.degrees(angle_between(R[ok][:, :, 1], up))
    if not valid.any():
        raise InputError(f"camera_up: expected an up the poses can be turned to, got one {np.median(angles):.0f} deg "
                         f"from their own in every frame (its sign flipped? a level camera's is 0,-1,0)")
    pitch, roll = (float(np.degrees(a)) + 0.0 for a in camera_pitch_roll(up))  # + 0.0: no "-0.0"
    poses = None
    if estimate is not None and np.isfinite([estimate.camera_pitch_interval_deg, estimate.camera_roll_interval_deg]).all():
        pitch_gap = pitch - estimate.camera_pitch_deg
        roll_gap = (roll - estimate.camera_roll_deg + 180.0) % 360.0 - 180.0
        poses = {"pitch_deg": estimate.camera_pitch_deg, "roll_deg": estimate.camera_roll_deg,
                 "pitch_interval_deg": estimate.camera_pitch_interval_deg,
                 "roll_interval_deg": estimate.camera_roll_interval_deg,
                 "angle_from_given_deg": float(np.degrees(angle_between(estimate.up, up))),
                 "outside_interval": bool(abs(pitch_gap) > estimate.camera_pitch_interval_deg
                                          or abs(roll_gap) > estimate.camera_roll_interval_deg)}
    nan = float("nan")
    pitch_int, roll_int = (float(v) for v in interval_deg) if interval_deg is not None else (nan, nan)
    return out, valid, SequenceUp(
        evidence=GIVEN_UP, up=up.copy(), camera_pitch_deg=pitch, camera_roll_deg=roll,
        camera_pitch_interval_deg=pitch_int, camera_roll_interval_deg=roll_int,
        up_uncertainty_deg=float(np.hypot(pitch_int, roll_int)), camera_pitch_uncertainty_deg=nan,
        camera_roll_uncertainty_deg=nan, interval_reaches_other_posture_p=None, posture=None,
        up_spread_deg=float(np.median(angles)), up_spread_p95_deg=float(np.percentile(angles, 95)),
        ground_plane={"used": False, "reason": "the camera's up was given"}, poses_estimate=poses)


def up_model_sequence(R: np.ndarray, ok: np.ndarray, evidence: UpEvidence, fps: float, camera_prior: bool = True,
                      joints_cam: np.ndarray | None = None, params: UpModelParameters | None = None,
                      floor_frames: np.ndarray | None = None,
                      posture: str = "auto") -> tuple[np.ndarray, np.ndarray, SequenceUp]:
    """Sequence mode by the up model (:mod:`pcnet.stages.up_model`): the static posterior's up
    for every valid frame and each frame's heading about it
    (:func:`pcnet.stages.temporal.rotations_about_up` of the per-frame rotations ``R``
    ``(T, 3, 3)``; ``ok`` ``(T,)`` bool their valid frames).

    ``camera_prior`` False: a uniform prior over the up and no lying hypothesis (the poses
    alone). ``posture`` (:data:`POSTURES`): ``auto``, or ``upright`` / ``lying`` declared by the
    user, who knows what the poses cannot tell (docs/up_model.md, "What the poses cannot tell"):
    the posture prior ``rho`` becomes 0 / 1, and the camera prior stays; a declared lying body
    whose trunk the answer leaves nearer vertical than horizontal (its trunk runs up and down the
    image: a portrait camera without its display rotation) is refused. ``joints_cam``
    ``(T, 17, 3)`` with a pelvis path (measured, or from 2D keypoints): the footfalls weigh in
    the posture's posterior, and an upright posture's up is then fused with the floor contacts
    (:func:`pcnet.stages.ground_plane.posture_and_floor_up`). The intervals stay the up model's:
    the fused ones are too narrow on validation
    (``benchmarks/results/fit_floor_contacts.txt``). ``params``: the up model's parameters
    (default: the shipped ones; the ablation switches terms off through them). ``floor_frames``:
    ``(T,)`` bool, the only frames whose feet the floor contacts read (one person's stretch of
    a 2D track that switches people, :func:`pcnet.stages.flags.one_person_frames`; decision
    0066), or ``None`` (every valid frame); the poses' up reads every valid frame.

    Returns:
        ``(rotations (T, 3, 3), valid (T,) bool, up)``: the
        :class:`~pcnet.stages.rectification_report.SequenceUp` with the posterior's 95 %
        half-widths as intervals, the poses' part alone (Laplace, no systematic error) as the
        uncertainties and the posture hypotheses.

    Raises:
        InputError: ``posture`` lying where the lying posture's answer leaves the trunk nearer
            vertical than horizontal (the declaration cannot be met).
    """
    params = default_parameters() if params is None else params
    if not camera_prior:
        params = replace(params, camera_prior_outside=1.0)
    if posture != "auto":
        params = replace(params, lying_prior=float(posture == "lying"))
    summary = summarise_recording(evidence.frames(ok), fps, params)
    J = None if joints_cam is None else check_poses(joints_cam, "joints_cam")
    floor_ok = ok if floor_frames is None else ok & np.asarray(floor_frames, bool)
    chain = posture_and_floor_up(summary, J, floor_ok, params, lying=camera_prior)
    post, up, ground = chain.posterior, chain.up, chain.ground
    if posture == "lying":
        trunk_from_vertical = float(np.degrees(np.arccos(min(1.0, abs(float(post.summary.up @ up))))))
        if trunk_from_vertical < 45.0:  # nearer vertical than horizontal: not lying
            # the likeliest cause first: a clinic trial's seated lotus was told to turn its input
            raise InputError(f"posture lying: expected a lying trunk, got one {trunk_from_vertical:.0f} deg from "
                             f"vertical at the up the camera prior allows: the trunk runs up and down the image, "
                             f"as a sitting or standing body's does (leave the posture to the priors, auto, or "
                             f"declare upright); a lying body shows that only to a camera turned a quarter turn or "
                             f"looking straight down (turn the input to how it was displayed: a phone's display "
                             f"rotation)")
    kind = "up model+ground_plane" if ground["used"] else "up model"
    rotations, heading_ok = rotations_about_up(R, up)
    pitch, roll = camera_pitch_roll(up)
    # the summary's covariance is in tangent radians; the printed figures are pitch and roll angles
    pose_sd = np.degrees(np.sqrt(np.diag(post.summary.cov)) / tangent_per_pitch_roll(post.summary.up))
    spread = np.degrees(angle_between(normalize(R[ok, :, 1]), up[None]))
    hypotheses = PostureHypotheses(post.posture, float(post.p_lying), post.summary.up, declared=posture != "auto")
    return rotations, ok & heading_ok, SequenceUp(
        evidence=kind, up=up, camera_pitch_deg=float(np.degrees(pitch)), camera_roll_deg=float(np.degrees(roll)),
        camera_pitch_interval_deg=post.pitch_half_deg, camera_roll_interval_deg=post.roll_half_deg,
        up_uncertainty_deg=float(np.hypot(post.pitch_half_deg, post.roll_half_deg)),
        camera_pitch_uncertainty_deg=float(Z95 * pose_sd[0]), camera_roll_uncertainty_deg=float(min(180.0, Z95 * pose_sd[1])),
        interval_reaches_other_posture_p=(round(hypotheses.other_p, 4) if hypotheses.other_p >= OTHER_POSTURE_P
                                          else None),
        posture=hypotheses if camera_prior else None, up_spread_deg=float(np.median(spread)),
        up_spread_p95_deg=float(np.percentile(spread, 95)), ground_plane=ground)


def frame_bound(estimate: FrameEstimate, base_deg: float) -> np.ndarray:
    """Per-frame tilt bound ``(T,)`` (deg; :func:`pcnet.stages.uncertainty.frame_tilt_bound`, widened
    where the shipped ensemble's networks disagree; ``base_deg`` throughout for one estimator)."""
    if estimate.disagreement_deg is None:
        return np.full(len(estimate.valid), base_deg)
    return frame_tilt_bound(estimate.disagreement_deg, estimate.camera_frame_weight, base_deg)


@dataclass(frozen=True)
class HeadingStep:
    """Step 3: where the heading about each frame's up comes from (``source``, one of
    :data:`pcnet.stages.heading.HEADING_SOURCES`, already resolved by
    :func:`resolve_heading_source`); :func:`pcnet.stages.heading.apply_heading`, the up kept."""

    source: str = "auto"

    def __post_init__(self) -> None:
        if self.source not in HEADING_SOURCES:
            raise InputError(f"unknown heading source {self.source!r}; expected one of {HEADING_SOURCES}")

    def __call__(self, joints_cam: np.ndarray, R: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, HeadingChoice]:
        return apply_heading(joints_cam, R, valid, self.source)


@dataclass(frozen=True)
class Rectification:
    """Steps 1-3 for one recording: ``estimator`` -> ``sequence`` -> ``heading``, then the
    canonical poses ``(X - pelvis) @ R + residual`` (:func:`pcnet.stages.core.canonical.to_canonical`).

    Calling it with ``joints_cam`` ``(T, 17, 3)`` (camera frame, any unit, NaN = missing),
    ``fps`` and optionally ``decide_on`` (:class:`SequenceEvidence`) returns
    :class:`Rectified`, its report the
    :class:`~pcnet.stages.rectification_report.RectificationReport`. Input rules (dtype, the
    pelvis from the hips) are the caller's: :func:`pcnet.pipeline.rectification.rectify`.

    Raises:
        InputError: bad shapes, or (sequence modes) no valid frame.
    """

    estimator: FrameEstimator
    sequence: SequenceEvidence = SequenceEvidence()
    heading: HeadingStep = HeadingStep("predicted")
    allocate: Allocate | None = None

    def __call__(self, joints_cam: np.ndarray, fps: float, decide_on: np.ndarray | None = None) -> Rectified:
        # An estimator written without ``allocate`` still runs (in memory).
        estimate = self.estimator(joints_cam, fps) if self.allocate is None else \
            self.estimator(joints_cam, fps, self.allocate)
        gate = estimate.camera_frame_weight
        base = self.estimator.frame_tilt_bound_base_deg
        seq = self.sequence(joints_cam, estimate.rotation, estimate.valid, fps, decide_on,
                            calibrated=bool(np.isfinite(base)), evidence=estimate.evidence)
        valid = np.ones(len(seq.rotation), bool) if seq.valid is None else seq.valid
        R, heading = self.heading(joints_cam, seq.rotation, valid)
        report = RectificationReport(
            mode=seq.mode, sequence=seq.up, heading=heading,
            weights=None if gate is None else EnsembleWeights.of(gate, valid, estimate.quarter_turns),
            camera_frame_weight=None if gate is None else np.where(valid, gate, np.nan),
            frame_tilt_bound_base_deg=base, frame_tilt_bound_deg=np.where(valid, frame_bound(estimate, base), np.nan))
        # the residual was predicted in the network's own frame; sequence and smooth modes answer
        # with another rotation, in which it is turned before it is added
        canonical = to_canonical(joints_cam, R, estimate.residual,
                                 out=(self.allocate or in_memory)("canonical", joints_cam.shape, np.float32),
                                 residual_frame=estimate.rotation)
        return Rectified(R, canonical, R[:, :, 1].copy(), valid, self.estimator.name, report)
