"""map_server floor maps: YAML + image -> occupancy grid -> merged wall rectangles -> mesh.

The YAML and the image are read exactly as ROS 1 map_server (noetic) reads them, so the grid
here is the very grid that map_server publishes and amcl localises against:

* required keys ``image``, ``resolution``, ``origin`` ([x, y, yaw]), ``negate``,
  ``occupied_thresh``, ``free_thresh``; optional ``mode`` (trinary | scale | raw, default
  trinary); a relative ``image`` path is relative to the YAML file;
* per pixel, the mean of the colour channels (alpha excluded in scale/raw mode when the image
  has one), ``occ = (255 - mean) / 255`` (``mean / 255`` when negated); ``occ >
  occupied_thresh`` -> 100, ``occ < free_thresh`` -> 0, else -1 (trinary) or scaled 1..99;
* image row 0 is the top of the map; grid row 0 is the bottom (``cell (0, 0)`` at ``origin``).

Walls are the cells whose value is 100; unknown (-1) cells are not walls.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..errors import MapError
from .checks import is_number as _is_number
from ..yamlio import read_yaml

__all__ = [
    "FloorMap",
    "crop_known",
    "load_map",
    "map_from_grid",
    "merge_rectangles",
    "outline_segments",
    "wall_mesh",
    "wall_outline_mesh",
]

_REQUIRED = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")
_OPTIONAL = ("mode",)
_MODES = ("trinary", "scale", "raw")


@dataclass(frozen=True, eq=False)
class FloorMap:
    """An occupancy grid as map_server publishes it.

    Attributes:
        grid: int8 array (height, width); row 0 is the bottom row, values -1/0..100.
        resolution: metres per cell.
        origin: (x, y, yaw) of the lower-left corner of cell (0, 0) in the map frame.
        yaml_path: the map.yaml it came from ("" when built in memory).
        image_path: the image it came from.
        negate, occupied_thresh, free_thresh, mode: the YAML settings used.
    """

    grid: np.ndarray
    resolution: float
    origin: Tuple[float, float, float]
    yaml_path: str = ""
    image_path: str = ""
    negate: bool = False
    occupied_thresh: float = 0.65
    free_thresh: float = 0.196
    mode: str = "trinary"
    _rects: List[Tuple[int, int, int, int]] = field(default_factory=list, repr=False, compare=False)
    # derived grids kept with the map (sim/solidmap.py keeps its answer per handling here)
    _derived: Dict[Any, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def width(self) -> int:
        """Number of cells along x."""
        return int(self.grid.shape[1])

    @property
    def height(self) -> int:
        """Number of cells along y."""
        return int(self.grid.shape[0])

    @property
    def occupied(self) -> np.ndarray:
        """Boolean (height, width) mask of wall cells (value 100)."""
        return self.grid == 100

    def cell_to_world(self, col: Union[float, np.ndarray],
                      row: Union[float, np.ndarray]) -> Tuple[np.ndarray, np.ndarray]:
        """Map-frame coordinates of cell centres (arrays or scalars)."""
        u = (np.asarray(col, dtype=float) + 0.5) * self.resolution
        v = (np.asarray(row, dtype=float) + 0.5) * self.resolution
        return self._grid_to_world(u, v)

    def world_to_cell(self, x: Union[float, np.ndarray],
                      y: Union[float, np.ndarray]) -> Tuple[np.ndarray, np.ndarray]:
        """Integer (col, row) of the cells containing map-frame points (may be out of range)."""
        ox, oy, yaw = self.origin
        dx = np.asarray(x, dtype=float) - ox
        dy = np.asarray(y, dtype=float) - oy
        c, s = math.cos(yaw), math.sin(yaw)
        u = c * dx + s * dy
        v = -s * dx + c * dy
        return (np.floor(u / self.resolution).astype(int), np.floor(v / self.resolution).astype(int))

    def value_at(self, x: float, y: float) -> int:
        """Grid value at a map-frame point; -1 outside the grid (unknown)."""
        cells = self.world_to_cell(x, y)
        col, row = int(cells[0]), int(cells[1])
        if 0 <= col < self.width and 0 <= row < self.height:
            return int(self.grid[row, col])
        return -1

    def bounds(self) -> Tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the whole grid in the map frame."""
        u = np.array([0.0, self.width, self.width, 0.0]) * self.resolution
        v = np.array([0.0, 0.0, self.height, self.height]) * self.resolution
        x, y = self._grid_to_world(u, v)
        return (float(x.min()), float(y.min()), float(x.max()), float(y.max()))

    def rectangles(self) -> List[Tuple[int, int, int, int]]:
        """Wall cells merged into rectangles (col0, row0, col1, row1), half-open; cached."""
        if not self._rects:
            self._rects.extend(merge_rectangles(self.occupied))
        return self._rects

    def _grid_to_world(self, u: np.ndarray, v: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        ox, oy, yaw = self.origin
        c, s = math.cos(yaw), math.sin(yaw)
        return (ox + c * u - s * v, oy + s * u + c * v)


def load_map(yaml_path: str) -> FloorMap:
    """Load a map_server map.yaml and its image exactly as map_server does.

    Args:
        yaml_path: path of the map.yaml.

    Returns:
        The FloorMap.

    Raises:
        MapError: the YAML or the image is missing, malformed or inconsistent; the message
            names the file and the problem.
    """
    meta = _read_yaml(yaml_path)
    res = meta["resolution"]
    origin = meta["origin"]
    image_path = meta["image"]
    if not os.path.isabs(image_path):
        image_path = os.path.join(os.path.dirname(os.path.abspath(yaml_path)), image_path)
    pixels, has_alpha = _read_image(yaml_path, image_path)
    grid = _threshold(pixels, has_alpha, meta["negate"], meta["occupied_thresh"],
                      meta["free_thresh"], meta["mode"])
    return FloorMap(grid=grid, resolution=res, origin=origin, yaml_path=os.path.abspath(yaml_path),
                    image_path=image_path, negate=meta["negate"],
                    occupied_thresh=meta["occupied_thresh"], free_thresh=meta["free_thresh"],
                    mode=meta["mode"])


def map_from_grid(grid: np.ndarray, resolution: float,
                  origin: Sequence[float] = (0.0, 0.0, 0.0)) -> FloorMap:
    """Build a FloorMap from an in-memory grid (row 0 = bottom), e.g. for tests and tools."""
    grid = np.asarray(grid, dtype=np.int8)
    if grid.ndim != 2 or grid.size == 0:
        raise MapError("<grid>: grid must be a non-empty 2-D array, got shape %s" % (grid.shape,))
    ox, oy, yaw = (float(v) for v in origin)
    return FloorMap(grid=grid, resolution=float(resolution), origin=(ox, oy, yaw))


def crop_known(fmap: FloorMap, margin: float) -> FloorMap:
    """The part of ``fmap`` around its known cells (free or occupied), ``margin`` metres wider
    on each side (within the map): what a SLAM node's fixed-size map being built amounts to
    (gmapping's is 200 m square by default). ``fmap`` itself when nothing is cut off or
    nothing is known."""
    grid = np.asarray(fmap.grid)
    known = grid >= 0
    if not known.any():
        return fmap
    rows, cols = np.nonzero(known.any(axis=1))[0], np.nonzero(known.any(axis=0))[0]
    k = int(math.ceil(margin / fmap.resolution))
    r0, r1 = max(0, int(rows[0]) - k), min(fmap.height, int(rows[-1]) + k + 1)
    c0, c1 = max(0, int(cols[0]) - k), min(fmap.width, int(cols[-1]) + k + 1)
    if (r0, c0, r1, c1) == (0, 0, fmap.height, fmap.width):
        return fmap
    x, y = fmap._grid_to_world(np.asarray(c0 * fmap.resolution),
                               np.asarray(r0 * fmap.resolution))
    return map_from_grid(grid[r0:r1, c0:c1], fmap.resolution,
                         (float(x), float(y), fmap.origin[2]))


def _read_yaml(path: str) -> Dict[str, Any]:
    doc = read_yaml(path, "map", MapError)
    if not isinstance(doc, dict):
        raise MapError("%s: expected a mapping of map_server keys, got %s"
                       % (path, type(doc).__name__))
    missing = [k for k in _REQUIRED if k not in doc]
    if missing:
        raise MapError("%s: missing required key(s): %s" % (path, ", ".join(missing)))
    unknown = sorted(k for k in doc if k not in _REQUIRED + _OPTIONAL)
    if unknown:
        raise MapError("%s: unknown key(s): %s" % (path, ", ".join(map(str, unknown))))

    res = doc["resolution"]
    if isinstance(res, (list, tuple)):
        if len(res) == 2 and all(_is_number(r) for r in res) and float(res[0]) != float(res[1]):
            raise MapError("%s: non-square pixels (resolution %s): map_server needs one "
                           "resolution for x and y" % (path, list(res)))
        raise MapError("%s: resolution must be a single positive number, got %r" % (path, res))
    if not _is_number(res) or not math.isfinite(float(res)) or float(res) <= 0.0:
        raise MapError("%s: resolution must be a positive number of metres per pixel, got %r"
                       % (path, res))
    origin = doc["origin"]
    if (not isinstance(origin, (list, tuple)) or len(origin) != 3
            or not all(_is_number(v) and math.isfinite(float(v)) for v in origin)):
        raise MapError("%s: origin must be [x, y, yaw] (3 finite numbers), got %r" % (path, origin))
    for key in ("occupied_thresh", "free_thresh"):
        v = doc[key]
        if not _is_number(v) or not 0.0 <= float(v) <= 1.0:
            raise MapError("%s: %s must be a number in [0, 1], got %r" % (path, key, v))
    if float(doc["free_thresh"]) > float(doc["occupied_thresh"]):
        raise MapError("%s: free_thresh (%s) is above occupied_thresh (%s)"
                       % (path, doc["free_thresh"], doc["occupied_thresh"]))
    negate = doc["negate"]
    if negate not in (0, 1, True, False):
        raise MapError("%s: negate must be 0 or 1, got %r" % (path, negate))
    mode = doc.get("mode", "trinary")
    if mode not in _MODES:
        raise MapError("%s: mode must be one of %s, got %r" % (path, "/".join(_MODES), mode))
    image = doc["image"]
    if not isinstance(image, str) or not image.strip():
        raise MapError("%s: image must be a file name, got %r" % (path, image))
    return {
        "image": image,
        "resolution": float(res),
        "origin": tuple(float(v) for v in origin),
        "negate": bool(negate),
        "occupied_thresh": float(doc["occupied_thresh"]),
        "free_thresh": float(doc["free_thresh"]),
        "mode": mode,
    }


def _read_image(yaml_path: str, image_path: str) -> Tuple[np.ndarray, bool]:
    """Pixels as uint8 (rows, cols, channels), top row first, and whether there is alpha."""
    from PIL import Image, UnidentifiedImageError  # local: only map loading needs Pillow

    if not os.path.isfile(image_path):
        raise MapError("%s: image file not found: %s" % (yaml_path, image_path))
    try:
        with Image.open(image_path) as img:
            img.load()
            mode = img.mode
            if mode in ("1", "P"):
                img = img.convert("RGBA" if "transparency" in img.info else "L")
            elif mode in ("I", "I;16", "I;16B", "F"):
                raise MapError("%s: image %s has %s pixels; map_server maps are 8-bit"
                               % (yaml_path, image_path, mode))
            elif mode not in ("L", "LA", "RGB", "RGBA"):
                img = img.convert("RGB")
            arr = np.asarray(img, dtype=np.uint8)
            has_alpha = img.mode in ("LA", "RGBA")
    except MapError:
        raise
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as e:
        raise MapError("%s: image %s is not a readable image (%s)"
                       % (yaml_path, image_path, str(e).splitlines()[0] if str(e) else
                          type(e).__name__)) from None
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise MapError("%s: image %s is empty" % (yaml_path, image_path))
    return arr, has_alpha


def _threshold(pixels: np.ndarray, has_alpha: bool, negate: bool, occ_th: float,
               free_th: float, mode: str) -> np.ndarray:
    """map_server's per-pixel rule, vectorised; returns the grid with row 0 at the bottom."""
    n_channels = pixels.shape[2]
    avg_channels = n_channels - 1 if (has_alpha and mode != "trinary") else n_channels
    color_avg = pixels[:, :, :avg_channels].astype(np.float64).sum(axis=2) / avg_channels
    alpha = pixels[:, :, -1].astype(np.float64) if has_alpha else np.full(color_avg.shape, 255.0)
    if negate:
        color_avg = 255.0 - color_avg
    if mode == "raw":
        grid = color_avg.astype(np.int64).astype(np.uint8).view(np.int8)
        return np.ascontiguousarray(grid[::-1])
    occ = (255.0 - color_avg) / 255.0
    grid = np.full(occ.shape, -1, dtype=np.int8)
    grid[occ > occ_th] = 100
    grid[occ < free_th] = 0
    if mode == "scale":
        mid = (occ <= occ_th) & (occ >= free_th) & (alpha >= 1.0)
        # (equal thresholds: the cells exactly at them get 1, where map_server divides by 0)
        ratio = ((occ[mid] - free_th) / (occ_th - free_th) if occ_th > free_th
                 else np.zeros(int(np.count_nonzero(mid))))
        grid[mid] = (1 + 98 * ratio).astype(np.int8)
    return np.ascontiguousarray(grid[::-1])


def merge_rectangles(mask: np.ndarray) -> List[Tuple[int, int, int, int]]:
    """Cover the True cells of a 2-D mask with disjoint rectangles, greedily maximal.

    Scanning rows from the first, each uncovered run of True cells is taken as wide as it
    goes, then grown row by row while the whole run stays True and uncovered.

    Args:
        mask: boolean (rows, cols).

    Returns:
        Rectangles (col0, row0, col1, row1), half-open, in scan order; together they cover
        every True cell exactly once.
    """
    free = np.array(mask, dtype=bool, copy=True)
    rows, cols = free.shape
    rects: List[Tuple[int, int, int, int]] = []
    for r in range(rows):
        row = free[r]
        if not row.any():
            continue
        padded = np.concatenate(([False], row, [False]))
        edges = np.flatnonzero(padded[1:] != padded[:-1])
        for c0, c1 in zip(edges[0::2], edges[1::2]):
            r1 = r + 1
            while r1 < rows and free[r1, c0:c1].all():
                r1 += 1
            free[r:r1, c0:c1] = False
            rects.append((int(c0), int(r), int(c1), int(r1)))
    return rects


# Two triangles per face, counter-clockwise seen from outside, for a box whose corners are
# numbered 0-3 bottom (ccw from lower-left) and 4-7 top. The bottom face is left out: walls
# stand on the floor and nothing looks at them from below.
_BOX_FACES = np.array([
    [4, 5, 6], [4, 6, 7],            # top
    [0, 1, 5], [0, 5, 4],            # -y side
    [1, 2, 6], [1, 6, 5],            # +x side
    [2, 3, 7], [2, 7, 6],            # +y side
    [3, 0, 4], [3, 4, 7],            # -x side
], dtype=np.int32)


def wall_mesh(fmap: FloorMap, height: float,
              rects: Optional[List[Tuple[int, int, int, int]]] = None
              ) -> Tuple[np.ndarray, np.ndarray]:
    """One triangle mesh of all wall rectangles extruded from z=0 to ``height``.

    Args:
        fmap: the floor map.
        height: wall height in metres (> 0).
        rects: rectangles to use instead of ``fmap.rectangles()``.

    Returns:
        (vertices float64 (8K, 3), indices int32 (30K,)) in the map frame.

    Raises:
        MapError: height is not a positive finite number.
    """
    if not (isinstance(height, (int, float)) and math.isfinite(height) and height > 0):
        raise MapError("%s: wall height must be a positive number of metres, got %r"
                       % (fmap.yaml_path or "<grid>", height))
    rects = fmap.rectangles() if rects is None else rects
    if not rects:
        return np.zeros((0, 3)), np.zeros((0,), dtype=np.int32)
    r = np.asarray(rects, dtype=float) * fmap.resolution
    u = np.stack([r[:, 0], r[:, 2], r[:, 2], r[:, 0]], axis=1)   # (K, 4) ccw
    v = np.stack([r[:, 1], r[:, 1], r[:, 3], r[:, 3]], axis=1)
    x, y = fmap._grid_to_world(u, v)
    k = len(rects)
    verts = np.zeros((k, 8, 3))
    verts[:, :4, 0] = x
    verts[:, :4, 1] = y
    verts[:, 4:, 0] = x
    verts[:, 4:, 1] = y
    verts[:, 4:, 2] = float(height)
    faces = _BOX_FACES[None, :, :] + (8 * np.arange(k, dtype=np.int32))[:, None, None]
    return verts.reshape(-1, 3), faces.reshape(-1).astype(np.int32)


def _runs(lines: np.ndarray) -> List[Tuple[int, int, int]]:
    """(line, start, end) of every run of True cells along each row of ``lines``, half-open."""
    padded = np.zeros((lines.shape[0], lines.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = lines
    steps = np.diff(padded, axis=1)
    out = []  # type: List[Tuple[int, int, int]]
    for line in np.flatnonzero(lines.any(axis=1)):
        edges = np.flatnonzero(steps[line])
        out.extend((int(line), int(a), int(b)) for a, b in zip(edges[0::2], edges[1::2]))
    return out


def outline_segments(mask: np.ndarray) -> np.ndarray:
    """The boundary between the True cells of a 2-D mask and the rest, cells beyond the
    mask counting as False, as maximal axis-aligned segments.

    Returns:
        int array (K, 4) of (col0, row0, col1, row1) in cell-corner coordinates: row segments
        (row0 == row1) first, then column segments.
    """
    m = np.asarray(mask, dtype=bool)
    padded = np.zeros((m.shape[0] + 2, m.shape[1] + 2), dtype=bool)
    padded[1:-1, 1:-1] = m
    across_rows = padded[1:, 1:-1] != padded[:-1, 1:-1]        # (rows+1, cols)
    across_cols = (padded[1:-1, 1:] != padded[1:-1, :-1]).T    # (cols+1, rows)
    segs = [(c0, r, c1, r) for r, c0, c1 in _runs(across_rows)]
    segs += [(c, r0, c, r1) for c, r0, r1 in _runs(across_cols)]
    return np.asarray(segs, dtype=np.int64).reshape(-1, 4)


def wall_outline_mesh(fmap: FloorMap, height: float, segments: np.ndarray
                      ) -> Tuple[np.ndarray, np.ndarray]:
    """Vertical quads from z=0 to ``height`` on outline segments (``outline_segments``):
    the walls as a beam or a body meets them, without the faces inside a wall or on top.

    Returns:
        (vertices float64 (4K, 3), indices int32 (6K,)) in the map frame.
    """
    s = np.asarray(segments, dtype=float).reshape(-1, 4) * fmap.resolution
    x0, y0 = fmap._grid_to_world(s[:, 0], s[:, 1])
    x1, y1 = fmap._grid_to_world(s[:, 2], s[:, 3])
    verts = np.zeros((len(s), 4, 3))
    verts[:, 0, 0], verts[:, 0, 1] = x0, y0
    verts[:, 1, 0], verts[:, 1, 1] = x1, y1
    verts[:, 2, :2] = verts[:, 1, :2]
    verts[:, 3, :2] = verts[:, 0, :2]
    verts[:, 2:, 2] = float(height)
    faces = (np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32)[None, :, :]
             + (4 * np.arange(len(s), dtype=np.int32))[:, None, None])
    return verts.reshape(-1, 3), faces.reshape(-1).astype(np.int32)
