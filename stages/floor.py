"""The ground under a recording: one horizontal plane fitted to stance contacts, or a
per-frame fallback (docs/CONVENTIONS.md, "World frame"; used by
:func:`pcnet.stages.world_frame.to_world`).

Model (world frame, +Y up, any one length unit). In frame ``t`` let ``m_t`` be the height of
the lowest joint centre (a stance ankle when upright, the lowest resting body part when
lying). A joint resting on the ground ``y = g`` has

    m_t = g + c L + e_t,

with ``L`` the subject's leg length (median over frames of hip->knee + knee->ankle, both
legs, in the input's own skeleton), ``c`` = :data:`ANKLE_CLEARANCE_LEG` the height of the
ankle joint centre above the ground at stance as a fraction of the leg (H36M-17 has no sole
or toe joint), and ``e_t`` the contact's noise. Every usable frame (an ankle visible, a path)
is a contact; in a flight frame ``m_t`` is higher, an outlier, and

    g + c L = argmin_a  sum_{t in contacts} rho((m_t - a) / sigma),

``rho`` Tukey's biweight with the standard ``c = 4.685`` (:data:`~pcnet.stages.spherical.TUKEY_C`,
95 % efficiency under Gaussian noise), ``sigma = 1.4826 MAD`` of the contact heights about
their median (fixed), solved by iteratively reweighted least squares from the median
(Huber & Ronchetti, *Robust Statistics*, 2nd ed., 2009, ch. 3 and 6). A body supported at
least half the time (walking, running, standing, lying) has its rests in the majority; a
jump's flight and a heel rising before toe-off are high outliers the biweight rejects. (A
selection of the slower half of the frames by the lowest joint's displacement, shipped before
decision 0071, did not help on held-out mocap and was deleted.)

Why a horizontal plane (only its height fitted), not a tilted one: the world frame's +Y is the
recording's gravity estimate, and with a pelvis path (measured, or recovered from the 2D
keypoints) sequence mode already weighs the floor's tilt from the foot contacts in that estimate (:func:`pcnet.stages.ground_plane.ground_plane_up`,
a term of the up model); a second tilt here would either repeat that fit or contradict the
gravity the accelerations use. A depth scale error of a recovered path
scales it along the camera rays about the camera centre, which moves every stance contact by
the same ``k (h_pelvis - h_camera)``: an offset the height absorbs, no slope. Measured by
``benchmarks/fit_floor.py`` (``benchmarks/results/fit_floor.txt``): a 5 % path scale error
moves the fitted floor under the pelvis by the amounts listed there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .spherical import tukey_weights

#: Height of the ankle joint centre above the ground at stance, as a fraction of the leg
#: length (hip->knee + knee->ankle). Fitted by
#: ``python -m benchmarks.fit_floor --data ../shared/data`` (benchmarks/results/fit_floor.txt)
#: on ../shared/data/mocap/cmu_train_h36m17.npz, training subjects of the motion-style split
#: (models/datasets.py: select_split(..., "train", "motion-style"): CMU subjects 8, 9, 11, 13,
#: 61; world floor y = 0): the median over subjects of each subject's median over clips of
#: this module's contact fit of the ankle-centre plane (true path), over the leg length.
#: Leg rather than shank (knee->ankle): every CMU subject there has the same retargeted
#: skeleton, so the choice was made across the two training rigs (CMU train, Bandai train:
#: the fraction of the leg differs by less between them than the fraction of the shank; see
#: the result file). Refitted under every frame's lowest joint as a contact (decision 0071; 0.1302 before).
ANKLE_CLEARANCE_LEG = 0.1319
#: The fewest contacts for a plane: the robust scale (MAD) of fewer points is zero or undefined.
MIN_CONTACTS = 3

KINDS = ("plane", "per frame", "pelvis")


@dataclass(frozen=True)
class Floor:
    """How the world frame's floor (``y = 0``) was placed.

    kind: ``"plane"`` (one horizontal ground plane for the recording, fitted to stance
        contacts along a pelvis path), ``"per frame"`` (no pelvis path, or too few contacts:
        the ground under each frame's lowest joint centre), or ``"pelvis"`` (no ankle in any
        frame: no ground was seen; heights are relative to the pelvis, ``y = 0`` at the pelvis
        without a path, at its median height with one).
    clearance: height of the ankle-centre (contact) plane above the ground, in the poses'
        units (``ANKLE_CLEARANCE_LEG`` x ``leg_length``; 0 for ``"pelvis"``).
    leg_length: the subject's median leg length, poses' units (NaN when no leg was measured).
    n_contacts: stance contacts the plane was fitted to: usable frames inside the biweight's
        support at the fit (a weight above 0; a flight frame's is 0), 0 unless ``"plane"``.
    residual: robust scale (1.4826 MAD) of the contact heights about the plane, poses' units
        (NaN unless ``"plane"``).
    reason: why the floor is not a fitted plane (``""`` for ``"plane"``).
    """

    kind: str
    clearance: float
    leg_length: float
    n_contacts: int = 0
    residual: float = float("nan")
    reason: str = ""

    def note(self, units: str) -> str:
        """One line for a run's notes: what ``y = 0`` is; lengths in the poses' ``units``
        (e.g. ``"m"``, ``"normalised"``), named after each number."""
        unit = " m" if units == "m" else f" {units} units"  # not in brackets: the summary line drops asides
        if self.kind == "plane":
            return (f"floor: one ground plane for the recording, fitted to {self.n_contacts} stance contacts "
                    f"(residual {self.residual:.3g}{unit}); ankle centres stand {self.clearance:.3g}{unit} above it")
        if self.kind == "per frame":
            return (f"floor per frame ({self.reason}): y = 0 is {self.clearance:.3g}{unit} below each frame's "
                    f"lowest joint centre, assumed on the floor")
        return f"no floor ({self.reason}): heights are relative to the pelvis"


#: The least scale :func:`tukey_location` divides by, so that equal heights give that height.
MIN_SCALE = 1e-12


def tukey_location(x: np.ndarray, max_iter: int = 100) -> tuple[float, float]:
    """Tukey-biweight M-estimate of location of the finite values of ``x`` (``(N,)``, N >= 1)
    and the scale used (1.4826 MAD about the median, fixed; floored at 1e-12 so that equal
    values give that value). IRLS from the median (:func:`~pcnet.stages.spherical.tukey_weights`)."""
    x = np.asarray(x, np.float64)
    x = x[np.isfinite(x)]
    mu = float(np.median(x))
    scale = float(1.4826 * np.median(np.abs(x - mu)))
    s = max(scale, MIN_SCALE)
    for _ in range(max_iter):
        w = tukey_weights((x - mu) / s)
        if not w.sum() > 0:
            break
        new = float(np.sum(w * x) / np.sum(w))
        if abs(new - mu) <= 1e-12 * max(1.0, abs(mu)):
            mu = new
            break
        mu = new
    return mu, scale


def fit_ground(lowest: np.ndarray, usable: np.ndarray, leg_length: float) -> tuple[float, Floor]:
    """The recording's ground plane from per-frame evidence along a pelvis path (module docstring).

    Args:
        lowest: ``(T,)`` height along world +Y of each frame's lowest joint centre (NaN: none).
        usable: ``(T,)`` bool, the frames allowed to hold a contact (an ankle visible, a path).
        leg_length: the subject's median leg length (same unit; NaN: clearance 0).

    Returns:
        ``(ground_y, Floor)``: the height of the ground (``g`` of the module docstring) and
        a :class:`Floor` of kind ``"plane"``; or NaN and a ``"per frame"`` :class:`Floor`
        saying why no plane was fitted (fewer than :data:`MIN_CONTACTS` contacts).
    """
    clearance = ANKLE_CLEARANCE_LEG * leg_length if np.isfinite(leg_length) else 0.0
    c = np.asarray(usable, bool) & np.isfinite(lowest)
    n = int(c.sum())
    if n < MIN_CONTACTS:
        return float("nan"), Floor("per frame", clearance, leg_length,
                                   reason=f"{n} stance contacts along the pelvis path, fewer than {MIN_CONTACTS}")
    level, scale = tukey_location(lowest[c])
    held = int(np.count_nonzero(tukey_weights((lowest[c] - level) / max(scale, MIN_SCALE))))
    return level - clearance, Floor("plane", clearance, leg_length, held, scale)
