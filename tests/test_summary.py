"""The run summary reads in seconds (issue 52): one line per finding, most severe first, each
with its one action; the full text in the output folder's report.md."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from conftest import FIXTURES, camera_up, run_report, sequence_up

from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import RunResult, run_pipeline
from pcnet.stages.flags import (HEADLINE_WIDTH, Finding, Kind, Severity, absent_joints_flag, body_size_flag,
                               given_up_flag,
                                ensemble_weights_flag,
                                floor_flag, implausible_motion_findings, keypoints_outside_image_flag,
                                keypoints_unused_flag, leg_asymmetry_flag, lifter_frame_flag, limb_proportions_flag,
                                missing_data_line,
                                mirrored_skeleton_flag, no_opensim_flag,
                                no_world_frame_flag, note_finding, opensim_fit_findings,
                                orientation_flags, posture_flag, ranked, shortened, side_swap_flag, size_change_flag,
                                track_segments, track_switch_flag, unfiltered_flag)
from pcnet.stages.kinematics import format_flag_counts
from pcnet.stages.opensim_ik import ik_fit_flags
from pcnet.stages.plausibility import ImplausibleMotion
from pcnet.stages.rectification_report import EnsembleWeights, PostureHypotheses
from pcnet.stages.remap import remap_to_h36m
from pcnet.stages.sinks.report import REPORT_NAME

MEDIAPIPE = FIXTURES / "mediapipe_blazepose33_f000-059.npz"  # real Sports2D MediaPipe, 60 frames
BOX_X3D = FIXTURES / "boxing_X3D_f000-059.npy"  # real MotionBERT output of the boxing demo
#: A summary line of a finding or note fits a terminal this wide.
LINE_WIDTH = 135


def _switched_track() -> tuple[np.ndarray, np.ndarray]:
    """The real MediaPipe fixture's 2D keypoints with the tracker jumping 600 px right at frame 30."""
    with np.load(MEDIAPIPE) as d:
        kp = remap_to_h36m(d["keypoints_2d"].astype(np.float32), "blazepose33", confidence_channel=True)
    kp[30:, :, 0] += 600.0
    return kp, float(30)


def _flags() -> list[Finding]:
    """Real flags of several kinds and severities, the track switch not first."""
    kp, fps = _switched_track()
    segment, events = track_segments(kp, fps)
    present = np.ones(60, bool)
    feet = present.copy()
    feet[:3] = False
    return (lifter_frame_flag(15.5, 8.6) + floor_flag(feet, present) + leg_asymmetry_flag(np.load(BOX_X3D))
            + track_switch_flag(segment, events, person_option=False))


def _every_kind() -> list[Finding]:
    """One finding of every :class:`Kind`, each from the function that raises it."""
    box = np.load(BOX_X3D)
    fit = {"marker_rms_m": 0.049, "marker_max_m": 0.172, "segments_not_scaled": ["head"], "markers_left_out": ["NOSE"]}
    kp, _ = _switched_track()
    return (_flags() + orientation_flags(120.0) + orientation_flags(50.0, 50.0, 0.0)
            + orientation_flags(90.0, 0.0, 90.0) + body_size_flag(box * 100, "m")
            + posture_flag(sequence_up(PostureHypotheses("lying", 0.9, camera_up(0.0, 80.0))))
            + posture_flag(sequence_up(PostureHypotheses("upright", 0.2, camera_up(0.0, 70.0))))
            + ensemble_weights_flag(EnsembleWeights(0.8, 5, 10, 100, {"90": 30, "270": 0}))
            + unfiltered_flag(np.zeros((5, 17), bool), np.ones((5, 17), bool), 30.0, 6.0)
            + absent_joints_flag(np.eye(17, dtype=bool)[[5] * 5])
            + floor_flag(np.zeros(5, bool), np.ones(5, bool))
            + implausible_motion_findings([ImplausibleMotion("right_wrist", "speed", 60, 70, 14.9, 68, 8.18, "m/s"),
                                           ImplausibleMotion("left_ankle", "acceleration", 61, 63, 399.0, 62, 141.0,
                                                             "m/s^2")])
            + size_change_flag(box * np.linspace(1.0, 3.0, len(box))[:, None, None])
            + limb_proportions_flag(np.load(FIXTURES / "yoga_Veena_Vrikshasana_f000-099.npy"))
            + mirrored_skeleton_flag(box * np.array([1.0, 1.0, -1.0]))
            + side_swap_flag(kp, kp[:, [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]])
            + keypoints_outside_image_flag(kp, (100, 100))
            + keypoints_unused_flag("root path: no frame could be fitted (of 60, some with 17 usable joints)")
            + no_world_frame_flag("smooth") + no_opensim_flag()
            + opensim_fit_findings({**fit, "warnings": ik_fit_flags(fit)})
            + given_up_flag(_given_level_up()))


def _given_level_up():
    """The sequence up of a real recording whose camera looks 19 deg up, given a level camera's."""
    from pcnet.pipeline import rectify

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")
    return rectify(joints, mode="sequence", fps=30.0, camera_up=(0.0, -1.0, 0.0)).report.sequence


def test_every_flag_function_says_its_kind_with_numbers_in_its_headline():
    """Each flag function builds its own findings: a declared kind, a severity above a note's,
    a headline whose numbers are the full text's own, and the one action it asks."""
    findings = _every_kind()
    assert {f.kind for f in findings} == set(Kind)  # every declared kind is raised somewhere
    for f in findings:
        assert f.severity > Severity.INFO and f.action and f.action != "see report.md", f
        assert len(f.headline) <= HEADLINE_WIDTH and f.detail
        numbers = re.findall(r"\d+", f.headline)
        assert all(n in f.detail for n in numbers), (f.headline, f.detail)  # its numbers are the flag's own


def test_findings_about_some_frames_name_them():
    """The flags about some frames carry them as [start, stop) ranges; the others None."""
    kp, fps = _switched_track()
    (switch,) = track_switch_flag(*track_segments(kp, fps))
    assert switch.kind == Kind.TRACK_SWITCH and switch.frames == ((30, 60),)  # probably someone else
    feet = np.ones(60, bool)
    feet[:3] = feet[40:45] = False
    assert floor_flag(feet, np.ones(60, bool))[0].frames == ((0, 3), (40, 45))
    (speed,) = implausible_motion_findings([ImplausibleMotion("right_wrist", "speed", 60, 70, 14.9, 68, 8.18, "m/s"),
                                            ImplausibleMotion("left_wrist", "speed", 71, 72, 9.0, 71, 8.18, "m/s")])
    assert speed.frames == ((60, 73),) and speed.headline.startswith("implausible speed in frames 60-72: right wrist")
    assert speed.action == "leave those frames out (implausible_motion = 1)"
    # a frame rate typed with --fps alone is checked first (a user trial's 120 for a 30 fps file)
    (typed,) = implausible_motion_findings([ImplausibleMotion("right_wrist", "speed", 60, 70, 14.9, 68, 8.18, "m/s")],
                                           fps_typed=True)
    assert typed.action == ("check --fps if the speeds are high throughout, else leave those frames out "
                            "(implausible_motion = 1)")
    assert floor_flag(np.zeros(5, bool), np.ones(5, bool))[0].frames is None  # the whole recording
    assert lifter_frame_flag(15.5, 8.6)[0].frames is None


def test_findings_are_ranked_by_severity_track_switch_first():
    findings = ranked(_flags())
    assert [f.severity for f in findings] == sorted((f.severity for f in findings), reverse=True)
    assert findings[0].headline.startswith("2D track switches person at frame 30")
    assert findings[0].severity == Severity.PROBLEM and "track one person" in findings[0].action
    # within a severity, Kind's declared order: the lifter turn before the partial floor, though given after
    check = [f.headline.split()[0] for f in findings if f.severity == Severity.CHECK]
    assert check == ["lifter", "lifter's", "no"]
    assert ranked([Finding(Severity.INFO, "a", "", "a"), Finding(Severity.PROBLEM, "b", "x", "b")])[0].headline == "b"
    # the declared kind orders, not the text: a finding of no kind comes last within its severity
    unknown = Finding(Severity.CHECK, "2D track probably switches person", "x", "2D track probably switches person")
    assert ranked([unknown, *findings])[-1] is unknown


def test_unknown_texts_are_shortened_to_one_line_keeping_the_first_clauses():
    text = ("pelvis path from the 2D keypoints (focal length 1219 px assumed (a phone's 26 mm equivalent)): 219 of "
            "230 frames, depth 1-sigma median 0.21 m; 47 frames rejected as outliers; held at its first position")
    short = shortened(text)
    assert short.startswith("pelvis path from the 2D keypoints: 219 of 230 frames") and len(short) <= HEADLINE_WIDTH
    assert "(" not in short
    assert note_finding(text).headline == short
    # without "; " or ": " where a cut may fall, a note ends at a whole clause, not mid-phrase
    # (a user trial read "taking the subject's ankle-to-head chain as H36M's share...")
    scaled = ("scaled by 0.8458 to a 1.75 m subject (from normalised), taking the subject's ankle-to-head chain as "
              "H36M's share of stature (an individual's share differs by several per cent, stages/scale.py)")
    assert shortened(scaled) == "scaled by 0.8458 to a 1.75 m subject..."  # "..." as a ", " may split a list
    assert note_finding("a short note") == Finding(Severity.INFO, "a short note", "", "a short note")
    fit = {"marker_rms_m": 0.01, "marker_max_m": 0.02, "warnings": ["something new happened: " + "x " * 80]}
    (new,) = opensim_fit_findings(fit)  # a text of no known kind stays a warning, shortened
    assert new.kind is None and new.action == "see report.md" and len(new.headline) <= HEADLINE_WIDTH


def test_summary_prints_one_line_per_finding_and_points_to_the_report():
    flags = _flags()
    counts = {"missing_with_pose": {"right_knee": 3, "left_elbow": 74, "left_wrist": 36}, "frames_without_pose": 8,
              "unfiltered": {}}
    missing = format_flag_counts(counts)
    # the summary's line says how much of the recording the worst joint lacks, where it knows the length
    assert missing_data_line({**counts, "frames": 120}, {}).startswith("missing: 3 joints (most: left_elbow 74 of 120 frames)")
    notes = [missing,
             "world.bvh: 94 of 230 frames had missing joints or no place (no fitted pelvis path), filled by linear "
             "interpolation in time, held at the ends (BVH cannot hold NaN; the CSV, TRC and npz keep them missing)"]
    result = RunResult(frames=60, valid_frames=57, units="m", method="pcnet", fps=30.0, fps_source="--fps", findings=flags,
                       notes=notes, note_lines={missing: missing_data_line(counts, {})},
                       report=run_report("auto", "sequence", intervals_deg=(8.6, 3.5)),
                       outputs={"canonical.npz": FIXTURES / "o" / "canonical.npz", REPORT_NAME: FIXTURES / "o" / REPORT_NAME})
    lines = result.summary().splitlines()
    warnings = [ln for ln in lines if ln.startswith("WARNING")]
    assert len(warnings) == len(flags) and warnings[0].startswith("WARNING  2D track switches person")
    assert all(" -> " in ln for ln in warnings)
    assert [ln for ln in lines if ln.startswith("note")] == [
        "note     missing: 3 joints (most: left_elbow 74 frames); no joint at all: 8 frames",
        "note     world.bvh: 94 of 230 frames had missing joints or no place..."]
    assert all(len(ln) <= LINE_WIDTH for ln in warnings + lines[:6]), max(lines, key=len)
    assert lines[-1] == f"details: {FIXTURES / 'o' / REPORT_NAME}" and "report.md  " not in result.summary()
    # the posture read either way (a physiotherapist's trial found "upright" said nowhere); no
    # direction for a pitch its interval holds both ways of (a docs trial: "looking up" at -0.2 +- 6.9)
    assert ("camera tilt       8.8 deg from level (pitch +8.6 +- 8.6, roll +2.0 +- 3.5 deg; 95 % interval, body read "
            "upright)") in lines
    report = result.report_text()
    assert result.flags == [f.detail for f in flags] and all(text in report for text in result.flags + notes)
    assert report.index("2D track probably switches") < report.index("the lifter's output was turned")
    assert "95 % posterior interval per axis (up model, docs/up_model.md)" in report  # the long tilt line
    # a clinician trial read "12 without a valid pose" against "a person in 221 of 230 frames"
    assert "3 without a valid pose: kept as NaN rows, valid = 0; a pose needs the pelvis, both hips, the thorax " \
           "and both shoulders" in report


def test_intervals_are_not_called_95_percent_where_the_per_frame_ups_spread_beyond_a_static_camera():
    """Sequence mode's intervals are calibrated on static validation cameras, none of which
    spread beyond the threshold: beyond it (the moving-camera note fires) the tilt line says the
    interval is not calibrated, short and long (decision 0090; a user trial's static Tadasana
    windows read 19 deg with a "95 %" interval of +- 7 that missed)."""
    from pcnet.stages.temporal import MODE_THRESHOLD_DEG

    def tilt_lines(spread):
        result = RunResult(frames=60, valid_frames=60, units="m", method="pcnet", fps=30.0, fps_source="--fps",
                           findings=[], notes=[], outputs={},
                           report=run_report("sequence", "sequence", spread_deg=spread, intervals_deg=(8.6, 3.5)))
        short = [ln for ln in result.summary().splitlines() if ln.startswith("camera tilt")]
        return short[0], result.report_text()

    short, report = tilt_lines(MODE_THRESHOLD_DEG + 1.0)
    assert short.endswith("deg; interval not calibrated: ups spread wide)") and len(short) <= LINE_WIDTH, short
    assert "95 %" not in short
    assert "posterior interval per axis, not calibrated for this recording: its per-frame ups spread beyond any " \
        "static camera's of the validation data" in report and "95 % posterior interval per axis" not in report
    short, report = tilt_lines(MODE_THRESHOLD_DEG - 1.0)
    assert short.endswith("deg; 95 % interval, body read upright)") and "not calibrated" not in report


def test_the_rectification_line_names_weights_that_are_not_the_shipped_ones():
    """A user trial's own network read "rectification     pcnet, mode sequence", as the shipped
    pair does; the line now names the weights' file."""
    import dataclasses

    def line(weights):
        report = dataclasses.replace(run_report("sequence", "sequence"), inputs={"method": "pcnet", "weights": weights})
        result = RunResult(frames=60, valid_frames=60, units="m", method="pcnet", fps=30.0, fps_source="--fps",
                           findings=[], notes=[], outputs={}, report=report)
        return next(ln for ln in result.summary().splitlines() if ln.startswith("rectification"))

    assert line("/tmp/runs/my_camera.onnx").startswith("rectification     pcnet (my_camera.onnx weights), mode sequence")
    assert line("shipped").startswith("rectification     pcnet, mode sequence")


@pytest.mark.slow
def test_a_run_publishes_report_md_with_every_flag_and_note_in_full(tmp_path):
    """The real 60-frame Sports2D fixture with its 2D track made to jump at frame 30: the
    summary's first warning is the switch, and report.md (published with the outputs, so a
    re-run with --overwrite still owns the folder) holds every flag and note in full."""
    with np.load(MEDIAPIPE) as d:
        arrays = dict(d)
    arrays["keypoints_2d"][30:, :, 0] += 600.0
    src = tmp_path / "switched.npz"
    np.savez(src, **arrays)
    cfg = RunConfig(lifter="mediapipe", lifter_output=str(src), keypoints2d=str(src), keypoints2d_format="mediapipe",
                    method="geometric", recording=False, out=str(tmp_path / "out"), overwrite=True)
    result = run_pipeline(cfg, progress=False)
    lines = result.summary().splitlines()
    warnings = [ln for ln in lines if ln.startswith("WARNING")]
    assert warnings[0].startswith("WARNING  2D track switches at frame 30; followed the person at the "), warnings
    assert all(len(ln) <= LINE_WIDTH for ln in lines if ln.startswith(("WARNING", "note"))), lines
    assert lines[-1] == f"details: {tmp_path / 'out' / 'report.md'}"
    report = (tmp_path / "out" / "report.md").read_text()
    with np.load(tmp_path / "out" / "canonical.npz") as npz:
        flags, notes = list(npz["flags"]), list(npz["notes"])
    assert flags and notes and all(text in report for text in flags + notes)
    assert len(flags) == len(warnings) and report.count("\n### ") == len(flags)
    # every number of the report is in its table, one not defined (JSON null) as n/a (a
    # data-dictionary trial missed a null from the table that says it lists them all)
    with np.load(tmp_path / "out" / "canonical.npz") as npz:
        record = json.loads(npz["report"].item())
    undefined = [k for k, v in record.items() if v is None]
    assert undefined and all(f"| {k} | n/a |" in report for k in undefined), undefined
    # the joint angles' ranges and speeds' peaks leave out the other person's frames, as the switch's warning asks
    from pcnet.stages.flags import one_person_frames

    with np.load(tmp_path / "out" / "canonical.npz") as npz:
        segment = npz["track_segment"]
    tracked = np.isfinite(segment)
    other = int((tracked & ~one_person_frames(np.where(tracked, segment, 0).astype(int))).sum())
    assert other >= 27 and result.angle_ranges.other_person_frames == other
    assert (f"the {other} frames outside the 2D track's longest one-person stretch (the track-switch "
            f"warning's)") in report
    for ranges in (result.angle_ranges, result.speed_ranges):  # the joint speeds' peaks too
        assert ranges.other_person_frames == other and ranges.rows
        assert all(r.frames <= 60 - other for r in ranges.rows)
    # the trunk's lean is a key fact, the angle table's median (a clinic trial found it at rows 19-20 of 36);
    # the geometric method has no calibrated interval, so no "+-" (a clinic trial read a bootstrap's +-0.1 as sure)
    medians = {r.name: r.median for r in result.angle_ranges.rows}
    trunk = next(ln for ln in lines if ln.startswith("trunk lean "))
    assert trunk == (f"trunk lean        {medians['trunk_inclination_deg']:.1f} deg from vertical (pelvis-thorax line, "
                     f"median; no calibrated uncertainty in this mode or method)"), trunk
    # report.md adds its direction both ways, which part in a side bend (a clinic trial's Trikonasana)
    assert (f"forward {medians['trunk_sagittal_inclination_deg']:+.1f}, to the right "
            f"{medians['trunk_frontal_inclination_deg']:+.1f} in the pelvis's planes; forward "
            f"{medians['trunk_flexion_to_gravity_deg']:+.1f}, to the right "
            f"{medians['trunk_lateral_tilt_to_gravity_deg']:+.1f} in the thorax's") in report
    run_pipeline(cfg, progress=False)  # the folder, report.md included, is pcnet's own: --overwrite replaces it



def test_the_per_frame_tilt_spread_is_recorded_only_where_frames_have_their_own_up():
    # sequence mode's frames share its one up: three equal numbers would read as perfect agreement
    assert "camera_tilt_per_frame_deg" not in run_report("sequence", "sequence").as_record()
    assert run_report("smooth", "smooth").as_record()["camera_tilt_per_frame_deg"] == [8.0, 7.0, 9.0]


def test_frames_left_out_with_every_joint_are_explained():
    """Sequence mode leaves out a frame whose own up points more than 143 deg from the
    recording's (no heading about it): a user trial saw "842 without a valid pose" and no
    reason (joints in another order than the lifter's). Frames missing joints are the
    missing-data note's, not this one's."""
    from pcnet.pipeline.runner import _headingless_frames_note

    joints = np.load(BOX_X3D)[:10].astype(np.float64)
    joints[0, 3] = np.nan
    valid = np.ones(10, bool)
    valid[[0, 4, 5]] = False
    (note,) = _headingless_frames_note(run_report("sequence", "sequence").rectification, joints, valid)
    assert note.startswith("2 of 10 frames with every joint have no canonical pose") and "--layout" in note
    assert "world-frame poses and kinematics keep them" in note  # a user trial read "NaN rows" beside finite CSV rows
    assert _headingless_frames_note(run_report("frame", "frame").rectification, joints, valid) == []
    assert _headingless_frames_note(run_report("sequence", "sequence").rectification, joints, np.ones(10, bool)) == []


def test_a_recording_shorter_than_the_spreads_low_pass_says_its_drift_is_not_measured():
    """The per-frame ups' spread reads their slow drift through a 0.25 s low-pass: an 11-frame
    (0.18 s) lab trial printed "per-frame ups 0.0 deg from their own mean" whatever its ups did
    (a multi-camera trial read it as the networks agreeing perfectly). Shorter than the
    low-pass, the line says the drift is not measured; a longer recording keeps the number."""
    from pcnet.stages.temporal import MODE_SMOOTHING_S

    def rectification_lines(frames: int, fps: float) -> tuple[str, str]:
        result = RunResult(frames=frames, valid_frames=frames, units="m", method="pcnet", fps=fps, fps_source="--fps",
                           findings=[], notes=[], outputs={},
                           report=run_report("sequence", "sequence", spread_deg=0.0, intervals_deg=(7.7, 5.7)))
        short = next(ln for ln in result.summary().splitlines() if ln.startswith("rectification"))
        return short, result.report_text()

    short, report = rectification_lines(11, 60.0)
    assert f"per-frame ups' drift unmeasured in 0.18 s (low-pass {MODE_SMOOTHING_S:g} s)" in short, short
    assert len(short) <= LINE_WIDTH and "0.0 deg" not in short
    assert "the per-frame ups' drift not measured: 0.18 s of poses, shorter than the" in report
    short, _ = rectification_lines(60, 60.0)  # 1 s: the spread is read
    assert "per-frame ups 0.0 deg from their own mean" in short and "unmeasured" not in short
