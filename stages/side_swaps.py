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
from .core.framestore import frame_blocks, true_runs

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


def side_swaps_note(swapped: dict[str, np.ndarray], shown: int = 3) -> str | None:
    """The run's note on :func:`side_swap_frames`' frames, ``None`` where none was exchanged:
    per limb its frames and their first ``shown`` ranges (first to last frame)."""
    parts = []
    for limb, mask in swapped.items():
        runs = true_runs(mask)
        if not runs:
            continue
        ranges = ", ".join(f"{a}" if b == a + 1 else f"{a}-{b - 1}" for a, b in runs[:shown])
        more = f" +{len(runs) - shown} more" if len(runs) > shown else ""
        n = int(np.sum(mask))
        parts.append(f"{limb} in {n} frame{'s' * (n != 1)} ({ranges}{more})")
    return parts and (f"left/right swaps undone, found by the limbs' path continuity (decision 0106): "
                      f"{'; '.join(parts)}; canonical.npz side_swaps") or None
