"""The public API of ``pcnet.pipeline`` (``rectify``, ``run_pipeline``, ``RunConfig``): each
example of its module docstring (what the API reference shows) runs on the committed fixtures
and gives what it says; ``import pcnet.pipeline`` stays cheap."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap

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


def test_the_three_names_are_the_documented_functions():
    from pcnet.pipeline import RunConfig, rectify, run_pipeline
    from pcnet.pipeline.config import RunConfig as config_RunConfig
    from pcnet.pipeline.rectification import rectify as rectification_rectify
    from pcnet.pipeline.runner import run_pipeline as runner_run_pipeline

    assert (rectify, run_pipeline, RunConfig) == (rectification_rectify, runner_run_pipeline, config_RunConfig)
    assert set(pcnet.pipeline.__all__) == {"rectify", "run_pipeline", "RunConfig", "InputError"} \
        <= set(dir(pcnet.pipeline))
    from pcnet.pipeline import InputError

    assert issubclass(InputError, ValueError)  # what the three raise for bad input, catchable as documented
    assert EXAMPLES[0].strip() == "from pcnet.pipeline import rectify, run_pipeline, RunConfig, InputError"
    with pytest.raises(AttributeError, match="no_such_name"):
        pcnet.pipeline.no_such_name  # noqa: B018


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


def test_run_pipeline_example(in_folder_with_fixtures, capsys):
    namespace = {}
    exec(_example("run_pipeline(cfg"), namespace)
    result = namespace["result"]
    assert result.frames == 100
    out = in_folder_with_fixtures / "yoga_out"
    assert (out / "canonical.npz").is_file() and (out / "kinematics.csv").is_file()
    assert "frames            100 at 30 fps" in capsys.readouterr().out


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
        rectify(joints, mode="sequence", **{option: value})
