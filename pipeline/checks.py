"""The checks of a rectified recording: one step that reads what the inputs, the camera frame
and the rectification gave (:class:`CheckInputs`) and returns its flags
(:class:`pcnet.stages.flags.Finding` objects) in the order they are raised (:func:`checks`;
the summary ranks them, :func:`pcnet.stages.flags.ranked`).

The flags later steps raise on their own products (the floor, the filter, the motion check,
OpenSim's fit) are added where those are made (pipeline/runner.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pcnet.stages.core.conventions import validate_poses
from pcnet.stages.core.errors import InputError
from pcnet.stages.flags import (Finding, body_size_flag, camera_tilt, ensemble_weights_flag, given_up_flag,
                               given_up_note, keypoints_outside_image_flag, leg_asymmetry_flag, lifter_frame_flag,
                               limb_proportions_flag, mirrored_skeleton_flag, note_finding, orientation_flags,
                               per_frame_tilt_summary, posture_flag, side_swap_flag, size_change_flag,
                               track_switch_flag)
from pcnet.stages.rectification_report import EnsembleWeights, ModeChoice, RectificationReport
from pcnet.stages.rectify import GIVEN_UP, Rectified
from pcnet.stages.temporal import MODE_THRESHOLD_DEG
from pcnet.stages.scale import IMAGE_SCALED_UNITS


@dataclass(frozen=True)
class CameraTilt:
    """The camera's tilt from level and its pitch and roll (deg) of the recording's mean up
    (:func:`pcnet.stages.flags.camera_tilt`): what the summary's tilt line prints."""

    tilt_deg: float
    pitch_deg: float
    roll_deg: float

    @classmethod
    def of(cls, rotation, valid) -> CameraTilt:
        """From ``(T, 3, 3)`` canonical -> camera rotations (column 1: the up in the camera frame)
        and the ``(T,)`` valid frames."""
        return cls(*camera_tilt(rotation[:, :, 1], valid))


def _calibrated_halves(report: RectificationReport) -> tuple[float, float] | None:
    """The up's calibrated 95 % pitch and roll half-widths (deg): sequence mode's intervals over
    a static camera's spread, or a standing trial's (``camera_up_from``); ``(0, 0)`` for an up
    given exactly (``--camera-up``); ``None`` otherwise (frame and smooth modes, another method,
    ups spread beyond a static camera's)."""
    seq = report.sequence
    if seq is None:
        return None
    if seq.evidence == GIVEN_UP and not seq.given_from_run:
        return 0.0, 0.0
    if seq.evidence != GIVEN_UP and spreads_beyond_static(report.mode):
        return None
    halves = (seq.camera_pitch_interval_deg, seq.camera_roll_interval_deg)
    return (float(halves[0]), float(halves[1])) if np.isfinite(halves).all() else None


def pitch_half_width(report: RectificationReport) -> float:
    """The camera pitch's calibrated 95 % half-width in degrees (:func:`_calibrated_halves`),
    ``inf`` where there is none. The tilt line names the camera's direction only beyond it
    (:func:`pcnet.stages.flags.with_looking`; a docs trial read "looking up" for -0.2 +- 6.9, a
    clinic trial "looking down" from a bootstrap of +-0.1)."""
    halves = _calibrated_halves(report)
    return float("inf") if halves is None else halves[0]


def calibrated_tilt_interval(report: RectificationReport) -> float | None:
    """The up's calibrated 95 % half-width in degrees, the larger of pitch and roll
    (:func:`_calibrated_halves`), 0 for an up given exactly, ``None`` where there is none. What
    a printed "+-" on a lean against gravity may claim: a clinic trial read a bootstrap's +-0.1
    and a frame-mode bound's +-7.4 beside a per-frame bound of 30 deg as sure."""
    halves = _calibrated_halves(report)
    return None if halves is None else max(halves)


def per_frame_tilt(rotation, valid, mode: str) -> list[float] | None:
    """The per-frame tilts' median and 5-95 % range (deg,
    :func:`pcnet.stages.flags.per_frame_tilt_summary`) of ``(T, 3, 3)`` rotations over the
    ``(T,)`` valid frames, or ``None`` in sequence mode (``mode``, the one that ran), whose
    frames share its one up."""
    return None if mode == "sequence" else per_frame_tilt_summary(rotation[:, :, 1], valid)


@dataclass(frozen=True)
class CheckInputs:
    """What :func:`checks` reads.

    joints_camera: ``(T, 17, 3)`` root-relative camera-frame poses after the scale step;
    units: the lifter's own units (a metric body's size is checked only without ``--height``,
    image-scaled sizes never; the leg and size-change checks compare lengths within the
    recording, which a constant factor leaves alone and image units' per-frame size moves a
    little: the boxing demo's leg asymmetry reads 18 %, 19 % on the unscaled poses);
    keypoints2d: ``(T, 17, 3)`` H36M-17 pixels and confidence in the displayed frame, or
    ``None``; report: what rectification decided; tilt:
    the camera's tilt; lifter_turn_deg: :attr:`pcnet.adapters.Poses3D.frame_turn_deg`; track_segment,
    track_events: :func:`pcnet.stages.flags.track_segments` of the 2D track (``None`` and
    ``[]`` without one); height_given: ``--height`` was given (the body is scaled to it);
    person_option: ``--person`` can choose another track of the 2D file; own_estimator: the 2D
    keypoints are pcnet's own estimator's (``--video`` without a 2D file); roi_given: that
    estimator saw a ``--roi``; focal_known: the
    camera's focal length was known (``--focal-px`` or the lifter file's camera matrix);
    picture: ``(width, height)`` of the picture ``keypoints2d`` are in, or ``None`` where unknown
    (``pipeline/runner.py: _keypoint_picture``); picture_typed: that size is ``--image-size``
    (no video), which the user may have typed the other way round; units_declared: the user
    declared the poses' units and joint order (``--lifter generic``) rather than the lifter's
    format fixing them;
    depth_sensor: a depth sensor's own skeleton (:attr:`pcnet.adapters.Poses3D.depth_sensor`),
    whose axes and sides its reader fixes.
    """

    joints_camera: np.ndarray
    units: str
    keypoints2d: np.ndarray | None
    report: RectificationReport
    tilt: CameraTilt
    lifter_turn_deg: float
    track_segment: np.ndarray | None
    track_events: list
    height_given: bool
    person_option: bool
    own_estimator: bool = False
    roi_given: bool = False
    focal_known: bool = False
    picture: tuple[int, int] | None = None
    picture_typed: bool = False
    units_declared: bool = True
    depth_sensor: bool = False


def checks(c: CheckInputs) -> list[Finding]:
    """The findings of a rectified recording, in the order canonical.npz keeps their texts: the
    camera's orientation, the body's size, limbs, legs and size change, keypoints outside the image, a
    side swap (or else a mirrored skeleton), the posture hypotheses, the
    ensemble's weights (outside sequence mode), the lifter's frame and a switch of the 2D track."""
    report, cam, kp2d = c.report, c.joints_camera, c.keypoints2d
    return [
        *_orientation_flags(report, c.tilt),
        *(body_size_flag(cam, c.units) if not c.height_given else []),
        *limb_proportions_flag(cam, order_fixed=not c.units_declared),
        *leg_asymmetry_flag(cam),
        # image-scaled sizes are made constant per frame (the scale step); a metric body should keep its own
        *(size_change_flag(cam, units_declared=c.units_declared) if c.units not in IMAGE_SCALED_UNITS else []),
        # the picture the keypoints are in: a video's, --image-size or the 2D file's (unknown for a turned
        # video whose keypoints' frame is unknown)
        *(keypoints_outside_image_flag(kp2d, c.picture, c.picture_typed) if kp2d is not None and c.picture else []),
        # a side swap is a mirror image too: said once
        *((side_swap_flag(kp2d, cam) if kp2d is not None else [])
          or mirrored_skeleton_flag(cam, depth_sensor=c.depth_sensor)),
        *posture_flag(report.sequence),
        *ensemble_weights_flag(_answering_weights(report)),
        *lifter_frame_flag(c.lifter_turn_deg, *tilt_tolerance(report), focal_known=c.focal_known),
        *(track_switch_flag(c.track_segment, c.track_events, person_option=c.person_option,
                            own_estimator=c.own_estimator, roi_given=c.roi_given, keypoints2d=kp2d,
                            picture=c.picture)
          if c.track_segment is not None else []),
    ]


def pose_checks(joints_camera: np.ndarray, rectified: Rectified) -> list[Finding]:
    """The findings of :func:`checks` that the poses and their rectification alone can give, as
    ``pcnet rectify`` prints them (no file, unit, 2D keypoints or video to read): the camera's
    orientation, the limbs' proportions (a wrong joint order), the legs' asymmetry, a mirrored
    skeleton, the posture hypotheses, the ensemble's weights (outside sequence mode) and, as a
    note, per-frame ups spread beyond a static camera's (sequence mode's intervals are then not
    calibrated: :func:`moving_camera_note`).

    Args:
        joints_camera: ``(T, 17, 3)`` camera-frame H36M-17 poses, any units, NaN = missing:
            what :func:`pcnet.pipeline.rectification.rectify` was given.
        rectified: its result.

    Raises:
        InputError: ``joints_camera`` not ``(T, 17, 3)`` numbers with a finite value (a single
            ``(17, 3)`` pose is one frame; ``inf`` is missing, as
            :func:`~pcnet.pipeline.rectification.rectify` reads them), or not as many
            frames as ``rectified`` (the poses of another call), or ``rectified`` not a
            :class:`~pcnet.stages.rectify.Rectified`.
    """
    # read as rectify read them: inf and placeholders missing (a trial's inf printed numpy warnings)
    joints_camera = validate_poses(joints_camera, "pose_checks: joints_camera")
    if not isinstance(rectified, Rectified):
        raise InputError(f"pose_checks: rectified: expected what rectify returned (Rectified), got "
                         f"{type(rectified).__name__}")
    if len(joints_camera) != len(rectified.rotation):
        raise InputError(f"pose_checks: expected the {len(rectified.rotation)} frames rectify was given, got "
                         f"{len(joints_camera)} frame{'s' * (len(joints_camera) != 1)} of joints_camera")
    report = rectified.report
    tilt = CameraTilt.of(rectified.rotation, rectified.valid)
    return [*_orientation_flags(report, tilt),
            *limb_proportions_flag(joints_camera), *leg_asymmetry_flag(joints_camera),
            *mirrored_skeleton_flag(joints_camera), *posture_flag(report.sequence),
            *ensemble_weights_flag(_answering_weights(report)),
            # the intervals' own caveat, which pcnet run's summary gives (an API trial's gate trusted an interval
            # of a 12 deg spread)
            # not where the up was given: its interval is not this spread's, and smooth mode takes no given up
            *map(note_finding, given_up_note(report.sequence) if up_was_given(report)
                 else moving_camera_note(report.mode))]


def _orientation_flags(report: RectificationReport, tilt: "CameraTilt") -> list[Finding]:
    """The camera orientation's flags (:func:`pcnet.stages.flags.orientation_flags`), or, where
    the camera's up was given, whether the poses contradict it (:func:`given_up_flag`): the
    camera prior's and the posture's questions are then the user's answer (a trial's given up
    drew the prior's odds and a --posture advice --camera-up refuses)."""
    if up_was_given(report):
        return given_up_flag(report.sequence)
    return orientation_flags(tilt.tilt_deg, tilt.pitch_deg, tilt.roll_deg, report.posture)


def _answering_weights(report: RectificationReport) -> EnsembleWeights | None:
    """The view gate's weights where they shape the answer (the per-frame up is the answer:
    outside sequence mode), else ``None``."""
    return report.weights if report.mode.run != "sequence" else None


def spreads_beyond_static(mode: ModeChoice) -> bool:
    """Whether the per-frame ups spread more than auto mode's threshold
    (:data:`pcnet.stages.temporal.MODE_THRESHOLD_DEG`, which no static camera of the validation
    data passed): there the sequence intervals are not calibrated (decision 0090)."""
    return mode.spread_deg is not None and mode.spread_deg > MODE_THRESHOLD_DEG


def up_was_given(report: RectificationReport) -> bool:
    """Whether the run's one up was given (``--camera-up``, ``--camera-up-from``), not estimated."""
    return report.sequence is not None and report.sequence.evidence == GIVEN_UP


def moving_camera_note(mode: ModeChoice) -> list[str]:
    """A note when sequence mode was asked for (the default) and the per-frame ups spread beyond
    a static camera's (:func:`spreads_beyond_static`): a camera that moved gets one up that is
    wrong where it turned; a body moving fast or far from upright spreads them too (decision 0041)."""
    if mode.requested != "sequence" or not spreads_beyond_static(mode):
        return []
    # The static camera's case first: yoga and cycling trials under a tripod read "use --mode
    # smooth" as an instruction; what they can act on is whether their camera moved.
    return [f"per-frame up spreads {mode.spread_deg:.1f} deg, beyond the {MODE_THRESHOLD_DEG:g} of any static "
            f"validation camera: a body far from upright or moving fast spreads it too, and under a static camera "
            f"(a tripod) nothing changes but the interval, not called 95 %; a camera that moved needs --mode smooth"]


#: :func:`tilt_tolerance`'s word for a tilt the user gave (``--camera-up``): no uncertainty of pcnet's.
GIVEN_TILT = "given, --camera-up"


def tilt_tolerance(report: RectificationReport) -> tuple[float, str]:
    """The camera tilt uncertainty the summary states (deg) and what it is: the larger 95 %
    pitch/roll half-width in sequence mode (the bootstrap's for a method without a calibrated
    interval), else the per-frame bound where the two networks agree; NaN and
    :data:`GIVEN_TILT` for a given up."""
    seq = report.sequence
    if seq is not None and seq.evidence == GIVEN_UP:
        if seq.given_from_run:
            return (max(seq.camera_pitch_interval_deg, seq.camera_roll_interval_deg),
                    "the standing trial's 95 % interval (camera_up_from), the larger of pitch and roll")
        return float("nan"), GIVEN_TILT
    if seq is not None:
        interval = ("interval, not calibrated for this spread of per-frame ups" if spreads_beyond_static(report.mode)
                    else "95 % interval, the larger of pitch and roll")
        for halves, what in (((seq.camera_pitch_interval_deg, seq.camera_roll_interval_deg), interval),
                             # a method without a calibrated interval states its bootstrap
                             ((seq.camera_pitch_uncertainty_deg, seq.camera_roll_uncertainty_deg),
                              "bootstrap-only uncertainty, no calibrated interval for this method")):
            if np.isfinite(halves).all():
                return float(max(halves)), what
    return float(report.frame_tilt_bound_base_deg), "per-frame bound, not calibrated on real lifter output"
