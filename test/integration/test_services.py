#!/usr/bin/env python3
"""rostest node: ~spawn, ~delete, ~set_pose and ~step of the simulator (srv/*.srv): robot3
spawned and driven, robot2 deleted (robot3 moves up a row and still answers), robot3 deleted,
robot1 and the person teleported, 10 ticks stepped while paused.

worlds/simple: free interior x in [0.10, 5.90], y in [0.10, 3.90], pillar x in [4.0, 4.5],
y in [1.0, 1.5]; robot1 spawns at (1.5, 2.0, 0), robot2 at (3.0, 3.0, pi). The Scitos laser is
0.3 m ahead of base_footprint.
"""
from __future__ import annotations

import math
import os
import sys
import time
import unittest

import rosgraph
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Pose2D, Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, LaserScan
from std_srvs.srv import Empty

from bullet_floor_sim.msg import People
from bullet_floor_sim.srv import Delete, SetPose, Spawn, Step

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from simple_room import expected_range  # noqa: E402
from helpers import wait_for  # noqa: E402

SPAWN_AT = (5.2, 0.7, math.pi / 2)    # facing +y, clear of the pillar and robot2


def msg(topic, cls, timeout=15.0):
    return rospy.wait_for_message(topic, cls, timeout=timeout)


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def topic_users(topic):
    """(publishers, subscribers) of ``topic`` on the master."""
    pubs, subs, _ = rosgraph.Master("/test_services").getSystemState()
    return ([n for t, ns in pubs if t == topic for n in ns],
            [n for t, ns in subs if t == topic for n in ns])


class Services(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_services")
        for name in ("spawn", "delete", "set_pose", "step", "pause", "unpause"):
            rospy.wait_for_service("/simulator/" + name, 60.0)
        cls.spawn = rospy.ServiceProxy("/simulator/spawn", Spawn)
        cls.delete = rospy.ServiceProxy("/simulator/delete", Delete)
        cls.set_pose = rospy.ServiceProxy("/simulator/set_pose", SetPose)
        cls.step = rospy.ServiceProxy("/simulator/step", Step)
        cls.pause = rospy.ServiceProxy("/simulator/pause", Empty)
        cls.unpause = rospy.ServiceProxy("/simulator/unpause", Empty)
        cls.tf = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.tf)
        msg("/robot1/base_scan", LaserScan, 60.0)

    def lookup(self, target, source="map", timeout=10.0):
        t = self.tf.lookup_transform(source, target, rospy.Time(0), rospy.Duration(timeout))
        return (t.transform.translation.x, t.transform.translation.y,
                yaw_of(t.transform.rotation))

    def test_1_spawn_drive_and_refusals(self):
        r = self.spawn(model="scitos_a5", name="robot3", pose=Pose2D(*SPAWN_AT))
        self.assertTrue(r.success, r.message)
        gt = msg("/robot3/base_pose_ground_truth", Odometry)
        self.assertAlmostEqual(gt.pose.pose.position.x, SPAWN_AT[0], places=6)
        self.assertAlmostEqual(gt.pose.pose.position.y, SPAWN_AT[1], places=6)
        scan = msg("/robot3/base_scan", LaserScan)
        self.assertEqual(scan.header.frame_id, "robot3/base_laser_link")
        ahead = scan.ranges[int(round(-scan.angle_min / scan.angle_increment))]
        self.assertAlmostEqual(ahead, expected_range(5.2, 1.0, math.pi / 2), delta=0.05)
        wait_for(lambda: "/simulator" in topic_users("/robot3/cmd_vel")[1], 10.0,
                 "the simulator to subscribe /robot3/cmd_vel")
        # its robot_state_publisher: the laser 0.3 m ahead of base_footprint, in map
        x, y, yaw = self.lookup("robot3/base_laser_link")
        self.assertAlmostEqual(x, 5.2, delta=0.02)
        self.assertAlmostEqual(y, 1.0, delta=0.02)
        cmd = rospy.Publisher("/robot3/cmd_vel", Twist, queue_size=1)
        t_end = rospy.get_time() + 1.5
        while rospy.get_time() < t_end:
            cmd.publish(Twist(linear=_vec(0.3, 0, 0)))
            rospy.sleep(0.1)
        gt = msg("/robot3/base_pose_ground_truth", Odometry)
        self.assertGreater(gt.pose.pose.position.y, SPAWN_AT[1] + 0.15)
        self.assertAlmostEqual(gt.pose.pose.position.x, SPAWN_AT[0], delta=0.01)
        cmd.unregister()
        for req, why in ((dict(model="scitos_a5", name="robot3", pose=Pose2D(1.0, 1.0, 0.0)),
                          "already in the world"),
                         (dict(model="no_such_model", name="robot4", pose=Pose2D(1.0, 1.0, 0.0)),
                          "no_such_model"),
                         (dict(model="scitos_a5", name="robot4", pose=Pose2D(4.25, 1.25, 0.0)),
                          "inside a wall")):
            r = self.spawn(**req)
            self.assertFalse(r.success)
            self.assertIn(why, r.message)
        self.assertEqual(topic_users("/robot4/odom"), ([], []))

    def test_2_delete_a_middle_row_then_the_new_robot(self):
        r = self.delete(name="robot2")            # robot3 moves up a row
        self.assertTrue(r.success, r.message)
        wait_for(lambda: topic_users("/robot2/odom")[0] == [], 10.0, "robot2's topics to go")
        before = msg("/robot3/base_pose_ground_truth", Odometry).pose.pose.position
        battery = msg("/robot3/battery_state", BatteryState)
        self.assertGreater(battery.percentage, 0.9)     # its own battery, full
        cmd = rospy.Publisher("/robot3/cmd_vel", Twist, queue_size=1)
        t_end = rospy.get_time() + 1.0
        while rospy.get_time() < t_end:               # robot3 still answers its commands
            cmd.publish(Twist(angular=_vec(0, 0, 0.5)))
            rospy.sleep(0.1)
        cmd.unregister()
        gt = msg("/robot3/base_pose_ground_truth", Odometry).pose.pose
        self.assertAlmostEqual(gt.position.x, before.x, delta=0.01)
        self.assertGreater(yaw_of(gt.orientation), math.pi / 2 + 0.2)
        r = self.delete(name="robot3")
        self.assertTrue(r.success, r.message)
        self.assertIn("robots now: robot1", r.message)
        wait_for(lambda: topic_users("/robot3/odom")[0] == [] and
                 topic_users("/robot3/cmd_vel")[1] == [], 10.0, "robot3's topics to go")
        self.assertFalse(rospy.has_param("/robot3/robot_description"))
        self.assertTrue(topic_users("/robot1/odom")[0])     # robot1's stay
        msg("/robot1/base_scan", LaserScan)
        r = self.delete(name="robot3")
        self.assertFalse(r.success)
        self.assertIn("no robot 'robot3'", r.message)

    def test_3_set_pose_robot_and_person(self):
        odom0 = msg("/robot1/odom", Odometry).pose.pose.position
        r = self.set_pose(name="robot1", pose=Pose2D(2.0, 1.0, math.pi / 2))
        self.assertTrue(r.success, r.message)
        gt = msg("/robot1/base_pose_ground_truth", Odometry)
        self.assertAlmostEqual(gt.pose.pose.position.x, 2.0, places=6)
        self.assertAlmostEqual(gt.pose.pose.position.y, 1.0, places=6)
        self.assertAlmostEqual(yaw_of(gt.pose.pose.orientation), math.pi / 2, places=6)
        odom1 = msg("/robot1/odom", Odometry).pose.pose.position    # the wheels did not turn
        self.assertAlmostEqual(odom1.x, odom0.x, places=6)
        self.assertAlmostEqual(odom1.y, odom0.y, places=6)
        wait_for(lambda: abs(self.lookup("robot1/base_footprint", timeout=1.0)[1] - 1.0) < 1e-3,
                 10.0, "tf map -> robot1/base_footprint to jump")
        r = self.set_pose(name="robot1", pose=Pose2D(4.25, 1.25, 0.0))
        self.assertFalse(r.success)
        self.assertIn("inside a wall", r.message)
        r = self.set_pose(name="person_1", pose=Pose2D(0.8, 3.3, 0.0))
        self.assertTrue(r.success, r.message)
        # the next ground truth has the person there (it may have taken a step since)
        p = msg("/ground_truth/people", People).people[0]
        self.assertEqual(p.name, "person_1")
        self.assertLess(math.hypot(p.position.x - 0.8, p.position.y - 3.3), 0.2)
        for name, pose, why in (("person_1", (4.25, 1.25), "cannot stand at"),
                                ("nobody", (1.0, 1.0), "no robot or person 'nobody'")):
            r = self.set_pose(name=name, pose=Pose2D(pose[0], pose[1], 0.0))
            self.assertFalse(r.success)
            self.assertIn(why, r.message)

    def test_4_step_exactly_while_paused(self):
        r = self.step(ticks=10)
        self.assertFalse(r.success)
        self.assertIn("pause it first", r.message)
        self.pause()
        clocks = []
        sub = rospy.Subscriber("/clock", Clock, lambda m: clocks.append(m.clock.to_nsec()))
        time.sleep(0.5)                      # (wall time: sim time stands while paused)
        first = self.step(ticks=1)
        self.assertTrue(first.success, first.message)
        r = self.step(ticks=10)
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.clock.to_nsec() - first.clock.to_nsec(), 10 * 10_000_000)
        wait_for(lambda: clocks and clocks[-1] == r.clock.to_nsec(), 5.0,
                 "/clock to read the step's end")
        time.sleep(0.5)                      # paused: the clock stays there
        self.assertEqual(clocks[-1], r.clock.to_nsec())
        self.assertFalse(self.step(ticks=0).success)
        sub.unregister()
        self.unpause()


def _vec(x, y, z):
    from geometry_msgs.msg import Vector3
    return Vector3(x, y, z)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_services", Services)
