"""Input normalisation shared by training, torch inference and onnxruntime inference.

numpy only, so run-time inference never needs torch.
"""

from __future__ import annotations

import numpy as np

from pcnet.stages.conventions import H36M_PARENTS, L_HIP, PELVIS, R_HIP, check_poses
from pcnet.stages.errors import InputError

# Joints needed to define the body frame at all; a frame missing any is invalid.
_REQUIRED = (R_HIP, L_HIP, 8, 11, 14)


def normalize_input(joints_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Prepare camera-frame poses for the network.

    1. Centre on the pelvis (the mid-hip stands in when the pelvis is NaN).
    2. Fill NaN joints with their parent's position (the bone collapses to zero length,
       which the network saw in training through dropped-joint noise); never with 0.
    3. Divide by the pose's scale ``s`` = the mean distance of the 16 non-root joints from
       the pelvis, so metric, millimetre and MotionBERT's normalised outputs all reach the
       network at unit size. Rotations are scale-free; a predicted residual is multiplied
       back by ``s`` so the output keeps the input's units.

    Args:
        joints_cam: ``(N, 17, 3)`` H36M-17 camera frame, any units.

    Returns:
        ``x`` ``(N, 17, 3)`` float32 normalised input (zeros for invalid frames),
        ``scale`` ``(N,)`` float64 in input units, ``valid`` ``(N,)`` bool: False where a
        hip, the thorax or a shoulder is NaN or the pose has zero size.

    Raises:
        ValueError: wrong shape.
    """
    X = check_poses(joints_cam, "joints_cam").astype(np.float64)
    pelvis = X[:, PELVIS]
    mid_hip = 0.5 * (X[:, R_HIP] + X[:, L_HIP])
    pelvis = np.where(np.isfinite(pelvis).all(-1, keepdims=True), pelvis, mid_hip)
    X = X - pelvis[:, None]
    valid = np.isfinite(X[:, list(_REQUIRED)]).all((1, 2)) & np.isfinite(pelvis).all(-1)
    X[:, PELVIS] = np.where(np.isfinite(X[:, PELVIS]), X[:, PELVIS], 0.0)
    for child, parent in enumerate(H36M_PARENTS):  # parents precede children
        if parent >= 0:
            miss = ~np.isfinite(X[:, child]).all(-1)
            X[miss, child] = X[miss, parent]
    scale = np.linalg.norm(X[:, 1:], axis=-1).mean(-1)
    valid &= np.isfinite(scale) & (scale > 1e-9)
    x = np.zeros_like(X, dtype=np.float32)
    x[valid] = (X[valid] / scale[valid, None, None]).astype(np.float32)
    return x, scale, valid


def window_indices(valid: np.ndarray, fps: float, offsets_s: np.ndarray) -> np.ndarray:
    """Frame indices of each frame's temporal window, for the static-camera up refiner.

    Frame ``t``'s window is ``t + round(offsets_s * fps)``, clamped to the sequence; a
    neighbour that is invalid is replaced by ``t`` itself, so no window holds a pose the
    network cannot rectify.

    Args:
        valid: ``(T,)`` bool, frames :func:`normalize_input` accepted.
        fps: frame rate in Hz, > 0.
        offsets_s: ``(W,)`` window offsets in seconds (0 = the centre frame).

    Returns:
        ``(T, W)`` int64 indices into the sequence.

    Raises:
        ValueError: non-positive ``fps``.
    """
    if not fps > 0:
        raise InputError(f"fps must be positive, got {fps}")
    valid = np.asarray(valid, bool)
    T = len(valid)
    steps = np.round(np.asarray(offsets_s, np.float64) * fps).astype(np.int64)
    centre = np.arange(T)[:, None]
    idx = np.clip(centre + steps[None], 0, max(T - 1, 0))
    return np.where(valid[idx], idx, centre)


def window_features(x: np.ndarray, R_centre: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The up refiner's input: every pose of a window seen in its centre frame's predicted
    canonical frame. With a static camera the whole window then shares the centre frame's
    tilt error, which is what the refiner reads (how the poses move relative to gravity).

    Args:
        x: ``(T, 17, 3)`` float32 normalised camera-frame poses (:func:`normalize_input`).
        R_centre: ``(N, 3, 3)`` the centre frames' canonical->camera rotations (finite).
        idx: ``(N, W)`` window indices into ``x`` (:func:`window_indices` rows).

    Returns:
        ``(N, W * 51)`` float32, row-major over (window, joint, canonical axis).
    """
    win = x[idx].astype(np.float32)                                  # (N, W, 17, 3) camera frame
    canon = np.einsum("nwjc,nck->nwjk", win, np.asarray(R_centre, np.float32))
    return canon.reshape(len(idx), -1)


REFINER_INPUTS = ("predicted", "body")


def body_frame(x: np.ndarray) -> np.ndarray:
    """A frame fixed to the body by the pose alone: columns = the spine axis (pelvis ->
    thorax), the hip line (right_hip - left_hip) made perpendicular to it, and their cross
    product. ``x`` ``(N, 17, 3)`` pelvis-centred (:func:`normalize_input`); returns
    ``(N, 3, 3)`` float64 body->input-frame rotations (NaN where spine or hips are degenerate).
    Any camera rotation of the input rotates it alike, so a pose seen in it is the same
    from every camera."""
    from pcnet.stages.rotations import normalize

    x = np.asarray(x, np.float64)
    spine = normalize(x[:, 8] - x[:, PELVIS])
    hips = x[:, R_HIP] - x[:, L_HIP]
    side = normalize(hips - np.sum(hips * spine, -1, keepdims=True) * spine)
    return np.stack([spine, side, np.cross(spine, side)], -1)


def refiner_features(kind: str, x: np.ndarray, R_centre: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """An up refiner's input for its ``kind`` (the ``input_frame`` of its ``.json``).

    ``"predicted"``: :func:`window_features` (the window in the centre frames' predicted
    canonical frame). ``"body"`` (one-frame windows): the centre pose in its
    :func:`body_frame`, the same from every camera, so the refiner needs to learn no
    rotation equivariance, only how this pose stands relative to gravity (``R_centre`` is
    not used).

    Returns:
        ``(N, F)`` float32: ``F = W * 51``.

    Raises:
        ValueError: unknown ``kind``.
    """
    if kind == "predicted":
        return window_features(x, R_centre, idx)
    if kind != "body":
        raise InputError(f"unknown refiner input frame {kind!r}; expected one of {REFINER_INPUTS}")
    pose = np.asarray(x[idx[:, 0]], np.float64)
    return np.einsum("njc,nck->njk", pose, body_frame(pose)).reshape(len(idx), -1).astype(np.float32)


def refiner_up_xz(kind: str, x_centre: np.ndarray, R_centre: np.ndarray, output: np.ndarray) -> np.ndarray:
    """An up refiner's output as the corrected up ``(u_x, u_z)`` in the centre frames'
    predicted canonical frame ``R_centre`` ``(N, 3, 3)`` (what
    :func:`pcnet.models.inference.tilt_to_up` takes), ``(N, 2)`` float64. ``"predicted"``
    refiners output it directly; ``"body"`` ones output the up in :func:`body_frame` of the
    centre pose ``x_centre`` ``(N, 17, 3)``, normalised here."""
    output = np.asarray(output, np.float64)
    if kind == "predicted":
        return output
    B = body_frame(x_centre)
    up_cam = np.einsum("nij,nj->ni", B, output / np.linalg.norm(output, axis=-1, keepdims=True))
    return np.einsum("nji,nj->ni", np.asarray(R_centre, np.float64), up_cam)[:, [0, 2]]
