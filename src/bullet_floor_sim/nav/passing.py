"""Passing places: where a robot that yields in a passage too narrow for two waits, out of the
way of the one coming the other way.

Two discs of radii r1 and r2 pass side by side where the floor is at least
2 (r1 + r2) + margin wide, that is where the medial axis of the floor (the skeleton of the
cells a disc fits on, the middle of every corridor and door) has a wall clearance of at least
r1 + r2 + margin / 2. :func:`narrow_axis` is the rest of that axis: the way the other robot
must take through every narrow part. A *passing place* is a cell the yielding robot fits on at
least r1 + r2 + margin from every point of it: in a room or a wide stretch beside a corridor's
mouth, never in the corridor itself (:func:`passing_place`, the nearest one it can reach).
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numpy as np

from .grid import PlanningGrid, disc_points

__all__ = ["narrow_axis", "passing_place", "on_the_way", "gives_way", "heads_west_or_south"]


def narrow_axis(grid: PlanningGrid, other_radius: float, margin: float) -> np.ndarray:
    """Map-frame points (N, 2) of the floor's medial axis where a disc of the grid's radius
    and one of ``other_radius`` cannot pass side by side with ``margin`` m between them
    (planning-cell centres; the Navigator's ``passing_margin``)."""
    from skimage.morphology import skeletonize

    axis = skeletonize(np.isfinite(grid.cost))
    narrow = axis & (grid.clearance < grid.config.robot_radius + other_radius + 0.5 * margin)
    rows, cols = np.nonzero(narrow)
    k = grid.factor
    x, y = grid.fmap.cell_to_world((cols + 0.5) * k - 0.5, (rows + 0.5) * k - 0.5)
    return np.column_stack([np.atleast_1d(x), np.atleast_1d(y)]).astype(float)


def passing_place(grid: PlanningGrid, axis: np.ndarray, robot: Sequence[float],
                  blocker: np.ndarray, other_radius: float, reach: float,
                  margin: float) -> Optional[Tuple[float, float]]:
    """The nearest passing place (see the module doc; ``margin`` m the gap between the two)
    the robot at ``robot`` (x, y) reaches within ``reach`` m without passing ``blocker``
    (map-frame points of what it meets, which it also keeps that far from); None when
    there is none."""
    from .give_way import give_way_point

    clear = _passing_clearance(grid, other_radius, margin)
    rx, ry = float(robot[0]), float(robot[1])
    near = axis[np.hypot(axis[:, 0] - rx, axis[:, 1] - ry) <= reach + clear] \
        if len(axis) else axis
    pts = np.asarray(blocker, dtype=float).reshape(-1, 2)
    route = np.vstack([near, pts]) if len(near) else pts
    cx, cy = (float(v) for v in pts.mean(axis=0)) if len(pts) else (rx, ry)
    return give_way_point(grid, route, (rx, ry), (cx, cy), clear, reach, obstacles=pts)


def on_the_way(grid: PlanningGrid, axis: np.ndarray, point: Sequence[float],
               other_radius: float, margin: float) -> bool:
    """Whether ``point`` is where what the robot meets must pass: nearer the narrow axis
    than a passing place is (both radii and ``margin``)."""
    if not len(axis):
        return False
    d = np.hypot(axis[:, 0] - float(point[0]), axis[:, 1] - float(point[1]))
    return bool(d.min() < _passing_clearance(grid, other_radius, margin))


def _passing_clearance(grid: PlanningGrid, other_radius: float, margin: float) -> float:
    """How far (m) a passing place lies from the narrow axis: both radii and the margin."""
    return grid.config.robot_radius + other_radius + margin


def gives_way(grid: PlanningGrid, axis: np.ndarray, pose: Sequence[float], blocker: np.ndarray,
              other_radius: float, reach: float, margin: float, heading_rule: bool = True
              ) -> bool:
    """Whether the robot at ``pose`` (x, y, yaw) yields to what it meets head-on (``blocker``,
    the scan points of it), by a rule that robot applies too: the one whose passing place is
    nearer, by more than a metre, yields; one with no passing place never does (the other
    must); within a metre, the one :func:`heads_west_or_south` when ``heading_rule``.
    What it meets is taken to be a disc of
    ``other_radius`` just beyond its points (the robot itself as a disc of its own), and
    the passing places leave ``margin`` m between the two."""
    x, y = float(pose[0]), float(pose[1])
    mine = passing_place(grid, axis, (x, y), blocker, other_radius, reach, margin)
    if mine is None:
        return False
    pts = np.asarray(blocker, dtype=float).reshape(-1, 2)
    centre = pts.mean(axis=0)
    away = centre - (x, y)
    centre = centre + 0.7 * other_radius * away / max(float(np.hypot(*away)), 1e-9)
    me = disc_points(x, y, 0.8 * grid.config.robot_radius)
    theirs = passing_place(grid, axis, centre, me, other_radius, reach, margin)
    d_mine = math.hypot(mine[0] - x, mine[1] - y)
    if theirs is None:
        return True
    d_theirs = math.hypot(theirs[0] - centre[0], theirs[1] - centre[1])
    if abs(d_mine - d_theirs) > 1.0:
        return d_mine < d_theirs
    return heading_rule and heads_west_or_south(float(pose[2]))


def heads_west_or_south(yaw: float) -> bool:
    """The heading rule's loser: a heading against ``RULE_DIRECTION`` (20 degrees north of
    east; cos(yaw - 20 deg) < 0): west, south and what lies between. Of two robots facing
    each other exactly one is, in a passage of any direction but the one at right angles to
    it (110 degrees from east, which buildings seldom have), and a little heading noise
    decides nothing in an east-west or north-south one."""
    return math.cos(yaw - RULE_DIRECTION) < 0.0


#: The heading rule's direction (rad from east): not a building's usual 0, 45 or 90 degrees.
RULE_DIRECTION = math.radians(20.0)
