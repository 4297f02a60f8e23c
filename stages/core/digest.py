"""Content digests of files: what tells one input (a lifter output, a training data file) from
another of the same name."""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path

#: Bytes read at a time: bounded memory for a long video or a large mocap archive.
_CHUNK = 1 << 20


def sha256_file(path: str | os.PathLike) -> str:
    """Hex sha256 (FIPS 180-4) of a file's bytes, read in 1 MiB chunks.

    Raises:
        OSError: the file cannot be read.
    """
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(_CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


def sha256_file_version(path: str | os.PathLike) -> str:
    """:func:`sha256_file`, read once per version of a file in a process: keyed by the resolved
    path, its modification time (ns) and size, so a file rewritten since is read again (the
    shipped weights, hashed for the code digest and by every run of a batch worker; a file an
    evaluation checks up to three times).

    Raises:
        OSError: the file cannot be read.
    """
    resolved = Path(path).resolve()
    stat = resolved.stat()
    return _sha256_of(str(resolved), stat.st_mtime_ns, stat.st_size)


def sha256_path(path: str | os.PathLike, cached: bool = True) -> str:
    """The digest of an input: a file's :func:`sha256_file_version` (``cached``) or
    :func:`sha256_file`; a folder's (an OpenPose ``--write_json`` folder, read as one input), the
    hex sha256 of one line per regular file under it, ``<relative POSIX path> NUL <its sha256>``,
    in sorted order, so that a file added, removed, renamed or changed changes it.

    Raises:
        OSError: a file cannot be read.
    """
    digest_of = sha256_file_version if cached else sha256_file
    folder = Path(path)
    if not folder.is_dir():
        return digest_of(folder)
    digest = hashlib.sha256()
    for file in sorted(f for f in folder.rglob("*") if f.is_file()):
        digest.update(f"{file.relative_to(folder).as_posix()}\0{digest_of(file)}\n".encode())
    return digest.hexdigest()


#: Room for pcnet's own code files (about 100, :func:`pcnet.pipeline.config.code_digest`) and a
#: run's inputs, so that digesting the code does not evict the weights a report digests next.
@functools.lru_cache(maxsize=256)
def _sha256_of(path: str, mtime_ns: int, size: int) -> str:
    return sha256_file(path)
