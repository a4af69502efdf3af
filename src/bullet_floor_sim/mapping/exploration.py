"""Exploring a world in one process: the embedded mapper, the explorer and the embedded
navigation drive one robot until no reachable frontier is left (the core of mapping.launch's
``explore:=true``, as the evaluation plays the observer scenario in one process).

The mapper takes the robot's scans at its ground-truth laser pose every ``map_every``
seconds; every new goal is planned on the map built so far (unknown space passable, as
navfn's ``allow_unknown``: the robot's lidar stops it at what it finds there).
Coverage is measured against the world's map: the share of the true free cells of the
robot's free-space component that the map reads free.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, List, Optional, Tuple

import numpy as np

from ..nav.planner import Navigator, PathFollower, PlanError, PlanningGrid, obstacles_in_base
from ..nav.grid import PlannerConfig
from ..sim.sensors import Scan
from .frontiers import Explorer, ExplorerConfig
from .occupancy import MapperConfig, OccupancyMapper

__all__ = ["ExploreResult", "explore", "coverage"]


@dataclass
class ExploreResult:
    """What :func:`explore` did: the map, (sim seconds, coverage) every 30 s, the goals sent
    and whether it finished (no reachable frontier left)."""

    mapper: OccupancyMapper
    curve: List[Tuple[float, float]] = field(default_factory=list)
    goals: List[Tuple[float, float]] = field(default_factory=list)
    failed: int = 0
    finished: bool = False
    sim_time: float = 0.0


def explore(world: Any, robot: int = 0, seconds: float = 900.0, map_every: float = 0.5,
            mapper_config: MapperConfig = MapperConfig(),
            progress: Optional[Callable[[str], None]] = None) -> ExploreResult:
    """Explore ``world`` with robot ``robot`` for at most ``seconds`` of sim time."""
    say = progress or (lambda _s: None)
    laser = world.models[robot].laser_pose
    mapper = OccupancyMapper(mapper_config, centre=world.pose[robot, :2])
    explorer = Explorer(ExplorerConfig(robot_radius=float(world.radius[robot])))
    truth = _reachable_free(world, robot)
    out = ExploreResult(mapper)
    t0 = world.clock.now
    nav: Optional[Navigator] = None
    goal: Optional[Tuple[float, float, float]] = None
    next_map = next_curve = t0
    scan: Optional[Scan] = None
    steps = max(1, int(round(0.1 / world.clock.dt)))
    while world.clock.now - t0 < seconds:
        for s in world.step(steps):
            if isinstance(s, Scan) and s.robot == robot:
                scan = s
        t = world.clock.now
        x, y, yaw = (float(v) for v in world.pose[robot])
        if scan is not None and t >= next_map:
            c, s_ = math.cos(yaw), math.sin(yaw)
            mapper.update((x + c * laser[0] - s_ * laser[1], y + s_ * laser[0] + c * laser[1],
                           yaw + laser[3]), scan.ranges, scan.angle_min, scan.angle_increment,
                          scan.range_max)
            mapper.clear_disc(x, y, float(world.radius[robot]))
            next_map = t + map_every
        if t >= next_curve:
            out.curve.append((t - t0, coverage(mapper, world.fmap, truth)))
            say("explore: %.0f s, %.1f %% of the free space mapped, %d goals"
                % (t - t0, 100 * out.curve[-1][1], len(out.goals)))
            next_curve = t + 30.0
        if nav is None:
            built = mapper.floor_map()
            goal = explorer.next_goal(built, (x, y, yaw))
            if goal is None:
                out.finished = True
                break
            nav = Navigator(PlanningGrid(built, PlannerConfig(
                robot_radius=float(world.radius[robot]), unknown_is_obstacle=False)),
                PathFollower())
            try:
                nav.start((x, y, yaw), goal, t)
                out.goals.append((goal[0], goal[1]))
            except PlanError:
                explorer.goal_failed(goal)
                out.failed += 1
                nav = None
                continue
        obstacles = None if scan is None else obstacles_in_base(
            scan.ranges, scan.angle_min, scan.angle_increment, scan.range_max,
            (laser[0], laser[1], laser[3]))
        st = nav.update((x, y, yaw), obstacles, t)
        if st.state == "active":
            world.command(robot, st.v, 0.0, st.w)
            continue
        world.command(robot, 0.0, 0.0, 0.0)
        if goal is not None:
            explorer.goal_failed(goal)     # reached or not, its place is done with
            out.failed += 0 if st.state == "succeeded" else 1
        nav = None
    out.sim_time = world.clock.now - t0
    out.curve.append((out.sim_time, coverage(mapper, world.fmap, truth)))
    return out


def _reachable_free(world: Any, robot: int) -> np.ndarray:
    """The true map's free cells in the robot's 4-connected free-space component."""
    from scipy.ndimage import label

    free = world.fmap.grid == 0
    labels, _ = label(free)
    col, row = world.fmap.world_to_cell(world.pose[robot, 0], world.pose[robot, 1])
    return labels == labels[int(row), int(col)]


def coverage(mapper: OccupancyMapper, fmap: Any, truth: np.ndarray) -> float:
    """Share of the ``truth`` cells (of the world's map ``fmap``) the mapper reads free."""
    rows, cols = np.nonzero(truth)
    x, y = fmap.cell_to_world(cols, rows)
    res = mapper.config.resolution
    r = np.floor((np.asarray(y) - mapper.origin[1]) / res).astype(int)
    c = np.floor((np.asarray(x) - mapper.origin[0]) / res).astype(int)
    g = mapper.grid()
    inside = (r >= 0) & (c >= 0) & (r < g.shape[0]) & (c < g.shape[1])
    seen = np.zeros(len(r), dtype=bool)
    seen[inside] = g[r[inside], c[inside]] == 0
    return float(seen.mean()) if len(seen) else math.nan
