"""How pcnet remembers and reports an interrupt (Ctrl-C, SIGTERM, SIGHUP): the handler the
console entry point, the CLI and batch workers install, and the check that output-publishing
code makes before it publishes."""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

EXIT_INTERRUPTED = 130
_interrupted = threading.Event()
#: Signals that ask a process to stop, besides Ctrl-C's SIGINT: a scheduler's or ``kill``'s
#: SIGTERM, and SIGHUP from a closed terminal or SSH session (a user trial's batch died at once
#: on it, leaving its staged folders); SIGHUP does not exist on Windows.
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


def raise_interrupt(signum, frame) -> None:
    """Signal handler: remember the interrupt, then unwind like Ctrl-C."""
    _interrupted.set()
    raise KeyboardInterrupt(f"signal {signum}")


class InterruptedAfterPublishing(KeyboardInterrupt):
    """An interrupt that came once the output ``path`` was published whole: the command says
    so, not that nothing was written (a file-safety trial's signals at publication read
    "nothing half-written was left behind" beside the new output)."""

    def __init__(self, path: str):
        super().__init__(f"interrupted after {path} was published")
        self.path = path


@contextmanager
def interrupts_deferred():
    """Hold Ctrl-C, SIGTERM and SIGHUP while the block runs, then raise the first that came as
    ``KeyboardInterrupt``: for a publication and its clean-up, which an interrupt between two
    steps left half done (a replaced output's trash folder without its marker, which no run
    removes: a file-safety trial). Only signals whose handler is Python's (:func:`raise_interrupt`,
    Ctrl-C's default) are held; an ignored or default one keeps its meaning. Python runs signal
    handlers in the main thread, so elsewhere (a Ray task's thread) nothing is held."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []

    def remember(signum, frame) -> None:
        came.append(signum)
        _interrupted.set()

    held = {s: h for s in (signal.SIGINT, *STOP_SIGNALS) if callable(h := signal.getsignal(s))}
    for signum in held:
        signal.signal(signum, remember)
    try:
        yield
    finally:
        for signum, handler in held.items():
            signal.signal(signum, handler)
    if came:
        raise KeyboardInterrupt(f"signal {came[0]}")


def was_interrupted() -> bool:
    """Whether an interrupt arrived in this process."""
    return _interrupted.is_set()


def check_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if an interrupt arrived that something swallowed (Python
    ignores exceptions raised in weakref callbacks and destructors), so that no output is
    published after the user asked to stop."""
    if was_interrupted():
        raise KeyboardInterrupt("interrupted earlier")


def came_from_interrupt(err: BaseException) -> bool:
    """Whether ``err`` is how an interrupt came out: raised while handling (or because of) a
    ``KeyboardInterrupt``, or raised at all once an interrupt arrived. Libraries turn an
    interrupt into their own error: a C extension's import into its ImportError
    ("initialization failed"), numpy's ``fromfile``, interrupted inside its isinstance check
    of a file object, into "TypeError: expected str, bytes or os.PathLike object" (a SIGTERM
    in CI). Once the user asked to stop, whatever unwinds is that stop."""
    return was_interrupted() or any(isinstance(e, KeyboardInterrupt) for e in exception_chain(err))


def exception_chain(err: BaseException | None):
    """``err``, then what it was raised from or while handling (``__cause__``, else
    ``__context__``), and so on, each once."""
    seen = set()
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        yield err
        err = err.__cause__ or err.__context__


def quiet_interrupt_hook(default):
    """An ``sys.unraisablehook`` that drops a ``KeyboardInterrupt`` raised where Python cannot
    propagate it (a weakref callback, a destructor: importlib's module-lock clean-up is one)
    instead of printing its traceback; the interrupt is remembered (:func:`was_interrupted`)
    and stops the run at the next check. Anything else goes to ``default``."""
    if getattr(default, "quiet_interrupts", False):  # installed already (the CLI's group under the entry point)
        return default

    def hook(unraisable):
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            default(unraisable)
    hook.quiet_interrupts = True
    return hook
