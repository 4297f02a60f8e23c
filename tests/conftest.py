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


def camera_up(pitch_deg: float, roll_deg: float):
    """``(3,)`` the unit up (camera frame) of a camera pitched and rolled by these angles
    (degrees; :func:`pcnet.stages.core.rotations.compose_camera_rotation`'s convention)."""
    import numpy as np

    from pcnet.stages.core.rotations import compose_camera_rotation

    return compose_camera_rotation(0.0, np.radians(pitch_deg), np.radians(roll_deg))[:, 1]


def sequence_up(posture, intervals_deg: tuple[float, float] = (8.0, 9.0), cone_deg: float = 12.0):
    """A :class:`pcnet.stages.rectification_report.SequenceUp` for flag tests: these posture
    hypotheses (``None``: no posture), pitch / roll 95 % half-widths and cone; its intervals
    reach the other posture where that keeps at least ``OTHER_POSTURE_P``, as the up model's do."""
    import numpy as np

    from pcnet.stages.rectification_report import SequenceUp
    from pcnet.stages.up_model import OTHER_POSTURE_P

    reaches = None if posture is None or posture.other_p < OTHER_POSTURE_P else posture.other_p
    return SequenceUp("up model", np.array([0.0, -1.0, 0.0]), 0.0, 0.0, *intervals_deg, cone_deg, 3.0, 3.0, reaches,
                      posture, 3.0, 6.0, {"used": False})


def run_report(requested: str = "auto", run: str = "sequence", spread_deg: float | None = None,
               intervals_deg: tuple[float, float] | None = None):
    """A :class:`pcnet.pipeline.run_report.RunReport` for summary tests: mode ``run`` for the
    ``requested`` one, and in sequence mode the up model's 95 % pitch / roll half-widths
    ``intervals_deg`` (upright, no posture other than upright kept)."""
    import numpy as np

    from pcnet.pipeline.checks import CameraTilt
    from pcnet.pipeline.run_report import RunReport
    from pcnet.stages.ground_plane import NO_PELVIS_PATH
    from pcnet.stages.rectification_report import (HeadingChoice, ModeChoice, PostureHypotheses,
                                                   RectificationReport, SequenceUp)

    sequence = None
    if intervals_deg is not None:
        sequence = SequenceUp("up model", np.array([0.0, -1.0, 0.0]), 8.6, 2.0, *intervals_deg,
                              float(np.hypot(*intervals_deg)), 3.0, 1.5, None,
                              PostureHypotheses("upright", 0.0, camera_up(8.0, 0.0)), 2.0, 5.0,
                              {"used": False, "reason": NO_PELVIS_PATH})
    rect = RectificationReport(ModeChoice(requested, run, spread_deg=spread_deg), sequence,
                               HeadingChoice("predicted", "auto", 3.0, 4.0), None, None, 4.4, np.full(3, 4.4))
    return RunReport(rect, CameraTilt(8.8, 8.6, 2.0), None if run == "sequence" else [8.0, 7.0, 9.0], None,
                     "world" if run == "sequence" else "canonical", "not observable" if run == "sequence" else None,
                     None, 6.0, "cutoff_hz", None)
