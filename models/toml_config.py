"""Reading TOML configs into dataclasses, every field type-checked (numpy/torch-free: the
run-time pipeline uses it too)."""

from __future__ import annotations

import dataclasses
import tomllib
import types
import typing
from pathlib import Path

from pcnet.stages.errors import InputError


def read_toml(path: str | Path) -> dict:
    """The TOML file's top-level table.

    Raises:
        InputError: the file is missing, unreadable or not TOML (named in the message).
    """
    path = Path(path)
    try:
        return tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        reason = err.strerror if isinstance(err, OSError) and err.strerror else err
        raise InputError(f"{path}: not a readable TOML config ({reason})") from err


def type_name(tp: object) -> str:
    """A short readable name of a type annotation (``float | None``, ``list[str]``)."""
    if isinstance(tp, type) and not typing.get_args(tp):
        return tp.__name__
    return str(tp).replace("typing.", "")


def value_matches(value: object, tp: object) -> bool:
    """Whether a parsed config value (TOML/JSON types) fits the annotation ``tp``.

    Strict where a loose reading would change meaning: ``"false"`` is not a ``bool`` and a
    ``bool`` is not an ``int``; an ``int`` is accepted for a ``float``. A dict fits a nested
    dataclass (its own fields are checked by the loader of that table).
    """
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp is typing.Any:
        return True
    if origin in (typing.Union, types.UnionType):
        return any(value_matches(value, a) for a in args)
    if tp is type(None):
        return value is None
    if tp is bool:
        return isinstance(value, bool)
    if tp is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if tp is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if origin in (list, tuple):
        if not isinstance(value, (list, tuple)):
            return False
        item = args[0] if args else typing.Any
        return all(value_matches(v, item) for v in value)
    if tp is dict or origin is dict:
        return isinstance(value, dict)
    if dataclasses.is_dataclass(tp):
        return isinstance(value, (dict, tp))
    return isinstance(tp, type) and isinstance(value, tp)


def check_config_types(source: str | Path, where: str, given: dict, cls) -> None:
    """Raise :class:`InputError` naming ``source``, the field, its expected type and the value
    when a value of ``given`` does not fit its field of the dataclass ``cls``
    (:func:`value_matches`). Unknown keys are left to :func:`check_config_keys`."""
    hints = typing.get_type_hints(cls)
    for key, value in given.items():
        if key in hints and not value_matches(value, hints[key]):
            raise InputError(f"{source}: {where}field {key!r}: expected {type_name(hints[key])}, "
                             f"got {value!r} ({type(value).__name__})")


def check_config_keys(path: str | Path, where: str, given: dict, cls) -> None:
    """Raise :class:`InputError` naming ``path`` (and ``where`` in it) if ``given`` has keys
    that are not fields of the dataclass ``cls``, or values whose type does not fit the
    field's (:func:`check_config_types`)."""
    allowed = {f.name for f in dataclasses.fields(cls)}
    unknown = set(given) - allowed
    if unknown:
        raise InputError(f"{path}: {where}unknown keys {sorted(unknown)}; expected some of {sorted(allowed)}")
    check_config_types(path, where, given, cls)
