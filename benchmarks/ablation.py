"""Ablation of the decision machinery around the two networks: each evidence source and rule switched off in turn.

    python -m benchmarks.ablation --data ../shared/data [--max-clips 200] [--cache /tmp/pcnet_ablation_cache] \
        [--out benchmarks/results/ablation.txt]

Issue 49, "Ablation, not accretion": a piece that does not help on held-out data goes. This
script measures every piece on held-out data only, one row each.

Evidence is extracted ONCE per clip and cached (``--cache``, one ``.npz`` per data set, read
with ``allow_pickle=False``: :func:`save_records` / :func:`load_records`): each
recording runs through the shipped estimator exactly as ``pcnet run`` builds it
(:class:`pcnet.pipeline.rectification.NetworkEstimator` -> :class:`pcnet.models.inference.ViewGatedPCNet`
``predict_gated``), with recorders on the two onnxruntime sessions' ``predict_normalized``
that keep each network's raw per-frame rotations: the body-frame network and the camera-frame
network on the quarter-turned input (turned back into the camera frame); with the quarter turns,
the gate's weights and the disagreement the estimator returns; the up model's evidence of a
static camera (the camera-frame network's ups at each frame's own quarter turn, decision
0074, and those turns); and, run here, the camera-frame network on the unturned input of the
turned frames (for "quarter turns off" and the plain means). The same
estimate then goes through the real chain (:class:`pcnet.stages.rectify.Rectification`,
``SequenceEvidence("auto", camera_prior=True)``, heading ``auto``: ``pcnet run``'s defaults
before decision 0041 made sequence mode the default; no bootstrap, which does not move the up)
and its up is cached too. Every
variant below is then numpy on the cache, built from the package's own functions
(:func:`pcnet.models.view_gate.camera_frame_weight`, ``blend_rotations``, ``quarter_turn_matrices``,
:func:`pcnet.stages.uncertainty.frame_tilt_bound`, :func:`pcnet.stages.temporal.choose_mode`,
``smooth_rotations``, and for a static camera the up model,
:func:`pcnet.stages.rectify.up_model_sequence`); the switches are arguments here, never edits
of the package. Row ``default`` is ``pcnet run``'s default chain (sequence mode); the auto row
is rebuilt from the cache the same way and checked against the real chain's cached up (the
"reproduction check" line: the largest angle between the two over every recording).

Data, held out from the shipped weights (their training mix is the Bandai + CMU motion-style
train split and three DeepMimic floor motions; models/MODEL_CARD.md):
- mocap: the Bandai motion-style test split, the CMU test subjects (motion-style test split of
  cmu_train_h36m17.npz) and DeepMimic (its clips the weights' training records do not name:
  78 of 81), at most ``--max-clips`` clips per set (a
  seeded random subset, sorted), each clip one static camera from the "paper" distribution
  (``make_pairs(..., views="paper", seed=0, camera="static", noise=LifterNoise())``, the
  protocol of benchmarks/calibrate_uncertainty.py and auto_mode_threshold.py); the truth's up
  is constant over a clip;
- real calibrated: real/pose2sim_gravity/statictrial_cam01-04 (4 real cameras, MediaPipe, the
  lab's calibrated up; read as benchmarks/gravity_benchmark.py reads them), each as filmed and
  rolled by 90, 180 and -90 deg about the optical axis (16 views);
- yoga physics (benchmarks/yoga_physics.py): the 88 distinct real VideoPose3D yoga files at
  stride 2 (15 fps), no ground truth: median trunk angle from each method's up per file,
  targets Shavasana >= 80, Padmasana <= 15, Tadasana <= 6 deg (the trunk angle here is taken
  against the up in the camera frame, without the network's small residual, so it can differ
  from yoga_physics.txt by a few tenths of a degree); and the default chain's sequence intervals
  on the 15 Tadasana files, standing straight, against the trunk's robust mean direction as the
  true up (the person's own posture, a few degrees, is in that truth's error);
- roll equivariance (benchmarks/equivariance.py): its 6 real clips (middle 300 frames), the
  camera rolled by 30 and 90 deg about its optical axis; extra error = mean angle between the
  up of the rolled view and the unrolled view's up turned with the camera (0 for an
  equivariant method);
- a measured root (what a depth sensor, or a file whose pelvis is a measured path, gives; the
  sets above are root-relative, as monocular lifters deliver): the three held-out mocap sets
  with each clip's pelvis path kept in the camera frame (:func:`camera_root_path`), and the
  Bandai test split's other clips (those outside the seeded subset above: untouched by the
  floor work until decision 0043); rows: the default chain, whose up model is then fused with
  the floor contacts (:mod:`pcnet.stages.ground_plane`), the floor switched off, and the
  floor with the pelvis path a monocular run recovers from 2D keypoints instead
  (:func:`keypoint_root_path`: the clean joints 3 m plus the pelvis's reach in front of the
  camera, projected with 2 px noise and 5 % wrong detections, the lifter-noise 3D; its verdict
  is against the floor switched off);
- a camera rolled a quarter turn over a pelvis path (issue 49's "camera rolled 90 deg, upright
  subject read as upright whenever the evidence says so"): the three held-out mocap sets with
  the camera rolled 90 deg about its optical axis, clockwise for even clips and anticlockwise
  for odd ones (the networks run on the rolled inputs, :func:`rolled_evidence`), each with its
  measured pelvis path and with the path recovered from 2D keypoints for the level camera,
  both rolled with it; rows: the default chain (the footfalls weigh in the posture's
  posterior, :class:`pcnet.stages.ground_plane.FloorEnergy`), and the footfalls only in the
  upright fine fit (the chain before decision 0048), whose verdict is against the default;
- a moving camera (what mode ``auto`` and its threshold are for; every set above is a static
  camera): the cached inputs of the Bandai test and DeepMimic clips with at least 150 frames
  (at most 60 per set), the camera's pitch sweeping linearly through 30 deg over each clip
  (the protocol of benchmarks/auto_mode_threshold.py); the truth's up moves with the camera;
- a rolled camera (issue 49's "camera rolled 30 deg, extra tilt <= +0.5", measured against
  the truth): the cached inputs of the three held-out mocap sets with the camera rolled 30 deg
  about its optical axis, clockwise for even clips and anticlockwise for odd ones (``X' = X
  Q^T``, true up ``Q u``); per clip the extra sequence tilt error is its error rolled minus its
  error unrolled (the mocap sections' recording), and the verdict is on that extra against the
  default's.

Metrics. Mocap: per clip the tilt error of the output (mean over its valid frames of the
angle between the output up and the true up; in sequence mode the one up's error), then mean
/ median / p95 over clips; ``frame`` = the per-frame estimate's tilt error (before any
sequence step), mean over all frames; ``>20`` = clips erring more than 20 deg; ``lying`` =
clips whose up model's posture (upright / lying) is not the truth (lying = median true
trunk angle from up > 60 deg; without the priors every clip reads upright); ``cover`` (also
for the real cameras) = per cent of the recordings with intervals whose true camera pitch and
roll both lie inside the printed 95 % intervals (``nan``: the row prints none), and the
coverage line gives the default's per axis. Verdict: paired
bootstrap over clips (2,000 replicates) of the mean difference row - default, 95 % interval;
for a row that switches a piece off, "helps" when switching it off makes the error larger
(interval above 0), "hurts" when smaller (below 0), else "no effect", and "no effect" too
whenever the mean difference is under 0.05 deg (negligible) or exactly 0 for every clip
("identical"); in brackets after it the clips whose error moved by more than 0.5 deg
(worse, better; for yoga: files that newly fail / newly pass); for an alternative
(the plain robust mean; auto mode, static or moving by the spread threshold, with the fitted
or the hand-set constants, or by the Bayes factor of benchmarks/camera_motion_model.py) "better"
/ "worse" / "same". The real cameras, the
yoga fails and the equivariance use the same bootstrap over their views / files / rolled
clips (few of them: read those intervals as rough).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import hashlib
import os
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

import pcnet.stages.temporal as temporal
from pcnet.models.datasets import load_mocap, make_pairs, select_split
from pcnet.models.inference import BODY_WEIGHTS, CAMERA_WEIGHTS, get_session
from pcnet.models.lifter_noise import LifterNoise
from pcnet.models.preprocess import normalize_input
from pcnet.models.view_gate import blend_rotations, camera_frame_weight, frame_quarter_turns, quarter_turn_matrices
from pcnet.pipeline.rectification import NetworkEstimator
from benchmarks.camera_motion_model import decide_camera_motion
from benchmarks.fit_root_path import K as K_VIEW
from benchmarks.fit_root_path import detected_keypoints
from benchmarks.report import BOOTSTRAP, SHARED_DATA, require_folder
from pcnet.stages.core.canonical import canonical_rotation
from pcnet.stages.core.conventions import PELVIS, THORAX, check_poses
from pcnet.stages.core.rotations import angle_between, axis_rotation, camera_pitch_roll, normalize, with_up
from pcnet.stages.flags import posture_flag
from pcnet.stages.ground_plane import posture_and_floor_up
from pcnet.stages.rectify import HeadingStep, Rectification, SequenceEvidence, up_model_sequence
from pcnet.stages.root_path import root_from_keypoints
from pcnet.stages.spherical import robust_mean_direction
from pcnet.stages.uncertainty import FRAME_TILT_95_DEG, frame_tilt_bound
from pcnet.stages.up_model import UpEvidence, default_parameters, static_posterior, summarise_recording

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "ablation.txt"
CACHE = Path("/tmp/pcnet_ablation_cache")
MOCAP_SETS = (("Bandai motion-style test", "bandai_h36m17.npz", "test"),
              ("CMU test subjects", "cmu_train_h36m17.npz", "test"),
              ("DeepMimic, clips no shipped weights trained on", "deepmimic_h36m17.npz", "all"))
REAL_ROLLS_DEG = (0, 90, 180, -90)
EQUIVARIANCE_ROLLS_DEG = (30, 90)
YOGA_STRIDE = 2
GROSS_DEG = 20.0
#: A clip is truly lying where its median trunk (pelvis -> thorax) is this far from the true
#: vertical: the benchmarks' definition of the truth, not a constant of the package (its
#: non-upright warning, which shared it, went with decision 0076).
LYING_TRUNK_DEG = 60.0
#: A mean difference smaller than this (deg) is "no effect" whatever its interval.
NEGLIGIBLE_DEG = 0.05
#: A clip "changed" when its error moved by more than this (deg).
CHANGED_DEG = 0.5
SWEEP_DEG = 30.0
ROLL_DEG = 30.0
QUARTER_DEG = 90.0
SWEEP_MIN_FRAMES = 150
SWEEP_MAX_CLIPS = 60
CACHE_VERSION = 8
#: Recordings whose missed intervals are named one by one (more are counted).
MAX_LISTED = 20


# ============================================================================ extraction


@dataclass(frozen=True)
class _Fixed:
    """A FrameEstimator that returns an estimate already made (so the real chain runs on it)."""

    estimate: object
    name: str = "pcnet"
    frame_tilt_bound_base_deg: float = FRAME_TILT_95_DEG

    def __call__(self, joints_cam, fps=30.0, allocate=None):
        return self.estimate


@contextlib.contextmanager
def recording(session):
    """Record every ``predict_normalized`` call of the pair's two sessions: ``[(net, R)]``."""
    calls = []
    originals = {}
    for net in ("body", "camera"):
        sess = getattr(session, net)
        orig = sess.predict_normalized
        originals[net] = orig

        def wrapped(*a, _orig=orig, _net=net, **k):
            out = _orig(*a, **k)
            calls.append((_net, out[0].copy()))
            return out

        sess.predict_normalized = wrapped
    try:
        yield calls
    finally:
        for net, orig in originals.items():
            del getattr(session, net).predict_normalized  # back to the class's method


def extract(X: np.ndarray, fps: float) -> dict:
    """The cached evidence of one recording ``X`` ``(T, 17, 3)`` (module docstring)."""
    X = np.asarray(X, np.float32)
    session = get_session(None)
    with recording(session) as calls:
        est = NetworkEstimator()(X, fps)
    n = len(X)
    if n > 8192:
        raise ValueError("recordings over one block (8192 frames) are not supported by the recorder")
    turns = est.quarter_turns
    body = [R for net, R in calls if net == "body"]
    cam = [R for net, R in calls if net == "camera"]
    # a second camera-frame pass reads the frames whose running-window turn is not the recording's
    assert len(body) == 1 and len(cam) in (1, 2), (len(body), len(cam))
    R_body = body[0]
    Q = quarter_turn_matrices(turns)
    R_camT = np.swapaxes(Q, 1, 2) @ cam[0]  # the camera-frame network's answer on the turned input, turned back
    R_camP = R_camT.copy()  # the camera-frame network on the input as filmed
    if turns.any():
        idx = np.flatnonzero(turns)
        x, scale, ok = normalize_input(check_poses(X, "joints_cam"))
        R_camP[idx] = session.camera.predict_normalized(x[idx], scale[idx], ok[idx])[0]
    real = Rectification(_Fixed(est), SequenceEvidence("auto", True, n_bootstrap=0), HeadingStep("auto"))(X, fps)
    rep = real.report
    return {
        "fps": float(fps), "J": X, "R_body": R_body, "R_camT": R_camT, "R_camP": R_camP, "valid": est.valid.copy(),
        "turns": turns.copy(), "weight": est.camera_frame_weight.copy(),
        "up_camS": est.evidence.camera_up.copy(), "turnS": frame_quarter_turns(R_body, est.valid),
        "frame_up": est.rotation[:, :, 1].copy(), "real_up": real.up.copy(), "real_valid": real.valid.copy(),
        "real_mode": real.mode, "real_posture": None if rep.posture is None else rep.posture.most_probable,
        "ground_plane_used": bool(rep.sequence is not None and rep.sequence.ground_plane.get("used", False)),
    }


#: The package sources that make the cached evidence (inputs and network outputs); the chain
#: after them runs live, and the reproduction check compares it with the chain run at extraction.
EVIDENCE_SOURCES = ("inference.py", "view_gate.py", "preprocess.py", "datasets.py", "lifter_noise.py")


def _weights_key() -> str:
    """Digest of the shipped weights and :data:`EVIDENCE_SOURCES` (a change re-extracts)."""
    h = hashlib.sha256()
    models = CAMERA_WEIGHTS.parents[1]
    for p in (CAMERA_WEIGHTS, BODY_WEIGHTS, *(models / name for name in EVIDENCE_SOURCES)):
        h.update(p.read_bytes())
    return h.hexdigest()[:12]


#: Separator of the npz keys of :func:`save_records`: ``"{i}/{field}[/{subfield}...]"``.
_SEP = "/"
#: The npz key of the record count and of the manifest (one ``(key, kind)`` row per value).
_COUNT, _MANIFEST = "__count__", "__manifest__"


def _flatten(prefix: str, d: dict, arrays: dict, manifest: list) -> None:
    """Add dict ``d``'s values under ``prefix`` to ``arrays`` (npz key -> array) and ``manifest``."""
    if not d:
        manifest.append((prefix, "dict"))  # an empty dict, so it comes back
    for field, v in d.items():
        if not isinstance(field, str) or _SEP in field:
            raise ValueError(f"field name {field!r} at {prefix!r}: not a str without {_SEP!r}")
        key = f"{prefix}{_SEP}{field}"
        if isinstance(v, dict):
            _flatten(key, v, arrays, manifest)
            continue
        if v is None:
            kind = "none"
        elif isinstance(v, np.ndarray):
            kind = "array"
        elif isinstance(v, np.generic):  # before bool / int / float / str: np.float64 and np.str_ are subclasses
            kind = "scalar"
        elif isinstance(v, bool):
            kind = "bool"
        elif isinstance(v, int):
            kind = "int"
        elif isinstance(v, float):
            kind = "float"
        elif isinstance(v, str):
            kind = "str"
        else:
            raise TypeError(f"{key}: cannot store a {type(v).__name__} without pickle")
        if kind != "none":
            a = np.asarray(v)
            if a.dtype.hasobject:
                raise TypeError(f"{key}: an object array needs pickle")
            arrays[key] = a
        manifest.append((key, kind))


def save_records(path: Path, records: list[dict]) -> None:
    """Write ``records`` (a list of dicts, one per recording) to ``path`` as an ``.npz`` that
    :func:`load_records` reads with ``allow_pickle=False``: every value under the key
    ``"{i}/{field}"`` (nested dicts ``"{i}/{field}/{subfield}"``): numpy arrays as they are
    (any dtype without Python objects), numpy scalars, Python ``bool`` / ``int`` / ``float`` /
    ``str`` as 0-d arrays; ``None`` stored in the manifest only. The manifest (``(key, kind)``
    rows in insertion order) restores the types and the field order. Written atomically
    (a temporary file, then ``replace``).

    Raises:
        TypeError: a value of another type (a list, an object array, ...).
        ValueError: a field name that is not a str or holds ``/``."""
    if not isinstance(records, list) or not all(isinstance(r, dict) for r in records):
        raise TypeError("records must be a list of dicts")
    arrays, manifest = {}, []
    for i, rec in enumerate(records):
        _flatten(str(i), rec, arrays, manifest)
    arrays[_COUNT] = np.asarray(len(records), np.int64)
    arrays[_MANIFEST] = np.asarray(manifest, dtype=np.str_).reshape(-1, 2)
    path = Path(path)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def load_records(path: Path) -> list[dict]:
    """The list of dicts :func:`save_records` wrote to ``path``: the same fields in the same
    order, arrays with their dtypes and shapes, numpy scalars as numpy scalars, Python
    ``bool`` / ``int`` / ``float`` / ``str`` / ``None`` and nested dicts as they were. Read with
    ``allow_pickle=False`` (a file holding pickled objects raises ``ValueError``)."""
    with np.load(path, allow_pickle=False) as z:
        records = [{} for _ in range(int(z[_COUNT]))]
        for key, kind in z[_MANIFEST].tolist():
            i, *fields = key.split(_SEP)
            d = records[int(i)]
            for field in fields[:-1]:
                d = d.setdefault(field, {})
            if kind == "dict":  # an empty dict (a whole record: already there)
                if fields:
                    d.setdefault(fields[-1], {})
                continue
            if kind == "none":
                value = None
            elif kind == "array":
                value = z[key]
            elif kind == "scalar":
                value = z[key][()]
            else:
                value = {"bool": bool, "int": int, "float": float, "str": str}[kind](z[key].item())
            d[fields[-1]] = value
    return records


def cached(cache: Path, name: str, build):
    """``build()`` (a list of dicts) once, saved under ``cache`` by :func:`save_records` (keyed
    on the shipped weights too) and read back by :func:`load_records`."""
    path = cache / f"v{CACHE_VERSION}_{_weights_key()}_{name}.npz"
    if path.is_file():
        return load_records(path)
    t0 = time.time()
    out = build()
    cache.mkdir(parents=True, exist_ok=True)
    save_records(path, out)
    print(f"  extracted {name} in {time.time() - t0:.0f} s", flush=True)
    return out


def static_camera_clips(clips: list, max_clips: int, views: str = "paper", seed: int = 0, rest: bool = False,
                        noise: LifterNoise | None = None):
    """The held-out protocol's recordings: at most ``max_clips`` of ``clips`` (a seeded random
    subset, in order; ``rest``: the clips outside that subset instead), each seen by one static
    camera of ``views`` with lifter noise
    (``make_pairs(..., views=views, seed=seed, camera="static", noise=noise or LifterNoise())``;
    the held-out sets use the "paper" views, seed 0). Yields ``(clip, inputs (T, 17, 3)
    camera-frame joints, R (T, 3, 3) true canonical->camera, frames (T,) the clip's frame
    indices)`` for the clips with at least two frames."""
    if len(clips) > max_clips:
        rng = np.random.default_rng(0)
        chosen = set(rng.choice(len(clips), max_clips, replace=False).tolist())
        clips = [c for i, c in enumerate(clips) if (i in chosen) != rest]
    elif rest:
        return
    pairs = make_pairs(clips, views=views, seed=seed, camera="static", noise=noise or LifterNoise())
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)
        if len(sel) >= 2:
            yield clip, pairs.inputs[sel], pairs.R[sel], pairs.frame[sel]


def camera_view_joints(clip, frames: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``(T, 17, 3)`` float64 the clip's clean joints in the camera frame of ``R`` ``(T, 3, 3)``
    (true canonical->camera of the clip's ``frames``), from its first frame's pelvis, metres.
    The world->camera turn of each frame is ``R_t R_world,t^T`` (``R_world`` canonical->world,
    as make_pairs builds it)."""
    W = clip.joints[frames].astype(np.float64)
    R_world, _ = canonical_rotation(W, (0.0, 1.0, 0.0))
    C = R @ np.swapaxes(R_world, 1, 2)
    return np.einsum("tij,tkj->tki", C, W - W[:1, PELVIS:PELVIS + 1])


def camera_root_path(clip, frames: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``(T, 3)`` float64 the clip's pelvis path in the camera frame of ``R`` (:func:`camera_view_joints`),
    from its first frame's pelvis, metres: what a depth sensor measures of the root (up to the
    camera's position)."""
    return camera_view_joints(clip, frames, R)[:, PELVIS]


def keypoint_root_path(clip, frames: np.ndarray, R: np.ndarray, X: np.ndarray, fps: float,
                       rng: np.random.Generator) -> np.ndarray:
    """``(T, 3)`` float64 the pelvis path a monocular run recovers from 2D keypoints
    (:func:`pcnet.stages.root_path.root_from_keypoints`, what ``pcnet run`` does with
    ``--keypoints2d`` and metric poses) from :func:`detected_keypoints_2d`; the 3D are the
    lifter-noise inputs ``X`` ``(T, 17, 3)``, root-relative. NaN where no fit."""
    X = np.asarray(X, np.float64)
    return root_from_keypoints(X - X[:, PELVIS:PELVIS + 1], detected_keypoints_2d(clip, frames, R, rng), K_VIEW,
                               fps).position


def detected_keypoints_2d(clip, frames: np.ndarray, R: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``(T, 17, 3)`` x_px, y_px, confidence: the 2D keypoints of a monocular run's detector.
    The clip's clean joints in the camera of ``R`` (:func:`camera_view_joints`) stand ``3 m``
    plus the pelvis's largest excursion in front of the camera (as in
    benchmarks/fit_root_path.py) and are seen by :data:`K_VIEW` with its pixel noise and wrong
    detections (:func:`benchmarks.fit_root_path.detected_keypoints`)."""
    P = camera_view_joints(clip, frames, R)
    pelvis = P[:, PELVIS]
    centre = pelvis.mean(0)
    P = P - centre + np.array([0.0, 0.0, 3.0 + np.max(np.linalg.norm(pelvis - centre, axis=1))])
    return detected_keypoints(P, rng)


def mocap_evidence(data: Path, file: str, split: str, max_clips: int, rest: bool = False) -> list[dict]:
    out = []
    for clip, X, R, _ in static_camera_clips(select_split(load_mocap(data / "mocap" / file), split, "motion-style"),
                                             max_clips, rest=rest):
        ev = extract(X, clip.fps)
        ev["name"] = clip.name
        ev["true_up"] = R[:, :, 1].copy()
        out.append(ev)
    return out


@functools.cache
def trained_clip_names() -> frozenset[str]:
    """The clips the shipped weights trained on whole, by their training records'
    ``whole_clips`` (the ``.json`` beside each ``.onnx``): DeepMimic's three floor motions,
    in the camera-frame network's mix. A held-out set leaves them out (:func:`held_out`)."""
    names = set()
    for weights in (CAMERA_WEIGHTS, BODY_WEIGHTS):
        record = get_session(str(weights)).info.get("training_config") or {}
        names.update(record.get("whole_clips") or [])
    return frozenset(names)


def held_out(recordings: list[dict]) -> list[dict]:
    """``recordings`` less those of a clip the shipped weights trained on
    (:func:`trained_clip_names`). The static sets' caches keep every clip, so that a
    recording's inputs (its view, its lifter noise) do not depend on which clips the weights
    trained on; the sets made from them (moving, rolled, pitched cameras) are made from the
    held-out recordings only (their cache keys say ``heldout``)."""
    trained = trained_clip_names()
    return [ev for ev in recordings if ev["name"] not in trained]


def heldout_clips(data: Path, file: str, split: str) -> list:
    """The clips of one :data:`MOCAP_SETS` entry (``DATA/mocap/file``, its motion-style
    ``split``) less those the shipped weights trained on (:func:`trained_clip_names`): what
    a fit's held-out check reads, so that its table's label ("clips no shipped weights trained
    on") holds."""
    trained = trained_clip_names()
    return [c for c in select_split(load_mocap(data / "mocap" / file), split, "motion-style") if c.name not in trained]


def mocap_set(data: Path, cache: Path, file: str, split: str, max_clips: int, rest: bool = False) -> list[dict]:
    """One mocap set's held-out recordings through the networks (:func:`mocap_evidence`,
    :func:`held_out`), :func:`cached` under the key every benchmark shares:
    ``{dataset}_{split}[_rest]_{max_clips}``."""
    key = f"{file.split('_')[0]}_{split}{'_rest' if rest else ''}_{max_clips}"
    return held_out(cached(cache, key, lambda: mocap_evidence(data, file, split, max_clips, rest=rest)))


def heldout_sweep(cache: Path, static: list[list[dict]], max_clips: int) -> list[dict]:
    """The held-out moving camera (:func:`sweep_evidence` of the Bandai test and DeepMimic sets,
    ``static`` in :data:`MOCAP_SETS` order), :func:`cached` under ``sweep_heldout_{max_clips}``."""
    return cached(cache, f"sweep_heldout_{max_clips}", lambda: sweep_evidence([static[0], static[2]]))


def sweep_evidence(sets: list[list[dict]]) -> list[dict]:
    """A moving camera: the cached static-camera inputs of clips with at least
    :data:`SWEEP_MIN_FRAMES` frames (at most :data:`SWEEP_MAX_CLIPS` per set), the camera's
    pitch sweeping linearly through :data:`SWEEP_DEG` over the clip (benchmarks/auto_mode_threshold.py):
    ``X'_t = X_t @ S_t.T``, true up ``S_t u``."""
    out = []
    for evs in sets:
        for ev in [e for e in evs if len(e["J"]) >= SWEEP_MIN_FRAMES][:SWEEP_MAX_CLIPS]:
            T = len(ev["J"])
            S = np.stack([axis_rotation("x", a) for a in np.radians(np.linspace(-1, 1, T) * SWEEP_DEG / 2)])
            X = np.einsum("tij,tkj->tki", S, ev["J"].astype(np.float64)).astype(np.float32)
            new = extract(X, ev["fps"])
            new.update(name=ev["name"], true_up=np.einsum("tij,tj->ti", S, ev["true_up"]))
            out.append(new)
    return out


def roll_matrix(index: int, roll_deg: float) -> np.ndarray:
    """``(3, 3)`` the camera roll of clip ``index`` of a set: ``roll_deg`` about the optical
    axis, clockwise for even clips and anticlockwise for odd ones."""
    return axis_rotation("z", np.radians(roll_deg if index % 2 == 0 else -roll_deg))


def rolled_evidence(sets: list[list[dict]], roll_deg: float = ROLL_DEG) -> list[dict]:
    """The cached static-camera recordings of ``sets`` with the camera rolled ``roll_deg``
    (:func:`roll_matrix`): ``X' = X Q^T``, true up ``Q u``; ``set`` and ``index`` name the
    unrolled recording."""
    out = []
    for s, evs in enumerate(sets):
        for i, ev in enumerate(evs):
            Q = roll_matrix(i, roll_deg)
            new = extract((ev["J"].astype(np.float64) @ Q.T).astype(np.float32), ev["fps"])
            new.update(name=ev["name"], true_up=ev["true_up"] @ Q.T, set=s, index=i)
            out.append(new)
    return out


def rolled_table(rolled: list[dict], runs: dict, static: list[tuple[str, list[dict], dict]]) -> list[str]:
    """Per variant, the mean extra sequence tilt error (deg) of the rolled recordings over their
    unrolled ones, per set and over all (module docstring); ``static``: the mocap sections'
    ``(title, recordings, runs)`` in :func:`rolled_evidence`'s set order."""
    titles = [t.split(":")[0] for t, _, _ in static]
    lines = [f"## Camera rolled {ROLL_DEG:g} deg about its optical axis (the held-out mocap above, alternate clips "
             f"clockwise and anticlockwise): extra sequence tilt error (deg) against the same clip unrolled, mean over "
             f"clips [p95]; verdict on the extra over all {len(rolled)} clips",
             f"{'variant':<40}" + "".join(f"{t[:22]:>24}" for t in titles) + f"{'all':>16}{'frame':>7}"
             + "  verdict: mean diff vs default [95 % CI]"]
    sets = np.array([ev["set"] for ev in rolled])
    base = None

    def frame_error(out, evs) -> float:
        return float(np.nanmean(np.concatenate([deg(o["frame_up"], ev["true_up"]) for o, ev in zip(out, evs)])))

    for v in VARIANTS:
        out = runs[v.label]
        extra = np.array([clip_error(o["up"], ev["true_up"])
                          - clip_error(static[ev["set"]][2][v.label][ev["index"]]["up"],
                                       static[ev["set"]][1][ev["index"]]["true_up"]) for o, ev in zip(out, rolled)])
        if v.kind == "default":
            base = extra
        cells = "".join(f"{np.nanmean(extra[sets == s]):>+17.2f} [{np.nanpercentile(extra[sets == s], 95):>+4.1f}]"
                        for s in range(len(static)))
        # the per-frame tilt error of the rolled views (deg, every frame of every clip): the view
        # gate's ramps change only the per-frame answers
        lines.append(f"{v.label:<40}{cells}{np.nanmean(extra):>+9.2f} [{np.nanpercentile(extra, 95):>+4.1f}]"
                     f"{frame_error(out, rolled):>7.2f}  {verdict(v.kind, extra - base)}")
    label = VARIANTS[0].label
    lines.append(f"{label}, median extra per set: "
                 + ", ".join(f"{t} {np.nanmedian(base[sets == s]):+.2f}" for s, t in enumerate(titles)))

    lines.append(f"{label}, per-frame tilt error (deg) unrolled -> rolled per set: " + ", ".join(
        f"{t} {frame_error(static[s][2][label], static[s][1]):.2f} -> "
        f"{frame_error([o for o, ev in zip(runs[label], rolled) if ev['set'] == s], [ev for ev in rolled if ev['set'] == s]):.2f}"
        for s, t in enumerate(titles)))
    worst = np.argsort(-np.nan_to_num(base, nan=-np.inf))[:8]
    lines.append(f"{label}, the {len(worst)} largest extras: "
                 + ", ".join(f"{rolled[i]['name'].removesuffix('.txt')} {base[i]:+.1f}" for i in worst))
    return lines


def rolled_recordings(cache: Path, static: list[list[dict]], max_clips: int, roll_deg: float = ROLL_DEG) -> list[dict]:
    """:func:`rolled_evidence` of the held-out mocap ``static`` (:data:`MOCAP_SETS` order), cached
    under ``rolled{roll_deg}_heldout_{max_clips}``."""
    return cached(cache, f"rolled{roll_deg:g}_heldout_{max_clips}", lambda: rolled_evidence(static, roll_deg))


def pitched_evidence(sets: list[list[dict]], pitch_deg) -> list[dict]:
    """The cached static-camera recordings of ``sets`` with the camera pitched ``pitch_deg``
    further down about its x axis: ``X' = X P^T``, true up ``P u`` (a camera on a ceiling rig or
    a balcony; benchmarks/view_gate_pieces.py, benchmarks/steep_camera.py). ``pitch_deg``: one
    angle (deg) for every recording, or a sequence of one per recording in order."""
    n = sum(len(evs) for evs in sets)
    angles = iter(np.broadcast_to(np.asarray(pitch_deg, np.float64), (n,)))
    out = []
    for evs in sets:
        for ev in evs:
            P = axis_rotation("x", np.radians(next(angles)))
            new = extract((ev["J"].astype(np.float64) @ P.T).astype(np.float32), ev["fps"])
            new.update(name=ev["name"], true_up=ev["true_up"] @ P.T)
            out.append(new)
    return out


def pitched_recordings(cache: Path, static: list[list[dict]], max_clips: int, pitch_deg: float) -> list[dict]:
    """:func:`pitched_evidence` of the held-out mocap ``static`` (:data:`MOCAP_SETS` order), cached
    under ``pitched{pitch_deg}_heldout_{max_clips}``."""
    return cached(cache, f"pitched{pitch_deg:g}_heldout_{max_clips}", lambda: pitched_evidence(static, pitch_deg))


def real_recordings(data: Path, cache: Path) -> list[dict]:
    """:func:`real_camera_evidence`, cached under ``real_cameras``."""
    return cached(cache, "real_cameras", lambda: real_camera_evidence(data))


def heldout_arguments(argv, doc: str, script: str, result: Path | None,
                      flags: tuple[tuple[str, str], ...] = ()) -> argparse.Namespace:
    """The command line of a script that scores this ablation's held-out recordings: ``--data``,
    ``--max-clips`` (the cache's keys), ``--cache``, ``--out`` (default ``result``) and the
    script's own on/off ``flags`` (``(name, help)``); exits with one line where ``--data`` lacks
    the mocap."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--max-clips", type=int, default=200, help="as benchmarks/ablation.py's (its cache keys)")
    ap.add_argument("--cache", type=Path, default=CACHE)
    ap.add_argument("--out", type=Path, default=result)
    for name, text in flags:
        ap.add_argument(name, action="store_true", help=text)
    args = ap.parse_args(argv)
    require_folder(args.data, script)
    return args


def heldout_recordings(data: Path, cache: Path, max_clips: int, quarter: bool = False) -> list[tuple[str, list[dict]]]:
    """``(title, recordings)`` of this ablation's held-out sets, from its cache: the
    :data:`MOCAP_SETS`, the moving camera, the camera rolled :data:`ROLL_DEG` (and
    :data:`QUARTER_DEG` with ``quarter``) and the real calibrated cameras in 16 views."""
    static = [mocap_set(data, cache, file, split, max_clips) for _, file, split in MOCAP_SETS]
    out = [(title, evs) for (title, _, _), evs in zip(MOCAP_SETS, static)]
    out.append((f"moving camera (pitch sweeping {SWEEP_DEG:g} deg)", heldout_sweep(cache, static, max_clips)))
    rolls = (ROLL_DEG, QUARTER_DEG) if quarter else (ROLL_DEG,)
    out += [(f"camera rolled {roll:g} deg (the three sets)", rolled_recordings(cache, static, max_clips, roll))
            for roll in rolls]
    out.append(("real calibrated cameras, 16 views", real_recordings(data, cache)))
    return out


def real_camera_evidence(data: Path) -> list[dict]:
    from benchmarks.gravity_benchmark import load_camera, roll_view

    out = []
    for path in sorted((data / "real" / "pose2sim_gravity").glob("statictrial_cam*.npz")):
        joints, up, fps = load_camera(path)
        for roll in REAL_ROLLS_DEG:
            J, u = roll_view(joints, up, roll)
            ev = extract(J, fps)
            ev.update(name=f"{path.stem.replace('statictrial_', '')} roll {roll:+d}", true_up=np.tile(u, (len(J), 1)),
                      camera=path.stem.replace("statictrial_", ""), roll=roll)
            out.append(ev)
    return out


def yoga_evidence(data: Path) -> list[dict]:
    from benchmarks.yoga_physics import FPS, parse_name, plain_export

    from pcnet.adapters import load_videopose3d
    from pcnet.stages.core.conventions import root_relative

    paths = sorted((data / "real" / "yoga_videopose3d").glob("*.npy"), key=lambda p: (not plain_export(p), p.name))
    out, seen = [], set()
    for path in paths:
        poses = load_videopose3d(path)
        digest = hashlib.sha1(np.ascontiguousarray(poses.joints).tobytes()).hexdigest()
        if digest in seen:
            continue
        seen.add(digest)
        joints, _ = root_relative(poses.joints[::YOGA_STRIDE])
        ev = extract(joints, FPS / YOGA_STRIDE)
        ev.update(name=path.name, asana=parse_name(path)[1])
        out.append(ev)
    return out


def equivariance_evidence(data: Path) -> list[dict]:
    from benchmarks.equivariance import load_clips

    out = []
    for name, joints, fps in load_clips(data, 300):
        for roll in (0, *EQUIVARIANCE_ROLLS_DEG):
            Q = axis_rotation("z", np.radians(roll))
            ev = extract(joints @ Q.T, fps)
            ev.update(name=name, roll=roll, Q=Q)
            out.append(ev)
    return out


def evidence_of(ev: dict, turns: bool = True, nets: str = "both") -> UpEvidence:
    """The up model's evidence of one cached recording: each network's own up (the camera-frame
    network's on each frame turned back by its own quarter turn, turned forward again: decision
    0074) and those turns; ``turns`` False: the camera-frame network on the input as filmed;
    ``nets`` ``"camera"`` or ``"body"``: only that network's ups (the other's blanked, so its
    term of the likelihood is 0)."""
    Q = quarter_turn_matrices(ev["turnS"]) if turns and ev["turnS"].any() else None
    c = np.where(ev["valid"][:, None] & (nets != "body"), ev["up_camS"] if turns else ev["R_camP"][:, :, 1], np.nan)
    b = np.where(ev["valid"][:, None] & (nets != "camera"), ev["R_body"][:, :, 1], np.nan)
    return UpEvidence.of(c, b, Q)


# ============================================================================ variants


@dataclass(frozen=True)
class Variant:
    """One row: the default chain with switches (module docstring)."""

    label: str
    kind: str = "removal"  # "default", "removal" or "alternative"
    gate: str = "shipped"  # shipped | body-estimate | half | body | camera
    turns: bool = True
    prior: bool = True
    lying: bool = True
    auto: bool = False  # auto mode (static or moving by mode_rule); False = sequence, pcnet run's default
    plain_mean: bool = False  # equal-weight Tukey mean of both networks' per-frame ups
    nets: str = "both"  # the up model's evidence: "both" networks' ups, or only the "camera" or "body" one's
    mode_rule: str = "spread"  # auto's static/moving rule: "spread" (choose_mode) | "bayes" (benchmarks/camera_motion_model.py)
    #: auto's threshold (deg), its low-pass (s) and smooth mode's time constant (s); None = the package's
    mode_constants: tuple[float, float, float] | None = None
    #: up model parameters overridden, ``((name, value), ...)``: a term of its likelihood switched off
    params: tuple[tuple[str, float], ...] = ()

    def up_parameters(self):
        """The up model's parameters of this row: the shipped ones with :attr:`params` replaced."""
        return replace(default_parameters(), **dict(self.params))


#: The chain the extraction ran (benchmarks' real chain, mode auto), which the reproduction check rebuilds.
AUTO = "auto: static or moving by the spread threshold"
VARIANTS = (
    Variant("default (pcnet run)", "default"),
    Variant("up model: lying posture off", lying=False),
    Variant("up model: camera prior and lying posture off", prior=False),
    Variant("up model: camera-frame net's level fall-back off", params=(("camera_fallback_deg", 1e4),)),
    Variant("up model: no outlier share (von Mises-Fisher alone)", params=(("outlier_share", 0.0),)),
    Variant("up model: no systematic error (S = 0)", params=(("systematic_pitch_deg", 0.0), ("systematic_roll_deg", 0.0))),
    Variant("up model: frames independent (tau = 0)", params=(("error_time_s", 0.0),)),
    Variant("up model: body-frame net's term off", nets="camera"),
    Variant("up model: camera-frame net's term off", nets="body"),
    Variant("plain Tukey mean of both nets' ups", "alternative", plain_mean=True, prior=False, auto=False),
    Variant("gate off: fixed 50/50", gate="half"),
    Variant("gate off: body-frame net only", gate="body"),
    Variant("gate off: camera-frame net only", gate="camera"),
    Variant("gate: body-frame estimate alone", gate="body-estimate"),
    Variant("gate: pitch ramps alone (the hand-set roll ramps off)", gate="pitch"),
    Variant("quarter turns off", turns=False),
    Variant(AUTO, "alternative", auto=True),
    Variant("auto with hand-set constants (5 deg, 0.5 s, 0.2 s)", "alternative", auto=True,
            mode_constants=(5.0, 0.5, 0.2)),
    Variant("auto by Bayes factor", "alternative", auto=True, mode_rule="bayes"),
)


def gate_inputs(ev: dict, turns: bool = True):
    """``(Rb, Rc, valid, Qb, Qc)``: one cached recording's body-frame and camera-frame rotations
    ``(T, 3, 3)`` (the camera-frame network's on the quarter-turned input, turned back, or with
    ``turns`` False on the input as filmed), their valid frames, and both rotations in the
    quarter-turned frame the view gate reads."""
    Rb = ev["R_body"]
    if turns:
        Rc, k, valid = ev["R_camT"], ev["turns"], ev["valid"]
    else:
        Rc, k = ev["R_camP"], np.zeros(len(Rb), np.int64)
        valid = ev["valid"] & np.isfinite(Rc).all((1, 2))
    Q = quarter_turn_matrices(k) if k.any() else None
    Qb, Qc = (Rb, Rc) if Q is None else (Q @ Rb, Q @ Rc)
    return Rb, Rc, valid, Qb, Qc


def per_frame(ev: dict, v: Variant):
    """``(R (T,3,3), valid, weight, disagreement)``: the pair's per-frame estimate under ``v``
    (ViewGatedPCNet.predict_gated's arithmetic on the cached network outputs)."""
    fps = ev["fps"]
    Rb, Rc, valid, Qb, Qc = gate_inputs(ev, v.turns)
    if v.gate == "shipped":
        w = camera_frame_weight(Qb, valid, fps, Qc)
    elif v.gate == "body-estimate":
        w = camera_frame_weight(Qb, valid, fps)
    elif v.gate == "pitch":  # |roll| <= 180, so ramps from 180 to 360 deg are 1: roll taken out
        w = camera_frame_weight(Qb, valid, fps, Qc, roll_ramp_deg=(180.0, 360.0), body_roll_limit_deg=(180.0, 360.0))
    else:
        w = np.where(valid, {"half": 0.5, "body": 0.0, "camera": 1.0}[v.gate], np.nan)
    R = with_up(Rb, blend_rotations(Rb, Rc, w)[:, :, 1])
    R[~valid] = np.nan
    d = np.degrees(angle_between(Rc[:, :, 1], Rb[:, :, 1]))
    return R, valid, w, d


def shipped_rotations(ev: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(R (T, 3, 3), ok (T,))``: the default chain's per-frame rotations of one cached
    recording and its valid frames (:func:`per_frame` of the default variant, checked by
    :func:`pcnet.stages.temporal.check_rotations`)."""
    R, valid, _, _ = per_frame(ev, VARIANTS[0])
    return temporal.check_rotations(R, valid)


def run_variant(ev: dict, v: Variant) -> dict:
    """Output ups ``(T, 3)`` (NaN where not valid), the per-frame ups, the mode and the posture."""
    J, fps = ev["J"], ev["fps"]
    if v.plain_mean:
        ok = ev["valid"] & np.isfinite(ev["R_camP"]).all((1, 2))
        ub, uc = ev["R_body"][ok, :, 1], ev["R_camP"][ok, :, 1]
        up, _ = robust_mean_direction(np.concatenate([ub, uc]))
        frame = np.full((len(J), 3), np.nan)
        frame[ok] = normalize(ub + uc)
        out = np.where(ok[:, None], up[None], np.nan)
        return {"up": out, "frame_up": frame, "mode": "sequence", "posture": None, "bound": None}
    R, valid, w, d = per_frame(ev, v)
    bound = frame_tilt_bound(d, w, FRAME_TILT_95_DEG)
    R, ok = temporal.check_rotations(R, valid)
    res = {"frame_up": np.where(ok[:, None], R[:, :, 1], np.nan), "bound": np.where(ok, bound, np.nan)}
    if v.auto and ok.sum() < 2:
        return {**res, "up": res["frame_up"], "mode": "frame", "posture": None}
    evidence = evidence_of(ev, v.turns, v.nets)
    if not v.auto:
        mode = "sequence"
    elif v.mode_rule == "bayes":
        mode = "smooth" if decide_camera_motion(R[:, :, 1], ok, fps).moving else "sequence"
    else:
        threshold, lowpass, _ = v.mode_constants or (temporal.MODE_THRESHOLD_DEG, temporal.MODE_SMOOTHING_S, None)
        mode = "sequence" if temporal.up_spread_deg(R, ok, fps, lowpass) <= threshold else "smooth"
    if mode == "smooth":
        tau = temporal.SMOOTH_TIME_CONSTANT_S if v.mode_constants is None else v.mode_constants[2]
        out = temporal.smooth_rotations(R, ok, fps, tau)[:, :, 1]
        return {**res, "up": np.where(ok[:, None], out, np.nan), "mode": mode, "posture": None}
    p = v.up_parameters()
    if v.lying:  # the chain's own sequence step
        _, _, seq = up_model_sequence(R, ok, evidence, fps, camera_prior=v.prior, params=p)
        pitch, roll = camera_pitch_roll(seq.up)
        return {**res, "up": np.where(ok[:, None], seq.up, np.nan), "mode": mode,
                "posture": "upright" if seq.posture is None else seq.posture.most_probable,
                "posture_warned": bool(posture_flag(seq)),
                "interval": (np.degrees(pitch), np.degrees(roll), seq.camera_pitch_interval_deg,
                             seq.camera_roll_interval_deg)}
    post = static_posterior(summarise_recording(evidence.frames(ok), fps, p), p, lying=False)
    return {**res, "up": np.where(ok[:, None], post.up, np.nan), "mode": mode, "posture": post.posture}


# ============================================================================ metrics


def deg(u, v) -> np.ndarray:
    return np.degrees(angle_between(np.asarray(u, np.float64), np.asarray(v, np.float64)))


def clip_error(up: np.ndarray, truth: np.ndarray) -> float:
    e = deg(up, truth)
    return float(np.nanmean(e)) if np.isfinite(e).any() else float("nan")


def paired_interval(diff: np.ndarray, rng_seed: int = 0) -> tuple[float, float, float]:
    """Mean of ``diff`` and the 95 % percentile interval of a paired bootstrap over its items."""
    d = diff[np.isfinite(diff)]
    if len(d) == 0:
        return float("nan"), float("nan"), float("nan")
    rng = np.random.default_rng(rng_seed)
    means = d[rng.integers(0, len(d), (BOOTSTRAP, len(d)))].mean(1)
    return float(d.mean()), float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def verdict(kind: str, diff: np.ndarray, tol: float = 1e-9, negligible: float = NEGLIGIBLE_DEG) -> str:
    """The row's word and interval (module docstring)."""
    if kind == "default":
        return "-"
    m, lo, hi = paired_interval(diff)
    if not np.isfinite(m):
        return "n/a"
    if abs(m) < tol and abs(lo) < tol and abs(hi) < tol:
        word = "no effect" if kind == "removal" else "same"
        return f"{word} (identical)"
    if abs(m) < negligible:
        word = "no effect" if kind == "removal" else "same"
    elif lo > 0:
        word = "helps" if kind == "removal" else "worse"
    elif hi < 0:
        word = "hurts" if kind == "removal" else "better"
    else:
        word = "no effect" if kind == "removal" else "same"
    d = diff[np.isfinite(diff)]
    moved = f" ({int(np.sum(d > CHANGED_DEG))} worse, {int(np.sum(d < -CHANGED_DEG))} better)"
    return f"{word} {m:+.2f} [{lo:+.2f}, {hi:+.2f}]{moved}"


def yoga_verdict(kind: str, diff: np.ndarray) -> str:
    """:func:`verdict` on a difference in fail indicators (no degree threshold)."""
    return verdict(kind, diff, negligible=0.0)


def true_lying(ev: dict) -> bool:
    J = ev["J"].astype(np.float64)
    a = deg(J[:, THORAX] - J[:, PELVIS], ev["true_up"])
    return bool(np.nanmedian(a) > LYING_TRUNK_DEG)


def mocap_table(title: str, evs: list[dict], runs: dict) -> list[str]:
    lying = np.array([true_lying(ev) for ev in evs])
    frames = sum(len(ev["J"]) for ev in evs)
    lines = [f"## {title}: {len(evs)} clips, {frames} frames ({int(lying.sum())} clips truly lying)",
             f"{'variant':<40}{'seq mean':>9}{'median':>8}{'p95':>8}{'frame':>8}{'>20':>5}{'lying':>6}"
             f"{'smooth':>7}{'cover':>7}  verdict: mean diff vs default [95 % CI], deg", ]
    base = None
    for v in VARIANTS:
        out = runs[v.label]
        err = np.array([clip_error(o["up"], ev["true_up"]) for o, ev in zip(out, evs)])
        fe = np.concatenate([deg(o["frame_up"], ev["true_up"]) for o, ev in zip(out, evs)])
        wrong = sum((o["posture"] == "lying") != t for o, t in zip(out, lying))
        smooth = sum(o["mode"] == "smooth" for o in out)
        if v.kind == "default":
            base = err
        lines.append(f"{v.label:<40}{np.nanmean(err):>9.2f}{np.nanmedian(err):>8.2f}{np.nanpercentile(err, 95):>8.2f}"
                     f"{np.nanmean(fe):>8.2f}{int(np.sum(err > GROSS_DEG)):>5}{wrong:>6}{smooth:>7}"
                     f"{both_axes_coverage(out, evs):>7.1f}  {verdict(v.kind, err - base)}")
    label = VARIANTS[0].label
    hits = np.concatenate([deg(o["frame_up"], ev["true_up"]) <= o["bound"] for o, ev in zip(runs[label], evs)
                           if o["bound"] is not None])
    lines.append("per-frame 95 % bound coverage (frames whose per-frame tilt error is within the reported bound): "
                 f"{label}: {100 * np.mean(hits):.2f} %")
    lines.append(interval_coverage(runs[label], evs))
    lines.append(f"recordings whose sequence intervals miss the truth: {interval_misses(runs[label], evs)}")
    return lines


def interval_hits(out: list[dict], evs: list[dict]) -> np.ndarray:
    """``(n, 2)`` bool: for each of the ``n`` recordings run in sequence mode with intervals,
    whether its true camera pitch / roll lies inside the printed 95 % interval (the up model's
    posterior half-widths)."""
    hit = []
    for o, ev in zip(out, evs):
        if o.get("interval") is None:
            continue
        p, r, hp, hr = o["interval"]
        tp, tr = np.degrees(camera_pitch_roll(ev["true_up"][np.flatnonzero(np.isfinite(o["up"]).all(-1))[0]]))
        hit.append((abs(tp - p) <= hp, abs((tr - r + 180.0) % 360.0 - 180.0) <= hr))
    return np.array(hit, bool).reshape(-1, 2)


def interval_misses(out: list[dict], evs: list[dict]) -> str:
    """The recordings whose printed intervals (:func:`interval_hits`) miss the truth on an axis,
    ``name (pitch|roll|both)``, comma-separated; ``"none"`` without any; only their count
    beyond :data:`MAX_LISTED`."""
    run = [(o, ev) for o, ev in zip(out, evs) if o.get("interval") is not None]
    hits = interval_hits([o for o, _ in run], [ev for _, ev in run])
    missed = [f"{ev['name']} ({'both' if not h.any() else 'pitch' if not h[0] else 'roll'})"
              for (_, ev), h in zip(run, hits) if not h.all()]
    if len(missed) > MAX_LISTED:
        return f"{len(missed)} of {len(run)}"
    return ", ".join(missed) or "none"


def both_axes_coverage(out: list[dict], evs: list[dict]) -> float:
    """Per cent of the recordings with intervals (:func:`interval_hits`) whose pitch and roll
    intervals both hold the truth; NaN where none has intervals."""
    h = interval_hits(out, evs)
    return 100.0 * float(h.all(1).mean()) if len(h) else float("nan")


def interval_coverage(out: list[dict], evs: list[dict]) -> str:
    """The coverage line of :func:`interval_hits`: pitch, roll and both, per cent."""
    h = interval_hits(out, evs)
    if not len(h):
        return "sequence 95 % interval coverage: no recording read static"
    return (f"sequence 95 % interval coverage ({len(h)} recordings read static): pitch {100 * h[:, 0].mean():.1f} %, "
            f"roll {100 * h[:, 1].mean():.1f} %, both {100 * h.all(1).mean():.1f} %")


def real_table(evs: list[dict], runs: dict) -> list[str]:
    cams = sorted({ev["camera"] for ev in evs})
    lines = ["## Real calibrated 4 cameras (pose2sim_gravity): sequence tilt error (deg) per camera as filmed, "
             "mean over cameras per extra roll; verdict over the 16 views",
             f"{'variant':<40}" + "".join(f"{c:>7}" for c in cams) + "".join(f"{'r' + format(r, '+d'):>7}"
                                                                            for r in REAL_ROLLS_DEG)
             + f"{'cover':>7}{'frame':>7}{'fr r0':>7}  verdict: mean diff vs default [95 % CI]"]
    base = None
    as_filmed = [i for i, ev in enumerate(evs) if ev["roll"] == 0]
    for v in VARIANTS:
        err = np.array([clip_error(o["up"], ev["true_up"]) for o, ev in zip(runs[v.label], evs)])
        if v.kind == "default":
            base = err
        per_cam = [err[[i for i, ev in enumerate(evs) if ev["camera"] == c and ev["roll"] == 0][0]] for c in cams]
        per_roll = [np.mean(err[[i for i, ev in enumerate(evs) if ev["roll"] == r]]) for r in REAL_ROLLS_DEG]
        # the per-frame tilt error (deg, mean over frames): every view, and the views as filmed
        frame = [float(np.nanmean(np.concatenate([deg(runs[v.label][i]["frame_up"], evs[i]["true_up"]) for i in idx])))
                 for idx in (range(len(evs)), as_filmed)]
        lines.append(f"{v.label:<40}" + "".join(f"{e:>7.1f}" for e in per_cam) + "".join(f"{e:>7.1f}" for e in per_roll)
                     + f"{both_axes_coverage(runs[v.label], evs):>7.1f}" + "".join(f"{e:>7.1f}" for e in frame)
                     + f"  {verdict(v.kind, err - base)}")
    lines.append(interval_coverage(runs[VARIANTS[0].label], evs))
    return lines


def yoga_table(evs: list[dict], runs: dict) -> list[str]:
    from benchmarks.yoga_physics import TARGETS

    targeted = [i for i, ev in enumerate(evs) if ev["asana"] in TARGETS]
    counts = {a: sum(evs[i]["asana"] == a for i in targeted) for a in TARGETS}
    lines = [f"## Yoga physics ({len(evs)} real VideoPose3D files, stride {YOGA_STRIDE}): files FAILING the trunk "
             "target per asana (" + ", ".join(f"{a} {op} {t:g}: {counts[a]} files" for a, (op, t) in TARGETS.items())
             + "); median trunk angle (deg) over files per asana; verdict on the fail count over the targeted files",
             f"{'variant':<40}" + "".join(f"{'fail ' + a[:5]:>11}" for a in TARGETS)
             + "".join(f"{'med ' + a[:5]:>11}" for a in TARGETS) + "  verdict: fails diff vs default [95 % CI]"]
    base = None
    for v in VARIANTS:
        trunk = []
        for o, ev in zip(runs[v.label], evs):
            J = ev["J"].astype(np.float64)
            a = deg(J[:, THORAX] - J[:, PELVIS], o["up"])
            trunk.append(float(np.nanmedian(a)) if np.isfinite(a).any() else np.nan)
        fails = np.array([float(not (trunk[i] >= TARGETS[evs[i]["asana"]][1] if TARGETS[evs[i]["asana"]][0] == ">="
                                     else trunk[i] <= TARGETS[evs[i]["asana"]][1])) for i in targeted])
        if v.kind == "default":
            base = fails
        per = [int(sum(f for f, i in zip(fails, targeted) if evs[i]["asana"] == a)) for a in TARGETS]
        med = [np.nanmedian([trunk[i] for i in targeted if evs[i]["asana"] == a]) for a in TARGETS]
        lines.append(f"{v.label:<40}" + "".join(f"{p:>11d}" for p in per) + "".join(f"{m:>11.1f}" for m in med)
                     + f"  {yoga_verdict(v.kind, fails - base)}")
    # Standing straight, the trunk is vertical up to the person's posture (a few degrees): a
    # truth for the printed intervals on real lifter output, with that posture added to its error.
    standing = [i for i, ev in enumerate(evs) if ev["asana"] == "Tadasana"]
    proxies = [{"true_up": np.tile(trunk_up(evs[i]["J"]), (len(evs[i]["J"]), 1))} for i in standing]
    cover = interval_coverage([runs[VARIANTS[0].label][i] for i in standing], proxies)
    lines.append(f"default, Tadasana files, the trunk's robust mean direction taken as the true up: {cover}")
    return lines


def trunk_up(J: np.ndarray) -> np.ndarray:
    """``(3,)`` the robust (Tukey) mean direction of the pelvis -> thorax vectors of ``J`` ``(T, 17, 3)``."""
    J = np.asarray(J, np.float64)
    t = normalize(J[:, THORAX] - J[:, PELVIS])
    return robust_mean_direction(t[np.isfinite(t).all(-1)])[0]


def equivariance_table(evs: list[dict], runs: dict) -> list[str]:
    names = list(dict.fromkeys(ev["name"] for ev in evs))
    lines = [f"## Roll equivariance ({len(names)} real clips of benchmarks/equivariance.py, middle 300 frames): extra "
             "error (deg) of the up when the camera rolls, mean over clips [worst clip]; verdict over the "
             f"{len(names) * len(EQUIVARIANCE_ROLLS_DEG)} rolled clips",
             f"{'variant':<40}" + "".join(f"{'roll ' + str(r):>16}" for r in EQUIVARIANCE_ROLLS_DEG)
             + "  verdict: mean diff vs default [95 % CI]"]
    base = None
    for v in VARIANTS:
        out = runs[v.label]
        extra = {}
        for name in names:
            i0 = next(i for i, ev in enumerate(evs) if ev["name"] == name and ev["roll"] == 0)
            for r in EQUIVARIANCE_ROLLS_DEG:
                i = next(i for i, ev in enumerate(evs) if ev["name"] == name and ev["roll"] == r)
                e = deg(out[i]["up"], out[i0]["up"] @ evs[i]["Q"].T)
                extra[(name, r)] = float(np.nanmean(e)) if np.isfinite(e).any() else np.nan
        vals = np.array([extra[(n, r)] for n in names for r in EQUIVARIANCE_ROLLS_DEG])
        if v.kind == "default":
            base = vals
        cells = "".join(f"{np.nanmean([extra[(n, r)] for n in names]):>9.1f} [{np.nanmax([extra[(n, r)] for n in names]):>4.0f}]"
                        for r in EQUIVARIANCE_ROLLS_DEG)
        lines.append(f"{v.label:<40}{cells}  {verdict(v.kind, vals - base)}")
    return lines


def measured_root_recordings(data: Path, file: str, split: str, max_clips: int, evs: list[dict], rest: bool = False):
    """The held-out recordings ``evs`` of ``file`` / ``split`` (:func:`mocap_evidence`, ``rest``
    as there) with a pelvis path: ``[(ev, joints with the path a depth sensor measures
    (:func:`camera_root_path`), joints with the path recovered from 2D keypoints
    (:func:`keypoint_root_path`, NaN frames where it has no fit))]``, each ``(T, 17, 3)``
    camera frame, metres. The 2D noise is seeded per set (0), drawn clip after clip."""
    by_name = {ev["name"]: ev for ev in evs}
    rng = np.random.default_rng(0)
    out = []
    for clip, X, R, frames in static_camera_clips(select_split(load_mocap(data / "mocap" / file), split, "motion-style"),
                                                  max_clips, rest=rest):
        if clip.name not in by_name:  # trained on (:func:`held_out`)
            continue
        ev = by_name[clip.name]
        if not np.array_equal(X, ev["J"]):
            raise SystemExit(f"{clip.name}: the cached inputs differ from make_pairs' (stale cache?)")
        X = X.astype(np.float64)
        from_2d = keypoint_root_path(clip, frames, R, X, ev["fps"], rng)
        out.append((ev, X + camera_root_path(clip, frames, R)[:, None], X - X[:, PELVIS:PELVIS + 1] + from_2d[:, None]))
    return out


def floor_recordings(data: Path, cache: Path, max_clips: int, static: list[list[dict]]) -> list[tuple[str, list]]:
    """``[(title, recordings)]`` of the floor sections: each held-out mocap set ``static``
    (:data:`MOCAP_SETS` order, :func:`mocap_set`) with its pelvis path
    (:func:`measured_root_recordings`), then the Bandai test split's other clips, untouched by
    the floor work until decision 0043 (the sets before were seen in 0042)."""
    sets = [(title, measured_root_recordings(data, file, split, max_clips, evs))
            for (title, file, split), evs in zip(MOCAP_SETS, static)]
    file, split = MOCAP_SETS[0][1:]
    rest = mocap_set(data, cache, file, split, max_clips, rest=True)
    sets.append(("Bandai test, other clips", measured_root_recordings(data, file, split, max_clips, rest, rest=True)))
    return sets


def floor_table(sets: list[tuple[str, list]]) -> list[str]:
    """The floor contacts switched off, on held-out recordings with a pelvis path: per set the
    sequence tilt error of the default chain with a measured root (the up model fused with the
    floor, :func:`pcnet.stages.rectify.up_model_sequence` with the located joints), of the up
    model alone, and of the floor with the path recovered from 2D keypoints (its verdict
    against the up model alone), the recordings whose floor moved the up, and the 95 % interval
    coverage of each."""
    lines = ["## Floor contacts with a pelvis path (the held-out mocap above with each clip's pelvis path kept, as "
             "a depth sensor measures it, or recovered from simulated 2D keypoints): sequence tilt error (deg) over "
             "clips",
             f"{'set':<28}{'variant':<34}{'mean':>7}{'median':>8}{'p95':>7}{'>20':>5}{'floor':>7}"
             "  verdict: mean diff vs default (the 2D row: vs floor off) [95 % CI], deg; interval coverage"]
    labels = ("default (floor fused)", "floor contacts off", "path from 2D keypoints")
    for title, recs in sets:
        rows = {label: ([], 0, []) for label in labels}
        for ev, J, J2d in recs:
            R, ok = shipped_rotations(ev)
            for label, joints in zip(labels, (J, None, J2d)):
                _, _, seq = up_model_sequence(R, ok, evidence_of(ev), ev["fps"], joints_cam=joints)
                pitch, roll = camera_pitch_roll(seq.up)
                up = np.where(ok[:, None], seq.up, np.nan)
                err, used, out = rows[label]
                err.append(clip_error(up, ev["true_up"]))
                out.append({"up": up, "interval": (np.degrees(pitch), np.degrees(roll), seq.camera_pitch_interval_deg,
                                                   seq.camera_roll_interval_deg)})
                rows[label] = (err, used + bool(seq.ground_plane.get("used")), out)
        rows = {label: (np.array(err), used, out) for label, (err, used, out) in rows.items()}
        base, off = rows[labels[0]][0], rows[labels[1]][0]
        for label, (err, used, out) in rows.items():
            kind, ref = {labels[0]: ("default", base), labels[1]: ("removal", base), labels[2]: ("removal", off)}[label]
            word = verdict(kind, (off - err) if label == labels[2] else (err - ref))
            cover = interval_coverage(out, [rec[0] for rec in recs]).split(": ", 1)[1]
            lines.append(f"{title:<28}{label:<34}{err.mean():>7.2f}{np.median(err):>8.2f}{np.percentile(err, 95):>7.2f}"
                         f"{int(np.sum(err > GROSS_DEG)):>5}{used:>7}  {word}; {cover}")
    return lines


def rolled_floor_table(rolled: list[dict], floor_sets: list[tuple[str, list]]) -> list[str]:
    """The footfalls switched off in the posture's posterior, on the held-out recordings with a
    pelvis path seen by a camera rolled :data:`QUARTER_DEG` (:func:`rolled_evidence`): per set
    and path, the sequence tilt error over clips and the clips read as lying, of the default
    chain and of the chain before decision 0048 (the footfalls only in an upright posture's fine
    fit: :func:`pcnet.stages.ground_plane.posture_and_floor_up` with ``footfalls=False``)."""
    lines = [f"## Camera rolled {QUARTER_DEG:g} deg over a pelvis path (the held-out mocap above, alternate clips "
             "clockwise and anticlockwise; the pelvis path measured, or recovered from 2D keypoints for the level "
             "camera, rolled with it): sequence tilt error (deg) over clips",
             f"{'set':<28}{'variant':<52}{'mean':>7}{'median':>8}{'p95':>7}{'>20':>5}{'lying':>7}"
             "  verdict: mean diff vs default [95 % CI], deg"]
    p = default_parameters()
    for s, (title, recs) in enumerate(floor_sets):
        by_index = {ev["index"]: ev for ev in rolled if ev["set"] == s}
        for path in ("measured path", "path from 2D keypoints"):
            errs = {True: [], False: []}
            lying = {True: 0, False: 0}
            for i, (_, J, J2d) in enumerate(recs):
                ev, Q = by_index[i], roll_matrix(i, QUARTER_DEG)
                joints = (J if path == "measured path" else J2d) @ Q.T
                R, ok = shipped_rotations(ev)
                evidence = evidence_of(ev)
                _, _, seq = up_model_sequence(R, ok, evidence, ev["fps"], joints_cam=joints)
                old = posture_and_floor_up(summarise_recording(evidence.frames(ok), ev["fps"], p), joints, ok, p,
                                           footfalls=False)
                before = (old.up, old.posterior.posture)
                for default, (up, posture) in ((True, (seq.up, seq.posture.most_probable)), (False, before)):
                    errs[default].append(clip_error(np.where(ok[:, None], up, np.nan), ev["true_up"]))
                    lying[default] += posture == "lying"
            base = np.array(errs[True])
            for default in (True, False):
                err = np.array(errs[default])
                label = f"{path}: " + ("default (footfalls in the posture)" if default else
                                       "footfalls only in the upright fit")
                word = "-" if default else verdict("removal", err - base)
                lines.append(f"{title:<28}{label:<52}{err.mean():>7.2f}{np.median(err):>8.2f}{np.percentile(err, 95):>7.2f}"
                             f"{int(np.sum(err > GROSS_DEG)):>5}{lying[default]:>7}  {word}")
    return lines


def reproduction_check(evs: list[dict], runs: dict) -> str:
    worst, mism = 0.0, 0
    for o, ev in zip(runs[AUTO], evs):
        both = np.isfinite(o["up"]).all(1) & np.isfinite(ev["real_up"]).all(1)
        mism += int(np.sum(np.isfinite(o["up"]).all(1) != ev["real_valid"]))
        if both.any():
            worst = max(worst, float(np.max(deg(o["up"][both], ev["real_up"][both]))))
    gp = sum(ev["ground_plane_used"] for ev in evs)
    return (f"reproduction check: the auto row rebuilt from the cache vs the real chain in auto mode (run at extraction; a difference "
            f"means the chain's code changed since): largest angle {worst:.2e} deg, "
            f"{mism} frames whose validity differs; ground plane used in {gp} of {len(evs)} recordings")


def evaluate(evs: list[dict]) -> dict:
    return {v.label: [run_variant(ev, v) for ev in evs] for v in VARIANTS}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--max-clips", type=int, default=200, help="clips per mocap set (seeded random subset)")
    ap.add_argument("--cache", type=Path, default=CACHE)
    ap.add_argument("--out", type=Path, default=RESULT)
    ap.add_argument("--skip", nargs="*", default=[], choices=("mocap", "floor", "real", "yoga", "equivariance"))
    ap.add_argument("--other-clips", action="store_true",
                    help="the mocap sets' clips outside their --max-clips subset (only the Bandai test has any), "
                         "no derived sets: a held-out set the default subsets leave untouched")
    ap.add_argument("--rows", nargs="*", default=None, metavar="LABEL",
                    help="only the default row and the rows whose label contains one of these (default: every row)")
    args = ap.parse_args(argv)
    global VARIANTS
    if args.rows is not None:
        VARIANTS = tuple(v for v in VARIANTS if v.kind == "default" or v.label == AUTO  # the reproduction check's
                         or any(r in v.label for r in args.rows))
    require_folder(args.data, "ablation")
    t0 = time.time()
    lines = [__doc__.splitlines()[0], "",
             f"    python -m benchmarks.ablation --data ../shared/data --max-clips {args.max_clips}"
             + (f" --skip {' '.join(args.skip)}" if args.skip else "")
             + (" --other-clips" if args.other_clips else "")
             + (" --rows " + " ".join(repr(r) for r in args.rows) if args.rows is not None else "")
             + (f" --out {args.out.resolve().relative_to(RESULT.parents[2])}" if args.out.resolve() != RESULT.resolve()
                and args.out.resolve().is_relative_to(RESULT.parents[2]) else ""), "",
             "Rows: the default chain of `pcnet run` (sequence mode, camera prior, lying posture), then one piece switched off "
             "(or an alternative) at a time; see the script's docstring for the protocol and every column.", ""]
    sections = []
    floor_sets = []
    if args.other_clips:
        args.skip = ["mocap", "floor", "real", "yoga", "equivariance"]
        for title, file, split in MOCAP_SETS:
            evs = mocap_set(args.data, args.cache, file, split, args.max_clips, rest=True)
            if evs:
                sections.append(("mocap", f"{title}, the clips outside the {args.max_clips}-clip subset", evs))
    if "mocap" not in args.skip or "floor" not in args.skip:
        static = []
        for title, file, split in MOCAP_SETS:
            evs = mocap_set(args.data, args.cache, file, split, args.max_clips)
            if "mocap" not in args.skip:
                sections.append(("mocap", title, evs))
            static.append(evs)
        if "floor" not in args.skip:
            floor_sets = floor_recordings(args.data, args.cache, args.max_clips, static)
    if "mocap" not in args.skip:
        moving = heldout_sweep(args.cache, static, args.max_clips)
        sections.append(("mocap", f"Moving camera (pitch sweeping {SWEEP_DEG:g} deg over each clip; Bandai test and "
                                  f"DeepMimic clips of >= {SWEEP_MIN_FRAMES} frames, at most {SWEEP_MAX_CLIPS} each)",
                         moving))
        sections.append(("rolled", "rolled", rolled_recordings(args.cache, static, args.max_clips)))
    if "real" not in args.skip:
        sections.append(("real", "real", real_recordings(args.data, args.cache)))
    if "yoga" not in args.skip:
        sections.append(("yoga", "yoga", cached(args.cache, f"yoga_stride{YOGA_STRIDE}", lambda: yoga_evidence(args.data))))
    if "equivariance" not in args.skip:
        sections.append(("equivariance", "equivariance",
                         cached(args.cache, "equivariance", lambda: equivariance_evidence(args.data))))
    static_runs = []  # the held-out mocap sections' (title, recordings, runs), for the rolled camera's extra
    for kind, title, evs in sections:
        t1 = time.time()
        runs = evaluate(evs)
        if kind == "mocap" and len(static_runs) < len(MOCAP_SETS):
            static_runs.append((title, evs, runs))
        table = {"mocap": lambda: mocap_table(title, evs, runs), "real": lambda: real_table(evs, runs),
                 "yoga": lambda: yoga_table(evs, runs), "equivariance": lambda: equivariance_table(evs, runs),
                 "rolled": lambda: rolled_table(evs, runs, static_runs)}[kind]()
        block = table + [reproduction_check(evs, runs) + f" ({time.time() - t1:.0f} s)", ""]
        print("\n".join(block), flush=True)
        lines += block
    if floor_sets:
        t1 = time.time()
        block = floor_table(floor_sets) + [f"({time.time() - t1:.0f} s)", ""]
        print("\n".join(block), flush=True)
        lines += block
        t1 = time.time()
        quarter = rolled_recordings(args.cache, static, args.max_clips, QUARTER_DEG)
        block = rolled_floor_table(quarter, floor_sets[:len(MOCAP_SETS)]) + [f"({time.time() - t1:.0f} s)", ""]
        print("\n".join(block), flush=True)
        lines += block
    lines.append(f"(wall time {time.time() - t0:.0f} s including cache reads; 2 shared CPU cores)")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(line.rstrip() for line in lines) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
