"""The frame up refiner: the shipped weights on held-out real mocap (one random camera per
frame, the paper's protocol), when it is (not) applied, and its training config.

Real motion: ``tests/fixtures/bandai_test_clips.npz`` (12 clips of the Bandai test split,
never trained on; CC BY-NC 4.0, see ``tests/fixtures/README.md``). Run with ``-s`` to see
the measured numbers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcnet.models.datasets import Noise, load_mocap, make_pairs
from pcnet.models.inference import DEFAULT_WEIGHTS, shipped_frame_refiner
from pcnet.stages.rectify import frame_refiner_for, rectify, up_refiner_note
from pcnet.stages.rotations import angle_between

FIXTURES = Path(__file__).parent / "fixtures"


def test_shipped_frame_refiner_lowers_the_per_frame_tilt_error_on_held_out_clips():
    """Clean poses (mocap: rigid pelvis), one random camera per frame, clip by clip as
    ``pcnet evaluate`` does: the tilt error with the frame up refiner is lower."""
    clips = load_mocap(FIXTURES / "bandai_test_clips.npz")
    pairs = make_pairs(clips, "paper", seed=0)
    errors, moved = {True: [], False: []}, []
    for i in range(len(clips)):
        sel = pairs.clip == i
        ups = {}
        for use in (True, False):
            res = rectify(pairs.inputs[sel], "pcnet", mode="frame", up_refiner=use)
            assert res.report["frame_refined"] is use and res.valid.all()
            ups[use] = res.up
            errors[use].append(np.degrees(angle_between(res.up, pairs.R[sel][:, :, 1])))
        moved.append(np.degrees(angle_between(ups[True], ups[False])))
    before, after, moved = (np.concatenate(v) for v in (errors[False], errors[True], moved))
    print(f"\n{len(before)} frames, per-frame tilt error {before.mean():.2f} deg -> {after.mean():.2f} "
          f"with the frame up refiner")
    assert after.mean() < before.mean()
    assert 0.0 < moved.mean() and moved.max() < 20.0  # a re-estimate near the network's, not a new frame


def test_frame_refiner_is_skipped_on_inputs_less_precise_than_mocap():
    """Upstream-like noise (the hip width varies from frame to frame): the network's ups are
    kept and the report says why."""
    clip = load_mocap(FIXTURES / "bandai_test_clips.npz")[:1]
    X = make_pairs(clip, "paper", seed=0, noise=Noise()).inputs
    res = rectify(X, "pcnet")
    assert res.report["frame_refined"] is False and "hip width CV" in res.report["frame_refiner_skipped"]
    np.testing.assert_allclose(res.rotation, rectify(X, "pcnet", up_refiner=False).rotation)


def test_frame_refiner_applies_only_to_the_network_it_was_trained_on(tmp_path):
    assert frame_refiner_for("geometric", None) is None
    assert frame_refiner_for("pcnet", None, use=False) is None
    assert frame_refiner_for("pcnet-rigid", None) is not None
    onnx = pytest.importorskip("onnx")
    model = onnx.load(str(DEFAULT_WEIGHTS))
    model.doc_string = "another 3DPCNet"  # a loadable network with other bytes
    other = tmp_path / "other.onnx"
    onnx.save(model, str(other))
    assert shipped_frame_refiner(str(other)) is None
    X = make_pairs(load_mocap(FIXTURES / "bandai_test_clips.npz")[:1], "paper").inputs
    res = rectify(X, "pcnet", weights=str(other))
    assert res.report["frame_refined"] is False and res.report["frame_refiner"] is None
    assert rectify(X, "geometric").report["frame_refined"] is False


def test_frame_refiner_declines_poses_unlike_its_training_data():
    """DeepMimic's crawl (on all fours, never in Bandai): the sequence's median correction is
    beyond the domain check, so the network's own ups are kept, and the summary says so."""
    clips = load_mocap(FIXTURES / "deepmimic_small.npz")
    crawl = next(c for c in clips if "crawl" in c.name)
    X = make_pairs([crawl], "paper", seed=0).inputs
    res = rectify(X, "pcnet", fps=crawl.fps)
    info = res.report["frame_refiner"]
    print(f"\ncrawl: median correction {info['median_correction_deg']:.1f} deg, "
          f"domain check {info['max_median_correction_deg']:.1f} deg")
    assert not info["applied"] and "frame up refiner not used" in up_refiner_note(res.report)
    np.testing.assert_allclose(res.rotation, rectify(X, "pcnet", up_refiner=False).rotation)


def test_refiner_config_allows_per_frame_cameras_for_a_one_frame_window_only(tmp_path):
    pytest.importorskip("torch")
    from pcnet.models.up_refiner import UpRefinerNet, load_refiner_config

    cfg = tmp_path / "frame.toml"
    cfg.write_text('offsets_s = [0.0]\ncameras = ["per-frame"]\nnoise_fractions = [0.5]\nval_camera = "per-frame"\n'
                   "layers = 3\nhidden = 16\n")
    loaded = load_refiner_config(cfg)
    net = UpRefinerNet(len(loaded.offsets_s), loaded.hidden, loaded.layers)
    assert sum(isinstance(m, __import__("torch").nn.Linear) for m in net.net) == 4
    cfg.write_text('cameras = ["per-frame"]\nnoise_fractions = [0.5]\n')  # the +-0.53 s default window
    with pytest.raises(ValueError, match=r"frame\.toml: cameras, val_camera: expected \['per-clip', 'static'\]"):
        load_refiner_config(cfg)


def test_frame_refiner_runs_before_sequence_mode_and_both_are_reported():
    """One camera per clip, clean: the frame refiner's ups feed sequence mode, and the report
    of each mode keeps what the frame refiner did."""
    X = make_pairs(load_mocap(FIXTURES / "bandai_test_clips.npz")[:1], "paper", camera="per-clip").inputs
    for mode in ("sequence", "smooth", "auto"):
        res = rectify(X, "pcnet", mode=mode)
        assert res.report["frame_refined"] is True and res.report["frame_refiner"]["applied"], mode
    assert rectify(X, "pcnet", mode="sequence").report["up_refined"] is True
