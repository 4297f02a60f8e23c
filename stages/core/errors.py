"""The one error type for bad input: a user's file, option or array that pcnet refuses.

Every entry point (``pcnet`` commands, :func:`pcnet.pipeline.rectification.rectify`, the adapters,
the config loaders) raises :class:`InputError` (or a subclass such as
:class:`pcnet.adapters.AdapterError`) for input it cannot use; the command line turns it
into one line and exit status 1. Any other exception is a bug in pcnet.
"""

from __future__ import annotations

import difflib
import errno
import importlib


class InputError(ValueError):
    """Input pcnet refuses, with a one-line message naming the file (or option), the field,
    what was expected and what was found.

    A ``ValueError`` subclass, so callers that already catch ``ValueError`` keep working.
    Newlines in the message are folded into spaces so that it stays one line.
    """

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))


def close_names(unknown, known) -> str:
    """``" (heigth: height?)"`` for each unknown name with a close known one (difflib's
    ratio >= 0.6, case and ``-``/``_`` ignored), ``""`` when none is close: the hint a
    refused key, column or option gives."""
    known = list(known)
    hints = []
    for name in unknown:
        match = difflib.get_close_matches(str(name).lower().replace("-", "_"), known, n=1)
        if match:
            hints.append(f" ({name}: {match[0]}?)")
    return "".join(hints)


#: What a write that runs out of room fails with: a full disk, a file size limit, a quota.
_NO_ROOM = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT}


def one_line(err: BaseException) -> str:
    """The one-line message of an expected error (what ``pcnet`` prints after ``Error:`` and
    a batch row reports): an :class:`InputError`'s own text, an ``OSError``'s file and
    reason, and for an ``OSError`` without a file name from a write that ran out of room
    (numpy and zipfile write without naming the file) that reason with what failed."""
    if isinstance(err, OSError) and err.filename is not None:
        names = " -> ".join(str(f) for f in (err.filename, err.filename2) if f is not None)
        return f"{names}: {err.strerror or err}"
    if isinstance(err, OSError) and err.errno in _NO_ROOM:
        return f"{err.strerror}: writing the outputs failed (a full disk, a quota or a file size limit?)"
    return " ".join(str(err).split())


def import_extra(module: str, missing: str):
    """The optional dependency ``module`` (an extra such as ``pcnet[ray]``), imported.

    Raises:
        InputError: ``missing`` (one line naming the extra) when it is not installed.
        KeyboardInterrupt: the import was interrupted (its ImportError caused by one).
    """
    try:
        return importlib.import_module(module)
    except ImportError as err:
        if isinstance(err.__cause__ or err.__context__, KeyboardInterrupt):
            # a Ctrl-C or SIGTERM inside the module's own import: an interrupt, not a missing extra
            raise KeyboardInterrupt(str(err)) from err
        raise InputError(missing) from None
