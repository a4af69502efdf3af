"""Planar lidars of all robots, cast together in PyBullet ray batches (world.yaml ``laser:``).

One model covers every robot (one row per robot), so that a world of 50 robots costs as few
``rayTestBatch`` calls as the 16,384-ray limit allows.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..checks import positive
from ...errors import ConfigError
from .base import NEVER, SensorKind

__all__ = ["LaserConfig", "Scan", "RayPlan", "Lidar", "KIND"]


@dataclass(frozen=True)
class LaserConfig:
    """A planar lidar at the model's ``base_laser_link`` (defaults: the Scitos A5 Hokuyo).

    Beams are spread over ``fov`` degrees centred ahead, ``resolution`` degrees apart (a full
    360-degree fov does not repeat its first beam). Ranges get Gaussian noise of ``noise_std``
    metres; a beam with no return reads +inf and one closer than ``range_min`` reads -inf
    (REP 117).
    """

    range_min: float = 0.1
    range_max: float = 30.0
    fov: float = 180.0
    resolution: float = 1.0
    rate: float = 10.0
    noise_std: float = 0.01
    enabled: bool = True

    @property
    def beams(self) -> int:
        """Number of beams per scan."""
        n = int(round(self.fov / self.resolution))
        return n if self.fov >= 360.0 - 1e-9 else n + 1

    def validate(self, where: str) -> None:
        """Raise ConfigError if a value is out of range."""
        positive(self, where, ("range_max", "fov", "resolution", "rate"))
        if not 0.0 <= self.range_min < self.range_max:
            raise ConfigError("%s: range_min must be in [0, range_max), got %r"
                              % (where, self.range_min))
        if self.fov > 360.0:
            raise ConfigError("%s: fov must be at most 360 degrees, got %r" % (where, self.fov))
        if self.noise_std < 0.0:
            raise ConfigError("%s: noise_std must be >= 0, got %r" % (where, self.noise_std))


@dataclass(frozen=True)
class Scan:
    """One laser scan of one robot, in LaserScan terms (angles in radians, REP 117 ranges).

    Attributes:
        robot: robot index in the world.
        stamp_ns: sim time of the scan, nanoseconds.
        ranges: float32 (beams,), +inf = no return, -inf = closer than range_min.
        angle_min, angle_max, angle_increment: beam angles in base_laser_link.
        range_min, range_max: as configured.
        scan_time: 1 / rate.
    """

    robot: int
    stamp_ns: int
    ranges: np.ndarray
    angle_min: float
    angle_max: float
    angle_increment: float
    range_min: float
    range_max: float
    scan_time: float


#: How far beyond the previous scan's ranges a ray is cast before it is cast again in full.
_PREDICT_MARGIN = 0.3


@dataclass(frozen=True)
class RayPlan:
    """The rays of one scan tick (see ``Lidar.plan``); distances are from the laser origin.

    Attributes:
        robots: the scanning robots, in ray order; counts: beams of each.
        origins, dirs: (M, 3) laser origin and (M, 2) unit direction of every beam.
        froms, tos: (M, 3) the segments to cast.
        start: (M,) where the segment starts (where the beam leaves the robot's own body).
        length: (M,) segment length, tos - froms.
        full: (M,) where the beam ends (range_max or the map bounds).
        cut: (M,) the segment stops short of ``full`` (cast again in full on a miss).
    """

    robots: np.ndarray
    counts: List[int]
    origins: np.ndarray
    dirs: np.ndarray
    froms: np.ndarray
    tos: np.ndarray
    start: np.ndarray
    length: np.ndarray
    full: np.ndarray
    cut: np.ndarray


class Lidar:
    """Planar lidars of a set of robots, cast together.

    Args:
        cfgs: one LaserConfig per robot (disabled ones are skipped).
        laser_poses: one (x, y, z, yaw) of base_laser_link in base_footprint per robot.
        rng: numpy Generator for range noise.
    """

    def __init__(self, cfgs: Sequence[LaserConfig], laser_poses: Sequence[Tuple[float, ...]],
                 rng: np.random.Generator) -> None:
        self.cfgs = list(cfgs)
        self.rng = rng
        self.offsets = np.array([p[:3] for p in laser_poses], dtype=float).reshape(-1, 3)
        self.yaw = np.array([p[3] for p in laser_poses], dtype=float)
        self.angles: List[np.ndarray] = []
        for c in self.cfgs:
            inc = math.radians(c.resolution)
            half = math.radians(c.fov) / 2.0
            n = c.beams
            amin = -half if c.fov < 360.0 - 1e-9 else -math.pi
            self.angles.append(amin + inc * np.arange(n))
        self.period_ns = np.array([int(round(1e9 / c.rate)) for c in self.cfgs], dtype=np.int64)
        self.self_exit: List[Optional[np.ndarray]] = [None] * len(self.cfgs)
        self._range_max = np.array([c.range_max for c in self.cfgs], dtype=float)
        # where each beam starts (set_self_exit), one row per robot; ragged if geometries differ
        width = max((len(a) for a in self.angles), default=0)
        self._exits = np.zeros((len(self.cfgs), width))
        # robots whose beams have the same angles share a kind
        kinds: Dict[Tuple[int, float, float, bool], int] = {}
        self._kind = [kinds.setdefault((len(a), float(a[0]) if len(a) else 0.0, c.resolution,
                                        c.fov >= 360.0 - 1e-9), len(kinds))
                      for a, c in zip(self.angles, self.cfgs)]
        # the previous scan of each robot: true ranges, and (yaw, laser x, laser y)
        self._prev_dist = np.full((len(self.cfgs), width), np.inf)
        self._prev_meta = np.zeros((len(self.cfgs), 3))
        self._prev_ok = np.zeros(len(self.cfgs), dtype=bool)
        # the robots with a lidar, each's next scan, and the earliest of those (sim ns)
        self.robots = np.array([i for i, c in enumerate(self.cfgs) if c.enabled], dtype=np.int64)
        self.next_scan_ns = np.zeros(len(self.cfgs), dtype=np.int64)
        self.next_ns = NEVER

    @classmethod
    def build(cls, world, cfgs: Sequence[LaserConfig]) -> "Lidar":
        """The lidars of ``world``'s robots (at their models' base_laser_link), each first
        due one period from now."""
        lidar = cls(cfgs, [m.laser_pose for m in world.models], world.rng)
        lidar.next_scan_ns[:] = world.clock.now_ns + lidar.period_ns
        lidar._schedule()
        return lidar

    def _schedule(self) -> None:
        self.next_ns = int(self.next_scan_ns[self.robots].min()) if len(self.robots) else NEVER

    def read(self, world) -> List["Scan"]:
        """The scans of the due lidars (``World.cast_beams`` measures their beams), each next
        due one period on (a missed one is not made up)."""
        now = world.clock.now_ns
        due = self.robots[self.next_scan_ns[self.robots] <= now]
        yaw = world.pose[:, 2]
        out_of_range = (yaw < -np.pi) | (yaw >= np.pi)   # wrap only those: (y + pi) - pi != y
        if out_of_range.any():
            yaw[out_of_range] = np.remainder(yaw[out_of_range] + np.pi, 2.0 * np.pi) - np.pi
        plan = self.plan(due, world.pose, world.ray_bounds(), predict=not world.walls_on_grid)
        dist, hit = world.cast_beams(plan)
        out = []
        s = 0
        for i, k in zip(due.tolist(), plan.counts):
            e = s + k
            out.append(self.scan(i, now, self.ranges(i, dist[s:e], hit[s:e])))
            s = e
        nxt = self.next_scan_ns[due] + self.period_ns[due]
        self.next_scan_ns[due] = np.where(nxt <= now, now + self.period_ns[due], nxt)
        self._schedule()
        return out

    def reset(self, world, rows: Sequence[int]) -> None:
        """Robots moved: drop their scan history."""
        self.forget(rows)

    def set_self_exit(self, robot: int, exit_dist: np.ndarray) -> None:
        """Where each beam leaves the robot's own body (m from the laser origin, 0 = never
        inside it): beams start there, so a lidar never sees its own robot."""
        exits = np.asarray(exit_dist, dtype=float)
        self.self_exit[robot] = exits
        self._exits[robot, :len(exits)] = exits

    def forget(self, robots: Optional[Sequence[int]] = None) -> None:
        """Drop the scan history used to shorten rays (after a teleport, e.g. a reset)."""
        self._prev_ok[slice(None) if robots is None else list(robots)] = False

    def plan(self, robots: Union[Sequence[int], np.ndarray], poses: np.ndarray,
             bounds: Tuple[float, float, float, float], predict: bool = True) -> RayPlan:
        """Ray segments for the given robots' scans.

        A beam runs from where it leaves the robot's own body toward range_max, clipped to
        ``bounds`` (nothing beyond them can be hit). When the robot scanned before, the ray
        is also cut a margin beyond the farthest of the previous scan's ranges around the
        same world direction (a long ray walks past many walls and robots it cannot reach);
        a cut ray that hits nothing is cast again in full (``World`` does), so the result is
        exactly that of the full ray. Without ``predict`` no ray is cut (the walls' grid
        caster stops at the first wall anyway: the prediction only cost time).
        """
        robots = np.asarray(robots, dtype=np.int64).reshape(-1)
        counts = [len(self.angles[i]) for i in robots.tolist()]
        groups: Dict[int, List[int]] = {}
        for q, i in enumerate(robots.tolist()):
            groups.setdefault(self._kind[i], []).append(q)
        parts = [self._plan_kind(np.array(qs, dtype=np.int64), robots, poses, predict)
                 for qs in groups.values()]
        if len(parts) == 1:      # one lidar geometry (the usual case): already in ray order
            o, d, start, end, rmax = parts[0][1:]
        else:
            m = int(sum(counts))
            offs = np.concatenate(([0], np.cumsum(counts)))[:-1].astype(np.int64)
            o, d, start, end, rmax = (np.empty((m, 3)), np.empty((m, 2)), np.empty(m),
                                      np.empty(m), np.empty(m))
            for qs, *arrays in parts:
                n = counts[qs[0]]
                at = (offs[qs][:, None] + np.arange(n)[None, :]).reshape(-1)
                for dst, src in zip((o, d, start, end, rmax), arrays):
                    dst[at] = src
        m = len(start)
        f, t, full = np.empty((m, 3)), np.empty((m, 3)), np.empty(m)
        start, end = np.array(start, dtype=float), np.array(end, dtype=float)
        xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        _segments(o, d, start, end, np.asarray(rmax, dtype=float), xmin, ymin, xmax, ymax,
                  full, f, t)
        return RayPlan(robots=robots, counts=counts, origins=o, dirs=d, froms=f, tos=t,
                       start=start, length=end - start, full=full, cut=end < full)

    def _plan_kind(self, qs: np.ndarray, robots: np.ndarray, poses: np.ndarray,
                   predict: bool = True):
        """Beams of the scanning robots ``robots[qs]``, which share one lidar geometry:
        (qs, origins, dirs, starts, predicted ends, range_max), robot after robot."""
        rows = robots[qs]
        n = len(self.angles[rows[0]])
        yaw = poses[rows, 2]
        c, sn = np.cos(yaw), np.sin(yaw)
        ox, oy, oz = self.offsets[rows, 0], self.offsets[rows, 1], self.offsets[rows, 2]
        origin = np.empty((len(rows), 3))                                         # (Q, 3)
        origin[:, 0] = poses[rows, 0] + c * ox - sn * oy
        origin[:, 1] = poses[rows, 1] + sn * ox + c * oy
        origin[:, 2] = oz
        ang = (yaw + self.yaw[rows])[:, None] + self.angles[rows[0]][None, :]      # (Q, n)
        d = np.empty((len(rows) * n, 2))
        d[:, 0] = np.cos(ang).reshape(-1)
        d[:, 1] = np.sin(ang).reshape(-1)
        start = self._exits[rows, :n].reshape(-1)
        end = (self._predict(rows, origin, yaw).reshape(-1) if predict
               else np.full(len(start), np.inf))
        rmax = np.repeat(self._range_max[rows], n)
        return qs, np.repeat(origin, n, axis=0), d, start, end, rmax

    def _predict(self, rows: np.ndarray, origin: np.ndarray, yaw: np.ndarray) -> np.ndarray:
        """(Q, beams) distance along each beam of robots ``rows`` (same lidar geometry)
        beyond which the previous scan says nothing is hit (+inf when unknown). Only a
        speed-up: a wrong guess costs a second cast."""
        n = len(self.angles[rows[0]])
        known = self._prev_ok[rows]
        if not known.any():
            return np.full((len(rows), n), np.inf)
        dist = self._prev_dist[rows, :n]                                      # (Q, n)
        meta = self._prev_meta[rows]                                          # yaw0, x0, y0
        wrap = self.cfgs[rows[0]].fov >= 360.0 - 1e-9
        # farthest of beams j-1 .. j+2 of the previous scan, then shifted by the turn: new
        # beam k looks where old beam k + turn / inc looked
        if wrap:
            pad = np.concatenate((dist[:, -1:], dist, dist[:, :2]), axis=1)
        else:   # beams beyond the fan: unknown
            inf = np.full((len(rows), 3), np.inf)
            pad = np.concatenate((inf, dist, inf), axis=1)
        m = np.maximum(np.maximum(pad[:, :-3], pad[:, 1:-2]), np.maximum(pad[:, 2:-1], pad[:, 3:]))
        inc = math.radians(self.cfgs[rows[0]].resolution)
        turn = np.remainder(yaw - meta[:, 0] + np.pi, 2.0 * np.pi) - np.pi
        shift = np.floor(turn / inc).astype(np.int64)
        idx = np.arange(n)[None, :] + shift[:, None]
        if wrap:
            idx = np.remainder(idx, n)                                    # m is (Q, n)
        else:
            idx = np.clip(idx + 2, 0, n + 2)                              # m is (Q, n + 3)
        near = m[np.arange(len(rows))[:, None], idx]
        moved = np.hypot(origin[:, 0] - meta[:, 1], origin[:, 1] - meta[:, 2])
        out = near + (_PREDICT_MARGIN + 2.0 * moved)[:, None]
        out[~known] = np.inf
        return out

    def unmoved(self, plan: RayPlan, poses: np.ndarray) -> np.ndarray:
        """Per planned robot: its lidar is exactly where it was at its previous scan."""
        rows = plan.robots
        offs = np.concatenate(([0], np.cumsum(plan.counts)))[:-1]
        meta = self._prev_meta[rows]
        return (self._prev_ok[rows] & (meta[:, 0] == poses[rows, 2])
                & (meta[:, 1] == plan.origins[offs, 0]) & (meta[:, 2] == plan.origins[offs, 1]))

    def previous(self, plan: RayPlan) -> Tuple[np.ndarray, np.ndarray]:
        """The planned robots' previous ranges as (distance, hit) per ray (what
        ``remember`` kept; meaningless for robots without a previous scan)."""
        if len(set(plan.counts)) == 1 and len(plan.robots):
            dist = self._prev_dist[plan.robots, :plan.counts[0]].reshape(-1).copy()
        else:
            dist = np.concatenate([self._prev_dist[i, :k]
                                   for i, k in zip(plan.robots.tolist(), plan.counts)] or
                                  [np.zeros(0)])
        return dist, np.isfinite(dist)

    def remember(self, plan: RayPlan, poses: np.ndarray, dist: np.ndarray,
                 hit: np.ndarray) -> None:
        """Keep this scan's true ranges (+inf = no return) for the next scan's ``plan``."""
        r = np.where(hit, dist, np.inf)
        offs = np.concatenate(([0], np.cumsum(plan.counts)))[:-1]
        rows = plan.robots
        if len(set(plan.counts)) == 1 and len(rows):
            n = plan.counts[0]
            self._prev_dist[rows, :n] = r.reshape(len(rows), n)
        else:
            for i, s, k in zip(rows.tolist(), offs.tolist(), plan.counts):
                self._prev_dist[i, :k] = r[s:s + k]
        self._prev_meta[rows, 0] = poses[rows, 2]
        self._prev_meta[rows, 1:] = plan.origins[offs, :2]
        self._prev_ok[rows] = True

    def ranges(self, robot: int, dist: np.ndarray, hit: np.ndarray) -> np.ndarray:
        """REP 117 ranges of one scan from true hit distances: noise, -inf below min, +inf no
        return."""
        cfg = self.cfgs[robot]
        r = dist
        if cfg.noise_std > 0.0:
            r = r + self.rng.normal(0.0, cfg.noise_std, size=r.shape)
        out = np.where(hit, r, np.inf)
        out[hit & (r < cfg.range_min)] = -np.inf
        out[hit & (r > cfg.range_max)] = np.inf
        return out.astype(np.float32)

    def scan(self, robot: int, stamp_ns: int, ranges: np.ndarray) -> Scan:
        """Wrap ranges into a Scan with the robot's beam geometry."""
        cfg = self.cfgs[robot]
        a = self.angles[robot]
        inc = math.radians(cfg.resolution)
        return Scan(robot=robot, stamp_ns=stamp_ns, ranges=ranges, angle_min=float(a[0]),
                    angle_max=float(a[-1]), angle_increment=inc, range_min=cfg.range_min,
                    range_max=cfg.range_max, scan_time=1.0 / cfg.rate)


def _segments(o, d, start, end, rmax, xmin, ymin, xmax, ymax, full, f, t):  # type: ignore
    """Each ray's segment, in place: ``full`` (M,) the nearer of ``rmax`` and where the ray
    (origin ``o`` (M, 3), unit direction ``d`` (M, 2)) leaves the box (xmin, ymin, xmax,
    ymax); ``start`` and ``end`` (M,) clipped to it (an end less than 1e-6 m past its start
    moves to ``full``: nothing left to cast, cast it all); ``f`` and ``t`` (M, 3) the
    segment's ends. One loop over the rays (compiled by numba: the same arithmetic as
    numpy's, a tenth of its per-call cost on a 360-beam scan)."""
    for k in range(o.shape[0]):
        a, b = d[k, 0], d[k, 1]
        tx = (xmax - o[k, 0]) / a if a > 0 else ((xmin - o[k, 0]) / a if a < 0 else math.inf)
        ty = (ymax - o[k, 1]) / b if b > 0 else ((ymin - o[k, 1]) / b if b < 0 else math.inf)
        fk = min(rmax[k], max(min(tx, ty), 0.0))
        sk = min(start[k], fk)
        ek = min(max(end[k], sk), fk)
        if ek - sk < 1e-6:
            ek = fk
        full[k], start[k], end[k] = fk, sk, ek
        f[k, 0], f[k, 1], f[k, 2] = o[k, 0] + a * sk, o[k, 1] + b * sk, o[k, 2]
        t[k, 0], t[k, 1], t[k, 2] = o[k, 0] + a * ek, o[k, 1] + b * ek, o[k, 2]


try:   # as sim/grid_rays.py: compiled where numba is installed (the venv's requirements)
    import numba
    _segments = numba.njit(cache=True)(_segments)
except ImportError:   # pragma: no cover
    pass


KIND = SensorKind(LaserConfig, Lidar.build)
