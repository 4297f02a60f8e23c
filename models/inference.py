"""Run-time 3DPCNet inference with onnxruntime (no torch)."""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from .preprocess import normalize_input

WEIGHTS_DIR = Path(__file__).parent / "weights"
DEFAULT_WEIGHTS = WEIGHTS_DIR / "pcnet_small.onnx"


class PCNetSession:
    """An onnxruntime session of an exported 3DPCNet.

    ``predict(joints_cam)`` takes H36M-17 camera-frame poses ``(N, 17, 3)`` in any units and
    returns ``R`` ``(N, 3, 3)`` float64 canonical->camera, ``residual`` ``(N, 17, 3)`` in
    the input's units (the paper's Delta, canonical frame) and ``valid`` ``(N,)``; invalid
    frames (missing hips, thorax or shoulders; zero-size pose) are NaN.

    Raises:
        FileNotFoundError: the weights file does not exist.
    """

    def __init__(self, weights: str | Path | None = None, threads: int = 0):
        import onnxruntime as ort

        self.path = Path(weights) if weights else DEFAULT_WEIGHTS
        if not self.path.is_file():
            raise FileNotFoundError(f"{self.path}: 3DPCNet ONNX weights not found")
        opts = ort.SessionOptions()
        if threads:
            opts.intra_op_num_threads = threads
        self.session = ort.InferenceSession(str(self.path), opts, providers=["CPUExecutionProvider"])
        meta = self.path.with_suffix(".json")
        self.info = json.loads(meta.read_text()) if meta.is_file() else {}

    def predict(self, joints_cam: np.ndarray, batch_size: int = 4096) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x, scale, valid = normalize_input(joints_cam)
        n = len(x)
        R = np.full((n, 3, 3), np.nan)
        residual = np.full((n, 17, 3), np.nan)
        idx = np.flatnonzero(valid)
        for i in range(0, len(idx), batch_size):
            sel = idx[i : i + batch_size]
            r, d = self.session.run(["rotation", "residual"], {"x": x[sel]})
            R[sel] = r
            residual[sel] = d * scale[sel, None, None]
        return R, residual, valid


@lru_cache(maxsize=4)
def get_session(weights: str | None = None) -> PCNetSession:
    """A cached :class:`PCNetSession` (``None`` = the shipped weights)."""
    return PCNetSession(weights)
