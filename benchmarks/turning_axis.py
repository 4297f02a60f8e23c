"""Auto mode by the axis the body turns about (decision 0069): the threshold fitted on validation,
then the held-out check against the spread rule. Not shipped: it reads more static
recordings of the Bandai test split as moving than the spread rule (its runs).

    python -m benchmarks.turning_axis --data ../shared/data             # fit (validation only)
    python -m benchmarks.turning_axis --data ../shared/data --evaluate  # held-out check

A person on a floor changes heading by turning about the vertical. Between two frames ``t``
and ``k`` in which the body has the same configuration (the same distances between all its
joints), the pelvis-centred skeleton a static camera sees has turned about the camera-frame up
``g`` only: the least-squares rotation ``R`` with ``R x_t,j ~ x_k,j`` (Kabsch, "A solution for
the best rotation to relate two sets of vectors", Acta Cryst. A32, 1976) leaves ``g`` in place.
A camera that rotates between the two frames adds its rotation, which tilts ``g``:
``tau = angle(R g, g)`` is the camera's change of tilt (plus the skeletons' noise). The
networks' pose-driven errors do not enter: the statistic reads the joints, and matched frames
share their configuration. Decision 0069 fixed the statistic:

- frames: the valid frames with all 17 joints finite, in time order; the first and the last
  third of them (the longest time apart, where a moving camera has moved most);
- each frame of one third is matched to the frame of the other third with the nearest
  configuration, the Euclidean distance between the 136 pairwise joint distances;
- the statistic is the median ``tau`` over the matched pairs, in degrees.

The statistic is :func:`turn_tilt_deg` of each recording's joints, with the
up model's summary of its poses (:func:`pcnet.stages.up_model.summarise_recording`, shipped
parameters) as the up. The frames are those of the shipped chain's per-frame step
(``benchmarks/ablation.py`` ``per_frame``, default variant).

Fit: the data of ``benchmarks/fit_camera_mode.py`` (the 393 static validation recordings and the
validation recordings with the camera pitch sweeping 30 deg); the threshold is
``fit_camera_mode.best_threshold``'s (the midpoint of the widest interval with the fewest
misreads). Writes benchmarks/results/turning_axis_fit.txt.

``--evaluate`` (decision 0069's pass condition): on the ablation's held-out static sets (Bandai
motion-style test, CMU test subjects, DeepMimic) and its moving camera, the recordings each
rule reads as moving and the mean tilt error of auto mode under each rule (moving: smooth
mode's up; static: the default chain's sequence up), against the spread rule as shipped
(:func:`pcnet.stages.temporal.up_spread_deg`, ``MODE_THRESHOLD_DEG``, ``MODE_SMOOTHING_S``).
Reported beside them: the real static recordings (the Pose2Sim calibrated cameras in 16 views,
the yoga files) each rule reads as moving. Needs the fitted threshold in
benchmarks/results/turning_axis_fit.txt. Writes benchmarks/results/turning_axis.txt.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np

import pcnet.stages.temporal as temporal
from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.fit_camera_mode import best_threshold
from benchmarks.report import print_and_save
from pcnet.stages.core.conventions import PELVIS
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.rotations import procrustes_rotation
from pcnet.stages.up_model import default_parameters, summarise_recording

#: At most this many frames of each third are matched (evenly spaced): the brute-force nearest
#: neighbours cost the square of it. A computing cap, not a statistical choice: the median
#: of thousands of pairs does not need more.
_MAX_FRAMES_PER_THIRD = 2000
_PAIRS = np.triu_indices(17, 1)


def configuration(joints: np.ndarray) -> np.ndarray:
    """``(T, 136)`` the distances between every two of the 17 joints of ``joints``
    ``(T, 17, 3)`` (any unit): the body's configuration, the same under any rotation."""
    d = joints[:, :, None] - joints[:, None]
    return np.linalg.norm(d, axis=-1)[:, _PAIRS[0], _PAIRS[1]]


def nearest(a: np.ndarray, b: np.ndarray, chunk: int = 1000) -> np.ndarray:
    """``(len(a),)`` index into ``b`` ``(M, D)`` of each row of ``a`` ``(N, D)``'s nearest row (Euclidean)."""
    bb = np.sum(b * b, axis=1)
    out = np.empty(len(a), np.int64)
    for i in range(0, len(a), chunk):
        block = a[i:i + chunk]
        out[i:i + chunk] = np.argmin(bb[None] - 2.0 * block @ b.T, axis=1)
    return out


def turn_tilt_deg(joints_cam: np.ndarray, valid: np.ndarray, up: np.ndarray) -> float:
    """The median tilt (deg) that the rotations between matched configurations give the up
    (module docstring): about 0 for a static camera, the camera's change of tilt for a moving one.

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 camera-frame joints (any unit; the root may be kept:
            each skeleton is centred on its pelvis); NaN = missing.
        valid: ``(T,)`` bool, the frames to read.
        up: ``(3,)`` the recording's up in the camera frame (the up model's summary of the poses).

    Returns:
        the median tilt in degrees; NaN with fewer than 3 frames whose 17 joints are all finite.

    Raises:
        InputError: ``joints_cam`` not ``(T, 17, 3)``, ``valid`` not ``(T,)``, ``up`` not a
            finite ``(3,)`` vector.
    """
    J = np.asarray(joints_cam, np.float64)
    if J.ndim != 3 or J.shape[1:] != (17, 3):
        raise InputError(f"turn_tilt_deg: joints_cam must have shape (T, 17, 3), got {J.shape}")
    valid = np.asarray(valid, bool)
    if valid.shape != (len(J),):
        raise InputError(f"turn_tilt_deg: valid must have shape ({len(J)},), got {valid.shape}")
    g = np.asarray(up, np.float64)
    if g.shape != (3,) or not np.isfinite(g).all() or not np.linalg.norm(g) > 0:
        raise InputError(f"turn_tilt_deg: up must be a finite non-zero (3,) vector, got {g!r}")
    g = g / np.linalg.norm(g)
    frames = np.flatnonzero(valid & np.isfinite(J).all(axis=(1, 2)))
    n = len(frames) // 3
    if n < 1:
        return float("nan")
    first, last = (_evenly(f) for f in (frames[:n], frames[-n:]))
    X = J - J[:, PELVIS:PELVIS + 1]
    c_first, c_last = configuration(X[first]), configuration(X[last])
    sources = np.concatenate([first, last])
    targets = np.concatenate([last[nearest(c_first, c_last)], first[nearest(c_last, c_first)]])
    # X[sources] R ~ X[targets] (row vectors): R turns g by as much as its transpose does.
    R = procrustes_rotation(X[sources], X[targets])[0]
    cos = np.clip(np.einsum("i,nij,j->n", g, R, g), -1.0, 1.0)
    return float(np.degrees(np.median(np.arccos(cos))))


def _evenly(frames: np.ndarray) -> np.ndarray:
    if len(frames) <= _MAX_FRAMES_PER_THIRD:
        return frames
    return frames[np.linspace(0, len(frames) - 1, _MAX_FRAMES_PER_THIRD).round().astype(np.int64)]


RESULTS = Path(__file__).resolve().parent / "results"
FIT_RESULT = RESULTS / "turning_axis_fit.txt"
RESULT = RESULTS / "turning_axis.txt"


def statistic(ev: dict) -> float:
    """:func:`turn_tilt_deg` of one cached recording, the up model's summary of its poses as the up."""
    _, ok = A.shipped_rotations(ev)
    if ok.sum() < 2:
        return float("nan")
    up = summarise_recording(A.evidence_of(ev).frames(ok), ev["fps"], default_parameters()).up
    return turn_tilt_deg(ev["J"], ok, up)


def spread(ev: dict) -> float:
    """The shipped rule's statistic (:func:`pcnet.stages.temporal.up_spread_deg`)."""
    R, ok = A.shipped_rotations(ev)
    return temporal.up_spread_deg(R, ok, ev["fps"], temporal.MODE_SMOOTHING_S)


def fit(args) -> list[str]:
    val = F.validation_sets(args.data, args.cache)
    static = np.array([statistic(ev) for evs in val.values() for ev in evs])
    swept = np.array([statistic(ev) for ev in F.validation_sweeps(args.cache, val)])
    theta, wrong, lo, hi = best_threshold(static[np.isfinite(static)], swept[np.isfinite(swept)])
    q = lambda x: " / ".join(f"{v:.2f}" for v in np.nanpercentile(x, [50, 90, 100]))  # noqa: E731
    return [f"Validation: {len(static)} static recordings (median / p90 / max {q(static)} deg), {len(swept)} with "
            f"the camera pitch sweeping 30 deg (min {np.nanmin(swept):.2f}, median {np.nanmedian(swept):.2f}); "
            f"{int(np.sum(~np.isfinite(static)) + np.sum(~np.isfinite(swept)))} without a statistic",
            f"misreads at the threshold: {wrong} (interval [{lo:.2f}, {hi:.2f}))",
            f"TURN_TILT_THRESHOLD_DEG = {theta:.2f}"]


def fitted_threshold() -> float:
    """The threshold :func:`fit` wrote (benchmarks/results/turning_axis_fit.txt)."""
    text = FIT_RESULT.read_text() if FIT_RESULT.is_file() else ""
    m = re.search(r"^TURN_TILT_THRESHOLD_DEG = (\S+)$", text, re.M)
    if m is None:
        raise SystemExit(f"turning_axis: {FIT_RESULT}: expected a line 'TURN_TILT_THRESHOLD_DEG = ...', got none "
                         "(run the fit first, without --evaluate)")
    return float(m.group(1))


def auto_error(ev: dict, moving: bool) -> float:
    """Auto mode's mean tilt error (deg) on one recording under a static/moving reading."""
    if moving:
        R, ok = A.shipped_rotations(ev)
        up = temporal.smooth_rotations(R, ok, ev["fps"], temporal.SMOOTH_TIME_CONSTANT_S)[:, :, 1]
        return A.clip_error(np.where(ok[:, None], up, np.nan), ev["true_up"])
    return A.clip_error(A.run_variant(ev, A.VARIANTS[0])["up"], ev["true_up"])


def evaluate(args, theta: float) -> list[str]:
    sets = A.heldout_recordings(args.data, args.cache, args.max_clips)[:4]
    real = [("real calibrated cameras, 16 views", A.real_recordings(args.data, args.cache)),
            ("real yoga files", A.cached(args.cache, f"yoga_stride{A.YOGA_STRIDE}", lambda: A.yoga_evidence(args.data)))]
    lines = [f"threshold {theta:.2f} deg (benchmarks/results/turning_axis_fit.txt); spread rule as shipped: "
             f"{temporal.MODE_THRESHOLD_DEG} deg, low-pass {temporal.MODE_SMOOTHING_S} s", "",
             "| set | recordings | read as moving: spread / turning axis | auto tilt error, mean deg: spread / turning axis |",
             "|---|---:|---|---|"]
    for title, evs in sets + real:
        s = np.array([spread(ev) for ev in evs])
        t = np.array([statistic(ev) for ev in evs])
        by_spread, by_turn = s > temporal.MODE_THRESHOLD_DEG, t > theta
        cells = f"{int(by_spread.sum())} / {int(by_turn.sum())}"
        errors = "-"
        if not title.startswith("real"):
            e_s = np.nanmean([auto_error(ev, m) for ev, m in zip(evs, by_spread)])
            e_t = np.nanmean([auto_error(ev, m) for ev, m in zip(evs, by_turn)])
            errors = f"{e_s:.2f} / {e_t:.2f}"
        lines.append(f"| {title} | {len(evs)} | {cells} | {errors} |")
        print(lines[-1], flush=True)
    return lines


def main(argv=None) -> int:
    args = A.heldout_arguments(argv, __doc__, "turning_axis", None,
                               (("--evaluate", "the held-out check (module docstring)"),))
    t0 = time.time()
    command = "python -m benchmarks.turning_axis --data ../shared/data" + " --evaluate" * args.evaluate
    head = [__doc__.split("\n")[0], "", f"    {command}", ""]
    body = evaluate(args, fitted_threshold()) if args.evaluate else fit(args)
    print_and_save(head + body + ["", f"({time.time() - t0:.0f} s)"],
                   args.out or (RESULT if args.evaluate else FIT_RESULT))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
