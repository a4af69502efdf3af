"""The ROI edits the rviz menu makes, on plain :class:`~.rois.Roi` values: move a vertex, add
or delete a point, a new ROI and its id; and the :class:`Debouncer` that decides when a dragged
ROI is saved (data/roi_store.py stores them). No rospy here.
"""
from __future__ import annotations

import json
import math
from typing import Any, Dict, Iterable, List, Tuple

from .rois import Roi, RoiError, validate_roi

__all__ = ["move_vertex", "add_point", "delete_point", "new_roi", "next_roi_id", "Debouncer"]


def _copy(roi: Roi, vertices: Iterable[Tuple[float, float]]) -> Roi:
    return Roi(id=roi.id, config=roi.config, type=roi.type, map_name=roi.map_name,
               vertices=[(float(x), float(y)) for x, y in vertices])


def _check_index(roi: Roi, index: int) -> None:
    if not 0 <= index < len(roi.vertices):
        raise RoiError("ROI %s: no vertex %d (it has %d)"
                       % (json.dumps(roi.id), index, len(roi.vertices)))


def move_vertex(roi: Roi, index: int, x: float, y: float) -> Roi:
    """A copy of ``roi`` with vertex ``index`` at (x, y).

    Raises:
        RoiError: no such vertex, or a non-finite coordinate.
    """
    _check_index(roi, index)
    if not (math.isfinite(x) and math.isfinite(y)):
        raise RoiError("ROI %s: vertex %d moved to a non-finite position (%s, %s)"
                       % (json.dumps(roi.id), index, x, y))
    vertices = list(roi.vertices)
    vertices[index] = (float(x), float(y))
    return _copy(roi, vertices)


def add_point(roi: Roi, index: int) -> Roi:
    """A copy of ``roi`` with a new vertex halfway along the edge from vertex ``index`` to the
    next one (inserted after ``index``), as soma_roi_manager's Add Point."""
    _check_index(roi, index)
    n = len(roi.vertices)
    (x0, y0), (x1, y1) = roi.vertices[index], roi.vertices[(index + 1) % n]
    vertices = list(roi.vertices)
    vertices.insert(index + 1, ((x0 + x1) / 2.0, (y0 + y1) / 2.0))
    return _copy(roi, vertices)


def delete_point(roi: Roi, index: int) -> Roi:
    """A copy of ``roi`` without vertex ``index``.

    Raises:
        RoiError: no such vertex, or the ROI would keep fewer than 3 vertices.
    """
    _check_index(roi, index)
    if len(roi.vertices) <= 3:
        raise RoiError("ROI %s: cannot delete vertex %d, a polygon needs at least 3 vertices"
                       % (json.dumps(roi.id), index))
    return _copy(roi, [v for k, v in enumerate(roi.vertices) if k != index])


def next_roi_id(ids: Iterable[str]) -> str:
    """One more than the largest numeric id (SOMA numbers ROIs "1", "2", ...). Pass deleted
    ids too, so that a new ROI does not continue a deleted one's history."""
    numbers = [int(i) for i in ids if i.isdigit()]
    return str(max(numbers) + 1 if numbers else 1)


def new_roi(roi_id: str, roi_type: str, map_name: str, config: str, x: float, y: float,
            size: float = 1.0) -> Roi:
    """A square ROI of side ``size`` centred on (x, y) (soma_roi_manager's Add ROI)."""
    h = float(size) / 2.0
    roi = Roi(id=roi_id, config=config, type=roi_type, map_name=map_name,
              vertices=[(x - h, y - h), (x + h, y - h), (x + h, y + h), (x - h, y + h)])
    validate_roi(roi)
    return roi


# --------------------------------------------------------------------------------------------
# debouncing
# --------------------------------------------------------------------------------------------


class Debouncer:
    """When to save edited items: once nothing touched them for ``quiet`` seconds, and at
    the latest ``max_wait`` seconds after the first unsaved edit (a long drag is saved too).
    """

    def __init__(self, quiet: float = 1.0, max_wait: float = 3.0) -> None:
        if not (quiet >= 0.0 and max_wait >= quiet):
            raise ValueError("debounce: need 0 <= quiet <= max_wait, got %r, %r"
                             % (quiet, max_wait))
        self.quiet = float(quiet)
        self.max_wait = float(max_wait)
        self._first: Dict[Any, float] = {}
        self._last: Dict[Any, float] = {}

    def touch(self, key: Any, now: float) -> None:
        """Record an edit of ``key`` at time ``now``."""
        self._first.setdefault(key, now)
        self._last[key] = now

    def due(self, now: float) -> List[Any]:
        """Keys to save now (they are forgotten until touched again)."""
        out = [k for k in self._last
               if now - self._last[k] >= self.quiet or now - self._first[k] >= self.max_wait]
        for k in out:
            del self._first[k], self._last[k]
        return out

    def pending(self) -> List[Any]:
        """Keys edited and not yet due."""
        return list(self._last)

    def drain(self) -> List[Any]:
        """Every pending key (at shutdown)."""
        out = list(self._last)
        self._first.clear()
        self._last.clear()
        return out
