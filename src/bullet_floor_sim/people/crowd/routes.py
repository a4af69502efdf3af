"""Paths for many people at once: one shortest-path tree per region, shared by everyone
walking to it.

A leg goes to a point inside a region. Planning each leg with A* costs 10-70 ms on the
shipped maps, too much for a crowd; instead, the first leg to a region runs Dijkstra once
from all of that region's goal cells (scipy's, over the passable cells of the people's
planning grid, with A*'s step costs: 8-connected, no corner cutting, the wall cost added), and
keeps the predecessor of every cell. A path to the region is then the chain of predecessors
from the start cell, and the last stretch to the goal point a straight line inside the region
(or A* there, where a wall is in the way).
"""
from __future__ import annotations

from typing import Any, Dict, Sequence

import numpy as np

from ...data.rois import Roi
from ...nav.grid import PlanError, PlanningGrid
from ..walker import GoalSampler

__all__ = ["Routes"]

_ROOT = -1


class Routes:
    """Paths from anywhere on the floor to the goal points of regions.

    Args:
        grid: the people's planning grid (its robot radius is a person's).
        sampler: the goal sampler on that grid (a region's goal cells are its ``cells_in``).
    """

    def __init__(self, grid: PlanningGrid, sampler: GoalSampler) -> None:
        self.grid = grid
        self.sampler = sampler
        self._graph, self._node = grid.graph()
        self._cells = np.argwhere(self._node >= 0)       # node -> (row, col)
        self._trees: Dict[str, np.ndarray] = {}
        #: per ROI file: (its Markov chain, the regions walked, the warnings), kept by
        #: build.build_crowd (the regions a walker reaches are this sampler's)
        self.chains: Dict[str, Any] = {}

    def tree(self, roi: Roi) -> np.ndarray:
        """The predecessor of every node on its shortest path to ``roi``'s goal cells
        (``_ROOT`` at a goal cell, another negative number where there is no path);
        computed once per region."""
        pred = self._trees.get(roi.id)
        if pred is None:
            from scipy.sparse.csgraph import dijkstra

            x, y, _ = self.sampler.cells_in(roi)
            col, row = self.grid.fmap.world_to_cell(x, y)
            nodes = self._node[np.asarray(row) // self.grid.factor,
                               np.asarray(col) // self.grid.factor]
            nodes = np.unique(nodes[nodes >= 0])
            if not len(nodes):
                raise PlanError("region %r has no cell a person can stand in" % roi.id)
            _, pred, _ = dijkstra(self._graph, directed=False, indices=nodes, min_only=True,
                                  return_predecessors=True)
            pred = np.asarray(pred, dtype=np.int64)   # -9999 where there is no path
            pred[nodes] = _ROOT
            self._trees[roi.id] = pred
        return pred

    def route(self, start: Sequence[float], roi: Roi, goal: Sequence[float]) -> np.ndarray:
        """(M, 2) map-frame points from ``start`` to ``goal`` (a goal point of ``roi``), one
        planning cell apart up to the region.

        Raises:
            PlanError: the start has no passable cell near it, or cannot reach the region.
        """
        grid = self.grid
        cell = grid.free_cell_near(float(start[0]), float(start[1]))
        if cell is None:
            raise PlanError("no passable cell near (%.2f, %.2f)" % (start[0], start[1]))
        pred = self.tree(roi)
        u = int(self._node[cell[1], cell[0]])
        nodes = [u]
        while pred[u] >= 0:
            u = int(pred[u])
            nodes.append(u)
        if pred[u] != _ROOT:    # the chain ended before the region: no path
            raise PlanError("region %r cannot be reached from (%.2f, %.2f)"
                            % (roi.id, start[0], start[1]))
        rc = self._cells[np.asarray(nodes)]
        k = grid.factor
        x, y = grid.fmap.cell_to_world((rc[:, 1] + 0.5) * k - 0.5, (rc[:, 0] + 0.5) * k - 0.5)
        pts = np.column_stack((np.atleast_1d(x), np.atleast_1d(y)))
        entry = (float(pts[-1, 0]), float(pts[-1, 1]))
        g = (float(goal[0]), float(goal[1]))
        if grid.line_of_sight(entry, g):
            rest = np.array([g])
        else:
            rest = grid.plan(entry, g)[1:]
        return np.vstack((np.asarray(start[:2], dtype=float)[None, :], pts[1:], rest))
