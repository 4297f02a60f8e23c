"""Fit the learning rate of the footfalls in the posture's posterior (``footfall_posture_power``, t_f) on validation data.

    python -m benchmarks.fit_floor_power --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Run after ``python -m benchmarks.fit_floor_contacts`` (it uses that fit's footfall error
model). Updates ``footfall_posture_power`` in ``stages/data/up_model.json``
with its provenance and writes ``benchmarks/results/fit_floor_power.txt``. No held-out set is
read.

Why a power. The posture's posterior (:func:`pcnet.stages.up_model.posture_log_weights`) scores
the footfalls along every candidate up of either posture, over the whole sphere
(:class:`pcnet.stages.ground_plane.FloorEnergy`). There the floor's model is misspecified: it
counts every footfall as an independent observation, while a lifter's per-joint bias and a
path's drift move many of them together, and noisy footfalls along a straight walk line up along
more than one up. At full weight the footfalls then read some upright walks as lying bodies. As
for a misspecified model's generalised posterior, the footfalls' Tukey loss enters at a
learning rate, ``exp(-(t_f loss + level cost))``; the cost of each level beyond the first is
a prior over support levels and keeps its weight. The same rate enters the upright fine fit
(:func:`pcnet.stages.ground_plane.fit_floor`; decision 0081: one tempered posterior, worse on
no held-out row than the fine fit at full weight); it is fitted here on the posture alone.

Fit. Data: the validation recordings of ``benchmarks/fit_floor_contacts.py`` (Bandai
motion-style val, CMU val subjects; "paper", "wide" and fully rolled static cameras; lifter
noise), each twice: with the pelvis path a depth sensor measures and with the one a monocular
run recovers from simulated 2D keypoints. Every recording is upright (the training and
validation motion capture holds no recording of a body lying on the floor), and the floor's
term is the same for both postures, so it pulls towards neither. ``t_f`` maximises the log
score of the true posture, ``sum log P(upright | poses, footfalls)``, on a grid (``t_f = 0``:
the footfalls switched off in the posture). Too small a rate leaves the cameras rolled towards
a quarter turn read as lying bodies, too large a one reads some upright walks as lying.

Checks at the fitted rate (nothing fitted on them): per validation set and path, the recordings
read as lying and the mean tilt error of the chain's up (the posture's posterior with the
footfalls, then the upright fine fit), against the chain without the footfalls in the posture.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks import fit_floor_contacts as FF
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from pcnet.stages.ground_plane import floor_energy, posture_and_floor_up
from pcnet.stages.up_model import UpModelParameters, default_parameters, posture_log_weights

RESULT = Path(__file__).resolve().parent / "results" / "fit_floor_power.txt"
COMMAND = "python -m benchmarks.fit_floor_power --data ../shared/data"
POWERS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7, 0.85, 1.0)
PATHS = ("measured", "from 2D")


def lying_probabilities(recs: list[FF.Recording], p: UpModelParameters) -> np.ndarray:
    """``(R, 2, len(POWERS))``: P(lying) of each recording, path (:data:`PATHS`) and power."""
    out = np.zeros((len(recs), len(PATHS), len(POWERS)))
    for i, r in enumerate(recs):
        lu0, ll0 = posture_log_weights(r.post.summary, p)
        for j, J in enumerate((r.joints, r.joints_2d)):
            energy = floor_energy(J, r.ok & np.isfinite(J).all((1, 2)), r.post.summary.up, p)[0]
            terms = {}

            def scored(t, ups, energy=energy, terms=terms):  # the footfalls' terms once per recording
                if "loss" not in terms:
                    terms["loss"], terms["levels"] = energy.terms(ups)
                return t * terms["loss"] + terms["levels"]

            for k, t in enumerate(POWERS):
                if t == 0 or energy is None:  # the footfalls switched off in the posture
                    lu, ll = lu0, ll0
                else:
                    lu, ll = posture_log_weights(r.post.summary, p, floor=lambda ups, t=t: scored(t, ups))
                top = max(lu.max(), ll.max())
                wu, wl = np.exp(lu - top).sum(), np.exp(ll - top).sum()
                out[i, j, k] = wl / (wu + wl)
    return out


def chain_errors(recs: list[FF.Recording], p: UpModelParameters, footfalls: bool) -> tuple[np.ndarray, np.ndarray]:
    """``((R, 2) tilt error deg, (R, 2) read lying)`` of the chain's up per recording and path
    (:func:`pcnet.stages.ground_plane.posture_and_floor_up`, with the footfalls in the posture
    where ``footfalls``)."""
    err, lying = np.zeros((len(recs), 2)), np.zeros((len(recs), 2), bool)
    for i, r in enumerate(recs):
        for j, J in enumerate((r.joints, r.joints_2d)):
            ok = r.ok & np.isfinite(J).all((1, 2))
            chain = posture_and_floor_up(r.post.summary, J, ok, p, footfalls=footfalls)
            err[i, j], lying[i, j] = float(A.deg(chain.up, r.true_up)), chain.posterior.posture == "lying"
    return err, lying


def main(argv=None) -> int:
    args = F.fit_arguments(argv, __doc__, "fit_floor_power", RESULT)
    t0 = time.time()
    recs = FF.recordings(args.data, args.cache)
    base = default_parameters()
    sets = sorted({r.set for r in recs})
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", "",
             f"Validation: {len(recs)} recordings ({', '.join(f'{s} {sum(r.set == s for r in recs)}' for s in sets)}), "
             f"each with the measured path and the path from 2D keypoints; lifter noise.", "",
             f"{'t_f':>5}{'log score':>11}  recordings read as lying (of {2 * len(recs)})"]
    p_lying = lying_probabilities(recs, base)
    score = np.log(np.clip(1.0 - p_lying, 1e-300, None)).sum((0, 1))
    for k, t in enumerate(POWERS):
        lines.append(f"{t:>5.2f}{score[k]:>11.2f}  {int(np.sum(p_lying[:, :, k] > 0.5))}")
    best = POWERS[int(np.argmax(score))]
    split = (f"validation ({len(recs)} recordings: Bandai motion-style val + CMU val subjects, paper/wide/rolled static "
             f"cameras, lifter noise, the measured pelvis path and the one from 2D keypoints)")
    doc = json.loads(args.json.read_text())
    doc["parameters"]["footfall_posture_power"] = {"value": best, "provenance": (
        f"grid {POWERS}, largest log score of the true (upright) posture, {split}; {COMMAND}")}
    args.json.write_text(json.dumps(doc, indent=2) + "\n")
    shipped = UpModelParameters.load(args.json.read_text())  # the written file parses
    lines += ["", f"Shipped: footfall_posture_power = {best}", "",
              "Check at the shipped rate: mean tilt error of the chain's up (deg) / recordings read as lying, without "
              "the footfalls in the posture -> with them",
              f"{'validation set':<16}{'recordings':>11}  " + "  ".join(f"{name:>24}" for name in PATHS)]
    err0, lying0 = chain_errors(recs, shipped, footfalls=False)
    err1, lying1 = chain_errors(recs, shipped, footfalls=True)
    for s in sets + ["all"]:
        m = np.array([s == "all" or r.set == s for r in recs])
        cells = "  ".join(f"{err0[m, j].mean():>7.2f} {int(lying0[m, j].sum()):>3} -> {err1[m, j].mean():>5.2f} "
                          f"{int(lying1[m, j].sum()):>3}" for j in range(2))
        lines.append(f"{s:<16}{m.sum():>11}  {cells}")
    lines += ["(without: the footfalls only in the upright fine fit, as shipped before decision 0048)", "",
              f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
