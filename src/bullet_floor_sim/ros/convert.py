"""Message conversions shared by the nodes (thin: plain data in, ROS messages out)."""
from __future__ import annotations

import math

import rospy
from nav_msgs.msg import MapMetaData, OccupancyGrid

from bullet_floor_sim.core.floormap import FloorMap


def occupancy_grid(fmap: FloorMap, frame_id: str = "map",
                   stamp: rospy.Time = rospy.Time(0)) -> OccupancyGrid:
    """The map as map_server publishes it (0 free, 100 occupied, -1 unknown)."""
    info = MapMetaData()
    info.map_load_time = stamp
    info.resolution = fmap.resolution
    info.width, info.height = fmap.width, fmap.height
    info.origin.position.x, info.origin.position.y = fmap.origin[0], fmap.origin[1]
    yaw = fmap.origin[2]
    info.origin.orientation.z, info.origin.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    grid = OccupancyGrid()
    grid.header.frame_id = frame_id
    grid.header.stamp = stamp
    grid.info = info
    grid.data = fmap.grid.ravel().tolist()
    return grid
