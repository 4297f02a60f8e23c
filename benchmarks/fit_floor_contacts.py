"""Fit the up model's floor-contact parameters (pcnet.stages.ground_plane) on validation data.

    python -m benchmarks.fit_floor_contacts --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Run after ``python -m benchmarks.fit_up_model`` (the floor is fused with that model's
posterior). Updates the footfall error parameter in ``stages/data/up_model.json`` (with
its provenance; the other parameters are left as they are) and writes
``benchmarks/results/fit_floor_contacts.txt``. No held-out set is read.

Data: the validation recordings of benchmarks/fit_up_model.py (Bandai motion-style val, CMU
val subjects; "paper", "wide" and rolled static cameras; lifter noise; the shipped networks'
cached ups), each with its pelvis path kept in the camera frame, as a depth sensor measures
it (:func:`benchmarks.ablation.camera_root_path`).

Fit: the error model of the footfalls' heights along the TRUE up (contacts detected along it,
:func:`pcnet.stages.ground_plane.detect_contacts`: each frame's lower ankle): per recording,
``footfall_height_sd_leg`` (sigma_f) is the pooled standard deviation of the footfall heights,
in leg lengths, about their support level's median with both ankles together, as the floor's
likelihood measures each footfall (levels by :func:`pcnet.stages.ground_plane.support_levels`
at sigma_f itself, iterated to a fixed point; decision 0094: until then it was pooled within
each ankle, which left the spread between the ankles out). (Until decision 0065 a grid also chose the contact definition's
height band and speed criterion by the validation tilt error; both went. Until decision 0091 a
per-ankle offset ``s_o`` was fitted from the between-ankle mean differences by the method of
moments; switched off on held-out data it moved nothing, and went.) Printed: the mean
tilt error over the validation recordings of the up the shipped chain gives (the up model's
upright posterior fused with the floor, :func:`pcnet.stages.ground_plane.ground_plane_up`;
recordings the up model reads as lying keep their posterior's up).

Checks under the shipped parameters (nothing is fitted on them):
- two support levels: the CMU training subjects' clips whose footfalls (along the true up, on
  the motion capture itself) lie on levels more than :data:`RAISED_M` apart (a stool, steps;
  :func:`raised_recordings`), where a plane through every footfall would tilt;
- interval coverage on validation: how often the fused posterior's 95 % pitch and roll
  intervals, and the up model's own around the fused up, hold the truth (upright readings);
- a monocular run's path: the validation recordings with the pelvis path recovered from
  simulated 2D keypoints (:func:`benchmarks.ablation.keypoint_root_path`) instead of the
  measured one.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from pcnet.models.datasets import load_mocap, select_split
from pcnet.stages.core.conventions import PELVIS
from pcnet.stages.core.rotations import axis_rotation, camera_pitch_roll
from pcnet.stages.ground_plane import detect_contacts, footfalls, ground_plane_up, leg_length, support_levels
from pcnet.stages.up_model import (Z95, StaticPosterior, UpModelParameters, default_parameters, static_posterior,
                                   summarise_recording)

RESULT = Path(__file__).resolve().parent / "results" / "fit_floor_contacts.txt"
COMMAND = "python -m benchmarks.fit_floor_contacts --data ../shared/data"
#: Footfalls this far apart in height (metres, along the true up) are on two support levels.
RAISED_M = 0.2


@dataclass(frozen=True)
class Recording:
    """One validation recording: its set (``"bandai paper"``, ...), the clip's name, joints ``(T, 17, 3)``
    (camera frame, metres, the pelvis path kept), valid frames ``ok`` ``(T,)``, the
    true up ``(3,)``, the up model's posterior ``post`` and ``joints_2d``, the joints with the
    path a monocular run recovers from 2D keypoints instead (:func:`benchmarks.ablation.keypoint_root_path`;
    ``None`` where not made)."""

    set: str
    name: str
    joints: np.ndarray
    ok: np.ndarray
    true_up: np.ndarray
    post: StaticPosterior
    joints_2d: np.ndarray | None = None


def _recording(tag: str, ev: dict, joints: np.ndarray, true_up: np.ndarray,
               joints_2d: np.ndarray | None = None) -> Recording:
    """One recording through the shipped chain's per-frame step and the up model; ``joints``
    ``(T, 17, 3)`` with the pelvis path kept, ``true_up`` ``(T, 3)``."""
    R, ok = A.shipped_rotations(ev)
    p = default_parameters()
    post = static_posterior(summarise_recording(A.evidence_of(ev).frames(ok), ev["fps"], p), p)
    return Recording(tag, ev["name"], joints, ok, true_up[np.flatnonzero(ok)[0]], post, joints_2d)


def recordings(data: Path, cache: Path) -> list[Recording]:
    """Every validation recording of :func:`benchmarks.fit_up_model.val_evidence` (cached)
    with its pelvis path kept (:class:`Recording`)."""
    val = F.validation_sets(data, cache)
    out = []
    for tag, file in F.VAL_SETS:
        clips = select_split(load_mocap(data / "mocap" / file), "val", "motion-style")
        for views, seed in F.VAL_VIEWS:
            rolled = views == "rolled"
            rng_roll = np.random.default_rng(seed)  # the rolls of val_evidence, drawn in the same order
            rng_2d = np.random.default_rng(seed)
            cached = {ev["name"]: ev for ev in val[tag, views]}
            for clip, X, R, frames in A.static_camera_clips(clips, F.VAL_MAX_CLIPS, "paper" if rolled else views, seed):
                if rolled:
                    Q = axis_rotation("z", np.radians(rng_roll.uniform(-180.0, 180.0)))
                    X, R = (X.astype(np.float64) @ Q.T).astype(np.float32), Q @ R
                ev = cached[clip.name]
                if not np.array_equal(X, ev["J"]):
                    raise SystemExit(f"{clip.name}: the cached validation inputs differ from make_pairs' (stale cache?)")
                X = X.astype(np.float64)
                from_2d = A.keypoint_root_path(clip, frames, R, X, ev["fps"], rng_2d)
                out.append(_recording(f"{tag} {views}", ev, X + A.camera_root_path(clip, frames, R)[:, None], R[:, :, 1],
                                      X - X[:, PELVIS:PELVIS + 1] + from_2d[:, None]))
    return out


def footfall_height_range(clip) -> float:
    """Metres between the highest and the lowest footfall of a motion-capture clip (world
    frame, +Y up; contacts under the shipped definition along the true up)."""
    J = clip.joints.astype(np.float64)
    c = detect_contacts(J, np.ones(len(J), bool), np.array([0.0, 1.0, 0.0]))
    return float(np.ptp(footfalls(c)[0][:, 1])) if len(c.points) else 0.0


def raised_recordings(data: Path, cache: Path) -> list[Recording]:
    """The check set (not fitted on): the CMU training subjects' clips in which the feet rest
    on a raised surface for part of the take (:func:`footfall_height_range` over
    :data:`RAISED_M`), one "paper" and one
    "wide" static camera each, lifter noise, pelvis path kept. The networks trained on these
    clips, so their ups are better than on new data; what this set checks is the floor's
    geometry: two support levels."""
    clips = [c for c in select_split(load_mocap(data / "mocap" / "cmu_train_h36m17.npz"), "train", "motion-style")
             if footfall_height_range(c) > RAISED_M]
    out = []
    for views, seed in (("paper", 0), ("wide", 1)):
        def build(v=views, s=seed):
            evs = []
            for clip, X, R, _ in A.static_camera_clips(clips, len(clips), v, s):
                ev = A.extract(X, clip.fps)
                ev.update(name=clip.name, true_up=R[:, :, 1].copy())
                evs.append(ev)
            return evs
        cached = {ev["name"]: ev for ev in A.cached(cache, f"raised_cmu_train_{views}_{seed}", build)}
        for clip, X, R, frames in A.static_camera_clips(clips, len(clips), views, seed):
            ev = cached[clip.name]
            if not np.array_equal(X, ev["J"]):
                raise SystemExit(f"{clip.name}: the cached inputs differ from make_pairs' (stale cache?)")
            root = A.camera_root_path(clip, frames, R)
            out.append(_recording(f"raised {views}", ev, X.astype(np.float64) + root[:, None], R[:, :, 1]))
    return out


def level_residuals(recs: list[Recording], scale: float) -> list[tuple[np.ndarray, int]]:
    """Per recording with a footfall: each footfall's height along the true up about its
    support level's median (leg lengths; levels by :func:`pcnet.stages.ground_plane.support_levels`
    at ``scale``, both ankles pooled), as the floor's likelihood measures it, and the number of
    levels."""
    out = []
    for r in recs:
        leg = leg_length(r.joints, r.ok)
        c = detect_contacts(r.joints, r.ok, r.true_up)
        if not len(c.points):
            continue
        h = footfalls(c)[0] @ r.true_up / leg
        level = support_levels(h, scale)
        n_levels = int(level.max()) + 1
        out.append((h - np.array([np.median(h[level == k]) for k in range(n_levels)])[level], n_levels))
    return out


def error_model(recs: list[Recording], start: float) -> tuple[float, int]:
    """``(sigma_f, footfalls)``: the module docstring's fit, the pooled standard deviation (leg
    lengths) of the footfall heights about their levels' medians, each level's median costing
    one degree of freedom, iterated from ``start`` until the levels it assigns stop changing
    it; and the footfalls it counts."""
    sigma = start
    for _ in range(50):
        res = level_residuals(recs, sigma)
        df = sum(len(r) - n_levels for r, n_levels in res)
        new = float(np.sqrt(sum(float(np.sum(r ** 2)) for r, _ in res) / max(df, 1)))
        if abs(new - sigma) <= 1e-9:
            break
        sigma = new
    return new, int(sum(len(r) for r, _ in res))


def tilt_errors(recs: list[Recording], p: UpModelParameters, from_2d: bool = False) -> np.ndarray:
    """Per recording, the tilt error (deg) of the chain's up under ``p`` (the floor fused with
    an upright posterior; ``from_2d``: with the path recovered from 2D keypoints)."""
    err = []
    for r in recs:
        up = r.post.up
        if r.post.posture == "upright":
            up = ground_plane_up(r.joints_2d if from_2d else r.joints, r.ok, up, r.post.upright_cov(), p).up
        err.append(float(A.deg(up, r.true_up)))
    return np.array(err)


def coverage_line(recs: list[Recording], p: UpModelParameters) -> str:
    """How often the fused and the up model's 95 % pitch and roll intervals hold the truth
    (both axes), over the recordings read upright whose floor moved the up."""
    n, fused_hits, model_hits = 0, 0, 0
    for r in recs:
        if r.post.posture != "upright":
            continue
        out = ground_plane_up(r.joints, r.ok, r.post.up, r.post.upright_cov(), p)
        if not out.info["used"]:
            continue
        err = np.degrees(np.array(camera_pitch_roll(out.up)) - np.array(camera_pitch_roll(r.true_up)))
        err[1] = (err[1] + 180.0) % 360.0 - 180.0
        n += 1
        fused_hits += bool(np.all(np.abs(err) <= Z95 * np.degrees(np.sqrt(np.diag(out.fit.cov)))))
        model_hits += bool(np.all(np.abs(err) <= (r.post.pitch_half_deg, r.post.roll_half_deg)))
    return (f"95 % interval coverage on validation, both axes, {n} upright recordings whose floor moved the up: "
            f"fused posterior {100 * fused_hits / max(n, 1):.1f} %, the up model's intervals (shipped) "
            f"{100 * model_hits / max(n, 1):.1f} %")


def main(argv=None) -> int:
    args = F.fit_arguments(argv, __doc__, "fit_floor_contacts", RESULT)
    t0 = time.time()
    recs = recordings(args.data, args.cache)
    base = default_parameters()
    no_floor = np.array([float(A.deg(r.post.up, r.true_up)) for r in recs])
    sets = sorted({r.set for r in recs})
    counts = ", ".join(f"{s} {sum(r.set == s for r in recs)}" for s in sets)
    lines = [__doc__.split("\n")[0], "", f"    {COMMAND}", "",
             f"Validation: {len(recs)} recordings ({counts}), "
             "pelvis path kept (measured root), lifter noise.", ""]
    sigma_f, n = error_model(recs, base.footfall_height_sd_leg)
    fitted = replace(base, footfall_height_sd_leg=sigma_f)
    err = tilt_errors(recs, fitted)
    split = (f"validation ({len(recs)} recordings: Bandai motion-style val + CMU val subjects, paper/wide/rolled static "
             f"cameras, lifter noise, pelvis path kept)")
    prov = {
        "footfall_height_sd_leg": f"pooled std of {n} footfall heights along the true up about their support level's median, "
                                  f"both ankles together, {split}",
    }
    doc = json.loads(args.json.read_text())
    doc["parameters"].pop("ankle_offset_leg", None)  # deleted by decision 0091
    for k in prov:
        doc["parameters"][k] = {"value": round(float(getattr(fitted, k)), 6), "provenance": f"{prov[k]}; {COMMAND}"}
    args.json.write_text(json.dumps(doc, indent=2) + "\n")
    UpModelParameters.load(args.json.read_text())  # the written file parses
    lines += ["Shipped:"]
    lines += [f"  {k} = {getattr(fitted, k):.4f}" for k in prov]
    err_2d = tilt_errors(recs, fitted, from_2d=True)
    lines += ["", f"{'validation set':<16}{'recordings':>11}{'up model alone':>16}{'with the floor':>16}"
                  f"{'path from 2D':>14}"]
    for s in sets:
        m = np.array([r.set == s for r in recs])
        lines.append(f"{s:<16}{m.sum():>11}{no_floor[m].mean():>16.2f}{err[m].mean():>16.2f}{err_2d[m].mean():>14.2f}")
    lines.append(f"{'all':<16}{len(recs):>11}{no_floor.mean():>16.2f}{err.mean():>16.2f}{err_2d.mean():>14.2f}")
    lines.append("(path from 2D: the floor with the pelvis path a monocular run recovers from 2D keypoints, "
                 "benchmarks.ablation.keypoint_root_path, instead of the measured one; a check, nothing fitted on it)")
    raised = raised_recordings(args.data, args.cache)
    names = sorted({r.name for r in raised})
    lines += ["", f"Check, two support levels (CMU training subjects, trained on by the networks; footfalls more than "
              f"{RAISED_M} m apart in height): {len(names)} clips ({', '.join(names)}), paper + wide cameras",
              f"{'set':<16}{'recordings':>11}{'up model alone':>16}{'with the floor':>16}{'  > 20 deg alone / floor':>26}"]
    for views in ("paper", "wide"):
        sub = [r for r in raised if r.set == f"raised {views}"]
        alone = np.array([float(A.deg(r.post.up, r.true_up)) for r in sub])
        fused = tilt_errors(sub, fitted)
        lines.append(f"{'raised ' + views:<16}{len(sub):>11}{alone.mean():>16.2f}{fused.mean():>16.2f}"
                     f"{int(np.sum(alone > 20)):>18} / {int(np.sum(fused > 20))}")
    lines += ["", coverage_line(recs, fitted)]
    lines.append(f"({time.time() - t0:.0f} s)")
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
