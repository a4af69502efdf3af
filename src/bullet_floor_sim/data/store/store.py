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

Errors are sorted by kind. Database-wide (:class:`StoreUnavailable`: unreachable, refused
credentials, a damaged or locked file, a full disk on the server) keeps every write journalled
and retries. A refusal of one write (a plain :class:`StoreError`) sets aside that write only,
and anything else one journalled write provokes (a bad regex, a bad value) sets it aside too:
the replay moves on. Set-aside writes go to the rejected file with their reason;
:meth:`Store.replay_rejected` (``rosrun bullet_floor_sim store replay-rejected``) puts them
back after a fix.

When the journal itself cannot take a write (disk full, its cap reached) the write waits in
memory (``DEFAULT_MAX_HELD_BYTES``), in order behind the journal, with one error line; past
that it is lost, and counted (:attr:`Store.lost`).
"""
from __future__ import annotations

import collections
import logging
import os
import threading
import time
from typing import Any, Callable, Deque, Dict, List, Optional, Sequence, Tuple, Union

import bson

from .base import (Backend, DuplicateKeyError, SortSpec, StoreError, StoreUnavailable,
                   check_bson, check_filter, check_names, short_error, is_operator_update,
                   normalize_sort, redact_uri)
from .journal import DEFAULT_MAX_BYTES, Journal, JournalFull, rejected_entries

__all__ = ["Store", "DEFAULT_MAX_HELD_BYTES"]

LOG = logging.getLogger("bullet_floor_sim.store")
#: Writes the journal cannot take (disk full, over its cap) wait in memory up to this many
#: bytes of journal lines; beyond it they are lost, each loss counted in an error line.
DEFAULT_MAX_HELD_BYTES = 64 * 1024 ** 2
#: Shares of the journal's cap at which a warning says how full it is.
_FULL_WARNINGS = (0.5, 0.75, 0.9)


class Store:
    """A document store (see module doc). Open one with :func:`open_store`.

    Attributes:
        uri: the database: a ``mongodb://`` URI or the embedded store's directory.
        kind: "mongodb" or "embedded".
        journal_path: where writes go while the database is unreachable.

    Thread-safe: every operation holds one lock.
    """

    def __init__(self, uri: str, backend: Backend, journal_path: str,
                 retry_interval: float = 5.0, max_journal_bytes: int = DEFAULT_MAX_BYTES,
                 max_held_bytes: int = DEFAULT_MAX_HELD_BYTES):
        self.uri = uri
        self.kind = backend.kind
        self.journal_path = journal_path
        self._backend = backend
        self._journal = Journal(journal_path, max_journal_bytes)
        self._retry_interval = retry_interval
        self._lock = threading.RLock()
        self._down: Optional[str] = None  # why the database is unreachable, while it is
        self._next_try = 0.0
        self._closed = False
        # writes the journal could not take, in order behind it: (line, entry)
        self._held: Deque[Tuple[bytes, Dict[str, Any]]] = collections.deque()
        self._held_bytes = 0
        self._max_held_bytes = int(max_held_bytes)
        self._lost = 0
        self._journal_trouble: Optional[str] = None  # why the journal takes no writes
        self._full_warned = 0.0
        with self._lock:
            self._replay(force=True)

    # -- state ----------------------------------------------------------------------------------

    @property
    def shown_uri(self) -> str:
        """The URI as logs and messages show it: any password replaced by ``***``."""
        return redact_uri(self.uri)

    @property
    def available(self) -> bool:
        """False after an operation found the database unreachable, until one reaches it."""
        return self._down is None

    @property
    def pending(self) -> int:
        """How many writes wait for the database (journalled, or held in memory)."""
        with self._lock:
            return self._journal.count() + len(self._held)

    @property
    def held(self) -> int:
        """Writes accepted but only in memory (the journal could not take them): not durable
        until the journal or the database has them."""
        return len(self._held)

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def lost(self) -> int:
        """Writes lost because neither the journal nor the memory queue could take them."""
        return self._lost

    def replay(self) -> bool:
        """Try the database now (ignoring ``retry_interval``) and replay the journal.

        Returns:
            True when nothing is left in the journal.
        """
        with self._lock:
            self._check_open()
            return self._replay(force=True)

    def close(self) -> None:
        """Close the backend; journalled writes stay on disk for the next store. Writes held
        in memory get one more try at the journal; those it still refuses are lost, and
        counted in an error line."""
        with self._lock:
            if not self._closed:
                self._closed = True
                if self._held:
                    try:
                        with self._journal.locked():
                            while self._held:
                                self._journal.append(self._held[0][0])
                                self._held_bytes -= len(self._held.popleft()[0])
                    except (OSError, JournalFull) as e:
                        LOG.error("store %s: closing with %d writes the journal %s cannot "
                                  "take (%s): LOST", self.shown_uri, len(self._held),
                                  self.journal_path, e)
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
        check_filter(filter)
        is_operator_update(update)
        return self._write({"op": "update", "db": db, "coll": collection, "filter": filter,
                            "update": update, "upsert": bool(upsert), "multi": bool(multi)})

    def delete(self, db: str, collection: str, filter: Dict[str, Any]) -> Optional[int]:
        """Delete every matching document.

        Returns:
            How many were deleted; None when the write was journalled.
        """
        check_names(db, collection)
        check_filter(filter)
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
        check_filter(filter)
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
        check_filter(filter)
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

    def _backlog(self) -> bool:
        return bool(self._held) or self._journal.pending()

    def _write(self, entry: Dict[str, Any]) -> Any:
        check_bson(entry)
        with self._lock:
            self._check_open()
            if self._waiting() or (self._backlog() and not self._replay()):
                return self._journalled(entry)
            try:
                result = _guarded(entry, lambda: self._apply(entry, replay=False))
            except StoreUnavailable as e:
                self._went_down(e)
                return self._journalled(entry)
            self._came_up(0)
            return result

    def _journalled(self, entry: Dict[str, Any]) -> None:
        """Append to the journal, behind whatever waits in memory; hold in memory when the
        journal cannot take it."""
        line = self._journal.encode(entry)
        try:
            with self._journal.locked():
                while self._held:
                    self._journal.append(self._held[0][0])
                    self._held_bytes -= len(self._held.popleft()[0])
                size = self._journal.append(line)
        except (OSError, JournalFull) as e:
            self._hold(line, entry, e)
            return None
        if self._journal_trouble is not None:
            LOG.warning("store %s: the journal %s takes writes again%s", redact_uri(self.uri),
                        self.journal_path, "; %d writes were lost" % self._lost
                        if self._lost else "")
            self._journal_trouble = None
        self._warn_if_filling(size)
        LOG.debug("store %s: journalled %s on %s.%s", redact_uri(self.uri), entry["op"],
                  entry["db"], entry["coll"])
        return None

    def _hold(self, line: bytes, entry: Dict[str, Any], error: Exception) -> None:
        why = str(error) if isinstance(error, JournalFull) else "cannot write the journal %s (%s)" \
            % (self.journal_path, getattr(error, "strerror", None) or error)
        if self._held_bytes + len(line) > self._max_held_bytes:
            self._lost += 1
            if self._lost == 1 or self._lost % 1000 == 0:
                LOG.error("store %s: %s and %s of writes already wait in memory: write LOST "
                          "(%d so far)", redact_uri(self.uri), why, _mb(self._held_bytes),
                          self._lost)
            return
        if self._journal_trouble is None:
            LOG.error("store %s: %s; holding writes in memory (at most %s) until it can",
                      redact_uri(self.uri), why, _mb(self._max_held_bytes))
            self._journal_trouble = why
        self._held.append((line, entry))
        self._held_bytes += len(line)

    def _warn_if_filling(self, size: int) -> None:
        share = size / float(self._journal.max_bytes)
        passed = [f for f in _FULL_WARNINGS if share >= f > self._full_warned]
        if passed:
            self._full_warned = passed[-1]
            LOG.warning("store %s: the journal %s holds %s, %d %% of its cap of %s; writes "
                        "beyond the cap wait in memory (%s), then are lost",
                        redact_uri(self.uri), self.journal_path, _mb(size), 100 * share,
                        _mb(self._journal.max_bytes), _mb(self._max_held_bytes))

    def _read(self, fn: Callable[[], Any]) -> Any:
        with self._lock:
            self._check_open()
            if self._waiting() or (self._backlog() and not self._replay()):
                raise StoreUnavailable(self._unreachable())
            try:
                result = _guarded(None, fn)
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
        """Apply journalled, then held, writes in order; True when none is left."""
        if not self._backlog():
            return True
        if not force and self._waiting():
            return False
        applied = 0
        if self._journal.pending():
            try:
                with self._journal.locked(), self._journal.progress() as mark:
                    for raw, entry, end in self._journal.entries():
                        ok = self._replay_one(raw, entry, journal_locked=True)
                        if ok is None:
                            return False
                        applied += ok
                        mark(end)
                    self._journal.clear()
                    self._full_warned = 0.0
            except OSError as e:
                self._went_down(StoreUnavailable("store %s: cannot read the journal %s (%s)" % (
                    redact_uri(self.uri), self.journal_path, e.strerror or e)))
                return False
        while self._held:
            line, entry = self._held[0]
            ok = self._replay_one(line[:-1], entry, journal_locked=False)
            if ok is None:
                return False
            applied += ok
            self._held_bytes -= len(self._held.popleft()[0])
        self._came_up(applied)
        return True

    def _replay_one(self, raw: bytes, entry: Optional[Dict[str, Any]],
                    journal_locked: bool) -> Optional[int]:
        """Apply one journalled write: 1 when applied, 0 when set aside (refused by the
        database, unreadable, or failing in any other way of its own), None when the database
        is unavailable (nothing is set aside then)."""
        try:
            if entry is None or not {"op", "db", "coll"} <= set(entry):
                raise StoreError("store: unreadable journal line")
            _guarded(entry, lambda: self._apply(entry, replay=True))
            return 1
        except StoreUnavailable as e:
            self._went_down(e)
            return None
        except StoreError as e:
            why = str(e)
        try:
            if journal_locked:
                self._journal.reject(raw, why)
            else:   # a held write: the rejected file is shared with other processes
                with self._journal.locked():
                    self._journal.reject(raw, why)
        except OSError as e:
            self._went_down(StoreUnavailable("store %s: cannot set a write aside in %s (%s)" % (
                redact_uri(self.uri), self._journal.rejected_path, e.strerror or e)))
            return None
        LOG.error("store %s: set a journalled write aside in %s: %s", redact_uri(self.uri),
                  self._journal.rejected_path, why)
        return 0

    def replay_rejected(self) -> Tuple[int, int]:
        """Put the writes set aside back behind the journal (after a fix: a restored database,
        a corrected permission) and replay.

        Returns:
            (writes put back, writes set aside again).

        Raises:
            StoreError: the rejected file cannot be read or the journal cannot take them.
        """
        with self._lock:
            self._check_open()
            path = self._journal.rejected_path
            try:
                with self._journal.locked():
                    lines = rejected_entries(path)
                    if lines:   # one append: all of them go back, or none
                        self._journal.append(b"".join(lines))
                        os.unlink(path)
                    back = len(lines)
            except (OSError, JournalFull) as e:
                raise StoreError("store %s: cannot put the writes set aside in %s back (%s)"
                                 % (redact_uri(self.uri), path, e)) from None
            self._replay(force=True)
            return back, len(rejected_entries(path))

    def _went_down(self, error: StoreUnavailable) -> None:
        self._next_try = time.monotonic() + self._retry_interval
        if self._down is None:
            self._down = short_error(str(error))
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
        return "%s; %d writes journalled in %s" % (
            self._down or "store %s: database unreachable" % redact_uri(self.uri),
            self._journal.count() + len(self._held), self.journal_path)


def _guarded(entry: Optional[Dict[str, Any]], fn: Callable[[], Any]) -> Any:
    """Run one backend call; an exception that is not the store's own (a bad regex, a bad
    value deep in a document) becomes a StoreError naming the operation."""
    try:
        return fn()
    except StoreError:
        raise
    except Exception as e:  # noqa: BLE001 - whatever one entry provokes stays with that entry
        what = "%s on %s.%s" % (entry["op"], entry["db"], entry["coll"]) if entry else "read"
        raise StoreError("store: %s failed (%s: %s)" % (what, type(e).__name__, e)) from None


def _mb(n: int) -> str:
    return "%.1f MB" % (n / 1048576.0)
