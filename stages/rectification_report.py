"""What rectification decided and why, as typed records (frozen dataclasses), one per step
of :class:`pcnet.stages.rectify.Rectification`, gathered in :class:`RectificationReport`.

The run writes :meth:`RectificationReport.as_record` (with the pipeline's own facts) as the
``report`` of ``canonical.npz``; docs/outputs.md lists its keys. Angles are degrees; ``up``
is a unit vector in the OpenCV camera frame (docs/CONVENTIONS.md); per-frame arrays are
``(T,)`` float64, NaN where the frame is not valid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core.rotations import camera_pitch_roll, camera_tilt_deg


@dataclass(frozen=True)
class ModeChoice:
    """The temporal mode (:data:`pcnet.stages.temporal.MODES`): ``requested`` (the option) and
    ``run`` (what ran: ``auto`` resolves to ``sequence`` or ``smooth``, or to ``frame`` with
    ``reason`` ``"one valid frame"``); ``spread_deg`` the spread of the per-frame ups that
    ``auto`` decides on (:func:`pcnet.stages.temporal.up_spread_deg`; ``None`` in frame mode);
    ``decided_on_frames`` the valid frames the spread was read over (what ``auto`` decides on)
    when they were one person's stretch of a 2D track that switches people (else ``None``); ``smooth_time_constant_s``
    the smoothing kernel in smooth mode (else ``None``)."""

    requested: str
    run: str
    reason: str | None = None
    spread_deg: float | None = None
    decided_on_frames: int | None = None
    smooth_time_constant_s: float | None = None


@dataclass(frozen=True, eq=False)
class PostureHypotheses:
    """The up model's posterior over the body's posture (docs/up_model.md): ``most_probable``
    the more probable hypothesis (``"upright"`` or ``"lying"``), ``p_lying`` the lying hypothesis's
    posterior probability in [0, 1], ``pose_up`` ``(3,)`` the unit up the poses alone give
    (camera frame; the posterior's likelihood mode, without the priors): the camera an upright
    body implies, whose pitch, roll and tilt the properties give. ``declared``: the posture was
    given by the user (``--posture``: a prior of 0 or 1 on lying), not read from the priors."""

    most_probable: str
    p_lying: float
    pose_up: np.ndarray
    declared: bool = False

    @property
    def pose_up_pitch_deg(self) -> float:
        """Camera pitch (degrees) of :attr:`pose_up` (:func:`pcnet.stages.core.rotations.camera_pitch_roll`)."""
        return float(np.degrees(camera_pitch_roll(self.pose_up)[0]))

    @property
    def pose_up_roll_deg(self) -> float:
        """Camera roll (degrees) of :attr:`pose_up` (:func:`pcnet.stages.core.rotations.camera_pitch_roll`)."""
        return float(np.degrees(camera_pitch_roll(self.pose_up)[1]))

    @property
    def pose_up_tilt_deg(self) -> float:
        """Tilt (degrees) of :attr:`pose_up` from a level camera
        (:func:`pcnet.stages.core.rotations.camera_tilt_deg`)."""
        return float(camera_tilt_deg(self.pose_up))

    @property
    def other_p(self) -> float:
        """Posterior probability of the less probable posture."""
        return min(self.p_lying, 1.0 - self.p_lying)


#: :class:`SequenceUp`'s ``evidence`` where the camera's up was given (``camera_up``).
GIVEN_UP = "given"


@dataclass(frozen=True, eq=False)
class SequenceUp:
    """A static camera's one up (sequence mode; :class:`pcnet.stages.rectify.SequenceEvidence`).

    ``up`` ``(3,)`` camera frame; ``camera_pitch_deg`` / ``camera_roll_deg`` its pitch and roll
    (:func:`pcnet.stages.core.rotations.camera_pitch_roll`); ``camera_pitch_interval_deg`` /
    ``camera_roll_interval_deg`` the up model's 95 % posterior half-widths (NaN for a method
    without one); ``up_uncertainty_deg`` their ``hypot`` (the up model) or the bootstrap's
    95 % cone (another method); ``camera_{pitch,roll}_uncertainty_deg`` the poses' part alone
    (the up model's Laplace half-widths without the systematic error and priors, or the
    bootstrap's); ``interval_reaches_other_posture_p`` the less probable posture's posterior
    probability where it keeps at least :data:`pcnet.stages.up_model.OTHER_POSTURE_P` (the
    interval then reaches it), else ``None``; ``posture`` the up model's
    :class:`PostureHypotheses` (``None`` for another method or without the camera prior's
    lying hypothesis); ``up_spread_deg`` / ``up_spread_p95_deg`` the median / 95th percentile
    angle of the per-frame ups from ``up``; ``evidence`` what made it (``"up model"``,
    ``"poses"``, each ``+ground_plane`` where a measured root's floor contacts refined it;
    ``"given"`` where the camera's up was given); ``ground_plane`` whether and why (not) they did
    (:func:`pcnet.stages.ground_plane.ground_plane_up`'s diagnostics); ``poses_estimate``, for a
    given up, what the poses' own up (the up model's) reads beside it: ``pitch_deg``,
    ``roll_deg``, their 95 % half-widths ``pitch_interval_deg`` / ``roll_interval_deg``,
    ``angle_from_given_deg`` and ``outside_interval`` (the given up outside them on either
    axis); ``None`` where no calibrated interval exists (another method) or nothing was given."""

    evidence: str
    up: np.ndarray
    camera_pitch_deg: float
    camera_roll_deg: float
    camera_pitch_interval_deg: float
    camera_roll_interval_deg: float
    up_uncertainty_deg: float
    camera_pitch_uncertainty_deg: float
    camera_roll_uncertainty_deg: float
    interval_reaches_other_posture_p: float | None
    posture: PostureHypotheses | None
    up_spread_deg: float
    up_spread_p95_deg: float
    ground_plane: dict
    poses_estimate: dict | None = None

    @property
    def given_from_run(self) -> bool:
        """Whether the up was given with its own 95 % interval: another run's estimate
        (``--camera-up-from``), not a calibration's (``--camera-up``, no interval)."""
        return self.evidence == GIVEN_UP and bool(
            np.isfinite([self.camera_pitch_interval_deg, self.camera_roll_interval_deg]).all())


@dataclass(frozen=True)
class HeadingChoice:
    """Where the heading came from (:func:`pcnet.stages.heading.apply_heading`): ``source``
    (``"predicted"`` or ``"hips"``) for the ``requested`` source
    (:data:`pcnet.stages.heading.HEADING_SOURCES`); ``hip_width_cv_percent`` the hip width's
    coefficient of variation (NaN under two frames with hips); ``difference_median_deg`` the
    median absolute hip-line vs predicted heading over the valid frames (NaN when no frame has
    both); ``hip_undefined_frames`` valid frames that kept the predicted heading."""

    source: str
    requested: str
    hip_width_cv_percent: float
    difference_median_deg: float
    hip_undefined_frames: int = 0


@dataclass(frozen=True)
class EnsembleWeights:
    """The shipped ensemble's weights on its camera-frame network over the valid frames
    (:mod:`pcnet.models.view_gate`): ``camera_frame_share`` their mean, ``body_frame_frames``
    the frames the body-frame network answered alone (weight 0), ``blended_frames`` those it
    shared (0 < weight < 1), ``frames`` the valid frames, ``turned_frames`` frames whose input
    the camera-frame network read turned back by ``"90"`` and ``"270"`` deg about the optical
    axis."""

    camera_frame_share: float
    body_frame_frames: int
    blended_frames: int
    frames: int
    turned_frames: dict[str, int]

    @classmethod
    def of(cls, weight: np.ndarray, valid: np.ndarray, turns: np.ndarray | None) -> EnsembleWeights:
        """From the ``(T,)`` weights, ``(T,)`` bool valid frames and ``(T,)`` int quarter turns
        (0, 1 or 3; ``None``: none turned)."""
        w = weight[valid]
        turned = {str(90 * k): int(np.sum(turns[valid] == k)) if turns is not None else 0 for k in (1, 3)}
        return cls(float(np.mean(w)) if len(w) else float("nan"), int(np.sum(w == 0.0)),
                   int(np.sum((w > 0.0) & (w < 1.0))), int(len(w)), turned)

    @property
    def set_aside_frames(self) -> int:
        """Frames where the camera-frame network did not answer alone."""
        return self.body_frame_frames + self.blended_frames


@dataclass(frozen=True, eq=False)
class RectificationReport:
    """Everything :class:`pcnet.stages.rectify.Rectification` decided for one recording of
    ``T`` frames: the ``mode``, the static camera's ``sequence`` up (sequence mode, else
    ``None``), the ``heading``, the ensemble's ``weights`` (``None`` when one estimator ran),
    ``camera_frame_weight`` ``(T,)`` (the same per frame, ``None`` likewise),
    ``frame_tilt_bound_base_deg`` the estimator's calibrated per-frame bound where nothing widens it
    (NaN when uncalibrated) and ``frame_tilt_bound_deg`` ``(T,)`` per frame
    (:func:`pcnet.stages.uncertainty.frame_tilt_bound`; NaN where not valid or uncalibrated);
    ``pelvis_from_hips_frames`` the frames whose missing pelvis the caller took as the hip
    midpoint (:func:`pcnet.stages.core.conventions.fill_pelvis_from_hips`; ``None``: not counted)."""

    mode: ModeChoice
    sequence: SequenceUp | None
    heading: HeadingChoice
    weights: EnsembleWeights | None
    camera_frame_weight: np.ndarray | None
    frame_tilt_bound_base_deg: float
    frame_tilt_bound_deg: np.ndarray
    pelvis_from_hips_frames: int | None = None

    @property
    def posture(self) -> PostureHypotheses | None:
        """The up model's posture hypotheses (sequence mode with the shipped ensemble), else ``None``."""
        return self.sequence.posture if self.sequence is not None else None

    @property
    def lying(self) -> bool:
        """Whether the up model read the body as lying."""
        return self.posture is not None and self.posture.most_probable == "lying"

    def as_record(self) -> dict:
        """The flat record of docs/outputs.md (``canonical.npz``'s ``report``, less the
        pipeline's own keys; :func:`pcnet.stages.sinks.result.jsonable` makes it JSON), ``None``
        for what does not apply, no per-frame arrays."""
        m, h = self.mode, self.heading
        out: dict = {"requested_mode": m.requested, "mode": m.run}
        out.update({k: v for k, v in (("mode_reason", m.reason), ("spread_deg", m.spread_deg),
                                       ("mode_decided_on_frames", m.decided_on_frames),
                                       ("time_constant_s", m.smooth_time_constant_s)) if v is not None})
        if m.run == "smooth":
            out["evidence"] = "per-frame"
        if self.sequence is not None:
            s = self.sequence
            out.update(evidence=s.evidence, up=[float(v) for v in s.up], up_uncertainty_deg=s.up_uncertainty_deg,
                       camera_pitch_deg=s.camera_pitch_deg, camera_roll_deg=s.camera_roll_deg,
                       camera_pitch_uncertainty_deg=s.camera_pitch_uncertainty_deg,
                       camera_roll_uncertainty_deg=s.camera_roll_uncertainty_deg,
                       camera_pitch_interval_deg=s.camera_pitch_interval_deg,
                       camera_roll_interval_deg=s.camera_roll_interval_deg,
                       interval_reaches_other_posture_p=s.interval_reaches_other_posture_p,
                       posture=None if s.posture is None else {
                           "most_probable": s.posture.most_probable, "p_lying": round(s.posture.p_lying, 4),
                           "declared": s.posture.declared,
                           "pose_up_tilt_deg": round(s.posture.pose_up_tilt_deg, 2),
                           "pose_up_pitch_deg": round(s.posture.pose_up_pitch_deg, 2),
                           "pose_up_roll_deg": round(s.posture.pose_up_roll_deg, 2)},
                       up_spread_deg=s.up_spread_deg, up_spread_p95_deg=s.up_spread_p95_deg,
                       ground_plane=dict(s.ground_plane))
            if s.poses_estimate is not None:
                out["poses_estimate"] = dict(s.poses_estimate)
        out.update(requested_heading_source=h.requested, heading_source=h.source,
                   hip_width_cv_percent=h.hip_width_cv_percent, heading_difference_median_deg=h.difference_median_deg,
                   hip_heading_undefined_frames=h.hip_undefined_frames)
        out["view_gate"] = None if self.weights is None else {
            "camera_frame_share": self.weights.camera_frame_share, "body_frame_frames": self.weights.body_frame_frames,
            "blended_frames": self.weights.blended_frames, "frames": self.weights.frames,
            "turned_frames": dict(self.weights.turned_frames)}
        # Not "95": calibrated on simulated lifter noise only, it held in 31-52 % of real frames
        # (issue 49), so its key does not call it a 95 % bound (a user trial).
        out["frame_tilt_bound_base_deg"] = self.frame_tilt_bound_base_deg
        if self.pelvis_from_hips_frames is not None:
            out["pelvis_from_hips_frames"] = self.pelvis_from_hips_frames
        return out


__all__ = ["ModeChoice", "PostureHypotheses", "SequenceUp", "HeadingChoice", "EnsembleWeights",
           "RectificationReport"]


def why_up_not_reusable(record: dict) -> str | None:
    """Why a run's up cannot be another recording's known up (``--camera-up-from``), or
    ``None`` where it can: ``record`` is :meth:`RectificationReport.as_record`'s
    (``canonical.npz``'s ``report``). Only an up the poses read: sequence mode (one up for a
    static camera), the body not read lying, with intervals that do not reach the lying posture
    (a lying body's up is the camera prior's), per-frame ups within a static camera's spread
    (:data:`pcnet.stages.temporal.MODE_THRESHOLD_DEG`: a moving camera has no one up); an up that
    run was itself given is taken as it is."""
    from .temporal import MODE_THRESHOLD_DEG

    posture = record.get("posture") or {}
    spread = record.get("spread_deg")
    if record.get("mode") != "sequence":
        return f"mode {record.get('mode')}, which has no one up for the recording"
    if record.get("evidence") == GIVEN_UP:
        return None
    if posture.get("most_probable") == "lying":  # no posture: the poses alone (--no-camera-prior, another method)
        return "a body read lying, whose up is the camera prior's, not its poses'"
    if record.get("interval_reaches_other_posture_p") is not None:
        return "intervals that reach the lying posture (the poses cannot tell which way is up)"
    if spread is not None and not spread <= MODE_THRESHOLD_DEG:
        return (f"per-frame ups spread {spread:.1f} deg, beyond the {MODE_THRESHOLD_DEG:g} of a static camera (a "
                f"moving camera has no one up)")
    return None

