"""What the simulator makes solid in a SLAM-built map: unknown areas, slivers, gaps, speckle.

Every map here is drawn cell by cell, so each count is the number of cells drawn.
"""
from __future__ import annotations

import numpy as np
import pytest

from bullet_floor_sim.errors import ConfigError
from bullet_floor_sim.sim.floormap import map_from_grid
from bullet_floor_sim.sim.solidmap import MapHandling, solid_map

RES = 0.05


def room(gap: int = 0):
    """A 40 x 40-cell grid: unknown outside, a one-cell wall ring (rows/cols 5 and 34) around
    free cells; ``gap`` cells of the east wall (rows 18..) are free, with unknown behind."""
    g = np.full((40, 40), -1, dtype=np.int8)
    g[5:35, 5:35] = 100
    g[6:34, 6:34] = 0
    if gap:
        g[18:18 + gap, 34] = 0
    return g


def solid(g, **kw):
    return solid_map(map_from_grid(g, RES), MapHandling(**kw))


def test_unknown_outside_is_solid_and_counted():
    g = room()
    s = solid(g, close_gaps=0.0)
    sol = s.fmap.grid == 100
    assert sol[g < 0].all() and sol[g == 100].all() and not sol[g == 0].any()
    assert s.unknown_solid == int((g < 0).sum()) == 40 * 40 - 30 * 30
    assert s.report == ["700 unknown cells (2 m2) are solid (unknown: wall)"]


def test_unknown_free_leaves_only_the_walls():
    g = room()
    s = solid(g, unknown="free", close_gaps=0.0)
    assert ((s.fmap.grid == 100) == (g == 100)).all()
    assert s.unknown_solid == 0 and s.report == []


def test_a_one_cell_gap_is_closed_and_a_door_is_not():
    # free space on both sides of an interior wall (column 20) with a 1-cell and a 16-cell gap
    g = np.zeros((40, 40), dtype=np.int8)
    g[:, 20] = 100
    g[10, 20] = 0            # a one-cell slit: 0.05 m
    g[20:36, 20] = 0         # a 0.8 m door
    s = solid(g, close_gaps=0.15)
    sol = s.fmap.grid == 100
    assert sol[10, 20]
    assert not sol[20:36, 20].any()
    assert s.gap_cells == 1
    assert s.report == ["1 cells of gaps up to 0.15 m closed (clean.close_gaps)"]
    assert not solid(g, close_gaps=0.0).fmap.grid[10, 20]


def test_no_beam_path_out_of_a_wall_gap_into_unknown():
    g = room(gap=1)
    s = solid(g, close_gaps=0.15)
    sol = s.fmap.grid == 100
    assert sol[18, 34] and sol[18, 35]   # the gap and the unknown behind it
    assert not solid(g, close_gaps=0.0).fmap.grid[18, 34]   # 0: the gap stays


def test_slivers_of_unknown_in_an_open_hall_are_floor_and_wide_unknown_is_not():
    g = np.zeros((60, 60), dtype=np.int8)
    g[30, 10:50] = -1        # a one-cell unseen strip across the hall (40 cells)
    g[5:15, 5:15] = -1       # a 0.5 m unseen block (behind furniture)
    s = solid(g, close_gaps=0.0)
    sol = s.fmap.grid == 100
    assert not sol[30, 10:50].any()
    assert sol[5:15, 5:15].all()
    assert s.sliver_cells == 40 and s.unknown_solid == 100
    # with no sliver width every unknown cell is solid
    assert (solid(g, close_gaps=0.0, unknown_slivers=0.0).fmap.grid[30, 10:50] == 100).all()


def test_a_ray_fan_in_unknown_space_stays_solid():
    # every other column is a free ray through unknown space: half free, half unknown
    g = np.full((60, 60), -1, dtype=np.int8)
    g[:, ::2] = 0
    s = solid(g, close_gaps=0.0)
    sol = s.fmap.grid == 100
    # the unknown strips are 1 cell wide, but around an unknown column 6 of the 13 columns of
    # the 0.6 m window are free (46 % < 50 %): no sliver, the fan stays solid
    assert sol[:, 1::2].all() and s.sliver_cells == 0
    closed = solid(g, close_gaps=0.15).fmap.grid == 100
    assert closed[10:50, 10:50].all()   # with the gaps closed, no free ray is left


def test_speckle_is_dropped_only_when_asked_and_only_small_isolated_blobs():
    g = np.zeros((40, 40), dtype=np.int8)
    g[10, 10] = 100                       # one cell: 0.0025 m2
    g[20:22, 20:22] = 100                 # four cells: 0.01 m2
    g[30:36, 30:36] = 100                 # 36 cells: a pillar
    kept = solid(g, close_gaps=0.0, speckle=0.0)
    assert kept.speckle_cells == 0 and (kept.fmap.grid == 100).sum() == 41
    # the default, 0.005 m2: one- and two-cell blobs go, the four-cell one stays
    d = solid(g, close_gaps=0.0).fmap.grid == 100
    assert not d[10, 10] and d[20:22, 20:22].all() and d[30:36, 30:36].all()
    s = solid(g, close_gaps=0.0, speckle=0.01)
    sol = s.fmap.grid == 100
    assert not sol[10, 10] and not sol[20:22, 20:22].any() and sol[30:36, 30:36].all()
    assert (s.speckle_blobs, s.speckle_cells) == (2, 5)
    assert s.report == ["2 occupied blobs (5 cells) of at most 0.01 m2 removed (clean.speckle)"]


def test_the_users_map_is_not_changed():
    g = room(gap=2)
    before = g.copy()
    fmap = map_from_grid(g, RES)
    solid_map(fmap, MapHandling(speckle=1.0))
    assert (fmap.grid == before).all()


@pytest.mark.parametrize("kw, msg", [
    ({"unknown": "maybe"}, r"w.yaml: unknown must be one of wall \| free, got 'maybe'"),
    ({"close_gaps": -1}, r"w.yaml: clean.close_gaps must be a number of metres >= 0, got -1"),
    ({"speckle": float("nan")}, r"w.yaml: clean.speckle must be a number of square metres"),
    ({"unknown_slivers": "x"}, r"w.yaml: clean.unknown_slivers must be a number of metres"),
])
def test_bad_handling_is_one_line_naming_the_file(kw, msg):
    with pytest.raises(ConfigError, match=msg):
        MapHandling(**kw).check("w.yaml")


def test_the_derived_map_is_kept_on_disk_and_read_back_the_same(tmp_path, monkeypatch):
    import os

    from scipy.ndimage import distance_transform_edt

    monkeypatch.setenv("BULLET_FLOOR_SIM_CACHE", str(tmp_path))
    KW = dict(close_gaps=0.15, speckle=0.0)   # a handling that changes the grid
    g = room(gap=1)
    first = solid(g, **KW)
    entries = os.listdir(tmp_path / "maps")
    assert len(entries) == 1 and entries[0].endswith(".npz")
    # the distance field is the Euclidean distance (in cells) to the nearest solid cell
    occ = first.fmap.occupied
    assert np.allclose(first.distance, distance_transform_edt(~occ))
    again = solid(g, **KW)                       # a new FloorMap of the same grid: from the disk
    assert again is not first
    assert np.array_equal(again.fmap.grid, first.fmap.grid)
    assert np.array_equal(again.distance, first.distance)
    assert again.fmap.rectangles() == first.fmap.rectangles()
    assert (again.report, again.gap_cells, again.unknown_solid) == (
        first.report, first.gap_cells, first.unknown_solid)
    # another handling, another entry; an edited grid, another entry
    solid(g, close_gaps=0.0)
    g2 = g.copy()
    g2[20, 20] = 100
    assert solid(g2, **KW).fmap.grid[20, 20] == 100
    assert len(os.listdir(tmp_path / "maps")) == 3
    # a corrupt entry is derived again (and rewritten)
    for name in os.listdir(tmp_path / "maps"):
        (tmp_path / "maps" / name).write_bytes(b"not an npz")
    assert np.array_equal(solid(g, **KW).fmap.grid, first.fmap.grid)
    # an empty BULLET_FLOOR_SIM_CACHE turns the cache off
    monkeypatch.setenv("BULLET_FLOOR_SIM_CACHE", "")
    assert solid(g, **KW).report == first.report


def test_a_map_being_built_keeps_its_specks():
    # one occupied cell in free space: a wall seen once; planning on a map being built
    # (unknown passable) keeps it, the world's default drops it (0.0025 m2 < 0.005)
    from bullet_floor_sim.nav.grid import PlannerConfig, PlanningGrid
    from bullet_floor_sim.sim.floormap import map_from_grid
    from bullet_floor_sim.sim.solidmap import while_mapping

    g = np.zeros((40, 40), dtype=np.int8)
    g[20, 20] = 100
    fmap = map_from_grid(g, 0.05)
    building = PlanningGrid(fmap, PlannerConfig(resolution=0.05, unknown_is_obstacle=False))
    world = PlanningGrid(fmap, PlannerConfig(resolution=0.05))
    assert not np.isfinite(building.cost[20, 20]) and np.isfinite(world.cost[20, 20])
    assert while_mapping().speckle == 0.0 and while_mapping().unknown == "free"
