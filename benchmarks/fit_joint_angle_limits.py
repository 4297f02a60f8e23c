"""Joint-angle limits fitted on training mocap (decision 0084), and their false alarms on held-out mocap.

    python -m benchmarks.fit_joint_angle_limits --data ../shared/data

Fit: the training mix's training split (:func:`benchmarks.mocap_sets.training_mix_splits`:
Bandai motion-style train, CMU training subjects), clean, each clip at its own frame rate
through :func:`pcnet.stages.kinematics.compute_kinematics` (the runner's default low-pass,
``pipeline/config.py`` ``DEFAULT_CUTOFF_HZ``). Per angle of :data:`SEGMENT_ANGLES` (the ISB
angles between two segments; left and right pooled) the smallest and the largest value of any
frame: no percentile or margin, recorded with where each occurred.

Check (decision 0084's rule): on the Bandai motion-style test split's clips outside the
ablation's 200-clip subset (``benchmarks.ablation.static_camera_clips(..., rest=True)``: one
static "paper" camera, the lifter-noise model), the recordings whose warning
(:func:`joint_angle_range_flag`: an angle whose median over the frames lies outside its
limits) would fire, at most 1 in 20; and the real Padmasana file a user trial
found (``real/yoga_videopose3d/export_Veena_Padmasana.npy``) flagged. It would have written
``stages/data/joint_angle_limits.json`` for a warning in stages/flags.py where the rule passed;
it did not (decision 0084), so the check lives here alone.
"""

from __future__ import annotations

import datetime
import json
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks.ablation import MOCAP_SETS, static_camera_clips
from benchmarks.mocap_sets import TRAINING_MIX, training_mix_splits
from benchmarks.report import fit_arguments, print_and_save
from pcnet.adapters import get_3d_adapter
from pcnet.models.datasets import load_mocap, select_split
from pcnet.pipeline.config import DEFAULT_CUTOFF_HZ
from pcnet.stages.isb_angles import NAMES
from pcnet.stages.kinematics import angle_kind, compute_kinematics

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "fit_joint_angle_limits.txt"
COMMAND = "python -m benchmarks.fit_joint_angle_limits --data ../shared/data"

#: The ISB angles between two segments (``stages/isb_angles.NAMES`` less the two against
#: gravity, which the rectification sets), without ``_deg``: what :func:`joint_angle_range_flag`
#: reads.
SEGMENT_ANGLES: tuple[str, ...] = tuple(n.removesuffix("_deg") for n in NAMES if "to_gravity" not in n)
#: Where the fitted limits would have shipped (decision 0084 did not ship them).
JOINT_ANGLE_LIMITS_PATH = ROOT / "stages" / "data" / "joint_angle_limits.json"


@dataclass(frozen=True)
class JointAngleLimits:
    """Per angle kind (:func:`pcnet.stages.kinematics.angle_kind` of :data:`SEGMENT_ANGLES`),
    ``(low, high)`` degrees: the smallest and largest value of any frame of the training mocap
    (decision 0084, ``python -m benchmarks.fit_joint_angle_limits --data ../shared/data``).

    Attributes:
        limits: kind -> ``(low, high)``, deg. provenance: the fit's command, data and where each
            extreme occurred.
    """

    limits: Mapping[str, tuple[float, float]]
    provenance: Mapping = field(default_factory=dict)


def joint_angle_range_flag(angles: Mapping[str, np.ndarray], limits: JointAngleLimits) -> list[str]:
    """A flag naming the angles between two segments whose median over the recording's frames
    lies outside the training mocap's range (:class:`JointAngleLimits`, decision 0084): a pose no
    training motion reaches, read by a lifter that never saw it either.

    Args:
        angles: angle name (with or without ``_deg``) -> ``(T,)`` degrees, NaN = missing (e.g.
            :attr:`pcnet.stages.kinematics.Kinematics.angles`); names outside
            :data:`SEGMENT_ANGLES` are not read.
        limits: the fitted :class:`JointAngleLimits`.

    Returns:
        the warning's headline, or nothing.
    """
    table = limits.limits
    beyond = []
    for name, values in angles.items():
        short = name.removesuffix("_deg")
        x = np.asarray(values, np.float64)
        if short not in SEGMENT_ANGLES or not np.isfinite(x).any():
            continue
        median, (low, high) = float(np.nanmedian(x)), table[angle_kind(short)]
        if not low <= median <= high:
            beyond.append((short, median, low, high))
    if not beyond:
        return []
    name, median, _, _ = max(beyond, key=lambda b: max(b[2] - b[1], b[1] - b[3]))
    more = f" +{len(beyond) - 1} more" if len(beyond) > 1 else ""
    return [f"{name.replace('_', ' ')} reads {median:.0f} deg, beyond any training motion's{more}"]

PADMASANA = ("real", "yoga_videopose3d", "export_Veena_Padmasana.npy")
#: Camera frame (x right, y down, z forward) -> Y up: a proper rotation (180 deg about x), which
#: leaves every angle between two segments as it is.
Y_UP = np.array([1.0, -1.0, -1.0])


def angles_of(joints: np.ndarray, fps: float) -> dict[str, np.ndarray]:
    """The :data:`SEGMENT_ANGLES` of Y-up H36M-17 poses, as a run computes them."""
    k = compute_kinematics(joints, fps, DEFAULT_CUTOFF_HZ)
    return {name: np.asarray(k.angles[name]) for name in SEGMENT_ANGLES}


def fit(clips) -> dict[str, dict]:
    """Per angle kind, ``{"low", "high", "low_at", "high_at"}`` (deg; clip and frame)."""
    out: dict[str, dict] = {}
    for clip in clips:
        for name, a in angles_of(clip.joints, clip.fps).items():
            if not np.isfinite(a).any():
                continue
            kind, lo, hi = angle_kind(name), int(np.nanargmin(a)), int(np.nanargmax(a))
            row = out.setdefault(kind, {"low": np.inf, "high": -np.inf})
            if a[lo] < row["low"]:
                row.update(low=float(a[lo]), low_at=f"{clip.name} frame {lo} ({name})")
            if a[hi] > row["high"]:
                row.update(high=float(a[hi]), high_at=f"{clip.name} frame {hi} ({name})")
    return {k: {**v, "low": float(np.floor(v["low"] * 10) / 10), "high": float(np.ceil(v["high"] * 10) / 10)}
            for k, v in sorted(out.items())}


def main() -> None:
    args = fit_arguments(__doc__, "fit_joint_angle_limits", RESULT, JOINT_ANGLE_LIMITS_PATH)
    t0 = time.perf_counter()
    (train,) = training_mix_splits(args.data, "train")
    limits = fit(train)
    candidate = JointAngleLimits({k: (v["low"], v["high"]) for k, v in limits.items()})
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"Fit: {len(train)} training clips, {DEFAULT_CUTOFF_HZ:g} Hz low-pass; per angle the smallest and largest "
             f"frame (rounded outwards to 0.1 deg)", "", f"{'angle':<34}{'low':>8}{'high':>8}  where"]
    lines += [f"{k:<34}{v['low']:>8.1f}{v['high']:>8.1f}  {v['low_at']}; {v['high_at']}" for k, v in limits.items()]
    _, file, split = MOCAP_SETS[0]
    clips = select_split(load_mocap(args.data / "mocap" / file), split, "motion-style")
    flagged, n = [], 0
    for clip, X, R, _ in static_camera_clips(clips, 200, rest=True):
        n += 1
        found = joint_angle_range_flag(angles_of(X.astype(np.float64) * Y_UP, clip.fps), candidate)
        if found:
            flagged.append(f"{clip.name}: {found[0]}")
    poses = get_3d_adapter("videopose3d").load(args.data.joinpath(*PADMASANA))
    real = joint_angle_range_flag(angles_of(np.asarray(poses.joints, np.float64) * Y_UP, 30.0), candidate)
    held_ok, real_ok = len(flagged) <= n / 20, bool(real)
    lines += ["", f"Held out: Bandai motion-style test, the clips outside the ablation's 200 ({n} recordings, one static "
                  f"'paper' camera, lifter noise): {len(flagged)} flagged (at most {n / 20:.1f} allowed)",
              *(f"    {f}" for f in flagged[:20]), *(["    ..."] if len(flagged) > 20 else []),
              f"Real {'/'.join(PADMASANA)} at 30 fps: {real[0] if real else 'not flagged'}", "",
              f"Decision 0084's rule: (1) held-out false alarms within 1 in 20: {'yes' if held_ok else 'no'}; (2) the "
              f"real Padmasana flagged: {'yes' if real_ok else 'no'}. The limits "
              f"{'ship' if held_ok and real_ok else 'do not ship'}.", "", f"({time.perf_counter() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    if held_ok and real_ok:
        args.json.write_text(json.dumps({
            "description": "pcnet's joint-angle limits (stages/flags.py joint_angle_range_flag, decision 0084): the "
                           "smallest and largest value of each angle between two segments in the training mocap",
            "limits": {k: [v["low"], v["high"]] for k, v in limits.items()},
            "provenance": {"command": COMMAND, "date": datetime.date.today().isoformat(),
                           "data": " + ".join(TRAINING_MIX) + f", motion-style train split ({len(train)} clips)",
                           "filter": f"{DEFAULT_CUTOFF_HZ:g} Hz (stages/kinematics.py compute_kinematics)",
                           "where": {k: [v["low_at"], v["high_at"]] for k, v in limits.items()}}}, indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
