"""The view gate's pieces and the quarter turns, each switched off on held-out data (decisions 0061, 0062).

    python -m benchmarks.view_gate_pieces --data ../shared/data [--cache /tmp/pcnet_ablation_cache]

Frame mode blends the two networks per frame by the view gate (``models/view_gate.py``):
``w = max(in(body), in(camera) * near(body))``, ``in`` and ``near`` products of linear ramps in
each network's running-median camera roll and pitch. Each piece is switched off alone, the
rest as shipped (docs/decisions/0061-view-gate-pieces-ablated.md):

- ``pitch off``: ``in`` and ``near`` in roll only (the two pitch ramps);
- ``steps``: each ramp a step at its midpoint (one threshold per ramp instead of two);
- ``no median``: each frame's own view estimate (the quarter turns keep their window);
- ``no camera estimate``: ``w = in(body)`` (the camera-frame network's estimate and ``near``);
- ``quarter turns off`` (decision 0062): the camera-frame network on the input as filmed, the
  gate in that frame (benchmarks/ablation.py's "quarter turns off" row in frame mode).

Printed per set: the mean over clips of each clip's mean per-frame tilt error (deg) of the
shipped gate and of each piece off, with the paired difference (piece off minus shipped) and
its 95 % bootstrap interval over clips (:func:`benchmarks.ablation.paired_interval`).
Validation sets first (the up model's fitting data: information only), then the held-out sets
of ``benchmarks/ablation.py`` from its cache, and a camera pitched a further
:data:`PITCH_DEG` deg down (the three held-out mocap sets' recordings, ``X' = X P^T``, true up
``P u``), cached under ``pitched{PITCH_DEG}_{max_clips}``. Last, the pieces that the rule does
not keep, switched off together.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks import ablation as A
from benchmarks import fit_up_model as F
from benchmarks.report import print_and_save
from pcnet.models import view_gate as G
from pcnet.stages.core.rotations import with_up

RESULT = Path(__file__).resolve().parent / "results" / "view_gate_pieces.txt"
COMMAND = "python -m benchmarks.view_gate_pieces --data ../shared/data"
#: The new held-out set's extra camera pitch, degrees down (decision 0061).
PITCH_DEG = 60.0
#: Decision 0061's margin: a piece stays if switching it off is worse by more than this (deg) on a held-out set.
MARGIN_DEG = 0.10


@dataclass(frozen=True)
class Gate:
    """Which of the view gate's pieces are on."""

    label: str
    pitch: bool = True
    ramps: bool = True
    median: bool = True
    camera_estimate: bool = True
    turns: bool = True


SHIPPED = Gate("shipped")
PIECES = (Gate("pitch off", pitch=False), Gate("steps", ramps=False), Gate("no median", median=False),
          Gate("no camera estimate", camera_estimate=False))
#: Decision 0062: the quarter turns off (the camera-frame network on the input as filmed, the gate in that frame).
NO_TURNS = Gate("quarter turns off", turns=False)


def _ramp(x: np.ndarray, full: float, none: float, ramps: bool) -> np.ndarray:
    return G._ramp(x, full, none) if ramps else (x < (full + none) / 2).astype(np.float64)


def gate_weight(gate: Gate, Rb: np.ndarray, Rc: np.ndarray, valid: np.ndarray, fps: float) -> np.ndarray:
    """``(T,)`` the camera-frame network's weight under ``gate`` (:func:`pcnet.models.view_gate.camera_frame_weight`'s
    formula with pieces switched off); ``Rb``, ``Rc`` the networks' ``(T, 3, 3)`` rotations in the quarter-turned frame."""
    w = np.full(len(valid), np.nan)
    idx = np.flatnonzero(valid)
    if len(idx) == 0:
        return w
    size = G.window_frames(fps) if gate.median else 1

    def inside(roll, pitch, roll_ramp, pitch_ramp):
        out = _ramp(roll, *roll_ramp, gate.ramps)
        return out * _ramp(pitch, *pitch_ramp, gate.ramps) if gate.pitch else out

    roll_b, pitch_b = G.camera_view_estimate(Rb[idx], size)
    w[idx] = inside(roll_b, pitch_b, G.ROLL_RAMP_DEG, G.PITCH_RAMP_DEG)
    if gate.camera_estimate:
        roll_c, pitch_c = G.camera_view_estimate(Rc[idx], size)
        kept_in = (inside(roll_c, pitch_c, G.ROLL_RAMP_DEG, G.PITCH_RAMP_DEG)
                   * inside(roll_b, pitch_b, G.BODY_ESTIMATE_LIMIT_ROLL_DEG, G.BODY_ESTIMATE_LIMIT_PITCH_DEG))
        w[idx] = np.maximum(w[idx], kept_in)
    return w


def frame_error(ev: dict, gate: Gate) -> float:
    """One recording's mean per-frame tilt error (deg) under ``gate`` (ablation.per_frame's arithmetic)."""
    fps = ev["fps"]
    Rb, Rc, valid, Qb, Qc = A.gate_inputs(ev, gate.turns)
    w = gate_weight(gate, Qb, Qc, valid, fps)
    if gate == SHIPPED:  # the reimplementation is the package's gate
        assert np.allclose(w, G.camera_frame_weight(Qb, valid, fps, Qc), rtol=0, atol=1e-12, equal_nan=True)
    up = with_up(Rb, G.blend_rotations(Rb, Rc, w)[:, :, 1])[:, :, 1]
    return A.clip_error(np.where(valid[:, None], up, np.nan), ev["true_up"])


def heldout_sets(args) -> list[tuple[str, list[dict]]]:
    """``(title, recordings)`` of decision 0061's held-out sets: the ablation's, the camera rolled
    30 and 90 deg included, and the camera pitched :data:`PITCH_DEG` deg down (``args``: the
    command line of :func:`benchmarks.ablation.heldout_arguments`)."""
    heldout = A.heldout_recordings(args.data, args.cache, args.max_clips, quarter=True)
    static = [evs for _, evs in heldout[:len(A.MOCAP_SETS)]]
    heldout.append((f"camera pitched {PITCH_DEG:g} deg down (the three sets)",
                    A.pitched_recordings(args.cache, static, args.max_clips, PITCH_DEG)))
    return heldout


def errors(evs: list[dict], gates: tuple[Gate, ...]) -> np.ndarray:
    """``(N, len(gates))`` each recording's mean per-frame tilt error (deg) per gate."""
    return np.array([[frame_error(ev, g) for g in gates] for ev in evs])


def worse(diff: np.ndarray) -> tuple[bool, str]:
    """Whether ``diff`` (an alternative minus the shipped gate, per clip) is worse by decision
    0061's rule (mean above :data:`MARGIN_DEG`, interval above zero), and its cell."""
    mean, lo, hi = A.paired_interval(diff)
    return bool(mean > MARGIN_DEG and lo > 0), f"{mean:+.2f} [{lo:+.2f}, {hi:+.2f}]"


def table(sets: list[tuple[str, list[dict]]], gates: tuple[Gate, ...]) -> tuple[list[str], np.ndarray]:
    """Rows per set and ``(sets, len(gates) - 1)`` bool: gate ``k + 1`` worse than ``gates[0]`` by the rule."""
    lines = [f"{'set':<44}{'clips':>6}{gates[0].label:>10}"
             + "".join(f"{g.label:>20} {'- shipped [95 % CI]':<22}" for g in gates[1:])]
    flags = []
    for title, evs in sets:
        e = errors(evs, gates)
        line, row = f"{title:<44}{len(evs):>6}{np.nanmean(e[:, 0]):>10.2f}", []
        for k in range(1, len(gates)):
            bad, cell = worse(e[:, k] - e[:, 0])
            row.append(bad)
            line += f"{np.nanmean(e[:, k]):>20.2f} {cell:<22}"
        lines.append(line)
        flags.append(row)
    return lines, np.array(flags)


def main(argv: list[str] | None = None) -> int:
    args = A.heldout_arguments(argv, __doc__, "view_gate_pieces", RESULT)
    t0 = time.time()
    gates = (SHIPPED, *PIECES, NO_TURNS)
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             "Mean over clips of each clip's mean per-frame tilt error (deg), and each piece off minus the shipped gate.",
             "", "## Validation (information only)"]
    val = [(f"{tag} val, {views}", evs) for (tag, views), evs in F.validation_sets(args.data, args.cache).items()]
    lines += table(val, gates)[0]
    heldout = heldout_sets(args)
    rows, flags = table(heldout, gates)
    lines += ["", "## Held out", *rows, ""]
    stays = flags.any(axis=0)
    for k, (g, keep) in enumerate(zip((*PIECES, NO_TURNS), stays)):
        where = [title for (title, _), bad in zip(heldout, flags[:, k]) if bad]
        lines.append(f"{g.label}: " + (f"stays (switching it off is worse on {', '.join(where)})" if keep
                                       else "does not stay (switching it off is worse on no held-out set)"))
    dropped = [g for g, keep in zip(PIECES, stays) if not keep]  # 0061's pieces; 0062's turns decide alone
    if dropped:
        reduced = Gate("reduced: " + " + ".join(g.label for g in dropped),
                       **{field: all(getattr(g, field) for g in dropped) for field in ("pitch", "ramps", "median",
                                                                                     "camera_estimate", "turns")})
        rows, flags = table(heldout, (SHIPPED, reduced))
        lines += ["", "## The pieces that do not stay, switched off together", *rows, "",
                  "reduced gate: " + ("worse on " + ", ".join(t for (t, _), bad in zip(heldout, flags[:, 0]) if bad)
                                      if flags.any() else "not worse on any held-out set: ships")]
    lines += ["", f"({time.time() - t0:.0f} s)"]
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
