"""Frontier exploration (Yamauchi 1997): go to the nearest reachable boundary between known
free space and unknown space, until none is left.

* :func:`frontiers`: the free cells beside unknown ones, in 8-connected clusters of at least
  ``min_cells``;
* :class:`Explorer`: the next goal: of the known free, passable cells within ``reach`` of a
  frontier cluster, the one nearest to the robot along the planner's grid (one Dijkstra from
  the robot, scipy). Unknown space is passable for planning, as navfn's ``allow_unknown``
  (the robot's own lidar stops it short of what it finds there); goals tried and failed are
  ruled out. Only the known part of the map and a margin are searched (a SLAM node's map is
  mostly unknown: gmapping's is 200 m square).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..geometry import wrap_angles
from ..nav.grid import PlannerConfig, PlanningGrid
from ..sim.floormap import FloorMap, crop_known

__all__ = ["Frontier", "frontiers", "Explorer", "ExplorerConfig"]


@dataclass(frozen=True)
class Frontier:
    """A cluster of frontier cells: their (row, col) and the centroid in the map frame."""

    cells: np.ndarray
    centroid: Tuple[float, float]

    @property
    def size(self) -> int:
        return len(self.cells)


def frontiers(fmap: FloorMap, min_cells: int = 4) -> List[Frontier]:
    """The frontier clusters of a trinary map (100 / 0 / -1), largest first."""
    from scipy.ndimage import binary_dilation, label

    g = np.asarray(fmap.grid)
    unknown = g < 0
    near_unknown = binary_dilation(unknown, structure=np.array([[0, 1, 0], [1, 1, 1],
                                                                [0, 1, 0]], dtype=bool))
    cells = (g == 0) & near_unknown
    labels, _n = label(cells, structure=np.ones((3, 3), dtype=bool))
    # every cluster's cells in one pass (row-major within a cluster, as argwhere gives them)
    rc = np.argwhere(labels > 0)
    if not len(rc):
        return []
    k = labels[rc[:, 0], rc[:, 1]]
    order = np.argsort(k, kind="stable")
    sizes = np.bincount(k)[1:]
    out = []
    for part in np.split(rc[order], np.cumsum(sizes)[:-1]):
        if len(part) < min_cells:
            continue
        x, y = fmap.cell_to_world(part[:, 1].mean(), part[:, 0].mean())
        out.append(Frontier(part, (float(x), float(y))))
    out.sort(key=lambda f: -f.size)
    return out


@dataclass
class ExplorerConfig:
    """Exploration parameters.

    Attributes:
        robot_radius: the robot's footprint (the planner's inflation).
        min_frontier: smallest frontier worth a trip, metres of boundary.
        reach: a goal is a passable cell at most this far from its frontier (m): the robot
            sees the unknown beyond from there.
        blacklist_radius: a goal done with (:meth:`Explorer.goal_failed`: failed, reached,
            or, in the explorer node, sent) rules out goals this close to it (m).
        min_distance: goals nearer the robot than this (along the grid) are not sent.
        view_range: a frontier cell within this distance (m) of a goal reached, and within
            ``view_angle`` of the way the robot faced there, was looked at: if it is a
            frontier still (the unknown beyond it does not show: a wall's far side, glass,
            a shadow), it is no reason to go anywhere again (:meth:`Explorer.looked_from`).
            0: every frontier cell counts until it closes. (office: the robot went along such
            a strip in 0.6 m goals, 45 goals for 2 % of the floor.)
        view_angle: half the angle (radians) of that view (the Scitos lidar sees 90 degrees
            either side; the goal's heading faces its nearest frontier cell).
    """

    robot_radius: float = 0.34
    min_frontier: float = 0.75
    reach: float = 1.0
    blacklist_radius: float = 0.5
    min_distance: float = 0.5
    view_range: float = 2.0
    view_angle: float = math.radians(80.0)


@dataclass
class Explorer:
    """Picks exploration goals on the map being built."""

    config: ExplorerConfig = field(default_factory=ExplorerConfig)
    failed: List[Tuple[float, float]] = field(default_factory=list)
    looked: List[Tuple[float, float, float]] = field(default_factory=list)

    def next_goal(self, fmap: FloorMap, pose: Sequence[float]
                  ) -> Optional[Tuple[float, float, float]]:
        """The next goal (x, y, yaw facing the nearest frontier cell, map frame), or None when
        no frontier is reachable: the map is done."""
        from scipy.ndimage import distance_transform_edt

        c = self.config
        fmap = crop_known(fmap, c.reach + 2.0 * c.robot_radius + 1.0)
        grid = PlanningGrid(fmap, PlannerConfig(robot_radius=c.robot_radius,
                                                resolution=fmap.resolution,
                                                unknown_is_obstacle=False))
        min_cells = max(1, int(math.ceil(c.min_frontier / fmap.resolution)))
        found = self._not_looked_at(fmap, frontiers(fmap, min_cells), min_cells)
        if not found:
            return None
        dist = _distances(grid, pose)
        if dist is None:
            return None
        near = np.zeros(grid.cost.shape, dtype=bool)
        for f in found:
            near[f.cells[:, 0] // grid.factor, f.cells[:, 1] // grid.factor] = True
        to_frontier = distance_transform_edt(~near) * grid.resolution
        known_free = np.asarray(fmap.grid)[::grid.factor, ::grid.factor] == 0
        ok = np.isfinite(dist) & (to_frontier <= c.reach) & known_free
        for fx, fy in self.failed:
            col, row = grid.to_cell(fx, fy)
            k = int(math.ceil(c.blacklist_radius / grid.resolution))
            if row + k < 0 or col + k < 0:      # off the (cropped) grid below or left
                continue
            ok[max(0, row - k):row + k + 1, max(0, col - k):col + k + 1] = False
        ok &= dist >= c.min_distance          # a trip that shows something new
        if not ok.any():
            return None
        flat = np.where(ok, dist, np.inf).argmin()
        row, col = divmod(int(flat), grid.width)
        x, y = grid.to_world(col, row)
        # face the nearest frontier cell: the lidar looks at what is unknown
        fr = np.vstack([f.cells for f in found])
        cx, cy = (np.asarray(v, dtype=float) for v in fmap.cell_to_world(fr[:, 1], fr[:, 0]))
        k = int(np.argmin(np.hypot(cx - x, cy - y)))
        return x, y, math.atan2(float(cy[k]) - y, float(cx[k]) - x)

    def looked_from(self, pose: Sequence[float]) -> None:
        """The robot stood at ``pose`` (x, y, yaw: a goal reached): frontier cells in its view
        from there no longer count (ExplorerConfig.view_range)."""
        self.looked.append((float(pose[0]), float(pose[1]), float(pose[2])))

    def _not_looked_at(self, fmap: FloorMap, found: List[Frontier], min_cells: int
                       ) -> List[Frontier]:
        """``found`` without the cells looked at from a goal reached (see ``looked_from``);
        clusters left with fewer than ``min_cells`` dropped."""
        c = self.config
        if c.view_range <= 0 or not self.looked or not found:
            return found
        out = []
        for f in found:
            x, y = (np.asarray(v, dtype=float) for v in fmap.cell_to_world(f.cells[:, 1],
                                                                          f.cells[:, 0]))
            seen = np.zeros(len(f.cells), dtype=bool)
            for lx, ly, lyaw in self.looked:
                dx, dy = x - lx, y - ly
                bearing = np.abs(wrap_angles(np.arctan2(dy, dx) - lyaw))
                seen |= (np.hypot(dx, dy) <= c.view_range) & (bearing <= c.view_angle)
            if np.count_nonzero(~seen) >= min_cells:
                rc = f.cells[~seen]
                cx, cy = fmap.cell_to_world(rc[:, 1].mean(), rc[:, 0].mean())
                out.append(Frontier(rc, (float(cx), float(cy))))
        return out

    def goal_failed(self, goal: Sequence[float]) -> None:
        """Do not send a goal near ``goal`` again: the navigation gave up on it or reached
        it (the explorer node calls this when it sends a goal)."""
        self.failed.append((float(goal[0]), float(goal[1])))


def _distances(grid: PlanningGrid, pose: Sequence[float]) -> Optional[np.ndarray]:
    """Path length (m, the planner's step costs) from the robot to every passable cell; inf
    where unreachable. None when the robot has no passable cell near it."""
    from scipy.sparse.csgraph import dijkstra

    start = grid.free_cell_near(float(pose[0]), float(pose[1]))
    if start is None:
        return None
    graph, node = grid.graph()
    d = dijkstra(graph, directed=False, indices=int(node[start[1], start[0]]))
    out = np.full(node.shape, np.inf)
    out[node >= 0] = d * grid.resolution
    return out
