"""Plausibility of a recording's motion: joint speeds and accelerations beyond what people do.

A lifter's error does not respect a body's limits: a left/right swap, a track switch or a
detector jump moves a wrist half a metre between two frames, which reads as a wrist at 15 m/s
(the Sports2D demo's main track: a head at 5.5 m/s, a wrist at 14.8 m/s; GitHub issue 51).
This module finds the frames whose motion is beyond what the project's training motion
capture contains, so a run can say where its speeds, accelerations and angles are the
lifter's error rather than the person's motion.

What is measured: each joint's speed ``|v|`` and acceleration magnitude ``|a|`` **relative to
the pelvis** (the pelvis's own path removed, so a root-relative lifter, whose world pelvis
only moves vertically, and a measured root are judged alike), after the same zero-phase
Butterworth low-pass and central differences pcnet's kinematics use
(:func:`pcnet.stages.kinematics.filtered_derivatives`), at the cutoff and order the limits
were fitted with. Pelvis-relative motion does not depend on the (fixed) frame the poses are
in, so world-frame, camera-frame and mocap poses read the same; the per-frame canonical
frame, which turns with the pelvis, adds rotating-frame terms (use world poses where a run
has them).

The limits (``stages/data/motion_limits.json``, shipped with the package) are fitted, not
chosen: per joint group the largest pelvis-relative speed and acceleration in the training
motion capture of the shipped weights (CMU training subjects and Bandai's motion-style
training split: walking, running, dashes, jumps, kicks, punches, dances), by
``python -m benchmarks.fit_speed_limits --data ../shared/data``, which records the command,
files, split, filter, date and where each maximum occurred in the file, and reports the
held-out false-alarm rate in ``benchmarks/results/fit_speed_limits.txt``. Motion faster than
any of it (ballistic throws, racket sports, flips; a baseball pitcher's wrist exceeds 20 m/s)
is flagged too, and so are sprints (DeepMimic's fastest runs reach a knee speed 9 % above the
limit): the flag says what the limit is and where it comes from, so a user filming such
motion can read it.

Non-metric runs (``units != "m"``) are not checked (:func:`motion_check_note` says why).
NaN (missing joints or frames) is never bridged: the filter and the derivatives work on each
run of finite samples, and frames without a derivative are never flagged.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from .core.conventions import H36M_JOINTS, PELVIS
from .core.errors import InputError
from .core.framestore import true_runs
from .kinematics import FILTER_ORDER, filtered_derivatives

#: The shipped limits (``pcnet/stages/data/motion_limits.json``).
LIMITS_PATH = Path(__file__).resolve().parent / "data" / "motion_limits.json"
#: Quantities checked, and their units (metric runs only).
QUANTITIES = ("speed", "acceleration")
UNITS = MappingProxyType({"speed": "m/s", "acceleration": "m/s^2"})
#: Frame ranges listed per flag line (report.md's full text; the terminal's headline lists
#: fewer) before "and N more": all of a ten-minute session's joins fit (a long-recording trial
#: found its report cut at 5 of 7); every frame is in canonical.npz and kinematics.csv.
MAX_RANGES_LISTED = 20
#: Joints named (with their peak and limit) per flag line before "and N more".
MAX_JOINTS_LISTED = 4


@dataclass(frozen=True)
class MotionLimits:
    """Per joint group limits of pelvis-relative speed and acceleration, with provenance.

    Attributes:
        groups: ``group -> joint names`` (H36M-17 names; the pelvis is in none: its
            pelvis-relative motion is 0 by construction).
        speed: ``group -> limit`` in m/s. acceleration: ``group -> limit`` in m/s^2.
        cutoff_hz, order: the low-pass the limits were fitted with
            (:func:`pcnet.stages.kinematics.butterworth_lowpass`).
        source: a short text naming where the limits come from, for flag lines.
        provenance: the file's whole provenance block (command, data, split, date, ...).
        path: the file read.
    """

    groups: Mapping[str, tuple[str, ...]]
    speed: Mapping[str, float]
    acceleration: Mapping[str, float]
    cutoff_hz: float
    order: int
    source: str
    provenance: Mapping = field(default_factory=dict)
    path: str = ""

    def group_of(self, joint: str) -> str | None:
        """The group holding ``joint``, or None (no limit: the pelvis, or an unknown name)."""
        for group, joints in self.groups.items():
            if joint in joints:
                return group
        return None

    def limit(self, joint: str, quantity: str) -> float | None:
        """The limit of ``joint``'s ``quantity`` (``"speed"`` m/s, ``"acceleration"`` m/s^2),
        or None when the joint has none."""
        group = self.group_of(joint)
        if group is None:
            return None
        return float(getattr(self, quantity)[group])


@dataclass(frozen=True)
class ImplausibleMotion:
    """One joint's run of frames whose pelvis-relative ``quantity`` exceeds its limit.

    Attributes:
        joint: H36M-17 joint name. quantity: ``"speed"`` or ``"acceleration"``.
        first_frame, last_frame: 0-based frame indices, inclusive (ranges closer than the
            filter resolves are merged: :func:`merge_gap_frames`).
        peak: the largest value in the range; peak_frame: where it occurred.
        limit: the limit exceeded. unit: ``"m/s"`` or ``"m/s^2"``.
    """

    joint: str
    quantity: str
    first_frame: int
    last_frame: int
    peak: float
    peak_frame: int
    limit: float
    unit: str


def _as_float(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
        raise InputError(f"{where}: expected a positive number, got {value!r}")
    return float(value)


def load_motion_limits(path: str | Path | None = None) -> MotionLimits:
    """Read the motion limits file (JSON; default: the shipped :data:`LIMITS_PATH`).

    The file (written by ``benchmarks/fit_speed_limits.py``) holds ``filter``
    (``cutoff_hz``, ``order``), ``source`` (short text), ``groups``
    (``name -> {"joints": [...], "speed_m_per_s": x, "acceleration_m_per_s2": y, ...}``) and a
    ``provenance`` block (command, data files, split, date).

    Raises:
        FileNotFoundError: no such file.
        InputError: not JSON, or a field missing or of the wrong kind (named in the message).
    """
    path = Path(LIMITS_PATH if path is None else path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as err:
        raise InputError(f"{path}: expected a JSON motion limits file, got unreadable JSON ({err})") from err
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a JSON object, got {type(data).__name__}")
    try:
        filt, groups_in, source = data["filter"], data["groups"], data["source"]
        provenance = data["provenance"]
    except KeyError as err:
        raise InputError(f"{path}: field {err.args[0]!r}: expected it, got none") from err
    if not isinstance(groups_in, dict) or not groups_in:
        raise InputError(f"{path}: field 'groups': expected a non-empty object, got {groups_in!r}")
    groups, speed, acceleration = {}, {}, {}
    seen: set[str] = set()
    for name, g in groups_in.items():
        where = f"{path}: groups.{name}"
        if not isinstance(g, dict):
            raise InputError(f"{where}: expected an object, got {g!r}")
        joints = g.get("joints")
        if not isinstance(joints, list) or not joints or any(j not in H36M_JOINTS for j in joints):
            raise InputError(f"{where}.joints: expected H36M-17 joint names, got {joints!r}")
        if seen & set(joints):
            raise InputError(f"{where}.joints: expected each joint in one group, got {sorted(seen & set(joints))} again")
        seen |= set(joints)
        groups[name] = tuple(joints)
        speed[name] = _as_float(g.get("speed_m_per_s"), f"{where}.speed_m_per_s")
        acceleration[name] = _as_float(g.get("acceleration_m_per_s2"), f"{where}.acceleration_m_per_s2")
    if not isinstance(filt, dict):
        raise InputError(f"{path}: field 'filter': expected an object, got {filt!r}")
    order = filt.get("order")
    if isinstance(order, bool) or not isinstance(order, int) or order < 2 or order % 2:
        raise InputError(f"{path}: filter.order: expected an even integer >= 2, got {order!r}")
    return MotionLimits(
        groups=MappingProxyType(groups), speed=MappingProxyType(speed),
        acceleration=MappingProxyType(acceleration), cutoff_hz=_as_float(filt.get("cutoff_hz"), f"{path}: filter.cutoff_hz"),
        order=order, source=str(source), provenance=MappingProxyType(dict(provenance)), path=str(path))


def pelvis_relative_motion(positions, fps: float, cutoff_hz: float | None, order: int = FILTER_ORDER,
                           joints: Sequence[str] = H36M_JOINTS,
                           breaks: tuple[int, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
    """Speed and acceleration magnitude of ``joints`` relative to the pelvis.

    Each joint's path minus the pelvis's, low-passed and differentiated by
    :func:`pcnet.stages.kinematics.filtered_derivatives` (zero-phase Butterworth, central
    differences; NaN at missing frames, at the ends of each finite run and where a run was
    too short to filter). Read one joint at a time, so ``positions`` may be a long
    recording's on-disk array (:class:`pcnet.stages.core.framestore.FrameArray`).

    Args:
        positions: ``(T, 17, 3)`` H36M-17 poses in metres, any fixed frame; NaN = missing.
        fps: frame rate, Hz (> 0). cutoff_hz: -3 dB cutoff, Hz (None: no filter).
        order: even order of the zero-phase filter.
        joints: the joint names to measure.
        breaks: frames where the lifter's output restarts (:attr:`pcnet.adapters.Poses3D.breaks`):
            no derivative across them (NaN there, as at a run's ends).

    Returns:
        ``(speed, acceleration)``, each ``(T, len(joints))`` float64, m/s and m/s^2.

    Raises:
        InputError: ``positions`` not ``(T, 17, 3)``, an unknown joint, or an invalid fps or
            cutoff (:func:`~pcnet.stages.kinematics.butterworth_lowpass`).
    """
    shape = tuple(np.shape(positions))
    if len(shape) != 3 or shape[1:] != (17, 3):
        raise InputError(f"positions: expected (T, 17, 3) H36M-17 poses, got shape {shape}")
    unknown = [j for j in joints if j not in H36M_JOINTS]
    if unknown:
        raise InputError(f"joints: expected H36M-17 names, got {unknown}")
    T = shape[0]
    pelvis = np.asarray(positions[:, PELVIS], np.float64)
    speed = np.full((T, len(joints)), np.nan)
    acc = np.full((T, len(joints)), np.nan)
    for k, name in enumerate(joints):
        j = H36M_JOINTS.index(name)
        if j == PELVIS:
            rel = np.where(np.isfinite(pelvis), 0.0, np.nan)
        else:
            rel = np.asarray(positions[:, j], np.float64) - pelvis
        _, _, v, a = filtered_derivatives(rel, fps, cutoff_hz, order, breaks)
        speed[:, k] = np.linalg.norm(v, axis=-1)
        acc[:, k] = np.linalg.norm(a, axis=-1)
    return speed, acc


def merge_gap_frames(fps: float, cutoff_hz: float) -> int:
    """Frames between two exceedances up to which they are one event: one period of the
    cutoff frequency, ``ceil(fps / cutoff)`` (5 frames at 30 fps and 6 Hz), the width of the
    main lobe of the low-pass's impulse response, within which it does not resolve two events.
    A joint displaced for a few frames (a left/right swap, a detector jump) reads as a speed
    peak where it leaves and one where it comes back, with plausible motion between: merged,
    the range covers the displaced frames too."""
    return int(np.ceil(fps / cutoff_hz))


def _ranges(over: np.ndarray, gap: int) -> list[tuple[int, int]]:
    """Inclusive ``(first, last)`` runs of True in ``over`` ``(T,)``, runs at most ``gap``
    frames apart merged."""
    out: list[tuple[int, int]] = []
    for start, stop in true_runs(over):
        if out and start - out[-1][1] - 1 <= gap:
            out[-1] = (out[-1][0], stop - 1)
        else:
            out.append((start, stop - 1))
    return out


def motion_check_note(units: str, fps: float, limits: MotionLimits | None = None) -> str | None:
    """Why a run's motion is not checked (for the run's notes), or None when it is:
    non-metric poses (the limits are in metres), or a frame rate whose Nyquist frequency is
    not above the limits' cutoff (the motion cannot be filtered as the limits were)."""
    limits = load_motion_limits() if limits is None else limits
    if units != "m":
        return (f"joint speeds and accelerations not checked against the training motion's fastest: the poses are in {units}, "
                f"not metres (give --height)")
    if not fps > 2 * limits.cutoff_hz:
        return (f"joint speeds and accelerations not checked against the training motion's fastest: {fps:g} fps cannot be filtered at "
                f"the limits' {limits.cutoff_hz:g} Hz cutoff (its Nyquist frequency is {fps / 2:g} Hz)")
    return None


def implausible_motion(positions, fps: float, cutoff_hz: float | None = None, limits: MotionLimits | None = None,
                       *, units: str = "m", breaks: tuple[int, ...] = ()) -> list[ImplausibleMotion]:
    """Runs of frames where a joint's pelvis-relative speed or acceleration exceeds its limit.

    Args:
        positions: ``(T, 17, 3)`` H36M-17 poses in metres in any fixed frame (the run's world
            frame; camera-frame or mocap poses alike); NaN = missing. The per-frame canonical
            frame adds rotating-frame terms. May be an on-disk
            :class:`~pcnet.stages.core.framestore.FrameArray` (read a joint at a time).
        fps: frame rate, Hz.
        cutoff_hz: low-pass cutoff, Hz; None (recommended): the limits' own
            (``limits.cutoff_hz``), so what counts as implausible does not depend on a run's
            ``--cutoff-hz`` (a higher cutoff keeps more of the noise and of the motion's peaks).
        limits: from :func:`load_motion_limits` (default: the shipped file).
        units: the poses' length unit; anything but ``"m"`` is not checked (returns ``[]``;
            :func:`motion_check_note` gives the note), nor is a frame rate whose Nyquist
            frequency is not above the cutoff.
        breaks: frames where the lifter's output restarts (:attr:`pcnet.adapters.Poses3D.breaks`):
            the jump of a restart is the lifter's, not motion, and is not measured.

    Returns:
        findings sorted by quantity (speed first), joint (H36M order) and first frame; one
        per joint, quantity and run of frames above the limit (runs closer than
        :func:`merge_gap_frames` merged).

    Raises:
        InputError: ``positions`` not ``(T, 17, 3)``, or ``fps`` not positive.
    """
    limits = load_motion_limits() if limits is None else limits
    if not (isinstance(fps, (int, float, np.integer, np.floating)) and np.isfinite(fps) and fps > 0):
        raise InputError(f"fps: expected a frame rate > 0, got {fps!r}")
    cutoff = limits.cutoff_hz if cutoff_hz is None else float(cutoff_hz)
    if units != "m" or not fps > 2 * cutoff:
        return []
    joints = [j for j in H36M_JOINTS if limits.group_of(j) is not None]
    speed, acc = pelvis_relative_motion(positions, fps, cutoff, limits.order, joints, breaks)
    gap = merge_gap_frames(fps, cutoff)
    out = []
    for quantity, values in (("speed", speed), ("acceleration", acc)):
        for k, joint in enumerate(joints):
            limit = limits.limit(joint, quantity)
            v = values[:, k]
            with np.errstate(invalid="ignore"):
                over = np.isfinite(v) & (v > limit)
            for first, last in _ranges(over, gap):
                seg = np.where(np.isfinite(v[first:last + 1]), v[first:last + 1], -np.inf)
                at = int(np.argmax(seg))
                out.append(ImplausibleMotion(joint, quantity, first, last, float(seg[at]), first + at, limit,
                                             UNITS[quantity]))
    return out


def implausible_frames(findings: Sequence[ImplausibleMotion], num_frames: int) -> np.ndarray:
    """``(num_frames,)`` bool: True in every frame of a finding's range (first to last frame,
    inclusive).

    Raises:
        InputError: a finding outside ``[0, num_frames)``.
    """
    mask = np.zeros(int(num_frames), bool)
    for f in findings:
        if not 0 <= f.first_frame <= f.last_frame < num_frames:
            raise InputError(f"implausible_frames: frames {f.first_frame}-{f.last_frame} of {f.joint}: expected "
                             f"within [0, {num_frames})")
        mask[f.first_frame:f.last_frame + 1] = True
    return mask


def _union(ranges: Sequence[tuple[int, int]]) -> list[tuple[int, int]]:
    """Overlapping or touching inclusive ranges merged, sorted."""
    out: list[list[int]] = []
    for a, b in sorted(ranges):
        if out and a <= out[-1][1] + 1:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(a, b) for a, b in out]


def _frames_text(ranges: Sequence[tuple[int, int]]) -> str:
    shown = [f"{a}" if a == b else f"{a}-{b}" for a, b in ranges[:MAX_RANGES_LISTED]]
    more = len(ranges) - len(shown)
    return ", ".join(shown) + (f" and {more} more range{'s' * (more != 1)}" if more else "")


def implausible_motion_flags(findings: Sequence[ImplausibleMotion], limits: MotionLimits | None = None) -> list[str]:
    """Flag lines (the run summary's ``WARNING`` texts) for :func:`implausible_motion`'s
    findings: one line per quantity (speed, acceleration) that has any, naming the frame
    ranges (all joints' ranges merged; the first :data:`MAX_RANGES_LISTED`), the joints with
    their peak and limit (largest peak-to-limit ratio first; the first
    :data:`MAX_JOINTS_LISTED`), where the limits come from, and what to do.

    Args:
        findings: from :func:`implausible_motion`.
        limits: the limits used (default: the shipped file), for their source.

    Returns:
        zero, one or two lines.
    """
    if not findings:
        return []
    limits = load_motion_limits() if limits is None else limits
    lines = []
    for quantity in QUANTITIES:
        mine = [f for f in findings if f.quantity == quantity]
        if not mine:
            continue
        ranges = _union([(f.first_frame, f.last_frame) for f in mine])
        peaks: dict[str, ImplausibleMotion] = {}
        for f in mine:
            if f.joint not in peaks or f.peak > peaks[f.joint].peak:
                peaks[f.joint] = f
        ranked = sorted(peaks.values(), key=lambda f: -f.peak / f.limit)
        digits = 1 if quantity == "speed" else 0
        named = "; ".join(f"{f.joint.replace('_', ' ')} {f.peak:.{digits}f} {f.unit} at frame {f.peak_frame} "
                          f"(limit {f.limit:.{digits + 1}f})" for f in ranked[:MAX_JOINTS_LISTED])
        more = len(ranked) - MAX_JOINTS_LISTED
        named += f"; and {more} more joint{'s' * (more != 1)}" if more > 0 else ""
        frames = "frame" + ("s" if len(ranges) > 1 or ranges[0][0] != ranges[0][1] else "")
        lines.append(
            f"joint {quantity} beyond any training motion's in {frames} {_frames_text(ranges)}: {named}. These are "
            # a trial compared them with kinematics.csv's world-frame columns, empty at that frame
            f"{quantity}s relative to the pelvis, not kinematics.csv's world-frame columns, and the limits the "
            f"largest pelvis-relative {quantity} per joint group in {limits.source}; faster motion there is probably "
            f"a tracking or lifting error (a track switch, a left/right swap, a detector jump, joints jittering by "
            f"centimetres from frame to frame, which the low-pass lets through at its cutoff; or motion the limits "
            f"have not seen, such as sprints, throws, racket sports or flips): check the input's poses (and 2D keypoints, "
            f"where given) in those frames, and leave them out of speed, acceleration and angle analyses "
            f"(canonical.npz: implausible_frames). If a slow movement is flagged, check the frame rate first: a rate "
            f"n times the true one makes every {quantity} {'n' if quantity == 'speed' else 'n^2'} times too large")
    return lines
