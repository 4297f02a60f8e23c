"""Reading TOML configs into dataclasses (numpy/torch-free: the run-time pipeline uses it too)."""

from __future__ import annotations

import tomllib
from dataclasses import fields
from pathlib import Path


def read_toml(path: str | Path) -> dict:
    """The TOML file's top-level table.

    Raises:
        ValueError: the file is missing, unreadable or not TOML (named in the message).
    """
    path = Path(path)
    try:
        return tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise ValueError(f"{path}: not a readable TOML config ({err})") from err


def check_config_keys(path: str | Path, where: str, given: dict, cls) -> None:
    """Raise ValueError naming ``path`` (and ``where`` in it) if ``given`` has keys that are
    not fields of the dataclass ``cls``."""
    allowed = {f.name for f in fields(cls)}
    unknown = set(given) - allowed
    if unknown:
        raise ValueError(f"{path}: {where}unknown keys {sorted(unknown)}; expected some of {sorted(allowed)}")
