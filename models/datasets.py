"""Mocap datasets: loading, clip splits, and (input, canonical target, R) pairs.

Pure numpy, so evaluation runs without torch. Every random choice draws from a
``numpy.random.Generator`` seeded by the caller: same seed, same pairs.

Mocap format (``shared/data/README.md``): an ``.npz`` with one float32 ``(T, 17, 3)``
array per clip (H36M-17, metres, world frame with +Y up, pelvis not centred), and
optionally a ``.json`` beside it mapping clip name -> ``{"frames", "fps", ...}``.
"""

from __future__ import annotations

import json
import re
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pcnet.models.lifter_noise import LifterNoise, apply_lifter_noise
from pcnet.stages.core.canonical import canonical_rotation, to_canonical
from pcnet.stages.core.conventions import (
    H36M_JOINTS, H36M_MIRROR_ORDER, H36M_PARENTS, HEAD, NECK_NOSE, PELVIS, SPINE, THIGH_RANGE_M, THORAX, median_thigh_length,
    validate_fps, validate_poses)
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.rotations import axis_rotation, sample_camera_rotations

SPLITS = ("train", "val", "test", "all")
#: Frame rate (Hz) of a clip whose metadata json gives none (the shared sets' json do).
DEFAULT_MOCAP_FPS = 30.0


@dataclass(frozen=True)
class Clip:
    name: str
    joints: np.ndarray  # (T, 17, 3) world frame, metres
    fps: float
    # Performer id from the metadata json (CMU: "subject"); None where the source has none.
    subject: int | None = None
    # False where the metadata json gives no fps and DEFAULT_MOCAP_FPS was assumed.
    fps_stated: bool = True


def load_numpy_file(path: Path, what: str):
    """Open a ``.npy`` or ``.npz`` without pickles, like ``np.load(path, allow_pickle=False)``.

    Returns:
        the array of a ``.npy``, or for a ``.npz`` an ``np.lib.npyio.NpzFile``
        (:class:`pcnet.adapters.validate.NumpyArchive`) whose ``[key]`` raises
        :class:`~pcnet.stages.core.errors.InputError` for a damaged or pickled member.

    Raises:
        FileNotFoundError: missing file (naming ``path`` and ``what``).
        InputError: ``"PATH: not a readable WHAT file ([member 'KEY': ]expected ..., got
            ...)"``: not numpy at all (a CSV is called that, not "pickled data"), a damaged
            file or header, a pickled object array, an array larger than half the available
            memory, or an ``.npz`` whose declared sizes are a zip bomb's
            (:func:`pcnet.adapters.validate.open_numpy`).
    """
    # Imported here: the adapters package loads OpenCV, which datasets users rarely need.
    from pcnet.adapters.types import AdapterError
    from pcnet.adapters.validate import open_numpy

    path = Path(path)
    if not path.exists():
        where = "" if path.is_absolute() else f" (relative to the working directory {Path.cwd()})"
        raise FileNotFoundError(f"{path}: {what} file not found{where}")
    if not path.is_file():
        raise InputError(f"{path}: expected a regular {what} file, got a folder, device or pipe")
    try:
        return open_numpy(path)
    except AdapterError as err:
        # An .npz refused for a member's declared sizes names the member; the expectation
        # says which bound (a zip bomb's expansion, the memory available).
        where = "" if err.field in ("path", "content") else f"member {err.field!r}: "
        raise InputError(f"{path}: not a readable {what} file ({where}expected {err.expected}, got {err.got})") from err


def load_mocap(path: str | Path) -> list[Clip]:
    """Load every clip of a mocap ``.npz`` (sorted by name).

    A clip's frame rate is the ``fps`` of its entry in the ``.json`` beside the file, else
    :data:`DEFAULT_MOCAP_FPS` with ``Clip.fps_stated`` False (it matters to the lifter-like
    noise's correlation time and to sequence modes' time windows, not to per-frame scores).

    Raises:
        FileNotFoundError: missing file.
        ValueError: not a readable npz, no arrays, an array that is not ``(T, 17, 3)``, a
            clip whose median thigh is outside :data:`~pcnet.stages.core.conventions.THIGH_RANGE_M`
            (not metres; the message names the file and the key), no frame with all 17 joints
            (naming the joints missing in every frame), or a ``.json`` entry whose ``frames``
            is not the clip's frame count.
    """
    path = Path(path)
    data = load_numpy_file(path, "mocap .npz")
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise InputError(f"{path}: expected an .npz with one (T, 17, 3) array per clip, got a single array")
    meta = read_sidecar(path.with_suffix(".json"))
    clips = []
    with data:
        if not data.files:
            raise InputError(f"{path}: the npz holds no clips")
        unknown = sorted(set(meta) - set(data.files))
        if unknown:  # a misspelt clip name would silently fall back to 30 fps
            raise InputError(f"{path.with_suffix('.json')}: expected clip names of {path.name}, got {len(unknown)} "
                             f"it does not hold: {', '.join(unknown[:3])}{' ...' if len(unknown) > 3 else ''}")
        for name in sorted(data.files):
            arr = validate_poses(data[name], f"{path} [clip {name}]", units="m", metres_only=True)
            if not np.isfinite(arr).all(axis=(1, 2)).any():
                never = [H36M_JOINTS[j] for j in np.flatnonzero(~np.isfinite(arr).all(axis=2).any(axis=0))]
                raise InputError(f"{path} [clip {name}]: expected at least one frame with all 17 joints, got none"
                                 + (f" ({', '.join(never)} missing in every frame)" if never else ""))
            thigh = median_thigh_length(arr)
            if not THIGH_RANGE_M[0] <= thigh <= THIGH_RANGE_M[1]:
                raise InputError(f"{path} [clip {name}]: expected metres (a median thigh of {THIGH_RANGE_M[0]}-"
                                 f"{THIGH_RANGE_M[1]} m), got a median hip -> knee length of {thigh:.3g}: "
                                 f"centimetres or millimetres? scale the file to metres")
            info = meta.get(name, {})
            if not isinstance(info, dict):
                raise InputError(f"{path.with_suffix('.json')}: field {name!r}: expected an object, got {info!r}")
            # a sidecar of another version of the file (resampled, cut) would give its clips a wrong frame rate
            if "frames" in info and info["frames"] != len(arr):
                raise InputError(f"{path.with_suffix('.json')}: clip {name}: field 'frames': expected {len(arr)} (the "
                                 f"clip's frames in {path.name}), got {info['frames']!r}: the sidecar of another "
                                 f"version of the file?")
            subject = info.get("subject")
            fps = validate_fps(info.get("fps", DEFAULT_MOCAP_FPS),
                               f"{path.with_suffix('.json')}: clip {name}: field 'fps'")
            clips.append(Clip(name, arr, fps,
                              subject if isinstance(subject, int) and not isinstance(subject, bool) else None,
                              fps_stated="fps" in info))
    return clips


#: A mocap file whose clips' mean trunk direction is at least this long (1 = every trunk
#: parallel) and this far from +Y is probably not in a +Y-up world frame (see
#: :func:`world_up_warning`).
UP_CHECK_MIN_LENGTH = 0.5
UP_CHECK_MAX_DEG = 45.0


def world_up_warning(clips: list[Clip], source: str | Path) -> str | None:
    """A one-line warning when ``clips`` are probably not in pcnet's +Y-up world frame
    (docs/CONVENTIONS.md), else ``None``.

    The mean over every frame of the unit trunk vector (pelvis -> thorax, world frame) is
    about +Y for upright people (Bandai 1.0 deg from +Y, length 0.99; CMU 1.7, 0.98;
    DeepMimic with its crawls and rolls 1.6, 0.96). A Z-up lab frame or a Y-down camera-like
    frame moves it to +Z or -Y, and every score computed from such a file is wrong. Subjects
    lying in one direction throughout give the same reading and cannot be told apart from the
    poses alone (only gravity's dynamics could), so this warns instead of refusing; lying
    subjects facing various ways average to a short vector and do not warn (the DeepMimic
    floor-motion fixture: length 0.45).
    """
    trunks = []
    for clip in clips:
        t = clip.joints[:, THORAX] - clip.joints[:, PELVIS]
        n = np.linalg.norm(t, axis=1)
        ok = np.isfinite(n) & (n > 0)
        trunks.append(t[ok] / n[ok, None])
    if not trunks or not sum(len(t) for t in trunks):
        return None
    mean = np.concatenate(trunks).mean(axis=0)
    length = float(np.linalg.norm(mean))
    angle = float(np.degrees(np.arccos(np.clip(mean[1] / length, -1.0, 1.0)))) if length > 0 else 0.0
    if length < UP_CHECK_MIN_LENGTH or angle <= UP_CHECK_MAX_DEG:
        return None
    axis = int(np.argmax(np.abs(mean)))
    along = ("+" if mean[axis] > 0 else "-") + "XYZ"[axis]
    return (f"{source}: expected a world frame with +Y up (docs/CONVENTIONS.md), but the subjects' trunks "
            f"(pelvis -> thorax) point along {along} on average, {angle:.0f} deg from +Y: a Z-up or Y-down file "
            f"gives wrong scores and targets (convert it to +Y up first); subjects lying one way throughout "
            f"read the same")


def assumed_fps_warning(clips: list[Clip], source: str | Path) -> str | None:
    """A one-line warning when some ``clips`` have no ``fps`` in the ``.json`` beside
    ``source`` and were read at :data:`DEFAULT_MOCAP_FPS`, else ``None``. Callers warn only
    where time matters: lifter-like noise, sequence modes, and frame mode's view gate, whose
    quarter turns are read over a window in seconds (``models/view_gate.py: WINDOW_S``); the
    geometric method's frame mode does not use it."""
    assumed = sum(not c.fps_stated for c in clips)
    if not assumed:
        return None
    sidecar = Path(source).with_suffix(".json")
    found = f"found none for {assumed} of {len(clips)} clips" if sidecar.is_file() else "found no such file"
    return (f"{sidecar}: expected each clip's 'fps' (the lifter-like noise's correlation time, sequence modes' "
            f"windows and the view gate's are in seconds), {found}: read at {DEFAULT_MOCAP_FPS:g} fps")


def read_sidecar(path: Path) -> dict:
    """The optional ``.json`` beside a mocap npz (clip name -> frames, fps, subject, ...);
    ``{}`` when there is none.

    Raises:
        InputError: it exists but is not a UTF-8 JSON object.
    """
    if not path.is_file():
        return {}
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as err:  # RecursionError: nested too deeply
        raise InputError(f"{path}: expected the mocap's JSON metadata, got unreadable content ({err})") from None
    if not isinstance(meta, dict):
        raise InputError(f"{path}: expected a JSON object (clip name -> metadata), got {type(meta).__name__}")
    return meta


def clip_split(name: str) -> str:
    """Deterministic split of a whole clip by its name: ``crc32(name) % 10`` in 0-7 ->
    train, 8 -> val, 9 -> test (about 80/10/10). Whole clips never straddle splits, but the
    takes of one motion and style do (the ``"clip"`` scheme of :func:`select_split`)."""
    return _bucket_split(name)


def _bucket_split(key: str) -> str:
    # zlib.crc32, not hash(): Python salts str hashes per process, a split must not move.
    bucket = zlib.crc32(key.encode("utf-8")) % 10
    return "train" if bucket < 8 else ("val" if bucket == 8 else "test")


SPLIT_SCHEMES = ("clip", "motion-style")

#: Bandai clip names, ``<dataset>_<motion>_<style>_<take>``: ``dataset-<n>``, then motion and
#: style as lower-case words joined by hyphens (never underscores), then a numeric take, e.g.
#: ``dataset-1_bow_active_001``, ``dataset-2_raise-up-left-hand_youthful_034``. All 3076
#: names of ``bandai_h36m17.npz`` match (226 groups; ``tests/test_heldout_eval.py``).
BANDAI_NAME = re.compile(r"(dataset-\d+)_([a-z0-9]+(?:-[a-z0-9]+)*)_([a-z0-9]+(?:-[a-z0-9]+)*)_(\d+)")
#: CMU Graphics Lab clip names, ``<subject>_<trial>`` (``008_01`` = subject 8, trial 1), as in
#: ``cmu_train_h36m17.npz``, whose json also gives ``subject`` (equal to the prefix for all 101).
CMU_NAME = re.compile(r"(\d{2,3})_(\d{2,3})")

#: Bandai styles held out of train and val and put whole into test, per dataset: the styles
#: with the lowest ``crc32("<dataset>/<style>")`` (a fixed rule, not a choice by results), 2 of
#: dataset-1's 15 styles and 1 of dataset-2's 7 (about 13 % and 14 % of each dataset's styles).
#: Style names recur across the two datasets ("feminine", "active", "normal"): a held-out
#: style is unseen in its own dataset only; the other dataset's takes under that name
#: (recorded separately, by other actors, some of the same motions: dataset-1's run_active and
#: walk_active, dataset-2's run_feminine) remain in train. A dataset not listed here holds no
#: style out.
HELDOUT_TEST_STYLES: dict[str, tuple[str, ...]] = {
    "dataset-1": ("feminine", "chimpira"),
    "dataset-2": ("active",),
}
#: How many styles :data:`HELDOUT_TEST_STYLES` holds out per dataset (the rule's quota).
HELDOUT_STYLE_COUNT = {"dataset-1": 2, "dataset-2": 1}

#: CMU subjects held out whole (``cmu_train_h36m17.json`` ``subject``). Chosen by hand so that each
#: held-out subject's activities are also done by a training subject (walks: 8; salsa: 61;
#: soccer kicks: 11; climbing, jumping, sitting, laughing: 13): the split measures new
#: people, not new activities. Train keeps 8, 9, 11, 13, 61 and any other subject.
CMU_HOLDOUT_SUBJECTS: dict[str, tuple[int, ...]] = {"val": (12, 60), "test": (10, 14)}


def parse_bandai_name(name: str) -> tuple[str, str, str, int] | None:
    """``(dataset, motion, style, take)`` of a Bandai clip name (:data:`BANDAI_NAME`), e.g.
    ``"dataset-1_bow_active_001"`` -> ``("dataset-1", "bow", "active", 1)``; ``None`` for any
    other name."""
    m = BANDAI_NAME.fullmatch(name)
    return None if m is None else (m.group(1), m.group(2), m.group(3), int(m.group(4)))


def clip_subject(clip: Clip) -> int | None:
    """The CMU subject of a clip: its metadata ``subject``, else the ``<subject>_<trial>``
    name prefix (:data:`CMU_NAME`); ``None`` for other clips."""
    if clip.subject is not None:
        return clip.subject
    m = CMU_NAME.fullmatch(clip.name)
    return None if m is None else int(m.group(1))


def group_key(clip: Clip) -> str | None:
    """The unit the ``"motion-style"`` scheme keeps whole: ``"<dataset>_<motion>_<style>"``
    for Bandai (all takes of one motion in one style), ``"cmu-subject-<id>"`` for CMU (all of
    one performer's clips); ``None`` for a clip with neither (e.g. DeepMimic)."""
    parsed = parse_bandai_name(clip.name)
    if parsed is not None:
        return "_".join(parsed[:3])
    subject = clip_subject(clip)
    return None if subject is None else f"cmu-subject-{subject}"


def motion_style_split(clip: Clip) -> str:
    """Split of a clip under the ``"motion-style"`` scheme (no group straddles splits).

    Bandai (:func:`parse_bandai_name`): a style of :data:`HELDOUT_TEST_STYLES` -> test;
    otherwise the whole ``(dataset, motion, style)`` group by ``crc32("<dataset>_<motion>_<style>")
    % 10``: 0-7 train, 8 val, 9 test. CMU (:func:`clip_subject`): subjects of
    :data:`CMU_HOLDOUT_SUBJECTS` -> val / test, every other subject -> train.

    Raises:
        InputError: a clip that is neither Bandai nor CMU (no motion, style or subject in its
            name or metadata): use split "all" (cross-dataset) or the "clip" scheme.
    """
    parsed = parse_bandai_name(clip.name)
    if parsed is not None:
        dataset, motion, style, _ = parsed
        if style in HELDOUT_TEST_STYLES.get(dataset, ()):
            return "test"
        return _bucket_split(f"{dataset}_{motion}_{style}")
    subject = clip_subject(clip)
    if subject is not None:
        for split, subjects in CMU_HOLDOUT_SUBJECTS.items():
            if subject in subjects:
                return split
        return "train"
    raise InputError(f"clip {clip.name!r}: split scheme 'motion-style' expected a Bandai name "
                     f"<dataset>_<motion>_<style>_<take> or a CMU subject number (name <subject>_<trial> or an "
                     f"integer json 'subject'), got neither; use split 'all' (cross-dataset) "
                     f"or split scheme 'clip'")


def clip_split_of(clip: Clip, scheme: str = "clip") -> str:
    """``"train"``/``"val"``/``"test"`` of one clip under ``scheme`` (:data:`SPLIT_SCHEMES`).

    Raises:
        InputError: unknown scheme, or a clip the scheme cannot place (:func:`motion_style_split`).
    """
    if scheme == "clip":
        return clip_split(clip.name)
    if scheme == "motion-style":
        return motion_style_split(clip)
    raise InputError(f"split scheme {scheme!r}: expected one of {SPLIT_SCHEMES}")


def select_split(clips: list[Clip], split: str, scheme: str = "clip") -> list[Clip]:
    """Clips of ``split`` (``train``/``val``/``test``/``all``) under ``scheme``.

    Schemes: ``"clip"`` (the default of this function, what releases 1-2 trained on:
    :func:`clip_split`, each take hashed alone, so most test clips have a sibling take of the
    same motion and style in train) and ``"motion-style"`` (what every config in
    ``configs/`` and the shipped weights use: :func:`motion_style_split`, whole Bandai
    motion-style groups and whole styles held out, CMU split by subject). ``"all"`` returns every clip under either scheme.

    On ``bandai_h36m17.npz`` (3076 clips, 226 groups): ``"clip"`` gives train / val / test
    2475 / 293 / 308 clips (333,044 / 39,986 / 43,815 frames), and 75 of the 89 test groups
    have a take in train; ``"motion-style"`` gives 1971 / 195 / 910 clips in 158 / 19 / 49
    groups (283,280 / 30,710 / 102,855 frames), 30 of the test groups from the held-out
    styles. On ``cmu_train_h36m17.npz``: val subjects 12, 60 (11 clips), test 10, 14 (28).

    Raises:
        InputError: unknown split or scheme, or (``"motion-style"``) a clip that is neither
            Bandai nor CMU.
    """
    if split not in SPLITS:
        raise InputError(f"unknown split {split!r}; expected one of {SPLITS}")
    if scheme not in SPLIT_SCHEMES:
        raise InputError(f"split scheme {scheme!r}: expected one of {SPLIT_SCHEMES}")
    return [c for c in clips if split == "all" or clip_split_of(c, scheme) == split]


def groups_in_split(clips: list[Clip], split: str, scheme: str = "clip") -> set[str]:
    """The :func:`group_key` of every clip of ``split`` under ``scheme`` (clips without a
    group count under their own name): which motion-style groups (CMU subjects) a model
    trained on that split has seen at least one take of."""
    return {group_key(c) or c.name for c in select_split(clips, split, scheme)}


@dataclass(frozen=True)
class Augmentation:
    """Skeleton-proportion augmentation, applied per clip in the canonical frame (the target
    changes with it). Bandai's hips are about 0.13 m wide, Human3.6M's about 0.25 m, so
    the hip bones get the widest range (shared/data/README.md)."""

    hip_width: tuple[float, float] = (0.9, 2.1)
    shoulder_width: tuple[float, float] = (0.85, 1.35)
    other_bones_sigma: float = 0.07
    # Share of clips mirrored left-right (sagittal plane, left and right joints swapped): the
    # mirror image of a movement is a movement people make (a left kick for a right one);
    # flip augmentation as in VideoPose3D (Pavllo et al., CVPR 2019, section 4). 0 = none.
    mirror_fraction: float = 0.0
    # Habitual posture differs between people: standing trunk inclination and forward head
    # posture vary by several degrees across healthy adults, and a network that learned a
    # few actors' posture reads another person's lean as camera tilt. Per clip, the upper
    # body (spine and everything above, joints 7-16) turns about the pelvis by a sagittal
    # and a lateral angle, and the neck and head (9, 10) about the thorax by a further
    # sagittal angle, each ~ N(0, sigma^2) in degrees, legs and gravity unchanged. 0 = none.
    trunk_sagittal_sigma_deg: float = 0.0
    trunk_lateral_sigma_deg: float = 0.0
    head_sagittal_sigma_deg: float = 0.0


@dataclass(frozen=True)
class Noise:
    """Upstream-like noise on the camera-frame input only (metres, camera frame): monocular
    lifters err most along the camera's depth axis."""

    jitter_m: float = 0.015
    depth_m: float = 0.04
    bone_scale_sigma: float = 0.04
    drop_prob: float = 0.01
    # Share of poses that get the noise; the rest stay clean, so a model trained with
    # fraction < 1 stays precise on clean inputs (mocap, good lifters) as well.
    fraction: float = 1.0


def _bone_scale(X: np.ndarray, factors: np.ndarray) -> np.ndarray:
    """Scale each bone vector of ``X`` ``(N, 17, 3)`` by ``factors`` ``(N, 17)`` (indexed by
    child joint), rebuilding positions outward from the pelvis."""
    out = X.copy()
    for child, parent in enumerate(H36M_PARENTS):
        if parent >= 0:
            out[:, child] = out[:, parent] + factors[:, child, None] * (X[:, child] - X[:, parent])
    return out


_MIRROR_Z = np.diag([1.0, 1.0, -1.0])


def mirror_canonical(canon: np.ndarray) -> np.ndarray:
    """The left-right mirror image of canonical poses ``(N, 17, 3)`` (any units): ``z -> -z``
    (the subject's right) and every left joint swapped with its right one, so that the result
    is again in the canonical frame (right hip at +z, docs/CONVENTIONS.md)."""
    return (np.asarray(canon) * np.array([1.0, 1.0, -1.0]))[:, list(H36M_MIRROR_ORDER)]


def _proportion_factors(n: int, aug: Augmentation, rng: np.random.Generator) -> np.ndarray:
    f = np.clip(rng.normal(1.0, aug.other_bones_sigma, (n, 17)), 0.8, 1.2)
    hip = rng.uniform(*aug.hip_width, n)
    sho = rng.uniform(*aug.shoulder_width, n)
    f[:, [1, 4]] = hip[:, None]
    f[:, [11, 14]] = sho[:, None]
    # left and right limbs of one body keep equal lengths
    for left, right in ((5, 2), (6, 3), (12, 15), (13, 16)):
        f[:, right] = f[:, left]
    return f


_UPPER_BODY = np.arange(SPINE, 17)
_HEAD = np.array([NECK_NOSE, HEAD])


def posture_rotations(n: int, aug: Augmentation, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray] | None:
    """Per-clip posture turns of :class:`Augmentation` (canonical frame: +Y up, +Z the
    subject's right, so sagittal = about Z, lateral = about X): ``(trunk, head)``, each
    ``(n, 3, 3)`` float64; ``None`` without drawing when every sigma is 0, so that configs
    without posture augmentation keep their random stream."""
    if not (aug.trunk_sagittal_sigma_deg or aug.trunk_lateral_sigma_deg or aug.head_sagittal_sigma_deg):
        return None
    sagittal = rng.normal(0.0, aug.trunk_sagittal_sigma_deg, n)
    lateral = rng.normal(0.0, aug.trunk_lateral_sigma_deg, n)
    head = rng.normal(0.0, aug.head_sagittal_sigma_deg, n)
    trunk = axis_rotation("z", np.radians(sagittal)) @ axis_rotation("x", np.radians(lateral))
    return trunk, axis_rotation("z", np.radians(head))


def apply_posture(canon: np.ndarray, trunk: np.ndarray, head: np.ndarray) -> np.ndarray:
    """Canonical poses ``(N, 17, 3)`` with the upper body turned by ``trunk`` ``(N, 3, 3)``
    about the pelvis and then the neck and head by ``head`` ``(N, 3, 3)`` about the thorax
    (:class:`Augmentation`'s posture terms); pelvis and legs unchanged, so the hip line and
    the canonical frame stay as they were."""
    out = np.array(canon, np.float64, copy=True)
    pelvis = out[:, PELVIS : PELVIS + 1]
    out[:, _UPPER_BODY] = pelvis + np.einsum("nij,nkj->nki", trunk, out[:, _UPPER_BODY] - pelvis)
    thorax = out[:, THORAX : THORAX + 1]
    out[:, _HEAD] = thorax + np.einsum("nij,nkj->nki", head, out[:, _HEAD] - thorax)
    return out


#: Width of the trunk-lean bins of :func:`lean_balance_weights`, degrees.
LEAN_BIN_DEG = 5.0


def lean_balance_weights(lean_deg: np.ndarray, cap: float) -> np.ndarray:
    """Sampling weights ``(N,)`` float64 that flatten the trunk-lean distribution of a
    training set: inverse frequency of each pose's :data:`LEAN_BIN_DEG` bin of its trunk
    lean ``lean_deg`` ``(N,)`` (degrees, :func:`pcnet.stages.core.canonical.trunk_lean_deg`),
    relative to the most populated bin (weight 1) and capped at ``cap``. Upright poses fill
    most mocap (Bandai's and CMU's training clips: 89 % of frames lean under 10 deg, 1.9 %
    over 20), which teaches the network that a trunk is
    nearly vertical; held-out motions lean more (CMU test subjects and DeepMimic: 41-43 %
    over 10 deg). Re-weighting by the frequency of a rare class with a cap is the usual
    class-balancing recipe; the cap keeps a handful of extreme frames from dominating.
    Frames without a lean (NaN) get weight 1.

    Raises:
        ValueError: ``cap < 1``.
    """
    if not cap >= 1:
        raise ValueError(f"lean balance cap: expected >= 1, got {cap}")
    lean = np.asarray(lean_deg, np.float64)
    known = np.isfinite(lean)
    bins = np.zeros(len(lean), np.int64)
    bins[known] = (lean[known] // LEAN_BIN_DEG).astype(np.int64)
    counts = np.bincount(bins[known], minlength=1).astype(np.float64)
    weights = np.ones(len(lean))
    if known.any():
        weights[known] = np.minimum(cap, counts.max() / counts[bins[known]])
    return weights


@dataclass(frozen=True)
class PairSet:
    """Pairs for training or evaluation.

    inputs: ``(N, 17, 3)`` float32 camera frame (OpenCV axes), pelvis-centred, metres;
    canonical: ``(N, 17, 3)`` float32 canonical target; R: ``(N, 3, 3)`` float64 true
    canonical->camera rotation; clip: ``(N,)`` int clip index; frame: ``(N,)`` frame index.
    """

    inputs: np.ndarray
    canonical: np.ndarray
    R: np.ndarray
    clip: np.ndarray
    frame: np.ndarray
    clip_names: tuple[str, ...]
    #: Frames of the clips (after stride and ``max_frames``) without a defined canonical
    #: target: a missing joint of the pelvis and hips, or a hip line along gravity.
    dropped_frames: int = 0


CAMERAS = ("per-frame", "per-clip", "static")


def make_pairs(
    clips: list[Clip],
    views: str = "paper",
    seed: int = 0,
    camera: str = "per-frame",
    noise: Noise | LifterNoise | None = None,
    augmentation: Augmentation | None = None,
    frame_stride: int = 1,
    max_frames: int | None = None,
) -> PairSet:
    """Build (camera-frame input, canonical target, R) pairs from world-frame mocap.

    Canonical targets follow ``docs/CONVENTIONS.md`` (gravity up, pelvis heading); frames whose
    heading is undefined (hip line near vertical) are dropped. ``R`` is sampled from
    ``views`` ("paper"/"wide", :func:`pcnet.stages.core.rotations.sample_camera_rotations`), one
    per frame (``camera="per-frame"``, the paper's protocol) or one per clip: with
    ``camera="per-clip"`` the camera keeps its place relative to the body's heading (a
    camera fixed in tilt that pans with the subject's turns, so every frame stays in the
    view distribution), with ``camera="static"`` it is fixed in the world (the sampled view
    holds at the clip's first frame; the subject's own turning then shows, as in a real
    recording). The input is ``canonical @ R.T``, then
    ``noise`` if given: :class:`Noise` (frame-independent, :func:`apply_noise`) or
    :class:`pcnet.models.lifter_noise.LifterNoise` (errors that persist over each clip,
    drawn over the clip's full length so that stride and ``max_frames`` keep each kept
    frame's error; with per-frame cameras drawn in a per-clip reference camera first, see
    :func:`_lifter_inputs`). ``frame_stride`` keeps every k-th frame; ``max_frames`` then keeps
    at most that many frames, evenly spaced over the whole set (deterministic).

    Raises:
        ValueError: unknown ``camera``, no clips, or no valid frame.
    """
    if camera not in CAMERAS:
        raise InputError(f"unknown camera mode {camera!r}; expected one of {CAMERAS}")
    if not clips:
        raise InputError("no clips to build pairs from (empty split?)")
    rng = np.random.default_rng(seed)
    idx_clip = np.concatenate([np.full(len(c.joints[::frame_stride]), i) for i, c in enumerate(clips)])
    idx_frame = np.concatenate([np.arange(0, len(c.joints), frame_stride) for c in clips])
    world = np.concatenate([c.joints[::frame_stride] for c in clips]).astype(np.float64)
    if max_frames is not None and len(world) > max_frames:
        keep = np.linspace(0, len(world) - 1, max_frames).round().astype(int)
        world, idx_clip, idx_frame = world[keep], idx_clip[keep], idx_frame[keep]

    R_world, valid = canonical_rotation(world, (0.0, 1.0, 0.0))
    canon = to_canonical(world, R_world).astype(np.float64)
    if augmentation is not None:
        per_clip = _proportion_factors(len(clips), augmentation, rng)
        canon = _bone_scale(canon, per_clip[idx_clip])
        # Re-derive the frame: scaling the hip bones can turn the hip line slightly.
        R_aug, valid_aug = canonical_rotation(canon, (0.0, 1.0, 0.0))
        canon = to_canonical(canon, R_aug).astype(np.float64)
        R_world = np.einsum("nij,njk->nik", R_world, R_aug)
        valid &= valid_aug
        posture = posture_rotations(len(clips), augmentation, rng)
        if posture is not None:
            canon = apply_posture(canon, posture[0][idx_clip], posture[1][idx_clip])
        if augmentation.mirror_fraction > 0:
            mirrored = (rng.random(len(clips)) < augmentation.mirror_fraction)[idx_clip]
            canon[mirrored] = mirror_canonical(canon[mirrored])
            # The mirrored body turns the other way: canonical->world mirrored about the same plane.
            R_world[mirrored] = _MIRROR_Z @ R_world[mirrored] @ _MIRROR_Z
    if not valid.any():
        names = ", ".join(c.name for c in clips[:3]) + (f" and {len(clips) - 3} more" if len(clips) > 3 else "")
        raise InputError(f"clips {names}: expected frames with a defined canonical heading (distinct hips), got none")
    canon, idx_clip, idx_frame, R_world = canon[valid], idx_clip[valid], idx_frame[valid], R_world[valid]
    n = len(canon)

    if camera == "per-frame":
        R = sample_views(n, views, rng)
    else:
        R = sample_views(len(clips), views, rng)[idx_clip]
    if camera == "static":
        # canonical->world is a turn about the vertical; undo the first frame's, keep the rest
        first = np.unique(idx_clip, return_index=True)[1]
        R_first = np.empty((len(clips), 3, 3))
        R_first[idx_clip[first]] = R_world[first]
        R = np.einsum("nij,nkj,nkl->nil", R, R_first[idx_clip], R_world)
    if isinstance(noise, LifterNoise):
        inputs = _lifter_inputs(clips, canon, R, idx_clip, idx_frame, camera, views, noise, rng)
    else:
        inputs = np.einsum("nij,nkj->nki", R, canon)
        if noise is not None:
            inputs = apply_noise(inputs, noise, rng, idx_clip)
    return PairSet(
        inputs.astype(np.float32), canon.astype(np.float32), R, idx_clip, idx_frame,
        tuple(c.name for c in clips), dropped_frames=int((~valid).sum()),
    )


def _lifter_inputs(clips, canon, R, idx_clip, idx_frame, camera, views, noise, rng) -> np.ndarray:
    """Camera-frame inputs with :mod:`pcnet.models.lifter_noise` errors. A lifter's errors
    live in the frame of the one camera that filmed the clip; with a new camera every frame
    (``per-frame``) they are drawn in a per-clip reference camera (one more draw from
    ``views``), taken back to the canonical frame, and only then turned by each frame's own
    camera: the temporal structure survives, the depth axis of the errors is the reference
    camera's, not each frame's."""
    n_frames = np.array([len(c.joints) for c in clips])
    fps = np.array([c.fps for c in clips])
    if camera == "per-frame":
        R_ref = sample_views(len(clips), views, rng)[idx_clip]
        ref = np.einsum("nij,nkj->nki", R_ref, canon)
        noisy_canon = np.einsum("nki,nij->nkj", apply_lifter_noise(ref, idx_clip, idx_frame, n_frames, fps, rng, noise),
                                R_ref)
        return np.einsum("nij,nkj->nki", R, noisy_canon)
    inputs = np.einsum("nij,nkj->nki", R, canon)
    return apply_lifter_noise(inputs, idx_clip, idx_frame, n_frames, fps, rng, noise)


def sample_views(n: int, views: str, rng: np.random.Generator) -> np.ndarray:
    """``n`` camera rotations from one distribution of
    :func:`pcnet.stages.core.rotations.sample_camera_rotations` (docs/CONVENTIONS.md), or a
    mixture ``"A+B"`` (e.g. ``"paper+wide"``): each rotation drawn from either with probability
    1/2 (a training mix that keeps the common near-frontal views dense while covering people
    turning around)."""
    if "+" in views:
        first, second = views.split("+", 1)
        pick = rng.random(n) < 0.5
        return np.where(pick[:, None, None], sample_camera_rotations(n, first, rng),
                        sample_camera_rotations(n, second, rng))
    return sample_camera_rotations(n, views, rng)


def apply_noise(inputs: np.ndarray, noise: Noise, rng: np.random.Generator, clip: np.ndarray | None = None) -> np.ndarray:
    """Upstream-like errors on camera-frame poses ``(N, 17, 3)`` (metres): per-clip
    bone-length scaling (an estimator's skeleton differs from the subject's), isotropic
    per-joint jitter, extra error along the camera depth axis +z, and dropped joints set to
    NaN (never the pelvis, which defines the origin); only a ``noise.fraction`` share of
    the poses (drawn at random) is changed. Returns pelvis-centred float64."""
    clean = np.asarray(inputs, np.float64)
    X = clean
    n = len(X)
    clip = np.arange(n) if clip is None else clip
    factors = np.clip(rng.normal(1.0, noise.bone_scale_sigma, (int(clip.max()) + 1, 17)), 0.85, 1.15)
    X = _bone_scale(X, factors[clip])
    X = X + rng.normal(0.0, noise.jitter_m, X.shape)
    X[..., 2] += rng.normal(0.0, noise.depth_m, X.shape[:2])
    X = X - X[:, PELVIS : PELVIS + 1]
    drop = rng.random(X.shape[:2]) < noise.drop_prob
    drop[:, PELVIS] = False
    X[drop] = np.nan
    if noise.fraction < 1.0:
        keep_clean = rng.random(n) >= noise.fraction
        X[keep_clean] = clean[keep_clean] - clean[keep_clean, PELVIS : PELVIS + 1]
    return X
