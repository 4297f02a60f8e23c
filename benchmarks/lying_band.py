"""Decision 0099's trial: the lying posture's elevation uniform within the definition of lying, against the normal it replaced.

    python -m benchmarks.lying_band --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

1. On the training frames (:func:`benchmarks.fit_up_model.training_trunk_angles`, the shipped
   weights' mix), per cut of :data:`benchmarks.fit_up_model.LYING_CUTS_DEG`: the lying frames'
   RMS elevation against the uniform's, and the maximum likelihood scale of a normal truncated
   to the lying band (:func:`benchmarks.fit_up_model.fit_lying`).
2. The shipped chain (:func:`pcnet.stages.up_model.log_lying`: the band) against the lying
   elevation as shipped before decision 0099 (a normal of ``sigma_lie`` =
   :data:`NORMAL_SIGMA_DEG`, no cut, with the footfalls' learning rate fitted for it,
   :data:`NORMAL_FOOTFALL_POWER`) as an alternative row: on the ablation's held-out sets
   (:mod:`benchmarks.ablation`'s tables with their paired bootstrap verdicts; its auto row
   too, which its reproduction check reads), the steep
   cameras of :mod:`benchmarks.steep_camera`, the floor sections (run once per model: they
   take the package's default parameters), and the 12 real recordings of
   :mod:`benchmarks.real_intervals`.

Writes ``benchmarks/results/lying_band.txt``. Decision 0099's rule reads it.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import pcnet.stages.up_model as up_model
from benchmarks import ablation as A
from benchmarks import real_intervals as RI
from benchmarks import steep_camera as SC
from benchmarks.fit_up_model import LYING_CUTS_DEG, fit_lying, training_trunk_angles
from benchmarks.report import print_and_save, require_mocap

RESULT = Path(__file__).resolve().parent / "results" / "lying_band.txt"
COMMAND = "python -m benchmarks.lying_band --data ../shared/data"
#: ``lying_elevation_deg`` and ``footfall_posture_power`` of ``stages/data/up_model.json`` at
#: git c081bde, the last commit with the normal lying elevation.
NORMAL_SIGMA_DEG = 19.627361
NORMAL_FOOTFALL_POWER = 0.15
#: The provenance key that routes a row's parameters to the normal elevation.
NORMAL_KEY = "lying elevation (trial)"
BAND = up_model.log_lying


def log_lying_normal(g: np.ndarray, s: up_model.PoseSummary, p: up_model.UpModelParameters) -> np.ndarray:
    """The lying density before decision 0099: elevation ``asin(g_hat . g)`` normal with
    variance ``sigma_lie^2 + tr(C_L + S) / 2``, no cut; per steradian."""
    var = np.radians(NORMAL_SIGMA_DEG) ** 2 + 0.5 * np.trace(s.cov + up_model.systematic_cov(p))
    e = np.arcsin(np.clip(np.sum(g * s.up, -1), -1.0, 1.0))
    return -0.5 * e ** 2 / var - 0.5 * np.log(2 * np.pi * var) - np.log(2 * np.pi * np.maximum(np.cos(e), 1e-6))


def log_lying_either(g: np.ndarray, s: up_model.PoseSummary, p: up_model.UpModelParameters) -> np.ndarray:
    return (log_lying_normal if p.provenance.get(NORMAL_KEY) else BAND)(g, s, p)


def normal_parameters(p: up_model.UpModelParameters) -> up_model.UpModelParameters:
    return replace(p, footfall_posture_power=NORMAL_FOOTFALL_POWER, provenance={**p.provenance, NORMAL_KEY: "normal"})


def use_default(normal: bool) -> None:
    """Make the band's (or the normal's) parameters the package's default for everything run after."""
    up_model._DEFAULT = None
    shipped = up_model.default_parameters()
    up_model._DEFAULT = normal_parameters(shipped) if normal else shipped


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=A.DEFAULT)
    ap.add_argument("--cache", type=Path, default=A.CACHE)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    require_mocap(args.data, "lying_band")
    t0 = time.time()
    up_model.log_lying = log_lying_either
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", ""]

    angles = training_trunk_angles(args.data)
    lines += ["## Training frames", f"{sum(len(a) for _, a in angles)} frames of {len(angles)} clips (the shipped "
              "weights' mix); per cut: lying frames, RMS elevation / the uniform's, truncated normal's ML scale (deg)"]
    for c in LYING_CUTS_DEG:
        _, rms, scale, k, _ = fit_lying(angles, c)
        lines.append(f"cut {c:g} deg: {k} frames, RMS {rms:.2f} / {(90 - c) / np.sqrt(3):.2f}, scale {scale:.4g}")
    lines.append("")
    print("\n".join(lines), flush=True)

    shipped = up_model.default_parameters()
    normal = normal_parameters(shipped)
    alternative = A.Variant(f"lying elevation normal, sigma_lie {NORMAL_SIGMA_DEG:.2f} (before 0099)", "alternative",
                            params=(("provenance", normal.provenance),
                                    ("footfall_posture_power", NORMAL_FOOTFALL_POWER)))
    A.VARIANTS = (A.Variant("default (lying band)", "default"), next(v for v in A.VARIANTS if v.label == A.AUTO),
                  alternative)
    tmp = args.out.with_name(args.out.stem + "_part.tmp")
    try:
        A.main(["--data", str(args.data), "--cache", str(args.cache), "--out", str(tmp), "--skip", "floor"])
        lines += ["## The ablation's held-out sets", *tmp.read_text().splitlines()[4:], ""]
        SC.ROWS = (A.VARIANTS[0], alternative)
        SC.main(["--data", str(args.data), "--cache", str(args.cache), "--out", str(tmp)])
        lines += ["## Steep cameras (benchmarks.steep_camera)", *tmp.read_text().splitlines()[4:], ""]
    finally:
        tmp.unlink(missing_ok=True)

    static = [A.mocap_set(args.data, args.cache, file, split, 200) for _, file, split in A.MOCAP_SETS]
    floor_sets = A.floor_recordings(args.data, args.cache, 200, static)
    quarter = A.rolled_recordings(args.cache, static, 200, A.QUARTER_DEG)
    for label, is_normal in (("lying band", False), (alternative.label, True)):
        use_default(is_normal)
        block = [f"## Floor sections, {label}", *A.floor_table(floor_sets),
                 *A.rolled_floor_table(quarter, floor_sets[:len(A.MOCAP_SETS)]), ""]
        print("\n".join(block), flush=True)
        lines += block
        checks = [(scene, source, RI.check_run(cfg, up)) for scene, source, cfg, up in RI.recordings(args.data)]
        held = sum(c.holds for _, _, c in checks if c.has_interval)
        block = [f"## Real recordings (benchmarks.real_intervals), {label}",
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
