"""Calibrated pitch/roll intervals (stages/uncertainty.py) and their recorded calibration."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import shared
from pcnet.stages.rectify import SequenceEvidence
from pcnet.stages.uncertainty import FRAME_DISAGREEMENT_FACTOR, FRAME_TILT_95_BODY_DEG, FRAME_TILT_95_DEG, frame_tilt_bound

FRAME_RESULT = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "frame_bound.txt"


def test_constants_match_recorded_calibration():
    frame = FRAME_RESULT.read_text()
    assert "python -m benchmarks.calibrate_frame_bound" in frame
    m = re.search(r"FRAME_TILT_95_DEG = (\d+\.\d+), FRAME_DISAGREEMENT_FACTOR = (\d+\.\d+), "
                  r"FRAME_TILT_95_BODY_DEG = (\d+\.\d+)", frame)
    assert m and FRAME_TILT_95_DEG == pytest.approx(float(m.group(1)), abs=0.005)
    assert FRAME_DISAGREEMENT_FACTOR == pytest.approx(float(m.group(2)), abs=0.005)
    assert FRAME_TILT_95_BODY_DEG == pytest.approx(float(m.group(3)), abs=0.005)


def test_another_methods_sequence_up_has_its_bootstrap_and_no_95_percent_interval():
    rng = np.random.default_rng(0)
    R0 = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    R0 *= np.sign(np.linalg.det(R0))
    noise = [np.linalg.qr(np.eye(3) + 0.05 * rng.normal(size=(3, 3)))[0] for _ in range(60)]
    R = np.stack([n * np.sign(np.linalg.det(n)) @ R0 for n in noise])
    rep = SequenceEvidence("sequence")(None, R, None, 30.0).up
    assert np.isfinite([rep.camera_pitch_uncertainty_deg, rep.camera_roll_uncertainty_deg]).all()
    assert np.isnan([rep.camera_pitch_interval_deg, rep.camera_roll_interval_deg]).all()


def test_coverage_on_heldout_deepmimic_clips():
    """A few DeepMimic clips (never used for fitting the up model), static camera, lifter noise,
    seed 0: the posterior's intervals must contain the true pitch and roll far more often than
    the poses' part alone, and in most clips."""
    from pcnet.models.datasets import load_mocap, make_pairs
    from pcnet.models.lifter_noise import LifterNoise
    from pcnet.pipeline.rectification import rectify

    clips = load_mocap(shared("mocap", "deepmimic_h36m17.npz"))
    clips = [c for c in clips if 60 <= len(c.joints) <= 400][::3][:10]
    pairs = make_pairs(clips, views="paper", seed=0, camera="static", noise=LifterNoise())
    inside_boot, inside_cal = [], []
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)
        up = pairs.R[sel[0]][:, 1]
        true_p, true_r = np.degrees(np.arcsin(-up[2])), np.degrees(np.arctan2(up[0], -up[1]))
        rep = rectify(pairs.inputs[sel].astype(np.float64), "pcnet", mode="sequence", fps=clip.fps).report.sequence
        e = np.abs([rep.camera_pitch_deg - true_p, (rep.camera_roll_deg - true_r + 180) % 360 - 180])
        boot = np.array([rep.camera_pitch_uncertainty_deg, rep.camera_roll_uncertainty_deg])
        cal = np.array([rep.camera_pitch_interval_deg, rep.camera_roll_interval_deg])
        inside_boot.append(bool((e <= boot).all()))
        inside_cal.append(bool((e <= cal).all()))
    assert len(clips) >= 8
    assert np.mean(inside_cal) >= 0.7, (inside_boot, inside_cal)
    assert np.mean(inside_cal) >= np.mean(inside_boot)


@pytest.mark.slow
def test_frame_mode_summary_prints_the_calibrated_per_frame_bound(tmp_path):
    """Frame mode has no sequence interval; the summary prints the per-frame tilt bound
    calibrated on held-out mocap (FRAME_TILT_95_DEG), sequence mode does not."""
    from click.testing import CliRunner

    from conftest import FIXTURES
    from pcnet.pipeline.cli import main

    src = str(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")
    args = ["run", "--lifter", "videopose3d", "--lifter-output", src, "--fps", "30", "--no-recording"]
    res = CliRunner().invoke(main, [*args, "--mode", "frame", "--out", str(tmp_path / "f")])
    assert res.exit_code == 0, res.output
    # said as what it is: a bound that held in 81-92 % of held-out mocap frames, not a 95 % interval
    assert f"bound {FRAME_TILT_95_DEG:.1f} deg where the two networks agree" in res.output
    assert "not a 95 % interval" in res.output and "in 95 % of frames" not in res.output
    with np.load(tmp_path / "f" / "canonical.npz") as npz:
        bound, valid = npz["frame_tilt_bound_deg"], npz["valid"]
    assert bound.shape == valid.shape and np.isfinite(bound[valid]).all() and np.isnan(bound[~valid]).all()
    assert (bound[valid] >= min(FRAME_TILT_95_DEG, FRAME_TILT_95_BODY_DEG) - 1e-9).all()
    res = CliRunner().invoke(main, [*args, "--mode", "sequence", "--out", str(tmp_path / "s")])
    assert res.exit_code == 0, res.output
    assert "of the true up in 95 % of frames" not in res.output
    with np.load(tmp_path / "s" / "canonical.npz") as npz:  # the sequence up weighs frames equally (decision 0035)
        assert "sequence_frame_weights" not in json.loads(str(npz["report"]))


def test_frame_bound_widens_with_disagreement_and_hands_over_with_the_gate():
    """The per-frame bound is the calibrated base where the two networks agree, grows with
    their disagreement where the camera-frame network answers, and is the body-frame
    network's own bound where the gate set the camera-frame network aside."""
    d = np.array([0.0, 2.0, 5.0, 10.0, 20.0, np.nan])
    on = frame_tilt_bound(d, np.ones(6))
    assert on[0] == pytest.approx(FRAME_TILT_95_DEG)
    assert (np.diff(on[:5]) > 0).all() and np.isnan(on[5])
    assert on[4] == pytest.approx(np.hypot(FRAME_TILT_95_DEG, FRAME_DISAGREEMENT_FACTOR * 20.0))
    off = frame_tilt_bound(d[:5], np.zeros(5))
    np.testing.assert_allclose(off, FRAME_TILT_95_BODY_DEG)  # disagreement with an out-of-view network says nothing
    half = frame_tilt_bound(np.array([10.0]), np.array([0.5]))
    assert half[0] == pytest.approx(0.5 * on[3] + 0.5 * FRAME_TILT_95_BODY_DEG)
