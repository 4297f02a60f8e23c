"""The up model's scatter and systematic-error fits (benchmarks/fit_up_model.py ``fit_scatter``,
``fit_systematic``): maximum likelihood recovers the spreads and the outlier share the
residuals were drawn with, and the tied forms of decision 0059 lose where the data tell the
two apart."""

from __future__ import annotations

import sys

import numpy as np

from conftest import ROOT

if str(ROOT) not in sys.path:  # benchmarks/ is a package of the repository, not of the installed pcnet
    sys.path.append(str(ROOT))
from benchmarks.fit_up_model import fit_scatter, fit_systematic  # noqa: E402


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


def test_one_scatter_for_both_networks_is_their_pooled_spread_and_less_likely_where_they_differ():
    rng = np.random.default_rng(4)
    rc = [_residuals(rng, 20_000, 2.0, 0.02)]
    rb = [_residuals(rng, 20_000, 3.0, 0.02)]
    sigma_b, sigma_c, _, free = fit_scatter(rc, rb)
    sigma, same, _, tied = fit_scatter(rc, rb, tied=True)
    assert sigma == same and sigma_c < sigma < sigma_b
    assert tied < free - 100  # spreads 2 and 3 deg over 40,000 frames: the tied model is far less likely
    rb_alike = [_residuals(rng, 20_000, 2.0, 0.02)]
    assert fit_scatter(rc, rb_alike, tied=True)[3] > fit_scatter(rc, rb_alike)[3] - 5  # alike: nearly as likely


def test_the_systematic_error_fit_recovers_two_axes_and_its_isotropic_form_loses_on_them():
    rng = np.random.default_rng(5)
    n = 2000
    covs = np.repeat(np.diag(np.radians([0.5, 0.5]) ** 2)[None], n, 0)
    es = rng.normal(size=(n, 2)) * np.sqrt(np.radians([0.5, 0.5]) ** 2 + np.radians([3.0, 1.0]) ** 2)
    s_pitch, s_roll, diagonal = fit_systematic(es, covs)
    s, same, isotropic = fit_systematic(es, covs, isotropic=True)
    assert abs(s_pitch - 3.0) < 0.15 and abs(s_roll - 1.0) < 0.1
    assert s == same and s_roll < s < s_pitch
    assert isotropic < diagonal - 100
