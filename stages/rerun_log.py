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
    /video/keypoints                Points2D, 2D keypoints (px), keypoint_ids = H36M index
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
    /series/{group}/{name}          Scalars (+ SeriesLines, static), one row per frame
                                    where the value is finite
    /series/status/valid            Scalars: 1 where the rotation is valid, else 0

Missing data is left out, never drawn as zeros: NaN joints, bones with a NaN end,
invalid frames' arrows and non-finite series samples are simply not logged for that
frame (an empty batch on a frame clears the previous one).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from .conventions import H36M_BONES, H36M_JOINTS, L_WRIST, PELVIS, R_WRIST, THORAX
from .atomic import atomic_path
from .errors import InputError

_BONE_A = np.array([a for a, _ in H36M_BONES])
_BONE_B = np.array([b for _, b in H36M_BONES])

# Left blue, right red, midline grey (the usual pose-viewer colouring).
_LEFT_C, _RIGHT_C, _MID_C = (40, 110, 235), (230, 60, 50), (170, 170, 170)


def _side_colour(name: str) -> tuple[int, int, int]:
    return _LEFT_C if name.startswith("left") else _RIGHT_C if name.startswith("right") else _MID_C


_JOINT_COLOURS = np.array([_side_colour(n) for n in H36M_JOINTS], dtype=np.uint8)
_BONE_COLOURS = _JOINT_COLOURS[_BONE_B]
_AXIS_COLOURS = np.array([(230, 40, 40), (40, 200, 40), (40, 90, 240)], dtype=np.uint8)
_AXIS_LABELS = ["X anterior", "Y up", "Z right"]
_UP_COLOUR = (250, 200, 0)


def _check(name: str, arr: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray:
    a = np.asarray(arr, dtype=np.float64)
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
    ok = np.isfinite(path).all(-1)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(np.int8), [0]])))
    return [path[a:b] for a, b in zip(edges[::2], edges[1::2]) if b - a >= 2]


def _series_path(name: str) -> tuple[str, str]:
    """``"group/leaf"`` -> (``"series/group/leaf"``, group); a bare name is its own group."""
    parts = [p for p in str(name).strip("/").split("/") if p]
    if not parts:
        raise InputError(f"write_recording: empty series name {name!r}")
    return "series/" + "/".join(parts), parts[0]


def build_blueprint(*, has_image: bool, series_groups: list[str], fps: float, has_world: bool = False):
    """The default layout: top row video + 2D overlay | camera 3D | canonical 3D (| world
    3D); bottom row one time-series view per series group (side by side up to four, tabs
    beyond); the time panel on the ``frame`` timeline at ``fps``."""
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
    plots = [rrb.TimeSeriesView(origin=f"series/{g}", name=g.replace("_", " ")) for g in series_groups]
    rows = [rrb.Horizontal(*top)]
    if plots:
        rows.append(rrb.Horizontal(*plots) if len(plots) <= 4 else rrb.Tabs(*plots))
    layout = rrb.Vertical(*rows, row_shares=[3, 2][: len(rows)])
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
    wrist_paths: Mapping[str, np.ndarray] | None = None,
    series: Mapping[str, np.ndarray] | None = None,
    application_id: str = "pcnet",
    min_confidence: float = 0.0,
    flags: Sequence[str] = (),
    world: np.ndarray | None = None,
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
            recording.
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
    cam = np.asarray(joints_cam, dtype=np.float64)
    T = cam.shape[0]
    cam = _check("joints_cam", cam, (T, 17, 3))
    can = _check("canonical", canonical, (T, 17, 3))
    R = _check("rotations", rotations, (T, 3, 3))
    up = _check("up", up, (T, 3))
    valid = np.asarray(valid, dtype=bool)
    if valid.shape != (T,):
        raise InputError(f"write_recording: valid must have shape ({T},), got {valid.shape}")
    kp = None if keypoints2d is None else _check("keypoints2d", keypoints2d, (T, 17, 3))
    series_arrays = {}
    for name, values in dict(series or {}).items():
        key = _series_path(name)
        if key in series_arrays or key[0] == "series/status/valid":
            raise InputError(f"write_recording: series {name!r} collides with another series")
        series_arrays[key] = _check(f"series[{name!r}]", values, (T,))
    wld = None if world is None else _check("world", world, (T, 17, 3))
    path_space, path_poses = ("canonical", can) if wld is None else ("world", wld)
    canon_paths = (
        {"left_wrist": path_poses[:, L_WRIST], "right_wrist": path_poses[:, R_WRIST]}
        if wrist_paths is None
        else {str(k): _check(f"wrist_paths[{k!r}]", p, (T, 3)) for k, p in wrist_paths.items()}
    )
    if video_path is not None and not Path(video_path).is_file():
        raise FileNotFoundError(f"write_recording: video not found: {video_path}")

    frames = np.arange(T, dtype=np.int64)
    seconds = frames / float(fps)
    asset, video_ns = None, None
    if video_path is not None:
        asset = rr.AssetVideo(path=video_path)
        video_ns = asset.read_frame_timestamps_nanos()
        n = min(T, len(video_ns))
        seconds[:n] = video_ns[:n] * 1e-9
        # Poses beyond the video's last frame continue at 1/fps so time stays monotonic.
        if n and T > n:
            seconds[n:] = seconds[n - 1] + (frames[n:] - (n - 1)) / float(fps)

    groups = list(dict.fromkeys([g for _, g in series_arrays] + ["status"]))
    has_image = asset is not None or kp is not None
    blueprint = build_blueprint(has_image=has_image, series_groups=groups, fps=fps, has_world=wld is not None)

    # Arrow length: 60 % of the median pelvis-thorax distance, in the data's own units.
    torso = np.linalg.norm(cam[:, THORAX] - cam[:, PELVIS], axis=-1)
    torso = torso[np.isfinite(torso) & (torso > 0)]
    arrow_len = 0.6 * float(np.median(torso)) if torso.size else 1.0

    def index(t: np.ndarray = frames, s: np.ndarray = seconds) -> list:
        return [rr.TimeColumn("frame", sequence=t), rr.TimeColumn("video_time", duration=s)]

    rec = rr.RecordingStream(application_id, default_enabled=True)
    with atomic_path(path_rrd, suffix=".rrd") as tmp:
        try:
            rec.save(tmp, default_blueprint=blueprint)
            _log_all(
                rr, rec, index, frames, seconds, cam, can, R, up, valid, kp, asset,
                video_ns, canon_paths, series_arrays, arrow_len, min_confidence, wld, path_space,
            )
            text = "\n".join(f"- {f}" for f in flags) if flags else "no warnings"
            rec.log("flags", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True, strict=True)
        finally:
            # disconnect() flushes and closes the file sink before the rename.
            rec.flush()
            rec.disconnect()
        if not tmp.is_file():
            raise RuntimeError(
                "rerun wrote no recording (is logging disabled, e.g. RERUN=off?)"
            )
    return Path(path_rrd)


def _log_all(
    rr, rec, index, frames, seconds, cam, can, R, up, valid, kp, asset, video_ns,
    canon_paths, series_arrays, arrow_len, min_confidence, wld, path_space,
) -> None:
    # strict=True everywhere: rerun's default turns API misuse into a warning and drops
    # the data, which would yield a silently incomplete recording.
    def send(path: str, columns, idx=None) -> None:
        rec.send_columns(path, indexes=idx or index(), columns=columns, strict=True)

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
    if kp is not None:
        xy = kp[..., :2]
        conf_ok = np.isfinite(kp[..., 2]) & (kp[..., 2] > min_confidence)
        log("video/keypoints", rr.Points2D.from_fields(class_ids=0, radii=rr.Radius.ui_points(4.0)))
        send("video/keypoints", _points_columns(rr, xy, conf_ok, dims=2))
        log("video/skeleton", rr.LineStrips2D.from_fields(radii=rr.Radius.ui_points(2.0)))
        send("video/skeleton", _bones_columns(rr, xy, conf_ok, dims=2))

    # --- 3D views
    log("camera", rr.ViewCoordinates.RDF)
    # FUR = X forward, Y up, Z right: exactly the canonical axes (right-handed, Y up).
    log("canonical", rr.ViewCoordinates.FUR)
    spaces = [("camera", cam), ("canonical", can)]
    if wld is not None:
        log("world", rr.ViewCoordinates.FUR)  # the world frame has the canonical frame's axis roles
        spaces.append(("world", wld))
    for space, X in spaces:
        log(f"{space}/skeleton/joints", rr.Points3D.from_fields(class_ids=0, radii=rr.Radius.ui_points(5.0)))
        send(f"{space}/skeleton/joints", _points_columns(rr, X))
        log(f"{space}/skeleton/bones", rr.LineStrips3D.from_fields(radii=rr.Radius.ui_points(2.5)))
        send(f"{space}/skeleton/bones", _bones_columns(rr, X))

    axes_ok = valid & np.isfinite(R).all((1, 2)) & np.isfinite(cam[:, PELVIS]).all(-1)
    origins = np.repeat(cam[axes_ok, PELVIS], 3, axis=0)
    vectors = (np.swapaxes(R[axes_ok], 1, 2) * arrow_len).reshape(-1, 3)  # rows = columns of R
    log("camera/body_axes", rr.Arrows3D.from_fields(colors=_AXIS_COLOURS, labels=_AXIS_LABELS))
    send(
        "camera/body_axes",
        rr.Arrows3D.columns(vectors=vectors, origins=origins).partition(3 * axes_ok.astype(np.int64)),
    )
    up_norm = np.linalg.norm(up, axis=-1)
    up_ok = valid & np.isfinite(up_norm) & (up_norm > 0) & np.isfinite(cam[:, PELVIS]).all(-1)
    log("camera/up", rr.Arrows3D.from_fields(colors=[_UP_COLOUR], labels=["up"]))
    send(
        "camera/up",
        rr.Arrows3D.columns(
            vectors=up[up_ok] * (1.3 * arrow_len / up_norm[up_ok, None]),
            origins=cam[up_ok, PELVIS],
        ).partition(up_ok.astype(np.int64)),
    )

    # --- wrist paths (static: the whole trajectory is the point of the picture)
    cam_rel = cam - cam[:, PELVIS : PELVIS + 1]
    paths = {
        ("camera", "left_wrist"): cam_rel[:, L_WRIST],
        ("camera", "right_wrist"): cam_rel[:, R_WRIST],
    }
    for name, p in canon_paths.items():
        paths[(path_space, name)] = p
    for (space, name), p in paths.items():
        strips = _finite_strips(p)
        if strips:
            log(
                f"{space}/wrist_paths/{name}",
                rr.LineStrips3D(strips, colors=[_side_colour(name)], radii=rr.Radius.ui_points(1.0)),
            )

    # --- time series
    status = {("series/status/valid", "status"): valid.astype(np.float64)}
    for (path, _group), values in {**series_arrays, **status}.items():
        ok = np.isfinite(values)
        log(path, rr.SeriesLines(names=path.rsplit("/", 1)[-1]))
        send(path, rr.Scalars.columns(scalars=values[ok]), idx=index(frames[ok], seconds[ok]))


def series_from_kinematics(
    kinematics, joints: tuple[str, ...] = ("left_wrist", "right_wrist")
) -> dict[str, np.ndarray]:
    """Time series for :func:`write_recording` from a
    :class:`~pcnet.stages.kinematics.Kinematics`: per joint the position, velocity and
    acceleration components and the speed, plus every angle.

    Names are ``"{group}/{joint}_{component}"`` with groups ``position_{u}``,
    ``velocity_{u}_per_s``, ``acceleration_{u}_per_s2``, ``speed_{u}_per_s`` and
    ``angles_deg`` (``u`` = the kinematics' length unit), so the recording gets one plot
    per quantity with its unit in the title.

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
        for c, axis in enumerate("xyz"):
            out[f"position_{u}/{j}_{axis}"] = k.positions[:, i, c]
            out[f"velocity_{v}/{j}_v{axis}"] = k.velocity[:, i, c]
            out[f"acceleration_{a}/{j}_a{axis}"] = k.acceleration[:, i, c]
        out[f"speed_{v}/{j}"] = k.speed[:, i]
    for name, ang in k.angles.items():
        out[f"angles_deg/{name}"] = np.asarray(ang)
    return out
