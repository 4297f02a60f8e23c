"""Checks shared by adapters, so that every bad input ends in one
:class:`~pcnet.adapters.types.AdapterError` line naming the file and the field.

Two mechanisms every adapter goes through:

* **reading**: :func:`read_json` and :func:`open_numpy` (with :func:`load_array_file`,
  :func:`load_npy` and :func:`json_numbers` on top) parse untrusted bytes. They check the
  file's own claims before acting on them (a ``.npy`` header's shape against the bytes
  present and the memory available, so a damaged header never allocates gigabytes; an
  ``.npz``'s declared sizes against the file's, so a zip bomb is refused before it is
  decompressed), refuse pickled object arrays, and turn every parser failure into an
  ``AdapterError``.
* **finishing**: :func:`checked_keypoints` (2D) and :func:`checked_poses` (3D) are the
  last step before an adapter builds its result. Non-finite values become NaN (missing
  data), coordinates beyond :data:`pcnet.stages.core.conventions.MAX_ABS_COORDINATE` for their
  units are refused naming the frame and joint, 2D confidence is clipped to [0, 1], and
  an all-missing result is refused.

:func:`frame_count_for` bounds the frame indices written inside a file before an adapter
allocates one row per frame.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import reprlib
import struct
import tokenize
import zipfile
import zlib
from pathlib import Path
from typing import IO, Any, Iterator, Mapping, Sequence

import numpy as np

from pcnet.stages.core.conventions import MAX_ABS_COORDINATE, get_layout, placeholder_joints, shape_hint, validate_poses
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.framestore import frame_blocks

from .types import AdapterError

_NPY_MAGIC = b"\x93NUMPY"
# Local file header, and the end-of-archive record that starts an empty zip.
_ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")
_FLOAT32_MAX = float(np.finfo(np.float32).max)
# What numpy's header parser and zipfile raise on damaged bytes: numpy tokenizes and
# literal-evals the header (tokenize.TokenError, SyntaxError), zlib.error for a bad deflate
# stream, NotImplementedError for an unknown compression method, RuntimeError for an
# encrypted member, struct.error for a short record. Caught only around parsing.
_PARSE_ERRORS = (ValueError, TypeError, KeyError, OSError, EOFError, OverflowError, SyntaxError,
                 tokenize.TokenError, zipfile.BadZipFile, zlib.error, NotImplementedError, RuntimeError,
                 struct.error)
# Plain numeric or text dtypes; text arrays are legitimate metadata (MediaPipe's "layout").
_LOADABLE_KINDS = "biufcSU"
# Content-derived bound on frame indices when the video's frame count is unknown, see
# frame_count_for.
FRAMES_PER_RECORD = 100
FRAMES_SLACK = 10_000


def _short(text: object, limit: int = 200) -> str:
    """``text`` on one line, at most ``limit`` characters: messages quote foreign content."""
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


def describe_keys(keys: Sequence[str], limit: int = 10) -> str:
    """``"3 arrays: 'a', 'b', 'c'"``; at most ``limit`` names, then ``...``, so that an
    archive with thousands of arrays still gives a one-line, readable message."""
    shown = ", ".join(repr(k) for k in list(keys)[:limit])
    more = ", ..." if len(keys) > limit else ""
    return f"{len(keys)} array{'s' if len(keys) != 1 else ''}: {shown}{more}" if keys else "no arrays"


def as_path(path: object, what: str = "a file path") -> Path:
    """``path`` as a ``Path``.

    Raises:
        AdapterError: field ``path`` when it is not a ``str`` or path-like (a library caller's
            number or array), which ``Path`` would refuse with a TypeError.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise AdapterError(path, "path", what, f"{type(path).__name__} {reprlib.repr(path)}")
    return Path(path)


def require_file(path: str | Path, what: str = "a readable file") -> Path:
    """Return ``path`` as a ``Path`` after checking it is an existing, readable file.

    Raises:
        AdapterError: field ``path`` when it is not a path, missing, a folder, or unreadable.
    """
    p = as_path(path, what)
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


class _FloatOverflow(Exception):
    pass


def _json_float(text: str) -> float:
    # float("1e400") is inf, which the adapters would take for a missing value; a literal
    # that large is a damaged number, not missing data.
    value = float(text)
    if math.isinf(value):
        raise _FloatOverflow(text)
    return value


def read_json(path: str | Path) -> Any:
    """Parse a JSON file. ``NaN``/``Infinity`` literals parse to floats; the adapters treat
    them as missing data.

    Raises:
        AdapterError: field ``path`` (missing/unreadable), ``content`` (empty file, invalid
            JSON with the parser's line and column, a number literal beyond float64 range,
            an integer of more digits than Python converts, or nesting deeper than the
            parser's recursion limit).
    """
    p = require_file(path, "a JSON file")
    text = p.read_text(encoding="utf-8-sig", errors="replace")  # -sig: a BOM some Windows tools write
    if not text.strip():
        raise AdapterError(p, "content", "JSON", "an empty file")
    with _json_errors(p):
        return json.loads(text, parse_float=_json_float)


@contextlib.contextmanager
def _json_errors(p: Path) -> Iterator[None]:
    """Parser errors as one-line AdapterErrors naming the file."""
    try:
        yield
    except _FloatOverflow as exc:
        raise AdapterError(p, "content", "JSON numbers within float64 range", _short(exc, 40)) from None
    except json.JSONDecodeError as exc:
        binary = _binary_kind(p)
        raise AdapterError(p, "content", "valid JSON", binary or f"{exc.msg.removesuffix(' at')} at line {exc.lineno} "
                                                               f"column {exc.colno}") from exc
    except ValueError as exc:  # int digit limit (CVE-2020-10735 guard)
        raise AdapterError(p, "content", "JSON numbers of at most 4300 digits", _short(exc)) from exc
    except RecursionError as exc:
        raise AdapterError(p, "content", "JSON nested at most a few hundred levels deep", "deeper nesting") from exc


def _binary_kind(p: Path) -> str:
    """What a file that is not JSON is, from its first bytes, for a user who named the wrong
    format (a user trial gave a MediaPipe archive as AlphaPose's JSON); ``""`` for text."""
    with open(p, "rb") as fh:
        head = fh.read(16)
    if head.startswith(b"PK\x03\x04"):
        return "a zip archive such as numpy's .npz (MediaPipe's archive is read by the mediapipe format)"
    if head.startswith(b"\x93NUMPY"):
        return "a numpy .npy array"
    return _video_kind(head)


def _video_kind(head: bytes) -> str:
    """``"a video (...): give it as --video"`` when the first bytes ``head`` (16 or more) are a
    video container's signature (ISO base media ``ftyp`` box: MP4 / MOV, ISO/IEC 14496-12;
    RIFF ``AVI ``; EBML: Matroska / WebM), else ``""``: a coach gave the video as the lifter
    output and read a message about its bytes."""
    if head[4:8] == b"ftyp":
        kind = "MP4 / MOV"
    elif head[:4] == b"RIFF" and head[8:12] == b"AVI ":
        kind = "AVI"
    elif head[:4] == b"\x1aE\xdf\xa3":
        kind = "Matroska / WebM"
    else:
        return ""
    return f"a video ({kind}): give it as --video"


#: Characters read at a time by :func:`iter_json_array`.
JSON_CHUNK_CHARS = 1 << 20


class _Malformed(Exception):
    """A JSON syntax error met while streaming; reported by :func:`read_json` on the whole file
    so the message, line and column are the file's (an error path only)."""


def iter_json_array(path: str | Path, expected: str) -> Iterator[Any]:
    """The items of a JSON file whose top level is an array, decoded one at a time.

    Same parsing and errors as :func:`read_json`, but the file is read
    :data:`JSON_CHUNK_CHARS` characters at a time and only one item's Python objects exist at
    a time: a 2-hour AlphaPose file parsed whole is about 1.3 GB of Python floats, and its text
    alone about 0.3 GB; streamed, memory holds one chunk plus the caller's arrays.

    Args:
        path: the JSON file.
        expected: what the top-level array holds, for the error when it is not an array
            (e.g. ``"a list of detections (AlphaPose docs/output.md)"``).

    Raises:
        AdapterError: as :func:`read_json`; field ``top level`` when it is not an array.
    """
    p = require_file(path, "a JSON file")
    try:
        yield from _stream_array(p, expected)
    except _Malformed:
        read_json(p)  # raises the parser's error with the file's line and column
        raise AdapterError(p, "content", "valid JSON", "a syntax error") from None  # not reached


def _stream_array(p: Path, expected: str) -> Iterator[Any]:
    decoder = json.JSONDecoder(parse_float=_json_float)
    ws = json.decoder.WHITESPACE.match
    with open(p, encoding="utf-8-sig", errors="replace") as fh:
        buf, eof = "", False

        def more(keep_from: int) -> int:
            """Drop ``buf[:keep_from]``, append the next chunk; the new index of ``keep_from``."""
            nonlocal buf, eof
            chunk = fh.read(JSON_CHUNK_CHARS)
            eof = not chunk
            buf = buf[keep_from:] + chunk
            return 0

        def skip_ws(pos: int) -> int:
            pos = ws(buf, pos).end()
            while pos == len(buf) and not eof:
                pos = more(pos)
                pos = ws(buf, pos).end()
            return pos

        pos = skip_ws(0)
        if pos == len(buf):
            raise AdapterError(p, "content", "JSON", "an empty file")
        if buf[pos] != "[":
            data = read_json(p)  # invalid JSON reads as read_json's error
            got = f"a JSON object with keys {sorted(data)[:6]}" if isinstance(data, dict) else type(data).__name__
            raise AdapterError(p, "top level", expected, got)
        with _json_errors(p):
            pos = skip_ws(pos + 1)
            if buf.startswith("]", pos):
                pos += 1
            else:
                while True:
                    while True:
                        try:
                            item, end = decoder.raw_decode(buf, pos)
                        except json.JSONDecodeError:
                            if eof:
                                raise _Malformed from None
                            pos = more(pos)
                            continue
                        # A number cut by the chunk's end ("1." of "1.25") decodes short: an
                        # item is whole when a delimiter follows it.
                        if eof or (end < len(buf) and buf[end] in " \t\n\r,]"):
                            break
                        pos = more(pos)
                    yield item
                    pos = skip_ws(end)
                    if buf.startswith("]", pos):
                        pos += 1
                        break
                    if not buf.startswith(",", pos):
                        raise _Malformed
                    pos = skip_ws(pos + 1)
            if skip_ws(pos) != len(buf):
                raise _Malformed


def json_numbers(p: str | Path, field: str, value: Any, depth: int = 1) -> np.ndarray:
    """A JSON list of numbers (``depth=1``) or of lists of numbers (``depth=2``) as a
    float64 array.

    JSON's typing is checked rather than left to numpy, which would silently read
    ``true`` as 1 and ``"1.5"`` as 1.5.

    Raises:
        AdapterError: ``field`` when ``value`` is not such a list, holds booleans, strings,
            null or objects, is ragged, or holds an integer beyond float64's range.
    """
    shape = "a list of numbers" if depth == 1 else "a list of [numbers] lists"

    def bad(v: Any) -> AdapterError:
        return AdapterError(p, field, shape, _short(f"{type(v).__name__} {v!r}", 80))

    if not isinstance(value, list):
        raise bad(value)
    if not value:
        return np.zeros((0,) * depth)
    stack = [(value, depth)]
    while stack:
        items, level = stack.pop()
        for v in items:
            if level > 1:
                if not isinstance(v, list):
                    raise bad(v)
                stack.append((v, level - 1))
            elif type(v) not in (int, float):  # bool is a subclass of int: refused here
                raise bad(v)
    try:
        arr = np.array(value, dtype=np.float64)
    except OverflowError as exc:
        raise AdapterError(p, field, "numbers within float64 range", "a larger integer") from exc
    except ValueError as exc:
        raise AdapterError(p, field, f"{shape}, all of one length", "lists of different lengths") from exc
    if arr.ndim != depth:
        raise AdapterError(p, field, shape, f"{arr.ndim} levels of lists")
    return arr


# --------------------------------------------------------------------------- numpy files

#: How many times its compressed size an ``.npz`` member, and a whole ``.npz`` its size on
#: disk, may expand to once it is larger than :data:`NPZ_EXPANSION_FREE_BYTES`; checked from
#: the zip's central directory before anything is decompressed. Pose, mocap and landmark
#: arrays are measured floats: in the 679 ``.npz`` of ``../shared/data`` (mocap, MediaPipe,
#: Kinect, Pose2Sim; 15,402 members) no member over 10 kB expands more than 1.2 fold, small
#: text members up to 6 fold, and float data in general less than 10. Only long constant runs
#: expand further (deflate's limit is 1032 fold, reached by zeros): a large member that
#: expands more than 100 fold is all but one constant, which is what a zip bomb is (1 MB that
#: decompresses to 1 GB) and what no recording is. Such a file saved with ``np.savez``
#: (stored, not compressed) still loads.
NPZ_MAX_EXPANSION = 100
#: Below this (decompressed, bytes) an ``.npz`` member or archive may expand any amount: it
#: decompresses in a fraction of a second and fits any machine, and small arrays padded with
#: zeros or NaN (an untracked joint, a short clip) legitimately expand far more than floats.
NPZ_EXPANSION_FREE_BYTES = 100_000_000
#: Part of :func:`available_memory` one array read from a file may take: the reader holds
#: the array, and its callers' first step (the float32 conversion of :func:`require_numeric`,
#: :func:`~pcnet.stages.core.conventions.validate_poses`) one more copy of about its size.
ARRAY_MEMORY_FRACTION = 0.5
#: Arrays smaller than this (bytes) skip the memory check: no such allocation is what
#: exhausts memory, and reading /proc/meminfo for each of a mocap file's 3,000 clips would
#: cost a quarter of their loading time.
_MEMORY_CHECK_BYTES = 1 << 24
#: Bytes read at a time into an array's memory (no second copy of the whole file).
_READ_CHUNK = 1 << 24


def _bytes(n: int) -> str:
    """``n`` bytes for a message: ``"972 kB"``, ``"1.02 GB"``."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= 0.9995 * size:  # 999.96 MB reads "1 GB", not "1e+03 MB"
            return f"{n / size:.3g} {unit}"
    return f"{n} bytes"


def available_memory() -> int | None:
    """Bytes of memory this process may still take, ``None`` where the system does not say.

    Linux's ``MemAvailable`` (free memory plus the page cache the kernel can drop), lowered to
    the process's cgroup v2 ``memory.max`` where a container sets one (its current use is
    mostly reclaimable page cache, so it is not subtracted); elsewhere the free pages of
    ``os.sysconf``, which leave out the page cache and so err on the small side.
    """
    found = []
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            found += [int(line.split()[1]) * 1024 for line in fh if line.startswith("MemAvailable:")]
    except (OSError, ValueError, IndexError):
        pass
    if not found:
        try:
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (OSError, ValueError, AttributeError):  # not every system names these
            pass
    try:
        own = next(line[3:] for line in Path("/proc/self/cgroup").read_text().splitlines() if line.startswith("0::"))
        limit = (Path("/sys/fs/cgroup") / own.strip().lstrip("/") / "memory.max").read_text().strip()
        if limit != "max":
            found.append(int(limit))
    except (OSError, ValueError, StopIteration):
        pass
    return max(min(found), 0) if found else None


def _check_expansion(p: Path, field: str, of: str, packed: int, unpacked: int) -> None:
    """Refuse ``unpacked`` decompressed bytes declared from ``packed`` stored ones (``of``:
    ``"its compressed size"``) beyond :data:`NPZ_MAX_EXPANSION` times, above
    :data:`NPZ_EXPANSION_FREE_BYTES`.

    Raises:
        AdapterError: ``field``, naming both sizes and the bound.
    """
    if unpacked > max(NPZ_EXPANSION_FREE_BYTES, NPZ_MAX_EXPANSION * packed):
        raise AdapterError(p, field, f"at most {NPZ_MAX_EXPANSION} times {of} once decompressed, above "
                                     f"{_bytes(NPZ_EXPANSION_FREE_BYTES)} (measured arrays expand under 10 times)",
                           f"{_bytes(unpacked)} from {_bytes(packed)}, {unpacked // max(packed, 1)} times: a zip bomb? "
                           f"(real data saved uncompressed, with np.savez, loads)")


def _check_archive(p: Path, archive: zipfile.ZipFile, size: int) -> None:
    """Check an ``.npz``'s declared member sizes (its central directory) before any member is
    decompressed: each member's compressed bytes lie within the file's ``size``, and neither a
    member nor the whole archive expands beyond :data:`NPZ_MAX_EXPANSION` (the whole against
    the file's size, so that members sharing the same compressed bytes count each time).

    Raises:
        AdapterError: the member's key (or ``content`` for the whole archive), naming sizes.
    """
    for info in archive.infolist():
        key = info.filename.removesuffix(".npy")
        if info.compress_size > size:
            raise AdapterError(p, key, f"a member's compressed bytes within the file's {_bytes(size)}",
                               f"{_bytes(info.compress_size)} declared: a damaged zip directory")
        _check_expansion(p, key, "its compressed size", info.compress_size, info.file_size)
    total = sum(info.file_size for info in archive.infolist())
    _check_expansion(p, "content", "the file's size (all members)", size, total)


def _read_npy(p: Path, field: str, fp: IO[bytes], size: int) -> np.ndarray:
    """One array from an open ``.npy`` stream of ``size`` bytes in all.

    The header's shape and dtype are checked before anything is allocated: against the
    bytes present (a damaged header claiming 10**12 elements is refused, not a MemoryError)
    and, from 16 MiB, against :data:`ARRAY_MEMORY_FRACTION` of :func:`available_memory`. The
    data is read into the array a chunk at a time: memory holds the array once.

    Raises:
        AdapterError: ``field``: an unknown format version, a damaged header, a pickled
            object array or another non-plain dtype, a shape the bytes do not hold or memory
            cannot, truncated data.
    """
    try:
        version = np.lib.format.read_magic(fp)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(fp)
        elif version == (2, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(fp)
        else:
            # 3.0 only adds utf-8 structured field names: never a pose array.
            raise AdapterError(p, field, "a .npy of format version 1.0 or 2.0", f"version {version}")
        start = fp.tell()
    except AdapterError:
        raise
    except _PARSE_ERRORS as exc:
        raise AdapterError(p, field, "a .npy array header", f"a damaged header ({_short(exc, 120)})") from exc
    if dtype.hasobject:
        raise AdapterError(p, field, "a numeric array", "a pickled object array (dtype object), refused for safety")
    if dtype.kind not in _LOADABLE_KINDS or dtype.itemsize == 0:
        raise AdapterError(p, field, "a plain numeric array", f"dtype {dtype}")
    if any(d < 0 for d in shape):
        raise AdapterError(p, field, "a .npy header with a valid shape", f"shape {shape}")
    count = math.prod(shape)
    nbytes = count * dtype.itemsize
    if nbytes > size - start:
        raise AdapterError(p, field, f"{nbytes} bytes of data for shape {shape} {dtype} (the .npy header)",
                           f"{max(size - start, 0)} bytes: the file is truncated or its header damaged")
    memory = available_memory() if nbytes >= _MEMORY_CHECK_BYTES else None
    if memory is not None and nbytes > ARRAY_MEMORY_FRACTION * memory:
        raise AdapterError(p, field, f"an array of at most {_bytes(int(ARRAY_MEMORY_FRACTION * memory))} (half the "
                                     f"{_bytes(memory)} of memory available: it and one working copy)",
                           f"shape {shape} {dtype}, {_bytes(nbytes)}")
    arr = np.empty(count, dtype)
    data, done = arr.view(np.uint8), 0
    try:
        while done < nbytes:
            got = fp.readinto(data[done:done + _READ_CHUNK])
            if not got:
                break
            done += got
    except _PARSE_ERRORS as exc:
        raise AdapterError(p, field, "readable array data", _short(f"{type(exc).__name__}: {exc}", 120)) from exc
    if done != nbytes:
        raise AdapterError(p, field, f"{nbytes} bytes of data for shape {shape} {dtype}",
                           f"{done} bytes: the file is truncated")
    if fortran:  # C order, as numpy's own copy of a Fortran-order file would be
        return np.ascontiguousarray(arr.reshape(shape[::-1]).T)
    return arr.reshape(shape)


class NumpyArchive(np.lib.npyio.NpzFile):
    """An ``.npz`` opened by :func:`open_numpy`: numpy's ``NpzFile`` (``files``, ``[key]``,
    ``with``) whose members load through the same checks as a ``.npy`` file.

    ``archive[key]`` returns an ndarray or raises :class:`AdapterError` naming the file and
    ``key`` (damaged member, pickled object array, not a ``.npy`` member, unknown
    compression); an unknown key is a ``KeyError`` as for any mapping.
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        fid = self.path.open("rb")
        try:
            super().__init__(fid, own_fid=True, allow_pickle=False)
            _check_archive(self.path, self.zip, self.path.stat().st_size)
        except BaseException:
            fid.close()
            raise

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self.files:
            raise KeyError(f"{key} is not a file in the archive")
        names = self.zip.namelist()
        name = key + ".npy" if key + ".npy" in names else key
        try:
            info = self.zip.getinfo(name)
            with self.zip.open(info) as fp:
                if fp.read(len(_NPY_MAGIC)) != _NPY_MAGIC:
                    raise AdapterError(self.path, key, "a .npy array inside the .npz", "another kind of member")
                fp.seek(0)
                return _read_npy(self.path, key, fp, info.file_size)
        except AdapterError:
            raise
        except _PARSE_ERRORS as exc:
            raise AdapterError(self.path, key, "a readable .npy member",
                               _short(f"a damaged archive ({type(exc).__name__}: {exc})", 160)) from exc


def open_numpy(path: str | Path) -> np.ndarray | NumpyArchive:
    """Open a ``.npy`` (returns the array) or ``.npz`` (returns a :class:`NumpyArchive`,
    use it in a ``with`` block), deciding by the file's first bytes, not its name.

    Pickled object arrays are refused (the safety of ``np.load(allow_pickle=False)``);
    text and numeric dtypes load, the caller checks which it needs.

    Raises:
        AdapterError: field ``path`` (missing/unreadable); ``content`` when the file is not
            numpy at all (e.g. a CSV: the message says so, not "pickled data"), a damaged
            zip, an ``.npz`` that would expand beyond :data:`NPZ_MAX_EXPANSION` times its
            size, or a ``.npy`` whose header is damaged, disagrees with the file's size, asks
            for more than half the available memory, or holds a pickled object array; an
            ``.npz`` member's key when its declared sizes do (a zip bomb, a damaged directory).
    """
    p = require_file(path, "a .npy or .npz file")
    try:
        with p.open("rb") as fp:
            head = fp.read(16)
            if head.startswith(_NPY_MAGIC):
                fp.seek(0)
                return _read_npy(p, "content", fp, p.stat().st_size)
    except OSError as exc:
        raise AdapterError(p, "path", "a readable file", f"unreadable ({exc.strerror})") from exc
    if head[:4] in _ZIP_MAGICS:
        try:
            return NumpyArchive(p)
        except AdapterError:  # the archive's declared sizes, already one line
            raise
        except _PARSE_ERRORS as exc:
            raise AdapterError(p, "content", "a numpy .npz archive",
                               _short(f"a damaged zip ({type(exc).__name__}: {exc})", 160)) from exc
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    got = ("an empty file" if not head else _video_kind(head) or
           ("a JSON file: 2D keypoints go to --keypoints2d with their --keypoints2d-format"
            if text[:1] in (b"[", b"{") else f"a file that is not numpy (it starts with {head[:6]!r})"))
    raise AdapterError(p, "content", "a numpy .npy/.npz file", got)


#: Archives another adapter reads, told by their array names: what a single-array lifter's
#: refusal suggests instead (the files of ``../shared/data``'s MediaPipe and UTD-MHAD sets).
_ARCHIVE_HINTS = (({"world_3d", "keypoints_2d"}, "MediaPipe's landmarks: read them with --lifter mediapipe"),
                  ({"skeleton", "skeleton_fps"}, "Kinect v1 skeletons: read them with --lifter kinect_v1"))


def archive_hint(keys) -> str:
    """``"; Kinect v1 skeletons: read them with --lifter kinect_v1"`` when the archive's
    array names ``keys`` are another lifter's known archive (:data:`_ARCHIVE_HINTS`), else
    ``""``: what a refusal of that archive adds."""
    return next((f"; {what}" for names, what in _ARCHIVE_HINTS if names <= set(keys)), "")


def load_array_file(path: str | Path, key: str | None = None, key_option: bool = True) -> np.ndarray:
    """Load one array from ``.npy`` or from ``.npz`` (``key``; optional when the archive
    holds a single array). Pickled objects are refused; see :func:`open_numpy`.
    ``key_option``: the caller's lifter takes ``--key``; the message for an archive of several
    arrays names it only then.

    Raises:
        AdapterError: field ``path``, ``content`` (not a numpy file, damaged, pickled) or
            ``key`` (missing or ambiguous; at most 10 names are listed).
    """
    p = as_path(path)
    data = open_numpy(p)
    if not isinstance(data, NumpyArchive):
        if key is not None:  # a key that would be silently ignored is a mistake
            raise AdapterError(p, "key", "no key for a single-array .npy file", repr(key))
        return data
    with data:
        keys = list(data.files)
        if key is None:
            if len(keys) != 1:
                hint = archive_hint(keys)
                wanted = ("--key (key=) naming one of the archive's arrays" if key_option else
                          "an .npz holding one array (this lifter takes no --key; save the poses alone)")
                raise AdapterError(p, "key", wanted, describe_keys(keys) + hint)
            key = keys[0]
        if key not in keys:
            raise AdapterError(p, "key", f"an array named {key!r} in the archive", describe_keys(keys) + archive_hint(keys))
        return data[key]


def require_numeric(p: str | Path, field: str, arr: Any) -> np.ndarray:
    """Return ``arr`` as float32 after checking it holds real numbers (int or float dtype).

    ``inf``/``-inf`` become NaN (missing data, as the conventions say), and so does any
    NaN payload. A finite value too large for float32 is refused rather than turned into inf
    and then silently into NaN.

    Raises:
        AdapterError: ``field`` holds booleans, complex numbers, strings or objects, or a
            value beyond float32's range (its index is named).
    """
    a = np.asarray(arr)
    if a.dtype.kind not in "iuf":
        raise AdapterError(p, field, "a real-valued numeric array (int or float)", f"dtype {a.dtype}")
    with np.errstate(over="ignore", invalid="ignore"):
        out = a.astype(np.float32)
    inf = np.isinf(out)
    if a.dtype.kind == "f" and a.dtype.itemsize > 4:
        overflow = inf & np.isfinite(a)
        if overflow.any():
            idx = tuple(int(i) for i in np.argwhere(overflow)[0])
            raise AdapterError(p, field, f"values within float32 range (|v| <= {_FLOAT32_MAX:.3g})",
                               f"{float(a[idx]):.4g} at index {idx}")
    # Every non-finite value becomes the one quiet NaN: inf is missing data, and a signalling
    # NaN from a damaged file would raise "invalid value" warnings in later arithmetic.
    out[~np.isfinite(out)] = np.nan
    return out


def load_npy(path: str | Path, ndim: int | tuple[int, ...] = 3, num_joints: int | None = None,
             field: str = "array") -> np.ndarray:
    """Load a numeric array with ``ndim`` dimensions whose last two axes are
    ``(num_joints, 3)``; return it as float32 with ``inf`` as NaN. It must hold at least
    one finite value.

    Raises:
        AdapterError: the file checks of :func:`load_array_file`, then ``field`` for a wrong
            dtype, rank, joint count or an all-NaN array.
    """
    p = as_path(path)
    arr = require_numeric(p, field, load_array_file(p, key_option=False))  # its lifters take no --key
    ndims = (ndim,) if isinstance(ndim, int) else tuple(ndim)
    joints = num_joints if num_joints else 'J'
    tail = f"(T, {joints}, 3)" if ndims == (3,) else f"(..., {joints}, 3) with {' or '.join(map(str, ndims))} dimensions"
    fits = arr.shape[-1:] == (3,) and (num_joints is None or arr.shape[-2] == num_joints)
    if arr.ndim not in ndims or not fits:
        batch = arr.ndim - 1 in ndims and arr.shape[0] == 1 and fits  # a batch of one recording
        raise AdapterError(p, field, f"shape {tail}", f"shape {arr.shape}"
                           + (" (a leading batch axis of one? save a[0])" if batch else "")
                           + (shape_hint(arr.shape, num_joints) if num_joints else ""))
    require_some_finite(p, field, arr)
    return arr


def require_some_finite(p: str | Path, field: str, arr: np.ndarray) -> None:
    """Raise :class:`AdapterError` (``field``) when ``arr`` is empty or holds no finite value."""
    if arr.size == 0:
        raise AdapterError(p, field, "at least one frame", f"shape {arr.shape}")
    if not np.isfinite(arr).any():
        raise AdapterError(p, field, "some finite values", "only NaN/inf")


def finite_max_abs(arr: np.ndarray) -> float:
    """Largest finite ``|value|`` of ``arr``; NaN when it has none (no all-NaN warning)."""
    a = np.asarray(arr)
    if a.ndim == 0:
        a = a[None]
    best = float("nan")
    for rows in frame_blocks(len(a)):  # a block at a time: no whole-recording copies
        block = a[rows]
        finite = block[np.isfinite(block)]
        if finite.size:
            best = float(np.fmax(best, np.abs(finite).max()))
    return best


def nonfinite_frames(arr: np.ndarray, joint_names: Sequence[str], skip_empty_frames: bool = False) -> dict[str, int]:
    """What a file held that is read as missing: per joint, the number of frames in which
    ``(T, J, 3)`` ``arr`` has a non-finite coordinate (``inf``, ``-inf``, NaN) for it.

    Count on the array **as read from the file**, before an adapter adds NaN of its own (a
    depth sensor's untracked joints, joints a layout lacks), so that the count tells the
    file's non-finite values from joints missing for other reasons.

    Args:
        arr: ``(T, J, 3)`` real numbers (any float or int dtype).
        joint_names: the ``J`` names of the file's layout.
        skip_empty_frames: frames without a single finite value are the format's own "no
            person" (MediaPipe) and are not counted.

    Returns:
        joint name -> frames, in layout order, only joints with at least one such frame.
    """
    counts = np.zeros(len(joint_names), np.int64)
    for rows in frame_blocks(len(arr)):  # a block at a time: no whole-recording copies
        bad = ~np.isfinite(np.asarray(arr[rows])).all(axis=2)
        if skip_empty_frames:
            bad &= ~bad.all(axis=1, keepdims=True)
        counts += bad.sum(axis=0)
    return {name: int(n) for name, n in zip(joint_names, counts) if n}


def nonfinite_line(counts: Mapping[str, int], limit: int = 6, what: str = "non-finite values (inf/NaN)") -> str:
    """One summary line for :func:`nonfinite_frames`' counts (or another per-joint count of
    frames read as missing, ``what`` the file held there), ``''`` for none; the ``limit``
    joints with the most frames are named, the others counted.

    Example: ``"input: non-finite values (inf/NaN) read as missing: right_ankle 10 frames,
    left_wrist 2 frames"``.
    """
    if not counts:
        return ""
    ranked = sorted(counts.items(), key=lambda item: -item[1])  # stable: layout order among equals
    shown = ", ".join(f"{name} {n} frame{'s' * (n != 1)}" for name, n in ranked[:limit])
    rest = ranked[limit:]
    if rest:
        more = sum(n for _, n in rest)
        shown += f", {len(rest)} more joint{'s' * (len(rest) != 1)} ({more} frame{'s' * (more != 1)})"
    return f"input: {what} read as missing: {shown}"


#: The farthest a root-relative export's pelvis lies from the origin, median over frames (in
#: its units): VideoPose3D's real exports about 1e-4 m, D3DP zeroes it; MotionBERT's
#: infer_wild output keeps the root's image position, 0.23-0.52 normalised units (median) in
#: the real files of shared/data/real (boxing, cycling).
ROOT_RELATIVE_MAX = 0.01


def pelvis_offset(joints: np.ndarray, layout: str = "h36m17") -> tuple[float, float]:
    """``(distance, depth)``: medians over the frames with a finite pelvis (the ``pelvis``
    joint of poses ``(T, J, 3)`` in ``layout``, H36M-17 by default; where it is missing, or in a
    layout without one such as COCO-17, the hip midpoint, which root-relative exports put within
    0.1 mm of it: VideoPose3D's yoga files) of its distance from the origin and of its z; NaN,
    NaN without such a frame. Tells a root-relative export (distance under
    :data:`ROOT_RELATIVE_MAX`) from one that keeps the root where the person is.

    Raises:
        ValueError: a ``layout`` without both hips (:func:`get_layout` for an unknown name)."""
    names = get_layout(layout).joints
    hips = 0.5 * (np.asarray(joints[:, names.index("left_hip")], np.float64)
                  + np.asarray(joints[:, names.index("right_hip")], np.float64))
    pelvis = np.asarray(joints[:, names.index("pelvis")], np.float64) if "pelvis" in names else hips
    pelvis = np.where(np.isfinite(pelvis).all(axis=1, keepdims=True), pelvis, hips)
    pelvis = pelvis[np.isfinite(pelvis).all(axis=1)]
    if not len(pelvis):
        return float("nan"), float("nan")
    return float(np.median(np.linalg.norm(pelvis, axis=1))), float(np.median(pelvis[:, 2]))


def rebased_world_frame(joints: np.ndarray, pelvis_distance: float) -> bool:
    """Whether H36M-17 poses ``(T, 17, 3)`` whose pelvis lies ``pelvis_distance`` from the
    origin (:func:`pelvis_offset`) look like a display world frame rather than a camera
    frame: the pelvis away from the origin and the lowest z of every joint and frame
    exactly 0 (within 1 mm). D3DP's in-the-wild script (paTRICK-swk/D3DP
    ``in_the_wild/videopose_diffusion.py``, the ``test_3d_output_<video>_postprocess.npy``
    file) turns predictions into a z-up world frame for display with VideoPose3D's
    ``camera_to_world`` and rebases the height so that the lowest point is 0, also when the
    file is renamed or reduced to ``(N, 17, 3)``; a camera frame has every joint in front of
    the camera or, root-relative, joints on both sides of the pelvis."""
    z = np.asarray(joints[..., 2], np.float64)
    finite = z[np.isfinite(z)]
    return bool(len(finite) and pelvis_distance > ROOT_RELATIVE_MAX and abs(float(finite.min())) < 1e-3)


REBASED_WORLD_FRAME = ("a world frame with z up and the lowest point rebased to z = 0 (a rendering step's "
                       "camera_to_world output, display only)")


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
    points and the largest finite raw confidence (NaN when there is none)."""
    conf = points[..., 2]
    finite = conf[np.isfinite(conf)]
    raw_max = float(finite.max()) if finite.size else float("nan")
    np.clip(conf, 0.0, 1.0, out=conf)
    return points, raw_max


# --------------------------------------------------------------------------- options


def require_option_int(p: str | Path, name: str, value: Any, minimum: int = 0, allow_none: bool = True) -> int | None:
    """``value`` of option ``name`` as an int >= ``minimum`` (``None`` passes when allowed).

    Raises:
        AdapterError: field ``name`` for a bool, a non-integer or a smaller value.
    """
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise AdapterError(p, name, f"an integer >= {minimum}" + (" or None" if allow_none else ""), repr(value))
    return int(value)


def frame_count_for(p: str | Path, field: str, max_index: int, records: int,
                    frame_count: int | None = None, num_frames: int | None = None) -> int:
    """Number of output frames ``T`` for a file whose largest 0-based frame index is
    ``max_index``, checked before one row per frame is allocated.

    The rule: with ``frame_count`` (the video's frame count) every index must be below it.
    Without it, an index above ``100 * records + 10000`` (``records`` = detections, frame
    records or files in the input) is refused as implausible: a tracker writes at least one
    record per hundred frames of a real recording, and ``image_id "2000000000.jpg"`` in a
    10 kB file would otherwise allocate hundreds of GiB. Sparse files beyond that need
    ``frame_count``. ``num_frames`` (the requested ``T``) obeys the same bound.

    Returns:
        ``num_frames`` when given, else ``max_index + 1``.

    Raises:
        AdapterError: ``field`` naming the index and the bound; ``frame_count`` or
            ``num_frames`` that is not a positive integer.
    """
    frame_count = require_option_int(p, "frame_count", frame_count, 1)
    num_frames = require_option_int(p, "num_frames", num_frames, 1)
    if frame_count is not None:
        limit, why = frame_count, f"< frame_count={frame_count} (the video's frame count)"
    else:
        limit = FRAMES_PER_RECORD * records + FRAMES_SLACK + 1
        why = (f"<= {limit - 1}, plausible for a file of {records} records "
               f"(100 x records + 10000); give --video (frame_count=, the video's frame count) for sparser files")
    if max_index >= limit:
        raise AdapterError(p, field, f"0-based frame indices {why}", f"frame index {max_index}")
    if num_frames is None:
        return max_index + 1
    if max_index >= num_frames:
        raise AdapterError(p, field, f"frame indices < num_frames={num_frames}", f"frame index {max_index}")
    if num_frames > limit:
        source = "the video's frame count" if frame_count is not None else f"the bound for {records} records"
        raise AdapterError(p, "num_frames", f"at most {limit} frames ({source})", num_frames)
    return num_frames


# --------------------------------------------------------------------------- finishing


def _beyond(values: np.ndarray, bound: float) -> tuple[tuple[int, int, float] | None, int]:
    """``((frame, joint, value) of the first finite |value| above ``bound`` or None, number
    of joints with one)`` for ``(T, J, C)`` values, in their own precision."""
    with np.errstate(invalid="ignore"):
        beyond = np.abs(values) > bound
    hits = beyond.any(axis=2)
    if not hits.any():
        return None, 0
    t, j = (int(i) for i in np.argwhere(hits)[0])
    return (t, j, float(values[t, j][beyond[t, j]][0])), int(hits.sum())


def _raise_beyond(p, field: str, first, count: int, bound: float, unit: str, layout: str) -> None:
    if first is not None:
        t, j, value = first
        name = get_layout(layout).joints[j]
        raise AdapterError(p, f"{field} (frame {t}, joint {name})", f"|coordinate| <= {bound:g} {unit}",
                           f"{value:.4g} ({count} joints beyond it)")


def checked_keypoints(p: str | Path, field: str, points: np.ndarray, layout: str,
                      in_place: bool = False) -> tuple[np.ndarray, float]:
    """The last step of every 2D adapter: make ``(T, J, 3)`` x_px, y_px, confidence obey
    the conventions.

    A joint with any non-finite channel (``inf``, NaN, JSON ``Infinity``) is missing: NaN in
    all three channels; so is a placeholder for an undetected joint: one at exactly pixel
    ``(0, 0)`` (OpenPose's ``0, 0, 0``), or every keypoint of a frame at one pixel
    (:func:`pcnet.stages.core.conventions.placeholder_joints`). ``|x|`` or ``|y|`` beyond
    ``MAX_ABS_COORDINATE["px"]`` (1e5) is refused, and so are keypoints that all lie within
    one pixel of the origin (a body smaller than a pixel: coordinates normalised by the image
    size). Confidence is clipped to [0, 1].

    ``in_place``: write the result into ``points`` when it is a writable float32 array (a
    long recording's keypoints are then not copied); checked a block of frames at a time in
    float64, the precision the bound is checked in.

    Returns:
        (float32 ``(T, J, 3)`` points, largest finite raw confidence or NaN).

    Raises:
        AdapterError: ``field`` naming frame and joint for a coordinate beyond the bound,
            when no finite keypoint is left, or when every keypoint is within [-1, 1].
    """
    points = np.asarray(points)
    n_joints = get_layout(layout).num_joints
    if points.ndim != 3 or points.shape[1:] != (n_joints, 3):
        raise AdapterError(p, field, f"(T, {n_joints}, 3) keypoints for layout {layout}", f"shape {points.shape}")
    in_place = in_place and points.dtype == np.float32 and points.flags.writeable
    out = points if in_place else np.empty(points.shape, np.float32)
    bound = MAX_ABS_COORDINATE["px"]
    any_finite, raw_max, first, count = False, float("nan"), None, 0
    largest = -np.inf
    for rows in frame_blocks(len(points)):
        pts = np.array(points[rows], dtype=np.float64)
        pts[~np.isfinite(pts).all(axis=2)] = np.nan  # a joint with any non-finite channel is missing
        pts[np.all(pts[..., :2] == 0.0, axis=2)] = np.nan
        pts[placeholder_joints(pts[..., :2], keep_root=False)] = np.nan
        largest = max(largest, float(np.nanmax(np.abs(pts[..., :2]), initial=-np.inf)))
        block_first, block_count = _beyond(pts[..., :2], bound)
        if first is None and block_first is not None:
            first = (rows.start + block_first[0],) + block_first[1:]
        count += block_count
        any_finite |= bool(np.isfinite(pts).any())
        pts, block_max = clip_confidence(pts)
        raw_max = float(np.fmax(raw_max, block_max))
        if first is None:  # once a coordinate is beyond the bound the file is refused: its cast could overflow
            out[rows] = pts
    _raise_beyond(p, field, first, count, bound, "px", layout)
    if not any_finite:
        raise AdapterError(p, field, "some detected keypoints",
                           "only NaN/inf or placeholders (pixel (0, 0), or a frame on one pixel)")
    if largest <= 1.0:  # a whole body inside one pixel is no detection: image-normalised coordinates
        raise AdapterError(p, field, "pixel coordinates (x_px, y_px)",
                           "every keypoint within [-1, 1]: coordinates normalised by the image size? multiply x by "
                           "its width and y by its height")
    return out, raw_max


def checked_poses(p: str | Path, field: str, joints: np.ndarray, layout: str, units: str,
                  in_place: bool = False) -> np.ndarray:
    """The last step of every 3D adapter: ``(T, J, 3)`` joints in ``units`` through
    :func:`pcnet.stages.core.conventions.validate_poses`, the check every entry point shares.

    ``inf`` becomes NaN; a coordinate beyond ``MAX_ABS_COORDINATE[units]`` (100 m, 1e5 px,
    1e3 normalised) is refused naming the frame and the joint of ``layout``. ``in_place``: an
    adapter's own float32 array is cleaned where it is (no copy of a long recording).

    Returns:
        float32 ``(T, J, 3)``.

    Raises:
        AdapterError: ``field`` for a coordinate beyond the bound, the wrong dtype or shape,
            no frame, or no finite value.
    """
    lay = get_layout(layout)
    try:
        return validate_poses(joints, source=str(p), units=units, num_joints=lay.num_joints, joint_names=lay.joints,
                              in_place=in_place)
    except InputError as exc:
        msg = str(exc)
        msg = msg[len(str(p)) + 2:] if msg.startswith(f"{p}: ") else msg
        said = re.fullmatch(r"(?:([\w\[\]., ]+): )?expected (.+?), got (.+)", msg)
        if said:  # already "expected ..., got ...": keep it one statement, not one nested in another
            where, expected, got = said.groups()
            raise AdapterError(p, field, f"{expected} ({layout} joints, units {units!r})",
                               f"{got} at {where}" if where else got) from None
        raise AdapterError(p, field, f"valid {layout} joints in units {units!r}", msg) from None
