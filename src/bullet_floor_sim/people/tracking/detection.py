"""Detections in one scan: scan points in the map, the static map's points dropped, clusters of
person or robot size. See the package doc."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, List, Literal, Optional, Sequence, Tuple, Union, overload

import numpy as np

from ...sim.floormap import FloorMap
from ...sim.solidmap import MapHandling, solid_map
from .config import TrackerConfig, TrackingError

class StaticMap:
    """What the floor map explains: the distance from every cell to the nearest solid cell
    (occupied, or unknown under ``unknown: wall``; sim/solidmap.py), centre to centre.

    Args:
        fmap: the floor map.
        tolerance: points whose cell is within this distance of such a cell are explained.
        handling: how the map's unknown cells and gaps are read (the world's; default:
            MapHandling()).

    Raises:
        TrackingError: tolerance is negative or not finite.
    """

    def __init__(self, fmap: FloorMap, tolerance: float = 0.2,
                 handling: Optional[MapHandling] = None) -> None:
        from scipy.ndimage import distance_transform_edt

        if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance)
                and tolerance >= 0):
            raise TrackingError("static map: tolerance must be a finite number >= 0, got %r"
                                % (tolerance,))
        self.fmap = fmap
        self.tolerance = float(tolerance)
        # solid as the simulator makes it (sim/solidmap.py): an unseen sliver of an open hall
        # is floor where a person can stand, not a wall that explains scan points
        static = solid_map(fmap, handling or MapHandling()).fmap.occupied
        if static.any():
            self.distance_field = distance_transform_edt(~static) * fmap.resolution
        else:
            self.distance_field = np.full(static.shape, np.inf)

    def distance(self, points: np.ndarray) -> np.ndarray:
        """(N,) distance (m) from each point's cell to the nearest static cell; 0 outside the
        map (everything there counts as static)."""
        pts = _as_points(points, "points")
        col, row = self.fmap.world_to_cell(pts[:, 0], pts[:, 1])
        inside = (col >= 0) & (col < self.fmap.width) & (row >= 0) & (row < self.fmap.height)
        out = np.zeros(len(pts))
        out[inside] = self.distance_field[row[inside], col[inside]]
        return out

    def explained(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: the point is explained by the map (or lies outside it, and is ignored)."""
        return self.distance(points) <= self.tolerance


@overload
def scan_points(ranges: Sequence[float], angle_min: float, angle_increment: float,
                laser_pose: Sequence[float], return_beams: Literal[False] = False) -> np.ndarray:
    ...


@overload
def scan_points(ranges: Sequence[float], angle_min: float, angle_increment: float,
                laser_pose: Sequence[float], return_beams: Literal[True]
                ) -> Tuple[np.ndarray, np.ndarray]:
    ...


def scan_points(ranges: Sequence[float], angle_min: float, angle_increment: float,
                laser_pose: Sequence[float], return_beams: bool = False
                ) -> Union[np.ndarray, Tuple[np.ndarray, np.ndarray]]:
    """Map-frame points of a scan's finite returns.

    Args:
        ranges: (B,) REP 117 ranges; +inf (no return), -inf (too close) and NaN are dropped.
        angle_min, angle_increment: beam angles in the laser frame (radians).
        laser_pose: (x, y, yaw) of the laser frame in the map frame.
        return_beams: also return each point's beam index.

    Returns:
        Points (N, 2) float64 in beam order; with ``return_beams``, (points, beam indices
        (N,) int64, increasing).

    Raises:
        TrackingError: ranges is not 1-D, or the angles or the pose are not finite.
    """
    r = np.asarray(ranges, dtype=float)
    if r.ndim != 1:
        raise TrackingError("scan_points: ranges must be 1-D, got shape %s" % (r.shape,))
    pose = tuple(float(v) for v in laser_pose)
    if len(pose) != 3 or not all(math.isfinite(v) for v in pose):
        raise TrackingError("scan_points: laser_pose must be 3 finite numbers (x, y, yaw), "
                            "got %r" % (tuple(laser_pose),))
    if not (math.isfinite(angle_min) and math.isfinite(angle_increment)):
        raise TrackingError("scan_points: angle_min and angle_increment must be finite, got "
                            "%r and %r" % (angle_min, angle_increment))
    beams = np.flatnonzero(np.isfinite(r))
    a = pose[2] + angle_min + angle_increment * beams
    d = r[beams]
    pts = np.empty((len(beams), 2))
    pts[:, 0] = pose[0] + d * np.cos(a)
    pts[:, 1] = pose[1] + d * np.sin(a)
    return (pts, beams.astype(np.int64)) if return_beams else pts


def cluster(points: np.ndarray, gap: float, wrap: bool = False) -> List[np.ndarray]:
    """Split points given in beam order where two consecutive ones are farther apart than
    ``gap``.

    Only the distance splits: beams dropped between two points (no return, or explained by
    the map) do not, so a person standing by a wall whose middle points fall within the map's
    tolerance stays one cluster when what remains is still close together.

    Args:
        points: (N, 2) in beam order.
        gap: largest distance between consecutive points of one cluster (m).
        wrap: the scan is a full circle, so the last and first points are neighbours too.

    Returns:
        Index arrays into ``points``, one per cluster, in beam order.
    """
    pts = _as_points(points, "points")
    n = len(pts)
    if n == 0:
        return []
    step = np.hypot(*np.diff(pts, axis=0).T) if n > 1 else np.zeros(0)
    cuts = np.flatnonzero(step > gap) + 1
    groups = np.split(np.arange(n), cuts)
    if (wrap and len(groups) > 1
            and math.hypot(*(pts[0] - pts[-1])) <= gap):
        groups[0] = np.concatenate((groups.pop(), groups[0]))
    return groups


@dataclass(frozen=True)
class Detection:
    """One entity seen in one scan.

    Attributes:
        x, y: estimated centre in the map frame (m).
        size: extent of its points, the largest distance between two of them (m).
        n_points: number of scan points.
        cut: it holds a point on the edge of the scan's view, and TrackerConfig.edge_cut
            is ``position`` (the tracker corrects a track's position with it, not its
            velocity).
    """

    x: float
    y: float
    size: float
    n_points: int
    cut: bool = False


def detect(points: np.ndarray, static: StaticMap, laser_xy: Sequence[float],
           config: Optional[TrackerConfig] = None, wrap: bool = False,
           edge: Optional[np.ndarray] = None) -> List[Detection]:
    """Entities that the map does not explain, among a scan's points.

    Args:
        points: (N, 2) map-frame points in beam order (:func:`scan_points`).
        static: the static map; points it explains are dropped.
        laser_xy: (x, y) of the laser in the map frame (the centre is pushed away from it).
        config: detection parameters (``TrackerConfig()`` when None).
        wrap: the scan is a full circle (see :func:`cluster`).
        edge: (N,) bool, the point is on an edge of the view of a scan that is not a full
            circle (:func:`view_edge`); unless ``config.edge_cut`` is ``use``, a cluster
            holding one is ``cut`` (``drop``: no detection). None: no point is.

    Returns:
        One Detection per cluster of ``min_points`` or more points with an extent within
        [min_size, max_size], in beam order.
    """
    cfg = config or TrackerConfig()
    pts = _as_points(points, "points")
    keep = ~static.explained(pts)
    pts = pts[keep]
    at_edge = (np.asarray(edge, dtype=bool)[keep] if edge is not None and cfg.edge_cut != "use"
               else np.zeros(len(pts), dtype=bool))
    sensor = np.asarray(laser_xy, dtype=float).reshape(2)
    out = []
    for idx in cluster(pts, cfg.cluster_gap, wrap):
        cut = bool(at_edge[idx].any())
        if len(idx) < cfg.min_points or (cut and cfg.edge_cut == "drop"):
            continue
        q = pts[idx]
        diff = q[:, None, :] - q[None, :, :]
        size = float(np.sqrt((diff * diff).sum(axis=2).max()))
        if not cfg.min_size <= size <= cfg.max_size:
            continue
        c = q.mean(axis=0)
        u = c - sensor
        norm = math.hypot(u[0], u[1])
        if norm > 0.0:
            c = c + u * (cfg.centre_offset / norm)
        out.append(Detection(x=float(c[0]), y=float(c[1]), size=size, n_points=len(idx),
                             cut=cut))
    return out


def view_edge(ranges: Sequence[float], beams: np.ndarray, angle_increment: float
              ) -> Tuple[bool, Optional[np.ndarray]]:
    """Whether a scan (REP 117 ``ranges``, beams ``angle_increment`` apart) is a full circle,
    and, when it is not, which of the points on ``beams`` (:func:`scan_points`' beam indices)
    lie on an edge of its view: its first or last beam that reads (a return, or +inf: none
    in range; NaN and -inf, an invalid or too-close reading, do not say where the view
    ends, so the edge is the next beam in). The edge cuts a body standing across it: the
    points left lie to one side of the body's centre, and move as it leaves the view
    (issue 33's trace of the ipa production plant, docs/evaluation.md, session 78)."""
    r = np.asarray(ranges, dtype=float).reshape(-1)
    if abs(angle_increment) * len(r) >= 2.0 * math.pi - 1e-6:
        return True, None
    b = np.asarray(beams)
    reads = np.flatnonzero(~np.isnan(r) & (r != -np.inf))
    if not len(reads):
        return False, np.zeros(len(b), dtype=bool)
    return False, (b == reads[0]) | (b == reads[-1])


def scan_detections(ranges: Sequence[float], angle_min: float, angle_increment: float,
                    laser_pose: Sequence[float], static: StaticMap,
                    config: Optional[TrackerConfig] = None
                    ) -> Tuple[List[Detection], np.ndarray]:
    """:func:`scan_points` then :func:`detect` for one scan (a ``Scan``'s or a LaserScan's
    fields): its detections and its points. A scan whose beams cover a full circle wraps
    around; one that does not has edges (:func:`view_edge`)."""
    pts, beams = scan_points(ranges, angle_min, angle_increment, laser_pose, return_beams=True)
    wrap, edge = view_edge(ranges, beams, angle_increment)
    return detect(pts, static, laser_pose[:2], config, wrap, edge), pts


def detect_scan(ranges: Sequence[float], angle_min: float, angle_increment: float,
                laser_pose: Sequence[float], static: StaticMap,
                config: Optional[TrackerConfig] = None) -> List[Detection]:
    """The detections of one scan (:func:`scan_detections`)."""
    return scan_detections(ranges, angle_min, angle_increment, laser_pose, static, config)[0]


def _as_points(points: Any, what: str) -> np.ndarray:
    pts = np.asarray(points, dtype=float)
    if pts.size == 0:
        return pts.reshape(0, 2)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise TrackingError("%s must be an (N, 2) array, got shape %s" % (what, pts.shape))
    return pts


# --------------------------------------------------------------------------------------------
# tracking
# --------------------------------------------------------------------------------------------
