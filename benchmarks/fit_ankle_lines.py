"""Fit the ankle lines' scale and learning rate (``ankle_line_sd_leg``, ``ankle_line_power``) on validation data.

    python -m benchmarks.fit_ankle_lines --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

The ankle lines (:class:`pcnet.stages.ground_plane.AnkleLines`, decision 0096): in a frame whose
feet both rest on the floor the line between the ankles is level, so its height difference
along the true up, ``delta_t = d_t . g`` (``d_t`` left ankle minus right ankle in leg lengths),
is small. Data: the validation recordings of ``benchmarks/fit_up_model.py`` (Bandai motion-style
val, CMU val subjects; "paper", "wide" and fully rolled static cameras; lifter noise;
root-relative joints). No held-out set is read.

- ``sigma_c``: the RMS of ``delta_t`` at the true up over every validation frame with both legs
  (the maximum-likelihood scale of a zero-mean Gaussian; double stance, feet in swing and lifter
  noise pooled: a Gaussian-plus-uniform mixture fitted to the same frames put no weight on the
  uniform part).
- ``t_c``: the frames share their errors, so the sum over frames enters at a learning rate, as
  for a misspecified model's generalised posterior (the floor's ``t_f``: benchmarks/fit_floor_power.py).
  It maximises, on a grid, the log score of the true up, ``sum log p(g_true | poses, ankle
  lines)`` over the recordings, the posterior density per steradian over both postures on the
  up model's ~1 deg sphere grid (the grid point nearest the truth). ``t_c = 0``: no ankle lines.

Checks at the fitted values (nothing fitted on them): per validation set, the mean tilt error of
the posture's posterior up (:func:`pcnet.stages.ground_plane.posture_and_floor_up`, no pelvis
path) and the recordings read as lying, without and with the ankle lines. Updates the two
parameters in ``stages/data/up_model.json`` with their provenance and writes
``benchmarks/results/fit_ankle_lines.txt``.
"""

from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.special import logsumexp

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from pcnet.stages.core.conventions import L_ANKLE, R_ANKLE
from pcnet.stages.ground_plane import ankle_lines, leg_length, posture_and_floor_up
from pcnet.stages.up_model import UpModelParameters, default_parameters, posterior_grid, posture_log_weights, \
    summarise_recording

RESULT = Path(__file__).resolve().parent / "results" / "fit_ankle_lines.txt"
COMMAND = "python -m benchmarks.fit_ankle_lines --data ../shared/data"
POWERS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7, 0.85, 1.0)


def height_differences(ev: dict) -> np.ndarray:
    """``delta_t`` ``(n,)``: the left ankle's height above the right one along the true up, in leg
    lengths, over the recording's valid frames with both legs."""
    J = np.asarray(ev["J"], np.float64)
    ok = ev["valid"] & np.isfinite(J).all((1, 2))
    if not ok.any():
        return np.zeros(0)
    return (J[ok, L_ANKLE] - J[ok, R_ANKLE]) @ ev["true_up"][0] / leg_length(J, ok)


def main(argv=None) -> int:
    args = F.fit_arguments(argv, __doc__, "fit_ankle_lines", RESULT)
    t0 = time.time()
    val = F.validation_sets(args.data, args.cache)
    base = default_parameters()
    recs = [(key, ev) for key, evs in val.items() for ev in evs if ev["valid"].sum() >= 2]
    delta = np.concatenate([height_differences(ev) for _, ev in recs])
    sigma = float(np.sqrt(np.mean(delta ** 2)))
    unit = replace(base, ankle_line_sd_leg=sigma, ankle_line_power=1.0)
    grid = posterior_grid()
    cell = np.log(4 * np.pi / len(grid))
    score = np.zeros(len(POWERS))
    summaries = []
    for _, ev in recs:
        e = A.evidence_of(ev)
        summary = summarise_recording(e.frames(e.valid), ev["fps"], base)
        summaries.append(summary)
        lu0, ll0 = posture_log_weights(summary, base)
        lines = ankle_lines(ev["J"], e.valid, ev["fps"], unit)
        energy = np.zeros(len(grid)) if lines is None else lines(grid)
        truth = int(np.argmax(grid @ ev["true_up"][0]))
        for k, t in enumerate(POWERS):
            total = np.logaddexp(lu0 - t * energy, ll0 - t * energy)
            score[k] += total[truth] - logsumexp(total) - cell
    best = POWERS[int(np.argmax(score))]
    split = (f"validation ({len(recs)} recordings: Bandai motion-style val + CMU val subjects, paper/wide/rolled static "
             f"cameras, lifter noise, root-relative joints)")
    doc = json.loads(args.json.read_text())
    doc["parameters"]["ankle_line_sd_leg"] = {"value": round(sigma, 6), "provenance": (
        f"RMS of the ankles' height difference along the true up, {delta.size} frames, {split}; {COMMAND}")}
    doc["parameters"]["ankle_line_power"] = {"value": best, "provenance": (
        f"grid {POWERS}, largest log score of the true up, {split}; {COMMAND}")}
    args.json.write_text(json.dumps(doc, indent=2) + "\n")
    shipped = UpModelParameters.load(args.json.read_text())  # the written file parses
    lines_out = [__doc__.split("\n")[0], "", f"    {COMMAND}", "",
                 f"Data: {split}; {delta.size} frames with both legs.", "",
                 f"sigma_c = {sigma:.4f} leg lengths (|delta| quantiles 50/95 %: "
                 f"{np.quantile(np.abs(delta), 0.5):.3f} / {np.quantile(np.abs(delta), 0.95):.3f})", "",
                 f"{'t_c':>5}{'log score':>11}"]
    lines_out += [f"{t:>5.2f}{s:>11.1f}" for t, s in zip(POWERS, score)]
    lines_out += ["", f"Shipped: ankle_line_sd_leg = {sigma:.6f}, ankle_line_power = {best}", "",
                  "Check at the shipped values: mean tilt error of the posterior's up (deg) / recordings read as lying, "
                  "without -> with the ankle lines",
                  f"{'validation set':<18}{'recordings':>11}  without        with"]
    off = replace(shipped, ankle_line_power=0.0)
    rows = []
    for (key, ev), summary in zip(recs, summaries):
        ok = ev["valid"]
        out = []
        for p in (off, shipped):
            chain = posture_and_floor_up(summary, None, ok, p, lines=ankle_lines(ev["J"], ok, ev["fps"], p))
            out += [float(A.deg(chain.up, ev["true_up"][0])), chain.posterior.posture == "lying"]
        rows.append((f"{key[0]} {key[1]}", *out))
    for name in sorted({r[0] for r in rows}) + ["all"]:
        sel = [r for r in rows if name in ("all", r[0])]
        a = np.array([r[1:] for r in sel], float)
        lines_out.append(f"{name:<18}{len(sel):>11}  {a[:, 0].mean():6.2f} {int(a[:, 1].sum()):3d}  {a[:, 2].mean():6.2f} "
                         f"{int(a[:, 3].sum()):3d}")
    lines_out += ["", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines_out, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
