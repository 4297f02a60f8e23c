"""What the heading benchmarks share: each network's heading on the shipped pair's up, and angles
on a circle in degrees."""

from __future__ import annotations

import numpy as np

from pcnet.models.inference import ViewGatedPCNet
from pcnet.stages.core.rotations import with_up


def wrapped_deg(d):
    """``d`` (deg, scalar or array) wrapped into [-180, 180)."""
    return (np.asarray(d, np.float64) + 180.0) % 360.0 - 180.0


def circular_mean_deg(a: np.ndarray) -> float:
    """Circular mean (deg) of the finite angles in ``a`` (deg); NaN when none is finite."""
    r = np.radians(np.asarray(a, np.float64))
    r = r[np.isfinite(r)]
    return float(np.degrees(np.arctan2(np.sin(r).mean(), np.cos(r).mean()))) if len(r) else float("nan")


def pair_headings(pair: ViewGatedPCNet, joints: np.ndarray, fps: float):
    """The shipped pair on one recording's camera-frame poses ``(T, 17, 3)``: ``(valid (T,),
    disagreement (T,) deg, (camera-frame, body-frame) rotations alone, (camera-frame,
    body-frame) rotations on the pair's up)``; "on the pair's up": each network's rotation
    turned by the shortest arc onto the pair's up (stages/core/rotations.py: with_up), so the
    two differ only in their heading and both have the pair's tilt."""
    R_pair, _, ok, _, disagreement, *_ = pair.predict_gated(joints, fps)
    alone = pair.camera.predict(joints)[0], pair.body.predict(joints)[0]
    up = R_pair[:, :, 1]
    return ok, disagreement, alone, tuple(with_up(R, up) for R in alone)
