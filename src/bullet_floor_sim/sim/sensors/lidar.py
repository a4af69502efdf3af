"""Planar lidars of all robots, cast together in PyBullet ray batches (world.yaml ``laser:``).

One model covers every robot (one row per robot), so that a world of 50 robots costs as few
``rayTestBatch`` calls as the 16,384-ray limit allows.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..checks import check_numbers
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
        check_numbers(self, ("range_max", "fov", "resolution", "rate"), where)
        if not 0.0 <= self.range_min < self.range_max:
            raise ConfigError("%s: range_min must be in [0, range_max), got %r"
                              % (where, self.range_min))
        if self.fov > 360.0:
            raise ConfigError("%s: fov must be at most 360 degrees, got %r" % (where, self.fov))
        check_numbers(self, ("noise_std",), where, strict=False)


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
        first: (Q,) int64 each robot's first ray (its rays are first .. first + count - 1).
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
    first: np.ndarray


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
        # each beam's direction in the laser's frame: a scan turns them by its heading
        self._cos = [np.cos(a) for a in self.angles]
        self._sin = [np.sin(a) for a in self.angles]
        self.period_ns = np.array([int(round(1e9 / c.rate)) for c in self.cfgs], dtype=np.int64)
        self.self_exit: List[Optional[np.ndarray]] = [None] * len(self.cfgs)
        self._range_max = np.array([c.range_max for c in self.cfgs], dtype=float)
        self._n_beams = [len(a) for a in self.angles]         # (a list: read per robot in Python)
        self._layouts: Dict[Tuple[int, ...], Any] = {}        # see _layout
        self._n_beams_array = np.array(self._n_beams, dtype=np.int64)
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
        lidar.restart(world.clock.now_ns)
        return lidar

    def restart(self, now_ns: int) -> None:
        """Every lidar first due one period after ``now_ns``."""
        self.next_scan_ns[:] = now_ns + self.period_ns
        self._schedule()

    def reschedule(self) -> None:
        """When the next scan is due, after rows' ``next_scan_ns`` were set (sim/roster.py)."""
        self._schedule()

    def _schedule(self) -> None:
        self.next_ns = int(_earliest(self.next_scan_ns, self.robots, NEVER))

    def read(self, world) -> List["Scan"]:
        """The scans of the due lidars (``World.cast_beams`` measures their beams), each next
        due one period on (a missed one is not made up)."""
        now = world.clock.now_ns
        due = np.empty(len(self.robots), dtype=np.int64)
        k, first = _take_due(self.next_scan_ns, self.robots, self.period_ns, now, NEVER, due)
        self.next_ns = int(first)
        due = due[:k]
        yaw = world.pose[:, 2]
        if any(not -math.pi <= y < math.pi for y in yaw.tolist()):
            out_of_range = (yaw < -np.pi) | (yaw >= np.pi)   # wrap only those: (y + pi) - pi != y
            yaw[out_of_range] = np.remainder(yaw[out_of_range] + np.pi, 2.0 * np.pi) - np.pi
        plan = self.plan(due, world.pose, world.ray_bounds(), predict=not world.walls_on_grid)
        dist, hit = world.cast_beams(plan)
        out = []
        s = 0
        for i, k in zip(due.tolist(), plan.counts):
            e = s + k
            out.append(self.scan(i, now, self.ranges(i, dist[s:e], hit[s:e])))
            s = e
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
        robots, counts, firsts, m, groups = self._layout(robots)
        o, d, f, t = np.empty((m, 3)), np.empty((m, 2)), np.empty((m, 3)), np.empty((m, 3))
        start, end, full, length = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
        cut = np.empty(m, dtype=bool)
        xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        for rows, first in groups:   # robots with one lidar geometry: their beams at once
            yaw = poses[rows, 2]
            heading = yaw + self.yaw[rows]
            if predict:
                pred = self._predict(rows, self._origins(rows, poses, yaw), yaw)
            else:
                pred = _NO_PREDICTION
            r0 = int(rows[0])
            _beams(poses, self.offsets, np.cos(yaw), np.sin(yaw), np.cos(heading),
                   np.sin(heading), self._cos[r0], self._sin[r0], self._exits, self._range_max,
                   rows, first, pred, xmin, ymin, xmax, ymax, o, d, start, end, full, length,
                   cut, f, t)
        return RayPlan(robots=robots, counts=counts, origins=o, dirs=d, froms=f, tos=t,
                       start=start, length=length, full=full, cut=cut, first=firsts)

    def _layout(self, robots: Union[Sequence[int], np.ndarray]
                ) -> Tuple[np.ndarray, List[int], np.ndarray, int,
                           List[Tuple[np.ndarray, np.ndarray]]]:
        """Where each of these robots' rays go in a plan: the robots (int64), their beam
        counts, each one's first ray, the rays in all, and per lidar geometry its robots
        and their first rays. Kept per set of robots (a scan tick repeats the last one)."""
        listed = tuple(np.asarray(robots, dtype=np.int64).reshape(-1).tolist())
        layout = self._layouts.get(listed)
        if layout is None:
            counts = [self._n_beams[i] for i in listed]
            firsts = np.concatenate(([0], np.cumsum(counts, dtype=np.int64)[:-1])) \
                if listed else np.zeros(0, dtype=np.int64)
            kinds: Dict[int, List[int]] = {}
            for q, i in enumerate(listed):
                kinds.setdefault(self._kind[i], []).append(q)
            rows = np.array(listed, dtype=np.int64)
            groups = [(rows[qs], firsts[qs]) for qs in kinds.values()]
            if len(self._layouts) >= 64:   # (robots due at many different ticks)
                self._layouts.clear()
            layout = self._layouts[listed] = (rows, counts, firsts.astype(np.int64),
                                              int(sum(counts)), groups)
        return layout

    def _origins(self, rows: np.ndarray, poses: np.ndarray, yaw: np.ndarray) -> np.ndarray:
        """(Q, 3) the laser origins of robots ``rows`` at ``poses`` (map frame)."""
        origin = np.empty((len(rows), 3))
        _laser_origins(poses, rows, np.cos(yaw), np.sin(yaw), self.offsets, origin)
        return origin

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
        out = np.empty(len(plan.robots), dtype=bool)
        _unmoved(self._prev_ok, self._prev_meta, plan.robots, plan.first, poses, plan.origins,
                 out)
        return out

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
        _remember(self._prev_dist, self._prev_meta, self._prev_ok, plan.robots, plan.first,
                  self._n_beams_array, poses, plan.origins, dist, hit)

    def ranges(self, robot: int, dist: np.ndarray, hit: np.ndarray) -> np.ndarray:
        """REP 117 ranges of one scan from true hit distances: noise, -inf below min, +inf no
        return."""
        cfg = self.cfgs[robot]
        r = dist
        if cfg.noise_std > 0.0:
            r = r + self.rng.normal(0.0, cfg.noise_std, size=r.shape)
        out = np.empty(len(r), dtype=np.float32)
        _rep117(r, hit, cfg.range_min, cfg.range_max, out)
        return out

    def scan(self, robot: int, stamp_ns: int, ranges: np.ndarray) -> Scan:
        """Wrap ranges into a Scan with the robot's beam geometry."""
        cfg = self.cfgs[robot]
        a = self.angles[robot]
        inc = math.radians(cfg.resolution)
        return Scan(robot=robot, stamp_ns=stamp_ns, ranges=ranges, angle_min=float(a[0]),
                    angle_max=float(a[-1]), angle_increment=inc, range_min=cfg.range_min,
                    range_max=cfg.range_max, scan_time=1.0 / cfg.rate)


#: ``Lidar.plan``'s stand-in for "no predicted ends" (every ray runs to its full length).
_NO_PREDICTION = np.empty((0, 0))


def _laser_origins(poses, rows, c, sn, offsets, out):  # type: ignore
    """``out[q]``: the laser origin of robot ``rows[q]`` at ``poses`` (map frame), its yaw's
    cosine and sine ``c[q]``, ``sn[q]`` (numpy's: numba's own differ in the last bit)."""
    for q in range(rows.shape[0]):
        out[q, 0], out[q, 1], out[q, 2] = _laser_origin(poses, rows[q], c[q], sn[q], offsets)


def _laser_origin(poses, r, c, sn, offsets):  # type: ignore
    """Robot r's laser origin (x, y, z, map frame) at ``poses``, its yaw's cosine ``c`` and
    sine ``sn``."""
    ox, oy = offsets[r, 0], offsets[r, 1]
    return poses[r, 0] + c * ox - sn * oy, poses[r, 1] + sn * ox + c * oy, offsets[r, 2]


def _take_due(next_scan_ns, robots, period_ns, now, never, due):  # type: ignore
    """The lidars of ``robots`` due at ``now`` into ``due`` (returns their count), each next
    due one period on (a missed one is not made up), and the earliest next scan of all
    (``never`` without robots)."""
    k = 0
    for r in robots:
        if next_scan_ns[r] <= now:
            due[k] = r
            k += 1
            nxt = next_scan_ns[r] + period_ns[r]
            next_scan_ns[r] = now + period_ns[r] if nxt <= now else nxt
    return k, _earliest(next_scan_ns, robots, never)


def _earliest(next_scan_ns, robots, never):  # type: ignore
    """The earliest next scan of ``robots`` (``never`` without robots)."""
    first = never
    for r in robots:
        first = min(first, next_scan_ns[r])
    return first


def _rep117(r, hit, range_min, range_max, out):  # type: ignore
    """``out`` (float32): each range ``r`` where it is a hit within [range_min, range_max],
    -inf for a hit nearer than range_min, +inf for no hit or one beyond range_max."""
    for k in range(r.shape[0]):
        if not hit[k] or r[k] > range_max:
            out[k] = math.inf
        elif r[k] < range_min:
            out[k] = -math.inf
        else:
            out[k] = r[k]


def _unmoved(prev_ok, prev_meta, rows, first, poses, origins, out):  # type: ignore
    """``out[q]``: robot ``rows[q]``'s lidar, whose first ray is ``first[q]`` of ``origins``,
    is exactly where ``prev_meta`` (yaw, laser x, laser y) had it at a kept scan."""
    for q in range(rows.shape[0]):
        r, k = rows[q], first[q]
        out[q] = (prev_ok[r] and prev_meta[r, 0] == poses[r, 2]
                  and prev_meta[r, 1] == origins[k, 0] and prev_meta[r, 2] == origins[k, 1])


def _remember(prev_dist, prev_meta, prev_ok, rows, first, beams, poses, origins, dist,
              hit):  # type: ignore
    """Keep each robot ``rows[q]``'s ranges (``beams[r]`` rays from ``first[q]``; +inf
    where ``hit`` is false), its yaw and its laser's x, y."""
    for q in range(rows.shape[0]):
        r, k = rows[q], first[q]
        for j in range(beams[r]):
            prev_dist[r, j] = dist[k + j] if hit[k + j] else math.inf
        prev_meta[r, 0], prev_meta[r, 1], prev_meta[r, 2] = poses[r, 2], origins[k, 0], origins[k, 1]
        prev_ok[r] = True


def _beams(poses, offsets, cos_y, sin_y, cos_h, sin_h, cos_b, sin_b, exits, rmax, rows, first,
           pred, xmin, ymin, xmax, ymax, o, d, start, end, full, length, cut, f,
           t):  # type: ignore
    """The rays of robots ``rows`` (one lidar geometry), in place from each robot's
    ``first`` ray: origin ``o``, the laser's (``_laser_origin``: ``poses``, ``offsets`` and
    the yaws' cosines and sines ``cos_y``, ``sin_y``); unit direction ``d``, the beams'
    directions in the laser's frame (``cos_b``, ``sin_b``, (n,)) turned by each laser's
    heading (``cos_h``, ``sin_h``, (Q,)), within a few units in the last place of the cosine
    and sine of the sum;
    ``start`` where the beam leaves the robot (``exits``); ``full`` the nearer of the
    robot's ``rmax`` and where the ray leaves the box (xmin, ymin, xmax, ymax); ``end`` the
    predicted end (``pred`` (Q, n); none: ``full``), start and end clipped to full (an end
    less than 1e-6 m past its start moves to ``full``: nothing left to cast, cast it all);
    ``length`` end - start, ``cut`` end < full, and the segment's ends ``f``, ``t``.
    One loop over the rays (compiled by numba: a tenth of numpy's per-call cost on a
    360-beam scan)."""
    for q in range(rows.shape[0]):
        r = rows[q]
        ox, oy, oz = _laser_origin(poses, r, cos_y[q], sin_y[q], offsets)
        ch, sh = cos_h[q], sin_h[q]
        for j in range(cos_b.shape[0]):
            k = first[q] + j
            a, b = ch * cos_b[j] - sh * sin_b[j], sh * cos_b[j] + ch * sin_b[j]
            tx = (xmax - ox) / a if a > 0 else ((xmin - ox) / a if a < 0 else math.inf)
            ty = (ymax - oy) / b if b > 0 else ((ymin - oy) / b if b < 0 else math.inf)
            fk = min(rmax[r], max(min(tx, ty), 0.0))
            sk = min(exits[r, j], fk)
            ek = min(max(pred[q, j] if pred.shape[0] else math.inf, sk), fk)
            if ek - sk < 1e-6:
                ek = fk
            o[k, 0], o[k, 1], o[k, 2] = ox, oy, oz
            d[k, 0], d[k, 1] = a, b
            full[k], start[k], end[k] = fk, sk, ek
            length[k], cut[k] = ek - sk, ek < fk
            f[k, 0], f[k, 1], f[k, 2] = ox + a * sk, oy + b * sk, oz
            t[k, 0], t[k, 1], t[k, 2] = ox + a * ek, oy + b * ek, oz


try:   # as sim/grid_rays.py: compiled where numba is installed (the venv's requirements)
    import numba
    _beams = numba.njit(cache=True)(_beams)
    _laser_origin = numba.njit(cache=True)(_laser_origin)
    _laser_origins = numba.njit(cache=True)(_laser_origins)
    _unmoved = numba.njit(cache=True)(_unmoved)
    _rep117 = numba.njit(cache=True)(_rep117)
    _earliest = numba.njit(cache=True)(_earliest)
    _take_due = numba.njit(cache=True)(_take_due)
    _remember = numba.njit(cache=True)(_remember)
except ImportError:   # pragma: no cover
    pass


KIND = SensorKind(LaserConfig, Lidar.build)
