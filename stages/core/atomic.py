"""Atomic file writing: an output appears whole or not at all.

A writer writes a hidden temporary file in the destination folder and ``os.replace``-s it
onto the target (an atomic rename on POSIX and Windows when both are on one file system).
On any error the temporary file is removed and the target is left as it was.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Iterator
from pathlib import Path

from .errors import InputError


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = ".tmp") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    The temporary (``.<name>.<uuid4><suffix>``, not created here) lives in the same
    folder so ``os.replace`` stays a rename (never a cross-device copy), and the caller
    creates it with the usual permissions. On an exception the temporary is deleted and
    the exception propagates; ``path`` is untouched.

    Raises:
        InputError: the destination folder does not exist, or it (or the target) cannot be
            written; the message names ``path``, never the hidden temporary.
    """
    target = Path(path)
    if not target.parent.is_dir():
        raise InputError(f"{target}: expected an existing destination folder, got no folder {target.parent}")
    # A fresh unique name rather than mkstemp: mkstemp creates the file with mode 0600,
    # which os.replace would carry over to the user's output.
    tmp_path = target.parent / f".{target.name}.{uuid.uuid4().hex}{suffix}"
    try:
        yield tmp_path
        os.replace(tmp_path, target)
    except OSError as err:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        if err.filename is not None and Path(err.filename) in (tmp_path, target):
            raise InputError(f"{target}: cannot write it ({err.strerror or err})") from err
        raise
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (the destination folder must exist)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)
