"""Run the whole pipeline on the MediaPipe BlazePose results of the Sports2D demo video.

    python examples/sports2d_mediapipe.py [--data ../shared/data] [--out DIR]

Needs the project's shared data (not shipped with pcnet), real/sports2d_demo under --data (video
+ mediapipe_blazepose33.npz). MediaPipe world
landmarks are metric, so no --height is needed. The demo video states no focal length, so the
turn from MediaPipe's virtual camera into the real one assumes a phone's (the summary's note
says so); ``RunConfig(focal_px=F)`` gives the real one (``pcnet run --focal-px F``).
"""

import argparse
from pathlib import Path

from pcnet.pipeline import RunConfig, run_pipeline

DEFAULT = Path(__file__).resolve().parents[1].parent / "shared" / "data"

ap = argparse.ArgumentParser()
ap.add_argument("--data", type=Path, default=DEFAULT, help="the shared data folder (holds real/sports2d_demo)")
ap.add_argument("--out", default="sports2d_out")
args = ap.parse_args()
demo = args.data / "real" / "sports2d_demo"
if not (demo / "demo.mp4").is_file():
    raise SystemExit(f"sports2d_mediapipe.py: --data {args.data}: expected real/sports2d_demo/demo.mp4 in it, got no "
                     f"such file (the shared data is not shipped with pcnet)")
npz = str(demo / "mediapipe_blazepose33.npz")
cfg = RunConfig(video=str(demo / "demo.mp4"), keypoints2d=npz, keypoints2d_format="mediapipe",
                lifter="mediapipe", lifter_output=npz, out=args.out, overwrite=True)
print(run_pipeline(cfg).summary())
