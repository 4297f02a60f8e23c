"""Content digests of files: what tells one input (a lifter output, a training data file) from
another of the same name."""

from __future__ import annotations

import hashlib
import os

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
