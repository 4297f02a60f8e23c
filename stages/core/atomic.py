"""Atomic file writing: an output appears whole or not at all.

A writer writes a hidden temporary file in the destination folder and ``os.replace``-s it
onto the target (an atomic rename on POSIX and Windows when both are on one file system).
On any error the temporary file is removed and the target is left as it was. Where the user
did not ask to replace an existing file, the temporary is published with ``os.link``, which
fails when the name exists: of two runs racing to one new file, the later one refuses
instead of replacing the earlier one's output.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import uuid
from collections.abc import Iterator
from pathlib import Path

from .errors import InputError, environment_errno, reason, short_path

#: The longest file name (bytes) that ext4, XFS, btrfs, ZFS, APFS and tmpfs accept (their
#: NAME_MAX): pcnet's hidden temporary names are kept within it, whatever the output's name.
NAME_MAX = 255
#: errno values of a file system without hard links (FAT, some network shares), where a
#: new file is published by a checked rename instead of ``os.link``.
_NO_HARD_LINKS = {errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EXDEV, errno.EMLINK, errno.ENOSYS}


def hidden_name(name: str, tail: str) -> str:
    """``.<name><tail>``: the hidden temporary name pcnet writes beside the output ``name``,
    within :data:`NAME_MAX` bytes. Where ``name`` leaves no room, its longest prefix that
    fits is kept and followed by ``~`` and 16 hex digits of its BLAKE2b digest, so that two
    long names sharing a prefix still get distinct temporaries, and the same name always
    the same one (:func:`pcnet.pipeline.outdir.clean_stale` finds an output's leftovers by it).

    Args:
        name: the output's file or folder name (one path component).
        tail: what follows the name (a unique id and suffix, at most ``NAME_MAX - 18`` bytes).
    """
    room = NAME_MAX - 1 - len(os.fsencode(tail))
    if len(os.fsencode(name)) <= room:
        return f".{name}{tail}"
    digest = "~" + hashlib.blake2b(os.fsencode(name), digest_size=8).hexdigest()
    prefix = name
    while len(os.fsencode(prefix)) > room - len(digest):  # by characters: never half a UTF-8 sequence
        prefix = prefix[:-1]
    return f".{prefix}{digest}{tail}"


def make_parents(folder: Path, created: list[Path]) -> None:
    """Create ``folder`` and its missing parents, appending each folder this call created to
    ``created`` as soon as it exists (outermost first), so that a failure or an interrupt
    half-way still leaves the list of what to remove. A folder another process creates at the
    same moment is not this run's."""
    missing = []
    for folder in (folder, *folder.parents):
        if folder.exists() or folder.is_symlink():
            if not folder.is_dir():
                raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(folder))
            break
        missing.append(folder)
    for folder in reversed(missing):
        try:
            folder.mkdir()
        except FileExistsError:
            continue
        created.append(folder)


def remove_created(created: list[Path]) -> None:
    """Remove the folders :func:`make_parents` created, innermost first, each only while it
    is empty: a folder someone else has put something into since is theirs to keep."""
    for folder in reversed(created):
        try:
            folder.rmdir()
        except OSError:
            return


def _publish_new(tmp_path: Path, target: Path) -> None:
    """Give ``tmp_path`` the name ``target`` only if ``target`` does not exist, atomically
    (``link(2)`` fails with ``EEXIST``), then drop the temporary name."""
    taken = InputError(f"{short_path(target)}: expected a new file, got one written there while pcnet worked (another "
                       f"run?); left as it is: pass --overwrite to replace it, or choose another name")
    try:
        os.link(tmp_path, target)
    except FileExistsError:
        raise taken from None
    except OSError as err:
        if err.errno not in _NO_HARD_LINKS:
            raise
        if target.exists() or target.is_symlink():  # no atomic check here: the nearest one
            raise taken from None
        os.replace(tmp_path, target)
        return
    tmp_path.unlink()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = ".tmp", replace: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    The temporary (:func:`hidden_name` ``(name, ".<uuid4><suffix>")``, not created here)
    lives in the same folder so ``os.replace`` stays a rename (never a cross-device copy),
    and the caller creates it with the usual permissions. On an exception the temporary is
    deleted and the exception propagates; ``path`` is untouched.

    Args:
        path: the file to write.
        suffix: the temporary's suffix (a writer that picks its format by suffix needs it).
        replace: whether an existing ``path`` may be replaced; when false, a file that
            appeared there while the caller wrote (another run's) is kept and the call
            refused.

    Raises:
        InputError: the destination folder does not exist, it (or the target) cannot be
            written (the reason and what to do), or ``replace`` is false and ``path``
            exists; the message names ``path``, never the hidden temporary.
    """
    target = Path(path)
    if not target.parent.is_dir():
        raise InputError(f"{short_path(target)}: expected an existing destination folder, got no folder "
                         f"{short_path(target.parent)}")
    # A fresh unique name rather than mkstemp: mkstemp creates the file with mode 0600,
    # which os.replace would carry over to the user's output.
    tmp_path = target.parent / hidden_name(target.name, f".{uuid.uuid4().hex}{suffix}")
    try:
        yield tmp_path
        if replace:
            os.replace(tmp_path, target)
        else:
            _publish_new(tmp_path, target)
    except OSError as err:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        # numpy and zipfile raise a failed write (ENOSPC, a short write) without a file name
        unnamed_write_error = err.filename is None and environment_errno(err) is not None
        if unnamed_write_error or (err.filename is not None and Path(err.filename) in (tmp_path, target)):
            # the user's file named, not the temporary, whose name means nothing to them
            raise InputError(f"{short_path(target)}: cannot write it ({reason(err)})") from err
        raise
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise


def write_text(path: str | os.PathLike, text: str, replace: bool = True) -> Path:
    """Write ``text`` to ``path`` atomically (the destination folder must exist; ``replace``
    as in :func:`atomic_path`)."""
    with atomic_path(path, replace=replace) as tmp:
        tmp.write_text(text)
    return Path(path)


def writing_failed(err: BaseException, staging: Path, shown: str) -> InputError | None:
    """The one-line refusal, naming ``shown`` (the user's output as they gave it, e.g.
    ``"--out results/run1"``), for a failure of the environment (a full disk or inode table, a
    quota, a read-only or vanished folder, too many open files) while writing into the hidden
    folder ``staging``; ``None`` for any other error, which keeps its own message. Writers
    report such a failure as an ``OSError`` or as :func:`atomic_path`'s ``InputError`` caused
    by one, naming a hidden temporary that means nothing to the user."""
    cause = err if isinstance(err, OSError) else err.__cause__ if isinstance(err, InputError) else None
    if not isinstance(cause, OSError) or environment_errno(cause) is None:
        return None
    what = "the outputs"
    if cause.filename is not None:
        try:
            inside = Path(os.fsdecode(cause.filename)).resolve().relative_to(staging.resolve())
        except (ValueError, OSError, RuntimeError):
            return None
        if inside.parts and not inside.name.startswith("."):  # a writer's hidden temporary is no name to show
            what = short_path(inside.as_posix())
    return InputError(f"{shown}: cannot write {what} there ({reason(cause)}); left as it was")
