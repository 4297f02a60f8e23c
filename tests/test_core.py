"""Conventions, rotation maths, canonical frame, geometric baseline, metrics, datasets."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial.transform import Rotation
from conftest import FIXTURES, shared

from pcnet.models.datasets import clip_split, load_mocap, make_pairs, select_split
from pcnet.stages.core import rotations as rot
from pcnet.stages.core.canonical import canonical_rotation, to_canonical, world_to_canonical
from pcnet.stages.core.conventions import H36M_PARENTS, LAYOUTS, check_poses, get_layout
from pcnet.stages.core.geometric import geometric_rotation
from pcnet.stages.core.metrics import heading_error_deg, mpjpe_mm, pa_mpjpe_mm, rotation_error_deg, tilt_error_deg
from pcnet.stages.remap import remap_to_h36m

BANDAI = FIXTURES / "bandai_small.npz"
DEEPMIMIC = FIXTURES / "deepmimic_small.npz"


@pytest.fixture(scope="module")
def world_poses() -> np.ndarray:
    return np.concatenate([c.joints for c in load_mocap(BANDAI)])


def test_layouts_are_consistent():
    h36m = get_layout("H36M-17")
    assert [p for p in H36M_PARENTS if p >= 0] == [b[0] for b in sorted(h36m.bones, key=lambda b: b[1])]
    for lay in LAYOUTS.values():
        assert len(lay.to_h36m) == 17
        for a, b in lay.bones + lay.lr_pairs:
            assert 0 <= a < lay.num_joints and 0 <= b < lay.num_joints
        for left, right in lay.lr_pairs:  # pairs are named left/right consistently
            assert "left" in lay.joints[left] and "right" in lay.joints[right], (lay.name, left, right)
        # every H36M side joint maps from source joints of the same side
        for k, name in enumerate(get_layout("h36m17").joints):
            for side in ("left", "right"):
                if name.startswith(side):
                    assert all(lay.joints[s].startswith(side) for s in lay.to_h36m[k]), (lay.name, name)
    with pytest.raises(ValueError, match="unknown joint layout"):
        get_layout("coco18")


def test_halpe_and_coco_mappings_agree_with_motionbert_on_real_data():
    """MotionBERT made boxing X3D.npy from this AlphaPose file with its halpe2h36m: our
    Halpe-26 remap, normalised like MotionBERT's crop_scale (``lib/utils/utils_data.py``,
    called from ``lib/data/dataset_wild.py:read_input``), must land on X3D's x, y joint
    by joint, and clearly worse with left and right swapped."""
    items = json.loads(shared("real", "boxing_motionbert", "alphapose-results.json").read_text())
    kp = np.array([it["keypoints"] for it in items], np.float32).reshape(len(items), 26, 3)
    halpe = remap_to_h36m(kp, "halpe26", confidence_channel=True)
    x3d = np.load(shared("real", "boxing_motionbert", "X3D.npy"))
    pts = halpe[..., :2][halpe[..., 2] != 0]
    lo, hi = pts.min(0), pts.max(0)
    scale = (hi - lo).max()
    u = ((halpe[..., :2] - (lo + hi - scale) / 2) / scale - 0.5) * 2
    err = np.linalg.norm(x3d[..., :2] - u, axis=-1).mean(0)
    swap = [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]
    err_swapped = np.linalg.norm(x3d[..., :2] - u[:, swap], axis=-1).mean(0)
    assert err.max() < 0.07
    sided = [1, 2, 3, 4, 5, 6, 11, 12, 13, 14, 15, 16]
    assert (err_swapped[sided] > 1.5 * err[sided]).all()
    # COCO-17 is Halpe-26's first 17 joints: both recipes agree on the limbs
    coco = remap_to_h36m(kp[:, :17], "coco17", confidence_channel=True)
    np.testing.assert_allclose(halpe[:, sided, :2], coco[:, sided, :2])
    # synthetic joints take the minimum confidence of their sources
    np.testing.assert_allclose(coco[:, 0, 2], np.minimum(kp[:, 11, 2], kp[:, 12, 2]))


def test_6d_to_matrix_is_a_rotation():
    d6 = np.random.default_rng(0).normal(size=(500, 6))
    R = rot.rotation_6d_to_matrix(d6)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-9)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-9)
    R0 = rot.sample_camera_rotations(50, "wide", np.random.default_rng(1))
    np.testing.assert_allclose(rot.rotation_6d_to_matrix(rot.matrix_to_rotation_6d(R0)), R0, atol=1e-12)
    assert np.isnan(rot.rotation_6d_to_matrix(np.zeros(6))).all()


def test_torch_6d_matches_numpy():
    torch = pytest.importorskip("torch", reason="torch (the [train] extra) not installed")
    from pcnet.models.network import rotation_6d_to_matrix

    d6 = np.random.default_rng(2).normal(size=(64, 6))
    Rt = rotation_6d_to_matrix(torch.from_numpy(d6)).numpy()
    np.testing.assert_allclose(Rt, rot.rotation_6d_to_matrix(d6), atol=1e-6)
    np.testing.assert_allclose(np.linalg.det(Rt), 1.0, atol=1e-6)


def test_with_up_takes_the_up_and_keeps_the_nearest_heading():
    """The result is a rotation whose up is the given one, nearest the input among all such
    rotations (no turn about the new up beats it), the input itself when the ups agree, and a
    half turn about the input's +X when they are opposite."""
    R = Rotation.random(200, random_state=3).as_matrix()
    up = rot.normalize(np.random.default_rng(4).normal(size=(200, 3)))
    out = rot.with_up(R, up)
    np.testing.assert_allclose(out[:, :, 1], up, atol=1e-12)
    np.testing.assert_allclose(np.swapaxes(out, 1, 2) @ out, np.broadcast_to(np.eye(3), out.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(out), 1.0, atol=1e-12)
    nearest = rot.geodesic_angle(out, R)
    for angle in (-0.2, -0.01, 0.01, 0.2):  # turning about the new up only moves away from R
        K = np.zeros_like(out)
        K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -up[:, 2], up[:, 1], -up[:, 0]
        K -= np.swapaxes(K, 1, 2)
        turned = (np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K) @ out
        assert np.all(rot.geodesic_angle(turned, R) > nearest)
    np.testing.assert_allclose(rot.with_up(R, R[:, :, 1]), R, atol=1e-12)
    flipped = rot.with_up(R[:5], -R[:5, :, 1])
    np.testing.assert_allclose(flipped[:, :, 0], R[:5, :, 0], atol=1e-12)
    np.testing.assert_allclose(flipped[:, :, 1], -R[:5, :, 1], atol=1e-12)
    assert np.isnan(rot.with_up(R[:1], np.full(3, np.nan))).all()


def test_camera_rotation_round_trip_and_ranges():
    rng = np.random.default_rng(3)
    for dist, pitch_max, roll_max in (("paper", 25, 12), ("wide", 45, 25), ("handheld", 25, 30)):
        R = rot.sample_camera_rotations(4000, dist, rng)
        h, p, r = rot.decompose_camera_rotation(R)
        np.testing.assert_allclose(rot.compose_camera_rotation(h, p, r), R, atol=1e-9)
        assert np.degrees(np.abs(p)).max() <= pitch_max + 1e-6
        assert np.degrees(np.abs(r)).max() <= roll_max + 1e-6
        if dist == "handheld":  # roll N(0, 10) in every view: about 23 % beyond 12 deg
            assert 0.18 < (np.degrees(np.abs(r)) > 12).mean() < 0.28
    # the frontal camera sees the subject's up as image-up and its right on image-left
    R = rot.compose_camera_rotation(0.0, 0.0, 0.0)
    np.testing.assert_allclose(R @ [0, 1, 0], [0, -1, 0])
    np.testing.assert_allclose(R @ [0, 0, 1], [-1, 0, 0])
    # positive pitch = camera looking down: up tilts away from the camera (-z)
    assert (rot.compose_camera_rotation(0.0, 0.3, 0.0) @ [0, 1, 0])[2] < 0
    with pytest.raises(ValueError, match="view distribution"):
        rot.sample_camera_rotations(3, "fisheye", rng)


def test_canonical_frame_returns_known_rotation(world_poses):
    canon, valid = world_to_canonical(world_poses)
    assert valid.all()
    # right hip on +Z, head above the pelvis
    assert (canon[:, 1, 2] > 0).all() and (canon[:, 4, 2] < 0).all() and np.median(canon[:, 10, 1]) > 0.4
    R = rot.sample_camera_rotations(len(canon), "wide", np.random.default_rng(4))
    cam = canon @ np.swapaxes(R, 1, 2) + np.array([0.3, -0.1, 3.0])  # a translated camera view
    R_back, ok = canonical_rotation(cam, R[:, :, 1])
    assert ok.all()
    np.testing.assert_allclose(R_back, R, atol=1e-5)
    np.testing.assert_allclose(to_canonical(cam, R_back), canon, atol=1e-5)
    # R, not R^T: the transposed rotation must not pass
    assert rotation_error_deg(np.swapaxes(R_back, 1, 2), R).mean() > 10


def test_geometric_exact_on_upright_coplanar_pose(world_poses):
    canon, _ = world_to_canonical(world_poses[:1])
    pose = canon[0].copy()
    # upright, hips and shoulders in one vertical plane, both lines level
    pose[[1, 4, 11, 14]] = [[0, -0.02, 0.12], [0, -0.02, -0.12], [0, 0.45, -0.18], [0, 0.45, 0.18]]
    R = rot.sample_camera_rotations(200, "wide", np.random.default_rng(5))
    cam = np.einsum("nij,kj->nki", R, pose)
    R_hat, valid = geometric_rotation(cam)
    assert valid.all()
    np.testing.assert_allclose(R_hat, R, atol=1e-6)  # float32 poses


def test_geometric_flags_degenerate_and_nan_frames(world_poses):
    cam = world_poses[:5] - world_poses[:5, :1]
    cam[0, 1] = np.nan  # NaN hip
    cam[1, 4] = cam[1, 1]  # coincident hips
    cam[2, 11] = cam[2, 14]  # coincident shoulders
    cam[3] = 0.0  # zero-size skeleton
    R, valid = geometric_rotation(cam)
    assert valid.tolist() == [False, False, False, False, True]
    assert np.isnan(R[:4]).all() and np.isfinite(R[4]).all()
    with pytest.raises(ValueError, match=r"expected shape \(N, 17, 3\)"):
        geometric_rotation(np.zeros((5, 16, 3)))
    with pytest.raises(ValueError):
        check_poses(np.zeros((2, 17, 2)))


def test_error_metrics_on_known_rotations():
    R = rot.sample_camera_rotations(100, "paper", np.random.default_rng(6))
    about_up = R @ rot.axis_rotation("y", np.radians(10.0))  # 10 deg heading error, no tilt
    np.testing.assert_allclose(rotation_error_deg(about_up, R), 10.0, atol=1e-6)
    np.testing.assert_allclose(heading_error_deg(about_up, R), 10.0, atol=1e-6)
    np.testing.assert_allclose(tilt_error_deg(about_up, R), 0.0, atol=1e-6)
    axis = rot.normalize(np.cross(R[:, :, 1], [1.0, 0.0, 0.0]))  # any axis perpendicular to up
    tilted = Rotation.from_rotvec(np.radians(7.0) * axis).as_matrix() @ R
    np.testing.assert_allclose(tilt_error_deg(tilted, R), 7.0, atol=1e-6)
    np.testing.assert_allclose(heading_error_deg(tilted, R), 0.0, atol=1e-3)


def test_procrustes_and_mpjpe(world_poses):
    Y = world_poses[:20] - world_poses[:20, :1]
    R = rot.sample_camera_rotations(20, "wide", np.random.default_rng(7))
    X = 1.7 * np.einsum("nij,nkj->nki", R, Y) + 0.5
    np.testing.assert_allclose(pa_mpjpe_mm(X, Y), 0.0, atol=1e-6)
    assert (mpjpe_mm(X, Y) > 10).all()
    shifted = Y + np.array([0.01, 0.0, 0.0])
    np.testing.assert_allclose(mpjpe_mm(shifted, Y), 10.0, atol=1e-4)


def test_procrustes_rotation_recovers_the_turn_and_stays_proper(world_poses):
    """Row vectors: ``Y0 = X0 R`` gives back ``R``; a mirrored target still gets a proper rotation."""
    X0 = world_poses[:20] - world_poses[:20, :1]
    R = rot.sample_camera_rotations(20, "wide", np.random.default_rng(3))
    est, trace = rot.procrustes_rotation(X0, X0 @ R)
    np.testing.assert_allclose(est, R, atol=1e-9)
    np.testing.assert_allclose(trace, (X0**2).sum((1, 2)), rtol=1e-6)  # the fixture is float32
    mirrored, _ = rot.procrustes_rotation(X0, X0 * np.array([-1.0, 1.0, 1.0]))
    np.testing.assert_allclose(np.linalg.det(mirrored), 1.0, atol=1e-9)


def test_mocap_loading_and_splits(tmp_path):
    clips = load_mocap(DEEPMIMIC)
    assert {c.name for c in clips} == set(np.load(DEEPMIMIC).files)
    assert clip_split("dataset-1_bow_active_001") == clip_split("dataset-1_bow_active_001")
    assert sum(len(select_split(clips, s)) for s in ("train", "val", "test")) == len(clips)
    bad = tmp_path / "bad.npz"
    np.savez(bad, clip=np.zeros((4, 16, 3)))
    with pytest.raises(ValueError, match=r"bad.npz \[clip clip\]: expected shape \(T, 17, 3\) joints, got \(4, 16, 3\)"):
        load_mocap(bad)
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="junk.npz: not a readable"):
        load_mocap(tmp_path / "junk.npz")
    with pytest.raises(FileNotFoundError):
        load_mocap(tmp_path / "missing.npz")
    with pytest.raises(ValueError, match="unknown split"):
        select_split(clips, "dev")


def test_pairs_are_deterministic_and_consistent():
    from pcnet.models.datasets import Augmentation, Noise

    clips = load_mocap(BANDAI)
    a = make_pairs(clips, "wide", seed=3, noise=Noise(), augmentation=Augmentation())
    b = make_pairs(clips, "wide", seed=3, noise=Noise(), augmentation=Augmentation())
    np.testing.assert_array_equal(a.inputs, b.inputs)
    clean = make_pairs(clips, "paper", seed=3, camera="per-clip")
    np.testing.assert_allclose(clean.canonical @ np.swapaxes(clean.R, 1, 2), clean.inputs, atol=1e-5)
    for i in range(len(clips)):  # one fixed camera per clip
        Rs = clean.R[clean.clip == i]
        assert np.allclose(Rs, Rs[0])
    assert np.isnan(a.inputs).any() and not np.isnan(a.inputs[:, 0]).any()  # dropped joints, never the pelvis
    # proportion augmentation widens the narrow Bandai hips
    hip = np.linalg.norm(a.canonical[:, 1] - a.canonical[:, 4], axis=-1)
    assert hip.max() > 1.5 * np.linalg.norm(clean.canonical[:, 1] - clean.canonical[:, 4], axis=-1).max()


def test_static_camera_is_fixed_in_the_world():
    """camera="static": every frame of a clip is its world pose (pelvis-centred) seen by ONE
    rotation, with the same up as "per-clip" (which pans with the subject's heading instead)."""
    from scipy.spatial.transform import Rotation

    clips = load_mocap(BANDAI)
    per_clip = make_pairs(clips, "paper", seed=3, camera="per-clip")
    static = make_pairs(clips, "paper", seed=3, camera="static")
    np.testing.assert_allclose(static.canonical, per_clip.canonical)
    np.testing.assert_allclose(static.R[:, :, 1], per_clip.R[:, :, 1], atol=1e-12)
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(static.clip == i)
        np.testing.assert_allclose(static.R[sel[0]], per_clip.R[sel[0]], atol=1e-12)
        world = clip.joints[static.frame[sel]].astype(np.float64)
        world = (world - world[:, :1]).reshape(-1, 3)
        residual = {}
        for name, pairs in (("static", static), ("per-clip", per_clip)):
            X = pairs.inputs[sel].astype(np.float64).reshape(-1, 3)
            rot, _ = Rotation.align_vectors(X, world)
            residual[name] = np.abs(rot.apply(world) - X).max()
        assert residual["static"] < 1e-4, (clip.name, residual)
        assert residual["per-clip"] > 100 * residual["static"], (clip.name, residual)


def test_noise_fraction_leaves_the_rest_clean():
    from pcnet.models.datasets import Noise, apply_noise

    clips = load_mocap(BANDAI)
    X = make_pairs(clips, "paper", seed=0).inputs.astype(np.float64)
    rng = np.random.default_rng(0)
    half = apply_noise(X, Noise(fraction=0.5), rng)
    changed = ~np.all(np.isclose(half, X, atol=1e-12, equal_nan=False), axis=(1, 2))
    assert 0.35 < changed.mean() < 0.65, changed.mean()
    np.testing.assert_allclose(half[~changed], X[~changed], atol=1e-12)  # untouched rows exact, no NaN
    none = apply_noise(X, Noise(fraction=0.0), np.random.default_rng(1))
    np.testing.assert_allclose(none, X, atol=1e-12)
    assert np.isnan(apply_noise(X, Noise(), np.random.default_rng(1))).any()


def test_evaluate_cli_json(tmp_path):
    from pcnet.pipeline.cli import main

    out = tmp_path / "r.json"
    args = ["evaluate", "--method", "geometric", "--data", str(DEEPMIMIC), "--split", "all", "--views", "wide",
            "--seed", "1", "--json", str(out)]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    first = json.loads(out.read_text())
    assert first["method"] == "geometric" and first["frames"] == 239
    for key in ("rotation_deg", "tilt_deg", "heading_deg", "mpjpe_mm", "pa_mpjpe_mm"):
        assert set(first[key]) == {"mean", "median", "p95"}
        assert f"{first[key]['mean']:.2f}" in res.output
    assert sum(c["frames"] for c in first["per_clip"]) == 239 and {"name", "tilt_deg"} <= set(first["per_clip"][0])
    again = CliRunner().invoke(main, args)  # an existing --json is the user's until --overwrite
    assert again.exit_code == 1 and "--overwrite" in again.output and json.loads(out.read_text()) == first
    assert CliRunner().invoke(main, [*args, "--overwrite"]).exit_code == 0
    assert json.loads(out.read_text()) == first  # deterministic for a seed
    res = CliRunner().invoke(main, ["evaluate", "--method", "geometric", "--data", str(tmp_path / "none.npz")])
    assert res.exit_code != 0 and "none.npz" in res.output


def test_virtual_camera_rotation_turns_the_optical_axis_onto_the_ray():
    from pcnet.stages.core.perspective import intrinsics, virtual_camera_rotation

    K = intrinsics(1920.0, 1080.0, 1000.0)
    pixels = np.array([[960.0, 540.0], [1960.0, 540.0], [300.0, 100.0], [np.nan, 5.0]])
    R = virtual_camera_rotation(pixels, K)
    np.testing.assert_allclose(R[0], np.eye(3), atol=1e-12)  # at the principal point
    # One focal length right of the centre: the ray is 45 deg about +y (x = f, z = f).
    np.testing.assert_allclose(R[1], rot.axis_rotation("y", np.radians(45.0)), atol=1e-12)
    ray = np.linalg.solve(K, [300.0, 100.0, 1.0])
    np.testing.assert_allclose(R[2] @ [0.0, 0.0, 1.0], ray / np.linalg.norm(ray), atol=1e-12)
    np.testing.assert_allclose(R[2] @ R[2].T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R[2]) == pytest.approx(1.0)
    # The smallest such rotation: its axis lies in the image plane (no extra roll).
    axis = Rotation.from_matrix(R[2]).as_rotvec()
    assert abs(axis[2]) < 1e-12
    assert np.degrees(np.linalg.norm(axis)) == pytest.approx(np.degrees(np.arccos(ray[2] / np.linalg.norm(ray))))
    assert np.isnan(R[3]).all()


def test_focal_length_from_the_35mm_equivalent_keeps_the_diagonal_angle_of_view():
    from pcnet.stages.core.errors import InputError
    from pcnet.stages.core.perspective import focal_px_from_35mm

    f = focal_px_from_35mm(1920.0, 1080.0, 26.0)
    diagonal_fov = 2 * np.degrees(np.arctan(np.hypot(1920.0, 1080.0) / 2 / f))
    assert diagonal_fov == pytest.approx(2 * np.degrees(np.arctan(np.hypot(36.0, 24.0) / 2 / 26.0)))
    assert focal_px_from_35mm(36.0, 24.0, 50.0) == pytest.approx(50.0)  # the film frame in mm
    with pytest.raises(InputError, match="width"):
        focal_px_from_35mm(0.0, 1080.0)


def test_mirrored_clips_stay_canonical_and_keep_input_and_target_consistent():
    from pcnet.models.datasets import Augmentation, mirror_canonical

    clips = load_mocap(FIXTURES / "bandai_small.npz")[:4]
    canon = world_to_canonical(np.concatenate([c.joints for c in clips]).astype(np.float64))[0]
    mirrored = mirror_canonical(canon)
    # Again canonical (the frame of a canonical pose is the identity) and a true mirror image.
    R, ok = canonical_rotation(mirrored, (0.0, 1.0, 0.0))
    np.testing.assert_allclose(R[ok], np.broadcast_to(np.eye(3), R[ok].shape), atol=1e-9)
    np.testing.assert_allclose(mirror_canonical(mirrored), canon, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(mirrored[:, 2] - mirrored[:, 1], axis=-1),  # right knee-hip
                               np.linalg.norm(canon[:, 5] - canon[:, 4], axis=-1), atol=1e-12)  # left's
    for camera in ("per-frame", "static"):
        pairs = make_pairs(clips, "paper", seed=1, camera=camera, augmentation=Augmentation(mirror_fraction=0.5))
        np.testing.assert_allclose(pairs.inputs, np.einsum("nij,nkj->nki", pairs.R, pairs.canonical), atol=1e-5)
        R, _ = canonical_rotation(pairs.canonical.astype(np.float64), (0.0, 1.0, 0.0))
        np.testing.assert_allclose(R, np.broadcast_to(np.eye(3), R.shape), atol=1e-5)
    plain = make_pairs(clips, "paper", seed=1, augmentation=Augmentation())
    some = make_pairs(clips, "paper", seed=1, augmentation=Augmentation(mirror_fraction=1.0))
    np.testing.assert_allclose(some.canonical, mirror_canonical(plain.canonical.astype(np.float64)), atol=1e-6)


def test_posture_augmentation_turns_the_upper_body_and_keeps_legs_frame_and_bones():
    from pcnet.models.datasets import Augmentation
    from pcnet.stages.core.canonical import trunk_lean_deg

    clips = load_mocap(FIXTURES / "bandai_small.npz")[:6]
    plain = make_pairs(clips, "paper", seed=2, augmentation=Augmentation())
    posture = Augmentation(trunk_sagittal_sigma_deg=8.0, trunk_lateral_sigma_deg=3.0, head_sagittal_sigma_deg=10.0)
    turned = make_pairs(clips, "paper", seed=2, augmentation=posture)
    # Pelvis and legs as they were, so the hip line and the canonical frame too.
    np.testing.assert_allclose(turned.canonical[:, :7], plain.canonical[:, :7], atol=1e-6)
    R, _ = canonical_rotation(turned.canonical.astype(np.float64), (0.0, 1.0, 0.0))
    np.testing.assert_allclose(R, np.broadcast_to(np.eye(3), R.shape), atol=1e-5)
    np.testing.assert_allclose(turned.inputs, np.einsum("nij,nkj->nki", turned.R, turned.canonical), atol=1e-5)
    for child, parent in enumerate(H36M_PARENTS):
        if parent >= 0:
            np.testing.assert_allclose(np.linalg.norm(turned.canonical[:, child] - turned.canonical[:, parent], axis=-1),
                                       np.linalg.norm(plain.canonical[:, child] - plain.canonical[:, parent], axis=-1),
                                       atol=1e-5)
    # One turn per clip: the change of trunk lean varies between clips, barely within one.
    change = trunk_lean_deg(turned.canonical) - trunk_lean_deg(plain.canonical)
    per_clip = np.array([change[turned.clip == i].mean() for i in range(len(clips))])
    assert per_clip.std() > 2.0
    # Off by default, without touching the random stream of older configs.
    again = make_pairs(clips, "paper", seed=2, augmentation=Augmentation())
    np.testing.assert_array_equal(again.inputs, plain.inputs)


def test_lean_balance_weights_flatten_the_trunk_lean_of_real_mocap():
    from pcnet.models.datasets import lean_balance_weights
    from pcnet.stages.core.canonical import trunk_lean_deg

    clips = load_mocap(BANDAI) + load_mocap(DEEPMIMIC)  # upright takes and floor motions
    canon = world_to_canonical(np.concatenate([c.joints for c in clips]).astype(np.float64))[0]
    lean = trunk_lean_deg(canon)
    trunk = canon[:, 8] - canon[:, 0]
    np.testing.assert_allclose(np.cos(np.radians(lean)), trunk[:, 1] / np.linalg.norm(trunk, axis=-1), atol=1e-9)
    assert (lean > 45).any() and (lean < 5).mean() > 0.2  # the fixture has both kinds
    w = lean_balance_weights(lean, 10.0)
    assert w.min() == 1.0 and w.max() <= 10.0
    common = np.bincount((lean // 5).astype(int)).argmax()
    assert np.all(w[(lean // 5).astype(int) == common] == 1.0)
    assert w[lean > 45].mean() > 3 * w[lean < 5].mean()
    # weighted draws: a larger share of leaning poses than the raw frames
    assert np.average(lean > 15, weights=w) > 1.5 * np.mean(lean > 15)
    assert np.array_equal(lean_balance_weights(lean, 1.0), np.ones(len(canon)))
    missing = canon.copy()
    missing[:3, 8] = np.nan
    assert np.all(lean_balance_weights(trunk_lean_deg(missing), 10.0)[:3] == 1.0)
    with pytest.raises(ValueError, match="cap"):
        lean_balance_weights(lean, 0.5)


def test_root_relative_fills_the_pelvis_from_the_hips_and_centres_on_it():
    """Real VideoPose3D poses: a missing pelvis becomes the hip midpoint before centring; a
    frame without pelvis or hips stays missing (never zeros)."""
    from pcnet.stages.core.conventions import L_HIP, PELVIS, R_HIP, root_relative

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:5].astype(np.float32) + 1.0
    joints[1, PELVIS] = np.nan
    joints[2, [PELVIS, L_HIP]] = np.nan
    rel, filled = root_relative(joints)
    assert rel.dtype == np.float64 and rel.shape == joints.shape
    assert filled.tolist() == [False, True, False, False, False]
    np.testing.assert_allclose(rel[0], joints[0] - joints[0, PELVIS], atol=1e-6)
    mid = 0.5 * (joints[1, L_HIP] + joints[1, R_HIP])
    np.testing.assert_allclose(rel[1, PELVIS + 1 :], joints[1, PELVIS + 1 :] - mid, atol=1e-6)
    assert (rel[1, PELVIS] == 0).all()
    assert np.isnan(rel[2]).all()


def test_sample_views_mixes_two_distributions_half_and_half():
    from pcnet.models.datasets import sample_views

    R = sample_views(4000, "handheld+wide", np.random.default_rng(8))
    _, pitch, roll = rot.decompose_camera_rotation(R)
    wide_only = np.degrees(np.abs(pitch)) > 25  # only the wide views pitch beyond 25 deg (U(-45, 45): 4/9 of them)
    assert 0.17 < wide_only.mean() < 0.27
    assert np.degrees(np.abs(roll)).max() <= 30 + 1e-6
    with pytest.raises(ValueError, match="view distribution"):
        sample_views(3, "paper+fisheye", np.random.default_rng(8))


def test_the_core_functions_name_bad_shapes_and_non_rotations():
    """A user trial got numpy's broadcasting errors from to_canonical and angles for a matrix
    that is no rotation from decompose_camera_rotation: each now says what it expected."""
    from pcnet.stages.core.canonical import to_canonical
    from pcnet.stages.core.errors import InputError

    X = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:5]
    with pytest.raises(InputError, match=r"R: expected \(3, 3\) or \(5, 3, 3\) rotations for 5 poses, got shape \(4, 3, 3\)"):
        to_canonical(X, np.tile(np.eye(3), (4, 1, 1)))
    with pytest.raises(InputError, match=r"joints_cam: expected \(N, J, 3\) poses"):
        to_canonical(X[..., :2], np.eye(3))
    assert to_canonical(X, np.eye(3)).shape == X.shape
    with pytest.raises(InputError, match=r"expected \(\.\.\., 3, 3\) rotations"):
        rot.decompose_camera_rotation(np.ones(3))
    with pytest.raises(InputError, match="not one"):
        rot.decompose_camera_rotation(np.ones((3, 3)))
    nan = np.full((2, 3, 3), np.nan)
    nan[0] = np.eye(3)
    assert np.isnan(rot.decompose_camera_rotation(nan)[1][1])  # a missing rotation stays missing


def test_a_residual_from_another_frame_is_turned_into_the_answers_frame():
    """``to_canonical(..., residual_frame=R_own)`` adds ``residual @ R_own^T @ R``: the same
    camera-frame correction whichever rotation places the body; a frame whose own rotation is
    not finite (the network left it out, residual 0) adds the residual as given."""
    rng = np.random.default_rng(0)
    X = rng.normal(size=(4, 17, 3))
    R, R_own = (Rotation.random(4, random_state=s).as_matrix() for s in (1, 2))
    residual = rng.normal(scale=0.05, size=(4, 17, 3))
    R_own[3] = np.nan
    got = to_canonical(X, R, residual, residual_frame=R_own)
    rigid = (X - X[:, :1]) @ R
    np.testing.assert_allclose(got[:3], (rigid + residual @ np.swapaxes(R_own, 1, 2) @ R)[:3], atol=1e-5)
    np.testing.assert_allclose(got[3], rigid[3] + residual[3], atol=1e-5)
    # the body it describes in the camera frame does not depend on R
    np.testing.assert_allclose(got[:3] @ np.swapaxes(R, 1, 2)[:3],
                               (to_canonical(X, R_own, residual) @ np.swapaxes(R_own, 1, 2))[:3], atol=1e-5)
