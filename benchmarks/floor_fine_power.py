"""Decision 0081's trial: the upright fine floor fit at the posture's learning rate, its fused posterior as the intervals.

    python -m benchmarks.floor_fine_power --data ../shared/data [--max-clips 200] [--cache /tmp/pcnet_ablation_cache]

On the held-out recordings with a pelvis path of :mod:`benchmarks.ablation` (its cache; the
Bandai motion-style test, the CMU test subjects and DeepMimic, then the Bandai test split's
other clips; the path a depth sensor measures, and the one recovered from simulated 2D
keypoints), with a level camera and with the camera rolled a quarter turn (the three sets), each
clip's sequence tilt error and whether its printed 95 % pitch and roll intervals both hold the
truth, for two chains of :func:`pcnet.stages.ground_plane.posture_and_floor_up`:

- shipped: the fine fit at full weight, the up model's intervals;
- candidate: the fine fit's footfall loss at the learning rate ``t_f``
  (``footfall_posture_power``, the posture's), and the fused posterior's half-widths where the
  floor moved an upright reading whose other posture keeps under 5 %.

Per row: mean and median tilt error of each, the candidate minus the shipped chain with its
paired 95 % bootstrap interval over clips (:func:`benchmarks.ablation.paired_interval`), decision
0061's verdict (worse: above 0.10 deg with the interval above zero), and both chains' interval
coverage. The rule is in docs/decisions/0081-floor-learning-rate-in-the-fine-fit.md.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks.report import print_and_save
from pcnet.stages.core.rotations import camera_pitch_roll
from pcnet.stages.ground_plane import posture_and_floor_up
from pcnet.stages.up_model import default_parameters, summarise_recording

RESULT = Path(__file__).resolve().parent / "results" / "floor_fine_power.txt"
COMMAND = "python -m benchmarks.floor_fine_power --data ../shared/data"
WORSE_DEG = 0.10


def chain_outcome(ev: dict, joints: np.ndarray, candidate: bool) -> tuple[float, bool]:
    """``(tilt error deg, both intervals hold the truth)`` of one recording's sequence up with
    ``joints`` (camera frame, with its pelvis path) under the shipped chain or the candidate."""
    p = default_parameters()
    R, ok = A.shipped_rotations(ev)
    summary = summarise_recording(A.evidence_of(ev).frames(ok), ev["fps"], p)
    chain = posture_and_floor_up(summary, joints, ok, p, power=p.footfall_posture_power if candidate else 1.0,
                                 fused_intervals=candidate)
    truth = ev["true_up"][np.flatnonzero(ok)[0]]
    err = A.clip_error(np.where(ok[:, None], chain.up, np.nan), ev["true_up"])
    d = np.degrees(np.array(camera_pitch_roll(chain.up)) - np.array(camera_pitch_roll(truth)))
    d[1] = (d[1] + 180.0) % 360.0 - 180.0
    return err, bool(abs(d[0]) <= chain.pitch_half_deg and abs(d[1]) <= chain.roll_half_deg)


def row(title: str, pairs: list[tuple[dict, np.ndarray]]) -> tuple[str, bool]:
    """One table line and whether the candidate is worse there by decision 0061's rule."""
    out = {c: [chain_outcome(ev, J, c) for ev, J in pairs] for c in (False, True)}
    err = {c: np.array([e for e, _ in out[c]]) for c in out}
    hit = {c: 100.0 * np.mean([h for _, h in out[c]]) for c in out}
    diff = err[True] - err[False]
    mean, lo, hi = A.paired_interval(diff)
    worse = mean > WORSE_DEG and lo > 0
    return (f"{title:<58}{len(pairs):>5}{err[False].mean():>8.2f}{np.median(err[False]):>7.2f}{err[True].mean():>8.2f}"
            f"{np.median(err[True]):>7.2f}  {mean:+.2f} [{lo:+.2f}, {hi:+.2f}] {'WORSE' if worse else 'ok':<6}"
            f"{hit[False]:>7.1f}{hit[True]:>7.1f}"), worse


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=A.DEFAULT)
    ap.add_argument("--max-clips", type=int, default=200)
    ap.add_argument("--cache", type=Path, default=A.CACHE)
    args = ap.parse_args(argv)
    A.require_mocap(args.data, "floor_fine_power")
    t0 = time.time()
    static = [A.mocap_set(args.data, args.cache, file, split, args.max_clips) for _, file, split in A.MOCAP_SETS]
    floor_sets = A.floor_recordings(args.data, args.cache, args.max_clips, static)
    quarter = A.rolled_recordings(args.cache, static, args.max_clips, A.QUARTER_DEG)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"{'held-out row':<58}{'clips':>5}{'shipped':>8}{'med':>7}{'cand.':>8}{'med':>7}  cand. - shipped [95 % CI]"
             f"  verdict  cover shipped / cand. (%)"]
    worse = []
    for s, (title, recs) in enumerate(floor_sets):
        for path, k in (("measured path", 1), ("path from 2D keypoints", 2)):
            line, w = row(f"{title}, {path}", [(rec[0], rec[k]) for rec in recs])
            lines.append(line)
            print(line, flush=True)
            worse.append(w)
    for s, (title, recs) in enumerate(floor_sets[:len(A.MOCAP_SETS)]):
        by_index = {ev["index"]: ev for ev in quarter if ev["set"] == s}
        for path, k in (("measured path", 1), ("path from 2D keypoints", 2)):
            pairs = [(by_index[i], rec[k] @ A.roll_matrix(i, A.QUARTER_DEG).T) for i, rec in enumerate(recs)]
            line, w = row(f"{title}, rolled {A.QUARTER_DEG:g} deg, {path}", pairs)
            lines.append(line)
            print(line, flush=True)
            worse.append(w)
    lines += ["", f"rows where the candidate is worse by decision 0061's rule: {sum(worse)} of {len(worse)}",
              f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, RESULT)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
