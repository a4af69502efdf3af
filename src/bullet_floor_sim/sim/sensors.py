"""Sensors: planar lidar (PyBullet batch ray tests), odometry with error, battery.

Each model works on all robots at once (one row per robot), so that a world of 50 robots costs
a few numpy operations per step and as few ``rayTestBatch`` calls as the 16,384-ray limit allows.
"""
from __future__ import annotations

import math
import operator
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import bullet_capi
from .config import BatteryConfig, LaserConfig, OdometryConfig
from ..geometry import wrap_angle, wrap_angles

_BODY = operator.itemgetter(0)
_FRACTION = operator.itemgetter(2)

__all__ = [
    "ray_chunk",
    "MAX_RAYS_PER_BATCH",
    "Scan",
    "RayPlan",
    "Lidar",
    "Odometry",
    "Battery",
    "cast_rays",
]

#: Up to this many robots, per-robot models step in plain floats instead of numpy arrays.
SMALL_N = 4

#: pybullet 3.2.7 advertises MAX_RAY_INTERSECTION_BATCH_SIZE = 16384, but a batch of exactly
#: 16384 rays comes back short (16383 results from lists, none from numpy arrays).
MAX_RAYS_PER_BATCH = 16383


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


#: Rays per call through the C API and through rayTestBatch (see cast_rays).
_RAY_CHUNK_CAPI, _RAY_CHUNK_TUPLES = 4000, 1000


def ray_chunk() -> int:
    """Rays per cast_rays call: larger through PyBullet's C API than through rayTestBatch."""
    return _RAY_CHUNK_CAPI if bullet_capi.available() else _RAY_CHUNK_TUPLES


def cast_rays(client, froms: np.ndarray, tos: np.ndarray, threads: int = 0,
              mask: Optional[int] = None, chunk: int = MAX_RAYS_PER_BATCH
              ) -> Tuple[np.ndarray, np.ndarray]:
    """Cast rays with ``rayTestBatch``, ``chunk`` rays per call (at most the batch limit);
    through PyBullet's C API when ``bullet_capi`` can reach it (the same ray test, without a
    Python tuple per ray).

    Args:
        client: a pybullet BulletClient.
        froms, tos: (M, 3) ray start and end points.
        threads: pybullet numThreads (0 = all cores).
        mask: collisionFilterMask (only bodies whose collision group shares a bit are hit).
        chunk: rays per call. Measured here with rayTestBatch, calls of about 1000 rays cost
            10-20% less per ray than calls of 16,383 (single- and multi-threaded); through the
            C API on two threads, calls of 4000 cost 5-8% less per ray than calls of 1000
            (0.38 vs 0.40 us for 8 m rays, 0.54 vs 0.58 for 30 m ones), and the sim bench's
            10 robots ran 2.5% faster, so ``World`` uses 4000.

    Returns:
        (hit fraction (M,) float64 in [0, 1], hit body id (M,) int, -1 = no hit).
    """
    m = len(froms)
    frac = np.empty(m)
    ids = np.empty(m, dtype=np.int64)
    step = max(1, min(int(chunk), MAX_RAYS_PER_BATCH))
    for s in range(0, m, step):
        e = min(m, s + step)
        frac[s:e], ids[s:e] = _cast_batch(client, froms[s:e], tos[s:e], threads, mask)
    return frac, ids


def _cast_batch(client, froms: np.ndarray, tos: np.ndarray, threads: int,
                mask: Optional[int]) -> Tuple[np.ndarray, np.ndarray]:
    """One call of at most MAX_RAYS_PER_BATCH rays: (hit fractions, hit body ids)."""
    fast = bullet_capi.cast_batch(client, froms, tos, threads, mask)
    if fast is not None:
        return fast
    m = len(froms)
    if mask is None:
        res = client.rayTestBatch(froms, tos, numThreads=threads)
    else:
        res = client.rayTestBatch(froms, tos, numThreads=threads, collisionFilterMask=mask)
    if len(res) != m:
        raise RuntimeError("rayTestBatch returned %d results for %d rays" % (len(res), m))
    return (np.fromiter(map(_FRACTION, res), float, m),
            np.fromiter(map(_BODY, res), np.int64, m))


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
        kinds = {}                       # robots whose beams have the same angles share a kind
        self._kind = [kinds.setdefault((len(a), float(a[0]) if len(a) else 0.0, c.resolution,
                                        c.fov >= 360.0 - 1e-9), len(kinds))
                      for a, c in zip(self.angles, self.cfgs)]
        # the previous scan of each robot: true ranges, and (yaw, laser x, laser y)
        self._prev_dist = np.full((len(self.cfgs), width), np.inf)
        self._prev_meta = np.zeros((len(self.cfgs), 3))
        self._prev_ok = np.zeros(len(self.cfgs), dtype=bool)

    def set_self_exit(self, robot: int, exit_dist: np.ndarray) -> None:
        """Where each beam leaves the robot's own body (m from the laser origin, 0 = never
        inside it): beams start there, so a lidar never sees its own robot."""
        self.self_exit[robot] = np.asarray(exit_dist, dtype=float)
        self._exits[robot, :len(self.self_exit[robot])] = self.self_exit[robot]

    def forget(self, robots: Optional[Sequence[int]] = None) -> None:
        """Drop the scan history used to shorten rays (after a teleport, e.g. a reset)."""
        self._prev_ok[slice(None) if robots is None else list(robots)] = False

    def plan(self, robots: Sequence[int], poses: np.ndarray,
             bounds: Tuple[float, float, float, float]) -> RayPlan:
        """Ray segments for the given robots' scans.

        A beam runs from where it leaves the robot's own body toward range_max, clipped to
        ``bounds`` (nothing beyond them can be hit). When the robot scanned before, the ray
        is also cut a margin beyond the farthest of the previous scan's ranges around the
        same world direction (a long ray walks past many walls and robots it cannot reach);
        a cut ray that hits nothing is cast again in full (``World`` does), so the result is
        exactly that of the full ray.
        """
        robots = np.asarray(robots, dtype=np.int64).reshape(-1)
        counts = [len(self.angles[i]) for i in robots.tolist()]
        groups = {}
        for q, i in enumerate(robots.tolist()):
            groups.setdefault(self._kind[i], []).append(q)
        parts = [self._plan_kind(np.array(qs, dtype=np.int64), robots, poses)
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
        full = np.minimum(rmax, _exit_distance(o[:, :2], d, bounds))
        start = np.minimum(start, full)
        end = np.minimum(np.maximum(end, start), full)
        short = end - start < 1e-6
        if short.any():
            end[short] = full[short]             # nothing left to cast: cast it all
        f = o.copy()
        f[:, :2] += d * start[:, None]
        t = o.copy()
        t[:, :2] += d * end[:, None]
        return RayPlan(robots=robots, counts=counts, origins=o, dirs=d, froms=f, tos=t,
                       start=start, length=end - start, full=full, cut=end < full)

    def _plan_kind(self, qs: np.ndarray, robots: np.ndarray, poses: np.ndarray):
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
        end = self._predict(rows, origin, yaw).reshape(-1)
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


def _exit_distance(origin: np.ndarray, d: np.ndarray,
                   bounds: Tuple[float, float, float, float]) -> np.ndarray:
    """Distance along each ray (origin (M, 2), unit dir (M, 2)) to where it leaves the box."""
    xmin, ymin, xmax, ymax = bounds
    with np.errstate(divide="ignore", invalid="ignore"):
        # a zero component gives +-inf or nan, which fmin (nan) and the sign fix (-inf) drop
        tx = (np.where(d[:, 0] > 0, xmax, xmin) - origin[:, 0]) / d[:, 0]
        ty = (np.where(d[:, 1] > 0, ymax, ymin) - origin[:, 1]) / d[:, 1]
        tx[d[:, 0] == 0] = np.inf
        ty[d[:, 1] == 0] = np.inf
    return np.maximum(np.minimum(tx, ty), 0.0)


class Odometry:
    """Odometry integrated from each step's wheel motion, with random-walk error and drift.

    Errors accumulate as random walks: after D metres in a straight line the position error
    has std ``noise_trans * sqrt(D)``; after turning A radians the heading error has std
    ``noise_rot * sqrt(A)``; ``noise_rot_per_m`` adds heading error per sqrt(metre) and
    ``drift_yaw`` a systematic heading error per metre. Zero noise gives the exact motion.
    """

    def __init__(self, cfgs: Sequence[OdometryConfig], rng: np.random.Generator) -> None:
        self.rng = rng
        self.k_trans = np.array([c.noise_trans for c in cfgs])
        self.k_rot = np.array([c.noise_rot for c in cfgs])
        self.k_rot_m = np.array([c.noise_rot_per_m for c in cfgs])
        self.drift = np.array([c.drift_yaw for c in cfgs])
        self.noisy = bool(np.any(self.k_trans) or np.any(self.k_rot) or np.any(self.k_rot_m)
                          or np.any(self.drift))
        self.pose = np.zeros((len(cfgs), 3))

    def update(self, old: np.ndarray, new: np.ndarray) -> None:
        """Integrate the motion from ground-truth poses ``old`` to ``new`` (N, 3)."""
        if len(old) <= SMALL_N:
            self._update_small(old.tolist(), new.tolist())
            return
        dxw = new[:, 0] - old[:, 0]
        dyw = new[:, 1] - old[:, 1]
        c, s = np.cos(old[:, 2]), np.sin(old[:, 2])
        bx = c * dxw + s * dyw
        by = -s * dxw + c * dyw
        dth = wrap_angles(new[:, 2] - old[:, 2])
        if self.noisy:
            dist = np.hypot(bx, by)
            n = self.rng.standard_normal((len(dist), 2))
            scale = 1.0 + n[:, 0] * self.k_trans * np.sqrt(dist) / np.maximum(dist, 1e-12)
            scale = np.where(dist > 0, scale, 1.0)
            bx = bx * scale
            by = by * scale
            dth = dth + n[:, 1] * np.sqrt(self.k_rot ** 2 * np.abs(dth) + self.k_rot_m ** 2 * dist) \
                + self.drift * dist
        yaw = self.pose[:, 2]
        c, s = np.cos(yaw), np.sin(yaw)
        self.pose[:, 0] += c * bx - s * by
        self.pose[:, 1] += s * bx + c * by
        self.pose[:, 2] = wrap_angles(yaw + dth)

    def _update_small(self, old: list, new: list) -> None:
        """``update`` in plain floats, robot by robot (for a few robots numpy's per-call cost
        dominates); the same formulas and the same random draws."""
        noise = self.rng.standard_normal((len(old), 2)).tolist() if self.noisy else None
        out = []
        for i, (o, nw, p) in enumerate(zip(old, new, self.pose.tolist())):
            dxw, dyw = nw[0] - o[0], nw[1] - o[1]
            c, s = math.cos(o[2]), math.sin(o[2])
            bx, by = c * dxw + s * dyw, -s * dxw + c * dyw
            dth = wrap_angle(nw[2] - o[2])
            if noise is not None:
                dist = math.hypot(bx, by)
                if dist > 0:
                    scale = 1.0 + noise[i][0] * self.k_trans[i] * math.sqrt(dist) / max(dist, 1e-12)
                    bx, by = bx * scale, by * scale
                dth = dth + noise[i][1] * math.sqrt(self.k_rot[i] ** 2 * abs(dth)
                                                    + self.k_rot_m[i] ** 2 * dist) \
                    + self.drift[i] * dist
            c, s = math.cos(p[2]), math.sin(p[2])
            out.append((p[0] + c * bx - s * by, p[1] + s * bx + c * by,
                        wrap_angle(p[2] + dth)))
        self.pose[:] = out

    def reset(self, robots: Optional[Sequence[int]] = None) -> None:
        """Odometry back to (0, 0, 0) for the given robots (all by default)."""
        if robots is None:
            self.pose[:] = 0.0
        else:
            self.pose[list(robots)] = 0.0


class Battery:
    """Linear discharge in time; computed on demand, so it costs nothing per step."""

    def __init__(self, cfgs: Sequence[BatteryConfig], now_ns: int) -> None:
        self.cfgs = list(cfgs)
        self.t0 = np.full(len(cfgs), now_ns, dtype=np.int64)

    def state(self, robot: int, now_ns: int) -> Tuple[float, float, float]:
        """(percentage in [0, 1], voltage V, remaining charge Ah) of one robot at a time."""
        c = self.cfgs[robot]
        hours = (now_ns - int(self.t0[robot])) / 3.6e12
        pct = min(1.0, max(0.0, c.initial - c.discharge_per_hour * hours))
        volt = c.voltage_empty + (c.voltage_full - c.voltage_empty) * pct
        return pct, volt, c.capacity_ah * pct

    def reset(self, robots: Sequence[int], now_ns: int) -> None:
        """Recharge: start discharging again from ``initial``."""
        self.t0[list(robots)] = now_ns


