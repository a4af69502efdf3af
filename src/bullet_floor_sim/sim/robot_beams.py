"""Lidar beams against the other robots: after the beams were cast at the walls alone (robot
bodies out of the scene, or the walls walked on the solid grid), the beams that can reach
another robot before their wall are clipped to that robot's measured cross-section
(sections.py, compiled by numba), or cast again in Bullet with the robots in place where no
checked section exists. ``world`` is the stepping
:class:`~.world.World` (see World.cast_beams).
"""
from __future__ import annotations

import math
from typing import Any, Optional, Tuple

import numpy as np

from .sections import clip_to_sections
from .sensors import cast_rays, ray_chunk

__all__ = ["candidates", "circle_candidates", "cast_at_robots", "ray_owner"]


def cast_at_robots(world: Any, plan: Any, dist: np.ndarray, hit: np.ndarray) -> None:
    """The beams that may meet another robot before their wall hit, against those robots
    (``dist``/``hit`` updated in place).

    A beam against a robot whose cross-section at the beam's height was measured and
    checked (measure.sections) is clipped to that polygon (sections.clip_to_sections). Any
    other is cast
    again in Bullet, with the robots in place, over the stretch where it is inside some
    other robot's bounding circle (and beyond its own robot's body), so the ray usually
    starts outside its own robot's bounding box."""
    reach = np.where(hit, dist, plan.full)
    g, j, t_in, t_out = candidates(world, plan, reach)
    if not len(g):
        return
    beams = len(np.unique(g))
    sec = world.section_index[plan.robots[ray_owner(plan, g)], j]
    flat = sec >= 0
    if flat.any():
        _clip(world, plan, reach, g[flat], j[flat], sec[flat], dist, hit)
    if not flat.all():
        _cast_in_bullet(world, plan, reach, g[~flat], t_in[~flat], t_out[~flat],
                                    dist, hit)
    world.rays_at_robots += beams

def ray_owner(plan: Any, g: np.ndarray) -> np.ndarray:
    """Index into ``plan.robots`` of the scan each ray ``g`` belongs to."""
    return np.searchsorted(plan.first, g, side="right") - 1

def _clip(world: Any, plan: Any, reach: np.ndarray, g: np.ndarray, j: np.ndarray,
                    sec: np.ndarray, dist: np.ndarray, hit: np.ndarray) -> None:
    """Beams ``g`` against robots ``j``'s measured sections ``sec`` (see sections.py)."""
    tyaw = world.pose[:, 2]
    clip_to_sections(g, j, sec, world.pose, np.cos(tyaw), np.sin(tyaw), plan.origins,
                     plan.dirs, plan.start, reach, world._section_normals,
                     world._section_offsets, dist, hit)


def _cast_in_bullet(world: Any, plan: Any, reach: np.ndarray, g: np.ndarray, t_in: np.ndarray,
                           t_out: np.ndarray, dist: np.ndarray, hit: np.ndarray) -> None:
    """Beams ``g`` cast in Bullet over the union of their stretches (t_in, t_out)."""
    order = np.argsort(g, kind="stable")
    g, t_in, t_out = g[order], t_in[order], t_out[order]
    first = np.flatnonzero(np.concatenate(([True], g[1:] != g[:-1])))
    idx = g[first]
    t_in = np.maximum(np.minimum.reduceat(t_in, first), plan.start[idx])
    t_out = np.minimum(np.maximum.reduceat(t_out, first), reach[idx])
    ok = t_out - t_in > 1e-9
    idx, t_in, t_out = idx[ok], t_in[ok], t_out[ok]
    if not len(idx):
        return
    o, d = plan.origins[idx], plan.dirs[idx]
    froms = o.copy()
    froms[:, :2] += d * t_in[:, None]
    tos = o.copy()
    tos[:, :2] += d * t_out[:, None]
    world._sync_bodies()     # every robot where it stands (cast_beams leaves them stale)
    frac, ids = cast_rays(world.client, froms, tos, world.threads(len(idx)), chunk=ray_chunk())
    robot = np.isin(ids, world._body_array)
    at = idx[robot]
    new = t_in[robot] + frac[robot] * (t_out[robot] - t_in[robot])
    closer = new < np.where(hit[at], dist[at], np.inf)
    dist[at[closer]] = new[closer]
    hit[at[closer]] = True
    world.rays_cast += len(idx)

def candidates(world: Any, plan: Any, reach: np.ndarray
                      ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The (ray, robot) pairs where the ray's line passes within the other robot's
    bounding circle nearer than ``reach`` (a robot's body lies inside its circle, so no
    other ray can hit a robot before ``reach``), with the stretch inside the circle.

    Returns:
        (ray indices, robot indices, distance where the circle is entered, where it is
        left), distances from the laser origin; a ray may appear with several robots.
    """
    own = plan.robots[:, None] == np.arange(world.n)[None, :]
    return circle_candidates(world, plan, reach, world.pose[:, :2],
                             world._ray_radius[plan.robots], own)


def circle_candidates(world: Any, plan: Any, reach: np.ndarray, centres: np.ndarray,
                      radii: np.ndarray, skip: Optional[np.ndarray] = None
                      ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The (ray, circle) pairs where the ray's line passes within a circle nearer than
    ``reach``: for each scan, only the beams whose angles fall in the circle's angular window
    (widened by one beam each side, so that rounding in the window never drops a beam).

    Args:
        centres: (N, 2) map-frame circle centres.
        radii: (Q, N) each circle's radius as seen by each of the plan's Q scans.
        skip: (Q, N) True for the pairs to leave out (a robot's own circle).

    Returns:
        (ray indices, circle indices, distance where the circle is entered, where it is
        left), distances from the laser origin (the entry is d - r: a bound, not the exact
        meeting point); scan by scan, circle by circle, beams in window order.
    """
    q_robot = plan.robots
    shape = (len(q_robot), len(centres))      # (the compiled loops do not check indices)
    if np.shape(radii) != shape or (skip is not None and np.shape(skip) != shape):
        raise ValueError("circle_candidates: radii %s and skip %s must be %s (scans, circles)"
                         % (np.shape(radii), None if skip is None else np.shape(skip), shape))
    if skip is None:
        skip = np.zeros(shape, dtype=bool)
    yaw = world.pose[q_robot, 2] + world.lidar.yaw[q_robot]
    return _circle_pairs(plan.origins, plan.first, np.ascontiguousarray(centres, dtype=float),
                         np.ascontiguousarray(radii, dtype=float),
                         np.ascontiguousarray(skip, dtype=np.bool_), reach,
                         world._beam_geometry[q_robot], yaw)


def _window(d, rx, ry, r, yaw, geo_q):  # type: ignore
    """A scan's beams (beam table row ``geo_q``, laser yaw ``yaw``) whose angles fall in
    the angular window of a circle of radius ``r`` whose centre is ``rx``, ``ry`` (distance
    ``d``) from the laser: (first beam, count, beams in a circle), to walk modulo the last;
    every beam when 2 pi is no whole number of beams."""
    amin, inc, beams, circle = geo_q[0], geo_q[1], int(geo_q[2]), int(geo_q[3])
    if circle == 0:
        return 0, beams, 1 << 40
    half = math.asin(min(1.0, r / max(d, 1e-12))) if d > r else math.pi
    vc = ((math.atan2(ry, rx) - yaw - amin) % (2.0 * math.pi)) / inc   # the centre's beam
    w = half / inc + 1.0
    lo = int(math.floor(vc - w))
    return lo, min(int(math.ceil(vc + w)) - lo + 1, circle), circle


def _circle_pairs(origins, first, centres, radii, skip, reach, geo, yaw):  # type: ignore
    """``circle_candidates``' loops: scan q (its rays from ``first[q]``, laser at
    ``origins[first[q]]``, beam table row ``geo[q]``, yaw ``yaw[q]``) against each circle j
    it does not ``skip`` whose nearest point is nearer than the scan's farthest ``reach``:
    a first pass finds each pair's window, a second lists its beams. Compiled by numba (a
    few dozen numpy calls on (Q, N) arrays cost more than the arithmetic at 10 robots)."""
    nq, nc = radii.shape
    m = reach.shape[0]
    lo = np.zeros((nq, nc), dtype=np.int64)
    count = np.zeros((nq, nc), dtype=np.int64)
    period = np.ones((nq, nc), dtype=np.int64)
    dist = np.zeros((nq, nc))
    total = 0
    for q in range(nq):
        s = first[q]
        far = -math.inf
        for k in range(s, first[q + 1] if q + 1 < nq else m):
            far = max(far, reach[k])
        for j in range(nc):
            rx, ry = centres[j, 0] - origins[s, 0], centres[j, 1] - origins[s, 1]
            d = math.hypot(rx, ry)
            if skip[q, j] or not d - radii[q, j] < far:
                continue
            lo[q, j], count[q, j], period[q, j] = _window(d, rx, ry, radii[q, j], yaw[q], geo[q])
            dist[q, j] = d
            total += count[q, j]
    g_out = np.empty(total, dtype=np.int64)
    j_out = np.empty(total, dtype=np.int64)
    in_out = np.empty(total)
    out_out = np.empty(total)
    n = 0
    for q in range(nq):
        s, beams = first[q], int(geo[q, 2])
        for j in range(nc):
            entry, leave = dist[q, j] - radii[q, j], dist[q, j] + radii[q, j]
            for t in range(count[q, j]):
                v = (lo[q, j] + t) % period[q, j]
                if v < beams and reach[s + v] > entry:
                    g_out[n], j_out[n], in_out[n], out_out[n] = s + v, j, entry, leave
                    n += 1
    return g_out[:n], j_out[:n], in_out[:n], out_out[:n]


try:   # as sim/grid_rays.py: compiled where numba is installed (the venv's requirements)
    import numba
    _window = numba.njit(cache=True)(_window)
    _circle_pairs = numba.njit(cache=True)(_circle_pairs)
except ImportError:   # pragma: no cover
    pass
