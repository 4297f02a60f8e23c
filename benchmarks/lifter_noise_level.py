"""How large the lifter-like noise is: MPJPE of the noisy camera-frame input against the clean one.

    python -m benchmarks.lifter_noise_level [--data ../shared/data]

Input pairs as `pcnet evaluate --noise lifter` builds them (make_pairs(clips, seed=0,
camera=..., noise=LifterNoise()) against the same call without noise): root-relative MPJPE per
frame, mm, mean / median / p95, on the Bandai motion-style test split (the README's held-out
rows) with per-clip and per-frame "paper" cameras and on DeepMimic; then each component of
models/lifter_noise.py alone (the others set to 0) on the Bandai split, per-clip cameras.
Writes benchmarks/results/lifter_noise_level.txt.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA, data_arguments, print_and_save

from pcnet.models.datasets import load_mocap, make_pairs, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.core.metrics import mpjpe_mm

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "lifter_noise_level.txt"
COMMAND = "python -m benchmarks.lifter_noise_level --data ../shared/data"
OFF = {"offset_sigma_xy_m": 0.0, "offset_sigma_z_m": 0.0, "bone_scale_sigma": 0.0, "lean_sigma_deg": 0.0,
       "depth_scale_sigma": 0.0, "jitter_m": 0.0, "burst_jitter_m": 0.0, "swap_rate_hz": 0.0}
#: Each component alone: the fields it keeps at their defaults (everything else in OFF is 0).
COMPONENTS = {
    "slow per-joint offsets": ("offset_sigma_xy_m", "offset_sigma_z_m"),
    "per-clip lean": ("lean_sigma_deg",),
    "bone lengths": ("bone_scale_sigma",),
    "jitter and bursts": ("jitter_m", "burst_jitter_m"),
    "depth scale": ("depth_scale_sigma",),
    "left/right swaps": ("swap_rate_hz",),
}


def level(clips, camera: str, noise: LifterNoise) -> str:
    clean = make_pairs(clips, seed=0, camera=camera)
    noisy = make_pairs(clips, seed=0, camera=camera, noise=noise)
    err = mpjpe_mm(noisy.inputs, clean.inputs)
    return f"{err.mean():6.1f} {np.median(err):7.1f} {np.percentile(err, 95):6.1f}  ({len(err)} frames)"


def main() -> None:
    args = data_arguments(__doc__, DEFAULT, RESULT, 1)
    bandai = select_split(load_mocap(args.data / "mocap" / "bandai_h36m17.npz"), "test", "motion-style")
    deepmimic = load_mocap(args.data / "mocap" / "deepmimic_h36m17.npz")
    defaults = LifterNoise()
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "", f"{'set, cameras, noise':<62}{'mean':>6} {'median':>7} {'p95':>6}"]
    for name, clips, camera in (("Bandai motion-style test, per-clip cameras", bandai, "per-clip"),
                                ("Bandai motion-style test, per-frame cameras", bandai, "per-frame"),
                                ("DeepMimic all, per-clip cameras", deepmimic, "per-clip")):
        lines.append(f"{name + ', every component':<62}{level(clips, camera, defaults)}")
    for name, kept in COMPONENTS.items():
        alone = dataclasses.replace(defaults, **{k: v for k, v in OFF.items() if k not in kept})
        lines.append(f"{'Bandai test, per-clip cameras, ' + name + ' alone':<62}{level(bandai, 'per-clip', alone)}")
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
