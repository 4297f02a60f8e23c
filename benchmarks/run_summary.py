"""Best epochs of training runs, from their ``metrics.jsonl`` (written by ``pcnet train``).

    python -m benchmarks.run_summary RUN.metrics.jsonl [...]

Per file: the epochs run, the epoch ``pcnet train`` keeps as ``best.pt`` (lowest validation
rotation error), its validation rotation and tilt errors (deg) and the mean seconds per epoch;
then the mean of the best epochs' errors over the files given (one recipe's seeds), the
numbers a rule over seed means compares (docs/decisions/0049-network-width-and-schedule.md).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def best_epoch(path: Path) -> dict:
    """The ``metrics.jsonl`` record with the lowest ``val_rotation_deg`` (the first on ties),
    with ``epochs`` (records in the file) and ``mean_seconds`` added.

    Raises:
        ValueError: a file with no record, a line that is not a JSON object, or a record
            without the validation fields.
    """
    rows = []
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except json.JSONDecodeError as err:
            raise ValueError(f"{path}: line {n}: expected one JSON record per epoch, got invalid JSON ({err.msg})") from None
        if not isinstance(row, dict):
            raise ValueError(f"{path}: line {n}: expected a JSON object, got {type(row).__name__}")
        rows.append(row)
    if not rows:
        raise ValueError(f"{path}: expected one JSON record per epoch, got none")
    for row in rows:
        if not {"val_rotation_deg", "val_tilt_deg", "seconds"} <= row.keys():
            raise ValueError(f"{path}: expected fields val_rotation_deg, val_tilt_deg and seconds in every record, "
                             f"got {sorted(row)}")
    best = min(rows, key=lambda row: row["val_rotation_deg"])
    return {**best, "epochs": len(rows), "mean_seconds": float(np.mean([row["seconds"] for row in rows]))}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path, help="metrics.jsonl files of one recipe's seeds")
    args = parser.parse_args(argv)
    try:
        best = [best_epoch(path) for path in args.files]
    except (OSError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    print("| run | epochs | best epoch | val rotation (deg) | val tilt (deg) | s / epoch |")
    print("|---|---|---|---|---|---|")
    for path, row in zip(args.files, best):
        print(f"| {path.name} | {row['epochs']} | {row['epoch']} | {row['val_rotation_deg']:.3f} | "
              f"{row['val_tilt_deg']:.3f} | {row['mean_seconds']:.1f} |")
    print(f"| mean of {len(best)} | | | {np.mean([r['val_rotation_deg'] for r in best]):.3f} | "
          f"{np.mean([r['val_tilt_deg'] for r in best]):.3f} | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
