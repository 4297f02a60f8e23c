"""The floor contacts of the up model (pcnet.stages.ground_plane): fused with the poses,
one support level where the feet rest on two, silent where the feet stay in place, refused
for root-relative joints. Real motion capture (tests/fixtures/mocap_small.npz,
Bandai-Namco-Research-Motiondataset, CC BY-NC 4.0), seen by a static camera."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pcnet.stages.core.conventions import PELVIS
from pcnet.stages.core.rotations import angle_between, axis_rotation, sample_camera_rotations
from pcnet.stages.ground_plane import (FOOTFALLS_LEFT_OUT, NO_PELVIS_PATH, detect_contacts, footfalls, ground_plane_up,
                                      leg_length, levels_objective, posture_and_floor_up)
from pcnet.stages.spherical import TUKEY_C
from pcnet.stages.up_model import PoseSummary, default_parameters, exp_map

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
        out = ground_plane_up(X, ok, u0, _cov(6.0))
        assert out.info["used"], out.info
        assert _deg(out.up, truth) < 1.5, (_deg(out.up, truth), out.info)
        # the fused covariance is narrower than the poses' prior along every axis
        assert np.all(np.linalg.eigvalsh(out.fit.cov) < np.radians(6.0) ** 2)


def test_the_fine_fit_weighs_the_footfalls_at_the_posture_learning_rate():
    """Decision 0081: one tempered posterior. The floor's information in the fused covariance
    (``cov^-1 - C0^-1``) scales with ``t_f``: at full weight it is about 1 / t_f times larger;
    tempered, a walk's floor still corrects a posterior 5.8 deg off."""
    from dataclasses import replace

    X, truth = _seen(WALK, 0, noise_m=0.015)
    ok = np.ones(len(X), bool)
    u0 = exp_map(truth, np.radians([5.0, -3.0]))
    p = default_parameters()
    assert 0.0 < p.footfall_posture_power < 1.0
    tempered = ground_plane_up(X, ok, u0, _cov(6.0), p)
    full = ground_plane_up(X, ok, u0, _cov(6.0), replace(p, footfall_posture_power=1.0))
    prior_inv = np.linalg.inv(_cov(6.0))
    info_t = np.linalg.inv(tempered.fit.cov) - prior_inv
    info_1 = np.linalg.inv(full.fit.cov) - prior_inv
    ratio = np.trace(info_t) / np.trace(info_1)
    assert abs(ratio - p.footfall_posture_power) < 0.3 * p.footfall_posture_power, ratio
    assert _deg(tempered.up, truth) < 1.5 and _deg(full.up, truth) < 1.5


def test_feet_on_two_levels_do_not_tilt_the_floor():
    # The second half of the walk on a platform 40 cm high (a stool, a step): every frame there
    # lifted along the true up. A plane through all footfalls tilts towards the platform; the
    # posterior's mode is one level, the other level's footfalls sitting in Tukey's flat tail.
    X, truth = _seen(WALK, 2, noise_m=0.015)
    half = len(X) // 2
    X[half:] += 0.4 * truth
    ok = np.ones(len(X), bool)
    ok[half - 1:half + 1] = False  # no footfall spans the cut, where the feet jump 40 cm in a frame
    p = default_parameters()
    points, _ = footfalls(detect_contacts(X, ok, truth))
    heights = points @ truth
    assert np.ptp(heights) > 0.35  # both levels are among the footfalls
    centred = points - points.mean(0)
    one_plane = np.linalg.svd(centred)[2][-1]  # the least-squares plane through every footfall
    assert min(_deg(one_plane, truth), _deg(-one_plane, truth)) > 5.0
    u0 = exp_map(truth, np.radians([3.0, -2.0]))
    out = ground_plane_up(X, ok, u0, _cov(4.0), p)
    assert out.info["used"] and out.info["n_levels"] == 2 and _deg(out.up, truth) < 1.5, (_deg(out.up, truth), out.info)


def test_feet_in_place_do_not_tilt_the_up():
    # Both feet stay put. Only the lower ankle is a contact (decision 0065), so resting feet
    # give one footfall (it gave 7.5 deg before footfalls were one observation each), and a
    # small per-frame jitter, which makes the two ankles take turns as the lower one, must not
    # read as a floor tilt either: 2 mm, about twice what MediaPipe's landmarks jitter on
    # Pose2Sim's still T-pose (1.5 cm tilts it up to 1.1 deg: docs/decisions/0065).
    X, truth = _seen(RAISE, 0)
    p = default_parameters()
    ok = np.ones(len(X), bool)
    points, ankle = footfalls(detect_contacts(X, ok, truth))
    assert len(points) == 1
    still = ground_plane_up(X, ok, truth, _cov(5.0), p)
    assert _deg(still.up, truth) < 1.0
    # the reason says why one footfall fits a floor and not its tilt (an IMU trial read "the
    # contacts constrain no floor tilt" beside a fitted floor plane)
    assert not still.info["used"] and still.info["reason"].startswith("one footfall: feet that stay in one place")
    for seed in range(5):
        X, truth = _seen(RAISE, seed, noise_m=0.002)
        out = ground_plane_up(X, ok, truth, _cov(5.0), p)
        assert out.info["n_footfalls"] > 2 and _deg(out.up, truth) < 0.5, (seed, out.info)


def test_root_relative_joints_are_refused():
    X, truth = _seen(WALK, 0, noise_m=0.015)
    rel = X - X[:, PELVIS:PELVIS + 1]
    u0 = exp_map(truth, np.radians([5.0, 0.0]))
    out = ground_plane_up(rel, np.ones(len(X), bool), u0, _cov(5.0))
    assert not out.info["used"] and "pelvis" in out.info["reason"] and np.allclose(out.up, u0)


def test_levels_objective_scores_many_candidate_normals_as_one_at_a_time():
    p = default_parameters()
    X, truth = _seen(WALK, 1, noise_m=0.015)
    ok = np.ones(len(X), bool)
    leg = leg_length(X, ok)
    points, _ = footfalls(detect_contacts(X, ok, truth))
    scale = p.footfall_height_sd_leg * leg
    ups = exp_map(np.broadcast_to(truth, (40, 3)), np.random.default_rng(0).normal(0.0, 0.3, (40, 2)))
    together = levels_objective(ups @ points.T, scale)
    one_by_one = [float(levels_objective(points @ u, scale)) for u in ups]
    assert np.allclose(together, one_by_one, rtol=0, atol=1e-9)
    # one level exactly: no cost; two levels far apart: one footfall's largest cost, c^2 / 6
    assert levels_objective(np.zeros(5), scale) == 0.0
    assert np.isclose(levels_objective(np.r_[np.zeros(5), np.ones(5)], scale), TUKEY_C ** 2 / 6)


def test_a_walk_across_the_view_tells_an_upright_walker_from_a_lying_body():
    """A camera rolled a quarter turn over a real walk with its pelvis path: the skeleton alone
    fits an upright body and a body lying on the floor as well (the declared priors then say
    lying), but along the lying body's up the footfalls climb a support level at every step.
    With the footfalls in the posture's posterior (decision 0048) the walker reads upright;
    root-relative, the prior still decides."""
    from pcnet.pipeline.rectification import rectify

    X, truth = _seen(WALK, 0, noise_m=0.015)
    Q = axis_rotation("z", np.radians(90.0))
    rolled, truth = X @ Q.T, Q @ truth
    walk = rolled[-1, PELVIS] - rolled[0, PELVIS]
    lying_up = np.array([0.0, -1.0, 0.0])  # the level camera's up, where the prior puts a lying body
    assert abs(walk @ lying_up) > 1.0  # metres walked along the lying body's up: across the view
    seq = rectify(rolled, "pcnet", mode="sequence", fps=FPS, measured_root=True).report.sequence
    assert seq.posture.most_probable == "upright" and seq.posture.p_lying < 0.05, seq.posture
    assert _deg(seq.up, truth) < 5.0, (_deg(seq.up, truth), seq.ground_plane)
    alone = rectify(rolled - rolled[:, PELVIS:PELVIS + 1], "pcnet", mode="sequence", fps=FPS).report.sequence
    assert alone.posture.most_probable == "lying"


def test_posture_and_floor_up_weighs_the_footfalls_in_the_posture_only_when_asked():
    """The stage function the chain, the fit and the ablation share: a rolled walker whose poses
    read their true up (1 deg) reads lying from the poses and priors alone (no path, or the
    footfalls left out as before decision 0048), upright once the footfalls weigh in, and then
    gets the upright fine floor fit."""
    X, truth = _seen(WALK, 0, noise_m=0.015)
    Q = axis_rotation("z", np.radians(90.0))
    rolled, truth = X @ Q.T, Q @ truth
    ok = np.ones(len(rolled), bool)
    summary, p = PoseSummary(truth, _cov(1.0)), default_parameters()
    none = posture_and_floor_up(summary, None, ok, p)
    assert none.posterior.posture == "lying" and none.ground == {"used": False, "reason": NO_PELVIS_PATH}
    before = posture_and_floor_up(summary, rolled, ok, p, footfalls=False)
    assert before.posterior.posture == "lying" and before.ground["reason"] == FOOTFALLS_LEFT_OUT
    assert np.array_equal(before.up, before.posterior.up)
    chain = posture_and_floor_up(summary, rolled, ok, p)
    assert chain.posterior.posture == "upright" and chain.ground["reason"] == "ok", chain.ground
    assert _deg(chain.up, truth) < 3.0


def test_where_the_2d_track_switches_person_the_floor_reads_one_persons_feet():
    """Decision 0066: a real walk, then the track jumps to another person standing half a metre
    higher (a box) two metres away. Both people's feet give the floor two support levels; the
    floor of the longest one-person stretch has the walker's alone."""
    from pcnet.pipeline.rectification import rectify_checked

    X, truth = _seen(WALK, 0, noise_m=0.015)
    other = X[: len(X) // 2] + 0.5 * truth + np.array([2.0, 0.0, 0.0])
    both = np.concatenate([X, other])
    walker = np.r_[np.ones(len(X), bool), np.zeros(len(other), bool)]
    mixed = rectify_checked(both, mode="sequence", fps=FPS, measured_root=True).report.sequence.ground_plane
    one = rectify_checked(both, mode="sequence", fps=FPS, measured_root=True, decide_on=walker).report.sequence
    assert mixed["n_levels"] >= 2 and mixed["n_contacts"] > len(X), mixed
    assert one.ground_plane["n_levels"] == 1 and one.ground_plane["n_contacts"] <= len(X), one.ground_plane
    assert _deg(one.up, truth) < 3.0, (_deg(one.up, truth), one.ground_plane)
