"""Why pcnet: the same movement filmed from two places gives different trajectories; after
rectification they agree.

    python examples/compare_two_views.py [--data MOCAP.npz] [--clip NAME] [--method pcnet]

Takes a real mocap clip (default: a Bandai walk turning left, of the motion-style test split the
shipped weights did not train on, from the test fixture mocap_small.npz; of another --data file,
its first clip), films it with two
fixed synthetic cameras (front-left and side-right, pitched differently), and compares the
right-wrist trajectory seen by the two cameras before and after rectification.
"""

import argparse
from pathlib import Path

import numpy as np

from pcnet.models.datasets import load_mocap
from pcnet.stages.core.canonical import to_canonical
from pcnet.stages.core.conventions import R_WRIST
from pcnet.pipeline.rectification import make_estimator
from pcnet.stages.core.rotations import compose_camera_rotation
from pcnet.stages.rectify import SequenceEvidence

ROOT = Path(__file__).resolve().parents[1]
ap = argparse.ArgumentParser()
ap.add_argument("--data", default=str(ROOT / "tests" / "fixtures" / "mocap_small.npz"))
ap.add_argument("--clip", default=None)
ap.add_argument("--method", default="pcnet")
args = ap.parse_args()

clips = {c.name: c for c in load_mocap(args.data)}
# held out from the shipped weights' training (a trained clip would flatter the agreement); another file: its first
HELD_OUT_CLIP = "dataset-2_walk-turn-left_active_001"
clip = clips[args.clip] if args.clip else clips.get(HELD_OUT_CLIP, next(iter(clips.values())))
# root-relative poses in the mocap's world frame (Y up), as a lifter reports them: the cameras below
# are fixed there, whichever way the subject turns (not in the canonical frame, which turns with it)
world = clip.joints - clip.joints[:, :1]
cameras = {"front-left, 10 deg down": compose_camera_rotation(np.radians(35), np.radians(10), np.radians(2)),
           "right side, 25 deg down": compose_camera_rotation(np.radians(-100), np.radians(25), np.radians(-4))}
wrist = {}
for name, R in cameras.items():
    cam = world @ R.T  # what a lifter would report in this camera's frame (noise-free here)
    estimate = make_estimator(args.method)(cam, clip.fps)
    seq = SequenceEvidence("auto")(cam, estimate.rotation, estimate.valid, clip.fps)
    wrist[name] = (cam[:, R_WRIST], to_canonical(cam, seq.rotation)[:, R_WRIST], seq.mode.run)

(a_cam, a_can, mode_a), (b_cam, b_can, mode_b) = wrist.values()
rms = lambda d: 100 * float(np.sqrt(np.nanmean(np.sum(d**2, -1))))  # noqa: E731
print(f"clip {clip.name} ({len(world)} frames), method {args.method}, modes {mode_a}/{mode_b}")
print(f"right wrist, RMS difference between the two views: camera frames {rms(a_cam - b_cam):.1f} cm, "
      f"after rectification {rms(a_can - b_can):.1f} cm")
