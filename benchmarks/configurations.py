"""The rectification configurations the real-data benchmarks compare (one table column each).

- ``geo``: the paper's geometric baseline (section 2.3), frame and sequence mode;
- ``3dpcnet-cam``: the previous shipped 3DPCNet, the paper's camera-frame input trained on Bandai's
  clip-scheme train split (models/weights/pcnet_camera.onnx), frame mode and sequence mode
  from the poses alone: the paper's model without pcnet's additions;
- ``pcnet``: the shipped body-frame 3DPCNet (configs/pcnet_body.toml), frame mode, sequence mode
  from the poses alone (``-prior``) and with the camera prior and lying reading (the default of
  ``pcnet run``, stages/gravity_prior.py).
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from pcnet.stages.rectify import Rectified, rectify

CAMERA_FRAME_WEIGHTS = str(Path(__file__).resolve().parents[1] / "models" / "weights" / "pcnet_camera.onnx")


class Configuration(NamedTuple):
    label: str
    method: str
    mode: str
    weights: str | None = None
    camera_prior: bool = True

    def rectify(self, joints: np.ndarray, fps: float) -> Rectified:
        return rectify(joints, self.method, self.weights, mode=self.mode, fps=fps, camera_prior=self.camera_prior)


CONFIGURATIONS = (
    Configuration("geo frame", "geometric", "frame"),
    Configuration("geo seq", "geometric", "sequence"),
    Configuration("3dpcnet-cam frame", "pcnet", "frame", CAMERA_FRAME_WEIGHTS),
    Configuration("3dpcnet-cam seq-prior", "pcnet", "sequence", CAMERA_FRAME_WEIGHTS, camera_prior=False),
    Configuration("pcnet frame", "pcnet", "frame"),
    Configuration("pcnet seq-prior", "pcnet", "sequence", camera_prior=False),
    Configuration("pcnet seq", "pcnet", "sequence"),
)

#: Width of a text-table column that holds a configuration label (the longest, plus a gap).
LABEL_WIDTH = max(len(c.label) for c in CONFIGURATIONS) + 2
