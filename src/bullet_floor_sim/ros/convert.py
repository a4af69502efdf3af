"""Message conversions shared by the nodes (thin: plain data in, ROS messages out)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import rospy
from nav_msgs.msg import MapMetaData, OccupancyGrid

from bullet_floor_sim.core.floormap import FloorMap, map_from_grid


def yaw(q: Any) -> float:
    """Yaw (rad) of a geometry_msgs/Quaternion."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def grid_from_msg(msg: OccupancyGrid) -> FloorMap:
    """FloorMap of a nav_msgs/OccupancyGrid (row 0 = bottom, as map_server publishes)."""
    info = msg.info
    grid = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
    return map_from_grid(grid, info.resolution,
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
