"""stages/root_path.py: the pelvis path in the camera frame from root-relative metric joints
and their 2D keypoints.

Real trajectories: the Bandai walk-turn clip of tests/fixtures/mocap_small.npz (walks about
3.5 m x 2.7 m while turning, 120 frames, 30 fps, world frame +Y up, metres; see
tests/fixtures/README.md), seen by a static level camera; the CMU validation-subject test
needs ../shared/data and skips without it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pcnet.stages.core.errors import InputError
from pcnet.stages.root_path import (PROCESS_NOISE_Q, VELOCITY_PRIOR_STD, RootPath, _fit_block, _rts,
                                    _wiener_velocity, root_from_keypoints)

FIXTURES = Path(__file__).parent / "fixtures"
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
K = np.array([[1400.0, 0.0, 960.0], [0.0, 1400.0, 540.0], [0.0, 0.0, 1.0]])
FPS = 30.0


def camera_view(world: np.ndarray, azimuth_deg: float = 30.0, distance: float = 6.0) -> np.ndarray:
    """World poses (+Y up) in the OpenCV frame of a level camera ``distance`` m from the mean
    pelvis at ``azimuth_deg``, 1 m above the floor, looking horizontally at it."""
    centre = world[:, 0].mean(0)
    a = np.radians(azimuth_deg)
    fwd = np.array([np.sin(a), 0.0, np.cos(a)])
    eye = centre - distance * fwd
    eye[1] = 1.0
    down = np.array([0.0, -1.0, 0.0])
    return (world - eye) @ np.stack([np.cross(down, fwd), down, fwd]).T


def project(P: np.ndarray) -> np.ndarray:
    q = P @ K.T
    return q[..., :2] / q[..., 2:]


def scene(name: str = "dataset-2_walk-turn-left_active_001"):
    with np.load(FIXTURES / "mocap_small.npz") as d:
        world = d[name].astype(np.float64)
    P = camera_view(world)
    X = P - P[:, :1]
    kp = np.concatenate([project(P), np.ones(P.shape[:2] + (1,))], -1)
    return P, X, kp


def add_noise(kp: np.ndarray, rng, sigma: float = 2.0) -> np.ndarray:
    out = kp.copy()
    out[..., :2] += rng.normal(0.0, sigma, out[..., :2].shape)
    return out


def test_clean_projection_recovers_the_path():
    P, X, kp = scene()
    r = root_from_keypoints(X, kp, K, FPS)
    assert isinstance(r, RootPath)
    assert r.position.shape == (len(P), 3) and r.position.dtype == np.float64
    assert r.frames_fitted == len(P) and r.frames_rejected == 0
    assert np.abs(r.position - P[:, 0]).max() < 1e-4  # 0.1 mm: exact data, exact model
    assert np.isfinite(r.std).all() and r.depth_std_median == pytest.approx(np.median(r.std[:, 2]))


def test_noise_outlier_joints_and_frames():
    P, X, kp = scene()
    rng = np.random.default_rng(0)
    kp = add_noise(kp, rng)
    bad = rng.random(kp.shape[:2]) < 0.05  # wrong detections: 40-80 px off
    kp[..., :2] += bad[..., None] * rng.uniform(40, 80, bad.shape)[..., None] * rng.choice([-1, 1], bad.shape + (2,))
    switch = [30, 31, 77]  # the 2D track jumps to someone 200 px to the right for a frame
    kp[switch, :, 0] += 200.0
    r = root_from_keypoints(X, kp, K, FPS)
    err = np.linalg.norm(r.position - P[:, 0], axis=1)
    assert np.isfinite(err).all()
    # At 6 m, 2 px is 9 mm across; depth is ~10x weaker (observed median 7 mm, max 31 mm).
    assert np.median(err) < 0.02 and err.max() < 0.08
    assert r.frames_rejected >= len(switch)
    assert err[switch].max() < 0.05  # bridged from the neighbours, not pulled 0.9 m aside


def test_per_frame_fit_ignores_a_wrong_joint():
    # One joint 250 px off in every other frame: the robust fit moves by millimetres (observed
    # median 2 mm); plain least squares moved by 0.7 m on the same data.
    P, X, kp = scene()
    rng = np.random.default_rng(6)
    kp = add_noise(kp, rng, 1.0)
    frames = np.arange(0, len(P), 2)
    before = _fit_block(X, kp, K, 0.3)[:, :3]
    kp[frames, rng.integers(1, 17, len(frames)), :2] += rng.choice([-1, 1], (len(frames), 2)) * 250.0
    after = _fit_block(X, kp, K, 0.3)[:, :3]
    assert np.median(np.linalg.norm(after - before, axis=1)[frames]) < 0.01


def test_depth_is_the_weak_axis():
    P, X, kp = scene()
    r = root_from_keypoints(X, add_noise(kp, np.random.default_rng(1)), K, FPS)
    med = np.median(r.std, axis=0)
    assert med[2] > 3 * med[0] and med[2] > 3 * med[1]
    assert r.depth_std_median == pytest.approx(med[2])
    assert np.allclose(r.std, np.sqrt(np.diagonal(r.cov, axis1=1, axis2=2)))


def test_std_is_calibrated_for_pixel_noise():
    # Gaussian pixel noise is the noise model the fit's covariance assumes; the smoother's
    # process noise is fitted on other (CMU) motion. Over the three fixture clips and 4 seeds
    # the share of |error| < 2 std was 0.92-0.95 per axis (95.4 % for an exact Gaussian std).
    inside = []
    for name in ("dataset-2_walk-turn-left_active_001", "dataset-2_run_masculine_037",
                 "dataset-2_raise-up-both-hands_elderly_024"):
        P, X, kp = scene(name)
        for seed in range(4):
            r = root_from_keypoints(X, add_noise(kp, np.random.default_rng(seed)), K, FPS)
            inside.append(np.abs(r.position - P[:, 0]) < 2 * r.std)
    share = np.concatenate(inside).mean(0)
    assert np.all(share > 0.85) and np.all(share < 0.995), share


def test_gaps_are_bridged_and_ends_stay_nan():
    P, X, kp = scene()
    kp = add_noise(kp, np.random.default_rng(2))
    kp[50:60] = np.nan  # no detection
    kp[:4, 2:, 2] = 0.05  # only 2 confident joints: no fit
    r = root_from_keypoints(X, kp, K, FPS)
    assert r.frames_fitted == len(P) - 14
    assert np.isnan(r.position[:4]).all() and np.isnan(r.std[:4]).all()
    gap = np.linalg.norm(r.position[50:60] - P[50:60, 0], axis=1)
    assert np.isfinite(gap).all() and gap.max() < 0.15
    assert r.std[55, 0] > 2 * np.median(r.std[10:40, 0])


def test_a_switch_to_another_body_does_not_pull_the_path_before_it():
    """A 2D track that jumps to someone 2 m to the side at frame k: fitted as one body the smoother
    drags the frames before k towards the other person (the Sports2D demo's main person sank below
    the floor before the switch); with the track's stretches each is fitted on its own."""
    P, X, kp = scene()
    kp = add_noise(kp, np.random.default_rng(5))
    k = len(P) // 2
    other = P[k:] + np.array([2.0, 0.0, 0.0])
    kp[k:, :, :2] = project(other)
    segment = (np.arange(len(P)) >= k).astype(int)
    before = root_from_keypoints(X[:k], kp[:k], K, FPS).position
    split = root_from_keypoints(X, kp, K, FPS, segment=segment).position
    # as if the first stretch were alone (to 2 cm: the pixel noise level is the recording's)
    assert np.linalg.norm(split[:k] - before, axis=1).max() < 0.02
    assert np.linalg.norm(split[k:] - other[:, 0], axis=1).max() < 0.3
    whole = root_from_keypoints(X, kp, K, FPS).position
    assert np.linalg.norm(whole[k - 10:k] - P[k - 10:k, 0], axis=1).max() > 0.1  # what the stretches prevent
    with pytest.raises(InputError, match="segment"):
        root_from_keypoints(X, kp, K, FPS, segment=segment[1:])
    # a run's pelvis path: a stretch's frames with a pose but no 2D fit at its ends hold its own
    # first or last position, so no posed frame loses its place (a review: frames 56-62 were NaN)
    from pcnet.pipeline.pelvis_path import Intrinsics, pelvis_path

    kp[k - 4:k + 3] = np.nan
    path = pelvis_path(None, X, kp, Intrinsics(K, "test"), "m", FPS, 0.3, segment)
    assert np.isfinite(path.camera).all() and "held" in path.note
    np.testing.assert_allclose(path.camera[k - 4:k], np.repeat(path.camera[k - 5:k - 4], 4, axis=0))


def test_low_confidence_joints_are_ignored():
    P, X, kp = scene()
    kp[:, 13:, :2] += 300.0  # wrists and right arm far off, but below the threshold
    kp[:, 13:, 2] = 0.2
    r = root_from_keypoints(X, kp, K, FPS, min_confidence=0.3)
    assert np.abs(r.position - P[:, 0]).max() < 1e-4


def test_size_uncertainty_scales_the_whole_position():
    P, X, kp = scene()
    kp = add_noise(kp, np.random.default_rng(3))
    r0 = root_from_keypoints(X, kp, K, FPS)
    r1 = root_from_keypoints(X, kp, K, FPS, size_std_fraction=0.05)
    assert np.allclose(r1.position, r0.position)
    assert np.allclose(r1.std[:, 2], np.sqrt(r0.std[:, 2] ** 2 + (0.05 * r0.position[:, 2]) ** 2))
    # And the effect it stands for: a pose 5 % too large puts the pelvis 5 % too far.
    r2 = root_from_keypoints(1.05 * X, scene()[2], K, FPS)
    assert np.allclose(r2.position, 1.05 * P[:, 0], atol=1e-4)


def test_frame_array_like_input():
    P, X, kp = scene()

    class Rows:  # a memmap-like array: shape and slicing only
        def __init__(self, a):
            self.a, self.shape = a, a.shape

        def __len__(self):
            return len(self.a)

        def __getitem__(self, rows):
            return self.a[rows].astype(np.float32)

    r = root_from_keypoints(Rows(X), Rows(kp), K, FPS)
    assert np.abs(r.position - P[:, 0]).max() < 1e-3  # float32 input


def test_smoother_matches_batch_least_squares():
    # The Kalman/RTS recursion against the dense posterior of the same linear-Gaussian model:
    # states x_0..x_{m-1} = [p, v], prior v_0 ~ N(0, v0^2 I) (p_0 diffuse), x_{k+1} ~ N(F x_k, Q),
    # z_k ~ N(p_k, R_k) on the used frames.
    rng = np.random.default_rng(4)
    T = 25
    z = np.cumsum(rng.normal(0, 0.02, (T, 3)), 0) + [0, 0, 4]
    A = rng.normal(size=(T, 3, 3))
    R = A @ A.transpose(0, 2, 1) * 1e-4 + np.eye(3) * 1e-6
    use = rng.random(T) > 0.3
    use[:2] = [False, True]
    use[-1] = True
    F, Q = _wiener_velocity(1 / FPS, PROCESS_NOISE_Q)
    pos, cov = _rts(z, R, use, F, Q, VELOCITY_PRIOR_STD)
    k0 = 1
    m = T - k0
    info = np.zeros((6 * m, 6 * m))
    vec = np.zeros(6 * m)
    Qi = np.linalg.inv(Q)
    for i in range(m):
        if use[k0 + i]:
            Ri = np.linalg.inv(R[k0 + i])
            info[6 * i:6 * i + 3, 6 * i:6 * i + 3] += Ri
            vec[6 * i:6 * i + 3] += Ri @ z[k0 + i]
        if i + 1 < m:
            D = np.zeros((6, 6 * m))
            D[:, 6 * i:6 * i + 6] = -F
            D[:, 6 * i + 6:6 * i + 12] = np.eye(6)
            info += D.T @ Qi @ D
    info[3:6, 3:6] += np.eye(3) / VELOCITY_PRIOR_STD**2
    Sigma = np.linalg.inv(info)
    mean = Sigma @ vec
    for i in range(m):
        assert np.allclose(pos[k0 + i], mean[6 * i:6 * i + 3], atol=1e-9)
        assert np.allclose(cov[k0 + i], Sigma[6 * i:6 * i + 3, 6 * i:6 * i + 3], rtol=1e-6, atol=1e-12)
    assert np.isnan(pos[0]).all()


@pytest.mark.parametrize("joints, kp, k, message", [
    (np.zeros((5, 16, 3)), np.zeros((5, 16, 3)), K, "joints_cam: expected shape"),
    (np.zeros((5, 17, 3)), np.zeros((4, 17, 3)), K, "keypoints2d: expected shape"),
    (np.zeros((5, 17, 3)), np.zeros((5, 17, 3)), K[:2], "K: expected a finite (3, 3)"),
    (np.zeros((5, 17, 3)), np.zeros((5, 17, 3)), K * [[-1], [1], [1]], "positive focal"),
    (np.zeros((5, 17, 3)), np.zeros((5, 17, 3)), K * [[1], [1], [2]], "last row (0, 0, 1)"),
])
def test_bad_input(joints, kp, k, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        root_from_keypoints(joints, kp, k, FPS)


def test_no_frame_with_enough_joints():
    P, X, kp = scene()
    kp[:, 2:, 2] = 0.1
    with pytest.raises(InputError, match="needed 3 .* found at most 2"):
        root_from_keypoints(X, kp, K, FPS)
    with pytest.raises(InputError, match="fps"):
        root_from_keypoints(X, scene()[2], K, 0.0)


def test_cmu_validation_clip():
    path = SHARED / "mocap" / "cmu_train_h36m17.npz"
    if not path.exists():
        pytest.skip(f"{path} absent (../shared/data is not part of the repository)")
    from pcnet.models.datasets import load_mocap, select_split
    val = select_split(load_mocap(path), "val", "motion-style")
    clip = max(val, key=lambda c: len(c.joints))  # a CMU subject-60 salsa clip, ~560 frames
    P = camera_view(np.asarray(clip.joints, np.float64))
    X = P - P[:, :1]
    kp = add_noise(np.concatenate([project(P), np.ones(P.shape[:2] + (1,))], -1), np.random.default_rng(5))
    r = root_from_keypoints(X, kp, K, clip.fps)
    err = np.linalg.norm(r.position - P[:, 0], axis=1)
    ok = np.isfinite(err)
    assert ok.mean() > 0.98 and np.median(err[ok]) < 0.015
