"""Trajectory recorder: every pose of a walker, chunked (data/trajectory.py) and stored.

Subscribes to ``~pose_topic`` (geometry_msgs/PoseStamped in ``map``, e.g. the simulator's
ground truth ``/robot1/pose``), records every pose, and stores each chunk as a
human_trajectory Trajectory in database ``message_store``, collection ``people_trajectory``, in
mongodb_store's layout with ``_meta`` ``{"map", "taken": "online", "closed_by", "robot"}``
(``robot``: the pose topic's namespace, e.g. ``robot1``; ``"region"`` with ``split:
region``). Stored chunks are also published: those that continue a trajectory on
``~trajectories/batch``, the last one of each trajectory (``complete``) on
``~trajectories/complete`` (together: exactly what is stored). ``~path`` (nav_msgs/Path,
latched) shows the open chunk, ``~path_rate`` times a second.

Closed chunks are stored by a worker thread (data/recording.py), never by the subscriber, so
a slow or stalled database delays storing, not reception. The open chunk, and each closed one
until it is stored, is appended to a spill file every ``~flush_every`` seconds; a recorder
killed outright (SIGKILL, OOM) loses at most that window: the next recorder on the same
database and topic stores what the spill holds (closed_by "recovered"). On shutdown
(SIGINT/SIGTERM from roslaunch, or Ctrl-C) the open chunk is stored, marked complete, before
the node exits. If the database is down, chunks are journalled and replayed when it is back
(data/store). A trajectory ends after ``~max_gap`` seconds without a pose, measured on the
poses' stamps (on arrival times when the publisher stamps with another clock).

With ``~people_topic`` (people_msgs/People, e.g. the simulator's ``/ground_truth/people``)
every person is recorded too, each as its own trajectories (its own chunker and spill
file), with ``"person": <name>`` in each chunk's ``_meta``; ``~pose_topic`` "" records people
alone.

Parameters: ``~pose_topic`` (pose), ``~people_topic`` (""), ``~db`` ("" =
``$ROS_HOME/bullet_floor_sim/db``; or ``mongodb://host:port/``), ``~period`` 30 s, ``~split``
period|region, ``~max_poses`` 20000, ``~max_gap`` 10 s (a silence that ends a trajectory; 0 =
never), ``~map`` (map name for the stored meta; default the ROIs' map or the world's name),
``~world`` (default the running simulator's ``/simulator/world``, else office), ``~rois_file``
(default the world's rois.yaml), ``~rois_service`` /soma/query_rois (used first when it answers
within ``~rois_wait`` 2 s), ``~rois_config`` (""), ``~frame_id`` map, ``~path_rate`` 2 Hz (0:
no live path), ``~db_timeout`` 1.5 s (an unreachable database counts as down after that long),
``~db_retry_interval`` 5 s (how often a database found down is tried again), ``~flush_every`` 2
s and ``~spill_dir`` (default ``$ROS_HOME/bullet_floor_sim/spill``).
"""
from __future__ import annotations

import hashlib
import math
import os
import sys
import threading
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import rospy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from std_msgs.msg import Header

from ..sim.config import load_world_config, resolve_world
from ..errors import BulletFloorSimError
from ..paths import worlds_dir
from ..data.recording import ChunkQueue, ChunkSpill, PoseStream
from ..data.rois import Roi, load_rois
from ..data.store import (DuplicateKeyError, StoreError, message_document, open_store,
                          ros_home)
from ..data.trajectory import (COLLECTION, DATABASE, DEFAULT_MAX_GAP, DEFAULT_MAX_POSES,
                               DEFAULT_PERIOD, STORED_TYPE, Chunk, Chunker, RegionLocator,
                               check_max_poses, chunk_fields, chunk_id, ensure_indexes)
from ..msg import People, Trajectory
from .convert import chunk_to_msg, people_poses, pose_of_msg
from .node import forward_store_log, quiet_at_shutdown, run_node
from .params import check_params, config_from_params
from .soma import query_rois

__all__ = ["main", "RecorderNode"]

_NS = 1000000000


def rois_from_service(name: str, wait: float, map_name: str, config: str) -> List[Roi]:
    """The most recent ROIs of ``map_name`` (and ``config``) from a SOMAQueryROIs service.

    Returns:
        The ROIs, or [] when the service does not answer within ``wait`` seconds or has none.
    """
    try:
        rois = query_rois(name, config, wait)
    except rospy.ROSException:
        return []   # no ROI manager: the ROI file is used
    except rospy.ServiceException as e:
        rospy.logwarn("trajectory_recorder: ROI service %s failed (%s); using the ROI file",
                      name, e)
        return []
    return [r for r in rois if not map_name or r.map_name == map_name]


@dataclass
class RecorderParams:
    """The node's parameters (``~<field>``; ``map_name`` is ``~map``: see the module doc),
    checked here where the chunker and the store do not check them."""

    frame_id: str = "map"
    split: str = "period"
    map_name: str = ""
    period: float = DEFAULT_PERIOD
    max_poses: int = DEFAULT_MAX_POSES
    max_gap: float = DEFAULT_MAX_GAP
    db: str = ""
    db_timeout: float = 1.5
    db_retry_interval: float = 5.0
    pose_topic: str = "pose"
    people_topic: str = ""
    spill_dir: str = ""
    flush_every: float = 2.0
    path_rate: float = 2.0
    world: str = ""
    rois_service: str = "/soma/query_rois"
    rois_wait: float = 2.0
    rois_config: str = ""
    rois_file: str = ""

    def check(self) -> None:
        """Raises BulletFloorSimError naming the bad parameter."""
        check_params(self, "trajectory_recorder", ("db_timeout", "db_retry_interval"))
        check_params(self, "trajectory_recorder", ("path_rate", "rois_wait", "flush_every"),
                     strict=False)   # flush_every 0: every pose


def robot_of_topic(topic: str) -> str:
    """The robot a pose topic belongs to, as ``trajectories list`` names it: the topic's
    namespace (``/robot1/pose`` -> ``robot1``), or the topic itself when it has none."""
    parts = [p for p in topic.split("/") if p]
    return "/".join(parts[:-1]) if len(parts) > 1 else topic


class RecorderNode:
    """Parameters, subscriptions and the store; the chunking lives in data/trajectory.py,
    one chunker per stream (data/recording.PoseStream): the pose topic's, and one per person
    of ``~people_topic``.

    Raises:
        BulletFloorSimError: a bad parameter, an unreadable world or ROI file, or a store URI
            that cannot be opened.
    """

    def __init__(self) -> None:
        forward_store_log()
        p = self.params = config_from_params(RecorderParams(), names={"map_name": "map"})
        self.frame_id = p.frame_id.lstrip("/")
        self.map_name = p.map_name
        self.rois: List[Roi] = []
        self.rois_source = ""
        if p.split == "region":
            self.rois = self._load_rois(p)
        if not self.map_name:
            self.map_name = self.rois[0].map_name if self.rois else self._world().name
        check_max_poses(self._new_chunker().max_poses, self.frame_id)
        self.store = open_store(p.db or None, timeout=p.db_timeout,
                                retry_interval=p.db_retry_interval)
        ensure_indexes(self.store)
        self.topic = rospy.resolve_name(p.pose_topic) if p.pose_topic else ""
        self.people_topic = rospy.resolve_name(p.people_topic) if p.people_topic else ""
        if not (self.topic or self.people_topic):
            raise BulletFloorSimError("trajectory_recorder: nothing to record: ~pose_topic and "
                                      "~people_topic are both empty")
        self.lock = threading.Lock()
        self.finished = False
        self.streams: Dict[str, PoseStream] = {}   # "" = the pose topic; else a person
        self.live: List[PoseStamped] = []
        self.live_dirty = False
        self.header_seq = 0
        self.stored_chunks = 0
        self.stored_poses = 0
        self.rejected = 0
        self.unconfirmed: List[Tuple[PoseStream, Chunk]] = []   # stored, held in memory
        self.batch_pub = rospy.Publisher("~trajectories/batch", Trajectory, queue_size=100)
        self.complete_pub = rospy.Publisher("~trajectories/complete", Trajectory,
                                            queue_size=100)
        self.path_pub = rospy.Publisher("~path", Path, queue_size=1, latch=True)
        self.queue = ChunkQueue(self._store, "trajectory_recorder")
        self.subs = []
        if self.topic:
            self._open_stream("", self.topic)
            # queue_size None: rospy keeps every message (a bounded queue drops the oldest).
            self.subs.append(rospy.Subscriber(self.topic, PoseStamped, self._on_pose,
                                              queue_size=None))
        if self.people_topic:
            self.subs.append(rospy.Subscriber(self.people_topic, People, self._on_people,
                                              queue_size=None))
        rate = p.path_rate
        # reset: a clock that jumps back (the simulator restarted) does not stop the timer
        self.timer = rospy.Timer(rospy.Duration(1.0 / rate if rate > 0 else 1.0), self._tick,
                                 reset=True)
        self.path_rate = rate
        what = " and ".join(t for t in (self.topic, self.people_topic and
                                        "every person of " + self.people_topic) if t)
        rospy.loginfo("trajectory_recorder: %s -> %s %s.%s (map %s, split %s, period %.1f s, "
                      "max %d poses/chunk%s)", what, self.store.shown_uri, DATABASE,
                      COLLECTION, self.map_name, p.split, p.period, p.max_poses,
                      self.rois_source)
        # The hook stores the open chunks; rospy calls it from the SIGINT/SIGTERM handler
        # before the node goes down. close() (after spinning) waits for it.
        rospy.on_shutdown(self.close)

    @property
    def received(self) -> int:
        """Poses received over all streams."""
        return sum(s.received for s in self.streams.values())

    def close(self) -> None:
        """Store the open chunks (complete) and close the store: :meth:`shutdown`."""
        self.shutdown("shutdown")

    def _new_chunker(self) -> Chunker:
        p = self.params
        return Chunker(period=p.period, split=p.split, max_poses=p.max_poses,
                       max_gap=p.max_gap, region_of=RegionLocator(self.rois) if self.rois else None)

    def _open_stream(self, key: str, topic: str) -> PoseStream:
        """A new stream (its chunker and spill file); stores what a recorder killed before
        left in that spill file."""
        name = key or None
        stream = PoseStream(self._new_chunker(),
                            ChunkSpill(self._spill_path(self.params.spill_dir, topic, name),
                                       self.params.flush_every), name)
        self.streams[key] = stream
        self._recover(stream, topic)
        return stream

    # -- set-up -------------------------------------------------------------------------------
    def _spill_path(self, directory: str, topic: str, person: Optional[str]) -> str:
        """One spill file per database and pose topic, or topic and person (what the next
        recorder there reads)."""
        directory = directory or os.path.join(ros_home(), "bullet_floor_sim", "spill")
        text = "%s\0%s" % (self.store.uri, topic) + ("" if person is None else "\0" + person)
        key = hashlib.sha1(text.encode("utf-8"))
        return os.path.join(directory, key.hexdigest()[:16] + ".jsonl")

    def _recover(self, stream: PoseStream, topic: str) -> None:
        """Store what a recorder killed before its time left in the stream's spill file. A
        chunk's ``_id`` is the same every time it is stored (data/trajectory.chunk_id), so
        one that reached the store (or its journal) before the kill is not stored twice."""
        chunks = stream.spill.recover()
        kept = [c for c in chunks if self._store(c, (None, stream)) != "duplicate"]
        if self.store.held == 0:
            stream.spill.remove()
        if chunks:
            rospy.logwarn("trajectory_recorder: recovered %d chunks (%d poses) a previous "
                          "recorder on %s%s left unstored in %s", len(kept),
                          sum(len(c.poses) for c in kept), topic,
                          "" if stream.person is None else " (%s)" % stream.person,
                          stream.spill.path)

    def _world(self):
        # ~world, else the running simulator's world (sim.launch sets /simulator/world)
        world = (self.params.world or str(rospy.get_param("/simulator/world", ""))
                 or "office")
        return load_world_config(resolve_world(world, worlds_dir()))

    def _load_rois(self, p: "RecorderParams") -> List[Roi]:
        service = p.rois_service
        if service:
            rois = rois_from_service(service, p.rois_wait, self.map_name, p.rois_config)
            if rois:
                self.rois_source = ", %d ROIs from %s" % (len(rois), service)
                return rois
        path = p.rois_file
        if not path:
            world = self._world()
            if not world.rois:
                raise BulletFloorSimError("trajectory_recorder: split region needs ROIs: world "
                                          "%s has no rois file; set ~rois_file" % world.path)
            path = world.rois
        rois = load_rois(path)
        if self.map_name:
            rois = [r for r in rois if r.map_name == self.map_name] or rois
        if not rois:
            raise BulletFloorSimError("trajectory_recorder: %s holds no ROIs" % path)
        self.rois_source = ", %d ROIs from %s" % (len(rois), path)
        return rois

    # -- poses --------------------------------------------------------------------------------
    @quiet_at_shutdown
    def _on_pose(self, msg: PoseStamped) -> None:
        if not self._frame_ok(msg.header.frame_id, self.topic):
            return
        pose = pose_of_msg(msg)
        if not all(math.isfinite(v) for v in pose[1:]):
            self._reject("%s: non-finite pose at %s" % (self.topic, msg.header.stamp))
            return
        with self.lock:
            if self.finished:
                return
            closed = self.streams[""].add(pose, rospy.Time.now().to_nsec())
            if closed:
                self.live = [msg]
                for chunk in closed:
                    self._hand_over(self.streams[""], chunk)
            else:
                self.live.append(msg)
            self.live_dirty = True

    @quiet_at_shutdown
    def _on_people(self, msg: People) -> None:
        """Every person's position, each its own trajectory (stream)."""
        if not self._frame_ok(msg.header.frame_id, self.people_topic):
            return
        poses = people_poses(msg)
        with self.lock:
            if self.finished:
                return
            rx = rospy.Time.now().to_nsec()
            for name, pose in poses:
                if not name or not all(math.isfinite(v) for v in pose[1:]):
                    self._reject("%s: person %r: no name or a non-finite position at %s"
                                 % (self.people_topic, name, msg.header.stamp))
                    continue
                stream = self.streams.get(name) or self._open_stream(name, self.people_topic)
                for chunk in stream.add(pose, rx):
                    self._hand_over(stream, chunk)

    def _frame_ok(self, frame: str, topic: str) -> bool:
        if frame.lstrip("/") == self.frame_id:
            return True
        self._reject("%s: pose in frame %r, not %r" % (topic, frame, self.frame_id))
        return False

    def _reject(self, why: str) -> None:
        self.rejected += 1
        rospy.logwarn_throttle(10.0, "trajectory_recorder: %s: not recorded (%d so far)",
                               why, self.rejected)

    @quiet_at_shutdown
    def _tick(self, event) -> None:
        with self.lock:
            if self.finished:
                return
            now = rospy.Time.now()
            for stream in list(self.streams.values()):
                stream.spill.flush_if_due()
                ended = stream.check_gap(now.to_nsec())   # the one gap rule
                if ended is None:
                    continue
                rospy.loginfo("trajectory_recorder: %sno pose for %.1f s: trajectory %s ended "
                              "after %d chunks", "" if stream.person is None
                              else stream.person + ": ", stream.chunker.max_gap, ended.uuid,
                              ended.sequence_id + 1)
                self._hand_over(stream, ended)
                if stream.person is None:
                    self.live = []
                    self.live_dirty = True
            if not self.live_dirty or self.path_rate <= 0:
                return
            self.live_dirty = False
            path = Path(Header(0, now, self.frame_id), list(self.live))
        self.path_pub.publish(path)

    # -- storing ------------------------------------------------------------------------------
    def _hand_over(self, stream: PoseStream, chunk: Chunk) -> None:
        """A closed chunk to its stream's spill file and the store queue (lock held)."""
        chunk.frame_id = self.frame_id
        self.header_seq += 1
        stream.spill.closed(chunk)
        self.queue.put(chunk, (self.header_seq, stream))

    def _store(self, chunk: Chunk, context: Tuple[Optional[int], PoseStream]) -> str:
        """Store one chunk (journalled if the database is down) and publish it: the queue's
        worker, never the subscriber thread. ``context``: the header seq (None for a
        recovered chunk) and the chunk's stream. Returns "stored", "duplicate", "refused" or
        "closed"."""
        header_seq, stream = context
        now = rospy.Time.now()
        stamp_ns = now.secs * _NS + now.nsecs
        chunk.frame_id = self.frame_id
        meta = {"map": self.map_name, "taken": "online", "closed_by": chunk.closed_by}
        if chunk.region is not None or self.params.split == "region":
            meta["region"] = chunk.region
        if stream.person is not None:
            meta["person"] = stream.person
        else:
            meta["robot"] = robot_of_topic(self.topic)
        seq = header_seq if header_seq is not None else 0
        doc = message_document(chunk_fields(chunk, stamp_ns, seq), STORED_TYPE, meta=meta,
                               inserted_by=rospy.get_name(), now=stamp_ns / 1e9,
                               stamp_ns=stamp_ns)
        doc["_id"] = chunk_id(chunk)
        try:
            self.store.insert(DATABASE, COLLECTION, doc)
        except DuplicateKeyError:  # stored before (a recovered chunk): nothing to do
            self._confirm(stream, chunk)
            return "duplicate"
        except StoreError as e:
            if self.store.closed:  # shutting down: the spill file keeps it for the next
                return "closed"
            rospy.logerr("trajectory_recorder: chunk %d of %s (%d poses) NOT stored, the "
                         "database refused it: %s", chunk.sequence_id, chunk.uuid,
                         len(chunk.poses), e)
            self._confirm(stream, chunk)
            return "refused"
        self._confirm(stream, chunk)
        self.stored_chunks += 1
        self.stored_poses += len(chunk.poses)
        pub = self.complete_pub if chunk.complete else self.batch_pub
        if pub.get_num_connections() > 0:
            pub.publish(chunk_to_msg(chunk, now, seq))
        return "stored"

    def _confirm(self, stream: PoseStream, chunk: Chunk) -> None:
        """Let the spill file drop a chunk once its write is durable: in the database or the
        journal, not only in the store's memory (a full disk); then every earlier one too."""
        self.unconfirmed.append((stream, chunk))
        if self.store.held == 0:
            for st, c in self.unconfirmed:
                st.spill.stored(c)
            self.unconfirmed = []

    def shutdown(self, reason: str = "") -> None:
        """Store the open chunk (complete) and close the store; safe to call twice."""
        with self.lock:
            if self.finished:
                return
            self.finished = True
            self.timer.shutdown()
            for sub in self.subs:
                sub.unregister()
            for stream in self.streams.values():
                last = stream.chunker.finish()
                if last is not None:
                    self._hand_over(stream, last)
        finished = self.queue.close(60.0)   # on a timeout the worker takes no more chunks
        for stream in self.streams.values():
            if finished and self.store.held == 0:
                stream.spill.remove()       # everything is stored or journalled
            else:
                stream.spill.flush()
        if not (finished and self.store.held == 0):
            rospy.logerr("trajectory_recorder: %s; the chunks stay in the spill files for the "
                         "next recorder (%s)", "the store did not take the last chunks within "
                         "60 s" if not finished else "the journal cannot take %d writes"
                         % self.store.held, ", ".join(s.spill.path for s in self.streams.values()))
        pending = self.store.pending
        self.store.close()
        rospy.loginfo("trajectory_recorder: %s: stored %d chunks (%d poses incl. shared "
                      "boundaries) from %d poses received", reason or "shutdown",
                      self.stored_chunks, self.stored_poses, self.received)
        if pending:
            rospy.logwarn("trajectory_recorder: %d writes wait in the journal %s; they are "
                          "replayed when the database is reachable and a store opens it",
                          pending, self.store.journal_path)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim trajectory_recorder``."""
    return run_node("trajectory_recorder", RecorderNode, argv,
                    errors=(BulletFloorSimError, ValueError))


if __name__ == "__main__":
    sys.exit(main())
