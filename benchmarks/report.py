"""What the text benchmarks share: their command line over a data root, and what they do with
their report (print it and write it under results/)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

#: The project's shared data beside the repository (``--data``'s default; not shipped with pcnet).
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
#: Bootstrap resamples behind every 95 % interval the benchmarks print.
BOOTSTRAP = 2000


def data_arguments(doc: str, data: Path, out: Path, stride: int) -> argparse.Namespace:
    """``--data`` (the data root), ``--stride`` (every k-th frame, >= 1) and ``--out`` (the
    results file), parsed from the command line; the description is ``doc``'s first line."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--data", type=Path, default=data)
    ap.add_argument("--stride", type=int, default=stride)
    ap.add_argument("--out", type=Path, default=out)
    args = ap.parse_args()
    if args.stride < 1:
        ap.error("--stride must be >= 1")
    return args


def _data_and_out(doc: str, out: Path) -> argparse.ArgumentParser:
    """A parser with ``--data`` (the data root, default ``../shared/data``) and ``--out`` (the
    results file, default ``out``), described by ``doc``'s first line."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--out", type=Path, default=out)
    return ap


def trial_arguments(doc: str, out: Path, argv=None, script: str | None = None,
                    needs: str = "mocap") -> argparse.Namespace:
    """``--data`` and ``--out`` (:func:`_data_and_out`), parsed from ``argv``. With ``script``,
    exits with one line naming it where ``--data`` has no ``needs`` folder."""
    args = _data_and_out(doc, out).parse_args(argv)
    if script is not None:
        require_folder(args.data, script, needs)
    return args


def fit_arguments(doc: str, script: str, out: Path, written: Path, option: str = "--json") -> argparse.Namespace:
    """The command line of a script that fits shipped numbers on the mocap: ``--data`` and
    ``--out`` (:func:`_data_and_out`; exits with one line where the data root has no
    ``mocap/``) and ``option`` (where the fit's JSON is written, default ``written``)."""
    ap = _data_and_out(doc, out)
    ap.add_argument(option, type=Path, default=written, help="where the fit's JSON is written")
    args = ap.parse_args()
    require_folder(args.data, script)
    return args


def shipped_limit(value: float, digits: int, upper: bool = True) -> float:
    """A fitted limit rounded to ``digits`` decimals away from the data it envelops: up for an
    upper limit (a statistic above it fires), down for a lower one, so the fit's own extreme
    never fires once rounded."""
    step = 10.0 ** digits
    return (math.ceil(value * step) if upper else math.floor(value * step)) / step


def print_and_save(lines: list[str], out: Path) -> None:
    """Print ``lines`` and write them (newline-terminated) to ``out``, creating its folder."""
    text = "\n".join(lines) + "\n"
    print(text)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)


def require_folder(data: Path, script: str, needs: str = "mocap") -> None:
    """Exit with one line naming ``script`` when ``data`` (the data root) has no ``needs``
    folder."""
    if not (Path(data) / needs).is_dir():
        sys.exit(f"{script}: no {needs}/ folder under {data}; pass --data <data root>")


def write_detector_fit(path: Path, description: str, key: str, value: float, command: str, clips: int,
                       rule: str, at: str) -> None:
    """Write a limit fitted on decision 0077's recordings (``benchmarks.fit_side_swap.recordings``:
    the training mix's training split through the lifter-noise 3D and the simulated detector's
    2D) as ``{"description", key: value, "provenance"}`` JSON, ``at`` the clip that set it."""
    import datetime
    import json

    from benchmarks.mocap_sets import TRAINING_MIX

    path.write_text(json.dumps({
        "description": description, key: value,
        "provenance": {"command": command, "date": datetime.date.today().isoformat(),
                       "data": " + ".join(TRAINING_MIX) + f", motion-style train split ({clips} clips)",
                       "camera": "one static 'paper' view per clip (make_pairs seed 0): 3D with the lifter-noise "
                                 "model, 2D from benchmarks/ablation.detected_keypoints_2d (generator seed 0)",
                       "rule": rule, f"{key}_at": at}}, indent=2) + "\n")
    print(f"wrote {path}")

