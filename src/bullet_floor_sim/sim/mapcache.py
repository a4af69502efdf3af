"""The disk cache of what a map's solid cells cost to derive (sim/solidmap.py).

Deriving a big SLAM map's solid cells, their distance field and the rectangles the wall mesh
is made of takes about a second (malaga_faculty, 1644 x 1457 cells: 0.2 + 0.35 + 0.6 s);
every load after the first reads them back in a few milliseconds. The entry is keyed by the
grid's content (values, shape, resolution, origin) and the map handling, so a map from a file
and the same map from map_server's topic share it, and an edited map misses it.

Where: ``$BULLET_FLOOR_SIM_CACHE/maps`` when that is set (empty: no cache), else
``$ROS_HOME/bullet_floor_sim/maps`` (``~/.ros`` without ROS_HOME). An entry that cannot be
read is derived again; one that cannot be written is skipped (the load is only slower).
Nothing prunes the directory: a map takes about 5 bytes a cell (12 MB for malaga_faculty).
"""
from __future__ import annotations

import hashlib
import json
import os
from typing import Any, Dict, Optional

import numpy as np

from ..files import atomic_file

__all__ = ["map_cache_dir", "map_key", "load_entry", "store_entry"]

_FORMAT = "solid-v1"   # bump when sim/solidmap.py or merge_rectangles derives differently


def map_cache_dir() -> str:
    """Where derived map data is cached ("" = no cache)."""
    env = os.environ.get("BULLET_FLOOR_SIM_CACHE")
    if env is not None:
        return os.path.join(os.path.normpath(os.path.abspath(env)), "maps") if env else ""
    home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return os.path.join(home, "bullet_floor_sim", "maps")


def map_key(grid: np.ndarray, resolution: float, origin: Any, handling: Any) -> str:
    """A digest of everything the derived data depends on."""
    h = hashlib.sha1()
    h.update(("%s %r %r %r %r\n" % (_FORMAT, grid.shape, float(resolution),
                                     tuple(float(v) for v in origin), handling)).encode())
    h.update(np.ascontiguousarray(grid, dtype=np.int8).tobytes())
    return h.hexdigest()[:24]


def load_entry(key: str) -> Optional[Dict[str, Any]]:
    """The arrays and metadata stored under ``key``, or None (absent, unreadable, no cache)."""
    cache = map_cache_dir()
    if not cache:
        return None
    try:
        with np.load(os.path.join(cache, key + ".npz"), allow_pickle=False) as z:
            out = {name: z[name] for name in z.files}
        out["meta"] = json.loads(str(out["meta"]))
        return out
    except Exception:  # noqa: BLE001 - any unreadable entry (a truncated zip too) is derived again
        return None


def store_entry(key: str, arrays: Dict[str, np.ndarray], meta: Dict[str, Any]) -> None:
    """Store arrays and JSON-able metadata under ``key``, atomically; silently nothing when
    the cache is off or cannot be written."""
    cache = map_cache_dir()
    if not cache:
        return
    try:
        os.makedirs(cache, exist_ok=True)
        with atomic_file(os.path.join(cache, key + ".npz"), "wb", fsync=False) as f:
            np.savez(f, meta=np.array(json.dumps(meta)), **arrays)
    except OSError:
        pass
