"""Lidar beams against the other robots: after the beams were cast at the walls alone (robot
bodies out of the scene), the beams that can reach another robot before their wall are
clipped to that robot's measured cross-section in numpy (sections.py), or cast again in Bullet
with the robots in place where no checked section exists. ``world`` is the stepping
:class:`~.world.World` (see World.cast_beams).
"""
from __future__ import annotations

from typing import Any, Optional, Tuple

import numpy as np

from .sections import clip_beams
from .sensors import cast_rays, ray_chunk

__all__ = ["candidates", "circle_candidates", "cast_at_robots", "ray_owner"]


def cast_at_robots(world: Any, plan: Any, dist: np.ndarray, hit: np.ndarray) -> None:
    """The beams that may meet another robot before their wall hit, against those robots
    (``dist``/``hit`` updated in place).

    A beam against a robot whose cross-section at the beam's height was measured and
    checked (measure.sections) is clipped to that polygon in numpy. Any other is cast
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
    tyaw = world.pose[j, 2]
    c, s = np.cos(tyaw), np.sin(tyaw)
    o, d = plan.origins[g, :2], plan.dirs[g]
    ox, oy = o[:, 0] - world.pose[j, 0], o[:, 1] - world.pose[j, 1]
    lo = np.column_stack((c * ox + s * oy, c * oy - s * ox))          # in robot j's frame
    ld = np.column_stack((c * d[:, 0] + s * d[:, 1], c * d[:, 1] - s * d[:, 0]))
    t_in, t_out = clip_beams(lo, ld, world._section_normals[sec], world._section_offsets[sec])
    start = plan.start[g]
    t = np.maximum(t_in, start)     # a beam that starts inside another robot meets it at once
    meet = (t_in <= t_out) & (t_out > start) & (t < reach[g])
    if not meet.any():
        return
    g, t = g[meet], t[meet]
    best = np.full(len(dist), np.inf)
    np.minimum.at(best, g, t)
    at = np.flatnonzero(best < np.where(hit, dist, np.inf))
    dist[at] = best[at]
    hit[at] = True

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
    ``reach``: for each scan, only the beams whose angles fall in the circle's angular window.

    Args:
        centres: (N, 2) map-frame circle centres.
        radii: (Q, N) each circle's radius as seen by each of the plan's Q scans.
        skip: (Q, N) True for the pairs to leave out (a robot's own circle).

    Returns:
        (ray indices, circle indices, distance where the circle is entered, where it is
        left), distances from the laser origin (the entry is d - r: a bound, not the exact
        meeting point).
    """
    none = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0),
            np.zeros(0))
    q_robot = plan.robots
    offs = plan.first
    o = plan.origins[offs, :2]                                   # (Q, 2) laser origins
    rel = centres[None, :, :] - o[:, None, :]                     # (Q, N, 2)
    d = np.hypot(rel[..., 0], rel[..., 1])
    r = radii                                                     # (Q, N) at each laser's height
    entry = d - r
    far = np.maximum.reduceat(reach, offs)
    pair = entry < far[:, None]
    if skip is not None:
        pair &= ~skip
    qs, js = np.nonzero(pair)
    if not len(qs):
        return none
    geo = world._beam_geometry[q_robot[qs]]                       # amin, inc, beams, circle
    inc = geo[:, 1]
    dq, rq = d[qs, js], r[qs, js]
    half = np.where(dq > rq, np.arcsin(np.minimum(1.0, rq / np.maximum(dq, 1e-12))), np.pi)
    yaw = world.pose[q_robot[qs], 2] + world.lidar.yaw[q_robot[qs]]
    phi = np.arctan2(rel[qs, js, 1], rel[qs, js, 0]) - yaw - geo[:, 0]
    vc = np.remainder(phi, 2.0 * np.pi) / inc                     # beam index of the centre
    w = half / inc + 1.0
    circle = geo[:, 3].astype(np.int64)
    lo = np.floor(vc - w).astype(np.int64)
    n_v = np.minimum(np.ceil(vc + w).astype(np.int64) - lo + 1, circle)
    whole = circle == 0
    lo[whole], n_v[whole], circle[whole] = 0, geo[whole, 2].astype(np.int64), 1 << 40
    total = int(n_v.sum())
    rep = np.repeat(np.arange(len(qs)), n_v)
    v = np.repeat(lo - np.concatenate(([0], np.cumsum(n_v)[:-1])), n_v) + np.arange(total)
    v = np.remainder(v, circle[rep])
    keep = v < geo[rep, 2]
    rep, v = rep[keep], v[keep]
    g = offs[qs[rep]] + v
    pe = entry[qs, js][rep]
    keep = reach[g] > pe
    if not keep.any():
        return none
    g, rep, pe = g[keep], rep[keep], pe[keep]
    px = (dq + rq)[rep]                                         # where the circle is left
    return g, js[rep], pe, px
