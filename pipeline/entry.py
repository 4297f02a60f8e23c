"""The ``pcnet`` console command. It installs the interrupt handling before importing the
command line (numpy, onnxruntime, OpenCV take a second to import), so Ctrl-C or SIGTERM at
any moment ends in one line and exit status 130, never a traceback."""

from __future__ import annotations

import signal
import sys
import threading

EXIT_INTERRUPTED = 130
_interrupted = threading.Event()


def raise_interrupt(signum, frame) -> None:
    """Signal handler: remember the interrupt, then unwind like Ctrl-C."""
    _interrupted.set()
    raise KeyboardInterrupt(f"signal {signum}")


def check_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if an interrupt arrived that something swallowed (Python
    ignores exceptions raised in weakref callbacks and destructors), so that no output is
    published after the user asked to stop."""
    if _interrupted.is_set():
        raise KeyboardInterrupt("interrupted earlier")


def main() -> None:
    """Entry point of ``pcnet`` (``[project.scripts]``): SIGINT and SIGTERM unwind as
    ``KeyboardInterrupt`` and are remembered (:func:`check_interrupted`), then
    :func:`pcnet.pipeline.cli.main` runs every command under its error boundary."""
    signal.signal(signal.SIGTERM, raise_interrupt)
    signal.signal(signal.SIGINT, raise_interrupt)
    try:
        from pcnet.pipeline.cli import main as cli
    except KeyboardInterrupt:
        sys.stderr.write("pcnet: interrupted before starting; nothing was written\n")
        raise SystemExit(EXIT_INTERRUPTED) from None
    cli()


if __name__ == "__main__":
    main()
