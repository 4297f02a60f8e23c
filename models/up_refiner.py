"""Static-camera up refiner: training and ONNX export (needs torch).

pcnet's addition, not in the 3DPCNet paper. A per-frame network cannot tell a leaning
body from a tilted camera: on Bandai it underestimates the forward lean of running in
every frame alike, so averaging frames (``--mode sequence``) keeps that bias. Over a
fraction of a second a fixed camera shows more: how the body moves relative to gravity
(a stance foot slides back parallel to the floor, the trunk swings about a vertical).
The refiner reads a window of poses around each frame, all expressed in that frame's
predicted canonical frame (:func:`pcnet.models.preprocess.window_features`), and
predicts the true up in that frame; run time is
:class:`pcnet.models.inference.UpRefinerSession` (onnxruntime).

Training data: the base 3DPCNet's own predictions on the train split, one fixed random
camera per clip (paper + wide views; fixed in the world or panning with the subject) with
upstream-like noise, so the refiner learns that network's errors. Loss: squared error of the (x, z) components of the true up in the
predicted canonical frame (for small errors, the tilt error in radians squared).
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from pcnet.stages.rotations import angle_between

from .datasets import Augmentation, Noise, load_mocap, make_pairs, select_split
from .inference import DEFAULT_WEIGHTS, PCNetSession, file_sha256, tilt_to_up
from .preprocess import normalize_input, window_features, window_indices
from .toml_config import check_config_keys, read_toml

OPSET = 18


@dataclass
class RefinerConfig:
    """A refiner training run; loaded from TOML by :func:`load_refiner_config`."""

    data: list[str] = field(default_factory=lambda: ["../shared/data/mocap/bandai_h36m17.npz"])
    out_dir: str = "runs/up_refiner"
    base_weights: str | None = None  # the 3DPCNet whose errors are learnt (None = shipped)
    # Window: 17 poses 1/15 s apart, +-0.53 s around the frame.
    offsets_s: list[float] = field(default_factory=lambda: [k / 30.0 for k in range(-16, 17, 2)])
    hidden: int = 512
    epochs: int = 8
    batch_size: int = 1024
    lr: float = 1e-3
    weight_decay: float = 1e-4
    views: str = "paper+wide"
    # One camera draw over the train split per entry (make_pairs' camera protocol) with that
    # entry's share of noisy poses: "static" cameras show the subject's own turns within a
    # window (real recordings), "per-clip" ones pan with them (the evaluation protocol).
    cameras: list[str] = field(default_factory=lambda: ["static", "per-clip", "static", "per-clip"])
    noise_fractions: list[float] = field(default_factory=lambda: [1.0, 1.0, 0.5, 0.5])
    augment: bool = True  # skeleton-proportion augmentation of the training draws (as 3DPCNet's)
    seed: int = 11
    threads: int = 0


def load_refiner_config(path: str | Path) -> RefinerConfig:
    """Read a TOML file with top-level keys of :class:`RefinerConfig`.

    Raises:
        ValueError: not TOML, an unknown key, ``cameras`` / ``noise_fractions`` of different
            lengths or a camera other than static / per-clip (named with the file).
    """
    path = Path(path)
    raw = read_toml(path)
    check_config_keys(path, "", raw, RefinerConfig)
    cfg = RefinerConfig(**raw)
    if len(cfg.cameras) != len(cfg.noise_fractions) or not cfg.cameras:
        raise ValueError(f"{path}: cameras and noise_fractions must be non-empty lists of the same length "
                         f"(one entry per camera draw), got {len(cfg.cameras)} and {len(cfg.noise_fractions)}")
    bad = sorted(set(cfg.cameras) - {"static", "per-clip"})
    if bad:
        raise ValueError(f"{path}: cameras: expected 'static' or 'per-clip' entries, got {bad}")
    return cfg


class UpRefinerNet(torch.nn.Module):
    """MLP: window features ``(B, W * 51)`` -> ``up_xz`` ``(B, 2)``."""

    def __init__(self, window: int, hidden: int):
        super().__init__()
        self.window, self.hidden = window, hidden
        self.net = torch.nn.Sequential(
            torch.nn.Linear(window * 51, hidden), torch.nn.GELU(),
            torch.nn.Linear(hidden, hidden), torch.nn.GELU(),
            torch.nn.Linear(hidden, 2),
        )

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return self.net(features)


@dataclass
class _Draw:
    """One camera draw over a split: normalised poses, base predictions, windows, targets."""

    x: np.ndarray
    R_hat: np.ndarray
    idx: np.ndarray
    centres: np.ndarray
    target: np.ndarray
    clip: np.ndarray  # clip index of each centre


def _draw(clips, cfg: RefinerConfig, session: PCNetSession, views: str, camera: str, seed: int,
          fraction: float, augment: bool) -> _Draw:
    pairs = make_pairs(clips, views=views, seed=seed, camera=camera,
                       noise=Noise(fraction=fraction) if fraction > 0 else None,
                       augmentation=Augmentation() if augment else None)
    R_hat, _, valid = session.predict(pairs.inputs)
    x, _, _ = normalize_input(pairs.inputs)
    idx = np.zeros((len(x), len(cfg.offsets_s)), np.int64)
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)  # one clip's frames are contiguous
        if len(sel):
            idx[sel] = sel[0] + window_indices(valid[sel], clip.fps, np.asarray(cfg.offsets_s))
    centres = np.flatnonzero(valid)
    true_up = np.einsum("nki,nk->ni", R_hat[centres], pairs.R[centres][:, :, 1])
    return _Draw(x, R_hat, idx, centres, true_up[:, [0, 2]].astype(np.float32), pairs.clip[centres])


def _features(d: _Draw, rows: np.ndarray) -> torch.Tensor:
    c = d.centres[rows]
    return torch.from_numpy(window_features(d.x, d.R_hat[c], d.idx[c]))


@torch.no_grad()
def _refined(model: UpRefinerNet, d: _Draw, batch: int = 8192) -> tuple[np.ndarray, np.ndarray]:
    """The centres' base rotations and refined rotations, ``(N, 3, 3)`` each."""
    model.eval()
    rows = np.arange(len(d.centres))
    pred = np.concatenate([model(_features(d, rows[i : i + batch])).numpy() for i in range(0, len(rows), batch)])
    R = d.R_hat[d.centres]
    return R, tilt_to_up(R, pred.astype(np.float64))


def _angle_deg(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.degrees(angle_between(u, v))


def _max_clip_median_correction_deg(model: UpRefinerNet, d: _Draw) -> float:
    """The largest per-clip median of the refiner's correction angle on ``d`` (degrees):
    the run-time domain check of :meth:`pcnet.models.inference.UpRefinerSession.refine`."""
    R, refined = _refined(model, d)
    corr = _angle_deg(refined[:, :, 1], R[:, :, 1])
    return float(max(np.median(corr[d.clip == c]) for c in np.unique(d.clip)))


def _val_tilt_deg(model: UpRefinerNet, d: _Draw) -> tuple[float, float]:
    """Mean per-frame tilt error (deg) of the base predictions and of the refined ones."""
    R, refined = _refined(model, d)
    true_up = np.einsum("nij,nj->ni", R, np.stack([d.target[:, 0], np.zeros(len(R)), d.target[:, 1]], -1))
    true_up += R[:, :, 1] * np.sqrt(np.clip(1 - (d.target ** 2).sum(-1), 0, 1))[:, None]
    return float(_angle_deg(R[:, :, 1], true_up).mean()), float(_angle_deg(refined[:, :, 1], true_up).mean())


def train_refiner(cfg: RefinerConfig, resume: bool = True, progress: bool = True) -> Path:
    """Train the up refiner; returns the best checkpoint (lowest val per-frame tilt error;
    val = the val split, paper views, full noise, static cameras). Writes ``last.pt``
    (resumable), ``best.pt`` and ``metrics.jsonl`` (with the seconds of data preparation)
    to ``cfg.out_dir``.

    Raises:
        ValueError: empty split; FileNotFoundError: base weights missing.
    """
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    session = PCNetSession(cfg.base_weights, threads=cfg.threads)
    clips = [c for path in cfg.data for c in load_mocap(path)]
    train_clips, val_clips = select_split(clips, "train"), select_split(clips, "val")
    draws = [_draw(train_clips, cfg, session, cfg.views, camera, cfg.seed + k, f, cfg.augment)
             for k, (camera, f) in enumerate(zip(cfg.cameras, cfg.noise_fractions))]
    val = _draw(val_clips, cfg, session, "paper", "static", 10_000 + cfg.seed, 1.0, False)
    prep_s = time.time() - t0

    model = UpRefinerNet(len(cfg.offsets_s), cfg.hidden)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    pool = np.concatenate([np.stack([np.full(len(d.centres), k), np.arange(len(d.centres))], 1)
                           for k, d in enumerate(draws)])
    steps_per_epoch = len(pool) // cfg.batch_size
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, cfg.lr, total_steps=cfg.epochs * steps_per_epoch)
    start, best = 0, float("inf")
    last = out / "last.pt"
    if resume and last.is_file():
        ck = torch.load(last, map_location="cpu", weights_only=False)
        model.load_state_dict(ck["model"])
        opt.load_state_dict(ck["optimizer"])
        sched.load_state_dict(ck["scheduler"])
        start, best = ck["epoch"] + 1, ck["best"]
    (out / "config.json").write_text(json.dumps(asdict(cfg), indent=2))
    with open(out / "metrics.jsonl", "a") as fh:
        fh.write(json.dumps({"data_preparation_seconds": round(prep_s, 1)}) + "\n")

    for epoch in range(start, cfg.epochs):
        t1 = time.time()
        order = pool[np.random.default_rng(cfg.seed + epoch).permutation(len(pool))]
        model.train()
        running = 0.0
        bar = tqdm(range(steps_per_epoch), desc=f"epoch {epoch + 1}/{cfg.epochs}", disable=not progress)
        for n in bar:
            batch = order[n * cfg.batch_size : (n + 1) * cfg.batch_size]
            feats, targets = [], []
            for k, d in enumerate(draws):
                rows = batch[batch[:, 0] == k, 1]
                feats.append(_features(d, rows))
                targets.append(torch.from_numpy(d.target[rows]))
            loss = ((model(torch.cat(feats)) - torch.cat(targets)) ** 2).sum(-1).mean()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            sched.step()
            running += (loss.item() - running) / (n + 1)
            bar.set_postfix(loss=f"{running:.2e}")
        base_deg, refined_deg = _val_tilt_deg(model, val)
        record = {"epoch": epoch + 1, "seconds": round(time.time() - t1, 1), "train_loss": running,
                  "val_tilt_base_deg": base_deg, "val_tilt_refined_deg": refined_deg}
        with open(out / "metrics.jsonl", "a") as fh:
            fh.write(json.dumps(record) + "\n")
        if progress:
            tqdm.write(json.dumps(record))
        best_now = min(best, refined_deg)
        ck = {"model": model.state_dict(), "optimizer": opt.state_dict(), "scheduler": sched.state_dict(),
              "epoch": epoch, "best": best_now, "config": asdict(cfg)}
        torch.save(ck, out / "last.pt.tmp")
        Path(out / "last.pt.tmp").replace(last)
        if refined_deg < best:
            best = refined_deg
            torch.save({"kind": "up_refiner", "model": model.state_dict(), "config": asdict(cfg),
                        "epoch": epoch + 1, "val": record}, out / "best.pt")
    best_ck = torch.load(out / "best.pt", map_location="cpu", weights_only=False)
    model.load_state_dict(best_ck["model"])
    best_ck["max_median_correction_deg"] = _max_clip_median_correction_deg(model, val)
    torch.save(best_ck, out / "best.pt")
    return out / "best.pt"


def load_refiner_checkpoint(path: str | Path) -> tuple[UpRefinerNet, RefinerConfig, dict]:
    """The refiner in eval mode, its training config and ``{"max_median_correction_deg"}``
    (its domain check; only in a finished run's ``best.pt``), from a checkpoint.

    Raises:
        ValueError: a ``best.pt`` without the domain check (training did not finish).
    """
    ck = torch.load(path, map_location="cpu", weights_only=False)
    if "max_median_correction_deg" not in ck:
        raise ValueError(f"{path}: no 'max_median_correction_deg' (the domain check is set when training finishes)")
    cfg = RefinerConfig(**ck["config"])
    model = UpRefinerNet(len(cfg.offsets_s), cfg.hidden)
    model.load_state_dict(ck["model"])
    return model.eval(), cfg, {"max_median_correction_deg": ck["max_median_correction_deg"]}


def export_refiner_onnx(model: UpRefinerNet, cfg: RefinerConfig, path: str | Path, metadata: dict | None = None) -> Path:
    """Write the refiner as ONNX (``features`` (B, W*51) -> ``up_xz`` (B, 2), dynamic batch)
    atomically, plus ``<path>.json`` with ``offsets_s``, ``hidden``, the base weights' file
    name and SHA-256 (run time applies the refiner to that network only) and ``metadata``
    (give it ``max_median_correction_deg`` from :func:`load_refiner_checkpoint`)."""
    path = Path(path)
    tmp = path.with_suffix(".onnx.tmp")
    with torch.no_grad():
        torch.onnx.export(
            model.eval(), (torch.zeros(4, model.window * 51),), str(tmp), input_names=["features"],
            output_names=["up_xz"], dynamic_axes={"features": {0: "batch"}, "up_xz": {0: "batch"}},
            opset_version=OPSET, dynamo=False,
        )
    tmp.replace(path)
    base = Path(cfg.base_weights) if cfg.base_weights else DEFAULT_WEIGHTS
    info = {"offsets_s": list(cfg.offsets_s), "hidden": cfg.hidden, "base_weights": base.name,
            "base_weights_sha256": file_sha256(str(base)), "opset": OPSET, **(metadata or {})}
    path.with_suffix(".json").write_text(json.dumps(info, indent=2))
    return path
