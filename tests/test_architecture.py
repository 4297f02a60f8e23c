"""The rooms' import directions (docs/architecture.md), read from the source with ``ast``.

- the geometry core (``stages/core/``: conventions, rotations, canonical, metrics, geometric,
  errors, atomic) imports nothing of pcnet outside itself;
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
CORE = "stages.core"


def _package(path: Path) -> str:
    """Dotted package (without ``pcnet.``) holding ``path``: ``stages/core/rotations.py`` -> ``stages.core``."""
    return ".".join(path.relative_to(ROOT).parent.parts)


def _imports() -> dict[str, set[str]]:
    """``room/file.py`` -> the pcnet modules it imports, dotted without ``pcnet.``."""
    out: dict[str, set[str]] = {}
    for room in ROOMS:
        for path in sorted((ROOT / room).rglob("*.py")):
            package = _package(path)
            found: set[str] = set()
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.ImportFrom):
                    if node.level:
                        base = package.split(".")[: len(package.split(".")) - node.level + 1]
                        target = ".".join(base + ([node.module] if node.module else []))
                    elif node.module and node.module.startswith("pcnet."):
                        target = node.module[len("pcnet."):]
                    else:
                        continue
                    found |= {f"{target}.{a.name}" for a in node.names}
                elif isinstance(node, ast.Import):
                    found |= {a.name[len("pcnet."):] for a in node.names if a.name.startswith("pcnet.")}
            out[str(path.relative_to(ROOT))] = {t for t in found if t.split(".")[0] in ROOMS}
    return out


IMPORTS = _imports()


def _in(target: str, where: str) -> bool:
    return target == where or target.startswith(where + ".")


def _violations(files: str, allowed) -> list[str]:
    return [f"{f} imports pcnet.{t}" for f, targets in IMPORTS.items() if _in(_package(ROOT / f), files)
            for t in sorted(targets) if not allowed(f, t)]


def test_the_rooms_were_read():
    assert any(f.startswith("stages/core/") for f in IMPORTS)
    assert any(_in(t, "models.inference") for t in IMPORTS["pipeline/rectification.py"])  # imports are seen
    assert any(_in(t, CORE) for t in IMPORTS["stages/kinematics.py"])  # relative imports resolved


@pytest.mark.parametrize("files, rule, allowed", [
    (CORE, "the geometry core imports only itself", lambda f, t: _in(t, CORE)),
    ("stages", "stages import only stages", lambda f, t: _in(t, "stages")),
    ("models", "models use stages only through the core (and may read the adapters' checks)",
     lambda f, t: _in(t, "models") or _in(t, CORE) or _in(t, "adapters")),
    ("adapters", "adapters use stages only through the core and never import models or pipeline",
     lambda f, t: _in(t, "adapters") or _in(t, CORE)),
])
def test_import_directions(files, rule, allowed):
    assert _violations(files, allowed) == [], rule


def test_nothing_imports_the_pipeline_but_itself():
    offenders = [f for f, targets in IMPORTS.items() if not f.startswith("pipeline/")
                 and any(_in(t, "pipeline") for t in targets)]
    assert offenders == []
