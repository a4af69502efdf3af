#!/usr/bin/env python3
"""The Markov walker in the office world with the embedded navigation (walker_builtin.test).

* it reaches at least 4 distinct regions, each leg's target is a region the chain allows from
  where the leg started, and a reached goal leaves the robot inside its target region;
* every ``~current_region`` message names the region that ``data.rois.roi_at`` gives for the
  ground-truth pose (``/pose``) at that moment, and the topic runs at 1 Hz;
* the leg log lines ("leg 7: office 7 -> corridor 1 in 23.4 s; dwelling 1.2 s") reach /rosout;
* the chain is published (an arrow per transition, width 0.4 x probability) and stored in
  markov_chain_db.roi_proba_connexions_office, equal to the chain of worlds/office/rois.yaml;
* deleting an ROI in the store makes the ROI manager announce it and the walker rebuild and
  re-store the chain without it.
"""
from __future__ import annotations

import bisect
import json
import os
import re
import tempfile
import threading
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Log
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from bullet_floor_sim.people.markov import MarkovChain, load_chain
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.data.roi_store import RoiStore
from bullet_floor_sim.data.rois import load_rois, roi_at
from bullet_floor_sim.data.store import open_store

from helpers import wait_for

OFFICE_ROIS = os.path.join(worlds_dir(), "office", "rois.yaml")
LEG_LINE = re.compile(r"^markov_walker: leg (\d+): (.+) -> (.+) in (\d+\.\d) s; dwelling "
                      r"(\d+\.\d) s$")


class TestMarkovWalker(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_walker")
        cls.db = rospy.get_param("~db")
        cls.rois = load_rois(OFFICE_ROIS)
        cls.chain = MarkovChain.from_rois(cls.rois)
        cls.lock = threading.Lock()
        cls.poses = []      # (receive time, region by roi_at) from the ground truth
        cls.regions = []    # (receive time, ~current_region)
        cls.legs = []       # ~leg JSON objects
        cls.lines = []      # the walker's leg log lines from /rosout
        cls.chains = []     # ~chain MarkerArrays
        rospy.Subscriber("/pose", PoseStamped, cls._on_pose, queue_size=100)
        rospy.Subscriber("/markov_walker/current_region", String, cls._on_region,
                         queue_size=100)
        rospy.Subscriber("/markov_walker/leg", String, cls._on_leg, queue_size=100)
        rospy.Subscriber("/markov_walker/chain", MarkerArray, cls._on_chain, queue_size=10)
        rospy.Subscriber("/rosout", Log, cls._on_log, queue_size=500)

    @classmethod
    def _on_pose(cls, msg):
        t = rospy.get_time()
        if t <= 0.0:  # before this node's first /clock: no time to compare by
            return
        roi = roi_at(cls.rois, msg.pose.position.x, msg.pose.position.y)
        with cls.lock:
            cls.poses.append((t, roi.id if roi else ""))

    @classmethod
    def _on_region(cls, msg):
        t = rospy.get_time()
        if t <= 0.0:  # before this node's first /clock (the 1 Hz repeat comes again)
            return
        with cls.lock:
            cls.regions.append((t, msg.data))

    @classmethod
    def _on_leg(cls, msg):
        with cls.lock:
            cls.legs.append(json.loads(msg.data))

    @classmethod
    def _on_chain(cls, msg):
        with cls.lock:
            cls.chains.append(msg)

    @classmethod
    def _on_log(cls, msg):
        if msg.name == "/markov_walker" and msg.msg.startswith("markov_walker: leg "):
            with cls.lock:
                cls.lines.append(msg.msg)

    def reached(self):
        with self.lock:
            return {leg["to"] for leg in self.legs if leg["outcome"] == "succeeded"}

    def test_1_walks_between_regions_and_knows_where_it_is(self):
        wait_for(lambda: len(self.reached()) >= 4, 300, "legs reaching 4 distinct regions")
        with self.lock:
            legs, regions, poses = list(self.legs), list(self.regions), list(self.poses)
            lines = list(self.lines)
        self.assertGreaterEqual(len(self.reached()), 4, legs)
        # legs follow the chain and end inside their region
        for leg in legs:
            if leg["from"]:
                self.assertGreater(self.chain.probability(leg["from"], leg["to"]), 0.0, leg)
            self.assertEqual(leg["outcome"], "succeeded", leg)
            self.assertEqual(leg["end_region"], leg["to"], leg)
            self.assertGreater(leg["duration"], 0.0, leg)
        for prev, leg in zip(legs, legs[1:]):
            self.assertEqual(leg["leg"], prev["leg"] + 1)
            self.assertEqual(leg["from"], prev["end_region"])
        # one log line per leg, naming its regions and time
        labels = {r.id: "%s %s" % (r.type, r.id) for r in self.rois}
        parsed = [LEG_LINE.match(line) for line in lines]
        self.assertTrue(all(parsed), lines)
        by_number = {int(m.group(1)): m for m in parsed}
        for leg in legs:
            m = by_number.get(leg["leg"])
            if m is None:  # /rosout may lag behind ~leg by a message
                continue
            self.assertEqual((m.group(2), m.group(3)),
                             (labels.get(leg["from"], "none"), labels[leg["to"]]))
            self.assertAlmostEqual(float(m.group(4)), leg["duration"], delta=0.051)
            self.assertTrue(1.0 <= float(m.group(5)) <= 2.0)
        self.assertGreaterEqual(len(by_number), len(legs) - 1)
        # ~current_region against the ground truth: the region of a pose received within
        # 1.5 s of sim time before the message (the walker's own pose message, and latency
        # under load at 4x real time) or 0.3 s after it
        self.assertGreater(len(regions), 30)
        times = [t for t, _ in poses]
        exact = 0
        for t, region in regions:
            lo = bisect.bisect_left(times, t - 1.5)
            hi = bisect.bisect_right(times, t + 0.3)
            near = {r for _, r in poses[lo:hi]}
            self.assertIn(region, near, "current_region %r at t=%.2f; ground truth near then: "
                                        "%s" % (region, t, sorted(near)))
            k = bisect.bisect_right(times, t) - 1
            exact += k >= 0 and poses[k][1] == region
        self.assertGreaterEqual(exact, 0.9 * len(regions))
        # it names every region it passed through, not only the legs' targets
        seen = {r for _, r in regions}
        self.assertTrue(self.reached() <= seen, (self.reached(), seen))
        # and repeats at 1 Hz (sim time) between changes
        span = regions[-1][0] - regions[0][0]
        self.assertGreaterEqual(len(regions), 0.8 * span)

    def test_2_chain_is_published_and_stored(self):
        wait_for(lambda: self.chains, 30, "the latched ~chain MarkerArray")
        markers = self.chains[0].markers
        self.assertEqual(markers[0].action, Marker.DELETEALL)
        arrows = [m for m in markers if m.ns == "chain_arrows"]
        labels = [m for m in markers if m.ns == "chain_labels"]
        expected = sorted(0.4 * p for i in self.chain.ids for j, p in self.chain.row(i).items()
                          if j != i)
        self.assertEqual(len(arrows), 28)
        self.assertEqual(len(expected), 28)
        np.testing.assert_allclose(sorted(m.scale.x for m in arrows), expected, atol=1e-9)
        self.assertEqual(len(labels), 15)
        self.assertIn("office 5\nstay 0.83", [m.text for m in labels])
        with tempfile.TemporaryDirectory() as journal, \
                open_store(self.db, journal_dir=journal) as store:
            stored = load_chain(store, "office")
            docs = store.find("markov_chain_db", "roi_proba_connexions_office")
        self.assertEqual(stored.ids, self.chain.ids)
        np.testing.assert_allclose(stored.matrix, self.chain.matrix, atol=1e-12)
        self.assertEqual({d["built_by"] for d in docs}, {"/markov_walker"})
        self.assertEqual(len(docs), 15)

    def test_3_deleting_a_roi_rebuilds_the_chain(self):
        wait_for(lambda: self.chains, 30, "the latched ~chain MarkerArray")
        with self.lock:
            before = len(self.chains)
        with tempfile.TemporaryDirectory() as journal, \
                open_store(self.db, journal_dir=journal) as store:
            RoiStore(store, "office", inserted_by="/test_walker").delete("1", "11")  # office_6
            # the ROI manager picks the change up (sync every 2 s), announces it on
            # /soma/rois_changed, and the walker rebuilds, republishes and re-stores the chain
            wait_for(lambda: len(self.chains) > before, 60, "a rebuilt ~chain")
            fewer = [r for r in self.rois if r.id != "11"]
            expected = MarkovChain.from_rois(fewer)
            labels = [m for m in self.chains[-1].markers if m.ns == "chain_labels"]
            self.assertEqual(len(labels), 14)

            def restored():
                try:
                    return load_chain(store, "office").ids == expected.ids
                except Exception:
                    return False

            wait_for(restored, 30, "the rebuilt chain in the store")
            chain = load_chain(store, "office")
        self.assertEqual(chain.row("1"), expected.row("1"))
        # corridor_west lost office_6: candidates {1, 2, 5, 6, 10}, n = 4, 6, 1, 1, 1, S = 13
        self.assertAlmostEqual(chain.probability("1", "1"), (1 - 4 / 13) / 4)
        self.assertNotIn("11", chain.ids)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_walker", TestMarkovWalker)
