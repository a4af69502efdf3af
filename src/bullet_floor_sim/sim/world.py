"""The simulated floor: one PyBullet client, one sim clock, a fixed step, all robots.

``World`` owns sim time (``SimClock``: integer nanoseconds, never 0) and every robot's state
as arrays (one row per robot). A step, at ``physics_rate`` (100 Hz by default):

1. the watchdog zeroes the target of robots without a command for ``cmd_timeout``;
2. the drive moves each velocity toward its target within the velocity/acceleration limits
   and poses are integrated exactly for constant body velocity over the step (kinematics.py);
3. robots that could touch a wall or each other (from the map's clearance field) are checked
   exactly with PyBullet collision detection against the wall mesh and the other robots; a move
   that would penetrate deeper is refused and the robot stops, as Stage does (collision.py);
4. the people, if any (``add_people``), are stepped when due (people/crowd);
5. odometry and wheel angles are integrated; lidars that are due are cast in one batch at the
   walls, then the beams that may reach another robot against it (robot_beams.py), then
   those that may reach a person's leg against the legs (leg_beams.py).

The walls are static concave triangle meshes: vertical quads on the outline of the map's solid
cells (walls.py; sim/solidmap.py: occupied, and unknown unless the world says otherwise). The
faces inside a wall and on top are left out: a level beam never meets them and a robot meets a
side face first. On the real maps that halves the triangles and makes a ray 1.6-3x cheaper.
What is measured of the robots' bodies once at load is measure.py's.
"""
from __future__ import annotations

import contextlib
import math
import os
import sys
from typing import Dict, Iterable, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from . import collision, grid_rays, kinematics, leg_beams, measure, robot_beams, walls
from .clock import SimClock
from .people import People
from .views import RobotView, Snapshot
from .config import RobotSpec, WorldConfig, load_world_config, resolve_world
from ..errors import ConfigError
from .floormap import FloorMap, load_map
from ..paths import worlds_dir
from ..geometry import wrap_angle
from .robot import DRIVES, RobotModel, check_command, load_model
from .sensors import SENSORS, Battery, Lidar, Odometry, Scan, Sensor, cast_rays, ray_chunk
from . import small
from .measure import ROBOT_GROUP, ROBOT_MASK, SELF_GROUP
from .solidmap import SolidMap, solid_map

__all__ = ["SimClock", "World", "RobotView", "Snapshot", "People"]

#: The batch size from which ray casts use ``ray_threads`` (smaller ones run on one thread:
#: threads cost more than they save; measured on two cores through the C API, 100 rays took
#: 57 us on one thread and 65 on two, 200 rays 108 and 97, a 360-beam scan 186 and 144).
_THREADED_RAYS = 160


#: ``cast_beams``' rays to cast when every lidar is where it was
_NO_RAYS = np.zeros(0, dtype=np.int64)


class World:
    """A floor map extruded into PyBullet walls, with robots.

    Args:
        config: the parsed world file.
        physics_rate: fixed steps per second of sim time.
        gui: open the PyBullet window instead of running headless (DIRECT).
        seed: seed of every noise source (None = random).
        ray_threads: pybullet numThreads for ray casts (0 = all cores).
        start_time: sim time before the first step, seconds.

    Raises:
        ConfigError, MapError, RobotModelError: the world, map or a model cannot be loaded.
    """

    def __init__(self, config: WorldConfig, physics_rate: float = 100.0, gui: bool = False,
                 seed: Optional[int] = None, ray_threads: int = 0, start_time: float = 1.0) -> None:
        with _quiet_stdout():  # pybullet prints its build time and argv on import/connect
            import pybullet
            from pybullet_utils import bullet_client

        self.config = config
        self.clock = SimClock(physics_rate, start_time)
        self.rng = np.random.default_rng(seed)
        self.ray_threads = int(ray_threads)
        self.fmap: FloorMap = load_map(config.map_yaml)  # the user's map, as map_server serves it
        self.solid: SolidMap = solid_map(self.fmap, config.map_handling)  # what is extruded
        with _quiet_stdout():
            self.client = bullet_client.BulletClient(
                connection_mode=pybullet.GUI if gui else pybullet.DIRECT)
        self._gui = gui
        # bound once: BulletClient builds a new partial on every attribute access
        self._reset_pose = self.client.resetBasePositionAndOrientation
        self._closest_points = self.client.getClosestPoints
        if gui:
            self.client.configureDebugVisualizer(pybullet.COV_ENABLE_GUI, 0)
        self.wall_bodies = walls.build_walls(self.client, self.solid, config.wall_height, gui,
                                            self.fmap.yaml_path)
        self._clearance = walls.clearance_field(self.solid)
        self.people: Optional[People] = None   # see add_people
        self.rays_at_legs = 0       # beams shortened by a person's leg (statistics)
        self.specs: List[RobotSpec] = list(config.robots)
        self.models: List[RobotModel] = [load_model(s.model) for s in self.specs]
        self._init_robots()
        self._check_spawns()

    @classmethod
    def from_name(cls, world: str, **kwargs) -> "World":
        """Load ``world`` (a name under worlds/ or a path to a world.yaml)."""
        return cls(load_world_config(resolve_world(world, worlds_dir())), **kwargs)

    # ----------------------------------------------------------------------------- set-up
    def _init_robots(self) -> None:
        p = self.client
        n = len(self.specs)
        self.n = n
        self.spawn = np.array([s.pose for s in self.specs], dtype=float).reshape(n, 3)
        self.pose = self.spawn.copy()  # yaw is kept unwrapped while stepping
        self.vel = np.zeros((n, 3))
        self.target = np.zeros((n, 3))
        self.last_cmd_ns = np.full(n, -(2 ** 62), dtype=np.int64)
        self.cmd_timeout_ns = np.array([int(s.drive.cmd_timeout * 1e9) for s in self.specs],
                                       dtype=np.int64)
        self._expiry_ns = 2 ** 62          # earliest watchdog expiry of a moving target
        self._travel = np.zeros((n, 2))     # integral of (v, w) dt, for wheel angles
        self.wheel_radius = np.array([m.wheel_radius for m in self.models])
        self.wheel_sep = np.array([m.wheel_separation for m in self.models])
        self.stalled = np.zeros(n, dtype=bool)
        self.stall_count = np.zeros(n, dtype=np.int64)
        self._penetration = np.zeros(n)        # deepest into a wall
        self._robot_penetration = np.zeros(n)  # deepest into another robot
        self._vmax = np.array([math.hypot(s.drive.max_linear,
                                          s.drive.max_lateral if s.drive.type == "omni" else 0.0)
                               for s in self.specs])
        self._check_due_ns = 0              # next step whose poses need a collision check
        self._safe_until_ns = np.zeros(n, dtype=np.int64)   # per robot: no contact before
        self._window_consts = None          # for collision._window_small
        self._limits_small = None           # (dt, vmax, amax * dt) for kinematics.advance_small
        # one drive object per drive type, each over its own rows
        self._drives = []
        for kind, cls in DRIVES.items():
            rows = [i for i, s in enumerate(self.specs) if s.drive.type == kind]
            if rows:
                sel = slice(None) if len(rows) == n else np.array(rows)
                self._drives.append((sel, cls([self.specs[i].drive for i in rows])))
        self.bodies = []
        self._inertial = []
        self._body_at: List[Optional[Tuple[float, float, float]]] = [None] * n   # see _set_body
        for i, (spec, model) in enumerate(zip(self.specs, self.models)):
            x, y, yaw = self.pose[i]
            try:
                with _quiet_stdout():
                    b = p.loadURDF(model.urdf_path, [x, y, 0.0],
                                   p.getQuaternionFromEuler([0, 0, yaw]),
                                   flags=p.URDF_MERGE_FIXED_LINKS)
            except p.error as e:
                raise ConfigError("robot %r: PyBullet cannot load model %r (%s): %s"
                                  % (spec.name, spec.model, model.urdf_path, e)) from None
            p.setCollisionFilterGroupMask(b, -1, ROBOT_GROUP, ROBOT_MASK)
            self.bodies.append(b)
            info = p.getDynamicsInfo(b, -1)  # the base's pose in PyBullet is its inertial frame
            self._inertial.append((tuple(info[3]), tuple(info[4])))
        self._body_index = {b: i for i, b in enumerate(self.bodies)}
        cache: dict = {}
        self.radius = np.array([measure.body_radius(self, i, cache) for i in range(n)]).reshape(n)
        self.motion = 0             # physics steps that moved something (odometry catches up)
        # every sensor kind of the registry, over all robots; read when due, in its order
        self.sensors: Dict[str, Sensor] = {
            name: kind.build(self, [s.sensors[name] for s in self.specs])
            for name, kind in SENSORS.items()}
        self._sensor_list = list(self.sensors.values())
        self.schedule_sensors()
        # (what the views and ray casts use) SENSORS builds these classes under these names,
        # but its values are typed as the Sensor protocol: mypy cannot tell which is which
        self.lidar: Lidar = self.sensors["laser"]  # type: ignore[assignment]
        self.odometry: Odometry = self.sensors["odometry"]  # type: ignore[assignment]
        self.battery: Battery = self.sensors["battery"]  # type: ignore[assignment]
        self.bounds = self.fmap.bounds()
        self.rays_cast = 0          # rays cast so far (statistics)
        self.rays_recast = 0        # of which cast again in full after a cut ray missed
        self.rays_at_robots = 0     # of which cast again at other robots (see cast_beams)
        self.rays_reused = 0        # beams of unmoved lidars: wall distances of the last scan
        self._lift_for_rays = not self._gui   # (robots would flicker in the window)
        self._grid_rays = self._walls_on_grid(self.config.wall_height)
        self._body_array = np.array(self.bodies, dtype=np.int64)
        self._beam_geometry = measure.beam_table(self.lidar)
        self._idle = True           # no robot moves or has a non-zero command
        measure.self_exit(self)
        self._ray_radius = measure.radius_at_lasers(self)
        (self.section_index, self._section_normals, self._section_offsets,
         self.sections_report) = measure.sections(self)

    @contextlib.contextmanager
    def only(self, i: int, all_links: bool = False) -> Iterator[None]:
        """Within: rays cast with ``mask=SELF_GROUP`` see robot i's base (with
        ``all_links``, its wheels and other links too) and nothing else."""
        p = self.client
        links = range(-1, p.getNumJoints(self.bodies[i])) if all_links else (-1,)
        for link in links:
            p.setCollisionFilterGroupMask(self.bodies[i], link, SELF_GROUP, ROBOT_MASK)
        try:
            yield
        finally:
            for link in links:
                p.setCollisionFilterGroupMask(self.bodies[i], link, ROBOT_GROUP, ROBOT_MASK)

    def _check_spawns(self) -> None:
        """Refuse a robot whose spawn pose is off the map, in a wall cell or overlaps a wall
        or a robot."""
        for i in range(self.n):
            self._check_cell(i, "spawns")
        self._check_contacts(range(self.n), "spawns")

    def _check_place(self, i: int, verb: str = "would stand") -> None:
        """Raise ConfigError when robot i at its pose is off the map, in a wall or unknown
        cell, or overlaps a wall or another robot."""
        self._check_cell(i, verb)
        self._check_contacts([i], verb)

    def _check_cell(self, i: int, verb: str) -> None:
        """Raise ConfigError when robot i's pose is off the map or in a solid cell."""
        x, y, _ = self.pose[i]
        name = self.specs[i].name
        x0, y0, x1, y1 = self.fmap.bounds()
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            raise ConfigError("%s: robot %r %s off the map at (%.3f, %.3f) (the map spans "
                              "x %.2f..%.2f, y %.2f..%.2f)" % (self.config.path, name, verb,
                                                               x, y, x0, x1, y0, y1))
        if self.solid.fmap.value_at(x, y) == 100:
            what = "a wall" if self.fmap.value_at(x, y) == 100 else "unknown space"
            raise ConfigError("%s: robot %r %s inside %s at (%.3f, %.3f)"
                              % (self.config.path, name, verb, what, x, y))

    def _check_contacts(self, rows: Iterable[int], verb: str) -> None:
        """Raise ConfigError when a robot of ``rows`` overlaps a wall or another robot (every
        body moved to its pose, one collision detection for all)."""
        self._sync_bodies()
        self.client.performCollisionDetection()
        for i in rows:
            for c in self.client.getContactPoints(bodyA=self.bodies[i]):
                if c[8] < -collision.PENETRATION_TOL:
                    other = self._body_index.get(c[2])
                    raise ConfigError("%s: robot %r %s overlapping %s (%.3f m deep)" % (
                        self.config.path, self.specs[i].name, verb,
                        "robot %r" % self.specs[other].name if other is not None else "a wall",
                        -c[8]))

    def add_people(self, people: Optional["People"]) -> None:
        """Step ``people`` (people/crowd's Crowd) with the robots, and let the lidars see
        their legs; None removes them."""
        self.people = people
        self._set_due()

    # ----------------------------------------------------------------------------- control
    def command(self, robot: int, vx: float, vy: float = 0.0, w: float = 0.0) -> None:
        """Set a robot's commanded body velocity; it holds until the watchdog times out.

        Raises:
            CommandError: a non-finite or absurd component; the previous command stands.
        """
        spec = self.specs[robot]
        check_command(spec.drive, vx, vy, w, "robot %r" % spec.name)
        self.target[robot] = (vx, vy, w)
        self._idle = False
        self.last_cmd_ns[robot] = self.clock.now_ns
        self._expiry_ns = min(self._expiry_ns,
                              self.clock.now_ns + int(self.cmd_timeout_ns[robot]) + 1)

    def reset(self, robots: Optional[Sequence[int]] = None) -> None:
        """Robots back to their spawn poses, at rest, odometry and battery reset."""
        rows = list(range(self.n)) if robots is None else list(robots)
        self.update_odometry()
        self.pose[rows] = self.spawn[rows]
        self.vel[rows] = 0.0
        self.target[rows] = 0.0
        self.last_cmd_ns[rows] = -(2 ** 62)
        self._travel[rows] = 0.0
        self.stalled[rows] = False
        self._penetration[rows] = 0.0
        self._robot_penetration[rows] = 0.0
        for sensor in self._sensor_list:
            sensor.reset(self, rows)
        self.schedule_sensors()
        self._safe_until_ns[:] = 0
        self._check_due_ns = 0
        self._sync_bodies(rows)

    def restart(self, seed: Optional[int]) -> None:
        """Every robot back at its spawn pose, and the run started afresh from ``seed``: the
        noise drawn anew from it and every sensor first due one period from now, so the same
        seed and commands give the same run whatever ran before (gym episodes)."""
        self.reset()        # (odometry catches up with the old run first: draws noise)
        self.rng.bit_generator.state = np.random.default_rng(seed).bit_generator.state
        self._idle = True               # at rest, nothing commanded: no step moves anything
        self._expiry_ns = 2 ** 62
        now = self.clock.now_ns
        for sensor in self._sensor_list:
            sensor.restart(now)
        self.schedule_sensors()

    def set_pose(self, robot: int, pose: Sequence[float]) -> None:
        """Teleport a robot: at rest at ``pose`` (x, y, yaw in the map frame). Its odometry
        does not see the jump (as a wheel encoder would not); its lidar forgets its last scan.

        Raises:
            ConfigError: the pose is not three finite numbers, or puts the robot in a wall,
                in unknown space or overlapping another robot; the robot stays where it was.
        """
        x, y, yaw = (float(v) for v in pose)
        if not all(math.isfinite(v) for v in (x, y, yaw)):
            raise ConfigError("robot %r: pose (%r, %r, %r) is not finite"
                              % (self.specs[robot].name, x, y, yaw))
        self.update_odometry()
        old = self.pose[robot].copy()
        self.pose[robot] = (x, y, yaw)
        try:
            self._check_place(robot)
        except ConfigError:
            self.pose[robot] = old
            self._set_body(robot, old)
            raise
        self.vel[robot] = self.target[robot] = 0.0
        self.stalled[robot] = False
        self.odometry.moved(self, [robot])
        self.lidar.forget([robot])
        self._safe_until_ns[:] = 0
        self._check_due_ns = 0

    def update_odometry(self) -> None:
        """Bring odometry up to the current ground truth (done at the odometry rate anyway)."""
        self.odometry.catch_up(self)

    def view(self, robot: int, refresh: bool = True) -> RobotView:
        """Plain-number snapshot of one robot.

        Args:
            robot: robot index.
            refresh: bring odometry up to date first (a caller viewing every robot at once
                calls ``update_odometry()`` once and passes False).
        """
        if refresh:
            self.update_odometry()
        x, y, yaw = (float(v) for v in self.pose[robot])
        v, w = self.vel[robot, 0], self.vel[robot, 2]
        half = 0.5 * self.wheel_sep[robot]
        r = self.wheel_radius[robot]
        tv, tw = self._travel[robot]
        # rows of (N, 3) arrays: numpy's types have no shapes, so mypy sees tuples of any length
        return RobotView(pose=(x, y, wrap_angle(yaw)),
                         velocity=tuple(float(c) for c in self.vel[robot]),  # type: ignore[arg-type]
                         odom_pose=tuple(  # type: ignore[arg-type]
                             float(c) for c in self.odometry.pose[robot]),
                         wheel_positions=(float((tv - half * tw) / r), float((tv + half * tw) / r)),
                         wheel_velocities=(float((v - half * w) / r), float((v + half * w) / r)),
                         stalled=bool(self.stalled[robot]))

    def snapshot(self, wheels: bool = True) -> Snapshot:
        """Every robot at once as rows of floats (what ``view`` gives one robot at a time);
        call ``update_odometry()`` first for up-to-date odometry. Plain Python: a publisher
        packs the numbers one by one, and for a few robots numpy's per-call cost dominated.

        Args:
            wheels: also compute the wheel angles and speeds (None otherwise).
        """
        pi, two_pi = math.pi, 2.0 * math.pi
        pose = [(x, y, (t + pi) % two_pi - pi) for x, y, t in self.pose.tolist()]
        vel = self.vel.tolist()
        positions = speeds = None
        if wheels:
            positions, speeds = [], []
            for (tv, tw), (v, _, w), sep, r in zip(self._travel.tolist(), vel,
                                                   self.wheel_sep.tolist(),
                                                   self.wheel_radius.tolist()):
                half = 0.5 * sep
                positions.append(((tv - half * tw) / r, (tv + half * tw) / r))
                speeds.append(((v - half * w) / r, (v + half * w) / r))
        return Snapshot(pose=pose, velocity=vel, odom_pose=self.odometry.pose.tolist(),
                        wheel_positions=positions, wheel_velocities=speeds)

    # ----------------------------------------------------------------------------- stepping
    def step(self, n: int = 1) -> List[Scan]:
        """Advance ``n`` fixed steps: move the robots, tick the clock, read the due sensors.

        Returns:
            The sensors' readings during these steps (the lidars' Scans), in time order.
        """
        readings: List[Scan] = []
        for _ in range(n):
            if self.n and not self._idle:
                self._physics_step()
            self.clock.tick()
            now = self.clock.now_ns
            if now >= self._due_ns:     # the people's step, then the sensors' readings
                people = self.people
                if people is not None and now >= people.next_ns:
                    people.advance(now, self.pose[:, :2], self.radius)
                if now >= self._sensor_due_ns:
                    readings.extend(self.read_sensors())
                else:
                    self._set_due()
        return readings

    def read_sensors(self) -> list:
        """Read the sensors that are due now, in the registry's order."""
        now = self.clock.now_ns
        out: list = []
        for sensor in self._sensor_list:
            if sensor.next_ns <= now:
                out.extend(sensor.read(self))
        self.schedule_sensors()
        return out

    def schedule_sensors(self) -> None:
        """When the next sensor is due, after their ``next_ns`` changed (and the step's next
        due time with it)."""
        self._sensor_due_ns = self._next_sensor_ns()
        self._set_due()

    def _set_due(self) -> None:
        """When ``step`` next has something to do besides physics: a sensor or the people."""
        people = self.people
        self._due_ns = min(self._sensor_due_ns,
                           people.next_ns if people is not None else self._sensor_due_ns)

    def _next_sensor_ns(self) -> int:
        """When the next sensor is due (sim ns)."""
        return min(s.next_ns for s in self._sensor_list)

    def _physics_step(self) -> None:
        dt = self.clock.dt
        now = self.clock.now_ns
        if now >= self._expiry_ns:  # watchdog: stop robots whose commands are too old
            expired = (now - self.last_cmd_ns) > self.cmd_timeout_ns
            self.target[expired] = 0.0
            moving = np.any(self.target != 0.0, axis=1)
            self._expiry_ns = int((self.last_cmd_ns[moving] + self.cmd_timeout_ns[moving]).min()) + 1 \
                if moving.any() else 2 ** 62
        after = now + self.clock.step_ns    # the poses this step computes are those of then
        check = after >= self._check_due_ns
        old = self.pose.copy() if check else self.pose
        if self.n <= small.SMALL_N:
            kinematics.advance_small(self, dt)
        else:
            for rows, drive in self._drives:
                self.vel[rows] = drive.apply(self.target[rows], self.vel[rows], dt)
            self.pose = kinematics.integrate(self.pose, self.vel, dt)
        if check:
            due = np.flatnonzero(self._safe_until_ns <= after)
            self.stalled[due] = False
            cand, t_safe = collision.window(self, self.pose, due)
            if len(cand):
                collision.resolve(self, old, self.pose, cand)
            self._safe_until_ns[due] = after + (t_safe * 1e9).astype(np.int64)
            self._check_due_ns = int(self._safe_until_ns.min())
        if self.n <= small.SMALL_N:   # wheels turn with the velocity kept (0 for a refused move)
            any_moving = kinematics.travel_small(self._travel, self.vel, dt)
        else:
            self._travel[:, 0] += self.vel[:, 0] * dt
            self._travel[:, 1] += self.vel[:, 2] * dt
            any_moving = bool(self.vel.any())
        self.motion += 1
        if not (any_moving or self.target.any()):   # all at rest, nothing commanded
            self._idle = True

    def _set_body(self, i: int, pose) -> None:
        """Place a robot's body with its base_footprint at ``pose`` (PyBullet wants the
        pose of the base's inertial frame, so the URDF link pose is composed with it)."""
        x, y, yaw = pose = (float(pose[0]), float(pose[1]), float(pose[2]))
        if self._body_at[i] == pose:     # already there (collision checks set it back and forth)
            return
        self._body_at[i] = pose
        (px, py, pz), (qx, qy, qz, qw) = self._inertial[i]
        c, s = math.cos(yaw), math.sin(yaw)
        sz, cz = math.sin(0.5 * yaw), math.cos(0.5 * yaw)
        self._reset_pose(self.bodies[i], (x + c * px - s * py, y + s * px + c * py, pz),
                         (cz * qx - sz * qy, cz * qy + sz * qx, cz * qz + sz * qw,
                          cz * qw - sz * qz))

    def _sync_bodies(self, rows: Optional[Sequence[int]] = None) -> None:
        for i in (range(self.n) if rows is None else rows):
            self._set_body(i, self.pose[i])

    def ray_bounds(self) -> Tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) that every beam ends within: the map's bounds, grown to
        take in every robot with a metre to spare."""
        xmin, ymin, xmax, ymax = self.bounds
        if not self.n:      # (numpy's min and max on a few rows cost more than Python's)
            return (xmin, ymin, xmax, ymax)
        xs, ys = self.pose[:, 0].tolist(), self.pose[:, 1].tolist()
        return (min(xmin, min(xs) - 1.0), min(ymin, min(ys) - 1.0),
                max(xmax, max(xs) + 1.0), max(ymax, max(ys) + 1.0))

    def cast_beams(self, plan) -> Tuple[np.ndarray, np.ndarray]:
        """The true distances and hits of the lidar plan's beams (``Lidar.read`` makes them
        ranges), all robots' in one batch.

        PyBullet pays for every robot whose bounding box a ray passes through, even a robot
        the ray's collision filter excludes, and every beam starts inside its own robot's box.
        So the beams are first cast at the walls alone: walked on the solid grid, or in Bullet
        with every robot body moved out of the scene (a lidar that has not moved since its
        last scan reuses that scan's wall distances); then only the beams that can reach
        another robot before their wall (their line passes that robot's cross-section circle
        nearer than the wall) are clipped to its section or cast again with the robots in
        place (robot_beams.py puts the bodies where the robots stand before a Bullet cast;
        on the grid nothing else moves them here). Every step is exact, so the ranges are
        those of casting every beam in the full scene.
        """
        lift = self._lift_for_rays and self.n > 0
        if lift:
            # a lidar that has not moved since its last scan sees the same walls
            same = self.lidar.unmoved(plan, self.pose)
            unmoved = same.tolist()   # (numpy's any() and repeat() on a few robots cost more)
            if any(unmoved):
                dist, hit = self.lidar.previous(plan)
                cast = _NO_RAYS if all(unmoved) else np.flatnonzero(~np.repeat(same, plan.counts))
                if len(cast):
                    dist[cast], hit[cast] = self._cast_lifted(plan, cast)
                self.rays_reused += len(plan.full) - len(cast)
            else:   # no lidar where it was (robots on the move): every ray is cast
                dist, hit = self._cast_lifted(plan, None)
            if self._grid_rays is None:   # the bodies were lifted out: back in place (on
                self._sync_bodies()       # the grid, only robot_beams' Bullet cast needs them)
        else:   # every beam in the full scene (GUI: moving bodies out would show)
            self._sync_bodies()
            dist, hit = self._cast(plan, np.arange(len(plan.froms)))
        self.lidar.remember(plan, self.pose, dist, hit)
        if lift and self.n > 1:
            robot_beams.cast_at_robots(self, plan, dist, hit)
        if self.people is not None:
            body = self.people.body
            leg_beams.cast_at_legs(self, plan, dist, hit, self.people.legs(), body.leg_radius,
                                   body.leg_height)
        return dist, hit

    @property
    def walls_on_grid(self) -> bool:
        """Whether the lidars' beams are walked at the walls on the solid grid
        (sim/grid_rays.py) rather than cast in Bullet (never with the GUI: every beam is
        cast in the full scene there, see cast_beams)."""
        return self._grid_rays is not None and self._lift_for_rays

    def _walls_on_grid(self, wall_height: float):
        """The walls' ray caster on the solid grid (sim/grid_rays.py), or None: Bullet casts
        at the walls when numba is missing, a lidar sits at or above the walls' top (its
        beams would pass over them) or BULLET_FLOOR_SIM_GRID_RAYS is 0."""
        if os.environ.get("BULLET_FLOOR_SIM_GRID_RAYS", "1").strip() in ("0", "false", "no"):
            return None
        if not grid_rays.available() or any(not 0.0 < m.laser_pose[2] < wall_height
                                            for m in self.models):
            return None
        return grid_rays.GridRays(self.solid.fmap)

    def _cast_lifted(self, plan, rays: Optional[np.ndarray]) -> Tuple[np.ndarray, np.ndarray]:
        """Distances and hits of the plan's rays ``rays`` (sorted, unique; None: every ray)
        at the walls alone: on the solid grid, or in Bullet with the robots lifted out."""
        if self._grid_rays is not None:
            return self._cast_walls(plan, rays)
        self._lift_bodies()
        return self._cast(plan, np.arange(len(plan.full)) if rays is None else rays)

    def _cast_walls(self, plan, rays: Optional[np.ndarray]) -> Tuple[np.ndarray, np.ndarray]:
        """As ``_cast`` with the robots lifted out, on the solid grid: the distance to the
        first wall along each of the plan's rays ``rays`` (None: every ray; its full length
        on a miss), and whether there is one."""
        if rays is None:
            full = plan.full
            dist = self._grid_rays.cast(plan.origins, plan.dirs, plan.start, full)
        else:
            full = plan.full[rays]
            dist = self._grid_rays.cast(plan.origins[rays], plan.dirs[rays], plan.start[rays],
                                        full)
        hit = np.isfinite(dist)
        self.rays_cast += len(full)
        return np.where(hit, dist, full), hit

    def threads(self, rays: int) -> int:
        """PyBullet threads for a ray batch of ``rays`` rays."""
        return self.ray_threads if rays >= _THREADED_RAYS else 1

    def _cast(self, plan, rays: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Distances (from the laser origin) and hits of the plan's rays ``rays``; a ray the
        plan cut short that hits nothing is cast again in full."""
        froms, start, length = plan.froms[rays], plan.start[rays], plan.length[rays]
        frac, ids = cast_rays(self.client, froms, plan.tos[rays], self.threads(len(rays)),
                              chunk=ray_chunk())
        dist = start + frac * length
        hit = ids >= 0
        again = np.flatnonzero(plan.cut[rays] & ~hit)
        if len(again):
            rest = plan.full[rays[again]] - start[again]
            tos = froms[again].copy()
            tos[:, :2] += plan.dirs[rays[again]] * rest[:, None]
            f2, i2 = cast_rays(self.client, froms[again], tos, self.threads(len(again)),
                               chunk=ray_chunk())
            dist[again] = start[again] + f2 * rest
            hit[again] = i2 >= 0
        self.rays_cast += len(rays) + len(again)
        self.rays_recast += len(again)
        return dist, hit

    def _lift_bodies(self) -> None:
        """Move every robot body far out of the scene, apart (until ``_sync_bodies``)."""
        for i, b in enumerate(self.bodies):
            self._reset_pose(b, (1e4 + 10.0 * i, 1e4, -1e4), (0.0, 0.0, 0.0, 1.0))
        self._body_at = [None] * self.n

    def close(self) -> None:
        """Disconnect the PyBullet client."""
        try:
            self.client.disconnect()
        except Exception:  # already disconnected
            pass


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silence what Bullet's C++ URDF importer prints on file descriptors 1 and 2."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved + [devnull]:
            os.close(fd)
