"""Writers for pcnet's outputs: NPZ, per-frame kinematics CSV, OpenSim TRC and a PNG
of the wrists before and after rectification.

Every writer is atomic: it writes a hidden temporary file in the destination folder and
``os.replace``-s it onto the target (an atomic rename on POSIX and Windows when both
are on one file system). On any error the temporary file is removed and the target is
left as it was, so a crash never leaves a half-written file for a user to load.
"""

from __future__ import annotations

import csv
import itertools
import json
import os
import zipfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_path
from ..core.conventions import H36M_JOINTS, L_WRIST, METRES_PER_LENGTH_UNIT, R_WRIST, thigh_beyond_metres, validate_fps
from ..core.errors import InputError, import_extra
from ..core.framestore import FrameArray, frame_blocks
from ..kinematics import MIN_PROJECTED_FRACTION, PERIODIC_ANGLES, Kinematics, require_y_up
from .plots import display_samples, marked_frames, marks_note, new_figure, save_png, set_panel_title, shade_marks


# ---------------------------------------------------------------------------------------
# NPZ


def _npz_value(key: str, value: object) -> np.ndarray | FrameArray:
    if isinstance(value, FrameArray):
        return value
    if isinstance(value, Mapping):
        # Metadata dicts become JSON text so the file loads with allow_pickle=False; strict
        # JSON (RFC 8259 has no NaN), so every JSON reader takes it: a missing number is null.
        return np.asarray(json.dumps(finite_or_null(value), sort_keys=True, allow_nan=False))
    try:
        arr = np.asarray(value)
    except ValueError:  # numpy 2 refuses ragged nested sequences outright
        arr = np.asarray(value, dtype=object)
    if arr.dtype == object:
        raise TypeError(
            f"write_npz: {key!r} would be stored as a pickled object array; pass a numeric "
            f"array, a string, or a dict (stored as JSON)"
        )
    return arr


def finite_or_null(o: object) -> object:
    """``o`` (nested dicts, lists, tuples, numpy arrays and scalars, paths, text, numbers)
    with numpy values as Python ones, paths as text and NaN / inf as ``None``: what strict
    JSON (RFC 8259, no NaN) can hold.

    Raises:
        TypeError: a value of another type.
    """
    if isinstance(o, Mapping):
        return {k: finite_or_null(v) for k, v in o.items()}
    if isinstance(o, (list, tuple, np.ndarray)):
        return [finite_or_null(v) for v in (o.tolist() if isinstance(o, np.ndarray) else o)]
    if isinstance(o, np.generic):
        o = o.item()
    if isinstance(o, float) and not np.isfinite(o):
        return None
    if isinstance(o, Path):
        return str(o)
    if o is None or isinstance(o, (str, int, float, bool)):
        return o
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def write_npz(path: str | os.PathLike, *, replace: bool = True, **arrays_and_metadata: object) -> Path:
    """Write arrays and metadata to an uncompressed ``.npz``, atomically.

    Arrays, numbers, strings and bools are stored as numpy arrays under their keyword;
    a ``dict`` is stored as a 0-d string array holding its JSON text (so every key loads
    with ``np.load(path, allow_pickle=False)``; decode with ``json.loads(str(f[key]))``); a
    :class:`~pcnet.stages.core.framestore.FrameArray` (a long recording's array on disk) is
    copied in from its ``.npy`` file a block at a time, never read whole. The archive is what
    ``np.savez`` writes: stored (uncompressed) ``<key>.npy`` members, ZIP64 when needed.

    Args:
        path: destination file (the name is used as given; no ``.npz`` is appended).
        replace: whether an existing ``path`` may be replaced
            (:func:`~pcnet.stages.core.atomic.atomic_path`).
        **arrays_and_metadata: ``name=value`` pairs.

    Returns:
        the destination path.

    Raises:
        TypeError: a value that would need pickling (ragged lists, arbitrary objects).
        ValueError: no keyword given.
        pcnet.stages.core.errors.InputError: the file cannot be written, or ``replace`` is
            false and it appeared while this wrote.
    """
    if not arrays_and_metadata:
        raise ValueError("write_npz: nothing to write")
    payload = {k: _npz_value(k, v) for k, v in arrays_and_metadata.items()}
    with atomic_path(path, replace=replace) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_STORED,
                                                                  allowZip64=True) as zf:
        for key, value in payload.items():
            if isinstance(value, FrameArray):
                value.flush()
                zf.write(value.path, arcname=f"{key}.npy")  # zipfile copies the file in blocks
            else:
                with zf.open(f"{key}.npy", "w", force_zip64=True) as member:
                    np.lib.format.write_array(member, value, allow_pickle=False)
    return Path(path)


# ---------------------------------------------------------------------------------------
# CSV


#: Rows formatted per block by the CSV and TRC writers.
TEXT_BLOCK_ROWS = 2048


def unit_token(unit: str) -> str:
    """Unit string -> header-safe token: ``"m/s^2"`` -> ``"m_per_s2"``, ``"m"`` -> ``"m"``."""
    return unit.replace("/", "_per_").replace("^", "").replace(" ", "_")


# ---------------------------------------------------------------------------------------
# kinematics.csv's columns and their data dictionary

#: The ``frame`` field of a dictionary row: the frame a column's value is expressed in.
COLUMN_FRAMES = ("world", "canonical", "camera", "none")
#: Header of ``kinematics_columns.csv``.
DICTIONARY_HEADER = ("column", "unit", "frame", "definition")
_AXES = {
    "world": {"x": "+X (horizontal: the subject's forward over the first second)", "y": "+Y (up)",
              "z": "+Z (horizontal: X x Y, the subject's right at the start)"},
    "canonical": {"x": "+X (horizontal: the subject's anterior, pelvis heading)", "y": "+Y (up)",
                  "z": "+Z (horizontal: the subject's right along the hip line)"},
}
_HEIGHT = {"world": ", the height above the surface the feet stand on (y = 0: the ground, or a box's top)",
           "canonical": ", from the pelvis"}
#: What a world frame's heights are measured from when its floor is not one fitted plane
#: (:func:`pcnet.stages.world_frame.to_world_floor`), by the floor's ``kind``.
_FLOOR_HEIGHT = {
    "per frame": "; measured from a floor placed under each frame's lowest joint (no ground plane for the "
                 "recording), so a jump or a flight phase reads as standing, feet off the floor (on a bike's pedals, "
                 "raised while seated) move the pelvis up and down with them, and a lying body sits an ankle's height up.",
    "pelvis": "; no ankle was seen, so y = 0 is the pelvis's height, not the floor.",
}

#: Segment inclinations and unsigned flexions (:func:`pcnet.stages.kinematics.joint_angles`),
#: by name without side and ``_deg``: ``(frame, definition)``; ``{side}`` is the column's side.
_INCLINATIONS = {
    "trunk_inclination": ("canonical", "Angle between the pelvis->thorax segment and +Y (up): 0 = upright, 90 = "
                                       "lying, unsigned in [0, 180]."),
    "trunk_sagittal_inclination": ("canonical", "Pelvis->thorax segment against +Y in the sagittal (X-Y) plane of the "
                                                "pelvis heading frame: + leaning forward, - back."),
    "trunk_frontal_inclination": ("canonical", "Pelvis->thorax segment against +Y in the frontal (Z-Y) plane of the "
                                               "pelvis heading frame: + leaning towards the subject's right."),
    "thigh_sagittal_inclination": ("canonical", "The {side} thigh (hip->knee) against hanging straight down, in the "
                                                "sagittal plane of the pelvis heading frame: + knee in front of the hip "
                                                "(flexion), 90 = horizontal forward."),
    "thigh_frontal_inclination": ("canonical", "The {side} thigh (hip->knee) against hanging straight down, in the "
                                               "frontal plane of the pelvis heading frame: + knee away from the "
                                               "midline (abduction)."),
    "upper_arm_sagittal_inclination": ("canonical", "The {side} upper arm (shoulder->elbow) against hanging straight "
                                                    "down, in the sagittal plane of the pelvis heading frame: 90 = "
                                                    "horizontal forward, 180 = overhead."),
    "upper_arm_frontal_inclination": ("canonical", "The {side} upper arm (shoulder->elbow) against hanging straight "
                                                   "down, in the frontal plane of the pelvis heading frame: + away from "
                                                   "the midline, 90 = horizontal sideways."),
    "knee_flexion_unsigned": ("none", "180 minus the {side} hip-knee-ankle angle: 0 = straight, unsigned."),
    "elbow_flexion_unsigned": ("none", "180 minus the {side} shoulder-elbow-wrist angle: 0 = straight, unsigned; "
                                       "the same values as {side}_elbow_flexion_deg, ISB's elbow flexion (the upper "
                                       "arm's Z is that angle's plane normal), kept for the same name as the knee's."),
}
#: Definition of an angle column no table above describes (a test keeps it unused).
UNDESCRIBED_ANGLE = "An angle in degrees; no definition recorded for it (docs/joint_angles.md)."


def _angle_row(name: str) -> tuple[str, str]:
    """``(frame, definition)`` of the angle column ``name`` (with ``_deg``)."""
    frame, text = _angle_definition(name)
    return frame, text + _continuous(name)


def _angle_definition(name: str) -> tuple[str, str]:
    from ..isb_angles import DEFINITIONS, POSITIVE_SIGN

    if name in DEFINITIONS:
        frame = "canonical" if "to_gravity" in name else "none"
        return frame, (f"ISB joint angle: {DEFINITIONS[name]}; positive = {POSITIVE_SIGN.get(name, 'see docs/joint_angles.md')} "
                       f"(docs/joint_angles.md).")
    bare = name.removesuffix("_deg")
    side, _, rest = bare.partition("_")
    if side in ("left", "right") and rest in _INCLINATIONS:
        frame, text = _INCLINATIONS[rest]
        return frame, text.format(side=side) + _in_plane_empty(rest)
    if bare in _INCLINATIONS:
        frame, text = _INCLINATIONS[bare]
        return frame, text + _in_plane_empty(bare)
    return "none", UNDESCRIBED_ANGLE


def _continuous(name: str) -> str:
    """What a periodic angle's values may be (:data:`pcnet.stages.kinematics.PERIODIC_ANGLES`):
    continuous over time, so beyond its usual window where motion carries it there (a
    data-dictionary trial would have filtered a valid 285 deg out as impossible)."""
    level = PERIODIC_ANGLES.get(name.removesuffix("_deg"))
    if level is None:
        return ""
    return (f" Continuous over time: each run of frames reads in ({level:g}, {level + 360:g}] at its median, "
            f"and motion may carry it beyond (docs/joint_angles.md, Continuity in time).")


def _in_plane_empty(name: str) -> str:
    """When an in-plane inclination is empty (:func:`pcnet.stages.kinematics.joint_angles`)."""
    if not name.endswith(("sagittal_inclination", "frontal_inclination")):
        return ""
    near = np.degrees(np.arcsin(MIN_PROJECTED_FRACTION))
    return f" Empty where the segment lies within {near:.1f} deg of the plane's normal: no angle in that plane."


def kinematics_columns(
    joints: Sequence[str],
    units: str,
    angles: Iterable[str],
    extra: Mapping[str, tuple[str, str, str] | None],
    frame: str = "world",
    unobservable: Mapping[str, tuple[str, str]] | None = None,
    empty_angles: Mapping[str, str] | None = None,
    floor: str | None = None,
    up_uncertainty: str | None = None,
    unplaced: str | None = None,
    rates: Iterable[str] = (),
) -> list[tuple[str, str, str, str]]:
    """The columns of ``kinematics.csv``, in order, each ``(column, unit, frame, definition)``:
    the one source of its header (:func:`write_kinematics_csv`) and of its data dictionary
    (``kinematics_columns.csv``, :func:`write_column_dictionary`).

    Args:
        joints: joint names, in column order.
        units: the length unit (``"m"``, ``"normalised"``, ...); velocities are ``units/s``,
            accelerations ``units/s^2``.
        angles: the angle names (``Kinematics.angles``' keys, without ``_deg``).
        extra: extra column name -> ``(unit, frame, definition)``, or ``None`` when not
            described (the dictionary then refuses it).
        frame: the frame of positions, velocities and accelerations, ``"world"`` or
            ``"canonical"``.
        unobservable: joint -> ``(axes, reason)``: the axes (``"xz"``, ``"xyz"``) of that joint
            the input does not observe; their positions, velocities and accelerations and the
            joint's speed are written empty (:func:`blank_unobservable`) and ``reason`` (one
            clause) is said in their definitions.
        empty_angles: angle name -> why the run leaves it empty (one clause), said in its
            definition.
        floor: the world frame's floor kind (:class:`~pcnet.stages.floor.Floor`): ``"per
            frame"`` or ``"pelvis"`` says in the heights' definitions what y = 0 is; ``"plane"``
            or ``None``: the floor itself.
        up_uncertainty: how uncertain this run's up is (one clause), said in the definitions of
            the angles measured against it (frame ``canonical``: the up is their reference, so
            its error is theirs; a user trial read a 15 deg spread of trunk lean between four
            cameras from columns that gave no uncertainty).
        unplaced: which frames have a pose but no place in the world frame (one clause), said
            in every position, velocity, acceleration and speed definition: written empty there
            (:func:`blank_unobservable`'s ``rows``).
        rates: the angle names with a rate column ``{name}_deg_per_s``
            (:attr:`Kinematics.angle_rates`' keys), after the angles.

    Returns:
        a list of ``(column, unit, frame, definition)``; ``definition`` is ``None`` for an
        undescribed extra column.
    """
    if frame not in _AXES:
        raise ValueError(f"kinematics_columns: frame must be one of {sorted(_AXES)}, got {frame!r}")
    u, v, a = unit_token(units), unit_token(f"{units}/s"), unit_token(f"{units}/s^2")
    unobservable = dict(unobservable or {})
    hidden = {j: axes for j, (axes, _) in unobservable.items()}
    # root-relative horizontal positions: the other joints' are relative to the unobserved pelvis path
    relative = hidden.get("pelvis", "")
    cols = [("frame", "-", "none", "Frame index from 0, in the input's frame order."),
            ("time_s", "s", "none", "Time of the frame from the start of the recording, frame / fps.")]
    for j in joints:
        joint = j.replace("_", " ")
        gone = hidden.get(j, "")
        why = f"; empty in this run: {unobservable[j][1]}" if j in unobservable else ""

        def note(axis: str, j=j, gone=gone, why=why) -> str:
            if axis in gone:
                return why + "."
            if j != "pelvis" and axis in relative:
                return "; relative to the pelvis, whose own path along this axis is not observable in this run."
            if axis == "y" and frame == "world" and floor in _FLOOR_HEIGHT:
                return _FLOOR_HEIGHT[floor]
            return "."

        motion = len(cols)  # the joint's positions, velocities, accelerations and speed start here
        for c in "xyz":
            cols.append((f"{j}_{c}_{u}", units, frame, f"Position of the {joint} joint centre along {_AXES[frame][c]}"
                         f"{_HEIGHT[frame] if c == 'y' else ''}, low-pass filtered (raw where {j}_unfiltered = 1, "
                         f"empty where {j}_missing = 1)" + note(c)))
        for c in "xyz":
            cols.append((f"{j}_v{c}_{v}", f"{units}/s", frame, f"Velocity of the {joint} along {_AXES[frame][c]}, "
                         f"the central difference of the filtered positions (empty at a run's first and last frame "
                         f"and where missing or unfiltered)" + note(c)))
        for c in "xyz":
            cols.append((f"{j}_a{c}_{a}", f"{units}/s^2", frame, f"Acceleration of the {joint} along "
                         f"{_AXES[frame][c]}, the second central difference of the filtered positions (empty where "
                         f"the velocity is); kinematic, without gravity (an accelerometer reads it plus 9.81 m/s^2 "
                         f"up)" + note(c)))
        speed_note = why if gone else ("; it includes the rotating frame's terms (the canonical frame turns with "
                                       "the pelvis)" if frame == "canonical" else
                                       # a sports trial read a wrist's speed as the whole body's
                                       f"; along {' and '.join(relative)} relative to the pelvis, whose own path "
                                       f"is not observable in this run" if relative and j != "pelvis" else "")
        cols.append((f"{j}_speed_{v}", f"{units}/s", frame, f"Speed of the {joint}, the norm of its velocity (empty "
                     f"where the velocity is){speed_note}."))
        if unplaced:
            cols[motion:] = [(name, unit, of, f"{text} Empty in {unplaced}.") for name, unit, of, text in cols[motion:]]
        cols.append((f"{j}_missing", "0/1", "none", f"1 where the {joint} position is missing in this frame (NaN "
                     f"input, or masked by low 2D confidence), else 0."))
        cols.append((f"{j}_unfiltered", "0/1", "none", f"1 where the {joint} position is finite but raw (its run of "
                     f"frames too short for the low-pass filter, so no velocity or acceleration), else 0."))
    empty_angles = dict(empty_angles or {})
    for name in angles:
        column = f"{name}_deg"
        frame_of, definition = _angle_row(column)
        if name in empty_angles:
            definition = f"{definition.rstrip('.')}; empty in this run: {empty_angles[name]}."
        elif up_uncertainty and frame_of == "canonical":
            definition = f"{definition.rstrip('.')}. Against this run's up, which is {up_uncertainty}."
        cols.append((column, "deg", frame_of, definition))
    for name in rates:
        column = f"{name}_deg"
        periodic = ", taken modulo 360 deg (a turn is not motion)" if name in PERIODIC_ANGLES else ""
        definition = (f"Rate of change of {column} (for an ISB angle, the joint angular velocity): the difference "
                      f"of its values at the frames either side over 2 / fps{periodic}; empty where the angle is "
                      f"empty in the frame or either neighbour (a run's first and last frame, a gap) and where it "
                      f"needs a raw (unfiltered) joint position in any of those three frames.")
        if name in empty_angles:
            definition = f"{definition.rstrip('.')}; empty in this run: {empty_angles[name]}."
        cols.append((f"{column}_per_s", "deg/s", _angle_row(column)[0], definition))
    for name, described in extra.items():
        cols.append((name, *described) if described is not None else (name, "", "", None))
    return cols


def blank_unobservable(k: Kinematics, unobservable: Mapping[str, tuple[str, str]] | None,
                       rows: np.ndarray | None = None) -> Kinematics:
    """``k`` with the unobservable axes' positions, velocities and accelerations and those
    joints' speeds set to NaN (``unobservable`` as :func:`kinematics_columns`'), and every
    joint's in ``rows`` (``(k.num_frames,)`` bool: frames whose place in the world frame is not
    known though the pose is; their angles kept); ``k`` itself when there is nothing to blank."""
    rows = None if rows is None or not np.any(rows) else np.asarray(rows, bool)
    if not unobservable and rows is None:
        return k
    names = list(k.joint_names)
    pos, vel, acc, speed = (np.array(x, dtype=np.float64) for x in (k.positions, k.velocity, k.acceleration, k.speed))
    for j, (axes, _) in (unobservable or {}).items():
        if j not in names:
            continue
        i, c = names.index(j), ["xyz".index(ax) for ax in axes]
        pos[:, i, c] = vel[:, i, c] = acc[:, i, c] = np.nan
        speed[:, i] = np.nan
    if rows is not None:
        pos[rows] = vel[rows] = acc[rows] = speed[rows] = np.nan
    return replace(k, positions=pos, velocity=vel, acceleration=acc, speed=speed)


def _check_dictionary(columns: Sequence[tuple[str, str, str, str]]) -> None:
    bare = [c[0] for c in columns if not c[3]]
    if bare:
        raise ValueError(f"write_column_dictionary: expected a definition for every column, got none for {bare}")
    odd = [c[0] for c in columns if c[2] not in COLUMN_FRAMES]
    if odd:
        raise ValueError(f"write_column_dictionary: expected frames in {COLUMN_FRAMES}, got others for {odd}")


def write_column_dictionary(path: str | os.PathLike, columns: Sequence[tuple[str, str, str, str]]) -> Path:
    """Write ``kinematics_columns.csv``: one row per column of ``kinematics.csv``
    (:func:`kinematics_columns`), with :data:`DICTIONARY_HEADER`, atomically.

    Raises:
        ValueError: a column without a definition or with a frame not in :data:`COLUMN_FRAMES`.
    """
    _check_dictionary(columns)
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(DICTIONARY_HEADER)
        writer.writerows(columns)
    return Path(path)


def _fmt(v: float) -> str:
    # Empty field for missing values, as the TRC writer does; 7 significant digits keep
    # micrometre resolution on metre-scale data.
    return f"{v:.7g}" if v == v else ""


def write_kinematics_csv(
    path: str | os.PathLike,
    frame_index: np.ndarray,
    time_s: np.ndarray,
    kinematics: Kinematics | Iterable[Kinematics],
    extra_columns: Mapping[str, np.ndarray] | None = None,
    joints: Sequence[str] | None = None,
    *,
    dictionary: str | os.PathLike | None = None,
    extra_definitions: Mapping[str, tuple[str, str, str]] | None = None,
    frame: str = "world",
    unobservable: Mapping[str, tuple[str, str]] | None = None,
    empty_angles: Mapping[str, str] | None = None,
    floor: str | None = None,
    up_uncertainty: str | None = None,
    unplaced: str | None = None,
) -> Path:
    """Write one CSV row per frame with positions, velocities, accelerations, speeds,
    per-joint missing/unfiltered flags and angles of the kinematics (world or canonical frame), atomically.

    Columns, in order: ``frame``, ``time_s``; per joint ``{joint}_{x,y,z}_{u}``,
    ``{joint}_{vx,vy,vz}_{u}_per_s``, ``{joint}_{ax,ay,az}_{u}_per_s2``,
    ``{joint}_speed_{u}_per_s``, ``{joint}_missing``, ``{joint}_unfiltered``
    (``u`` = ``kinematics.units``, e.g. ``m``); per angle ``{angle}_deg``; per angle
    rate (:attr:`Kinematics.angle_rates`) ``{angle}_deg_per_s``; then
    ``extra_columns`` under their own names (put the unit in the name, e.g.
    ``tilt_error_deg``). Axes: x anterior, y up, z subject's right (the world frame of a static camera, else canonical).
    Missing values (NaN) are empty fields. Comma-separated, ``\\n`` line ends, UTF-8,
    written with the :mod:`csv` module.

    **Flags** (``0``/``1``, never empty): ``{joint}_missing`` = 1 where the joint's
    position is NaN in that frame (:attr:`Kinematics.missing`; its position, velocity
    and acceleration fields are empty); ``{joint}_unfiltered`` = 1 where the position is
    finite but raw, its run of finite frames too short for the low-pass filter
    (:attr:`Kinematics.unfiltered`; the position is written, velocity and acceleration
    are empty). An empty velocity/acceleration with both flags 0 is a run's first or
    last frame (recording ends, next to a gap), where central differences are undefined
    (:func:`~pcnet.stages.kinematics.derivatives`). Two 0/1 columns per joint rather
    than one coded flags column: a spreadsheet or ``pandas`` user can sum or filter them
    directly, without a code table, at the cost of two narrow columns per joint.

    Args:
        path: destination ``.csv``.
        frame_index: ``(T,)`` integer frame numbers (e.g. source-video frame indices).
        time_s: ``(T,)`` times in seconds.
        kinematics: :class:`~pcnet.stages.kinematics.Kinematics` with ``T`` frames, or
            consecutive chunks of it (:func:`~pcnet.stages.kinematics.kinematics_chunks`),
            written as they come so a long recording never needs all its rows in memory.
        extra_columns: optional ``name -> (T,)`` numeric or bool columns.
        joints: joint names to include (default: all 17 H36M-17 joints).
        dictionary: also write the data dictionary of these columns there
            (``kinematics_columns.csv``, :func:`write_column_dictionary`), from the same
            :func:`kinematics_columns` list as the header.
        extra_definitions: ``name -> (unit, frame, definition)`` of the ``extra_columns``
            (needed for each of them with ``dictionary``).
        frame: ``"world"`` or ``"canonical"``: the frame of the positions (for the dictionary).
        unobservable: joint -> ``(axes, reason)``: axes the input does not observe (the
            pelvis's horizontal path from a root-relative lifter), written empty, with
            ``reason`` in the dictionary (:func:`kinematics_columns`).
        empty_angles: angle name -> why the run leaves it empty, for the dictionary.
        floor: the world frame's floor kind, for the heights' definitions (:func:`kinematics_columns`).
        up_uncertainty: how uncertain the up is, for the angles against it (:func:`kinematics_columns`).
        unplaced: which frames the caller's kinematics leave without positions, for the
            dictionary (:func:`kinematics_columns`).

    Returns:
        the destination path.

    Raises:
        ValueError: a column whose length is not ``T``, chunks that do not add up to ``T``
            frames, an unknown joint, or a duplicate column name.
    """
    chunks = iter([kinematics]) if isinstance(kinematics, Kinematics) else iter(kinematics)
    first = next(chunks, None)
    if first is None:
        raise ValueError("write_kinematics_csv: no kinematics given")
    frame_index = np.asarray(frame_index)
    time_s = np.asarray(time_s, dtype=np.float64)
    T = first.num_frames if isinstance(kinematics, Kinematics) else len(frame_index)
    extra = dict(extra_columns or {})
    for name, col in (("frame_index", frame_index), ("time_s", time_s), *extra.items()):
        if np.shape(col) != (T,):
            raise ValueError(
                f"write_kinematics_csv: column {name!r} must have shape ({T},), got {np.shape(col)}"
            )
    names = list(first.joint_names)
    chosen = list(joints) if joints is not None else names
    unknown = [j for j in chosen if j not in names]
    if unknown:
        raise ValueError(f"write_kinematics_csv: unknown joints {unknown}; known: {names}")
    columns = [names.index(j) for j in chosen]

    described = {name: (extra_definitions or {}).get(name) for name in extra}
    listed = kinematics_columns(chosen, first.units, first.angles, described, frame, unobservable, empty_angles,
                                floor, up_uncertainty, unplaced, first.angle_rates)
    header = [c[0] for c in listed]
    dup = {h for h in header if header.count(h) > 1}
    if dup:
        raise ValueError(f"write_kinematics_csv: duplicate column names {sorted(dup)}")
    if dictionary is not None:
        _check_dictionary(listed)  # before any work; written once the table is

    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        done = 0
        for k in itertools.chain([first], chunks):
            k = blank_unobservable(k, unobservable)
            # Rows formatted a block at a time: .tolist() of a whole 2-hour table is GBs of floats.
            for lo in range(0, k.num_frames, TEXT_BLOCK_ROWS):
                hi = min(k.num_frames, lo + TEXT_BLOCK_ROWS)
                rows = slice(done + lo, done + hi)
                if rows.stop > T:
                    raise ValueError(f"write_kinematics_csv: the kinematics chunks have more than the {T} frames of frame_index")
                blocks = [time_s[rows, None]]
                for i in columns:
                    blocks += [k.positions[lo:hi, i], k.velocity[lo:hi, i], k.acceleration[lo:hi, i],
                               k.speed[lo:hi, i, None], k.missing[lo:hi, i, None], k.unfiltered[lo:hi, i, None]]
                blocks += [np.asarray(ang, np.float64)[lo:hi, None] for ang in k.angles.values()]
                blocks += [np.asarray(rate, np.float64)[lo:hi, None] for rate in k.angle_rates.values()]
                blocks += [np.asarray(col, np.float64)[rows, None] for col in extra.values()]
                table = np.concatenate(blocks, axis=1)
                for f, row in zip(frame_index[rows].tolist(), table.tolist()):
                    writer.writerow([str(f), *map(_fmt, row)])
            done += k.num_frames
        if done != T:
            raise ValueError(f"write_kinematics_csv: the kinematics chunks have {done} frames, frame_index has {T}")
    if dictionary is not None:
        write_column_dictionary(dictionary, listed)
    return Path(path)


# ---------------------------------------------------------------------------------------
# TRC


def write_trc(
    path: str | os.PathLike,
    poses: np.ndarray,
    fps: float,
    joint_names: Sequence[str] = H36M_JOINTS,
    units: str = "m",
    frames: np.ndarray | None = None,
    check_up: bool = True,
) -> Path:
    """Write Y-up poses (the recording's world frame, :mod:`pcnet.stages.world_frame`, or the
    canonical frame) as an OpenSim ``.trc`` marker file, atomically.

    Layout (as read by OpenSim 4's ``TRCFileAdapter``, opensim-core
    ``OpenSim/Common/TRCFileAdapter.cpp``): tab-separated;
    line 1 ``PathFileType 4 (X/Y/Z) <file name>``; line 2 the eight keys ``DataRate
    CameraRate NumFrames NumMarkers Units OrigDataRate OrigDataStartFrame OrigNumFrames``;
    line 3 their values; line 4 ``Frame# Time`` and each marker name followed by two
    empty fields; line 5 ``X1 Y1 Z1 X2 ...``; line 6 empty; then one row per frame:
    1-based frame number, time ``(frame - 1) / fps`` in s, and x y z per marker.

    Coordinates: the world and canonical frames have OpenSim's ground-frame axis roles (X
    forward, Y up, Z right), so values are written unchanged. World-frame markers stand on
    the floor (y = 0) with the pelvis at x = z = 0 (a root-relative lifter gives no
    horizontal translation); canonical markers are pelvis-centred.

    **Missing markers**: a NaN marker is written as three empty fields. OpenSim's reader
    keeps empty tokens and stores such a marker as NaN, which inverse kinematics skips
    for that frame. Every value, including the last, is followed by a tab (as OpenSim's
    own writer does): the tokenizer drops only a final empty token, so a missing last
    marker still yields the expected column count. Readers that collapse consecutive
    tabs (some older tools) cannot read missing markers in any TRC.

    Args:
        path: destination ``.trc``.
        poses: ``(T, J, 3)`` world-frame (or canonical) poses in ``units``; NaN for missing.
        fps: frame rate in Hz (DataRate, CameraRate, OrigDataRate).
        joint_names: ``J`` marker names (no tabs or line breaks); default H36M-17.
        units: ``"m"`` (OpenSim's default) or ``"mm"``.
        frames: ``(T,)`` 0-based frame numbers of the rows in the recording they come from
            (increasing), for a file that leaves some frames out: ``Frame#`` is ``frames + 1``
            and the time ``frames / fps``; default ``0 .. T-1``.
        check_up: refuse H36M-17 markers whose trunk points down in most frames
            (camera-frame poses, +Y down; :func:`~pcnet.stages.kinematics.require_y_up`).

    Returns:
        the destination path.

    Raises:
        InputError (a ValueError): as :func:`_checked_markers`.
        ValueError: ``frames`` not ``T`` increasing integers.
    """
    X, names, fps = _checked_markers("write_trc", poses, joint_names, fps, units, check_up)
    T, J = X.shape[:2]
    numbers = np.arange(T) if frames is None else np.asarray(frames)
    if numbers.shape != (T,) or not np.issubdtype(numbers.dtype, np.integer) or (np.diff(numbers) <= 0).any():
        raise ValueError(f"write_trc: frames must be {T} increasing integers, got shape {numbers.shape}")
    rate = f"{fps:.6g}"
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{Path(path).name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
        f"{rate}\t{rate}\t{T}\t{J}\t{units}\t{rate}\t1\t{T}",
        "Frame#\tTime\t" + "".join(f"{n}\t\t\t" for n in names),
        "\t\t" + "".join(f"X{i}\tY{i}\tZ{i}\t" for i in range(1, J + 1)),
        "",
    ]
    with atomic_path(path) as tmp, open(tmp, "w", newline="\n", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
        for lo in range(0, T, TEXT_BLOCK_ROWS):
            block = np.asarray(X[lo : lo + TEXT_BLOCK_ROWS], np.float64).reshape(-1, J * 3)
            for t, row in zip(numbers[lo : lo + TEXT_BLOCK_ROWS].tolist(), block.tolist()):
                fields = "\t".join(_fmt_trc(v) for v in row)
                fh.write(f"{t + 1}\t{t / fps:.6f}\t{fields}\t\n")
    return Path(path)


def require_ezc3d():
    """The ezc3d module. Raises InputError with one line naming the extra when it is missing."""
    return import_extra("ezc3d", 'C3D export needs ezc3d: pip install "pcnet[c3d]"')


def write_c3d(
    path: str | os.PathLike,
    poses: np.ndarray,
    fps: float,
    joint_names: Sequence[str] = H36M_JOINTS,
    units: str = "m",
    check_up: bool = True,
    description: str = "",
    software: str = "",
) -> Path:
    """Write Y-up poses (world or canonical frame, as :func:`write_trc`) as a C3D marker file
    with ezc3d (https://github.com/pyomeca/ezc3d), atomically.

    POINT:RATE = ``fps``, POINT:LABELS = ``joint_names``, POINT:UNITS = ``units``; the
    coordinates are written unchanged (X forward, Y up, Z right; POINT:X_SCREEN ``+X`` and
    POINT:Y_SCREEN ``+Y`` say so to viewers); a missing marker is passed to ezc3d as NaN,
    which stores it with residual -1 (C3D's invalid sample), a present one with residual 0.
    POINT:DESCRIPTIONS gives every marker ``description`` and MANUFACTURER:SOFTWARE /
    VERSION_LABEL the writer ``software`` ("name version") where given (C3D User Guide's
    MANUFACTURER group): a lab tool shows what the markers are and where they came from.

    Args:
        path: destination ``.c3d``; poses: ``(T, J, 3)`` float; fps: Hz; joint_names: ``J``
            labels; units: ``"m"`` or ``"mm"``; check_up: as :func:`write_trc`'s;
            description: the markers' frame and meaning; software: ``"pcnet 1.2.3"``.

    Returns:
        the destination path.

    Raises:
        InputError: ezc3d is not installed (one line naming the extra), or as
            :func:`_checked_markers`.
    """
    ezc3d = require_ezc3d()
    X, names, fps = _checked_markers("write_c3d", poses, joint_names, fps, units, check_up)
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [float(fps)]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = tuple(names)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = [units]
    # Which axes point right and up on screen (C3D User Guide, POINT:X_SCREEN/Y_SCREEN):
    # viewers that assume a Z-up lab would otherwise show this Y-up body lying down.
    c3d.add_parameter("POINT", "X_SCREEN", ["+X"])
    c3d.add_parameter("POINT", "Y_SCREEN", ["+Y"])
    if description:
        c3d["parameters"]["POINT"]["DESCRIPTIONS"]["value"] = [description] * len(names)
    if software:
        name, _, version = software.partition(" ")
        c3d.add_parameter("MANUFACTURER", "SOFTWARE", [name])
        c3d.add_parameter("MANUFACTURER", "VERSION_LABEL", [version or "unknown"])
    points = np.ones((4, X.shape[1], X.shape[0]))
    # ezc3d takes the whole point array: the C3D export (opt-in, --c3d) holds the recording.
    for rows in frame_blocks(len(X)):
        points[:3, :, rows] = np.transpose(np.asarray(X[rows], np.float64), (2, 1, 0))
    c3d["data"]["points"] = points
    # C3D marks an invalid sample by a negative residual (c3d.org, "The C3D File Format User
    # Guide", 3D point data); ezc3d writes 0 (valid) unless told, NaN coordinates or not.
    missing = ~np.isfinite(points[:3]).all(axis=0)
    c3d["data"]["meta_points"] = {"residuals": np.where(missing, -1.0, 0.0)[None],
                                  "camera_masks": np.zeros((7, *missing.shape), bool)}
    with atomic_path(path, suffix=".c3d") as tmp:
        c3d.write(str(tmp))
    return Path(path)


def _checked_markers(who: str, poses, joint_names, fps: float, units: str,
                     check_up: bool = True) -> tuple[np.ndarray, list[str], float]:
    """``(poses as (T, J, 3) float64, J marker names, fps as a float)`` for a marker file writer
    (a :class:`~pcnet.stages.core.framestore.FrameArray` stays on disk: read it a block at a
    time).

    Raises:
        InputError: a shape/name mismatch, no frame or no finite marker, a name with a
            tab/newline, duplicate or empty names, a frame rate :func:`validate_fps` refuses,
            units other than ``"m"``/``"mm"``, or H36M-17 markers whose median thigh in those
            units is no person's (:func:`~pcnet.stages.core.conventions.thigh_beyond_metres`:
            centimetres or millimetres given as metres), naming ``who``; with ``check_up``,
            H36M-17 markers whose trunk points down in most frames (a notebook trial wrote
            camera-frame poses, +Y down, as an upside-down skeleton for OpenSim).
    """
    X = poses if isinstance(poses, FrameArray) else np.asarray(poses, dtype=np.float64)
    names = [str(n) for n in joint_names]
    if X.ndim != 3 or X.shape[2] != 3 or X.shape[1] != len(names):
        raise InputError(f"{who}: expected (T, {len(names)}, 3) markers, got {X.shape}")
    if any(("\t" in n or "\n" in n or not n.strip()) for n in names) or len(set(names)) != len(names):
        raise InputError(f"{who}: marker names must be unique, non-empty, without tabs: {names}")
    fps = validate_fps(fps, f"{who}: fps")
    if units not in ("m", "mm"):
        raise InputError(f"{who}: units must be 'm' or 'mm', got {units!r}")
    if not any(np.isfinite(X[rows]).any() for rows in frame_blocks(len(X))):
        raise InputError(f"{who}: expected at least one frame with a finite marker, got {len(X)} frames without one")
    if names == list(H36M_JOINTS):
        thigh = thigh_beyond_metres(X, METRES_PER_LENGTH_UNIT[units])  # a joint column at a time
        if thigh is not None:
            raise InputError(f"{who}: expected markers in {units!r}, got a median thigh of {thigh:.3g} m in them, no "
                             f"person's (another unit?)")
        if check_up:
            require_y_up(X, who)
    return X, names, fps


def _fmt_trc(v: float) -> str:
    return f"{v:.6f}" if v == v else ""


# ---------------------------------------------------------------------------------------
# PNG


def wrists_figure(
    camera: np.ndarray,
    canonical: np.ndarray,
    fps: float,
    acc_camera: np.ndarray,
    acc_canonical: np.ndarray,
    units: str = "m",
    frame_label: str = "canonical frame (x anterior, y up, z right)",
    other_person: np.ndarray | None = None,
    implausible: np.ndarray | None = None,
):
    """The figure of wrist trajectories and accelerations before and after rectification (a
    :class:`matplotlib.figure.Figure` on an Agg canvas; :func:`plot_wrists` writes it).

    Two columns (camera frame | ``frame_label``: the recording's world frame or the
    canonical frame) by three rows: wrist position
    components, wrist acceleration components, and acceleration magnitude, against time
    in seconds; left wrist dashed, right wrist solid. The components show what
    rectification changes (camera-y mixes vertical and depth motion when the camera is
    tilted; canonical-y is vertical). The magnitude row matches between columns only
    when the rotation is constant over time (one rotation per sequence); per-frame
    rotations make the canonical frame a moving frame, and its jitter shows up there.
    Rendered with matplotlib's Agg canvas (no pyplot, no display needed).

    Args:
        camera: ``(T, 17, 3)`` root-relative camera-frame poses (x right, y down, z forward),
            ``units``: plotted as positions from the pelvis along the camera's axes.
        canonical: ``(T, 17, 3)`` rectified poses (x anterior, y up, z right: world or
            canonical frame), ``units``.
        fps: frame rate in Hz.
        acc_camera, acc_canonical: ``(T, 2, 3)`` left- and right-wrist accelerations in
            ``units/s^2`` (only the wrists, so a long recording need not keep every joint's).
        units: length unit label.
        frame_label: title of the rectified column.
        other_person, implausible: ``(T,)`` bool frames shaded grey (another person's, after
            a 2D track switch) and red (motion faster than any training motion), as in ``angles.png``.

    Raises:
        ValueError: mismatched shapes or ``fps <= 0``.
    """
    shapes = [tuple(np.shape(a)) for a in (camera, canonical, acc_camera, acc_canonical)]
    T = shapes[0][0] if shapes[0] else 0
    if shapes != [(T, 17, 3), (T, 17, 3), (T, 2, 3), (T, 2, 3)]:
        raise ValueError(f"wrists_figure: expected (T, 17, 3) poses and (T, 2, 3) wrist accelerations, got {shapes}")
    if not fps > 0:
        raise ValueError(f"wrists_figure: fps must be > 0, got {fps!r}")
    # Only the wrists are drawn: two joints read (a long recording's poses are on disk).
    # Kept in their own precision (float32 for a run's): display_samples converts one series at a time.
    cam, can = (np.asarray(p[:, [L_WRIST, R_WRIST]]) for p in (camera, canonical))
    acam, acan = (np.asarray(a) for a in (acc_camera, acc_canonical))
    t = np.arange(T) / fps
    other_person = marked_frames(other_person, t, "wrists_figure")
    implausible = marked_frames(implausible, t, "wrists_figure", "implausible")
    acc_u = f"{units}/s²"
    columns = (
        ("camera axes, from the pelvis (x right, y down, z forward)", cam, acam, ("x", "y", "z")),
        (frame_label, can, acan, ("x", "y", "z")),
    )
    comp_colors = ("tab:red", "tab:green", "tab:blue")
    fig, axes = new_figure(3, 2, 8.0 / 3.0,
                           f"Wrists before (camera frame) and after ({frame_label.split(' (')[0]}) rectification"
                           + marks_note(other_person, implausible), title_size=12.0)
    for col, (title, pos, acc, labels) in enumerate(columns):
        ax_p, ax_a, ax_m = axes[:, col]
        for w, (side, style) in enumerate((("left", "--"), ("right", "-"))):
            for c in range(3):
                ax_p.plot(*display_samples(t, pos[:, w, c]), style, color=comp_colors[c], lw=1,
                          label=f"{side} wrist {labels[c]}")
                ax_a.plot(*display_samples(t, acc[:, w, c]), style, color=comp_colors[c], lw=0.8,
                          label=f"{side} wrist a{labels[c]}")
            ax_m.plot(*display_samples(t, np.linalg.norm(acc[:, w].astype(np.float64), axis=-1)), style, color="k", lw=0.8,
                      label=f"{side} wrist |a|")
        set_panel_title(ax_p, title, 12.0)
        ax_p.set_ylabel(f"position ({units})")
        ax_a.set_ylabel(f"acceleration ({acc_u})")
        ax_m.set_ylabel(f"|acceleration| ({acc_u})")
        ax_m.set_xlabel("time (s)")
        for ax in (ax_p, ax_a, ax_m):
            shade_marks(ax, t, other_person, implausible)
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7, ncol=2, loc="upper right")
    return fig


def plot_wrists(path_png: str | os.PathLike, camera: np.ndarray, canonical: np.ndarray, fps: float,
                acc_camera: np.ndarray, acc_canonical: np.ndarray, units: str = "m",
                frame_label: str = "canonical frame (x anterior, y up, z right)", other_person: np.ndarray | None = None,
                implausible: np.ndarray | None = None) -> Path:
    """:func:`wrists_figure` as a PNG at ``path_png``, written atomically.

    Returns:
        the destination path.

    Raises:
        ValueError: as :func:`wrists_figure`.
    """
    return save_png(wrists_figure(camera, canonical, fps, acc_camera, acc_canonical, units, frame_label,
                                  other_person, implausible), path_png)
