"""Rectification speed on this machine: poses/s of the geometric baseline (numpy), 3DPCNet in
torch eager mode and 3DPCNet in onnxruntime, at batch 1 and batch 1024, for the shipped
width and the paper's width (randomly initialised: speed does not depend on the weights),
and the shipped pair as `pcnet run` calls it (both networks, the view gate, the blend;
models/inference.py: ViewGatedPCNet).

    python -m benchmarks.speed [--seconds 3] [--threads 0]

Last, the training rows: poses/s of one AdamW step (forward, the paper's loss, backward) at
batch 1024, what an epoch of `pcnet train` costs per pose on this machine.

Needs the [train] extra (torch, onnx) for the torch column and the paper-width export.
Inputs are real Bandai poses from the committed test fixture.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import onnxruntime as ort
import torch

from pcnet.models.datasets import load_mocap, make_pairs
from pcnet.models.export import export_onnx
from pcnet.models.inference import DEFAULT_WEIGHTS, ViewGatedPCNet
from pcnet.models.losses import LossWeights, composite_loss
from pcnet.models.network import PCNet, PCNetConfig
from pcnet.models.preprocess import normalize_input
from pcnet.stages.core.geometric import geometric_rotation

FIXTURE = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "bandai_small.npz"


def rate(fn, batch: int, seconds: float) -> float:
    """Poses per second of ``fn()`` processing ``batch`` poses, over about ``seconds``."""
    fn()  # warm-up
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        fn()
        n += 1
    return n * batch / (time.perf_counter() - t0)


def training_rate(cfg: PCNetConfig, x: np.ndarray, R: np.ndarray, canon: np.ndarray, seconds: float) -> float:
    """Poses/s of AdamW training steps on the normalised inputs ``x`` with their targets."""
    model = PCNet(cfg).train()
    opt = torch.optim.AdamW(model.parameters(), lr=1e-4)
    xb, Rb, cb = (torch.from_numpy(a).float() for a in (x, R, canon))

    def step():
        R_hat, delta, aux = model(xb, return_aux=True)
        loss, _ = composite_loss(model, xb, R_hat, delta, aux, Rb, cb, LossWeights())
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    return rate(step, len(x), seconds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--threads", type=int, default=0, help="intra-op threads (0 = library default)")
    args = ap.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    pairs = make_pairs(load_mocap(FIXTURE), "paper", seed=0)
    poses = np.resize(pairs.inputs, (1024, 17, 3))
    x, scale, _ = normalize_input(poses)
    R_true = np.resize(pairs.R, (1024, 3, 3))
    canon = np.resize(pairs.canonical, (1024, 17, 3)) / scale[:, None, None]

    shipped = PCNetConfig(**__import__("json").loads(DEFAULT_WEIGHTS.with_suffix(".json").read_text())["model_config"])
    presets = {"shipped": shipped, "paper": PCNetConfig()}
    rows = []
    for batch in (1, 1024):
        rows.append(("geometric (numpy)", "-", batch, rate(lambda: geometric_rotation(poses[:batch]), batch, args.seconds)))
    with tempfile.TemporaryDirectory() as tmp:
        for name, cfg in presets.items():
            model = PCNet(cfg).eval()
            path = DEFAULT_WEIGHTS if name == "shipped" else export_onnx(model, Path(tmp) / f"{name}.onnx")
            opts = ort.SessionOptions()
            if args.threads:
                opts.intra_op_num_threads = args.threads
            sess = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
            width = f"{cfg.hidden}/{cfg.output}"
            for batch in (1, 1024):
                xt = torch.from_numpy(x[:batch])
                with torch.no_grad():
                    rows.append((f"3DPCNet {name} torch eager", width, batch, rate(lambda: model(xt), batch, args.seconds)))
                xb = x[:batch]
                rows.append((f"3DPCNet {name} onnxruntime", width, batch,
                             rate(lambda: sess.run(["rotation"], {"x": xb}), batch, args.seconds)))
    gated = ViewGatedPCNet(threads=args.threads)
    for batch in (1, 1024):  # what `pcnet run` calls: both networks, the gate, the blend
        rows.append(("pcnet shipped pair (gated)", "2 nets", batch,
                     rate(lambda: gated.predict(poses[:batch]), batch, args.seconds)))
    for name, cfg in presets.items():
        rows.append((f"3DPCNet {name} training step", f"{cfg.hidden}/{cfg.output}", 1024,
                     training_rate(cfg, x, R_true, canon, args.seconds)))
    print(f"torch {torch.__version__} threads={torch.get_num_threads()}, onnxruntime {ort.__version__}")
    print(f"{'method':<34}{'hidden/out':>11}{'batch':>7}{'poses/s':>12}")
    for name, width, batch, r in rows:
        print(f"{name:<34}{width:>11}{batch:>7}{r:>12,.0f}")
    by = {(n, b): r for n, _, b, r in rows}
    print("ratios (batch 1024):")
    for name in presets:
        ort_r, torch_r = by[(f"3DPCNet {name} onnxruntime", 1024)], by[(f"3DPCNet {name} torch eager", 1024)]
        geo = by[("geometric (numpy)", 1024)]
        print(f"  {name}: onnxruntime / torch eager = {ort_r / torch_r:.2f}, geometric / onnxruntime = {geo / ort_r:.1f}")


if __name__ == "__main__":
    main()
