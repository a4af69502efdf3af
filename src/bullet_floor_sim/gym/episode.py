"""Where an episode starts and where its goal is: points of the largest part of the floor a
robot's footprint connects, drawn from the episode's random generator."""
from __future__ import annotations

from typing import Tuple

import numpy as np
from ..errors import ConfigError
from ..nav.grid import PlanningGrid, largest_part

__all__ = ["Floor"]

#: Draws of a goal before an episode gives up on its start and draws another.
GOAL_TRIES = 50
#: Starts drawn before the floor is declared too small for the goal distance asked.
START_TRIES = 200


class Floor:
    """The cells a robot can start on and be sent to.

    Args:
        grid: the planning grid of the robot's footprint (walls as the simulator's).
        clearance: the least wall distance (m) of a start or goal point.
        where: names the world in errors.

    Raises:
        ConfigError: no cell of the floor has that clearance.
    """

    def __init__(self, grid: PlanningGrid, clearance: float, where: str) -> None:
        self.grid = grid
        self.where = where
        main = largest_part(np.isfinite(grid.cost))
        if not main.any():
            raise ConfigError("%s: gym: no floor where the robot fits" % where)
        rows, cols = np.nonzero(main & (grid.clearance >= clearance))
        if not len(rows):
            raise ConfigError("%s: gym: no floor with %.2f m clearance for the robot"
                              % (where, clearance))
        x, y = grid.centres(cols, rows)
        self.points = np.column_stack((x, y))

    def draw(self, rng: np.random.Generator, distance: Tuple[float, float], in_sight: bool
             ) -> Tuple[Tuple[float, float, float], Tuple[float, float]]:
        """A start pose (x, y, yaw) and a goal (x, y) ``distance`` apart (straight line),
        both on the floor, the goal in line of sight of the start with ``in_sight``.

        Raises:
            ConfigError: no such pair after many draws (the floor is smaller than asked).
        """
        lo, hi = distance
        pts = self.points
        for _ in range(START_TRIES):
            sx, sy = pts[int(rng.integers(len(pts)))]
            d = np.hypot(pts[:, 0] - sx, pts[:, 1] - sy)
            ok = np.flatnonzero((d >= lo) & (d <= hi))
            if not len(ok):
                continue
            for _ in range(GOAL_TRIES):
                gx, gy = pts[int(ok[int(rng.integers(len(ok)))])]
                if not in_sight or self.grid.line_of_sight((sx, sy), (gx, gy)):
                    yaw = float(rng.uniform(-np.pi, np.pi))
                    return (float(sx), float(sy), yaw), (float(gx), float(gy))
        raise ConfigError("%s: gym: no start and goal %.1f-%.1f m apart%s on the floor"
                          % (self.where, lo, hi, " in sight" if in_sight else ""))
