"""Rotation maths on numpy arrays (the torch twin of :func:`rotation_6d_to_matrix` lives in
``pcnet.models.network``).

Conventions (``docs/CONVENTIONS.md``): rotation matrices act on column vectors, ``R`` maps the
canonical frame to the camera frame, batches put the matrix in the last two axes
``(..., 3, 3)``. Angles are radians unless a name ends in ``_deg``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from .conventions import R_FRONTAL
from .errors import InputError

_EPS = 1e-8


def normalize(v: np.ndarray, axis: int = -1, eps: float = _EPS) -> np.ndarray:
    """Unit vectors along ``axis`` (``v / |v|``, same shape as ``v``); vectors of length
    ``<= eps`` (default 1e-8, absolute, in ``v``'s units) and vectors with a NaN become NaN,
    never a silent zero. ``eps=0.0`` refuses only exactly-zero vectors."""
    n = np.linalg.norm(v, axis=axis, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > eps, v / n, np.nan)


def rotation_6d_to_matrix(d6: np.ndarray) -> np.ndarray:
    """6D representation ``(..., 6)`` -> rotation matrix ``(..., 3, 3)`` by Gram-Schmidt.

    The 6D vector holds the first two columns of the matrix, ``[a1, a2]`` (Zhou et al. 2019,
    "On the continuity of rotation representations", eq. 15-16):
    ``b1 = a1/|a1|, b2 = normalize(a2 - (b1.a2) b1), b3 = b1 x b2``, ``R = [b1 b2 b3]``.
    Degenerate inputs give NaN columns: all three where ``|a1|`` is below 1e-8, the second
    and third where ``a2`` is parallel to ``a1`` (absolute threshold, so scale a tiny
    6D vector up first).
    """
    d6 = np.asarray(d6, dtype=np.float64)
    a1, a2 = d6[..., 0:3], d6[..., 3:6]
    b1 = normalize(a1)
    b2 = normalize(a2 - np.sum(b1 * a2, axis=-1, keepdims=True) * b1)
    b3 = np.cross(b1, b2)
    return np.stack([b1, b2, b3], axis=-1)


def matrix_to_rotation_6d(R: np.ndarray) -> np.ndarray:
    """Rotation matrix ``(..., 3, 3)`` -> 6D ``(..., 6)``: its first two columns, concatenated."""
    R = np.asarray(R)
    return np.concatenate([R[..., :, 0], R[..., :, 1]], axis=-1)


def geodesic_angle(R1: np.ndarray, R2: np.ndarray) -> np.ndarray:
    """Geodesic distance on SO(3), radians in [0, pi], ``(...)`` for rotation matrices ``R1``,
    ``R2`` ``(..., 3, 3)`` (broadcast): ``arccos((tr(R1 R2^T) - 1) / 2)`` with the argument
    clamped to [-1, 1] (3DPCNet paper eq. 1). NaN where either matrix has a NaN."""
    tr = np.einsum("...ij,...ij->...", R1, R2)  # tr(R1 R2^T)
    return np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0))


def angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle in radians, [0, pi], between vectors ``u`` and ``v`` ``(..., 3)`` (broadcast; any
    length, unit not needed), ``(...)``; robust near 0 and pi (atan2 form). NaN where either
    has a NaN; 0 where either is zero-length."""
    cross = np.linalg.norm(np.cross(u, v), axis=-1)
    return np.arctan2(cross, np.sum(u * v, axis=-1))


def twist_angle(R: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Swing-twist decomposition: signed angle (radians, in [-pi, pi)) of the twist of ``R``
    ``(..., 3, 3)`` about the unit ``axis`` ``(3,)`` or ``(..., 3)``.

    With quaternion ``q = (v, w)``, the twist is ``normalize(w, (v.a) a)``, so the angle is
    ``2 atan2(v.a, w)``; it is the same for swing-then-twist and twist-then-swing.
    """
    shape = np.shape(R)[:-2]
    q = Rotation.from_matrix(np.reshape(R, (-1, 3, 3))).as_quat()  # (x, y, z, w)
    q = q.reshape(shape + (4,))
    along = np.sum(q[..., :3] * axis, axis=-1)
    ang = 2.0 * np.arctan2(along, q[..., 3])
    return (ang + np.pi) % (2 * np.pi) - np.pi


def camera_pitch_roll(up_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Camera pitch and roll in radians, each ``(...)``, from unit up direction(s) ``up_cam``
    ``(..., 3)`` in the camera frame (OpenCV axes: x right, y down, z forward):
    ``pitch = asin(-u_z)`` (argument clipped to [-1, 1]; positive = the camera looks down
    at the subject), ``roll = atan2(u_x, -u_y)`` (in [-pi, pi]; positive turns the camera
    about its optical axis as :func:`compose_camera_rotation`'s ``Rz(roll)``). They are
    :func:`decompose_camera_rotation`'s pitch and roll, which depend only on the up column
    ``R[..., :, 1]``; with :func:`camera_tilt_deg`, ``cos(tilt) = cos(pitch) cos(roll)``.
    NaN stays NaN. The one place pcnet turns an up vector into pitch and roll: degrees are
    ``np.degrees`` of these.
    """
    up_cam = np.asarray(up_cam)
    pitch = np.arcsin(np.clip(-up_cam[..., 2], -1.0, 1.0))
    roll = np.arctan2(up_cam[..., 0], -up_cam[..., 1])
    return pitch, roll


#: Camera tilt (angle between the estimated up and image-up, -y) above which the input is
#: probably upside down or its axes are wrong: a real camera films a standing scene with
#: the sky above, and even a phone held in portrait leaves up within 90 deg of some image
#: axis but not beyond 90 deg from image-up unless it is upside down.
UPSIDE_DOWN_TILT_DEG = 90.0


def camera_tilt_deg(up_cam: np.ndarray) -> np.ndarray:
    """Camera tilt in degrees, ``(...)``: the angle between unit up direction(s) ``up_cam``
    ``(..., 3)`` in the camera frame (OpenCV axes) and the image's up, -y: ``arccos(-u_y)``,
    0 for a level camera, 180 upside down. NaN stays NaN."""
    return np.degrees(np.arccos(np.clip(-np.asarray(up_cam)[..., 1], -1.0, 1.0)))


def with_up(R: np.ndarray, up: np.ndarray) -> np.ndarray:
    """``R`` ``(..., 3, 3)`` turned by the shortest arc that takes its up column (canonical +Y,
    ``R[..., :, 1]``) onto the unit vector ``up`` ``(..., 3)`` (camera frame; broadcast):
    ``A R`` with ``A`` the Rodrigues rotation about ``R_y x up`` by the angle between them
    (``A = I + K + K^2 (1 - c) / s^2``, ``K`` the cross-product matrix of ``R_y x up``, ``c``
    and ``s`` the angle's cosine and sine). The result has ``up`` as its up and keeps ``R``'s
    heading about it: of all rotations with that up, the one nearest ``R``. Where the two are
    opposite (the arc is not unique) ``R`` is turned by pi about its own +X. The result is then
    made orthonormal with its up kept (Gram-Schmidt from +Y: an ``R`` from float32 network
    output is orthonormal to about 1e-6 only). ``(..., 3, 3)`` float64; NaN where either input
    has a NaN.
    """
    R = np.asarray(R, np.float64)
    a = R[..., :, 1]
    b = np.broadcast_to(np.asarray(up, np.float64), a.shape)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)
    s2 = np.sum(v * v, axis=-1)
    K = np.zeros(v.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(s2 > _EPS ** 2, (1.0 - c) / s2, 0.5)[..., None, None]
    A = np.eye(3) + K + (K @ K) * f
    x = R[..., :, 0]
    half_turn = 2.0 * x[..., :, None] * x[..., None, :] - np.eye(3)  # pi about R's own +X
    opposite = ((s2 <= _EPS ** 2) & (c < 0))[..., None, None]
    turned = np.where(opposite, half_turn, A) @ R
    y = normalize(b)
    x = normalize(turned[..., :, 0] - np.sum(turned[..., :, 0] * y, axis=-1, keepdims=True) * y)
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def axis_rotation(axis: str, angle: np.ndarray) -> np.ndarray:
    """Right-handed rotation matrices ``(..., 3, 3)`` about ``"x"``, ``"y"`` or ``"z"`` by
    ``angle`` radians ``(...)`` (counter-clockwise looking down the axis).

    Raises:
        KeyError: ``axis`` not one of ``"x"``, ``"y"``, ``"z"``.
    """
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(angle), np.zeros_like(angle)
    rows = {
        "x": [[o, z, z], [z, c, -s], [z, s, c]],
        "y": [[c, z, s], [z, o, z], [-s, z, c]],
        "z": [[c, -s, z], [s, c, z], [z, z, o]],
    }[axis]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def compose_camera_rotation(heading: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """Canonical->camera rotation ``(..., 3, 3)`` from heading, camera pitch and camera roll
    (radians, each ``(...)``).

    ``R = Rz(roll) @ Rx(pitch) @ R_FRONTAL @ Ry(heading)``: the subject turned by ``heading``
    about its up axis (0 = facing the camera, positive = counter-clockwise seen from above),
    seen by a frontal camera that is then pitched about its x axis (positive = looking
    down at the subject, i.e. camera elevation) and rolled about its optical axis.
    Inverse of :func:`decompose_camera_rotation`.
    """
    return axis_rotation("z", roll) @ axis_rotation("x", pitch) @ R_FRONTAL @ axis_rotation("y", heading)


def decompose_camera_rotation(R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tilt/heading decomposition of canonical->camera rotations ``(..., 3, 3)``.

    Returns ``(heading, pitch, roll)`` in radians with :func:`compose_camera_rotation`'s
    meaning. Pitch and roll (the camera's tilt relative to gravity) depend only on the up
    vector ``u = R[:, 1]`` in the camera frame: ``pitch = asin(-u_z)``,
    ``roll = atan2(u_x, -u_y)`` (:func:`camera_pitch_roll`); heading is what is left about
    the up axis.

    Raises:
        InputError: ``R`` not ``(..., 3, 3)``, or a finite matrix that is not a rotation
            (``R^T R = I`` and ``det R = 1`` within 1e-3; NaN matrices give NaN angles).
    """
    R = np.asarray(R, np.float64)
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise InputError(f"R: expected (..., 3, 3) rotations, got shape {R.shape}")
    finite = np.isfinite(R).all(axis=(-2, -1))
    F = R[finite]
    if len(F) and (np.abs(np.swapaxes(F, -1, -2) @ F - np.eye(3)).max() > 1e-3
                   or np.abs(np.linalg.det(F) - 1.0).max() > 1e-3):
        raise InputError("R: expected rotation matrices (orthonormal, determinant +1), got a matrix that is not one")
    pitch, roll = camera_pitch_roll(R[..., :, 1])
    M = np.swapaxes(R_FRONTAL, -1, -2) @ axis_rotation("x", -pitch) @ axis_rotation("z", -roll) @ R
    heading = np.arctan2(M[..., 0, 2], M[..., 0, 0])
    return heading, pitch, roll


def _truncnormal(rng: np.random.Generator, sigma: float, clip: float, n: int) -> np.ndarray:
    return np.clip(rng.normal(0.0, sigma, n), -clip, clip)


def sample_camera_rotations(n: int, distribution: str, rng: np.random.Generator) -> np.ndarray:
    """Sample ``n`` camera-like canonical->camera rotations ``(n, 3, 3)`` float64.

    ``distribution`` (``docs/CONVENTIONS.md``, "Camera-like rotation sampling"):

    * ``"paper"`` (3DPCNet reference code): 75% yaw U(-70, 70), pitch N(0, 12) clip 20,
      roll N(0, 4) clip 8; 15% yaw +-90 + N(0, 10), pitch N(0, 8) clip 15, roll N(0, 3)
      clip 6; 10% yaw 180 + N(0, 20), pitch and roll as the side views; then
      |pitch| <= 25, |roll| <= 12 (degrees).
    * ``"wide"``: yaw U(-180, 180), pitch U(-45, 45), roll N(0, 10) clip 25.
    * ``"handheld"``: the paper's yaw and pitch, roll N(0, 10) clip 30 in every view (phones
      held or propped without a level: an assumption, and the declared camera prior of the
      up model, pitch N(0, 12), roll N(0, 10), :mod:`pcnet.stages.up_model`).

    Yaw is the camera's azimuth around the subject, so the subject's heading relative to
    the camera is ``-yaw``; pitch is the camera's elevation, roll its tilt about its optical
    axis (see :func:`compose_camera_rotation`).

    Raises:
        ValueError: for an unknown distribution name.
    """
    if distribution in ("paper", "handheld"):
        kind = rng.choice(3, size=n, p=[0.75, 0.15, 0.10])
        yaw = rng.uniform(-70, 70, n)
        pitch = _truncnormal(rng, 12, 20, n)
        roll = _truncnormal(rng, 4, 8, n)
        side_pitch = _truncnormal(rng, 8, 15, n)
        side_roll = _truncnormal(rng, 3, 6, n)
        side_yaw = rng.choice([-90.0, 90.0], size=n) + rng.normal(0, 10, n)
        back_yaw = 180.0 + rng.normal(0, 20, n)
        yaw = np.where(kind == 1, side_yaw, np.where(kind == 2, back_yaw, yaw))
        pitch = np.clip(np.where(kind > 0, side_pitch, pitch), -25, 25)
        roll = np.clip(np.where(kind > 0, side_roll, roll), -12, 12)
        if distribution == "handheld":
            roll = _truncnormal(rng, 10, 30, n)
    elif distribution == "wide":
        yaw = rng.uniform(-180, 180, n)
        pitch = rng.uniform(-45, 45, n)
        roll = _truncnormal(rng, 10, 25, n)
    else:
        raise InputError(f"unknown view distribution {distribution!r}; expected 'paper', 'wide' or 'handheld'")
    return compose_camera_rotation(np.radians(-yaw), np.radians(pitch), np.radians(roll))


def procrustes_rotation(X0: np.ndarray, Y0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The proper rotation ``R`` ``(N, 3, 3)`` minimising ``sum_j |x_j R - y_j|^2`` per item
    (row vectors; Kabsch 1976, Umeyama 1991), and ``tr(S D)`` ``(N,)``, the signed singular
    values' sum that the similarity's scale needs.

    Args:
        X0, Y0: ``(N, J, 3)`` finite point sets, already centred (or about a common point).
    """
    H = np.swapaxes(X0, 1, 2) @ Y0  # (N, 3, 3)
    U, S, Vt = np.linalg.svd(H)
    D = np.ones_like(S)
    D[:, -1] = np.sign(np.linalg.det(U @ Vt))
    return (U * D[:, None, :]) @ Vt, (S * D).sum(-1)


def similarity_procrustes(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Align ``X`` to ``Y`` with the best similarity transform per item (Umeyama 1991):
    ``X_aligned = s X R + t`` minimising ``|X_aligned - Y|^2`` with ``R`` a proper rotation.

    Args:
        X, Y: ``(N, J, 3)``; joints that are NaN in either are ignored in the fit. An item
        with fewer than 3 usable joints comes back NaN.

    Returns:
        ``(N, J, 3)`` float64, ``X`` aligned to ``Y``.
    """
    X = np.asarray(X, np.float64)
    Y = np.asarray(Y, np.float64)
    ok = np.isfinite(X).all(-1) & np.isfinite(Y).all(-1)  # (N, J)
    w = ok[..., None].astype(np.float64)
    cnt = np.maximum(w.sum(1, keepdims=True), 1.0)
    Xz, Yz = np.where(ok[..., None], X, 0.0), np.where(ok[..., None], Y, 0.0)
    mx, my = (Xz * w).sum(1, keepdims=True) / cnt, (Yz * w).sum(1, keepdims=True) / cnt
    X0, Y0 = (Xz - mx) * w, (Yz - my) * w
    R, trace = procrustes_rotation(X0, Y0)
    varx = (X0**2).sum((1, 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        s = trace / varx
    out = s[:, None, None] * ((X - mx) @ R) + my
    out[ok.sum(1) < 3] = np.nan
    return out
