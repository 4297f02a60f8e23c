"""The fastest each periodic joint angle turns in the training motion capture: where continuity ends.

    python -m benchmarks.fit_angle_speeds --data ../shared/data

``stages/kinematics.continuous_angles`` unwraps each periodic angle over a run of present
frames. A lifter's jump (a limb flipped between two frames) is not motion, and unwrapping
through it can leave the rest of the run a whole turn from its usual reading. A step faster
than any the training motion capture makes is taken as such a jump, and the run is split
there.

Fit: the clips of the shipped weights' training mix in its training split
(:func:`benchmarks.mocap_sets.training_mix_splits`: Bandai motion-style train, CMU training
subjects), each clip at its own frame rate, through pcnet's kinematics as a run computes them
(:func:`pcnet.stages.kinematics.compute_kinematics`: zero-phase Butterworth at the runner's
default cutoff, ``pipeline/config.py`` ``DEFAULT_CUTOFF_HZ``; each frame's own decomposition,
``continuous=False``). Per angle of :data:`pcnet.stages.kinematics.PERIODIC_ANGLES`, left and
right pooled, the limit is the largest ``|wrap(a[t+1] - a[t])| * fps`` (deg/s) over every
training frame: no percentile, no margin (the rule of ``benchmarks/fit_speed_limits.py``). The
clip and frame where each occurred are recorded. Writes
``stages/data/angle_speed_limits.json`` (shipped) and
``benchmarks/results/fit_angle_speeds.txt``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import time
from pathlib import Path

import numpy as np

from benchmarks.mocap_sets import TRAINING_MIX, training_mix_splits
from benchmarks.report import SHARED_DATA, print_and_save, require_folder
from pcnet.pipeline.config import DEFAULT_CUTOFF_HZ
from pcnet.stages.kinematics import ANGLE_SPEED_LIMITS_PATH, PERIODIC_ANGLES, angle_kind, compute_kinematics

RESULT = Path(__file__).resolve().parent / "results" / "fit_angle_speeds.txt"
COMMAND = "python -m benchmarks.fit_angle_speeds --data ../shared/data"


def fit(clips) -> dict[str, dict]:
    """Per angle kind (:func:`pcnet.stages.kinematics.angle_kind`), the largest step speed
    (deg/s, rounded up to 1) with the clip, frame and angle where it occurred."""
    best: dict[str, dict] = {}
    for clip in clips:
        angles = compute_kinematics(clip.joints, clip.fps, DEFAULT_CUTOFF_HZ, continuous=False).angles
        for name in PERIODIC_ANGLES:
            speed = np.abs((np.diff(angles[name]) + 180.0) % 360.0 - 180.0) * clip.fps
            if not np.isfinite(speed).any():
                continue
            t = int(np.nanargmax(speed))
            kind = angle_kind(name)
            if speed[t] > best.get(kind, {}).get("deg_per_s", -1.0):
                best[kind] = {"deg_per_s": float(speed[t]), "clip": clip.name, "frame": t, "angle": name}
    return {k: {**v, "deg_per_s": float(np.ceil(v["deg_per_s"]))} for k, v in sorted(best.items())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--out", type=Path, default=RESULT)
    ap.add_argument("--limits", type=Path, default=ANGLE_SPEED_LIMITS_PATH, help="where to write the limits JSON")
    args = ap.parse_args(argv)
    require_folder(args.data, "fit_angle_speeds")
    t0 = time.time()
    (train,) = training_mix_splits(args.data, "train")
    limits = fit(train)
    doc = {
        "description": "Largest frame-to-frame speed (deg/s) of each periodic joint angle in the training motion "
                       "capture: stages/kinematics.continuous_angles splits a run where a step is faster.",
        "rule": "maximum over every training frame, left and right pooled, rounded up to 1 deg/s (no percentile, "
                "no margin)",
        "filter": {"cutoff_hz": DEFAULT_CUTOFF_HZ, "code": "stages/kinematics.py compute_kinematics(continuous=False)"},
        "limits": limits,
        "provenance": {"command": COMMAND, "data": [f"mocap/{name}" for name in TRAINING_MIX],
                       "split": "train of the motion-style scheme (models/datasets.py select_split)",
                       "clips": len(train), "frames": int(sum(len(c.joints) for c in train)),
                       "date": datetime.date.today().isoformat()},
    }
    args.limits.write_text(json.dumps(doc, indent=1) + "\n")
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"{len(train)} training clips, {doc['provenance']['frames']} frames, {DEFAULT_CUTOFF_HZ:g} Hz low-pass",
             f"{'angle':<36}{'deg/s':>8}{'deg/frame at 30 fps':>22}  where"]
    lines += [f"{k:<36}{v['deg_per_s']:>8.0f}{v['deg_per_s'] / 30:>22.1f}  {v['clip']} frame {v['frame']} ({v['angle']})"
              for k, v in limits.items()]
    lines += ["", f"wrote {ANGLE_SPEED_LIMITS_PATH.name} ({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
