"""``report.md``: the long form of a run's summary (docs/outputs.md).

The terminal summary gives each finding one line (:class:`pcnet.stages.flags.Finding`'s
headline and action); this file keeps what the lines leave out: every finding's full text
in the summary's order, every note in full, the key facts in their long form, each joint
angle's range (:mod:`pcnet.stages.angle_ranges`) and the rectification report's scalar
numbers.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path

from ..core.atomic import write_text
from ..angle_ranges import AngleRanges
from ..flags import Finding

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
                    ranges: AngleRanges | None = None) -> str:
    """The text of ``report.md``.

    Args:
        title: the first heading's text (what ran on what).
        key_lines: ``(label, long text)`` of the summary's key facts.
        findings: the flags' findings, in the summary's order (most severe first).
        notes: the notes' findings, in the summary's order.
        report: the rectification report (``canonical.npz``'s ``report``).
        outputs: the output files' names.
        ranges: each angle's range (:func:`pcnet.stages.angle_ranges.angle_ranges`), or
            ``None`` (no kinematics: no joint-angle section).
    """
    findings, notes = list(findings), list(notes)
    out = [f"# {title}", "", "## Key facts", ""]
    out += [f"- **{label}**: {text}" for label, text in key_lines]
    out += ["", "## Warnings", ""]
    if not findings:
        out.append("None.")
    for i, f in enumerate(findings, 1):
        out += [f"### {i}. {f.headline}", "", f"Severity: {f.severity.name.lower()}. Action: {f.action}.", "",
                f.detail, ""]
    out += ["", "## Notes", ""]
    out += [f"- {n.detail}" for n in notes] or ["None."]
    if ranges is not None:
        out += ["", "## Joint angles", "", *_angle_table(ranges)]
    out += ["", "## Report numbers", "", "(`report` in canonical.npz; docs/outputs.md says what each is; the intervals "
            "the key facts print are `camera_pitch_interval_deg` and `camera_roll_interval_deg`, while "
            "`*_uncertainty_deg` is the poses' part alone)", "",
            "| key | value |", "|---|---|"]
    out += [f"| {k} | {v.replace('|', '/')} |" for k, v in _scalars(report)]
    out += ["", "## Outputs", ""] + [f"- {name}" for name in outputs]
    return "\n".join(out).rstrip() + "\n"


def _angle_table(ranges: AngleRanges) -> list[str]:
    """The joint-angle section's lines: which frames the ranges cover, then one row per angle."""
    if not ranges.rows:
        return ["None: no angle has a value in any frame counted."]
    left_out = []
    if ranges.implausible_frames:
        left_out.append(f"the {ranges.implausible_frames} frames the implausible-motion warning names")
    if ranges.other_person_frames:
        left_out.append(f"the {ranges.other_person_frames} frames outside the 2D track's longest one-person stretch "
                        f"(the track-switch warning's)")
    over = "every frame with a value" + (f", leaving out {' and '.join(left_out)}" if left_out else "") + (
        " (the motion was not checked; the notes say why)" if ranges.implausible_frames is None else "")
    return [f"Each angle of kinematics.csv (defined in kinematics_columns.csv, filtered as it is) over {over}: its "
            f"least and greatest value, the time each is first reached, the range between them and the median. "
            f"Angles against gravity (`*_inclination_deg`, `*_to_gravity_deg`) also carry the up's uncertainty, "
            f"which kinematics_columns.csv states.", "",
            "| angle | frames | min (deg) | at (s) | max (deg) | at (s) | range (deg) | median (deg) |",
            "|---|---|---|---|---|---|---|---|",
            *(f"| {r.name} | {r.frames} | {r.minimum_deg:.1f} | {r.minimum_s:.2f} | {r.maximum_deg:.1f} | "
              f"{r.maximum_s:.2f} | {r.range_deg:.1f} | {r.median_deg:.1f} |" for r in ranges.rows)]


def write_report(folder: Path, text: str) -> dict[str, Path]:
    """``report.md`` (``text``, :func:`report_markdown`) into ``folder`` (a run's staged
    output, published with the rest), atomically."""
    path = Path(folder) / REPORT_NAME
    write_text(path, text)
    return {REPORT_NAME: path}


__all__ = ["REPORT_NAME", "report_markdown", "write_report"]
