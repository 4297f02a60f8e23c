"""Sequence mode's up estimator: the robust spherical mean (Weiszfeld + Tukey biweight,
stages/spherical.py) against the simpler normalised coordinate-wise median of the per-frame ups.

    python -m benchmarks.sequence_up_estimator --data ../shared/data

The same runs as the README's held-out sequence rows (`pcnet evaluate --method M --data D
--split S --camera per-clip --noise lifter --mode sequence`), once as shipped and once with the
median swapped in for the robust mean (pooling and bootstrap alike). Tilt error in degrees,
mean / median / p95, and invalid frames. Writes benchmarks/results/sequence_up_estimator.txt.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import pcnet.stages.temporal as temporal
from benchmarks.report import SHARED_DATA
from pcnet.pipeline.evaluate import evaluate
from pcnet.stages.core.rotations import normalize

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "sequence_up_estimator.txt"
SETS = (("Bandai motion-style test", "bandai_h36m17.npz", "test"), ("CMU test subjects", "cmu_train_h36m17.npz", "test"),
        ("DeepMimic all", "deepmimic_h36m17.npz", "all"))


def median_direction(u: np.ndarray, w: np.ndarray | None = None, init: np.ndarray | None = None):
    """Normalised coordinate-wise median of ``(N, 3)`` / ``(B, N, 3)`` unit vectors (rows with
    zero weight or NaN ignored); the robust mean's signature, no scale (``None``)."""
    u = np.asarray(u, np.float64)
    single = u.ndim == 2
    u = u[None] if single else u
    w = np.ones(u.shape[:2]) if w is None else np.broadcast_to(np.asarray(w, np.float64), u.shape[:2])
    m = normalize(np.nanmedian(np.where(((w > 0) & np.isfinite(u).all(-1))[..., None], u, np.nan), axis=1))
    return (m[0], None) if single else (m, None)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    args = ap.parse_args()
    shipped = temporal.robust_mean_direction
    lines = ["python -m benchmarks.sequence_up_estimator",
             "| data | method | robust mean (shipped): tilt mean / median / p95 (invalid) | coordinate-wise median |",
             "|---|---|---|---|"]
    for label, file, split in SETS:
        for method in ("pcnet", "geometric"):
            cells = []
            for estimator in (shipped, median_direction):
                temporal.robust_mean_direction = estimator
                r = evaluate(method, args.data / "mocap" / file, split, camera="per-clip", noise="lifter", mode="sequence")
                t = r["tilt_deg"]
                cells.append(f"{t['mean']:.2f} / {t['median']:.2f} / {t['p95']:.2f} ({r['invalid_frames']})")
            temporal.robust_mean_direction = shipped
            lines.append(f"| {label} | {method} | {cells[0]} | {cells[1]} |")
            print(lines[-1], flush=True)
    RESULT.write_text("\n".join(lines) + "\n")
    print(f"wrote {RESULT}")


if __name__ == "__main__":
    main()
