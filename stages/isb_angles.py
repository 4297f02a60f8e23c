"""ISB-convention joint angles from H36M-17 joint centres.

Joint angles between two segment frames, with the rotation sequences and sign conventions of
the International Society of Biomechanics (ISB):

* hip, pelvis, trunk: Wu G. et al. (2002) "ISB recommendation on definitions of joint
  coordinate system of various joints for the reporting of human joint motion - part I:
  ankle, hip, and spine", J Biomech 35:543-548;
* shoulder (thoraco-humeral), elbow, thorax: Wu G. et al. (2005) "... part II: shoulder,
  elbow, wrist and hand", J Biomech 38:981-992;
* the joint coordinate system (JCS) and the knee: Grood E.S., Suntay W.J. (1983) "A joint
  coordinate system for the clinical description of three-dimensional motions: application
  to the knee", J Biomech Eng 105:136-144.

A JCS with ``e1`` = the proximal segment's Z axis, ``e3`` = the distal segment's Y axis and
the floating axis ``e2 = e3 x e1`` gives the same three angles as the intrinsic Z-X'-Y''
Cardan decomposition of the distal frame relative to the proximal one (Grood & Suntay 1983;
Wu et al. 2002, section 2), which is how they are computed here, with
:class:`scipy.spatial.transform.Rotation`.

Segment frames (all right-handed, ISB axis roles: X anterior, Y proximal/superior, Z to the
subject's right) are built from joint centres only, because H36M-17 has no anatomical
landmarks (no ASIS/PSIS, epicondyles, malleoli, C7/IJ/PX/T8, styloids). The definitions
and what they cannot capture are in ``docs/joint_angles.md``:

* **pelvis**: Z = left_hip -> right_hip; Y = pelvis -> spine made perpendicular to Z
  (stands in for the ISB Y, which is normal to the ASIS/PSIS plane); X = Y x Z.
* **thorax**: Y = spine -> thorax (stands in for mid(PX, T8) -> mid(IJ, C7));
  Z = left_shoulder -> right_shoulder made perpendicular to Y (stands in for the normal of
  the IJ-C7-mid(PX,T8) plane); X = Y x Z.
* **thigh**: Y = knee -> hip; Z = the normal of the hip-knee-ankle plane (the knee's flexion
  axis; stands in for the epicondyle line), signed by the knee-sign rule: flexion unless
  that would turn the hip beyond :data:`HYPEREXTENSION_HIP_ROTATION_DEG` about the thigh,
  so hip internal rotation can read beyond +-90 deg where the pelvis or thigh is off;
  X = Y x Z.
* **shank**: Y = ankle -> knee; Z = the thigh's Z (a hinge knee); X = Y x Z.
* **upper arm**: Y = elbow -> shoulder; Z = the normal of the shoulder-elbow-wrist plane,
  ``Y_humerus x Y_forearm`` (Wu et al. 2005's second humerus frame, which uses the forearm
  because epicondyles were missing); X = Y x Z.
* **forearm**: Y = wrist -> elbow; Z = the upper arm's Z; X = Y x Z.

Left-side angles are computed on the mirror image of the pose (reflected through a vertical
plane and relabelled left <-> right), so the same anatomical motion has the same sign on both
sides (the usual mirrored-frame practice; the same as negating the second and third Cardan
angles of the left side in right-handed frames).

Input: ``(T, 17, 3)`` H36M-17 joint centres in any frame whose +Y is up (the world frame or
the canonical frame of ``docs/CONVENTIONS.md``), any length unit. Only the two
``trunk_*_to_gravity`` angles use the direction of +Y; every other angle is between two body
segments and is unchanged by any rotation of the whole pose.

NaN policy: an angle is NaN when a joint it needs is NaN, when a frame it needs is degenerate
(:data:`MIN_AXIS_ANGLE_DEG`), when the limb plane that sets an axial rotation is undefined
(:data:`MIN_BEND_DEG`), or near a gimbal lock of its sequence (:data:`GIMBAL_MARGIN_DEG`).
Nothing raises for NaN input.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from types import MappingProxyType

import numpy as np
from scipy.spatial.transform import Rotation

from .core.conventions import (
    L_HIP,
    L_SHOULDER,
    PELVIS,
    R_ANKLE,
    R_ELBOW,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_WRIST,
    SPINE,
    THORAX,
)
from .core.errors import InputError
from .core.rotations import normalize

#: Two directions that define a pelvis, thorax or heading frame (pelvis->spine vs the hip
#: line; spine->thorax vs the shoulder line; thorax Z vs vertical) must be at least this far
#: from parallel (degrees), else the frame and every angle using it is NaN.
MIN_AXIS_ANGLE_DEG = 10.0

#: A knee or elbow bent less than this (degrees, 0 = straight) leaves the hip-knee-ankle or
#: shoulder-elbow-wrist plane undefined, and with it the thigh's or upper arm's axial
#: rotation: ``*_hip_internal_rotation_deg`` / ``*_shoulder_axial_rotation_deg`` are NaN
#: there. Knee and elbow flexion themselves stay defined. The plane's direction error is
#: about ``noise / (segment length * sin(bend))`` rad: 1 cm of noise on a 0.4 m shank is
#: ~16 deg at a 5 deg bend.
MIN_BEND_DEG = 5.0

#: A knee is read as hyperextended only where reading it as flexed would need the hip
#: turned more than this about the thigh (degrees; internal rotation beyond +-this). Hip
#: rotation stays within about +-45 deg in life (Roaas & Andersson 1982, Acta Orthop Scand
#: 53: 205-208); between 90 -+ 20 deg the sign of the knee follows the noise of a lifter's
#: hip line (a seated cyclist's knee flexion flipped from +45 to -47 deg), and flexion is
#: taken.
HYPEREXTENSION_HIP_ROTATION_DEG = 110.0

#: The most a knee hyperextends (degrees): genu recurvatum beyond 5 deg is already a
#: clinical finding and rarely reaches 20 (Loudon et al. 1998, J Orthop Sports Phys Ther 27:
#: 361-367); a bend beyond this is read as flexion whatever the hip reading (a lifter's
#: hip line had made a cyclist's knee read as hyperextended by 101 deg).
MAX_KNEE_HYPEREXTENSION_DEG = 25.0

#: Gimbal lock: within this many degrees of the singular middle angle (Z-X-Y: +-90 deg;
#: Y-X-Y: 0 or 180 deg elevation) the first and third angles of the sequence are not
#: separately defined and are NaN; the middle angle stays.
GIMBAL_MARGIN_DEG = 10.0

#: Column names, in the order :func:`isb_joint_angles` returns them.
NAMES: tuple[str, ...] = (
    "trunk_flexion_to_pelvis_deg",
    "trunk_lateral_bending_to_pelvis_deg",
    "trunk_axial_rotation_to_pelvis_deg",
    "trunk_flexion_to_gravity_deg",
    "trunk_lateral_tilt_to_gravity_deg",
    "left_hip_flexion_deg",
    "left_hip_adduction_deg",
    "left_hip_internal_rotation_deg",
    "right_hip_flexion_deg",
    "right_hip_adduction_deg",
    "right_hip_internal_rotation_deg",
    "left_knee_flexion_deg",
    "right_knee_flexion_deg",
    "left_shoulder_plane_of_elevation_deg",
    "left_shoulder_elevation_deg",
    "left_shoulder_axial_rotation_deg",
    "right_shoulder_plane_of_elevation_deg",
    "right_shoulder_elevation_deg",
    "right_shoulder_axial_rotation_deg",
    "left_elbow_flexion_deg",
    "right_elbow_flexion_deg",
)

_SIDE_SIGN = {
    "hip_flexion_deg": "thigh flexed (knee moved anterior) relative to the pelvis; negative = extension",
    "hip_adduction_deg": "thigh adducted (knee moved towards the midline) relative to the pelvis; negative = abduction",
    "hip_internal_rotation_deg": "thigh rotated internally (its anterior face turned towards the midline) relative to the pelvis; negative = external rotation",
    "knee_flexion_deg": "knee flexed (shank rotated posteriorly relative to the thigh); 0 = straight; negative = hyperextension",
    "shoulder_plane_of_elevation_deg": "plane in which the arm is elevated, measured from the thorax's frontal plane towards anterior: 0 = abduction plane (arm to the side), 90 = forward flexion plane, negative = behind the frontal plane",
    "shoulder_elevation_deg": "arm elevated away from the thorax's long axis: 0 = hanging along the trunk, 90 = horizontal, 180 = overhead (always >= 0)",
    "shoulder_axial_rotation_deg": "humerus rotated internally about its long axis (forearm turned towards the trunk); 0 = forearm in the plane of elevation pointing anterior; negative = external rotation",
    "elbow_flexion_deg": "elbow flexed; 0 = straight; never negative (hyperextension cannot be told from flexion)",
}

#: Positive-sign meaning of every column (for the data dictionary).
POSITIVE_SIGN: Mapping[str, str] = MappingProxyType({
    "trunk_flexion_to_pelvis_deg": "thorax flexed forward relative to the pelvis; negative = extension",
    "trunk_lateral_bending_to_pelvis_deg": "thorax bent towards the subject's right relative to the pelvis",
    "trunk_axial_rotation_to_pelvis_deg": "thorax turned towards the subject's left relative to the pelvis (right shoulder forward; counter-clockwise seen from above)",
    "trunk_flexion_to_gravity_deg": "thorax long axis leaning forward from vertical (in the thorax's own heading)",
    "trunk_lateral_tilt_to_gravity_deg": "thorax long axis leaning towards the subject's right from vertical",
    **{f"{side}_{key}": text for side in ("left", "right") for key, text in _SIDE_SIGN.items()},
})

#: Frames and rotation sequence of every column (for the data dictionary).
DEFINITIONS: Mapping[str, str] = MappingProxyType({
    "trunk_flexion_to_pelvis_deg": "thorax relative to pelvis, intrinsic Z-X'-Y'' (JCS: pelvis Z, floating, thorax Y), "
                                   "minus the first angle; empty where the spine joint lies on the pelvis-thorax line "
                                   "(built there, as Kinect's and MediaPipe's conversions do: 0 by construction)",
    "trunk_lateral_bending_to_pelvis_deg": "thorax relative to pelvis, intrinsic Z-X'-Y'', second angle",
    "trunk_axial_rotation_to_pelvis_deg": "thorax relative to pelvis, intrinsic Z-X'-Y'', third angle",
    "trunk_flexion_to_gravity_deg": "thorax relative to the heading frame (+Y up, Z = horizontal part of the thorax Z), intrinsic Z-X'-Y'', minus the first angle",
    "trunk_lateral_tilt_to_gravity_deg": "thorax relative to the heading frame, intrinsic Z-X'-Y'', second angle",
    **{f"{side}_{key}": text for side in ("left", "right") for key, text in {
        "hip_flexion_deg": "thigh relative to pelvis, intrinsic Z-X'-Y'' (JCS: pelvis Z, floating, thigh Y), first angle",
        "hip_adduction_deg": "thigh relative to pelvis, intrinsic Z-X'-Y'', second angle",
        "hip_internal_rotation_deg": ("thigh relative to pelvis, intrinsic Z-X'-Y'', third angle; empty where the knee "
                                      f"bends less than {MIN_BEND_DEG:g} deg (the thigh-shank plane is undefined); from "
                                      "a monocular lifter it errs more than it varies (docs/joint_angles.md)"),
        "knee_flexion_deg": "shank relative to thigh about the thigh Z (Grood & Suntay flexion axis), minus the first Z-X'-Y'' angle",
        "shoulder_plane_of_elevation_deg": "upper arm relative to thorax, intrinsic Y-X'-Y'' (Wu 2005), first angle (elevation taken positive)",
        "shoulder_elevation_deg": "upper arm relative to thorax, intrinsic Y-X'-Y'', second angle, sign flipped to be >= 0",
        "shoulder_axial_rotation_deg": ("upper arm relative to thorax, intrinsic Y-X'-Y'', third angle (elevation taken "
                                        f"positive); empty where the elbow bends less than {MIN_BEND_DEG:g} deg or the "
                                        f"elevation is within {GIMBAL_MARGIN_DEG:g} deg of 0 or 180 (docs/joint_angles.md)"),
        "elbow_flexion_deg": ("forearm relative to upper arm about the upper arm Z, first Z-X'-Y'' angle (Wu 2005); "
                              "the Z being the shoulder-elbow-wrist plane's normal, the same values as "
                              f"{side}_elbow_flexion_unsigned"),
    }.items()},
})

# Mirror image: reflect through the vertical X-Y plane (keeps +Y up) and swap left/right.
_MIRROR = np.array([1.0, 1.0, -1.0])
_SWAP_LR = np.array([0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13])
_UP = np.array([0.0, 1.0, 0.0])
#: Length (input units) at or below which a direction is undefined: NaN (``normalize``'s ``eps``).
_TINY = 1e-12


def _check(joints: object) -> np.ndarray:
    arr = np.asarray(joints)
    if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise InputError(f"joints: expected real-valued (float) H36M-17 joint coordinates, got dtype {arr.dtype}")
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (17, 3):
        raise InputError(f"joints: expected shape (T, 17, 3) H36M-17 joint centres, got {tuple(np.shape(joints))}")
    with np.errstate(invalid="ignore"):
        arr = arr.astype(np.float64)
    return np.where(np.isfinite(arr), arr, np.nan)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def _perp_unit(v: np.ndarray, axis: np.ndarray, min_angle_deg: float) -> np.ndarray:
    """Unit part of ``v`` perpendicular to the unit ``axis``; NaN where ``v`` is within
    ``min_angle_deg`` of parallel to ``axis`` (or NaN)."""
    vu = normalize(v, eps=_TINY)
    p = vu - _dot(vu, axis)[:, None] * axis
    n = np.linalg.norm(p, axis=-1)  # = sin(angle(v, axis))
    ok = n >= np.sin(np.radians(min_angle_deg))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok[:, None], p / np.where(ok, n, 1.0)[:, None], np.nan)


def _frame(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(T, 3, 3)`` whose columns are the axes X, Y, Z."""
    return np.stack([x, y, z], axis=-1)


def _valid(R: np.ndarray) -> np.ndarray:
    return np.isfinite(R).all(axis=(-2, -1))


def _euler_deg(R_rel: np.ndarray, seq: str) -> np.ndarray:
    """Intrinsic Euler/Cardan angles ``(T, 3)`` in degrees of relative rotations
    ``(T, 3, 3)``; rows with any NaN give NaN (scipy cannot take them).

    ``seq`` uses scipy's upper-case (intrinsic) form: ``"ZXY"`` means ``R = Rz(a) Rx(b) Ry(c)``,
    rotations about the moving axes Z, then X', then Y''; scipy returns the first and third
    angles in (-180, 180] and the middle one in [-90, 90] (Cardan, Z-X-Y) or [0, 180]
    (proper Euler, Y-X-Y). At a gimbal lock scipy warns and sets the third angle to 0;
    callers mask those angles with :data:`GIMBAL_MARGIN_DEG`, so the warning is silenced.
    """
    out = np.full(R_rel.shape[:-2] + (3,), np.nan)
    ok = _valid(R_rel)
    if ok.any():
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*[Gg]imbal lock.*")
            out[ok] = np.degrees(Rotation.from_matrix(R_rel[ok]).as_euler(seq))
    return out


def _wrap(deg: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-180, 180)."""
    return (deg + 180.0) % 360.0 - 180.0


def _bend(y_prox: np.ndarray, y_dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unsigned bend (degrees, 0 = straight) between two segments' long axes that both
    point proximally, and the (unnormalised) normal ``y_dist x y_prox`` of their plane."""
    n = np.cross(y_dist, y_prox)
    return np.degrees(np.arctan2(np.linalg.norm(n, axis=-1), _dot(y_dist, y_prox))), n


def _any_perp(y: np.ndarray) -> np.ndarray:
    """Some unit vector perpendicular to each unit ``y`` ``(T, 3)`` (for frames whose axial
    rotation is masked anyway)."""
    e = np.where((np.abs(y[:, :1]) < 0.9), np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]]))
    return normalize(np.cross(y, e), eps=_TINY)


def _right_side(X: np.ndarray) -> dict[str, np.ndarray]:
    """Frames and raw quantities of the pelvis, thorax and the subject's RIGHT limbs.

    Returns a dict with ``(T, 3, 3)`` frames (columns X, Y, Z) ``pelvis``, ``thorax``,
    ``thigh``, ``shank``, ``upper_arm``, ``forearm`` and ``(T,)`` arrays ``knee_bend``,
    ``knee_sign``, ``elbow_bend``.
    """
    # Pelvis (Wu 2002 pelvis: Z along the ASIS line, Y normal to the ASIS/PSIS plane):
    # Z = left_hip -> right_hip, Y = pelvis -> spine made perpendicular to Z.
    zp = normalize(X[:, R_HIP] - X[:, L_HIP], eps=_TINY)
    yp = _perp_unit(X[:, SPINE] - X[:, PELVIS], zp, MIN_AXIS_ANGLE_DEG)
    pelvis = _frame(np.cross(yp, zp), yp, zp)

    # Thorax (Wu 2005: Y = mid(PX,T8) -> mid(IJ,C7), Z normal to the IJ-C7-mid(PX,T8)
    # plane): Y = spine -> thorax, Z = left -> right shoulder made perpendicular to Y.
    yt = normalize(X[:, THORAX] - X[:, SPINE], eps=_TINY)
    zt = _perp_unit(X[:, R_SHOULDER] - X[:, L_SHOULDER], yt, MIN_AXIS_ANGLE_DEG)
    thorax = _frame(np.cross(yt, zt), yt, zt)

    # Thigh / shank (Wu 2002 femur: Y = mid-epicondyles -> hip centre, Z along the
    # epicondyle line; Grood & Suntay: the knee flexes about the femur's Z).
    y_th = normalize(X[:, R_HIP] - X[:, R_KNEE], eps=_TINY)
    y_sh = normalize(X[:, R_KNEE] - X[:, R_ANKLE], eps=_TINY)
    knee_bend, n_knee = _bend(y_th, y_sh)  # n_knee = y_sh x y_th: points right when flexed
    # The zero-internal-rotation thigh Z: Z-X-Y with the third angle 0, i.e.
    # Rz(a) Rx(b) e_z in pelvis coordinates, from the thigh's Y alone.
    y_loc = np.einsum("tji,tj->ti", pelvis, y_th)  # thigh Y in pelvis coordinates
    a = np.arctan2(-y_loc[:, 0], y_loc[:, 1])
    b = np.arcsin(np.clip(y_loc[:, 2], -1.0, 1.0))
    z_ref_loc = np.stack([np.sin(a) * np.sin(b), -np.cos(a) * np.sin(b), np.cos(b)], axis=-1)
    z_ref = np.einsum("tij,tj->ti", pelvis, z_ref_loc)
    # The plane normal's sign, which also signs the knee: flexed when the normal agrees with
    # the reference (hip internal rotation within +-90), hyperextended only where flexion
    # would need the thigh turned beyond HYPEREXTENSION_HIP_ROTATION_DEG: near +-90 the
    # choice follows the noise of a lifter's hip line, and a flexed knee is far more
    # common than a hyperextended one.
    flexed_rotation_cos = _dot(normalize(n_knee, eps=_TINY), z_ref)
    hyperextended = ((flexed_rotation_cos < np.cos(np.radians(HYPEREXTENSION_HIP_ROTATION_DEG)))
                     & (knee_bend <= MAX_KNEE_HYPEREXTENSION_DEG))
    knee_sign = np.where(hyperextended, -1.0, 1.0)
    knee_sign = np.where(np.isfinite(z_ref).all(-1), knee_sign, np.nan)
    plane_ok = knee_bend >= MIN_BEND_DEG
    z_th = np.where(plane_ok[:, None], knee_sign[:, None] * normalize(n_knee, eps=_TINY), z_ref)
    thigh = _frame(np.cross(y_th, z_th), y_th, z_th)
    z_sh = _perp_unit(z_th, y_sh, 1.0)
    shank = _frame(np.cross(y_sh, z_sh), y_sh, z_sh)
    # Where the knee plane is undefined the thigh Z is the zero-rotation reference: the
    # thigh frame then carries flexion/adduction but its axial rotation is masked.
    thigh_axial_ok = plane_ok

    # Upper arm / forearm (Wu 2005 humerus, second definition: Z normal to the plane of
    # the humerus' and forearm's long axes, pointing right; forearm Y = ulnar styloid ->
    # elbow, here wrist -> elbow).
    y_ua = normalize(X[:, R_SHOULDER] - X[:, R_ELBOW], eps=_TINY)
    y_fa = normalize(X[:, R_ELBOW] - X[:, R_WRIST], eps=_TINY)
    elbow_bend, n_elbow = _bend(y_ua, y_fa)  # n_elbow = y_fa x y_ua
    elbow_ok = elbow_bend >= MIN_BEND_DEG
    z_ua = np.where(elbow_ok[:, None], normalize(-n_elbow, eps=_TINY), _any_perp(y_ua))  # y_ua x y_fa
    upper_arm = _frame(np.cross(y_ua, z_ua), y_ua, z_ua)
    z_fa = _perp_unit(z_ua, y_fa, 1.0)
    forearm = _frame(np.cross(y_fa, z_fa), y_fa, z_fa)

    return {
        "pelvis": pelvis, "thorax": thorax, "thigh": thigh, "shank": shank,
        "upper_arm": upper_arm, "forearm": forearm, "knee_bend": knee_bend,
        "knee_sign": knee_sign, "thigh_axial_ok": thigh_axial_ok,
        "elbow_bend": elbow_bend, "upper_arm_axial_ok": elbow_ok,
    }


def _rel(proximal: np.ndarray, distal: np.ndarray) -> np.ndarray:
    """Distal frame expressed in the proximal one: ``R_p^T R_d`` ``(T, 3, 3)``."""
    return np.einsum("tji,tjk->tik", proximal, distal)


def _limb_angles(f: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Right-side angles from :func:`_right_side`'s frames (of the mirror image for the
    left side)."""
    lock_zxy = 90.0 - GIMBAL_MARGIN_DEG
    out: dict[str, np.ndarray] = {}

    # Hip: thigh relative to pelvis, intrinsic Z-X'-Y'' (Wu 2002 hip JCS: e1 = pelvis Z,
    # flexion; e2 floating, adduction; e3 = thigh Y, internal rotation). For the right side
    # the right-hand rule makes flexion, adduction and internal rotation positive.
    hip = _euler_deg(_rel(f["pelvis"], f["thigh"]), "ZXY")
    hip_lock = np.abs(hip[:, 1]) > lock_zxy
    out["hip_flexion_deg"] = np.where(hip_lock, np.nan, hip[:, 0])
    out["hip_adduction_deg"] = hip[:, 1]
    out["hip_internal_rotation_deg"] = np.where(hip_lock | ~f["thigh_axial_ok"], np.nan, hip[:, 2])

    # Knee: shank relative to thigh about the thigh's Z (Grood & Suntay). The right-hand
    # rotation about a right-pointing Z swings the shank anteriorly, i.e. extension, so
    # flexion is its negative. By construction the shank lies in the thigh's X-Y plane
    # (knee ad/abduction 0, rotation not observable), so this equals the signed bend.
    out["knee_flexion_deg"] = f["knee_sign"] * f["knee_bend"]

    # Shoulder: upper arm relative to thorax, intrinsic Y-X'-Y'' (Wu 2005 thoraco-humeral:
    # plane of elevation about the thorax Y, elevation about the floating X', axial rotation
    # about the humerus Y''). With the right-hand rule the right arm's elevation is
    # negative; scipy returns the equivalent solution with the middle angle in [0, 180]
    # (a, b, c) == (a + 180, -b, c + 180), so shifting the first and third angles by 180
    # gives plane of elevation (0 = abduction, 90 = flexion), elevation >= 0, and axial
    # rotation (internal positive) in the usual reporting form.
    sh = _euler_deg(_rel(f["thorax"], f["upper_arm"]), "YXY")
    sh_lock = (sh[:, 1] < GIMBAL_MARGIN_DEG) | (sh[:, 1] > 180.0 - GIMBAL_MARGIN_DEG)
    out["shoulder_plane_of_elevation_deg"] = np.where(sh_lock, np.nan, _wrap(sh[:, 0] - 180.0))
    out["shoulder_elevation_deg"] = sh[:, 1]
    out["shoulder_axial_rotation_deg"] = np.where(
        sh_lock | ~f["upper_arm_axial_ok"], np.nan, _wrap(sh[:, 2] - 180.0))

    # Elbow: forearm relative to upper arm, intrinsic Z-X'-Y'' (Wu 2005 elbow JCS: e1 =
    # humerus Z, flexion positive by the right-hand rule for the right arm). The upper
    # arm's Z is the normal of the arm's own plane, so the angle is the unsigned bend.
    out["elbow_flexion_deg"] = f["elbow_bend"]
    return out


def _trunk_angles(f: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    lock_zxy = 90.0 - GIMBAL_MARGIN_DEG
    # Thorax relative to pelvis, intrinsic Z-X'-Y'' (JCS e1 = pelvis Z, e3 = thorax Y; Wu
    # 2005's thorax sequence). The right-hand rotation about Z tilts the thorax backwards,
    # so flexion is reported as its negative.
    tr = _euler_deg(_rel(f["pelvis"], f["thorax"]), "ZXY")
    lock = np.abs(tr[:, 1]) > lock_zxy
    # Thorax relative to gravity: the same sequence relative to a heading frame whose Y is
    # +Y (up) and whose Z is the horizontal part of the thorax's Z (so the result does not
    # depend on where the subject faces).
    thorax = f["thorax"]
    zh = _perp_unit(thorax[:, :, 2], _UP, MIN_AXIS_ANGLE_DEG)
    heading = _frame(np.cross(np.broadcast_to(_UP, zh.shape), zh), np.broadcast_to(_UP, zh.shape), zh)
    tg = _euler_deg(_rel(heading, thorax), "ZXY")
    glock = np.abs(tg[:, 1]) > lock_zxy
    return {
        "trunk_flexion_to_pelvis_deg": np.where(lock, np.nan, -tr[:, 0]),
        "trunk_lateral_bending_to_pelvis_deg": tr[:, 1],
        "trunk_axial_rotation_to_pelvis_deg": np.where(lock, np.nan, tr[:, 2]),
        "trunk_flexion_to_gravity_deg": np.where(glock, np.nan, -tg[:, 0]),
        "trunk_lateral_tilt_to_gravity_deg": tg[:, 1],
    }


def _mirror(X: np.ndarray) -> np.ndarray:
    """The mirror image of the pose: reflected through the vertical X-Y plane, left and
    right joints swapped, so the subject's left limbs become right limbs."""
    return (X * _MIRROR)[:, _SWAP_LR]


#: A spine joint within this fraction of the trunk's length (pelvis -> thorax) of that line is
#: not a measured joint but built on the line (Kinect's and MediaPipe's conversions put it at
#: the midpoint): float32 rounding is ~1e-6 of it, a lifter's own spine joint is centimetres
#: off the line. There the pelvis Y and the thorax Y share the plane of the trunk and the hip
#: line, so the thorax's flexion relative to the pelvis is 0 by construction, not measured.
SPINE_ON_LINE_FRACTION = 1e-4
#: The angles that need a spine joint off the pelvis-thorax line (:data:`SPINE_ON_LINE_FRACTION`).
NEEDS_SPINE_JOINT = ("trunk_flexion_to_pelvis_deg",)


def spine_off_trunk_line(joints: np.ndarray) -> np.ndarray:
    """The spine joint's distance from the pelvis-thorax line over the trunk's length, per frame,
    of H36M-17 poses ``(T, 17, 3)`` (any frame, any unit): ``(T,)`` float64, NaN where the
    pelvis, spine or thorax is missing."""
    J = np.asarray(joints, np.float64)
    trunk, spine = J[:, THORAX] - J[:, PELVIS], J[:, SPINE] - J[:, PELVIS]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.linalg.norm(np.cross(spine, trunk), axis=-1) / np.sum(trunk * trunk, axis=-1)


def isb_joint_angles(joints: np.ndarray, check_up: bool = True) -> dict[str, np.ndarray]:
    """ISB joint angles (degrees) of H36M-17 poses.

    Sequences and signs (details and the segment-axis approximations: module docstring and
    ``docs/joint_angles.md``):

    * hip (Wu et al. 2002, JCS of Grood & Suntay 1983): thigh relative to pelvis, intrinsic
      Z-X'-Y'': flexion (+) about the pelvis Z, adduction (+, as OpenSim) about the floating
      axis, internal rotation (+) about the thigh Y;
    * knee (Grood & Suntay 1983): flexion (+) of the shank about the thigh's Z, negative =
      hyperextension; knee ad/abduction and rotation are not observable from joint centres;
    * shoulder (Wu et al. 2005): humerus relative to thorax, intrinsic Y-X'-Y'': plane of
      elevation (0 = abduction plane, 90 = flexion plane), elevation (>= 0), axial rotation
      (internal +);
    * elbow (Wu et al. 2005): flexion about the humerus Z, 0 = straight, >= 0;
    * trunk: thorax relative to pelvis, intrinsic Z-X'-Y'': flexion (+ forward), lateral
      bending (+ to the right), axial rotation (+ thorax turned to the left); and thorax
      relative to gravity (the same sequence in a heading frame: +Y up, Z = horizontal part
      of the thorax Z): flexion (+ forward lean), lateral tilt (+ to the right).

    Left and right use mirrored frames: the same anatomical motion has the same sign.

    Args:
        joints: ``(T, 17, 3)`` (or one ``(17, 3)`` pose) H36M-17 joint centres in a frame
            with +Y up (world or canonical frame, ``docs/CONVENTIONS.md``), any length
            unit; NaN = missing.

    Returns:
        dict ``name -> (T,)`` float64 degrees, keys in :data:`NAMES` order; NaN where a
        needed joint is NaN, a frame is degenerate (:data:`MIN_AXIS_ANGLE_DEG`), an axial
        rotation's limb plane is undefined (:data:`MIN_BEND_DEG`) or near gimbal lock
        (:data:`GIMBAL_MARGIN_DEG`), and, for :data:`NEEDS_SPINE_JOINT`, where the spine
        joint lies on the pelvis-thorax line (:data:`SPINE_ON_LINE_FRACTION`: built there, so
        the angle would be 0 by construction). Meaning of each sign: :data:`POSITIVE_SIGN`.

        check_up: refuse poses whose trunk points down in most frames
            (:func:`pcnet.stages.kinematics.require_y_up`: camera-frame poses, +Y down, whose
            angles against gravity would read upside down); False for a body inverted for most
            of the recording.

    Raises:
        InputError (a ValueError): ``joints`` of the wrong shape or dtype; with ``check_up``,
            poses that are not Y-up.
    """
    X = _check(joints)
    if check_up:
        from .kinematics import require_y_up  # kinematics imports this module

        require_y_up(X, "joints")
    with np.errstate(invalid="ignore", divide="ignore"):
        frames = _right_side(X)
        out = _trunk_angles(frames)
        right = _limb_angles(frames)
        left = _limb_angles(_right_side(_mirror(X)))
    for key in right:
        out[f"left_{key}"] = left[key]
        out[f"right_{key}"] = right[key]
    built = spine_off_trunk_line(X) <= SPINE_ON_LINE_FRACTION
    for name in NEEDS_SPINE_JOINT:
        out[name] = np.where(built, np.nan, out[name])
    return {name: np.asarray(out[name], dtype=np.float64) for name in NAMES}


def isb_segment_frames(joints: np.ndarray) -> dict[str, np.ndarray]:
    """The segment frames :func:`isb_joint_angles` uses, as rotation matrices.

    Returns:
        dict with ``pelvis``, ``thorax``, ``{left,right}_{thigh,shank,upper_arm,forearm}``:
        ``(T, 3, 3)`` float64 whose columns are the segment's X (anterior), Y (proximal /
        superior) and Z (to the subject's right) axes in the input frame; right-handed for
        both sides (a left segment's frame is its mirrored frame reflected back, with Z
        negated so that it points to the subject's right). NaN where undefined. Where a
        knee or elbow is nearly straight (:data:`MIN_BEND_DEG`) the thigh's / upper arm's
        X and Z are a placeholder (zero hip rotation / an arbitrary perpendicular) whose
        axial rotation is meaningless.

    Raises:
        InputError (a ValueError): ``joints`` of the wrong shape or dtype.
    """
    X = _check(joints)
    with np.errstate(invalid="ignore", divide="ignore"):
        right = _right_side(X)
        left = _right_side(_mirror(X))
    flip = np.diag(_MIRROR)  # reflection of the mirror, and the Z-negation back to right-handed
    out = {"pelvis": right["pelvis"], "thorax": right["thorax"]}
    for seg in ("thigh", "shank", "upper_arm", "forearm"):
        out[f"left_{seg}"] = flip @ left[seg] @ flip
        out[f"right_{seg}"] = right[seg]
    return out
