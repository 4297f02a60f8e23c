"""3DPCNet network, loss convention, ONNX export and torch-free inference."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES, ROOT

from pcnet.stages.core.errors import InputError
from pcnet.models.datasets import load_mocap, make_pairs
from pcnet.models.inference import DEFAULT_WEIGHTS
from pcnet.models.preprocess import normalize_input
from pcnet.stages.core.metrics import rotation_error_deg

torch = pytest.importorskip("torch", reason="torch (the [train] extra) not installed")

from pcnet.models.losses import LossWeights, composite_loss  # noqa: E402
from pcnet.models.network import PCNet, PCNetConfig  # noqa: E402

# Tiny models run fastest on one thread, and multi-threaded torch stalls on a busy machine.
torch.set_num_threads(1)
TINY = PCNetConfig(hidden=32, output=48, feedforward=64, heads=4, dropout=0.0)


def _pairs(n: int, seed: int, views: str = "paper"):
    pairs = make_pairs(load_mocap(FIXTURES / "bandai_small.npz"), views, seed=seed, max_frames=n)
    x, scale, valid = normalize_input(pairs.inputs)
    assert valid.all()
    canon = pairs.canonical / scale[:, None, None]
    return torch.from_numpy(x), torch.from_numpy(pairs.R.astype(np.float32)), torch.from_numpy(canon), pairs


def test_forward_shapes_and_rotation_validity():
    model = PCNet(TINY).eval()
    x, _, _, _ = _pairs(8, 0)
    R, delta, aux = model(x, return_aux=True)
    assert R.shape == (8, 3, 3) and delta.shape == (8, 17, 3)
    np.testing.assert_allclose(torch.linalg.det(R).detach().numpy(), 1.0, atol=1e-5)
    assert aux["attention"].shape == (8, 4, 17, 17)
    assert torch.allclose(aux["gate"].sum(-1), torch.ones(8))
    A = model.gcn.learned_adjacency()
    assert torch.allclose(A, A.T)


def test_training_on_a_tiny_set_learns_R_not_its_transpose():
    """The convention trap of a public reference implementation: the network must learn the
    canonical->camera R that rotates the pose, so a pose rotated by a known R gives R_hat ~ R."""
    torch.manual_seed(0)
    # wide views: near the frontal camera R is almost symmetric, so R and R^T would agree
    x, R, canon, _ = _pairs(96, 1, "wide")
    model = PCNet(TINY)
    opt = torch.optim.AdamW(model.parameters(), lr=3e-3)
    for _ in range(250):
        R_hat, delta, aux = model(x, return_aux=True)
        loss, parts = composite_loss(model, x, R_hat, delta, aux, R, canon, LossWeights())
        opt.zero_grad()
        loss.backward()
        opt.step()
    model.eval()
    with torch.no_grad():
        R_hat = model(x)[0].double().numpy()
    err = rotation_error_deg(R_hat, R.double().numpy())
    err_transposed = rotation_error_deg(np.swapaxes(R_hat, 1, 2), R.double().numpy())
    assert np.median(err) < 10.0, np.median(err)
    assert np.median(err_transposed) > 2 * np.median(err)


def test_onnx_export_matches_torch_on_real_poses(tmp_path):
    pytest.importorskip("onnx", reason="onnx (the [train] extra) not installed")
    from pcnet.models.export import export_onnx, max_difference

    model = PCNet(TINY).eval()
    path = export_onnx(model, tmp_path / "tiny.onnx")
    for n in (1, 3, 37):  # other batch sizes than the traced one
        x, _, _, _ = _pairs(n, 2)
        assert max_difference(model, path, x.numpy()) <= 1e-4
    # <name>.json is the model's description: an ONNX path ending .json would be overwritten by it
    with pytest.raises(InputError, match="expected an ONNX file name"):
        export_onnx(model, tmp_path / "model.json")
    assert not (tmp_path / "model.json").exists()


def test_body_frame_input_is_exactly_equivariant(tmp_path):
    """input_frame = "body": a camera rotated by Q gives R_hat rotated by Q (any Q, incl. 90
    and 180 deg rolls), in torch and in the exported ONNX graph; the residual is unchanged."""
    from scipy.spatial.transform import Rotation

    torch.manual_seed(0)
    model = PCNet(PCNetConfig(hidden=32, output=48, feedforward=64, heads=4, dropout=0.0,
                              input_frame="body")).eval()
    x, _, _, _ = _pairs(16, 4)
    Qs = [Rotation.from_euler("z", a, degrees=True).as_matrix() for a in (90.0, 180.0)]
    Qs += list(Rotation.random(3, random_state=1).as_matrix())
    with torch.no_grad():
        R0, d0 = model(x)
        for Q in Qs:
            Qt = torch.from_numpy(Q.astype(np.float32))
            R1, d1 = model(x @ Qt.T)
            assert torch.allclose(R1, Qt @ R0, atol=1e-4)  # float32 round-off through the encoder
            assert torch.allclose(d1, d0, atol=1e-4)
    pytest.importorskip("onnx", reason="onnx (the [train] extra) not installed")
    from pcnet.models.export import export_onnx, max_difference

    path = export_onnx(model, tmp_path / "body.onnx")
    assert max_difference(model, path, x.numpy()) <= 1e-4


def test_geodesic_loss_gradient_is_finite_at_180_degrees():
    """Body-frame inputs look alike at initialisation, so predictions 180 deg from the truth
    are common: the loss must still give finite gradients there."""
    model = PCNet(TINY)
    x, R, canon, _ = _pairs(4, 5)
    flip = torch.diag(torch.tensor([-1.0, -1.0, 1.0]))
    R_hat = (R @ flip).requires_grad_(True)  # exactly 180 deg from the truth
    delta = torch.zeros_like(x)
    loss, _ = composite_loss(model, x, R_hat, delta, {"attention": None}, R, canon, LossWeights())
    loss.backward()
    assert torch.isfinite(R_hat.grad).all()


@pytest.mark.skipif(not DEFAULT_WEIGHTS.is_file(), reason="shipped weights not built yet")
def test_shipped_weights_match_their_checkpoint_free_session_on_real_poses():
    """The shipped ONNX graph gives valid rotations on real mocap, and the rotation it gives
    for a pose and for the same pose rotated by Q differ by Q (equivariance, up to the
    model's error)."""
    from pcnet.models.inference import PCNetSession

    _, R, _, pairs = _pairs(64, 3)
    sess = PCNetSession()
    R_hat, residual, valid = sess.predict(pairs.inputs)
    assert valid.all()
    np.testing.assert_allclose(np.linalg.det(R_hat), 1.0, atol=1e-4)
    assert np.median(rotation_error_deg(R_hat, pairs.R)) < 10.0


def test_a_network_output_that_is_not_a_rotation_makes_its_frame_invalid():
    """A degenerate 6D output leaves the exported Gram-Schmidt finite but singular (zero
    columns); that frame has no rotation, so it is invalid and NaN rather than a valid
    singular 'rotation' passed on to rectification."""
    from pcnet.models.inference import PCNetSession

    _, _, _, pairs = _pairs(8, 3)
    sess = PCNetSession()
    real = sess.session

    class Degenerate:  # the real graph's outputs, with the first pose's rotation collapsed
        def run(self, names, feeds):
            r, d = real.run(names, feeds)
            r[0, :, 1:] = 0.0
            return r, d

    sess.session = Degenerate()
    R_hat, residual, valid = sess.predict(pairs.inputs)
    assert not valid[0] and np.isnan(R_hat[0]).all() and np.isnan(residual[0]).all()
    assert valid[1:].all()
    np.testing.assert_allclose(np.linalg.det(R_hat[1:]), 1.0, atol=1e-4)


@pytest.mark.skipif(not DEFAULT_WEIGHTS.is_file(), reason="shipped weights not built yet")
def test_inference_runs_with_torch_blocked():
    """Run-time inference must not need torch: block its import in a fresh interpreter."""
    code = textwrap.dedent(
        """
        import sys, numpy as np
        class Block:
            def find_spec(self, name, path=None, target=None):
                if name == "torch" or name.startswith("torch."):
                    raise ImportError("torch blocked for this test")
        sys.meta_path.insert(0, Block())
        from pcnet.pipeline.rectification import rectify
        from pcnet.models.datasets import load_mocap
        joints = load_mocap(sys.argv[1])[0].joints
        res = rectify(joints, "pcnet")
        assert res.valid.all() and res.canonical.shape == joints.shape
        seq = rectify(joints, "pcnet", mode="sequence", fps=30.0)
        assert seq.mode == "sequence" and np.isfinite(seq.up[seq.valid]).all()
        assert "torch" not in sys.modules
        print("ok")
        """
    )
    out = subprocess.run([sys.executable, "-c", code, str(FIXTURES / "bandai_small.npz")],
                         capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


def test_a_weights_file_saved_over_is_opened_again(tmp_path, monkeypatch):
    """A developer trial retrained, saved the ONNX over the old file and rectified again in the
    same process: the cached session answered with the old network. The cache is keyed by the
    file's size and modification time too."""
    from pcnet.models import inference

    opened = []
    monkeypatch.setattr(inference, "PCNetSession", lambda path: opened.append(Path(path).read_bytes()) or len(opened))
    inference._cached_session.cache_clear()
    weights = tmp_path / "w.onnx"
    weights.write_bytes(b"first")
    assert inference.get_session(str(weights)) == inference.get_session(str(weights)) == 1  # cached
    weights.write_bytes(b"retrained")
    assert inference.get_session(str(weights)) == 2 and opened == [b"first", b"retrained"]
    inference._cached_session.cache_clear()
