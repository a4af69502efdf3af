#!/usr/bin/env python3
"""Builtin navigation through its move_base interface, in the office world.

Goals are chosen from the map: the centroids of rooms in worlds/office/rois.yaml, checked free
on the planning grid. Each robot must end within 0.3 m of its goal and never touch a wall (its
ground-truth centre keeps the hull's circumradius, 0.32 m, from every wall cell); a goal in a
wall or off the map is ABORTED at once with the reason; a new goal preempts the running one.
"""
from __future__ import annotations

import math
import os
import sys
import threading
import unittest

import actionlib
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage
from scipy.ndimage import distance_transform_edt

from bullet_floor_sim.sim.floormap import load_map
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.nav.planner import PlanningGrid
from bullet_floor_sim.data.rois import centroid, load_rois

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from helpers import goal_outcome  # noqa: E402

HULL_RADIUS = 0.32
OFFICE = os.path.join(worlds_dir(), "office")


def room_goal(rois, roi_id, grid):
    x, y = centroid(next(r for r in rois if r.id == roi_id))
    assert grid.is_free(x, y), "room %s centroid (%.2f, %.2f) not free" % (roi_id, x, y)
    return x, y


def goal_msg(x, y, yaw=0.0, frame="map"):
    g = MoveBaseGoal()
    g.target_pose.header.frame_id = frame
    g.target_pose.header.stamp = rospy.Time.now()
    g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, y
    g.target_pose.pose.orientation.z = math.sin(yaw / 2.0)
    g.target_pose.pose.orientation.w = math.cos(yaw / 2.0)
    return g


class Watch:
    """Ground-truth pose and the smallest wall clearance seen, for one robot."""

    def __init__(self, ns, fmap, dist):
        self.pose = None
        self.min_clearance = math.inf
        self.fmap, self.dist = fmap, dist
        self.lock = threading.Lock()
        rospy.Subscriber(ns + "/base_pose_ground_truth", Odometry, self._cb, queue_size=50)

    def _cb(self, m):
        x, y = m.pose.pose.position.x, m.pose.pose.position.y
        c, r = self.fmap.world_to_cell(x, y)
        with self.lock:
            self.pose = (x, y)
            self.min_clearance = min(self.min_clearance, float(self.dist[int(r), int(c)]))

    def error_to(self, x, y):
        with self.lock:
            return math.hypot(self.pose[0] - x, self.pose[1] - y)


class TestBuiltinNavigation(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_navigation")
        cls.robots = rospy.get_param("~robots", ["robot1", "robot2"])
        cls.fmap = load_map(os.path.join(OFFICE, "map.yaml"))
        # distance from a cell centre to the nearest wall cell's edge
        cls.dist = distance_transform_edt(cls.fmap.grid != 100) * cls.fmap.resolution \
            - cls.fmap.resolution / 2.0
        cls.grid = PlanningGrid(cls.fmap)
        cls.rois = load_rois(os.path.join(OFFICE, "rois.yaml"))
        cls.ns = ["/" + r if r else "" for r in cls.robots]
        cls.clients = [actionlib.SimpleActionClient(ns + "/move_base", MoveBaseAction)
                       for ns in cls.ns]
        for ns, c in zip(cls.ns, cls.clients):
            assert c.wait_for_server(rospy.Duration(60)), "no action server %s/move_base" % ns
        cls.watch = [Watch(ns, cls.fmap, cls.dist) for ns in cls.ns]
        deadline = rospy.Time.now() + rospy.Duration(30)
        while any(w.pose is None for w in cls.watch) and rospy.Time.now() < deadline:
            rospy.sleep(0.1)

    def test_0_empty_name_robot_uses_bare_names(self):
        if self.robots != [""]:
            self.skipTest("only for the single robot with an empty name")
        odom = rospy.wait_for_message("/odom", Odometry, timeout=10)
        self.assertEqual((odom.header.frame_id, odom.child_frame_id), ("odom", "base_footprint"))
        scan = rospy.wait_for_message("/base_scan", LaserScan, timeout=10)
        self.assertEqual(scan.header.frame_id, "base_laser_link")
        static = rospy.wait_for_message("/tf_static", TFMessage, timeout=10)
        pairs = {(t.header.frame_id, t.child_frame_id) for t in static.transforms}
        self.assertIn(("base_footprint", "base_link"), pairs)
        self.assertIn(("base_link", "base_laser_link"), pairs)

    def drive(self, goals, timeout=150.0):
        """Send one goal per robot at once; return their final states."""
        for c, (x, y) in zip(self.clients, goals):
            c.send_goal(goal_msg(x, y))
        for c in self.clients[:len(goals)]:
            self.assertTrue(c.wait_for_result(rospy.Duration(timeout)), "goal timed out")
        return [c.get_state() for c in self.clients[:len(goals)]]

    def test_1_goals_across_rooms(self):
        # robot1 starts in the west corridor, robot2 in the centre: they cross in the corridor
        legs = [("12", "5"), ("9", "10")] if len(self.robots) > 1 else [("12",), ("9",), ("5",)]
        for leg in legs:
            goals = [room_goal(self.rois, rid, self.grid) for rid in leg]
            states = self.drive(goals)
            for i, ((x, y), st) in enumerate(zip(goals, states)):
                self.assertEqual(st, GoalStatus.SUCCEEDED,
                                 "%s to room %s: %s" % (self.robots[i] or "robot", leg[i],
                                                        self.clients[i].get_goal_status_text()))
                self.assertLessEqual(self.watch[i].error_to(x, y), 0.3)
        for i, w in enumerate(self.watch):
            self.assertGreater(w.min_clearance, HULL_RADIUS,
                               "%s came within %.3f m of a wall" % (self.robots[i], w.min_clearance))

    def test_2_bad_goals_abort_quickly_with_the_reason(self):
        # the plain ActionClient (helpers.goal_outcome): these goals end at once, which the
        # SimpleActionClient can miss under load (a CI run of session 26)
        c = actionlib.ActionClient(self.ns[0] + "/move_base", MoveBaseAction)
        self.assertTrue(c.wait_for_server(rospy.Duration(30)))
        for (x, y), why in (((4.42, 5.0), "too close to a wall"), ((40.0, 5.0), "outside the map"),
                            ((4.75, 5.0), "inside a wall")):
            t0 = rospy.Time.now()
            got = goal_outcome(c, goal_msg(x, y), 10.0)
            self.assertIsNotNone(got, "no result for the goal (%g, %g) in 10 s" % (x, y))
            self.assertEqual(got[0], GoalStatus.ABORTED)
            self.assertIn(why, got[1])
            self.assertLess((rospy.Time.now() - t0).to_sec(), 2.0)

    def test_3_new_goal_preempts_and_simple_goal_works(self):
        c = self.clients[0]
        far = room_goal(self.rois, "15", self.grid)
        c.send_goal(goal_msg(*far))
        rospy.sleep(3.0)
        first = c.gh
        near = room_goal(self.rois, "13", self.grid)
        # a new goal on move_base_simple/goal preempts the action goal, as in move_base
        pub = rospy.Publisher(self.ns[0] + "/move_base_simple/goal", PoseStamped, queue_size=1,
                              latch=True)
        ps = goal_msg(*near).target_pose
        pub.publish(ps)
        deadline = rospy.Time.now() + rospy.Duration(10)
        while first.get_goal_status() != GoalStatus.PREEMPTED and rospy.Time.now() < deadline:
            rospy.sleep(0.1)
        self.assertEqual(first.get_goal_status(), GoalStatus.PREEMPTED)
        deadline = rospy.Time.now() + rospy.Duration(150)
        while self.watch[0].error_to(*near) > 0.3 and rospy.Time.now() < deadline:
            rospy.sleep(0.5)
        self.assertLessEqual(self.watch[0].error_to(*near), 0.3)
        # and a cancel stops the robot where it is
        c.send_goal(goal_msg(*far))
        rospy.sleep(2.0)
        c.cancel_goal()
        self.assertTrue(c.wait_for_result(rospy.Duration(5)))
        self.assertEqual(c.get_state(), GoalStatus.PREEMPTED)
        rospy.sleep(1.0)
        before = self.watch[0].pose
        rospy.sleep(2.0)
        after = self.watch[0].pose
        self.assertLess(math.hypot(after[0] - before[0], after[1] - before[1]), 0.02)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_navigation", TestBuiltinNavigation)
