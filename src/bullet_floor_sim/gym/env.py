"""``FloorNavEnv``: a Gymnasium environment of one robot sent to a goal on a real building's
floor among walking people, on the simulator's own core (sim.World, people/crowd), no ROS.

Each episode (``reset(seed=...)``) draws a start pose and a goal on the largest part of the
floor the robot fits (episode.Floor), puts the robot there and starts the people afresh at
points of the world's regions; they walk between regions by the Markov chain and keep clear
of the robot by their social force. An action is the robot's commanded (v, w), held for
``control_rate``'s period. The observation is the lidar's latest scan, the goal in the robot
frame and the robot's velocity; the reward is config.RewardConfig's sum. An episode ends on
arrival or a collision and is cut off after ``max_time``.

The same seed gives the same episode: the world's noise, its sensors' schedules, the start,
the goal and the people are all drawn from it (``World.restart``).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Dict, Optional, Tuple

import gymnasium
import numpy as np
from gymnasium import spaces

from ..errors import ConfigError
from ..building import Building
from ..paths import worlds_dir
from ..people.crowd.build import build_crowd, routes_for
from ..sim.config import load_world_config, resolve_world
from ..sim.world import World
from .config import NavEnvConfig
from .episode import Floor

__all__ = ["FloorNavEnv"]


class FloorNavEnv(gymnasium.Env):
    """See the module doc; ``config`` (a NavEnvConfig) or its fields as keywords."""

    metadata = {"render_modes": []}

    def __init__(self, config: Optional[NavEnvConfig] = None, **kwargs: Any) -> None:
        cfg = dataclasses.replace(config or NavEnvConfig(), **kwargs)
        cfg.validate()
        self.config = cfg
        wcfg = load_world_config(resolve_world(cfg.world, worlds_dir()))
        if not 0 <= cfg.robot < len(wcfg.robots):
            raise ConfigError("%s: gym: robot %d is not one of the world's %d robots"
                              % (wcfg.path, cfg.robot, len(wcfg.robots)))
        if cfg.people and not wcfg.rois:
            raise ConfigError("%s: gym: %d people need the world's regions (rois:), and it has "
                              "none" % (wcfg.path, cfg.people))
        self.world = World(dataclasses.replace(wcfg, robots=[wcfg.robots[cfg.robot]]),
                           physics_rate=cfg.physics_rate, seed=0, ray_threads=cfg.ray_threads)
        try:
            self._setup(cfg, wcfg)
        except BaseException:
            self.world.close()
            raise

    def _setup(self, cfg: NavEnvConfig, wcfg: Any) -> None:
        """The floor, the people's routes, the spaces (the world loaded)."""
        w = self.world
        self.radius = float(w.radius[0])
        self.floor = Floor(Building(wcfg, w.fmap).grid(self.radius),
                           self.radius + cfg.clearance, wcfg.path)
        self._people_cfg = wcfg.people.with_count(cfg.people)
        self._routes = routes_for(w, self._people_cfg.body) if cfg.people else None
        drive = w.specs[0].drive
        hold = cfg.steps_per_action * w.clock.dt
        if hold >= drive.cmd_timeout:
            raise ConfigError("%s: gym: an action holds %.2f s (control_rate %g Hz), as long as "
                              "the drive's cmd_timeout (%.2f s) stops the robot: raise "
                              "control_rate" % (wcfg.path, hold, cfg.control_rate,
                                                drive.cmd_timeout))
        if not w.specs[0].laser.enabled:
            raise ConfigError("%s: gym: robot %d has no lidar (laser: enabled: false)"
                              % (wcfg.path, cfg.robot))
        self.action_space = spaces.Box(np.array([-drive.max_linear, -drive.max_angular], np.float32),
                                       np.array([drive.max_linear, drive.max_angular], np.float32),
                                       dtype=np.float32)
        beams = w.specs[0].laser.beams
        x0, y0, x1, y1 = w.bounds
        reach = float(math.hypot(x1 - x0, y1 - y0))
        self.observation_space = spaces.Dict({
            "scan": spaces.Box(0.0, cfg.scan_range, (beams,), np.float32),
            "goal": spaces.Box(-reach, reach, (2,), np.float32),
            "velocity": spaces.Box(self.action_space.low, self.action_space.high,
                                   dtype=np.float32)})
        self._scan = np.full(beams, cfg.scan_range, np.float32)
        self._scan_stamp = 0
        self.goal = (0.0, 0.0)
        self._steps = 0
        self._max_steps = int(math.ceil(cfg.max_time / hold - 1e-9))
        self._distance = 0.0

    # ----------------------------------------------------------------------------- episodes
    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None
              ) -> Tuple[Dict[str, np.ndarray], Dict[str, Any]]:
        """A new episode (see the module doc); ``options`` may give ``start`` (x, y, yaw)
        and ``goal`` (x, y) instead of drawing them."""
        super().reset(seed=seed)
        cfg, w, rng = self.config, self.world, self.np_random
        w.add_people(None)
        w.restart(int(rng.integers(2 ** 31)))
        start, goal = self.floor.draw(rng, cfg.goal_distance, cfg.goal_in_sight)
        options = dict(options or {})
        unknown = sorted(set(options) - {"start", "goal"})
        if unknown:
            raise ValueError("FloorNavEnv.reset: unknown option(s) %s (start, goal)"
                             % ", ".join(unknown))
        start = _numbers(options.get("start", start), 3, "start (x, y, yaw)")
        self.goal = _numbers(options.get("goal", goal), 2, "goal (x, y)")
        w.set_pose(0, start)
        if cfg.people:   # every walker seeded from the episode (not the world file's seeds)
            people = dataclasses.replace(
                self._people_cfg, seed=int(rng.integers(2 ** 31)),
                groups=tuple(dataclasses.replace(g, seed=None) for g in self._people_cfg.groups))
            w.add_people(build_crowd(w, people, self._routes))
        self._steps = 0
        self._distance = self._goal_distance()
        self._scan_stamp = 0
        while not self._scan_stamp:    # the first scan is due a lidar period on
            self._read(w.step(1))
        return self._observation(), self._info("", 0.0)

    def step(self, action: Any) -> Tuple[Dict[str, np.ndarray], float, bool, bool, Dict]:
        cfg, w, r = self.config, self.world, self.config.reward
        v, om = np.clip(np.asarray(action, dtype=float).reshape(2), self.action_space.low,
                        self.action_space.high)
        if not (math.isfinite(v) and math.isfinite(om)):
            raise ValueError("FloorNavEnv.step: action %r is not finite" % (action,))
        stalls = int(w.stall_count[0])
        w.command(0, float(v), 0.0, float(om))
        self._read(w.step(cfg.steps_per_action))
        self._steps += 1
        dt = cfg.steps_per_action * w.clock.dt
        before, self._distance = self._distance, self._goal_distance()
        gap, depth = self._nearest_person()
        collision = "wall" if w.stall_count[0] > stalls else ("person" if gap < 0.0 else "")
        arrived = self._distance <= cfg.goal_tolerance and not collision
        reward = (r.progress * (before - self._distance) + r.time * dt
                  + r.intrusion * depth * dt + (r.arrival if arrived else 0.0)
                  + (r.collision if collision else 0.0))
        terminated = arrived or bool(collision)
        truncated = not terminated and self._steps >= self._max_steps
        return self._observation(), float(reward), terminated, truncated, \
            self._info(collision, depth)

    def close(self) -> None:
        self.world.close()

    # ----------------------------------------------------------------------------- views
    def _read(self, scans: list) -> None:
        """Keep the latest scan's ranges, clipped to scan_range (no return reads it too)."""
        if not scans:
            return
        r = np.asarray(scans[-1].ranges, dtype=np.float32)
        self._scan = np.clip(np.nan_to_num(r, posinf=self.config.scan_range, neginf=0.0),
                             0.0, self.config.scan_range).astype(np.float32)
        self._scan_stamp = scans[-1].stamp_ns

    def _goal_distance(self) -> float:
        x, y, _ = self.world.pose[0]
        return float(math.hypot(self.goal[0] - x, self.goal[1] - y))

    def _nearest_person(self) -> Tuple[float, float]:
        """(the least gap (m) between the robot's body and a person's, negative when they
        touch; how deep the robot is in the nearest personal space, m)."""
        people = self.world.people
        if people is None or not people.n:
            return math.inf, 0.0
        x, y, _ = self.world.pose[0]
        d = np.hypot(people.pos[:, 0] - x, people.pos[:, 1] - y) - people.radius - self.radius
        gap = float(d.min())
        return gap, max(0.0, self.config.personal_space - gap)

    def _observation(self) -> Dict[str, np.ndarray]:
        w = self.world
        x, y, yaw = w.pose[0]
        dx, dy = self.goal[0] - x, self.goal[1] - y
        c, s = math.cos(yaw), math.sin(yaw)
        box = self.observation_space["goal"]
        goal = np.clip(np.array([c * dx + s * dy, -s * dx + c * dy], np.float32),
                       box.low, box.high)
        vel = np.clip(np.array([w.vel[0, 0], w.vel[0, 2]], np.float32),
                      self.action_space.low, self.action_space.high)
        return {"scan": self._scan.copy(), "goal": goal, "velocity": vel}

    def _info(self, collision: str, intrusion: float) -> Dict[str, Any]:
        x, y, yaw = (float(v) for v in self.world.pose[0])
        return {"pose": (x, y, yaw), "goal": self.goal, "distance": self._distance,
                "collision": collision, "intrusion": intrusion,
                "is_success": self._distance <= self.config.goal_tolerance and not collision,
                "time": self._steps * self.config.steps_per_action * self.world.clock.dt}


def _numbers(value: Any, n: int, what: str) -> tuple:
    """``value`` as a tuple of ``n`` finite floats, or ValueError naming ``what``."""
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        out = ()
    if len(out) != n or not all(math.isfinite(v) for v in out):
        raise ValueError("FloorNavEnv.reset: %s must be %d finite numbers, got %r"
                         % (what, n, value))
    return out
