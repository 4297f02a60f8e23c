"""``camera_pitch_roll``: the one function turning a camera-frame up vector into pitch and roll
(issue 52), checked against the composition it inverts."""

from __future__ import annotations

import numpy as np

from pcnet.stages.core.rotations import camera_pitch_roll, camera_tilt_deg, compose_camera_rotation


def test_pitch_and_roll_of_the_up_column_are_those_composed():
    rng = np.random.default_rng(52)
    heading, pitch, roll = rng.uniform(-np.pi, np.pi, 200), rng.uniform(-1.5, 1.5, 200), rng.uniform(-3.1, 3.1, 200)
    up = compose_camera_rotation(heading, pitch, roll)[:, :, 1]
    got_pitch, got_roll = camera_pitch_roll(up)
    np.testing.assert_allclose(got_pitch, pitch, atol=1e-9)
    np.testing.assert_allclose(got_roll, roll, atol=1e-9)
    # the tilt from level of the same up: cos(tilt) = cos(pitch) cos(roll)
    np.testing.assert_allclose(np.cos(np.radians(camera_tilt_deg(up))), np.cos(pitch) * np.cos(roll), atol=1e-9)


def test_a_level_camera_a_downward_look_and_nan():
    pitch, roll = camera_pitch_roll(np.array([[0.0, -1.0, 0.0], [0.0, -np.sqrt(0.5), -np.sqrt(0.5)],
                                              [np.nan, np.nan, np.nan]]))
    np.testing.assert_allclose(np.degrees(pitch[:2]), [0.0, 45.0], atol=1e-12)
    np.testing.assert_allclose(roll[:2], [0.0, 0.0], atol=1e-12)
    assert np.isnan(pitch[2]) and np.isnan(roll[2])
    assert np.shape(camera_pitch_roll(np.array([0.0, -1.0, 0.0]))[0]) == ()


def test_pcnet_rectify_reports_the_cameras_tilt_pitch_and_roll_as_pcnet_run(tmp_path):
    """A user trial: `pcnet rectify` printed no tilt and its frame-mode report had none of the
    camera keys docs/outputs.md lists for every mode. Both modes now carry them, equal to the
    rotations' own mean (frame) or one (sequence) up, and the terminal says them."""
    import json

    from click.testing import CliRunner
    from conftest import FIXTURES

    from pcnet.pipeline.cli import main

    src = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"
    for mode, extra in (("frame", []), ("sequence", ["--fps", "30"])):
        out = tmp_path / f"{mode}.npz"
        res = CliRunner().invoke(main, ["rectify", str(src), "--out", str(out), "--mode", mode, *extra])
        assert res.exit_code == 0, res.output
        with np.load(out, allow_pickle=False) as z:
            report = json.loads(str(z["report"]))
            up = z["rotation"][:, :, 1][z["valid"]].mean(axis=0)
        pitch, roll = np.degrees(camera_pitch_roll(up / np.linalg.norm(up)))
        assert abs(report["camera_pitch_deg"] - float(pitch)) < 1e-6 and abs(report["camera_roll_deg"] - float(roll)) < 1e-6
        assert abs(report["camera_tilt_deg"] - float(camera_tilt_deg(up / np.linalg.norm(up)))) < 1e-6
        assert ("camera_tilt_per_frame_deg" in report) == (mode == "frame")
        pitch = report["camera_pitch_deg"]
        # the direction only beside a calibrated interval that excludes level (frame mode has none)
        named = mode == "sequence" and abs(pitch) > report["camera_pitch_interval_deg"]
        looking = f"looking {'down' if pitch > 0 else 'up'}: " if named else ""
        assert f"camera tilt {report['camera_tilt_deg']:.1f} deg from level ({looking}pitch {pitch:+.1f}" in res.output
