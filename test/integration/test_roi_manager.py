#!/usr/bin/env python3
"""The ROI manager node against a fresh embedded store, as rviz and SOMA clients use it.

The node runs as a child process (rosrun, as roslaunch starts it) so the test can stop it with
SIGINT and start it again on the same database. Checked: /soma/map_info and /soma/query_rois
answer with worlds/office/rois.yaml exactly; an interactive-marker feedback message moving a
vertex changes the stored ROI (a new version, the old one kept) and /soma/roi_markers; the
menu's Delete Point / Add ROI / Delete ROI; a drag still unsaved when SIGINT arrives is saved
before exit; a restart keeps every edit (no reseeding from the file); `rois export` writes
what the store holds and `rois import` of an edited file reaches the running node; a drag
the database refuses (an SQLite trigger) is retried, and saved once it accepts.
"""
from __future__ import annotations

import os
import shutil
import signal
import sqlite3
import subprocess
import tempfile
import time
import unittest

import rospy
import rostest
import yaml
from std_msgs.msg import String
from visualization_msgs.msg import InteractiveMarkerFeedback, Marker, MarkerArray

from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.data.roi_store import RoiStore
from bullet_floor_sim.data.rois import load_rois
from bullet_floor_sim.data.store import open_store
from bullet_floor_sim.srv import MapInfo, SOMAQueryROIs

from helpers import wait_for

ROIS_FILE = os.path.join(worlds_dir(), "office", "rois.yaml")
FEEDBACK = "/soma_roi/1/feedback"
# menu entry ids as MenuHandler numbers them: Add Point, Delete Point, Add ROI, its types, ...
ADD_POINT, DELETE_POINT, ADD_ROI = 1, 2, 3


def settle():
    """InteractiveMarkerServer ignores feedback from a client other than the last one for 1 s
    after a marker is inserted (its two-clients rule): give new markers that second."""
    time.sleep(1.2)


def vertices(msg):
    return [(p.position.x, p.position.y) for p in msg.posearray.poses]


class RoiManagerTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_roi_manager")
        cls.tmp = tempfile.mkdtemp(prefix="bfs_rois_")
        cls.db = os.path.join(cls.tmp, "db")
        cls.proc = None
        cls.file_rois = load_rois(ROIS_FILE)
        cls.changed = []
        cls.markers = None
        rospy.Subscriber("/soma/rois_changed", String, lambda m: cls.changed.append(m.data))
        rospy.Subscriber("/soma/roi_markers", MarkerArray, cls._on_markers)
        cls.feedback = rospy.Publisher(FEEDBACK, InteractiveMarkerFeedback, queue_size=10)
        cls.start()

    @classmethod
    def tearDownClass(cls):
        cls.stop()
        shutil.rmtree(cls.tmp, ignore_errors=True)

    @classmethod
    def _on_markers(cls, msg):
        cls.markers = msg

    @classmethod
    def start(cls):
        cls.proc = subprocess.Popen(
            ["rosrun", "bullet_floor_sim", "roi_manager", "__name:=soma_roi_manager",
             "_world:=office", "_db:=" + cls.db, "_save_quiet:=0.5", "_save_max_wait:=2.0",
             "_sync_period:=0.5"], env=dict(os.environ, ROS_HOME=cls.tmp),
            start_new_session=True)
        rospy.wait_for_service("/soma/query_rois", timeout=60)
        cls.query = rospy.ServiceProxy("/soma/query_rois", SOMAQueryROIs)
        wait_for(lambda: cls.feedback.get_num_connections() > 0, 30, "the feedback subscriber")
        settle()


    @classmethod
    def stop(cls):
        if cls.proc and cls.proc.poll() is None:
            cls.proc.send_signal(signal.SIGINT)  # what roslaunch sends first
            try:
                cls.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(cls.proc.pid, signal.SIGKILL)
                cls.proc.wait()
                raise AssertionError("roi_manager ignored SIGINT for 15 s")
        # the service goes away with the node: wait until the master forgets it
        wait_for(lambda: not _service_up("/soma/query_rois"), 20, "the service to go away")

    def newest(self, roi_id=None):
        resp = self.query(query_type=0, returnmostrecent=True, roiconfigs=["1"],
                          roiids=[roi_id] if roi_id else [])
        return {r.id: r for r in resp.rois}

    def move(self, name, x, y):
        fb = InteractiveMarkerFeedback(client_id="/rviz/test", marker_name=name,
                                       event_type=InteractiveMarkerFeedback.POSE_UPDATE)
        fb.header.frame_id = "map"
        fb.pose.position.x, fb.pose.position.y = x, y
        fb.pose.orientation.w = 1.0
        self.feedback.publish(fb)

    def menu(self, name, entry):
        fb = InteractiveMarkerFeedback(client_id="/rviz/test", marker_name=name,
                                       event_type=InteractiveMarkerFeedback.MENU_SELECT,
                                       menu_entry_id=entry)
        fb.header.frame_id = "map"
        fb.pose.orientation.w = 1.0
        self.feedback.publish(fb)

    # -- the tests run in name order on one node / one database -------------------------------

    def test_1_services_answer_with_the_file_rois(self):
        info = rospy.ServiceProxy("/soma/map_info", MapInfo)(0)
        self.assertEqual(info.map_name, "office")
        listing = self.query(query_type=1)
        self.assertEqual(listing.configs, ["1"])
        self.assertEqual(listing.ids, [r.id for r in self.file_rois])
        got = self.newest()
        self.assertEqual(len(got), 15)
        for roi in self.file_rois:
            msg = got[roi.id]
            self.assertEqual((msg.type, msg.map_name, msg.config, msg.geotype),
                             (roi.type, "office", "1", "Polygon"))
            self.assertEqual(vertices(msg), roi.vertices)
        markers = wait_for(lambda: self.markers, 10, "/soma/roi_markers")
        labels = sorted(m.text for m in markers.markers if m.type == Marker.TEXT_VIEW_FACING)
        self.assertIn("15: kitchen", labels)
        self.assertEqual(len(labels), 15)

    def test_2_a_dragged_vertex_is_stored_as_a_new_version(self):
        before = vertices(self.newest("7")["7"])
        del self.changed[:]
        self.move("7_0", 9.5, 1.3)
        t0 = time.time()
        after = wait_for(lambda: (lambda v: v if v[0] == (9.5, 1.3) else None)(
            vertices(self.newest("7")["7"])), 10, "the dragged vertex in the store")
        rospy.loginfo("drag saved after %.2f s", time.time() - t0)
        self.assertEqual(after[1:], before[1:])
        answer = self.query(query_type=0, returnmostrecent=False, roiids=["7"])
        history = answer.rois
        self.assertEqual([vertices(h)[0] for h in history], [before[0], (9.5, 1.3)])
        # SOMA's unique_ids: one stored document id per ROI returned, a version each
        newest = self.query(query_type=0, returnmostrecent=True, roiids=["7"])
        self.assertEqual(len(answer.unique_ids), 2)
        self.assertEqual(len(set(answer.unique_ids)), 2)
        self.assertNotIn("7", answer.unique_ids)
        self.assertEqual(newest.unique_ids, answer.unique_ids[1:])
        wait_for(lambda: "1" in self.changed, 5, "/soma/rois_changed")
        line = wait_for(lambda: next((m for m in self.markers.markers
                                      if m.type == Marker.LINE_STRIP
                                      and abs(m.points[0].x - 9.5) < 1e-9), None), 5,
                        "the outline marker to follow the drag")
        self.assertAlmostEqual(line.points[0].y, 1.3)

    def test_3_menu_edits(self):
        n = len(vertices(self.newest("8")["8"]))
        self.menu("8_3", DELETE_POINT)
        wait_for(lambda: len(vertices(self.newest("8")["8"])) == n - 1, 10, "Delete Point")
        self.menu("8_0", ADD_POINT)
        wait_for(lambda: len(vertices(self.newest("8")["8"])) == n, 10, "Add Point")
        self.menu("15_0", ADD_ROI + 3)  # the third type of config/roi_types.yaml
        new = wait_for(lambda: self.newest().get("16"), 10, "Add ROI")
        self.assertEqual(new.type, "kitchen")
        self.assertEqual(len(vertices(new)), 4)
        settle()
        self.menu("16_0", ADD_ROI + 1 + len(yaml.safe_load(open(os.path.join(
            os.path.dirname(ROIS_FILE), "..", "..", "config", "roi_types.yaml")))["types"]))
        wait_for(lambda: "16" not in self.newest(), 10, "Delete ROI")
        # a triangle cannot lose a vertex: add one, then delete twice
        self.menu("15_0", ADD_ROI + 1)
        tri = wait_for(lambda: self.newest().get("17"), 10, "second Add ROI")
        settle()
        self.menu("17_0", DELETE_POINT)
        wait_for(lambda: len(vertices(self.newest("17")["17"])) == 3, 10, "Delete Point")
        settle()
        self.menu("17_0", DELETE_POINT)  # refused: a warning, the ROI keeps 3 vertices
        time.sleep(1.0)
        self.assertEqual(len(vertices(self.newest("17")["17"])), 3)
        self.assertEqual(len(vertices(tri)), 4)

    def test_4_sigint_saves_a_pending_drag_and_a_restart_keeps_every_edit(self):
        self.move("9_0", 17.7, 1.1)
        time.sleep(0.2)  # received, but the debounce (0.5 s) has not saved it yet
        self.stop()
        type(self).markers = None
        self.start()
        got = self.newest()
        self.assertEqual(vertices(got["9"])[0], (17.7, 1.1))
        self.assertEqual(vertices(got["7"])[0], (9.5, 1.3))
        self.assertIn("17", got)
        self.assertNotIn("16", got)
        self.assertEqual(len(got), 16)  # 15 from the file (none reseeded) + ROI 17

    def test_6_a_save_the_store_refuses_is_retried_not_called_invalid(self):
        before = vertices(self.newest("10")["10"])
        refuse = sqlite3.connect(os.path.join(self.db, "somadata.sqlite3"), isolation_level=None)
        refuse.execute('CREATE TRIGGER bfs_refuse BEFORE INSERT ON "docs:roi" '
                       "BEGIN SELECT RAISE(ABORT, 'refused by the test'); END")
        try:
            self.move("10_0", before[0][0] + 0.25, before[0][1])
            time.sleep(2.0)        # debounced, tried, refused by the database
            self.assertEqual(vertices(self.newest("10")["10"]), before)
        finally:
            refuse.execute("DROP TRIGGER bfs_refuse")
            refuse.close()
        # the saver retries (every 5 s) without another drag: the edit reaches the store
        moved = (before[0][0] + 0.25, before[0][1])
        wait_for(lambda: vertices(self.newest("10")["10"])[0] == moved, 15,
                 "the refused edit, retried")

    def test_5_export_and_import(self):
        out = os.path.join(self.tmp, "export.yaml")
        env = dict(os.environ, ROS_HOME=self.tmp)
        subprocess.check_call(["rosrun", "bullet_floor_sim", "rois", "export", "--db", self.db,
                               "--map", "office", "--config", "1", "-o", out], env=env)
        exported = {r.id: r for r in load_rois(out)}
        self.assertEqual({i: r.vertices for i, r in exported.items()},
                         {i: vertices(m) for i, m in self.newest().items()})
        doc = yaml.safe_load(open(out))
        doc["rois"] = [r for r in doc["rois"] if r["id"] != "17"]
        for r in doc["rois"]:
            if r["id"] == "15":
                r["type"] = "cafeteria"
        with open(out, "w") as f:
            yaml.safe_dump(doc, f)
        subprocess.check_call(["rosrun", "bullet_floor_sim", "rois", "import", out, "--db",
                               self.db, "--replace"], env=env)
        wait_for(lambda: self.newest()["15"].type == "cafeteria", 10, "the import")
        self.assertNotIn("17", self.newest())
        # the node reloaded it: its markers show the new type
        wait_for(lambda: self.markers and any(m.text == "15: cafeteria"
                                               for m in self.markers.markers), 10,
                 "the node to pick the import up")
        with open_store(self.db, journal_dir=os.path.join(self.tmp, "j2")) as store:
            history = RoiStore(store, "office").history("1", "17")
        # added, lost a vertex, deleted by the import: three versions, the last a deletion
        self.assertEqual([len(r.vertices) if r else None for _, r in history], [4, 3, None])


def _service_up(name):
    try:
        rospy.wait_for_service(name, timeout=0.2)
        return True
    except rospy.ROSException:
        return False


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "roi_manager", RoiManagerTest)
