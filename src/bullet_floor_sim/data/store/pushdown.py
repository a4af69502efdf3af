"""Index keys and filter pre-selection in SQL for the embedded backend.

The embedded backend keeps each document as one BSON blob; an index on a field path is an
SQLite expression index on ``bfs_key(doc, 'path')``, a deterministic SQL function that returns
the field's *index key*:

* missing or null -> NULL; numbers -> themselves; strings -> TEXT;
* ObjectId, bool, datetime -> a BLOB whose first byte is the BSON type's rank (7, 8, 9) and
  whose remaining bytes sort in value order (12 id bytes; 0/1; 8-byte big-endian ms + 2**63);
* anything else (arrays, embedded documents, NaN, binary, ...) and any path that crosses an
  array -> the marker ``X'FF'`` ("decide in Python").

SQLite orders NULL < numbers < TEXT < BLOB, the same brackets as MongoDB's sort order
(null < numbers < strings < ObjectId < bool < date), so comparisons and ORDER BY on keys agree
with MongoDB for every row not marked ``X'FF'``.

:func:`compile_filter` turns the parts of a MongoDB filter it understands (equality, $eq, $in,
$gt/$gte/$lt/$lte on indexed paths with scalar operands, ``_id`` equality and $in, $and) into
an SQL condition that selects a *superset* of the matching rows (marked rows always pass);
the backend then runs the full filter in Python (montydb's query engine) on what SQL returns.
"""
from __future__ import annotations

import calendar
import datetime
import math
import struct
from typing import Any, Callable, Dict, List, Optional, Set, Tuple

import bson

__all__ = [
    "COMPLEX",
    "MISSING",
    "index_key",
    "walk",
    "key_function",
    "key_expr",
    "id_key",
    "Pushdown",
    "compile_filter",
]

COMPLEX = b"\xff"
_RANK_OBJECTID = 7
_RANK_BOOL = 8
_RANK_DATE = 9


class _Missing:
    def __repr__(self) -> str:
        return "MISSING"


MISSING = _Missing()


def walk(doc: Any, path: str) -> Any:
    """The value at a dotted path; MISSING if absent, COMPLEX if the path crosses an array."""
    cur = doc
    for part in path.split("."):
        if isinstance(cur, dict):
            if part not in cur:
                return MISSING
            cur = cur[part]
        elif isinstance(cur, list):
            return COMPLEX
        else:
            return MISSING
    return cur


def _datetime_ms(value: datetime.datetime) -> int:
    if value.tzinfo is not None:
        value = value.astimezone(datetime.timezone.utc).replace(tzinfo=None)
    return calendar.timegm(value.timetuple()) * 1000 + value.microsecond // 1000


def index_key(value: Any) -> Any:
    """The SQL value that sorts ``value`` among others as MongoDB does (see module doc)."""
    if value is None or value is MISSING:
        return None
    if value is COMPLEX:
        return COMPLEX
    if isinstance(value, bool):
        return bytes([_RANK_BOOL, 1 if value else 0])
    if isinstance(value, int):
        return value if -2 ** 63 <= value < 2 ** 63 else COMPLEX
    if isinstance(value, float):
        return COMPLEX if math.isnan(value) else value
    if isinstance(value, str):
        return value
    if isinstance(value, bson.ObjectId):
        return bytes([_RANK_OBJECTID]) + value.binary
    if isinstance(value, datetime.datetime):
        return bytes([_RANK_DATE]) + struct.pack(">Q", _datetime_ms(value) + 2 ** 63)
    return COMPLEX


def key_function() -> Callable[[bytes, str], Any]:
    """A fresh ``bfs_key(doc, path)`` for one SQLite connection (it caches the last doc)."""
    last: List[Any] = [None, None]

    def bfs_key(blob: bytes, path: str) -> Any:
        if blob != last[0]:
            last[0], last[1] = blob, bson.decode(blob)
        return index_key(walk(last[1], path))

    return bfs_key


def key_expr(path: str) -> str:
    """The SQL expression an index on ``path`` is built on (queries must spell it the same)."""
    return "bfs_key(doc, '%s')" % path.replace("'", "''")


def id_key(value: Any) -> bytes:
    """The primary-key bytes of an ``_id`` value."""
    return bson.encode({"": value})


class Pushdown:
    """An SQL condition selecting a superset of a filter's matches.

    Attributes:
        sql: the condition ("1" when nothing could be pushed down).
        params: its parameters.
        exact: every condition of the filter was translated; the selection is then exact
            for all rows whose keys in ``paths`` are not COMPLEX.
        paths: the indexed paths the condition reads.
    """

    def __init__(self) -> None:
        self.clauses: List[str] = []
        self.params: List[Any] = []
        self.exact = True
        self.paths: Set[str] = set()

    @property
    def sql(self) -> str:
        return " AND ".join(self.clauses) if self.clauses else "1"


def compile_filter(filter: Dict[str, Any], indexed: Set[str], strict: bool = False) -> Pushdown:
    """Translate what can be translated of ``filter`` (see module doc).

    Args:
        strict: leave out the "or marked X'FF'" alternatives. Only for a caller that has
            checked, in the same transaction, that no candidate row is marked under the
            paths the condition reads: the selection is then the same, and SQLite can walk
            an index in order instead of merging two ranges.
    """
    out = Pushdown()
    _compile_into(out, filter, indexed, strict)
    return out


def _compile_into(out: Pushdown, filter: Dict[str, Any], indexed: Set[str],
                  strict: bool) -> None:
    for path, cond in filter.items():
        if path == "$and" and isinstance(cond, list):
            for sub in cond:
                if isinstance(sub, dict):
                    _compile_into(out, sub, indexed, strict)
                else:
                    out.exact = False
            continue
        if path == "_id":
            clause = _id_clause(cond)
        elif path in indexed:
            clause = _field_clause(key_expr(path), cond, "" if strict else _MARKED)
            if clause is not None:
                out.paths.add(path)
        else:
            clause = None
        if clause is None:
            out.exact = False
            continue
        sql, params, exact = clause
        out.clauses.append(sql)
        out.params.extend(params)
        out.exact = out.exact and exact


def _is_operators(cond: Any) -> bool:
    return isinstance(cond, dict) and bool(cond) and all(str(k).startswith("$") for k in cond)


def _id_clause(cond: Any) -> Optional[Tuple[str, List[Any], bool]]:
    if not _is_operators(cond):
        return "id = ?", [id_key(cond)], True
    if list(cond) == ["$eq"]:
        return "id = ?", [id_key(cond["$eq"])], True
    if list(cond) == ["$in"] and isinstance(cond["$in"], (list, tuple)):
        values = cond["$in"]
        if not values:
            return "0", [], True
        return "id IN (%s)" % ", ".join("?" * len(values)), [id_key(v) for v in values], True
    return None


_MARKED = " OR %s = X'FF'"


def _field_clause(expr: str, cond: Any, marked: str) -> Optional[Tuple[str, List[Any], bool]]:
    """SQL for one path's condition; ``marked`` is the "or marked" alternative (or "")."""
    if not _is_operators(cond):
        return _eq(expr, cond, marked)
    clauses, params, exact = [], [], True
    for op, value in cond.items():
        if op == "$eq":
            part = _eq(expr, value, marked)
        elif op == "$in" and isinstance(value, (list, tuple)):
            part = _in(expr, value, marked)
        elif op in _RANGE_OPS:
            part = _range(expr, op, value, marked)
        else:
            part = None
        if part is None:
            exact = False
            continue
        clauses.append(part[0])
        params.extend(part[1])
    if not clauses:
        return None
    return " AND ".join(clauses), params, exact


def _eq(expr: str, value: Any, marked: str) -> Optional[Tuple[str, List[Any], bool]]:
    if value is None:
        return "(%s IS NULL%s)" % (expr, marked % expr if marked else ""), [], True
    key = index_key(value)
    if key is COMPLEX:
        return None
    if marked:
        return "%s IN (?, X'FF')" % expr, [key], True
    return "%s = ?" % expr, [key], True


def _in(expr: str, values: Any, marked: str) -> Optional[Tuple[str, List[Any], bool]]:
    keys = [index_key(v) for v in values]
    if any(k is COMPLEX for k in keys):
        return None
    if not keys:
        return "0", [], True
    present = [k for k in keys if k is not None]
    items = ["?"] * len(present) + (["X'FF'"] if marked else [])
    sql = "%s IN (%s)" % (expr, ", ".join(items)) if items else "0"
    if len(present) < len(keys):
        sql = "(%s OR %s IS NULL)" % (sql, expr)
    return sql, present, True


_RANGE_OPS = {"$gt": ">", "$gte": ">=", "$lt": "<", "$lte": "<="}


def _range(expr: str, op: str, value: Any,
           marked: str) -> Optional[Tuple[str, List[Any], bool]]:
    key = index_key(value)
    if key is None or key is COMPLEX:
        return None
    sql_op = _RANGE_OPS[op]
    upward = op in ("$gt", "$gte")
    # Keep the comparison inside the operand's type bracket, as MongoDB does.
    if isinstance(key, bytes):
        low, high = "X'%02x'" % key[0], "X'%02x'" % (key[0] + 1)  # type: Optional[str], str
    elif isinstance(key, str):
        low, high = "''", "X''"
    else:
        low, high = None, "''"
    if upward:
        bound = "%s < %s" % (expr, high)  # type: Optional[str]
    else:
        bound = "%s >= %s" % (expr, low) if low else None
    sql = "%s %s ?" % (expr, sql_op)
    if bound:
        sql = "(%s AND %s)" % (sql, bound)
    return "(%s%s)" % (sql, marked % expr if marked else ""), [key], True
