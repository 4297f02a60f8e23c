"""Static-camera up: a posterior over up from the pose evidence and a camera prior.

A pose alone cannot tell some recordings apart: a body lying straight on the floor filmed by
a level camera shows the same camera-frame skeleton as a body standing straight filmed by a
camera rolled 90 deg, and a network that reads every body as upright answers "standing".
Sequence mode (one static camera) therefore combines two readings of the body with a prior
over the camera's orientation (Bayes' rule on the unit sphere S^2, camera frame, OpenCV axes:
x right, y down, z forward, so a level camera sees up = -y):

    p(u | poses) ~ [(1 - eps) vMF(u; m, k_pose) + eps G(u; t, k_girdle)]
                   x [w_level vMF(u; -y, k_camera) + (1 - w_level) / (4 pi)]

- **upright** reading: up near ``m``, the pose-based (and ground-plane) sequence up, with
  concentration ``k_pose = 1 / sigma_pose^2`` (``sigma_pose`` in radians: the pose evidence's
  systematic error, :data:`pcnet.stages.uncertainty.SIGMA_SYS_DEG`, with the bootstrap's);
- **lying** reading (prior probability :data:`LYING_PRIOR`): the trunk is near horizontal,
  so up is perpendicular to the mean trunk direction ``t`` (pelvis -> thorax), otherwise
  unknown: the girdle ``G(u) ~ exp(-k_girdle (u . t)^2)`` with ``k_girdle = 1 / (2 sigma^2)``,
  ``sigma =`` :data:`GIRDLE_SIGMA_DEG`;
- **camera prior**: with probability :data:`LEVEL_CAMERA_PRIOR` a camera within about
  :data:`LEVEL_CAMERA_SIGMA_DEG` of level (tripods, hand-held phones: landscape or portrait
  video both show the scene upright), otherwise any orientation (uniform), so an upside-down
  or sideways-stored video keeps its pose-based up instead of being pulled to level.

``vMF(u; mu, k) = k / (4 pi sinh k) exp(k u . mu)`` is the von Mises-Fisher density
(Mardia & Jupp, "Directional Statistics", 2000, section 9.3.2; angular std ~ 1/sqrt(k)).
The reading with the larger posterior mass is reported (``p_lying``), and its up is the
mode of the posterior within that reading. The masses are integrated on a Fibonacci grid
of :data:`GRID_POINTS` directions (about 1 deg apart); the upright mode is found by the
fixed-point iteration of the product of a vMF with a vMF mixture (exact for the model), the
lying mode on the grid (its interval is tens of degrees wide anyway).

The constants are priors, not fitted to any benchmark: the share of lying recordings and
the spread of camera tilt are assumptions about pcnet's users (rehabilitation exercises are
often filmed lying; most cameras stand within 20 deg of level) and are stated in the run's
report. What the model cannot do: a straight body filmed by a camera rolled 90 deg is read
as lying (the readings are the same skeleton); the report's ``p_lying`` and the run summary
say which reading was taken and how sure it was.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .core.rotations import camera_pitch_roll, normalize

#: Prior probability that the body lies (trunk near horizontal) in a recording.
LYING_PRIOR = 0.1
#: Angular std (deg) of a lying trunk about the horizontal plane (pillows, bridges, cobra).
GIRDLE_SIGMA_DEG = 15.0
#: Prior probability of a camera near level; the rest is uniform over S^2.
LEVEL_CAMERA_PRIOR = 0.9
#: Angular std (deg) of a near-level camera's up about the image's -y axis.
LEVEL_CAMERA_SIGMA_DEG = 20.0
#: Directions of the integration grid.
GRID_POINTS = 40_000
#: Camera-frame up of a level camera (OpenCV axes, y down).
LEVEL_UP = np.array([0.0, -1.0, 0.0])

_FOUR_PI = 4.0 * np.pi

#: Posterior probability of the reading not reported from which the printed 95 % interval
#: reaches it (a region holding 95 % of the posterior must hold some of a reading with more
#: than 5 %): :attr:`GravityPosterior.pitch_half_both_deg` (docs/experiments.md, "A 95 %
#: interval that reaches the other reading").
OTHER_READING_P = 0.05


@dataclass(frozen=True)
class GravityPosterior:
    """Result of :func:`gravity_posterior`.

    up: ``(3,)`` unit camera-frame up of the chosen reading; reading: ``"upright"`` or
    ``"lying"``; p_lying: posterior probability of the lying reading; interval_deg: 95 %
    cone half-angle of the posterior within the chosen reading (deg); pitch_half_deg,
    roll_half_deg: 95 % half-widths of camera pitch / roll within the chosen reading (deg,
    :func:`pcnet.stages.core.rotations.decompose_camera_rotation`'s angles);
    pose_camera_angle_deg: angle between the pose-based up and a level camera's up;
    pitch_half_both_deg, roll_half_both_deg: the same half-widths around the chosen up over the
    whole posterior, both readings (what a 95 % interval must reach when the other reading
    keeps more than 5 %: :data:`OTHER_READING_P`).
    """

    up: np.ndarray
    reading: str
    p_lying: float
    interval_deg: float
    pitch_half_deg: float
    roll_half_deg: float
    pose_camera_angle_deg: float
    pitch_half_both_deg: float = float("nan")
    roll_half_both_deg: float = float("nan")

    @property
    def other_reading_p(self) -> float:
        """Posterior probability of the reading not reported."""
        return min(self.p_lying, 1.0 - self.p_lying)

    def report(self) -> dict:
        """JSON-ready summary with the priors used."""
        return {"reading": self.reading, "p_lying": round(self.p_lying, 4),
                "interval_deg": round(self.interval_deg, 2),
                "pose_camera_angle_deg": round(self.pose_camera_angle_deg, 2),
                "priors": {"lying": LYING_PRIOR, "girdle_sigma_deg": GIRDLE_SIGMA_DEG,
                           "level_camera": LEVEL_CAMERA_PRIOR, "level_camera_sigma_deg": LEVEL_CAMERA_SIGMA_DEG}}


def fibonacci_sphere(n: int) -> np.ndarray:
    """``(n, 3)`` float64 near-uniform unit vectors (Fibonacci lattice; Gonzalez 2010, "Measurement
    of areas on a sphere using Fibonacci and latitude-longitude lattices", Math. Geosci. 42)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    phi = np.pi * (1.0 + 5.0 ** 0.5) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)


def _log_vmf(cos: np.ndarray, kappa: float) -> np.ndarray:
    """log vMF density on S^2 at ``cos = u . mu`` (overflow-free log sinh)."""
    log_sinh = kappa + np.log1p(-np.exp(-2.0 * kappa)) - np.log(2.0)
    return np.log(kappa) - np.log(_FOUR_PI) - log_sinh + kappa * cos


def _log_girdle(cos: np.ndarray, kappa: float) -> np.ndarray:
    """log of the girdle density ``exp(-kappa cos^2) / Z`` on S^2,
    ``Z = 2 pi sqrt(pi / kappa) erf(sqrt(kappa))``."""
    from scipy.special import erf

    log_z = np.log(2.0 * np.pi * np.sqrt(np.pi / kappa) * erf(np.sqrt(kappa)))
    return -kappa * cos ** 2 - log_z


def _upright_mode(m: np.ndarray, k_pose: float, k_cam: float, log_w_level: float, log_w_uniform: float) -> np.ndarray:
    """Mode of ``vMF(m, k_pose) x [w vMF(c, k_cam) + (1 - w) / 4pi]``: the stationarity
    condition is ``u ~ k_pose m + k_cam r(u) c`` with ``r`` the level component's
    responsibility at ``u``; iterated from ``m``."""
    u = m
    for _ in range(50):
        a = log_w_level + _log_vmf(np.dot(u, LEVEL_UP), k_cam)
        r = 1.0 / (1.0 + np.exp(log_w_uniform - np.log(_FOUR_PI) - a))
        new = normalize(k_pose * m + k_cam * r * LEVEL_UP)
        if np.dot(new, u) > 1.0 - 1e-15:
            return new
        u = new
    return u


def _half_widths(grid: np.ndarray, p: np.ndarray, up: np.ndarray) -> tuple[float, float, float]:
    """95 % cone half-angle and pitch / roll half-widths (deg) of grid weights ``p`` about ``up``."""
    def q95(x):
        order = np.argsort(x)
        c = np.cumsum(p[order])
        return float(x[order][min(np.searchsorted(c, 0.95 * c[-1]), len(x) - 1)])

    cone = np.degrees(np.arccos(np.clip(grid @ up, -1.0, 1.0)))
    pitch, roll = np.degrees(camera_pitch_roll(grid))
    p0, r0 = np.degrees(camera_pitch_roll(up))
    dr = (roll - r0 + 180.0) % 360.0 - 180.0
    return q95(cone), q95(np.abs(pitch - p0)), q95(np.abs(dr))


def gravity_posterior(pose_up: np.ndarray, pose_sigma_deg: float, trunk: np.ndarray | None) -> GravityPosterior:
    """Posterior over a static camera's up (module docstring).

    Args:
        pose_up: ``(3,)`` camera-frame up from the poses (and floor contacts), unit.
        pose_sigma_deg: its angular std (deg), > 0: systematic error and sampling spread.
        trunk: ``(3,)`` mean camera-frame trunk direction (pelvis -> thorax, any length), or
            ``None`` (no lying reading).

    Returns:
        :class:`GravityPosterior`.

    Raises:
        ValueError: non-finite or zero ``pose_up``, non-positive ``pose_sigma_deg``.
    """
    m = np.asarray(pose_up, np.float64)
    if m.shape != (3,) or not np.isfinite(m).all() or np.linalg.norm(m) < 1e-9:
        raise ValueError(f"pose_up: expected a finite non-zero 3-vector, got {pose_up!r}")
    if not pose_sigma_deg > 0:
        raise ValueError(f"pose_sigma_deg: expected > 0, got {pose_sigma_deg!r}")
    m = normalize(m, eps=0.0)  # the check above is the length threshold
    k_pose = 1.0 / np.radians(pose_sigma_deg) ** 2
    k_cam = 1.0 / np.radians(LEVEL_CAMERA_SIGMA_DEG) ** 2
    k_girdle = 1.0 / (2.0 * np.radians(GIRDLE_SIGMA_DEG) ** 2)
    grid = fibonacci_sphere(GRID_POINTS)
    log_cam = np.logaddexp(np.log(LEVEL_CAMERA_PRIOR) + _log_vmf(grid @ LEVEL_UP, k_cam),
                           np.log(1.0 - LEVEL_CAMERA_PRIOR) - np.log(_FOUR_PI))
    log_upright = np.log(1.0 - LYING_PRIOR) + _log_vmf(grid @ m, k_pose) + log_cam
    have_trunk = trunk is not None and np.isfinite(trunk).all() and np.linalg.norm(trunk) > 1e-9
    if have_trunk:
        t = normalize(np.asarray(trunk, np.float64), eps=0.0)
        log_lying = np.log(LYING_PRIOR) + _log_girdle(grid @ t, k_girdle) + log_cam
    else:
        log_lying = np.full(len(grid), -np.inf)
    # Masses (the grid's equal cell areas cancel in the ratio).
    top = max(log_upright.max(), log_lying.max())
    mass_up, mass_lying = np.exp(log_upright - top).sum(), np.exp(log_lying - top).sum()
    p_lying = float(mass_lying / (mass_up + mass_lying))
    angle = float(np.degrees(np.arccos(np.clip(np.dot(m, LEVEL_UP), -1, 1))))
    if p_lying > 0.5:
        weights = np.exp(log_lying - log_lying.max())
        up, reading = grid[int(np.argmax(log_lying))], "lying"
    else:
        weights = np.exp(log_upright - log_upright.max())
        up = _upright_mode(m, k_pose, k_cam, np.log(LEVEL_CAMERA_PRIOR), np.log(1.0 - LEVEL_CAMERA_PRIOR))
        reading = "upright"
    cone, pitch_half, roll_half = _half_widths(grid, weights, up)
    both = np.logaddexp(log_upright, log_lying)
    _, pitch_both, roll_both = _half_widths(grid, np.exp(both - both.max()), up)
    return GravityPosterior(up, reading, p_lying, cone, pitch_half, roll_half, angle, pitch_both, roll_both)
