"""What the heading benchmarks share: their command line, and angles on a circle in degrees."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def heading_arguments(doc: str, out: Path, argv=None) -> argparse.Namespace:
    """``--data`` (the data root) and ``--out`` (the results file, default ``out``), parsed from
    ``argv``; the description is ``doc``'s first line."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--out", type=Path, default=out)
    return ap.parse_args(argv)


def wrapped_deg(d):
    """``d`` (deg, scalar or array) wrapped into [-180, 180)."""
    return (np.asarray(d, np.float64) + 180.0) % 360.0 - 180.0


def circular_mean_deg(a: np.ndarray) -> float:
    """Circular mean (deg) of the finite angles in ``a`` (deg); NaN when none is finite."""
    r = np.radians(np.asarray(a, np.float64))
    r = r[np.isfinite(r)]
    return float(np.degrees(np.arctan2(np.sin(r).mean(), np.cos(r).mean()))) if len(r) else float("nan")
