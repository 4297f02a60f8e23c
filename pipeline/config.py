"""Configuration of one ``pcnet run``: a plain dataclass, loadable from TOML or a CSV row."""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import inspect
import math
import os
import re
from dataclasses import dataclass, field, fields
from importlib import metadata
from pathlib import Path

import numpy as np

from pcnet.models.toml_config import (check_config_types, check_unknown_keys, read_toml, type_hints, type_name,
                                      value_matches)
from pcnet.stages.core.conventions import MAX_FPS, MIN_FPS
from pcnet.stages.core.digest import sha256_file_version
from pcnet.stages.core.errors import InputError, close_names, refuse, shown_value

def _registered(kind: str) -> dict:
    from pcnet.adapters.registry import registered

    return registered(kind)


def lifter_names() -> tuple[str, ...]:
    """The 3D adapters registered in this process (:mod:`pcnet.adapters.registry`), in
    registration order: the built-in lifters (what ``pcnet run --lifter`` offers), then any
    registered later with ``@register_3d``, which the Python API's :class:`RunConfig` takes too."""
    return tuple(_registered("3d"))


def keypoint_formats() -> tuple[str, ...]:
    """The registered 2D adapters (``keypoints2d_format``'s choices), in registration order."""
    return tuple(_registered("2d"))


def multi_track_formats() -> dict[str, str]:
    """``{2D format: what a track id is in it}`` for the registered 2D formats whose files hold
    several people's tracks, one of which ``person`` chooses (``register_2d(multi_track=...)``)."""
    return {name: entry.multi_track for name, entry in _registered("2d").items() if entry.multi_track}


#: Relative difference between ``fps`` and the video's own rate accepted as the same rate.
FPS_TOLERANCE = 0.01


def rates_agree(fps: float, recorded: float) -> bool:
    """Whether a frame rate ``fps`` is the rate ``recorded`` within :data:`FPS_TOLERANCE` of it."""
    return abs(fps - recorded) <= FPS_TOLERANCE * recorded


def fps_contradiction(fps: float, source, recorded: float) -> str | None:
    """The refusal of a given frame rate ``fps`` that contradicts the rate ``recorded`` in
    ``source`` (a video's, or an input file's own) by more than :data:`FPS_TOLERANCE`, in
    `pcnet run`'s terms (a manifest's: ``pcnet.pipeline.batch.in_manifest_terms``); ``None``
    when they agree."""
    if rates_agree(fps, recorded):
        return None
    return (f"--fps {fps:g}: expected the rate {source} records ({recorded:g} fps), got {fps:g} fps; pass "
            f"--fps-override to use --fps anyway")


def records_frame_rate(kind: str, name: str) -> bool:
    """Whether files of the registered ``kind`` (``"2d"``/``"3d"``) adapter ``name`` can carry
    their frame rate (``register_2d/3d(records_fps=...)``); ``True`` for an unknown name (the
    choice checks refuse it).

    Raises:
        KeyError: ``kind`` not ``"2d"`` or ``"3d"``.
    """
    entry = _registered(kind).get(name)
    return entry is None or entry.records_fps


def reads_folder(keypoints2d_format: str | None) -> bool:
    """Whether the registered 2D format ``keypoints2d_format`` reads a folder of files, not one
    file (``register_2d(folder_input=True)``: OpenPose's ``--write_json`` folder); ``False`` for
    ``None`` or an unknown name (the choice checks refuse it)."""
    entry = _registered("2d").get(keypoints2d_format)
    return entry is not None and entry.folder_input


MODES = ("auto", "frame", "sequence", "smooth")


def unit_camera_up(values, name: str, form: str = "X,Y,Z", given=None) -> tuple[float, float, float]:
    """A given camera up (three numbers, camera frame, OpenCV axes, any length) as a unit
    ``(x, y, z)``.

    Raises:
        InputError: not three finite numbers, or all 0, naming ``name``, the ``form`` expected
            and what was ``given`` (default ``values``).
    """
    try:
        v = np.asarray(values, np.float64)
    except (TypeError, ValueError):
        v = np.array([])
    if v.shape == (3,) and np.isfinite(v).all() and np.abs(v).max() > 0:
        v = v / np.abs(v).max()  # no overflow in the norm (a trial's 1e200)
    if v.shape != (3,) or not np.isfinite(v).all() or not np.linalg.norm(v) > 0:
        level = "0,-1,0" if form == "X,Y,Z" else "(0, -1, 0)"
        raise InputError(f"{name}: expected {form}, the camera's up in its own frame (x right, y down, z forward; a "
                         f"level camera's is {level}), got {shown_value(values) if given is None else repr(given)}")
    return tuple(float(c) for c in v / np.linalg.norm(v))


def parse_camera_up(text: str, name: str) -> tuple[float, float, float]:
    """A given camera up written ``"X,Y,Z"`` (a command line's, a manifest's, a TOML file's) as
    :func:`unit_camera_up` reads it.

    Raises:
        InputError: not three finite numbers, or all 0, naming ``name``.
    """
    try:
        values = [float(c) for c in str(text).split(",")]
    except ValueError:
        values = []
    return unit_camera_up(values, name, given=text)


def trial_up_record(folder, name: str) -> dict:
    """An earlier ``pcnet run`` of the same static camera whose up its poses read, as the run
    that takes it records it: ``{"folder", "up", "camera_pitch_interval_deg",
    "camera_roll_interval_deg"}`` (its ``canonical.npz`` ``report``'s, camera frame; the
    intervals its 95 % ones, NaN where that run's up was itself given); the checks are
    :func:`pcnet.stages.rectification_report.why_up_not_reusable`'s.

    Raises:
        InputError: not such a folder, or a run whose up is not one to reuse, naming ``name``.
    """
    import json

    from pcnet.stages.rectification_report import why_up_not_reusable

    path = Path(folder) / "canonical.npz"
    if not path.is_file():
        given = Path(folder)
        what = (" (no canonical.npz in it)" if given.is_dir() else " (a file: give the run's folder)"
                if given.is_file() else " (no such folder)")
        raise InputError(f"{name}: expected a pcnet run output folder with canonical.npz (a run of the same static "
                         f"camera), got {folder}{what}")
    try:
        with np.load(path, allow_pickle=False) as z:
            report = json.loads(str(z["report"]))
    except (OSError, ValueError, KeyError) as err:
        raise InputError(f"{name}: {path}: expected a pcnet run's canonical.npz with its report, got one that does "
                         f"not read ({err})") from None
    why = why_up_not_reusable(report)
    if why is not None:
        raise InputError(f"{name}: {folder}: expected a run whose up its poses read (sequence mode, a body read "
                         f"upright, a static camera), got {why}")
    up = np.asarray(report.get("up", []), np.float64)
    if up.shape != (3,) or not np.isfinite(up).all():
        raise InputError(f"{name}: {path}: expected the report's up, three finite numbers, got {report.get('up')!r}")

    def interval(key: str) -> float:
        value = report.get(key)
        return float(value) if isinstance(value, (int, float)) else float("nan")

    return {"folder": str(Path(folder).resolve()), "up": list(unit_camera_up(up, name)),
            "camera_pitch_interval_deg": interval("camera_pitch_interval_deg"),
            "camera_roll_interval_deg": interval("camera_roll_interval_deg")}


def check_camera_up_use(mode: str, posture: str, name: str, posture_name: str) -> None:
    """A given camera up is for sequence mode (one up for a static camera) with the posture the
    up leaves to the poses (``auto``).

    Raises:
        InputError: another mode or posture, naming ``name`` or ``posture_name``.
    """
    if mode != "sequence":
        raise InputError(f"{name}: expected with mode sequence (one up for a static camera), got mode {mode}")
    if posture != "auto":
        raise InputError(f"{posture_name}: expected auto with a given camera up (the given up decides which way is "
                         f"up), got {posture}")
ALIGN = ("none", "truncate")
# Plausible heights: the shortest to the tallest adult recorded (Guinness: 0.55-2.72 m).
MIN_HEIGHT_M, MAX_HEIGHT_M = 0.5, 3.0
#: One international foot, metres (a height typed in feet gets its conversion as a hint).
FOOT_M = 0.3048

#: What ``confidence_threshold`` and ``cutoff_hz`` mean when not given (None): they are
#: optional so that validate() can refuse them given where they would be ignored.
DEFAULT_CONFIDENCE = 0.3
DEFAULT_CUTOFF_HZ = 6.0

#: The ``source`` of a config built from `pcnet run`'s options: errors then name the option.
COMMAND_LINE = "command line"


def field_name(source: str, *names: str) -> str:
    """How an error names config field(s): ``--cutoff-hz`` for the command line, else
    ``"<source>: field 'cutoff_hz'"`` (``fields 'a' and 'b'``)."""
    if source == COMMAND_LINE:
        return " and ".join(_flag(n) for n in names)
    if len(names) == 1:
        return f"{source}: field {names[0]!r}"
    return f"{source}: fields " + " and ".join(repr(n) for n in names)


#: Adapter options that `pcnet run` has a flag for and a manifest a column for (the others only in a
#: config's [lifter_options]).
COMMAND_LINE_OPTIONS = ("pixel", "hypothesis", "layout", "axes", "units", "key", "delimiter", "measured_root")


def check_lifter_options(source: str, lifter: str, options: dict) -> dict:
    """``options`` if the ``lifter``'s adapter takes them all with values of the types it
    declares, else one line (rather than a TypeError from deep inside the adapter): naming the
    flags for the command line (``--focal-px: expected only the options --lifter motionbert
    takes ...``), the field otherwise.

    Raises:
        InputError: an option the adapter does not take, a value of the wrong type, or one
            its ``option_problems`` (if it has them) refuses.
    """
    from pcnet.adapters import get_3d_adapter

    adapter = get_3d_adapter(lifter)
    load = adapter.load
    var_keyword, taken = _keyword_options(load)
    if var_keyword:
        return options
    unknown = sorted(set(options) - set(taken))
    if unknown:
        named = _option_field(source, *unknown)
        if source == COMMAND_LINE:
            raise InputError(f"{named}: expected only the options --lifter {lifter} takes "
                             f"({', '.join(_option_flag(n) for n in taken) or 'none'}), got {named}")
        raise InputError(f"{named}: expected only options --lifter {lifter} takes "
                         f"({', '.join(taken) or 'none'}), got {', '.join(unknown)}")
    hints = type_hints(getattr(load, "__func__", load))
    for option, value in options.items():
        if option in hints and not value_matches(value, hints[option]):
            raise InputError(f"{_option_field(source, option)}: expected {type_name(hints[option])} for --lifter "
                             f"{lifter}, got {value!r} ({type(value).__name__})")
    # Values the adapter would refuse only once it reads the file (an adapter may say which).
    for option, expected, got in getattr(adapter, "option_problems", lambda **_: [])(**options)[:1]:
        raise InputError(f"{_option_field(source, option)}: expected {expected} for --lifter {lifter}, got {got}")
    return options


def _option_field(source: str, *options: str) -> str:
    """How an error names adapter options: their flags on the command line (``--units``), else
    their key in the ``lifter_options`` table (``"run.toml: field 'lifter_options.units'"``,
    TOML's dotted key), not as fields of the config they are not."""
    if source == COMMAND_LINE:
        return ", ".join(_option_flag(o) for o in options)
    return field_name(source, *(f"lifter_options.{o}" for o in options))


def _keyword_options(load) -> tuple[bool, list[str]]:
    """Whether an adapter's ``load`` takes any keyword (``**kwargs``), and the options it
    names: its parameters after the path that a keyword can pass (keyword-only, or positional
    ones with a name), read once per function (a manifest checks one config per row)."""
    func = getattr(load, "__func__", load)  # each adapter instance has its own bound method
    bound = func is not load
    try:
        var_keyword, taken = _signature_options(func, bound)
    except TypeError:  # unhashable
        var_keyword, taken = _signature_options.__wrapped__(func, bound)
    return var_keyword, list(taken)


@functools.lru_cache(maxsize=64)
def _signature_options(func, bound: bool) -> tuple[bool, tuple[str, ...]]:
    params = list(inspect.signature(func).parameters.values())
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    before_options = {p.name for p in positional[:1 + bound]}  # ``self`` of a method, then the path
    return (any(p.kind is p.VAR_KEYWORD for p in params),
            tuple(p.name for p in params if p.name not in before_options
                  and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)))


#: The lifter format the embedded estimator of `pcnet run --video` writes
#: (:mod:`pcnet.pipeline.video_estimate`); its options (``focal_px``) apply to a video alone.
ESTIMATOR_LIFTER = "mediapipe"


def _flag(name: str) -> str:
    """The command-line spelling of a config field: ``cutoff_hz`` -> ``--cutoff-hz``."""
    return "--" + name.replace("_", "-")


def _option_flag(option: str) -> str:
    """How a user gives an adapter option on the command line: ``focal_px`` -> ``--focal-px``;
    one without a flag by its config key (``clip_len``)."""
    return _flag(option) if option in COMMAND_LINE_OPTIONS else option


@dataclass
class RunConfig:
    """Inputs and options of the staged pipeline (same names as ``pcnet run``'s options).

    Each field is the ``pcnet run`` option of the same name with ``_`` for ``-`` (``focal_px``
    is ``--focal-px``, ``overwrite`` is ``--overwrite``); the messages of :class:`InputError`
    name the option, so a Python caller sets the field of that name. ``out``: the output folder
    (``docs/outputs.md``), new unless ``overwrite`` (which replaces only a previous pcnet
    output). ``height``: the subject's standing height in metres, scaling the poses to it
    (:func:`pcnet.stages.scale.height_factor`). ``mode``: ``sequence`` (one up for a static
    camera, the default), ``frame``, ``smooth`` or ``auto``. ``recording``: also write the
    rerun recording (``recording.rrd``). ``plots``: also write the PNG plots (``wrists.png``,
    ``angles.png``, ``speeds.png``; about half of a short recording's output time).

    ``lifter_options`` are passed to the 3D adapter: the keyword arguments its ``load`` takes,
    checked by :func:`check_lifter_options` (for example ``pixel``/``clip_len`` for motionbert,
    ``hypothesis``/``step`` for ddhpose, ``layout``/``axes``/``units``/``key``/``delimiter``/
    ``measured_root`` for generic; each adapter's docstring lists its own);
    ``person`` picks a 2D track (AlphaPose ``idx``, MMPose instance position); ``heading``
    is the heading source of :func:`pcnet.pipeline.rectification.rectify` (``None`` = its default).
    ``fps`` is needed only when neither a video nor an input file gives the frame rate; with
    a video it must match the video's rate unless ``fps_override``. ``camera_prior``:
    sequence mode's up model (the shipped ensemble) uses its declared camera prior and its lying
    reading (:mod:`pcnet.stages.up_model`); False = the poses alone. ``posture``: ``auto``, or
    the body's posture where the user knows it, ``upright`` or ``lying`` (read by the same up
    model: :func:`pcnet.stages.rectify.check_posture`). ``c3d``: also write the markers as a C3D file
    (needs the ``c3d`` extra, ezc3d). ``residual_cutoff``: choose the low-pass cutoff by
    Winter's residual analysis of the recording (:func:`pcnet.stages.kinematics.residual_analysis`)
    instead of ``cutoff_hz``. ``opensim``: also scale an OpenSim model and solve inverse
    kinematics on the world-frame markers before the output is published
    (:func:`pcnet.stages.opensim_ik.scale_and_ik`; needs the ``opensim`` extra and metric poses),
    ``mass`` (kg) setting the model's mass. A ``video`` without ``lifter`` and
    ``lifter_output`` (and without 2D keypoints) is estimated by the embedded MediaPipe
    estimator (:mod:`pcnet.pipeline.video_estimate`, the ``video`` extra). ``focal_px``: the
    camera's focal length in pixels (principal point at the image centre), for every lifter:
    it places the pelvis path recovered from the 2D keypoints
    (:func:`pcnet.stages.root_path.root_from_keypoints`) and turns MediaPipe's landmarks into
    the real camera; ``None`` = a MediaPipe file's own ``K``, else a phone's 26 mm equivalent
    (:data:`pcnet.stages.core.perspective.DEFAULT_FOCAL_35MM`). ``image_size``: ``"WIDTHxHEIGHT"``
    in pixels of the frames the 2D keypoints were detected in, for a run without a video whose
    keypoint file does not state it (AlphaPose, OpenPose): the principal point of that fit.
    ``roi``: ``"X,Y,W,H"`` (or four ints) in pixels of the video as displayed, for a video alone: the embedded
    estimator sees only that region, so it follows the person there, not another one in view
    (:func:`pcnet.models.pose_estimator.estimate_video`). ``camera_up``: ``"X,Y,Z"`` (or three
    numbers), the static camera's up direction (against gravity) in its own frame (OpenCV axes:
    x right, y down, z forward; a level camera's is ``0,-1,0``; any length), where it is known
    (a calibration, the gravity sensor of the phone that filmed, another run's
    ``canonical.npz`` ``report`` ``up``): sequence mode takes it instead of estimating
    one (:class:`pcnet.stages.rectify.SequenceEvidence`). ``camera_up_from``: instead of
    ``camera_up``, an earlier run's output folder of the same static camera, unmoved, whose up
    its poses read (:func:`trial_up_record`: a standing trial before a floor exercise).
    """

    lifter: str | None = None
    lifter_output: str | None = None
    keypoints2d: str | None = None
    keypoints2d_format: str | None = None
    video: str | None = None
    out: str = "pcnet_out"
    method: str = "pcnet"
    mode: str = "sequence"
    heading: str | None = None
    height: float | None = None
    fps: float | None = None
    fps_override: bool = False
    person: int | None = None
    confidence_threshold: float | None = None
    cutoff_hz: float | None = None
    align: str = "none"
    overwrite: bool = False
    recording: bool = True
    plots: bool = True
    weights: str | None = None
    camera_prior: bool = True
    posture: str = "auto"
    c3d: bool = False
    residual_cutoff: bool = False
    opensim: bool = False
    mass: float | None = None
    focal_px: float | None = None
    image_size: str | None = None
    roi: str | None = None
    camera_up: str | None = None
    camera_up_from: str | None = None
    lifter_options: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._plain_values()

    def _plain_values(self) -> None:
        """Turn the values a Python caller holds into the plain ones the config keeps, when it
        is made and again when it is validated (a service's trial set ``cfg.out = Path(...)``
        on a config made once)."""
        # Python callers hold paths as pathlib.Path; the config keeps the str a TOML file,
        # a manifest and the command line give.
        for name in PATH_FIELDS:
            value = getattr(self, name)
            if isinstance(value, os.PathLike):
                setattr(self, name, os.fspath(value))
        # A region given as numbers, (x, y, w, h), is the "x,y,w,h" a TOML file or the command line gives.
        if isinstance(self.roi, (tuple, list)) and all(isinstance(v, (int, np.integer)) for v in self.roi):
            self.roi = ",".join(str(int(v)) for v in self.roi)
        # and an up given as numbers (a numpy array, a tuple) the "x,y,z" they give
        if isinstance(self.camera_up, (tuple, list, np.ndarray)) and all(
                isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in self.camera_up):
            self.camera_up = ",".join(repr(float(v)) for v in self.camera_up)
        # A rate or height computed with numpy is a numpy scalar (np.float32(30)); the config
        # keeps the plain Python value that the type check, TOML and the report's JSON take.
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.generic):
                setattr(self, f.name, value.item())
        if isinstance(self.lifter_options, dict):
            self.lifter_options = {k: v.item() if isinstance(v, np.generic) else v
                                   for k, v in self.lifter_options.items()}

    @property
    def image_size_px(self) -> tuple[int, int] | None:
        """``image_size`` as ``(width, height)`` pixels, or ``None`` (checked by :meth:`validate`)."""
        if self.image_size is None:
            return None
        width, height = self.image_size.lower().split("x")
        return int(width), int(height)

    @property
    def roi_px(self) -> tuple[int, int, int, int] | None:
        """``roi`` as ``(x, y, width, height)`` pixels, or ``None`` (checked by :meth:`validate`)."""
        return None if self.roi is None else tuple(int(v) for v in self.roi.split(","))

    @property
    def camera_up_vector(self) -> tuple[float, float, float] | None:
        """``camera_up`` (or the up of the run ``camera_up_from`` names, :func:`trial_up_record`)
        as a unit ``(x, y, z)`` in the camera frame, or ``None`` (checked by
        :meth:`validate`)."""
        if self.camera_up_from is not None:
            return tuple(trial_up_record(self.camera_up_from, "camera_up_from")["up"])
        return None if self.camera_up is None else parse_camera_up(self.camera_up, "camera_up")

    @property
    def min_confidence(self) -> float:
        """2D confidence below which a 3D joint becomes NaN: ``confidence_threshold`` or
        :data:`DEFAULT_CONFIDENCE`."""
        return DEFAULT_CONFIDENCE if self.confidence_threshold is None else self.confidence_threshold

    @property
    def lowpass_hz(self) -> float:
        """The kinematics' low-pass cutoff unless ``residual_cutoff``: ``cutoff_hz`` or
        :data:`DEFAULT_CUTOFF_HZ`."""
        return DEFAULT_CUTOFF_HZ if self.cutoff_hz is None else self.cutoff_hz

    @classmethod
    def from_values(cls, source: str, values: dict) -> "RunConfig":
        """Build and :meth:`validate` a config from parsed values (a TOML table, a manifest
        row, command-line options), naming ``source`` in errors.

        Raises:
            InputError: a name that is no field, or :meth:`validate` refuses a value (or the
                inputs are missing).
        """
        allowed = sorted(f.name for f in fields(cls))
        unknown = sorted(map(str, set(values) - set(allowed)))
        if unknown:
            raise InputError(f"{field_name(source, *unknown)}: unknown{close_names(unknown, allowed)}; expected some "
                             f"of {allowed}")
        return cls(**values).validate(source)

    def _check_inputs_given(self, source: str) -> None:
        """A lifter with its output, or a video alone (the embedded estimator gives both the 3D
        poses and the 2D keypoints).

        Raises:
            InputError: naming the missing or the surplus fields.
        """
        cli = source == COMMAND_LINE
        name = _flag if cli else (lambda n: n)
        if self.lifter_output is None and self.lifter is None:
            if self.video is None:
                got = "none of them" if self.keypoints2d is None else (
                    f"only 2D keypoints ({name('keypoints2d')}): pcnet does not lift 2D keypoints to 3D; run a "
                    f"lifter (MotionBERT, VideoPose3D, DDHPose) on them first, or give the video")
                raise InputError(f"{field_name(source, 'lifter', 'lifter_output')}: expected {name('lifter')} and "
                                 f"{name('lifter_output')} (a 3D lifter's file), or {name('video')} alone (the embedded "
                                 f"estimator, pip install \"pcnet[video]\"), got {got}")
            if self.keypoints2d is not None:
                raise InputError(f"{field_name(source, 'keypoints2d')}: expected none with {name('video')} alone (the "
                                 f"embedded estimator makes its own 2D keypoints and 3D poses), got "
                                 f"{name('keypoints2d')}; give {name('lifter')} and {name('lifter_output')} too, or "
                                 f"leave it out")
            check_lifter_options(source, ESTIMATOR_LIFTER, self.lifter_options)  # --focal-px: the camera's
        for given, missing in (("lifter", "lifter_output"), ("lifter_output", "lifter")):
            if getattr(self, given) is not None and getattr(self, missing) is None:
                # which lifter made the file is the user's to say: the choices (a coach's trial read only "a value")
                choices = f" (one of {', '.join(lifter_names())})" if missing == "lifter" else ""
                raise InputError(f"{field_name(source, missing)}: expected a value{choices} with {name(given)} "
                                 f"{getattr(self, given)!r}, got none")

    def _no_recorded_rate(self) -> bool:
        """No video, no fps, and neither the lifter's files nor the 2D format's (if any) can
        record a frame rate (``register_2d/3d(records_fps=False)``, :mod:`pcnet.adapters.registry`;
        MediaPipe archives and Kinect skeletons may carry theirs)."""
        return (self.video is None and self.fps is None and self.lifter is not None
                and not records_frame_rate("3d", self.lifter)
                and (self.keypoints2d_format is None or not records_frame_rate("2d", self.keypoints2d_format)))

    def _check_lifter_facts(self, source: str) -> None:
        """Refuse what the lifter's registered format facts rule out before its file is read
        (``register_3d(never_metric=..., absent_joints=...)``): a study's manifest check let such
        rows through, each to fail as soon as it ran."""
        from pcnet.stages.core.conventions import H36M_JOINTS
        from pcnet.stages.scale import HEIGHT_CHAIN, chain_joints_lacking

        facts = _registered("3d").get(self.lifter)
        if facts is None:
            return
        metric = [f for f in ("c3d", "opensim") if getattr(self, f)]
        if facts.never_metric and metric and self.height is None:
            raise InputError(f"{field_name(source, *metric)}: expected metric poses (a lifter writing metres, or "
                             f"{field_name(source, 'height')}), got lifter {self.lifter}, whose poses are never in metres")
        if self.height is None:
            return
        lacking = chain_joints_lacking(np.array([j not in facts.absent_joints for j in H36M_JOINTS]))
        if lacking:
            raise InputError(f"{field_name(source, 'height')}: expected a skeleton with the {HEIGHT_CHAIN} its size "
                             f"is measured on, got lifter {self.lifter}, whose skeleton never has {', '.join(lacking)}; "
                             f"leave out {field_name(source, 'height')}")

    def _check_camera_up(self, source: str) -> None:
        """``camera_up`` or ``camera_up_from`` (one of them): :func:`parse_camera_up` or
        :func:`trial_up_record`, and :func:`check_camera_up_use`."""
        if self.camera_up is not None and self.camera_up_from is not None:
            raise InputError(f"{field_name(source, 'camera_up_from')}: expected instead of "
                             f"{field_name(source, 'camera_up')} (one known up), got both")
        name = field_name(source, "camera_up" if self.camera_up is not None else "camera_up_from")
        if self.camera_up is not None:
            parse_camera_up(self.camera_up, name)
        else:
            trial_up_record(self.camera_up_from, name)
        check_camera_up_use(self.mode, self.posture, name, field_name(source, "posture"))

    def validate(self, source: str = "config") -> "RunConfig":
        """Check every field's type (against the annotations), choices, ranges and
        combinations. The path fields (``video``, ``keypoints2d``, ``lifter_output``, ``out``,
        ``weights``) are checked for their type and whether they are given, never by their
        value: their files are the caller's to check, and ``pcnet batch`` validates the rows of
        a manifest that differ only in their paths once (a rule about a path's value belongs
        with the checks of the files, in :mod:`pcnet.pipeline.batch` and ``runner``).

        Raises:
            InputError: naming ``source``, the field, what was expected and what was given.
        """
        from pcnet.stages.heading import HEADING_SOURCES
        from pcnet.stages.opensim_ik import HEIGHT_RANGE_M, MASS_RANGE_KG
        from pcnet.stages.rectify import METHODS, check_method_weights, check_posture

        self._plain_values()
        check_config_types(source, "", {f.name: getattr(self, f.name) for f in fields(self)}, RunConfig)
        self._check_inputs_given(source)
        # the choices and ranges, each a field of its own: all of their problems at once
        problems = []
        # (field, value, choices, None allowed)
        for name, value, choices, optional in (
            ("lifter", self.lifter, lifter_names(), self.lifter_output is None), ("method", self.method, METHODS, False),
            ("mode", self.mode, MODES, False), ("align", self.align, ALIGN, False),
            ("heading", self.heading, HEADING_SOURCES, True),
            ("keypoints2d_format", self.keypoints2d_format, keypoint_formats(), True),
        ):
            if isinstance(value, str) and value not in choices and value.lower() in choices:
                # any case reads as the name (a yoga trial's manifest gave "VideoPose3D", as its authors write it)
                value = value.lower()
                setattr(self, name, value)
            if not (optional and value is None) and value not in choices:
                problems.append(f"{field_name(source, name)}: expected one of {', '.join(choices)}, got "
                                f"{value!r}{close_names([value], choices)}")
        if (self.keypoints2d is None) != (self.keypoints2d_format is None):
            given = "keypoints2d" if self.keypoints2d is not None else "keypoints2d_format"
            missing = "keypoints2d_format" if given == "keypoints2d" else "keypoints2d"
            problems.append(f"{field_name(source, 'keypoints2d', 'keypoints2d_format')}: expected both or neither, "
                            f"got {_flag(given) if source == COMMAND_LINE else given} "
                            f"{getattr(self, given)!r} without {_flag(missing) if source == COMMAND_LINE else missing}")
        # (field, value, low, high, unit): ranges that a real recording can have
        for name, value, low, high, unit in (
            ("height", self.height, MIN_HEIGHT_M, MAX_HEIGHT_M, "m (the subject's height)"),
            ("fps", self.fps, MIN_FPS, MAX_FPS, "frames per second"),
            ("cutoff_hz", self.cutoff_hz, 0.1, MAX_FPS / 2, "Hz"),
            ("confidence_threshold", self.confidence_threshold, 0.0, 1.0, "(2D confidence)"),
            ("mass", self.mass, *MASS_RANGE_KG, "kg (the subject's mass)"),
            # the OpenSim model's own range, before any work rather than after the run
            ("height", self.height if self.opensim else None, *HEIGHT_RANGE_M,
             "m (the subject's height, as the OpenSim model is scaled)"),
        ):
            if value is not None and not (math.isfinite(value) and low <= value <= high):
                # a height in centimetres or feet is the likely slip (user trials typed --height 170 and 5.6)
                hint = next((f" ({other}? give metres: {value * per_unit:.3g})"
                             for other, per_unit in (("centimetres", 0.01), ("feet", FOOT_M))
                             if name == "height" and math.isfinite(value) and low <= value * per_unit <= high), "")
                problems.append(f"{field_name(source, name)}: expected a value in [{low:g}, {high:g}] {unit}, got "
                                f"{value!r}{hint}")
        refuse(problems)
        if self.focal_px is not None and not (math.isfinite(self.focal_px) and self.focal_px > 0):
            raise InputError(f"{field_name(source, 'focal_px')}: expected a positive finite focal length in pixels, "
                             f"got {self.focal_px!r}")
        if self.image_size is not None and not re.fullmatch(r"[1-9][0-9]{0,5}[xX][1-9][0-9]{0,5}", self.image_size):
            raise InputError(f"{field_name(source, 'image_size')}: expected WIDTHxHEIGHT in pixels (e.g. 1920x1080), "
                             f"got {self.image_size!r}")
        if self.roi is not None and not re.fullmatch(r"[0-9]{1,5},[0-9]{1,5},[1-9][0-9]{0,4},[1-9][0-9]{0,4}",
                                                     self.roi.replace(" ", "")):
            raise InputError(f"{field_name(source, 'roi')}: expected X,Y,W,H in pixels of the video as displayed "
                             f"(whole numbers, the corner X,Y from the top left, width and height at least 1), got "
                             f"{self.roi!r}")
        if self.roi is not None and (self.video is None or self.lifter_output is not None):
            got = "no video" if self.video is None else "a lifter's output, whose person is already chosen"
            raise InputError(f"{field_name(source, 'roi')}: expected with a video alone (the embedded estimator "
                             f"follows the person inside it), got {got}")
        if "focal_px" in self.lifter_options:  # one source: the camera's, whatever the lifter
            raise InputError(f"{_option_field(source, 'focal_px')}: expected focal_px as a run option (the camera's focal "
                             f"length, for every lifter), got it in lifter_options; move it to the top level")
        if self.person is not None and self.person < 0:
            raise InputError(f"{field_name(source, 'person')}: expected a track id >= 0, got {self.person}")
        # Options that would be silently ignored are mistakes the user should hear about.
        multi_track = multi_track_formats()
        if self.person is not None and self.keypoints2d_format not in multi_track:
            got = (f"keypoints2d_format {self.keypoints2d_format!r}" if self.keypoints2d_format is not None
                   else "pcnet's own pose estimator's (one person per frame)" if self.video is not None
                   else "no 2D keypoints")
            raise InputError(f"{field_name(source, 'person')}: expected 2D keypoints with several tracks "
                             f"({' or '.join(multi_track)}), got {got}")
        check_method_weights(self.method, self.weights, field_name(source, "weights"))
        check_posture(self.posture, self.method, self.weights, self.mode, self.camera_prior,
                      field_name(source, "posture"))
        if self.lifter is not None:
            check_lifter_options(source, self.lifter, self.lifter_options)
        if self.mode in ("frame", "smooth"):
            # both act only on sequence mode's fixed world frame for the recording
            if not self.camera_prior:
                name = "--no-camera-prior" if source == COMMAND_LINE else field_name(source, "camera_prior")
                raise InputError(f"{name}: expected with mode sequence or auto (the camera prior weighs only sequence "
                                 f"mode's one up for the recording), got mode {self.mode}")
            if self.lifter_options.get("measured_root"):
                raise InputError(f"{_option_field(source, 'measured_root')}: expected with mode sequence or auto (only "
                                 f"a fixed world frame keeps the measured pelvis path), got mode {self.mode}")
            if self.opensim:  # a user trial got a whole run, then a warning that no fit was made
                raise InputError(f"{field_name(source, 'opensim')}: expected with mode sequence or auto (OpenSim's "
                                 f"inverse kinematics reads world.trc, which only a fixed world frame gives), got mode "
                                 f"{self.mode}")
        if self.fps_override and self.fps is None:
            raise InputError(f"{field_name(source, 'fps_override')}: expected together with fps, got no fps")
        if self._no_recorded_rate():
            # the metric check needs the loaded file; its requirement is named here, or a user
            # trial met it only on the next attempt
            metric = [f for f in ("c3d", "opensim") if getattr(self, f)] if self.height is None else []
            cli = source == COMMAND_LINE
            also = (f"; {' and '.join(_flag(f) if cli else f for f in metric)} will also expect metric poses (a "
                    f"lifter writing metres, or {_flag('height') if cli else 'height'})") if metric else ""
            raise InputError(f"{field_name(source, 'fps')}: expected the frame rate (no video is given and "
                             f"{self.lifter} files do not record one), got none{also}")
        if self.lifter is not None:
            self._check_lifter_facts(source)
        if self.camera_up is not None or self.camera_up_from is not None:
            self._check_camera_up(source)
        if self.confidence_threshold is not None and self.keypoints2d is None:
            raise InputError(f"{field_name(source, 'confidence_threshold')}: expected together with 2D keypoints "
                             f"(it masks their low-confidence joints), got {self.confidence_threshold:g} without keypoints2d")
        if self.cutoff_hz is not None and self.fps is not None and self.cutoff_hz >= self.fps / 2:
            raise InputError(f"{field_name(source, 'cutoff_hz')}: expected a cutoff below half the frame rate "
                             f"(Nyquist: {self.fps / 2:g} Hz at fps {self.fps:g}), got {self.cutoff_hz:g}")
        if self.cutoff_hz is None and not self.residual_cutoff and self.fps is not None \
                and DEFAULT_CUTOFF_HZ >= self.fps / 2:
            cutoff, residual = (("--cutoff-hz", "--residual-cutoff") if source == COMMAND_LINE
                                else ("cutoff_hz", "residual_cutoff"))
            raise InputError(f"{field_name(source, 'fps')}: expected a frame rate above {2 * DEFAULT_CUTOFF_HZ:g} fps "
                             f"for the default low-pass cutoff {DEFAULT_CUTOFF_HZ:g} Hz (Nyquist), got {self.fps:g}; "
                             f"give {cutoff} below {self.fps / 2:g} or {residual}")
        if self.mass is not None and not self.opensim:
            cli = source == COMMAND_LINE
            raise InputError(f"{field_name(source, 'mass')}: expected together with {_flag('opensim') if cli else 'opensim'} "
                             f"(it sets the OpenSim model's mass), got {_flag('mass') if cli else 'mass'} {self.mass:g} "
                             f"without it")
        if self.residual_cutoff and self.cutoff_hz is not None:
            raise InputError(f"{field_name(source, 'cutoff_hz', 'residual_cutoff')}: expected one of the two (the "
                             f"residual analysis chooses the cutoff), got cutoff_hz {self.cutoff_hz:g} and residual_cutoff")
        return self


#: The packages whose files decide what a run writes, and those files' kinds: code, weights,
#: data tables, the OpenSim model (not pages, licences or the bundled example, an input; not an
#: editor's or a system's hidden files, which would make every batch row run again).
_CODE_PACKAGES = ("pcnet.pipeline", "pcnet.stages", "pcnet.adapters", "pcnet.models")
_CODE_SUFFIXES = (".py", ".json", ".onnx", ".task", ".osim", ".xml")
_NOT_CODE = ("__pycache__", "example_data")
#: The code digest of an installed pcnet whose package files cannot be read (a zip import, a file
#: gone): never equal to an earlier output's, so a batch runs every row again.
UNKNOWN_CODE = "unknown"


@functools.cache
def pcnet_version() -> str:
    """The installed pcnet's version and its code: ``"0.1.0+code.3f2a9c1d0b7e"``, the
    distribution's version (``unknown`` when pcnet is not installed, e.g. imported from a bare
    checkout) with, as a PEP 440 local label, the first 12 hex digits of a sha256 over the
    relative path and bytes of every file of its packages (code, weights, data tables).

    The distribution's version alone stays the same across changes of the code (an editable
    install, a reinstall from a newer checkout), so a batch re-run would keep outputs that
    older code wrote (:mod:`pcnet.pipeline.batch_marker`); the digest changes with any of its
    files. Read once per process. Where the package's files cannot be read (not plain files on
    disk, or one unreadable), the label is ``+code.unknown`` (:data:`UNKNOWN_CODE`), which a
    batch never takes for the code of an earlier output.
    """
    try:
        version = metadata.version("pcnet")
    except metadata.PackageNotFoundError:
        version = "unknown"
    roots = {package: Path(importlib.util.find_spec(package).origin).parent for package in _CODE_PACKAGES}
    try:
        digest = code_digest(roots)[:12]
    except OSError:
        digest = UNKNOWN_CODE
    return f"{version}+code.{digest}"


def code_digest(roots: dict[str, Path]) -> str:
    """Hex sha256 over ``{name: folder}``'s code files (suffixes :data:`_CODE_SUFFIXES`, not
    hidden, outside ``__pycache__`` and ``example_data``): each file's ``name/relative path``
    and the sha256 of its bytes, in sorted order (:func:`pcnet_version`).

    Raises:
        OSError: a folder holds no such file (not a folder on disk: a zip import), or a file
            cannot be read.
    """
    digest = hashlib.sha256()
    for name, root in sorted(roots.items()):
        files = sorted(p for p in root.rglob("*") if p.suffix in _CODE_SUFFIXES and not p.name.startswith(".")
                       and not set(_NOT_CODE) & set(p.relative_to(root).parts) and p.is_file())
        if not files:
            raise OSError(f"{root}: no code files to read")
        for path in files:
            digest.update(f"{name}/{path.relative_to(root).as_posix()}\0".encode())
            # per version of a file: a run's report digests the shipped weights again
            digest.update(bytes.fromhex(sha256_file_version(path)))
    return digest.hexdigest()


#: The fields of :class:`RunConfig` that name files or folders.
PATH_FIELDS = ("video", "keypoints2d", "lifter_output", "out", "weights", "camera_up_from")


def settings_record(cfg: RunConfig) -> dict:
    """Every field of ``cfg`` as a run used it (JSON-able; paths absolute, so that a colleague
    repeats the run from anywhere; a lifter option that is not a plain value as its text):
    the report's ``inputs.settings`` (a trial could not tell a run's height or confidence
    threshold from its outputs). A default the config resolves itself is written as its value
    (a trial read ``heading n/a`` and ``cutoff_hz n/a`` for a run with auto and 6 Hz): the heading
    source, the low-pass cutoff unless the residual analysis chooses it, and the 2D confidence
    threshold where 2D keypoints are read."""
    from pcnet.stages.rectify import resolve_heading_source  # SciPy and the stages: only once a run is recorded

    resolved = {"heading": resolve_heading_source(cfg.method, cfg.heading)}
    if not cfg.residual_cutoff:
        resolved["cutoff_hz"] = cfg.lowpass_hz
    if cfg.keypoints2d is not None or cfg.video is not None:
        resolved["confidence_threshold"] = cfg.min_confidence
    out = {}
    for f in fields(cfg):
        value = resolved.get(f.name, getattr(cfg, f.name))
        if f.name in PATH_FIELDS and value is not None:
            value = str(Path(value).resolve())
        elif f.name == "lifter_options":
            value = plain_options(value)
        out[f.name] = value
    return out


def plain_options(options: dict) -> dict:
    """Lifter ``options`` sorted by name, a value that is not a plain JSON value as its text."""
    return {k: v if isinstance(v, (str, int, float, bool)) else str(v) for k, v in sorted(options.items())}


def parse_hypothesis(text: str) -> int | str:
    """DDHPose ``--hypothesis`` / manifest cell: a decimal integer index, or a name
    (``mean``) left for the adapter to check. ``"²"`` or ``"--5"`` are names, not numbers."""
    text = text.strip()
    return int(text) if re.fullmatch(r"-?[0-9]+", text) else text


#: Settings that choose one of two ways: an override of one drops the file's other.
ALTERNATIVES = (("cutoff_hz", "residual_cutoff"),)


def load_run_config(path: str | Path, **overrides) -> RunConfig:
    """Read a TOML file whose top-level keys are :class:`RunConfig` fields (plus an optional
    ``[lifter_options]`` table); relative paths are resolved against the file's folder;
    ``overrides`` (not None) win, and one of :data:`ALTERNATIVES` given there replaces the file's
    other.

    Raises:
        InputError: unknown keys, values of the wrong type or invalid values, or an input file
            (``video``, ``keypoints2d``, ``lifter_output``, ``weights``) that does not exist,
            naming the file and the field.
    """
    path = Path(path)
    raw = read_toml(path)
    misplaced = sorted(set(raw) & set(COMMAND_LINE_OPTIONS))
    if misplaced:  # a manifest's column, the command line's flag: a table of its own here (a trial's `pixel = true`)
        raise InputError(f"{path}: {', '.join(map(repr, misplaced))}: expected in a [lifter_options] table (options "
                         f"of the lifter's file), got {'it' if len(misplaced) == 1 else 'them'} at the top level")
    # the types are the config's to check, after it reads an array of numbers (roi, camera_up) as its text
    check_unknown_keys(path, "", raw, RunConfig)
    for key in PATH_FIELDS:
        if isinstance(raw.get(key), str):
            raw[key] = str((path.parent / raw[key]).resolve()) if not Path(raw[key]).is_absolute() else raw[key]
    given = {k: v for k, v in overrides.items() if v is not None}
    for a, b in ALTERNATIVES:  # the command line's choice replaces the file's other one (a trial's
        for mine, other in ((a, b), (b, a)):  # --cutoff-hz over a file's residual_cutoff was refused)
            if mine in given and other not in given:
                raw.pop(other, None)
    raw.update(given)
    # named before the settings they may explain; the weights too (a trial's read only the resolved path)
    for key in ("video", "keypoints2d", "lifter_output", "weights"):
        if isinstance(raw.get(key), str) and not os.path.lexists(raw[key]):
            raise InputError(f"{field_name(str(path), key)}: expected an existing file, got no such file "
                             f"({raw[key]})")
    return RunConfig.from_values(str(path), raw)
