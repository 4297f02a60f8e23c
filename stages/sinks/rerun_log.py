"""A rerun (``.rrd``) recording of one pcnet run: video with 2D keypoints, the skeleton
in the camera frame and in the canonical frame, wrist paths, and time series.

Written for rerun-sdk 0.41 (API as defined in the rerun-sdk 0.41.0 Python package:
``rerun/recording_stream.py`` ``RecordingStream.save``/``send_columns``,
``rerun/_send_columns.py``, ``rerun/blueprint/``; reference docs at
ref.rerun.io/docs/python): an explicit
``rr.RecordingStream`` (never the global one) saved with a default blueprint, and
columnar ``rr.send_columns`` for every per-frame series, so 36,000 frames take about a
second (no per-frame ``rr.log`` loop).

Entity tree (all per-frame data is on the ``frame`` (sequence) and ``video_time``
(duration, seconds) timelines)::

    /                               AnnotationContext: H36M-17 keypoint names and colours
    /video                          AssetVideo (static) + VideoFrameReference per video frame
    /video/keypoints                Points2D, 2D keypoints (px of the video as rerun shows it), keypoint_ids = H36M index;
                                    those the run did not use (low confidence, outside the picture) are not drawn
    /video/skeleton                 LineStrips2D, one strip per bone
    /camera                         ViewCoordinates RDF (OpenCV camera frame), static
    /camera/skeleton/joints         Points3D
    /camera/skeleton/bones          LineStrips3D
    /camera/body_axes               Arrows3D: canonical X (anterior, red), Y (up, green),
                                    Z (subject's right, blue), drawn at the pelvis
    /camera/up                      Arrows3D: the estimated up direction (yellow)
    /camera/wrist_paths/{side}      LineStrips3D (static): pelvis-relative wrist paths
    /canonical                      ViewCoordinates FUR (X forward, Y up, Z right), static
    /canonical/skeleton/joints      Points3D
    /canonical/skeleton/bones       LineStrips3D
    /canonical/wrist_paths/{name}   LineStrips3D (static), one strip per finite run (no world given)
    /world                          ViewCoordinates FUR, static (when world poses are given)
    /world/skeleton/joints, bones   as for canonical, in the recording's fixed world frame
    /world/wrist_paths/{name}       LineStrips3D (static), the wrist paths when world is given
    /world/floor                    LineStrips3D (static): a grid on the floor plane y = 0
                                    around the subject's horizontal extent (world only)
    /series/{group}/{name}          Scalars (+ SeriesLines, static), one row per frame
                                    where the value is finite; ``group`` may be nested
                                    (``angles_deg/hip``): one plot per group
    /series/status/valid            Scalars: 1 where the rotation is valid, else 0
    /series/status/implausible_motion  Scalars: 1 in frames of motion faster than any training motion
                                    (stages/plausibility.py), else 0 (only when checked; valid frames)
    /series/status/track_segment    Scalars: the 2D track's person segment (0, then 1, 2, ...
                                    after each switch; only with 2D keypoints)
    /flags                          TextDocument (static, markdown): the run's warnings

Readability: joint labels are off by default (``show_labels=False`` on the 2D and 3D
joints: the H36M names from the annotation context would cover the person; hovering a
joint still shows its name); left joints and bones blue, right red, midline grey; series
colours from :func:`pcnet.stages.sinks.plots.series_colours` (left cool, right warm, so left
and right never share a colour); angles split into one plot per joint or segment
(:func:`pcnet.stages.sinks.plots.angle_group`, at most six series each).

Missing data is left out, never drawn as zeros: NaN joints, bones with a NaN end,
invalid frames' arrows and non-finite series samples are simply not logged for that
frame (an empty batch on a frame clears the previous one).
"""

from __future__ import annotations

import errno
import os
import resource
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_path
from ..core.conventions import H36M_BONES, H36M_JOINTS, L_WRIST, PELVIS, R_WRIST, THORAX
from ..core.errors import InputError
from ..core.framestore import FrameArray, FrameColumn, column, frame_blocks, per_frame, true_runs
from .plots import LEFT_COLOURS, RIGHT_COLOURS, angle_group, series_colours

_BONE_A = np.array([a for a, _ in H36M_BONES])
_BONE_B = np.array([b for _, b in H36M_BONES])

# Left blue, right red, midline grey (the usual pose-viewer colouring); the same blue and
# red start the series colour families of stages/sinks/plots.py.
_LEFT_C, _RIGHT_C, _MID_C = LEFT_COLOURS[0], RIGHT_COLOURS[0], (170, 170, 170)
_FLOOR_C = (105, 105, 105)
#: Frames per send_columns call.
SEND_BLOCK_FRAMES = 4096
#: Seconds a flush may wait while the recording's file does not grow before its writer counts as
#: stopped: rerun's file writer stops on a full disk and a flush then waits forever, deaf to Ctrl-C
#: and SIGTERM (a file-safety trial's run hung over 10 minutes on a 4 MB tmpfs). An I/O setting, not a model
#: parameter: long enough for a slow network share to write one block.
STALLED_WRITER_S = 30.0


#: Set once a recording's file writer stopped in this process: rerun's own shutdown at exit then
#: waits on it forever (:func:`writer_stopped`).
_WRITER_STOPPED: list[Path] = []


def writer_stopped() -> bool:
    """Whether a recording's rerun file writer stopped in this process (a full disk, a file size
    limit): its queued data can never be written, and rerun's shutdown at interpreter exit waits
    on it, so the command line leaves with ``os._exit`` once its own clean-up and error line are
    done (measured: a full 5 MB tmpfs held the process after its error line until SIGKILL)."""
    return bool(_WRITER_STOPPED)


def _writer_stopped(path: Path, err: Exception | None) -> OSError:
    """The ``OSError`` a stopped rerun file writer stands for (rerun logs the cause, it does
    not return it): a full disk or quota where no room is left beside ``path``, a file size limit
    where ``path`` reached it, else an input/output error naming rerun's message."""
    try:
        room = os.statvfs(path.parent)
        # no block left, or an inode table that is full (a file system without one reports 0 of 0)
        full = room.f_bavail * room.f_frsize < max(room.f_frsize, 1) or (room.f_files > 0 and room.f_favail == 0)
    except OSError:
        full = False
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    size = path.stat().st_size if path.exists() else 0
    code = (errno.ENOSPC if full else errno.EFBIG if limit != resource.RLIM_INFINITY and size >= limit - (1 << 20)
            else errno.EIO)
    _WRITER_STOPPED.append(path)
    text = os.strerror(code) if code != errno.EIO else f"rerun's file writer stopped: {err or 'it wrote nothing'}"
    return OSError(code, text, str(path))


class _Growth:
    """Whether the recording's file at ``path`` has stopped growing: :meth:`stalled` is asked
    after each one-second wait of :func:`_bounded` and :func:`_flusher`, and is true once the
    file's size has not changed for :data:`STALLED_WRITER_S`."""

    def __init__(self, path: Path) -> None:
        self.path, self.size, self.since = path, None, time.monotonic()

    def stalled(self) -> bool:
        now = self.path.stat().st_size if self.path.exists() else -1
        if now != self.size:
            self.size, self.since = now, time.monotonic()
            return False
        return time.monotonic() - self.since > STALLED_WRITER_S


def _bounded(call: Callable[[], None], path: Path) -> None:
    """``call()`` (a rerun call that may wait on the file writer inside native code: ``save``
    hands the queued blueprint to it) run in a daemon thread and waited on a second at a time;
    :func:`_writer_stopped`'s ``OSError`` where ``path`` stops growing for
    :data:`STALLED_WRITER_S` before it returns (the thread is then left to the process's exit,
    which :func:`writer_stopped` makes immediate)."""
    import threading

    failure: list[BaseException] = []

    def run() -> None:
        try:
            call()
        except BaseException as err:  # handed to the waiting thread
            failure.append(err)

    worker = threading.Thread(target=run, name="pcnet-rerun-save", daemon=True)
    worker.start()
    growth = _Growth(path)
    while worker.is_alive():
        worker.join(1.0)
        if growth.stalled() and worker.is_alive():
            raise _writer_stopped(path, None)
    if failure:
        raise failure[0]


def _flusher(rec, path: Path) -> Callable[[], None]:
    """``rec.flush()`` for a recording saved to ``path``, waited on a second at a time (so that
    Ctrl-C and SIGTERM are heard between the waits), and raised as :func:`_writer_stopped`'s
    ``OSError`` where rerun says its writer shut down or the file stops growing for
    :data:`STALLED_WRITER_S` (``pcnet run`` then names its ``--out`` in one line)."""
    def flush() -> None:
        growth = _Growth(path)
        while True:
            try:
                rec.flush(timeout_sec=1.0)
                return
            except RuntimeError as err:
                if "shut down" in str(err):  # rerun's "File-writer thread shut down prematurely"
                    raise _writer_stopped(path, err) from err
            if growth.stalled():
                raise _writer_stopped(path, None)
    return flush


def _side_colour(name: str) -> tuple[int, int, int]:
    return _LEFT_C if name.startswith("left") else _RIGHT_C if name.startswith("right") else _MID_C


_JOINT_COLOURS = np.array([_side_colour(n) for n in H36M_JOINTS], dtype=np.uint8)
_BONE_COLOURS = _JOINT_COLOURS[_BONE_B]
_AXIS_COLOURS = np.array([(230, 40, 40), (40, 200, 40), (40, 90, 240)], dtype=np.uint8)
_AXIS_LABELS = ["X anterior", "Y up", "Z right"]
_UP_COLOUR = (250, 200, 0)


def _check(name: str, arr: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray:
    # float32 stays float32 (what rerun stores): a float64 copy of a 2-hour recording's poses is 88 MB each.
    if isinstance(arr, (FrameArray, FrameColumn)):  # on disk, read a block at a time when sent
        if tuple(arr.shape) != shape:
            raise InputError(f"write_recording: {name} must have shape {shape}, got {tuple(arr.shape)}")
        return arr
    a = np.asarray(arr)
    a = a if a.dtype in (np.float32, np.float64) else a.astype(np.float64)
    if a.shape != shape:
        raise InputError(f"write_recording: {name} must have shape {shape}, got {a.shape}")
    return a


def _points_columns(rr, X: np.ndarray, joint_ok: np.ndarray | None = None, dims: int = 3):
    """Per-frame partitions of the finite (and ``joint_ok``) joints of ``X`` ``(T, 17, dims)``."""
    keep = np.isfinite(X).all(-1)
    if joint_ok is not None:
        keep &= joint_ok
    kid = np.broadcast_to(np.arange(X.shape[1]), keep.shape)[keep]
    arche = rr.Points3D if dims == 3 else rr.Points2D
    return arche.columns(positions=X[keep], keypoint_ids=kid).partition(keep.sum(1))


def _strips_array(rr, seg: np.ndarray, dims: int):
    """``(N, P, dims)`` same-length strips -> the Arrow array rerun stores.

    rerun's numpy path computes the list offsets in a Python loop over strips (~1 s per
    500k bones); building the list array directly is ~100x faster. The Arrow type is
    taken from rerun itself so it always matches the installed version.
    """
    import pyarrow as pa

    batch = rr.components.LineStrip3DBatch if dims == 3 else rr.components.LineStrip2DBatch
    strip_type = batch([np.zeros((2, dims))]).as_arrow_array().type
    n, p = seg.shape[:2]
    points = pa.FixedSizeListArray.from_arrays(
        pa.array(np.ascontiguousarray(seg, dtype=np.float32).reshape(-1)), type=strip_type.value_type
    )
    offsets = pa.array(np.arange(0, n * p + 1, p, dtype=np.int32))
    return pa.ListArray.from_arrays(offsets, points, type=strip_type)


def _bones_columns(rr, X: np.ndarray, joint_ok: np.ndarray | None = None, dims: int = 3):
    """Per-frame partitions of the bones of ``X`` whose two ends are finite."""
    seg = np.stack([X[:, _BONE_A], X[:, _BONE_B]], axis=2)  # (T, 16, 2, dims)
    keep = np.isfinite(seg).all((-1, -2))
    if joint_ok is not None:
        keep &= joint_ok[:, _BONE_A] & joint_ok[:, _BONE_B]
    colours = np.broadcast_to(_BONE_COLOURS, keep.shape + (3,))[keep]
    arche = rr.LineStrips3D if dims == 3 else rr.LineStrips2D
    strips = _strips_array(rr, seg[keep], dims)
    return arche.columns(strips=strips, colors=colours).partition(keep.sum(1))


def _finite_strips(path: np.ndarray) -> list[np.ndarray]:
    """Split a ``(T, 3)`` path at NaN gaps; runs of one point cannot make a line."""
    return [path[a:b] for a, b in true_runs(np.isfinite(path).all(-1)) if b - a >= 2]


def _series_path(name: str) -> tuple[str, str]:
    """``"group/leaf"`` -> (``"series/group/leaf"``, group), where the group is everything
    before the last ``/`` (``"angles_deg/hip/left_hip_flexion"`` -> group
    ``"angles_deg/hip"``); a bare name is its own group."""
    parts = [p for p in str(name).strip("/").split("/") if p]
    if not parts:
        raise InputError(f"write_recording: empty series name {name!r}")
    group = "/".join(parts[:-1]) if len(parts) > 1 else parts[0]
    return "series/" + "/".join(parts), group


def _median_torso(X: np.ndarray) -> float:
    """Median pelvis-thorax distance of poses ``(T, 17, 3)`` over the frames with a positive
    one, in their units; NaN when none."""
    torso = np.linalg.norm(X[:, THORAX] - X[:, PELVIS], axis=-1)
    torso = torso[np.isfinite(torso) & (torso > 0)]
    return float(np.median(torso)) if torso.size else float("nan")


def _floor_grid(world: np.ndarray, torso: float, frames: np.ndarray | None = None) -> list[np.ndarray]:
    """Line strips of a square grid on the floor plane y = 0 of the world frame, covering
    the horizontal extent of every finite joint of ``frames`` (``(T,)`` bool; ``None``: all)
    plus a margin of about one and a half torso lengths; spacing a round number (1, 2 or 5 x
    10^k) near the torso length (0.5 for a metric adult), at most 100 lines per direction.
    Empty when no joint is finite."""
    extents = []  # per block of frames: the finite joints' (min, max) of x and z
    for rows in frame_blocks(len(world)):
        block = world[rows] if frames is None else world[rows][frames[rows]]
        xz = block[..., [0, 2]].reshape(-1, 2)
        xz = xz[np.isfinite(xz).all(-1)]
        if xz.size:
            extents.append((xz.min(0), xz.max(0)))
    if not extents or not (np.isfinite(torso) and torso > 0):
        return []
    lo = np.min([e[0] for e in extents], axis=0) - 1.5 * torso
    hi = np.max([e[1] for e in extents], axis=0) + 1.5 * torso
    exp = np.floor(np.log10(torso))
    step = min((m * 10.0**exp for m in (1.0, 2.0, 5.0, 10.0)), key=lambda v: abs(np.log(v / torso)))
    while ((hi - lo) / step).max() > 100:
        step *= 2.0
    lo, hi = np.floor(lo / step) * step, np.ceil(hi / step) * step
    xs = np.arange(lo[0], hi[0] + step / 2, step)
    zs = np.arange(lo[1], hi[1] + step / 2, step)
    strips = [np.array([[x, 0.0, lo[1]], [x, 0.0, hi[1]]]) for x in xs]
    strips += [np.array([[lo[0], 0.0, z], [hi[0], 0.0, z]]) for z in zs]
    return strips


def _series_views(series_groups: Sequence[str]):
    """One TimeSeriesView per group; a group's view shows its own series only, not those
    of a nested group (``angles_deg`` next to ``angles_deg/hip``)."""
    import rerun.blueprint as rrb

    views = {}
    for g in series_groups:
        nested = [h for h in series_groups if h != g and h.startswith(g + "/")]
        contents = ["+ $origin/**"] + [f"- /series/{h}/**" for h in nested]
        title = g.replace("/", ": ").replace("_", " ")
        views[g] = rrb.TimeSeriesView(origin=f"series/{g}", contents=contents, name=title)
    return views


def build_blueprint(*, has_image: bool, series_groups: list[str], fps: float, has_world: bool = False,
                    warnings: int = 0):
    """The default layout: top row video + 2D overlay | camera 3D | canonical 3D (| world
    3D); bottom row the run's warnings (the ``flags`` document, the first tab, named with
    their count, open when there are any) and the time series, one ``TimeSeriesView`` per series group.

    Groups are gathered by their first path component (``angles_deg/hip``,
    ``angles_deg/knee``, ... -> ``angles_deg``): a component with several groups becomes one
    grid (a tab named after it); groups alone in their component (``position_m``,
    ``speed_m_per_s``, ``status``, ...) share one grid, the first tab. One tab is shown
    without a tab bar. The time panel is on the ``frame`` timeline at ``fps``.
    """
    import rerun.blueprint as rrb

    top = []
    if has_image:
        top.append(rrb.Spatial2DView(origin="video", name="video + 2D keypoints"))
    top += [
        rrb.Spatial3DView(origin="camera", name="camera frame (x right, y down, z forward)"),
        rrb.Spatial3DView(origin="canonical", name="canonical frame (X anterior, Y up, Z right)"),
    ]
    if has_world:
        top.append(rrb.Spatial3DView(origin="world", name="world frame (fixed per recording, floor at y = 0)"))
    views = _series_views(list(dict.fromkeys(series_groups)))
    by_head: dict[str, list[str]] = {}
    for g in views:
        by_head.setdefault(g.split("/", 1)[0], []).append(g)
    singles = [views[gs[0]] for gs in by_head.values() if len(gs) == 1]
    tabs = [rrb.TextDocumentView(origin="flags", name=f"warnings ({warnings})" if warnings else "no warnings")]
    if singles:
        tabs.append(singles[0] if len(singles) == 1 else rrb.Grid(*singles, name="time series"))
    for head, gs in by_head.items():
        if len(gs) > 1:
            tabs.append(rrb.Grid(*(views[g] for g in gs), name=head.replace("_", " ")))
    # the warnings open first when there are any (a run never keeps them to itself)
    bottom = tabs[0] if len(tabs) == 1 else rrb.Tabs(*tabs, active_tab=0 if warnings else 1)
    layout = rrb.Vertical(rrb.Horizontal(*top), bottom, row_shares=[3, 2])
    return rrb.Blueprint(layout, rrb.TimePanel(timeline="frame", fps=float(fps)))


def write_recording(
    path_rrd: str | os.PathLike,
    *,
    fps: float,
    joints_cam: np.ndarray,
    canonical: np.ndarray,
    rotations: np.ndarray,
    up: np.ndarray,
    valid: np.ndarray,
    keypoints2d: np.ndarray | None = None,
    video_path: str | os.PathLike | None = None,
    video_first_frame: int = 0,
    wrist_paths: Mapping[str, np.ndarray] | None = None,
    series: Mapping[str, np.ndarray] | None = None,
    application_id: str = "pcnet",
    min_confidence: float = 0.0,
    flags: Sequence[str] = (),
    world: np.ndarray | None = None,
    show_labels: bool = False,
    floor: bool = True,
    notes: list[str] | None = None,
    implausible_frames: np.ndarray | None = None,
    track_segment: np.ndarray | None = None,
    keypoints2d_outside: np.ndarray | None = None,
    floor_frames: np.ndarray | None = None,
) -> Path:
    """Write a ``.rrd`` recording of one sequence with a default blueprint, atomically.

    Frame ``t`` of the poses is video frame ``t`` (pose files carry one pose per decoded
    frame, in order). Timelines: ``frame`` = ``t``; ``video_time`` = the video's own
    presentation timestamp of frame ``t`` when a video is given (so poses and pictures
    line up exactly), else ``t / fps``. See the module docstring for the entity tree.

    Args:
        path_rrd: destination ``.rrd``; a temporary beside it is renamed on success.
        fps: pose frame rate in Hz.
        joints_cam: ``(T, 17, 3)`` camera frame (x right, y down, z forward).
        canonical: ``(T, 17, 3)`` canonical frame (X anterior, Y up, Z right).
        rotations: ``(T, 3, 3)`` canonical->camera (``x_cam = R @ x_canon``); its
            columns are drawn as the body axes at the camera-frame pelvis.
        up: ``(T, 3)`` estimated up direction in the camera frame.
        valid: ``(T,)`` bool, frames with a usable rotation; others get no arrows.
        keypoints2d: optional ``(T, 17, 3)`` x_px, y_px, confidence in H36M-17 order;
            joints with confidence <= ``min_confidence`` or NaN are not drawn.
        video_path: optional MP4 (rerun's AssetVideo reads MP4 only); embedded in the
            recording. A video whose codec rerun cannot play (e.g. MPEG-4 Part 2, ``mp4v``;
            rerun 0.x plays H.264, H.265, AV1 and VP9) is left out, the rest recorded, and a
            line saying so appended to ``notes``.
        video_first_frame: index of pose frame 0's picture among the frames the container
            stores (:func:`pcnet.adapters.video.first_shown_frame`: 0 unless an MP4 edit list
            starts playback later).
        wrist_paths: optional ``name -> (T, 3)`` paths to draw (e.g. filtered wrists), in
            the world frame when ``world`` is given, else in the canonical frame; default:
            the wrists of ``world`` or ``canonical``. The camera view always gets the
            pelvis-relative wrists of ``joints_cam``.
        series: optional ``name -> (T,)`` values; ``"group/leaf"`` names are grouped into
            one plot per group (e.g. ``"wrist_speed/right_m_per_s"``). A frame where a
            value is not finite is not logged for that series.
        application_id: rerun application id.
        min_confidence: 2D keypoints at or below it are hidden.
        flags: the run's warnings (:mod:`pcnet.stages.flags`), logged as a static text
            document ``flags`` so the viewer shows them beside the data.
        world: optional ``(T, 17, 3)`` poses in the recording's world frame
            (:mod:`pcnet.stages.world_frame`), drawn as a third 3D view ``world``.
        show_labels: show the joint names beside the 2D and 3D joints (off by default: they
            cover the person; the viewer still names a hovered joint and can switch them on).
        floor: draw the floor grid ``/world/floor`` at y = 0 (only with ``world``).
        notes: where a line about a video left out is appended (the run summary's notes).
        implausible_frames: optional ``(T,)`` bool, frames whose joint speeds or accelerations
            exceed the training motion's fastest (:func:`pcnet.stages.plausibility.implausible_frames`),
            logged as the series ``status/implausible_motion`` (1 there, 0 in the other valid
            frames, nothing where not valid: not checked there, as ``kinematics.csv``) beside
            ``status/valid``; ``None`` (not checked) logs nothing.
        track_segment: optional ``(T,)`` float, the 2D track's person segment per frame
            (``kinematics.csv``'s ``track_segment``: 0 the first person, 1, 2, ... after each
            switch; NaN where no person), logged as the series ``status/track_segment`` so that
            a track switch shows on the timeline (a user trial saw the other person's frames
            drawn like the first's, with nothing marking them).
        keypoints2d_outside: optional ``(T, 17)`` bool, 2D keypoints outside the picture,
            whose joints the run took as missing (:func:`pcnet.stages.remap.outside_image`):
            not drawn, so that the 2D view shows the keypoints the 3D views use (a user trial
            saw them drawn beside the picture while their joints were missing in 3D).
        floor_frames: optional ``(T,)`` bool, the frames whose joints the floor grid spans
            (the tracked person's: a trial's grid also spanned the frames where the 2D track
            had switched to another person); default every frame.

    Returns:
        the destination path.

    Raises:
        ValueError: a shape mismatch, ``fps <= 0``, or a bad series name.
        FileNotFoundError: ``video_path`` does not exist.
        RuntimeError: rerun produced no file (e.g. logging disabled with ``RERUN=off``).
    """
    import rerun as rr

    if not fps > 0:
        raise InputError(f"write_recording: fps must be > 0, got {fps!r}")
    T = len(joints_cam)
    cam = _check("joints_cam", joints_cam, (T, 17, 3))
    can = _check("canonical", canonical, (T, 17, 3))
    R = _check("rotations", rotations, (T, 3, 3))
    up = _check("up", up, (T, 3))
    valid = np.asarray(valid, dtype=bool)
    if valid.shape != (T,):
        raise InputError(f"write_recording: valid must have shape ({T},), got {valid.shape}")
    kp = None if keypoints2d is None else _check("keypoints2d", keypoints2d, (T, 17, 3))
    implausible = None
    if implausible_frames is not None:
        implausible = np.asarray(implausible_frames, dtype=bool)
        if implausible.shape != (T,):
            raise InputError(f"write_recording: implausible_frames must have shape ({T},), got {implausible.shape}")
    segment = None if track_segment is None else _check("track_segment", track_segment, (T,))
    floor_frames = None if floor_frames is None else _check("floor_frames", floor_frames, (T,)).astype(bool)
    outside = None
    if keypoints2d_outside is not None:
        outside = np.asarray(keypoints2d_outside, dtype=bool)
        if outside.shape != (T, 17):
            raise InputError(f"write_recording: keypoints2d_outside must have shape ({T}, 17), got {outside.shape}")
    series_arrays = {}
    for name, values in dict(series or {}).items():
        key = _series_path(name)
        if key in series_arrays or key[0].startswith("series/status/"):
            raise InputError(f"write_recording: series {name!r} collides with another series")
        series_arrays[key] = _check(f"series[{name!r}]", values, (T,))
    wld = None if world is None else _check("world", world, (T, 17, 3))
    path_space, path_poses = ("canonical", can) if wld is None else ("world", wld)
    # Read when drawn, one path at a time (a long recording's are on disk).
    canon_paths = (
        {"left_wrist": column(path_poses, L_WRIST), "right_wrist": column(path_poses, R_WRIST)}
        if wrist_paths is None
        else {str(k): _check(f"wrist_paths[{k!r}]", p, (T, 3)) for k, p in wrist_paths.items()}
    )
    if video_path is not None and not Path(video_path).is_file():
        raise FileNotFoundError(f"write_recording: video not found: {video_path}")

    frames = np.arange(T, dtype=np.int64)
    seconds = frames / float(fps)
    asset, video_ns = None, None
    if video_path is not None:
        try:
            asset = rr.AssetVideo(path=video_path)
            # One video frame per pose frame, from the first frame a player shows: rerun lists
            # the stored frames, before an MP4 edit list (boxing2.mp4: 360 stored, 301 played
            # from stored frame 59), and the poses may not cover them all.
            video_ns = asset.read_frame_timestamps_nanos()[video_first_frame : video_first_frame + T]
        except RuntimeError as err:  # rerun's own video reader: an unsupported codec or container
            asset, video_ns = None, None
            if notes is not None:
                notes.append(f"recording.rrd: {video_path} left out, rerun cannot play it ({err}); poses, keypoints "
                             f"and series are recorded without the picture")
    if video_ns is not None:
        n = min(T, len(video_ns))
        seconds[:n] = video_ns[:n] * 1e-9
        # Poses beyond the video's last frame continue at 1/fps so time stays monotonic.
        if n and T > n:
            seconds[n:] = seconds[n - 1] + (frames[n:] - (n - 1)) / float(fps)

    groups = list(dict.fromkeys([g for _, g in series_arrays] + ["status"]))
    has_image = asset is not None or kp is not None
    blueprint = build_blueprint(has_image=has_image, series_groups=groups, fps=fps, has_world=wld is not None,
                                warnings=len(flags))

    # Arrow length: 60 % of the median pelvis-thorax distance, in the data's own units.
    torso = _median_torso(cam)
    arrow_len = 0.6 * torso if np.isfinite(torso) else 1.0

    def index(t: np.ndarray = frames, s: np.ndarray = seconds) -> list:
        return [rr.TimeColumn("frame", sequence=t), rr.TimeColumn("video_time", duration=s)]

    rec = rr.RecordingStream(application_id, default_enabled=True)
    with atomic_path(path_rrd, suffix=".rrd") as tmp:
        flush = _flusher(rec, tmp)
        try:
            try:
                _bounded(lambda: rec.save(tmp, default_blueprint=blueprint), tmp)
            except RuntimeError as err:  # rerun's encoder on a disk already full, as an OSError
                raise _writer_stopped(tmp, err) from err
            _log_all(
                rr, rec, flush, index, frames, seconds, cam, can, R, up, valid, kp, asset,
                video_ns, canon_paths, series_arrays, arrow_len, min_confidence, wld, path_space,
                show_labels=bool(show_labels), floor=bool(floor), implausible=implausible, segment=segment,
                outside=outside, floor_frames=floor_frames,
            )
            text = "\n".join(f"- {f}" for f in flags) if flags else "no warnings"
            rec.log("flags", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True, strict=True)
            flush()  # all of it written before the rename (a stopped writer raises here, not in disconnect)
        except OSError:
            raise  # a stopped writer: disconnect() would wait on it forever
        except BaseException:
            rec.disconnect()
            raise
        rec.disconnect()  # closes the file sink
        if not tmp.is_file():
            raise RuntimeError(
                "rerun wrote no recording (is logging disabled, e.g. RERUN=off?)"
            )
    return Path(path_rrd)


def _log_all(
    rr, rec, flush, index, frames, seconds, cam, can, R, up, valid, kp, asset, video_ns,
    canon_paths, series_arrays, arrow_len, min_confidence, wld, path_space, *,
    show_labels: bool = False, floor: bool = True, implausible: np.ndarray | None = None,
    segment: np.ndarray | None = None, outside: np.ndarray | None = None, floor_frames: np.ndarray | None = None,
) -> None:
    # strict=True everywhere: rerun's default turns API misuse into a warning and drops
    # the data, which would yield a silently incomplete recording.
    def send(path: str, columns, idx=None) -> None:
        rec.send_columns(path, indexes=idx or index(), columns=columns, strict=True)
        # Wait for the file sink: without it rerun's batcher queues a long recording's blocks
        # faster than they are written (measured: +490 MB vs +250 MB for 2 hours at 30 fps).
        flush()

    def log(path: str, *items, static: bool = True) -> None:
        rec.log(path, *items, static=static, strict=True)

    log(
        "/",
        rr.AnnotationContext(
            [
                rr.ClassDescription(
                    info=rr.AnnotationInfo(id=0, label="H36M-17"),
                    keypoint_annotations=[
                        rr.AnnotationInfo(id=i, label=n, color=tuple(int(c) for c in _JOINT_COLOURS[i]))
                        for i, n in enumerate(H36M_JOINTS)
                    ],
                )
            ]
        ),
    )

    # --- image space
    if asset is not None:
        log("video", asset)
        send(
            "video",
            rr.VideoFrameReference.columns_nanos(video_ns),
            idx=[
                rr.TimeColumn("frame", sequence=np.arange(len(video_ns), dtype=np.int64)),
                rr.TimeColumn("video_time", duration=video_ns * 1e-9),
            ],
        )
    # Per-frame data goes out a block of frames at a time: the Arrow columns of a whole
    # 2-hour recording would hold GBs at once; the file sink writes each block as it comes.
    blocks = list(frame_blocks(len(frames), SEND_BLOCK_FRAMES))

    def block_index(b: slice) -> list:
        return index(frames[b], seconds[b])

    if kp is not None:
        log("video/keypoints", rr.Points2D.from_fields(
            class_ids=0, radii=rr.Radius.ui_points(4.0), show_labels=show_labels))
        log("video/skeleton", rr.LineStrips2D.from_fields(radii=rr.Radius.ui_points(2.0)))
        for b in blocks:
            kp_b = kp[b]
            conf_ok = np.isfinite(kp_b[..., 2]) & (kp_b[..., 2] > min_confidence)
            if outside is not None:
                conf_ok &= ~outside[b]
            send("video/keypoints", _points_columns(rr, kp_b[:, :, :2], conf_ok, dims=2), block_index(b))
            send("video/skeleton", _bones_columns(rr, kp_b[:, :, :2], conf_ok, dims=2), block_index(b))

    # --- 3D views
    log("camera", rr.ViewCoordinates.RDF)
    # FUR = X forward, Y up, Z right: exactly the canonical axes (right-handed, Y up).
    log("canonical", rr.ViewCoordinates.FUR)
    spaces = [("camera", cam), ("canonical", can)]
    if wld is not None:
        log("world", rr.ViewCoordinates.FUR)  # the world frame has the canonical frame's axis roles
        spaces.append(("world", wld))
        grid = _floor_grid(wld, _median_torso(wld), floor_frames) if floor else []
        if grid:
            log("world/floor", rr.LineStrips3D(grid, colors=[_FLOOR_C], radii=rr.Radius.ui_points(0.75)))
    for space, X in spaces:
        log(f"{space}/skeleton/joints", rr.Points3D.from_fields(
            class_ids=0, radii=rr.Radius.ui_points(5.0), show_labels=show_labels))
        log(f"{space}/skeleton/bones", rr.LineStrips3D.from_fields(radii=rr.Radius.ui_points(2.5)))
        for b in blocks:
            X_b = X[b]
            send(f"{space}/skeleton/joints", _points_columns(rr, X_b), block_index(b))
            send(f"{space}/skeleton/bones", _bones_columns(rr, X_b), block_index(b))

    pelvis = np.asarray(cam[:, PELVIS])
    axes_ok = valid & per_frame(lambda R_b: np.isfinite(R_b).all((1, 2)), R) & np.isfinite(pelvis).all(-1)
    up_norm = per_frame(lambda u: np.linalg.norm(u, axis=-1), up)
    up_ok = valid & np.isfinite(up_norm) & (up_norm > 0) & np.isfinite(pelvis).all(-1)
    log("camera/body_axes", rr.Arrows3D.from_fields(colors=_AXIS_COLOURS, labels=_AXIS_LABELS))
    log("camera/up", rr.Arrows3D.from_fields(colors=[_UP_COLOUR], labels=["up"]))
    for b in blocks:
        ok, R_b, pelvis_b = axes_ok[b], R[b], pelvis[b]
        vectors = (np.swapaxes(R_b[ok], 1, 2) * arrow_len).reshape(-1, 3)  # rows = columns of R
        send("camera/body_axes", rr.Arrows3D.columns(
            vectors=vectors, origins=np.repeat(pelvis_b[ok], 3, axis=0)).partition(3 * ok.astype(np.int64)),
            block_index(b))
        ok, n_b = up_ok[b], up_norm[b]
        send("camera/up", rr.Arrows3D.columns(
            vectors=up[b][ok] * (1.3 * arrow_len / n_b[ok, None]), origins=pelvis_b[ok],
        ).partition(ok.astype(np.int64)), block_index(b))

    # --- wrist paths (static: the whole trajectory is the point of the picture)
    # (space, name, path, origin subtracted): each read only while it is logged.
    paths = [("camera", "left_wrist", column(cam, L_WRIST), pelvis),
             ("camera", "right_wrist", column(cam, R_WRIST), pelvis)]
    paths += [(path_space, name, p, None) for name, p in canon_paths.items()]
    for space, name, p, origin in paths:
        p = np.asarray(p)
        strips = _finite_strips(p if origin is None else p - origin)
        if strips:
            log(
                f"{space}/wrist_paths/{name}",
                rr.LineStrips3D(strips, colors=[_side_colour(name)], radii=rr.Radius.ui_points(1.0)),
            )

    # --- time series
    status = {("series/status/valid", "status"): valid.astype(np.float64)}
    if implausible is not None:
        status[("series/status/implausible_motion", "status")] = np.where(valid, implausible, np.nan)
    if segment is not None:
        status[("series/status/track_segment", "status")] = segment
    everything = {**series_arrays, **status}
    colours: dict[str, tuple[int, int, int]] = {}
    for group in dict.fromkeys(g for _, g in everything):
        colours.update(series_colours([p for p, g in everything if g == group]))
    for (path, _group), values in everything.items():
        log(path, rr.SeriesLines(names=path.rsplit("/", 1)[-1], colors=[colours[path]]))
        for b in blocks:
            values_b = np.asarray(values[b])
            ok = np.isfinite(values_b)
            send(path, rr.Scalars.columns(scalars=values_b[ok]), idx=index(frames[b][ok], seconds[b][ok]))


def series_from_kinematics(
    kinematics, joints: tuple[str, ...] = ("left_wrist", "right_wrist")
) -> dict[str, np.ndarray]:
    """Time series for :func:`write_recording` from a
    :class:`~pcnet.stages.kinematics.Kinematics`: per joint the position, velocity and
    acceleration components and the speed, plus every angle.

    Names are ``"{group}/{joint}_{component}"`` with groups ``position_{u}``,
    ``velocity_{u}_per_s``, ``acceleration_{u}_per_s2``, ``speed_{u}_per_s``
    (``u`` = the kinematics' length unit), and ``"angles_deg/{angle group}/{angle}"`` with
    the groups of :func:`pcnet.stages.sinks.plots.angle_group` (``trunk``, ``hip``, ``knee``,
    ``shoulder``, ``elbow``, the segment inclinations, ...), so the recording gets one plot
    per quantity or angle group (at most six series) with its unit in the title.

    Raises:
        ValueError: an unknown joint name.
    """
    from .exports import unit_token

    k = kinematics
    names = list(k.joint_names)
    u, v, a = unit_token(k.units), unit_token(k.velocity_units), unit_token(k.acceleration_units)
    out: dict[str, np.ndarray] = {}
    for j in joints:
        if j not in names:
            raise InputError(f"series_from_kinematics: unknown joint {j!r}")
        i = names.index(j)
        # Columns (lazy for a long recording's kinematics on disk, read a block at a time).
        for c, axis in enumerate("xyz"):
            out[f"position_{u}/{j}_{axis}"] = column(k.positions, i, c)
            out[f"velocity_{v}/{j}_v{axis}"] = column(k.velocity, i, c)
            out[f"acceleration_{a}/{j}_a{axis}"] = column(k.acceleration, i, c)
        out[f"speed_{v}/{j}"] = column(k.speed, i)
    for name, ang in k.angles.items():
        out[f"angles_deg/{angle_group(name)}/{name}"] = column(ang)
    return out
