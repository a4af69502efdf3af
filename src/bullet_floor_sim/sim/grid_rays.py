"""Rays against the walls on the solid grid itself: an exact cell-by-cell traversal.

The wall mesh the simulator builds (sim/walls.py) is the outline of the solid cells: a face
wherever a solid cell meets a free one (or the map's edge). A horizontal ray below the walls'
top therefore first meets a wall where it first crosses from a cell of one kind into a cell
of the other, and walking the cells it crosses in order (Amanatides and Woo's traversal)
finds that crossing exactly, as the ray test on the mesh does, without building a command
per batch or searching a tree. Compiled by numba when it is installed (as nav/grid.py's
planner); without it the same loop runs as plain Python, slowly, so World keeps to Bullet
then (``available()``).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["available", "GridRays"]


def _axis(p, cell, rate, per_cell):  # type: ignore
    """Along one grid axis, for a ray at ``p`` (in ``cell``) moving ``rate`` cells per
    metre (``per_cell`` = 1 / rate, metres a cell; multiplying by it is faster than
    dividing by rate): the step between cells (-1, 0, 1), the metres to the first cell
    boundary, and the metres between boundaries."""
    if rate > 0:
        return 1, (cell + 1 - p) * per_cell, per_cell
    if rate < 0:
        return -1, (p - cell) * -per_cell, -per_cell
    return 0, math.inf, math.inf


def _first_crossing(room, frame, o, d, start, end, jump, out):  # type: ignore
    """For each ray i from ``o[i]`` + ``start[i]`` along the unit direction ``d[i]`` (map
    frame, metres), ``start[i]`` plus the metres to its first crossing between a solid and
    a free cell (outside the grid is free) before ``end[i]``; inf where there is none.
    ``frame``: the grid's origin x, y, the cos and sin of its yaw, and cells per metre.
    ``room``: per cell, 0 for a solid cell, else the distance (cells) between its centre
    and the nearest solid cell's, rounded down (at least 1); a ray in a free cell with
    ``jump`` cells of room or more jumps ``room - 1.5`` cells at once (no solid cell's
    point is that near any point of the cell: sqrt(2) < 1.5) instead of walking them,
    unless it runs along a grid line (``_AXIAL``)."""
    h, w = room.shape
    gx, gy, gc, gs, k = frame[0], frame[1], frame[2], frame[3], frame[4]
    metres = 1.0 / k    # a cell's side
    for i in range(o.shape[0]):
        # the ray's start and direction in grid units (cells, from the grid's corner)
        px = o[i, 0] + d[i, 0] * start[i] - gx
        py = o[i, 1] + d[i, 1] * start[i] - gy
        u, v = (gc * px + gs * py) * k, (-gs * px + gc * py) * k
        a, b = (gc * d[i, 0] + gs * d[i, 1]) * k, (-gs * d[i, 0] + gc * d[i, 1]) * k
        ia = 1.0 / a if a != 0.0 else math.inf
        ib = 1.0 / b if b != 0.0 else math.inf
        lim = end[i] - start[i]
        cx, cy = int(math.floor(u)), int(math.floor(v))
        inside = 0 <= cx < w and 0 <= cy < h
        prev = room[cy, cx] == 0 if inside else False
        sx, tx, dx = _axis(u, cx, a, ia)
        sy, ty, dy = _axis(v, cy, b, ib)
        hit = math.inf
        here = 0.0      # metres along the ray to where it entered its cell (or jumped to)
        # a ray along a grid line (a beam at 0 or 90 degrees: 0 or 1e-16 across it) walks:
        # which side of the line it runs on is the walk's rounding, and a jump would take
        # it afresh from the jumped-to point (a beam grazing a wall's end then differs)
        jumps = min(abs(a), abs(b)) > _AXIAL * max(abs(a), abs(b))
        while True:
            if (jumps and not prev and 0 <= cx < w and 0 <= cy < h
                    and room[cy, cx] >= jump):
                here += (room[cy, cx] - 1.5) * metres
                if here > lim:
                    break
                cx, cy = int(math.floor(u + a * here)), int(math.floor(v + b * here))
                sx, tx, dx = _axis(u + a * here, cx, a, ia)
                sy, ty, dy = _axis(v + b * here, cy, b, ib)
                tx += here
                ty += here
                continue
            side = prev
            if abs(tx - ty) <= 1e-9 * (1.0 + min(tx, ty)):   # (inf: a ray along an axis)
                # through a cell corner: the two cells beside it are touched too (the mesh's
                # faces meet there, and the ray test counts a ray through their end a hit)
                t = tx
                a1, b1 = cx + sx, cy + sy
                if 0 <= a1 < w and 0 <= cy < h and (room[cy, a1] == 0) != prev:
                    side = not prev
                if 0 <= cx < w and 0 <= b1 < h and (room[b1, cx] == 0) != prev:
                    side = not prev
                cx, cy = a1, b1
                tx += dx
                ty += dy
            elif tx < ty:
                t = tx
                cx += sx
                tx += dx
            else:
                t = ty
                cy += sy
                ty += dy
            if t > lim:
                break
            here = t
            cur = room[cy, cx] == 0 if (0 <= cx < w and 0 <= cy < h) else False
            if cur != prev or side != prev:
                hit = t
                break
        out[i] = start[i] + hit


#: Cells of room (see _first_crossing) from which a ray jumps instead of walking.
_JUMP = 4.0
#: A ray whose direction's smaller grid component is below this share of the larger never
#: jumps (it runs along a grid line; see _first_crossing).
_AXIAL = 1e-6


try:   # the same loop, compiled (a 360-beam scan on office: well under a millisecond)
    import numba
    _axis = numba.njit(cache=True)(_axis)
    _first_crossing = numba.njit(cache=True)(_first_crossing)
    _COMPILED = True
except ImportError:   # pragma: no cover - numba is in the venv's requirements
    _COMPILED = False


def available() -> bool:
    """Whether the traversal is compiled (numba): only then is it worth using."""
    return _COMPILED


class GridRays:
    """Ray distances to the walls of one solid map (a FloorMap whose solid cells are 100).

    Args:
        solid: the solid cells as the wall mesh has them (World.solid.fmap).
    """

    def __init__(self, solid: Any) -> None:
        occupied = np.asarray(solid.occupied, dtype=bool)
        self.resolution = float(solid.resolution)
        ox, oy, yaw = (float(v) for v in solid.origin)
        self.frame = np.array([ox, oy, math.cos(yaw), math.sin(yaw), 1.0 / self.resolution])
        #: cells a ray must have in view to jump (``_first_crossing``; inf: walk every cell)
        self.jump = _JUMP
        if occupied.any():
            from scipy.ndimage import distance_transform_edt

            room = distance_transform_edt(~occupied)   # 0 on solid cells, >= 1 elsewhere
        else:
            room = np.full(occupied.shape, np.inf)
        # one byte a cell, 0 = solid (the walk reads one array: a 400 x 600 map is 240 kB,
        # where a bool grid and a float room were 2.2 MB, and other work evicted them from
        # the cache between scans); the room rounded down and capped at 255 cells, so a
        # jump never goes further than the exact room allows
        self.room = np.ascontiguousarray(np.minimum(np.floor(room), 255.0).astype(np.uint8))

    def cast(self, origins: np.ndarray, dirs: np.ndarray, start: np.ndarray,
             end: np.ndarray) -> np.ndarray:
        """Distance from each origin (M, 2+) along its unit direction (M, 2) to the first
        wall between ``start`` and ``end`` metres; inf where there is none."""
        o = np.ascontiguousarray(origins, dtype=float)
        d = np.ascontiguousarray(dirs, dtype=float)
        out = np.empty(len(o))
        # (a jump of room - 1.5 cells must move on: at least half a cell from 2 cells of room)
        _first_crossing(self.room, self.frame, o, d, np.ascontiguousarray(start, dtype=float),
                        np.ascontiguousarray(end, dtype=float), max(float(self.jump), 2.0), out)
        return out
