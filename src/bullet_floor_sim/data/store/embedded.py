"""The embedded backend: documents in SQLite files, MongoDB semantics from montydb's engine.

Layout: ``<directory>/<db>.sqlite3``, one table ``"docs:<collection>"`` per collection with
``seq`` (insertion order), ``id`` (the BSON-encoded ``_id``, unique) and ``doc`` (the BSON
document). WAL journal, ``synchronous=NORMAL`` by default (durable across process crashes; a
power cut may lose the last commits, as MongoDB's default write concern may).

Queries, updates and sorts follow MongoDB exactly as montydb implements them (its
``QueryFilter``, ``Updator`` and ``ordering``, pinned montydb 2.5.6); SQLite only pre-selects
rows through indexes (:mod:`.pushdown`) and answers :meth:`latest` with one ``GROUP BY``.
Why not montydb's own sqlite storage: it has no indexes and no aggregation, reopens the file
on every operation and decodes every document of a collection on every find (about 30 ms per
1,000 documents; see bench/store_bench.py).
"""
from __future__ import annotations

import os
import re
import sqlite3
from typing import Any, Dict, List, Optional, Set, Tuple

import bson
from bson.codec_options import CodecOptions

from .base import Backend, DuplicateKeyError, StoreError, StoreUnavailable, is_operator_update
from .pushdown import (COMPLEX, MISSING, compile_filter, id_key, index_key, key_expr,
                       key_function, walk)

__all__ = ["EmbeddedBackend"]

_CODEC = CodecOptions(tz_aware=False)  # type: CodecOptions[Dict[str, Any]]
_TABLE_PREFIX = "docs:"
_KEY_IN_INDEX = re.compile(r"bfs_key\(doc, '((?:[^']|'')*)'\)")
# OperationalErrors that are mistakes in a statement, not an unavailable database.
_SQL_BUGS = ("syntax error", "no such column", "no such function", "unrecognized token")


def _montydb_engine():
    """montydb's query/update engine, set up to use pymongo's bson (once per process)."""
    from montydb.types import bson as monty_bson

    monty_bson.init(True)
    if not monty_bson.bson_used:
        raise StoreError("store: montydb was set up without BSON in this process; the embedded "
                         "store needs montydb's BSON mode")
    from montydb.engine import field_walker, queries, update

    return queries.QueryFilter, update.Updator, field_walker.FieldWalker, queries.ordering


def _table(collection: str) -> str:
    return '"%s%s"' % (_TABLE_PREFIX, collection)


class _Database:
    """One SQLite file (one MongoDB database) and what we know of its schema."""

    def __init__(self, path: str, timeout: float, synchronous: str):
        self.conn = sqlite3.connect(path, timeout=timeout, isolation_level=None,
                                    check_same_thread=False)
        try:
            self.conn.create_function("bfs_key", 2, key_function(), deterministic=True)
            self.conn.execute("PRAGMA journal_mode=WAL")
            self.conn.execute("PRAGMA synchronous=%s" % synchronous)
        except sqlite3.Error:
            self.conn.close()
            raise
        self._version: Optional[int] = None
        self.tables: Set[str] = set()
        self.indexed: Dict[str, Set[str]] = {}

    def refresh(self) -> None:
        """Re-read tables and indexed paths when the schema changed (also in another process)."""
        version = self.conn.execute("PRAGMA schema_version").fetchone()[0]
        if version == self._version:
            return
        tables: Set[str] = set()
        indexed: Dict[str, Set[str]] = {}
        for kind, name, table, sql in self.conn.execute(
                "SELECT type, name, tbl_name, sql FROM sqlite_master"):
            if not table.startswith(_TABLE_PREFIX):
                continue
            collection = table[len(_TABLE_PREFIX):]
            if kind == "table":
                tables.add(collection)
            elif kind == "index" and sql:
                paths = [p.replace("''", "'") for p in _KEY_IN_INDEX.findall(sql)]
                indexed.setdefault(collection, set()).update(paths)
        self.tables, self.indexed, self._version = tables, indexed, version


class EmbeddedBackend(Backend):
    """MongoDB-style collections in SQLite files under one directory.

    Args:
        directory: where the ``<db>.sqlite3`` files live (created if missing).
        timeout: seconds to wait for another process's lock before the database counts as
            unavailable.
        synchronous: SQLite's ``synchronous`` pragma (NORMAL or FULL).

    Raises:
        StoreError: the directory cannot be created or is not a directory.
    """

    kind = "embedded"

    def __init__(self, directory: str, timeout: float = 1.5, synchronous: str = "NORMAL"):
        if synchronous.upper() not in ("OFF", "NORMAL", "FULL", "EXTRA"):
            raise StoreError("store: bad synchronous mode %r (NORMAL or FULL)" % synchronous)
        try:
            os.makedirs(directory, exist_ok=True)
        except OSError as e:
            raise StoreError("store %s: cannot create the database directory (%s)"
                             % (directory, e.strerror or e)) from None
        self.directory = directory
        self._timeout = timeout
        self._synchronous = synchronous.upper()
        self._dbs: Dict[str, _Database] = {}
        self._QueryFilter, self._Updator, self._FieldWalker, self._ordering = _montydb_engine()

    # -- plumbing -----------------------------------------------------------------------------

    def _db(self, db: str) -> _Database:
        handle = self._dbs.get(db)
        if handle is None:
            handle = _Database(os.path.join(self.directory, db + ".sqlite3"), self._timeout,
                               self._synchronous)
            self._dbs[db] = handle
        handle.refresh()
        return handle

    def _run(self, db: str, write: bool, fn):
        """Run ``fn(handle)`` in one transaction; translate SQLite's errors."""
        try:
            handle = self._db(db)
            conn = handle.conn
            conn.execute("BEGIN IMMEDIATE" if write else "BEGIN")
            try:
                result = fn(handle)
                conn.execute("COMMIT")
            except BaseException:
                if conn.in_transaction:
                    conn.execute("ROLLBACK")
                raise
            return result
        except sqlite3.IntegrityError as e:
            if "UNIQUE" not in str(e):   # a constraint or trigger of the database refused it
                raise StoreError("store %s: database %s refused the write (%s)"
                                 % (self.directory, db, e)) from None
            raise DuplicateKeyError("store %s: duplicate _id in %s (%s)"
                                    % (self.directory, db, e)) from None
        except sqlite3.OperationalError as e:
            self._drop(db)
            if any(bug in str(e) for bug in _SQL_BUGS):
                raise StoreError("store %s: database %s: %s" % (self.directory, db, e)) from None
            # locked past the timeout, I/O error, cannot open, disk full, read-only
            raise StoreUnavailable("store %s: database %s unavailable (%s)"
                                   % (self.directory, db, e)) from None
        except OSError as e:
            self._drop(db)
            raise StoreUnavailable("store %s: database %s unavailable (%s)"
                                   % (self.directory, db, e)) from None
        except (sqlite3.ProgrammingError, sqlite3.DataError, sqlite3.InterfaceError) as e:
            raise StoreError("store %s: database %s: %s" % (self.directory, db, e)) from None
        except sqlite3.DatabaseError as e:  # not a database, malformed: database-wide
            self._drop(db)
            raise StoreUnavailable("store %s: database %s is damaged (%s); restore or move "
                                   "the file %s.sqlite3" % (self.directory, db, e, db)) from None
        except (bson.errors.InvalidDocument, bson.errors.InvalidBSON) as e:
            raise StoreError("store %s: cannot store the document (%s)"
                             % (self.directory, e)) from None
        except StoreError:
            raise
        except Exception as e:  # montydb's OperationFailure/WriteError: bad filter or update
            if type(e).__module__.startswith("montydb"):
                raise StoreError("store: %s" % e) from None
            raise

    def _drop(self, db: str) -> None:
        handle = self._dbs.pop(db, None)
        if handle is not None:
            try:
                handle.conn.close()
            except sqlite3.Error:
                pass

    def _ensure_table(self, handle: _Database, collection: str) -> None:
        if collection not in handle.tables:
            handle.conn.execute(
                "CREATE TABLE IF NOT EXISTS %s (seq INTEGER PRIMARY KEY, id BLOB NOT NULL UNIQUE, "
                "doc BLOB NOT NULL)" % _table(collection))
            handle.tables.add(collection)

    def _candidates(self, handle: _Database, collection: str, filter: Dict[str, Any],
                    order: str = "seq") -> List[Tuple[int, Dict[str, Any]]]:
        """(seq, doc) of every matching document, full MongoDB filter applied in Python."""
        if collection not in handle.tables:
            return []
        match = self._QueryFilter(filter)
        pushed = compile_filter(filter, handle.indexed.get(collection, set()))
        rows = handle.conn.execute("SELECT seq, doc FROM %s WHERE %s ORDER BY %s"
                                   % (_table(collection), pushed.sql, order), pushed.params)
        out = []
        for seq, blob in rows:
            doc = bson.decode(blob, _CODEC)
            if match(doc):
                out.append((seq, doc))
        return out

    # -- Backend ------------------------------------------------------------------------------

    def insert(self, db: str, collection: str, doc: Dict[str, Any]) -> None:
        blob = bson.encode(doc)

        def run(handle: _Database) -> None:
            self._ensure_table(handle, collection)
            handle.conn.execute("INSERT INTO %s (id, doc) VALUES (?, ?)" % _table(collection),
                                (id_key(doc["_id"]), blob))

        self._run(db, True, run)

    def update(self, db: str, collection: str, filter: Dict[str, Any], update: Dict[str, Any],
               upsert: bool, multi: bool) -> int:
        operators = is_operator_update(update)
        if not operators and multi:
            raise StoreError("store: a replacement document updates one document; "
                             "use $-operators with multi=True")
        updator = self._Updator(update) if operators else None

        def run(handle: _Database) -> int:
            found = self._candidates(handle, collection, filter)
            if not multi:
                found = found[:1]
            if not found:
                if upsert:
                    self._upsert(handle, collection, filter, update, updator)
                    return 1
                return 0
            for seq, doc in found:
                new = self._apply(doc, update, updator)
                if new is not None:
                    handle.conn.execute("UPDATE %s SET doc = ? WHERE seq = ?"
                                        % _table(collection), (bson.encode(new), seq))
            return len(found)

        return self._run(db, True, run)

    def _apply(self, doc: Dict[str, Any], update: Dict[str, Any],
               updator: Any) -> Optional[Dict[str, Any]]:
        """The updated document, or None when nothing changed."""
        if updator is None:
            if "_id" in update and update["_id"] != doc["_id"]:
                raise StoreError("store: a replacement may not change _id (%r -> %r)"
                                 % (doc["_id"], update["_id"]))
            new = {"_id": doc["_id"]}
            new.update((k, v) for k, v in update.items() if k != "_id")
            return new if new != doc else None
        walker = self._FieldWalker(doc)
        if not updator(walker):
            return None
        if walker.doc.get("_id") != doc["_id"]:
            raise StoreError("store: an update may not change _id")
        return walker.doc

    def _upsert(self, handle: _Database, collection: str, filter: Dict[str, Any],
                update: Dict[str, Any], updator: Any) -> None:
        # _id: the replacement's, else the filter's equality on _id, else a new ObjectId.
        fields = _equality_fields(filter)
        doc = {"_id": fields.pop("_id") if "_id" in fields else bson.ObjectId()}
        if updator is None:
            doc.update(update)
        else:
            doc.update(fields)
            walker = self._FieldWalker(doc)
            updator(walker, do_insert=True)
            doc = walker.doc
        self._ensure_table(handle, collection)
        handle.conn.execute("INSERT INTO %s (id, doc) VALUES (?, ?)" % _table(collection),
                            (id_key(doc["_id"]), bson.encode(doc)))

    def delete(self, db: str, collection: str, filter: Dict[str, Any]) -> int:
        def run(handle: _Database) -> int:
            if collection not in handle.tables:  # nothing written yet: nothing to delete
                return 0
            found = self._candidates(handle, collection, filter)
            handle.conn.executemany("DELETE FROM %s WHERE seq = ?" % _table(collection),
                                    [(seq,) for seq, _ in found])
            return len(found)

        return self._run(db, True, run)

    def find(self, db: str, collection: str, filter: Dict[str, Any],
             sort: List[Tuple[str, int]], limit: int) -> List[Dict[str, Any]]:
        def run(handle: _Database) -> List[Dict[str, Any]]:
            if collection not in handle.tables:
                return []
            if sort and limit and self._sql_can_sort(handle, collection, filter, sort):
                order = ", ".join("%s %s" % (key_expr(p), "ASC" if d == 1 else "DESC")
                                  for p, d in sort) + ", seq"
                return self._streamed(handle, collection, filter, order, limit)
            docs = [doc for _, doc in self._candidates(handle, collection, filter)]
            if sort:
                walkers = [self._FieldWalker(doc) for doc in docs]
                docs = [w.doc for w in self._ordering(walkers, dict(sort))]
            return docs[:limit] if limit else docs

        return self._run(db, False, run)

    def _sql_can_sort(self, handle: _Database, collection: str, filter: Dict[str, Any],
                      sort: List[Tuple[str, int]]) -> bool:
        """Every sort key indexed and no candidate row has an array/document under one."""
        indexed = handle.indexed.get(collection, set())
        if not all(p in indexed for p, _ in sort):
            return False
        return not self._any_complex(handle, collection, filter, [p for p, _ in sort])

    def _any_complex(self, handle: _Database, collection: str, filter: Dict[str, Any],
                     paths: List[str]) -> bool:
        pushed = compile_filter(filter, handle.indexed.get(collection, set()))
        marks = " OR ".join("%s = X'FF'" % key_expr(p) for p in paths)
        row = handle.conn.execute("SELECT 1 FROM %s WHERE %s AND (%s) LIMIT 1"
                                  % (_table(collection), pushed.sql, marks),
                                  pushed.params).fetchone()
        return row is not None

    def _streamed(self, handle: _Database, collection: str, filter: Dict[str, Any], order: str,
                  limit: int) -> List[Dict[str, Any]]:
        match = self._QueryFilter(filter)
        pushed = compile_filter(filter, handle.indexed.get(collection, set()))
        out = []
        for (blob,) in handle.conn.execute("SELECT doc FROM %s WHERE %s ORDER BY %s"
                                           % (_table(collection), pushed.sql, order),
                                           pushed.params):
            doc = bson.decode(blob, _CODEC)
            if match(doc):
                out.append(doc)
                if len(out) == limit:
                    break
        return out

    def latest(self, db: str, collection: str, filter: Dict[str, Any], group_by: List[str],
               order_by: str) -> List[Dict[str, Any]]:
        def run(handle: _Database) -> List[Dict[str, Any]]:
            if collection not in handle.tables:
                return []
            indexed = handle.indexed.get(collection, set())
            pushed = compile_filter(filter, indexed)
            paths = sorted(pushed.paths) + list(group_by) + [order_by]
            if (pushed.exact and all(p in indexed for p in group_by + [order_by])
                    and not self._any_complex(handle, collection, filter, paths)):
                # SQLite: with max(), the bare column comes from the row holding the maximum.
                # No marked rows among the candidates: the strict condition selects the same
                # rows and lets SQLite walk the index in group order.
                pushed = compile_filter(filter, indexed, strict=True)
                rows = handle.conn.execute(
                    "SELECT doc, max(%s) FROM %s WHERE %s GROUP BY %s" % (
                        key_expr(order_by), _table(collection), pushed.sql,
                        ", ".join(key_expr(g) for g in group_by)), pushed.params)
                docs = [bson.decode(blob, _CODEC) for blob, _ in rows]
            else:
                docs = self._latest_in_python(handle, collection, filter, group_by, order_by)
            return sorted(docs, key=lambda d: [_sort_token(walk(d, g)) for g in group_by])

        return self._run(db, False, run)

    def _latest_in_python(self, handle: _Database, collection: str, filter: Dict[str, Any],
                          group_by: List[str], order_by: str) -> List[Dict[str, Any]]:
        docs = [doc for _, doc in self._candidates(handle, collection, filter)]
        walkers = self._ordering([self._FieldWalker(d) for d in docs], {order_by: -1})
        seen: Set[bytes] = set()
        out = []
        for walker in walkers:
            group = bson.encode({"g": [_group_value(walker.doc, g) for g in group_by]})
            if group not in seen:
                seen.add(group)
                out.append(walker.doc)
        return out

    def create_index(self, db: str, collection: str, keys: List[Tuple[str, int]]) -> None:
        name = "%s%s.%s" % (_TABLE_PREFIX, collection,
                            "_".join("%s_%d" % (p, d) for p, d in keys))
        columns = ", ".join("%s %s" % (key_expr(p), "ASC" if d == 1 else "DESC")
                            for p, d in keys)

        def run(handle: _Database) -> None:
            self._ensure_table(handle, collection)
            handle.conn.execute('CREATE INDEX IF NOT EXISTS "%s" ON %s (%s)'
                                % (name.replace('"', '""'), _table(collection), columns))

        self._run(db, True, run)

    def close(self) -> None:
        for db in list(self._dbs):
            self._drop(db)


def _group_value(doc: Dict[str, Any], path: str) -> Any:
    value = walk(doc, path)
    return None if value is COMPLEX or value is MISSING else value


def _sort_token(value: Any) -> Tuple[int, Any]:
    """A Python sort key following the index key's order (NULL < numbers < text < blobs)."""
    key = index_key(value)
    if key is None:
        return (0, 0)
    if isinstance(key, (int, float)):
        return (1, key)
    if isinstance(key, str):
        return (2, key.encode("utf-8"))
    return (3, key)


def _equality_fields(filter: Dict[str, Any]) -> Dict[str, Any]:
    """The document an upsert starts from: the filter's plain equality conditions."""
    doc: Dict[str, Any] = {}
    for path, cond in filter.items():
        if path == "$and" and isinstance(cond, list):
            for sub in cond:
                if isinstance(sub, dict):
                    doc.update(_equality_fields(sub))
            continue
        if path.startswith("$"):
            continue
        if isinstance(cond, dict) and list(cond) == ["$eq"]:
            cond = cond["$eq"]
        elif isinstance(cond, dict) and any(str(k).startswith("$") for k in cond):
            continue
        parts = path.split(".")
        target = doc
        for part in parts[:-1]:
            target = target.setdefault(part, {})
            if not isinstance(target, dict):
                break
        else:
            target[parts[-1]] = cond
    return doc
