"""The user documentation's pages as installed with the package (``pcnet docs``): the outputs
and the run's report cite them as ``docs/<page>.md``, and a pip install has no repository
folder to find them in (a user trial), so they ship as package data of ``pcnet.docs``
(``pyproject.toml``): the top level, ``guide/``, ``benchmarks/`` and ``decisions/``."""

from __future__ import annotations

import importlib
from pathlib import Path

from pcnet.stages.core.errors import InputError, close_names

#: The folders of the docs site shipped with the package (the pages the outputs cite).
SHIPPED_FOLDERS = ("", "guide", "benchmarks", "decisions")


def docs_folder() -> Path:
    """The installed ``pcnet/docs`` folder (the repository's ``docs/`` in an editable install).
    ``pcnet.docs`` is a namespace package (no ``__init__``, so the docs site holds no Python),
    whose path lists the folder; ``importlib.resources`` cannot read an editable install's
    namespace path on Python 3.11.

    Raises:
        InputError: the package was installed without its documentation."""
    for entry in importlib.import_module("pcnet.docs").__path__:
        if Path(entry).is_dir():
            return Path(entry)
    raise InputError("pcnet docs: expected the documentation installed with pcnet (pcnet/docs), got no such folder: "
                     "reinstall pcnet")


def pages() -> dict[str, Path]:
    """``{name: file}`` of the shipped pages, ``name`` as the docs site's path without
    ``.md`` (``"joint_angles"``, ``"guide/limits"``): folder by folder in
    :data:`SHIPPED_FOLDERS`' order, each sorted by name."""
    root = docs_folder()
    return {str(p.relative_to(root).with_suffix("")): p
            for folder in SHIPPED_FOLDERS for p in sorted((root / folder).glob("*.md"))}


def find_page(cited: str) -> tuple[str, Path]:
    """The shipped page ``cited`` names: as the outputs cite it (``docs/guide/limits.md``,
    with or without a ``#section``), its name (``guide/limits``), where no other page has it its
    file's name alone (``limits``), or a decision's number (``0090``, as "decision 0090" is cited).

    Returns:
        ``(name, file)``.

    Raises:
        InputError: no shipped page by that name (close names suggested).
    """
    known = pages()
    name = cited.split("#", 1)[0].strip().removeprefix("docs/").removesuffix(".md")
    if name in known:
        return name, known[name]
    by_file = [n for n in known if n.rsplit("/", 1)[-1] == name
               or (name.isdigit() and n.startswith(f"decisions/{int(name):04d}-"))]
    if len(by_file) == 1:
        return by_file[0], known[by_file[0]]
    if name == "api" or name.startswith("api/"):  # the site renders these from docstrings (a developer trial)
        module = "pcnet." + (name.removeprefix("api/") if name != "api" else "pipeline")
        raise InputError(f"pcnet docs {cited}: expected one of the shipped pages (pcnet docs lists them), got the "
                         f"Python API, which the modules' docstrings are: python -m pydoc {module}")
    raise InputError(f"pcnet docs {cited}: expected one of the shipped pages (pcnet docs lists them), got no page "
                     f"{name!r}{close_names([name], [*known, *(n.rsplit('/', 1)[-1] for n in known)])}")


def title(page: Path) -> str:
    """A page's first heading (``# ...``), or its file name where it has none."""
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("# "):
            return line[2:].strip()
    return page.name
