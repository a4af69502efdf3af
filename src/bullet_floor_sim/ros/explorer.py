"""Frontier exploration through move_base (mapping.launch's ``explore:=true``).

The node reads the map being built (the ``dynamic_map`` service, nav_msgs/GetMap, where the
mapper serves it, else the ``map`` topic: the embedded mapper's or a SLAM package's), picks
the nearest reachable frontier (mapping/frontiers.py) from the robot's pose (tf
``~global_frame`` -> ``~base_frame``) and sends it to ``move_base``
(move_base_msgs/MoveBaseAction: the embedded path follower or stock move_base, either with
unknown space passable). A goal's place is ruled out once it is sent (reached or not, it is
done with). By default the next goal is picked once the last has ended, on the map as it is
then, from where the robot stands (0.15-0.34 s of wall time on office's map). With
``~lookahead`` > 0, it is picked once the robot is within that distance of its goal, on the
map as it is then, as if from the goal, and goes out the moment the goal is reached (a goal
not reached is followed by a pick from where the robot stands): the robot does not stand,
but the pick misses what the robot sees on its last metres and at the goal, and in one
process office took 300-480 s instead of 180-240 s to reach the map explore.test asks for
(docs/mapping.md, session 49). When no reachable frontier is left on a map built after the
last goal ended (or ``~finish_wait`` seconds after it: gmapping builds no new map while the
robot stands still), it logs so, publishes ``~finished`` (std_msgs/Bool, latched) true and
sends no more goals.

Parameters: ``~global_frame`` (map), ``~base_frame`` (base_footprint), ``~robot_radius``
(0.34), ``~min_frontier`` (0.75 m), ``~reach`` (1.0 m), ``~blacklist_radius`` (0.5 m),
``~min_distance`` (0.5 m), ``~view_range`` (2.0 m; 0: off), ``~view_angle`` (1.40 rad)
(ExplorerConfig's), ``~lookahead`` (0 m: pick the next goal once
the last has ended), ``~goal_timeout`` (120 s of sim time: a goal not ended by then is
cancelled), ``~finish_wait`` (10 s).
"""
from __future__ import annotations

import math
import sys
import threading
import time
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import actionlib
from actionlib import CommState
import rospy
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseAction
from nav_msgs.msg import OccupancyGrid
from nav_msgs.srv import GetMap
from std_msgs.msg import Bool

from ..mapping.frontiers import Explorer, ExplorerConfig
from .convert import grid_from_msg, move_base_goal, planar
from .node import run_node
from .params import check_params, config_from_params

__all__ = ["main", "ExplorerParams"]

_DONE = {GoalStatus.SUCCEEDED: "reached", GoalStatus.ABORTED: "aborted",
         GoalStatus.REJECTED: "rejected", GoalStatus.PREEMPTED: "preempted",
         GoalStatus.RECALLED: "recalled", GoalStatus.LOST: "lost"}


@dataclass
class ExplorerParams:
    """The node's parameters (see the module doc)."""

    global_frame: str = "map"
    base_frame: str = "base_footprint"
    robot_radius: float = ExplorerConfig.robot_radius
    min_frontier: float = ExplorerConfig.min_frontier
    reach: float = ExplorerConfig.reach
    blacklist_radius: float = ExplorerConfig.blacklist_radius
    min_distance: float = ExplorerConfig.min_distance
    view_range: float = ExplorerConfig.view_range
    view_angle: float = ExplorerConfig.view_angle
    lookahead: float = 0.0
    goal_timeout: float = 120.0
    finish_wait: float = 10.0

    def check(self) -> None:
        check_params(self, "explorer", ("robot_radius", "min_frontier", "reach",
                                        "goal_timeout", "finish_wait"))
        check_params(self, "explorer", ("blacklist_radius", "min_distance", "lookahead",
                                        "view_range", "view_angle"), strict=False)


class ExplorerNode:
    """Map in, move_base goals out (see the module doc)."""

    def __init__(self) -> None:
        p = self.params = config_from_params(ExplorerParams())
        self.explorer = Explorer(ExplorerConfig(
            robot_radius=p.robot_radius, min_frontier=p.min_frontier, reach=p.reach,
            blacklist_radius=p.blacklist_radius, min_distance=p.min_distance,
            view_range=p.view_range, view_angle=p.view_angle))
        self.map: Optional[OccupancyGrid] = None
        self.lock = threading.Lock()
        self.tf = tf2_ros.Buffer()
        self.listener = tf2_ros.TransformListener(self.tf)
        self.finished_pub = rospy.Publisher("~finished", Bool, queue_size=1, latch=True)
        self.finished_pub.publish(Bool(False))
        rospy.Subscriber("map", OccupancyGrid, self._on_map, queue_size=1)
        self.client = actionlib.ActionClient("move_base", MoveBaseAction)
        self.goals = self.failed = 0
        self.pick_wall = 0.0      # wall seconds the last pick took (fetch and search)
        self.dynamic_map: Optional[rospy.ServiceProxy] = None
        try:
            rospy.wait_for_service("dynamic_map", timeout=10.0)
            self.dynamic_map = rospy.ServiceProxy("dynamic_map", GetMap)
        except rospy.ROSException:
            rospy.loginfo("explorer: no %s service: goals are picked on %s",
                          rospy.resolve_name("dynamic_map"), rospy.resolve_name("map"))

    def _on_map(self, msg: OccupancyGrid) -> None:
        with self.lock:
            self.map = msg

    def _pose(self) -> Optional[Tuple[float, float, float]]:
        try:
            t = self.tf.lookup_transform(self.params.global_frame, self.params.base_frame,
                                         rospy.Time(0), rospy.Duration(1.0))
        except tf2_ros.TransformException as e:
            rospy.logwarn_throttle(10.0, "explorer: no pose (%s -> %s): %s",
                                   self.params.global_frame, self.params.base_frame, e)
            return None
        return planar(t.transform)

    def run(self) -> None:
        """Explore, then stay up: ``~finished`` stays latched for late subscribers."""
        self.explore()
        rospy.spin()

    def explore(self) -> None:
        """Send goals until no reachable frontier is left (or shutdown)."""
        rospy.loginfo("explorer: waiting for %s", rospy.resolve_name("move_base"))
        while not self.client.wait_for_server(rospy.Duration(5.0)):
            if rospy.is_shutdown():
                return
            rospy.logwarn_throttle(30.0, "explorer: no move_base action server yet at %s",
                                   rospy.resolve_name("move_base"))
        ended = rospy.Time(0)                 # when the last goal ended
        ahead: Optional[Tuple[float, float, float]] = None
        while not rospy.is_shutdown():
            if ahead is not None:             # picked while the last goal was being reached
                ahead = self._go(ahead)
                ended = rospy.Time.now()
                continue
            msg, fmap, goal = self._pick()
            if msg is None:
                rospy.sleep(0.5)
                continue
            if (goal is None and msg.header.stamp < ended
                    and rospy.Time.now() - ended < rospy.Duration(self.params.finish_wait)):
                rospy.sleep(0.5)               # done, unless the next map shows more
                continue
            if goal is None:
                free = float((fmap.grid == 0).sum()) * fmap.resolution ** 2
                rospy.loginfo("explorer: finished: no reachable frontier left after %d goals "
                              "(%d not reached); %.0f m^2 of free space mapped", self.goals,
                              self.failed, free)
                self.finished_pub.publish(Bool(True))
                return
            ahead = self._go(goal)
            ended = rospy.Time.now()

    def _latest_map(self) -> Optional[OccupancyGrid]:
        """The map as it is now from the mapper's ``dynamic_map`` service where it answers
        (the embedded mapper renders it on demand), else the last ``map`` message."""
        if self.dynamic_map is not None:
            try:
                return self.dynamic_map().map
            except (rospy.ServiceException, rospy.ROSException) as e:
                with self.lock:
                    first = self.map is None
                if first:        # no map yet: nothing scanned, nothing to say
                    rospy.loginfo_throttle(30.0, "explorer: waiting for the first map")
                else:
                    rospy.logwarn_throttle(30.0, "explorer: %s does not answer (%s): using %s",
                                           self.dynamic_map.resolved_name, e,
                                           rospy.resolve_name("map"))
        with self.lock:
            return self.map

    def _go(self, goal: Sequence[float]) -> Optional[Tuple[float, float, float]]:
        """Send ``goal`` (ruling its place out) and wait for it to end (or time out). The
        next goal picked from ``goal`` on the way when it was reached, else None."""
        g = move_base_goal(goal[0], goal[1], goal[2], self.params.global_frame)
        self.goals += 1
        self.explorer.goal_failed(goal)
        rospy.loginfo("explorer: goal %d: (%.2f, %.2f), picked in %.2f s of wall time", self.goals,
                      goal[0], goal[1], self.pick_wall)
        # actionlib's ActionClient, not the SimpleActionClient: its send_goal races the
        # server's first status (actionlib issue #206: a spurious error line per goal)
        gh = self.client.send_goal(g)
        deadline = rospy.Time.now() + rospy.Duration(self.params.goal_timeout)
        ahead: Optional[Tuple[float, float, float]] = None
        picked = False
        while gh.get_comm_state() != CommState.DONE and not rospy.is_shutdown():
            if not picked and self._near(goal):
                ahead, picked = self._pick(goal)[2], True
                continue
            if rospy.Time.now() > deadline:
                gh.cancel()
                rospy.logwarn("explorer: goal %d not reached in %.0f s: cancelled",
                              self.goals, self.params.goal_timeout)
                self.failed += 1
                break
            rospy.sleep(0.2)
        else:
            state = gh.get_goal_status()
            if state == GoalStatus.SUCCEEDED:
                self.explorer.looked_from(goal)
                return ahead
            if not rospy.is_shutdown():
                self.failed += 1
                rospy.logwarn("explorer: goal %d %s: %s", self.goals,
                              _DONE.get(state, str(state)), gh.get_goal_status_text())
        return None

    def _near(self, goal: Sequence[float]) -> bool:
        """Whether the robot is within ``~lookahead`` of ``goal`` (False with no pose)."""
        if self.params.lookahead <= 0.0:
            return False
        pose = self._pose()
        return pose is not None and math.hypot(goal[0] - pose[0],
                                               goal[1] - pose[1]) <= self.params.lookahead

    def _pick(self, origin: Optional[Sequence[float]] = None):
        """The latest map (the message and its FloorMap) and the next goal on it as seen from
        ``origin`` (None: from where the robot stands); (None, None, None) with no map or no
        pose. ``pick_wall`` gets the wall time the fetch and the search took."""
        start = time.monotonic()
        msg = self._latest_map()
        if origin is None:
            origin = self._pose()
        if msg is None or origin is None:
            return None, None, None
        fmap = grid_from_msg(msg)
        goal = self.explorer.next_goal(fmap, origin)
        self.pick_wall = time.monotonic() - start
        return msg, fmap, goal


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim explorer``."""
    return run_node("explorer", ExplorerNode, argv)


if __name__ == "__main__":
    sys.exit(main())
