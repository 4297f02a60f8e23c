"""pcnet.adapters on real data: shapes, layouts, NaN for missing, person selection,
left/right and axis checks from physical facts of the recordings, and bad input.

Fixtures (tests/fixtures/README.md) are verbatim cuts of ../shared/data/real. MMPose and
OpenPose have no real files there, so their inputs are the real AlphaPose detections
rewritten in those writers' schemas (MMPose ``demo/topdown_demo_with_mmdet.py`` and
``mmpose/apis/inferencers/base_mmpose_inferencer.py``; OpenPose ``doc/02_output.md``);
DDHPose inputs stack real VideoPose3D poses into its hypothesis axes. Full-data checks
skip without ../shared/data.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from pcnet.adapters import (
    AdapterError,
    Keypoints2D,
    Poses3D,
    available_2d,
    available_3d,
    axes_to_camera,
    get_2d_adapter,
    get_3d_adapter,
    iter_frames,
    load_alphapose,
    load_ddhpose,
    load_generic,
    load_mediapipe_2d,
    load_mediapipe_3d,
    load_mmpose,
    load_motionbert,
    load_openpose,
    load_videopose3d,
    probe_video,
    read_frame,
    register_3d,
)
from conftest import FIXTURES, shared

from pcnet.adapters.registry import unregister
from pcnet.stages.core.conventions import (
    HEAD, L_ANKLE, L_HIP, L_SHOULDER, NECK_NOSE, PELVIS, R_ANKLE, R_HIP, R_SHOULDER, THORAX, get_layout, validate_poses,
)
from pcnet.stages.core.errors import InputError
from pcnet.stages.remap import remap_to_h36m

FIX = FIXTURES

BOXING_AP = FIX / "boxing_alphapose_f000-059.json"  # frames 0-59, one detection each, idx 1
AP809 = FIX / "alphapose809_f130-159.json"  # frames 130-159, two detections in frame 144
BOXING_X3D = FIX / "boxing_X3D_f000-059.npy"
MEDIAPIPE = FIX / "mediapipe_blazepose33_f000-059.npz"  # frames 0-2 have no person
YOGA = {  # 100-frame windows where each pose is held
    "Tadasana": FIX / "yoga_Abhay_Tadasana_f000-099.npy",  # standing, facing the camera
    "Shavasana": FIX / "yoga_Abhay_Shavasana_f200-299.npy",  # lying on the back, side view
    "Bhujangasana": FIX / "yoga_Abhay_Bhujangasana_f150-249.npy",  # cobra: prone, chest up
}
CLIP = FIX / "boxing2_f000-009.mp4"



def raw_entries(path: Path) -> list[dict]:
    return json.loads(path.read_text())


def frac(mask: np.ndarray) -> float:
    return float(np.mean(mask))


def assert_names_file(err: pytest.ExceptionInfo, path: Path) -> None:
    msg = str(err.value)
    assert Path(path).name in msg, msg
    assert "\n" not in msg


# --------------------------------------------------------------------------- types, registry


def test_adapter_error_is_one_line_with_file_field_expected():
    err = AdapterError("/x/y.json", "keypoints", "51 or 78 values\nper detection", got=40)
    assert isinstance(err, ValueError)
    assert str(err) == "file '/x/y.json': field 'keypoints': expected 51 or 78 values per detection, got 40"
    assert (err.path, err.field, err.got) == ("/x/y.json", "keypoints", 40)


def test_result_types_validate_their_arrays():
    pts = np.zeros((2, 17, 3), np.float32)
    assert Keypoints2D(pts, "coco17", "a").num_frames == 2
    with pytest.raises(ValueError, match="shape"):
        Keypoints2D(pts, "halpe26", "a")
    with pytest.raises(ValueError, match="float32"):
        Keypoints2D(pts.astype(np.float64), "coco17", "a")
    with pytest.raises(ValueError, match="units"):
        Poses3D(pts, "h36m17", units="mm")
    with pytest.raises(ValueError, match="camera"):
        Poses3D(pts, "h36m17", frame="world")


def test_registry_lists_and_returns_builtin_adapters():
    assert available_2d() == ["alphapose", "mediapipe", "mmpose", "openpose"]
    assert available_3d() == ["azure_kinect", "ddhpose", "generic", "kinect_v1", "mediapipe", "motionbert", "videopose3d"]
    kp = get_2d_adapter("alphapose").load(BOXING_AP, num_frames=70)
    assert isinstance(kp, Keypoints2D) and kp.num_frames == 70
    assert isinstance(get_3d_adapter("videopose3d").load(YOGA["Tadasana"]), Poses3D)
    with pytest.raises(ValueError, match="available"):
        get_2d_adapter("no_such_detector")


def test_registering_a_user_adapter(tmp_path):
    @register_3d("test_rub_mm")
    class RubMillimetres:
        def load(self, path, **options):
            return load_generic(path, axes="RUB", units="mm")

    try:
        assert "test_rub_mm" in available_3d()
        base = np.load(YOGA["Tadasana"])
        np.save(tmp_path / "p.npy", base * np.array([1000, -1000, -1000], np.float32))
        out = get_3d_adapter("test_rub_mm").load(tmp_path / "p.npy")
        np.testing.assert_allclose(out.joints, base, atol=1e-6)
        from pcnet.pipeline.config import RunConfig
        from pcnet.pipeline.runner import run_pipeline

        result = run_pipeline(RunConfig(lifter="test_rub_mm", lifter_output=str(tmp_path / "p.npy"), fps=30.0,
                                        method="geometric", recording=False, out=str(tmp_path / "o")).validate(),
                              progress=False)
        assert result.frames == len(base) and (tmp_path / "o" / "canonical.npz").is_file()
        with pytest.raises(ValueError, match="already used"):
            register_3d("test_rub_mm")(type("Other", (), {"load": lambda self, p: None}))
        with pytest.raises(TypeError, match="load"):
            register_3d("test_no_load")(type("NoLoad", (), {}))
    finally:
        unregister("test_rub_mm", "3d")
    assert "test_rub_mm" not in available_3d()
    from pcnet.stages.core.errors import InputError

    with pytest.raises(InputError, match="field 'lifter': expected one of"):
        RunConfig(lifter="test_rub_mm", lifter_output=str(tmp_path / "p.npy"), fps=30.0).validate()


# --------------------------------------------------------------------------- AlphaPose


def test_alphapose_boxing_shapes_and_confidence_clipping():
    kp = load_alphapose(BOXING_AP)
    raw = np.array([e["keypoints"] for e in raw_entries(BOXING_AP)], np.float32).reshape(60, 26, 3)
    assert kp.points.shape == (60, 26, 3) and kp.points.dtype == np.float32
    assert kp.layout == "halpe26" and kp.track_id == 1
    np.testing.assert_array_equal(kp.points[..., :2], raw[..., :2])
    assert raw[..., 2].max() > 1.0  # AlphaPose scores are not bounded by 1 ...
    assert kp.points[..., 2].max() == 1.0  # ... so the adapter clips them
    np.testing.assert_array_equal(kp.points[..., 2], np.clip(raw[..., 2], 0, 1))
    assert "clipped" in kp.notes


def test_alphapose_boxing_left_right_after_remap():
    # The boxer faces image-left (towards the bag) in an orthodox stance: toes point left
    # and the left (lead) foot is the one further left in the image.
    kp = load_alphapose(BOXING_AP)
    halpe = kp.points
    assert frac(halpe[:, 20, 0] < halpe[:, 24, 0]) == 1.0  # left big toe ahead of left heel
    h36m = remap_to_h36m(kp.points, kp.layout, confidence_channel=True)
    assert frac(h36m[:, L_ANKLE, 0] < h36m[:, R_ANKLE, 0]) == 1.0
    assert frac(h36m[:, L_HIP, 0] < h36m[:, R_HIP, 0]) > 0.7
    assert frac(h36m[:, NECK_NOSE, 0] < h36m[:, PELVIS, 0]) == 1.0


def test_alphapose_809_two_people_frame_is_deterministic(tmp_path):
    entries = raw_entries(AP809)
    in_144 = [e for e in entries if e["image_id"] == "144.jpg"]
    assert len(in_144) == 2 and in_144[0]["score"] > in_144[1]["score"]
    kp = load_alphapose(AP809)
    # Frames are indexed by image_id: the cut starts at frame 130, so 0-129 are NaN.
    assert kp.points.shape == (160, 26, 3)
    assert np.isnan(kp.points[:130]).all() and np.isfinite(kp.points[130:]).all()
    assert kp.track_id == 0  # list-form idx [0.0] / [[0.0], [0.0]] without a tracker
    best = np.array(in_144[0]["keypoints"], np.float32).reshape(26, 3)
    np.testing.assert_array_equal(kp.points[144, :, :2], best[:, :2])
    assert "[144]" in kp.notes and "list-form" in kp.notes
    # the summary's choice line says --person cannot pick the other person (one id for all)
    assert "without a tracker" in kp.choice and "--person cannot choose another" in kp.choice
    # File order does not matter.
    rev = tmp_path / "reversed.json"
    rev.write_text(json.dumps(entries[::-1]))
    np.testing.assert_array_equal(load_alphapose(rev).points, kp.points)
    np.testing.assert_array_equal(load_alphapose(AP809, person=0).points, kp.points)
    with pytest.raises(AdapterError, match="idx") as err:
        load_alphapose(AP809, person=1)
    assert_names_file(err, AP809)


def test_alphapose_track_choice_by_summed_score_and_tie_break(tmp_path):
    entries = raw_entries(BOXING_AP)
    # Track 7: frames 0-29 only, better per frame (score + 1) but a lower sum over the video.
    intruder = []
    for e in entries[:30]:
        f = dict(e, idx=7, score=e["score"] + 1.0)
        f["keypoints"] = [v + 100.0 if i % 3 == 0 else v for i, v in enumerate(e["keypoints"])]
        intruder.append(f)
    path = tmp_path / "two_tracks.json"
    path.write_text(json.dumps(intruder + entries))
    base = load_alphapose(BOXING_AP).points
    chosen = load_alphapose(path)
    assert chosen.track_id == 1
    np.testing.assert_array_equal(chosen.points, base)
    seven = load_alphapose(path, person=7)
    assert seven.track_id == 7 and seven.points.shape == (60, 26, 3)
    np.testing.assert_array_equal(seven.points[:30, :, 0], base[:30, :, 0] + 100.0)
    assert np.isnan(seven.points[30:]).all()
    # Equal sums: the lower id wins, whatever the order in the file.
    tie = tmp_path / "tie.json"
    tie.write_text(json.dumps([dict(e, idx=4) for e in entries] + [dict(e, idx=2) for e in entries]))
    assert load_alphapose(tie).track_id == 2


def test_alphapose_frames_and_layouts(tmp_path):
    padded = load_alphapose(BOXING_AP, num_frames=75)
    assert padded.points.shape == (75, 26, 3) and np.isnan(padded.points[60:]).all()
    with pytest.raises(AdapterError, match="num_frames"):
        load_alphapose(BOXING_AP, num_frames=50)
    coco = tmp_path / "coco.json"
    coco.write_text(json.dumps([dict(e, keypoints=e["keypoints"][:51]) for e in raw_entries(BOXING_AP)]))
    kp = load_alphapose(coco)
    assert kp.layout == "coco17" and kp.points.shape == (60, 17, 3)
    np.testing.assert_array_equal(kp.points[..., :2], load_alphapose(BOXING_AP).points[:, :17, :2])


# --------------------------------------------------------------------------- MMPose (real detections, MMPose schema)


def _mm_instance(e: dict, n: int | None = None) -> dict:
    kp = np.array(e["keypoints"]).reshape(-1, 3)[:n]
    x, y, w, h = e["box"]
    return {"keypoints": kp[:, :2].tolist(), "keypoint_scores": kp[:, 2].tolist(),
            "bbox": [[x, y, x + w, y + h]], "bbox_score": e["score"]}


def _mm_frames(entries: list[dict], base: int, n: int | None = None) -> list[dict]:
    by_frame: dict[int, list] = {}
    for e in entries:
        by_frame.setdefault(int(e["image_id"][:-4]), []).append(_mm_instance(e, n))
    return [{"frame_id": f + base, "instances": inst} for f, inst in sorted(by_frame.items())]


def test_mmpose_both_writers_match_alphapose(tmp_path):
    entries = raw_entries(AP809)
    demo = tmp_path / "demo_preds.json"  # topdown_demo_with_mmdet: 1-based frame_id
    demo.write_text(json.dumps({"meta_info": {"dataset_name": "halpe26"}, "instance_info": _mm_frames(entries, 1)}))
    infer = tmp_path / "video.json"  # MMPoseInferencer: 0-based frame_id
    infer.write_text(json.dumps(_mm_frames(entries, 0)))
    ref = load_alphapose(AP809).points
    for path in (demo, infer):
        kp = load_mmpose(path)
        assert kp.layout == "halpe26" and kp.points.shape == (160, 26, 3) and kp.track_id is None
        # Frame 144: the instance with the higher mean keypoint score is AlphaPose's choice too.
        np.testing.assert_array_equal(kp.points, ref)
    assert "1-based" in load_mmpose(demo).notes and "0-based" in load_mmpose(infer).notes
    second = load_mmpose(infer, person=1)
    assert np.isfinite(second.points).all(axis=(1, 2)).nonzero()[0].tolist() == [144]
    other = np.array([e for e in entries if e["image_id"] == "144.jpg"][1]["keypoints"]).reshape(26, 3)
    np.testing.assert_allclose(second.points[144, :, :2], other[:, :2])


def test_mmpose_wholebody_and_single_image(tmp_path):
    entries = raw_entries(BOXING_AP)
    frames = _mm_frames(entries, 0, n=17)
    for fr in frames:  # COCO-WholeBody: 17 body joints then 116 feet/face/hands
        for inst in fr["instances"]:
            inst["keypoints"] += [[0.0, 0.0]] * 116
            inst["keypoint_scores"] += [0.0] * 116
    wb = tmp_path / "wholebody.json"
    wb.write_text(json.dumps(frames))
    kp = load_mmpose(wb)
    assert kp.layout == "coco17" and kp.points.shape == (60, 17, 3)
    np.testing.assert_allclose(kp.points[..., :2], load_alphapose(BOXING_AP).points[:, :17, :2])
    single = tmp_path / "image.json"
    single.write_text(json.dumps([_mm_instance(entries[5])]))
    one = load_mmpose(single)
    assert one.points.shape == (1, 26, 3)
    np.testing.assert_allclose(one.points[0, :, :2], load_alphapose(BOXING_AP).points[5, :, :2])


def test_mmpose_and_alphapose_refuse_each_others_files(tmp_path):
    mm = tmp_path / "mm.json"
    mm.write_text(json.dumps(_mm_frames(raw_entries(BOXING_AP), 0)))
    with pytest.raises(AdapterError, match="image_id") as err:
        load_alphapose(mm)
    assert_names_file(err, mm)
    with pytest.raises(AdapterError, match="frame_id") as err:
        load_mmpose(BOXING_AP)
    assert_names_file(err, BOXING_AP)
    demo_dict = tmp_path / "dict.json"
    demo_dict.write_text(json.dumps({"meta_info": {}, "instance_info": _mm_frames(raw_entries(BOXING_AP), 1)}))
    with pytest.raises(AdapterError, match="list of detections") as err:
        load_alphapose(demo_dict)
    assert_names_file(err, demo_dict)


def test_mmpose_refuses_a_repeated_frame_id(tmp_path):
    """Each MMPose writer gives a frame one record; a repeat (an edit, two files joined) would
    pool two frames' people and leave a frame empty, so it is refused in one line."""
    frames = _mm_frames(raw_entries(BOXING_AP), 0)
    frames[4]["frame_id"] = 3
    bad = tmp_path / "repeat.json"
    bad.write_text(json.dumps(frames))
    with pytest.raises(AdapterError, match=r"\[4\]\.frame_id.*one record per frame.*video frame 3") as err:
        load_mmpose(bad)
    assert_names_file(err, bad)


def test_mmpose_wrong_joint_count(tmp_path):
    bad = tmp_path / "twenty.json"
    bad.write_text(json.dumps(_mm_frames(raw_entries(BOXING_AP), 0, n=20)))
    with pytest.raises(AdapterError, match="20 joints") as err:
        load_mmpose(bad)
    assert_names_file(err, bad)


# --------------------------------------------------------------------------- OpenPose (real detections, OpenPose schema)


def _write_openpose(folder: Path, people_by_frame: dict[int, list[list[float]]]) -> Path:
    folder.mkdir()
    for frame, people in people_by_frame.items():
        doc = {"version": 1.3, "people": [
            {"person_id": [-1], "pose_keypoints_2d": kp, "face_keypoints_2d": [],
             "hand_left_keypoints_2d": [], "hand_right_keypoints_2d": []} for kp in people]}
        (folder / f"clip_{frame:012d}_keypoints.json").write_text(json.dumps(doc))
    return folder


def _halpe_people(entries: list[dict]) -> dict[int, list[list[float]]]:
    by_frame: dict[int, list] = {}
    for e in entries[::-1]:  # frame 144: the weaker detection comes first
        by_frame.setdefault(int(e["image_id"][:-4]), []).append(list(e["keypoints"]))
    return by_frame


def test_openpose_folder_selection_and_missing(tmp_path):
    people = _halpe_people(raw_entries(AP809))
    del people[135]  # no file for this frame
    people[140] = []  # a file with nobody
    people[131][0][3 * 11: 3 * 11 + 3] = [0.0, 0.0, 0.0]  # undetected left hip
    kp = load_openpose(_write_openpose(tmp_path / "op", people))
    ref = load_alphapose(AP809).points
    assert kp.layout == "halpe26" and kp.points.shape == (160, 26, 3)
    assert np.isnan(kp.points[[135, 140]]).all() and np.isnan(kp.points[:130]).all()
    assert np.isnan(kp.points[131, 11]).all() and np.isfinite(kp.points[131, 12]).all()
    keep = [f for f in range(130, 160) if f not in (131, 135, 140)]
    np.testing.assert_array_equal(kp.points[keep], ref[keep])  # incl. frame 144's stronger person
    assert kp.choice.startswith("per frame the person with the highest summed confidence, in 1 frame holding several")
    assert "--person cannot follow one" in kp.choice


def test_openpose_body25_from_real_detections(tmp_path):
    halpe, body25 = get_layout("halpe26"), get_layout("body25")
    names = {n: i for i, n in enumerate(halpe.joints)} | {"mid_hip": halpe.joints.index("hip")}
    order = [names[n] for n in body25.joints]
    ref = load_alphapose(BOXING_AP)
    people = {f: [ref.points[f, order].ravel().tolist()] for f in range(60)}
    kp = load_openpose(_write_openpose(tmp_path / "b25", people))
    assert kp.layout == "body25" and kp.points.shape == (60, 25, 3)
    a = remap_to_h36m(kp.points, "body25", confidence_channel=True)
    b = remap_to_h36m(ref.points, "halpe26", confidence_channel=True)
    same = [k for k in range(17) if k != HEAD]  # BODY_25 has no head top: mid-eyes instead
    np.testing.assert_allclose(a[:, same], b[:, same], atol=1e-4)
    assert frac(a[:, L_ANKLE, 0] < a[:, R_ANKLE, 0]) == 1.0


def test_openpose_bad_inputs(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(AdapterError, match="keypoints.json") as err:
        load_openpose(empty)
    assert_names_file(err, empty)
    with pytest.raises(AdapterError, match="folder"):
        load_openpose(BOXING_AP)
    wrong = tmp_path / "wrong"
    wrong.mkdir()
    bad_file = wrong / "clip_000000000000_keypoints.json"
    bad_file.write_text(BOXING_AP.read_text())  # an AlphaPose list, not an OpenPose frame
    with pytest.raises(AdapterError, match="people") as err:
        load_openpose(wrong)
    assert_names_file(err, bad_file)
    coco18 = _write_openpose(tmp_path / "coco18", {0: [[1.0, 2.0, 0.5] * 18]})
    with pytest.raises(AdapterError, match="18 joints"):
        load_openpose(coco18)


# --------------------------------------------------------------------------- MediaPipe


def test_mediapipe_2d_shapes_nan_and_left_right():
    kp = load_mediapipe_2d(MEDIAPIPE)
    assert kp.layout == "blazepose33" and kp.points.shape == (60, 33, 3)
    empty = np.isnan(kp.points).all(axis=(1, 2))
    assert empty.nonzero()[0].tolist() == [0, 1, 2]  # MediaPipe found nobody there
    assert np.isfinite(kp.points[3:]).all()
    assert np.nanmin(kp.points[..., 2]) >= 0 and np.nanmax(kp.points[..., 2]) <= 1
    # Frames 3-59: the man on the box faces the camera, so his left is image right.
    h36m = remap_to_h36m(kp.points[3:], kp.layout, confidence_channel=True)
    assert frac(h36m[:, L_HIP, 0] > h36m[:, R_HIP, 0]) > 0.85
    assert frac(h36m[:, L_SHOULDER, 0] > h36m[:, R_SHOULDER, 0]) > 0.85


def test_mediapipe_world_landmarks_are_in_the_camera_frame():
    p3 = load_mediapipe_3d(MEDIAPIPE)
    assert p3.units == "m" and p3.frame == "camera" and p3.layout == "blazepose33"
    assert np.isnan(p3.joints[:3]).all()
    h = remap_to_h36m(p3.joints[3:], p3.layout)
    assert np.abs(h[:, PELVIS]).max() < 0.01  # MediaPipe's origin is the mid-hip
    # Facing the camera: left at +x (right in the image), nose nearer (smaller z) than the
    # pelvis, head above (smaller y) the ankles; metres: hips about 0.1-0.4 m apart.
    assert frac(h[:, L_HIP, 0] > h[:, R_HIP, 0]) > 0.85
    assert frac(h[:, NECK_NOSE, 2] < h[:, PELVIS, 2]) > 0.85
    assert frac(h[:, HEAD, 1] < np.minimum(h[:, L_ANKLE, 1], h[:, R_ANKLE, 1])) > 0.9
    hip_width = np.linalg.norm(h[:, L_HIP] - h[:, R_HIP], axis=-1)
    assert 0.1 < np.median(hip_width) < 0.4
    # The 3D left/right agrees with the 2D one frame by frame.
    kp = remap_to_h36m(load_mediapipe_2d(MEDIAPIPE).points[3:], "blazepose33")
    agree = np.sign(kp[:, L_HIP, 0] - kp[:, R_HIP, 0]) == np.sign(h[:, L_HIP, 0] - h[:, R_HIP, 0])
    assert frac(agree) > 0.85


def test_mediapipe_world_landmarks_are_turned_from_the_virtual_camera_into_the_real_one(tmp_path):
    from pcnet.stages.core.perspective import focal_px_from_35mm, intrinsics, virtual_camera_rotation

    delivered = load_mediapipe_3d(MEDIAPIPE, real_camera=False)
    assert delivered.summary_note == ""
    mp = dict(np.load(MEDIAPIPE))
    hips = (mp["keypoints_2d"][:, 23, :2].astype(np.float64) + mp["keypoints_2d"][:, 24, :2]) / 2
    width, height = float(mp["width"]), float(mp["height"])

    def expected(K):
        return np.einsum("tij,tkj->tki", virtual_camera_rotation(hips, K), delivered.joints)

    # No K in the file: a phone's 26 mm equivalent, principal point at the image centre.
    read = load_mediapipe_3d(MEDIAPIPE)
    np.testing.assert_allclose(read.joints, expected(intrinsics(width, height, focal_px_from_35mm(width, height))),
                               atol=1e-5)
    assert "assumed" in read.summary_note and "--focal-px" in read.summary_note
    assert np.isnan(read.joints[:3]).all()  # no person: still NaN
    # The turn is a rotation: bone lengths unchanged; it is not the identity here.
    def shoulder_to_hip(J):
        return np.linalg.norm(J[3:, 11] - J[3:, 23], axis=-1)

    np.testing.assert_allclose(shoulder_to_hip(read.joints), shoulder_to_hip(delivered.joints), rtol=1e-5)
    assert np.abs(read.joints[3:] - delivered.joints[3:]).max() > 0.01
    # --focal-px wins over everything; the file's K over the default.
    np.testing.assert_allclose(load_mediapipe_3d(MEDIAPIPE, focal_px=2000.0).joints,
                               expected(intrinsics(width, height, 2000.0)), atol=1e-5)
    K = np.array([[1500.0, 0.0, 700.0], [0.0, 1500.0, 400.0], [0.0, 0.0, 1.0]])
    with_k = tmp_path / "with_k.npz"
    np.savez(with_k, **mp, K=K)
    read_k = load_mediapipe_3d(with_k)
    np.testing.assert_allclose(read_k.joints, expected(K), atol=1e-5)
    assert "the file's K" in read_k.summary_note
    assert get_3d_adapter("mediapipe").load(with_k, focal_px=2000.0).summary_note.startswith("MediaPipe world")
    for bad_k in (np.eye(2), np.diag([0.0, 1.0, 1.0]), np.full((3, 3), np.nan)):
        bad = tmp_path / "bad_k.npz"
        np.savez(bad, **mp, K=bad_k)
        with pytest.raises(AdapterError, match="K") as err:
            load_mediapipe_3d(bad)
        assert_names_file(err, bad)
    for bad_focal in (0.0, -5.0, float("nan"), True):
        with pytest.raises(AdapterError, match="focal_px"):
            load_mediapipe_3d(MEDIAPIPE, focal_px=bad_focal)
    # Without what the turn needs, the landmarks are read as delivered and the note says why.
    no_size = tmp_path / "no_size.npz"
    np.savez(no_size, **{k: v for k, v in mp.items() if k not in ("width", "height")})
    read_ns = load_mediapipe_3d(no_size)
    np.testing.assert_array_equal(read_ns.joints, delivered.joints)
    assert "neither K nor width/height" in read_ns.summary_note
    with pytest.raises(AdapterError, match="width/height"):
        load_mediapipe_3d(no_size, focal_px=1000.0)
    no_2d = tmp_path / "no_2d.npz"
    np.savez(no_2d, **{k: v for k, v in mp.items() if k != "keypoints_2d"})
    assert "no keypoints_2d" in load_mediapipe_3d(no_2d).summary_note


def test_mediapipe_full_file_nan_frames():
    path = shared("real", "sports2d_demo", "mediapipe_blazepose33.npz")
    kp, p3 = load_mediapipe_2d(path), load_mediapipe_3d(path)
    assert kp.points.shape == p3.joints.shape == (230, 33, 3)
    empty = np.isnan(p3.joints).all(axis=(1, 2)).nonzero()[0].tolist()
    assert empty == [0, 1, 2, 169, 201, 227, 228, 229]
    assert np.isnan(kp.points).all(axis=(1, 2)).nonzero()[0].tolist() == empty


# --------------------------------------------------------------------------- MotionBERT


def test_motionbert_fixture_units_and_notes():
    p3 = load_motionbert(BOXING_X3D)
    assert p3.joints.shape == (60, 17, 3) and p3.layout == "h36m17" and p3.units == "normalised"
    assert p3.joints[0, PELVIS, 2] == 0.0  # first frame of a 243-frame clip
    assert "each 243-frame clip on its own and zeroes its first frame's root z" in p3.notes
    assert "the whole pose may jump there" in p3.notes  # not the root alone (a cycling trial)
    assert np.abs(p3.joints).max() < 1.5


def test_motionbert_refuses_its_2d_input_given_as_its_output(tmp_path):
    """MotionBERT's input (x, y, confidence), passed as X3D.npy, was read as depths and gave a
    result (a developer trial); the real X3D's z has joints in front of the root."""
    from pcnet.adapters.types import AdapterError

    x3d = np.load(BOXING_X3D, allow_pickle=False)
    conf = np.random.default_rng(0).uniform(0.4, 0.98, x3d.shape[:2])
    as_input = np.concatenate([x3d[..., :2], conf[..., None]], -1).astype(np.float32)
    np.save(tmp_path / "input2d.npy", as_input)
    with pytest.raises(AdapterError, match=r"field 'X3D z': .* got z in \[0\.40, 0\.98\] everywhere, the first root at "
                                           r"0\.\d\d: 2D keypoints with confidences \(MotionBERT's input\)"):
        load_motionbert(tmp_path / "input2d.npy")
    assert (x3d[..., 2] < 0).any()  # the real file passes: joints in front of the root


def test_motionbert_notes_a_root_at_the_origin():
    """A real VideoPose3D export (pelvis at the origin in every frame) read as MotionBERT passes
    as 'normalised': MotionBERT's --rootrel output looks the same, so it is noted, naming both;
    MotionBERT's default output (root at its image position) is not."""
    poses = load_motionbert(YOGA["Tadasana"])
    assert poses.summary_note in poses.notes  # shown as a note line of the run summary
    assert poses.summary_note.startswith("pelvis at the origin") and "infer_wild --rootrel" in poses.summary_note \
        and "--lifter videopose3d" in poses.summary_note
    from pcnet.stages.flags import shortened  # the summary's form keeps the hint (a trial's was cut off before it)

    assert "--lifter videopose3d" in shortened(poses.summary_note)
    assert load_motionbert(BOXING_X3D).summary_note == ""


def test_motionbert_axes_on_the_boxer():
    h = load_motionbert(BOXING_X3D).joints
    assert frac(h[:, HEAD, 1] < h[:, PELVIS, 1]) == 1.0  # y down
    # Facing image-left with the left side towards the camera (left = up x forward):
    assert frac(h[:, L_HIP, 2] < h[:, R_HIP, 2]) == 1.0
    assert frac(h[:, L_SHOULDER, 2] < h[:, R_SHOULDER, 2]) == 1.0
    assert frac(h[:, L_ANKLE, 0] < h[:, R_ANKLE, 0]) == 1.0  # lead foot, as in the 2D


def test_motionbert_pixel_mode(tmp_path):
    norm = np.load(BOXING_X3D)
    w, h = 854, 480  # infer_wild --pixel: out * min(w, h) / 2, then x, y += (w/2, h/2)
    px = norm * (min(w, h) / 2)
    px[..., :2] += [w / 2, h / 2]
    path = tmp_path / "X3D_pixel.npy"
    np.save(path, px.astype(np.float32))
    p3 = load_motionbert(path, pixel=True)
    assert p3.units == "px"
    np.testing.assert_allclose(p3.joints, px, rtol=1e-6)
    with pytest.raises(AdapterError, match="pixel=True") as err:
        load_motionbert(path)
    assert_names_file(err, path)
    with pytest.raises(AdapterError, match="pixel=False"):
        load_motionbert(BOXING_X3D, pixel=True)


def test_motionbert_full_file_clip_boundary():
    p3 = load_motionbert(shared("real", "boxing_motionbert", "X3D.npy"))
    assert p3.joints.shape == (301, 17, 3)
    assert p3.joints[0, PELVIS, 2] == 0.0 and p3.joints[243, PELVIS, 2] == 0.0
    assert p3.joints[242, PELVIS, 2] != 0.0
    assert "0, 243" in p3.notes


# --------------------------------------------------------------------------- DDHPose / D3DP


_NOT_ROOT = (np.arange(17) > 0).astype(np.float32)[:, None]


def _hypotheses(tmp_path: Path) -> tuple[np.ndarray, Path, Path]:
    base = np.load(YOGA["Tadasana"])
    k, hyp = 2, 3
    offset = np.array([[k_ * 0.1 + (h_ - 1) * 0.01 for h_ in range(hyp)] for k_ in range(k)], np.float32)
    # every joint but the root, which D3DP's evaluate_diffusion zeroes in each hypothesis
    arr5 = base[None, None] + offset[:, :, None, None, None] * _NOT_ROOT  # (K, H, N, 17, 3)
    p5, p4 = tmp_path / "test_3d_yoga_output.npy", tmp_path / "four.npy"
    np.save(p5, arr5)
    np.save(p4, arr5[0])
    return base, p5, p4


def test_ddhpose_steps_and_hypotheses(tmp_path):
    base, p5, p4 = _hypotheses(tmp_path)
    mean = load_ddhpose(p5)  # last step, mean over hypotheses
    assert mean.joints.shape == (100, 17, 3) and mean.units == "m" and mean.layout == "h36m17"
    np.testing.assert_allclose(mean.joints, base + 0.1 * _NOT_ROOT, atol=1e-6)
    np.testing.assert_allclose(load_ddhpose(p5, step=0).joints, base, atol=1e-6)
    np.testing.assert_allclose(load_ddhpose(p5, hypothesis=2).joints, base + 0.11 * _NOT_ROOT, atol=1e-6)
    np.testing.assert_allclose(load_ddhpose(p4, hypothesis=0).joints, base - 0.01 * _NOT_ROOT, atol=1e-6)
    with pytest.raises(AdapterError, match="MotionBERT's infer_wild output"):  # a root kept in the image
        load_ddhpose(BOXING_X3D)
    np.testing.assert_allclose(load_ddhpose(YOGA["Tadasana"]).joints, base)
    assert "hypothesis 2" in load_ddhpose(p5, hypothesis=2).notes


def test_ddhpose_mean_skips_hypotheses_without_a_joint(tmp_path):
    """Non-finite is missing data: a hypothesis that lacks a joint (or all of them) leaves the
    mean of the others, not a missing joint or a refused file."""
    base, _, p4 = _hypotheses(tmp_path)
    arr = np.load(p4)  # (3, N, 17, 3): hypotheses at -0.01, 0, +0.01
    arr[0] = np.inf
    arr[1, 5, 12] = np.nan
    np.save(tmp_path / "gaps.npy", arr)
    poses = load_ddhpose(tmp_path / "gaps.npy")
    expected = base + 0.005 * _NOT_ROOT
    expected[5, 12] = base[5, 12] + 0.01
    np.testing.assert_allclose(poses.joints, expected, atol=1e-6)
    assert "from the hypotheses that have them" in poses.notes


def test_ddhpose_bad_options_and_files(tmp_path):
    _, p5, _ = _hypotheses(tmp_path)
    for kwargs in ({"hypothesis": 3}, {"hypothesis": "median"}, {"step": 2}):
        with pytest.raises(AdapterError) as err:
            load_ddhpose(p5, **kwargs)
        assert_names_file(err, p5)
    with pytest.raises(AdapterError, match="hypothesis"):
        load_ddhpose(YOGA["Tadasana"], hypothesis=1)
    post = tmp_path / "test_3d_output_yoga_postprocess.npy"
    np.save(post, np.load(YOGA["Tadasana"]))
    with pytest.raises(AdapterError, match="_postprocess"):
        load_ddhpose(post)
    mat = tmp_path / "inference_data_P_Agg.mat"
    mat.write_bytes(b"MATLAB 5.0")
    with pytest.raises(AdapterError, match="MPI-INF-3DHP"):
        load_ddhpose(mat)
    # frames and hypotheses swapped, as user code often stores them: averaged 100 "hypotheses"
    # into 3 frames before (a developer trial's exit 0 with 5 frames of a 1521-frame clip)
    swapped = tmp_path / "frames_first.npy"
    np.save(swapped, np.swapaxes(np.load(p5)[-1], 0, 1))
    with pytest.raises(AdapterError, match=r"fewer hypotheses than frames, got 100 'hypotheses' of 3 frames: frames "
                                           r"first\? np\.swapaxes\(a, -4, -3\)") as err:
        load_ddhpose(swapped)
    assert_names_file(err, swapped)
    # a clip shorter than its hypotheses count has the same shape (a bad-input trial's 3-frame clip of 100 read
    # only as swapped): the line says how to give it, and that way is read
    assert "a clip shorter than its hypotheses count looks the same: save one of them, a[h]" in str(err.value)
    short = np.load(p5)[-1, :, :2]  # 3 hypotheses of 2 frames
    np.save(tmp_path / "short.npy", short)
    with pytest.raises(AdapterError, match="a clip shorter than its hypotheses count"):
        load_ddhpose(tmp_path / "short.npy")
    np.save(tmp_path / "short_mean.npy", short.mean(axis=0))
    np.testing.assert_allclose(load_ddhpose(tmp_path / "short_mean.npy").joints, short.mean(axis=0), atol=1e-6)


def test_motionbert_clip_starts_are_the_poses_breaks():
    """MotionBERT lifts each clip_len-frame clip on its own, so the pose may jump where the
    next starts: those frames are the Poses3D's breaks, which the pipeline differentiates
    nothing across (a cycling trial's seam read as a 397 deg/s knee)."""
    from pcnet.adapters import Poses3D

    assert load_motionbert(BOXING_X3D).breaks == ()  # 60 frames: one clip
    assert load_motionbert(BOXING_X3D, clip_len=20).breaks == (20, 40)
    joints = np.zeros((5, 17, 3), np.float32)
    for bad in ((0,), (5,), (3, 2), (2, 2), (True,)):
        with pytest.raises(ValueError, match="breaks must be ascending frame indices in 1..4"):
            Poses3D(joints, "h36m17", breaks=bad)


def test_lifter_files_shaped_as_upstream_code_saves_them_name_the_fix(tmp_path):
    """A batch of one recording and joints-first arrays get the line that says what they
    look like (a developer trial read "(..., 17, 3) with 3 dimensions")."""
    x3d = np.load(BOXING_X3D)
    np.save(tmp_path / "batch.npy", x3d[None])
    np.save(tmp_path / "joints_first.npy", np.swapaxes(x3d, 0, 1))
    with pytest.raises(AdapterError, match=r"expected shape \(T, 17, 3\), got shape \(1, 60, 17, 3\) \(a leading "
                                           r"batch axis of one\? save a\[0\]\)"):
        load_motionbert(tmp_path / "batch.npy")
    with pytest.raises(AdapterError, match=r"got shape \(17, 60, 3\) \(axes in another order\? np\.transpose\(a, "
                                           r"\(1, 0, 2\)\) gives \(T, 17, 3\)\)"):
        load_motionbert(tmp_path / "joints_first.npy")
    # every order of the three axes gets the transpose that undoes it (an ergonomist's (20, 3, T) got no hint)
    for axes in ((1, 2, 0), (2, 1, 0), (0, 2, 1), (2, 0, 1)):
        shuffled = np.transpose(x3d, axes)
        np.save(tmp_path / "shuffled.npy", shuffled)
        with pytest.raises(AdapterError, match=r"np\.transpose\(a, \((\d), (\d), (\d)\)\)") as caught:
            load_generic(tmp_path / "shuffled.npy")
        undo = tuple(int(a) for a in re.search(r"transpose\(a, \((\d), (\d), (\d)\)", str(caught.value)).groups())
        np.testing.assert_array_equal(np.transpose(shuffled, undo), x3d)


def test_a_flat_skeleton_or_2d_keypoints_given_as_3d_poses_are_refused(tmp_path):
    """A 2D projection saved with z = 0 ran to exit 0 with a "95 %" interval missing the real
    file's pitch, and 2D keypoints with confidences given to a metric lifter read "millimetres
    or centimetres given as metres?" (a developer trial)."""
    flat = np.load(YOGA["Tadasana"])
    flat[..., 2] = 0.0
    np.save(tmp_path / "flat.npy", flat)
    with pytest.raises(AdapterError, match=r"expected 3D joints .* got every frame's joints at one z \(z = 0 in frame "
                                           r"0\): a 2D projection or 2D keypoints given as 3D poses\?") as err:
        load_videopose3d(tmp_path / "flat.npy")
    assert_names_file(err, tmp_path / "flat.npy")
    with pytest.raises(InputError, match="at one z"):
        validate_poses(flat)
    validate_poses(np.load(YOGA["Tadasana"]))  # a real skeleton has depth
    keypoints = np.load(YOGA["Tadasana"]) * np.float32([900, 900, 0]) + np.float32([960, 540, 0.0])
    keypoints[..., 2] = np.random.default_rng(0).uniform(0.2, 1.1, keypoints.shape[:2])  # AlphaPose scores pass 1
    np.save(tmp_path / "keypoints.npy", keypoints)
    with pytest.raises(AdapterError, match=r"2D keypoints \(x, y pixels and a confidence\) given as 3D poses\?"):
        load_videopose3d(tmp_path / "keypoints.npy")
    np.save(tmp_path / "mm.npy", np.load(YOGA["Tadasana"]) * 1000)  # depths in front of the root: millimetres
    with pytest.raises(AdapterError, match=r"millimetres or centimetres given as metres\?"):
        load_videopose3d(tmp_path / "mm.npy")


# --------------------------------------------------------------------------- VideoPose3D


def test_videopose3d_root_relative_or_with_its_trajectory_but_not_motionbert(tmp_path):
    """A VideoPose3D export is root-relative (pelvis about 1e-4 m from the origin), or with the
    trajectory model carries the root in front of the camera; MotionBERT's normalised output
    (pelvis at its image position, depth near 0) given as VideoPose3D is refused."""
    poses = np.load(YOGA["Tadasana"]).astype(np.float32)
    assert np.median(np.linalg.norm(poses[:, PELVIS], axis=-1)) < 1e-3
    moved = tmp_path / "with_trajectory.npy"
    np.save(moved, poses + np.float32([0.3, -0.2, 4.0]))
    assert load_videopose3d(moved).joints.shape == poses.shape
    with pytest.raises(AdapterError, match=r"MotionBERT's infer_wild output\? \(--lifter motionbert\)") as err:
        load_videopose3d(BOXING_X3D)
    assert_names_file(err, BOXING_X3D)
    # without its pelvis the hip midpoint tells the same (the check had been skipped)
    no_pelvis = np.load(BOXING_X3D)
    no_pelvis[:, PELVIS] = np.inf
    np.save(tmp_path / "no_pelvis.npy", no_pelvis)
    with pytest.raises(AdapterError, match=r"MotionBERT's infer_wild output"):
        load_videopose3d(tmp_path / "no_pelvis.npy")
    poses[:, PELVIS] = np.nan
    np.save(tmp_path / "vp3d_no_pelvis.npy", poses)
    assert load_videopose3d(tmp_path / "vp3d_no_pelvis.npy").joints.shape == poses.shape


def test_a_rebased_z_up_world_frame_is_refused_by_both_camera_frame_adapters(tmp_path):
    """D3DP's display file (camera_to_world with the H36M camera quaternion, then z -= min z),
    renamed and reduced to (N, 17, 3), is no camera frame: VideoPose3D had read it as a
    trajectory-model export (a body 'lying'), DDHPose blamed MotionBERT."""
    from scipy.spatial.transform import Rotation

    X = np.load(YOGA["Tadasana"]).astype(np.float64)
    w, x, y, z = 0.1407, -0.1501, -0.7552, 0.6223  # formats: camera_to_world's quaternion
    world = Rotation.from_quat([x, y, z, w]).apply(X.reshape(-1, 3)).reshape(X.shape)
    world[..., 2] -= world[..., 2].min()
    np.save(tmp_path / "renamed.npy", world.astype(np.float32))
    for load in (load_videopose3d, load_ddhpose):
        with pytest.raises(AdapterError, match="world frame with z up and the lowest point rebased"):
            load(tmp_path / "renamed.npy")
    assert load_videopose3d(YOGA["Tadasana"]).joints.shape == X.shape


def test_videopose3d_standing_and_lying_poses():
    stand = load_videopose3d(YOGA["Tadasana"])
    assert stand.joints.shape == (100, 17, 3) and stand.units == "m" and stand.layout == "h36m17"
    h = stand.joints
    # Tadasana: standing, facing the camera.
    assert frac(h[:, L_HIP, 0] > h[:, R_HIP, 0]) == 1.0
    assert frac(h[:, HEAD, 1] < h[:, PELVIS, 1]) == 1.0
    assert frac(h[:, NECK_NOSE, 2] < h[:, PELVIS, 2]) > 0.9
    assert 0.15 < np.median(np.linalg.norm(h[:, L_HIP] - h[:, R_HIP], axis=-1)) < 0.35  # metres
    trunk = h[:, THORAX] - h[:, PELVIS]
    assert np.all(np.abs(trunk[:, 1]) > 3 * np.abs(trunk[:, 0]))
    # Shavasana: lying, seen from the side: trunk and legs run along image x, opposite ways.
    lying = load_videopose3d(YOGA["Shavasana"]).joints
    trunk = lying[:, THORAX] - lying[:, PELVIS]
    legs = (lying[:, L_ANKLE] + lying[:, R_ANKLE]) / 2 - lying[:, PELVIS]
    assert np.all(np.abs(trunk[:, 0]) > 3 * np.abs(trunk[:, 1]))
    assert np.all(np.abs(legs[:, 0]) > 3 * np.abs(legs[:, 1])) and np.all(trunk[:, 0] * legs[:, 0] < 0)
    # Bhujangasana: legs along the floor, chest lifted above the pelvis.
    cobra = load_videopose3d(YOGA["Bhujangasana"]).joints
    legs = (cobra[:, L_ANKLE] + cobra[:, R_ANKLE]) / 2 - cobra[:, PELVIS]
    assert np.all(np.abs(legs[:, 0]) > 3 * np.abs(legs[:, 1]))
    assert frac(cobra[:, HEAD, 1] < cobra[:, PELVIS, 1]) == 1.0


def test_videopose3d_all_real_exports_load():
    folder = shared("real", "yoga_videopose3d")
    files = sorted(folder.glob("*.npy"))
    assert len(files) >= 90
    for f in files:
        p3 = load_videopose3d(f)
        assert p3.joints.shape[1:] == (17, 3) and np.isfinite(p3.joints).all()
        assert np.abs(p3.joints[:, PELVIS]).max() < 1e-3


# --------------------------------------------------------------------------- generic


def test_generic_csv_rub_millimetres_with_header_and_gaps(tmp_path):
    base = np.load(YOGA["Tadasana"])[:20]
    src = base * np.array([1000.0, -1000.0, -1000.0])  # OpenGL-like camera axes, mm
    rows = [[f"{v:.4f}" for v in r] for r in src.reshape(20, -1)]
    rows[3][3 * L_HIP + 2] = ""  # one missing z
    header = ",".join(f"{n}_{c}" for n in get_layout("h36m17").joints for c in "xyz")
    path = tmp_path / "poses.csv"
    path.write_text(header + "\n" + "\n".join(",".join(r) for r in rows) + "\n")
    p3 = load_generic(path, layout="h36m17", axes="RUB", units="mm")
    assert p3.units == "m" and p3.joints.shape == (20, 17, 3)
    expect = base.copy()
    expect[3, L_HIP, 2] = np.nan
    np.testing.assert_allclose(p3.joints, expect, atol=1e-6)
    assert np.isfinite(p3.joints[3, L_HIP, :2]).all()  # the gap does not spread to x, y


def test_generic_csv_columns_follow_their_header_names_not_their_position(tmp_path):
    """A user trial's CSV named H36M-17's joints in its own order and ran with exit 0, read as
    a lying body with unequal legs: a header naming every joint's axes now orders the columns
    by name; one naming a joint the layout lacks, or leaving one out, is refused in one line."""
    base = np.load(YOGA["Tadasana"])[:20]
    names = get_layout("h36m17").joints
    order = np.random.default_rng(3).permutation(17)
    header = ",".join(f"{names[j]}.{c}" for j in order for c in "xyz")
    path = tmp_path / "own_order.csv"
    path.write_text(header + "\n" + "\n".join(",".join(f"{v:.6f}" for v in r)
                                               for r in base[:, order].reshape(20, -1)) + "\n")
    p3 = load_generic(path)
    np.testing.assert_allclose(p3.joints, base, atol=1e-6)
    assert "columns read by their header's joint names" in p3.notes
    wrong = tmp_path / "nose.csv"
    wrong.write_text(header.replace("head.", "nose.") + "\n" + path.read_text().split("\n", 1)[1])
    with pytest.raises(AdapterError, match=r"field 'header'.*got nose \(not h36m17 joints\)"):
        load_generic(wrong)
    # a frame and a time column beside the joints' (a plugin trial's CSV): left out, and said
    named = ",".join(f"{n}_{c}" for n in names for c in "xyz")
    rows = "\n".join(f"{i},{i / 30:.4f}," + ",".join(f"{v:.6f}" for v in r) for i, r in enumerate(base.reshape(20, -1)))
    framed = tmp_path / "framed.csv"
    framed.write_text(f"frame,time_s,{named}\n{rows}\n")
    p4 = load_generic(framed)
    np.testing.assert_allclose(p4.joints, base, atol=1e-6)
    assert "columns 'frame', 'time_s' left out (no joint axis)" in p4.notes and "order differs" not in p4.notes


@pytest.mark.slow
def test_a_semicolon_csv_runs_with_the_delimiter_flag(tmp_path):
    """A spreadsheet's semicolon CSV needed a --config file for its separator (a user trial):
    `pcnet run --delimiter ';'` reads it, and without the flag the refusal names it."""
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    base = np.load(YOGA["Tadasana"])[:30]
    path = tmp_path / "semicolons.csv"
    path.write_text("\n".join(";".join(f"{v:.6f}" for v in r) for r in base.reshape(30, -1)) + "\n")
    args = ["run", "--lifter", "generic", "--lifter-output", str(path), "--fps", "30", "--no-recording"]
    res = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "no")])
    assert res.exit_code == 1 and "--delimiter" in res.output and "separated by ';'" in res.output, res.output
    res = CliRunner().invoke(main, [*args, "--delimiter", ";", "--out", str(tmp_path / "yes")])
    assert res.exit_code == 0, res.output
    np.save(tmp_path / "same.npy", base.astype(np.float32))  # the same poses as an array: the same run
    res = CliRunner().invoke(main, [*args[:4], str(tmp_path / "same.npy"), *args[5:], "--out", str(tmp_path / "npy")])
    assert res.exit_code == 0, res.output
    with np.load(tmp_path / "yes" / "canonical.npz") as a, np.load(tmp_path / "npy" / "canonical.npz") as b:
        np.testing.assert_allclose(a["joints_camera"], b["joints_camera"], atol=1e-6)


def test_generic_zeros_are_missing_before_they_make_a_pelvis(tmp_path):
    """A user trial's COCO-layout file held a hip written as (0, 0, 0) for "not detected": the
    pelvis, the mean of the hips, came out halfway to the camera centre with nothing missing. A
    layout whose pelvis is no single joint has no joint at the origin of root-relative poses,
    so such a joint is missing even alone; H36M-17's own pelvis at the origin stays."""
    with np.load(FIXTURES / "mediapipe_blazepose33_f000-059.npz") as d:
        world = d["world_3d"].astype(np.float64)  # real MediaPipe world landmarks, metres
    world[10:15, 23] = 0.0  # left hip "not detected"
    path = tmp_path / "blaze.npy"
    np.save(path, world)
    p3 = load_generic(path, layout="blazepose33", axes="RDF", units="m")
    assert np.isnan(p3.joints[10:15, 23]).all() and np.isfinite(p3.joints[10:15, 24]).all()
    from pcnet.stages.remap import remap_to_h36m
    h36m = remap_to_h36m(p3.joints, "blazepose33")
    both_hips = np.isfinite(world[:, [23, 24]]).all(axis=(1, 2))
    both_hips[10:15] = False
    assert np.isnan(h36m[10:15, 0]).all() and np.isfinite(h36m[both_hips, 0]).all() and both_hips.sum() > 40


def test_generic_csv_row_of_empty_cells_is_a_missing_frame_not_a_blank_line(tmp_path):
    """pandas' ``to_csv`` writes a frame with every joint NaN as a row of commas: it stays a
    frame (all NaN), so later frames keep their times; blank lines are still skipped."""
    base = np.load(YOGA["Tadasana"])[:10]
    rows = [",".join(f"{v:.6f}" for v in r) for r in base.reshape(10, -1)]
    rows[4] = "," * (17 * 3 - 1)
    path = tmp_path / "poses.csv"
    path.write_text("\n".join(rows[:7]) + "\n\n" + "\n".join(rows[7:]) + "\n\n")
    joints = load_generic(path).joints
    assert joints.shape == (10, 17, 3) and np.isnan(joints[4]).all()
    keep = np.arange(10) != 4
    np.testing.assert_allclose(joints[keep], base[keep], atol=1e-6)


def test_generic_csv_headers_pandas_numbers_and_widths(tmp_path):
    """pandas' ``to_csv(index=False)`` names the columns 0, 1, ..., 50: a header, not a frame
    (it had shifted every frame by one), and with its default index column an empty first
    name whose column is dropped; a header naming another number of columns, a digit
    separator, another delimiter (also with decimal commas) and a UTF-8 byte-order mark are
    handled in one line each."""
    base = np.load(YOGA["Tadasana"])[:6]
    body = "\n".join(",".join(f"{v:.6f}" for v in r) for r in base.reshape(6, -1)) + "\n"
    numbered = tmp_path / "pandas.csv"
    numbered.write_text(",".join(str(i) for i in range(51)) + "\n" + body)
    read = load_generic(numbered)
    np.testing.assert_allclose(read.joints, base, atol=1e-6)
    assert "line 1: 0, 1, ..., 50 read as pandas' column names" in read.summary_note
    indexed = tmp_path / "pandas_index.csv"  # to_csv() with its default index=True
    indexed.write_text("," + ",".join(str(i) for i in range(51)) + "\n"
                       + "".join(f"{t}," + line + "\n" for t, line in enumerate(body.splitlines())))
    read = load_generic(indexed)
    np.testing.assert_allclose(read.joints, base, atol=1e-6)
    assert "index column, dropped" in read.summary_note
    short = tmp_path / "short_header.csv"
    short.write_text("x,y,z\n" + body)
    with pytest.raises(AdapterError, match=r"header.*one name per column \(51 columns of numbers\), got 3 names"):
        load_generic(short)
    truncated = tmp_path / "truncated.csv"  # a file cut off mid-row: the line is named (a user trial)
    truncated.write_text("# exported\n" + body + body.splitlines()[0][:9] + "\n")
    with pytest.raises(AdapterError, match=r"'line 8': expected 51 columns, as on 6 of the 7 rows, got 1; widths \[1, 51\]"):
        load_generic(truncated)
    bom = tmp_path / "bom.csv"
    bom.write_text("\ufeff" + body, encoding="utf-8")
    np.testing.assert_allclose(load_generic(bom).joints, base, atol=1e-6)
    semicolons = tmp_path / "semicolons.csv"  # a spreadsheet export with semicolons
    semicolons.write_text(body.replace(",", ";"))
    with pytest.raises(AdapterError, match=r"delimiter.*got line 1 separated by ';'"):
        load_generic(semicolons)
    np.testing.assert_allclose(load_generic(semicolons, delimiter=";").joints, base, atol=1e-6)
    decimal_commas = tmp_path / "decimal_commas.csv"
    decimal_commas.write_text(body.replace(",", ";").replace(".", ","))
    with pytest.raises(AdapterError, match=r"delimiter.*decimal point.*got line 1 separated by ';'"):
        load_generic(decimal_commas)
    with pytest.raises(AdapterError, match=r"delimiter.*got line 1 separated by ','"):
        load_generic(bom, delimiter="\t")
    underscore = tmp_path / "underscore.csv"
    underscore.write_text(body.replace(body.split(",")[1], "1_0", 1))
    with pytest.raises(AdapterError, match=r"line 1, column 2.*got '1_0'"):
        load_generic(underscore)
    lines = body.splitlines()
    cells = lines[3].split(",")
    cells[10] = "abc"  # a text cell in a data row: the message shows that cell, not the row's first
    lines[3] = ",".join(cells)
    text_cell = tmp_path / "text_cell.csv"
    text_cell.write_text("\n".join(lines) + "\n")
    with pytest.raises(AdapterError, match=r"line 4, column 11.*got 'abc'"):
        load_generic(text_cell)


def test_generic_csv_as_numpy_and_spreadsheets_write_it(tmp_path):
    """What other writers produce: ``numpy.savetxt`` with a ``#`` header (skipped, as
    ``numpy.loadtxt`` does) or its default space separator (named), a first frame whose first
    coordinate is missing (a frame, not pandas' index header), and decimal commas read with
    ``;`` as the delimiter (named as decimal commas, not as another separator)."""
    base = np.load(YOGA["Tadasana"])[:6]
    flat = base.reshape(6, -1).astype(np.float64)
    commented = tmp_path / "savetxt.csv"
    np.savetxt(commented, flat, delimiter=",", header="tadasana poses in metres", footer="end")
    np.testing.assert_allclose(load_generic(commented).joints, base, atol=1e-6)
    spaces = tmp_path / "savetxt.txt"
    np.savetxt(spaces, flat)
    with pytest.raises(AdapterError, match=r"delimiter.*got line 1 separated by spaces"):
        load_generic(spaces)
    np.testing.assert_allclose(load_generic(spaces, delimiter=" ").joints, base, atol=1e-6)
    gap = flat.copy()
    gap[0, 0] = np.nan
    first_missing = tmp_path / "first_missing.csv"
    first_missing.write_text("\n".join(",".join("" if np.isnan(v) else f"{v:.6f}" for v in r) for r in gap) + "\n")
    joints = load_generic(first_missing).joints
    assert joints.shape == (6, 17, 3) and np.isnan(joints[0, 0, 0])
    np.testing.assert_allclose(joints[1:], base[1:], atol=1e-6)
    decimal_commas = tmp_path / "decimal_commas.csv"
    decimal_commas.write_text("\n".join(";".join(f"{v:.6f}".replace(".", ",") for v in r) for r in flat) + "\n")
    with pytest.raises(AdapterError, match=r"line 1.*numbers with a decimal point, got decimal commas"):
        load_generic(decimal_commas, delimiter=";")


def test_an_archive_of_several_arrays_for_a_lifter_without_key_says_so(tmp_path):
    """VideoPose3D, MotionBERT and DDHPose take no --key: naming it would send the user to an
    option that is then refused."""
    path = tmp_path / "two.npz"
    np.savez(path, poses=np.load(YOGA["Tadasana"]), other=np.zeros(3))
    with pytest.raises(AdapterError, match=r"an \.npz holding one array \(this lifter takes no --key") as err:
        load_videopose3d(path)
    assert "--key (key=)" not in str(err.value)


def test_a_kinect_archive_given_to_a_single_array_lifter_names_the_kinect_adapter(tmp_path):
    """A UTD-MHAD-style archive (``skeleton`` + ``skeleton_fps``, as ../shared/data keeps them)
    read with --lifter videopose3d: the refusal names --lifter kinect_v1, as a MediaPipe
    archive's names --lifter mediapipe."""
    path = tmp_path / "a05_s3_t2.npz"
    np.savez(path, skeleton=np.load(YOGA["Tadasana"]), skeleton_fps=np.float64(20.1))
    with pytest.raises(AdapterError, match=r"read them with --lifter kinect_v1"):
        load_videopose3d(path)
    with pytest.raises(AdapterError, match=r"'world_3d'.*read them with --lifter kinect_v1"):
        load_mediapipe_3d(path)  # the other lifter that reads an archive


def test_json_with_a_byte_order_mark_reads_as_without(tmp_path):
    """Some Windows tools start UTF-8 JSON with a byte-order mark; the real AlphaPose file so
    stored reads the same (it was refused as invalid JSON)."""
    bom = tmp_path / "bom.json"
    bom.write_bytes(b"\xef\xbb\xbf" + BOXING_AP.read_bytes())
    np.testing.assert_array_equal(load_alphapose(bom).points, load_alphapose(BOXING_AP).points)


def test_generic_npz_key_and_axis_permutation(tmp_path):
    base = np.load(YOGA["Tadasana"])
    z_up = np.stack([base[..., 0], base[..., 2], -base[..., 1]], -1)  # x right, y forward, z up
    path = tmp_path / "poses.npz"
    np.savez(path, poses=z_up.reshape(100, 51), other=np.zeros(3))
    np.testing.assert_allclose(load_generic(path, key="poses", axes="RFU").joints, base)
    with pytest.raises(AdapterError, match="key") as err:
        load_generic(path)
    assert_names_file(err, path)
    np.testing.assert_allclose(load_generic(YOGA["Tadasana"], units="normalised").joints, base)
    assert load_generic(YOGA["Tadasana"], units="px").units == "px"


def test_a_generic_files_pelvis_path_is_noted_where_the_run_drops_it(tmp_path):
    """Real root-relative poses put 3.5 m in front of the camera (a lifter that estimates the
    trajectory): read without measured_root, the path is dropped, and the note says how to keep
    it (a custom-lifter trial lost it without a word); root-relative and measured files get none."""
    base = np.load(YOGA["Tadasana"])
    path = tmp_path / "trajectory.npy"
    np.save(path, base + np.array([0.0, 0.9, 3.5], np.float32))
    note = load_generic(path).summary_note
    assert note.startswith(f"{path}: pelvis 3.61 m from the camera: give --measured-root to keep its path"), note
    assert load_generic(path, measured_root=True).summary_note == ""
    assert load_generic(YOGA["Tadasana"]).summary_note == ""
    assert load_generic(path, units="normalised").summary_note == ""  # no metric path to keep


def test_axes_to_camera_spec():
    np.testing.assert_array_equal(axes_to_camera("RDF"), np.eye(3))
    assert np.linalg.det(axes_to_camera("RUB")) == 1.0
    assert np.linalg.det(axes_to_camera("RUF")) == -1.0  # left-handed source
    np.testing.assert_array_equal(np.array([1.0, 2.0, 3.0]) @ axes_to_camera("LUF"), [-1.0, -2.0, 3.0])
    for bad in ("RRF", "XYZ", "RD", "RDFB", "RLF"):
        with pytest.raises(ValueError):
            axes_to_camera(bad)


def test_generic_bad_declarations(tmp_path):
    tad = YOGA["Tadasana"]
    for kwargs, field in (({"axes": "RRF"}, "axes"), ({"units": "inch"}, "units"),
                          ({"layout": "smpl24"}, "layout"), ({"layout": "halpe26"}, "array")):
        with pytest.raises(AdapterError, match=field) as err:
            load_generic(tad, **kwargs)
        assert_names_file(err, tad)
    short = tmp_path / "short.csv"
    short.write_text("1,2,3\n4,5,6\n")
    with pytest.raises(AdapterError, match="51"):
        load_generic(short)
    text = tmp_path / "text.csv"
    text.write_text("a,b,c\n1,2,3\nx,y,z\n")
    with pytest.raises(AdapterError, match="line 3"):
        load_generic(text, layout="h36m17")
    other = tmp_path / "poses.bvh"
    other.write_text("HIERARCHY")
    with pytest.raises(AdapterError, match="extension"):
        load_generic(other)


# --------------------------------------------------------------------------- bad input, every adapter

LOADERS_2D = [(n, ".json") for n in ("alphapose", "mmpose")] + [("mediapipe", ".npz")]
LOADERS_3D = [(n, ".npy") for n in ("motionbert", "ddhpose", "videopose3d", "generic")] + [("mediapipe", ".npz")]


@pytest.mark.parametrize("kind,name,ext", [("2d", n, e) for n, e in LOADERS_2D] + [("3d", n, e) for n, e in LOADERS_3D])
def test_missing_file_names_the_file(tmp_path, kind, name, ext):
    adapter = get_2d_adapter(name) if kind == "2d" else get_3d_adapter(name)
    missing = tmp_path / f"not_here{ext}"
    with pytest.raises(AdapterError, match="no such file") as err:
        adapter.load(missing)
    assert_names_file(err, missing)


def test_missing_openpose_folder(tmp_path):
    with pytest.raises(AdapterError, match="no such folder") as err:
        load_openpose(tmp_path / "nowhere")
    assert_names_file(err, tmp_path / "nowhere")


@pytest.mark.parametrize("loader", [load_alphapose, load_mmpose])
@pytest.mark.parametrize("content,match", [("", "empty file"), ("  \n", "empty file"), ("[]", "empty list"),
                                           ("{not json", "valid JSON"), ('"text"', "str")])
def test_empty_or_invalid_json(tmp_path, loader, content, match):
    path = tmp_path / "results.json"
    path.write_text(content)
    with pytest.raises(AdapterError, match=match) as err:
        loader(path)
    assert_names_file(err, path)


@pytest.mark.parametrize("loader", [load_alphapose, load_mmpose])
def test_a_numpy_file_given_as_json_is_named_as_numpy(loader):
    """A user trial gave a MediaPipe archive with the AlphaPose format and read "expected valid
    JSON, got Expecting value at line 1 column 1"; the message now says what the file is."""
    with pytest.raises(AdapterError, match=r"expected valid JSON, got a zip archive such as numpy's \.npz \(MediaPipe's "
                                           r"archive is read by the mediapipe format\)"):
        loader(MEDIAPIPE)
    with pytest.raises(AdapterError, match="expected valid JSON, got a numpy .npy array"):
        loader(FIX / "boxing_X3D_f000-059.npy")


def test_a_video_or_2d_json_given_as_a_lifter_output_is_named_as_such():
    """A coach's trial gave the video, then AlphaPose's JSON, as the lifter output and read a
    message about the file's first bytes: the message says what the file is and where it goes."""
    from pcnet.adapters.validate import load_array_file

    with pytest.raises(AdapterError, match=r"expected a numpy \.npy/\.npz file, got a video \(MP4 / MOV\): give it "
                                           r"as --video$"):
        load_array_file(CLIP)
    with pytest.raises(AdapterError, match=r"got a JSON file: 2D keypoints go to --keypoints2d with their "
                                           r"--keypoints2d-format$"):
        load_array_file(FIX / "boxing_alphapose_f000-059.json")
    with pytest.raises(AdapterError, match=r"expected valid JSON, got a video \(MP4 / MOV\): give it as --video$"):
        load_alphapose(CLIP)


def test_wrong_joint_counts(tmp_path):
    entries = raw_entries(BOXING_AP)[:3]
    for n_values, match in ((40, "multiple of 3"), (60, "20 joints")):
        path = tmp_path / f"ap{n_values}.json"
        path.write_text(json.dumps([dict(e, keypoints=e["keypoints"][:n_values]) for e in entries]))
        with pytest.raises(AdapterError, match=match) as err:
            load_alphapose(path)
        assert_names_file(err, path)
    arr16 = tmp_path / "sixteen.npy"
    np.save(arr16, np.load(BOXING_X3D)[:, :16])
    for loader in (load_motionbert, load_videopose3d, load_ddhpose):
        with pytest.raises(AdapterError, match=r"\(60, 16, 3\)") as err:
            loader(arr16)
        assert_names_file(err, arr16)
    mp = dict(np.load(MEDIAPIPE))
    mp["world_3d"] = mp["world_3d"][:, :25]
    bad_mp = tmp_path / "mp25.npz"
    np.savez(bad_mp, **mp)
    with pytest.raises(AdapterError, match="world_3d") as err:
        load_mediapipe_3d(bad_mp)
    assert_names_file(err, bad_mp)


def test_nan_only_inputs(tmp_path):
    nan3d = tmp_path / "nan.npy"
    np.save(nan3d, np.full((5, 17, 3), np.nan, np.float32))
    for loader in (load_motionbert, load_videopose3d, load_ddhpose, load_generic):
        with pytest.raises(AdapterError, match="NaN") as err:
            loader(nan3d)
        assert_names_file(err, nan3d)
    mp = dict(np.load(MEDIAPIPE))
    mp["keypoints_2d"] = np.full_like(mp["keypoints_2d"], np.nan)
    nan_mp = tmp_path / "nan_mp.npz"
    np.savez(nan_mp, **mp)
    with pytest.raises(AdapterError, match="keypoints_2d") as err:
        load_mediapipe_2d(nan_mp)
    assert_names_file(err, nan_mp)
    load_mediapipe_3d(nan_mp)  # world_3d is still real: only the broken array is refused
    nan_json = tmp_path / "nan.json"
    nan_json.write_text(json.dumps([dict(e, keypoints=[float("nan")] * 78) for e in raw_entries(BOXING_AP)[:3]]))
    with pytest.raises(AdapterError, match="NaN") as err:
        load_alphapose(nan_json)
    assert_names_file(err, nan_json)


def test_not_a_numpy_file(tmp_path):
    fake = tmp_path / "X3D.npy"
    fake.write_text("this is not numpy")
    with pytest.raises(AdapterError, match="content") as err:
        load_motionbert(fake)
    assert_names_file(err, fake)
    with pytest.raises(AdapterError, match="content") as err:
        load_mediapipe_3d(fake)
    assert_names_file(err, fake)


# --------------------------------------------------------------------------- video


def test_video_probe_read_and_iterate_fixture_clip():
    info = probe_video(CLIP)
    assert (info.frame_count, info.fps, info.width, info.height) == (10, 30.0, 854, 480)
    frames = list(iter_frames(CLIP))
    assert len(frames) == 10 and frames[0].shape == (480, 854, 3) and frames[0].dtype == np.uint8
    np.testing.assert_array_equal(read_frame(CLIP, 7), frames[7])  # seeking is frame-exact
    middle = list(iter_frames(CLIP, start=3, stop=6))
    assert len(middle) == 3
    np.testing.assert_array_equal(middle[0], frames[3])
    assert not np.array_equal(frames[0], frames[9])
    for bad in (10, -1):
        with pytest.raises(AdapterError, match="index") as err:
            read_frame(CLIP, bad)
        assert_names_file(err, CLIP)


@pytest.mark.parametrize("frames", [1, 2])
def test_a_video_of_one_or_two_real_frames_is_probed_whole(tmp_path, frames):
    """A user trial's one-frame clip of the real boxing video was refused as "0 frames, first
    frame read": the check of its last frame sought back to frame 0, which the file refuses."""
    import cv2

    short = tmp_path / f"short{frames}.mp4"
    writer = cv2.VideoWriter(str(short), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (854, 480))
    for frame in list(iter_frames(CLIP))[:frames]:
        writer.write(frame)
    writer.release()
    info = probe_video(short)
    assert (info.frame_count, info.fps, info.width, info.height) == (frames, 30.0, 854, 480)


def test_unreadable_and_missing_video(tmp_path):
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"\x00\x01 definitely not a video" * 50)
    for call in (probe_video, lambda p: read_frame(p, 0), iter_frames):
        with pytest.raises(AdapterError, match="video") as err:
            call(junk)
        assert_names_file(err, junk)
    with pytest.raises(AdapterError, match="no such file") as err:
        probe_video(tmp_path / "gone.mp4")
    assert_names_file(err, tmp_path / "gone.mp4")


def test_full_videos_frame_counts_match_their_keypoints():
    boxing = shared("real", "boxing_motionbert", "boxing2.mp4")
    info = probe_video(boxing)
    # The container claims 360 frames; 301 decode, matching AlphaPose and MotionBERT.
    assert probe_video(boxing, verify=False).frame_count == 360
    assert info.frame_count == 301 == load_motionbert(boxing.with_name("X3D.npy")).num_frames
    assert load_alphapose(boxing.with_name("alphapose-results.json")).num_frames == 301
    demo = probe_video(shared("real", "sports2d_demo", "demo.mp4"))
    mp = np.load(shared("real", "sports2d_demo", "mediapipe_blazepose33.npz"))
    assert (demo.frame_count, demo.width, demo.height) == (230, int(mp["width"]), int(mp["height"]))


def test_full_alphapose_files():
    boxing = load_alphapose(shared("real", "boxing_motionbert", "alphapose-results.json"))
    assert boxing.points.shape == (301, 26, 3) and np.isfinite(boxing.points).all()
    np.testing.assert_array_equal(boxing.points[:60], load_alphapose(BOXING_AP).points)
    h = remap_to_h36m(boxing.points, "halpe26", confidence_channel=True)
    assert frac(h[:, L_ANKLE, 0] < h[:, R_ANKLE, 0]) > 0.95
    full = load_alphapose(shared("real", "alphapose_halpe26_809", "alphapose-results.json"))
    assert full.points.shape == (809, 26, 3) and full.track_id == 0
    assert "[144]" in full.notes  # the only frame with two detections
    np.testing.assert_array_equal(full.points[130:160], load_alphapose(AP809).points[130:160])


@pytest.mark.parametrize("text, message", [
    ('[{"a": 1} {"a": 2}]', "Expecting ',' delimiter at line 1 column 11"),
    ('[{"a": 1}] x', "Extra data at line 1 column 12"),
    ('[{"a": 1},', "Expecting value at line 1 column 11"),
    ('[1e400]', "JSON numbers within float64 range"),
    ('{"a": [1]}', "field 'top level': expected a list, got a JSON object with keys ['a']"),
    ('  ', "empty file"),
])
@pytest.mark.parametrize("chunk", [1, 3, 1 << 20])
def test_item_by_item_json_has_the_whole_file_parsers_errors(tmp_path, monkeypatch, text, message, chunk):
    """AlphaPose files are read one detection at a time, in chunks of text (a 2-hour file
    parsed whole is GBs of Python floats); damaged files still give one line naming file,
    place and problem, wherever the chunks end."""
    import pcnet.adapters.validate as validate
    from pcnet.adapters.validate import iter_json_array

    monkeypatch.setattr(validate, "JSON_CHUNK_CHARS", chunk)
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(AdapterError) as err:
        list(iter_json_array(path, "a list"))
    assert message in str(err.value) and str(path) in str(err.value)


@pytest.mark.parametrize("chunk", [1, 7, 4096, 1 << 20])
def test_item_by_item_json_equals_the_whole_file(tmp_path, monkeypatch, chunk):
    import json as json_module

    import pcnet.adapters.validate as validate
    from pcnet.adapters.validate import iter_json_array, read_json

    monkeypatch.setattr(validate, "JSON_CHUNK_CHARS", chunk)  # chunk ends inside numbers, keys, items
    path = FIXTURES / "boxing_alphapose_f000-059.json"
    assert list(iter_json_array(path, "a list")) == read_json(path)
    (tmp_path / "numbers.json").write_text("[1.25, 123456789, -7e-3 ,2]  ")  # top-level numbers cut at chunk ends
    assert list(iter_json_array(tmp_path / "numbers.json", "a list")) == [1.25, 123456789, -7e-3, 2]
    spaced = json_module.dumps([{"x": float("nan")}, [], {}], indent=3)
    (tmp_path / "spaced.json").write_text(f"\n {spaced} \n")
    items = list(iter_json_array(tmp_path / "spaced.json", "a list"))
    assert items[1:] == [[], {}] and items[0]["x"] != items[0]["x"]  # NaN literal = missing data


def test_keypoints_normalised_by_the_image_size_are_refused(tmp_path):
    """The real boxing AlphaPose file with x / 854 and y / 480 (a detector's normalised
    output): a whole body inside one pixel is no detection; it had run, its pelvis path tens
    of metres deep (a user trial)."""
    items = json.loads(BOXING_AP.read_text())
    for it in items:
        it["keypoints"] = [v / (854.0 if i % 3 == 0 else 480.0) if i % 3 < 2 else v
                           for i, v in enumerate(it["keypoints"])]
    (tmp_path / "norm.json").write_text(json.dumps(items))
    with pytest.raises(AdapterError, match=r"norm\.json.*pixel coordinates.*every keypoint within \[-1, 1\]"):
        load_alphapose(tmp_path / "norm.json")
    assert load_alphapose(BOXING_AP).num_frames == 60  # the pixels themselves pass


def test_a_library_caller_passing_no_path_gets_the_adapters_error():
    """A user trial: ``load_motionbert(5)`` raised Python's TypeError and a custom adapter's
    float64 ``Poses3D`` a bare ValueError; both are now the adapters' one error, naming the
    field and what was found."""
    from pcnet.adapters import Poses3D

    with pytest.raises(AdapterError, match=r"file '5': field 'path': expected a file path, got int 5"):
        load_motionbert(5)
    with pytest.raises(AdapterError, match=r"field 'joints': expected a float32 numpy array, got dtype float64"):
        Poses3D(np.load(FIX / "boxing_X3D_f000-059.npy").astype(np.float64), "h36m17", units="normalised",
                source="vp.npy")


def test_the_registry_docstrings_adapter_example_reads_its_format(tmp_path):
    """The adapter example of ``pcnet.adapters.registry`` (a plugin trial wrote its adapter from
    it): run as written, in a process of its own, on H36M-17 millimetres with y up and z towards
    the camera, it gives the camera-frame metres, and its placeholder zeros are missing."""
    import re
    import subprocess
    import sys
    import textwrap

    import pcnet.adapters.registry as registry

    example = textwrap.dedent(re.search(r"::\n\n((?:    .*\n|\n)+)", registry.__doc__).group(1))
    base = np.load(YOGA["Tadasana"])[:30].astype(np.float32)
    written = base * np.array([1e3, -1e3, -1e3], np.float32)
    written[4, 16] = 0.0  # an undetected wrist, as such a lifter writes it
    np.save(tmp_path / "out.npy", written)
    assert 'get_3d_adapter("my_lifter").load("out.npy")' in example
    code = example + 'np.save("read.npy", poses.joints)\n'
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd=tmp_path)
    read = np.load(tmp_path / "read.npy")
    assert np.isnan(read[4, 16]).all()
    read[4, 16] = base[4, 16]
    np.testing.assert_allclose(read, base, atol=1e-5)
