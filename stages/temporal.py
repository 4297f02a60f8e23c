"""Sequence-aware canonicalisation: use the fact that gravity does not move in a static camera.

The 3DPCNet paper rectifies every frame on its own. In a video from a fixed camera (clinics,
labs, most sports recordings) the up direction in the camera frame, ``R[:, 1]``
(``docs/CONVENTIONS.md``), is the same in every frame; only the subject's heading changes. This
module pools the per-frame predictions of any per-frame estimator (the geometric baseline,
the learned network, ...) accordingly:

* :func:`sequence_rectify` - one robust up direction for the whole sequence
  (:func:`pcnet.stages.spherical.robust_mean_direction`), per-frame heading about it, the
  ground-plane refinement from foot contacts when the root is measured
  (:mod:`pcnet.stages.ground_plane`), and uncertainties.
* :func:`smooth_rotations` - for moving cameras: zero-phase Gaussian smoothing on SO(3)
  (weighted chordal quaternion mean; no Euler angles anywhere).
* :func:`choose_mode` - static or moving camera, from the spread of the per-frame ups.
* :func:`check_rotations` - the shared check of per-frame rotations and validity.

The mode dispatch is :class:`pcnet.stages.rectify.SequenceEvidence`.

Frames and shapes: ``R`` ``(T, 3, 3)`` canonical->camera (``x_cam = R @ x_canon``); joints
``(T, 17, 3)`` H36M-17 in the camera frame (OpenCV axes, any length unit); angles in public
outputs are degrees. Nothing here knows where ``R`` came from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import convolve1d
from scipy.spatial.transform import Rotation

from .core.conventions import check_poses
from .core.errors import InputError
from .core.rotations import angle_between, camera_pitch_roll, decompose_camera_rotation, normalize
from .ground_plane import NO_PELVIS_PATH, fit_floor, ground_plane_up
from .spherical import robust_mean_direction, weighted_quantile
from .up_model import default_parameters

MODES = ("frame", "sequence", "smooth", "auto")

# --- uncertainty ------------------------------------------------------------------------------
BOOTSTRAP_REPLICATES = 200
# Block length of the moving-block bootstrap. Consecutive frames of a pose sequence are not
# independent (a held pose gives the same error for seconds); 1 s blocks keep that
# short-range dependence inside each block (Kunsch 1989).
BOOTSTRAP_BLOCK_S = 1.0
_MIN_BLOCKS = 5

# --- heading ----------------------------------------------------------------------------------
# |a_perp + u x c| = 1 + cos(theta) for a frame whose up is theta from the sequence up: 2 when
# they agree, 0 when it is flipped: below this the heading is undefined.
_MIN_HEADING_NORM = 0.2
#: A frame whose own up is further than this from a prescribed up has no heading about it
#: (:func:`rotations_about_up`): ``1 + cos(theta) = 0.2``, about 143 deg.
HEADING_LIMIT_DEG = float(np.degrees(np.arccos(_MIN_HEADING_NORM - 1.0)))

# --- ground plane (methods other than the shipped ensemble) -----------------------------------
#: Prior std (deg) of a per-frame estimator's systematic tilt error about its robust mean up,
#: the normal prior of the floor contacts for the methods the up model does not describe (the
#: geometric baseline, one network given as weights): comparisons, hand-set (the geometric
#: baseline's trunk-lean bias measured 3-5 deg on Bandai walking, ~14 deg running). The
#: shipped ensemble uses the up model's fitted posterior instead.
POSE_PRIOR_DEG = 5.0

# --- mode choice ------------------------------------------------------------------------------
# Fitted on validation data by ``python -m benchmarks.fit_camera_mode --data ../shared/data``
# (benchmarks/results/fit_camera_mode.txt; tests/test_temporal.py checks these equal it):
#: Auto mode's static/moving threshold on :func:`up_spread_deg`, degrees.
MODE_THRESHOLD_DEG = 4.01
#: Kernel std (s) of the low-pass inside :func:`up_spread_deg` for the mode choice.
MODE_SMOOTHING_S = 0.25
#: Kernel std (s) of smooth mode's SO(3) smoothing (:func:`smooth_rotations`).
SMOOTH_TIME_CONSTANT_S = 0.5


@dataclass(frozen=True)
class SequenceResult:
    """Result of :func:`sequence_rectify`.

    Attributes:
        rotations: ``(T, 3, 3)`` float64 canonical->camera, all sharing ``up`` as column 1;
            NaN where ``valid`` is False.
        up: ``(3,)`` float64 unit up direction (against gravity) in the camera frame.
        up_uncertainty_deg: radius of the 95% moving-block-bootstrap confidence cone around
            ``up`` (95th percentile of the bootstrap replicates' angles to ``up``), degrees.
        camera_pitch_deg, camera_roll_deg: the camera's tilt from ``up`` with
            :func:`~pcnet.stages.core.rotations.decompose_camera_rotation`'s meaning:
            ``pitch = asin(-u_z)`` (positive = camera looking down), ``roll = atan2(u_x, -u_y)``.
        camera_pitch_uncertainty_deg, camera_roll_uncertainty_deg: 95th percentile of the
            bootstrap replicates' absolute pitch / roll differences from the estimate
            (half-width of a symmetric 95% interval), degrees.
        heading_deg: ``(T,)`` subject heading per frame (decompose_camera_rotation's heading:
            0 = facing the camera, positive = counter-clockwise seen from above), NaN if invalid.
        up_spread_deg: (weighted) median angle between the per-frame ups ``R[:, :, 1]`` and
            ``up``, degrees: how much the per-frame estimator disagrees with the pooled up.
        up_spread_p95_deg: the 95th percentile of the same angles.
        evidence: ``"poses"`` or ``"poses+ground_plane"``.
        valid: ``(T,)`` bool, frames with a rotation.
        ground_plane: diagnostics of the ground-plane step (``{"used": bool, "reason": str,
            ...}``); the reason says why it was skipped when it was.
    """

    rotations: np.ndarray
    up: np.ndarray
    up_uncertainty_deg: float
    camera_pitch_deg: float
    camera_roll_deg: float
    camera_pitch_uncertainty_deg: float
    camera_roll_uncertainty_deg: float
    heading_deg: np.ndarray
    up_spread_deg: float
    up_spread_p95_deg: float
    evidence: str
    valid: np.ndarray
    ground_plane: dict = field(default_factory=dict)


# ============================================================================ input checks


def check_rotations(R: np.ndarray, valid: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``(R (T, 3, 3) float64, ok (T,) bool)``: ``valid`` (``None`` = all) and finite ``R``.

    Raises:
        InputError: ``R`` not ``(T, 3, 3)`` or ``valid`` not ``(T,)``.
    """
    R = np.asarray(R, np.float64)
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise InputError(f"R: expected shape (T, 3, 3) rotations, got {R.shape}")
    if valid is None:
        valid = np.ones(len(R), bool)
    valid = np.asarray(valid)
    if valid.shape != (len(R),):
        raise InputError(f"valid: expected shape ({len(R)},), got {valid.shape}")
    return R, valid.astype(bool) & np.isfinite(R).all((1, 2))


def frame_ups(R: np.ndarray) -> np.ndarray:
    """Per-frame up directions ``R[:, :, 1]`` ``(T, 3)``, renormalised (NaN stays NaN)."""
    return normalize(np.asarray(R, np.float64)[:, :, 1])


# ============================================================================ heading


def rotations_about_up(R: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame rotations with a prescribed up: the rotation closest to each ``R_t``
    (Frobenius norm) whose column 1 is ``up``.

    With ``a = R_t[:, 0]`` (anterior), ``c = R_t[:, 2]`` (subject's right) and ``Y = up``,
    maximising ``tr(R'^T R_t)`` over ``R' = [X, Y, X x Y]`` gives
    ``X = normalize(a_perp + Y x c)``, ``a_perp = a - (a.Y) Y``; then ``Z = X x Y`` (so that
    ``X = Y x Z``, right-handed, ``docs/CONVENTIONS.md``). This is the projection of the anterior
    axis onto the plane perpendicular to ``up`` combined with the anterior axis implied by
    the lateral axis (``Y x c``), so it stays defined when one of them is (anti)parallel to
    ``up``; it is undefined only when ``R_t``'s own up is nearly opposite to ``up``.

    Args:
        R: ``(T, 3, 3)`` canonical->camera per-frame predictions.
        up: ``(3,)`` or ``(T, 3)`` unit up direction(s) in the camera frame.

    Returns:
        ``(rotations (T, 3, 3) float64, ok (T,) bool)``; NaN rotation where not ``ok``.
    """
    R = np.asarray(R, np.float64)
    Y = np.broadcast_to(np.asarray(up, np.float64), (len(R), 3))
    a, c = R[:, :, 0], R[:, :, 2]
    x = a - np.sum(a * Y, -1, keepdims=True) * Y + np.cross(Y, c)
    n = np.linalg.norm(x, axis=-1)
    ok = np.isfinite(n) & (n > _MIN_HEADING_NORM)
    with np.errstate(invalid="ignore", divide="ignore"):
        X = x / n[:, None]
    Z = np.cross(X, Y)
    out = np.stack([X, Y, Z], axis=-1)
    out[~ok] = np.nan
    return out, ok


# ============================================================================ main estimator


def _block_starts(T: int, block: int, B: int, rng: np.random.Generator) -> np.ndarray:
    """Moving-block bootstrap (Kunsch 1989): ``(B, ceil(T / block))`` uniform random starts
    of the blocks of consecutive frames each replicate is built from."""
    return rng.integers(0, T - block + 1, size=(B, -(-T // block)))


def _block_indices(starts: np.ndarray, block: int, T: int) -> np.ndarray:
    """``(b, T)`` frame indices of the replicates whose block starts are ``starts`` ``(b, n)``."""
    return (starts[:, :, None] + np.arange(block)).reshape(len(starts), -1)[:, :T]


def _pose_prior_cov() -> np.ndarray:
    """``(2, 2)`` rad^2: :data:`POSE_PRIOR_DEG` on each tangent axis."""
    return np.eye(2) * np.radians(POSE_PRIOR_DEG) ** 2


def sequence_rectify(
    R: np.ndarray,
    valid: np.ndarray | None = None,
    joints_cam: np.ndarray | None = None,
    *,
    fps: float = 30.0,
    n_bootstrap: int = BOOTSTRAP_REPLICATES,
) -> SequenceResult:
    """One up direction for a static-camera sequence, per-frame heading about it.

    1. **Up**: :func:`robust_mean_direction` of the per-frame ups ``R[:, :, 1]`` (Weiszfeld
       geometric median on S^2, then Tukey-biweight IRLS).
    2. **Ground plane** (``joints_cam`` given, with a pelvis path): the floor contacts fused
       with the robust mean up as a Gaussian prior of std :data:`POSE_PRIOR_DEG` per axis
       (:func:`pcnet.stages.ground_plane.ground_plane_up`, with the up model's fitted contact
       parameters), the reason in ``ground_plane["reason"]``.
    3. **Heading**: :func:`rotations_about_up`, the rotation with the sequence up closest to
       each frame's prediction.
    4. **Uncertainty**: moving-block bootstrap (Kunsch 1989, "The jackknife and the bootstrap
       for general stationary observations", Ann. Stat. 17: 1217) over frames, 1 s blocks
       (``fps``), ``n_bootstrap`` replicates, deterministic (seed 0), re-running steps 1-2.
       Sequences shorter than 5 blocks use ``T // 5`` frame blocks (optimistic intervals).
       Measured: with unbiased AR(1) rotation noise (5 deg per axis, lag-1 correlation 0.8)
       on 90-120-frame clips (4-5 blocks) the 95% cone covered the truth in 80-90% of trials
       (iid noise: 93%), the pitch / roll intervals in 81% / 86%; at lag-1 correlation 0.95
       (errors lasting longer than a block) only 56%. It measures frame-to-frame scatter only: an
       error common to all frames (e.g. the geometric baseline's trunk-lean bias, or its
       upright-trunk assumption on a person lying down) is invisible to it.

    Args:
        R: ``(T, 3, 3)`` per-frame canonical->camera predictions (any source).
        valid: ``(T,)`` bool; frames with NaN ``R`` are invalid too. ``None`` = all.
        joints_cam: optional ``(T, 17, 3)`` H36M-17 camera-frame joints (any unit), for the
            ground plane.
        fps: frame rate (bootstrap block length).
        n_bootstrap: bootstrap replicates (0 = no uncertainty, NaN).

    Returns:
        :class:`SequenceResult`.

    Raises:
        ValueError: wrong shapes, non-positive fps or no valid frame.
    """
    R, ok = check_rotations(R, valid)
    T = len(R)
    if not fps > 0:
        raise InputError(f"fps must be positive, got {fps}")
    ups = frame_ups(R)
    ok &= np.isfinite(ups).all(-1)
    if not ok.any():
        raise InputError("sequence_rectify: no valid frame (all invalid or NaN)")
    w = ok.astype(np.float64)

    u_pose, _ = robust_mean_direction(ups, w)
    up, gp = u_pose, {"used": False, "reason": NO_PELVIS_PATH}
    contacts, leg = None, float("nan")
    J = None
    if joints_cam is not None:
        # Left as given (float32, or on disk for a long recording): the estimators read the
        # joints they use as float64 columns.
        J = check_poses(joints_cam, "joints_cam")
        if len(J) != T:
            raise InputError(f"joints_cam: expected {T} frames, got {len(J)}")
    if J is not None:
        floor = ground_plane_up(J, ok, u_pose, _pose_prior_cov())
        up, gp = floor.up, floor.info
        if gp["used"]:
            contacts, leg = floor.contacts, floor.leg
    evidence = "poses+ground_plane" if gp["used"] else "poses"
    rotations, hok = rotations_about_up(R, up)
    out_valid = ok & hok
    rotations[~out_valid] = np.nan
    heading = np.full(T, np.nan)
    if out_valid.any():
        heading[out_valid] = np.degrees(decompose_camera_rotation(rotations[out_valid])[0])

    dev = angle_between(ups, up[None])
    spread = float(np.degrees(weighted_quantile(np.where(ok, dev, 0.0)[None], w[None], 0.5)[0]))
    spread95 = float(np.degrees(weighted_quantile(np.where(ok, dev, 0.0)[None], w[None], 0.95)[0]))
    pitch, roll = np.degrees(camera_pitch_roll(up))

    unc = dict(up=np.nan, pitch=np.nan, roll=np.nan)
    if n_bootstrap > 0 and T >= 2:
        block = max(1, int(round(BOOTSTRAP_BLOCK_S * fps)))
        if T < _MIN_BLOCKS * block:
            block = max(1, T // _MIN_BLOCKS)
        rng = np.random.default_rng(0)
        starts = _block_starts(T, block, n_bootstrap, rng)
        # Replicates in chunks, their frame indices built per chunk: all at once would hold
        # (B, T) indices and (B, T, 3) arrays several times over, GBs for a 2-hour recording.
        chunk = max(1, 500_000 // max(T, 1))
        ub = np.concatenate([
            robust_mean_direction(ups[idx], w[idx], init=u_pose)[0]
            for i in range(0, n_bootstrap, chunk)
            for idx in [_block_indices(starts[i : i + chunk], block, T)]
        ])
        if contacts is not None:
            # Each replicate refits the plane to the contacts of its resampled frames; one
            # with too few contacts to fit a plane is dropped (falling back to the pose-based
            # up there would mix two estimators into one interval).
            for b in range(n_bootstrap):
                rep = contacts.repeated(np.bincount(_block_indices(starts[b : b + 1], block, T)[0], minlength=T))
                if not np.isfinite(ub[b]).all() or not len(rep.points):
                    ub[b] = np.nan
                    continue
                ub[b] = fit_floor(rep, ub[b], _pose_prior_cov(), leg, default_parameters()).up
        good = np.isfinite(ub).all(-1)
        if good.any():
            ub = ub[good]
            unc["up"] = float(np.percentile(np.degrees(angle_between(ub, up[None])), 95))
            pb, rb = np.degrees(camera_pitch_roll(ub))
            pe, re_ = np.degrees(camera_pitch_roll(up))
            dp = pb - pe
            dr = (rb - re_ + 180.0) % 360.0 - 180.0
            unc["pitch"] = float(np.percentile(np.abs(dp), 95))
            unc["roll"] = float(np.percentile(np.abs(dr), 95))

    return SequenceResult(
        rotations=rotations,
        up=up,
        up_uncertainty_deg=unc["up"],
        camera_pitch_deg=float(pitch),
        camera_roll_deg=float(roll),
        camera_pitch_uncertainty_deg=unc["pitch"],
        camera_roll_uncertainty_deg=unc["roll"],
        heading_deg=heading,
        up_spread_deg=spread,
        up_spread_p95_deg=spread95,
        evidence=evidence,
        valid=out_valid,
        ground_plane=gp,
    )


# ============================================================================ moving camera


def smooth_rotations(
    R: np.ndarray, valid: np.ndarray | None, fps: float, time_constant_s: float = 0.2
) -> np.ndarray:
    """Zero-phase Gaussian smoothing of a rotation sequence on SO(3), for moving cameras.

    Each output frame is the weighted chordal L2 mean of the valid input rotations within
    +-3 sigma frames, weights ``exp(-dt^2 / (2 tau^2))``: the principal eigenvector of
    ``sum_k w_k q_k q_k^T`` over unit quaternions (Markley, Cheng, Crassidis & Oshman 2007,
    "Averaging quaternions", J. Guid. Control Dyn. 30: 1193; the same estimator as
    ``scipy.spatial.transform.Rotation.mean``). ``q q^T`` is sign-invariant, so no quaternion
    hemisphere bookkeeping is needed, and no Euler angles are involved. The kernel is
    symmetric, so there is no lag (zero phase) and a rotation at constant angular velocity
    passes unchanged. Near the ends (and the edges of invalid gaps) the window is truncated
    and renormalised, i.e. one-sided there: a rotation at constant angular velocity omega is
    pulled inwards by up to ``sqrt(2/pi) omega tau`` (about ``0.8 omega tau``; 1.6 deg for a
    10 deg/s camera pan and the default tau) at the first and last frame.

    ``time_constant_s`` (tau) is the standard deviation of the Gaussian kernel in seconds
    (``sigma = tau * fps`` frames). To first order (small rotations within a window) the
    filter acts on the rotation vector as a linear Gaussian filter with gain
    ``exp(-2 pi^2 tau^2 f^2)``: -3 dB at ``f = sqrt(ln 2) / (2 pi tau) = 0.1325 / tau`` Hz
    (0.66 Hz for the default 0.2 s); a 1 Hz oscillation keeps 45% of its amplitude.

    Invalid frames contribute nothing. An invalid frame with valid frames within +-3 sigma
    is filled by their weighted mean (interpolation); a frame with none stays NaN.

    Args:
        R: ``(T, 3, 3)`` canonical->camera rotations (re-orthonormalised via quaternions).
        valid: ``(T,)`` bool or ``None`` (all; NaN frames are always invalid).
        fps: frame rate, > 0.
        time_constant_s: kernel std in seconds, >= 0 (0 = no smoothing).

    Returns:
        ``(T, 3, 3)`` float64.

    Raises:
        ValueError: bad shapes, non-positive fps, negative time constant.
    """
    R, ok = check_rotations(R, valid)
    if not fps > 0:
        raise InputError(f"fps must be positive, got {fps}")
    if not time_constant_s >= 0:
        raise InputError(f"time_constant_s must be >= 0, got {time_constant_s}")
    T = len(R)
    out = np.full((T, 3, 3), np.nan)
    if not ok.any():
        return out
    q = np.zeros((T, 4))
    q[ok] = Rotation.from_matrix(R[ok]).as_quat()
    M = (q[:, :, None] * q[:, None, :]).reshape(T, 16)
    sigma = time_constant_s * fps
    half = int(np.ceil(3.0 * sigma))
    k = np.arange(-half, half + 1)
    g = np.exp(-0.5 * (k / sigma) ** 2) if sigma > 0 else np.ones(1)
    S = convolve1d(M, g, axis=0, mode="constant", cval=0.0)
    W = convolve1d(ok.astype(np.float64), g, axis=0, mode="constant", cval=0.0)
    has = W > 1e-12 * g.sum()
    vec = np.linalg.eigh(S[has].reshape(-1, 4, 4))[1][..., -1]
    out[has] = Rotation.from_quat(vec).as_matrix()
    return out


# ============================================================================ mode choice


def up_spread_deg(
    R: np.ndarray, valid: np.ndarray | None = None, fps: float | None = None, smoothing_s: float = MODE_SMOOTHING_S
) -> float:
    """Median angle (degrees) between the per-frame ups and their robust mean
    (:func:`robust_mean_direction`), after low-passing the up trajectory.

    With ``fps`` given, the per-frame rotations are first smoothed with
    :func:`smooth_rotations` (kernel std ``smoothing_s``): camera motion that matters for a
    single-up assumption is slow (drift, sweeps), while estimator noise and quick pose
    changes (punches, steps) are fast; smoothing removes the latter so the statistic
    measures the former. Without ``fps`` the raw ups are used.

    Args:
        R: ``(T, 3, 3)`` canonical->camera rotations (column 1 = up in the camera frame).
        valid: ``(T,)`` bool or ``None`` (every finite rotation).
        fps: frame rate in Hz, or ``None`` (no smoothing).
        smoothing_s: the smoothing kernel's std, seconds.

    Returns:
        the spread in degrees; NaN without a valid frame.
    """
    R, ok = check_rotations(R, valid)
    if fps is not None and smoothing_s > 0:
        R = smooth_rotations(R, ok, fps, smoothing_s)
        ok = ok & np.isfinite(R).all((1, 2))
    ups = frame_ups(R)[ok]
    if len(ups) == 0:
        return float("nan")
    m, _ = robust_mean_direction(ups)
    return float(np.degrees(np.median(angle_between(ups, m[None]))))


def choose_mode(
    R: np.ndarray,
    valid: np.ndarray | None = None,
    threshold_deg: float = MODE_THRESHOLD_DEG,
    fps: float | None = None,
) -> tuple[str, float]:
    """Static camera (``"sequence"``) or moving camera (``"smooth"``)?

    Decision: ``"sequence"`` if :func:`up_spread_deg` (median angular deviation of the
    low-passed per-frame ups from their robust mean) is at most ``threshold_deg``, else
    ``"smooth"``. The statistic is the typical tilt error that a single up would make
    against the slowly varying per-frame trajectory, so the threshold is the tilt error one
    accepts in exchange for the pooling; it only sees changes of *tilt* (camera pitch and
    roll): a camera that only pans about the vertical keeps the up fixed, and sequence mode
    is right for it.

    ``MODE_THRESHOLD_DEG`` and the low-pass ``MODE_SMOOTHING_S`` are fitted on validation
    data (benchmarks/fit_camera_mode.py): the fewest misread recordings among static cameras
    and cameras whose pitch sweeps 30 deg, then the shorter low-pass. Held-out
    results: benchmarks/results/ablation.txt.

    Sustained trunk movements that a per-frame estimator reads as tilt (the side bend of
    Trikonasana, the cobra lift of Bhujangasana, with the geometric baseline) are, from
    rotations alone, indistinguishable from a camera roll or pitch, and such clips are
    classified ``"smooth"`` (per-frame estimates are kept). Short clips
    (< ~5 s) with a moving camera can score below the threshold when pose changes and camera
    motion cancel. Without ``fps`` the raw per-frame ups are used, which carry the
    estimator's frame-to-frame noise: then pass a larger threshold.

    Args:
        R: ``(T, 3, 3)`` per-frame canonical->camera predictions.
        valid: ``(T,)`` bool or ``None``.
        threshold_deg: decision threshold in degrees.
        fps: frame rate; ``None`` skips the low-pass (then use a larger threshold).

    Returns:
        ``(mode, spread_deg)``.

    Raises:
        ValueError: bad shapes; no valid frame.
    """
    spread = up_spread_deg(R, valid, fps)
    if not np.isfinite(spread):
        raise InputError("choose_mode: no valid frame")
    return ("sequence" if spread <= threshold_deg else "smooth"), spread
