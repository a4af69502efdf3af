#!/usr/bin/env python3
"""rostest node: the simulator's people (people.test).

* the ground truth arrives on subscribers that declare the upstream types (people_msgs/People,
  spencer_tracking_msgs/TrackedPersons), whose md5sums genmsg computes from the upstream
  definitions kept as test fixtures: what a subscriber of those types checks on connect; the
  connection headers name the upstream types (what rosbag records: a bag recorded here, and
  the ROS 2 bag converted from it, name them), and a subscriber of our own
  bullet_floor_sim/People connects too;
* three people, named person_1..3, inside the room, the two topics agreeing;
* robot1's published scan (it stands still at its spawn pose, its laser 0.3 m ahead): every
  beam that ends short of the known walls and off robot2 ends within 0.31 m of a person's
  centre (legs reach 0.1 m aside, 0.15 m fore and aft, 0.06 m thick), and there are many.
"""
from __future__ import annotations

import math
import os
import sys
import threading
import unittest

import rospy
import rostest
from sensor_msgs.msg import LaserScan

from bullet_floor_sim.msg import People, TrackedPersons

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "unit"))
from helpers import wait_for  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from simple_room import expected_range  # noqa: E402
from test_upstream_types import upstream_md5  # noqa: E402


class UpstreamPeople(People):
    _type = "people_msgs/People"


class UpstreamTracked(TrackedPersons):
    _type = "spencer_tracking_msgs/TrackedPersons"


LASER = (1.8, 2.0)          # robot1 at (1.5, 2.0, 0) in worlds/simple, laser 0.3 m ahead
FREE = (0.1, 0.1, 5.9, 3.9)  # the room's free interior
ROBOT2 = (3.0, 3.0)          # robot2 stands there


class PeopleTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_people")
        cls.lock = threading.Lock()
        cls.people, cls.tracked, cls.scans, cls.ours = {}, {}, {}, {}
        rospy.Subscriber("/ground_truth/people", UpstreamPeople, cls._keep, cls.people)
        rospy.Subscriber("/ground_truth/people", People, cls._keep, cls.ours)   # our own type
        rospy.Subscriber("/ground_truth/tracked_persons", UpstreamTracked, cls._keep,
                         cls.tracked)
        rospy.Subscriber("/robot1/base_scan", LaserScan, cls._keep, cls.scans)

    @classmethod
    def _keep(cls, msg, into):
        with cls.lock:
            into[msg.header.stamp.to_nsec()] = msg

    def test_1_upstream_types_connect_and_agree(self):
        self.assertEqual(UpstreamPeople._md5sum, upstream_md5("people_msgs/People"))
        self.assertEqual(UpstreamTracked._md5sum,
                         upstream_md5("spencer_tracking_msgs/TrackedPersons"))
        wait_for(lambda: len(self.people) >= 20 and len(self.tracked) >= 20
                 and len(self.ours) >= 20, 60, "20 messages on each ground-truth topic")
        with self.lock:
            # the simulator advertises the upstream names (ros/upstream.py): the connection
            # header, which rosbag records, names them and their dependencies
            header = next(iter(self.people.values()))._connection_header
            self.assertEqual(header["type"], "people_msgs/People")
            self.assertIn("\nMSG: people_msgs/Person\n", header["message_definition"])
            header = next(iter(self.tracked.values()))._connection_header
            self.assertEqual(header["type"], "spencer_tracking_msgs/TrackedPersons")
            self.assertIn("\nMSG: spencer_tracking_msgs/TrackedPerson\n",
                          header["message_definition"])
            both = sorted(set(self.people) & set(self.tracked))
            self.assertGreater(len(both), 10)
            for t in both:
                people, tracked = self.people[t], self.tracked[t]
                self.assertEqual([p.name for p in people.people],
                                 ["person_1", "person_2", "person_3"])
                self.assertEqual([tr.track_id for tr in tracked.tracks], [1, 2, 3])
                for p, tr in zip(people.people, tracked.tracks):
                    self.assertTrue(FREE[0] < p.position.x < FREE[2]
                                    and FREE[1] < p.position.y < FREE[3], p)
                    self.assertAlmostEqual(tr.pose.pose.position.x, p.position.x)
                    self.assertAlmostEqual(tr.pose.pose.position.y, p.position.y)
                    self.assertEqual(people.header.frame_id, "map")

    def test_2_legs_in_the_scan(self):
        """Every beam of robot1's scan that ends short of the room's walls (and not on
        robot2) ends on a leg: within 0.31 m of a person's centre; and there are many."""
        wait_for(lambda: len(set(self.people) & set(self.scans)) >= 30, 60,
                 "30 scans with the people's ground truth of the same stamp")
        on_legs = 0
        with self.lock:
            stamps = sorted(set(self.people) & set(self.scans))
            for t in stamps:
                scan = self.scans[t]
                for k, r in enumerate(scan.ranges):
                    a = scan.angle_min + k * scan.angle_increment
                    if not math.isfinite(r) or r > expected_range(LASER[0], LASER[1], a) - 0.05:
                        continue
                    x, y = LASER[0] + r * math.cos(a), LASER[1] + r * math.sin(a)
                    if math.hypot(x - ROBOT2[0], y - ROBOT2[1]) < 0.45:
                        continue
                    near = min(math.hypot(x - p.position.x, y - p.position.y)
                               for p in self.people[t].people)
                    self.assertLess(near, 0.31, "a return at (%.2f, %.2f) explained by no "
                                                "wall, robot or person" % (x, y))
                    on_legs += 1
        self.assertGreater(on_legs, 2 * len(stamps), "beams on legs in %d scans" % len(stamps))

    def test_3_a_recorded_bag_names_the_upstream_types(self):
        """rosbag record stores the publisher's connection header: the bag, and the ROS 2
        bag `bag convert` makes of it, name people_msgs and spencer_tracking_msgs."""
        import shutil
        import subprocess
        import tempfile

        import rosbag

        from bullet_floor_sim.ros.bag_tool import convert

        tmp = tempfile.mkdtemp(prefix="bfs_people_bag_")
        try:
            path = os.path.join(tmp, "people.bag")
            subprocess.run(["rosbag", "record", "--duration=3", "-O", path,
                            "/ground_truth/people", "/ground_truth/tracked_persons"],
                           check=True, timeout=60, stdout=subprocess.DEVNULL)
            with rosbag.Bag(path) as bag:
                info = bag.get_type_and_topic_info()
            self.assertEqual({t: (v.msg_type, v.message_count > 5) for t, v in info.topics.items()},
                             {"/ground_truth/people": ("people_msgs/People", True),
                              "/ground_truth/tracked_persons":
                                  ("spencer_tracking_msgs/TrackedPersons", True)})
            self.assertEqual(info.msg_types["people_msgs/People"],
                             upstream_md5("people_msgs/People"))
            try:
                from rosbags.rosbag2 import Reader
            except ImportError:
                return
            out = os.path.join(tmp, "ros2")
            convert([path], out)
            with Reader(out) as reader:
                types = {c.topic: c.msgtype for c in reader.connections}
            self.assertEqual(types, {
                "/ground_truth/people": "people_msgs/msg/People",
                "/ground_truth/tracked_persons": "spencer_tracking_msgs/msg/TrackedPersons"})
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_people", PeopleTest)
