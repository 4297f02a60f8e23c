"""Fit ``--heading auto``'s hip-width threshold on validation data (decision 0085).

    python -m benchmarks.fit_heading_source --data ../shared/data [--heldout]

``auto`` takes each frame's heading from the input's hip line when the recording's hip width
varies little (:func:`pcnet.stages.heading.hip_width_cv_percent` at most
``AUTO_MAX_HIP_WIDTH_CV_PERCENT``), else from the rectification's own (predicted) heading. The
hip line's heading error grows with the hips' noise, which the width's coefficient of variation
measures (a rigid pelvis keeps its width); the predicted heading's does not depend on it. The
threshold is where choosing by it errs least.

Recordings: each clip of a set seen by one static "paper" camera
(:func:`benchmarks.ablation.static_camera_clips`) with the lifter noise of
:class:`pcnet.models.lifter_noise.LifterNoise` scaled by each of :data:`SCALES` (every size and
the swap rate times the scale; 0: clean mocap, 1: the laboratory level, 2: beyond it, as real
in-the-wild lifters are), rectified as ``pcnet run`` does by default (the shipped ensemble,
sequence mode). Per recording: the hip width's CV and the mean per-frame heading error
(:func:`pcnet.stages.core.metrics.heading_error_deg`) with the heading predicted and with the
hip line's.

Fit (validation: the Bandai motion-style val split and the CMU validation subjects, at most
120 clips each, as benchmarks/fit_up_model.py): the threshold with the least mean heading error
over all recordings, the midpoint between the two CVs that bound the best interval.
``--heldout`` also prints, for the held-out sets of benchmarks/ablation.py (Bandai motion-style
test, CMU test subjects, DeepMimic; at most 200 clips each), each recording's error under the
fitted and the hand-set threshold (1 %, decision 0027) and their paired difference per clip, averaged over the scales (decision 0061's rule: worse when
the mean is above 0.10 deg and its 95 % bootstrap interval above zero).

``AUTO_MIN_FRAMES`` (decision 0088), the fewest valid frames from which ``auto`` reads the CV at
all (below it the heading is predicted), is fitted on the same validation recordings cut to
their first ``n`` valid frames for each ``n`` in :data:`PREFIX_FRAMES`: the CV and both sources'
mean heading errors over those frames (the rotations are the whole recording's, so the
comparison is between the two heading sources on the same up). For each candidate floor ``m``
in :data:`PREFIX_FRAMES`, the mean heading error over every cut recording of the policy
"predicted below ``m`` frames, else ``auto`` with the fitted threshold"; the floor with the least
wins, ties to the smaller. ``--heldout`` compares it with the hand-set 10 (decision 0061's rule,
one difference per clip: its mean over the scales and the cuts).

Writes benchmarks/results/fit_heading_source.txt.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save, require_folder
from pcnet.models.datasets import load_mocap, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.pipeline.rectification import NetworkEstimator
from pcnet.stages.core.metrics import heading_error_deg
from pcnet.stages.heading import apply_heading, hip_width_cv_percent
from pcnet.stages.rectify import HeadingStep, Rectification, SequenceEvidence

RESULT = Path(__file__).resolve().parent / "results" / "fit_heading_source.txt"
COMMAND = "python -m benchmarks.fit_heading_source --data ../shared/data"
#: Lifter-noise scales (decision 0085): clean, fractions of the laboratory level, and twice it.
SCALES = (0.0, 0.1, 0.25, 0.5, 1.0, 2.0)
HELDOUT_MAX_CLIPS = 200
#: The threshold hand-set by decision 0027, which the fit is checked against (decision 0085).
HAND_SET_PERCENT = 1.0
#: Cuts (first ``n`` valid frames) on which ``AUTO_MIN_FRAMES`` is fitted, and its candidates (decision 0088).
PREFIX_FRAMES = (2, 3, 4, 5, 6, 8, 10, 12, 15, 20, 30)
#: The floor hand-set with ``auto`` (decision 0027), which the fit is checked against (decision 0088).
HAND_SET_MIN_FRAMES = 10
#: Fields of :class:`LifterNoise` that are not sizes: kept when scaling.
_NOT_SIZES = ("offset_time_constant_s", "burst_rate_hz")


def scaled_noise(scale: float) -> LifterNoise:
    """:class:`LifterNoise` with every size and the swap rate times ``scale``."""
    base = LifterNoise()
    return replace(base, **{f.name: getattr(base, f.name) * scale for f in fields(base) if f.name not in _NOT_SIZES})


@dataclass(frozen=True)
class Recordings:
    """Per recording (``N``): ``whole`` ``(N, 3)``: hip width CV (percent), mean heading error
    (deg) predicted, from the hips, over every valid frame; ``cuts``: the same over the first
    ``n`` valid frames, ``(N, 3)`` per ``n`` of :data:`PREFIX_FRAMES` (NaN rows for shorter
    recordings)."""

    whole: np.ndarray
    cuts: dict[int, np.ndarray]


def _row(X, valid, R_pred, R_hips, R_true) -> tuple[float, float, float]:
    return (hip_width_cv_percent(X, valid), np.nanmean(heading_error_deg(R_pred[valid], R_true[valid])),
            np.nanmean(heading_error_deg(R_hips[valid], R_true[valid])))


def recordings(clips: list, max_clips: int, scale: float) -> Recordings:
    """Each clip of ``clips`` (at most ``max_clips``) seen by one static camera with the lifter
    noise scaled by ``scale``, rectified by the shipped chain: its :class:`Recordings` rows."""
    rectify = Rectification(NetworkEstimator(), SequenceEvidence("sequence", n_bootstrap=0), HeadingStep("predicted"))
    whole, cuts = [], {n: [] for n in PREFIX_FRAMES}
    for clip, X, R, _ in A.static_camera_clips(clips, max_clips, noise=scaled_noise(scale)):
        out = rectify(X, clip.fps)
        R_hips, _ = apply_heading(X, out.rotation, out.valid, "hips")
        whole.append(_row(X, out.valid, out.rotation, R_hips, R))
        frames = np.flatnonzero(out.valid)
        for n in PREFIX_FRAMES:
            first = np.zeros_like(out.valid)
            first[frames[:n]] = True
            cuts[n].append(_row(X, first, out.rotation, R_hips, R) if len(frames) >= n else (np.nan,) * 3)
    return Recordings(np.array(whole), {n: np.array(rows) for n, rows in cuts.items()})


def chosen_error(rows: np.ndarray, threshold: float) -> np.ndarray:
    """Each recording's heading error under ``auto`` with ``threshold`` (percent)."""
    return np.where(rows[:, 0] <= threshold, rows[:, 2], rows[:, 1])


def fit_threshold(rows: np.ndarray) -> tuple[float, float, float]:
    """``(threshold, lo, hi)``: the midpoint of the interval of thresholds between consecutive
    CVs with the least mean chosen error (the lowest such interval)."""
    cvs = np.unique(rows[:, 0])
    cuts = np.concatenate([[0.0], cvs])
    means = np.array([chosen_error(rows, c).mean() for c in cuts])
    i = int(np.argmin(means))
    lo = cuts[i]
    hi = cvs[np.searchsorted(cvs, lo, side="right")] if lo < cvs[-1] else lo
    return float((lo + hi) / 2), float(lo), float(hi)


def floor_error(cuts: dict[int, np.ndarray], floor: int, threshold: float) -> np.ndarray:
    """``(N,)`` each recording's heading error under ``auto`` with ``floor`` and ``threshold``,
    averaged over its cuts (predicted on a cut of fewer than ``floor`` frames)."""
    per_cut = [rows[:, 1] if n < floor else chosen_error(rows, threshold) for n, rows in cuts.items()]
    return np.nanmean(per_cut, axis=0)


def fit_floor(cuts: list[dict[int, np.ndarray]], threshold: float) -> tuple[int, dict[int, float]]:
    """``(floor, means)``: the candidate of :data:`PREFIX_FRAMES` with the least mean error of
    :func:`floor_error` over every recording of ``cuts`` (ties to the smaller), and each
    candidate's mean."""
    means = {m: float(np.nanmean(np.concatenate([floor_error(c, m, threshold) for c in cuts])))
             for m in PREFIX_FRAMES}
    best = min(means.values())
    return min(m for m, v in means.items() if v == best), means


def describe(title: str, rows: np.ndarray, threshold: float) -> list[str]:
    """One line per scale and one overall: CV range, errors predicted / hips / auto at both thresholds."""
    return [f"{title:<38}{len(rows):>6}{np.median(rows[:, 0]):>9.2f}{rows[:, 1].mean():>9.2f}{rows[:, 2].mean():>9.2f}"
            f"{chosen_error(rows, HAND_SET_PERCENT).mean():>9.2f}{chosen_error(rows, threshold).mean():>9.2f}"]


HEADER = (f"{'recordings':<38}{'n':>6}{'CV med':>9}{'pred':>9}{'hips':>9}{'auto 1%':>9}{'auto fit':>9}   "
          "(mean heading error, deg; 'auto 1%': the hand-set threshold, 'auto fit': the fitted one)")


def run_sets(sets: list[tuple[str, list]], max_clips: int) -> dict[str, dict[float, Recordings]]:
    return {name: {s: recordings(clips, max_clips, s) for s in SCALES} for name, clips in sets}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=A.DEFAULT)
    ap.add_argument("--heldout", action="store_true")
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    require_folder(args.data, "fit_heading_source")
    t0 = time.time()
    val = run_sets([(tag, select_split(load_mocap(args.data / "mocap" / file), "val", "motion-style"))
                    for tag, file in F.VAL_SETS], F.VAL_MAX_CLIPS)
    rows = np.concatenate([r.whole for by_scale in val.values() for r in by_scale.values()])
    threshold, lo, hi = fit_threshold(rows)
    floor, floor_means = fit_floor([r.cuts for by_scale in val.values() for r in by_scale.values()], threshold)
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}{' --heldout' if args.heldout else ''}", "",
             f"lifter-noise scales {SCALES}; hand-set threshold (decision 0027) {HAND_SET_PERCENT} %", "",
             "validation", HEADER]
    for name, by_scale in val.items():
        lines += [row for s, r in by_scale.items() for row in describe(f"  {name} x{s:g}", r.whole, threshold)]
    lines += describe("  all", rows, threshold)
    lines += ["", f"AUTO_MAX_HIP_WIDTH_CV_PERCENT = {threshold:.4f}   (best interval [{lo:.4f}, {hi:.4f}) %)", "",
              f"floor (valid frames) -> mean heading error (deg) over the validation recordings cut to their first "
              f"{', '.join(map(str, PREFIX_FRAMES))} frames",
              *(f"  {m:>3}  {v:.4f}" for m, v in floor_means.items()),
              f"AUTO_MIN_FRAMES = {floor}"]
    if args.heldout:
        from benchmarks.view_gate_pieces import worse
        held = run_sets([(title, A.heldout_clips(args.data, file, split))
                         for title, file, split in A.MOCAP_SETS], HELDOUT_MAX_CLIPS)
        lines += ["", "held out", HEADER]
        for name, by_scale in held.items():
            lines += [row for s, r in by_scale.items() for row in describe(f"  {name} x{s:g}", r.whole, threshold)]
            # one difference per clip (its mean over the scales): the scales' recordings of a clip are not independent
            diff = np.mean([chosen_error(r.whole, threshold) - chosen_error(r.whole, HAND_SET_PERCENT)
                            for r in by_scale.values()], axis=0)
            bad, cell = worse(diff)
            lines.append(f"  {name}: fitted - hand-set {cell}{': worse' if bad else ''}")
            fitted = [floor_error(r.cuts, floor, threshold) for r in by_scale.values()]
            hand_set = [floor_error(r.cuts, HAND_SET_MIN_FRAMES, threshold) for r in by_scale.values()]
            bad, cell = worse(np.mean(fitted, axis=0) - np.mean(hand_set, axis=0))
            lines.append(f"  {name}, cut to the first {', '.join(map(str, PREFIX_FRAMES))} frames: floor {floor} "
                         f"{np.nanmean(fitted):.2f}, floor {HAND_SET_MIN_FRAMES} {np.nanmean(hand_set):.2f}; "
                         f"fitted - hand-set {cell}{': worse' if bad else ''}")
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
