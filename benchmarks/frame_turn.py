"""Each frame at its own quarter turn for the up model's evidence (decision 0074), against one turn per recording.

    python -m benchmarks.frame_turn --data ../shared/data [--max-clips 200] [--cache DIR]

The shipped evidence (decision 0073) reads the camera-frame 3DPCNet at one quarter turn for the
whole recording (``models/view_gate.recording_quarter_turn``). The candidate reads each frame at
its own turn: the multiple of 90 deg nearest the body-frame network's roll in that frame, no
half turns (:func:`frame_turns`). The per-frame rotations (the view gate's) are the shipped ones
in both.

On the ablation's cached held-out recordings (:func:`benchmarks.ablation.heldout_recordings`
with the quarter-turned sets) and its yoga files: the camera-frame network's up of each frame
at its candidate turn comes from the cache where it holds it (the recording's turn, the running
window's, or none) and is run otherwise. Each recording's sequence up by the up model
(:func:`pcnet.stages.rectify.up_model_sequence`, the default chain's). Per set: recordings
with a frame whose turn changes, mean sequence tilt error, the paired difference with its 95 %
bootstrap interval and decision 0061's verdict; the real views whose pitch and roll intervals
both hold the truth; the yoga files failing their trunk targets.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks.report import print_and_save
from benchmarks.yoga_physics import TARGETS
from pcnet.models.inference import get_session
from pcnet.models.preprocess import normalize_input
from pcnet.models.view_gate import _nearest_quarter, quarter_turn_matrices
from pcnet.stages.core.conventions import PELVIS, THORAX, check_poses
from pcnet.stages.core.rotations import camera_pitch_roll, decompose_camera_rotation
from pcnet.stages.rectify import up_model_sequence
from pcnet.stages.up_model import UpEvidence

RESULT = Path(__file__).resolve().parent / "results" / "frame_turn.txt"
COMMAND = "python -m benchmarks.frame_turn --data ../shared/data"
#: Decision 0061's rule: worse by more than this mean (deg) with the interval above zero.
WORSE_DEG = 0.10


def frame_turns(R_body: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """``(T,)`` int64 each valid frame's quarter turn (0, 1 or 3): the multiple of 90 deg nearest
    the body-frame network's roll in that frame, a half turn read as none (0 where not valid)."""
    k = np.zeros(len(valid), np.int64)
    if valid.any():
        roll = decompose_camera_rotation(R_body[valid])[2]
        k[valid] = _nearest_quarter(np.cos(roll), np.sin(roll))  # quarter_turns' rule, one frame as the window
    return k


def candidate_evidence(ev: dict) -> tuple[UpEvidence, int]:
    """The up model's evidence with each frame at its own turn, and how many frames' turn changed
    from the recording's one turn."""
    valid = ev["valid"]
    k = frame_turns(ev["R_body"], valid)
    changed = valid & (k != ev["turn"])
    up_cam = ev["up_camS"].copy()
    todo = []
    for t in np.flatnonzero(changed):
        if k[t] == ev["turns"][t]:
            up_cam[t] = ev["R_camT"][t, :, 1]
        elif k[t] == 0:
            up_cam[t] = ev["R_camP"][t, :, 1]
        else:
            todo.append(t)
    if todo:
        idx = np.array(todo)
        Q = quarter_turn_matrices(k[idx])
        x, scale, ok = normalize_input(check_poses(ev["J"][idx], "joints_cam"))
        x = np.einsum("tij,tkj->tki", Q, x.astype(np.float64)).astype(np.float32)
        R = get_session(None).camera.predict_normalized(x, scale, ok)[0]
        up_cam[idx] = (np.swapaxes(Q, 1, 2) @ R)[:, :, 1]
    c = np.where(valid[:, None], up_cam, np.nan)
    b = np.where(valid[:, None], ev["R_body"][:, :, 1], np.nan)
    return UpEvidence.of(c, b, quarter_turn_matrices(k) if k.any() else None), int(changed.sum())


def sequence_run(ev: dict, evidence: UpEvidence) -> dict:
    """The default chain's sequence answer of one cached recording with ``evidence``
    (:func:`benchmarks.ablation.run_variant`'s output keys)."""
    R, ok = A.shipped_rotations(ev)
    _, _, seq = up_model_sequence(R, ok, evidence, ev["fps"])
    pitch, roll = camera_pitch_roll(seq.up)
    return {"up": np.where(ok[:, None], seq.up, np.nan),
            "interval": (np.degrees(pitch), np.degrees(roll), seq.camera_pitch_interval_deg,
                         seq.camera_roll_interval_deg)}


def both(ev: dict) -> tuple[dict, dict, int]:
    shipped = sequence_run(ev, A.evidence_of(ev))
    evidence, changed = candidate_evidence(ev)
    return shipped, (shipped if not changed else sequence_run(ev, evidence)), changed


def trunk_fails(runs: list[dict], evs: list[dict]) -> dict[str, int]:
    fails = dict.fromkeys(TARGETS, 0)
    for o, ev in zip(runs, evs):
        if ev["asana"] not in TARGETS:
            continue
        J = ev["J"].astype(np.float64)
        trunk = float(np.nanmedian(A.deg(J[:, THORAX] - J[:, PELVIS], o["up"])))
        op, target = TARGETS[ev["asana"]]
        fails[ev["asana"]] += not (trunk >= target if op == ">=" else trunk <= target)
    return fails


def main(argv=None) -> int:
    args = A.heldout_arguments(argv, __doc__, "frame_turn", RESULT)
    t0 = time.time()
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND} --max-clips {args.max_clips}", "",
             f"{'set':<46}{'clips':>6}{'turned':>8}{'shipped':>9}{'per frame':>10}  per frame - shipped [95 % CI], verdict"]
    worse = False
    real_hits = None
    for title, evs in A.heldout_recordings(args.data, args.cache, args.max_clips, quarter=True):
        results = [both(ev) for ev in evs]
        e0 = np.array([A.clip_error(s["up"], ev["true_up"]) for (s, _, _), ev in zip(results, evs)])
        e1 = np.array([A.clip_error(c["up"], ev["true_up"]) for (_, c, _), ev in zip(results, evs)])
        m, lo, hi = A.paired_interval(e1 - e0)
        lost = m > WORSE_DEG and lo > 0
        worse |= lost
        turned = sum(n > 0 for _, _, n in results)
        lines.append(f"{title:<46}{len(evs):>6}{turned:>8}{np.nanmean(e0):>9.2f}{np.nanmean(e1):>10.2f}  "
                     f"{m:+.2f} [{lo:+.2f}, {hi:+.2f}] {'worse' if lost else 'not worse'}")
        if title.startswith("real calibrated"):
            real_hits = [int(A.interval_hits([r[i] for r in results], evs).all(1).sum()) for i in (0, 1)]
    yoga = A.cached(args.cache, f"yoga_stride{A.YOGA_STRIDE}", lambda: A.yoga_evidence(args.data))
    yoga_runs = [both(ev) for ev in yoga]
    fails = [trunk_fails([r[i] for r in yoga_runs], yoga) for i in (0, 1)]
    lines += ["", f"real calibrated views whose pitch and roll intervals both hold the truth: shipped {real_hits[0]}, "
                  f"per frame {real_hits[1]} of 16",
              f"yoga files ({len(yoga)}; {sum(n > 0 for _, _, n in yoga_runs)} with a frame whose turn changes) failing "
              f"the trunk target, shipped / per frame: "
              + ", ".join(f"{a} {fails[0][a]} / {fails[1][a]}" for a in TARGETS)]
    ships = not worse and real_hits[1] >= real_hits[0] and sum(fails[1].values()) <= sum(fails[0].values())
    lines += ["", f"Decision 0074's rule: each frame at its own turn {'ships' if ships else 'does not ship'} (worse on no set "
                  f"by 0.10 deg with the interval above zero, no fewer real views covered, no more yoga files failing).",
              f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
