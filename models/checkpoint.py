"""Training checkpoints written and read without running code (needs torch).

A checkpoint is a ``torch.save`` of a dict holding only tensors and plain types (dict,
list, tuple, str, int, float, bool, None): configs are stored as dicts
(:func:`dataclasses.asdict`) and rebuilt on load. It is read with
``torch.load(..., weights_only=True)``, which refuses any pickled Python object, so a
crafted ``.pt`` cannot execute code. Every entry point that reads a checkpoint (``pcnet
export``, ``init_checkpoint`` and resuming in ``pcnet train``) goes through
:func:`load_checkpoint_dict`.

Entries: ``kind`` (``"pcnet"``; a checkpoint without it is taken as ``"pcnet"``), ``model``
(the state dict) and, by file, ``model_config`` / ``config`` / ``optimizer`` /
``scheduler`` / ``epoch`` / ``best`` / ``val``.
"""

from __future__ import annotations

import collections
import pickle
import re
import warnings
from pathlib import Path

import torch

from pcnet.stages.core.atomic import atomic_path
from pcnet.stages.core.errors import InputError

from .toml_config import check_config_keys

KINDS = ("pcnet",)
# Exact types: a numpy float64 is a float subclass but pickles as a numpy object, which
# weights_only refuses, so such a checkpoint would save but never load again.
_PLAIN = (str, int, float, bool, type(None))
_CONTAINERS = (dict, collections.OrderedDict)


def _plain_path(obj: object, where: str = "checkpoint") -> str | None:
    """Where in ``obj`` the first value that ``weights_only`` would refuse sits, or None."""
    if type(obj) in _PLAIN or isinstance(obj, torch.Tensor):
        return None
    if type(obj) in _CONTAINERS:
        for k, v in obj.items():
            if type(k) not in _PLAIN:
                return f"{where} key {k!r}"
            bad = _plain_path(v, f"{where}[{k!r}]")
            if bad:
                return bad
        return None
    if type(obj) in (list, tuple):
        for i, v in enumerate(obj):
            bad = _plain_path(v, f"{where}[{i}]")
            if bad:
                return bad
        return None
    return f"{where} ({type(obj).__module__}.{type(obj).__qualname__})"


def save_checkpoint(ck: dict, path: str | Path) -> Path:
    """Write ``ck`` to ``path`` atomically (a reader never sees half a file).

    Raises:
        TypeError: ``ck`` holds something other than tensors and plain types (a bug in the
            caller: the file would not load with ``weights_only=True``).
        FileNotFoundError: the destination folder does not exist.
    """
    bad = _plain_path(ck)
    if bad:
        raise TypeError(f"{path}: a checkpoint holds only tensors and plain types, not {bad}")
    with atomic_path(path) as tmp:
        torch.save(ck, tmp)
    return Path(path)


def _short_reason(err: Exception) -> str:
    """A few words on why ``torch.load`` failed (its own messages run to several lines)."""
    text = str(err)
    if isinstance(err, FileNotFoundError):
        return "no such file"
    if isinstance(err, OSError):
        return (err.strerror or type(err).__name__).lower()
    if isinstance(err, (pickle.UnpicklingError, KeyError)):  # KeyError: a byte that is no pickle opcode
        found = re.search(r"GLOBAL (\S+)", text)
        if found:
            return f"it holds a Python object ({found.group(1)}), refused without running it"
        return "not a torch file"
    if isinstance(err, EOFError):
        return "empty or truncated file"
    if isinstance(err, RuntimeError) and ("zip" in text or "archive" in text or "inline_container" in text):
        return "a zip archive that is not a torch file"
    first = text.strip().splitlines()[0] if text.strip() else ""
    return f"{type(err).__name__}: {first[:150]}" if first else type(err).__name__


def load_checkpoint_dict(path: str | Path, kind: str | None = None, required: tuple[str, ...] = ("model",),
                         map_location: str | torch.device = "cpu") -> dict:
    """The dict of a pcnet checkpoint, read with ``weights_only=True`` (no code runs).

    Args:
        path: a ``best.pt`` / ``last.pt``.
        kind: ``"pcnet"`` to require that kind; None accepts any of :data:`KINDS`.
        required: entries that must be present besides ``kind``.
        map_location: where tensors are loaded (``torch.load``'s argument).

    Returns:
        The dict, with ``kind`` set (``"pcnet"`` when the file has none).

    Raises:
        InputError: ``<path>: not a pcnet checkpoint (<reason>)`` for a missing file, a
            pickle with Python objects, random bytes, a zip that is not torch's, or a dict
            without the expected entries.
    """
    try:
        with warnings.catch_warnings():
            # torch warns about the pickle protocol of foreign files before refusing them.
            warnings.simplefilter("ignore")
            ck = torch.load(path, map_location=map_location, weights_only=True)
    except Exception as err:  # weights_only: nothing in the file ran, whatever torch raised
        raise not_a_checkpoint(path, _short_reason(err)) from err
    if not isinstance(ck, dict):
        raise not_a_checkpoint(path, f"holds a {type(ck).__name__}, not a dict")
    ck = dict(ck)
    ck.setdefault("kind", "pcnet")
    if ck["kind"] not in KINDS:
        raise not_a_checkpoint(path, f"unknown kind {ck['kind']!r}; expected one of {list(KINDS)}")
    if kind is not None and ck["kind"] != kind:
        raise not_a_checkpoint(path, f"kind {ck['kind']!r}, expected {kind!r}")
    missing = [k for k in required if k not in ck]
    if missing:
        raise not_a_checkpoint(path, f"no {', '.join(repr(k) for k in missing)} entry")
    model = ck.get("model")
    if "model" in required and not (isinstance(model, dict)
                                    and all(isinstance(v, torch.Tensor) for v in model.values())):
        raise not_a_checkpoint(path, "'model' is not a state dict of tensors")
    return ck


def resume_point(path: str | Path, ck: dict) -> tuple[int, float]:
    """(first epoch to run, best validation error so far) from a ``last.pt`` dict.

    Raises:
        InputError: ``epoch`` is not an int or ``best`` not a number.
    """
    epoch, best = ck.get("epoch"), ck.get("best")
    if type(epoch) is not int or type(best) not in (int, float):
        raise not_a_checkpoint(path, f"'epoch' {epoch!r} / 'best' {best!r}: expected an int and a number")
    return epoch + 1, float(best)


def not_a_checkpoint(path: str | Path, reason: str) -> InputError:
    """The :class:`InputError` ``<path>: not a pcnet checkpoint (<reason>)``."""
    return InputError(f"{path}: not a pcnet checkpoint ({reason})")


def config_from_dict(path: str | Path, entry: str, given: object, cls):
    """Rebuild the dataclass ``cls`` from the dict stored under ``entry``.

    Raises:
        InputError: ``given`` is not a dict, or has unknown keys or values of the wrong type
            (``<path>: not a pcnet checkpoint (...)``).
    """
    if not isinstance(given, dict):
        raise not_a_checkpoint(path, f"{entry!r} is not a dict")
    try:
        check_config_keys(path, f"{entry!r} ", given, cls)
    except InputError as err:
        raise not_a_checkpoint(path, str(err).removeprefix(f"{path}: ")) from err
    return cls(**{k: _as_field(v) for k, v in given.items()})


def _as_field(value: object) -> object:
    # TOML arrays arrive as lists; torch may hand tuples back as tuples. Dataclasses take lists.
    return list(value) if isinstance(value, tuple) else value


def load_state(path: str | Path, module: torch.nn.Module | torch.optim.Optimizer | object, state: object,
               entry: str) -> None:
    """``module.load_state_dict(state)`` (a model, optimiser or scheduler).

    Raises:
        InputError: the state does not fit (``<path>: not a pcnet checkpoint ('<entry>'
            does not fit: ...)``), e.g. weights of another architecture.
    """
    if isinstance(module, torch.nn.Module) and isinstance(state, dict):
        mismatch = _state_mismatch(module.state_dict(), state)
        if mismatch:
            raise not_a_checkpoint(path, f"{entry!r} does not fit this architecture: {mismatch}")
    try:
        module.load_state_dict(state)
    except (RuntimeError, ValueError, KeyError, TypeError, IndexError, AttributeError) as err:
        # torch lists every mismatched key over many lines; the first few words say enough.
        text = " ".join(str(err).split()).removeprefix(f"Error(s) in loading state_dict for {type(module).__name__}: ")
        raise not_a_checkpoint(path, f"{entry!r} does not fit: {text[:200]}") from err


def _state_mismatch(expected: dict, given: dict) -> str:
    """Counts of missing, unexpected and wrongly shaped entries, with an example; "" if none."""
    missing = [k for k in expected if k not in given]
    unexpected = [k for k in given if k not in expected]
    shaped = [k for k in expected if k in given and isinstance(given[k], torch.Tensor)
              and tuple(given[k].shape) != tuple(expected[k].shape)]
    parts = [f"{len(keys)} {what} (e.g. {keys[0]!r})" for keys, what in
             ((missing, "missing"), (unexpected, "unexpected"), (shaped, "of another shape")) if keys]
    return ", ".join(parts)


#: What a training run writes into its ``out_dir`` (``pcnet train``).
RUN_FILES = frozenset({"config.json", "metrics.jsonl", "last.pt", "best.pt"})


def check_run_folder(out_dir: str | Path) -> None:
    """Refuse, before any work, an ``out_dir`` a training run must not write into: the
    current folder or one above it, a file, or an existing folder that is not a previous run
    (anything besides :data:`RUN_FILES`, or no ``last.pt`` to resume). A run writes
    ``config.json`` and appends to ``metrics.jsonl``, so a user's files of those names must
    never be taken for a run's.

    Raises:
        InputError: naming ``out_dir`` and what it holds.
    """
    given = str(out_dir)
    target = Path(out_dir).resolve()
    cwd = Path.cwd().resolve()
    if target == cwd or target in cwd.parents:
        raise InputError(f"out_dir {given}: expected a folder for this run, got the current folder or one above it")
    if not target.exists():
        return
    if not target.is_dir():
        raise InputError(f"out_dir {given}: expected a folder, got a file")
    names = sorted(p.name for p in target.iterdir())
    foreign = [n for n in names if n not in RUN_FILES]
    if foreign:
        shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
        raise InputError(f"out_dir {given}: expected a new folder or a previous training run's, got one holding "
                         f"files a run does not write ({shown})")
    if names and "last.pt" not in names:
        raise InputError(f"out_dir {given}: expected a new folder or a previous training run's (with last.pt), got "
                         f"one holding {', '.join(names)} without last.pt; choose another out_dir")
