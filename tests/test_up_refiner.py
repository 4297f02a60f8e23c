"""The static-camera up refiner: window maths, the rotation update, the shipped weights on
held-out real mocap, and when the refiner is (not) applied.

Real motion: ``tests/fixtures/bandai_test_clips.npz``, four clips of the Bandai test split
(never trained on; CC BY-NC 4.0, see ``tests/fixtures/README.md``), each seen by one camera
fixed in the world for the whole clip. Run with ``-s`` to see the measured numbers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcnet.models.datasets import Noise, load_mocap, make_pairs
from pcnet.models.inference import DEFAULT_WEIGHTS, UpRefinerSession, get_session, shipped_up_refiner, tilt_to_up
from pcnet.models.preprocess import normalize_input, refiner_features, window_features, window_indices
from pcnet.stages.rectify import rectify, up_refiner_for, up_refiner_note
from pcnet.stages.rotations import angle_between, axis_rotation, sample_camera_rotations

FIXTURE = Path(__file__).parent / "fixtures" / "bandai_test_clips.npz"


def _static_camera_views(noise: bool = False):
    """The fixture clips, each seen by one camera fixed in the world ('paper' view at the
    clip's first frame): ``[(name, camera-frame joints (T, 17, 3), true up (3,))]``."""
    clips = load_mocap(FIXTURE)
    pairs = make_pairs(clips, "paper", seed=0, camera="static", noise=Noise() if noise else None)
    out = []
    for i, clip in enumerate(clips):
        sel = pairs.clip == i
        out.append((clip.name, pairs.inputs[sel].astype(np.float64), pairs.R[sel][0][:, 1]))
    return out


def test_window_indices_clamp_scale_with_fps_and_skip_invalid_frames():
    valid = np.ones(10, bool)
    valid[6] = False
    idx = window_indices(valid, 30.0, np.array([-2 / 30, 0.0, 2 / 30]))
    assert idx.shape == (10, 3) and idx.dtype == np.int64
    assert idx[0].tolist() == [0, 0, 2]          # clamped at the start
    assert idx[9].tolist() == [7, 9, 9]          # clamped at the end
    assert idx[4].tolist() == [2, 4, 4]          # invalid neighbour 6 -> the centre frame
    # the same offsets in seconds span twice the frames at 60 fps
    assert window_indices(np.ones(10, bool), 60.0, np.array([2 / 30]))[0, 0] == 4
    with pytest.raises(ValueError, match="fps"):
        window_indices(valid, 0.0, np.array([0.0]))


def test_window_features_are_the_window_in_the_centre_frames_canonical_frame():
    _, X, _ = _static_camera_views()[0]
    x, _, valid = normalize_input(X)
    R_cam = sample_camera_rotations(1, "wide", np.random.default_rng(0))[0]  # any canonical->camera
    idx = window_indices(valid, 30.0, np.array([0.0, 4 / 30]))
    f = window_features(x, R_cam[None], idx[:1]).reshape(2, 17, 3)
    assert f.dtype == np.float32
    assert np.allclose(f[0], x[0] @ R_cam, atol=1e-5)  # row vectors: canonical = x_cam @ R
    assert np.allclose(f[1], x[4] @ R_cam, atol=1e-5)


def test_tilt_to_up_sets_the_up_and_keeps_the_heading():
    rng = np.random.default_rng(1)
    R = sample_camera_rotations(50, "wide", rng)
    up_xz = rng.normal(0.0, 0.1, (50, 2))
    out = tilt_to_up(R, up_xz)
    assert np.allclose(np.einsum("nij,nkj->nik", out, out), np.eye(3), atol=1e-9)
    assert np.allclose(np.linalg.det(out), 1.0)
    u = np.stack([up_xz[:, 0], np.sqrt(1 - (up_xz**2).sum(-1)), up_xz[:, 1]], -1)
    assert np.allclose(out[:, :, 1], np.einsum("nij,nj->ni", R, u), atol=1e-9)
    # the turn R^T R' is a pure tilt: its axis is horizontal in the canonical frame
    from scipy.spatial.transform import Rotation

    rotvec = Rotation.from_matrix(np.einsum("nji,njk->nik", R, out)).as_rotvec()
    assert np.abs(rotvec[:, 1]).max() < 1e-9
    assert np.allclose(tilt_to_up(R, np.zeros((50, 2))), R)


@pytest.mark.parametrize("noise", [False, True], ids=["clean", "noise"])
def test_shipped_refiner_lowers_the_sequence_tilt_error_on_held_out_clips(noise):
    """Bandai test-split clips (12 clips, every 22nd by name), one static camera each:
    ``--mode sequence`` with and without the refiner, shipped weights."""
    with_ref, without = [], []
    for name, X, up_true in _static_camera_views(noise):
        errs = []
        for use in (True, False):
            res = rectify(X, "pcnet", mode="sequence", up_refiner=use)
            assert res.report["up_refined"] is use
            errs.append(float(np.degrees(angle_between(res.up[res.valid][0], up_true))))
        with_ref.append(errs[0])
        without.append(errs[1])
        print(f"\n{name:42s} sequence tilt error {errs[1]:.2f} deg -> {errs[0]:.2f} with the refiner")
    print(f"mean over {len(with_ref)} clips: {np.mean(without):.2f} -> {np.mean(with_ref):.2f} deg")
    assert np.mean(with_ref) < np.mean(without)


def test_refiner_applies_only_to_the_network_it_was_trained_on(tmp_path):
    assert up_refiner_for("geometric", None) is None
    assert up_refiner_for("pcnet", None, use=False) is None
    assert up_refiner_for("pcnet-rigid", None) is not None
    other = tmp_path / "other.onnx"
    other.write_bytes(DEFAULT_WEIGHTS.read_bytes() + b"\0")  # any other bytes: another network
    assert shipped_up_refiner(str(other)) is None
    assert shipped_up_refiner(str(DEFAULT_WEIGHTS)) is not None
    # frame mode never uses it; geometric sequence mode says it did not run
    X = _static_camera_views()[0][1]
    assert "up_refined" not in rectify(X, "pcnet", mode="frame").report
    assert rectify(X, "geometric", mode="sequence").report["up_refined"] is False


def test_refiner_keeps_invalid_frames_and_needs_its_window_offsets(tmp_path):
    X = _static_camera_views()[1][1]
    X[5, 1] = np.nan  # right hip missing: frame 5 cannot be rectified
    R, _, valid = get_session().predict(X)
    refined, info = UpRefinerSession().refine(X, R, valid, 30.0)
    assert info["applied"]
    assert not valid[5] and np.isnan(refined[5]).all()
    assert np.isfinite(refined[valid]).all()
    moved = np.degrees(angle_between(refined[valid][:, :, 1], R[valid][:, :, 1]))
    assert 0.0 < moved.max() < 60.0
    # a weights file without its .json (window offsets) is refused with the file named
    bare = tmp_path / "up_refiner.onnx"
    bare.write_bytes((DEFAULT_WEIGHTS.parent / "up_refiner.onnx").read_bytes())
    with pytest.raises(ValueError, match=r"up_refiner\.json.*offsets_s"):
        UpRefinerSession(bare)


def test_refiner_declines_motion_unlike_its_training_data():
    """DeepMimic's crawl (on all fours, never in Bandai): the median correction is beyond the
    domain check, so sequence mode keeps the network's own ups and says so; a Bandai clip
    passes the check."""
    clips = load_mocap(Path(__file__).parent / "fixtures" / "deepmimic_small.npz")
    crawl = next(c for c in clips if "crawl" in c.name)
    pairs = make_pairs([crawl], "paper", seed=0, camera="static")
    res = rectify(pairs.inputs, "pcnet", mode="sequence", fps=crawl.fps)
    info = res.report["up_refiner"]
    print(f"\ncrawl: median correction {info['median_correction_deg']:.1f} deg, "
          f"domain check {info['max_median_correction_deg']:.1f} deg")
    assert not info["applied"] and res.report["up_refined"] is False
    assert "not used" in up_refiner_note(res.report)
    plain = rectify(pairs.inputs, "pcnet", mode="sequence", fps=crawl.fps, up_refiner=False)
    np.testing.assert_allclose(res.up[res.valid], plain.up[plain.valid])
    res = rectify(_static_camera_views()[0][1], "pcnet", mode="sequence")
    assert res.report["up_refiner"]["applied"] and "refined" in up_refiner_note(res.report)


@pytest.mark.parametrize("input_frame, offsets", [("predicted", None), ("body", [0.0])])
def test_onnx_export_matches_torch(tmp_path, input_frame, offsets):
    torch = pytest.importorskip("torch")
    from pcnet.models.up_refiner import RefinerConfig, UpRefinerNet, export_refiner_onnx

    cfg = RefinerConfig(hidden=32, input_frame=input_frame, **({"offsets_s": offsets} if offsets else {}))
    torch.manual_seed(0)
    net = UpRefinerNet(len(cfg.offsets_s), cfg.hidden, cfg.layers, cfg.input_frame)
    torch.nn.init.normal_(net.net[-1].weight, std=0.1)  # a trained-like, non-zero correction
    path = export_refiner_onnx(net, cfg, tmp_path / "r.onnx", {"max_median_correction_deg": 6.0})
    sess = UpRefinerSession(path)
    assert np.allclose(sess.offsets_s, cfg.offsets_s) and sess.max_median_correction_deg == 6.0
    assert sess.input_frame == input_frame
    X = _static_camera_views()[2][1]
    x, _, valid = normalize_input(X)
    R = np.repeat(axis_rotation("x", np.array([0.2])), len(x), 0)
    feats = refiner_features(input_frame, x, R, window_indices(valid, 30.0, sess.offsets_s))
    with torch.no_grad():
        ref = net(torch.from_numpy(feats)).numpy()
    (got,) = sess.session.run(None, {"features": feats})
    assert got.shape == (len(x), 2 if input_frame == "predicted" else 3)
    assert np.abs(got - ref).max() <= 1e-5


def test_body_frame_features_are_the_same_from_every_camera():
    """The frame refiner's input does not change when the camera turns, and an output equal
    to the predicted up (any length) maps back to no correction."""
    from pcnet.models.preprocess import body_frame, refiner_up_xz

    _, X, _ = _static_camera_views()[0]
    x, _, valid = normalize_input(X)
    R = get_session().predict(X)[0]
    idx = np.arange(len(x))[:, None]
    Q = sample_camera_rotations(1, "wide", np.random.default_rng(3))[0]
    f = refiner_features("body", x, R, idx)
    f_turned = refiner_features("body", (x @ Q.T).astype(np.float32), Q @ R, idx)
    assert f.shape == (len(x), 51) and np.abs(f - f_turned).max() < 1e-4
    B = body_frame(x)
    assert np.allclose(np.einsum("nji,njk->nik", B, B), np.eye(3), atol=1e-9)
    assert np.allclose(B[:, :, 0], (x[:, 8] / np.linalg.norm(x[:, 8], axis=-1, keepdims=True)), atol=1e-6)
    unchanged = refiner_up_xz("body", x, R, 2.0 * np.einsum("nji,nj->ni", B, R[:, :, 1]))
    assert np.abs(unchanged).max() < 1e-6
    with pytest.raises(ValueError, match="refiner input frame"):
        refiner_features("camera", x, R, idx)


def test_refiner_commands_reject_bad_files_in_one_line(tmp_path):
    pytest.importorskip("torch")
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text("epochs = 2\n[oops\n")
    res = CliRunner().invoke(main, ["train-refiner", "--config", str(bad)])
    assert res.exit_code == 1 and "bad.toml: not a readable TOML config" in res.output
    bad.write_text('cameras = ["static"]\n')
    res = CliRunner().invoke(main, ["train-refiner", "--config", str(bad)])
    assert res.exit_code == 1 and "cameras and noise_fractions" in res.output
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a checkpoint")
    out = tmp_path / "r.onnx"
    res = CliRunner().invoke(main, ["export", "--checkpoint", str(junk), "--out", str(out)])
    assert res.exit_code == 1 and "junk.pt: not a pcnet checkpoint" in res.output
    assert not out.exists() and len(res.output.strip().splitlines()) == 1
