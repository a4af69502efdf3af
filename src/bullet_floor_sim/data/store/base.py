"""What every store backend shares: the errors, the backend contract, default paths, names.

A backend (:mod:`.mongo`, :mod:`.embedded`) does the database work and nothing else: it
raises :class:`StoreUnavailable` when the database cannot be reached (the front end,
:class:`~.store.Store`, then journals writes), :class:`DuplicateKeyError` for an ``_id`` that
is already there, and :class:`StoreError` for everything else that is the caller's fault.
"""
from __future__ import annotations

import hashlib
import os
import re
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import bson

from ...errors import BulletFloorSimError

__all__ = [
    "StoreError",
    "StoreUnavailable",
    "DuplicateKeyError",
    "Backend",
    "SortSpec",
    "MONGODB_DEFAULT_PORT",
    "ros_home",
    "default_db_dir",
    "default_journal_path",
    "check_names",
    "normalize_sort",
    "is_operator_update",
    "redact_uri",
    "check_bson",
    "check_filter",
    "short_error",
]

# mongodb_store's mongodb_server.py and message_store_node.py default to this port.
MONGODB_DEFAULT_PORT = 62345

SortSpec = Union[None, str, Sequence[Tuple[str, int]]]

_DB_NAME = re.compile(r"^[A-Za-z0-9_-]{1,63}$")
_COLLECTION_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,119}$")


class StoreError(BulletFloorSimError):
    """A store cannot be opened, or an operation on it is invalid or failed."""


class StoreUnavailable(StoreError):
    """The database cannot be reached (server down, file locked, disk error).

    Writes never raise it (they are journalled); reads do.
    """


class DuplicateKeyError(StoreError):
    """A document with this ``_id`` is already in the collection."""


class Backend:
    """The contract of a backend; every method may raise the three errors above.

    ``filter``, ``update`` and ``sort`` are pymongo's: ``{"a.b": {"$gt": 1}}``,
    ``{"$set": {...}}`` or a replacement document, ``[("field", 1 | -1), ...]``.
    """

    kind = "?"

    def insert(self, db: str, collection: str, doc: Dict[str, Any]) -> None:
        """Insert one document that already has its ``_id``."""
        raise NotImplementedError

    def update(self, db: str, collection: str, filter: Dict[str, Any], update: Dict[str, Any],
               upsert: bool, multi: bool) -> int:
        """Apply an operator update or a replacement; return matched (or upserted) count."""
        raise NotImplementedError

    def delete(self, db: str, collection: str, filter: Dict[str, Any]) -> int:
        """Delete every matching document; return how many."""
        raise NotImplementedError

    def find(self, db: str, collection: str, filter: Dict[str, Any],
             sort: List[Tuple[str, int]], limit: int) -> List[Dict[str, Any]]:
        """Matching documents, sorted, at most ``limit`` of them (0: all)."""
        raise NotImplementedError

    def latest(self, db: str, collection: str, filter: Dict[str, Any], group_by: List[str],
               order_by: str) -> List[Dict[str, Any]]:
        """Per distinct ``group_by`` values, the matching document with the largest ``order_by``."""
        raise NotImplementedError

    def create_index(self, db: str, collection: str, keys: List[Tuple[str, int]]) -> None:
        """Create (if missing) an index on ``keys``."""
        raise NotImplementedError

    def close(self) -> None:
        """Release connections; the backend is unusable afterwards."""
        raise NotImplementedError


def ros_home() -> str:
    """``$ROS_HOME``, or ``~/.ros`` as roslib defines it."""
    home = os.environ.get("ROS_HOME")
    if home:
        return home
    return os.path.join(os.path.expanduser("~"), ".ros")


def default_db_dir() -> str:
    """The embedded database used when no URI is given: ``$ROS_HOME/bullet_floor_sim/db``."""
    return os.path.join(ros_home(), "bullet_floor_sim", "db")


def default_journal_path(uri: str, journal_dir: Optional[str] = None) -> str:
    """``<journal_dir>/<sha1 of uri, 16 hex>.jsonl``; journal_dir defaults to
    ``$ROS_HOME/bullet_floor_sim/journal``. One journal per database, shared by every process
    that writes to it (appends and replays take a file lock)."""
    directory = journal_dir or os.path.join(ros_home(), "bullet_floor_sim", "journal")
    digest = hashlib.sha1(uri.encode("utf-8")).hexdigest()[:16]
    return os.path.join(directory, digest + ".jsonl")


def check_names(db: str, collection: str) -> None:
    """Reject database and collection names that are not portable to both backends.

    Raises:
        StoreError: a name is empty, too long or has characters outside ``[A-Za-z0-9_-]``
            (``.`` also allowed in collection names, except ``system.``).
    """
    if not isinstance(db, str) or not _DB_NAME.match(db):
        raise StoreError("store: bad database name %r (use 1-63 characters of A-Z a-z 0-9 _ -)"
                         % (db,))
    if (not isinstance(collection, str) or not _COLLECTION_NAME.match(collection)
            or collection.startswith("system.")):
        raise StoreError("store: bad collection name %r (use 1-120 characters of A-Z a-z 0-9 _ "
                         "- ., not starting with '.' or 'system.')" % (collection,))


def normalize_sort(sort: SortSpec) -> List[Tuple[str, int]]:
    """pymongo's sort argument as a list of (path, 1 | -1).

    Raises:
        StoreError: not a field name or a list of (field, 1 | -1) pairs.
    """
    if sort is None:
        return []
    if isinstance(sort, str):
        return [(sort, 1)]
    out = []
    try:
        for key, direction in sort:
            if not isinstance(key, str) or direction not in (1, -1) or isinstance(direction, bool):
                raise ValueError
            out.append((key, int(direction)))
    except (TypeError, ValueError):
        raise StoreError("store: bad sort %r (use a field name or [(field, 1 | -1), ...])"
                         % (sort,)) from None
    return out


def redact_uri(uri: str) -> str:
    """The URI with any password replaced by ``***``, for logs and messages."""
    return re.sub(r"^(mongodb(?:\+srv)?://[^:/@]*):[^@/]*@", r"\1:***@", uri)


def is_operator_update(update: Dict[str, Any]) -> bool:
    """True for ``{"$set": ...}``-style updates, False for replacement documents.

    Raises:
        StoreError: not a dict, or $-operators mixed with plain fields.
    """
    if not isinstance(update, dict):
        raise StoreError("store: an update must be a dict, not %s" % type(update).__name__)
    dollar = [k.startswith("$") for k in update]
    if dollar and all(dollar):
        return True
    if not any(dollar):
        return False
    raise StoreError("store: update mixes $-operators and plain fields: %s" % ", ".join(update))


def check_filter(filter: Any) -> None:
    if not isinstance(filter, dict):
        raise StoreError("store: a filter must be a dict, not %s" % type(filter).__name__)


def check_bson(entry: Dict[str, Any]) -> None:
    """Reject what BSON cannot hold before it reaches a backend or the journal."""
    try:
        bson.encode(entry)
    except (bson.errors.BSONError, TypeError, OverflowError) as e:
        raise StoreError("store: cannot store %s on %s.%s (%s)"
                         % (entry["op"], entry["db"], entry["coll"], e)) from None


def short_error(message: str) -> str:
    """One line, without pymongo's topology description."""
    message = message.splitlines()[0] if message else message
    for tail in (", Timeout:", " (configured timeouts"):
        if tail in message:
            message = message.split(tail)[0] + ")"
    return message if len(message) <= 240 else message[:237] + "..."
