"""The simulator node: steps the core world and speaks what map_server, amcl and move_base expect.

Per robot ``N`` (topic namespace ``/N``, frame prefix ``N/``; a robot with an empty name uses
bare names) it publishes, stamped with sim time: ``odom`` and tf ``N/odom -> N/base_footprint``,
``base_scan``, ``base_pose_ground_truth`` (Odometry in ``map``), ``pose`` (PoseStamped in
``map``), ``battery_state``, ``joint_states``; it subscribes ``cmd_vel``. It publishes
``/clock`` from the core's clock and, unless ``~publish_map`` is false, a latched ``/map``.

Parameters: ``~world`` (name under worlds/ or a world.yaml path; default office),
``~real_time_factor`` (1.0; 0 = as fast as possible), ``~physics_rate`` (100), ``~gui``,
``~seed`` (-1 = random), ``~clock_rate`` (100), ``~odom_rate`` (50), ``~pose_rate`` (20),
``~state_rate`` (10: battery and joint states), ``~people`` (-1: the world file's
``people:`` section; N: that many, of its first group's kind), ``~people_rate`` (10: the
crowd's ground truth, ros/sim/people_out.py), ``~publish_map`` (true),
``~ground_truth_tf`` (false: true publishes map -> N/odom from ground truth, for runs without
amcl; a list of robot names does it for those robots only, e.g. a walker beside an observer
that amcl localises),
``~single_robot`` (false: true keeps only the world's first robot and gives it an empty name,
i.e. bare topics and frames ``/odom``, ``odom``, ``base_footprint``, as the MORSE tutorial's),
``~only`` ("": a robot's name keeps that robot of the world alone, in its namespace: the one
that maps in mapping.launch), ``~serve_cleaned`` (false: /map with the world's map handling
applied; the handling set for the nodes is then ``unknown`` alone), ``~check_world`` (true:
log the map check, building/check.py, at start), ``~study_walker`` and ``~study_observer``
("": the robots of a study, as demo.launch sets them: the check's problems for them stop the
simulator, unless ``~allow_unreachable``),
``~publish_initialpose`` (false: true publishes each spawn pose, latched, on ``N/initialpose``
at start and after ``~reset``, so amcl starts localised whatever the world),
``~robot_state_publishers`` (builtin: this node publishes what one robot_state_publisher per
robot would, from the robot's prefixed URDF: ``robot_description``, the fixed joints on
/tf_static, the wheels on /tf with joint_states; process: one Debian robot_state_publisher
per robot, started by this node; none; ros/sim/rsp.py), so any number of robots works from
one launch file,
``~ray_threads`` (0: PyBullet threads for lidar batches of 1000 rays or more, 0 = all cores;
1 leaves the other cores to the rest of the ROS graph),
``~max_command_lag`` (0.15 s of sim time: while a moving robot's last ``cmd_vel`` is older,
the clock goes no faster than real time, so a navigation node that cannot keep pace with
``rtf:=0`` slows the simulator instead of driving on stale commands; 0 = never wait;
sim/pacing.py), ``~wait_for_subscribers`` (true: after each send the clock holds until every
subscriber on this machine has read it, so no node works from data queued seconds behind; Linux
only), ``~max_command_wait`` (2.0 s of wall time: a robot late for that long, or a subscriber
that has not read for that long, is let go, with a warning naming it, until it is back),
``~upstream_type_names`` (true: /ground_truth/people and /ground_truth/tracked_persons are
advertised as people_msgs/People and spencer_tracking_msgs/TrackedPersons, ros/upstream.py;
``rostopic echo`` then needs those packages installed; false: as bullet_floor_sim's types).
Services: ``~reset``, ``~pause``, ``~unpause`` (std_srvs/Empty); ``~spawn``, ``~delete``,
``~set_pose`` and ``~step`` (bullet_floor_sim/Spawn, Delete, SetPose, Step: ros/sim/services.py).
"""
from __future__ import annotations

import dataclasses
import math
import struct
import sys
import threading
import time
from typing import Callable, Dict, List, Optional, Sequence, Tuple, Union


import rospy
from geometry_msgs.msg import (PoseWithCovarianceStamped, Twist)
from nav_msgs.msg import MapMetaData, OccupancyGrid
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64
from std_srvs.srv import Empty, EmptyResponse
from tf2_msgs.msg import TFMessage

from ..sim import bullet_capi
from ..sim.config import load_world_config, resolve_world
from ..errors import BulletFloorSimError, CommandError, ConfigError
from ..sim.pacing import BacklogGate, CommandGate, clock_wall_bound, tcp_unread, waits_line
from ..paths import worlds_dir
from ..sim.solidmap import cleaned_map, served_handling
from ..sim.world import World
from .params import set_map_handling
from .sim.frames import gt_tf_robots, map_to_odom
from .sim.outbox import Outbox
from .sim.rsp import BuiltinStatePublisher, RobotStatePublishers, state_publisher_mode
from .sim.people_out import PeopleOutput
from ..people.crowd.build import build_crowd
from .sim.signals import StopSignals, set_rostime, stop_listening_to_own_clock
from .sim.publish import Output, Tick, robot_outputs
from .sim.services import MainThreadJobs, RobotIO, RosterServices
from .sim.wire import II, U32, LinkTfWire, TfWire, check_wires, quaternion, ros_time

__all__ = ["main", "SimulatorNode"]

_MAX_FLUSH_WAIT = 0.05     # s: the longest a queued message waits for its send when not pacing
_MAX_FLUSH_SIM = 0.05      # s of sim time: the same bound while the clock waits for subscribers
_HOLD_POLL = 0.0005        # s: the sleep between looks while the clock waits for a node


class SimulatorNode:
    """ROS glue around one core ``World``: messages in and out, pacing, services.

    Args:
        world: the core world.
        rtf: real-time factor to hold (0 = as fast as possible).
        rates: Hz of "clock", "odom" (and tf), "pose" (ground truth), "state" (battery, joints
            and, with ``wheel_tf``, the wheels' tf).
        publish_map: publish the world's map, latched, on /map and /map_metadata.
        serve_cleaned: publish it with the world's map handling's changes made
            (sim/solidmap.cleaned_map), so that amcl and move_base see the building the
            simulator does.
        ground_truth_tf: publish map -> N/odom from ground truth: True for every robot, or
            the names of the robots to do it for.
        initialpose: publish spawn poses, latched, on N/initialpose.
        clock_wall_period: when the asked pace would publish /clock more often than once per
            this many wall seconds (rtf 0, or clock rate x rtf above its inverse), /clock is
            published at most that often (nobody consumes it faster; every message still
            carries its exact sim-time stamp). At a pace below that bound every tick is
            published, also while catching up after a stall.
        flush_period: least wall seconds between sends of the queued messages when not
            pacing.
        send_share: when not pacing, sends take at most this share of the wall time: the
            next flush waits (up to 50 ms) ten times as long as the last one took, with 0.1.
            Sends cost per subscriber connection: 300 connections (50 robots) took 5 ms a
            flush, every step with 2 ms between flushes.
        report_period: wall seconds between logs (and messages on ~real_time_factor_achieved
            and ~publishing_share) of the achieved real-time factor and the wall time spent
            building and sending messages as a share of the time spent stepping the world.
        gate: when the clock waits for the robots' controllers (sim/pacing.py; default: a
            moving robot's command may be 0.15 s of sim time old, a wait lasts at most 2 s).
        backlog: when the clock waits for subscribers to read what was sent (None: never).
        upstream_type_names: advertise the people topics under the upstream type names.
    """

    def __init__(self, world: World, rtf: float, rates: dict, publish_map: bool,
                 ground_truth_tf: Union[bool, Sequence[str]] = False,
                 initialpose: bool = False,
                 clock_wall_period: float = 0.001, flush_period: float = 0.002,
                 send_share: float = 0.1, report_period: float = 10.0,
                 gate: Optional[CommandGate] = None, serve_cleaned: bool = False,
                 backlog: Optional[BacklogGate] = None,
                 upstream_type_names: bool = True, wheel_tf: bool = False) -> None:
        check_wires()
        self.wheel_tf = wheel_tf
        self.world = world
        self.gate = gate or CommandGate([s.name for s in world.specs])
        self.backlog = backlog
        self._flush_sim = 0.0        # sim time of the last flush
        self.gt_setting = ground_truth_tf
        self.gt_tf = gt_tf_robots(ground_truth_tf, [s.name for s in world.specs])
        self.own_time = stop_listening_to_own_clock()
        self.rtf = rtf
        self.lock = threading.Lock()
        self.paused = False
        self.flush_period = flush_period
        for name, v in (("send_share", send_share), ("report_period", report_period)):
            if not (math.isfinite(v) and v > 0.0) or (name == "send_share" and v > 1.0):
                raise ConfigError("~%s: %r is not a %s" % (
                    name, v, "share in (0, 1]" if name == "send_share" else "positive number"))
        for name, v in rates.items():
            if not (math.isfinite(v) and v > 0.0):
                raise ConfigError("~%s_rate: %r is not a positive rate (Hz)" % (name, v))
        self.clock_wall_period = clock_wall_bound(rates["clock"], rtf, clock_wall_period)
        self.send_share = send_share
        self.report_period = report_period
        step = world.clock.step_ns
        self.every = {k: max(1, int(round(1e9 / v / step))) for k, v in rates.items()}
        self.out = Outbox()
        pub = self.out.publisher
        # every robot's outputs (sim/publish.py) and cmd_vel subscriber, by name; the reading
        # outputs by (type, robot) and the periodic ones by rate, robot by robot (_reindex)
        self.robot_io: Dict[str, RobotIO] = {}
        self.rows: Dict[str, int] = {}     # robot name -> its row in the world (_reindex)
        self.initialpose_on = initialpose
        for spec in world.specs:
            self._open_robot(spec)
        self.clock_pub = pub("/clock", Clock, 10)
        self.tf_pub = pub("/tf", TFMessage, 100)
        self._reindex()
        self.rtf_pub = rospy.Publisher("~real_time_factor_achieved", Float64, queue_size=1)
        self.share_pub = rospy.Publisher("~publishing_share", Float64, queue_size=1)
        self._clock_wall = -math.inf      # wall time of the last /clock
        self._clock_behind = False        # a due /clock was skipped (wall-rate bound)
        self._flush_next = time.perf_counter()   # when not pacing, no flush before this
        # wall seconds spent in World.step, and in building and sending messages (the
        # publishing overhead the log and bench/ros_bench.py report)
        self.time_stepping = self.time_publishing = 0.0
        self.people_out = (PeopleOutput(pub, world.people, world.clock.now_ns,
                                        upstream=upstream_type_names)
                           if world.people is not None else None)
        if publish_map:
            self._publish_map(serve_cleaned)
        self._publish_initialposes()
        self.jobs = MainThreadJobs()
        rospy.Service("~reset", Empty, self._on_reset)
        rospy.Service("~pause", Empty, self._on_pause)
        rospy.Service("~unpause", Empty, self._on_unpause)
        self.rsps: Union[RobotStatePublishers, BuiltinStatePublisher, None] = None  # by main()
        self.services = RosterServices(self)

    # ------------------------------------------------------------------------- robots
    def _open_robot(self, spec) -> None:
        """The topics of a robot of the world (its row found by name at each use)."""
        i = [s.name for s in self.world.specs].index(spec.name)
        ns = "/" + spec.name if spec.name else ""
        self.robot_io[spec.name] = RobotIO(
            robot_outputs(self.out.publisher, ns, spec.prefix, i, self.world),
            rospy.Subscriber(ns + "/cmd_vel", Twist, self._on_cmd, callback_args=spec.name,
                             queue_size=1),
            rospy.Publisher(ns + "/initialpose", PoseWithCovarianceStamped, queue_size=1,
                            latch=True) if self.initialpose_on else None)

    def close_robot(self, name: str) -> None:
        """Unregister a robot's topics (after the world let it go; ``_reindex`` next)."""
        io = self.robot_io.pop(name)
        io.cmd_sub.unregister()
        for o in io.outputs:
            self.out.drop(o.pub)
        if io.initialpose is not None:
            io.initialpose.unregister()

    def _reindex(self) -> None:
        """After the world's robots changed: each output's row, the outputs by reading and
        rate, the tf frames, the gate's robots (called with the lock held, or before spin)."""
        w = self.world
        names = [s.name for s in w.specs]
        self.rows = {n: i for i, n in enumerate(names)}
        for name, io in self.robot_io.items():
            for o in io.outputs:
                o.robot = self.rows[name]
        outputs = [o for n in names for o in self.robot_io[n].outputs]
        self.reading_out: Dict[Tuple[type, int], Output] = {
            (o.reads, o.robot): o for o in outputs if o.reads is not None}
        self.periodic: Dict[str, List[Output]] = {
            rate: [o for o in outputs if o.rate == rate] for rate in ("odom", "pose", "state")}
        setting = self.gt_setting
        if isinstance(setting, (list, tuple)):    # robots deleted since are left out
            setting = [n for n in setting if n in self.rows]
        self.gt_tf = gt_tf_robots(setting, names)
        prefixes = [spec.prefix for spec in w.specs]
        pairs = [(p + "odom", p + "base_footprint") for p in prefixes]
        pairs += [("map", prefixes[i] + "odom") for i in self.gt_tf]
        self.tf_wire = TfWire(pairs)
        self.wheel_wire = LinkTfWire([x.prefixed(s.prefix) for s, m in zip(w.specs, w.models)
                                      for x in m.wheel_links])
        if self.gate.names != [n or "<empty>" for n in names]:
            self.gate = CommandGate(names, self.gate.max_lag, self.gate.max_wait)

    # ------------------------------------------------------------------------- callbacks
    def _on_cmd(self, msg: Twist, name: str) -> None:
        try:
            with self.lock:
                robot = self.rows.get(name)
                if robot is None:       # deleted since the message came
                    return
                self.world.command(robot, msg.linear.x, msg.linear.y, msg.angular.z)
                self.gate.command(robot, self.world.clock.now, msg.linear.x, msg.linear.y,
                                  msg.angular.z)
        except CommandError as e:
            rospy.logwarn_throttle(2.0, str(e))

    def _on_reset(self, _req) -> EmptyResponse:
        def reset() -> Tuple[bool, str]:
            with self.lock:
                self.world.reset()
                self.gate.reset()
            self._publish_initialposes()
            return True, "robots reset to their spawn poses"

        ok, message = self.jobs.call(reset)     # the main loop's: robots may come and go
        (rospy.loginfo if ok else rospy.logwarn)("simulator: %s", message)
        return EmptyResponse()

    def _publish_initialposes(self, names: Optional[Sequence[str]] = None) -> None:
        """Spawn poses on N/initialpose (latched), so amcl starts (and restarts) localised;
        of the robots ``names`` only (None: all)."""
        for spec in self.world.specs:
            if names is not None and spec.name not in names:
                continue
            pub = self.robot_io[spec.name].initialpose
            if pub is None:
                continue
            m = PoseWithCovarianceStamped()
            m.header.frame_id = "map"
            m.header.stamp = ros_time(self.world.clock.now_ns)
            m.pose.pose.position.x, m.pose.pose.position.y = spec.pose[0], spec.pose[1]
            q = m.pose.pose.orientation
            q.x, q.y, q.z, q.w = quaternion(spec.pose[2])
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
    def _publish_map(self, cleaned: bool) -> None:
        fmap = (cleaned_map(self.world.fmap, self.world.config.map_handling) if cleaned
                else self.world.fmap)
        info = MapMetaData()
        info.map_load_time = ros_time(self.world.clock.now_ns)
        info.resolution = fmap.resolution
        info.width, info.height = fmap.width, fmap.height
        info.origin.position.x, info.origin.position.y = fmap.origin[0], fmap.origin[1]
        (info.origin.orientation.x, info.origin.orientation.y, info.origin.orientation.z,
         info.origin.orientation.w) = quaternion(fmap.origin[2])
        grid = OccupancyGrid()
        grid.header.frame_id = "map"
        grid.header.stamp = info.map_load_time
        grid.info = info
        grid.data = fmap.grid.ravel().tolist()
        self.map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub = rospy.Publisher("/map_metadata", MapMetaData, queue_size=1, latch=True)
        self.map_pub.publish(grid)
        self.meta_pub.publish(info)

    def _publish_clock(self, now_ns: int) -> None:
        secs, nsecs = divmod(now_ns, 1_000_000_000)
        if self.own_time:
            set_rostime(rospy.Time(secs, nsecs))
        if self.out.wanted(self.clock_pub):
            # each /clock in its own send: a rospy node keeps only the newest /clock of what
            # one read brings (its /clock subscriber's queue size is 1), so /clock messages
            # batched with the next flush would reach Python nodes as jumps of several steps
            self.out.put(self.clock_pub, U32.pack(8) + II.pack(secs, nsecs))
            self.out.send_now(self.clock_pub)
        self._clock_behind = False

    def publish(self, scans) -> None:
        """Queue what is due after a step (called with the lock held; ``flush`` sends; a
        /clock goes out at once, ``_publish_clock``)."""
        w = self.world
        steps = w.clock.steps
        now_ns = w.clock.now_ns
        if steps % self.every["clock"] == 0:
            wall = time.perf_counter()
            if wall - self._clock_wall >= self.clock_wall_period:
                self._clock_wall = wall
                self._publish_clock(now_ns)
            else:
                self._clock_behind = True
        odom_due = steps % self.every["odom"] == 0
        pose_due = steps % self.every["pose"] == 0
        state_due = steps % self.every["state"] == 0
        if odom_due or pose_due or state_due:
            self._robot_states(now_ns, odom_due, pose_due, state_due)
        out = self.out
        if self.people_out is not None and steps % self.every["people"] == 0:
            self._people(now_ns)
        for reading in scans:
            o = self.reading_out.get((type(reading), reading.robot))
            if o is not None and out.wanted(o.pub):
                o.put_reading(out, reading)

    def _people(self, now_ns: int) -> None:
        """The crowd's ground truth, and its log: leg lines at debug level, the rest at info."""
        assert self.people_out is not None and self.world.people is not None
        self.people_out.put(self.out, *divmod(now_ns, 1_000_000_000))
        for line in self.world.people.take_log():   # type: ignore[attr-defined]
            (rospy.logdebug if ": leg " in line else rospy.loginfo)("simulator: %s", line)

    def _robot_states(self, now_ns: int, odom_due: bool, pose_due: bool,
                      state_due: bool) -> None:
        w = self.world
        out = self.out
        wanted = out.wanted
        secs, nsecs = divmod(now_ns, 1_000_000_000)
        if odom_due:    # (odometry is integrated at its own rate; an extra update costs noise draws)
            w.update_odometry()
        snap = w.snapshot(wheels=state_due)
        tick = Tick(now_ns, secs, nsecs, snap, w)
        for rate, due in (("odom", odom_due), ("pose", pose_due), ("state", state_due)):
            if due:
                for o in self.periodic[rate]:
                    if wanted(o.pub):
                        o.put(out, tick)
        odom = snap.odom_pose
        if odom_due and wanted(self.tf_pub):
            poses = odom
            if self.gt_tf:
                poses = odom + [map_to_odom(snap.pose[i], odom[i]) for i in self.gt_tf]
            out.put(self.tf_pub, self.tf_wire.pack(secs, nsecs, poses))
        if state_due and self.wheel_tf and self.wheel_wire.links and wanted(self.tf_pub):
            out.put(self.tf_pub, self.wheel_wire.pack(
                secs, nsecs, [a for pair in snap.wheel_positions for a in pair]))

    def flush(self) -> None:
        """Send the queued messages (and the latest /clock if the wall-rate bound held it)."""
        if self._clock_behind:
            self._clock_wall = time.perf_counter()
            self._publish_clock(self.world.clock.now_ns)
        self.out.flush()
        self._flush_sim = self.world.clock.now

    # ------------------------------------------------------------------------- main loop
    def spin(self, stop: Callable[[], bool] = lambda: False) -> None:
        """Step, publish and pace until shutdown; every ``report_period`` log the achieved
        real-time factor and the publishing share (and publish them).

        Args:
            stop: polled every step (and while pacing or paused); True ends the loop, as
                rospy shutdown does. Never blocks for more than 50 ms of wall time at once.
        """
        w = self.world
        wall0, sim0 = time.perf_counter(), w.clock.now
        report_at = wall0 + self.report_period
        rep_wall, rep_sim = wall0, sim0
        rep_step, rep_pub = self.time_stepping, self.time_publishing
        while not (rospy.is_shutdown() or stop()):
            if self.jobs.pending:
                self.jobs.run()
                wall0, sim0 = time.perf_counter(), w.clock.now
            if self.paused:
                self.flush()
                with self.lock:
                    self.gate.suspend()     # a pause is no wait, and late for nobody
                if self.backlog is not None:
                    self.backlog.suspend()
                time.sleep(0.01)
                wall0, sim0 = time.perf_counter(), w.clock.now
                continue
            t0 = time.perf_counter()
            if self._controllers_late(t0) or self._subscribers_behind(t0):
                # send what is queued (a node answers, or waits for, the latest data)
                self.flush()
                time.sleep(_HOLD_POLL)
                continue
            with self.lock:
                scans = w.step(1)
                t1 = time.perf_counter()
                self.publish(scans)
            now_wall = time.perf_counter()
            self.time_stepping += t1 - t0
            self.time_publishing += now_wall - t1
            ahead = 0.0
            if self.rtf > 0:
                ahead = (w.clock.now - sim0) / self.rtf - (now_wall - wall0)
                if ahead < -1.0:  # far behind: do not try to catch up in a burst
                    wall0, sim0 = now_wall, w.clock.now
            if ahead > 0 or now_wall >= self._flush_next or (
                    self.backlog is not None and w.clock.now - self._flush_sim >= _MAX_FLUSH_SIM):
                self.flush()
                flushed = time.perf_counter()
                self.time_publishing += flushed - now_wall
                # a send costs per connection more than per byte: when not pacing, sending
                # takes at most send_share of the wall time (the next flush waits for it)
                self._flush_next = flushed + min(max(
                    self.flush_period, (flushed - now_wall) / self.send_share), _MAX_FLUSH_WAIT)
            if ahead > 0:
                time.sleep(min(ahead, 0.05))
            if now_wall >= report_at:
                achieved = (w.clock.now - rep_sim) / (now_wall - rep_wall)
                stepping = self.time_stepping - rep_step
                publishing = self.time_publishing - rep_pub
                share = publishing / stepping if stepping > 0 else 0.0
                wall = max(now_wall - rep_wall, 1e-9)
                rospy.loginfo("simulator: real-time factor %.2f (asked %s); of the wall time "
                              "%.0f%% stepping, %.0f%% publishing%s", achieved,
                              self.rtf if self.rtf > 0 else "as fast as possible",
                              100.0 * stepping / wall, 100.0 * publishing / wall,
                              waits_line(self.gate.take_report(),
                                         self.backlog.take_report() if self.backlog is not None else None,
                                         wall))
                self.rtf_pub.publish(Float64(achieved))
                self.share_pub.publish(Float64(share))
                report_at = now_wall + self.report_period
                rep_wall, rep_sim = now_wall, w.clock.now
                rep_step, rep_pub = self.time_stepping, self.time_publishing

    def _controllers_late(self, wall: float) -> bool:
        """Whether the clock holds for a moving robot's late controller (sim/pacing.py)."""
        with self.lock:
            held = self.gate.hold(self.world.clock.now, wall)
        for name in self.gate.released:
            rospy.logwarn("simulator: waited %.1f s of wall time for a cmd_vel for %s, which is "
                          "moving; going on without it until its next command (is its "
                          "controller alive?)", self.gate.max_wait, name)
        return bool(held)

    def _subscribers_behind(self, wall: float) -> bool:
        """After a send, whether the clock holds because a subscriber has not yet read it
        (sim/pacing.py)."""
        if self.backlog is None or not self.out.sent:
            return False
        try:
            unread = self.out.unread(tcp_unread)
        except (OSError, struct.error) as e:
            rospy.logwarn("simulator: cannot see what subscribers have read (%s); not waiting "
                          "for them", e)
            self.backlog = None
            return False
        held = self.backlog.hold(unread, self.world.clock.now, wall)
        for sub, topic in self.backlog.released:
            rospy.logwarn("simulator: %s has not read %s for %.1f s of wall time; going on "
                          "without it until it has caught up", sub, topic, self.backlog.max_wait)
        if not held:
            self.out.sent = False
        return bool(held)



def _log_check(world: World, walker: str = "", observer: str = "",
               allow: bool = False) -> None:
    """The map check (building/check.py, as ``check_world`` prints it) in the log: what the
    map handling changed, what each footprint reaches; a warning for each region the first
    robot cannot reach, a second robot cut off from it, and one region that is most of the
    building. With ``walker`` named (demo.launch's study: ``~study_walker``, observed by
    ``~study_observer``), what would make that study degrade raises ConfigError, so the
    required simulator stops the launch, unless ``allow`` (``~allow_unreachable``): then each
    problem is a warning that says the demo went on."""
    from ..building import Building
    from ..building.check import check_building, refusal, study_problems, \
        world_study_problems

    report = check_building(Building(world.config, world.fmap))
    for line in report.lines():
        log = rospy.logwarn if line.lstrip().startswith("warning:") else rospy.loginfo
        log("simulator: check_world: %s", line)
    if not (world.config.robots and world.config.rois):
        return
    if not walker:
        for p in world_study_problems(report, world.config):
            rospy.logwarn("simulator: check_world: %s", p)
        return
    names = [s.name for s in report.footprint("robot").starts]
    for who in (walker, observer):
        if who and who not in names:
            raise ConfigError("%s: ~study_walker/~study_observer: no robot %r (the world has %s)"
                              % (world.config.path, who, ", ".join(names)))
    problems = study_problems(report, walker, observer or None)
    if problems and not allow:
        raise ConfigError(refusal("world %s: the demo would degrade" % world.config.path,
                                  problems, "allow_unreachable:=true"))
    for p in problems:
        rospy.logwarn("simulator: check_world: %s (going on: allow_unreachable)", p)


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim simulator``."""
    rospy.init_node("simulator", disable_signals=True)
    stop = StopSignals().install()  # see StopSignals: never shut down inside a handler
    seed = int(rospy.get_param("~seed", -1))
    try:
        mode = state_publisher_mode(rospy.get_param("~robot_state_publishers", "builtin"))
        config = load_world_config(resolve_world(str(rospy.get_param("~world", "office")),
                                                 worlds_dir()))
        only = str(rospy.get_param("~only", ""))
        if only:   # one robot of the world (mapping.launch: the one that maps)
            if only not in [r.name for r in config.robots]:
                raise ConfigError("%s: ~only: no robot %r (the world has %s)" % (
                    config.path, only, ", ".join(r.name for r in config.robots)))
            config = dataclasses.replace(config, robots=[r for r in config.robots
                                                         if r.name == only])
        if rospy.get_param("~single_robot", False):
            if not config.robots:
                raise ConfigError("%s: single_robot needs at least one robot" % config.path)
            config = dataclasses.replace(
                config, robots=[dataclasses.replace(config.robots[0], name="")])
        world = World(config, physics_rate=float(rospy.get_param("~physics_rate", 100.0)),
                      gui=bool(rospy.get_param("~gui", False)), seed=None if seed < 0 else seed,
                      ray_threads=int(rospy.get_param("~ray_threads", 0)))
        people = int(rospy.get_param("~people", -1))
        crowd_cfg = world.config.people if people < 0 else world.config.people.with_count(people)
        if crowd_cfg.seed is None and seed >= 0:
            crowd_cfg = dataclasses.replace(crowd_cfg, seed=seed)
        crowd = build_crowd(world, crowd_cfg)
        world.add_people(crowd)
    except BulletFloorSimError as e:
        rospy.logfatal("simulator: %s", e)
        return 1
    # before /map: nodes read it as the world does (a cleaned /map has the cleaning done)
    serve_cleaned = bool(rospy.get_param("~serve_cleaned", False))
    set_map_handling(served_handling(world.config.map_handling)
                     if serve_cleaned and rospy.get_param("~publish_map", True)
                     else world.config.map_handling)
    rates = {k: float(rospy.get_param("~%s_rate" % k, d))
             for k, d in (("clock", 100.0), ("odom", 50.0), ("pose", 20.0), ("state", 10.0),
                          ("people", 10.0))}
    try:
        wait = float(rospy.get_param("~max_command_wait", 2.0))
        gate = CommandGate([s.name for s in world.specs],
                           float(rospy.get_param("~max_command_lag", 0.15)), wait)
        backlog = BacklogGate(wait) if rospy.get_param("~wait_for_subscribers", True) else None
        node = SimulatorNode(world, float(rospy.get_param("~real_time_factor", 1.0)), rates,
                             bool(rospy.get_param("~publish_map", True)),
                             rospy.get_param("~ground_truth_tf", False),
                             bool(rospy.get_param("~publish_initialpose", False)),
                             send_share=float(rospy.get_param("~send_share", 0.1)),
                             report_period=float(rospy.get_param("~report_period", 10.0)),
                             gate=gate, backlog=backlog,
                             serve_cleaned=serve_cleaned,
                             upstream_type_names=bool(rospy.get_param("~upstream_type_names",
                                                                      True)),
                             wheel_tf=mode == "builtin")
    except BulletFloorSimError as e:
        rospy.logfatal("simulator: %s", e)
        world.close()
        return 1
    rsps = None
    try:
        if mode != "none":
            rsps = node.rsps = (BuiltinStatePublisher(world) if mode == "builtin"
                                else RobotStatePublishers(world))
        rospy.loginfo("simulator: world %s with robots %s; beams at the walls %s, other "
                      "ray tests through %s",
                      world.config.path, ", ".join(s.name or "<empty>" for s in world.specs),
                      "on the solid grid" if world.walls_on_grid else "in Bullet",
                      bullet_capi.status())
        if world.people is not None:
            rospy.loginfo("simulator: %d people walk the regions of %s", crowd.n,  # type: ignore
                          ", ".join(sorted({g.rois or world.config.rois or ""
                                            for g in crowd_cfg.groups})))
        for line in world.sections_report:
            rospy.loginfo("simulator: lidar beams at robots of %s", line)
        if rospy.get_param("~check_world", True):
            _log_check(world, str(rospy.get_param("~study_walker", "")),
                       str(rospy.get_param("~study_observer", "")),
                       bool(rospy.get_param("~allow_unreachable", False)))
        else:   # what the map's handling made solid or floor, at least
            for line in world.solid.report:
                rospy.loginfo("simulator: map %s: %s", world.fmap.yaml_path, line)
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
