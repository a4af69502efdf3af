"""Kinematic robots: velocities toward their targets within the drive limits, and poses
integrated exactly for constant body velocity over a step."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["advance_small", "integrate", "travel_small"]


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
    """Drive limits and pose integration of World._physics_step for a few robots: the same
    formulas as ``Drive.apply`` and ``integrate``, robot by robot in one compiled loop
    (``_advance``; for a few robots numpy's per-call cost dominates). The velocities change
    in place; the poses are a new array, as ``integrate`` gives."""
    lim = world._limits_small
    if lim is None or lim[0] != dt:
        vmax = np.zeros((world.n, 3))
        amax = np.zeros((world.n, 3))
        for rows, drive in world._drives:
            vmax[rows], amax[rows] = drive.vmax, drive.amax
        lim = world._limits_small = (dt, vmax, amax * dt)
    _, vmax, step = lim
    pose = np.empty(world.pose.shape)   # (numpy's empty_like dispatches: a microsecond)
    _advance(world.target, world.vel, world.pose, vmax, step, float(dt), pose)
    world.pose = pose


def _advance(target, vel, pose, vmax, step, dt, out):  # type: ignore
    """``advance_small``'s loop: each velocity toward its ``target`` within +-``vmax`` and
    +-``step`` of where it was (in place), then ``out`` the pose after ``dt`` along the arc,
    as ``integrate`` (math's sine and cosine, which numba calls too: the plain-Python loop
    this replaced gave the same bits)."""
    for i in range(pose.shape[0]):
        for k in range(3):
            vel[i, k] = min(max(min(max(target[i, k], -vmax[i, k]), vmax[i, k]),
                                vel[i, k] - step[i, k]), vel[i, k] + step[i, k])
        half = vel[i, 2] * (0.5 * dt)
        kk = (math.sin(half) / half if half else 1.0) * dt
        a = pose[i, 2] + half
        c, s = math.cos(a), math.sin(a)
        vx, vy = vel[i, 0] * kk, vel[i, 1] * kk
        out[i, 0] = pose[i, 0] + c * vx - s * vy
        out[i, 1] = pose[i, 1] + s * vx + c * vy
        out[i, 2] = a + half


def travel_small(travel, vel, dt):  # type: ignore
    """The wheels' travel (N, 2: metres driven, radians turned) on by ``vel`` (vx, w) over
    ``dt``, in place, and whether any robot moves (any velocity not 0): the few-robot step
    after its collision check (one compiled call, where numpy took two and Python three)."""
    moving = False
    for i in range(travel.shape[0]):
        travel[i, 0] = travel[i, 0] + vel[i, 0] * dt
        travel[i, 1] = travel[i, 1] + vel[i, 2] * dt
        moving = moving or vel[i, 0] != 0.0 or vel[i, 1] != 0.0 or vel[i, 2] != 0.0
    return moving


try:   # as sim/grid_rays.py: compiled where numba is installed (the venv's requirements)
    import numba
    _advance = numba.njit(cache=True)(_advance)
    travel_small = numba.njit(cache=True)(travel_small)
except ImportError:   # pragma: no cover
    pass
