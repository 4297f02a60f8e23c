"""Any 3D joint array (.npy, .npz, .csv) with a stated layout, axes and units -> :class:`Poses3D`.

The only maths is what the user declares: an axis permutation with sign flips (``axes=``)
and a unit scale (``units=``).
"""

from __future__ import annotations

import collections
import csv
import math
import re
from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import get_layout, shape_hint

from .registry import register_3d
from .types import AdapterError, Poses3D
from .validate import (ROOT_RELATIVE_MAX, as_path, checked_poses, load_array_file, nonfinite_frames, pelvis_offset,
                       require_file, require_numeric, require_some_finite)

# Letter -> (camera axis, sign) in the OpenCV camera frame: x Right, y Down, z Forward.
_AXIS_LETTERS = {"R": (0, 1.0), "L": (0, -1.0), "D": (1, 1.0), "U": (1, -1.0), "F": (2, 1.0), "B": (2, -1.0)}
# Unit -> (scale, unit tag of the result).
_UNITS = {"m": (1.0, "m"), "cm": (0.01, "m"), "mm": (0.001, "m"), "normalised": (1.0, "normalised"), "px": (1.0, "px")}


def axes_to_camera(axes: str) -> np.ndarray:
    """Matrix ``M`` (3, 3) with ``X_cam = X_src @ M`` for row-vector joints.

    ``axes`` has one letter per source axis (x, y, z) naming the camera-frame direction it
    points to: ``R``/``L`` (image right/left), ``D``/``U`` (image down/up), ``F``/``B``
    (away from / towards the camera); each of the three pairs used once. ``"RDF"`` is the
    identity (OpenCV), ``"RUB"`` flips y and z (OpenGL camera), ``"RFU"`` is a z-up frame
    looking along +y. A left-handed source (e.g. ``"RUF"``) becomes right-handed through
    its single flip: that is a relabelling, not a mirror of the body, because the letters
    say where each source axis really points.

    Raises:
        ValueError: not three letters from R/L/U/D/F/B with each pair once.
    """
    spec = str(axes).upper()
    if len(spec) != 3 or any(c not in _AXIS_LETTERS for c in spec):
        raise ValueError(f"axes {axes!r}: expected 3 letters from R/L, U/D, F/B such as 'RDF'")
    m = np.zeros((3, 3), np.float32)
    for src, letter in enumerate(spec):
        cam, sign = _AXIS_LETTERS[letter]
        m[src, cam] = sign
    if sorted(_AXIS_LETTERS[c][0] for c in spec) != [0, 1, 2]:
        raise ValueError(f"axes {axes!r}: expected each of R/L, U/D, F/B exactly once")
    return m


def _cell(c: str) -> float:
    """A CSV cell as a float; empty is missing (NaN, never 0). Raises ValueError for text and
    for a finite literal beyond float64 range (``1e400``), which ``float`` would turn into
    inf and so, silently, into a missing value."""
    if not c:
        return float("nan")
    if "_" in c:  # float() reads "1_0" as 10: a digit separator no pose table writes
        raise ValueError(c)
    v = float(c)
    if math.isinf(v) and "inf" not in c.lower():
        raise ValueError(c)
    return v


def _is_number(c: str, read=float) -> bool:
    """Whether ``read`` (``float``, or :func:`_cell`) takes ``c`` without a ValueError."""
    try:
        read(c)
    except ValueError:
        return False
    return True


def _read_csv(p: Path, delimiter: str) -> tuple[np.ndarray, str, np.ndarray, list[str] | None]:
    """``(rows, note, empty, names)``: the data rows of a pose CSV as float64 ``(T, columns)``
    (an empty cell is NaN), a note on how its header was read (empty for none or names),
    bool ``(T, columns)``, True for the empty cells (the format's "missing", unlike a
    ``nan``/``inf`` cell), and the header's column names (``None`` without a header of names;
    :func:`_columns_by_name` reads them).

    Rules: blank lines and lines starting with ``#`` (``numpy.savetxt``'s header and footer,
    comments as ``numpy.loadtxt`` reads them) are skipped; a row of empty cells is a frame with
    every joint missing; an optional first line of names is the header, and must name every
    column; pandas' header (``to_csv``: numbered names 0, 1, ... when the columns had none,
    and an empty first name for its index column, which is then dropped from every row) is
    recognised as such, but a first frame whose first coordinate is missing is not a header.

    Raises:
        AdapterError: naming the line: a cell that is not a number after the header, a line
            separated by another delimiter than ``delimiter``, rows of different widths, a
            header naming another number of columns, no data row.
    """
    rows: list[list[float]] = []
    empty: list[list[bool]] = []
    row_lines: list[int] = []
    note = ""
    header: list[str] | None = None
    with p.open(newline="", encoding="utf-8-sig", errors="replace") as fh:
        reader = csv.reader(fh, delimiter=delimiter)
        line_no = 0
        header_seen, header_width, index_column = False, None, False
        while True:
            try:
                row = next(reader)
            except StopIteration:
                break
            except csv.Error as exc:  # e.g. a field beyond csv's size limit: not a pose table
                raise AdapterError(p, f"line {reader.line_num}", "a CSV table of numbers", str(exc)[:120]) from exc
            line_no = reader.line_num
            cells = [c.strip() for c in row]
            if len(cells) <= 1 and not any(cells):  # a blank line; a row of empty cells is a frame
                continue
            if cells[0].startswith("#"):
                continue
            names = cells[1:]
            if (not rows and not header_seen and cells[0] == "" and len(cells) > 1 and all(names)
                    and (names == [str(i) for i in range(len(names))] or not any(map(_is_number, names)))):
                header_seen, header_width, index_column = True, len(cells) - 1, True  # pandas' index column
                note = f"line {line_no}: pandas' header with an index column, dropped"
                header = names
                continue
            if not rows and not header_seen and cells == [str(i) for i in range(len(cells))]:
                header_seen, header_width = True, len(cells)
                note = f"line {line_no}: 0, 1, ..., {len(cells) - 1} read as pandas' column names, not a frame"
                continue
            if index_column:
                cells = cells[1:]
            try:
                rows.append([_cell(c) for c in cells])
                empty.append([not c for c in cells])
                row_lines.append(line_no)
            except ValueError:
                if delimiter != "," and any("," in c for c in cells) and all(
                        c == "" or _is_number(c.replace(",", ".")) for c in cells):
                    raise AdapterError(p, f"line {line_no}", "numbers with a decimal point",
                                       f"decimal commas ({next(c for c in cells if ',' in c)!r}); save the file "
                                       f"with a decimal point (pandas: decimal='.')") from None
                others = [d for d in (",", ";", "\t", " ") if d != delimiter and any(d in c for c in cells)]
                if others:
                    found = {",": "','", ";": "';'", "\t": "tabs", " ": "spaces"}[others[0]]
                    raise AdapterError(p, "delimiter", f"{delimiter!r}-separated columns of numbers with a decimal "
                                       f"point (another separator: --delimiter, or delimiter = \"...\" in a "
                                       f"--config file's [lifter_options])", f"line {line_no} separated by {found}") from None
                # A header is a first line without a single number; a first line with some
                # numbers is a damaged data row, which must not vanish as a "header".
                if rows or header_seen or any(_is_number(c) for c in cells):
                    column, bad = next((k, c) for k, c in enumerate(cells, 1 + index_column)
                                       if not _is_number(c, _cell))
                    raise AdapterError(p, f"line {line_no}, column {column}",
                                       "numbers only after the optional header line of names", repr(bad)[:80]) from None
                header_seen, header_width, header = True, len(cells), cells
    if not rows:
        raise AdapterError(p, "rows", "at least one data row", "none")
    widths = {len(r) for r in rows}
    if len(widths) != 1:
        counts = collections.Counter(len(r) for r in rows)
        usual = max(sorted(counts), key=counts.__getitem__)  # the most rows' width (ties: the narrower)
        line, width = next((n, len(r)) for n, r in zip(row_lines, rows) if len(r) != usual)
        raise AdapterError(p, f"line {line}", f"{usual} columns, as on {counts[usual]} of the {len(rows)} rows",
                           f"{width}; widths {sorted(widths)[:10]}")
    if header_width is not None and {header_width} != widths:
        raise AdapterError(p, "header", f"one name per column ({widths.pop()} columns of numbers)",
                           f"{header_width} names")
    return np.asarray(rows, np.float64), note, np.asarray(empty, bool), header


_COLUMN_NAME = re.compile(r"(.+?)[ ._:/-]?([xyz])", re.IGNORECASE)


def _columns_by_name(p: Path, header: list[str] | None, lay) -> tuple[np.ndarray | None, str]:
    """``(order, note)``: where a CSV ``header`` names every joint of layout ``lay`` with an
    axis (``head.x``, ``left_hip_y``, ``nose z``; the layout's own names), the column of each
    joint's ``x, y, z`` in layout order, and a note saying so; other columns whose names are
    no joint axis (``frame``, ``time``) are left out, named in the note (a plugin trial's
    ``frame`` column had made the whole header unread); ``(None, "")`` where the header does
    not name the layout's joints (its columns are read in layout order).

    Raises:
        AdapterError: a header naming the layout's joints with one missing, repeated or unknown.
    """
    if not header:
        return None, ""
    parsed = {i: _COLUMN_NAME.fullmatch(name.strip()) for i, name in enumerate(header)}
    columns = [i for i, m in parsed.items() if m]
    keys = [(parsed[i].group(1).strip().lower(), parsed[i].group(2).lower()) for i in columns]
    known = set(lay.joints)
    if not any(joint in known for joint, _ in keys):
        return None, ""
    wanted = [(joint, axis) for joint in lay.joints for axis in "xyz"]
    if sorted(keys) != sorted(wanted):
        unknown = sorted({joint for joint, _ in keys} - known)
        absent = sorted({f"{j}.{a}" for j, a in wanted} - {f"{j}.{a}" for j, a in keys})
        found = (f"{', '.join(unknown[:5])} (not {lay.name} joints)" if unknown
                 else f"no {', '.join(absent[:5])}" if absent else "a name repeated")
        raise AdapterError(p, "header", f"a name for each {lay.name} joint's x, y and z (e.g. {lay.joints[0]}.x), "
                           f"or no joint names", found)
    order = np.array([columns[keys.index(k)] for k in wanted])
    left_out = [header[i].strip() for i, m in parsed.items() if not m]
    if np.array_equal(order, np.arange(len(header))):
        return None, ""
    notes = [f"columns read by their header's joint names ({lay.name} order differs from the file's)"
             if np.any(np.diff(order) < 0) else "",
             f"column{'s' * (len(left_out) != 1)} {', '.join(map(repr, left_out))} left out (no joint axis)"
             if left_out else ""]
    return order, "; ".join(n for n in notes if n)


def load_generic(path: str | Path, layout: str = "h36m17", axes: str = "RDF", units: str = "m",
                 key: str | None = None, delimiter: str = ",", measured_root: bool = False) -> Poses3D:
    """Read a plain 3D joint array and declare what it is.

    Args:
        path: ``.npy``; ``.npz`` (``key=`` names the array unless there is only one);
            ``.csv``/``.txt``: one row per frame, ``J*3`` columns ``x, y, z`` per joint in
            layout order, an optional header line (pandas' ``to_csv`` header and index column
            are recognised; a header naming every joint's axes, ``head.x`` or ``left_hip_y``
            with the layout's joint names, puts the columns in layout order by those names
            and leaves out columns that name no joint axis, such as ``frame``:
            :func:`_columns_by_name`), empty cells = missing.
            Arrays may be ``(T, J, 3)`` or ``(T, J*3)``.
        layout: joint layout name (``h36m17``, ``coco17``, ``halpe26``, ``body25``, ``blazepose33``).
        axes: where the source's x, y, z point in the camera frame, see :func:`axes_to_camera`
            (default ``"RDF"``: already OpenCV camera axes).
        units: ``"m"``, ``"cm"``/``"mm"`` (converted to metres), ``"normalised"`` or ``"px"``.
        key: array name inside an ``.npz``.
        delimiter: CSV separator.
        measured_root: the file's pelvis positions are a measured camera-frame path (a
            multi-camera or depth system, a lifter that estimates the global trajectory), not
            a root-relative pose's: the run then keeps the pelvis's path and one floor for the
            recording (``Poses3D.root_translation``). Metric units only.

    Returns:
        ``Poses3D``: float32 ``(T, J, 3)`` in the camera frame (x right, y down, z forward),
        units ``m`` / ``normalised`` / ``px``; NaN preserved; root as delivered.

        ``inf`` (and ``inf`` cells) are missing data: NaN.

    Raises:
        AdapterError: missing/unreadable file, unknown extension, bad ``layout``, ``axes``,
            ``units``, ``key`` or ``delimiter``, ``measured_root`` with non-metric units, wrong column count or shape for the layout,
            non-numeric content (bool, complex, text, pickled objects), all NaN, a coordinate
            beyond the bound of its units after scaling (100 m, 1e5 px, 1e3 normalised;
            naming frame and joint).

    Source of the target conventions: docs/CONVENTIONS.md "Camera frame"; the file format is
    the user's declaration, not an upstream fact.
    """
    p = as_path(path)
    for option, expected, got in generic_option_problems(layout, axes, units, key, delimiter, measured_root)[:1]:
        raise AdapterError(p, option, expected, got)
    lay, m = get_layout(layout), axes_to_camera(axes)

    suffix = p.suffix.lower()
    header_note = ""
    if suffix in (".csv", ".txt"):
        field = "columns"
        table, header_note, empty, names = _read_csv(require_file(p, "a CSV file"), delimiter)
        order, name_note = _columns_by_name(p, names, lay)
        if order is not None:
            table, empty = table[:, order], empty[:, order]
            header_note = "; ".join(n for n in (header_note, name_note) if n)
        arr = require_numeric(p, field, table)
        table = np.where(empty, 0.0, table)  # for the count below: an empty cell is the format's "missing"
    elif suffix in (".npy", ".npz"):
        table = arr = require_numeric(p, key or "array", load_array_file(p, key))
        field = key or "array"
    else:
        require_file(p)
        raise AdapterError(p, "extension", "one of .npy, .npz, .csv, .txt", repr(p.suffix))

    j = lay.num_joints
    if arr.ndim == 2 and arr.shape[1] == 3 * j:
        arr = arr.reshape(arr.shape[0], j, 3)
    if arr.ndim != 3 or arr.shape[1:] != (j, 3):
        raise AdapterError(p, field, f"(T, {j}, 3) or (T, {3 * j}) values for layout {lay.name}",
                           f"shape {arr.shape}" + shape_hint(arr.shape, j))
    require_some_finite(p, field, arr)
    nonfinite = nonfinite_frames(table.reshape(arr.shape), lay.joints)  # the file's inf/NaN

    scale, unit_tag = _UNITS[units]
    # Index-and-sign instead of ``arr @ m``: NaN * 0 would spread one missing coordinate
    # to the whole joint.
    joints = np.empty_like(arr)
    for src, cam in zip(*np.nonzero(m)):
        joints[..., cam] = arr[..., src] * (m[src, cam] * np.float32(scale))
    notes = [f"generic {suffix} file, layout {lay.name}, declared axes {axes.upper()} -> camera RDF"]
    if axes.upper() != "RDF":
        notes.append(f"X_cam = X_src @ {m.astype(int).tolist()}")
    notes.append(f"units {units}" + (f" x {scale:g} -> m" if scale != 1.0 else ""))
    notes.append("root as delivered" + (": a measured path (measured_root)" if measured_root else ""))
    joints = checked_poses(p, field, joints, lay.name, unit_tag)
    kept = "" if measured_root else _unkept_path_note(joints, lay.name, unit_tag)
    said = "; ".join(n for n in (header_note, kept) if n)
    return Poses3D(joints, lay.name, units=unit_tag, source=str(p), notes="; ".join(notes + [said] * bool(said)),
                   root_translation=bool(measured_root), summary_note=said and f"{p}: {said}",
                   nonfinite=nonfinite)


def _unkept_path_note(joints: np.ndarray, layout: str, units: str) -> str:
    """The note of a metric file whose pelvis (:func:`pelvis_offset`) lies away from the origin
    without ``measured_root``: a path the run reads root-relative, so it does not keep it (a
    custom-lifter trial's trajectory was dropped without a word); ``""`` otherwise."""
    if units != "m" or not {"left_hip", "right_hip"} <= set(get_layout(layout).joints):
        return ""
    distance, _ = pelvis_offset(joints, layout)
    if not distance > ROOT_RELATIVE_MAX:  # NaN: no frame with a pelvis
        return ""
    return (f"pelvis {distance:.2f} m from the camera: give --measured-root to keep its path (median distance; "
            f"read root-relative here, the path dropped; kept, it gives the world frame's travel and one floor)")


def generic_option_problems(layout: object = "h36m17", axes: object = "RDF", units: object = "m",
                            key: object = None, delimiter: object = ",",
                            measured_root: object = False) -> list[tuple[str, str, str]]:
    """``(option, expected, found)`` for each option value :func:`load_generic` refuses (no
    file needed, so a batch manifest's rows are checked before any row runs)."""
    problems = []
    for option, value, parse, expected in (
            ("layout", layout, get_layout, "a known layout name (h36m17, coco17, halpe26, body25, blazepose33)"),
            ("axes", axes, axes_to_camera, "3 letters from R/L, U/D, F/B, each pair once (e.g. 'RDF', 'RUB')")):
        try:
            if not isinstance(value, str):
                raise ValueError(value)
            parse(value)
        except ValueError:
            problems.append((option, expected, repr(value)))
    if not isinstance(units, str) or units not in _UNITS:
        problems.append(("units", f"one of {sorted(_UNITS)}", repr(units)))
    if key is not None and not isinstance(key, str):
        problems.append(("key", "the name of an array in the .npz, or None", repr(key)))
    if not isinstance(delimiter, str) or len(delimiter) != 1:
        problems.append(("delimiter", "a single character", repr(delimiter)))
    if not isinstance(measured_root, bool):
        problems.append(("measured_root", "true or false", repr(measured_root)))
    elif measured_root and units in ("normalised", "px"):
        problems.append(("measured_root", "metric --units (m, cm, mm) for a measured pelvis path", f"--units {units}"))
    return problems


@register_3d("generic", records_fps=False)
class GenericAdapter:
    """Registry entry for :func:`load_generic` (options: ``layout``, ``axes``, ``units``,
    ``key``, ``delimiter``, ``measured_root``)."""

    option_problems = staticmethod(generic_option_problems)

    def load(self, path: str | Path, *, layout: str = "h36m17", axes: str = "RDF", units: str = "m",
             key: str | None = None, delimiter: str = ",", measured_root: bool = False) -> Poses3D:
        return load_generic(path, layout=layout, axes=axes, units=units, key=key, delimiter=delimiter,
                            measured_root=measured_root)
