"""The adapter registry is the one list of adapter names and format facts (issue 52): a new
adapter registered with its decorator shows up in ``pcnet run``'s choices and help, in
``RunConfig`` validation and in ``pcnet batch``'s frame-rate check, with no other edit."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from pcnet.adapters import register_2d, register_3d
from pcnet.adapters.registry import unregister
from pcnet.pipeline.cli import main
from pcnet.pipeline.config import (RunConfig, keypoint_formats, lifter_names, multi_track_formats,
                                   records_frame_rate)
from pcnet.stages.core.errors import InputError


def test_the_builtin_facts_are_those_the_lists_held():
    """What pipeline/config.py and pipeline/batch.py listed by hand before the registry held it."""
    assert lifter_names()[:7] == ("motionbert", "ddhpose", "videopose3d", "mediapipe", "generic", "kinect_v1",
                                  "azure_kinect")
    assert keypoint_formats()[:4] == ("alphapose", "mmpose", "openpose", "mediapipe")
    assert multi_track_formats() == {"alphapose": "AlphaPose idx", "mmpose": "MMPose instance"}
    assert {n for n in lifter_names() if not records_frame_rate("3d", n)} == {"motionbert", "videopose3d", "ddhpose",
                                                                              "generic"}
    assert {n for n in keypoint_formats() if not records_frame_rate("2d", n)} == {"alphapose", "mmpose", "openpose"}


def _needs_fps(**given) -> bool:
    """Whether RunConfig.validate refuses the config for want of a frame rate (as `pcnet batch`
    refuses a row before any runs)."""
    try:
        RunConfig(lifter_output="p.npy", **({"keypoints2d": "k.json"} if "keypoints2d_format" in given else {}),
                  **given).validate()
    except InputError as err:
        assert "field 'fps': expected the frame rate" in str(err), err
        return True
    return False


@pytest.fixture
def probe_adapters():
    """A 3D and a multi-track 2D adapter registered only by their decorators."""

    @register_3d("test_probe_lifter", records_fps=False)
    class ProbeLifter:
        def load(self, path):
            raise AssertionError("not read here")

    @register_2d("test_probe_2d", records_fps=False, multi_track="Probe track")
    class ProbeKeypoints:
        def load(self, path, *, person=None):
            raise AssertionError("not read here")

    try:
        yield
    finally:
        unregister("test_probe_lifter", "3d")
        unregister("test_probe_2d", "2d")


def test_a_registered_adapter_reaches_the_cli_the_config_and_the_batch_checks(probe_adapters):
    assert lifter_names()[-1] == "test_probe_lifter" and keypoint_formats()[-1] == "test_probe_2d"
    assert multi_track_formats()["test_probe_2d"] == "Probe track"
    help_text = " ".join(CliRunner().invoke(main, ["run", "--help"]).output.split())
    assert "test_probe_lifter]" in help_text and "|test_probe_2d]" in help_text
    assert "(AlphaPose idx / MMPose instance / Probe track)" in help_text
    cfg = RunConfig(lifter="test_probe_lifter", lifter_output="p.npy", keypoints2d="k.json",
                    keypoints2d_format="test_probe_2d", person=1, fps=30.0).validate()
    assert cfg.person == 1
    assert _needs_fps(lifter="test_probe_lifter")
    assert _needs_fps(lifter="test_probe_lifter", keypoints2d_format="test_probe_2d")
    assert not _needs_fps(lifter="test_probe_lifter", keypoints2d_format="mediapipe")
    assert not _needs_fps(lifter="test_probe_lifter", fps=25.0)
    assert not _needs_fps(lifter="test_probe_lifter", video="v.mp4")


def test_a_custom_adapters_options_and_what_it_returns(tmp_path):
    """A custom adapter's option taken positionally (``load(self, path, scale=1.0)``) is an
    option like a keyword-only one; an adapter returning a bare array is named as the bug it is
    (a developer's trial: "expected only options ... (none)", then an AttributeError)."""
    import numpy as np
    from pcnet.pipeline.config import check_lifter_options
    from pcnet.pipeline.runner import run_pipeline

    @register_3d("test_scaled_lifter", records_fps=False)
    class ScaledLifter:
        def load(self, path, scale=1.0):
            return np.load(path) * scale

    try:
        assert check_lifter_options("config", "test_scaled_lifter", {"scale": 2.0}) == {"scale": 2.0}
        with pytest.raises(InputError, match=r"expected only options --lifter test_scaled_lifter takes \(scale\)"):
            check_lifter_options("config", "test_scaled_lifter", {"path": "x"})
        np.save(tmp_path / "p.npy", np.zeros((3, 17, 3), np.float32))
        with pytest.raises(TypeError, match=r"ScaledLifter.load: expected to return pcnet.adapters.Poses3D, got "
                                            r"ndarray"):
            run_pipeline(RunConfig(lifter="test_scaled_lifter", lifter_output=str(tmp_path / "p.npy"), fps=30.0,
                                   lifter_options={"scale": 2.0}, out=str(tmp_path / "o"), recording=False))
        assert not (tmp_path / "o").exists()
        # a custom adapter need not check its path: a missing file is the user's bad input, one line naming
        # it, not the adapter's FileNotFoundError (a developer's trial)
        with pytest.raises(InputError, match=r"^file '.*nope\.csv': field 'lifter_output': expected an existing file "
                                             r"or folder, got no such file or folder$"):
            run_pipeline(RunConfig(lifter="test_scaled_lifter", lifter_output=str(tmp_path / "nope.csv"), fps=30.0,
                                   out=str(tmp_path / "o"), recording=False))
        assert not (tmp_path / "o").exists()
    finally:
        unregister("test_scaled_lifter", "3d")


def test_a_custom_adapters_unknown_layout_names_its_file(tmp_path):
    """A custom adapter returning layout "mpi17" got "unknown joint layout 'mpi17'" with no file
    named (a developer trial): the adapter's error names the file and the field."""
    import numpy as np
    from pcnet.adapters import Poses3D
    from pcnet.adapters.types import AdapterError

    with pytest.raises(AdapterError, match=r"^file 'mine\.npy': field 'layout': expected one of blazepose33, body25, "
                                           r"coco17, h36m17, halpe26, got 'mpi17'$"):
        Poses3D(np.zeros((2, 17, 3), np.float32), "mpi17", units="m", source="mine.npy")


def test_an_unregistered_adapter_is_refused_everywhere():
    result = CliRunner().invoke(main, ["run", "--lifter", "test_probe_lifter", "--lifter-output", "p.npy"])
    assert result.exit_code != 0 and "'test_probe_lifter' is not one of 'motionbert'" in result.output
    with pytest.raises(InputError, match="field 'keypoints2d_format': expected one of"):
        RunConfig(lifter="motionbert", lifter_output="p.npy", keypoints2d="k.json",
                  keypoints2d_format="test_probe_2d", fps=30.0).validate()
    with pytest.raises(InputError, match=r"several tracks \(alphapose or mmpose\), got keypoints2d_format 'openpose'"):
        RunConfig(lifter="motionbert", lifter_output="p.npy", keypoints2d="k.json", keypoints2d_format="openpose",
                  person=0, fps=30.0).validate()


def test_an_installed_packages_adapter_plugin_reaches_pcnet_run(tmp_path):
    """A developer trial could register an adapter in Python only: `pcnet run --lifter mine`
    refused the name. An installed package declares its adapter module in the `pcnet.adapters`
    entry point group (a dist-info on the path, as pip leaves it); a broken one is named in a
    warning and left out, and pcnet still starts."""
    source = ("from pcnet.adapters import register_3d\n"
              "@register_3d('plugged_lifter', records_fps=False)\n"
              "class Plugged:\n"
              "    def load(self, path):\n"
              "        raise NotImplementedError\n")
    res = _pcnet_with_plugin(tmp_path, "my_plugin", "0.1", source, "plugged = my_plugin\nbroken = no_such_module\n",
                             "run", "--help")
    assert res.returncode == 0, res.stderr
    assert "plugged_lifter" in res.stdout
    assert "adapter plugin 'broken' (no_such_module) not loaded: ModuleNotFoundError" in res.stderr
    from pcnet.adapters import available_3d

    assert "plugged_lifter" not in available_3d()  # not installed in this process


def test_an_adapters_own_error_names_the_adapter_and_its_package(tmp_path):
    """A developer trial's adapter returned ``Poses3D(units="cm")``: the ValueError's
    traceback named neither the adapter nor the file. It stays a bug report (traceback, not
    bad input) and its last line names the adapter's class, its package and the file."""
    source = ("import numpy as np\n"
              "from pcnet.adapters import Poses3D, register_3d\n"
              "@register_3d('cm_lifter', records_fps=False)\n"
              "class CentimetreLifter:\n"
              "    def load(self, path):\n"
              "        return Poses3D(np.zeros((4, 17, 3), np.float32), 'h36m17', units='cm', source=str(path))\n")
    data = tmp_path / "poses.npy"
    data.write_bytes(b"")
    res = _pcnet_with_plugin(tmp_path, "cm_plugin", "0.3", source, "cm = cm_plugin\n", "run", "--lifter", "cm_lifter",
                             "--lifter-output", str(data), "--fps", "30", "--out", str(tmp_path / "o"))
    assert res.returncode == 1, res.stderr
    assert "Traceback" in res.stderr and "units must be one of" in res.stderr
    assert (f"pcnet: raised by the adapter cm_plugin.CentimetreLifter (package cm-plugin 0.3) reading {data}: "
            "a bug in that adapter") in res.stderr.splitlines()[-1]
    assert not (tmp_path / "o").exists()


def _pcnet_with_plugin(folder, module: str, version: str, source: str, entry_points: str, *args):
    """``pcnet *args`` in a fresh process with ``module`` (``source``) installed as the plugin
    distribution ``module`` (dashes for underscores) ``version`` declaring ``entry_points`` in the
    ``pcnet.adapters`` group: a dist-info on the path, as pip leaves it."""
    import os
    import subprocess
    import sys

    (folder / f"{module}.py").write_text(source)
    info = folder / f"{module}-{version}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {module.replace('_', '-')}\nVersion: {version}\n")
    (info / "RECORD").write_text(f"{module}.py,,\n")
    (info / "top_level.txt").write_text(f"{module}\n")
    (info / "entry_points.txt").write_text(f"[pcnet.adapters]\n{entry_points}")
    return subprocess.run([sys.executable, "-c", "from pcnet.pipeline.entry import main; main()", *args],
                          capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(folder)}, timeout=120)
