#!/usr/bin/env python3
"""demo.launch end to end (see demo_builtin.test)."""
from __future__ import annotations

import glob
import json
import math
import os
import shutil
import threading
import unittest

import actionlib
import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from std_msgs.msg import String

from bullet_floor_sim.msg import Trajectory
from bullet_floor_sim.srv import SOMAQueryROIs

from helpers import wait_for


class Demo(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_demo")
        cls.home = rospy.get_param("~home")
        cls.lock = threading.Lock()
        cls.legs, cls.chunks, cls.poses = [], [], []
        rospy.Subscriber("/robot1/markov_walker/leg", String,
                         lambda m: cls._add(cls.legs, json.loads(m.data)))
        rospy.Subscriber("/trajectory_recorder/trajectories/batch", Trajectory,
                         lambda m: cls._add(cls.chunks, m))
        rospy.Subscriber("/robot1/pose", PoseStamped, lambda m: cls._add(cls.poses, m),
                         queue_size=1000)
        cls.robot2 = None
        rospy.Subscriber("/robot2/pose", PoseStamped, cls._on_robot2)

    @classmethod
    def tearDownClass(cls):
        # the bag grows ~10 MB a minute: do not leave it in /tmp (nodes still running may
        # recreate a few small files)
        shutil.rmtree(cls.home, ignore_errors=True)

    @classmethod
    def _add(cls, bucket, item):
        with cls.lock:
            bucket.append(item)

    @classmethod
    def _on_robot2(cls, msg):
        cls.robot2 = msg

    def test_1_rois_answer(self):
        rospy.wait_for_service("/soma/query_rois", timeout=60)
        resp = rospy.ServiceProxy("/soma/query_rois", SOMAQueryROIs)(
            query_type=0, returnmostrecent=True, roiconfigs=["1"])
        self.assertEqual(len(resp.rois), 15)

    def test_2_the_walker_completes_legs_and_the_observer_navigates(self):
        client = actionlib.SimpleActionClient("/robot2/move_base", MoveBaseAction)
        self.assertTrue(client.wait_for_server(rospy.Duration(60)))
        goal = MoveBaseGoal()
        goal.target_pose.header.frame_id = "map"
        goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = 20.0, 10.0
        goal.target_pose.pose.orientation.w = 1.0
        client.send_goal(goal)
        # two legs of the walker, each from a region to a region it may go to
        wait_for(lambda: len(self.legs) >= 2, 200, "two walker legs")
        self.assertTrue(client.wait_for_result(rospy.Duration(120)))
        p = self.robot2.pose.position
        self.assertLess(math.hypot(p.x - 20.0, p.y - 10.0), 0.3)
        # the walker reached its goal regions (robot2 may block the corridor now and then)
        wait_for(lambda: sum(leg["outcome"] == "succeeded" for leg in self.legs) >= 2, 200,
                 "two legs that reached their region")
        for leg in self.legs:
            if leg["outcome"] == "succeeded":
                self.assertEqual(leg["end_region"], leg["to"])

    def test_3_trajectories_stored_and_bag_written(self):
        chunks = wait_for(lambda: len(self.chunks) >= 2 and self.chunks, 120,
                          "two stored trajectory chunks (period 10 s)")
        for c in chunks:
            self.assertGreater(len(c.trajectory), 50)  # 10 s of 20 Hz poses
            self.assertGreaterEqual(c.end_time, c.start_time)
            self.assertEqual(c.trajectory[0].header.frame_id, "map")
        # consecutive chunks share their boundary pose
        self.assertEqual(chunks[0].trajectory[-1].header.stamp,
                         chunks[1].trajectory[0].header.stamp)
        active = wait_for(lambda: glob.glob(os.path.join(
            self.home, "bullet_floor_sim", "bags", "demo_*.bag.active")), 30, "the bag")
        self.assertGreater(os.path.getsize(active[0]), 100000)
        self.assertTrue(os.path.isdir(os.path.join(self.home, "bullet_floor_sim", "db")))


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "demo_builtin", Demo)
