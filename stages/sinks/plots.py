"""PNG plots of a run's kinematics: joint angles and joint speeds over time, and the
grouping and colours of angle series that the rerun recording shares with them.

The wrists plot (positions and accelerations before and after rectification) is
:func:`pcnet.stages.sinks.exports.plot_wrists`; the plots here sit beside it in a run's output
folder (``angles.png``, ``speeds.png``).

Grouping: the angles of :class:`~pcnet.stages.kinematics.Kinematics` (the ISB joint angles
of :mod:`pcnet.stages.isb_angles` and the segment inclinations of
:func:`pcnet.stages.kinematics.joint_angles`, 36 series) are split into one group per joint
or segment (:data:`ANGLE_GROUPS`), so no plot has more than six series.

Colours: one family per side so left and right stay apart even in a viewer without line
styles (rerun): the subject's left in cool colours (blue first, as the skeleton's left
joints), the right in warm colours (red first), midline series in a neutral qualitative
palette; within a side, the n-th series of a group gets the n-th colour of the family.
In the PNGs the left side is also dashed, the right solid (as in ``wrists.png``).

Rendering uses matplotlib's Agg canvas (no pyplot, no display); every PNG is written
atomically (:mod:`pcnet.stages.core.atomic`). NaN samples (missing joints, undefined angles,
run edges without a derivative) are gaps in the lines, never zeros.
"""

from __future__ import annotations

import io
import os
import re
import warnings
from collections.abc import Iterable, Mapping
from pathlib import Path
from types import MappingProxyType

import numpy as np

from ..core.atomic import atomic_path
from ..core.errors import InputError
from ..core.framestore import true_runs

#: Samples per plotted line above which a line is drawn from per-bin extremes.
MAX_PLOT_SAMPLES = 4000


def display_samples(t: np.ndarray, y: np.ndarray, max_samples: int = MAX_PLOT_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """A time series ``(T,)`` reduced for drawing at figure resolution.

    Up to ``max_samples`` samples it is returned unchanged. Beyond, the samples are split
    into ``max_samples // 3`` bins of consecutive samples and each bin is drawn by its
    minimum and maximum (min/max decimation, as in Jugel et al., "M4: a visualization-oriented
    time series data aggregation", PVLDB 7(10), 2014): the envelope and every peak of a
    2-hour recording look as with all 216,000 samples, at a fraction of matplotlib's memory
    and time. A bin with a missing (NaN) sample ends with a NaN, so gaps stay visible (at bin
    resolution); an all-NaN bin is a gap.

    Args:
        t, y: ``(T,)`` times (increasing) and values; NaN = missing.
        max_samples: most samples drawn (>= 3).

    Returns:
        ``(t, y)`` float64, at most ``max_samples`` long.
    """
    t = np.asarray(t, np.float64)
    y = np.asarray(y, np.float64)
    if len(y) <= max_samples:
        return t, y
    starts = np.linspace(0, len(y), max(1, max_samples // 3) + 1).astype(int)[:-1]
    ends = np.append(starts[1:], len(y)) - 1
    finite = np.isfinite(y)
    lo = np.minimum.reduceat(np.where(finite, y, np.inf), starts)
    hi = np.maximum.reduceat(np.where(finite, y, -np.inf), starts)
    gap = np.logical_or.reduceat(~finite, starts)
    empty = ~np.isfinite(lo)
    lo[empty] = hi[empty] = np.nan
    third = np.where(gap, np.nan, hi)
    return (np.stack([t[starts], t[ends], t[ends]], axis=1).ravel(),
            np.stack([lo, hi, third], axis=1).ravel())

# ---------------------------------------------------------------------------------------
# groups and colours (no matplotlib needed: rerun_log uses them too)

#: Angle groups in display order: ``group id -> title``. Every angle name of
#: :class:`~pcnet.stages.kinematics.Kinematics` falls into one (:func:`angle_group`);
#: names matching none go to ``"other"``.
ANGLE_GROUPS: Mapping[str, str] = MappingProxyType({
    "trunk": "trunk (ISB: thorax to pelvis, thorax to gravity)",
    "trunk_inclination": "trunk inclination (pelvis->thorax to gravity)",
    "hip": "hip (ISB, thigh to pelvis)",
    "thigh_inclination": "thigh inclination (to gravity)",
    "shoulder": "shoulder (ISB Y-X-Y, humerus to thorax)",
    "upper_arm_inclination": "upper-arm inclination (to gravity)",
    "knee": "knee flexion (ISB, signed)",
    "elbow": "elbow flexion (ISB)",
    "flexion_unsigned": "knee and elbow flexion, unsigned (180 - included angle)",
    "other": "other angles",
})

#: Groups :func:`plot_joint_angles` leaves out when the ISB knee or elbow panel is drawn:
#: the unsigned flexions equal the ISB ones except that hyperextension reads positive, so
#: the lines would lie on top of each other.
REDUNDANT_IN_PNG: tuple[str, ...] = ("flexion_unsigned",)

_SIDED_JOINT = re.compile(r"^(left|right)_(hip|knee|shoulder|elbow)_(.+)$")
_SIDED_SEGMENT = re.compile(r"^(left|right)_(thigh|upper_arm)_(.+)_inclination$")

#: Colour families, RGB 0-255: the subject's left (cool), right (warm), midline (neutral).
#: The first left/right colours are the skeleton's side colours in the rerun recording.
LEFT_COLOURS: tuple[tuple[int, int, int], ...] = ((40, 110, 235), (0, 170, 200), (120, 80, 220), (60, 170, 80))
RIGHT_COLOURS: tuple[tuple[int, int, int], ...] = ((230, 60, 50), (245, 150, 20), (210, 60, 160), (150, 100, 60))
MID_COLOURS: tuple[tuple[int, int, int], ...] = (
    (120, 120, 120), (180, 150, 0), (0, 150, 130), (150, 90, 190), (90, 160, 40), (200, 100, 120),
)


def angle_group(name: str) -> str:
    """The :data:`ANGLE_GROUPS` id of an angle name (with or without ``_deg``):
    ``"left_hip_flexion"`` -> ``"hip"``, ``"right_thigh_sagittal_inclination"`` ->
    ``"thigh_inclination"``, ``"trunk_flexion_to_pelvis_deg"`` -> ``"trunk"``,
    ``"trunk_inclination"`` -> ``"trunk_inclination"``, ``"left_knee_flexion_unsigned"`` ->
    ``"flexion_unsigned"``; anything else ``"other"``."""
    n = str(name).removesuffix("_deg")
    if _SIDED_JOINT.match(n) and n.endswith("_flexion_unsigned"):
        return "flexion_unsigned"
    if m := _SIDED_SEGMENT.match(n):
        return f"{m.group(2)}_inclination"
    if m := _SIDED_JOINT.match(n):
        return m.group(2)
    if n.startswith("trunk_") or n == "trunk":
        return "trunk_inclination" if n.endswith("inclination") else "trunk"
    return "other"


def group_angles(names: Iterable[str]) -> dict[str, list[str]]:
    """Angle names grouped by :func:`angle_group`, groups in :data:`ANGLE_GROUPS` order
    (empty groups left out), names in their given order within a group."""
    names = list(names)
    by = {g: [n for n in names if angle_group(n) == g] for g in ANGLE_GROUPS}
    return {g: ns for g, ns in by.items() if ns}


def side_of(name: str) -> str:
    """``"left"``, ``"right"`` or ``"mid"`` from a series or joint name's first word
    (``"left_hip_flexion"``, ``"right_wrist_vx"``, ``"trunk_flexion_to_pelvis"``)."""
    n = str(name).rsplit("/", 1)[-1]
    return "left" if n.startswith("left") else "right" if n.startswith("right") else "mid"


def series_colours(names: Iterable[str]) -> dict[str, tuple[int, int, int]]:
    """RGB 0-255 colour of each series of one plot: the subject's left in
    :data:`LEFT_COLOURS`, right in :data:`RIGHT_COLOURS`, the rest in :data:`MID_COLOURS`;
    the n-th series of a side gets the n-th colour of its family (cycling). So a left and a
    right series never share a colour, and the same component (e.g. flexion, the first of
    a joint) gets the family's first colour on both sides."""
    counts = {"left": 0, "right": 0, "mid": 0}
    families = {"left": LEFT_COLOURS, "right": RIGHT_COLOURS, "mid": MID_COLOURS}
    out = {}
    for n in names:
        side = side_of(n)
        fam = families[side]
        out[n] = fam[counts[side] % len(fam)]
        counts[side] += 1
    return out


def _angle_label(name: str, group: str) -> str:
    """Legend text: ``"left_hip_flexion"`` -> ``"left flexion"``, ``"trunk_flexion_to_pelvis"``
    -> ``"flexion to pelvis"``, ``"left_thigh_sagittal_inclination"`` -> ``"left sagittal"``."""
    n = name.removesuffix("_deg")
    if m := _SIDED_SEGMENT.match(n):
        return f"{m.group(1)} {m.group(3).replace('_', ' ')}"
    if m := _SIDED_JOINT.match(n):
        rest = m.group(3) if group == m.group(2) else f"{m.group(2)}_{m.group(3)}"
        return f"{m.group(1)} {rest.replace('_', ' ')}"
    if group in ("trunk", "trunk_inclination") and n.startswith("trunk_"):
        return n.removeprefix("trunk_").replace("_", " ")
    return n.replace("_", " ")


# ---------------------------------------------------------------------------------------
# figures

#: Joint groups of :func:`joint_speeds_figure`: ``title -> joint names``.
SPEED_GROUPS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "wrists and elbows": ("left_wrist", "right_wrist", "left_elbow", "right_elbow"),
    "ankles and knees": ("left_ankle", "right_ankle", "left_knee", "right_knee"),
    "pelvis, thorax and head": ("pelvis", "thorax", "head"),
})


def _rgb(c: tuple[int, int, int]) -> tuple[float, float, float]:
    return tuple(v / 255.0 for v in c)


def _time_axis(kin, fps: float, who: str) -> np.ndarray:
    if not (isinstance(fps, (int, float, np.floating, np.integer)) and fps > 0):
        raise InputError(f"{who}: fps must be > 0, got {fps!r}")
    if abs(float(fps) - float(kin.fps)) > 1e-6 * max(1.0, float(kin.fps)):
        raise InputError(f"{who}: fps {fps!r} differs from the kinematics' {kin.fps!r} Hz")
    return np.arange(kin.num_frames) / float(fps)


#: Figure margins in inches: the y axis label and tick labels at the left (and again between
#: two columns), the time axis label and tick labels at the bottom, a panel's one-line title
#: between rows. Fixed rather than matplotlib's constrained layout, which measured every text
#: of every panel at each save: with it and auto-placed panel titles, ``pcnet demo``'s three
#: figures took 4.0 s, 2.3 s without (``write_figures`` timed on 2 cores).
MARGIN_LEFT_IN, MARGIN_RIGHT_IN, MARGIN_BOTTOM_IN = 1.0, 0.15, 0.55
ROW_GAP_IN, COLUMN_GAP_IN = 0.4, 1.05


def new_figure(rows: int, cols: int, height_per_row: float, title: str, title_size: float = 11.0):
    """A 13-inch-wide Agg :class:`~matplotlib.figure.Figure` (no pyplot, no display) with a
    ``(rows, cols)`` grid of axes sharing x under the suptitle ``title`` (its lines set the top
    margin); ``(fig, axes (rows, cols))``. Margins are fixed in inches (:data:`MARGIN_LEFT_IN`
    and the others), so each panel keeps room for its title, axis labels and tick labels of up
    to six characters (-10000, 0.0025) whatever the figure's height."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    width, height = 13.0, 1.0 + height_per_row * rows
    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    axes = np.atleast_2d(fig.subplots(rows, cols, sharex=True, squeeze=False))
    line_in = 1.3 * title_size / 72.0
    fig.suptitle(title, fontsize=title_size, y=1.0 - 0.1 / height, va="top")
    top_in = 0.1 + line_in * (title.count("\n") + 1) + ROW_GAP_IN
    plot_w = width - MARGIN_LEFT_IN - MARGIN_RIGHT_IN
    plot_h = height - MARGIN_BOTTOM_IN - top_in
    axes_w = (plot_w - (cols - 1) * COLUMN_GAP_IN) / cols
    axes_h = (plot_h - (rows - 1) * ROW_GAP_IN) / rows
    fig.subplots_adjust(left=MARGIN_LEFT_IN / width, right=1.0 - MARGIN_RIGHT_IN / width,
                        bottom=MARGIN_BOTTOM_IN / height, top=1.0 - top_in / height,
                        wspace=COLUMN_GAP_IN / axes_w, hspace=ROW_GAP_IN / axes_h)
    return fig, axes


def set_panel_title(ax, title: str, fontsize: float = 10.0) -> None:
    """``ax``'s title, placed at the top of the panel (:data:`ROW_GAP_IN` holds it). A title
    without a fixed ``y`` is placed above any tick labels at the top, which matplotlib measures
    at every save: a quarter of a figure's time, for panels that never have top tick labels."""
    ax.set_title(title, fontsize=fontsize, y=1.0)


#: What the grey spans of the angle and speed figures mark.
OTHER_PERSON_NOTE = "grey: another person's frames (the 2D track switched)"
#: Colour (RGB 0-1) of the spans marking motion faster than any training motion, and what they mark.
IMPLAUSIBLE_COLOUR = (1.0, 0.8, 0.8)
IMPLAUSIBLE_NOTE = "red: motion faster than any training motion (canonical.npz implausible_frames)"


#: Resolution (dots per inch) the figures are saved at.
SAVE_DPI = 110
#: Narrowest span drawn, in pixels of the saved figure: one marked frame of a ten-minute plot is
#: a fifth of a pixel wide, which a user trial could not see.
MIN_SPAN_PX = 3.0


def _shade(ax, t: np.ndarray, marked: np.ndarray | None, color=0.85) -> None:
    """Spans (grey by default) over the runs of ``marked`` ``(T,)`` bool frames at times ``t``
    ``(T,)`` (each frame spans half a frame either side), each at least :data:`MIN_SPAN_PX`
    wide about its centre."""
    if marked is None or not np.any(marked):
        return
    half = 0.5 * (t[1] - t[0]) if len(t) > 1 else 0.5
    min_half = 0.5 * MIN_SPAN_PX * (t[-1] - t[0] + 2 * half) / (ax.figure.get_figwidth() * SAVE_DPI)
    color = str(color) if isinstance(color, float) else color
    for start, stop in true_runs(marked):
        lo, hi = t[start] - half, t[stop - 1] + half
        widen = max(0.0, min_half - 0.5 * (hi - lo))
        ax.axvspan(lo - widen, hi + widen, color=color, lw=0, zorder=0)


def marked_frames(marked, t: np.ndarray, name: str, what: str = "other_person") -> np.ndarray | None:
    """``marked`` ``(T,)`` as bool frames at times ``t``, ``None`` when absent or none is marked.

    Raises:
        InputError: ``marked`` not ``(T,)`` (``name``, ``what`` named).
    """
    if marked is None:
        return None
    marked = np.asarray(marked, bool)
    if marked.shape != t.shape:
        raise InputError(f"{name}: {what} has shape {marked.shape}, expected {t.shape}")
    return marked if marked.any() else None


def shade_marks(ax, t: np.ndarray, other_person: np.ndarray | None, implausible: np.ndarray | None) -> None:
    """Grey spans over ``other_person`` frames and red ones over ``implausible`` frames
    (:func:`marked_frames`' ``(T,)`` bool or ``None``) at times ``t``."""
    _shade(ax, t, other_person)
    _shade(ax, t, implausible, IMPLAUSIBLE_COLOUR)


def marks_note(other_person, implausible) -> str:
    """The title's second line: what the shaded spans mark (empty when none is drawn)."""
    notes = [n for n, m in ((OTHER_PERSON_NOTE, other_person), (IMPLAUSIBLE_NOTE, implausible)) if m is not None]
    return f"\n{'; '.join(notes)}" if notes else ""


def _no_data(ax) -> None:
    ax.text(0.5, 0.5, "no finite values", transform=ax.transAxes, ha="center", va="center",
            color="0.4", fontsize=9)


def _series_label(label: str, y: np.ndarray) -> str:
    """A legend entry; a series with no finite sample says so rather than showing a line
    that is nowhere in the panel."""
    return label if np.isfinite(y).any() else f"{label} (no values)"


def _time_limits(axes, t: np.ndarray) -> None:
    """The recording's time span on every panel, so a panel with gaps (or no value at all)
    still shows where in the recording it is, not matplotlib's default -0.05..0.05 s."""
    half = 0.5 * (t[1] - t[0]) if len(t) > 1 else 0.5
    for ax in np.ravel(axes):
        ax.set_xlim(t[0] - half, t[-1] + half)


def joint_angles_figure(kin, fps: float, *, frame_label: str = "world frame", other_person=None, implausible=None):
    """The figure of :func:`plot_joint_angles` (a :class:`matplotlib.figure.Figure` on an
    Agg canvas), for callers that want to inspect or restyle it.

    Raises:
        InputError: ``fps <= 0``, ``fps`` not the kinematics' rate, no angles, or
            ``other_person`` or ``implausible`` not ``(T,)``.
    """
    t = _time_axis(kin, fps, "plot_joint_angles")
    other_person = marked_frames(other_person, t, "plot_joint_angles")
    implausible = marked_frames(implausible, t, "plot_joint_angles", "implausible")
    groups = group_angles(kin.angles)
    if not groups:
        raise InputError("plot_joint_angles: the kinematics have no angles")
    if {"knee", "elbow"} & groups.keys():
        groups = {g: ns for g, ns in groups.items() if g not in REDUNDANT_IN_PNG}
    ncols = 2 if len(groups) > 1 else 1
    nrows = int(np.ceil(len(groups) / ncols))
    fig, axes = new_figure(
        nrows, ncols, 2.4,
        f"Joint angles (deg; left dashed, right solid; gaps = undefined or missing), from {frame_label} positions"
        + marks_note(other_person, implausible))
    for ax, (group, names) in zip(axes.flat, groups.items()):
        colours = series_colours(names)
        finite = False
        for n in names:
            y = np.asarray(kin.angles[n], np.float64)
            if y.shape != t.shape:
                raise InputError(f"plot_joint_angles: angle {n!r} has shape {y.shape}, expected {t.shape}")
            finite |= bool(np.isfinite(y).any())
            style = "--" if side_of(n) == "left" else "-"
            ax.plot(*display_samples(t, y), style, color=_rgb(colours[n]), lw=1.0,
                    label=_series_label(_angle_label(n, group), y))
        shade_marks(ax, t, other_person, implausible)
        if not finite:
            _no_data(ax)
        set_panel_title(ax, ANGLE_GROUPS[group])
        ax.set_ylabel("angle (deg)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=2, loc="upper right")
    _time_limits(axes, t)
    for ax in axes.flat[len(groups):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    if len(groups) % ncols:  # the bottom-right panel is hidden: label the one above it
        axes[-2, -1].set_xlabel("time (s)")
        axes[-2, -1].tick_params(labelbottom=True)
    return fig


def joint_speeds_figure(kin, fps: float, units: str | None = None, *, frame_label: str = "world frame",
                        other_person=None, implausible=None):
    """The figure of :func:`plot_joint_speeds` (a :class:`matplotlib.figure.Figure` on an
    Agg canvas), for callers that want to inspect or restyle it.

    Raises:
        InputError: ``fps <= 0`` or not the kinematics' rate, ``kin.speed`` not ``(T, J)``,
            or ``other_person`` or ``implausible`` not ``(T,)``.
    """
    t = _time_axis(kin, fps, "plot_joint_speeds")
    other_person = marked_frames(other_person, t, "plot_joint_speeds")
    implausible = marked_frames(implausible, t, "plot_joint_speeds", "implausible")
    speed = kin.speed  # read a joint at a time (a long recording's is on disk)
    names = list(kin.joint_names)
    if tuple(np.shape(speed)) != (len(t), len(names)):
        raise InputError(f"plot_joint_speeds: speed must be {(len(t), len(names))}, got {np.shape(speed)}")
    unit = f"{kin.units if units is None else units}/s"
    groups = {title: [j for j in joints if j in names] for title, joints in SPEED_GROUPS.items()}
    groups = {k: v for k, v in groups.items() if v}
    fig, axes = new_figure(len(groups), 1, 2.6,
                           f"Joint speeds |v| ({unit}) in the {frame_label}; gaps = missing, unfiltered or run edges"
                           + marks_note(other_person, implausible))
    for ax, (title, joints) in zip(axes[:, 0], groups.items()):
        colours = series_colours(joints)
        finite = False
        for j in joints:
            y = np.asarray(speed[:, names.index(j)], np.float64)
            finite |= bool(np.isfinite(y).any())
            style = "--" if side_of(j) == "left" else "-"
            ax.plot(*display_samples(t, y), style, color=_rgb(colours[j]), lw=1.0,
                    label=_series_label(j.replace("_", " "), y))
        shade_marks(ax, t, other_person, implausible)
        if not finite:
            _no_data(ax)
        set_panel_title(ax, title)
        ax.set_ylabel(f"speed ({unit})")
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, ncol=2, loc="upper right")
    _time_limits(axes, t)
    axes[-1, 0].set_xlabel("time (s)")
    return fig


def save_png(fig, path_png: str | os.PathLike) -> Path:
    """Render ``fig`` to PNG (:data:`SAVE_DPI`) and write it atomically to ``path_png``."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=SAVE_DPI)
    with atomic_path(path_png) as tmp:
        tmp.write_bytes(buf.getvalue())
    return Path(path_png)


def plot_joint_angles(path_png: str | os.PathLike, kin, fps: float, *, frame_label: str = "world frame",
                      other_person=None, implausible=None) -> Path:
    """PNG of every joint angle of ``kin`` over time, one panel per joint or segment.

    Panels (:data:`ANGLE_GROUPS`, two columns): the ISB joint angles of
    :mod:`pcnet.stages.isb_angles` (trunk to pelvis and to gravity, hip, shoulder, knee and
    elbow flexion) beside the segment inclinations of
    :func:`pcnet.stages.kinematics.joint_angles` (trunk, thigh, upper arm against gravity;
    the unsigned knee/elbow flexions, :data:`REDUNDANT_IN_PNG`, are left out when the ISB
    ones are there: they would hide under them). Each panel has at most six
    series: the subject's left dashed in cool colours, right solid in warm colours
    (:func:`series_colours`). y: degrees (signs in ``isb_angles.POSITIVE_SIGN`` and
    ``docs/joint_angles.md``); x: time in seconds, ``frame / fps``. NaN (a missing joint, a
    degenerate frame, gimbal lock) is a gap in the line; a panel with no finite value says
    so.

    Args:
        path_png: destination ``.png`` (its folder must exist); written atomically.
        kin: a :class:`~pcnet.stages.kinematics.Kinematics` (``angles``: ``name -> (T,)``
            degrees).
        fps: frame rate in Hz; must equal ``kin.fps``.
        frame_label: the frame the positions were in (e.g. the runner's ``FRAME_LABELS``);
            between-segment angles do not depend on it, the angles to gravity use its +Y.
        other_person: ``(T,)`` bool, frames of another person than the recording's main one
            (the 2D track switched: :func:`pcnet.stages.flags.one_person_frames`), shaded grey.
        implausible: ``(T,)`` bool, frames whose motion exceeds the training motion's fastest
            (:func:`pcnet.stages.plausibility.implausible_frames`), shaded red
            (:data:`IMPLAUSIBLE_COLOUR`).

    Returns:
        the destination path.

    Raises:
        InputError: ``fps <= 0`` or not ``kin.fps``, no angles, an angle, ``other_person`` or
            ``implausible`` not ``(T,)``, or the destination folder missing / not writable.
    """
    return save_png(joint_angles_figure(kin, fps, frame_label=frame_label, other_person=other_person,
                                        implausible=implausible), path_png)


def plot_joint_speeds(
    path_png: str | os.PathLike, kin, fps: float, units: str | None = None, *, frame_label: str = "world frame",
    other_person=None, implausible=None,
) -> Path:
    """PNG of the speed ``|v|`` of key joints over time: wrists and elbows, ankles and
    knees, pelvis, thorax and head (:data:`SPEED_GROUPS`), one panel each.

    The speed is ``kin.speed`` (the norm of the central-difference velocity of the filtered
    positions): NaN where a joint is missing or unfiltered and at every run edge, drawn as
    a gap. It is a physical speed only in a fixed frame (the world frame); in the canonical
    frame, which turns with the pelvis, it includes rotating-frame terms (``frame_label``
    says which). Left dashed (cool colours), right solid (warm), midline neutral.

    Args:
        path_png: destination ``.png`` (its folder must exist); written atomically.
        kin: a :class:`~pcnet.stages.kinematics.Kinematics` (``speed``: ``(T, 17)``).
        fps: frame rate in Hz; must equal ``kin.fps``.
        units: length unit of the positions (``"m"``, ``"normalised"``); the y axis is in
            ``units/s``. Default: ``kin.units``.
        frame_label: the frame of the positions, shown in the title.
        other_person: ``(T,)`` bool, frames of another person, shaded grey (as
            :func:`plot_joint_angles`).
        implausible: ``(T,)`` bool, frames of motion faster than any training motion, shaded red (as
            :func:`plot_joint_angles`).

    Returns:
        the destination path.

    Raises:
        InputError: ``fps <= 0`` or not ``kin.fps``, ``speed``, ``other_person`` or
            ``implausible`` of the wrong shape, or the destination folder missing / not writable.
    """
    return save_png(joint_speeds_figure(kin, fps, units, frame_label=frame_label, other_person=other_person,
                                        implausible=implausible), path_png)


def gait_cycles_figure(cycles: Mapping[str, np.ndarray], angles: Iterable[str],
                       foot_off_percent: Mapping[str, float], title: str):
    """The clinical gait graph: per joint angle one panel over 0-100 % of the stride, each
    foot's mean (left dashed blue, right solid red, as the other figures) with a band of one
    standard deviation over its strides, and a vertical line at its mean foot off (stance to
    its left, swing to its right).

    Args:
        cycles: ``"{side}_{angle}_deg" -> (n_strides, P)`` degrees over ``P`` points from 0 to
            100 % (:func:`pcnet.stages.gait.cycle_normalised`); NaN = missing.
        angles: the angle names (no side, no ``_deg``), one panel each, in order.
        foot_off_percent: ``side -> `` mean stance in % of the stride (NaN: no line).
        title: the figure's title.

    Returns:
        the matplotlib figure (:func:`save_png` writes it).
    """
    angles = list(angles)
    fig, axes = new_figure(1, len(angles), 3.2, title)
    for ax, angle in zip(axes[0], angles):
        set_panel_title(ax, angle.replace("_", " ") + " (deg)")
        drawn = False
        for side, colour, style in (("left", LEFT_COLOURS[0], "--"), ("right", RIGHT_COLOURS[0], "-")):
            curves = np.asarray(cycles.get(f"{side}_{angle}_deg", np.zeros((0, 2))), np.float64)
            counted = np.isfinite(curves).sum(axis=0)
            if not counted.any():
                continue
            x = np.linspace(0.0, 100.0, curves.shape[1])
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN point: a gap
                mean, sd = np.nanmean(curves, axis=0), np.nanstd(curves, axis=0)
            ax.fill_between(x, mean - sd, mean + sd, color=_rgb(colour), alpha=0.15, linewidth=0)
            ax.plot(x, mean, style, color=_rgb(colour), label=f"{side} ({curves.shape[0]} strides)")
            off = foot_off_percent.get(side, float("nan"))
            if np.isfinite(off):
                ax.axvline(off, color=_rgb(colour), linestyle=style, linewidth=0.8)
            drawn = True
        if drawn:
            ax.legend(fontsize=8, loc="best")
        else:
            _no_data(ax)
        ax.set_xlim(0, 100)
        ax.set_xlabel("% of stride (foot strike to foot strike)")
        ax.grid(alpha=0.3)
    return fig
