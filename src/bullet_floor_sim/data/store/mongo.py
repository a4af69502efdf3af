"""The MongoDB backend: a real server through pymongo (mongodb_store's database).

Hosts without a port get mongodb_store's 62345. Timeouts are short (``timeout`` seconds for
server selection and connecting), so an outage is noticed within about that long and the
front end can journal instead of blocking a ROS callback for pymongo's default 30 s.
"""
from __future__ import annotations

from typing import Any, Dict, List, Tuple

import bson

from .base import (MONGODB_DEFAULT_PORT, Backend, DuplicateKeyError, StoreError,
                   StoreUnavailable, is_operator_update, redact_uri)

__all__ = ["MongoBackend"]

#: Server error codes that concern the whole database, not one write: credentials and rights
#: (18 AuthenticationFailed, 13 Unauthorized), shutdown and elections (91, 189, 10107, 11600,
#: 11602, 13435), lock timeouts (24), no disk space (14031). A time limit (50, 262) is one
#: operation's: a write that keeps hitting it is set aside rather than holding the journal.
_DATABASE_WIDE = frozenset((13, 18, 24, 91, 189, 10107, 11600, 11602, 13435, 14031))


class MongoBackend(Backend):
    """pymongo calls with pymongo's errors turned into the store's.

    Args:
        uri: ``mongodb://host[:port][,host...]/[?options]`` (or ``mongodb+srv://``).
        timeout: seconds for server selection and for connecting; socket reads get
            ``max(10, 5 * timeout)``.

    Raises:
        StoreError: the URI does not parse or names bad options.
    """

    kind = "mongodb"

    def __init__(self, uri: str, timeout: float = 1.5):
        import pymongo
        from pymongo import errors

        self._errors = errors
        self.uri = uri
        ms = int(timeout * 1000)
        try:
            self._client: pymongo.MongoClient[Dict[str, Any]] = pymongo.MongoClient(
                uri, port=MONGODB_DEFAULT_PORT, serverSelectionTimeoutMS=ms,
                connectTimeoutMS=ms, socketTimeoutMS=max(10000, 5 * ms), tz_aware=False,
                appname="bullet_floor_sim", connect=False)
        except (errors.PyMongoError, ValueError, TypeError) as e:
            raise StoreError("store %s: invalid MongoDB URI (%s)" % (redact_uri(uri), e)) from None

    def _call(self, fn, *args, **kwargs):
        """Run one pymongo call; translate its errors."""
        errors = self._errors
        try:
            return fn(*args, **kwargs)
        except errors.DuplicateKeyError as e:
            raise DuplicateKeyError("store %s: duplicate _id (%s)"
                                    % (redact_uri(self.uri), _first_line(e))) from None
        except errors.ConnectionFailure as e:  # AutoReconnect, ServerSelectionTimeout, ...
            raise StoreUnavailable("store %s: MongoDB unreachable (%s: %s)" % (
                redact_uri(self.uri), type(e).__name__, _first_line(e))) from None
        except errors.OperationFailure as e:
            if e.code in _DATABASE_WIDE:
                raise StoreUnavailable("store %s: MongoDB refused the database (%s %s: %s)" % (
                    redact_uri(self.uri), type(e).__name__, e.code, _first_line(e))) from None
            raise StoreError("store %s: %s" % (redact_uri(self.uri), _first_line(e))) from None
        except (errors.PyMongoError, bson.errors.BSONError) as e:
            raise StoreError("store %s: %s" % (redact_uri(self.uri), _first_line(e))) from None

    def _coll(self, db: str, collection: str):
        return self._client[db][collection]

    def insert(self, db: str, collection: str, doc: Dict[str, Any]) -> None:
        self._call(self._coll(db, collection).insert_one, doc)

    def update(self, db: str, collection: str, filter: Dict[str, Any], update: Dict[str, Any],
               upsert: bool, multi: bool) -> int:
        coll = self._coll(db, collection)
        if not is_operator_update(update):
            if multi:
                raise StoreError("store: a replacement document updates one document; "
                                 "use $-operators with multi=True")
            res = self._call(coll.replace_one, filter, update, upsert=upsert)
        elif multi:
            res = self._call(coll.update_many, filter, update, upsert=upsert)
        else:
            res = self._call(coll.update_one, filter, update, upsert=upsert)
        return res.matched_count + (1 if res.upserted_id is not None else 0)

    def delete(self, db: str, collection: str, filter: Dict[str, Any]) -> int:
        return self._call(self._coll(db, collection).delete_many, filter).deleted_count

    def find(self, db: str, collection: str, filter: Dict[str, Any],
             sort: List[Tuple[str, int]], limit: int) -> List[Dict[str, Any]]:
        coll = self._coll(db, collection)
        return self._call(lambda: list(coll.find(filter, sort=sort or None, limit=limit)))

    def latest(self, db: str, collection: str, filter: Dict[str, Any], group_by: List[str],
               order_by: str) -> List[Dict[str, Any]]:
        # $sort + $group/$first: served by an index on (filter fields, group_by, order_by -1).
        keys = ["k%d" % i for i in range(len(group_by))]
        sort = dict([(g, 1) for g in group_by] + [(order_by, -1)])
        pipeline = [
            {"$match": filter},
            {"$sort": sort},
            {"$group": {"_id": dict(zip(keys, ["$" + g for g in group_by])),
                        "doc": {"$first": "$$ROOT"}}},
            {"$replaceRoot": {"newRoot": "$doc"}},
            {"$sort": dict((g, 1) for g in group_by)},
        ]
        coll = self._coll(db, collection)
        return self._call(lambda: list(coll.aggregate(pipeline)))

    def create_index(self, db: str, collection: str, keys: List[Tuple[str, int]]) -> None:
        self._call(self._coll(db, collection).create_index, keys)

    def close(self) -> None:
        self._client.close()


def _first_line(e: BaseException) -> str:
    """An exception's message, first line only, without pymongo's 'full error' tail."""
    text = str(e).split(", full error:")[0]
    return text.splitlines()[0] if text else type(e).__name__
