"""sim/grid_rays.py: rays walked cell by cell on the solid grid meet the walls where the ray
test on the wall mesh does (worlds/simple exactly, office to Bullet's own edge tolerance),
and where the known geometry of worlds/simple says."""
from __future__ import annotations

import dataclasses
import math
import os
import sys

import numpy as np
import pytest

from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim import grid_rays
from bullet_floor_sim.sim.config import load_world_config, resolve_world
from bullet_floor_sim.sim.sensors.rays import cast_rays
from bullet_floor_sim.sim.world import World

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from simple_room import expected_range  # noqa: E402

pytestmark = pytest.mark.skipif(not grid_rays.available(), reason="numba not installed")


def _world(name):
    cfg = load_world_config(resolve_world(name, worlds_dir()))
    return World(dataclasses.replace(cfg, robots=[]), seed=1)


def test_simple_room_ranges_match_the_known_geometry():
    w = _world("simple")
    try:
        g = grid_rays.GridRays(w.solid.fmap)
        points = [(1.0, 1.0), (3.0, 2.0), (5.0, 3.5), (4.25, 0.5), (0.5, 3.0)]
        angles = np.radians(np.arange(0.3, 360.0, 7.5))      # no ray grazes a corner
        o = np.array([p for p in points for _ in angles], dtype=float)
        a = np.tile(angles, len(points))
        d = np.c_[np.cos(a), np.sin(a)]
        got = g.cast(o, d, np.zeros(len(o)), np.full(len(o), 20.0))
        want = [expected_range(x, y, t) for (x, y), t in zip(o, a)]
        np.testing.assert_allclose(got, want, atol=1e-9)
        # a ray that ends short of the wall meets nothing
        assert g.cast(o[:1], d[:1], np.zeros(1), np.full(1, 0.5))[0] == math.inf
    finally:
        w.close()


def test_rays_exactly_along_the_axes_meet_the_walls():
    # a direction with a component exactly 0 (a lidar turned by a whole quarter gives one):
    # the crossing along that axis is never, not a corner (it read +inf through the wall)
    w = _world("simple")
    try:
        g = grid_rays.GridRays(w.solid.fmap)
        points = [(1.0, 1.0), (3.0, 2.0), (2.3, 1.8)]
        d = np.array([(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)])
        o = np.array([p for p in points for _ in d], dtype=float)
        dirs = np.tile(d, (len(points), 1))
        got = g.cast(o, dirs, np.zeros(len(o)), np.full(len(o), 20.0))
        want = [expected_range(x, y, math.atan2(v, u)) for (x, y), (u, v) in zip(o, dirs)]
        assert np.isfinite(got).all()
        np.testing.assert_allclose(got, want, atol=1e-9)
    finally:
        w.close()


@pytest.mark.parametrize("name", ["simple", "office"])
def test_the_grid_meets_the_walls_where_the_mesh_does(name):
    """2000 rays from free cells in every direction: the same hits and, but for rays that
    clip a cell's corner by less than Bullet's edge tolerance, the same distances."""
    w = _world(name)
    try:
        g = grid_rays.GridRays(w.solid.fmap)
        rng = np.random.default_rng(4)
        free = np.argwhere(w._clearance > 0.3)
        cells = free[rng.integers(0, len(free), 2000)]
        xs, ys = w.solid.fmap.cell_to_world(cells[:, 1], cells[:, 0])
        a = rng.uniform(-math.pi, math.pi, 2000)
        d = np.c_[np.cos(a), np.sin(a)]
        o = np.c_[xs, ys, np.full(2000, 0.3)]
        start, end = np.full(2000, 0.2), np.full(2000, 25.0)
        froms, tos = o.copy(), o.copy()
        froms[:, :2] += d * start[:, None]
        tos[:, :2] += d * end[:, None]
        frac, ids = cast_rays(w.client, froms, tos, 1)
        mesh = np.where(ids >= 0, start + frac * (end - start), np.inf)
        grid = g.cast(o, d, start, end)
        assert (np.isfinite(mesh) == np.isfinite(grid)).all()
        hit = np.isfinite(mesh)
        close = np.abs(mesh[hit] - grid[hit]) < 1e-5
        assert close.mean() > 0.995, close.mean()
        assert (grid[hit][~close] > mesh[hit][~close]).all()   # Bullet's tolerance: earlier
    finally:
        w.close()


def test_the_world_walks_its_walls_on_the_grid_unless_told_not_to(monkeypatch):
    w = _world("simple")
    try:
        assert w.walls_on_grid
    finally:
        w.close()
    monkeypatch.setenv("BULLET_FLOOR_SIM_GRID_RAYS", "0")
    w = _world("simple")
    try:
        assert not w.walls_on_grid
    finally:
        w.close()


@pytest.mark.parametrize("name", ["office", "malaga_campus"])
def test_rays_that_jump_through_open_floor_end_where_walking_every_cell_ends(name):
    """3000 rays from free cells, some starting in walls, some cut short: jumping through
    free space by each cell's room (the distance transform) finds the same crossings, to
    1e-9 m, as walking every cell (no room is enough to jump); there is room to jump."""
    w = _world(name)
    try:
        g = grid_rays.GridRays(w.solid.fmap)
        rng = np.random.default_rng(7)
        rows, cols = np.nonzero(np.ones_like(g.room))
        pick = rng.integers(0, len(rows), 3000)
        xs, ys = w.solid.fmap.cell_to_world(cols[pick] + rng.uniform(-0.5, 0.5, 3000),
                                            rows[pick] + rng.uniform(-0.5, 0.5, 3000))
        a = rng.uniform(-math.pi, math.pi, 3000)
        o, d = np.c_[xs, ys], np.c_[np.cos(a), np.sin(a)]
        start = rng.uniform(0.0, 0.5, 3000)
        end = start + rng.choice([0.7, 5.0, 40.0], 3000)
        jumped = g.cast(o, d, start, end)
        assert g.room.max() >= 10
        g.jump = math.inf
        walked = g.cast(o, d, start, end)
        assert np.array_equal(np.isfinite(jumped), np.isfinite(walked))
        assert 0.2 < np.isfinite(walked).mean() < 1.0
        ok = np.isfinite(walked)
        np.testing.assert_allclose(jumped[ok], walked[ok], rtol=0, atol=1e-9)
    finally:
        w.close()


def test_beams_along_grid_lines_end_where_walking_every_cell_ends():
    """Lidar-style beams (yaw + i degrees: cos and sin leave 1e-16 where 0 is meant) from
    points on grid lines of a grid of random wall stubs: a beam that runs along a grid line
    and grazes a stub's end meets it, or not, as the cell-by-cell walk does (a jump took the
    side of the line afresh: 2 of 120,000 beams differed by up to 0.75 m)."""
    import types

    rng = np.random.default_rng(3)
    h, w = 120, 150
    solid = np.zeros((h, w), bool)
    for _ in range(40):
        r, c = rng.integers(0, h), rng.integers(0, w)
        solid[r:r + rng.integers(1, 15), c:c + rng.integers(1, 3)] = True
        r, c = rng.integers(0, h), rng.integers(0, w)
        solid[r:r + rng.integers(1, 3), c:c + rng.integers(1, 15)] = True
    bad = 0
    for org in [(-2.3, 1.7), (-10.0, -60.0), (0.0, 0.0)]:
        g = grid_rays.GridRays(types.SimpleNamespace(occupied=solid, resolution=0.05,
                                                     origin=(org[0], org[1], 0.0)))
        n = 40000
        u, v = rng.uniform(0, w, n), rng.uniform(0, h, n)
        half = np.arange(n) % 2 == 0
        v[half], u[~half] = np.round(v[half]), np.round(u[~half])
        o = np.c_[org[0] + u * 0.05, org[1] + v * 0.05, np.full(n, 0.3)]
        yaw = rng.choice([0.0, math.pi / 2, -math.pi / 2, math.pi, 0.1, -1.3], n)
        a = yaw + (-math.pi + rng.integers(0, 360, n) * math.radians(1.0))
        d = np.c_[np.cos(a), np.sin(a)]
        start, end = np.zeros(n), np.full(n, 12.0)
        jumped = g.cast(o, d, start, end)
        g.jump = math.inf
        walked = g.cast(o, d, start, end)
        both = np.isfinite(jumped) & np.isfinite(walked)
        bad += int((np.isfinite(jumped) != np.isfinite(walked)).sum()
                   + (np.abs(jumped[both] - walked[both]) > 1e-9).sum())
    assert bad == 0
