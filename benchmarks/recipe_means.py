"""Two training recipes compared by their seed means, from benchmarks/floor_experiment.py's results files.

    python -m benchmarks.recipe_means --a FILE [FILE ...] [--a-shipped] --b FILE [FILE ...]

Each FILE is one candidate camera-frame network scored by ``floor_experiment.py`` (its
"candidate pair" cells: the candidate with the shipped body-frame network, per frame, clean);
``--a-shipped`` counts the files' "shipped pair" cells (the shipped network, the same in every
file) as one more seed of recipe A. Printed per row: each recipe's seeds and their mean, and
the rule of docs/experiments.md ("Floor motions x4 against the shipped recipe, compared by
seed means"): B passes only if (a) its mean held-out floor roll is at least
:data:`ROLL_GAIN_DEG` below A's, (b) on DeepMimic's other clips, the Bandai motion-style test
and the CMU test subjects its mean is at most :data:`TOLERANCE_DEG` above A's, and (c) its mean
number of real Tadasana and Padmasana files passing in frame mode is at least A's. The rule's
text is the decision; this script only does its arithmetic.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROLL_GAIN_DEG = 5.0
TOLERANCE_DEG = 0.05
ROLL = "DeepMimic, floor roll, held out"
NO_WORSE = ("DeepMimic, all other clips", "Bandai motion-style test", "CMU test subjects")
YOGA = ("Tadasana", "Padmasana")


def read_result(path: Path) -> dict[str, dict[str, float]]:
    """``{"shipped": {...}, "candidate": {...}}`` from one ``floor_experiment.py`` results file:
    the pair's mean rotation error (deg) per mocap row and, per yoga asana, the files passing in
    frame mode.

    Raises:
        ValueError: a row this script needs is missing (naming the file and the row).
    """
    values: dict[str, dict[str, float]] = {"shipped": {}, "candidate": {}}
    for line in path.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 4 and cells[0] in (ROLL, *NO_WORSE):
            values["shipped"][cells[0]] = float(cells[2].split("/")[0])
            values["candidate"][cells[0]] = float(cells[3].split("/")[0])
        elif len(cells) >= 3 and cells[0].split(" (")[0] in YOGA:
            asana = cells[0].split(" (")[0]
            for who, cell in (("shipped", cells[1]), ("candidate", cells[2])):
                found = re.search(r"pass (\d+)/\d+", cell)
                if found:
                    values[who][asana] = float(found.group(1))
    for who in values:
        for row in (ROLL, *NO_WORSE, *YOGA):
            if row not in values[who]:
                raise ValueError(f"{path}: expected floor_experiment.py's row {row!r} ({who}), found none")
    return values


def seeds(paths: list[Path], shipped: bool) -> list[dict[str, float]]:
    results = [read_result(p) for p in paths]
    out = [r["candidate"] for r in results]
    return out + [results[0]["shipped"]] if shipped and results else out


def mean(rows: list[dict[str, float]], key: str) -> float:
    return sum(r[key] for r in rows) / len(rows)


def compare(a: list[dict[str, float]], b: list[dict[str, float]]) -> tuple[list[str], bool]:
    """The printed table and whether B passes the rule."""
    lines = [f"  {'row':<34}{'A seeds':<28}{'A mean':>8}   {'B seeds':<22}{'B mean':>8}  clause"]
    ok = True
    for row in (ROLL, *NO_WORSE, *YOGA):
        ma, mb = mean(a, row), mean(b, row)
        if row == ROLL:
            passed, clause = mb <= ma - ROLL_GAIN_DEG, f"B <= A - {ROLL_GAIN_DEG:g}"
        elif row in NO_WORSE:
            passed, clause = mb <= ma + TOLERANCE_DEG, f"B <= A + {TOLERANCE_DEG:g}"
        else:
            passed, clause = mb >= ma, "B >= A (files passing)"
        ok &= passed
        fa = " ".join(f"{r[row]:g}" for r in a)
        fb = " ".join(f"{r[row]:g}" for r in b)
        lines.append(f"  {row:<34}{fa:<28}{ma:>8.3f}   {fb:<22}{mb:>8.3f}  {clause}: {'pass' if passed else 'FAIL'}")
    return lines, ok


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--a", type=Path, nargs="+", required=True, help="floor_experiment.py results of recipe A's seeds")
    ap.add_argument("--a-shipped", action="store_true", help="count the shipped pair as one more seed of A")
    ap.add_argument("--b", type=Path, nargs="+", required=True, help="floor_experiment.py results of recipe B's seeds")
    args = ap.parse_args(argv)
    try:
        a, b = seeds(args.a, args.a_shipped), seeds(args.b, False)
    except (OSError, ValueError) as err:
        print(f"recipe_means: {err}", file=sys.stderr)
        return 1
    lines, ok = compare(a, b)
    print("\n".join(lines + ["", f"B {'passes' if ok else 'does not pass'} the rule"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
