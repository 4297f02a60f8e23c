"""Export a trained 3DPCNet to ONNX with a dynamic batch axis (needs torch and onnx)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from pcnet.stages.core.atomic import atomic_path
from pcnet.stages.core.errors import InputError

from .network import PCNet

OPSET = 18


class _Exported(torch.nn.Module):
    """Inference graph: normalised poses ``x`` (B,17,3) -> ``rotation`` (B,3,3),
    ``residual`` (B,17,3) (normalised units)."""

    def __init__(self, model: PCNet):
        super().__init__()
        self.model = model

    def forward(self, x):
        return self.model(x)


def export_onnx(model: PCNet, path: str | Path, metadata: dict | None = None, replace: bool = True) -> Path:
    """Write ``model`` as ONNX (opset 18) to ``path`` atomically, plus ``<path>.json`` with
    the architecture and ``metadata``: both appear, or neither where the user did not ask to
    replace them (``replace`` false: a file that appeared there meanwhile, another run's, is
    kept and the call refused, :func:`pcnet.stages.core.atomic.atomic_path`). The batch axis is dynamic; the graph is traced with
    a batch of 4 because exporters specialise example dimensions of size 0 or 1
    (pytorch/pytorch issues #144242 and #157621), and the fused MHA fast path (no ONNX
    symbolic for ``aten::_transformer_encoder_layer_fwd`` /
    ``aten::_native_multi_head_attention``: pytorch/pytorch issues #94434 and #143107) is
    disabled while tracing with ``torch.backends.mha.set_fastpath_enabled`` (PyTorch docs,
    ``torch.backends.mha``).
    """
    path = Path(path)
    if path.suffix.lower() == ".json":
        raise InputError(f"--out {path}: expected an ONNX file name (.onnx), got .json: the model's description is "
                         f"written beside it as <name>.json")
    model = model.eval()
    x = torch.randn(4, 17, 3)
    fast = torch.backends.mha.get_fastpath_enabled()
    torch.backends.mha.set_fastpath_enabled(False)
    info = {"model_config": model.cfg.to_dict(), "opset": OPSET, **(metadata or {})}
    published = False
    try:
        # The description is published last: an .onnx without it is not recognisably pcnet's.
        with atomic_path(path.with_suffix(".json"), replace=replace) as tmp_json:
            with atomic_path(path, replace=replace) as tmp, torch.no_grad():
                torch.onnx.export(
                    _Exported(model), (x,), str(tmp), input_names=["x"], output_names=["rotation", "residual"],
                    dynamic_axes={"x": {0: "batch"}, "rotation": {0: "batch"}, "residual": {0: "batch"}},
                    opset_version=OPSET, dynamo=False,
                )
            published = True
            tmp_json.write_text(json.dumps(info, indent=2))
    except BaseException:
        if published and not replace:  # this call made that file new: take it back with its description
            path.unlink(missing_ok=True)
        raise
    finally:
        torch.backends.mha.set_fastpath_enabled(fast)
    return path


def export_checkpoint(checkpoint: str | Path, path: str | Path, replace: bool = True) -> Path:
    """Export a 3DPCNet checkpoint (``best.pt``) to ONNX at ``path``, plus ``<path>.json``
    naming the checkpoint. The checkpoint is read with ``weights_only=True`` and fully
    checked before anything is written; ``replace`` as in :func:`export_onnx`.

    Returns:
        ``path``.

    Raises:
        InputError: ``<checkpoint>: not a pcnet checkpoint (<reason>)`` (a pickle with
            Python objects, random bytes, a missing file, missing entries, weights that do
            not fit their config).
        FileNotFoundError: the folder of ``path`` does not exist.
    """
    from .train import load_checkpoint

    model = load_checkpoint(checkpoint)
    return export_onnx(model, path, {"checkpoint": str(checkpoint), **training_record(checkpoint)}, replace)


#: Fields of a run's ``config.json`` not copied beside exported weights: where and on what
#: device it ran (not what shaped the weights), the architecture (``model_config`` holds it) and
#: the run it started from (its own record follows). Every other field is: the data, the
#: noise and augmentation, the optimiser and the loss (a review found the learning rate and
#: the posture augmentation's sigmas missing).
NOT_TRAINING_FIELDS = ("out_dir", "threads", "device", "model", "init_checkpoint")


#: Fine-tuning runs followed back through their ``init_checkpoint`` at most (a longer chain is cut).
MAX_FINE_TUNING_CHAIN = 8


def training_record(checkpoint: str | Path, _depth: int = 0) -> dict:
    """``{"training_config": {...}}`` from the ``config.json`` that ``pcnet train`` wrote beside
    ``checkpoint`` (every field but :data:`NOT_TRAINING_FIELDS`), or ``{}`` when there is none
    or it is not a JSON object: evaluation reads it to say how much
    of a dataset the weights trained on, and it repeats the training. A run
    fine-tuned from another checkpoint also records it (``init_checkpoint``) and that run's own
    record (``init_training_config``, ``{}`` where its folder has none), followed back up to
    :data:`MAX_FINE_TUNING_CHAIN` runs: the earlier runs' data trained the weights too (a user
    trial's export kept only the last epoch's run)."""
    try:
        config = json.loads((Path(checkpoint).parent / "config.json").read_text())
    except (OSError, ValueError, RecursionError):  # RecursionError: nested too deeply
        return {}
    if not isinstance(config, dict):
        return {}
    record = {k: v for k, v in config.items() if k not in NOT_TRAINING_FIELDS}
    init = config.get("init_checkpoint")
    if isinstance(init, str) and init:
        record["init_checkpoint"] = init
        if _depth < MAX_FINE_TUNING_CHAIN:
            record["init_training_config"] = training_record(init, _depth + 1).get("training_config", {})
    return {"training_config": record}


def max_difference(model: PCNet, path: str | Path, x: np.ndarray) -> float:
    """Largest absolute difference on ``rotation`` between torch and onnxruntime for the
    normalised inputs ``x`` ``(N, 17, 3)``."""
    from .inference import import_onnxruntime

    sess = import_onnxruntime().InferenceSession(str(path), providers=["CPUExecutionProvider"])
    with torch.no_grad():
        R_torch = model.eval()(torch.from_numpy(x.astype(np.float32)))[0].numpy()
    R_ort = sess.run(["rotation"], {"x": x.astype(np.float32)})[0]
    return float(np.abs(R_torch - R_ort).max())
