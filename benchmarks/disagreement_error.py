"""Does the two networks' disagreement over a recording predict the up model's error there? (validation only)

    python -m benchmarks.disagreement_error --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Exploratory, for issue 49's sequence intervals (DeepMimic's coverage is below 90 %): a
systematic error that grows with the networks' disagreement could widen the intervals where the
motion is new, if the disagreement tracked the error. Per validation recording of
benchmarks/fit_up_model.py (no held-out set is read): the up model's summary error, the angle
between the truth and ``g_hat`` (:func:`pcnet.stages.up_model.summarise_recording`), and the
angle between the two networks' robust mean ups (:func:`pcnet.stages.spherical.robust_mean_direction`).
Printed: their Spearman correlation over all recordings and per set, and the RMS error in bins
of the disagreement. Writes ``benchmarks/results/disagreement_error.txt``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from pcnet.stages.spherical import robust_mean_direction
from pcnet.stages.up_model import default_parameters, log_map, summarise_recording

RESULT = Path(__file__).resolve().parent / "results" / "disagreement_error.txt"
COMMAND = "python -m benchmarks.disagreement_error --data ../shared/data"
#: Quantiles of the disagreement that bound the bins of the RMS error.
BIN_QUANTILES = (0.0, 0.5, 0.8, 0.95, 1.0)


def recording_row(ev: dict, p) -> tuple[float, float] | None:
    """``(summary error, disagreement)`` (deg) of one validation recording; ``None`` with fewer
    than 10 frames where both networks answered."""
    e = A.evidence_of(ev)
    ok = e.valid & np.isfinite(e.camera_up).all(-1) & np.isfinite(e.body_up).all(-1)
    if ok.sum() < 10:
        return None
    g = ev["true_up"][np.flatnonzero(e.valid)[0]]
    error = float(np.degrees(np.linalg.norm(log_map(g, summarise_recording(e, ev["fps"], p).up))))
    c, b = robust_mean_direction(e.camera_up[ok])[0], robust_mean_direction(e.body_up[ok])[0]
    return error, float(np.degrees(np.arccos(np.clip(c @ b, -1.0, 1.0))))


def main(argv=None) -> int:
    args = F.fit_arguments(argv, __doc__, "disagreement_error", RESULT, writes_json=False)
    t0 = time.time()
    p = default_parameters()
    rows = []
    for (tag, views), evs in F.validation_sets(args.data, args.cache).items():
        rows += [(f"{tag} {views}", *r) for ev in evs if (r := recording_row(ev, p)) is not None]
    sets = [r[0] for r in rows]
    err, dis = np.array([r[1] for r in rows]), np.array([r[2] for r in rows])
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", "",
             f"Validation recordings: {len(rows)}; the shipped parameters (stages/data/up_model.json).", "",
             f"{'set':<16}{'recordings':>11}{'Spearman':>10}{'median error':>14}{'median disagreement':>21}",
             f"{'all':<16}{len(rows):>11}{spearmanr(err, dis).correlation:>10.2f}{np.median(err):>14.2f}"
             f"{np.median(dis):>21.2f}"]
    for s in sorted(set(sets)):
        m = np.array([x == s for x in sets])
        lines.append(f"{s:<16}{m.sum():>11}{spearmanr(err[m], dis[m]).correlation:>10.2f}{np.median(err[m]):>14.2f}"
                     f"{np.median(dis[m]):>21.2f}")
    lines += ["", "RMS summary error (deg) by the disagreement's quantile bins:"]
    edges = np.quantile(dis, BIN_QUANTILES)
    for lo, hi, qlo, qhi in zip(edges[:-1], edges[1:], BIN_QUANTILES[:-1], BIN_QUANTILES[1:]):
        m = (dis >= lo) & (dis <= hi)
        lines.append(f"  quantiles {qlo:.2f}-{qhi:.2f} (disagreement {lo:.1f}-{hi:.1f} deg): {m.sum()} recordings, "
                     f"RMS error {np.sqrt(np.mean(err[m] ** 2)):.2f}")
    lines += ["", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
