"""Where a robot steps out of another's way: the nearest free place clear of a route
(:func:`give_way_point`), preferring roomy places, places in sight of what it gives way to and
places whose way there sets off towards it (:func:`path_headings`). The Navigator's give-way
(nav/navigator.py), the passing places (nav/passing.py) and the observer (people/follow*.py)
use it.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numpy as np

from ..geometry import wrap_angles
from .grid import PlanningGrid

__all__ = ["give_way_point", "path_headings"]


def give_way_point(grid: PlanningGrid, route: np.ndarray, robot: Sequence[float],
                   target: Sequence[float], clear: float, reach: float, roomy: float = 0.0,
                   obstacles: Optional[np.ndarray] = None, in_view: float = 0.0
                   ) -> Optional[Tuple[float, float]]:
    """The free planning-cell centre nearest to ``robot`` that is at least ``clear`` metres from
    every point of ``route`` (an (N, 2) polyline sampled finely, e.g. a plan) and from the
    ``target``, within ``reach`` metres of the robot and reachable from it without passing
    ``obstacles`` (map-frame points, inflated as the planner does); one with ``roomy`` metres
    of wall clearance first, and of those (then of the rest) one that sees the target (no wall
    between: the lidar finds it from there, where it waits) and whose way from the robot sets
    off within ``in_view`` radians of the target's bearing (:func:`path_headings`: driving
    there, a forward-looking lidar keeps the target in view), then one that sees it, then one
    within that bearing (0: neither preference). None when there is none. By the straight
    line's bearing instead, the observer on freiburg_079 stepped to a place 3.3 m off whose
    way first led away from the walker, turned its back on it, and lost it (tracked 62 %;
    69 % by the way's heading)."""
    from scipy.ndimage import label

    rx, ry = float(robot[0]), float(robot[1])
    c0, r0 = grid.to_cell(rx, ry)
    n = int(math.ceil(reach / grid.resolution))
    cols = np.arange(max(0, c0 - n), min(grid.width, c0 + n + 1))
    rows = np.arange(max(0, r0 - n), min(grid.height, r0 + n + 1))
    if not len(cols) or not len(rows):
        return None
    window = grid.cost[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
    if obstacles is not None and len(obstacles):
        window = window.copy()
        grid._stamp_obstacles(window, np.asarray(obstacles, dtype=float).reshape(-1, 2),
                              (rx, ry), corner=(int(cols[0]), int(rows[0])))
    free = np.isfinite(window)
    # 4-connected: the planner's 8-connected A* cuts no corner, so it joins no more than
    # that (8-connected parts offered places it could not plan to, and the observer stood
    # where it was, in the walker's way, for good)
    parts, _ = label(free)
    r, c = r0 - rows[0], c0 - cols[0]
    near = parts[max(r - 2, 0):r + 3, max(c - 2, 0):c + 3]   # its cell, or one next to it
    near = near[near > 0]
    if not len(near):
        return None
    own = int(np.bincount(near).argmax())
    R, C = np.nonzero(parts == own)
    R, C = R + rows[0], C + cols[0]
    k = grid.factor
    x, y = grid.fmap.cell_to_world((C + 0.5) * k - 0.5, (R + 0.5) * k - 0.5)
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    d_robot = np.hypot(x - rx, y - ry)
    ok = (d_robot <= reach) & (np.hypot(x - float(target[0]), y - float(target[1])) >= clear)
    pts = np.asarray(route, dtype=float).reshape(-1, 2)
    if len(pts):
        from scipy.spatial import cKDTree

        ok &= cKDTree(pts).query(np.stack([x, y], axis=1))[0] >= clear
    if not ok.any():
        return None
    roomy_ok = ok & (grid.clearance[R, C] >= roomy)
    tiers = [roomy_ok, ok]
    if in_view > 0.0:
        bearing = math.atan2(float(target[1]) - ry, float(target[0]) - rx)
        head = np.full(len(x), np.nan)
        head[ok] = path_headings(grid, (rx, ry), R[ok], C[ok], 2.0 * reach)
        head = np.where(np.isnan(head), np.arctan2(y - ry, x - rx), head)
        seen = np.abs(wrap_angles(head - bearing)) <= in_view
        sight = np.zeros_like(ok)
        sight[ok] = grid.in_sight(np.stack([x[ok], y[ok]], axis=1), target)
        tiers = [roomy_ok & sight & seen, roomy_ok & sight, roomy_ok & seen, roomy_ok,
                 ok & sight & seen, ok & sight, ok & seen, ok]
    pick = next(t for t in tiers if t.any())
    i = int(np.argmin(np.where(pick, d_robot, np.inf)))
    return float(x[i]), float(y[i])


def path_headings(grid: PlanningGrid, start: Sequence[float], rows: np.ndarray,
                  cols: np.ndarray, reach: float, ahead: float = 0.7) -> np.ndarray:
    """For planning cells (rows, cols), the bearing from ``start`` of the point ``ahead``
    metres out along the cheapest way to each on the planner's graph (the way the robot
    sets off; from the nearest passable cell when its own is not, as the planner starts),
    searched up to step costs of 2 x ``reach`` / resolution (at least 1 a cell, more near
    walls); NaN for a cell not reached. A place whose straight line from the robot lies
    towards a target can lie down a path that first leads away from it (round a wall). The
    graph has no target in it: a way through the target's own body counts as towards it."""
    from scipy.sparse.csgraph import dijkstra

    graph, node = grid.graph()
    out = np.full(len(rows), np.nan)
    near = grid.free_cell_near(float(start[0]), float(start[1]))
    if near is None or not len(rows):
        return out
    c0, r0 = near
    dist, pred = dijkstra(graph, directed=False, indices=int(node[r0, c0]),
                          return_predecessors=True,
                          limit=2.0 * reach / grid.resolution)   # weights: >= 1 a cell step
    cells = grid.node_cells()
    cur = node[np.asarray(rows), np.asarray(cols)]
    live = (cur >= 0)
    live[live] = np.isfinite(dist[cur[live]])
    sx, sy = float(start[0]), float(start[1])
    for _ in range(int(4.0 * reach / grid.resolution)):
        px, py = grid.centres(cells[cur, 1], cells[cur, 0])
        far = live & (np.hypot(px - sx, py - sy) > ahead)
        far[far] = pred[cur[far]] >= 0
        if not far.any():
            break
        cur[far] = pred[cur[far]]
    px, py = grid.centres(cells[cur, 1], cells[cur, 0])
    out[live] = np.arctan2(py[live] - sy, px[live] - sx)
    return out
