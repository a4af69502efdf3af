"""Chunks as stored documents (mongodb_store's layout) and JSON lines, and reading them back
trajectory by trajectory. See the package doc (data/trajectory)."""
from __future__ import annotations


import decimal
import hashlib
import json
import math
import struct
from dataclasses import dataclass, field
from typing import Any, Collection, Dict, Iterable, Iterator, List, Optional, Tuple, Union

from .chunks import Chunk, Pose, TrajectoryError, displacement, pose_from_xy_yaw


DATABASE = "message_store"
COLLECTION = "people_trajectory"
STORED_TYPE = "human_trajectory/Trajectory"
#: The most a stored chunk may weigh as BSON: half of MongoDB's 16 MB document limit.
MAX_CHUNK_BYTES = 8 * 1024 * 1024
# Indexes the recorder (and the readers) create: (uuid, sequence_id) and sequence_id let the
# embedded store answer latest(uuid, sequence_id) and chunk lookups from the index alone;
# start time and map serve users' own queries.
INDEXES = ([("uuid", 1), ("sequence_id", 1)], [("sequence_id", 1)], [("start_time.secs", 1)],
           [("_meta.map", 1)])


_NS = 1000000000


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
    poses = []  # type: List[Dict[str, Any]]
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
        meta: its last chunk's ``_meta`` (map, person or robot).
    """

    uuid: Any
    start_ns: int
    end_ns: int
    first_seq: int
    last_seq: int
    only: Optional[Dict[str, Any]] = field(default=None, repr=False)
    meta: Dict[str, Any] = field(default_factory=dict, repr=False)


#: a person's name, several, or None (everyone)
Persons = Union[None, str, Collection[str]]
#: what ``kind`` selects: everyone, people (``_meta.person``), robots (``_meta.robot``)
KINDS = ("", "people", "robots")   # robots: ``_meta.robot`` (the recorder of a pose topic)


def _names(person: Persons) -> frozenset:
    if not person:
        return frozenset()
    return frozenset([person] if isinstance(person, str) else person)


def _is_of(doc: Dict[str, Any], names: frozenset, kind: str) -> bool:
    meta = doc.get("_meta") or {}
    who = meta.get("person")
    if names:
        return who is not None and str(who) in names
    if kind == "people":
        return bool(who)
    return kind == "" or bool(meta.get("robot")) and not who


def stored_people(store: Any, database: str = DATABASE, collection: str = COLLECTION
                  ) -> List[str]:
    """Every person's name that a stored trajectory carries (``_meta.person``), sorted.

    Raises:
        StoreUnavailable: the database cannot be read now.
    """
    return sorted({str(p) for d in store.latest(database, collection, ["uuid"], "sequence_id")
                   for p in [(d.get("_meta") or {}).get("person")] if p})


def trajectory_heads(store: Any, map_name: Optional[str] = None,
                     since_ns: Optional[int] = None, until_ns: Optional[int] = None,
                     database: str = DATABASE, collection: str = COLLECTION,
                     person: Persons = None, kind: str = "") -> List[Head]:
    """The stored trajectories of ``map_name`` (all when empty) that reach into
    [since, until], ordered by their first pose (then uuid); with ``person`` (a name or
    several), only those people's (``_meta.person``, as the recorder of a people topic stores
    them); with ``kind`` "people" or "robots", only people's or only robots'
    (``_meta.robot``, as the recorder of a pose topic stores it; chunks that name neither,
    e.g. imported ones, are in neither).

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
    if kind not in KINDS:
        raise ValueError("kind %r: use one of %s" % (kind, ", ".join(repr(k) for k in KINDS)))
    names = _names(person)
    heads = []
    for last in store.latest(database, collection, ["uuid"], "sequence_id"):
        if map_name and _map_of(last) != map_name:
            continue
        if not _is_of(last, names, kind):
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
        heads.append(Head(uid, start, end, _seq(first), last_seq, only,
                          dict(last.get("_meta") or {})))
    heads.sort(key=lambda h: (h.start_ns, str(h.uuid)))
    return heads


# iter_documents reads a trajectory's chunks this many at a time at most ($in on
# sequence_id: the embedded store checks each document against every value in Python), and
# aims at about this many poses per read.
_PAGE_CHUNKS = 16
_PAGE_POSES = 20000


def iter_documents(store: Any, map_name: Optional[str] = None, since_ns: Optional[int] = None,
                   until_ns: Optional[int] = None, heads: Optional[List[Head]] = None,
                   database: str = DATABASE, collection: str = COLLECTION,
                   person: Persons = None, kind: str = "") -> Iterator[Dict[str, Any]]:
    """The stored chunks of ``map_name`` that end at or after ``since_ns`` and start at or
    before ``until_ns``, as documents: trajectory after trajectory (in order of their first
    pose), each in ``sequence_id`` order.

    Memory stays bounded however much is stored (a day of one walker at 10 Hz decodes to
    1.5 GB of dicts at once): each trajectory is read a few chunks at a time, by indexed
    ``{"uuid": u, "sequence_id": {"$in": [...]}}`` lookups (:func:`ensure_indexes`).

    Args:
        heads: the trajectories to read (default: :func:`trajectory_heads` of the same
            selection).
        person, kind: only these people's, or only people's or robots' trajectories (when
            ``heads`` is not given; see :func:`trajectory_heads`).

    Raises:
        StoreUnavailable: the database cannot be read now.
        TrajectoryError: a stored document is malformed.
    """
    if heads is None:
        heads = trajectory_heads(store, map_name, since_ns, until_ns, database, collection,
                                 person, kind)
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
                  database: str = DATABASE, collection: str = COLLECTION,
                  person: Optional[str] = None) -> List[Chunk]:
    """Stored chunks of ``map_name`` (all maps when empty) overlapping [since, until], of the
    ``last_n`` trajectories that end last (0: all), of ``person`` when given, in
    :func:`iter_documents`' order.

    Raises:
        StoreUnavailable: the database cannot be read now.
        TrajectoryError: a stored document is malformed.
    """
    heads = trajectory_heads(store, map_name, since_ns, until_ns, database, collection,
                             person)
    if last_n and last_n > 0:
        keep = {id(h) for h in sorted(heads, key=lambda h: (h.end_ns, str(h.uuid)))[-last_n:]}
        heads = [h for h in heads if id(h) in keep]
    return [chunk_from_document(d) for d in iter_documents(
        store, map_name, since_ns, until_ns, heads, database, collection)]
