"""Regions of interest (ROIs): plain polygons in the map frame, their YAML file and checks.

A ROI is what SOMA stores as a SOMAROIObject, reduced to the fields the simulator needs: an
``id``, the ``config`` (SOMA's ROI set) and ``map_name`` it belongs to, a ``type`` (corridor,
office, ...) and its polygon ``vertices`` in the map frame (metres). ``worlds/<name>/rois.yaml``
holds one map and one config::

    map_name: office
    config: "1"
    rois:
      - {id: "1", type: corridor, points: [[x, y], [x, y], [x, y], [x, y]]}

Every error is a RoiError on one line naming the file (when known), the ROI id and the problem.
A closing vertex equal to the first one is dropped (the polygon is closed implicitly).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple

import numpy as np
import yaml
from shapely.geometry import LinearRing, Point, Polygon
from shapely.validation import explain_validity

from ..errors import BulletFloorSimError
from ..files import atomic_file
from ..sim.checks import is_number as _is_number
from ..yamlio import read_yaml

__all__ = [
    "id_order",
    "RoiError",
    "Roi",
    "load_rois",
    "save_rois",
    "rois_from_dict",
    "rois_to_dict",
    "validate_roi",
    "validate_rois",
    "check_bounds",
    "one_map_and_config",
    "roi_polygon",
    "roi_at",
    "centroid",
    "random_point_inside",
]

_FILE_KEYS = ("map_name", "config", "rois")
_ROI_KEYS = ("id", "type", "points")

Vertex = Tuple[float, float]


class RoiError(BulletFloorSimError):
    """A ROI or a ROI file is malformed: bad keys or types, too few vertices, self-intersection,
    non-finite coordinates, duplicate ids, or no point can be drawn inside it."""


@dataclass(eq=True)
class Roi:
    """One region of interest.

    Attributes:
        id: the ROI id, unique within its map and config (SOMA's ``id``).
        config: the ROI set it belongs to (SOMA's ``config``).
        type: what the region is (corridor, office, lab, kitchen, ...).
        map_name: the map it is drawn on.
        vertices: polygon corners (x, y) in the map frame, metres, not repeating the first.
    """

    id: str
    config: str
    type: str
    map_name: str
    vertices: List[Vertex] = field(default_factory=list)


# --------------------------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------------------------


def load_rois(path: str) -> List[Roi]:
    """Read and validate a rois.yaml.

    Args:
        path: the file.

    Returns:
        The ROIs in file order.

    Raises:
        RoiError: the file is missing, not YAML, or any ROI is invalid; the message names
            the file, the ROI id and the problem.
    """
    return rois_from_dict(read_yaml(path, "ROI", RoiError), source=path)


def save_rois(rois: Sequence[Roi], path: str) -> None:
    """Write ROIs of one map and config as a rois.yaml (one flow-style line per ROI).

    Raises:
        RoiError: the ROIs are invalid or belong to several maps/configs.
    """
    doc = rois_to_dict(rois)
    lines = ["map_name: %s" % _dump_scalar(doc["map_name"]),
             "config: %s" % _dump_scalar(doc["config"]),
             "rois:" if doc["rois"] else "rois: []"]
    for entry in doc["rois"]:
        lines.append("  - " + yaml.safe_dump(entry, default_flow_style=True, sort_keys=False,
                                             width=float("inf")).strip())
    with atomic_file(path) as f:
        f.write("\n".join(lines) + "\n")


def _dump_scalar(value: str) -> str:
    """A string as a double-quoted YAML scalar (JSON string syntax is valid YAML)."""
    return json.dumps(value)


def rois_from_dict(doc: Any, source: str = "") -> List[Roi]:
    """Build and validate ROIs from a parsed rois.yaml document.

    Args:
        doc: ``{"map_name": str, "config": str, "rois": [{"id", "type", "points"}, ...]}``.
        source: where it came from, for messages ("" when unknown).

    Returns:
        The ROIs in document order.

    Raises:
        RoiError: missing/unknown keys, wrong types or invalid polygons.
    """
    where = source + ": " if source else ""
    if not isinstance(doc, dict):
        raise RoiError("%sexpected a mapping with keys %s, got %s"
                       % (where, ", ".join(_FILE_KEYS), type(doc).__name__))
    missing = [k for k in _FILE_KEYS if k not in doc]
    if missing:
        raise RoiError("%smissing key(s): %s" % (where, ", ".join(missing)))
    unknown = sorted(str(k) for k in doc if k not in _FILE_KEYS)
    if unknown:
        raise RoiError("%sunknown key(s): %s (expected %s)"
                       % (where, ", ".join(unknown), ", ".join(_FILE_KEYS)))
    map_name = _string(doc["map_name"], "%smap_name" % where, allow_empty=False)
    config = _string(doc["config"], "%sconfig" % where, allow_empty=False)
    entries = doc["rois"]
    if entries is None:
        entries = []
    if not isinstance(entries, list):
        raise RoiError("%srois must be a list of {id, type, points}, got %s"
                       % (where, type(entries).__name__))
    rois = []
    for k, entry in enumerate(entries):
        rois.append(_roi_from_entry(entry, k, map_name, config, where))
    validate_rois(rois, source)
    return rois


def _roi_from_entry(entry: Any, index: int, map_name: str, config: str, where: str) -> Roi:
    label = "rois[%d]" % index
    if isinstance(entry, dict) and isinstance(entry.get("id"), str):
        label = "ROI %s" % _quote(entry["id"])
    if not isinstance(entry, dict):
        raise RoiError("%s%s: expected a mapping {id, type, points}, got %s"
                       % (where, label, type(entry).__name__))
    missing = [k for k in _ROI_KEYS if k not in entry]
    if missing:
        raise RoiError("%s%s: missing key(s): %s" % (where, label, ", ".join(missing)))
    unknown = sorted(str(k) for k in entry if k not in _ROI_KEYS)
    if unknown:
        raise RoiError("%s%s: unknown key(s): %s (expected %s)"
                       % (where, label, ", ".join(unknown), ", ".join(_ROI_KEYS)))
    roi_id = entry["id"]
    if not isinstance(roi_id, str):
        raise RoiError("%s%s: id must be a string (quote it: \"%s\"), got %s"
                       % (where, label, roi_id, type(roi_id).__name__))
    roi_type = _string(entry["type"], "%s%s: type" % (where, label), allow_empty=False)
    points = entry["points"]
    if not isinstance(points, list):
        raise RoiError("%s%s: points must be a list of [x, y], got %s"
                       % (where, label, type(points).__name__))
    vertices = []
    for k, p in enumerate(points):
        if (not isinstance(p, (list, tuple)) or len(p) != 2
                or not all(_is_number(v) for v in p)):
            raise RoiError("%s%s: point %d must be [x, y] (two numbers), got %r%s"
                           % (where, label, k, p, _number_hint(p)))
        vertices.append((float(p[0]), float(p[1])))
    if len(vertices) > 1 and vertices[0] == vertices[-1]:
        vertices.pop()
    return Roi(id=roi_id, config=config, type=roi_type, map_name=map_name, vertices=vertices)


def rois_to_dict(rois: Sequence[Roi]) -> Dict[str, Any]:
    """The rois.yaml document of ROIs that share one map and one config.

    Raises:
        RoiError: the ROIs are invalid, or empty, or span several maps or configs.
    """
    rois = list(rois)
    if not rois:
        raise RoiError("no ROIs to write: a rois.yaml needs at least its map_name and config")
    validate_rois(rois)
    map_name, config = one_map_and_config(rois, "a rois.yaml holds one map and one config,")
    return {
        "map_name": map_name,
        "config": config,
        "rois": [{"id": r.id, "type": r.type, "points": [[x, y] for x, y in r.vertices]}
                 for r in rois],
    }


def one_map_and_config(rois: Sequence[Roi], lead: str) -> Tuple[str, str]:
    """The one map name and config that non-empty ``rois`` share.

    Raises:
        RoiError: "<lead> got maps ... and configs ...", when they span several.
    """
    maps = sorted({r.map_name for r in rois})
    configs = sorted({r.config for r in rois})
    if len(maps) > 1 or len(configs) > 1:
        raise RoiError("%s got maps %s and configs %s"
                       % (lead, ", ".join(maps), ", ".join(configs)))
    return maps[0], configs[0]


# --------------------------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------------------------


def validate_roi(roi: Roi, source: str = "") -> None:
    """Check one ROI's fields and polygon.

    Args:
        roi: the ROI.
        source: the file it came from, for messages ("" when unknown).

    Raises:
        RoiError: a field has the wrong type, fewer than 3 vertices, a non-finite coordinate,
            or a self-intersecting (or zero-area) polygon; the message says where.
    """
    where = source + ": " if source else ""
    if not isinstance(roi.id, str) or not roi.id:
        raise RoiError("%sROI id must be a non-empty string, got %r" % (where, roi.id))
    label = "%sROI %s" % (where, _quote(roi.id))
    for name in ("config", "type", "map_name"):
        _string(getattr(roi, name), "%s: %s" % (label, name), allow_empty=False)
    if not isinstance(roi.vertices, (list, tuple)):
        raise RoiError("%s: vertices must be a list of (x, y), got %s"
                       % (label, type(roi.vertices).__name__))
    for k, v in enumerate(roi.vertices):
        if not isinstance(v, (list, tuple)) or len(v) != 2 or not all(_is_number(c) for c in v):
            raise RoiError("%s: vertex %d must be (x, y) (two numbers), got %r" % (label, k, v))
        if not (math.isfinite(v[0]) and math.isfinite(v[1])):
            raise RoiError("%s: vertex %d (%s, %s) is not finite" % (label, k, v[0], v[1]))
    n = len(roi.vertices)
    if n < 3:
        raise RoiError("%s: a polygon needs at least 3 vertices, got %d" % (label, n))
    pts = np.asarray(roi.vertices, dtype=float)
    if np.linalg.matrix_rank(pts - pts.mean(axis=0), tol=1e-9) < 2:
        raise RoiError("%s: all %d vertices lie on one line (the polygon has no area)"
                       % (label, n))
    ring = LinearRing(roi.vertices)
    if not ring.is_simple:
        raise RoiError("%s: polygon edges cross or touch (%s); list the vertices in order "
                       "around the region" % (label, _explain(Polygon(roi.vertices))))
    polygon = Polygon(roi.vertices)
    if not polygon.is_valid or polygon.area <= 0.0:
        raise RoiError("%s: polygon is not valid (%s)" % (label, _explain(polygon)))


def validate_rois(rois: Iterable[Roi], source: str = "") -> None:
    """Check every ROI and that no id repeats within a map and config.

    Raises:
        RoiError: the first problem found (see validate_roi), or a duplicate id.
    """
    where = source + ": " if source else ""
    seen = {}  # type: Dict[Tuple[str, str, str], int]
    for k, roi in enumerate(rois):
        validate_roi(roi, source)
        key = (roi.map_name, roi.config, roi.id)
        if key in seen:
            raise RoiError("%sROI %s: duplicate id in map %s config %s (ROIs number %d and %d)"
                           % (where, _quote(roi.id), _quote(roi.map_name), _quote(roi.config),
                              seen[key] + 1, k + 1))
        seen[key] = k


def check_bounds(rois: Iterable[Roi], bounds: Sequence[float]) -> List[str]:
    """Warnings for ROIs with vertices outside the map.

    Args:
        rois: the ROIs.
        bounds: the map's (xmin, ymin, xmax, ymax), e.g. ``FloorMap.bounds()``.

    Returns:
        One line per ROI that has vertices outside the bounds (empty when all are inside).
    """
    xmin, ymin, xmax, ymax = (float(b) for b in bounds)
    warnings = []
    for roi in rois:
        outside = [(k, x, y) for k, (x, y) in enumerate(roi.vertices)
                   if not (xmin <= x <= xmax and ymin <= y <= ymax)]
        if outside:
            k, x, y = outside[0]
            more = " and %d more" % (len(outside) - 1) if len(outside) > 1 else ""
            warnings.append("ROI %s: vertex %d (%g, %g)%s outside the map bounds "
                            "x %g..%g, y %g..%g"
                            % (_quote(roi.id), k, x, y, more, xmin, xmax, ymin, ymax))
    return warnings


# --------------------------------------------------------------------------------------------
# geometry
# --------------------------------------------------------------------------------------------


def roi_polygon(roi: Roi) -> Polygon:
    """The ROI as a shapely Polygon."""
    return Polygon(roi.vertices)


def roi_at(rois: Iterable[Roi], x: float, y: float) -> Optional[Roi]:
    """The ROI containing (x, y) (boundary included), the smallest one if several do.

    Returns:
        The ROI, or None when the point is in none.
    """
    best = None
    best_area = math.inf
    pt = Point(float(x), float(y))
    for roi in rois:
        xs = [v[0] for v in roi.vertices]
        ys = [v[1] for v in roi.vertices]
        if not (min(xs) <= x <= max(xs) and min(ys) <= y <= max(ys)):
            continue
        poly = roi_polygon(roi)
        if poly.covers(pt) and poly.area < best_area:
            best, best_area = roi, poly.area
    return best


def centroid(roi: Roi) -> Vertex:
    """The polygon's centroid (x, y); for a non-convex ROI it may lie outside the polygon."""
    c = roi_polygon(roi).centroid
    return (float(c.x), float(c.y))


def random_point_inside(roi: Roi, rng: Optional[np.random.Generator] = None,
                        margin: float = 0.0,
                        is_free: Optional[Callable[[float, float], bool]] = None,
                        max_tries: int = 1000) -> Vertex:
    """A uniformly random point at least ``margin`` metres inside the ROI.

    Args:
        roi: the region.
        rng: numpy Generator (seed it for reproducible goals); a fresh one when None.
        margin: minimum distance from the polygon's boundary, metres (>= 0).
        is_free: optional callback; a point is accepted only when ``is_free(x, y)`` is True
            (e.g. free and reachable on the map).
        max_tries: number of random draws before giving up.

    Returns:
        (x, y).

    Raises:
        RoiError: the polygon has no point ``margin`` inside it, or no draw was accepted.
    """
    if rng is None:
        rng = np.random.default_rng()
    if margin < 0.0 or not math.isfinite(margin):
        raise RoiError("ROI %s: margin must be a finite number >= 0, got %r"
                       % (_quote(roi.id), margin))
    poly = roi_polygon(roi)
    inner = poly.buffer(-margin) if margin > 0.0 else poly
    if inner.is_empty:
        raise RoiError("ROI %s: no point lies %g m inside it (the region is too narrow)"
                       % (_quote(roi.id), margin))
    xmin, ymin, xmax, ymax = inner.bounds
    boundary = poly.exterior
    rejected_free = 0
    for _ in range(max(1, int(max_tries))):
        x = float(rng.uniform(xmin, xmax))
        y = float(rng.uniform(ymin, ymax))
        pt = Point(x, y)
        # the buffer approximates arcs by chords: check the exact distance as well
        if not poly.contains(pt) or boundary.distance(pt) < margin:
            continue
        if is_free is not None and not is_free(x, y):
            rejected_free += 1
            continue
        return (x, y)
    why = (" (%d of them inside but not free)" % rejected_free) if is_free is not None else ""
    raise RoiError("ROI %s: no acceptable point %g m inside it after %d tries%s"
                   % (_quote(roi.id), margin, max_tries, why))


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def _quote(s: Any) -> str:
    return '"%s"' % s


def _number_hint(p: Any) -> str:
    """YAML 1.1 (PyYAML) reads 1e-3 as text: say so when a 'string' is really a number."""
    for v in p if isinstance(p, (list, tuple)) else ():
        if isinstance(v, str):
            try:
                float(v)
            except ValueError:
                continue
            return " (YAML reads %s as text: write it with a dot, e.g. 1.0e-3)" % v
    return ""


def _string(v: Any, what: str, allow_empty: bool = True) -> str:
    if not isinstance(v, str):
        raise RoiError("%s must be a string (quote it: \"%s\"), got %s"
                       % (what, v, type(v).__name__))
    if not allow_empty and not v:
        raise RoiError("%s must not be empty" % what)
    return v


def _explain(polygon: Polygon) -> str:
    """explain_validity's '<Reason>[x y]' as '<reason> at (x, y)'."""
    text = explain_validity(polygon)
    if "[" in text and text.endswith("]"):
        reason, _, coords = text[:-1].partition("[")
        parts = coords.split()
        try:
            return "%s at (%g, %g)" % (reason.strip().lower(), float(parts[0]), float(parts[1]))
        except (IndexError, ValueError):
            pass
    if text == "Valid Geometry":
        return "zero area: the vertices are collinear"
    return text.lower()


def id_order(roi_id: str) -> Tuple[int, int, str]:
    """Sort key of ROI ids: numeric ids in numeric order ("2" < "10"), then the others
    alphabetically."""
    return (0, int(roi_id), "") if roi_id.isdigit() else (1, 0, roi_id)
