"""The public API of ``pcnet.pipeline`` (``rectify``, ``run_pipeline``, ``RunConfig``): each
example of its module docstring (what the API reference shows) runs on the committed fixtures
and gives what it says; ``import pcnet.pipeline`` stays cheap."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import pcnet.pipeline
from conftest import FIXTURES

EXAMPLES = [textwrap.dedent(block) for block in re.findall(r"::\n\n((?:    .*\n|\n)+)", pcnet.pipeline.__doc__)]


def _example(*names: str) -> str:
    """The docstring's one example that uses every name in ``names``."""
    (found,) = [code for code in EXAMPLES[1:] if all(name in code for name in names)]
    return found


@pytest.fixture
def in_folder_with_fixtures(tmp_path, monkeypatch):
    """Run where the examples' relative paths (``tests/fixtures/...``, ``yoga_out``) resolve."""
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "fixtures").symlink_to(FIXTURES, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_the_public_names_are_the_documented_functions():
    from pcnet.pipeline import RunConfig, pose_checks, rectify, run_pipeline
    from pcnet.pipeline.checks import pose_checks as checks_pose_checks
    from pcnet.pipeline.config import RunConfig as config_RunConfig
    from pcnet.pipeline.rectification import rectify as rectification_rectify
    from pcnet.pipeline.runner import run_pipeline as runner_run_pipeline

    assert (rectify, pose_checks, run_pipeline, RunConfig) == (rectification_rectify, checks_pose_checks,
                                                               runner_run_pipeline, config_RunConfig)
    assert set(pcnet.pipeline.__all__) == {"rectify", "pose_checks", "run_pipeline", "RunConfig", "InputError"} \
        <= set(dir(pcnet.pipeline))
    from pcnet.pipeline import InputError

    assert issubclass(InputError, ValueError)  # what the three raise for bad input, catchable as documented
    assert EXAMPLES[0].strip() == "from pcnet.pipeline import rectify, pose_checks, run_pipeline, RunConfig, InputError"
    with pytest.raises(AttributeError, match="no_such_name"):
        pcnet.pipeline.no_such_name  # noqa: B018


def test_type_checkers_see_the_packages_and_the_public_names_types():
    """An API trial's mypy found no pcnet (no PEP 561 marker) and typed ``rectify`` as ``Any``
    (imported on first use): every package ships ``py.typed``, and a ``TYPE_CHECKING`` block
    names each public name's module, the same as the lazy table's."""
    import ast
    import tomllib

    root = Path(__file__).resolve().parents[1]
    package_data = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    for package, folder in (("pcnet.pipeline", "pipeline"), ("pcnet.stages", "stages"), ("pcnet.adapters", "adapters"),
                            ("pcnet.models", "models")):
        assert (root / folder / "py.typed").is_file() and "py.typed" in package_data[package], package
    tree = ast.parse((root / "pipeline" / "__init__.py").read_text())
    (block,) = [node for node in tree.body if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING"]
    typed = {alias.name: node.module for node in block.body for alias in node.names}
    assert typed == pcnet.pipeline._PUBLIC


def test_importing_the_package_loads_none_of_the_heavy_modules():
    heavy = ("numpy", "scipy", "onnxruntime", "cv2", "torch", "pcnet.adapters", "pcnet.pipeline.runner")
    code = f"import sys, pcnet.pipeline; print([m for m in {heavy!r} if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_rectify_example(in_folder_with_fixtures, capsys):
    namespace = {}
    exec(_example("rectify(joints"), namespace)
    res, joints = namespace["res"], namespace["joints"]
    assert joints.shape == (100, 17, 3) and res.canonical.shape == (100, 17, 3) and res.valid.all()
    assert res.mode == "sequence" and np.allclose(res.up, res.up[0]) and np.isclose(np.linalg.norm(res.up[0]), 1.0)
    head_above_pelvis = res.canonical[:, 10, 1] - res.canonical[:, 0, 1]  # canonical +Y is up
    assert (head_above_pelvis > 0.3).all()
    assert "(100, 17, 3) 100" in capsys.readouterr().out
    # the camera's pitch and roll and their intervals, as pcnet run's summary gives them
    from pcnet.pipeline.checks import CameraTilt
    from pcnet.stages.core.rotations import camera_pitch_roll

    tilt = namespace["tilt"]
    assert tilt == CameraTilt.of(res.rotation, res.valid) and "camera_tilt_deg" not in res.report.as_record()
    assert np.allclose((tilt.pitch_deg, tilt.roll_deg), np.degrees(camera_pitch_roll(res.up[0])))
    assert 0 < namespace["seq"].camera_pitch_interval_deg < 20 and 0 < namespace["seq"].camera_roll_interval_deg < 20


def test_pose_checks_example_warns_of_a_mirrored_skeleton_that_rectify_accepts(in_folder_with_fixtures, capsys):
    from pcnet.pipeline.rectification import rectify

    namespace = {}
    exec(_example("rectify(joints"), namespace)
    capsys.readouterr()
    exec(_example("pose_checks(joints"), namespace)
    assert capsys.readouterr().out == ""  # the fixture as VideoPose3D gives it: nothing to say
    mirrored = namespace["joints"] * np.array([-1.0, 1.0, 1.0], np.float32)  # x flipped: a left-handed skeleton
    namespace.update(joints=mirrored, res=rectify(mirrored, mode="sequence", fps=30.0))
    exec(_example("pose_checks(joints"), namespace)
    assert "mirrored" in capsys.readouterr().out


def test_run_pipeline_example(in_folder_with_fixtures, capsys):
    namespace = {}
    exec(_example("run_pipeline(cfg"), namespace)
    result = namespace["result"]
    assert result.frames == 100
    out = in_folder_with_fixtures / "yoga_out"
    assert (out / "canonical.npz").is_file() and (out / "kinematics.csv").is_file()
    assert "frames            100 at 30 fps" in capsys.readouterr().out
    # reading the arrays back, as the docstring shows (a service's trial found no arrays on the result)
    namespace["np"] = np
    exec(_example("joints_world"), namespace)
    assert namespace["world"].shape == (100, 17, 3) and namespace["world"].dtype == np.float64
    assert np.nanmin(namespace["world"][..., 1]) >= 0.0  # above the floor, y up
    knee = np.array(namespace["knee"])
    assert knee.shape == (100,) and np.isfinite(knee).all() and 0.0 < np.median(knee) < 90.0


def test_run_config_example_gives_the_defaults_it_states():
    code = _example("RunConfig.from_values")
    *body, last = code.strip().splitlines()
    namespace = {}
    exec("\n".join(body), namespace)
    stated = re.search(r"#\s*(\(.*?\))", last).group(1)
    assert eval(last.split("#")[0], namespace) == eval(stated)
    cfg = namespace["cfg"]
    assert (cfg.lifter, cfg.fps) == ("motionbert", 25.0)
    # a name that is no field: InputError naming it, as a TOML file's unknown key (a user trial: TypeError)
    from pcnet.pipeline import InputError, RunConfig

    with pytest.raises(InputError, match=r"trial: fields '3' and 'heigth': unknown \(heigth: height\?\)"):
        RunConfig.from_values("trial", {"lifter": "motionbert", "lifter_output": "x.npy", "heigth": 1.7, 3: 1})


@pytest.mark.parametrize("option, value", [("camera_prior", "no"), ("measured_root", 1), ("fps", "30")])
def test_rectify_refuses_options_of_another_type(option, value):
    """``camera_prior="no"`` ran with the prior on (a user trial): the options are checked as
    RunConfig checks its fields."""
    from pcnet.pipeline import InputError, rectify

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:10]
    with pytest.raises(InputError, match=f"rectify: {option}: expected"):
        rectify(joints, mode="sequence", **{"fps": 30.0, option: value})


@pytest.mark.parametrize("mode", ["sequence", "smooth", "auto"])
def test_rectify_needs_the_frame_rate_for_modes_that_pool_over_seconds(mode):
    """``rectify(mode="smooth")`` had quietly read every recording as 30 fps (a library user's
    trial): a 60 fps recording would be smoothed over twice the time. Frame mode takes 30 for
    the view gate's window alone."""
    from pcnet.pipeline import InputError, rectify

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:20]
    with pytest.raises(InputError, match=f"mode '{mode}' pools frames over seconds: give fps"):
        rectify(joints, mode=mode)
    assert rectify(joints, mode=mode, fps=60.0).valid.all()
    assert rectify(joints).valid.all()


@pytest.mark.parametrize("mode", ["frame", "sequence", "smooth", "auto"])
def test_rectify_refuses_poses_without_a_frame_it_can_rectify_in_every_mode(mode):
    """Frame mode returned every frame NaN for poses without hips, and ``pose_checks`` found
    nothing (a library user's trial); the other modes refused. Every mode refuses, as
    ``pcnet run`` and ``pcnet rectify`` do."""
    from pcnet.pipeline import InputError, rectify

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:20].copy()
    joints[:, [0, 1, 4]] = np.nan  # pelvis and hips
    with pytest.raises(InputError, match="^no frame has the hips, thorax and shoulders"):
        rectify(joints, mode=mode, fps=30.0)
    joints[5] = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[5]
    assert rectify(joints, mode=mode, fps=30.0).valid.sum() == 1


def test_results_print_their_arrays_as_shapes():
    """``repr`` of a ``Rectified`` of 100 frames printed every value of ``up`` and ``valid``
    (about 300 lines in a developer trial's log): arrays print as shape and dtype."""
    from pcnet.pipeline import rectify
    from pcnet.stages.kinematics import compute_kinematics

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")
    res = rectify(joints, mode="sequence", fps=30.0)
    kin = compute_kinematics(joints - joints[:, :1], 30.0, rotation=res.rotation)
    for text in (repr(res), repr(kin)):
        assert "\n" not in text and len(text) < 1000, text
    assert "up=<100x3 float64>" in repr(res) and "report=RectificationReport(...)" in repr(res)
    assert "positions=<100x17x3 float64>" in repr(kin) and "36 in all}" in repr(kin) and "cutoff_hz=6.0" in repr(kin)


# --- what a library user meets (a developer's trial of the Python API) -----------------------


def test_sequence_mode_refuses_poses_whose_every_frame_it_leaves_out():
    """Poses with their vertical axis flipped (a Y-up export read as camera-frame) keep no frame
    with a heading about sequence mode's up: ``rectify`` returned NaN rows alone, where ``pcnet
    run`` refuses them in one line (a developer trial)."""
    from pcnet.pipeline import InputError, rectify

    flipped = np.load(FIXTURES / "boxing_X3D_f000-059.npy") * np.array([1.0, -1.0, 1.0])
    assert rectify(flipped, mode="frame").valid.any()
    with pytest.raises(InputError, match=r"^every frame's own up is more than 143 deg from the sequence up"):
        rectify(flipped, mode="sequence", fps=30.0)


def test_results_pickle_for_worker_processes_and_compare_by_identity():
    """``Kinematics`` could not be pickled ("cannot pickle 'mappingproxy'"), so a process pool
    could not return it; ``==`` on the results raised numpy's "truth value is ambiguous"."""
    import copy
    import pickle

    from pcnet.pipeline import rectify
    from pcnet.stages.kinematics import compute_kinematics

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:40]
    res = rectify(joints, mode="sequence", fps=30.0)
    kin = compute_kinematics(res.canonical, 30.0)
    for value in (res, res.report, kin):
        back = pickle.loads(pickle.dumps(value))
        assert type(back) is type(value)
        assert value == value and value != back and len({value, back}) == 2  # identity, no exception
    for back in (pickle.loads(pickle.dumps(kin)), copy.deepcopy(kin)):
        assert back.angles.keys() == kin.angles.keys()
        np.testing.assert_array_equal(back.angles["trunk_inclination"], kin.angles["trunk_inclination"])
        np.testing.assert_array_equal(back.positions, kin.positions)
        with pytest.raises(TypeError):
            back.angles["trunk_inclination"] = None  # still read-only
        assert not back.positions.flags.writeable
    # unpickled arrays are read-only again, as the classes say (a developer trial wrote into them)
    for back in (pickle.loads(pickle.dumps(res)), copy.deepcopy(res)):
        assert not any(getattr(back, f).flags.writeable for f in ("rotation", "canonical", "up", "valid"))
        np.testing.assert_array_equal(back.canonical, res.canonical)


def test_kinematics_refuse_empty_input_and_a_frame_rate_that_is_not_a_number():
    """Empty poses gave numpy's "cannot reshape array of size 0"; ``fps="30"`` was taken by
    ``compute_kinematics`` but refused by ``rectify``, and ``derivatives(x, "30")`` raised a
    TypeError; ``fps=True`` read as 1 Hz."""
    from pcnet.pipeline import InputError
    from pcnet.stages.kinematics import butterworth_lowpass, compute_kinematics, derivatives

    poses = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:30] * np.array([1.0, -1.0, -1.0])  # Y up
    with pytest.raises(InputError, match="canonical: expected at least one frame"):
        compute_kinematics(np.zeros((0, 17, 3)), 30.0)
    for call in (butterworth_lowpass, derivatives):
        with pytest.raises(InputError, match="at least one sample"):
            call(np.zeros((0, 17, 3)), 30.0)
        with pytest.raises(InputError, match=r"fps: expected a frame rate in Hz \(a number\), got '30' \(str\)"):
            call(poses, "30")
    for fps in ("30", True):
        with pytest.raises(InputError, match="fps: expected a frame rate in Hz"):
            compute_kinematics(poses, fps)
    assert compute_kinematics(poses, np.float32(30.0)).fps == 30.0


def test_kinematics_refuse_centimetres_said_to_be_metres_and_a_unit_that_is_no_name():
    """A user trial's library chain read a VideoPose3D file in centimetres (the adapter's
    metres) and got a wrist at 152 m/s: ``pcnet run`` refuses such a body, the library did not.
    ``units=5`` gave velocities in "5/s"."""
    from pcnet.pipeline import InputError
    from pcnet.stages.kinematics import compute_kinematics

    poses = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:30] * np.array([1.0, -1.0, -1.0])  # Y up
    with pytest.raises(InputError, match=r"canonical: expected poses in metres \(units 'm': a median thigh length of "
                                         r"0\.2-0\.7 m\), got \d\d\.\d m: centimetres or millimetres given as metres\?"):
        compute_kinematics(poses * 100.0, 30.0)
    with pytest.raises(InputError, match="another unit or joint order given as metres"):
        compute_kinematics(poses / 100.0, 30.0)
    assert compute_kinematics(poses * 100.0, 30.0, units="cm").units == "cm"
    # metres declared as "mm" were labelled mm/s (a notebook trial)
    with pytest.raises(InputError, match=r"canonical: expected poses in 'mm' \(units 'mm': .*\), got 0\.000\d+ m: "
                                         r"another unit or joint order given as 'mm'\?"):
        compute_kinematics(poses, 30.0, units="mm")
    with pytest.raises(InputError, match=r"units: expected a length unit's name \(one of 'm', 'cm', 'mm', "
                                         r"'normalised', 'px'\), got 5"):
        compute_kinematics(poses, 30.0, units=5)
    # any other string was taken and labelled the velocities "furlong/s" (a developer trial)
    with pytest.raises(InputError, match="got 'furlong'"):
        compute_kinematics(poses, 30.0, units="furlong")
    # a long recording in chunks is judged as a whole, as compute_kinematics judges it (a review:
    # a last chunk holding only a few glitched 3 m thighs was refused alone)
    from pcnet.stages.core.conventions import L_KNEE, R_KNEE
    from pcnet.stages.kinematics import kinematics_chunks

    long = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy").astype(np.float64) * [1.0, -1.0, -1.0]  # Y up
    long[50:, [L_KNEE, R_KNEE]] = np.nan
    long[90:95, [L_KNEE, R_KNEE]] = long[90:95, [1, 4]] + np.array([0.0, -3.0, 0.0])
    whole = compute_kinematics(long, 30.0)
    chunks = list(kinematics_chunks(long, 30.0, chunk_frames=20))
    np.testing.assert_allclose(np.concatenate([k.positions for k in chunks]), whole.positions, atol=1e-9)


def test_the_world_frame_refuses_poses_that_are_not_root_relative():
    """Raw MotionBERT output (the pelvis at its image position) given to ``to_world_floor``
    had its image position read as a path, silently."""
    from pcnet.adapters import load_motionbert
    from pcnet.pipeline import InputError, rectify
    from pcnet.stages.world_frame import to_world_floor, world_frame

    joints = load_motionbert(FIXTURES / "boxing_X3D_f000-059.npy").joints
    res = rectify(joints, mode="sequence", fps=30.0)
    frame = world_frame(res.rotation, res.valid, 30.0)
    with pytest.raises(InputError, match=r"expected root-relative poses \(pelvis at the origin\), got the pelvis at"):
        to_world_floor(joints, frame)
    relative = joints - joints[:, :1]
    world, _ = to_world_floor(relative, frame)
    assert np.isfinite(world).all()
    # VideoPose3D's exports hold their root up to 1e-4 of their size from the origin (float32):
    # root-relative as documented, and taken so (a developer trial was refused them)
    yoga = np.load(FIXTURES / "yoga_Abhay_Shavasana_f200-299.npy")
    assert 0 < np.abs(yoga[:, 0]).max() < 1e-3 * np.abs(yoga).max()
    res = rectify(yoga, mode="sequence", fps=30.0)
    assert np.isfinite(to_world_floor(yoga, world_frame(res.rotation, res.valid, 30.0))[0]).any()
    # root_relative's (poses, root) passed whole got numpy's "inhomogeneous shape" (a notebook trial)
    from pcnet.stages.core.conventions import root_relative

    with pytest.raises(InputError, match=r"got a tuple of 2 \(root_relative returns \(poses, root\): pass poses"):
        to_world_floor(root_relative(joints), frame)


def test_lifter_joints_leave_the_callers_array_as_it_was():
    """``lifter_joints`` (the step the ``Poses3D`` docs point to) had written NaN over the
    caller's placeholder joints, in the frozen ``Poses3D``'s array."""
    from pcnet.adapters import Poses3D
    from pcnet.pipeline.io import lifter_joints

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy").astype(np.float32)
    joints[5, 3] = joints[5, 6] = 0.0  # two joints at exactly (0, 0, 0): a writer's placeholder
    before = joints.copy()
    out = lifter_joints(Poses3D(joints, "h36m17", units="m"), "x")
    assert np.isnan(out[5, 3]).all() and np.array_equal(joints, before)
    owned = joints.copy()
    assert lifter_joints(Poses3D(owned, "h36m17", units="m"), "x", in_place=True) is owned  # pcnet run's own load


def test_importing_the_adapters_leaves_opencv_and_the_environment_alone():
    """``import pcnet.adapters`` imported OpenCV (about a second) and set
    OPENCV_FFMPEG_LOGLEVEL for the whole process; now only reading a video does, and a level
    the user set is kept."""
    code = textwrap.dedent(f"""
        import os, sys
        import pcnet.adapters
        assert "cv2" not in sys.modules and "OPENCV_FFMPEG_LOGLEVEL" not in os.environ
        pcnet.adapters.probe_video({str(FIXTURES / "boxing2_f000-009.mp4")!r})
        assert os.environ["OPENCV_FFMPEG_LOGLEVEL"] == "-8"
        print("ok")
    """)
    env = {k: v for k, v in os.environ.items() if k != "OPENCV_FFMPEG_LOGLEVEL"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr


def test_the_rectify_array_example_runs_and_prints_the_pose_checks():
    """``examples/rectify_array.py`` on the bundled MotionBERT output: its lines, then the
    warnings the poses alone give (that output's legs differ in length)."""
    script = Path(__file__).resolve().parent.parent / "examples" / "rectify_array.py"
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, check=True).stdout
    assert out.startswith("X3D.npy: 301 frames, 301 valid\n") and "camera pitch" in out
    assert "WARNING  lifter's legs differ" in out


def test_library_calls_refuse_what_would_be_silently_wrong_in_one_line():
    """A developer trial of the Python API: pose_checks took the poses of another call and a
    list without a word, joint_angles and isb_joint_angles took camera-frame poses (+Y down)
    and read the trunk at 174 deg, a cutoff given as a string and a ragged list failed with
    Python's own TypeError / numpy's ValueError."""
    from pcnet.pipeline import InputError, pose_checks, rectify
    from pcnet.stages.isb_angles import isb_joint_angles
    from pcnet.stages.kinematics import butterworth_lowpass, compute_kinematics, joint_angles

    J = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:40]
    res = rectify(J, mode="sequence", fps=30.0)
    with pytest.raises(InputError, match="expected the 40 frames rectify was given, got 10"):
        pose_checks(J[:10], res)
    with pytest.raises(InputError, match=r"joints_camera: expected shape \(T, 17, 3\)"):
        pose_checks(J[:, :16], res)
    assert pose_checks(J.tolist(), res) == pose_checks(J, res)
    single = J[0]
    assert isinstance(pose_checks(single, rectify(single)), list)  # one pose is one frame, as rectify reads it
    for angles in (joint_angles, isb_joint_angles):
        with pytest.raises(InputError, match="expected Y-up poses"):
            angles(J)  # camera frame: the trunk points down
        assert angles(J, check_up=False)  # a body inverted on purpose
        upright = angles(res.canonical)["trunk_inclination" if angles is joint_angles else "trunk_flexion_to_gravity_deg"]
        assert abs(np.nanmedian(upright)) < 45  # a standing body, not the 180 deg of the camera frame
    for call in (lambda: compute_kinematics(res.canonical, 30.0, cutoff_hz="6", units="m"),
                 lambda: butterworth_lowpass(np.zeros((50, 3)), 30.0, cutoff_hz="6")):
        with pytest.raises(InputError, match="cutoff_hz: expected a number of Hz in"):
            call()
    with pytest.raises(InputError, match="^joints_cam: expected .* nested sequence of unequal lengths$"):
        rectify([[[0.0, 0.0, 0.0]] * 17, [[0.0, 0.0]] * 17])  # named as rectify's argument, no numpy text
    # another layout's joints, or swapped axes, are named with the fix (two trials met them)
    with pytest.raises(InputError, match=r"33 joints: the blazepose33 layout\? remap it first: .*remap_to_h36m"):
        rectify(np.zeros((5, 33, 3)))
    with pytest.raises(InputError, match="axes in another order"):
        rectify(np.swapaxes(J, 1, 2))
    # the frozen results are frozen: their arrays too (the trial wrote into both unwarned)
    kin = compute_kinematics(res.canonical, 30.0, units="m")
    for array in (res.canonical, res.rotation, res.valid, kin.positions, kin.speed, kin.missing):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0


def test_rectify_names_a_root_relative_tuple_and_2d_keypoints():
    """A developer trial passed ``root_relative``'s (poses, flag) whole, and (T, 17, 2)
    keypoints: numpy's "nested sequence" and a bare shape did not say what was wrong."""
    from pcnet.pipeline import InputError, rectify
    from pcnet.stages.core.conventions import root_relative

    joints = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")[:20]
    with pytest.raises(InputError, match=r"got a tuple of 2 arrays \(root_relative returns \(poses, pelvis "
                                         r"filled\): pass poses, its \[0\]\)$"):
        rectify(root_relative(joints))
    with pytest.raises(InputError, match=r"got \(20, 17, 2\) \(2D keypoints\? pcnet takes a lifter's 3D poses: "
                                         r"lift them first\)$"):
        rectify(joints[..., :2])


def test_the_documented_world_frame_chain_reads_a_writers_zeros_as_missing():
    """The package docstring's chain to the world frame and kinematics: a developer trial
    followed it with a wrist written as zeros, which read 18.6 m/s; through ``validate_poses``
    (as the docstring now says) the zeros are missing, as ``rectify`` reads them."""
    from pcnet.pipeline import rectify
    from pcnet.stages.core.conventions import R_WRIST, root_relative, validate_poses
    from pcnet.stages.kinematics import compute_kinematics
    from pcnet.stages.world_frame import to_world, world_frame

    raw = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy").astype(np.float32)
    zeros = raw.copy()
    zeros[40:60, R_WRIST] = 0.0
    res = rectify(zeros, mode="sequence", fps=30.0)
    frame = world_frame(res.rotation, res.valid, 30.0)
    read = compute_kinematics(to_world(root_relative(validate_poses(zeros))[0], frame), 30.0)
    assert read.missing[40:60, R_WRIST].all() and not read.missing[:30, R_WRIST].any()
    as_positions = compute_kinematics(to_world(root_relative(zeros)[0], frame), 30.0)
    assert not as_positions.missing[:, R_WRIST].any()  # what the chain gave without validate_poses
    clean = compute_kinematics(to_world(root_relative(raw)[0], frame), 30.0)
    peak = {name: np.nanmax(k.speed[:, R_WRIST]) for name, k in (("read", read), ("clean", clean),
                                                                   ("as positions", as_positions))}
    assert peak["read"] <= peak["clean"] * 1.01 and peak["as positions"] > 1.5 * peak["clean"], peak


def test_rectify_refuses_arrays_for_its_options_in_one_short_line():
    """A developer trial passed per-frame arrays where rectify takes one value: a (T, 3)
    camera_up made a 4,059-character error line, arrays for mode, heading or posture met numpy's
    "truth value is ambiguous", and one for weights "File name too long"."""
    from pcnet.pipeline.rectification import rectify
    from pcnet.stages.core.errors import InputError

    X = np.load(FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy")
    cases = {"camera_up": dict(camera_up=np.tile([0.0, -1.0, 0.0], (100, 1)), mode="sequence", fps=30.0),
             "fps": dict(fps=np.full(100, 30.0), mode="sequence"), "camera_prior": dict(camera_prior=np.ones(100)),
             "mode": dict(mode=np.array(["sequence"] * 100)), "heading": dict(heading=np.array(["auto"] * 100)),
             "posture": dict(posture=np.array(["auto"] * 100)), "weights": dict(weights=np.zeros(300))}
    for name, options in cases.items():
        shape = rf"^rectify: {name}: expected .*, got an array of shape \(\d+(, 3)?,?\)"
        with pytest.raises(InputError, match=shape) as caught:
            rectify(X, **options)
        assert len(str(caught.value)) < 200 and "\n" not in str(caught.value), str(caught.value)
