"""OpenSim scaling and inverse kinematics of pcnet's world-frame TRC (optional extra).

``pcnet run`` writes ``world.trc`` for a static camera: the 17 H36M-17 joint centres as
markers named as :data:`pcnet.stages.core.conventions.H36M_JOINTS`, in metres, in the recording's
world frame, which has OpenSim's ground-frame axis roles (+X forward, +Y up, +Z right; the ground
at y = 0, ankle centres at rest the fitted clearance above it; [CONVENTIONS.md](../docs/CONVENTIONS.md) "World frame").
:func:`scale_and_ik` scales a full-body model to the subject from those markers and solves
inverse kinematics over the whole recording.

Model and setup files (``pcnet/stages/opensim_data/``, see ``ATTRIBUTION.md`` there):

* ``Model_H36M17.osim``: Pose2Sim's ``Model_Pose2Sim_simple.osim`` (Pagnon et al. 2021,
  BSD-3-Clause; after Rajagopal et al. 2016) without mesh geometry, with the coordinates no
  joint-centre marker constrains locked at their default values (ankle, subtalar, mtp and
  wrist flexion/deviation at 0, pronation/supination at 1.57 rad, 89.95 deg: :func:`locked_note`).
* ``Markers_H36M17.xml``: one marker per H36M-17 joint at the model's joint centres, read
  from the joints' parent offset frames in the ``.osim`` (hips, knees, ankles, shoulders,
  elbows, wrists; ``pelvis`` at the midpoint of the hip centres). ``spine``, ``thorax``,
  ``neck_nose`` and ``head`` have no joint in the model: they are ``fixed=false`` and the
  ScaleTool's marker placer moves them to where the subject's static window has them.
* ``Scaling_Setup_H36M17.xml``: measurement-based scaling (marker-pair distances averaged over
  the whole recording: hip width -> pelvis; hip-shoulder -> torso X Y and head; shoulder width ->
  torso Z; hip-knee -> femur; knee-ankle -> tibia and foot; shoulder-elbow -> humerus;
  elbow-wrist -> forearm and hand; each side on its own), then the marker placer on a static
  window.
* ``IK_Setup_H36M17.xml``: the marker weights (1; 0.5 for spine, neck_nose, head) and the
  solver accuracy 1e-4 (in an exploratory run when it was chosen, OpenSim's default 1e-5 was
  about 3x slower for < 1 mm less RMS on the demo and mocap clips, and on a Bandai kick kept the
  right arm in a wrong local solution for 60+ frames).

Sources: opensim-core ``ScaleTool`` / ``ModelScaler`` / ``MarkerPlacer`` and
``InverseKinematicsTool`` (https://opensimconfluence.atlassian.net/wiki/spaces/OpenSim/pages/
53090037/How+Scaling+Works and .../53089741/How+Inverse+Kinematics+Works; opensim-core
``OpenSim/Tools/ScaleTool.cpp``, ``InverseKinematicsTool.cpp``); the Pose2Sim repository
(https://github.com/perfanalytics/pose2sim, ``Pose2Sim/OpenSim_Setup/``) for the model and
the layout of the setup files.

``opensim`` (PyPI, ``pip install "pcnet[opensim]"``) is imported only when a function here
runs, so pcnet works without it.
"""

from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import shutil
import socket
import time
import uuid
from pathlib import Path

import numpy as np

from .core.conventions import H36M_JOINTS
from .core.atomic import write_text, writing_failed
from .core.errors import InputError, import_extra
from .core.framestore import seen_joints
from .isb_angles import GIMBAL_MARGIN_DEG

MISSING_OPENSIM = 'OpenSim scaling and inverse kinematics (--opensim, pcnet opensim) need OpenSim: pip install "pcnet[opensim]"'
DATA_DIR = Path(__file__).resolve().parent / "opensim_data"
MODEL_FILE = "Model_H36M17.osim"
MARKER_FILE = "Markers_H36M17.xml"
SCALE_SETUP = "Scaling_Setup_H36M17.xml"
IK_SETUP = "IK_Setup_H36M17.xml"
#: What :func:`scale_and_ik` writes; the last is its fit (marker errors and the fit's warning).
#: The two setups and their marker files are what the tools ran, for a re-run in OpenSim.
OUTPUTS = ("scaled_model.osim", "ik.mot", "ik_marker_errors.sto", "scale_setup.xml", "scale_markers.trc",
           "ik_setup.xml", "ik_markers.trc", "opensim_fit.json")
#: Subject heights (m) and masses (kg) the shipped model is scaled to.
HEIGHT_RANGE_M = (0.5, 2.5)
MASS_RANGE_KG = (10.0, 300.0)
#: Inverse kinematics fits worse than this RMS marker error (m) get a warning: OpenSim's
#: "Simulation with OpenSim - Best Practices" checklist asks of IK an RMS error under about
#: 2 cm (and a maximum under 4 cm; the maximum over a whole recording is noisy: 4-6 cm on
#: mocap truth here, benchmarks/results/opensim_ik.txt, so only the RMS is checked).
MAX_GOOD_MARKER_RMS_M = 0.02


def unscaled_segments_flag(result: dict) -> str | None:
    """The warning when :func:`scale_and_ik`'s ``result`` left a segment unscaled (the markers
    of its every measurement were in no frame), else ``None``."""
    if not result.get("segments_not_scaled"):
        return None
    return (f"segments {', '.join(result['segments_not_scaled'])} keep the generic model's size: no frame has "
            f"the markers that measure them ({', '.join(result['markers_left_out'])} left out)")


def marker_rms_flag(result: dict) -> str | None:
    """The warning when :func:`scale_and_ik`'s ``result`` has an RMS marker error above
    :data:`MAX_GOOD_MARKER_RMS_M` (the joint angles then describe a model that does not follow
    the poses), else ``None``."""
    rms, worst = result["marker_rms_m"], result["marker_max_m"]
    if rms <= MAX_GOOD_MARKER_RMS_M:  # NaN (no IK frame) is warned about too
        return None
    return (f"marker RMS {100 * rms:.1f} cm (max {100 * worst:.1f} cm): above the ~{100 * MAX_GOOD_MARKER_RMS_M:.0f} cm "
            f"OpenSim's best-practice checklist asks of inverse kinematics; the model does not follow these poses "
            f"(the lifter's own error: bone lengths that change from frame to frame, a limb read in a pose no body "
            f"takes; or a skeleton unlike a human body, a different person, missing joints): check the "
            f"joint angles before using them")


def model_leg_asymmetry(result: dict) -> tuple[float, str]:
    """The relative difference of the scaled model's legs (thigh plus shank, from
    ``result["segment_lengths_m"]``, :func:`segment_lengths`): ``|left - right| / max(left,
    right)`` and the shorter side, as :func:`pcnet.stages.flags.leg_asymmetry` measures the
    poses'; NaN and ``""`` without both legs."""
    lengths = result.get("segment_lengths_m") or {}
    legs = {side: sum(lengths.get(f"{side}_{s}", float("nan")) for s in ("thigh", "shank")) for side in ("left", "right")}
    longer = max(legs.values())
    if not (np.isfinite(list(legs.values())).all() and longer > 0):
        return float("nan"), ""
    return abs(legs["left"] - legs["right"]) / longer, min(legs, key=legs.get)


def model_leg_asymmetry_flag(result: dict) -> str | None:
    """The warning when the scaled model's legs differ (:func:`model_leg_asymmetry`) by more
    than a person's do: the lifter-skeleton limit ``leg_asymmetry`` the run's own check uses
    (:func:`pcnet.stages.flags.load_skeleton_limits`, fitted on training mocap, decision 0075),
    else ``None``. The ScaleTool scales each side on its own markers, so a lifter's short leg
    becomes the model's (a user trial's 18 % went into the model with no word in its fit)."""
    from .flags import load_skeleton_limits  # flags reads this module's fit; imported when asked

    difference, shorter = model_leg_asymmetry(result)
    if not difference > load_skeleton_limits().leg_asymmetry:
        return None
    return (f"the scaled model's legs differ by {100 * difference:.0f} % in length ({shorter} shorter; limb lengths "
            f"in the fit), more than a person's: the markers' (the lifter's) error, not the subject's; the {shorter} "
            f"side's joint angles and any model quantity that depends on segment lengths carry it")


def ik_fit_flags(result: dict) -> list[str]:
    """:func:`scale_and_ik`'s warnings: :func:`unscaled_segments_flag`,
    :func:`marker_rms_flag`, then :func:`model_leg_asymmetry_flag`, those that apply."""
    return [text for text in (unscaled_segments_flag(result), marker_rms_flag(result),
                              model_leg_asymmetry_flag(result)) if text]


def time_spans(times: np.ndarray, flagged: np.ndarray) -> list[tuple[float, float]]:
    """``[(first, last), ...]`` s: the runs of consecutive ``flagged`` ``(T,)`` bool rows of a
    table with ``times`` ``(T,)`` s (OpenSim's per-frame marker errors)."""
    flagged = np.asarray(flagged, bool)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], flagged.astype(np.int8), [0]])))
    return [(float(times[a]), float(times[b - 1])) for a, b in zip(edges[::2], edges[1::2])]


def _spans_text(spans) -> str:
    """At most three spans as ``a-b s``, and how many more."""
    text = ", ".join(f"{a:.2f} s" if f"{a:.2f}" == f"{b:.2f}" else f"{a:.2f}-{b:.2f} s" for a, b in spans[:3])
    return text + (f" and {len(spans) - 3} more" if len(spans) > 3 else "")


def _trial_name(path: str) -> str:
    """A marker file named by its folder and name (``standing/world.trc``): pcnet's are all
    ``world.trc``."""
    p = Path(path)
    return f"{p.parent.name}/{p.name}" if p.parent.name else p.name


def opensim_fit_line(result: dict, short: bool = False) -> str:
    """One summary line of :func:`scale_and_ik`'s fit: marker RMS and maximum over the IK
    frames, the frames above the RMS limit and when, the frames and the markers left out
    (``short``: without why), IK speed."""
    left_out = result["frames_without_markers"]
    above = result.get("frames_above_rms_limit", 0)
    markers = result.get("markers_left_out") or []
    scaled, total = result.get("scale_frames"), result["frames"] + left_out
    trial = result.get("scale_trial")
    why = ("" if short else " (empty in every frame of the recording or of its static trial)" if trial
           else " (empty in every frame: the input skeleton has no such joint)")
    if trial:
        scaled_on = f"; scaled on the static trial {_trial_name(trial)} ({scaled} frames with every marker)"
    else:
        scaled_on = f"; scaled on the {scaled} frames with every marker" if scaled is not None and scaled < total else ""
    return (f"OpenSim IK: marker RMS {100 * result['marker_rms_m']:.2f} cm to the lifter's joints over "
            f"{result['frames']} frames (max {100 * result['marker_max_m']:.2f} cm)"
            + (f"; {above} frames above {100 * MAX_GOOD_MARKER_RMS_M:.0f} cm RMS "
               f"({_spans_text(result.get('above_rms_limit_s') or [])}): their angles do not follow the poses"
               if above else "")
            + (f"; {left_out} frames without any marker left out" if left_out else "")
            + (f"; marker{'s' if len(markers) > 1 else ''} {', '.join(markers)} left out{why}" if markers else "")
            + scaled_on
            + f"; {result['frames_per_s']:.1f} frames/s (scaling {result['scale_seconds']:.1f} s)")


#: What the fitted coordinates cannot say: the model's three pelvis markers lie on the hip axis and
#: H36M-17 has no ASIS/PSIS, so the split of trunk-to-thigh flexion between ``pelvis_tilt``, the
#: hips and ``L5_S1_Flex_Ext`` is the model's, not the subject's (docs/joint_angles.md,
#: docs/benchmarks/kinematics.md: their sum agrees with pcnet's thigh-to-thorax angle within
#: 1.1 deg on mocap once each recording's offset is removed).
UNOBSERVED_NOTE = ("pelvis_tilt and L5_S1_Flex_Ext are not observable from joint centres: read hip_flexion "
                   "- L5_S1_Flex_Ext (thigh to thorax) instead of either (docs/benchmarks/kinematics.md)")


#: Two sets of angles side by side: a user trial read ik.mot's hip flexion 11 deg from
#: kinematics.csv's on the boxing demo with nothing in the output saying why.
NOT_ISB_NOTE = ("ik.mot's angles are not kinematics.csv's: they are the scaled model's coordinates, not ISB angles "
                "from joint centres; their pelvis and limb frames differ, and so do the angles: hip flexion by 4-8 deg "
                "on mocap and 11 on the boxing demo (docs/joint_angles.md, 'Pelvic tilt against ASIS/PSIS'): compare "
                "each with itself")


@functools.lru_cache(maxsize=1)
def locked_note() -> str:
    """What ``ik.mot``'s locked columns are: the coordinates :data:`MODEL_FILE` locks at their
    default values (no H36M-17 marker constrains them; all rotational, so degrees in
    ``ik.mot``), read from the model, so that a constant there is not read as a measured
    neutral joint."""
    import xml.etree.ElementTree as ET  # the shipped model file, not user input

    by_value: dict[float, list[str]] = {}
    for c in ET.parse(DATA_DIR / MODEL_FILE).iter("Coordinate"):
        if (c.findtext("locked") or "").strip() == "true":
            by_value.setdefault(round(math.degrees(float(c.findtext("default_value") or 0.0)), 2), []).append(c.get("name"))
    held = "; ".join(f"{', '.join(names)} at {value:g} deg" for value, names in by_value.items())
    return f"ik.mot: locked in the model (H36M-17 has no foot or hand points), not measured: {held}"


#: What an empty cell of ``ik.mot`` does to OpenSim's next tool (an OpenSim trial's inverse
#: dynamics stopped on one NaN with "GCVSpline: there must be 6 or more data points").
DYNAMICS_NEEDS_CELLS = ("OpenSim's inverse dynamics needs every cell (its GCVSpline error names none): fill or cut "
                        "those frames first")


def unobserved_coordinates_note(result: dict) -> str | None:
    """The note on :func:`scale_and_ik`'s ``result["coordinates_unobserved"]``
    (:func:`blank_unobserved`): which ``ik.mot`` columns are empty in how many frames, else
    ``None``."""
    listed = _emptied_columns(result, "coordinates_unobserved")
    return listed and (f"ik.mot: {listed}: no marker beyond the joint was seen there (the solver would carry its last "
                       f"value on, docs/outputs.md); {DYNAMICS_NEEDS_CELLS}")


def gimbal_lock_note(result: dict) -> str | None:
    """The note on :func:`scale_and_ik`'s ``result["coordinates_gimbal_lock"]``
    (:func:`blank_gimbal_lock`), else ``None``."""
    listed = _emptied_columns(result, "coordinates_gimbal_lock")
    return listed and (f"ik.mot: {listed}: the joint's middle angle (arm_add for the shoulder, an arm held out "
                       f"sideways) lay within {GIMBAL_MARGIN_DEG:g} deg of +-90, where the two turn about one axis "
                       f"(gimbal lock, docs/joint_angles.md); {DYNAMICS_NEEDS_CELLS}")


def _emptied_columns(result: dict, key: str) -> str | None:
    """``result[key]``'s ``{coordinate: rows emptied}`` as one clause per count, most first."""
    by_count: dict[int, list[str]] = {}
    for coordinate, n in (result.get(key) or {}).items():
        by_count.setdefault(n, []).append(coordinate)
    return "; ".join(f"{', '.join(names)} empty (NaN) in {n} of {result['frames']} frames"
                     for n, names in sorted(by_count.items(), reverse=True)) or None


def model_mass_note(result: dict) -> str | None:
    """Without the subject's mass, what the scaled model weighs and why it is not the subject's
    (a study trial's `pcnet run --opensim` rows got 85-89 kg models with no word), else ``None``."""
    if result.get("subject_mass_kg") is not None or result.get("model_mass_kg") is None:
        return None
    return (f"the scaled model weighs {result['model_mass_kg']:.1f} kg: the generic model's mass scaled with its "
            f"segments, not the subject's; give --mass before using it for dynamics")


def opensim_notes(result: dict) -> list[str]:
    """The notes of a fit (:func:`scale_and_ik`'s ``result``), for the summary and the report:
    what joint centres cannot observe (:data:`UNOBSERVED_NOTE`), that the columns are not
    kinematics.csv's angles (:data:`NOT_ISB_NOTE`), the columns emptied
    (:func:`unobserved_coordinates_note`, :func:`gimbal_lock_note`), the locked ones
    (:func:`locked_note`) and, without the subject's mass, the model's (:func:`model_mass_note`)."""
    return [UNOBSERVED_NOTE, NOT_ISB_NOTE, *filter(None, [unobserved_coordinates_note(result), gimbal_lock_note(result)]),
            locked_note(), *filter(None, [model_mass_note(result)])]


#: The heading of the section ``pcnet opensim`` adds to the run's report.md (:func:`opensim_markdown`).
REPORT_SECTION = "## OpenSim inverse kinematics (pcnet opensim)"


def _or_none(value, unit: str) -> str:
    return "not given" if value is None else f"{value:g} {unit}"


def _body_mass_index(result: dict) -> str:
    """`` (body-mass index B kg/m^2)`` where the fit had the subject's height and mass, else
    ``""``: a mass typed in pounds reads as a BMI no one has (a clinician's 154 "kg" at 1.72 m:
    52), which the kilograms alone hide."""
    height, mass = result.get("subject_height_m"), result.get("subject_mass_kg")
    return "" if height is None or mass is None else f" (body-mass index {mass / height ** 2:.1f} kg/m^2)"


def _limb_lengths(result: dict) -> str:
    """``thigh 0.412 / 0.398, shank ...`` from ``result["segment_lengths_m"]``."""
    lengths = result.get("segment_lengths_m") or {}
    return ", ".join(f"{name.replace('_', ' ')} {lengths[f'left_{name}']:.3f} / {lengths[f'right_{name}']:.3f}"
                     for name in LIMB_SEGMENTS if f"left_{name}" in lengths and f"right_{name}" in lengths) or "none"


def opensim_markdown(result: dict) -> str:
    """The long form of ``pcnet opensim``'s terminal lines, a section of the run's report.md:
    the fit in full, the marker placer's static window, every warning in full (most severe
    first, with its severity and action) and the outputs."""
    from .flags import opensim_fit_findings, ranked

    w0, w1 = result["static_window_s"]
    lines = [REPORT_SECTION, "", "(Where the notes above hold an OpenSim IK line of `pcnet run --opensim`, this fit "
             "replaced it.)", "", f"- **fit**: {opensim_fit_line(result)}",
             f"- **scaling trial**: {result.get('scale_trial') or 'the recording itself (world.trc)'}",
             f"- **static window** (marker placer, in the scaling trial): {w0:.3f}-{w1:.3f} s",
             f"- **scaled limb lengths** (m, left / right): {_limb_lengths(result)}",
             f"- **subject** (as `pcnet opensim`'s --height and --mass; the markers' scale is `pcnet run "
             f"--height`'s): height {_or_none(result.get('subject_height_m'), 'm')}, mass "
             f"{_or_none(result.get('subject_mass_kg'), 'kg')}{_body_mass_index(result)}; the scaled model weighs "
             f"{_or_none(result.get('model_mass_kg'), 'kg')}", *(f"- **note**: {note}" for note in opensim_notes(result)),
             "",
             "### OpenSim warnings", ""]
    findings = ranked(opensim_fit_findings(result))
    for i, f in enumerate(findings, 1):
        lines += f.report_lines(i, "####")
    lines += [] if findings else ["None.", ""]
    lines += ["### OpenSim outputs", ""] + [f"- {name}" for name in OUTPUTS]
    return "\n".join(lines) + "\n"


def import_opensim():
    """Import ``opensim`` with its log quiet (warnings only) and no ``opensim.log`` in the
    working folder. Raises :class:`InputError` with :data:`MISSING_OPENSIM` when missing."""
    opensim = import_extra("opensim", MISSING_OPENSIM)
    with contextlib.suppress(Exception):
        opensim.Logger.removeFileSink()
        opensim.Logger.setLevelString("warn")
    return opensim


def read_trc(trc_path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, list[str], str]:
    """Read a ``.trc`` as written by :func:`pcnet.stages.sinks.exports.write_trc`.

    Returns:
        ``(times (T,) s, markers (T, M, 3) in the file's units with NaN for empty fields,
        marker names (M,), units)``; the header's frame rate is :func:`trc_data_rate`'s.

    Raises:
        InputError: the file is not a TRC with at least one frame.
    """
    return _read_trc(trc_path)[1:]


def _read_trc(trc_path: str | os.PathLike) -> tuple[dict, np.ndarray, np.ndarray, list[str], str]:
    """:func:`read_trc`'s answer after the header's ``{key: value}`` (strings)."""
    path = Path(trc_path)
    try:
        text = path.read_text()
    except OSError as err:
        raise InputError(f"{path}: cannot read it ({err.strerror or err})") from err
    lines = text.splitlines()
    try:
        keys, values = lines[1].split("\t"), lines[2].split("\t")
        header = dict(zip(keys, values))
        units = header.get("Units", "m").strip()
        names = [n for n in lines[3].split("\t")[2:] if n.strip()]
        rows = []
        for line in lines[5:]:
            if not line.strip():
                continue
            fields = line.split("\t")
            vals = [float(f) if f.strip() else math.nan for f in fields[1:2 + 3 * len(names)]]
            vals += [math.nan] * (1 + 3 * len(names) - len(vals))
            rows.append(vals)
    except (IndexError, ValueError) as err:
        raise InputError(f"{path}: expected an OpenSim .trc marker file (pcnet's world.trc), "
                         f"got unreadable content ({err})") from err
    if not rows or not names:
        raise InputError(f"{path}: expected markers and at least one frame, got none")
    # a file cut short (a copy or a disk that filled) still parses: a bad-input trial's IK ran on
    # its first 41 of 100 frames, the last of them cut mid-number
    declared = header.get("NumFrames", "").strip()
    if declared.isdigit() and int(declared) != len(rows):
        raise InputError(f"{path}: NumFrames: expected as many frame rows as the header's {declared}, got "
                         f"{len(rows)} (a file cut short or edited?)")
    if not text.endswith("\n"):  # a row cut inside its last number parses as a shorter number
        raise InputError(f"{path}: its last frame row: expected a line ending after it, got none (a file cut "
                         f"short?)")
    data = np.asarray(rows, dtype=float)
    return header, data[:, 0], data[:, 1:].reshape(len(rows), len(names), 3), names, units


def trc_data_rate(header: dict, times: np.ndarray) -> float:
    """The frame rate (frames per second) of a ``.trc`` (``header`` its ``{key: value}``,
    :func:`_read_trc`): its ``DataRate``, else (no positive finite value there) the reciprocal
    of the median step of its ``times`` ``(T,)`` s. The header's, because a TRC's times are
    written to a few decimals: a rate worked out from them (30.0003 for 30 fps) moves every
    later frame's time in the files written from it."""
    try:
        rate = float(header["DataRate"])
    except (KeyError, ValueError):
        rate = math.nan
    if math.isfinite(rate) and rate > 0:
        return rate
    return 1.0 / float(np.median(np.diff(times)))


def static_window(times: np.ndarray, markers: np.ndarray, seconds: float = 0.5) -> tuple[float, float]:
    """The static window for the marker placer: among windows of ``seconds`` (at least one
    frame) whose frames have every marker, the one with the least mean marker speed; when no
    frame is complete, the window with the most markers present.

    Args:
        times: ``(T,)`` s, increasing.
        markers: ``(T, M, 3)``, NaN for missing.
        seconds: window length.

    Returns:
        ``(start_s, end_s)`` (inclusive frame times).
    """
    T = len(times)
    dt = float(np.median(np.diff(times))) if T > 1 else 1.0
    n = int(max(1, min(T, round(seconds / dt))))
    present = np.isfinite(markers).all(axis=2).sum(axis=1)  # (T,)
    complete = present == markers.shape[1]
    speed = np.full(T, np.inf)
    if T > 1:
        v = np.linalg.norm(np.diff(markers, axis=0), axis=2) / dt  # (T-1, M)
        s = np.nanmean(np.where(np.isfinite(v), v, np.nan), axis=1) if np.isfinite(v).any() else np.full(T - 1, np.inf)
        speed[1:] = np.where(np.isfinite(s), s, np.inf)
        speed[0] = speed[1]
    else:
        speed[:] = 0.0
    best, best_key = 0, None
    for start in range(T - n + 1):
        sl = slice(start, start + n)
        key = (0 if complete[sl].all() else 1, -int(present[sl].sum()), float(np.mean(speed[sl])))
        if best_key is None or key < best_key:
            best, best_key = start, key
    return float(times[best]), float(times[best + n - 1])


def _array(osim, a: float, b: float):
    arr = osim.ArrayDouble()
    arr.append(float(a))
    arr.append(float(b))
    return arr


@contextlib.contextmanager
def _stdout_to(path: Path):
    """Send the process's stdout (file descriptor 1: OpenSim's C++ log and model summaries)
    to ``path`` for the duration; yields ``path``."""
    import sys

    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(path, "w") as sink:
            os.dup2(sink.fileno(), 1)
            try:
                yield path
            finally:
                os.dup2(saved, 1)
    finally:
        os.close(saved)


def _last_message(log: Path) -> str:
    """The last warning/error line OpenSim wrote, for a one-line error message."""
    with contextlib.suppress(OSError):
        lines = [line.strip() for line in log.read_text().splitlines()
                 if "[error]" in line or "[warning]" in line or "rror" in line]
        if lines:
            return lines[-1][:300]
    return "no message from OpenSim"


def _parse_sto(path: Path) -> tuple[list[str], np.ndarray]:
    """An OpenSim ``.sto`` / ``.mot`` file's column names and ``(N, C)`` float values."""
    table = _MotTable.read(path)
    return table.columns, table.values()


def _tasks_off(tasks, markers: list[str]) -> None:
    """Turn off the IK marker tasks of ``markers`` in an ``IKTaskSet`` (OpenSim's ``apply``)."""
    for name in markers:
        if tasks.contains(name):
            tasks.get(name).setApply(False)


def _leave_markers_out(tool, markers: list[str]) -> list[str]:
    """Leave ``markers`` out of a ScaleTool: their marker placer tasks off, the measurements'
    marker pairs that use them removed, a measurement left without a pair not applied.

    Returns:
        the names of the measurements not applied (their segments keep the generic model's size).
    """
    _tasks_off(tool.getMarkerPlacer().getIKTaskSet(), markers)
    gone = set(markers)
    unscaled = []
    measurements = tool.getModelScaler().getMeasurementSet()
    for m in range(measurements.getSize()):
        measurement = measurements.get(m)
        pairs = measurement.getMarkerPairSet()
        for i in reversed(range(pairs.getSize())):
            if {pairs.get(i).getMarkerName(0), pairs.get(i).getMarkerName(1)} & gone:
                pairs.remove(i)
        if pairs.getSize() == 0 and measurement.getApply():
            measurement.setApply(False)
            unscaled.append(measurement.getName())
    return unscaled


#: Start of the hidden folder :func:`scale_and_ik` works in inside the output folder; the rest
#: of its name is ``<pid>@<host>-<random>``, so that a killed run's leftover can be told from
#: a live run's (:func:`staging_owner`).
STAGING_PREFIX = ".pcnet-opensim-tmp-"


def staging_owner(name: str) -> tuple[int, str] | None:
    """``(pid, host)`` of the process that made a :func:`scale_and_ik` staging folder called
    ``name``, or None when ``name`` is not one."""
    if not name.startswith(STAGING_PREFIX):
        return None
    pid, at, host = name[len(STAGING_PREFIX):].rpartition("-")[0].partition("@")
    return (int(pid), host) if pid.isdigit() and at and host else None


def coordinate_markers(model) -> dict[str, set[str]]:
    """For each unlocked coordinate of an OpenSim ``model`` (``opensim.Model``), the markers on
    the bodies its joint moves: the joint's child body and every body distal to it. A frame with
    none of them present gives inverse kinematics no information on that coordinate (the
    solver carries its last value on), so :func:`blank_unobserved` empties it there.

    Returns:
        ``{coordinate name: {marker names}}`` (the pelvis's free joint: every marker).
    """
    children: dict[str, list[str]] = {}
    joints = []
    for i in range(model.getJointSet().getSize()):
        joint = model.getJointSet().get(i)
        parent, child = (joint.getParentFrame().findBaseFrame().getName(),
                         joint.getChildFrame().findBaseFrame().getName())
        children.setdefault(parent, []).append(child)
        joints.append((joint, child))
    on_body: dict[str, set[str]] = {}
    for i in range(model.getMarkerSet().getSize()):
        marker = model.getMarkerSet().get(i)
        on_body.setdefault(marker.getParentFrame().findBaseFrame().getName(), set()).add(marker.getName())

    def distal(body: str) -> set[str]:
        found = set(on_body.get(body, ()))
        for child in children.get(body, ()):
            found |= distal(child)
        return found

    out = {}
    for joint, child in joints:
        for k in range(joint.numCoordinates()):
            coordinate = joint.get_coordinates(k)
            if not coordinate.get_locked():
                out[coordinate.getName()] = distal(child)
    return out


#: The limb segments whose scaled lengths ``opensim_fit.json`` records: ``name -> (proximal,
#: distal)`` joint-centre markers of the shipped model, per side.
LIMB_SEGMENTS = {"thigh": ("hip", "knee"), "shank": ("knee", "ankle"),
                 "upper_arm": ("shoulder", "elbow"), "forearm": ("elbow", "wrist")}


def segment_lengths(model, state) -> dict[str, float]:
    """Lengths (m) of the scaled model's limb segments (:data:`LIMB_SEGMENTS`), the distance
    between their joint-centre markers in the model's default pose: ``{"left_thigh": ...,
    "right_thigh": ..., ...}``, less a segment whose marker was left out of the run. The
    ScaleTool scales each side on its own marker pairs, so a lifter's leg that is shorter on
    one side is shorter in the model too: these show it. ``state``: the model's initialised
    default state (``model.initSystem()``)."""
    markers = model.getMarkerSet()
    out = {}
    for side in ("left", "right"):
        for name, (a, b) in LIMB_SEGMENTS.items():
            ends = [f"{side}_{j}" for j in (a, b)]
            if all(markers.contains(m) for m in ends):  # a marker left out of the run is not in the model
                pa, pb = (markers.get(m).getLocationInGround(state) for m in ends)
                out[f"{side}_{name}"] = float(np.linalg.norm([pa.get(i) - pb.get(i) for i in range(3)]))
    return out


def blank_unobserved(mot_path: Path, present: np.ndarray, markers: list[str],
                     by_coordinate: dict[str, set[str]]) -> dict[str, int]:
    """Write NaN into ``ik.mot`` where a coordinate's frame had none of its markers
    (:func:`coordinate_markers`): such a value is the solver's carried-on guess, not a
    measurement (a user trial read a smooth 51-110 deg right elbow in 253 frames where the
    right elbow and wrist were never seen). The rest of the file is kept byte for byte.

    Args:
        mot_path: the IK tool's ``.mot`` (header, ``endheader``, a tab-separated column line,
            one row per IK frame).
        present: ``(N, M)`` bool, marker ``m`` present in IK row ``n`` (rows in file order).
        markers: the ``M`` marker names.
        by_coordinate: :func:`coordinate_markers`' map.

    Returns:
        ``{coordinate: rows emptied}`` for each coordinate emptied in at least one row.

    Raises:
        InputError: the file's rows do not match ``present``'s (an IK tool that wrote another
            frame count).
    """
    table = _MotTable.read(mot_path)
    if len(table.rows) != len(present):
        raise InputError(f"{mot_path}: expected {len(present)} inverse-kinematics rows, got {len(table.rows)}")
    index = {name: m for m, name in enumerate(markers)}
    emptied = {}
    for coordinate, its_markers in by_coordinate.items():
        cols = [m for name, m in index.items() if name in its_markers]
        unseen = ~present[:, cols].any(axis=1) if cols else np.ones(len(present), bool)
        if coordinate in table.columns and unseen.any():
            emptied[coordinate] = unseen
    return table.blank(emptied)


def euler_triplets(model) -> list[tuple[str, str, str]]:
    """The coordinates of each joint of an OpenSim ``model`` (``opensim.Model``) that turns
    by three successive rotations about orthogonal axes, one coordinate each (a
    ``CustomJoint``'s ``rotation1-3``: the shipped model's pelvis, hips, L5/S1, neck and
    shoulders, Z then X then Y), as ``(first, middle, third)``. Where the middle angle
    nears +-90 deg the first and third axes line up and the two angles are not separately
    defined (gimbal lock), as for pcnet's own Euler angles (:mod:`pcnet.stages.isb_angles`)."""
    osim = import_opensim()
    triplets = []
    for i in range(model.getJointSet().getSize()):
        joint = osim.CustomJoint.safeDownCast(model.getJointSet().get(i))
        if joint is None:
            continue
        names, axes = [], []
        for k in range(3):
            axis = joint.getSpatialTransform().getTransformAxis(k)
            coordinates = axis.getCoordinateNamesInArray()
            names += [coordinates.get(n) for n in range(coordinates.getSize())]
            axes.append([axis.getAxis().get(n) for n in range(3)])
        if len(names) == len(set(names)) == 3 and np.allclose(np.abs(np.asarray(axes) @ np.transpose(axes)), np.eye(3)):
            triplets.append(tuple(names))
    return triplets


def blank_gimbal_lock(mot_path: Path, triplets: list[tuple[str, str, str]],
                      margin_deg: float = GIMBAL_MARGIN_DEG) -> dict[str, int]:
    """Write NaN into ``ik.mot``'s first and third angle of each of :func:`euler_triplets`
    in the rows where its middle angle lies within ``margin_deg`` of +-90 deg: there the two
    turn about one axis, so the solver's split between them is arbitrary (an OpenSim trial's
    T-pose read ``arm_flex`` and ``arm_rot`` 86-113 deg apart between four cameras of one
    standing subject). pcnet's own angles are NaN there too (``isb_angles.GIMBAL_MARGIN_DEG``).

    Args:
        mot_path: the IK tool's ``.mot`` (rotations in degrees, or radians where its header
            says ``inDegrees=no``).
        triplets: ``(first, middle, third)`` coordinate names.
        margin_deg: half-width (deg) of the band about +-90 deg.

    Returns:
        ``{coordinate: rows emptied}`` for each coordinate emptied in at least one row.
    """
    table = _MotTable.read(mot_path)
    values = table.values() if table.in_degrees else np.degrees(table.values())  # only rotations are read below
    emptied: dict[str, np.ndarray] = {}
    for first, middle, third in triplets:
        if middle not in table.columns:
            continue
        with np.errstate(invalid="ignore"):  # NaN (not observed): not locked
            locked = np.abs(np.abs(values[:, table.columns.index(middle)]) - 90.0) < margin_deg
        for name in (first, third):
            if name in table.columns and locked.any():
                emptied[name] = emptied.get(name, np.zeros(len(locked), bool)) | locked
    return table.blank(emptied)


class _MotTable:
    """An OpenSim ``.sto`` / ``.mot`` file's lines, column names and data rows, read by
    :meth:`values` and rewritten in place by :meth:`blank` (every other byte kept)."""

    def __init__(self, path: Path, lines: list[str], end: int):
        self.path, self.lines = path, lines
        self.columns = [c.strip() for c in lines[end + 1].split("\t")]
        self.rows = [i for i in range(end + 2, len(lines)) if lines[i].strip()]
        self.in_degrees = not any(line.replace(" ", "").lower() == "indegrees=no" for line in lines[:end])

    @classmethod
    def read(cls, path: Path) -> "_MotTable":
        lines = Path(path).read_text().splitlines()
        return cls(Path(path), lines, next(i for i, line in enumerate(lines) if line.strip() == "endheader"))

    def values(self) -> np.ndarray:
        """``(N, C)`` float64, the data rows as written (NaN where empty)."""
        rows = [[float(x) for x in self.lines[i].split("\t")] for i in self.rows]
        return np.asarray(rows, dtype=float).reshape(-1, len(self.columns))

    def blank(self, emptied: dict[str, np.ndarray]) -> dict[str, int]:
        """NaN in the ``(N,)`` True rows of each named column; the file rewritten atomically
        where anything changed. Returns ``{name: rows emptied}``."""
        for name, rows in emptied.items():
            column = self.columns.index(name)
            for row in np.flatnonzero(rows):
                values = self.lines[self.rows[row]].split("\t")
                values[column] = "NaN"
                self.lines[self.rows[row]] = "\t".join(values)
        if emptied:
            write_text(self.path, "\n".join(self.lines) + "\n")
        return {name: int(rows.sum()) for name, rows in emptied.items()}


def _read_h36m_trc(path: Path, use: str) -> tuple[dict, np.ndarray, np.ndarray, str]:
    """``(header, times (T,), joints (T, 17, 3) in H36M-17 order, units)`` of a marker file
    with the H36M-17 joint markers, for ``use`` (named in the errors).

    Raises:
        InputError: unreadable, a joint marker missing, fewer than 2 frames, units not m or mm.
    """
    header, times, markers, names, units = _read_trc(path)
    missing = [j for j in H36M_JOINTS if j not in names]
    if missing:
        raise InputError(f"{path}: expected the H36M-17 joint markers, got none named {', '.join(missing)}")
    if len(times) < 2:
        raise InputError(f"{path}: expected at least 2 frames for {use}, got {len(times)}")
    if units not in ("m", "mm"):
        raise InputError(f"{path}: expected Units m or mm, got {units!r}")
    return header, times, markers[:, [names.index(j) for j in H36M_JOINTS]], units


def scale_and_ik(
    trc_path: str | os.PathLike,
    out_dir: str | os.PathLike,
    height_m: float | None,
    mass_kg: float | None = None,
    *,
    static_trc: str | os.PathLike | None = None,
    static_seconds: float = 0.5,
    overwrite: bool = False,
) -> dict:
    """Scale the shipped model to the subject of ``trc_path`` (or of a separate static trial,
    ``static_trc``) and solve inverse kinematics on ``trc_path``.

    1. ScaleTool (opensim-core): measurement-based scale factors from marker-pair distances
       averaged over the scaling trial's frames with every marker (``Scaling_Setup_H36M17.xml``;
       the scaling trial is ``static_trc`` where given, as in OpenSim's own workflow of a
       standing trial, else the recording itself), then the marker placer on that trial's
       :func:`static_window` (``static_seconds``) moves the four trunk/head markers that have
       no joint in the model. ``mass_kg`` sets the total mass with the
       generic model's mass distribution; without it the segment masses scale with the
       segments. ``height_m`` is recorded in ``opensim_fit.json`` and given to the ScaleTool,
       which does not scale by it: pcnet's TRC is already scaled by ``pcnet run --height``.
    2. InverseKinematicsTool over every frame of the TRC with at least one marker (weights in
       ``IK_Setup_H36M17.xml``; missing markers are skipped in their frames; a frame with
       none, a lost track, has no row in ``ik.mot``: OpenSim's solver cannot assemble it).

    Writes into ``out_dir`` (which must exist): ``scaled_model.osim``, ``ik.mot`` (generalised
    coordinates per frame; rotations in degrees, pelvis translations in metres, ground frame =
    the TRC's frame), ``ik_marker_errors.sto`` (OpenSim's per-frame
    ``total_squared_error``, ``marker_error_RMS``, ``marker_error_max`` in metres), the two
    tools' setups as they ran with their marker files (``scale_setup.xml`` on
    ``scale_markers.trc``, the complete frames; ``ik_setup.xml`` on ``ik_markers.trc``, the
    frames with a marker; file names relative to the folder, the generic model's absolute in
    the installed package) and ``opensim_fit.json`` (the returned fit: marker errors, frames,
    static window and :func:`ik_fit_flags`' ``warnings``). The tools run in a hidden temporary folder inside
    ``out_dir``; the files are renamed into place only when both tools succeeded, and only that
    temporary folder is ever deleted.

    Args:
        trc_path: an OpenSim marker file with the H36M-17 joint centres (pcnet's
            ``world.trc``: ``(T, 17, 3)`` markers, metres, Y up, X forward, Z right).
        out_dir: existing destination folder.
        static_trc: the scaling trial, a marker file like ``trc_path`` of the same subject
            in the same units (e.g. another ``pcnet run``'s ``world.trc`` of the subject
            standing still), or ``None`` to scale on ``trc_path``. A marker that either trial
            has in no frame is left out of both.
        height_m: the subject's height in metres (recorded), or ``None``.
        mass_kg: the subject's mass in kg, or ``None``.
        static_seconds: length of the marker placer's static window in seconds.
        overwrite: replace existing output files of these names (else refuse).

    Returns:
        ``{"marker_rms_m"`` (RMS over all frames and markers), ``"marker_max_m"`` (largest
        single marker error), ``"marker_rms_median_frame_m"``, ``"frames_above_rms_limit"`` and
        ``"above_rms_limit_s"`` (IK rows whose RMS marker error passes
        :data:`MAX_GOOD_MARKER_RMS_M`, and their time spans), ``"model_mass_kg"`` (the scaled
        model's total mass), ``"segment_lengths_m"`` (:func:`segment_lengths`), ``"frames"``
        (IK rows), ``"frames_without_markers"`` (left out), ``"scale_trial"`` (``static_trc``'s
        path, or ``None``), ``"scale_frames"``, ``"static_window_s"`` (in the scaling trial's
        time), ``"warnings"``, ``"seconds"`` (IK wall time), ``"frames_per_s"``,
        ``"scale_seconds"``, ``"outputs"`` (paths)``}``.

    Raises:
        InputError: opensim is missing, a TRC is unreadable or lacks H36M-17 markers, the
            static trial's units differ from the recording's, the outputs exist without
            ``overwrite``, or a tool failed.
    """
    osim = import_opensim()
    trc = Path(trc_path).resolve()
    out = Path(out_dir).resolve()
    if not out.is_dir():
        raise InputError(f"{out_dir}: expected an existing output folder, got none")
    if height_m is not None and not (HEIGHT_RANGE_M[0] <= float(height_m) <= HEIGHT_RANGE_M[1]):
        raise InputError(f"--height: expected the subject's height in metres ({HEIGHT_RANGE_M[0]:g} to "
                         f"{HEIGHT_RANGE_M[1]:g}), got {height_m}")
    if mass_kg is not None and not (MASS_RANGE_KG[0] <= float(mass_kg) <= MASS_RANGE_KG[1]):
        raise InputError(f"--mass: expected the subject's mass in kg ({MASS_RANGE_KG[0]:g} to {MASS_RANGE_KG[1]:g}), "
                         f"got {mass_kg}")
    header, times, joints, units = _read_h36m_trc(trc, "scaling and IK")
    fps = trc_data_rate(header, times)
    if static_trc is None:
        scale_source, s_times, s_joints, s_fps = trc, times, joints, fps
    else:
        scale_source = Path(static_trc).resolve()
        s_header, s_times, s_joints, s_units = _read_h36m_trc(scale_source, "scaling")
        if s_units != units:
            raise InputError(f"{scale_source}: Units: expected the recording's {units!r} ({trc}), got {s_units!r}")
        s_fps = trc_data_rate(s_header, s_times)
    existing = [name for name in OUTPUTS if (out / name).exists()]
    if existing and not overwrite:
        raise InputError(f"{out_dir}: expected no earlier OpenSim outputs, got {', '.join(existing)}; "
                         f"pass --overwrite to replace them")

    data = DATA_DIR
    start_s = float(times[0])
    # A marker missing in every frame (a Kinect v1 has no nose: neck_nose is empty throughout)
    # is left out of the run: out of the marker files, its IK tasks off, its marker pairs gone.
    seen = seen_joints(joints) & seen_joints(s_joints)  # (17,)
    left_out = [j for j, ok in zip(H36M_JOINTS, seen) if not ok]
    used = [j for j, ok in zip(H36M_JOINTS, seen) if ok]
    joints, s_joints = joints[:, seen], s_joints[:, seen]  # (T, M, 3)
    complete = np.isfinite(s_joints).all(axis=(1, 2))
    if not complete.any():
        raise InputError(f"{scale_source}: expected at least one frame with all {len(used)} joint markers the "
                         f"recording has for scaling, got none"
                         + (f" ({', '.join(left_out)} in no frame, left out)" if left_out else ""))
    # OpenSim's IK cannot assemble a frame without a single marker (non-finite marker values
    # make its solver throw): such frames (a lost track) are left out of its marker file.
    marked = np.isfinite(joints).any(axis=(1, 2))
    tmp = out / f"{STAGING_PREFIX}{os.getpid()}@{socket.gethostname()}-{uuid.uuid4().hex[:12]}"
    try:
        tmp.mkdir()
        # The ScaleTool averages marker-pair distances (and the placer marker positions) over
        # its time range and a single missing marker spoils a measurement: scale on the
        # complete frames only (their own copy, times renumbered).
        from .sinks.exports import finite_or_null, write_trc

        write_trc(tmp / "scale_markers.trc", s_joints[complete], s_fps, used, units, check_up=False)
        c_times = np.arange(int(complete.sum())) / s_fps
        c0, c1 = static_window(c_times, s_joints[complete], static_seconds)
        kept = np.flatnonzero(complete)
        w0 = float(s_times[kept[round(c0 * s_fps)]])
        w1 = float(s_times[kept[round(c1 * s_fps)]])
        # --- scaling -------------------------------------------------------------------
        t_scale = time.perf_counter()
        # The setups name their files relative to the output folder, so that they re-run in
        # OpenSim beside their outputs; the ScaleTool runs from its written setup (it reads
        # relative names against the setup's folder), so that the file is what ran.
        tool = osim.ScaleTool(str(data / SCALE_SETUP))
        tool.setPathToSubject("")
        tool.setSubjectMass(float(mass_kg) if mass_kg is not None else -1.0)
        tool.setSubjectHeight(float(height_m) * 1000.0 if height_m is not None else -1.0)
        gmm = tool.getGenericModelMaker()
        gmm.setModelFileName(str(data / MODEL_FILE))
        gmm.setMarkerSetFileName(str(data / MARKER_FILE))
        scaler = tool.getModelScaler()
        scaler.setMarkerFileName("scale_markers.trc")
        scaler.setTimeRange(_array(osim, float(c_times[0]), float(c_times[-1])))
        scaler.setPreserveMassDist(mass_kg is not None)
        scaler.setOutputModelFileName("")
        scaler.setOutputScaleFileName("")
        placer = tool.getMarkerPlacer()
        placer.setMarkerFileName("scale_markers.trc")
        placer.setTimeRange(_array(osim, c0, c1))
        placer.setOutputModelFileName("scaled_model.osim")
        placer.setOutputMotionFileName("")
        placer.setMaxMarkerMovement(-1.0)
        unscaled = _leave_markers_out(tool, left_out)
        tool.printToXML(str(tmp / "scale_setup.xml"))
        tool = osim.ScaleTool(str(tmp / "scale_setup.xml"))
        with _stdout_to(tmp / "opensim_scale.log") as log:
            try:
                ok = tool.run()
            except RuntimeError:
                ok = False
        unused = [line.strip() for line in log.read_text().splitlines() if "not used to scale" in line]
        if not ok or not (tmp / "scaled_model.osim").is_file() or unused:
            raise InputError(f"{scale_source}: OpenSim scaling failed ({_last_message(log)})")
        scale_seconds = time.perf_counter() - t_scale

        # --- inverse kinematics ----------------------------------------------------------
        write_trc(tmp / "ik_markers.trc", joints[marked], fps, used, units,
                  frames=np.flatnonzero(marked) + int(round(start_s * fps)), check_up=False)
        ik = osim.InverseKinematicsTool(str(data / IK_SETUP))
        _tasks_off(ik.getIKTaskSet(), left_out)
        ik.set_model_file("scaled_model.osim")
        ik.set_marker_file("ik_markers.trc")
        ik.setStartTime(float(times[marked][0]))
        ik.setEndTime(float(times[marked][-1]))
        ik.setResultsDir(".")
        ik.setOutputMotionFileName("ik.mot")
        ik.set_report_errors(True)
        ik.printToXML(str(tmp / "ik_setup.xml"))
        # The InverseKinematicsTool reads relative names against the working folder (a re-run
        # starts in the output folder): this run gives it absolute ones instead of changing
        # this process's folder.
        model = osim.Model(str(tmp / "scaled_model.osim"))
        ik.setModel(model)
        ik.set_marker_file(str(tmp / "ik_markers.trc"))
        ik.setResultsDir(str(tmp))
        ik.setOutputMotionFileName(str(tmp / "ik.mot"))
        t_ik = time.perf_counter()
        with _stdout_to(tmp / "opensim_ik.log") as log:
            try:
                ok = ik.run()
            except RuntimeError:  # the binding raises where the C++ tool would return false
                ok = False
        ik_seconds = time.perf_counter() - t_ik
        errors = sorted(tmp.glob("*_ik_marker_errors.sto"))
        if not ok or not (tmp / "ik.mot").is_file() or not errors:
            raise InputError(f"{trc}: OpenSim inverse kinematics failed ({_last_message(log)})")
        os.replace(errors[0], tmp / "ik_marker_errors.sto")
        unobserved = blank_unobserved(tmp / "ik.mot", np.isfinite(joints[marked]).all(axis=2), used,
                                      coordinate_markers(model))
        gimbal_lock = blank_gimbal_lock(tmp / "ik.mot", euler_triplets(model))

        cols, err = _parse_sto(tmp / "ik_marker_errors.sto")
        rms = err[:, cols.index("marker_error_RMS")]
        mx = err[:, cols.index("marker_error_max")]
        above = rms > MAX_GOOD_MARKER_RMS_M
        state = model.initSystem()
        result = {
            "marker_rms_m": float(np.sqrt(np.mean(rms ** 2))),
            "marker_max_m": float(np.max(mx)),
            "marker_rms_median_frame_m": float(np.median(rms)),
            "frames_above_rms_limit": int(above.sum()),
            "above_rms_limit_s": time_spans(err[:, cols.index("time")], above),
            "model_mass_kg": float(model.getTotalMass(state)),
            "frames": len(rms),
            "frames_without_markers": int((~marked).sum()),
            "scale_trial": None if static_trc is None else str(scale_source),
            "scale_frames": int(complete.sum()),
            "markers_left_out": left_out,
            "coordinates_unobserved": unobserved,
            "coordinates_gimbal_lock": gimbal_lock,
            "segments_not_scaled": unscaled,
            "segment_lengths_m": segment_lengths(model, state),
            "static_window_s": (w0, w1),
            "subject_height_m": None if height_m is None else float(height_m),
            "subject_mass_kg": None if mass_kg is None else float(mass_kg),
        }
        result["warnings"] = ik_fit_flags(result)
        write_text(tmp / OUTPUTS[-1], json.dumps(finite_or_null(result), indent=1) + "\n")
        for name in OUTPUTS:
            os.replace(tmp / name, out / name)
    except (OSError, InputError) as err:
        refusal = writing_failed(err, tmp, str(out_dir))
        if refusal is None:
            raise
        raise refusal from err
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {
        **result,
        "seconds": float(ik_seconds),
        "frames_per_s": float(result["frames"] / ik_seconds) if ik_seconds > 0 else math.inf,
        "scale_seconds": float(scale_seconds),
        "outputs": {name: str(out / name) for name in OUTPUTS},
    }
