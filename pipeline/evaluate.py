"""``pcnet evaluate``: rotation, tilt, heading, MPJPE and PA-MPJPE of a rectification
method on mocap with synthetic camera views (deterministic for a given seed)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from pcnet.models.datasets import (SPLIT_SCHEMES, Noise, assumed_fps_warning, clip_split_of, group_key, groups_in_split,
                                   load_mocap, make_pairs, select_split, world_up_warning)
from pcnet.models.inference import training_config
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.core.conventions import H36M_JOINTS
from pcnet.stages.core.digest import sha256_file_version
from pcnet.stages.core.metrics import METRICS, evaluate_rotations, summarize
from pcnet.stages.core.errors import InputError
from pcnet.stages.flags import mirrored_skeleton_flag
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.rectify import HeadingStep, Rectification, SequenceEvidence, resolve_heading_source

#: Input noise of ``pcnet evaluate --noise``: none (clean mocap), ``frame`` (every frame's
#: error drawn anew, :class:`pcnet.models.datasets.Noise`) or ``lifter`` (errors that persist
#: over a clip like a monocular lifter's, :mod:`pcnet.models.lifter_noise`).
NOISE_KINDS = ("none", "frame", "lifter")


def noise_kind(noise: bool | str | None) -> str:
    """``noise`` as one of :data:`NOISE_KINDS`: ``True`` is ``"frame"`` (the flag's old
    meaning), ``False``/``None`` ``"none"``.

    Raises:
        InputError: any other value.
    """
    if noise is True:
        return "frame"
    if noise is False or noise is None:
        return "none"
    if noise not in NOISE_KINDS:
        raise InputError(f"--noise: expected one of {NOISE_KINDS}, got {noise!r}")
    return noise


def _noise_model(kind: str):
    return {"none": None, "frame": Noise(), "lifter": LifterNoise()}[kind]


def scored_indices(n: int, max_frames: int | None) -> np.ndarray:
    """Indices of the pairs that are scored: all ``n``, or ``max_frames`` evenly spaced over
    them (``linspace(0, n - 1, max_frames)`` rounded, the rule ``make_pairs`` used). They
    depend on the frames only, never on the method, so every method is scored on the same
    frames."""
    if max_frames is None or n <= max_frames:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_frames).round().astype(int))


def frame_set_id(clip_names: tuple[str, ...], clip: np.ndarray, frame: np.ndarray) -> str:
    """A short digest (16 hex digits, SHA-256) of the scored ``(clip name, frame index)``
    pairs: equal in two results exactly when they scored the same frames of the same clips."""
    h = hashlib.sha256()
    for name in clip_names:
        h.update(name.encode("utf-8") + b"\0")
    h.update(np.ascontiguousarray(clip, np.int64).tobytes())
    h.update(np.ascontiguousarray(frame, np.int64).tobytes())
    return h.hexdigest()[:16]


def _training_overlap(data: str | Path, all_clips, chosen, record: dict) -> dict | None:
    """How much of the evaluated data the weights trained on, by their ``training_config``
    (the ``.json`` beside the ONNX file, which ``pcnet export`` fills from the run folder):
    ``None`` when the weights' training data is unknown, or when neither this file's name is
    among it nor a chosen clip among the clips of a file trained on whole (``whole_clips``, e.g.
    DeepMimic's floor motions moved into training, which leaves the rest of DeepMimic a
    cross-dataset test): clip names alike in form say nothing (new CMU subjects carry the
    ``subject_trial`` names of the training file; :func:`_unknown_file_warning` says so);
    else the clips of their train split (or trained on whole) among ``chosen`` and the
    motion-style groups (CMU: subjects; a clip without a group: itself) of ``chosen`` with a
    take trained on, ``clips_trained_whole`` (how many of the trained clips came from a file
    trained on whole, the evaluated file itself included), ``split_trained`` (whether the
    weights took a train split of this file) and ``matched_by`` (``"file name"`` or ``"clip
    names"``). Records from before ``whole_clips`` existed count no clip trained on whole
    unless the evaluated file is the one trained on whole."""
    found = _trained_clips(data, chosen, record)
    if found is None:
        return None
    trained, whole, split_trained, matched_by = found
    scheme = record.get("split_scheme", "clip")
    seen_groups = {group_key(c) or c.name for c in trained}
    if split_trained:
        seen_groups |= groups_in_split(all_clips, "train", scheme)
    groups = {group_key(c) or c.name for c in chosen}
    return {
        "scheme": scheme, "split_trained": split_trained, "clips": len(chosen), "clips_trained_on": len(trained),
        "clips_trained_whole": sum(c.name in whole for c in chosen),
        "groups": len(groups), "groups_with_a_trained_take": len(groups & seen_groups), "matched_by": matched_by,
    }


def _split_trained_file(data: str | Path, record: dict) -> bool:
    """Whether the record lists the evaluated file's name as one the weights took a train split
    of (not trained on whole)."""
    listed = _listed_files(record)
    flags = record.get("train_whole") or [False] * len(listed)
    return any(n == Path(data).name and not w for n, w in zip(listed, flags))


def _foreign_clip(data: str | Path, record: dict, clips) -> str | None:
    """The first of ``clips`` that shows the evaluated file is not the training file it is
    named like: the record took a train split of a file of that name, and its split scheme
    cannot place this clip (no Bandai name, no CMU subject for ``motion-style``; a user
    trial's own clips in a file named ``cmu_train_h36m17.npz``); ``None`` otherwise."""
    if not _split_trained_file(data, record):
        return None
    scheme = record.get("split_scheme", "clip")
    for c in clips:
        try:
            clip_split_of(c, scheme)
        except InputError:
            return c.name
    return None


def _other_content(data: str | Path, record: dict) -> bool:
    """Whether the evaluated file bears the name of a file the weights trained on but not its
    content: the record gives the training files' sha256 (``data_sha256``, which ``pcnet
    train`` records) and none of the files of that name had this file's (an ML trial's decoy,
    its test clips copied under the training file's name, read "trained on 12 of these 14");
    False where the record gives no digests or names no such file."""
    hashes = record.get("data_sha256")
    if not isinstance(hashes, list) or len(hashes) != len(record.get("data", [])):
        return False
    named = [h for d, h in zip(record.get("data", []), hashes) if Path(str(d)).name == Path(data).name]
    if not named:
        return False
    return sha256_file_version(data) not in named


def _listed_files(record: dict) -> list[str]:
    """The names (no folder) of the files a training record's ``data`` lists: a file is matched
    by its name, wherever it was read from in training."""
    return [Path(str(d)).name for d in record.get("data", [])]


def _untrained(data: str | Path, clips: list, method: str, weights: str | None) -> list:
    """``clips`` less those the weights trained on, by their record (:func:`_trained_clips`).

    Raises:
        InputError: the geometric method (no weights), or weights whose record cannot tell
            which clips they trained on.
    """
    if method == "geometric":
        raise InputError("--untrained-only: expected a method with weights (pcnet, pcnet-rigid), got geometric, "
                         "which trained on nothing")
    record = training_config(weights)
    if not record:
        raise InputError(f"--untrained-only: expected weights with a training record, got none beside "
                         f"{weights or 'the shipped weights'} (the .json pcnet export writes)")
    found = _trained_clips(data, clips, record)
    if found is not None:
        trained = {c.name for c in found[0]}
        return [c for c in clips if c.name not in trained]
    if (Path(data).name in _listed_files(record) and not _other_content(data, record)
            and _foreign_clip(data, record, clips) is None):
        raise InputError(f"--untrained-only: expected a training record that says which clips of {Path(data).name} "
                         f"the weights trained on, got split scheme {record.get('split_scheme')!r}")
    return clips  # a file the record does not list, no clip it names: none trained on as far as it tells (warned)


def _trained_clips(data: str | Path, chosen, record: dict) -> tuple[list, set, bool, str] | None:
    """The clips of ``chosen`` the weights' ``training_config`` (``record``) says they trained
    on, as :func:`_training_overlap` counts them: ``(trained, whole clip names, split_trained,
    matched_by)``, or ``None`` where the record cannot tell (no files listed, an unknown
    scheme, a file it does not list and no clip it names, a file named like a split-trained one
    whose clips its scheme cannot place)."""
    listed = _listed_files(record)
    scheme = record.get("split_scheme", "clip")
    whole = set(record.get("whole_clips") or [])
    if not listed or scheme not in SPLIT_SCHEMES:
        return None
    split_trained = True  # the evaluated file is one the weights took a train split of
    if Path(data).name in listed:
        matched_by = "file name"
        if _other_content(data, record) or _foreign_clip(data, record, chosen) is not None:
            return None  # named like a training file, but not it (_foreign_file_warning)
        split_trained = _split_trained_file(data, record)
        if not split_trained:  # the file itself was trained on whole
            whole |= {c.name for c in chosen}
    elif any(c.name in whole for c in chosen):
        matched_by, split_trained = "clip names", False
    else:
        return None
    trained = [c for c in chosen if c.name in whole or split_trained and clip_split_of(c, scheme) == "train"]
    return trained, whole, split_trained, matched_by


def _unlisted_whole_warning(record: dict) -> str | None:
    """A warning when the weights trained on a whole file (``train_whole``) but their record
    predates ``whole_clips``: clips of the evaluated data may be among that file's, and
    :func:`_training_overlap` cannot tell; ``None`` otherwise."""
    whole = [d for d, w in zip(record.get("data", []), record.get("train_whole") or []) if w]
    if not whole or record.get("whole_clips"):
        return None
    return (f"the weights trained on every clip of {', '.join(map(str, whole))}, whose clip names their record does "
            f"not list (exported before pcnet recorded them): clips of this data may be among them")


def _unknown_file_warning(data: str | Path, record: dict, overlap: dict | None,
                          left_out: list[str] | None = None, split: str = "all", scored: tuple[int, int] = (0, 0)
                          ) -> str | None:
    """A warning when the weights' record names their training files but the evaluated file
    is not one of them: whether its clips overlap the training data cannot be told from names,
    so the scores are not called held out; where some evaluated clips are recognised by name
    among the clips trained on whole (``overlap``, :func:`_training_overlap`), it says so and
    that the others may still be among the training files', and with ``--untrained-only``
    (``left_out``: the clips it left out, by name) which recognised clips it left out and
    that it scored every other (user trials read a silent ``--untrained-only`` as "none of
    these trained on"), and where ``split`` (not ``all``) chose ``scored`` = ``(chosen, all)``
    clips, that it chose them by their names as it splits the training files, which
    means nothing for this file (a lab's trial scored 1 of its 4 clips, named like CMU's test
    subjects, as "test"); ``None`` otherwise."""
    listed = _listed_files(record)
    if not listed or Path(data).name in listed:
        return None
    known = ""
    if overlap is not None:
        n = overlap["clips_trained_whole"]
        known = (f"; of the evaluated clips, {n} {'is' if n == 1 else 'are'} recognised by name among the clips they "
                 f"trained on whole, and the others may be among their training files' too")
    left = ""
    if left_out is not None:
        named = (f"{len(left_out)} clip{'s' * (len(left_out) != 1)} recognised by name among the clips they "
                 f"trained on whole ({', '.join(left_out)})" if left_out else "no clip recognised by name")
        left = f"; --untrained-only left out {named} and scored every other"
    chosen = ""
    if split != "all" and scored[0] < scored[1]:
        chosen = (f"; --split {split} chose {scored[0]} of its {scored[1]} clips by their names, as the training "
                  f"files are split, which means nothing for this file: --split all takes every clip")
    return (f"{Path(data).name} is not among the files the weights trained on ({', '.join(listed)}): whether its "
            f"clips overlap their training data is unknown (a renamed copy of a training file would look new)"
            f"{known}{left}{chosen}")


def _missing_joints_warning(targets: np.ndarray) -> str | None:
    """A warning where scored frames ``targets`` ``(N, 17, 3)`` miss joints (NaN) beyond those
    a target needs: MPJPE and PA-MPJPE are then means over the joints present (a user trial's
    file without wrists in 60 frames was scored without a word); ``None`` otherwise."""
    missing = ~np.isfinite(targets).all(-1)
    frames = missing.any(-1)
    if not frames.any():
        return None
    joints = [H36M_JOINTS[j] for j in np.flatnonzero(missing.any(0))]
    return (f"{int(frames.sum())} scored frames miss joints ({', '.join(joints[:4])}"
            f"{' and more' if len(joints) > 4 else ''}): mpjpe_mm and pa_mpjpe_mm there are over the joints present")


def _mirrored_clips_warning(clips) -> str | None:
    """A warning where evaluated clips' ground truth is a mirror image of a body
    (:func:`pcnet.stages.flags.mirrored_skeleton_flag`: knees bending forward, elbows
    backward): a file whose left and right joints are exchanged, whose targets' sides are then
    wrong, so the scores are not the method's (a lab's trial: 9.8 deg mean rotation error where
    its correctly labelled clips gave 1.8, without a word; the test fires on none of the shared
    mocap files' clips: ``python -m benchmarks.fit_mirror_flag --data ../shared/data``);
    ``None`` otherwise."""
    mirrored = [c.name for c in clips if mirrored_skeleton_flag(c.joints)]
    if not mirrored:
        return None
    return (f"{len(mirrored)} of {len(clips)} clips are mirror images of a body (knees bend forward, elbows backward: "
            f"{', '.join(mirrored[:3])}{' ...' if len(mirrored) > 3 else ''}): left and right exchanged in the file? "
            f"Their targets' sides are then wrong, and their scores are not the method's")


def _foreign_file_warning(data: str | Path, record: dict, clips) -> str | None:
    """A warning where the evaluated file bears the name of a file the weights trained on but
    holds clips its record's split scheme cannot place (:func:`_foreign_clip`): the name says
    nothing, and whether the clips overlap the training data is unknown; ``None`` otherwise."""
    if _other_content(data, record):
        return (f"{Path(data).name} bears the name of a file the weights trained on, but not its content (its sha256 "
                f"is not the one their training record gives): not that file, so whether its clips overlap the "
                f"training data is unknown")
    foreign = _foreign_clip(data, record, clips)
    if foreign is None:
        return None
    return (f"{Path(data).name} bears the name of a file the weights trained on, but its clip {foreign!r} has no "
            f"place in that file's {record.get('split_scheme', 'clip')} split: not that file, so whether its clips "
            f"overlap the training data is unknown")


def _fine_tuned_warning(record: dict) -> str | None:
    """A warning when the weights were fine-tuned from another checkpoint (``init_checkpoint``
    in their record, :func:`pcnet.models.export.training_record`): the overlap counted is the
    last run's data alone, and the earlier runs' data (listed where their records say) trained
    the weights too; ``None`` otherwise."""
    chain, earlier = [], record
    while earlier.get("init_checkpoint"):
        data = [Path(str(d)).name for d in (earlier.get("init_training_config") or {}).get("data", [])]
        chain.append(f"{earlier['init_checkpoint']} ({', '.join(data) if data else 'data unknown'})")
        earlier = earlier.get("init_training_config") or {}
    if not chain:
        return None
    # no "overlap above" where none was counted (an ML trial read it beside "overlap unknown")
    return (f"the weights were fine-tuned from {'; from '.join(chain)}: the earlier runs' data trained them too, and "
            f"any overlap counted here is the last run's data's alone")


def _unknown_training_warning(weights, record: dict) -> str | None:
    """A warning when the weights carry no training record (no ``.json`` beside them with a
    ``training_config``, as ``pcnet export`` writes): whether they trained on the evaluated
    clips cannot be told; ``None`` otherwise."""
    if record:
        return None
    beside = Path(str(weights)).with_suffix(".json") if weights else "the shipped weights"
    return (f"the weights' training data is unknown (no training_config in {beside}): these scores may include "
            f"clips they trained on; keep the .json that pcnet export writes beside the weights")


def evaluate(
    method: str,
    data: str | Path,
    split: str = "test",
    views: str = "paper",
    seed: int = 0,
    max_frames: int | None = None,
    weights: str | None = None,
    camera: str = "per-frame",
    noise: bool | str = "none",
    mode: str = "frame",
    heading: str | None = None,
    split_scheme: str = "motion-style",
    unseen_by: str | None = None,
    details: bool = False,
    camera_prior: bool = True,
    untrained_only: bool = False,
) -> dict:
    """Evaluate ``method`` on the ``split`` clips of a mocap npz.

    Clips: :func:`pcnet.models.datasets.select_split` under ``split_scheme`` (``"motion-style"``:
    whole Bandai motion-style groups and styles held out, CMU by subject; ``"clip"``: the old
    per-take hash of the releases before release 3, kept for continuity). ``unseen_by`` (a
    scheme) then keeps only clips whose group (:func:`pcnet.models.datasets.group_key`; a clip
    without one: the clip itself) has no take in that scheme's train split of the same file:
    ``unseen_by="clip"`` scores the groups the old clip split never trained on, most of which
    the shipped weights (motion-style split) did train on (the result's ``training_overlap``
    says how many). ``untrained_only`` then leaves out the clips the weights' training record
    names as trained on (:func:`_trained_clips`: their train split of this file, or clips of a
    file trained on whole, such as DeepMimic's three floor motions), so that what is scored is
    held out as far as the record tells.

    Pairs come from :func:`pcnet.models.datasets.make_pairs` over whole clips, with ``noise``
    (:data:`NOISE_KINDS`; ``True``/``False`` mean ``"frame"``/``"none"``). ``mode`` other than
    ``"frame"`` post-processes each clip's per-frame rotations with
    :class:`pcnet.stages.rectify.SequenceEvidence` (``sequence`` assumes a static camera,
    meaningful with ``camera="per-clip"``); ``heading`` then chooses each clip's heading
    source (:func:`pcnet.stages.heading.apply_heading`; ``None`` = the method's default,
    :func:`pcnet.stages.rectify.resolve_heading_source`), each clip being one recording
    whatever the camera protocol (the steps of :class:`pcnet.stages.rectify.Rectification`,
    as in ``rectify``). The canonical prediction is
    ``(X - pelvis) @ R_hat (+ residual)``, compared with the canonical target.

    ``max_frames`` only chooses which frames are scored (:func:`scored_indices`): every clip
    is rectified whole first, so per-clip decisions (heading source, sequence mode) and each
    frame's noise are those of the full run, and the scored frames are a subset
    of its frames with the same errors. Frames the method marks invalid are counted
    (``invalid_frames``) and left out of every metric; the scored frames do not depend on the
    method (``frame_set`` names them), so methods are compared on the same frames, each
    excluding its own invalid ones.

    Returns:
        ``{"method", "weights" (the ``weights`` file, ``"shipped"``, or ``None`` for the geometric
        method), "views", "split", "split_scheme", "unseen_by", "untrained_only", "data", "seed", "camera",
        "noise", "mode", "heading", "camera_prior", "warnings" (lines, e.g.
        :func:`pcnet.models.datasets.world_up_warning`), "clips", "groups", "frames" (scored frames),
        "total_frames" (frames rectified), "target_undefined_frames" (frames of the data left
        out before rectifying: no defined canonical target), "invalid_frames" (of the scored ones),
        "valid_frames", "frame_set", "clip_heading_sources" (clips per source used),
        "clip_modes" (sequence modes only), "camera_prior", "training_overlap" (evaluated
        clips and groups the evaluated weights trained on, by split or whole file, by their
        ``training_config``, :func:`_training_overlap`; ``None`` for other data), "<metric>": {"mean", "median", "p95"} ...}`` with the metrics of
        :data:`pcnet.stages.core.metrics.METRICS` (degrees, millimetres), over the valid scored
        frames, "per_clip": one dict per rectified clip in order (``name``, ``heading_source``,
        ``mode``, ``frames`` scored, ``valid`` of them, and each metric's mean over them, ``None``
        where none is valid; a user trial asked which clips err)}``. With ``details``: also
        ``"per_frame"`` (``clip``, ``frame``, ``valid`` and each metric as arrays over the
        scored frames).

    Raises:
        InputError: empty split (after ``unseen_by`` and ``untrained_only``), ``untrained_only``
            for the geometric method or for weights whose record cannot tell, unknown method, heading source, noise
            or split scheme, a clip the scheme cannot place, ``max_frames < 1``, a sequence
            mode (``sequence``, ``auto``) with ``camera="per-frame"`` (before any inference).
    """
    heading = resolve_heading_source(method, heading)
    kind = noise_kind(noise)
    if mode in ("sequence", "auto") and camera == "per-frame":
        raise InputError(f"--mode {mode}: expected --camera per-clip or static (one camera per clip, which sequence "
                         f"mode assumes), got --camera per-frame (a new camera every frame)")
    if max_frames is not None and max_frames < 1:
        raise InputError(f"max_frames: expected a count >= 1, got {max_frames}")
    if unseen_by is not None and unseen_by not in SPLIT_SCHEMES:
        raise InputError(f"unseen_by {unseen_by!r}: expected one of {SPLIT_SCHEMES} or none")
    all_clips = load_mocap(data)
    warnings = [w for w in [world_up_warning(all_clips, data)] if w]
    clips = select_split(all_clips, split, split_scheme)
    in_split = len(clips)
    if unseen_by is not None:
        seen = groups_in_split(all_clips, "train", unseen_by)
        clips = [c for c in clips if (group_key(c) or c.name) not in seen]
    left_out: list[str] | None = None  # the clips --untrained-only left out, by name
    if untrained_only:
        kept = _untrained(data, clips, method, weights)
        left_out = [c.name for c in clips if c not in kept]
        clips = kept
    if not clips:
        extra = f" with no group in the {unseen_by!r} train split" if unseen_by else ""
        extra += " that the weights did not train on" if untrained_only else ""
        raise InputError(f"{data}: split {split!r} (scheme {split_scheme!r}) has no clips{extra}"
                         + ("; --split all scores every clip" if split != "all" else ""))
    # frame mode's view gate reads its quarter turns over a window in seconds too (an evaluation
    # trial's clips read at 30 fps instead of 24-60 scored 22.1 deg where they score 10.9)
    if kind == "lifter" or mode != "frame" or method != "geometric":
        warnings += [w for w in [assumed_fps_warning(clips, data)] if w]
    warnings += [w for w in [_mirrored_clips_warning(clips)] if w]
    pairs = make_pairs(clips, views=views, seed=seed, camera=camera, noise=_noise_model(kind))
    # Scores need the rotations only, not the camera-tilt uncertainty (bootstrap).
    chain = Rectification(make_estimator(method, weights), SequenceEvidence(mode, camera_prior, n_bootstrap=0),
                          HeadingStep(heading))
    n = len(pairs.inputs)
    R_hat, canon_hat, valid = np.full((n, 3, 3), np.nan), np.full((n, 17, 3), np.nan), np.zeros(n, bool)
    modes_run: dict[str, int] = {}
    headings_run: dict[str, int] = {}
    per_clip = []
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)
        if len(sel) == 0:
            continue
        # One clip is one recording for every per-recording step, the estimator's too.
        res = chain(pairs.inputs[sel], clip.fps)
        R_hat[sel], canon_hat[sel], valid[sel] = res.rotation, res.canonical, res.valid
        if mode != "frame":
            modes_run[res.mode] = modes_run.get(res.mode, 0) + 1
        headings_run[res.heading_source] = headings_run.get(res.heading_source, 0) + 1
        per_clip.append((i, {"name": clip.name, "heading_source": res.heading_source, "mode": res.mode}))
    keep = scored_indices(len(valid), max_frames)
    valid_k = valid[keep]
    errors = evaluate_rotations(R_hat[keep], pairs.R[keep], canon_hat[keep], pairs.canonical[keep])
    for name in METRICS:  # a method's invalid frames never count, whatever it returned there
        errors[name] = np.where(valid_k, errors[name], np.nan)
    warnings += [w for w in [_missing_joints_warning(pairs.canonical[keep][valid_k])] if w]
    result = {
        "method": method, "weights": None if method == "geometric" else str(weights) if weights else "shipped",
        "views": views, "split": split, "split_scheme": split_scheme, "unseen_by": unseen_by,
        "untrained_only": untrained_only, "left_out_trained_clips": left_out or [],
        "data": str(data), "seed": seed, "camera": camera, "noise": kind, "mode": mode, "heading": heading,
        "camera_prior": camera_prior, "warnings": warnings,
        "target_undefined_frames": pairs.dropped_frames,
        "clips": len(clips), "groups": len({group_key(c) or c.name for c in clips}),
        "frames": len(keep), "total_frames": len(valid),
        "invalid_frames": int((~valid_k).sum()), "valid_frames": int(valid_k.sum()),
        "frame_set": frame_set_id(pairs.clip_names, pairs.clip[keep], pairs.frame[keep]),
    }
    if modes_run:
        result["clip_modes"] = modes_run
    result["clip_heading_sources"] = headings_run
    if method != "geometric":
        record = training_config(weights)
        result["training_overlap"] = _training_overlap(data, all_clips, clips, record)
        warnings += [w for w in [_unlisted_whole_warning(record), _unknown_training_warning(weights, record),
                                 _fine_tuned_warning(record),
                                 _unknown_file_warning(data, record, result["training_overlap"], left_out,
                                                       split, (in_split, len(all_clips))),
                                 _foreign_file_warning(data, record, clips)] if w]
    else:
        result["training_overlap"] = None
    result.update({name: summarize(errors[name]) for name in METRICS})
    result["per_clip"] = _clip_scores(per_clip, pairs.clip[keep], valid_k, errors)
    if details:
        result["per_frame"] = {"clip": pairs.clip[keep], "frame": pairs.frame[keep], "valid": valid_k, **errors}
    return result


def _clip_scores(per_clip: list[tuple[int, dict]], clip: np.ndarray, valid: np.ndarray, errors: dict) -> list[dict]:
    """Each rectified clip's entry (its index among the clips, its dict) with its scored and
    valid frames (``clip``, ``valid``: per scored frame) and its metrics' means over them.
    Counted by clip index in one pass (``np.bincount``), not one mask per clip: thousands of
    clips over hundreds of thousands of frames."""
    n = max((index for index, _ in per_clip), default=-1) + 1
    frames = np.bincount(clip, minlength=n)
    counted = np.bincount(clip[valid], minlength=n)
    sums = {name: np.bincount(clip[valid], weights=errors[name][valid], minlength=n) for name in METRICS}
    return [{**entry, "frames": int(frames[i]), "valid": int(counted[i]),
             **{name: round(float(sums[name][i] / counted[i]), 4) if counted[i] else None for name in METRICS}}
            for i, entry in per_clip]


def _modes_run(result: dict) -> str:
    """`` (clips sequence:N,smooth:M)`` where auto mode chose per clip (a user trial found the
    choice only in the JSON), else ``""``."""
    modes = result.get("clip_modes") or {}
    if result.get("mode") != "auto" or not modes:
        return ""
    return " (clips " + ",".join(f"{k}:{v}" for k, v in sorted(modes.items())) + ")"


def format_table(result: dict) -> str:
    """The result as a plain-text table (one row per metric: mean, median, p95), headed by
    the protocol, the clip and frame counts (invalid frames are excluded from the metrics)
    and how much of the data the evaluated weights trained on, where their record says."""
    sources = ",".join(f"{k}:{v}" for k, v in result.get("clip_heading_sources", {}).items())
    unseen = f" unseen-by={result['unseen_by']}" if result.get("unseen_by") else ""
    unseen += " untrained-only" if result.get("untrained_only") else ""
    weights = f" weights={result['weights']}" if result.get("weights") else ""
    head = (f"method={result['method']}{weights} views={result['views']} split={result['split']} "
            f"scheme={result.get('split_scheme', 'clip')}{unseen} "
            f"camera={result['camera']} noise={result['noise']} mode={result['mode']} "
            f"heading={result.get('heading', 'predicted')} (clips {sources}){_modes_run(result)} seed={result['seed']}\n"
            f"clips={result.get('clips', '?')} groups={result.get('groups', '?')} frames={result['frames']} "
            f"(of {result.get('total_frames', result['frames'])} rectified) invalid={result['invalid_frames']} "
            f"(excluded) frame_set={result.get('frame_set', '?')}")
    if result.get("target_undefined_frames"):
        head += (f"\n{result['target_undefined_frames']} frames of the data had no defined target (a missing pelvis "
                 f"or hip, or a hip line along gravity) and were left out before rectifying")
    overlap = result.get("training_overlap")
    if overlap:
        how = [f"{overlap['scheme']}-scheme train split"] if overlap.get("split_trained", True) else []
        if overlap.get("clips_trained_whole"):
            how.append(f"{overlap['clips_trained_whole']} of these clips from a file trained on whole")
        at_least = ""
        if overlap.get("matched_by") == "clip names":
            how.append("recognised by their clip names; the others' overlap unknown")
            at_least = "at least "
        head += (f"\nthe weights trained on {at_least}{overlap['clips_trained_on']} of these {overlap['clips']} clips "
                 f"and on takes of {overlap['groups_with_a_trained_take']} of their {overlap['groups']} "
                 f"motion-style groups or subjects ({'; '.join(how)})")
    if result.get("noise") == "none" and result.get("clip_heading_sources", {}).get("hips"):
        # the canonical frame's heading is defined by the hip line, which clean mocap gives exactly
        head += ("\nheading from the input's hip line, exact on clean mocap: heading_deg and the rotation scores "
                 "measure the networks' heading only with --heading predicted")
    lines = [head, *(f"WARNING {w}" for w in result.get("warnings", [])),
             f"{'metric':<14}{'mean':>10}{'median':>10}{'p95':>10}   (over the scored frames: a long clip weighs "
             f"more)"]
    for name in METRICS:
        s = result[name]
        lines.append(f"{name:<14}{s['mean']:>10.2f}{s['median']:>10.2f}{s['p95']:>10.2f}")
    if result["method"] in ("pcnet-rigid", "geometric") and result.get("noise") == "none":
        # a trial read the zeros as a fault: Procrustes undoes any rotation, the method's only change
        lines.append("pa_mpjpe_mm is 0 for a rigid method on clean input: it only rotates the poses, which the "
                     "Procrustes alignment undoes (docs/CONVENTIONS.md, metrics)")
    return "\n".join(lines)
