"""The ``pcnet`` console command. It installs the interrupt handling before importing the
command line (numpy, onnxruntime, OpenCV take a second to import), so Ctrl-C or SIGTERM at
any moment ends in one line and exit status 130, never a traceback."""

from __future__ import annotations

import signal
import sys

EXIT_INTERRUPTED = 130


def raise_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


def main() -> None:
    """Entry point of ``pcnet`` (``[project.scripts]``): SIGTERM unwinds like Ctrl-C, then
    :func:`pcnet.pipeline.cli.main` runs every command under its error boundary."""
    signal.signal(signal.SIGTERM, raise_interrupt)
    try:
        from pcnet.pipeline.cli import main as cli
    except KeyboardInterrupt:
        sys.stderr.write("pcnet: interrupted before starting; nothing was written\n")
        raise SystemExit(EXIT_INTERRUPTED) from None
    cli()


if __name__ == "__main__":
    main()
