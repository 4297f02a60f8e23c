"""Metric scaling of non-metric lifter output from the subject's height.

MotionBERT's default output is in normalised image units (Walter0807/MotionBERT
``infer_wild.py``, ``X3D.npy``; maintainer answers in its issues #9 and #21) and no
lifter recovers metres from one camera. Given the subject's standing height, one
scale factor per sequence turns the skeleton into metres.

The estimate uses **bone lengths, not vertical extent**, so it does not need a standing
frame: a lying, crouching or cartwheeling subject scales the same way.

Derivation of :data:`CHAIN_TO_STATURE`
--------------------------------------
The chain is ankle -> knee -> hip (leg; left and right averaged) plus
pelvis -> spine -> thorax -> neck_nose -> head (trunk, neck and head).

* In the Human3.6M reference skeleton (the 32-joint offsets shipped with H36M and used
  by Martinez et al. 2017, ``human-motion-prediction/src/forward_kinematics.py``,
  millimetres) these bones are exactly collinear and vertical in the rest pose:
  shank 454.21, thigh 442.89, pelvis->spine 233.48 (0.10 + 233.38), spine->thorax
  257.08, thorax->neck_nose 121.13, neck_nose->head 115.00; sum 1623.8 mm. H36M-17
  joint 10 ("head") is that skeleton's head end site (VideoPose3D keeps 32-joint index
  15, the end of the head segment), taken here as the vertex, and the hip joints sit
  level with the pelvis (a purely lateral 132.95 mm offset). So the chain spans ankle
  joint -> vertex of a standing subject.
* Stature adds the ankle-joint height above the floor, 0.039 H (Drillis & Contini 1966,
  as tabulated in Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed.,
  2009, fig. 4.1).
* Hence chain = (1 - 0.039) H and ``CHAIN_TO_STATURE = 0.961``.

The lateral pelvis->hip bones are left out of the chain on purpose: in that skeleton
they are horizontal and add nothing to stature. Assumptions, stated so users can judge
them: the subject's proportions match H36M's head-to-ankle proportions; the lifter's
bone lengths are those of a real skeleton up to one scale. Proportions differ between
people and between anthropometric tables (Winter's leg fraction 0.491 H would give the
H36M skeleton a stature of 1.83 m, against 1.69 m from the whole chain), so expect the
scale to be off by several per cent (up to about 8 %) for an individual.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter

from .core.conventions import (
    H36M_JOINTS,
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
    check_poses,
)
from .core.errors import InputError
from .core.framestore import seen_joints

#: Head-to-ankle bone chain divided by stature (module docstring: H36M reference
#: skeleton + Drillis & Contini ankle height 0.039 H).
CHAIN_TO_STATURE = 1.0 - 0.039

#: Units of lifter output that follow the person's size in the image (normalised pixel
#: coordinates, pixels): a subject walking towards the camera grows in them.
IMAGE_SCALED_UNITS = ("normalised", "px")
#: Window of the running median that smooths the per-frame size (seconds): long enough to
#: average a lifter's frame-to-frame bone-length noise, short against a walk towards the
#: camera (1.5 m/s from 6 m to 2 m triples the size in under 3 s).
SIZE_WINDOW_S = 1.0

#: The limbs' long bones of H36M-17, by name: (proximal joint, distal joint).
LIMB_BONES = {"right thigh": (R_HIP, R_KNEE), "right shank": (R_KNEE, R_ANKLE), "left thigh": (L_HIP, L_KNEE),
              "left shank": (L_KNEE, L_ANKLE), "right upper arm": (R_SHOULDER, R_ELBOW),
              "right forearm": (R_ELBOW, R_WRIST), "left upper arm": (L_SHOULDER, L_ELBOW),
              "left forearm": (L_ELBOW, L_WRIST)}
_LEG_BONES = tuple((LIMB_BONES[f"{side} thigh"], LIMB_BONES[f"{side} shank"]) for side in ("right", "left"))
_AXIAL_BONES = ((PELVIS, SPINE), (SPINE, THORAX), (THORAX, NECK_NOSE), (NECK_NOSE, HEAD))


def _bone_length(X: np.ndarray, a: int, b: int) -> np.ndarray:
    return np.linalg.norm(np.asarray(X[:, b], np.float64) - np.asarray(X[:, a], np.float64), axis=-1)


def leg_lengths(joints: np.ndarray) -> np.ndarray:
    """Per-frame leg lengths, shank plus thigh, of H36M-17 poses ``(T, 17, 3)`` (any frame
    and units, in memory or on disk): ``(T, 2)`` float64, right then left; NaN where a
    joint of that leg is missing."""
    return np.stack([sum(_bone_length(joints, a, b) for a, b in side) for side in _LEG_BONES], -1)


def limb_lengths(joints: np.ndarray) -> np.ndarray:
    """Per-frame lengths of the :data:`LIMB_BONES` of H36M-17 poses ``(T, 17, 3)`` (any frame
    and units, in memory or on disk): ``(T, 8)`` float64 in that order; NaN where a joint is
    missing."""
    return np.stack([_bone_length(joints, a, b) for a, b in LIMB_BONES.values()], -1)


def mean_leg_length(joints: np.ndarray) -> np.ndarray:
    """Per-frame leg length of H36M-17 poses ``(T, 17, 3)`` (any frame and units, in memory or
    on disk): ``(T,)`` float64, the mean of :func:`leg_lengths` over the legs present (one
    visible leg is enough: left and right legs have the same length); NaN where neither is."""
    legs = leg_lengths(joints)
    n = np.isfinite(legs).sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.nansum(legs, axis=-1) / n, np.nan)


def height_chain_length(joints: np.ndarray) -> np.ndarray:
    """Per-frame standing-height proxy: the head-to-ankle chain of bone lengths.

    ``shank + thigh`` (mean of left and right; one side alone when the other is NaN)
    ``+ |pelvis-spine| + |spine-thorax| + |thorax-neck_nose| + |neck_nose-head|``.

    Args:
        joints: ``(T, 17, 3)`` H36M-17, any frame, any units.

    Returns:
        ``(T,)`` float64 in the units of ``joints``; NaN where the chain is incomplete.

    Raises:
        InputError (a ValueError): wrong shape.
    """
    X = check_poses(joints, "joints")  # joint columns read as float64 (in memory or on disk)
    leg = mean_leg_length(X)
    axial = sum(_bone_length(X, a, b) for a, b in _AXIAL_BONES)
    return leg + axial


def _measurable_chain(joints: np.ndarray, who: str) -> tuple[np.ndarray, np.ndarray]:
    """:func:`height_chain_length` ``(T,)`` and ``(T,)`` bool, the frames where it is finite
    and positive; an :class:`InputError` naming ``who`` when there is none."""
    chain = height_chain_length(joints)
    good = np.isfinite(chain) & (chain > 0)
    if not good.any():
        absent = chain_joints_lacking(seen_joints(check_poses(joints, "joints")))
        why = f": {', '.join(absent)} missing in every frame (the input's skeleton has no such joint)" if absent else ""
        raise InputError(f"{who}: no frame has a complete {HEIGHT_CHAIN}, so the skeleton size cannot be "
                         f"estimated{why}")
    return chain, good


#: The joints :func:`height_chain_length` measures, as messages name them.
HEIGHT_CHAIN = "ankle-knee-hip / pelvis-spine-thorax-neck_nose-head chain"


def chain_joints_lacking(seen: np.ndarray) -> list[str]:
    """The joints of :func:`height_chain_length`'s chain that a skeleton never has, by name:
    each trunk joint not ``seen``, and ``"<right>/<left>"`` for a leg joint seen on neither
    side (one leg is enough).

    Args:
        seen: ``(17,)`` bool, whether each H36M-17 joint is present in some frame
            (:func:`pcnet.stages.core.framestore.seen_joints`).

    Returns:
        The names, empty when the chain can be complete.
    """
    absent = [H36M_JOINTS[j] for j in dict.fromkeys(np.ravel(_AXIAL_BONES)) if not seen[j]]
    right, left = ([j for bone in bones for j in bone] for bones in _LEG_BONES)
    return absent + [f"{H36M_JOINTS[r]}/{H36M_JOINTS[lf]}" for r, lf in dict.fromkeys(zip(right, left))
                     if not (seen[r] or seen[lf])]


def height_factor(joints: np.ndarray, height_m: float, who: str = "joints") -> float:
    """Metres per input unit of a pose sequence, from the subject's standing height.

    ``factor = height_m / (median_t chain_t / CHAIN_TO_STATURE)``, where ``chain_t`` is
    :func:`height_chain_length` and the median runs over the frames where the chain is
    finite and positive (robust to frames with a mis-estimated limb). See the module
    docstring for the derivation of ``CHAIN_TO_STATURE = 0.961`` (H36M reference skeleton,
    Drillis & Contini / Winter 2009 ankle height) and its uncertainty (several per cent).
    The caller multiplies the poses by it (a block at a time for poses on disk).

    Args:
        joints: ``(T, 17, 3)`` (or ``(17, 3)``) H36M-17 poses in any frame and any
            consistent units (normalised, pixels, metres), in memory or a
            :class:`~pcnet.stages.core.framestore.FrameArray`; NaN for missing joints.
        height_m: the subject's standing height in metres.
        who: what the error names (the input file and option).

    Raises:
        InputError (a ValueError): ``height_m`` not a finite number > 0, wrong shape, or no
            frame with a complete head-to-ankle chain.
    """
    if not np.isfinite(height_m) or height_m <= 0:
        raise InputError(f"height_m must be a finite height in metres > 0, got {height_m!r}")
    chain, good = _measurable_chain(joints, who)
    stature = float(np.median(chain[good])) / CHAIN_TO_STATURE
    return float(height_m) / stature


def size_normalising_factors(joints: np.ndarray, fps: float, window_s: float = SIZE_WINDOW_S) -> np.ndarray:
    """Per-frame factors that give every frame the recording's median body size, for lifter
    output in image units (:data:`IMAGE_SCALED_UNITS`).

    Such output is the 2D keypoints lifted in the image's scale (MotionBERT's
    ``infer_wild.py``: keypoints normalised by one crop scale per clip, 3D in the same
    units; Walter0807/MotionBERT issues #9, #21), so the skeleton's size is proportional to
    the person's size in the image, which changes as they move in depth. The ankle-to-head
    bone chain (:func:`height_chain_length`) does not depend on the pose, so its running
    median over ``window_s`` is the frame's size: ``factor_t = median_all(chain) /
    running_median_t(chain)``. Frames without a complete chain take the size interpolated
    between their neighbours (the nearest one at the ends).

    Args:
        joints: ``(T, 17, 3)`` H36M-17 poses in image units (any frame).
        fps: frame rate, Hz (> 0).
        window_s: running-median window, seconds (at least one frame).

    Returns:
        ``(T,)`` float64 factors (1 where the size is the median).

    Raises:
        InputError (a ValueError): wrong shape, ``fps`` not > 0, or no frame with a complete
            chain.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise InputError(f"size_normalising_factors: fps must be > 0, got {fps!r}")
    chain, good = _measurable_chain(joints, "size_normalising_factors")
    frames = np.arange(len(chain))
    filled = np.interp(frames, frames[good], chain[good])
    size = median_filter(filled, size=max(1, int(round(window_s * fps))) | 1, mode="nearest")
    return float(np.median(chain[good])) / size

