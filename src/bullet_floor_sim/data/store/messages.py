"""ROS messages as mongodb_store's MessageStoreProxy stores them, from plain dicts.

A stored message is its fields as a (nested) document plus ``_meta`` (mongodb_store
``message_store_node.py`` ``insert_ros_srv`` and ``util.py`` ``store_message``): the caller's
meta keys, then ``inserted_at`` and ``inserted_by``, ``published_at`` and ``timestamp`` (the
header stamp, or the insert time), then ``stored_class`` and ``stored_type``. SOMA object
types also get ``util.add_soma_fields``' extras (``loc``, ``timestamp``, ``geotype``/``geoloc``).
Datetimes are naive UTC at millisecond precision, as BSON stores them and as mongodb_store
writes them (``datetime.utcfromtimestamp``).

The ROS glue converts messages to dicts (mongodb_store's ``msg_to_document`` shape: one key per
slot, nested messages as dicts, times as ``{"secs", "nsecs"}``) and passes them here.
"""
from __future__ import annotations

import datetime
import time
from typing import Any, Dict, Optional

from .base import StoreError

__all__ = [
    "SOMA_TYPES",
    "stored_class_for",
    "ros_datetime",
    "message_document",
    "insert_message",
]

# The types mongodb_store's store_message() passes through add_soma_fields().
SOMA_TYPES = ("soma2_msgs/SOMA2Object", "soma_msgs/SOMAObject", "soma_msgs/SOMAROIObject")

_EPOCH = datetime.datetime(1970, 1, 1)


def stored_class_for(stored_type: str) -> str:
    """genpy's module path of a message class: "soma_msgs/SOMAROIObject" ->
    "soma_msgs.msg._SOMAROIObject.SOMAROIObject" (``msg.__module__ + "." + class name``).

    Raises:
        StoreError: not "package/Type".
    """
    parts = stored_type.split("/") if isinstance(stored_type, str) else []
    if len(parts) != 2 or not all(parts):
        raise StoreError("store: bad message type %r (use package/Type)" % (stored_type,))
    package, name = parts
    return "%s.msg._%s.%s" % (package, name, name)


def ros_datetime(seconds: Optional[float] = None, nanoseconds: Optional[int] = None
                 ) -> datetime.datetime:
    """A time as mongodb_store stores it: naive UTC ``datetime``, truncated to milliseconds.

    Args:
        seconds: seconds since the epoch (ROS time); now when both are None.
        nanoseconds: the same in integer nanoseconds (exact; wins over ``seconds``).
    """
    if nanoseconds is not None:
        ms = int(nanoseconds) // 1000000
    else:
        ms = int((time.time() if seconds is None else seconds) * 1000)
    return _EPOCH + datetime.timedelta(milliseconds=ms)


def message_document(fields: Dict[str, Any], stored_type: str,
                     stored_class: Optional[str] = None, meta: Optional[Dict[str, Any]] = None,
                     inserted_by: str = "", now: Optional[float] = None,
                     stamp_ns: Optional[int] = None) -> Dict[str, Any]:
    """The document mongodb_store would insert for a message with these fields.

    Args:
        fields: the message as a dict (not modified).
        stored_type: the ROS type, e.g. "soma_msgs/SOMAROIObject".
        stored_class: the Python class path; derived from ``stored_type`` when None.
        meta: the caller's meta (e.g. ``{"map": ..., "taken": ...}``); copied first.
        inserted_by: the inserting node's name (mongodb_store: the service caller id).
        now: insert time, seconds since the epoch (ROS time); wall clock when None.
        stamp_ns: the message's header stamp in nanoseconds (``published_at``/``timestamp``);
            the insert time when None.

    Returns:
        A new dict: the fields, the SOMA extras for SOMA types, and ``_meta``.
    """
    if not isinstance(fields, dict):
        raise StoreError("store: message fields must be a dict, not %s" % type(fields).__name__)
    if stamp_ns is None:
        stamp_ns = int(round((time.time() if now is None else now) * 1e9))
    doc = dict(fields)
    m = dict(meta or {})
    m["inserted_at"] = ros_datetime(seconds=now)
    m["inserted_by"] = inserted_by
    m["published_at"] = ros_datetime(nanoseconds=stamp_ns)
    m["timestamp"] = int(stamp_ns)
    m["stored_class"] = stored_class or stored_class_for(stored_type)
    m["stored_type"] = stored_type
    if stored_type in SOMA_TYPES:
        _add_soma_fields(doc, stored_type)
    doc["_meta"] = m
    return doc


def insert_message(store: Any, db: str, collection: str, fields: Dict[str, Any],
                   stored_type: str, stored_class: Optional[str] = None,
                   meta: Optional[Dict[str, Any]] = None, inserted_by: str = "",
                   now: Optional[float] = None, stamp_ns: Optional[int] = None) -> Any:
    """Insert :func:`message_document` (same arguments) into ``store``; return its ``_id``."""
    doc = message_document(fields, stored_type, stored_class, meta, inserted_by, now, stamp_ns)
    return store.insert(db, collection, doc)


def _add_soma_fields(doc: Dict[str, Any], stored_type: str) -> None:
    """mongodb_store util.add_soma_fields, on a dict."""
    try:
        if "pose" in doc:
            position = doc["pose"]["position"]
            doc["loc"] = [position["x"], position["y"]]
        if "logtimestamp" in doc:
            doc["timestamp"] = _EPOCH + datetime.timedelta(seconds=int(doc["logtimestamp"]))
        if "geotype" in doc:
            poses = (doc.get("geoposearray") or {}).get("poses") or []
            if doc["geotype"] == "Point":
                for p in poses:
                    doc["geoloc"] = {"type": doc["geotype"],
                                     "coordinates": [p["position"]["x"], p["position"]["y"]]}
            if stored_type == "soma_msgs/SOMAROIObject":
                doc["geotype"] = "Polygon"
                doc["geoloc"] = {"type": "Polygon", "coordinates": [
                    [[p["position"]["x"], p["position"]["y"]] for p in poses]]}
    except (KeyError, TypeError) as e:
        raise StoreError("store: %s fields lack what mongodb_store's SOMA indexing needs (%s)"
                         % (stored_type, e)) from None
