"""Where networks differ, clip by clip: per clip mean rotation error on one split of a mocap file.

Each ``--weights`` is scored, and the clips are sorted by how far the candidates' mean departs
from the first network's (the reference), with each clip's description from the file's ``.json``.

    python -m benchmarks.per_clip_difference --data ../shared/data/mocap/cmu_train_h36m17.npz \\
        --weights models/weights/pcnet_camera.onnx runs/pcnet_camera_floor_seed11.onnx ... \\
        [--split test] [--top 12] [--out benchmarks/results/per_clip_difference.txt]

Each network is scored alone (``pcnet evaluate --method pcnet --weights W``'s protocol: by
default clean, "paper" views, a new camera every frame, frame mode, seed 0; ``--camera``,
``--noise`` and ``--mode`` as in ``pcnet evaluate``), so every network sees the same frames;
``pair`` in place of a file scores the shipped default (both networks and the view gate).
Then, per clip description (motion), the frame-weighted mean of every network.
A mean over a split hides where a change of training data costs; this says which motions pay.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from benchmarks.report import print_and_save

from pcnet.models.datasets import CAMERAS, load_mocap, read_sidecar, select_split
from pcnet.pipeline.evaluate import NOISE_KINDS, evaluate
from pcnet.stages.core.errors import InputError
from pcnet.stages.temporal import MODES


def per_clip_rotation(data: Path, split: str, weights: str, **protocol) -> tuple[float, np.ndarray, np.ndarray]:
    """``(mean over frames, (C,) per clip mean, (C,) valid frames per clip)`` of the rotation error (deg) of the network
    ``weights`` (``"pair"``: the shipped default) on the ``split`` clips of ``data`` (motion-style scheme), in clip order; NaN
    for a clip with no valid scored frame (no defined target, or no prediction); ``protocol``:
    :func:`pcnet.pipeline.evaluate.evaluate`'s ``camera``, ``noise``, ``mode``."""
    r = evaluate("pcnet", data, split, weights=None if weights == "pair" else weights, details=True, **protocol)
    frame = r["per_frame"]
    clip = frame["clip"][frame["valid"]]
    err = frame["rotation_deg"][frame["valid"]]
    total = np.bincount(clip, weights=err, minlength=r["clips"])
    count = np.bincount(clip, minlength=r["clips"])
    return r["rotation_deg"]["mean"], np.where(count > 0, total / np.maximum(count, 1), np.nan), count


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--weights", nargs="+", required=True, help="the reference first, then the candidates")
    ap.add_argument("--split", default="test")
    ap.add_argument("--top", type=int, default=12)
    ap.add_argument("--camera", default="per-frame", choices=list(CAMERAS))
    ap.add_argument("--noise", default="none", choices=list(NOISE_KINDS))
    ap.add_argument("--mode", default="frame", choices=list(MODES))
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results/per_clip_difference.txt"))
    args = ap.parse_args()
    if len(args.weights) < 2:
        ap.error("--weights: give the reference and at least one candidate")
    for path in [args.data] + [Path(w) for w in args.weights if w != "pair"]:
        if not path.is_file():
            sys.exit(f"{path}: expected {'a mocap .npz (--data)' if path == args.data else 'an exported network (--weights)'}"
                     f", got no such file")
    try:
        clips = select_split(load_mocap(args.data), args.split, "motion-style")
        meta = read_sidecar(args.data.with_suffix(".json"))  # load_mocap has checked each entry is an object
        scored = [per_clip_rotation(args.data, args.split, w, camera=args.camera, noise=args.noise, mode=args.mode)
                  for w in args.weights]
    except InputError as err:
        sys.exit(str(err))
    descriptions = [meta.get(c.name, {}).get("description", "") for c in clips]
    ref = scored[0][1]
    delta = np.mean([s[1] for s in scored[1:]], axis=0) - ref
    lines = [__doc__.splitlines()[0], "", "    python -m benchmarks.per_clip_difference " + " ".join(sys.argv[1:]), "",
             f"{args.data.name}, split {args.split} (motion-style), {len(clips)} clips; camera {args.camera}, noise "
             f"{args.noise}, mode {args.mode}; mean rotation "
             f"error (deg); networks: " + ", ".join(f"[{i}] {w}" for i, w in enumerate(args.weights)), "",
             "all clips: " + " / ".join(f"[{i}] {m:.2f}" for i, (m, *_) in enumerate(scored)), "",
             f"clips whose candidates' mean departs most from [0] (top {args.top}):", ""]
    lines.append(f"{'clip':<14}{'frames':>7}  " + "".join(f"{f'[{i}]':>8}" for i in range(len(scored)))
                 + f"{'mean-[0]':>10}  description")
    for i in np.argsort(-np.abs(delta))[: args.top]:
        lines.append(f"{clips[i].name:<14}{len(clips[i].joints):>7}  " + "".join(f"{s[1][i]:>8.2f}" for s in scored)
                     + f"{delta[i]:>+10.2f}  {descriptions[i]}")
    if any(descriptions):
        lines += ["", "per motion (clip description), frame-weighted mean:", "",
                  f"{'clips':>5}{'frames':>8}  " + "".join(f"{f'[{i}]':>8}" for i in range(len(scored))) + "  description"]
        motions = {d: np.array([e == d for e in descriptions]) for d in set(descriptions)}
        for desc, rows in sorted(motions.items(), key=lambda item: -scored[0][2][item[1]].sum()):
            means = [np.nansum(s[1][rows] * s[2][rows]) / max(s[2][rows].sum(), 1) for s in scored]
            lines.append(f"{rows.sum():>5}{int(scored[0][2][rows].sum()):>8}  " + "".join(f"{m:>8.2f}" for m in means)
                         + f"  {desc or '(none)'}")
    print_and_save(lines, args.out)


if __name__ == "__main__":
    main()
