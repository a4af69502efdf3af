"""people/follow.py and the modules of its rules (follow_give_way, follow_search,
follow_geometry): the observer's follow / search decisions, on a hand-made map."""
import math

import numpy as np
import pytest

from bullet_floor_sim.sim.floormap import map_from_grid
from bullet_floor_sim.people.follow import (FollowBehaviour, FollowConfig, FollowError,
                                            standoff_point)
from bullet_floor_sim.people.follow_geometry import point_past
from bullet_floor_sim.people.search import (SearchPlan, as_plan, likely_count, in_view, patrol_points,
                                            hub_points, lookout_points,
                                            pick_target, search_plan,
                                            search_point, search_points)
from bullet_floor_sim.nav.planner import PlanError, PlanningGrid, give_way_point, path_length
from bullet_floor_sim.nav.give_way import path_headings

RES = 0.05


def hall(width=10.0, height=4.0):
    """An empty walled hall, width x height metres (walls one cell thick at the border)."""
    g = np.zeros((int(round(height / RES)), int(round(width / RES))), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    return PlanningGrid(map_from_grid(g, RES))


class Tr:
    def __init__(self, id, x, y):
        self.id, self.x, self.y = id, x, y


def test_standoff_point_is_on_the_line_back_to_the_robot_at_the_distance():
    grid = hall()
    p = standoff_point(grid, (6.0, 2.0), (2.0, 2.0), 1.5)
    assert p == pytest.approx((4.5, 2.0), abs=1e-9)
    # near a wall the circle point towards the robot is blocked: the nearest free direction
    p = standoff_point(grid, (5.0, 1.0), (5.0, -3.0), 1.5)  # robot "below" the hall
    assert p is not None and grid.is_free(*p)
    assert math.hypot(p[0] - 5.0, p[1] - 1.0) == pytest.approx(1.5, abs=1e-9)
    assert abs(p[0] - 5.0) > 0.5  # rotated away from straight down, which is outside


def test_follow_sends_a_standoff_goal_facing_the_target_then_replans_when_it_moves():
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, replan_distance=0.5, goal_period=2.0))
    d = fb.update(0.0, (2.0, 2.0, 0.0), (6.0, 2.0, 0.5, 0.0))
    assert d.mode == "follow"
    gx, gy, gyaw = d.goal
    assert (gx, gy) == pytest.approx((4.5, 2.0), abs=1e-9)
    assert gyaw == pytest.approx(0.0, abs=1e-9)  # facing the target
    # it moved 0.3 m in 0.6 s: no new goal yet (neither replan_distance nor goal_period)
    assert fb.update(0.6, (2.3, 2.0, 0.0), (6.3, 2.0, 0.5, 0.0)).goal is None
    # 0.6 m from where it was when the goal was sent: a new goal 1.5 m behind it
    d = fb.update(1.2, (2.6, 2.0, 0.0), (6.6, 2.0, 0.5, 0.0))
    assert d.goal[:2] == pytest.approx((5.1, 2.0), abs=1e-9)
    # moving slowly but steadily: a goal at least every goal_period
    assert fb.update(1.6, (2.7, 2.0, 0.0), (6.7, 2.0, 0.5, 0.0)).goal is None
    assert fb.update(3.3, (2.8, 2.0, 0.0), (6.9, 2.0, 0.5, 0.0)).goal is not None


def test_a_standing_target_within_reach_only_gets_faced():
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7))
    fb.update(0.0, (2.0, 2.0, 0.0), (3.8, 2.0, 0.0, 0.0))
    # still target 1.8 m away (< 2.2) and ahead: nothing to do
    assert fb.update(1.0, (2.0, 2.0, 0.0), (3.8, 2.0, 0.0, 0.0), goal_done=True).goal is None
    # it stepped to the robot's left, 1 m: turn on the spot to face it
    d = fb.update(2.0, (2.0, 2.0, 0.0), (2.6, 3.4, 0.0, 0.0), goal_done=True)
    assert d.goal[:2] == pytest.approx((2.0, 2.0))
    assert d.goal[2] == pytest.approx(math.atan2(1.4, 0.6), abs=1e-9)


def test_lost_target_waits_lost_after_then_searches_the_predicted_region_and_looks_round():
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(lost_after=2.0, search_turn=math.pi))
    fb.update(0.0, (2.0, 2.0, 0.0), (4.8, 2.0, 0.5, 0.0))  # lost 2.3 m off: not close by
    dest = ("7", (8.0, 3.0))
    d = fb.update(1.5, (2.5, 2.0, 0.0), None, dest)
    assert d.mode == "follow" and d.goal is None  # unseen 1.5 s < lost_after
    d = fb.update(2.5, (2.5, 2.0, 0.0), None, dest)
    # it was going east at 0.5 m/s: first where it went, trail (4 s) on, facing that way
    assert d.mode == "search" and "trailing" in d.reason
    assert d.goal == pytest.approx((4.8 + 4.0 * 0.5, 2.0, 0.0), abs=RES)
    assert fb.update(3.0, (3.0, 2.0, 0.0), None, dest).goal is None  # on its way
    d = fb.update(6.0, (6.8, 2.0, 0.1), None, dest, goal_done=True)   # not in view: round
    assert d.goal == pytest.approx((6.8, 2.0, 0.1 - math.pi)) and "looking round" in d.reason
    d = fb.update(7.0, (6.8, 2.0, 0.1 - math.pi), None, dest, goal_done=True)  # the region
    assert d.mode == "search"
    assert d.goal == pytest.approx((8.0, 3.0, math.atan2(1.0, 1.2)))
    d = fb.update(9.0, (8.0, 3.0, 0.2), None, dest, goal_done=True)
    assert d.goal == pytest.approx((8.0, 3.0, 0.2 - math.pi))  # look round, once
    assert fb.update(12.0, (8.0, 3.0, 0.2 - math.pi), None, dest, goal_done=True).goal is None
    # seen again: back to following
    assert fb.update(13.0, (8.0, 3.0, 0.0), (9.5, 3.0, 0.3, 0.0)).mode == "follow"


def test_patrol_points_are_the_roomiest_place_of_each_block():
    grid = hall(12.0, 4.0)                     # walls one 0.05 m cell thick at the border
    pts = patrol_points(grid, 4.0, 0.6)
    # one block per 4 m along x (the 4 m height is one block): the centre line y = 2, as far
    # from the side walls as the block allows (x = 2, 6, 10: 1.95 m from the walls)
    assert len(pts) == 3
    for (x, y), x0 in zip(sorted(pts.tolist()), (0.0, 4.0, 8.0)):
        assert x0 <= x < x0 + 4.0 and abs(y - 2.0) <= grid.resolution
        assert grid.clearance_at(x, y) >= 1.8
    assert len(patrol_points(grid, 4.0, 2.5)) == 0   # nowhere that roomy


def test_lookouts_of_a_corridor_leave_out_its_ends_and_a_room_keeps_every_point():
    corridor = hall(30.0, 2.0)
    pts = [(x + 0.5, 1.0) for x in range(30)]            # its axis, every metre
    # within 8 m of a point: 17 points from x = 8.5 to 21.5 (8 each way and itself),
    # fewer nearer the ends
    got = lookout_points(corridor, pts, 8.0)
    assert got[:, 0].tolist() == [x + 0.5 for x in range(8, 22)]
    assert np.all(got[:, 1] == 1.0)
    # lost at the west end: the region's search point is the nearest lookout, 8 m in
    plan = search_plan({"c": 1.0}, lambda r: got, (1.0, 1.0))
    assert plan[0] == ("c", (8.5, 1.0))
    room = hall(6.0, 4.0)
    pts = [(x, y) for x in (1.0, 3.0, 5.0) for y in (1.0, 3.0)]   # all within 8 m of each other
    assert lookout_points(room, pts, 8.0).tolist() == [list(p) for p in pts]
    # a lattice 1 m apart from x = 0.6: differences of exactly 8 m come out 8 + 1e-15 in
    # floats for some pairs; they count, so the 8 kept are those 8 m in from either end
    lattice = [(0.6 + k, 1.0) for k in range(24)]
    got = lookout_points(corridor, lattice, 8.0)
    assert got[:, 0] == pytest.approx([8.6 + k for k in range(8)])
    # sight 0: each point sees only itself, so all of them are kept
    assert len(lookout_points(corridor, [(x + 0.5, 1.0) for x in range(30)], 0.0)) == 30
    # a wall across the room at x = 2: the 4 points east of it see each other, the 2 west
    # of it only each other, so the east side is kept
    g = np.zeros((80, 120), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    g[:, 40] = 100
    walled = PlanningGrid(map_from_grid(g, RES))
    got = lookout_points(walled, pts, 8.0)
    assert sorted(got.tolist()) == [[3.0, 1.0], [3.0, 3.0], [5.0, 1.0], [5.0, 3.0]]


def test_a_target_never_found_again_gets_a_patrol_of_the_building_nearest_first():
    grid = hall(12.0, 4.0)
    fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, search_wait=1.0, search_rounds=2,
                                            patrol_sight=0.0))  # only places gone to count
    fb.update(0.0, (2.0, 2.0, 0.0), (6.0, 2.0, 0.0, 0.0))     # seen once, 4 m off
    dest = [("7", (10.0, 2.0))]
    t, robot, goals = 2.0, (2.0, 2.0, 0.0), []
    d = fb.update(t, robot, None, dest)
    for _ in range(40):                                       # goals reached at once
        if d.goal is not None:
            goals.append((d.reason, d.goal[:2]))
            robot = d.goal
        t += 1.5
        d = fb.update(t, robot, None, dest, goal_done=d.goal is not None)
    searched = [g for r, g in goals if "searching" in r]
    patrolled = [g for r, g in goals if "patrolling" in r]
    assert searched[:2] == [(10.0, 2.0), (10.0, 2.0)]         # the plan's region, two rounds
    assert all(g == (10.0, 2.0) for g in searched)
    assert len(patrolled) >= 6 and "not found in 2 rounds" in [
        r for r, _ in goals if "patrolling" in r][0]
    places = sorted(patrol_points(grid, 4.0, 0.6).tolist())
    first_tour = [list(g) for g in patrolled[:3]]
    assert sorted(first_tour) == places                        # each place once per tour
    assert first_tour[0] == max(places)                        # from x = 10: nearest first
    # the next tour: all again, but the place it stands at (where the last one ended)
    assert sorted(list(g) for g in patrolled[3:5]) == sorted(
        p for p in places if p != first_tour[-1])


def test_a_target_lost_close_by_is_looked_for_behind_first():
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, distance=1.5, slack=0.7))
    fb.update(0.0, (2.0, 2.0, 0.0), (3.5, 2.5, 0.0, 0.0))
    plan = [("7", (8.0, 3.0))]
    # the observer turned its back (yaw pi) and lost it 1.58 m off: it turns towards it first
    d = fb.update(1.5, (2.0, 2.0, math.pi), None, plan)
    assert d.mode == "search" and "looking back" in d.reason
    assert d.goal == pytest.approx((2.0, 2.0, math.atan2(0.5, 1.5)), abs=1e-9)
    assert fb.update(2.0, (2.0, 2.0, 1.0), None, plan).goal is None    # still turning
    # not in view: the other half of the view, on the spot
    d = fb.update(3.0, (2.0, 2.0, 0.32), None, plan, goal_done=True)
    assert d.goal == pytest.approx((2.0, 2.0, 0.32 - math.pi)) and "looking round" in d.reason
    assert fb.update(4.0, (2.0, 2.0, -1.0), None, plan).goal is None   # still turning
    # not there either: on to the predicted region
    d = fb.update(5.0, (2.0, 2.0, 0.32 - math.pi), None, plan, goal_done=True)
    assert d.goal[:2] == pytest.approx((8.0, 3.0)) and "region 7" in d.reason


def test_a_target_lost_close_by_in_front_is_trailed_not_turned_to():
    """Lost close by but within 75 degrees of the observer's heading, in its lidar's view:
    it went behind something, and turning to where it was shows nothing (mit_csail: the
    walker left a room by its door and went down the corridor behind the wall while the
    observer, facing the door, turned to it and waited). A moving target is trailed; one that
    stood still is looked for from where it was (``look_distance`` 0), or from its stand-off
    point with ``look_distance`` 1.5 m, facing it."""
    grid = hall()
    plan = [("7", (8.0, 3.0))]
    for side in (1.0, -1.0):            # 18 degrees to the left, then to the right
        fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, distance=1.5, slack=0.7,
                                                trail=4.0, trail_turn=0.0))   # straight on
        fb.update(0.0, (2.0, 2.0, 0.0), (3.5, 2.0 + side * 0.5, 0.0, side * 0.6))   # 1.58 m
        d = fb.update(1.5, (2.0, 2.0, 0.0), None, plan)
        assert d.mode == "search" and "trailing" in d.reason
        gx, gy, gyaw = d.goal
        assert gx == pytest.approx(3.5) and gyaw == pytest.approx(side * 0.5 * math.pi)
        assert 0.5 < side * (gy - 2.0) <= 2.0 - fb.config.roomy     # on, short of the wall
    # the same target standing still: from where it was (look_distance 0), facing the
    # way the observer came; with look_distance 1.5, from the stand-off point 1.5 m from it
    # on the observer's side, facing it
    still = FollowBehaviour(grid, FollowConfig(lost_after=1.0, distance=1.5, slack=0.7))
    still.update(0.0, (2.0, 2.0, 0.0), (3.5, 2.5, 0.0, 0.0))
    d = still.update(1.5, (2.0, 2.0, 0.0), None, plan)
    assert "look where it was" in d.reason
    assert d.goal == pytest.approx((3.5, 2.5, math.atan2(0.5, 1.5)), abs=1e-9)
    still = FollowBehaviour(grid, FollowConfig(lost_after=1.0, distance=1.5, slack=0.7,
                                               look_distance=1.5))
    still.update(0.0, (2.0, 2.0, 0.0), (3.5, 2.5, 0.0, 0.0))
    d = still.update(1.5, (2.0, 2.0, 0.0), None, plan)
    back = math.atan2(-0.5, -1.5)
    assert d.goal == pytest.approx((3.5 + 1.5 * math.cos(back), 2.5 + 1.5 * math.sin(back),
                                    back + math.pi), abs=1e-9)

    def lost_at(degrees: float, trail: float = 4.0) -> str:
        fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, distance=1.5, slack=0.7,
                                                trail=trail))
        a = math.radians(degrees)
        fb.update(0.0, (2.0, 2.0, 0.0), (2.0 + 1.2 * math.cos(a), 2.0 + 1.2 * math.sin(a),
                                         0.6, 0.0))     # 1.2 m off, walking east
        return fb.update(1.5, (2.0, 2.0, 0.0), None, plan).reason

    # within 75 degrees of the heading on either side: trailed; past it: turned to
    assert all("trailing" in lost_at(a) for a in (70.0, -70.0))
    assert all("looking back" in lost_at(a) for a in (80.0, -80.0))
    # with trail 0 a target lost close by is turned to wherever it was
    assert "looking back" in lost_at(18.0, trail=0.0)


def test_look_lead_turns_to_where_a_target_lost_close_by_went_on_to():
    """The observer at (2, 2) facing east loses a target 1.2 m to its left (90 degrees off:
    turned to, not trailed). Walking west at 0.6 m/s: with ``look_lead`` 0 it turns to
    where the target was (yaw pi/2); with 2 s, to where it would be 1.2 m further west,
    (0.8, 3.2): yaw 3 pi/4. Standing still (slower than 0.15 m/s): where it was, whatever
    the lead."""
    grid = hall()
    plan = [("7", (8.0, 3.0))]

    def look(lead: float, vx: float):
        fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, distance=1.5, slack=0.7,
                                                look_lead=lead))
        fb.update(0.0, (2.0, 2.0, 0.0), (2.0, 3.2, vx, 0.0))
        return fb.update(1.5, (2.0, 2.0, 0.0), None, plan)

    d = look(0.0, -0.6)
    assert d.reason == "target lost close by at (2.00, 3.20): looking back"
    assert d.goal == pytest.approx((2.0, 2.0, math.pi / 2), abs=1e-9)
    d = look(2.0, -0.6)
    assert d.reason == "target lost close by at (2.00, 3.20): looking back to (0.80, 3.20)"
    assert d.goal == pytest.approx((2.0, 2.0, 3 * math.pi / 4), abs=1e-9)
    # slower than 0.15 m/s it stood: where it was
    d = look(2.0, -0.1)
    assert d.reason == "target lost close by at (2.00, 3.20): looking back"
    assert d.goal == pytest.approx((2.0, 2.0, math.pi / 2), abs=1e-9)
    with pytest.raises(FollowError, match="look_lead"):
        FollowConfig(look_lead=-1.0).check()


def test_a_target_lost_while_moving_is_trailed_up_to_the_wall_it_went_towards():
    """Straight on (``trail_turn`` 0; the default, pi/2, turns a trail a wall cuts short:
    test_trail_turn_turns_a_trail_a_wall_cuts_short_by_the_least_that_frees_it)."""
    grid = hall()                                   # 10 x 4 m
    fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=4.0, trail_turn=0.0))
    fb.update(0.0, (6.0, 2.0, 0.0), (8.0, 2.5, 0.6, 0.0))   # 2.4 m on would be past the wall
    d = fb.update(1.5, (5.5, 2.0, 0.0), None, [("7", (1.0, 1.0))])   # 2.55 m off
    gx, gy, gyaw = d.goal
    assert "trailing" in d.reason and gy == pytest.approx(2.5) and gyaw == pytest.approx(0.0)
    # short of the wall, at the last point with roomy (0.6 m) clearance: room to look round
    roomy = fb.config.roomy
    assert grid.clearance_at(gx, gy) >= roomy > grid.clearance_at(gx + 2 * RES, gy)
    assert 10.0 - roomy - 0.2 < gx <= 10.0 - roomy
    # down a corridor too narrow to turn in (1 m: 0.5 m of clearance at most), no trail:
    # it would stop and look round where its base wedges on the walls. It looks down the
    # corridor from where it was last seen, facing the way it came, and from there goes on
    # to the region without turning round
    narrow = hall(10.0, 1.0)
    fn = FollowBehaviour(narrow, FollowConfig(lost_after=1.0, trail=4.0, distance=1.5))
    fn.update(0.0, (5.0, 0.5, 0.0), (8.3, 0.5, 0.6, 0.0))   # 2.8 m off: not close by
    d = fn.update(1.5, (5.5, 0.5, 0.0), None, [("7", (1.0, 0.5))])
    assert "trailing" not in d.reason and "look where it was" in d.reason
    assert d.goal == pytest.approx((8.3, 0.5, 0.0), abs=1e-9)
    d = fn.update(4.0, (8.3, 0.5, 0.0), None, [("7", (1.0, 0.5))], goal_done=True)
    assert d.goal[:2] == pytest.approx((1.0, 0.5)) and "region 7" in d.reason
    # nor does it look round there after turning to a still target lost close by
    fs = FollowBehaviour(narrow, FollowConfig(lost_after=1.0))
    fs.update(0.0, (5.0, 0.5, 0.0), (6.0, 0.5, 0.0, 0.0))
    assert "looking back" in fs.update(1.5, (5.0, 0.5, math.pi), None, [("7", (1.0, 0.5))]).reason
    d = fs.update(3.0, (5.0, 0.5, 0.0), None, [("7", (1.0, 0.5))], goal_done=True)
    assert d.goal[:2] == pytest.approx((1.0, 0.5)) and "region 7" in d.reason
    # a target that stood still is not trailed: turned to, as before (close by)
    still = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=4.0))
    still.update(0.0, (6.0, 2.0, 0.0), (7.0, 2.5, 0.05, 0.0))
    d = still.update(1.5, (6.0, 2.0, math.pi), None, [("7", (1.0, 1.0))])
    assert "looking back" in d.reason and d.goal[:2] == pytest.approx((6.0, 2.0))
    # moving, but lost close by (1.6 m: it walked past behind the observer): looked back
    # at, not trailed by a velocity that at a leg's start is seldom the way it goes on;
    # with look_lead 0 at where it was, with the default 4 s at where it would be by then
    # (2.4 m on east: a yaw, not a place to drive to)
    mover = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=4.0, look_lead=0.0))
    mover.update(0.0, (6.0, 2.0, 0.0), (7.5, 2.5, 0.6, 0.0))
    d = mover.update(1.5, (6.0, 2.0, math.pi), None, [("7", (1.0, 1.0))])
    assert "looking back" in d.reason and d.goal == pytest.approx(
        (6.0, 2.0, math.atan2(0.5, 1.5)), abs=1e-9)
    mover = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=4.0))
    mover.update(0.0, (6.0, 2.0, 0.0), (7.5, 2.5, 0.6, 0.0))
    d = mover.update(1.5, (6.0, 2.0, math.pi), None, [("7", (1.0, 1.0))])
    assert "looking back to (9.90, 2.50)" in d.reason and d.goal == pytest.approx(
        (6.0, 2.0, math.atan2(0.5, 3.9)), abs=1e-9)
    with pytest.raises(FollowError, match="trail"):
        FollowConfig(trail=-1.0).check()


def test_trail_turn_turns_a_trail_a_wall_cuts_short_by_the_least_that_frees_it():
    """A 1.6 m corridor (the observer's centre keeps 0.4 m off the walls): a target lost
    going (0.4, -0.3) m/s (-36.9 degrees) would walk into the south wall. With
    ``trail_turn`` the observer trails it the least turned way (15-degree steps, left
    first) free for the whole 2 m: +15 degrees (-21.9) still meets the wall within 2 m,
    +30 (-6.9) does not; at 0 it stops short of the wall where it was lost."""
    def trail(turn, target, plan_to=(9.0, 0.8), size=(10.0, 1.6), robot=(0.5, 0.8, 0.0)):
        fb = FollowBehaviour(hall(*size), FollowConfig(lost_after=1.0, trail=4.0,
                                                       trail_turn=turn))
        fb.update(0.0, robot, target)               # over 2.2 m off, ahead
        return fb.update(1.5, robot, None, [("7", plan_to)])
    heading = math.atan2(-0.3, 0.4)
    straight = trail(0.0, (3.0, 0.8, 0.4, -0.3))
    assert "turned" not in straight.reason and straight.goal[2] == pytest.approx(heading)
    assert math.hypot(straight.goal[0] - 3.0, straight.goal[1] - 0.8) < 0.5
    turned = trail(math.pi / 2, (3.0, 0.8, 0.4, -0.3))
    assert "turned +30 degrees" in turned.reason
    assert turned.goal[2] == pytest.approx(heading + math.radians(30.0))
    assert turned.goal[0] > 4.4            # on down the corridor, at a roomy point
    assert turned.goal[1] == pytest.approx(0.8 + (turned.goal[0] - 3.0)
                                           * math.tan(turned.goal[2]))
    # 15 degrees either way is not enough: as straight on
    assert trail(math.radians(15.0), (3.0, 0.8, 0.4, -0.3)).goal == straight.goal
    # lost 0.35 m off the wall, nearer than the observer's centre may go (0.4 m): no
    # straight trail (it looks from where it was); turned, the first cells are not free
    # and +45 degrees (+8.1) is free from its first free cell on for the whole 2 m
    near_wall = trail(math.pi / 2, (3.0, 0.35, 0.4, -0.3))
    assert "not trailed" in trail(0.0, (3.0, 0.35, 0.4, -0.3)).reason
    assert "turned +45 degrees" in near_wall.reason
    assert near_wall.goal[:2] == pytest.approx((3.0 + 2.0 * math.cos(heading + math.pi / 4),
                                                0.35 + 2.0 * math.sin(heading + math.pi / 4)))
    # the corridor's east end 1 m ahead, walls 0.8 m either side: no way is free for 2 m
    dead = trail(math.pi / 2, (9.0, 0.8, 0.5, 0.0), plan_to=(1.0, 0.8))
    assert "turned" not in dead.reason and dead.goal[2] == pytest.approx(0.0)
    # head on at a wall 1.2 m ahead in an open hall, room both ways: the least turn that
    # frees 2 m is 75 degrees (cos 75 x 2 m = 0.52 m east, short of the 0.85 m the
    # observer's centre may go), and of +75 and -75 the left one
    hall_way = trail(math.pi / 2, (8.8, 4.0, 0.5, 0.0), plan_to=(1.0, 4.0), size=(10.0, 8.0),
                     robot=(5.0, 4.0, 0.0))
    assert "turned +75 degrees" in hall_way.reason
    assert hall_way.goal[2] == pytest.approx(math.radians(75.0)) and hall_way.goal[1] > 5.5
    # a thin wall 0.3 m off where it was lost (nearer than the observer may stand): no
    # way through it (the first version turned -30 degrees to (5.73, 2.30), beyond it)
    g = np.zeros((84, 200), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = g[60, :] = 100     # the wall at y 3.0-3.05 m
    walled = FollowBehaviour(PlanningGrid(map_from_grid(g, RES)),
                             FollowConfig(lost_after=1.0, trail=4.0, trail_turn=math.pi / 2))
    walled.update(0.0, (1.0, 3.6, 0.0), (4.0, 3.3, 0.5, 0.0))
    d = walled.update(1.5, (1.0, 3.6, 0.0), None, [("7", (9.0, 3.6))])
    assert "trailing" not in d.reason
    # the default is pi/2: at a hall's end wall, 2 m of room south, 1.5 m north (-60)
    assert FollowConfig().trail_turn == pytest.approx(math.pi / 2)
    fd = FollowBehaviour(hall(), FollowConfig(lost_after=1.0))
    fd.update(0.0, (5.5, 2.0, 0.0), (8.0, 2.5, 0.6, 0.0))
    assert "turned -60 degrees" in fd.update(1.5, (5.5, 2.0, 0.0), None,
                                             [("7", (1.0, 1.0))]).reason
    with pytest.raises(FollowError, match="trail_turn"):
        FollowConfig(trail_turn=2.0).check()
    with pytest.raises(FollowError, match="trail_turn"):
        FollowConfig(trail_turn=-0.1).check()


def test_a_target_lost_further_off_is_looked_for_where_it_was_seen_first():
    """Not close by, not trailed (it stood still): with ``look_distance`` 1.5 m, the
    stand-off point of where it was last seen, facing that place, then a look round there,
    then the predicted region; trail 0 sends the observer straight to the region."""
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, distance=1.5, slack=0.7,
                                            look_distance=1.5))
    fb.update(0.0, (2.0, 2.0, 0.0), (6.0, 3.0, 0.05, 0.0))     # 4.1 m off, standing
    plan = [("7", (1.0, 1.0))]
    d = fb.update(1.5, (2.0, 2.0, 0.0), None, plan)
    assert d.mode == "search" and "look where it was" in d.reason
    gx, gy, gyaw = d.goal
    assert math.hypot(6.0 - gx, 3.0 - gy) == pytest.approx(1.5, abs=1e-9)
    assert gx < 6.0 and gyaw == pytest.approx(math.atan2(3.0 - gy, 6.0 - gx), abs=1e-9)
    d = fb.update(5.0, (gx, gy, gyaw), None, plan, goal_done=True)
    assert d.goal == pytest.approx((gx, gy, gyaw - math.pi)) and "looking round" in d.reason
    d = fb.update(7.0, (gx, gy, gyaw - math.pi), None, plan, goal_done=True)
    assert d.goal[:2] == pytest.approx((1.0, 1.0)) and "region 7" in d.reason
    straight = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=0.0))
    straight.update(0.0, (2.0, 2.0, 0.0), (6.0, 3.0, 0.05, 0.0))
    assert straight.update(1.5, (2.0, 2.0, 0.0), None, plan).goal[:2] == pytest.approx((1.0, 1.0))


def test_look_distance_sets_how_near_where_it_was_the_observer_looks_from():
    """A loss 4.1 m off, standing, with ``look_distance`` 0.6 m: the point 0.6 m
    from where it was on the observer's side, facing it; with 0: where it was, facing the
    way the observer came to it (from (2, 2): atan2(1, 4)), then a look round there. A lost
    point in the wall's inflation (not free): from the stand-off point at ``distance``."""
    grid = hall()
    plan = [("7", (1.0, 1.0))]

    def lost(look: float, where=(6.0, 3.0)):
        fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, distance=1.5,
                                                look_distance=look))
        fb.update(0.0, (2.0, 2.0, 0.0), (where[0], where[1], 0.05, 0.0))
        return fb, fb.update(1.5, (2.0, 2.0, 0.0), None, plan)

    _, d = lost(0.6)
    gx, gy, gyaw = d.goal
    assert "look where it was" in d.reason
    assert math.hypot(6.0 - gx, 3.0 - gy) == pytest.approx(0.6, abs=1e-9) and gx < 6.0
    assert gyaw == pytest.approx(math.atan2(3.0 - gy, 6.0 - gx), abs=1e-9)
    fb, d = lost(0.0)
    assert d.goal == pytest.approx((6.0, 3.0, math.atan2(1.0, 4.0)), abs=1e-9)
    d = fb.update(5.0, d.goal, None, plan, goal_done=True)   # roomy there: it looks round
    assert "looking round" in d.reason and d.goal == pytest.approx(
        (6.0, 3.0, math.atan2(1.0, 4.0) - math.pi))
    # 0.1 m from the top wall: not free for the observer, so from 1.5 m (the stand-off)
    _, d = lost(0.0, (6.0, 3.9))
    gx, gy, _ = d.goal
    assert grid.is_free(gx, gy) and math.hypot(6.0 - gx, 3.9 - gy) == pytest.approx(1.5, abs=1e-9)
    with pytest.raises(FollowError, match="look_distance"):
        FollowConfig(look_distance=-0.5).check()


def test_a_search_goes_on_to_the_next_likely_region_and_round_again():
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, search_turn=math.pi, search_wait=3.0,
                                            trail=0.0))   # straight to the regions
    fb.update(0.0, (2.0, 2.0, 0.0), (4.8, 2.0, 0.5, 0.0))
    plan = [("7", (8.0, 3.0)), ("4", (1.0, 1.0))]
    assert fb.update(2.0, (2.5, 2.0, 0.0), None, plan).goal[:2] == pytest.approx((8.0, 3.0))
    d = fb.update(9.0, (8.0, 3.0, 0.0), None, plan, goal_done=True)
    assert d.goal == pytest.approx((8.0, 3.0, -math.pi))  # looks round at region 7
    assert fb.update(12.0, (8.0, 3.0, math.pi), None, plan, goal_done=True).goal is None
    assert fb.update(14.9, (8.0, 3.0, math.pi), None, plan).goal is None  # waits 3 s
    d = fb.update(15.0, (8.0, 3.0, math.pi), None, plan)
    assert d.mode == "search" and "region 4 (2 of 2)" in d.reason
    assert d.goal == pytest.approx((1.0, 1.0, math.atan2(-2.0, -7.0)))
    fb.update(25.0, (1.0, 1.0, 0.0), None, plan, goal_done=True)            # look round
    fb.update(28.0, (1.0, 1.0, math.pi), None, plan, goal_done=True)        # wait
    d = fb.update(31.0, (1.0, 1.0, math.pi), None, plan)
    assert d.goal[:2] == pytest.approx((8.0, 3.0)) and "(1 of 2)" in d.reason  # round again
    # a new prediction (another list) starts over at its most likely region
    d = fb.update(32.0, (2.0, 1.5, 0.0), None, [("5", (3.0, 3.0))])
    assert d.goal[:2] == pytest.approx((3.0, 3.0))


def lost_and_searching(fb, plan, ticks=30):
    """The target seen once 4 m off, then lost for good: each goal taken as reached at
    once, a tick every 1.5 s; the (reason, (x, y)) of every goal sent."""
    fb.update(0.0, (2.0, 2.0, 0.0), (6.0, 2.0, 0.0, 0.0))
    t, robot, goals = 2.0, (2.0, 2.0, 0.0), []
    d = fb.update(t, robot, None, plan)
    for _ in range(ticks):
        if d.goal is not None:
            goals.append((d.reason, d.goal[:2]))
            robot = d.goal
        t += 1.5
        d = fb.update(t, robot, None, plan, goal_done=d.goal is not None)
    return goals


def test_after_its_rounds_a_search_takes_the_other_regions_once_each_then_patrols():
    """A plan of 3 regions of which 1 is likely: region 7 for two rounds, then 4 and 5 once
    each, most likely first, then the patrol; a plain list is all likely."""
    grid = hall(12.0, 4.0)
    cfg = FollowConfig(lost_after=1.0, search_wait=1.0, search_rounds=2, trail=0.0,
                       patrol_sight=0.0)
    plan = SearchPlan([("7", (10.0, 2.0)), ("4", (1.0, 1.0)), ("5", (6.0, 3.0))], likely=1)
    goals = lost_and_searching(FollowBehaviour(grid, cfg), plan)
    went = [g for r, g in goals if "searching" in r or "patrolling" in r]
    assert went[:4] == [(10.0, 2.0), (10.0, 2.0), (1.0, 1.0), (6.0, 3.0)]
    assert "next likeliest, region 4 (2 of 3)" in [r for r, _ in goals][
        [g for _, g in goals].index((1.0, 1.0))]
    assert any("patrolling" in r for r, _ in goals)
    assert all(g != (1.0, 1.0) for r, g in goals if "patrolling" in r)
    # a plain list: both regions round and round (two rounds), then the patrol
    goals = lost_and_searching(FollowBehaviour(grid, cfg),
                               [("7", (10.0, 2.0)), ("4", (1.0, 1.0))])
    searched = [g for r, g in goals if "searching" in r]
    assert searched[:4] == [(10.0, 2.0), (1.0, 1.0), (10.0, 2.0), (1.0, 1.0)]
    assert "patrolling" in [r for r, _ in goals if "searching" in r or "patrolling" in r][4]


def test_after_patrol_return_seconds_of_patrol_the_search_goes_back_to_the_plan():
    """With patrol_return 10 s: the plan (region 7 twice, 4, 5), patrol places for 10 s, the
    plan again from region 7, patrol again, ...; with 0 the patrol goes on for good."""
    grid = hall(12.0, 4.0)
    plan = SearchPlan([("7", (10.0, 2.0)), ("4", (1.0, 1.0)), ("5", (6.0, 3.0))], likely=1)
    cfg = FollowConfig(lost_after=1.0, search_wait=1.0, search_rounds=2, trail=0.0,
                       patrol_sight=0.0, patrol_return=10.0)
    fb = FollowBehaviour(grid, cfg)
    fb.update(0.0, (2.0, 2.0, 0.0), (6.0, 2.0, 0.0, 0.0))
    t, robot, sent = 2.0, (2.0, 2.0, 0.0), []   # (time, reason, (x, y)) of each place
    d = fb.update(t, robot, None, plan)
    for _ in range(80):
        if d.goal is not None and "looking round" not in d.reason:
            sent.append((t, d.reason, d.goal[:2]))
        if d.goal is not None:
            robot = d.goal
        t += 1.5
        d = fb.update(t, robot, None, plan, goal_done=d.goal is not None)
    kinds = ["patrol" if "patrolling" in r else "plan" if "region" in r else r
             for _, r, _ in sent]
    back = [i for i, (_, r, _) in enumerate(sent) if "back to the likely regions" in r]
    assert len(back) >= 2, kinds
    first_patrol = kinds.index("patrol")
    assert [g for _, _, g in sent[:first_patrol]] == [
        (10.0, 2.0), (10.0, 2.0), (1.0, 1.0), (6.0, 3.0)]
    # back at region 7 once the place after 10 s of patrol is due, the whole plan again
    assert sent[back[0]][2] == (10.0, 2.0) and "region 7 (1 of 3)" in sent[back[0]][1]
    assert sent[back[0] - 1][0] - sent[first_patrol][0] < 10.0 <= (
        sent[back[0]][0] - sent[first_patrol][0])
    assert [g for _, _, g in sent[back[0]:back[0] + 4]] == [
        (10.0, 2.0), (10.0, 2.0), (1.0, 1.0), (6.0, 3.0)]
    assert kinds[back[0] + 4] == "patrol"
    # off: the plan once, then only the patrol
    cfg.patrol_return = 0.0
    goals = lost_and_searching(FollowBehaviour(grid, cfg), plan, ticks=80)
    went = [r for r, _ in goals if "searching" in r or "patrolling" in r]
    assert sum("searching" in r for r in went) == 4 and len(went) > 12


def test_a_return_to_the_plan_goes_on_to_the_next_hub_afterwards():
    """With watches, each patrol after a return to the plan starts at the next hub (three in
    a 30 m corridor), not at the first again."""
    grid = hall(30.0, 3.0)
    cfg = FollowConfig(lost_after=1.0, search_wait=1.0, search_rounds=2, trail=0.0,
                       patrol_sight=0.0, watch=4.0, patrol_return=6.0)
    goals = lost_and_searching(FollowBehaviour(grid, cfg), [("7", (28.0, 1.5))], ticks=120)
    hubs = [r.split("(hub ")[1].rstrip(")") for r, _ in goals if "(hub " in r]
    returns = [r for r, _ in goals if "back to the likely regions" in r]
    assert hubs[:3] == ["1 of 3", "2 of 3", "3 of 3"] and len(returns) >= 3
    assert hubs[3] == "1 of 3"


def test_a_target_seen_again_and_lost_again_gets_the_whole_plan_first():
    """After a return to the plan and patrol, the target is seen, then lost again: the new
    search takes the plan's regions in order (two rounds of the likely one), not back at
    once."""
    grid = hall(12.0, 4.0)
    plan = SearchPlan([("7", (10.0, 2.0)), ("4", (1.0, 1.0)), ("5", (6.0, 3.0))], likely=1)
    cfg = FollowConfig(lost_after=1.0, search_wait=1.0, search_rounds=2, trail=0.0,
                       patrol_sight=0.0, patrol_return=10.0)
    fb = FollowBehaviour(grid, cfg)
    lost_and_searching(fb, plan, ticks=36)     # searched, patrolled, back, patrolling
    assert fb._patrol_since is not None
    robot = (6.0, 2.0, 0.0)
    fb.update(100.0, robot, (8.0, 2.0, 0.0, 0.0), plan)          # seen again
    t, d, sent = 102.0, fb.update(102.0, robot, None, plan), []   # lost again
    for _ in range(14):   # (first it looks back where the target was lost, close by)
        if d.goal is not None and "region" in d.reason and "looking round" not in d.reason:
            sent.append((d.reason, d.goal[:2]))
        if d.goal is not None:
            robot = d.goal
        t += 1.5
        d = fb.update(t, robot, None, plan, goal_done=d.goal is not None)
    assert [g for _, g in sent[:4]] == [(10.0, 2.0), (10.0, 2.0), (1.0, 1.0), (6.0, 3.0)]
    assert not any("back to the likely regions" in r for r, _ in sent[:4])


def test_patrol_return_must_be_a_number_at_least_zero():
    with pytest.raises(FollowError, match="patrol_return"):
        FollowConfig(patrol_return=-1.0).check()


def test_search_plan_with_the_rest_ranks_every_region_and_counts_the_likely():
    probs = {"1": 0.02, "2": 0.5, "3": 0.3, "4": 0.1, "5": 0.08}
    goals = {"2": [(0.0, 0.0), (5.0, 5.0)], "3": [(1.0, 1.0)], "5": [(9.0, 9.0)]}
    plan = search_plan(probs, lambda r: goals.get(r, []), (4.0, 4.0), 3, 0.05, rest=True)
    assert [r for r, _ in plan] == ["2", "3", "4", "5", "1"] and plan.likely == 3
    assert plan[3] == ("5", (9.0, 9.0)) and plan[4] == ("1", (4.0, 4.0))
    assert search_plan(probs, lambda r: goals.get(r, []), (0, 0), 5, 0.09, rest=True).likely == 3
    assert likely_count([0.01, 0.01], 3, 0.5) == 1 and likely_count([], 3, 0.5) == 0
    assert as_plan(plan).likely == 3 and as_plan(list(plan)).likely == 5
    assert as_plan(("2", (1, 2))) == [("2", (1.0, 2.0))] and as_plan(None) == []


def test_the_unlikely_regions_of_a_plan_come_nearest_first():
    """After the likely regions and those of at least min_probability, the near-nil ones
    by the distance of their search point from where the target was last seen, not by id."""
    probs = {"1": 0.6, "2": 0.3, "3": 0.07, "10": 0.01, "11": 0.01, "4": 0.01}
    goals = {"1": [(1, 0)], "2": [(2, 0)], "3": [(3, 0)], "10": [(9, 0)], "11": [(5, 0)],
             "4": [(-2, 0)]}
    plan = search_plan(probs, lambda r: goals[r], (0.0, 0.0), 2, 0.05, rest=True)
    assert [r for r, _ in plan] == ["1", "2", "3", "4", "11", "10"] and plan.likely == 2


def test_search_plan_takes_the_likely_regions_most_likely_first():
    probs = {"1": 0.02, "2": 0.5, "3": 0.3, "4": 0.1, "5": 0.08}
    goals = {"2": [(0.0, 0.0), (5.0, 5.0)], "3": [(1.0, 1.0)], "4": [], "5": [(9.0, 9.0)]}
    plan = search_plan(probs, lambda r: goals.get(r, []), (4.0, 4.0), count=3, min_probability=0.05)
    assert plan == [("2", (5.0, 5.0)), ("3", (1.0, 1.0)), ("4", (4.0, 4.0))]
    assert [r for r, _ in search_plan(probs, lambda r: goals.get(r, []), (0, 0), 5, 0.09)] == ["2", "3", "4"]
    # of equal ones the given best first (the predictor's arg-max), then by id
    even = {"1": 0.4, "2": 0.4, "3": 0.2}
    assert [r for r, _ in search_plan(even, lambda r: [], (0, 0), 3, 0.05)] == ["1", "2", "3"]
    assert [r for r, _ in search_plan(even, lambda r: [], (0, 0), 3, 0.05, "2")] == [
        "2", "1", "3"]
    # the most likely region always, however unlikely
    got = search_plan({"1": 0.01, "2": 0.01}, lambda r: goals.get(r, []), (0, 0), 3, 0.5)
    assert got == [("1", (0.0, 0.0))]


def test_lost_or_never_seen_without_prediction_patrols_the_building():
    fb = FollowBehaviour(hall())
    fb.update(0.0, (2.0, 2.0, 0.0), (4.0, 2.0, 0.0, 0.0))
    d = fb.update(5.0, (2.0, 2.0, 0.0), None, None)
    assert d.mode == "patrol" and d.goal is not None and "patrolling" in d.reason
    first = d.goal
    assert fb.update(6.0, (2.0, 2.0, 0.0), None, None).goal is None     # on its way
    d = fb.update(20.0, first, None, None, goal_done=True)                # there: the next
    assert d.mode == "patrol" and d.goal is not None
    assert math.hypot(d.goal[0] - first[0], d.goal[1] - first[1]) > 1.0
    # an observer that has not seen its target for patrol_after from the start patrols
    fresh = FollowBehaviour(hall())
    d = fresh.update(0.0, (2.0, 2.0, 0.3), None, None)     # first it looks round, once
    # (to the right: facing a little north of east, more of the hall lies to its right)
    assert d.goal == pytest.approx((2.0, 2.0, 0.3 - math.pi + 0.05))
    assert d.reason == "target not seen yet: looking round to the right"
    assert fresh.update(1.0, (2.0, 2.0, 1.0), None, None).goal is None
    assert fresh.update(9.0, (2.0, 2.0, 0.3 - math.pi), None, None, goal_done=True).goal is None
    late = fresh.config.patrol_after + 0.1
    assert fresh.update(late, (2.0, 2.0, 0.0), None, None).mode == "patrol"


@pytest.mark.parametrize("y, side", [(0.8, 1.0), (3.2, -1.0)])
def test_a_target_not_seen_yet_is_looked_for_first_where_more_of_the_floor_lies(y, side):
    """Facing east along a 10 m x 4 m hall 0.8 m from its south wall, the floor lies to the
    left (north): the look round turns left first (a little under a half turn, so that the
    short way round is that way); 0.8 m from the north wall, right."""
    d = FollowBehaviour(hall()).update(0.0, (5.0, y, 0.0), None, None)
    assert d.goal == pytest.approx((5.0, y, side * (math.pi - 0.05)))
    assert d.reason.endswith("to the left" if side > 0 else "to the right")


def test_pick_target_keeps_the_followed_id_else_the_nearest_to_last_seen():
    tracks = [Tr(3, 0.0, 0.0), Tr(5, 4.0, 0.0), Tr(9, 8.0, 0.0)]
    assert pick_target(tracks, 5, (0.0, 0.0)).id == 5
    assert pick_target(tracks, 4, (7.0, 0.5)).id == 9
    assert pick_target(tracks, None, None).id == 3
    assert pick_target([], 5, None) is None


def test_search_point_and_in_view():
    assert search_point([(0.0, 0.0), (3.0, 4.0), (1.0, 1.0)], (2.5, 3.0)) == (3.0, 4.0)
    assert search_point([], (2.5, 3.0)) == (2.5, 3.0)
    # all regions at once: the nearest of each (the first of equals), where it was for none
    regions = [[(0.0, 0.0), (3.0, 4.0)], [], [(2.0, 3.0), (3.0, 3.0)], [(9.0, 9.0)]]
    assert search_points(regions, (2.5, 3.0)) == [(3.0, 4.0), (2.5, 3.0), (2.0, 3.0),
                                                  (9.0, 9.0)]
    laser = (0.3, 0.0, 0.0)
    assert in_view((0.0, 0.0, 0.0), laser, (3.0, 0.0), math.pi, 30.0)
    assert in_view((0.0, 0.0, 0.0), laser, (0.3, 2.0), math.pi, 30.0)      # 90 deg: edge
    assert not in_view((0.0, 0.0, 0.0), laser, (0.2, 2.0), math.pi, 30.0)  # just behind
    assert not in_view((0.0, 0.0, math.pi), laser, (3.0, 0.0), math.pi, 30.0)
    assert not in_view((0.0, 0.0, 0.0), laser, (40.0, 0.0), math.pi, 30.0)


@pytest.mark.parametrize("field,value", [("distance", 0.0), ("lost_after", float("nan")),
                                         ("goal_period", -1.0), ("search_wait", 0.0),
                                         ("search_regions", 0),
                                         ("search_min_probability", 1.5),
                                         ("search_turn", 2.0 * math.pi),
                                         ("pass_detour", -1.0)])
def test_bad_config_names_the_field(field, value):
    with pytest.raises(FollowError, match=field):
        FollowBehaviour(hall(), FollowConfig(**{field: value}))


def test_a_target_coming_at_the_observer_gets_room_to_the_side_not_a_retreat():
    grid = hall(10.0, 6.0)
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7))
    # target 1.6 m ahead coming straight at the observer at 0.5 m/s
    d = fb.update(0.0, (2.0, 3.0, 0.0), (3.6, 3.0, -0.5, 0.0))
    gx, gy, gyaw = d.goal
    assert math.hypot(gx - 3.6, gy - 3.0) == pytest.approx(1.5, abs=1e-9)
    assert abs(gy - 3.0) > 1.0          # beside its path, not on it
    assert gyaw == pytest.approx(math.atan2(3.0 - gy, 3.6 - gx))
    # going away from the observer: trail it on the line as usual
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5))
    d = fb.update(0.0, (1.0, 3.0, 0.0), (3.6, 3.0, 0.5, 0.0))
    assert d.goal[:2] == pytest.approx((2.1, 3.0), abs=1e-9)


def test_a_stand_off_point_nearer_than_replan_distance_is_turned_to_not_driven_to():
    """The target moves (its track jitters) 1.5-1.9 m ahead: the stand-off points lie
    0.1-0.4 m off, under replan_distance; the observer turns to face the target when it
    looks more than 0.5 rad away, else stays; a point 1.1 m off is driven to."""
    grid = hall(10.0, 6.0)
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, replan_distance=0.5))
    d = fb.update(0.0, (2.0, 3.0, 0.0), (3.6, 3.0, 0.5, 0.0))
    assert d.goal == (2.0, 3.0, 0.0)        # first sight: where it stands (replacing any goal)
    d = fb.update(1.0, (2.0, 3.0, 0.0), (3.6, 3.0, 0.5, 0.0), goal_done=True)
    d = fb.update(2.1, (2.0, 3.0, 0.0), (3.6, 3.05, 0.5, 0.0))
    assert d.goal is None                   # standing, facing it, 0.1 m to go: stays
    d = fb.update(4.2, (2.0, 3.0, 1.2), (3.4, 3.4, 0.0, 0.5))
    assert d.goal is not None and d.goal[:2] == (2.0, 3.0) and "turning" in d.reason
    assert d.goal[2] == pytest.approx(math.atan2(0.4, 1.4))
    d = fb.update(6.4, (2.0, 3.0, 0.3), (4.6, 3.0, 0.5, 0.0))
    assert d.goal[:2] == pytest.approx((3.1, 3.0), abs=1e-9)


def two_rooms(door=1.0):
    """A 10 x 6 m hall split by a wall at x = 5 m with a ``door`` metres wide centred at y = 3."""
    g = np.zeros((int(round(6.0 / RES)), int(round(10.0 / RES))), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    col = int(round(5.0 / RES))
    lo, hi = int(round((3.0 - door / 2) / RES)), int(round((3.0 + door / 2) / RES))
    g[:lo, col] = g[hi:, col] = 100
    return PlanningGrid(map_from_grid(g, RES))


def test_standoff_points_keep_out_of_doorways_when_they_can():
    grid = two_rooms()
    assert grid.clearance_at(5.0, 3.0) < 0.6 <= grid.clearance_at(4.0, 3.0)
    # straight back towards the robot is the doorway itself
    assert standoff_point(grid, (6.5, 3.0), (2.0, 3.0), 1.5) == pytest.approx((5.0, 3.0))
    p = standoff_point(grid, (6.5, 3.0), (2.0, 3.0), 1.5, roomy=0.6)
    assert grid.is_free(*p) and grid.clearance_at(*p) >= 0.6
    assert math.hypot(p[0] - 6.5, p[1] - 3.0) == pytest.approx(1.5, abs=1e-9)


def test_an_observer_waiting_in_a_doorway_moves_out_of_it():
    grid = two_rooms()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, roomy=0.6))
    fb.update(0.0, (5.0, 3.0, 0.0), (6.3, 3.0, 0.0, 0.0))          # first sight: a goal
    # the target stands still 1.3 m away; while the goal runs, nothing new
    assert fb.update(1.0, (5.0, 3.0, 0.0), (6.3, 3.0, 0.0, 0.0)).goal is None
    # the goal ended with the observer still in the door: it steps out to a roomy point
    d = fb.update(2.0, (5.0, 3.0, 0.0), (6.3, 3.0, 0.0, 0.0), goal_done=True)
    assert d.goal is not None and "narrow passage" in d.reason
    gx, gy, gyaw = d.goal
    assert grid.clearance_at(gx, gy) >= 0.6
    assert gyaw == pytest.approx(math.atan2(3.0 - gy, 6.3 - gx))
    # waiting in a roomy place, it stays put
    assert fb.update(9.0, (gx, gy, gyaw), (6.3, 3.0, 0.0, 0.0), goal_done=True).goal is None


def test_the_way_out_of_a_narrow_passage_is_not_turned_back_from():
    """Waiting in a doorway, the observer is sent out of it; the target, seen again with a
    jittering track on the way, gets no turn back to it (that kept the observer in the
    doorway and shut the walker in for good: aces_austin); once there, it faces the target
    again as usual (unblock off: the rule under test alone)."""
    grid = two_rooms()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, roomy=0.6,
                                            replan_distance=0.5, unblock=0.0))
    fb.update(0.0, (5.0, 3.0, 0.0), (6.3, 3.0, 0.0, 0.0))
    d = fb.update(2.0, (5.0, 3.0, 0.0), (6.3, 3.0, 0.0, 0.0), goal_done=True)
    assert d.goal is not None and "narrow passage" in d.reason
    out = d.goal
    # on the way out, turned away from the target (its stand-off point is where the
    # observer is), the track jitters: no turn back to it
    x = out[0]
    d = fb.update(4.5, (x, 2.3, -math.pi / 2), (x, 3.8, 0.4, 0.3))
    assert d.goal is None
    d = fb.update(7.0, (x, 2.2, -math.pi / 2), (x + 0.05, 3.7, -0.4, 0.3))
    assert d.goal is None
    # there, the goal done: a target still in the doorway's reach is faced as before
    d = fb.update(9.0, (out[0], out[1], -math.pi / 2), (6.3, 3.0, 0.0, 0.0), goal_done=True)
    assert d.goal is not None and d.goal[:2] == pytest.approx(out[:2])
    assert d.goal[2] == pytest.approx(math.atan2(3.0 - out[1], 6.3 - out[0]))


def test_a_stand_off_goal_back_from_a_target_too_close_is_not_turned_back_from():
    """The target (its track jittering, so moving) stands 0.8 m off: the observer is sent
    back to the stand-off distance and turns away to drive there; seen again 1.2 m off, its
    stand-off point under replan_distance away, the goal under way is kept, not replaced by
    a turn back to the target (that loop held the observer in a walker's way for 60 s:
    seattle)."""
    grid = hall(10.0, 6.0)
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, replan_distance=0.5, unblock=0.0))
    d = fb.update(0.0, (5.0, 3.0, 0.0), (5.8, 3.0, 0.3, 0.0))
    assert d.goal is not None and d.goal[:2] == pytest.approx((4.3, 3.0), abs=1e-6)
    d = fb.update(2.5, (4.95, 3.0, math.pi), (6.15, 3.0, 0.3, 0.0))
    assert d.goal is None
    # there, the goal done: turned to face the target as usual
    d = fb.update(5.0, (4.3, 3.0, math.pi), (5.8, 3.0, 0.3, 0.0), goal_done=True)
    assert d.goal == pytest.approx((4.3, 3.0, 0.0), abs=1e-6)
    # a stand-off goal towards a target far off is no back-off: a target that walked past
    # the observer meanwhile is turned to at once
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, replan_distance=0.5, unblock=0.0))
    d = fb.update(0.0, (3.0, 3.0, 0.0), (6.0, 4.0, -0.5, 0.0))
    assert d.goal is not None and math.hypot(d.goal[0] - 3.0, d.goal[1] - 3.0) > 1.0
    d = fb.update(3.0, (3.3, 3.1, 0.3), (1.8, 4.0, -0.5, 0.0))
    assert d.goal is not None and d.goal[:2] == pytest.approx((3.3, 3.1)) and "turning" in d.reason


def corridor_with_alcove():
    """A corridor 1.2 m wide (y 1.0..2.2) and 12 m long, with a 2 x 2 m alcove on its north
    side at x 6..8 (y 2.2..4.2): the one place where two robots can pass."""
    g = np.full((int(5.0 / RES), int(12.0 / RES)), 100, dtype=np.int8)
    g[int(1.0 / RES):int(2.2 / RES), 1:-1] = 0
    g[int(2.2 / RES):int(4.2 / RES), int(6.0 / RES):int(8.0 / RES)] = 0
    return PlanningGrid(map_from_grid(g, RES))


def test_give_way_point_is_the_nearest_free_place_clear_of_the_route():
    grid = corridor_with_alcove()
    route = np.array([[x, 1.6] for x in np.arange(2.0, 11.0, 0.1)])
    p = give_way_point(grid, route, (6.5, 1.6), (3.0, 1.6), 0.9, 4.0)
    assert p is not None and grid.is_free(*p)
    assert 6.0 < p[0] < 8.0 and p[1] >= 1.6 + 0.9 - 1e-9   # up in the alcove
    # hand-checked: the nearest free cell centre at least 0.9 m from y = 1.6 is at y = 2.55,
    # straight above the robot's cell (x 6.45 or 6.55)
    assert p[1] == pytest.approx(2.55, abs=1e-6) and abs(p[0] - 6.5) <= 0.05 + 1e-9
    # the alcove out of reach: nowhere to go
    assert give_way_point(grid, route, (2.5, 1.6), (1.0, 1.6), 0.9, 2.0) is None


def _alcove_behind_a_corner(side_open):
    """corridor_with_alcove with the alcove's way in shut but for two planning cells that
    touch at a corner (and, with ``side_open``, the cell beside them that makes it a step)."""
    grid = corridor_with_alcove()
    c, r = grid.to_cell(7.0, 2.45)
    grid.cost[r, :] = np.inf
    grid.cost[r + 1, :] = np.inf
    grid.cost[r, c] = grid.cost[r + 1, c + 1] = 1.0
    if side_open:
        grid.cost[r + 1, c] = 1.0
    return grid


def test_no_give_way_point_behind_a_corner_the_planner_does_not_cut():
    # the 8-connected A* cuts no corner: the alcove cannot be planned to and is not offered
    route = np.array([[x, 1.6] for x in np.arange(2.0, 11.0, 0.1)])
    grid = _alcove_behind_a_corner(False)
    assert give_way_point(grid, route, (6.5, 1.6), (3.0, 1.6), 0.9, 4.0) is None
    with pytest.raises(PlanError):
        grid.plan((6.5, 1.6, 0.0), (7.0, 3.5, 0.0))
    # with the cell beside the corner open, the way in is a step the planner takes
    grid = _alcove_behind_a_corner(True)
    p = give_way_point(grid, route, (6.5, 1.6), (3.0, 1.6), 0.9, 4.0)
    assert p is not None and p[1] >= 2.5
    assert len(grid.plan((6.5, 1.6, 0.0), (p[0], p[1], 0.0))) >= 2


def test_a_give_way_point_towards_the_target_comes_before_a_nearer_one_behind():
    # a corridor (y 1.0..2.2) with an alcove north at x 4..5, towards the target in the west,
    # and one at x 8..9, behind the observer; the target walks east along y = 1.6
    g = np.full((int(5.0 / RES), int(14.0 / RES)), 100, dtype=np.int8)
    g[int(1.0 / RES):int(2.2 / RES), 1:-1] = 0
    for x0 in (4.0, 8.0):
        g[int(2.2 / RES):int(4.2 / RES), int(x0 / RES):int((x0 + 1.0) / RES)] = 0
    grid = PlanningGrid(map_from_grid(g, RES))
    route = np.array([[x, 1.6] for x in np.arange(1.0, 13.0, 0.1)])
    robot, target = (7.0, 1.6), (1.0, 1.6)
    behind = give_way_point(grid, route, robot, target, 0.9, 4.0)
    assert behind is not None and 8.0 < behind[0] < 9.0 and behind[1] >= 2.5   # the nearest
    ahead = give_way_point(grid, route, robot, target, 0.9, 4.0, in_view=math.radians(75.0))
    assert ahead is not None and 4.0 < ahead[0] < 5.0 and ahead[1] >= 2.5
    # hand-checked: the nearest free planning cell centre of that alcove 0.9 m clear of
    # y = 1.6 is at y 2.55 in its east-most free column, x 4.65 (the wall at x 5.0 less the
    # 0.34 m footprint radius: 4.66); it lies 22 degrees off the target's bearing
    assert ahead == pytest.approx((4.65, 2.55), abs=1e-6)
    off = abs(math.atan2(ahead[1] - 1.6, ahead[0] - 7.0) - math.pi)
    assert off < math.radians(75.0) and abs(math.atan2(behind[1] - 1.6, behind[0] - 7.0)
                                            - math.pi) > math.radians(75.0)
    # the bearing that counts is the way the observer sets off (nav/give_way.path_headings):
    # to the west alcove it drives west along the corridor, at the target, so that alcove
    # comes first even within 10 degrees (its straight line is 22 degrees off)
    c, r = grid.to_cell(*ahead)
    way = path_headings(grid, robot, np.array([r]), np.array([c]), 8.0)[0]
    assert abs(abs(way) - math.pi) < math.radians(10.0)
    assert give_way_point(grid, route, robot, target, 0.9, 4.0,
                          in_view=math.radians(10.0)) == pytest.approx(ahead)


def test_an_observer_on_the_targets_way_steps_aside_and_waits_until_it_passed():
    grid = corridor_with_alcove()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9))
    dest = [("east", (10.5, 1.6))]
    # the target stands west of the observer and is predicted to walk east, through it
    d = fb.update(0.0, (6.3, 1.6, math.pi), (4.8, 1.6, 0.0, 0.0), dest)
    assert d.mode == "give_way" and d.goal is not None
    gx, gy, gyaw = d.goal
    assert 6.0 < gx < 8.0 and gy >= 2.5                    # into the alcove
    assert gyaw == pytest.approx(math.atan2(1.6 - gy, 4.8 - gx), abs=1e-9)  # facing it
    # it waits there while the target comes past (no new goal), however the target moves
    assert fb.update(1.0, (6.5, 2.6, -2.0), (5.5, 1.6, 0.7, 0.0), dest).goal is None
    assert fb.mode == "give_way"
    # once the target has gone its distance (1.5 m from where it stood), it follows again
    d = fb.update(5.0, (6.5, 2.6, -1.0), (7.9, 1.6, 0.7, 0.0), dest)
    assert d.mode == "follow"


def test_an_observer_the_target_can_go_round_stays_where_it_sees_it():
    # a room 8 x 5 m: the observer stands on the target's straight way east, but the target
    # goes round it (0.3 m further): no stepping aside; in the corridor it cannot, and does
    g = np.full((int(5.0 / RES), int(12.0 / RES)), 100, dtype=np.int8)
    g[int(0.5 / RES):int(4.5 / RES), int(1.0 / RES):int(11.0 / RES)] = 0
    grid = PlanningGrid(map_from_grid(g, RES))
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9))
    dest = [("east", (10.0, 2.5))]
    d = fb.update(0.0, (6.3, 2.5, math.pi), (4.8, 2.5, 0.0, 0.0), dest)
    assert d.mode != "give_way"
    free = path_length(grid.plan((4.8, 2.5), (10.0, 2.5)))
    a = np.linspace(0.0, 2.0 * math.pi, 12, endpoint=False)
    body = np.column_stack([6.3 + 0.34 * np.cos(a), 2.5 + 0.34 * np.sin(a)])
    assert path_length(grid.plan((4.8, 2.5), (10.0, 2.5), obstacles=body)) < free + 2.0
    always = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9,
                                                pass_detour=0.0))
    assert always.update(0.0, (6.3, 2.5, math.pi), (4.8, 2.5, 0.0, 0.0), dest).mode == "give_way"
    corridor = FollowBehaviour(corridor_with_alcove(), FollowConfig(distance=1.5, slack=0.7,
                                                                   give_way=0.9))
    assert corridor.update(0.0, (6.3, 1.6, math.pi), (4.8, 1.6, 0.0, 0.0),
                           [("east", (10.5, 1.6))]).mode == "give_way"


def test_the_stretch_past_the_observer_is_where_the_path_first_gets_that_far_beyond_it():
    path = np.column_stack([np.arange(101) * 0.1, np.zeros(101)])     # x 0..10 m along y 0
    # nearest to the observer at x 5 (0.2 m off); from there the first point 2.68 m from it:
    # hypot(x - 5, 0.2) >= 2.68 first at x 7.7 (2.6 m would be 2.608)
    assert point_past(path, (1.0, 0.0), (5.0, 0.2), 0.9, 2.68) == pytest.approx((7.7, 0.0))
    # only the points from the target's on count: one already past the observer is not
    # held up by it (its nearest approach from x 6 on is 1.02 m)
    assert point_past(path, (6.0, 0.0), (5.0, 0.2), 0.9, 2.68) is None
    assert point_past(path[50:51], (5.0, 0.0), (5.0, 0.2), 0.9, 2.68) == pytest.approx((5.0, 0.0))
    assert point_past(path, (1.0, 0.0), (5.0, 2.0), 0.9, 2.68) is None     # never within 0.9 m
    assert point_past(path, (1.0, 0.0), (9.0, 0.2), 0.9, 2.68) == pytest.approx((10.0, 0.0))  # end
    assert point_past(None, (1.0, 0.0), (5.0, 0.2), 0.9, 2.68) is None


def test_an_observer_on_a_loop_gives_way_unless_the_long_way_round_is_short_enough():
    # a ring corridor 1.4 m wide round a block (x 2.4..9.6, y 2.4..5.6): the observer stands
    # in its south side on the target's way east; round it is the long way (14.5 m
    # more), so it steps aside; with pass_detour 30 m that way counts as passing
    g = np.full((int(8.0 / RES), int(12.0 / RES)), 100, dtype=np.int8)
    g[int(1.0 / RES):int(7.0 / RES), int(1.0 / RES):int(11.0 / RES)] = 0
    g[int(2.4 / RES):int(5.6 / RES), int(2.4 / RES):int(9.6 / RES)] = 100
    grid = PlanningGrid(map_from_grid(g, RES))
    dest = [("east", (10.3, 1.7))]
    seen = (6.3, 1.7, math.pi), (4.8, 1.7, 0.0, 0.0)
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9))
    assert fb.update(0.0, *seen, dest).mode == "give_way"
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9,
                                            pass_detour=30.0))
    assert fb.update(0.0, *seen, dest).mode != "give_way"
    a = np.linspace(0.0, 2.0 * math.pi, 12, endpoint=False)
    body = np.column_stack([6.3 + 0.34 * np.cos(a), 1.7 + 0.34 * np.sin(a)])
    free = path_length(grid.plan((4.8, 1.7), (10.3, 1.7)))
    assert 12.0 < path_length(grid.plan((4.8, 1.7), (10.3, 1.7), obstacles=body)) - free < 30.0


def test_the_pass_by_check_plans_again_from_a_target_off_its_kept_route():
    # the ring corridor: routes kept from the north side (4.8, 6.3) go east round the block,
    # nowhere near the observer in the south side; the target, now seen in the south side
    # within goal_period, walks into the observer, and round it is the long way
    g = np.full((int(8.0 / RES), int(12.0 / RES)), 100, dtype=np.int8)
    g[int(1.0 / RES):int(7.0 / RES), int(1.0 / RES):int(11.0 / RES)] = 0
    g[int(2.4 / RES):int(5.6 / RES), int(2.4 / RES):int(9.6 / RES)] = 100
    grid = PlanningGrid(map_from_grid(g, RES))
    dests, robot = [(10.3, 1.7)], (6.3, 1.7)
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9))
    fb._target_routes(0.0, (4.8, 6.3), dests)
    assert point_past(fb._route_paths[0], (4.8, 6.3), robot, 0.88, 2.68) is None
    assert fb._passes_by((4.8, 1.7), robot, dests) is False


def test_an_observer_in_one_of_two_aisles_stays_when_the_other_is_hardly_longer():
    # two aisles 1.4 m wide either side of a block (x 3..13, y 2.4..3.4) in a hall: the
    # observer stands in the south one, on the target's way east; the north one is 1.1 m
    # longer, so it stays. Planned only to 2.68 m past the observer, the way round is 16.6 m
    # longer (down the north aisle and back along the south one): that stretch alone would
    # have sent it aside, so the check plans to the destination too
    g = np.full((int(6.0 / RES), int(16.0 / RES)), 100, dtype=np.int8)
    g[int(1.0 / RES):int(4.8 / RES), int(1.0 / RES):int(15.0 / RES)] = 0
    g[int(2.4 / RES):int(3.4 / RES), int(3.0 / RES):int(13.0 / RES)] = 100
    grid = PlanningGrid(map_from_grid(g, RES))
    target, robot, dest = (2.0, 2.6), (4.0, 1.7), (14.0, 2.6)
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9))
    assert fb.update(0.0, (*robot, math.pi), (*target, 0.0, 0.0), [("east", dest)]).mode \
        != "give_way"
    body = np.column_stack([robot[0] + 0.34 * np.cos(np.linspace(0, 2 * math.pi, 12, False)),
                            robot[1] + 0.34 * np.sin(np.linspace(0, 2 * math.pi, 12, False))])
    free = path_length(grid.plan(target, dest))
    assert path_length(grid.plan(target, dest, obstacles=body)) - free < 2.0
    end = point_past(grid.plan(target, dest), target, robot, 0.88, 2.68)
    assert end is not None and end != dest
    assert path_length(grid.plan(target, end, obstacles=body)) \
        - path_length(grid.plan(target, end)) > 10.0


def test_the_pass_by_check_takes_the_destinations_of_now_not_of_the_routes_kept():
    # in the room the target goes round the observer on its way east; half a second later
    # (its routes kept for goal_period) it is predicted to go where the observer stands: it
    # cannot get there round it, so the observer steps aside
    g = np.full((int(5.0 / RES), int(12.0 / RES)), 100, dtype=np.int8)
    g[int(0.5 / RES):int(4.5 / RES), int(1.0 / RES):int(11.0 / RES)] = 0
    grid = PlanningGrid(map_from_grid(g, RES))
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9))
    target = (4.8, 2.5, 0.0, 0.0)
    assert fb.update(0.0, (6.3, 2.5, math.pi), target, [("east", (10.0, 2.5))]).mode \
        != "give_way"
    assert fb.update(0.5, (6.45, 2.5, math.pi), target, [("here", (6.6, 2.5))]).mode \
        == "give_way"


def test_giving_way_again_after_a_search_sends_the_give_way_goal_again():
    grid = corridor_with_alcove()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9,
                                            lost_after=2.0))
    dest = [("east", (10.5, 1.6))]
    first = fb.update(0.0, (6.3, 1.6, math.pi), (4.8, 1.6, 0.0, 0.0), dest).goal
    assert first is not None
    # unseen (hidden by the alcove's corner): it goes on to the alcove while the navigation
    # is under way, and searches once that goal is done (here given up where it stood) ...
    assert fb.update(1.0, (6.3, 1.6, math.pi), None, dest).goal is None
    assert fb.update(2.5, (6.3, 1.6, math.pi), None, dest).mode == "give_way"
    d = fb.update(3.0, (6.3, 1.6, math.pi), None, dest, goal_done=True)
    assert d.mode == "search" and d.goal is not None and d.goal[:2] != first[:2]
    # ... then seen again where it stood: the give-way goal goes out again (the navigation
    # is on the search goal now; holding the old yield left the observer in its way)
    d = fb.update(3.5, (6.3, 1.6, math.pi), (4.8, 1.6, 0.0, 0.0), dest)
    assert d.mode == "give_way" and d.goal is not None
    assert d.goal[:2] == pytest.approx(first[:2])


def test_an_observer_behind_the_target_or_far_from_it_does_not_give_way():
    grid = corridor_with_alcove()
    dest = [("east", (10.5, 1.6))]
    # behind the target, which walks away from it: the usual stand-off goal
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7))
    d = fb.update(0.0, (3.0, 1.6, 0.0), (4.5, 1.6, 0.6, 0.0), dest)
    assert d.mode == "follow"
    # on its way but 4 m off (beyond distance + slack): nothing to give way to yet
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7))
    d = fb.update(0.0, (8.5, 1.6, math.pi), (4.5, 1.6, 0.0, 0.0), dest)
    assert d.mode == "follow"


def test_an_observer_standing_in_a_long_narrow_corridor_waits_in_the_hall_beyond_it():
    # a corridor 1.0 m wide (y 1.0..2.0, x 0..8) opening into a hall (x 8..12, y 0..4): no
    # point of the stand-off circle is roomy, the hall is
    g = np.full((int(4.0 / RES), int(12.0 / RES)), 100, dtype=np.int8)
    g[int(1.0 / RES):int(2.0 / RES), 1:int(8.0 / RES)] = 0
    g[1:-1, int(8.0 / RES):-1] = 0
    grid = PlanningGrid(map_from_grid(g, RES))
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, roomy=0.6,
                                            give_way=0.9, give_way_reach=4.0))
    fb.update(0.0, (6.5, 1.5, math.pi), (5.5, 1.5, 0.0, 0.0))          # the first goal
    # at its goal (done), the target standing 1 m off: no roomy point on the stand-off circle,
    # so the nearest roomy place, in the hall, 1.0 m or more from the target
    d = fb.update(2.0, (6.5, 1.5, math.pi), (5.5, 1.5, 0.0, 0.0), goal_done=True)
    assert d.goal is not None and "narrow passage" in d.reason
    gx, gy, _ = d.goal
    assert grid.clearance_at(gx, gy) >= 0.6 and gx > 8.0
    assert math.hypot(gx - 6.5, gy - 1.5) <= 4.0


def test_no_route_to_any_destination_is_no_reason_to_give_way():
    grid = corridor_with_alcove()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7))
    # the only likely destination lies outside the map: no route, the usual follow decision
    d = fb.update(0.0, (6.3, 1.6, math.pi), (4.8, 1.6, 0.0, 0.0), [("x", (40.0, 1.6))])
    assert d.mode == "follow"


def test_a_target_that_stays_close_by_is_stepped_away_from():
    """The target stands 0.9 m from the observer, in a hall, with no prediction: after
    ``unblock`` seconds (not before) the observer steps to a place at least ``give_way`` from
    the target and from where it stood, and waits there for it to go on."""
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=4.0))
    robot, target = (5.0, 2.0, 0.0), (5.9, 2.0, 0.0, 0.0)
    for t in (0.0, 1.0, 2.0, 3.9):
        assert fb.update(t, robot, target, goal_done=True).mode == "follow"
    d = fb.update(4.0, robot, target, goal_done=True)
    assert d.mode == "give_way" and d.goal is not None
    gx, gy, gyaw = d.goal
    assert math.hypot(gx - 5.9, gy - 2.0) >= 0.9 - 1e-9
    assert math.hypot(gx - 5.0, gy - 2.0) >= 0.9 - 1e-9
    assert math.hypot(gx - 5.0, gy - 2.0) <= 1.6          # the nearest such place
    assert gyaw == pytest.approx(math.atan2(2.0 - gy, 5.9 - gx), abs=1e-9)
    assert fb.update(5.0, (gx, gy, gyaw), target).goal is None     # waits there
    # a target that comes close and goes on within the time is not stepped away from
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=4.0))
    for t, x in ((0.0, 5.9), (2.0, 5.9), (3.0, 7.5), (5.0, 5.9), (8.5, 5.9)):
        assert fb.update(t, robot, (x, 2.0, 0.0, 0.0), goal_done=True).mode == "follow"
    never = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=0))
    assert all(never.update(t, robot, target).mode == "follow" for t in range(12))


def test_a_blocked_target_tracked_to_and_fro_within_the_distance_is_stepped_away_from():
    """The target stands 1.2-1.4 m off (beyond give_way + 0.2, within ``distance``), its
    track jumping 0.4 m to and fro as a blocked walker's did: stepped away from after
    ``unblock`` seconds. One that walks on (more than ``give_way`` from where it was) or
    goes beyond ``distance`` starts the count again."""
    grid = hall()
    cfg = FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=4.0)
    fb = FollowBehaviour(grid, cfg)
    robot = (5.0, 2.0, 0.0)
    track = [(6.2, 2.0, 0.1, 0.0), (6.3, 2.4, -0.1, 0.2)]
    for k in range(8):
        assert fb.update(0.5 * k, robot, track[k % 2]).mode == "follow"
    d = fb.update(4.0, robot, track[0])
    assert d.mode == "give_way" and d.goal is not None and "stood within 1.5 m" in d.reason
    assert math.hypot(d.goal[0] - 6.2, d.goal[1] - 2.0) >= 0.9 - 1e-9
    # walking on towards the observer and past: each 0.5 s further on, never 4 s in one place
    fb = FollowBehaviour(grid, cfg)
    path = [(6.4, 2.0), (6.2, 2.0), (6.0, 2.0), (5.8, 2.0), (5.6, 2.8), (5.1, 3.0), (4.6, 3.0),
            (4.1, 3.0), (3.6, 3.0)]
    for k, (x, y) in enumerate(path):
        assert fb.update(0.6 * k, robot, (x, y, -0.4, 0.0)).mode == "follow"
    # beyond the distance between two spells of 3 s: no step
    fb = FollowBehaviour(grid, cfg)
    for t, x in ((0.0, 6.2), (3.0, 6.2), (3.5, 6.7), (4.0, 6.2), (6.5, 6.2)):
        assert fb.update(t, robot, (x, 2.0, 0.0, 0.0)).mode == "follow"


def test_a_goal_under_way_is_replaced_when_the_target_is_seen_close_by():
    """Searching (a goal under way 5 m on), the observer sees the target standing 1.55 m
    ahead, its stand-off point under replan_distance away: it stops where it is, facing the
    target, instead of driving on through it to the search point."""
    grid = hall(12.0, 6.0)
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, lost_after=1.0, trail=0.0))
    fb.update(0.0, (2.0, 3.0, 0.0), (7.0, 3.0, 0.0, 0.0))     # seen 5 m off, then lost
    d = fb.update(3.0, (2.0, 3.0, 0.0), None, [("7", (10.0, 3.0))])
    assert d.mode == "search" and d.goal[:2] == pytest.approx((10.0, 3.0))
    d = fb.update(5.0, (5.0, 3.0, 0.0), (6.55, 3.0, 0.0, 0.0), [("7", (10.0, 3.0))])
    assert d.mode == "follow" and d.goal == (5.0, 3.0, 0.0)


def test_a_target_dwelling_at_the_stand_off_distance_is_not_stepped_away_from():
    """Within ``distance`` but not nearer than ``distance`` - 0.2 m (the observer waits at
    the stand-off distance, to its goal tolerance): a dwelling target is left alone; one
    that comes nearer starts the count."""
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=4.0))
    robot = (5.0, 2.0, 0.0)
    for t in range(12):
        assert fb.update(float(t), robot, (6.42, 2.0, 0.0, 0.0)).mode == "follow"
    for t in (12.0, 13.0, 14.0, 15.0):          # 1.25 m, then 1.42 m again: still counted
        fb.update(t, robot, ((6.25, 2.0, 0.0, 0.0) if t == 12.0 else (6.42, 2.0, 0.0, 0.0)))
    assert fb.update(16.0, robot, (6.42, 2.0, 0.0, 0.0)).mode == "give_way"


def test_a_target_lost_while_stepping_aside_is_looked_for_once_there():
    """Driving to the place it steps aside to, the observer turns its back on the target:
    it keeps going (no search goal) until that goal is done or ``give_way_hold`` is up, then
    looks for it where it was (from there when the target is in front; turned
    to where it stood otherwise)."""
    grid = hall()
    # blocked_way off: the look where it was (with it, from where the observer stood:
    # test_blocked_way_looks_from_where_the_observer_stood_the_way_the_target_went)
    cfg = FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=4.0, lost_after=2.0,
                       give_way_hold=20.0, blocked_way=False)
    fb = FollowBehaviour(grid, cfg)
    robot, target = (5.0, 2.0, 0.0), (5.9, 2.0, 0.0, 0.0)
    dest = [("east", (9.0, 2.0))]
    for t in (0.0, 1.0, 2.0, 3.0):
        fb.update(t, robot, target, dest, goal_done=True)
    step = fb.update(4.0, robot, target, dest, goal_done=True)
    assert step.mode == "give_way" and step.goal is not None
    for t in (5.0, 7.0, 10.0, 15.0):          # unseen, on the way: no new goal
        d = fb.update(t, (4.8, 2.3, 2.5), None, dest)
        assert d.mode == "give_way" and d.goal is None
    # there, facing where it stood (in view, so turning shows nothing): it goes to look
    # where it was, from there (look_distance 0), facing the way it came
    d = fb.update(16.0, step.goal, None, dest, goal_done=True)
    assert d.mode == "search" and "look where it was" in d.reason
    assert d.goal == pytest.approx((5.9, 2.0, math.atan2(2.0 - step.goal[1],
                                                         5.9 - step.goal[0])), abs=1e-9)
    # facing away from it there: it looks back at it, where it stands
    fb = FollowBehaviour(grid, cfg)
    for t in (0.0, 1.0, 2.0, 3.0, 4.0):
        step = fb.update(t, robot, target, dest, goal_done=True)
    gx, gy, gyaw = step.goal
    fb.update(5.0, (4.8, 2.3, 2.5), None, dest)
    d = fb.update(16.0, (gx, gy, gyaw + math.pi), None, dest, goal_done=True)
    assert d.mode == "search" and "looking back" in d.reason
    assert d.goal[:2] == pytest.approx((gx, gy))
    assert d.goal[2] == pytest.approx(math.atan2(2.0 - gy, 5.9 - gx), abs=1e-9)
    # nor one it drives away from (the navigation took the long way round)
    fb = FollowBehaviour(grid, cfg)
    for t in (0.0, 1.0, 2.0, 3.0, 4.0):
        step = fb.update(t, robot, target, dest, goal_done=True)
    gx, gy = step.goal[:2]
    away = (5.0 - 0.8 * (gx - 5.0), 2.0 - 0.8 * (gy - 2.0), 0.0)   # 1.8 x as far from it
    assert fb.update(6.5, away, None, dest).mode == "search"
    # a step-aside goal still under way after give_way_hold no longer holds the search off
    fb = FollowBehaviour(grid, cfg)
    for t in (0.0, 1.0, 2.0, 3.0, 4.0):
        fb.update(t, robot, target, dest, goal_done=True)
    assert fb.update(24.5, (4.8, 2.3, 2.5), None, dest).mode == "search"


def test_blocked_way_looks_from_where_the_observer_stood_the_way_the_target_went():
    """The observer at (5, 2) blocks a target standing at (5.9, 2) for 4 s and steps aside.
    Lost meanwhile, with ``blocked_way`` it is looked for from (5, 2), facing west (from
    the target through where the observer stood: yaw pi); without it, where it was. Seen
    again and lost 3 m off (more than ``distance`` from where it stood), or lost after
    ``give_way_hold``, it is looked for as any target."""
    grid = hall()
    dest = [("east", (9.0, 2.0))]

    def lost(blocked: bool, seen_again=None, t_lost: float = 16.0):
        cfg = FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=4.0,
                           lost_after=2.0, give_way_hold=20.0, blocked_way=blocked)
        fb = FollowBehaviour(grid, cfg)
        for t in (0.0, 1.0, 2.0, 3.0):
            fb.update(t, (5.0, 2.0, 0.0), (5.9, 2.0, 0.0, 0.0), dest, goal_done=True)
        step = fb.update(4.0, (5.0, 2.0, 0.0), (5.9, 2.0, 0.0, 0.0), dest, goal_done=True)
        assert step.mode == "give_way" and "stood within" in step.reason
        if seen_again is not None:
            fb.update(5.0, step.goal, seen_again, dest)
        return fb.update(t_lost, step.goal, None, dest, goal_done=True)

    d = lost(True)
    assert d.mode == "search" and "stepped out of its way" in d.reason
    assert d.goal == pytest.approx((5.0, 2.0, math.pi), abs=1e-9)
    assert "stepped out of its way" not in lost(False).reason
    assert "stepped out of its way" not in lost(True, (2.9, 2.0, -0.05, 0.0)).reason
    assert "stepped out of its way" not in lost(True, t_lost=30.0).reason
    # seen 3 m off and then back near where it stood: it went on from there (not through)
    cfg = FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=4.0, lost_after=2.0,
                       give_way_hold=20.0)
    fb = FollowBehaviour(grid, cfg)
    for t in (0.0, 1.0, 2.0, 3.0, 4.0):
        step = fb.update(t, (5.0, 2.0, 0.0), (5.9, 2.0, 0.0, 0.0), dest, goal_done=True)
    fb.update(5.0, step.goal, (8.9, 2.0, 0.3, 0.0), dest)
    fb.update(6.0, step.goal, (6.5, 2.0, -0.3, 0.0), dest)
    d = fb.update(9.0, step.goal, None, dest, goal_done=True)
    assert d.mode == "search" and "stepped out of its way" not in d.reason
    # once a step: lost again after it was looked for so, as any target
    fb = FollowBehaviour(grid, cfg)
    for t in (0.0, 1.0, 2.0, 3.0, 4.0):
        step = fb.update(t, (5.0, 2.0, 0.0), (5.9, 2.0, 0.0, 0.0), dest, goal_done=True)
    assert "stepped out of its way" in fb.update(16.0, step.goal, None, dest,
                                                 goal_done=True).reason
    fb.update(17.0, (5.0, 2.0, math.pi), (5.2, 2.6, 0.0, 0.0), dest)
    d = fb.update(20.0, (5.0, 2.0, math.pi), None, dest, goal_done=True)
    assert d.mode == "search" and "stepped out of its way" not in d.reason
    # no place to step to (a 1 m corridor, nothing predicted): it stays, and a loss is
    # not taken for one it stepped out of the way of
    narrow = hall(10.0, 1.0)
    fn = FollowBehaviour(narrow, FollowConfig(distance=1.5, give_way=0.9, unblock=4.0,
                                              lost_after=2.0, give_way_reach=0.3))
    for t in (0.0, 1.0, 2.0, 3.0, 4.0, 5.0):
        d = fn.update(t, (5.0, 0.5, 0.0), (5.9, 0.5, 0.0, 0.0), [], goal_done=True)
        assert d.mode == "follow"
    d = fn.update(8.0, (5.0, 0.5, 0.0), None, [("7", (1.0, 0.5))], goal_done=True)
    assert d.mode == "search" and "stepped out of its way" not in d.reason
    with pytest.raises(FollowError, match="blocked_way"):
        FollowConfig(blocked_way="false").check()


def test_give_way_through_looks_from_where_the_observer_stood_after_a_step_off_its_way():
    """The observer at (6.3, 1.6) stands on the way of a target at (4.8, 1.6) predicted to
    walk east, and steps into the alcove. The target, last seen with a velocity pointing
    back west (a track's first steps), is lost meanwhile: with ``give_way_through`` it is
    looked for from (6.3, 1.6), facing east (from the target through where the observer
    stood); not so when the observer never got within 1 m of the place it stepped to;
    without it, or with ``blocked_way`` off, it is looked for where it was, as before (a
    trail west has no roomy point in the corridor)."""
    grid = corridor_with_alcove()
    dest = [("east", (10.5, 1.6))]

    def lost(through: bool, blocked: bool = True, far=None):
        fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9,
                                                lost_after=2.0, give_way_hold=20.0,
                                                blocked_way=blocked,
                                                give_way_through=through))
        step = fb.update(0.0, (6.3, 1.6, math.pi), (4.8, 1.6, -0.4, 0.0), dest)
        assert step.mode == "give_way" and "likely destination" in step.reason
        fb.update(1.0, far or (6.4, 2.0, 1.2), None, dest)
        return step.goal, fb.update(4.0, far or step.goal, None, dest, goal_done=True)

    goal, d = lost(True)
    assert d.mode == "search" and "stepped out of its way" in d.reason
    assert d.goal == pytest.approx((6.3, 1.6, 0.0), abs=1e-9)
    # a place it never got within 1 m of (it drove off east, the long way round): not
    # looked for from where it stood, which is in the target's way
    far = (8.8, 1.6, 0.0)
    assert math.hypot(far[0] - goal[0], far[1] - goal[1]) > 1.0
    assert math.hypot(6.3 - goal[0], 1.6 - goal[1]) > 1.0
    d = lost(True, far=far)[1]
    assert d.mode == "search" and "stepped out of its way" not in d.reason
    for through, blocked in ((False, True), (True, False)):
        d = lost(through, blocked)[1]
        assert d.mode == "search" and "stepped out of its way" not in d.reason
        assert "look where it was" in d.reason and d.goal[:2] == pytest.approx((4.8, 1.6))
    with pytest.raises(FollowError, match="give_way_through"):
        FollowConfig(give_way_through=1).check()


def test_a_target_lost_after_a_give_way_is_trailed_the_way_it_went_meanwhile():
    """The observer steps aside (unblock) and waits; the target walks off east, seen, then
    is lost: the trail goes by the velocity it was seen with while the observer gave way (it
    went by the one from before: looking back where the target had stood)."""
    grid = hall()
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, slack=0.7, give_way=0.9, unblock=4.0,
                                            lost_after=2.0, trail=4.0))
    robot, dest = (5.0, 2.0, 0.0), [("east", (9.0, 2.0))]
    for t in (0.0, 1.0, 2.0, 3.0):
        fb.update(t, robot, (5.9, 2.0, 0.0, 0.0), dest, goal_done=True)
    step = fb.update(4.0, robot, (5.9, 2.0, 0.0, 0.0), dest, goal_done=True)
    assert step.mode == "give_way"
    at = step.goal
    assert fb.update(5.0, at, (6.5, 2.0, 0.6, 0.0), dest, goal_done=True).mode == "give_way"
    assert fb.update(6.0, at, (7.1, 2.0, 0.6, 0.0), dest).mode == "give_way"
    fb.update(6.5, at, (7.7, 2.0, 0.6, 0.0), dest)   # 2.5 m off: not close by
    fb.update(7.0, at, None, dest)
    d = fb.update(8.5, at, None, dest)
    assert d.mode == "search" and d.goal is not None and "trailing" in d.reason
    gx, gy, gyaw = d.goal
    assert gx > 8.0 and gy == pytest.approx(2.0, abs=0.1) and gyaw == pytest.approx(0.0)


def hall_with_pocket(gap=0.75):
    """A hall 10 x 4 m and, north of it, a room 2.5 x 2.5 m whose only way in is a gap
    ``gap`` wide in the 0.2 m wall between them (x 4.625-5.375 for 0.75 m)."""
    g = np.full((int(7.0 / RES), int(10.0 / RES)), 100, dtype=np.int8)
    g[1:int(4.0 / RES), 1:-1] = 0                                  # the hall, y 0.05-4.0
    g[int(4.2 / RES):int(6.7 / RES), int(3.75 / RES):int(6.25 / RES)] = 0   # the room
    half = int(round(gap / 2 / RES))
    mid = int(5.0 / RES)
    g[int(4.0 / RES):int(4.2 / RES), mid - half:mid + half] = 0
    return PlanningGrid(map_from_grid(g, RES))


def test_a_goal_behind_a_passage_too_snug_to_turn_in_is_waited_for_outside():
    """The target walks into a room whose way in is 0.75 m wide (clearance below the
    observer's 0.34 m radius + snug 0.04): the follow goal 1.5 m behind it, in the gap or in
    the room, becomes the nearest place in the hall, facing it. From inside the room, a goal
    in the hall is kept (the bigger part), and with snug 0 (the default) the goal is in the
    room."""
    grid = hall_with_pocket()
    c = grid.clearance_at(5.0, 4.1)
    assert grid.config.robot_radius <= c < grid.config.robot_radius + 0.04, c
    assert grid.plan((5.0, 2.0), (5.0, 5.5)) is not None        # it can plan in
    target = (5.0, 5.6, 0.0, 0.5)                                 # walking north in the room
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, snug=0.04))
    d = fb.update(0.0, (5.0, 2.5, math.pi / 2), target)
    gx, gy, gyaw = d.goal
    assert d.mode == "follow" and gy < 4.0, d                    # in the hall ...
    assert math.hypot(gx - 5.0, gy - 4.1) < 1.0                 # ... by the gap
    assert gyaw == pytest.approx(math.pi / 2, abs=0.6)          # facing in
    free = FollowBehaviour(grid, FollowConfig(distance=1.5, snug=0.0))
    assert free.update(0.0, (5.0, 2.5, math.pi / 2), target).goal[1] > 4.0
    inside = FollowBehaviour(grid, FollowConfig(distance=1.5, snug=0.04))
    d = inside.update(0.0, (5.0, 5.5, -math.pi / 2), (5.0, 2.0, 0.0, -0.5))
    gx, gy, _ = d.goal                                            # out in the hall, 1.5 m
    assert gy < 4.0 and math.hypot(gx - 5.0, gy - 2.0) == pytest.approx(1.5, abs=0.01)


def test_a_give_way_point_in_sight_of_the_target_comes_before_a_nearer_one_behind_a_wall():
    # a 10 x 4 m hall, a wall stub hanging from the north wall at x 2.8..3.3 down to y 2.65;
    # the target at (1.5, 2.3) west of it walks east along y = 2.3, the observer at (5, 2.6)
    g = np.zeros((int(4.0 / RES), int(10.0 / RES)), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    g[int(2.65 / RES):, int(2.8 / RES):int(3.3 / RES)] = 100
    grid = PlanningGrid(map_from_grid(g, RES))
    route = np.array([[x, 2.3] for x in np.arange(1.5, 9.5, 0.1)])
    robot, target = (5.0, 2.6), (1.5, 2.3)
    # hand-checked: from (5, 3.2) the line to the target is at y 2.71 at x 3.3, in the stub;
    # from (5, 1.4) nothing is in the way
    assert grid.in_sight(np.array([[5.0, 3.2], [5.0, 1.4], [2.0, 3.4]]),
                         target).tolist() == [False, True, True]
    # without a view preference: the nearest place, north (0.6 m off, south is 1.2 m)
    north = give_way_point(grid, route, robot, target, 0.9, 4.0)
    assert north is not None and north[1] >= 3.2 - 1e-9 and north[0] > 3.3
    assert not grid.in_sight(np.array([north]), target)[0]
    # with it (any bearing): the nearest place that sees the target, south of the route
    south = give_way_point(grid, route, robot, target, 0.9, 4.0, in_view=math.pi)
    assert south is not None and south[1] <= 2.3 - 0.9 + 1e-9
    assert grid.in_sight(np.array([south]), target)[0]
    assert math.hypot(south[0] - 5.0, south[1] - 2.6) < 1.4


def test_patrol_places_seen_on_the_way_count_as_visited():
    # a 24 x 4 m hall: patrol places on y = 2 at x = 2, 4, 8, 12, 16, 20 (the first of the
    # roomiest cells of each 4 m block: as roomy as the 4 m height lets anywhere from x 2)
    grid = hall(24.0, 4.0)
    xs = sorted(round(x) for x, _ in patrol_points(grid, 4.0, 0.6).tolist())
    assert xs == [2, 4, 8, 12, 16, 20]

    def second_goal(sight):
        fb = FollowBehaviour(grid, FollowConfig(patrol_sight=sight, patrol_after=1.0))
        fb.update(0.0, (2.0, 2.0, 0.0), None, None)                  # looks round first
        d = fb.update(2.0, (2.0, 2.0, 0.0), None, None, goal_done=True)
        assert d.mode == "patrol" and round(d.goal[0]) == 2             # the place it is at
        fb.update(3.0, (2.0, 2.0, 0.0), None, None)                   # facing east
        return fb, fb.update(4.0, (2.0, 2.0, 0.0), None, None, goal_done=True).goal

    # going to each place in turn: the next one along
    assert round(second_goal(0.0)[1][0]) == 4
    # the places within 8 m ahead (x 4 and 8) were seen from where it stands: on to x 12
    fb, goal = second_goal(8.0)
    assert round(goal[0]) == 12
    # on the way, at x 8.1 facing east, x 16 comes in view 7.95 m off; it goes on to x 12
    # all the same (passing over the place it drives to, it turned on the spot in a small
    # office from one seen place to the next); from x 12 the next is x 20 (8.15 m off, out
    # of sight), not x 16
    assert fb.update(5.5, (8.1, 2.0, 0.0), None, None).goal is None
    d = fb.update(12.0, (11.9, 1.95, 0.0), None, None, goal_done=True)
    assert d.mode == "patrol" and round(d.goal[0]) == 20 and "patrolling" in d.reason


def test_the_place_to_step_aside_to_is_not_past_the_target_in_a_corridor():
    # a corridor 1.9 m wide (y 0.05..1.95), alcoves north at x 10.5..11.5 (past the target)
    # and x 4..5 (behind the observer); the target at (9.5, 1) heads west, through the
    # observer at (8, 1), to (1, 1)
    g = np.full((int(4.2 / RES), int(16.0 / RES)), 100, dtype=np.int8)
    g[1:int(1.95 / RES), 1:-1] = 0
    for x0 in (4.0, 10.5):
        g[int(1.95 / RES):int(4.0 / RES), int(x0 / RES):int((x0 + 1.0) / RES)] = 0
    grid = PlanningGrid(map_from_grid(g, RES))
    robot, target = (8.0, 1.0, 0.0), (9.5, 1.0)
    route = np.array([[x, 1.0] for x in np.arange(1.0, 9.6, 0.1)])
    # a point target leaves a 0.22 m band each side for the observer's centre: a place past
    # the target is offered (the nearest, in the corridor beyond it)
    past = give_way_point(grid, route, robot, target, 0.9, 4.0,
                          obstacles=np.array([target]))
    assert past is not None and past[0] > 9.5
    # the follower stamps the target as a body of its own radius: no way by it; the alcove
    # behind (3.7 m off) it is
    fb = FollowBehaviour(grid, FollowConfig())
    d = fb.update(0.0, robot, (*target, 0.0, 0.0), [("1", (1.0, 1.0))])
    assert d.mode == "give_way" and d.goal is not None
    assert 4.0 < d.goal[0] < 5.0 and d.goal[1] >= 1.9


def test_a_target_lost_close_by_from_a_doorway_is_trailed_not_turned_to():
    """In a 0.75 m gap (no room to turn) the observer loses a target 1.3 m off walking out
    into the hall: it trails it out of the gap instead of turning where it stands (turning
    in a doorway, it blocked the walker: seattle); with room to turn, it looks back."""
    grid = hall_with_pocket()
    assert grid.clearance_at(5.0, 4.1) < FollowConfig().roomy
    fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=4.0, distance=1.5, slack=0.7))
    fb.update(0.0, (5.0, 4.1, -0.5 * math.pi), (5.0, 2.8, 0.0, -0.6))
    d = fb.update(1.5, (5.0, 4.1, 0.5 * math.pi), None, [("7", (1.0, 1.0))])
    assert "trailing" in d.reason and d.goal[1] < 2.8 and d.goal[2] == pytest.approx(-0.5 * math.pi)
    roomy = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=4.0, distance=1.5, slack=0.7))
    roomy.update(0.0, (5.0, 3.3, 0.5 * math.pi), (6.0, 2.6, 0.6, 0.0))
    d = roomy.update(1.5, (5.0, 3.3, 0.5 * math.pi), None, [("7", (1.0, 1.0))])
    assert "looking back" in d.reason and d.goal[:2] == pytest.approx((5.0, 3.3))


def test_a_target_lost_close_by_from_a_doorway_is_looked_at_from_a_roomy_place():
    """In a doorway (no room to turn) the observer loses a target that stood 1 m behind it:
    it does not turn where its base may wedge on the frame (aces_austin: it backed and
    nudged for 30 s while the walker it blocked stood at its side); it looks from a roomy
    place at the stand-off distance, facing where the target was, then looks round there.
    With no roomy place within reach (a corridor too narrow for any), it turns as before."""
    grid = two_rooms()
    roomy = FollowConfig().roomy
    assert grid.clearance_at(5.0, 3.0) < roomy
    fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=4.0, distance=1.5, slack=0.7))
    fb.update(0.0, (5.0, 3.0, math.pi), (4.0, 3.0, 0.0, 0.0))
    plan = [("7", (8.0, 1.0))]
    d = fb.update(1.5, (5.0, 3.0, 0.0), None, plan)
    assert d.mode == "search" and "no room to turn" in d.reason
    gx, gy, gyaw = d.goal
    assert grid.clearance_at(gx, gy) >= roomy and gx > 5.0      # on the observer's side
    assert math.hypot(gx - 4.0, gy - 3.0) == pytest.approx(1.5, abs=1e-9)
    assert gyaw == pytest.approx(math.atan2(3.0 - gy, 4.0 - gx), abs=1e-9)
    d = fb.update(6.0, (gx, gy, gyaw), None, plan, goal_done=True)
    assert "looking round" in d.reason and d.goal[:2] == pytest.approx((gx, gy))
    # trail 0 keeps the plain rule: turned to where it stands
    plain = FollowBehaviour(grid, FollowConfig(lost_after=1.0, trail=0.0, distance=1.5,
                                               slack=0.7))
    plain.update(0.0, (5.0, 3.0, math.pi), (4.0, 3.0, 0.0, 0.0))
    assert "looking back" in plain.update(1.5, (5.0, 3.0, 0.0), None, plan).reason
    # in a 1 m corridor no stand-off point is roomy: where an alcove 1-3 m back widens it
    alcove = np.full((int(round(5.0 / RES)), int(round(10.0 / RES))), 100, dtype=np.int8)
    alcove[int(round(1.0 / RES)):int(round(2.0 / RES)), 1:-1] = 0
    alcove[int(round(2.0 / RES)):int(round(4.0 / RES)),
           int(round(2.0 / RES)):int(round(4.0 / RES))] = 0
    ga = PlanningGrid(map_from_grid(alcove, RES))
    fa = FollowBehaviour(ga, FollowConfig(lost_after=1.0, trail=4.0, distance=1.5))
    fa.update(0.0, (5.0, 1.5, math.pi), (6.0, 1.5, 0.0, 0.0))
    d = fa.update(1.5, (5.0, 1.5, math.pi), None, plan)          # it is behind
    gx, gy, gyaw = d.goal
    assert "no room to turn" in d.reason and ga.clearance_at(gx, gy) >= roomy
    assert 2.0 < gx < 4.0 and math.hypot(gx - 5.0, gy - 1.5) <= 4.0   # by the alcove
    assert gyaw == pytest.approx(math.atan2(1.5 - gy, 6.0 - gx), abs=1e-9)
    # no roomy place within reach at all: turned to, as before
    narrow = hall(10.0, 1.0)
    fn = FollowBehaviour(narrow, FollowConfig(lost_after=1.0, trail=4.0, distance=1.5))
    fn.update(0.0, (5.0, 0.5, 0.0), (6.0, 0.5, 0.0, 0.0))
    d = fn.update(1.5, (5.0, 0.5, math.pi), None, plan)
    assert "looking back" in d.reason and d.goal[:2] == pytest.approx((5.0, 0.5))


def test_path_headings_are_the_way_the_robot_sets_off_not_the_straight_line():
    # a 10 x 6 m hall with a wall at x 3.0-3.2 from the floor up to y 4.5: from (2, 3) the
    # place (4.5, 3) lies straight east, but the way there goes north round the wall's end
    g = np.zeros((int(6.0 / RES), int(10.0 / RES)), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    g[:int(4.5 / RES), int(3.0 / RES):int(3.2 / RES)] = 100
    grid = PlanningGrid(map_from_grid(g, RES))
    places = [(4.5, 3.0), (2.0, 1.0), (2.0, 3.0)]
    cols, rows = zip(*(grid.to_cell(x, y) for x, y in places))
    head = path_headings(grid, (2.0, 3.0), np.array(rows), np.array(cols), 12.0)
    assert math.degrees(head[0]) > 45.0          # north first, not east (0 degrees)
    assert head[1] == pytest.approx(-math.pi / 2, abs=0.2)   # open floor: straight south
    assert not math.isnan(head[2])               # its own cell: the cell's centre
    # from a point too near the wall to stand on (0.1 m from it): from the nearest cell the
    # robot can stand on, as the planner starts, not NaN
    c, r = grid.to_cell(2.9, 3.0)
    assert not np.isfinite(grid.cost[r, c])
    off = path_headings(grid, (2.9, 3.0), np.array(rows[1:2]), np.array(cols[1:2]), 12.0)[0]
    assert -math.pi < off < 0.0                  # (2, 1) lies south-west of it
    # out of reach of the search: NaN
    assert math.isnan(path_headings(grid, (2.0, 3.0), np.array(rows[:1]), np.array(cols[:1]),
                                    1.0)[0])


def test_hubs_are_the_places_most_ways_between_places_go_through():
    """Five places 4 m apart along a 3 m wide corridor, joined within 2 x 3 m: a path graph.
    Of the ten ways between two places, the middle one (x 10) lies on four, x 6 and x 14 on
    three each, the ends on none; x 6 and 14 are within 6 m of x 10, so x 10 is the only
    hub. A wall across the corridor at x 8 cuts the graph in two: then x 14, the middle of
    the three places east of it, is the hub (one way), and nothing west of it."""
    places = np.array([[x, 1.5] for x in (2.0, 6.0, 10.0, 14.0, 18.0)])
    grid = hall(20.0, 3.0)
    assert hub_points(grid, places, 3.0, 1.0, 3).tolist() == [[10.0, 1.5]]
    assert len(hub_points(grid, places, 3.0, 1.6, 3)) == 0    # the corridor's 1.4 m clearance
    assert len(hub_points(grid, places, 1.5, 1.0, 3)) == 0    # 4 m apart: no place joined
    g = np.zeros((int(round(3.0 / RES)), int(round(20.0 / RES))), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    g[:, int(round(8.0 / RES))] = 100
    walled = PlanningGrid(map_from_grid(g, RES))
    assert hub_points(walled, places, 3.0, 1.0, 3).tolist() == [[14.0, 1.5]]


def test_after_the_plan_a_search_watches_at_the_hub_by_turns_with_the_patrol():
    """Lost for good in a 20 x 3 m corridor: the plan's region for two rounds, then the hub
    (the patrol place at x 8.05 of x 1.55, 4.05, ..., 16.05), looking round there again and
    again for ``watch`` seconds, then patrol places for as long, then the hub again (the
    only one). With ``watch`` 0 it patrols straight after the plan."""
    grid = hall(20.0, 3.0)
    hub = tuple(hub_points(grid, patrol_points(grid, 4.0, 0.6), 4.0, 3 * 0.34, 3)[0])
    assert hub == pytest.approx((8.05, 1.45))
    cfg = FollowConfig(lost_after=1.0, search_wait=1.0, search_rounds=2, trail=0.0,
                       patrol_sight=0.0, watch=10.0)
    goals = lost_and_searching(FollowBehaviour(grid, cfg), [("7", (18.0, 1.5))], ticks=60)
    kinds = [("watch" if "watching at the place" in r else "patrol" if "patrolling" in r
              else "search" if "searching" in r else "look" if "looking round" in r else r,
              g) for r, g in goals]
    first = next(i for i, (k, _) in enumerate(kinds) if k == "watch")
    assert [k for k, _ in kinds[:first]].count("search") == 2
    assert kinds[first][1] == hub and "hub 1 of 1" in goals[first][0]
    # at the hub: only turns on the spot until the watch is over, at least two of them
    looks = []
    for k, g in kinds[first + 1:]:
        if k != "look":
            break
        looks.append(g)
    assert len(looks) >= 2 and all(g == hub for g in looks)
    assert any("watching at hub 1: looking round" in r for r, _ in goals)
    rest = [k for k, _ in kinds[first + 1 + len(looks):]]
    assert rest[0] == "patrol" and goals[first + 1 + len(looks)][1] != hub   # not the hub again
    assert "watch" in rest                     # back to the hub after patrolling
    # 10 s of patrol at 1.5 s a tick and three ticks a place (go, look, wait): 3 places
    assert [k for k in rest[:rest.index("watch")] if k == "patrol"] == ["patrol"] * 3
    # watch 0: the patrol straight after the plan, never a hub
    cfg.watch = 0.0
    goals = lost_and_searching(FollowBehaviour(grid, cfg), [("7", (18.0, 1.5))], ticks=60)
    assert not any("watching" in r for r, _ in goals)
    assert any("patrolling" in r for r, _ in goals)


def lost_in_a_hall(search_rounds):
    """An observer at (2, 2) in a 20 x 3 m hall that saw the target once 4 m off, then lost
    it, with a plan of two regions: the behaviour, the plan, and its first search decision
    (at 2 s)."""
    cfg = FollowConfig(lost_after=1.0, search_wait=1.0, search_rounds=search_rounds,
                       trail=0.0, patrol_sight=0.0)
    fb = FollowBehaviour(hall(20.0, 3.0), cfg)
    plan = [("7", (18.0, 1.5)), ("8", (10.0, 1.5))]
    fb.update(0.0, (2.0, 2.0, 0.0), (6.0, 2.0, 0.0, 0.0))
    return fb, plan, fb.update(2.0, (2.0, 2.0, 0.0), None, plan)


def test_a_search_point_the_observer_did_not_get_to_is_not_taken_for_reached():
    """mit_csail: a goal with no way to it ends at once; the observer looked round 3.5 m
    from the search point "at region 1's search point", again and again. Now a place more
    than a metre off is not reached: on to the next region of the plan."""
    fb, plan, d = lost_in_a_hall(search_rounds=1)
    robot = (2.0, 2.0, 0.0)
    assert d.goal[:2] == (18.0, 1.5)
    d = fb.update(2.5, robot, None, plan, goal_done=True)      # it never moved
    assert d.reason.startswith("region 7's search point not reached (16.0 m short); ")
    assert d.goal[:2] == (10.0, 1.5) and "region 8" in d.reason
    d = fb.update(3.0, (9.3, 1.5, 0.0), None, plan, goal_done=True)   # 0.7 m off: there
    assert d.reason == "at region 8's search point: looking round"


def test_places_none_of_which_is_reached_are_skipped_as_many_in_a_row_as_the_plan_has():
    """Shut in (every goal ends at once where it stands), the observer sent a new goal every
    tick for ever, a plan each; now, after as many places in a row as the plan has regions,
    it looks round where it is and waits, as at a place reached."""
    fb, plan, d = lost_in_a_hall(search_rounds=2)
    robot, t, reasons = (2.0, 2.0, 0.0), 2.0, []
    for _ in range(8):
        if d.goal is not None:
            reasons.append(d.reason)
        t += 0.5
        d = fb.update(t, robot, None, plan, goal_done=d.goal is not None)
    assert [r.split(" (")[0] for r in reasons[1:4]] == [
        "region 7's search point not reached", "region 8's search point not reached",
        "region 7's search point not reached"]
    assert reasons[3].endswith("3 places in a row: looking round here")
    assert reasons[4].startswith("not found: searching region 8")   # after the wait


def test_a_search_place_moved_out_of_a_pocket_is_reached_at_the_place_it_was_moved_to():
    grid = hall_with_pocket()
    fb = FollowBehaviour(grid, FollowConfig(lost_after=1.0, snug=0.04, search_rounds=1,
                                            trail=0.0, patrol_sight=0.0))
    plan = [("P", (5.0, 5.5)), ("Q", (1.0, 2.0))]
    robot = (8.0, 2.0, 0.0)
    fb.update(0.0, robot, (8.5, 2.0, 0.0, 0.0))
    d = fb.update(2.0, robot, None, plan)
    while "region P" not in d.reason:
        d = fb.update(2.5, robot, None, plan, goal_done=True)
    assert "is in a pocket" in d.reason and math.hypot(d.goal[0] - 5.0, d.goal[1] - 5.5) > 1.0
    d = fb.update(5.0, tuple(d.goal), None, plan, goal_done=True)   # got where it was sent
    assert d.reason == "at region P's search point: looking round"


def test_a_hub_the_observer_did_not_get_to_is_not_watched():
    """The way to the hub ends where the observer stands, 10 m short of it: it neither looks
    round there nor keeps a watch (a place more than a metre off is not reached); the patrol
    follows at once."""
    grid = hall(20.0, 3.0)
    cfg = FollowConfig(lost_after=1.0, search_wait=1.0, search_rounds=2, trail=0.0,
                       patrol_sight=0.0, watch=10.0)
    fb = FollowBehaviour(grid, cfg)
    plan = [("7", (18.0, 1.5))]
    fb.update(0.0, (2.0, 2.0, 0.0), (6.0, 2.0, 0.0, 0.0))
    t, robot, reasons = 2.0, (2.0, 2.0, 0.0), []
    d = fb.update(t, robot, None, plan)
    for _ in range(30):
        if d.goal is not None:
            reasons.append(d.reason)
            if "watching at the place" not in d.reason:   # never gets to the hub
                robot = d.goal
        t += 1.5
        d = fb.update(t, robot, None, plan, goal_done=d.goal is not None)
    went = reasons.index(next(r for r in reasons if "watching at the place" in r))
    assert robot != (8.05, 1.45)
    assert not any("at hub 1" in r or "watching at hub" in r for r in reasons[:went + 2])
    assert reasons[went + 1].startswith("hub 1 not reached (10.0 m short); ")
    assert "patrolling" in reasons[went + 1]


def corridor_beside_room(end_col=None):
    """A 10 x 5 m hall split along its length by a one-cell wall at y = 1 m: a corridor
    0.95 m wide (y 0.05-1.0) below, a room above, no way between them on this map; with
    ``end_col``, a wall across the corridor in that column."""
    g = np.zeros((int(round(5.0 / RES)), int(round(10.0 / RES))), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    g[int(round(1.0 / RES)), :] = 100
    if end_col is not None:
        g[:int(round(1.0 / RES)), end_col] = 100
    return PlanningGrid(map_from_grid(g, RES))


def test_a_standoff_point_with_sight_is_not_behind_the_corridors_wall():
    grid = corridor_beside_room()
    target, robot = (6.0, 0.525), (2.0, 0.525)
    straight_back = (4.5, 0.525)
    assert grid.is_free(*straight_back) and grid.clearance_at(*straight_back) < 0.6
    # without sight: the first roomy point within 90 degrees, in the room past the wall
    p = standoff_point(grid, target, robot, 1.5, roomy=0.6)
    assert p[1] > 1.05 and grid.clearance_at(*p) >= 0.6
    assert not grid.in_sight(np.array([p]), target)[0]
    # with sight: nothing roomy is in view, so the first free point in view, straight back
    q = standoff_point(grid, target, robot, 1.5, roomy=0.6, sight=True)
    assert q == pytest.approx(straight_back, abs=1e-9)
    assert grid.in_sight(np.array([q]), target)[0]
    # the observer following with standoff_sight sends that goal, facing the target
    fb = FollowBehaviour(grid, FollowConfig(distance=1.5, roomy=0.6, standoff_sight=True))
    d = fb.update(0.0, (*robot, 0.0), (*target, 0.5, 0.0))
    assert d.mode == "follow" and d.goal[:2] == pytest.approx(straight_back, abs=1e-9)
    assert d.goal[2] == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(FollowError, match="standoff_sight must be true or false"):
        FollowConfig(standoff_sight="yes").check()


def test_a_standoff_point_with_sight_comes_from_a_smaller_circle_before_one_behind_a_wall():
    grid = corridor_beside_room(end_col=44)       # the corridor ends at x = 2.2 m
    target, robot = (1.0, 0.525), (2.0, 3.0)     # the observer in the room above
    p = standoff_point(grid, target, robot, 1.5, roomy=0.6)
    assert p[1] > 1.05 and not grid.in_sight(np.array([p]), target)[0]
    q = standoff_point(grid, target, robot, 1.5, roomy=0.6, sight=True)
    assert q[1] < 1.0 and grid.in_sight(np.array([q]), target)[0]
    assert math.hypot(q[0] - 1.0, q[1] - 0.525) == pytest.approx(0.75, abs=1e-9)


def test_a_standoff_point_with_sight_and_nothing_in_view_is_the_one_without():
    grid = corridor_beside_room()
    # a track in the dividing wall's cell: every line to it ends in a wall; the first free
    # candidate is in the corridor (0.4 m of clearance), a roomy one lies in the room
    target, robot = (6.0, 1.02), (2.0, 0.525)
    assert not grid.is_free(*target)
    p = standoff_point(grid, target, robot, 1.5, roomy=0.6)
    assert p is not None and grid.clearance_at(*p) >= 0.6
    assert standoff_point(grid, target, robot, 1.5, roomy=0.6, sight=True) == p
    # in the open, a roomy point on the observer's side in view: the same with and without
    h = hall()
    assert standoff_point(h, (6.0, 2.0), (2.0, 2.0), 1.5, roomy=0.6, sight=True) \
        == standoff_point(h, (6.0, 2.0), (2.0, 2.0), 1.5, roomy=0.6) \
        == pytest.approx((4.5, 2.0), abs=1e-9)
