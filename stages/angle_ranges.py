"""Each joint angle's range over a recording: the numbers a clinician or coach reads first
(a knee's flexion range in a squat, the most a trunk leaned), in report.md (docs/outputs.md).

A range is the angle's least and greatest value over the frames that have one, with the
time of each, and their difference: the range of motion of movement analysis (max - min of
the trial's angle curve). The angles are ``kinematics.csv``'s, already low-pass filtered, so a
single noisy frame moves them less than it moves the raw poses. Frames the warnings ask to
leave out are left out: the implausible-motion warning's (speeds or accelerations no person
makes) and the track-switch warning's (outside the 2D track's longest one-person stretch).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class AngleRange:
    """One angle's range over a recording.

    name: ``kinematics.csv``'s column (``left_knee_flexion_deg``); frames: frames with a
    value, the left-out ones not counted; minimum_deg, maximum_deg: its least and greatest
    value (deg); minimum_s, maximum_s: the time of the first frame reaching each (s from the
    recording's start, ``kinematics.csv``'s ``time_s``); median_deg: its median (deg).
    """

    name: str
    frames: int
    minimum_deg: float
    minimum_s: float
    maximum_deg: float
    maximum_s: float
    median_deg: float

    @property
    def range_deg(self) -> float:
        """``maximum_deg - minimum_deg``: the range of motion (deg)."""
        return self.maximum_deg - self.minimum_deg


@dataclass(frozen=True)
class AngleRanges:
    """Each angle's range and the frames left out of them.

    rows: :class:`AngleRange` per angle with a value; implausible_frames: frames the
    implausible-motion warning names, left out (``None``: the motion was not checked);
    other_person_frames: frames outside the 2D track's longest one-person stretch (probably
    another person, the track-switch warning's), left out.
    """

    rows: tuple[AngleRange, ...]
    implausible_frames: int | None
    other_person_frames: int


def angle_ranges(angles: Mapping[str, np.ndarray], fps: float, implausible: np.ndarray | None = None,
                 other_person: np.ndarray | None = None) -> AngleRanges:
    """The range of each angle with at least one value.

    Args:
        angles: ``{name: (T,) degrees}`` as :attr:`pcnet.stages.kinematics.Kinematics.angles`
            (names without ``_deg``; NaN where the angle has no value).
        fps: frames per second (> 0) of the recording.
        implausible: optional ``(T,)`` bool, the implausible-motion warning's frames
            (``canonical.npz``'s ``implausible_frames``), left out; ``None``: not checked.
        other_person: optional ``(T,)`` bool, frames outside the 2D track's longest
            one-person stretch (:func:`pcnet.stages.flags.one_person_frames`' complement),
            left out.

    Returns:
        :class:`AngleRanges`: rows in ``angles``' order, angles with no value in any counted
        frame left out.

    Raises:
        ValueError: ``fps`` not a positive finite number, or ``implausible``,
            ``other_person`` or an angle of another length than the first angle.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"angle_ranges: expected fps > 0, got {fps}")
    frames = len(next(iter(angles.values()))) if angles else 0
    left_out = np.zeros(frames, bool)
    for name, mask in (("implausible", implausible), ("other_person", other_person)):
        if mask is not None:
            if len(mask) != frames:
                raise ValueError(f"angle_ranges: {name} has {len(mask)} frames, the angles {frames}")
            left_out |= np.asarray(mask, bool)
    rows = []
    for name, values in angles.items():
        if len(values) != frames:
            raise ValueError(f"angle_ranges: {name} has {len(values)} frames, the first angle {frames}")
        values = np.where(left_out, np.nan, np.asarray(values, dtype=np.float64))
        counted = np.isfinite(values)
        if not counted.any():
            continue
        low, high = int(np.nanargmin(values)), int(np.nanargmax(values))
        rows.append(AngleRange(f"{name}_deg", int(counted.sum()), float(values[low]), low / fps,
                               float(values[high]), high / fps, float(np.nanmedian(values))))
    return AngleRanges(tuple(rows), None if implausible is None else int(np.count_nonzero(implausible)),
                       0 if other_person is None else int(np.count_nonzero(other_person)))


__all__ = ["AngleRange", "AngleRanges", "angle_ranges"]
