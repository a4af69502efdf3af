"""Trajectory viewer: stored trajectories for rviz, selected at start and at run time.

Reads the chunks the recorder stored (``message_store.people_trajectory``, either backend),
joins them per trajectory (uuid) and publishes:

* ``~markers`` (visualization_msgs/MarkerArray, latched): one LINE_STRIP per trajectory in
  namespace ``trajectories``, coloured by time (blue = oldest shown pose, red = newest) or by
  trajectory (one hue each); a DELETEALL first, so a new selection replaces the old one.
* with ``paths``: one latched nav_msgs/Path per trajectory on ``~paths/t_<uuid>``.

Long trajectories are thinned for display to ``~max_points`` points (first and last kept).

The selection: ``~map`` ("" = every map), ``~since`` / ``~until`` (seconds, ROS time; 0 = no
limit: chunks ending at or after since and starting at or before until), ``~last_n`` (the N
trajectories that end last; 0 = all), ``~person`` ("" = every trajectory; a name: that
person's, as the recorder of a people topic stores them), ``~color_by`` time|trajectory,
``~paths`` false. The
service ``~select`` (bullet_floor_sim/SelectTrajectories) changes it at run time.

New chunks appear without polling: the viewer subscribes to the recorder's
``~trajectories/batch`` and ``~trajectories/complete`` (``~chunk_topics``, default
``/trajectory_recorder/trajectories/{batch,complete}``) and reads each announced chunk back
from the store (so the map filter applies). ``~refresh_period`` > 0 also re-reads everything
that often (seconds), e.g. to see imported trajectories. Other parameters: ``~db``,
``~db_timeout`` 1.5, ``~frame_id`` map, ``~line_width`` 0.05 m, ``~max_points`` 10000.

Memory stays bounded: the viewer holds at most ``~max_poses`` (100000) poses, the chunks that
end last (about 1.4 h of one walker at 20 Hz; a trajectory lasts as long as its walker walks,
so its oldest chunks leave the view first), with one log line. New chunks are shown at most
every ``~publish_period`` (1.0) seconds of wall time: the markers are rebuilt from every pose
shown, and rebuilt for each chunk of 20 people's they kept the viewer too busy to read /clock,
so the simulator waited for it.
"""
from __future__ import annotations

import colorsys
import math
import re
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

import rospy
from geometry_msgs.msg import Pose, Quaternion
from nav_msgs.msg import Path
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from ..errors import BulletFloorSimError
from ..data.store import StoreError, open_store
from ..data.trajectory import (COLLECTION, DATABASE, Chunk, Joined, chunk_from_document,
                               ensure_indexes, join_chunks, select_chunks)
from ..msg import Trajectory
from ..srv import SelectTrajectories, SelectTrajectoriesResponse
from .convert import pose_msgs
from .node import closed_at_shutdown, forward_store_log, quiet_at_shutdown, run_node
from .packed_markers import PackedMarkerArray, pack_marker, time_colours
from .params import check_int_params, check_params, config_from_params

__all__ = ["main", "ViewerNode", "Selection", "decimate", "newest",
           "trajectory_colour"]

_NS = 1000000000
COLOR_BY = ("time", "trajectory")


@dataclass
class ViewerParams:
    """The node's parameters (``~<field>``) but the selection's (:class:`Selection`), checked."""

    frame_id: str = "map"
    line_width: float = 0.05
    max_points: int = 10000
    max_poses: int = 100000
    db: str = ""
    db_timeout: float = 1.5
    chunk_topics: list = field(default_factory=lambda: [
        "/trajectory_recorder/trajectories/batch", "/trajectory_recorder/trajectories/complete"])
    refresh_period: float = 0.0
    publish_period: float = 1.0

    def check(self) -> None:
        """Raises BulletFloorSimError naming the bad parameter (the selection checks its own)."""
        check_int_params(self, "trajectory_viewer", ("max_points",), least=2)
        check_int_params(self, "trajectory_viewer", ("max_poses",))
        check_params(self, "trajectory_viewer", ("line_width", "db_timeout", "publish_period"))
        check_params(self, "trajectory_viewer", ("refresh_period",), strict=False)   # 0: never


@dataclass(frozen=True)
class Selection:
    """Which stored chunks are shown (see module doc); times in seconds, 0 = no limit."""

    map_name: str = ""
    since: float = 0.0
    until: float = 0.0
    last_n: int = 0
    color_by: str = "time"
    paths: bool = False
    person: str = ""

    def check(self) -> None:
        """Raises BulletFloorSimError naming the bad field."""
        for name in ("since", "until"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise BulletFloorSimError("%s %r: must be seconds >= 0 (0 = no limit)"
                                          % (name, v))
        if self.since and self.until and self.since > self.until:
            raise BulletFloorSimError("since %s is after until %s" % (self.since, self.until))
        if self.last_n < 0:
            raise BulletFloorSimError("last_n %d: must be >= 0 (0 = all)" % self.last_n)
        if self.color_by not in COLOR_BY:
            raise BulletFloorSimError("color_by %r: use %s" % (self.color_by,
                                                               " or ".join(COLOR_BY)))

    @property
    def since_ns(self) -> Optional[int]:
        return int(round(self.since * _NS)) if self.since else None

    @property
    def until_ns(self) -> Optional[int]:
        return int(round(self.until * _NS)) if self.until else None

    def describe(self) -> str:
        parts = ["map %s" % self.map_name if self.map_name else "every map"]
        if self.person:
            parts.append("person %s" % self.person)
        if self.since:
            parts.append("since %.3f s" % self.since)
        if self.until:
            parts.append("until %.3f s" % self.until)
        if self.last_n:
            parts.append("last %d" % self.last_n)
        parts.append("coloured by %s" % self.color_by)
        return ", ".join(parts)


def newest(chunks: Dict[Tuple[str, int], Chunk], last_n: int, max_poses: int
           ) -> Dict[Tuple[str, int], Chunk]:
    """The chunks shown: of the ``last_n`` trajectories that end last (0: all of them), the
    chunks that end last, newest first, as many as fit in ``max_poses`` poses (the newest one
    always). A trajectory is one pose stream as long as its walker walks: whole, the newest
    one alone could outgrow any cap."""
    ends: Dict[str, int] = {}
    for c in chunks.values():
        ends[c.uuid] = max(ends.get(c.uuid, 0), c.end_ns)
    uuids = set(ends)
    if last_n > 0:
        uuids = set(sorted(ends, key=lambda u: (ends[u], u), reverse=True)[:last_n])
    order = sorted((k for k, c in chunks.items() if c.uuid in uuids),
                   key=lambda k: (chunks[k].end_ns, k), reverse=True)
    keep: Dict[Tuple[str, int], Chunk] = {}
    total = 0
    for k in order:
        n = len(chunks[k].poses)
        if keep and total + n > max_poses:
            break
        keep[k] = chunks[k]
        total += n
    return chunks if len(keep) == len(chunks) else keep


def decimate(poses: Sequence, max_points: int) -> List:
    """At most ``max_points`` poses, evenly spaced, the first and last always kept."""
    n = len(poses)
    if n <= max_points or max_points < 2:
        return list(poses)
    step = (n - 1) / float(max_points - 1)
    return [poses[int(round(k * step))] for k in range(max_points)]


def trajectory_colour(k: int) -> ColorRGBA:
    """The k-th of a sequence of well-separated hues (golden-ratio steps)."""
    r, g, b = colorsys.hsv_to_rgb((k * 0.618033988749895) % 1.0, 0.85, 0.95)
    return ColorRGBA(r, g, b, 1.0)


def path_topic_name(uuid: str) -> str:
    """``t_<uuid without dashes>``: a valid ROS name for any uuid string."""
    return "t_" + re.sub(r"[^A-Za-z0-9_]", "_", uuid.replace("-", ""))


class ViewerNode:
    """The viewer (see module doc).

    Raises:
        BulletFloorSimError: a bad parameter or store URI.
    """

    def __init__(self) -> None:
        forward_store_log()
        p = self.params = config_from_params(ViewerParams())
        self.frame_id, self.line_width = p.frame_id, p.line_width
        self.max_points, self.max_poses = p.max_points, p.max_poses
        self.capped = False
        self.selection = config_from_params(Selection(), names={"map_name": "map"})
        self.store = open_store(p.db or None, timeout=p.db_timeout)
        ensure_indexes(self.store)  # reads go by start time and by uuid
        self.lock = threading.RLock()
        self.chunks: Dict[Tuple[str, int], Chunk] = {}
        self.last_seq: Dict[str, int] = {}   # the highest sequence_id read of each uuid
        self.dirty = False                   # chunks read but not yet shown
        self.published_at = -math.inf        # wall time of the last markers
        self.shown: List[Joined] = []
        self.need_reload = True
        self.marker_pub = rospy.Publisher("~markers", MarkerArray, queue_size=1, latch=True)
        self.path_pubs: Dict[str, rospy.Publisher] = {}
        self.service = rospy.Service("~select", SelectTrajectories, self._on_select)
        self.subs = [rospy.Subscriber(t, Trajectory, self._on_chunk, queue_size=100)
                     for t in p.chunk_topics]
        self.refresh_period = p.refresh_period
        self.next_refresh = 0.0
        with self.lock:
            self._reload_or_warn()
        self.timer = rospy.Timer(rospy.Duration(2.0), self._tick, reset=True)
        threading.Thread(target=self._show_late, daemon=True).start()
        rospy.loginfo("trajectory_viewer: %d trajectories shown (%s) from %s",
                      len(self.shown), self.selection.describe(), self.store.shown_uri)

    def close(self) -> None:
        """The store's held writes get their last try (see data/store)."""
        self.store.close()

    # -- loading ------------------------------------------------------------------------------
    def _reload(self, sel: Selection) -> Dict[Tuple[str, int], Chunk]:
        chunks = select_chunks(self.store, sel.map_name, sel.since_ns, sel.until_ns, sel.last_n,
                               person=sel.person or None)
        self.last_seq = {}
        for c in chunks:
            self.last_seq[c.uuid] = max(self.last_seq.get(c.uuid, -1), c.sequence_id)
        return self._cap({(c.uuid, c.sequence_id): c for c in chunks}, sel.last_n)

    def _cap(self, chunks: Dict[Tuple[str, int], Chunk], last_n: int
             ) -> Dict[Tuple[str, int], Chunk]:
        kept = newest(chunks, last_n, self.max_poses)
        if len(kept) < len(chunks):
            shown = {u for u, _ in kept}     # a trajectory out of view is read again whole
            self.last_seq = {u: q for u, q in self.last_seq.items() if u in shown}
            if not self.capped:
                self.capped = True
                rospy.loginfo("trajectory_viewer: showing the chunks that end last within "
                              "~max_poses %d poses; older ones are dropped from view (narrow "
                              "the selection with ~since/~until/~last_n to see them)",
                              self.max_poses)
        return kept

    def _reload_or_warn(self, at_once: bool = True) -> None:
        """Read the selection again and show it (``at_once`` False: within publish_period)."""
        try:
            self.chunks = self._reload(self.selection)
        except (StoreError, BulletFloorSimError) as e:
            rospy.logwarn_throttle(30.0, "trajectory_viewer: cannot read the stored "
                                   "trajectories yet: %s", e)
            return
        self.need_reload, self.dirty = False, True
        if at_once:
            self._publish()
        else:
            self._show_if_due()

    @quiet_at_shutdown
    def _tick(self, event) -> None:
        with self.lock:
            now = rospy.get_rostime().to_sec()
            due = self.refresh_period > 0 and now >= self.next_refresh
            if self.need_reload or due:
                self.next_refresh = now + self.refresh_period
                self._reload_or_warn()

    @quiet_at_shutdown
    def _on_chunk(self, msg: Trajectory) -> None:
        with self.lock:
            sel = self.selection
            try:  # an indexed lookup; the map and time limits are checked below
                docs = self.store.find(DATABASE, COLLECTION, {"uuid": msg.uuid,
                                                              "sequence_id": msg.sequence_id})
                found = [chunk_from_document(d) for d in docs if not sel.person
                         or (d.get("_meta") or {}).get("person") == sel.person]
            except (StoreError, BulletFloorSimError) as e:
                rospy.logwarn_throttle(30.0, "trajectory_viewer: cannot read chunk %d of %s "
                                       "back (%s); reloading later", msg.sequence_id, msg.uuid,
                                       e)
                self.need_reload = True
                return
            for c in found:
                if sel.map_name and c.map_name != sel.map_name:
                    continue
                if sel.since_ns is not None and c.end_ns < sel.since_ns:
                    continue
                if sel.until_ns is not None and c.start_ns > sel.until_ns:
                    continue
                if (c.sequence_id > self.last_seq.get(c.uuid, -1) + 1
                        and (sel.since_ns is None or c.start_ns >= sel.since_ns)):
                    # its predecessor (which ends where it starts) is selected too but was
                    # not read (we started late, or a message was lost): read all
                    self._reload_or_warn(at_once=False)
                    return
                self.chunks[(c.uuid, c.sequence_id)] = c
                self.last_seq[c.uuid] = max(self.last_seq.get(c.uuid, -1), c.sequence_id)
            if self.chunks:
                self.chunks = self._cap(self.chunks, sel.last_n)
                self.dirty = True
                self._show_if_due()

    def _show_if_due(self) -> None:
        """Publish what was read, unless the last markers are younger than publish_period
        (wall time); _show_late publishes it then (called with the lock held)."""
        if self.dirty and time.monotonic() - self.published_at >= self.params.publish_period:
            self._publish()

    def _show_late(self) -> None:
        """Chunks held back by publish_period are shown once it has passed (wall time: sim
        time flies when the simulator runs flat out)."""
        while not rospy.is_shutdown():
            time.sleep(self.params.publish_period / 4.0)
            try:
                with self.lock:
                    self._show_if_due()
            except (rospy.ROSException, AttributeError) as e:
                if not closed_at_shutdown(e):
                    raise
                return

    # -- output -------------------------------------------------------------------------------
    def _publish(self) -> None:
        self.dirty = False
        try:
            self._publish_markers()
        finally:   # the next publish_period counts from the end of this one
            self.published_at = time.monotonic()

    def _publish_markers(self) -> None:
        sel = self.selection
        self.shown = join_chunks(self.chunks.values())
        stamp = rospy.Time.now()
        header = Header(0, stamp, self.frame_id)
        packed = [pack_marker(Marker(header=header, ns="trajectories", action=Marker.DELETEALL))]
        times = [p[0] for j in self.shown for p in (j.poses[0], j.poses[-1]) if j.poses]
        t0, t1 = (min(times), max(times)) if times else (0, 0)
        span = float(t1 - t0) or 1.0
        for k, j in enumerate(self.shown):
            poses = decimate(j.poses, self.max_points)
            if len(poses) < 2:
                continue
            m = Marker(header=header, ns="trajectories", id=k, type=Marker.LINE_STRIP,
                       action=Marker.ADD, pose=Pose(orientation=Quaternion(0, 0, 0, 1)))
            m.scale.x = self.line_width
            m.text = j.uuid
            xyz = np.array([p[1:4] for p in poses], dtype=float)
            colours = None
            if sel.color_by == "time":
                m.color = ColorRGBA(1, 1, 1, 1)
                stamps = np.fromiter((p[0] for p in poses), dtype=np.int64, count=len(poses))
                colours = time_colours((stamps - t0) / span)
            else:
                m.color = trajectory_colour(k)
            packed.append(pack_marker(m, xyz, colours))
        self.marker_pub.publish(PackedMarkerArray(packed))
        self._publish_paths(stamp)

    def _publish_paths(self, stamp: rospy.Time) -> None:
        wanted = {}
        if self.selection.paths:
            wanted = {path_topic_name(j.uuid): j for j in self.shown}
        for name in list(self.path_pubs):
            if name not in wanted:
                self.path_pubs.pop(name).unregister()
        for name, j in wanted.items():
            pub = self.path_pubs.get(name)
            if pub is None:
                pub = rospy.Publisher("~paths/" + name, Path, queue_size=1, latch=True)
                self.path_pubs[name] = pub
            pub.publish(Path(Header(0, stamp, self.frame_id),
                             pose_msgs(decimate(j.poses, self.max_points), self.frame_id)))

    def path_topics(self) -> List[str]:
        """The resolved Path topics of the shown trajectories, in their order."""
        if not self.selection.paths:
            return []
        return [self.path_pubs[path_topic_name(j.uuid)].resolved_name for j in self.shown]

    # -- service ------------------------------------------------------------------------------
    def _on_select(self, req) -> SelectTrajectoriesResponse:
        with self.lock:
            sel = Selection(req.map_name, req.since, req.until, req.last_n,
                            req.color_by or self.selection.color_by, bool(req.paths),
                            req.person)
            try:
                sel.check()
                chunks = self._reload(sel)
            except (StoreError, BulletFloorSimError) as e:
                return self._response(False, "refused, selection unchanged: %s"
                                      % " ".join(str(e).split()))
            self.selection, self.chunks, self.need_reload = sel, chunks, False
            self._publish()
            poses = sum(len(j.poses) for j in self.shown)
            return self._response(True, "%d trajectories (%d chunks, %d poses): %s"
                                  % (len(self.shown), len(self.chunks), poses,
                                     sel.describe()))

    def _response(self, ok: bool, message: str) -> SelectTrajectoriesResponse:
        if not ok:
            rospy.logwarn("trajectory_viewer: ~select %s", message)
        return SelectTrajectoriesResponse(success=ok, count=len(self.shown),
                                          uuids=[j.uuid for j in self.shown],
                                          path_topics=self.path_topics(), message=message)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim trajectory_viewer``."""
    return run_node("trajectory_viewer", ViewerNode, argv,
                    errors=(BulletFloorSimError, ValueError))


if __name__ == "__main__":
    sys.exit(main())
