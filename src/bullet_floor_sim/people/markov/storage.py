"""The chain in the store (one document per region, as the seed stored it) and ROIs read from
SOMA's documents. See the package doc."""
from __future__ import annotations

import datetime
import uuid
from typing import Any, Iterable, List, Mapping, Optional, Set, Tuple

import numpy as np

from ...data.roi_store import roi_from_document
from ...data.rois import Roi, RoiError, validate_roi, validate_rois
from .chain import DATABASE, ChainError, MarkovChain, chain_collection


ROI_DATABASE = "somadata"  # where SOMA's soma_roi_manager (and data/roi_store) keeps ROIs
ROI_COLLECTION = "roi"


#: The collection of per-map markers naming each map's current chain build.
BUILDS_COLLECTION = "chain_builds"
#: Builds other than the current one are deleted once they are this old: two walkers that
#: rebuild one map's chain at once then never delete each other's fresh documents.
STALE_BUILD_S = 60.0


def store_chain(store: Any, chain: MarkovChain, map_name: Optional[str] = None,
                extra: Optional[Mapping[str, Any]] = None,
                now: Optional[datetime.datetime] = None) -> int:
    """Write the chain to a store, replacing the map's previous chain.

    The seed emptied the collection and then inserted one document per region. Here the new
    documents (all tagged with one fresh ``build_id`` and ``built_at``) go in first, then the
    map's marker in ``markov_chain_db.chain_builds`` (``_id`` the map) names this build, and
    builds other than this one older than :data:`STALE_BUILD_S` are deleted. A reader never
    finds the collection empty, and two writers rebuilding one map at once keep both builds
    for a while (the marker names the last) instead of deleting each other's.

    Args:
        store: a :class:`~bullet_floor_sim.data.store.Store` (or anything with its
            ``delete``/``insert``/``update``).
        chain: the chain.
        map_name: the map whose collection to use (default: ``chain.map_name``).
        extra: more fields for every document (e.g. ``{"built_by": "/markov_walker"}``);
            they never override the chain's own fields.
        now: the build time (default: now, UTC).

    Returns:
        The number of documents written (journalled while the database is down).

    Raises:
        ValueError: no usable map name.
        StoreError: the store refused the documents.
    """
    stored = chain.to_documents(map_name)
    db, coll = stored["database"], stored["collection"]
    build = uuid.uuid4().hex
    at = (now or datetime.datetime.utcnow()).replace(microsecond=0, tzinfo=None)
    for doc in stored["documents"]:
        doc["build_id"], doc["built_at"] = build, at
        if extra:
            doc = dict(doc, **{k: v for k, v in extra.items() if k not in doc})
        store.insert(db, coll, doc)
    name = stored["documents"][0]["map_name"] if stored["documents"] else coll
    store.update(db, BUILDS_COLLECTION, {"_id": name},
                 {"$set": {"build_id": build, "built_at": at, "collection": coll}},
                 upsert=True)
    stale = at - datetime.timedelta(seconds=STALE_BUILD_S)
    store.delete(db, coll, {"build_id": {"$ne": build},
                            "$or": [{"built_at": {"$lt": stale}},
                                    {"built_at": {"$exists": False}}]})
    return len(stored["documents"])


def load_chain(store: Any, map_name: str) -> MarkovChain:
    """Read back the chain :func:`store_chain` wrote for a map: the build its marker names
    (else, the newest build in the collection).

    Raises:
        ChainError: no chain is stored for the map, or its documents are malformed (the
            message names the collection and the region).
        StoreUnavailable: the database is unreachable.
    """
    coll = chain_collection(map_name)
    where = "%s.%s" % (DATABASE, coll)
    docs = store.find(DATABASE, coll, {}, sort=[("_id", 1)])
    if not docs:
        raise ChainError("%s: no chain stored for map %r" % (where, map_name))
    marker = store.find_one(DATABASE, BUILDS_COLLECTION, {"_id": map_name}) or {}
    builds = {d.get("build_id") for d in docs}
    current = marker.get("build_id")
    if current not in builds:
        current = docs[-1].get("build_id")  # no marker (an older writer): the newest build
    docs = [d for d in docs if d.get("build_id") == current]
    ids = []  # type: List[str]
    rows = []  # type: List[List[Tuple[str, float]]]
    for doc in docs:
        region = doc.get("ID_region")
        pairs = doc.get("proba_connexions")
        if not isinstance(region, str) or not isinstance(pairs, list):
            raise ChainError("%s: document %s lacks ID_region (string) or proba_connexions "
                             "(list)" % (where, doc.get("_id")))
        row = []
        for pair in pairs:
            if (not isinstance(pair, (list, tuple)) or len(pair) != 2
                    or not isinstance(pair[1], (int, float))):
                raise ChainError("%s: region %r: proba_connexions entries must be [id, "
                                 "probability], got %r" % (where, region, pair))
            row.append((str(pair[0]), float(pair[1])))
        ids.append(region)
        rows.append(row)
    index = {r: k for k, r in enumerate(ids)}
    matrix = np.zeros((len(ids), len(ids)))
    for k, row in enumerate(rows):
        for j, p in row:
            if j not in index:
                raise ChainError("%s: region %r leads to %r, which has no document"
                                 % (where, ids[k], j))
            matrix[k, index[j]] = p
    configs = sorted({str(d.get("config", "")) for d in docs})
    try:
        return MarkovChain(ids=ids, matrix=matrix, map_name=map_name,
                           config=configs[0] if len(configs) == 1 else "")
    except ValueError as e:
        raise ChainError("%s: %s" % (where, e)) from None


def rois_from_documents(docs: Iterable[Mapping[str, Any]], strict: bool = True) -> List[Roi]:
    """ROIs from stored SOMAROIObject documents (or dicts with the same fields).

    The vertices are ``posearray.poses[k].position.{x, y}``; a closing vertex equal to the
    first is dropped, as in rois.yaml.

    Args:
        docs: documents with ``id``, ``config``, ``type``, ``map_name`` and ``posearray``.
        strict: validate the result (polygons, duplicate ids) and raise on the first problem;
            with False, see :func:`usable_rois` to drop bad ROIs instead.

    Returns:
        The ROIs, in document order.

    Raises:
        RoiError: a document lacks a field or has a malformed one (named with the ROI id), or,
            with ``strict``, an ROI is invalid.
    """
    rois = [roi_from_document(doc, "ROI") for doc in docs]
    if strict:
        validate_rois(rois)
    return rois


def usable_rois(rois: Iterable[Roi]) -> Tuple[List[Roi], List[str]]:
    """The valid ROIs, and one warning per ROI left out (invalid polygon, repeated id).

    For a live system: one ROI broken by an edit must not stop the chain of the others.
    """
    good, warnings = [], []  # type: List[Roi], List[str]
    seen: Set[Tuple[str, str, str]] = set()
    for roi in rois:
        try:
            validate_roi(roi)
        except RoiError as e:
            warnings.append("%s: left out of the chain" % e)
            continue
        key = (roi.map_name, roi.config, roi.id)
        if key in seen:
            warnings.append('ROI "%s": repeated id in map %s config %s: the later one is left '
                            "out of the chain" % (roi.id, roi.map_name, roi.config))
            continue
        seen.add(key)
        good.append(roi)
    return good, warnings


def read_rois(store: Any, map_name: str, config: str = "1") -> List[Roi]:
    """The current ROIs of a map and config in the ROI store: the newest version of each ROI
    (by ``_meta.version``), deleted ROIs left out, as the ROI manager answers
    ``/soma/query_rois`` (:class:`~bullet_floor_sim.data.roi_store.RoiStore`).

    Args:
        store: a :class:`~bullet_floor_sim.data.store.Store`.
        map_name: the map.
        config: the ROI config (SOMA's ``config``).

    Returns:
        The ROIs, numeric ids in numeric order (not validated: see :func:`usable_rois`).

    Raises:
        RoiError: a stored document is malformed.
        StoreUnavailable: the database is unreachable.
    """
    from ...data.roi_store import RoiStore

    return RoiStore(store, map_name).current(config)
