"""The shipped chain on the held-out floor rows, per clip, and paired against a saved earlier run.

    python -m benchmarks.floor_rows --data ../shared/data --save FILE.npz [--max-clips 200]
    python -m benchmarks.floor_rows --data ../shared/data --against FILE.npz

Rows, as ``benchmarks/ablation.py``'s two floor sections build them from its cache
(:func:`benchmarks.ablation.floor_recordings`): the Bandai
motion-style test split, the CMU test subjects, DeepMimic and the Bandai test split's other clips
with each clip's pelvis path measured, or recovered from simulated 2D keypoints
(:func:`benchmarks.ablation.measured_root_recordings`); and the first three seen by a camera
rolled :data:`benchmarks.ablation.QUARTER_DEG` deg over both paths, where the footfalls weigh in
the posture. Each clip's sequence tilt error (deg) of the shipped chain
(:func:`pcnet.stages.rectify.up_model_sequence` with the joints carrying the path).

``--save`` writes the per-clip errors (``allow_pickle=False`` arrays, one per row) so that a run
of another commit can be compared clip by clip: ``--against`` prints, per row, the mean of this
run and of the saved one and the paired difference (this minus saved) with its 95 % bootstrap
interval over clips (:func:`benchmarks.view_gate_pieces.worse`: worse by more than
:data:`benchmarks.view_gate_pieces.MARGIN_DEG` with the interval above zero). Decision 0065's
check: the saved run from git 0c079c4 (the contact rules before their deletion) against the
chain after it (``benchmarks/results/floor_rows.txt``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks.report import print_and_save, require_folder
from benchmarks.view_gate_pieces import MARGIN_DEG, worse
from pcnet.stages.rectify import up_model_sequence

RESULT = Path(__file__).resolve().parent / "results" / "floor_rows.txt"
COMMAND = "python -m benchmarks.floor_rows --data ../shared/data"
PATHS = ("measured path", "path from 2D keypoints")


def clip_error(ev: dict, joints: np.ndarray) -> float:
    """One recording's sequence tilt error (deg) by the shipped chain, its joints carrying a pelvis path."""
    R, ok = A.shipped_rotations(ev)
    _, _, seq = up_model_sequence(R, ok, A.evidence_of(ev), ev["fps"], joints_cam=joints)
    return A.clip_error(np.where(ok[:, None], seq.up, np.nan), ev["true_up"])


def rows(data: Path, cache: Path, max_clips: int) -> dict[str, np.ndarray]:
    """``{row title: (clips,) errors}`` in the module docstring's order."""
    static = [A.mocap_set(data, cache, file, split, max_clips) for _, file, split in A.MOCAP_SETS]
    floor_sets = A.floor_recordings(data, cache, max_clips, static)
    out = {}
    for title, recs in floor_sets:
        for k, path in enumerate(PATHS):
            out[f"{title}, {path}"] = np.array([clip_error(ev, (J, J2d)[k]) for ev, J, J2d in recs])
            print(f"{title}, {path}: {out[f'{title}, {path}'].mean():.2f}", flush=True)
    quarter = A.rolled_recordings(cache, static, max_clips, A.QUARTER_DEG)
    for s, (title, recs) in enumerate(floor_sets[:len(A.MOCAP_SETS)]):
        by_index = {ev["index"]: ev for ev in quarter if ev["set"] == s}
        for k, path in enumerate(PATHS):
            name = f"{title}, rolled {A.QUARTER_DEG:g} deg, {path}"
            out[name] = np.array([clip_error(by_index[i], (J, J2d)[k] @ A.roll_matrix(i, A.QUARTER_DEG).T)
                                  for i, (_, J, J2d) in enumerate(recs)])
            print(f"{name}: {out[name].mean():.2f}", flush=True)
    return out


def saved_rows(path: Path) -> dict[str, np.ndarray]:
    """A ``--save`` file's ``{row title: (clips,) errors}``; exits with one line naming ``path``
    where it is missing or not such a file (read with ``allow_pickle=False``)."""
    try:
        with np.load(path, allow_pickle=False) as saved:
            return {str(name): saved[f"row{i}"] for i, name in enumerate(saved["names"])}
    except (OSError, KeyError, ValueError) as exc:
        raise SystemExit(f"floor_rows: {path}: expected a --save file of an earlier run (names, row0, row1, ...), "
                         f"could not read it: {exc}") from None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=A.DEFAULT)
    ap.add_argument("--max-clips", type=int, default=200)
    ap.add_argument("--cache", type=Path, default=A.CACHE)
    what = ap.add_mutually_exclusive_group(required=True)
    what.add_argument("--save", type=Path, help="write this run's per-clip errors to this .npz")
    what.add_argument("--against", type=Path, help="a --save file of an earlier run: compare clip by clip")
    args = ap.parse_args(argv)
    require_folder(args.data, "floor_rows")
    before = None if args.against is None else saved_rows(args.against)  # read first: a bad file fails at once
    t0 = time.time()
    now = rows(args.data, args.cache, args.max_clips)
    if args.save is not None:
        np.savez(args.save, names=np.array(list(now)), **{f"row{i}": e for i, e in enumerate(now.values())})
        print(f"wrote {args.save}")
        return 0
    if list(before) != list(now) or any(len(before[k]) != len(now[k]) for k in now):
        raise SystemExit(f"floor_rows: {args.against}: its rows or clip counts differ from this run's")
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND} --max-clips {args.max_clips} --against {args.against.name}", "",
             f"Mean sequence tilt error over clips (deg), this run against the saved one; worse: by more than "
             f"{MARGIN_DEG:.2f} deg with the 95 % interval above zero.", "",
             f"{'held-out row':<62}{'clips':>6}{'saved':>8}{'now':>8}  now - saved [95 % CI]"]
    for name, err in now.items():
        bad, cell = worse(err - before[name])
        lines.append(f"{name:<62}{len(err):>6}{before[name].mean():>8.2f}{err.mean():>8.2f}  {cell}"
                     + ("  worse" if bad else ""))
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, RESULT)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
