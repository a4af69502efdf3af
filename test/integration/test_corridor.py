#!/usr/bin/env python3
"""Two robots facing each other in the corridor world's 1.4 m corridor, each sent through
move_base to the hall behind the other: both goals SUCCEED, each robot ends within 0.3 m of
its goal and never touches a wall, and one of them went back into the hall it came from while
the other was still in the corridor: exactly one of them yielded."""
from __future__ import annotations

import os
import unittest

import actionlib
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseAction
from scipy.ndimage import distance_transform_edt

from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim.floormap import load_map

from test_navigation import HULL_RADIUS, Watch, goal_msg

GOALS = {"robot1": (27.0, 3.65), "robot2": (2.6, 3.65)}


class Track(Watch):
    """Watch, plus whether the robot stood aside in a hall while the other was in the
    corridor."""

    def __init__(self, ns, fmap, dist):
        super().__init__(ns, fmap, dist)
        self.aside = False


class TestCorridor(unittest.TestCase):
    def test_facing_robots_both_arrive(self):
        rospy.init_node("test_corridor")
        fmap = load_map(os.path.join(worlds_dir(), "corridor", "map.yaml"))
        dist = distance_transform_edt(fmap.grid != 100) * fmap.resolution - fmap.resolution / 2
        names = sorted(GOALS)
        watch = {n: Track("/" + n, fmap, dist) for n in names}
        clients = {n: actionlib.SimpleActionClient("/%s/move_base" % n, MoveBaseAction)
                   for n in names}
        for n, c in clients.items():
            self.assertTrue(c.wait_for_server(rospy.Duration(60)), "no %s/move_base" % n)
        deadline = rospy.Time.now() + rospy.Duration(30)
        while any(w.pose is None for w in watch.values()) and rospy.Time.now() < deadline:
            rospy.sleep(0.1)
        for n in names:
            clients[n].send_goal(goal_msg(*GOALS[n], yaw=0.0))
        deadline = rospy.Time.now() + rospy.Duration(250)
        while rospy.Time.now() < deadline and any(
                c.get_state() in (GoalStatus.PENDING, GoalStatus.ACTIVE) for c in clients.values()):
            poses = {n: w.pose for n, w in watch.items()}
            self.assertTrue(all(poses.values()), "no ground truth pose from %s" % poses)
            for n in names:
                other = poses[names[1 - names.index(n)]]
                x = poses[n][0]
                in_corridor = 5.5 < other[0] < 24.0
                own_hall = x < 4.65 if n == "robot1" else x > 24.95   # the hall it came from
                if in_corridor and own_hall:
                    watch[n].aside = True
            rospy.sleep(0.2)
        for n in names:
            c = clients[n]
            self.assertEqual(c.get_state(), GoalStatus.SUCCEEDED,
                             "%s: %s" % (n, c.get_goal_status_text()))
            self.assertLessEqual(watch[n].error_to(*GOALS[n]), 0.3)
            self.assertGreater(watch[n].min_clearance, HULL_RADIUS,
                               "%s came within %.3f m of a wall" % (n, watch[n].min_clearance))
        aside = [n for n, w in watch.items() if w.aside]
        self.assertEqual(len(aside), 1, "stood aside in their halls: %s" % aside)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_corridor", TestCorridor)
