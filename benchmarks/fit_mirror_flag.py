"""The mirror test (stages/mirror.py) fitted on training mocap, and how it reads held-aside data.

    python -m benchmarks.fit_mirror_flag --data ../shared/data

Fit: the training mix's training split (benchmarks/mocap_sets.py: Bandai motion-style train,
CMU training subjects; never validation, test or DeepMimic), each clip seen by one static
"paper" camera with the lifter-noise model (models/lifter_noise.py defaults;
``make_pairs(camera="static", seed=0)``, as benchmarks/fit_speed_limits.py). Per clip, the
median (knee, elbow) bend sines ``m`` (stages/mirror.py ``recording_cues``); ``mu`` and ``S``
are their mean and covariance over clips (a mirror image's ``m`` is ``-m``, so the body's
distribution is the whole fit). Written to stages/data/mirror_flag.json with its provenance.

Read (not used for the fit), at the shipped odds (stages/mirror.py ``MIRROR_ODDS``): the share
of recordings called mirrored (false alarms) and of their mirror images (``z -> -z``) called
mirrored (detections) on
- the fit's own clips;
- the training mix's validation split, with the same noise and clean;
- every clip of the shared mocap files, clean, as ``pcnet evaluate`` reads them (its warning
  of a file whose clips are mirror images: left and right exchanged);
- every real lifter file of the shared data: 90 VideoPose3D yoga files (standing, seated,
  lying, prone) and the MotionBERT boxing and cycling files.
"""

from __future__ import annotations

import datetime
import glob
import json
import time
from pathlib import Path

import numpy as np

from benchmarks.fit_speed_limits import clip_series
from benchmarks.mocap_sets import TRAINING_MIX, training_mix_splits
from benchmarks.report import fit_arguments, print_and_save
from pcnet.models.datasets import load_mocap
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.mirror import CUES, MIRROR_ODDS, MIRROR_PATH, MirrorModel, recording_cues

RESULT = Path(__file__).resolve().parent / "results" / "fit_mirror_flag.txt"
COMMAND = "python -m benchmarks.fit_mirror_flag --data ../shared/data"
MIRROR_Z = np.array([1.0, 1.0, -1.0])


def cues_of(series) -> tuple[list[str], np.ndarray]:
    """Names and ``(N, 2)`` recording cues of the ``(name, poses)`` pairs with a finite ``m``."""
    names, rows = [], []
    for name, X in series:
        m, counted = recording_cues(X)
        if counted:
            names.append(name)
            rows.append(m)
    return names, np.array(rows).reshape(-1, 2)


#: Decision 0103's trial: the mirror hypothesis must also fit the recording's cues, their
#: Mahalanobis distance to ``-mu`` under ``S`` within the chi-square 95 % quantile of 2 degrees
#: of freedom, ``-2 ln 0.05`` (the level of MIRROR_ODDS): a knee read hyperextended with elbows
#: bent as a body's is neither a body nor its mirror image.
FIT_D2 = -2.0 * np.log(0.05)


def fires(model: MirrorModel, m: np.ndarray, fit_check: bool = False) -> bool:
    """The shipped test (odds of at least MIRROR_ODDS), and with ``fit_check`` decision
    0103's condition that the mirror hypothesis fits ``m`` (:data:`FIT_D2`)."""
    if model.log_odds(m) < np.log(MIRROR_ODDS):
        return False
    d = m + model.mean
    return not fit_check or float(d @ np.linalg.solve(model.cov, d)) <= FIT_D2


def reading(model: MirrorModel, series, label: str, fit_check: bool = False) -> list[str]:
    """One line: false alarms on ``series`` and detections of its mirror images, with the
    names of the false alarms (``fit_check``: decision 0103's test, :func:`fires`)."""
    names, m = cues_of(series)
    _, mirrored = cues_of((n, X * MIRROR_Z) for n, X in series)
    fa = [n for n, row in zip(names, m) if fires(model, row, fit_check)]
    hit = sum(fires(model, row, fit_check) for row in mirrored)
    line = (f"  {label:<44} false alarms {len(fa):>3} / {len(m):<5} ({100 * len(fa) / max(len(m), 1):4.1f} %)   "
            f"mirror images detected {hit:>4} / {len(mirrored):<5} ({100 * hit / max(len(mirrored), 1):5.1f} %)")
    return [line] + [f"      false alarm: {n}" for n in fa[:10]] + ([f"      ... {len(fa) - 10} more"] if len(fa) > 10 else [])


def noisy(clips) -> list[tuple[str, np.ndarray]]:
    return [(name, X) for name, _, X in clip_series(clips, LifterNoise())]


def main() -> None:
    args = fit_arguments(__doc__, "fit_mirror_flag", RESULT, MIRROR_PATH, option="--fit")
    t0 = time.perf_counter()
    train, val = training_mix_splits(args.data, "train", "val")
    train_series = noisy(train)
    _, m = cues_of(train_series)
    mean, cov = m.mean(axis=0), np.cov(m.T)
    provenance = {"command": COMMAND, "data": [f"mocap/{f}" for f in TRAINING_MIX],
                  "split": "motion-style train (models/datasets.py select_split)",
                  "camera": "one static 'paper' camera per clip, lifter-noise model defaults, make_pairs seed 0",
                  "recordings": int(len(m)), "date": datetime.date.today().isoformat()}
    fit = {"description": "A body's per-recording median knee and elbow bend sines (stages/mirror.py): mean and "
                          "covariance over the training recordings; a mirror image's are their negation.",
           "cues": list(CUES), "mean": [round(float(v), 6) for v in mean],
           "cov": [[round(float(v), 8) for v in row] for row in cov], "provenance": provenance}
    args.fit.write_text(json.dumps(fit, indent=1) + "\n", encoding="utf-8")
    model = MirrorModel(np.array(fit["mean"]), np.array(fit["cov"]), provenance)
    w = -2.0 * np.linalg.solve(model.cov, model.mean)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"Fit: {len(m)} training recordings (of {len(train)} clips). mu (knee, elbow) = "
             f"({mean[0]:+.3f}, {mean[1]:+.3f}); S = [[{cov[0, 0]:.4f}, {cov[0, 1]:.4f}], [{cov[1, 0]:.4f}, "
             f"{cov[1, 1]:.4f}]]; log odds of a mirror image = {w[0]:+.2f} m_knee {w[1]:+.2f} m_elbow; the flag "
             f"fires from odds {MIRROR_ODDS:g}:1 (log {np.log(MIRROR_ODDS):.2f}). Written to {args.fit.name}.", "",
             "Read at those odds (a recording, and its mirror image z -> -z):"]
    lines += reading(model, train_series, "training split, lifter noise (the fit's own)")
    lines += reading(model, noisy(val), "validation split, lifter noise")
    lines += reading(model, [(c.name, c.joints) for c in val], "validation split, clean")
    # every clip as pcnet evaluate reads it (its mirrored-clips warning): clean, the mocap's own frame
    for name in ("bandai_h36m17.npz", "cmu_train_h36m17.npz", "deepmimic_h36m17.npz"):
        lines += reading(model, [(c.name, c.joints) for c in load_mocap(args.data / "mocap" / name)],
                         f"{name}, every clip, clean (pcnet evaluate)")
    real = args.data / "real"
    for label, pattern in (("real VideoPose3D yoga files", "yoga_videopose3d/*.npy"),
                           ("real MotionBERT files (boxing, cycling)", "*motionbert/*.npy")):
        files = sorted(glob.glob(str(real / pattern)))
        if files:
            lines += reading(model, [(Path(f).name, np.load(f, allow_pickle=False)) for f in files],
                             f"{label} ({len(files)})")
    lines += ["", f"({time.perf_counter() - t0:.0f} s)"]
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
