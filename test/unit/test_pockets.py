"""nav/pockets.py: dead ends behind snug passages, on hand-made maps."""
import numpy as np

from bullet_floor_sim.nav.planner import PlanningGrid
from bullet_floor_sim.nav.pockets import floor_pockets
from bullet_floor_sim.sim.floormap import map_from_grid

RES = 0.05


def hall_with_rooms(second_door: bool):
    """A hall 12 x 4 m; north of it, behind a 0.2 m wall, a room 2.5 x 2.5 m (x 3.75-6.25)
    with a 0.75 m doorway at x 5 and, with ``second_door``, another at x 4.2; and a room
    5.45 x 3 m (x 6.5-11.95) with a 0.75 m doorway at x 9."""
    g = np.full((int(7.5 / RES), int(12.0 / RES)), 100, dtype=np.int8)
    g[1:int(4.0 / RES), 1:-1] = 0
    g[int(4.2 / RES):int(6.7 / RES), int(3.75 / RES):int(6.25 / RES)] = 0
    g[int(4.2 / RES):int(7.2 / RES), int(6.5 / RES):-1] = 0
    for x in [5.0, 9.0] + ([4.2] if second_door else []):
        c = int(round(x / RES))
        g[int(4.0 / RES):int(4.2 / RES), c - 7:c + 8] = 0       # 0.75 m
    return PlanningGrid(map_from_grid(g, RES))


def _part(grid, labels, x, y):
    c, r = grid.to_cell(x, y)
    return labels[r, c]


def test_a_small_room_with_one_snug_way_in_is_a_pocket_and_its_doorway_with_it():
    grid = hall_with_rooms(second_door=False)
    labels, pocket = floor_pockets(grid, 0.04, 1.5)
    small, door, hall = (_part(grid, labels, 5.0, y) for y in (5.5, 4.1, 2.0))
    big = _part(grid, labels, 9.0, 5.7)
    assert pocket[small] and door == small             # the room and its doorway
    assert not pocket[hall] and not pocket[big]        # 11.7 m^2 to stand in: > 7.1 m^2
    assert len({small, hall, big}) == 3
    # a larger follow distance (19.6 m^2) makes the big room a pocket too; snug 0: one part
    labels2, pocket2 = floor_pockets(grid, 0.04, 2.5)
    assert pocket2[_part(grid, labels2, 9.0, 5.7)]
    labels0, pocket0 = floor_pockets(grid, 0.0, 1.5)
    assert _part(grid, labels0, 5.0, 5.5) == _part(grid, labels0, 5.0, 2.0)
    assert not pocket0.any()


def test_a_small_room_with_two_ways_in_is_no_pocket():
    grid = hall_with_rooms(second_door=True)
    labels, pocket = floor_pockets(grid, 0.04, 1.5)
    assert not pocket[_part(grid, labels, 5.0, 5.5)]
