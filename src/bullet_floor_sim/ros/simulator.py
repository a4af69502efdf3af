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
amcl; a list of robot names does it for those robots only, e.g. a walker beside an observer
that amcl localises),
``~single_robot`` (false: true keeps only the world's first robot and gives it an empty name,
i.e. bare topics and frames ``/odom``, ``odom``, ``base_footprint``, as the MORSE tutorial's),
``~publish_initialpose`` (false: true publishes each spawn pose, latched, on ``N/initialpose``
at start and after ``~reset``, so amcl starts localised whatever the world),
``~robot_state_publishers`` (true: one robot_state_publisher per robot, started by this node
with the robot's prefixed URDF, so any number of robots works from one launch file),
``~ray_threads`` (0: PyBullet threads for lidar batches of 1000 rays or more, 0 = all cores;
1 leaves the other cores to the rest of the ROS graph),
``~max_command_lag`` (0.15 s of sim time: while a moving robot's last ``cmd_vel`` is older,
the clock goes no faster than real time, so a navigation node that cannot keep pace with
``rtf:=0`` slows the simulator instead of driving on stale commands; 0 = never wait;
sim/pacing.py), ``~wait_for_subscribers`` (true: after each send the clock holds until every
subscriber on this machine has read it, so no node works from data queued seconds behind; Linux
only), ``~max_command_wait`` (2.0 s of wall time: a robot late for that long, or a subscriber
that has not read for that long, is let go, with a warning naming it, until it is back).
Services: ``~reset``, ``~pause``, ``~unpause`` (std_srvs/Empty).
"""
from __future__ import annotations

import dataclasses
import io
import math
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

import rospy
from geometry_msgs.msg import (PoseStamped, PoseWithCovarianceStamped, TransformStamped,
                               Twist)
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, JointState, LaserScan
from std_msgs.msg import Float64
from std_srvs.srv import Empty, EmptyResponse
from tf2_msgs.msg import TFMessage

from ..sim import bullet_capi
from ..sim.config import load_world_config, resolve_world
from ..errors import BulletFloorSimError, CommandError, ConfigError
from ..sim.pacing import BacklogGate, CommandGate, tcp_unread
from ..paths import worlds_dir
from ..sim.robot import expand_xacro
from ..sim.world import World
from .params import set_map_handling

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


# ------------------------------------------------------------------------------ wire format
# A robot costs ~270 messages per sim second. Through rospy each is a genpy build and
# serialisation (15-20 us) and, per subscriber, a hand-off to that connection's writer thread
# (QueuedConnection.write_data ends in time.sleep(0): a GIL switch per message, two thirds of
# the node's time in bench/ros_bench.py). Here each message kind has a template of its wire
# bytes, built once by genpy and patched with struct.pack_into (checked against genpy at
# start-up, see _check_wires), and _Outbox sends them in batches without blocking.

_U32 = struct.Struct("<I")
_II = struct.Struct("<II")
_HDR = struct.Struct("<III")        # std_msgs/Header seq, stamp.secs, stamp.nsecs
_D7 = struct.Struct("<7d")          # Pose: position xyz, orientation xyzw
_D6 = struct.Struct("<6d")          # Twist: linear xyz, angular xyz
_D2 = struct.Struct("<2d")
_F7 = struct.Struct("<7f")
_MAX_FLUSH_WAIT = 0.05     # s: the longest a queued message waits for its send when not pacing
_MAX_FLUSH_SIM = 0.05      # s of sim time: the same bound while the clock waits for subscribers
_HOLD_POLL = 0.0005        # s: the sleep between looks while the clock waits for a node
_SENTINELS = (1234.5678125, 2345.6789125)   # unlikely values; each slot must be unique


def _wire(msg) -> bytes:
    """What rospy sends for ``msg``: its length (uint32), then the serialised message."""
    b = io.BytesIO()
    msg.serialize(b)
    data = b.getvalue()
    return _U32.pack(len(data)) + data


def _at(data: bytes, fmt: str, value: float) -> int:
    """Offset of the single place where ``value`` packed as ``fmt`` occurs in ``data``."""
    key = struct.pack(fmt, value)
    i = data.find(key)
    if i < 0 or data.find(key, i + 1) >= 0:
        raise RuntimeError("simulator: message template has no unique slot for %r" % value)
    return i


class _OdomWire:
    """nav_msgs/Odometry of a planar pose and body velocity between two fixed frames."""

    def __init__(self, frame: str, child: str) -> None:
        t = _wire(_odometry(frame, child, (_SENTINELS[0], 0.0, 0.0), (_SENTINELS[1], 0.0, 0.0),
                            rospy.Time(1, 0)))
        self.buf = bytearray(t)
        self.pose_at = _at(t, "<d", _SENTINELS[0])
        self.twist_at = _at(t, "<d", _SENTINELS[1])

    def pack(self, seq: int, secs: int, nsecs: int, pose, vel) -> bytes:
        b = self.buf
        h = 0.5 * pose[2]
        _HDR.pack_into(b, 4, seq, secs, nsecs)
        _D7.pack_into(b, self.pose_at, pose[0], pose[1], 0.0, 0.0, 0.0, math.sin(h), math.cos(h))
        _D6.pack_into(b, self.twist_at, vel[0], vel[1], 0.0, 0.0, 0.0, vel[2])
        return bytes(b)


class _PoseWire:
    """geometry_msgs/PoseStamped of a planar pose in a fixed frame."""

    def __init__(self, frame: str) -> None:
        m = PoseStamped()
        m.header.frame_id = frame
        m.pose.position.x = _SENTINELS[0]
        m.pose.orientation.w = 1.0
        t = _wire(m)
        self.buf = bytearray(t)
        self.pose_at = _at(t, "<d", _SENTINELS[0])

    def pack(self, seq: int, secs: int, nsecs: int, pose) -> bytes:
        b = self.buf
        h = 0.5 * pose[2]
        _HDR.pack_into(b, 4, seq, secs, nsecs)
        _D7.pack_into(b, self.pose_at, pose[0], pose[1], 0.0, 0.0, 0.0, math.sin(h), math.cos(h))
        return bytes(b)


class _TfWire:
    """tf2_msgs/TFMessage of planar transforms between fixed frame pairs, one stamp for all."""

    def __init__(self, pairs: List[Tuple[str, str]]) -> None:
        self.parts = []
        for parent, child in pairs:
            b = io.BytesIO()
            _transform(parent, child, (_SENTINELS[0], 0.0, 0.0), rospy.Time(1, 0)).serialize(b)
            t = b.getvalue()
            self.parts.append((bytearray(t), _at(t, "<d", _SENTINELS[0])))
        self.head = _U32.pack(4 + sum(len(t) for t, _ in self.parts)) + _U32.pack(len(pairs))

    def pack(self, secs: int, nsecs: int, poses) -> bytes:
        out = [self.head]
        for (b, at), pose in zip(self.parts, poses):
            h = 0.5 * pose[2]
            _II.pack_into(b, 4, secs, nsecs)          # the header's seq (0) comes first
            _D7.pack_into(b, at, pose[0], pose[1], 0.0, 0.0, 0.0, math.sin(h), math.cos(h))
            out.append(bytes(b))
        return b"".join(out)


class _ScanWire:
    """sensor_msgs/LaserScan of one robot's lidar (geometry fixed, ranges float32)."""

    def __init__(self, frame: str, s) -> None:
        m = LaserScan()
        m.header.frame_id = frame
        m.angle_min, m.angle_max, m.angle_increment = s.angle_min, s.angle_max, s.angle_increment
        m.scan_time = s.scan_time
        m.range_min, m.range_max = s.range_min, s.range_max
        self.key = (s.angle_min, s.angle_max, s.angle_increment, s.scan_time, s.range_min,
                    s.range_max)
        self.head = bytearray(_wire(m)[:-8])    # without the empty ranges and intensities

    def pack(self, seq: int, secs: int, nsecs: int, ranges: np.ndarray) -> bytes:
        r = ranges.astype("<f4", copy=False).tobytes()
        h = self.head
        _U32.pack_into(h, 0, len(h) + len(r) + 4)
        _HDR.pack_into(h, 4, seq, secs, nsecs)
        return b"".join((h, _U32.pack(len(ranges)), r, b"\0\0\0\0"))


class _JointsWire:
    """sensor_msgs/JointState of the two wheels (positions, velocities; no efforts)."""

    def __init__(self, names: List[str]) -> None:
        m = JointState()
        m.name = list(names)
        m.position = [_SENTINELS[0], 0.0]
        m.velocity = [_SENTINELS[1], 0.0]
        t = _wire(m)
        self.buf = bytearray(t)
        self.pos_at = _at(t, "<d", _SENTINELS[0])
        self.vel_at = _at(t, "<d", _SENTINELS[1])

    def pack(self, seq: int, secs: int, nsecs: int, pos, vel) -> bytes:
        b = self.buf
        _HDR.pack_into(b, 4, seq, secs, nsecs)
        _D2.pack_into(b, self.pos_at, pos[0], pos[1])
        _D2.pack_into(b, self.vel_at, vel[0], vel[1])
        return bytes(b)


def _battery(stamp, volt: float, pct: float, charge: float, capacity: float) -> BatteryState:
    b = BatteryState()
    b.header.stamp = stamp
    b.voltage, b.percentage, b.charge = volt, pct, charge
    b.capacity = b.design_capacity = capacity
    b.current = float("nan")
    b.power_supply_status = BatteryState.POWER_SUPPLY_STATUS_DISCHARGING
    b.power_supply_technology = BatteryState.POWER_SUPPLY_TECHNOLOGY_UNKNOWN
    b.present = True
    return b


class _BatteryWire:
    """sensor_msgs/BatteryState: voltage, charge and percentage change, the rest is fixed."""

    def __init__(self, capacity: float) -> None:
        t = _wire(_battery(rospy.Time(1, 0), _SENTINELS[0], 0.0, 0.0, capacity))
        self.capacity = capacity
        self.buf = bytearray(t)
        self.at = _at(t, "<f", _SENTINELS[0])   # voltage .. percentage: seven float32

    def pack(self, seq: int, secs: int, nsecs: int, volt: float, pct: float,
             charge: float) -> bytes:
        b = self.buf
        _HDR.pack_into(b, 4, seq, secs, nsecs)
        _F7.pack_into(b, self.at, volt, 0.0, math.nan, charge, self.capacity, self.capacity,
                      pct)
        return bytes(b)


def _check_wires() -> None:
    """Every template against genpy's serialisation of the same message (start-up check).

    Raises:
        RuntimeError: a template writes different bytes than genpy (a message definition
            differs from the one these templates were written for).
    """
    stamp = rospy.Time(1234567, 89012345)
    pose, vel = (1.25, -3.5, 2.75), (0.4, 0.1, -0.3)

    def same(mine: bytes, msg, seq: int = 7) -> None:
        if hasattr(msg, "header"):
            msg.header.seq = seq
        if mine != _wire(msg):
            raise RuntimeError("simulator: wire template for %s differs from genpy" % msg._type)

    same(_OdomWire("a/odom", "a/base_footprint").pack(7, stamp.secs, stamp.nsecs, pose, vel),
         _odometry("a/odom", "a/base_footprint", pose, vel, stamp))
    ps = PoseStamped()
    ps.header.stamp, ps.header.frame_id = stamp, "map"
    ps.pose = _odometry("map", "", pose, vel, stamp).pose.pose
    same(_PoseWire("map").pack(7, stamp.secs, stamp.nsecs, pose), ps)
    pairs = [("odom", "base_footprint"), ("map", "r2/odom")]
    same(_TfWire(pairs).pack(stamp.secs, stamp.nsecs, [pose, vel]),
         TFMessage(transforms=[_transform(a, b, p, stamp) for (a, b), p in zip(pairs, [pose, vel])]))
    from ..sim.sensors import Scan

    ranges = np.array([0.5, np.inf, -np.inf, 2.25], dtype=np.float32)
    scan = Scan(robot=0, stamp_ns=stamp.to_nsec(), ranges=ranges, angle_min=-1.5,
                angle_max=1.5, angle_increment=1.0, range_min=0.1, range_max=30.0,
                scan_time=0.1)
    m = LaserScan()
    m.header.stamp, m.header.frame_id = stamp, "base_laser_link"
    m.angle_min, m.angle_max, m.angle_increment = -1.5, 1.5, 1.0
    m.scan_time, m.range_min, m.range_max = 0.1, 0.1, 30.0
    m.ranges = ranges.tolist()
    same(_ScanWire("base_laser_link", scan).pack(7, stamp.secs, stamp.nsecs, ranges), m)
    js = JointState()
    js.header.stamp, js.name = stamp, ["l", "r"]
    js.position, js.velocity = [1.5, -2.5], [0.25, 0.5]
    same(_JointsWire(["l", "r"]).pack(7, stamp.secs, stamp.nsecs, (1.5, -2.5), (0.25, 0.5)), js)
    same(_BatteryWire(60.0).pack(7, stamp.secs, stamp.nsecs, 28.1, 0.75, 45.0),
         _battery(stamp, 28.1, 0.75, 45.0, 60.0))


class _Outbox:
    """Batched, non-blocking delivery of wire bytes to the subscribers of some publishers.

    rospy hands every message to one writer thread per subscriber. Here messages wait per
    connection and leave in one non-blocking ``send`` per connection per ``flush`` (or as
    soon as a connection has the publisher's queue size waiting); a subscriber that does not
    keep up loses its oldest messages beyond that queue size (as with rospy's queue) and
    never stalls the simulation. Main thread only. Publishers
    used here are created without a rospy queue (raw connections) and never publish through
    rospy, so nothing else writes to their sockets.
    """

    def __init__(self) -> None:
        self._queues: Dict[object, list] = {}   # connection -> [messages, bytes sent of the first]
        self.publishers: List[rospy.Publisher] = []
        self.sent = False   # bytes went out since the owner last cleared this
        self.raw = raw_sockets_usable()
        if not self.raw:
            rospy.logwarn("simulator: this rospy's connections have no socket/done attributes; "
                          "every message goes through rospy's blocking write_data instead")

    def publisher(self, topic: str, cls, queue_size: int) -> rospy.Publisher:
        """A publisher for ``put``: rospy connections without rospy's per-connection queue."""
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")     # rospy warns about a missing queue_size
            pub = rospy.Publisher(topic, cls, queue_size=None)
        pub._bfs_queue_size = queue_size
        self.publishers.append(pub)
        return pub

    @staticmethod
    def wanted(pub: rospy.Publisher) -> bool:
        """Whether anyone subscribes (build nothing otherwise)."""
        return bool(pub.impl.connections)

    def put(self, pub: rospy.Publisher, data: bytes) -> None:
        """Queue ``data`` (from a *Wire ``pack``) for every current subscriber of ``pub``.
        A queue that reaches the publisher's queue size is sent at once; only what its
        socket does not take then is dropped, oldest first."""
        limit = pub._bfs_queue_size
        queues = self._queues
        for c in pub.impl.connections:
            q = queues.get(c)
            if q is None:
                if hasattr(c, "_connection") or not self.raw:
                    # a rospy QueuedConnection (someone else in this process made a publisher
                    # on this topic with a queue, and its thread writes to the socket), or a
                    # rospy whose connections this outbox does not know: go through rospy
                    try:
                        c.write_data(data)
                    except Exception:  # noqa: BLE001  (rospy drops such connections itself)
                        pass
                    continue
                q = queues[c] = [[], 0]
                _no_delay(c)
            msgs = q[0]
            msgs.append(data)
            if len(msgs) > limit and not self._send(c, q):
                del msgs[1 if q[1] else 0]      # drop the oldest not yet being sent

    def flush(self) -> None:
        """Send what each connection's socket takes now; keep the rest for the next flush."""
        for c, q in list(self._queues.items()):
            if q[0]:
                self._send(c, q)
            elif getattr(c, "done", True):
                del self._queues[c]

    def _send(self, c, q: list) -> bool:
        """One non-blocking send of a connection's queue; whether the queue is short again."""
        msgs = q[0]
        sock = getattr(c, "socket", None)
        if getattr(c, "done", True) or sock is None:
            del msgs[:]
            self._queues.pop(c, None)
            return True
        data = msgs[0] if len(msgs) == 1 else b"".join(msgs)
        try:
            n = sock.send(memoryview(data)[q[1]:] if q[1] else data, socket.MSG_DONTWAIT)
        except (BlockingIOError, InterruptedError):
            return False
        except OSError:                     # subscriber gone: rospy's own clean-up
            del msgs[:]
            self._queues.pop(c, None)
            try:
                c.close()
            except Exception:  # noqa: BLE001  (already closing)
                pass
            return True
        self.sent = True
        left = n + q[1]
        if left == len(data):
            k = len(msgs)
            del msgs[:]
            left = 0
        else:
            k = 0
            while left >= len(msgs[k]):
                left -= len(msgs[k])
                k += 1
            del msgs[:k]
        q[1] = left
        c.stat_bytes = getattr(c, "stat_bytes", 0) + n
        c.stat_num_msg = getattr(c, "stat_num_msg", 0) + k
        return not msgs


def raw_sockets_usable() -> bool:
    """Whether rospy's TCPROS connections have what ``_Outbox`` writes through: the
    ``socket`` and ``done`` attributes its constructor sets, and ``write_data``."""
    from rospy.impl.tcpros_base import TCPROSTransport

    names = set()
    for cls in TCPROSTransport.__mro__:     # done is set by rospy.transport.Transport
        init = cls.__dict__.get("__init__")
        if init is not None and hasattr(init, "__code__"):
            names.update(init.__code__.co_names)
    return "socket" in names and "done" in names and hasattr(TCPROSTransport, "write_data")


try:   # rospy internals: the setter of rospy's time, used when this node owns the clock
    from rospy.rostime import _set_rostime
except ImportError:
    _set_rostime = None


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
    except ImportError:
        return False
    sub = getattr(simtime, "_clock_sub", None)
    if sub is None or _set_rostime is None:
        return False
    sub.unregister()
    simtime._clock_sub = None
    return True


class StopSignals:
    """SIGINT/SIGTERM handlers that only record the request; the main loop acts on it.

    rospy's own handlers (and roslaunch's ``rl_signal``, which any roslaunch ``Process`` made in
    this process installs) run the whole shutdown inside the handler: in the main thread, at
    whatever bytecode it was interrupted. The simulator's main thread spends much of its time in
    ``Publisher.publish`` -> ``QueuedConnection.write_data``, holding that connection's
    non-reentrant lock; rospy's shutdown then closes all topics and waits for the topic
    manager's lock, which rospy's registration thread holds while it waits for the connection
    lock the interrupted main thread still has: a deadlock (2-3 runs in 20 of sim.launch in
    worlds/simple with scan subscribers; the rostests and nav_bench saw it too). Both rospy and
    roslaunch ignore every later signal once shutdown has begun, so roslaunch's SIGTERM did
    nothing either and only SIGKILL ended the node.

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
    """ROS glue around one core ``World``: messages in and out, pacing, services.

    Args:
        world: the core world.
        rtf: real-time factor to hold (0 = as fast as possible).
        rates: Hz of "clock", "odom" (and tf), "pose" (ground truth), "state" (battery, joints).
        publish_map: publish the world's map, latched, on /map and /map_metadata.
        ground_truth_tf: publish map -> N/odom from ground truth: True for every robot, or
            the names of the robots to do it for.
        initialpose: publish spawn poses, latched, on N/initialpose.
        clock_wall_period: when running faster than real time, /clock is published at most
            once per this many wall seconds (nobody consumes it faster; every message still
            carries its exact sim-time stamp).
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
    """

    def __init__(self, world: World, rtf: float, rates: dict, publish_map: bool,
                 ground_truth_tf: Union[bool, Sequence[str]] = False,
                 initialpose: bool = False,
                 clock_wall_period: float = 0.001, flush_period: float = 0.002,
                 send_share: float = 0.1, report_period: float = 10.0,
                 gate: Optional[CommandGate] = None,
                 backlog: Optional[BacklogGate] = None) -> None:
        _check_wires()
        self.world = world
        self.gate = gate or CommandGate([s.name for s in world.specs])
        self.backlog = backlog
        self._flush_sim = 0.0        # sim time of the last flush
        self._peers = {}  # type: Dict[object, Tuple[Any, Tuple[str, str]]]
        self.gt_tf = _gt_tf_robots(ground_truth_tf, [s.name for s in world.specs])
        self.own_time = _stop_listening_to_own_clock()
        self.rtf = rtf
        self.lock = threading.Lock()
        self.paused = False
        self.clock_wall_period = clock_wall_period
        self.flush_period = flush_period
        for name, v in (("send_share", send_share), ("report_period", report_period)):
            if not (math.isfinite(v) and v > 0.0) or (name == "send_share" and v > 1.0):
                raise ConfigError("~%s: %r is not a %s" % (
                    name, v, "share in (0, 1]" if name == "send_share" else "positive number"))
        for name, v in rates.items():
            if not (math.isfinite(v) and v > 0.0):
                raise ConfigError("~%s_rate: %r is not a positive rate (Hz)" % (name, v))
        self.send_share = send_share
        self.report_period = report_period
        step = world.clock.step_ns
        self.every = {k: max(1, int(round(1e9 / v / step))) for k, v in rates.items()}
        self.out = _Outbox()
        pub = self.out.publisher
        self.robots = []
        for i, spec in enumerate(world.specs):
            ns = "/" + spec.name if spec.name else ""
            pre = spec.prefix
            r = {
                "prefix": pre,
                "odom": pub(ns + "/odom", Odometry, 10),
                "scan": pub(ns + "/base_scan", LaserScan, 10),
                "gt": pub(ns + "/base_pose_ground_truth", Odometry, 10),
                "pose": pub(ns + "/pose", PoseStamped, 10),
                "battery": pub(ns + "/battery_state", BatteryState, 2),
                "joints": pub(ns + "/joint_states", JointState, 10),
                "odom_wire": _OdomWire(pre + "odom", pre + "base_footprint"),
                "gt_wire": _OdomWire("map", pre + "base_footprint"),
                "pose_wire": _PoseWire("map"),
                "joints_wire": _JointsWire([pre + j for j in world.models[i].wheel_joints]),
                "battery_wire": _BatteryWire(spec.battery.capacity_ah),
                "scan_wire": None,
                "seq": {"odom": 0, "gt": 0, "pose": 0, "joints": 0, "battery": 0, "scan": 0},
            }
            rospy.Subscriber(ns + "/cmd_vel", Twist, self._on_cmd, callback_args=i, queue_size=1)
            self.robots.append(r)
        self.clock_pub = pub("/clock", Clock, 10)
        self.tf_pub = pub("/tf", TFMessage, 100)
        pairs = [(r["prefix"] + "odom", r["prefix"] + "base_footprint") for r in self.robots]
        pairs += [("map", self.robots[i]["prefix"] + "odom") for i in self.gt_tf]
        self.tf_wire = _TfWire(pairs)
        self.rtf_pub = rospy.Publisher("~real_time_factor_achieved", Float64, queue_size=1)
        self.share_pub = rospy.Publisher("~publishing_share", Float64, queue_size=1)
        self._clock_wall = -math.inf      # wall time of the last /clock
        self._clock_behind = False        # a due /clock was skipped (wall-rate bound)
        self._flush_next = time.perf_counter()   # when not pacing, no flush before this
        # wall seconds spent in World.step, and in building and sending messages (the
        # publishing overhead the log and bench/ros_bench.py report)
        self.time_stepping = self.time_publishing = 0.0
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
                self.gate.command(robot, self.world.clock.now, msg.linear.x, msg.linear.y,
                                  msg.angular.z)
        except CommandError as e:
            rospy.logwarn_throttle(2.0, str(e))

    def _on_reset(self, _req) -> EmptyResponse:
        with self.lock:
            self.world.reset()
            self.gate.reset()
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

    def _publish_clock(self, now_ns: int) -> None:
        secs, nsecs = divmod(now_ns, 1_000_000_000)
        if self.own_time:
            _set_rostime(rospy.Time(secs, nsecs))
        if self.out.wanted(self.clock_pub):
            self.out.put(self.clock_pub, _U32.pack(8) + _II.pack(secs, nsecs))
        self._clock_behind = False

    def publish(self, scans) -> None:
        """Queue what is due after a step (called with the lock held; ``flush`` sends)."""
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
        for s in scans:
            r = self.robots[s.robot]
            if not out.wanted(r["scan"]):
                continue
            wire = r["scan_wire"]
            if wire is None or wire.key != (s.angle_min, s.angle_max, s.angle_increment,
                                            s.scan_time, s.range_min, s.range_max):
                wire = r["scan_wire"] = _ScanWire(r["prefix"] + "base_laser_link", s)
            r["seq"]["scan"] += 1
            secs, nsecs = divmod(s.stamp_ns, 1_000_000_000)
            out.put(r["scan"], wire.pack(r["seq"]["scan"], secs, nsecs, s.ranges))

    def _robot_states(self, now_ns: int, odom_due: bool, pose_due: bool,
                      state_due: bool) -> None:
        w = self.world
        out = self.out
        wanted = out.wanted
        secs, nsecs = divmod(now_ns, 1_000_000_000)
        if odom_due:    # (odometry is integrated at its own rate; an extra update costs noise draws)
            w.update_odometry()
        snap = w.snapshot(wheels=state_due)
        pose, vel, odom = snap.pose, snap.velocity, snap.odom_pose
        wpos, wvel = snap.wheel_positions, snap.wheel_velocities
        for i, r in enumerate(self.robots):
            seq = r["seq"]
            if odom_due and wanted(r["odom"]):
                seq["odom"] += 1
                out.put(r["odom"], r["odom_wire"].pack(seq["odom"], secs, nsecs, odom[i], vel[i]))
            if pose_due:
                if wanted(r["gt"]):
                    seq["gt"] += 1
                    out.put(r["gt"], r["gt_wire"].pack(seq["gt"], secs, nsecs, pose[i], vel[i]))
                if wanted(r["pose"]):
                    seq["pose"] += 1
                    out.put(r["pose"], r["pose_wire"].pack(seq["pose"], secs, nsecs, pose[i]))
            if state_due:
                if wanted(r["joints"]):
                    seq["joints"] += 1
                    out.put(r["joints"], r["joints_wire"].pack(seq["joints"], secs, nsecs,
                                                               wpos[i], wvel[i]))
                if wanted(r["battery"]):
                    seq["battery"] += 1
                    pct, volt, charge = w.battery.state(i, now_ns)
                    out.put(r["battery"], r["battery_wire"].pack(seq["battery"], secs, nsecs,
                                                                 volt, pct, charge))
        if odom_due and wanted(self.tf_pub):
            poses = odom
            if self.gt_tf:
                poses = odom + [_map_to_odom(pose[i], odom[i]) for i in self.gt_tf]
            out.put(self.tf_pub, self.tf_wire.pack(secs, nsecs, poses))

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
                              self._waits_line(wall))
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
            unread = self._unread()
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

    def _unread(self) -> Dict[Tuple[str, str], int]:
        """Unread bytes per (subscriber, topic) of every connection on this machine."""
        unread = tcp_unread()
        for c in [c for c in self._peers if getattr(c, "done", True)]:
            del self._peers[c]
        out = {}  # type: Dict[Tuple[str, str], int]
        for pub in self.out.publishers:
            for c in pub.impl.connections:
                peer = self._peers.get(c)
                if peer is None:
                    peer = self._peers[c] = _peer_key(c, pub.resolved_name)
                if peer[0] is not None:
                    out[peer[1]] = max(out.get(peer[1], 0), unread.get(peer[0], 0))
        return out

    def _waits_line(self, wall: float) -> str:
        """The report's account of the wall time spent waiting for controllers and
        subscribers, slowest first; empty when nobody was waited for."""
        line = ""
        waited = sorted(self.gate.take_report().items(), key=lambda kv: -kv[1])
        if waited:
            line += "; waited for cmd_vel of %s" % ", ".join(
                "%s %.0f%%" % (n, 100.0 * t / wall) for n, t in waited)
        if self.backlog is not None:
            subs = sorted(self.backlog.take_report().items(), key=lambda kv: -kv[1])[:3]
            if subs:
                line += "; waited for subscribers %s" % ", ".join(
                    "%s (%s) %.0f%%" % (s, t, 100.0 * w / wall) for (s, t), w in subs)
        return line


def _no_delay(c) -> None:
    """TCP_NODELAY on a subscriber's socket: the batches here are small and end on a message,
    and Nagle's algorithm held each one back until the peer's delayed ACK (up to 40 ms of
    wall time), while the clock waited for the subscriber to read it."""
    sock = getattr(c, "socket", None)
    try:
        if sock is not None and sock.family in (socket.AF_INET, socket.AF_INET6):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    except OSError:
        pass


def _peer_key(c, topic: str) -> Tuple[Any, Tuple[str, str]]:
    """(the subscriber's socket as tcp_unread keys it, or None when it cannot be seen;
    (subscriber, topic)) of a publisher-side connection."""
    label = (str(getattr(c, "endpoint_id", "") or "?"), topic)
    sock = getattr(c, "socket", None)
    try:
        if sock is None or sock.family != socket.AF_INET:
            return None, label
        return (sock.getpeername(), sock.getsockname()), label
    except OSError:
        return None, label


def _map_to_odom(truth, odom) -> Tuple[float, float, float]:
    """map -> N/odom that makes odom -> base_footprint land on the ground truth (what
    fake_localization does); only when no localisation node (amcl) publishes it."""
    xg, yg, thg = truth
    xo, yo, tho = odom
    th = thg - tho
    c, s = math.cos(th), math.sin(th)
    return xg - (c * xo - s * yo), yg - (s * xo + c * yo), th


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


def _gt_tf_robots(setting: Any, names: List[str]) -> List[int]:
    """Indices of the robots whose map -> N/odom comes from ground truth (``~ground_truth_tf``:
    a bool, or a list of robot names)."""
    if isinstance(setting, (list, tuple)):
        unknown = sorted(set(map(str, setting)) - set(names))
        if unknown:
            raise ConfigError("~ground_truth_tf: no robot named %s (robots: %s)"
                              % (", ".join(unknown), ", ".join(n or "<empty>" for n in names)))
        return [i for i, n in enumerate(names) if n in set(map(str, setting))]
    if isinstance(setting, str):  # a launch-file string such as "true"/"false"
        setting = setting.strip().lower() in ("true", "1", "yes")
    return list(range(len(names))) if setting else []


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
                      gui=bool(rospy.get_param("~gui", False)), seed=None if seed < 0 else seed,
                      ray_threads=int(rospy.get_param("~ray_threads", 0)))
    except BulletFloorSimError as e:
        rospy.logfatal("simulator: %s", e)
        return 1
    set_map_handling(world.config.map_handling)  # before /map: nodes read it as the world does
    rates = {k: float(rospy.get_param("~%s_rate" % k, d))
             for k, d in (("clock", 100.0), ("odom", 50.0), ("pose", 20.0), ("state", 10.0))}
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
                             gate=gate, backlog=backlog)
    except BulletFloorSimError as e:
        rospy.logfatal("simulator: %s", e)
        world.close()
        return 1
    rsps = None
    try:
        if rospy.get_param("~robot_state_publishers", True):
            rsps = RobotStatePublishers(world)
        rospy.loginfo("simulator: world %s with robots %s; ray tests through %s",
                      world.config.path, ", ".join(s.name or "<empty>" for s in world.specs),
                      bullet_capi.status())
        for line in world.sections_report:
            rospy.loginfo("simulator: lidar beams at robots of %s", line)
        for line in world.solid.report:  # what the map's handling made solid or floor
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
