"""The floor contacts of the up model (pcnet.stages.ground_plane): fused with the poses,
one support level where the feet rest on two, silent where the feet stay in place, refused
for root-relative joints. Real motion capture (tests/fixtures/mocap_small.npz,
Bandai-Namco-Research-Motiondataset, CC BY-NC 4.0), seen by a static camera."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import PELVIS
from pcnet.stages.core.rotations import angle_between, sample_camera_rotations
from pcnet.stages.ground_plane import detect_contacts, footfalls, ground_plane_up, leg_length
from pcnet.stages.up_model import default_parameters, exp_map

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "mocap_small.npz"
WALK, RAISE = "dataset-2_walk-turn-left_active_001", "dataset-2_raise-up-both-hands_elderly_024"
FPS = 30.0


def _seen(name: str, seed: int = 0, noise_m: float = 0.0):
    """``(joints (T, 17, 3) camera frame with the root kept, true up (3,))`` of a fixture clip
    under a static "paper" camera, with iid noise of ``noise_m`` metres per joint and axis."""
    with np.load(FIXTURE) as d:
        W = d[name].astype(np.float64)
    C = sample_camera_rotations(1, "paper", np.random.default_rng(seed))[0]  # world -> camera
    X = np.einsum("ij,tkj->tki", C, W - W[:1, PELVIS:PELVIS + 1]) + np.array([0.0, 0.0, 4.0])
    X = X + np.random.default_rng(seed).normal(0.0, noise_m, X.shape)
    return X, C[:, 1]


def _deg(a, b) -> float:
    return float(np.degrees(angle_between(a, b)))


def _cov(sd_deg: float) -> np.ndarray:
    return np.eye(2) * np.radians(sd_deg) ** 2


def test_a_walk_floor_corrects_a_biased_posterior():
    for seed in range(3):
        X, truth = _seen(WALK, seed, noise_m=0.015)
        ok = np.ones(len(X), bool)
        u0 = exp_map(truth, np.radians([5.0, -3.0]))  # the poses' up, 5.8 deg off
        out = ground_plane_up(X, ok, u0, FPS, _cov(6.0))
        assert out.info["used"], out.info
        assert _deg(out.up, truth) < 1.5, (_deg(out.up, truth), out.info)
        # the fused covariance is narrower than the poses' prior along every axis
        assert np.all(np.linalg.eigvalsh(out.fit.cov) < np.radians(6.0) ** 2)


def test_feet_on_two_levels_do_not_tilt_the_floor():
    # The second half of the walk on a platform 40 cm high (a stool, a step): every frame there
    # lifted along the true up. A plane through all footfalls tilts towards the platform; the
    # posterior's mode is one level, the other level's footfalls sitting in Tukey's flat tail.
    X, truth = _seen(WALK, 2, noise_m=0.015)
    half = len(X) // 2
    X[half:] += 0.4 * truth
    ok = np.ones(len(X), bool)
    p = default_parameters()
    points, _ = footfalls(detect_contacts(X, ok, truth, FPS, leg_length(X, ok), p))
    heights = points @ truth
    assert np.ptp(heights) > 0.35  # both levels are among the footfalls
    centred = points - points.mean(0)
    one_plane = np.linalg.svd(centred)[2][-1]  # the least-squares plane through every footfall
    assert min(_deg(one_plane, truth), _deg(-one_plane, truth)) > 5.0
    u0 = exp_map(truth, np.radians([3.0, -2.0]))
    out = ground_plane_up(X, ok, u0, FPS, _cov(4.0), p)
    assert out.info["used"] and out.info["n_levels"] == 2 and _deg(out.up, truth) < 1.5, (_deg(out.up, truth), out.info)


def test_feet_in_place_do_not_tilt_the_up():
    # Both feet stay put: one footfall each. Contacts within a footfall share its error, so the
    # millimetre jitter of a resting ankle must not read as a floor tilt (it gave 7.5 deg before
    # footfalls were one observation each).
    X, truth = _seen(RAISE, 0)
    p = default_parameters()
    ok = np.ones(len(X), bool)
    contacts = detect_contacts(X, ok, truth, FPS, leg_length(X, ok), p)
    points, ankle = footfalls(contacts)
    assert len(points) <= 4 and set(ankle) == {0, 1}
    out = ground_plane_up(X, ok, truth, FPS, _cov(5.0), p)
    assert _deg(out.up, truth) < 1.0, out.info


def test_root_relative_joints_are_refused():
    X, truth = _seen(WALK, 0, noise_m=0.015)
    rel = X - X[:, PELVIS:PELVIS + 1]
    u0 = exp_map(truth, np.radians([5.0, 0.0]))
    out = ground_plane_up(rel, np.ones(len(X), bool), u0, FPS, _cov(5.0))
    assert not out.info["used"] and "pelvis" in out.info["reason"] and np.allclose(out.up, u0)
