"""The follower node: the observer robot keeps the tracked entity in view at a set distance.

Run it in the observing robot's namespace. It picks one track of ``tracks`` (people_tracker's
``track_list``) and keeps following that id while it lives, sends goals to the robot's
``move_base`` action (stock move_base or the embedded path_follower: the same interface) at a
stand-off point ``~distance`` metres from the target, facing it, re-planned as the track moves;
when the track is lost for ``~lost_after`` seconds it goes to where the predictor says the
target is heading (``destination``: the best region's point nearest the track), looks round
there, and goes on to the next likely regions of ``destination``'s ``points`` in turn
(``~search_regions``, ``~search_min_probability``), then to the others once each.
people/agents.FollowerAgent (people/follow.py) makes the decisions, as in the evaluation.

Topics: ``tracks`` (in, bullet_floor_sim/TrackArray), ``destination`` (in,
bullet_floor_sim/Destination), ``base_pose_ground_truth`` (in, with ``~pose_source``
ground_truth), ``~mode`` (std_msgs/String, latched: follow | give_way | search | patrol | idle, on change),
``~target`` (geometry_msgs/PointStamped: the followed track's position), ``~target_id``
(std_msgs/UInt32, latched: the followed track's id, on change; destination_predictor takes a
new id for the target it replaces and hands that target's leg over to it).

Parameters: ``~pose_source`` (amcl: tf ``<global_frame> -> <base_frame>``; ground_truth),
``~global_frame`` (map), ``~base_frame`` (base_footprint, prefixed by the tf_prefix of the
namespace's robot, e.g. ``robot2/base_footprint``), ``~action`` (move_base), ``~rate`` (5 Hz),
``~map_topic`` (/map), ``~robot_radius`` (0.34) and the FollowConfig fields as ``~<field>``
(``~distance`` 1.5, ``~lost_after`` 2.0, ...).
"""
from __future__ import annotations

import math
import sys
import threading
from collections import namedtuple
from typing import Optional, Sequence

import actionlib
import rospy
import tf2_ros
from actionlib.action_client import CommState
from geometry_msgs.msg import PointStamped
from move_base_msgs.msg import MoveBaseAction
from nav_msgs.msg import OccupancyGrid, Odometry
from std_msgs.msg import String, UInt32

from ..errors import BulletFloorSimError
from ..people.agents import FollowerAgent
from ..people.follow import FollowBehaviour, FollowConfig
from ..people.search import SearchPlan, likely_count
from ..nav.planner import PlannerConfig, PlanningGrid
from ..msg import Destination, TrackArray
from .params import config_from_params, map_handling
from .convert import grid_from_msg, move_base_goal, planar, yaw as yaw_of
from .node import StartupGrace, quiet_at_shutdown, run_node

__all__ = ["main", "FollowerNode"]

_Tr = namedtuple("_Tr", "id x y vx vy")




def plan_of(msg: Destination, config: FollowConfig) -> SearchPlan:
    """The search plan of a Destination message: its regions' points, most likely first,
    the likely ones those of ``config.search_regions`` and ``search_min_probability``
    (people/search.likely_count); the best point alone when it has no points."""
    pairs = [(r, (pt.x, pt.y)) for r, pt in zip(msg.regions, msg.points)]
    if not pairs:
        return SearchPlan([(msg.best, (msg.best_point.x, msg.best_point.y))])
    return SearchPlan(pairs, likely_count(msg.probabilities, config.search_regions,
                                          config.search_min_probability))

class FollowerNode:
    """Tracks and destinations in, move_base goals out."""

    def __init__(self) -> None:
        gp = rospy.get_param
        self.source = str(gp("~pose_source", "amcl"))
        if self.source not in ("amcl", "ground_truth"):
            raise BulletFloorSimError("follower: ~pose_source must be amcl or ground_truth, "
                                      "got %r" % self.source)
        self.frame = str(gp("~global_frame", "map"))
        self.base_frame = str(gp("~base_frame", "base_footprint"))
        self.config = config_from_params(FollowConfig())
        self.planner_cfg = PlannerConfig(robot_radius=float(gp("~robot_radius", PlannerConfig.robot_radius)))
        self.rate = float(gp("~rate", 5.0))
        self.lock = threading.Lock()
        self.agent: Optional[FollowerAgent] = None
        self.tracks = []
        self.tracks_t = -math.inf
        self.destinations = {}      # track id -> SearchPlan (plan_of): most likely first
        self.gt = None
        self.mode = ""
        self.goal_handle = None   # the last goal sent (actionlib ClientGoalHandle)
        self.startup = StartupGrace()   # (no pose before the first transforms arrive)
        self.tf_buffer = tf2_ros.Buffer()
        # located from ground truth, the follower needs no tf (a listener reads every /tf)
        self.tf_listener = None if self.source == "ground_truth" else \
            tf2_ros.TransformListener(self.tf_buffer)
        self.mode_pub = rospy.Publisher("~mode", String, queue_size=1, latch=True)
        self.target_pub = rospy.Publisher("~target", PointStamped, queue_size=2)
        self.target_id_pub = rospy.Publisher("~target_id", UInt32, queue_size=1, latch=True)
        # The plain ActionClient, polled (as markov_walker's): SimpleActionClient logs "Got a
        # transition callback on a goal handle that we're not tracking" at ERROR when the
        # server's status of a goal it replaced arrives after the next send_goal.
        self.client = actionlib.ActionClient(str(gp("~action", "move_base")), MoveBaseAction)
        rospy.Subscriber(str(gp("~map_topic", "/map")), OccupancyGrid, self._on_map,
                         queue_size=1)
        rospy.Subscriber("tracks", TrackArray, self._on_tracks, queue_size=2)
        rospy.Subscriber("destination", Destination, self._on_destination, queue_size=5)
        if self.source == "ground_truth":
            rospy.Subscriber("base_pose_ground_truth", Odometry, self._on_gt, queue_size=1)

    def _on_map(self, msg: OccupancyGrid) -> None:
        try:
            grid = PlanningGrid(grid_from_msg(msg), self.planner_cfg, handling=map_handling())
        except BulletFloorSimError as e:
            rospy.logerr("follower: cannot use the map: %s", e)
            return
        with self.lock:
            agent = FollowerAgent(FollowBehaviour(grid, self.config))
            if self.agent is not None:   # a new map: the same target and its search plan
                agent.target_id, agent.destination = self.agent.target_id, self.agent.destination
            self.agent = agent

    def _on_gt(self, msg: Odometry) -> None:
        p = msg.pose.pose
        self.gt = (p.position.x, p.position.y, yaw_of(p.orientation))

    @quiet_at_shutdown
    def _on_tracks(self, msg: TrackArray) -> None:
        with self.lock:
            self.tracks = [_Tr(t.id, t.position.x, t.position.y, t.velocity.x, t.velocity.y)
                           for t in msg.tracks]
            self.tracks_t = msg.header.stamp.to_sec()
            live = {t.id for t in msg.tracks}
            self.destinations = {k: v for k, v in self.destinations.items() if k in live}

    @quiet_at_shutdown
    def _on_destination(self, msg: Destination) -> None:
        if not msg.best:
            return
        with self.lock:
            self.destinations[msg.track_id] = plan_of(msg, self.config)

    def _pose(self):
        if self.source == "ground_truth":
            return self.gt
        try:
            t = self.tf_buffer.lookup_transform(self.frame, self.base_frame, rospy.Time(0),
                                                rospy.Duration(0.1))
        except tf2_ros.TransformException as e:
            self.startup.log("pose", 10.0, "follower: no pose (tf %s -> %s): %s", self.frame,
                             self.base_frame, e)
            return None
        return planar(t.transform)

    def step(self) -> None:
        pose = self._pose()
        with self.lock:
            if self.agent is None or pose is None:
                return
            now = rospy.get_time()
            tracks = self.tracks if now - self.tracks_t < 1.0 else []
            gh = self.goal_handle
            done = gh is not None and gh.get_comm_state() == CommState.DONE
            step = self.agent.tick(now, pose, tracks, self.destinations, done)
        target, dec = step.target, step.decision
        if step.new:
            rospy.loginfo("follower: following track %d", target.id)
            self.target_id_pub.publish(UInt32(target.id))
        if dec.mode != self.mode:
            self.mode = dec.mode
            self.mode_pub.publish(String(dec.mode))
            rospy.loginfo("follower: %s%s", dec.mode, ": " + dec.reason if dec.reason else "")
        if target is not None:
            pt = PointStamped()
            pt.header.stamp, pt.header.frame_id = rospy.Time.now(), self.frame
            pt.point.x, pt.point.y = target.x, target.y
            self.target_pub.publish(pt)
        if dec.goal is not None:
            self.goal_handle = self.client.send_goal(
                move_base_goal(dec.goal[0], dec.goal[1], dec.goal[2], self.frame))

    def run(self) -> None:
        while not rospy.is_shutdown() and not self.client.wait_for_server(rospy.Duration(5.0)):
            rospy.logwarn("follower: waiting for the %s action server",
                          rospy.resolve_name("move_base"))
        rate = rospy.Rate(self.rate)
        while not rospy.is_shutdown():
            self.step()
            try:
                rate.sleep()
            except rospy.ROSTimeMovedBackwardsException:   # (a ROSInterruptException too)
                pass
            except rospy.ROSInterruptException:
                break
        if self.goal_handle is not None:
            self.client.cancel_all_goals()


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim follower``."""
    return run_node("follower", FollowerNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
