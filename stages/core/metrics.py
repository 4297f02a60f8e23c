"""Evaluation metrics of ``docs/CONVENTIONS.md`` ("Error metrics") and their summaries."""

from __future__ import annotations

import numpy as np

from .rotations import angle_between, geodesic_angle, similarity_procrustes, twist_angle

METRICS = ("rotation_deg", "tilt_deg", "heading_deg", "mpjpe_mm", "pa_mpjpe_mm")


def rotation_error_deg(R_hat: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Geodesic angle between ``R_hat`` and ``R`` ``(N, 3, 3)``, degrees ``(N,)`` in [0, 180];
    NaN where either has a NaN (an invalid frame)."""
    return np.degrees(geodesic_angle(R_hat, R))


def tilt_error_deg(R_hat: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Angle between predicted and true up vectors ``R_hat[:, :, 1]`` vs ``R[:, :, 1]`` (the
    canonical +Y in the camera frame), degrees ``(N,)`` in [0, 180]; NaN where either has a
    NaN."""
    return np.degrees(angle_between(R_hat[..., :, 1], R[..., :, 1]))


def heading_error_deg(R_hat: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Absolute angle of the residual rotation ``R^T R_hat`` (canonical frame) about the true
    up axis (canonical +Y), by swing-twist decomposition; degrees ``(N,)`` in [0, 180]. Meaningful only where the up
    is close: with a tilt error near 180 deg the twist about the true up is arbitrary."""
    E = np.swapaxes(R, -1, -2) @ R_hat
    out = np.full(E.shape[:-2], np.nan)
    ok = np.isfinite(E).all((-1, -2))
    out[ok] = np.abs(np.degrees(twist_angle(E[ok], np.array([0.0, 1.0, 0.0]))))
    return out


def mpjpe_mm(pred: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Mean per-joint position error per frame, millimetres ``(N,)``, for metric ``(N, J, 3)``
    poses in metres; NaN joints are left out of the mean."""
    d = np.linalg.norm(np.asarray(pred, np.float64) - target, axis=-1)
    with np.errstate(invalid="ignore"), _quiet():
        return 1000.0 * np.nanmean(d, axis=-1)


def pa_mpjpe_mm(pred: np.ndarray, target: np.ndarray) -> np.ndarray:
    """MPJPE after per-frame similarity Procrustes alignment of ``pred`` to ``target``
    (Umeyama), millimetres ``(N,)``."""
    return mpjpe_mm(similarity_procrustes(pred, target), target)


def summarize(values: np.ndarray) -> dict[str, float]:
    """``{"mean", "median", "p95"}`` of the finite values (NaN = invalid frames, skipped)."""
    v = np.asarray(values, np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"mean": float("nan"), "median": float("nan"), "p95": float("nan")}
    return {"mean": float(v.mean()), "median": float(np.median(v)), "p95": float(np.percentile(v, 95))}


def evaluate_rotations(
    R_hat: np.ndarray, R: np.ndarray, canon_hat: np.ndarray, canon: np.ndarray
) -> dict[str, np.ndarray]:
    """Per-frame errors of every metric in :data:`METRICS`; frames with a NaN prediction get
    NaN errors (they are counted as invalid by the caller).

    Args:
        R_hat, R: ``(T, 3, 3)`` predicted and true canonical->camera rotations.
        canon_hat, canon: ``(T, 17, 3)`` predicted and true canonical poses in metres
            (canonical frame, docs/CONVENTIONS.md).

    Returns:
        ``name -> (T,)`` float64: ``rotation_deg`` (geodesic), ``tilt_deg``, ``heading_deg``
        in degrees, ``mpjpe_mm`` and ``pa_mpjpe_mm`` in millimetres (docs/CONVENTIONS.md,
        "Metrics").
    """
    return {
        "rotation_deg": rotation_error_deg(R_hat, R),
        "tilt_deg": tilt_error_deg(R_hat, R),
        "heading_deg": heading_error_deg(R_hat, R),
        "mpjpe_mm": mpjpe_mm(canon_hat, canon),
        "pa_mpjpe_mm": pa_mpjpe_mm(canon_hat, canon),
    }


class _quiet:
    """Silence numpy's 'mean of empty slice' warning for all-NaN frames."""

    def __enter__(self):
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        self._w.__exit__(*exc)
