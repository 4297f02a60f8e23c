"""The ablation's held-out protocols (benchmarks/ablation.py) on a real mocap walk
(tests/fixtures/mocap_small.npz, Bandai Namco Research Motiondataset, CC BY-NC 4.0): the
measured root (``camera_root_path``: a static camera's view keeps the pelvis path in that
camera's frame, turned by the world->camera rotation and not its transpose), the other clips,
the path from 2D keypoints and the rolled camera."""

from __future__ import annotations

import sys
from types import SimpleNamespace

import numpy as np

from conftest import ROOT

if str(ROOT) not in sys.path:  # benchmarks/ is a package of the repository, not of the installed pcnet
    sys.path.append(str(ROOT))
from benchmarks.ablation import camera_root_path  # noqa: E402
from pcnet.stages.core.canonical import canonical_rotation  # noqa: E402
from pcnet.stages.core.conventions import PELVIS  # noqa: E402
from pcnet.stages.core.rotations import compose_camera_rotation  # noqa: E402

WALK = "dataset-2_walk-turn-left_active_001"


def test_the_pelvis_path_is_turned_into_the_static_camera_frame():
    with np.load(ROOT / "tests" / "fixtures" / "mocap_small.npz") as d:
        W = d[WALK].astype(np.float64)
    frames = np.arange(0, len(W), 3)
    # world -> camera: yaw 60, pitch 15, roll 5 deg; its transpose moves the path by 0.66 m
    C = compose_camera_rotation(np.radians(60.0), np.radians(15.0), np.radians(5.0))
    R_world, _ = canonical_rotation(W[frames], (0.0, 1.0, 0.0))
    path = camera_root_path(SimpleNamespace(joints=W), frames, C @ R_world)  # R: canonical -> camera
    expected = (W[frames, PELVIS] - W[0, PELVIS]) @ C.T
    assert np.ptp(expected, axis=0).max() > 2.0  # the walk covers metres
    np.testing.assert_allclose(path, expected, atol=1e-9)
    assert np.abs(camera_root_path(SimpleNamespace(joints=W), frames, C.T @ R_world) - expected).max() > 0.3


def test_the_other_clips_are_the_rest_of_the_held_out_split():
    # The ablation's untouched floor set: the clips outside the seeded subset, none of them in it.
    from benchmarks.ablation import static_camera_clips
    from pcnet.models.datasets import Clip

    with np.load(ROOT / "tests" / "fixtures" / "mocap_small.npz") as d:
        clips = [Clip(k, d[k].astype(np.float32), 30.0) for k in sorted(d.files)]
    chosen = [c.name for c, *_ in static_camera_clips(clips, 2)]
    rest = [c.name for c, *_ in static_camera_clips(clips, 2, rest=True)]
    assert len(chosen) == 2 and len(rest) == len(clips) - 2 and not set(chosen) & set(rest)
    assert [c.name for c, *_ in static_camera_clips(clips, len(clips), rest=True)] == []


def test_the_monocular_protocol_recovers_the_walks_path_from_its_2d_keypoints():
    # benchmarks/ablation.py keypoint_root_path: the walk 3 m (plus its reach) in front of the
    # camera, seen by a detector with 2 px noise and 5 % wrong detections; the recovered path is
    # the camera-frame pelvis path to a few centimetres (depth the least sure).
    from benchmarks.ablation import camera_view_joints, keypoint_root_path

    with np.load(ROOT / "tests" / "fixtures" / "mocap_small.npz") as d:
        W = d[WALK].astype(np.float64)
    frames = np.arange(len(W))
    C = compose_camera_rotation(np.radians(30.0), np.radians(10.0), 0.0)
    R = C @ canonical_rotation(W, (0.0, 1.0, 0.0))[0]
    clip = SimpleNamespace(joints=W)
    P = camera_view_joints(clip, frames, R)
    relative = P - P[:, PELVIS:PELVIS + 1]
    path = keypoint_root_path(clip, frames, R, relative, 30.0, np.random.default_rng(0))
    pelvis = P[:, PELVIS]
    truth = pelvis - pelvis.mean(0) + [0.0, 0.0, 3.0 + np.linalg.norm(pelvis - pelvis.mean(0), axis=1).max()]
    error = np.linalg.norm(path - truth, axis=1)
    assert np.isfinite(error).all() and np.median(error) < 0.05, np.median(error)
    # a wrong placement (the path without the offset) is metres off
    assert np.median(np.linalg.norm(path - (pelvis - pelvis.mean(0)), axis=1)) > 2.0


def test_the_rolled_camera_protocol_turns_the_poses_and_the_truth_alike():
    # benchmarks/ablation.py rolled_evidence: each cached recording seen by the same camera
    # rolled 30 deg about its optical axis (even clips one way, odd ones the other); the true up
    # turns with the poses, so the body-frame network, which is exactly equivariant, errs by the
    # same angle rolled and unrolled.
    from benchmarks.ablation import ROLL_DEG, deg, extract, rolled_evidence, static_camera_clips
    from pcnet.models.datasets import Clip
    from pcnet.stages.core.rotations import axis_rotation

    with np.load(ROOT / "tests" / "fixtures" / "mocap_small.npz") as d:
        clips = [Clip(WALK, d[WALK].astype(np.float32)[:60], 30.0)] * 2
    evs = []
    for clip, X, R, _ in static_camera_clips(clips, 2):
        ev = extract(X, clip.fps)
        ev.update(name=clip.name, true_up=R[:, :, 1].copy())
        evs.append(ev)
    rolled = rolled_evidence([evs])
    for i, (ev, rv) in enumerate(zip(evs, rolled)):
        assert (rv["set"], rv["index"]) == (0, i)
        Q = axis_rotation("z", np.radians(ROLL_DEG if i % 2 == 0 else -ROLL_DEG))
        np.testing.assert_allclose(rv["true_up"], ev["true_up"] @ Q.T, atol=1e-12)
        np.testing.assert_allclose(rv["J"], ev["J"] @ Q.T.astype(np.float32), atol=1e-5)
        body, body_rolled = ev["R_body"][:, :, 1], rv["R_body"][:, :, 1]
        np.testing.assert_allclose(deg(body_rolled, rv["true_up"]), deg(body, ev["true_up"]), atol=0.05)
