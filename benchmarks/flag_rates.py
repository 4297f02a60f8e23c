"""How often each flag fires on upright recordings of new subjects filmed by a static camera.

    python -m benchmarks.flag_rates --data ../shared/data [--max-clips 60] [--no-swaps] [--out FILE]
    python -m benchmarks.flag_rates --data ../shared/data --real-only

The issue "Flags that carry information": a flag fires where its reading changes what the user
should do; on upright recordings from a level camera of new subjects, at most 1 recording in 20
should carry a warning. This script counts, per flag kind, how many such recordings carry one.

Data, held out from the shipped weights (their training mix is the Bandai + CMU motion-style
train split; models/MODEL_CARD.md), as benchmarks/ablation.py reads it: the CMU test subjects
(motion-style test split of cmu_train_h36m17.npz), the Bandai motion-style test split and
DeepMimic (all clips). Clips whose body is lying (median angle of the clean trunk, pelvis ->
thorax, from the world's up > 60 deg, ablation.py's ``LYING_TRUNK_DEG``) are skipped; of the
rest a seeded random subset (``numpy`` seed 0, sorted) of at most ``--max-clips`` per set.

Camera: one static camera per clip from the "paper" distribution (docs/CONVENTIONS.md; pcnet
has no level-only view distribution), ``make_pairs(..., views="paper", seed=0,
camera="static", noise=LifterNoise())``: the protocol of benchmarks/ablation.py. Each clip's
true camera pitch and roll are printed, and every table is given twice: over all clips and
over the "level" clips only (|pitch| <= 10 and |roll| <= 10 deg; the camera's yaw, i.e. the
subject's heading relative to it, is free: front, side and back views).

Protocol: each clip goes through what a user runs. Its camera-frame joints ``(T, 17, 3)``
(metres; frames whose heading is undefined are dropped by make_pairs) are saved as a
VideoPose3D-style .npy in a temporary folder and run through
``run_pipeline(RunConfig(lifter="videopose3d", lifter_output=..., fps=clip.fps, height=H,
recording=False, out=...).validate(), progress=False)`` with every other option at the
defaults of ``pcnet run`` (mode sequence since decision 0041; auto before it). ``H`` is the
subject's height as a user would give it: the median head-to-ankle chain of the clean mocap skeleton
(:func:`pcnet.stages.scale.height_chain_length`) over ``CHAIN_TO_STATURE``.

``--no-swaps`` switches off the lifter-noise model's left/right swaps
(``LifterNoise(swap_rate_hz=0)``; results in ``flag_rates_no_swaps.txt``): a swap moves the
wrists or ankles across the body for a few frames, a lifter error the implausible-motion flag
is for (decision 0034), so the difference between the two runs is how many of its findings
point at an injected error rather than at nothing.

Real lifter output (``--real-only``, ``flag_rates_real.txt``): every real 3D lifter file of the
shared data, each run as ``pcnet run`` reads it with its defaults: the 90 VideoPose3D yoga
exports (repeats named ``*.mp4.npy`` skipped, as benchmarks/yoga_physics.py; 30 fps), the
boxing demo (MotionBERT with AlphaPose 2D and the video) and the Sports2D demo (MediaPipe), as
benchmarks/vanishing_gravity.py runs them, Pose2Sim's four calibrated cameras (MediaPipe, 2D and
3D from one file) and the two MotionBERT cycling clips (30 fps assumed; no video). These are not
all upright (the yoga's lying and prone asanas), so the section lists each file's findings, and
counts per kind, rather than judging a rate: what a user of real lifters would be told.

Counted per data set: the recordings carrying at least one finding of each
:class:`pcnet.stages.flags.Kind` at severity CHECK or PROBLEM (``RunResult.ranked_findings``),
those carrying any CHECK/PROBLEM finding, flags of severity INFO, and notes
(``RunResult.note_findings``; their headlines grouped with digits replaced by ``#``). Cells
are "n/N (pct)". One example headline per kind follows the tables.
"""

from __future__ import annotations

import argparse
import re
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

from benchmarks.ablation import LYING_TRUNK_DEG, static_camera_clips
from benchmarks.report import SHARED_DATA, print_and_save, require_folder
from benchmarks.vanishing_gravity import RECORDINGS
from benchmarks.yoga_physics import FOLDER as YOGA_FOLDER
from benchmarks.yoga_physics import FPS as YOGA_FPS
from benchmarks.yoga_physics import plain_export
from pcnet.models.datasets import load_mocap, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.pipeline import RunConfig, run_pipeline
from pcnet.stages.core.conventions import PELVIS, THORAX
from pcnet.stages.core.rotations import camera_pitch_roll
from pcnet.stages.flags import Kind, Severity
from pcnet.stages.scale import CHAIN_TO_STATURE, height_chain_length

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "flag_rates.txt"
RESULT_NO_SWAPS = RESULT.with_name("flag_rates_no_swaps.txt")
RESULT_REAL = RESULT.with_name("flag_rates_real.txt")
COMMAND = "python -m benchmarks.flag_rates --data ../shared/data"
SETS = (("CMU test", "cmu_train_h36m17.npz", "test"),
        ("Bandai test", "bandai_h36m17.npz", "test"),
        ("DeepMimic", "deepmimic_h36m17.npz", "all"))
LEVEL_DEG = 10.0
WORLD_UP = np.array([0.0, 1.0, 0.0])


def trunk_angle_deg(joints: np.ndarray) -> float:
    """Median angle (deg) of the trunk (pelvis -> thorax) from the world's up, world frame."""
    t = joints[:, THORAX].astype(np.float64) - joints[:, PELVIS]
    c = t @ WORLD_UP / np.linalg.norm(t, axis=-1)
    return float(np.nanmedian(np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))))


def stature_m(joints: np.ndarray) -> float:
    """The subject's height (m) as a user would state it, from the clean skeleton."""
    return float(np.nanmedian(height_chain_length(joints)) / CHAIN_TO_STATURE)


def upright_clips(data: Path, file: str, split: str) -> tuple[list, int]:
    """The set's upright clips and the number of lying clips skipped."""
    clips = select_split(load_mocap(data / "mocap" / file), split, "motion-style")
    upright = [c for c in clips if trunk_angle_deg(c.joints) <= LYING_TRUNK_DEG]
    return upright, len(clips) - len(upright)


def run_clip(X: np.ndarray, fps: float, height: float, tmp: Path) -> dict:
    """One recording through run_pipeline: its findings, notes, mode and seconds."""
    src = tmp / "joints.npy"
    np.save(src, X.astype(np.float32))
    cfg = RunConfig(lifter="videopose3d", lifter_output=str(src), fps=float(fps), height=height,
                    recording=False, out=str(tmp / "out"))
    t0 = time.time()
    result = run_pipeline(cfg.validate(), progress=False)
    return {"findings": result.ranked_findings, "notes": result.note_findings, "mode": result.mode,
            "seconds": time.time() - t0}


def evaluate_set(data: Path, file: str, split: str, max_clips: int, log, noise: LifterNoise) -> tuple[list[dict], int]:
    clips, lying = upright_clips(data, file, split)
    rows = []
    for clip, X, R, _ in static_camera_clips(clips, max_clips, noise=noise):
        pitch, roll = (float(np.degrees(a)) for a in camera_pitch_roll(R[0][:, 1]))
        row = {"name": clip.name, "frames": len(X), "pitch": pitch, "roll": roll,
               "level": abs(pitch) <= LEVEL_DEG and abs(roll) <= LEVEL_DEG}
        with tempfile.TemporaryDirectory(prefix="pcnet_flag_rates_") as tmp:
            try:
                row.update(run_clip(X, clip.fps, stature_m(clip.joints), Path(tmp)))
            except Exception as exc:  # a run that fails is reported, not counted as clean
                row["error"] = f"{type(exc).__name__}: {exc}"
        rows.append(row)
        log(f"  {clip.name[:48]:48s} {row['frames']:5d} fr  pitch {pitch:6.1f} roll {roll:6.1f}  "
            + (row.get("error") or f"{row['mode']:8s} {row['seconds']:5.1f} s  "
               + "; ".join(f"{f.kind.name if f.kind else '-'}:{f.severity.name}" for f in row["findings"])))
    return rows, lying


def real_runs(data: Path) -> list[tuple[str, dict]]:
    """``(name, RunConfig fields)`` of every real lifter file of the shared data (module docstring)."""
    real = data / "real"
    runs = [(f"yoga {path.stem.removeprefix('export_')}", dict(lifter="videopose3d", lifter_output=str(path), fps=YOGA_FPS))
            for path in sorted(data.joinpath(*YOGA_FOLDER).glob("*.npy")) if plain_export(path)]
    runs += [(name, {k: str(data / v) if k in ("video", "keypoints2d", "lifter_output") else v
                     for k, v in RECORDINGS[name]["run"].items()}) for name in ("boxing", "sports2d")]
    for path in sorted((real / "pose2sim_gravity").glob("statictrial_cam*.npz")):
        runs.append((f"pose2sim {path.stem.removeprefix('statictrial_')}",
                     dict(keypoints2d=str(path), keypoints2d_format="mediapipe", lifter="mediapipe", lifter_output=str(path))))
    runs += [(f"cycling {path.stem}", dict(lifter="motionbert", lifter_output=str(path), fps=30.0))
             for path in sorted((real / "cycling_motionbert").glob("clip_?_X3D.npy"))]
    return runs


def real_section(data: Path, log) -> list[str]:
    """Each real lifter file's CHECK/PROBLEM findings, and how many files carry each kind."""
    lines, counts, n = [], Counter(), 0
    for name, fields in real_runs(data):
        with tempfile.TemporaryDirectory(prefix="pcnet_flag_rates_") as tmp:
            try:
                result = run_pipeline(RunConfig(**fields, recording=False, out=str(Path(tmp) / "out")).validate(),
                                      progress=False)
            except Exception as exc:  # reported, not counted as clean
                lines.append(f"  {name:34s} failed: {type(exc).__name__}: {exc}")
                continue
        found = [f for f in result.ranked_findings if f.severity >= Severity.CHECK]
        n += 1
        counts.update({f.kind.name if f.kind else "(no kind)" for f in found})
        lines.append(f"  {name:34s} {result.mode:8s} " + " | ".join(
            f"{f.kind.name if f.kind else '-'}: {f.headline}" for f in found))
        log(lines[-1])
    tally = [f"{kind:24s} {c:3d}/{n}" for kind, c in counts.most_common()]
    return ["## Real lifter files: files carrying each kind (CHECK/PROBLEM)", ""] + tally + [
        "", "## Real lifter files: each file's mode and CHECK/PROBLEM headlines", ""] + lines


def warned(row: dict) -> list:
    return [f for f in row.get("findings", []) if f.severity >= Severity.CHECK]


def cell(n: int, N: int) -> str:
    return f"{n}/{N} ({100.0 * n / N:.0f}%)" if N else "-"


def note_stem(headline: str) -> str:
    return " ".join(re.sub(r"[-+]?\d+(\.\d+)?", "#", headline).split()[:6])


def table(results: dict[str, list[dict]], keep) -> list[str]:
    cols = {name: [r for r in rows if "error" not in r and keep(r)] for name, rows in results.items()}
    cols["all sets"] = [r for rows in cols.values() for r in rows]
    width = max(len(k.name) for k in Kind) + 2
    lines = ["kind (CHECK/PROBLEM)".ljust(width) + "".join(f"{c:>18s}" for c in cols)]

    def line(label, test):
        return label.ljust(width) + "".join(f"{cell(sum(map(test, rows)), len(rows)):>18s}" for rows in cols.values())

    kinds = sorted({f.kind for rows in cols.values() for r in rows for f in warned(r)}, key=lambda k: (k is None, k or 0))
    for k in kinds:
        lines.append(line(k.name if k else "(no kind)", lambda r, k=k: any(f.kind == k for f in warned(r))))
    lines.append(line("ANY CHECK/PROBLEM", lambda r: bool(warned(r))))
    lines.append(line("any INFO flag", lambda r: any(f.severity < Severity.CHECK for f in r["findings"])))
    lines.append(line("any note", lambda r: bool(r["notes"])))
    lines.append(line("read moving", lambda r: r["mode"] != "sequence"))
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--max-clips", type=int, default=60)
    ap.add_argument("--no-swaps", action="store_true", help="the lifter-noise model without its left/right swaps")
    ap.add_argument("--real-only", action="store_true", help="only the real lifter files' section (RESULT_REAL)")
    ap.add_argument("--out", type=Path, default=None, help=f"default {RESULT.name}, or {RESULT_NO_SWAPS.name} with --no-swaps")
    args = ap.parse_args(argv)
    if args.real_only:
        if not (args.data / "real").is_dir():
            raise SystemExit(f"flag_rates: {args.data / 'real'}: expected the shared data's real lifter files, found no folder")
        lines = [__doc__.splitlines()[0].replace("upright recordings of new subjects filmed by a static camera",
                                                 "real lifter output"), "", f"    {COMMAND} --real-only", ""]
        print_and_save(lines + real_section(args.data, print), args.out or RESULT_REAL)
        return 0
    out = args.out or (RESULT_NO_SWAPS if args.no_swaps else RESULT)
    noise = LifterNoise(swap_rate_hz=0.0) if args.no_swaps else LifterNoise()
    require_folder(args.data, "flag_rates")
    t0 = time.time()
    per_clip: list[str] = []

    def log(s: str) -> None:
        print(s, flush=True)
        per_clip.append(s)

    results, skipped = {}, {}
    for name, file, split in SETS:
        log(f"{name} ({file}, {split}):")
        results[name], skipped[name] = evaluate_set(args.data, file, split, args.max_clips, log, noise)
    rows = [r for rs in results.values() for r in rs]
    ok = [r for r in rows if "error" not in r]
    secs = np.array([r["seconds"] for r in ok])
    lines = [__doc__.splitlines()[0] + (" Lifter noise without its left/right swaps." if args.no_swaps else ""), "",
             f"    {COMMAND} --max-clips {args.max_clips}" + (" --no-swaps" if args.no_swaps else ""), "",
             "Recordings: " + ", ".join(f"{n} {len(results[n])} (lying skipped {skipped[n]})" for n in results)
             + f"; {sum(r['level'] for r in ok)} of {len(ok)} with a level camera (|pitch|, |roll| <= {LEVEL_DEG:g} deg)."
             + (f" Failed runs: {len(rows) - len(ok)}." if len(rows) > len(ok) else ""),
             f"run_pipeline: median {np.median(secs):.1f} s, max {secs.max():.1f} s per recording "
             f"({time.time() - t0:.0f} s in all).", "",
             "## Recordings carrying at least one finding of the kind, all cameras of the paper distribution", ""]
    lines += table(results, lambda r: True)
    lines += ["", f"## The same, level cameras only (|pitch|, |roll| <= {LEVEL_DEG:g} deg)", ""]
    lines += table(results, lambda r: r["level"])
    lines += ["", "## One example headline per kind (CHECK/PROBLEM, with its clip's camera pitch / roll)", ""]
    seen = set()
    for r in ok:
        for f in warned(r):
            if f.kind not in seen:
                seen.add(f.kind)
                lines.append(f"{f.kind.name if f.kind else '(no kind)'} [{f.severity.name}; {r['name'][:40]}, "
                             f"pitch {r['pitch']:.0f} roll {r['roll']:.0f}]: {f.headline}")
    stems = Counter(s for r in ok for s in {f"{f.kind.name if f.kind else '-'}: {note_stem(f.headline)}"
                                            for f in r["findings"] if f.severity < Severity.CHECK}
                    | {f"note: {note_stem(n.headline)}" for n in r["notes"]})
    lines += ["", "## INFO flags and notes: recordings carrying each (headline's first words, digits as #)", ""]
    lines += [f"{c:4d}/{len(ok)}  {s}" for s, c in stems.most_common()]
    failed = [r for r in rows if "error" in r]
    if failed:
        lines += ["", "## Failed runs", ""] + [f"{r['name']}: {r['error']}" for r in failed]
    lines += ["", "## Per recording (frames, true camera pitch / roll deg, mode, seconds, flags)", ""] + per_clip
    print_and_save(lines, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
