"""The observer's detector/tracker node: moving entities in one robot's lidar, as tracks.

Run it in the observing robot's namespace (``<group ns="robot2">``). On every ``base_scan`` it
places the scan in the map frame with the robot's localised pose, drops the points the static
map explains, clusters the rest, keeps clusters of person/robot size and tracks them with a
constant-velocity Kalman filter (gating, global nearest-neighbour association, birth after a
few hits, death after ``max_age`` unseen): people/agents.TrackerAgent (people/tracking), the
object the evaluation drives too. No ground truth of the tracked entity is used.

Pose source (``~pose_source``):

* ``amcl`` (default with stock navigation): tf ``<global_frame> -> <laser frame>`` at the scan's
  stamp (amcl's map -> odom composed with the simulator's odom -> base_footprint).
* ``ground_truth``: the robot's ``base_pose_ground_truth`` (nav_msgs/Odometry in the map frame)
  at the scan's stamp (the simulator stamps both from the same step; between two poses it is
  interpolated, and a scan newer than the newest pose waits up to 0.5 s for it), composed with
  the static base -> laser transform (tf, looked up once). A scan with no pose at its stamp is
  skipped, never placed with another pose: that smears walls into false tracks.

Topics (``~`` = ``people_tracker/``): ``base_scan`` (in), ``base_pose_ground_truth`` (in, for
``ground_truth``), ``~tracks`` (geometry_msgs/PoseArray, map frame, orientation = heading),
``~track_list`` (bullet_floor_sim/TrackArray: id, position, velocity, covariance per track),
``~markers`` (visualization_msgs/MarkerArray: a cylinder, an id label and a velocity arrow
per track). The map comes from ``~map_topic`` (``/map``, latched).

Parameters: ``~pose_source`` (amcl | ground_truth), ``~global_frame`` (map), ``~map_topic``,
and the people/tracking.py TrackerConfig fields as ``~<field>`` (e.g. ``~max_age``).
"""
from __future__ import annotations

import math
import sys
import threading
from typing import List, Optional, Sequence

import rospy
import tf2_ros
from geometry_msgs.msg import Point, Pose, PoseArray, Vector3
from nav_msgs.msg import OccupancyGrid, Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..errors import BulletFloorSimError
from ..people.agents import TrackerAgent
from ..people.tracking import PoseHistory, StaticMap, TrackerConfig
from ..msg import Track as TrackMsg
from ..msg import TrackArray
from .params import config_from_params, map_handling
from .convert import grid_from_msg, planar, yaw as yaw_of
from .node import StartupGrace, TfOnDemand, quiet_at_shutdown, run_node

__all__ = ["main", "PeopleTrackerNode", "POSE_SOURCES"]

POSE_SOURCES = ("amcl", "ground_truth")



class PeopleTrackerNode:
    """Scan in, tracks out; the detection and tracking live in people/tracking.py."""

    def __init__(self) -> None:
        gp = rospy.get_param
        self.source = str(gp("~pose_source", "amcl"))
        if self.source not in POSE_SOURCES:
            raise BulletFloorSimError("people_tracker: ~pose_source must be one of %s, got %r"
                                      % (" | ".join(POSE_SOURCES), self.source))
        self.frame = str(gp("~global_frame", "map"))
        self.config = config_from_params(TrackerConfig())
        self.agent: Optional[TrackerAgent] = None   # made when the map arrives
        self.gt = PoseHistory()   # base_footprint in the map, by stamp
        self.gt_cond = threading.Condition()
        self.base_frame = ""
        self.laser_in_base = {}   # laser frame -> (x, y, yaw)
        self.lock = threading.Lock()
        # the first scans may come before the map, a pose or the laser's static transform
        self.startup = StartupGrace()
        self.tf = TfOnDemand()
        self.tf_buffer = self.tf.buffer
        self.pose_pub = rospy.Publisher("~tracks", PoseArray, queue_size=5)
        self.list_pub = rospy.Publisher("~track_list", TrackArray, queue_size=5)
        self.marker_pub = rospy.Publisher("~markers", MarkerArray, queue_size=2)
        rospy.Subscriber(str(gp("~map_topic", "/map")), OccupancyGrid, self._on_map,
                         queue_size=1)
        if self.source == "ground_truth":
            rospy.Subscriber("base_pose_ground_truth", Odometry, self._on_gt, queue_size=20)
        rospy.Subscriber("base_scan", LaserScan, self._on_scan, queue_size=1)
        rospy.loginfo("people_tracker: tracking in %s (pose from %s)",
                      rospy.resolve_name("base_scan"), self.source)

    def _on_map(self, msg: OccupancyGrid) -> None:
        try:
            static = StaticMap(grid_from_msg(msg), self.config.static_tolerance,
                               handling=map_handling())
        except BulletFloorSimError as e:
            rospy.logerr("people_tracker: cannot use the map: %s", e)
            return
        with self.lock:
            if self.agent is None:
                self.agent = TrackerAgent(static, self.config)
            else:   # a new map: the tracks go on
                self.agent.static = static
        rospy.loginfo("people_tracker: map %dx%d at %.3f m", msg.info.width, msg.info.height,
                      msg.info.resolution)

    def _on_gt(self, msg: Odometry) -> None:
        p = msg.pose.pose
        with self.gt_cond:
            self.base_frame = msg.child_frame_id
            self.gt.add(msg.header.stamp.to_sec(), p.position.x, p.position.y,
                        yaw_of(p.orientation))
            self.gt_cond.notify_all()

    def _gt_at(self, stamp) -> Optional[tuple]:
        """The ground-truth pose at ``stamp`` (waiting up to 0.5 s wall for it), or None."""
        t = stamp.to_sec()
        with self.gt_cond:
            self.gt_cond.wait_for(lambda: (self.gt.latest is not None and self.gt.latest >= t)
                                  or rospy.is_shutdown(), timeout=0.5)
            return self.gt.at(t)

    def _laser_pose(self, msg: LaserScan):
        """(x, y, yaw) of the scan's frame in the global frame, or None (logged)."""
        frame = msg.header.frame_id
        try:
            if self.source == "amcl":
                t = self.tf_buffer.lookup_transform(self.frame, frame, msg.header.stamp,
                                                    rospy.Duration(0.2))
                return planar(t.transform)
            base = self._gt_at(msg.header.stamp)
            if base is None:
                self.startup.log("pose", 10.0, "people_tracker: no base_pose_ground_truth at "
                                 "the scan's stamp %.3f (newest %s); scan skipped",
                                 msg.header.stamp.to_sec(), self.gt.latest)
                return None
            off = self.laser_in_base.get(frame)
            if off is None:
                self.tf.listen()         # a laser frame not seen before
                t = self.tf_buffer.lookup_transform(self.base_frame, frame, rospy.Time(0),
                                                    rospy.Duration(0.5))
                off = planar(t.transform)
                self.laser_in_base[frame] = off
                self.tf.stop()           # placed from ground truth: no more tf needed
        except tf2_ros.TransformException as e:
            self.startup.log(("tf", frame), 10.0, "people_tracker: no transform %s -> %s: %s",
                             self.frame if self.source == "amcl" else self.base_frame, frame,
                             e)
            return None
        x, y, yaw = base
        c, s = math.cos(yaw), math.sin(yaw)
        return x + c * off[0] - s * off[1], y + s * off[0] + c * off[1], yaw + off[2]

    @quiet_at_shutdown
    def _on_scan(self, msg: LaserScan) -> None:
        if self.agent is None:
            self.startup.log("map", 10.0, "people_tracker: waiting for the map")
            return
        pose = self._laser_pose(msg)
        if pose is None:
            return
        with self.lock:
            step = self.agent.tick(msg.header.stamp.to_sec(), msg, pose)
        if step.restarted:   # time went backwards (a bag loop, sim reset)
            rospy.logwarn("people_tracker: %s; starting afresh", step.restarted)
            return
        self._publish(step.tracks, msg.header.stamp)

    def _publish(self, tracks: Sequence, stamp) -> None:
        pa = PoseArray()
        pa.header.stamp, pa.header.frame_id = stamp, self.frame
        ta = TrackArray()
        ta.header = pa.header
        markers = MarkerArray()
        clear = Marker()
        clear.action = Marker.DELETEALL
        markers.markers.append(clear)
        for tr in tracks:
            heading = math.atan2(tr.vy, tr.vx)
            pose = Pose()
            pose.position = Point(tr.x, tr.y, 0.0)
            pose.orientation.z, pose.orientation.w = math.sin(heading / 2), math.cos(heading / 2)
            pa.poses.append(pose)
            m = TrackMsg()
            m.id = tr.id
            m.position = Point(tr.x, tr.y, 0.0)
            m.velocity = Vector3(tr.vx, tr.vy, 0.0)
            m.covariance = [float(v) for v in tr.cov.reshape(-1)]
            m.hits = tr.hits
            m.first_seen = rospy.Time.from_sec(tr.born)
            m.last_seen = rospy.Time.from_sec(tr.last_seen)
            ta.tracks.append(m)
            markers.markers += self._markers(tr, stamp)
        self.pose_pub.publish(pa)
        self.list_pub.publish(ta)
        self.marker_pub.publish(markers)

    def _markers(self, tr, stamp) -> List[Marker]:
        out = []
        for k, kind in enumerate((Marker.CYLINDER, Marker.TEXT_VIEW_FACING, Marker.ARROW)):
            m = Marker()
            m.header.stamp, m.header.frame_id = stamp, self.frame
            m.ns, m.id, m.type, m.action = "tracks", 3 * tr.id + k, kind, Marker.ADD
            m.pose.orientation.w = 1.0
            m.color = ColorRGBA(1.0, 0.4, 0.0, 0.6)
            m.lifetime = rospy.Duration(1.0)
            if kind == Marker.CYLINDER:
                m.pose.position = Point(tr.x, tr.y, 0.5)
                m.scale = Vector3(0.6, 0.6, 1.0)
            elif kind == Marker.TEXT_VIEW_FACING:
                m.pose.position = Point(tr.x, tr.y, 1.3)
                m.scale.z = 0.35
                m.color = ColorRGBA(1.0, 1.0, 1.0, 1.0)
                m.text = "track %d" % tr.id
            else:
                m.points = [Point(tr.x, tr.y, 0.5), Point(tr.x + tr.vx, tr.y + tr.vy, 0.5)]
                m.scale = Vector3(0.08, 0.16, 0.2)
            out.append(m)
        return out


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim people_tracker``."""
    return run_node("people_tracker", PeopleTrackerNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
