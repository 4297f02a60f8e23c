"""OpenSim scaling + inverse kinematics of H36M-17 joint-centre markers: marker error and speed.

    python -m benchmarks.opensim_ik [--data ../shared/data] [--max-frames 300]

Rows (stages/opensim_ik.py: scale_and_ik, the shipped Model_H36M17.osim, one process, one
IK thread):
- demo: `pcnet run` on the bundled example (MotionBERT + AlphaPose, 301 frames, 3DPCNet,
  --height 1.75, no recording), its world.trc;
- mocap: real motion-capture clips (../shared/data/mocap: a Bandai walk and kick, a CMU
  clip; metres, +Y up, already a gravity frame) written with pcnet.stages.sinks.exports.write_trc
  after moving the first frame's pelvis to x = z = 0 and the floor (5th percentile of the
  lowest joint centre) to y = 0, as stages/world_frame.py does; at most --max-frames frames.
  Without ../shared/data, the Bandai clips of tests/fixtures/bandai_test_clips.npz.
Marker RMS: over all frames and the 17 markers (from OpenSim's ik_marker_errors.sto);
max: the largest single marker error; frames/s: IK alone (scaling reported apart).
Writes benchmarks/results/opensim_ik.txt with the command at the top.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.report import SHARED_DATA
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "pipeline" / "example_data"
WANTED = {
    "bandai_h36m17.npz": ["dataset-1_walk_normal_001", "dataset-1_kick_normal_001"],
    "cmu_train_h36m17.npz": [None],  # None: the longest clip
}


def demo_trc(tmp: Path) -> Path:
    out = tmp / "demo"
    cmd = [sys.executable, "-m", "pcnet.pipeline.entry", "run", "--lifter", "motionbert",
           "--lifter-output", str(EXAMPLE / "X3D.npy"), "--keypoints2d", str(EXAMPLE / "alphapose-results.json"),
           "--keypoints2d-format", "alphapose", "--fps", "30", "--height", "1.75", "--out", str(out),
           "--no-recording"]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return out / "world.trc"


def mocap_clips(data: Path, max_frames: int) -> list[tuple[str, np.ndarray, float]]:
    from pcnet.models.datasets import load_mocap

    clips = []
    mocap = data / "mocap"
    if mocap.is_dir():
        for file, names in WANTED.items():
            path = mocap / file
            if not path.is_file():
                continue
            with np.load(path) as npz:
                keys = list(npz.files)
                for name in names:
                    if name is None:
                        name = max(keys, key=lambda k: npz[k].shape[0])
                    elif name not in keys:
                        continue
                    clips.append((f"{file.split('_')[0]}:{name}", np.asarray(npz[name], float)[:max_frames], 30.0))
    if not clips:
        for clip in load_mocap(ROOT / "tests" / "fixtures" / "bandai_test_clips.npz")[:2]:
            clips.append((f"fixture:{clip.name}", np.asarray(clip.joints, float)[:max_frames], clip.fps))
    return clips


def to_floor_frame(joints: np.ndarray) -> np.ndarray:
    """Pelvis of the first frame at x = z = 0, floor (5th percentile of the lowest joint) at y = 0."""
    out = joints.copy()
    out[..., 0] -= joints[0, 0, 0]
    out[..., 2] -= joints[0, 0, 2]
    out[..., 1] -= np.nanpercentile(np.nanmin(joints[..., 1], axis=1), 5)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(SHARED_DATA))
    ap.add_argument("--max-frames", type=int, default=300)
    args = ap.parse_args()
    from pcnet.stages.sinks.exports import write_trc
    from pcnet.stages.opensim_ik import import_opensim, scale_and_ik

    osim = import_opensim()
    command = "python -m benchmarks.opensim_ik" + "".join(f" {a}" for a in sys.argv[1:])
    machine = (f"{os.cpu_count()} CPU cores ({platform.machine()}), Python {platform.python_version()}, "
               f"OpenSim {osim.__version__}; IK single-threaded; model stages/opensim_data/Model_H36M17.osim")
    header = (f"{'recording':<42} {'frames':>6} {'RMS cm':>7} {'max cm':>7} {'median frame RMS cm':>20} "
              f"{'IK frames/s':>12} {'scale s':>8}")
    lines = [f"    {command}", "", machine, "", header]
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        rows = [("demo (pcnet run, world.trc, 3DPCNet)", demo_trc(tmp))]
        for name, joints, fps in mocap_clips(Path(args.data), args.max_frames):
            path = tmp / f"{len(rows)}.trc"
            write_trc(path, to_floor_frame(joints), fps)
            rows.append((name, path))
        for name, trc in rows:
            out = tmp / f"ik{len(lines)}"
            out.mkdir()
            r = scale_and_ik(trc, out, None)
            line = (f"{name:<42} {r['frames']:>6} {100 * r['marker_rms_m']:>7.2f} {100 * r['marker_max_m']:>7.2f} "
                    f"{100 * r['marker_rms_median_frame_m']:>20.2f} {r['frames_per_s']:>12.1f} {r['scale_seconds']:>8.2f}")
            print(line, flush=True)
            lines.append(line)
    results = ROOT / "benchmarks" / "results" / "opensim_ik.txt"
    results.write_text("\n".join(lines) + "\n")
    print(f"wrote {results}")


if __name__ == "__main__":
    main()
