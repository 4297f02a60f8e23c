"""Fit the ankle lines' scale and learning rate (``ankle_line_sd_leg``, ``ankle_line_power``) on validation data.

    python -m benchmarks.fit_ankle_lines --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

The ankle lines (:class:`pcnet.stages.ground_plane.AnkleLines`, decision 0096, second model):
in a frame whose feet are both planted the line between the ankles is level, and it holds
still while the pelvis moves. Per frame, ``delta_t = d_t . g`` (``d_t`` left ankle minus right
ankle in leg lengths, ``g`` the true up) and ``v_t`` the line's velocity (leg lengths per
second). Data: the validation recordings of ``benchmarks/fit_up_model.py`` (Bandai
motion-style val, CMU val subjects; "paper", "wide" and fully rolled static cameras; lifter
noise; root-relative joints). No held-out set is read.

- ``pi``, ``sigma_h``, ``sigma_v``, ``sigma_w`` (``ankle_planted_share``,
  ``ankle_line_sd_leg``, ``ankle_planted_speed_sd``, ``ankle_free_speed_sd``): maximum
  likelihood of the two-state model at the true up over every validation frame with both legs
  and both neighbours (Nelder-Mead on the pooled frames).
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
from scipy.optimize import minimize
from scipy.special import logsumexp

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from pcnet.stages.ground_plane import ankle_line_frames, ankle_lines, posture_and_floor_up
from pcnet.stages.up_model import UpModelParameters, default_parameters, posterior_grid, posture_log_weights, \
    summarise_recording

RESULT = Path(__file__).resolve().parent / "results" / "fit_ankle_lines.txt"
COMMAND = "python -m benchmarks.fit_ankle_lines --data ../shared/data"
POWERS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7, 0.85, 1.0)


def line_frames(ev: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(delta (n,), v (n, 3))``: the left ankle's height above the right one along the true up
    (leg lengths) and the ankle line's velocity (leg lengths per second), over the recording's
    valid frames (:func:`pcnet.stages.ground_plane.ankle_line_frames`)."""
    d, v = ankle_line_frames(ev["J"], ev["valid"], ev["fps"])
    return d @ ev["true_up"][0], v


def fit_states(delta: np.ndarray, v: np.ndarray) -> dict[str, float]:
    """Maximum likelihood of the planted / free model (module docstring) on pooled frames."""
    def nll(x):
        share, sh, sv, sw = 1 / (1 + np.exp(-x[0])), *np.exp(x[1:])
        planted = (np.log(share) - 0.5 * (delta / sh) ** 2 - np.log(np.sqrt(2 * np.pi) * sh)
                   - 0.5 * np.sum(v ** 2, -1) / sv ** 2 - 3 * np.log(np.sqrt(2 * np.pi) * sv))
        free = np.log1p(-share) + np.log(0.5) - 0.5 * np.sum(v ** 2, -1) / sw ** 2 - 3 * np.log(np.sqrt(2 * np.pi) * sw)
        return -np.logaddexp(planted, free).sum()

    x = minimize(nll, [0.0, np.log(0.03), np.log(0.1), np.log(1.0)], method="Nelder-Mead",
                 options={"maxiter": 8000, "xatol": 1e-7, "fatol": 1e-7}).x
    share, sh, sv, sw = 1 / (1 + np.exp(-x[0])), *np.exp(x[1:])
    return {"ankle_planted_share": float(share), "ankle_line_sd_leg": float(sh), "ankle_planted_speed_sd": float(sv),
            "ankle_free_speed_sd": float(sw)}


def main(argv=None) -> int:
    args = F.fit_arguments(argv, __doc__, "fit_ankle_lines", RESULT)
    t0 = time.time()
    val = F.validation_sets(args.data, args.cache)
    base = default_parameters()
    recs = [(key, ev) for key, evs in val.items() for ev in evs if ev["valid"].sum() >= 2]
    frames = [line_frames(ev) for _, ev in recs]
    delta, speed = np.concatenate([f[0] for f in frames]), np.concatenate([f[1] for f in frames])
    states = fit_states(delta, speed)
    unit = replace(base, **states, ankle_line_power=1.0)
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
    for name, value in states.items():
        doc["parameters"][name] = {"value": round(value, 6), "provenance": (
            f"maximum likelihood of the planted / free ankle-line model at the true up, {delta.size} frames, "
            f"{split}; {COMMAND}")}
    doc["parameters"]["ankle_line_power"] = {"value": best, "provenance": (
        f"grid {POWERS}, largest log score of the true up, {split}; {COMMAND}")}
    args.json.write_text(json.dumps(doc, indent=2) + "\n")
    shipped = UpModelParameters.load(args.json.read_text())  # the written file parses
    lines_out = [__doc__.split("\n")[0], "", f"    {COMMAND}", "",
                 f"Data: {split}; {delta.size} frames with both legs and both neighbours.", "",
                 "Two states, maximum likelihood: " + ", ".join(f"{k} {v:.4f}" for k, v in states.items()),
                 f"(|delta| quantiles 50/95 %: {np.quantile(np.abs(delta), 0.5):.3f} / "
                 f"{np.quantile(np.abs(delta), 0.95):.3f} leg lengths; |v| 50/95 %: "
                 f"{np.quantile(np.linalg.norm(speed, axis=1), 0.5):.3f} / "
                 f"{np.quantile(np.linalg.norm(speed, axis=1), 0.95):.3f} leg lengths/s)", "",
                 f"{'t_c':>5}{'log score':>11}"]
    lines_out += [f"{t:>5.2f}{s:>11.1f}" for t, s in zip(POWERS, score)]
    lines_out += ["", f"Shipped: ankle_line_power = {best}", "",
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
