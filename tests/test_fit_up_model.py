"""The up model's scatter fit (benchmarks/fit_up_model.py ``fit_scatter``): maximum likelihood of
per-frame tangent residuals under ``(1 - eps) N2(0, sigma^2 I) + eps / (4 pi)`` recovers the
spreads and the outlier share it was drawn with."""

from __future__ import annotations

import sys

import numpy as np

from conftest import ROOT

if str(ROOT) not in sys.path:  # benchmarks/ is a package of the repository, not of the installed pcnet
    sys.path.append(str(ROOT))
from benchmarks.fit_up_model import fit_scatter  # noqa: E402


def _residuals(rng, n: int, sigma_deg: float, eps: float) -> np.ndarray:
    """``(n, 2)`` tangent residuals (rad): Gaussian, with a share ``eps`` of directions uniform
    on the sphere (their tangent coordinates at the pole: the log map of a uniform direction)."""
    r = rng.normal(scale=np.radians(sigma_deg), size=(n, 2))
    out = rng.random(n) < eps
    z = rng.uniform(-1.0, 1.0, out.sum())
    phi = rng.uniform(0.0, 2 * np.pi, out.sum())
    angle = np.arccos(z)
    r[out] = angle[:, None] * np.stack([np.cos(phi), np.sin(phi)], -1)
    return r


def test_fit_scatter_recovers_both_spreads_and_the_outlier_share():
    rng = np.random.default_rng(3)
    rc = [_residuals(rng, 20_000, 2.0, 0.02) for _ in range(2)]
    rb = [_residuals(rng, 20_000, 3.5, 0.02) for _ in range(2)]
    sigma_b, sigma_c, eps, _ = fit_scatter(rc, rb)
    assert abs(sigma_c - 2.0) < 0.05
    assert abs(sigma_b - 3.5) < 0.08
    assert 0.015 < eps < 0.025
