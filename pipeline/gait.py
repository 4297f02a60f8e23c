"""``pcnet gait``: gait events and spatiotemporal parameters of a `pcnet run` output folder
(:mod:`pcnet.stages.gait`), written beside the run's outputs.

Reads ``canonical.npz`` (``joints_world``, ``fps``, ``units``, ``pelvis_path_std_world``, the
``report``'s ``root_path`` and ``cutoff_hz``), low-passes the world poses with the run's own
cutoff (``stages/kinematics.py: butterworth_lowpass``, as kinematics.csv), and writes
``gait_events.csv`` (one row per event), ``gait.json`` (the summary), ``gait_cycles.csv`` and
``gait_cycles.png`` (hip and knee angles of kinematics.csv over each stride, 0-100 %) and a "Gait"
section of the run's report.md.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from pcnet.adapters.validate import NumpyArchive, open_numpy
from pcnet.stages.core.atomic import write_text
from pcnet.stages.core.conventions import METRES_PER_LENGTH_UNIT
from pcnet.stages.core.errors import InputError
from pcnet.stages.flags import one_person_frames
from pcnet.stages.gait import (backward_steps, check_forward, cycle_normalised, CYCLE_POINTS, gait_events, GaitError,
                               GaitEvents, GaitSummary, SIDES, Step, steps, summarise)
from pcnet.stages.kinematics import butterworth_lowpass
from pcnet.stages.sinks.plots import gait_cycles_figure, save_png

EVENTS_NAME = "gait_events.csv"
SUMMARY_NAME = "gait.json"
CYCLES_NAME = "gait_cycles.csv"
FIGURE_NAME = "gait_cycles.png"
OUTPUTS = (EVENTS_NAME, SUMMARY_NAME, CYCLES_NAME, FIGURE_NAME)
#: The ISB joint angles (kinematics.csv's ``{side}_{angle}_deg``) cut into gait cycles: the
#: sagittal and frontal hip and the knee, the clinical gait graph's joints that H36M-17 has
#: (no foot: no ankle angle).
CYCLE_ANGLES = ("hip_flexion", "hip_adduction", "knee_flexion")
#: The heading of report.md's gait section (replaced, not repeated, by a second `pcnet gait`).
REPORT_SECTION = "## Gait (pcnet gait)"
METHOD = ("Zeni et al. 2008 coordinate method (foot strike = the ankle furthest ahead of the pelvis, foot off = "
          "furthest behind; stages/gait.py)")


@dataclass(frozen=True)
class RunPoses:
    """What ``pcnet gait`` needs of a run.

    Attributes:
        joints: ``(T, 17, 3)`` float64 world-frame poses, low-passed as the run's kinematics.
        fps: frame rate (Hz).
        units: the poses' length unit (``"m"``, ``"cm"``, ``"mm"``) or ``"normalised"`` / ``"px"``.
        on_path: ``(T,)`` bool, frames whose pelvis follows an observed path.
        root_path: the run's pelvis path source (``"measured"``, ``"from 2D keypoints"``,
            ``"not observable"``).
        one_person_frames: frames analysed: all, or the 2D track's longest stretch where it
            jumped between people (``track_segment``; the others are NaN in ``joints``).
    """

    joints: np.ndarray
    fps: float
    units: str
    on_path: np.ndarray
    root_path: str
    one_person_frames: int

    @property
    def length_unit(self) -> str | None:
        """:attr:`units` where it is a length (``"m"``, ``"cm"``, ``"mm"``), else ``None``."""
        return self.units if self.units in METRES_PER_LENGTH_UNIT else None


def _field(arrays: NumpyArchive, npz: Path, name: str) -> np.ndarray:
    if name not in arrays.files:
        raise InputError(f"{npz}: field '{name}': expected it in a `pcnet run` output, got none (an older or "
                         f"foreign file: rerun pcnet run)")
    return arrays[name]


def read_run(folder: Path) -> RunPoses:
    """The world poses of the `pcnet run` output ``folder``.

    Raises:
        InputError: no ``canonical.npz``, a field missing or of the wrong kind, or a run
            without a world frame (a moving camera: frame or smooth mode).
    """
    npz = folder / "canonical.npz"
    if not npz.is_file():
        raise InputError(f"{folder}: expected a `pcnet run` output folder with canonical.npz, got none")
    arrays = open_numpy(npz)
    if not isinstance(arrays, NumpyArchive):
        raise InputError(f"{npz}: expected pcnet's canonical.npz archive, got a single .npy array")
    with arrays:
        joints = np.asarray(_field(arrays, npz, "joints_world"), np.float64)
        fps_field = _field(arrays, npz, "fps")
        units = str(_field(arrays, npz, "units"))
        path_std = np.asarray(_field(arrays, npz, "pelvis_path_std_world"), np.float64)
        report_text = str(_field(arrays, npz, "report"))
        segment = np.asarray(arrays["track_segment"], np.float64) if "track_segment" in arrays.files else None
    if fps_field.shape != () or fps_field.dtype.kind not in "fiu" or not float(fps_field) > 0:
        got = (f"{fps_field.item()!r}" if fps_field.shape == () and fps_field.dtype.kind in "fiu"
               else f"shape {fps_field.shape} of {fps_field.dtype}")  # a trial's 0 read "shape () of float64"
        raise InputError(f"{npz}: field 'fps': expected one positive frame rate, got {got}")
    fps = float(fps_field)
    try:
        report = json.loads(report_text)
    except json.JSONDecodeError:
        report = None
    if not isinstance(report, dict):
        raise InputError(f"{npz}: field 'report': expected the run's report (a JSON object), got {report_text[:40]!r}")
    if joints.ndim != 3 or joints.shape[1:] != (17, 3) or joints.shape[0] == 0:
        raise InputError(f"{npz}: field 'joints_world': expected world-frame poses (a static camera: pcnet run --mode "
                         f"sequence), got shape {joints.shape}: the run kept the canonical frame (a moving camera), "
                         f"which has no fixed forward for gait events")
    one_person = np.ones(len(joints), bool)
    if segment is not None and segment.shape == (len(joints),):  # (0,) without 2D keypoints
        tracked = np.isfinite(segment)
        if len(np.unique(segment[tracked])) > 1:
            # the 2D track jumped between people: the longest stretch alone, as world.trc holds it
            one_person = np.zeros(len(joints), bool)
            one_person[tracked] = one_person_frames(segment[tracked].astype(int))
            joints = np.where(one_person[:, None, None], joints, np.nan)
    root_path = report.get("root_path") or "not observable"
    pelvis_seen = np.isfinite(joints[:, 0]).all(axis=1)
    if root_path == "from 2D keypoints" and path_std.shape == (len(joints), 3):
        on_path = pelvis_seen & np.isfinite(path_std).all(axis=1)
    else:
        on_path = pelvis_seen & (root_path == "measured")
    cutoff = report.get("cutoff_hz")
    if cutoff:
        joints = butterworth_lowpass(joints, fps, float(cutoff))
    return RunPoses(joints, fps, units, on_path, root_path, int(one_person.sum()))


def read_cycle_angles(folder: Path, frames: int) -> dict[str, np.ndarray]:
    """kinematics.csv's :data:`CYCLE_ANGLES` columns of both sides, ``"{side}_{angle}_deg" ->
    (frames,)`` float64 (empty cells NaN).

    Raises:
        InputError: no kinematics.csv, a column missing, a cell not a number, or another
            number of rows than ``frames`` (canonical.npz's).
    """
    path = folder / "kinematics.csv"
    names = [f"{side}_{angle}_deg" for side in SIDES for angle in CYCLE_ANGLES]
    if not path.is_file():
        raise InputError(f"{folder}: expected kinematics.csv (pcnet run writes it), got none")
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.reader(f)
        header = next(reader, [])
        absent = [n for n in names if n not in header]
        if absent:
            raise InputError(f"{path}: field '{absent[0]}': expected the ISB joint angle column pcnet run writes, "
                             f"got none")
        columns = [header.index(n) for n in names]
        rows = []
        for line, row in enumerate(reader, start=2):
            try:
                rows.append([float(row[i]) if row[i].strip() else math.nan for i in columns])
            except (ValueError, IndexError):
                raise InputError(f"{path}: line {line}: expected a number or an empty cell in each angle column, "
                                 f"got {row[:3]}...") from None
    if len(rows) != frames:
        raise InputError(f"{path}: expected {frames} rows, one per frame of canonical.npz, got {len(rows)}")
    values = np.asarray(rows, np.float64).reshape(len(rows), len(names))
    return {name: values[:, k] for k, name in enumerate(names)}


def _number(x: float, digits: int) -> float | None:
    return round(float(x), digits) if math.isfinite(x) else None


def _cell(x: float, digits: int) -> str:
    return "" if not math.isfinite(x) else f"{x:.{digits}f}"


def events_csv(step_list: list[Step], offs: dict[str, np.ndarray], fps: float, unit: str) -> str:
    """``gait_events.csv``: one row per event in time order; the step columns on foot-strike
    rows only (:class:`pcnet.stages.gait.Step`; empty where a value does not exist)."""
    rows = [(s.time_s, s.side, "foot_strike", s) for s in step_list]
    rows += [(t, side, "foot_off", None) for side in SIDES for t in offs[side]]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["time_s", "frame", "side", "event", "step_time_s", "stride_time_s", "stance_percent",
                     f"step_length_{unit}"])
    for t, side, event, s in sorted(rows, key=lambda r: r[0]):
        values = ["", "", "", ""] if s is None else [
            _cell(s.step_time_s, 3), _cell(s.stride_time_s, 3), _cell(s.stance_percent, 1), _cell(s.step_length, 3)]
        writer.writerow([f"{t:.3f}", int(round(t * fps)), side, event, *values])
    return out.getvalue()


@dataclass(frozen=True)
class GaitResult:
    """One run's gait analysis (:func:`analyse`).

    Attributes:
        run: :class:`RunPoses`.
        events: :class:`pcnet.stages.gait.GaitEvents`.
        steps: :class:`pcnet.stages.gait.Step` per foot strike.
        summary: :class:`pcnet.stages.gait.GaitSummary`.
        length_empty_because: why step lengths and speed are empty, or ``None``.
        backward_note: the note on backward steps (:func:`pcnet.stages.gait.check_forward`), or
            ``None``.
        cycles: ``"{side}_{angle}_deg" -> (strides, CYCLE_POINTS)`` degrees: kinematics.csv's
            :data:`CYCLE_ANGLES` over each stride of that foot
            (:func:`pcnet.stages.gait.cycle_normalised`).
    """

    run: RunPoses
    events: GaitEvents
    steps: list[Step]
    summary: GaitSummary
    length_empty_because: str | None
    backward_note: str | None
    cycles: Mapping[str, np.ndarray]


def summary_dict(result: GaitResult) -> dict:
    """``gait.json``: the method, the run's path source and units, and :class:`GaitSummary`."""
    run, summary = result.run, result.summary
    sides = {side: {k: (_number(v, 4) if isinstance(v, float) else v)
                    for k, v in dataclasses.asdict(getattr(summary, side)).items()} for side in SIDES}
    return {
        "method": METHOD,
        "fps": run.fps,
        "length_unit": run.length_unit,
        "root_path": run.root_path,
        "frames": len(run.joints),
        "frames_of_the_tracked_person": run.one_person_frames,
        "steps_with_length": sum(math.isfinite(s.step_length) for s in result.steps),
        "steps_backward": backward_steps(result.steps)[0],
        "note": result.backward_note,
        "step_length_empty_because": result.length_empty_because,
        "cadence_steps_per_min": _number(summary.cadence_steps_per_min, 2),
        "walking_speed_per_s": _number(summary.walking_speed, 4),
        "stride_period_s": _number(summary.stride_period_s, 4),
        **sides,
    }


def step_length_reason(run: RunPoses) -> str | None:
    """Why step lengths and speed are empty, or ``None`` where they are measured."""
    if run.length_unit is None:
        return (f"poses in {run.units} units, not a length: step lengths and speed need a metric lifter or "
                f"pcnet run --height")
    if not run.on_path.any():
        return ("the run has no pelvis path (report.md's notes say why: no 2D keypoints, no image size or focal "
                "length, ...): step lengths and speed need footprints in the world")
    return None


def analyse(folder: Path) -> GaitResult:
    """Events, steps and summary of the run in ``folder`` (nothing written).

    Raises:
        InputError: :func:`read_run`'s; :class:`pcnet.stages.gait.GaitError` (an InputError)
            naming the file where no gait cycle is found.
    """
    run = read_run(folder)
    reason = step_length_reason(run)
    try:  # the events' refusals and the steps' direction, each naming the poses they read
        events = gait_events(run.joints, run.fps)
        step_list = steps(events, run.joints, run.on_path if reason is None else np.zeros_like(run.on_path))
        backward = check_forward(step_list)
    except GaitError as err:
        raise GaitError(f"{folder / 'canonical.npz'}: field 'joints_world' (the run's world-frame poses): {err}") \
            from None
    angles = read_cycle_angles(folder, len(run.joints))
    cycles = {name: cycle_normalised(x, events, name.split("_", 1)[0]) for name, x in angles.items()}
    return GaitResult(run, events, step_list, summarise(events, step_list), reason, backward,
                      MappingProxyType(cycles))


def cycles_csv(result: GaitResult) -> str:
    """``gait_cycles.csv``: one row per angle, stride and point of the stride (long format)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["side", "angle", "stride", "strike_time_s", "percent", "value_deg"])
    percent = np.linspace(0.0, 100.0, CYCLE_POINTS)
    for name, curves in result.cycles.items():
        side, angle = name.removesuffix("_deg").split("_", 1)
        strikes = result.events.foot(side).strikes_s
        for i, curve in enumerate(curves):
            for p, v in zip(percent, curve):
                writer.writerow([side, angle, i + 1, f"{strikes[i]:.3f}", f"{p:g}", _cell(v, 2)])
    return out.getvalue()


def write_gait(folder: Path, result: GaitResult) -> dict[str, Path]:
    """Write :data:`OUTPUTS` into ``folder`` (each atomically)."""
    summary = summary_dict(result)
    offs = {side: result.events.foot(side).offs_s for side in SIDES}
    unit = result.run.length_unit or result.run.units
    figure = gait_cycles_figure(result.cycles, CYCLE_ANGLES,
                                {side: getattr(result.summary, side).stance_percent for side in SIDES},
                                f"Gait cycles: {folder.name}\nmean and 1 SD over strides; vertical lines: mean foot off")
    return {EVENTS_NAME: write_text(folder / EVENTS_NAME, events_csv(result.steps, offs, result.run.fps, unit)),
            SUMMARY_NAME: write_text(folder / SUMMARY_NAME, json.dumps(summary, indent=1) + "\n"),
            CYCLES_NAME: write_text(folder / CYCLES_NAME, cycles_csv(result)),
            FIGURE_NAME: save_png(figure, folder / FIGURE_NAME)}


def gait_markdown(result: GaitResult) -> str:
    """report.md's gait section: the method, cadence, speed and the per-foot table."""
    u = result.run.length_unit or "-"
    lines = [REPORT_SECTION, "",
             f"{METHOD}. Cadence {_cell(result.summary.cadence_steps_per_min, 1)} steps/min, walking speed "
             f"{_cell(result.summary.walking_speed, 2)} {u}/s"
             + (f" (empty: {result.length_empty_because})" if result.length_empty_because else "")
             + ". " + (f"Note: {result.backward_note}. " if result.backward_note else "")
             + "Every event: gait_events.csv; the summary: gait.json; hip and knee angles over each stride: "
             "gait_cycles.csv and gait_cycles.png.", "",
             f"| foot | strikes | stride time (s) | stride time SD (s) | step time (s) | stance (% of stride) | "
             f"step length ({u}) |", "|---|---|---|---|---|---|---|"]
    for side in SIDES:
        s = getattr(result.summary, side)
        cells = [_cell(getattr(s, k), d) for k, d in (
            ("stride_time_s", 3), ("stride_time_sd_s", 3), ("step_time_s", 3), ("stance_percent", 1),
            ("step_length", 3))]
        lines.append(f"| {side} | {s.strikes} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


#: ``pcnet gait --table``'s columns: one row per run folder.
TABLE_COLUMNS = ("folder", "cadence_steps_per_min", "walking_speed_per_s", "length_unit", "root_path",
                 *(f"{side}_{key}" for side in SIDES for key in (
                     "strikes", "stride_time_s", "stride_time_sd_s", "step_time_s", "stance_percent", "step_length")),
                 "refused")


def summary_row(folder: str, result: GaitResult | None, refused: str | None) -> dict:
    """One ``--table`` row: :func:`summary_dict`'s numbers flattened, or only the folder and
    why it was refused (empty cells elsewhere)."""
    row = dict.fromkeys(TABLE_COLUMNS, "")
    row["folder"] = folder
    if result is None:
        row["refused"] = refused
        return row
    summary = summary_dict(result)
    for key in ("cadence_steps_per_min", "walking_speed_per_s", "length_unit", "root_path"):
        row[key] = "" if summary[key] is None else summary[key]
    for side in SIDES:
        for key, value in summary[side].items():
            row[f"{side}_{key}"] = "" if value is None else value
    return row


def table_written_by_pcnet(file: Path) -> bool:
    """Whether ``file`` is a ``pcnet gait --table`` (its header is :data:`TABLE_COLUMNS`)."""
    try:
        with open(file, newline="", encoding="utf-8") as f:
            return next(csv.reader(f), None) == list(TABLE_COLUMNS)
    except (OSError, UnicodeDecodeError, csv.Error):
        return False
