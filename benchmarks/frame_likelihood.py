"""Frame mode without the view gate: the up model's per-frame likelihood and each network alone against the gate.

    python -m benchmarks.frame_likelihood --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Frame mode answers each frame alone. pcnet ships the view gate's blend of its two networks'
rotations (``models/view_gate.py``: ramps with hand-set constants, decisions 0025 and 0040).
The up model (``stages/up_model.py``, docs/up_model.md) already holds a fitted error model of
each network's per-frame up: ``l_t(g)``, with the camera-frame network's precision falling
with its view tilt and its fall-back to the level camera. Its per-frame maximiser ``g_hat_t``
(each frame alone, no prior: ``benchmarks.up_model_variants.summarise_frames``) is a frame-mode
answer with no constant of its own.

Printed per set: the mean over clips of each clip's mean per-frame tilt error (deg) of the
gate and of ``g_hat_t``, and the paired difference (``g_hat_t`` minus gate) with its 95 %
bootstrap interval over clips (:func:`benchmarks.ablation.paired_interval`); then the same for
each network alone (the camera-frame network in the quarter-turned frame, the body-frame
network; benchmarks/ablation.py's "gate off" rows). Validation sets first (Bandai motion-style
val + CMU val subjects, static "paper", "wide" and fully rolled views: the up model was fitted
on them), then the held-out sets of ``benchmarks/ablation.py`` from its cache (the same
recordings: Bandai motion-style test, CMU test subjects, DeepMimic, the moving camera, the
camera rolled 30 and 90 deg, the real calibrated cameras in their 16 views). The decision
rules are docs/decisions/0050-frame-mode-likelihood.md's (``g_hat_t``) and
docs/decisions/0057-frame-mode-gate-against-one-network.md's (each network alone).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from benchmarks.up_model_variants import summarise_frames
from pcnet.stages.up_model import default_parameters

RESULT = Path(__file__).resolve().parent / "results" / "frame_likelihood.txt"
COMMAND = "python -m benchmarks.frame_likelihood --data ../shared/data"


#: The networks alone, with their column labels: benchmarks/ablation.py's rows with the gate's weight fixed.
ALONE = tuple((label, next(v for v in A.VARIANTS if v.gate == gate)) for label, gate in (("body net", "body"),
                                                                                          ("cam net", "camera")))


def _gate_error(ev: dict, v) -> float:
    R, valid, _, _ = A.per_frame(ev, v)
    return A.clip_error(np.where(valid[:, None], R[:, :, 1], np.nan), ev["true_up"])


def clip_errors(evs: list[dict]) -> np.ndarray:
    """``(N, 4)``: each recording's mean per-frame tilt error (deg) of the gate, ``g_hat_t`` and
    each network alone (:data:`ALONE` order)."""
    p = default_parameters()
    return np.array([[_gate_error(ev, A.VARIANTS[0]),
                      A.clip_error(summarise_frames(A.evidence_of(ev), p).up, ev["true_up"]),
                      *(_gate_error(ev, v) for _, v in ALONE)] for ev in evs])


def row(title: str, evs: list[dict]) -> str:
    e = clip_errors(evs)
    out = f"{title:<44}{len(evs):>6}{np.nanmean(e[:, 0]):>8.2f}"
    for k in range(1, e.shape[1]):
        mean, lo, hi = A.paired_interval(e[:, k] - e[:, 0])
        out += f"{np.nanmean(e[:, k]):>8.2f} {mean:+.2f} [{lo:+.2f}, {hi:+.2f}]"
    return out


def main(argv: list[str] | None = None) -> int:
    args = A.heldout_arguments(argv, __doc__, "frame_likelihood", RESULT)
    t0 = time.time()
    head = (f"{'set':<44}{'clips':>6}{'gate':>8}" + "".join(f"{name:>8} {'- gate [95 % CI]':<22}" for name in
                                                             ("g_hat_t", *(label for label, _ in ALONE))))
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             "Mean over clips of each clip's mean per-frame tilt error (deg), and each alternative's paired "
             "difference from the gate. body net: the body-frame network alone; cam net: the camera-frame network "
             "alone (quarter-turned frame).", "", "## Validation", head]
    for (tag, views), evs in F.validation_sets(args.data, args.cache).items():
        lines.append(row(f"{tag} val, {views}", evs))
    lines += ["", "## Held out (benchmarks/ablation.py's recordings)", head]
    lines += [row(title, evs) for title, evs in A.heldout_recordings(args.data, args.cache, args.max_clips, quarter=True)]
    lines += ["", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
