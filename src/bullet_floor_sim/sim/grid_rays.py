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


def _axis(p, cell, rate):  # type: ignore
    """Along one grid axis, for a ray at ``p`` (in ``cell``) moving ``rate`` cells per
    metre: the step between cells (-1, 0, 1), the metres to the first cell boundary, and
    the metres between boundaries."""
    if rate > 0:
        return 1, (cell + 1 - p) / rate, 1.0 / rate
    if rate < 0:
        return -1, (p - cell) / -rate, -1.0 / rate
    return 0, math.inf, math.inf


def _first_crossing(solid, u0, v0, du, dv, length, out):  # type: ignore
    """For each ray i from (u0, v0) (grid units: cells, from the grid's corner) along
    (du, dv) (cells per metre), the metres to its first crossing between a solid and a free
    cell (outside the grid is free) within ``length[i]``; inf where there is none."""
    h, w = solid.shape
    for i in range(u0.shape[0]):
        u, v, a, b, lim = u0[i], v0[i], du[i], dv[i], length[i]
        cx, cy = int(math.floor(u)), int(math.floor(v))
        inside = 0 <= cx < w and 0 <= cy < h
        prev = solid[cy, cx] if inside else False
        sx, tx, dx = _axis(u, cx, a)
        sy, ty, dy = _axis(v, cy, b)
        hit = math.inf
        while True:
            side = prev
            if abs(tx - ty) <= 1e-9 * (1.0 + tx):
                # through a cell corner: the two cells beside it are touched too (the mesh's
                # faces meet there, and the ray test counts a ray through their end a hit)
                t = tx
                a1, b1 = cx + sx, cy + sy
                if 0 <= a1 < w and 0 <= cy < h and solid[cy, a1] != prev:
                    side = not prev
                if 0 <= cx < w and 0 <= b1 < h and solid[b1, cx] != prev:
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
            cur = solid[cy, cx] if (0 <= cx < w and 0 <= cy < h) else False
            if cur != prev or side != prev:
                hit = t
                break
        out[i] = hit


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
        self.solid = np.ascontiguousarray(solid.occupied)
        self.resolution = float(solid.resolution)
        ox, oy, yaw = (float(v) for v in solid.origin)
        self.origin, self.c, self.s = (ox, oy), math.cos(yaw), math.sin(yaw)

    def cast(self, origins: np.ndarray, dirs: np.ndarray, start: np.ndarray,
             end: np.ndarray) -> np.ndarray:
        """Distance from each origin (M, 2+) along its unit direction (M, 2) to the first
        wall between ``start`` and ``end`` metres; inf where there is none."""
        o = np.asarray(origins, dtype=float)[:, :2]
        d = np.asarray(dirs, dtype=float)[:, :2]
        start = np.asarray(start, dtype=float)
        px = o[:, 0] + d[:, 0] * start - self.origin[0]
        py = o[:, 1] + d[:, 1] * start - self.origin[1]
        k = 1.0 / self.resolution
        u0 = (self.c * px + self.s * py) * k
        v0 = (-self.s * px + self.c * py) * k
        du = (self.c * d[:, 0] + self.s * d[:, 1]) * k
        dv = (-self.s * d[:, 0] + self.c * d[:, 1]) * k
        out = np.empty(len(o))
        _first_crossing(self.solid, u0, v0, du, dv,
                        np.asarray(end, dtype=float) - start, out)
        return start + out
