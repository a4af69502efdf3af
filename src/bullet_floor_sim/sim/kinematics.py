"""Kinematic robots: velocities toward their targets within the drive limits, and poses
integrated exactly for constant body velocity over a step."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["advance_small", "integrate"]


def integrate(pose: np.ndarray, vel: np.ndarray, dt: float) -> np.ndarray:
    """Pose after ``dt`` at constant body velocity (vx, vy, w), for every row (yaw unwrapped).

    The displacement is the chord of the arc, R(yaw + dth/2) (vx, vy) dt sinc(dth/2), with
    sinc(h) = sin(h) / h: exact at any step rate (a Stage-like 10 Hz step ends an arc where
    a 100 Hz one does). The truncated series 1 - h^2/6 used before was off by h^4/120.
    """
    half = vel[:, 2] * (0.5 * dt)
    k = np.sinc(half * (1.0 / math.pi)) * dt
    a = pose[:, 2] + half
    c = np.cos(a)
    s = np.sin(a)
    vx = vel[:, 0] * k
    vy = vel[:, 1] * k
    out = np.empty_like(pose)
    out[:, 0] = pose[:, 0] + c * vx - s * vy
    out[:, 1] = pose[:, 1] + s * vx + c * vy
    out[:, 2] = a + half
    return out


def advance_small(world: Any, dt: float) -> None:
    """Drive limits and pose integration of World._physics_step in plain floats, robot by
    robot: the same formulas as ``Drive.apply`` and ``integrate``
    (for a few robots numpy's per-call cost dominates)."""
    lim = world._limits_small
    if lim is None or lim[0] != dt:
        vmax = np.zeros((world.n, 3))
        amax = np.zeros((world.n, 3))
        for rows, drive in world._drives:
            vmax[rows], amax[rows] = drive.vmax, drive.amax
        lim = world._limits_small = (dt, vmax.tolist(), (amax * dt).tolist())
    _, vmax, step = lim
    vel, pose = [], []
    for t, v, p, vm, st in zip(world.target.tolist(), world.vel.tolist(), world.pose.tolist(),
                               vmax, step):
        nv = [min(max(min(max(t[k], -vm[k]), vm[k]), v[k] - st[k]), v[k] + st[k])
              for k in (0, 1, 2)]
        half = nv[2] * (0.5 * dt)
        kk = (math.sin(half) / half if half else 1.0) * dt
        a = p[2] + half
        c, s = math.cos(a), math.sin(a)
        vx, vy = nv[0] * kk, nv[1] * kk
        vel.append(nv)
        pose.append((p[0] + c * vx - s * vy, p[1] + s * vx + c * vy, a + half))
    world.vel[:] = vel
    world.pose = np.array(pose)
