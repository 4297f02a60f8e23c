"""Rectify an array of H36M-17 camera-frame poses with the Python API.

    python examples/rectify_array.py [POSES.npy]

Default input: the bundled MotionBERT output of the `pcnet demo` example.
"""

import sys
from pathlib import Path

import numpy as np

import pcnet.pipeline
from pcnet.pipeline import pose_checks, rectify
from pcnet.stages.core.rotations import decompose_camera_rotation

path = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(pcnet.pipeline.__file__).parent / "example_data" / "X3D.npy"
joints = np.load(path, allow_pickle=False)  # (T, 17, 3), camera frame: x right, y down, z forward
# sequence mode, one up for the recording, as `pcnet run` reads it (the default, frame mode, gives each frame its own)
res = rectify(joints, method="pcnet", mode="sequence", fps=30.0)  # or "pcnet-rigid", "geometric"
heading, pitch, roll = decompose_camera_rotation(res.rotation)
print(f"{path.name}: {len(joints)} frames, {int(res.valid.sum())} valid")
print(f"camera pitch {np.degrees(np.nanmean(pitch)):+.1f} deg, roll {np.degrees(np.nanmean(roll)):+.1f} deg")
print(f"frame 0 canonical head (x anterior, y up, z right): {res.canonical[0, 10].round(3)}")
for finding in pose_checks(joints, res):  # a wrong joint order, mirroring or axes still rectify: read these
    print(finding.terminal_line())
