"""Is balance evidence worth adding to sequence mode? A measured experiment, not shipped code.

    python -m benchmarks.balance_evidence --data ../shared/data [--max-clips 200]

The idea (issue "Generalise honestly", section 2): over a recording on the floor, the body's
centre of mass lies above its support on average, so the direction from the supporting
ankles to the centre of mass is an estimate of up that no pose network's training bias
touches. Here: segment masses and centre-of-mass positions from de Leva (1996), "Adjustments
to Zatsiorsky-Seluyanov's segment inertia parameters", J. Biomech. 29(9): 1223-1230,
Table 4 (male; hand and foot lumped at the wrist and ankle); support = the ankles lowest
along the current up (within 0.05 leg lengths) in frames where an ankle is the body's lowest
point, moved forward by ``--cop-offset`` leg lengths (the centre of pressure of quiet
standing lies a few cm in front of the ankle joint); up = robust mean direction of the
per-frame ankle->centre-of-mass directions, 3 iterations from the network's sequence up.

Each clip is one static camera (the paper's view distribution, per clip) with lifter-like
noise (models/lifter_noise.py). Rows: Bandai and CMU validation (where a weight would be
chosen), Bandai and CMU test, DeepMimic, then the real calibrated cameras of pose2sim_gravity
(real MediaPipe output, a standing T-pose); columns: sequence-up tilt error of the shipped
pair (robust mean of its per-frame ups), of the balance estimate, and of their normalised
weighted mean with the balance weight given.

    python -m benchmarks.balance_evidence --data ../shared/data --correlation

Balance as a term of the up model (docs/up_model.md) would add information only where its
error is not the networks' error. ``--correlation`` measures that on the up model's validation
recordings (``benchmarks/fit_up_model.py``: 393 static recordings, lifter noise; no held-out
set is read): per recording, the error of the up model's summary of the poses ``g_hat``
(:func:`pcnet.stages.up_model.summarise_recording`) and of the balance estimate started from it,
both as tangent coordinates (pitch, roll) at the true up; per axis their standard deviations, biases
and correlation, and the weight of balance in the best linear unbiased combination of the two
(``w = (s_n^2 - c) / (s_n^2 + s_b^2 - 2 c)``, ``c`` the covariance; Aitken 1935) with that
combination's RMS error. Writes benchmarks/results/balance_correlation.txt.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA, print_and_save, require_folder
from pcnet.models.datasets import load_mocap, make_pairs, select_split
from pcnet.models.lifter_noise import LifterNoise
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.core.rotations import angle_between, normalize
from pcnet.stages.spherical import robust_mean_direction

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "balance_evidence.txt"
CORRELATION_RESULT = RESULT.with_name("balance_correlation.txt")
#: (mass fraction, proximal joint, distal joint, centre of mass as a fraction from proximal),
#: H36M-17 indices; de Leva 1996 Table 4, male. Head+neck: vertex -> cervicale (H36M head ->
#: thorax); trunk: cervicale -> mid-hip (thorax -> pelvis).
SEGMENTS = ((0.0694, 10, 8, 0.5002), (0.4346, 8, 0, 0.4486),
            (0.0271, 11, 12, 0.5772), (0.0271, 14, 15, 0.5772),
            (0.0162, 12, 13, 0.4574), (0.0162, 15, 16, 0.4574),
            (0.0061, 13, 13, 0.0), (0.0061, 16, 16, 0.0),
            (0.1416, 4, 5, 0.4095), (0.1416, 1, 2, 0.4095),
            (0.0433, 5, 6, 0.4459), (0.0433, 2, 3, 0.4459),
            (0.0137, 6, 6, 0.0), (0.0137, 3, 3, 0.0))
SETS = (("Bandai val", "bandai_h36m17.npz", "val"), ("CMU val", "cmu_train_h36m17.npz", "val"),
        ("Bandai test", "bandai_h36m17.npz", "test"), ("CMU test", "cmu_train_h36m17.npz", "test"),
        ("DeepMimic all", "deepmimic_h36m17.npz", "all"))
WEIGHTS = (0.2, 0.35, 0.5)


def centre_of_mass(J: np.ndarray) -> np.ndarray:
    """``(T, 17, 3)`` H36M-17 joints -> ``(T, 3)`` whole-body centre of mass (same frame, unit)."""
    c = sum(f * (J[:, p] + r * (J[:, d] - J[:, p])) for f, p, d, r in SEGMENTS)
    return c / sum(f for f, *_ in SEGMENTS)


def balance_up(J: np.ndarray, u0: np.ndarray, cop_offset: float, tol: float = 0.05) -> np.ndarray | None:
    """Up from support -> centre of mass directions (module docstring); ``None`` if < 10 frames stand."""
    leg = np.nanmedian(np.linalg.norm(J[:, 1] - J[:, 2], axis=-1) + np.linalg.norm(J[:, 2] - J[:, 3], axis=-1))
    com, u = centre_of_mass(J), u0
    for _ in range(3):
        h = J @ u
        low = h.min(1)
        ankle_h = h[:, [3, 6]]
        support = (ankle_h <= low[:, None] + tol * leg) & (ankle_h.min(1) <= low + tol * leg)[:, None]
        n = support.sum(1)
        stand = n > 0
        if stand.sum() < 10:
            return None
        S = (J[:, [3, 6]] * support[..., None]).sum(1) / np.maximum(n, 1)[:, None]
        anterior = normalize(np.cross(u, normalize(J[:, 1] - J[:, 4])))
        d = normalize(com - (S + cop_offset * leg * anterior))
        u, _ = robust_mean_direction(d[stand], np.ones(stand.sum()), init=u)
    return u


def real_camera_rows(data: Path, cop_offset: float) -> list[str]:
    """The same two estimates on the real calibrated cameras (pose2sim_gravity: MediaPipe, a
    standing T-pose, 11 frames per camera, read as ``pcnet run --lifter mediapipe`` reads it):
    tilt error (deg) against the lab's gravity per camera."""
    from benchmarks.gravity_benchmark import load_camera

    lines = ["", "real calibrated cameras (pose2sim_gravity, MediaPipe, standing T-pose), tilt error, deg",
             "| camera | pcnet sequence | balance |", "|---|---|---|"]
    for path in sorted((data / "real" / "pose2sim_gravity").glob("statictrial_cam*.npz")):
        J, truth, fps = load_camera(path)
        estimate = make_estimator("pcnet")(J, fps)
        ok = estimate.valid
        u_net, _ = robust_mean_direction(estimate.rotation[ok, :, 1], np.ones(ok.sum()))
        u_bal = balance_up(J, u_net, cop_offset)
        cells = [np.nan if u is None else np.degrees(angle_between(u, truth)) for u in (u_net, u_bal)]
        lines.append(f"| {path.stem.replace('statictrial_', '')} | {cells[0]:.1f} | {cells[1]:.1f} |")
    return lines


def correlation_lines(data: Path, cache: Path, cop_offset: float) -> list[str]:
    """The ``--correlation`` table (module docstring) on the up model's validation recordings."""
    from benchmarks import fit_up_model as F
    from pcnet.stages.up_model import default_parameters, log_map

    e_net, e_bal, left_out = [], [], 0
    for evs in F.validation_sets(data, cache).values():
        for ev, s, g in F.summaries(evs, default_parameters()):
            b = balance_up(ev["J"].astype(np.float64), s.up, cop_offset)
            if b is None:
                left_out += 1
                continue
            e_net.append(np.degrees(log_map(g, s.up)))
            e_bal.append(np.degrees(log_map(g, b)))
    en, eb = np.array(e_net), np.array(e_bal)
    lines = [f"python -m benchmarks.balance_evidence --correlation --cop-offset {cop_offset}",
             f"validation recordings of benchmarks/fit_up_model.py: {len(en)} ({left_out} without 10 standing frames "
             "left out); errors at the true up, deg",
             "| axis | up model's g_hat: sd, bias | balance: sd, bias | correlation | balance's BLUE weight | "
             "RMS: g_hat, combined |", "|---|---|---|---|---|---|"]
    for axis, name in enumerate(("pitch", "roll")):
        C = np.cov(en[:, axis], eb[:, axis])
        w = (C[0, 0] - C[0, 1]) / (C[0, 0] + C[1, 1] - 2 * C[0, 1])
        combined = (1 - w) * en[:, axis] + w * eb[:, axis]
        rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
        lines.append(f"| {name} | {np.sqrt(C[0, 0]):.2f}, {en[:, axis].mean():+.2f} | {np.sqrt(C[1, 1]):.2f}, "
                     f"{eb[:, axis].mean():+.2f} | {C[0, 1] / np.sqrt(C[0, 0] * C[1, 1]):+.2f} | {w:+.2f} | "
                     f"{rms(en[:, axis]):.2f}, {rms(combined):.2f} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--max-clips", type=int, default=200, help="first N clips of each set")
    ap.add_argument("--cop-offset", type=float, default=0.06, help="leg lengths (0.06 ~ 5 cm)")
    ap.add_argument("--correlation", action="store_true",
                    help="balance's error against the up model's on the validation recordings (module docstring)")
    ap.add_argument("--cache", type=Path, default=None,
                    help="the ablation's evidence cache (--correlation; default: the ablation's)")
    args = ap.parse_args()
    require_folder(args.data, "balance_evidence")
    t0 = time.time()
    if args.correlation:
        from benchmarks.ablation import CACHE
        print_and_save(correlation_lines(args.data, args.cache or CACHE, args.cop_offset)
                       + [f"wall time {time.time() - t0:.0f} s"], CORRELATION_RESULT)
        return
    head = "| set | clips | pcnet sequence | balance | " + " | ".join(f"mix {w}" for w in WEIGHTS) + " |"
    lines = [f"python -m benchmarks.balance_evidence --max-clips {args.max_clips} --cop-offset {args.cop_offset}",
             "sequence-up tilt error, deg, mean / median over clips (static camera per clip, lifter-like noise)",
             head, "|" + "---|" * (head.count("|") - 1)]
    for label, file, split in SETS:
        clips = select_split(load_mocap(args.data / "mocap" / file), split, "motion-style")[: args.max_clips]
        pairs = make_pairs(clips, views="paper", seed=0, camera="per-clip", noise=LifterNoise())
        rows = []
        for i, clip in enumerate(clips):
            sel = np.flatnonzero(pairs.clip == i)
            estimate = make_estimator("pcnet")(pairs.inputs[sel], clip.fps)
            R, ok = estimate.rotation, estimate.valid & np.isfinite(estimate.rotation[:, :, 1]).all(-1)
            u_net, _ = robust_mean_direction(R[ok, :, 1], np.ones(ok.sum()))
            u_bal = balance_up(pairs.inputs[sel].astype(np.float64), u_net, args.cop_offset)
            truth = pairs.R[sel[0]][:, 1]
            ups = [u_net, u_bal] + [None if u_bal is None else normalize((1 - w) * u_net + w * u_bal) for w in WEIGHTS]
            rows.append([np.nan if u is None else np.degrees(angle_between(u, truth)) for u in ups])
        r = np.array(rows)
        cells = [f"{np.nanmean(c):.2f} / {np.nanmedian(c):.2f}" for c in r.T]
        lines.append(f"| {label} | {len(clips)} ({np.isfinite(r[:, 1]).sum()} standing) | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    lines += real_camera_rows(args.data, args.cop_offset)
    lines.append(f"wall time {time.time() - t0:.0f} s")
    RESULT.write_text("\n".join(lines) + "\n")
    print(f"wrote {RESULT}")


if __name__ == "__main__":
    main()
