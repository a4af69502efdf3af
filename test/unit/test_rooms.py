"""Automatic room segmentation and the ROIs drawn from it (building/rooms.py), on synthetic
floors of known geometry (no ROS)."""
from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

from bullet_floor_sim.building.rooms import (
    RoomConfig,
    auto_rois,
    rooms_to_rois,
    segment_rooms,
    write_rois,
)
from bullet_floor_sim.data.rois import load_rois, validate_roi
from bullet_floor_sim.people.markov.adjacency import vertex_adjacency
from bullet_floor_sim.sim.floormap import map_from_grid
from bullet_floor_sim.sim.solidmap import MapHandling

RES = 0.05
W, H = 12.0, 8.0
WALL = 0.15
# the hand-drawn ground truth (map metres, x0, y0, x1, y1): a corridor along the bottom and
# three rooms above it, each with a 0.9 m door into the corridor
CORRIDOR = (0.1, 0.1, W - 0.1, 1.6)
ROOMS = ((0.1, 1.75, 4.0, H - 0.1), (4.15, 1.75, 8.0, H - 0.1), (8.15, 1.75, W - 0.1, H - 0.1))
DOORS_X = (1.5, 5.5, 9.5)


def cell(m, res=RES):
    return int(round(m / res))


def building(res=RES, furniture=False, door_between=False):
    """The grid (row 0 = bottom): outer walls 0.1 m, corridor/room wall and room walls 0.15 m."""
    grid = np.zeros((cell(H, res), cell(W, res)), dtype=np.int8)

    def rect(x0, y0, x1, y1, value=100):
        grid[cell(y0, res):cell(y1, res), cell(x0, res):cell(x1, res)] = value

    rect(0, 0, W, 0.1)
    rect(0, H - 0.1, W, H)
    rect(0, 0, 0.1, H)
    rect(W - 0.1, 0, W, H)
    rect(0, 1.6, W, 1.6 + WALL)
    rect(4.0, 1.75, 4.0 + WALL, H)
    rect(8.0, 1.75, 8.0 + WALL, H)
    for x in DOORS_X:
        rect(x, 1.6, x + 0.9, 1.6 + WALL, 0)
    if door_between:
        rect(4.0, 5.0, 4.0 + WALL, 5.9, 0)
    if furniture:
        rect(1.5, 4.0, 2.5, 4.6)  # a table, 0.6 m²
        for x, y in ((1.0, 3.0), (3.0, 6.5), (6.0, 1.0), (10.0, 4.0)):
            rect(x, y, x + 0.3, y + 0.3)  # chairs, bins
    return grid


def truth(res=RES):
    """Hand-drawn ground truth labels: 1 corridor, 2..4 rooms (door cells in none)."""
    gt = np.zeros((cell(H, res), cell(W, res)), dtype=np.int64)
    for k, (x0, y0, x1, y1) in enumerate((CORRIDOR,) + ROOMS):
        gt[cell(y0, res):cell(y1, res), cell(x0, res):cell(x1, res)] = k + 1
    return gt


def recall_precision(gt, labels):
    """ipa's recall (mean over GT regions of the best overlap / region) and precision (mean
    over segments of the best overlap / segment)."""
    n_gt, n_seg = int(gt.max()), int(labels.max())
    overlap = np.bincount(labels.ravel() * (n_gt + 1) + gt.ravel(),
                          minlength=(n_seg + 1) * (n_gt + 1)).reshape(n_seg + 1, n_gt + 1)[1:, 1:]
    recall = np.mean(overlap.max(axis=0) / np.bincount(gt.ravel())[1:])
    precision = np.mean(overlap.max(axis=1) / np.bincount(labels.ravel())[1:])
    return float(recall), float(precision)


def world_centre(fmap, x0, y0, x1, y1):
    """Map-frame point of the centre of a rectangle given in grid metres."""
    col, row = (x0 + x1) / 2 / fmap.resolution - 0.5, (y0 + y1) / 2 / fmap.resolution - 0.5
    x, y = fmap.cell_to_world(col, row)
    return float(x), float(y)


# --------------------------------------------------------------------------------------------
# segmentation
# --------------------------------------------------------------------------------------------


def test_finds_the_three_rooms_and_the_corridor():
    grid = building()
    labels = segment_rooms(grid != 100, RES)
    assert labels.dtype == np.int32
    assert labels.max() == 4
    recall, precision = recall_precision(truth(), labels)
    assert recall == pytest.approx(1.0, abs=0.005)
    assert precision == pytest.approx(1.0, abs=0.01)  # the door cells are in no GT region


def test_every_free_cell_has_a_room_and_walls_none():
    grid = building()
    labels = segment_rooms(grid != 100, RES)
    assert (labels[grid != 100] > 0).all()
    assert (labels[grid == 100] == 0).all()


def test_furniture_does_not_split_rooms():
    grid = building(furniture=True)
    labels = segment_rooms(grid != 100, RES)
    assert labels.max() == 4
    assert (labels[grid == 100] == 0).all()
    recall, precision = recall_precision(truth(), labels)
    assert recall > 0.98  # the furniture cells are in the GT, in no segment
    assert precision == pytest.approx(1.0, abs=0.01)


def test_parameters_are_in_metres_not_cells():
    for res in (0.05, 0.1):
        labels = segment_rooms(building(res) != 100, res)
        assert labels.max() == 4
        recall, precision = recall_precision(truth(res), labels)
        assert min(recall, precision) > 0.97


def test_a_wide_opening_joins_two_rooms():
    grid = building()
    grid[cell(1.75):cell(5.0), cell(4.0):cell(4.0 + WALL)] = 0  # 3.25 m gap in a room wall
    labels = segment_rooms(grid != 100, RES)
    assert labels.max() == 3
    assert labels[cell(4.0), cell(2.0)] == labels[cell(4.0), cell(6.0)]
    loose = RoomConfig(door_ratio=0.0, max_door_width=0.0)  # every pass joins
    assert segment_rooms(building() != 100, RES, loose).max() == 1


def test_a_wall_piece_between_two_doors_is_no_furniture():
    grid = building(door_between=True)  # leaves a 0.95 m² wall piece touching no other wall
    labels = segment_rooms(grid != 100, RES, RoomConfig(furniture_area=2.0))
    assert labels.max() == 4


def test_small_islands_and_empty_maps():
    free = np.zeros((40, 40), dtype=bool)
    assert segment_rooms(free, RES).max() == 0
    free[5:10, 5:10] = True  # 0.0625 m²: below min_room_area, no room
    free[15:35, 15:35] = True  # 1 m x 1 m... 1 m²
    labels = segment_rooms(free, RES, RoomConfig(min_room_area=0.5))
    assert labels.max() == 1
    assert (labels[5:10, 5:10] == 0).all() and (labels[15:35, 15:35] == 1).all()
    with pytest.raises(ValueError):
        segment_rooms(free, 0.0)


# --------------------------------------------------------------------------------------------
# ROIs
# --------------------------------------------------------------------------------------------


def rois_of(grid, origin=(0.0, 0.0, 0.0)):
    fmap = map_from_grid(grid, RES, origin)
    labels = segment_rooms(grid != 100, RES)
    return fmap, labels, rooms_to_rois(labels, fmap, "synthetic", config="2")


def test_rois_chain_doors_but_not_walls():
    fmap, labels, rois = rois_of(building())
    assert [r.id for r in rois] == ["1", "2", "3", "4"]
    corridor = [k for k, r in enumerate(rois) if r.type == "corridor"]
    assert len(corridor) == 1
    nb = vertex_adjacency([r.vertices for r in rois], 0.2)
    c = corridor[0]
    assert nb[c] == {k for k in range(4) if k != c}
    for k in range(4):
        if k != c:
            assert nb[k] == {c}  # rooms side by side with a wall between: not neighbours


def test_rois_chain_a_door_between_two_rooms():
    _, _, rois = rois_of(building(door_between=True))
    nb = vertex_adjacency([r.vertices for r in rois], 0.2)
    rooms = [k for k, r in enumerate(rois) if r.type == "room"]
    degrees = sorted(len(nb[k]) for k in rooms)
    assert degrees == [1, 2, 2]  # the two rooms with the door see each other and the corridor


def test_rois_are_valid_inside_the_map_and_respect_the_origin():
    origin = (-3.0, 2.0, 0.0)
    fmap, labels, rois = rois_of(building(), origin)
    xmin, ymin, xmax, ymax = fmap.bounds()
    polygons = [Polygon(r.vertices) for r in rois]
    for roi, poly in zip(rois, polygons):
        validate_roi(roi)
        assert roi.map_name == "synthetic" and roi.config == "2"
        assert xmin <= poly.bounds[0] and poly.bounds[2] <= xmax
        assert ymin <= poly.bounds[1] and poly.bounds[3] <= ymax
    for rect in (CORRIDOR,) + ROOMS:
        x, y = world_centre(fmap, *rect)
        inside = [k for k, p in enumerate(polygons) if p.contains(Point(x, y))]
        assert len(inside) == 1
        # and the ROI covers most of the region, 0.15 m off the walls
        x0, y0, x1, y1 = rect
        area = (x1 - x0 - 0.3) * (y1 - y0 - 0.3)
        assert polygons[inside[0]].area == pytest.approx(area, rel=0.1)
    for a in range(len(polygons)):
        for b in range(a + 1, len(polygons)):
            assert polygons[a].intersection(polygons[b]).area < 1e-9


def test_rotated_origin():
    fmap, _, rois = rois_of(building(), (1.0, 2.0, np.pi / 2))
    poly = Polygon(rois[0].vertices)
    xmin, ymin, xmax, ymax = fmap.bounds()
    assert xmin - 1e-6 <= poly.bounds[0] and poly.bounds[2] <= xmax + 1e-6
    assert poly.bounds[3] - poly.bounds[1] > poly.bounds[2] - poly.bounds[0]  # the corridor turned


def test_auto_rois_and_write_rois_roundtrip(tmp_path, monkeypatch):
    monkeypatch.setenv("BULLET_FLOOR_SIM_CACHE", "")
    grid = building(furniture=True)
    fmap = map_from_grid(grid, RES, (5.0, -1.0, 0.0))
    rois = auto_rois(fmap, MapHandling(), "synthetic")
    assert len(rois) == 4
    path = str(tmp_path / "rois.yaml")
    write_rois(rois, path)
    again = load_rois(path)
    assert [(r.id, r.type, r.map_name, r.config) for r in again] == \
        [(r.id, r.type, r.map_name, r.config) for r in rois]
    for a, b in zip(again, rois):
        assert np.allclose(a.vertices, b.vertices)
