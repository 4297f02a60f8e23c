"""mkdocs hook: let mkdocstrings find the ``pcnet.*`` packages in the working tree.

pcnet's import names map top-level folders (``pipeline/`` -> ``pcnet.pipeline``, pyproject.toml
``[tool.setuptools.package-dir]``), which griffe's static analysis cannot follow. When mkdocs
loads this hook (before any page is read), it lays out ``build/pcnet-docs-src/pcnet/``, a
namespace package of symlinks to those folders (``build/`` is git-ignored); mkdocs.yml puts
``build/pcnet-docs-src`` on the python handler's search path.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TREE = ROOT / "build" / "pcnet-docs-src" / "pcnet"
PACKAGES = ("pipeline", "stages", "adapters", "models")

TREE.mkdir(parents=True, exist_ok=True)
for _name in PACKAGES:
    _link = TREE / _name
    if _link.is_symlink() and _link.resolve() != (ROOT / _name).resolve():
        _link.unlink()
    if not _link.is_symlink():
        _link.symlink_to(ROOT / _name, target_is_directory=True)
