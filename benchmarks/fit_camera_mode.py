"""Fit auto mode's static/moving threshold and smooth mode's time constant on validation data.

    python -m benchmarks.fit_camera_mode --data ../shared/data

Auto mode reads a recording as a moving camera when the spread of its low-passed per-frame ups
(:func:`pcnet.stages.temporal.up_spread_deg`, kernel std ``MODE_SMOOTHING_S``) exceeds
``MODE_THRESHOLD_DEG``. Smooth mode then smooths the per-frame rotations with a Gaussian of std
``SMOOTH_TIME_CONSTANT_S`` (:func:`pcnet.stages.temporal.smooth_rotations`). All three are fitted
here, on validation data only. That data is the static cameras of benchmarks/fit_up_model.py
("paper", "wide" and fully rolled views of the Bandai motion-style validation split and the CMU
validation subjects, lifter noise) and the same clips of at least 150 frames with the camera
pitch sweeping 30 deg. The per-frame rotations are those the shipped chain gives
(benchmarks/ablation.py ``per_frame``, the default variant).

- ``SMOOTH_TIME_CONSTANT_S``: the grid value with the least mean tilt error of the smoothed ups
  on the swept clips.
- ``MODE_SMOOTHING_S``, ``MODE_THRESHOLD_DEG``: for each grid value of the low-pass, the
  threshold with the fewest misread clips (static read moving plus swept read static; the
  midpoint of the widest interval of thresholds reaching that minimum). The low-pass with the
  fewest misreads wins; ties go to the shorter low-pass, because a long kernel, truncated at a
  clip's ends, shrinks the spread of a short clip's sweep. (A largest-margin tie-break, tried
  on the same data, picked a 1 s low-pass that reads a 30 deg sweep over the ~4 s clips of
  tests/test_temporal.py as static.)

Writes benchmarks/results/fit_camera_mode.txt. The package's constants
(stages/temporal.py) must equal what it prints (tests/test_temporal.py checks).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import pcnet.stages.temporal as temporal
from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save

RESULT = Path(__file__).resolve().parent / "results" / "fit_camera_mode.txt"
SMOOTH_GRID_S = (0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0)
LOWPASS_GRID_S = (0.25, 0.5, 1.0, 2.0)


def best_threshold(static: np.ndarray, moving: np.ndarray) -> tuple[float, int, float, float]:
    """``(threshold, misreads, lo, hi)``: the midpoint of the widest interval ``[lo, hi)`` of
    thresholds with the fewest misreads (static above it, moving at or below it)."""
    cuts = np.unique(np.concatenate([static, moving, [0.0, max(static.max(), moving.max()) + 1.0]]))
    errors = np.array([np.sum(static > c) + np.sum(moving <= c) for c in cuts])
    fewest = errors.min()
    best = (0.0, -1.0, -1.0)
    for i in np.flatnonzero(errors == fewest):
        lo, hi = cuts[i], cuts[i + 1] if i + 1 < len(cuts) else cuts[i]
        if hi - lo > best[0]:
            best = (hi - lo, lo, hi)
    _, lo, hi = best
    return float((lo + hi) / 2), int(fewest), float(lo), float(hi)


def main(argv=None) -> int:
    args = F.fit_arguments(argv, __doc__, "fit_camera_mode", RESULT, writes_json=False)
    t0 = time.time()
    val = F.validation_sets(args.data, args.cache)
    static = [e for evs in val.values() for e in evs]
    swept = F.validation_sweeps(args.cache, val)
    lines = [__doc__.split("\n")[0], "", "    python -m benchmarks.fit_camera_mode --data ../shared/data", "",
             f"Validation: {len(static)} static recordings, {len(swept)} with the camera pitch sweeping 30 deg.", "",
             "smooth mode on the swept clips: time constant (s) -> mean tilt error (deg)"]
    errors = {}
    for tau in SMOOTH_GRID_S:
        errs = []
        for ev in swept:
            R, ok = A.shipped_rotations(ev)
            up = temporal.smooth_rotations(R, ok, ev["fps"], tau)[:, :, 1]
            errs.append(A.clip_error(np.where(ok[:, None], up, np.nan), ev["true_up"]))
        errors[tau] = float(np.nanmean(errs))
        lines.append(f"  {tau:5.2f}  {errors[tau]:.3f}")
    tau = min(errors, key=errors.get)
    lines += [f"SMOOTH_TIME_CONSTANT_S = {tau:g}", "",
              "auto mode: low-pass (s) -> threshold (deg), misreads of "
              f"{len(static) + len(swept)} (static read moving + swept read static), interval"]
    fits = {}
    for lowpass in LOWPASS_GRID_S:
        spread_static = np.array([temporal.up_spread_deg(*A.shipped_rotations(ev), ev["fps"], lowpass) for ev in static])
        spread_swept = np.array([temporal.up_spread_deg(*A.shipped_rotations(ev), ev["fps"], lowpass) for ev in swept])
        thr, wrong, lo, hi = best_threshold(spread_static[np.isfinite(spread_static)],
                                            spread_swept[np.isfinite(spread_swept)])
        fits[lowpass] = (wrong, thr)
        lines.append(f"  {lowpass:5.2f}  {thr:6.2f}  {wrong:3d}  [{lo:.2f}, {hi:.2f}): static read moving "
                     f"{int(np.sum(spread_static > thr))}, swept read static {int(np.sum(spread_swept <= thr))}")
    lowpass = min(fits, key=lambda k: (fits[k][0], k))
    lines += [f"MODE_SMOOTHING_S = {lowpass:g}", f"MODE_THRESHOLD_DEG = {fits[lowpass][1]:.2f}",
              f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
