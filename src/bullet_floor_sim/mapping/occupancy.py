"""A log-odds occupancy grid built from laser scans taken at known poses (the embedded
mapper; gmapping's grid without the particle filter).

Each beam marks the cells it crosses as freer (``hit_free``) and, when it returns before
``range_max``, its end cell as more occupied (``hit_occupied``); log-odds are clamped to
``[clamp_low, clamp_high]`` so a moved object is forgotten again. Free space is traced only
out to ``trace_range`` (far beams are too sparse to clear space reliably). The grid grows as
the robot sees beyond it. Read out as map_server's trinary grid (100 occupied, 0 free,
-1 unknown) with map_server's default thresholds (occupied above 0.65, free below 0.196).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence, Tuple, Union

import numpy as np

from ..sim.floormap import FloorMap, map_from_grid

__all__ = ["MapperConfig", "OccupancyMapper", "SURFACE", "logit"]

#: How far beyond a beam's end its end cell is taken (m): past float32 rounding of a range.
SURFACE = 1e-3


def logit(p: float) -> float:
    """log(p / (1 - p))."""
    return math.log(p / (1.0 - p))


@dataclass(frozen=True)
class MapperConfig:
    """Grid and sensor-model parameters (metres, log-odds).

    Attributes:
        resolution: cell size (gmapping's ``delta`` default, 0.05 m).
        hit_occupied, hit_free: log-odds added to a beam's end cell and to the cells it
            crosses (probabilities 0.7 and 0.15: as in gmapping's counting, one observation
            decides, an end seen once reads occupied and a cell crossed once free; an
            occupied cell crossed twice (a person who walked on) reads free again).
        clamp_low, clamp_high: log-odds bounds.
        trace_range: free space is marked out to this distance along a beam.
        occupied_thresh, free_thresh: probabilities of the trinary read-out (map_server's).
    """

    resolution: float = 0.05
    hit_occupied: float = logit(0.7)
    hit_free: float = logit(0.15)
    clamp_low: float = -4.0
    clamp_high: float = 4.0
    trace_range: float = 12.0
    occupied_thresh: float = 0.65
    free_thresh: float = 0.196


class OccupancyMapper:
    """The grid; ``origin`` is its lower-left corner in the map frame (it moves as the grid
    grows to the left or down).

    Args:
        config: parameters.
        centre: where the first robot pose is (the grid starts 20 m square around it).
    """

    def __init__(self, config: MapperConfig = MapperConfig(),
                 centre: Sequence[float] = (0.0, 0.0)) -> None:
        self.config = c = config
        n = int(round(20.0 / c.resolution))
        self.logodds = np.zeros((n, n), dtype=np.float32)
        self.origin = (float(centre[0]) - n * c.resolution / 2.0,
                       float(centre[1]) - n * c.resolution / 2.0)
        self.scans = 0

    def update(self, laser: Sequence[float], ranges: Union[np.ndarray, Sequence[float]],
               angle_min: float, angle_increment: float, range_max: float) -> None:
        """Add one scan taken from ``laser`` (x, y, yaw of the laser in the map frame)."""
        c = self.config
        r = np.asarray(ranges, dtype=float)
        a = angle_min + angle_increment * np.arange(len(r)) + float(laser[2])
        ok = ~np.isnan(r) & (r > 0)                       # -inf (too near): nothing known
        hit = ok & np.isfinite(r) & (r < range_max)
        reach = np.where(hit, r, range_max)
        free_to = np.minimum(reach, c.trace_range)
        ox, oy = float(laser[0]), float(laser[1])
        # a beam ends on the obstacle's surface, often exactly on a cell border: its end cell
        # is the one just beyond (SURFACE metres further along the beam)
        beyond = np.where(hit, reach + SURFACE, reach)
        ends = np.column_stack((ox + beyond * np.cos(a), oy + beyond * np.sin(a)))
        far = np.column_stack((ox + free_to * np.cos(a), oy + free_to * np.sin(a)))
        self._grow(np.vstack((far[ok], ends[hit], [[ox, oy]])))
        ends_traced = hit[ok] & (reach[ok] <= c.trace_range)
        free_cells = self._traced(ox, oy, a[ok], free_to[ok], ends_traced)
        L = self.logodds
        L[free_cells] += c.hit_free
        rows, cols = self.cells(ends[hit])
        np.add.at(L, (rows, cols), c.hit_occupied)
        np.clip(L, c.clamp_low, c.clamp_high, out=L)
        self.scans += 1

    def clear_disc(self, x: float, y: float, radius: float) -> None:
        """Mark the cells within ``radius`` of (x, y) free: where the robot stands (its own
        lidar may not see under it)."""
        res = self.config.resolution
        self._grow(np.array([[x - radius, y - radius], [x + radius, y + radius]]))
        (r0, r1), (c0, c1) = (self.cells(np.array([[x - radius, y - radius],
                                                     [x + radius, y + radius]])))
        rows, cols = np.mgrid[r0:r1 + 1, c0:c1 + 1]
        cx = self.origin[0] + (cols + 0.5) * res
        cy = self.origin[1] + (rows + 0.5) * res
        inside = np.hypot(cx - x, cy - y) <= radius
        L = self.logodds
        L[rows[inside], cols[inside]] = np.minimum(L[rows[inside], cols[inside]],
                                                   logit(self.config.free_thresh) - 0.1)

    def _traced(self, ox: float, oy: float, angles: np.ndarray, lengths: np.ndarray,
                stops_at_hit: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """The distinct cells the beams cross before their ends (half-cell steps), the end
        cell of a beam that hits left out."""
        res = self.config.resolution
        step = 0.5 * res
        n = np.maximum(1, np.ceil(lengths / step).astype(int))
        rep = np.repeat(np.arange(len(angles)), n)
        k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        t = np.minimum(k * step, lengths[rep])
        x = ox + t * np.cos(angles[rep])
        y = oy + t * np.sin(angles[rep])
        rows, cols = self.cells(np.column_stack((x, y)))
        # leave out the samples in a hitting beam's end cell (that cell is marked occupied)
        ends = np.column_stack((ox + lengths * np.cos(angles), oy + lengths * np.sin(angles)))
        er, ec = self.cells(ends)
        keep = ~(stops_at_hit[rep] & (rows == er[rep]) & (cols == ec[rep]))
        flat = np.unique(rows[keep] * self.logodds.shape[1] + cols[keep])
        return np.divmod(flat, self.logodds.shape[1])

    def cells(self, xy: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of the grid cells of points (N, 2) in the map frame (may be off it)."""
        res = self.config.resolution
        cols = np.floor((xy[:, 0] - self.origin[0]) / res).astype(np.int64)
        rows = np.floor((xy[:, 1] - self.origin[1]) / res).astype(np.int64)
        return rows, cols

    def _grow(self, xy: np.ndarray) -> None:
        """Pad the grid (with 5 m to spare) so that every point lies on it."""
        res = self.config.resolution
        rows, cols = self.cells(xy)
        h, w = self.logodds.shape
        margin = int(round(5.0 / res))
        down = max(0, -int(rows.min()) + margin) if rows.min() < 0 else 0
        left = max(0, -int(cols.min()) + margin) if cols.min() < 0 else 0
        up = max(0, int(rows.max()) - h + 1 + margin) if rows.max() >= h else 0
        right = max(0, int(cols.max()) - w + 1 + margin) if cols.max() >= w else 0
        if down or left or up or right:
            self.logodds = np.pad(self.logodds, ((down, up), (left, right)))
            self.origin = (self.origin[0] - left * res, self.origin[1] - down * res)

    def grid(self) -> np.ndarray:
        """The trinary grid (rows from the bottom): 100 occupied, 0 free, -1 unknown."""
        c = self.config
        out = np.full(self.logodds.shape, -1, dtype=np.int8)
        out[self.logodds > logit(c.occupied_thresh)] = 100
        out[self.logodds < logit(c.free_thresh)] = 0
        return out

    def floor_map(self) -> FloorMap:
        """The map as a FloorMap (what /map and dynamic_map serve, what save_map writes)."""
        return map_from_grid(self.grid(), self.config.resolution,
                             (self.origin[0], self.origin[1], 0.0))
