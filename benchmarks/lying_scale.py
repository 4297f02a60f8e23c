"""Decision 0082's trial: does the 60 deg cut that defines a lying training frame move any result?

    python -m benchmarks.lying_scale --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

1. On the training frames (:func:`benchmarks.fit_up_model.training_trunk_angles`, the shipped
   weights' mix): the cut-free attempt, a maximum likelihood mixture of the trunk elevation
   ``e`` (from the horizontal), ``(1 - w) vMF(kappa)`` about the vertical (its elevation
   marginal ``kappa / (2 sinh kappa) exp(kappa sin e) cos e``) plus ``w N(0, s^2)`` truncated to
   ``|e| <= 90 deg``, from three starts of ``s`` and ``w``; then ``sigma_lie`` for each cut of
   :data:`benchmarks.fit_up_model.LYING_CUTS_DEG`.
2. The shipped chain with ``sigma_lie`` at the refit (the 60 deg cut), the rows "sigma_lie at the
   smallest / largest cut's fit" beside it, on the ablation's held-out sets
   (:mod:`benchmarks.ablation`'s tables, its default and auto rows and these two as
   alternatives), its floor sections (run once per value: they take the package's default
   parameters), and the 12 real recordings of :mod:`benchmarks.real_intervals`.

Writes ``benchmarks/results/lying_scale.txt``. Decision 0082's rule reads it.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.optimize import minimize
from scipy.stats import norm

import pcnet.stages.up_model as up_model
from benchmarks import ablation as A
from benchmarks import real_intervals as RI
from benchmarks.fit_up_model import LYING_CUTS_DEG, fit_lying, training_trunk_angles
from benchmarks.report import print_and_save, require_folder

RESULT = Path(__file__).resolve().parent / "results" / "lying_scale.txt"
COMMAND = "python -m benchmarks.lying_scale --data ../shared/data"


def mixture_fit(elev: np.ndarray) -> list[tuple[float, float, float, float]]:
    """The cut-free attempt on elevations ``elev`` (rad): per start, ``(kappa, s_deg, w, -log L)``."""
    cos_e = np.maximum(np.cos(elev), 1e-300)

    @np.errstate(divide="ignore", over="ignore")  # a start that runs kappa to 0 or s to infinity scores -inf / inf
    def nll(x):
        kappa, s, w = np.exp(x[0]), np.exp(x[1]), 1.0 / (1.0 + np.exp(-x[2]))
        upright = np.log(kappa) - kappa - np.log1p(-np.exp(-2.0 * kappa)) + kappa * np.sin(elev) + np.log(cos_e)
        inside = norm.cdf(np.pi / 2, scale=s) - norm.cdf(-np.pi / 2, scale=s)
        lying = norm.logpdf(elev, scale=s) - np.log(inside)
        return -float(np.sum(np.logaddexp(np.log1p(-w) + upright, np.log(w) + lying)))

    out = []
    for s0, w0 in ((10.0, 1e-4), (20.0, 1e-3), (30.0, 1e-2)):
        res = minimize(nll, [np.log(20.0), np.log(np.radians(s0)), np.log(w0 / (1 - w0))], method="Nelder-Mead",
                       options={"maxiter": 4000, "xatol": 1e-6, "fatol": 1e-6})
        out.append((float(np.exp(res.x[0])), float(np.degrees(np.exp(res.x[1]))),
                    float(1.0 / (1.0 + np.exp(-res.x[2]))), float(res.fun)))
    return out


def with_lying_scale(sigma_deg: float) -> None:
    """Make ``sigma_deg`` the package's default ``sigma_lie`` for everything run after."""
    up_model._DEFAULT = None
    up_model._DEFAULT = replace(up_model.default_parameters(), lying_elevation_deg=sigma_deg)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=A.DEFAULT)
    ap.add_argument("--cache", type=Path, default=A.CACHE)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    require_folder(args.data, "lying_scale")
    t0 = time.time()
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", ""]

    angles = training_trunk_angles(args.data)
    ang = np.concatenate([a for _, a in angles])
    lines += ["## Training frames", f"{len(ang)} frames of {len(angles)} clips (the shipped weights' mix)",
              "cut-free mixture (vMF upright + normal lying), per start: kappa, s (deg), w, -log L"]
    lines += [f"  kappa {k:9.3f}  s {s:14.4g}  w {w:.5f}  -log L {f:.1f}" for k, s, w, f in
              mixture_fit(np.radians(90.0 - ang))]
    fits = {c: fit_lying(angles, c) for c in LYING_CUTS_DEG}
    lines += [f"cut {c:g} deg: {k} frames, sigma_lie {s:.2f} deg" for c, (_, s, k, _) in fits.items()]
    base = fit_lying(angles)[1]
    low, high = min(s for _, s, _, _ in fits.values()), max(s for _, s, _, _ in fits.values())
    lines += [f"refit (the {A.LYING_TRUNK_DEG:g} deg cut): {base:.3f}; trial ends {low:.3f} / {high:.3f}", ""]
    print("\n".join(lines), flush=True)

    with_lying_scale(base)
    ends = (A.Variant(f"sigma_lie {low:.2f} (smallest cut fit)", "alternative",
                      params=(("lying_elevation_deg", low),)),
            A.Variant(f"sigma_lie {high:.2f} (largest cut fit)", "alternative",
                      params=(("lying_elevation_deg", high),)))
    A.VARIANTS = (A.Variant(f"default (sigma_lie {base:.2f})", "default"),
                  next(v for v in A.VARIANTS if v.label == A.AUTO), *ends)
    tmp = args.out.with_name(args.out.stem + "_ablation.tmp")
    try:
        A.main(["--data", str(args.data), "--cache", str(args.cache), "--out", str(tmp), "--skip", "floor"])
        lines += ["## The ablation's held-out sets", *tmp.read_text().splitlines()[4:], ""]
    finally:
        tmp.unlink(missing_ok=True)

    static = [A.mocap_set(args.data, args.cache, file, split, 200) for _, file, split in A.MOCAP_SETS]
    floor_sets = A.floor_recordings(args.data, args.cache, 200, static)
    quarter = A.rolled_recordings(args.cache, static, 200, A.QUARTER_DEG)
    for label, sigma in (("refit", base), ("smallest cut fit", low), ("largest cut fit", high)):
        with_lying_scale(sigma)
        block = [f"## Floor sections, sigma_lie {sigma:.2f} ({label})", *A.floor_table(floor_sets),
                 *A.rolled_floor_table(quarter, floor_sets[:len(A.MOCAP_SETS)]), ""]
        print("\n".join(block), flush=True)
        lines += block
        checks = [(scene, source, RI.check_run(cfg, up)) for scene, source, cfg, up in RI.recordings(args.data)]
        held = sum(c.holds for _, _, c in checks if c.has_interval)
        block = [f"## Real recordings (benchmarks.real_intervals), sigma_lie {sigma:.2f} ({label})",
                 *(f"{scene:<16}{source:<34}{c.mode:<10} holds {'yes' if c.holds else 'NO':<4} tilt {c.tilt_error:5.1f}"
                   for scene, source, c in checks),
                 f"both intervals hold the truth in {held} of {sum(c.has_interval for _, _, c in checks)}; mean tilt "
                 f"error {np.mean([c.tilt_error for _, _, c in checks]):.2f} deg", ""]
        print("\n".join(block), flush=True)
        lines += block
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
