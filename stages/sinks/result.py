"""One recording's result, the object every output sink reads, and the sinks as functions of it.

The runner (``pcnet run``, :mod:`pcnet.pipeline.runner`) fills a :class:`RecordingResult` and
calls the sinks in order; each writes its files into a folder (the run's staged folder) and
returns ``{output name: path}``. The file formats themselves are the array-level writers of
:mod:`.exports`, :mod:`.bvh`, :mod:`.plots` and :mod:`.rerun_log` (docs/outputs.md).

Frames and units: ``joints_camera`` root-relative OpenCV camera frame; ``canonical`` per-frame
canonical frame (docs/CONVENTIONS.md); ``poses`` the frame the kinematics live in
(``kinematics_frame``: ``"world"``, one gravity-aligned frame per recording, or
``"canonical"``); lengths in ``units``; rotations ``(T, 3, 3)`` canonical->camera.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from ..core.canonical import to_canonical
from ..core.conventions import H36M_JOINTS
from ..core.rotations import decompose_camera_rotation
from ..core.framestore import column, frame_blocks, in_memory, per_frame, present_frames, seen_joints
from ..flags import one_person_frames, track_present
from ..kinematics import FrameGatherer, count_flags, frames_phrase
from ..rectification_report import RectificationReport
from ..remap import outside_image
from .bvh import write_bvh
from .exports import blank_unobservable, plot_wrists, write_c3d, write_kinematics_csv, write_npz, write_trc
from .plots import SPEED_GROUPS, plot_joint_angles, plot_joint_speeds
from .rerun_log import series_from_kinematics, write_recording

WRISTS = ("left_wrist", "right_wrist")
#: Joints whose filtered kinematics stay in memory after the CSV is written (plots, recording).
KEPT_JOINTS = tuple(dict.fromkeys(WRISTS + sum(SPEED_GROUPS.values(), ())))
FRAME_LABELS = {"world": "world frame (x forward at the start, y up, z right; floor y = 0)",
                "canonical": "canonical frame (x anterior, y up, z right)"}


@dataclass
class RecordingResult:
    """Everything the sinks write for one recording of ``T`` frames.

    Filled in two steps: the arrays before the kinematics table, then the kept kinematics
    (``kinematics``, ``missing``, ``unfiltered``, ``flag_counts``), which
    :func:`write_kinematics_table` fills while it streams ``kinematics_blocks``.

    Attributes:
        fps: frame rate, Hz. units: length unit of every position (``"m"`` for metric runs).
        method: rectification method name. rectification: what rectification decided
            (:class:`~pcnet.stages.rectification_report.RectificationReport`). root_path: where a
            world frame's pelvis path came from (``"measured"``, ``"from 2D keypoints"``, ``"not
            observable"``), ``None`` without a world frame. floor_kind: the world frame's floor
            (:class:`~pcnet.stages.floor.Floor` ``kind``: ``"plane"``, ``"per frame"``,
            ``"pelvis"``), ``None`` without a world frame. report: the run's report record
            (docs/outputs.md; JSON-able after :func:`jsonable`), which the pipeline sets before
            :func:`write_arrays`. flags: ``WARNING`` texts. notes: run notes; sinks
            append theirs (e.g. frames BVH interpolated).
        joints_camera: ``(T, 17, 3)`` float root-relative camera-frame poses.
        rotation: ``(T, 3, 3)`` canonical->camera; canonical ``(T, 17, 3)``; valid ``(T,)`` bool.
        kinematics_frame: ``"world"`` or ``"canonical"``; poses ``(T, 17, 3)`` in it.
        world: ``(T, 17, 3)`` world-frame poses or ``None``; world_rotation ``(3, 3)``
            (NaN without a world frame).
        keypoints2d: ``(T, 17, 3)`` px + confidence or ``None``; track_segment ``(T,)`` int or
            ``None``; video: the video path or ``None``; video_keypoints2d: the same keypoints in
            the pixels the recording shows the video in (a phone video is shown as stored), or
            ``None`` for ``keypoints2d``; keypoint_picture: ``(width, height)`` of the picture
            ``keypoints2d`` are in, or ``None`` where not known; video_first_frame: the stored
            frame that pose frame 0 shows (0 unless an MP4 edit list starts playback later);
            min_confidence: 2D threshold.
        wrist_acceleration_camera: ``(T, 2, 3)`` filtered camera-frame wrist accelerations.
        kinematics_blocks: iterable of :class:`pcnet.stages.kinematics.Kinematics` blocks in
            frame order, consumed once by :func:`write_kinematics_table`.
        kinematics: :data:`KEPT_JOINTS`' kinematics, float32 (after the table); missing, unfiltered
            ``(T, 17)`` bool; flag_counts: :func:`pcnet.stages.kinematics.count_flags`.
        implausible_frames: ``(T,)`` bool, frames where a joint's pelvis-relative speed or
            acceleration exceeds the training motion's fastest
            (:func:`pcnet.stages.plausibility.implausible_frames`), or ``None`` when the motion
            was not checked (non-metric poses); written to the npz, shaded in the angle and
            speed plots, logged in the recording.
        pelvis_path_std: ``(T, 3)`` float64 1-sigma (the poses' units) of a pelvis path
            recovered from the 2D keypoints along the world axes X, Y, Z (depth is the weak
            axis), or ``None`` for a measured or unobservable path; written to the npz.
        empty_angles: angle name -> why the run leaves that column empty (the data dictionary
            says it).
    """

    fps: float
    units: str
    method: str
    rectification: RectificationReport
    flags: list[str]
    notes: list[str]
    joints_camera: np.ndarray
    rotation: np.ndarray
    canonical: np.ndarray
    valid: np.ndarray
    kinematics_frame: str
    poses: np.ndarray
    world: np.ndarray | None
    world_rotation: np.ndarray
    keypoints2d: np.ndarray | None = None
    track_segment: np.ndarray | None = None
    video: str | None = None
    video_keypoints2d: np.ndarray | None = None
    keypoint_picture: tuple[int, int] | None = None
    video_first_frame: int = 0
    min_confidence: float = 0.0
    wrist_acceleration_camera: np.ndarray | None = None
    subject_height_m: float = float("nan")
    kinematics_blocks: Iterable = ()
    kinematics: object = None
    missing: np.ndarray | None = None
    unfiltered: np.ndarray | None = None
    flag_counts: dict = field(default_factory=dict)
    implausible_frames: np.ndarray | None = None
    pelvis_path_std: np.ndarray | None = None
    empty_angles: dict = field(default_factory=dict)
    root_path: str | None = None
    floor_kind: str | None = None
    report: dict = field(default_factory=dict)

    @cached_property
    def unplaced(self) -> np.ndarray | None:
        """:func:`unplaced_frames` of this run, read once (the table and the marker files both
        need it, and it reads every frame's joints)."""
        return unplaced_frames(self)

    @cached_property
    def heading_deg(self) -> np.ndarray:
        """``(T,)`` camera heading of each frame's rotation, degrees
        (:func:`pcnet.stages.core.rotations.decompose_camera_rotation`)."""
        return per_frame(lambda R: np.degrees(decompose_camera_rotation(R)[0]), self.rotation)

    @property
    def frame_label(self) -> str:
        return FRAME_LABELS[self.kinematics_frame]


def jsonable(report: dict) -> dict:
    """The report without per-frame arrays (arrays of up to 3 values kept as lists), numpy
    scalars as Python numbers, nested dicts alike."""
    clean = {}
    for k, v in report.items():
        if isinstance(v, np.ndarray):
            if v.ndim == 0 or v.size <= 3:
                clean[k] = v.tolist()
        elif isinstance(v, (np.floating, np.integer)):
            clean[k] = v.item()
        elif isinstance(v, dict):
            clean[k] = jsonable(v)
        else:
            clean[k] = v
    return clean


#: ``kinematics.csv``'s columns beyond the kinematics: ``(unit, frame, definition)`` for its data dictionary.
EXTRA_COLUMNS = {
    "valid": ("0/1", "none", "1 where the frame was rectified (hips, thorax and shoulders present), else 0."),
    "heading_deg": ("deg", "camera", "The subject's heading in the camera's view from the frame's rotation: 0 = facing "
                                     "the camera, + counter-clockwise seen from above (empty where not valid)."),
    "track_segment": ("-", "none", "The stretch of the 2D track between jumps to another place (stages/flags.py: "
                                   "track_segments); frames outside the longest stretch are probably another person "
                                   "(empty where the 2D keypoints have no pelvis or thorax)."),
    "implausible_motion": ("0/1", "none", "1 where a joint moves faster or accelerates harder than in any training "
                                          "motion (the implausible-motion warning's frames; canonical.npz "
                                          "implausible_frames), else 0 (empty where not valid)."),
}


def unobservable_paths(r: RecordingResult) -> dict[str, tuple[str, str]]:
    """The pelvis axes the run's input does not observe, with why (``kinematics.csv`` leaves
    them empty, :func:`.exports.kinematics_columns`): the horizontal path in a world frame from
    a root-relative lifter; all three in the canonical frame, whose origin it is."""
    if r.kinematics_frame == "canonical":
        return {"pelvis": ("xyz", "the canonical frame is centred on the pelvis, whose position and motion in it "
                                  "are 0 by construction, not measured")}
    if r.root_path in (None, "not observable"):
        why = ("from a root-relative lifter" if r.units == "m" else
               f"from poses in {r.units}, not metres (a path is recovered from 2D keypoints for metric poses: --height)")
        return {"pelvis": ("xz", f"the pelvis's horizontal path is not observable {why} (the world frame holds it at "
                                 f"x = z = 0), so neither is its horizontal motion or speed")}
    return {}


def absent_joints(r: RecordingResult) -> dict[str, tuple[str, str]]:
    """The joints missing in every frame of the input (Kinect v1's skeleton has no nose), as
    :func:`unobservable_paths` gives the unobserved axes: their columns' definitions say so (a
    trial found the generic text beside columns empty throughout)."""
    return {H36M_JOINTS[j]: ("xyz", "the input's skeleton has no such joint (missing in every frame)")
            for j in np.flatnonzero(~seen_joints(r.joints_camera))}


def unplaced_frames(r: RecordingResult) -> np.ndarray | None:
    """``(T,)`` bool: the frames with a pose whose pelvis path from 2D keypoints has no fit
    (``pelvis_path_std`` NaN): the world frame holds them at their stretch's first or last
    fitted position (:func:`pcnet.pipeline.pelvis_path.pelvis_path`), so their positions and
    motion are not the body's (a trial's pelvis stayed 0.66 m up through a backflip);
    ``None`` without such a path."""
    if r.root_path != "from 2D keypoints" or r.pelvis_path_std is None or r.world is None:
        return None
    return ~np.isfinite(r.pelvis_path_std).all(axis=1) & present_frames(r.joints_camera)


def write_kinematics_table(r: RecordingResult, folder: Path, allocate=None) -> dict[str, Path]:
    """``kinematics.csv`` (:func:`.exports.write_kinematics_csv`, with the ``valid``,
    ``heading_deg``, ``track_segment`` and ``implausible_motion`` columns, the last two empty
    without 2D input or where the motion was not checked) from ``r.kinematics_blocks``, consumed once,
    and its data dictionary ``kinematics_columns.csv`` (from the same column list; the
    :func:`unobservable_paths` empty in both); fills
    ``r.kinematics`` (:data:`KEPT_JOINTS` only, float32: what a long recording keeps for the
    plots and the recording; in arrays from ``allocate``, :class:`~pcnet.stages.kinematics.FrameGatherer`),
    ``r.missing``, ``r.unfiltered`` and ``r.flag_counts``."""
    T = len(r.joints_camera)
    kept = FrameGatherer(T, KEPT_JOINTS, np.float32, allocate)
    missing, unfiltered = np.zeros((T, 17), bool), np.zeros((T, 17), bool)
    unobservable = {**absent_joints(r), **unobservable_paths(r)}
    unplaced = r.unplaced if r.unplaced is not None and r.unplaced.any() else None

    def keeping(blocks):
        for k in blocks:
            rows = slice(kept.filled, kept.filled + k.num_frames)
            # the plots and the recording show what the CSV has
            k = blank_unobservable(k, unobservable, None if unplaced is None else unplaced[rows])
            kept.add(k)
            missing[rows], unfiltered[rows] = k.missing, k.unfiltered
            yield k

    frames = np.arange(T)
    path, dictionary = folder / "kinematics.csv", folder / "kinematics_columns.csv"
    extra = {"valid": r.valid.astype(int), "heading_deg": r.heading_deg}
    definitions = dict(EXTRA_COLUMNS)
    # Empty, never 0, where there is nothing to say (a user trial's frames with no person passed
    # the track-switch warning's own filter as "track_segment 0, implausible_motion 0"); the same
    # columns whatever the input (an estimator-swapping trial's code met columns that came and went).
    nothing = np.full(T, np.nan)
    for name, values, why in (
            # which person the 2D track followed, as the track-switch flag names it
            ("track_segment", None if r.track_segment is None else _track_segment(r), "no 2D keypoints, no 2D track"),
            # the frames the implausible-motion warning asks to leave out
            ("implausible_motion", None if r.implausible_frames is None else np.where(r.valid, _implausible(r), np.nan),
             "the motion was not checked (the run's notes say why)")):
        extra[name] = nothing if values is None else values
        if values is None:
            unit, of, text = EXTRA_COLUMNS[name]
            definitions[name] = (unit, of, f"{text.rstrip('.')}; empty in this run: {why}.")
    write_kinematics_csv(path, frames, frames / r.fps, keeping(r.kinematics_blocks), extra_columns=extra,
                         dictionary=dictionary, extra_definitions=definitions, frame=r.kinematics_frame,
                         unobservable=unobservable, empty_angles=r.empty_angles,
                         floor=r.floor_kind if r.kinematics_frame == "world" else None,
                         up_uncertainty=up_uncertainty(r.rectification),
                         unplaced=None if unplaced is None else
                         f"the {frames_phrase(int(unplaced.sum()))} with a pose but no fitted pelvis path (held at its "
                         f"first or last fitted position in the world frame, so their place is not known; the angles "
                         f"are kept)")
    r.kinematics = kept.result()
    r.missing, r.unfiltered = missing, unfiltered
    r.flag_counts = count_flags(r.missing, r.unfiltered)
    return {"kinematics.csv": path, "kinematics_columns.csv": dictionary}


def up_uncertainty(report: RectificationReport) -> str | None:
    """How uncertain a run's up is, as a clause for the columns measured against it: sequence
    mode's camera pitch and roll intervals (the summary's, or for a standing trial's given up,
    ``--camera-up-from``, that trial's), else each frame's tilt bound
    (``canonical.npz``); ``None`` where the run has neither (a method without them)."""
    seq = report.sequence
    if seq is not None:
        if not (np.isfinite(seq.camera_pitch_interval_deg) and np.isfinite(seq.camera_roll_interval_deg)):
            return None
        # An error along a unit mix of the two axes (the subject's sagittal or frontal plane
        # at any heading) has a 95 % half-width no larger than the larger axis's.
        widest = max(seq.camera_pitch_interval_deg, seq.camera_roll_interval_deg)
        whose = "the standing trial's interval, --camera-up-from" if seq.given_from_run else "the summary's interval"
        return (f"uncertain by +-{seq.camera_pitch_interval_deg:.1f} deg in the camera's pitch and "
                f"+-{seq.camera_roll_interval_deg:.1f} deg in its roll ({whose}), so by at most "
                f"+-{widest:.1f} deg in the subject's sagittal or frontal plane at any heading, an error these angles "
                f"carry on top of the lifter's own and of a lean held for the whole recording (docs/guide/limits.md)")
    if np.isfinite(report.frame_tilt_bound_deg).any():
        return ("uncertain per frame by canonical.npz's frame_tilt_bound_deg, an error these angles carry on top of "
                "the lifter's own (docs/guide/limits.md)")
    return None


def write_arrays(r: RecordingResult, folder: Path) -> dict[str, Path]:
    """``canonical.npz`` (:func:`.exports.write_npz`; keys in docs/outputs.md); ``implausible_frames``
    ``(T,)`` bool (empty when the motion was not checked: non-metric poses);
    ``pelvis_path_std_world`` ``(T, 3)`` (empty unless the path was recovered from 2D keypoints)."""
    path = folder / "canonical.npz"
    empty = np.zeros(0)
    write_npz(
        path, rotation=r.rotation, canonical=r.canonical, joints_camera=r.joints_camera,
        up=r.rotation[:, :, 1], valid=r.valid, heading_deg=r.heading_deg, fps=r.fps, units=r.units,
        method=r.method, mode=r.rectification.mode.run, heading_source=r.rectification.heading.source,
        joint_names=np.array(H36M_JOINTS),
        keypoints2d=r.keypoints2d if r.keypoints2d is not None else np.zeros((0, 17, 3), np.float32),
        missing=r.missing, unfiltered=r.unfiltered, flag_counts=r.flag_counts,
        flags=np.array(r.flags, dtype=str), notes=np.array(r.notes, dtype=str),
        track_segment=_track_segment(r) if r.track_segment is not None else np.zeros(0),
        report=jsonable(r.report),
        camera_frame_weight=empty if r.rectification.camera_frame_weight is None else r.rectification.camera_frame_weight,
        frame_tilt_bound_deg=r.rectification.frame_tilt_bound_deg,
        joints_world=r.world if r.world is not None else np.zeros((0, 17, 3)), world_rotation=r.world_rotation,
        implausible_frames=_implausible(r) if r.implausible_frames is not None else np.zeros(0, bool),
        pelvis_path_std_world=r.pelvis_path_std if r.pelvis_path_std is not None else np.zeros((0, 3)),
        subject_height_m=np.float64(r.subject_height_m),
    )
    return {"canonical.npz": path}


def _track_segment(r: RecordingResult) -> np.ndarray:
    """``(T,)`` the 2D track's person segment, NaN where no person is tracked (never 0 there)."""
    return np.where(track_present(r.keypoints2d), r.track_segment, np.nan)


def _implausible(r: RecordingResult) -> np.ndarray:
    """``r.implausible_frames`` as ``(T,)`` bool, checked against the recording's length."""
    marked = np.asarray(r.implausible_frames, bool)
    if marked.shape != (len(r.joints_camera),):
        raise ValueError(f"implausible_frames: expected shape ({len(r.joints_camera)},), got {marked.shape}")
    return marked


def write_motion_files(r: RecordingResult, folder: Path, c3d: bool = False, allocate=None,
                       software: str = "") -> dict[str, Path]:
    """Metric runs only (``r.units == "m"``): ``<frame>.trc``, ``<frame>.c3d`` (``c3d``, its
    markers described by their frame and its writer named ``software``) and
    ``<frame>.bvh`` of ``r.poses`` (:func:`.exports.write_trc`, :func:`.exports.write_c3d`,
    :func:`.bvh.write_bvh`), only the 2D track's longest one-person stretch where it switches
    person, and the frames without a place (:func:`_marker_poses`); a BVH needs one frame with all 17 joints (else a note, no file)
    and interpolates gaps (a note counts them). ``allocate`` makes the BVH skeleton's
    per-frame samples (:func:`.bvh.write_bvh`)."""
    if r.units != "m":
        return {}
    name = r.kinematics_frame
    poses = _marker_poses(r, name, allocate or in_memory)
    out = {f"{name}.trc": folder / f"{name}.trc"}
    # the run's own estimate of the up: a recording read upside down is written as read
    write_trc(out[f"{name}.trc"], poses, r.fps, check_up=False)
    if c3d:
        # a lab tool reads the frame in the file: a canonical C3D has no path and no floor, and a
        # world C3D of a root-relative lifter no horizontal path (a trial read its zeros as a path)
        described = f"H36M-17 joint centre, {FRAME_LABELS[name]}" + (
            "; pelvis at the origin, no path, no floor" if name == "canonical" else
            "; pelvis held at x = z = 0, its horizontal path not observed" if "pelvis" in unobservable_paths(r)
            else "")
        out[f"{name}.c3d"] = write_c3d(folder / f"{name}.c3d", poses, r.fps, check_up=False, description=described,
                                       software=software)
    bvh = f"{name}.bvh"
    incomplete = per_frame(lambda P: ~np.isfinite(P).all(axis=(1, 2)), poses)
    if incomplete.all():
        r.notes.append(f"{bvh} not written: no frame has all 17 joints (BVH needs one for the bone lengths)")
        return out
    out[bvh] = write_bvh(folder / bvh, poses, r.fps, allocate=allocate)
    if incomplete.any():
        # the unplaced frames (no fitted pelvis path) are empty in the TRC too: counted here, not as missing joints
        r.notes.append(f"{bvh}: {int(incomplete.sum())} of {len(incomplete)} frames had missing joints or no place "
                       f"(no fitted pelvis path), "
                       f"filled by linear interpolation in time, held at the ends (BVH cannot hold NaN; the CSV, TRC and "
                       f"npz keep them missing)")
    return out


def other_persons_frames(r: RecordingResult) -> np.ndarray | None:
    """``(T,)`` bool, the frames outside the 2D track's longest one-person stretch
    (:func:`pcnet.stages.flags.one_person_frames`); ``None`` without a 2D track."""
    return None if r.track_segment is None else ~one_person_frames(r.track_segment)


def _marker_poses(r: RecordingResult, name: str, allocate) -> np.ndarray:
    """``r.poses`` with two kinds of frames missing (NaN); ``r.poses`` itself where there are
    none. The frames outside the 2D track's longest one-person stretch, where the track switches
    person (with a note): the marker files carry no ``track_segment`` column, and OpenSim or a
    BVH viewer would animate whoever the track jumped to in the frame fitted to the first
    person (a user trial: another person 1.4 m below the ground in world.trc). The
    :func:`unplaced_frames` (the pelvis path's note says so): their place is no measurement
    (an export trial found the pelvis frozen in world.trc and the C3D where kinematics.csv was
    empty)."""
    no_mask = np.zeros(len(r.poses), bool)
    other, unplaced = (no_mask if m is None else m for m in (other_persons_frames(r), r.unplaced))
    gone = other | unplaced
    if not gone.any():
        return r.poses
    poses = allocate(f"{name}_markers", r.poses.shape, np.float32)
    for rows in frame_blocks(len(gone)):
        block = np.array(r.poses[rows], np.float32)
        block[gone[rows]] = np.nan
        poses[rows] = block
    if other.any():
        # a BVH cannot leave a frame empty (stages/sinks/bvh.py): a trial's Blender body stood frozen there
        r.notes.append(f"marker files ({name}.trc, .c3d): the {int(other.sum())} frames outside the 2D track's "
                       f"longest one-person stretch are left empty (probably another person; kinematics.csv and "
                       f"canonical.npz keep them, with track_segment); {name}.bvh, which cannot leave a frame empty, "
                       f"interpolates across them between kept frames and holds the nearest kept pose at its ends")
    return poses


def write_figures(r: RecordingResult, folder: Path) -> dict[str, Path]:
    """``wrists.png`` (camera frame against ``r.kinematics_frame``), ``angles.png`` and
    ``speeds.png`` (:mod:`.plots`; in each, frames outside the 2D track's longest one-person stretch
    shaded grey, frames of motion faster than any training motion, ``r.implausible_frames``, shaded red)."""
    kin = r.kinematics
    wrist_acc = kin.acceleration[:, [KEPT_JOINTS.index(n) for n in WRISTS]]
    other = other_persons_frames(r)
    implausible = None if r.implausible_frames is None else _implausible(r)
    out = {"wrists.png": plot_wrists(folder / "wrists.png", r.joints_camera, r.poses, r.fps,
                                     r.wrist_acceleration_camera, wrist_acc, r.units, frame_label=r.frame_label,
                                     other_person=other, implausible=implausible)}
    for name, plot in (("angles.png", plot_joint_angles), ("speeds.png", plot_joint_speeds)):
        out[name] = plot(folder / name, kin, r.fps, frame_label=r.frame_label, other_person=other,
                         implausible=implausible)
    return out


#: The rerun recording's file name, also its key in a run's outputs (an API trial's
#: ``outputs["recording.rrd"]`` met a KeyError where every other output is keyed by its name).
RECORDING_NAME = "recording.rrd"


def write_rerun(r: RecordingResult, folder: Path, warnings: list[str] | None = None) -> dict[str, Path]:
    """``recording.rrd`` (:func:`.rerun_log.write_recording`): video, 2D keypoints, camera,
    canonical and world views, wrist paths, kinematics series, the warnings (``warnings``,
    default ``r.flags``), the frames of motion faster than any training motion (``r.implausible_frames``)
    and the 2D track's person segments."""
    path = write_recording(
        folder / RECORDING_NAME, fps=r.fps, joints_cam=r.joints_camera,
        # the body the kinematics read (decision 0100: the input turned rigidly, no residual)
        canonical=to_canonical(r.joints_camera, r.rotation),
        rotations=r.rotation, up=column(r.rotation, slice(None), 1), valid=r.valid,
        keypoints2d=r.keypoints2d if r.video_keypoints2d is None else r.video_keypoints2d, video_path=r.video, video_first_frame=r.video_first_frame, wrist_paths={n: column(r.kinematics.positions, KEPT_JOINTS.index(n)) for n in WRISTS},
        series=series_from_kinematics(r.kinematics), min_confidence=r.min_confidence,
        flags=r.flags if warnings is None else warnings, world=r.world,
        notes=r.notes, implausible_frames=None if r.implausible_frames is None else _implausible(r),
        track_segment=None if r.track_segment is None else _track_segment(r),
        floor_frames=None if r.track_segment is None else one_person_frames(r.track_segment),
        keypoints2d_outside=(None if r.keypoints2d is None or r.keypoint_picture is None
                             else per_frame(lambda kp: outside_image(kp, r.keypoint_picture), r.keypoints2d)),
    )
    return {RECORDING_NAME: path}
