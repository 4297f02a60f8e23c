"""Reading TOML configs into dataclasses, every field type-checked (numpy/torch-free: the
run-time pipeline uses it too)."""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import tomllib
import types
import typing
from collections.abc import Mapping
from pathlib import Path

from pcnet.stages.core.errors import InputError, close_names


#: Deepest nesting a config may have: arrays and inline tables inside one another, and the
#: parts of one dotted key (``a.b.c``, a table header's too). pcnet's configs nest two levels.
#: tomllib parses arrays and inline tables by recursion (about four Python frames a level),
#: so ``height = [[[...]]]`` 100,000 levels deep would end in a RecursionError, and it holds
#: every prefix of a dotted key, so a 600 kB key of 100,000 parts takes gigabytes; a bound
#: checked before parsing does not depend on the interpreter's recursion limit.
MAX_TOML_NESTING = 100
# The nesting scan's tokens: strings (their brackets and dots are text) and comments, read
# past; brackets and braces; the dots of a dotted key, whose run a "=", a ",", a bracket or
# the end of the line ends (a float or a date in a value holds one dot: two parts, far below).
_TOML_NESTING_TOKENS = re.compile(r"""
      "{3}(?:\\.|[^\\])*?"{3} | '{3}.*?'{3} | "(?:\\.|[^"\\\n])*" | '[^'\n]*' | \#[^\n]*
    | (?P<open>[\[{]) | (?P<close>[\]}]) | (?P<dot>\.) | (?P<end>[=,\n])
""", re.X | re.S)


def toml_nesting(text: str, limit: int = MAX_TOML_NESTING) -> int:
    """How deep TOML ``text`` nests: the larger of the depth of its arrays and inline tables
    and the parts of its longest dotted key (a float's dot counts: ``1.5`` is two). One
    linear scan before parsing, which stops once past ``limit``."""
    depth = deepest = dots = 0
    for token in _TOML_NESTING_TOKENS.finditer(text):
        kind = token.lastgroup  # None: a string or a comment
        if kind == "dot":
            dots += 1
        elif kind is not None:
            dots = 0
            depth += 1 if kind == "open" else -1 if kind == "close" and depth else 0
        deepest = max(deepest, depth, dots + 1)
        if deepest > limit:
            break
    return deepest


def read_toml(path: str | Path) -> dict:
    """The TOML file's top-level table.

    Raises:
        InputError: the file is missing, unreadable, not TOML, or nested deeper than
            :data:`MAX_TOML_NESTING` levels (named in the message).
    """
    path = Path(path)
    if path.exists() and not path.is_file() and not path.is_dir():  # reading a pipe waits forever
        raise InputError(f"{path}: expected a TOML config file, got a special file (a named pipe or device)")
    try:
        text = path.read_text()
        if toml_nesting(text) > MAX_TOML_NESTING:
            raise InputError(f"{path}: not a readable TOML config (nesting deeper than {MAX_TOML_NESTING} levels)")
        return tomllib.loads(text)
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


def type_hints(obj) -> Mapping:
    """``typing.get_type_hints(obj)`` (a class or a function), read-only, computed once per
    object: evaluating the string annotations (``from __future__ import annotations``) costs
    about 0.3 ms a class, which a manifest of 100,000 rows, each one config, would pay each row."""
    try:
        return _type_hints(obj)
    except TypeError:  # unhashable (a callable instance defining __eq__ only)
        return types.MappingProxyType(typing.get_type_hints(obj))


@functools.lru_cache(maxsize=256)
def _type_hints(obj) -> Mapping:
    return types.MappingProxyType(typing.get_type_hints(obj))


#: Types whose every value fits an annotation naming them (:func:`value_matches`): an ``int``
#: fits ``float`` too, a ``bool`` only ``bool``.
_PLAIN = {str: (str,), bool: (bool,), int: (int,), float: (float, int), type(None): (type(None),), dict: (dict,)}


def _plain_types(tp: object) -> frozenset:
    """The exact value types that surely fit the annotation ``tp`` (a plain type or a union of
    them): a shortcut past :func:`value_matches` for the common values of a config, which a
    manifest checks on every row; other values (subclasses included) take the full check."""
    try:
        return _plain_types_of(tp)
    except TypeError:  # an unhashable annotation
        return frozenset()


@functools.lru_cache(maxsize=512)
def _plain_types_of(tp: object) -> frozenset:
    args = typing.get_args(tp) if typing.get_origin(tp) in (typing.Union, types.UnionType) else (tp,)
    return frozenset(t for a in args for t in _PLAIN.get(typing.get_origin(a) or a, ()))


def check_config_types(source: str | Path, where: str, given: dict, cls) -> None:
    """Raise :class:`InputError` naming ``source``, the field, its expected type and the value
    when a value of ``given`` does not fit its field of the dataclass ``cls``
    (:func:`value_matches`). Unknown keys are left to :func:`check_config_keys`."""
    hints = type_hints(cls)
    for key, value in given.items():
        if key in hints and type(value) not in _plain_types(hints[key]) and not value_matches(value, hints[key]):
            shown = repr(value)
            shown = shown if len(shown) <= 80 else shown[:77] + "..."  # an array's repr runs to pages
            # a notebook's np.float32(30) or np.load(...)["fps"] (a notebook trial)
            hint = "; pass a plain Python value (float(x), str(x))" if type(value).__module__ == "numpy" else ""
            raise InputError(f"{source}: {where}field {key!r}: expected {type_name(hints[key])}, "
                             f"got {shown} ({type(value).__name__}){hint}")


def check_unknown_keys(path: str | Path, where: str, given: dict, cls) -> None:
    """Raise :class:`InputError` naming ``path`` (and ``where`` in it) if ``given`` has keys
    that are not fields of the dataclass ``cls``."""
    allowed = {f.name for f in dataclasses.fields(cls)}
    unknown = set(given) - allowed
    if unknown:
        raise InputError(f"{path}: {where}unknown keys {sorted(unknown)}{close_names(sorted(unknown), sorted(allowed))}; "
                         f"expected some of {sorted(allowed)}")


def check_config_keys(path: str | Path, where: str, given: dict, cls) -> None:
    """:func:`check_unknown_keys`, then :func:`check_config_types`: raise :class:`InputError`
    for a key that is no field of the dataclass ``cls`` or a value whose type does not fit."""
    check_unknown_keys(path, where, given, cls)
    check_config_types(path, where, given, cls)


class Range(typing.NamedTuple):
    """A field's valid values: finite numbers from ``low`` to ``high``, each end included
    unless its flag says otherwise (``Range(0, 1, low_inclusive=False)`` is ``(0, 1]``).
    A plain tuple ``(low, high[, low_inclusive[, high_inclusive]])`` means the same."""

    low: float
    high: float
    low_inclusive: bool = True
    high_inclusive: bool = True

    def __contains__(self, value: object) -> bool:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            return False
        above = value >= self.low if self.low_inclusive else value > self.low
        below = value <= self.high if self.high_inclusive else value < self.high
        return above and below

    def describe(self, integer: bool = False) -> str:
        """``an integer in [1, 10000]`` / ``a finite number in (0, 1]``."""
        kind = "an integer" if integer else "a finite number"
        return (f"{kind} in {'[' if self.low_inclusive else '('}{_number(self.low)}, "
                f"{_number(self.high)}{']' if self.high_inclusive else ')'}")


def _number(x: float) -> str:
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


def _field_values(cfg: object) -> Mapping:
    if isinstance(cfg, Mapping):
        return cfg
    return {f.name: getattr(cfg, f.name) for f in dataclasses.fields(cfg)}


def _is_int_field(cls, name: str) -> bool:
    if cls is None:
        return False
    tp = type_hints(cls).get(name)
    args = typing.get_args(tp)
    return tp is int or (typing.get_origin(tp) in (list, tuple) and args[:1] == (int,))


def _got(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 200 else text[:197] + "..."


def check_ranges(path: str | Path, where: str, cfg: object, bounds: Mapping[str, tuple], cls=None) -> None:
    """Raise :class:`InputError` naming ``path``, the field, its valid range and the value
    when a numeric field of ``cfg`` (a dataclass instance, or a mapping of given values,
    types already checked) is not finite or outside its :class:`Range` in ``bounds``.
    A list field's every entry must be in the range; ``None`` (an optional field left
    unset) and fields absent from a mapping are skipped. ``cls`` (default: the type of a
    dataclass ``cfg``) tells integer fields from real ones for the message."""
    values = _field_values(cfg)
    if cls is None and dataclasses.is_dataclass(cfg):
        cls = type(cfg)
    for name, bound in bounds.items():
        if name not in values or values[name] is None:
            continue
        bound, value = Range(*bound), values[name]
        what = bound.describe(_is_int_field(cls, name))
        if isinstance(value, (list, tuple)):
            for i, item in enumerate(value):
                if item not in bound:
                    raise InputError(f"{path}: {where}field {name!r}: expected every entry {what}, "
                                     f"got {_got(item)} at index {i}")
        elif value not in bound:
            raise InputError(f"{path}: {where}field {name!r}: expected {what}, got {_got(value)}")


def _choice_matches(value: object, allowed: str) -> bool:
    if allowed.endswith(":<n>"):  # "cuda:<n>": that prefix and a device number
        return isinstance(value, str) and re.fullmatch(re.escape(allowed[:-3]) + r"\d+", value) is not None
    return value == allowed


def check_choices(path: str | Path, where: str, cfg: object, choices: Mapping[str, typing.Sequence[str]]) -> None:
    """Raise :class:`InputError` naming ``path``, the field, the allowed values and the
    value when a field of ``cfg`` (dataclass instance or mapping) is not one of its
    ``choices`` (for a list field: every entry). An allowed value ``"name:<n>"`` stands for
    ``name:0``, ``name:1``, ... ``None`` and absent fields are skipped."""
    values = _field_values(cfg)
    for name, allowed in choices.items():
        if name not in values or values[name] is None:
            continue
        value = values[name]
        listed = ", ".join(repr(a) for a in allowed)
        items = list(enumerate(value)) if isinstance(value, (list, tuple)) else [(None, value)]
        for i, item in items:
            if not any(_choice_matches(item, a) for a in allowed):
                at = "" if i is None else f" at index {i}"
                every = "" if i is None else "every entry "
                raise InputError(f"{path}: {where}field {name!r}: expected {every}one of {listed}, "
                                 f"got {_got(item)}{at}")


def check_lengths(path: str | Path, where: str, cfg: object, lengths: Mapping[str, tuple[int, int]]) -> None:
    """Raise :class:`InputError` naming ``path`` and the field when a list or string field
    of ``cfg`` has fewer than ``low`` or more than ``high`` entries (characters); ``None``
    and absent fields are skipped. Strings in a list must not be empty."""
    values = _field_values(cfg)
    for name, (low, high) in lengths.items():
        if name not in values or values[name] is None:
            continue
        value = values[name]
        kind = "entries" if isinstance(value, (list, tuple)) else "characters"
        if not low <= len(value) <= high:
            raise InputError(f"{path}: {where}field {name!r}: expected {low} to {high} {kind}, "
                             f"got {len(value)} ({_got(value)})")
        if isinstance(value, (list, tuple)):
            for i, item in enumerate(value):
                if isinstance(item, str) and not item.strip():
                    raise InputError(f"{path}: {where}field {name!r}: expected non-empty strings, "
                                     f"got {item!r} at index {i}")
