"""Blending the body-frame network's up into the camera-frame network's where the gate trusts the latter (not shipped).

    python -m benchmarks.network_blend [--data ../shared/data]

Both 3DPCNets run on every frame anyway, so averaging them costs nothing at run time. On the
motion-style *validation* split (a new "paper" camera per frame, clean and with lifter-like
noise; only the frames the view gate gives the camera-frame network alone, w = 1), the mean
per-frame tilt error of the normalised up ``(1 - alpha) u_camera + alpha u_body`` for alpha in
0-0.5. The rule written before the run (models/MODEL_CARD.md "Experiments"): a gain of at
least 0.05 deg both clean and with lifter noise before any held-out set is run. Writes
benchmarks/results/network_blend.txt.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import print_and_save, trial_arguments

from pcnet.models.datasets import make_pairs
from pcnet.models.inference import BODY_WEIGHTS
from pcnet.models.lifter_noise import LifterNoise
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.core.rotations import angle_between

RESULT = Path(__file__).resolve().parent / "results" / "network_blend.txt"
COMMAND = "python -m benchmarks.network_blend --data ../shared/data"
ALPHAS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)


def blend_errors(clips, noise) -> tuple[dict[float, float], int]:
    """Mean tilt error (deg) per alpha over the frames the gate gives the camera-frame network
    alone, and how many frames that is."""
    pair, body = make_estimator("pcnet"), make_estimator("pcnet", str(BODY_WEIGHTS))
    pairs = make_pairs(clips, views="paper", seed=0, camera="per-frame", noise=noise)
    errors: dict[float, list] = {a: [] for a in ALPHAS}
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(pairs.clip == i)
        if not len(sel):
            continue
        gated, alone = pair(pairs.inputs[sel], clip.fps), body(pairs.inputs[sel], clip.fps)
        ok = gated.valid & alone.valid & (gated.camera_frame_weight == 1.0)
        u_cam, u_body, truth = gated.rotation[ok][:, :, 1], alone.rotation[ok][:, :, 1], pairs.R[sel][ok][:, :, 1]
        for a in ALPHAS:
            u = (1 - a) * u_cam + a * u_body
            errors[a].append(np.degrees(angle_between(u / np.linalg.norm(u, axis=1, keepdims=True), truth)))
    return {a: float(np.concatenate(e).mean()) for a, e in errors.items()}, int(sum(len(x) for x in errors[0.0]))


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="network_blend")
    (val,) = training_mix_splits(args.data, "val")
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             "Motion-style validation split, frames with w = 1; mean per-frame tilt error (deg) per alpha:",
             f"  {'noise':<8}{'frames':>8}" + "".join(f"{a:>9.1f}" for a in ALPHAS)]
    for name, noise in (("clean", None), ("lifter", LifterNoise())):
        means, n = blend_errors(val, noise)
        lines.append(f"  {name:<8}{n:>8}" + "".join(f"{means[a]:>9.3f}" for a in ALPHAS))
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
