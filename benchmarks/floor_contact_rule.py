"""The world frame's ground with and without its slower-half contact rule (decision 0071).

    python -m benchmarks.floor_contact_rule --data ../shared/data

``stages/floor.py`` fits the ground plane to the slower half of the frames' lowest joints (the
shipped rule). The candidate takes every usable frame's lowest joint. Each is used with its own
``ANKLE_CLEARANCE_LEG``: the shipped one, and the candidate's refitted by
``benchmarks/fit_floor.py``'s procedure on the CMU training subjects. Both run through
``stages/world_frame.to_world_floor``, the candidate by replacing ``stages/floor.contacts`` for
the call. Rows: ``fit_floor``'s held-out clips and inputs (CMU validation subjects 12 and 60,
DeepMimic; the true path, the path x1.05 along the rays, its depth x1.05, lifter noise); per
row the mean absolute floor error (cm) of each and their paired difference per clip with its
95 % bootstrap interval (:func:`benchmarks.ablation.paired_interval`). Writes
benchmarks/results/floor_contact_rule.txt.
"""

from __future__ import annotations

import argparse
import contextlib
import time
from collections import defaultdict
from pathlib import Path
from unittest import mock

import numpy as np

import pcnet.stages.floor as floor_module
import pcnet.stages.world_frame as world_frame_module
from benchmarks import fit_floor as FF
from benchmarks.ablation import paired_interval
from benchmarks.report import SHARED_DATA, print_and_save, require_mocap
from pcnet.models.datasets import group_key, load_mocap, select_split
from pcnet.stages.world_frame import to_world_floor

RESULT = Path(__file__).resolve().parent / "results" / "floor_contact_rule.txt"
#: Worse by the rule: mean absolute error up by more than this (cm) with the interval above zero.
MARGIN_CM = 0.2
INPUTS = ("path", "path x1.05 (rays)", "path z x1.05", "lifter noise")


def every_frame(lowest: np.ndarray, step: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """The candidate's contacts: every usable frame with a lowest joint."""
    return usable & np.isfinite(lowest)


@contextlib.contextmanager
def rule(candidate: bool, clearance: float):
    """The floor's contacts and clearance for the duration: the candidate's or the shipped."""
    if not candidate:
        yield
        return
    with mock.patch.object(floor_module, "contacts", every_frame), \
            mock.patch.object(FF, "contacts", every_frame), \
            mock.patch.object(floor_module, "ANKLE_CLEARANCE_LEG", clearance), \
            mock.patch.object(world_frame_module, "ANKLE_CLEARANCE_LEG", clearance):
        yield


def refitted_clearance(cmu) -> float:
    """``fit_floor``'s fit of ``ANKLE_CLEARANCE_LEG`` under the candidate's contacts."""
    per_subject = defaultdict(list)
    with rule(True, float("nan")):
        for c in select_split(cmu, "train", "motion-style"):
            if len(c.joints) >= 30:
                a, leg, _, _ = FF.contact_level(c.joints.astype(np.float64))
                per_subject[group_key(c)].append(a / leg)
    return float(np.median([np.median(v) for v in per_subject.values()]))


def errors(clips, candidate: bool, clearance: float) -> dict[str, np.ndarray]:
    """Per input of :data:`INPUTS`, each clip's absolute floor error (cm)."""
    out = defaultdict(list)
    with rule(candidate, clearance):
        for i, c in enumerate(clips):
            J = c.joints.astype(np.float64)
            if len(J) < 30:
                continue
            rel, root, frame = FF.filmed(J, c.fps)
            if not np.allclose((frame.rotation @ FF.CAMERA)[1], [0, 1, 0], atol=1e-6):
                continue
            noisy = FF.filmed(J, c.fps, noise_seed=i)[0]
            for name, path, joints in zip(INPUTS, (root, root * 1.05, root * np.array([1.0, 1.0, 1.05]), root),
                                          (rel, rel, rel, noisy)):
                out[name].append(abs(FF.floor_error_cm(J, to_world_floor(joints, frame, path)[0])))
    return {k: np.array(v) for k, v in out.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    require_mocap(args.data, "floor_contact_rule")
    t0 = time.time()
    cmu = load_mocap(args.data / "mocap" / "cmu_train_h36m17.npz")
    clearance = refitted_clearance(cmu)
    lines = [__doc__.splitlines()[0], "", "    python -m benchmarks.floor_contact_rule --data ../shared/data", "",
             f"ANKLE_CLEARANCE_LEG: shipped {floor_module.ANKLE_CLEARANCE_LEG} (slower half), candidate refitted "
             f"{clearance:.4f} (every frame)", "",
             "| data | input | clips | shipped, mean abs (cm) | candidate | candidate - shipped [95 % CI] | worse |",
             "|---|---|---:|---:|---:|---|---|"]
    worse_on = []
    for label, clips in (("CMU val (subjects 12, 60)", select_split(cmu, "val", "motion-style")),
                         ("DeepMimic (all)", load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz"))):
        shipped, new = errors(clips, False, clearance), errors(clips, True, clearance)
        for name in INPUTS:
            mean, lo, hi = paired_interval(new[name] - shipped[name])
            bad = mean > MARGIN_CM and lo > 0
            worse_on += [f"{label}, {name}"] * bad
            lines.append(f"| {label} | {name} | {len(new[name])} | {shipped[name].mean():.2f} | {new[name].mean():.2f} | "
                         f"{mean:+.2f} [{lo:+.2f}, {hi:+.2f}] | {'yes' if bad else 'no'} |")
    lines += ["", "verdict: " + (f"worse on {'; '.join(worse_on)}: the rule stays" if worse_on else
                                 "worse on no row: the rule goes"), "", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
