"""Rooms of a floor map, found automatically, and SOMA ROIs drawn from them.

:func:`segment_rooms` splits the free space of an occupancy grid into rooms. It works on the
clearance (distance to the nearest obstacle) of the free cells:

1. obstacle blobs of at most ``furniture_area`` that touch no other obstacle (chairs, table
   legs, pillars, a person caught while mapping) are ignored while rooms are found: rooms are
   made by walls, not by furniture (a long thin blob, ``wall_length`` or more, is a piece of
   wall between two doors and stays);
2. every marked maximum of the clearance (an h-maximum, ``seed_height`` deep) seeds a basin; a
   watershed of the negated clearance grows the basins over the free space, so basins meet at
   the passes (the narrowest points between two wide places);
3. basins are merged in order of decreasing pass clearance, as long as the pass is not a door:
   a pass separates two rooms when its clearance is below ``door_ratio`` times the smaller of
   the two rooms' largest clearances, and at most ``max_door_width / 2`` (a wider opening joins
   the two sides). A corridor's width wobbles a little (merged); a door is much narrower than
   the rooms on either side (kept);
4. rooms smaller than ``min_room_area`` join the neighbour they share the longest border with.

:func:`rooms_to_rois` turns the labels into SOMA ROIs (one polygon per room, in the map frame)
whose vertices follow the seed's chain rule (people/markov/adjacency.vertex_adjacency): rooms
that meet at a doorway share the vertices of the cut; rooms with only a wall between them lie
the wall's thickness plus twice the ROI clearance (0.15 m) apart. :func:`auto_rois` does both
from a FloorMap. See docs/rooms.md for the measured accuracy (bench/rooms_bench.py).
"""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np
import shapely
from scipy import ndimage as ndi
from shapely.affinity import affine_transform
from shapely.geometry import Polygon

from ..data.rois import Roi, save_rois, validate_roi
from ..nav.grid import largest_part
from ..roomconfig import RoomConfig
from ..sim.floormap import FloorMap
from ..sim.solidmap import MapHandling, solid_map

__all__ = ["BasinGraph", "RoomConfig", "auto_rois", "basin_graph", "rooms_from_basins",
           "rooms_to_rois", "segment_rooms", "write_rois"]

_EIGHT = np.ones((3, 3), dtype=bool)


def segment_rooms(free: np.ndarray, resolution: float,
                  config: RoomConfig = RoomConfig()) -> np.ndarray:
    """Label the rooms of a map's free space (see the module doc).

    Args:
        free: bool (rows, cols), True where the floor is free.
        resolution: metres per cell.
        config: the parameters.

    Returns:
        int32 (rows, cols): 0 on obstacles and on free islands too small to be a room, rooms
        1..n elsewhere (every free cell connected to a room has its room's label).
    """
    return rooms_from_basins(basin_graph(free, resolution, config), config)


@dataclass(frozen=True, eq=False)
class BasinGraph:
    """The watershed basins of a map's clearance and the passes between them: what
    :func:`segment_rooms` merges into rooms. It depends on ``furniture_area``,
    ``wall_length`` and ``seed_height`` only, so a parameter search can build it once for the
    other parameters.

    Attributes:
        free: bool (rows, cols), the free cells.
        resolution: metres per cell.
        basins: int32 (rows, cols), basin 1..n per floor cell (0 elsewhere).
        pairs: int (m, 2), neighbouring basins (a < b).
        passes: float (m,), clearance (m) of the widest pass between each pair.
        borders: float (m,), length of each pair's common border (touching cell pairs).
        peaks: float (n + 1,), the largest clearance (m) in each basin.
        areas: float (n + 1,), each basin's area (m²).
    """

    free: np.ndarray
    resolution: float
    basins: np.ndarray
    pairs: np.ndarray
    passes: np.ndarray
    borders: np.ndarray
    peaks: np.ndarray
    areas: np.ndarray


def basin_graph(free: np.ndarray, resolution: float,
                config: RoomConfig = RoomConfig()) -> BasinGraph:
    """Steps 1 and 2 of :func:`segment_rooms`: the basins and their passes."""
    free = np.asarray(free, dtype=bool)
    if free.ndim != 2:
        raise ValueError("free must be a 2-D array, got shape %s" % (free.shape,))
    if not resolution > 0.0:
        raise ValueError("resolution must be > 0 m, got %r" % (resolution,))
    cell_area = resolution * resolution
    floor = free | _furniture(~free, config.furniture_area / cell_area,
                               config.wall_length / resolution)
    clearance = _clearance(floor) * resolution
    basins = _basins(floor, clearance, config.seed_height)
    n = int(basins.max())
    pairs, passes, borders = _passes(basins, clearance)
    peaks = np.zeros(n + 1)
    if n:
        peaks[1:] = ndi.maximum(clearance, basins, np.arange(1, n + 1))
    areas = np.bincount(basins.ravel(), minlength=n + 1) * cell_area
    return BasinGraph(free, float(resolution), basins, pairs, passes, borders, peaks, areas)


def rooms_from_basins(graph: BasinGraph, config: RoomConfig = RoomConfig()) -> np.ndarray:
    """Steps 3 and 4 of :func:`segment_rooms`: merge the basins into rooms and label them."""
    n = len(graph.peaks) - 1
    if n == 0:
        return np.zeros(graph.free.shape, dtype=np.int32)
    parent = _merge_at_doors(n, graph.pairs, graph.passes, graph.peaks, config)
    parent = _merge_small(parent, graph.pairs, graph.borders, graph.areas, config.min_room_area)
    labels = _relabel(parent)[graph.basins]
    labels[~graph.free] = 0
    return _drop_islands(labels, config.min_room_area / graph.resolution ** 2)


# --------------------------------------------------------------------------------------------
# steps
# --------------------------------------------------------------------------------------------


def _furniture(solid: np.ndarray, max_cells: float, wall_cells: float) -> np.ndarray:
    """Obstacle blobs (8-connected) of at most max_cells cells that are not wall pieces (at
    least wall_cells long and four times longer than their mean width) and do not touch the
    edge of the grid."""
    from skimage.measure import regionprops

    blobs, n = ndi.label(solid, structure=_EIGHT)
    if n == 0 or max_cells <= 0:
        return np.zeros(solid.shape, dtype=bool)
    sizes = np.bincount(blobs.ravel(), minlength=n + 1)
    small = sizes <= max_cells
    small[0] = False
    # a blob on the edge of the grid continues outside it: never furniture
    edge = np.unique(np.concatenate([blobs[0], blobs[-1], blobs[:, 0], blobs[:, -1]]))
    small[edge] = False
    candidates = np.where(small[blobs], blobs, 0)
    for blob in regionprops(candidates):
        length = max(float(blob.major_axis_length), 1.0)
        if length >= wall_cells and length >= 4.0 * blob.area / length:
            small[blob.label] = False
    return small[blobs]


def _clearance(floor: np.ndarray) -> np.ndarray:
    """Distance in cells from each floor cell to the nearest non-floor cell (outside = wall)."""
    padded = np.pad(floor, 1, constant_values=False)
    return ndi.distance_transform_edt(padded)[1:-1, 1:-1]


def _basins(floor: np.ndarray, clearance: np.ndarray, height: float) -> np.ndarray:
    """Watershed basins of the negated clearance over the floor, one per h-maximum."""
    from skimage.morphology import h_maxima
    from skimage.segmentation import watershed

    peaks = h_maxima(clearance, max(height, 1e-6)).astype(bool) & floor
    markers, _ = ndi.label(peaks, structure=_EIGHT)
    return watershed(-clearance, markers, mask=floor, connectivity=2).astype(np.int32)


def _passes(basins: np.ndarray, clearance: np.ndarray
            ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Neighbouring basin pairs (a < b), the clearance of the widest pass between each pair
    (the largest min-clearance of two touching cells, one in each) and their border length
    (in touching cell pairs)."""
    keys, values = [], []
    n = int(basins.max()) + 1
    for a, b, ca, cb in _shifted(basins, clearance):
        touch = (a > 0) & (b > 0) & (a != b)
        la, lb = a[touch].astype(np.int64), b[touch].astype(np.int64)
        keys.append(np.minimum(la, lb) * n + np.maximum(la, lb))
        values.append(np.minimum(ca[touch], cb[touch]))
    key = np.concatenate(keys)
    value = np.concatenate(values)
    if key.size == 0:
        empty = np.zeros((0, 2), dtype=np.int64)
        return empty, np.zeros(0), np.zeros(0)
    uniq, inv = np.unique(key, return_inverse=True)
    passes = np.full(uniq.size, -np.inf)
    np.maximum.at(passes, inv, value)
    borders = np.bincount(inv).astype(float)
    pairs = np.stack([uniq // n, uniq % n], axis=1)
    return pairs, passes, borders


def _shifted(labels: np.ndarray, values: np.ndarray
             ) -> Iterator[Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """(labels, labels of the neighbour, values, values of the neighbour) for the four
    neighbour directions that cover every 8-neighbour pair once."""
    yield labels[:, :-1], labels[:, 1:], values[:, :-1], values[:, 1:]
    yield labels[:-1, :], labels[1:, :], values[:-1, :], values[1:, :]
    yield labels[:-1, :-1], labels[1:, 1:], values[:-1, :-1], values[1:, 1:]
    yield labels[:-1, 1:], labels[1:, :-1], values[:-1, 1:], values[1:, :-1]


def _find(parent: np.ndarray, k: int) -> int:
    root = k
    while parent[root] != root:
        root = parent[root]
    while parent[k] != root:
        parent[k], k = root, parent[k]
    return root


def _merge_at_doors(n: int, pairs: np.ndarray, passes: np.ndarray, peaks: np.ndarray,
                    config: RoomConfig) -> np.ndarray:
    """Union-find parents after merging every pass that is no door, widest pass first."""
    parent = np.arange(n + 1)
    peak = peaks.copy()
    wide = config.max_door_width / 2.0
    for k in np.argsort(-passes, kind="stable"):
        a, b = _find(parent, int(pairs[k, 0])), _find(parent, int(pairs[k, 1]))
        if a == b:
            continue
        if passes[k] >= wide or passes[k] >= config.door_ratio * min(peak[a], peak[b]):
            parent[b] = a
            peak[a] = max(peak[a], peak[b])
    return parent


def _merge_small(parent: np.ndarray, pairs: np.ndarray, borders: np.ndarray, areas: np.ndarray,
                 min_area: float) -> np.ndarray:
    """Merge rooms under min_area into the neighbour with the longest common border, the
    smallest room first, until none is left that has a neighbour."""
    roots = [_find(parent, k) for k in range(len(parent))]
    area: Dict[int, float] = {}
    for k in range(1, len(parent)):
        area[roots[k]] = area.get(roots[k], 0.0) + float(areas[k])
    adj: Dict[int, Dict[int, float]] = {r: {} for r in area}
    for (a, b), w in zip(pairs.tolist(), borders.tolist()):
        ra, rb = roots[a], roots[b]
        if ra != rb:
            adj[ra][rb] = adj[ra].get(rb, 0.0) + w
            adj[rb][ra] = adj[rb].get(ra, 0.0) + w
    heap = [(a, r) for r, a in area.items() if a < min_area]
    heapq.heapify(heap)
    while heap:
        a, r = heapq.heappop(heap)
        if parent[r] != r or area[r] != a or not adj[r]:
            continue  # merged away, grown since (queued again), or alone
        target = max(adj[r], key=lambda m: (adj[r][m], -m))
        parent[r] = target
        area[target] += a
        for m, w in adj.pop(r).items():
            del adj[m][r]
            if m != target:
                adj[target][m] = adj[target].get(m, 0.0) + w
                adj[m][target] = adj[m].get(target, 0.0) + w
        if area[target] < min_area:
            heapq.heappush(heap, (area[target], target))
    return parent


def _relabel(parent: np.ndarray) -> np.ndarray:
    """Lookup basin -> room label 1..n (0 stays 0), rooms numbered by first basin."""
    roots = np.array([_find(parent, k) for k in range(len(parent))])
    _, first, inv = np.unique(roots[1:], return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))
    lookup = np.zeros(len(parent), dtype=np.int32)
    lookup[1:] = order[inv] + 1
    return lookup


def _drop_islands(labels: np.ndarray, min_cells: float) -> np.ndarray:
    """Set rooms smaller than min_cells to 0 and number the rest 1..n consecutively."""
    sizes = np.bincount(labels.ravel())
    keep = sizes >= min_cells
    keep[0] = False
    lookup = np.zeros(sizes.size, dtype=np.int32)
    lookup[keep] = np.arange(1, int(keep.sum()) + 1, dtype=np.int32)
    return lookup[labels]


# --------------------------------------------------------------------------------------------
# ROIs
# --------------------------------------------------------------------------------------------


def rooms_to_rois(labels: np.ndarray, fmap: FloorMap, map_name: str, config: str = "1",
                  clearance: float = 0.15, simplify: float = 0.1,
                  corridor_elongation: float = 4.0) -> List[Roi]:
    """One SOMA ROI per room of ``labels``, in the map frame.

    A room's polygon is the union of its cells at least ``clearance`` from any cell outside
    every room (its largest 4-connected part, holes dropped), so a wall between two rooms
    leaves a gap of the wall's width plus twice the clearance between their polygons, while
    rooms that meet at a door cut (cells of both labels touching) keep the cut as a common
    edge. The polygons are simplified together (shapely.coverage_simplify), so a common edge
    keeps the same vertices in both: the seed's vertex rule (vertex_adjacency, 0.2 m) finds
    rooms joined by a door, and not rooms with only a wall between them.

    Args:
        labels: int (rows, cols) on ``fmap``'s grid (row 0 = bottom), 0 = no room, as from
            :func:`segment_rooms`.
        fmap: the map the labels were made on (resolution, origin).
        map_name, config: the ROIs' SOMA map and config.
        clearance: metres kept free between a polygon and the cells outside every room.
        simplify: metres, the simplification tolerance (about the largest deviation).
        corridor_elongation: a room whose area is at least this many times the square of its
            widest width (twice its largest clearance) is typed "corridor", the others "room".

    Returns:
        The ROIs with ids "1".."n" in label order (a room with no cell ``clearance`` from the
        walls gets none, and the ids stay consecutive). Each passes validate_roi.
    """
    labels = np.asarray(labels)
    if labels.shape != fmap.grid.shape:
        raise ValueError("labels have shape %s, the map's grid %s"
                         % (labels.shape, fmap.grid.shape))
    res = fmap.resolution
    inside = labels > 0
    dist = _clearance(inside) * res
    cells = np.where(dist - res >= clearance - 1e-9, labels, 0)  # cell edges clearance off
    rooms, polygons = _room_polygons(cells)
    if not polygons:
        return []
    simple = shapely.coverage_simplify(np.array(polygons, dtype=object), simplify / res)
    c, s = math.cos(fmap.origin[2]), math.sin(fmap.origin[2])
    matrix = [c * res, -s * res, s * res, c * res, fmap.origin[0], fmap.origin[1]]
    rois: List[Roi] = []
    for room, poly in zip(rooms, simple):
        shell = _largest(poly)
        if shell is None:
            continue
        world = affine_transform(Polygon(shell.exterior), matrix)
        vertices = [(round(float(x), 4), round(float(y), 4)) for x, y in world.exterior.coords[:-1]]
        widest = 2.0 * float(dist[labels == room].max())
        elongated = world.area >= corridor_elongation * widest * widest
        roi = Roi(id=str(len(rois) + 1), config=config, type="corridor" if elongated else "room",
                  map_name=map_name, vertices=vertices)
        validate_roi(roi)
        rois.append(roi)
    return rois


def auto_rois(fmap: FloorMap, handling: MapHandling = MapHandling(), map_name: str = "",
              config: str = "1", rooms: RoomConfig = RoomConfig(),
              clearance: float = 0.15) -> List[Roi]:
    """The rooms of a map as ROIs: free = not solid in solid_map(fmap, handling) (what the
    simulator treats as floor), :func:`segment_rooms`, then :func:`rooms_to_rois`.

    Args:
        fmap: the map.
        handling: the world's map handling.
        map_name: the ROIs' map name (the map file's stem when "").
        config: the ROIs' SOMA config.
        rooms: the segmentation parameters.
        clearance: see :func:`rooms_to_rois`.
    """
    import os

    if not map_name:
        map_name = os.path.splitext(os.path.basename(fmap.yaml_path))[0] or "map"
    free = np.asarray(solid_map(fmap, handling).fmap.grid) != 100
    labels = segment_rooms(free, fmap.resolution, rooms)
    return rooms_to_rois(labels, fmap, map_name, config, clearance)


def write_rois(rois: Sequence[Roi], path: str) -> None:
    """Write ROIs as a rois.yaml (the format of worlds/*/rois.yaml, data/rois.save_rois)."""
    save_rois(rois, path)


def _room_polygons(cells: np.ndarray) -> Tuple[List[int], List[Polygon]]:
    """Per label of ``cells``, the union of the cell squares of its largest 4-connected part
    (in cell units: cell (col, row) is the square [col, col+1] x [row, row+1]), with every
    vertex of a neighbouring polygon that lies on its boundary inserted (an edge-matched
    coverage, as coverage_simplify needs)."""
    rooms: List[int] = []
    polygons: List[Polygon] = []
    slices = ndi.find_objects(cells)
    for k, sl in enumerate(slices):
        if sl is None:
            continue
        part = largest_part(cells[sl] == k + 1)
        rows, c0, c1 = _runs(part)
        boxes = shapely.box(c0 + sl[1].start, rows + sl[0].start, c1 + sl[1].start,
                            rows + 1 + sl[0].start)
        union = shapely.union_all(boxes)
        shell = _largest(union)
        if shell is not None:
            rooms.append(k + 1)
            polygons.append(shell)
    return rooms, _edge_match(polygons)


def _runs(mask: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Horizontal runs of True cells: (row, first col, end col) arrays."""
    padded = np.pad(mask, ((0, 0), (1, 1)), constant_values=False).astype(np.int8)
    step = np.diff(padded, axis=1)
    rows, first = np.nonzero(step == 1)  # row-major order: the k-th start and end pair up
    _, end = np.nonzero(step == -1)
    return rows, first, end


def _largest(geom: shapely.Geometry) -> Optional[Polygon]:
    """The largest polygon of a (multi)polygon, None when empty."""
    if geom is None or geom.is_empty:
        return None
    parts = list(geom.geoms) if hasattr(geom, "geoms") else [geom]
    parts = [p for p in parts if isinstance(p, Polygon) and p.area > 0]
    return max(parts, key=lambda p: p.area) if parts else None


def _edge_match(polygons: List[Polygon]) -> List[Polygon]:
    """Insert into each polygon the vertices of the others that lie on its boundary."""
    if len(polygons) < 2:
        return polygons
    tree = shapely.STRtree(polygons)
    out = []
    for k, poly in enumerate(polygons):
        others = [polygons[m] for m in tree.query(poly, predicate="touches").tolist() if m != k]
        if others:
            points = shapely.multipoints(np.concatenate(
                [shapely.get_coordinates(shapely.boundary(o)) for o in others]))
            poly = shapely.snap(poly, points, 1e-6)
        out.append(poly)
    return out
