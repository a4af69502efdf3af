"""Odometry: wheel motion integrated with random-walk error and drift (world.yaml ``odometry:``)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np

from .. import small
from ..checks import check_numbers
from ...geometry import wrap_angles
from .base import NEVER, SensorKind

__all__ = ["OdometryConfig", "Odometry", "KIND"]


@dataclass(frozen=True)
class OdometryConfig:
    """Odometry integrated from the wheel motion, with error.

    Per step, the travelled distance gets Gaussian error of std ``noise_trans`` x distance and
    the rotation ``noise_rot`` x |rotation| + ``noise_rot_per_m`` x distance; ``drift_yaw`` adds
    a systematic yaw error in radians per metre travelled (uneven wheels). Defaults are small
    so that amcl has something to correct.
    """

    noise_trans: float = 0.01
    noise_rot: float = 0.01
    noise_rot_per_m: float = 0.005
    drift_yaw: float = 0.0
    rate: float = 50.0

    def validate(self, where: str) -> None:
        """Raise ConfigError if a value is out of range."""
        check_numbers(self, ("noise_trans", "noise_rot", "noise_rot_per_m"), where, strict=False)
        check_numbers(self, ("rate",), where)


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
        # the same four as one (N, 4) array, for _update_small's compiled loop
        self._k_small = np.column_stack((self.k_trans, self.k_rot, self.k_rot_m,
                                         self.drift)).reshape(len(cfgs), 4)
        self.noisy = bool(np.any(self.k_trans) or np.any(self.k_rot) or np.any(self.k_rot_m)
                          or np.any(self.drift))
        self.pose = np.zeros((len(cfgs), 3))
        self.rates = [c.rate for c in cfgs]
        self.next_ns = NEVER      # (the world's: see build)
        self.period_ns = 0
        self._ref: Optional[np.ndarray] = None   # the ground truth it has integrated up to
        self._motion = 0                         # World.motion then

    @classmethod
    def build(cls, world, cfgs: Sequence[OdometryConfig]) -> "Odometry":
        """The odometry of ``world``'s robots, integrated every ``period_ns``: the highest
        rate of them, in whole steps."""
        odo = cls(cfgs, world.rng)
        every = max(1, int(round(1e9 / max(odo.rates or [1.0]) / world.clock.step_ns)))
        odo.period_ns = every * world.clock.step_ns
        odo.restart(world.clock.now_ns)
        odo._ref, odo._motion = world.pose.copy(), world.motion
        return odo

    def read(self, world) -> List:
        """Integrate up to the current ground truth; no readings (``World.view`` and
        ``World.snapshot`` give the pose)."""
        self.catch_up(world)
        self.next_ns += self.period_ns
        return []

    def catch_up(self, world) -> None:
        """Integrate the motion since the last call, if the world moved since."""
        if world.motion == self._motion:
            return
        assert self._ref is not None   # build sets it
        self.update(self._ref, world.pose)
        self._ref[:] = world.pose
        self._motion = world.motion

    def update(self, old: np.ndarray, new: np.ndarray) -> None:
        """Integrate the motion from ground-truth poses ``old`` to ``new`` (N, 3)."""
        if len(old) <= small.SMALL_N:
            self._update_small(old, new)
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

    def _update_small(self, old: np.ndarray, new: np.ndarray) -> None:
        """``update`` robot by robot in one compiled loop (``_integrate_small``; for a few
        robots numpy's per-call cost dominates); the same formulas and the same random
        draws."""
        noise = self.rng.standard_normal((len(old), 2)) if self.noisy else _NO_NOISE
        _integrate_small(old, new, self.pose, noise, self._k_small)

    def restart(self, now_ns: int) -> None:
        """Integrated first one period after ``now_ns``."""
        self.next_ns = now_ns + self.period_ns

    def moved(self, world, rows: Sequence[int]) -> None:
        """Robots ``rows`` were teleported (``World.set_pose``, after ``catch_up``): their
        odometry goes on from where it is, without the jump."""
        assert self._ref is not None   # build sets it
        self._ref[list(rows)] = world.pose[list(rows)]

    def reset(self, world, rows: Sequence[int]) -> None:
        """Odometry of ``rows`` back to (0, 0, 0), integrated on from their poses now (the
        world caught up with the old poses before it moved them)."""
        rows = list(rows)
        self.pose[rows] = 0.0
        assert self._ref is not None   # build sets it
        self._ref[rows] = world.pose[rows]


#: ``_update_small``'s noise when the odometry is exact: no draws
_NO_NOISE = np.zeros((0, 2))


def _integrate_small(old, new, pose, noise, k):  # type: ignore
    """``Odometry.update``'s formulas robot by robot: the body-frame motion from ground truth
    ``old`` to ``new``, scaled and turned by ``noise`` (N, 2) standard normal draws (none:
    exact) with gains ``k`` (N, 4: noise_trans, noise_rot, noise_rot_per_m, drift_yaw),
    added to ``pose`` in place. Compiled by numba (math's functions, and Python's float
    modulo for the wrap: the plain-Python loop this replaced gave the same bits)."""
    pi, two_pi = math.pi, 2.0 * math.pi
    for i in range(old.shape[0]):
        dxw, dyw = new[i, 0] - old[i, 0], new[i, 1] - old[i, 1]
        c, s = math.cos(old[i, 2]), math.sin(old[i, 2])
        bx, by = c * dxw + s * dyw, -s * dxw + c * dyw
        dth = (new[i, 2] - old[i, 2] + pi) % two_pi - pi
        if noise.shape[0]:
            dist = math.hypot(bx, by)
            if dist > 0:
                scale = 1.0 + noise[i, 0] * k[i, 0] * math.sqrt(dist) / max(dist, 1e-12)
                bx, by = bx * scale, by * scale
            dth = dth + noise[i, 1] * math.sqrt(k[i, 1] ** 2 * abs(dth) + k[i, 2] ** 2 * dist) \
                + k[i, 3] * dist
        c, s = math.cos(pose[i, 2]), math.sin(pose[i, 2])
        x, y = pose[i, 0] + c * bx - s * by, pose[i, 1] + s * bx + c * by
        pose[i, 0], pose[i, 1], pose[i, 2] = x, y, (pose[i, 2] + dth + pi) % two_pi - pi


try:   # as sim/grid_rays.py: compiled where numba is installed (the venv's requirements)
    import numba
    _integrate_small = numba.njit(cache=True)(_integrate_small)
except ImportError:   # pragma: no cover
    pass


KIND = SensorKind(OdometryConfig, Odometry.build)
