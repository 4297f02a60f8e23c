"""Each joint angle's and joint speed's range in report.md and ``RunResult.angle_ranges`` /
``speed_ranges`` (stages/column_ranges.py), on real lifter output: the numbers a
physiotherapist looked for in the summary and report.md (a user trial found no knee range or
trunk lean there), and a coach's peak wrist speed (another trial parsed the CSV for it)."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from conftest import FIXTURES

from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import run_pipeline
from pcnet.stages.column_ranges import column_ranges

MEDIAPIPE = FIXTURES / "mediapipe_blazepose33_f000-059.npz"


@pytest.fixture(scope="module")
def mediapipe_run(tmp_path_factory):
    """A metric run (its motion checked) of 60 real MediaPipe frames, the first 3 without a person."""
    out = tmp_path_factory.mktemp("angles") / "mp"
    cfg = RunConfig(keypoints2d=str(MEDIAPIPE), keypoints2d_format="mediapipe", lifter="mediapipe",
                    lifter_output=str(MEDIAPIPE), fps=30, out=str(out), recording=False)
    result = run_pipeline(cfg, progress=False)
    with open(out / "kinematics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return result, rows, (out / "report.md").read_text()


def _column(rows: list[dict], name: str) -> np.ndarray:
    return np.array([float(r[name]) if r[name] else np.nan for r in rows])


def _as_the_csv_holds_it(r, rows: list[dict], unit: str) -> None:
    """A range row ``r`` against its kinematics.csv column (6-7 significant digits), over the
    frames the implausible-motion warning leaves in."""
    values = np.where(_column(rows, "implausible_motion") == 1, np.nan, _column(rows, r.name))
    time_s = _column(rows, "time_s")
    assert r.unit == unit and r.frames == np.isfinite(values).sum(), r.name
    for got, want in ((r.minimum, np.nanmin(values)), (r.maximum, np.nanmax(values)), (r.median, np.nanmedian(values)),
                      (r.minimum_s, time_s[np.nanargmin(values)]), (r.maximum_s, time_s[np.nanargmax(values)])):
        assert math.isclose(got, want, rel_tol=1e-5, abs_tol=1e-4), r.name


def test_the_report_gives_each_angles_range_as_kinematics_csv_holds_it(mediapipe_run):
    result, rows, report = mediapipe_run
    columns = [c for c in rows[0] if c.endswith("_deg") and c != "heading_deg"]
    assert result.report.implausible_frames is not None  # metres: the motion was checked
    left_out = _column(rows, "implausible_motion") == 1
    time_s = _column(rows, "time_s")
    ranges = {r.name: r for r in result.angle_ranges.rows}
    assert result.angle_ranges.implausible_frames == result.report.implausible_frames == left_out.sum()
    assert result.angle_ranges.other_person_frames == 0  # one person throughout
    # what each row's frames are a share of (a coach read an arm seen in 6 % of frames as any other row)
    assert result.angle_ranges.counted_frames == len(rows) - left_out.sum() == 60 - left_out.sum()
    assert f"| angle | frames of {result.angle_ranges.counted_frames} | min (deg) |" in report
    with_values = [c for c in columns if np.isfinite(np.where(left_out, np.nan, _column(rows, c))).any()]
    assert list(ranges) == with_values and "left_knee_flexion_deg" in ranges and "trunk_inclination_deg" in ranges
    for name, r in ranges.items():
        values = np.where(left_out, np.nan, _column(rows, name))
        assert r.frames == np.isfinite(values).sum() <= 57  # the first 3 frames have no person
        # the CSV's 6 significant digits
        assert r.unit == "deg"
        assert math.isclose(r.minimum, np.nanmin(values), rel_tol=1e-5, abs_tol=1e-5), name
        assert math.isclose(r.maximum, np.nanmax(values), rel_tol=1e-5, abs_tol=1e-5), name
        assert math.isclose(r.median, np.nanmedian(values), rel_tol=1e-5, abs_tol=1e-5), name
        assert math.isclose(r.maximum_s, time_s[np.nanargmax(values)], rel_tol=1e-5, abs_tol=1e-5), name
        assert math.isclose(r.range, r.maximum - r.minimum)
        assert (f"| {name} | {r.frames} | {r.minimum:.1f} | {r.minimum_s:.2f} | {r.maximum:.1f} | "
                f"{r.maximum_s:.2f} | {r.range:.1f} | {r.median:.1f} |") in report
    section = report[report.index("## Joint angles"):report.index("## Joint speeds")]
    n = result.report.implausible_frames
    assert (f"over every frame with a value, leaving out the {n} frames the implausible-motion warning names:" if n
            else "over every frame with a value:") in section


def test_the_report_gives_each_plotted_joints_peak_speed_as_kinematics_csv_holds_it(mediapipe_run):
    result, rows, report = mediapipe_run
    left_out = _column(rows, "implausible_motion") == 1
    peaks = {r.name: r for r in result.speed_ranges.rows}
    assert list(peaks)[:2] == ["left_wrist_speed_m_per_s", "right_wrist_speed_m_per_s"]  # metres: the fixture's
    assert {"left_ankle_speed_m_per_s", "head_speed_m_per_s"} <= set(peaks)
    assert result.speed_ranges.implausible_frames == left_out.sum()
    section = report[report.index("## Joint speeds"):report.index("## Report numbers")]
    assert f"| speed | frames of {60 - left_out.sum()} | peak (m/s) | at (s) | median (m/s) |" in section
    assert "A fast movement's peak (a punch, a throw, a kick) reads low" in section
    # relative to the pelvis only where its path is not observed (here it is fitted to the 2D keypoints)
    assert result.report.root_path == "from 2D keypoints" and "relative to the pelvis" not in section
    for name, r in peaks.items():
        _as_the_csv_holds_it(r, rows, "m/s")
        assert f"| {name} | {r.frames} | {r.maximum:.2f} | {r.maximum_s:.2f} | {r.median:.2f} |" in section


def test_the_report_gives_each_angle_rates_peaks_as_kinematics_csv_holds_them(mediapipe_run):
    """A coach's peak knee extension velocity: each ``*_deg_per_s`` column's least and greatest
    value (the fastest motion each way) and when, over the frames the angles' ranges cover."""
    result, rows, report = mediapipe_run
    left_out = _column(rows, "implausible_motion") == 1
    peaks = {r.name: r for r in result.rate_ranges.rows}
    assert list(peaks) == [f"{r.name}_per_s" for r in result.angle_ranges.rows]  # every angle with a rate
    assert result.rate_ranges.implausible_frames == left_out.sum()
    section = report[report.index("## Joint angular velocities"):report.index("## Joint speeds")]
    assert f"| angle rate | frames of {60 - left_out.sum()} | min (deg/s) | at (s) | max (deg/s) | at (s) |" in section
    assert "the axial rotations and the shoulder's plane of elevation up to 4 times" in section
    for name, r in peaks.items():
        _as_the_csv_holds_it(r, rows, "deg/s")
        assert f"| {name} | {r.frames} | {r.minimum:.0f} | {r.minimum_s:.2f} | {r.maximum:.0f} | " in section
    knee = peaks["left_knee_flexion_deg_per_s"]
    assert knee.minimum < 0 < knee.maximum  # flexes and extends


def test_ranges_leave_out_the_frames_the_warnings_name_and_angles_without_a_value(mediapipe_run):
    _, rows, _ = mediapipe_run
    knee = _column(rows, "left_knee_flexion_deg")
    top, bottom = int(np.nanargmax(knee)), int(np.nanargmin(knee))
    angles = {"left_knee_flexion_deg": knee, "absent_deg": np.full(len(knee), np.nan)}
    implausible, other = np.zeros(len(knee), bool), np.zeros(len(knee), bool)
    implausible[top], other[bottom] = True, True
    (kept,) = column_ranges(angles, "deg", 30.0).rows
    left = column_ranges(angles, "deg", 30.0, implausible, other)
    (without,) = left.rows
    assert (left.implausible_frames, left.other_person_frames) == (1, 1)
    assert (left.counted_frames, column_ranges(angles, "deg", 30.0).counted_frames) == (len(knee) - 2, len(knee))
    assert column_ranges(angles, "deg", 30.0).implausible_frames is None  # not checked
    assert kept.name == "left_knee_flexion_deg" and kept.maximum_s == pytest.approx(top / 30.0)
    assert without.frames == kept.frames - 2
    assert without.maximum == pytest.approx(np.nanmax(np.delete(knee, [top, bottom])))
    assert without.minimum == pytest.approx(np.nanmin(np.delete(knee, [top, bottom])))
    assert without.maximum < kept.maximum and without.minimum > kept.minimum
    with pytest.raises(ValueError, match="expected fps > 0"):
        column_ranges(angles, "deg", 0.0)
    with pytest.raises(ValueError, match="other_person has 59 frames, the columns 60"):
        column_ranges(angles, "deg", 30.0, other_person=other[1:])
