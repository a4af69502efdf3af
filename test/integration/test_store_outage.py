#!/usr/bin/env python3
"""rostest node: demo.launch recording robot1's trajectory into MongoDB through a 60 s outage.

The test starts the wire-protocol MongoDB test server (test/unit/mongo_server.py) on the
port the launch file gives every node, subscribes to /robot1/pose as the recorder does, lets
a few chunks be stored, kills the server for 60 s (the recorder, the walker and the ROI
manager journal meanwhile), starts it again on the same data, then stops the simulator (a
required node: roslaunch stops the others, the recorder storing its open chunk) and reads
the stored chunks back: joined, their
poses are exactly the poses published between the first the recorder stored (it may have
subscribed a moment after the test) and the last the test received, each once, and no chunk
is stored twice.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading
import time
import unittest

import rospkg
import rospy
import rostest
from geometry_msgs.msg import PoseStamped

from bullet_floor_sim.data.store import open_store
from bullet_floor_sim.data.trajectory import join_chunks, select_chunks
from bullet_floor_sim.msg import Trajectory

sys.path.insert(0, os.path.join(rospkg.RosPack().get_path("bullet_floor_sim"), "test", "unit"))
from mongo_server import MongoServer, find_launcher  # noqa: E402

NS = 1000000000
OUTAGE_S = 60.0


def wait_for(condition, what, timeout):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("timed out after %.0f s waiting for %s" % (timeout, what))
        time.sleep(0.2)


def stamp_ns(msg):
    return msg.header.stamp.secs * NS + msg.header.stamp.nsecs


class StoreOutage(unittest.TestCase):
    def test_every_pose_stored_once_across_a_60s_outage(self):
        rospy.init_node("test_store_outage")
        home, port = rospy.get_param("~home"), int(rospy.get_param("~port"))
        launcher, why = find_launcher()
        self.assertIsNotNone(launcher, why)
        server = MongoServer(launcher, os.path.join(home, "mongo"), port=port).start(60)
        poses, chunks, lock = [], [], threading.Lock()

        def on_pose(msg):
            with lock:
                poses.append((stamp_ns(msg), msg.pose.position.x, msg.pose.position.y))

        sub = rospy.Subscriber("/robot1/pose", PoseStamped, on_pose, queue_size=None)
        rospy.Subscriber("/trajectory_recorder/trajectories/batch", Trajectory,
                         lambda m: chunks.append(m.sequence_id), queue_size=100)
        try:
            wait_for(lambda: len(chunks) >= 2, "two chunks stored before the outage", 120)
            server.kill()
            before = len(chunks)
            time.sleep(OUTAGE_S)
            during = len(chunks) - before
            self.assertGreaterEqual(during, 8)   # journalled, and published as stored
            server.start(60)
            time.sleep(15.0)            # the next chunk (5 s) replays the journal first
            # the simulator is required: roslaunch then stops every node, the recorder storing
            # its open chunk as it goes. It sends SIGINT to this test's process group too
            # (rospy takes it); rosnode runs in its own session so that it cannot die of it
            # before it exits (CI, session 45: "rosnode kill died with SIGINT"). roslaunch
            # kills this node 17 s after that SIGINT: the reads below must finish by then
            subprocess.run(["rosnode", "kill", "/simulator"], check=True, timeout=60,
                           stdout=subprocess.DEVNULL, start_new_session=True)
            time.sleep(2.0)
            sub.unregister()
            with open_store(server.uri, journal_dir=os.path.join(home, "check")) as store:
                wait_for(lambda: any(c.complete for c in select_chunks(store)),
                         "the recorder's last chunk", 60)
                stored = select_chunks(store)
            keys = [(c.uuid, c.sequence_id) for c in stored]
            self.assertEqual(len(keys), len(set(keys)), "a chunk stored twice")
            got = [(p[0], p[1], p[2]) for j in join_chunks(stored) for p in j.poses]
            self.assertEqual(len(got), len(set(p[0] for p in got)), "a pose stored twice")
            with lock:
                sent = list(poses)
            # the recorder subscribes on its own: it may have missed the first poses the test
            # received, never a later one
            start = max(sent[0][0], got[0][0])
            sent = [p for p in sent if p[0] >= start]
            self.assertGreater(len(sent), 1000)
            window = [p for p in got if start <= p[0] <= sent[-1][0]]
            self.assertEqual(window, sent)
            rospy.loginfo("store outage: %d poses published in the window, %d chunks stored "
                          "(%d during the %.0f s outage), every pose once", len(sent),
                          len(stored), during, OUTAGE_S)
        finally:
            server.stop()
            shutil.rmtree(os.path.join(home, "mongo"), ignore_errors=True)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_store_outage", StoreOutage)
