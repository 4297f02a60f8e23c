"""Checks shared by adapters: the file exists and parses, arrays have the right shape and
are not all NaN, keypoint counts name a layout. Every failure is an
:class:`~pcnet.adapters.types.AdapterError` naming the file and the field.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .types import AdapterError


def require_file(path: str | Path, what: str = "a readable file") -> Path:
    """Return ``path`` as a ``Path`` after checking it is an existing, readable file.

    Raises:
        AdapterError: field ``path`` when it is missing, a folder, or unreadable.
    """
    p = Path(path)
    if not p.exists():
        raise AdapterError(p, "path", what, "no such file")
    if not p.is_file():
        raise AdapterError(p, "path", what, "a folder or special file")
    try:
        with p.open("rb"):
            pass
    except OSError as exc:
        raise AdapterError(p, "path", what, f"unreadable ({exc.strerror})") from exc
    return p


def read_json(path: str | Path) -> Any:
    """Parse a JSON file.

    Raises:
        AdapterError: field ``path`` (missing/unreadable), ``content`` (empty file or
            invalid JSON, with the parser's line and column).
    """
    p = require_file(path, "a JSON file")
    text = p.read_text(encoding="utf-8", errors="replace")
    if not text.strip():
        raise AdapterError(p, "content", "JSON", "an empty file")
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise AdapterError(p, "content", "valid JSON", f"{exc.msg} at line {exc.lineno} column {exc.colno}") from exc


def load_array_file(path: str | Path, key: str | None = None) -> np.ndarray:
    """Load one array from ``.npy`` or from ``.npz`` (``key``; optional when the archive
    holds a single array). Pickled objects are refused (``allow_pickle=False``).

    Raises:
        AdapterError: field ``path``, ``content`` (not a numpy file) or ``key``.
    """
    p = require_file(path, "a .npy or .npz file")
    try:
        data = np.load(p, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise AdapterError(p, "content", "a numpy .npy/.npz file", type(exc).__name__ + ": " + str(exc)) from exc
    if isinstance(data, np.lib.npyio.NpzFile):
        with data:
            keys = list(data.files)
            if key is None:
                if len(keys) != 1:
                    raise AdapterError(p, "key", "key= naming one of the archive's arrays", f"keys {keys}")
                key = keys[0]
            if key not in keys:
                raise AdapterError(p, key, f"an array named {key!r} in the archive", f"keys {keys}")
            try:
                return data[key]
            except ValueError as exc:
                raise AdapterError(p, key, "a numeric array (no pickled objects)", str(exc)) from exc
    return data


def require_numeric(p: Path, field: str, arr: Any) -> np.ndarray:
    """Return ``arr`` as float32 after checking it is numeric.

    Raises:
        AdapterError: ``field`` holds strings, objects, or is not an array.
    """
    a = np.asarray(arr)
    if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise AdapterError(p, field, "a numeric array", f"dtype {a.dtype}")
    return a.astype(np.float32)


def load_npy(path: str | Path, ndim: int | tuple[int, ...] = 3, num_joints: int | None = None,
             key: str | None = None, field: str = "array") -> np.ndarray:
    """Load a numeric array with ``ndim`` dimensions whose last two axes are
    ``(num_joints, 3)``; return it as float32. It must hold at least one finite value.

    Raises:
        AdapterError: the file checks of :func:`load_array_file`, then ``field`` for a wrong
            dtype, rank, joint count or an all-NaN array.
    """
    p = Path(path)
    arr = require_numeric(p, field, load_array_file(p, key))
    ndims = (ndim,) if isinstance(ndim, int) else tuple(ndim)
    tail = f"(..., {num_joints if num_joints else 'J'}, 3)"
    if arr.ndim not in ndims or arr.shape[-1] != 3 or (num_joints is not None and arr.shape[-2] != num_joints):
        raise AdapterError(p, field, f"shape {tail} with {' or '.join(map(str, ndims))} dimensions", f"shape {arr.shape}")
    require_some_finite(p, field, arr)
    return arr


def require_some_finite(p: str | Path, field: str, arr: np.ndarray) -> None:
    """Raise :class:`AdapterError` (``field``) when ``arr`` is empty or holds no finite value."""
    if arr.size == 0:
        raise AdapterError(p, field, "at least one frame", f"shape {arr.shape}")
    if not np.isfinite(arr).any():
        raise AdapterError(p, field, "some finite values", "only NaN/inf")


def layout_from_count(p: str | Path, field: str, count: int, table: Mapping[int, str]) -> str:
    """Name of the layout for a keypoint ``count`` according to ``table``.

    Raises:
        AdapterError: ``field`` when the count is not in ``table``.
    """
    if count not in table:
        options = ", ".join(f"{n} ({name})" for n, name in table.items())
        raise AdapterError(p, field, f"one of {options} joints", f"{count} joints")
    return table[count]


def clip_confidence(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Clip channel 2 of ``(T, J, 3)`` points to [0, 1] in place (NaN stays NaN); return the
    points and the largest raw confidence (NaN when there is none)."""
    conf = points[..., 2]
    raw_max = float(np.nanmax(conf)) if np.isfinite(conf).any() else float("nan")
    np.clip(conf, 0.0, 1.0, out=conf)
    return points, raw_max
