#!/usr/bin/env python3
"""rostest node: the simulator at rtf 0 (as fast as it can) in worlds/simple.

Flat out, the node queues messages per connection and sends them in batches (see Outbox in
ros/simulator.py). A subscriber that keeps up must still get every message, in order: the
header seq of each topic goes up by exactly one, the stamps by exactly the topic's period.
Messages are taken as rospy.AnyMsg (the header read from the raw bytes) so this process keeps
up easily.
"""
from __future__ import annotations

import os
import struct
import sys
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from helpers import wait_for  # noqa: E402

#: topic -> sim-time period of its messages, per sim.launch ``rates`` (the test's ``~rates``):
#: ours (the default) and stage (Stage's: a 10 Hz step, everything at 10 Hz)
PERIODS = {
    "ours": {"/robot1/base_scan": 0.1, "/robot1/battery_state": 0.1, "/robot2/joint_states": 0.1,
             "/robot2/base_pose_ground_truth": 0.05, "/robot1/odom": 0.02, "/clock": 0.01},
    "stage": {"/robot1/base_scan": 0.1, "/robot1/battery_state": 0.1,
              "/robot2/joint_states": 0.1, "/robot2/base_pose_ground_truth": 0.1,
              "/robot1/odom": 0.1, "/clock": 0.1},
}
_HEADER = struct.Struct("<III")


def _span(got) -> float:
    """Sim seconds between the second and the last message kept of a topic."""
    return (got[-1][1] - got[1][1]) * 1e-9 if len(got) > 2 else 0.0


class SimFlatOut(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_sim_flat_out")
        cls.periods = PERIODS[rospy.get_param("~rates", "ours")]
        cls.clock = []
        rospy.Subscriber("/clock", Clock, lambda m: cls.clock.append(m.clock.to_nsec()),
                         queue_size=None)
        cls.seen = {t: [] for t in cls.periods if t != "/clock"}
        cls.rtf, cls.share = [], []
        rospy.Subscriber("/simulator/real_time_factor_achieved", Float64,
                         lambda m: cls.rtf.append(m.data))
        rospy.Subscriber("/simulator/publishing_share", Float64,
                         lambda m: cls.share.append(m.data))
        rospy.wait_for_message("/clock", Clock, timeout=30.0)
        subs = [rospy.Subscriber(t, rospy.AnyMsg, cls._keep, callback_args=t, queue_size=None)
                for t in cls.seen]
        wait_for(lambda: all(len(v) > 10 for v in cls.seen.values()), 30.0, "every topic")
        # 21 s of sim time on every topic, however fast this machine runs it (4 s of wall
        # time saw 15 sim s with a busy CPU: a speed bound, which belongs in `make bench`)
        wait_for(lambda: all(_span(v) > 21.0 for v in cls.seen.values()), 45.0,
                 "21 s of sim time on every topic")
        for s in subs:
            s.unregister()
        wait_for(lambda: len(cls.share) >= 3, 20.0, "three reports of the publishing share")

    @classmethod
    def _keep(cls, msg, topic):
        seq, secs, nsecs = _HEADER.unpack_from(msg._buff, 0)
        cls.seen[topic].append((seq, secs * 10 ** 9 + nsecs))

    def test_reports_real_time_factor(self):
        """Flat out the node still reports the real-time factor it achieved, every second: a
        positive figure. (How fast is the benchmarks' figure, `make bench`, never a bound
        here: a busy 2-core CI machine ran this world at 1.2x while a quiet one runs it above
        50x, so any bound in a test either fails there or tests nothing.)"""
        self.assertGreaterEqual(len(self.rtf), 3, self.rtf)
        for v in self.rtf:
            self.assertGreater(v, 0.0, self.rtf)

    def test_the_clock_steps_by_the_step_period(self):
        """/clock goes up, message after message, by whole steps of the rates' step period
        (flat out it is sent at most every ``clock_wall_period`` of wall time, so steps are
        skipped, never split): with rates:=stage every stamp is a multiple of 0.1 s."""
        step = int(round(self.periods["/clock"] * 1e9))
        stamps = self.clock[1:]
        self.assertGreater(len(stamps), 100)
        gaps = [b - a for a, b in zip(stamps, stamps[1:])]
        self.assertTrue(all(g > 0 for g in gaps), "/clock went back or repeated")
        self.assertEqual({g % step for g in gaps}, {0}, "/clock steps off the %d ns grid" % step)
        self.assertEqual({t % step for t in stamps}, {0})
        if step == 10 ** 7:   # ours: the 100 Hz step shows between the 0.1 s marks
            self.assertTrue(any(t % 10 ** 8 for t in stamps))

    def test_no_message_lost_or_reordered(self):
        for topic, got in self.seen.items():
            period = self.periods[topic]
            # from the second message: the first may have been queued before we connected
            seqs = [s for s, _ in got[1:]]
            stamps = [t for _, t in got[1:]]
            with self.subTest(topic=topic):
                sim_s = (stamps[-1] - stamps[0]) * 1e-9
                self.assertGreater(sim_s, 20.0, "%s: only %.1f sim s seen" % (topic, sim_s))
                gaps = [b - a for a, b in zip(seqs, seqs[1:]) if b - a != 1]
                self.assertEqual(gaps, [], "%s: seq jumps %s" % (topic, gaps[:10]))
                steps = {b - a for a, b in zip(stamps, stamps[1:])}
                self.assertEqual(steps, {int(round(period * 1e9))}, topic)

    def test_publishing_share_is_reported(self):
        """The node's publishing time over its stepping time: a share, not zero."""
        for v in self.share:
            self.assertGreater(v, 0.0)
            self.assertLess(v, 1.0)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "sim_flat_out", SimFlatOut)
