"""The adapter registry is the one list of adapter names and format facts (issue 52): a new
adapter registered with its decorator shows up in ``pcnet run``'s choices and help, in
``RunConfig`` validation and in ``pcnet batch``'s frame-rate check, with no other edit."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from pcnet.adapters import register_2d, register_3d
from pcnet.adapters.registry import unregister
from pcnet.pipeline.batch import _needs_fps_column
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


def _row(**given) -> dict:
    return {"video": None, "fps": None, "lifter": None, "keypoints2d_format": None, **given}


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
    assert _needs_fps_column(_row(lifter="test_probe_lifter"))
    assert _needs_fps_column(_row(lifter="test_probe_lifter", keypoints2d_format="test_probe_2d"))
    assert not _needs_fps_column(_row(lifter="test_probe_lifter", keypoints2d_format="mediapipe"))
    assert not _needs_fps_column(_row(lifter="test_probe_lifter", fps=25.0))


def test_an_unregistered_adapter_is_refused_everywhere():
    result = CliRunner().invoke(main, ["run", "--lifter", "test_probe_lifter", "--lifter-output", "p.npy"])
    assert result.exit_code != 0 and "'test_probe_lifter' is not one of 'motionbert'" in result.output
    with pytest.raises(InputError, match="field 'keypoints2d_format': expected one of"):
        RunConfig(lifter="motionbert", lifter_output="p.npy", keypoints2d="k.json",
                  keypoints2d_format="test_probe_2d", fps=30.0).validate()
    with pytest.raises(InputError, match=r"several tracks \(alphapose or mmpose\), got keypoints2d_format 'openpose'"):
        RunConfig(lifter="motionbert", lifter_output="p.npy", keypoints2d="k.json", keypoints2d_format="openpose",
                  person=0, fps=30.0).validate()
