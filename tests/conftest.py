"""Shared test paths: committed fixtures, and the full shared data when it exists."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures"
SHARED_DATA = ROOT.parent / "shared" / "data"


def shared(*parts: str) -> Path:
    """A path under ../shared/data, skipping the test when it is absent (fresh clone)."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{path} not present: full-data check runs only beside ../shared/data")
    return path


def rrd_summary(path: Path):
    """Rows per temporal entity, the set of static entities, chunks per entity and the
    blueprint's view origins of an ``.rrd``, read with rerun's own reader."""
    from collections import Counter

    from rerun.chunk import RrdReader

    reader = RrdReader(path)
    rows, static, chunks = Counter(), set(), {}
    for ch in reader.stream():
        if ch.is_static:
            static.add(ch.entity_path)
        else:
            rows[ch.entity_path] += ch.num_rows
            chunks.setdefault(ch.entity_path, []).append(ch)
    origins = set()
    for ch in reader.stream(store=reader.blueprints()[0]):
        rb = ch.to_record_batch()
        if "ViewBlueprint:space_origin" in rb.schema.names:
            origins.update(v[0] for v in rb.column("ViewBlueprint:space_origin").to_pylist())
    return rows, static, chunks, origins
