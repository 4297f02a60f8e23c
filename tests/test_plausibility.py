"""Plausibility flags for motion faster than any training motion (``stages/plausibility.py``, GitHub issue 51):
the shipped limits and their provenance, detection on real motion with and without an injected
glitch, the flag line, and the mask in the npz, the plots and the recording.

Real data: ``tests/fixtures/mocap_small.npz`` (Bandai clips: a walk with a turn, a run, raising
both hands), ``tests/fixtures/bandai_test_clips.npz`` (twelve held-out Bandai clips) and the
real VideoPose3D yoga exports (``yoga_*.npy``; fixtures/README.md). The fit's own data
(``../shared/data``) only for the check that the shipped numbers are the training maxima.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from conftest import FIXTURES, rrd_summary
from pcnet.stages.core.canonical import canonical_rotation, to_canonical
from pcnet.stages.core.conventions import H36M_JOINTS, HEAD, R_WRIST
from pcnet.stages.core.errors import InputError
from pcnet.stages.kinematics import compute_kinematics, count_flags
from pcnet.stages.plausibility import (
    LIMITS_PATH, MAX_RANGES_LISTED, ImplausibleMotion, implausible_frames, implausible_motion,
    implausible_motion_flags, load_motion_limits, merge_gap_frames, motion_check_note, pelvis_relative_motion)

FPS = 30.0
RUN = "dataset-2_run_masculine_037"
DATA = FIXTURES.parents[2] / "shared" / "data"


def _clip(name: str = RUN) -> np.ndarray:
    with np.load(FIXTURES / "mocap_small.npz") as d:
        return d[name].astype(np.float64)


def _glitched(frames=(40, 41), joint=R_WRIST, metres=0.8) -> np.ndarray:
    """The real run with one joint thrown ``metres`` sideways in ``frames``: a detector jump or
    a left/right swap (a wrist to the other side of the body) of the kind lifters make."""
    X = _clip()
    X[list(frames), joint, 0] += metres
    return X


# --- the shipped limits --------------------------------------------------------------------


def test_shipped_limits_load_with_provenance_and_cover_every_joint_but_the_pelvis():
    from pcnet.pipeline.config import DEFAULT_CUTOFF_HZ

    limits = load_motion_limits()
    prov = limits.provenance
    # the command that wrote them: `python -m benchmarks.fit_speed_limits` since benchmarks/ became a package
    assert prov["command"].startswith("python -m benchmarks.fit_speed_limits")
    assert sorted(prov["data"]) == ["mocap/bandai_h36m17.npz", "mocap/cmu_train_h36m17.npz"]
    assert "train" in prov["split"] and prov["frames"] > 100_000 and prov["date"][:2] == "20"
    assert "DeepMimic" in prov["not_used"]
    # the filter pcnet's kinematics use by default, so the flag reads what speeds.png shows
    assert limits.cutoff_hz == DEFAULT_CUTOFF_HZ and limits.order == 4
    covered = sorted(j for g in limits.groups.values() for j in g)
    assert covered == sorted(j for j in H36M_JOINTS if j != "pelvis")
    assert limits.limit("pelvis", "speed") is None
    # distal joints move faster than proximal ones, as in any human motion
    assert limits.limit("right_wrist", "speed") > limits.limit("right_elbow", "speed") > \
        limits.limit("right_shoulder", "speed")
    assert limits.limit("left_ankle", "speed") > limits.limit("left_knee", "speed") > limits.limit("left_hip", "speed")
    # the Sports2D numbers (head 5.5 m/s, wrist 14.8 m/s) lie beyond them
    assert limits.limit("head", "speed") < 5.5 and limits.limit("left_wrist", "speed") < 14.8
    assert "motion_limits.json" in limits.source


def test_limits_file_ships_in_the_package_data():
    import tomllib

    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    globs = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["pcnet.stages"]
    assert any(LIMITS_PATH.relative_to(root / "stages").match(g) for g in globs)


@pytest.mark.skipif(not (DATA / "mocap" / "cmu_train_h36m17.npz").is_file(), reason="needs ../shared/data")
def test_shipped_limits_are_the_training_maxima_on_cmu():
    """Every CMU training clip stays within the limits, and each limit the fit found on a CMU
    clip is that clip's maximum (the file says where): the numbers are the fit's."""
    from pcnet.models.datasets import load_mocap, select_split

    limits = load_motion_limits()
    clips = {c.name: c for c in select_split(load_mocap(DATA / "mocap" / "cmu_train_h36m17.npz"), "train",
                                             "motion-style")}
    doc = json.loads(LIMITS_PATH.read_text())
    for c in clips.values():
        assert implausible_motion(c.joints, c.fps, limits=limits) == [], c.name
    checked = 0
    for group, entry in doc["groups"].items():
        for q, unit in (("speed", "m_per_s"), ("acceleration", "m_per_s2")):
            at = entry[f"{q}_at"]
            if at["clip"] in clips:
                s, a = pelvis_relative_motion(clips[at["clip"]].joints, FPS, limits.cutoff_hz, limits.order,
                                              [at["joint"]])
                assert (s if q == "speed" else a)[at["frame"], 0] == pytest.approx(entry[f"{q}_{unit}"], abs=1e-3)
                checked += 1
    assert checked >= 8


def test_a_broken_limits_file_is_refused_by_name(tmp_path):
    doc = json.loads(LIMITS_PATH.read_text())
    del doc["groups"]["wrists"]["speed_m_per_s"]
    bad = tmp_path / "limits.json"
    bad.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="wrists.speed_m_per_s"):
        load_motion_limits(bad)
    bad.write_text(json.dumps({k: v for k, v in json.loads(LIMITS_PATH.read_text()).items() if k != "provenance"}))
    with pytest.raises(InputError, match="provenance"):
        load_motion_limits(bad)


# --- detection -------------------------------------------------------------------------------


def test_clean_real_motion_is_not_flagged():
    """Held-out Bandai clips, the fixture's walk, run and arm raises, and real VideoPose3D
    lifter output (standing, seated, lying, prone)."""
    with np.load(FIXTURES / "bandai_test_clips.npz") as d:
        clips = {k: d[k].astype(np.float64) for k in d.files}
    with np.load(FIXTURES / "mocap_small.npz") as d:
        clips |= {k: d[k].astype(np.float64) for k in d.files}
    for name in ("yoga_vp3d_Bhumi_Tadasana.npy", "yoga_Abhay_Padmasana_f200-299.npy",
                 "yoga_Abhay_Shavasana_f200-299.npy", "yoga_Abhay_Bhujangasana_f150-249.npy"):
        clips[name] = np.load(FIXTURES / name).astype(np.float64)  # camera frame: any fixed frame will do
    assert len(clips) == 19
    for name, X in clips.items():
        assert implausible_motion(X, FPS) == [], name


def test_a_glitched_wrist_is_flagged_on_the_glitch_frames_and_nowhere_else():
    X = _glitched((40, 41))
    found = implausible_motion(X, FPS)
    assert {f.joint for f in found} == {"right_wrist"}
    assert {f.quantity for f in found} == {"speed", "acceleration"}
    mask = implausible_frames(found, len(X))
    flagged = np.flatnonzero(mask)
    # the glitch frames are inside; the low-pass spreads a sample over about a period of its
    # cutoff, so the range reaches at most that far beyond them, and nowhere else
    gap = merge_gap_frames(FPS, 6.0)
    assert mask[40:42].all()
    assert flagged.min() >= 40 - gap and flagged.max() <= 41 + gap
    assert np.all(np.diff(flagged) == 1)  # one range
    speed = next(f for f in found if f.quantity == "speed")
    assert speed.peak > speed.limit == load_motion_limits().limit("right_wrist", "speed")
    assert 40 - gap <= speed.peak_frame <= 41 + gap and speed.unit == "m/s"
    # without the glitch nothing: the flag is the glitch's
    assert implausible_motion(_clip(), FPS) == []


def test_a_longer_displacement_is_one_range_covering_it():
    """Out and back again six frames later: a speed peak at each end, plausible motion
    between; merged into one range that covers the displaced frames."""
    found = implausible_motion(_glitched(range(40, 46)), FPS)
    speed = [f for f in found if f.quantity == "speed"]
    assert len(speed) == 1 and speed[0].first_frame <= 40 and speed[0].last_frame >= 45


def test_nan_frames_are_carried_and_never_flagged():
    X = _glitched((40, 41))
    X[60:64] = np.nan  # a frame without a pose
    X[10:12, HEAD] = np.nan  # a missing joint
    found = implausible_motion(X, FPS)
    mask = implausible_frames(found, len(X))
    assert not mask[60:64].any() and mask[40:42].all()
    assert {f.joint for f in found} == {"right_wrist"}
    speed, acc = pelvis_relative_motion(X, FPS, 6.0)
    assert np.isnan(speed[60:64]).all() and np.isnan(acc[10:12, HEAD]).all()


def test_motion_is_judged_relative_to_the_pelvis_in_any_fixed_frame():
    """A body carried along (a root path, a turned camera) moves its joints at the root's
    speed: not the joints' own, and not flagged; a fixed rotation changes nothing."""
    X = _clip()
    carried = X + np.arange(len(X))[:, None, None] * np.array([0.5, 0.0, 0.0])  # 15 m/s pelvis
    assert implausible_motion(carried, FPS) == []
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ np.diag([1.0, -1.0, -1.0])
    a = pelvis_relative_motion(_glitched(), FPS, 6.0)
    b = pelvis_relative_motion(_glitched() @ R.T, FPS, 6.0)
    np.testing.assert_allclose(a, b, atol=1e-9, equal_nan=True)


def test_non_metric_runs_and_low_frame_rates_are_not_checked_and_say_why():
    X = _glitched()
    assert implausible_motion(X, FPS, units="normalised") == []
    assert "normalised" in motion_check_note("normalised", FPS) and "--height" in motion_check_note("normalised", FPS)
    assert implausible_motion(X[::3], 10.0) == []  # 10 fps cannot be filtered at 6 Hz
    assert "10 fps" in motion_check_note("m", 10.0)
    assert motion_check_note("m", FPS) is None


def test_a_long_recording_on_disk_is_read_a_joint_at_a_time(tmp_path):
    from pcnet.stages.core.framestore import FrameStore

    X = _glitched()
    with FrameStore(tmp_path) as store:
        arr = store.create("poses", X.shape, np.float64)
        arr[:] = X
        assert implausible_motion(arr, FPS) == implausible_motion(X, FPS) != []


def test_wrong_shapes_and_rates_are_refused():
    with pytest.raises(InputError, match="17, 3"):
        implausible_motion(np.zeros((10, 16, 3)), FPS)
    with pytest.raises(InputError, match="fps"):
        implausible_motion(_clip(), 0.0)
    with pytest.raises(InputError, match="within"):
        implausible_frames([ImplausibleMotion("head", "speed", 5, 12, 9.0, 6, 4.0, "m/s")], 10)


# --- the flag line -----------------------------------------------------------------------------


def test_flag_lines_name_ranges_peaks_limits_source_and_what_to_do():
    X = _glitched((40, 41))
    X[70:72, R_WRIST, 0] += 0.8
    found = implausible_motion(X, FPS)
    lines = implausible_motion_flags(found)
    assert len(lines) == 2 and lines[0].startswith("joint speed") and lines[1].startswith("joint acceleration")
    speed = lines[0]
    peak = max(f.peak for f in found if f.quantity == "speed")
    ranges = [(f.first_frame, f.last_frame) for f in found if f.quantity == "speed"]
    assert len(ranges) == 2
    assert ", ".join(f"{a}-{b}" for a, b in ranges) in speed
    assert f"right wrist {peak:.1f} m/s" in speed and f"limit {load_motion_limits().limit('right_wrist', 'speed'):.2f}" in speed
    assert "motion_limits.json" in speed and "implausible_frames" in speed
    assert "check the input's poses (and 2D keypoints, where given)" in speed  # a Kinect run has none
    # the limits are the training motion's fastest, not a human's (a sprint coach's 3.7 m/s jog passed them)
    assert speed.startswith("joint speed beyond any training motion's in frames") and "human" not in speed
    # measured about the pelvis, which kinematics.csv's world-frame columns are not (a trial compared them)
    assert "These are speeds relative to the pelvis, not kinematics.csv's world-frame columns" in speed
    assert implausible_motion_flags([]) == []


def test_flag_lines_merge_touching_ranges_and_cap_the_list():
    f = [ImplausibleMotion("right_wrist", "speed", 10 * k, 10 * k + 2, 9.0 + k, 10 * k + 1, 8.0, "m/s")
         for k in range(MAX_RANGES_LISTED + 3)]
    f.append(ImplausibleMotion("left_wrist", "speed", 3, 4, 8.5, 3, 8.0, "m/s"))  # touches 0-2: one range 0-4
    (line,) = implausible_motion_flags(f)
    assert "frames 0-4, 10-12," in line and "and 3 more ranges" in line
    assert line.index("right wrist") < line.index("left wrist")  # the worst first


# --- sinks --------------------------------------------------------------------------------------


def _result(X: np.ndarray, implausible):
    from pcnet.stages.rectification_report import HeadingChoice, ModeChoice, RectificationReport
    from pcnet.stages.sinks.result import RecordingResult

    R, valid = canonical_rotation(X, (0.0, 1.0, 0.0))
    can = to_canonical(X, R)
    missing = ~np.isfinite(X).all(-1)
    report = RectificationReport(ModeChoice("sequence", "sequence"), None, HeadingChoice("hips", "auto", 1.0, 2.0),
                                 None, None, float("nan"), np.full(len(X), np.nan))
    return RecordingResult(
        fps=FPS, units="m", method="pcnet", rectification=report, flags=[], notes=[],
        joints_camera=X - X[:, :1], rotation=R, canonical=can, valid=valid, kinematics_frame="world", poses=X,
        world=X, world_rotation=np.eye(3), missing=missing, unfiltered=np.zeros_like(missing),
        flag_counts=count_flags(missing, np.zeros_like(missing)), implausible_frames=implausible)


def test_the_npz_carries_the_mask_and_keeps_every_other_array(tmp_path):
    from pcnet.stages.sinks.result import write_arrays

    X = _glitched()
    mask = implausible_frames(implausible_motion(X, FPS), len(X))
    plain = tmp_path / "plain"
    plain.mkdir()
    write_arrays(_result(X, None), plain)
    write_arrays(_result(X, mask), tmp_path)
    with np.load(tmp_path / "canonical.npz", allow_pickle=False) as z, \
            np.load(plain / "canonical.npz", allow_pickle=False) as unchecked:
        assert z["implausible_frames"].dtype == bool
        np.testing.assert_array_equal(z["implausible_frames"], mask)
        assert z["implausible_frames"][40:42].all()
        assert unchecked["implausible_frames"].shape == (0,)  # not checked: empty
        assert set(z.files) == set(unchecked.files)
        for key in ("rotation", "canonical", "joints_camera", "valid", "missing", "joints_world", "flags", "notes"):
            assert key in z.files
    with pytest.raises(ValueError, match="implausible_frames"):
        write_arrays(_result(X, mask[:-1]), tmp_path)


def test_implausible_frames_are_shaded_red_in_both_figures():
    from matplotlib.patches import Rectangle

    from pcnet.stages.sinks.plots import IMPLAUSIBLE_COLOUR, IMPLAUSIBLE_NOTE, joint_angles_figure, joint_speeds_figure

    X = _glitched()
    kin = compute_kinematics(X, FPS, 6.0, "m")
    mask = implausible_frames(implausible_motion(X, FPS), len(X))
    first = int(np.flatnonzero(mask)[0])
    for figure in (joint_angles_figure, joint_speeds_figure):
        fig = figure(kin, FPS, implausible=mask)
        assert IMPLAUSIBLE_NOTE in fig._suptitle.get_text()
        for ax in (a for a in fig.axes if a.get_visible()):
            spans = [p for p in ax.patches if isinstance(p, Rectangle)]
            assert len(spans) == 1
            assert tuple(spans[0].get_facecolor()[:3]) == pytest.approx(IMPLAUSIBLE_COLOUR)
            assert round(spans[0].get_x() * FPS + 0.5) == first
        assert IMPLAUSIBLE_NOTE not in figure(kin, FPS)._suptitle.get_text()
        with pytest.raises(ValueError, match="implausible"):
            figure(kin, FPS, implausible=mask[:-1])


def test_the_recording_logs_the_flagged_frames(tmp_path):
    from pcnet.stages.sinks.rerun_log import write_recording

    X = _glitched()
    mask = implausible_frames(implausible_motion(X, FPS), len(X))
    R, valid = canonical_rotation(X, (0.0, 1.0, 0.0))
    assert valid.all()
    valid[0] = False  # not checked there: nothing logged, as kinematics.csv leaves it empty (a user trial saw 0)
    kw = dict(fps=FPS, joints_cam=X, canonical=to_canonical(X, R), rotations=R, up=R[:, :, 1], valid=valid)
    segment = np.where(np.arange(len(X)) < 20, 0.0, 1.0)
    segment[5] = np.nan  # nobody tracked in that frame
    path = write_recording(tmp_path / "run.rrd", implausible_frames=mask, track_segment=segment, **kw)
    rows, _, chunks, _ = rrd_summary(path)
    assert rows["/series/status/implausible_motion"] == len(X) - 1

    def logged(entity):
        return np.concatenate([np.asarray(ch.to_record_batch().column("Scalars:scalars").to_pylist(), float).ravel()
                               for ch in chunks[entity]])

    np.testing.assert_array_equal(logged("/series/status/implausible_motion"), mask[1:].astype(float))
    # a track switch shows on the timeline (a user trial: the other person's frames looked like the first's)
    np.testing.assert_array_equal(logged("/series/status/track_segment"), segment[np.isfinite(segment)])
    unchecked = write_recording(tmp_path / "plain.rrd", **kw)
    assert "/series/status/implausible_motion" not in rrd_summary(unchecked)[0]
    with pytest.raises(ValueError, match="implausible_frames"):
        write_recording(tmp_path / "bad.rrd", implausible_frames=mask[:-1], **kw)


def test_findings_are_frozen():
    f = ImplausibleMotion("head", "speed", 1, 2, 6.0, 1, 4.0, "m/s")
    with pytest.raises(dataclasses.FrozenInstanceError):
        f.peak = 1.0  # type: ignore[misc]


def test_one_marked_frame_of_a_ten_minute_plot_is_visible(tmp_path):
    """A user trial's ten-minute session: each flagged frame was under a pixel wide in the
    saved figure. A span is drawn at least MIN_SPAN_PX wide, so the saved PNG shows it."""
    import matplotlib.image

    from pcnet.stages.sinks.plots import IMPLAUSIBLE_COLOUR, MIN_SPAN_PX, joint_speeds_figure, save_png

    X = np.tile(_glitched(), (int(np.ceil(600 * FPS / len(_glitched()))), 1, 1))[: int(600 * FPS)]
    kin = compute_kinematics(X, FPS, 6.0, "m")
    mask = np.zeros(len(X), bool)
    mask[len(X) // 2] = True
    png = save_png(joint_speeds_figure(kin, FPS, implausible=mask), tmp_path / "speeds.png")
    image = matplotlib.image.imread(png)[..., :3]
    red = np.all(np.abs(image - np.array(IMPLAUSIBLE_COLOUR)) < 0.02, axis=-1)
    widest = int(np.max(np.sum(red, axis=1)))
    assert widest >= MIN_SPAN_PX - 1, widest
