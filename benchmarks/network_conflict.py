"""Each network's share of per-frame ups in the up model's outlier component (measured, not shipped).

Validation recordings against a file whose two networks disagree throughout; no held-out set
is read.

    python -m benchmarks.network_conflict --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Why: a developer's trial passed VideoPose3D's z-up world output as camera-frame poses. The
camera-frame network read a level camera, the body-frame network the trunk 80 deg away, in
every frame; the up model went with one of them and printed a tight interval with no warning
(decision 0093: the output's posture cannot tell this from a side bend).

Statistic (the up model's own posterior predictive, :mod:`pcnet.stages.up_model`): at the
recording's pose-based up ``g_hat`` (:func:`~pcnet.stages.up_model.summarise_recording`), each
network's reading in frame ``t`` belongs to the outlier component with probability

    r_t = (eps / 4 pi) / p(reading_t | g_hat)

(``p`` the likelihood's mixture for that network: vMF plus ``eps``'s uniform share; the
camera-frame network's with its fall-back ``lambda(psi)``). The model expects a share of
about ``eps`` (0.94 %) outliers per network; the statistic is the larger of the two networks'
mean ``r_t`` over valid frames. A limit fitted as the largest over the up model's validation
recordings (the data ``eps`` was fitted on: benchmarks/fit_up_model.py) would be a warning's;
this script prints that distribution and the trial's case, for a decision to test on held-out
data.

The trial's case: the first 300 frames of the real VideoPose3D Tadasana file, turned by
VideoPose3D's camera_to_world (common/camera.py) with the Human3.6M camera orientation its
run.py renders in-the-wild output with; and the same frames as the lifter gives them.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import SHARED_DATA, print_and_save
from pcnet.stages.up_model import (UpEvidence, UpModelParameters, camera_view_estimate, default_parameters,
                                   log_vmf_mixture, summarise_recording)

RESULT = Path(__file__).resolve().parent / "results" / "network_conflict.txt"
COMMAND = "python -m benchmarks.network_conflict --data ../shared/data"
#: VideoPose3D run.py's Human3.6M camera orientation (w, x, y, z) for in-the-wild renders.
H36M_RENDER_QUATERNION = (0.14070565, -0.15007018, -0.7552408, 0.62232804)


def outlier_shares(e: UpEvidence, g: np.ndarray, p: UpModelParameters) -> tuple[float, float]:
    """``(camera, body)``: each network's mean outlier responsibility ``r_t`` (module docstring)
    over the frames where it gave an up, at the up ``g`` ``(3,)``."""
    kappa = 1.0 / np.radians(p.network_sigma_deg) ** 2
    uniform = np.log(p.outlier_share) - np.log(4 * np.pi)
    G = np.broadcast_to(g, e.camera_up.shape)
    level = e.level_up()
    _, lam = camera_view_estimate(G, level, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        lc = np.logaddexp(np.log1p(-lam) + log_vmf_mixture(np.sum(e.camera_up * G, -1), kappa, p.outlier_share),
                          np.log(lam) + log_vmf_mixture(np.sum(e.camera_up * level, -1), kappa, p.outlier_share))
        lb = log_vmf_mixture(np.sum(e.body_up * G, -1), kappa, p.outlier_share)
    shares = []
    for log_p in (lc, lb):
        ok = np.isfinite(log_p)
        shares.append(float(np.mean(np.exp(uniform - log_p[ok]))) if ok.any() else float("nan"))
    return shares[0], shares[1]


def conflict(ev: dict, p: UpModelParameters) -> tuple[float, float]:
    """One cached recording's :func:`outlier_shares` at its pose-based up."""
    e = A.evidence_of(ev)
    summary = summarise_recording(e, ev["fps"], p)
    return outlier_shares(e.frames(e.valid), summary.up, p)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=SHARED_DATA)
    ap.add_argument("--cache", type=Path, default=A.CACHE)
    args = ap.parse_args(argv)
    t0 = time.time()
    p = default_parameters()
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"Up model parameters as shipped (outlier_share eps = {p.outlier_share:.4f}).", ""]
    rows, worst = [], []
    for (tag, views), evs in F.validation_sets(args.data, args.cache).items():
        stats = [(max(conflict(ev, p)), ev["name"]) for ev in evs]
        values = np.array([s for s, _ in stats])
        top = max(stats)
        worst.append((top[0], f"{tag} {views}", top[1]))
        rows.append(f"{tag + ' ' + views:<16} {len(values):>5} {np.median(values):>8.4f} "
                    f"{np.percentile(values, 95):>8.4f} {values.max():>8.4f}  {top[1]}")
    lines += ["Validation (the up model's fit data): per recording, the larger network's outlier share",
              f"{'set':<16} {'clips':>5} {'median':>8} {'p95':>8} {'max':>8}  where the max is", *rows, ""]
    limit = max(worst)
    lines.append(f"Largest over validation (a limit fitted as decision 0075 fits its limits): {limit[0]:.4f} "
                 f"({limit[1]}, {limit[2]})")
    camera = np.load(args.data / "real" / "yoga_videopose3d" / "export_Abhay_Tadasana.npy",
                     allow_pickle=False)[:300].astype(np.float64)
    w, x, y, z = H36M_RENDER_QUATERNION
    world = Rotation.from_quat([x, y, z, w]).apply(camera.reshape(-1, 3)).reshape(camera.shape)
    lines += ["", "The trial's case (real VideoPose3D Tadasana, first 300 frames; camera, body network shares):"]
    for name, X in (("as the lifter gives it", camera), ("its z-up world output", world)):
        c, b = conflict(A.extract(X.astype(np.float32), 30.0), p)
        lines.append(f"  {name:<26} camera {c:.4f}  body {b:.4f}  -> {max(c, b):.4f}"
                     f"{'  beyond the validation limit' if max(c, b) > limit[0] else ''}")
    lines += ["", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, RESULT)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
