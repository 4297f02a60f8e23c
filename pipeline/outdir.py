"""Output folders that never cost the user a file: checked before any work, written beside
the destination, swapped in by renames.

Rules (docs/safety.md):

* ``--out`` may not be the current folder or one of its ancestors, may not contain any
  input file (an input's own folder or any folder above it), and may not be an input.
* ``--overwrite`` replaces only a previous pcnet output: a folder holding the marker file
  :data:`MARKER` and nothing that marker does not list, each file unchanged since (size and
  modification time, or size and content where a copy gave the file a new time). Anything
  else is refused, whatever the flag says.
* A run writes into a hidden sibling ``.<out>.pcnet-tmp-<id>`` (with the marker), then
  renames the old output to ``.<out>.pcnet-trash-<id>``, the new one to ``out``, and only
  then deletes from the trash the files its marker lists, unchanged, by name: anything the user
  put into the old output during the run (after the check above) stays, with the trash folder,
  unmarked, and the run says where. A kill at any instant leaves either the whole old or the whole new
  output at ``out`` (or, between the two renames, the whole old one in the trash, which the
  next run renames back); the next run removes leftovers whose marker names a process that
  is no longer running. Hidden names stay within the file system's name limit however long
  ``out``'s name is (:func:`pcnet.stages.core.atomic.hidden_name`).
* Without ``--overwrite`` the new output is published only if ``out`` is still free: the run
  claims the name with ``mkdir`` (which fails if it exists) and renames its staged folder
  onto that empty claim, so of two runs racing to one new ``out`` the later one refuses and
  the earlier one's output stays whole.
* A run that fails or is interrupted removes what it created: its staged folder and the
  missing parent folders of ``out`` it made.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import re
import shutil
import socket
import stat
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from pcnet.stages.core.atomic import NAME_MAX, hidden_name, make_parents, remove_created, write_text, writing_failed
from pcnet.stages.core.errors import InputError, reason, short_path

from .interrupt import InterruptedAfterPublishing, check_interrupted, interrupts_deferred

MARKER = ".pcnet-output"
TMP_TAG = ".pcnet-tmp-"
TRASH_TAG = ".pcnet-trash-"
#: What :func:`_trash_name` appends to an output's name, with a 12-hex id.
_TRASH_TAIL = f"{TRASH_TAG}{'0' * 12}"
#: An empty staged folder without a marker is a leftover only once it is this old (s): a row
#: that has just created its folder writes its marker within microseconds, and another row's
#: clean-up running in that window must not remove it (as Ray rows starting together did).
EMPTY_STAGED_GRACE_S = 60.0
#: Bytes pcnet's paths inside an output folder add to the folder's own path: the longest
#: hidden temporary of an output file (``.<name>.<32 hex>.tmp`` for names up to 64 bytes),
#: or of `pcnet opensim`'s staging folder and the files in it.
INSIDE_OUT_BYTES = 200
#: The longest path the kernel accepts in one call where ``pathconf`` cannot tell (Linux's PATH_MAX).
DEFAULT_PATH_MAX = 4096


def is_within(path: str | os.PathLike, folder: str | os.PathLike) -> bool:
    """``path == folder or folder in path.parents`` for absolute resolved paths, compared as
    text (a manifest's 100,000 rows check this several times each; building every parent
    Path cost most of it)."""
    p, f = os.fspath(path), os.fspath(folder)
    if os.sep != "/":
        p, f = os.path.normcase(p), os.path.normcase(f)
    return p == f or (p.startswith(f) and (f.endswith(os.sep) or p[len(f)] == os.sep))


def check_out_folder(out: str | os.PathLike, inputs: Iterable[str | os.PathLike | None] = (),
                     overwrite: bool = False, *,
                     resolve: Callable[[str | os.PathLike], Path] | None = None,
                     exists: Callable[[str], bool] | None = None) -> Path:
    """Check that ``out`` may be written (and, with ``overwrite``, replaced) before any work.

    Args:
        out: the output folder as the user gave it (``.``, ``x/..`` and symlinks resolved).
        inputs: the run's input files or folders (``None`` entries ignored).
        overwrite: the user asked to replace an existing output.
        resolve: ``Path(p).resolve()`` or a cache of it (``pcnet batch`` checks many rows
            sharing folders and inputs).
        exists: ``Path(p).exists()`` of ``out`` as given, or a cache of it (``pcnet batch``
            has resolved each row's ``out`` before, and a ``stat`` is its costliest step).

    Returns:
        the resolved absolute output path.

    Raises:
        InputError: one line naming ``out`` and the rule it breaks.
    """
    resolve = resolve or (lambda p: Path(p).resolve())
    given = short_path(out)
    if os.path.islink(out) and not os.path.exists(out) and _dangling(out):
        # followed, the output would be made wherever the link points (in a shared folder, where
        # someone else put it: a file-safety trial's); a link to an existing folder is that folder
        raise InputError(f"--out {given}: expected a new folder or an existing one, got a symbolic link to a missing "
                         f"path ({os.readlink(out)}); give the folder itself")
    target = resolve(out)
    text = str(target)  # compared as text below: a batch checks 100,000 rows
    _check_path_length(text, given)
    if is_within(resolve(os.getcwd()), text):
        raise InputError(f"--out {given}: expected a new folder for pcnet's outputs, got the current folder "
                         f"or one above it ({target})")
    for item in inputs:
        if item is None:
            continue
        source = str(resolve(item))
        if is_within(source, text) or is_within(text, source):
            raise InputError(f"--out {given}: expected a folder apart from the inputs, got one that "
                             f"{'is' if source == text else 'contains' if is_within(source, text) else 'lies inside'}"
                             f" the input {item}")
    _check_writable(text, given)
    if not (exists(os.fspath(out)) if exists else target.exists()):
        return target
    if not target.is_dir():
        raise InputError(f"--out {given}: expected a folder for pcnet's outputs, got an existing file; choose "
                         f"another --out")
    try:
        foreign = foreign_entries(target)
    except OSError as err:
        raise InputError(f"--out {given}: expected a folder pcnet can read, got {err.strerror or err}; choose another "
                         f"--out") from None
    if foreign:
        shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
        rule = ("--overwrite replaces only a previous pcnet output" if overwrite else
                "expected a new folder (or, with --overwrite, a previous pcnet output)")
        fix = "move those files out of it to replace it, or choose another --out" if overwrite else "choose another --out"
        raise InputError(f"--out {given}: {rule}, got a folder holding files pcnet did not write or that changed "
                         f"since ({shown}); {fix}")
    if not overwrite:
        empty = not any(target.iterdir())
        raise FileExistsError(f"--out {given}: expected a new folder, got one that exists"
                              f"{' (empty)' if empty else ' (a previous pcnet output)'}; choose another --out or pass "
                              f"--overwrite")
    return target


def _dangling(link: str | os.PathLike) -> bool:
    """Whether the symbolic link ``link`` leads to a missing path (not a loop, which resolving
    names as one)."""
    try:
        Path(link).resolve(strict=True)
    except FileNotFoundError:
        return True
    except (OSError, RuntimeError):
        return False
    return False


#: Folders an output's parent was found writable in, so that a batch's rows sharing one are
#: checked once: only a yes is kept (a folder made read-only since is still met when the run
#: writes, as before this check); cleared when it reaches 4,096 folders.
_WRITABLE_PARENTS: set[str] = set()


def _check_writable(target: str, given: str) -> None:
    """Refuse, before any work, an output whose folder this process cannot write in: the
    output is staged beside ``target`` and renamed in at the end (:func:`staged_output`), so
    the nearest existing folder above it must take new entries. ``access(2)`` answers at no
    cost (permissions, and a read-only file system or an immutable folder even for root);
    where it says no, a folder made there and removed again gives the reason the run would
    have met, and decides (access cannot see every rule, an ACL for one). A run had computed
    everything before the staging folder met a read-only parent."""
    parent = os.path.dirname(target)
    if parent in _WRITABLE_PARENTS:
        return
    folder = parent
    while not os.path.isdir(folder):
        if os.path.dirname(folder) == folder:
            return
        folder = os.path.dirname(folder)
    if os.access(folder, os.W_OK | os.X_OK):
        if len(_WRITABLE_PARENTS) >= 4096:
            _WRITABLE_PARENTS.clear()
        _WRITABLE_PARENTS.add(parent)
        return
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".pcnet-probe-", dir=folder))
    except OSError as err:
        raise InputError(f"--out {given}: expected a place pcnet can write in, got {short_path(folder)} "
                         f"({reason(err)}); choose another --out") from None


@functools.lru_cache(maxsize=256)
def _folder_limits(folder: str) -> tuple[int, int, int, int]:
    """``(NAME_MAX, PATH_MAX, longest name, length)`` for outputs inside the absolute ``folder``: the
    limits of the file system holding it or, where it does not exist yet, its nearest existing
    parent (``pathconf``; Linux's 255 and 4096 where it cannot tell), and the byte length of
    the longest name in ``folder`` and of ``folder`` itself (a batch's rows share a few
    folders, so a row's check looks at its own name only)."""
    existing = Path("/")
    for parent in (Path(folder), *Path(folder).parents):
        with contextlib.suppress(OSError):  # a name beyond the limit: ENAMETOOLONG from stat
            if parent.is_dir():
                existing = parent
                break
    longest = max((len(os.fsencode(part)) for part in folder.split(os.sep)), default=0)
    length = len(os.fsencode(folder.rstrip(os.sep)))  # "/" joins its names without another separator
    try:
        return os.pathconf(existing, "PC_NAME_MAX"), os.pathconf(existing, "PC_PATH_MAX"), longest, length
    except (OSError, ValueError):
        return NAME_MAX, DEFAULT_PATH_MAX, longest, length


def _check_path_length(target: str, given: str) -> None:
    """Refuse, before any work, an output path the file system cannot hold with pcnet's files
    inside it: a name in it beyond the file system's name limit, or a whole path within
    :data:`INSIDE_OUT_BYTES` of the longest path a call may name (:func:`_folder_limits`)."""
    folder, name = os.path.split(target)
    name_max, path_max, longest, folder_bytes = _folder_limits(folder)
    name_bytes = len(name) if name.isascii() else len(os.fsencode(name))
    if max(longest, name_bytes) > name_max:
        raise InputError(f"--out {given}: expected folder names of at most {name_max} bytes (this file system's "
                         f"limit), got one of {max(longest, name_bytes)} bytes; choose a shorter --out")
    # the longest path a run names: a file inside the trash folder, the longer of the two hidden names
    trash = 1 + name_bytes + len(_TRASH_TAIL)  # hidden_name's ".<name><tail>" where it fits
    if trash > NAME_MAX:
        trash = len(os.fsencode(hidden_name(name, _TRASH_TAIL)))
    longest_path = folder_bytes + 1 + trash + 1 + INSIDE_OUT_BYTES
    if longest_path >= path_max:
        raise InputError(f"--out {given}: expected a path short enough for pcnet's files inside it (this system "
                         f"names at most {path_max - 1} bytes in one path), got {len(os.fsencode(target))} bytes "
                         f"for the folder; choose a shorter --out")


def foreign_entries(folder: Path) -> list[str]:
    """Names in ``folder`` that pcnet did not write, or that changed since (all of them when
    there is no valid marker; ``[folder name]`` when ``folder`` is not a folder), leaving out
    a killed `pcnet opensim`'s staging folder (:func:`stale_staging`). The marker records each
    file's size, modification time and content digest, so an output the user edited (a CSV
    opened and saved) counts as theirs and is never deleted, while a copied output folder
    (``cp -r``, scp, a sync tool: new times, same bytes) stays pcnet's."""
    if folder.is_symlink() or not folder.is_dir():
        return [folder.name]
    listed = read_marker(folder).get("files")
    if not isinstance(listed, dict):
        listed = {}
    stale = {entry.name for entry in stale_staging(folder)}
    return [entry.name for entry in sorted(folder.iterdir(), key=lambda p: p.name)
            if entry.name != MARKER and entry.name not in stale and not _listed_unchanged(entry, listed)]


def stale_staging(folder: Path) -> list[Path]:
    """Staging folders that a killed `pcnet opensim` left inside ``folder`` (pcnet's own,
    their process gone): the next `pcnet opensim` removes them, and `pcnet run --overwrite`
    does not count them as the user's."""
    from pcnet.stages.opensim_ik import staging_owner

    stale = []
    for entry in sorted(folder.iterdir()):
        owner = staging_owner(entry.name)
        if owner and entry.is_dir() and not entry.is_symlink() and not _process_alive(
                {"pid": owner[0], "host": owner[1]}):
            stale.append(entry)
    return stale


def _listed_unchanged(path: Path, listed: dict) -> bool:
    """Whether ``path`` is a plain file that ``listed`` (a marker's ``files``) records with
    its current size and either its modification time or, where the time changed (a copy),
    its content digest (markers written before digests were recorded: the time only)."""
    if path.name not in listed or path.is_symlink() or not path.is_file():
        return False
    stamp, st = listed[path.name], path.stat()
    if not isinstance(stamp, dict) or stamp.get("size") != st.st_size:
        return False
    if stamp.get("mtime_ns") == st.st_mtime_ns:
        return True
    return "blake2b" in stamp and stamp["blake2b"] == _digest(path)


def _digest(path: Path) -> str:
    """BLAKE2b (16 bytes, hex) of the file's content, read a MiB at a time."""
    h = hashlib.blake2b(digest_size=16)
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _stamp(path: Path) -> dict:
    st = path.stat()
    return {"size": st.st_size, "mtime_ns": st.st_mtime_ns, "blake2b": _digest(path)}


def owned_files(folder: Path) -> dict:
    """``name -> stamp`` of the files the folder's pcnet marker lists (``{}`` when the folder
    has no pcnet marker)."""
    info = read_marker(folder)
    files = info.get("files") if info.get("writer") == "pcnet" else None
    return files if isinstance(files, dict) else {}


def listed_files_missing(folder: Path) -> list[str]:
    """The files the folder's pcnet marker lists that are no longer there (deleted); an
    edited file is still there (it is the user's now, and never replaced)."""
    return [name for name in owned_files(folder) if not (folder / name).is_file()]


def is_owned(folder: Path, name: str) -> bool:
    """Whether ``folder/name`` is a file pcnet wrote there, unchanged since (as
    :func:`foreign_entries` judges it)."""
    return _listed_unchanged(folder / name, owned_files(folder))


def register_files(folder: Path, names) -> None:
    """Add files pcnet has just written into ``folder`` to its pcnet marker, so that the
    folder stays recognisably pcnet's (``--overwrite`` may replace it); nothing happens for a
    folder without a pcnet marker."""
    info = read_marker(folder)
    if info.get("writer") != "pcnet":
        return
    info["files"] = {**owned_files(folder), **{n: _stamp(folder / n) for n in names}}
    write_text(folder / MARKER, json.dumps(info, indent=1) + "\n")


def read_marker(folder: Path) -> dict:
    """The marker's JSON content, ``{}`` when it is missing or unreadable."""
    try:
        data = json.loads((folder / MARKER).read_text())
    except (OSError, ValueError, RecursionError):
        return {}
    return data if isinstance(data, dict) else {}


def _write_marker(folder: Path, state: str) -> None:
    files = {p.name: _stamp(p) for p in sorted(folder.iterdir()) if p.name != MARKER and p.is_file()}
    info = {"writer": "pcnet", "state": state, "pid": os.getpid(), "host": socket.gethostname(),
            "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "files": files}
    # atomically: a process killed while rewriting it must not leave a folder without a marker,
    # which clean_stale would then never recognise as pcnet's
    write_text(folder / MARKER, json.dumps(info, indent=1) + "\n")


#: Staging and trash folders of this process's runs in progress (resolved paths): a folder
#: marked with this process's id is another thread's live run if listed here, a leftover
#: otherwise (a container's pcnet often runs under the same small pid as a killed one before it).
_LIVE_FOLDERS: set[str] = set()
_LIVE_FOLDERS_LOCK = threading.Lock()


def _staging_live_here(folder: Path) -> bool:
    with _LIVE_FOLDERS_LOCK:
        return str(folder.resolve()) in _LIVE_FOLDERS


def _set_live(folder: Path, live: bool) -> None:
    """List (or unlist) ``folder``, a resolved path, in :data:`_LIVE_FOLDERS`."""
    with _LIVE_FOLDERS_LOCK:
        (_LIVE_FOLDERS.add if live else _LIVE_FOLDERS.discard)(str(folder))


def _process_alive(info: dict) -> bool:
    # A process on another host (a cluster node sharing this filesystem) cannot be checked
    # from here: its folder is left alone rather than deleted under a running row.
    if info.get("host") != socket.gethostname():
        return True
    if not isinstance(info.get("pid"), int):
        return False
    try:
        os.kill(info["pid"], 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    return info["pid"] != os.getpid()


def _leftover_kind(name: str) -> str | None:
    """``"tmp"`` or ``"trash"`` for a hidden staging or trash folder name pcnet makes for an
    output (``.NAME.pcnet-tmp-<12 hex>``, ``.NAME.pcnet-trash-<12 hex>``, NAME perhaps shortened
    by :func:`~pcnet.stages.core.atomic.hidden_name`), else ``None``: the whole name must match,
    so an output whose own name contains a tag is not mistaken for one."""
    for kind, tag in (("tmp", TMP_TAG), ("trash", TRASH_TAG)):
        if re.fullmatch(rf"\.(.+){re.escape(tag)}[0-9a-f]{{12}}", name, re.DOTALL):  # a name may hold a newline
            return kind
    return None


def _hidden_staging_beside(target: Path) -> list[Path]:
    """The entries beside ``target`` whose names could be pcnet's staging or trash folders,
    sorted: a study's folder may hold 100,000 outputs side by side, and each run's clean-up
    looks only at the few hidden names among them (a Path for each entry cost 1.8 s a run)."""
    with os.scandir(target.parent) as entries:
        names = [e.name for e in entries if e.name.startswith(".") and (TMP_TAG in e.name or TRASH_TAG in e.name)]
    return [target.parent / name for name in sorted(names)]


def clean_stale(target: Path) -> list[Path]:
    """Remove pcnet's own leftovers beside ``target`` from killed runs: hidden temp folders
    whose marker names a process no longer running, and ``target``'s own trash folders. A trash
    folder left between the two renames of a replacement of ``target`` is renamed back to
    ``target`` when ``target`` is missing (the old output, complete). Another output's trash is
    left for that output's next run: it may be the only copy of that output, and it may belong
    to a live replacement (:func:`_swap_in` marks it with its own process). Folders without a
    pcnet marker are never touched. Returns what was removed."""
    removed: list[Path] = []
    if not target.parent.is_dir():
        return removed
    for entry in _hidden_staging_beside(target):
        kind = _leftover_kind(entry.name)
        if kind is None or entry.is_symlink() or not entry.is_dir():
            continue
        if kind == "trash" and entry.name != _trash_name(target, entry.name[-12:]).name:
            continue
        info = read_marker(entry)
        if (not info and kind == "tmp" and not any(entry.iterdir())
                and time.time() - entry.stat().st_mtime > EMPTY_STAGED_GRACE_S):
            entry.rmdir()  # killed between creating its staged folder and writing the marker
            removed.append(entry)
            continue
        if info.get("writer") != "pcnet" or _process_alive(info) or _staging_live_here(entry):
            continue
        if kind == "trash" and not target.exists() and not target.is_symlink():
            os.rename(entry, target)
            continue
        if kind == "trash":  # a replaced output: only pcnet's own files go (the user may have added one)
            remove_owned(entry, lambda path, err: None)
        else:
            shutil.rmtree(entry, ignore_errors=True)
        removed.append(entry)
    return removed


def _staged_name(target: Path, tag: str, uid: str) -> Path:
    return target.parent / hidden_name(target.name, f"{tag}{uid}")


def _trash_name(target: Path, uid: str) -> Path:
    """``.<out>.pcnet-trash-<uid>`` beside ``target`` (its name shortened where needed)."""
    return _staged_name(target, TRASH_TAG, uid)


@contextlib.contextmanager
def staged_output(out: str | os.PathLike, overwrite: bool = False, left: list[str] | None = None) -> Iterator[Path]:
    """Yield a fresh hidden folder beside ``out`` to write into; on success swap it in as
    ``out`` (see the module docstring), on any exception (``KeyboardInterrupt`` and the
    CLI's SIGTERM included) delete it and the parent folders of ``out`` this call created, and
    leave ``out`` as it was.

    Folders are created with the process umask (as ``mkdir`` does), not ``0700``; one that
    replaces an earlier output takes that folder's mode, group and extended attributes
    (:func:`_carry_folder_attributes`). The swap and the earlier output's removal run whole
    (:func:`~.interrupt.interrupts_deferred`): an interrupt during them is raised after, as
    :class:`~.interrupt.InterruptedAfterPublishing` once the output is in place. Call
    :func:`check_out_folder` first; this function does not re-check its rules, except that
    without ``overwrite`` the output is published only where ``out`` is still free when the
    run ends (another run may have finished there meanwhile), and an output that
    :func:`clean_stale` renames back from a killed replacement's trash after that check is
    kept and the run refused, as an existing output would have been.

    Raises:
        InputError: the output folder (or its parent) cannot be created or written (naming
            ``out`` and what to do, never the hidden temporary), another run published ``out``
            first and ``overwrite`` is false, or a killed run's output came back there and
            ``overwrite`` is false.
    """
    target = Path(out).resolve()
    given = short_path(out)
    tmp = _staged_name(target, TMP_TAG, uuid.uuid4().hex[:12])
    created: list[Path] = []
    try:
        try:
            make_parents(target.parent, created)
            was_there = target.exists() or target.is_symlink()
            clean_stale(target)
        except OSError as err:  # make_parents names a file in the way as the ENOTDIR's file name
            why = f"{err.filename} is a file, not a folder" if isinstance(err, NotADirectoryError) else reason(err)
            raise InputError(f"--out {given}: cannot create the output folder there ({why})") from err
        if not was_there and target.exists() and not overwrite:
            raise InputError(f"--out {given}: expected a new folder, got the output of an earlier pcnet run that was "
                             f"killed while replacing it, now put back there; pass --overwrite to replace it")
        try:
            # Inside the clean-up block: an interrupt arriving as mkdir returns must not leave it.
            _set_live(tmp, True)
            tmp.mkdir()
            _write_marker(tmp, "writing")
            yield tmp
            check_interrupted()  # an interrupt swallowed on the way must still stop the swap
            _write_marker(tmp, "complete")
            # The user may have put files into the old output while this run worked: they are
            # theirs, and swapping would delete them with the old folder.
            appeared = foreign_entries(target) if target.exists() else []
            if appeared:
                raise InputError(f"--out {given}: expected only pcnet's files in the output folder to replace, got "
                                 f"{', '.join(appeared[:5])}{' ...' if len(appeared) > 5 else ''} added or changed "
                                 f"during the run; left as they are, and this run's output not written: move them and "
                                 f"run again")
            published = False
            try:
                # the swap and the old output's removal run whole: an interrupt waits for them
                with interrupts_deferred():
                    trash = _swap_in(tmp, target, overwrite, given)
                    published = True
                    if trash is not None:
                        _discard_replaced(trash, given, left)
            except KeyboardInterrupt as stop:
                if published:
                    raise InterruptedAfterPublishing(f"--out {given}") from stop
                raise
        except (OSError, InputError) as err:
            refusal = writing_failed(err, tmp, f"--out {given}")
            if refusal is None:
                raise
            raise refusal from err
        finally:
            _set_live(tmp, False)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        remove_created(created)
        raise


def _discard_replaced(trash: Path, given: str, left: list[str] | None) -> None:
    """Remove from ``trash``, the output an ``--overwrite`` replaced, what pcnet wrote there
    (:func:`remove_owned`), and add to ``left`` what stays and why."""
    failures: list[str] = []
    kept = remove_owned(trash, lambda path, err: failures.append(f"{Path(path).name}: {reason(err)}"))
    _set_live(trash, False)
    if kept and left is not None:  # a file-safety trial's note, written as the run ended, was deleted
        left.append(f"{', '.join(kept[:5])}{' ...' if len(kept) > 5 else ''} appeared in --out {given} while this "
                    f"run replaced it: kept, not deleted, in {trash} (hidden, beside it): move them back")
    if failures and left is not None:  # a bad-input trial: an undeletable old file stayed there unsaid
        left.append(f"files of the output this run replaced are left in {trash} ({failures[0]}"
                    f"{'; and more' if len(failures) > 1 else ''}) beside --out {given}: remove that folder "
                    f"yourself (without its marker, pcnet cannot tell it is its own)")


def remove_owned(folder: Path, failed) -> list[str]:
    """Delete from ``folder`` (a replaced output, renamed to its trash name) what pcnet wrote
    there, by name: the files its marker lists, unchanged (:func:`foreign_entries`' judgement),
    and a killed `pcnet opensim`'s staging; then the marker and the folder, where nothing else
    is left. Anything else (a file the user added or edited while a run replaced the folder)
    stays, and so does the folder, without its marker: pcnet never touches a folder without
    one. ``failed(path, error)`` is called for what cannot be removed.

    Returns:
        the names kept that pcnet did not write (sorted).
    """
    listed = owned_files(folder)
    stale = {entry.name for entry in stale_staging(folder)}
    for entry in sorted(folder.iterdir()):
        if entry.name in stale:
            _remove_tree(entry, failed)
        elif entry.name != MARKER and _listed_unchanged(entry, listed):
            try:
                entry.unlink()
            except OSError as err:
                failed(entry, err)
    with contextlib.suppress(OSError):
        (folder / MARKER).unlink()
    try:
        folder.rmdir()
    except OSError:  # not empty: the user's files (or ones that arrived after the scan), left unmarked
        pass
    if not folder.exists():
        return []
    return sorted(e.name for e in folder.iterdir() if not _listed_unchanged(e, listed) and e.name not in stale)


def _remove_tree(folder: Path, failed) -> None:
    """``shutil.rmtree(folder)`` that goes on past what it cannot remove, calling ``failed(path,
    error)`` for each (``onexc`` from Python 3.12, ``onerror`` before it)."""
    if sys.version_info >= (3, 12):
        shutil.rmtree(folder, onexc=lambda _, path, err: failed(path, err))
    else:
        shutil.rmtree(folder, onerror=lambda _, path, info: failed(path, info[1]))


def _carry_folder_attributes(old: Path, new: Path) -> None:
    """Give ``new``, the staged output about to replace the folder ``old``, what a folder
    rewritten in place would have kept: ``old``'s permission bits (setgid included), group and
    extended attributes (POSIX ACLs; :func:`shutil.copystat`, which skips those the file system
    or the user may not set), with ``new``'s own times; where ``old`` is setgid, its files take
    its group as files made inside it would. A file-safety trial's shared group folder lost its
    group and setgid bit to ``--overwrite``. Best effort: a group the user does not belong to
    stays the one the folder was made with."""
    st = old.stat()
    # each step on its own: a group the user is not in must not cost the mode (a second
    # file-safety trial's private 0700 folder came back 0755, readable by anyone)
    with contextlib.suppress(OSError):
        os.chown(new, -1, st.st_gid)  # before the mode: a change of group clears the setgid bit
    with contextlib.suppress(OSError):
        shutil.copystat(old, new)
    with contextlib.suppress(OSError):
        os.chmod(new, stat.S_IMODE(st.st_mode))  # copystat's, unless it stopped before it
    with contextlib.suppress(OSError):
        os.utime(new)
    if st.st_mode & stat.S_ISGID and os.stat(new).st_gid == st.st_gid:
        for path in new.rglob("*"):
            with contextlib.suppress(OSError):
                os.chown(path, -1, st.st_gid, follow_symlinks=False)


def _swap_in(tmp: Path, target: Path, overwrite: bool, given: str) -> Path | None:
    """Publish ``tmp`` as ``target``. With ``overwrite``: rename ``target`` (if any) to a
    trash name, then ``tmp`` to ``target``; if the second rename fails or is interrupted, the
    old output goes back. Without: claim ``target`` with ``mkdir`` (atomic: it fails where
    anything exists there) and rename ``tmp`` onto that empty claim. Returns the trash path."""
    if not overwrite:
        try:
            target.mkdir()
        except FileExistsError:
            raise InputError(f"--out {given}: expected a new folder, got one that another run (or someone) made "
                             f"there while this run worked; left as it is, and this run's output not written: pass "
                             f"--overwrite to replace a pcnet output, or choose another --out") from None
        try:
            os.rename(tmp, target)
        except BaseException:
            with contextlib.suppress(OSError):
                target.rmdir()
            raise
        return None
    trash = None
    try:
        if target.exists():
            trash = _trash_name(target, uuid.uuid4().hex[:12])
            _set_live(trash, True)  # another thread's clean_stale must not take it for a leftover
            _carry_folder_attributes(target, tmp)
            info = read_marker(target)
            if info.get("writer") == "pcnet":  # the trash is this live run's until it is removed
                before = (target / MARKER).read_bytes()
                write_text(target / MARKER, json.dumps({**info, "pid": os.getpid(), "host": socket.gethostname()},
                                                       indent=1) + "\n")
            try:
                os.rename(target, trash)
            except OSError as err:  # a mount point (EBUSY) cannot be moved aside: a user trial
                if info.get("writer") == "pcnet":  # left as it was, its marker too (a second file-safety trial)
                    with contextlib.suppress(OSError):
                        write_text(target / MARKER, before.decode("utf-8"))
                raise InputError(f"--out {given}: cannot move the earlier output aside to replace it ({reason(err)}); "
                                 f"left as it was, and this run's output not written") from err
        os.rename(tmp, target)
    except BaseException:
        if trash is not None:
            if not target.exists():  # only after the first rename: the old output goes back
                os.rename(trash, target)
            _set_live(trash, False)
        raise
    return trash
