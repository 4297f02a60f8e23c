"""The floor contacts' two detection rules, each switched off on held-out data (decision 0065).

    python -m benchmarks.floor_pieces --data ../shared/data [--max-clips 200] [--cache /tmp/pcnet_ablation_cache]

The floor contacts (``stages/ground_plane.py``: :func:`pcnet.stages.ground_plane.detect_contacts`)
count an ankle as on the floor where it is within ``h_c`` leg lengths of the frame's lower ankle
(the height band) and slower than ``v_c`` leg lengths per second over ``+-w`` seconds (the speed
criterion). Each rule is switched off alone, every other parameter as shipped
(docs/decisions/0065-floor-contact-detection-ablated.md):

- ``no speed criterion``: ``contact_speed_leg_s`` infinite and ``contact_speed_window_s`` 0 (one
  frame), so every frame's ankle in the band is a contact but the first and the last frame's
  (the central difference has no speed there);
- ``no height band``: ``contact_height_leg`` 0, only each frame's lower ankle.

Held-out rows, as ``benchmarks/ablation.py``'s two floor sections build them from its cache:
the Bandai motion-style test split, the CMU test subjects, DeepMimic and the Bandai test split's
other clips with each clip's pelvis path measured, or recovered from simulated 2D keypoints
(:func:`benchmarks.ablation.measured_root_recordings`); and the first three seen by a camera
rolled :data:`benchmarks.ablation.QUARTER_DEG` deg over both paths, where the footfalls weigh in
the posture. Each row: the mean over clips of the sequence tilt error (deg) of the shipped chain
(:func:`pcnet.stages.rectify.up_model_sequence` with the joints carrying the path) and of each
rule off, with the paired difference (off minus shipped) and its 95 % bootstrap interval over
clips (:func:`benchmarks.ablation.paired_interval`); a rule stays if some row is worse by more
than :data:`benchmarks.view_gate_pieces.MARGIN_DEG` with the interval above zero
(:func:`benchmarks.view_gate_pieces.worse`).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks.report import print_and_save, require_mocap
from benchmarks.view_gate_pieces import MARGIN_DEG, worse
from pcnet.stages import temporal
from pcnet.stages.rectify import up_model_sequence
from pcnet.stages.up_model import UpModelParameters, default_parameters

RESULT = Path(__file__).resolve().parent / "results" / "floor_pieces.txt"
COMMAND = "python -m benchmarks.floor_pieces --data ../shared/data"
#: ``(label, parameters replaced)``: the shipped chain, then each rule off.
SWITCHES = (("shipped", ()),
            ("no speed criterion", (("contact_speed_leg_s", np.inf), ("contact_speed_window_s", 0.0))),
            ("no height band", (("contact_height_leg", 0.0),)))
PATHS = ("measured path", "path from 2D keypoints")


def clip_errors(ev: dict, joints: np.ndarray, params: list[UpModelParameters]) -> list[float]:
    """One recording's sequence tilt error (deg) under each of ``params``, its joints carrying a pelvis path."""
    R, valid, _, _ = A.per_frame(ev, A.VARIANTS[0])
    R, ok = temporal.check_rotations(R, valid)
    evidence = A.evidence_of(ev)
    out = []
    for p in params:
        _, _, seq = up_model_sequence(R, ok, evidence, ev["fps"], joints_cam=joints, params=p)
        out.append(A.clip_error(np.where(ok[:, None], seq.up, np.nan), ev["true_up"]))
    return out


def row(title: str, errors: np.ndarray) -> tuple[str, list[bool]]:
    """A table row from ``(clips, len(SWITCHES))`` errors, and whether each rule off is worse by the rule."""
    cells, verdicts = [], []
    for k in range(1, len(SWITCHES)):
        bad, cell = worse(errors[:, k] - errors[:, 0])
        verdicts.append(bad)
        cells.append(f"{np.mean(errors[:, k]):>8.2f} {cell:<24}{'worse' if bad else '':<6}")
    return f"{title:<58}{len(errors):>6}{np.mean(errors[:, 0]):>9.2f}  " + "".join(cells), verdicts


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=A.DEFAULT)
    ap.add_argument("--max-clips", type=int, default=200)
    ap.add_argument("--cache", type=Path, default=A.CACHE)
    args = ap.parse_args(argv)
    require_mocap(args.data, "floor_pieces")
    t0 = time.time()
    base = default_parameters()
    params = [replace(base, **dict(changes)) for _, changes in SWITCHES]
    floor_sets, static = [], []
    for title, file, split in A.MOCAP_SETS:
        evs = A.mocap_set(args.data, args.cache, file, split, args.max_clips)
        static.append(evs)
        floor_sets.append((title, A.measured_root_recordings(args.data, file, split, args.max_clips, evs)))
    file, split = A.MOCAP_SETS[0][1:]
    rest = A.mocap_set(args.data, args.cache, file, split, args.max_clips, rest=True)
    floor_sets.append(("Bandai test, other clips",
                       A.measured_root_recordings(args.data, file, split, args.max_clips, rest, rest=True)))
    header = (f"{'held-out row':<58}{'clips':>6}{'shipped':>9}  "
              + "".join(f"{label:>8} {'- shipped [95 % CI]':<30}" for label, _ in SWITCHES[1:]))
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND} --max-clips {args.max_clips}", "",
             f"Mean sequence tilt error over clips (deg); a rule stays if switching it off is worse on some row by more "
             f"than {MARGIN_DEG:.2f} deg with the interval above zero.", "", header]
    keeps = np.zeros(len(SWITCHES) - 1, bool)
    for title, recs in floor_sets:
        for path_index, path in enumerate(PATHS):
            errors = np.array([clip_errors(ev, (J, J2d)[path_index], params) for ev, J, J2d in recs])
            line, verdicts = row(f"{title}, {path}", errors)
            keeps |= verdicts
            lines.append(line)
            print(line, flush=True)
    quarter = A.rolled_recordings(args.cache, static, args.max_clips, A.QUARTER_DEG)
    for s, (title, recs) in enumerate(floor_sets[:len(A.MOCAP_SETS)]):
        by_index = {ev["index"]: ev for ev in quarter if ev["set"] == s}
        for path_index, path in enumerate(PATHS):
            errors = np.array([clip_errors(by_index[i], (J, J2d)[path_index] @ A.roll_matrix(i, A.QUARTER_DEG).T, params)
                               for i, (_, J, J2d) in enumerate(recs)])
            line, verdicts = row(f"{title}, rolled {A.QUARTER_DEG:g} deg, {path}", errors)
            keeps |= verdicts
            lines.append(line)
            print(line, flush=True)
    lines += [""] + [f"{label}: {'stays (worse off on some row)' if keep else 'goes (worse off on no row)'}"
                     for (label, _), keep in zip(SWITCHES[1:], keeps)]
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, RESULT)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
