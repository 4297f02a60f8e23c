"""Up refiners: training and ONNX export (needs torch).

pcnet's additions, not in the 3DPCNet paper. Two refiners share this code and differ by
their window (``offsets_s``) and input frame (``input_frame``):

Frame up refiner (``offsets_s = [0.0]``, ``input_frame = "body"``): re-estimates each
frame's up from that pose alone, seen in a frame fixed to the body (spine axis and hip
line, :func:`pcnet.models.preprocess.body_frame`). The pose is then the same from every
camera, so the MLP spends nothing on rotation equivariance, which 3DPCNet must learn from
camera-frame input; trained on clean mocap (Bandai proportions), it is used on
mocap-precise inputs only (:func:`pcnet.stages.heading.precise_hips`). Its output replaces
the network's up; the heading is kept.

Static-camera refiner (+-0.53 s window, for ``--mode sequence``): a per-frame network
cannot tell a leaning body from a tilted camera: on Bandai it underestimates the forward lean of running in
every frame alike, so averaging frames (``--mode sequence``) keeps that bias. Over a
fraction of a second a fixed camera shows more: how the body moves relative to gravity
(a stance foot slides back parallel to the floor, the trunk swings about a vertical).
It reads a window of poses around each frame, all expressed in that frame's
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

from pcnet.stages.atomic import atomic_path, write_text
from pcnet.stages.errors import InputError
from pcnet.stages.rotations import angle_between

from .checkpoint import (check_run_folder, config_from_dict, load_checkpoint_dict, load_state, not_a_checkpoint,
                         resume_point, save_checkpoint)
from .datasets import CAMERAS, Augmentation, Noise, load_mocap, make_pairs, select_split
from .inference import DEFAULT_WEIGHTS, PCNetSession, file_sha256, tilt_to_up
from .preprocess import REFINER_INPUTS, body_frame, normalize_input, refiner_features, refiner_up_xz, window_indices
from .toml_config import Range, check_choices, check_config_keys, check_lengths, check_ranges, read_toml
from .train import SEED_RANGE, VIEWS

OPSET = 18


@dataclass
class RefinerConfig:
    """A refiner training run; loaded from TOML by :func:`load_refiner_config` (valid values:
    :data:`REFINER_RANGES`, :data:`REFINER_LENGTHS` and the choices checked there)."""

    data: list[str] = field(default_factory=lambda: ["../shared/data/mocap/bandai_h36m17.npz"])
    out_dir: str = "runs/up_refiner"
    base_weights: str | None = None  # the 3DPCNet whose errors are learnt (None = shipped)
    # Window: 17 poses 1/15 s apart, +-0.53 s around the frame.
    offsets_s: list[float] = field(default_factory=lambda: [k / 30.0 for k in range(-16, 17, 2)])
    # "predicted": the window seen in the predicted canonical frame; "body" (one-frame
    # windows): the pose in a frame fixed to the body (its output replaces the network's up).
    input_frame: str = "predicted"
    hidden: int = 512
    layers: int = 2  # hidden layers of the MLP
    epochs: int = 8
    batch_size: int = 1024
    lr: float = 1e-3
    weight_decay: float = 1e-4
    views: str = "paper+wide"
    # One camera draw over the train split per entry (make_pairs' camera protocol) with that
    # entry's share of noisy poses: "static" cameras show the subject's own turns within a
    # window (real recordings), "per-clip" ones pan with them (the evaluation protocol).
    # "per-frame" (a new camera every frame, the paper's protocol) suits a one-frame window only.
    cameras: list[str] = field(default_factory=lambda: ["static", "per-clip", "static", "per-clip"])
    noise_fractions: list[float] = field(default_factory=lambda: [1.0, 1.0, 0.5, 0.5])
    # Validation draw (val split, paper views): picks the best epoch and sets the domain check.
    val_camera: str = "static"
    val_noise_fraction: float = 1.0
    augment: bool = True  # skeleton-proportion augmentation of the training draws (as 3DPCNet's)
    seed: int = 11
    threads: int = 0


#: Valid values of :class:`RefinerConfig`'s numeric fields (every value, every list entry,
#: also finite).
REFINER_RANGES = {
    "offsets_s": Range(-5, 5),  # seconds around the frame
    "hidden": Range(1, 8192),
    "layers": Range(1, 32),
    "epochs": Range(1, 10_000),
    "batch_size": Range(1, 1_048_576),
    "lr": Range(0, 1, low_inclusive=False),  # OneCycle peak learning rate, (0, 1]
    "weight_decay": Range(0, 1),
    "noise_fractions": Range(0, 1),  # shares of the poses
    "val_noise_fraction": Range(0, 1),
    "seed": SEED_RANGE,
    "threads": Range(0, 1024),  # 0 = torch / onnxruntime default
}
#: Lists and paths: 1 to 255 window offsets, 1 to 64 camera draws, at least one data file.
REFINER_LENGTHS = {"data": (1, 10_000), "out_dir": (1, 4096), "base_weights": (1, 4096), "offsets_s": (1, 255),
                   "cameras": (1, 64), "noise_fractions": (1, 64)}


def load_refiner_config(path: str | Path) -> RefinerConfig:
    """Read a TOML file with top-level keys of :class:`RefinerConfig`.

    Every value is checked here, before anything is created: types, the ranges of
    :data:`REFINER_RANGES` (all values finite), the list lengths of :data:`REFINER_LENGTHS`,
    ``views`` in :data:`pcnet.models.train.VIEWS`, ``input_frame`` in
    :data:`pcnet.models.preprocess.REFINER_INPUTS` and the cameras below.

    Raises:
        InputError: not TOML, an unknown key, a value of the wrong type or out of its
            range or choices, ``cameras`` / ``noise_fractions`` of different lengths, a
            camera other than static / per-clip, or per-frame or ``input_frame = "body"``
            with a window of more than one frame (named with the file and the field).
    """
    path = Path(path)
    raw = read_toml(path)
    check_config_keys(path, "", raw, RefinerConfig)
    cfg = RefinerConfig(**raw)
    check_ranges(path, "", cfg, REFINER_RANGES)
    check_lengths(path, "", cfg, REFINER_LENGTHS)
    check_choices(path, "", cfg, {"views": VIEWS, "input_frame": REFINER_INPUTS, "cameras": CAMERAS,
                                  "val_camera": CAMERAS})
    if len(cfg.cameras) != len(cfg.noise_fractions):
        raise InputError(f"{path}: cameras and noise_fractions must be non-empty lists of the same length "
                         f"(one entry per camera draw), got {len(cfg.cameras)} and {len(cfg.noise_fractions)}")
    if cfg.input_frame == "body" and len(cfg.offsets_s) != 1:
        raise InputError(f"{path}: input_frame: expected one of {REFINER_INPUTS} ('body' with a one-frame "
                         f"window, offsets_s = [0.0]), got {cfg.input_frame!r} with {len(cfg.offsets_s)} offsets")
    allowed = {"static", "per-clip"} | ({"per-frame"} if len(cfg.offsets_s) == 1 else set())
    bad = sorted(set(cfg.cameras + [cfg.val_camera]) - allowed)
    if bad:
        raise InputError(f"{path}: cameras, val_camera: expected {sorted(allowed)} for a window of "
                         f"{len(cfg.offsets_s)} frame(s), got {bad}")
    return cfg


class UpRefinerNet(torch.nn.Module):
    """MLP with ``layers`` hidden GELU layers: features ``(B, F)`` -> ``(B, 2)`` ``up_xz`` in
    the predicted canonical frame (``input_frame="predicted"``, ``F = W * 51``) or ``(B, 3)``
    the up in the body frame, unnormalised (``"body"``, ``F = 51``;
    :func:`pcnet.models.preprocess.refiner_features`)."""

    def __init__(self, window: int, hidden: int, layers: int = 2, input_frame: str = "predicted"):
        super().__init__()
        self.window, self.hidden, self.input_frame = window, hidden, input_frame
        self.n_features = window * 51
        self.n_out = 2 if input_frame == "predicted" else 3
        widths = [self.n_features] + [hidden] * layers
        blocks = [m for a, b in zip(widths, widths[1:]) for m in (torch.nn.Linear(a, b), torch.nn.GELU())]
        self.net = torch.nn.Sequential(*blocks, torch.nn.Linear(hidden, self.n_out))

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return self.net(features)


@dataclass
class _Draw:
    """One camera draw over a split: normalised poses, base predictions, windows, targets."""

    x: np.ndarray
    R_hat: np.ndarray
    idx: np.ndarray
    centres: np.ndarray
    true_up: np.ndarray  # (N, 3) camera frame, per centre
    target: np.ndarray  # what the network outputs: up_xz (predicted frame) or the up in the body frame
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
    true_up = pairs.R[centres][:, :, 1]
    if cfg.input_frame == "predicted":
        target = np.einsum("nki,nk->ni", R_hat[centres], true_up)[:, [0, 2]]
    else:
        target = np.einsum("nki,nk->ni", body_frame(x[centres]), true_up)
    return _Draw(x, R_hat, idx, centres, true_up, target.astype(np.float32), pairs.clip[centres])


def _features(model: UpRefinerNet, d: _Draw, rows: np.ndarray) -> torch.Tensor:
    c = d.centres[rows]
    return torch.from_numpy(refiner_features(model.input_frame, d.x, d.R_hat[c], d.idx[c]))


def _loss(model: UpRefinerNet, out: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Squared error of ``up_xz`` (for small errors, the tilt error in radians squared), or
    of the normalised body-frame up (the squared chord of the tilt error)."""
    if model.input_frame == "body":
        out = torch.nn.functional.normalize(out, dim=-1)
    return ((out - target) ** 2).sum(-1).mean()


@torch.no_grad()
def _refined(model: UpRefinerNet, d: _Draw, batch: int = 8192) -> tuple[np.ndarray, np.ndarray]:
    """The centres' base rotations and refined rotations, ``(N, 3, 3)`` each."""
    model.eval()
    rows = np.arange(len(d.centres))
    pred = np.concatenate([model(_features(model, d, rows[i : i + batch])).numpy() for i in range(0, len(rows), batch)])
    R = d.R_hat[d.centres]
    return R, tilt_to_up(R, refiner_up_xz(model.input_frame, d.x[d.centres], R, pred))


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
    return float(_angle_deg(R[:, :, 1], d.true_up).mean()), float(_angle_deg(refined[:, :, 1], d.true_up).mean())


def train_refiner(cfg: RefinerConfig, resume: bool = True, progress: bool = True) -> Path:
    """Train the up refiner; returns the best checkpoint (lowest val per-frame tilt error;
    val = the val split, paper views, ``val_camera``, ``val_noise_fraction``). Writes ``last.pt``
    (resumable), ``best.pt`` and ``metrics.jsonl`` (with the seconds of data preparation)
    to ``cfg.out_dir``; checkpoints hold tensors and plain types only
    (:mod:`pcnet.models.checkpoint`).

    Everything is read and checked (base weights, data, ``last.pt`` when resuming) before
    ``cfg.out_dir`` is created, so a bad input leaves no run folder behind.

    Raises:
        InputError: empty split, base weights missing or not ONNX, a ``batch_size`` larger
            than the training windows, or a ``last.pt`` that is not an up-refiner checkpoint
            of this architecture.
        FileNotFoundError, ValueError: a missing or unreadable data file.
    """
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    out = Path(cfg.out_dir)
    check_run_folder(out)
    t0 = time.time()
    session = PCNetSession(cfg.base_weights, threads=cfg.threads)
    clips = [c for path in cfg.data for c in load_mocap(path)]
    train_clips, val_clips = select_split(clips, "train"), select_split(clips, "val")
    for split, chosen in (("train", train_clips), ("val", val_clips)):
        if not chosen:
            raise InputError(f"data {cfg.data}: no clips in the {split} split "
                             f"(clips are split by name, pcnet.models.datasets.clip_split)")
    draws = [_draw(train_clips, cfg, session, cfg.views, camera, cfg.seed + k, f, cfg.augment)
             for k, (camera, f) in enumerate(zip(cfg.cameras, cfg.noise_fractions))]
    val = _draw(val_clips, cfg, session, "paper", cfg.val_camera, 10_000 + cfg.seed, cfg.val_noise_fraction, False)
    prep_s = time.time() - t0

    model = UpRefinerNet(len(cfg.offsets_s), cfg.hidden, cfg.layers, cfg.input_frame)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    pool = np.concatenate([np.stack([np.full(len(d.centres), k), np.arange(len(d.centres))], 1)
                           for k, d in enumerate(draws)])
    steps_per_epoch = len(pool) // cfg.batch_size
    if steps_per_epoch == 0:
        raise InputError(f"batch_size {cfg.batch_size}: larger than the {len(pool)} training windows of "
                         f"data {cfg.data}")
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, cfg.lr, total_steps=cfg.epochs * steps_per_epoch)
    start, best = 0, float("inf")
    last = out / "last.pt"
    if resume and last.is_file():
        ck = load_checkpoint_dict(last, kind="up_refiner", required=("model", "optimizer", "scheduler", "epoch", "best"))
        load_state(last, model, ck["model"], "model")
        load_state(last, opt, ck["optimizer"], "optimizer")
        load_state(last, sched, ck["scheduler"], "scheduler")
        start, best = resume_point(last, ck)
    out.mkdir(parents=True, exist_ok=True)
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
                if not len(rows):  # a small batch may hold no window of this draw
                    continue
                feats.append(_features(model, d, rows))
                targets.append(torch.from_numpy(d.target[rows]))
            loss = _loss(model, model(torch.cat(feats)), torch.cat(targets))
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
        save_checkpoint({"kind": "up_refiner", "model": model.state_dict(), "optimizer": opt.state_dict(),
                         "scheduler": sched.state_dict(), "epoch": epoch, "best": best_now, "config": asdict(cfg)},
                        last)
        if refined_deg < best:
            best = refined_deg
            save_checkpoint({"kind": "up_refiner", "model": model.state_dict(), "config": asdict(cfg),
                             "epoch": epoch + 1, "val": record}, out / "best.pt")
    best_ck = load_checkpoint_dict(out / "best.pt", kind="up_refiner")
    load_state(out / "best.pt", model, best_ck["model"], "model")
    best_ck["max_median_correction_deg"] = _max_clip_median_correction_deg(model, val)
    save_checkpoint(best_ck, out / "best.pt")
    return out / "best.pt"


def load_refiner_checkpoint(path: str | Path) -> tuple[UpRefinerNet, RefinerConfig, dict]:
    """The refiner in eval mode, its training config and ``{"max_median_correction_deg"}``
    (its domain check; only in a finished run's ``best.pt``), from a checkpoint read with
    ``weights_only=True`` (no code in the file runs).

    Raises:
        InputError: ``<path>: not a pcnet checkpoint (<reason>)``: not an up-refiner
            checkpoint, weights that do not fit its config, or a ``best.pt`` without the
            domain check (training did not finish).
    """
    ck = load_checkpoint_dict(path, kind="up_refiner", required=("model", "config"))
    domain = ck.get("max_median_correction_deg")
    if type(domain) not in (int, float):
        raise not_a_checkpoint(path, "no 'max_median_correction_deg': the domain check is set when training "
                                     "finishes")
    cfg = config_from_dict(path, "config", ck["config"], RefinerConfig)
    model = UpRefinerNet(len(cfg.offsets_s), cfg.hidden, cfg.layers, cfg.input_frame)
    load_state(path, model, ck["model"], "model")
    return model.eval(), cfg, {"max_median_correction_deg": float(domain)}


def export_refiner_onnx(model: UpRefinerNet, cfg: RefinerConfig, path: str | Path, metadata: dict | None = None) -> Path:
    """Write the refiner as ONNX (``features`` (B, F) -> ``up_xz`` (B, 2), or ``up_body``
    (B, 3) for ``input_frame="body"``; dynamic batch) atomically, plus ``<path>.json`` with
    ``offsets_s``, ``input_frame``, ``hidden``, ``layers``, the base weights' file name and
    SHA-256 (run time applies the refiner to that network only) and ``metadata`` (give it ``max_median_correction_deg`` from
    :func:`load_refiner_checkpoint`).

    Raises:
        InputError: the base weights file is missing (nothing is written then).
    """
    path = Path(path)
    base = Path(cfg.base_weights) if cfg.base_weights else DEFAULT_WEIGHTS
    # Checked before anything is written: without the base's hash the refiner is unusable.
    if not base.is_file():
        raise InputError(f"{base}: no such file (the base 3DPCNet weights the refiner was trained on, "
                         f"base_weights in its config)")
    info = {"offsets_s": list(cfg.offsets_s), "input_frame": cfg.input_frame, "hidden": cfg.hidden, "layers": cfg.layers, "base_weights": base.name,
            "base_weights_sha256": file_sha256(str(base)), "opset": OPSET}
    info.update(metadata or {})
    out_name = "up_xz" if model.input_frame == "predicted" else "up_body"
    with atomic_path(path) as tmp, torch.no_grad():
        torch.onnx.export(
            model.eval(), (torch.zeros(4, model.n_features),), str(tmp), input_names=["features"],
            output_names=[out_name], dynamic_axes={"features": {0: "batch"}, out_name: {0: "batch"}},
            opset_version=OPSET, dynamo=False,
        )
    write_text(path.with_suffix(".json"), json.dumps(info, indent=2))
    return path
