"""Static-camera up posterior (pcnet.stages.gravity_prior) on real VideoPose3D yoga poses."""

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pcnet.stages.core.conventions import PELVIS, THORAX
from pcnet.stages.gravity_prior import LEVEL_UP, gravity_posterior
from pcnet.stages.core.rotations import angle_between
from pcnet.stages.temporal import mean_trunk

FIX = Path(__file__).parent / "fixtures"


def _trunk(name: str) -> np.ndarray:
    """Mean camera-frame trunk direction of a real yoga fixture (x right, y down), as
    sequence mode computes it."""
    X = np.load(FIX / name, allow_pickle=False).astype(np.float64)
    return mean_trunk(X, np.ones(len(X), bool))


def _deg(a, b) -> float:
    return float(np.degrees(angle_between(np.asarray(a, float), np.asarray(b, float))))


def test_standing_level_camera_keeps_the_pose_up():
    trunk = _trunk("yoga_Abhay_Tadasana_f000-099.npy")
    up = trunk / np.linalg.norm(trunk)
    g = gravity_posterior(up, 4.0, trunk)
    assert g.reading == "upright" and g.p_lying < 0.05
    # the level-camera prior pulls by at most k_cam / (k_pose + k_cam) of the angle to -y
    assert _deg(g.up, up) <= 0.05 * _deg(up, LEVEL_UP) + 1e-6


@pytest.mark.parametrize("axis,angle", [("z", 180.0), ("x", 180.0), ("y", 180.0)])
def test_rotated_camera_standing_body_keeps_its_up(axis, angle):
    """Upside-down cameras: the uniform part of the camera prior leaves the pose-based up
    where it is (no pull towards a level camera)."""
    Q = Rotation.from_euler(axis, angle, degrees=True).as_matrix()
    trunk = Q @ _trunk("yoga_Abhay_Tadasana_f000-099.npy")
    up = trunk / np.linalg.norm(trunk)
    g = gravity_posterior(up, 4.0, trunk)
    assert g.reading == "upright"
    assert _deg(g.up, up) < 0.5


def test_tilted_camera_pull_is_bounded():
    """A camera rolled 45 deg: the level-camera prior moves the up by the posterior's share
    k_cam / (k_pose + k_cam) of the angle at most (4 % for 4 vs 20 deg)."""
    Q = Rotation.from_euler("z", 45.0, degrees=True).as_matrix()
    trunk = Q @ _trunk("yoga_Abhay_Tadasana_f000-099.npy")
    up = trunk / np.linalg.norm(trunk)
    g = gravity_posterior(up, 4.0, trunk)
    assert g.reading == "upright"
    assert 0.0 < _deg(g.up, up) <= (20.0**-2 / (4.0**-2 + 20.0**-2)) * _deg(up, LEVEL_UP) + 1e-6


def test_lying_body_level_camera_is_read_as_lying():
    """Real Shavasana (supine): the trunk is horizontal in the image; a network reading the
    body as upright puts up along it. The posterior takes the lying reading and the level
    camera's up, with an interval as wide as that evidence is."""
    trunk = _trunk("yoga_Abhay_Shavasana_f200-299.npy")
    assert _deg(trunk, LEVEL_UP) > 75  # the input itself: trunk near horizontal
    g = gravity_posterior(trunk / np.linalg.norm(trunk), 4.0, trunk)
    assert g.reading == "lying" and g.p_lying > 0.5
    assert abs(_deg(g.up, trunk) - 90.0) < 5.0  # up perpendicular to the trunk
    assert _deg(g.up, LEVEL_UP) < 20.0
    assert g.pitch_half_deg > 15.0 and g.roll_half_deg > 15.0


def test_standing_body_camera_rolled_90_is_ambiguous_and_read_as_lying():
    """The documented limit: the same skeleton as a lying body under a level camera."""
    Q = Rotation.from_euler("z", 90.0, degrees=True).as_matrix()
    trunk = Q @ _trunk("yoga_Abhay_Tadasana_f000-099.npy")
    g = gravity_posterior(trunk / np.linalg.norm(trunk), 4.0, trunk)
    assert g.reading == "lying" and 0.5 < g.p_lying < 0.9


def test_lying_body_camera_on_its_side_is_read_as_standing():
    """The converse limit (README, "Camera prior and lying bodies"): real Shavasana under a
    camera rolled so that the head points up the image is the skeleton of a standing body
    under a level camera; the posterior reads it upright, with no lying mass left to warn."""
    trunk = _trunk("yoga_Abhay_Shavasana_f200-299.npy")
    turned = [Rotation.from_euler("z", a, degrees=True).as_matrix() @ trunk for a in (90.0, -90.0)]
    head_up = min(turned, key=lambda t: _deg(t, LEVEL_UP))
    assert _deg(head_up, LEVEL_UP) < 20.0
    g = gravity_posterior(head_up / np.linalg.norm(head_up), 4.0, head_up)
    assert g.reading == "upright" and g.p_lying < 0.1 and _deg(g.up, head_up) < 5.0


def test_no_trunk_means_no_lying_reading():
    g = gravity_posterior(np.array([1.0, 0.0, 0.0]), 4.0, None)
    assert g.reading == "upright" and g.p_lying == 0.0


@pytest.mark.parametrize("up,sigma", [((0, 0, 0), 4.0), ((np.nan, 1, 0), 4.0), ((0, -1, 0), 0.0), ((0, -1), 4.0)])
def test_bad_arguments_are_refused(up, sigma):
    with pytest.raises(ValueError):
        gravity_posterior(np.array(up, float), sigma, None)


def _trunk_from_vertical_deg(canonical: np.ndarray) -> float:
    t = canonical[:, THORAX] - canonical[:, PELVIS]
    t = t[np.isfinite(t).all(-1)]
    return float(np.median(np.degrees(np.arccos(np.clip(t[:, 1] / np.linalg.norm(t, axis=-1), -1, 1)))))


def test_sequence_mode_reads_a_real_lying_body_as_lying():
    """End to end on real Shavasana (geometric per-frame method: its up IS the trunk axis, the
    worst case): sequence mode with the camera prior lays the trunk down; without it the
    trunk stands up."""
    from pcnet.pipeline.rectification import rectify

    X = np.load(FIX / "yoga_Abhay_Shavasana_f200-299.npy", allow_pickle=False).astype(np.float64)
    with_prior = rectify(X, "geometric", mode="sequence", fps=30.0)
    gravity = with_prior.report["gravity"]
    assert gravity["reading"] == "lying" and with_prior.report["evidence"].endswith("+camera_prior")
    assert _trunk_from_vertical_deg(with_prior.canonical) > 75.0
    assert gravity["interval_deg"] > 15.0  # the posterior's width, not the bootstrap's
    # printed as a 95 % interval only for the calibrated pair: the posterior's pose term is its calibration
    assert np.isnan(with_prior.report["camera_pitch_interval_deg"])
    alone = rectify(X, "geometric", mode="sequence", fps=30.0, camera_prior=False)
    assert alone.report["gravity"] is None and _trunk_from_vertical_deg(alone.canonical) < 30.0


def test_a_95_percent_interval_reaches_the_other_reading_where_it_keeps_more_than_5_percent():
    """Real prone cobra (VideoPose3D Bhujangasana): both networks read the raised chest as an
    upright trunk under a camera rolled about 65 deg, and the lying reading (a level camera)
    keeps 13 % of the posterior; the printed 95 % intervals then reach a level camera, which
    the calibrated ones alone (a few degrees) missed. A standing body, whose lying reading keeps
    well under 5 %, keeps the calibrated interval."""
    from pcnet.pipeline.rectification import rectify
    from pcnet.stages.gravity_prior import OTHER_READING_P
    from pcnet.stages.uncertainty import calibrated_interval

    cobra = rectify(np.load(FIX / "yoga_Abhay_Bhujangasana_f150-249.npy"), "pcnet", mode="sequence", fps=30.0).report
    assert cobra["gravity"]["reading"] == "upright" and cobra["gravity"]["p_lying"] >= OTHER_READING_P
    assert abs(cobra["camera_roll_deg"]) > 45.0  # read as a strongly rolled camera
    assert abs(cobra["camera_roll_deg"]) <= cobra["camera_roll_interval_deg"]  # a level camera is inside
    assert abs(cobra["camera_pitch_deg"]) <= cobra["camera_pitch_interval_deg"]
    assert cobra["interval_reaches_other_reading_p"] == pytest.approx(cobra["gravity"]["p_lying"], abs=1e-4)
    assert cobra["camera_roll_interval_deg"] > 5 * calibrated_interval(cobra["camera_roll_uncertainty_deg"], "roll",
                                                                       scale=cobra["evidence_scale"])
    standing = rectify(np.load(FIX / "yoga_Abhay_Tadasana_f000-099.npy"), "pcnet", mode="sequence", fps=30.0).report
    assert standing["gravity"]["p_lying"] < OTHER_READING_P and standing["interval_reaches_other_reading_p"] is None
    assert standing["camera_pitch_interval_deg"] == pytest.approx(calibrated_interval(
        standing["camera_pitch_uncertainty_deg"], "pitch", scale=standing["evidence_scale"]))


def test_reading_flags_name_the_reading():
    from pcnet.stages.flags import gravity_reading_flag

    trunk = _trunk("yoga_Abhay_Shavasana_f200-299.npy")
    lying = gravity_posterior(trunk / np.linalg.norm(trunk), 4.0, trunk).report()
    (flag,) = gravity_reading_flag(lying)
    assert "read as lying" in flag and "--no-camera-prior" in flag
    upright = gravity_posterior(LEVEL_UP, 4.0, LEVEL_UP).report()
    assert gravity_reading_flag(upright) == [] and gravity_reading_flag(None) == []
    Q = Rotation.from_euler("z", 70.0, degrees=True).as_matrix()
    tilted = gravity_posterior(Q @ LEVEL_UP, 4.0, Q @ LEVEL_UP).report()
    assert tilted["reading"] == "upright" and tilted["p_lying"] >= 0.1
    assert "ambiguous" in gravity_reading_flag(tilted)[0]


def test_cli_no_camera_prior_switch(tmp_path):
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    src = FIX / "yoga_Abhay_Shavasana_f200-299.npy"
    trunk = {}
    for name, extra in (("prior", []), ("alone", ["--no-camera-prior"])):
        out = tmp_path / f"{name}.npz"
        res = CliRunner().invoke(main, ["rectify", str(src), "--out", str(out), "--method", "geometric",
                                        "--mode", "sequence", *extra])
        assert res.exit_code == 0, res.output
        with np.load(out, allow_pickle=False) as z:
            trunk[name] = _trunk_from_vertical_deg(z["canonical"])
    assert trunk["prior"] > 75.0 > 30.0 > trunk["alone"]


@pytest.mark.slow
def test_pcnet_run_says_when_it_reads_a_lying_body(tmp_path):
    """`pcnet run` on real Shavasana (VideoPose3D): the summary names the lying reading and
    prints the posterior's interval, not the upright calibration's."""
    from click.testing import CliRunner

    from pcnet.pipeline.cli import main

    res = CliRunner().invoke(main, ["run", "--lifter", "videopose3d", "--lifter-output",
                                    str(FIX / "yoga_Abhay_Shavasana_f200-299.npy"), "--fps", "30",
                                    "--out", str(tmp_path / "out"), "--no-recording"])
    assert res.exit_code == 0, res.output
    assert "WARNING  body read as lying" in res.output
    assert "posterior interval of the lying reading" in res.output
    with np.load(tmp_path / "out" / "canonical.npz", allow_pickle=False) as z:
        assert any("read as lying" in f for f in z["flags"])
        assert _trunk_from_vertical_deg(z["canonical"]) > 75.0
