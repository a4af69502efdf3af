"""Exploring a world in one process: the embedded mapper, the explorer and the embedded
navigation drive one robot until no reachable frontier is left (the core of mapping.launch's
``explore:=true``, as the evaluation plays the observer scenario in one process).

Two ways to place the scans:

* ``slam=None``: at the robot's ground-truth laser pose every ``map_every`` seconds, in the
  world's frame (the map as it would be with perfect localisation);
* ``slam=SlamConfig(...)``: as mapping.launch's embedded mapper does
  (:class:`~.slam.ScanMatchingMapper`): at the odometry pose corrected by scan matching, in
  the frame where odometry started (the robot's spawn pose); the robot then navigates by that
  estimate too, as it does in ROS.

Every new goal is planned on the map built so far (unknown space passable, as navfn's
``allow_unknown``: the robot's lidar stops it at what it finds there). Coverage is measured
against the world's map: the share of the true free cells of the robot's free-space component
that the map reads free (:func:`coverage`, which takes the map frame's pose in the world).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, List, Optional, Sequence, Tuple

import numpy as np

from ..geometry import compose
from ..nav.grid import PlannerConfig
from ..nav.planner import Navigator, PathFollower, PlanError, PlanningGrid, obstacles_in_base
from ..sim.sensors import Scan
from .compare import reachable, sample
from .frontiers import Explorer, ExplorerConfig
from .occupancy import MapperConfig, OccupancyMapper
from .slam import ScanMatchingMapper, SlamConfig

__all__ = ["ExploreResult", "explore", "coverage"]


@dataclass
class ExploreResult:
    """What :func:`explore` did: the map, the map frame's pose in the world, (sim seconds,
    coverage) every 30 s, the goals sent, whether it finished (no reachable frontier left)
    and the pose estimate's error at the end (metres, radians)."""

    mapper: OccupancyMapper
    frame: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    curve: List[Tuple[float, float]] = field(default_factory=list)
    goals: List[Tuple[float, float]] = field(default_factory=list)
    failed: int = 0
    finished: bool = False
    sim_time: float = 0.0
    error: Tuple[float, float] = (0.0, 0.0)


class _Localiser:
    """The robot's pose in the map frame and the scans into the map: ground truth, or
    odometry corrected by scan matching (see the module doc)."""

    def __init__(self, world: Any, robot: int, slam: Optional[SlamConfig], map_every: float,
                 mapper_config: MapperConfig) -> None:
        self.world, self.robot, self.map_every = world, robot, map_every
        lp = world.models[robot].laser_pose
        self.laser = (float(lp[0]), float(lp[1]), float(lp[3]))
        self.slam = None if slam is None else ScanMatchingMapper(slam, mapper_config)
        if self.slam is None:
            self.mapper = OccupancyMapper(mapper_config, centre=world.pose[robot, :2])
            self.frame = (0.0, 0.0, 0.0)
        else:
            self.slam.mapper = self.mapper = OccupancyMapper(mapper_config, centre=(0.0, 0.0))
            x, y, yaw = (float(v) for v in world.spawn[robot])
            self.frame = (x, y, yaw)
        self.next_map = -math.inf

    def pose(self) -> Tuple[float, float, float]:
        """The robot's pose in the map frame."""
        if self.slam is None:
            x, y, yaw = (float(v) for v in self.world.pose[self.robot])
            return (x, y, yaw)
        self.world.update_odometry()
        return self.slam.in_map(self.world.odometry.pose[self.robot])

    def add(self, scan: Scan, t: float) -> None:
        """Put ``scan`` (taken now) into the map, if it is due."""
        args = (scan.ranges, scan.angle_min, scan.angle_increment, scan.range_max)
        if self.slam is not None:
            self.world.update_odometry()
            self.slam.add(compose(self.world.odometry.pose[self.robot], self.laser), *args)
        elif t >= self.next_map:
            self.mapper.update(compose(self.world.pose[self.robot], self.laser), *args)
            self.next_map = t + self.map_every
        else:
            return
        x, y, _ = self.pose()
        self.mapper.clear_disc(x, y, float(self.world.radius[self.robot]))


def explore(world: Any, robot: int = 0, seconds: float = 900.0, map_every: float = 0.5,
            mapper_config: MapperConfig = MapperConfig(), slam: Optional[SlamConfig] = None,
            progress: Optional[Callable[[str], None]] = None) -> ExploreResult:
    """Explore ``world`` with robot ``robot`` for at most ``seconds`` of sim time."""
    say = progress or (lambda _s: None)
    loc = _Localiser(world, robot, slam, map_every, mapper_config)
    radius = float(world.radius[robot])
    explorer = Explorer(ExplorerConfig(robot_radius=radius))
    truth = reachable(world.fmap, *world.spawn[robot][:2])
    out = ExploreResult(loc.mapper, loc.frame)
    t0 = world.clock.now
    nav: Optional[Navigator] = None
    goal: Optional[Tuple[float, float, float]] = None
    next_curve = t0
    scan: Optional[Scan] = None
    steps = max(1, int(round(0.1 / world.clock.dt)))
    while world.clock.now - t0 < seconds:
        for s in world.step(steps):
            if isinstance(s, Scan) and s.robot == robot:
                scan = s
                loc.add(s, world.clock.now)
        t = world.clock.now
        pose = loc.pose()
        if t >= next_curve:
            out.curve.append((t - t0, coverage(loc.mapper, world.fmap, truth, loc.frame)))
            say("explore: %.0f s, %.1f %% of the free space mapped, %d goals"
                % (t - t0, 100 * out.curve[-1][1], len(out.goals)))
            next_curve = t + 30.0
        if nav is None:
            built = loc.mapper.floor_map()
            goal = explorer.next_goal(built, pose)
            if goal is None:
                out.finished = True
                break
            nav = Navigator(PlanningGrid(built, PlannerConfig(
                robot_radius=radius, unknown_is_obstacle=False)), PathFollower())
            try:
                nav.start(pose, goal, t)
                out.goals.append((goal[0], goal[1]))
            except PlanError:
                explorer.goal_failed(goal)
                out.failed += 1
                nav = None
                continue
        obstacles = None if scan is None else obstacles_in_base(
            scan.ranges, scan.angle_min, scan.angle_increment, scan.range_max, loc.laser)
        st = nav.update(pose, obstacles, t)
        if st.state == "active":
            world.command(robot, st.v, 0.0, st.w)
            continue
        world.command(robot, 0.0, 0.0, 0.0)
        if goal is not None:
            explorer.goal_failed(goal)     # reached or not, its place is done with
            if st.state == "succeeded":
                explorer.looked_from(goal)
            out.failed += 0 if st.state == "succeeded" else 1
        nav = None
    out.sim_time = world.clock.now - t0
    est, true = compose(loc.frame, loc.pose()), world.pose[robot]
    out.error = (math.hypot(est[0] - true[0], est[1] - true[1]),
                 abs(math.remainder(est[2] - true[2], math.tau)))
    out.curve.append((out.sim_time, coverage(loc.mapper, world.fmap, truth, loc.frame)))
    return out


def coverage(mapper: OccupancyMapper, fmap: Any, truth: np.ndarray,
             frame: Sequence[float] = (0.0, 0.0, 0.0)) -> float:
    """Share of the ``truth`` cells (of the world's map ``fmap``) the mapper reads free;
    ``frame`` is the map frame's pose in the world."""
    rows, cols = np.nonzero(truth)
    seen = sample(mapper.floor_map(), fmap, frame)[rows, cols] == 0
    return float(seen.mean()) if len(seen) else math.nan
