"""Can a gait recording tell a wrong frame rate? Dynamic similarity, fitted on training mocap (decision 0108).

    python -m benchmarks.frame_rate_check --data ../shared/data

Two trials gave ``pcnet gait`` a walk at the wrong ``--fps`` (x2: 196 steps/min with 0.78 m
steps; x0.5: 49 steps/min) and read it without comment. A slow-motion phone video (filmed at
120 or 240 fps, stored at 30) is the same error, x1/4 or x1/8.

Model (Alexander 1976, "Estimates of speeds of dinosaurs", Nature 261:129-130; Alexander &
Jayes 1983, J. Zool. 201:135-152: animals of any size move alike at equal Froude numbers): a
gait's cadence made dimensionless by its leg length ``L``, ``c* = c sqrt(L / g)`` (``c`` steps
per second), follows its dimensionless stride, here the stance foot's sweep relative to the
pelvis over ``L`` (``d* = (s(strike) - s(off)) / L``, Zeni's signal of ``stages/gait.py``:
a length, so a wrong frame rate leaves it alone, and one a treadmill walk has too)::

    log c* = a + b log d* + e,   e ~ N(0, s^2)

A frame rate ``k`` times the true one reads ``c`` as ``k c``: ``log k_hat = log c* - a - b log d*``
with the 95 % interval ``+-1.96 s``.

Fitted (least squares) on the clean true joints of the training mocap's walks and runs (Bandai
motion-style train: walk, walk-turn-*, run, dash; the CMU training subjects' clips described as
walks or runs), low-passed at 6 Hz as ``pcnet run``'s default, through ``pcnet gait``'s events.
Scored, clean, on the validation and test splits and on DeepMimic's walks and runs (another data
set): the residual's mean and spread, the share of clips whose 95 % interval holds ``k = 1``, and
of those read at a wrong rate (``k`` = 2, 1/2, 1/4: the same joints at ``fps * k``; 1/4 a
slow-motion video) whose interval excludes 1. Nothing here is shipped; the record is decision 0108.

Also measured: whether a walk and a run can be told apart without the frame rate, by the phase
of the pelvis's height above the lower ankle against the feet's separation (an inverted
pendulum is highest at mid-stance, a spring lowest: Cavagna, Heglund & Taylor 1977): the sign
of their correlation per clip.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from benchmarks.gait_validation import BANDAI_GAIT, bandai_kind, screen_group
from benchmarks.report import print_and_save, trial_arguments
from pcnet.models.datasets import load_mocap, select_split
from pcnet.stages.core.conventions import L_ANKLE, PELVIS, R_ANKLE
from pcnet.stages.gait import GaitError, SIDES, anterior_ankle_signals, check_forward, gait_events, steps, summarise
from pcnet.stages.kinematics import butterworth_lowpass
from pcnet.stages.scale import leg_lengths

RESULT = Path(__file__).resolve().parent / "results" / "frame_rate_check.txt"
G = 9.80665
CUTOFF_HZ = 6.0
MIN_SECONDS = 3.0
WRONG_RATES = (2.0, 0.5, 0.25)
Z95 = 1.959964


def clip_features(joints: np.ndarray, fps: float) -> dict | None:
    """``{"cadence", "leg", "sweep", "pendulum"}`` of one clip (cadence in steps/s at ``fps``;
    leg and sweep in the joints' unit; pendulum the correlation above), or ``None`` where
    ``pcnet gait`` refuses it."""
    joints = butterworth_lowpass(joints, fps, CUTOFF_HZ)
    try:
        events = gait_events(joints, fps)
        step_list = steps(events, joints, np.ones(len(joints), bool))
        check_forward(step_list)
    except GaitError:
        return None
    signal = anterior_ankle_signals(joints)
    frames = np.arange(len(joints))
    sweeps = []
    for side in SIDES:
        foot = events.foot(side)
        for t in foot.strikes_s:
            offs = foot.offs_s[foot.offs_s > t]
            if offs.size and offs[0] - t < events.stride_period_s:
                sweeps.append(np.interp(t * fps, frames, signal[side]) - np.interp(offs[0] * fps, frames, signal[side]))
    height = joints[:, PELVIS, 1] - np.minimum(joints[:, L_ANKLE, 1], joints[:, R_ANKLE, 1])
    apart = np.abs(signal["left"] - signal["right"])
    ok = np.isfinite(height) & np.isfinite(apart)
    cadence = summarise(events, step_list).cadence_steps_per_min / 60.0
    if not sweeps or not np.isfinite(cadence):
        return None
    return {"cadence": float(cadence), "leg": float(np.nanmedian(leg_lengths(joints))),
            "sweep": float(np.median(sweeps)), "pendulum": float(np.corrcoef(height[ok], apart[ok])[0, 1])}


def gait_clips(data: Path):
    """``(set label, split, kind, clip)`` of every walk and run of at least :data:`MIN_SECONDS`."""
    bandai = load_mocap(data / "mocap" / "bandai_h36m17.npz")
    cmu = load_mocap(data / "mocap" / "cmu_train_h36m17.npz")
    described = json.loads((data / "mocap" / "cmu_train_h36m17.json").read_text())
    for split in ("train", "val", "test"):
        for c in select_split(bandai, split, "motion-style"):
            kind = bandai_kind(c.name)
            if kind in BANDAI_GAIT:
                yield "Bandai", split, "run" if kind in ("run", "dash") else "walk", c
        for c in select_split(cmu, split, "motion-style"):
            text = str(described[c.name].get("description", "")).lower()
            if "walk" in text or "run" in text or "jog" in text:
                yield "CMU", split, "run" if ("run" in text or "jog" in text) else "walk", c
    for c in load_mocap(data / "mocap" / "deepmimic_h36m17.npz"):
        if screen_group("deepmimic", c.name) == "gait":
            yield "DeepMimic", "all", "walk" if "walk" in c.name.lower() else "run", c


def dimensionless(f: dict, rate: float = 1.0) -> tuple[float, float]:
    """``(log d*, log c*)`` of :func:`clip_features`'s ``f`` read at ``rate`` times the true frame rate."""
    return float(np.log(f["sweep"] / f["leg"])), float(np.log(f["cadence"] * rate * np.sqrt(f["leg"] / G)))


def main(argv=None) -> None:
    args = trial_arguments(__doc__, RESULT, argv, "benchmarks.frame_rate_check")
    t0 = time.perf_counter()
    rows = []
    for label, split, kind, clip in gait_clips(args.data):
        if len(clip.joints) / clip.fps < MIN_SECONDS:
            continue
        f = clip_features(np.asarray(clip.joints, np.float64), float(clip.fps))
        if f is not None and f["sweep"] > 0:
            rows.append((label, split, kind, f))
    train = np.array([dimensionless(f) for label, split, _, f in rows if split == "train"])
    A = np.c_[np.ones(len(train)), train[:, 0]]
    (a, b), *_ = np.linalg.lstsq(A, train[:, 1], rcond=None)
    s = float(np.std(train[:, 1] - A @ (a, b), ddof=2))
    lines = ["# A wrong frame rate from a gait's dynamic similarity (decision 0108)", "",
             "command: `python -m benchmarks.frame_rate_check --data ../shared/data`", "",
             f"Fit on the training split's {len(train)} walks and runs (clean, {CUTOFF_HZ:g} Hz low-pass): "
             f"log c* = {a:+.3f} {b:+.3f} log d*, residual sd s = {s:.3f} (95 %: the rate within x{np.exp(-Z95 * s):.2f}"
             f"-x{np.exp(Z95 * s):.2f} of the stated)", "",
             "| set | split | gait | clips | residual mean | residual sd | interval holds k = 1 | "
             + " | ".join(f"k = {k:g} caught" for k in WRONG_RATES) + " | pendulum sign right |",
             "|---|---|---|---|---|---|---|" + "---|" * len(WRONG_RATES) + "---|"]
    groups = sorted({(label, split, kind) for label, split, kind, _ in rows},
                    key=lambda g: (["Bandai", "CMU", "DeepMimic"].index(g[0]), ["train", "val", "test", "all"].index(g[1]), g[2]))
    for group in groups:
        fs = [f for label, split, kind, f in rows if (label, split, kind) == group]

        def residual(rate: float) -> np.ndarray:
            x = np.array([dimensionless(f, rate) for f in fs])
            return x[:, 1] - a - b * x[:, 0]  # log k_hat

        e = residual(1.0)
        caught = [f"{np.mean(np.abs(residual(k)) > Z95 * s) * 100:.0f} %" for k in WRONG_RATES]
        pendulum = np.array([f["pendulum"] for f in fs])
        right = np.mean(pendulum < 0) if group[2] == "walk" else np.mean(pendulum > 0)
        lines.append(f"| {group[0]} | {group[1]} | {group[2]} | {len(fs)} | {e.mean():+.3f} | {e.std():.3f} | "
                     f"{np.mean(np.abs(e) <= Z95 * s) * 100:.0f} % | " + " | ".join(caught) + f" | {right * 100:.0f} % |")
    deep = [f for label, _, kind, f in rows if label == "DeepMimic" and kind == "run"]
    lines += ["", "k_hat: the frame rate the fit implies over the stated (the truth is 1); 'caught': the clip read "
              "at k times its frame rate has an interval that excludes 1. 'pendulum sign right': walks with a "
              "negative, runs with a positive correlation of the pelvis's height over the lower ankle with the "
              "feet's separation.",
              f"DeepMimic's runs: cadence {min(f['cadence'] for f in deep) * 60:.0f}-"
              f"{max(f['cadence'] for f in deep) * 60:.0f} steps/min, sweep over leg "
              f"{min(f['sweep'] / f['leg'] for f in deep):.2f}-{max(f['sweep'] / f['leg'] for f in deep):.2f}.",
              f"({time.perf_counter() - t0:.0f} s)"]
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
