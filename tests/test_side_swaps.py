"""Left/right limb swaps found by path continuity and undone (``stages/side_swaps.py``,
decision 0106), on real mocap with the lifter-noise model's swaps, and through ``pcnet run``."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES

from pcnet.models.lifter_noise import apply_lifter_errors, sample_lifter_errors
from pcnet.pipeline.cli import main
from pcnet.stages.core.framestore import FrameStore
from pcnet.stages.side_swaps import exchange_sides, repair_side_swaps, side_swap_frames, side_swaps_note

LEGS, ARMS = [1, 2, 3, 4, 5, 6], [11, 12, 13, 14, 15, 16]


def _clips():
    with np.load(FIXTURES / "mocap_small.npz", allow_pickle=False) as f:
        return {k: f[k].astype(np.float64) - f[k][:, :1].astype(np.float64) for k in f.files}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_noise_models_swaps_are_found_exactly_and_nothing_else(seed):
    for name, J in _clips().items():
        errors = sample_lifter_errors(len(J), 30.0, np.random.default_rng(seed))
        errors.swap[40:44] = 2  # both limbs, 4 frames, in every clip
        noisy = apply_lifter_errors(J, errors)
        r = repair_side_swaps(noisy)
        legs, arms = np.isin(errors.swap, [0, 2]), np.isin(errors.swap, [1, 2])  # SWAP_PARTS: legs, arms, both
        assert np.array_equal(r.swapped["legs"], legs) and np.array_equal(r.swapped["arms"], arms), name
        unswapped = apply_lifter_errors(J, replace(errors, swap=np.full(len(J), -1)))
        np.testing.assert_allclose(r.joints, unswapped, atol=1e-12)
        assert not repair_side_swaps(unswapped).any and not repair_side_swaps(J).any


def test_a_gap_breaks_the_chain_and_each_run_keeps_the_labels_it_mostly_has():
    J = next(iter(_clips().values()))
    X = J.copy()
    X[80:] = X[80:][:, [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]]  # sides exchanged from 80 on
    X[78:80] = np.nan  # ...after a gap: a run of its own, mirrored throughout, which is not a swap
    assert not repair_side_swaps(X).any
    X[78:80] = J[78:80]  # no gap: the exchange at 80 is a jump, and the run's shorter part (40 of 120) is undone
    r = repair_side_swaps(X)
    for limb in ("legs", "arms"):
        assert np.flatnonzero(r.swapped[limb]).tolist() == list(range(80, len(X)))
    np.testing.assert_allclose(r.joints, J)


def test_a_store_array_is_repaired_in_place_a_block_at_a_time(tmp_path):
    J = next(iter(_clips().values()))
    X = J.copy()
    X[10:13][:, LEGS] = X[10:13][:, [4, 5, 6, 1, 2, 3]]
    with FrameStore(tmp_path) as store:
        a = store.create("joints", X.shape, np.float32)
        a[0:len(X)] = X
        swapped = side_swap_frames(a)
        exchange_sides(a, swapped)
        np.testing.assert_allclose(a[0:len(X)], J.astype(np.float32), atol=1e-6)
    assert np.flatnonzero(swapped["legs"]).tolist() == [10, 11, 12] and not swapped["arms"].any()
    assert side_swaps_note(swapped) == ("left/right swaps undone, found by the limbs' path continuity (decision "
                                        "0106): legs in 3 frames (10-12); canonical.npz side_swaps")
    assert side_swaps_note({"legs": np.zeros(5, bool), "arms": np.zeros(5, bool)}) is None


def test_pcnet_run_undoes_a_lifters_swap_and_says_where(tmp_path):
    """A gait trial found a left/right swap of a real lifter flagged and left in; the boxing
    clip's MotionBERT output with its legs exchanged in frames 20-23 comes back as it was."""
    X = np.load(FIXTURES / "boxing_X3D_f000-059.npy")
    swapped = X.copy()
    swapped[20:24][:, LEGS] = X[20:24][:, [4, 5, 6, 1, 2, 3]]
    np.save(tmp_path / "swapped.npy", swapped)
    runs = {}
    for name, path in (("as_given", FIXTURES / "boxing_X3D_f000-059.npy"), ("swapped", tmp_path / "swapped.npy")):
        res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output", str(path), "--fps", "30",
                                        "--no-recording", "--out", str(tmp_path / name)])
        assert res.exit_code == 0, res.output
        runs[name] = res.output
    assert "left/right swaps undone" not in runs["as_given"]
    report = (tmp_path / "swapped" / "report.md").read_text()
    assert "left/right swaps undone, found by the limbs' path continuity (decision 0106): legs in 4 frames (20-23)" in report
    with np.load(tmp_path / "swapped" / "canonical.npz", allow_pickle=False) as f, \
            np.load(tmp_path / "as_given" / "canonical.npz", allow_pickle=False) as g:
        assert np.flatnonzero(f["side_swaps"][:, 0]).tolist() == [20, 21, 22, 23] and not f["side_swaps"][:, 1].any()
        np.testing.assert_array_equal(f["joints_camera"], g["joints_camera"])
        assert not g["side_swaps"].any() and json.loads(str(f["report"]))
    assert (tmp_path / "swapped" / "kinematics.csv").read_bytes() == (tmp_path / "as_given" / "kinematics.csv").read_bytes()
