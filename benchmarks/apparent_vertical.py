"""How much of the shipped pair's per-frame error on held-out mocap follows the body's acceleration (the apparent vertical)?

    python -m benchmarks.apparent_vertical --data ../shared/data [--stride 1]

A body that accelerates leans into the acceleration: the ground's reaction that carries it
points along the specific force ``f = a - g`` of its centre of mass (Newton's second law,
``m a = F_ground + m g``), so a runner on a curve leans towards the curve's centre by about
``atan(|a_lateral| / |g|)`` and one speeding up leans forward. A single pose shows that lean
and not what causes it, so an up read from one pose can follow the apparent vertical
``f / |f|`` instead of gravity. This measures how much of the shipped pair's per-frame error
does.

Frames: every ``--stride``-th frame of each clip seen by a new "paper" camera, clean (the
DeepMimic target's protocol: ``make_pairs(clips, views="paper", camera="per-frame", seed=0)``);
the shipped pair per frame (``make_estimator("pcnet")``, frame mode). Per frame, in the true
canonical frame, the signed pitch and roll of the predicted up (+ = anterior of, to the
subject's right of the true up) and of the apparent vertical ``normalize(a + 9.81 y)``, ``a``
the centre of mass's acceleration in m/s^2 (segment masses of de Leva 1996,
``balance_evidence.SEGMENTS``; second derivative of a quadratic Savitzky-Golay fit over a
window of ``W`` seconds, scipy.signal.savgol_filter, on the world-frame mocap before any
camera or stride: its metres and frame rate). A posture follows the force over a stride, not
its peaks within one (in flight the force is zero), so ``W`` is 0.5-2 s.

Per window ``W`` and set: the least-squares slope ``beta`` of the error's pitch (roll) on the
apparent vertical's (through the origin), the share of the error's variance it explains
(``R^2``), and the mean tilt error before and after removing ``beta`` times the lean. ``beta``
is fitted once on the motion-style *validation* split (never trained on; what a correction
learnt from training-like motion would remove) and once within each row (how much of that
row's error follows the lean: a description, not a method, since no lifter's root-relative
output gives the centre of mass's path). Rows: the validation split, the motion-style test
split, DeepMimic (another dataset; the camera-frame network trained on three of its floor
clips) by motion group. Then, for a static camera, DeepMimic's
groups in sequence mode (one "paper" camera fixed in the world per clip, ``make_pairs(...,
camera="static")``, ``rectify(joints, "pcnet", mode="sequence")`` as ``pcnet run`` does with a
static camera): the mean over clips of the sequence up's tilt error, where the lean averages
over the recording (the mean acceleration is the change of velocity over the duration). Writes
benchmarks/results/apparent_vertical.txt.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.signal import savgol_filter

from benchmarks.balance_evidence import centre_of_mass
from benchmarks.calibrate_frame_bound import DEEPMIMIC_GROUPS, canonical_pitch_roll, deepmimic_group
from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import SHARED_DATA, data_arguments, print_and_save, require_folder

from pcnet.models.datasets import load_mocap, make_pairs
from pcnet.pipeline.rectification import make_estimator, rectify
from pcnet.stages.core.canonical import canonical_rotation
from pcnet.stages.core.rotations import angle_between

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "apparent_vertical.txt"
COMMAND = "python -m benchmarks.apparent_vertical --data ../shared/data"
G = 9.81
UP = np.array([0.0, 1.0, 0.0])
#: Savitzky-Golay windows (s) for the centre of mass's acceleration.
WINDOWS_S = (0.5, 1.0, 2.0)

#: DeepMimic groups of this table: the running captures split by path, then those of
#: calibrate_frame_bound.py; the rest "other".
GROUPS = (("running straight (SIE)", "sie_humanoid3d_run_forward"),
          ("running on curves (SIE)", ("sie_humanoid3d_run_left", "sie_humanoid3d_run_right")),
          *DEEPMIMIC_GROUPS[1:])
GROUP_NAMES = (*(g for g, _ in GROUPS), "other")


def com_acceleration(com: np.ndarray, fps: float, window_s: float) -> np.ndarray:
    """``(T, 3)`` acceleration (m/s^2) of a centre-of-mass path ``(T, 3)`` in metres (the
    mocap's world frame; ``balance_evidence.centre_of_mass``); the window is shortened to the
    clip where it is longer, zeros for a clip under 5 frames."""
    T = len(com)
    n = min(int(round(window_s * fps)) | 1, T if T % 2 else T - 1)
    if n < 5:
        return np.zeros((T, 3))
    return savgol_filter(com, n, 2, deriv=2, axis=0) * fps ** 2


def clip_frames(estimator, clips, stride: int) -> list[dict]:
    """Per clip: the predicted up in the true canonical frame ``u`` (N, 3), and per window the
    apparent vertical there ``app[W]`` (N, 3), over the valid frames; with the clip's ``group``."""
    pairs = make_pairs(clips, views="paper", seed=0, camera="per-frame", frame_stride=stride)
    out = []
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)
        if not len(sel):
            continue
        est = estimator(pairs.inputs[sel], clip.fps / stride)
        ok = est.valid
        frames = pairs.frame[sel][ok]
        u = np.einsum("tji,tj->ti", pairs.R[sel][ok], est.rotation[ok][:, :, 1])
        world = np.asarray(clip.joints, np.float64)
        R_world, _ = canonical_rotation(world[frames], UP)  # canonical -> world
        com = centre_of_mass(world)
        app = {}
        for w in WINDOWS_S:
            f = com_acceleration(com, clip.fps, w)[frames] + G * UP
            app[w] = np.einsum("tji,tj->ti", R_world, f)
        out.append({"u": u, "app": app, "group": deepmimic_group(clip.name, GROUPS)})
    return out


def sequence_tilts(clips) -> dict[str, list[float]]:
    """Per DeepMimic group, each clip's mean tilt error (deg) of sequence mode's up, clean, with
    one static camera per clip."""
    pairs = make_pairs(clips, views="paper", seed=0, camera="static")
    out: dict[str, list[float]] = {}
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)
        if not len(sel):
            continue
        rect = rectify(pairs.inputs[sel], "pcnet", mode="sequence", fps=clip.fps)
        ok = rect.valid
        tilt = np.degrees(angle_between(rect.up[ok], pairs.R[sel][ok][:, :, 1]))
        out.setdefault(deepmimic_group(clip.name, GROUPS), []).append(float(tilt.mean()))
    return out


def signed(rows: list[dict], window: float) -> tuple[np.ndarray, np.ndarray]:
    """``(N, 2)`` signed pitch and roll (deg) of the error and of the apparent vertical."""
    e = np.concatenate([np.stack(canonical_pitch_roll(r["u"]), 1) for r in rows])
    a = np.concatenate([np.stack(canonical_pitch_roll(r["app"][window]), 1) for r in rows])
    return e, a


def slope(e: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Per axis, the least-squares ``beta`` of ``e ~ beta a`` through the origin."""
    return np.sum(e * a, 0) / np.sum(a * a, 0)


def explained(e: np.ndarray, a: np.ndarray, beta: np.ndarray) -> tuple[np.ndarray, float, float]:
    """(``R^2`` per axis, mean tilt before, after removing ``beta a``); tilt = the pitch and
    roll's root sum of squares (deg)."""
    r = e - beta * a
    return 1.0 - np.sum(r ** 2, 0) / np.sum(e ** 2, 0), float(np.hypot(*e.T).mean()), float(np.hypot(*r.T).mean())


def main() -> int:
    args = data_arguments(__doc__, DEFAULT, RESULT, stride=1)
    require_folder(args.data, "apparent_vertical")
    estimator = make_estimator("pcnet")
    val, test = training_mix_splits(args.data, "val", "test")
    deepmimic_clips = load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz")
    deepmimic = clip_frames(estimator, deepmimic_clips, args.stride)
    table = {"motion-style val (where beta is fitted)": clip_frames(estimator, val, args.stride),
             "motion-style test (Bandai, CMU 10, 14)": clip_frames(estimator, test, args.stride),
             "DeepMimic all (another dataset)": deepmimic}
    for g in GROUP_NAMES:
        table[f"  DeepMimic {g}"] = [r for r in deepmimic if r["group"] == g]
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}" + (f" --stride {args.stride}" if args.stride > 1 else ""), "",
             "Per-frame tilt, clean, deg (mean over frames; tilt here = sqrt(pitch^2 + roll^2) of the error in the true "
             "canonical frame); apparent = the apparent vertical's mean angle to gravity; R^2 pitch / roll; tilt after "
             "removing beta times the apparent vertical's lean, beta fitted on the validation split and within the row:"]
    for window in WINDOWS_S:
        beta_val = slope(*signed(table["motion-style val (where beta is fitted)"], window))
        lines += ["", f"Window {window:.1f} s; beta on the validation split: pitch {beta_val[0]:.2f}, roll {beta_val[1]:.2f}",
                  f"  {'data':<46}{'frames':>7}{'apparent':>9}{'tilt':>7}{'R^2 (val beta)':>16}{'after':>7}"
                  f"{'own beta':>16}{'R^2 (own)':>16}{'after':>7}"]
        for name, rows in table.items():
            if not rows:
                continue
            e, a = signed(rows, window)
            app = float(np.degrees(angle_between(np.concatenate([r["app"][window] for r in rows]), UP)).mean())
            r2_val, tilt, after_val = explained(e, a, beta_val)
            own = slope(e, a)
            r2_own, _, after_own = explained(e, a, own)
            lines.append(f"  {name:<46}{len(e):>7}{app:>9.2f}{tilt:>7.2f}{r2_val[0]:>8.2f}{r2_val[1]:>8.2f}{after_val:>7.2f}"
                         f"{own[0]:>8.2f}{own[1]:>8.2f}{r2_own[0]:>8.2f}{r2_own[1]:>8.2f}{after_own:>7.2f}")
    lines += ["", "Sequence mode, DeepMimic, one static camera per clip, clean: mean over clips of the sequence up's tilt "
              "error (deg)", f"  {'group':<44}{'clips':>6}{'tilt':>7}"]
    tilts = sequence_tilts(deepmimic_clips)
    for g in GROUP_NAMES:
        if g in tilts:
            lines.append(f"  {g:<44}{len(tilts[g]):>6}{np.mean(tilts[g]):>7.2f}")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
