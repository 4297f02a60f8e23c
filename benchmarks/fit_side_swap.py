"""The side-swap check's agreement limit fitted on training mocap, and its checks against the hand-set check.

    python -m benchmarks.fit_side_swap --data ../shared/data

Decision 0077. Fit: the training mix's training split (benchmarks/mocap_sets.py: Bandai
motion-style train, CMU training subjects), every clip seen by one static "paper" camera
(``benchmarks.ablation.static_camera_clips``: ``make_pairs(..., seed=0, camera="static")`` with
the lifter-noise model, its left/right swaps included) for the 3D, and by the benchmarks'
simulated detector for the 2D (``benchmarks.ablation.detected_keypoints_2d``, generator seed 0).
Per clip the agreement of ``stages/flags.side_agreement`` (the cosine between the 2D and 3D
left-right extents of the hips and shoulders); the limit is the smallest over the clips
(parameter-free, as decisions 0034, 0072 and 0075), recorded with the clip that set it.

Checks (the rule): on the held-out mocap (Bandai motion-style test, the ablation's 200-clip
subset; CMU test subjects; DeepMimic), seen as in the fit, the candidate (agreement below the
limit) and the hand-set check (:func:`hand_set_flagged`, ``stages/flags.side_swap_flag`` before the decision)
on each recording as it is (false alarms) and with its 3D sides exchanged (detections); on the
real boxing pair (the committed AlphaPose 2D and MotionBERT 3D fixtures), as it is and
exchanged. Writes stages/data/side_swap.json where the candidate passes.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks.ablation import MOCAP_SETS, detected_keypoints_2d, heldout_clips, static_camera_clips
from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import fit_arguments, print_and_save, shipped_limit, write_detector_fit
from pcnet.adapters import get_2d_adapter
from pcnet.stages.flags import side_agreement, side_extents
from pcnet.stages.remap import remap_to_h36m

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "fit_side_swap.txt"
JSON = ROOT / "stages" / "data" / "side_swap.json"
COMMAND = "python -m benchmarks.fit_side_swap --data ../shared/data"
#: H36M-17 with left and right exchanged (a wrong joint order).
EXCHANGED = [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]
MAX_CLIPS = 200
FIXTURES = ROOT / "tests" / "fixtures"


def recordings(clips, max_clips: int, rng: np.random.Generator):
    """``(name, 2D keypoints (T, 17, 3), 3D camera-frame poses (T, 17, 3))`` per clip."""
    for clip, X, R, frames in static_camera_clips(clips, max_clips):
        yield clip.name, detected_keypoints_2d(clip, frames, R, rng), X


#: The hand-set check before decision 0077: pairs spanning at least this share of the trunk in
#: both count, and more than this share of at least this many counted pairs must disagree.
HAND_SET_MIN_EXTENT, HAND_SET_SHARE, HAND_SET_MIN_PAIRS = 0.1, 0.5, 10


def hand_set_flagged(kp: np.ndarray, X: np.ndarray) -> bool:
    d2, d3 = side_extents(kp, X)
    with np.errstate(invalid="ignore"):
        sure = (np.abs(d2) >= HAND_SET_MIN_EXTENT) & (np.abs(d3) >= HAND_SET_MIN_EXTENT)
    counted = int(sure.sum())
    return counted >= HAND_SET_MIN_PAIRS and int((np.sign(d2[sure]) != np.sign(d3[sure])).sum()) > HAND_SET_SHARE * counted


def agreement(kp: np.ndarray, X: np.ndarray) -> float:
    return side_agreement(*side_extents(kp, X))


def main() -> None:
    args = fit_arguments(__doc__, "fit_side_swap", RESULT, JSON)
    t0 = time.perf_counter()
    (train,) = training_mix_splits(args.data, "train")
    fit = [(name, agreement(kp, X)) for name, kp, X in recordings(train, len(train), np.random.default_rng(0))]
    finite = [(n, a) for n, a in fit if np.isfinite(a)]
    at, lowest = min(finite, key=lambda na: na[1])
    limit = shipped_limit(lowest, 4, upper=False)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"Fit: {len(fit)} training clips ({len(finite)} with an agreement); agreement percentiles 1/5/50: "
             + " / ".join(f"{np.percentile([a for _, a in finite], q):.3f}" for q in (1, 5, 50)),
             f"limit (the smallest): {limit:.4f}, set by {at} ({lowest:.6f} rounded down to 0.0001)", "",
             "Held-out mocap: recordings flagged as they are (false alarms, budget 1 in 20 per set) and with the 3D "
             "sides exchanged (detections)", "",
             f"{'set':30s} {'n':>5s} {'false: fitted':>14s} {'hand-set':>9s} {'detected: fitted':>17s} {'hand-set':>9s}"]
    false_ok, detected = True, {"fitted": 0, "hand-set": 0}
    for label, file, split in MOCAP_SETS:
        clips = heldout_clips(args.data, file, split)
        n = fa_fit = fa_hand = de_fit = de_hand = 0
        for _, kp, X in recordings(clips, MAX_CLIPS, np.random.default_rng(0)):
            a = agreement(kp, X)
            n += 1
            fa_fit += a < limit
            de_fit += -a < limit
            fa_hand += hand_set_flagged(kp, X)
            de_hand += hand_set_flagged(kp, X[:, EXCHANGED])
        false_ok &= fa_fit <= n / 20
        detected["fitted"] += de_fit
        detected["hand-set"] += de_hand
        lines.append(f"{label:30s} {n:5d} {fa_fit:14d} {fa_hand:9d} {de_fit:17d} {de_hand:9d}")
    kp = get_2d_adapter("alphapose").load(FIXTURES / "boxing_alphapose_f000-059.json")
    kp2d = remap_to_h36m(kp.points, kp.layout, confidence_channel=True)
    X = np.load(FIXTURES / "boxing_X3D_f000-059.npy", allow_pickle=False).astype(np.float64)
    a_box = agreement(kp2d, X - X[:, :1])
    real_ok = not a_box < limit and -a_box < limit
    lines += ["", f"Real boxing pair (AlphaPose 2D, MotionBERT 3D, 60 frames): agreement {a_box:+.3f}; flagged as it "
                  f"is: {'yes' if a_box < limit else 'no'}, exchanged: {'yes' if -a_box < limit else 'no'} (hand-set: "
                  f"{'yes' if hand_set_flagged(kp2d, X) else 'no'}, "
                  f"{'yes' if hand_set_flagged(kp2d, X[:, EXCHANGED]) else 'no'})"]
    ships = false_ok and detected["fitted"] >= detected["hand-set"] and real_ok
    lines += ["", f"Decision 0077's rule: (1) false alarms within 1 in 20 per set: {'yes' if false_ok else 'no'}; "
                  f"(2) detections {detected['fitted']} >= hand-set {detected['hand-set']}: "
                  f"{'yes' if detected['fitted'] >= detected['hand-set'] else 'no'}; (3) real pair right both ways: "
                  f"{'yes' if real_ok else 'no'}. The fitted limit {'ships' if ships else 'does not ship'}.",
              "", f"({time.perf_counter() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    if ships:
        write_detector_fit(args.json, "pcnet's side-swap agreement limit (stages/flags.py side_swap_flag, decision 0077)",
                           "agreement_limit", limit, COMMAND, len(train),
                           "the smallest agreement over the training clips (decision 0077)", at)


if __name__ == "__main__":
    main()
