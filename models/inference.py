"""Run-time inference with onnxruntime (no torch): 3DPCNet, and the shipped ensemble of two of them
gated by camera orientation (:mod:`pcnet.models.view_gate`)."""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import check_poses
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.framestore import frame_blocks, in_memory
from pcnet.stages.core.rotations import angle_between, with_up

from .preprocess import normalize_input
from .view_gate import blend_rotations, camera_frame_weight, frame_quarter_turns, quarter_turn_matrices, quarter_turns

WEIGHTS_DIR = Path(__file__).parent / "weights"
#: The shipped camera-frame 3DPCNet (configs/pcnet_camera_floor4.toml) and body-frame 3DPCNet
#: (configs/pcnet_body_posture.toml); without ``weights`` pcnet runs both (:class:`ViewGatedPCNet`).
CAMERA_WEIGHTS = WEIGHTS_DIR / "pcnet_camera.onnx"
BODY_WEIGHTS = WEIGHTS_DIR / "pcnet_body.onnx"
DEFAULT_WEIGHTS = CAMERA_WEIGHTS


#: Frames normalised (and blended) per block: each frame's arithmetic is its own, so the
#: result equals the one-piece computation while a long recording's float64 temporaries stay
#: a block long.
CHUNK_FRAMES = 8192


def normalized_in_chunks(joints_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`pcnet.models.preprocess.normalize_input` of ``(N, 17, 3)`` poses, computed
    :data:`CHUNK_FRAMES` frames at a time into whole ``x`` ``(N, 17, 3)`` float32, ``scale``
    ``(N,)`` float64 and ``valid`` ``(N,)`` bool (the same values as one call)."""
    joints_cam = check_poses(joints_cam, "joints_cam")
    n = len(joints_cam)
    x, scale, valid = np.zeros((n, 17, 3), np.float32), np.zeros(n), np.zeros(n, bool)
    for lo in range(0, n, CHUNK_FRAMES):
        rows = slice(lo, lo + CHUNK_FRAMES)
        x[rows], scale[rows], valid[rows] = normalize_input(joints_cam[rows])
    return x, scale, valid


#: |det R - 1| above which a network's rotation output is not a rotation (float32 output
#: of a proper rotation is within 1e-5).
ROTATION_DET_TOLERANCE = 1e-3


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

    def predict(self, joints_cam: np.ndarray, batch_size: int = 256,
                residual: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(R, residual, valid)`` of ``joints_cam`` (in memory or a
        :class:`~pcnet.stages.core.framestore.FrameArray`), :data:`CHUNK_FRAMES` frames at a
        time; the residual goes into ``residual`` when given (any ``(N, 17, 3)`` array taking
        slice assignment, e.g. a FrameArray: a long recording's residual stays on disk)."""
        n = len(check_poses(joints_cam, "joints_cam"))
        R, valid = np.full((n, 3, 3), np.nan), np.zeros(n, bool)
        residual = in_memory("residual", (n, 17, 3), np.float64) if residual is None else residual
        for rows in frame_blocks(n, CHUNK_FRAMES):
            R[rows], residual[rows], valid[rows] = self.predict_normalized(
                *normalize_input(check_poses(joints_cam[rows], "joints_cam")), batch_size=batch_size)
        return R, residual, valid

    def predict_normalized(self, x: np.ndarray, scale: np.ndarray, valid: np.ndarray,
                           batch_size: int = 256) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`predict` from :func:`normalized_in_chunks`'s ``(x, scale, valid)``, so that
        several networks can share one normalisation of a recording.

        Args:
            x: ``(N, 17, 3)`` float32 normalised camera-frame poses (:mod:`.preprocess`).
            scale: ``(N,)`` the normalisation's scale per pose (input units).
            valid: ``(N,)`` bool; other poses are not run.
            batch_size: poses per onnxruntime call.

        Returns:
            ``(R, residual, valid)``: ``(N, 3, 3)`` float64 canonical->camera rotations and
            ``(N, 17, 3)`` float64 residuals in the input's units, NaN where not valid;
            ``valid`` is also False where the network's output is not a rotation.
        """
        # onnxruntime's arena keeps the largest batch's activations for the session's life:
        # peak RSS 1,060 MB at 4,096 poses, 181 MB at 256, which is faster on 2 cores
        # (9,859 vs 6,798 poses/s, `python -m benchmarks.ort_batch_memory`).
        n = len(x)
        R = np.full((n, 3, 3), np.nan)
        residual = np.full((n, 17, 3), np.nan)
        idx = np.flatnonzero(valid)
        for i in range(0, len(idx), batch_size):
            sel = idx[i : i + batch_size]
            r, d = self.session.run(["rotation", "residual"], {"x": x[sel]})
            R[sel] = r
            residual[sel] = d * scale[sel, None, None]
        # A degenerate 6D output (first two columns parallel or zero) leaves the exported
        # Gram-Schmidt finite but singular: such a frame has no rotation, so it is invalid.
        proper = np.abs(np.linalg.det(R[idx]) - 1.0) < ROTATION_DET_TOLERANCE
        if not proper.all():
            bad = idx[~proper]
            valid = valid.copy()
            valid[bad], R[bad], residual[bad] = False, np.nan, np.nan
        return R, residual, valid


@dataclass(frozen=True)
class StaticCameraUps:
    """Each network's own up per frame for a static camera: the evidence of
    :mod:`pcnet.stages.up_model`.

    camera: ``(N, 3)`` float64 the camera-frame 3DPCNet's up on each frame turned back by that
    frame's own quarter turn (:func:`pcnet.models.view_gate.frame_quarter_turns`, decision
    0074), turned forward again; body: ``(N, 3)`` float64 the body-frame 3DPCNet's up; both in
    the camera frame (OpenCV axes), NaN where that network gave none. turns: ``(N,)`` int64
    those quarter turns ``k`` (0, 1 or 3)."""

    camera: np.ndarray
    body: np.ndarray
    turns: np.ndarray


class ViewGatedPCNet:
    """The shipped ensemble: the camera-frame and the body-frame 3DPCNet, blended per frame by
    :func:`pcnet.models.view_gate.camera_frame_weight` (camera-frame inside its training
    views, body-frame beyond them), in the camera frame turned back by the quarter turns the
    body-frame network reads (:func:`pcnet.models.view_gate.quarter_turns`: a portrait camera
    is a level one for the camera-frame network). The blend sets the answer's up; its heading
    (the turn about that up) is the body-frame network's on every frame, its rotation turned by
    the shortest arc onto the blend's up (:func:`pcnet.stages.core.rotations.with_up`): that
    network's input frame is built from the hip line, and its heading is the more accurate on
    held-out mocap (docs/experiments.md, "The body-frame network's heading"; release 5.2).

    ``predict(joints_cam, fps)`` as :meth:`PCNetSession.predict` (one recording per call:
    the gate's running median runs over the frames in order); ``predict_gated`` also returns
    the camera-frame weight ``(N,)`` (NaN where not valid) and the angle between the two
    networks' up directions ``(N,)`` in degrees (NaN where not valid), a per-frame sign of poses
    unlike the training data (:func:`pcnet.stages.uncertainty.frame_tilt_bound`). ``info`` is the camera-frame
    weights' ``.json`` (both were trained on the same split).
    """

    def __init__(self, threads: int = 0):
        self.camera = PCNetSession(CAMERA_WEIGHTS, threads)
        self.body = PCNetSession(BODY_WEIGHTS, threads)
        self.path, self.info = self.camera.path, self.camera.info

    def predict_gated(self, joints_cam: np.ndarray, fps: float = 30.0, allocate=None):
        """``(R, residual, valid, camera-frame weight, disagreement in deg, quarter turns, ups)``
        (``ups``: :class:`StaticCameraUps`, the evidence of :mod:`pcnet.stages.up_model`: the
        camera-frame network on each frame's own quarter turn, run again on any frame whose
        running-window turn differs);
        ``joints_cam`` in memory or on disk, read :data:`CHUNK_FRAMES` frames at a time.
        ``allocate(name, shape, dtype)`` makes the two ``(N, 17, 3)`` float64 residual arrays
        (NaN-filled; default in memory; the pipeline's are on disk, so only the ``(N, 3, 3)``
        rotations and per-frame values of a long recording are in memory). Quarter turns
        ``(N,)`` int (0, 1 or 3, :func:`pcnet.models.view_gate.quarter_turns`): the camera-frame
        network reads the poses turned back by that many quarter turns about the optical axis,
        the gate reads both networks in that frame, and the answer is turned forward again."""
        n = len(check_poses(joints_cam, "joints_cam"))
        res_cam, res_body = ((allocate or in_memory)(name, (n, 17, 3), np.float64)
                             for name in ("residual", "residual_body"))
        R_cam, R_body, valid = np.full((n, 3, 3), np.nan), np.full((n, 3, 3), np.nan), np.zeros(n, bool)
        blocks = list(frame_blocks(n, CHUNK_FRAMES))
        for rows in blocks:
            normalized = normalize_input(check_poses(joints_cam[rows], "joints_cam"))
            R_body[rows], res_body[rows], valid[rows] = self.body.predict_normalized(*normalized)
        turns = quarter_turns(R_body, valid, fps)
        # Only a recording with turned frames pays for the turns (Q is exactly I elsewhere).
        Q = quarter_turn_matrices(turns) if turns.any() else None
        for rows in blocks:
            if len(blocks) > 1:  # a short recording's one block is normalised once for both networks
                normalized = normalize_input(check_poses(joints_cam[rows], "joints_cam"))
            x, scale, ok = normalized
            if Q is not None:  # normalisation is rotation-invariant, so the normalised poses are turned
                x = (x @ np.swapaxes(Q[rows], 1, 2)).astype(np.float32)
            R_cam[rows], res_cam[rows], camera_ok = self.camera.predict_normalized(x, scale, ok)
            valid[rows] &= camera_ok
            if Q is not None:
                R_cam[rows] = np.swapaxes(Q[rows], 1, 2) @ R_cam[rows]
        weight = (camera_frame_weight(R_body, valid, fps, R_cam) if Q is None
                  else camera_frame_weight(Q @ R_body, valid, fps, Q @ R_cam))
        disagreement = np.degrees(angle_between(R_cam[:, :, 1], R_body[:, :, 1]))
        ups = self._static_camera_ups(joints_cam, blocks, R_cam, R_body, valid, turns)  # before the blend
        # Blended a block at a time into the camera-frame network's arrays (no third copy); the
        # geodesic blend commutes with the turn, so it runs in the camera's own frame.
        for rows in blocks:
            w = weight[rows, None, None]
            res_cam[rows] = w * res_cam[rows] + (1 - w) * res_body[rows]
            # The gate chooses the up; the heading is the body-frame network's, whose input
            # frame is built from the hip line (docs/experiments.md, "The body-frame network's
            # heading on the ensemble's up").
            R_cam[rows] = with_up(R_body[rows], blend_rotations(R_body[rows], R_cam[rows], weight[rows])[:, :, 1])
        return R_cam, res_cam, valid, weight, disagreement, turns, ups

    def predict(self, joints_cam: np.ndarray, fps: float = 30.0):
        return self.predict_gated(joints_cam, fps)[:3]

    def _static_camera_ups(self, joints_cam, blocks, R_cam, R_body, valid, turns) -> StaticCameraUps:
        """:class:`StaticCameraUps` from the per-frame pass: the camera-frame network's ups where
        its running-window turn is the frame's own, and a new pass on the other frames."""
        own = frame_quarter_turns(R_body, valid)
        camera = R_cam[:, :, 1].copy()
        changed = valid & (turns != own)
        for rows in blocks:
            idx = np.flatnonzero(changed[rows])
            if not len(idx):
                continue
            Qt = np.swapaxes(quarter_turn_matrices(own[rows.start + idx]), 1, 2)
            # normalisation is per pose: only the frames read again are normalised
            x, scale, ok = normalize_input(np.asarray(joints_cam[rows])[idx])
            R, _, ok = self.camera.predict_normalized((x @ Qt).astype(np.float32), scale, ok)
            camera[rows.start + idx] = np.where(ok[:, None], (Qt @ R)[:, :, 1], np.nan)
        return StaticCameraUps(camera, R_body[:, :, 1].copy(), own)


def get_session(weights: str | None = None) -> PCNetSession | ViewGatedPCNet:
    """A cached :class:`PCNetSession` of ``weights``, or for ``None`` the shipped
    :class:`ViewGatedPCNet`; opened again where the file changed since (its size or
    modification time: a developer trial's retrained weights, saved over the old file, kept
    answering as the old ones in the same process)."""
    if weights is None:
        return _cached_session(None, None)
    try:
        st = os.stat(weights)
        stamp = (st.st_mtime_ns, st.st_size)
    except OSError:
        stamp = None  # opening it says what is wrong
    return _cached_session(str(weights), stamp)


@lru_cache(maxsize=4)
def _cached_session(weights: str | None, stamp: tuple[int, int] | None) -> PCNetSession | ViewGatedPCNet:
    return ViewGatedPCNet() if weights is None else PCNetSession(weights)


def training_config(weights: str | None = None) -> dict:
    """What ``weights`` (``None``: the shipped pair) trained on: the ``training_config`` of the
    ``.json`` beside them that their cached session read (``pcnet export`` writes it), or ``{}``
    where there is none."""
    record = get_session(None if weights is None else str(weights)).info.get("training_config", {})
    return record if isinstance(record, dict) else {}


def import_onnxruntime():
    """onnxruntime, with its telemetry off unless the user's environment says otherwise:
    onnxruntime 1.32 writes a device id and an event queue for upload to Microsoft under
    ``~/.cache/Microsoft/DeveloperTools/.onnxruntime`` at its first session (its
    docs/Privacy.md); ``ORT_DISABLE_TELEMETRY=1`` (set here where unset; read when its
    environment is created) writes and sends nothing. A pipeline stage should not (a developer
    trial found the files)."""
    os.environ.setdefault("ORT_DISABLE_TELEMETRY", "1")
    import onnxruntime

    return onnxruntime


def _open(weights, default: Path, threads: int):
    """(path, onnxruntime session, the ``.json`` beside the weights or {}).

    Raises:
        InputError: the file is missing, not an ONNX model onnxruntime can run, or its
            ``.json`` is not a JSON object.
    """
    ort = import_onnxruntime()
    path = Path(weights) if weights else default
    if not path.is_file():
        raise InputError(f"{path}: expected an ONNX weights file, got {'a folder' if path.is_dir() else 'no such file'}")
    opts = ort.SessionOptions()
    # `pcnet batch` gives each worker its share of the cores (pipeline/batch_worker.py).
    threads = threads or int(os.environ.get("PCNET_ORT_THREADS") or 0)
    if threads:
        opts.intra_op_num_threads = threads
    try:
        session = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
    except Exception as err:  # onnxruntime's InvalidProtobuf, Fail, InvalidGraph, ... share no base class
        out = path.with_suffix(".onnx") if path.suffix != ".onnx" else path.with_name(f"{path.stem}_exported.onnx")
        hint = (f"; a training checkpoint? export it first: pcnet export --checkpoint {path} --out {out}"
                if _is_zip(path) else "")
        raise InputError(f"{path}: not an ONNX model ({_ort_reason(err)}){hint}") from err
    meta = path.with_suffix(".json")
    info = {}
    if meta.is_file():
        try:
            info = json.loads(meta.read_text())
        except (OSError, UnicodeDecodeError, ValueError, RecursionError) as err:  # RecursionError: nested too deeply
            raise InputError(f"{meta}: not readable JSON beside the weights ({err})") from err
        if not isinstance(info, dict):
            raise InputError(f"{meta}: expected a JSON object beside the weights, got {type(info).__name__}")
    return path, session, info


def _is_zip(path: Path) -> bool:
    """Whether ``path`` starts as a zip archive does (torch.save's format: a ``.pt``)."""
    try:
        with open(path, "rb") as fh:
            return fh.read(4) == b"PK\x03\x04"
    except OSError:
        return False


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
