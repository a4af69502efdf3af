"""Trajectories: a pose stream cut into stored chunks, their metrics, documents and JSON lines.

A *trajectory* is one uninterrupted pose stream of one walker (one ``uuid``). It is stored as
*chunks*, each a human_trajectory ``Trajectory`` message (the human_trajectory package's format):

* :class:`Chunker` closes a chunk every ``period`` seconds of stamp time (``split="period"``),
  or when the pose enters another region (``split="region"``; ``period`` then also closes a
  long stay, 0 turns that off), and whenever a chunk reaches ``max_poses`` (a MongoDB
  document holds 16 MB; the seed skipped trajectories over 100,000 poses: here they are
  split, never dropped). ``sequence_id`` counts the chunks of a trajectory from 0.
* Consecutive chunks share the boundary pose: the pose that closes a chunk is its last pose
  and the first pose of the next one, so joining the chunks (:func:`join_chunks`) gives back
  the stream exactly and a stored trajectory is continuous.
* The trajectory ends (its last chunk gets ``complete = True``) when the recorder stops
  (:meth:`Chunker.finish`), when no pose came for ``max_gap`` seconds, or when stamps jump
  backwards (a restarted simulation or a replayed bag); the next pose starts a new uuid.

Metrics, per chunk, over the (x, y) positions of its poses (as human_trajectory computes
them): ``trajectory_length`` = the sum of the distances between consecutive poses
(``math.fsum``, so exact to rounding), ``trajectory_displacement`` = the distance from the first
to the last pose, ``displacement_pose_ratio`` = displacement / number of poses.

A pose is a plain tuple ``(t_ns, x, y, z, qx, qy, qz, qw)``: the stamp in integer nanoseconds
(exact, as ROS keeps it) and the pose in the map frame. Documents are mongodb_store's layout of
the message (:func:`chunk_fields`, :func:`chunk_from_document`); the command-line export is one
JSON line per chunk (:func:`chunk_to_json`, :func:`chunk_from_json`) with times as decimal
seconds with 9 digits: times, positions and metrics survive export -> import exactly, the
heading as a planar quaternion (to about 1e-15 rad).

Reading (:func:`trajectory_heads`, :func:`iter_documents`, :func:`select_chunks`) goes
trajectory by trajectory through indexed lookups (:func:`ensure_indexes`), a few chunks at a
time, so memory stays bounded however much is stored.

No rospy here: the ROS glue turns PoseStamped messages into pose tuples.
"""
from __future__ import annotations

import decimal
import hashlib
import json
import math
import struct
import uuid as uuidlib
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Sequence, Tuple

from ..errors import BulletFloorSimError

__all__ = [
    "DATABASE",
    "COLLECTION",
    "STORED_TYPE",
    "SPLITS",
    "DEFAULT_PERIOD",
    "DEFAULT_MAX_POSES",
    "DEFAULT_MAX_GAP",
    "INDEXES",
    "Pose",
    "TrajectoryError",
    "Chunk",
    "Joined",
    "Chunker",
    "RegionLocator",
    "path_length",
    "displacement",
    "yaw_of",
    "pose_from_xy_yaw",
    "split_poses",
    "join_chunks",
    "chunk_fields",
    "chunk_id",
    "chunk_from_document",
    "chunk_to_json",
    "chunk_from_json",
    "format_time",
    "parse_time",
    "ensure_indexes",
    "Head",
    "trajectory_heads",
    "iter_documents",
    "document_to_json",
    "select_chunks",
]

DATABASE = "message_store"
COLLECTION = "people_trajectory"
STORED_TYPE = "human_trajectory/Trajectory"
SPLITS = ("period", "region")
DEFAULT_PERIOD = 30.0
# A pose is about 260 bytes of BSON in mongodb_store's layout: 20,000 poses ~ 5 MB, far below
# MongoDB's 16 MB document limit (and 100 s of a 200 Hz pose stream).
DEFAULT_MAX_POSES = 20000
DEFAULT_MAX_GAP = 10.0
#: The most a stored chunk may weigh as BSON: half of MongoDB's 16 MB document limit.
MAX_CHUNK_BYTES = 8 * 1024 * 1024
# Indexes the recorder (and the readers) create: (uuid, sequence_id) and sequence_id let the
# embedded store answer latest(uuid, sequence_id) and chunk lookups from the index alone;
# start time and map serve users' own queries.
INDEXES = ([("uuid", 1), ("sequence_id", 1)], [("sequence_id", 1)], [("start_time.secs", 1)],
           [("_meta.map", 1)])

Pose = Tuple[int, float, float, float, float, float, float, float]

_NS = 1000000000


class TrajectoryError(BulletFloorSimError):
    """A bad chunking setting, a malformed stored trajectory or JSON line; names the input."""


# -- metrics ----------------------------------------------------------------------------------

def path_length(poses: Sequence[Pose]) -> float:
    """Sum of the (x, y) distances between consecutive poses (0.0 for fewer than 2)."""
    return math.fsum(math.hypot(b[1] - a[1], b[2] - a[2]) for a, b in zip(poses, poses[1:]))


def displacement(poses: Sequence[Pose]) -> float:
    """(x, y) distance from the first to the last pose (0.0 for none)."""
    if not poses:
        return 0.0
    return math.hypot(poses[-1][1] - poses[0][1], poses[-1][2] - poses[0][2])


def yaw_of(pose: Pose) -> float:
    """Heading (rad) of a pose's quaternion."""
    _, _, _, _, qx, qy, qz, qw = pose
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def pose_from_xy_yaw(t_ns: int, x: float, y: float, yaw: float) -> Pose:
    """A planar pose: z = 0 and the quaternion of a rotation by ``yaw`` about z."""
    return (int(t_ns), float(x), float(y), 0.0, 0.0, 0.0, math.sin(yaw / 2.0),
            math.cos(yaw / 2.0))


@dataclass
class Chunk:
    """One stored piece of a trajectory: the fields of a human_trajectory Trajectory.

    Build one with :meth:`from_poses` (metrics computed) or with explicit metrics (a stored
    or imported chunk keeps its own values).

    Attributes:
        uuid: the trajectory's id.
        sequence_id: the chunk's number within the trajectory, from 0.
        poses: its poses, at least one, stamps not decreasing.
        complete: True for the last chunk of a trajectory.
        trajectory_length, trajectory_displacement, displacement_pose_ratio: the metrics.
        frame_id: the poses' frame.
        region: the region the chunk was recorded in (``split="region"``), else None.
        closed_by: why it was closed: period, region, size, gap, time_jump, end.
        map_name: the map it belongs to (stored meta), when known.
    """

    uuid: str
    sequence_id: int
    poses: List[Pose]
    complete: bool
    trajectory_length: float
    trajectory_displacement: float
    displacement_pose_ratio: float
    frame_id: str = "map"
    region: Optional[str] = None
    closed_by: str = ""
    map_name: Optional[str] = None

    @classmethod
    def from_poses(cls, uuid: str, sequence_id: int, poses: List[Pose], complete: bool,
                   **kwargs: Any) -> "Chunk":
        """A chunk with its metrics computed from ``poses`` (see module doc)."""
        d = displacement(poses)
        return cls(uuid, sequence_id, poses, complete, path_length(poses), d,
                   d / len(poses) if poses else 0.0, **kwargs)

    @property
    def start_ns(self) -> int:
        """Stamp of the first pose, ns."""
        return self.poses[0][0]

    @property
    def end_ns(self) -> int:
        """Stamp of the last pose, ns."""
        return self.poses[-1][0]


# -- chunking ---------------------------------------------------------------------------------

class Chunker:
    """Cuts a pose stream into chunks (see module doc). Not thread-safe: one caller at a time.

    Args:
        period: seconds of stamp time after which a chunk closes (0: never, only with
            ``split="region"``).
        split: "period" or "region".
        max_poses: the most poses a chunk holds (>= 2); a full chunk closes ("size").
        max_gap: seconds without a pose after which the trajectory ends (0: never).
        region_of: ``(x, y) -> region id or None``; required with ``split="region"``.
        new_uuid: makes trajectory ids (default: random UUID4 strings).

    Raises:
        TrajectoryError: a bad setting, named.
    """

    def __init__(self, period: float = DEFAULT_PERIOD, split: str = "period",
                 max_poses: int = DEFAULT_MAX_POSES, max_gap: float = DEFAULT_MAX_GAP,
                 region_of: Optional[Callable[[float, float], Optional[str]]] = None,
                 new_uuid: Optional[Callable[[], str]] = None):
        if split not in SPLITS:
            raise TrajectoryError("split %r: use one of %s" % (split, ", ".join(SPLITS)))
        if not _finite_at_least(period, 0.0) or (split == "period" and period == 0):
            raise TrajectoryError("period %r: must be a finite number of seconds > 0 (>= 0 "
                                  "with split region)" % (period,))
        if isinstance(max_poses, bool) or not isinstance(max_poses, int) or max_poses < 2:
            raise TrajectoryError("max_poses %r: must be an integer >= 2" % (max_poses,))
        if not _finite_at_least(max_gap, 0.0):
            raise TrajectoryError("max_gap %r: must be a finite number of seconds >= 0 (0: "
                                  "never end a trajectory on a gap)" % (max_gap,))
        if split == "region" and region_of is None:
            raise TrajectoryError("split region needs regions (a ROI file or the ROI service)")
        self.period = float(period)
        self.split = split
        self.max_poses = max_poses
        self.max_gap = float(max_gap)
        self._period_ns = int(round(period * _NS))
        self._gap_ns = int(round(max_gap * _NS))
        self._region_of = region_of if split == "region" else None
        self._new_uuid = new_uuid or (lambda: str(uuidlib.uuid4()))
        self._uuid: Optional[str] = None
        self._seq = 0
        self._poses: List[Pose] = []
        self._start = 0
        self._region: Optional[str] = None
        self.poses_added = 0

    @property
    def uuid(self) -> Optional[str]:
        """The open trajectory's id (None between trajectories)."""
        return self._uuid

    @property
    def sequence_id(self) -> int:
        """The open chunk's number within its trajectory."""
        return self._seq

    @property
    def open_poses(self) -> List[Pose]:
        """The poses of the open chunk (do not modify)."""
        return self._poses

    @property
    def region(self) -> Optional[str]:
        """The open chunk's region (``split="region"``)."""
        return self._region

    def add(self, pose: Pose) -> List[Chunk]:
        """Record one pose.

        Returns:
            The chunks this pose closed, oldest first: none, one, or (after a gap or a jump
            back in time, when the new pose itself closes nothing) the ended trajectory's last.
        """
        t = pose[0]
        closed: List[Chunk] = []
        if self._uuid is not None:
            last = self._poses[-1][0]
            if t < last:
                closed.append(self._end("time_jump"))
            elif self._gap_ns and t - last > self._gap_ns:
                closed.append(self._end("gap"))
        self.poses_added += 1
        if self._uuid is None:
            self._uuid, self._seq, self._start = self._new_uuid(), 0, t
            self._poses = [pose]
            if self._region_of is not None:
                self._region = self._region_of(pose[1], pose[2])
            return closed
        self._poses.append(pose)
        region = self._region
        if self._region_of is not None:
            region = self._region_of(pose[1], pose[2])
        if region != self._region:
            closed.append(self._cut("region", pose, region))
        elif self._period_ns and t - self._start >= self._period_ns:
            closed.append(self._cut("period", pose, region))
        elif len(self._poses) >= self.max_poses:
            closed.append(self._cut("size", pose, region))
        return closed

    def check_gap(self, now_ns: int) -> Optional[Chunk]:
        """End the trajectory if its last pose is more than ``max_gap`` older than ``now_ns``.

        Returns:
            The ended trajectory's last chunk, or None.
        """
        if self._uuid is None or not self._gap_ns or now_ns - self._poses[-1][0] <= self._gap_ns:
            return None
        return self._end("gap")

    def finish(self, reason: str = "end") -> Optional[Chunk]:
        """End the open trajectory (the recorder stops, or ``reason`` says why).

        Returns:
            Its last chunk (``complete``; it may hold only the boundary pose of the previous
            chunk), or None when no trajectory is open.
        """
        if self._uuid is None:
            return None
        return self._end(reason)

    def _cut(self, reason: str, pose: Pose, region: Optional[str]) -> Chunk:
        chunk = Chunk.from_poses(self._uuid, self._seq, self._poses, False,
                                 region=self._region, closed_by=reason)
        self._seq += 1
        self._poses = [pose]
        self._start = pose[0]
        self._region = region
        return chunk

    def _end(self, reason: str) -> Chunk:
        chunk = Chunk.from_poses(self._uuid, self._seq, self._poses, True,
                                 region=self._region, closed_by=reason)
        self._uuid, self._poses, self._region = None, [], None
        return chunk


def split_poses(poses: Sequence[Pose], max_poses: int) -> List[List[Pose]]:
    """Pieces of at most ``max_poses`` poses sharing their boundary poses (never drops one).

    Raises:
        TrajectoryError: ``max_poses`` < 2.
    """
    if max_poses < 2:
        raise TrajectoryError("max_poses %r: must be an integer >= 2" % (max_poses,))
    if len(poses) <= max_poses:
        return [list(poses)]
    step = max_poses - 1
    return [list(poses[i:i + max_poses]) for i in range(0, len(poses) - 1, step)]


@dataclass
class Joined:
    """A trajectory put back together from its chunks.

    Attributes:
        uuid: its id.
        poses: every pose once (boundary poses not repeated).
        chunks: how many chunks it was made of.
        complete: its last chunk is marked complete.
        map_name: the map of its chunks.
    """

    uuid: str
    poses: List[Pose] = field(default_factory=list)
    chunks: int = 0
    complete: bool = False
    map_name: Optional[str] = None

    @property
    def end_ns(self) -> int:
        return self.poses[-1][0] if self.poses else 0


def join_chunks(chunks: Iterable[Chunk]) -> List[Joined]:
    """Group chunks by uuid and concatenate each group in ``sequence_id`` order, leaving out a
    chunk's first pose when it repeats the previous chunk's last one.

    Returns:
        One :class:`Joined` per uuid, ordered by the first pose's stamp (then uuid).
    """
    groups: Dict[str, List[Chunk]] = {}
    for c in chunks:
        groups.setdefault(c.uuid, []).append(c)
    out = []
    for uid, group in groups.items():
        group.sort(key=lambda c: c.sequence_id)
        j = Joined(uid, chunks=len(group), complete=group[-1].complete,
                   map_name=group[0].map_name)
        for c in group:
            start = 1 if j.poses and c.poses and c.poses[0] == j.poses[-1] else 0
            j.poses.extend(c.poses[start:])
        out.append(j)
    out.sort(key=lambda j: (j.poses[0][0] if j.poses else 0, j.uuid))
    return out


# -- regions ----------------------------------------------------------------------------------

class RegionLocator:
    """``region_of(x, y)`` for the chunker: the id of :func:`~.rois.roi_at`'s answer (the
    smallest ROI covering the point, boundary included), with a bounding-box pre-check and
    prepared shapely polygons (a few microseconds per pose).

    Args:
        rois: the regions (:class:`~.rois.Roi`).
    """

    def __init__(self, rois: Sequence[Any]):
        import shapely

        from .rois import roi_polygon

        entries = []
        for roi in rois:
            poly = roi_polygon(roi)
            shapely.prepare(poly)
            xs = [v[0] for v in roi.vertices]
            ys = [v[1] for v in roi.vertices]
            entries.append((poly.area, min(xs), max(xs), min(ys), max(ys), poly, roi.id))
        entries.sort(key=lambda e: e[0])  # smallest first: the first hit is the answer
        self._entries = entries
        self._test = shapely.intersects_xy
        self.ids = [e[6] for e in entries]

    def __call__(self, x: float, y: float) -> Optional[str]:
        for _, x0, x1, y0, y1, poly, rid in self._entries:
            if x0 <= x <= x1 and y0 <= y <= y1 and self._test(poly, x, y):
                return rid
        return None


# -- documents (mongodb_store's layout) -------------------------------------------------------

def _time_doc(t_ns: int) -> Dict[str, int]:
    secs, nsecs = divmod(int(t_ns), _NS)
    return {"secs": secs, "nsecs": nsecs}


def chunk_id(chunk: Chunk) -> Any:
    """The ``_id`` a chunk is stored under, the same every time it is stored (a recorder
    recovering what a killed one left cannot store it twice): an ObjectId whose seconds are
    the chunk's start and whose other 8 bytes hash (uuid, sequence_id)."""
    import bson

    secs = (int(chunk.start_ns) // _NS) & 0xFFFFFFFF
    digest = hashlib.sha1(("%s/%d" % (chunk.uuid, chunk.sequence_id)).encode("utf-8"))
    return bson.ObjectId(struct.pack(">I", secs) + digest.digest()[:8])


def max_poses_within(frame_id: str, limit: int = MAX_CHUNK_BYTES) -> int:
    """The most poses a chunk in ``frame_id`` may hold and stay under ``limit`` bytes of BSON
    (each pose as :func:`chunk_fields` stores it, with a 6-digit array index)."""
    import bson

    pose = (2 ** 40 * _NS, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    one = chunk_fields(Chunk.from_poses("u" * 36, 0, [pose], True, frame_id=frame_id))
    doc = bson.encode({"trajectory": {"999999": one["trajectory"][0]}})
    fixed = len(bson.encode(one)) + 4096        # the rest of the chunk and its _meta
    return max(2, (limit - fixed) // (len(doc) - 5))


def check_max_poses(max_poses: int, frame_id: str = "map") -> None:
    """Refuse a chunk length whose chunks would outweigh :data:`MAX_CHUNK_BYTES`.

    Raises:
        TrajectoryError: naming the most poses allowed.
    """
    most = max_poses_within(frame_id)
    if max_poses > most:
        raise TrajectoryError("max_poses %d: a chunk that long in frame %r would pass %d MB of "
                              "BSON (MongoDB refuses documents over 16 MB); at most %d"
                              % (max_poses, frame_id, MAX_CHUNK_BYTES >> 20, most))


def chunk_fields(chunk: Chunk, stamp_ns: int = 0, seq: int = 0) -> Dict[str, Any]:
    """The chunk as mongodb_store stores a human_trajectory Trajectory message (one key per
    slot, nested messages as dicts, times as ``{"secs", "nsecs"}``), without ``_meta``.

    Args:
        chunk: the chunk.
        stamp_ns: the message header's stamp (when it was stored), ns.
        seq: the message header's seq.
    """
    frame = chunk.frame_id
    poses = []
    append = poses.append
    for t, x, y, z, qx, qy, qz, qw in chunk.poses:
        secs, nsecs = divmod(t, _NS)
        append({"header": {"seq": 0, "stamp": {"secs": secs, "nsecs": nsecs},
                           "frame_id": frame},
                "pose": {"position": {"x": x, "y": y, "z": z},
                         "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}})
    return {
        "header": {"seq": int(seq), "stamp": _time_doc(stamp_ns), "frame_id": frame},
        "uuid": chunk.uuid,
        "trajectory": poses,
        "robot": [],
        "start_time": _time_doc(chunk.start_ns),
        "end_time": _time_doc(chunk.end_ns),
        "trajectory_length": float(chunk.trajectory_length),
        "complete": bool(chunk.complete),
        "sequence_id": int(chunk.sequence_id),
        "trajectory_displacement": float(chunk.trajectory_displacement),
        "displacement_pose_ratio": float(chunk.displacement_pose_ratio),
    }


def _pose_of_doc(s: Dict[str, Any], o: Dict[str, Any], q: Dict[str, Any]) -> Pose:
    return (s["secs"] * _NS + s["nsecs"], o["x"], o["y"], o["z"], q["x"], q["y"], q["z"],
            q["w"])


def chunk_from_document(doc: Dict[str, Any]) -> Chunk:
    """A stored Trajectory document (ours or human_trajectory's) as a :class:`Chunk`.

    Raises:
        TrajectoryError: a field is missing or has the wrong shape; names the document.
    """
    try:
        poses = [_pose_of_doc(p["header"]["stamp"], p["pose"]["position"],
                              p["pose"]["orientation"]) for p in doc["trajectory"]]
        if not poses:
            raise TrajectoryError("stored trajectory %s: no poses" % (doc.get("_id"),))
        frame = doc["trajectory"][0]["header"].get("frame_id", "map") or "map"
        meta = doc.get("_meta") or {}
        return Chunk(str(doc["uuid"]), int(doc.get("sequence_id", 0)), poses,
                     bool(doc.get("complete", False)), float(doc["trajectory_length"]),
                     float(doc.get("trajectory_displacement", displacement(poses))),
                     float(doc.get("displacement_pose_ratio", 0.0)), frame_id=frame,
                     region=meta.get("region"), closed_by=meta.get("closed_by", ""),
                     map_name=meta.get("map"))
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        raise TrajectoryError("stored trajectory %s: malformed (%s: %s)"
                              % (doc.get("_id") if isinstance(doc, dict) else "?",
                                 type(e).__name__, e)) from None


# -- JSON lines -------------------------------------------------------------------------------

def format_time(t_ns: int) -> str:
    """Nanoseconds as decimal seconds with 9 digits, e.g. 12.300000000 (a JSON number)."""
    secs, nsecs = divmod(int(t_ns), _NS)
    return "%d.%09d" % (secs, nsecs)


def parse_time(value: Any, what: str = "time") -> int:
    """Seconds (int, float, Decimal or a numeric string) as integer nanoseconds (rounded).

    Raises:
        TrajectoryError: not a finite number >= 0.
    """
    try:
        if isinstance(value, bool):
            raise ValueError
        d = decimal.Decimal(value if not isinstance(value, float) else repr(value))
        if not d.is_finite() or d < 0:
            raise ValueError
        return int((d * _NS).to_integral_value(decimal.ROUND_HALF_EVEN))
    except (ValueError, TypeError, decimal.InvalidOperation):
        raise TrajectoryError("%s %r: must be a number of seconds >= 0" % (what, value)) from None


def chunk_to_json(chunk: Chunk) -> str:
    """One export line: ``{"uuid", "sequence_id", "start_time", "end_time", "complete",
    "trajectory_length", "poses": [[t, x, y, yaw], ...]}``, t in seconds (9 decimals)."""
    atan2 = math.atan2
    fmt = "[%d.%09d, %r, %r, %r]".__mod__
    parts = [fmt((t // _NS, t % _NS, x, y,
                  atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))))
             for t, x, y, _, qx, qy, qz, qw in chunk.poses]
    return ('{"uuid": %s, "sequence_id": %d, "start_time": %s, "end_time": %s, '
            '"complete": %s, "trajectory_length": %r, "poses": [%s]}'
            % (json.dumps(chunk.uuid), chunk.sequence_id, format_time(chunk.start_ns),
               format_time(chunk.end_ns), "true" if chunk.complete else "false",
               float(chunk.trajectory_length), ", ".join(parts)))


_LINE_KEYS = ("uuid", "sequence_id", "start_time", "end_time", "complete",
              "trajectory_length", "poses")


def chunk_from_json(line: str, where: str = "line") -> Chunk:
    """Parse an export line back (poses become planar: z = 0, quaternion from yaw).

    ``start_time``/``end_time`` must be the first and last pose's stamps; metrics are taken
    from the line (``trajectory_length``) or computed (displacement, ratio).

    Raises:
        TrajectoryError: not JSON, missing or unknown keys, bad values; names ``where``.
    """
    try:
        doc = json.loads(line, parse_float=decimal.Decimal)
    except ValueError as e:
        raise TrajectoryError("%s: not JSON (%s)" % (where, e)) from None
    if not isinstance(doc, dict):
        raise TrajectoryError("%s: expected a JSON object with keys %s"
                              % (where, ", ".join(_LINE_KEYS)))
    missing = [k for k in _LINE_KEYS if k not in doc]
    unknown = sorted(k for k in doc if k not in _LINE_KEYS)
    if missing or unknown:
        raise TrajectoryError("%s: %s" % (where, "; ".join(
            (["missing key(s) " + ", ".join(missing)] if missing else [])
            + (["unknown key(s) " + ", ".join(unknown)] if unknown else []))))
    uid, seq, complete = doc["uuid"], doc["sequence_id"], doc["complete"]
    if not isinstance(uid, str) or not uid:
        raise TrajectoryError("%s: uuid must be a non-empty string, got %r" % (where, uid))
    if isinstance(seq, bool) or not isinstance(seq, int) or seq < 0:
        raise TrajectoryError("%s: sequence_id must be an integer >= 0, got %r" % (where, seq))
    if not isinstance(complete, bool):
        raise TrajectoryError("%s: complete must be true or false, got %r" % (where, complete))
    raw = doc["poses"]
    if not isinstance(raw, list) or not raw:
        raise TrajectoryError("%s: poses must be a non-empty list of [t, x, y, yaw]" % where)
    poses = []
    last = -1
    for k, p in enumerate(raw):
        if not isinstance(p, list) or len(p) != 4:
            raise TrajectoryError("%s: poses[%d] must be [t, x, y, yaw], got %r" % (where, k, p))
        t = parse_time(p[0], "%s: poses[%d] t" % (where, k))
        try:
            x, y, yaw = (float(v) for v in p[1:])
            if isinstance(p[1], bool) or not all(map(math.isfinite, (x, y, yaw))):
                raise ValueError
        except (TypeError, ValueError):
            raise TrajectoryError("%s: poses[%d] x, y, yaw must be finite numbers, got %r"
                                  % (where, k, p[1:])) from None
        if t < last:
            raise TrajectoryError("%s: poses[%d] t %s is before the previous pose's"
                                  % (where, k, format_time(t)))
        last = t
        poses.append(pose_from_xy_yaw(t, x, y, yaw))
    for key, want in (("start_time", poses[0][0]), ("end_time", poses[-1][0])):
        if parse_time(doc[key], "%s: %s" % (where, key)) != want:
            raise TrajectoryError("%s: %s %s is not the %s pose's time %s" % (
                where, key, doc[key], "first" if key == "start_time" else "last",
                format_time(want)))
    try:
        length = float(doc["trajectory_length"])
        if not math.isfinite(length) or length < 0 or isinstance(doc["trajectory_length"], bool):
            raise ValueError
    except (TypeError, ValueError):
        raise TrajectoryError("%s: trajectory_length must be a number of metres >= 0, got %r"
                              % (where, doc["trajectory_length"])) from None
    d = displacement(poses)
    return Chunk(uid, seq, poses, complete, length, d, d / len(poses))


# -- queries ----------------------------------------------------------------------------------

def ensure_indexes(store: Any, database: str = DATABASE, collection: str = COLLECTION) -> None:
    """Create (if missing) the indexes :func:`iter_documents` and the viewer rely on."""
    for keys in INDEXES:
        store.create_index(database, collection, keys)


def _span(doc: Dict[str, Any]) -> Tuple[int, int]:
    """(first, last) pose stamp of a stored chunk, ns."""
    try:
        a = doc["trajectory"][0]["header"]["stamp"]
        b = doc["trajectory"][-1]["header"]["stamp"]
        return a["secs"] * _NS + a["nsecs"], b["secs"] * _NS + b["nsecs"]
    except (KeyError, IndexError, TypeError) as e:
        raise TrajectoryError("stored trajectory %s: malformed (%s: %s)"
                              % (doc.get("_id"), type(e).__name__, e)) from None


@dataclass
class Head:
    """A stored trajectory as :func:`trajectory_heads` finds it.

    Attributes:
        uuid: its id.
        start_ns: first pose of its first chunk; end_ns: last pose of its last chunk.
        first_seq, last_seq: its first and last ``sequence_id``.
        only: the document, when the trajectory is a single chunk (already read).
    """

    uuid: Any
    start_ns: int
    end_ns: int
    first_seq: int
    last_seq: int
    only: Optional[Dict[str, Any]] = field(default=None, repr=False)


def trajectory_heads(store: Any, map_name: Optional[str] = None,
                     since_ns: Optional[int] = None, until_ns: Optional[int] = None,
                     database: str = DATABASE, collection: str = COLLECTION) -> List[Head]:
    """The stored trajectories of ``map_name`` (all when empty) that reach into
    [since, until], ordered by their first pose (then uuid).

    One ``latest(group_by=uuid, order_by=sequence_id)`` (an index walk reading the last chunk
    of each trajectory) and, for trajectories of several chunks, one indexed lookup of the
    first chunk. A trajectory's chunks are taken to follow each other in time (the recorder
    starts a new trajectory when stamps jump back), so its span is [first start, last end].
    Needs :func:`ensure_indexes`. Memory: the last chunk of every trajectory is read at once
    (and single-chunk trajectories are kept for :func:`iter_documents`), so a collection of
    very many short trajectories is held whole; long recordings are not.

    Raises:
        StoreUnavailable: the database cannot be read now.
        TrajectoryError: a stored document is malformed.
    """
    heads = []
    for last in store.latest(database, collection, ["uuid"], "sequence_id"):
        if map_name and _map_of(last) != map_name:
            continue
        end = _span(last)[1]
        if since_ns is not None and end < since_ns:
            continue
        uid, last_seq = last.get("uuid"), _seq(last)
        if last_seq == 0:
            first, only = last, last
        else:
            first = store.find(database, collection, {"uuid": uid}, sort=[("sequence_id", 1)],
                               limit=1)[0]
            only = first if _seq(first) == last_seq else None
        start = _span(first)[0]
        if until_ns is not None and start > until_ns:
            continue
        heads.append(Head(uid, start, end, _seq(first), last_seq, only))
    heads.sort(key=lambda h: (h.start_ns, str(h.uuid)))
    return heads


# iter_documents reads a trajectory's chunks this many at a time at most ($in on
# sequence_id: the embedded store checks each document against every value in Python), and
# aims at about this many poses per read.
_PAGE_CHUNKS = 16
_PAGE_POSES = 20000


def iter_documents(store: Any, map_name: Optional[str] = None, since_ns: Optional[int] = None,
                   until_ns: Optional[int] = None, heads: Optional[List[Head]] = None,
                   database: str = DATABASE, collection: str = COLLECTION
                   ) -> Iterator[Dict[str, Any]]:
    """The stored chunks of ``map_name`` that end at or after ``since_ns`` and start at or
    before ``until_ns``, as documents: trajectory after trajectory (in order of their first
    pose), each in ``sequence_id`` order.

    Memory stays bounded however much is stored (a day of one walker at 10 Hz decodes to
    1.5 GB of dicts at once): each trajectory is read a few chunks at a time, by indexed
    ``{"uuid": u, "sequence_id": {"$in": [...]}}`` lookups (:func:`ensure_indexes`).

    Args:
        heads: the trajectories to read (default: :func:`trajectory_heads` of the same
            selection).

    Raises:
        StoreUnavailable: the database cannot be read now.
        TrajectoryError: a stored document is malformed.
    """
    if heads is None:
        heads = trajectory_heads(store, map_name, since_ns, until_ns, database, collection)
    for head in heads:
        if head.only is not None:
            pages: Iterable[List[Dict[str, Any]]] = [[head.only]]
        else:
            pages = _pages(store, head, database, collection)
        for page in pages:
            for doc in page:
                if (not map_name or _map_of(doc) == map_name) and _wanted(doc, since_ns,
                                                                          until_ns):
                    yield doc


def _pages(store: Any, head: Head, database: str, collection: str
           ) -> Iterator[List[Dict[str, Any]]]:
    seq, k = head.first_seq, 2
    while seq <= head.last_seq:
        n = min(k, head.last_seq - seq + 1)
        docs = store.find(database, collection, {"uuid": head.uuid, "sequence_id": {
            "$in": list(range(seq, seq + n))}})
        docs.sort(key=_seq)
        poses = sum(len(d.get("trajectory") or ()) for d in docs)
        yield docs
        del docs
        seq += n
        k = max(1, min(_PAGE_CHUNKS, n * _PAGE_POSES // poses)) if poses else _PAGE_CHUNKS


def _seq(doc: Dict[str, Any]) -> int:
    try:
        return int(doc.get("sequence_id", 0))
    except (TypeError, ValueError):
        raise TrajectoryError("stored trajectory %s: bad sequence_id %r"
                              % (doc.get("_id"), doc.get("sequence_id"))) from None


def _map_of(doc: Dict[str, Any]) -> Any:
    meta = doc.get("_meta")
    return meta.get("map") if isinstance(meta, dict) else None


def _wanted(doc: Dict[str, Any], since_ns: Optional[int], until_ns: Optional[int]) -> bool:
    start, end = _span(doc)
    return not ((since_ns is not None and end < since_ns)
                or (until_ns is not None and start > until_ns))


def document_to_json(doc: Dict[str, Any]) -> str:
    """``chunk_to_json(chunk_from_document(doc))``, formatted straight from the document
    (the export's inner loop, in about half the time).

    Raises:
        TrajectoryError: the document is malformed.
    """
    atan2 = math.atan2
    fmt = "[%d.%09d, %r, %r, %r]".__mod__
    try:
        parts = []
        for p in doc["trajectory"]:
            s, o, q = p["header"]["stamp"], p["pose"]["position"], p["pose"]["orientation"]
            if not 0 <= s["nsecs"] < _NS:
                raise ValueError
            qx, qy, qz, qw = q["x"], q["y"], q["z"], q["w"]
            parts.append(fmt((s["secs"], s["nsecs"], o["x"], o["y"], atan2(
                2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz)))))
        start, end = _span(doc)
        return ('{"uuid": %s, "sequence_id": %d, "start_time": %s, "end_time": %s, '
                '"complete": %s, "trajectory_length": %r, "poses": [%s]}'
                % (json.dumps(str(doc["uuid"])), int(doc.get("sequence_id", 0)),
                   format_time(start), format_time(end),
                   "true" if doc.get("complete", False) else "false",
                   float(doc["trajectory_length"]), ", ".join(parts)))
    except (KeyError, IndexError, TypeError, ValueError, TrajectoryError):
        # malformed, or unnormalised stamps: the general path says what is wrong, or copes
        return chunk_to_json(chunk_from_document(doc))


def select_chunks(store: Any, map_name: Optional[str] = None, since_ns: Optional[int] = None,
                  until_ns: Optional[int] = None, last_n: int = 0,
                  database: str = DATABASE, collection: str = COLLECTION) -> List[Chunk]:
    """Stored chunks of ``map_name`` (all maps when empty) overlapping [since, until], of the
    ``last_n`` trajectories that end last (0: all), in :func:`iter_documents`' order.

    Raises:
        StoreUnavailable: the database cannot be read now.
        TrajectoryError: a stored document is malformed.
    """
    heads = trajectory_heads(store, map_name, since_ns, until_ns, database, collection)
    if last_n and last_n > 0:
        keep = {id(h) for h in sorted(heads, key=lambda h: (h.end_ns, str(h.uuid)))[-last_n:]}
        heads = [h for h in heads if id(h) in keep]
    return [chunk_from_document(d) for d in iter_documents(
        store, map_name, since_ns, until_ns, heads, database, collection)]


def _finite_at_least(v: Any, low: float) -> bool:
    return (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            and v >= low)
