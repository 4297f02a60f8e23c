"""Joint-angle and joint-speed PNGs (``stages/sinks/plots.py``) and the readability of the rerun
recording (``stages/sinks/rerun_log.py``): floor in the world view, joint labels off, left/right
colours apart, angle plots split into small groups.

Real data: ``tests/fixtures/mocap_small.npz`` (Bandai Namco Research Motiondataset clips,
world frame +Y up, metres, 30 fps; see fixtures/README.md): a walk with a turn (moves
about 3.5 m x 2.7 m, so the floor must follow it) and raising both hands.
"""

from __future__ import annotations

import io

import numpy as np
import pytest
from conftest import FIXTURES, rrd_summary
from pcnet.stages.core.canonical import canonical_rotation, to_canonical
from pcnet.stages.core.conventions import L_WRIST, R_WRIST
from pcnet.stages.isb_angles import NAMES as ISB_NAMES
from pcnet.stages.kinematics import ANGLE_NAMES, compute_kinematics
from pcnet.stages.sinks.plots import (
    ANGLE_GROUPS,
    LEFT_COLOURS,
    RIGHT_COLOURS,
    angle_group,
    group_angles,
    joint_angles_figure,
    joint_speeds_figure,
    plot_joint_angles,
    plot_joint_speeds,
    series_colours,
)

FPS = 30.0
WALK = "dataset-2_walk-turn-left_active_001"
HANDS = "dataset-2_raise-up-both-hands_elderly_024"
MAX_SERIES_PER_PLOT = 6


def _world(clip: str) -> np.ndarray:
    """A clip with its lowest joint on y = 0 (the world frame's floor)."""
    with np.load(FIXTURES / "mocap_small.npz") as d:
        X = d[clip].astype(np.float64)
    return X - np.array([0.0, np.nanmin(X[..., 1]), 0.0])


@pytest.fixture(scope="module")
def walk():
    X = _world(WALK)
    X[50:56, L_WRIST] = np.nan  # a masked wrist: gaps, not zeros
    return X, compute_kinematics(X, FPS, 6.0, "m")


# --- grouping and colours -----------------------------------------------------------------


def test_every_kinematics_angle_has_a_small_named_group(walk):
    _, kin = walk
    names = list(kin.angles)
    assert len(names) == len(ANGLE_NAMES) + len(ISB_NAMES)  # 36: one plot of them is unreadable
    groups = group_angles(names)
    assert "other" not in groups
    assert sorted(n for ns in groups.values() for n in ns) == sorted(names)
    assert max(len(ns) for ns in groups.values()) <= MAX_SERIES_PER_PLOT
    assert groups["hip"] == [f"{s}_hip_{c}" for s in ("left", "right")
                             for c in ("flexion", "adduction", "internal_rotation")]
    assert angle_group("trunk_flexion_to_pelvis_deg") == "trunk"
    assert angle_group("trunk_sagittal_inclination") == "trunk_inclination"
    assert angle_group("right_upper_arm_frontal_inclination") == "upper_arm_inclination"
    assert angle_group("left_knee_flexion") == "knee" and angle_group("left_knee_flexion_unsigned") != "knee"
    assert set(groups) <= set(ANGLE_GROUPS)


def test_left_and_right_never_share_a_colour():
    names = [f"{s}_shoulder_{c}" for s in ("left", "right") for c in ("plane_of_elevation", "elevation", "axial_rotation")]
    colours = series_colours(names)
    assert len(set(colours.values())) == 6
    assert colours["left_shoulder_plane_of_elevation"] == LEFT_COLOURS[0]
    assert colours["right_shoulder_plane_of_elevation"] == RIGHT_COLOURS[0]
    assert not set(LEFT_COLOURS) & set(RIGHT_COLOURS)


# --- PNGs --------------------------------------------------------------------------------


def _png_pixels(path) -> np.ndarray:
    from matplotlib.image import imread

    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return imread(io.BytesIO(data), format="png")


def test_joint_angles_png_has_a_labelled_panel_per_joint(tmp_path, walk):
    _, kin = walk
    fig = joint_angles_figure(kin, FPS, frame_label="world frame")
    axes = [ax for ax in fig.axes if ax.get_visible()]
    titles = [ax.get_title() for ax in axes]
    for joint in ("trunk", "hip", "knee", "shoulder", "elbow"):
        assert any(t.startswith(joint) for t in titles), (joint, titles)
    for ax in axes:
        assert ax.get_ylabel() == "angle (deg)"
        lines = ax.get_lines()
        assert 1 <= len(lines) <= MAX_SERIES_PER_PLOT
        labels = [ln.get_label() for ln in lines]
        # left and right are told apart by line style and colour
        left = [ln for ln in lines if ln.get_label().startswith("left")]
        right = [ln for ln in lines if ln.get_label().startswith("right")]
        assert all(ln.get_linestyle() == "--" for ln in left) and all(ln.get_linestyle() == "-" for ln in right)
        assert len({ln.get_color() for ln in lines}) == len(lines), labels
        # time in seconds on the x axis, the real data (not a placeholder) on y
        t = lines[0].get_xdata()
        assert t[0] == 0.0 and t[-1] == pytest.approx((kin.num_frames - 1) / FPS)
    assert sum(ax.get_xlabel() == "time (s)" for ax in axes) == 2  # the bottom of both columns
    hip = axes[titles.index(next(t for t in titles if t.startswith("hip")))]
    flex = next(ln for ln in hip.get_lines() if ln.get_label() == "right flexion")
    np.testing.assert_array_equal(flex.get_ydata(), kin.angles["right_hip_flexion"])
    # the masked wrist: NaN elbow flexion is drawn as a gap
    elbow = axes[titles.index(next(t for t in titles if t.startswith("elbow")))]
    y = next(ln for ln in elbow.get_lines() if ln.get_label() == "left flexion").get_ydata()
    assert np.isnan(y[50:56]).all() and np.isfinite(y[:50]).any()

    path = plot_joint_angles(tmp_path / "angles.png", kin, FPS, frame_label="world frame")
    img = _png_pixels(path)
    assert path.stat().st_size > 50_000 and img.shape[0] > 600 and img.shape[1] > 1000
    assert img[..., :3].std() > 0.05  # not a blank canvas
    assert [p.name for p in tmp_path.iterdir()] == ["angles.png"]  # atomic: no temporary left


def test_joint_speeds_png_is_in_units_per_second(tmp_path, walk):
    X, kin = walk
    fig = joint_speeds_figure(kin, FPS, "m", frame_label="world frame")
    axes = fig.axes
    assert len(axes) == 3
    assert all(ax.get_ylabel() == "speed (m/s)" for ax in axes)
    assert axes[-1].get_xlabel() == "time (s)"
    wrists = axes[0]
    labels = [ln.get_label() for ln in wrists.get_lines()]
    assert labels[:2] == ["left wrist", "right wrist"]
    y = wrists.get_lines()[0].get_ydata()
    assert np.isnan(y[49:57]).all()  # the gap, widened by the central difference
    # walking: the pelvis moves at a plausible speed (m/s), computed from the positions
    pelvis = axes[2].get_lines()[0]
    assert pelvis.get_label() == "pelvis"
    assert 0.5 < np.nanmedian(pelvis.get_ydata()) < 3.0
    np.testing.assert_allclose(np.nanmedian(pelvis.get_ydata()),
                               np.nanmedian(np.linalg.norm(np.diff(X[:, 0], axis=0), axis=-1) * FPS), rtol=0.1)
    assert "speed (normalised/s)" == joint_speeds_figure(kin, FPS, "normalised").axes[0].get_ylabel()

    path = plot_joint_speeds(tmp_path / "speeds.png", kin, FPS, "m", frame_label="world frame")
    assert path.stat().st_size > 30_000 and _png_pixels(path)[..., :3].std() > 0.05


def test_another_persons_frames_are_shaded_and_named_in_both_figures(walk):
    """Where the 2D track switched person (the Sports2D demo), the frames outside the main
    person's stretch are grey spans over every panel, and the title says what grey means."""
    from matplotlib.patches import Rectangle

    from pcnet.stages.sinks.plots import OTHER_PERSON_NOTE

    _, kin = walk
    other = np.zeros(len(kin.speed), bool)
    other[20:30] = other[40:45] = True
    for figure in (joint_angles_figure, joint_speeds_figure):
        fig = figure(kin, FPS, other_person=other)
        assert OTHER_PERSON_NOTE in fig._suptitle.get_text()
        for ax in (a for a in fig.axes if a.get_visible()):
            spans = [p for p in ax.patches if isinstance(p, Rectangle)]
            assert len(spans) == 2
            x0 = sorted(round(p.get_x() * FPS + 0.5) for p in spans)
            assert x0 == [20, 40]
        plain = figure(kin, FPS)
        assert OTHER_PERSON_NOTE not in plain._suptitle.get_text()
        assert not any(a.patches for a in plain.axes if a.get_visible())
        with pytest.raises(ValueError, match="other_person"):
            figure(kin, FPS, other_person=other[:-1])


def _panel_boxes(fig) -> list:
    """The drawn extent (display pixels) of each visible panel of ``fig``: its axes, title,
    tick labels and axis labels."""
    from matplotlib.transforms import Bbox

    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    boxes = []
    for ax in (a for a in fig.axes if a.get_visible()):
        parts = [ax.bbox, ax.xaxis.get_tightbbox(renderer), ax.yaxis.get_tightbbox(renderer)]
        if ax.get_title():
            parts.append(ax.title.get_window_extent(renderer))
        boxes.append(Bbox.union([b for b in parts if b is not None]))
    return boxes


def test_no_panels_text_overlaps_another_panel_the_title_or_the_picture_edge(walk):
    """The figures' layout is fixed in inches (``plots.new_figure``): every panel's title, tick
    labels and axis labels stay clear of the other panels and of a two-line suptitle, and
    inside the picture, for the three figures, an angle grid with its bottom-right panel
    hidden and tick labels of six characters."""
    import dataclasses

    from pcnet.stages.sinks.exports import wrists_figure
    from pcnet.stages.sinks.plots import gait_cycles_figure

    X, kin = walk
    marked = np.zeros(kin.num_frames, bool)
    marked[20:30] = True
    no_elbow = dataclasses.replace(kin, angles={n: a for n, a in kin.angles.items() if angle_group(n) != "elbow"})
    wrists = [L_WRIST, R_WRIST]
    acc = np.nan_to_num(kin.acceleration[:, wrists])
    figures = {
        "angles": joint_angles_figure(kin, FPS, other_person=marked, implausible=marked),
        "angles, odd panel count": joint_angles_figure(no_elbow, FPS),
        "speeds": joint_speeds_figure(kin, FPS, other_person=marked, implausible=marked),
        "wrists": wrists_figure(X - X[:, :1], X, FPS, acc, acc, other_person=marked, implausible=marked),
        # six-character tick labels: millimetres and accelerations of -10000 mm/s^2
        "wrists in mm": wrists_figure(1000 * (X - X[:, :1]), 1000 * X, FPS, 12000 * np.sin(acc), 12000 * np.sin(acc),
                                      "mm", other_person=marked, implausible=marked),
        # pcnet gait's figure (one row of three panels), its title as long as the others'
        "gait cycles": gait_cycles_figure(
            {f"{s}_{a}_deg": 40 * np.sin(np.linspace(0, 6, 303)).reshape(3, 101) for s in ("left", "right")
             for a in ("hip_flexion", "hip_adduction", "knee_flexion")},
            ("hip_flexion", "hip_adduction", "knee_flexion"), {"left": 60.0, "right": 61.0},
            "Gait cycles: a_run_folder_named_at_length\nmean and 1 SD over strides; vertical lines: mean foot off"),
    }
    for name, fig in figures.items():
        boxes = _panel_boxes(fig)
        assert len(boxes) >= 2, name
        picture = fig.bbox
        title = fig._suptitle.get_window_extent(fig.canvas.get_renderer())
        assert "\n" in fig._suptitle.get_text() or name == "angles, odd panel count"
        for i, box in enumerate(boxes):
            assert picture.x0 <= box.x0 and box.x1 <= picture.x1 and picture.y0 <= box.y0 and box.y1 <= picture.y1, (name, i)
            assert not box.overlaps(title), (name, i)
            for j, other in enumerate(boxes[i + 1:], i + 1):
                assert not box.overlaps(other), (name, i, j)
        assert picture.y0 <= title.y0 and title.y1 <= picture.y1, name


def test_a_short_clip_spans_its_own_time_and_empty_series_say_so():
    """An 8-frame clip (real Bandai walk) has no speed at all (too short to filter): every
    panel still spans the clip's 0..0.23 s, not matplotlib's default -0.05..0.05, and a
    series with no value says so in the legend (a user trial: the legend listed lines that
    were nowhere in the panel)."""
    X = _world(WALK)[:8]
    kin = compute_kinematics(X, FPS, 6.0, "m")
    for figure in (joint_angles_figure, joint_speeds_figure):
        fig = figure(kin, FPS)
        for ax in (a for a in fig.axes if a.get_visible()):
            lo, hi = ax.get_xlim()
            assert lo < 0.0 < 7 / FPS < hi < 8 / FPS, (lo, hi)
    speeds = joint_speeds_figure(kin, FPS)
    labels = [t.get_text() for ax in speeds.axes for t in ax.get_legend().get_texts()]
    assert labels and all(label.endswith("(no values)") for label in labels)
    walk = compute_kinematics(_world(WALK), FPS, 6.0, "m")
    labels = [t.get_text() for ax in joint_speeds_figure(walk, FPS).axes for t in ax.get_legend().get_texts()]
    assert not any("(no values)" in label for label in labels)


def test_plots_refuse_a_wrong_frame_rate_and_leave_nothing(tmp_path, walk):
    _, kin = walk
    with pytest.raises(ValueError, match="fps"):
        plot_joint_angles(tmp_path / "a.png", kin, 25.0)
    with pytest.raises(ValueError, match="fps"):
        plot_joint_speeds(tmp_path / "s.png", kin, 0.0, "m")
    assert list(tmp_path.iterdir()) == []


# --- rerun -------------------------------------------------------------------------------


def _recording(tmp_path, clip: str, **kw):
    from pcnet.stages.sinks.rerun_log import series_from_kinematics, write_recording

    W = _world(clip)
    R, valid = canonical_rotation(W, (0.0, 1.0, 0.0))  # camera frame = world frame here
    can = to_canonical(W, R)
    kin = compute_kinematics(W, FPS, 6.0, "m")
    series = series_from_kinematics(kin)
    kp = np.concatenate([W[..., :2] * 300 + 400, np.full(W.shape[:2] + (1,), 0.9)], -1)
    path = write_recording(tmp_path / "run.rrd", fps=FPS, joints_cam=W, canonical=can, rotations=R,
                           up=R[:, :, 1], valid=valid, keypoints2d=kp, series=series, world=W, **kw)
    return path, W, series


def _static_batch(path, entity: str):
    from rerun.chunk import RrdReader

    batches = [ch.to_record_batch() for ch in RrdReader(path).stream()
               if ch.is_static and ch.entity_path == entity]
    assert batches, f"no static chunk for {entity}"
    return batches


def _column(batches, name: str) -> list:
    return [v for rb in batches if name in rb.schema.names for v in rb.column(name).to_pylist()]


def _time_series_views(path) -> list[tuple[str, list[str]]]:
    """(origin, query expressions) of every TimeSeriesView in the recording's blueprint."""
    from rerun.chunk import RrdReader

    reader = RrdReader(path)
    views: dict[str, dict] = {}
    for ch in reader.stream(store=reader.blueprints()[0]):
        rb = ch.to_record_batch()
        for col in ("ViewBlueprint:class_identifier", "ViewBlueprint:space_origin", "ViewContents:query"):
            if col in rb.schema.names:
                # a view is /view/<id>, its contents /view/<id>/ViewContents
                view_id = ch.entity_path.strip("/").split("/")[1]
                views.setdefault(view_id, {})[col] = rb.column(col).to_pylist()[-1]
    return [(v["ViewBlueprint:space_origin"][0], v["ViewContents:query"]) for v in views.values()
            if v.get("ViewBlueprint:class_identifier", [None])[0] == "TimeSeries"]


def _matches(origin: str, query: list[str], entity: str) -> bool:
    """Evaluate the ``+ X/**`` / ``- X/**`` rules of a view's contents (the only forms used)."""
    keep = False
    for rule in query:
        sign, pattern = rule.split(" ", 1) if rule[:2] in ("+ ", "- ") else ("+", rule)
        prefix = "/" + pattern.replace("$origin", origin).strip("/").removesuffix("/**").strip("/")
        if entity == prefix or entity.startswith(prefix + "/"):
            keep = sign == "+"
    return keep


def test_rerun_world_view_has_a_floor_under_the_whole_walk(tmp_path):
    path, W, _ = _recording(tmp_path, WALK)
    rows, static, _, origins = rrd_summary(path)
    assert "/world/floor" in static and "world" in origins
    strips = [np.array(s) for s in _column(_static_batch(path, "/world/floor"), "LineStrips3D:strips")[0]]
    pts = np.concatenate(strips)
    assert len(strips) >= 8
    np.testing.assert_allclose(pts[:, 1], 0.0)  # the floor plane y = 0
    lo, hi = pts[:, [0, 2]].min(0), pts[:, [0, 2]].max(0)
    xz = W[..., [0, 2]].reshape(-1, 2)
    assert (lo <= xz.min(0)).all() and (hi >= xz.max(0)).all()  # the walk (about 3.5 m) stays on it
    assert ((hi - lo) < (xz.max(0) - xz.min(0)) + 5.0).all()  # and it is not absurdly large
    assert rows["/world/skeleton/joints"] == len(W)
    # floor_frames: the grid spans those frames' joints only (another person's frames left out)
    first = np.arange(len(W)) < len(W) // 4
    part = tmp_path / "part"
    part.mkdir()
    path3, _, _ = _recording(part, WALK, floor_frames=first)
    pts3 = np.concatenate([np.array(s) for s in _column(_static_batch(path3, "/world/floor"), "LineStrips3D:strips")[0]])
    span = W[first][..., [0, 2]].reshape(-1, 2)
    lo3, hi3 = pts3[:, [0, 2]].min(0), pts3[:, [0, 2]].max(0)
    assert (lo3 <= span.min(0)).all() and (hi3 >= span.max(0)).all() and ((hi3 - lo3) < (hi - lo)).any()
    # floor=False leaves it out
    off = tmp_path / "off"
    off.mkdir()
    path2, _, _ = _recording(off, HANDS, floor=False)
    assert "/world/floor" not in rrd_summary(path2)[1]


def test_rerun_joint_labels_are_off_by_default(tmp_path):
    path, _, _ = _recording(tmp_path, HANDS)
    for entity in ("/world/skeleton/joints", "/canonical/skeleton/joints", "/camera/skeleton/joints"):
        assert _column(_static_batch(path, entity), "Points3D:show_labels") == [[False]], entity
    assert _column(_static_batch(path, "/video/keypoints"), "Points2D:show_labels") == [[False]]
    on = tmp_path / "on"
    on.mkdir()
    path_on, _, _ = _recording(on, HANDS, show_labels=True)
    assert _column(_static_batch(path_on, "/world/skeleton/joints"), "Points3D:show_labels") == [[True]]


def test_rerun_time_series_are_split_into_small_groups_with_side_colours(tmp_path):
    path, _, series = _recording(tmp_path, WALK)
    entities = ["/series/" + n for n in series] + ["/series/status/valid"]
    views = _time_series_views(path)
    angle_views = [o for o, _ in views if o.startswith("series/angles_deg/")]
    assert len(angle_views) >= 5  # trunk, hip, knee, shoulder, elbow at least
    shown = {}
    for origin, query in views:
        members = [e for e in entities if _matches(origin, query, e)]
        assert 1 <= len(members) <= MAX_SERIES_PER_PLOT, (origin, members)
        for e in members:
            shown[e] = shown.get(e, 0) + 1
    assert shown == {e: 1 for e in entities}  # every series in exactly one plot
    # each series line has its colour; left and right of one plot never share one
    for origin in ("series/angles_deg/hip", "series/position_m"):
        colours = {}
        for e in entities:
            if e.rsplit("/", 1)[0] == "/" + origin:
                colours[e] = tuple(_column(_static_batch(path, e), "SeriesLines:colors")[0])
        assert len(colours) == 6 and len(set(colours.values())) == 6, origin


def test_long_series_are_drawn_from_their_extremes():
    """A 2-hour series is drawn from per-bin minima and maxima: every peak, the envelope and
    the gaps survive; short series are drawn as they are."""
    from pcnet.stages.sinks.plots import display_samples

    with np.load(FIXTURES / "mocap_small.npz") as d:
        wrist = d["dataset-2_walk-turn-left_active_001"][:, 16, 1].astype(np.float64)  # real right-wrist height
    y = np.tile(wrist, 1800)  # 216,000 samples
    t = np.arange(len(y)) / 30.0
    y[100_000] = 5.0  # a one-sample spike
    y[150_000:150_040] = np.nan  # a gap
    tt, yy = display_samples(t, y)
    assert len(tt) <= 4000 and np.all(np.diff(tt) >= 0)
    assert np.nanmax(yy) == 5.0 and np.nanmin(yy) == np.nanmin(y)
    gap_t = tt[np.isnan(yy)]
    assert len(gap_t) >= 1 and np.all(np.abs(gap_t - 150_020 / 30.0) < 5.0)
    short_t, short_y = display_samples(t[:300], y[:300])
    np.testing.assert_array_equal(short_y, y[:300])


def test_a_stopped_recording_writer_is_an_oserror_not_a_wait_forever(tmp_path, monkeypatch):
    """rerun's file writer stops on a full disk, and its flush then waited forever, deaf to
    SIGTERM (a file-safety trial's run hung 10 minutes on a 4 MB tmpfs; a file size limit gave a
    60-line traceback). The flush now waits a second at a time and turns a writer that shut
    down, or a file that stopped growing, into an OSError the run reports in one line."""
    import errno

    from pcnet.stages.sinks import rerun_log

    path = tmp_path / "r.rrd"
    path.write_bytes(b"x")
    monkeypatch.setattr(rerun_log, "_WRITER_STOPPED", [])  # this process's own flag: not the test's

    class Stream:
        def __init__(self, message: str):
            self.message, self.calls = message, 0

        def flush(self, *, timeout_sec: float) -> None:
            assert timeout_sec <= 1.0  # short waits: signals are heard between them
            self.calls += 1
            raise RuntimeError(self.message)

    with pytest.raises(OSError) as err:
        rerun_log._flusher(Stream("File-writer thread shut down prematurely"), path)()
    assert err.value.errno in (errno.ENOSPC, errno.EFBIG, errno.EIO) and err.value.filename == str(path)
    monkeypatch.setattr(rerun_log, "STALLED_WRITER_S", 0.05)
    stalled = Stream("flush timed out")
    with pytest.raises(OSError, match="rerun's file writer stopped"):
        rerun_log._flusher(stalled, path)()
    assert stalled.calls >= 2  # it waited again while the file might still grow

    class Done:
        def flush(self, *, timeout_sec: float) -> None:
            return None

    rerun_log._flusher(Done(), path)()  # a writer that keeps up returns at once
