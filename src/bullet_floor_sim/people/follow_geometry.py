"""Plain geometry the observer's rules share (people/follow.py): the stand-off point, the
target as a body for the planner, and where a target's path passes the observer.

Everything is plain numbers and arrays in and out; the rules that use them are in
people/follow.py, people/follow_give_way.py and people/follow_search.py.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numpy as np

from ..geometry import wrap_angle
from ..nav.planner import PlanningGrid, disc_points

__all__ = ["GIVE_WAY_HYSTERESIS", "MOVING", "standoff_point", "target_body", "on_path",
           "point_past", "distance_to"]

GIVE_WAY_HYSTERESIS = 0.2  # m: in the way below give_way less this; it steps to give_way
MOVING = 0.15              # m/s: a target slower than this stands still


def standoff_point(grid: PlanningGrid, target: Sequence[float], robot: Sequence[float],
                   distance: float, direction: Optional[float] = None, roomy: float = 0.0,
                   sight: bool = False) -> Optional[Tuple[float, float]]:
    """A free point ``distance`` from ``target``, as close as possible to the direction of
    ``robot`` (or to the bearing ``direction`` from the target, when given; candidates within
    90 degrees of it either side, every 15 degrees, then on circles 0.75 and 0.5 times as
    big). A point with at least ``roomy`` metres of wall clearance (not in a doorway) on the
    observer's side of the target (within 90 degrees of the robot's bearing from it: the
    observer is not sent past the target) comes first. With ``sight``, only points with no
    wall between them and the target (:meth:`PlanningGrid.in_sight`) are taken, in the same
    order (the largest circle with one); when no free point is in sight (a target tracked in
    a wall's cell, or behind a corner from every candidate), the point chosen without
    ``sight``. None when no free point lies within ``distance`` of the target."""
    tx, ty = float(target[0]), float(target[1])
    own = math.atan2(float(robot[1]) - ty, float(robot[0]) - tx)
    base = own if direction is None else float(direction)
    first = first_seen = None
    for radius in (distance, 0.75 * distance, 0.5 * distance):
        for k in range(13):  # 0, +15, -15, +30, ... +-90 degrees
            a = base + math.radians(15.0 * ((k + 1) // 2) * (1 if k % 2 else -1))
            x, y = tx + radius * math.cos(a), ty + radius * math.sin(a)
            if not grid.is_free(x, y):
                continue
            seen = not sight or bool(grid.in_sight(np.array([[x, y]]), (tx, ty))[0])
            if first is None:
                first = (x, y)
            if seen and first_seen is None:
                first_seen = (x, y)
            if (seen and radius == distance and abs(wrap_angle(a - own)) <= 0.5 * math.pi + 1e-9
                    and grid.clearance_at(x, y) >= roomy):
                return x, y
        if first_seen is not None:
            return first_seen
    if sight and first is not None:   # none in sight: as without
        return standoff_point(grid, target, robot, distance, direction, roomy)
    return first


def target_body(grid: PlanningGrid, tx: float, ty: float) -> np.ndarray:
    """The target at (tx, ty) as the planner's obstacles: a body of the observer's radius
    (as GiveWayRules._passes_by has it), not a point. As a point, the place to step aside
    to could lie past the target in a 2 m corridor, where the observer could not get by it
    (aces_austin: it stood behind the walker, blocking it, until the walker went 80 m round
    the loop)."""
    return disc_points(tx, ty, grid.config.robot_radius)


def on_path(path: Optional[np.ndarray], target: Sequence[float], within: float) -> bool:
    """Whether ``target`` is within ``within`` m of a point of ``path``; True for no path
    (kept: the destination could not be planned to a moment ago either)."""
    return path is None or bool(distance_to(path, target[0], target[1]).min() <= within)


def point_past(path: Optional[np.ndarray], target: Sequence[float], robot: Sequence[float],
               near: float, beyond: float) -> Optional[Tuple[float, float]]:
    """The first point of ``path`` (N, 2), from its point nearest ``target`` on, that is
    ``beyond`` metres from ``robot`` after the path's nearest approach to it, or its last
    point; None when there is no path or it never comes within ``near`` of the robot."""
    if path is None or not len(path):
        return None
    rest = path[int(np.argmin(distance_to(path, target[0], target[1]))):]
    d = distance_to(rest, robot[0], robot[1])
    i = int(np.argmin(d))
    if d[i] >= near:
        return None
    far = np.nonzero(d[i:] >= beyond)[0]
    x, y = rest[i + int(far[0])] if len(far) else rest[-1]
    return float(x), float(y)


def distance_to(points: np.ndarray, x: float, y: float) -> np.ndarray:
    """Distance from (x, y) to each of the (N, 2) points (inf for none)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(pts):
        return np.array([math.inf])
    return np.hypot(pts[:, 0] - x, pts[:, 1] - y)
