"""The one error type for bad input: a user's file, option or array that pcnet refuses.

Every entry point (``pcnet`` commands, :func:`pcnet.pipeline.rectification.rectify`, the adapters,
the config loaders) raises :class:`InputError` (or a subclass such as
:class:`pcnet.adapters.AdapterError`) for input it cannot use; the command line turns it
into one line and exit status 1. Any other exception is a bug in pcnet.
"""

from __future__ import annotations

import importlib


class InputError(ValueError):
    """Input pcnet refuses, with a one-line message naming the file (or option), the field,
    what was expected and what was found.

    A ``ValueError`` subclass, so callers that already catch ``ValueError`` keep working.
    Newlines in the message are folded into spaces so that it stays one line.
    """

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))



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
