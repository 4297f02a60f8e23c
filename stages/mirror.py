"""Is a 3D skeleton a mirror image of a body? A test from the way knees and elbows bend.

A mirror image (a depth axis of the wrong sign, an ``--axes`` mistake, or left and right
labels exchanged) is no rotation of a body: the rectification still finds an up, and every
sagittal angle comes out with its sign reversed. What tells a body from its mirror image is
its chirality, and H36M-17 carries it in two hinges that bend one way only: a knee flexes
backward, an elbow forward. With the body's right ``r`` (unit, left hip -> right hip), each
side's signed bend is

    b_knee  = -(t x s) . r / (|t| |s|),   t = knee - hip,      s = ankle - knee
    b_elbow =  (u x f) . r / (|u| |f|),   u = elbow - shoulder, f = wrist - elbow

(the sine of the flexion about the body's right, positive for a body's bend: canonical frame
``X = Y x Z`` forward, ``Y`` up, ``Z`` right, docs/CONVENTIONS.md). Each frame's cue is the
mean over the present sides; a recording's is the median over frames, ``m = (m_knee,
m_elbow)``. Mirroring negates both (a reflection changes the sign of every triple product).

The model: a body's ``m ~ N(mu, S)``, its mirror image's ``m ~ N(-mu, S)``, with ``mu`` and ``S``
the mean and covariance of ``m`` over the training motion capture seen through the
lifter-noise model (fitted by ``python -m benchmarks.fit_mirror_flag --data ../shared/data``,
stored with its provenance in ``stages/data/mirror_flag.json``). The log posterior odds of a
mirror image at even prior odds are the linear discriminant

    log LR = log N(m; -mu, S) - log N(m; mu, S) = -2 mu^T S^-1 m,

and the flag fires where they reach :data:`MIRROR_ODDS` (a 95 % posterior, the level of
pcnet's intervals). A skeleton with straight limbs carries no chirality (``m`` near 0, odds
near 1) and is not called mirrored: the nose, which earlier versions used, is absent from
mocap skeletons that put H36M's joint 9 on the neck.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from .core.conventions import (L_ANKLE, L_ELBOW, L_HIP, L_KNEE, L_SHOULDER, L_WRIST, R_ANKLE, R_ELBOW, R_HIP,
                               R_KNEE, R_SHOULDER, R_WRIST)
from .core.errors import InputError
from .core.framestore import frame_blocks

#: The shipped fit (``pcnet/stages/data/mirror_flag.json``).
MIRROR_PATH = Path(__file__).resolve().parent / "data" / "mirror_flag.json"
#: Posterior odds of a mirror image against a body (even prior odds) from which the flag
#: fires: 19 to 1, a 95 % posterior, the level of every interval pcnet prints. Declared, not
#: fitted: how often users hand pcnet mirrored files is unknown.
MIRROR_ODDS = 19.0
CUES = ("knee", "elbow")


@dataclass(frozen=True)
class MirrorModel:
    """The fitted cue distribution of a body's skeleton (:mod:`pcnet.stages.mirror`).

    Attributes:
        mean: ``(2,)`` float64 ``mu``, the mean of a recording's median (knee, elbow) bend
            sines (dimensionless).
        cov: ``(2, 2)`` float64 ``S``, their covariance over recordings.
        provenance: command, data, split and date of the fit.
    """

    mean: np.ndarray
    cov: np.ndarray
    provenance: MappingProxyType

    def log_odds(self, m: np.ndarray) -> float:
        """Log posterior odds (natural log, even prior odds) that ``m`` ``(2,)`` comes from a
        mirror image: ``-2 mu^T S^-1 m``."""
        return float(-2.0 * np.linalg.solve(self.cov, self.mean) @ m)


def load_mirror_model(path: str | Path | None = None) -> MirrorModel:
    """Read the mirror test's fit (JSON with ``cues``, ``mean``, ``cov``, ``provenance``;
    default: the shipped :data:`MIRROR_PATH`).

    Raises:
        FileNotFoundError: no such file.
        InputError: not JSON, a field missing, or ``mean``/``cov`` not a finite 2-vector and a
            symmetric positive-definite 2x2 matrix (named in the message).
    """
    path = Path(MIRROR_PATH if path is None else path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        cues, mean, cov, provenance = data["cues"], data["mean"], data["cov"], data["provenance"]
    except json.JSONDecodeError as err:
        raise InputError(f"{path}: expected a JSON mirror-test fit, got unreadable JSON ({err})") from err
    except (KeyError, TypeError) as err:
        raise InputError(f"{path}: field {err.args[0]!r}: expected cues, mean, cov and provenance, got none") from err
    if list(cues) != list(CUES):
        raise InputError(f"{path}: field 'cues': expected {list(CUES)}, got {cues!r}")
    try:
        mean, cov = np.asarray(mean, np.float64), np.asarray(cov, np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f"{path}: fields 'mean', 'cov': expected numbers, got {err}") from err
    if mean.shape != (2,) or not np.isfinite(mean).all():
        raise InputError(f"{path}: field 'mean': expected 2 finite numbers, got {data['mean']!r}")
    if cov.shape != (2, 2) or not np.isfinite(cov).all() or not np.allclose(cov, cov.T) \
            or np.linalg.eigvalsh(cov).min() <= 0:
        raise InputError(f"{path}: field 'cov': expected a symmetric positive-definite 2x2 matrix, got {data['cov']!r}")
    return MirrorModel(mean, cov, MappingProxyType(dict(provenance)))


def _bend_sine(J: np.ndarray, a: int, b: int, c: int, right: np.ndarray) -> np.ndarray:
    u, v = J[:, b] - J[:, a], J[:, c] - J[:, b]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.einsum("ij,ij->i", np.cross(u, v), right) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))


def limb_bend_sines(joints) -> np.ndarray:
    """``(T, 2)`` float64 each frame's (knee, elbow) signed bend sine, the mean over the sides
    present (formula in :mod:`pcnet.stages.mirror`): positive where the hinge bends as a
    body's does, negative for a mirror image, NaN where no side or no hip line is present.

    Args:
        joints: ``(T, 17, 3)`` H36M-17 poses in any frame and units, NaN = missing (read a
            block of frames at a time: may be on disk).
    """
    out = []
    for rows in frame_blocks(len(joints)):
        J = np.asarray(joints[rows], np.float64)
        right = J[:, R_HIP] - J[:, L_HIP]
        with np.errstate(invalid="ignore", divide="ignore"):
            right = right / np.linalg.norm(right, axis=1, keepdims=True)
        knees = -np.stack([_bend_sine(J, R_HIP, R_KNEE, R_ANKLE, right), _bend_sine(J, L_HIP, L_KNEE, L_ANKLE, right)])
        elbows = np.stack([_bend_sine(J, R_SHOULDER, R_ELBOW, R_WRIST, right),
                           _bend_sine(J, L_SHOULDER, L_ELBOW, L_WRIST, right)])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # both sides missing: NaN is the answer
            out.append(np.stack([np.nanmean(knees, 0), np.nanmean(elbows, 0)], 1))
    return np.concatenate(out) if out else np.zeros((0, 2))


def recording_cues(joints) -> tuple[np.ndarray, int]:
    """A recording's ``m`` ``(2,)`` float64 (median over frames of :func:`limb_bend_sines`,
    frames where both cues are finite) and the number of those frames (0: ``m`` is NaN)."""
    bends = limb_bend_sines(joints)
    bends = bends[np.isfinite(bends).all(axis=1)]
    if not len(bends):
        return np.full(2, np.nan), 0
    return np.median(bends, axis=0), len(bends)

