"""``report.md``: the long form of a run's summary (docs/outputs.md).

The terminal summary gives each finding one line (:class:`pcnet.stages.flags.Finding`'s
headline and action); this file keeps what the lines leave out: every finding's full text
in the summary's order, every note in full, the key facts in their long form, each joint
angle's and joint speed's range (:mod:`pcnet.stages.column_ranges`) and the rectification report's scalar
numbers.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path

from ..core.atomic import write_text
from ..column_ranges import ColumnRanges
from ..flags import Finding
from ..rectification_report import GIVEN_UP

REPORT_NAME = "report.md"


def _value(v) -> str:
    if isinstance(v, float):
        return "n/a" if not math.isfinite(v) else f"{v:.4g}"
    return str(v)


def _scalars(report: Mapping, prefix: str = "") -> list[tuple[str, str]]:
    """``(key, value)`` of the report's numbers, strings and booleans, nested dictionaries'
    keys joined with dots; lists of up to 3 numbers as one row, longer ones left out; a value
    that is not defined (``None``, the JSON's ``null``) as ``n/a``, as a NaN is (a
    data-dictionary trial missed ``interval_reaches_other_posture_p`` from the table)."""
    rows = []
    for key, v in report.items():
        name = f"{prefix}{key}"
        if isinstance(v, Mapping):
            rows += _scalars(v, name + ".")
        elif v is None:
            rows.append((name, "n/a"))
        elif isinstance(v, (bool, int, float, str)) and not hasattr(v, "shape"):
            rows.append((name, _value(v)))
        elif isinstance(v, (list, tuple)) and len(v) <= 3 and all(isinstance(x, (int, float)) for x in v):
            rows.append((name, ", ".join(_value(float(x)) for x in v)))
        elif hasattr(v, "shape") and getattr(v, "size", 99) <= 3:  # a small numpy array or scalar
            rows.append((name, ", ".join(_value(float(x)) for x in v.reshape(-1))))
    return rows


def report_markdown(title: str, key_lines: Iterable[tuple[str, str]], findings: Iterable[Finding],
                    notes: Iterable[Finding], report: Mapping, outputs: Iterable[str],
                    angle_ranges: ColumnRanges | None = None, speed_ranges: ColumnRanges | None = None,
                    rate_ranges: ColumnRanges | None = None) -> str:
    """The text of ``report.md``.

    Args:
        title: the first heading's text (what ran on what).
        key_lines: ``(label, long text)`` of the summary's key facts.
        findings: the flags' findings, in the summary's order (most severe first).
        notes: the notes' findings, in the summary's order.
        report: the rectification report (``canonical.npz``'s ``report``).
        outputs: the output files' names.
        angle_ranges, speed_ranges: each angle's and each joint speed's range
            (:func:`pcnet.stages.column_ranges.column_ranges`), or ``None`` (no kinematics: no
            joint-angle or joint-speed section).
        rate_ranges: each angle rate's range (the joint angular velocities), or ``None`` (no
            angular-velocity section).
    """
    findings, notes = list(findings), list(notes)
    out = [f"# {title}", "", "## Key facts", ""]
    out += [f"- **{label}**: {text}" for label, text in key_lines]
    out += ["", "## Warnings", ""]
    if not findings:
        out.append("None.")
    for i, f in enumerate(findings, 1):
        out += f.report_lines(i)
    out += ["", "## Notes", ""]
    out += [f"- {n.detail}" for n in notes] or ["None."]
    if angle_ranges is not None:
        out += ["", "## Joint angles", "", *_angle_table(angle_ranges)]
    if rate_ranges is not None:
        out += ["", "## Joint angular velocities", "", *_rate_table(rate_ranges)]
    if speed_ranges is not None:
        out += ["", "## Joint speeds", "", *_speed_table(speed_ranges, report.get("root_path") == "not observable")]
    given_interval = isinstance(report.get("camera_pitch_interval_deg"), float) and math.isfinite(
        report["camera_pitch_interval_deg"])
    intervals = ("; the intervals the key facts print are `camera_pitch_interval_deg` and `camera_roll_interval_deg`, "
                 "while `*_uncertainty_deg` is the poses' part alone" if report.get("evidence") != GIVEN_UP else
                 "; the camera's up came from a standing trial (--camera-up-from): `camera_pitch_interval_deg` and "
                 "`camera_roll_interval_deg` are that trial's, and `poses_estimate` is this recording's poses' own up "
                 "beside it" if given_interval else
                 "; the camera's up was given, so it has no interval: `poses_estimate` is the poses' own up beside it")
    out += ["", "## Report numbers", "",
            f"(`report` in canonical.npz; docs/outputs.md says what each is{intervals})", "",
            "| key | value |", "|---|---|"]
    out += [f"| {k} | {v.replace('|', '/')} |" for k, v in _scalars(report)]
    out += ["", "## Outputs", ""] + [f"- {name}" for name in outputs]
    return "\n".join(out).rstrip() + "\n"


def _frames_counted(ranges: ColumnRanges) -> str:
    """Which frames a section's ranges cover."""
    left_out = []
    if ranges.implausible_frames:
        left_out.append(f"the {ranges.implausible_frames} frames the implausible-motion warning names")
    if ranges.other_person_frames:
        left_out.append(f"the {ranges.other_person_frames} frames outside the 2D track's longest one-person stretch "
                        f"(the track-switch warning's)")
    return "every frame with a value" + (f", leaving out {' and '.join(left_out)}" if left_out else "") + (
        " (the motion was not checked; the notes say why)" if ranges.implausible_frames is None else "")


def _angle_table(ranges: ColumnRanges) -> list[str]:
    """The joint-angle section's lines: which frames the ranges cover, then one row per angle."""
    if not ranges.rows:
        return ["None: no angle has a value in any frame counted."]
    # the trust statement first and the columns a clinician looks for named (a clinician's trial
    # found the one mid-paragraph and four trunk columns with no word on which to read)
    return ["**Every angle carries the lifter's own error**, which no warning measures in one recording: four "
            "calibrated cameras of one standing subject read its hips and knees tens of degrees apart, and the hips' "
            "internal rotations, and the shoulders' axial rotations with the elbow bent less than about 30 deg, err "
            "more than they vary (docs/guide/limits.md, docs/joint_angles.md). Angles against "
            "gravity (`*_inclination_deg`, `*_to_gravity_deg`) also carry the up's uncertainty, which "
            "kinematics_columns.csv states.", "",
            # the thorax's own planes, as docs/joint_angles.md says (an ergonomist's trial read a Kinect pick-up's
            # hip-line planes, lost in the bend: 17.5 deg forward and 41.7 sideways for 43.4 and -1.6)
            "Trunk lean from vertical: `trunk_inclination_deg` (0 upright, 90 lying); forward and sideways: "
            "`trunk_flexion_to_gravity_deg` (positive forward) and `trunk_lateral_tilt_to_gravity_deg` (positive to "
            "the subject's right), in the thorax's own planes (`trunk_sagittal_inclination_deg` and "
            "`trunk_frontal_inclination_deg` split the lean in the planes of the hip line, which a bend or a lifter's "
            "hips can turn). Knees and elbows: `*_flexion_deg` (ISB, 0 straight; a negative knee reads "
            "hyperextended) and `*_flexion_unsigned_deg` (the angle between the two segments).", "",
            f"Each angle of kinematics.csv (defined in kinematics_columns.csv, filtered as it is) over "
            f"{_frames_counted(ranges)}: its least and greatest value, the time each is first reached, the range "
            f"between them and the median. `frames of {ranges.counted_frames}`: how many of the "
            f"{ranges.counted_frames} frames counted give the angle a value (an angle with none is not listed; "
            f"kinematics.csv has its empty column).", "",
            f"| angle | frames of {ranges.counted_frames} | min (deg) | at (s) | max (deg) | at (s) | range (deg) | median (deg) |",
            "|---|---|---|---|---|---|---|---|",
            *(f"| {r.name} | {r.frames} | {r.minimum:.1f} | {r.minimum_s:.2f} | {r.maximum:.1f} | "
              f"{r.maximum_s:.2f} | {r.range:.1f} | {r.median:.1f} |" for r in ranges.rows)]


def _rate_table(ranges: ColumnRanges) -> list[str]:
    """The angular-velocity section's lines: which frames the peaks cover, which rates are
    mostly noise, then one row per angle rate: its peak each way (for a flexion, the fastest
    extension and flexion) and the time of each."""
    if not ranges.rows:
        return ["None: no angle has a rate in any frame counted."]
    return [f"Each angle's rate of change (kinematics.csv's `*_deg_per_s` columns, filtered as they are; for an ISB "
            f"angle, the joint angular velocity) over {_frames_counted(ranges)}: its peak in each direction (the "
            f"least value is the fastest motion the other way, e.g. a knee's extension) and the time each is first "
            f"reached. Peaks read high where the lifter's noise dominates: on held-out mocap with lifter-like noise, knee "
            f"and hip flexion peaks 1-19 % above the truth's, elbow flexion 29-73 %, the axial rotations and the "
            f"shoulder's plane of elevation up to 4 times (docs/benchmarks/kinematics.md).", "",
            f"| angle rate | frames of {ranges.counted_frames} | min (deg/s) | at (s) | max (deg/s) | at (s) |", "|---|---|---|---|---|---|",
            *(f"| {r.name} | {r.frames} | {r.minimum:.0f} | {r.minimum_s:.2f} | {r.maximum:.0f} | {r.maximum_s:.2f} |"
              for r in ranges.rows)]


def _speed_table(ranges: ColumnRanges, pelvis_relative: bool) -> list[str]:
    """The joint-speed section's lines: which frames the peaks cover, what they are relative to
    (the pelvis, horizontally, where its path is not observed: ``pelvis_relative``), what
    lowers a fast peak, then one row per joint."""
    if not ranges.rows:
        return ["None: no joint has a speed in any frame counted."]
    unit = ranges.rows[0].unit
    relative = (" Horizontally they are relative to the pelvis, whose own path this run could not observe (no 2D "
                "keypoints or measured root), so the body's own travel is not in them." if pelvis_relative else "")
    return [f"The speed of each joint speeds.png shows (kinematics.csv's `*_speed_*` columns, filtered as they are) "
            f"over {_frames_counted(ranges)}: its peak, the time it is first reached, and its median.{relative} A fast "
            f"movement's peak (a punch, a throw, a kick) reads low: the low-pass filter and the lifter's own "
            f"smoothing over frames cut it, and no cutoff gives back what the frame rate and the lifter did not "
            f"keep (docs/guide/kinematics.md).", "",
            f"| speed | frames of {ranges.counted_frames} | peak ({unit}) | at (s) | median ({unit}) |", "|---|---|---|---|---|",
            *(f"| {r.name} | {r.frames} | {r.maximum:.2f} | {r.maximum_s:.2f} | {r.median:.2f} |" for r in ranges.rows)]


def write_report(folder: Path, text: str) -> dict[str, Path]:
    """``report.md`` (``text``, :func:`report_markdown`) into ``folder`` (a run's staged
    output, published with the rest), atomically."""
    path = Path(folder) / REPORT_NAME
    write_text(path, text)
    return {REPORT_NAME: path}


__all__ = ["REPORT_NAME", "report_markdown", "write_report"]
