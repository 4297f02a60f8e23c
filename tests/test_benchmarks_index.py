"""benchmarks/README.md's index table (the docs' scripts page, ``python -m
benchmarks.docs_tables``) names every runnable benchmark script, and nothing else: a script
whose command users cannot find in the docs, or a row whose script is gone, fails here."""

from __future__ import annotations

import re

from conftest import ROOT

BENCHMARKS = ROOT / "benchmarks"


def _indexed() -> set[str]:
    return set(re.findall(r"^\| `([a-z0-9_]+)` \|", (BENCHMARKS / "README.md").read_text(), re.MULTILINE))


def _runnable() -> set[str]:
    return {p.stem for p in BENCHMARKS.glob("*.py") if 'if __name__ == "__main__":' in p.read_text()}


def test_every_runnable_benchmark_script_has_a_row_in_the_index():
    assert _runnable() - _indexed() == set()


def test_every_row_of_the_index_names_a_script_that_exists():
    assert {name for name in _indexed() if not (BENCHMARKS / f"{name}.py").is_file()} == set()
