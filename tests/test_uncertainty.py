"""Calibrated pitch/roll intervals (stages/uncertainty.py) and their recorded calibration."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import shared
from pcnet.stages.rectify import SequenceEvidence
from pcnet.stages.uncertainty import (bound_weights, FRAME_DISAGREEMENT_FACTOR, FRAME_TILT_95_BODY_DEG, FRAME_TILT_95_DEG, SIGMA_SYS_DEG,
                                      Z, calibrated_interval, evidence_scale, frame_tilt_bound)

RESULT = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "uncertainty.txt"
FRAME_RESULT = RESULT.with_name("frame_bound.txt")


@pytest.mark.parametrize("axis", ["pitch", "roll"])
def test_interval_covers_bootstrap_and_is_monotone(axis):
    b = np.linspace(0.0, 20.0, 201)
    h = calibrated_interval(b, axis)
    assert h.shape == b.shape
    assert (h >= b).all() and (np.diff(h) > 0).all()
    assert calibrated_interval(0.0, axis) == pytest.approx(Z * SIGMA_SYS_DEG[axis])
    assert isinstance(calibrated_interval(1.0, axis), float)
    assert np.isnan(calibrated_interval(np.nan, axis))
    with pytest.raises(ValueError):
        calibrated_interval(1.0, "yaw")


def test_constants_match_recorded_calibration():
    text = RESULT.read_text()
    assert "python -m benchmarks.calibrate_uncertainty" in text
    for axis in ("pitch", "roll"):
        m = re.search(rf"^\s+{axis}\s+sigma_sys_deg = (\d+\.\d+)", text, re.M)
        assert m, f"{RESULT}: no calibrated sigma for {axis}"
        assert SIGMA_SYS_DEG[axis] == pytest.approx(float(m.group(1)), abs=0.005)
    frame = FRAME_RESULT.read_text()
    assert "python -m benchmarks.calibrate_frame_bound" in frame
    m = re.search(r"FRAME_TILT_95_DEG = (\d+\.\d+), FRAME_DISAGREEMENT_FACTOR = (\d+\.\d+), "
                  r"FRAME_TILT_95_BODY_DEG = (\d+\.\d+)", frame)
    assert m and FRAME_TILT_95_DEG == pytest.approx(float(m.group(1)), abs=0.005)
    assert FRAME_DISAGREEMENT_FACTOR == pytest.approx(float(m.group(2)), abs=0.005)
    assert FRAME_TILT_95_BODY_DEG == pytest.approx(float(m.group(3)), abs=0.005)
    m = re.search(r"Z = (\d+\.\d+); see", text)
    assert m and float(m.group(1)) == pytest.approx(Z)


def test_report_carries_calibrated_and_bootstrap_halfwidths():
    rng = np.random.default_rng(0)
    R0 = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    R0 *= np.sign(np.linalg.det(R0))
    noise = [np.linalg.qr(np.eye(3) + 0.05 * rng.normal(size=(3, 3)))[0] for _ in range(60)]
    R = np.stack([n * np.sign(np.linalg.det(n)) @ R0 for n in noise])
    _, _, rep = SequenceEvidence("sequence")(None, R, None, 30.0)
    for axis in ("pitch", "roll"):
        boot = rep[f"camera_{axis}_uncertainty_deg"]
        assert np.isfinite(boot)
        assert rep[f"camera_{axis}_interval_deg"] == pytest.approx(calibrated_interval(boot, axis))


def test_coverage_on_heldout_deepmimic_clips():
    """A few DeepMimic clips (never used for calibration), static camera, lifter noise, seed 0:
    the calibrated intervals must contain the true pitch and roll far more often than the
    bootstrap alone, and in most clips."""
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
        rep = rectify(pairs.inputs[sel].astype(np.float64), "pcnet", mode="sequence", fps=clip.fps).report
        e = np.abs([rep["camera_pitch_deg"] - true_p, (rep["camera_roll_deg"] - true_r + 180) % 360 - 180])
        boot = np.array([rep["camera_pitch_uncertainty_deg"], rep["camera_roll_uncertainty_deg"]])
        cal = np.array([rep["camera_pitch_interval_deg"], rep["camera_roll_interval_deg"]])
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


def test_bound_weights_are_inverse_variance_of_the_bound():
    b = np.array([FRAME_TILT_95_DEG, 2 * FRAME_TILT_95_DEG, np.nan, 0.0])
    np.testing.assert_allclose(bound_weights(b), [1.0, 0.25, 0.0, 0.0])

def test_evidence_scale_is_the_weighted_bound_relative_to_agreement():
    base = FRAME_TILT_95_DEG
    assert evidence_scale(np.full(50, base)) == pytest.approx(1.0)
    assert evidence_scale(np.full(50, 3 * base)) == pytest.approx(3.0)
    # Frames weigh as in the sequence up (inverse variance): one calm frame among wide ones counts most.
    mixed = np.array([base, 4 * base, 4 * base, np.nan])
    # weights 1, 1/16, 1/16; sum w (b / base) = 1 + 2 (1/16) 4
    assert evidence_scale(mixed) == pytest.approx((1 + 2 * 0.25) / (1 + 2 * 0.0625))
    assert 1.0 < evidence_scale(mixed) < 4.0
    assert evidence_scale(np.full(3, np.nan)) == 1.0 and evidence_scale(np.full(3, base), np.nan) == 1.0
    # The interval widens with it; scale 1 is the calibrated interval.
    assert calibrated_interval(0.5, "pitch", scale=1.0) == pytest.approx(calibrated_interval(0.5, "pitch"))
    assert calibrated_interval(0.0, "pitch", scale=3.0) == pytest.approx(3 * Z * SIGMA_SYS_DEG["pitch"])


def test_unfamiliar_real_poses_get_wider_intervals_than_standing():
    """Real VideoPose3D yoga (fixtures): a seated lotus, where the two networks disagree,
    gets an evidence scale above 1 and a wider sequence interval than a standing pose."""
    from conftest import FIXTURES
    from pcnet.pipeline.rectification import rectify

    reps = {}
    for name in ("yoga_vp3d_Bhumi_Tadasana.npy", "yoga_Abhay_Padmasana_f200-299.npy"):
        joints = np.load(FIXTURES / name, allow_pickle=False).astype(np.float64)
        reps[name] = rectify(joints - joints[:, :1], "pcnet", mode="sequence", fps=30.0).report
    stand, lotus = reps.values()
    assert stand["evidence_scale"] < 1.2 and lotus["evidence_scale"] > 2.0
    assert lotus["camera_pitch_interval_deg"] > stand["camera_pitch_interval_deg"]


@pytest.mark.slow
def test_summary_names_an_unfamiliar_recording(tmp_path):
    """The run summary's camera tilt line says when the evidence scale is beyond the
    calibration clips' (the seated lotus), and stays quiet for a standing pose."""
    from click.testing import CliRunner

    from conftest import FIXTURES
    from pcnet.pipeline.cli import main

    said = {}
    for name in ("yoga_vp3d_Bhumi_Tadasana.npy", "yoga_Abhay_Padmasana_f200-299.npy"):
        res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output", str(FIXTURES / name),
                                        "--fps", "30", "--no-recording", "--out", str(tmp_path / name)])
        assert res.exit_code == 0, res.output
        said[name] = "poses unlike the training data: widened" in res.output
    assert said == {"yoga_vp3d_Bhumi_Tadasana.npy": False, "yoga_Abhay_Padmasana_f200-299.npy": True}


