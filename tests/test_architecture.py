"""The rooms' import directions (docs/architecture.md), read from the source with ``ast``.

- the geometry core (``stages``: conventions, rotations, canonical, metrics, geometric, errors,
  atomic) imports nothing of pcnet outside itself;
- the other ``stages`` import only ``stages``: never the network (``models``), the file formats
  (``adapters``) or the composition (``pipeline``);
- ``models`` and ``adapters`` use ``stages`` only through the core; ``models`` may read the
  adapters' array checks, adapters never import ``models``;
- ``pipeline`` composes everything and nothing imports it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
ROOMS = ("adapters", "stages", "models", "pipeline")
CORE = {"conventions", "rotations", "canonical", "metrics", "geometric", "errors", "atomic"}


def _imports(room: str) -> dict[str, set[tuple[str, str]]]:
    """module name -> {(room, module)} of the pcnet modules it imports (absolute or relative)."""
    out: dict[str, set[tuple[str, str]]] = {}
    for path in sorted((ROOT / room).rglob("*.py")):
        found: set[tuple[str, str]] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    parts = [room] + (node.module.split(".") if node.module else [])
                    if len(parts) == 1:
                        found |= {(room, a.name) for a in node.names}
                        continue
                elif node.module and node.module.startswith("pcnet."):
                    parts = node.module.split(".")[1:]
                    if len(parts) == 1:
                        found |= {(parts[0], a.name) for a in node.names}
                        continue
                else:
                    continue
                found.add((parts[0], parts[1]))
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    parts = alias.name.split(".")
                    if parts[0] == "pcnet" and len(parts) > 1:
                        found.add((parts[1], parts[2] if len(parts) > 2 else "__init__"))
        out[path.stem] = {(r, m) for r, m in found if r in ROOMS}
    return out


IMPORTS = {room: _imports(room) for room in ROOMS}


def _violations(room: str, allowed) -> list[str]:
    return [f"{room}/{module}.py imports pcnet.{r}.{m}" for module, deps in IMPORTS[room].items()
            for r, m in sorted(deps) if not allowed(module, r, m)]


def test_the_rooms_were_read():
    assert CORE <= set(IMPORTS["stages"]) and "rectification" in IMPORTS["pipeline"]
    assert ("models", "inference") in IMPORTS["pipeline"]["rectification"]  # the reader sees imports


@pytest.mark.parametrize("room, rule, allowed", [
    ("stages", "the geometry core imports only the core; other stages only stages",
     lambda mod, r, m: r == "stages" and (m in CORE if mod in CORE else True)),
    ("models", "models use stages only through the core (and may read the adapters' checks)",
     lambda mod, r, m: r == "models" or (r == "stages" and m in CORE) or r == "adapters"),
    ("adapters", "adapters use stages only through the core and never import models or pipeline",
     lambda mod, r, m: r == "adapters" or (r == "stages" and m in CORE)),
])
def test_import_directions(room, rule, allowed):
    assert _violations(room, allowed) == [], rule


def test_nothing_imports_the_pipeline_but_itself():
    offenders = [f"{room}/{module}.py" for room in ("adapters", "stages", "models")
                 for module, deps in IMPORTS[room].items() if any(r == "pipeline" for r, _ in deps)]
    assert offenders == []
