"""Message conversions shared by the nodes (thin: plain data in, ROS messages out)."""
from __future__ import annotations

import math
from typing import Any, List, Sequence, Tuple

import numpy as np
import rospy
from geometry_msgs.msg import Point, Pose, PoseStamped, Quaternion
from move_base_msgs.msg import MoveBaseGoal
from nav_msgs.msg import MapMetaData, OccupancyGrid
from std_msgs.msg import Header

from ..data.trajectory import Chunk
from ..msg import Trajectory
from ..sim.floormap import FloorMap, map_from_grid

_NS = 1000000000


def yaw(q: Any) -> float:
    """Yaw (rad) of a geometry_msgs/Quaternion."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def planar(t: Any) -> Tuple[float, float, float]:
    """(x, y, yaw) of a geometry_msgs/Transform (a TransformStamped's ``transform``)."""
    return t.translation.x, t.translation.y, yaw(t.rotation)


def move_base_goal(x: float, y: float, heading: float, frame_id: str) -> MoveBaseGoal:
    """A move_base goal at (x, y) facing ``heading`` in ``frame_id``, stamped now."""
    g = MoveBaseGoal()
    g.target_pose.header.frame_id = frame_id
    g.target_pose.header.stamp = rospy.Time.now()
    g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, y
    g.target_pose.pose.orientation.z = math.sin(heading / 2.0)
    g.target_pose.pose.orientation.w = math.cos(heading / 2.0)
    return g


def grid_from_msg(msg: OccupancyGrid) -> FloorMap:
    """FloorMap of a nav_msgs/OccupancyGrid (row 0 = bottom, as map_server publishes).

    The resolution travels as a float32: 0.05 arrives as 0.0500000007. It is read back as the
    shortest decimal that float32 holds (0.05), the value the map's YAML gave: otherwise a
    length in cells (a 0.15 m gap to close: 2.99999996 cells) rounds down, and a map from the
    topic is handled differently from the same map from its file."""
    info = msg.info
    grid = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
    return map_from_grid(grid, float(str(np.float32(info.resolution))),
                         (info.origin.position.x, info.origin.position.y,
                          yaw(info.origin.orientation)))


def occupancy_grid(fmap: FloorMap, frame_id: str = "map",
                   stamp: rospy.Time = rospy.Time(0)) -> OccupancyGrid:
    """The map as map_server publishes it (0 free, 100 occupied, -1 unknown)."""
    info = MapMetaData()
    info.map_load_time = stamp
    info.resolution = fmap.resolution
    info.width, info.height = fmap.width, fmap.height
    info.origin.position.x, info.origin.position.y = fmap.origin[0], fmap.origin[1]
    a = fmap.origin[2]
    info.origin.orientation.z, info.origin.orientation.w = math.sin(a / 2), math.cos(a / 2)
    grid = OccupancyGrid()
    grid.header.frame_id = frame_id
    grid.header.stamp = stamp
    grid.info = info
    grid.data = fmap.grid.ravel().tolist()
    return grid


def pose_of_msg(msg: PoseStamped):
    """A PoseStamped as data/trajectory's pose tuple (t_ns, x, y, z, qx, qy, qz, qw)."""
    s = msg.header.stamp
    p = msg.pose.position
    q = msg.pose.orientation
    return (s.secs * _NS + s.nsecs, p.x, p.y, p.z, q.x, q.y, q.z, q.w)


def people_poses(msg):
    """A people_msgs/People as (name, pose tuple) per person: the message's stamp, the
    position, and the heading of the velocity when the person moves (else none: identity)."""
    s = msg.header.stamp
    t_ns = s.secs * _NS + s.nsecs
    out = []
    for p in msg.people:
        v = p.velocity
        qz, qw = 0.0, 1.0
        if math.hypot(v.x, v.y) > 0.1:
            yaw = math.atan2(v.y, v.x)
            qz, qw = math.sin(0.5 * yaw), math.cos(0.5 * yaw)
        out.append((p.name, (t_ns, p.position.x, p.position.y, p.position.z, 0.0, 0.0, qz, qw)))
    return out


def _time(t_ns: int) -> rospy.Time:
    secs, nsecs = divmod(int(t_ns), _NS)
    return rospy.Time(secs, nsecs)


def pose_msgs(poses: Sequence, frame_id: str) -> List[PoseStamped]:
    """Pose tuples as PoseStamped messages."""
    out = []
    for t, x, y, z, qx, qy, qz, qw in poses:
        out.append(PoseStamped(Header(0, _time(t), frame_id),
                               Pose(Point(x, y, z), Quaternion(qx, qy, qz, qw))))
    return out


def chunk_to_msg(chunk: Chunk, stamp: rospy.Time, seq: int = 0):
    """A chunk as a bullet_floor_sim/Trajectory message (human_trajectory's fields)."""
    return Trajectory(header=Header(seq, stamp, chunk.frame_id), uuid=chunk.uuid,
                      trajectory=pose_msgs(chunk.poses, chunk.frame_id), robot=[],
                      start_time=_time(chunk.start_ns), end_time=_time(chunk.end_ns),
                      trajectory_length=chunk.trajectory_length, complete=chunk.complete,
                      sequence_id=chunk.sequence_id,
                      trajectory_displacement=chunk.trajectory_displacement,
                      displacement_pose_ratio=chunk.displacement_pose_ratio)
