"""The rectification configurations the real-data benchmarks compare (one table column each).

- ``geo``: the paper's geometric baseline (section 2.3), frame and sequence mode;
- ``cam-net``: the shipped camera-frame 3DPCNet alone (the paper's input, configs/pcnet_camera_floor4.toml),
  frame mode; ``body-net``: the shipped body-frame 3DPCNet alone (configs/pcnet_body_posture.toml);
- ``pcnet``: the shipped pair gated by camera orientation (models/view_gate.py), frame mode,
  sequence mode from the poses alone (``-prior``) and with the camera prior and lying reading
  (the default of ``pcnet run``, stages/gravity_prior.py).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pcnet.models.inference import BODY_WEIGHTS, CAMERA_WEIGHTS
from pcnet.pipeline.rectification import rectify
from pcnet.stages.rectify import Rectified

CAMERA_NET = str(CAMERA_WEIGHTS)
BODY_NET = str(BODY_WEIGHTS)


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
    Configuration("cam-net frame", "pcnet", "frame", CAMERA_NET),
    Configuration("body-net frame", "pcnet", "frame", BODY_NET),
    Configuration("pcnet frame", "pcnet", "frame"),
    Configuration("pcnet seq-prior", "pcnet", "sequence", camera_prior=False),
    Configuration("pcnet seq", "pcnet", "sequence"),
)

#: Width of a text-table column that holds a configuration label (the longest, plus a gap).
LABEL_WIDTH = max(len(c.label) for c in CONFIGURATIONS) + 2
