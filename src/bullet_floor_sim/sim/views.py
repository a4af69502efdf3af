"""What the world tells about its robots, in plain numbers (the ROS glue makes messages of it)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Tuple

__all__ = ["RobotView", "Snapshot"]


@dataclass(frozen=True)
class RobotView:
    """A snapshot of one robot, in plain numbers (ROS glue turns it into messages).

    Attributes:
        pose: ground truth (x, y, yaw) in the map frame.
        velocity: applied body velocity (vx, vy, w).
        odom_pose: odometry (x, y, yaw) in the robot's odom frame.
        wheel_positions: (left, right) wheel angles, radians.
        wheel_velocities: (left, right) wheel speeds, rad/s.
        stalled: the last step's move was refused by a collision.
    """

    pose: Tuple[float, float, float]
    velocity: Tuple[float, float, float]
    odom_pose: Tuple[float, float, float]
    wheel_positions: Tuple[float, float]
    wheel_velocities: Tuple[float, float]
    stalled: bool


@dataclass(frozen=True)
class Snapshot:
    """Every robot at once: one row of plain floats per robot (what a publisher packs).

    Attributes:
        pose: N rows (x, y, yaw) of ground truth, yaw in [-pi, pi).
        velocity: N rows (vx, vy, w) of applied body velocity.
        odom_pose: N rows (x, y, yaw) of odometry in each robot's odom frame.
        wheel_positions: N rows (left, right) of wheel angles, radians (None if not asked for).
        wheel_velocities: N rows (left, right) of wheel speeds, rad/s (None if not asked for).
    """

    pose: List[Tuple[float, float, float]]
    velocity: List[List[float]]
    odom_pose: List[List[float]]
    wheel_positions: Optional[List[Tuple[float, float]]]
    wheel_velocities: Optional[List[Tuple[float, float]]]
