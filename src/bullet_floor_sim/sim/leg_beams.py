"""Lidar beams against people's legs: vertical cylinders, met exactly in numpy.

After the beams were cast at the walls (and the robots, robot_beams.py), each beam whose
angle falls within a leg's angular window (robot_beams.circle_candidates) is intersected with
that leg's circle, and its range shortened where the leg is nearer. A laser mounted above the
legs' height sees none. ``world`` is the stepping :class:`~.world.World` (World.cast_beams).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .robot_beams import circle_candidates

__all__ = ["cast_at_legs", "ray_circle"]


def cast_at_legs(world: Any, plan: Any, dist: np.ndarray, hit: np.ndarray,
                 legs: np.ndarray, radius: float, height: float) -> None:
    """Shorten the plan's beams (``dist``/``hit`` in place) that meet a leg first.

    Args:
        legs: (K, 2) map-frame leg centres.
        radius: the legs' radius.
        height: lasers at this height or above see no legs.
    """
    if not len(legs) or not len(plan.robots):
        return
    reach = np.where(hit, dist, plan.full)
    above = plan.origins[plan.first, 2] >= height                           # (Q,)
    radii = np.full((len(plan.robots), len(legs)), float(radius))
    g, k, _, _ = circle_candidates(world, plan, reach, legs, radii,
                                   np.repeat(above[:, None], len(legs), axis=1))
    if not len(g):
        return
    t = ray_circle(plan.origins[g, :2], plan.dirs[g], legs[k], radius, plan.start[g])
    meet = t < reach[g]
    if not meet.any():
        return
    g, t = g[meet], t[meet]
    best = np.full(len(dist), np.inf)
    np.minimum.at(best, g, t)
    at = np.flatnonzero(np.isfinite(best))
    dist[at] = best[at]
    hit[at] = True
    world.rays_at_legs += len(at)


def ray_circle(origins: np.ndarray, dirs: np.ndarray, centres: np.ndarray, radius: float,
               start: np.ndarray) -> np.ndarray:
    """Where rays (origins (M, 2), unit dirs (M, 2)), starting ``start`` (M,) along, first
    meet circles (centres (M, 2), one radius): the distance from the origin, +inf where a
    ray misses its circle or passes it before its start (a ray that starts inside its
    circle meets it at its start)."""
    oc = centres - origins
    b = oc[:, 0] * dirs[:, 0] + oc[:, 1] * dirs[:, 1]          # along the ray to the closest point
    disc = b * b - (oc[:, 0] ** 2 + oc[:, 1] ** 2 - radius * radius)
    root = np.sqrt(np.maximum(disc, 0.0))
    near, far = b - root, b + root
    t = np.maximum(near, start)
    return np.where((disc >= 0.0) & (far > start), t, np.inf)
