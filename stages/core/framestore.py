"""Whole-recording arrays kept on disk and read or written a block of frames at a time, so
that a long recording's memory does not grow with its length (``pcnet run``, issue "bounded
memory for long ones").

Each array is one ``.npy`` file (numpy's format, ``numpy.lib.format``), so a finished array
can go into ``canonical.npz`` as it is. Reads and writes are file I/O into fresh arrays, not
memory maps: the pages of a map count in the process's resident memory for as long as the
map lives, which would put the whole file back in it.

Axis 0 is always frames. An array supports ``a[i:j]`` (and ``a[i:j, ...]``, ``a[:, k]``,
which read a block at a time), ``a[i:j] = values``, ``len(a)``, ``shape``, ``dtype``; it
refuses ``np.asarray(a)`` of a pose-sized array (a whole-recording read) with a TypeError,
so code that was not written for it fails loudly rather than quietly loading everything.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import fields, is_dataclass
from pathlib import Path

import numpy as np
from numpy.lib import format as npy_format

#: Frames per block in :meth:`FrameArray.blocks` and the block-wise readers (a 17-joint
#: float64 block is 3.3 MB).
BLOCK_FRAMES = 8192
#: Values per frame up to which ``np.asarray`` may read a :class:`FrameArray` whole: a
#: ``(T,)`` or ``(T, 3)`` column (24 bytes a frame in float64), which plots and per-frame
#: logic need whole anyway.
MAX_WHOLE_ROW_ITEMS = 3


class FrameArray:
    """A ``(T, ...)`` array in a ``.npy`` file, accessed a block of frames at a time.

    Made by :meth:`FrameStore.create`.

    Raises:
        TypeError: ``np.asarray`` of the whole array, a step other than 1, or an index that
            is neither an int, a slice nor a tuple starting with one.
        ValueError: writing a block of the wrong shape, or writing a read-only array.
    """

    def __init__(self, path: Path, shape: tuple[int, ...], dtype: np.dtype, offset: int, writable: bool = True):
        self.path = Path(path)
        self.shape = tuple(int(s) for s in shape)
        self.dtype = np.dtype(dtype)
        self.writable = writable
        self._offset = offset
        self._row_items = int(np.prod(self.shape[1:], dtype=np.int64))
        self._fh = open(self.path, "r+b" if writable else "rb")

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def __len__(self) -> int:
        return self.shape[0]

    def __array__(self, dtype=None, copy=None):
        if self._row_items > MAX_WHOLE_ROW_ITEMS:
            raise TypeError(f"{self.path.name}: a whole-recording array on disk; read it a block at a time "
                            f"(a[i:j]) rather than with np.asarray")
        return np.asarray(self.read(0, len(self)), dtype)

    def column(self, *index) -> FrameColumn:
        """``a[:, *index]`` as a :class:`FrameColumn`, read only when sliced or converted."""
        return FrameColumn(self, index)

    def _rows(self, key: slice) -> tuple[int, int]:
        start, stop, step = key.indices(len(self))
        if step != 1:
            raise TypeError(f"{self.path.name}: only contiguous frame ranges can be read, got step {step}")
        return start, max(start, stop)

    def read(self, start: int, stop: int) -> np.ndarray:
        """Frames ``[start, stop)`` as a new in-memory array ``(stop - start, ...)``."""
        n = max(0, stop - start)
        self._fh.seek(self._offset + start * self._row_items * self.dtype.itemsize)
        data = np.fromfile(self._fh, dtype=self.dtype, count=n * self._row_items)
        return data.reshape((n,) + self.shape[1:])

    def __getitem__(self, key):
        rest: tuple = ()
        if isinstance(key, tuple):
            key, rest = key[0], key[1:]
        if isinstance(key, (int, np.integer)):
            i = int(key) + (len(self) if key < 0 else 0)
            if not 0 <= i < len(self):
                raise IndexError(f"{self.path.name}: frame {key} of {len(self)}")
            block = self.read(i, i + 1)[0]
            return block[rest] if rest else block
        if not isinstance(key, slice):
            raise TypeError(f"{self.path.name}: index frames with an int or a slice, got {type(key).__name__}")
        start, stop = self._rows(key)
        if not rest:
            return self.read(start, stop)
        index = (slice(None),) + rest
        if stop - start <= BLOCK_FRAMES:
            return self.read(start, stop)[index]
        # Filled block by block: a list of the blocks' column views would keep every whole
        # block alive until the end, i.e. the whole array in memory.
        out = np.empty((stop - start,) + self.row_shape(rest), self.dtype)
        for rows in frame_blocks(stop - start):
            out[rows] = self.read(start + rows.start, start + rows.stop)[index]
        return out

    def row_shape(self, index: tuple = ()) -> tuple[int, ...]:
        """The shape of one frame of ``a[:, *index]``."""
        return np.empty((0,) + self.shape[1:], self.dtype)[(slice(None),) + tuple(index)].shape[1:]

    def __setitem__(self, key, value) -> None:
        if not self.writable:
            raise ValueError(f"{self.path.name}: read-only")
        if not isinstance(key, slice):
            raise TypeError(f"{self.path.name}: write a slice of frames, got {type(key).__name__}")
        start, stop = self._rows(key)
        block = np.broadcast_to(np.asarray(value, self.dtype), (stop - start,) + self.shape[1:])
        self._fh.seek(self._offset + start * self._row_items * self.dtype.itemsize)
        np.ascontiguousarray(block).tofile(self._fh)

    def blocks(self, size: int | None = None) -> Iterator[slice]:
        """Consecutive frame slices of at most ``size`` (default :data:`BLOCK_FRAMES`) frames
        covering the array."""
        return frame_blocks(len(self), size)

    def flush(self) -> None:
        self._fh.flush()

    def close(self) -> None:
        self._fh.close()


class FrameColumn:
    """``arr[:, *index]`` of a :class:`FrameArray`, read lazily: ``c[i:j]`` reads frames
    ``[i, j)`` only; ``np.asarray(c)`` reads the whole column (a few values per frame)."""

    def __init__(self, arr: FrameArray, index: tuple):
        self.arr, self.index = arr, tuple(index)
        self.shape = (len(arr),) + arr.row_shape(self.index)
        self.dtype = arr.dtype

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key):
        if isinstance(key, slice):
            return self.arr[(key,) + self.index]  # block by block, never the whole rows
        return self.arr[key][self.index]

    def __array__(self, dtype=None, copy=None):
        return np.asarray(self.arr[(slice(None),) + self.index], dtype)


def column(arr, *index):
    """``arr[:, *index]``: at once for an in-memory array, a lazy :class:`FrameColumn` for a
    :class:`FrameArray`."""
    return arr.column(*index) if isinstance(arr, FrameArray) else arr[(slice(None),) + index]


def in_memory(name: str, shape: tuple, dtype) -> np.ndarray:
    """:meth:`FrameStore.create`'s in-memory stand-in: a new NaN-filled array (``name``
    unused), what a short recording or an API call without a store gets."""
    return np.full(shape, np.nan, dtype)


def freeze_arrays(result: object) -> None:
    """Make every in-memory array field of a frozen dataclass ``result`` read-only, so that the
    result is frozen as its class says (a developer trial wrote into a ``Kinematics``' positions);
    a :class:`FrameArray` on disk is left as it is."""
    for f in fields(result):
        value = getattr(result, f.name)
        if type(value) is np.ndarray:
            value.setflags(write=False)


def arrays_repr(result: object) -> str:
    """``repr`` of a dataclass ``result`` with each array field (and each mapping of arrays) as its
    shape and dtype and each nested dataclass as its class name: a result of a few hundred frames
    printed every value (a developer trial's log filled 300 lines)."""
    def brief(value: object) -> str:
        if isinstance(value, np.ndarray) or hasattr(value, "shape") and hasattr(value, "dtype"):
            return f"<{'x'.join(map(str, value.shape))} {value.dtype}>"
        if is_dataclass(value):
            return f"{type(value).__name__}(...)"
        if isinstance(value, Mapping) and any(isinstance(v, np.ndarray) for v in value.values()):
            return "{" + ", ".join(f"{k!r}: {brief(v)}" for k, v in list(value.items())[:3]) + \
                (f", ... {len(value)} in all" if len(value) > 3 else "") + "}"
        return repr(value)
    return f"{type(result).__name__}(" + ", ".join(f"{f.name}={brief(getattr(result, f.name))}"
                                                   for f in fields(result) if f.repr) + ")"


def restore_frozen(result: object, state: dict) -> None:
    """``__setstate__`` of a frozen dataclass whose arrays :func:`freeze_arrays` made
    read-only: unpickling (a batch worker's result) gives writeable arrays back, so they are
    frozen again (a developer trial wrote into an unpickled result)."""
    result.__dict__.update(state)
    freeze_arrays(result)


def frame_blocks(n: int, size: int | None = None) -> Iterator[slice]:
    """Consecutive slices of at most ``size`` (default :data:`BLOCK_FRAMES`, read at call
    time) frames covering ``n`` frames."""
    size = size or BLOCK_FRAMES
    return (slice(lo, min(n, lo + size)) for lo in range(0, n, size))


def per_frame(f, arr) -> np.ndarray:
    """``f(arr[rows])`` for each block of frames of ``arr`` (in memory or a
    :class:`FrameArray`), concatenated: a per-frame result ``(T, ...)`` computed with one
    block of the input in memory at a time. ``f`` must map ``n`` frames to ``n`` rows."""
    if not len(arr):
        return np.asarray(f(arr[0:0]))
    return np.concatenate([f(arr[rows]) for rows in frame_blocks(len(arr))])


def true_runs(mask) -> list[tuple[int, int]]:
    """``[start, stop)`` of each run of True in a ``(T,)`` bool array (runs of frames)."""
    padded = np.concatenate([[False], np.asarray(mask, bool), [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def present_frames(poses) -> np.ndarray:
    """``(T,)`` bool: frames of ``(T, J, 3)`` poses (in memory or a :class:`FrameArray`)
    with any finite joint, read a block of frames at a time."""
    return per_frame(lambda P: np.isfinite(P).any(axis=(1, 2)), poses)


def seen_joints(poses) -> np.ndarray:
    """``(J,)`` bool: the joints of ``(T, J, 3)`` poses (in memory or a :class:`FrameArray`)
    with all three coordinates finite in at least one frame, read a block of frames at a
    time; False for a joint the input's skeleton never has (Kinect v1's nose)."""
    seen = np.zeros(np.shape(poses)[1], dtype=bool)
    for rows in frame_blocks(len(poses)):
        seen |= np.isfinite(np.asarray(poses[rows], np.float64)).all(axis=-1).any(axis=0)
    return seen


class FrameStore:
    """A folder of :class:`FrameArray` files for one recording; ``close()`` deletes the folder,
    which the store created (``tempfile.mkdtemp``) and nothing else writes into.

    ``folder``: where to create it (the run's staged output folder, so the arrays are on the
    disk the outputs go to, not in a RAM-backed ``/tmp``).
    """

    def __init__(self, folder: str | os.PathLike):
        self.folder = Path(tempfile.mkdtemp(prefix=".frames-", dir=folder))
        self._arrays: list[FrameArray] = []

    def create(self, name: str, shape: tuple[int, ...], dtype, fill: float | None = np.nan) -> FrameArray:
        """A new writable ``(T, ...)`` array ``name.npy``: a float array has every value
        ``fill`` (NaN, missing, until written; ``None``: zeros), any other dtype zeros."""
        path = self.folder / f"{name}.npy"
        dtype = np.dtype(dtype)
        with open(path, "wb") as fh:
            npy_format.write_array_header_1_0(fh, {"descr": npy_format.dtype_to_descr(dtype),
                                                    "fortran_order": False, "shape": tuple(shape)})
            offset = fh.tell()
            fh.truncate(offset + int(np.prod(shape, dtype=np.int64)) * dtype.itemsize)
        arr = FrameArray(path, shape, dtype, offset, writable=True)
        if dtype.kind == "f" and fill is not None and fill != 0:
            for rows in arr.blocks():
                arr[rows] = fill
        self._arrays.append(arr)
        return arr

    def close(self) -> None:
        for arr in self._arrays:
            arr.close()
        shutil.rmtree(self.folder, ignore_errors=True)

    def __enter__(self) -> FrameStore:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
