"""A standing trial's up for the other recordings of the same static camera (``--camera-up-from``, decision 0109).

    python -m benchmarks.standing_trial_up --data ../shared/data [--cameras 6]

A clinic films a patient's floor and seated exercises from one tripod. Alone, each recording's
up comes from its own poses, and where they cannot tell (a body lying across the image, a
seated or side-bent body the networks read as a tilted camera) from the camera prior. A
standing trial filmed first by the same unmoved camera reads the camera's up from a body the
networks know; ``pcnet run --camera-up-from TRIAL_OUT`` gives it to the other recordings
(only an up its poses read: ``stages/rectification_report.py: why_up_not_reusable``).

1. **Held-out mocap with the true up.** The CMU test subjects (10 and 14; never trained on)
   and DeepMimic (the walk as the standing trial; of its floor motions the shipped weights
   trained on three, so they are listed apart). Per subject, one static camera ("paper" views,
   ``--cameras`` seeds) films every clip; each clip gets its own lifter-like errors
   (``models/lifter_noise.py``). The standing trial: CMU 010_04 (a walk), 014_37 (drinking
   soda, standing; 127 frames), DeepMimic's walk. Each other clip is rectified in sequence mode
   alone and with the trial's up, against the camera's true up: the tilt error, mean over clips
   and cameras, and the paired difference with its 95 % bootstrap interval over the
   clip-camera pairs.
2. **Real VideoPose3D yoga files** (no truth): each person's Tadasana as the standing trial for
   their other asanas, assumed filmed by the same unmoved camera (the data do not say): the
   median trunk angle from vertical alone and with the trial's up, against the physics of each
   asana (Shavasana >= 80, Padmasana <= 15 deg; issue 49's targets).
"""

from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

import numpy as np

from benchmarks.report import BOOTSTRAP, SHARED_DATA, print_and_save, require_folder
from pcnet.models.datasets import load_mocap
from pcnet.models.lifter_noise import apply_lifter_errors, sample_lifter_errors
from pcnet.pipeline import rectify
from pcnet.stages.core.conventions import PELVIS, THORAX
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.rotations import angle_between, sample_camera_rotations
from pcnet.stages.rectification_report import why_up_not_reusable

RESULT = Path(__file__).resolve().parent / "results" / "standing_trial_up.txt"
#: (set, standing trial, the clips it serves: a name prefix or a list)
MOCAP_SETS = (("CMU test subject 10", "cmu_train_h36m17.npz", "010_04", "010_"),
              ("CMU test subject 14", "cmu_train_h36m17.npz", "014_37", "014_"),
              ("DeepMimic floor motions (3 of 4 trained on)", "deepmimic_h36m17.npz", "humanoid3d_walk.txt",
               ("humanoid3d_crawl.txt", "humanoid3d_getup_facedown.txt", "humanoid3d_getup_faceup.txt",
                "humanoid3d_roll.txt")))
ASANAS = ("Shavasana", "Bhujangasana", "Padmasana", "Vrikshasana", "Trikonasana")


def filmed(world: np.ndarray, R: np.ndarray, fps: float, rng: np.random.Generator) -> np.ndarray:
    """``(T, 17, 3)`` world-frame mocap (+Y up) seen root-relative by a static camera whose
    canonical->camera rotation is ``R``, with one clip's lifter-like errors."""
    cam = (world - world[:, PELVIS:PELVIS + 1]) @ R.T
    return apply_lifter_errors(cam, sample_lifter_errors(len(cam), fps, rng))


def tilt_error(up: np.ndarray, R: np.ndarray) -> float:
    return float(np.degrees(angle_between(np.asarray(up, np.float64), R[:, 1])))


def paired(alone: np.ndarray, given: np.ndarray, rng: np.random.Generator) -> str:
    d = given - alone
    boot = np.array([d[rng.integers(0, len(d), len(d))].mean() for _ in range(BOOTSTRAP)])
    return f"{d.mean():+.2f} [{np.percentile(boot, 2.5):+.2f}, {np.percentile(boot, 97.5):+.2f}]"


def mocap_rows(data: Path, cameras: int) -> list[str]:
    lines = ["## 1. Held-out mocap: sequence tilt error (deg) alone and with the standing trial's up", "",
             f"{cameras} static 'paper' cameras per subject, each clip with its own lifter-like errors.", "",
             "| set | clips x cameras | trials refused | alone: mean / median | with the trial's up: mean / median | "
             "difference [95 %] | read lying alone |", "|---|---|---|---|---|---|---|"]
    rng = np.random.default_rng(0)
    for label, file, trial_name, served in MOCAP_SETS:
        clips = {c.name: c for c in load_mocap(data / "mocap" / file)}
        names = [n for n in clips if (n.startswith(served) if isinstance(served, str) else n in served) and n != trial_name]
        alone, given, lying, refused = [], [], 0, 0
        for seed in range(cameras):
            R = sample_camera_rotations(1, "paper", np.random.default_rng(1000 + seed))[0]
            trial = clips[trial_name]
            res = rectify(filmed(trial.joints.astype(np.float64), R, trial.fps, rng), mode="sequence", fps=trial.fps)
            if why_up_not_reusable(res.report.as_record()) is not None:
                refused += 1
                continue
            up = res.report.sequence.up
            for n in names:
                c = clips[n]
                X = filmed(c.joints.astype(np.float64), R, c.fps, rng)
                try:
                    own = rectify(X, mode="sequence", fps=c.fps).report
                except InputError:
                    continue
                alone.append(tilt_error(own.sequence.up, R))
                lying += own.lying
                given.append(tilt_error(up, R))
        a, g = np.array(alone), np.array(given)
        lines.append(f"| {label} | {len(names)} x {cameras} | {refused} of {cameras} | {a.mean():.2f} / "
                     f"{np.median(a):.2f} | {g.mean():.2f} / {np.median(g):.2f} | {paired(a, g, rng)} | {lying} |")
        print(lines[-1], flush=True)
    return lines + [""]


def trunk_from_vertical(res) -> float:
    """Median angle (deg) of the canonical pelvis->thorax line from +Y over the valid frames."""
    trunk = res.canonical[:, THORAX] - res.canonical[:, PELVIS]
    ok = res.valid & np.isfinite(trunk).all(1)
    return float(np.degrees(np.median(angle_between(trunk[ok], np.array([0.0, 1.0, 0.0])[None]))))


def yoga_rows(data: Path) -> list[str]:
    folder = data / "real" / "yoga_videopose3d"
    files: dict[str, dict[str, Path]] = {}
    for f in sorted(folder.glob("export_*_*.npy")):
        m = re.fullmatch(r"export_(.+)_([A-Za-z]+)\.npy", f.name)
        if m:
            files.setdefault(m.group(1), {})[m.group(2)] = f
    lines = ["## 2. Real VideoPose3D yoga files: median trunk angle from vertical (deg), alone / with the person's "
             "Tadasana up", "", "Same unmoved camera per person assumed (not known). `-`: no such file; `refused`: "
             "the Tadasana run's up is not one to reuse.", "",
             "| person | Tadasana (trial) | " + " | ".join(ASANAS) + " |", "|---|---|" + "---|" * len(ASANAS)]
    counts = {a: [0, 0, 0] for a in ASANAS}  # files, meeting the target alone, with the trial's up
    target = {"Shavasana": lambda t: t >= 80, "Padmasana": lambda t: t <= 15}
    for person, asanas in files.items():
        if "Tadasana" not in asanas:
            continue
        trial = rectify(np.load(asanas["Tadasana"], allow_pickle=False), mode="sequence", fps=30.0)
        why = why_up_not_reusable(trial.report.as_record())
        cells = [f"{trunk_from_vertical(trial):.1f}" + ("" if why is None else " (refused)")]
        for asana in ASANAS:
            if asana not in asanas:
                cells.append("-")
                continue
            X = np.load(asanas[asana], allow_pickle=False)
            own = trunk_from_vertical(rectify(X, mode="sequence", fps=30.0))
            if why is None:
                up = tuple(trial.report.sequence.up)
                with_trial = trunk_from_vertical(rectify(X, mode="sequence", fps=30.0, camera_up=up))
                cells.append(f"{own:.1f} / {with_trial:.1f}")
                if asana in target:
                    counts[asana][0] += 1
                    counts[asana][1] += target[asana](own)
                    counts[asana][2] += target[asana](with_trial)
            else:
                cells.append(f"{own:.1f} / -")
        lines.append(f"| {person} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    lines += ["", "Files meeting issue 49's physics target (the persons with a reusable Tadasana up): "
              + "; ".join(f"{a} {counts[a][1]} of {counts[a][0]} alone, {counts[a][2]} with the trial's up"
                          for a in target), ""]
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--cameras", type=int, default=6)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args()
    require_folder(args.data, "benchmarks.standing_trial_up")
    t0 = time.perf_counter()
    lines = ["# A standing trial's up for the other recordings of one static camera (decision 0109)", "",
             f"command: `python -m benchmarks.standing_trial_up --data ../shared/data --cameras {args.cameras}`", ""]
    lines += mocap_rows(args.data, args.cameras)
    lines += yoga_rows(args.data)
    print_and_save(lines + [f"({time.perf_counter() - t0:.0f} s)"], args.out)


if __name__ == "__main__":
    main()
