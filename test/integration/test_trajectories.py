#!/usr/bin/env python3
"""rostest node: trajectory recorder and viewer against a scripted pose publisher.

The scripted poses: pose k at stamp 1000 s + k * 50 ms (20 Hz), x = 0.1 k,
y = 2 + 0.5 sin(0.1 k), yaw = 0.01 k. With period 2 s a chunk closes at every 40th pose and
holds 41 (the boundary pose is shared with the next chunk).

* test_1: the recorder and viewer of trajectories.launch (trajectories.test): every published
  pose stored exactly once, live markers, SIGINT stores the open chunk, the viewer's paths and
  ~select.
* test_2: a recorder of its own, stopped with SIGTERM: the open chunk is stored.
* test_3: a recorder of its own whose embedded database is locked by another process (a real
  SQLite lock: the database cannot be written) while 300 poses arrive: its chunks go to the
  journal and are replayed when the lock is released; nothing lost, nothing stored twice.
* test_4: a database that stalls for 4 s (locked, the recorder waiting on it) while poses
  stamped with the current time arrive at 20 Hz, max_gap 2 s: one trajectory, every pose.
* test_5: a recorder killed with SIGKILL; the next one on the same database and topic stores
  what the first left in its spill file: every pose but at most the last flush window.
* test_6: a recorder of a people_msgs/People topic (the simulator's ground truth): each
  person's every position stored once, as its own trajectory, named in the meta.
"""
from __future__ import annotations

import math
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import xmlrpc.client

import rosgraph
import rospkg
import rospy
import rostest
from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import Path
from visualization_msgs.msg import Marker, MarkerArray

from bullet_floor_sim.data.store import default_journal_path, open_store
from bullet_floor_sim.data.store.journal import Journal
from bullet_floor_sim.data.trajectory import (COLLECTION, DATABASE, STORED_TYPE, join_chunks,
                                              path_length, select_chunks)
from bullet_floor_sim.msg import People, Person, Trajectory
from bullet_floor_sim.srv import SelectTrajectories, SelectTrajectoriesRequest

NS = 1000000000
T0 = 1000 * NS
DT = 50000000
TIMEOUT = 90.0  # generous: two cores shared with other test runs


def scripted(k):
    """(PoseStamped, the pose tuple the store must hold) of pose k."""
    t = T0 + k * DT
    yaw = 0.01 * k
    m = PoseStamped()
    m.header.frame_id = "map"
    m.header.stamp = rospy.Time(t // NS, t % NS)
    m.pose.position.x = 0.1 * k
    m.pose.position.y = 2.0 + 0.5 * math.sin(0.1 * k)
    m.pose.orientation.z = math.sin(yaw / 2)
    m.pose.orientation.w = math.cos(yaw / 2)
    return m, (t, m.pose.position.x, m.pose.position.y, 0.0, 0.0, 0.0, m.pose.orientation.z,
               m.pose.orientation.w)


def wait_for(condition, what, timeout=TIMEOUT):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("timed out after %.0f s waiting for %s" % (timeout, what))
        if rospy.is_shutdown():
            raise AssertionError("ROS shut down while waiting for %s" % what)
        time.sleep(0.05)


class Latest:
    """The messages of a topic, kept in arrival order."""

    def __init__(self, topic, cls):
        self.msgs = []
        self.lock = threading.Lock()
        self.sub = rospy.Subscriber(topic, cls, self._on, queue_size=None)

    def _on(self, msg):
        with self.lock:
            self.msgs.append(msg)

    @property
    def last(self):
        with self.lock:
            return self.msgs[-1] if self.msgs else None

    def __len__(self):
        with self.lock:
            return len(self.msgs)


def publish(pub, first, last, burst=100):
    """Publish poses first..last-1; return their tuples."""
    out = []
    for k in range(first, last):
        msg, tup = scripted(k)
        pub.publish(msg)
        out.append(tup)
        if (k + 1) % burst == 0:
            time.sleep(0.02)
    return out


def path_ends_at(latest, t_ns):
    def check():
        p = latest.last
        if p is None or not p.poses:
            return False
        s = p.poses[-1].header.stamp
        return s.secs * NS + s.nsecs == t_ns
    return check


def node_pid(name):
    uri = rosgraph.Master("/test_trajectories").lookupNode(name)
    code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/test_trajectories")
    assert code == 1, "getPid of %s failed" % name
    return pid


def stored(db, journal_dir=None):
    with open_store(db, journal_dir=journal_dir) as store:
        return select_chunks(store), store.find(DATABASE, COLLECTION, {})


class RecorderProcess:
    """A trajectory_recorder of the test's own (its own database, ROS_HOME and topic)."""

    def __init__(self, name, workdir, people=False, **params):
        self.name = name
        self.db = os.path.join(workdir, "db")
        self.ros_home = os.path.join(workdir, "ros_home")
        self.journal_dir = os.path.join(self.ros_home, "bullet_floor_sim", "journal")
        self.topic = "/%s/%s" % (name, "people" if people else "pose")
        self.log_path = os.path.join(workdir, name + ".log")
        os.makedirs(workdir, exist_ok=True)
        node = os.path.join(rospkg.RosPack().get_path("bullet_floor_sim"), "nodes",
                            "trajectory_recorder")
        params = dict({"max_gap": 0}, **params)
        topics = (["_people_topic:=" + self.topic, "_pose_topic:="] if people
                  else ["_pose_topic:=" + self.topic])
        args = [sys.executable, node, "__name:=" + name, "_db:=" + self.db,
                "_map:=office"] + topics
        args += ["_%s:=%s" % kv for kv in sorted(params.items())]
        with open(self.log_path, "wb") as log:
            self.proc = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT,
                                         env=dict(os.environ, ROS_HOME=self.ros_home))
        self.pub = rospy.Publisher(self.topic, People if people else PoseStamped,
                                   queue_size=100000)
        self.path = Latest("/%s/path" % name, Path)
        self.batch = Latest("/%s/trajectories/batch" % name, Trajectory)
        wait_for(lambda: self.pub.get_num_connections() > 0
                 and self.batch.sub.get_num_connections() > 0, "%s to subscribe%s"
                 % (name, self._exited()))

    def _exited(self):
        code = self.proc.poll()
        return "" if code is None else " (it exited with %s: %s)" % (code, self.log())

    def log(self):
        with open(self.log_path, "rb") as f:
            return f.read().decode("utf-8", "replace")[-3000:]

    def stop(self, sig):
        self.proc.send_signal(sig)
        try:
            return self.proc.wait(60)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            raise AssertionError("%s did not exit within 60 s of %s: %s"
                                 % (self.name, sig, self.log()))

    def close(self):
        for s in (self.path.sub, self.batch.sub):
            s.unregister()
        self.pub.unregister()
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


class Trajectories(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_trajectories")
        cls.db = rospy.get_param("~db")
        cls.tmp = tempfile.mkdtemp(prefix="bfs_traj_test_")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)
        shutil.rmtree(cls.db, ignore_errors=True)

    def check_meta(self, doc, name, taken="online"):
        meta = doc["_meta"]
        self.assertEqual((meta["map"], meta["taken"], meta["stored_type"], meta["inserted_by"]),
                         ("office", taken, STORED_TYPE, name))
        self.assertEqual(meta["stored_class"],
                         "human_trajectory.msg._Trajectory.Trajectory")

    def test_1_launch_records_every_pose_once_viewer_shows_them_sigint_stores_the_rest(self):
        pub = rospy.Publisher("/traj_test/pose", PoseStamped, queue_size=100000)
        batch = Latest("/trajectory_recorder/trajectories/batch", Trajectory)
        live = Latest("/trajectory_recorder/path", Path)
        markers = Latest("/trajectory_viewer/markers", MarkerArray)
        wait_for(lambda: pub.get_num_connections() > 0 and batch.sub.get_num_connections() > 0,
                 "the recorder to subscribe")
        published = publish(pub, 0, 1000)
        wait_for(path_ends_at(live, published[-1][0]), "the live path to reach the last pose")
        wait_for(lambda: len(batch) == 24, "24 chunks on ~trajectories/batch")
        msgs = batch.msgs
        self.assertEqual([m.sequence_id for m in msgs], list(range(24)))
        self.assertEqual({m.uuid for m in msgs}, {msgs[0].uuid})
        self.assertEqual({len(m.trajectory) for m in msgs}, {41})
        self.assertFalse(any(m.complete for m in msgs))
        want = path_length(published[40:81])
        self.assertAlmostEqual(msgs[1].trajectory_length, want, places=4)  # float32 field
        self.assertEqual(msgs[1].start_time.to_nsec(), published[40][0])
        self.assertEqual(msgs[1].end_time.to_nsec(), published[80][0])
        # the viewer read each announced chunk back: one line strip through 961 poses
        wait_for(lambda: markers.last is not None and len(markers.last.markers) == 2
                 and len(markers.last.markers[1].points) == 961, "the viewer's markers")
        m = markers.last.markers
        self.assertEqual((m[0].action, m[1].type, m[1].ns), (Marker.DELETEALL,
                                                             Marker.LINE_STRIP, "trajectories"))
        self.assertEqual(len(m[1].colors), 961)  # coloured by time: oldest blue, newest red
        self.assertGreater(m[1].colors[0].b, 0.9)
        self.assertGreater(m[1].colors[-1].r, 0.9)
        self.assertEqual((m[1].points[960].x, m[1].points[960].y), published[960][1:3])

        # SIGINT (what roslaunch sends): the open chunk (poses 960..999) is stored
        os.kill(node_pid("/trajectory_recorder"), signal.SIGINT)
        wait_for(lambda: any(c.complete for c in stored(self.db)[0]),
                 "the open chunk to be stored")
        chunks, docs = stored(self.db)
        self.assertEqual([(c.sequence_id, len(c.poses), c.complete) for c in chunks],
                         [(k, 41, False) for k in range(24)] + [(24, 40, True)])
        self.assertEqual(chunks[-1].closed_by, "end")
        joined = join_chunks(chunks)
        self.assertEqual(len(joined), 1)
        self.assertEqual(len(joined[0].poses), len(published))  # count published == stored
        self.assertEqual(joined[0].poses, published)            # ... and the same poses
        for d in docs:
            self.check_meta(d, "/trajectory_recorder")

        # the viewer on request: a Path per trajectory, and the selection service
        select = rospy.ServiceProxy("/trajectory_viewer/select", SelectTrajectories)
        select.wait_for_service(TIMEOUT)
        r = select(SelectTrajectoriesRequest(map_name="office", paths=True,
                                             color_by="trajectory"))
        self.assertTrue(r.success, r.message)
        self.assertEqual((r.count, r.uuids), (1, [msgs[0].uuid]))
        self.assertEqual(r.path_topics, ["/trajectory_viewer/paths/t_"
                                         + msgs[0].uuid.replace("-", "")])
        self.assertIn("1 trajectories (25 chunks, 1000 poses): map office", r.message)
        path = rospy.wait_for_message(r.path_topics[0], Path, timeout=TIMEOUT)
        self.assertEqual([p.header.stamp.to_nsec() for p in path.poses],
                         [p[0] for p in published])
        wait_for(lambda: len(markers.last.markers[1].points) == 1000
                 and not markers.last.markers[1].colors, "markers of the whole trajectory")
        r = select(SelectTrajectoriesRequest(since=1050.0))  # after the last chunk ended
        self.assertTrue(r.success)
        self.assertEqual((r.count, r.path_topics), (0, []))
        r = select(SelectTrajectoriesRequest(map_name="lab"))
        self.assertEqual(r.count, 0)
        r = select(SelectTrajectoriesRequest(person="person_1"))   # the walker names nobody
        self.assertEqual(r.count, 0)
        self.assertIn("person person_1", r.message)
        r = select(SelectTrajectoriesRequest(since=1010.0, until=1020.0))
        self.assertEqual(r.count, 1)
        self.assertIn("(7 chunks, 281 poses)", r.message)  # 1008-1010, ..., 1020-1022
        r = select(SelectTrajectoriesRequest(color_by="rainbow"))
        self.assertFalse(r.success)
        self.assertEqual(r.count, 1)  # unchanged
        self.assertEqual(r.message, "refused, selection unchanged: color_by 'rainbow': use "
                                    "time or trajectory")
        r = select(SelectTrajectoriesRequest(since=20.0, until=10.0))
        self.assertFalse(r.success)
        self.assertIn("since 20.0 is after until 10.0", r.message)
        for s in (batch.sub, live.sub, markers.sub):
            s.unregister()

    def test_2_sigterm_stores_the_open_chunk(self):
        rec = RecorderProcess("rec_term", os.path.join(self.tmp, "term"), period=100.0)
        try:
            published = publish(rec.pub, 0, 50)
            wait_for(path_ends_at(rec.path, published[-1][0]), "rec_term's live path")
            self.assertEqual(rec.stop(signal.SIGTERM), 0, rec.log())
            chunks, docs = stored(rec.db, rec.journal_dir)
            self.assertEqual([(c.sequence_id, c.complete, c.closed_by) for c in chunks],
                             [(0, True, "end")])
            self.assertEqual(chunks[0].poses, published)
            self.check_meta(docs[0], "/rec_term")
            self.assertIn("stored 1 chunks (50 poses", rec.log())
        finally:
            rec.close()

    def test_3_database_outage_in_the_middle_loses_nothing(self):
        rec = RecorderProcess("rec_outage", os.path.join(self.tmp, "outage"), period=1.0,
                              db_timeout=0.2, db_retry_interval=0.5)
        journal = Journal(default_journal_path(os.path.abspath(rec.db), rec.journal_dir))
        try:
            published = publish(rec.pub, 0, 200)  # chunks close at poses 20, 40, ..., 180
            wait_for(lambda: len(rec.batch) == 9, "9 chunks before the outage")
            self.assertEqual(len(stored(rec.db, rec.journal_dir)[0]), 9)
            # another process takes the database's write lock: nothing can be written
            blocker = sqlite3.connect(os.path.join(rec.db, DATABASE + ".sqlite3"),
                                      isolation_level=None, timeout=30)
            blocker.execute("BEGIN EXCLUSIVE")
            try:
                published += publish(rec.pub, 200, 500)  # chunks close at 200, ..., 480
                wait_for(lambda: len(rec.batch) == 24, "24 chunks (15 during the outage)")
                wait_for(path_ends_at(rec.path, published[-1][0]), "the live path")
                self.assertEqual(journal.count(), 15)  # every chunk of the outage journalled
            finally:
                blocker.execute("ROLLBACK")
                blocker.close()
            # the database is back: the next chunk stored replays the journal first
            k = 500
            deadline = time.monotonic() + TIMEOUT
            while journal.pending():
                self.assertLess(time.monotonic(), deadline, "journal not replayed: "
                                + rec.log())
                published += publish(rec.pub, k, k + 20)  # one more chunk each time
                k += 20
                time.sleep(0.3)
            n_chunks = (len(published) - 1) // 20  # closed at poses 20, 40, ...
            wait_for(lambda: len(rec.batch) == n_chunks, "%d chunks" % n_chunks)
            self.assertEqual(rec.stop(signal.SIGINT), 0, rec.log())
            self.assertFalse(journal.pending())
            chunks, docs = stored(rec.db, rec.journal_dir)
            keys = [(c.uuid, c.sequence_id) for c in chunks]
            self.assertEqual(len(keys), len(set(keys)))  # nothing stored twice
            self.assertEqual(len(chunks), n_chunks + 1)  # + the open chunk on SIGINT
            joined = join_chunks(chunks)
            self.assertEqual(len(joined), 1)
            self.assertEqual(joined[0].poses, published)  # nothing lost
            self.assertIn("journalling writes to", rec.log())
            # the 15 of the outage, and any stored within db_retry_interval after it
            replayed = re.search(r"reachable again; replayed (\d+) journalled writes", rec.log())
            self.assertIsNotNone(replayed, rec.log())
            self.assertGreaterEqual(int(replayed.group(1)), 15)
        finally:
            rec.close()


    def test_4_a_database_stall_is_not_a_gap(self):
        rec = RecorderProcess("rec_stall", os.path.join(self.tmp, "stall"), period=1.0,
                              max_gap=2.0, db_timeout=10.0)
        try:
            published = []

            def live(seconds):
                end = time.monotonic() + seconds
                while time.monotonic() < end:
                    msg, _ = scripted(len(published))
                    msg.header.stamp = rospy.Time.now()
                    rec.pub.publish(msg)
                    published.append(pose_tuple(msg))
                    time.sleep(0.05)

            live(2.5)
            blocker = sqlite3.connect(os.path.join(rec.db, DATABASE + ".sqlite3"),
                                      isolation_level=None, timeout=30)
            blocker.execute("BEGIN EXCLUSIVE")
            try:
                live(4.0)                      # the recorder's store waits on the lock
            finally:
                blocker.execute("ROLLBACK")
                blocker.close()
            live(2.0)
            wait_for(path_ends_at(rec.path, published[-1][0]), "rec_stall's live path")
            self.assertEqual(rec.stop(signal.SIGINT), 0, rec.log())
            chunks, _ = stored(rec.db, rec.journal_dir)
            joined = join_chunks(chunks)
            self.assertEqual([(j.complete, chunks[-1].closed_by) for j in joined],
                             [(True, "end")], rec.log())
            self.assertEqual(joined[0].poses, published)
            self.assertNotIn("no pose for", rec.log())
            rospy.loginfo("stall: %d poses in %d chunks, one trajectory", len(published),
                          len(chunks))
        finally:
            rec.close()

    def test_5_sigkill_loses_at_most_the_flush_window(self):
        work = os.path.join(self.tmp, "kill")
        rec = RecorderProcess("rec_kill", work, period=100.0, flush_every=0.5)
        try:
            published = publish(rec.pub, 0, 100)
            wait_for(path_ends_at(rec.path, published[-1][0]), "rec_kill's live path")
            time.sleep(1.5)                    # a flush (the timer ticks at 2 Hz)
            published += publish(rec.pub, 100, 105)
            rec.proc.kill()                    # SIGKILL: no shutdown hook runs
            rec.proc.wait()
        finally:
            rec.close()
        again = RecorderProcess("rec_kill", work, period=100.0, flush_every=0.5)
        try:
            self.assertEqual(again.stop(signal.SIGINT), 0, again.log())
            self.assertIn("recovered 1 chunks", again.log())
            chunks, _ = stored(again.db, again.journal_dir)
            self.assertEqual([(c.sequence_id, c.complete, c.closed_by) for c in chunks],
                             [(0, True, "recovered")])
            kept = chunks[0].poses
            self.assertGreaterEqual(len(kept), 100)          # all but the last flush window
            self.assertEqual(kept, published[:len(kept)])
            rospy.loginfo("sigkill: %d of %d published poses recovered", len(kept),
                          len(published))
        finally:
            again.close()

    def test_6_every_person_is_its_own_trajectory(self):
        rec = RecorderProcess("rec_people", os.path.join(self.tmp, "people"), people=True,
                              period=1.0)
        try:
            sent = {"ann": [], "bob": []}
            for k in range(60):                   # 20 Hz for 3 s: chunks close at 20 and 40
                t = T0 + k * DT
                msg = People()
                msg.header.frame_id = "map"
                msg.header.stamp = rospy.Time(t // NS, t % NS)
                for name, y in (("ann", 1.0), ("bob", 4.0)):
                    msg.people.append(Person(name=name, position=Point(0.1 * k, y, 0.0),
                                             velocity=Point(2.0, 0.0, 0.0), reliability=1.0))
                    # walking along +x: heading 0, the identity quaternion
                    sent[name].append((t, 0.1 * k, y, 0.0, 0.0, 0.0, 0.0, 1.0))
                rec.pub.publish(msg)
            wait_for(lambda: len(rec.batch) >= 4, "rec_people's 4 closed chunks")
            time.sleep(1.0)                       # the last messages arrive
            self.assertEqual(rec.stop(signal.SIGINT), 0, rec.log())
            chunks, docs = stored(rec.db, rec.journal_dir)
            person = {d["uuid"]: d["_meta"]["person"] for d in docs}
            joined = {person[j.uuid]: j for j in join_chunks(chunks)}
            self.assertEqual(sorted(joined), ["ann", "bob"])
            for name in ("ann", "bob"):
                self.assertEqual(joined[name].poses, sent[name])
                self.assertEqual(joined[name].chunks, 3)
                self.assertTrue(joined[name].complete)
            self.assertIn("every person of /rec_people/people", rec.log())
        finally:
            rec.close()


def pose_tuple(m):
    s = m.header.stamp
    return (s.secs * NS + s.nsecs, m.pose.position.x, m.pose.position.y, 0.0, 0.0, 0.0,
            m.pose.orientation.z, m.pose.orientation.w)


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_trajectories", Trajectories)
