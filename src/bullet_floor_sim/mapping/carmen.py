"""Maps from SLAM-corrected CARMEN laser logs (the Radish data sets' ``*-corrected.log``):
each ``FLASER`` line's scan counted at its corrected laser pose, as gmapping counts hits and
passes (:func:`map_from_log`), read out as map_server's trinary grid and cropped to the known
cells. (The embedded mapper's log-odds, mapping/occupancy.py, forget a thin wall that
thousands of grazing beams pass: a batch of a whole log wants counts.)

A ``FLASER n r_1 .. r_n x y theta odom_x odom_y odom_theta ...`` line holds n ranges over
180 degrees, right to left, at the laser pose (x, y, theta) the SLAM estimated. Ranges at or
beyond ``range_max`` (a SICK reports 80 m or more for no return) are left out.
"""
from __future__ import annotations

import gzip
import math
from typing import Iterator, Tuple

import numpy as np

from ..errors import MapError
from ..sim.floormap import FloorMap, crop_known, map_from_grid

__all__ = ["read_flaser", "map_from_log", "flaser_angles"]

Scan = Tuple[np.ndarray, Tuple[float, float, float]]


def flaser_angles(n: int) -> Tuple[float, float]:
    """(angle_min, angle_increment) of an n-beam FLASER scan over 180 degrees: an odd count
    includes both ends (181: 1 degree steps from -90 to +90), an even one leaves the left end
    out (180: -90 to +89)."""
    return -math.pi / 2.0, math.pi / (n - 1 if n % 2 else n)


def read_flaser(path: str) -> Iterator[Scan]:
    """The scans of a CARMEN log (plain or .gz): (ranges, laser pose) per FLASER line.

    Raises:
        MapError: the file cannot be read, or a FLASER line is malformed (named by number).
    """
    opener = gzip.open if path.endswith(".gz") else open
    try:
        with opener(path, "rt", errors="replace") as f:  # type: ignore[operator]
            for number, line in enumerate(f, 1):
                if line.startswith("FLASER"):
                    yield _parse(line, path, number)
    except (OSError, EOFError) as e:
        raise MapError("%s: cannot read the log (%s)" % (path, e)) from None


def _parse(line: str, path: str, number: int) -> Scan:
    t = line.split()
    try:
        n = int(t[1])
        ranges = np.array(t[2:2 + n], dtype=float)
        pose = tuple(float(v) for v in t[2 + n:5 + n])
    except (IndexError, ValueError):
        raise MapError("%s:%d: malformed FLASER line" % (path, number)) from None
    if n < 2 or len(ranges) != n or len(pose) != 3 or not all(map(math.isfinite, pose)):
        raise MapError("%s:%d: malformed FLASER line" % (path, number))
    return ranges, (pose[0], pose[1], pose[2])


def map_from_log(path: str, resolution: float = 0.05, range_max: float = 40.0,
                 trace_range: float = 15.0, occupied_share: float = 0.25,
                 margin: float = 1.0) -> FloorMap:
    """The occupancy map of a corrected log, counted as gmapping counts: each beam that
    returns before ``range_max`` hits its end cell and passes the cells before it (out to
    ``trace_range`` m); a cell is occupied when at least ``occupied_share`` of the beams that
    reached it ended there (gmapping's occ_thresh), free when beams passed it otherwise,
    unknown when none reached it. Beams without a return are left out (no window fans).
    Cropped to the known cells plus ``margin`` m.

    Raises:
        MapError: unreadable or malformed log, or one without a FLASER line.
    """
    scans = list(read_flaser(path))
    if not scans:
        raise MapError("%s: no FLASER line (not a CARMEN laser log?)" % path)
    ends, origins = [], []
    for ranges, (x, y, th) in scans:
        a0, da = flaser_angles(len(ranges))
        a = th + a0 + da * np.arange(len(ranges))
        ok = (ranges > 0.05) & (ranges < range_max)
        ends.append(np.column_stack([x + ranges[ok] * np.cos(a[ok]),
                                     y + ranges[ok] * np.sin(a[ok])]))
        origins.append(np.repeat([[x, y]], int(ok.sum()), axis=0))
    end, start = np.vstack(ends), np.vstack(origins)
    if not len(end):
        raise MapError("%s: no beam returns within %g m" % (path, range_max))
    lo = np.minimum(end.min(axis=0), start.min(axis=0)) - 1.0
    w, h = (np.ceil((np.maximum(end.max(axis=0), start.max(axis=0)) + 1.0 - lo)
                    / resolution).astype(int))
    hits = np.bincount(_cells(end, lo, resolution, w), minlength=w * h)
    passes = np.zeros(w * h, dtype=np.int64)
    for k in range(0, len(end), 20000):   # beams in batches: the samples take memory
        passes += np.bincount(_passed(start[k:k + 20000], end[k:k + 20000], lo, resolution, w,
                                      trace_range), minlength=w * h)
    grid = np.full(w * h, -1, dtype=np.int8)
    grid[passes > 0] = 0
    grid[(hits > 0) & (hits >= occupied_share * (hits + passes))] = 100
    fmap = map_from_grid(grid.reshape(h, w), resolution, (float(lo[0]), float(lo[1]), 0.0))
    return crop_known(fmap, margin)


def _cells(xy: np.ndarray, lo: np.ndarray, res: float, w: int) -> np.ndarray:
    ij = np.floor((xy - lo) / res).astype(np.int64)
    return ij[:, 1] * w + ij[:, 0]


def _passed(start: np.ndarray, end: np.ndarray, lo: np.ndarray, res: float, w: int,
            trace_range: float) -> np.ndarray:
    """The cells each beam passes before its end cell (half-cell steps, out to
    ``trace_range``), each counted once a beam."""
    d = end - start
    length = np.hypot(d[:, 0], d[:, 1])
    reach = np.minimum(length - res, trace_range)
    n = np.maximum(0, np.ceil(reach / (0.5 * res)).astype(np.int64))
    beam = np.repeat(np.arange(len(start)), n)
    t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) * 0.5 * res
    u = d[beam] / length[beam, None]
    cells = _cells(start[beam] + u * t[:, None], lo, res, w)
    return np.unique(beam * (w * 10 ** 7) + cells) % (w * 10 ** 7)
