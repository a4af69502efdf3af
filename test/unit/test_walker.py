"""The walker's decisions on the office world: region lookup, goal sampling (inside, clear of
walls, reachable), seeded legs that follow the chain, log lines, retries and dwell (no ROS)."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt
from scipy.stats import chisquare
from shapely.geometry import Point

from bullet_floor_sim.sim.floormap import load_map, map_from_grid
from bullet_floor_sim.people.markov import MarkovChain
from bullet_floor_sim.nav.planner import PlanningGrid, path_length
from bullet_floor_sim.data.rois import Roi, RoiError, load_rois, roi_at, roi_polygon
from bullet_floor_sim.people.walker import (GoalSampler, Leg, RegionIndex, Walker, WalkerConfig,
                                          WalkerError, anchor, region_label, walkable_regions)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
OFFICE = os.path.join(ROOT, "worlds", "office")


@pytest.fixture(scope="module")
def office():
    fmap = load_map(os.path.join(OFFICE, "map.yaml"))
    rois = load_rois(os.path.join(OFFICE, "rois.yaml"))
    grid = PlanningGrid(fmap)
    # exact distance from each map cell centre to the nearest wall cell's edge
    wall_dist = distance_transform_edt(fmap.grid != 100) * fmap.resolution \
        - fmap.resolution / 2.0
    return fmap, rois, grid, GoalSampler(grid), wall_dist


def walker(office, seed=1, **config):
    _, rois, _, sampler, _ = office
    return Walker(MarkovChain.from_rois(rois), rois, sampler, WalkerConfig(**config), seed)


# --------------------------------------------------------------------------------------------
# regions
# --------------------------------------------------------------------------------------------


def test_region_index_agrees_with_roi_at(office):
    fmap, rois, _, _, _ = office
    index = RegionIndex(rois)
    rng = np.random.default_rng(0)
    xmin, ymin, xmax, ymax = fmap.bounds()
    points = list(zip(rng.uniform(xmin, xmax, 5000), rng.uniform(ymin, ymax, 5000)))
    points += [v for r in rois for v in r.vertices]  # shared vertices: on several boundaries
    points += [(2.65, 8.925), (8.875, 10.0), (-1.0, -1.0), (math.nan, 3.0)]
    inside = 0
    for x, y in points:
        want = roi_at(rois, x, y) if math.isfinite(x) else None
        assert index.roi_at(x, y) is want, (x, y)
        assert index.region_at(x, y) == ("" if want is None else want.id)
        inside += want is not None
    assert inside > 3000  # most of the floor is covered by regions
    assert index.region_at(2.65, 8.925) == "1"  # doorway line: the smaller region (corridor)
    assert index.region_at(2.0, 5.0) == "5"
    assert RegionIndex([]).region_at(1.0, 1.0) == ""


def test_nearest_region_outside_all(office):
    _, rois, _, _, _ = office
    index = RegionIndex(rois)
    assert index.roi_at(0.5, 5.0) is None           # in the west wall, west of office_1
    assert index.nearest(0.5, 5.0).id == "5"
    assert index.nearest(2.0, 5.0).id == "5"
    assert RegionIndex([]).nearest(0.0, 0.0) is None


def test_region_label_and_anchor():
    box = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)]
    assert region_label(Roi("7", "1", "office", "m", box)) == "office 7"
    assert region_label(Roi("office_3", "1", "office", "m", box)) == "office_3"
    assert region_label(Roi("Kitchen", "1", "kitchen", "m", box)) == "Kitchen"
    assert anchor(Roi("a", "1", "office", "m", box)) == (1.0, 1.0)
    # a U shape: the centroid (in the notch) is outside; the anchor is inside
    u = Roi("u", "1", "lab", "m", [(0, 0), (3, 0), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3),
                                   (0, 3)])
    x, y = anchor(u)
    assert roi_polygon(u).contains(Point(x, y))


# --------------------------------------------------------------------------------------------
# goals
# --------------------------------------------------------------------------------------------


def test_goals_are_inside_clear_and_reachable(office):
    fmap, rois, grid, sampler, wall_dist = office
    rng = np.random.default_rng(5)
    start = (3.0, 10.0)  # robot1's start in the corridor
    for roi in rois:
        poly = roi_polygon(roi)
        for k in range(60):
            x, y = sampler.sample(roi, rng, start)
            assert poly.contains(Point(x, y)), roi.id
            assert poly.exterior.distance(Point(x, y)) >= 0.5 - 1e-9, roi.id
            c, r = fmap.world_to_cell(x, y)
            assert wall_dist[int(r), int(c)] >= 0.45 - fmap.resolution, (roi.id, x, y)
            if k < 2:
                path = grid.plan(start, (x, y))  # reachable: the planner finds a path
                assert tuple(path[-1]) == pytest.approx((x, y))


def test_goals_cover_the_region(office):
    _, rois, _, sampler, _ = office
    lab = next(r for r in rois if r.id == "9")
    rng = np.random.default_rng(1)
    pts = np.array([sampler.sample(lab, rng) for _ in range(400)])
    # the lab spans x 17.5..29.1: goals spread over it, not clustered at one spot
    assert pts[:, 0].min() < 19.5 and pts[:, 0].max() > 27.0
    assert pts[:, 1].min() < 2.5 and pts[:, 1].max() > 7.0


def two_rooms():
    """Two 3 m x 3 m rooms side by side, a solid wall between them (no door)."""
    grid = np.zeros((80, 140), dtype=np.int8)   # 7 m x 4 m at 0.05 m
    grid[:2, :] = grid[-2:, :] = 100
    grid[:, :2] = grid[:, -2:] = 100
    grid[:, 68:72] = 100                         # wall at x 3.4..3.6
    return map_from_grid(grid, 0.05, (0.0, 0.0, 0.0))


def test_unreachable_region_is_reported():
    grid = PlanningGrid(two_rooms())
    sampler = GoalSampler(grid, clearance=0.45, margin=0.3, goal_tries=200)
    assert sampler.components == 2
    west = Roi("w", "1", "office", "m", [(0.1, 0.1), (3.4, 0.1), (3.4, 3.9), (0.1, 3.9)])
    east = Roi("e", "1", "office", "m", [(3.6, 0.1), (6.9, 0.1), (6.9, 3.9), (3.6, 3.9)])
    rng = np.random.default_rng(0)
    x, y = sampler.sample(east, rng, start=(5.0, 2.0))
    assert x > 3.6
    assert sampler.sample(east, rng)[0] > 3.6  # no start: reachability is not checked
    assert sampler.sample(west, rng, start=(1.5, 2.0))[0] < 3.4
    with pytest.raises(RoiError, match=r'ROI "e": no acceptable point 0.3 m inside it after 200 '
                                       r"tries \(200 of them inside but not free\) \(its free "
                                       r"space is not connected to the robot's\)"):
        sampler.sample(east, rng, start=(1.5, 2.0))
    # a robot pressed against a wall still belongs to its room's component
    assert sampler.component_at(0.15, 2.0) == sampler.component_at(1.5, 2.0) > 0
    assert sampler.component_at(50.0, 50.0) == 0


def test_a_stay_leg_moves_at_least_min_stay_move_else_another_region_is_drawn():
    """One 7 m x 4 m hall: a big region (west) and a small one (east, 1.2 m square: its
    points all lie within 0.85 m of its centre). Stays in the west region go at least
    min_stay_move from where the walker stands; from the small one every leg goes west and
    the log says why the stay was drawn again; a region with no other way out keeps its
    short stays."""
    grid = np.zeros((80, 140), dtype=np.int8)
    grid[:2, :] = grid[-2:, :] = grid[:, :2] = grid[:, -2:] = 100
    sampler = GoalSampler(PlanningGrid(map_from_grid(grid, 0.05, (0.0, 0.0, 0.0))),
                          clearance=0.45, margin=0.5, goal_tries=100)
    west = Roi("w", "1", "office", "m", [(0.1, 0.1), (4.5, 0.1), (4.5, 1.4), (4.5, 2.6),
                                         (4.5, 3.9), (0.1, 3.9)])
    east = Roi("e", "1", "office", "m", [(4.5, 1.4), (5.7, 1.4), (5.7, 2.6), (4.5, 2.6)])
    chain = MarkovChain.from_rois([west, east])
    w = Walker(chain, [west, east], sampler, WalkerConfig(min_stay_move=1.0), seed=4)
    stays = 0
    for k in range(200):
        leg = w.next_leg((2.0, 2.0), float(k))
        if leg.target_region == "w":
            stays += 1
            assert math.hypot(leg.goal[0] - 2.0, leg.goal[1] - 2.0) >= 1.0
    assert stays > 20
    for k in range(20):
        assert w.next_leg((5.1, 2.0), float(k)).target_region == "w"
    assert any(line.startswith("no goal in office e for a stay 1.0 m from where the walker "
                               "stands (") and line.endswith("drawn again without the stay")
               for line in w.log)
    # without the rule, the small region's stays are drawn (under 1 m off)
    w0 = Walker(chain, [west, east], sampler, WalkerConfig(min_stay_move=0.0), seed=4)
    assert any(w0.next_leg((5.1, 2.0), float(k)).target_region == "e" for k in range(20))
    # a region the chain leaves for no other still gets its (short) stays
    alone = Walker(MarkovChain.from_rois([east]), [east], sampler,
                   WalkerConfig(min_stay_move=1.0), seed=4)
    assert alone.next_leg((5.1, 2.0), 0.0).target_region == "e"


def rooms_and_narrow_door(door_cells: int):
    """Three 2 m x 3 m rooms in a row: a 1.0 m door between the first two, a door of
    ``door_cells`` x 0.05 m between the second and the third, and a 0.3 m wide closet."""
    grid = np.zeros((80, 160), dtype=np.int8)    # 8 m x 4 m at 0.05 m
    grid[:2, :] = grid[-2:, :] = 100
    grid[:, :2] = grid[:, -2:] = 100
    grid[:, 48:52] = 100                          # wall at x 2.4..2.6
    grid[30:50, 48:52] = 0                        # 1.0 m door
    grid[:, 98:102] = 100                         # wall at x 4.9..5.1
    grid[30:30 + door_cells, 98:102] = 0
    grid[2:8, 2:150] = 100                        # a 0.3 m strip along the south wall
    grid[2:8, 2:8] = 0
    return map_from_grid(grid, 0.05, (0.0, 0.0, 0.0))


def test_walkable_regions_leaves_out_a_room_behind_a_narrow_door_and_names_it():
    rois = [Roi("a", "1", "office", "m", [(0.1, 0.4), (2.4, 0.4), (2.4, 3.9), (0.1, 3.9)]),
            Roi("b", "1", "office", "m", [(2.6, 0.4), (4.9, 0.4), (4.9, 3.9), (2.6, 3.9)]),
            Roi("c", "1", "lab", "m", [(5.1, 0.4), (7.9, 0.4), (7.9, 3.9), (5.1, 3.9)]),
            Roi("d", "1", "closet", "m", [(0.1, 0.1), (0.4, 0.1), (0.4, 0.4), (0.1, 0.4)])]
    # a 0.6 m door: the walker (0.34 m radius, planning cells of 0.1 m) does not pass
    sampler = GoalSampler(PlanningGrid(rooms_and_narrow_door(12)), 0.45, 0.5)
    kept, warnings = walkable_regions(rois, sampler)
    assert [r.id for r in kept] == ["a", "b"]
    assert warnings == [
        'region "c" (lab c) cannot be reached: its free space is not connected to the rest of '
        "the floor's (a passage narrower than the walker's 0.68 m footprint with clearance): "
        "left out of the walk",
        'region "d" (closet d) has no point 0.45 m from every wall: left out of the walk']
    # a 0.8 m door (an office door) and a 1.2 m door: all three rooms are one component; a
    # 0.7 m door is narrower than the 0.68 m footprint with any room to spare
    for cells in (16, 24):
        sampler = GoalSampler(PlanningGrid(rooms_and_narrow_door(cells)), 0.45, 0.5)
        kept, warnings = walkable_regions(rois[:3], sampler)
        assert [r.id for r in kept] == ["a", "b", "c"] and warnings == []
    sampler = GoalSampler(PlanningGrid(rooms_and_narrow_door(14)), 0.45, 0.5)
    assert [r.id for r in walkable_regions(rois[:3], sampler)[0]] == ["a", "b"]


def test_narrow_region_gets_goals_with_half_the_margin():
    grid = PlanningGrid(two_rooms())
    sampler = GoalSampler(grid, clearance=0.35, margin=0.5)
    strip = Roi("s", "1", "corridor", "m", [(0.5, 1.6), (3.0, 1.6), (3.0, 2.4), (0.5, 2.4)])
    rng = np.random.default_rng(2)
    for _ in range(50):
        x, y = sampler.sample(strip, rng)
        assert 1.85 <= y <= 2.15  # 0.25 m (half the margin) from the strip's long sides


# --------------------------------------------------------------------------------------------
# legs
# --------------------------------------------------------------------------------------------


def run_legs(w, pose, n):
    legs = []
    for k in range(n):
        leg = w.next_leg(pose, 10.0 * k)
        w.finish(leg, "succeeded", 10.0 * k + 4.0, w.region_at(leg.goal[0], leg.goal[1]))
        legs.append(leg)
        pose = leg.goal
    return legs


def test_same_seed_same_walk_and_goals_reach_their_regions(office):
    a = run_legs(walker(office, seed=11), (3.0, 10.0, 0.0), 40)
    b = run_legs(walker(office, seed=11), (3.0, 10.0, 0.0), 40)
    c = run_legs(walker(office, seed=12), (3.0, 10.0, 0.0), 40)
    assert [(leg.target_region, leg.goal) for leg in a] == \
        [(leg.target_region, leg.goal) for leg in b]
    assert [leg.goal for leg in a] != [leg.goal for leg in c]
    for prev, leg in zip(a, a[1:]):
        assert leg.start_region == prev.target_region
        assert leg.end_region == leg.target_region  # the goal lies in the region drawn
    assert a[0].start_region == "1" and a[0].number == 1 and a[-1].number == 40
    # the goal's yaw points from the start of the leg to the goal
    x0, y0 = 3.0, 10.0
    gx, gy, yaw = a[0].goal
    assert yaw == pytest.approx(math.atan2(gy - y0, gx - x0))


def test_legs_follow_the_chain(office):
    _, rois, _, _, _ = office
    chain = MarkovChain.from_rois(rois)
    w = walker(office, seed=3)
    counts = {}
    pose = (2.0, 5.0)  # office_1 ("5")
    for k in range(3000):
        leg = w.next_leg(pose, float(k))
        counts[leg.target_region] = counts.get(leg.target_region, 0) + 1
    assert set(counts) == {"5", "1"}
    # P(5 -> 5) = 5/6, P(5 -> 1) = 1/6
    _, p = chisquare([counts["5"], counts["1"]], [2500, 500])
    assert p > 0.001
    counts = {}
    for k in range(6000):
        leg = w.next_leg((3.0, 10.0), float(k))  # corridor_west ("1")
        counts[leg.target_region] = counts.get(leg.target_region, 0) + 1
    row = chain.row("1")
    assert set(counts) == set(row)
    ids = sorted(row)
    _, p = chisquare([counts[i] for i in ids], [6000 * row[i] for i in ids])
    assert p > 0.001


def test_a_legs_time_limit_grows_with_its_planned_path_not_the_crows_distance(office):
    _, _, grid, _, _ = office
    w = walker(office, seed=2, timeout_per_m=30.0)
    longer = 0
    for k in range(20):
        leg = w.next_leg((2.0, 5.0, 0.0), float(k))      # from office 5, out through its door
        way = path_length(grid.plan((2.0, 5.0), leg.goal[:2]))
        crow = math.hypot(leg.goal[0] - 2.0, leg.goal[1] - 5.0)
        assert leg.timeout == pytest.approx(max(120.0, 30.0 * way), rel=1e-9)
        longer += 30.0 * way > max(120.0, 30.0 * crow) + 30.0
    assert longer >= 1        # some legs out of the room go round its walls: 30 s more, or more


def test_leg_from_outside_every_region_starts_from_the_nearest(office):
    w = walker(office, seed=4)
    leg = w.next_leg((0.5, 5.0, 0.0), 0.0)   # in office_1's west wall: in no region
    assert leg.start_region == ""
    assert leg.target_region in ("5", "1")   # drawn from office_1's row
    assert w.origin_region(0.5, 5.0) == "5"


def test_log_lines(office):
    w = walker(office)
    leg = Leg(number=0, start_region="7", target_region="2", goal=(12.0, 10.0, 0.0),
              started=100.0)
    assert w.finish(leg, "succeeded", 123.44, "2") == "leg 0: office 7 -> corridor 2 in 23.4 s"
    assert leg.to_dict() == {"leg": 0, "from": "7", "to": "2", "goal": [12.0, 10.0, 0.0],
                             "started": 100.0, "duration": 23.44, "outcome": "succeeded",
                             "detail": "", "end_region": "2", "regoals": 0}
    leg = Leg(number=8, start_region="", target_region="9", goal=(25.1, 4.3, 0.0),
              started=10.0)
    assert w.finish(leg, "timeout", 130.0, "3", "no result within 120 s") == (
        "leg 8: none -> lab 9 timeout after 120.0 s: no result within 120 s (goal 25.10, "
        "4.30; now in corridor 3)")
    assert w.log[-1].startswith("leg 8: none -> lab 9 timeout")
    assert w.visited == {"2"}
    with pytest.raises(ValueError, match="unknown leg outcome 'lost it'"):
        w.finish(leg, "lost it", 1.0, "")


def test_retry_delay_backs_off_and_resets(office):
    w = walker(office, retry_delay=1.0, max_retry_delay=5.0)
    delays = [w.retry_delay()]
    for k in range(5):
        leg = w.next_leg((3.0, 10.0), 0.0)
        w.finish(leg, "aborted", 1.0, "1", "no path")
        delays.append(w.retry_delay())
    assert delays == [0.0, 1.0, 2.0, 4.0, 5.0, 5.0]
    w.finish(w.next_leg((3.0, 10.0), 0.0), "succeeded", 1.0, "1")
    assert w.retry_delay() == 0.0 and w.failures_in_a_row == 0


def test_dwell_is_uniform_in_range_and_seeded(office):
    a = walker(office, seed=9, dwell_min=2.0, dwell_max=4.0)
    b = walker(office, seed=9, dwell_min=2.0, dwell_max=4.0)
    da = [a.dwell() for _ in range(2000)]
    assert da[:10] == [b.dwell() for _ in range(10)]
    assert 2.0 <= min(da) and max(da) <= 4.0
    assert np.mean(da) == pytest.approx(3.0, abs=0.05)
    # the dwell stream is separate: drawing dwell times does not change the regions drawn
    c = walker(office, seed=9)
    assert [leg.target_region for leg in run_legs(a, (3.0, 10.0), 20)] == \
        [leg.target_region for leg in run_legs(c, (3.0, 10.0), 20)]
    assert walker(office, seed=9, dwell_min=3.0, dwell_max=3.0).dwell() == 3.0


def test_seed_none_draws_and_reports_one(office):
    w = walker(office, seed=None)
    assert 0 <= w.seed_used < 2 ** 31  # fits a ROS int parameter
    again = walker(office, seed=w.seed_used)
    assert [leg.goal for leg in run_legs(w, (3.0, 10.0), 5)] == \
        [leg.goal for leg in run_legs(again, (3.0, 10.0), 5)]


def test_set_regions_rebuilds_and_checks(office):
    _, rois, _, _, _ = office
    w = walker(office)
    fewer = [r for r in rois if r.id not in ("5", "6")]
    w.set_regions(MarkovChain.from_rois(fewer), fewer)
    assert {w.next_leg((3.0, 10.0), 0.0).target_region for _ in range(200)} == {"1", "2", "10",
                                                                                 "11"}
    with pytest.raises(WalkerError, match="walker: chain regions without ROI: 5, 6"):
        w.set_regions(MarkovChain.from_rois(rois), fewer)


def test_no_acceptable_goal_gives_up_with_the_reasons(office):
    fmap, _, grid, _, _ = office
    # a region drawn inside a wall block: nothing in it is free
    wall = Roi("w", "1", "office", "office", [(-5.0, -5.0), (-1.0, -5.0), (-1.0, -1.0),
                                              (-5.0, -1.0)])
    w = Walker(MarkovChain.from_rois([wall]), [wall], GoalSampler(grid, goal_tries=20),
               WalkerConfig(max_picks=3), seed=0)
    with pytest.raises(WalkerError, match=r'walker: no acceptable goal in the regions drawn '
                                          r'from office w after 3 draws: ROI "w": no '
                                          r'acceptable point'):
        w.next_leg((-3.0, -3.0), 0.0)
    assert w.legs == 0 and w.log[0].startswith('no goal in office w: ROI "w"')


@pytest.mark.parametrize("config,message", [
    (dict(goal_timeout=0), "goal_timeout must be a finite number of seconds > 0, got 0"),
    (dict(dwell_min=-1.0), "dwell_min must be a finite number >= 0, got -1.0"),
    (dict(dwell_min=5.0, dwell_max=2.0), r"dwell_max \(2 s\) must be >= dwell_min \(5 s\)"),
    (dict(max_picks=0), "max_picks must be an integer >= 1, got 0"),
    (dict(margin=math.inf), "margin must be a finite number >= 0, got inf"),
])
def test_bad_config(office, config, message):
    with pytest.raises(WalkerError, match="walker: " + message):
        walker(office, **config)


# --------------------------------------------------------------------------------------------
# the node's message helpers (no master needed)
# --------------------------------------------------------------------------------------------


def test_roi_from_msg_and_chain_markers():
    from geometry_msgs.msg import Pose
    from visualization_msgs.msg import Marker

    from bullet_floor_sim.msg import SOMAROIObject
    from bullet_floor_sim.ros.markers import chain_markers
    from bullet_floor_sim.ros.soma import roi_from_msg

    msg = SOMAROIObject(id="a", config="1", type="office", map_name="m")
    for x, y in [(0, 0), (2, 0), (2, 2), (0, 2), (0, 0)]:
        p = Pose()
        p.position.x, p.position.y = x, y
        msg.posearray.poses.append(p)
    a = roi_from_msg(msg)
    assert a == Roi("a", "1", "office", "m", [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)])
    b = Roi("b", "1", "corridor", "m", [(2.0, 0.0), (6.0, 0.0), (6.0, 2.0), (2.0, 2.0)])
    chain = MarkovChain.from_rois([a, b])  # P(a->b) = P(b->a) = 1/2
    out = chain_markers(chain, [a, b], "map", None).markers
    assert out[0].action == Marker.DELETEALL
    arrows = [m for m in out if m.ns == "chain_arrows"]
    labels = [m for m in out if m.ns == "chain_labels"]
    assert len(arrows) == 2 and len(labels) == 2
    assert [m.scale.x for m in arrows] == pytest.approx([0.2, 0.2])  # 0.4 x 1/2
    a_to_b = arrows[0]
    # from a's centre (1, 1) towards b's (4, 1), 0.5 m trimmed at each end, 0.15 m to the
    # right of the line (y - 0.15), so that b -> a (to its own right) does not cover it
    assert [c for p in a_to_b.points for c in (p.x, p.y)] == pytest.approx([1.5, 0.85, 3.5, 0.85])
    assert [c for p in arrows[1].points for c in (p.x, p.y)] == pytest.approx([3.5, 1.15, 1.5,
                                                                               1.15])
    assert labels[0].text == "office a\nstay 0.50"
    assert (labels[1].pose.position.x, labels[1].pose.position.y) == (4.0, 1.0)
    assert all(m.header.frame_id == "map" for m in out)
