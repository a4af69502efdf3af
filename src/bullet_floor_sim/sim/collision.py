"""Collisions of the kinematic robots: which robots could touch a wall or another robot within
the next steps (from the map's clearance field and their speeds), and the exact check of those
in Bullet; a move that would press deeper is refused and the robot stops (as Stage does).
``world`` is the stepping :class:`~.world.World` (see World._physics_step).
"""
from __future__ import annotations

import math
from typing import Any, Tuple

import numpy as np

__all__ = ["PENETRATION_TOL", "clearance_at", "resolve", "window"]

#: How deep a contact may be before a move counts as pressing in (Bullet's contact slop).
PENETRATION_TOL = 1e-3
#: How deep two robots may press into each other (their bumpers give): with none, two
#: octagonal bases touching corner to corner could neither turn nor slide past each other.
_ROBOT_CONTACT_SLACK = 0.03
_CLEARANCE_MARGIN = 0.05
#: Collision windows of up to this many (robot, other robot) pairs are computed in plain floats.
_SMALL_PAIRS = 64


def clearance_at(world: Any, poses: np.ndarray) -> np.ndarray:
    col, row = world.fmap.world_to_cell(poses[:, 0], poses[:, 1])
    inside = (col >= 0) & (col < world.fmap.width) & (row >= 0) & (row < world.fmap.height)
    out = np.full(len(poses), np.inf)
    out[inside] = world._clearance[row[inside], col[inside]]
    return out

def window(world: Any, pose: np.ndarray, rows: np.ndarray
                      ) -> Tuple[np.ndarray, np.ndarray]:
    """For the robots ``rows``: which may touch a wall or a robot now, and how long each
    cannot reach contact (its gap to the nearest wall at its top speed, to every other
    robot at both top speeds). A robot in contact with another has a window of 0, so
    both robots of a pair in contact are always checked together.

    Returns:
        (candidate robot indices, seconds per robot of ``rows`` without contact).
    """
    if len(rows) * world.n <= _SMALL_PAIRS:
        return _window_small(world, pose, rows)
    p = pose[rows]
    r = world.radius[rows]
    gap = clearance_at(world, p) - r - _CLEARANCE_MARGIN
    near = gap < 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        t_safe = gap / world._vmax[rows]
        if world.n > 1:
            d = np.hypot(p[:, None, 0] - pose[None, :, 0], p[:, None, 1] - pose[None, :, 1])
            pair_gap = d - r[:, None] - world.radius[None, :] - _CLEARANCE_MARGIN
            pair_gap[np.arange(len(rows)), rows] = np.inf
            near |= (pair_gap < 0.0).any(axis=1)
            t_safe = np.minimum(t_safe, np.min(
                pair_gap / (world._vmax[rows, None] + world._vmax[None, :]), axis=1))
    t_safe = np.where(near | np.isnan(t_safe), 0.0, np.minimum(t_safe, 1e6))
    return rows[near], t_safe

def _window_small(world: Any, pose: np.ndarray, rows: np.ndarray
                            ) -> Tuple[np.ndarray, np.ndarray]:
    """``window`` in plain floats: the same formulas, for a few rows (most
    steps check one or two robots, where numpy's per-call cost was 80 us a step)."""
    if world._window_consts is None:
        m = world.fmap
        ox, oy, yaw = m.origin
        world._window_consts = (float(ox), float(oy), math.cos(yaw), math.sin(yaw),
                               1.0 / m.resolution, m.width, m.height,
                               world.radius.tolist(), world._vmax.tolist())
    ox, oy, c, s, inv_res, width, height, radius, vmax = world._window_consts
    clear = world._clearance
    xy = pose[:, :2].tolist()
    cand, out = [], []
    hypot, floor, inf = math.hypot, math.floor, math.inf
    for i in rows.tolist():
        x, y = xy[i]
        dx, dy = x - ox, y - oy
        col, row = int(floor((c * dx + s * dy) * inv_res)), int(floor((c * dy - s * dx) * inv_res))
        wall = float(clear[row, col]) if 0 <= col < width and 0 <= row < height else inf
        ri, vi = radius[i], vmax[i]
        gap = wall - ri - _CLEARANCE_MARGIN
        near = gap < 0.0
        t = gap / vi if vi > 0.0 else (inf if gap >= 0.0 else 0.0)
        for j, (xj, yj) in enumerate(xy):
            if j == i:
                continue
            g = hypot(x - xj, y - yj) - ri - radius[j] - _CLEARANCE_MARGIN
            if g < 0.0:
                near = True
            v = vi + vmax[j]
            if v > 0.0:
                t = min(t, g / v)
        if near:
            cand.append(i)
        out.append(0.0 if near else min(max(t, 0.0), 1e6))
    return np.array(cand, dtype=np.int64), np.array(out)

def resolve(world: Any, old: np.ndarray, new: np.ndarray, cand: np.ndarray) -> None:
    """Refuse the move of every candidate robot that would penetrate a wall deeper than
    it already does, or another robot deeper than that and than the bumpers' give
    (``_ROBOT_CONTACT_SLACK``).

    The candidates are taken in turn: each one's move is tested against the walls and
    against the robots near it where they stand at that moment (the candidates already
    taken at their final pose, the others at their old one), so a penetration is charged
    to the robot whose move makes it. Charged to both robots of a pair, one robot pushing
    into another froze the other too, even while it only tried to back away or turn: two
    robots in contact stayed locked for good. Pairs and walls are queried with
    getClosestPoints (a whole-world performCollisionDetection also ran every robot
    against the wall mesh)."""
    closest = world._closest_points
    cl = cand.tolist()
    for i in cl:
        world._set_body(i, old[i])
    reach = world.radius + _CLEARANCE_MARGIN
    taken = set()
    for i in cl:
        taken.add(i)
        bi = world.bodies[i]
        world._set_body(i, new[i])
        depth = robot_depth = 0.0
        for wb in world.wall_bodies:
            for c in closest(bi, wb, 0.0):
                if c[8] < -PENETRATION_TOL:
                    depth = max(depth, -c[8])
        for j in cl:
            if j == i:
                continue
            at = new[j] if j in taken else old[j]   # where its body stands now
            if math.hypot(new[i, 0] - at[0], new[i, 1] - at[1]) > reach[i] + reach[j]:
                continue
            for c in closest(bi, world.bodies[j], 0.0):
                if c[8] < -PENETRATION_TOL:
                    robot_depth = max(robot_depth, -c[8])
        if (depth > world._penetration[i] + PENETRATION_TOL
                or robot_depth > max(world._robot_penetration[i] + PENETRATION_TOL,
                                     _ROBOT_CONTACT_SLACK)):
            new[i] = old[i]
            world.vel[i] = 0.0
            world.stalled[i] = True
            world.stall_count[i] += 1
            world._set_body(i, old[i])
        else:
            # the reference depths only ever go down with the robot's own moves: set to
            # each accepted depth, moves of less than the tolerance a step crept in
            world._penetration[i] = min(world._penetration[i], depth)
            world._robot_penetration[i] = min(world._robot_penetration[i], robot_depth)
