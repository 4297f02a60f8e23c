"""BVH (Biovision hierarchy) export of H36M-17 world-frame poses for animation tools.

Format: Biovision BVH as described by M. Meredith and S. Maddock, "Motion capture file
formats explained", Department of Computer Science, University of Sheffield, 2001: a
``HIERARCHY`` section (``ROOT``/``JOINT`` blocks with an ``OFFSET`` from the parent, in the
rest pose, and their ``CHANNELS``; ``End Site`` blocks close the leaves) followed by a
``MOTION`` section (``Frames:``, ``Frame Time:`` in seconds, one line of channel values per
frame in the order the channels are declared). A joint's world transform is its parent's
world transform, then a translation by its ``OFFSET`` (the root: by its position channels),
then its rotation, the product of the rotation channels in their declared order
(``CHANNELS ... Zrotation Xrotation Yrotation``: ``R = Rz(z) @ Rx(x) @ Ry(y)``, angles in
degrees, applied to column vectors: intrinsic Z, X, Y, scipy's
``Rotation.from_euler("ZXY", ...)``). A child joint lies at ``p_parent + W_parent @ offset``.

Conventions chosen here (see :func:`write_bvh` for the full list):

* axes and units unchanged from the input (pcnet's world frame: X forward, Y up, Z right;
  the default unit is metres, BVH itself has no unit field);
* rest pose (all rotations zero): a T-pose facing +X, legs straight down, trunk, neck and
  head straight up, arms straight out sideways; the hip, shoulder and nose offsets from
  the pelvis/thorax take the subject's own median directions in the pelvis/thorax frames;
* offsets: the subject's median bone lengths, so the file reproduces the poses rigidified
  to those lengths (each bone keeps its per-frame direction);
* five zero-offset link joints (as the CMU BVH files' ``LHipJoint``) let the two hips,
  the nose and the two shoulders move relative to the pelvis/thorax, so positions are
  reproduced exactly, not as a best fit;
* root position: the pelvis's horizontal position (X, Z), and a height (Y) that puts the
  rigidified skeleton's lowest joint at the height of the input's lowest joint in each frame
  (:func:`floor_shift`), so the BVH stands on the same floor as the TRC/CSV of the same poses
  (the median bone lengths alone would sink or lift the feet by the legs' length variation).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.atomic import atomic_path
from ..core.conventions import (
    H36M_BONES,
    H36M_JOINTS,
    H36M_PARENTS,
    HEAD,
    L_ANKLE,
    L_ELBOW,
    L_HIP,
    L_KNEE,
    L_SHOULDER,
    L_WRIST,
    NECK_NOSE,
    PELVIS,
    R_ANKLE,
    R_ELBOW,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_WRIST,
    SPINE,
    THORAX,
    validate_fps,
)
from ..core.errors import InputError
from ..core.framestore import FrameArray, column, in_memory
from ..core.rotations import normalize
from .exports import TEXT_BLOCK_ROWS

#: Rotation order (scipy intrinsic sequence = BVH channel order) of the pelvis and thorax,
#: whose rotations turn several bones: heading (about Y) and forward bending (about Z) are
#: free, the gimbal lock is at 90 degrees of sideways lean (about X).
FRAME_ORDER = "ZXY"
#: Rotation order of a joint that turns one bone, by the axis of that bone's rest direction
#: (its largest component): the bone axis in the middle, so that the gimbal lock (middle
#: angle +-90 degrees) falls only where the swing itself is undefined (the bone turned by
#: nearly 180 degrees from its rest direction). Legs, spine, neck: ZYX; arms: XZY.
BONE_ORDER = {0: "YXZ", 1: "ZYX", 2: "XZY"}
#: Length units :func:`write_bvh` accepts (values are written unchanged; BVH has no unit field).
BVH_UNITS: tuple[str, ...] = ("m", "cm", "mm")
#: End Site stub length as a fraction of the leaf's incoming bone (display only: H36M-17
#: has no point beyond the ankles, wrists and head top).
END_SITE_FRACTION = 0.2

_UP, _DOWN = np.array([0.0, 1.0, 0.0]), np.array([0.0, -1.0, 0.0])
_RIGHT, _LEFT = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0])
# T-pose rest directions (world axes: X forward, Y up, Z right) of the bones whose parent
# joint has one child; the link children (hips, nose, shoulders) use the subject's median
# direction in the pelvis/thorax frame instead.
_REST_DIR = {
    R_KNEE: _DOWN, R_ANKLE: _DOWN, L_KNEE: _DOWN, L_ANKLE: _DOWN, SPINE: _UP, THORAX: _UP,
    HEAD: _UP, L_ELBOW: _LEFT, L_WRIST: _LEFT, R_ELBOW: _RIGHT, R_WRIST: _RIGHT,
}
# H36M joints reached through a zero-offset link joint placed at their parent.
_LINKED = (R_HIP, L_HIP, NECK_NOSE, L_SHOULDER, R_SHOULDER)
# Joints with several children: their orientation is a frame (y axis, z hint) per frame.
_FRAMES = {PELVIS: ((PELVIS, SPINE), (L_HIP, R_HIP)), THORAX: ((SPINE, THORAX), (L_SHOULDER, R_SHOULDER))}


@dataclass(frozen=True)
class BvhMotion:
    """The BVH skeleton and motion computed from H36M-17 poses by :func:`bvh_motion`.

    Nodes are the BVH joints in file (depth-first) order: the 17 H36M joints plus five
    zero-offset link joints.

    Attributes:
        names: ``(N,)`` node names (``N = 22``).
        parents: ``(N,)`` parent node index, ``-1`` for the root.
        joint_index: ``(N,)`` H36M-17 index of each node, ``-1`` for a link joint.
        offsets: ``(N, 3)`` float64 rest offsets from the parent node (root: zeros), input units.
        end_sites: ``{node: (3,) offset}`` for the leaves (display stubs, see module doc).
        root_position: ``(T, 3)`` float64 the root's position channels per frame: the
            pelvis position raised by :func:`floor_shift` (the lowest joint on the input's floor).
        orders: ``(N,)`` rotation orders (``"ZXY"``: channels ``Zrotation Xrotation
            Yrotation``; scipy's intrinsic sequences).
        euler_deg: ``(T, N, 3)`` float64 local rotations in degrees, in each node's order,
            unwrapped in time (no 360-degree jumps).
        bone_lengths: ``(16,)`` float64 median bone lengths (``H36M_BONES`` order), input units.
        positions: ``(T, 17, 3)`` float64 joint positions the file encodes (forward
            kinematics of the above): the filled poses with each bone scaled to its median
            length, moved up or down by :func:`floor_shift` in each frame.
        filled: ``(T, 17)`` bool, True where a joint was missing (NaN) and filled in.
        deviation: ``(T, 17)`` float64 distance between ``positions`` and the input poses,
            NaN where the input was missing.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    joint_index: np.ndarray
    offsets: np.ndarray
    end_sites: dict[int, np.ndarray]
    root_position: np.ndarray
    orders: tuple[str, ...]
    euler_deg: np.ndarray
    bone_lengths: np.ndarray
    positions: np.ndarray
    filled: np.ndarray
    deviation: np.ndarray

    @property
    def filled_frames(self) -> np.ndarray:
        """``(T,)`` bool: frames in which at least one joint was filled in."""
        return self.filled.any(axis=1)


def _nodes(names: Sequence[str]) -> tuple[list[str], list[int], list[int]]:
    """Depth-first BVH nodes: (names, parent node indices, H36M index or -1 for a link)."""
    out_names: list[str] = []
    out_parents: list[int] = []
    out_joint: list[int] = []
    children = {j: [c for c, p in enumerate(H36M_PARENTS) if p == j] for j in range(17)}

    def visit(j: int, parent_node: int) -> None:
        if j in _LINKED:
            out_names.append(f"{names[H36M_PARENTS[j]]}_to_{names[j]}")
            out_parents.append(parent_node)
            out_joint.append(-1)
            parent_node = len(out_names) - 1
        out_names.append(names[j])
        out_parents.append(parent_node)
        out_joint.append(j)
        me = len(out_names) - 1
        for c in children[j]:
            visit(c, me)

    visit(PELVIS, -1)
    return out_names, out_parents, out_joint


def _hold(W: np.ndarray, before: np.ndarray | None = None) -> np.ndarray:
    """Replace frames with NaN rotations (degenerate geometry) by the nearest earlier, then
    later, valid frame; identity if none. ``before`` ``(3, 3)``: the valid rotation that
    precedes ``W`` (the previous chunk's), so chunks hold as the whole recording would."""
    if before is not None:
        return _hold(np.concatenate([before[None], W]))[1:]
    bad = ~np.isfinite(W).all(axis=(1, 2))
    if not bad.any():
        return W
    good = np.flatnonzero(~bad)
    if good.size == 0:
        return np.broadcast_to(np.eye(3), W.shape).copy()
    idx = np.arange(len(W))
    prev = np.maximum.accumulate(np.where(bad, -1, idx))
    prev = np.where(prev < 0, good[0], prev)
    return W[prev]


def _frame(y: np.ndarray, z_hint: np.ndarray, before: np.ndarray | None = None) -> np.ndarray:
    """``(T, 3, 3)`` rotations whose columns are (x, y, z): y along ``y``, z the part of
    ``z_hint`` perpendicular to it, x = y cross z (right-handed)."""
    yu = normalize(y, eps=0.0)
    z = z_hint - np.sum(z_hint * yu, axis=-1, keepdims=True) * yu
    zu, zn = normalize(z, eps=0.0), np.linalg.norm(z, axis=-1)
    zu[zn < 1e-9 * np.maximum(np.linalg.norm(z_hint, axis=-1), 1e-30)] = np.nan
    xu = np.cross(yu, zu)
    return _hold(np.stack([xu, yu, zu], axis=-1), before)


def _swing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(T, 3, 3)`` smallest rotations turning unit vectors ``a`` onto ``b``; identity
    where ``b`` is NaN (a zero-length bone); a half turn about an axis perpendicular to
    ``a`` where they are opposite."""
    v = np.cross(a, b)
    s = np.linalg.norm(v, axis=-1)
    c = np.sum(a * b, axis=-1)
    angle = np.arctan2(s, c)
    with np.errstate(invalid="ignore", divide="ignore"):
        axis = v / s[:, None]
    tiny = ~(s > 1e-12)
    if tiny.any():  # parallel or opposite: any axis perpendicular to a
        e = np.eye(3)[np.argmin(np.abs(a[tiny]), axis=-1)]
        axis[tiny] = normalize(np.cross(a[tiny], e), eps=0.0)
    rotvec = axis * angle[:, None]
    rotvec[~np.isfinite(rotvec).all(axis=-1)] = 0.0
    return Rotation.from_rotvec(rotvec).as_matrix()


def _fill(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per joint and coordinate, linear interpolation in time over missing samples (held
    constant before the first / after the last finite one). Returns (filled, filled mask)."""
    missing = ~np.isfinite(X).all(axis=-1)
    if not missing.any():
        return X, missing
    Y = X.copy()
    t = np.arange(len(X))
    for j in np.flatnonzero(missing.any(axis=0)):
        ok = ~missing[:, j]
        for k in range(3):
            Y[:, j, k] = np.interp(t, t[ok], X[ok, j, k])
    return Y, missing


def _rows(X, lo: int, hi: int) -> np.ndarray:
    """Frames ``[lo, hi)`` of in-memory or on-disk poses as float64, inf as NaN (missing)."""
    with np.errstate(invalid="ignore"):
        block = np.asarray(X[lo:hi], np.float64)
    return np.where(np.isinf(block), np.nan, block)


def _streamed_skeleton(poses, names: list[str], allocate=None):
    """:func:`_skeleton` of ``(T, 17, 3)`` poses in memory or on disk
    (:class:`~pcnet.stages.core.framestore.FrameArray`) read a block of frames at a time:
    ``(poses, known (T, 17) bool: joints with all three coordinates finite, skeleton)``.
    The per-frame samples the skeleton is the median of go into arrays from ``allocate(name,
    shape, dtype)`` (default in memory; a :class:`~pcnet.stages.core.framestore.FrameStore`'s
    keeps a long recording's on disk).

    Raises:
        InputError: as :func:`_checked_poses`.
    """
    poses = _pose_array(poses)
    T = len(poses)
    allocate = allocate or in_memory
    known = np.zeros((T, 17), bool)
    lengths = allocate("bvh_bone_lengths", (T, len(H36M_BONES)), np.float64)
    directions = {c: allocate(f"bvh_link_direction_{c}", (T, 3), np.float64) for c in _LINKED}
    count, before = 0, None
    for lo in range(0, T, TEXT_BLOCK_ROWS):
        hi = min(T, lo + TEXT_BLOCK_ROWS)
        block = _rows(poses, lo, hi)
        known[lo:hi] = np.isfinite(block).all(axis=-1)
        L, D, before = _skeleton_samples(block[known[lo:hi].all(axis=1)], before)
        lengths[count:count + len(L)] = L
        for c in _LINKED:
            directions[c][count:count + len(L)] = D[c]
        count += len(L)
    _require_a_complete_frame(known.all(axis=1))
    return poses, known, _skeleton_from(lengths, directions, names, count)


def _column_medians(samples, count: int) -> np.ndarray:
    """Median of each column of the first ``count`` rows of ``samples`` ``(n, k)``, read a
    column at a time (``samples`` may be on disk); equal to ``np.median(samples[:count], axis=0)``."""
    return np.array([np.median(column(samples, i)[:count]) for i in range(samples.shape[1])])


def _filled_rows(X, known: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Frames ``[lo, hi)`` of :func:`_fill` of the whole recording ``X`` (in memory or on
    disk), reading besides the block only the nearest known frame before and after each gap
    that crosses its edges (the interpolation's end points)."""
    block = _rows(X, lo, hi)
    missing = ~known[lo:hi]
    if not missing.any():
        return block
    t = np.arange(lo, hi)
    for j in np.flatnonzero(missing.any(axis=0)):
        frames = np.flatnonzero(known[:, j])
        if not len(frames):  # never seen: stays NaN, as np.interp of nothing cannot fill it
            continue
        inside = frames[(frames >= lo) & (frames < hi)]
        before, after = frames[frames < lo][-1:], frames[frames >= hi][:1]
        points = np.concatenate([before, inside, after])
        values = np.concatenate([_rows(X, f, f + 1)[:, j] for f in before]
                                + [block[inside - lo, j]] + [_rows(X, f, f + 1)[:, j] for f in after])
        for k in range(3):
            block[:, j, k] = np.interp(t, points, values[:, k])
    return block


def _check_names(who: str, joint_names: Sequence[str]) -> list[str]:
    names = [str(n) for n in joint_names]
    if len(names) != 17:
        raise InputError(f"{who}: expected 17 H36M-17 joint names, got {len(names)}: {names}")
    if any(not n or any(ch.isspace() for ch in n) or n in ("{", "}") for n in names) or len(set(names)) != 17:
        raise InputError(f"{who}: joint names must be unique, non-empty and without whitespace, got {names}")
    return names


@dataclass(frozen=True)
class _Skeleton:
    """What every frame shares: nodes, rest directions, offsets, orders (from all frames)."""

    names: list[str]
    parent: list[int]
    joint: list[int]
    children: dict[int, list[int]]
    rest_dir: dict[int, np.ndarray]
    offsets: np.ndarray
    orders: tuple[str, ...]
    lengths: np.ndarray


def _pose_array(poses):
    """``poses`` (in memory, or a :class:`~pcnet.stages.core.framestore.FrameArray` left on
    disk) once its dtype and ``(T, 17, 3)`` shape are checked.

    Raises:
        InputError: a non-numeric dtype, or a shape other than ``(T, 17, 3)`` with ``T >= 1``.
    """
    arr = poses if isinstance(poses, FrameArray) else np.asarray(poses)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise InputError(f"write_bvh: expected real-valued (float) joint coordinates, got dtype {arr.dtype}")
    if arr.ndim != 3 or arr.shape[1:] != (17, 3) or arr.shape[0] == 0:
        raise InputError(f"write_bvh: expected poses of shape (T, 17, 3) with T >= 1 (H36M-17 joints), "
                         f"got {tuple(arr.shape)}")
    return arr


def _require_a_complete_frame(complete: np.ndarray) -> None:
    """Raise :class:`InputError` unless a frame of ``complete`` ``(T,)`` has all 17 joints."""
    if not complete.any():
        raise InputError(f"write_bvh: expected at least one frame with all 17 joints finite, got none of "
                         f"{len(complete)} frames")


def _checked_poses(poses: np.ndarray, joint_names: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    names = _check_names("write_bvh", joint_names)
    # No copy of a float64 recording (a 2-hour one is 176 MB) unless it holds inf to replace.
    X = np.asarray(_pose_array(poses)).astype(np.float64, copy=False)
    if np.isinf(X).any():
        X = np.where(np.isinf(X), np.nan, X)
    _require_a_complete_frame(np.isfinite(X).all(axis=(1, 2)))
    return X, names


def _body_frames(P: np.ndarray, before: dict[int, np.ndarray] | None = None) -> dict[int, np.ndarray]:
    """World rotations ``(T, 3, 3)`` of the multi-child joints (pelvis, thorax); ``before``:
    their rotations in the frame preceding ``P`` (see :func:`_hold`)."""
    before = before or {}
    return {j: _frame(P[:, b] - P[:, a], P[:, zr] - P[:, zl], before.get(j))
            for j, ((a, b), (zl, zr)) in _FRAMES.items()}


def _skeleton_samples(Xc: np.ndarray, before: dict[int, np.ndarray] | None = None):
    """What the rest skeleton is the median of, from frames with all 17 joints ``Xc``
    ``(n, 17, 3)`` float64: bone lengths ``(n, 16)``, the link children's unit directions in
    the pelvis/thorax frames ``{joint: (n, 3)}``, and those frames' last rotations, the
    ``before`` of the next block (:func:`_hold`), so that a recording's samples gathered a
    block of frames at a time are the whole recording's."""
    lengths = np.stack([np.linalg.norm(Xc[:, c] - Xc[:, p], axis=-1) for p, c in H36M_BONES], axis=-1)
    frames = _body_frames(Xc, before)
    directions = {c: normalize(np.einsum("tji,tj->ti", frames[H36M_PARENTS[c]], Xc[:, c] - Xc[:, H36M_PARENTS[c]]), eps=0.0)
                  for c in _LINKED}
    return lengths, directions, ({j: f[-1] for j, f in frames.items()} if len(Xc) else before)


def _skeleton(X: np.ndarray, names: list[str]) -> _Skeleton:
    """The rest skeleton of raw poses ``X``, from their complete frames (where the gap-filled
    poses equal them)."""
    complete = np.isfinite(X).all(axis=(1, 2))
    return _skeleton_from(*_skeleton_samples(X[complete])[:2], names)


def _skeleton_from(bone_lengths, link_directions: dict, names: list[str], count: int | None = None) -> _Skeleton:
    """The rest skeleton from :func:`_skeleton_samples` of every complete frame (the first
    ``count`` rows of the samples, default all)."""
    bones = H36M_BONES
    count = len(bone_lengths) if count is None else count
    lengths = _column_medians(bone_lengths, count)
    length = {c: lengths[i] for i, (_, c) in enumerate(bones)}
    if not (lengths > 0).all():
        zero = [f"{names[p]}-{names[c]}" for (p, c), L in zip(bones, lengths) if not L > 0]
        raise InputError(f"write_bvh: expected bones of positive length, got median length 0 for {zero}")

    node_names, node_parent, node_joint = _nodes(names)
    N = len(node_names)
    # The link children's rest directions are their median directions in the pelvis/thorax frames.
    rest_dir = dict(_REST_DIR)
    for c in _LINKED:
        rest_dir[c] = normalize(_column_medians(link_directions[c], count), eps=0.0)
    for _, (zl, zr) in _FRAMES.values():
        # One forward (x) component for the pair, their heights and lengths kept, so that the
        # rest pose's pelvis/thorax frame is exactly the identity (zero channels = rest pose).
        a, b = rest_dir[zr] * length[zr], rest_dir[zl] * length[zl]
        x = (a[0] + b[0]) / 2
        for v, j in ((a, zr), (b, zl)):
            side = np.sqrt(max(length[j] ** 2 - x**2 - v[1] ** 2, 0.0))
            rest_dir[j] = normalize(np.array([x, v[1], np.copysign(side, v[2])]), eps=0.0)
    offsets = np.zeros((N, 3))
    for n, j in enumerate(node_joint):
        if j > 0:
            offsets[n] = rest_dir[j] * length[j]
    children = {n: [m for m in range(N) if node_parent[m] == n] for n in range(N)}
    orders = []
    for n in range(N):
        kids = children[n]
        if node_joint[n] in _FRAMES:
            orders.append(FRAME_ORDER)
        else:  # the bone it turns: to its one child, or its End Site (along its own offset)
            bone = offsets[kids[0]] if kids else rest_dir[node_joint[n]]
            orders.append(BONE_ORDER[int(np.argmax(np.abs(bone)))])
    return _Skeleton(node_names, node_parent, node_joint, children, rest_dir, offsets, tuple(orders), lengths)


def _world_rotations(P: np.ndarray, sk: _Skeleton, before: np.ndarray | None = None) -> np.ndarray:
    """``(T, N, 3, 3)`` world rotation of every node for gap-filled poses ``P``, frame by
    frame; ``before`` ``(N, 3, 3)``: the preceding chunk's last row, so that a chunk gives
    the rows the whole recording would."""
    T, N = len(P), len(sk.names)
    frames = _body_frames(P, None if before is None else {j: before[sk.joint.index(j)] for j in _FRAMES})
    W = np.empty((T, N, 3, 3))
    for n in range(N):
        j, par = sk.joint[n], sk.parent[n]
        Wp = W[:, par] if par >= 0 else np.broadcast_to(np.eye(3), (T, 3, 3))
        kids = sk.children[n]
        if j in frames:
            W[:, n] = frames[j]
        elif not kids:  # a leaf: its rotation is not observable, it follows its parent
            W[:, n] = Wp
        else:
            (k,) = kids
            target = sk.joint[k]
            here = H36M_PARENTS[target] if j < 0 else j  # a link sits at its parent joint
            carried = np.einsum("tij,j->ti", Wp, sk.rest_dir[target])
            d = normalize(P[:, target] - P[:, here], eps=0.0)
            W[:, n] = _swing(carried, d) @ Wp
    return W


def _euler(W: np.ndarray, sk: _Skeleton, previous: np.ndarray | None = None) -> np.ndarray:
    """``(T, N, 3)`` local Euler angles in degrees, each node in its order, unwrapped in time
    continuing from ``previous`` ``(N, 3)`` (the preceding chunk's last row) when given."""
    T, N = W.shape[:2]
    parent_W = np.concatenate([np.broadcast_to(np.eye(3), (T, 1, 3, 3)),
                               W[:, [max(p, 0) for p in sk.parent[1:]]]], axis=1)
    local = np.einsum("tnji,tnjk->tnik", parent_W, W)
    euler = np.empty((T, N, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # scipy's gimbal-lock note: the rotation is still exact
        for n in range(N):
            euler[:, n] = Rotation.from_matrix(local[:, n]).as_euler(sk.orders[n], degrees=True)
    if previous is None:
        return np.unwrap(euler, period=360.0, axis=0)
    return np.unwrap(np.concatenate([previous[None], euler]), period=360.0, axis=0)[1:]


def _forward(W: np.ndarray, sk: _Skeleton, root: np.ndarray) -> np.ndarray:
    """``(T, 17, 3)`` H36M-17 joint positions by forward kinematics of world rotations ``W``
    ``(T, N, 3, 3)`` and the skeleton's offsets from root positions ``root`` ``(T, 3)``."""
    T, N = W.shape[:2]
    pos = np.zeros((T, N, 3))
    pos[:, 0] = root
    for n in range(1, N):
        pos[:, n] = pos[:, sk.parent[n]] + np.einsum("tij,j->ti", W[:, sk.parent[n]], sk.offsets[n])
    node_of = {j: n for n, j in enumerate(sk.joint) if j >= 0}
    return pos[:, [node_of[j] for j in range(17)]]


def floor_shift(measured: np.ndarray, rigid: np.ndarray, known: np.ndarray) -> np.ndarray:
    """``(T,)`` vertical (Y) shift that puts the lowest joint of ``rigid`` at the height of the
    lowest joint of ``measured`` in each frame (both ``(T, 17, 3)``, Y up), the minima taken
    over the joints ``known`` ``(T, 17)`` (present in the input: the TRC's markers), or over
    all 17 (gap-filled) where a frame has none.

    Why the lowest joint: the BVH's bones have one (median) length for the recording, so its
    joints differ from the input's by the per-frame bone-length variation accumulated from the
    pelvis (a lifter's legs vary by several cm, MediaPipe's by 20 cm and more); placing the
    root at the measured pelvis carries that error to the feet, which then sink below the
    floor the world frame defines (its ground at y = 0, stance ankle centres the fitted clearance above it,
    stages/floor.py) or float above it. Matching the
    lowest joint instead keeps the floor contact exact: no BVH joint goes below the lowest
    TRC marker of its frame, and the lowest one is at its height (to the written 6 decimals).
    A least-squares fit of both ankles' heights would leave the lower foot below the floor
    whenever the two legs' rigidified lengths err differently; the price of the lowest joint
    is that the others (the pelvis included) carry the whole length error, not half of it.
    """
    known = known & np.isfinite(measured).all(axis=-1)
    none = ~known.any(axis=1)
    known = known | none[:, None]  # no joint present: the gap-filled pose (measured) decides
    with np.errstate(invalid="ignore"):
        low_measured = np.where(known, measured[..., 1], np.inf).min(axis=1)
        low_rigid = np.where(known, rigid[..., 1], np.inf).min(axis=1)
        shift = low_measured - low_rigid
    return np.where(np.isfinite(shift), shift, 0.0)


def _root_position(P: np.ndarray, known: np.ndarray, W: np.ndarray, sk: _Skeleton) -> np.ndarray:
    """``(T, 3)`` root position channels of gap-filled poses ``P``: the pelvis, raised by
    :func:`floor_shift` (``known``: the joints present in the input)."""
    root = P[:, PELVIS].copy()
    root[:, 1] += floor_shift(P, _forward(W, sk, P[:, PELVIS]), known)
    return root


def bvh_motion(poses: np.ndarray, joint_names: Sequence[str] = H36M_JOINTS) -> BvhMotion:
    """The BVH skeleton (rest offsets) and per-frame channel values of H36M-17 poses.

    See :func:`write_bvh` for the conventions; this is its computation without the file,
    for callers that need :attr:`BvhMotion.filled_frames` or :attr:`BvhMotion.deviation`.

    Args:
        poses: ``(T, 17, 3)`` float world-frame joint centres (X forward, Y up, Z right),
            any length unit; NaN (or inf) for missing joints.
        joint_names: the 17 joint names (no whitespace); default H36M-17's.

    Returns:
        a :class:`BvhMotion`.

    Raises:
        InputError: a shape other than ``(T, 17, 3)`` or ``T = 0``, a non-numeric dtype, bad
            names, no frame with all 17 joints finite, or a zero median bone length.
    """
    X, names = _checked_poses(poses, joint_names)
    P, missing = _fill(X)
    sk = _skeleton(X, names)
    W = _world_rotations(P, sk)
    euler = _euler(W, sk)

    # Forward kinematics of what the file holds (what a reader reconstructs), the root raised
    # so that the lowest joint stands where the input's does.
    N = W.shape[1]
    root = _root_position(P, ~missing, W, sk)
    positions = _forward(W, sk, root)
    deviation = np.linalg.norm(positions - X, axis=-1)

    end_sites = {n: END_SITE_FRACTION * sk.offsets[n] for n in range(N) if not sk.children[n]}
    return BvhMotion(
        names=tuple(sk.names), parents=np.array(sk.parent), joint_index=np.array(sk.joint),
        offsets=sk.offsets, end_sites=end_sites, root_position=root,
        orders=sk.orders, euler_deg=euler,
        bone_lengths=sk.lengths, positions=positions, filled=missing, deviation=deviation,
    )


def write_bvh(
    path: str | os.PathLike,
    poses: np.ndarray,
    fps: float,
    *,
    units: str = "m",
    joint_names: Sequence[str] = H36M_JOINTS,
    allocate=None,
) -> Path:
    """Write H36M-17 world-frame poses as a BVH (Biovision hierarchy) motion file, atomically.

    Format: Biovision BVH (M. Meredith, S. Maddock, "Motion capture file formats
    explained", University of Sheffield, 2001), as read by Blender's BVH importer and
    bvhio; tab-indented, ``\\n`` line ends, values with 6 decimals.

    **Hierarchy** (22 joints): ``ROOT`` pelvis (6 channels ``Xposition Yposition Zposition
    Zrotation Xrotation Yrotation``) and 21 ``JOINT``\\s with 3 rotation channels each: the 17
    H36M-17 joints named ``joint_names``, plus five links with zero offset,
    ``pelvis_to_right_hip``, ``pelvis_to_left_hip``, ``thorax_to_neck_nose``,
    ``thorax_to_left_shoulder`` and ``thorax_to_right_shoulder`` (as CMU's ``LHipJoint``),
    so that each of these bones has its own rotation and the hips, nose and shoulders are
    reproduced exactly rather than by a best fit of the pelvis/thorax. The leaves (ankles,
    head, wrists) carry zero rotations (not observable from joint centres) and an ``End
    Site`` stub continuing their bone by :data:`END_SITE_FRACTION` of its length (display
    only, no measured point).

    **Rest pose and offsets**: a T-pose in the input's axes (X forward, Y up, Z right:
    pcnet's world frame, which has BVH's usual Y-up): legs straight down, spine, thorax and
    head straight up, arms straight out sideways (left -Z, right +Z); pelvis->hip,
    thorax->nose and thorax->shoulder offsets point along the subject's median direction in
    the pelvis/thorax frame (the two hips, and the two shoulders, share one forward
    component, their mean, so that the rest pose has exactly zero rotations). Offset
    lengths are the subject's median bone lengths over the frames with all joints finite. The root offset is zero.

    **Root position** (the floor): the position channels hold the pelvis's horizontal
    position (X, Z) and, in each frame, the height (Y) that puts the rigidified skeleton's
    lowest joint at the height of the input's lowest joint (over the joints present in that
    frame: the TRC's markers; all 17 gap-filled ones where none is), :func:`floor_shift`.
    The BVH thus stands on the same floor as the TRC, CSV and npz of the same poses (in the
    world frame no BVH joint goes below y = 0 where the TRC has none, and its lowest joint is
    at the TRC's lowest marker height); the pelvis height then differs from the measured one
    by the legs' bone-length variation. Placing the root at the measured pelvis instead would
    carry that variation to the feet (on a MediaPipe run, feet 20 cm below the floor); a
    least-squares fit of the two ankles' heights would still sink the lower foot whenever
    the two legs err differently.

    **Rotations**: local (parent-relative), degrees, unwrapped in time so that no channel
    jumps by 360 degrees. Each joint declares its own order (BVH allows it; readers such as
    Blender's and bvhio honour it); channels ``Zrotation Xrotation Yrotation`` mean
    ``R = Rz @ Rx @ Ry`` on column vectors, scipy ``Rotation.from_euler("ZXY", [z, x, y],
    degrees=True)``:

    * pelvis (root) and thorax: :data:`FRAME_ORDER` ``ZXY`` (heading about Y and forward
      bending about Z unrestricted; gimbal lock only at 90 degrees of sideways lean);
    * a joint that turns one bone (its child, or for a leaf its End Site): the bone's rest
      axis (the largest component of its rest direction) in the middle
      (:data:`BONE_ORDER`): ``ZYX`` for bones along Y (legs, spine, neck, head), ``XZY``
      along Z (arms, hip and shoulder links), ``YXZ`` along X (the nose link when the nose
      sits more in front of the thorax than above it), so the gimbal lock coincides with the swing's own singularity below (a single order
      for all, e.g. ``ZXY``, would lock with the arms hanging at the sides).

    How each joint's rotation is chosen:

    * pelvis: the frame with y along pelvis->spine and z along the part of the hip line
      (left_hip->right_hip) perpendicular to it (x = y cross z, forward);
    * thorax: y along spine->thorax, z along the shoulder line (left->right) made
      perpendicular (its rotation relative to the spine is a pure twist about the trunk);
    * every other joint with one child (including the links): the smallest rotation
      (swing) that turns the child's rest direction, as carried by the parent, onto the
      bone's direction in that frame: twist about the bone is not observable from joint
      centres and is taken as zero relative to the parent. This is continuous in time
      except where a bone points exactly opposite to its carried rest direction (e.g. an
      arm held straight across the chest, pointing to the other side), where the swing
      axis is undefined and the channels of that joint can jump (positions stay exact).

    The file therefore reproduces the poses **rigidified** to the median bone lengths (each
    bone keeps its per-frame direction, its length is the median), moved vertically onto the
    input's floor as above, to the written precision (well below 0.01 mm in metres); the
    distance to the raw poses is the bone-length variation accumulated along each chain
    from the lowest joint (:attr:`BvhMotion.deviation` from :func:`bvh_motion`).

    **Units**: ``units`` names the unit of ``poses``, written unchanged; BVH has no unit
    field, so a reader must be told (Blender's importer takes the values as scene units
    times its Scale option; tools that expect centimetres need ``poses * 100`` with
    ``units="cm"``).

    **Missing data**: BVH cannot hold NaN. A missing joint (NaN or inf) is filled, per joint
    and coordinate, by linear interpolation in time between its nearest finite samples, and
    held constant before the first / after the last one; then rigidified as above. Nothing is
    filled silently: :func:`bvh_motion` returns the mask (:attr:`BvhMotion.filled`,
    :attr:`BvhMotion.filled_frames`) for the caller to report. At least one frame must have
    all 17 joints finite.

    Args:
        path: destination ``.bvh`` (its folder must exist).
        poses: ``(T, 17, 3)`` float world-frame joint centres (H36M-17 order, X forward, Y up,
            Z right) in ``units``; NaN for missing.
        fps: frame rate in Hz; ``Frame Time`` is ``1 / fps`` s.
        units: ``"m"`` (default, pcnet's unit), ``"cm"`` or ``"mm"``.
        joint_names: the 17 joint names (unique, no whitespace); default H36M-17's.
        allocate: ``allocate(name, shape, dtype)`` for the per-frame samples of the bone
            lengths and link directions (float64, 31 values per frame) whose medians give the
            skeleton; default in memory (``pcnet run`` passes its
            :class:`~pcnet.stages.core.framestore.FrameStore`'s ``create``).

    Returns:
        the destination path.

    Raises:
        InputError: a shape other than ``(T, 17, 3)``, no frames, a non-numeric dtype, an
            fps outside [1, 10000] Hz, unknown units, bad joint names, no frame with all
            joints finite, a zero median bone length, or an unwritable destination.
    """
    fps = validate_fps(fps, "write_bvh: fps")
    if units not in BVH_UNITS:
        raise InputError(f"write_bvh: units must be one of {list(BVH_UNITS)}, got {units!r}")
    names = _check_names("write_bvh", joint_names)
    X, known, sk = _streamed_skeleton(poses, names, allocate)
    kids = sk.children
    lines = ["HIERARCHY"]

    def vec(v: np.ndarray) -> str:
        return " ".join(f"{x:.6f}" for x in v)

    def block(n: int, depth: int) -> None:
        ind = "\t" * depth
        lines.append(f"{ind}{'ROOT' if n == 0 else 'JOINT'} {sk.names[n]}")
        lines.append(f"{ind}{{")
        lines.append(f"{ind}\tOFFSET {vec(sk.offsets[n])}")
        rot = " ".join(f"{axis}rotation" for axis in sk.orders[n])
        lines.append(f"{ind}\tCHANNELS 6 Xposition Yposition Zposition {rot}" if n == 0
                     else f"{ind}\tCHANNELS 3 {rot}")
        for k in kids[n]:
            block(k, depth + 1)
        if not kids[n]:
            lines.extend([f"{ind}\tEnd Site", f"{ind}\t{{", f"{ind}\t\tOFFSET {vec(END_SITE_FRACTION * sk.offsets[n])}",
                          f"{ind}\t}}"])
        lines.append(f"{ind}}}")

    block(0, 0)
    T = len(X)
    lines += ["MOTION", f"Frames: {T}", f"Frame Time: {1.0 / fps:.10f}"]
    previous, last_W = None, None
    with atomic_path(path) as tmp, open(tmp, "w", newline="\n", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
        # Channels a block of frames at a time (each frame's rotations are its own; only the
        # unwrapping carries over), so a 2-hour recording never holds all its rotations.
        for lo in range(0, T, TEXT_BLOCK_ROWS):
            hi = min(T, lo + TEXT_BLOCK_ROWS)
            block_P = _filled_rows(X, known, lo, hi)
            W = _world_rotations(block_P, sk, last_W)
            euler = _euler(W, sk, previous)
            previous, last_W = euler[-1], W[-1]
            root = _root_position(block_P, known[lo:hi], W, sk)
            values = np.concatenate([root, euler.reshape(len(euler), -1)], axis=1)
            if not np.isfinite(values).all():  # never a NaN in a BVH; a bug if reached
                raise AssertionError("write_bvh: non-finite channel value")
            fh.writelines(" ".join(f"{v:.6f}" for v in row) + "\n" for row in values.tolist())
    return Path(path)
