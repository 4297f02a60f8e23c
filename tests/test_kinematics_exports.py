"""Downstream stages: metric scaling, filtering, derivatives, joint angles, the
exporters (NPZ, CSV, TRC, PNG) and the rerun recording.

Real data: ``tests/fixtures/yoga_vp3d_Bhumi_Tadasana.npy`` (a real VideoPose3D export,
camera frame, metres; see fixtures/README.md); the full ``export_Abhay_Tadasana.npy`` and
the boxing video from ``../shared/data`` when present (skipped otherwise).
"""

from __future__ import annotations

import csv
import dataclasses
import re
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES, rrd_summary, shared

from pcnet.stages.sinks import exports
from pcnet.stages.core.canonical import canonical_rotation, to_canonical
from pcnet.stages.core.conventions import (
    H36M_JOINTS,
    H36M_PARENTS,
    L_ANKLE,
    L_ELBOW,
    L_KNEE,
    L_SHOULDER,
    L_WRIST,
    PELVIS,
    R_ANKLE,
    R_ELBOW,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_WRIST,
    R_FRONTAL,
)
from pcnet.stages.sinks.exports import plot_wrists, write_c3d, write_kinematics_csv, write_npz, write_trc
from pcnet.stages.core.geometric import geometric_rotation
from pcnet.stages.kinematics import (
    PERIODIC_ANGLES,
    angle_rates,
    butterworth_lowpass,
    compute_kinematics,
    FrameGatherer,
    count_flags,
    derivatives,
    flag_counts,
    format_flag_counts,
    joint_angles,
    kinematics_chunks,
    lowpass_rotations,
    residual_analysis,
    settle_frames,
)
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.rotations import axis_rotation
from pcnet.stages.scale import CHAIN_TO_STATURE, height_chain_length, height_factor, size_normalising_factors

FPS_YOGA = 30.0  # the yoga exports state no rate; 30 fps assumed (fixtures/README.md)


@pytest.fixture(scope="module")
def yoga_cam() -> np.ndarray:
    """Real VideoPose3D poses, camera frame, metres, (1234, 17, 3)."""
    return np.load(FIXTURES / "yoga_vp3d_Bhumi_Tadasana.npy")


@pytest.fixture(scope="module")
def yoga_level(yoga_cam) -> np.ndarray:
    """Canonical poses assuming a level camera (up = camera -y): gravity is not taken
    from the trunk, so trunk angles are not zero by construction."""
    R, valid = canonical_rotation(yoga_cam, np.array([0.0, -1.0, 0.0]))
    assert valid.all()
    return to_canonical(yoga_cam, R)


# --- a constructed skeleton -----------------------------------------------------------

# Human3.6M reference skeleton (Martinez et al. 2017, forward_kinematics.py offsets, mm),
# standing, arms hanging, in the canonical frame (X anterior, Y up, Z right), metres.
_H36M_REF_MM = {
    "right_hip": (0, 0, 132.95), "right_knee": (0, -442.89, 0), "right_ankle": (0, -454.21, 0),
    "left_hip": (0, 0, -132.95), "left_knee": (0, -442.89, 0), "left_ankle": (0, -454.21, 0),
    "spine": (0, 233.48, 0), "thorax": (0, 257.08, 0), "neck_nose": (0, 121.13, 0),
    "head": (0, 115.00, 0), "left_shoulder": (0, 0, -151.03), "left_elbow": (0, -278.88, 0),
    "left_wrist": (0, -251.73, 0), "right_shoulder": (0, 0, 151.03),
    "right_elbow": (0, -278.88, 0), "right_wrist": (0, -251.73, 0),
}


def standing_pose() -> np.ndarray:
    X = np.zeros((17, 3))
    for j, name in enumerate(H36M_JOINTS):
        if j:
            X[j] = X[H36M_PARENTS[j]] + np.array(_H36M_REF_MM[name]) / 1000.0
    return X


def descendants(j: int) -> list[int]:
    out = [j]
    for c, p in enumerate(H36M_PARENTS):
        if p in out and c not in out:
            out.append(c)
    return out


def rotate_chain(X: np.ndarray, pivot: int, first: int, axis: str, deg: float) -> np.ndarray:
    """Rotate joint ``first`` and everything below it about joint ``pivot``."""
    X = X.copy()
    R = axis_rotation(axis, np.radians(deg))
    idx = descendants(first)
    X[idx] = (X[idx] - X[pivot]) @ R.T + X[pivot]
    return X


# --- scale ---------------------------------------------------------------------------


def test_scale_ratio_reproduces_h36m_reference_stature():
    # The H36M reference skeleton in millimetres: its chain is 1623.8 mm, so its stature
    # is 1623.8 / 0.961 mm, and scaling to that height must map 1 mm to 0.001 m.
    X = standing_pose()[None] * 1000.0
    chain = height_chain_length(X)[0]
    assert chain == pytest.approx(1623.79, abs=0.01)
    stature_m = chain / CHAIN_TO_STATURE / 1000.0
    assert height_factor(X, stature_m) == pytest.approx(1e-3, rel=1e-9)


def test_scale_uses_bone_lengths_so_any_pose_scales_alike(yoga_cam):
    X = yoga_cam[:300].astype(np.float64)
    # Fake a non-metric lifter: an arbitrary unit and a rotated, crouched copy.
    unit = 0.37
    crouched = np.stack([rotate_chain(p, R_KNEE, R_ANKLE, "z", -80.0) for p in X])
    lying = crouched @ axis_rotation("x", np.radians(90.0)).T
    f_ref = height_factor(X, 1.70)
    f_unit = height_factor(X * unit, 1.70)
    f_lying = height_factor(lying, 1.70)
    assert f_unit == pytest.approx(f_ref / unit, rel=1e-6)
    assert f_lying == pytest.approx(f_ref, rel=1e-6)


def test_scale_real_metric_output_is_plausible_and_nan_safe(yoga_cam):
    X = yoga_cam.copy()
    X[10:50] = np.nan  # missing frames
    X[60:70, L_KNEE] = np.nan  # one leg missing: the other leg is used
    factor = height_factor(X, 1.70)
    # VideoPose3D is already metric: the factor stays near 1 for an adult.
    assert 0.8 < factor < 1.3
    assert np.isfinite(height_chain_length(X)[60:70]).all()


def test_scale_errors(yoga_cam):
    with pytest.raises(ValueError, match="height_m"):
        height_factor(yoga_cam, 0.0)
    with pytest.raises(ValueError, match="height_m"):
        height_factor(yoga_cam, -1.7)
    with pytest.raises(ValueError, match="clip.npy: --height: no frame"):
        height_factor(np.full((5, 17, 3), np.nan), 1.7, who="clip.npy: --height")


def test_image_scaled_sizes_are_made_constant_per_frame(yoga_cam):
    """A real body seen growing 3-fold (a walk towards the camera in a lifter's image units)
    gets its median size back in every frame, through missing frames; a body whose size does
    not change keeps factors of 1."""
    X = yoga_cam[:300].astype(np.float64)
    grown = X * np.linspace(1.0, 3.0, len(X))[:, None, None]
    grown[100:120] = np.nan
    f = size_normalising_factors(grown, 30.0)
    chain = height_chain_length(grown * f[:, None, None])
    ok = np.isfinite(chain)
    assert f.shape == (300,) and np.isfinite(f).all() and not ok[100:120].any()
    assert np.percentile(chain[ok], 95) / np.percentile(chain[ok], 5) < 1.1  # 2.7 before
    np.testing.assert_allclose(np.median(chain[ok]), np.median(height_chain_length(grown)[ok]), rtol=0.05)
    steady = size_normalising_factors(X, 30.0)
    assert np.abs(steady - 1).max() < 0.1
    with pytest.raises(ValueError, match="no frame"):
        size_normalising_factors(np.full((5, 17, 3), np.nan), 30.0)


# --- Butterworth ---------------------------------------------------------------------


def test_butterworth_keeps_low_removes_high_and_is_minus_3db_at_cutoff():
    fps, n = 100.0, 3000
    t = np.arange(n) / fps
    low, high = np.sin(2 * np.pi * 1.0 * t), 0.5 * np.sin(2 * np.pi * 20.0 * t)
    y = butterworth_lowpass(low + high, fps, cutoff_hz=6.0)
    core = slice(200, -200)
    assert np.max(np.abs(y[core] - low[core])) < 0.01
    at_cut = butterworth_lowpass(np.sin(2 * np.pi * 6.0 * t), fps, cutoff_hz=6.0)
    # "4th order" = 2nd order per pass, cutoff corrected so the dual pass is -3 dB at 6 Hz.
    assert np.max(np.abs(at_cut[core])) == pytest.approx(1 / np.sqrt(2), abs=0.01)


def test_butterworth_nan_gaps_stay_nan_and_are_not_bridged():
    fps = 100.0
    t = np.arange(600) / fps
    x = np.where(t < 3.0, 0.0, 100.0) + 0.2 * np.sin(2 * np.pi * 25 * t)
    x[295:305] = np.nan  # the step hides inside the gap
    x[450:455] = np.nan
    x[452] = 7.0  # an isolated 1-sample run between NaNs
    y, flagged = butterworth_lowpass(x, fps, 6.0, return_unfiltered=True)
    assert np.isnan(y[295:305]).all() and np.isnan(y[[450, 451, 453, 454]]).all()
    # Filtering across the gap would smear the 0 -> 100 step (tens of units) into both
    # sides; per-run filtering leaves only the 0.2-amplitude edge ripple.
    assert np.max(np.abs(y[200:295])) < 0.25
    assert np.max(np.abs(y[305:400] - 100.0)) < 0.25
    assert np.max(np.abs(y[220:280])) < 0.01
    assert flagged[452] and y[452] == 7.0 and flagged.sum() == 1


def test_butterworth_multichannel_real_data(yoga_level):
    X = yoga_level.astype(np.float64).copy()
    X[100:120, L_WRIST] = np.nan
    Y, flagged = butterworth_lowpass(X, FPS_YOGA, 6.0, return_unfiltered=True)
    assert Y.shape == X.shape and not flagged.any()
    assert np.array_equal(np.isnan(Y), np.isnan(X))
    # Real estimator jitter is mostly above 6 Hz: the frame-to-frame jerk drops.
    jitter = lambda a: np.nanmedian(np.abs(np.diff(a, 2, axis=0)))  # noqa: E731
    assert jitter(Y) < 0.5 * jitter(X)


def test_butterworth_argument_errors():
    x = np.zeros(100)
    with pytest.raises(ValueError, match="Nyquist"):
        butterworth_lowpass(x, 30.0, cutoff_hz=15.0)
    with pytest.raises(ValueError, match="even"):
        butterworth_lowpass(x, 30.0, cutoff_hz=6.0, order=3)


# --- derivatives ---------------------------------------------------------------------


def test_derivatives_of_known_trajectories():
    fps = 50.0
    t = np.arange(200) / fps
    quad = np.stack([1 + 2 * t - 3 * t**2, 0.5 * t**2], -1)
    v, a = derivatives(quad, fps)
    # Central differences are exact on a quadratic; the two end samples have no
    # central stencil and stay blank.
    assert np.isnan(v[[0, -1]]).all() and np.isnan(a[[0, -1]]).all()
    assert np.allclose(v[1:-1], np.stack([2 - 6 * t, t], -1)[1:-1], atol=1e-9)
    assert np.allclose(a[1:-1], [-6.0, 1.0], atol=1e-6)
    # The older one-sided ends, kept behind edges="one-sided", are exact there too.
    v1, a1 = derivatives(quad, fps, edges="one-sided")
    assert np.allclose(v1, np.stack([2 - 6 * t, t], -1), atol=1e-9)
    assert np.allclose(a1, np.broadcast_to([-6.0, 1.0], a1.shape), atol=1e-6)
    with pytest.raises(ValueError, match="edges"):
        derivatives(quad, fps, edges="forward")  # type: ignore[arg-type]
    fps = 1000.0
    t = np.arange(2000) / fps
    v, a = derivatives(np.sin(2 * np.pi * t), fps)
    w = 2 * np.pi
    assert np.max(np.abs(v[1:-1] - w * np.cos(w * t[1:-1]))) < 1e-3 * w
    assert np.max(np.abs(a[1:-1] + w**2 * np.sin(w * t[1:-1]))) < 1e-3 * w**2


def test_derivatives_respect_gaps():
    x = np.arange(20, dtype=float) ** 2
    x[5] = np.nan
    x[7] = np.nan  # finite runs: [0, 5), [6, 7) (one sample), [8, 20)
    v, a = derivatives(x, 1.0)
    # Missing samples, the lone sample and every run's first and last sample: no
    # central stencil, so no derivative (a one-sided value would bridge nothing but
    # would be a different, noisier estimator).
    blank = [0, 4, 5, 6, 7, 8, 19]
    assert np.isnan(v[blank]).all() and np.isnan(a[blank]).all()
    inner = np.setdiff1d(np.arange(20), blank)
    assert np.isfinite(v[inner]).all() and np.isfinite(a[inner]).all()
    # Inside runs the quadratic is differentiated exactly: no value leaks across a gap.
    assert np.allclose(v[inner], 2 * inner) and np.allclose(a[inner], 2.0)
    v, a = derivatives(np.array([0.0, 1.0, np.nan]), 1.0)
    assert np.isnan(v).all() and np.isnan(a).all()
    # edges="one-sided": runs of two get a forward difference, end accelerations copy
    # their neighbour.
    v, a = derivatives(x, 1.0, edges="one-sided")
    assert np.isnan(v[[5, 6, 7]]).all() and np.isnan(a[[5, 6, 7]]).all()
    assert np.allclose(v[8:], 2 * np.arange(8, 20)) and np.allclose(a[8:], 2.0)
    v, a = derivatives(np.array([0.0, 1.0, np.nan]), 1.0, edges="one-sided")
    assert np.allclose(v[:2], 1.0) and np.isnan(a).all()


# --- joint angles --------------------------------------------------------------------


def test_angles_zero_when_standing_with_arms_down():
    ang = joint_angles(standing_pose())
    for name, value in ang.items():
        assert abs(value[0]) < 1e-4, name


@pytest.mark.parametrize("side", ["left", "right"])
def test_angle_signs_on_constructed_limbs(side):
    s = 1.0 if side == "right" else -1.0  # +Z is the subject's right
    hip, knee, ankle = (R_HIP, R_KNEE, R_ANKLE) if side == "right" else (4, L_KNEE, L_ANKLE)
    sho, elb, wri = (R_SHOULDER, R_ELBOW, R_WRIST) if side == "right" else (L_SHOULDER, L_ELBOW, L_WRIST)
    other = "left" if side == "right" else "right"
    X0 = standing_pose()

    flexed = rotate_chain(X0, hip, knee, "z", 30.0)  # about +Z: knee moves anterior (+X)
    a = joint_angles(flexed)
    assert a[f"{side}_thigh_sagittal_inclination"][0] == pytest.approx(30.0, abs=1e-4)
    assert a[f"{other}_thigh_sagittal_inclination"][0] == pytest.approx(0.0, abs=1e-4)
    assert a[f"{side}_knee_flexion_unsigned"][0] == pytest.approx(0.0, abs=1e-4)

    # Knee moved away from the midline: towards +Z on the right, -Z on the left.
    abducted = rotate_chain(X0, hip, knee, "x", -s * 20.0)
    assert np.sign(abducted[knee, 2] - X0[knee, 2]) == s
    assert joint_angles(abducted)[f"{side}_thigh_frontal_inclination"][0] == pytest.approx(20.0, abs=1e-4)
    adducted = rotate_chain(X0, hip, knee, "x", s * 15.0)
    assert joint_angles(adducted)[f"{side}_thigh_frontal_inclination"][0] == pytest.approx(-15.0, abs=1e-4)

    bent = rotate_chain(X0, knee, ankle, "z", -60.0)  # foot goes back
    a = joint_angles(bent)
    assert a[f"{side}_knee_flexion_unsigned"][0] == pytest.approx(60.0, abs=1e-4)
    assert a[f"{side}_thigh_sagittal_inclination"][0] == pytest.approx(0.0, abs=1e-4)

    arm_fwd = rotate_chain(X0, sho, elb, "z", 90.0)
    a = joint_angles(arm_fwd)
    assert a[f"{side}_upper_arm_sagittal_inclination"][0] == pytest.approx(90.0, abs=1e-4)
    # A horizontal forward arm has no frontal-plane angle.
    assert np.isnan(a[f"{side}_upper_arm_frontal_inclination"][0])
    overhead = rotate_chain(X0, sho, elb, "x", -s * 200.0)  # abducted past overhead
    assert joint_angles(overhead)[f"{side}_upper_arm_frontal_inclination"][0] == pytest.approx(200.0, abs=1e-4)
    elbow = rotate_chain(X0, elb, wri, "z", 90.0)
    assert joint_angles(elbow)[f"{side}_elbow_flexion_unsigned"][0] == pytest.approx(90.0, abs=1e-4)


def test_trunk_angles_on_constructed_lean():
    X0 = standing_pose()
    fwd = rotate_chain(X0, PELVIS, 7, "z", -20.0)  # about -Z: thorax moves anterior (+X)
    assert fwd[8, 0] > 0
    a = joint_angles(fwd)
    assert a["trunk_inclination"][0] == pytest.approx(20.0, abs=1e-4)
    assert a["trunk_sagittal_inclination"][0] == pytest.approx(20.0, abs=1e-4)
    assert a["trunk_frontal_inclination"][0] == pytest.approx(0.0, abs=1e-4)
    right = rotate_chain(X0, PELVIS, 7, "x", 15.0)  # thorax towards +Z (subject's right)
    assert right[8, 2] > 0
    a = joint_angles(right)
    assert a["trunk_frontal_inclination"][0] == pytest.approx(15.0, abs=1e-4)
    assert a["trunk_inclination"][0] == pytest.approx(15.0, abs=1e-4)


def test_angles_survive_camera_rotation_and_rectification():
    # A right hip flexed 40 deg and a left shoulder abducted 70 deg, seen by a camera at
    # yaw 35, pitch 10: geometric rectification recovers the canonical angles, while the
    # same maths on raw camera coordinates does not.
    X = rotate_chain(standing_pose(), R_HIP, R_KNEE, "z", 40.0)
    X = rotate_chain(X, L_SHOULDER, L_ELBOW, "x", 70.0)
    R = R_FRONTAL @ axis_rotation("y", np.radians(35.0)) @ axis_rotation("z", np.radians(10.0))
    cam = (X @ R.T)[None] + np.array([0.1, -0.2, 3.0])
    R_hat, valid = geometric_rotation(cam)
    a = joint_angles(to_canonical(cam, R_hat))
    assert valid.all()
    assert a["right_thigh_sagittal_inclination"][0] == pytest.approx(40.0, abs=1e-4)
    assert a["left_upper_arm_frontal_inclination"][0] == pytest.approx(70.0, abs=1e-4)
    with pytest.raises(ValueError, match="expected Y-up poses"):
        joint_angles(cam - cam[:, :1])  # the camera frame is refused, since read as it is ...
    raw = joint_angles(cam - cam[:, :1], check_up=False)
    assert abs(raw["right_thigh_sagittal_inclination"][0] - 40.0) > 10.0  # ... its angles are wrong


def test_angles_on_real_standing_sequence(yoga_level):
    a = joint_angles(yoga_level)
    med = {k: float(np.nanmedian(v)) for k, v in a.items()}
    assert med["trunk_inclination"] < 10.0
    assert med["left_knee_flexion_unsigned"] < 30.0 and med["right_knee_flexion_unsigned"] < 30.0
    # Tadasana with feet together: both thighs converge (adduction, negative) and the
    # raised arms abduct both shoulders near 170 deg: mirrored signs agree left/right.
    assert med["left_thigh_frontal_inclination"] < 0 and med["right_thigh_frontal_inclination"] < 0
    assert med["left_upper_arm_frontal_inclination"] > 150 and med["right_upper_arm_frontal_inclination"] > 150


def test_angles_on_full_real_file_when_available():
    X = np.load(shared("real", "yoga_videopose3d", "export_Abhay_Tadasana.npy"))
    R, valid = geometric_rotation(X)
    k = compute_kinematics(to_canonical(X, R), FPS_YOGA, 6.0, "m")
    assert valid.all() and k.positions.shape == X.shape
    assert np.nanmedian(k.angles["trunk_inclination"]) < 10.0
    assert np.nanpercentile(k.angles["left_knee_flexion_unsigned"], 5) < 30.0


# --- compute_kinematics --------------------------------------------------------------


def test_compute_kinematics_bundle(yoga_level):
    k = compute_kinematics(yoga_level, FPS_YOGA, 6.0, "m")
    T = len(yoga_level)
    assert k.positions.shape == k.velocity.shape == k.acceleration.shape == (T, 17, 3)
    assert (k.units, k.velocity_units, k.acceleration_units) == ("m", "m/s", "m/s^2")
    assert np.allclose(k.speed, np.linalg.norm(k.velocity, axis=-1), equal_nan=True)
    knee = joint_angles(k.positions)["left_knee_flexion_unsigned"]
    assert np.allclose(k.angles["left_knee_flexion_unsigned"], knee, equal_nan=True)
    v, _ = derivatives(k.positions, FPS_YOGA)
    assert np.allclose(k.velocity, v, equal_nan=True)
    # A gap-free recording: only the first and last frame lack derivatives, nothing is
    # flagged.
    assert np.isnan(k.acceleration[[0, -1]]).all() and np.isfinite(k.acceleration[1:-1]).all()
    assert k.missing.shape == k.unfiltered.shape == (T, 17) and k.missing.dtype == bool
    assert not k.missing.any() and not k.unfiltered.any()
    with pytest.raises(dataclasses.FrozenInstanceError):
        k.fps = 60.0  # type: ignore[misc]
    raw = compute_kinematics(yoga_level, FPS_YOGA, None, "normalised")
    assert raw.velocity_units == "normalised/s" and np.allclose(raw.positions, yoga_level)


# --- missing / unfiltered flags ------------------------------------------------------


def _wrist_acc_norm(k) -> np.ndarray:
    return np.linalg.norm(k.acceleration[:, R_WRIST], axis=-1)


def read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def test_wrist_masked_in_one_frame_is_flagged_in_the_csv(tmp_path, yoga_level):
    """The demo's case on real data: the right wrist masked in frame 4 leaves a 4-frame
    run [0, 4) too short for the filter. Frame 4 is flagged missing, frames 0-3
    unfiltered with their raw positions and no derivatives, frame 5 (first after the
    gap) has no central stencil, frame 6 on is differentiated as usual."""
    X = yoga_level.astype(np.float64).copy()
    X[4, R_WRIST] = np.nan
    k = compute_kinematics(X, FPS_YOGA, 6.0, "m")
    T = len(X)
    assert np.flatnonzero(k.missing[:, R_WRIST]).tolist() == [4]
    assert np.flatnonzero(k.unfiltered[:, R_WRIST]).tolist() == [0, 1, 2, 3]
    assert k.missing.sum() == 1 and k.unfiltered.sum() == 4  # no other joint touched
    assert np.array_equal(k.positions[:4, R_WRIST], X[:4, R_WRIST])  # raw, not dropped
    assert np.isnan(k.velocity[:6, R_WRIST]).all() and np.isnan(k.acceleration[:6, R_WRIST]).all()
    assert np.isfinite(k.acceleration[6:-1, R_WRIST]).all()
    assert np.isfinite(k.acceleration[1:-1, R_ELBOW]).all()  # other joints keep theirs

    path = write_kinematics_csv(tmp_path / "k.csv", np.arange(T), np.arange(T) / FPS_YOGA, k,
                                extra_columns={"valid": np.ones(T, int)})
    header, body = read_csv(path)
    col = lambda name: [r[header.index(name)] for r in body]  # noqa: E731
    missing, unfiltered = col("right_wrist_missing"), col("right_wrist_unfiltered")
    assert missing[4] == "1" and missing.count("1") == 1 and set(missing) == {"0", "1"}
    assert unfiltered[:4] == ["1"] * 4 and unfiltered.count("1") == 4
    assert col("right_wrist_x_m")[4] == "" and col("right_wrist_x_m")[0] != ""
    assert col("right_wrist_ax_m_per_s2")[:6] == [""] * 6 and col("right_wrist_ax_m_per_s2")[6] != ""
    assert col("valid")[4] == "1"  # the frame is valid: only the flags say the wrist is not
    for j in H36M_JOINTS:
        if j != "right_wrist":
            assert set(col(f"{j}_missing")) == {"0"} and set(col(f"{j}_unfiltered")) == {"0"}, j

    counts = flag_counts(k)
    assert counts["missing"] == {"right_wrist": 1} and counts["unfiltered"] == {"right_wrist": 4}
    assert (counts["missing_total"], counts["unfiltered_total"]) == (1, 4)
    assert (counts["frames_with_missing"], counts["frames_with_unfiltered"]) == (1, 4)
    assert counts["frames_without_pose"] == 0 and counts["frames"] == T
    assert format_flag_counts(k) == format_flag_counts(counts) == (
        "missing: right_wrist 1 of 1234 frames; unfiltered: right_wrist 4 of 1234 frames "
        "(runs shorter than the filter needs; no velocity/acceleration there)")


def test_no_acceleration_spike_at_gap_edges(yoga_level):
    """A short run of raw samples between two masked frames, placed over the noisiest
    stretch of the real wrist track (raw second differences up to about 100 m/s^2 near
    frame 1160), and single masked frames all along the recording: no acceleration
    within 3 frames of a gap exceeds the unmasked recording's maximum. Differentiating
    the raw run (the previous behaviour) does."""
    X = yoga_level.astype(np.float64)
    ceiling = np.nanmax(_wrist_acc_norm(compute_kinematics(X, FPS_YOGA, 6.0, "m")))
    assert 20.0 < ceiling < 60.0

    Y = X.copy()
    Y[[1155, 1164], R_WRIST] = np.nan  # run [1156, 1164): 8 frames, too short to filter
    k = compute_kinematics(Y, FPS_YOGA, 6.0, "m")
    assert np.flatnonzero(k.unfiltered[:, R_WRIST]).tolist() == list(range(1156, 1164))
    near = slice(1150, 1171)
    assert np.nanmax(_wrist_acc_norm(k)[near]) <= ceiling
    assert np.isnan(_wrist_acc_norm(k)[1154:1166]).all()
    # The old path (raw samples differentiated, one-sided ends): a spike well above it.
    _, old = derivatives(butterworth_lowpass(Y, FPS_YOGA, 6.0), FPS_YOGA, edges="one-sided")
    assert np.nanmax(np.linalg.norm(old[near, R_WRIST], axis=-1)) > 1.5 * ceiling

    worst = 0.0
    for t in range(12, len(X) - 12, 11):  # filtered runs on both sides of the gap
        Y = X.copy()
        Y[t, R_WRIST] = np.nan
        a = _wrist_acc_norm(compute_kinematics(Y, FPS_YOGA, 6.0, "m"))
        assert np.isnan(a[t - 1 : t + 2]).all(), t
        worst = max(worst, float(np.nanmax(a[t - 3 : t + 4])))
    assert worst <= ceiling


def test_flag_counts_frames_without_pose_and_nothing_flagged(yoga_level):
    X = yoga_level[:300].astype(np.float64).copy()
    assert format_flag_counts(compute_kinematics(X, FPS_YOGA, 6.0, "m")) == ""
    X[40:43] = np.nan  # frames without any pose
    X[100, L_WRIST] = np.nan
    X[200:203, L_ANKLE] = np.nan
    k = compute_kinematics(X, FPS_YOGA, 6.0, "m")
    c = flag_counts(k)
    assert c["missing"]["left_wrist"] == 4 and c["missing"]["pelvis"] == 3 and len(c["missing"]) == 17
    assert c["missing_with_pose"] == {"left_ankle": 3, "left_wrist": 1}
    assert c["frames_without_pose"] == 3 and c["frames_with_missing"] == 7
    assert c["missing_total"] == 17 * 3 + 1 + 3 and c["unfiltered_total"] == 0
    assert format_flag_counts(c) == "missing: left_ankle 3 of 300 frames, left_wrist 1 of 300 frames; no joint at all: 3 frames"
    import json

    assert json.loads(json.dumps(c)) == c  # plain types: fits a JSON report
    # Filtering switched off: nothing is "left unfiltered"; derivatives still central only.
    raw = compute_kinematics(X, FPS_YOGA, None, "m")
    assert not raw.unfiltered.any() and np.array_equal(raw.missing, k.missing)
    assert np.isnan(raw.acceleration[[39, 43], 0]).all() and np.isfinite(raw.acceleration[44, 1]).all()


# --- exports -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def kin(yoga_level):
    return compute_kinematics(yoga_level[:200], FPS_YOGA, 6.0, "m")


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_npz_roundtrip_without_pickle(tmp_path, kin):
    path = write_npz(tmp_path / "run.npz", canonical=kin.positions, fps=30.0, units="m",
                     meta={"source": "yoga", "height_m": 1.7}, missing=kin.missing,
                     unfiltered=kin.unfiltered, flag_counts=flag_counts(kin))
    with np.load(path, allow_pickle=False) as f:
        assert np.array_equal(f["canonical"], kin.positions)
        assert f["missing"].dtype == bool and f["unfiltered"].shape == (kin.num_frames, 17)
        assert np.array_equal(f["missing"], kin.missing)
        assert float(f["fps"]) == 30.0 and str(f["units"]) == "m"
        import json

        assert json.loads(str(f["meta"])) == {"height_m": 1.7, "source": "yoga"}
    # strict JSON, as any JSON reader takes it: a missing number (the geometric baseline's
    # uncalibrated bound) is null, never NaN
    write_npz(tmp_path / "nan.npz", meta={"bound": np.float64(np.nan), "pitch": [1.0, float("inf")]})
    with np.load(tmp_path / "nan.npz", allow_pickle=False) as f:
        assert json.loads(str(f["meta"]), parse_constant=lambda c: 1 / 0) == {"bound": None, "pitch": [1.0, None]}
    (tmp_path / "nan.npz").unlink()
    with pytest.raises(TypeError, match="pickled"):
        write_npz(tmp_path / "bad.npz", ragged=[np.zeros(2), np.zeros(3)])
    assert leftovers(tmp_path) == ["run.npz"]


def test_csv_rows_headers_units_and_values(tmp_path, kin):
    T = kin.num_frames
    valid = np.ones(T, bool)
    valid[5] = False
    path = write_kinematics_csv(tmp_path / "k.csv", np.arange(T) + 100, np.arange(T) / FPS_YOGA, kin,
                                {"valid": valid, "tilt_deg": np.full(T, np.nan)})
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    header, body = rows[0], rows[1:]
    assert len(body) == T
    for col in ("frame", "time_s", "right_wrist_x_m", "right_wrist_vx_m_per_s",
                "right_wrist_az_m_per_s2", "right_wrist_speed_m_per_s", "trunk_inclination_deg",
                "left_knee_flexion_unsigned_deg", "valid", "tilt_deg"):
        assert col in header, col
    assert len(header) == 2 + 17 * 12 + 2 * len(kin.angles) + 2
    assert header[-2 - len(kin.angles):-2] == [f"{name}_deg_per_s" for name in kin.angles]
    # each rate is the central difference of its angle column as written (7 digits)
    knee, rate = (np.array([float(r[header.index(n)]) if r[header.index(n)] else np.nan for r in body])
                  for n in ("left_knee_flexion_deg", "left_knee_flexion_deg_per_s"))
    np.testing.assert_allclose(rate[1:-1], (knee[2:] - knee[:-2]) * FPS_YOGA / 2, atol=1e-3 * FPS_YOGA)
    assert np.isnan(rate[[0, -1]]).all() and np.isfinite(rate[1:-1]).all() and np.nanmax(np.abs(rate)) > 10.0
    assert header[header.index("right_wrist_speed_m_per_s") + 1 :][:2] == [
        "right_wrist_missing", "right_wrist_unfiltered"]
    c = header.index("right_wrist_vx_m_per_s")
    got = np.array([float(r[c]) if r[c] else np.nan for r in body])
    assert np.allclose(got, kin.velocity[:, R_WRIST, 0], rtol=1e-6, atol=1e-9, equal_nan=True)
    assert body[0][c] == "" and body[1][c] != ""  # the first frame has no central difference
    assert body[0][0] == "100" and body[5][header.index("valid")] == "0"
    assert all(r[header.index("tilt_deg")] == "" for r in body)  # NaN -> empty field


def test_angle_rates_read_a_turn_as_no_motion_and_leave_raw_and_empty_frames_empty(kin):
    """A periodic angle whose run continuous_angles split at a lifter's jump may hold pieces a
    turn apart: the rate there is the motion's, not 360 deg per two frames. A raw (unfiltered)
    joint position empties the rates of the angles it reaches, in its frame and the two
    beside it, and no other angle's (a user trial lost every knee rate to a raw wrist). A
    frame whose angle is empty has no rate, though both neighbours have an angle (a trial read
    534 deg/s at a frame without a pose, between two people of a switched 2D track)."""
    name = "right_shoulder_plane_of_elevation"
    assert name in PERIODIC_ANGLES
    turned = np.asarray(kin.angles[name]).copy()
    turned[100:] += 360.0
    raw = np.asarray(kin.unfiltered).copy()
    raw[50, R_ELBOW] = True
    knee = np.asarray(kin.angles["left_knee_flexion"]).copy()
    knee[150] = np.nan
    rates = angle_rates(dataclasses.replace(kin, angles={**kin.angles, name: turned, "left_knee_flexion": knee},
                                            unfiltered=raw))
    away = np.r_[0:49, 52:len(turned)]
    np.testing.assert_allclose(rates[name][away], kin.angle_rates[name][away], atol=1e-9, equal_nan=True)
    assert np.isnan(rates[name][49:52]).all() and np.isfinite(rates[name][[48, 52]]).all()
    assert np.isfinite(kin.angle_rates[name][49:52]).all()
    np.testing.assert_allclose(rates["right_elbow_flexion"][49:52], np.nan)  # the elbow's own angle
    assert np.isfinite(rates["left_knee_flexion"][49:52]).all()  # a knee does not read the right elbow
    assert np.isnan(rates["left_knee_flexion"][149:152]).all() and np.isfinite(rates["left_knee_flexion"][[148, 152]]).all()


def test_csv_rejects_wrong_lengths(tmp_path, kin):
    with pytest.raises(ValueError, match="valid"):
        write_kinematics_csv(tmp_path / "k.csv", np.arange(kin.num_frames), np.arange(kin.num_frames),
                             kin, {"valid": np.ones(3)})
    assert leftovers(tmp_path) == []


def read_trc(path: Path):
    """A minimal TRC reader following OpenSim 4's TRCFileAdapter/FileAdapter::tokenize:
    every tab ends a token (empty tokens kept), a final empty token is dropped."""

    def tokens(line: str) -> list[str]:
        parts = line.rstrip("\n").split("\t")
        return parts[:-1] if parts and parts[-1] == "" else parts

    lines = path.read_text().split("\n")
    assert tokens(lines[0])[:3] == ["PathFileType", "4", "(X/Y/Z)"]
    meta = dict(zip(tokens(lines[1]), tokens(lines[2])))
    labels = [t for t in tokens(lines[3]) if t]
    xyz = [t for t in tokens(lines[4]) if t]
    assert lines[5] == ""
    n = int(meta["NumMarkers"])
    rows = []
    for line in lines[6:]:
        if not line:
            break
        row = tokens(line)
        assert len(row) == 2 + 3 * n, "OpenSim RowLengthMismatch"
        rows.append([float(v) if v else np.nan for v in row])
    return meta, labels, xyz, np.array(rows)


def test_a_trc_cut_short_is_refused_not_read_as_a_shorter_recording(tmp_path, yoga_level):
    """A bad-input trial cut a run's world.trc in frame 41's row: `pcnet opensim` solved IK on
    41 of its 100 frames, the last one's marker read from a number cut in half, with exit 0.
    The header's NumFrames and the last line's missing line ending tell a file cut short."""
    from pcnet.stages.core.errors import InputError
    from pcnet.stages.opensim_ik import read_trc as read_markers

    path = write_trc(tmp_path / "poses.trc", yoga_level[:50].astype(np.float64), FPS_YOGA)
    assert read_markers(path)[1].shape == (50, 17, 3)
    text = path.read_text()
    cut = text.index("\n", text.index("\n41\t") + 1) - 7  # inside frame 41's last number
    (tmp_path / "cut.trc").write_text(text[:cut])
    with pytest.raises(InputError, match=r"cut\.trc: NumFrames: expected as many frame rows as the header's 50, got "
                                         r"41 \(a file cut short or edited\?\)"):
        read_markers(tmp_path / "cut.trc")
    header = text.splitlines()[2]  # the header made to agree: the missing line ending still tells
    (tmp_path / "cut41.trc").write_text(text[:cut].replace(header, header.replace("\t50\t17\t", "\t41\t17\t", 1)))
    with pytest.raises(InputError, match=r"its last frame row: expected a line ending"):
        read_markers(tmp_path / "cut41.trc")


def test_trc_parses_back_with_missing_markers(tmp_path, yoga_level):
    X = yoga_level[:50].astype(np.float64).copy()
    X[3, R_WRIST] = np.nan  # the last marker: the hardest case for the tokenizer
    X[4, PELVIS] = np.nan
    path = write_trc(tmp_path / "poses.trc", X, FPS_YOGA)
    meta, labels, xyz, data = read_trc(path)
    assert list(meta) == ["DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units",
                          "OrigDataRate", "OrigDataStartFrame", "OrigNumFrames"]
    assert meta["NumFrames"] == "50" and meta["NumMarkers"] == "17" and meta["Units"] == "m"
    assert float(meta["DataRate"]) == FPS_YOGA
    assert labels == ["Frame#", "Time", *H36M_JOINTS]
    assert xyz == [f"{c}{i}" for i in range(1, 18) for c in "XYZ"]
    assert data.shape == (50, 2 + 51)
    assert np.array_equal(data[:, 0], np.arange(1, 51))
    assert np.allclose(data[:, 1], np.arange(50) / FPS_YOGA, atol=1e-6)
    back = data[:, 2:].reshape(50, 17, 3)
    assert np.array_equal(np.isnan(back), np.isnan(X))
    assert np.allclose(back, X, atol=1e-6, equal_nan=True)


def test_camera_frame_poses_are_refused_where_y_up_ones_are_expected(yoga_cam, yoga_level):
    """A developer's trial passed camera-frame (+Y down) poses and read a trunk inclination of
    178 deg; the same poses levelled are taken."""
    with pytest.raises(InputError, match=r"canonical: expected Y-up poses .* \(median inclination 1[5-8]\d deg, "
                                         r"beyond 128\): camera-frame poses \(\+Y down\)\?"):
        compute_kinematics(yoga_cam[:100], 30.0)
    assert compute_kinematics(yoga_level[:100], 30.0).angles
    # a body inverted for most of the recording (a handstand) looks the same: the caller says so
    assert compute_kinematics(yoga_cam[:100], 30.0, check_up=False).angles


def test_poses_without_a_finite_coordinate_are_refused_as_rectify_refuses_them(yoga_level):
    """A developer's trial got a Kinematics of NaN, every frame missing, without a word, where
    rectify refuses the same input; a recording with one finite frame is taken."""
    empty = np.full((50, 17, 3), np.nan, np.float32)
    with pytest.raises(InputError, match=r"^canonical: expected some finite joint coordinates, got only NaN/inf$"):
        compute_kinematics(empty, 30.0)
    empty[20] = yoga_level[20]
    assert compute_kinematics(empty, 30.0).missing[20].sum() == 0


def test_marker_writers_refuse_what_the_pipeline_refuses(tmp_path, yoga_level):
    """A library caller's marker file gets the checks a run's does (a developer's trial: DataRate
    inf, True as 1 Hz, millimetres written as metres, an empty file that looked valid)."""
    X = yoga_level[:10].astype(np.float64)
    for fps, said in ((float("inf"), "write_trc: fps: expected a frame rate in"),
                      (True, "write_trc: fps: expected a frame rate in Hz (a number), got True"),
                      ("30", "write_trc: fps: expected a frame rate in Hz (a number), got '30'")):
        with pytest.raises(InputError, match=re.escape(said)):
            write_trc(tmp_path / "a.trc", X, fps)
    with pytest.raises(InputError, match=r"write_trc: expected markers in 'm', got a median thigh of \d+ m"):
        write_trc(tmp_path / "a.trc", X * 1000.0, 30.0)
    write_trc(tmp_path / "a.trc", X * 1000.0, 30.0, units="mm")
    for empty in (X[:0], np.full_like(X, np.nan)):
        with pytest.raises(InputError, match="write_trc: expected at least one frame with a finite marker"):
            write_trc(tmp_path / "b.trc", empty, 30.0)
    assert not (tmp_path / "b.trc").exists()
    # camera-frame poses (+Y down) are an upside-down skeleton for OpenSim (a notebook trial), as
    # compute_kinematics refuses them; a body inverted throughout is the caller's to declare
    upside_down = X * [1.0, -1.0, -1.0]
    with pytest.raises(InputError, match=r"^write_trc: expected Y-up poses"):
        write_trc(tmp_path / "c.trc", upside_down, 30.0)
    assert not (tmp_path / "c.trc").exists()
    write_trc(tmp_path / "c.trc", upside_down, 30.0, check_up=False)
    pytest.importorskip("ezc3d", reason='ezc3d not installed (pip install "pcnet[c3d]")')
    with pytest.raises(InputError, match=r"^write_c3d: expected Y-up poses"):
        write_c3d(tmp_path / "c.c3d", upside_down, 30.0)


def test_png_is_written(tmp_path, yoga_cam, yoga_level):
    cam, can = yoga_cam[:300], yoga_level[:300]
    _, acam = derivatives(butterworth_lowpass(cam, FPS_YOGA), FPS_YOGA)
    _, acan = derivatives(butterworth_lowpass(can, FPS_YOGA), FPS_YOGA)
    wrists = [L_WRIST, R_WRIST]
    path = plot_wrists(tmp_path / "wrists.png", cam, can, FPS_YOGA, acam[:, wrists], acan[:, wrists])
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    # another person's frames are shaded here too, as in angles.png (a user trial: only the wrists were not)
    from matplotlib.patches import Rectangle

    from pcnet.stages.sinks.exports import wrists_figure
    from pcnet.stages.sinks.plots import OTHER_PERSON_NOTE

    other = np.zeros(300, bool)
    other[100:150] = True
    fig = wrists_figure(cam, can, FPS_YOGA, acam[:, wrists], acan[:, wrists], other_person=other)
    assert OTHER_PERSON_NOTE in fig._suptitle.get_text() and len(fig.axes) == 6
    for ax in fig.axes:
        (span,) = [p for p in ax.patches if isinstance(p, Rectangle)]
        assert round(span.get_x() * FPS_YOGA + 0.5) == 100
    plain = wrists_figure(cam, can, FPS_YOGA, acam[:, wrists], acan[:, wrists])
    assert not any(ax.patches for ax in plain.axes)
    with pytest.raises(ValueError, match="wrists_figure: other_person has shape"):
        plot_wrists(tmp_path / "bad.png", cam, can, FPS_YOGA, acam[:, wrists], acan[:, wrists], other_person=other[:-1])


@pytest.mark.parametrize("writer", ["npz", "csv", "trc", "png"])
def test_writers_are_atomic(tmp_path, monkeypatch, kin, yoga_level, writer):
    """A failure mid-write (a partial temp file exists) leaves neither a partial target
    nor the temp file, and keeps an existing target unchanged."""
    target = tmp_path / f"out.{writer}"
    target.write_text("previous")
    T = kin.num_frames
    seen_partial = []

    def fail() -> None:
        seen_partial.append([p.name for p in tmp_path.iterdir() if p.name.startswith(".out.")])
        raise OSError("disk full (simulated)")

    def after(n_calls: int, orig):
        calls = {"n": 0}

        def wrapped(*args, **kwargs):
            calls["n"] += 1
            if calls["n"] > n_calls:
                fail()
            return orig(*args, **kwargs)

        return wrapped

    if writer == "npz":

        def partial_member(member, array, **kw):  # the archive's first member half written
            member.write(b"\x93NUMPY partial")
            fail()

        monkeypatch.setattr(exports.np.lib.format, "write_array", partial_member)
        call = lambda: write_npz(target, a=np.zeros(3))  # noqa: E731
    elif writer == "csv":  # fails after about 10 rows
        monkeypatch.setattr(exports, "_fmt", after(2000, exports._fmt))
        call = lambda: write_kinematics_csv(target, np.arange(T), np.arange(T) / 30.0, kin)  # noqa: E731
    elif writer == "trc":  # fails after about 40 rows
        monkeypatch.setattr(exports, "_fmt_trc", after(2000, exports._fmt_trc))
        call = lambda: write_trc(target, yoga_level[:100], 30.0)  # noqa: E731
    else:
        orig_write = Path.write_bytes

        def partial_write(self, data):
            orig_write(self, data[: len(data) // 2])
            fail()

        monkeypatch.setattr(Path, "write_bytes", partial_write)
        z = np.zeros((10, 17, 3))
        call = lambda: plot_wrists(target, z, z, 30.0, z[:, :2], z[:, :2])  # noqa: E731
    with pytest.raises(OSError, match="simulated"):
        call()
    assert len(seen_partial) == 1 and len(seen_partial[0]) == 1  # a temp file existed
    assert leftovers(tmp_path) == [target.name]
    assert target.read_text() == "previous"


# --- rerun ---------------------------------------------------------------------------


def _inputs(cam: np.ndarray):
    R, valid = geometric_rotation(cam)
    can = to_canonical(cam, R)
    return R, valid, can


def test_rerun_recording_entities_rows_and_blueprint(tmp_path, yoga_cam):
    from pcnet.stages.sinks.rerun_log import series_from_kinematics, write_recording

    cam = yoga_cam.copy()
    cam[40:45] = np.nan  # missing frames
    R, valid, can = _inputs(cam)
    k = compute_kinematics(can, FPS_YOGA, 6.0, "m")
    series = series_from_kinematics(k)
    kp = np.concatenate([cam[..., :2] * 400 + 300, np.full(cam.shape[:2] + (1,), 0.9)], -1)
    kp[7, L_WRIST, 2] = 0.0  # a zero-confidence keypoint is hidden
    path = write_recording(tmp_path / "run.rrd", fps=FPS_YOGA, joints_cam=cam, canonical=can,
                           rotations=R, up=R[:, :, 1], valid=valid, keypoints2d=kp, series=series)
    assert leftovers(tmp_path) == ["run.rrd"]
    rows, static, chunks, origins = rrd_summary(path)
    T = len(cam)
    for entity in ("/camera/skeleton/joints", "/camera/skeleton/bones", "/canonical/skeleton/joints",
                   "/canonical/skeleton/bones", "/camera/body_axes", "/camera/up",
                   "/video/keypoints", "/video/skeleton", "/series/status/valid"):
        assert rows[entity] == T, entity
    for name, values in series.items():
        assert rows["/series/" + name] == np.isfinite(values).sum(), name
    assert {"/camera", "/canonical", "/camera/wrist_paths/right_wrist",
            "/canonical/wrist_paths/left_wrist", "/"} <= static
    assert {"camera", "canonical", "video", "series/angles_deg/hip", "series/angles_deg/knee", "series/position_m"} <= origins
    # Per-frame partitions: frame 40 (NaN) has no joints, frame 7 has 16 2D keypoints.
    rb = chunks["/canonical/skeleton/joints"][0].to_record_batch()
    frames = rb.column("frame").to_pylist()
    pos = rb.column("Points3D:positions").to_pylist()
    by_frame = dict(zip(frames, pos))
    assert len(by_frame[40]) == 0 and len(by_frame[0]) == 17
    assert np.allclose(np.array(by_frame[0]), can[0], atol=1e-6)
    rb2 = chunks["/video/keypoints"][0].to_record_batch()
    kp_by_frame = dict(zip(rb2.column("frame").to_pylist(), rb2.column("Points2D:positions").to_pylist()))
    assert len(kp_by_frame[7]) == 16


def test_rerun_video_lines_up_with_frames(tmp_path):
    """The bundled boxing2.mp4 stores 360 frames and an MP4 edit list that starts playback at
    stored frame 59: FFmpeg, OpenCV and the 2D detector saw the 301 frames from there, while
    rerun's frame table lists the stored ones. Pose frame t must show stored frame t + 59."""
    import rerun as rr

    from pcnet.adapters import first_shown_frame, iter_frames
    from pcnet.stages.sinks.rerun_log import write_recording

    example = Path(__file__).resolve().parent.parent / "pipeline" / "example_data"
    video = example / "boxing2.mp4"
    X = np.load(example / "X3D.npy")  # (301, 17, 3) normalised
    X = X - X[:, :1]
    ts = rr.AssetVideo(path=video).read_frame_timestamps_nanos()
    played = sum(1 for _ in iter_frames(video))
    assert (len(ts), played, len(X)) == (360, 301, 301)
    first = first_shown_frame(video)
    assert first == len(ts) - played == 59  # the edit list cuts the start only
    assert first_shown_frame(FIXTURES / "boxing2_f000-009.mp4") == 0  # re-encoded without an edit list
    R, valid, can = _inputs(X)
    path = write_recording(tmp_path / "box.rrd", fps=30.0, joints_cam=X, canonical=can, rotations=R,
                           up=R[:, :, 1], valid=valid, keypoints2d=None, video_path=video, video_first_frame=first,
                           series={"trunk": joint_angles(can)["trunk_inclination"]})
    rows, static, chunks, origins = rrd_summary(path)
    assert "/video" in static and rows["/video"] == len(X) and rows["/camera/skeleton/joints"] == len(X)
    assert "video" in origins
    rb = chunks["/camera/skeleton/joints"][0].to_record_batch()
    vt = rb.column("video_time").cast("int64").to_numpy()
    assert np.array_equal(vt, ts[first : first + len(X)])


def test_rerun_write_is_atomic(tmp_path, monkeypatch, yoga_cam):
    import rerun as rr

    from pcnet.stages.sinks.rerun_log import write_recording

    cam = yoga_cam[:50]
    R, valid, can = _inputs(cam)
    orig = rr.RecordingStream.send_columns
    calls = {"n": 0}

    def boom(self, *a, **k):
        calls["n"] += 1
        if calls["n"] == 4:
            raise RuntimeError("simulated failure mid-recording")
        return orig(self, *a, **k)

    monkeypatch.setattr(rr.RecordingStream, "send_columns", boom)
    with pytest.raises(RuntimeError, match="simulated"):
        write_recording(tmp_path / "x.rrd", fps=30.0, joints_cam=cam, canonical=can, rotations=R,
                        up=R[:, :, 1], valid=valid)
    assert leftovers(tmp_path) == []


def test_rerun_36000_frames_is_fast(tmp_path, yoga_cam):
    """Columnar logging: a 20-minute sequence (36,000 frames at 30 fps, the real
    sequence tiled) must write in seconds. A per-frame rr.log loop takes minutes."""
    from pcnet.stages.sinks.rerun_log import series_from_kinematics, write_recording

    reps = int(np.ceil(36000 / len(yoga_cam)))
    cam = np.tile(yoga_cam, (reps, 1, 1))[:36000]
    R, valid, can = _inputs(cam)
    k = compute_kinematics(can, FPS_YOGA, 6.0, "m")
    series = series_from_kinematics(k)
    kp = np.concatenate([cam[..., :2] * 400 + 300, np.ones(cam.shape[:2] + (1,))], -1)
    t0 = time.perf_counter()
    path = write_recording(tmp_path / "long.rrd", fps=FPS_YOGA, joints_cam=cam, canonical=can,
                           rotations=R, up=R[:, :, 1], valid=valid, keypoints2d=kp, series=series)
    elapsed = time.perf_counter() - t0
    assert path.stat().st_size > 1_000_000
    assert elapsed < 20.0, f"36,000 frames took {elapsed:.1f} s"


def test_c3d_export_round_trips_real_world_frame_markers(tmp_path):
    """`pcnet run --c3d`: the world-frame markers as C3D (ezc3d), read back unchanged with
    their labels, rate and units; a missing marker stays missing."""
    ezc3d = pytest.importorskip("ezc3d", reason='ezc3d not installed (pip install "pcnet[c3d]")')
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    example = Path(__file__).resolve().parent.parent / "pipeline" / "example_data"
    x3d = tmp_path / "X3D_40.npy"
    poses = np.load(example / "X3D.npy")[:40]
    poses[5, 16] = np.nan  # right wrist missing in frame 5
    np.save(x3d, poses)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output", str(x3d), "--fps", "30",
                                    "--height", "1.75", "--out", str(out), "--no-recording", "--c3d"])
    assert res.exit_code == 0, res.output
    c3d = ezc3d.c3d(str(out / "world.c3d"))
    assert list(c3d["parameters"]["POINT"]["LABELS"]["value"]) == list(H36M_JOINTS)
    assert c3d["parameters"]["POINT"]["RATE"]["value"][0] == 30.0
    assert c3d["parameters"]["POINT"]["UNITS"]["value"] == ["m"]
    # viewers told that +Y is up (a Z-up default would show the body lying down)
    assert [c3d["parameters"]["POINT"][k]["value"] for k in ("X_SCREEN", "Y_SCREEN")] == [["+X"], ["+Y"]]
    # what the markers are and who wrote them, for a lab tool (a C3D user found ezc3d's defaults only)
    from pcnet.pipeline.config import pcnet_version

    assert set(c3d["parameters"]["POINT"]["DESCRIPTIONS"]["value"]) == {  # root-relative: no horizontal path
        "H36M-17 joint centre, world frame (x forward at the start, y up, z right; floor y = 0); pelvis held at "
        "x = z = 0, its horizontal path not observed"}
    assert c3d["parameters"]["MANUFACTURER"]["SOFTWARE"]["value"] == ["pcnet"]
    assert c3d["parameters"]["MANUFACTURER"]["VERSION_LABEL"]["value"] == [pcnet_version()]
    with np.load(out / "canonical.npz") as npz:
        world = npz["joints_world"]
    points = np.transpose(c3d["data"]["points"][:3], (2, 1, 0))
    np.testing.assert_allclose(points, world, atol=1e-5)
    assert np.isnan(points[5, 16]).all()
    # C3D's own mark of an invalid sample, for tools that read the residual, not NaN
    residuals = c3d["data"]["meta_points"]["residuals"][0].T  # (frames, markers)
    np.testing.assert_array_equal(residuals < 0, ~np.isfinite(world).all(axis=2))


def test_c3d_without_ezc3d_is_one_line_before_any_work(monkeypatch, tmp_path):
    import sys

    from pcnet.pipeline.config import RunConfig
    from pcnet.pipeline.runner import run_pipeline
    from pcnet.stages.core.errors import InputError

    monkeypatch.setitem(sys.modules, "ezc3d", None)  # import ezc3d -> ImportError
    cfg = RunConfig(lifter="motionbert", lifter_output=str(tmp_path / "never_read.npy"), fps=30,
                    out=str(tmp_path / "out"), c3d=True)
    with pytest.raises(InputError, match=r'C3D export needs ezc3d: pip install "pcnet\[c3d\]"'):
        run_pipeline(cfg, progress=False)
    assert not (tmp_path / "out").exists()


def test_a_lifters_restart_ends_the_filters_stretch_and_no_rate_crosses_it(yoga_level):
    """A trial's MotionBERT cycling clip: the pose jumps where the lifter starts its next
    243-frame clip, and the jump read as a knee extending at 397 deg/s and as implausible motion
    blamed on --fps. With the restart as a break, each side is filtered and differentiated as a
    recording of its own: the chunks equal each stretch's kinematics computed alone, no
    velocity or rate reaches across, and the jump is not measured as motion."""
    from pcnet.stages.plausibility import implausible_motion

    X = yoga_level.astype(np.float64)[:400].copy()
    X[243:] = X[243:] @ axis_rotation("z", np.radians(90.0)).T  # the whole pose tips over at the restart
    parts = list(kinematics_chunks(X, 30.0, 6.0, chunk_frames=97, breaks=(243,)))
    assert [p.num_frames for p in parts] == [97, 97, 49, 97, 60]  # a chunk ends at the break
    gather = FrameGatherer(len(X))
    for part in parts:
        gather.add(part)
    joined = gather.result()
    for (a, b) in ((0, 243), (243, 400)):
        alone = compute_kinematics(X[a:b], 30.0, 6.0)
        for name in ("positions", "velocity", "acceleration", "speed"):
            np.testing.assert_allclose(getattr(alone, name), getattr(joined, name)[a:b], rtol=1e-9, atol=1e-9,
                                       equal_nan=True, err_msg=name)
        for name, rate in alone.angle_rates.items():
            np.testing.assert_allclose(rate, joined.angle_rates[name][a:b], rtol=1e-9, atol=1e-9, equal_nan=True,
                                       err_msg=name)
        for name, angle in alone.angles.items():  # read afresh after the break (an API trial's knee flipped)
            other = joined.angles[name][a:b]
            if name in PERIODIC_ANGLES:  # a run's 360-deg level is chosen in the chunk where it starts
                other = np.where(np.isfinite(other), angle + (other - angle + 180.0) % 360.0 - 180.0, other)
            np.testing.assert_allclose(angle, other, rtol=1e-9, atol=1e-9, equal_nan=True, err_msg=name)
    assert np.isnan(joined.velocity[[242, 243]]).all() and np.isnan(joined.angle_rates["right_knee_flexion"][[242, 243]]).all()
    # the jump alone is implausible motion; as a restart it is not motion
    assert implausible_motion(X, 30.0) and not implausible_motion(X, 30.0, breaks=(243,))


# chunk = 1 (a block per frame, about 14 s) is the slow tier's; 13 and 97 cross the same edges in the fast tier
def wobbling_rotations(T: int, seed: int) -> np.ndarray:
    """``(T, 3, 3)`` canonical -> camera rotations of a camera looking at a Y-up body (y down)
    whose orientation wobbles a few degrees from frame to frame, as frame mode's do."""
    from scipy.spatial.transform import Rotation

    wobble = Rotation.from_rotvec(np.random.default_rng(seed).normal(0.0, np.radians(3.0), (T, 3))).as_matrix()
    return wobble @ np.diag([1.0, -1.0, -1.0])


# chunk = 1 (a block per frame, about 14 s) is the slow tier's; 13 and 97 cross the same edges in the fast tier
@pytest.mark.parametrize("fps, cutoff, chunk, turned", [
    (30.0, 6.0, 97, False), pytest.param(30.0, 6.0, 1, False, marks=pytest.mark.slow), (60.0, 2.0, 250, False),
    (30.0, None, 13, False), (30.0, 6.0, 97, True)])
def test_kinematics_in_chunks_equal_the_whole_recording(yoga_level, fps, cutoff, chunk, turned):
    """kinematics_chunks (bounded memory for long recordings) == compute_kinematics of the
    whole recording: values to ~1e-12 relative, identical NaN, missing and unfiltered flags,
    across gaps that cross chunk edges and runs too short to filter; ``turned``: camera-frame
    poses placed by per-frame rotations (some frames without one), low-passed apart."""
    X = yoga_level.astype(np.float64).copy()
    rng = np.random.default_rng(3)
    X[rng.random(X.shape[:2]) < 0.01] = np.nan
    X[300:340] = np.nan  # a gap
    X[345:350, 13] = np.nan  # leaves a short raw run for the wrist
    R = None
    if turned:
        R = wobbling_rotations(len(X), 4)
        R[[120, 121, 500]] = np.nan  # frames without a rotation
        X = np.einsum("tij,tkj->tki", R, X)  # into the camera frame, X_cam = X R^T
    whole = compute_kinematics(X, fps, cutoff, rotation=R)
    if turned:
        assert whole.missing[[120, 121, 500]].all() and whole.unfiltered.any()
    parts = list(kinematics_chunks(X, fps, cutoff, chunk_frames=chunk, rotation=R))
    assert [p.num_frames for p in parts[:-1]] == [chunk] * (len(parts) - 1)
    gather = FrameGatherer(len(X))
    for part in parts:
        gather.add(part)
    joined = gather.result()
    for name in ("positions", "velocity", "acceleration", "speed"):
        a, b = getattr(whole, name), getattr(joined, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9, equal_nan=True, err_msg=name)
    np.testing.assert_array_equal(whole.missing, joined.missing)
    np.testing.assert_array_equal(whole.unfiltered, joined.unfiltered)
    assert whole.missing.any() and (whole.unfiltered.any() or cutoff is None)
    for name, angle in whole.angles.items():
        other = joined.angles[name]
        if name in PERIODIC_ANGLES:  # a run's 360-deg level is chosen in the chunk where it starts
            other = np.where(np.isfinite(other), angle + (other - angle + 180.0) % 360.0 - 180.0, other)
        np.testing.assert_allclose(angle, other, rtol=1e-9, atol=1e-9, equal_nan=True, err_msg=name)
    assert list(joined.angle_rates) == list(whole.angles)
    for name, rate in whole.angle_rates.items():  # across the chunks' seams too
        np.testing.assert_allclose(rate, joined.angle_rates[name], rtol=1e-9, atol=1e-9, equal_nan=True, err_msg=name)
    assert count_flags(joined.missing, joined.unfiltered) == flag_counts(whole)
    with pytest.raises(RuntimeError, match="more than the"):
        gather.add(parts[0])  # more frames than announced
    short = FrameGatherer(len(X) + 1)
    short.add(parts[0])
    with pytest.raises(RuntimeError, match="frames gathered"):
        short.result()


def test_kinematics_in_chunks_refuse_what_the_whole_recording_refuses(yoga_level, yoga_cam):
    """A developer trial fed kinematics_chunks camera-frame poses (+Y down) and all-NaN poses,
    which compute_kinematics refuses, and got a trunk inclination of 175 deg and an empty
    chunk; an order or chunk size of the wrong type raised a bare TypeError."""
    X = yoga_cam[:200].astype(np.float64)
    with pytest.raises(InputError, match="expected Y-up poses"):
        compute_kinematics(X, 30.0)
    with pytest.raises(InputError, match="poses: expected Y-up poses"):
        next(kinematics_chunks(X, 30.0, chunk_frames=50))
    assert len(list(kinematics_chunks(X, 30.0, chunk_frames=50, check_up=False))) == 4  # an inverted body, said
    with pytest.raises(InputError, match="expected some finite joint coordinates"):
        next(kinematics_chunks(np.full((50, 17, 3), np.nan), 30.0))
    level = yoga_level[:100]
    for bad in (2.5, "50", 0, True):
        with pytest.raises(InputError, match="chunk_frames: expected an integer >= 1"):
            next(kinematics_chunks(level, 30.0, chunk_frames=bad))
    for bad in ("4", 3, 4.0):
        with pytest.raises(InputError, match="order is the order"):
            compute_kinematics(level, 30.0, order=bad)
    # a writer's zeros for every joint are placeholders, as rectify calls them, not a unit
    with pytest.raises(InputError, match="placeholders"):
        compute_kinematics(np.zeros((5, 17, 3)), 30.0)


def test_a_body_lying_on_its_side_keeps_its_heading_free_angles(yoga_cam):
    """A real standing pose laid on its side (hip line vertical): the pelvis-heading frame
    and the plane inclinations are undefined, but the trunk's inclination (about 90 deg) and
    the unsigned knee and elbow flexion, which need no heading, are not."""
    from pcnet.stages.core.canonical import canonical_rotation
    from pcnet.stages.core.conventions import PELVIS

    X = yoga_cam[:200].astype(np.float64) - yoga_cam[:200, PELVIS : PELVIS + 1]
    R, ok = canonical_rotation(X, np.median(X[:, 8] - X[:, 0], axis=0))  # camera -> a Y-up canonical frame
    upright = X @ R
    side = upright @ axis_rotation("x", np.radians(90.0)).T  # about the forward axis: hip line vertical
    k_up = compute_kinematics(upright, 30.0)
    k_side = compute_kinematics(side, 30.0)
    assert np.isnan(k_side.angles["trunk_sagittal_inclination"]).all()
    assert np.nanmedian(k_up.angles["trunk_inclination"]) < 10.0
    assert abs(np.nanmedian(k_side.angles["trunk_inclination"]) - 90.0) < 10.0
    for name in ("left_knee_flexion_unsigned", "right_elbow_flexion_unsigned"):
        np.testing.assert_allclose(k_side.angles[name], k_up.angles[name], atol=1e-9, equal_nan=True)
        assert np.isfinite(k_side.angles[name]).mean() > 0.9


def test_settle_frames_follow_the_filter():
    """Context grows as the filter's poles approach the unit circle (lower cutoff / higher
    rate) and always exceeds the filter's pad length."""
    assert settle_frames(30.0, None) == 2
    assert 10 < settle_frames(30.0, 6.0) < settle_frames(60.0, 6.0) < settle_frames(200.0, 1.0)
    with pytest.raises(InputError):
        settle_frames(30.0, 20.0)


def test_residual_analysis_finds_the_noise_and_lowers_the_cutoff_for_noisier_data():
    """Winter's residual analysis on real mocap (tests/fixtures/mocap_small.npz) with added
    white noise: the fitted noise level is the added noise, and the cutoff falls as the noise
    grows (more of the spectrum is noise)."""
    with np.load(FIXTURES / "mocap_small.npz") as d:
        X = d["dataset-2_walk-turn-left_active_001"].astype(np.float64)
    rng = np.random.default_rng(0)
    cutoffs = []
    for sigma in (0.005, 0.02):
        r = residual_analysis(X + rng.normal(0.0, sigma, X.shape), 30.0)
        assert abs(r.noise - sigma) < 0.15 * sigma
        assert r.per_signal_hz.shape == (51,) and 0.5 <= r.cutoff_hz <= 14.25
        cutoffs.append(r.cutoff_hz)
    assert cutoffs[1] < cutoffs[0] < 6.0
    gappy = X.copy()
    gappy[40:50] = np.nan
    assert np.isfinite(residual_analysis(gappy, 30.0).cutoff_hz)
    with pytest.raises(InputError, match="long enough to filter"):
        residual_analysis(X[:5], 30.0)


def _run_boxing(out: Path, *more: str):
    """`pcnet run` on the real 60-frame boxing fixture (MotionBERT, root-relative, with its
    AlphaPose 2D keypoints: a `track_segment` column), no recording."""
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output",
                                    str(FIXTURES / "boxing_X3D_f000-059.npy"), "--keypoints2d",
                                    str(FIXTURES / "boxing_alphapose_f000-059.json"), "--keypoints2d-format",
                                    "alphapose", "--fps", "30", "--height", "1.75", "--out", str(out),
                                    "--no-recording", *more])
    assert res.exit_code == 0, res.output
    return res


def _dictionary(out: Path) -> tuple[list[str], dict[str, list[str]], list[str], list[list[str]]]:
    """``(dictionary header, column -> row, kinematics.csv header, its rows)``; asserts one
    dictionary row per CSV column and one CSV column per dictionary row."""
    header, body = read_csv(out / "kinematics.csv")
    d_header, d_rows = read_csv(out / "kinematics_columns.csv")
    described = [row[0] for row in d_rows]
    assert described == header  # every column once, in the CSV's order, and nothing else
    assert len(set(described)) == len(described)
    return d_header, {row[0]: row for row in d_rows}, header, body


def test_status_columns_are_empty_where_there_is_nothing_to_say(tmp_path):
    """A frame with no pose has no implausible_motion, a frame whose 2D keypoints lack the
    pelvis or thorax no track_segment: empty cells, never 0 (a user trial's frames with no
    person passed the track-switch warning's own filter as "track_segment 0, implausible_motion 0")."""
    import json

    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    poses = np.load(FIXTURES / "boxing_X3D_f000-059.npy", allow_pickle=False).copy()
    poses[20:23] = np.nan
    np.save(tmp_path / "x3d.npy", poses)
    people = [p for p in json.loads((FIXTURES / "boxing_alphapose_f000-059.json").read_text())
              if p["image_id"] not in ("30.jpg", "31.jpg")]
    (tmp_path / "kp.json").write_text(json.dumps(people))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", "--lifter", "motionbert", "--lifter-output", str(tmp_path / "x3d.npy"),
                                    "--keypoints2d", str(tmp_path / "kp.json"), "--keypoints2d-format", "alphapose",
                                    "--fps", "30", "--height", "1.75", "--out", str(out),
                                    "--no-recording"])
    assert res.exit_code == 0, res.output
    with open(out / "kinematics.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    no_pose = [20, 21, 22, 30, 31]  # a frame without 2D keypoints has no pose either
    assert [i for i, r in enumerate(rows) if r["valid"] == "0"] == no_pose
    assert [i for i, r in enumerate(rows) if r["implausible_motion"] == ""] == no_pose
    assert [i for i, r in enumerate(rows) if r["track_segment"] == ""] == [30, 31]
    assert all(r["implausible_motion"] in ("0", "1") for i, r in enumerate(rows) if i not in no_pose)
    assert all(r["track_segment"].isdigit() for i, r in enumerate(rows) if i not in (30, 31))


def test_kinematics_columns_csv_describes_every_column_of_a_real_run(tmp_path):
    """`kinematics_columns.csv` beside `kinematics.csv`: one row (column, unit, frame,
    definition) per column of the run's CSV, built from the same column list as its header;
    listed in the `.pcnet-output` marker and the summary."""
    import json

    from pcnet.stages.sinks.exports import COLUMN_FRAMES, DICTIONARY_HEADER, UNDESCRIBED_ANGLE

    out = tmp_path / "out"
    res = _run_boxing(out)
    assert f"kinematics_columns.csv {out / 'kinematics_columns.csv'}" in res.output
    assert "kinematics_columns.csv" in json.loads((out / ".pcnet-output").read_text())["files"]
    d_header, rows, header, _ = _dictionary(out)
    assert tuple(d_header) == DICTIONARY_HEADER == ("column", "unit", "frame", "definition")
    assert "track_segment" in rows and "right_hip_flexion_deg" in rows and "trunk_inclination_deg" in rows
    for name, (_, unit, frame, definition) in rows.items():
        assert unit and frame in COLUMN_FRAMES, name
        assert definition.endswith(".") and definition != UNDESCRIBED_ANGLE, (name, definition)
    assert rows["right_wrist_vx_m_per_s"][1:3] == ["m/s", "world"]
    assert rows["right_wrist_az_m_per_s2"][1] == "m/s^2" and rows["right_wrist_missing"][1:3] == ["0/1", "none"]
    assert rows["heading_deg"][1:3] == ["deg", "camera"] and rows["time_s"][1] == "s"
    assert "positive = thigh flexed" in rows["right_hip_flexion_deg"][3]
    # the implausible-motion warning's frames, in the CSV a spreadsheet user reads (a user trial: only the npz had them)
    assert rows["implausible_motion"][1:3] == ["0/1", "none"]
    with open(out / "kinematics.csv", newline="") as f:
        marked = [int(r["implausible_motion"] or 0) for r in csv.DictReader(f)]  # empty: not valid
    with np.load(out / "canonical.npz", allow_pickle=False) as npz:
        assert marked == npz["implausible_frames"].astype(int).tolist()
    assert "empty where the knee bends less than 5 deg" in rows["right_hip_internal_rotation_deg"][3]
    # the angles against gravity say how uncertain their reference is (a four-camera trial read their
    # spread with no uncertainty given); the joint angles between segments do not depend on it
    report = json.loads(np.load(out / "canonical.npz", allow_pickle=False)["report"].item())
    pitch = f"+-{report['camera_pitch_interval_deg']:.1f} deg in the camera's pitch"
    # a clinician's trial: the subject's planes, not the camera's axes, are what the angles are in
    widest = max(report['camera_pitch_interval_deg'], report['camera_roll_interval_deg'])
    planes = f"at most +-{widest:.1f} deg in the subject's sagittal or frontal plane at any heading"
    for name in ("trunk_inclination_deg", "right_thigh_sagittal_inclination_deg", "trunk_flexion_to_gravity_deg"):
        assert pitch in rows[name][3] and planes in rows[name][3], (name, rows[name][3])
    assert "the camera's pitch" not in rows["right_knee_flexion_deg"][3]
    # a periodic angle may read beyond its window (a data-dictionary trial would have dropped a
    # valid 285 deg as impossible); an angle that cannot wrap says nothing of it
    assert "Continuous over time: each run of frames reads in (-180, 180]" in rows["left_shoulder_plane_of_elevation_deg"][3]
    assert "reads in (-90, 270]" in rows["left_upper_arm_frontal_inclination_deg"][3]
    assert "Continuous over time" not in rows["right_knee_flexion_deg"][3]


@pytest.mark.slow
def test_an_unobservable_pelvis_path_is_empty_not_zero(tmp_path):
    """A root-relative lifter gives no horizontal pelvis path: the world frame holds the pelvis
    at x = z = 0, so its x/z positions, velocities, accelerations and its speed were ~0 in the
    CSV; they are empty now, with the reason in the dictionary, while its height and the
    other joints keep their values. In the (pelvis-centred) canonical frame of a moving camera
    all three pelvis axes are empty."""
    out = tmp_path / "world"
    _run_boxing(out)
    _, rows, header, body = _dictionary(out)
    blank = [f"pelvis_{c}_m" for c in "xz"] + [f"pelvis_{d}{c}_m_per_s{s}" for d, s in (("v", ""), ("a", "2"))
                                               for c in "xz"] + ["pelvis_speed_m_per_s"]
    for name in blank:
        i = header.index(name)
        assert all(r[i] == "" for r in body), name
        assert "not observable from a root-relative lifter" in rows[name][3], name
    for name in ("pelvis_y_m", "pelvis_vy_m_per_s", "right_wrist_x_m", "right_wrist_speed_m_per_s"):
        i = header.index(name)
        assert sum(r[i] != "" for r in body) > len(body) // 2, name
        assert "empty in this run" not in rows[name][3], name
    assert all(r[header.index("pelvis_missing")] == "0" for r in body)  # its height is there
    assert "relative to the pelvis" in rows["right_wrist_x_m"][3]
    # and so are the speeds (a sports trial read a wrist's speed without the pelvis's travel as the whole)
    assert "along x and z relative to the pelvis, whose own path is not observable" \
        in rows["right_wrist_speed_m_per_s"][3]
    assert "Horizontally they are relative to the pelvis" in (out / "report.md").read_text()
    # ... from a per-frame floor, which the dictionary now says (a user trial read it as measured)
    for name in ("pelvis_y_m", "left_ankle_y_m"):
        assert "floor placed under each frame's lowest joint" in rows[name][3], name
    out = tmp_path / "canonical"
    _run_boxing(out, "--mode", "smooth")
    _, rows, header, body = _dictionary(out)
    assert rows["pelvis_y_m"][2] == "canonical"
    for name in ("pelvis_x_m", "pelvis_y_m", "pelvis_z_m", "pelvis_vy_m_per_s", "pelvis_speed_m_per_s"):
        i = header.index(name)
        assert all(r[i] == "" for r in body), name
        assert "centred on the pelvis" in rows[name][3], name


def test_a_measured_pelvis_path_keeps_its_columns_and_an_undescribed_column_is_refused(tmp_path, kin):
    """With no unobservable axis (a depth sensor's measured root) the pelvis columns are the
    kinematics' values; an extra column without a definition cannot enter the dictionary."""
    T = kin.num_frames
    path = write_kinematics_csv(tmp_path / "k.csv", np.arange(T), np.arange(T) / FPS_YOGA, kin,
                                {"valid": np.ones(T, int)}, dictionary=tmp_path / "d.csv",
                                extra_definitions={"valid": ("0/1", "none", "Valid.")})
    header, body = read_csv(path)
    c = header.index("pelvis_vx_m_per_s")
    got = np.array([float(r[c]) if r[c] else np.nan for r in body])
    np.testing.assert_allclose(got, kin.velocity[:, PELVIS, 0], rtol=1e-6, atol=1e-9, equal_nan=True)
    assert [r[0] for r in read_csv(tmp_path / "d.csv")[1]] == header
    with pytest.raises(ValueError, match=r"expected a definition for every column, got none for \['tilt_deg'\]"):
        write_kinematics_csv(tmp_path / "k2.csv", np.arange(T), np.arange(T) / FPS_YOGA, kin,
                             {"tilt_deg": np.zeros(T)}, dictionary=tmp_path / "d2.csv")
    assert not (tmp_path / "k2.csv").exists() and not (tmp_path / "d2.csv").exists()


def test_the_heights_definition_says_what_y_0_is_for_each_floor():
    """Without one fitted ground plane the heights are not above the floor: per frame, y = 0
    sits under each frame's lowest joint; with no ankle seen, it is the pelvis's height (a user
    trial read pelvis_y as a measured height; a review found the note keyed on the path, not on
    the floor used)."""
    from pcnet.stages.core.conventions import H36M_JOINTS
    from pcnet.stages.sinks.exports import kinematics_columns

    def definition(floor, column="pelvis_y_m"):
        rows = kinematics_columns(list(H36M_JOINTS), "m", [], {}, "world", floor=floor)
        return {name: text for name, _, _, text in rows}[column]

    assert definition("plane").endswith("the height above the surface the feet stand on (y = 0: the ground, or a "
                                        "box's top), low-pass filtered (raw where pelvis_unfiltered = 1, empty where "
                                        "pelvis_missing = 1).")
    assert definition(None) == definition("plane")
    assert "floor placed under each frame's lowest joint" in definition("per frame", "left_ankle_y_m")
    assert "y = 0 is the pelvis's height, not the floor" in definition("pelvis")
    assert "floor placed" not in definition("per frame", "pelvis_x_m")


def test_one_rotation_gives_the_same_kinematics_filtered_in_either_frame(yoga_level):
    """Decision 0102: for one rotation (sequence mode) low-passing the camera-frame poses and
    then turning them equals low-passing the turned poses; a rotation constant in time passes
    :func:`lowpass_rotations` unchanged, a wobbling one comes out a rotation, NaN stays NaN."""
    R = wobbling_rotations(1, 5)[0]
    X = np.einsum("ij,tkj->tki", R, yoga_level.astype(np.float64))
    Rs = np.repeat(R[None], len(X), axis=0)
    a = compute_kinematics(to_canonical(X, R).astype(np.float64), 30.0)
    b = compute_kinematics(X, 30.0, rotation=Rs)
    np.testing.assert_allclose(a.positions, b.positions, atol=1e-5)  # to_canonical's float32
    for name, angle in a.angles.items():
        np.testing.assert_allclose(angle, b.angles[name], atol=1e-3, equal_nan=True, err_msg=name)
    kept, raw = lowpass_rotations(Rs, 30.0)
    np.testing.assert_allclose(kept, Rs, atol=1e-12)
    assert not raw.any()
    W = wobbling_rotations(200, 6)
    W[50] = np.nan
    F, _ = lowpass_rotations(W, 30.0)
    ok = np.isfinite(F).all(axis=(1, 2))
    assert not ok[50] and ok.sum() == 199
    np.testing.assert_allclose(F[ok] @ np.swapaxes(F[ok], 1, 2), np.broadcast_to(np.eye(3), (199, 3, 3)), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(F[ok]), 1.0, atol=1e-12)
    with pytest.raises(InputError, match=r"rotation: expected \(100, 3, 3\) rotations"):
        compute_kinematics(X[:100], 30.0, rotation=Rs)
    # a user trial's matrices that are not rotations gave angles to gravity 80-170 deg off, silently
    for not_rotation in (np.zeros_like(Rs), Rs * np.array([1.0, 1.0, -1.0]), 1.01 * Rs):
        with pytest.raises(InputError, match=r"rotation: expected proper rotations .* got frame 0"):
            compute_kinematics(X, 30.0, rotation=not_rotation)
    # a missing pelvis is the hips' midpoint, as rectification and pcnet run place it
    gap = X.copy()
    gap[20:25, 0] = np.nan
    filled = compute_kinematics(gap, 30.0, rotation=Rs)
    assert not filled.missing[20:25].any()
    np.testing.assert_allclose(filled.angles["left_knee_flexion"], b.angles["left_knee_flexion"], atol=1.0)


@pytest.mark.slow
def test_angles_between_segments_do_not_depend_on_the_mode(tmp_path):
    """Decision 0102: frame and smooth modes place the same camera-frame poses with different
    rotations; the poses and the rotations are low-passed apart, so every angle between two
    segments (not those to gravity) is the same in both modes' kinematics.csv (before, the
    filter of the turned poses mixed the rotations' noise into them: 0.1-1.9 deg on mocap)."""
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    tables = {}
    for mode in ("frame", "smooth"):
        out = tmp_path / mode
        res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output",
                                        str(FIXTURES / "yoga_Abhay_Bhujangasana_f150-249.npy"), "--fps", "30",
                                        "--mode", mode, "--out", str(out), "--no-recording"])
        assert res.exit_code == 0, res.output
        header, rows = read_csv(out / "kinematics.csv")
        tables[mode] = {h: np.array([float(r[i]) if r[i] else np.nan for r in rows]) for i, h in enumerate(header)}
    between = [h for h in tables["frame"] if h.endswith("_deg") and not any(
        word in h for word in ("inclination", "gravity", "heading"))]
    assert len(between) >= 20
    moved = 0.0
    for h in between:
        a, b = tables["frame"][h], tables["smooth"][h]
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=h)
        np.testing.assert_allclose(a, b, atol=2e-3, equal_nan=True, err_msg=h)
    for h in tables["frame"]:
        if "inclination" in h:
            moved = max(moved, float(np.nanmax(np.abs(tables["frame"][h] - tables["smooth"][h]))))
    assert moved > 0.1  # the modes' rotations do differ: angles to gravity move


@pytest.mark.slow
def test_the_motion_check_reads_the_same_frames_in_every_mode(tmp_path):
    """The motion check compares pelvis-relative speeds and accelerations with limits fitted in
    a fixed frame (stages/plausibility.py: ``implausible_motion``); without a world frame it
    reads the camera frame, not the per-frame canonical frame whose rotations' noise moved what
    it flagged (real MediaPipe fixture: frames 4 and 12 in frame mode, 4 and 5 in sequence mode)."""
    from pcnet.pipeline import RunConfig, run_pipeline

    flagged = {}
    for mode in ("sequence", "frame", "smooth"):
        out = tmp_path / mode
        run_pipeline(RunConfig(lifter="mediapipe", lifter_output=str(FIXTURES / "mediapipe_blazepose33_f000-059.npz"),
                               mode=mode, out=str(out), recording=False), progress=False)
        header, rows = read_csv(out / "kinematics.csv")
        column = header.index("implausible_motion")
        flagged[mode] = [i for i, r in enumerate(rows) if r[column] == "1"]
    assert flagged["sequence"], "the fixture's lifter jump is flagged"
    assert flagged["frame"] == flagged["smooth"] == flagged["sequence"]


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["frame", "smooth"])
def test_the_networks_residual_never_reaches_the_kinematics(tmp_path, mode):
    """Decision 0100: every mode's kinematics read the input turned rigidly. On the real prone
    fixture (Bhujangasana, where the residual is centimetres) the default method and
    ``pcnet-rigid`` (the same rotations, no residual) write the same kinematics.csv, while
    canonical.npz keeps the network's residual-carrying poses."""
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    outs = {}
    for method in ("pcnet", "pcnet-rigid"):
        out = tmp_path / method
        res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output",
                                        str(FIXTURES / "yoga_Abhay_Bhujangasana_f150-249.npy"), "--fps", "30",
                                        "--mode", mode, "--method", method, "--out", str(out), "--no-recording"])
        assert res.exit_code == 0, res.output
        outs[method] = out
    assert read_csv(outs["pcnet"] / "kinematics.csv") == read_csv(outs["pcnet-rigid"] / "kinematics.csv")
    with np.load(outs["pcnet"] / "canonical.npz") as a, np.load(outs["pcnet-rigid"] / "canonical.npz") as b:
        np.testing.assert_array_equal(a["rotation"], b["rotation"])
        moved = np.linalg.norm(a["canonical"] - b["canonical"], axis=-1)
    assert np.nanmedian(moved) > 0.02  # metres: the residual is there, in canonical.npz only


def test_frames_with_a_pose_but_no_fitted_pelvis_path_have_no_positions(yoga_level):
    """A held pelvis path is no measurement: a two-person trial's pelvis stayed 0.66 m up through
    a backflip in kinematics.csv. Such frames (``pelvis_path_std`` NaN with a pose) keep their
    angles and lose every position, velocity, acceleration and speed, and the dictionary says so."""
    from types import SimpleNamespace

    from pcnet.stages.sinks.exports import blank_unobservable, kinematics_columns
    from pcnet.stages.sinks.result import unplaced_frames

    k = compute_kinematics(yoga_level, 30.0)
    rows = np.zeros(k.num_frames, bool)
    rows[:3] = True
    out = blank_unobservable(k, None, rows)
    assert np.isnan(out.positions[:3]).all() and np.isnan(out.speed[:3]).all()
    np.testing.assert_array_equal(out.positions[3:], k.positions[3:])
    for name, values in k.angles.items():
        np.testing.assert_array_equal(out.angles[name], values)
    assert blank_unobservable(k, None, np.zeros(k.num_frames, bool)) is k

    T = k.num_frames
    std = np.full((T, 3), 0.05)
    std[:3] = np.nan
    cam = np.ones((T, 17, 3))
    cam[0] = np.nan  # no pose at all: missing, not unplaced
    run = SimpleNamespace(root_path="from 2D keypoints", pelvis_path_std=std, world=cam, joints_camera=cam)
    np.testing.assert_array_equal(np.flatnonzero(unplaced_frames(run)), [1, 2])
    assert unplaced_frames(SimpleNamespace(**{**vars(run), "root_path": "measured"})) is None

    cols = {c[0]: c[3] for c in kinematics_columns(["pelvis"], "m", [], {}, "world", unplaced="the 2 frames X")}
    assert cols["pelvis_y_m"].endswith(" Empty in the 2 frames X.") and cols["pelvis_speed_m_per_s"].endswith(
        " Empty in the 2 frames X.") and not cols["pelvis_missing"].endswith("X.")


@pytest.mark.slow
def test_a_real_run_leaves_the_unplaced_frames_positions_empty(tmp_path):
    """The sports2d demo from its MediaPipe file: the frames whose pelvis path has no fit
    (pelvis_path_std_world NaN) have empty positions in kinematics.csv and keep their angles."""
    from pcnet.pipeline import RunConfig, run_pipeline

    folder = shared("real", "sports2d_demo")
    mp = folder / "mediapipe_blazepose33.npz"
    cfg = RunConfig(video=str(folder / "demo.mp4"), lifter="mediapipe", lifter_output=str(mp), keypoints2d=str(mp),
                    keypoints2d_format="mediapipe", recording=False, out=str(tmp_path / "o"))
    result = run_pipeline(cfg.validate(), progress=False)
    with np.load(result.outputs["canonical.npz"], allow_pickle=False) as npz:
        std, world = npz["pelvis_path_std_world"], npz["joints_world"]
    unplaced = ~np.isfinite(std).all(axis=1) & np.isfinite(world).any(axis=(1, 2))
    with open(result.outputs["kinematics.csv"], newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert unplaced.any()
    for i in np.flatnonzero(unplaced):
        assert rows[i]["pelvis_y_m"] == rows[i]["left_ankle_speed_m_per_s"] == "", i
    assert any(rows[i]["trunk_inclination_deg"] for i in np.flatnonzero(unplaced))
    assert all(rows[i]["pelvis_y_m"] for i in np.flatnonzero(~unplaced & np.isfinite(std).all(axis=1))
               if rows[i]["pelvis_missing"] == "0")
    assert "kinematics.csv and the marker files leave their positions empty" in (
        tmp_path / "o" / "report.md").read_text()
    trc = read_trc(result.outputs["world.trc"])[3][:, 2:]  # the marker files agree with the CSV (an export trial)
    assert len(trc) == len(rows) and np.isnan(trc[unplaced]).all()
    assert np.isfinite(trc[~unplaced]).all(axis=1).sum() > 100


def test_angles_between_segments_do_not_depend_on_the_pelvis_path_next_to_a_gap(yoga_level):
    """An estimator-swapping trial: where a masked wrist left a run of frames too short for the
    filter (kept raw), elbow flexion moved by up to 1.2 deg when only the fitted pelvis path
    changed (--height). A raw joint beside a filtered one carried the path's own filter
    residual into their segment; about the pelvis, the joints' positions are the path's
    filtered positions plus their own, raw or filtered, and a segment no longer sees the path."""
    X = yoga_level[:90].astype(np.float64)  # real poses, pelvis at the origin
    X[[40, 43], R_WRIST] = np.nan  # frames 41-42: a two-frame run, too short for the filter
    t = np.arange(len(X)) / FPS_YOGA
    paths = [np.stack([0.8 * t, 0.02 * np.sin(9 * t), 0.1 * t ** 2], -1),  # a walk with a bounce
             np.stack([0.3 * t + 0.2 * np.sin(5 * t), 0.0 * t, -0.5 * t], -1)]
    kin = [compute_kinematics(X + p[:, None], FPS_YOGA) for p in paths]
    assert kin[0].unfiltered[41:43, R_WRIST].all()
    # filtered whole, the elbow moved 0.16 deg between the two paths; what is left is the poses'
    # float32 rounding (3e-5 deg)
    for name in ("right_elbow_flexion", "right_shoulder_elevation", "left_knee_flexion"):
        np.testing.assert_allclose(kin[0].angles[name], kin[1].angles[name], atol=1e-3, equal_nan=True, err_msg=name)
    # the pelvis is its path low-passed, as before
    pelvis = (X + paths[0][:, None]).astype(np.float32).astype(np.float64)[:, PELVIS]
    np.testing.assert_allclose(kin[0].positions[:, PELVIS], butterworth_lowpass(pelvis, FPS_YOGA, 6.0), atol=1e-9)
