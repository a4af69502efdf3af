"""Opening a store by its URI: MongoDB (``mongodb://``) or the embedded store (a directory)."""
from __future__ import annotations

import os
from typing import Optional

from .base import Backend, StoreError, default_db_dir, default_journal_path, redact_uri
from .journal import DEFAULT_MAX_BYTES
from .store import DEFAULT_MAX_HELD_BYTES, Store

__all__ = ["open_store", "require_existing"]


def require_existing(uri: Optional[str], database: str) -> None:
    """For a tool that only reads: refuse an embedded store without ``database`` (opening it
    would create an empty one, and the tool would report nothing found). A MongoDB URI
    passes: a server that cannot be reached is an error when it is read.

    Raises:
        StoreError: "no such database: PATH ...".
    """
    if uri and "://" in uri:
        return
    path = os.path.abspath(os.path.expanduser(uri or default_db_dir()))
    if not os.path.isdir(path):
        raise StoreError("no such database: %s (a directory of the embedded store; give --db "
                         "mongodb://host:port/ or the directory a recorder wrote)" % path)
    if not os.path.isfile(os.path.join(path, database + ".sqlite3")):
        raise StoreError("no such database: %s holds no %s (%s.sqlite3); is it the directory "
                         "a recorder wrote?" % (path, database, database))


def open_store(uri: Optional[str] = None, journal_dir: Optional[str] = None,
               timeout: float = 1.5, retry_interval: float = 5.0,
               synchronous: str = "NORMAL", max_journal_bytes: int = DEFAULT_MAX_BYTES,
               max_held_bytes: int = DEFAULT_MAX_HELD_BYTES) -> Store:
    """Open the store named by ``uri`` and replay what its journal holds.

    Args:
        uri: ``mongodb://host[:port]/`` (port 62345 when omitted, as mongodb_store), or a
            directory for the embedded store; None or "" for ``$ROS_HOME/bullet_floor_sim/db``.
        journal_dir: where the journal lives (default ``$ROS_HOME/bullet_floor_sim/journal``).
        timeout: seconds before an unreachable MongoDB (or a locked SQLite file) counts as down.
        retry_interval: seconds between attempts to reach a database found down.
        synchronous: the embedded backend's SQLite ``synchronous`` pragma.
        max_journal_bytes: the journal's cap (the disk budget of an outage).
        max_held_bytes: how much may wait in memory when the journal cannot take writes.

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
        return Store(key, backend, default_journal_path(key, journal_dir), retry_interval,
                     max_journal_bytes, max_held_bytes)
    except BaseException:
        backend.close()
        raise
