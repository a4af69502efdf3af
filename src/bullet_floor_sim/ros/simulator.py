"""The simulator node: steps the core world and speaks what map_server, amcl and move_base expect.

Per robot ``N`` (topic namespace ``/N``, frame prefix ``N/``; a robot with an empty name uses
bare names) it publishes, stamped with sim time: ``odom`` and tf ``N/odom -> N/base_footprint``,
``base_scan``, ``base_pose_ground_truth`` (Odometry in ``map``), ``pose`` (PoseStamped in
``map``), ``battery_state``, ``joint_states``; it subscribes ``cmd_vel``. It publishes
``/clock`` from the core's clock and, unless ``~publish_map`` is false, a latched ``/map``.

Parameters: ``~world`` (name under worlds/ or a world.yaml path; default office),
``~real_time_factor`` (1.0; 0 = as fast as possible), ``~physics_rate`` (100), ``~gui``,
``~seed`` (-1 = random), ``~clock_rate`` (100), ``~odom_rate`` (50), ``~pose_rate`` (20),
``~state_rate`` (10: battery and joint states), ``~publish_map`` (true),
``~ground_truth_tf`` (false: true publishes map -> N/odom from ground truth, for runs without
amcl),
``~single_robot`` (false: true keeps only the world's first robot and gives it an empty name,
i.e. bare topics and frames ``/odom``, ``odom``, ``base_footprint``, as the MORSE tutorial's),
``~publish_initialpose`` (false: true publishes each spawn pose, latched, on ``N/initialpose``
at start and after ``~reset``, so amcl starts localised whatever the world),
``~robot_state_publishers`` (true: one robot_state_publisher per robot, started by this node
with the robot's prefixed URDF, so any number of robots works from one launch file).
Services: ``~reset``, ``~pause``, ``~unpause`` (std_srvs/Empty).
"""
from __future__ import annotations

import dataclasses
import math
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Callable, List, Optional

import rospy
from geometry_msgs.msg import (PoseStamped, PoseWithCovarianceStamped, TransformStamped,
                               Twist)
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, JointState, LaserScan
from std_msgs.msg import Float64
from std_srvs.srv import Empty, EmptyResponse
from tf2_msgs.msg import TFMessage

from ..core.config import load_world_config, resolve_world
from ..core.errors import BulletFloorSimError, CommandError, ConfigError
from ..core.paths import worlds_dir
from ..core.robot import expand_xacro
from ..core.world import World

__all__ = ["main", "SimulatorNode"]


def _stamp(ns: int) -> rospy.Time:
    return rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


def _quat(yaw: float):
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def _odometry(frame: str, child: str, pose, velocity, stamp) -> Odometry:
    """nav_msgs/Odometry of a planar pose (x, y, yaw) and body velocity (vx, vy, w)."""
    m = Odometry()
    m.header.stamp = stamp
    m.header.frame_id = frame
    m.child_frame_id = child
    p = m.pose.pose
    p.position.x, p.position.y = pose[0], pose[1]
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = _quat(pose[2])
    m.twist.twist.linear.x, m.twist.twist.linear.y = velocity[0], velocity[1]
    m.twist.twist.angular.z = velocity[2]
    return m


def _transform(parent: str, child: str, pose, stamp) -> TransformStamped:
    """A planar transform (x, y, yaw) from ``parent`` to ``child``."""
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y = pose[0], pose[1]
    r = t.transform.rotation
    r.x, r.y, r.z, r.w = _quat(pose[2])
    return t


def _stop_listening_to_own_clock() -> bool:
    """Under /use_sim_time, rospy subscribes every node to /clock, the simulator included:
    each /clock message would cross a TCP connection back into this process (a thread hand-off
    and a deserialisation per step). The simulator owns the clock, so it drops that
    subscription and sets rospy's time itself each step (rospy internals, checked here).

    Returns:
        True when rospy's time is now set by this node.
    """
    try:
        from rospy.impl import simtime
        from rospy.rostime import _set_rostime  # noqa: F401  (the setter used in publish)
    except ImportError:
        return False
    sub = getattr(simtime, "_clock_sub", None)
    if sub is None:
        return False
    sub.unregister()
    simtime._clock_sub = None
    return True


def _set_rostime(stamp: rospy.Time) -> None:
    from rospy.rostime import _set_rostime as setter

    setter(stamp)


class StopSignals:
    """SIGINT/SIGTERM handlers that only record the request; the main loop acts on it.

    rospy's own handlers (and roslaunch's ``rl_signal``, which any roslaunch ``Process`` made in
    this process installs) run the whole shutdown inside the handler: in the main thread, at
    whatever bytecode it was interrupted. The simulator's main thread spends much of its time in
    ``Publisher.publish`` -> ``QueuedConnection.write_data``, holding that connection's
    non-reentrant lock; rospy's shutdown then closes all topics and waits for the topic
    manager's lock, which rospy's registration thread holds while it waits for the connection
    lock the interrupted main thread still has: a deadlock (2-3 runs in 20 of sim.launch in
    worlds/simple with scan subscribers; the rostests and nav_bench saw it too). Both rospy and roslaunch ignore every later signal once shutdown
    has begun, so roslaunch's SIGTERM did nothing either and only SIGKILL ended the node.

    Here the first signal sets ``signum``; the loop sees it between steps, where it holds no
    lock, and shuts down from there. A second signal exits at once (shutdown itself is stuck).
    """

    def __init__(self) -> None:
        self.signum: Optional[int] = None

    def install(self) -> "StopSignals":
        """Take over SIGINT and SIGTERM (call from the main thread, after rospy.init_node
        with ``disable_signals=True``)."""
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, self._handle)
        return self

    def _handle(self, signum: int, _frame) -> None:
        if self.signum is not None:
            os.write(2, b"simulator: second signal during shutdown, exiting now\n")
            os._exit(128 + signum)
        self.signum = signum  # a plain assignment: safe whatever the main thread holds

    def __call__(self) -> bool:
        """True once a stop signal arrived."""
        return self.signum is not None


class SimulatorNode:
    """ROS glue around one core ``World``: messages in and out, pacing, services."""

    def __init__(self, world: World, rtf: float, rates: dict, publish_map: bool,
                 ground_truth_tf: bool = False, initialpose: bool = False) -> None:
        self.world = world
        self.ground_truth_tf = ground_truth_tf
        self.own_time = _stop_listening_to_own_clock()
        self.rtf = rtf
        self.lock = threading.Lock()
        self.paused = False
        step = world.clock.step_ns
        self.every = {k: max(1, int(round(1e9 / v / step))) for k, v in rates.items()}
        self.robots = []
        for i, spec in enumerate(world.specs):
            ns = "/" + spec.name if spec.name else ""
            pre = spec.prefix
            r = {
                "prefix": pre,
                "odom": rospy.Publisher(ns + "/odom", Odometry, queue_size=10),
                "scan": rospy.Publisher(ns + "/base_scan", LaserScan, queue_size=10),
                "gt": rospy.Publisher(ns + "/base_pose_ground_truth", Odometry, queue_size=10),
                "pose": rospy.Publisher(ns + "/pose", PoseStamped, queue_size=10),
                "battery": rospy.Publisher(ns + "/battery_state", BatteryState, queue_size=2),
                "joints": rospy.Publisher(ns + "/joint_states", JointState, queue_size=10),
                "wheels": [pre + j for j in world.models[i].wheel_joints],
            }
            rospy.Subscriber(ns + "/cmd_vel", Twist, self._on_cmd, callback_args=i, queue_size=1)
            self.robots.append(r)
        self.clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)
        self.tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=100)
        self.rtf_pub = rospy.Publisher("~real_time_factor_achieved", Float64, queue_size=1)
        if publish_map:
            self._publish_map()
        self.initialpose = [rospy.Publisher(("/" + sp.name if sp.name else "") + "/initialpose",
                                            PoseWithCovarianceStamped, queue_size=1, latch=True)
                            for sp in world.specs] if initialpose else []
        self._publish_initialposes()
        rospy.Service("~reset", Empty, self._on_reset)
        rospy.Service("~pause", Empty, self._on_pause)
        rospy.Service("~unpause", Empty, self._on_unpause)

    # ------------------------------------------------------------------------- callbacks
    def _on_cmd(self, msg: Twist, robot: int) -> None:
        try:
            with self.lock:
                self.world.command(robot, msg.linear.x, msg.linear.y, msg.angular.z)
        except CommandError as e:
            rospy.logwarn_throttle(2.0, str(e))

    def _on_reset(self, _req) -> EmptyResponse:
        with self.lock:
            self.world.reset()
        rospy.loginfo("simulator: robots reset to their spawn poses")
        self._publish_initialposes()
        return EmptyResponse()

    def _publish_initialposes(self) -> None:
        """Spawn poses on N/initialpose (latched), so amcl starts (and restarts) localised."""
        for spec, pub in zip(self.world.specs, self.initialpose):
            m = PoseWithCovarianceStamped()
            m.header.frame_id = "map"
            m.header.stamp = _stamp(self.world.clock.now_ns)
            m.pose.pose.position.x, m.pose.pose.position.y = spec.pose[0], spec.pose[1]
            q = m.pose.pose.orientation
            q.x, q.y, q.z, q.w = _quat(spec.pose[2])
            cov = [0.0] * 36
            cov[0] = cov[7] = 0.05 ** 2
            cov[35] = 0.05 ** 2
            m.pose.covariance = cov
            pub.publish(m)

    def _on_pause(self, _req) -> EmptyResponse:
        self.paused = True
        return EmptyResponse()

    def _on_unpause(self, _req) -> EmptyResponse:
        self.paused = False
        return EmptyResponse()

    # ------------------------------------------------------------------------- output
    def _publish_map(self) -> None:
        fmap = self.world.fmap
        info = MapMetaData()
        info.map_load_time = _stamp(self.world.clock.now_ns)
        info.resolution = fmap.resolution
        info.width, info.height = fmap.width, fmap.height
        info.origin.position.x, info.origin.position.y = fmap.origin[0], fmap.origin[1]
        (info.origin.orientation.x, info.origin.orientation.y, info.origin.orientation.z,
         info.origin.orientation.w) = _quat(fmap.origin[2])
        grid = OccupancyGrid()
        grid.header.frame_id = "map"
        grid.header.stamp = info.map_load_time
        grid.info = info
        grid.data = fmap.grid.ravel().tolist()
        self.map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub = rospy.Publisher("/map_metadata", MapMetaData, queue_size=1, latch=True)
        self.map_pub.publish(grid)
        self.meta_pub.publish(info)

    def publish(self, scans) -> None:
        """Publish what is due after a step (called with the lock held)."""
        w = self.world
        steps = w.clock.steps
        stamp = _stamp(w.clock.now_ns)
        if self.own_time:
            _set_rostime(stamp)
        if steps % self.every["clock"] == 0:
            self.clock_pub.publish(Clock(clock=stamp))
        odom_due = steps % self.every["odom"] == 0
        pose_due = steps % self.every["pose"] == 0
        state_due = steps % self.every["state"] == 0
        tfs: List[TransformStamped] = []
        if odom_due or pose_due or state_due:
            w.update_odometry()
            for i, r in enumerate(self.robots):
                v = w.view(i, refresh=False)
                if odom_due:
                    self._odom(r, v, stamp, tfs)
                    if self.ground_truth_tf:
                        tfs.append(self._map_to_odom(r, v, stamp))
                if pose_due:
                    self._ground_truth(r, v, stamp)
                if state_due:
                    self._state(i, r, v, stamp)
        if tfs:
            self.tf_pub.publish(TFMessage(transforms=tfs))
        for s in scans:
            self._scan(self.robots[s.robot], s)

    def _odom(self, r: dict, v, stamp, tfs: List[TransformStamped]) -> None:
        odom, base = r["prefix"] + "odom", r["prefix"] + "base_footprint"
        r["odom"].publish(_odometry(odom, base, v.odom_pose, v.velocity, stamp))
        tfs.append(_transform(odom, base, v.odom_pose, stamp))

    def _map_to_odom(self, r: dict, v, stamp) -> TransformStamped:
        """map -> N/odom that makes odom -> base_footprint land on the ground truth (what
        fake_localization does); only when no localisation node (amcl) publishes it."""
        xg, yg, thg = v.pose
        xo, yo, tho = v.odom_pose
        th = thg - tho
        c, s = math.cos(th), math.sin(th)
        return _transform("map", r["prefix"] + "odom",
                          (xg - (c * xo - s * yo), yg - (s * xo + c * yo), th), stamp)

    def _ground_truth(self, r: dict, v, stamp) -> None:
        m = _odometry("map", r["prefix"] + "base_footprint", v.pose, v.velocity, stamp)
        r["gt"].publish(m)
        ps = PoseStamped()
        ps.header = m.header
        ps.pose = m.pose.pose
        r["pose"].publish(ps)

    def _state(self, i: int, r: dict, v, stamp) -> None:
        js = JointState()
        js.header.stamp = stamp
        js.name = r["wheels"]
        js.position = list(v.wheel_positions)
        js.velocity = list(v.wheel_velocities)
        r["joints"].publish(js)
        pct, volt, charge = self.world.battery.state(i, self.world.clock.now_ns)
        b = BatteryState()
        b.header.stamp = stamp
        b.voltage, b.percentage, b.charge = volt, pct, charge
        b.capacity = b.design_capacity = self.world.specs[i].battery.capacity_ah
        b.current = float("nan")
        b.power_supply_status = BatteryState.POWER_SUPPLY_STATUS_DISCHARGING
        b.power_supply_technology = BatteryState.POWER_SUPPLY_TECHNOLOGY_UNKNOWN
        b.present = True
        r["battery"].publish(b)

    def _scan(self, r: dict, s) -> None:
        m = LaserScan()
        m.header.stamp = _stamp(s.stamp_ns)
        m.header.frame_id = r["prefix"] + "base_laser_link"
        m.angle_min, m.angle_max, m.angle_increment = s.angle_min, s.angle_max, s.angle_increment
        m.scan_time = s.scan_time
        m.range_min, m.range_max = s.range_min, s.range_max
        m.ranges = s.ranges.tolist()
        r["scan"].publish(m)

    # ------------------------------------------------------------------------- main loop
    def spin(self, stop: Callable[[], bool] = lambda: False) -> None:
        """Step, publish and pace until shutdown; log the achieved real-time factor every 10 s.

        Args:
            stop: polled every step (and while pacing or paused); True ends the loop, as
                rospy shutdown does. Never blocks for more than 50 ms of wall time at once.
        """
        w = self.world
        wall0, sim0 = time.perf_counter(), w.clock.now
        report_at = wall0 + 10.0
        rep_wall, rep_sim = wall0, sim0
        while not (rospy.is_shutdown() or stop()):
            if self.paused:
                time.sleep(0.01)
                wall0, sim0 = time.perf_counter(), w.clock.now
                continue
            with self.lock:
                scans = w.step(1)
                self.publish(scans)
            now_wall = time.perf_counter()
            if self.rtf > 0:
                ahead = (w.clock.now - sim0) / self.rtf - (now_wall - wall0)
                if ahead > 0:
                    time.sleep(min(ahead, 0.05))
                elif ahead < -1.0:  # far behind: do not try to catch up in a burst
                    wall0, sim0 = now_wall, w.clock.now
            if now_wall >= report_at:
                achieved = (w.clock.now - rep_sim) / (now_wall - rep_wall)
                rospy.loginfo("simulator: real-time factor %.2f (asked %s)", achieved,
                              self.rtf if self.rtf > 0 else "as fast as possible")
                self.rtf_pub.publish(Float64(achieved))
                report_at, rep_wall, rep_sim = now_wall + 10.0, now_wall, w.clock.now


class RobotStatePublishers:
    """One robot_state_publisher per robot, in its namespace, with the prefixed URDF.

    Plain child processes in the simulator's process group (what roslaunch and a terminal
    signal), so they stop with it, and stopped here within ``timeout`` when it stops. Not
    roslaunch's scriptapi: that installs signal handlers doing the whole shutdown inside the
    handler and waits up to 15 s per child.
    """

    def __init__(self, world: World) -> None:
        import rospkg
        from roslib.packages import find_node

        exe = find_node("robot_state_publisher", "robot_state_publisher")
        if not exe:
            raise BulletFloorSimError("robot_state_publisher is not installed "
                                      "(set ~robot_state_publishers false to run without it)")
        log_dir = os.path.join(rospkg.get_log_dir(), str(rospy.get_param("/run_id", "")))
        os.makedirs(log_dir, exist_ok=True)
        self.procs: List[subprocess.Popen] = []
        for spec in world.specs:
            ns = "/" + spec.name if spec.name else "/"
            rospy.set_param((ns.rstrip("/") or "") + "/robot_description",
                            expand_xacro(spec.model, spec.prefix))
            tag = (spec.name or "") + ("-" if spec.name else "") + "robot_state_publisher"
            env = dict(os.environ, ROS_NAMESPACE=ns)
            with open(os.path.join(log_dir, tag + "-stdout.log"), "ab") as out:
                self.procs.append(subprocess.Popen(
                    [exe[0], "__name:=robot_state_publisher",
                     "__log:=" + os.path.join(log_dir, tag + ".log")],
                    env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                    close_fds=True))

    def stop(self, timeout: float = 1.0) -> None:
        """SIGINT every child still running, SIGKILL what is left after ``timeout`` s."""
        for p in self.procs:
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        deadline = time.monotonic() + timeout
        for p in self.procs:
            try:
                p.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim simulator``."""
    rospy.init_node("simulator", disable_signals=True)
    stop = StopSignals().install()  # see StopSignals: never shut down inside a handler
    seed = int(rospy.get_param("~seed", -1))
    try:
        config = load_world_config(resolve_world(str(rospy.get_param("~world", "office")),
                                                 worlds_dir()))
        if rospy.get_param("~single_robot", False):
            if not config.robots:
                raise ConfigError("%s: single_robot needs at least one robot" % config.path)
            config = dataclasses.replace(
                config, robots=[dataclasses.replace(config.robots[0], name="")])
        world = World(config, physics_rate=float(rospy.get_param("~physics_rate", 100.0)),
                      gui=bool(rospy.get_param("~gui", False)), seed=None if seed < 0 else seed)
    except BulletFloorSimError as e:
        rospy.logfatal("simulator: %s", e)
        return 1
    rates = {k: float(rospy.get_param("~%s_rate" % k, d))
             for k, d in (("clock", 100.0), ("odom", 50.0), ("pose", 20.0), ("state", 10.0))}
    node = SimulatorNode(world, float(rospy.get_param("~real_time_factor", 1.0)), rates,
                         bool(rospy.get_param("~publish_map", True)),
                         bool(rospy.get_param("~ground_truth_tf", False)),
                         bool(rospy.get_param("~publish_initialpose", False)))
    rsps = None
    try:
        if rospy.get_param("~robot_state_publishers", True):
            rsps = RobotStatePublishers(world)
        rospy.loginfo("simulator: world %s with robots %s", world.config.path,
                      ", ".join(s.name or "<empty>" for s in world.specs))
        node.spin(stop)
    except BulletFloorSimError as e:
        rospy.logfatal("simulator: %s", e)
        return 1
    finally:
        # from the main loop, holding no lock: rospy closes topics and unregisters here
        rospy.signal_shutdown("signal %d" % stop.signum if stop() else "simulator stopped")
        if rsps is not None:
            rsps.stop()
        world.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
