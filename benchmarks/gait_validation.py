"""Gait events and spatiotemporal parameters (``pcnet gait``, ``stages/gait.py``) against motion capture.

    python -m benchmarks.gait_validation --data ../shared/data [--max-clips 8] [--max-seconds 20]
        [--seed 0] [--out benchmarks/results/gait_validation.txt]

Nothing in ``stages/gait.py`` is fitted, so no clip here chose anything; the data are still the
held-out ones (never trained on by the shipped networks, whose rectification the runs use).

1. **Screen** (every clip of the Bandai and DeepMimic mocap, clean): how many clips
   ``pcnet gait`` accepts (``gait_events``, then ``check_forward`` on the steps with the true
   pelvis path), per kind of motion. Walks and runs (Bandai walk, walk-turn-*, run,
   dash; DeepMimic clips named walk, jog or run) should be accepted, in-place motion (bows,
   waves, raised hands, calls; DeepMimic's other clips) refused; Bandai's walks to the left or
   right (facing the way they go), its backwards walks (refused by their steps' direction:
   ``check_forward``) and DeepMimic's walk-to-stand transitions are listed apart.
2. **Through `pcnet run`** (a user's path): the Bandai motion-style test split's walks and runs
   (``select_split(..., "test", "motion-style")``: walk, walk-turn-*, run, dash) and DeepMimic's
   forward walks and runs, at most ``--max-clips`` of each set evenly spaced over the clips of at
   least 3 s, the first ``--max-seconds`` of each. Each clip is filmed by one static camera and
   run through ``pcnet run`` clean and with lifter-like noise, both exactly as in
   ``benchmarks/world_validation.py`` (its camera, inputs and runner: 3D from VideoPose3D's
   export, 2D AlphaPose keypoints, the pelvis path fitted to them, the rectification's world
   frame; a black video of the camera's size gives the image size). ``pcnet gait``'s analysis (``pipeline/gait.py: analyse``) reads the run's folder.
   Truth: the same analysis on the true joints (``world_validation.truth_world``, low-passed with
   the run's cutoff, the pelvis path known in every frame).

3. **A real walk** (``real/sports2d_demo/demo.mp4``, a woman walking across the view for about
   5 s while a man stands and jumps on a box behind her): ``pcnet run --video demo.mp4 --roi
   0,470,1768,524 --height 1.65`` (the embedded MediaPipe, shown only the band she walks in; her
   height is assumed, and step lengths and speed scale with it), then ``pcnet gait``'s summary
   and events, and each knee's peak flexion over the mean gait cycle. Skipped without the
   ``video`` extra. No truth here: the events' frames are for checking against the video by eye.

4. **Real recordings that are not gait**: every VideoPose3D yoga file of ``real/yoga_videopose3d``
   (asanas held in place), the boxing clip's MotionBERT output (``real/boxing_motionbert``, with its
   AlphaPose 2D) and the two stationary-bike clips of ``real/cycling_motionbert``, each through
   ``pcnet run`` (``--fps 30 --height 1.7``): how many ``gait_events`` reads as gait.

Metrics per clip (truth events matched to the run's by side, each to the nearest within half
the true stride):
- strike / off time error (ms): median over matched events of |run time - true time|;
- matched: the share of true strikes with a run strike matched; extra: run strikes without one;
- cadence (steps/min), stance (% of stride), step length (m) and walking speed (m/s): the run's
  summary value minus the truth's (``pcnet gait``'s gait.json), signed and absolute;
- refused: clips whose run ``pcnet gait`` refused (no antiphase, no cycle, no step).
Summaries over clips: median and 95th percentile of |error|, mean of the signed error.
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import json
import sys
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA
from benchmarks.world_validation import (FOCAL_PX, focal_route, make_inputs, place_camera, run_pcnet,
                                         truth_world)
from pcnet.models.datasets import load_mocap, select_split
from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.gait import analyse
from pcnet.pipeline.runner import run_pipeline
from pcnet.stages.gait import check_forward, GaitError, gait_events, SIDES, steps, summarise
from pcnet.stages.kinematics import butterworth_lowpass

ROOT = Path(__file__).resolve().parent.parent
RESULT = ROOT / "benchmarks" / "results" / "gait_validation.txt"
MIN_SECONDS = 3.0
BANDAI_GAIT = ("walk", "walk-turn-left", "walk-turn-right", "run", "dash")
#: Bandai's walks toward the actor's left or right (facing the way they go: a gait trial measured
#: a median cosine of 0.76-0.99 between the facing and the travel) and backwards.
BANDAI_SIDEWAYS = ("walk-left", "walk-right")
BANDAI_BACKWARD = ("walk-back",)
DEEPMIMIC_GAIT = ("walk", "jog", "run")
CONDITIONS = ("clean", "lifter noise")


def bandai_kind(name: str) -> str:
    return name.split("_")[1]


def screen_group(set_name: str, name: str) -> str:
    """"gait", "not forward" or "in place" for the antiphase screen."""
    if set_name == "bandai":
        kind = bandai_kind(name)
        return ("gait" if kind in BANDAI_GAIT else "walk left/right" if kind in BANDAI_SIDEWAYS
                else "backward" if kind in BANDAI_BACKWARD else "in place")
    lowered = name.lower()
    if "ready" in lowered:  # walk <-> stand transitions: partly gait, listed apart
        return "walk to stand"
    return "gait" if any(w in lowered for w in DEEPMIMIC_GAIT) else "in place"


def antiphase_screen(data: Path) -> list[str]:
    lines = ["## 1. Screen: clips pcnet gait accepts (clean mocap, every clip, the pelvis path known)", "",
             "| set | motion | clips | accepted | refused |", "|---|---|---|---|---|"]
    for set_name, file in (("bandai", "bandai_h36m17.npz"), ("deepmimic", "deepmimic_h36m17.npz")):
        counts = collections.defaultdict(lambda: [0, 0])
        for clip in load_mocap(data / "mocap" / file):
            group = screen_group(set_name, clip.name)
            joints = np.asarray(clip.joints, np.float64)
            try:  # pcnet gait's refusals: the events' (gait_events) and the steps' direction (check_forward)
                check_forward(steps(gait_events(joints, clip.fps), joints, np.ones(len(joints), bool)))
                counts[group][0] += 1
            except GaitError:
                counts[group][1] += 1
        groups = (("gait", "walk left/right", "backward", "in place") if set_name == "bandai"
                  else ("gait", "walk to stand", "in place"))
        for group in groups:
            a, r = counts[group]
            lines.append(f"| {set_name} | {group} | {a + r} | {a} | {r} |")
    return lines + [""]


def held_out_clips(data: Path, max_clips: int, max_seconds: float):
    bandai = [c for c in select_split(load_mocap(data / "mocap" / "bandai_h36m17.npz"), "test", "motion-style")
              if bandai_kind(c.name) in BANDAI_GAIT]
    deepmimic = [c for c in load_mocap(data / "mocap" / "deepmimic_h36m17.npz")
                 if screen_group("deepmimic", c.name) == "gait"]
    for label, clips in (("Bandai motion-style test walks and runs", bandai),
                         ("DeepMimic walks and runs (another data set)", deepmimic)):
        long_enough = [c for c in clips if len(c.joints) / c.fps >= MIN_SECONDS]
        picks = np.unique(np.linspace(0, len(long_enough) - 1, min(max_clips, len(long_enough))).round().astype(int))
        for i in picks:
            c = long_enough[i]
            n = min(len(c.joints), int(round(max_seconds * c.fps)))
            yield label, c.name, np.asarray(c.joints[:n], np.float64), float(c.fps)


def truth_analysis(world: np.ndarray, fps: float, cutoff_hz: float | None):
    joints = butterworth_lowpass(world, fps, cutoff_hz) if cutoff_hz else world
    events = gait_events(joints, fps)
    step_list = steps(events, joints, np.ones(len(joints), bool))
    return events, summarise(events, step_list)


def matched(true_t: np.ndarray, run_t: np.ndarray, window: float) -> tuple[np.ndarray, int, int]:
    """|time difference| of each true event's nearest run event within ``window`` (s); counts matched, extra."""
    dts = []
    used = set()
    for t in true_t:
        if run_t.size == 0:
            continue
        k = int(np.argmin(np.abs(run_t - t)))
        if abs(run_t[k] - t) <= window:
            dts.append(abs(run_t[k] - t))
            used.add(k)
    return np.asarray(dts), len(dts), run_t.size - len(used)


def clip_metrics(out: Path, world: np.ndarray, fps: float, cutoff_hz: float | None) -> dict:
    try:
        result = analyse(out)
    except GaitError:
        return {"refused": 1}
    events, truth = truth_analysis(world, fps, cutoff_hz)
    window = truth.stride_period_s / 2
    strike_dt, off_dt, n_true, n_matched, extra = [], [], 0, 0, 0
    for side in SIDES:
        dt, m, x = matched(events.foot(side).strikes_s, result.events.foot(side).strikes_s, window)
        strike_dt.append(dt)
        n_true += events.foot(side).strikes_s.size
        n_matched += m
        extra += x
        off_dt.append(matched(events.foot(side).offs_s, result.events.foot(side).offs_s, window)[0])
    strike_dt, off_dt = np.concatenate(strike_dt), np.concatenate(off_dt)

    def both(summary, key):
        return float(np.nanmean([getattr(getattr(summary, s), key) for s in SIDES]))

    run = result.summary
    return {
        "refused": 0,
        "strike_ms": 1000 * float(np.median(strike_dt)) if strike_dt.size else np.nan,
        "off_ms": 1000 * float(np.median(off_dt)) if off_dt.size else np.nan,
        "matched": n_matched / max(n_true, 1), "extra": extra / max(n_true, 1),
        "cadence": run.cadence_steps_per_min - truth.cadence_steps_per_min,
        "stance": both(run, "stance_percent") - both(truth, "stance_percent"),
        "step_length": both(run, "step_length") - both(truth, "step_length"),
        "speed": run.walking_speed - truth.walking_speed,
        "true_cadence": truth.cadence_steps_per_min, "true_speed": truth.walking_speed,
    }


METRICS = (("strike_ms", "foot strike time error (ms)", ".0f", False), ("off_ms", "foot off time error (ms)", ".0f", False),
           ("matched", "true strikes matched", ".2f", False), ("extra", "extra run strikes per true", ".2f", False),
           ("cadence", "cadence error (steps/min)", ".1f", True), ("stance", "stance error (% of stride)", ".1f", True),
           ("step_length", "step length error (m)", ".3f", True), ("speed", "walking speed error (m/s)", ".3f", True))


def summary_rows(label: str, cond: str, ms: list[dict]) -> list[str]:
    ok = [m for m in ms if not m["refused"]]
    rows = []
    for key, name, f, signed in METRICS:
        x = np.asarray([m[key] for m in ok], np.float64)
        x = x[np.isfinite(x)]
        if not x.size:
            rows.append(f"| {label} | {cond} | {name} | - | - | - |")
            continue
        a = np.abs(x)
        mean = f"{x.mean():+{f}}" if signed else f"{x.mean():{f}}"
        rows.append(f"| {label} | {cond} | {name} | {np.median(a):{f}} | {np.percentile(a, 95):{f}} | {mean} |")
    return rows


WALKER_VIDEO = ("real", "sports2d_demo", "demo.mp4")
WALKER_ROI = "0,470,1768,524"
WALKER_HEIGHT_M = 1.65


def real_walk(data: Path, tmp: Path) -> list[str]:
    lines = ["## 3. A real walk: the Sports2D demo's walker through `pcnet run --video`", ""]
    if importlib.util.find_spec("mediapipe") is None:
        return lines + ["skipped: the video extra (MediaPipe) is not installed", ""]
    video = data.joinpath(*WALKER_VIDEO)
    out = tmp / "walker"
    run_pipeline(RunConfig(video=str(video), roi=WALKER_ROI, height=WALKER_HEIGHT_M, out=str(out), recording=False),
                 progress=False)
    result = analyse(out)
    s = result.summary
    lines += [f"`pcnet run --video {'/'.join(WALKER_VIDEO)} --roi {WALKER_ROI} --height {WALKER_HEIGHT_M}`, "
              f"then `pcnet gait`: cadence {s.cadence_steps_per_min:.1f} steps/min, walking speed "
              f"{s.walking_speed:.2f} m/s, {len(result.steps)} foot strikes", "",
              "| foot | strikes | stride time (s) | stance (% of stride) | step length (m) |", "|---|---|---|---|---|"]
    for side in SIDES:
        f = getattr(s, side)
        lines.append(f"| {side} | {f.strikes} | {f.stride_time_s:.3f} | {f.stance_percent:.1f} | {f.step_length:.3f} |")
    peaks = {side: float(np.nanmax(np.nanmean(result.cycles[f"{side}_knee_flexion_deg"], axis=0))) for side in SIDES}
    lines += ["", "mean knee flexion's peak over the cycle (deg): " + ", ".join(f"{k} {v:.1f}" for k, v in peaks.items())]
    lines += ["", "foot strikes (frame, side): " + ", ".join(
        f"{round(st.time_s * result.run.fps)} {st.side}" for st in result.steps), ""]
    return lines


def real_not_gait(data: Path, tmp: Path) -> list[str]:
    real = data / "real"
    sets = {
        "yoga (VideoPose3D)": [dict(lifter="videopose3d", lifter_output=str(f))
                               for f in sorted((real / "yoga_videopose3d").glob("export_*.npy"))],
        "boxing (MotionBERT, AlphaPose 2D)": [dict(
            lifter="motionbert", lifter_output=str(real / "boxing_motionbert" / "X3D.npy"),
            keypoints2d=str(real / "boxing_motionbert" / "alphapose-results.json"), keypoints2d_format="alphapose")],
        "stationary bike (MotionBERT)": [dict(lifter="motionbert", lifter_output=str(f))
                                         for f in sorted((real / "cycling_motionbert").glob("clip_?_X3D.npy"))],
    }
    lines = ["## 4. Real recordings that are not gait, through `pcnet run`", "",
             "| recordings | runs | read as gait | which |", "|---|---|---|---|"]
    for label, configs in sets.items():
        accepted = []
        for k, fields in enumerate(configs):
            out = tmp / f"real_{len(label)}_{k}"
            run_pipeline(RunConfig(**fields, fps=30.0, height=1.7, out=str(out), recording=False), progress=False)
            try:
                analyse(out)
                accepted.append(Path(fields["lifter_output"]).name)
            except GaitError:
                pass
        lines.append(f"| {label} | {len(configs)} | {len(accepted)} | {', '.join(accepted) or '-'} |")
    return lines + [""]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--max-clips", type=int, default=8, help="per data set")
    ap.add_argument("--max-seconds", type=float, default=20.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args()
    t0 = time.perf_counter()
    command = "python -m benchmarks.gait_validation" + "".join(f" {a}" for a in sys.argv[1:])
    lines = [f"# Gait events against motion capture\n\ncommand: `{command}`\n"]
    lines += antiphase_screen(args.data)
    print("\n".join(lines), flush=True)
    route, _ = focal_route()
    per = collections.defaultdict(list)
    clip_rows = ["| set | clip | condition | refused | strike (ms) | off (ms) | cadence err | true cadence | "
                 "step length err (m) | speed err (m/s) | true speed (m/s) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for label, name, joints, fps in held_out_clips(args.data, args.max_clips, args.max_seconds):
            world = truth_world(joints, fps)
            seed = zlib.crc32(name.encode()) + args.seed
            cam = place_camera(world, np.random.default_rng(seed))
            if cam is None:
                print(f"{name}: no camera keeps it in view; skipped", flush=True)
                continue
            for cond in CONDITIONS:
                rel, px = make_inputs(world, cam, fps, cond != "clean", np.random.default_rng(seed + 1))
                out, _ = run_pcnet(Path(tmp) / f"{zlib.crc32(name.encode())}_{cond[0]}", rel, px, fps, False,
                                   route, blank_video=True, mode="sequence")
                with np.load(out / "canonical.npz", allow_pickle=False) as z:
                    cutoff = json.loads(str(z["report"])).get("cutoff_hz")
                m = clip_metrics(out, world, fps, cutoff)
                per[(label, cond)].append(m)
                cells = ["yes" if m["refused"] else "no"] + (["-"] * 7 if m["refused"] else [
                    f"{m['strike_ms']:.0f}", f"{m['off_ms']:.0f}", f"{m['cadence']:+.1f}", f"{m['true_cadence']:.1f}",
                    f"{m['step_length']:+.3f}", f"{m['speed']:+.3f}", f"{m['true_speed']:.2f}"])
                clip_rows.append(f"| {label} | {name} | {cond} | " + " | ".join(cells) + " |")
                print(clip_rows[-1], flush=True)
        walk = real_walk(args.data, Path(tmp))
        print("\n".join(walk), flush=True)
        walk += real_not_gait(args.data, Path(tmp))
    print("\n".join(walk[-8:]), flush=True)
    table = ["## 2. Through `pcnet run` (one static camera per clip, `--mode sequence`)", "",
             f"Focal length {FOCAL_PX:.1f} px given to the runs; truth = the same analysis on the true joints.", "",
             "| set | condition | metric | median abs | p95 abs | mean (signed) |", "|---|---|---|---|---|---|"]
    for (label, cond), ms in per.items():
        refused = sum(m["refused"] for m in ms)
        table.append(f"| {label} | {cond} | clips (refused) | {len(ms)} ({refused}) | | |")
        table += summary_rows(label, cond, ms)
    lines += table + ["", "Per clip:", ""] + clip_rows + [""] + walk + [f"({time.perf_counter() - t0:.0f} s)"]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(table), flush=True)


if __name__ == "__main__":
    main()
