#!/usr/bin/env python3
"""rostest node: the recorder's timer survives sim time jumping back.

The test drives /clock itself: 10 s of poses from t = 100 s, then the clock restarts at
t = 1 s (a simulator restarted) and 3 s of poses follow, then silence while the clock runs
on. The first trajectory ends on the jump back (``time_jump``); the second must end on the
silence (``gap``, max_gap 2 s), which only the recorder's timer notices: a rospy.Timer
without ``reset`` dies when the clock goes back.
"""
from __future__ import annotations

import shutil
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Clock

from bullet_floor_sim.msg import Trajectory


class Timers(unittest.TestCase):
    def test_the_gap_timer_outlives_a_clock_jumping_back(self):
        rospy.init_node("test_timers")
        db = rospy.get_param("~db")
        clock = rospy.Publisher("/clock", Clock, queue_size=10)
        pose = rospy.Publisher("/timers_test/pose", PoseStamped, queue_size=1000)
        complete, lock = [], threading.Lock()

        def on_complete(msg):
            with lock:
                complete.append(msg)

        rospy.Subscriber("/trajectory_recorder/trajectories/complete", Trajectory, on_complete)
        deadline = time.monotonic() + 60
        while pose.get_num_connections() == 0 or clock.get_num_connections() == 0:
            self.assertLess(time.monotonic(), deadline, "the recorder did not subscribe")
            time.sleep(0.1)

        def run(t0, seconds, with_poses):
            for k in range(int(seconds * 20)):
                t = rospy.Time.from_sec(t0 + k * 0.05)
                clock.publish(Clock(clock=t))
                if with_poses:
                    msg = PoseStamped()
                    msg.header.stamp, msg.header.frame_id = t, "map"
                    msg.pose.position.x = 0.01 * k
                    msg.pose.orientation.w = 1.0
                    pose.publish(msg)
                time.sleep(0.01)

        try:
            run(100.0, 10.0, True)
            run(1.0, 3.0, True)           # the clock jumps back: a restarted simulator
            run(4.0, 6.0, False)          # silence, the clock running on
            deadline = time.monotonic() + 20
            while True:
                with lock:
                    got = [(m.complete, len(m.trajectory)) for m in complete]
                if len(got) >= 2 or time.monotonic() > deadline:
                    break
                run(10.0 + (time.monotonic() % 1000), 0.5, False)
            self.assertEqual(len(got), 2, "complete chunks: %s" % got)
            self.assertEqual([n for _, n in got], [200, 60])
        finally:
            shutil.rmtree(db, ignore_errors=True)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_timers", Timers)
