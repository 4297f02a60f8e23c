"""pcnet's ISB joint angles against OpenSim (benchmarks/isb_opensim_agreement.py).

Needs the optional extra (``pip install "pcnet[opensim]"``) and is skipped without it.
- model check: the shipped model posed at random coordinates, pcnet's angles on its joint-centre
  markers: every sign mapping of the benchmark has slope +1 (no IK, no data);
- a real clip: the committed Bandai fixture (tests/fixtures/mocap_small.npz, 60 frames of the
  run) through scale_and_ik: the well-observed angles follow OpenSim's coordinates.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import FIXTURES, ROOT

if str(ROOT) not in sys.path:  # benchmarks/ is a package of the repository, not of the installed pcnet
    sys.path.append(str(ROOT))
from benchmarks import isb_opensim_agreement as agreement  # noqa: E402

SKIP = 'OpenSim not installed (pip install "pcnet[opensim]")'


def test_sign_mappings_on_the_model_itself():
    pytest.importorskip("opensim", reason=SKIP)
    from pcnet.stages.opensim_ik import import_opensim

    stats = agreement.model_check_stats(import_opensim(), n_poses=80, seed=1)
    assert set(stats) == {p[0] for p in agreement.PAIRS}
    for angle, st in stats.items():
        if angle == "trunk flexion / pelvis":
            # pcnet's pelvis Y (pelvis -> spine) follows the torso: only half the lumbar flexion.
            assert 0.4 < st["slope"] < 0.7, (angle, st)
            continue
        assert st["poses"] >= 40, (angle, st)
        assert 0.9 < st["slope"] < 1.1, (angle, st)  # +1: the sign mapping is right
        assert st["r"] > 0.95, (angle, st)
    for angle in ("hip adduction R", "hip adduction L", "hip rotation R", "hip rotation L", "knee flexion R",
                  "knee flexion L", "elbow flexion R", "elbow flexion L", "trunk lateral bending / pelvis",
                  "trunk axial rotation / pelvis", "thigh / thorax flexion R (hip + trunk flexion)"):
        assert stats[angle]["residual"] < 1.5, (angle, stats[angle])


def test_real_clip_agrees_with_opensim_ik(tmp_path):
    pytest.importorskip("opensim", reason=SKIP)
    from pcnet.models.datasets import load_mocap
    from pcnet.stages.sinks.exports import write_trc
    from pcnet.stages.opensim_ik import import_opensim

    clip = next(c for c in load_mocap(FIXTURES / "mocap_small.npz") if c.name == "dataset-2_run_masculine_037")
    trc = write_trc(tmp_path / "run.trc", agreement.to_floor_frame(np.asarray(clip.joints, float)[:60]), clip.fps)
    pc, ov, res = agreement.compare_recording(import_opensim(), trc, tmp_path / "ik")
    assert res["frames"] == 60
    by_angle = {p[0]: p for p in agreement.PAIRS}
    for angle in ("knee flexion R", "knee flexion L", "elbow flexion R", "elbow flexion L",
                  "thigh / thorax flexion R (hip + trunk flexion)", "thigh / thorax flexion L (hip + trunk flexion)"):
        _, col, coord, sign = by_angle[angle]
        s = agreement.agreement([agreement.pair_values(pc, ov, col, coord, sign)])
        assert s["frames"] >= 50, (angle, s)
        assert s["r"] > 0.9, (angle, s)  # a wrong sign would give r < 0
        assert s["cmae"] < 5.0, (angle, s)
        assert abs(s["bias"]) < 15.0, (angle, s)
