"""The ``pcnet`` console command. It installs the interrupt handling before importing the
command line (numpy, onnxruntime, OpenCV take a second to import), so Ctrl-C or SIGTERM at
any moment ends in one line and exit status 130, never a traceback."""

from __future__ import annotations

import signal
import sys

from pcnet.pipeline.interrupt import EXIT_INTERRUPTED, quiet_interrupt_hook, raise_interrupt, was_interrupted


def main() -> None:
    """Entry point of ``pcnet`` (``[project.scripts]``): SIGINT, SIGTERM and SIGHUP (unless
    ignored, as ``nohup`` ignores it) unwind as
    ``KeyboardInterrupt`` and are remembered (:func:`check_interrupted`), then
    :func:`pcnet.pipeline.cli.main` runs every command under its error boundary.

    click runs in non-standalone mode so that an interrupt outside a command's body (while
    click parses the arguments) also ends in exit 130; in standalone mode click would turn it
    into "Aborted!" and exit 1."""
    signal.signal(signal.SIGTERM, raise_interrupt)
    signal.signal(signal.SIGINT, raise_interrupt)
    hangup = getattr(signal, "SIGHUP", None)  # not on Windows
    if hangup is not None and signal.getsignal(hangup) is not signal.SIG_IGN:  # nohup: outlive the terminal
        signal.signal(hangup, raise_interrupt)
    sys.unraisablehook = quiet_interrupt_hook(sys.unraisablehook)
    try:
        import click

        from pcnet.pipeline.cli import main as cli
    except KeyboardInterrupt:
        _stop("pcnet: interrupted before starting; nothing was written")
    if was_interrupted():  # swallowed inside the imports (an import lock's weakref callback)
        _stop("pcnet: interrupted before starting; nothing was written")
    try:
        code = cli.main(prog_name="pcnet", standalone_mode=False)
    except click.ClickException as err:
        err.show()
        raise SystemExit(err.exit_code) from None
    except (click.Abort, KeyboardInterrupt):
        if not was_interrupted():  # click's Abort for an end of input at a prompt
            _stop("Aborted!", status=1)
        _stop("pcnet: interrupted; nothing half-written was left behind")
    raise SystemExit(code if isinstance(code, int) else 0)


def _stop(line: str, status: int = EXIT_INTERRUPTED) -> None:
    sys.stderr.write(line + "\n")
    raise SystemExit(status) from None

if __name__ == "__main__":
    main()
