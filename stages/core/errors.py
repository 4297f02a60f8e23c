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
import math
import re


class InputError(ValueError):
    """Input pcnet refuses, with a one-line message naming the file (or option), the field,
    what was expected and what was found.

    A ``ValueError`` subclass, so callers that already catch ``ValueError`` keep working.
    Newlines in the message are folded into spaces so that it stays one line.
    """

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))

    @property
    def problems(self) -> tuple[str, ...]:
        """The message's problems one by one where :func:`refuse` raised several, else the message."""
        return getattr(self, "_problems", (str(self),))


def refuse(problems: list[str]) -> None:
    """Raise the ``problems`` of one input at once (nothing when there are none): an
    :class:`InputError` whose message joins them with ``"; "`` and whose ``problems`` keeps
    them apart (``pcnet batch`` names each on a line of its own).

    Raises:
        InputError: with ``problems``, when there is at least one.
    """
    if problems:
        err = InputError("; ".join(problems))
        err._problems = tuple(" ".join(str(p).split()) for p in problems)
        raise err


#: Names users give to a run setting's field that spelling does not reach (a yoga trial's
#: manifest column ``frame_rate`` got no hint).
SAME_MEANING = {"frame_rate": "fps", "framerate": "fps", "rate": "fps", "sample_rate": "fps", "hz": "fps",
                "output": "out", "output_dir": "out", "outdir": "out"}


def close_names(unknown, known) -> str:
    """``" (heigth: height?)"`` for each unknown name with a close known one (difflib's
    ratio >= 0.6, case and ``-``/``_`` ignored, or another name of it, :data:`SAME_MEANING`),
    ``""`` when none is close: the hint a refused key, column or option gives."""
    known = list(known)
    hints = []
    for name in unknown:
        plain = str(name).lower().replace("-", "_")
        match = [SAME_MEANING[plain]] if SAME_MEANING.get(plain) in known else difflib.get_close_matches(plain, known, n=1)
        if match:
            hints.append(f" ({name}: {match[0]}?)")
    return "".join(hints)


#: What a write that runs out of room fails with: a full disk (or its inodes), a file size
#: limit, a quota.
_NO_ROOM = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT}
#: What to do about a failure of the environment rather than of the input, by errno.
_ADVICE = {
    **dict.fromkeys(_NO_ROOM, "the disk, its inodes or your quota are full: free space there or write elsewhere"),
    errno.EROFS: "write elsewhere",
    errno.EACCES: "check the permissions of that path, or use another",
    # a second file-safety trial's cause was the sticky bit: another user's folder in /tmp
    errno.EPERM: "an immutable or append-only file or folder, or another user's in a sticky folder such as /tmp? "
                 "use another path",
    errno.EMFILE: "raise the open-file limit (ulimit -n) and run again",
    errno.ENFILE: "close programs or raise the system's open-file limit, and run again",
    errno.ENAMETOOLONG: "use a shorter path",
    errno.ELOOP: "a symbolic-link loop? use the real path",
    errno.EBUSY: "a mount point or a folder in use? write into a new folder inside it, or elsewhere",
}
#: Paths longer than this are shown by their start and end: a 4,000-character path is not a
#: message anyone reads.
_SHOWN_PATH_CHARS = 160


#: numpy's ``tofile``/``write_array`` on a full disk: an ``OSError`` without errno.
_SHORT_WRITE = re.compile(r"\d+ requested and \d+ written")


def environment_errno(err: OSError) -> int | None:
    """``err``'s errno, or ``ENOSPC`` for a write that stopped short without one (numpy's
    ``"N requested and M written"``: what a full disk, quota or file size limit gives)."""
    if err.errno is None and _SHORT_WRITE.search(str(err)):
        return errno.ENOSPC
    return err.errno


def reason(err: OSError) -> str:
    """What failed and what to do, for an ``OSError``: its ``strerror`` (or text) followed by
    :func:`environment_advice` of :func:`environment_errno`."""
    code = environment_errno(err)
    what = f"a write stopped short: {err}" if code != err.errno else err.strerror or err
    return f"{what}{environment_advice(code)}"


def environment_advice(code: int | None) -> str:
    """``"; <what to do>"`` for an ``OSError``'s errno that is a failure of the environment
    (full disk or quota, read-only file system, permissions, too many open files, a name too
    long, a link loop, a busy mount point), ``""`` for any other."""
    return f"; {_ADVICE[code]}" if code in _ADVICE else ""


def short_path(path: object) -> str:
    """``path`` as text, at most about :data:`_SHOWN_PATH_CHARS` characters: a longer one is
    shown as its first and last parts around ``...``."""
    text = str(path)
    if len(text) <= _SHOWN_PATH_CHARS:
        return text
    half = _SHOWN_PATH_CHARS // 2 - 2
    return f"{text[:half]}...{text[-half:]} ({len(text)} characters)"


def shown_value(value: object) -> str:
    """A wrong argument as an error line shows it: an array of more than one value by its shape
    and dtype (a developer trial's per-frame ``camera_up`` made a 4,059-character line), else
    its ``repr``, at most about :data:`_SHOWN_PATH_CHARS` characters."""
    shape = getattr(value, "shape", None)
    if isinstance(shape, tuple) and math.prod(shape) > 1:
        return f"an array of shape {shape} of {getattr(value, 'dtype', type(value).__name__)}"
    return short_path(repr(value))


def one_line(err: BaseException) -> str:
    """The one-line message of an expected error (what ``pcnet`` prints after ``Error:`` and
    a batch row reports): an :class:`InputError`'s own text; an ``OSError``'s file (long paths
    shortened, :func:`short_path`), reason and what to do (:func:`environment_advice`); for an
    ``OSError`` without a file name from a write that ran out of room (numpy and zipfile write
    without naming the file) that reason with what failed; ``RecursionError`` and
    ``MemoryError`` as what they mean for an input."""
    if isinstance(err, OSError) and err.filename is not None:
        names = " -> ".join(short_path(f) for f in (err.filename, err.filename2) if f is not None)
        return f"{names}: {reason(err)}"
    if isinstance(err, OSError) and environment_errno(err) in _NO_ROOM:
        return f"writing the outputs failed ({reason(err)})"
    if isinstance(err, RecursionError):
        return "an input nested too deeply to read (RecursionError): check the input and config files"
    if isinstance(err, MemoryError):
        return ("out of memory (MemoryError): the input is too large for this machine's free memory; split the "
                "recording or run on a machine with more memory")
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
