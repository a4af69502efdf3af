"""ROI manager node: SOMA's ROI services and rviz editing over the document store.

``rosrun bullet_floor_sim roi_manager _world:=office _db:=URI``

* ``/soma/map_info`` (MapInfo) and ``/soma/query_rois`` (SOMAQueryROIs), SOMA's names and
  fields, answered from the store (:mod:`bullet_floor_sim.data.roi_store`).
* One InteractiveMarkerServer per config at ``soma_roi/<config>`` (feedback on
  ``/soma_roi/<config>/feedback``): a sphere per vertex named ``<roi id>_<vertex index>`` with
  a MOVE_PLANE control, an outline ``<roi id>_outline``, and a right-click menu Add Point /
  Delete Point / Add ROI (types from ``~types``) / Delete ROI.
* Drags are saved once the vertex rests for ``~save_quiet`` s (and at the latest
  ``~save_max_wait`` s into a long drag), each as a new version; menu edits are saved at
  once; pending edits are saved at shutdown. A polygon made self-intersecting by a drag is
  not saved (warning) until it is valid again. An edit the store refuses (not an outage:
  those are journalled) is reported as a store error and retried every 5 s; nothing one
  save raises stops the saver.
* ``/soma/roi_markers`` (latched MarkerArray: outline and "id: type" label of every ROI) and
  ``/soma/rois_changed`` (std_msgs/String: the config, after every saved change).
* ``/soma/map`` (latched OccupancyGrid of the world's map, as soma_map_manager publishes it),
  so rviz shows the map without a simulator or map_server (``~publish_map``).
* At start, the world's rois.yaml (``~rois_file`` overrides) seeds the store when the store
  has no ROI for its map and config; afterwards the store is the truth. Changes written by
  others (``rosrun bullet_floor_sim rois import``) are picked up every ``~sync_period`` s (0: never).
"""
from __future__ import annotations

import colorsys
import functools
import hashlib
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

import rospy
from geometry_msgs.msg import Point, Quaternion
from nav_msgs.msg import OccupancyGrid
from interactive_markers.interactive_marker_server import InteractiveMarkerServer
from interactive_markers.menu_handler import MenuHandler
from std_msgs.msg import ColorRGBA, String
from visualization_msgs.msg import (InteractiveMarker, InteractiveMarkerControl,
                                    InteractiveMarkerFeedback, Marker, MarkerArray)

from bullet_floor_sim.data import roi_edits as edits
from bullet_floor_sim.data import roi_store as rs
from bullet_floor_sim.sim.config import load_world_config, resolve_world
from bullet_floor_sim.errors import BulletFloorSimError
from bullet_floor_sim.sim.floormap import load_map
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.data.rois import Roi, RoiError, centroid, check_bounds, load_rois
from bullet_floor_sim.data.store import StoreError, StoreUnavailable, open_store
from bullet_floor_sim.ros.convert import occupancy_grid
from bullet_floor_sim.ros.soma import document_to_msg
from bullet_floor_sim.ros.node import run_node
from bullet_floor_sim.ros.params import check_params, config_from_params
from bullet_floor_sim.srv import (MapInfo, MapInfoResponse, SOMAQueryROIs,
                                  SOMAQueryROIsResponse)

DEFAULT_TYPES = ["office", "corridor", "kitchen", "lab", "meeting_room", "toilet", "stairs",
                 "lift", "reception"]
Key = Tuple[str, str]  # (config, roi id)


def type_color(roi_type: str, alpha: float = 1.0) -> ColorRGBA:
    """A stable colour per ROI type (hue from a hash of the name)."""
    hue = int(hashlib.md5(roi_type.encode("utf-8")).hexdigest()[:6], 16) / float(0xFFFFFF)
    r, g, b = colorsys.hsv_to_rgb(hue, 0.75, 0.9)
    return ColorRGBA(r, g, b, alpha)


# --------------------------------------------------------------------------------------------
# the node
# --------------------------------------------------------------------------------------------


#: Seconds between attempts to save an edit the store refused.
_RETRY_S = 5.0


@dataclass
class RoiManagerParams:
    """The node's parameters (``~<field>``: see the module doc), checked."""

    frame_id: str = "map"
    types: list = field(default_factory=lambda: list(DEFAULT_TYPES))
    new_roi_size: float = 1.0
    sync_period: float = 2.0
    save_quiet: float = 1.0
    save_max_wait: float = 3.0
    publish_map: bool = True
    map_name: str = ""             # "": the seed file's map, else office
    db: str = ""
    rois_file: str = ""
    world: str = "office"

    def check(self) -> None:
        """Raises BulletFloorSimError naming the bad parameter."""
        check_params(self, "roi_manager", ("new_roi_size", "save_max_wait"))
        check_params(self, "roi_manager", ("save_quiet",), strict=False)
        check_params(self, "roi_manager", ("sync_period",), least=None)   # 0 or less: no sync


class RoiManagerNode:
    """The ROI manager; see the module docstring."""

    def __init__(self) -> None:
        p = self.params = config_from_params(RoiManagerParams())
        self.frame_id = p.frame_id
        self.types = [str(t) for t in p.types] or list(DEFAULT_TYPES)
        self.new_roi_size = p.new_roi_size
        self.sync_period = p.sync_period
        self.debouncer = edits.Debouncer(p.save_quiet, p.save_max_wait)
        self.fmap = None
        seed_rois, bounds = self._seed_file()
        if self.fmap is not None and p.publish_map:
            self.map_pub = rospy.Publisher("/soma/map", OccupancyGrid, queue_size=1, latch=True)
            self.map_pub.publish(occupancy_grid(self.fmap, self.frame_id))
        self.map_name = p.map_name or (seed_rois[0].map_name if seed_rois else "office")
        self.store = open_store(p.db or None)
        rospy.loginfo("roi_manager: ROIs of map %s in %s (%s)", self.map_name,
                      self.store.shown_uri, self.store.kind)
        self.rois_db = rs.RoiStore(self.store, self.map_name, inserted_by=rospy.get_name())
        self.lock = threading.RLock()
        self.rois: Dict[Key, Roi] = {}
        self.known: Dict[Key, int] = {}        # newest stored version we know of
        self.invalid: Dict[Key, str] = {}      # edits not saved: the polygon is invalid
        self.unsaved: Dict[Key, str] = {}      # edits the store refused: retried
        self.servers: Dict[str, InteractiveMarkerServer] = {}
        self.menus: Dict[str, MenuHandler] = {}
        self.menu_actions: Dict[str, Dict[int, Tuple[str, str]]] = {}
        self.markers_pub = rospy.Publisher("/soma/roi_markers", MarkerArray, queue_size=1,
                                           latch=True)
        self.changed_pub = rospy.Publisher("/soma/rois_changed", String, queue_size=10)

        self._load(seed_rois, bounds)
        rospy.Service("/soma/map_info", MapInfo, self._map_info)
        rospy.Service("/soma/query_rois", SOMAQueryROIs, self._query)
        self._stop = threading.Event()
        self._worker = threading.Thread(target=self._run, name="roi_saver", daemon=True)
        self._worker.start()
        rospy.on_shutdown(self._shutdown)

    # -- start-up -------------------------------------------------------------------------------

    def _seed_file(self) -> Tuple[List[Roi], Optional[Tuple[float, float, float, float]]]:
        """The ROIs that seed the store (``~rois_file`` or the world's) and the map bounds."""
        rois_file, world = self.params.rois_file, self.params.world
        bounds = None
        if world:
            cfg = load_world_config(resolve_world(world, worlds_dir()))
            self.fmap = load_map(cfg.map_yaml)
            bounds = self.fmap.bounds()
            rois_file = rois_file or (cfg.rois or "")
        if not rois_file:
            rospy.logwarn("roi_manager: no ROI file to seed from (world %r has no rois:)", world)
            return [], bounds
        rois = load_rois(rois_file)
        for warning in check_bounds(rois, bounds) if bounds else []:
            rospy.logwarn("roi_manager: %s: %s", rois_file, warning)
        return rois, bounds

    def _load(self, seed_rois: List[Roi], bounds: Any) -> None:
        while not rospy.is_shutdown():
            try:
                if seed_rois and self.rois_db.seed(seed_rois):
                    rospy.loginfo("roi_manager: seeded %d ROIs of config %s from the world's "
                                  "ROI file", len(seed_rois), seed_rois[0].config)
                current = self.rois_db.current()
                versions = self.rois_db.versions()
                break
            except StoreUnavailable as e:
                rospy.logwarn_throttle(10.0, "roi_manager: %s; retrying" % e)
                time.sleep(1.0)
        else:
            return
        with self.lock:
            self.rois = {(r.config, r.id): r for r in current}
            self.known = versions
            configs = sorted({c for c, _ in versions} | ({seed_rois[0].config}
                                                          if seed_rois else set()))
            for config in configs:
                self._server(config)
                self._rebuild_config(config)
            self._publish_markers()
        rospy.loginfo("roi_manager: %d ROIs in config(s) %s", len(current), ", ".join(configs))

    # -- services -------------------------------------------------------------------------------

    def _map_info(self, _req: Any) -> MapInfoResponse:
        return MapInfoResponse(map_name=self.map_name, map_unique_id=self.map_name)

    def _query(self, req: Any) -> SOMAQueryROIsResponse:
        try:
            result = self.rois_db.query(rs.RoiQuery.from_request(req))
        except (BulletFloorSimError, StoreUnavailable) as e:
            rospy.logerr("roi_manager: /soma/query_rois: %s", e)
            raise rospy.ServiceException(str(e))
        return SOMAQueryROIsResponse(configs=result["configs"], ids=result["ids"],
                                     unique_ids=[str(d["_id"]) for d in result["rois"]],
                                     rois=[document_to_msg(d) for d in result["rois"]],
                                     queryjson=result["queryjson"])

    # -- interactive markers --------------------------------------------------------------------

    def _server(self, config: str) -> InteractiveMarkerServer:
        if config not in self.servers:
            self.servers[config] = InteractiveMarkerServer("soma_roi/" + config)
            menu = MenuHandler()
            cb = functools.partial(self._feedback, config)
            actions: Dict[int, Tuple[str, str]] = {}
            actions[menu.insert("Add Point", callback=cb)] = ("add_point", "")
            actions[menu.insert("Delete Point", callback=cb)] = ("delete_point", "")
            add_roi = menu.insert("Add ROI")
            for t in self.types:
                actions[menu.insert(t, parent=add_roi, callback=cb)] = ("add_roi", t)
            actions[menu.insert("Delete ROI", callback=cb)] = ("delete_roi", "")
            self.menus[config] = menu
            self.menu_actions[config] = actions
        return self.servers[config]

    def _vertex_marker(self, roi: Roi, k: int) -> InteractiveMarker:
        x, y = roi.vertices[k]
        im = InteractiveMarker()
        im.header.frame_id = self.frame_id
        im.name = "%s_%d" % (roi.id, k)
        im.description = roi.id if k == 0 else ""
        im.scale = 0.5
        im.pose.position = Point(x, y, 0.0)
        im.pose.orientation.w = 1.0
        sphere = Marker(type=Marker.SPHERE, color=type_color(roi.type))
        sphere.scale.x = sphere.scale.y = sphere.scale.z = 0.25
        sphere.pose.orientation.w = 1.0
        control = InteractiveMarkerControl()
        control.name = "move_plane"
        control.orientation = Quaternion(0.0, 0.70710678, 0.0, 0.70710678)  # normal = z
        control.interaction_mode = InteractiveMarkerControl.MOVE_PLANE
        control.always_visible = True
        control.markers.append(sphere)
        im.controls.append(control)
        return im

    def _outline_marker(self, roi: Roi) -> InteractiveMarker:
        im = InteractiveMarker()
        im.header.frame_id = self.frame_id
        im.name = "%s_outline" % roi.id
        im.scale = 1.0
        im.pose.orientation.w = 1.0
        line = Marker(type=Marker.LINE_STRIP, color=type_color(roi.type))
        line.scale.x = 0.05
        line.pose.orientation.w = 1.0
        line.points = [Point(x, y, 0.02) for x, y in roi.vertices + roi.vertices[:1]]
        control = InteractiveMarkerControl(interaction_mode=InteractiveMarkerControl.NONE,
                                           always_visible=True)
        control.markers.append(line)
        im.controls.append(control)
        return im

    def _rebuild_roi(self, key: Key, old_vertices: int = 0) -> None:
        """(Re)insert every marker of one ROI; erase the ones of removed vertices."""
        config, roi_id = key
        server = self._server(config)
        roi = self.rois.get(key)
        count = len(roi.vertices) if roi else 0
        for k in range(count, old_vertices):
            server.erase("%s_%d" % (roi_id, k))
        if roi is None:
            server.erase("%s_outline" % roi_id)
        else:
            for k in range(count):
                marker = self._vertex_marker(roi, k)
                server.insert(marker, functools.partial(self._feedback, config),
                              InteractiveMarkerFeedback.POSE_UPDATE)
                self.menus[config].apply(server, marker.name)
            server.insert(self._outline_marker(roi))
        server.applyChanges()

    def _rebuild_config(self, config: str) -> None:
        server = self._server(config)
        server.clear()
        for key in sorted(k for k in self.rois if k[0] == config):
            self._rebuild_roi(key)
        server.applyChanges()

    def _feedback(self, config: str, fb: InteractiveMarkerFeedback) -> None:
        roi_id, _, index = fb.marker_name.rpartition("_")
        if not index.isdigit():
            return
        key, k = (config, roi_id), int(index)
        with self.lock:
            roi = self.rois.get(key)
            if roi is None or k >= len(roi.vertices):
                return
            try:
                if fb.event_type == InteractiveMarkerFeedback.POSE_UPDATE:
                    self._moved(key, roi, k, fb.pose.position.x, fb.pose.position.y)
                elif fb.event_type == InteractiveMarkerFeedback.MENU_SELECT:
                    action = self.menu_actions[config].get(fb.menu_entry_id)
                    if action:
                        self._menu(key, roi, k, action, fb)
            except BulletFloorSimError as e:
                rospy.logwarn("roi_manager: %s", e)

    def _moved(self, key: Key, roi: Roi, k: int, x: float, y: float) -> None:
        if roi.vertices[k] == (x, y):
            return
        self.rois[key] = edits.move_vertex(roi, k, x, y)
        self.servers[key[0]].insert(self._outline_marker(self.rois[key]))
        self.servers[key[0]].applyChanges()
        self.debouncer.touch(key, time.monotonic())

    def _menu(self, key: Key, roi: Roi, k: int, action: Tuple[str, str],
              fb: InteractiveMarkerFeedback) -> None:
        what, arg = action
        config = key[0]
        if what == "add_point":
            self.rois[key] = edits.add_point(roi, k)
            self._save(key)
            self._rebuild_roi(key)
        elif what == "delete_point":
            self.rois[key] = edits.delete_point(roi, k)
            self._save(key)
            self._rebuild_roi(key, old_vertices=len(roi.vertices))
        elif what == "delete_roi":
            for pending in self.debouncer.drain():  # save pending drags first
                self._save(pending)
            self.rois_db.delete(config, roi.id)
            del self.rois[key]
            self._rebuild_roi(key, old_vertices=len(roi.vertices))
            self._changed(config)
            rospy.loginfo("roi_manager: deleted ROI %s of config %s", roi.id, config)
        elif what == "add_roi":
            x, y = roi.vertices[k]
            new_id = edits.next_roi_id(i for c, i in set(self.rois) | set(self.known)
                                    if c == config)
            new = edits.new_roi(new_id, arg, self.map_name, config, x + self.new_roi_size,
                             y + self.new_roi_size, self.new_roi_size)
            new_key = (config, new_id)
            self.rois[new_key] = new
            self._save(new_key)
            self._rebuild_roi(new_key)
            rospy.loginfo("roi_manager: added ROI %s (%s) to config %s", new_id, arg, config)

    # -- saving ---------------------------------------------------------------------------------

    def _save(self, key: Key) -> bool:
        roi = self.rois.get(key)
        if roi is None:
            return False
        try:
            version = self.rois_db.save(roi)
        except RoiError as e:
            if self.invalid.get(key) != str(e):
                rospy.logwarn("roi_manager: not saved: %s; move the vertex so that the "
                              "polygon is valid again", e)
            self.invalid[key] = str(e)
            return False
        except (StoreError, OSError) as e:   # the store's fault, not the polygon's: retried
            if key not in self.unsaved:
                rospy.logerr("roi_manager: ROI %s of config %s not saved, the store failed: "
                             "%s; retrying every %.0f s", key[1], key[0], e, _RETRY_S)
            self.unsaved[key] = str(e)
            return False
        if self.invalid.pop(key, None):
            rospy.loginfo("roi_manager: ROI %s of config %s is valid again", key[1], key[0])
        if self.unsaved.pop(key, None):
            rospy.loginfo("roi_manager: ROI %s of config %s saved after retrying", key[1],
                          key[0])
        self.known[key] = version
        self._changed(key[0])
        return True

    def _changed(self, config: str) -> None:
        self._publish_markers()
        self.changed_pub.publish(String(data=config))

    def _run(self) -> None:
        """The saver: debounced drags, retries of refused saves, the periodic sync. Nothing
        one pass raises ends it."""
        next_sync = time.monotonic() + self.sync_period
        next_retry = time.monotonic() + _RETRY_S
        while not self._stop.wait(0.1):
            try:
                now = time.monotonic()
                with self.lock:
                    due = list(self.debouncer.due(now))
                    if now >= next_retry:
                        next_retry = now + _RETRY_S
                        due += [k for k in self.unsaved if k not in due]
                    for key in due:
                        self._save(key)
                if self.sync_period > 0 and time.monotonic() >= next_sync:
                    next_sync = time.monotonic() + self.sync_period
                    self._sync()
            except Exception as e:  # noqa: BLE001 - the saver outlives any one failure
                rospy.logerr_throttle(30.0, "roi_manager: saver: %s: %s (retrying)",
                                      type(e).__name__, e)

    def _sync(self) -> None:
        """Pick up ROI versions written by others (e.g. ``rois import``)."""
        try:
            stored = self.rois_db.versions()
        except StoreUnavailable:
            return
        with self.lock:
            busy = set(self.debouncer.pending()) | set(self.invalid) | set(self.unsaved)
            changed = {k for k, v in stored.items()
                       if v > self.known.get(k, 0) and k not in busy}
            if not changed:
                return
            try:
                current = {(r.config, r.id): r for r in self.rois_db.current()}
            except StoreUnavailable:
                return
            for key in changed:
                old = self.rois.get(key)
                if key in current:
                    self.rois[key] = current[key]
                else:
                    self.rois.pop(key, None)
                self.known[key] = stored[key]
                self._rebuild_roi(key, old_vertices=len(old.vertices) if old else 0)
            for config in sorted({c for c, _ in changed}):
                rospy.loginfo("roi_manager: config %s changed in the store; reloaded", config)
                self._changed(config)

    def _shutdown(self) -> None:
        self._stop.set()
        with self.lock:
            for key in list(self.debouncer.drain()) + list(self.unsaved):
                self._save(key)
            for key, why in self.unsaved.items():
                rospy.logerr("roi_manager: ROI %s of config %s NOT saved at shutdown: %s",
                             key[1], key[0], why)
            self.store.close()

    # -- rviz -----------------------------------------------------------------------------------

    def _publish_markers(self) -> None:
        out = MarkerArray()
        clear = Marker(action=Marker.DELETEALL)
        clear.header.frame_id = self.frame_id
        out.markers.append(clear)
        for n, (key, roi) in enumerate(sorted(self.rois.items())):
            config = key[0]
            line = Marker(type=Marker.LINE_STRIP, ns="roi_%s" % config, id=n,
                          color=type_color(roi.type, 0.9))
            line.header.frame_id = self.frame_id
            line.pose.orientation.w = 1.0
            line.scale.x = 0.06
            line.points = [Point(x, y, 0.01) for x, y in roi.vertices + roi.vertices[:1]]
            label = Marker(type=Marker.TEXT_VIEW_FACING, ns="roi_%s_label" % config, id=n,
                           color=ColorRGBA(1.0, 1.0, 1.0, 0.95), text="%s: %s" % (roi.id,
                                                                                roi.type))
            label.header.frame_id = self.frame_id
            cx, cy = centroid(roi)
            label.pose.position = Point(cx, cy, 0.3)
            label.pose.orientation.w = 1.0
            label.scale.z = 0.45
            out.markers.extend([line, label])
        self.markers_pub.publish(out)


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim roi_manager``."""
    return run_node("soma_roi_manager", RoiManagerNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
