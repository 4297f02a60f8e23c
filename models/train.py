"""Training loop for 3DPCNet (paper section 2.2.2): AdamW, cosine annealing, composite loss,
resumable checkpoints, a JSON-lines metrics log per epoch.

Each epoch draws fresh camera rotations, proportion augmentation and upstream-like noise
(seeded by ``seed + epoch``), so the model never sees the same (pose, view) twice.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from pcnet.stages.core.atomic import make_parents, remove_created, write_text
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.canonical import trunk_lean_deg
from pcnet.stages.core.digest import sha256_file
from pcnet.stages.core.metrics import rotation_error_deg, summarize, tilt_error_deg

from .checkpoint import (check_run_folder, config_from_dict, load_checkpoint_dict, load_state, not_a_checkpoint,
                         resume_point, save_checkpoint)
from .datasets import (SPLIT_SCHEMES, Augmentation, Noise, assumed_fps_warning, lean_balance_weights, load_mocap,
                       make_pairs, select_split, world_up_warning)
from .lifter_noise import LifterNoise
from .losses import LossWeights, composite_loss
from .network import PCNet, PCNetConfig
from .preprocess import normalize_input
from .toml_config import Range, check_choices, check_config_keys, check_lengths, check_ranges, read_toml


@dataclass
class TrainConfig:
    """Everything a training run depends on; loaded from TOML by :func:`load_config` (valid
    values: :data:`TRAIN_RANGES`, :data:`MODEL_RANGES`, :data:`LOSS_RANGES`, :data:`VIEWS`,
    :data:`DEVICES`)."""

    data: list[str] = field(default_factory=lambda: ["../shared/data/mocap/bandai_h36m17.npz"])
    # How many times each ``data`` file's clips enter an epoch (each copy with its own
    # cameras, proportions and noise): weights a small set of rare pose types; [] = once each.
    data_repeats: list[int] = field(default_factory=list)
    # Per ``data`` file, true: every clip of it trains and none validates, whatever the split
    # scheme (a documented subset of a cross-dataset set moved into training, such as
    # configs/pcnet_body_floor.toml's DeepMimic floor motions); [] = none.
    train_whole: list[bool] = field(default_factory=list)
    # Train/val clips (:data:`pcnet.models.datasets.SPLIT_SCHEMES`): "motion-style" keeps
    # every take of a held-out motion+style (Bandai) or subject (CMU) out of training.
    split_scheme: str = "clip"
    out_dir: str = "runs/pcnet"
    epochs: int = 80
    batch_size: int = 1024
    lr: float = 5e-4
    weight_decay: float = 0.01
    views: str = "wide"
    frame_stride: int = 1
    noise: bool = True
    noise_fraction: float = 1.0  # share of training poses that get the noise (validation: all)
    # "frame": frame-independent upstream noise (models.datasets.Noise); "lifter": errors
    # that persist over a clip (models.lifter_noise.LifterNoise), as real lifters make.
    noise_model: str = "frame"
    augment: bool = True
    # Share of clips mirrored left-right per epoch (with ``augment``; models.datasets.Augmentation).
    mirror_fraction: float = 0.0
    # > 0: each epoch draws its poses with replacement from every frame of the training
    # clips (not every ``frame_stride``-th), weighted by inverse trunk-lean frequency capped
    # at this value (models.datasets.lean_balance_weights); the epoch keeps its length.
    lean_balance_cap: float = 0.0
    # Per-clip posture augmentation, degrees (with ``augment``; models.datasets.Augmentation):
    # std of the upper body's sagittal and lateral turn about the pelvis and of the head's
    # sagittal turn about the thorax. 0 = off.
    trunk_sagittal_sigma_deg: float = 0.0
    trunk_lateral_sigma_deg: float = 0.0
    head_sagittal_sigma_deg: float = 0.0
    seed: int = 0
    threads: int = 0  # 0 = torch default
    device: str = "auto"  # auto = cuda when present
    val_frames: int = 20000
    init_checkpoint: str | None = None  # start from these weights (fine-tuning), fresh optimiser
    model: PCNetConfig = field(default_factory=PCNetConfig)
    loss: LossWeights = field(default_factory=LossWeights)


#: View distributions of :func:`pcnet.models.datasets.sample_views`.
VIEWS = ("paper", "wide", "paper+wide", "handheld+wide")
#: Noise models of :class:`TrainConfig` ``noise_model``.
NOISE_MODELS = ("frame", "lifter")
#: Devices a config may name (``cuda:<n>``: that GPU; ``auto``: cuda when present).
DEVICES = ("auto", "cpu", "cuda", "cuda:<n>")
#: Random seeds (numpy, torch; ``seed + epoch`` and ``10_000 + seed`` stay valid too).
SEED_RANGE = Range(0, 2**31 - 1)

#: Valid values of :class:`TrainConfig`'s numeric fields (every value also finite).
TRAIN_RANGES = {
    "epochs": Range(1, 10_000),
    "batch_size": Range(1, 1_048_576),
    "lr": Range(0, 1, low_inclusive=False),  # AdamW learning rate, (0, 1]
    "weight_decay": Range(0, 1),
    "frame_stride": Range(1, 10_000),
    "noise_fraction": Range(0, 1),  # a share of the poses
    "mirror_fraction": Range(0, 1),  # a share of the clips
    "lean_balance_cap": Range(0, 1000),  # 0 = off, else a weight cap >= 1
    "trunk_sagittal_sigma_deg": Range(0, 45),
    "trunk_lateral_sigma_deg": Range(0, 45),
    "head_sagittal_sigma_deg": Range(0, 45),
    "seed": SEED_RANGE,
    "threads": Range(0, 1024),  # 0 = torch default
    "val_frames": Range(1, 100_000_000),
}
#: :class:`PCNetConfig` (``[model]``): sizes and dropout; ``hidden`` must also be a
#: multiple of ``heads`` (checked by :class:`PCNetConfig`).
MODEL_RANGES = {
    "hidden": Range(1, 2048),
    "output": Range(1, 4096),
    "gcn_layers": Range(0, 32),
    "transformer_layers": Range(0, 32),
    "heads": Range(1, 64),
    "feedforward": Range(1, 8192),
    "dropout": Range(0, 1, high_inclusive=False),
}
#: :class:`LossWeights` (``[loss]``): every weight in [0, 100].
LOSS_RANGES = {f.name: Range(0, 100) for f in dataclasses.fields(LossWeights)}
#: Lists and paths: at least one data file, a non-empty out_dir.
TRAIN_LENGTHS = {"data": (1, 10_000), "out_dir": (1, 4096), "init_checkpoint": (1, 4096),
                 "data_repeats": (0, 10_000), "train_whole": (0, 10_000)}


def load_config(path: str | Path) -> TrainConfig:
    """Read a TOML file with top-level keys of :class:`TrainConfig` and optional ``[model]``
    and ``[loss]`` tables. Relative data paths are resolved against the current directory.

    Every value is checked here, before anything is created: types, then the ranges of
    :data:`TRAIN_RANGES`, :data:`MODEL_RANGES` and :data:`LOSS_RANGES` (all values finite),
    ``views`` in :data:`VIEWS`, ``device`` in :data:`DEVICES` and a non-empty ``data`` list.

    Raises:
        InputError: not TOML, an unknown key, a value of the wrong type or out of its
            range or choices, top-level or in ``[model]`` / ``[loss]`` (named with the
            file and the field).
    """
    path = Path(path)
    raw = read_toml(path)
    check_config_keys(path, "", raw, TrainConfig)
    check_ranges(path, "", raw, TRAIN_RANGES, TrainConfig)
    check_choices(path, "", raw, {"views": VIEWS, "device": DEVICES, "split_scheme": SPLIT_SCHEMES,
                                  "noise_model": NOISE_MODELS})
    check_lengths(path, "", raw, TRAIN_LENGTHS)
    repeats = raw.get("data_repeats", [])
    if repeats and (len(repeats) != len(raw.get("data", TrainConfig().data)) or min(repeats) < 1 or max(repeats) > 100):
        raise InputError(f"{path}: data_repeats: expected one integer in [1, 100] per data file, got {repeats!r}")
    whole = raw.get("train_whole", [])
    if whole and (len(whole) != len(raw.get("data", TrainConfig().data)) or not all(isinstance(w, bool) for w in whole)):
        raise InputError(f"{path}: train_whole: expected one true/false per data file, got {whole!r}")
    cap = raw.get("lean_balance_cap", 0)
    if 0 < cap < 1:
        raise InputError(f"{path}: field 'lean_balance_cap': expected 0 (off) or a weight cap >= 1, got {cap}")
    tables = {}
    for table, cls, bounds in (("model", PCNetConfig, MODEL_RANGES), ("loss", LossWeights, LOSS_RANGES)):
        given = raw.pop(table, {})
        if not isinstance(given, dict):
            raise InputError(f"{path}: {table} must be a [{table}] table, got {given!r}")
        check_config_keys(path, f"[{table}] has ", given, cls)
        check_ranges(path, f"[{table}] has ", given, bounds, cls)
        try:
            tables[table] = cls(**given)
        except InputError as err:  # PCNetConfig's own checks (hidden a multiple of heads)
            raise InputError(f"{path}: {err}") from err
    return TrainConfig(**raw, **tables)


def training_clips(loaded: list[list], repeats: list[int], train_whole: list[bool],
                   scheme: str) -> tuple[list, list]:
    """``(train, val)`` clips of a run: per data file (``loaded``, its clips), the ``train``
    split of ``scheme`` (:func:`pcnet.models.datasets.select_split`) ``repeats`` times and
    its ``val`` split, or, where ``train_whole`` is true, every clip ``repeats`` times and none
    for validation (``[]`` = false for every file).

    Raises:
        InputError: a clip the scheme cannot place (:func:`pcnet.models.datasets.select_split`).
    """
    whole = train_whole or [False] * len(loaded)
    train = [c for clips, k, w in zip(loaded, repeats, whole)
             for c in (clips if w else select_split(clips, "train", scheme)) * k]
    val = [c for clips, w in zip(loaded, whole) if not w for c in select_split(clips, "val", scheme)]
    return train, val


def _device(name: str) -> torch.device:
    """``auto`` = cuda when present.

    Raises:
        InputError: an unknown device name, or cuda asked for where there is none.
    """
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except RuntimeError as err:
        raise InputError(f"device {name!r}: not a torch device ({' '.join(str(err).split())})") from err
    if device.type == "cuda" and not torch.cuda.is_available():
        raise InputError(f"device {name!r}: CUDA is not available here (use device = \"auto\" or \"cpu\")")
    if device.type == "cuda" and device.index is not None and device.index >= torch.cuda.device_count():
        raise InputError(f"device {name!r}: no such GPU here ({torch.cuda.device_count()} visible)")
    return device


def _epoch_tensors(clips, cfg: TrainConfig, seed: int, views: str, noise: bool, augment: bool, **kw):
    fraction = kw.get("noise_fraction", 1.0)
    lifter = noise and cfg.noise_model == "lifter"
    pairs = make_pairs(
        clips, views=views, seed=seed,
        noise=(LifterNoise() if lifter else Noise(fraction=fraction)) if noise else None,
        augmentation=Augmentation(
            mirror_fraction=cfg.mirror_fraction, trunk_sagittal_sigma_deg=cfg.trunk_sagittal_sigma_deg,
            trunk_lateral_sigma_deg=cfg.trunk_lateral_sigma_deg, head_sagittal_sigma_deg=cfg.head_sagittal_sigma_deg,
        ) if augment else None,
        frame_stride=kw.get("frame_stride", cfg.frame_stride),
        max_frames=kw.get("max_frames"),
    )
    inputs = pairs.inputs
    if lifter and fraction < 1.0:  # LifterNoise draws whole clips; the clean share is put back per pose
        clean = np.random.default_rng(seed + 7919).random(len(inputs)) >= fraction
        inputs = inputs.copy()
        inputs[clean] = np.einsum("nij,nkj->nki", pairs.R[clean], pairs.canonical[clean])
    x, scale, valid = normalize_input(inputs)
    canon = pairs.canonical[valid] / scale[valid, None, None]
    return (
        torch.from_numpy(x[valid]),
        torch.from_numpy(pairs.R[valid].astype(np.float32)),
        torch.from_numpy(canon.astype(np.float32)),
    )


@torch.no_grad()
def validate(model: PCNet, x, R, device, batch: int = 4096) -> dict:
    """Mean validation errors in degrees, ``{"val_rotation_deg", "val_tilt_deg"}``, of
    ``model`` on ``x`` ``(N, 17, 3)`` normalised camera-frame poses (:mod:`.preprocess`)
    against ``R`` ``(N, 3, 3)`` true canonical->camera rotations (float tensors, CPU),
    run in batches of ``batch`` on ``device``."""
    model.eval()
    preds = [model(x[i : i + batch].to(device))[0].cpu() for i in range(0, len(x), batch)]
    R_hat = torch.cat(preds).double().numpy()
    Rt = R.double().numpy()
    return {
        "val_rotation_deg": summarize(rotation_error_deg(R_hat, Rt))["mean"],
        "val_tilt_deg": summarize(tilt_error_deg(R_hat, Rt))["mean"],
    }


def train(cfg: TrainConfig, resume: bool = True, progress: bool = True) -> Path:
    """Train 3DPCNet; returns the path of the best checkpoint (lowest validation rotation
    error). Writes ``last.pt`` (resumable), ``best.pt`` and ``metrics.jsonl`` to
    ``cfg.out_dir``; checkpoints hold tensors and plain types only
    (:mod:`pcnet.models.checkpoint`).

    Everything is read and checked (data, ``init_checkpoint``, ``last.pt`` when resuming)
    before ``cfg.out_dir`` is created, so a bad input leaves no run folder behind; a run that
    fails or is interrupted before its first epoch is saved removes the folder and the parents
    it created (a later failure keeps ``last.pt`` to resume from).

    Raises:
        InputError: empty training or validation split, an unknown device, or an
            ``init_checkpoint`` / ``last.pt`` that is not a 3DPCNet checkpoint of this
            architecture.
        FileNotFoundError, ValueError: a missing or unreadable data file.
    """
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    device = _device(cfg.device)
    out = Path(cfg.out_dir)
    check_run_folder(out)
    repeats = cfg.data_repeats or [1] * len(cfg.data)
    loaded = [load_mocap(path) for path in cfg.data]
    # What the files held, so that a resume over other data is refused and an evaluation can
    # tell a training file from another of its name (an ML trial's decoy read "trained on 12 of 14").
    data_sha256 = [sha256_file(path) for path in cfg.data]
    for path, clips in zip(cfg.data, loaded):
        if warning := world_up_warning(clips, path):
            tqdm.write(f"WARNING {warning}")
        if cfg.noise and cfg.noise_model == "lifter" and (warning := assumed_fps_warning(clips, path)):
            tqdm.write(f"WARNING {warning}")
    train_clips, val_clips = training_clips(loaded, repeats, cfg.train_whole, cfg.split_scheme)
    for split, chosen in (("train", train_clips), ("val", val_clips)):
        if not chosen:
            raise InputError(f"data {cfg.data}: no clips in the {split} split of scheme {cfg.split_scheme!r} "
                             f"(pcnet.models.datasets.select_split)")
    x_val, R_val, _ = _epoch_tensors(
        val_clips, cfg, seed=10_000 + cfg.seed, views=cfg.views, noise=cfg.noise, augment=False,
        frame_stride=1, max_frames=cfg.val_frames,
    )

    model = PCNet(cfg.model).to(device)
    if cfg.init_checkpoint:
        ck = load_checkpoint_dict(cfg.init_checkpoint, kind="pcnet", map_location=device)
        load_state(cfg.init_checkpoint, model, ck["model"], "model")
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    n_train = sum(len(c.joints[:: cfg.frame_stride]) for c in train_clips)
    steps_per_epoch = math.ceil(n_train / cfg.batch_size)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=cfg.epochs * steps_per_epoch)
    start, best = 0, float("inf")
    last = out / "last.pt"
    if resume and last.is_file():
        ck = load_checkpoint_dict(last, kind="pcnet", required=("model", "optimizer", "scheduler", "epoch", "best"),
                                  map_location=device)
        load_state(last, model, ck["model"], "model")
        load_state(last, opt, ck["optimizer"], "optimizer")
        load_state(last, sched, ck["scheduler"], "scheduler")
        _check_same_run(last, ck.get("config"), cfg)
        _check_same_data(last, ck.get("data_sha256"), cfg.data, data_sha256)
        start, best = resume_point(last, ck)
        if start >= cfg.epochs and progress:
            tqdm.write(f"{last}: all {cfg.epochs} epochs of this run already ran")
    created: list[Path] = []  # out and the parents this run made
    make_parents(out, created)
    try:
        if start == 0:  # a new run (--no-resume, or a folder without last.pt): not after an old run's epochs
            (out / "metrics.jsonl").unlink(missing_ok=True)
        # Clips trained on whole are named so that evaluation can say when a test set holds them
        # (a cross-dataset file whose subset was moved into training: pcnet.pipeline.evaluate).
        whole_clips = sorted({c.name for clips, w in zip(loaded, cfg.train_whole or []) if w for c in clips})
        record = {**asdict(cfg), "data_sha256": data_sha256, **({"whole_clips": whole_clips} if whole_clips else {})}
        write_text(out / "config.json", json.dumps(record, indent=2))

        for epoch in range(start, cfg.epochs):
            t0 = time.time()
            gen = torch.Generator().manual_seed(cfg.seed + epoch)
            balanced = cfg.lean_balance_cap > 0
            x, R, canon = _epoch_tensors(train_clips, cfg, cfg.seed + epoch, cfg.views, cfg.noise, cfg.augment,
                                      noise_fraction=cfg.noise_fraction, frame_stride=1 if balanced else cfg.frame_stride)
            if balanced:
                weights = torch.from_numpy(lean_balance_weights(trunk_lean_deg(canon.numpy()), cfg.lean_balance_cap))
                order = torch.multinomial(weights, min(n_train, len(x)), replacement=True, generator=gen)
            else:
                order = torch.randperm(len(x), generator=gen)
            model.train()
            running: dict[str, float] = {}
            bar = tqdm(range(0, len(order), cfg.batch_size), desc=f"epoch {epoch + 1}/{cfg.epochs}", disable=not progress)
            for n, i in enumerate(bar, 1):
                idx = order[i : i + cfg.batch_size]
                xb, Rb, cb = x[idx].to(device), R[idx].to(device), canon[idx].to(device)
                R_hat, delta, aux = model(xb, return_aux=True)
                loss, parts = composite_loss(model, xb, R_hat, delta, aux, Rb, cb, cfg.loss)
                opt.zero_grad(set_to_none=True)
                loss.backward()
                torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
                opt.step()
                sched.step()
                for k, v in parts.items():
                    running[k] = running.get(k, 0.0) + (float(v) - running.get(k, 0.0)) / n
                bar.set_postfix({k: f"{v:.4f}" for k, v in running.items() if k in ("total", "rot", "pose")})
            metrics = {k: float(v) for k, v in validate(model, x_val, R_val, device).items()}
            record = {"epoch": epoch + 1, "seconds": round(time.time() - t0, 1), "lr": float(sched.get_last_lr()[0]),
                      **{f"train_{k}": v for k, v in running.items()}, **metrics}
            with open(out / "metrics.jsonl", "a") as fh:
                fh.write(json.dumps(record) + "\n")
            if progress:
                tqdm.write(json.dumps(record))
            save_checkpoint({"kind": "pcnet", "model": model.state_dict(), "optimizer": opt.state_dict(),
                             "scheduler": sched.state_dict(), "epoch": epoch,
                             "best": min(best, metrics["val_rotation_deg"]), "model_config": cfg.model.to_dict(),
                             "config": asdict(cfg), "data_sha256": data_sha256}, last)
            if metrics["val_rotation_deg"] < best:
                best = metrics["val_rotation_deg"]
                save_checkpoint({"kind": "pcnet", "model": model.state_dict(), "model_config": cfg.model.to_dict(),
                                 "epoch": epoch + 1, "val": metrics}, out / "best.pt")
    except BaseException:
        # A new run folder without one finished epoch holds nothing to resume from: it goes,
        # with the parents made for it; a run with a last.pt keeps it (--no-resume starts over).
        if created and not last.is_file():
            for name in ("config.json", "metrics.jsonl"):
                (out / name).unlink(missing_ok=True)
            remove_created(created)
        raise
    return out / "best.pt"


#: Config fields a resumed run may change: where and how fast it runs, not what it learns.
RESUME_MAY_CHANGE = ("out_dir", "threads", "device")


def _check_same_run(last: Path, saved, cfg: TrainConfig) -> None:
    """Refuse to resume ``last`` (a ``last.pt``) under a config that differs from the one it
    was trained with (``saved``, its ``config`` entry; older checkpoints without one are not
    checked) in anything but :data:`RESUME_MAY_CHANGE`: the run's ``config.json`` and the
    exported weights' ``.json`` would describe neither run, and a longer ``epochs`` would
    restart the cosine learning-rate schedule's decay midway.

    Raises:
        InputError: naming ``last`` and the changed fields (old -> new).
    """
    if not isinstance(saved, dict):
        return
    now = json.loads(json.dumps(asdict(cfg), default=str))
    saved = json.loads(json.dumps(saved, default=str))
    changed = [k for k in sorted(set(now) | set(saved)) if k not in RESUME_MAY_CHANGE and now.get(k) != saved.get(k)]
    if changed:
        shown = "; ".join(f"{k} {saved.get(k)!r} -> {now.get(k)!r}" for k in changed[:4])
        more = f"; and {len(changed) - 4} more" if len(changed) > 4 else ""
        raise InputError(f"{last}: expected to resume the run of the same config, got changes ({shown}{more}); give "
                         f"a new out_dir (--out-dir), or --no-resume to train this config from the start")


def _check_same_data(last: Path, saved, data: list, now: list[str]) -> None:
    """Refuse to resume ``last`` over data files whose content differs from what its run began
    with (``saved``: its ``data_sha256``, the files' sha256 in ``data`` order; checkpoints from
    before pcnet recorded them are not checked): the weights would have learnt from two data
    sets and their record name one (an ML trial resumed over a rewritten file without a word).

    Raises:
        InputError: naming ``last`` and the first changed file.
    """
    if not isinstance(saved, list) or len(saved) != len(now):
        return
    for path, old, new in zip(data, saved, now):
        if old != new:
            raise InputError(f"{last}: expected to resume over the data its run began with, got {path} changed since "
                             f"(sha256 {new[:12]}..., not {old[:12]}...); give a new out_dir (--out-dir), or "
                             f"--no-resume to train on this data from the start")


def load_checkpoint(path: str | Path) -> PCNet:
    """A :class:`PCNet` in eval mode from a 3DPCNet ``best.pt`` / ``last.pt``, read with
    ``weights_only=True`` (no code in the file runs).

    Raises:
        InputError: ``<path>: not a pcnet checkpoint (<reason>)``: not a 3DPCNet checkpoint,
            or its weights do not fit its ``model_config``.
    """
    ck = load_checkpoint_dict(path, kind="pcnet")
    given = ck.get("model_config")
    if given is None:
        config = ck.get("config")
        given = config.get("model") if isinstance(config, dict) else None
    if given is None:
        raise not_a_checkpoint(path, "no 'model_config' entry")
    model = PCNet(config_from_dict(path, "model_config", given, PCNetConfig))
    load_state(path, model, ck["model"], "model")
    return model.eval()
