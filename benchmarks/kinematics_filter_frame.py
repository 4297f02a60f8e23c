"""Joint angles filtered in the turning canonical frame or in the camera frame, against mocap truth (decision 0102).

    python -m benchmarks.kinematics_filter_frame --data ../shared/data --sets validation
    python -m benchmarks.kinematics_filter_frame --data ../shared/data --sets heldout

In frame and smooth modes (no world frame) ``pcnet run`` low-passed the poses turned into the
canonical frame of each frame, ``(X_t - pelvis_t) @ R_t``, so the filter smooths the
rotation's frame-to-frame noise into the body as well: the angles between two segments, which
no frame changes, then depend on the mode that chose ``R_t`` (a user trial: a cycling clip's
elbow 152.6 deg in one mode, 138.4 in another at a lifter jump). The candidate filters where
the input lives:

- ``turning`` (shipped before decision 0102): ``lowpass((X - pelvis) @ R)``;
- ``camera`` (shipped since decision 0102): ``(lowpass(X) - lowpass(X)_pelvis) @ lowpass(R)``,
  the camera-frame poses and the rotation (its nine entries, the same zero-phase Butterworth,
  then the nearest rotation by SVD) low-passed apart and then composed
  (``compute_kinematics(X, fps, rotation=R)``, stages/kinematics.py: ``lowpass_rotations``).
  For one rotation per recording (sequence mode, a world frame) both are the same; angles
  between segments no longer depend on the mode.

Both with ``pcnet run``'s default 6 Hz, 4th-order filter. Scored as benchmarks/kinematics_residual.py
scores: every angle of ``Kinematics.angles`` against the same angles of the truth (the clean
mocap in its true canonical frame), mean absolute difference (deg, wrapped modulo 360) over
the frames where the rotation is valid and the truth and both candidates are defined; one
clip's score is the mean of its angles'; ``camera - turning`` per clip gets the ablation's
paired verdict (benchmarks/ablation.py). Per angle group too, and the modes' disagreement:
the mean absolute difference between frame-mode and smooth-mode angles between segments
(ISB joint and unsigned angles).

Recordings: the ablation's protocol (``benchmarks.ablation.static_camera_clips``: at most
``--max-clips`` clips per set, one static "paper" camera each, seed 0) with lifter-like noise
(models/lifter_noise.py) and with frame-independent noise (``models.datasets.Noise``); each
also seen by a moving camera, its pitch sweeping linearly through ``SWEEP_DEG`` over the clip
(as the ablation's moving camera). ``--sets validation``: the training mix's motion-style
validation split (Bandai, CMU); ``--sets heldout``: the ablation's held-out mocap (Bandai
motion-style test, CMU test subjects, DeepMimic less the clips the shipped weights trained
on). Real rows (``--sets heldout``; no truth): the modes' disagreement on real lifter output
(the boxing and cycling MotionBERT clips; cycling at 30 fps assumed, the file carries none).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks.ablation import SWEEP_DEG, _Fixed, camera_view_joints, static_camera_clips, verdict
from benchmarks.kinematics_residual import GROUPS, NOISES, _score, group_of, sets_arguments
from benchmarks.report import print_and_save
from benchmarks.world_kinematics import wrapped_diff
from pcnet.pipeline.rectification import make_estimator, resolve_heading_source
from pcnet.stages.core.canonical import to_canonical
from pcnet.stages.core.rotations import axis_rotation
from pcnet.stages.kinematics import compute_kinematics
from pcnet.stages.rectify import HeadingStep, Rectification, SequenceEvidence

MODES = ("frame", "smooth")
CANDIDATES = ("turning", "camera")
CUTOFF_HZ = 6.0  # pcnet run's default (RunConfig.lowpass_hz)
CAMERAS = ("static camera", "moving camera")


def candidate_angles(X: np.ndarray, R: np.ndarray, fps: float) -> dict[str, dict[str, np.ndarray]]:
    """``{candidate: Kinematics.angles}`` of camera-frame poses ``X`` ``(T, 17, 3)`` placed by ``R``."""
    turning = compute_kinematics(to_canonical(X, R), fps, CUTOFF_HZ, check_up=False, units="normalised")
    camera = compute_kinematics(X, fps, CUTOFF_HZ, check_up=False, units="normalised", rotation=R)
    return {"turning": dict(turning.angles), "camera": dict(camera.angles)}


def modes_disagreement(X: np.ndarray, fps: float, estimate) -> dict[str, float]:
    """Per candidate: the mean over angles between segments of the mean absolute difference
    (deg) between frame-mode and smooth-mode angles, over the frames both modes place."""
    by_mode = {}
    for mode in MODES:
        rect = Rectification(_Fixed(estimate), SequenceEvidence(mode, n_bootstrap=0),
                             HeadingStep(resolve_heading_source("pcnet", None)))(X, fps)
        by_mode[mode] = (candidate_angles(X, rect.rotation, fps), rect.valid)
    (a, va), (b, vb) = by_mode["frame"], by_mode["smooth"]
    out = {}
    for c in CANDIDATES:
        d = [np.nanmean(np.abs(wrapped_diff(a[c][n], b[c][n]))[va & vb]) for n in a[c] if group_of(n) != "inclination"]
        out[c] = float(np.nanmean(d))
    return out


def clip_scores(X: np.ndarray, truth: np.ndarray, fps: float, estimator) -> dict:
    """One recording ``X`` ``(T, 17, 3)`` (camera frame) against its truth (canonical frame):
    ``{mode: {"all": {candidate: score}, "groups": {group: {candidate: score}}}, "modes": ...}``."""
    estimate = estimator(X, fps)
    true_angles = compute_kinematics(truth, fps).angles
    out = {}
    for mode in MODES:
        rect = Rectification(_Fixed(estimate), SequenceEvidence(mode, n_bootstrap=0),
                             HeadingStep(resolve_heading_source("pcnet", None)))(X, fps)
        angles = candidate_angles(X, rect.rotation, fps)
        errors, names = {c: [] for c in CANDIDATES}, []
        for name, t in true_angles.items():
            ok = rect.valid & np.isfinite(t)
            for c in CANDIDATES:
                ok &= np.isfinite(angles[c][name])
            if not ok.any():
                continue
            names.append(name)
            for c in CANDIDATES:
                errors[c].append(np.where(ok, np.abs(wrapped_diff(angles[c][name], t)), np.nan))
        E = {c: np.array(errors[c]) for c in CANDIDATES}
        out[mode] = {"all": {c: _score(E[c]) for c in CANDIDATES},
                     "groups": {g: {c: _score(E[c][[group_of(n) == g for n in names]]) for c in CANDIDATES}
                                for g in GROUPS}}
    out["modes"] = modes_disagreement(X, fps, estimate)
    return out


def sweep(X: np.ndarray) -> np.ndarray:
    """``X`` seen by a camera whose pitch sweeps linearly through :data:`SWEEP_DEG` over the
    clip (benchmarks.ablation.sweep_evidence): ``X'_t = X_t @ S_t^T``; the truth's canonical
    frame does not move."""
    S = np.stack([axis_rotation("x", a) for a in np.radians(np.linspace(-1, 1, len(X)) * SWEEP_DEG / 2)])
    return np.einsum("tij,tkj->tki", S, X)


def score_set(clips: list, max_clips: int, noise, estimator) -> dict[str, list[dict]]:
    out = {c: [] for c in CAMERAS}
    for clip, X, R, frames in static_camera_clips(clips, max_clips, noise=noise):
        if len(X) < 30:
            continue
        X = np.asarray(X, np.float64)
        truth = to_canonical(camera_view_joints(clip, frames, R), R)
        out["static camera"].append(clip_scores(X, truth, clip.fps, estimator))
        out["moving camera"].append(clip_scores(sweep(X), truth, clip.fps, estimator))
    return out


def set_lines(title: str, scored: list[dict]) -> list[str]:
    lines = []
    for mode in MODES:
        t = np.array([s[mode]["all"]["turning"] for s in scored])
        c = np.array([s[mode]["all"]["camera"] for s in scored])
        k = np.isfinite(t) & np.isfinite(c)
        groups = " | ".join(" / ".join(f"{np.nanmean([s[mode]['groups'][g][x] for s in scored]):.2f}"
                                       for x in CANDIDATES) for g in GROUPS)
        lines.append(f"| {title} | {mode} | {k.sum()} | {t[k].mean():.2f} | {c[k].mean():.2f} | "
                     f"{verdict('alternative', c[k] - t[k])} | {groups} |")
    return lines


def modes_line(title: str, scored: list[dict]) -> str:
    cells = " | ".join(f"{np.nanmean([s['modes'][c] for s in scored]):.3f}" for c in CANDIDATES)
    return f"| {title} | {len(scored)} | {cells} |"


def real_lines(data: Path, estimator) -> list[str]:
    from pcnet.adapters import load_motionbert

    files = [(data / "real" / "boxing_motionbert" / "X3D.npy", 30.0)]
    files += [(p, 30.0) for p in sorted((data / "real" / "cycling_motionbert").glob("*.npy"))]
    lines = ["| real clip (MotionBERT) | frames | turning | camera |", "|---|---:|---:|---:|"]
    for path, fps in files:
        X = np.asarray(load_motionbert(path).joints, np.float64)
        d = modes_disagreement(X, fps, estimator(X, fps))
        lines.append(f"| {path.parent.name}/{path.name} | {len(X)} | {d['turning']:.3f} | {d['camera']:.3f} |")
    return lines


def main(argv=None) -> None:
    args, out, sets = sets_arguments(argv, __doc__, "kinematics_filter_frame")
    t0 = time.perf_counter()
    estimator = make_estimator("pcnet")
    lines = [__doc__.splitlines()[0], "",
             f"    python -m benchmarks.kinematics_filter_frame --data {args.data} --sets {args.sets} "
             f"--max-clips {args.max_clips}", "",
             "Mean over clips of the clip's mean angle error (deg); verdict of camera - turning per clip (paired",
             "bootstrap over clips, 95 %); per angle group, turning / camera (mean over clips, deg).", "",
             "| set | mode | clips | turning | camera | camera - turning | ISB joint | unsigned | inclination |",
             "|---|---|---:|---:|---:|---|---|---|---|"]
    modes = ["", "Modes' disagreement: frame vs smooth mode, angles between segments, mean absolute difference (deg):",
             "", "| set | clips | turning | camera |", "|---|---:|---:|---:|"]
    for noise_name, noise in NOISES.items():
        for title, clips in sets:
            scored = score_set(clips, args.max_clips, noise(), estimator)
            for camera in CAMERAS:
                label = f"{title}, {noise_name}, {camera}"
                lines += set_lines(label, scored[camera])
                modes.append(modes_line(label, scored[camera]))
            print(f"  {title}, {noise_name}: {len(scored['static camera'])} clips ({time.perf_counter() - t0:.0f} s)",
                  flush=True)
    lines += modes
    if args.sets == "heldout":
        lines += ["", "Real lifter output (no truth): modes' disagreement, angles between segments (deg):", ""]
        lines += real_lines(args.data, estimator)
    lines += ["", f"run time {time.perf_counter() - t0:.0f} s"]
    print_and_save(lines, out)


if __name__ == "__main__":
    main()
