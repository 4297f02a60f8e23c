"""pcnet's conventions as data: joint layouts, their mappings to H36M-17, and the frames.

Everything here restates ``docs/CONVENTIONS.md``; every room of pcnet imports it, nothing
redefines it.

Frames
------
* **camera frame** (what adapters deliver): OpenCV axes, +x right in the image, +y down,
  +z forward (away from the camera), pelvis at the origin.
* **canonical frame** (what rectification delivers, ISB / OpenSim global-frame axes):
  origin pelvis, +Y up (against gravity), +Z the subject's right (horizontal part of
  right_hip - left_hip), +X anterior = Y x Z.
* **rotation**: ``R`` maps canonical to camera, ``x_cam = R @ x_canon``; for row-vector
  arrays ``X_cam = X_canon @ R.T`` and ``X_canon = X_cam @ R``. Up in the camera frame is
  ``R[:, 1]``.

Joint-layout sources: H36M-17 from VideoPose3D ``common/skeleton.py``; COCO-17 and Halpe-26
from AlphaPose/Halpe-FullBody; BODY_25 from OpenPose ``doc/02_output.md``; BlazePose-33 from
MediaPipe ``PoseLandmark``. Mappings to H36M-17: MotionBERT ``coco2h36m`` / ``halpe2h36m``;
BODY_25 and BlazePose-33 follow the same mid-point recipe with their own indices.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .errors import InputError, shown_value
from .framestore import FrameArray, frame_blocks

H36M_JOINTS: tuple[str, ...] = (
    "pelvis", "right_hip", "right_knee", "right_ankle", "left_hip", "left_knee",
    "left_ankle", "spine", "thorax", "neck_nose", "head", "left_shoulder",
    "left_elbow", "left_wrist", "right_shoulder", "right_elbow", "right_wrist",
)
H36M_PARENTS: tuple[int, ...] = (-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 9, 8, 11, 12, 8, 14, 15)
H36M_BONES: tuple[tuple[int, int], ...] = tuple(
    (p, c) for c, p in enumerate(H36M_PARENTS) if p >= 0
)
H36M_LR_PAIRS: tuple[tuple[int, int], ...] = ((4, 1), (5, 2), (6, 3), (11, 14), (12, 15), (13, 16))
#: Joint order of the left-right mirror image: ``poses[:, H36M_MIRROR_ORDER]`` swaps every left
#: joint with its right one (:data:`H36M_LR_PAIRS`); the mirror's coordinate flip is the caller's.
_MIRROR_SWAP = {**dict(H36M_LR_PAIRS), **{right: left for left, right in H36M_LR_PAIRS}}
H36M_MIRROR_ORDER: tuple[int, ...] = tuple(_MIRROR_SWAP.get(j, j) for j in range(17))

# Named indices used by the geometry; joint 9 (nose) is never a spine point.
PELVIS, R_HIP, R_KNEE, R_ANKLE, L_HIP, L_KNEE, L_ANKLE = 0, 1, 2, 3, 4, 5, 6
SPINE, THORAX, NECK_NOSE, HEAD = 7, 8, 9, 10
L_SHOULDER, L_ELBOW, L_WRIST, R_SHOULDER, R_ELBOW, R_WRIST = 11, 12, 13, 14, 15, 16

# Canonical->camera rotation of a level camera in front of the subject, looking at it:
# canonical up (+Y) -> camera -y, subject's right (+Z) -> image left (-x),
# anterior (+X, towards the camera) -> camera -z.
R_FRONTAL = np.array([[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]])


@dataclass(frozen=True)
class Layout:
    """A 2D/3D keypoint layout and its recipe to H36M-17.

    ``to_h36m[k]`` lists the source joints whose mean gives H36M joint ``k`` (coordinates
    are averaged; confidence takes the minimum so that one missing parent invalidates the
    synthetic joint, pcnet's own choice: MotionBERT's ``halpe2h36m``/``coco2h36m`` in
    ``lib/data/dataset_wild.py``/``lib/data/dataset_action.py`` average it instead).
    """

    name: str
    joints: tuple[str, ...]
    bones: tuple[tuple[int, int], ...]
    lr_pairs: tuple[tuple[int, int], ...]
    to_h36m: tuple[tuple[int, ...], ...]

    @property
    def num_joints(self) -> int:
        return len(self.joints)


_COCO_JOINTS = (
    "nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hip",
    "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
)
_COCO_BONES = (
    (15, 13), (13, 11), (16, 14), (14, 12), (11, 12), (5, 11), (6, 12), (5, 6), (5, 7),
    (6, 8), (7, 9), (8, 10), (1, 2), (0, 1), (0, 2), (1, 3), (2, 4),
)
_COCO_LR = ((1, 2), (3, 4), (5, 6), (7, 8), (9, 10), (11, 12), (13, 14), (15, 16))

H36M17 = Layout(
    "h36m17", H36M_JOINTS, H36M_BONES, H36M_LR_PAIRS, tuple((k,) for k in range(17))
)

COCO17 = Layout(
    "coco17", _COCO_JOINTS, _COCO_BONES, _COCO_LR,
    (
        (11, 12), (12,), (14,), (16,), (11,), (13,), (15,),
        (5, 6, 11, 12),  # spine = mean(pelvis, thorax) = mean of shoulders and hips
        (5, 6), (0,), (1, 2), (5,), (7,), (9,), (6,), (8,), (10,),
    ),
)

HALPE26 = Layout(
    "halpe26",
    _COCO_JOINTS + (
        "head", "neck", "hip", "left_big_toe", "right_big_toe", "left_small_toe",
        "right_small_toe", "left_heel", "right_heel",
    ),
    _COCO_BONES[:12] + (
        (17, 18), (18, 19), (18, 5), (18, 6), (19, 11), (19, 12), (0, 18),
        (15, 20), (15, 22), (15, 24), (16, 21), (16, 23), (16, 25),
    ),
    _COCO_LR + ((20, 21), (22, 23), (24, 25)),
    (
        (19,), (12,), (14,), (16,), (11,), (13,), (15,), (18, 19), (18,), (0,), (17,),
        (5,), (7,), (9,), (6,), (8,), (10,),
    ),
)

BODY25 = Layout(
    "body25",
    (
        "nose", "neck", "right_shoulder", "right_elbow", "right_wrist", "left_shoulder",
        "left_elbow", "left_wrist", "mid_hip", "right_hip", "right_knee", "right_ankle",
        "left_hip", "left_knee", "left_ankle", "right_eye", "left_eye", "right_ear",
        "left_ear", "left_big_toe", "left_small_toe", "left_heel", "right_big_toe",
        "right_small_toe", "right_heel",
    ),
    (
        (0, 1), (1, 2), (2, 3), (3, 4), (1, 5), (5, 6), (6, 7), (1, 8), (8, 9), (9, 10),
        (10, 11), (8, 12), (12, 13), (13, 14), (0, 15), (15, 17), (0, 16), (16, 18),
        (14, 19), (19, 20), (14, 21), (11, 22), (22, 23), (11, 24),
    ),
    (
        (5, 2), (6, 3), (7, 4), (12, 9), (13, 10), (14, 11), (16, 15), (18, 17),
        (19, 22), (20, 23), (21, 24),
    ),
    (
        (8,), (9,), (10,), (11,), (12,), (13,), (14,), (1, 8), (1,), (0,), (15, 16),
        (5,), (6,), (7,), (2,), (3,), (4,),
    ),
)

BLAZEPOSE33 = Layout(
    "blazepose33",
    (
        "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner",
        "right_eye", "right_eye_outer", "left_ear", "right_ear", "mouth_left",
        "mouth_right", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
        "left_wrist", "right_wrist", "left_pinky", "right_pinky", "left_index",
        "right_index", "left_thumb", "right_thumb", "left_hip", "right_hip", "left_knee",
        "right_knee", "left_ankle", "right_ankle", "left_heel", "right_heel",
        "left_foot_index", "right_foot_index",
    ),
    (
        (11, 12), (11, 13), (13, 15), (12, 14), (14, 16), (11, 23), (12, 24), (23, 24),
        (23, 25), (25, 27), (24, 26), (26, 28), (27, 29), (29, 31), (27, 31), (28, 30),
        (30, 32), (28, 32), (0, 2), (0, 5), (2, 7), (5, 8),
    ),
    (
        (1, 4), (2, 5), (3, 6), (7, 8), (9, 10), (11, 12), (13, 14), (15, 16), (17, 18),
        (19, 20), (21, 22), (23, 24), (25, 26), (27, 28), (29, 30), (31, 32),
    ),
    (
        (23, 24), (24,), (26,), (28,), (23,), (25,), (27,), (11, 12, 23, 24), (11, 12),
        (0,), (2, 5), (11,), (13,), (15,), (12,), (14,), (16,),
    ),
)

LAYOUTS: dict[str, Layout] = {
    lay.name: lay for lay in (H36M17, COCO17, HALPE26, BODY25, BLAZEPOSE33)
}


def get_layout(name: str) -> Layout:
    """Look up a layout by name (``h36m17``, ``coco17``, ``halpe26``, ``body25``, ``blazepose33``).

    Raises:
        ValueError: for an unknown name, listing the known ones.
    """
    key = name.lower().replace("-", "").replace("_", "")
    for lay in LAYOUTS.values():
        if lay.name == key:
            return lay
    raise InputError(f"unknown joint layout {name!r}; expected one of {sorted(LAYOUTS)}")


def _unmasked(joints, name: str = "poses") -> np.ndarray:
    """``joints`` as an array, a numpy masked array's masked values NaN (missing): ``np.asarray``
    alone would return the values the mask hides."""
    if np.ma.isMaskedArray(joints) and (np.issubdtype(joints.dtype, np.floating)
                                        or np.issubdtype(joints.dtype, np.integer)):  # complex, bool: refused later
        return np.ma.filled(joints.astype(np.float64), np.nan)
    # a developer trial's rectify(root_relative(x)) got numpy's "nested sequence" message
    if isinstance(joints, tuple) and len(joints) == 2 and np.ndim(joints[0]) == 3:
        raise InputError(f"{name}: expected a (T, 17, 3) array, got a tuple of 2 arrays (root_relative returns "
                         f"(poses, pelvis filled): pass poses, its [0])")
    try:
        return np.asarray(joints)
    except ValueError:  # a ragged nested list: numpy's own message names no shape
        raise InputError(f"{name}: expected (N, 17, 3) joints, got a nested sequence of unequal lengths") from None


def shape_hint(shape: tuple[int, ...], num_joints: int = 17) -> str:
    """What a wrongly shaped pose array most likely is, as a clause to end an error line with
    (``""`` where nothing fits): another layout's joint count (:data:`LAYOUTS`), to be remapped to
    H36M-17 first, or the frame, joint and coordinate axes in another order (the transpose that
    orders them), or 2D keypoints."""
    if len(shape) == 3 and shape[-1] == 3 and shape[1] != num_joints:
        named = [lay.name for lay in LAYOUTS.values() if lay.num_joints == shape[1]]
        if named:
            return (f" ({shape[1]} joints: the {' or '.join(named)} layout? remap it first: "
                    f"pcnet.stages.remap.remap_to_h36m(points, {named[0]!r}), or pcnet run --lifter generic --layout "
                    f"{named[0]})")
    if len(shape) == 3 and shape[1] == num_joints and shape[-1] == 2:  # a developer trial passed 2D keypoints
        return " (2D keypoints? pcnet takes a lifter's 3D poses: lift them first)"
    # the exact axes, since an ergonomist's (20, 3, T) array was told only "another order"
    for axes in ((2, 0, 1), (2, 1, 0), (0, 2, 1), (1, 0, 2), (1, 2, 0)):
        if len(shape) == 3 and (shape[axes[1]], shape[axes[2]]) == (num_joints, 3):
            return f" (axes in another order? np.transpose(a, {axes}) gives (T, {num_joints}, 3))"
    return ""


def check_poses(joints: np.ndarray, name: str = "poses", num_joints: int = 17) -> np.ndarray:
    """Validate and return ``joints`` as float32 ``(N, J, 3)``; a single ``(J, 3)`` pose is
    promoted to ``(1, J, 3)``. A long recording's :class:`~.framestore.FrameArray` (on disk,
    float) is returned as it is once its shape is checked. A numpy masked array's masked
    values are missing: NaN.

    Raises:
        ValueError: naming ``name`` and the expected shape when the shape is wrong.
    """
    if isinstance(joints, FrameArray):  # on disk: checked, never read whole
        if joints.shape[1:] != (num_joints, 3) or not np.issubdtype(joints.dtype, np.floating):
            raise InputError(f"{name}: expected float (N, {num_joints}, 3) H36M-17 joints, got "
                             f"{joints.shape} {joints.dtype}")
        return joints
    arr = _unmasked(joints, name)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (num_joints, 3):
        raise InputError(
            f"{name}: expected shape (N, {num_joints}, 3) H36M-17 joints, got {tuple(np.shape(joints))}"
            f"{shape_hint(np.shape(joints), num_joints)}"
        )
    if not np.issubdtype(arr.dtype, np.number):
        raise InputError(f"{name}: expected a numeric array, got dtype {arr.dtype}")
    return arr.astype(np.float32, copy=False)


#: Largest plausible absolute coordinate per unit (``Poses3D.units``; ``None`` = unknown):
#: 100 m (no recording spans more), 1e5 px (a 100-megapixel frame is 1e4 wide) and 1e3 for
#: MotionBERT's image-normalised scale (about [-1, 1]). Larger values are a unit or file
#: error, never a pose.
MAX_ABS_COORDINATE: dict[str | None, float] = {"m": 100.0, "px": 1e5, "normalised": 1e3, None: 1e5}


#: Frame rates pcnet accepts (Hz): from a slow 1 fps time-lapse to high-speed video.
MIN_FPS, MAX_FPS = 1.0, 10_000.0


def validate_fps(fps: object, source: str = "fps") -> float:
    """The frame rate as a float after checking it is a finite number in
    [:data:`MIN_FPS`, :data:`MAX_FPS`] Hz (filters and windows are sized from it, so an absurd
    rate would ask for absurd memory).

    Raises:
        InputError: naming ``source``, the range and the value.
    """
    # A string or bool is refused, not converted: "30" is a parsing slip of the caller's, and
    # True would read as 1 Hz (every entry point then agrees on what a frame rate is).
    kind = fps.dtype.kind if isinstance(fps, np.ndarray) else None  # npz["fps"] is a 0-d array
    if isinstance(fps, (bool, np.bool_, str, bytes)) or kind in ("b", "U", "S", "O"):
        raise InputError(f"{source}: expected a frame rate in Hz (a number), got {shown_value(fps)} "
                         f"({type(fps).__name__})")
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise InputError(f"{source}: expected a frame rate in Hz, got {shown_value(fps)}") from None
    if not (np.isfinite(value) and MIN_FPS <= value <= MAX_FPS):
        raise InputError(f"{source}: expected a frame rate in [{MIN_FPS:g}, {MAX_FPS:g}] Hz, got {value:g}")
    return value


def placeholder_joints(values: np.ndarray, keep_root: bool = True, root: int | None = 0) -> np.ndarray:
    """Which joints of 3D poses are a writer's placeholder for "not detected", not a position.

    Two exact coincidences that no measured pose has: every present joint of a frame (two or
    more) at one point (a frame written as zeros, or collapsed onto the root), and two or more
    joints of a frame at exactly ``(0, 0, 0)`` (trackers such as Kinect's write ``(0, 0, 0)``
    for an untracked joint), each of which is then a placeholder. One joint alone at the
    origin is kept where the layout's root is unknown: it may be the root of root-relative
    poses (MotionBERT, VideoPose3D). With ``keep_root`` (H36M-17, whose root is the pelvis,
    joint 0) the root is that joint: it is kept at the origin, and any other joint there is a
    placeholder even alone (it would sit on the root of root-relative poses, or on the camera
    centre of camera-frame ones; a user trial's wrist written as zeros had been kept). A layout
    whose pelvis is no single joint (COCO-17, BlazePose-33: the mean of the hips) has no joint
    that root-relative poses put at the origin, so with ``keep_root`` and ``root=None`` every
    joint there is a placeholder, even alone (a user trial's COCO hip written as zeros had made
    a pelvis halfway to the camera centre).

    Args:
        values: ``(T, J, D)`` float coordinates (3D poses; 2D keypoints' ``x, y``), NaN = missing.
        keep_root: the layout's root is known: ``root``, the joint kept at the origin unless its
            whole frame is collapsed (H36M-17's pelvis, joint 0), or ``None``, no such joint.
        root: see ``keep_root``.

    Returns:
        ``(T, J)`` bool, True where the joint is a placeholder.
    """
    present = np.isfinite(values).all(axis=2)
    lo = np.min(values, axis=1, initial=np.inf, where=present[..., None])
    hi = np.max(values, axis=1, initial=-np.inf, where=present[..., None])
    collapsed = (present.sum(axis=1) >= 2) & np.all(hi == lo, axis=1)
    at_origin = present & np.all(values == 0.0, axis=2)
    placeholder = (at_origin & (at_origin.sum(axis=1) >= 2)[:, None]) | (present & collapsed[:, None])
    if keep_root:
        placeholder |= at_origin  # even alone, but for the root, kept unless its frame collapsed
        if root is not None:
            placeholder[:, root] = present[:, root] & collapsed
    return placeholder


def validate_poses(joints: object, source: str = "poses", units: str | None = None,
                   num_joints: int = 17, joint_names: tuple[str, ...] | None = None,
                   in_place: bool = False, metres_only: bool = False) -> np.ndarray:
    """The one check every entry point applies to 3D poses (``pcnet rectify``,
    :func:`pcnet.pipeline.rectification.rectify`, ``pcnet run`` after its adapter).

    Args:
        joints: ``(T, J, 3)`` array (a single ``(J, 3)`` pose is promoted), real numbers
            (float or int dtype; bool, complex, strings and objects are refused).
        source: the file or argument named in errors.
        units: ``"m"``, ``"px"``, ``"normalised"`` or ``None`` (unknown) for the magnitude
            bound :data:`MAX_ABS_COORDINATE`.
        num_joints, joint_names: the layout's joint count and names (default H36M-17's), for
            the shape check and the message.
        in_place: write the result into ``joints`` when it is a writable float32 array (the
            caller's own: a long recording is not copied). Checked a block of frames at a
            time either way.
        metres_only: the caller reads metres alone (mocap for evaluation and training), so a
            millimetre file is told to scale to metres, not to read it with ``pcnet run``'s
            generic reader's ``--units``, which that command does not have.

    Returns:
        float32 ``(T, J, 3)``; non-finite values (``inf``), a masked array's masked values
        and placeholders (:func:`placeholder_joints`) become NaN: missing data.

    Raises:
        InputError: wrong dtype or shape, no frame, no finite value, a coordinate beyond
            the bound for ``units`` (naming the frame and joint), or joints with one coordinate
            the same in every frame that has three or more (a 2D projection saved as 3D).
    """
    if joints is None or isinstance(joints, (str, bytes, os.PathLike)):
        # an API trial passed a file's path (and None) and was told "got dtype object"
        got = "None" if joints is None else f"a path ({os.fsdecode(joints)!r})"
        raise InputError(f"{source}: expected an array of joint coordinates (T, {num_joints}, 3), got {got}; load it "
                         f"first (np.load for such an array; run_pipeline reads a lifter's own file)")
    arr = _unmasked(joints, source)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise InputError(f"{source}: expected real-valued (float) joint coordinates, got dtype {arr.dtype}")
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (num_joints, 3):
        raise InputError(f"{source}: expected shape (T, {num_joints}, 3) joints, got {tuple(np.shape(joints))}"
                         f"{shape_hint(np.shape(joints), num_joints)}")
    if arr.shape[0] == 0:
        raise InputError(f"{source}: expected at least one frame, got shape {arr.shape}")
    bound = MAX_ABS_COORDINATE[units]
    in_place = in_place and arr.dtype == np.float32 and arr.flags.writeable and arr.ndim == np.ndim(joints)
    out = arr if in_place else np.empty(arr.shape, np.float32)
    any_finite, seen_finite, first, count = False, False, None, 0
    # per axis: whether some frame's joints (three or more) spread along it; the first such frame's value
    spread_along, flat_value = np.zeros(3, bool), None
    # x, y beyond the bound beside a third channel never negative and within it: confidences, not
    # depths (millimetres have joints in front of a root-relative root, or depths of a metre and more)
    z_range = [np.inf, -np.inf]
    # The joint that root-relative poses put at the origin: the layout's pelvis where it is one
    # joint (H36M-17's, BODY-25's mid-hip), none where it is the hips' mean; unknown for names of
    # no layout.
    names = H36M_JOINTS if joint_names is None else tuple(joint_names)
    layout = next((lay for lay in LAYOUTS.values() if lay.joints == names), None)
    keep_root = layout is not None
    root = layout.to_h36m[PELVIS][0] if layout is not None and len(layout.to_h36m[PELVIS]) == 1 else None
    # A block of frames at a time: float64 copies of a long recording would be hundreds of MB.
    for rows in frame_blocks(len(arr)):
        # The bound is checked on the values as given: a float64 beyond float32's range would
        # otherwise become inf, then NaN, and pass as missing data.
        with np.errstate(invalid="ignore"):  # signalling NaNs in a file are missing data too
            values = arr[rows].astype(np.float64)
        finite = np.isfinite(values)
        seen_finite |= bool(finite.any())
        too_big = finite & (np.abs(np.where(finite, values, 0.0)) > bound)
        if too_big.any():
            if first is None:
                t, j, axis = np.argwhere(too_big)[0]
                first = (rows.start + int(t), int(j), float(values[t, j, axis]))
            count += int(too_big.any(axis=2).sum())
        values = np.where(finite, values, np.nan)
        values[placeholder_joints(values, keep_root, root)] = np.nan
        out[rows] = values
        three = np.isfinite(values).all(axis=2).sum(axis=1) >= 3
        if three.any():
            extent = np.nanmax(values[three], axis=1) - np.nanmin(values[three], axis=1)
            spread_along |= (extent > 0).any(axis=0)
            if flat_value is None:
                flat_value = (rows.start + int(np.flatnonzero(three)[0]), np.nanmin(values[three][0], axis=0))
        any_finite |= bool(np.isfinite(values).any())
        z = values[..., 2][np.isfinite(values[..., 2])]
        if z.size:
            z_range = [min(z_range[0], float(z.min())), max(z_range[1], float(z.max()))]
    if not seen_finite:
        raise InputError(f"{source}: expected some finite joint coordinates, got only NaN/inf")
    if not any_finite:
        raise InputError(f"{source}: expected joint positions, got only placeholders for missing joints (in every "
                         f"frame all joints at one point, e.g. all zeros, or several at (0, 0, 0))")
    if first is not None:
        t, j, value = first
        name = H36M_JOINTS[j] if joint_names is None else joint_names[j]
        confidences = 0.0 <= z_range[0] and z_range[1] <= bound
        unit_hint = ("; 2D keypoints (x, y pixels and a confidence) given as 3D poses?" if confidences and units == "m"
                     else "; millimetres or centimetres given as metres? scale the file to metres"
                     + ("" if metres_only else ", or read it with pcnet run --lifter generic --units mm (or cm)")
                     if units == "m" else "")
        raise InputError(f"{source}: frame {t}, joint {name}: expected |coordinate| <= {bound:g} "
                         f"{units or '(any unit)'}, got {value:.4g} ({count} joint value{'s' if count != 1 else ''} "
                         f"beyond it{unit_hint})")
    if flat_value is not None and not spread_along.all():
        axis = int(np.flatnonzero(~spread_along)[0])
        t, at = flat_value
        raise InputError(f"{source}: expected 3D joints, got every frame's joints at one {'xyz'[axis]} "
                         f"({'xyz'[axis]} = {at[axis]:.4g} in frame {t}): a 2D projection or 2D keypoints given as 3D "
                         f"poses?")
    return out


#: Thigh (hip -> knee) lengths, metres, that a person can have: a small child's 0.2 m to
#: 0.7 m (adult thighs are about 0.4-0.5 m, Winter's anthropometric table: 0.245 x height).
THIGH_RANGE_M = (0.2, 0.7)
#: Median thigh lengths (m) outside which poses said to be in metres are refused: a third of
#: the bottom and 3 times the top of :data:`THIGH_RANGE_M`, beyond any bone of a person even
#: under a wrong joint layout; centimetres given as metres read about 40 m, metres given as
#: centimetres about 0.004.
REFUSED_THIGH_M = (THIGH_RANGE_M[0] / 3, 3 * THIGH_RANGE_M[1])


def median_thigh_length(joints) -> float:
    """Median hip -> knee length over both legs and every frame of H36M-17 poses
    ``(T, 17, 3)`` (any units, NaN = missing; read as given, so an on-disk array is read
    whole); NaN when no thigh is finite. Compared with :data:`THIGH_RANGE_M` it tells metres
    from centimetres, millimetres or a lifter's normalised scale."""
    thighs = np.concatenate([np.linalg.norm(joints[:, knee] - joints[:, hip], axis=1)
                             for hip, knee in ((L_HIP, L_KNEE), (R_HIP, R_KNEE))])
    thighs = thighs[np.isfinite(thighs)]
    return float(np.median(thighs)) if thighs.size else float("nan")


#: Metres per unit of the length units poses may be in (the others, a lifter's ``normalised``
#: scale or ``px``, have no fixed length).
METRES_PER_LENGTH_UNIT = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: Pose units with no metric scale: a lifter's normalised output, and pixels.
UNSCALED_UNITS = ("normalised", "px")


def thigh_beyond_metres(joints, metres_per_unit: float = 1.0) -> float | None:
    """The median thigh (:func:`median_thigh_length`) of H36M-17 poses ``(T, 17, 3)``, in
    metres (the poses' units times ``metres_per_unit``), when it lies outside
    :data:`REFUSED_THIGH_M`, no person's (above: centimetres or millimetres read as metres;
    below: another unit or joint order), else ``None`` (also where no thigh is finite)."""
    thigh = median_thigh_length(joints) * metres_per_unit
    low, high = REFUSED_THIGH_M
    return thigh if thigh < low or thigh > high else None


def fill_pelvis_from_hips(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """H36M-17 pelvis rule: a missing (NaN) pelvis is the midpoint of the hips when both are
    present (H36M's pelvis is the hip-joint midpoint, VideoPose3D ``common/h36m_dataset.py``
    skeleton); otherwise it stays missing and the frame cannot be rectified.

    Args:
        joints: float ``(T, 17, 3)`` H36M-17, any frame and units.

    Returns:
        ``(joints copy with the pelvis filled, filled (T,) bool)``.
    """
    out = np.array(joints, copy=True)
    missing = np.isnan(out[:, PELVIS]).any(axis=1)
    hips_ok = np.isfinite(out[:, [L_HIP, R_HIP]]).all(axis=(1, 2))
    filled = missing & hips_ok
    out[filled, PELVIS] = 0.5 * (out[filled, L_HIP] + out[filled, R_HIP])
    return out, filled


def root_relative(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pelvis-centred poses, the input of every rectifier: :func:`fill_pelvis_from_hips`,
    then the pelvis subtracted from every joint.

    Args:
        joints: ``(T, 17, 3)`` H36M-17, any frame and units (NaN = missing).

    Returns:
        ``(float64 (T, 17, 3) root-relative joints, pelvis filled from the hips (T,) bool)``;
        frames still without a pelvis are all NaN.
    """
    out, filled = fill_pelvis_from_hips(np.asarray(joints, np.float64))
    return out - out[:, PELVIS : PELVIS + 1], filled
