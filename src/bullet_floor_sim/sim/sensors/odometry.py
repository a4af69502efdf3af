"""Odometry: wheel motion integrated with random-walk error and drift (world.yaml ``odometry:``)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np

from .. import small
from ..checks import positive
from ...errors import ConfigError
from ...geometry import wrap_angle, wrap_angles
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
        for k in ("noise_trans", "noise_rot", "noise_rot_per_m"):
            if getattr(self, k) < 0.0:
                raise ConfigError("%s: %s must be >= 0, got %r" % (where, k, getattr(self, k)))
        positive(self, where, ("rate",))


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
        # the same four per robot as Python floats, for _update_small (numpy's scalars made
        # every product in its loop a numpy call: 5.6 us a robot, one robot at 50 Hz)
        self._k_small = list(zip(self.k_trans.tolist(), self.k_rot.tolist(),
                                 self.k_rot_m.tolist(), self.drift.tolist()))
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
        for i, (o, nw, p, k) in enumerate(zip(old, new, self.pose.tolist(), self._k_small)):
            dxw, dyw = nw[0] - o[0], nw[1] - o[1]
            c, s = math.cos(o[2]), math.sin(o[2])
            bx, by = c * dxw + s * dyw, -s * dxw + c * dyw
            dth = wrap_angle(nw[2] - o[2])
            if noise is not None:
                k_trans, k_rot, k_rot_m, drift = k
                dist = math.hypot(bx, by)
                if dist > 0:
                    scale = 1.0 + noise[i][0] * k_trans * math.sqrt(dist) / max(dist, 1e-12)
                    bx, by = bx * scale, by * scale
                dth = dth + noise[i][1] * math.sqrt(k_rot ** 2 * abs(dth) + k_rot_m ** 2 * dist) \
                    + drift * dist
            c, s = math.cos(p[2]), math.sin(p[2])
            out.append((p[0] + c * bx - s * by, p[1] + s * bx + c * by,
                        wrap_angle(p[2] + dth)))
        self.pose[:] = out

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


KIND = SensorKind(OdometryConfig, Odometry.build)
