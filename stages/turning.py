"""Did the camera move? The tilt of the body's turns between moments of the same configuration.

A person on a floor changes heading by turning about the vertical. Between two frames ``t``
and ``k`` in which the body has the same configuration (the same distances between all its
joints), the pelvis-centred skeleton a static camera sees has turned about the camera-frame up
``g`` only: the least-squares rotation ``R`` with ``R x_t,j ~ x_k,j`` (Kabsch, "A solution for
the best rotation to relate two sets of vectors", Acta Cryst. A32, 1976) leaves ``g`` in place.
A camera that rotates between the two frames adds its rotation, which tilts ``g``:
``tau = angle(R g, g)`` is the camera's change of tilt (plus the skeletons' noise). The
networks' pose-driven errors do not enter: the statistic reads the joints, and matched frames
share their configuration. Decision 0069 (docs/decisions) fixes the statistic:

- frames: the valid frames with all 17 joints finite, in time order; the first and the last
  third of them (the longest time apart, where a moving camera has moved most);
- each frame of one third is matched to the frame of the other third with the nearest
  configuration, the Euclidean distance between the 136 pairwise joint distances;
- the statistic is the median ``tau`` over the matched pairs, in degrees.
"""

from __future__ import annotations

import numpy as np

from .core.conventions import PELVIS
from .core.errors import InputError

#: At most this many frames of each third are matched (evenly spaced): the brute-force nearest
#: neighbours cost the square of it. A computing cap, not a statistical choice: the median
#: of thousands of pairs does not need more.
_MAX_FRAMES_PER_THIRD = 2000
_PAIRS = np.triu_indices(17, 1)


def configuration(joints: np.ndarray) -> np.ndarray:
    """``(T, 136)`` the distances between every two of the 17 joints of ``joints``
    ``(T, 17, 3)`` (any unit): the body's configuration, the same under any rotation."""
    d = joints[:, :, None] - joints[:, None]
    return np.linalg.norm(d, axis=-1)[:, _PAIRS[0], _PAIRS[1]]


def nearest(a: np.ndarray, b: np.ndarray, chunk: int = 1000) -> np.ndarray:
    """``(len(a),)`` index into ``b`` ``(M, D)`` of each row of ``a`` ``(N, D)``'s nearest row (Euclidean)."""
    bb = np.sum(b * b, axis=1)
    out = np.empty(len(a), np.int64)
    for i in range(0, len(a), chunk):
        block = a[i:i + chunk]
        out[i:i + chunk] = np.argmin(bb[None] - 2.0 * block @ b.T, axis=1)
    return out


def kabsch(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` the proper rotations ``R`` minimising ``sum_j |R p_j - q_j|^2`` for each of
    the ``N`` pairs of point sets ``P``, ``Q`` ``(N, J, 3)`` (already centred; Kabsch 1976)."""
    H = np.einsum("nji,njk->nik", P, Q)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.swapaxes(Vt, 1, 2) @ np.swapaxes(U, 1, 2)))
    D = np.zeros_like(H)
    D[:, 0, 0] = D[:, 1, 1] = 1.0
    D[:, 2, 2] = d
    return np.swapaxes(Vt, 1, 2) @ D @ np.swapaxes(U, 1, 2)


def turn_tilt_deg(joints_cam: np.ndarray, valid: np.ndarray, up: np.ndarray) -> float:
    """The median tilt (deg) that the rotations between matched configurations give the up
    (module docstring): about 0 for a static camera, the camera's change of tilt for a moving one.

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 camera-frame joints (any unit; the root may be kept:
            each skeleton is centred on its pelvis); NaN = missing.
        valid: ``(T,)`` bool, the frames to read.
        up: ``(3,)`` the recording's up in the camera frame (the up model's summary of the poses).

    Returns:
        the median tilt in degrees; NaN with fewer than 3 frames whose 17 joints are all finite.

    Raises:
        InputError: ``joints_cam`` not ``(T, 17, 3)``, ``valid`` not ``(T,)``, ``up`` not a
            finite ``(3,)`` vector.
    """
    J = np.asarray(joints_cam, np.float64)
    if J.ndim != 3 or J.shape[1:] != (17, 3):
        raise InputError(f"turn_tilt_deg: joints_cam must have shape (T, 17, 3), got {J.shape}")
    valid = np.asarray(valid, bool)
    if valid.shape != (len(J),):
        raise InputError(f"turn_tilt_deg: valid must have shape ({len(J)},), got {valid.shape}")
    g = np.asarray(up, np.float64)
    if g.shape != (3,) or not np.isfinite(g).all() or not np.linalg.norm(g) > 0:
        raise InputError(f"turn_tilt_deg: up must be a finite non-zero (3,) vector, got {g!r}")
    g = g / np.linalg.norm(g)
    frames = np.flatnonzero(valid & np.isfinite(J).all(axis=(1, 2)))
    n = len(frames) // 3
    if n < 1:
        return float("nan")
    first, last = (_evenly(f) for f in (frames[:n], frames[-n:]))
    X = J - J[:, PELVIS:PELVIS + 1]
    c_first, c_last = configuration(X[first]), configuration(X[last])
    sources = np.concatenate([first, last])
    targets = np.concatenate([last[nearest(c_first, c_last)], first[nearest(c_last, c_first)]])
    R = kabsch(X[sources], X[targets])
    cos = np.clip(np.einsum("i,nij,j->n", g, R, g), -1.0, 1.0)
    return float(np.degrees(np.median(np.arccos(cos))))


def _evenly(frames: np.ndarray) -> np.ndarray:
    if len(frames) <= _MAX_FRAMES_PER_THIRD:
        return frames
    return frames[np.linspace(0, len(frames) - 1, _MAX_FRAMES_PER_THIRD).round().astype(np.int64)]
