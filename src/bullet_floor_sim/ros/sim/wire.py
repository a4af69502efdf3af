"""Message bytes for the simulator's publishers: each message type packed once into a
template, then only its changing fields written per message (checked against genpy at start).
"""
from __future__ import annotations

import io
import math
import struct
from typing import List, Tuple

import numpy as np

import rospy
from geometry_msgs.msg import (PoseStamped, TransformStamped)
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState, JointState, LaserScan
from tf2_msgs.msg import TFMessage


__all__ = ["BatteryWire", "II", "JointsWire", "LinkTfWire", "OdomWire", "PoseWire", "ScanWire",
           "TfWire", "U32", "check_wires", "quaternion", "ros_time", "static_links_message"]


def ros_time(ns: int) -> rospy.Time:
    return rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


def quaternion(yaw: float):
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def _odometry(frame: str, child: str, pose, velocity, stamp) -> Odometry:
    """nav_msgs/Odometry of a planar pose (x, y, yaw) and body velocity (vx, vy, w)."""
    m = Odometry()
    m.header.stamp = stamp
    m.header.frame_id = frame
    m.child_frame_id = child
    p = m.pose.pose
    p.position.x, p.position.y = pose[0], pose[1]
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = quaternion(pose[2])
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
    r.x, r.y, r.z, r.w = quaternion(pose[2])
    return t


def _link_transform(link, quat, stamp) -> TransformStamped:
    """The transform of a URDF joint (sim/links.Link) with its child's rotation ``quat``."""
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = link.parent
    t.child_frame_id = link.child
    tr = t.transform.translation
    tr.x, tr.y, tr.z = link.xyz
    r = t.transform.rotation
    r.x, r.y, r.z, r.w = quat
    return t


def static_links_message(links, stamp) -> TFMessage:
    """/tf_static's message of fixed joints (sim/links.Link), all stamped ``stamp``."""
    return TFMessage(transforms=[_link_transform(x, x.quat, stamp) for x in links])


# ------------------------------------------------------------------------------ wire format
# A robot costs ~270 messages per sim second. Through rospy each is a genpy build and
# serialisation (15-20 us) and, per subscriber, a hand-off to that connection's writer thread
# (QueuedConnection.write_data ends in time.sleep(0): a GIL switch per message, two thirds of
# the node's time in bench/ros_bench.py). Here each message kind has a template of its wire
# bytes, built once by genpy and patched with struct.pack_into (checked against genpy at
# start-up, see check_wires), and Outbox sends them in batches without blocking.

U32 = struct.Struct("<I")
II = struct.Struct("<II")
_HDR = struct.Struct("<III")        # std_msgs/Header seq, stamp.secs, stamp.nsecs
_D7 = struct.Struct("<7d")          # Pose: position xyz, orientation xyzw
_D6 = struct.Struct("<6d")          # Twist: linear xyz, angular xyz
_D4 = struct.Struct("<4d")          # Quaternion xyzw
_D2 = struct.Struct("<2d")
_F7 = struct.Struct("<7f")
_SENTINELS = (1234.5678125, 2345.6789125)   # unlikely values; each slot must be unique


def _wire(msg) -> bytes:
    """What rospy sends for ``msg``: its length (uint32), then the serialised message."""
    b = io.BytesIO()
    msg.serialize(b)
    data = b.getvalue()
    return U32.pack(len(data)) + data


def _at(data: bytes, fmt: str, value: float) -> int:
    """Offset of the single place where ``value`` packed as ``fmt`` occurs in ``data``."""
    key = struct.pack(fmt, value)
    i = data.find(key)
    if i < 0 or data.find(key, i + 1) >= 0:
        raise RuntimeError("simulator: message template has no unique slot for %r" % value)
    return i


class OdomWire:
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


class PoseWire:
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


def _tf_templates(transforms: List[TransformStamped]) -> Tuple[List[Tuple[bytearray, int]], bytes]:
    """A TFMessage's parts: each transform's bytes (with ``_SENTINELS[0]`` in the one slot
    that changes) and that slot's offset, and the message's head (its length and count)."""
    parts = []
    for tr in transforms:
        b = io.BytesIO()
        tr.serialize(b)
        t = b.getvalue()
        parts.append((bytearray(t), _at(t, "<d", _SENTINELS[0])))
    return parts, U32.pack(4 + sum(len(t) for t, _ in parts)) + U32.pack(len(parts))


class TfWire:
    """tf2_msgs/TFMessage of planar transforms between fixed frame pairs, one stamp for all."""

    def __init__(self, pairs: List[Tuple[str, str]]) -> None:
        self.parts, self.head = _tf_templates(
            [_transform(parent, child, (_SENTINELS[0], 0.0, 0.0), rospy.Time(1, 0))
             for parent, child in pairs])

    def pack(self, secs: int, nsecs: int, poses) -> bytes:
        out = [self.head]
        for (b, at), pose in zip(self.parts, poses):
            h = 0.5 * pose[2]
            II.pack_into(b, 4, secs, nsecs)          # the header's seq (0) comes first
            _D7.pack_into(b, at, pose[0], pose[1], 0.0, 0.0, 0.0, math.sin(h), math.cos(h))
            out.append(bytes(b))
        return b"".join(out)


class LinkTfWire:
    """tf2_msgs/TFMessage of turning joints (sim/links.Link: the wheels) at given angles, one
    stamp for all: what robot_state_publisher publishes from a joint_states message."""

    def __init__(self, links) -> None:
        self.links = list(links)
        self.parts, self.head = _tf_templates(
            [_link_transform(x, (_SENTINELS[0], 0.0, 0.0, 1.0), rospy.Time(1, 0))
             for x in self.links])

    def pack(self, secs: int, nsecs: int, angles) -> bytes:
        out = [self.head]
        for (b, at), link, angle in zip(self.parts, self.links, angles):
            II.pack_into(b, 4, secs, nsecs)          # the header's seq (0) comes first
            _D4.pack_into(b, at, *link.turned(angle))
            out.append(bytes(b))
        return b"".join(out)


class ScanWire:
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
        U32.pack_into(h, 0, len(h) + len(r) + 4)
        _HDR.pack_into(h, 4, seq, secs, nsecs)
        return b"".join((h, U32.pack(len(ranges)), r, b"\0\0\0\0"))


class JointsWire:
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


class BatteryWire:
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


def check_wires() -> None:
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

    same(OdomWire("a/odom", "a/base_footprint").pack(7, stamp.secs, stamp.nsecs, pose, vel),
         _odometry("a/odom", "a/base_footprint", pose, vel, stamp))
    ps = PoseStamped()
    ps.header.stamp, ps.header.frame_id = stamp, "map"
    ps.pose = _odometry("map", "", pose, vel, stamp).pose.pose
    same(PoseWire("map").pack(7, stamp.secs, stamp.nsecs, pose), ps)
    pairs = [("odom", "base_footprint"), ("map", "r2/odom")]
    same(TfWire(pairs).pack(stamp.secs, stamp.nsecs, [pose, vel]),
         TFMessage(transforms=[_transform(a, b, p, stamp) for (a, b), p in zip(pairs, [pose, vel])]))
    from ...sim.links import Link
    from ...sim.sensors import Scan

    wheels = [Link("l", "a/base_link", "a/left_wheel", (0.0, 0.25, 0.04), (0.0, 0.0, 0.0, 1.0),
                   (0.0, 1.0, 0.0)),
              Link("r", "a/base_link", "a/right_wheel", (0.1, -0.25, 0.04),
                   (0.5, 0.5, 0.5, 0.5), (0.6, 0.8, 0.0))]
    same(LinkTfWire(wheels).pack(stamp.secs, stamp.nsecs, (1.25, -7.5)),
         TFMessage(transforms=[_link_transform(x, x.turned(a), stamp)
                               for x, a in zip(wheels, (1.25, -7.5))]))

    ranges = np.array([0.5, np.inf, -np.inf, 2.25], dtype=np.float32)
    scan = Scan(robot=0, stamp_ns=stamp.to_nsec(), ranges=ranges, angle_min=-1.5,
                angle_max=1.5, angle_increment=1.0, range_min=0.1, range_max=30.0,
                scan_time=0.1)
    m = LaserScan()
    m.header.stamp, m.header.frame_id = stamp, "base_laser_link"
    m.angle_min, m.angle_max, m.angle_increment = -1.5, 1.5, 1.0
    m.scan_time, m.range_min, m.range_max = 0.1, 0.1, 30.0
    m.ranges = ranges.tolist()
    same(ScanWire("base_laser_link", scan).pack(7, stamp.secs, stamp.nsecs, ranges), m)
    js = JointState()
    js.header.stamp, js.name = stamp, ["l", "r"]
    js.position, js.velocity = [1.5, -2.5], [0.25, 0.5]
    same(JointsWire(["l", "r"]).pack(7, stamp.secs, stamp.nsecs, (1.5, -2.5), (0.25, 0.5)), js)
    same(BatteryWire(60.0).pack(7, stamp.secs, stamp.nsecs, 28.1, 0.75, 45.0),
         _battery(stamp, 28.1, 0.75, 45.0, 60.0))
