"""pcnet from Python: the names a script needs, and the error they raise.

``pcnet`` itself is an implicit namespace package (its folders install as ``pcnet.pipeline``,
``pcnet.stages``, ...; ``pyproject.toml``), so the public API lives here::

    from pcnet.pipeline import rectify, pose_checks, run_pipeline, RunConfig, InputError

Bad input (a file, an array, a config value) raises :class:`InputError`
(:class:`pcnet.stages.core.errors.InputError`, a ``ValueError``) with one line naming the file
or field, what was expected and what was found; an earlier pcnet output folder or an empty
one (``tempfile.mkdtemp()``'s; without ``overwrite``, which replaces either) raises
``FileExistsError``, any other existing folder an :class:`InputError`.
Messages name ``pcnet run``'s options: the :class:`RunConfig` field of the same name
(``--focal-px`` is ``focal_px``) is what a script sets.

They are imported when first used, so ``import pcnet.pipeline`` stays cheap (no onnxruntime,
OpenCV or adapters until then).

:func:`rectify` (:func:`pcnet.pipeline.rectification.rectify`, what ``pcnet rectify`` runs):
camera-frame H36M-17 poses ``(T, 17, 3)`` (OpenCV axes: x right, y down, z forward; any
length unit; NaN = missing) in, a :class:`~pcnet.stages.rectify.Rectified` out: ``rotation``
``(T, 3, 3)`` canonical -> camera, ``canonical`` ``(T, 17, 3)`` pelvis-centred poses in the
canonical frame (x anterior, y up, z right; ``docs/CONVENTIONS.md``) with the network's
residual, ``up`` ``(T, 3)`` the camera-frame up, ``valid`` ``(T,)``. ``pcnet run``'s kinematics
read the input turned rigidly instead, ``(X - pelvis) @ R`` (decision 0100), low-passed in the
camera frame and the rotations apart (``pcnet.stages.kinematics.compute_kinematics(joints, 30.0,
rotation=res.rotation)`` gives a frame or smooth mode run's angles; decision 0102)::

    import numpy as np
    from pcnet.pipeline import rectify

    # a clone's test fixture; an installed pcnet carries one real lifter output of its own,
    # Path(pcnet.pipeline.__file__).parent / "example_data" / "X3D.npy" (MotionBERT, normalised units)
    joints = np.load("tests/fixtures/yoga_Abhay_Tadasana_f000-099.npy")  # (100, 17, 3), metres
    res = rectify(joints, mode="sequence", fps=30.0)  # 3DPCNet; method="geometric": the paper's baseline
    print(res.canonical.shape, res.valid.sum(), res.up[0])  # sequence: one up for a static camera

    from pcnet.pipeline.checks import CameraTilt

    tilt = CameraTilt.of(res.rotation, res.valid)  # pcnet run's "camera tilt" line, deg
    seq = res.report.sequence  # sequence mode's up and its 95 % intervals, deg
    print(tilt.pitch_deg, seq.camera_pitch_interval_deg, tilt.roll_deg, seq.camera_roll_interval_deg)

Three things ``pcnet run`` does beyond :func:`rectify`, for a script that wants its numbers
from arrays (a developer trial's chain differed from the command line's on both counts):
:func:`rectify`'s ``mode`` defaults to ``frame`` (each frame alone, the paper), ``pcnet run``'s
to ``sequence`` (one up for a static camera): pass ``mode="sequence", fps=...``. A lifter whose
output is not metric (MotionBERT's normalised units, pixels) lifts in the image's scale, so its
skeleton grows as the person nears the camera: ``pcnet run`` first gives every frame the
recording's median body size, ``joints * pcnet.stages.scale.size_normalising_factors(joints,
fps)[:, None, None]`` (root-relative joints; the rotations hardly change, positions and speeds
do: a wrist's speed by up to 46 % of its mean on a real MotionBERT clip). The world frame, one
fixed gravity-aligned frame for the recording, is
``pcnet.stages.world_frame.to_world(pcnet.stages.core.conventions.root_relative(joints)[0],
world_frame(res.rotation, res.valid, fps))``, with ``joints`` as :func:`rectify` read them:
``joints = pcnet.stages.core.conventions.validate_poses(joints)`` (its missing joints NaN,
a writer's placeholders for them too: a joint or frame of zeros; ``root_relative`` and the
kinematics take a zero as a position, and a developer trial's wrist written as zeros read
18.6 m/s); ``canonical.npz``'s ``joints_world`` also has the floor under the body
(``to_world_floor``) and, with 2D keypoints, the pelvis path.

What else ``pcnet run`` does that an array chain must do itself (an API trial measured each):
a lifter's file is read by its adapter (:mod:`pcnet.adapters`), which may change the poses
(MediaPipe's are turned from its virtual camera into the real one:
``pcnet.adapters.mediapipe.load_mediapipe_3d``, 7 deg of up on a real clip) and give the
lifter's restarts (``Poses3D.breaks``, MotionBERT's clip starts, which the kinematics take no
derivative across: ``kinematics_chunks(..., breaks=...)``); joints whose 2D keypoint's
confidence is under ``confidence_threshold`` are missing (``pcnet.stages.remap.mask_low_confidence``);
with 2D keypoints, frames of another person (a switched 2D track) are left out of the ranges,
and the pelvis path's floor contacts correct the up (``pcnet.pipeline.pelvis_path``). For
all of it in one call, :func:`run_pipeline` below.

:func:`rectify` returns a result whatever the poses are: a wrong joint order, a mirrored
skeleton or other axes still rectify. :func:`pose_checks` (:func:`pcnet.pipeline.checks.pose_checks`)
gives the warnings ``pcnet run`` would print that the poses alone can give (the camera's
orientation, leg asymmetry, a mirrored skeleton, the posture), each a
:class:`~pcnet.stages.flags.Finding` with a ``terminal_line()``::

    from pcnet.pipeline import pose_checks

    for finding in pose_checks(joints, res):
        print(finding.terminal_line())

:func:`run_pipeline` (:func:`pcnet.pipeline.runner.run_pipeline`) with a :class:`RunConfig`
(:class:`pcnet.pipeline.config.RunConfig`, the fields of ``pcnet run``'s options) runs what
``pcnet run`` runs on one recording and writes its output folder (``docs/outputs.md``); it
returns a :class:`~pcnet.pipeline.runner.RunResult`::

    from pcnet.pipeline import RunConfig, run_pipeline

    cfg = RunConfig(lifter="videopose3d", lifter_output="tests/fixtures/yoga_Abhay_Tadasana_f000-099.npy",
                    fps=30.0, height=1.7, recording=False, out="yoga_out")
    result = run_pipeline(cfg.validate(), progress=False)  # validate(): every field's value first
    print(result.summary())

The result holds counts, the report and the written files' paths (``result.outputs``, by file
name), not the arrays: a long recording's arrays stay on disk. Read them back from the files
(``docs/outputs.md`` lists every array and column)::

    import csv

    with np.load(result.outputs["canonical.npz"], allow_pickle=False) as npz:
        world = npz["joints_world"]  # (T, 17, 3) float64, the world frame (y up, floor y = 0), in the run's units: m
    with open(result.outputs["kinematics.csv"], newline="") as fh:
        rows = list(csv.DictReader(fh))  # one per frame; an empty cell is missing
    knee = [float(r["left_knee_flexion_deg"] or "nan") for r in rows]

:class:`RunConfig` can also be read from a TOML file with the same keys
(:func:`pcnet.pipeline.config.load_run_config`), or built from a dict of values checked in one
go::

    from pcnet.pipeline import RunConfig

    cfg = RunConfig.from_values("my script", {"lifter": "motionbert", "lifter_output": "X3D.npy", "fps": 25.0})
    cfg.mode, cfg.lowpass_hz  # ('sequence', 6.0): the defaults ``pcnet run`` uses
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # what a type checker reads for the names __getattr__ imports on first use
    from pcnet.pipeline.checks import pose_checks
    from pcnet.pipeline.config import RunConfig
    from pcnet.pipeline.rectification import rectify
    from pcnet.pipeline.runner import run_pipeline
    from pcnet.stages.core.errors import InputError

#: Public name -> the module that defines it.
_PUBLIC = {
    "rectify": "pcnet.pipeline.rectification",
    "pose_checks": "pcnet.pipeline.checks",
    "run_pipeline": "pcnet.pipeline.runner",
    "RunConfig": "pcnet.pipeline.config",
    # what they raise for bad input (a ValueError): one line naming the file or field
    "InputError": "pcnet.stages.core.errors",
}

__all__ = ["rectify", "pose_checks", "run_pipeline", "RunConfig", "InputError"]


def __getattr__(name: str):
    """The public names, imported from their modules on first use (PEP 562)."""
    if name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
