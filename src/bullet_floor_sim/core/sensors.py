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

from .config import BatteryConfig, LaserConfig, OdometryConfig

_BODY = operator.itemgetter(0)
_FRACTION = operator.itemgetter(2)

__all__ = [
    "MAX_RAYS_PER_BATCH",
    "Scan",
    "Lidar",
    "Odometry",
    "Battery",
    "cast_rays",
]

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


def cast_rays(client, froms: np.ndarray, tos: np.ndarray, threads: int = 0
              ) -> Tuple[np.ndarray, np.ndarray]:
    """Cast rays with ``rayTestBatch``, as few calls as the batch limit allows.

    Args:
        client: a pybullet BulletClient.
        froms, tos: (M, 3) ray start and end points.
        threads: pybullet numThreads (0 = all cores).

    Returns:
        (hit fraction (M,) float64 in [0, 1], hit body id (M,) int, -1 = no hit).
    """
    m = len(froms)
    frac = np.empty(m)
    ids = np.empty(m, dtype=np.int64)
    for s in range(0, m, MAX_RAYS_PER_BATCH):
        e = min(m, s + MAX_RAYS_PER_BATCH)
        res = client.rayTestBatch(froms[s:e], tos[s:e], numThreads=threads)
        if len(res) != e - s:
            raise RuntimeError("rayTestBatch returned %d results for %d rays" % (len(res), e - s))
        frac[s:e] = np.fromiter(map(_FRACTION, res), float, e - s)
        ids[s:e] = np.fromiter(map(_BODY, res), np.int64, e - s)
    return frac, ids


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

    def rays(self, robots: Sequence[int], poses: np.ndarray, bounds: Tuple[float, float, float, float]
             ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, List[int]]:
        """Ray segments for the given robots' scans.

        Each ray runs from the laser origin toward range_max, clipped to ``bounds`` (nothing
        beyond them can be hit), which keeps the BVH walk short.

        Returns:
            (froms (M, 3), tos (M, 3), full length of each ray as cast (M,), beam counts).
        """
        froms, dirs, lens, counts = [], [], [], []
        for i in robots:
            x, y, yaw = poses[i]
            c, s = math.cos(yaw), math.sin(yaw)
            ox, oy, oz = self.offsets[i]
            origin = (x + c * ox - s * oy, y + s * ox + c * oy, oz)
            a = yaw + self.yaw[i] + self.angles[i]
            d = np.column_stack((np.cos(a), np.sin(a)))
            n = len(a)
            froms.append(np.broadcast_to(origin, (n, 3)))
            dirs.append(d)
            lens.append(np.full(n, self.cfgs[i].range_max))
            counts.append(n)
        f = np.concatenate(froms)
        d = np.concatenate(dirs)
        length = np.minimum(np.concatenate(lens), _exit_distance(f[:, :2], d, bounds))
        t = f.copy()
        t[:, :2] += d * length[:, None]
        return f, t, length, counts

    def ranges(self, robot: int, fraction: np.ndarray, hit: np.ndarray,
               length: np.ndarray) -> np.ndarray:
        """REP 117 ranges of one scan from hit fractions: noise, -inf below min, +inf no return."""
        cfg = self.cfgs[robot]
        r = fraction * length
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
        tx = np.where(d[:, 0] > 0, (xmax - origin[:, 0]) / d[:, 0],
                      np.where(d[:, 0] < 0, (xmin - origin[:, 0]) / d[:, 0], np.inf))
        ty = np.where(d[:, 1] > 0, (ymax - origin[:, 1]) / d[:, 1],
                      np.where(d[:, 1] < 0, (ymin - origin[:, 1]) / d[:, 1], np.inf))
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
        dxw = new[:, 0] - old[:, 0]
        dyw = new[:, 1] - old[:, 1]
        c, s = np.cos(old[:, 2]), np.sin(old[:, 2])
        bx = c * dxw + s * dyw
        by = -s * dxw + c * dyw
        dth = _wrap(new[:, 2] - old[:, 2])
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
        self.pose[:, 2] = _wrap(yaw + dth)

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


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi
