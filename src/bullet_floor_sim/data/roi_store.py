"""ROIs in the document store, as SOMA keeps them.

Every saved ROI is a new document (SOMA kept history): the SOMAROIObject fields as mongodb_store
writes a message (``header``, ``id``, ``map_name``, ``config``, ``type``, ``logtimestamp`` ...,
``posearray`` with one pose per vertex, ``geotype: Polygon``) plus ``_meta`` with
``stored_type: soma_msgs/SOMAROIObject`` and ``version``, a number increasing per (map, config,
id) that orders the versions exactly (``logtimestamp`` has one-second resolution): the write
time in milliseconds, or one more than the previous version when that is larger. Deleting an ROI
writes a version with ``_meta.deleted: true``: the ROI disappears from queries, its history
stays. Default place: database ``somadata``, collection ``roi``, as SOMA's ROI manager.

:class:`RoiStore` reads and writes them (and answers SOMA's SOMAQueryROIs semantics); the
rviz menu's edits are in data/roi_edits.py. No rospy here.
"""
from __future__ import annotations

import datetime
import json
import math
import time
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

from .rois import Roi, RoiError, id_order, validate_roi, validate_rois
from .store import Store, StoreUnavailable, message_document

__all__ = [
    "DATABASE",
    "COLLECTION",
    "STORED_TYPE",
    "RoiQuery",
    "RoiStore",
    "roi_to_fields",
    "roi_from_document",
]

DATABASE = "somadata"
COLLECTION = "roi"
STORED_TYPE = "soma_msgs/SOMAROIObject"
_INDEX = [("map_name", 1), ("config", 1), ("id", 1), ("_meta.version", 1)]
_EPOCH = datetime.datetime(1970, 1, 1)


# --------------------------------------------------------------------------------------------
# documents
# --------------------------------------------------------------------------------------------


def _pose(x: float, y: float) -> Dict[str, Any]:
    return {"position": {"x": float(x), "y": float(y), "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}


def _header(stamp: float, frame_id: str) -> Dict[str, Any]:
    secs = int(math.floor(stamp))
    return {"seq": 0, "stamp": {"secs": secs, "nsecs": int(round((stamp - secs) * 1e9)) % 10**9},
            "frame_id": frame_id}


def roi_to_fields(roi: Roi, logtimestamp: int, frame_id: str = "map") -> Dict[str, Any]:
    """The SOMAROIObject fields of ``roi`` as mongodb_store stores them (a plain dict).

    Args:
        roi: the ROI.
        logtimestamp: Unix time (UTC seconds) of this version; logday/loghour/logminute/
            logtimeminutes are derived from it as SOMA's insert service does.
        frame_id: the frame of the vertices.
    """
    t = _EPOCH + datetime.timedelta(seconds=int(logtimestamp))
    header = _header(float(logtimestamp), frame_id)
    return {
        "header": header,
        "id": roi.id,
        "map_name": roi.map_name,
        "map_unique_id": roi.map_name,
        "config": roi.config,
        "type": roi.type,
        "logtimestamp": int(logtimestamp),
        "logday": t.isoweekday(),
        "loghour": t.hour,
        "logminute": t.minute,
        "logtimeminutes": t.hour * 60 + t.minute,
        "posearray": {"header": header, "poses": [_pose(x, y) for x, y in roi.vertices]},
        "geotype": "Polygon",
        "geoposearray": {"header": header, "poses": []},
    }


def roi_from_document(doc: Any, what: str = "stored ROI") -> Roi:
    """The ROI a SOMAROIObject document describes (a stored document, a message's fields:
    :func:`ros.soma.roi_from_msg`, or a dict with the same fields): the one conversion of
    SOMA's ROIs. The vertices are ``posearray.poses[k].position.{x, y}``; a closing vertex
    equal to the first is dropped, as in rois.yaml. Not validated (data/rois.validate_roi).

    Raises:
        RoiError: the document lacks a field or has a malformed one; the error names it as
            ``what`` and its id (e.g. 'stored ROI "7": ...').
    """
    label = '%s "%s"' % (what, doc["id"]) if isinstance(doc, Mapping) and "id" in doc \
        else what
    if not isinstance(doc, Mapping):
        raise RoiError("%s: not a SOMAROIObject document (a %s)" % (label, type(doc).__name__))
    missing = [f for f in ("id", "config", "type", "map_name", "posearray") if f not in doc]
    if missing:
        raise RoiError("%s: not a SOMAROIObject document: missing field(s) %s"
                       % (label, ", ".join(missing)))
    try:
        vertices = [(float(p["position"]["x"]), float(p["position"]["y"]))
                    for p in doc["posearray"]["poses"]]
    except (KeyError, TypeError, ValueError) as e:
        raise RoiError("%s: not a SOMAROIObject document: posearray.poses[k].position.x/y "
                       "expected (%s: %s)" % (label, type(e).__name__, e)) from None
    if len(vertices) > 1 and vertices[0] == vertices[-1]:
        vertices.pop()
    return Roi(id=str(doc["id"]), config=str(doc["config"]), type=str(doc["type"]),
               map_name=str(doc["map_name"]), vertices=vertices)


# --------------------------------------------------------------------------------------------
# SOMA query
# --------------------------------------------------------------------------------------------


class RoiQuery:
    """SOMAQueryROIs' request fields (soma_query_manager semantics).

    query_type 0 queries ROIs; 1 lists the ids and configs only. Time of day limits compare
    ``logtimeminutes`` with hour * 60 + minutes; date limits compare ``logtimestamp`` (a limit
    of 0 is ignored); ``weekday`` is ISO (1 = Monday). ``roiids``/``roiconfigs`` are OR-ed
    within each list; an empty list does not filter. ``returnmostrecent`` keeps the newest
    version of each ROI (after the other filters).
    """

    FIELDS = ("query_type", "uselowertime", "useuppertime", "usedates", "useweekday",
              "returnmostrecent", "lowerhour", "upperhour", "lowerminutes", "upperminutes",
              "lowerdate", "upperdate", "weekday", "roiids", "roiconfigs")

    # set by name in __init__ (declared for the type checker)
    uselowertime: bool
    useuppertime: bool
    usedates: bool
    useweekday: bool
    returnmostrecent: bool
    lowerhour: int
    upperhour: int
    lowerminutes: int
    upperminutes: int
    lowerdate: int
    upperdate: int
    weekday: int

    def __init__(self, **fields: Any) -> None:
        unknown = sorted(set(fields) - set(self.FIELDS))
        if unknown:
            raise RoiError("ROI query: unknown field(s) %s" % ", ".join(unknown))
        self.query_type = int(fields.get("query_type", 0))
        for name in ("uselowertime", "useuppertime", "usedates", "useweekday",
                     "returnmostrecent"):
            setattr(self, name, bool(fields.get(name, False)))
        for name in ("lowerhour", "upperhour", "lowerminutes", "upperminutes", "lowerdate",
                     "upperdate", "weekday"):
            setattr(self, name, int(fields.get(name, 0)))
        self.roiids = [str(i) for i in fields.get("roiids", []) or []]
        self.roiconfigs = [str(c) for c in fields.get("roiconfigs", []) or []]

    @classmethod
    def from_request(cls, request: Any) -> "RoiQuery":
        """From a SOMAQueryROIs request (any object with the fields as attributes)."""
        return cls(**{name: getattr(request, name) for name in cls.FIELDS
                      if hasattr(request, name)})

    @property
    def timed(self) -> bool:
        """True when a time of day, date or weekday limit applies."""
        return bool(self.uselowertime or self.useuppertime or self.useweekday
                    or (self.usedates and (self.lowerdate > 0 or self.upperdate > 0)))

    def filter(self, map_name: str) -> Dict[str, Any]:
        """The MongoDB filter of this query on ``map_name`` (one flat document, so the
        embedded store can answer it from its indexes)."""
        flt: Dict[str, Any] = {"map_name": map_name}
        for field, values in (("id", self.roiids), ("config", self.roiconfigs)):
            if len(values) == 1:
                flt[field] = values[0]
            elif values:
                flt[field] = {"$in": list(values)}
        minutes: Dict[str, int] = {}
        if self.uselowertime:
            minutes["$gte"] = self.lowerhour * 60 + self.lowerminutes
        if self.useuppertime:
            minutes["$lte"] = self.upperhour * 60 + self.upperminutes
        if minutes:
            flt["logtimeminutes"] = minutes
        dates: Dict[str, int] = {}
        if self.usedates and self.lowerdate > 0:
            dates["$gte"] = self.lowerdate
        if self.usedates and self.upperdate > 0:
            dates["$lte"] = self.upperdate
        if dates:
            flt["logtimestamp"] = dates
        if self.useweekday:
            flt["logday"] = self.weekday
        return flt

    def selects(self, doc: Dict[str, Any]) -> bool:
        """Whether the id/config lists select ``doc`` (the untimed part of the filter)."""
        return ((not self.roiids or doc.get("id") in self.roiids)
                and (not self.roiconfigs or doc.get("config") in self.roiconfigs))


# --------------------------------------------------------------------------------------------
# the store
# --------------------------------------------------------------------------------------------


class RoiStore:
    """ROI versions of one map in a :class:`~.store.Store`.

    Args:
        store: the open store.
        map_name: the map whose ROIs this reads and writes.
        inserted_by: the writing node's name (``_meta.inserted_by``).
        database, collection: where the ROIs live (SOMA's defaults).
        clock: seconds since the epoch for ``logtimestamp`` (wall clock by default).

    The newest versions (:meth:`current`, and queries for the most recent ROIs) are answered
    from the last ones read, with this store's own writes since, while the database is down;
    history and timed queries are not.
    """

    def __init__(self, store: Store, map_name: str, inserted_by: str = "",
                 database: str = DATABASE, collection: str = COLLECTION,
                 clock: Any = time.time) -> None:
        if not isinstance(map_name, str) or not map_name:
            raise RoiError("ROI store: map_name must be a non-empty string, got %r"
                           % (map_name,))
        self.store = store
        self.map_name = map_name
        self.inserted_by = inserted_by
        self.database = database
        self.collection = collection
        self._clock = clock
        self._versions: Dict[Tuple[str, str], int] = {}
        self._cache: Optional[Dict[Tuple[Any, Any], Dict[str, Any]]] = None
        self.from_memory = 0   # reads answered from the cache while the database was down
        store.create_index(database, collection, _INDEX)

    # -- reads ----------------------------------------------------------------------------------

    def _latest_docs(self, config: Optional[str] = None) -> List[Dict[str, Any]]:
        # Grouped on the map alone, the embedded store answers from its index in one SQL
        # GROUP BY (about 12 ms for 100 ROIs among 10,000 versions); the config is filtered
        # here, since the group keys include it.
        # While the database is down, the newest versions last read (and this store's own
        # writes since, journalled) answer: the ROIs do not vanish with the database.
        try:
            docs = self.store.latest(self.database, self.collection, ["config", "id"],
                                     "_meta.version", filter={"map_name": self.map_name})
            self._cache = {(d.get("config"), d.get("id")): d for d in docs}
        except StoreUnavailable:
            if self._cache is None:
                raise
            self.from_memory += 1
            cached = list(self._cache.items())   # the saver thread may add to it meanwhile
            docs = [d for _, d in sorted(cached, key=lambda kv: (str(kv[0][0]), str(kv[0][1])))]
        return [d for d in docs if config is None or d.get("config") == config]

    def current(self, config: Optional[str] = None) -> List[Roi]:
        """The newest version of every ROI not deleted (of one config, or all), by
        (config, id) with numeric ids in numeric order.

        Raises:
            StoreUnavailable: the database is down.
        """
        docs = self._latest_docs(config)
        for doc in docs:
            self._note_version(doc)
        rois = [roi_from_document(d) for d in docs if not _deleted(d)]
        return sorted(rois, key=lambda r: (r.config, id_order(r.id)))

    def versions(self, config: Optional[str] = None) -> Dict[Tuple[str, str], int]:
        """The newest version number of every ROI ((config, id) -> version; deleted included).
        """
        docs = self._latest_docs(config)
        return {(d["config"], d["id"]): int(d.get("_meta", {}).get("version", 0)) for d in docs}

    def configs(self) -> List[str]:
        """Configs of the map that hold at least one ROI (deleted or not)."""
        return sorted({c for c, _ in self.versions()})

    def history(self, config: str, roi_id: str) -> List[Tuple[int, Optional[Roi]]]:
        """Every version of one ROI, oldest first: (version, ROI or None when deleted)."""
        docs = self.store.find(self.database, self.collection,
                               {"map_name": self.map_name, "config": config, "id": roi_id},
                               sort=[("_meta.version", 1)])
        return [(int(d["_meta"].get("version", 0)),
                 None if _deleted(d) else roi_from_document(d)) for d in docs]

    def query(self, request: RoiQuery) -> Dict[str, Any]:
        """Answer a SOMAQueryROIs request.

        Returns:
            ``{"configs": [...], "ids": [...], "rois": [document, ...], "queryjson": str}``
            (documents are SOMAROIObject dicts with ``_meta``; none for query_type 1).

        Raises:
            RoiError: an unknown query_type.
            StoreUnavailable: the database is down.
        """
        if request.query_type == 1:
            latest = self._latest_docs()
            live = [d for d in latest if not _deleted(d)]
            return {"configs": sorted({d["config"] for d in live}),
                    "ids": sorted({d["id"] for d in live}, key=id_order), "rois": [],
                    "queryjson": json.dumps({"map_name": self.map_name})}
        if request.query_type != 0:
            raise RoiError("ROI query: query_type must be 0 (query) or 1 (ids and configs), "
                           "got %d" % request.query_type)
        flt = request.filter(self.map_name)
        if request.returnmostrecent and not request.timed:
            # ids and configs are the group keys: filtering after grouping is the same
            docs = [d for d in self._latest_docs() if request.selects(d) and not _deleted(d)]
        elif request.returnmostrecent:
            docs = [d for d in self.store.latest(self.database, self.collection,
                                                 ["config", "id"], "_meta.version", filter=flt)
                    if not _deleted(d)]
        else:
            docs = [d for d in self.store.find(self.database, self.collection, flt,
                                               sort=[("config", 1), ("id", 1),
                                                     ("_meta.version", 1)])
                    if not _deleted(d)]
        docs.sort(key=lambda d: (d["config"], id_order(d["id"]), d["_meta"].get("version", 0)))
        return {"configs": sorted({d["config"] for d in docs}),
                "ids": sorted({d["id"] for d in docs}, key=id_order), "rois": docs,
                "queryjson": json.dumps(flt, sort_keys=True)}

    # -- writes ---------------------------------------------------------------------------------

    def save(self, roi: Roi) -> int:
        """Store a new version of ``roi`` (validated first); return its version number.

        Raises:
            RoiError: the ROI is invalid or belongs to another map.
        """
        self._check_map(roi)
        validate_roi(roi)
        return self._insert(roi, deleted=False)

    def delete(self, config: str, roi_id: str) -> int:
        """Mark an ROI deleted (a new version; its history stays). Returns the version.

        Raises:
            RoiError: no such ROI.
        """
        live = {(r.config, r.id): r for r in self.current(config)}
        if (config, roi_id) not in live:
            raise RoiError("ROI %s config %s of map %s: cannot delete, no such ROI"
                           % (json.dumps(roi_id), json.dumps(config), json.dumps(self.map_name)))
        return self._insert(live[(config, roi_id)], deleted=True)

    def seed(self, rois: Sequence[Roi]) -> bool:
        """Store ``rois`` when the store has nothing for their map and config (not even
        deleted ROIs: after the first start the store is the truth).

        Returns:
            True when they were stored.

        Raises:
            RoiError: the ROIs are invalid, empty or span several configs or another map.
        """
        rois = list(rois)
        if not rois:
            raise RoiError("ROI seed for map %s: no ROIs" % json.dumps(self.map_name))
        validate_rois(rois)
        configs = {r.config for r in rois}
        if len(configs) != 1:
            raise RoiError("ROI seed: one config at a time, got %s" % ", ".join(sorted(configs)))
        for roi in rois:
            self._check_map(roi)
        if self.versions(configs.pop()):
            return False
        for roi in rois:
            self._insert(roi, deleted=False)
        return True

    def replace(self, rois: Sequence[Roi], config: str) -> Tuple[int, int]:
        """Make ``rois`` the current ROIs of ``config``: a new version of each ROI that
        changed (or is new), a deletion of each current ROI not in ``rois``.

        Returns:
            (versions written, ROIs deleted).
        """
        rois = list(rois)
        validate_rois(rois)
        for roi in rois:
            self._check_map(roi)
            if roi.config != config:
                raise RoiError("ROI %s: config %s, expected %s"
                               % (json.dumps(roi.id), json.dumps(roi.config),
                                  json.dumps(config)))
        current = {r.id: r for r in self.current(config)}
        written = deleted = 0
        for roi in rois:
            old = current.pop(roi.id, None)
            if old is None or old.type != roi.type or _vertices(old) != _vertices(roi):
                self._insert(roi, deleted=False)
                written += 1
        for roi in current.values():
            self._insert(roi, deleted=True)
            deleted += 1
        return written, deleted

    # -- helpers --------------------------------------------------------------------------------

    def _check_map(self, roi: Roi) -> None:
        if roi.map_name != self.map_name:
            raise RoiError("ROI %s: map %s, but this store holds map %s"
                           % (json.dumps(roi.id), json.dumps(roi.map_name),
                              json.dumps(self.map_name)))

    def _note_version(self, doc: Dict[str, Any]) -> None:
        key = (doc["config"], doc["id"])
        version = int(doc.get("_meta", {}).get("version", 0))
        if version > self._versions.get(key, 0):
            self._versions[key] = version

    def _next_version(self, roi: Roi, now: float) -> int:
        # Milliseconds of the write time, or one more than the last version this process saw:
        # increasing without reading the database, so edits made while it is down (journalled)
        # still sort after the versions already stored.
        return max(self._versions.get((roi.config, roi.id), 0) + 1, int(now * 1000))

    def _insert(self, roi: Roi, deleted: bool) -> int:
        now = float(self._clock())
        version = self._next_version(roi, now)
        meta: Dict[str, Any] = {"map": roi.map_name, "version": version}
        if deleted:
            meta["deleted"] = True
        doc = message_document(roi_to_fields(roi, int(now)), STORED_TYPE, meta=meta,
                               inserted_by=self.inserted_by, now=now)
        doc["_id"] = self.store.insert(self.database, self.collection, doc)
        if self._cache is not None:
            self._cache[(roi.config, roi.id)] = doc
        self._versions[(roi.config, roi.id)] = version
        return version


def _deleted(doc: Dict[str, Any]) -> bool:
    return bool(doc.get("_meta", {}).get("deleted", False))


def _vertices(roi: Roi) -> List[Tuple[float, float]]:
    return [(float(x), float(y)) for x, y in roi.vertices]
