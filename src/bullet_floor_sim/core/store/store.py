"""The store front end: one interface over both backends, with the write journal.

Writes (insert, update, delete, create_index) never fail because the database is down: they
go to the journal (:mod:`.journal`), one warning is logged per outage, and the journal is
replayed in order on the next operation that reaches the database, and when a store is opened
(a restarted process replays what the previous one journalled). While a journal is pending,
new writes are appended behind it, so the database sees every write in call order.

Nothing is lost and nothing is duplicated: an insert gets its ``_id`` (a client-side ObjectId)
before the first attempt, and replaying an insert whose ``_id`` is already there (the first
attempt reached the server but its reply did not come back) is skipped. Updates are replayed
as given: ``$set``/``$unset``/replacements are idempotent; a ``$inc``/``$push`` whose reply
was lost to a dropped connection may be applied twice (a server-down outage never does that:
those writes were never sent).

Reads while the database is unreachable, or while journalled writes cannot be replayed, raise
:class:`StoreUnavailable` (one line, naming the URI): a read never returns a state that is
missing writes this store has accepted. After a failure the database is retried at most every
``retry_interval`` seconds; in between, writes go straight to the journal and reads fail fast,
so a ROS callback never waits the server-selection timeout twice in a row.
"""
from __future__ import annotations

import logging
import os
import threading
import time
from typing import Any, Callable, Dict, List, Optional, Sequence, Union

import bson

from .base import (Backend, DuplicateKeyError, SortSpec, StoreError, StoreUnavailable,
                   check_names, default_db_dir, default_journal_path, is_operator_update,
                   normalize_sort, redact_uri)
from .journal import Journal

__all__ = ["Store", "open_store"]

LOG = logging.getLogger("bullet_floor_sim.store")


class Store:
    """A document store (see module doc). Open one with :func:`open_store`.

    Attributes:
        uri: the database: a ``mongodb://`` URI or the embedded store's directory.
        kind: "mongodb" or "embedded".
        journal_path: where writes go while the database is unreachable.

    Thread-safe: every operation holds one lock.
    """

    def __init__(self, uri: str, backend: Backend, journal_path: str,
                 retry_interval: float = 5.0):
        self.uri = uri
        self.kind = backend.kind
        self.journal_path = journal_path
        self._backend = backend
        self._journal = Journal(journal_path)
        self._retry_interval = retry_interval
        self._lock = threading.RLock()
        self._down: Optional[str] = None  # why the database is unreachable, while it is
        self._next_try = 0.0
        self._closed = False
        with self._lock:
            self._replay(force=True)

    # -- state ----------------------------------------------------------------------------------

    @property
    def available(self) -> bool:
        """False after an operation found the database unreachable, until one reaches it."""
        return self._down is None

    @property
    def pending(self) -> int:
        """How many journalled writes wait for the database."""
        with self._lock:
            return self._journal.count() if self._journal.pending() else 0

    def replay(self) -> bool:
        """Try the database now (ignoring ``retry_interval``) and replay the journal.

        Returns:
            True when nothing is left in the journal.
        """
        with self._lock:
            self._check_open()
            return self._replay(force=True)

    def close(self) -> None:
        """Close the backend; journalled writes stay on disk for the next store."""
        with self._lock:
            if not self._closed:
                self._closed = True
                self._backend.close()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return "Store(%r, kind=%s)" % (redact_uri(self.uri), self.kind)

    # -- writes ---------------------------------------------------------------------------------

    def insert(self, db: str, collection: str, doc: Dict[str, Any]) -> Any:
        """Insert one document (the caller's dict is not modified).

        Returns:
            Its ``_id``: the document's own, or a new ObjectId (also when journalled).

        Raises:
            DuplicateKeyError: the ``_id`` is already in the collection.
            StoreError: bad names or a document BSON cannot hold.
        """
        check_names(db, collection)
        if not isinstance(doc, dict):
            raise StoreError("store: a document must be a dict, not %s" % type(doc).__name__)
        if "_id" not in doc:
            doc = dict([("_id", bson.ObjectId())] + list(doc.items()))
        self._write({"op": "insert", "db": db, "coll": collection, "doc": doc})
        return doc["_id"]

    def update(self, db: str, collection: str, filter: Dict[str, Any],
               update: Dict[str, Any], upsert: bool = False, multi: bool = False) -> Optional[int]:
        """Update the first matching document (all with ``multi``), as pymongo does.

        Args:
            update: ``{"$set": ...}``-style operators, or a replacement document.
            upsert: insert a document when nothing matches.

        Returns:
            Documents matched (or 1 when upserted); None when the write was journalled.
        """
        check_names(db, collection)
        _check_filter(filter)
        is_operator_update(update)
        return self._write({"op": "update", "db": db, "coll": collection, "filter": filter,
                            "update": update, "upsert": bool(upsert), "multi": bool(multi)})

    def delete(self, db: str, collection: str, filter: Dict[str, Any]) -> Optional[int]:
        """Delete every matching document.

        Returns:
            How many were deleted; None when the write was journalled.
        """
        check_names(db, collection)
        _check_filter(filter)
        return self._write({"op": "delete", "db": db, "coll": collection, "filter": filter})

    def create_index(self, db: str, collection: str, keys: SortSpec) -> None:
        """Create an index (if missing) on ``keys`` (a field, or [(field, 1 | -1), ...]).

        The embedded backend pre-selects with indexes on equality/range filters and answers
        :meth:`latest` from an index on (filter fields, group_by, order_by).
        """
        check_names(db, collection)
        spec = normalize_sort(keys)
        if not spec:
            raise StoreError("store: an index needs at least one key")
        self._write({"op": "index", "db": db, "coll": collection, "keys": spec})

    # -- reads ----------------------------------------------------------------------------------

    def find(self, db: str, collection: str, filter: Optional[Dict[str, Any]] = None,
             sort: SortSpec = None, limit: int = 0) -> List[Dict[str, Any]]:
        """Matching documents, as pymongo's ``find(filter, sort=sort, limit=limit)``.

        Raises:
            StoreUnavailable: the database is unreachable (or journalled writes cannot be
                replayed yet).
        """
        check_names(db, collection)
        filter = filter or {}
        _check_filter(filter)
        spec = normalize_sort(sort)
        if not isinstance(limit, int) or limit < 0:
            raise StoreError("store: bad limit %r (0 for no limit)" % (limit,))
        return self._read(lambda: self._backend.find(db, collection, filter, spec, limit))

    def find_one(self, db: str, collection: str, filter: Optional[Dict[str, Any]] = None,
                 sort: SortSpec = None) -> Optional[Dict[str, Any]]:
        """The first matching document, or None."""
        found = self.find(db, collection, filter, sort, limit=1)
        return found[0] if found else None

    def latest(self, db: str, collection: str, group_by: Union[str, Sequence[str]],
               order_by: str, filter: Optional[Dict[str, Any]] = None) -> List[Dict[str, Any]]:
        """For each distinct value of ``group_by`` among the matching documents, the one with
        the largest ``order_by`` (e.g. the newest version of each ROI of a map), sorted by
        ``group_by``. MongoDB: ``$sort`` + ``$group``/``$first``; embedded: one SQL ``GROUP BY``
        when the fields are indexed, else find + dedupe in Python.
        """
        check_names(db, collection)
        filter = filter or {}
        _check_filter(filter)
        groups = [group_by] if isinstance(group_by, str) else list(group_by)
        if not groups or not all(isinstance(g, str) and g for g in groups + [order_by]):
            raise StoreError("store: latest() needs field names for group_by and order_by")
        return self._read(lambda: self._backend.latest(db, collection, filter, groups,
                                                       order_by))

    # -- journal and outages --------------------------------------------------------------------

    def _check_open(self) -> None:
        if self._closed:
            raise StoreError("store %s: closed" % redact_uri(self.uri))

    def _waiting(self) -> bool:
        return self._down is not None and time.monotonic() < self._next_try

    def _write(self, entry: Dict[str, Any]) -> Any:
        _check_bson(entry)
        with self._lock:
            self._check_open()
            if self._waiting() or (self._journal.pending() and not self._replay()):
                return self._journalled(entry)
            try:
                result = self._apply(entry, replay=False)
            except StoreUnavailable as e:
                self._went_down(e)
                return self._journalled(entry)
            self._came_up(0)
            return result

    def _journalled(self, entry: Dict[str, Any]) -> None:
        with self._journal.locked():
            self._journal.append(entry)
        LOG.debug("store %s: journalled %s on %s.%s", redact_uri(self.uri), entry["op"],
                  entry["db"], entry["coll"])
        return None

    def _read(self, fn: Callable[[], Any]) -> Any:
        with self._lock:
            self._check_open()
            if self._waiting() or (self._journal.pending() and not self._replay()):
                raise StoreUnavailable(self._unreachable())
            try:
                result = fn()
            except StoreUnavailable as e:
                self._went_down(e)
                raise StoreUnavailable(self._unreachable()) from None
            self._came_up(0)
            return result

    def _apply(self, entry: Dict[str, Any], replay: bool) -> Any:
        op, db, coll = entry["op"], entry["db"], entry["coll"]
        backend = self._backend
        if op == "insert":
            try:
                backend.insert(db, coll, entry["doc"])
            except DuplicateKeyError:
                if not replay:
                    raise
                # An earlier attempt got through before the connection dropped.
                LOG.info("store %s: journalled insert of %r was already applied",
                         redact_uri(self.uri), entry["doc"]["_id"])
            return entry["doc"]["_id"]
        if op == "update":
            return backend.update(db, coll, entry["filter"], entry["update"], entry["upsert"],
                                  entry["multi"])
        if op == "delete":
            return backend.delete(db, coll, entry["filter"])
        if op == "index":
            backend.create_index(db, coll, [(k, int(d)) for k, d in entry["keys"]])
            return None
        raise StoreError("store: unknown journal operation %r" % (op,))

    def _replay(self, force: bool = False) -> bool:
        """Apply journalled writes in order; True when the journal is empty afterwards."""
        if not self._journal.pending():
            return True
        if not force and self._waiting():
            return False
        applied = 0
        with self._journal.locked():
            lines, done = self._journal.read()
            for i in range(done, len(lines)):
                raw, entry = lines[i]
                try:
                    if entry is None or not {"op", "db", "coll"} <= set(entry):
                        raise StoreError("store: unreadable journal line")
                    self._apply(entry, replay=True)
                    applied += 1
                except StoreUnavailable as e:
                    self._went_down(e)
                    return False
                except StoreError as e:
                    LOG.error("store %s: the database refused a journalled write (%s); moved "
                              "it to %s", redact_uri(self.uri), e, self._journal.rejected_path)
                    self._journal.reject(raw, str(e))
                self._journal.mark_done(i + 1)
            self._journal.clear()
        self._came_up(applied)
        return True

    def _went_down(self, error: StoreUnavailable) -> None:
        self._next_try = time.monotonic() + self._retry_interval
        if self._down is None:
            self._down = _short(str(error))
            LOG.warning("%s; journalling writes to %s until it is back", self._down,
                        self.journal_path)

    def _came_up(self, replayed: int) -> None:
        if self._down is not None:
            LOG.warning("store %s: database reachable again; replayed %d journalled writes",
                        redact_uri(self.uri), replayed)
            self._down = None
        elif replayed:
            LOG.info("store %s: replayed %d writes journalled earlier (%s)",
                     redact_uri(self.uri), replayed, self.journal_path)

    def _unreachable(self) -> str:
        pending = self._journal.count() if self._journal.pending() else 0
        return "%s; %d writes journalled in %s" % (
            self._down or "store %s: database unreachable" % redact_uri(self.uri), pending,
            self.journal_path)


def open_store(uri: Optional[str] = None, journal_dir: Optional[str] = None,
               timeout: float = 1.5, retry_interval: float = 5.0,
               synchronous: str = "NORMAL") -> Store:
    """Open the store named by ``uri`` and replay what its journal holds.

    Args:
        uri: ``mongodb://host[:port]/`` (port 62345 when omitted, as mongodb_store), or a
            directory for the embedded store; None or "" for ``$ROS_HOME/bullet_floor_sim/db``.
        journal_dir: where the journal lives (default ``$ROS_HOME/bullet_floor_sim/journal``).
        timeout: seconds before an unreachable MongoDB (or a locked SQLite file) counts as down.
        retry_interval: seconds between attempts to reach a database found down.
        synchronous: the embedded backend's SQLite ``synchronous`` pragma.

    Returns:
        The store. A database that is down does not prevent opening: writes are journalled.

    Raises:
        StoreError: the URI is malformed, has an unsupported scheme, or the directory cannot
            be created.
    """
    if not uri:
        uri = default_db_dir()
    if not isinstance(uri, str):
        raise StoreError("store: the URI must be a string, not %s" % type(uri).__name__)
    if uri.startswith(("mongodb://", "mongodb+srv://")):
        from .mongo import MongoBackend

        backend: Backend = MongoBackend(uri, timeout=timeout)
        key = uri
    elif "://" in uri:
        raise StoreError("store %s: unsupported URI scheme %r (use mongodb://host[:port]/ or a "
                         "directory path)" % (redact_uri(uri), uri.split("://", 1)[0]))
    else:
        from .embedded import EmbeddedBackend

        key = os.path.abspath(os.path.expanduser(uri))
        if os.path.exists(key) and not os.path.isdir(key):
            raise StoreError("store %s: not a directory" % key)
        backend = EmbeddedBackend(key, timeout=timeout, synchronous=synchronous)
    try:
        return Store(key, backend, default_journal_path(key, journal_dir), retry_interval)
    except BaseException:
        backend.close()
        raise


def _check_filter(filter: Any) -> None:
    if not isinstance(filter, dict):
        raise StoreError("store: a filter must be a dict, not %s" % type(filter).__name__)


def _check_bson(entry: Dict[str, Any]) -> None:
    """Reject what BSON cannot hold before it reaches a backend or the journal."""
    try:
        bson.encode(entry)
    except (bson.errors.BSONError, TypeError, OverflowError) as e:
        raise StoreError("store: cannot store %s on %s.%s (%s)"
                         % (entry["op"], entry["db"], entry["coll"], e)) from None


def _short(message: str) -> str:
    """One line, without pymongo's topology description."""
    message = message.splitlines()[0] if message else message
    for tail in (", Timeout:", " (configured timeouts"):
        if tail in message:
            message = message.split(tail)[0] + ")"
    return message if len(message) <= 240 else message[:237] + "..."
