"""Left/right swaps of a lifter's limbs, found by the continuity of each limb's path and undone.

A 2D detector that confuses a person's sides for a few frames (common side-on, or where the
limbs cross) hands the lifter swapped keypoints, and the lifter's 3D then swaps the left and
right leg (with the hips) or arm (with the shoulders) in those frames. The joints of a body move
continuously: between two frames a limb moves by its speed over the frame rate, while a swap moves
it across the body (hips about 0.25 m apart, shoulders 0.3 m). So for each limb pair, of the two
labellings of every frame (as given, or exchanged) the path with the least total squared
displacement between consecutive frames is the body's (a first-order Markov chain of two states,
solved exactly by the Viterbi algorithm; Viterbi, IEEE Trans. Inf. Theory 13:260-269, 1967), and
the labelling that the input gives in most frames of a run is the one kept (a run of frames
whose sides are all exchanged is a mirrored input, which :func:`pcnet.stages.flags.mirrored_skeleton_flag`
reads, not a swap). No parameter: the cost is the displacement itself.

Parts: a leg is its hip, knee and ankle, an arm its shoulder, elbow and wrist; both swap together
where the whole body's sides are confused. Frames where a part's joints are not all finite
break its chain: each run of frames is solved alone.

Decision 0106 measured it on held-out mocap through the lifter-noise model
(``python -m benchmarks.side_swap_repair --data ../shared/data``).

Shapes: joints ``(T, 17, 3)`` H36M-17, any frame and units (the pelvis is not part of a limb).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core.conventions import (L_ANKLE, L_ELBOW, L_HIP, L_KNEE, L_SHOULDER, L_WRIST, R_ANKLE, R_ELBOW, R_HIP,
                               R_KNEE, R_SHOULDER, R_WRIST)
from .core.framestore import true_runs

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
    """``(n,)`` int, 0 = as given, 1 = exchanged: the least total squared displacement path of
    ``run`` ``(n, 2, k, 3)`` (each frame's two labellings), the majority kept as given."""
    n = len(run)
    cost = np.zeros(2)
    back = np.zeros((n, 2), np.int64)
    for t in range(1, n):
        step = np.sum((run[t][None] - run[t - 1][:, None]) ** 2, axis=(2, 3))  # (previous, current)
        total = cost[:, None] + step
        back[t] = np.argmin(total, axis=0)
        cost = total[back[t], [0, 1]]
    state = np.empty(n, np.int64)
    state[-1] = int(np.argmin(cost))
    for t in range(n - 1, 0, -1):
        state[t - 1] = back[t, state[t]]
    return 1 - state if 2 * state.sum() > n else state


def repair_side_swaps(joints: np.ndarray) -> SideSwaps:
    """Find and undo the frames whose left and right limbs a lifter exchanged (module docstring).

    Args:
        joints: ``(T, 17, 3)`` H36M-17 poses, any frame and units; NaN = missing.

    Returns:
        :class:`SideSwaps`: the repaired joints (a new float64 array) and the exchanged frames
        per limb.

    Raises:
        ValueError: ``joints`` not ``(T, 17, 3)``.
    """
    J = np.asarray(joints, np.float64)
    if J.ndim != 3 or J.shape[1:] != (17, 3):
        raise ValueError(f"joints: expected (T, 17, 3), got {J.shape}")
    out = J.copy()
    swapped = {}
    for limb, (left, right) in LIMBS.items():
        given, exchanged = J[:, left + right], J[:, right + left]
        both = np.stack([given, exchanged], axis=1)
        mask = np.zeros(len(J), bool)
        for a, b in true_runs(np.isfinite(given).all(axis=(1, 2))):
            mask[a:b] = _labelling(both[a:b]) == 1
        out[np.ix_(mask, left + right)] = exchanged[mask]
        swapped[limb] = mask
    return SideSwaps(out, swapped)
