"""Run-time inference with onnxruntime (no torch): 3DPCNet and the up refiners (frame and
static-camera)."""

from __future__ import annotations

import hashlib
import json
import re
from functools import lru_cache
from pathlib import Path

import numpy as np

from pcnet.stages.errors import InputError
from pcnet.stages.rotations import angle_between

from .preprocess import normalize_input, refiner_features, refiner_up_xz, window_indices

WEIGHTS_DIR = Path(__file__).parent / "weights"
DEFAULT_WEIGHTS = WEIGHTS_DIR / "pcnet_small.onnx"
DEFAULT_UP_REFINER = WEIGHTS_DIR / "up_refiner.onnx"
DEFAULT_FRAME_REFINER = WEIGHTS_DIR / "frame_up_refiner.onnx"


class PCNetSession:
    """An onnxruntime session of an exported 3DPCNet.

    ``predict(joints_cam)`` takes H36M-17 camera-frame poses ``(N, 17, 3)`` in any units and
    returns ``R`` ``(N, 3, 3)`` float64 canonical->camera, ``residual`` ``(N, 17, 3)`` in
    the input's units (the paper's Delta, canonical frame) and ``valid`` ``(N,)``; invalid
    frames (missing hips, thorax or shoulders; zero-size pose) are NaN.

    Raises:
        InputError: ``<path>: no such file``, ``<path>: not an ONNX model (<reason>)``, or an
            ONNX model without 3DPCNet's input ``x`` (B, 17, 3) and outputs ``rotation``,
            ``residual``.
    """

    def __init__(self, weights: str | Path | None = None, threads: int = 0):
        self.path, self.session, self.info = _open(weights, DEFAULT_WEIGHTS, threads)
        _check_signature(self.path, self.session, "3DPCNet", {"x": [17, 3]}, {"rotation": [3, 3], "residual": [17, 3]})

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


def _open(weights, default: Path, threads: int):
    """(path, onnxruntime session, the ``.json`` beside the weights or {}).

    Raises:
        InputError: the file is missing, not an ONNX model onnxruntime can run, or its
            ``.json`` is not a JSON object.
    """
    import onnxruntime as ort

    path = Path(weights) if weights else default
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    opts = ort.SessionOptions()
    if threads:
        opts.intra_op_num_threads = threads
    try:
        session = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
    except Exception as err:  # onnxruntime's InvalidProtobuf, Fail, InvalidGraph, ... share no base class
        raise InputError(f"{path}: not an ONNX model ({_ort_reason(err)})") from err
    meta = path.with_suffix(".json")
    info = {}
    if meta.is_file():
        try:
            info = json.loads(meta.read_text())
        except (OSError, UnicodeDecodeError, ValueError) as err:
            raise InputError(f"{meta}: not readable JSON beside the weights ({err})") from err
        if not isinstance(info, dict):
            raise InputError(f"{meta}: expected a JSON object beside the weights, got {type(info).__name__}")
    return path, session, info


def _ort_reason(err: Exception) -> str:
    """onnxruntime's message without its ``[ONNXRuntimeError] : 7 : ... failed:`` prefix."""
    text = " ".join(str(err).split())
    found = re.search(r"failed:\s*(.+)", text)
    text = found.group(1) if found else text
    return text if len(text) <= 200 else text[:197] + "..."


def _check_signature(path: Path, session, what: str, inputs: dict[str, list], outputs: dict[str, list]) -> None:
    """Raise :class:`InputError` unless the model has exactly the named ``inputs`` and at
    least the named ``outputs``, each with a leading batch axis and then the given sizes."""
    found_in = {i.name: i.shape for i in session.get_inputs()}
    found_out = {o.name: o.shape for o in session.get_outputs()}
    expected = "inputs " + ", ".join(f"{k} (batch, {', '.join(map(str, v))})" for k, v in inputs.items())
    expected += "; outputs " + ", ".join(f"{k} (batch, {', '.join(map(str, v))})" for k, v in outputs.items())
    got = (f"inputs {', '.join(f'{k} {v}' for k, v in found_in.items())}; "
           f"outputs {', '.join(f'{k} {v}' for k, v in found_out.items())}")
    ok = set(found_in) == set(inputs) and set(outputs) <= set(found_out)
    for name, dims in (*inputs.items(), *outputs.items()):
        shape = found_in.get(name) or found_out.get(name)
        # a dimension given by name (a symbolic axis) cannot be checked here
        if ok and (len(shape) != 1 + len(dims) or any(isinstance(a, int) and a != b for a, b in zip(shape[1:], dims))):
            ok = False
    if not ok:
        raise InputError(f"{path}: not {what} weights: expected {expected}, got {got}")


class UpRefinerSession:
    """An onnxruntime session of an up refiner (:mod:`pcnet.models.up_refiner`): the frame
    up refiner (a one-frame window) or the static-camera one.

    ``refine(joints_cam, R, valid, fps)`` corrects each frame's up direction from the poses
    in its window (``offsets_s`` in the weights' ``.json``: ``[0]`` for the frame refiner,
    about +-0.5 s for the static-camera one, which assumes a camera that does not move over
    the window): the network reads the window in the frame's predicted canonical frame and
    returns the true up expressed there, ``(u_x, u_z)`` (``u_y`` follows from unit length),
    or (``input_frame = "body"`` in the ``.json``, the frame refiner) reads the pose in a
    frame fixed to the body and returns the true up in that frame
    (:func:`pcnet.models.preprocess.refiner_features`). The corrected rotation is the
    predicted one turned by the smallest rotation taking its up to the corrected up, so the
    heading is kept.
    Trained on the errors of one 3DPCNet (``base_weights`` in the ``.json``); other
    weights need their own refiner.

    Raises:
        InputError: ``<path>: no such file``, ``<path>: not an ONNX model (<reason>)``, its
            ``.json`` lacks ``offsets_s`` (the window, seconds), or the model's input
            ``features`` / output do not fit that window and ``input_frame``.
    """

    def __init__(self, weights: str | Path | None = None, threads: int = 0, default: Path = DEFAULT_UP_REFINER):
        self.path, self.session, self.info = _open(weights, default, threads)
        meta = self.path.with_suffix(".json")
        try:
            self.offsets_s = np.asarray(self.info.get("offsets_s", []), np.float64).reshape(-1)
            self.max_median_correction_deg = float(self.info.get("max_median_correction_deg", np.inf))
        except (TypeError, ValueError) as err:
            raise InputError(f"{meta}: field 'offsets_s' / 'max_median_correction_deg': expected numbers ({err})") from err
        if self.offsets_s.size == 0:
            raise InputError(f"{meta}: field 'offsets_s' (window offsets in seconds) missing")
        self.input_frame = self.info.get("input_frame", "predicted")
        n_out = 2 if self.input_frame == "predicted" else 3
        outputs = [o.name for o in self.session.get_outputs()]
        if len(outputs) != 1:
            raise InputError(f"{self.path}: not up-refiner weights: expected one output, got {outputs}")
        _check_signature(self.path, self.session, "up-refiner", {"features": [self.offsets_s.size * 51]},
                         {outputs[0]: [n_out]})

    def refine(self, joints_cam: np.ndarray, R: np.ndarray, valid: np.ndarray, fps: float,
               batch_size: int = 4096) -> tuple[np.ndarray, dict]:
        """Refined canonical->camera rotations, or ``R`` unchanged for a motion unlike the
        training data.

        Domain check: if the median correction over the sequence's valid frames exceeds
        ``max_median_correction_deg`` (the ``.json``; the largest per-clip median the
        refiner made on the held-out val split, set by training), the motion is outside
        what it learnt (on DeepMimic: crawling, rolling, getting up, kicks) and its
        corrections are not trusted; ``R`` is returned as given.

        Args:
            joints_cam: ``(T, 17, 3)`` H36M-17 camera-frame poses of ONE static-camera
                recording, any units.
            R: ``(T, 3, 3)`` per-frame canonical->camera predictions of the base network.
            valid: ``(T,)`` bool; invalid frames (or NaN ``R``) stay as given.
            fps: frame rate in Hz (the window is defined in seconds).

        Returns:
            ``(R (T, 3, 3) float64, info)``, ``info`` = ``{"applied": bool,
            "median_correction_deg": float, "max_median_correction_deg": float}``.
        """
        R = np.asarray(R, np.float64)
        x, _, ok = normalize_input(joints_cam)
        ok &= np.asarray(valid, bool) & np.isfinite(R).all((1, 2))
        out = R.copy()
        idx = window_indices(ok, fps, self.offsets_s)
        centres = np.flatnonzero(ok)
        for i in range(0, len(centres), batch_size):
            c = centres[i : i + batch_size]
            feats = refiner_features(self.input_frame, x, R[c], idx[c])
            (raw,) = self.session.run(None, {"features": feats})
            out[c] = tilt_to_up(R[c], refiner_up_xz(self.input_frame, x[c], R[c], raw))
        moved = angle_between(out[centres, :, 1], R[centres, :, 1])
        median = float(np.degrees(np.median(moved))) if len(centres) else 0.0
        applied = median <= self.max_median_correction_deg
        info = {"applied": bool(applied), "median_correction_deg": median,
                "max_median_correction_deg": self.max_median_correction_deg}
        return (out if applied else R.copy()), info


def tilt_to_up(R: np.ndarray, up_xz: np.ndarray) -> np.ndarray:
    """Turn each rotation by the smallest rotation that takes its up column ``R[:, :, 1]``
    to ``R @ (u_x, u_y, u_z)``, with ``u_y = sqrt(1 - u_x^2 - u_z^2)`` (clamped to tilts of
    at most 60 deg). ``R`` ``(N, 3, 3)`` canonical->camera, ``up_xz`` ``(N, 2)``: the
    target up in the rotation's own canonical frame. Returns ``(N, 3, 3)`` float64."""
    from scipy.spatial.transform import Rotation

    a, b = up_xz[:, 0], up_xz[:, 1]
    u = np.stack([a, np.sqrt(np.clip(1.0 - a * a - b * b, 0.25, 1.0)), b], -1)
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    # In the canonical frame the smallest rotation from +Y to u has axis Y x u.
    axis = np.stack([u[:, 2], np.zeros(len(u)), -u[:, 0]], -1)
    sin = np.linalg.norm(axis, axis=-1)
    rotvec = axis / np.maximum(sin, 1e-12)[:, None] * np.arctan2(sin, u[:, 1])[:, None]
    # R @ Q with Q acting in the canonical frame equals (R Q R^T) R: the same turn seen in the camera frame.
    return np.einsum("nij,njk->nik", R, Rotation.from_rotvec(rotvec).as_matrix())


@lru_cache(maxsize=8)
def file_sha256(path: str) -> str:
    """Hex SHA-256 of a file's bytes (cached per path)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@lru_cache(maxsize=4)
def shipped_frame_refiner(weights: str | None = None):
    """The shipped frame up refiner's :meth:`UpRefinerSession.refine` when ``weights``
    (``None`` = the shipped 3DPCNet) is the network it was trained on (same SHA-256 as its
    ``base_weights_sha256``), else ``None``: a refiner learns one network's errors."""
    refiner = UpRefinerSession(default=DEFAULT_FRAME_REFINER)
    return refiner.refine if _trained_on(refiner, weights) else None


@lru_cache(maxsize=4)
def shipped_up_refiner(weights: str | None = None):
    """The shipped static-camera up refiner's :meth:`UpRefinerSession.refine` when
    ``weights`` (``None`` = the shipped 3DPCNet) is the network it was trained on, else
    ``None``."""
    refiner = UpRefinerSession()
    return refiner.refine if _trained_on(refiner, weights) else None


def _trained_on(refiner: UpRefinerSession, weights: str | None) -> bool:
    base = Path(weights) if weights else DEFAULT_WEIGHTS
    return file_sha256(str(base)) == refiner.info.get("base_weights_sha256")
