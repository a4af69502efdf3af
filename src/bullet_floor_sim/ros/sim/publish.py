"""What the simulator node publishes per robot: one output per topic, sensors by registry.

An output owns its topic's publisher, its wire template (wire.py) and its sequence number.
``SENSOR_OUTPUTS`` publishes each sensor kind of ``sim/sensors`` (``SENSORS``) under the
same name; a kind with no output here is simulated but not published. A periodic output
goes out at one of the node's rates (``rate``: "odom", "pose" or "state") from the world's
snapshot; a reading output (``reads``: the reading's type) goes out with every reading of
its robot that ``World.step`` returns. The robot's other outputs (ground truth, pose, joint
states) are ``ROBOT_OUTPUTS``.
"""
from __future__ import annotations

from typing import Dict, List, NamedTuple, Optional, Type

from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState, JointState, LaserScan

from ...sim.sensors import Scan
from .wire import BatteryWire, JointsWire, OdomWire, PoseWire, ScanWire

__all__ = ["Tick", "Output", "SENSOR_OUTPUTS", "ROBOT_OUTPUTS", "robot_outputs"]


class Tick(NamedTuple):
    """What a periodic output packs from: the stamp and the world's snapshot."""

    now_ns: int
    secs: int
    nsecs: int
    snap: object     # sim.views.Snapshot
    world: object    # sim.world.World


class Output:
    """One topic of one robot.

    Args:
        publisher: ``Outbox.publisher`` (topic, type, queue size) -> publisher.
        ns: the robot's topic namespace ("" or "/name").
        prefix: its frame prefix ("" or "name/").
        robot: its index in the world.
        world: the world (its spec and model give the frames and constants).
    """

    rate: Optional[str] = None       # the node's rate it goes out at (periodic outputs)
    reads: Optional[type] = None     # the reading type it publishes (reading outputs)

    def __init__(self, publisher, ns: str, prefix: str, robot: int, world) -> None:
        self.robot = robot
        self.seq = 0
        self.pub = self.make(publisher, ns, prefix, world)

    def make(self, publisher, ns: str, prefix: str, world):
        """Create the publisher and the wire template; return the publisher."""
        raise NotImplementedError

    def put(self, out, tick: Tick) -> None:
        """Queue this robot's message from ``tick`` (periodic outputs)."""
        raise NotImplementedError

    def put_reading(self, out, reading) -> None:
        """Queue the message of one reading (reading outputs)."""
        raise NotImplementedError


class OdomOut(Output):
    """``odom``: the odometry sensor's pose with the true body velocity."""

    rate = "odom"

    def make(self, publisher, ns, prefix, world):
        self.wire = OdomWire(prefix + "odom", prefix + "base_footprint")
        return publisher(ns + "/odom", Odometry, 10)

    def put(self, out, tick: Tick) -> None:
        i = self.robot
        self.seq += 1
        out.put(self.pub, self.wire.pack(self.seq, tick.secs, tick.nsecs, tick.snap.odom_pose[i],
                                         tick.snap.velocity[i]))


class ScanOut(Output):
    """``base_scan``: every scan of the robot's lidar (LaserScan in ``base_laser_link``)."""

    reads = Scan

    def make(self, publisher, ns, prefix, world):
        self.frame = prefix + "base_laser_link"
        self.wire: Optional[ScanWire] = None    # made from the first scan's geometry
        return publisher(ns + "/base_scan", LaserScan, 10)

    def put_reading(self, out, s: Scan) -> None:
        wire = self.wire
        if wire is None or wire.key != (s.angle_min, s.angle_max, s.angle_increment,
                                        s.scan_time, s.range_min, s.range_max):
            wire = self.wire = ScanWire(self.frame, s)
        self.seq += 1
        secs, nsecs = divmod(s.stamp_ns, 1_000_000_000)
        out.put(self.pub, wire.pack(self.seq, secs, nsecs, s.ranges))


class BatteryOut(Output):
    """``battery_state``: the battery sensor's state now."""

    rate = "state"

    def make(self, publisher, ns, prefix, world):
        self.wire = BatteryWire(world.specs[self.robot].battery.capacity_ah)
        return publisher(ns + "/battery_state", BatteryState, 2)

    def put(self, out, tick: Tick) -> None:
        self.seq += 1   # (the world's battery sensor now: a spawn or delete builds a new one)
        pct, volt, charge = tick.world.battery.state(self.robot, tick.now_ns)
        out.put(self.pub, self.wire.pack(self.seq, tick.secs, tick.nsecs, volt, pct, charge))


class GroundTruthOut(Output):
    """``base_pose_ground_truth``: the true pose and velocity (Odometry in ``map``)."""

    rate = "pose"

    def make(self, publisher, ns, prefix, world):
        self.wire = OdomWire("map", prefix + "base_footprint")
        return publisher(ns + "/base_pose_ground_truth", Odometry, 10)

    def put(self, out, tick: Tick) -> None:
        i = self.robot
        self.seq += 1
        out.put(self.pub, self.wire.pack(self.seq, tick.secs, tick.nsecs, tick.snap.pose[i],
                                         tick.snap.velocity[i]))


class PoseOut(Output):
    """``pose``: the true pose (PoseStamped in ``map``)."""

    rate = "pose"

    def make(self, publisher, ns, prefix, world):
        self.wire = PoseWire("map")
        return publisher(ns + "/pose", PoseStamped, 10)

    def put(self, out, tick: Tick) -> None:
        self.seq += 1
        out.put(self.pub, self.wire.pack(self.seq, tick.secs, tick.nsecs,
                                         tick.snap.pose[self.robot]))


class JointsOut(Output):
    """``joint_states``: the wheel joints' angles and speeds."""

    rate = "state"

    def make(self, publisher, ns, prefix, world):
        self.wire = JointsWire([prefix + j for j in world.models[self.robot].wheel_joints])
        return publisher(ns + "/joint_states", JointState, 10)

    def put(self, out, tick: Tick) -> None:
        i = self.robot
        self.seq += 1
        out.put(self.pub, self.wire.pack(self.seq, tick.secs, tick.nsecs,
                                         tick.snap.wheel_positions[i],
                                         tick.snap.wheel_velocities[i]))


#: The output of each sensor kind (``sim.sensors.SENSORS``) by the same name.
SENSOR_OUTPUTS: Dict[str, Type[Output]] = {
    "odometry": OdomOut,
    "laser": ScanOut,
    "battery": BatteryOut,
}

#: Every robot's outputs that are not a sensor's.
ROBOT_OUTPUTS: List[Type[Output]] = [GroundTruthOut, PoseOut, JointsOut]


def robot_outputs(publisher, ns: str, prefix: str, robot: int, world) -> List[Output]:
    """Robot ``robot``'s outputs: its sensors' (the world's kinds that have one) and the
    others, in the order they are queued within a step."""
    kinds = [SENSOR_OUTPUTS[k] for k in world.sensors if k in SENSOR_OUTPUTS]
    return [cls(publisher, ns, prefix, robot, world) for cls in kinds + ROBOT_OUTPUTS]
