"""Which of pcnet's two 3DPCNets to trust, from the camera orientation it reads.

pcnet ships two networks trained by the same recipe on the same data (models/MODEL_CARD.md):
the paper's camera-frame 3DPCNet (section 2.1, input in camera coordinates), more accurate
on held-out motion capture because it has learnt how cameras are usually held, and a
body-frame 3DPCNet (:func:`pcnet.models.network.body_frame`), exactly equivariant to camera
rotation, hence right for any camera roll but less accurate for level cameras. The
camera-frame network only knows cameras inside its training views ("paper" + "wide"
distributions, docs/CONVENTIONS.md: |roll| <= 25 deg, |pitch| <= 45 deg); outside them its
answer is pulled back towards a level camera (at 90 deg roll its tilt error is ~43 deg).

The gate reads the camera pitch and roll from both networks' ups, each as a running median
over about two seconds (so a few hard poses do not switch networks, while a phone turned
during the recording does). The body-frame network has no preference for level cameras, so
its estimate is not pulled into the range it tests; but it reads every body as upright, so a
seated, squatting or bent-over body under a level camera also reads as a steep camera. The
camera-frame network's own estimate tells these apart: for such bodies it reads a level
camera, while for a camera really rolled 45 deg or more it reads one outside its training
views (its answer is pulled back towards level, but not inside the range). The camera-frame
network therefore gets full weight when the body-frame estimate is inside the range, and
also when its own estimate is inside that range while the body-frame estimate is not far
beyond it (roll below 45-60 deg: beyond that even the camera-frame network sometimes reads a
90 deg roll as inside, on the validation split; pitch below 45-60 deg: beyond that it reads a
camera pitched steeply down as inside, fitted on validation views that include such cameras,
decision 0063); linear ramps in between. The range in roll is 10-20 deg, well inside the
training views' 25 deg: the camera-frame network reads a camera rolled 30 deg as rolled only
about 15 deg (pulled towards the level cameras it trained on), and from about 15 deg of roll it is less accurate
than the body-frame network (motion-style validation split, clean: 2.81 vs 2.20 deg at 15
deg roll). With the earlier 20-30 deg range its own estimate kept it in at 30 deg of roll,
where it is the worse network (benchmarks/results/view_gate_rule_*.txt). A body lying across the image reads as a
camera rolled about a quarter turn to both: the camera-frame network answers for the poses
turned back (below), reading the trunk as up as the body-frame network does, and in sequence
mode the up model weighs that hypothesis against a lying body under a level camera
(:mod:`pcnet.stages.up_model`, docs/up_model.md). Measured on motion capture:
benchmarks/results/view_gate.txt (benchmarks/view_gate.py) and, against the two earlier
releases' rules, benchmarks/results/view_gate_rule_*.txt (benchmarks/view_gate_rule.py).

A camera turned a quarter turn about its optical axis (a phone in portrait) is exactly a
level camera whose image was turned: turning the poses back by 90 deg (:func:`quarter_turns`,
from the body-frame network's signed roll estimate) gives the camera-frame network the view it
was trained on, and its answer turned forward again is the same as for the level camera,
frame for frame. So the gate runs in that turned frame
(:class:`pcnet.models.inference.ViewGatedPCNet`). Half turns are not taken: cameras are
level or in portrait (the up model's camera prior, :mod:`pcnet.stages.up_model`), while a body that
reads as upside down is far more often a body upside down or getting up from the floor, for
which the camera-frame network's level-camera prior in the turned frame would make a wrong
answer firmer (first built with half turns, DeepMimic's get-up-from-lying clip erred 164 deg
median on those frames against the body-frame network's 145, and 64 of its frames lost their
heading in sequence mode); the body-frame network answers an estimate near 180 deg.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter
from scipy.spatial.transform import Rotation

from pcnet.stages.core.rotations import axis_rotation, decompose_camera_rotation

#: Camera-frame network weight ramps (degrees): full weight up to the first value, none from
#: the second on. Roll: where the camera-frame network stops being the more accurate one
#: (module docstring); chosen between 5-15 and 10-20 deg (benchmarks/view_gate_rule.py) with the
#: CMU test subjects and DeepMimic in view as well as the validation split (README, view-gate
#: section); hand-set: fitted on the validation split the roll constants and the window lose on
#: held-out data (decision 0040, ``python -m benchmarks.fit_view_gate``); taken out, per-frame
#: tilt on held-out rolled cameras worsens (decision 0110, ``benchmarks/results/ablation_view_gate.txt``).
ROLL_RAMP_DEG = (10.0, 20.0)
#: Pitch: fitted on the validation split's "paper", "wide", fully rolled and steep views (a
#: further 30-80 deg down) by ``python -m benchmarks.fit_gate_pitch --data ../shared/data``
#: (decision 0063, ``benchmarks/results/fit_gate_pitch.txt``; tests/test_view_gate.py checks
#: these equal it), with :data:`BODY_ESTIMATE_LIMIT_PITCH_DEG`.
PITCH_RAMP_DEG = (40.0, 55.0)
#: Beyond these body-frame estimates (roll, pitch ramps, degrees) the camera-frame network's
#: own estimate no longer keeps it in. Roll hand-set (above); pitch fitted (above).
BODY_ESTIMATE_LIMIT_ROLL_DEG = (45.0, 60.0)
BODY_ESTIMATE_LIMIT_PITCH_DEG = (45.0, 60.0)
#: Running-median window of the camera view estimate, seconds; hand-set (above). Frame and smooth
#: modes only: the up model's evidence reads each frame at its own quarter turn
#: (:func:`frame_quarter_turns`, decision 0074).
WINDOW_S = 2.0


def _ramp(x: np.ndarray, full: float, none: float) -> np.ndarray:
    return np.clip((none - x) / (none - full), 0.0, 1.0)


def window_frames(fps: float) -> int:
    """Frames of the camera view estimate's running median: :data:`WINDOW_S` at ``fps``, odd, at least 1."""
    return max(1, int(round(WINDOW_S * fps)) | 1)


def camera_view_estimate(R: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """The camera's ``|roll|`` and ``|pitch|`` (degrees, each ``(T,)`` float64) that ``(T, 3, 3)``
    canonical->camera rotations (finite, one recording in frame order) imply, as running
    medians over ``size`` frames (scipy ``median_filter``, edges repeated);
    :func:`pcnet.stages.core.rotations.decompose_camera_rotation`'s angles."""
    _, pitch, roll = decompose_camera_rotation(R)
    return (median_filter(np.degrees(np.abs(roll)), size=size, mode="nearest"),
            median_filter(np.degrees(np.abs(pitch)), size=size, mode="nearest"))


def camera_frame_weight(R_body_net: np.ndarray, valid: np.ndarray, fps: float = 30.0,
                        R_camera_net: np.ndarray | None = None,
                        roll_ramp_deg: tuple[float, float] = ROLL_RAMP_DEG,
                        body_roll_limit_deg: tuple[float, float] = BODY_ESTIMATE_LIMIT_ROLL_DEG) -> np.ndarray:
    """Weight of the camera-frame network per frame, from both networks' camera view estimates.

    ``w = max(in(body), in(camera) * near(body))``: ``in`` is 1 inside the training views
    less a margin (:data:`ROLL_RAMP_DEG`, :data:`PITCH_RAMP_DEG`), ``near`` 1 while the
    body-frame estimate is not far beyond them (:data:`BODY_ESTIMATE_LIMIT_ROLL_DEG`,
    :data:`BODY_ESTIMATE_LIMIT_PITCH_DEG`), each a product of linear ramps in roll and pitch.

    Args:
        R_body_net: ``(T, 3, 3)`` canonical->camera rotations of the body-frame 3DPCNet
            (docs/CONVENTIONS.md), NaN where not valid.
        valid: ``(T,)`` bool, the frames with a rotation.
        fps: frame rate (Hz) that sets the running-median window (:data:`WINDOW_S`); one
            recording per call.
        R_camera_net: ``(T, 3, 3)`` the camera-frame 3DPCNet's rotations; ``None`` uses the
            body-frame estimate alone (``w = in(body)``).
        roll_ramp_deg: the roll ramp of ``in`` (default :data:`ROLL_RAMP_DEG`; earlier
            releases used ``(20, 30)``, benchmarks/view_gate_rule.py).
        body_roll_limit_deg: the roll ramp of ``near`` (default
            :data:`BODY_ESTIMATE_LIMIT_ROLL_DEG`). Both at ``(180, 360)`` take roll out of the
            gate, which then reads pitch alone (the ablation's row, decision 0110).

    Returns:
        ``(T,)`` float64 in [0, 1]; NaN where not valid. Pitch and roll are
        :func:`pcnet.stages.core.rotations.decompose_camera_rotation`'s, their absolute values
        median-filtered over the valid frames in order.
    """
    weight = np.full(len(valid), np.nan)
    idx = np.flatnonzero(valid)
    if len(idx) == 0:
        return weight
    size = window_frames(fps)
    roll_b, pitch_b = camera_view_estimate(R_body_net[idx], size)
    weight[idx] = _ramp(roll_b, *roll_ramp_deg) * _ramp(pitch_b, *PITCH_RAMP_DEG)
    if R_camera_net is not None:
        roll_c, pitch_c = camera_view_estimate(R_camera_net[idx], size)
        kept_in = (_ramp(roll_c, *roll_ramp_deg) * _ramp(pitch_c, *PITCH_RAMP_DEG)
                   * _ramp(roll_b, *body_roll_limit_deg) * _ramp(pitch_b, *BODY_ESTIMATE_LIMIT_PITCH_DEG))
        weight[idx] = np.maximum(weight[idx], kept_in)
    return weight


def quarter_turns(R_body_net: np.ndarray, valid: np.ndarray, fps: float = 30.0) -> np.ndarray:
    """Quarter turns ``k`` (0, 1 or 3) of the camera about its optical axis per frame, for the
    gate of frame and smooth modes: the multiple of 90 deg nearest the body-frame network's
    signed roll estimate, 0 where that is 180 deg (module docstring: no half turns; roll of
    :func:`pcnet.stages.core.rotations.decompose_camera_rotation`; its cosine and sine each
    median-filtered over :func:`window_frames` valid frames in order, so a few hard poses do not
    turn the frame while a phone turned during the recording does).

    Args:
        R_body_net: ``(T, 3, 3)`` canonical->camera rotations of the body-frame 3DPCNet
            (docs/CONVENTIONS.md), NaN where not valid.
        valid: ``(T,)`` bool.
        fps: frame rate (Hz) of the window.

    Returns:
        ``(T,)`` int64 in {0, 1, 3}, 0 where not valid. :func:`quarter_turn_matrices` of ``k``
        turns the camera back: ``X' = X @ Q_k.T`` is level within 45 deg of roll, or (no half
        turn) upside down within 45 deg.
    """
    return _turns(R_body_net, valid, window_frames(fps))


def frame_quarter_turns(R_body_net: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Each frame's own quarter turn ``k`` (0, 1 or 3): :func:`quarter_turns`' rule with one
    frame as its window. The up model's evidence reads the camera-frame network on each frame
    turned back by it (decision 0074): the up model scores each frame alone, so its evidence
    needs no window, and a body lying in some frames does not turn its standing frames.

    Args:
        R_body_net: ``(T, 3, 3)`` canonical->camera rotations of the body-frame 3DPCNet, NaN
            where not valid.
        valid: ``(T,)`` bool.

    Returns:
        ``(T,)`` int64 in {0, 1, 3}, 0 where not valid.
    """
    return _turns(R_body_net, valid, 1)


def _turns(R_body_net: np.ndarray, valid: np.ndarray, size: int) -> np.ndarray:
    """The multiple of 90 deg (``k`` in {0, 1, 3}) nearest the body-frame network's roll, its
    cosine and sine median-filtered over ``size`` valid frames; a half turn (k = 2) is 0 (module
    docstring); 0 where not valid."""
    k = np.zeros(len(valid), np.int64)
    idx = np.flatnonzero(valid)
    if len(idx):
        roll = decompose_camera_rotation(R_body_net[idx])[2]
        cos_roll = median_filter(np.cos(roll), size=size, mode="nearest")  # size 1: the frame's own
        sin_roll = median_filter(np.sin(roll), size=size, mode="nearest")
        turn = np.round(np.arctan2(sin_roll, cos_roll) / (np.pi / 2)).astype(np.int64) % 4
        k[idx] = np.where(turn == 2, 0, turn)
    return k


def quarter_turn_matrices(k: np.ndarray) -> np.ndarray:
    """``(T, 3, 3)`` rotations about the camera's optical axis (+z) by ``-90 k`` deg: applied to a
    camera frame turned by ``k`` quarter turns (``X' = X @ Q.T``, ``R' = Q R``), they turn it back."""
    # Rounded so that the turn is exact: a quarter-turned camera then gives bit-for-bit the
    # level camera's input.
    return np.rint(axis_rotation("z", -np.pi / 2 * np.asarray(k, np.float64)))


def blend_rotations(R_body: np.ndarray, R_camera: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Geodesic interpolation ``R_body exp(w log(R_body^T R_camera))`` per frame.

    Args:
        R_body, R_camera: ``(T, 3, 3)`` rotation matrices (any one convention, the same for
            both); weight: ``(T,)`` in [0, 1], 1 = ``R_camera``.

    Returns:
        ``(T, 3, 3)`` float64; NaN where either input or the weight is NaN.
    """
    out = np.full(R_body.shape, np.nan)
    ok = np.isfinite(R_body).all(axis=(1, 2)) & np.isfinite(R_camera).all(axis=(1, 2)) & np.isfinite(weight)
    if ok.any():
        relative = Rotation.from_matrix(np.swapaxes(R_body[ok], 1, 2) @ R_camera[ok]).as_rotvec()
        out[ok] = R_body[ok] @ Rotation.from_rotvec(relative * weight[ok, None]).as_matrix()
    return out
