"""The social-force model of the crowd's local motion, per unit mass (accelerations, m/s^2).

The circular specification of Helbing, Farkas & Vicsek (2000), with the anisotropy of
Helbing & Johansson (2009) and a bias to pass on the right:

* driving: ``(v0 e - v) / tau``: relax to the preferred speed ``v0`` along the desired
  direction ``e`` (towards the next point of the person's path) within ``tau``;
* another person j (or a robot), at centre distance ``d`` with radii summing to ``r``:
  ``A exp((r - d) / B) w(phi)`` along ``n`` (the unit vector from j to i), where
  ``w(phi) = lam + (1 - lam) (1 + cos phi) / 2`` weighs people ahead (cos phi = -n . e_i)
  over those behind. For someone ahead the direction is ``n`` turned by
  ``pass_angle * cos phi`` towards i's right, so two people meeting head on both step to
  their right instead of stopping nose to nose. Bodies that overlap also push apart with
  ``contact * (r - d)`` along ``n`` (the body force);
* a wall at clearance ``d`` from i's centre, whose distance grows along ``n``:
  ``A_w exp((r_i - d) / B_w)`` along ``n``, plus the body force on overlap.

Only pairs closer than ``cutoff`` interact: the crowd finds them with a k-d tree, so one step
costs about linearly in the number of people (crowd.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from ...errors import ConfigError
from ...sim.checks import check_numbers

__all__ = ["ForceConfig", "driving", "repulsion", "wall_repulsion", "limit_speed"]


@dataclass(frozen=True)
class ForceConfig:
    """Social-force parameters (per unit mass: m/s^2, m, s).

    Attributes:
        tau: relaxation time of the driving term (Helbing & Molnar 1995: 0.5 s).
        strength, range: ``A`` and ``B`` of the person (and robot) repulsion.
        anisotropy: ``lam``: the weight of someone straight behind relative to straight
            ahead (1 = isotropic).
        pass_angle: how far (radians) the repulsion of someone straight ahead is turned to
            one's right.
        contact: body force per metre of overlap (1/s^2).
        wall_strength, wall_range: ``A_w`` and ``B_w`` of the wall repulsion.
        cutoff: people farther apart than this (centre to centre, m) do not interact.
        max_speed_factor: a person's speed is capped at this times its preferred speed
            (Helbing 2000: 1.3).
        horizon: seconds ahead the repulsion looks: it acts at the distance two people will
            be at their closest within this time, at their present velocities (0: now).
    """

    tau: float = 0.5
    strength: float = 2.0
    range: float = 0.4
    anisotropy: float = 0.3
    pass_angle: float = 0.35
    contact: float = 60.0
    wall_strength: float = 3.0
    wall_range: float = 0.15
    cutoff: float = 2.5
    max_speed_factor: float = 1.3
    horizon: float = 1.5

    def validate(self, where: str) -> None:
        """Raise ConfigError naming the first bad value."""
        check_numbers(self, ("tau", "range", "wall_range", "cutoff", "max_speed_factor"), where)
        check_numbers(self, ("strength", "contact", "wall_strength", "pass_angle", "horizon"),
                      where, strict=False)
        if not 0.0 <= self.anisotropy <= 1.0:
            raise ConfigError("%s: anisotropy must be in [0, 1], got %r"
                              % (where, self.anisotropy))
        if self.max_speed_factor < 1.0:
            raise ConfigError("%s: max_speed_factor must be >= 1, got %r"
                              % (where, self.max_speed_factor))


def driving(vel: np.ndarray, desired: np.ndarray, tau: float) -> np.ndarray:
    """``(desired - vel) / tau`` row by row: (N, 2) velocities and desired velocities."""
    return (desired - vel) / tau


def repulsion(pos: np.ndarray, heading: np.ndarray, radius: np.ndarray,
              other_pos: np.ndarray, other_radius: np.ndarray, i: np.ndarray, j: np.ndarray,
              cfg: ForceConfig, vel: Optional[np.ndarray] = None,
              other_vel: Optional[np.ndarray] = None) -> np.ndarray:
    """The force on each person from others: pairs (i[k], j[k]) say person i[k] feels
    other j[k] (both directions of a person pair are two entries).

    Args:
        pos, heading, radius: the people's (N, 2) positions, (N, 2) unit walking directions
            (zero for someone standing: then the weight is that of someone beside) and (N,)
            body radii.
        other_pos, other_radius: (M, 2) and (M,) of the others (the people again, or robots).
        i, j: (K,) indices into the people and the others.

    Returns:
        (N, 2) summed forces.
    """
    out = np.zeros_like(pos, dtype=float)
    if not len(i):
        return out
    now = pos[i] - other_pos[j]
    dist_now = np.hypot(now[:, 0], now[:, 1])
    n_now = now / np.maximum(dist_now, 1e-9)[:, None]
    d = now
    if vel is not None and cfg.horizon > 0:   # where they will be closest, within the horizon
        u = vel[i] - (other_vel[j] if other_vel is not None else 0.0)
        uu = u[:, 0] ** 2 + u[:, 1] ** 2
        t = np.clip(-(now[:, 0] * u[:, 0] + now[:, 1] * u[:, 1]) / np.maximum(uu, 1e-12),
                    0.0, cfg.horizon)
        d = now + u * t[:, None]
    dist = np.hypot(d[:, 0], d[:, 1])
    # head on, the predicted offset vanishes: then the side is the present one
    n = np.where(dist[:, None] > 1e-6, d / np.maximum(dist, 1e-9)[:, None], n_now)
    r = radius[i] + other_radius[j]
    e = heading[i]
    cos_phi = -(n_now[:, 0] * e[:, 0] + n_now[:, 1] * e[:, 1])
    lam = cfg.anisotropy
    mag = cfg.strength * np.exp((r - dist) / cfg.range) * (lam + (1.0 - lam) * 0.5 * (1.0 + cos_phi))
    turn = cfg.pass_angle * np.maximum(cos_phi, 0.0)
    c, s = np.cos(turn), np.sin(turn)
    direction = np.column_stack((c * n[:, 0] - s * n[:, 1], s * n[:, 0] + c * n[:, 1]))
    # n points from the other to i: for someone ahead it points against e (-x where e is +x),
    # and turned counter-clockwise it gains a -y part: i's right
    f = (mag[:, None] * direction
         + (cfg.contact * np.maximum(r - dist_now, 0.0))[:, None] * n_now)
    np.add.at(out, i, f)
    return out


def wall_repulsion(clearance: np.ndarray, normal: np.ndarray, radius: np.ndarray,
                   cfg: ForceConfig) -> np.ndarray:
    """(N, 2) wall forces from each person's (N,) clearance to the nearest wall (m, from its
    centre) and the (N, 2) unit direction in which that clearance grows."""
    mag = cfg.wall_strength * np.exp((radius - clearance) / cfg.wall_range)
    mag = mag + cfg.contact * np.maximum(radius - clearance, 0.0)
    return mag[:, None] * normal


def limit_speed(vel: np.ndarray, limit: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Velocities (N, 2) scaled down to at most ``limit`` (N,) m/s; also their speeds."""
    speed = np.hypot(vel[:, 0], vel[:, 1])
    over = speed > limit
    if over.any():
        vel = vel.copy()
        vel[over] *= (limit[over] / speed[over])[:, None]
        speed = np.where(over, limit, speed)
    return vel, speed
