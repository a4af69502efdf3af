#!/usr/bin/env python3
"""rostest node: the recorder's timer survives sim time jumping back; sim-time sleeps, rates
and timers (ros/sim_sleep, installed in this process as in every node) wake when due.

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
from bullet_floor_sim.ros import sim_sleep


class Timers(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_timers")
        sim_sleep.install()
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=10)

    def test_sleep_rate_and_timer_wake_when_due(self):
        """This process publishes /clock in 10 ms ticks from t = 200 s (one every 2 ms of
        wall time) and sleeps on it with sim_sleep's sleep: rospy.sleep(0.5), a 20 Hz
        rospy.Rate, a 0.1 s rospy.Timer each end at the first tick at or past their deadline
        (a few ticks later at most: the tick must reach the process first); then the clock
        goes back to 1 s and a sleep of 5 s raises ROSTimeMovedBackwardsException. (It runs
        before the recorder's test, whose clock starts again at 100 s.)"""
        self.assertEqual(rospy.timer.sleep.__module__, "bullet_floor_sim.ros.sim_sleep")
        clock = self.clock
        deadline = time.monotonic() + 30
        while clock.get_num_connections() < 1:      # this process's own /clock subscription
            self.assertLess(time.monotonic(), deadline, "no subscriber to /clock")
            time.sleep(0.05)
        run = threading.Event()
        run.set()
        start_ns = 200 * 10 ** 9

        def tick():
            k = 0
            while run.is_set():
                clock.publish(Clock(clock=rospy.Time(0, start_ns + k * 10 ** 7)))
                k += 1
                time.sleep(0.002)

        ticker = threading.Thread(target=tick, daemon=True)
        ticker.start()
        try:
            while rospy.get_rostime().to_nsec() < start_ns:
                time.sleep(0.01)
            out = {}

            def sleeper():
                t0 = rospy.get_rostime()
                rospy.sleep(0.5)
                out["sleep"] = (rospy.get_rostime() - t0).to_sec()

            def rate():
                r = rospy.Rate(20.0)
                t0 = rospy.get_rostime()
                for _ in range(10):
                    r.sleep()
                out["rate"] = (rospy.get_rostime() - t0).to_sec()

            fired = []
            timer = rospy.Timer(rospy.Duration(0.1), lambda e: fired.append(
                (e.current_expected.to_sec(), e.current_real.to_sec())), reset=True)
            threads = [threading.Thread(target=f) for f in (sleeper, rate)]
            for t in threads:
                t.start()
            for t in threads:
                t.join(30)
            timer.shutdown()
            self.assertGreaterEqual(out["sleep"], 0.5)
            self.assertLess(out["sleep"], 0.5 + 0.3)    # (ticks in flight)
            self.assertGreaterEqual(out["rate"], 0.5 - 0.05 - 1e-9)   # the first period starts
            self.assertLess(out["rate"], 0.5 + 0.3)                  # at Rate(), not at t0
            self.assertGreaterEqual(len(fired), 4)
            for (e0, _), (e1, _) in zip(fired, fired[1:]):
                self.assertAlmostEqual(e1 - e0, 0.1, places=6)       # expected: every 0.1 s
            for expected, real in fired:
                self.assertGreaterEqual(real, expected - 1e-9)
                self.assertLess(real - expected, 0.3)
        finally:
            run.clear()
            ticker.join(5)
        got = []

        def long_sleep():
            try:
                rospy.sleep(5.0)
                got.append("returned")
            except rospy.exceptions.ROSTimeMovedBackwardsException:
                got.append("moved backwards")

        t = threading.Thread(target=long_sleep)
        t.start()
        time.sleep(0.2)
        clock.publish(Clock(clock=rospy.Time(1)))
        t.join(10)
        self.assertEqual(got, ["moved backwards"])

    def test_the_gap_timer_outlives_a_clock_jumping_back(self):
        db = rospy.get_param("~db")
        clock = self.clock
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
