"""Gait events and spatiotemporal parameters from world-frame H36M-17 poses.

Frame and units: pcnet's world frame (docs/CONVENTIONS.md, "World frame": +Y up, fixed for the
recording), the poses' own length unit; times in seconds. NaN = missing.

Events (Zeni, Richards & Higginson 2008, "Two simple methods for determining gait events
during treadmill and overground walking using kinematic data", Gait & Posture 27(4):710-714,
the coordinate-based method): in each frame ``t`` let ``f_t`` be the subject's horizontal
forward direction (the canonical +X of the frame's own hip line,
:func:`forward_axes`) and

    s_t = (ankle_t - pelvis_t) . f_t

each foot's anterior position relative to the pelvis. A foot strike is a local maximum of
``s`` (the foot furthest ahead), a foot off a local minimum (furthest behind). Zeni et al.
use the heel for strikes, the toe for foot-off and the sacrum as reference; H36M-17 has
neither heel nor toe, so the ankle joint centre stands for both and the pelvis (mid-hip) for
the sacrum. Turning the reference with the hips each frame, not with one lab axis, keeps the
method on a curved path and on a treadmill alike (Zeni et al.'s lab axis assumes straight
walking).

Walking and running move the two feet in antiphase: while one swings forward relative to the
pelvis the other, on the ground, moves back. A recording whose two signals are not
negatively correlated (Pearson, over the frames with both) is refused: standing, jumping or
turning on the spot moves both ankles together with the pelvis. (On the Bandai mocap,
clean, with the rest of this method: 1,019 of 1,022 forward walks and runs accepted and 2,003
of 2,009 in-place clips refused; `python -m benchmarks.gait_validation`.)

A step carries the swing foot from behind the stance foot to ahead of it, so a maximum of
``s`` counts as a strike only where that foot is then ahead of the other (``s`` larger) and
a minimum as a foot off only where it is behind: a fencer's or boxer's stance, one foot
always ahead, has extrema but no steps. And the feet take turns: a recording where fewer
than half of the consecutive strikes alternate between the feet (the majority rule, the one
number here, chosen after four real yoga recordings of 89 read as gait without it; the mocap
and held-out walks are unchanged by it) is refused.

Nothing is tuned. Two extrema of the same kind on one foot are at least half a stride
apart, the stride ``P`` being the lag of the highest peak of the signals' biased
autocorrelation (both feet averaged, pooled over the runs of frames with both signals) below
half those frames; half the period is the separation that leaves equal room either side, and
an extremum counts only with that room inside its run of frames (nearer a run's edge the
motion beyond it is unseen). A recording
without a positive autocorrelation peak there has no gait cycle to find (:class:`GaitError`).
Event times are refined within the frame by the parabola through the extremum and its two
neighbours (the standard three-point peak interpolation).

Spatiotemporal parameters (the usual definitions, e.g. Whittle's *Gait Analysis*, 4th ed.,
2007): stride time between successive strikes of one foot; step time from a strike
of one foot to the next strike of the other; cadence = 60 / mean step time (steps/min);
stance = strike to the same foot's next off, as a percentage of that stride; step length =
the forward distance from one foot's placement to the other's next, each ankle taken at its
own strike in the world frame (footprint to footprint, as a lab measures it from heel
markers), so it needs the pelvis path (a root-relative pose alone gives the two ankles'
separation at the strike, which falls short of the footprints: the trailing heel has
lifted by then); walking speed = the steps' summed lengths over their summed times.

Limits: the events assume the whole recording is walking or running forward; stretches of
standing or turning on the spot within it also have extrema of ``s``, which this method reads
as events. Walking backwards swaps strikes and offs: with step lengths (an observed pelvis
path), a walk whose steps mostly go backward is refused and one with some is noted
(:func:`check_forward`). Zeni et al. validated the method on walking; in running the ankle is
furthest behind the pelvis after the foot has left the ground, so stance reads longer than
the foot's contact and no flight phase shows. Pedalling (a stationary bike, an
elliptical trainer) moves the feet as steps do and reads as gait.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

from .core.canonical import canonical_rotation
from .core.conventions import L_ANKLE, PELVIS, R_ANKLE
from .core.errors import InputError
from .core.framestore import true_runs

SIDES = ("left", "right")
_ANKLE = {"left": L_ANKLE, "right": R_ANKLE}


class GaitError(InputError):
    """The poses hold no gait cycle the method can find (too short, no periodic foot motion)."""


@dataclass(frozen=True)
class FootEvents:
    """One foot's events.

    Attributes:
        side: ``"left"`` or ``"right"``.
        strikes_s: ``(n,)`` float64 foot-strike times (s from frame 0), ascending.
        offs_s: ``(m,)`` float64 foot-off times (s), ascending.
    """

    side: str
    strikes_s: np.ndarray
    offs_s: np.ndarray


@dataclass(frozen=True)
class GaitEvents:
    """Both feet's events of one recording.

    Attributes:
        left, right: :class:`FootEvents`.
        stride_period_s: the stride the events were separated by (s; autocorrelation, above).
        fps: frame rate (Hz).
        present: ``(T,)`` bool, the frames with both feet's signals (both ankles, the pelvis
            and the hip line): the events were read on their runs.
    """

    left: FootEvents
    right: FootEvents
    stride_period_s: float
    fps: float
    present: np.ndarray

    def foot(self, side: str) -> FootEvents:
        return self.left if side == "left" else self.right

    def strikes_in_order(self) -> list[tuple[float, str]]:
        """Both feet's strikes as ``(time_s, side)``, ascending in time."""
        return sorted((t, side) for side in SIDES for t in self.foot(side).strikes_s)

    def unbroken(self, t0: float, t1: float) -> bool:
        """Whether every frame from time ``t0`` to ``t1`` (s) is :attr:`present`: a step or a
        stride across a gap (the person occluded, another person's frames) is not one."""
        a, b = int(np.floor(t0 * self.fps)), int(np.ceil(t1 * self.fps))
        return bool(0 <= a <= b < len(self.present) and self.present[a:b + 1].all())


@dataclass(frozen=True)
class Step:
    """One foot strike and what it ends or begins.

    Attributes:
        side: the striking foot.
        time_s: the strike's time (s).
        step_time_s: time since the other foot's previous strike (s), NaN where that strike is
            not the previous event of either foot's strikes (the first strike, or two strikes of
            one foot in a row) or a gap lies between (:meth:`GaitEvents.unbroken`).
        stride_time_s: time to this foot's next strike (s), NaN for its last strike or across a
            gap.
        stance_percent: this foot's stance in the stride it begins (strike to its next off, %
            of the stride), NaN where the stride does not hold exactly one off of this foot.
        step_length: forward distance (along the two strikes' mean ``f``) from the other foot's
            ankle at its previous strike to this one's at this strike: footprint to footprint,
            the poses' unit; NaN where ``step_time_s`` is, where either strike's frame is off
            the observed pelvis path, or an ankle or the hips are missing there.
    """

    side: str
    time_s: float
    step_time_s: float
    stride_time_s: float
    stance_percent: float
    step_length: float


def forward_axes(joints: np.ndarray) -> np.ndarray:
    """Each frame's horizontal forward direction ``f_t``: the canonical +X of the frame's hip
    line (docs/CONVENTIONS.md; :func:`pcnet.stages.core.canonical.canonical_rotation` with up
    = +Y).

    Args:
        joints: ``(T, 17, 3)`` H36M-17 poses, world frame (+Y up), any length unit.

    Returns:
        ``(T, 3)`` float64 unit vectors in the world frame; NaN where the hip line is missing
        or near vertical.
    """
    R, _ = canonical_rotation(np.asarray(joints, np.float64), (0.0, 1.0, 0.0))
    return R[:, :, 0]


def anterior_ankle_signals(joints: np.ndarray) -> dict[str, np.ndarray]:
    """Each ankle's forward position relative to the pelvis, ``s_t`` of the module docstring.

    Args:
        joints: ``(T, 17, 3)`` H36M-17 poses, world frame (+Y up), any length unit.

    Returns:
        ``{"left": (T,), "right": (T,)}`` float64 in the poses' unit; NaN where the ankle, the
        pelvis or the hip line is missing.
    """
    joints = np.asarray(joints, np.float64)
    f = forward_axes(joints)
    return {side: np.einsum("ti,ti->t", joints[:, _ANKLE[side]] - joints[:, PELVIS], f) for side in SIDES}


def stride_period_frames(signals: dict[str, np.ndarray]) -> int:
    """The stride in frames: the lag of the highest local maximum of the two feet's mean biased
    autocorrelation, pooled over the runs of frames where both signals are finite (each run
    demeaned; lagged products only within a run), at lags below half the frames with both
    signals (two strides in view in all).

    Args:
        signals: :func:`anterior_ankle_signals`.

    Raises:
        GaitError: no positive local maximum there (too few frames, or no periodic foot
            motion).
    """
    both = np.isfinite(signals["left"]) & np.isfinite(signals["right"])
    runs = true_runs(both)
    longest = max((stop - start for start, stop in runs), default=0)
    acf = np.zeros(longest)
    for side in SIDES:
        products, energy = np.zeros(longest), 0.0
        for start, stop in runs:
            x = signals[side][start:stop] - np.mean(signals[side][start:stop])
            products[: stop - start] += np.correlate(x, x, "full")[stop - start - 1:]
            energy += float(x @ x)
        if energy > 0:
            acf += products / energy / len(SIDES)
    lags, _ = find_peaks(acf[: min(longest, int(both.sum()) // 2 + 1)])
    lags = lags[acf[lags] > 0]
    if lags.size == 0:
        raise GaitError(f"expected a walk or run (the feet moving back and forth relative to the pelvis, at least "
                        f"two strides), got {int(both.sum())} frames with both ankles (at most {longest} in a row) and "
                        f"no periodic foot motion")
    return int(lags[np.argmax(acf[lags])])


def _refined(y: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Sub-frame extremum positions of ``y`` at interior frames ``k`` (three-point parabola)."""
    if k.size == 0:
        return k.astype(np.float64)
    a, b, c = y[k - 1], y[k], y[k + 1]
    curvature = a - 2 * b + c
    with np.errstate(invalid="ignore", divide="ignore"):
        delta = np.where(curvature != 0, 0.5 * (a - c) / curvature, 0.0)
    return k + np.clip(delta, -0.5, 0.5)


def _extrema(s: np.ndarray, distance: int) -> tuple[np.ndarray, np.ndarray]:
    """Maxima and minima of ``s`` (frames, sub-frame refined) within each run of finite frames,
    each the extremum of the ``distance`` frames either side: one nearer a run's edge is not
    known to be one (the motion beyond the edge is unseen, and a person entering the picture
    or a track starting gives its first frames' settling; a real walk's first strike came a
    third of a step early)."""
    maxima, minima = [], []
    for start, stop in true_runs(np.isfinite(s)):
        run = s[start:stop]
        for out, sign in ((maxima, 1.0), (minima, -1.0)):
            k, _ = find_peaks(sign * run, distance=distance)
            k = k[(k >= distance) & (k < len(run) - distance)]
            out.append(start + _refined(run, k))
    return np.concatenate(maxima or [np.zeros(0)]), np.concatenate(minima or [np.zeros(0)])


def gait_events(joints: np.ndarray, fps: float) -> GaitEvents:
    """Foot strikes and foot offs of both feet (Zeni et al. 2008, module docstring).

    Args:
        joints: ``(T, 17, 3)`` H36M-17 poses, world frame (+Y up), any length unit, low-passed
            as the kinematics are (the extrema of raw lifter jitter are not events).
        fps: frame rate (Hz, > 0).

    Returns:
        :class:`GaitEvents`.

    Raises:
        InputError: ``joints`` is not ``(T, 17, 3)`` or ``fps`` is not positive.
        GaitError: the feet not in antiphase, no gait cycle (:func:`stride_period_frames`),
            or no step or fewer than half the consecutive strikes alternating between the feet.
    """
    joints = np.asarray(joints, np.float64)
    if joints.ndim != 3 or joints.shape[1:] != (17, 3):
        raise InputError(f"joints: expected (T, 17, 3) H36M-17 poses, got shape {joints.shape}")
    if not (np.isfinite(fps) and fps > 0):
        raise InputError(f"fps: expected a positive frame rate, got {fps}")
    signals = anterior_ankle_signals(joints)
    both = np.isfinite(signals["left"]) & np.isfinite(signals["right"])
    if both.sum() < 3:  # a correlation needs three frames (a trial's one-frame run read "+nan")
        raise GaitError(f"expected a walk or run, several frames with both ankles, got {both.sum()}")
    phase = np.corrcoef(signals["left"][both], signals["right"][both])[0, 1]
    if not phase < 0:
        # plain words first: a coach's trial could not read "antiphase" (the numbers stay for the record)
        raise GaitError(f"expected a walk or run, the feet taking turns (one moving forward while the other moves "
                        f"back), got feet that move together or barely move (standing, jumping, turning on the "
                        f"spot): their forward positions relative to the pelvis correlate {phase:+.2f} over "
                        f"{both.sum()} frames, where steps give a negative correlation")
    period = stride_period_frames(signals)
    feet = {}
    for side, other in zip(SIDES, SIDES[::-1]):
        ahead = signals[side] - signals[other]  # > 0: this foot ahead of the other
        strikes, offs = _extrema(signals[side], max(1, period // 2))
        strikes = strikes[_at(ahead, strikes) > 0]
        offs = offs[_at(ahead, offs) < 0]
        feet[side] = FootEvents(side, strikes / fps, offs / fps)
    events = GaitEvents(feet["left"], feet["right"], period / fps, float(fps), both)
    order = [side for _, side in events.strikes_in_order()]
    turns = sum(a != b for a, b in zip(order, order[1:]))
    if turns == 0 or 2 * turns < len(order) - 1:
        raise GaitError(f"expected steps, the feet striking in turn (left, right, left, ...: each strike ahead of the "
                        f"other foot, after the other's strike), got {len(feet['left'].strikes_s)} left and "
                        f"{len(feet['right'].strikes_s)} right foot strikes of which {turns} follow the other foot's")
    # a stride is what stance, stride time and the gait cycle are of (a gait trial's 2.3 s walk gave a
    # cadence from one step, empty strides and an empty gait-cycle plot)
    if not any(events.unbroken(a, b) for side in SIDES for a, b in zip(events.foot(side).strikes_s,
                                                                      events.foot(side).strikes_s[1:])):
        raise GaitError(f"expected at least one stride (a foot striking twice with both ankles in view between), got "
                        f"{len(feet['left'].strikes_s)} left and {len(feet['right'].strikes_s)} right foot strikes "
                        f"over {len(joints) / fps:.1f} s: an event needs half a stride of poses either side, so a "
                        f"recording needs about two strides")
    return events


def _at(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``x`` (T, ...) at fractional frames ``t`` by linear interpolation (NaN propagates)."""
    k = np.clip(np.floor(t).astype(int), 0, len(x) - 1)
    k1 = np.clip(k + 1, 0, len(x) - 1)
    w = (t - k).reshape((-1,) + (1,) * (x.ndim - 1))
    return (1 - w) * x[k] + w * x[k1]


def steps(events: GaitEvents, joints: np.ndarray, on_path: np.ndarray) -> list[Step]:
    """Every foot strike with its step, stride, stance and step length, in time order.

    Args:
        events: :func:`gait_events` of ``joints``.
        joints: the same ``(T, 17, 3)`` world-frame poses.
        on_path: ``(T,)`` bool, the frames whose pelvis follows an observed path (measured or
            fitted to 2D keypoints): a step length needs both its strikes' frames on it.

    Returns:
        :class:`Step` per strike of either foot, ascending in time.
    """
    joints = np.asarray(joints, np.float64)
    forward = forward_axes(joints)
    strikes = events.strikes_in_order()
    out = []
    for i, (t, side) in enumerate(strikes):
        other = "right" if side == "left" else "left"
        previous = strikes[i - 1] if i and strikes[i - 1][1] == other else None
        if previous is not None and not events.unbroken(previous[0], t):
            previous = None
        own = events.foot(side).strikes_s
        later = own[own > t]
        stride = later[0] - t if later.size and events.unbroken(t, later[0]) else np.nan
        offs = events.foot(side).offs_s
        inside = offs[(offs > t) & (offs < t + stride)] if np.isfinite(stride) else offs[:0]
        stance = 100.0 * (inside[0] - t) / stride if inside.size == 1 else np.nan
        length = np.nan
        if previous is not None:
            frames = np.array([previous[0], t]) * events.fps
            if on_path[np.round(frames).astype(int)].all():
                before, now = _at(joints[:, _ANKLE[other]], frames[:1])[0], _at(joints[:, _ANKLE[side]], frames[1:])[0]
                f = _at(forward, frames).sum(axis=0)
                f[1] = 0.0
                length = float((now - before) @ f / np.linalg.norm(f))
        out.append(Step(side, float(t), float(t - previous[0]) if previous else np.nan, float(stride),
                        float(stance), length))
    return out


def backward_steps(step_list: list[Step]) -> tuple[int, int]:
    """``(backward, measured)``: the steps whose length is negative (the new footprint behind
    the other: the pelvis travels against the hips' facing) and the steps with a length.

    A walk mostly backward reads its strikes as foot offs and the reverse (module docstring),
    so :func:`check_forward` refuses it; a few backward steps (a turn, a step back) are a walk
    that changes direction, whose means mix them in.
    """
    lengths = np.asarray([s.step_length for s in step_list], np.float64)
    measured = lengths[np.isfinite(lengths)]
    return int((measured < 0).sum()), int(measured.size)


def check_forward(step_list: list[Step]) -> str | None:
    """Refuse a walk whose steps mostly go backward (:func:`backward_steps`; more than half,
    the majority rule of :func:`gait_events`); ``None`` for a forward walk, else the note on
    the backward steps it has.

    Raises:
        GaitError: more than half of the steps with a length are backward (a gait trial's
            backward walk gave a speed of -1.06 m/s and swapped strikes and offs, unflagged).
    """
    backward, measured = backward_steps(step_list)
    if 2 * backward > measured:
        raise GaitError(f"expected a walk or run forward, got {backward} of {measured} steps going backward (each "
                        f"footprint behind the other's: the pelvis travels against the hips' facing), where this "
                        f"method reads foot strikes as foot offs")
    if backward:
        return (f"{backward} of {measured} steps go backward (a footprint behind the other's: a turn, a step back, "
                f"walking backward): the means mix them with the forward steps; gait_events.csv's negative "
                f"step lengths are those steps")
    return None


@dataclass(frozen=True)
class SideSummary:
    """One foot's means over its steps (NaN where it has none).

    Attributes:
        strikes: number of foot strikes.
        step_time_s, stride_time_s, stance_percent, step_length: means over the steps that
            have the value (:class:`Step`); step_length in the poses' unit.
        stride_time_sd_s: sample standard deviation of the stride times (s; NaN below two).
    """

    strikes: int
    step_time_s: float
    stride_time_s: float
    stride_time_sd_s: float
    stance_percent: float
    step_length: float


@dataclass(frozen=True)
class GaitSummary:
    """A recording's spatiotemporal parameters.

    Attributes:
        left, right: :class:`SideSummary`.
        cadence_steps_per_min: 60 / mean step time over both feet (NaN without a step).
        walking_speed: the steps' summed lengths over their summed step times (poses' unit per
            s; NaN without a step length: no observed pelvis path).
        stride_period_s: :attr:`GaitEvents.stride_period_s`.
    """

    left: SideSummary
    right: SideSummary
    cadence_steps_per_min: float
    walking_speed: float
    stride_period_s: float


def _mean(values) -> float:
    x = np.asarray([v for v in values if np.isfinite(v)], np.float64)
    return float(x.mean()) if x.size else float("nan")


def summarise(events: GaitEvents, step_list: list[Step]) -> GaitSummary:
    """Means per foot, both feet's cadence and the walking speed (definitions: module
    docstring).

    Args:
        events: :func:`gait_events`.
        step_list: :func:`steps` of the same events.
    """
    sides = {}
    for side in SIDES:
        own = [s for s in step_list if s.side == side]
        strides = np.asarray([s.stride_time_s for s in own if np.isfinite(s.stride_time_s)])
        sides[side] = SideSummary(
            strikes=len(own),
            step_time_s=_mean(s.step_time_s for s in own),
            stride_time_s=_mean(strides),
            stride_time_sd_s=float(strides.std(ddof=1)) if strides.size >= 2 else float("nan"),
            stance_percent=_mean(s.stance_percent for s in own),
            step_length=_mean(s.step_length for s in own))
    step_time = _mean(s.step_time_s for s in step_list)
    cadence = 60.0 / step_time if np.isfinite(step_time) and step_time > 0 else float("nan")
    measured = [s for s in step_list if np.isfinite(s.step_length)]
    speed = (sum(s.step_length for s in measured) / sum(s.step_time_s for s in measured)) if measured else float("nan")
    return GaitSummary(sides["left"], sides["right"], cadence, float(speed), events.stride_period_s)


#: Samples per normalised gait cycle: 0, 1, ..., 100 % of the stride (the gait literature's
#: time normalisation, foot strike to the same foot's next strike).
CYCLE_POINTS = 101


def cycle_normalised(x: np.ndarray, events: GaitEvents, side: str) -> np.ndarray:
    """A series cut into one foot's strides and each resampled to :data:`CYCLE_POINTS` points,
    0 to 100 % of the stride (linear interpolation between frames).

    Args:
        x: ``(T,)`` float, one value per frame (an angle in degrees); NaN = missing.
        events: :func:`gait_events` of the same frames.
        side: ``"left"`` or ``"right"``: whose strikes cut the strides.

    Returns:
        ``(n - 1, CYCLE_POINTS)`` float64 for ``n`` strikes; NaN where a point's neighbouring
        frames are missing in ``x``, and the whole row for a stride across a gap
        (:meth:`GaitEvents.unbroken`).
    """
    x = np.asarray(x, np.float64)
    strikes = events.foot(side).strikes_s
    out = np.full((max(len(strikes) - 1, 0), CYCLE_POINTS), np.nan)
    share = np.linspace(0.0, 1.0, CYCLE_POINTS)
    for i, (a, b) in enumerate(zip(strikes, strikes[1:])):
        if events.unbroken(a, b):
            out[i] = _at(x, np.clip((a + share * (b - a)) * events.fps, 0, len(x) - 1))
    return out
