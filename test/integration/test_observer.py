#!/usr/bin/env python3
"""The observer robot end to end (see observer.test)."""
from __future__ import annotations

import bisect
import json
import math
import shutil
import threading
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry
from std_msgs.msg import String

from bullet_floor_sim.msg import Destination, TrackArray

from helpers import wait_for

ROI_IDS = {str(i) for i in range(1, 16)}


class Observer(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_observer")
        cls.home = rospy.get_param("~home")
        cls.lock = threading.Lock()
        cls.gt_t, cls.gt_xy = [], []          # robot1 ground truth
        cls.robot2 = []                       # robot2 ground truth (x, y)
        cls.tracks, cls.dests, cls.legs, cls.modes = [], [], [], []
        rospy.Subscriber("/robot1/base_pose_ground_truth", Odometry, cls._on_gt,
                         queue_size=100)
        rospy.Subscriber("/robot2/base_pose_ground_truth", Odometry, cls._on_robot2,
                         queue_size=10)
        rospy.Subscriber("/robot2/people_tracker/track_list", TrackArray,
                         lambda m: cls._add(cls.tracks, m), queue_size=100)
        rospy.Subscriber("/robot2/destination_predictor/destination", Destination,
                         lambda m: cls._add(cls.dests, m), queue_size=100)
        rospy.Subscriber("/robot1/markov_walker/leg", String,
                         lambda m: cls._add(cls.legs, json.loads(m.data)))
        rospy.Subscriber("/robot2/follower/mode", String, lambda m: cls._add(cls.modes, m.data))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.home, ignore_errors=True)

    @classmethod
    def _add(cls, bucket, item):
        with cls.lock:
            bucket.append(item)

    @classmethod
    def _on_gt(cls, m):
        with cls.lock:
            cls.gt_t.append(m.header.stamp.to_sec())
            cls.gt_xy.append((m.pose.pose.position.x, m.pose.pose.position.y))

    @classmethod
    def _on_robot2(cls, m):
        with cls.lock:
            cls.robot2.append((m.pose.pose.position.x, m.pose.pose.position.y))

    def gt_at(self, t):
        with self.lock:
            k = bisect.bisect_left(self.gt_t, t)
            if k >= len(self.gt_t) or abs(self.gt_t[k] - t) > 0.06:
                return None
            return self.gt_xy[k]

    def test_1_tracker_follows_robot1_with_one_main_track(self):
        wait_for(lambda: len(self.tracks) > 400, 200, "400 track lists (40 s sim)")
        with self.lock:
            lists = list(self.tracks)
        errors, with_robot1, false_tracks, where = [], 0, 0, []
        for msg in lists:
            gt = self.gt_at(msg.header.stamp.to_sec())
            if gt is None:
                continue
            self.assertEqual(msg.header.frame_id, "map")
            near = [math.hypot(t.position.x - gt[0], t.position.y - gt[1]) for t in msg.tracks]
            if near and min(near) < 0.5:
                with_robot1 += 1
                errors.append(min(near))
            false_tracks += sum(1 for d in near if d >= 1.0)
            where += ["t=%.1f id %d (%.2f, %.2f) hits %d, robot1 (%.2f, %.2f)" % (
                msg.header.stamp.to_sec(), t.id, t.position.x, t.position.y, t.hits, gt[0],
                gt[1]) for t, d in zip(msg.tracks, near) if d >= 1.0]
        self.assertGreater(len(errors), 100, "robot1 tracked in only %d track lists of %d"
                           % (len(errors), len(lists)))
        errors.sort()
        median = errors[len(errors) // 2]
        self.assertLess(median, 0.15, "median track error %.3f m" % median)
        # no (or hardly any) tracks on the static walls
        self.assertLess(false_tracks, 0.05 * len(lists), "%d false tracks, e.g. %s" % (
            false_tracks, "; ".join(where[::max(1, len(where) // 8)])))

    def test_2_destinations_are_distributions_over_the_rois(self):
        wait_for(lambda: len(self.dests) > 20, 120, "20 destination messages")
        with self.lock:
            dests = list(self.dests)
            tracks = {m.header.stamp: m for m in self.tracks}
        standing = 0
        for d in dests:
            self.assertAlmostEqual(sum(d.probabilities), 1.0, places=6)
            self.assertEqual(list(d.probabilities), sorted(d.probabilities, reverse=True))
            self.assertEqual(d.best, d.regions[0])
            self.assertAlmostEqual(d.best_probability, d.probabilities[0])
            self.assertLessEqual(set(d.regions), ROI_IDS)
            self.assertIn(d.start_region, ROI_IDS)
            self.assertGreaterEqual(d.observed, 0.0)
            at = [t.position for t in getattr(tracks.get(d.header.stamp), "tracks", ())
                  if t.id == d.track_id]
            if not d.under_way and at:
                # standing: the next leg from where it stands; it is under way once the track
                # is min_progress (0.3 m) from there. ``observed`` is the path walked since it
                # stood, jitter included, so at least that distance (0.354 m was seen while
                # the track stayed within 0.3 m)
                away = math.hypot(at[0].x - d.start.x, at[0].y - d.start.y)
                self.assertLess(away, 0.3, d)
                self.assertGreaterEqual(d.observed, away - 1e-6, d)
                standing += 1
            # a search point for every region, in the regions' order: the first at
            # best_point, every one on the map
            self.assertEqual(len(d.points), len(d.regions))
            self.assertEqual((d.points[0].x, d.points[0].y), (d.best_point.x, d.best_point.y))
            for pt in d.points:
                self.assertTrue(0.0 < pt.x < 30.0 and 0.0 < pt.y < 20.0, pt)
        self.assertGreater(standing, 0, "no prediction made while robot1 stood")

    def test_3_a_leg_is_predicted_right_before_it_ends(self):
        """Of the walker's completed legs seen by the predictor, the last prediction made
        before the leg ended names its destination for at least one of the first three."""
        def judged():
            with self.lock:
                legs = [leg for leg in self.legs if leg["outcome"] == "succeeded"]
                dests = list(self.dests)
            out = []
            for leg in legs:
                end = leg["started"] + leg["duration"]
                during = [d for d in dests if leg["started"] <= d.header.stamp.to_sec() <= end]
                if during:
                    out.append((leg["to"], during[-1].best))
            return out if len(out) >= 3 else None
        out = wait_for(judged, 240, "three completed legs with predictions")
        self.assertTrue(any(to == best for to, best in out[:3]), out)

    def test_4_follower_follows(self):
        wait_for(lambda: "follow" in self.modes, 60, "the follower in follow mode")
        with self.lock:
            path = list(self.robot2)
        moved = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(path, path[1:]))
        self.assertGreater(moved, 1.0, "robot2 moved %.2f m" % moved)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "observer", Observer)
