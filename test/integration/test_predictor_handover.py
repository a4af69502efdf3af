#!/usr/bin/env python3
"""The follower's target_id hands a lost track's leg to its new id (predictor_handover.test)."""
from __future__ import annotations

import math
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import Point, Vector3
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import UInt32

from bullet_floor_sim.msg import Destination, Track, TrackArray
from bullet_floor_sim.ros.convert import occupancy_grid
from bullet_floor_sim.sim.floormap import load_map

from helpers import wait_for

S = (3.0, 10.0)       # office's west corridor (ROI "1"), where the leg starts
SPEED = 0.5           # m/s, east


class PredictorHandover(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_predictor_handover")
        cls.lock = threading.Lock()
        cls.dests = []
        cls.map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        cls.map_pub.publish(occupancy_grid(load_map(rospy.get_param("~map_yaml"))))
        cls.tracks = rospy.Publisher("/tracks", TrackArray, queue_size=50)
        cls.target = rospy.Publisher("/target_id", UInt32, queue_size=1, latch=True)
        rospy.Subscriber("/destination_predictor/destination", Destination, cls._on_dest,
                         queue_size=100)
        cls.t = 100.0

    @classmethod
    def _on_dest(cls, m):
        with cls.lock:
            cls.dests.append(m)

    def send(self, ident, x, y, vx=0.0):
        """One track update at the next stamp (0.1 s on); the predictor's answer to it."""
        PredictorHandover.t += 0.1
        stamp = rospy.Time.from_sec(self.t)
        msg = TrackArray()
        msg.header.stamp, msg.header.frame_id = stamp, "map"
        if ident is not None:
            msg.tracks.append(Track(id=ident, position=Point(x, y, 0.0),
                                    velocity=Vector3(vx, 0.0, 0.0)))
        self.tracks.publish(msg)
        if ident is None:
            return None
        return wait_for(lambda: self._answer(ident, stamp), 20, "track %d's destination at %.1f"
                        % (ident, self.t))

    def _answer(self, ident, stamp):
        with self.lock:
            got = [d for d in self.dests if d.track_id == ident and d.header.stamp == stamp]
        return got[-1] if got else None

    def test_the_followers_new_target_goes_on_with_the_lost_leg(self):
        wait_for(lambda: self.tracks.get_num_connections() > 0, 30, "the predictor's /tracks")
        self.target.publish(UInt32(1))   # the follower follows track 1
        # track 1 stands at S until the model is built (no answer before), then walks 1.5 m
        first = wait_for(lambda: self._try_stand(), 60, "the predictor's model")
        self.assertFalse(first.under_way)
        for k in range(1, 31):
            d = self.send(1, S[0] + SPEED * 0.1 * k, S[1], SPEED)
        self.assertTrue(d.under_way)
        self.assertEqual(d.start_region, "1")
        self.assertAlmostEqual(d.start.x, S[0], places=2)
        # lost for 8 s (twice handover_time) while it walks on 4 m: seen again as track 2,
        # which starts a leg of its own (its stand is where it was first seen)
        for _ in range(80):
            self.send(None, 0.0, 0.0)
        x2 = S[0] + 1.5 + 4.0
        d2 = self.send(2, x2, S[1], SPEED)
        self.assertAlmostEqual(d2.start.x, x2, places=2)
        self.assertFalse(d2.under_way)
        # the follower takes track 2 for its lost target: track 2 goes on with track 1's leg
        self.target.publish(UInt32(2))
        k = [0]

        def handed_over():
            k[0] += 1
            d = self.send(2, x2 + SPEED * 0.1 * k[0], S[1], SPEED)
            return d if abs(d.start.x - S[0]) < 0.01 else None

        d3 = wait_for(handed_over, 20, "track 2 to go on with track 1's leg")
        self.assertTrue(d3.under_way)
        self.assertEqual(d3.start_region, "1")
        # the leg began when track 1 last stood (a float in the core: to the microsecond)
        self.assertAlmostEqual(d3.leg_start.to_sec(), first.header.stamp.to_sec(), places=6)
        self.assertGreater(d3.observed, 1.5 + 4.0 - 1e-6)   # the unseen 4 m count as walked
        self.assertTrue(math.isclose(sum(d3.probabilities), 1.0, abs_tol=1e-4))
        # lost again for 8 s; this time target_id names track 3 before the predictor has had
        # an update with it (the topics are not in step): the hand-over waits for that update
        x3 = x2 + SPEED * 0.1 * k[0] + 4.0
        for _ in range(80):
            self.send(None, 0.0, 0.0)
        self.target.publish(UInt32(3))
        rospy.sleep(1.0)
        first3 = self.send(3, x3, S[1], SPEED)
        self.assertAlmostEqual(first3.start.x, x3, places=2)   # made before the hand-over
        d4 = self.send(3, x3 + SPEED * 0.1, S[1], SPEED)
        self.assertEqual((d4.start_region, d4.under_way), ("1", True))
        self.assertAlmostEqual(d4.leg_start.to_sec(), first.header.stamp.to_sec(), places=6)
        self.assertAlmostEqual(d4.start.x, S[0], places=2)

    def _try_stand(self):
        PredictorHandover.t += 0.1
        stamp = rospy.Time.from_sec(self.t)
        msg = TrackArray()
        msg.header.stamp, msg.header.frame_id = stamp, "map"
        msg.tracks.append(Track(id=1, position=Point(S[0], S[1], 0.0)))
        self.tracks.publish(msg)
        rospy.sleep(0.3)
        return self._answer(1, stamp)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "predictor_handover", PredictorHandover)
