"""Left/right limb swaps found by path continuity and undone (decision 0106's candidate, here since
it was withdrawn), on held-out mocap through the lifter-noise model and on real lifter output.

    python -m benchmarks.side_swap_repair --data ../shared/data

Per clip, the root-relative joints through ``models/lifter_noise.py`` (seed = the clip's index in
its set) three ways: with the model's swaps, with its swaps switched off, and clean. For each,
the root-relative MPJPE against the clean joints (mm) before and after
:func:`repair_side_swaps`, and the share of frames it exchanged.

Rule (decision 0106, fixed before the first run on the CMU test subjects): it ships if, on the
CMU test subjects (motion-style split), (a) with the swaps the repair lowers the MPJPE (paired
mean difference over clips below 0, its 95 % bootstrap interval below 0), and (b) without the
swaps and on clean joints it exchanges at most 0.1 % of the frames and raises the MPJPE by at
most 0.1 mm (paired mean). The Bandai motion-style test split (its first 150 clips) and
DeepMimic were seen while the candidate was chosen: printed as validation, not part of the rule.
Real lifter output (the yoga VideoPose3D exports, MotionBERT's boxing and cycling clips) has no
truth: the frames exchanged there are listed, not judged. Writes
benchmarks/results/side_swap_repair.txt.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from benchmarks.ablation import paired_interval
from benchmarks.report import print_and_save, trial_arguments
from pcnet.models.datasets import load_mocap, select_split
from pcnet.models.lifter_noise import apply_lifter_errors, sample_lifter_errors
from pcnet.stages.core.conventions import (L_ANKLE, L_ELBOW, L_HIP, L_KNEE, L_SHOULDER, L_WRIST, R_ANKLE, R_ELBOW, R_HIP,
                                           R_KNEE, R_SHOULDER, R_WRIST)
from pcnet.stages.core.framestore import frame_blocks, true_runs

RESULT = Path(__file__).resolve().parent / "results" / "side_swap_repair.txt"


#: The limbs whose sides a swap exchanges: (left joints, right joints).
LIMBS: dict[str, tuple[tuple[int, ...], tuple[int, ...]]] = {
    "legs": ((L_HIP, L_KNEE, L_ANKLE), (R_HIP, R_KNEE, R_ANKLE)),
    "arms": ((L_SHOULDER, L_ELBOW, L_WRIST), (R_SHOULDER, R_ELBOW, R_WRIST)),
}


@dataclass(frozen=True)
class SideSwaps:
    """What :func:`repair_side_swaps` found and undid.

    joints: ``(T, 17, 3)`` float64, the input with each swapped frame's limbs exchanged back.
    swapped: ``{limb: (T,) bool}`` for each of :data:`LIMBS`, the frames whose sides were
    exchanged."""

    joints: np.ndarray
    swapped: dict[str, np.ndarray]

    @property
    def any(self) -> bool:
        """Whether any frame of any limb was exchanged."""
        return any(bool(s.any()) for s in self.swapped.values())


def _labelling(run: np.ndarray) -> np.ndarray:
    """``(n,)`` bool, True = exchanged: the least total squared displacement path of ``run``
    ``(n, 2, k, 3)`` (each frame's two labellings), the majority kept as given."""
    n = len(run)
    # step[t, i, j]: squared displacement from labelling i at frame t to labelling j at t + 1
    step = np.sum((run[1:, None] - run[:-1, :, None]) ** 2, axis=(3, 4)).tolist()
    c0, c1 = 0.0, 0.0
    back = np.zeros((n, 2), bool)  # back[t, j]: the previous frame's labelling on the best path to j
    for t, ((s00, s01), (s10, s11)) in enumerate(step, start=1):
        to0, to1 = (c0 + s00, c1 + s10), (c0 + s01, c1 + s11)
        back[t] = to0[1] < to0[0], to1[1] < to1[0]
        c0, c1 = min(to0), min(to1)
    state = np.empty(n, bool)
    state[-1] = c1 < c0
    for t in range(n - 1, 0, -1):
        state[t - 1] = back[t, int(state[t])]
    return ~state if 2 * int(state.sum()) > n else state


def side_swap_frames(joints) -> dict[str, np.ndarray]:
    """``{limb: (T,) bool}``: the frames whose sides of each of :data:`LIMBS` the lifter
    exchanged (module docstring), from ``(T, 17, 3)`` H36M-17 ``joints`` (an array, or a
    :class:`~pcnet.stages.core.framestore.FrameArray`: only the limbs' joints are read).

    Raises:
        ValueError: ``joints`` not ``(T, 17, 3)``.
    """
    if len(joints.shape) != 3 or tuple(joints.shape[1:]) != (17, 3):
        raise ValueError(f"joints: expected (T, 17, 3), got {tuple(joints.shape)}")
    swapped = {}
    for limb, (left, right) in LIMBS.items():
        given = np.asarray(joints[:, list(left + right)], np.float64)
        both = np.stack([given, given[:, [*range(3, 6), *range(3)]]], axis=1)
        mask = np.zeros(len(given), bool)
        for a, b in true_runs(np.isfinite(given).all(axis=(1, 2))):
            mask[a:b] = _labelling(both[a:b])
        swapped[limb] = mask
    return swapped


def exchange_sides(joints, swapped: dict[str, np.ndarray]) -> None:
    """Exchange, in place, the left and right joints of each limb of ``joints`` ``(T, 17, 3)``
    (an array or a :class:`~pcnet.stages.core.framestore.FrameArray`) in its ``swapped``
    frames (:func:`side_swap_frames`)."""
    any_frame = np.logical_or.reduce([np.asarray(m, bool) for m in swapped.values()])
    for rows in frame_blocks(len(joints)):  # a block at a time: a store's array is not read whole
        if not any_frame[rows].any():
            continue
        block = np.array(joints[rows])
        for limb, mask in swapped.items():
            left, right = LIMBS[limb]
            here = np.asarray(mask[rows], bool)
            block[np.ix_(here, left + right)] = block[np.ix_(here, right + left)]
        joints[rows] = block


def repair_side_swaps(joints: np.ndarray) -> SideSwaps:
    """Find and undo the frames whose left and right limbs a lifter exchanged (module
    docstring): :func:`side_swap_frames`, then :func:`exchange_sides` on a copy.

    Args:
        joints: ``(T, 17, 3)`` H36M-17 poses, any frame and units; NaN = missing.

    Returns:
        :class:`SideSwaps`: the repaired joints (a new float64 array) and the exchanged frames
        per limb.

    Raises:
        ValueError: ``joints`` not ``(T, 17, 3)``.
    """
    J = np.array(joints, np.float64)
    swapped = side_swap_frames(J)
    exchange_sides(J, swapped)
    return SideSwaps(J, swapped)


#: The rule's bounds on inputs without swaps: share of frames exchanged, MPJPE added (mm).
MAX_FALSE_SHARE = 0.001
MAX_ADDED_MM = 0.1
VALIDATION_BANDAI_CLIPS = 150


def _mpjpe(a: np.ndarray, b: np.ndarray) -> float:
    return float(1000 * np.nanmean(np.linalg.norm(a - b, axis=-1)))


def measure(clips) -> dict[str, np.ndarray]:
    """Per input (``swaps``, ``no swaps``, ``clean``): ``(n_clips, 4)`` MPJPE before, after,
    frames exchanged, frames."""
    out: dict[str, list] = {"swaps": [], "no swaps": [], "clean": []}
    for i, c in enumerate(clips):
        J = c.joints.astype(np.float64)
        J = J - J[:, :1]
        if len(J) < 10:
            continue
        errors = sample_lifter_errors(len(J), c.fps, np.random.default_rng(i))
        inputs = {"swaps": apply_lifter_errors(J, errors),
                  "no swaps": apply_lifter_errors(J, replace(errors, swap=np.full(len(J), -1))), "clean": J}
        for name, X in inputs.items():
            r = repair_side_swaps(X)
            exchanged = np.logical_or.reduce(list(r.swapped.values()))
            out[name].append((_mpjpe(X, J), _mpjpe(r.joints, J), int(exchanged.sum()), len(J)))
    return {k: np.array(v, np.float64) for k, v in out.items()}


def rows(label: str, m: dict[str, np.ndarray]) -> tuple[list[str], dict[str, tuple]]:
    lines, stats = [], {}
    for name, a in m.items():
        mean, lo, hi = paired_interval(a[:, 1] - a[:, 0])
        share = a[:, 2].sum() / a[:, 3].sum()
        stats[name] = (mean, lo, hi, share)
        lines.append(f"| {label} | {name} | {len(a)} | {a[:, 0].mean():.2f} | {a[:, 1].mean():.2f} | "
                     f"{mean:+.3f} [{lo:+.3f}, {hi:+.3f}] | {100 * share:.3f} % |")
    return lines, stats


def real_files(data: Path) -> list[tuple[str, np.ndarray]]:
    """The real H36M-17 lifter outputs: yoga VideoPose3D exports, MotionBERT boxing and cycling."""
    real = data / "real"
    paths = sorted((real / "yoga_videopose3d").glob("export_*.npy")) + [real / "boxing_motionbert" / "X3D.npy"] \
        + sorted((real / "cycling_motionbert").glob("clip_*_X3D*.npy"))
    return [(p.name, np.load(p, allow_pickle=False).astype(np.float64)) for p in paths]


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="side_swap_repair")
    t0 = time.time()
    cmu = load_mocap(args.data / "mocap" / "cmu_train_h36m17.npz")
    bandai = select_split(load_mocap(args.data / "mocap" / "bandai_h36m17.npz"), "test", "motion-style")
    lines = [__doc__.splitlines()[0], "", "    python -m benchmarks.side_swap_repair --data ../shared/data", "",
             "| data | input | clips | MPJPE before (mm) | after | after - before [95 % CI] | frames exchanged |",
             "|---|---|---:|---:|---:|---|---:|"]
    held, stats = rows("CMU test subjects (held out)", measure(select_split(cmu, "test", "motion-style")))
    lines += held
    for label, clips in ((f"Bandai test, first {VALIDATION_BANDAI_CLIPS} (validation)", bandai[:VALIDATION_BANDAI_CLIPS]),
                         ("DeepMimic (validation)", load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz"))):
        lines += rows(label, measure(clips))[0]
    mean, lo, hi, _ = stats["swaps"]
    better = mean < 0 and hi < 0
    quiet = all(stats[k][3] <= MAX_FALSE_SHARE and stats[k][0] <= MAX_ADDED_MM for k in ("no swaps", "clean"))
    lines += ["", "Real lifter output (no truth; frames exchanged per limb, files with any):"]
    files = real_files(args.data)
    total = exchanged = 0
    for name, X in files:
        r = repair_side_swaps(X)
        total += len(X)
        hit = {limb: int(m.sum()) for limb, m in r.swapped.items() if m.any()}
        exchanged += int(np.logical_or.reduce(list(r.swapped.values())).sum())
        if hit:
            lines.append(f"  {name} ({len(X)} frames): " + ", ".join(f"{k} {v}" for k, v in hit.items()))
    lines += [f"  {len(files)} files, {exchanged} of {total} frames exchanged ({100 * exchanged / total:.2f} %)", "",
              f"verdict: with swaps {'better' if better else 'not better'} ({mean:+.3f} mm [{lo:+.3f}, {hi:+.3f}]); "
              f"without swaps and clean {'within' if quiet else 'beyond'} {100 * MAX_FALSE_SHARE:g} % of frames and "
              f"{MAX_ADDED_MM:g} mm: " + ("ships" if better and quiet else "does not ship"), "",
              f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
