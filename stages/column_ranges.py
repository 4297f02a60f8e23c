"""Each joint angle's and joint speed's range over a recording: the numbers a clinician or
coach reads first (a knee's flexion range in a squat, the most a trunk leaned, the peak speed
of the lead wrist in a punch), in report.md (docs/outputs.md).

A range is a ``kinematics.csv`` column's least and greatest value over the frames that have
one, with the time of each, and their difference: for an angle, the range of motion of
movement analysis (max - min of the trial's angle curve). The values are the CSV's, already
low-pass filtered, so a single noisy frame moves them less than it moves the raw poses. Frames
the warnings ask to leave out are left out: the implausible-motion warning's (speeds or
accelerations no person makes) and the track-switch warning's (outside the 2D track's longest
one-person stretch).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ColumnRange:
    """One column's range over a recording.

    name: ``kinematics.csv``'s column (``left_knee_flexion_deg``, ``left_wrist_speed_m_per_s``);
    unit: its unit (``deg``, ``m/s``); frames: frames with a value, the left-out ones not
    counted; minimum, maximum: its least and greatest value (``unit``); minimum_s, maximum_s:
    the time of the first frame reaching each (s from the recording's start,
    ``kinematics.csv``'s ``time_s``); median: its median (``unit``).
    """

    name: str
    unit: str
    frames: int
    minimum: float
    minimum_s: float
    maximum: float
    maximum_s: float
    median: float

    @property
    def range(self) -> float:
        """``maximum - minimum`` (``unit``): for an angle, the range of motion."""
        return self.maximum - self.minimum


@dataclass(frozen=True)
class ColumnRanges:
    """Each column's range and the frames left out of them.

    rows: :class:`ColumnRange` per column with a value; implausible_frames: frames the
    implausible-motion warning names, left out (``None``: the motion was not checked);
    other_person_frames: frames outside the 2D track's longest one-person stretch (probably
    another person, the track-switch warning's), left out; counted_frames: the recording's
    frames less those left out, what each row's ``frames`` is a share of.
    """

    rows: tuple[ColumnRange, ...]
    implausible_frames: int | None
    other_person_frames: int
    counted_frames: int


def column_ranges(columns: Mapping[str, np.ndarray], unit: str, fps: float, implausible: np.ndarray | None = None,
                  other_person: np.ndarray | None = None) -> ColumnRanges:
    """The range of each column with at least one value.

    Args:
        columns: ``{kinematics.csv column: (T,) values in unit}`` (NaN where the column is
            empty), e.g. the angles of :attr:`pcnet.stages.kinematics.Kinematics.angles` as
            ``{f"{name}_deg": values}``.
        unit: the columns' unit, as ``kinematics_columns.csv`` gives it (``deg``, ``m/s``).
        fps: frames per second (> 0) of the recording.
        implausible: optional ``(T,)`` bool, the implausible-motion warning's frames
            (``canonical.npz``'s ``implausible_frames``), left out; ``None``: not checked.
        other_person: optional ``(T,)`` bool, frames outside the 2D track's longest
            one-person stretch (:func:`pcnet.stages.flags.one_person_frames`' complement),
            left out.

    Returns:
        :class:`ColumnRanges`: rows in ``columns``' order, columns with no value in any
        counted frame left out.

    Raises:
        ValueError: ``fps`` not a positive finite number, or ``implausible``,
            ``other_person`` or a column of another length than the first column.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"column_ranges: expected fps > 0, got {fps}")
    frames = len(next(iter(columns.values()))) if columns else 0
    left_out = np.zeros(frames, bool)
    for name, mask in (("implausible", implausible), ("other_person", other_person)):
        if mask is not None:
            if len(mask) != frames:
                raise ValueError(f"column_ranges: {name} has {len(mask)} frames, the columns {frames}")
            left_out |= np.asarray(mask, bool)
    rows = []
    for name, values in columns.items():
        if len(values) != frames:
            raise ValueError(f"column_ranges: {name} has {len(values)} frames, the first column {frames}")
        values = np.where(left_out, np.nan, np.asarray(values, dtype=np.float64))
        counted = np.isfinite(values)
        if not counted.any():
            continue
        low, high = int(np.nanargmin(values)), int(np.nanargmax(values))
        rows.append(ColumnRange(name, unit, int(counted.sum()), float(values[low]), low / fps, float(values[high]),
                                high / fps, float(np.nanmedian(values))))
    return ColumnRanges(tuple(rows), None if implausible is None else int(np.count_nonzero(implausible)),
                        0 if other_person is None else int(np.count_nonzero(other_person)),
                        int(frames - np.count_nonzero(left_out)))


__all__ = ["ColumnRange", "ColumnRanges", "column_ranges"]
