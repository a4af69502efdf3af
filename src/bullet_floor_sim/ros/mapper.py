"""The embedded mapper: a map from one robot's scans where no SLAM package is installed
(mapping.launch's ``slam:=embedded``; mapping/occupancy.py).

Each scan (``scan``, sensor_msgs/LaserScan) comes with the laser's pose in ``~odom_frame``
at the scan's stamp (tf). Once the robot has moved ``~linearUpdate`` metres or turned
``~angularUpdate`` radians since the last scan taken, the scan is matched against the map so
far and added at the matched pose (mapping/slam.py: the robot's estimated pose is odometry
corrected by scan matching; ``~match`` false: odometry alone). The node broadcasts the
correction, ``~map_frame`` -> ``~odom_frame``, on /tf every ``~transform_publish_period``
seconds (stamped that far ahead, as gmapping does), and serves the map as gmapping does:
``map`` (nav_msgs/OccupancyGrid, latched) and ``map_metadata`` every
``~map_update_interval`` seconds of sim time, and the ``dynamic_map`` service
(nav_msgs/GetMap). The map frame is where odometry started.

Parameters (gmapping's names where gmapping has one): ``~map_frame`` (map), ``~odom_frame``
(odom), ``~delta`` (0.05 m, the cell size), ``~map_update_interval`` (5 s),
``~linearUpdate`` (0.25 m), ``~angularUpdate`` (0.25 rad), ``~sigma`` (0.05 m, the scan
matcher's likelihood field), ``~match`` (true), ``~transform_publish_period`` (0.05 s),
``~trace_range`` (12 m: free space is traced that far along a beam).
"""
from __future__ import annotations

import math
import sys
import threading
from dataclasses import dataclass
from typing import Optional, Sequence

import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import MapMetaData, OccupancyGrid
from nav_msgs.srv import GetMap, GetMapResponse
from sensor_msgs.msg import LaserScan

from ..errors import BulletFloorSimError
from ..mapping.matcher import MatcherConfig
from ..mapping.occupancy import MapperConfig
from ..mapping.slam import ScanMatchingMapper, SlamConfig
from .convert import occupancy_grid, planar
from .node import quiet_at_shutdown, run_node
from .params import check_params, config_from_params

__all__ = ["main", "MapperParams"]


@dataclass
class MapperParams:
    """The node's parameters (see the module doc)."""

    map_frame: str = "map"
    odom_frame: str = "odom"
    delta: float = 0.05
    map_update_interval: float = 5.0
    linear_update: float = SlamConfig.linear_update
    angular_update: float = SlamConfig.angular_update
    sigma: float = MatcherConfig.sigma
    match: bool = True
    transform_publish_period: float = 0.05
    trace_range: float = 12.0

    def check(self) -> None:
        check_params(self, "mapper", ("delta", "map_update_interval", "sigma",
                                      "transform_publish_period", "trace_range"))
        for field, name in GMAPPING_NAMES.items():
            v = getattr(self, field)
            if not (math.isfinite(v) and v >= 0):
                raise BulletFloorSimError("mapper: ~%s must be a finite number >= 0, got %r"
                                          % (name, v))


#: gmapping's parameter names for our fields
GMAPPING_NAMES = {"linear_update": "linearUpdate", "angular_update": "angularUpdate"}


class MapperNode:
    """Scans in, the map out (see the module doc)."""

    def __init__(self) -> None:
        p = self.params = config_from_params(MapperParams(), names=GMAPPING_NAMES)
        self.slam = ScanMatchingMapper(
            SlamConfig(linear_update=p.linear_update, angular_update=p.angular_update,
                       match=p.match),
            MapperConfig(resolution=p.delta, trace_range=p.trace_range),
            MatcherConfig(sigma=p.sigma))
        self.lock = threading.Lock()
        self.tf = tf2_ros.Buffer(rospy.Duration(30.0))
        self.listener = tf2_ros.TransformListener(self.tf)
        self.broadcaster = tf2_ros.TransformBroadcaster()
        self.map_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub = rospy.Publisher("map_metadata", MapMetaData, queue_size=1, latch=True)
        self.service = rospy.Service("dynamic_map", GetMap, self._on_get_map)
        self.sub = rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=5)
        self.timer = rospy.Timer(rospy.Duration(p.map_update_interval), self._publish,
                                 reset=True)
        self.sent = rospy.Time(0)
        self.tf_timer = rospy.Timer(rospy.Duration(p.transform_publish_period),
                                    self._broadcast, reset=True)
        self.skipped = 0
        rospy.loginfo("mapper: the embedded mapper (no SLAM package installed: %s) maps %s at "
                      "%.3f m/cell and broadcasts %s -> %s",
                      "odometry corrected by scan matching" if p.match
                      else "odometry poses, no scan matching", rospy.resolve_name("scan"),
                      p.delta, p.map_frame, p.odom_frame)

    def _laser_pose(self, msg: LaserScan) -> Optional[Sequence[float]]:
        try:
            t = self.tf.lookup_transform(self.params.odom_frame, msg.header.frame_id,
                                         msg.header.stamp, rospy.Duration(0.2))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                tf2_ros.ExtrapolationException) as e:
            self.skipped += 1
            rospy.logwarn_throttle(10.0, "mapper: no pose for a scan (%s); %d skipped", e,
                                   self.skipped)
            return None
        return planar(t.transform)

    def _on_scan(self, msg: LaserScan) -> None:
        pose = self._laser_pose(msg)
        if pose is None:
            return
        args = (msg.ranges, msg.angle_min, msg.angle_increment, msg.range_max)
        # matching reads the map only and this callback is its only writer: the lock (which
        # the map's readers and the tf broadcast take) is held for the update alone
        placed = self.slam.place(pose, *args)
        if placed is not None:
            with self.lock:
                self.slam.commit(pose, placed, *args)

    def _grid(self) -> Optional[OccupancyGrid]:
        with self.lock:
            if self.slam.mapper is None:
                return None
            fmap = self.slam.mapper.floor_map()
        return occupancy_grid(fmap, self.params.map_frame, rospy.Time.now())

    @quiet_at_shutdown
    def _publish(self, _event=None) -> None:
        grid = self._grid()
        if grid is not None:
            self.map_pub.publish(grid)
            self.meta_pub.publish(grid.info)

    def _on_get_map(self, _req) -> GetMapResponse:
        grid = self._grid()
        if grid is None:
            raise rospy.ServiceException("mapper: no scan mapped yet")
        return GetMapResponse(map=grid)

    @quiet_at_shutdown
    def _broadcast(self, _event=None) -> None:
        """map -> odom, the correction, stamped one period ahead (as gmapping's tf_delay)."""
        stamp = rospy.Time.now() + rospy.Duration(self.params.transform_publish_period)
        if stamp <= self.sent:           # the timer catching up (rtf > 1): once per stamp
            return
        self.sent = stamp
        with self.lock:
            x, y, th = self.slam.correction
        t = TransformStamped()
        t.header.stamp = stamp
        t.header.frame_id, t.child_frame_id = self.params.map_frame, self.params.odom_frame
        t.transform.translation.x, t.transform.translation.y = x, y
        t.transform.rotation.z, t.transform.rotation.w = math.sin(th / 2), math.cos(th / 2)
        self.broadcaster.sendTransform(t)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim mapper``."""
    return run_node("mapper", MapperNode, argv, errors=(BulletFloorSimError, ValueError))


if __name__ == "__main__":
    sys.exit(main())
