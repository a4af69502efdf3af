"""What the simulated building is made of: the solid cells of a SLAM-built map.

A map made with gmapping or slam_toolbox has three kinds of cell: occupied (walls, furniture),
free, and unknown (never seen: outside the building, behind furniture, beyond a window). Its
walls are a cell or two thick and have one-cell gaps where a beam slipped through during
mapping; ray fans of "free" cells reach out through windows and open doors into unknown space.
:func:`solid_map` decides which cells the simulator extrudes into walls, so that no beam and no
robot leaves the building through such a gap:

* ``unknown: wall`` (the default): unknown areas are solid. What the robot never saw is
  outside the building or inside furniture; treating it as wall keeps every beam and robot
  inside, as the map's own free space says. Unknown *slivers* are the exception: unknown
  cells in parts no wider than ``clean.unknown_slivers`` (metres, default 0.3; a
  morphological opening of the unknown mask) where at least half of the surrounding 0.6 m is
  free are floor: the unseen strips between a laser's diverging rays across an open hall, not
  walls. (Ray fans out through a window are as much unseen as seen, and stay solid.)
  ``unknown: free``: every unknown cell is empty (for maps whose unknown cells are known to
  be open floor).
* ``close_gaps`` (metres, default 0.15): slits in the solid cells up to this wide are closed
  (a morphological closing of the solid mask by a square of that size). Nothing a person or
  a robot passes is that narrow, so only beams are stopped: one-cell gaps in walls, and the
  one- or two-cell "free" rays a laser left in unknown space.
* ``speckle`` (square metres, default 0.005: two cells of 0.05 m): occupied blobs
  (8-connected) of at most this area that touch no other solid cell are removed. A blob in
  a SLAM map is as often a table leg as a person who walked by during mapping; larger
  values are for cluttered maps whose specks cut the floor (``check_world`` names them).

The speckle default was chosen on the corpus of real buildings by leaving each out in turn
(bench/choose_map_handling.py, docs/evaluation.md): one- and two-cell specks split orebro's
floor in two for the robot's footprint. The same folds prefer no closing of slits (the
simulated lidar then reads 1.3 % more of the logged beams as the real one did), but with 0
the observer tracked the walker 9 % of a study on acapulco_convention (92 % with 0.15 m), so
close_gaps stays 0.15. On the study's score every fold keeps 0.15 m against 0.3 m
(docs/evaluation.md, session 83).

Everything it changes is counted in :attr:`SolidMap.report` (the simulator logs it); the
user's map file is never rewritten, and map_server still serves it as it is. The solid cells,
their distance field and the wall rectangles are kept on disk (sim/mapcache.py), so a big map
costs its second of derivation once.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from ..errors import ConfigError
from .floormap import FloorMap
from .mapcache import load_entry, map_cache_dir, map_key, store_entry

__all__ = ["MapHandling", "SolidMap", "solid_map", "cleaned_map", "served_handling", "UNKNOWN_MODES",
           "while_mapping"]

UNKNOWN_MODES = ("wall", "free")
_SLIVER_WINDOW = 0.6  # metres: the neighbourhood whose free share tells floor from a ray fan


@dataclass(frozen=True)
class MapHandling:
    """How a world treats its map (the world.yaml keys ``unknown`` and ``clean``)."""

    unknown: str = "wall"
    close_gaps: float = 0.15
    speckle: float = 0.005
    unknown_slivers: float = 0.3

    def check(self, where: str = "map handling") -> None:
        """Raise ConfigError naming ``where`` and the first bad value."""
        if self.unknown not in UNKNOWN_MODES:
            raise ConfigError("%s: unknown must be one of %s, got %r"
                              % (where, " | ".join(UNKNOWN_MODES), self.unknown))
        for key, what in (("close_gaps", "metres"), ("speckle", "square metres"),
                          ("unknown_slivers", "metres")):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool)
                    and math.isfinite(v) and v >= 0):
                raise ConfigError("%s: clean.%s must be a number of %s >= 0, got %r"
                                  % (where, key, what, v))


_COUNTS = ("unknown_solid", "sliver_cells", "gap_cells", "speckle_cells", "speckle_blobs")


@dataclass
class SolidMap:
    """The solid cells, as a FloorMap (100 solid, 0 empty) on the user's grid, what was
    changed to get them, and ``distance``: float32 (rows, cols), the distance in cells from
    each cell centre to the nearest solid cell centre (inf everywhere on a map with none)."""

    fmap: FloorMap
    unknown_solid: int = 0
    sliver_cells: int = 0
    gap_cells: int = 0
    speckle_cells: int = 0
    speckle_blobs: int = 0
    report: List[str] = field(default_factory=list)
    distance: Optional[np.ndarray] = field(default=None, repr=False)


def solid_map(fmap: FloorMap, handling: MapHandling = MapHandling()) -> SolidMap:
    """The cells the simulator makes solid (see the module docstring).

    Args:
        fmap: the user's map, as map_server reads it.
        handling: unknown mode and cleaning.

    Returns:
        The SolidMap; its ``report`` has one line per change (empty when nothing changed).
        It is computed once per map and handling (the world, its planner and its tracker all
        ask) and shared: read it, do not change it.
    """
    key = ("solid_map", handling)
    cached = fmap._derived.get(key)
    if cached is None:
        disk = map_key(fmap.grid, fmap.resolution, fmap.origin, handling)
        cached = _from_entry(fmap, load_entry(disk))
        if cached is None:
            cached = _solid_map(fmap, handling)
            _store(disk, cached)
        fmap._derived[key] = cached
    return cached


def while_mapping(handling: Optional[MapHandling] = None) -> MapHandling:
    """The handling of a map being built: its unknown space is free (to explore) and no
    speck is dropped (a wall seen once or twice is a speck: dropped, the planner drove the
    robot into it; explore.test mapped 47 % of office with speckle 0.005)."""
    return dataclasses.replace(handling or MapHandling(), unknown="free", speckle=0.0)


def cleaned_map(fmap: FloorMap, handling: MapHandling = MapHandling()) -> FloorMap:
    """The user's map with the handling's changes made, for map_server, amcl and move_base:
    removed speckle and unknown slivers become free (0), closed gaps occupied (100); unknown
    cells that stay solid stay unknown (-1), as the map had them. A node that applies
    :func:`served_handling` to it gets the same solid cells back. (Not the whole handling
    again: on a real map the cleaning rules, applied to their own output, clear a little more,
    254 cells of malaga_corridor's 645546 solid ones.)"""
    grid = np.asarray(fmap.grid)
    solid = np.asarray(solid_map(fmap, handling).fmap.grid) == 100
    out = grid.copy()
    out[(grid != 0) & ~solid] = 0
    out[(grid == 0) & solid] = 100
    return FloorMap(grid=out.astype(np.int8), resolution=fmap.resolution, origin=fmap.origin,
                    yaml_path=fmap.yaml_path, image_path=fmap.image_path, negate=fmap.negate,
                    occupied_thresh=fmap.occupied_thresh, free_thresh=fmap.free_thresh,
                    mode=fmap.mode)


def served_handling(handling: MapHandling) -> MapHandling:
    """The handling a node applies to :func:`cleaned_map`'s output to get the solid cells of
    ``handling`` applied to the map itself: the cleaning already done, only ``unknown``."""
    return dataclasses.replace(handling, close_gaps=0.0, speckle=0.0, unknown_slivers=0.0)


def _distance(solid: np.ndarray) -> np.ndarray:
    from scipy.ndimage import distance_transform_edt

    if not solid.any():
        return np.full(solid.shape, np.inf, dtype=np.float32)
    return distance_transform_edt(~solid).astype(np.float32)


def _solid_fmap(fmap: FloorMap, solid: np.ndarray) -> FloorMap:
    return FloorMap(grid=np.where(solid, 100, 0).astype(np.int8), resolution=fmap.resolution,
                    origin=fmap.origin, yaml_path=fmap.yaml_path, image_path=fmap.image_path,
                    negate=fmap.negate, occupied_thresh=fmap.occupied_thresh,
                    free_thresh=fmap.free_thresh, mode=fmap.mode)


def _store(key: str, sm: SolidMap) -> None:
    """Keep what took long on disk: the solid cells, distances and wall rectangles (these
    are only worked out here when there is a cache to keep them in)."""
    if not map_cache_dir():
        return
    assert sm.distance is not None   # _solid_map fills it in
    rects = np.array(sm.fmap.rectangles(), dtype=np.int32).reshape(-1, 4)
    meta = {name: getattr(sm, name) for name in _COUNTS}
    meta["report"] = list(sm.report)
    store_entry(key, {"solid": np.packbits(sm.fmap.occupied), "distance": sm.distance,
                      "rects": rects}, meta)


def _from_entry(fmap: FloorMap, entry) -> Optional[SolidMap]:
    """The SolidMap of a cache entry; None when there is none or it does not fit the map."""
    if entry is None:
        return None
    try:
        n = fmap.grid.size
        solid = np.unpackbits(entry["solid"], count=n).astype(bool).reshape(fmap.grid.shape)
        distance = entry["distance"]
        if distance.shape != fmap.grid.shape or entry["rects"].ndim != 2:
            return None
        out = SolidMap(fmap=_solid_fmap(fmap, solid), distance=distance,
                       report=[str(line) for line in entry["meta"]["report"]],
                       **{name: int(entry["meta"][name]) for name in _COUNTS})
    except (KeyError, ValueError, TypeError):
        return None
    # the rows are (col0, row0, col1, row1), as _store wrote them; mypy cannot know a row's length
    out.fmap._rects.extend(tuple(int(v) for v in r) for r in entry["rects"])  # type: ignore[misc]
    return out


def _solid_map(fmap: FloorMap, handling: MapHandling) -> SolidMap:
    grid = fmap.grid
    occupied = grid == 100
    unknown = grid < 0
    res = fmap.resolution
    out = SolidMap(fmap=fmap)
    solid = occupied.copy()
    if handling.unknown == "wall" and unknown.any():
        walls = _without_slivers(unknown, grid == 0, res, handling.unknown_slivers)
        out.unknown_solid = int(walls.sum())
        out.sliver_cells = int(unknown.sum()) - out.unknown_solid
        out.report.append("%d unknown cells (%.0f m2) are solid (unknown: wall)"
                          % (out.unknown_solid, out.unknown_solid * res * res))
        if out.sliver_cells:
            out.report.append("%d unknown cells in slivers up to %.2f m wide are floor "
                              "(clean.unknown_slivers)" % (out.sliver_cells,
                                                           handling.unknown_slivers))
        solid |= walls
    if handling.speckle > 0:
        solid = _drop_speckle(solid, occupied, handling.speckle, res, out)
    k = int(math.floor(handling.close_gaps / res + 1e-9))
    if k >= 1 and solid.any():
        # a square of k + 1 cells closes every slit up to k cells wide; the grid is padded
        # with solid cells so that the closing does not eat the border
        pad = k + 1
        closed = _close(np.pad(solid, pad, constant_values=True), k + 1)[pad:-pad, pad:-pad]
        added = closed & ~solid
        out.gap_cells = int(added.sum())
        if out.gap_cells:
            out.report.append("%d cells of gaps up to %.2f m closed (clean.close_gaps)"
                              % (out.gap_cells, handling.close_gaps))
        solid = closed
    out.fmap = _solid_fmap(fmap, solid)
    out.distance = _distance(solid)
    return out


def _square_origin(n: int) -> int:
    # a square of even size is not centred: the second pass takes the reflected square, as
    # morphology's opening and closing do (checked against scipy.ndimage.binary_opening/closing)
    return -1 if n % 2 == 0 else 0


def _close(mask: np.ndarray, n: int) -> np.ndarray:
    """Morphological closing by an n x n square (separable max then min filters: 2-3x
    faster than binary_closing on a large map)."""
    from scipy import ndimage

    grown = ndimage.maximum_filter(mask.view(np.uint8), size=n)
    return ndimage.minimum_filter(grown, size=n, origin=_square_origin(n)).astype(bool)


def _open(mask: np.ndarray, n: int) -> np.ndarray:
    """Morphological opening by an n x n square (min then max filters)."""
    from scipy import ndimage

    shrunk = ndimage.minimum_filter(mask.view(np.uint8), size=n)
    return ndimage.maximum_filter(shrunk, size=n, origin=_square_origin(n)).astype(bool)


def _without_slivers(unknown: np.ndarray, free: np.ndarray, res: float,
                     width: float) -> np.ndarray:
    """``unknown`` less its slivers: parts no wider than ``width`` (an opening by a square of
    that size) in places that the map mostly saw as floor (at least half the cells within
    ``_SLIVER_WINDOW`` m are free). The second test keeps the ray fans a laser leaves through a
    window or an open door solid: there the unseen strips are as wide as the rays."""
    from scipy import ndimage

    k = int(math.floor(width / res + 1e-9))
    if k < 1:
        return unknown.copy()
    pad = k + 1
    opened = _open(np.pad(unknown, pad, mode="edge"), k + 1)
    sliver = unknown & ~opened[pad:-pad, pad:-pad]
    n = max(3, 2 * int(round(_SLIVER_WINDOW / (2.0 * res))) + 1)
    seen_free = ndimage.uniform_filter(free.astype(np.float32), size=n, mode="constant")
    return unknown & ~(sliver & (seen_free >= 0.5))


def _drop_speckle(solid: np.ndarray, occupied: np.ndarray, area: float, res: float,
                  out: SolidMap) -> np.ndarray:
    """Remove occupied blobs of at most ``area`` m2 that touch no other solid cell."""
    from scipy import ndimage

    labels, n = ndimage.label(solid, structure=np.ones((3, 3), dtype=bool))
    if n == 0:
        return solid
    sizes = np.bincount(labels.ravel())
    small = sizes * res * res <= area + 1e-12
    small[0] = False
    # a blob qualifies only when every cell of it is occupied (none unknown)
    has_unknown = np.bincount(labels[solid & ~occupied].ravel(), minlength=n + 1) > 0
    drop = small & ~has_unknown
    mask = drop[labels]
    out.speckle_blobs = int(drop.sum())
    out.speckle_cells = int(mask.sum())
    if out.speckle_cells:
        out.report.append("%d occupied blobs (%d cells) of at most %g m2 removed "
                          "(clean.speckle)" % (out.speckle_blobs, out.speckle_cells, area))
    return solid & ~mask
