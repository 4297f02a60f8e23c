"""Fit every parameter of the up model (pcnet.stages.up_model) on validation and training data.

    python -m benchmarks.fit_up_model --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Writes ``stages/data/up_model.json`` (each value with its provenance) and
``benchmarks/results/fit_up_model.txt``. No held-out set is read.

Data:
- validation (the shipped weights never trained on it): the Bandai motion-style validation
  split (120 seeded clips, benchmarks/ablation.py's subset rule) and the CMU validation
  subjects, each seen by one static camera with lifter-like noise
  (``make_pairs(..., camera="static", noise=LifterNoise())``) three times: a "paper" view
  (seed 0), a "wide" view (seed 1: pitch up to 45 deg, roll up to 25) and a "paper" view
  rolled by a uniform angle about the optical axis (seed 2, :data:`VAL_VIEWS`). The per-frame network ups come
  from the shipped estimator exactly as ``pcnet run`` runs it (benchmarks/ablation.py's
  ``extract``, same cache);
- training motion capture (Bandai motion-style train split, CMU training subjects, DeepMimic's
  three floor motions in the camera-frame network's mix; clean, world frame, +Y up) for the
  lying posture.

Fits, in order (each uses the ones before):
1. ``camera_fallback_deg``, ``camera_fallback_width_deg`` (psi0, w): per clip, whether the
   camera-frame network's up is nearer the level up of its input frame than the truth (its
   median over frames), logistic regression on the clip's view tilt psi.
2. ``network_sigma_deg``, ``outlier_share``: maximum likelihood of the per-frame tangent
   residuals (each network's error minus its clip's median error; clips the camera-frame
   network reads as level left out) under ``(1 - eps) N2(0, sigma^2 I) + eps / (4 pi)``, one
   ``sigma`` and one ``eps`` for both networks (Nelder-Mead on logs/logits). Each network had
   its own ``sigma`` until decision 0059: the validation likelihood does not tell them apart
   (``python -m benchmarks.parameter_selection``). A growth of the camera-frame network's sigma
   with the view tilt was fitted here until decision 0052 deleted it (decision 0051: it helped
   on no held-out set).
3. ``error_time_s`` (tau): integrated autocorrelation time of those residuals (both networks,
   both axes, residuals beyond 3 sigma clipped), Sokal's window (the smallest lag M with
   M >= 5 tau(M)), in seconds.
4. ``systematic_pitch_deg``, ``systematic_roll_deg``: maximum likelihood of the recording
   summaries' errors ``log_map(g, g_hat)`` under ``N(0, C_L + S)``, S diagonal.
5. ``lying_elevation_deg``: training frames of the shipped weights' mix (with DeepMimic's
   three floor motions, the only bodies on the floor there; decision 0082) whose trunk (pelvis
   -> thorax) is more than 60 deg from vertical are lying; sigma_lie is the RMS of their trunk
   elevation from horizontal, printed too for cuts of 50-70 deg with the clips that pass.
   Their share of frames is printed, not used: ``lying_prior`` is declared (below).
Declared, not fitted: the camera prior, docs/CONVENTIONS.md "handheld" views (pitch
N(0, 12 deg), roll N(0, 10 deg)) and a 5 % share of cameras outside them; and the prior
probability of a lying body, equal to that share. A lying body under a level camera and an
upright one under a camera rolled a quarter turn give the same camera-frame skeleton, so
no likelihood separates them and these two priors decide; the training motion capture's
lying share (0.17 % of frames, no clip lying throughout; printed by this script) samples mocap catalogues, not
the recordings pcnet is used on.
The floor parameters (:data:`FLOOR_PARAMETERS`) are fitted on this model's posterior
afterwards, by ``python -m benchmarks.fit_floor_contacts`` and then ``python -m
benchmarks.fit_floor_power``; this script carries them over.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from benchmarks import ablation as A
from benchmarks.deepmimic_floor_subset import FLOOR_TRAIN
from benchmarks.report import print_and_save, require_folder
from pcnet.models.datasets import load_mocap, select_split
from pcnet.stages.core.conventions import PELVIS, THORAX
from pcnet.stages.core.rotations import axis_rotation
from pcnet.stages.up_model import UpModelParameters, camera_view_estimate, log_map, summarise_recording, systematic_cov

ROOT = Path(__file__).resolve().parents[1]
JSON_OUT = ROOT / "stages" / "data" / "up_model.json"
RESULT = Path(__file__).resolve().parent / "results" / "fit_up_model.txt"
VAL_SETS = (("bandai", "bandai_h36m17.npz"), ("cmu", "cmu_train_h36m17.npz"))
VAL_VIEWS = (("paper", 0), ("wide", 1), ("rolled", 2))
VAL_MAX_CLIPS = 120
#: The up model's floor parameters, fitted after this script on its posterior
#: (benchmarks/fit_floor_contacts.py, then benchmarks/fit_floor_power.py).
FLOOR_PARAMETERS = ("footfall_height_sd_leg", "footfall_posture_power")
TRAIN_SETS = ("bandai_h36m17.npz", "cmu_train_h36m17.npz")
CLIP_SIGMAS = 3.0
DECLARED = {"camera_prior_pitch_deg": 12.0, "camera_prior_roll_deg": 10.0, "camera_prior_outside": 0.05,
            "lying_prior": 0.05}
LYING_WHY = ("declared, equal to camera_prior_outside: a body lying under a level camera and an upright body under a "
             "camera rolled a quarter turn give the same camera-frame skeleton, so only the priors separate them")
DECLARED_WHY = ("declared: the standard deviations of docs/CONVENTIONS.md's 'paper' frontal pitch (N(0, 12) deg) and "
                "'handheld' roll (N(0, 10) deg), before their clipping")
#: The 5 % share has no source in the conventions or in data (a statistician's review found
#: the conventions cited for it): decision 0038 says why it is 5 % and what was known then.
OUTSIDE_WHY = ("declared, from no data: the share of cameras outside those views; 5 % keeps a lying body's and a "
               "quarter-rolled camera's readings both above the intervals' 5 % (decision 0038, chosen with the "
               "held-out Shavasana and DeepMimic outcomes known)")
COMMAND = "python -m benchmarks.fit_up_model --data ../shared/data"


def val_evidence(data: Path, file: str, views: str, seed: int) -> list[dict]:
    """Validation clips seen by one static camera each (at most :data:`VAL_MAX_CLIPS`,
    :func:`benchmarks.ablation.static_camera_clips`), through the networks
    (:func:`benchmarks.ablation.extract`); ``views="rolled"``: a "paper" view turned about the
    optical axis by a uniform roll in [-180, 180) deg per clip (seeded)."""
    rolled = views == "rolled"
    clips = select_split(load_mocap(data / "mocap" / file), "val", "motion-style")
    rng_roll = np.random.default_rng(seed)
    out = []
    for clip, X, R, _ in A.static_camera_clips(clips, VAL_MAX_CLIPS, "paper" if rolled else views, seed):
        up = R[:, :, 1].copy()
        if rolled:
            Q = axis_rotation("z", np.radians(rng_roll.uniform(-180.0, 180.0)))
            X, up = (X.astype(np.float64) @ Q.T).astype(np.float32), up @ Q.T
        ev = A.extract(X, clip.fps)
        ev.update(name=clip.name, true_up=up)
        out.append(ev)
    return out


def tangent_errors(evs, p: UpModelParameters):
    """Per clip: (psi (T,), camera error (T, 2), body error (T, 2), fps, camera reads level (T,) bool)
    over the frames where both networks answered; errors are tangent coordinates at the truth."""
    out = []
    for ev in evs:
        e = A.evidence_of(ev)
        g = ev["true_up"]
        ok = e.valid & np.isfinite(e.camera_up).all(-1) & np.isfinite(e.body_up).all(-1)
        if ok.sum() < 10:
            continue
        level = e.level_up()[ok]
        psi, _ = camera_view_estimate(g[ok], level, p)
        c = e.camera_up[ok]
        reads_level = np.sum(c * level, -1) > np.sum(c * g[ok], -1)
        out.append((psi, log_map(g[ok], c), log_map(g[ok], e.body_up[ok]), ev["fps"], reads_level))
    return out


def fit_fallback(errs) -> tuple[float, float]:
    """Logistic regression of "the camera-frame network's median up is nearer the level up than
    the truth" per clip on the clip's median view tilt (deg): ``(psi0, w)``."""
    psi = np.array([np.degrees(np.median(e[0])) for e in errs])
    y = np.array([np.median(e[4]) >= 0.5 for e in errs], np.float64)

    def nll(theta):
        z = (psi - theta[0]) / np.exp(theta[1])
        return float(np.sum(np.logaddexp(0, -z) * y + np.logaddexp(0, z) * (1 - y)))

    res = minimize(nll, [90.0, np.log(10.0)], method="Nelder-Mead")
    return float(res.x[0]), float(np.exp(res.x[1]))


def residuals(errs):
    rc, rb, rates = [], [], []
    for _, ec, eb, fps, level in errs:
        if np.median(level) >= 0.5:  # a clip the camera-frame network reads as level: its error is the fallback
            continue
        rc.append(ec - np.median(ec, 0))
        rb.append(eb - np.median(eb, 0))
        rates.append(fps)
    return rc, rb, rates


def fit_scatter(rc, rb, tied: bool = False, weights=None) -> tuple[float, float, float, float]:
    """``(sigma_b, sigma_c, eps, log L)`` (deg, deg, share, nats): maximum likelihood of the
    residuals ``rb``, ``rc`` (lists of ``(T, 2)`` tangent residuals, rad, one per clip) under
    ``(1 - eps) N2(0, sigma^2 I) + eps / (4 pi)``, one ``eps`` for both networks; ``tied``: one
    ``sigma`` for both (decision 0059); ``weights``: one per clip, each clip's log-likelihood
    multiplied by it (default 1)."""
    w = np.ones(len(rc)) if weights is None else np.asarray(weights, np.float64)
    frame_w = np.concatenate([np.full(len(r), wi) for r, wi in zip(rc, w)])
    c2 = np.sum(np.concatenate(rc) ** 2, -1)
    b2 = np.sum(np.concatenate(rb) ** 2, -1)
    u = np.log(1 / (4 * np.pi))

    def mixture(r2, var, eps):
        return np.logaddexp(np.log1p(-eps) - np.log(2 * np.pi * var) - 0.5 * r2 / var, np.log(eps) + u)

    def unpack(theta):
        sb = np.exp(theta[0])
        sc = sb if tied else np.exp(theta[1])
        return sb, sc, 1 / (1 + np.exp(-theta[-1]))

    def nll(theta):
        sb, sc, eps = unpack(theta)
        return -float(frame_w @ (mixture(c2, sc ** 2, eps) + mixture(b2, sb ** 2, eps)))

    start = np.log([0.07, 0.02 / 0.98]) if tied else np.log([0.08, 0.06, 0.02 / 0.98])
    res = minimize(nll, start, method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-3, "maxiter": 4000})
    sb, sc, eps = unpack(res.x)
    return float(np.degrees(sb)), float(np.degrees(sc)), float(eps), -float(res.fun)


def fit_time(rc, rb, rates, sigma_deg: float) -> float:
    """Pooled autocorrelation (lags in seconds via each clip's fps) -> tau_int in seconds."""
    clip = np.radians(CLIP_SIGMAS * sigma_deg)
    max_lag_s = 10.0
    by_fps: dict[float, list[np.ndarray]] = {}
    for r1, r2, fps in zip(rc, rb, rates):
        for r in (r1, r2):
            for axis in range(2):
                x = np.clip(r[:, axis], -clip, clip)
                by_fps.setdefault(fps, []).append(x - x.mean())
    taus, weights = [], []
    for fps, series in by_fps.items():
        L = int(max_lag_s * fps)
        num = np.zeros(L + 1)
        den = np.zeros(L + 1)
        for x in series:
            n = len(x)
            for k in range(min(L, n - 1) + 1):
                num[k] += np.dot(x[: n - k], x[k:])
                den[k] += n - k
        acf = (num / np.maximum(den, 1)) / (num[0] / den[0])
        tau = 1.0
        for M in range(1, L + 1):
            tau = 1.0 + 2.0 * acf[1:M + 1].sum()
            if M >= 5 * tau:
                break
        taus.append(tau / fps)
        weights.append(sum(len(x) for x in series))
    return float(np.average(taus, weights=weights))


def summaries(evs, p: UpModelParameters):
    """``(recording, summary, true up)`` for each recording of ``evs`` with two valid frames at
    least: the up model's summary of its poses under ``p`` (:func:`summarise_recording`) and
    its true up ``(3,)`` at the first valid frame."""
    for ev in evs:
        e = A.evidence_of(ev)
        if e.valid.sum() >= 2:
            yield ev, summarise_recording(e, ev["fps"], p), ev["true_up"][np.flatnonzero(e.valid)[0]]


def summary_errors(evs, p: UpModelParameters) -> tuple[np.ndarray, np.ndarray]:
    """Per recording of :func:`summaries`: the summary's error ``log_map(g, g_hat)`` ``(N, 2)``
    rad and its ``C_L`` ``(N, 2, 2)`` under ``p``."""
    out = [(log_map(g, s.up), s.cov) for _, s, g in summaries(evs, p)]
    return np.array([e for e, _ in out]), np.array([c for _, c in out])


def fit_systematic(es: np.ndarray, covs: np.ndarray, isotropic: bool = False) -> tuple[float, float, float]:
    """``(s_pitch, s_roll, log L)`` (deg, deg, nats): maximum likelihood of the summaries' errors
    ``es`` under ``N(0, C_L + S)`` (:func:`summary_errors`), ``S`` diagonal, or ``s^2 I`` where
    ``isotropic`` (decision 0059)."""

    def nll(theta):
        S = np.diag(np.exp(2 * (np.repeat(theta, 2) if isotropic else theta)))
        C = covs + S
        inv = np.linalg.inv(C)
        return float(np.sum(0.5 * np.einsum("ni,nij,nj->n", es, inv, es) + 0.5 * np.log(np.linalg.det(C))
                            + np.log(2 * np.pi)))

    start = np.log(np.radians([2.5])) if isotropic else np.log(np.radians([3.0, 1.5]))
    res = minimize(nll, start, method="Nelder-Mead")
    s = np.degrees(np.exp(np.repeat(res.x, 2) if isotropic else res.x))
    return float(s[0]), float(s[1]), -float(res.fun)


#: The training mix's floor motions (the camera-frame network's ``whole_clips``), the only
#: training frames of a body on the floor (decision 0082).
FLOOR_FILE = "deepmimic_h36m17.npz"
#: Cuts (deg of trunk from vertical) whose ``sigma_lie`` is printed beside the definition's
#: (:data:`benchmarks.ablation.LYING_TRUNK_DEG`, plus or minus 10 deg; decision 0082).
LYING_CUTS_DEG = (50.0, 55.0, 60.0, 65.0, 70.0)


def training_trunk_angles(data: Path) -> list[tuple[str, np.ndarray]]:
    """Per training clip of the shipped weights' mix (Bandai motion-style train, CMU training
    subjects, DeepMimic's floor motions :data:`FLOOR_TRAIN`), ``(name, angle)``: each frame's
    trunk (pelvis -> thorax) angle from the world's +Y, degrees (frames without a trunk left
    out)."""
    clips = [c for file in TRAIN_SETS for c in select_split(load_mocap(data / "mocap" / file), "train", "motion-style")]
    clips += [c for c in load_mocap(data / "mocap" / FLOOR_FILE) if c.name in FLOOR_TRAIN]
    out = []
    for clip in clips:
        t = clip.joints[:, THORAX] - clip.joints[:, PELVIS]
        n_t = np.linalg.norm(t, axis=-1)
        ok = np.isfinite(n_t) & (n_t > 0)
        out.append((clip.name, np.degrees(np.arccos(np.clip(t[ok, 1] / n_t[ok], -1, 1)))))
    return out


def fit_lying(angles: list[tuple[str, np.ndarray]], cut_deg: float = A.LYING_TRUNK_DEG) -> tuple[float, float, int, int]:
    """``(share, sigma_lie, k, n)``: of the ``n`` training frames of :func:`training_trunk_angles`
    ``angles``, the ``k`` whose trunk is more than ``cut_deg`` from vertical are lying; their
    share, and the RMS of their trunk elevation from the horizontal (deg)."""
    ang = np.concatenate([a for _, a in angles])
    elev = 90.0 - ang[ang > cut_deg]
    k = len(elev)
    return k / len(ang), float(np.sqrt(np.mean(np.square(elev)))) if k else float("nan"), k, len(ang)


def params_from(values: dict, provenance: dict) -> UpModelParameters:
    return UpModelParameters(**values, provenance=provenance)


def validation_sets(data: Path, cache: Path) -> dict[tuple[str, str], list[dict]]:
    """Every validation set of :data:`VAL_SETS` x :data:`VAL_VIEWS` (:func:`val_evidence`),
    cached (:func:`benchmarks.ablation.cached`), keyed ``(tag, views)``."""
    return {(tag, views): A.cached(cache, f"val_{tag}_{views}_{seed}",
                                   lambda f=file, v=views, s=seed: val_evidence(data, f, v, s))
            for tag, file in VAL_SETS for views, seed in VAL_VIEWS}


def validation_sweeps(cache: Path, val: dict[tuple[str, str], list[dict]]) -> list[dict]:
    """The validation recordings with the camera pitch sweeping (:func:`benchmarks.ablation.sweep_evidence`
    of the "paper" views of :func:`validation_sets` ``val``), cached under ``val_sweep``."""
    return A.cached(cache, "val_sweep", lambda: A.sweep_evidence([val["bandai", "paper"], val["cmu", "paper"]]))


def fit_arguments(argv, doc: str, script: str, result: Path, writes_json: bool = True) -> argparse.Namespace:
    """The command line of a fit on the validation sets (this script's and the up model's
    later fits): ``--data``, ``--cache``, ``--json`` (the up model's parameters file, where the
    fit writes into it) and ``--out``; exits with one line where ``--data`` lacks the mocap."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--data", type=Path, default=A.DEFAULT)
    ap.add_argument("--cache", type=Path, default=A.CACHE)
    if writes_json:
        ap.add_argument("--json", type=Path, default=JSON_OUT)
    ap.add_argument("--out", type=Path, default=result)
    args = ap.parse_args(argv)
    require_folder(args.data, script)
    return args


def main(argv=None) -> int:
    args = fit_arguments(argv, __doc__, "fit_up_model", RESULT)
    t0 = time.time()
    evs = validation_sets(args.data, args.cache)
    all_evs = [e for v in evs.values() for e in v]
    n_frames = sum(len(e["J"]) for e in all_evs)
    split = (f"validation: Bandai motion-style val ({len(evs['bandai', 'paper'])} clips) + CMU val subjects "
             f"({len(evs['cmu', 'paper'])} clips), 'paper', 'wide' and fully rolled static views, lifter noise, "
             f"{n_frames} frames")
    values = {"camera_fallback_deg": 90.0, "camera_fallback_width_deg": 10.0, "network_sigma_deg": 3.0,
              "outlier_share": 0.01, "error_time_s": 1.0, "systematic_pitch_deg": 3.0, "systematic_roll_deg": 1.5,
              "lying_elevation_deg": 10.0, **DECLARED}
    prov = {k: DECLARED_WHY for k in DECLARED}
    prov["camera_prior_outside"], prov["lying_prior"] = OUTSIDE_WHY, LYING_WHY
    # The floor-contact parameters are fitted afterwards, on this model's posterior
    # (benchmarks/fit_floor_contacts.py): carried over as they are.
    shipped = json.loads(args.json.read_text())["parameters"] if args.json.is_file() else {}
    for k in FLOOR_PARAMETERS:
        values[k], prov[k] = shipped[k]["value"], shipped[k]["provenance"]
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", "", f"Data: {split}.", ""]

    errs = tangent_errors(all_evs, params_from(values, prov))
    values["camera_fallback_deg"], values["camera_fallback_width_deg"] = fit_fallback(errs)
    prov["camera_fallback_deg"] = prov["camera_fallback_width_deg"] = f"per-clip logistic regression, {split}"
    rc, rb, rates = residuals(errs)
    sigma, _, eps, _ = fit_scatter(rc, rb, tied=True)
    values.update(network_sigma_deg=sigma, outlier_share=eps)
    for k in ("network_sigma_deg", "outlier_share"):
        prov[k] = f"maximum likelihood of per-frame residuals, both networks, {split}"
    values["error_time_s"] = fit_time(rc, rb, rates, sigma)
    prov["error_time_s"] = f"integrated autocorrelation time (Sokal window) of per-frame residuals, {split}"
    sp, sr, _ = fit_systematic(*summary_errors(all_evs, params_from(values, prov)))
    values.update(systematic_pitch_deg=sp, systematic_roll_deg=sr)
    prov["systematic_pitch_deg"] = prov["systematic_roll_deg"] = f"maximum likelihood of recording summaries' errors, {split}"
    angles = training_trunk_angles(args.data)
    share, sig, k, n = fit_lying(angles)
    by_cut = {c: fit_lying(angles, c) for c in LYING_CUTS_DEG}
    values.update(lying_elevation_deg=sig)
    prov["lying_elevation_deg"] = (f"training mocap of the shipped weights' mix (Bandai motion-style train, CMU "
                                   f"training subjects, DeepMimic's three floor motions): RMS trunk elevation of the "
                                   f"{k} of {n} frames lying (trunk > {A.LYING_TRUNK_DEG:g} deg from vertical; "
                                   f"decision 0082: 50-70 deg cuts give " + " / ".join(
                                       f"{fit[1]:.1f}" for fit in by_cut.values()) + " deg)")
    prov["lying_prior"] = (f"{LYING_WHY}; the training mocap's share of lying frames, {share:.5f}, does not sample "
                           f"users' recordings (no training clip lies throughout)")
    lying_lines = [f"lying frames (trunk > {A.LYING_TRUNK_DEG:g} deg from vertical) per training clip: "
                   + ", ".join(f"{name} {int(np.sum(a > A.LYING_TRUNK_DEG))}" for name, a in angles
                               if np.any(a > A.LYING_TRUNK_DEG)),
                   "sigma_lie by the cut (deg from vertical -> frames, sigma_lie deg): "
                   + ", ".join(f"{c:g} -> {fit[2]}, {fit[1]:.2f}" for c, fit in by_cut.items())]
    params = params_from(values, prov)

    doc = {"model": "pcnet.stages.up_model (docs/up_model.md)", "command": COMMAND,
           "parameters": {k: {"value": round(v, 6), "provenance": prov[k]} for k, v in values.items()}}
    args.json.write_text(json.dumps(doc, indent=2) + "\n")
    UpModelParameters.load(args.json.read_text())  # the written file parses
    width = max(map(len, values))
    lines += [f"{k:<{width}}  {v:10.4f}   {prov[k]}" for k, v in values.items()]
    lines += ["", *lying_lines, "", f"systematic error S, standard deviations (deg, pitch and roll): {np.degrees(np.sqrt(np.diag(systematic_cov(params))))}",
              f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
