"""Microsoft Kinect skeletons -> :class:`Poses3D` (H36M-17, OpenCV camera frame, metres).

Two sensors, both depth cameras with their own skeleton trackers (not RGB monocular, not mocap):

* **Kinect v1** (Kinect for Windows SDK 1.x, Xbox 360 Kinect): 20 joints, metres, "skeleton
  space": right-handed, origin at the depth sensor, **+x to the sensor's left, +y up (the
  sensor's up: it tilts with the sensor), +z along the optical axis** (Kinect for Windows SDK
  docs, ``NUI_SKELETON_DATA`` / "skeleton space"; the same axes as Kinect v2's
  ``CameraSpacePoint``). To OpenCV (x right, y down, z forward):
  ``(x, y, z)_cv = (-x, -y, z)_kinect``, a 180 deg rotation about z (a proper rotation, no
  mirror). Two joint orders are in use (:data:`KINECT_V1_LAYOUTS`): the SDK's
  ``NUI_SKELETON_POSITION_INDEX`` enum (hip_center, spine, shoulder_center, head, ...) and
  UTD-MHAD's ``d_skel`` order (head, shoulder_center, spine, hip_center, ...); joints 4-19
  are the same in both.
* **Azure Kinect** (Body Tracking SDK 1.x, ``k4abt_joint_id_t``): 32 joints, **millimetres**,
  the depth camera's 3D frame: origin at its focal point, **+x right, +y down, +z forward**
  (Azure Kinect DK docs "Coordinate systems" and "Body tracking joints"), i.e. already OpenCV
  axes: only mm -> m. Note that the depth camera is tilted 6 deg down relative to the colour
  camera (same docs), so "level" refers to the depth camera, not the device case.

Mapping to H36M-17 (``docs/CONVENTIONS.md``; H36M names from
``pcnet.stages.core.conventions.H36M_JOINTS``), one rule per H36M joint:

=============  ==========================================  ================================
H36M joint     Kinect v1                                   Azure Kinect
=============  ==========================================  ================================
pelvis         mean(left_hip, right_hip)                   mean(HIP_LEFT, HIP_RIGHT)
hips, knees,   the same-named joints                       the same-named joints
ankles
spine          mean(pelvis, thorax)                        mean(pelvis, thorax)
thorax         shoulder_center                             mean(SHOULDER_LEFT, SHOULDER_RIGHT)
neck_nose      NaN (Kinect v1 has no nose)                 NOSE
head           head                                        HEAD
shoulders,     the same-named joints (wrist, not hand)     the same-named joints
elbows, wrists
=============  ==========================================  ================================

Why these choices:

* pelvis: Human3.6M's pelvis is the hip-joint midpoint (the rule of
  :func:`pcnet.stages.core.conventions.fill_pelvis_from_hips`). Kinect v1's hip_center sits about
  7 cm above the hip joints and Azure's PELVIS is its own estimate; both are dropped so the
  root means what it means everywhere in pcnet.
* spine: Kinect v1's "spine" sits just above hip_center (8 cm; UTD-MHAD data README), not
  mid-trunk where H36M's spine is; the midpoint of pelvis and thorax is the project's
  COCO-17 / BlazePose-33 rule (mean of shoulders and hips) and what the CMU/H36M-17 mocap
  conversions give (spine at 0.50 of pelvis->thorax). Azure's SPINE_NAVEL is not used for
  the same consistency.
* thorax: Kinect v1's shoulder_center is the neck base between the shoulders, the direct
  analogue of H36M's thorax (it sits about 11 cm above the shoulder line, H36M's thorax about
  5 cm). Azure has no such joint (its NECK is higher, SPINE_CHEST lower): the mean of the
  shoulders, the COCO-17 rule.
* neck_nose: H36M joint 9 is filled with the nose by every common converter; Kinect v1 has
  none, so it is NaN (never 0; pcnet never uses it as a spine point). Azure has NOSE.
* head: both sensors' HEAD is the centre of the head, lower than H36M's head joint (about
  0.19 m above Kinect v1's shoulder_center vs 0.25 m from H36M's thorax), comparable to the
  mid-eyes point the COCO-17 recipe uses.
* hands, feet, hand tips, thumbs, clavicles, eyes, ears: not in H36M-17, dropped.
* Kinect v1 hips are narrower than Human3.6M's (0.145 m apart in UTD-MHAD vs about 0.18-0.26 m):
  the hips are kept as tracked, nothing is rescaled.

Missing joints: a joint whose z (depth) is not > 0 cannot lie in front of a depth sensor;
trackers write (0, 0, 0) for untracked joints, so such joints become NaN, as do non-finite
values. The root is **not** centred (positions relative to the sensor, as the file has them):
the caller subtracts the pelvis, as for every :class:`Poses3D`.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import H36M_JOINTS

from .registry import register_3d
from .types import AdapterError, Poses3D
from .validate import (
    checked_poses,
    load_array_file,
    nonfinite_frames,
    require_file,
    require_numeric,
    require_some_finite,
)

#: Kinect v1 joints in the Kinect for Windows SDK's ``NUI_SKELETON_POSITION_INDEX`` order.
KINECT_V1_JOINTS_SDK: tuple[str, ...] = (
    "hip_center", "spine", "shoulder_center", "head", "left_shoulder", "left_elbow", "left_wrist",
    "left_hand", "right_shoulder", "right_elbow", "right_wrist", "right_hand", "left_hip", "left_knee",
    "left_ankle", "left_foot", "right_hip", "right_knee", "right_ankle", "right_foot",
)
#: Kinect v1 joints in UTD-MHAD's ``d_skel`` order (the first four reversed w.r.t. the SDK).
KINECT_V1_JOINTS_UTD: tuple[str, ...] = ("head", "shoulder_center", "spine", "hip_center") + KINECT_V1_JOINTS_SDK[4:]
#: ``layout=`` option of :func:`load_kinect_v1` -> joint order.
KINECT_V1_LAYOUTS: dict[str, tuple[str, ...]] = {"utd": KINECT_V1_JOINTS_UTD, "sdk": KINECT_V1_JOINTS_SDK}

#: Azure Kinect Body Tracking SDK ``k4abt_joint_id_t`` order (32 joints).
AZURE_KINECT_JOINTS: tuple[str, ...] = (
    "pelvis", "spine_navel", "spine_chest", "neck", "clavicle_left", "shoulder_left", "elbow_left",
    "wrist_left", "hand_left", "handtip_left", "thumb_left", "clavicle_right", "shoulder_right",
    "elbow_right", "wrist_right", "hand_right", "handtip_right", "thumb_right", "hip_left", "knee_left",
    "ankle_left", "foot_left", "hip_right", "knee_right", "ankle_right", "foot_right", "head", "nose",
    "eye_left", "ear_left", "eye_right", "ear_right",
)

# H36M-17 joint -> source joint names averaged; () = missing (NaN); "thorax"/"pelvis" refer
# to the H36M joints already built (spine = mean(pelvis, thorax)).
_V1_RULES: tuple[tuple[str, ...], ...] = (
    ("left_hip", "right_hip"), ("right_hip",), ("right_knee",), ("right_ankle",), ("left_hip",),
    ("left_knee",), ("left_ankle",), ("@pelvis", "@thorax"), ("shoulder_center",), (), ("head",),
    ("left_shoulder",), ("left_elbow",), ("left_wrist",), ("right_shoulder",), ("right_elbow",),
    ("right_wrist",),
)
_AZURE_RULES: tuple[tuple[str, ...], ...] = (
    ("hip_left", "hip_right"), ("hip_right",), ("knee_right",), ("ankle_right",), ("hip_left",),
    ("knee_left",), ("ankle_left",), ("@pelvis", "@thorax"), ("shoulder_left", "shoulder_right"), ("nose",),
    ("head",), ("shoulder_left",), ("elbow_left",), ("wrist_left",), ("shoulder_right",), ("elbow_right",),
    ("wrist_right",),
)

# Kinect v1 skeleton space -> OpenCV camera frame, for row vectors: X_cv = X_kinect * (-1, -1, 1).
_V1_TO_CV = np.array([-1.0, -1.0, 1.0], np.float32)


def _to_h36m(joints_cv: np.ndarray, names: tuple[str, ...], rules) -> np.ndarray:
    """Apply ``rules`` to ``(T, J, 3)`` camera-frame joints named ``names``; NaN propagates."""
    index = {n: i for i, n in enumerate(names)}
    out = np.full((joints_cv.shape[0], 17, 3), np.nan, np.float32)
    order = [8, 0] + [k for k in range(17) if k not in (0, 8)]  # thorax, pelvis first: spine uses them
    for k in order:
        src = rules[k]
        if not src:
            continue
        parts = [out[:, H36M_JOINTS.index(s[1:])] if s.startswith("@") else joints_cv[:, index[s]] for s in src]
        out[:, k] = np.mean(parts, axis=0)
    return out


def _missing_depth_to_nan(arr: np.ndarray, source: str | Path, field: str) -> np.ndarray:
    """NaN for joints not in front of the sensor (z <= 0, e.g. the (0, 0, 0) of untracked
    joints); an :class:`AdapterError` when that leaves none of the finite joints (a bad-input
    trial's all-zero file was called "only NaN/inf")."""
    out = np.array(arr, np.float32, copy=True)
    with np.errstate(invalid="ignore"):
        behind = ~(out[..., 2] > 0)
    if behind.all() and np.isfinite(out).all(axis=-1).any():
        raise AdapterError(source, field, "some joints in front of the sensor (z > 0)",
                           "every finite joint at z <= 0 (an untracked joint is written as (0, 0, 0))")
    out[behind] = np.nan
    return out


def _check_joint_array(source: str | Path, field: str, arr: object, num_joints: int, what: str) -> np.ndarray:
    a = require_numeric(source, field, arr)
    if a.ndim != 3 or a.shape[1:] != (num_joints, 3):
        raise AdapterError(source, field, f"shape (T, {num_joints}, 3) {what} joints", f"shape {a.shape}")
    require_some_finite(source, field, a)
    return a


def kinect_v1_to_h36m(skeleton: np.ndarray, layout: str = "utd", source: str | Path = "<array>",
                      field: str = "skeleton") -> np.ndarray:
    """Kinect v1 skeleton-space joints -> H36M-17 in the OpenCV camera frame.

    Args:
        skeleton: ``(T, 20, 3)`` real numbers, metres, Kinect v1 skeleton space (+x the
            sensor's left, +y up, +z away from the sensor), joint order ``layout``.
        layout: ``"utd"`` (UTD-MHAD ``d_skel``: head, shoulder_center, spine, hip_center, ...)
            or ``"sdk"`` (``NUI_SKELETON_POSITION_INDEX``: hip_center, spine,
            shoulder_center, head, ...); see :data:`KINECT_V1_LAYOUTS`.
        source, field: named in errors (the file and key the array came from).

    Returns:
        float32 ``(T, 17, 3)`` H36M-17, metres, OpenCV camera frame (x right, y down,
        z forward; ``(-x, -y, z)`` of skeleton space), positions relative to the sensor (not
        root-centred). neck_nose is NaN in every frame; joints with z <= 0 (untracked,
        written as 0) and non-finite values are NaN. Mapping rules: module docstring.

    Raises:
        AdapterError: unknown ``layout`` (field ``layout``); ``field`` when ``skeleton`` is
            not ``(T, 20, 3)`` real numbers, holds no finite value, or reads as the other
            joint order (hip_center farther from the hips than head, medians over frames).
    """
    if layout not in KINECT_V1_LAYOUTS:
        raise AdapterError(source, "layout", f"one of {sorted(KINECT_V1_LAYOUTS)}", repr(layout))
    a = _check_joint_array(source, field, skeleton, 20, "Kinect v1")
    cv = _missing_depth_to_nan(a * _V1_TO_CV, source, field)
    _check_v1_order(cv, layout, source, field)
    return _to_h36m(cv, KINECT_V1_LAYOUTS[layout], _V1_RULES)


def _check_v1_order(joints: np.ndarray, layout: str, source: str | Path, field: str) -> None:
    """Refuse joints that read as the other Kinect v1 order: the two orders differ by
    exchanging hip_center with head and spine with shoulder_center, and whatever the posture,
    hip_center lies beside the hips (about 7 cm above their midpoint) and the head far from
    them (UTD-MHAD data: at most 0.08 m against at least 0.60 m, medians over each of its 671
    sequences). Compared by their medians over frames; no constant."""
    names = KINECT_V1_LAYOUTS[layout]
    at = {name: joints[:, names.index(name)] for name in ("hip_center", "head", "left_hip", "right_hip")}
    hips = 0.5 * (at["left_hip"] + at["right_hip"])
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a joint never tracked: all-NaN median
        centre, head = (float(np.nanmedian(np.linalg.norm(at[n] - hips, axis=-1))) for n in ("hip_center", "head"))
    if centre > head:  # False where either is NaN: nothing to compare
        other = next(name for name in KINECT_V1_LAYOUTS if name != layout)
        raise AdapterError(source, field, f"Kinect v1 joints in the {layout!r} order (hip_center, joint "
                                          f"{names.index('hip_center')}, beside the hips; head, joint "
                                          f"{names.index('head')}, far from them)",
                           f"joint {names.index('hip_center')} {centre:.2f} m from the hips' midpoint and joint "
                           f"{names.index('head')} {head:.2f} m: the {other!r} order (--layout {other})")


def azure_kinect_to_h36m(joints_mm: np.ndarray, source: str | Path = "<array>", field: str = "joints") -> np.ndarray:
    """Azure Kinect Body Tracking joints -> H36M-17 in the OpenCV camera frame, metres.

    Args:
        joints_mm: ``(T, 32, 3)`` real numbers, **millimetres**, the depth camera's 3D frame
            (+x right, +y down, +z forward), ``k4abt_joint_id_t`` order
            (:data:`AZURE_KINECT_JOINTS`).
        source, field: named in errors.

    Returns:
        float32 ``(T, 17, 3)`` H36M-17, metres, OpenCV camera frame (no axis changed),
        relative to the depth camera (not root-centred); joints with z <= 0 and non-finite
        values NaN. Mapping rules: module docstring.

    Raises:
        AdapterError: ``field`` when the array is not ``(T, 32, 3)`` real numbers or holds no
            finite value.
    """
    a = _check_joint_array(source, field, joints_mm, 32, "Azure Kinect")
    cv = _missing_depth_to_nan(a * np.float32(1e-3), source, field)
    return _to_h36m(cv, AZURE_KINECT_JOINTS, _AZURE_RULES)


def _read_mat_skeleton(p: Path) -> np.ndarray:
    """UTD-MHAD ``*_skeleton.mat``: ``d_skel`` ``(20, 3, T)`` -> ``(T, 20, 3)``."""
    try:
        from scipy.io import loadmat

        mat = loadmat(p)
    except Exception as exc:  # scipy raises several types for damaged files
        raise AdapterError(p, "content", "a readable MATLAB .mat file", f"{type(exc).__name__}: {exc}") from exc
    if "d_skel" not in mat:
        names = sorted(k for k in mat if not k.startswith("__"))
        raise AdapterError(p, "d_skel", "a variable 'd_skel' (20, 3, T) (UTD-MHAD skeleton .mat)", f"variables {names}")
    d = np.asarray(mat["d_skel"])
    if d.ndim != 3 or d.shape[:2] != (20, 3):
        raise AdapterError(p, "d_skel", "shape (20, 3, T)", f"shape {d.shape}")
    return np.transpose(d, (2, 0, 1))


def _read_array(p: Path, key: str | None, default_key: str) -> tuple[np.ndarray, str]:
    with p.open("rb") as fh:
        head = fh.read(6)
    if head == b"MATLAB":
        return _read_mat_skeleton(p), "d_skel"
    if key is None:
        # an .npz holding `default_key` (e.g. the UTD-MHAD evaluation files) needs no key=
        try:
            return load_array_file(p, default_key), default_key
        except AdapterError as exc:
            if exc.field != "key":
                raise
        return load_array_file(p, None), "content"
    return load_array_file(p, key), key


def _name_key(name: str) -> str:
    """A joint name without case or separators: ``HipCenter``, ``hip_center``, ``hip-center``."""
    return "".join(c for c in name.lower() if c.isalnum())


def _declared_v1_layout(p: Path, layout: str | None) -> str:
    """The joint order an archive's ``joint_names`` declares, checked against ``layout``
    (``None``: the declared one, else ``"utd"``)."""
    try:
        names = np.asarray(load_array_file(p, "joint_names"))
    except AdapterError:
        return layout or "utd"
    text = [n.decode("utf-8", "replace") if isinstance(n, bytes) else str(n) for n in names.ravel().tolist()] \
        if names.dtype.kind in "US" else None
    declared = None if text is None else next(
        (name for name, order in KINECT_V1_LAYOUTS.items() if tuple(map(_name_key, order)) == tuple(map(_name_key, text))),
        None)
    if declared is None:
        if layout is not None:  # names in another spelling: the order the user states
            return layout
        got = f"{text[:5]} ..." if text else "a non-text array"
        raise AdapterError(p, "joint_names", f"one of the Kinect v1 joint orders {sorted(KINECT_V1_LAYOUTS)} "
                                             f"(UTD-MHAD: {list(KINECT_V1_JOINTS_UTD[:4])} ...), or layout= to state "
                                             f"it", got)
    if layout is not None and layout != declared:
        raise AdapterError(p, "joint_names", f"the {layout!r} joint order that layout= asks for",
                           f"the {declared!r} order ({text[:4]} ...)")
    return declared


def load_kinect_v1(path: str | Path, layout: str | None = None, key: str | None = None,
                   fps: float | None = None) -> Poses3D:
    """Read Kinect v1 skeletons (20 joints) into ``Poses3D`` (H36M-17, camera frame, metres).

    Files: ``.npy`` ``(T, 20, 3)``; ``.npz`` (array ``key``, default ``skeleton`` when present,
    else its single array; ``skeleton_fps`` in the archive sets ``fps``); UTD-MHAD
    ``*_skeleton.mat`` (``d_skel`` ``(20, 3, T)``). Values in metres, Kinect v1 skeleton space.

    Args:
        path: the file.
        layout: joint order, ``"utd"`` (UTD-MHAD) or ``"sdk"`` (Kinect SDK enum), see
            :func:`kinect_v1_to_h36m`; ``None``: the order the archive's ``joint_names``
            declares, else ``"utd"``.
        key: array name inside an ``.npz``.
        fps: frame rate, overriding the file's ``skeleton_fps``; ``None`` and no
            ``skeleton_fps`` leaves it unknown (Kinect v1 nominally runs at 30 fps but
            recorders drop frames: UTD-MHAD's effective rate is about 19 fps).

    Returns:
        ``Poses3D``: float32 ``(T, 17, 3)`` ``h36m17``, metres, OpenCV camera frame
        (``(-x, -y, z)`` of skeleton space), not root-centred, neck_nose NaN.

    Raises:
        AdapterError: missing/unreadable/non-numpy file, missing ``key``, wrong shape or joint
            count (naming file, field, expected and found), unknown ``layout``, a
            ``joint_names`` that is no Kinect v1 order or contradicts ``layout``, joints that
            read as the other order (:func:`kinect_v1_to_h36m`), a coordinate beyond 100 m, or
            no finite value.

    Source of the format facts: Kinect for Windows SDK 1.8 ``NUI_SKELETON_DATA`` /
    ``NUI_SKELETON_POSITION_INDEX`` (metres, skeleton space); UTD-MHAD (Chen, Jafari,
    Kehtarnavaz, ICIP 2015) ``d_skel`` joint order.
    """
    p = require_file(path, "a Kinect v1 skeleton file (.npy, .npz or UTD-MHAD .mat)")
    arr, field = _read_array(p, key, "skeleton")
    if layout is not None and layout not in KINECT_V1_LAYOUTS:
        raise AdapterError(p, "layout", f"one of {sorted(KINECT_V1_LAYOUTS)}", repr(layout))
    layout = _declared_v1_layout(p, layout) if field != "d_skel" and p.suffix.lower() == ".npz" else layout or "utd"
    joints = checked_poses(p, field, kinect_v1_to_h36m(arr, layout, p, field), "h36m17", "m")
    nonfinite = nonfinite_frames(arr, KINECT_V1_LAYOUTS[layout])  # the file's inf/NaN, not z <= 0
    if fps is None and field == "skeleton":
        fps = _archive_scalar(p, "skeleton_fps")
    notes = (f"Kinect v1 skeleton ({layout} joint order) -> H36M-17: (x, y, z)_cv = (-x, -y, z)_kinect, metres; "
             "pelvis = hip midpoint, spine = mean(pelvis, thorax), thorax = shoulder_center, head = head centre, "
             "neck_nose NaN (no nose); not root-centred; gravity only approximately -y (sensor tilt unknown)")
    return Poses3D(joints, "h36m17", units="m", source=str(p), notes=notes, summary_note=KINECT_V1_REST_NOTE,
                   fps=fps, root_translation=True, depth_sensor=True, nonfinite=nonfinite)


#: What its skeleton reads at rest, measured (a wrist-IMU trial read every subject standing
#: still as leaning back with hips and knees overextended, and took it for the subjects').
#: Kinect v1's nominal skeleton rate (Kinect for Windows SDK 1.x): what its recorders do not reach.
KINECT_V1_NOMINAL_FPS = 30.0
KINECT_V1_REST_NOTE = ("compare Kinect v1 angles with the subject's own rest, not with norms: its skeleton reads "
                       "people standing at rest with hips 14 deg extended, knees 5 deg hyperextended and the trunk "
                       "9 deg back (medians of 168 UTD-MHAD recordings, docs/guide/limits.md)")


def _archive_scalar(p: Path, name: str) -> float | None:
    try:
        v = np.asarray(load_array_file(p, name))
    except AdapterError:
        return None
    if v.shape != () or v.dtype.kind not in "iuf" or not np.isfinite(v) or float(v) <= 0:
        raise AdapterError(p, name, "a positive finite scalar frame rate", f"{v!r}"[:80])
    return float(v)


def load_azure_kinect(path: str | Path, key: str | None = None, fps: float | None = None) -> Poses3D:
    """Read Azure Kinect Body Tracking joints (32) into ``Poses3D`` (H36M-17, camera frame, metres).

    Files: ``.npy`` ``(T, 32, 3)`` or ``.npz`` (array ``key``, default ``joints`` when present,
    else its single array) of ``k4abt_skeleton_t`` joint positions of one body in
    ``k4abt_joint_id_t`` order, **millimetres**, depth-camera frame (x right, y down,
    z forward). The Body Tracking SDK's own JSON (``offline_processor``) is not read: export
    one body's positions to an array first.

    Returns:
        ``Poses3D``: float32 ``(T, 17, 3)`` ``h36m17``, metres, OpenCV camera frame, not
        root-centred; mapping rules in the module docstring.

    Raises:
        AdapterError: missing/unreadable/non-numpy file, missing ``key``, not
            ``(T, 32, 3)`` (naming file, field, expected and found), a coordinate beyond
            100 m, or no finite value.

    Source of the format facts: Azure Kinect DK documentation "Azure Kinect body tracking
    joints" (32 joints, millimetres, depth camera frame) and "Azure Kinect DK coordinate
    systems" (x right, y down, z forward); Body Tracking SDK 1.x ``k4abttypes.h``.
    """
    p = require_file(path, "an Azure Kinect joints file (.npy or .npz)")
    arr, field = _read_array(p, key, "joints")
    joints = checked_poses(p, field, azure_kinect_to_h36m(arr, p, field), "h36m17", "m")
    nonfinite = nonfinite_frames(arr, AZURE_KINECT_JOINTS)  # the file's inf/NaN, not z <= 0
    notes = ("Azure Kinect Body Tracking (32 joints, k4abt order) -> H36M-17: mm -> m, depth-camera axes are "
             "already x right / y down / z forward; pelvis = hip midpoint, spine = mean(pelvis, thorax), "
             "thorax = shoulder midpoint, neck_nose = NOSE, head = HEAD; not root-centred")
    return Poses3D(joints, "h36m17", units="m", source=str(p), notes=notes, fps=fps, root_translation=True,
                   depth_sensor=True, nonfinite=nonfinite)


@register_3d("kinect_v1", absent_joints=("neck_nose",))
class KinectV1Adapter:
    """Registry entry for :func:`load_kinect_v1` (options ``layout``, ``key``, ``fps``)."""

    def load(self, path: str | Path, *, layout: str | None = None, key: str | None = None,
             fps: float | None = None) -> Poses3D:
        return load_kinect_v1(path, layout=layout, key=key, fps=fps)


@register_3d("azure_kinect")
class AzureKinectAdapter:
    """Registry entry for :func:`load_azure_kinect` (options ``key``, ``fps``)."""

    def load(self, path: str | Path, *, key: str | None = None, fps: float | None = None) -> Poses3D:
        return load_azure_kinect(path, key=key, fps=fps)
