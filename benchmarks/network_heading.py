"""Which network's heading? Per-frame heading and rotation error of each network alone and of the pair's up with either network's heading.

    python -m benchmarks.network_heading --data ../shared/data [--sets val] [--out FILE]

Frames: every frame of each clip seen by a new "paper" camera (make_pairs(clips,
views="paper", camera="per-frame", seed=0)), clean and with lifter-like noise
(models/lifter_noise.py), frame mode, the networks' own headings (no `--heading` step: on
clean mocap `pcnet evaluate`'s default takes the hip line instead, on noisy input the
network's). Rows: the camera-frame and the body-frame network alone, and the pair's up
(ViewGatedPCNet.predict_gated) with the camera-frame network's heading (release 5.1's pair
wherever the gate gave the camera-frame network every frame) or the body-frame network's
(release 5.2's pair): that network's rotation turned by the shortest arc that takes its up onto
the pair's (stages/core/rotations.py: with_up), so both have the pair's tilt exactly. Then
the two headings on the pair's up by the angle between the two networks' ups (the
disagreement d of stages/uncertainty.py), where they part. Sets: `val` (the motion-style validation split,
Bandai validation groups and CMU subjects 12 and 60, never trained on), `test` (the
motion-style test split), `deepmimic` (all 81 clips). Writes benchmarks/results/network_heading.txt
by default.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.headings import pair_headings
from benchmarks.mocap_sets import training_mix_splits
from benchmarks.report import SHARED_DATA, print_and_save

from pcnet.models.datasets import load_mocap, make_pairs
from pcnet.models.inference import ViewGatedPCNet
from pcnet.models.lifter_noise import LifterNoise
from pcnet.stages.core.metrics import heading_error_deg, rotation_error_deg, tilt_error_deg

DEFAULT = SHARED_DATA
RESULT = Path(__file__).resolve().parent / "results" / "network_heading.txt"
ROWS = ("camera-frame alone", "body-frame alone", "pair up + camera heading", "pair up + body heading")
#: Disagreement bands (deg) of the breakdown.
BANDS = ((0, 5), (5, 10), (10, 20), (20, 40), (40, 180))


def clips_of(data: Path, name: str):
    if name == "deepmimic":
        return load_mocap(data / "mocap" / "deepmimic_h36m17.npz")
    if name in ("val", "test"):
        return training_mix_splits(data, name)[0]
    raise SystemExit(f"--sets: unknown set {name!r}; expected val, test or deepmimic")


def errors(pair: ViewGatedPCNet, clips, noise) -> tuple[dict[str, dict[str, np.ndarray]], np.ndarray]:
    """Per row, ``rotation`` / ``tilt`` / ``heading`` errors (deg) over the frames every row
    has valid, and those frames' disagreement (deg)."""
    views = make_pairs(clips, views="paper", seed=0, camera="per-frame", noise=noise)
    out = {row: {m: [] for m in ("rotation", "tilt", "heading")} for row in ROWS}
    disagreement = []
    for i, clip in enumerate(clips):
        sel = np.flatnonzero(views.clip == i)
        if not len(sel):
            continue
        x, truth = views.inputs[sel], views.R[sel]
        ok, d, alone, on_pair_up = pair_headings(pair, x, clip.fps)
        estimates = dict(zip(ROWS, (*alone, *on_pair_up)))
        ok = ok & np.all([np.isfinite(R).all(axis=(1, 2)) for R in estimates.values()], axis=0)
        for row, R in estimates.items():
            out[row]["rotation"].append(rotation_error_deg(R[ok], truth[ok]))
            out[row]["tilt"].append(tilt_error_deg(R[ok], truth[ok]))
            out[row]["heading"].append(heading_error_deg(R[ok], truth[ok]))
        disagreement.append(d[ok])
    return ({row: {m: np.concatenate(v) for m, v in ms.items()} for row, ms in out.items()},
            np.concatenate(disagreement))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT)
    ap.add_argument("--sets", nargs="+", default=["val"])
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    pair = ViewGatedPCNet()
    command = "python -m benchmarks.network_heading --data ../shared/data" + (
        "" if args.sets == ["val"] else " --sets " + " ".join(args.sets))
    lines = [__doc__.splitlines()[0], "", f"    {command}", "",
             "Per-frame error (deg), mean / p95, frame mode, the networks' own headings", "",
             f"  {'set':<26}{'row':<26}{'frames':>8}{'rotation':>16}{'tilt':>16}{'heading':>16}"]
    bands = ["", "Mean heading error (deg) on the pair's up by the two networks' disagreement d (deg): "
             "camera-frame / body-frame heading [frames]", "",
             f"  {'set':<26}" + "".join(f"{f'd {lo}-{hi}':>22}" for lo, hi in BANDS)]
    for name in args.sets:
        clips = clips_of(args.data, name)
        for noise, label in ((None, "clean"), (LifterNoise(), "lifter noise")):
            rows, d = errors(pair, clips, noise)
            for row, e in rows.items():
                cells = "".join(f"{e[m].mean():>9.2f} / {np.percentile(e[m], 95):>4.1f}"
                                for m in ("rotation", "tilt", "heading"))
                lines.append(f"  {name + ', ' + label:<26}{row:<26}{len(e['rotation']):>8}{cells}")
            lines.append("")
            cam, body = rows["pair up + camera heading"]["heading"], rows["pair up + body heading"]["heading"]
            cells = []
            for lo, hi in BANDS:
                m = (d >= lo) & (d < hi)
                cells.append(f"{cam[m].mean():.2f} / {body[m].mean():.2f} [{m.sum()}]" if m.any() else "-")
            bands.append(f"  {name + ', ' + label:<26}" + "".join(f"{c:>22}" for c in cells))
    lines += bands
    print_and_save(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
