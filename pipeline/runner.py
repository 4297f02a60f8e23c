"""The staged pipeline behind ``pcnet run``: files -> H36M-17 -> rectification -> kinematics
-> exports and a rerun recording.

All outputs are written into a hidden folder beside ``out`` that replaces ``out`` by renames
only when every stage has succeeded (:mod:`pcnet.pipeline.outdir`), so a failure or a kill
never leaves a half-written result and ``--overwrite`` never deletes anything but a previous
pcnet output.
"""

from __future__ import annotations

import ctypes
import gc
import importlib.metadata
import inspect
import os
import shlex
import sys
import threading
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path

import numpy as np
from tqdm import tqdm

from pcnet.adapters import (AdapterError, Keypoints2D, Poses3D, VideoInfo, first_shown_frame, get_2d_adapter,
                            get_3d_adapter, probe_video)
from pcnet.adapters.mediapipe import holds_keypoints_2d, load_mediapipe_2d
from pcnet.models.inference import BODY_WEIGHTS, CAMERA_WEIGHTS, training_config
from pcnet.adapters.validate import as_path, nonfinite_line
from pcnet.stages.core.conventions import (H36M_JOINTS, L_HIP, METRES_PER_LENGTH_UNIT, PELVIS, R_HIP,
                                          REFUSED_THIGH_M, THIGH_RANGE_M, fill_pelvis_from_hips,
                                          thigh_beyond_metres, validate_fps)
from pcnet.stages.core.canonical import to_canonical
from pcnet.stages.core.digest import sha256_file_version, sha256_path
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.framestore import FrameStore, frame_blocks, per_frame, present_frames
from pcnet.stages.opensim_ik import (OUTPUTS as OPENSIM_OUTPUTS, import_opensim, opensim_fit_line, opensim_notes,
                                     scale_and_ik)
from pcnet.stages.sinks.exports import require_ezc3d, unit_token
from pcnet.stages.flags import (Finding, Severity, absent_joints_flag, floor_flag, implausible_motion_findings,
                               keypoints_unused_flag, missing_data_line, no_opensim_flag, no_world_frame_flag,
                               note_finding, one_person_frames, opensim_fit_findings, ranked, track_segments,
                               unfiltered_flag, given_up_note, signed_deg, with_looking)
from pcnet.stages.floor import Floor
from pcnet.stages.isb_angles import NEEDS_SPINE_JOINT, SPINE_ON_LINE_FRACTION, spine_off_trunk_line
from pcnet.stages.heading import AUTO_MAX_HIP_WIDTH_CV_PERCENT, AUTO_MIN_FRAMES
from pcnet.stages.kinematics import (FILTER_ORDER, filtered_derivatives, format_flag_counts, frames_phrase, kinematics_chunks,
                                     residual_analysis)
from pcnet.pipeline.rectification import check_measured_root, rectify_checked
from pcnet.stages.rectification_report import RectificationReport
from pcnet.stages.rectify import GIVEN_UP, NO_VALID_FRAME, no_valid_frame_reason
from pcnet.stages.temporal import HEADING_LIMIT_DEG, MODE_SMOOTHING_S, MODE_THRESHOLD_DEG
from pcnet.stages.remap import built_joints, mask_low_confidence, outside_image, remap_to_h36m
from pcnet.stages.sinks.result import (RECORDING_NAME, WRISTS, RecordingResult, other_persons_frames, write_arrays, write_figures,
                                      write_kinematics_table, write_motion_files, write_rerun)
from pcnet.stages.sinks.report import REPORT_NAME, report_markdown, write_report
from pcnet.stages.scale import IMAGE_SCALED_UNITS, SIZE_WINDOW_S, height_factor, size_normalising_factors
from pcnet.stages.uncertainty import FRAME_TILT_95_BODY_DEG
from pcnet.stages.column_ranges import ColumnRanges, column_ranges
from pcnet.stages.plausibility import implausible_frames, implausible_motion, motion_check_note
from pcnet.stages.world_frame import feet_visible, to_world_floor, world_frame

from .checks import (GIVEN_TILT, CameraTilt, CheckInputs, calibrated_tilt_interval, checks, moving_camera_note,
                     per_frame_tilt, pitch_half_width, spreads_beyond_static, up_was_given)
from .config import (COMMAND_LINE, DEFAULT_CUTOFF_HZ, RunConfig, field_name, fps_contradiction, keypoint_formats,
                     multi_track_formats, pcnet_version, rates_agree, reads_folder, settings_record, trial_up_record)
from .io import lifter_joints
from .video_orientation import DisplayOrientation, display_orientation, keypoints_extent
from .outdir import check_out_folder, staged_output
from .pelvis_path import PelvisPath, camera_intrinsics, pelvis_path
from .run_report import RunReport
from .video_estimate import ESTIMATE_FILE, estimated_inputs

STEPS = ("inputs", "remap", "scale", "rectify", "kinematics", "exports", "recording")
_WORLD = ("world, fixed for the recording: +Y up, +X the subject's forward over the first second, y = 0 the surface "
          "the tracked person stands on (the ground, or a box's top where they stand on one); ")
WORLD_SUMMARY = {
    "not observable": _WORLD + "the pelvis's horizontal path is not observable (x = z = 0; its horizontal columns in "
                               "kinematics.csv are empty)",
    "measured": _WORLD + "the pelvis follows the path the input measured (x = z = 0 at the start)",
    "from 2D keypoints": _WORLD + "the pelvis follows the path fitted to the 2D keypoints (x = z = 0 at the start; "
                                  "depth is its weak axis: pelvis_path_std_world in canonical.npz)",
}
_WORLD_SHORT = "world, fixed for the recording (+Y up, y = 0 under the feet); "
#: The kinematics frame line of the terminal summary (:data:`WORLD_SUMMARY` in report.md).
WORLD_SHORT = {
    "not observable": _WORLD_SHORT + "pelvis path not observable (x = z = 0)",
    "measured": _WORLD_SHORT + "the pelvis follows the path the input measured",
    "from 2D keypoints": _WORLD_SHORT + "pelvis path fitted to the 2D keypoints (depth weak)",
}


@dataclass
class RunResult:
    """What a run produced: counts, the run's report (:class:`~pcnet.pipeline.run_report.RunReport`;
    the mode that ran and the camera's tilt, pitch and roll are read from it) and output paths;
    findings: the flags as raised (:class:`pcnet.stages.flags.Finding`), notes: the notes' texts;
    note_lines: the summary line of a note made from the data it words rather than from its
    text (the missing-data note's, :func:`pcnet.stages.flags.missing_data_line`), keyed by the
    note's text; angle_ranges, rate_ranges, speed_ranges: each joint angle's, each angle
    rate's and each plotted joint's speed's range over the recording
    (:class:`pcnet.stages.column_ranges.ColumnRanges`, report.md's joint-angle,
    angular-velocity and joint-speed tables; ``None`` from a run without kinematics);
    guessed_stature_m: :attr:`Scaled.guessed_stature_m`, which the units line names."""

    frames: int
    valid_frames: int
    units: str
    method: str
    report: RunReport
    outputs: dict[str, Path] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)
    fps: float = float("nan")
    fps_source: str = ""
    note_lines: dict[str, str] = field(default_factory=dict)
    angle_ranges: ColumnRanges | None = None
    speed_ranges: ColumnRanges | None = None
    rate_ranges: ColumnRanges | None = None
    guessed_stature_m: float | None = None

    @property
    def mode(self) -> str:
        """The temporal mode that ran (``auto`` resolved)."""
        return self.report.rectification.mode.run

    @property
    def camera_tilt_deg(self) -> float:
        """The camera's tilt from level (deg) of the recording's mean up (sequence mode: its one up)."""
        return self.report.tilt.tilt_deg

    @property
    def camera_pitch_deg(self) -> float:
        """The camera's pitch (deg), as :attr:`camera_tilt_deg`."""
        return self.report.tilt.pitch_deg

    @property
    def camera_roll_deg(self) -> float:
        """The camera's roll (deg), as :attr:`camera_tilt_deg`."""
        return self.report.tilt.roll_deg

    @property
    def flags(self) -> list[str]:
        """The flags' full texts, as raised (``canonical.npz``'s ``flags``)."""
        return [f.detail for f in self.findings]

    @property
    def ranked_findings(self) -> list[Finding]:
        """The flags' findings, most severe first (:func:`pcnet.stages.flags.ranked`)."""
        return ranked(self.findings)

    @property
    def note_findings(self) -> list[Finding]:
        """The notes as one-line findings (:data:`Severity.INFO`), in the order they were made."""
        return [Finding(Severity.INFO, self.note_lines[n], "", n) if n in self.note_lines else note_finding(n)
                for n in self.notes]

    def key_facts(self, long: bool = False) -> list[tuple[str, str]]:
        """``(label, text)`` of the few facts every summary states: frames, rectification,
        heading, camera tilt, the per-frame bound, the kinematics frame, units. ``long``: with
        every qualification (report.md), else one short line each (the terminal)."""
        frames = f"{self.frames} at {self.fps:.4g} fps ({self.fps_source}; " + (
            f"{self.frames - self.valid_frames} without a valid pose"
            + (": kept as NaN rows, valid = 0; a pose needs the pelvis, both hips, the thorax and both shoulders, "
               "and the notes say why any other frame was left out" * long) + ")"
            if self.valid_frames < self.frames else "every one with a valid pose)")
        mode, heading = self.report.rectification.mode, self.report.rectification.heading
        # "from their own mean": not from the recording's one up, which report.md's up_spread_deg measures
        # (a lying body's per-frame ups agree with each other and lie 88 deg from its up: a user trial)
        spread = (f"; per-frame ups {mode.spread_deg:.1f} deg from their own mean" + " (median, low-passed)" * long
                  if mode.spread_deg is not None else "")
        # The spread reads the ups' slow drift through a low-pass: a recording shorter than the
        # low-pass's own time scale shows none whatever the ups do (an 11-frame lab trial read "0.0 deg")
        seconds = (mode.decided_on_frames if mode.decided_on_frames is not None else self.valid_frames) / self.fps
        if mode.spread_deg is not None and seconds < MODE_SMOOTHING_S:
            spread = (f"; the per-frame ups' drift not measured: {seconds:.2f} s of poses, shorter than the "
                      f"{MODE_SMOOTHING_S:g} s low-pass (kernel standard deviation) that reads it" if long else
                      f"; per-frame ups' drift unmeasured in {seconds:.2f} s (low-pass {MODE_SMOOTHING_S:g} s)")
        decided = ((f" over the {mode.decided_on_frames} valid frames of the 2D track's longest stretch"
                    if long else f" over the {mode.decided_on_frames} frames of one person")
                   if mode.decided_on_frames is not None else "")
        rectification = (f"{self._method_label()}, mode {self.mode} (requested {mode.requested}" + spread
                         + (f"; {mode.reason}" if mode.reason else "") + decided
                         + self._auto_hint() + ")")
        heading = f"from {heading.source} (requested {heading.requested}; " + self._hip_width() + ")"
        tilt = f"{self.camera_tilt_deg:.1f} deg from level " + with_looking(
            self._pitch_roll(long), self.camera_pitch_deg, pitch_half_width(self.report.rectification)) + self._per_frame_tilt()
        kinematics = (WORLD_SUMMARY if long else WORLD_SHORT)[self.report.root_path] \
            if self.report.kinematics_frame == "world" \
            else "canonical (turns with the pelvis; no fixed frame without a static camera)"
        read = [("inputs", _inputs_line(self.report.inputs))] if long and self.report.inputs else []
        return [*read, ("frames", frames), ("rectification", rectification), ("heading", heading),
                ("camera tilt", tilt), *self._frame_bound(long), *self._trunk(long), ("kinematics frame", kinematics),
                ("units", self.units + self._guessed_size(long) + self._cutoff(long))]

    def _trunk(self, long: bool) -> list[tuple[str, str]]:
        """``("trunk lean", ...)``: the pelvis-thorax line's median angle from vertical, with the
        up's calibrated 95 % half-width where there is one (:func:`calibrated_tilt_interval`),
        which reaches it whole, and what it leaves out; report.md adds its direction in the
        pelvis's and the thorax's planes; nothing without the angle. A clinic trial found the
        trunk's columns at rows 19-20 of a 36-row table; a second read a side bend as a forward
        one in the thorax's planes, the direction this line therefore leaves to report.md."""
        rows = {r.name: r for r in self.angle_ranges.rows} if self.angle_ranges is not None else {}
        lean = rows.get("trunk_inclination_deg")
        if lean is None:
            return []
        half = calibrated_tilt_interval(self.report.rectification)
        sure = ("; no calibrated uncertainty in this mode or method" if half is None else
                "; the up was given" if half == 0.0 else
                f"; +- {half:.1f} from the up's 95 % interval, the lifter's own trunk error not included")
        text = f"{lean.median:.1f} deg from vertical (pelvis-thorax line, median{sure})"
        if long:
            parts = [(rows.get(f"trunk_{a}_deg"), rows.get(f"trunk_{b}_deg"), where) for a, b, where in (
                ("sagittal_inclination", "frontal_inclination", "the pelvis's planes"),
                ("flexion_to_gravity", "lateral_tilt_to_gravity", "the thorax's"))]
            split = "; ".join(f"forward {signed_deg(f.median)}, to the right {signed_deg(r.median)} in {where}"
                              for f, r, where in parts if f is not None and r is not None)
            if split:
                text += (f"; {split} (medians of kinematics.csv's trunk_* columns over the {lean.frames} frames of "
                         f"the angle table; the two part where the shoulders turn against the hips or the trunk "
                         f"bends sideways: docs/joint_angles.md)")
        return [("trunk lean", text)]

    def _guessed_size(self, long: bool) -> str:
        """``" (the lifter's guess of a 1.53 m stature: --height sets it)"`` where the metres are
        a monocular lifter's guess at the size, else ``""``: on the units line, not in a note of
        its own (a physiotherapist's trial read a walking speed without seeing that it rests on
        the guess; a coach's read plain "m" and every speed was 1/1.14 of the boxer's)."""
        if self.guessed_stature_m is None:
            return ""
        scales = ", and positions, speeds and the TRC scale with it" * long
        return f" (the lifter's guess of a {self.guessed_stature_m:.2f} m stature: --height sets it{scales})"

    def _cutoff(self, long: bool) -> str:
        """``"; low-pass 6 Hz (--cutoff-hz)"``: the cutoff that sets every speed and acceleration
        (a boxing analyst read 3.4 m/s punches without seeing it); ``""`` with no kinematics."""
        hz = self.report.cutoff_hz
        if hz is None or not np.isfinite(hz):
            return ""
        source = "residual analysis" if self.report.cutoff_source == "residual analysis" else "--cutoff-hz"
        # the rate's own limit: a wrist-IMU trial at 15 fps was told to raise a 6 Hz cutoff that
        # sat at 0.8 of what its rate resolves
        # Winter's gait cutoff is the default's reason, not any cutoff's (a study trial's 3 Hz was called it)
        gait = "Winter's for gait: " if hz == DEFAULT_CUTOFF_HZ else ""
        # both ways: a wrist-IMU trial's Kinect accelerations were twice the IMU's at 6 Hz, and a
        # sports trial's --residual-cutoff, offered for punches, chose a lower cutoff
        why = (f"; {self.fps:.4g} fps resolves up to {self.fps / 2:.3g} Hz; {gait}a higher one keeps more of a "
               f"punch's or a throw's peak speed, a lower one steadies a noisy input's accelerations; "
               f"--residual-cutoff fits one to the recording's noise"
               if long and source == "--cutoff-hz" else "")
        # the filter itself, for a methods section (a sports biomechanist's trial found only "low-pass 6 Hz")
        design = f"zero-lag Butterworth, order {FILTER_ORDER} over its 2 passes, -3 dB at the cutoff; " * long
        return f"; low-pass {hz:.3g} Hz ({design}{source}{why})"

    def summary(self) -> str:
        """A summary that reads in seconds: the key facts, then one line per finding, most
        severe first, each with the one action it asks (``WARNING <headline> -> <action>``),
        the notes one line each, the outputs, and where report.md keeps the full text."""
        lines = [f"{label:<17} {text}" for label, text in self.key_facts()]
        lines += [f.terminal_line() for f in self.ranked_findings]
        lines += [f"note     {n.headline}" for n in self.note_findings]
        # the outputs' paths in one column, past the longest name (kinematics_columns.csv)
        width = max([17, *(len(name) for name in self.outputs)])
        lines += [f"{name:<{width}} {path}" for name, path in self.outputs.items() if name != REPORT_NAME]
        if "kinematics.csv" in self.outputs:  # a coach's trial looked for the angles among 246 columns
            lines.append("joint angles: kinematics.csv's *_deg columns, their rates *_deg_per_s (each defined in "
                         "kinematics_columns.csv; their ranges, and the joints' peak speeds, in report.md)")
            # how far to trust them, in the terminal (a clinician's trial found it only in report.md)
            lines.append("angles carry the lifter's own error: 4 calibrated views of one subject read knees and hips "
                         "tens of deg apart (docs/guide/limits.md)")
        if RECORDING_NAME in self.outputs:
            # quoted as a shell needs it (a coach's path with a space did not paste)
            lines.append(f"open the recording with:  rerun {shlex.quote(str(self.outputs[RECORDING_NAME]))}")
        if REPORT_NAME in self.outputs:
            lines.append(f"details: {self.outputs[REPORT_NAME]}")
        return "\n".join(lines)

    def report_text(self, title: str = "pcnet run") -> str:
        """report.md's text (:func:`pcnet.stages.sinks.report.report_markdown`): the key facts
        in full, every finding's full text in the summary's order, every note in full, the
        rectification report's numbers and the outputs."""
        return report_markdown(title, self.key_facts(long=True), self.ranked_findings, self.note_findings,
                               self.report.as_record(),
                               [Path(path).name for name, path in self.outputs.items() if name != REPORT_NAME],
                               self.angle_ranges, self.speed_ranges, self.rate_ranges)

    def _per_frame_tilt(self) -> str:
        """Where the up may change from frame to frame, the tilt line's one number is that of the
        recording's mean up; the per-frame tilts' median and 5-95 % range say how they spread."""
        stats = self.report.tilt_per_frame_deg
        if not stats or not np.isfinite(stats[0]):
            return ""
        median, low, high = stats
        return f"; of the recording's mean up; per frame median {median:.1f}, 5-95 % {low:.1f}-{high:.1f} deg"

    def _hip_width(self) -> str:
        heading = self.report.rectification.heading
        cv = heading.hip_width_cv_percent
        if not np.isfinite(cv):
            return "hip width variation needs two frames with hips"
        if heading.requested != "auto":
            return f"hip width varies {cv:.1f} %"
        # what auto decided by (a user comparing cameras saw "hips" in one and "predicted" in
        # another), in as many decimals as tell the two apart (an IMU trial read "1.2 %, limit 1.2 %")
        places = next((d for d in range(1, 4) if round(cv, d) != round(AUTO_MAX_HIP_WIDTH_CV_PERCENT, d)), 4)
        return (f"hip width varies {cv:.{places}f} %, auto's limit for the hips {AUTO_MAX_HIP_WIDTH_CV_PERCENT:.{places}f} "
                f"% over {AUTO_MIN_FRAMES}+ frames")

    def _frame_bound(self, long: bool = True) -> list[tuple[str, str]]:
        rect = self.report.rectification
        base = rect.frame_tilt_bound_base_deg
        # A sequence up whose interval is known says its uncertainty on the tilt line instead; a
        # given one reads no per-frame up.
        if (rect.sequence is not None and (np.isfinite(rect.sequence.camera_pitch_interval_deg)
                                           or rect.sequence.evidence == GIVEN_UP)) or not np.isfinite(base):
            return []
        bound = np.asarray(rect.frame_tilt_bound_deg, np.float64)
        bound = bound[np.isfinite(bound)]
        here = f"; this recording median {np.median(bound):.1f}, max {bound.max():.1f} deg" if len(bound) else ""
        # Calibrated as a 95 % bound, it held in 81-92 % of held-out mocap frames (benchmarks/ablation.py)
        # and is not measured on real lifter output, so the summary says what it is, not "95 %".
        if not long:
            return [("per-frame up", f"bound {base:.1f} deg where the two networks agree, {FRAME_TILT_95_BODY_DEG:.1f} "
                                     f"where the body-frame network answers alone{here}; not a 95 % interval")]
        return [("per-frame up", f"bound {base:.1f} deg where the two networks agree, {FRAME_TILT_95_BODY_DEG:.1f} "
                f"where the body-frame network answers alone, more where they disagree{here} "
                f"(frame_tilt_bound_deg in canonical.npz): not a 95 % interval, it held in 81-92 % of frames on "
                f"held-out mocap with simulated lifter noise and is not calibrated on real lifter output")]

    def _auto_hint(self) -> str:
        """What auto mode's spread was measured against: within the threshold, a static camera;
        above it, what the spread can mean (lying, seated or cycling bodies spread the
        per-frame up too) and the option for a static camera (a user trial read "above the
        threshold" alone as "the camera moved")."""
        mode = self.report.rectification.mode
        if mode.requested != "auto" or mode.spread_deg is None:
            return ""
        if self.mode == "sequence" and mode.spread_deg <= MODE_THRESHOLD_DEG:
            return f", within the {MODE_THRESHOLD_DEG:g} deg of a static camera"
        if self.mode != "smooth":
            return ""
        return (f", above the {MODE_THRESHOLD_DEG:g} deg of a static camera: a moving camera, or poses whose up the "
                f"networks read less steadily; --mode sequence for a static camera")

    def _method_label(self) -> str:
        """The method, with the weights' file where they are not the shipped ones (a user trial's
        own network read "pcnet" like the shipped pair)."""
        weights = (self.report.inputs or {}).get("weights", "shipped")
        return self.method if weights == "shipped" else f"{self.method} ({Path(weights).name} weights)"

    def _pitch_roll(self, long: bool = True) -> str:
        seq = self.report.rectification.sequence
        if seq is not None and seq.evidence == GIVEN_UP:
            trial = (self.report.inputs or {}).get("camera_up_from")
            interval = None if trial is None else _trial_interval(self.report.inputs)
            given = GIVEN_TILT if trial is None else (
                f"given, --camera-up-from {trial['folder']}, " + ("whose own up was given" if interval is None else
                                                                 f"whose 95 % interval was +- {interval[0]:.1f} / "
                                                                 f"{interval[1]:.1f}"))
            return (f"(pitch {signed_deg(self.camera_pitch_deg)}, roll {signed_deg(self.camera_roll_deg)} deg; {given}; "
                    f"the per-frame ups lie a median {seq.up_spread_deg:.1f} deg from it)")
        nan = float("nan")
        pitch_unc, roll_unc = (seq.camera_pitch_interval_deg, seq.camera_roll_interval_deg) if seq else (nan, nan)
        if not (np.isfinite(pitch_unc) and np.isfinite(roll_unc)):
            boot = (seq.camera_pitch_uncertainty_deg, seq.camera_roll_uncertainty_deg) if seq else (nan, nan)
            weights = f"{' with --weights' if self.method != 'geometric' else ''}"
            if np.isfinite(boot).all() and not long:
                return (f"(pitch {signed_deg(self.camera_pitch_deg)}, roll {signed_deg(self.camera_roll_deg)} deg; bootstrap alone "
                        f"+- {boot[0]:.1f}/{boot[1]:.1f}; a 95 % interval is not for method {self.method}{weights})")
            if np.isfinite(boot).all():
                return (f"(pitch {signed_deg(self.camera_pitch_deg)}, roll {signed_deg(self.camera_roll_deg)} deg; bootstrap alone "
                        f"+- {boot[0]:.1f}/{boot[1]:.1f}, no 95 % interval: the lifter's systematic error is "
                        f"calibrated for the shipped 3DPCNet ensemble only, not for method {self.method}{weights})")
            return f"(pitch {signed_deg(self.camera_pitch_deg)}, roll {signed_deg(self.camera_roll_deg)} deg)"
        lying = self.report.rectification.lying
        posture = self.report.rectification.posture
        declared = " (declared)" if posture is not None and posture.declared else ""
        other = seq.interval_reaches_other_posture_p
        interval = (f"(pitch {signed_deg(self.camera_pitch_deg)} +- {pitch_unc:.1f}, roll {signed_deg(self.camera_roll_deg)} "
                    f"+- {roll_unc:.1f} deg; ")
        # The intervals are calibrated on static validation cameras, none of whose per-frame ups
        # spread beyond MODE_THRESHOLD_DEG: beyond it they are not called 95 % (decision 0090).
        beyond = spreads_beyond_static(self.report.rectification.mode)
        if not long:
            if beyond:
                label = ("lying posture's interval" if lying else "interval") + " not calibrated: ups spread wide"
            else:
                # the posture read either way (a physiotherapist's trial found "upright" said nowhere)
                upright = "" if posture is None else ", upright declared" if declared else ", body read upright"
                label = f"95 % posterior interval of the lying posture{declared}" if lying else "95 % interval" + upright
            if other is not None:
                label += f", widened to the {'upright' if lying else 'lying'} posture ({100 * other:.0f} %)"
            return interval + label + ")"
        label = (f"posterior interval of the lying posture{declared}" if lying
                 else f"posterior interval per axis{', upright declared' if declared else ''}")
        if beyond:
            label += (", not calibrated for this recording: its per-frame ups spread beyond any static camera's of the "
                      "validation data (a moving camera, or poses the networks read inconsistently; decision 0090)")
        else:
            label = "95 % " + label
        label += " (up model, docs/up_model.md)"
        if other is not None:
            label += (f"; widened to reach the {'upright' if lying else 'lying'} posture, which keeps "
                      f"{100 * other:.0f} % of the posterior")
        return (interval + f"{label}; the poses alone +- "
                f"{seq.camera_pitch_uncertainty_deg:.1f}/{seq.camera_roll_uncertainty_deg:.1f}; "
                f"evidence: {seq.evidence})")


#: :func:`_frame_rate`'s sources of a rate that rests on ``--fps`` alone (:func:`fps_unchecked`).
_FPS_ALONE = "--fps"
_FPS_OVERRIDING = "--fps, overriding"


def _frame_rate(cfg: RunConfig, video, *carried: tuple[str | None, float | None]) -> tuple[float, str]:
    """The recording's frame rate and where it came from (for the summary): ``--fps``, else the
    video's, else the one an input file carries (MediaPipe npz, a Kinect archive), given as
    ``(file, fps or None)`` pairs. ``--fps`` contradicting the video's or a file's own rate is an
    error unless ``fps_override``; the source is ``"--fps"`` alone only where nothing recorded a
    rate to check it against."""
    recorded = [(cfg.video, video.fps)] if video is not None else []
    recorded += [(source, fps) for source, fps in carried if fps is not None]
    if cfg.fps_override and not recorded:
        raise InputError("fps_override (--fps-override): expected a rate to override (a video's, or one an input "
                         "file records), got none: fps alone sets the rate")
    if cfg.fps is not None:
        problems = [fps_contradiction(cfg.fps, source, fps) for source, fps in recorded]
        if any(problems) and not cfg.fps_override:
            raise InputError(next(p for p in problems if p))
        if not recorded:
            return float(cfg.fps), _FPS_ALONE  # nothing to check it against (the motion warnings ask to)
        said = _FPS_OVERRIDING if problems[0] else "--fps, as recorded in"
        return float(cfg.fps), f"{said} {Path(recorded[0][0]).name}"
    if recorded:
        source, fps = recorded[0]
        for other, other_fps in recorded[1:]:  # a trial's 25 fps video read a 30 fps file's poses without a word
            if not rates_agree(other_fps, fps):
                raise InputError(f"frame rate: expected {Path(source).name} and {Path(other).name} to record the same "
                                 f"rate, got {fps:g} and {other_fps:g} fps: give the recording's rate with --fps and "
                                 f"--fps-override")
        return validate_fps(fps, f"{source}: frame rate"), f"recorded in {Path(source).name}"
    raise InputError("fps: needed when no video is given and the input files do not carry their frame rate "
                     "(pass --fps)")


def fps_unchecked(fps_source: str) -> bool:
    """Whether :func:`_frame_rate`'s rate rests on ``--fps`` alone: nothing recorded a rate, or
    ``--fps-override`` set it against the recorded one (a user trial's forced rate lost the
    motion warnings' "check --fps", though a forced rate is the likeliest to be wrong)."""
    return fps_source == _FPS_ALONE or fps_source.startswith(_FPS_OVERRIDING)


@dataclass(frozen=True, eq=False)
class RecordingInputs:
    """What :func:`_load_inputs` read for one recording.

    video: the probed video or ``None``; fps, fps_source: the frame rate (Hz) and where it came
    from; keypoints2d: ``(T, 17, 3)`` H36M-17 pixels and confidence or ``None``;
    keypoint_image_size: ``(width, height)`` the 2D file states, or ``None``; keypoint_extent:
    :func:`keypoints_extent` of a turned video's keypoints, or ``None``; joints: ``(T, 17, 3)``
    H36M-17 camera-frame lifter poses in ``units``; measured_root: the lifter's root is a
    measured path (:attr:`pcnet.adapters.Poses3D.root_translation`); depth_sensor: the file is a
    depth sensor's own skeleton (:attr:`pcnet.adapters.Poses3D.depth_sensor`); notes: summary lines about
    the inputs; lifter_turn_deg: :attr:`pcnet.adapters.Poses3D.frame_turn_deg`; nonfinite:
    :attr:`pcnet.adapters.Poses3D.nonfinite`; camera_matrix: the lifter file's ``(3, 3)`` ``K``
    or ``None`` (:attr:`pcnet.adapters.Poses3D.camera_matrix`); read: what was read, as the
    report's ``inputs`` (:func:`_inputs_read`); breaks: :attr:`pcnet.adapters.Poses3D.breaks`.
    """

    video: VideoInfo | None
    fps: float
    fps_source: str
    keypoints2d: np.ndarray | None
    keypoint_image_size: tuple[int, int] | None
    keypoint_extent: np.ndarray | None
    joints: np.ndarray | None
    units: str
    measured_root: bool
    depth_sensor: bool
    notes: list
    lifter_turn_deg: float
    nonfinite: dict
    camera_matrix: np.ndarray | None
    read: dict
    breaks: tuple[int, ...] = ()


def _read_with(adapter: object, path, kind: type, **options):
    """``adapter.load(path, **options)``, checked to return ``kind``; an exception other than
    bad input (:class:`InputError`) is a bug in the adapter and keeps its traceback, with a
    note naming the adapter, its module, the package it came from and the file (a developer
    trial's plugin failed with a traceback that named none of them).

    Raises:
        InputError: bad input, as the adapter raised it.
        TypeError: the adapter returned something other than ``kind``.
        Exception: whatever else the adapter raised, with that note.
    """
    try:
        loaded = adapter.load(path, **options)
        if not isinstance(loaded, kind):
            raise TypeError(f"{type(adapter).__qualname__}.load: expected to return pcnet.adapters.{kind.__name__}, "
                            f"got {type(loaded).__name__}")
    except InputError:
        raise
    except Exception as err:
        err.add_note(f"pcnet: raised by the adapter {_adapter_origin(adapter)} reading {path}: a bug in that "
                     "adapter, to report to its author with this traceback")
        raise
    return loaded


def _adapter_origin(adapter: object) -> str:
    """``pkg.module.Class (package dist 1.0)``: where an adapter's code comes from."""
    module = type(adapter).__module__
    dists = importlib.metadata.packages_distributions().get(module.split(".")[0], [])
    versions = []
    for dist in dists:
        try:
            versions.append(f"{dist} {importlib.metadata.version(dist)}")
        except importlib.metadata.PackageNotFoundError:
            versions.append(dist)
    origin = f" (package {', '.join(versions)})" if versions else ""
    return f"{module}.{type(adapter).__qualname__}{origin}"


def _require_input(path, field: str) -> None:
    """An input path checked before its adapter reads it: a registered adapter may not check
    its own, and a missing file is bad input, not the adapter's ``FileNotFoundError``.

    Raises:
        AdapterError: ``path`` (a file or folder: some formats are folders) does not exist."""
    if not as_path(path, f"an existing file or folder ({field})").exists():
        raise AdapterError(path, field, "an existing file or folder", "no such file or folder")


def _refuse_input_folders(cfg: RunConfig) -> None:
    """A folder given for an input that is a file (all but a 2D format read from a folder,
    ``register_2d(folder_input=True)``): named as such before the output folder is checked
    against the inputs (a bad-input trial's folder given as the API's ``lifter_output`` was
    refused as an ``--out`` inside it).

    Raises:
        InputError: the first such input, naming its field.
    """
    for name in ("video", "keypoints2d", "lifter_output", "weights"):
        path = getattr(cfg, name)
        if path is not None and Path(path).is_dir() and not (name == "keypoints2d"
                                                             and reads_folder(cfg.keypoints2d_format)):
            raise InputError(f"{field_name(COMMAND_LINE, name)}: expected a file, got a folder ({path})")


def _load_inputs(cfg: RunConfig) -> RecordingInputs:
    video = probe_video(cfg.video) if cfg.video else None
    kp2d, kp_fps, kp_size, kp_choice, kp_extent, kp_layout = None, None, None, "", None, None
    if cfg.keypoints2d:
        adapter = get_2d_adapter(cfg.keypoints2d_format)
        _require_input(cfg.keypoints2d, "keypoints2d")
        options = {"person": cfg.person} if cfg.keypoints2d_format in multi_track_formats() else {}
        if video is not None and "frame_count" in inspect.signature(adapter.load).parameters:
            options["frame_count"] = video.frame_count
        try:
            kp = _read_with(adapter, cfg.keypoints2d, Keypoints2D, **options)
        except AdapterError as err:
            # With --align truncate a 2D file may run past the video: read it whole, _align cuts it.
            if not (cfg.align == "truncate" and "frame_count" in options and "frame_count=" in err.expected):
                hint = _other_2d_format(cfg.keypoints2d, cfg.keypoints2d_format)
                if not hint:
                    raise
                raise InputError(f"{err}{hint}") from err
            del options["frame_count"]
            kp = _read_with(adapter, cfg.keypoints2d, Keypoints2D, **options)
        _refuse_another_archives_keypoints(cfg, kp.points)
        kp2d, kp_fps = remap_to_h36m(kp.points, kp.layout, confidence_channel=True), getattr(kp, "fps", None)
        kp_size = getattr(kp, "image_size", None)
        kp_choice, kp_layout = getattr(kp, "choice", ""), kp.layout
        if video is not None and video.rotation_deg:  # which frame the keypoints are in: feet and hands too
            kp_extent = keypoints_extent(kp.points)
        del kp  # the file's own layout: only its H36M-17 remap is read from here on
    adapter = get_3d_adapter(cfg.lifter)
    options = dict(cfg.lifter_options)  # checked by cfg.validate() in run_pipeline
    if cfg.focal_px is not None and "focal_px" in inspect.signature(adapter.load).parameters:
        options["focal_px"] = cfg.focal_px  # the camera's: a crop-based lifter turns into it (MediaPipe)
    _require_input(cfg.lifter_output, "lifter_output")
    poses = _read_with(adapter, cfg.lifter_output, Poses3D, **options)
    fps, fps_source = _frame_rate(cfg, video, (cfg.lifter_output, getattr(poses, "fps", None)), (cfg.keypoints2d, kp_fps))
    joints = lifter_joints(poses, str(cfg.lifter_output), in_place=True)  # loaded here: ours to overwrite
    built = built_joints(poses.layout)
    remapped = built and (f"3D joints remapped from {poses.layout} to H36M-17 with {', '.join(built)} built as means "
                          f"of other joints (stages/remap.py): trunk and shoulder angles rest on them")
    # an adapter whose file has no tracks says itself that --person cannot choose
    person_hint = "" if "--person" in kp_choice else " (--person chooses another)"
    choice = kp_choice and f"2D keypoints: {kp_choice}{person_hint}"
    return RecordingInputs(video, fps, fps_source, kp2d, kp_size, kp_extent, joints, poses.units, poses.root_translation,
                           poses.depth_sensor, [n for n in (poses.summary_note, choice, remapped, *_assumed_inputs(cfg),
                                                            _nominal_rate_note(cfg, fps_source)) if n],
                           poses.frame_turn_deg, poses.nonfinite, poses.camera_matrix,
                           _inputs_read(cfg, poses.layout, poses.units, kp_layout, video, poses.notes,
                                        _adapter_origin(adapter)), poses.breaks)


def _other_2d_format(path, tried: str) -> str:
    """``"; it reads as alphapose: --keypoints2d-format alphapose"`` where a 2D file refused by
    the format ``tried`` reads as another registered one (a coach's trial gave AlphaPose's JSON
    as MMPose's and read MMPose's expected keys), else ``""``. Only on that error path."""
    for name in keypoint_formats():
        if name == tried:
            continue
        try:
            get_2d_adapter(name).load(path)
        except Exception:  # noqa: BLE001 - any format that cannot read the file is simply not it
            continue
        return f"; it reads as {name}: --keypoints2d-format {name}"
    return ""


def _refuse_another_archives_keypoints(cfg: RunConfig, points: np.ndarray) -> None:
    """A MediaPipe lifter output holds the 2D keypoints of its own detection: 2D keypoints of
    another MediaPipe file that differ from them belong to another camera or another run, and
    would give the poses another person's left/right, track and pelvis path (a four-camera
    trial ran cam02's poses with cam01's keypoints unflagged). Identity, not a tolerance: the
    same detection gives the same numbers.

    Raises:
        InputError: naming both files and how far apart the keypoints lie.
    """
    if not (cfg.lifter == "mediapipe" and cfg.keypoints2d_format == "mediapipe" and cfg.lifter_output
            and os.path.realpath(cfg.keypoints2d) != os.path.realpath(cfg.lifter_output)
            and holds_keypoints_2d(cfg.lifter_output)):
        return
    own = load_mediapipe_2d(cfg.lifter_output).points
    if own.shape != points.shape:
        differ, detail = True, f"{len(points)} frames against {len(own)}"
    else:
        gap = np.linalg.norm(own[..., :2] - points[..., :2], axis=-1)
        both = np.isfinite(gap)
        differ = bool(np.any(gap[both] > 0)) or not np.array_equal(np.isfinite(own[..., 0]), np.isfinite(points[..., 0]))
        detail = f"median {np.median(gap[both]):.1f} px apart" if both.any() else "no landmark in common"
    if differ:
        raise InputError(f"file '{cfg.keypoints2d}': field 'keypoints_2d': expected the 2D keypoints of the lifter "
                         f"output's own detection ({cfg.lifter_output} holds them), got others ({detail}): another "
                         f"camera's or another run's? give {cfg.lifter_output} as --keypoints2d")


def _inputs_line(read: dict) -> str:
    """report.md's line of :func:`_inputs_read`'s record."""
    declared = "".join(f", {option} {value}" for option, value in read.get("lifter_options", {}).items())
    parts = [f"method {read['method']} ({read['weights']} weights)",
             f"3D {read['lifter_output']} (--lifter {read['lifter']}: {read['lifter_layout']}, {read['lifter_units']}"
             f"{declared and '; as declared' + declared})"]
    if "pose_estimator" in read:  # a video-alone run's file, not one the user gave
        parts[-1] += f", made from the video by pcnet's embedded estimator (mediapipe {read['pose_estimator']['mediapipe_version']})"
    if "keypoints2d" in read:
        parts.append(f"2D {read['keypoints2d']} ({read['keypoints2d_format']}: {read['keypoints2d_layout']})")
    if "video" in read:
        width, height = read["video_size"]
        parts.append(f"video {read['video']} ({width}x{height}, {read['video_frames']} frames)")
    return "; ".join(parts)


def _inputs_read(cfg: RunConfig, layout: str, units: str, kp_layout: str | None, video: VideoInfo | None,
                 lifter_notes: str = "", lifter_adapter: str = "") -> dict:
    """What a run read, for its report (``inputs``): the method and its weights (``"shipped"``
    or the ``--weights`` file), each file with the format it was read as and the joint layout
    found in it (an upstream estimator or a model swapped for another shows here), and the
    lifter options the file was declared with (``lifter_options``: a generic lifter's axes,
    units, key), how the adapter converted the file (``lifter_notes``, :attr:`Poses3D.notes`: its
    own layout and axes where it remapped them) and which code read it (``lifter_adapter``,
    module, class and package version: a plug-in's), the installed pcnet's version and every
    setting of ``cfg`` (``settings``,
    :func:`~pcnet.pipeline.config.settings_record`), from which the run can be repeated; paths
    absolute (a trial's relative command-line path read as typed)."""
    settings = settings_record(cfg)  # what repeats the run: every setting as used, paths absolute
    read = {"method": cfg.method, "weights": settings["weights"] or "shipped", "lifter": cfg.lifter,
            "lifter_output": settings["lifter_output"], "lifter_layout": layout, "lifter_units": units}
    if cfg.lifter_options:  # what the file was declared to be (a generic lifter's axes, units, key)
        read["lifter_options"] = settings["lifter_options"]
    # an in-house adapter's conversion and version had reached no output (a plug-in trial)
    read.update({k: v for k, v in (("lifter_notes", lifter_notes), ("lifter_adapter", lifter_adapter)) if v})
    if cfg.keypoints2d:
        read.update(keypoints2d=settings["keypoints2d"], keypoints2d_format=cfg.keypoints2d_format,
                    keypoints2d_layout=kp_layout)
    if video is not None:
        read.update(video=settings["video"], video_size=[video.width, video.height], video_frames=video.frame_count)
    if cfg.roi is not None:  # the region the embedded estimator saw: which person its poses are
        read["roi"] = list(cfg.roi_px)
    if cfg.camera_up_from is not None:  # the trial's up and how uncertain it was: the given up's own
        read["camera_up_from"] = trial_up_record(cfg.camera_up_from, "camera_up_from")
    read.update(pcnet_version=pcnet_version(), sha256=_digests(settings), settings=settings)
    return read


def _digests(settings: dict) -> dict:
    """``{setting: sha256}`` of every file a run read (the lifter output, 2D keypoints, video and
    the weights: a ``--weights`` file, or the shipped pair by file name where the method runs a
    network): the content a report's paths alone do not pin down (a reproducibility trial ran
    copies and could not tell them from the originals)."""
    out = {key: sha256_path(settings[key]) for key in ("lifter_output", "keypoints2d", "video", "weights")
           if settings.get(key)}
    if settings.get("camera_up_from"):  # the standing trial's up: its run's report (a re-filmed trial changes it)
        out["camera_up_from canonical.npz"] = sha256_path(Path(settings["camera_up_from"]) / "canonical.npz")
    if not settings.get("weights") and settings.get("method") != "geometric":
        out.update({f"weights {path.name}": sha256_file_version(path) for path in (CAMERA_WEIGHTS, BODY_WEIGHTS)})
    return out


def _published(read: dict, staged: Path, out: Path) -> dict:
    """:func:`_inputs_read`'s record with the files read from the run's ``staged`` folder
    named where they are published (``out``): the embedded estimator's poses (in its
    ``settings`` too)."""
    def named(record: dict) -> dict:
        return {k: str(out / Path(v).name) if k in ("lifter_output", "keypoints2d") and v and Path(v).parent == staged
                else named(v) if k == "settings" else v for k, v in record.items()}
    return named(read)


def _trial_interval(read: dict) -> tuple[float, float] | None:
    """The 95 % pitch and roll half-widths (deg) of the standing trial ``--camera-up-from``
    took the up from (the inputs record's ``camera_up_from``), ``None`` without one or where
    that trial's up was itself given without one."""
    trial = read.get("camera_up_from")
    if trial is None:
        return None
    interval = tuple(float("nan") if trial.get(k) is None else float(trial[k])  # JSON writes NaN as null
                     for k in ("camera_pitch_interval_deg", "camera_roll_interval_deg"))
    return interval if np.isfinite(interval).all() else None


def _given_up(cfg: RunConfig, inputs: AlignedInputs) -> tuple[float, float, float] | None:
    """The up the run is given: ``--camera-up``'s, or the standing trial's as the inputs record
    read it once (its interval beside it, :func:`_trial_interval`)."""
    trial = inputs.recording.read.get("camera_up_from")
    return tuple(trial["up"]) if trial is not None else cfg.camera_up_vector


def _nominal_rate_note(cfg: RunConfig, fps_source: str) -> str | None:
    """A note where a Kinect v1 skeleton's rate is ``--fps`` alone and exactly the sensor's
    nominal 30 fps, which its recorders do not reach (an ergonomist's trial read UTD-MHAD's
    92 frames as 3.07 s, not 5.02: every held posture's time 39 % short)."""
    from pcnet.adapters.kinect import KINECT_V1_NOMINAL_FPS

    if cfg.lifter != "kinect_v1" or not fps_unchecked(fps_source) or cfg.fps != KINECT_V1_NOMINAL_FPS:
        return None
    return (f"--fps {KINECT_V1_NOMINAL_FPS:g} is Kinect v1's nominal rate, which its recorders do not reach (they "
            f"drop frames: UTD-MHAD's files record 14-21 fps): frames / the recording's duration is its rate, and "
            f"every time, speed and held posture's duration scales with it")


def _assumed_inputs(cfg: RunConfig) -> list[str]:
    """Notes on what the run assumed about its inputs because nothing said otherwise: the
    generic lifter's default layout, axes and units, a MediaPipe archive whose own 2D
    keypoints (where it holds them) were not given."""
    notes = []
    if cfg.lifter == "generic":
        defaults = {name: param.default for name, param in inspect.signature(get_3d_adapter("generic").load).parameters.items()
                    if name in ("layout", "axes", "units") and name not in cfg.lifter_options}
        if defaults:
            notes.append("generic lifter read with the default " + ", ".join(f"--{k} {v}" for k, v in defaults.items())
                         + " (not given)")
    if cfg.lifter == "mediapipe" and cfg.keypoints2d is None and holds_keypoints_2d(cfg.lifter_output):
        notes.append("the MediaPipe archive's own 2D keypoints were not used (give the file as --keypoints2d too, "
                     "with --keypoints2d-format mediapipe, for the left/right and track-switch checks)")
    if cfg.weights is not None and cfg.method != "geometric" and not training_config(cfg.weights):
        # pcnet evaluate warns of it; a run said nothing (an ML trial's weights without their .json)
        notes.append(f"--weights {Path(cfg.weights).name}: no training record beside them (the .json pcnet export "
                     f"writes), so what they trained on is unknown")
    return notes


def _picture_typed(cfg: RunConfig) -> bool:
    """Whether the keypoints' picture size is the user's ``--image-size`` (no video): a size the
    user may have typed the other way round."""
    return cfg.image_size_px is not None and cfg.video is None


def _no_frame_hint(cfg: RunConfig, error: str, camera: CameraFrame, layout: str = "") -> str:
    """What to add to a "no frame can be rectified" error: the joint layout a file was read in (a
    generic file's default or declared one, a named lifter's own ``layout``), the likeliest
    cause there, the picture where joints were masked as outside it (a wrong --image-size),
    and the 2D confidence threshold where 2D keypoints mask joints (a
    threshold near 1 masks every joint)."""
    if not error.startswith(NO_VALID_FRAME):
        return ""
    hint = ""
    if cfg.lifter == "generic":  # a declared layout can be the wrong one too (a trial's COCO file declared h36m17)
        layout = cfg.lifter_options.get("layout")
        hint += (f" (read with {'the default --layout h36m17' if layout is None else f'--layout {layout}'}: is the "
                 f"file in another joint layout?)")
    elif layout:
        hint += f" (read in {cfg.lifter}'s joint order, {layout}: is the file in another joint order?)"
    if camera.outside and camera.picture is not None:
        w, h = camera.picture
        typed = " or width and height swapped in --image-size" if _picture_typed(cfg) else ""
        hint += (f" ({camera.outside} joint positions were masked as their 2D keypoints lie outside the {w}x{h} "
                 f"picture: keypoints of another video or resolution{typed}?)")
    if cfg.keypoints2d is not None:
        hint += (f" (or those joints were masked for 2D confidence in {cfg.keypoints2d} below "
                 f"{cfg.min_confidence:g}: is --confidence-threshold too high?)")
    return hint


_UNIT_NAMES = {"m": "metres", "cm": "centimetres", "mm": "millimetres"}


def _check_metric_body(cfg: RunConfig, cam) -> None:
    """Refuse H36M-17 camera-frame poses ``cam`` ``(T, 17, 3)`` said to be in metres (after any
    ``--units``) whose median thigh is no person's (:func:`pcnet.stages.core.conventions.thigh_beyond_metres`): their metric outputs
    (TRC, speeds) would be wrong by a factor of 100 or so. Smaller misfits stay a warning
    (:func:`pcnet.stages.flags.body_size_flag`).

    Raises:
        InputError: naming the lifter output, the thigh length and the options that fix it.
    """
    thigh = thigh_beyond_metres(cam)
    if thigh is None:
        return
    high = REFUSED_THIGH_M[1]
    if thigh > high and cfg.lifter == "generic":
        # the unit whose thigh would be a person's (a trial's millimetres declared as cm were told "give --units cm")
        declared = cfg.lifter_options.get("units") or "m"
        fits = [u for u, metres in METRES_PER_LENGTH_UNIT.items()
                if THIGH_RANGE_M[0] <= thigh * metres / METRES_PER_LENGTH_UNIT[declared] <= THIGH_RANGE_M[1]]
        guess = (f"{_UNIT_NAMES[fits[0]]}? give --units {fits[0]}" if fits
                 else "another unit? give --units m, cm or mm as the file holds")
    elif thigh > high:
        guess = {"videopose3d": "centimetres? read it with --lifter generic --units cm (VideoPose3D's H36M-17 order "
                                "and camera axes are the generic reader's defaults)"}.get(
            cfg.lifter, "centimetres? read it with --lifter generic, the file's --layout and --axes, and --units cm")
    else:
        guess = (f"metres declared as --units {cfg.lifter_options.get('units')}? declare --units m"
                 if cfg.lifter_options.get("units") in ("cm", "mm") else "a joint order other than the lifter's?")
    raise InputError(f"file '{cfg.lifter_output}': field 'units': expected poses in metres (a median thigh length of "
                     f"{THIGH_RANGE_M[0]}-{THIGH_RANGE_M[1]} m), got {thigh:.3g} m: {guess}, or --height to scale the "
                     f"poses")


def _unused_floor_note(measured_root: bool, ground_plane: dict | None) -> list[str]:
    """A note when the input measured the pelvis path (a depth camera, ``--measured-root``)
    but sequence mode's ground-plane step did not fit the floor from the foot contacts: the
    user may expect it, and ``ground_plane["reason"]`` says why not."""
    if not measured_root or not ground_plane or ground_plane.get("used"):
        return []
    return [f"up not refined by the floor's tilt from the foot contacts ({ground_plane.get('reason', 'no reason given')}): "
            f"it comes from the poses alone (stages/ground_plane.py)"]


#: 2D formats that write nothing for a frame without a detected person: AlphaPose's results
#: JSON lists detections, each with its ``image_id`` (adapters/alphapose.py), so a file that ends
#: before the video ends in undetected frames. Other formats write every frame (a MediaPipe file
#: or an OpenPose folder that ends early is another recording or an incomplete one).
DETECTIONS_ONLY_2D_FORMATS = ("alphapose",)


def _align(cfg: RunConfig, video, kp2d, joints):
    """``(kp2d, joints, note)``: 2D keypoints of :data:`DETECTIONS_ONLY_2D_FORMATS` that end
    before a video and a 3D output of one length padded with undetected (NaN) frames; else the inputs cut to their common length
    under ``--align truncate`` (the note says what was padded or cut; ``None`` when nothing
    was), else unchanged.

    Raises:
        InputError: the frame counts differ otherwise without ``--align truncate`` (2D
            keypoints one frame longer than the 3D with an empty frame 0: said to look counted
            from 1).
    """
    if (kp2d is not None and video is not None and cfg.keypoints2d_format in DETECTIONS_ONLY_2D_FORMATS
            and len(kp2d) < len(joints) == video.frame_count):
        n2 = len(kp2d)
        pad = np.full((len(joints) - n2, *kp2d.shape[1:]), np.nan, np.float32)
        return np.concatenate([np.asarray(kp2d, np.float32), pad]), joints, (
            f"2D keypoints end at frame {n2} of the {len(joints)} of the video and the 3D output: the last "
            f"{len(joints) - n2} read as undetected (NaN; {Path(cfg.keypoints2d).name} lists no person there)")
    counts = {"3D lifter output": (cfg.lifter_output, len(joints))}
    if kp2d is not None:
        counts["2D keypoints"] = (cfg.keypoints2d, len(kp2d))
    if video is not None:
        counts["video"] = (cfg.video, video.frame_count)
    n = min(c for _, c in counts.values())
    if len({c for _, c in counts.values()}) > 1:
        if cfg.align != "truncate":
            detail = ", ".join(f"{k} {p}: {c} frames" for k, (p, c) in counts.items())
            if kp2d is not None and len(kp2d) == len(joints) + 1 and not np.isfinite(kp2d[0]).any():
                raise InputError(f"frame counts differ ({detail}), and the 2D keypoints' frame 0 is empty: frame "
                                 f"indices counted from 1? pcnet counts them from 0 (the first frame is 0); "
                                 f"--align truncate would pair each 2D frame with the 3D frame before it")
            raise InputError(f"frame counts differ ({detail}); pass --align truncate to use the first {n} frames "
                             f"(only when every input is of this recording and starts at its first frame: "
                             f"truncating pairs frame i of each)")
        joints = joints[:n]
        kp2d = None if kp2d is None else kp2d[:n]
        cut = ", ".join(f"{k} {c - n}" for k, (_, c) in counts.items() if c > n)
        return kp2d, joints, f"--align truncate: the first {n} frames of every input used, the last frames cut ({cut})"
    return kp2d, joints, None


#: Change of an image-scaled body's size over a recording (largest / smallest per-frame
#: factor) from which the summary says it was made constant: the boxing demo's lifter noise
#: alone gives 1.05.
SIZE_NOTE_RATIO = 1.1

#: Allocations from this size up are served by ``mmap`` and return to the system when freed:
#: whole-recording arrays of long recordings (a 20-minute float32 pose array is 7 MiB), not
#: the per-chunk and per-batch working arrays below it, which the heap reuses.
MMAP_THRESHOLD_BYTES = 4 << 20
#: Free heap memory kept at the top of the heap before glibc gives it back.
TRIM_THRESHOLD_BYTES = 32 << 20


def _freed_arrays_back_to_the_os() -> None:
    """Have glibc serve allocations of :data:`MMAP_THRESHOLD_BYTES` or more by ``mmap``, so
    a freed whole-recording array returns its pages to the system at once, and keep
    :data:`TRIM_THRESHOLD_BYTES` of freed heap before trimming it.

    By default glibc raises its mmap threshold to the size of the largest block freed (up
    to 32 MiB, ``man 3 mallopt``, M_MMAP_THRESHOLD, M_TRIM_THRESHOLD), after which a long
    recording's per-stage arrays come from the heap and stay resident after they are freed.
    Setting a threshold turns that dynamic adjustment off for both, which leaves the trim
    threshold at 128 KiB: the heap then shrinks and regrows around every working array,
    each regrowth a page fault per 4 KiB. Measured (one 6,020-frame row, one thread): a
    1 MiB threshold with the default trim spent 2.4 s of 10 s in the kernel on 1.25 M page
    faults; 4 MiB with a 32 MiB trim 0.6 s on 0.14 M (glibc's defaults: 0.6 s, 0.15 M); peak
    RSS for 60 min at 30 fps 724 MB (4 MiB with the default trim: 730, glibc's defaults: 750).
    Other C libraries: nothing to do.
    """
    libc = _glibc()
    if libc is not None:
        libc.mallopt(-3, MMAP_THRESHOLD_BYTES)  # M_MMAP_THRESHOLD (glibc malloc.h)
        libc.mallopt(-1, TRIM_THRESHOLD_BYTES)  # M_TRIM_THRESHOLD


def _trim_heap() -> None:
    """Give the heap's free pages back to the system between stages (glibc ``malloc_trim(0)``,
    ``man 3 malloc_trim``: also the free pages in the middle of the heap, which the trim
    threshold never reaches). A stage's block-sized working arrays (below
    :data:`MMAP_THRESHOLD_BYTES`) and an input parser's many small objects leave the heap
    fragmented, so their pages stayed resident under the next stage's whole-recording
    arrays (with the block-wise rectification, the 2-hour peak of
    ``python -m benchmarks.pipeline_throughput`` went from 1,008 to 977 MB). First the cyclic
    garbage is collected: a drawn matplotlib figure is a cycle of objects that Python's
    collector frees only when container allocations trigger it, which the next stage's
    numpy work does not (20 MB left of a 60-minute recording's figures)."""
    gc.collect()
    libc = _glibc()
    if libc is not None:
        libc.malloc_trim(0)


@lru_cache(maxsize=1)
def _glibc():
    """The C library when it is glibc (Linux), else None (musl, macOS, Windows)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return None
    return libc if hasattr(libc, "mallopt") and hasattr(libc, "malloc_trim") else None  # musl has neither


def run_pipeline(cfg: RunConfig, progress: bool = True, *,
                 before_publish: Callable[[Path, RunResult], None] | None = None) -> RunResult:
    """Run every stage for one recording and write its outputs into ``cfg.out``.

    ``cfg.c3d`` and ``cfg.opensim`` need metric outputs: poses that stay unscaled (no
    ``cfg.height``, a lifter whose output is not in metres) are refused once the lifter output
    is read, before anything is written. ``cfg.opensim`` scales an OpenSim model and solves
    inverse kinematics on the world-frame markers in the staged output, so its files (and its
    fit's warning, in the summary, npz and recording) are published with the rest.
    ``before_publish(staged_folder, result)`` may add files of its own (``pcnet batch``'s resume
    marker) to the staged output before it is swapped in as ``cfg.out``, so that they appear
    together with it or not at all. ``progress``: a bar of the stages on stderr where stderr
    is a terminal.

    Returns:
        :class:`RunResult`: the run's report (:class:`~pcnet.pipeline.run_report.RunReport`),
        its findings and notes, the written outputs' paths and ``summary()``, the text
        ``pcnet run`` prints.

    Raises:
        FileExistsError: ``cfg.out`` is an earlier pcnet output or an empty folder and
            ``cfg.overwrite`` is False (not an ``InputError``: catch both to handle every
            refusal; any other existing folder is an ``InputError``).
        pcnet.stages.core.errors.InputError (``AdapterError`` is one): bad inputs or an unsafe
            ``out`` (:func:`pcnet.pipeline.outdir.check_out_folder`), naming file and field.
        TypeError: a registered adapter's ``load`` returned something other than the
            :class:`~pcnet.adapters.Poses3D` or :class:`~pcnet.adapters.Keypoints2D` it
            must return (a bug in that adapter).
    """
    _freed_arrays_back_to_the_os()
    if cfg.c3d:
        require_ezc3d()  # before any work: without ezc3d, one line saying how to get it
    if cfg.opensim:
        import_opensim()  # the same for OpenSim
    cfg.validate()
    _refuse_input_folders(cfg)
    out = check_out_folder(cfg.out, (cfg.video, cfg.keypoints2d, cfg.lifter_output, cfg.weights,
                                     # the standing trial's run: never overwritten by the one taking its up
                                     cfg.camera_up_from and Path(cfg.camera_up_from) / "canonical.npz"),
                           cfg.overwrite)
    # disable=None: no bar where stderr is not a terminal (a log file, a pipe), whose
    # carriage-return redraws would fill it; a long run there says where it is in lines.
    with _collector_skips_older_objects(), \
            tqdm(total=len(STEPS) + (cfg.lifter_output is None), desc="pcnet", disable=None if progress else True,
                 unit="stage") as bar, \
            _stage_lines(bar, progress, ("estimate",) * (cfg.lifter_output is None) + STEPS):
        return _run_stages(cfg, out, bar, before_publish)


#: Seconds between the lines that say which stage a run is in, where stderr is not a terminal.
STAGE_LINE_INTERVAL_S = 30.0


@contextmanager
def _stage_lines(bar, progress: bool, stages: tuple[str, ...]):
    """Where ``progress`` is asked for and stderr is not a terminal (a log file, a scheduler's
    output: ``bar`` is disabled there), a line every :data:`STAGE_LINE_INTERVAL_S` seconds
    naming the stage the run is in (``bar``'s postfix, one of ``stages``), its number and the
    seconds since the start (a user trial ran a ten-minute session into a log and saw nothing
    until it ended). A run shorter than the interval writes nothing."""
    if not (progress and bar.disable):
        yield
        return
    stop, start, interval_s = threading.Event(), time.perf_counter(), STAGE_LINE_INTERVAL_S

    def say() -> None:
        while not stop.wait(interval_s):
            stage = bar.postfix or stages[0]
            number = f" (stage {stages.index(stage) + 1} of {len(stages)})" if stage in stages else ""
            print(f"pcnet: {stage}{number}, {time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)

    thread = threading.Thread(target=say, name="pcnet-stage-lines", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


_FREEZE_LOCK = threading.Lock()
_freeze_depth = 0


@contextmanager
def _collector_skips_older_objects():
    """Exempt from the cyclic garbage collector, for the length of one recording, every object
    alive when it starts (``gc.freeze``, Python docs "gc"; ``gc.unfreeze`` after).
    :func:`_trim_heap`'s full collection between stages otherwise re-traverses every imported
    module's objects each time: 10 collections over about 160,000 objects cost 0.74 s of a
    4.3 s row of the bundled example (cProfile of a second row in one process, as in a batch
    worker). Objects made during the run are collected as before. The freeze is the
    process's: a caller that froze objects itself keeps its freeze (nothing is frozen or
    unfrozen here), and runs overlapping in threads freeze once, the first to start, and
    unfreeze once, the last to end."""
    global _freeze_depth
    with _FREEZE_LOCK:
        ours = _freeze_depth > 0 or gc.get_freeze_count() == 0
        if ours:
            if _freeze_depth == 0:
                gc.collect()
                gc.freeze()
            _freeze_depth += 1
    try:
        yield
    finally:
        if ours:
            with _FREEZE_LOCK:
                _freeze_depth -= 1
                if _freeze_depth == 0:
                    gc.unfreeze()


def _image_size(cfg: RunConfig, video: VideoInfo | None, keypoint_size: tuple[int, int] | None) -> tuple[int, int] | None:
    """``(width, height)`` of the frames the 2D keypoints are in (as displayed): the video's,
    else ``--image-size``, else the keypoint file's, else ``None``.

    Raises:
        InputError: ``--image-size``, or the size the keypoint file states, contradicting the
            video's size (displayed, or as stored for a turned video); ``--image-size``
            contradicting the keypoint file's.
    """
    given = cfg.image_size_px
    if video is not None:
        if given is not None and given != (video.width, video.height):
            raise InputError(f"--image-size {cfg.image_size}: expected the size of {cfg.video} as displayed "
                             f"({video.width}x{video.height}), got {given[0]}x{given[1]}; leave it out with a video")
        if keypoint_size is not None and tuple(keypoint_size) not in ((video.width, video.height), video.stored_size):
            raise InputError(f"file '{cfg.keypoints2d}': field 'width, height': expected the size of {cfg.video} "
                             f"({video.width}x{video.height}), got {keypoint_size[0]}x{keypoint_size[1]}: 2D keypoints "
                             f"of another video or resolution?")
        return video.width, video.height
    if given is not None and keypoint_size is not None and given != tuple(keypoint_size):
        raise InputError(f"--image-size {cfg.image_size}: expected the size {cfg.keypoints2d} states "
                         f"({keypoint_size[0]}x{keypoint_size[1]}), got {given[0]}x{given[1]}; leave it out")
    return given or keypoint_size


def _camera_frame(cfg: RunConfig, joints, kp2d, measured_root: bool, store: FrameStore,
                  orientation: DisplayOrientation, picture: tuple[int, int] | None = None):
    """The remap step a block of frames at a time into ``store``: the pelvis rule, the turn
    into a phone video's displayed frame (``orientation``), the root (kept as a measurement
    for a depth sensor), root-relative poses and the joints masked by their 2D confidence and,
    where the ``picture`` the displayed keypoints are in is known (:func:`_keypoint_picture`),
    by their 2D keypoint lying outside it (:func:`pcnet.stages.remap.outside_image`).
    Returns ``(joints_camera, keypoints2d or None, root_cam (T, 3) float64 or None,
    pelvis-filled frame count, joint positions masked as outside the picture, (2, 17) frames each
    joint was masked for its 2D confidence below the threshold (row 0) and for its 2D keypoint
    missing from the file (row 1))``."""
    T = len(joints)
    cam = store.create("joints_camera", (T, 17, 3), np.float32)
    kp = None if kp2d is None else store.create("keypoints2d", kp2d.shape, np.float32)
    # Only a depth sensor measures where the root is; a monocular lifter's root is zeroed,
    # image-normalised or a fixed depth.
    root_cam = np.full((T, 3), np.nan) if measured_root else None
    filled, finite, outside = 0, False, 0
    masked_2d = np.zeros((2, 17), np.int64)
    for rows in frame_blocks(T):
        J, pelvis_filled = fill_pelvis_from_hips(joints[rows])
        J = orientation.joints(J)
        filled += int(pelvis_filled.sum())
        if root_cam is not None:
            root_cam[rows] = J[:, PELVIS]
        J = J - J[:, PELVIS : PELVIS + 1]  # root-relative camera frame
        if kp is not None:
            kp[rows] = orientation.pixels(kp2d[rows])
            present = np.isfinite(J).all(axis=2)
            J = mask_low_confidence(J, kp2d[rows, :, 2], cfg.min_confidence)
            masked = present & ~np.isfinite(J).all(axis=2)
            # a keypoint the file does not have (NaN, inf: no score) is not a low score (a bad-input
            # trial's Infinity read as "confidence below 0.3")
            no_keypoint = ~np.isfinite(kp2d[rows, :, 2])
            masked_2d[0] += (masked & ~no_keypoint).sum(axis=0)
            masked_2d[1] += (masked & no_keypoint).sum(axis=0)
            if picture is not None:
                unseen = outside_image(kp[rows], picture) & np.isfinite(J).all(axis=2)
                outside += int(unseen.sum())
                J[unseen] = np.nan
        finite |= bool(np.isfinite(J).any())
        cam[rows] = J
    if not finite and outside:  # joints were seen, every one of them outside the picture
        raise InputError(f"{cfg.keypoints2d}: expected 2D keypoints inside the {picture[0]}x{picture[1]} picture, got "
                         f"every confident keypoint of every frame outside it (keypoints of another video, resolution "
                         f"or crop, or a wrong --image-size?)")
    if not finite:
        masked = ("" if cfg.keypoints2d is None else
                  f", or every joint masked for 2D confidence in {cfg.keypoints2d} below {cfg.min_confidence:g}")
        raise InputError(f"{cfg.lifter_output}: expected frames with a pelvis or both hips (the poses are centred on "
                         f"them), got every joint of every frame missing (NaN) once centred: no pelvis and no hip pair"
                         f"{masked}")
    return cam, kp, root_cam, filled, outside, masked_2d


#: What MediaPipe's 2D score is (``pcnet.adapters.mediapipe.load_mediapipe_2d``): an estimator
#: swap's trial saw the far arm masked in 283 of 301 frames, where AlphaPose's detection
#: confidence kept the same arm.
VISIBILITY_SCORE = ("MediaPipe's score is visibility, the chance a landmark is in view: an arm hidden behind the body "
                    "is masked though MediaPipe estimates it; --confidence-threshold 0 keeps the estimate")


def _masked_2d_notes(masked_2d: np.ndarray, frames: int, threshold: float,
                     keypoints2d_format: str | None = None) -> list[str]:
    """Notes naming the joints masked by their 2D keypoint, most first, from ``masked_2d``
    ``(2, 17)`` (:func:`_camera_frame`): those below the confidence threshold, and those the 2D
    file lacks. The missing-data line says how much is missing, these why and which setting
    decides it (a developer's trial lost MediaPipe's right arm in 283 of 301 frames with no
    cause given); for MediaPipe's keypoints, what its score is (:data:`VISIBILITY_SCORE`)."""
    def listed(counts: np.ndarray) -> str:
        order = [j for j in np.argsort(-counts, kind="stable") if counts[j]]
        return "; ".join(f"{H36M_JOINTS[j]} in {counts[j]} of {frames} frames" for j in order)

    notes = []
    if masked_2d[0].any():
        score = f" ({VISIBILITY_SCORE})" if keypoints2d_format == "mediapipe" else ""
        notes.append(f"joints masked for 2D confidence below --confidence-threshold {threshold:g}: "
                     f"{listed(masked_2d[0])}{score}")
    if masked_2d[1].any():
        notes.append(f"joints masked where the 2D keypoints lack them (no finite position or score): "
                     f"{listed(masked_2d[1])}")
    return notes


def _located(cam, root_cam: np.ndarray | None, store: FrameStore):
    """Camera-frame joints with the measured root put back (sequence mode fits the floor to
    the foot contacts, stages/ground_plane.py), or ``cam`` itself."""
    if root_cam is None:
        return cam
    located = store.create("joints_located", cam.shape, np.float32)
    for rows in frame_blocks(len(cam)):
        located[rows] = cam[rows] + root_cam[rows, None].astype(np.float32)
    return located


def _moved_to_disk(arr: np.ndarray, name: str, store: FrameStore):
    """``arr`` copied into the run's frame store a block of frames at a time."""
    stored = store.create(name, arr.shape, arr.dtype, fill=None)
    for rows in frame_blocks(len(arr)):
        stored[rows] = arr[rows]
    return stored


#: Share of the frames with a trunk above which the summary says how many have no pelvis heading.
HEADINGLESS_NOTE_SHARE = 0.1


def _headingless_note(angles, positions) -> list[str]:
    """A note when many frames have a trunk and both hips but no pelvis-heading frame (a hip
    line within a few degrees of vertical: a body lying on its side), whose plane inclinations
    and ISB angles to gravity are then empty while the heading-free angles remain. Frames
    without a hip are missing data, counted elsewhere, not a body on its side.

    Args:
        angles: the run's ``Kinematics.angles`` (name -> ``(T,)`` degrees).
        positions: its ``(T, 17, 3)`` positions (NaN = missing)."""
    hips = np.concatenate([np.isfinite(positions[rows][:, [R_HIP, L_HIP]]).all(axis=(1, 2))
                           for rows in frame_blocks(len(positions))])
    trunk = np.isfinite(np.asarray(angles["trunk_inclination"])) & hips
    headingless = int((trunk & ~np.isfinite(np.asarray(angles["trunk_sagittal_inclination"]))).sum())
    if headingless <= HEADINGLESS_NOTE_SHARE * max(int(trunk.sum()), 1):
        return []
    return [f"no pelvis heading in {headingless} of {int(trunk.sum())} frames (the hip line near vertical: a body lying "
            f"on its side): their sagittal and frontal inclinations are empty (and the ISB angles to gravity where "
            f"the shoulder line is vertical too); trunk inclination and the unsigned knee and elbow flexion are kept"]


def _spine_built_on_trunk_line(cam) -> bool:
    """True when every frame with a pelvis, spine and thorax has the spine on the pelvis-thorax
    line (:data:`~pcnet.stages.isb_angles.SPINE_ON_LINE_FRACTION`), and at least one frame has them."""
    ratio = per_frame(spine_off_trunk_line, cam)
    finite = np.isfinite(ratio)
    return bool(finite.any() and (ratio[finite] <= SPINE_ON_LINE_FRACTION).all())


def _opensim(cfg: RunConfig, staged: Path, findings: list[Finding], notes: list[str]) -> dict[str, Path]:
    """OpenSim scaling and inverse kinematics on the staged ``world.trc`` (into ``staged``):
    the fit's line goes to ``notes``, its warnings to ``findings``; without a world frame (a
    moving camera) a flag says why there is none. Returns the files written."""
    trc = staged / "world.trc"
    if not trc.is_file():
        findings += no_opensim_flag()
        return {}
    fit = scale_and_ik(trc, staged, cfg.height, cfg.mass)
    notes += [opensim_fit_line(fit), *opensim_notes(fit)]
    # the model's short leg is the poses' (the run's own check said it): one warning, not two
    findings += [f for f in opensim_fit_findings(fit) if f.kind is None or f.kind not in {g.kind for g in findings}]
    return {name: staged / name for name in OPENSIM_OUTPUTS}


def _scaled_in_place(arr, factor) -> None:
    """Multiply a pose array (on disk) by ``factor`` (a number, or ``(T,)`` one per frame) in
    float64, a block at a time, storing float32 values."""
    per_frame = np.ndim(factor) == 1
    for rows in frame_blocks(len(arr)):
        f = np.asarray(factor)[rows, None, None] if per_frame else factor
        arr[rows] = (arr[rows].astype(np.float64) * f).astype(np.float32)


# The steps of one recording, each reading and returning frozen records of what the next step
# needs; _run_stages lists them. Whole-recording pose arrays live in the run's FrameStore (on
# disk, read a block of frames at a time) and a step's long in-memory arrays are dropped as
# soon as the next step has what it needs of them.


@dataclass(frozen=True)
class AlignedInputs:
    """Step "inputs": what was read for the recording, cut to a common length.

    recording: :class:`RecordingInputs` whose ``joints`` and ``keypoints2d`` are cut by
    :func:`_align` (``None`` once :meth:`without_poses`); image_size: :func:`_image_size`;
    orientation: how the video is shown (:func:`display_orientation`); notes: the estimator's,
    the inputs' and the ``--align`` note, in that order.
    """

    recording: RecordingInputs
    image_size: tuple[int, int] | None
    orientation: DisplayOrientation
    notes: tuple[str, ...]

    def without_poses(self) -> AlignedInputs:
        """The same without the lifter's and the 2D file's long arrays (the camera frame has them)."""
        return replace(self, recording=replace(self.recording, joints=None, keypoints2d=None))


@dataclass(frozen=True, eq=False)
class CameraFrame:
    """Step "remap": the poses in the camera frame (:func:`_camera_frame`).

    joints: ``(T, 17, 3)`` float32 root-relative camera-frame poses in the store (in the
    lifter's units until the scale step scales them in place); keypoints2d: ``(T, 17, 3)``
    pixels and confidence in the displayed frame, or ``None``; video_keypoints2d: the same in
    the video's stored frame for the recording, or ``None``; root: ``(T, 3)`` float64 measured
    pelvis path, or ``None``; pelvis_filled: frames whose pelvis is the hip midpoint; notes;
    picture: ``(width, height)`` of the picture ``keypoints2d`` are in (:func:`_keypoint_picture`),
    or ``None`` where that is not known; outside: joint positions masked because their 2D
    keypoint lies outside it.
    """

    joints: np.ndarray
    keypoints2d: np.ndarray | None
    video_keypoints2d: np.ndarray | None
    root: np.ndarray | None
    pelvis_filled: int
    notes: tuple[str, ...]
    picture: tuple[int, int] | None = None
    outside: int = 0


@dataclass(frozen=True, eq=False)
class Rectified:
    """Step "rectify": the rectification result and its evidence.

    rotation: ``(T, 3, 3)`` canonical -> camera rotations (docs/CONVENTIONS.md); canonical:
    ``(T, 17, 3)`` poses in the store; valid: ``(T,)`` bool; report: what rectification decided (with the frames whose
    pelvis was filled from the hips); tilt: the camera's tilt from level; tilt_per_frame_deg:
    the per-frame tilts' median and 5-95 % range, ``None`` in sequence mode
    (:func:`pcnet.pipeline.checks.per_frame_tilt`);
    track_segment, track_events: :func:`pcnet.stages.flags.track_segments` of the 2D track
    (``None``, ``[]`` without one); notes.
    """

    rotation: np.ndarray
    canonical: np.ndarray
    valid: np.ndarray
    report: RectificationReport
    tilt: CameraTilt
    tilt_per_frame_deg: list[float] | None
    track_segment: np.ndarray | None
    track_events: list
    notes: tuple[str, ...]

    def one_person(self) -> np.ndarray | None:
        """:func:`_one_person` of this recording's 2D track."""
        return _one_person(self.track_segment, self.track_events)


def _one_person(segment: np.ndarray | None, events: list) -> np.ndarray | None:
    """``(T,)`` bool, the longest one-person stretch where the 2D track switches person
    (:func:`pcnet.stages.flags.one_person_frames`), else ``None`` (every frame is one person's)."""
    return one_person_frames(segment) if events else None


@dataclass(frozen=True)
class Scaled:
    """Step "scale" (before rectification, so that the up's floor contacts see metres where
    ``--height`` gives them): camera: the camera frame, its joints scaled in place, its root
    scaled; units: the poses' units after scaling; notes; guessed_stature_m: the stature (m)
    a monocular lifter's metres imply where no ``--height`` set the size, else ``None``."""

    camera: CameraFrame
    units: str
    notes: tuple[str, ...]
    guessed_stature_m: float | None = None


@dataclass(frozen=True, eq=False)
class World:
    """The world frame a static camera gives (part of the kinematics step).

    joints: ``(T, 17, 3)`` float64 world-frame poses in the store, or ``None`` without a fixed
    world frame; rotation: ``(3, 3)`` camera-to-world (NaN without); pelvis_path_std: the
    pelvis path's spread in the world frame or ``None``; findings (flags); notes; root_path:
    where the pelvis path came from (:class:`pcnet.pipeline.pelvis_path.PelvisPath` ``kind``)
    and floor: the floor fitted (:class:`pcnet.stages.floor.Floor`), ``None`` without.
    """

    joints: np.ndarray | None
    rotation: np.ndarray
    pelvis_path_std: np.ndarray | None
    findings: tuple[Finding, ...]
    notes: tuple[str, ...]
    root_path: str | None = None
    floor: Floor | None = None

    @property
    def frame(self) -> str:
        """The kinematics frame: "world" or "canonical"."""
        return "world" if self.joints is not None else "canonical"


@dataclass(frozen=True)
class Measured:
    """Step "kinematics": result: what the sinks write (its kinematics are computed a block
    at a time as they read them); outputs: the kinematics tables written; cutoff_hz,
    cutoff_source: the low-pass cutoff (Hz) and where it came from (``"cutoff_hz"`` or
    ``"residual analysis"``); note_lines, angle_ranges, speed_ranges, rate_ranges:
    :class:`RunResult`'s."""

    result: RecordingResult
    outputs: dict[str, Path]
    cutoff_hz: float
    cutoff_source: str
    note_lines: dict[str, str]
    angle_ranges: ColumnRanges | None = None
    speed_ranges: ColumnRanges | None = None
    rate_ranges: ColumnRanges | None = None


def _inputs(cfg: RunConfig, estimate_notes: list[str]) -> AlignedInputs:
    """Read the inputs, refuse a frame rate or units the run cannot use, cut them to a common
    length and read how the video is shown."""
    inputs = _load_inputs(cfg)
    image_size = _image_size(cfg, inputs.video, inputs.keypoint_image_size)
    units, fps, fps_source = inputs.units, inputs.fps, inputs.fps_source
    needing_metres = [name for name, asked in (("--c3d", cfg.c3d), ("--opensim", cfg.opensim)) if asked]
    if needing_metres and units != "m" and cfg.height is None:
        raise InputError(f"{cfg.lifter_output}: {' and '.join(needing_metres)} expected metric poses (a lifter "
                         f"writing metres, or --height), got {units} poses from --lifter {cfg.lifter}")
    if not cfg.residual_cutoff and cfg.lowpass_hz >= fps / 2:
        default = " (the default)" if cfg.cutoff_hz is None else ""
        raise InputError(f"frame rate {fps:g} fps ({fps_source}): expected a Nyquist frequency above the "
                         f"low-pass cutoff {cfg.lowpass_hz:g} Hz{default}, got {fps / 2:g} Hz; give --cutoff-hz "
                         f"below {fps / 2:g} or --residual-cutoff")
    kp2d, joints, aligned = _align(cfg, inputs.video, inputs.keypoints2d, inputs.joints)
    orientation = display_orientation(inputs.video, kp2d, inputs.keypoint_image_size, inputs.keypoint_extent)
    return AlignedInputs(replace(inputs, joints=joints, keypoints2d=kp2d), image_size, orientation,
                         (*estimate_notes, *inputs.notes, *([aligned] if aligned else [])))


def _keypoint_picture(inputs: AlignedInputs) -> tuple[int, int] | None:
    """``(width, height)`` of the picture the displayed-frame 2D keypoints are in: the run's
    image size, unless a video turned a quarter turn left it unknown whether the keypoints
    are in its stored or its displayed frame (:func:`display_orientation`); ``None`` without
    2D keypoints or a size."""
    o = inputs.orientation
    if inputs.recording.keypoints2d is None or inputs.image_size is None:
        return None
    return None if o.rotation_deg in (90, 270) and o.keypoint_frame == "unknown" else inputs.image_size


def _remap(cfg: RunConfig, inputs: AlignedInputs, store: FrameStore) -> CameraFrame:
    """The poses into the camera frame (:func:`_camera_frame`), and the 2D keypoints into the
    video's stored frame where the recording shows them over it."""
    recording, orientation = inputs.recording, inputs.orientation
    notes = [orientation.note] if orientation.note else []
    picture = _keypoint_picture(inputs)
    cam, kp2d, root_cam, pelvis_filled, outside, masked_2d = _camera_frame(
        cfg, recording.joints, recording.keypoints2d, recording.measured_root, store, orientation, picture)
    notes += _masked_2d_notes(masked_2d, len(cam), cfg.min_confidence, cfg.keypoints2d_format)
    video_kp2d = None
    if kp2d is not None and cfg.recording and orientation.recording_note:
        video_kp2d = store.create("keypoints2d_video", kp2d.shape, np.float32)
        for rows in frame_blocks(len(kp2d)):
            video_kp2d[rows] = orientation.recording_pixels(kp2d[rows])
        notes.append(orientation.recording_note)
    if pelvis_filled:
        notes.append(f"pelvis missing in {pelvis_filled} frame{'s' * (pelvis_filled != 1)}: taken as the hip midpoint")
    if outside:
        w, h = picture
        notes.append(f"{outside} joint position{'s' * (outside != 1)} whose 2D keypoint lies outside the {w}x{h} "
                     f"picture taken as missing: the detector placed {'them' if outside != 1 else 'it'} there "
                     f"without seeing {'them' if outside != 1 else 'it'}")
    return CameraFrame(cam, kp2d, video_kp2d, root_cam, pelvis_filled, tuple(notes), picture, outside)


def _refuse_unusable(cfg: RunConfig, camera: CameraFrame, units: str) -> None:
    """Refuse a body said to be in metres that is far too large, and ``--measured-root``
    over a root at the camera (:func:`_check_metric_body`,
    :func:`pcnet.pipeline.rectification.check_measured_root`)."""
    if units == "m" and cfg.height is None:
        _check_metric_body(cfg, camera.joints)
    if camera.root is not None and cfg.lifter_options.get("measured_root"):
        check_measured_root(camera.root, f"{cfg.lifter_output}: --measured-root", "drop --measured-root")


def _track(keypoints2d, fps: float) -> tuple[np.ndarray | None, list]:
    """:func:`pcnet.stages.flags.track_segments` of the run's 2D track (``(None, [])`` without one)."""
    return track_segments(keypoints2d, fps) if keypoints2d is not None else (None, [])


def _keypoint_path(cfg: RunConfig, inputs: AlignedInputs, scaled: Scaled,
                   segment: np.ndarray | None = None) -> PelvisPath | None:
    """The pelvis path fitted to the 2D keypoints before rectification, for the up's floor
    contacts (decision 0044) and the world frame, which reuses it (also where the fit found no
    path: its kind and note say why): in sequence or auto mode, without a measured root, from
    metric poses (the lifter's metres, or ``--height``'s scaling); ``None`` where none was
    fitted (:func:`pcnet.pipeline.pelvis_path.pelvis_path`; ``segment``: the 2D track's
    one-person stretches, each its own path; a track that never switches is one stretch)."""
    recording, camera = inputs.recording, scaled.camera
    if (camera.root is not None or camera.keypoints2d is None or scaled.units != "m"
            or cfg.mode not in ("sequence", "auto")):
        return None
    return pelvis_path(None, camera.joints, camera.keypoints2d,
                       camera_intrinsics(cfg.focal_px, recording.camera_matrix, inputs.image_size),
                       scaled.units, recording.fps, cfg.min_confidence, segment)


def _rectify(cfg: RunConfig, inputs: AlignedInputs, camera: CameraFrame, store: FrameStore,
             track: tuple[np.ndarray | None, list], keypoint_path: PelvisPath | None = None) -> Rectified:
    """Rectify the camera-frame poses (:func:`pcnet.pipeline.rectification.rectify_checked`),
    located by the measured root or else by the path ``keypoint_path`` found (:func:`_keypoint_path`)
    so that sequence mode weighs the floor contacts, and read the camera's tilt; the report gets
    the pelvis fill. ``track``: :func:`_track` of the 2D keypoints."""
    fps = inputs.recording.fps
    root = camera.root
    if root is None and keypoint_path is not None and keypoint_path.kind == "from 2D keypoints":
        root = keypoint_path.camera
    segment, events = track
    # A static camera does not move when the tracker jumps to another person, but the
    # jump and the other body's poses read as camera motion: decide the mode on one
    # person's frames.
    decide_on = _one_person(segment, events)
    layout = inputs.recording.read.get("lifter_layout") or ""
    try:
        res = rectify_checked(_located(camera.joints, root, store), cfg.method, cfg.weights, cfg.mode, fps,
                              cfg.heading, camera_prior=cfg.camera_prior, allocate=store.create, decide_on=decide_on,
                              measured_root=root is not None, posture=cfg.posture, camera_up=_given_up(cfg, inputs),
                              camera_up_interval_deg=_trial_interval(inputs.recording.read))
    except ValueError as err:
        if cfg.weights is not None and str(err).startswith(f"{cfg.weights}:"):
            raise  # the weights file's own error, already naming it
        if str(err).startswith("camera_up:"):  # the given up's own error (a sign flipped), named as given
            raise InputError(f"{field_name(COMMAND_LINE, 'camera_up')}{str(err)[len('camera_up'):]}") from None
        raise InputError(f"{cfg.lifter_output}: {err}{_no_frame_hint(cfg, str(err), camera, layout)}") from err
    if not res.valid.any():
        reason = no_valid_frame_reason(res.report)
        raise InputError(f"{cfg.lifter_output}: {reason}{_no_frame_hint(cfg, reason, camera, layout)}")
    report = replace(res.report, pelvis_from_hips_frames=camera.pelvis_filled)
    # a given up is not refined by anything
    notes = _unused_floor_note(inputs.recording.measured_root, report.sequence.ground_plane
                               if report.sequence is not None and report.sequence.evidence != GIVEN_UP else None)
    notes += given_up_note(report.sequence) if up_was_given(report) else moving_camera_note(report.mode)  # as pose_checks
    notes += _headingless_frames_note(report, camera.joints, res.valid)
    return Rectified(res.rotation, res.canonical, res.valid, report, CameraTilt.of(res.rotation, res.valid),
                     per_frame_tilt(res.rotation, res.valid, report.mode.run), segment, events, tuple(notes))


def _headingless_frames_note(report: RectificationReport, joints, valid: np.ndarray) -> list[str]:
    """A note on sequence mode's frames that had every joint but no canonical pose: their own up
    points more than :data:`pcnet.stages.temporal.HEADING_LIMIT_DEG` from the recording's one
    up, so no heading about it exists (:func:`pcnet.stages.temporal.rotations_about_up`); the
    world frame needs no per-frame heading, so their world poses stay."""
    if report.mode.run != "sequence":
        return []
    dropped = sum(int((np.isfinite(np.asarray(joints[rows])).all(axis=(1, 2)) & ~valid[rows]).sum())
                  for rows in frame_blocks(len(valid)))
    if not dropped:
        return []
    return [f"{frames_phrase(dropped, len(valid))} with every joint have no canonical pose (valid = 0; canonical.npz's "
            f"canonical and rotation NaN there): their own up points more than {HEADING_LIMIT_DEG:.0f} deg from the "
            f"recording's, so no heading about it exists (a body upside down there, or joints in another order than the "
            f"lifter's: --lifter generic --layout); the world-frame poses and kinematics keep them, turned by the "
            f"recording's one rotation"]


def _check_inputs(cfg: RunConfig, inputs: AlignedInputs, camera: CameraFrame, rectified: Rectified,
                  estimated: bool) -> CheckInputs:
    """What :func:`pcnet.pipeline.checks.checks` reads of the steps so far: the scaled camera
    frame, with the lifter's own units (what the scale step moves in the checks:
    :class:`pcnet.pipeline.checks.CheckInputs`); ``estimated``: the poses are the embedded
    estimator's, run on the video alone (``cfg`` then names its saved file as the 2D keypoints)."""
    recording = inputs.recording
    return CheckInputs(
        joints_camera=camera.joints, units=recording.units, keypoints2d=camera.keypoints2d,
        report=rectified.report, tilt=rectified.tilt,
        lifter_turn_deg=recording.lifter_turn_deg, track_segment=rectified.track_segment,
        track_events=rectified.track_events, height_given=cfg.height is not None,
        person_option=cfg.keypoints2d_format in multi_track_formats(),
        own_estimator=estimated, roi_given=cfg.roi is not None,
        focal_known=cfg.focal_px is not None or recording.camera_matrix is not None, picture=camera.picture,
        picture_typed=_picture_typed(cfg), units_declared=cfg.lifter == "generic",
        depth_sensor=recording.depth_sensor)


def _scale(cfg: RunConfig, camera: CameraFrame, units: str, fps: float) -> Scaled:
    """A body keeps its size: image-scaled poses are made constant per frame, then scaled to
    ``--height``; the camera-frame poses are scaled in place. The networks are scale-free
    (models/preprocess.py), so the rotations do not change."""
    cam, root_cam, notes, guessed = camera.joints, camera.root, [], None
    # A body keeps its size; in image units it grows as the person comes closer.
    sizes = None
    if units in IMAGE_SCALED_UNITS:
        try:
            sizes = size_normalising_factors(cam, fps)
        except InputError:  # no frame with legs and head: the size cannot be followed
            notes.append(f"body size left as the lifter's ({units}): no frame has the ankle-to-head chain that "
                         f"measures it")
    if sizes is not None:
        _scaled_in_place(cam, sizes)
        root_cam = None if root_cam is None else root_cam * sizes[:, None]
        change = float(np.max(sizes) / np.min(sizes))
        if change > SIZE_NOTE_RATIO:
            notes.append(f"body size made constant per frame: in the lifter's {units} output it changes "
                         f"{change:.2f}-fold (the person's size in the image; largest to smallest of its "
                         f"running median over {SIZE_WINDOW_S:g} s, stages/scale.py: size_normalising_factors)")
    if cfg.height is not None:
        try:
            factor = height_factor(cam, cfg.height, who=f"{cfg.lifter_output}: --height")
        except InputError as err:
            if root_cam is None:
                raise
            # a trial gave Kinect v1 (no nose joint) a height, which --height's chain cannot measure
            raise InputError(f"{err}; --lifter {cfg.lifter} is a depth sensor's skeleton, in metres already: leave "
                             f"out --height") from None
        _scaled_in_place(cam, factor)
        thigh = thigh_beyond_metres(cam)
        if thigh is not None:  # the stature's share came out of the wrong joints (a developer trial's COCO order)
            raise InputError(f"{cfg.lifter_output}: --height {cfg.height:g}: expected a body whose thigh scales to a "
                             f"person's ({THIGH_RANGE_M[0]}-{THIGH_RANGE_M[1]} m), got {thigh:.3g} m: a joint order "
                             f"other than H36M-17, the order --lifter {cfg.lifter} reads?")
        root_cam = None if root_cam is None else root_cam * factor
        notes.append(f"scaled by {factor:.4g} to a {cfg.height} m subject (from {units}), taking the subject's "
                     f"ankle-to-head chain as H36M's share of stature (an individual's share differs by several "
                     f"per cent, stages/scale.py)")
        units = "m"
    elif units != "m":
        notes.append(f"lifter output is {units}, not metres: give --height for metric kinematics and a TRC file")
    elif camera.root is None:  # a monocular lifter's metres are its guess at the size (a depth sensor's measure it)
        try:
            guessed = 1.0 / height_factor(cam, 1.0)  # the units line states it (RunResult._guessed_size)
        except InputError:  # no frame with the ankle-to-head chain: no stature to state
            pass
    return Scaled(replace(camera, root=root_cam), units, tuple(notes), guessed)


def _world(cfg: RunConfig, inputs: AlignedInputs, scaled: Scaled, rectified: Rectified, store: FrameStore,
           keypoint_path: PelvisPath | None = None) -> World:
    """The fixed world frame of a static camera (sequence mode): the pelvis path (the one
    :func:`_keypoint_path` fitted before rectification, where it ran), the floor and the
    world-frame poses; other modes have none, and say why. Anything differentiated in time
    lives in one fixed frame per recording; only a static camera gives one."""
    cam, fps = scaled.camera.joints, inputs.recording.fps
    mode = rectified.report.mode
    if mode.run == "sequence":
        frame = world_frame(rectified.rotation, rectified.valid, fps)
        if keypoint_path is not None:
            path = keypoint_path
        else:
            path = pelvis_path(scaled.camera.root, cam, scaled.camera.keypoints2d,
                               camera_intrinsics(cfg.focal_px, inputs.recording.camera_matrix, inputs.image_size),
                               scaled.units, fps, cfg.min_confidence, rectified.track_segment)
        joints, floor = to_world_floor(cam, frame, path.camera, out=store.create("joints_world", cam.shape, np.float64),
                                       floor_frames=rectified.one_person())
        # one ground plane for the recording holds in every frame, seen feet or not: only a per-frame
        # floor is interpolated where no ankle shows (a trial's plane run was told so), and noted
        per_frame_floor = floor.kind != "plane"
        return World(joints, frame.rotation, path.world_std(frame.rotation),
                     tuple((floor_flag(feet_visible(cam), present_frames(cam)) if per_frame_floor else [])
                           + (keypoints_unused_flag(path.refused) if path.refused else [])),
                     tuple(n for n in (path.note, floor.note(scaled.units) if per_frame_floor else "") if n),
                     root_path=path.kind, floor=floor)
    if mode.reason == "one valid frame":
        return World(None, np.full((3, 3), np.nan), None, (), (
            "one valid frame: the pose is given in the canonical frame (frame mode); --mode sequence places it in a "
            "world frame with the camera prior",))
    return World(None, np.full((3, 3), np.nan), None, tuple(no_world_frame_flag(mode.run)), ())


def _kinematics(cfg: RunConfig, inputs: AlignedInputs, scaled: Scaled, rectified: Rectified, world: World,
                findings: list[Finding], notes: list[str], store: FrameStore, tmp: Path) -> Measured:
    """The low-pass cutoff, the result the sinks write (kinematics computed a block at a time)
    and its kinematics tables, then the checks of the filtered motion. ``findings``, ``notes``:
    the run's lists, which this step adds to (the sinks add notes; the result carries the
    findings' texts from :func:`_recording` on)."""
    fps, units, cam = inputs.recording.fps, scaled.units, scaled.camera.joints
    # Decision 0100: the network's residual reshaped bodies it rarely trained on (11.6 cm on a
    # prone fixture) and made held-out angles no better, so every mode reads the input turned rigidly.
    rectified_poses = world.joints if world.joints is not None else \
        to_canonical(cam, rectified.rotation, out=store.create("poses_canonical", cam.shape, np.float32))
    # Decision 0102: without a world frame, the camera-frame poses and the per-frame rotations are
    # low-passed apart and then composed, so the rotations' noise never reaches angles between segments.
    filtered, turn = (world.joints, None) if world.joints is not None else (cam, rectified.rotation)
    cutoff = cfg.lowpass_hz
    if cfg.residual_cutoff:
        try:
            # Winter's residual analysis filters every coordinate whole: the one step
            # that reads the poses into memory (opt-in).
            poses = filtered[:]
            analysis = residual_analysis(poses if turn is None else poses - poses[:, PELVIS:PELVIS + 1], fps)
        except InputError as err:
            raise InputError(f"{cfg.lifter_output}: {err}") from err
        cutoff = analysis.cutoff_hz
        notes.append(f"low-pass cutoff {cutoff:.2f} Hz by residual analysis (Winter; noise {analysis.noise:.3g} "
                     f"{units}; per-coordinate cutoffs {np.nanpercentile(analysis.per_signal_hz, 10):.1f}-"
                     f"{np.nanpercentile(analysis.per_signal_hz, 90):.1f} Hz, 10th-90th percentile)")
    # Camera-frame wrist accelerations only feed the before/after wrist plot: two joints,
    # small enough to filter whole, and no angles to compute.
    acc_cam = filtered_derivatives(cam[:, [H36M_JOINTS.index(n) for n in WRISTS]], fps, cutoff)[3]
    result = RecordingResult(
        fps=fps, units=units, method=cfg.method, rectification=rectified.report, flags=[], notes=notes,
        joints_camera=cam, root_path=world.root_path, floor_kind=world.floor.kind if world.floor else None,
        rotation=rectified.rotation, canonical=rectified.canonical, valid=rectified.valid,
        kinematics_frame=world.frame, poses=rectified_poses, world=world.joints, world_rotation=world.rotation,
        keypoints2d=scaled.camera.keypoints2d, track_segment=rectified.track_segment, video=cfg.video,
        video_first_frame=first_shown_frame(cfg.video) if cfg.video and cfg.recording else 0,
        video_keypoints2d=scaled.camera.video_keypoints2d, keypoint_picture=scaled.camera.picture,
        min_confidence=cfg.min_confidence, wrist_acceleration_camera=acc_cam, pelvis_path_std=world.pelvis_path_std,
        subject_height_m=float("nan") if cfg.height is None else float(cfg.height))
    # rectification put the poses up (a body inverted for most of a take is read as such)
    # the lifter's restarts (MotionBERT's clip seams) end the filter's stretches as a recording's ends do
    breaks = tuple(b for b in inputs.recording.breaks if b < len(cam))
    if breaks:
        notes.append(_breaks_note(breaks, cfg.lifter))
    result.kinematics_blocks = kinematics_chunks(filtered, fps, cutoff, units, rotation=turn, check_up=False,
                                                 breaks=breaks)
    if _spine_built_on_trunk_line(cam):  # the kinematics leave that angle empty, not 0: say why
        why = ("the input's spine joint lies on the pelvis-thorax line (built there, no spine of its own), so that "
               "angle is 0 by construction")
        result.empty_angles = {name.removesuffix("_deg"): why for name in NEEDS_SPINE_JOINT}
        notes.append(f"{', '.join(NEEDS_SPINE_JOINT)} left empty: {why}")
    # motion no person makes (joint speeds and accelerations beyond the fitted limits): before
    # the table, whose implausible_motion column marks its frames
    unchecked = motion_check_note(units, fps)
    if unchecked:
        notes.append(unchecked)
    else:
        # pelvis-relative motion in a fixed frame: the per-frame canonical frame adds its rotations' noise
        implausible = implausible_motion(filtered, fps, units=units, breaks=breaks)
        result.implausible_frames = implausible_frames(implausible, len(cam))
        # a rate typed with --fps and no video or file to check it against is the likeliest cause
        findings += implausible_motion_findings(implausible, fps_typed=fps_unchecked(inputs.recording.fps_source))
    table = write_kinematics_table(result, tmp, allocate=store.create)
    findings += unfiltered_flag(result.missing, result.unfiltered, fps, cutoff) + absent_joints_flag(result.missing)
    # what is missing, and what of it the lifter's file held as inf/NaN (counted where it was read)
    nonfinite = inputs.recording.nonfinite
    missing_note = format_flag_counts(result.flag_counts, nonfinite_line(nonfinite))
    note_lines = {}
    if missing_note:
        notes.append(missing_note)
        note_lines[missing_note] = missing_data_line(result.flag_counts, nonfinite)
    notes += _headingless_note(result.kinematics.angles, result.kinematics.positions)
    k, left_out = result.kinematics, (result.implausible_frames, other_persons_frames(result))
    angles = column_ranges({f"{name}_deg": values for name, values in k.angles.items()}, "deg", fps, *left_out)
    speeds = column_ranges({f"{joint}_speed_{unit_token(k.velocity_units)}": k.speed[:, i]
                            for i, joint in enumerate(k.joint_names)}, k.velocity_units, fps, *left_out)
    rates = column_ranges({f"{name}_deg_per_s": values for name, values in k.angle_rates.items()}, "deg/s", fps,
                          *left_out)
    return Measured(result, table, cutoff, "residual analysis" if cfg.residual_cutoff else "cutoff_hz", note_lines,
                    angles, speeds, rates)


def _breaks_note(breaks: tuple[int, ...], lifter: str) -> str:
    """The note for a lifter's restarts (:attr:`pcnet.adapters.Poses3D.breaks`)."""
    shown = ", ".join(map(str, breaks[:4])) + (", ..." if len(breaks) > 4 else "")
    return (f"{lifter} restarts at frame{'s' * (len(breaks) > 1)} {shown} (each clip lifted on its own), where the "
            f"pose may jump: filtered, speeds and rates taken on each side apart, none across")


def _run_report(inputs: AlignedInputs, rectified: Rectified, world: World, measured: Measured) -> RunReport:
    """The run's report from what the steps decided and measured."""
    implausible = measured.result.implausible_frames
    return RunReport(
        rectification=rectified.report, tilt=rectified.tilt,
        # sequence mode's frames share its one up: no spread to give
        tilt_per_frame_deg=rectified.tilt_per_frame_deg,
        display_rotation=inputs.orientation.report() if inputs.orientation.note else None,
        kinematics_frame=world.frame, root_path=world.root_path, floor=world.floor, cutoff_hz=measured.cutoff_hz,
        cutoff_source=measured.cutoff_source, implausible_frames=None if implausible is None else int(implausible.sum()),
        inputs=inputs.recording.read)


def _exports(cfg: RunConfig, measured: Measured, findings: list[Finding], tmp: Path,
             store: FrameStore) -> dict[str, Path]:
    """The motion files, OpenSim's fit where asked (before the recording and the npz, which
    carry its warning; added to ``findings``) and the figures; with the kinematics tables, the
    files written."""
    result = measured.result
    motion = write_motion_files(result, tmp, c3d=cfg.c3d, allocate=store.create, software=f"pcnet {pcnet_version()}")
    outputs = {**measured.outputs, **motion}
    _trim_heap()
    if cfg.opensim:
        outputs.update(_opensim(cfg, tmp, findings, result.notes))
    if cfg.plots:  # a batch of short recordings spent half its output time on them (a scale trial)
        outputs.update(write_figures(result, tmp))
    return outputs


def _recording(cfg: RunConfig, result: RecordingResult, findings: list[Finding], tmp: Path,
               estimated: bool) -> dict[str, Path]:
    """The rerun recording where asked, then canonical.npz (last: the notes every sink added are
    in it), and the estimator's poses when the run made them (for a re-run). Both keep the
    ``findings``' full texts: canonical.npz as raised, the recording most severe first."""
    result.flags = [f.detail for f in findings]
    # the viewer's document as the summary orders them, most severe first, each with its action
    # (a user trial: the track switch came second, after a focal-length check)
    shown = [f"**{f.severity.name.lower()}**: {f.detail} (action: {f.action})" for f in ranked(findings)]
    outputs = write_rerun(result, tmp, shown) if cfg.recording else {}
    outputs.update(write_arrays(result, tmp))
    if estimated:
        outputs[Path(cfg.lifter_output).name] = Path(cfg.lifter_output)
    return outputs


@contextmanager
def _estimate_named_by_its_video(staged_file: Path, video: str | None):
    """A refusal that names the embedded estimator's staged poses (``staged_file``, gone once the
    run fails) names the video they came from instead: a user trial's region without a person
    was refused for a file in a hidden folder that no longer existed."""
    try:
        yield
    except InputError as err:
        if video is None or str(staged_file) not in str(err):
            raise
        raise InputError(str(err).replace(str(staged_file), f"the poses the embedded estimator found in {video}")) \
            from err


def _check_video_before_estimating(cfg: RunConfig) -> None:
    """What a video alone can be refused for before the embedded estimator spends its time on
    every frame: ``--fps`` contradicting the video's rate, ``--focal-px`` shorter than any
    lens's on its frames (a coach's trial waited 10 s for the first, 20 s for the second).

    Raises:
        InputError: as :func:`_frame_rate` and :func:`camera_intrinsics`.
    """
    video = probe_video(cfg.video)
    _frame_rate(cfg, video)
    camera_intrinsics(cfg.focal_px, None, (video.width, video.height))


def _run_stages(cfg: RunConfig, out: Path, bar, before_publish=None) -> RunResult:
    seconds: dict[str, float] = {}
    clock = [time.perf_counter(), None]

    def step(name: str) -> None:
        now = time.perf_counter()
        if clock[1] is not None:
            seconds[clock[1]] = now - clock[0]
        clock[:] = [now, name]
        bar.set_postfix_str(name)
        _trim_heap()

    # Whole-recording pose arrays live in a store in the staged output folder and are read a
    # block of frames at a time, so memory does not grow with the recording's length; the
    # store is removed before the folder is swapped in.
    left: list[str] = []  # the earlier output's files that replacing it could not remove
    with staged_output(out, cfg.overwrite, left) as tmp, FrameStore(tmp) as store, \
            _estimate_named_by_its_video(tmp / ESTIMATE_FILE, cfg.video):
        estimate_notes = []
        if cfg.lifter_output is None:  # the video alone: the embedded estimator's poses, kept with the outputs
            _check_video_before_estimating(cfg)
            step("estimate")
            cfg, note = estimated_inputs(cfg, tmp, progress=not bar.disable)
            estimate_notes.append(note)
            bar.update()
        step("inputs")
        inputs = _inputs(cfg, estimate_notes)
        if estimate_notes:  # the estimator's file is read from the staged folder, published as `out`
            from pcnet.models.pose_estimator import estimator_record  # OpenCV's import: only for a video run

            read = {**_published(inputs.recording.read, tmp, out), "pose_estimator": estimator_record()}
            inputs = replace(inputs, recording=replace(inputs.recording, read=read))
        bar.update()

        step("remap")
        camera = _remap(cfg, inputs, store)
        inputs = inputs.without_poses()  # the long input arrays: only the camera frame's live on
        _refuse_unusable(cfg, camera, inputs.recording.units)
        bar.update()

        step("scale")
        scaled = _scale(cfg, camera, inputs.recording.units, inputs.recording.fps)
        del camera  # its root is scaled in scaled.camera
        bar.update()

        step("rectify")
        track = _track(scaled.camera.keypoints2d, inputs.recording.fps)
        keypoint_path = _keypoint_path(cfg, inputs, scaled, track[0])
        rectified = _rectify(cfg, inputs, scaled.camera, store, track, keypoint_path)
        findings = checks(_check_inputs(cfg, inputs, scaled.camera, rectified, estimated=bool(estimate_notes)))
        bar.update()

        step("kinematics")
        world = _world(cfg, inputs, scaled, rectified, store, keypoint_path)
        findings += world.findings
        # the rotations on disk: only the sinks read them from here on
        rectified = replace(rectified, rotation=_moved_to_disk(rectified.rotation, "rotation", store))
        notes = [*inputs.notes, *scaled.camera.notes, *rectified.notes, *scaled.notes, *world.notes]
        measured = _kinematics(cfg, inputs, scaled, rectified, world, findings, notes, store, tmp)
        report = _run_report(inputs, rectified, world, measured)
        measured.result.report = report.as_record()
        bar.update()

        step("exports")
        outputs = _exports(cfg, measured, findings, tmp, store)
        bar.update()

        step("recording")
        outputs.update(_recording(cfg, measured.result, findings, tmp, estimated=bool(estimate_notes)))
        bar.update()
        step("done")
        run = RunResult(
            frames=len(scaled.camera.joints), valid_frames=int(rectified.valid.sum()), units=scaled.units,
            method=cfg.method, findings=findings, fps=inputs.recording.fps,
            fps_source=inputs.recording.fps_source, report=report,
            outputs={k: out / v.name for k, v in outputs.items()}, notes=notes, seconds=seconds,
            note_lines=measured.note_lines, angle_ranges=measured.angle_ranges,
            speed_ranges=measured.speed_ranges, rate_ranges=measured.rate_ranges,
            guessed_stature_m=scaled.guessed_stature_m,
        )
        # the long form of the summary, published with the rest
        run.outputs[REPORT_NAME] = out / next(iter(write_report(tmp, run.report_text(f"pcnet run: {out}")).values())).name
        if before_publish is not None:
            before_publish(tmp, run)
    run.notes += left
    return run
