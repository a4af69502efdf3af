"""Document storage: one small interface, a MongoDB backend and an embedded one.

    from bullet_floor_sim.data.store import open_store, insert_message

    with open_store("mongodb://localhost:62345/") as store:   # or a directory, or None
        _id = insert_message(store, "message_store", "soma_roi", fields,
                             "soma_msgs/SOMAROIObject", meta={"map": "office"},
                             inserted_by="/soma_roi_manager")
        newest = store.latest("message_store", "soma_roi", ["config", "id"], "logtimestamp",
                              filter={"map_name": "office"})

* ``mongodb://...``: a real MongoDB through pymongo (:mod:`.mongo`), mongodb_store's layout and
  default port 62345.
* a directory (default ``$ROS_HOME/bullet_floor_sim/db``): the embedded store
  (:mod:`.embedded`): SQLite files with MongoDB query/update semantics from montydb's engine.
* Writes that cannot reach the database are journalled and replayed later (:mod:`.store`,
  :mod:`.journal`); reads then raise :class:`StoreUnavailable`.
* :mod:`.messages` builds mongodb_store's ``_meta`` layout from plain dicts.

No rospy here: the ROS glue converts messages to dicts.
"""
from __future__ import annotations

from .base import (MONGODB_DEFAULT_PORT, DuplicateKeyError, StoreError, StoreUnavailable,
                   default_db_dir, default_journal_path, ros_home)
from .messages import (SOMA_TYPES, insert_message, message_document, ros_datetime,
                       stored_class_for)
from .store import Store
from .uri import open_store, require_existing

__all__ = [
    "MONGODB_DEFAULT_PORT",
    "SOMA_TYPES",
    "DuplicateKeyError",
    "Store",
    "StoreError",
    "StoreUnavailable",
    "default_db_dir",
    "default_journal_path",
    "insert_message",
    "message_document",
    "open_store", "require_existing",
    "ros_datetime",
    "ros_home",
    "stored_class_for",
]
