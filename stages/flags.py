"""Warnings a run must not keep to itself: an input that is probably upside down or has its
axes wrong, poses far from upright everyday movement, and a 2D track that jumps to another
person. Each check is arrays in, :class:`Finding` objects out (its kind, severity, one-line
headline, action, full text and, where it concerns some frames only, those frames); the
pipeline prints them in the run summary and stores their texts in the outputs.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import IntEnum, auto
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType

import numpy as np

from .core.errors import InputError
from .core.conventions import (H36M_JOINTS, HEAD, L_HIP, L_SHOULDER, NECK_NOSE, PELVIS, R_HIP, R_SHOULDER, SPINE,
                               THIGH_RANGE_M, THORAX, median_thigh_length)
from .core.framestore import frame_blocks, true_runs
from .core.rotations import UPSIDE_DOWN_TILT_DEG, camera_pitch_roll, camera_tilt_deg
from .kinematics import frames_phrase, shortest_filtered_run
from .mirror import MIRROR_ODDS, MirrorModel, load_mirror_model, recording_cues
from .opensim_ik import marker_rms_flag, model_leg_asymmetry, model_leg_asymmetry_flag, unscaled_segments_flag
from .plausibility import QUANTITIES, ImplausibleMotion, MotionLimits, implausible_motion_flags
from .rectification_report import EnsembleWeights, PostureHypotheses, SequenceUp
from .remap import outside_image
from .up_model import camera_outside_probability, default_parameters
from .scale import LIMB_BONES, height_chain_length, leg_lengths, limb_lengths

#: The fitted person-switch limits of :func:`track_segments` (decision 0072).
SWITCH_LIMITS_PATH = Path(__file__).resolve().parent / "data" / "track_switch.json"


# --- findings --------------------------------------------------------------------------------
# Every flag is a paragraph: what was seen, why it matters, what to do. The summary prints one
# line per finding (a headline with its numbers and the one action it asks) and report.md keeps
# the paragraph. Each flag function below builds its own findings: it says what it found (its
# Kind and Severity), the headline, the action and, where it concerns some frames, which.


class Severity(IntEnum):
    """How much a finding asks of the reader, most first (see :func:`ranked`)."""

    INFO = 1  #: what was assumed or done; nothing to do unless the assumption is wrong
    CHECK = 2  #: the result stands, but some numbers carry an error worth checking
    PROBLEM = 3  #: the result is wrong in part (another person, swapped sides, wrong units) until acted on


class Kind(IntEnum):
    """What a flag is about. The declaration order is the order :func:`ranked` keeps within
    one severity: causes before their symptoms (a track switch before the implausible speeds
    it causes)."""

    # PROBLEM: another person's poses, mirrored or swapped sides, wrong units, no output asked for
    TRACK_SWITCH = auto()  #: :func:`track_switch_flag`
    UPSIDE_DOWN = auto()  #: :func:`orientation_flags`
    SIDE_SWAP = auto()  #: :func:`side_swap_flag`
    MIRRORED = auto()  #: :func:`mirrored_skeleton_flag`
    BODY_SIZE = auto()  #: :func:`body_size_flag`
    OUTSIDE_IMAGE = auto()  #: :func:`keypoints_outside_image_flag`
    SIZE_CHANGE = auto()  #: :func:`size_change_flag`
    TOO_SHORT = auto()  #: :func:`unfiltered_flag`
    NO_OPENSIM = auto()  #: :func:`no_opensim_flag`
    NO_FLOOR = auto()  #: :func:`floor_flag`, no ankle anywhere
    # CHECK: the result stands; some numbers carry an error worth checking
    IMPLAUSIBLE_SPEED = auto()  #: :func:`implausible_motion_findings`
    IMPLAUSIBLE_ACCELERATION = auto()  #: :func:`implausible_motion_findings`
    LIFTER_TURN = auto()  #: :func:`lifter_frame_flag`
    GIVEN_UP = auto()  #: :func:`given_up_flag`
    CAMERA_TILT = auto()  #: :func:`orientation_flags`
    LYING = auto()  #: :func:`posture_flag`
    AMBIGUOUS_ORIENTATION = auto()  #: :func:`posture_flag`
    QUARTER_TURN = auto()  #: :func:`orientation_flags`
    NO_WORLD_FRAME = auto()  #: :func:`no_world_frame_flag`
    JOINT_ABSENT = auto()  #: :func:`absent_joints_flag`
    LIMB_PROPORTIONS = auto()  #: :func:`limb_proportions_flag`
    LEG_ASYMMETRY = auto()  #: :func:`leg_asymmetry_flag`
    VIEWS_SET_ASIDE = auto()  #: :func:`ensemble_weights_flag`
    FLOOR_PARTIAL = auto()  #: :func:`floor_flag`, some frames
    KEYPOINTS_UNUSED = auto()  #: :func:`keypoints_unused_flag`
    MARKER_RMS = auto()  #: :func:`opensim_fit_findings`
    SEGMENTS_UNSCALED = auto()  #: :func:`opensim_fit_findings`


#: Frame ranges ``(start, stop)``, stop exclusive (as :func:`pcnet.stages.core.framestore.true_runs`).
FrameRanges = tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class Finding:
    """One line of the run summary and one section of report.md.

    severity: :class:`Severity`. headline: what was found, with its numbers, one short line.
    action: the one thing it asks of the user (``""`` for a note). detail: the full text
    (``canonical.npz``'s ``flags``/``notes``). kind: :class:`Kind` (``None``: a note, or a flag
    of no declared kind). frames: the frames it concerns as :data:`FrameRanges`, or ``None``
    where it concerns the recording as a whole.
    """

    severity: Severity
    headline: str
    action: str
    detail: str
    kind: Kind | None = None
    frames: FrameRanges | None = None

    def terminal_line(self) -> str:
        """The finding as the terminal summaries print it: ``WARNING  headline -> action``, a
        note (:data:`Severity.INFO`) ``note     headline`` (an API trial's ``pcnet rectify``
        printed a note as a WARNING, and ``--strict`` counted it)."""
        if self.severity is Severity.INFO:
            return f"note     {self.headline}"
        return f"WARNING  {self.headline} -> {self.action}"

    @property
    def is_warning(self) -> bool:
        """Whether the finding is a WARNING (what ``--strict`` counts), not a note."""
        return self.severity is not Severity.INFO

    def report_lines(self, number: int, level: str = "###") -> list[str]:
        """The finding as a report.md section: its numbered headline, severity and action (a
        full stop added unless the action ends with its own mark, as a question does) and its
        full text."""
        end = "" if self.action.endswith(("?", ".", "!")) else "."
        return [f"{level} {number}. {self.headline}", "", f"Severity: {self.severity.name.lower()}. Action: "
                f"{self.action}{end}", "", self.detail, ""]


#: Characters a headline (or a shortened note) keeps at most.
HEADLINE_WIDTH = 100


def _clipped(text: str, width: int = HEADLINE_WIDTH) -> str:
    """``text`` cut at a word boundary to ``width`` characters, ending in ``...``."""
    if len(text) <= width:
        return text
    return text[:width - 3].rsplit(" ", 1)[0].rstrip(",;:") + "..."


def _found(kind: Kind, severity: Severity, headline: str, action: str, detail: str,
           frames: Iterable[tuple[int, int]] | None = None) -> Finding:
    """A flag's :class:`Finding`, its headline cut to :data:`HEADLINE_WIDTH`."""
    return Finding(severity, _clipped(headline), action, detail, kind, None if frames is None else tuple(frames))


def camera_tilt(up_cam: np.ndarray, valid: np.ndarray) -> tuple[float, float, float]:
    """Tilt, pitch and roll (degrees) of the camera from the mean estimated up direction.

    One up vector for the whole recording (the normalised mean of the valid frames' ups), so
    the three numbers are consistent: ``cos(tilt) = cos(pitch) cos(roll)`` with
    ``pitch = asin(-u_z)``, ``roll = atan2(u_x, -u_y)``
    (:func:`pcnet.stages.core.rotations.camera_pitch_roll`).

    Args:
        up_cam: ``(T, 3)`` unit up directions in the camera frame (OpenCV axes).
        valid: ``(T,)`` bool.

    Returns:
        ``(tilt, pitch, roll)`` in degrees, NaN when no frame is valid.
    """
    ok = _valid_ups(up_cam, valid)
    if not ok.any():
        return float("nan"), float("nan"), float("nan")
    u = up_cam[ok].mean(axis=0)
    u = u / np.linalg.norm(u)
    tilt = camera_tilt_deg(u)
    pitch, roll = np.degrees(camera_pitch_roll(u))
    return float(tilt), float(pitch), float(roll)


def signed_deg(deg: float, digits: int = 1) -> str:
    """``deg`` printed with its sign and ``digits`` decimals, ``+0.0`` where it rounds to zero (a
    level camera's pitch printed "-0.0" in an ergonomist's trial)."""
    return f"{round(deg, digits) + 0.0:+.{digits}f}"


def with_looking(pitch_roll: str, pitch_deg: float, half_width_deg: float = 0.0) -> str:
    """A tilt line's parenthesis ``"(pitch ..., roll ...)"`` led by the direction the camera
    looks, ``"(looking down: pitch ..."`` or ``"(looking up: ..."`` by the pitch's sign
    (:func:`pcnet.stages.core.rotations.camera_pitch_roll`: positive = down), unchanged where
    the pitch prints as level (``+0.0``), is NaN, or lies within ``half_width_deg`` (its
    calibrated interval's half-width; an interval that holds both directions says neither).
    Beside the pitch it names, not the tilt: an ergonomist could not tell which way a signed
    pitch pointed, and a clinic trial read "22 deg from level, looking up" as 22 deg up where
    the camera was pitched 8 and rolled 21."""
    if not np.isfinite(pitch_deg) or signed_deg(pitch_deg) == "+0.0" or abs(pitch_deg) <= half_width_deg:
        return pitch_roll
    return f"(looking {'down' if pitch_deg > 0 else 'up'}: " + pitch_roll.removeprefix("(")


def per_frame_tilt_summary(up_cam: np.ndarray, valid: np.ndarray) -> list[float]:
    """Median, 5th and 95th percentile (degrees) of the per-frame camera tilt
    ``arccos(-u_y)`` over the valid frames, for the summary of a recording whose up may
    change from frame to frame (frame and smooth modes), where :func:`camera_tilt`'s one
    number is that of the mean up.

    Args:
        up_cam: ``(T, 3)`` unit up directions in the camera frame (OpenCV axes).
        valid: ``(T,)`` bool.

    Returns:
        ``[median, p5, p95]`` floats, NaN when no frame is valid.
    """
    ok = _valid_ups(up_cam, valid)
    if not ok.any():
        return [float("nan")] * 3
    return [float(v) for v in np.percentile(camera_tilt_deg(up_cam[ok]), [50, 5, 95])]


def _valid_ups(up_cam: np.ndarray, valid: np.ndarray) -> np.ndarray:
    return np.asarray(valid, bool) & np.isfinite(up_cam).all(axis=1)


def orientation_flags(tilt_deg: float, pitch_deg: float | None = None, roll_deg: float | None = None,
                      posture: PostureHypotheses | None = None) -> list[Finding]:
    """Flags for a camera orientation that real recordings rarely have.

    The camera is judged against the image axis nearest the up direction, as the view gate
    judges a camera (``models/view_gate.py: quarter_turns``): a phone held in portrait, whose
    image-up is turned a quarter turn (roll near +-90 deg), is a level camera whose image was
    turned; it is said once (a body lying across the image under a level camera reads the
    same). A roll beyond +-135 deg, or a tilt beyond
    :data:`pcnet.stages.core.rotations.UPSIDE_DOWN_TILT_DEG` with no quarter turn, is read as
    upside-down or axis-swapped input. The camera-tilt flag fires where the up model's declared
    camera prior holds the camera (its pitch, and its roll beyond any quarter turn) more probably
    one of the cameras outside its handheld views than a handheld one
    (:func:`pcnet.stages.up_model.camera_outside_probability` above one half; decision 0064):
    either the camera was tilted that much, or the body is not upright (lying, seated, bent
    over), which the poses alone cannot tell apart.

    Args:
        tilt_deg, pitch_deg, roll_deg: degrees, from :func:`camera_tilt` (one recording's
            mean up; ``cos(tilt) = cos(pitch) cos(roll)``). Without ``pitch_deg`` and
            ``roll_deg`` only an upside-down tilt is judged.
        posture: the up model's posture hypotheses, where the run has them (sequence mode of
            the shipped ensemble with its camera prior, where ``--posture`` is read): a
            declared posture answers the quarter turn's question (portrait phone or lying
            body), so no quarter-turn flag; without them the flag's action says where
            ``--posture`` is read.

    Returns:
        zero or one finding.
    """
    if not np.isfinite(tilt_deg):
        return []
    oriented = pitch_deg is not None and roll_deg is not None and np.isfinite(pitch_deg) and np.isfinite(roll_deg)
    quarter = int(np.round(roll_deg / 90.0)) if oriented else 0
    if abs(quarter) == 2 or (quarter == 0 and tilt_deg > UPSIDE_DOWN_TILT_DEG):
        return [_found(Kind.UPSIDE_DOWN, Severity.PROBLEM,
                       f"up points {tilt_deg:.0f} deg from image-up: input upside down or its axes wrong",
                       "check the lifter's axes and joint order (--axes, --layout with --lifter generic)",
                       f"up points {tilt_deg:.0f} deg away from image-up: the input is probably upside down, its "
                       f"axes are wrong or its joints in another order (check the lifter's axis convention and joint "
                       f"layout; --axes and --layout with --lifter generic)")]
    if not oriented:
        return []
    roll_beyond = roll_deg - 90.0 * quarter
    outside = float(camera_outside_probability(pitch_deg, roll_beyond))
    if outside > 0.5:
        prior = default_parameters()
        beyond_turn = tilt_deg if quarter == 0 else float(np.degrees(np.arccos(np.clip(
            np.cos(np.radians(pitch_deg)) * np.cos(np.radians(roll_beyond)), -1.0, 1.0))))
        turned = "" if quarter == 0 else (f" beyond a quarter turn (roll {roll_deg:+.0f} deg, nearer a camera held in "
                                          f"portrait than a level one)")
        return [_found(Kind.CAMERA_TILT, Severity.CHECK,
                       f"camera tilt {beyond_turn:.0f} deg{' beyond a quarter turn' if quarter else ''}: a steep "
                       f"camera or a subject not upright", "check the result",
                       f"camera tilt {beyond_turn:.0f} deg{turned} (pitch {pitch_deg:+.0f}, roll {roll_beyond:+.0f} "
                       f"deg): more probably ({100 * outside:.0f} %) one of the unusual cameras than a handheld one, by "
                       f"the declared camera prior (pitch N(0, {prior.camera_prior_pitch_deg:g}), roll "
                       f"N(0, {prior.camera_prior_roll_deg:g}) deg, {100 * prior.camera_prior_outside:g} % outside "
                       f"them); either the camera was tilted that much or the subject is not upright (lying, seated, "
                       f"bent), which the poses alone cannot tell apart: check the result (and --axes, with --lifter "
                       f"generic)")]
    if quarter and not (posture is not None and posture.declared):
        declare = ("--posture lying if the subject lay, --posture upright to confirm" if posture is not None
                   else "if the subject lay and the camera stood still: --mode sequence --posture lying, with the "
                        "camera prior (a handheld camera has no posture option)")
        return [_found(Kind.QUARTER_TURN, Severity.CHECK,
                       f"camera read as turned a quarter turn (roll {roll_deg:+.0f} deg): portrait phone or lying "
                       f"body?", declare,
                       f"camera read as turned a quarter turn about its optical axis (roll {roll_deg:+.0f} deg: a "
                       f"phone in portrait, or a body lying across the image under a level camera, which the poses "
                       f"alone cannot tell apart): {declare}; a lying body's up then comes from the camera prior "
                       f"across the trunk")]
    return []


def body_size_flag(joints: np.ndarray, units: str) -> list[Finding]:
    """A flag when poses said to be in metres have a body no person has (median thigh
    length outside :data:`THIGH_RANGE_M`): usually millimetres or centimetres given as
    metres, or a lifter's normalised output.

    Args:
        joints: ``(T, 17, 3)`` H36M-17 poses in ``units``.
        units: the poses' units; only ``"m"`` is checked.
    """
    if units != "m":
        return []
    median = median_thigh_length(joints)
    low, high = THIGH_RANGE_M
    if not np.isfinite(median) or low <= median <= high:
        return []
    return [_found(Kind.BODY_SIZE, Severity.PROBLEM,
                   f"median thigh {median:.3g} m, no person's: the poses are probably not in metres",
                   "check --units or the joint order, or give --height",
                   f"median thigh length {median:.3g} m is outside the {low}-{high} m a person has: the lifter output "
                   f"is probably not in metres (check --units, or give --height to scale it; with --lifter generic "
                   f"also --layout: joints in another order give other bone lengths)")]


#: The fitted limits of :func:`leg_asymmetry_flag` and :func:`size_change_flag` (decision 0075).
SKELETON_LIMITS_PATH = Path(__file__).resolve().parent / "data" / "skeleton_limits.json"


@dataclass(frozen=True)
class SkeletonLimits:
    """How far a lifter's skeleton strays from a person's through an ordinary lifter's error:
    the largest values over the training mocap seen through the lifter-noise model (decision
    0075, ``python -m benchmarks.fit_skeleton_limits --data ../shared/data``).

    Attributes:
        leg_asymmetry: the largest relative difference of the left and right legs' lengths
            (:func:`leg_asymmetry`), a fraction of the longer leg.
        size_change_ratio: the largest 95th over 5th percentile of the ankle-to-head chain
            (:func:`size_percentiles`).
        limb_length_ratio: the largest ratio of the longest to the shortest limb bone
            (:func:`limb_proportions`).
        provenance: the fit's command, data, split and the clip that set each value.
    """

    leg_asymmetry: float
    size_change_ratio: float
    limb_length_ratio: float
    provenance: Mapping = field(default_factory=dict)


@lru_cache(maxsize=4)
def load_skeleton_limits(path: str | Path | None = None) -> SkeletonLimits:
    """Read :class:`SkeletonLimits` from JSON (``leg_asymmetry``, ``size_change_ratio``,
    ``limb_length_ratio``, ``provenance``; default: the shipped :data:`SKELETON_LIMITS_PATH`).

    Raises:
        FileNotFoundError: no such file.
        InputError: not JSON, or a field missing or not a positive finite number (named).
    """
    return _read_limits(SkeletonLimits, SKELETON_LIMITS_PATH if path is None else path,
                        ("leg_asymmetry", "size_change_ratio", "limb_length_ratio"), "lifter-skeleton limits",
                        "a positive number")


def _read_limits(cls, path: str | Path, names: Sequence[str], what: str, expected: str,
                 low: float = 0.0, high: float = np.inf):
    """``cls(**fields, provenance=...)`` from the JSON object of ``path``: its fields ``names``,
    each a finite number in ``(low, high]``, and its ``provenance``. Raises InputError naming
    the file and the field."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as err:
        raise InputError(f"{path}: expected the JSON {what}, got unreadable JSON ({err})") from err
    values = {}
    for name in names:
        value = data.get(name) if isinstance(data, dict) else None
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if not number or not np.isfinite(value) or not low < value <= high:
            raise InputError(f"{path}: field {name!r}: expected {expected}, got {value!r}")
        values[name] = float(value)
    return cls(**values, provenance=MappingProxyType(dict(data.get("provenance", {}))))


def leg_asymmetry(joints: np.ndarray) -> tuple[float, str]:
    """The relative difference of the left and right legs' lengths of H36M-17 poses
    ``(T, 17, 3)`` (any units): ``|left - right| / max(left, right)`` of the medians over frames
    of hip -> knee plus knee -> ankle, and the shorter side (``"left"`` or ``"right"``); NaN
    and ``""`` where a leg has no finite frame."""
    right, left = (float(np.median(leg[np.isfinite(leg)])) if np.isfinite(leg).any() else float("nan")
                   for leg in leg_lengths(joints).T)
    if not (np.isfinite(left) and np.isfinite(right)) or max(left, right) <= 0:
        return float("nan"), ""
    return abs(left - right) / max(left, right), "right" if right < left else "left"


def leg_asymmetry_flag(joints: np.ndarray, limits: SkeletonLimits | None = None) -> list[Finding]:
    """A flag when the left and right legs of H36M-17 poses ``(T, 17, 3)`` (any units) differ
    in length (:func:`leg_asymmetry`) by more than ``limits.leg_asymmetry`` (default: the
    shipped :func:`load_skeleton_limits`): heights above the floor and left/right comparisons
    then carry the lifter's error."""
    difference, shorter = leg_asymmetry(joints)
    if not difference > (limits or load_skeleton_limits()).leg_asymmetry:  # NaN: no leg measured
        return []
    return [_found(Kind.LEG_ASYMMETRY, Severity.CHECK,
                   f"lifter's legs differ {100 * difference:.0f} % in length ({shorter} shorter): floor heights "
                   f"carry it",
                   "compare left and right with care",
                   f"the lifter's left and right legs differ by {100 * difference:.0f} % in length (median over "
                   f"frames; the {shorter} one shorter), more than a person's: heights above the floor (the {shorter} "
                   f"foot can hover above it in stance) and left/right comparisons carry the lifter's error; a file in "
                   f"another joint order read as H36M-17 (COCO-17's eyes and ears as hips and knees) also makes the "
                   f"legs differ: check the joint order its lifter writes")]


@dataclass(frozen=True)
class LimbProportions:
    """The longest and the shortest limb bone of a recording (:func:`limb_proportions`):
    ratio: longest over shortest (NaN with fewer than two bones measured); longest, shortest:
    their names (:data:`pcnet.stages.scale.LIMB_BONES`); longest_length, shortest_length:
    their median lengths over frames (the poses' units)."""

    ratio: float
    longest: str = ""
    longest_length: float = float("nan")
    shortest: str = ""
    shortest_length: float = float("nan")


def limb_proportions(joints: np.ndarray) -> LimbProportions:
    """The longest and the shortest of the eight limb bones (thighs, shanks, upper arms,
    forearms; :func:`pcnet.stages.scale.limb_lengths`) of H36M-17 poses ``(T, 17, 3)`` (any
    units), each by its median length over the frames where it is finite and positive. A
    person's limb bones differ at most about twofold (forearm to thigh); a joint order other
    than H36M-17's joins joints that are not neighbours (a wrist to an ankle, one eye to the
    other), and a lifter that collapses a limb it cannot see shortens one bone to centimetres."""
    lengths = limb_lengths(joints)
    medians = {}
    for name, column in zip(LIMB_BONES, lengths.T):
        column = column[np.isfinite(column) & (column > 0)]
        if len(column):
            medians[name] = float(np.median(column))
    if len(medians) < 2:
        return LimbProportions(float("nan"))
    longest, shortest = max(medians, key=medians.get), min(medians, key=medians.get)
    return LimbProportions(medians[longest] / medians[shortest], longest, medians[longest], shortest,
                           medians[shortest])


def limb_proportions_flag(joints: np.ndarray, limits: SkeletonLimits | None = None,
                          order_fixed: bool = False) -> list[Finding]:
    """A flag when the longest limb bone of H36M-17 poses ``(T, 17, 3)`` (any units) is more
    than ``limits.limb_length_ratio`` times the shortest (:func:`limb_proportions`; default:
    the shipped :func:`load_skeleton_limits`, the largest over training mocap through the
    lifter-noise model): a joint order other than H36M-17's, or a limb the lifter collapsed.
    ``order_fixed``: the lifter's reader fixes the joint order (not ``--lifter generic``), so
    only the collapsed limb is left to say (a first-reader trial looked for a joint-order error
    in a VideoPose3D file)."""
    found, limit = limb_proportions(joints), (limits or load_skeleton_limits()).limb_length_ratio
    if not found.ratio > limit:  # NaN: fewer than two bones
        return []
    shorter = 100 * found.shortest_length / found.longest_length
    measured = (f"the lifter's {found.shortest} is {shorter:.0f} % of the length of its {found.longest} (medians "
                f"over frames), {found.ratio:.1f}-fold where a person's limb bones differ at most {limit:.1f}-fold "
                f"through an ordinary lifter's error: ")
    collapsed = "the lifter collapsed a limb it could not see, whose angles and speeds then fail"
    return [_found(Kind.LIMB_PROPORTIONS, Severity.CHECK,
                   f"lifter's {found.shortest} is {shorter:.0f} % of its {found.longest}'s length",
                   (f"treat the {found.shortest}'s angles and speeds with care: the lifter collapsed it" if order_fixed
                    else f"check the joint order; treat the {found.shortest}'s angles with care"),
                   measured + (collapsed + " (the joint order is the lifter's format's)" if order_fixed else
                               "a file in another joint order than H36M-17's joins joints that are not neighbours "
                               "(check the joint order its lifter writes, --layout with --lifter generic), or "
                               + collapsed))]


def size_percentiles(joints: np.ndarray) -> np.ndarray:
    """``(3,)`` float64 the 5th, 50th and 95th percentiles of the per-frame ankle-to-head chain
    (:func:`pcnet.stages.scale.height_chain_length`) of H36M-17 poses ``(T, 17, 3)``, over the
    frames where it is finite and positive; NaN with fewer than two such frames."""
    chain = height_chain_length(joints)
    chain = chain[np.isfinite(chain) & (chain > 0)]
    return np.percentile(chain, [5, 50, 95]) if len(chain) >= 2 else np.full(3, np.nan)


def size_change_flag(joints: np.ndarray, limits: SkeletonLimits | None = None,
                     units_declared: bool = True) -> list[Finding]:
    """A flag when the body of metric H36M-17 poses ``(T, 17, 3)`` changes size over the
    recording by more than ``limits.size_change_ratio`` (5th to 95th percentile of the
    ankle-to-head chain, :func:`size_percentiles`; default: the shipped
    :func:`load_skeleton_limits`): a real body keeps its size, so the lifter fails, or its output
    follows the image after all. Output in image units, whose size follows the person's
    distance by design, is made constant per frame instead
    (:func:`pcnet.stages.scale.size_normalising_factors`); metric output is scaled by one
    factor (:func:`pcnet.stages.scale.height_factor`, the median), so its positions, speeds
    and bone lengths are off by the ratio's deviation from the median. ``units_declared``: the
    user declared the units (``--lifter generic``), so image units read as metres are a likely
    cause and the action names the fix; False for a lifter whose format fixes its units
    (VideoPose3D's metres: a clinician's trial was told to declare image units for them)."""
    p5, p50, p95 = size_percentiles(joints)
    if not p95 / p5 > (limits or load_skeleton_limits()).size_change_ratio:  # NaN: fewer than two frames measured
        return []
    off = 100 * min(p95 / p50 - 1, 1 - p5 / p50)  # both tails, so a tenth of the frames
    cause = ("the lifter fails, or its output is in image units (declare them: --units normalised or px with "
             "--lifter generic, and pcnet makes the size constant per frame)" if units_declared else
             "the lifter fails on part of the recording (its format is metric, so the size should hold)")
    return [_found(Kind.SIZE_CHANGE, Severity.PROBLEM,
                   f"skeleton size changes {p95 / p5:.1f}-fold; a tenth of the frames off by > {off:.0f} %",
                   "check the lifter's output; for output in image units give --lifter generic with --units px or "
                   "normalised" if units_declared else "check the lifter's output on the frames it sizes differently",
                   f"the skeleton's size changes {p95 / p5:.1f}-fold over the recording (5th to 95th percentile of "
                   f"the ankle-to-head chain; a body keeps its size): {cause}. One scale factor (the median) leaves "
                   f"a tenth of the frames' positions, speeds and bone lengths off by more than {off:.0f} % in the "
                   f"metric exports")]


#: The fitted agreement limit of :func:`side_swap_flag` (decision 0077).
SIDE_SWAP_PATH = Path(__file__).resolve().parent / "data" / "side_swap.json"


@dataclass(frozen=True)
class SideSwapLimit:
    """The smallest :func:`side_agreement` of a recording whose sides are right: the smallest
    over the training mocap seen by a simulated detector (2D) and through the lifter-noise
    model (3D) (decision 0077, ``python -m benchmarks.fit_side_swap --data ../shared/data``).

    Attributes:
        agreement_limit: in [-1, 1]; below it the 3D sides are read as exchanged.
        provenance: the fit's command, data, split and the clip that set it.
    """

    agreement_limit: float
    provenance: Mapping = field(default_factory=dict)


@lru_cache(maxsize=4)
def load_side_swap_limit(path: str | Path | None = None) -> SideSwapLimit:
    """Read :class:`SideSwapLimit` from JSON (``agreement_limit``, ``provenance``; default: the
    shipped :data:`SIDE_SWAP_PATH`).

    Raises:
        FileNotFoundError: no such file.
        InputError: not JSON, or ``agreement_limit`` missing or not a number in (-1, 1].
    """
    return _read_limits(SideSwapLimit, SIDE_SWAP_PATH if path is None else path, ("agreement_limit",),
                        "side-swap limit", "a number in (-1, 1]", low=-1.0, high=1.0)


def side_extents(keypoints2d: np.ndarray, joints_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The right-minus-left extents of the hips and the shoulders along the image's x axis, over
    the trunk's length (pelvis -> thorax), in the 2D keypoints and in the 3D poses.

    Both are in the camera's view: the 2D keypoints in pixels (x right) and the 3D poses in the
    camera frame (OpenCV axes, x right), so a body's right hip lies on the same image side in
    both, and exchanging the 3D sides negates the 3D extents.

    Args:
        keypoints2d: ``(T, 17, >=2)`` H36M-17 pixels (NaN = missing).
        joints_cam: ``(T, 17, 3)`` H36M-17 camera-frame poses, any units.

    Returns:
        ``(d2, d3)``: ``(T, 2)`` float64 each (columns: hips, shoulders), NaN where a joint is
        missing.
    """
    # only the six joints it compares, x and y: a long recording's arrays stay on disk
    joints = [R_HIP, L_HIP, R_SHOULDER, L_SHOULDER, THORAX, PELVIS]
    kp = np.stack([np.asarray(keypoints2d[:, j, :2], np.float64) for j in joints], axis=1)
    X = np.stack([np.asarray(joints_cam[:, j, :2], np.float64) for j in joints], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return tuple(np.stack([(P[:, right, 0] - P[:, left, 0]) / np.linalg.norm(P[:, 4] - P[:, 5], axis=-1)
                               for right, left in ((0, 1), (2, 3))], axis=1) for P in (kp, X))


def side_agreement(d2: np.ndarray, d3: np.ndarray) -> float:
    """The cosine between the 2D and 3D left-right extents of :func:`side_extents` over every
    entry where both are finite: ``sum(d2 d3) / sqrt(sum(d2^2) sum(d3^2))`` in [-1, 1];
    exchanging the 3D sides negates it (decision 0077). NaN without such an entry or with all
    extents zero."""
    ok = np.isfinite(d2) & np.isfinite(d3)
    a, b = d2[ok], d3[ok]
    norm = float(np.sqrt(np.sum(a * a) * np.sum(b * b)))
    return float(np.sum(a * b) / norm) if norm > 0 else float("nan")


def side_swap_flag(keypoints2d: np.ndarray, joints_cam: np.ndarray,
                   limit: SideSwapLimit | None = None, model: MirrorModel | None = None) -> list[Finding]:
    """A flag when the 3D lifter's left and right contradict the 2D keypoints': the
    :func:`side_agreement` of their :func:`side_extents` is below ``limit.agreement_limit``
    (default: the shipped :func:`load_side_swap_limit`, decision 0077).

    Which of the two is wrong is read from the 3D skeleton alone, by the mirror test of
    :func:`mirrored_skeleton_flag` at its odds :data:`pcnet.stages.mirror.MIRROR_ODDS`:

    - unless the 3D skeleton bends its knees and elbows as a body does at those odds, its sides
      are probably exchanged (a wrong joint order or --layout, or a mirrored lifter input),
      which no pose-only check can always see: the rotation then faces the body the wrong way,
      with its knees bent backwards;
    - where it does, the 3D is a body and its sides are its own: front and back were confused,
      by the 2D detector (whose left and right then swap, common side-on) or by the lifter
      (which then turned the whole body round). The joint angles stand; the heading may be
      half a turn off.

    Args:
        keypoints2d: ``(T, 17, 3)`` H36M-17 pixels and confidence (NaN = missing).
        joints_cam: ``(T, 17, 3)`` H36M-17 camera-frame poses, any units.
        limit: the agreement limit; None: the shipped one.
        model: the mirror test's fitted cue distribution; None: the shipped one.
    """
    agreement = side_agreement(*side_extents(keypoints2d, joints_cam))
    lowest = (limit or load_side_swap_limit()).agreement_limit
    if not agreement < lowest:  # NaN: no hip or shoulder seen in both
        return []
    said = (f"agreement of the hips' and shoulders' left-right extents {agreement:+.2f}, below {lowest:+.2f}, the "
            f"lowest of any training recording whose sides are right")
    cues, counted = recording_cues(joints_cam)
    body_odds = float(np.exp(min(-(model or load_mirror_model()).log_odds(cues), 50.0))) if counted else 0.0
    if body_odds >= MIRROR_ODDS:
        return [_found(Kind.SIDE_SWAP, Severity.CHECK,
                       f"3D facing contradicts the 2D keypoints (agreement {agreement:+.2f}): front and back confused",
                       "compare the heading with the video",
                       f"the 3D poses' left and right contradict the 2D keypoints' ({said}), but the 3D skeleton bends "
                       f"its knees and elbows as a body does ({body_odds:.0f} times as likely as a mirror image), so its "
                       f"sides are its own: front and back were confused, by the 2D detector (its left and right "
                       f"swapped, common for a body seen side-on) or by the lifter (the whole body turned round). The "
                       f"joint angles stand; if the lifter turned the body, the heading is half a turn off")]
    return [_found(Kind.SIDE_SWAP, Severity.PROBLEM,
                   f"3D left/right contradict the 2D keypoints (agreement {agreement:+.2f}): sides swapped",
                   "check the joint order (--layout with --lifter generic)",
                   f"the 3D poses' left and right contradict the 2D keypoints' ({said}): the 3D output's sides are "
                   f"probably swapped (its joint order or --layout), so the body faces the wrong way and its knees "
                   f"bend backwards")]


#: H36M-17 joints of the trunk and head, whose 2D keypoints the outside-picture check reads: a
#: body cut by the frame's edge (a seated patient filmed from the waist up) loses its legs or
#: arms, not its trunk.
TRUNK_JOINTS = (PELVIS, R_HIP, L_HIP, SPINE, THORAX, NECK_NOSE, HEAD, L_SHOULDER, R_SHOULDER)
#: Share of the present trunk keypoints outside the picture from which the keypoints are taken
#: to belong to another video, resolution or crop (hand-set).
OUTSIDE_IMAGE_SHARE = 0.2


def keypoints_outside_image_flag(keypoints2d, image_size: tuple[int, int], size_typed: bool = False) -> list[Finding]:
    """A PROBLEM when more than :data:`OUTSIDE_IMAGE_SHARE` of the present trunk keypoints
    (:data:`TRUNK_JOINTS`) lie outside the picture, by :func:`pcnet.stages.remap.outside_image`'s
    one-pixel slack, the rule by which ``pcnet run`` takes their 3D joints as missing. Where the
    size was typed (``size_typed``: ``--image-size``, no video) and the picture turned a quarter
    (``height x width``) would not be flagged, it asks whether width and height were swapped.

    Args:
        keypoints2d: ``(T, 17, >=2)`` H36M-17 pixel coordinates in the displayed frame (x right,
            y down), NaN = missing; an array or a frame store read a block at a time.
        image_size: the displayed frame's ``(width, height)`` in pixels; ``(0, 0)`` = unknown.
        size_typed: the size is the user's ``--image-size``, not a video's or the file's.
    """
    w, h = image_size
    if w <= 0 or h <= 0:
        return []
    present = outside = outside_turned = 0
    for rows in frame_blocks(len(keypoints2d)):
        xy = np.asarray(keypoints2d[rows][:, list(TRUNK_JOINTS), :2], np.float64).reshape(-1, 2)
        finite = np.isfinite(xy).all(axis=1)
        present += int(finite.sum())
        outside += int((outside_image(xy, (w, h)) & finite).sum())
        outside_turned += int((outside_image(xy, (h, w)) & finite).sum())
    if not present or outside <= OUTSIDE_IMAGE_SHARE * present:
        return []
    share = 100 * outside / present
    swapped = size_typed and w != h and outside_turned <= OUTSIDE_IMAGE_SHARE * present
    cause = "width and height swapped?" if swapped else "another video, resolution or crop?"
    turned = f" ({100 * outside_turned / present:.0f} % lie outside a {h}x{w} picture)" if swapped else ""
    return [_found(Kind.OUTSIDE_IMAGE, Severity.PROBLEM,
                   f"{share:.0f} % of 2D trunk keypoints lie outside the {w}x{h} picture: {cause}",
                   "check --image-size (width x height)" if swapped else "check the 2D file belongs to this video",
                   f"{share:.0f} % of the trunk's 2D keypoints (hips, shoulders, spine, neck, head) lie outside the "
                   f"{w}x{h} picture, and their joints were taken as missing: {cause}{turned} The left/right and "
                   f"track-switch checks and the recording's overlay rest on them")]


def keypoints_unused_flag(reason: str) -> list[Finding]:
    """A WARNING when 2D keypoints were given but no frame's pelvis could be placed from them
    (:func:`pcnet.stages.root_path.root_from_keypoints` refused them: ``reason``, its error):
    keypoints of another video, with the image's y axis up, or of too few joints. The run goes
    on without a pelvis path, so without what the user gave them for."""
    return [_found(Kind.KEYPOINTS_UNUSED, Severity.CHECK,
                   "2D keypoints unused: no frame's pelvis could be placed from them",
                   "check the 2D file: this video's, image y down",
                   f"the 2D keypoints were given but not used: {reason}. Keypoints of another video, with the image's "
                   f"y axis pointing up, or with too few confident joints give no pelvis path, so the world frame has "
                   f"no horizontal path and no floor from the feet's contacts (heights per frame)")]


def mirrored_skeleton_flag(joints_cam, model: MirrorModel | None = None, depth_sensor: bool = False) -> list[Finding]:
    """A flag when the 3D poses are a mirror image of a body: their knees and elbows bend
    the wrong way, with posterior odds of at least :data:`pcnet.stages.mirror.MIRROR_ODDS`
    (the test of :mod:`pcnet.stages.mirror`).

    Args:
        joints_cam: ``(T, 17, 3)`` H36M-17 poses in any frame and units, NaN = missing (read a
            block of frames at a time: may be on disk).
        model: the fitted cue distribution (default: the shipped one).
        depth_sensor: the poses are a depth sensor's own skeleton (its reader says so:
            ``pcnet.adapters.Poses3D.depth_sensor``): its axes and sides are the reader's, so the
            action asks whether the subject faced away from the sensor (whose tracker
            labels the sides as if facing it) and points to how often the flag fires on real
            skeletons of subjects facing it, instead of naming the generic reader's options
            (an IMU trial's ``kinect_v1`` run was told to check ``--axes``); there the finding
            is a check without odds, which hold for motion capture, not for a depth sensor's
            skeleton (another IMU trial distrusted correct sides for "odds 53:1").
    """
    model = model or load_mirror_model()
    m, counted = recording_cues(joints_cam)
    log_odds = model.log_odds(m) if counted else -np.inf
    if log_odds < np.log(MIRROR_ODDS):
        return []
    odds = float(np.exp(min(log_odds, 50.0)))
    evidence = (f"the 3D skeleton is a mirror image of a body: over {counted} frames its knees bend forward and its "
                f"elbows backward (median bend sines {m[0]:+.2f}, {m[1]:+.2f}; a body's {model.mean[0]:+.2f}, "
                f"{model.mean[1]:+.2f}), {odds:.0f} times as likely for a mirror image as for a body")
    if depth_sensor:
        # The odds are the mocap's: on real Kinect v1 skeletons the flag fires on 36 of 671 files
        # of subjects facing the sensor and catches only 86 of their 671 mirror images
        # (benchmarks/results/mirror_fit_check_validation.txt), so it asks for a check, without odds.
        return [_found(Kind.MIRRORED, Severity.CHECK,
                       "3D skeleton may be mirrored (knees bend forward; weak on a depth sensor)",
                       "did the subject face away from the sensor?",
                       f"{evidence} under the model fitted on motion capture; a depth sensor's tracker labels the sides "
                       f"as if the subject faced it, so a subject turned away comes out mirrored, and every sagittal "
                       f"angle then has the wrong sign; but the odds do not hold for a depth sensor's skeleton: it also "
                       f"fires on real Kinect skeletons of subjects who faced the sensor, whose knees it reads "
                       f"hyperextended (docs/guide/warnings.md says how often), so there it says little")]
    # the generic reader's options: a named lifter such as kinect_v1 takes no --axes (a batch trial)
    return [_found(Kind.MIRRORED, Severity.PROBLEM,
                   f"3D skeleton mirrored (knees bend forward; odds {odds:.0f}:1): angles flip sign",
                   "check --axes, --layout (--lifter generic)",
                   f"{evidence}; its depth axis has the wrong sign (--axes) or its left and right are exchanged "
                   f"(--layout), so every sagittal angle has the wrong sign; read the file with --lifter generic, "
                   f"which takes both")]


def given_up_flag(sequence: SequenceUp | None) -> list[Finding]:
    """A flag where the camera's up was given (``--camera-up``, ``--camera-up-from``) and the poses' own up lies
    outside its 95 % interval on either axis (``SequenceUp.poses_estimate``): a given up in
    another frame, with a sign flipped or a calibration's row for its column reads every angle
    against gravity wrong (a trial's pasted row read a standing trunk 127 deg from vertical).
    ``None``, an estimated up, no calibrated interval, or a standing trial's up (its own
    interval: :func:`given_up_note`) gives none."""
    est = None if sequence is None else sequence.poses_estimate
    if est is None or not est["outside_interval"]:
        return []
    if sequence.given_from_run:
        return []  # a standing trial's up: :func:`given_up_note`
    return [_found(Kind.GIVEN_UP, Severity.CHECK,
                   f"given camera up {est['angle_from_given_deg']:.0f} deg from the poses' own, outside their 95 % "
                   f"interval",
                   "check --camera-up's frame and signs, or that --camera-up-from's run had this camera, unmoved",
                   f"the camera's up given with --camera-up or --camera-up-from (pitch "
                   f"{sequence.camera_pitch_deg:+.1f}, roll {sequence.camera_roll_deg:+.1f} deg) lies "
                   f"{est['angle_from_given_deg']:.0f} deg from the poses' "
                   f"own (pitch {est['pitch_deg']:+.1f} +- {est['pitch_interval_deg']:.1f}, roll {est['roll_deg']:+.1f} "
                   f"+- {est['roll_interval_deg']:.1f} deg, 95 % intervals of the up model): the run used the given "
                   f"one; check that it is in the camera's own frame (OpenCV: x right, y down, z forward), with its "
                   f"signs, and a calibration's column (R_world_to_cam applied to the world's up), not a row; for "
                   f"--camera-up-from, that its run was filmed by this camera, unmoved; or that the body stood "
                   f"upright")]


def given_up_note(sequence: SequenceUp | None) -> list[str]:
    """A note, not a warning, where the up came from a standing trial (``--camera-up-from``:
    the given up has its own interval) and the poses' own up lies outside its 95 % interval:
    such an up is given exactly where a recording's poses read the up poorly, so their
    disagreement is expected (a clinic's trial had a warning on 12 of 19 seated, tree and
    triangle exercises whose readings the trial's up set right)."""
    est = None if sequence is None else sequence.poses_estimate
    if est is None or not est["outside_interval"] or not sequence.given_from_run:
        return []
    return [f"the poses' own up (pitch {est['pitch_deg']:+.1f} +- {est['pitch_interval_deg']:.1f}, roll "
            f"{est['roll_deg']:+.1f} +- {est['roll_interval_deg']:.1f} deg) lies {est['angle_from_given_deg']:.0f} deg "
            f"from the standing trial's (--camera-up-from), which the run used: expected where the body is not "
            f"standing (seated, lying, bent sideways: the poses then read the up poorly, which is why the trial's is "
            f"given); for a standing body, the camera moved between the trial and this recording"]


def posture_flag(sequence: SequenceUp | None) -> list[Finding]:
    """A flag for the up model's posture hypotheses in sequence mode
    (:class:`~pcnet.stages.rectification_report.SequenceUp`, :func:`pcnet.stages.rectify.up_model_sequence`):
    the body was read as lying (up from the camera prior, not from the pose), or the lying
    hypothesis kept enough posterior probability that the 95 % intervals reach it
    (``interval_reaches_other_posture_p``, :data:`pcnet.stages.up_model.OTHER_POSTURE_P`;
    decision 0060). ``None`` or no posture (frame or smooth mode, another method, or no camera
    prior) gives none, and so does a posture the user declared (``--posture``)."""
    if sequence is None or sequence.posture is None or sequence.posture.declared:
        return []
    p = sequence.posture.p_lying
    if sequence.posture.most_probable == "lying":
        pitch, roll = sequence.posture.pose_up_pitch_deg, sequence.posture.pose_up_roll_deg
        camera = f"a camera looking {'down' if pitch >= 0 else 'up'} {abs(pitch):.0f} deg and rolled {roll:+.0f} deg"
        return [_found(Kind.LYING, Severity.CHECK,
                       f"body read as lying (posterior {100 * p:.0f} %): up taken from the priors",
                       # the reading first: a physiotherapist's five supine patients were told first of a
                       # camera rolled a quarter turn
                       f"--posture lying if the subject lay, --posture upright if standing under {camera} (or "
                       f"--axes, with --lifter generic, if the file's up axis is another)",
                       f"body read as lying (posterior {100 * p:.0f} %): the trunk lies across the image, so up is "
                       f"taken from the camera prior (near level; the true up within about "
                       f"{sequence.up_uncertainty_deg:.0f} deg, the pitch and roll 95 % half-widths combined, if the "
                       f"camera is not upside down: a supine "
                       f"body under an upside-down camera reads as prone) across the trunk; a body standing straight "
                       f"under {camera} (the poses' own reading, without the priors) looks the same (pass "
                       f"--posture upright if that is the camera; a phone video's "
                       f"display rotation tells when --video is given with the 2D keypoints), and so does a file "
                       f"whose up axis is declared wrongly (check --axes with --lifter generic). A body that really "
                       f"lies under a camera near level keeps this result (--posture lying says so): the angles "
                       f"between segments (hip, knee, elbow) do not depend on the up; angles to gravity and positions "
                       f"rest on the camera prior")]
    if sequence.interval_reaches_other_posture_p is not None:
        return [_found(Kind.AMBIGUOUS_ORIENTATION, Severity.CHECK,
                       f"ambiguous orientation: read upright, but lying keeps {100 * p:.0f} % posterior",
                       "--posture upright or --posture lying, as the subject was",
                       f"ambiguous body orientation: read as upright, but a lying body under a level camera keeps "
                       f"{100 * p:.0f} % posterior probability, so the 95 % intervals reach it (pose-based up "
                       f"{sequence.posture.pose_up_tilt_deg:.0f} deg from a level camera's); the poses cannot tell "
                       f"the two apart: declaring the posture (--posture upright or lying) settles it")]
    return []


#: Share of valid frames outside the camera-frame network's views above which it is flagged:
#: fitted on the up model's validation recordings as the share that best separates the per-frame
#: bound's hit (largest two-sample t; ``python -m benchmarks.fit_set_aside_share --data
#: ../shared/data``, ``benchmarks/results/fit_set_aside_share.txt``, decision 0079; 0.05 hand-set
#: before). The warning itself was kept by decision 0078.
OUTSIDE_VIEWS_SHARE = 0.0719


def ensemble_weights_flag(weights: EnsembleWeights | None) -> list[Finding]:
    """A flag from the shipped ensemble's weights (:class:`~pcnet.stages.rectification_report.EnsembleWeights`)
    when the camera-frame 3DPCNet was (partly) set aside for the body-frame one in more than
    :data:`OUTSIDE_VIEWS_SHARE` of the valid frames (the remaining roll or pitch beyond the view
    gate's ramps, or a body whose trunk is far from the image's vertical): there the per-frame
    bound holds the truth less often (decision 0078). ``None`` (one estimator ran) gives none.
    It concerns the per-frame up, so a run calls this only where that up is the answer (frame
    and smooth modes): in sequence mode the up model weighs both networks itself, and the
    posture and orientation flags say what it read. A quarter turn is said by
    :func:`orientation_flags` (the gate's own quarter-turn warning went with decision 0078)."""
    if not weights or not weights.frames:
        return []
    outside, frames = weights.set_aside_frames, weights.frames
    if outside <= OUTSIDE_VIEWS_SHARE * frames:
        return []
    return [_found(
        Kind.VIEWS_SET_ASIDE, Severity.CHECK,
        f"camera-frame network set aside in {outside} of {frames} frames: less accurate up there",
        "a static camera: run --mode sequence (the up model weighs both networks); else take the up there as less sure",
        f"camera-frame network set aside, wholly or in part, in {outside} of {frames} frames: the body-frame network "
        f"read the camera as rolled or pitched beyond the view gate's ramps (models/view_gate.py) after any quarter "
        f"turn, and the camera-frame network's own up did not place the camera inside its training views either (a rolled or "
        f"steep camera, or a body leaning sideways, upside down or across the image; the poses alone cannot tell "
        f"which): the rotation-equivariant body-frame network was used there ({weights.body_frame_frames} frames "
        f"alone, {weights.blended_frames} blended), less accurate on held-out mocap (models/MODEL_CARD.md)")]


#: The limb joints H36M-17's joint angles are measured at (hips, knees, ankles, shoulders,
#: elbows, wrists); a head joint the format lacks (Kinect v1 has no nose) empties no angle.
LIMB_JOINTS = tuple(j for j in H36M_JOINTS if j.split("_")[-1] in ("hip", "knee", "ankle", "shoulder", "elbow", "wrist"))


def absent_joints_flag(missing: np.ndarray) -> list[Finding]:
    """A flag naming the limb joints (:data:`LIMB_JOINTS`) missing in every frame that has
    a pose: their joint angles are empty throughout, which a user trial read only in a
    shortened missing-data note (a lifter file whose left knee was NaN: exit 0, the left knee
    and hip angle columns empty, the leg-asymmetry warning gone).

    Args:
        missing: ``(T, 17)`` bool flags of :class:`pcnet.stages.kinematics.Kinematics`.
    """
    missing = np.asarray(missing, bool)
    with_pose = ~missing.all(axis=1)
    if not with_pose.any():
        return []
    absent = [j for j in LIMB_JOINTS if missing[with_pose, H36M_JOINTS.index(j)].all()]
    if not absent:
        return []
    names, its = ", ".join(absent), "their" if len(absent) > 1 else "its"
    return [_found(Kind.JOINT_ABSENT, Severity.CHECK,
                   f"{names} missing in every frame: {its} joint angles are empty",
                   # a video's 6-frame clip with an arm hidden read "check the joint order" (a coach's trial)
                   "film the whole body in view, or check the input's joint order",
                   f"{names} missing in every one of the {int(with_pose.sum())} frames with a pose (NaN or "
                   f"placeholder values in the lifter output, its 2D keypoint outside the picture or below the "
                   f"confidence threshold in every frame), so every joint angle and segment measured at "
                   f"{'them' if len(absent) > 1 else 'it'} is empty: a joint out of the picture or hidden throughout, "
                   f"or (a lifter file) another joint order than the lifter's")]


def unfiltered_flag(missing: np.ndarray, unfiltered: np.ndarray, fps: float,
                    cutoff_hz: float | None) -> list[Finding]:
    """A flag when no joint position could be low-pass filtered: every run of present frames
    is shorter than the filter needs (:func:`pcnet.stages.kinematics.butterworth_lowpass`), so
    positions are raw and there are no velocities or accelerations.

    Args:
        missing, unfiltered: ``(T, 17)`` bool flags of :class:`pcnet.stages.kinematics.Kinematics`.
    """
    present = ~np.asarray(missing, bool)
    if cutoff_hz is None or not present.any() or not np.asarray(unfiltered, bool)[present].all():
        return []
    if len(present) >= shortest_filtered_run(fps, cutoff_hz):  # long enough: the gaps leave every run short
        longest = max(stop - start for joint in present.T for start, stop in true_runs(joint))
        return [_found(Kind.TOO_SHORT, Severity.PROBLEM,
                       f"gaps too frequent to filter (longest run of a present joint {longest} of "
                       f"{frames_phrase(len(present))}): raw positions, no velocity or acceleration",
                       "check why joints are missing (report.md)",
                       f"no run of present frames is longer than the {cutoff_hz:g} Hz low-pass filter needs at "
                       f"{fps:g} fps: the longest run of any joint is {longest} of {frames_phrase(len(present))}, "
                       f"broken by missing frames (2D confidence below --confidence-threshold, joints outside the "
                       f"picture, or the lifter's own gaps), so positions are raw and no velocity or acceleration "
                       f"is given")]
    return [_found(Kind.TOO_SHORT, Severity.PROBLEM,
                   f"too short to filter ({frames_phrase(len(present))}): raw positions, no velocity or acceleration",
                   "use a longer recording",
                   f"too short to filter: no run of present frames is longer than the {cutoff_hz:g} Hz low-pass "
                   f"filter needs at {fps:g} fps ({frames_phrase(len(present))}), so positions are raw and no "
                   f"velocity or acceleration is given")]


def floor_flag(feet_visible: np.ndarray, present: np.ndarray) -> list[Finding]:
    """A flag when frames with a pose show no ankle, so the world frame's floor was not seen
    there (:func:`pcnet.stages.world_frame.floor_heights`): heights interpolated from the
    frames that saw it (the finding's frames), or, with no ankle anywhere, relative to the
    pelvis.

    Args:
        feet_visible, present: ``(T,)`` bool: an ankle is finite; any joint is finite.
    """
    unseen = present & ~feet_visible
    missing, total = int(unseen.sum()), int(present.sum())
    if not missing:
        return []
    if missing == total:
        return [_found(Kind.NO_FLOOR, Severity.PROBLEM,
                       "no ankle in any frame: heights are relative to the pelvis, not the ground",
                       "read heights as pelvis-relative",
                       "no ankle visible in any frame: no floor, so world-frame heights are relative to the pelvis "
                       "(y = 0 at the pelvis), not to the ground")]
    return [_found(Kind.FLOOR_PARTIAL, Severity.CHECK,
                   f"no ankle in {missing} of {total} frames: the floor height is interpolated there",
                   "read heights there as estimates",
                   f"no ankle visible in {missing} of {total} frames: the floor was not seen there, so the pelvis's "
                   f"height above it is interpolated from the nearest frames that saw it", true_runs(unseen))]


@dataclass(frozen=True)
class SwitchLimits:
    """How far one person's 2D pelvis can move: a jump between two present frames ``g``
    frames apart at 30 fps (``(frame difference) * 30 / fps``) beyond
    ``jump_torsos + per_extra_frame * max(g - 1, 0)`` torso lengths (pelvis -> thorax in
    pixels, the larger of the two frames') is another person.

    Attributes:
        jump_torsos: the largest jump between consecutive frames at 30 fps, torso lengths.
        per_extra_frame: the largest further jump per frame of a gap, torso lengths.
        provenance: the fit's command, data, split and where each value was reached.
    """

    jump_torsos: float
    per_extra_frame: float
    provenance: Mapping = field(default_factory=dict)

    def limit(self, gap_frames_30fps: np.ndarray | float) -> np.ndarray:
        """The largest jump (torso lengths) one person makes over a gap of
        ``gap_frames_30fps`` frames at 30 fps (any shape, float)."""
        return self.jump_torsos + self.per_extra_frame * np.maximum(np.asarray(gap_frames_30fps, float) - 1.0, 0.0)


@lru_cache(maxsize=4)
def load_switch_limits(path: str | Path | None = None) -> SwitchLimits:
    """Read :class:`SwitchLimits` from JSON (``jump_torsos``, ``per_extra_frame``,
    ``provenance``; default: the shipped :data:`SWITCH_LIMITS_PATH`, written by
    ``python -m benchmarks.fit_track_switch --data ../shared/data``).

    Raises:
        FileNotFoundError: no such file.
        InputError: not JSON, or a field missing or not a positive finite number (named).
    """
    return _read_limits(SwitchLimits, SWITCH_LIMITS_PATH if path is None else path,
                        ("jump_torsos", "per_extra_frame"), "person-switch limits", "a positive number of torso lengths")


def _track_points(keypoints2d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(pelvis (T, 2) px, torso (T,) px, present (T,) bool)``: the 2D pelvis, the pelvis ->
    thorax length, and the frames with both (the frames a 2D track has a position in)."""
    # Two columns read (a long recording's keypoints are on disk, read a block at a time).
    pelvis, thorax = (np.asarray(keypoints2d[:, j, :2], np.float64) for j in (PELVIS, THORAX))
    torso = np.linalg.norm(thorax - pelvis, axis=1)
    return pelvis, torso, np.isfinite(pelvis).all(axis=1) & np.isfinite(torso) & (torso > 0)


def track_present(keypoints2d: np.ndarray) -> np.ndarray:
    """``(T,)`` bool: the frames of ``keypoints2d`` ``(T, 17, >=2)`` (H36M-17 px, NaN =
    missing) with a pelvis and a thorax, where :func:`track_segments` measures the track."""
    return _track_points(keypoints2d)[2]


def pelvis_jumps(keypoints2d: np.ndarray, fps: float,
                 max_gap_30fps: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The 2D pelvis's jumps in torso lengths (pelvis -> thorax in pixels, the larger of the
    two frames'), as :func:`track_segments` measures them, between consecutive present frames
    (those with a pelvis and a thorax; ``max_gap_30fps`` None) or between every pair of
    present frames at most ``max_gap_30fps`` frames at 30 fps apart.

    Args:
        keypoints2d: ``(T, 17, >=2)`` H36M-17 pixels; NaN = missing.
        fps: frame rate in Hz (> 0).
        max_gap_30fps: the longest gap, frames at 30 fps; None: consecutive present frames.

    Returns:
        ``(first, second, gap, jump)``: ``(N,)`` int frame indices, ``(N,)`` float the gap in
        frames at 30 fps, ``(N,)`` float the jump in torso lengths.
    """
    pelvis, torso, present = _track_points(keypoints2d)
    present = np.flatnonzero(present)
    pairs = [(present[:-1], present[1:])]
    if max_gap_30fps is not None:
        for step in range(2, len(present)):
            a, b = present[:-step], present[step:]
            near = (b - a) * 30.0 / fps <= max_gap_30fps
            if not near.any():  # present frames are sorted: a longer step only widens the gaps
                break
            pairs.append((a[near], b[near]))
    a, b = (np.concatenate(side).astype(int) for side in zip(*pairs))
    jump = np.linalg.norm(pelvis[b] - pelvis[a], axis=1) / np.maximum(torso[a], torso[b])
    return a, b, (b - a) * 30.0 / fps, jump


def track_segments(keypoints2d: np.ndarray, fps: float,
                   limits: SwitchLimits | None = None) -> tuple[np.ndarray, list[tuple[int, float]]]:
    """Split a 2D track where it jumps farther than one person can move: a tracker that
    switched to someone else.

    Between consecutive present frames (those with a pelvis and a thorax) the 2D pelvis may
    move at most ``limits.limit(gap)`` torso lengths (:class:`SwitchLimits`; default the
    shipped fit, :func:`load_switch_limits`, decision 0072).

    Args:
        keypoints2d: ``(T, 17, 3)`` H36M-17 x_px, y_px, confidence; NaN = missing.
        fps: frame rate in Hz (> 0).
        limits: the person-switch limits (default: the shipped ones).

    Returns:
        ``(segment (T,) int, events)``: ``segment`` numbers the stretches between jumps from
        0 (frames without a pelvis or thorax keep the number of the stretch they lie in);
        ``events`` lists ``(first frame after the jump, jump in torso lengths)``.
    """
    limits = limits or load_switch_limits()
    _, after, gap, jump = pelvis_jumps(keypoints2d, fps)
    switch = jump > limits.limit(gap)
    starts = np.zeros(len(keypoints2d), int)
    starts[after[switch]] = 1  # each frame after a jump opens a stretch
    events = [(int(frame), float(j)) for frame, j in zip(after[switch], jump[switch])]
    return np.cumsum(starts), events


def lifter_frame_flag(turn_deg: float, tolerance_deg: float, tolerance_is: str = "95 % interval",
                      focal_known: bool = False) -> list[Finding]:
    """A flag when an adapter turned the lifter's output into the camera frame by more than
    the run's own tilt uncertainty (``tolerance_deg``: the larger of the camera pitch and
    roll 95 % half-widths, or the per-frame bound where no interval is printed;
    ``tolerance_is`` names which, as the summary states it). ``focal_known``: the turn used the
    camera's focal length (``--focal-px`` or the file's own camera matrix), so the flag does
    not ask for it and is a note (:attr:`Severity.INFO`), not a warning.

    The turn rests on an assumption the file cannot confirm (MediaPipe's world landmarks
    answer in a virtual camera aimed at the person: adapters/mediapipe.py). On real videos
    with known gravity it helped where the cameras looked down at the person and hurt where
    one looked up at him (benchmarks/results/gravity_benchmark.txt and vanishing_gravity.txt:
    the Sports2D demo errs 16 deg turned by 15.5 deg, 6 untouched), so the tilt may be off by
    up to about the turn beyond its interval. ``turn_deg`` 0 (no turn) or a non-finite
    tolerance gives none.
    """
    if not (turn_deg > 0 and np.isfinite(tolerance_deg)) or turn_deg <= tolerance_deg:
        return []
    advice = ("compare a run with the person near the image centre" if focal_known else
              "give the video's true focal length (--focal-px; docs/video.md says how to get it from a calibration or "
              "the phone's 35 mm equivalent), or compare a run with the person near the image centre")
    # with the focal length known nothing is left to act on: a note, not a warning (a coach's
    # trial met it on every phone clip and again after giving --focal-px)
    return [_found(Kind.LIFTER_TURN, Severity.INFO if focal_known else Severity.CHECK,
                   f"lifter output turned {turn_deg:.1f} deg into the camera, beyond the tilt's {tolerance_deg:.1f} "
                   f"deg uncertainty",
                   # with the focal length given there is nothing left to give (a coach's trial read
                   # "check the result" as a task with no content)
                   "take the tilt as uncertain by up to the turn" if focal_known else "give --focal-px (docs/video.md)",
                   f"the lifter's output was turned by a median {turn_deg:.1f} deg into the real camera "
                   f"({'with its known focal length; ' * focal_known}MediaPipe's landmarks taken as seen from a "
                   f"virtual camera aimed at the person, an assumption the file cannot confirm), more than the tilt's "
                   f"stated uncertainty ({tolerance_deg:.1f} deg, {tolerance_is}): the camera tilt may be off by up "
                   f"to about the turn; {advice}")]


def one_person_frames(segment: np.ndarray) -> np.ndarray:
    """``(T,)`` bool: the frames of the longest stretch of :func:`track_segments`'s
    ``segment`` ``(T,)`` int (all True for a track without jumps; the first of equally long
    stretches)."""
    segment = np.asarray(segment)
    if not len(segment):
        return np.zeros(0, bool)
    return segment == int(np.argmax(np.bincount(segment)))


def track_switch_flag(segment: np.ndarray, events: list[tuple[int, float]], *,
                      person_option: bool = True, own_estimator: bool = False,
                      roi_given: bool = False, keypoints2d: np.ndarray | None = None,
                      picture: tuple[int, int] | None = None) -> list[Finding]:
    """A flag naming the jumps and the frames outside the longest stretch (the finding's
    frames: probably another person), and, with the 2D keypoints, where in the picture the
    person followed is: a physiotherapist's run followed a bystander for its longest stretch
    and was not told whose numbers it gave.

    Args:
        segment: ``(T,)`` int, :func:`track_segments`'s stretch of each frame.
        events: :func:`track_segments`'s ``(frame, jump in torso lengths)`` pairs.
        person_option: the 2D format has several tracks to choose from (``--person``);
            otherwise the advice is to re-run the tracker or leave those frames out.
        own_estimator: the 2D keypoints are pcnet's own estimator's (``--video`` alone), which
            follows one person with no track to choose or tracker to re-run: the advice is
            ``--roi`` around the person, or to leave those frames out.
        roi_given: that estimator already saw a ``--roi``, which the other person enters: the
            advice is a narrower one (a coach's run with a ``--roi`` was told to give one).
        keypoints2d: ``(T, 17, 3)`` H36M-17 pixels (as displayed) and confidence of the track
            (may be on disk: read a block of frames at a time), or ``None``; with them the
            headline names the followed stretch's median pelvis.
        picture: ``(width, height)`` px of the picture the keypoints are in, or ``None``; with
            it the headline says the pelvis's place in words (:func:`place_in_picture`: a
            coach's trial could not tell whom ``(644, 260) px`` was) and the detail both.
    """
    if not events:
        return []
    main_frames = one_person_frames(segment)
    main = int(segment[np.argmax(main_frames)])
    suspect = int((~main_frames).sum())
    followed = np.flatnonzero(main_frames)
    pelvis = None if keypoints2d is None else _median_pelvis_px(keypoints2d, main_frames)
    jumps = ", ".join(f"frame {f} ({j:.1f} torso lengths)" for f, j in events[:5])
    more = f" and {len(events) - 5} more" if len(events) > 5 else ""
    if person_option:
        action = advice = "check --person"
    elif own_estimator and roi_given:
        action = "narrow --roi to where the person stays (docs/video.md)"
        advice = ("pcnet's pose estimator follows whoever it finds, and another person enters the --roi given: run "
                  "again with a narrower --roi X,Y,W,H, the region the person stays in and the other does not enter "
                  "(pixels, as displayed; docs/video.md), or leave those frames out")
    elif own_estimator:
        action = "give --roi around the person (docs/video.md)"
        advice = ("pcnet's pose estimator follows whoever it finds: run again with --roi X,Y,W,H, the region of the "
                  "video (pixels, as displayed) the person stays in (docs/video.md), or leave those frames out")
    else:
        action = f"track one person, or drop track_segment != {main}"
        advice = "this 2D format has one track: re-run the tracker on one person, or leave those frames out"
    at = f"frame{'s' * (len(events) > 1)} {', '.join(str(f) for f, _ in events[:5])}{more}"
    if pelvis is None:
        headline, whom = f"2D track switches person at {at}; {suspect} frames probably someone else", ""
    else:
        x, y = (int(round(v)) for v in pelvis)
        where = None if picture is None else place_in_picture(pelvis, picture)
        place = "" if where is None else f", {where}"
        # two frames at most, so that the person followed stays within the headline's width; the place in
        # words where the picture is known (a coach could not tell whom "(644, 260) px" was), its pixels in the detail
        first = f"frame{'s' * (len(events) > 1)} {', '.join(str(f) for f, _ in events[:2])}" + \
            (f" +{len(events) - 2} more" if len(events) > 2 else "")
        whereabouts = f"({x}, {y}) px" if where is None else f"the {where}"
        headline = f"2D track switches at {first}; followed the person at {whereabouts}"
        whom = (f"; the results (the up, the floor, the world frame's axes) follow the longest stretch, frames "
                f"{followed[0]}-{followed[-1]}, whose pelvis lies at about ({x}, {y}) px in the picture{place} (x "
                f"right, y down, as displayed): if that is not the subject, the run measured someone else")
    return [_found(Kind.TRACK_SWITCH, Severity.PROBLEM, headline, action,
                   f"2D track probably switches person: jumps at {jumps}{more}; {suspect} frames lie outside the "
                   f"longest stretch (track_segment != {main} in canonical.npz and kinematics.csv){whom}; {advice}",
                   true_runs(~main_frames))]


def place_in_picture(point: np.ndarray, picture: tuple[int, int]) -> str:
    """Where the pixel ``point`` ``(x, y)`` (x right, y down) lies in a ``(width, height)``
    picture, in words: its third across (left, centre, right) and down (top, middle, bottom),
    ``"top left"`` ... ``"centre"`` ... ``"bottom right"``; outside the picture, the nearest
    third's words."""
    col, row = (min(max(int(3 * v / size), 0), 2) for v, size in zip(point, picture))
    if (col, row) == (1, 1):
        return "centre"
    return f"{('top', 'middle', 'bottom')[row]} {('left', 'centre', 'right')[col]}"


def _median_pelvis_px(keypoints2d, frames: np.ndarray) -> np.ndarray | None:
    """``(2,)`` the median 2D pelvis (px) of ``keypoints2d`` ``(T, 17, 3)`` (read a block of
    frames at a time: may be on disk) over the ``(T,)`` bool ``frames``; ``None`` where it is
    nowhere finite."""
    picked = []
    for rows in frame_blocks(len(frames)):
        pelvis = np.asarray(keypoints2d[rows])[frames[rows], PELVIS, :2]
        picked.append(pelvis[np.isfinite(pelvis).all(-1)])
    picked = np.concatenate(picked) if picked else np.empty((0, 2))
    return np.median(picked, axis=0) if len(picked) else None


def no_world_frame_flag(mode: str) -> list[Finding]:
    """The flag of a run without a fixed world frame (mode ``frame`` or ``smooth``): its
    kinematics are in the per-frame canonical frame."""
    return [_found(Kind.NO_WORLD_FRAME, Severity.CHECK,
                   f"no fixed world frame (mode {mode}): kinematics in the canonical frame, which turns",
                   "--mode sequence if the camera was static",
                   f"no fixed world frame: mode {mode} (a moving camera, or one the up estimates disagree on) has no "
                   f"fixed heading, so positions, velocities and accelerations are in the per-frame canonical frame, "
                   f"which turns with the pelvis (rotating-frame terms); use --mode sequence if the camera was static")]


def no_opensim_flag() -> list[Finding]:
    """The flag of ``--opensim`` without a world frame: no ``world.trc``, so no inverse kinematics."""
    return [_found(Kind.NO_OPENSIM, Severity.PROBLEM,
                   "no OpenSim IK: a moving camera (mode frame/smooth) has no world.trc",
                   "--mode sequence if the camera was static",
                   "no OpenSim inverse kinematics (--opensim): a moving camera (mode frame or smooth) has no fixed "
                   "world frame and no world.trc; use --mode sequence if the camera was static")]


def implausible_motion_findings(found: Sequence[ImplausibleMotion],
                                limits: MotionLimits | None = None, fps_typed: bool = False) -> list[Finding]:
    """One finding per quantity (speed, acceleration) of
    :func:`pcnet.stages.plausibility.implausible_motion`'s runs: the full text of
    :func:`pcnet.stages.plausibility.implausible_motion_flags`, a headline with the first two
    frame ranges and the joint furthest beyond its limit, and all the runs' frames merged.
    ``fps_typed``: the frame rate came from ``--fps`` alone (no video or file stated one), so
    the action asks to check it first: speeds scale with it, accelerations with its square."""
    details = implausible_motion_flags(found, limits)  # one per quantity found, in QUANTITIES' order
    out = []
    for quantity, detail in zip([q for q in QUANTITIES if any(f.quantity == q for f in found)], details):
        mine = [f for f in found if f.quantity == quantity]
        over = np.zeros(max(f.last_frame for f in mine) + 1, bool)
        for f in mine:
            over[f.first_frame:f.last_frame + 1] = True
        runs = true_runs(over)
        where = ", ".join(f"{a}" if b == a + 1 else f"{a}-{b - 1}" for a, b in runs[:2])
        where = (f"frame{'s' * (len(runs) > 1 or runs[0][1] > runs[0][0] + 1)} {where}"
                 + (f" +{len(runs) - 2} more" if len(runs) > 2 else ""))
        worst = max(mine, key=lambda f: f.peak / f.limit)
        digits = 1 if quantity == "speed" else 0
        kind = Kind.IMPLAUSIBLE_SPEED if quantity == "speed" else Kind.IMPLAUSIBLE_ACCELERATION
        out.append(_found(kind, Severity.CHECK,
                          f"implausible {quantity} in {where}: {worst.joint.replace('_', ' ')} "
                          f"{worst.peak:.{digits}f} {worst.unit} (limit {worst.limit:.{digits + 1}f})",
                          # a wrong rate scales every frame's speed alike; a few frames' spike is the lifter's
                          ("check --fps if the speeds are high throughout, else " if fps_typed else "")
                          + "leave those frames out (implausible_motion = 1)",
                          detail, runs))
    return out


def opensim_fit_findings(fit: dict) -> list[Finding]:
    """The findings of OpenSim's fit (:func:`pcnet.stages.opensim_ik.scale_and_ik`'s result):
    segments left unscaled (:func:`pcnet.stages.opensim_ik.unscaled_segments_flag`), a marker
    RMS above the best-practice bound (:func:`pcnet.stages.opensim_ik.marker_rms_flag`) and the
    scaled model's legs out of proportion (:func:`pcnet.stages.opensim_ik.model_leg_asymmetry_flag`,
    of the kind :data:`Kind.LEG_ASYMMETRY`, which a run that already has the poses' own drops),
    each with that function's text as its detail. Any other text of the fit's ``warnings`` is
    kept as a :data:`Severity.CHECK` finding of no kind (:func:`shortened`)."""
    out = []
    if unscaled := unscaled_segments_flag(fit):
        out.append(_found(Kind.SEGMENTS_UNSCALED, Severity.CHECK,
                          f"OpenSim segments {', '.join(fit['segments_not_scaled'])} not scaled: no frame has their "
                          f"markers", "read those segments' angles with care", unscaled))
    if rms := marker_rms_flag(fit):
        out.append(_found(Kind.MARKER_RMS, Severity.CHECK,
                          f"OpenSim marker RMS {100 * fit['marker_rms_m']:.1f} cm (max {100 * fit['marker_max_m']:.1f} "
                          f"cm): the model does not follow the poses",
                          "read ik.mot's angles with care (ik_marker_errors.sto: which markers it misses)", rms))
    if legs := model_leg_asymmetry_flag(fit):
        difference, shorter = model_leg_asymmetry(fit)
        out.append(_found(Kind.LEG_ASYMMETRY, Severity.CHECK,
                          f"OpenSim model's legs differ {100 * difference:.0f} % in length ({shorter} shorter): the "
                          f"lifter's", "compare left and right with care", legs))
    known = {f.detail for f in out}
    return out + [Finding(Severity.CHECK, shortened(text), "see report.md", text) for text in fit["warnings"]
                  if text not in known]


def ranked(findings: Iterable[Finding]) -> list[Finding]:
    """``findings`` most severe first; within one severity in :class:`Kind`'s declared order,
    findings of no kind last, then as given.

    Why: a reader gives a summary a few seconds, so what makes part of the result wrong
    (:data:`Severity.PROBLEM`: a 2D track that switched person, swapped or mirrored sides, wrong
    units, data missing for the whole recording) comes before what makes some numbers less
    certain (:data:`Severity.CHECK`: a tilt that may be off, implausible speeds, frames whose
    floor was not seen), and both before what was merely assumed or done (notes,
    :data:`Severity.INFO`). Within a severity the declared order puts causes before their
    symptoms (a track switch before the implausible speeds it causes)."""
    return sorted(findings, key=lambda f: (-int(f.severity), len(Kind) + 1 if f.kind is None else int(f.kind)))


# --- notes -----------------------------------------------------------------------------------
# Notes (what was assumed or done) are text made across the pipeline: the adapters, the
# estimator, the kinematics and the sinks. Each is one INFO line in the summary: the few kinds
# below, keyed by how their text begins, get their own short line; any other is shortened.


def missing_data_line(counts: Mapping, nonfinite: Mapping[str, int]) -> str:
    """The run summary's line on missing data, from the counts the full note words
    (:func:`pcnet.stages.kinematics.format_flag_counts` with
    :func:`pcnet.adapters.validate.nonfinite_line`): a per-joint list of two or more joints
    becomes a joint count and the joint most affected, ``"missing: 2 joints (most: left_elbow 74
    of 120 frames); no joint at all: 8 frames"``; ``''`` when nothing is missing, unfiltered or non-finite.

    Args:
        counts: :func:`pcnet.stages.kinematics.flag_counts`' dict (``missing_with_pose``,
            ``frames_without_pose``, ``unfiltered``).
        nonfinite: joint name -> frames the lifter's file held as inf/NaN
            (:attr:`pcnet.adapters.Poses3D.nonfinite`).
    """
    def per_joint(what: str, frames: Mapping[str, int]) -> str:
        if len(frames) == 1:
            ((joint, n),) = frames.items()
            return f"{what}: {joint} {frames_phrase(n, counts.get('frames'))}"
        n, joint = max((n, joint) for joint, n in frames.items())
        return f"{what}: {len(frames)} joints (most: {joint} {frames_phrase(n, counts.get('frames'))})"

    parts = []
    if counts["missing_with_pose"]:
        parts.append(per_joint("missing", counts["missing_with_pose"]))
    if counts["frames_without_pose"]:
        parts.append(f"no joint at all: {frames_phrase(counts['frames_without_pose'])}")
    if len(nonfinite) > 1:
        parts.append(f"inf/NaN in the input: {len(nonfinite)} joints")
    elif nonfinite:
        parts.append(per_joint("input: non-finite values read as missing", nonfinite))
    if counts["unfiltered"]:
        parts.append(per_joint("unfiltered", counts["unfiltered"]))
    return _clipped("; ".join(parts))


#: An OpenSim coordinate's name in a note (``pro_sup_r``): a word with an underscore.
_COORDINATE_NAME = r"[A-Za-z]\w*_\w+"

#: ``(pattern, line)``: a note whose text the pattern matches from its start (``re.match``,
#: DOTALL) is summarised by ``line(match)``.
NOTE_LINES: tuple[tuple[str, Callable[[re.Match], str]], ...] = (
    (r"MediaPipe world landmarks turned from the virtual camera .*\(focal length (?P<f>\d+) px, "
     r"(?P<how>[^:;]*).*turn median (?P<med>\S+),",
     lambda m: f"MediaPipe poses turned from the virtual camera by a median {m['med']} deg "
               f"(focal length {m['f']} px, {m['how']})"),
    (r"poses: (?P<est>.*?) on the video(?P<roi>(?: inside --roi \S+)?), a person in (?P<n>\d+) of (?P<of>\d+) "
     r"frames; saved as (?P<file>\S+)",
     lambda m: f"poses: {m['est']} on the video, a person in {m['n']} of {m['of']} frames"),  # --roi: as typed
    (r"low-pass cutoff (?P<hz>\S+) Hz by residual analysis \(Winter; noise (?P<noise>[^;]*);",
     lambda m: f"low-pass cutoff {m['hz']} Hz by residual analysis (Winter; noise {m['noise']})"),
    (r"3D joints remapped from (?P<layout>\S+) to H36M-17 with (?P<built>.*?) built as means",
     lambda m: f"3D joints remapped from {m['layout']} to H36M-17 with {m['built']} built from others"),
    # the moving-camera note's line keeps its other cause: a static tripod under a side bend
    (r"per-frame up spreads (?P<spread>\S+) deg",
     lambda m: f"per-frame up spreads {m['spread']} deg: a leaning body (no action) or a moving "
               f"camera (--mode smooth)"),
    # a list of locked coordinates cut short reads as the whole list (a user trial: "ankle_angle_r,
    # subtalar_angle_r, mtp_angle_r" of 12)
    (r"ik\.mot: locked in the model \(.*?\), not measured: (?P<held>.*)",
     lambda m: f"ik.mot: {len(re.findall(_COORDINATE_NAME, m['held']))} coordinates locked in the model, "
               f"not measured (report.md names them)"),
    # which person of several: another choice is another subject, so the way to choose stays
    (r"2D keypoints: track (?P<track>\S+) chosen (?P<how>as the highest summed per-frame score|by person=)(?P<rest>.*)",
     lambda m: shortened(m.string) if m['how'] == "by person=" else
     f"2D keypoints: track {m['track']} chosen {m['how']}"
     + ("; --person chooses another" if "--person chooses another" in m['rest'] else "")),
)


def shortened(text: str, width: int = HEADLINE_WIDTH) -> str:
    """A note (or a flag of no kind) as one line of at most ``width`` characters: the
    parenthesised asides dropped, then the longest run of whole clauses (ending before a
    ``"; "``, else a ``": "``, else a ``", "``) that fits and keeps half the width, else the
    longest that fits, else cut at a word boundary; a line that drops a clause ends in ``...``
    (report.md has the rest: an OpenSim trial's terminal line dropped the frames whose fit
    failed without a sign that more followed)."""
    if len(text) <= width:
        return text
    depth, kept = 0, []
    for ch in text:
        depth += ch == "("
        if depth == 0:
            kept.append(ch)
        depth -= ch == ")" and depth > 0
    short = re.sub(r"\s+([,;:.])", r"\1", re.sub(r" {2,}", " ", "".join(kept))).strip()
    if len(short) <= width:
        return short
    clause_ends = {sep: [m.start() for m in re.finditer(re.escape(sep), short) if m.start() <= width - 3]
                   for sep in ("; ", ": ", ", ")}
    for ends in clause_ends.values():
        if ends and ends[-1] >= width // 2:
            return short[:ends[-1]] + "..."
    if any(clause_ends.values()):  # a short whole clause reads better than a phrase cut off
        return short[:max(ends[-1] for ends in clause_ends.values() if ends)] + "..."
    return _clipped(short, width)


def note_finding(text: str) -> Finding:
    """The :data:`Severity.INFO` :class:`Finding` of one note: its line by :data:`NOTE_LINES`,
    else :func:`shortened`."""
    for pattern, line in NOTE_LINES:
        m = re.match(pattern, text, re.DOTALL)
        if m:
            return Finding(Severity.INFO, shortened(line(m)), "", text)
    return Finding(Severity.INFO, shortened(text), "", text)
