"""A built map against the world's map, cell by cell (the embedded mapper's check, and how a
SLAM package's saved map is scored).

The built map's frame is where the robot started (gmapping's and the embedded mapper's
``map`` frame is the odometry origin), so the comparison takes ``frame``: the built map
frame's pose in the world's map frame (the robot's spawn pose). The built map is sampled at
each world cell's centre (nearest cell; -1 off the map).

* free IoU: of the cells free in either map, the share free in both; the world's free cells
  are those of ``region`` (default: all of them; :func:`reachable` gives the robot's
  free-space component, what it can see);
* occupied IoU: the same for occupied cells, against the world's wall *faces*: its occupied
  cells beside a free cell of the region (a lidar sees no deeper into a wall);
* occupied F1 within one cell: the built occupied cells within one cell of a world wall, and
  the faces within one cell of a built occupied cell (range noise and a map's own
  discretisation move an edge by a cell).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from ..sim.floormap import FloorMap

__all__ = ["MapAgreement", "agreement", "reachable", "sample"]

_CROSS = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool)


def sample(built: FloorMap, world: FloorMap, frame: Sequence[float] = (0.0, 0.0, 0.0)
           ) -> np.ndarray:
    """The built map's value (100 / 0 / -1) at every cell of the world's map: an array of
    the world grid's shape."""
    rows, cols = np.mgrid[0:world.height, 0:world.width]
    wx, wy = (np.asarray(v, dtype=float) for v in world.cell_to_world(cols, rows))
    c, s = math.cos(frame[2]), math.sin(frame[2])
    dx, dy = wx - frame[0], wy - frame[1]
    mx, my = c * dx + s * dy, -s * dx + c * dy          # into the built map's frame
    bc, br = (np.floor(v).astype(np.int64) for v in built.world_to_cell(mx, my))
    inside = (br >= 0) & (bc >= 0) & (br < built.height) & (bc < built.width)
    out = np.full(world.grid.shape, -1, dtype=np.int16)
    g = np.asarray(built.grid)
    out[inside] = g[br[inside], bc[inside]]
    return out


def reachable(world: FloorMap, x: float, y: float) -> np.ndarray:
    """The world map's free cells 4-connected to the free cell at (x, y)."""
    from scipy.ndimage import label

    labels, _ = label(np.asarray(world.grid) == 0)
    col, row = (int(np.floor(v)) for v in world.world_to_cell(x, y))
    if labels[row, col] == 0:
        raise ValueError("(%.2f, %.2f) is not a free cell of the world's map" % (x, y))
    return labels == labels[row, col]


@dataclass(frozen=True)
class MapAgreement:
    """See the module doc; ``free_covered`` is the share of the region's free cells the
    built map reads free."""

    iou_free: float
    iou_occupied: float
    occupied_f1_1cell: float
    free_covered: float

    def line(self) -> str:
        return ("free IoU %.3f, occupied IoU %.3f (F1 within a cell %.3f), %.1f %% of the "
                "free space mapped" % (self.iou_free, self.iou_occupied,
                                       self.occupied_f1_1cell, 100 * self.free_covered))


def agreement(built: FloorMap, world: FloorMap, frame: Sequence[float] = (0.0, 0.0, 0.0),
              region: Optional[np.ndarray] = None) -> MapAgreement:
    """The built map against the world's (see the module doc)."""
    from scipy.ndimage import binary_dilation

    ours = sample(built, world, frame)
    truth = np.asarray(world.grid)
    free = (truth == 0) if region is None else (region & (truth == 0))
    faces = (truth == 100) & binary_dilation(free, structure=np.ones((3, 3), dtype=bool))
    mine_free, mine_occ = ours == 0, ours == 100
    near_wall = binary_dilation(truth == 100, structure=_CROSS)
    near_mine = binary_dilation(mine_occ, structure=_CROSS)
    hits = (mine_occ & near_wall).sum() + (faces & near_mine).sum()
    return MapAgreement(
        iou_free=_iou(mine_free, free),
        iou_occupied=_iou(mine_occ, faces),
        occupied_f1_1cell=float(hits / max(1, mine_occ.sum() + faces.sum())),
        free_covered=float((mine_free & free).sum() / max(1, free.sum())))


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    union = (a | b).sum()
    return float((a & b).sum() / union) if union else math.nan
