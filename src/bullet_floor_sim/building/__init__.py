"""A world's building: the facts about its floor that the map check, the walker, the people and
the evaluation need, worked out once per world.

:class:`Building` holds the user's map, what the world's map handling makes solid
(sim/solidmap.py), the regions of interest, and per footprint the planning grid (where a disc
of that radius fits), the goal sampler (the points a walker of that footprint is sent to) and
the regions it can walk. building/check.py reports on it (``check_world``).

Two footprints matter to a study: a robot's (the planner's ``robot_radius``, the walker's goal
``clearance``) and a person's (the crowd's body radius, and GOAL_CLEARANCE more for a goal).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Dict, List, Optional, Tuple

from ..data.rois import Roi, load_rois
from ..nav.grid import PlannerConfig, PlanningGrid, largest_part
from ..sim.config import WorldConfig, load_world_config, resolve_world
from ..sim.floormap import FloorMap, load_map
from ..sim.solidmap import SolidMap, solid_map

__all__ = ["Building", "Footprint", "robot_footprint", "person_footprint"]


@dataclass(frozen=True)
class Footprint:
    """A disc that walks the floor: ``radius`` (m, where the planner lets it go) and
    ``clearance`` (m, the least wall distance of a goal point)."""

    name: str
    radius: float
    clearance: float


def robot_footprint(planner: Optional[PlannerConfig] = None) -> Footprint:
    """The walker robot's footprint as the planner and the walker's goal sampler use it."""
    from ..people.walker import WalkerConfig

    radius = (planner or PlannerConfig()).robot_radius
    return Footprint("robot", radius, max(radius, WalkerConfig().clearance))


def person_footprint(config: WorldConfig) -> Footprint:
    """A person's footprint: the world's body radius, goals GOAL_CLEARANCE further in."""
    from ..people.crowd.build import GOAL_CLEARANCE

    r = config.people.body.radius
    return Footprint("person", r, r + GOAL_CLEARANCE)


class Building:
    """The floor of one world (see the module doc). Everything is computed on first use and
    kept.

    Args:
        config: the parsed world.yaml.
        fmap: its map when already loaded (else read from ``config.map_yaml``).
        planner: the planning parameters of every footprint's grid, its ``robot_radius``
            set per footprint (default: PlannerConfig(), what the nodes plan with).
    """

    def __init__(self, config: WorldConfig, fmap: Optional[FloorMap] = None,
                 planner: Optional[PlannerConfig] = None) -> None:
        self.config = config
        self.fmap = fmap if fmap is not None else load_map(config.map_yaml)
        self.planner = planner or PlannerConfig()
        self._grids: Dict[float, PlanningGrid] = {}
        self._samplers: Dict[Footprint, object] = {}
        self._rois: Optional[Tuple[List[Roi], List[str]]] = None

    @classmethod
    def load(cls, world: str) -> "Building":
        """The building of a world name under worlds/ or a world.yaml path.

        Raises:
            ConfigError: no such world, or a bad world file or map.
        """
        from ..paths import worlds_dir

        return cls(load_world_config(resolve_world(world, worlds_dir())))

    @property
    def name(self) -> str:
        return self.config.name

    @property
    def solid(self) -> SolidMap:
        """The solid cells as the simulator extrudes them, and what the handling changed."""
        return solid_map(self.fmap, self.config.map_handling)

    def grid(self, radius: float) -> PlanningGrid:
        """The planning grid for a disc of ``radius`` (walls as the simulator's)."""
        key = round(float(radius), 4)
        if key not in self._grids:
            self._grids[key] = PlanningGrid(self.fmap, replace(self.planner, robot_radius=key),
                                            handling=self.config.map_handling)
        return self._grids[key]

    def sampler(self, footprint: Footprint):
        """The goal sampler (people/walker.GoalSampler) of a footprint."""
        from ..people.walker import GoalSampler, WalkerConfig

        if footprint not in self._samplers:
            w = WalkerConfig()
            self._samplers[footprint] = GoalSampler(self.grid(footprint.radius),
                                                    footprint.clearance, w.margin, w.goal_tries)
        return self._samplers[footprint]

    def regions(self) -> Tuple[List[Roi], List[str]]:
        """The world's valid ROIs, and one warning per ROI left out as invalid (no ROIs when
        the world has no rois file)."""
        if self._rois is None:
            from ..people.markov import usable_rois

            self._rois = usable_rois(load_rois(self.config.rois)) if self.config.rois else ([], [])
        return self._rois

    def roomy_starts(self, n: int, apart: float, within: Optional[float] = None
                     ) -> List[Tuple[float, float]]:
        """``n`` start points for robots: the roomiest cells (most wall clearance) of the
        largest part of the floor a robot's footprint connects, each at least ``apart`` m
        from those before, and with ``within``, at most that far from the first and in a
        straight line of sight of it on the planning grid (an observer that starts seeing
        its walker); fewer when the floor has no room for them."""
        import numpy as np

        grid = self.grid(robot_footprint().radius)
        rows, cols = np.nonzero(largest_part(np.isfinite(grid.cost)))
        if not len(rows):
            return []
        order = np.argsort(-grid.clearance[rows, cols], kind="stable")
        out: List[Tuple[float, float]] = []
        for k in order:
            x, y = grid.to_world(int(cols[k]), int(rows[k]))
            if out and within is not None and not (
                    (x - out[0][0]) ** 2 + (y - out[0][1]) ** 2 <= within ** 2
                    and grid.line_of_sight(out[0], (x, y))):
                continue
            if all((x - a) ** 2 + (y - b) ** 2 >= apart ** 2 for a, b in out):
                out.append((x, y))
                if len(out) == n:
                    break
        return out

    def walkable(self, footprint: Footprint) -> Tuple[List[Roi], List[str]]:
        """The regions a walker of ``footprint`` walks (people/walker.walkable_regions), and
        one warning per region left out."""
        from ..people.walker import walkable_regions

        return walkable_regions(self.regions()[0], self.sampler(footprint))
