"""Which of the up model's parameter pairs the validation data can tell apart (decision 0059, part 1).

    python -m benchmarks.parameter_selection --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Writes ``benchmarks/results/parameter_selection.txt``. No held-out set is read: the data are
the validation recordings of benchmarks/fit_up_model.py, under the parameters in
``stages/data/up_model.json`` (the committed results file: those before decision 0059, commit
c9a0514; the decision records the same verdicts under the ones shipped since).

1. The networks' scatters: ``sigma_b`` and ``sigma_c`` free against one ``sigma``
   (:func:`benchmarks.fit_up_model.fit_scatter`), each clip's log-likelihood divided by its
   ``m = max(1, tau fps)`` as the up model divides it
   (:func:`pcnet.stages.up_model.frames_per_error`); ``BIC = -2 log L + k log n`` with
   ``n = sum over clips of frames / m``.
2. The systematic error: ``S`` diagonal against ``s^2 I``
   (:func:`benchmarks.fit_up_model.fit_systematic`); ``n`` = recordings.
The smaller model is chosen where its BIC is not larger. (A third criterion, whether the
floor's per-ankle offset ``s_o`` could be told from zero, kept it in decisions 0059 and 0067;
switched off on held-out data it moved nothing, and decision 0091 deleted it.)
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from pcnet.stages.up_model import default_parameters, frames_per_error

RESULT = Path(__file__).resolve().parent / "results" / "parameter_selection.txt"
COMMAND = "python -m benchmarks.parameter_selection --data ../shared/data"


def bic(log_l: float, k: int, n: float) -> float:
    """Schwarz's criterion ``-2 log L + k log n``."""
    return -2.0 * log_l + k * np.log(n)


def verdict(smaller_wins: bool, smaller: str) -> str:
    return f"choose {smaller}" if smaller_wins else "keep both"


def main(argv=None) -> int:
    args = F.fit_arguments(argv, __doc__, "parameter_selection", RESULT, writes_json=False)
    t0 = time.time()
    p = default_parameters()
    evs = F.validation_sets(args.data, args.cache)
    all_evs = [e for v in evs.values() for e in v]
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", "",
             f"Validation: {len(all_evs)} recordings of benchmarks/fit_up_model.py; the shipped parameters "
             f"(stages/data/up_model.json).", ""]

    rc, rb, rates = F.residuals(F.tangent_errors(all_evs, p))
    m = np.array([frames_per_error(fps, p) for fps in rates])
    n = float(sum(len(r) / mi for r, mi in zip(rc, m)))
    free = F.fit_scatter(rc, rb, weights=1 / m)
    tied = F.fit_scatter(rc, rb, tied=True, weights=1 / m)
    b_free, b_tied = bic(free[3], 3, n), bic(tied[3], 2, n)
    lines += [f"1. Scatter: {len(rc)} clips, {sum(map(len, rc))} frames, m = {m.min():.2f}-{m.max():.2f}, "
              f"n = {n:.0f}",
              f"   free:  sigma_b {free[0]:.4f}, sigma_c {free[1]:.4f} deg, eps {free[2]:.4f}; "
              f"log L / m {free[3]:.2f}; BIC {b_free:.2f}",
              f"   tied:  sigma {tied[0]:.4f} deg, eps {tied[2]:.4f}; log L / m {tied[3]:.2f}; BIC {b_tied:.2f}",
              f"   BIC tied - free {b_tied - b_free:+.2f}: {verdict(b_tied <= b_free, 'one sigma')}", ""]

    es, covs = F.summary_errors(all_evs, p)
    diag = F.fit_systematic(es, covs)
    iso = F.fit_systematic(es, covs, isotropic=True)
    b_diag, b_iso = bic(diag[2], 2, len(es)), bic(iso[2], 1, len(es))
    lines += [f"2. Systematic error: {len(es)} recordings",
              f"   diagonal:  s_pitch {diag[0]:.4f}, s_roll {diag[1]:.4f} deg; log L {diag[2]:.2f}; BIC {b_diag:.2f}",
              f"   isotropic: s {iso[0]:.4f} deg; log L {iso[2]:.2f}; BIC {b_iso:.2f}",
              f"   BIC isotropic - diagonal {b_iso - b_diag:+.2f}: {verdict(b_iso <= b_diag, 'one s')}", ""]

    lines += [f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
