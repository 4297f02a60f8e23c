"""The ablation's network-term rows (benchmarks/ablation.py ``evidence_of(..., nets=)``, decision
0058): switching one network's term off blanks that network's ups in the up model's evidence and
leaves the other's as they are."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import ROOT

if str(ROOT) not in sys.path:  # benchmarks/ is a package of the repository, not of the installed pcnet
    sys.path.append(str(ROOT))
from benchmarks.ablation import evidence_of  # noqa: E402


def _record(T: int = 6) -> dict:
    rng = np.random.default_rng(2)
    rot = lambda: Rotation.random(T, random_state=rng).as_matrix()  # noqa: E731
    return {"R_body": rot(), "R_camT": rot(), "R_camP": rot(), "valid": np.array([True] * (T - 1) + [False]),
            "turns": np.zeros(T, np.int64), "up_camS": rot()[:, :, 1], "turnS": np.zeros(T, np.int64)}


@pytest.mark.parametrize("kept, blanked", [("camera", "body_up"), ("body", "camera_up")])
def test_one_networks_term_off_blanks_only_its_ups(kept, blanked):
    ev = _record()
    both, one = evidence_of(ev), evidence_of(ev, nets=kept)
    other = "camera_up" if blanked == "body_up" else "body_up"
    assert np.isnan(getattr(one, blanked)).all()
    np.testing.assert_array_equal(getattr(one, other), getattr(both, other))
    np.testing.assert_array_equal(one.valid, both.valid)
