"""The embedded navigation default against hand-made maps and the real core world (no ROS)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from bullet_floor_sim.sim.config import load_world_config, resolve_world
from bullet_floor_sim.sim.floormap import map_from_grid
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.nav import grid as G
from bullet_floor_sim.nav.planner import (FollowerConfig, Navigator, NavigatorConfig,
                                           PathFollower, PlanError,
                                           PlannerConfig, PlanningGrid, obstacles_in_base,
                                           path_length)
from bullet_floor_sim.sim.world import World

RES = 0.05


def two_rooms(door=(1.5, 2.5)):
    """8 m x 4 m, outer walls 0.1 m, a wall at x 3.95..4.05 with a door over y in `door`."""
    h, w = int(4 / RES), int(8 / RES)
    g = np.zeros((h, w), dtype=np.int8)
    g[:2, :] = g[-2:, :] = 100
    g[:, :2] = g[:, -2:] = 100
    g[:, 79:81] = 100
    if door is not None:
        g[int(door[0] / RES):int(door[1] / RES), 79:81] = 0
    return map_from_grid(g, RES)


def fine_clearance(fmap, pts):
    d = distance_transform_edt(fmap.grid != 100) * fmap.resolution
    col, row = fmap.world_to_cell(pts[:, 0], pts[:, 1])
    return d[row, col] - fmap.resolution / 2.0


def test_straight_path_is_straight_and_exact_at_both_ends():
    grid = PlanningGrid(two_rooms())
    path = grid.plan((0.8, 2.0), (3.2, 2.0))
    assert tuple(path[0]) == (0.8, 2.0) and tuple(path[-1]) == (3.2, 2.0)
    assert path_length(path) == pytest.approx(2.4, abs=0.02)
    assert np.abs(path[:, 1] - 2.0).max() < 0.06


def test_path_through_a_door_keeps_the_robot_radius_from_every_wall():
    fmap = two_rooms()
    cfg = PlannerConfig(robot_radius=0.34)
    path = PlanningGrid(fmap, cfg).plan((1.0, 0.6), (7.0, 3.4))
    assert path_length(path) < 1.25 * math.hypot(6.0, 2.8)
    assert fine_clearance(fmap, path).min() >= cfg.robot_radius
    at_door = path[np.abs(path[:, 0] - 4.0) < 0.05]
    assert len(at_door) and np.abs(at_door[:, 1] - 2.0).max() < 0.12  # door centre, not a jamb
    assert np.hypot(*np.diff(path, axis=0).T).max() <= cfg.path_spacing + 1e-9


@pytest.mark.parametrize("goal, match", [
    ((4.0, 3.5), r"goal \(4.00, 3.50\) is inside a wall"),
    ((9.0, 2.0), r"goal \(9.00, 2.00\) is outside the map \(x 0.00..8.00, y 0.00..4.00\)"),
    ((7.7, 2.0), r"too close to a wall \(clearance 0.1\d m < robot radius 0.34 m\)"),
    ((float("nan"), 1.0), r"not a finite position"),
])
def test_bad_goals_raise_with_the_reason(goal, match):
    with pytest.raises(PlanError, match=match):
        PlanningGrid(two_rooms()).plan((1.0, 2.0), goal)


def test_unreachable_goal_and_too_narrow_door():
    with pytest.raises(PlanError, match=r"unreachable from \(1.00, 2.00\)"):
        PlanningGrid(two_rooms(door=None)).plan((1.0, 2.0), (6.0, 2.0))
    narrow = two_rooms(door=(1.7, 2.3))  # 0.6 m < two radii
    with pytest.raises(PlanError, match="unreachable"):
        PlanningGrid(narrow).plan((1.0, 2.0), (6.0, 2.0))


def test_obstacle_points_are_planned_around():
    grid = PlanningGrid(two_rooms())
    blob = np.array([(2.0, y) for y in np.arange(1.2, 2.9, 0.05)])
    path = grid.plan((0.8, 2.0), (3.2, 2.0), obstacles=blob)
    d = np.min(np.hypot(path[:, None, 0] - blob[None, :, 0], path[:, None, 1] - blob[None, :, 1]),
               axis=1)
    assert d.min() >= 0.34
    assert path_length(path) > 2.4 + 0.5


def test_obstacle_points_stamp_the_cells_within_the_radius_whole_or_in_a_window():
    grid = PlanningGrid(two_rooms())
    rad = grid.config.robot_radius + 0.5 * grid.resolution
    start = (0.8, 2.0)
    pts = np.array([(2.0, 1.3), (2.03, 2.71), (0.9, 2.05), (3.96, 0.12), (50.0, 50.0)])
    cost = grid.cost.copy()
    got = grid._stamp_obstacles(cost, pts, start)
    # by hand: every grid cell whose centre lies within rad of a point, but for the point
    # inside the robot's own footprint at start (0.1 m off) and the one off the map
    rows, cols = np.mgrid[0:grid.height, 0:grid.width]
    x, y = grid.centres(cols, rows)
    want = np.zeros(cost.shape, dtype=bool)
    for px, py in pts[[0, 1, 3]]:
        want |= np.hypot(x - px, y - py) <= rad
    assert got == set(np.flatnonzero(want).tolist()) and len(got) > 40
    assert np.isinf(cost[want]).all()
    assert np.array_equal(cost[~want], grid.cost[~want])
    # a window of the costs (cols 10-29, rows 5-24) gets the same cells, cut to it
    window = grid.cost[5:25, 10:30].copy()
    grid._stamp_obstacles(window, pts, start, corner=(10, 5))
    assert np.array_equal(np.isinf(window), np.isinf(cost[5:25, 10:30]))
    assert not grid._stamp_obstacles(grid.cost.copy(), pts[[2]], start)


def test_plans_after_many_plans_are_a_fresh_grids_and_a_copy_plans_alike():
    import copy
    import pickle

    grid = PlanningGrid(load_map_of("office"))
    rng = np.random.default_rng(5)
    free = np.argwhere(np.isfinite(grid.cost))
    pairs = [tuple(grid.to_world(c, r) for r, c in free[rng.integers(len(free), size=2)])
             for _ in range(12)]
    body = np.array([(15.0, 10.0), (15.05, 10.1)])          # an obstacle for every other plan
    used = [_plan_or_none(grid, a, b, body if k % 2 else None) for k, (a, b) in
            enumerate(pairs)]
    assert sum(p is not None for p in used) >= 8
    for k, (a, b) in enumerate(pairs):   # each again on a grid that never planned
        want = _plan_or_none(PlanningGrid(grid.fmap), a, b, body if k % 2 else None)
        assert (want is None) == (used[k] is None)
        assert want is None or np.array_equal(want, used[k])
    for twin in (copy.deepcopy(grid), pickle.loads(pickle.dumps(grid))):
        a, b = pairs[0]
        assert np.array_equal(twin.plan(a, b), grid.plan(a, b))
    with pytest.raises(PlanError, match=r"obstacles: \(N, 2\) map-frame points expected"):
        grid.plan(pairs[0][0], pairs[0][1], obstacles=np.zeros((4, 3)))


def _plan_or_none(grid, a, b, obstacles):
    try:
        return grid.plan(a, b, obstacles=obstacles)
    except PlanError:
        return None


def load_map_of(world):
    from bullet_floor_sim.sim.floormap import load_map
    return load_map(load_world_config(resolve_world(world, worlds_dir())).map_yaml)


def test_follower_stops_for_an_obstacle_ahead_but_not_beside():
    f = PathFollower(FollowerConfig(robot_radius=0.34, stop_distance=0.3, side_margin=0.03))
    f.set_path(np.array([[0.0, 0.0], [5.0, 0.0]]))
    assert f.compute((0, 0, 0), np.array([[0.6, 0.1]])).state == "blocked"
    assert f.compute((0, 0, 0), np.array([[0.6, 0.4]])).state == "following"
    assert f.compute((0, 0, 0), np.array([[-0.5, 0.0]])).state == "following"
    cmd = f.compute((0, 0, math.pi), None)
    assert cmd.state == "rotating" and cmd.v == 0.0


def test_follower_stopped_beside_something_new_goes_on_unless_the_path_takes_it_nearer():
    # a point 0.36 m to the left and 4 cm ahead: inside the stop corridor's half-width (0.37)
    # but beyond the footprint (0.34). Straight on, the robot gets no nearer to it: it goes
    # (before, it was blocked there for good); a path bending left towards it stops it.
    f = PathFollower(FollowerConfig(robot_radius=0.34, stop_distance=0.3, side_margin=0.03))
    beside = np.array([[0.04, 0.36]])
    f.set_path(np.array([[0.0, 0.0], [5.0, 0.0]]))
    cmd = f.compute((0, 0, 0), beside, np.array([False]))
    assert cmd.state == "following" and cmd.v > 0
    f.set_path(np.array([[0.0, 0.0], [0.4, 0.1], [1.0, 0.6]]))
    assert f.compute((0, 0, 0), beside, np.array([False])).state == "blocked"
    # the same point 0.3 m further ahead lies in the corridor the robot would sweep: it stops
    f.set_path(np.array([[0.0, 0.0], [5.0, 0.0]]))
    assert f.compute((0, 0, 0), np.array([[0.35, 0.36]]), np.array([False])).state == "blocked"
    # heading 0.45 rad left of its path, the point at map (0.08, 0.36) lies 0.23 m ahead of
    # it: the path's line passes it at 0.36 m, but pure pursuit's arc sets off along the
    # heading, into it (the exemption is for points beside the robot, not ahead)
    yaw = 0.45
    c, s = math.cos(yaw), math.sin(yaw)
    ahead = np.array([[c * 0.08 + s * 0.36, -s * 0.08 + c * 0.36]])
    f.set_path(np.array([[0.0, 0.0], [5.0, 0.0]]))
    cmd = f.compute((0, 0, yaw), ahead, np.array([False]))
    assert cmd.v == 0.0 and cmd.state in ("rotating", "blocked")


def test_free_along_path_measures_along_the_line_to_the_first_point_near_it():
    # robot at the origin facing +x; the line runs (0, 0) -> (1, 0) -> (1, 4); half-width
    # 0.34 + 0.03 = 0.37; sweep 1.5 m: the second segment begins within it and counts whole
    f = PathFollower(FollowerConfig(robot_radius=0.34, stop_distance=0.3, side_margin=0.03,
                                    sweep=1.5))
    f.set_path(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 4.0]]))
    pose = (0.0, 0.0, 0.0)
    # 0.2 m beside the second segment, 0.5 m along it: 1.0 + 0.5 m along the line
    assert f.free_along_path(pose, np.array([[1.2, 0.5]])) == pytest.approx(1.5 - 0.34)
    # a point 0.1 m beside the first segment, 0.8 m along, comes first
    got = f.free_along_path(pose, np.array([[1.2, 0.5], [0.8, 0.1], [5.0, 0.1]]))
    assert got == pytest.approx(0.8 - 0.34)
    # 3 m along the long second segment (which begins within the sweep): 4.0 m along
    assert f.free_along_path(pose, np.array([[1.1, 3.0]])) == pytest.approx(4.0 - 0.34)
    # near no segment, or behind the robot: nothing
    assert f.free_along_path(pose, np.array([[5.0, 0.1], [0.5, 0.6], [-0.2, 0.0]])) == math.inf
    # turned half round, the same map point (0.8, 0.1) is behind: nothing ahead
    assert f.free_along_path((0.0, 0.0, math.pi), np.array([[-0.8, -0.1]])) == math.inf
    # a segment that begins beyond the sweep is not looked along: (1.1, 1.8) lies 0.1 m
    # beside (1, 1) -> (1, 2), which begins 2 m along, and 0.81 m from the segment before
    f.set_path(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 2.0]]))
    assert f.free_along_path(pose, np.array([[1.1, 1.8]])) == math.inf
    f.config.sweep = 2.5
    assert f.free_along_path(pose, np.array([[1.1, 1.8]])) == pytest.approx(2.8 - 0.34)
    # a repeated path point (a zero-length segment) adds nothing along the line: 0.36 m
    # beside the last segment, 0.8 m along (0.47 m from the first one's end)
    f.set_path(np.array([[0.0, 0.0], [0.5, 0.0], [0.5, 0.0], [1.0, 0.0]]))
    assert f.free_along_path(pose, np.array([[0.8, 0.36]])) == pytest.approx(0.8 - 0.34)
    # with the robot at the path's end there is no line left
    f.set_path(np.array([[0.0, 0.0]]))
    assert f.free_along_path(pose, np.array([[0.5, 0.0]])) == math.inf


def test_scan_points_land_in_the_base_frame():
    pts = obstacles_in_base([1.0, float("inf"), 2.0], -math.pi / 2, math.pi / 2, 30.0,
                            (0.3, 0.0, 0.0))
    np.testing.assert_allclose(pts, [[0.3, -1.0], [0.3, 2.0]], atol=1e-12)


def _wall_distance(world, x, y, reach=1.0):
    """Exact distance (m) from (x, y) to the nearest solid cell's square (inf beyond reach)."""
    fm = world.solid.fmap
    res = fm.resolution
    col, row = fm.world_to_cell(x, y)
    n = int(reach / res) + 1
    r0, c0 = max(int(row) - n, 0), max(int(col) - n, 0)
    rows, cols = np.nonzero(fm.occupied[r0:int(row) + n + 1, c0:int(col) + n + 1])
    if not len(rows):
        return math.inf
    x0 = fm.origin[0] + (cols + c0) * res   # the maps here have no origin yaw
    y0 = fm.origin[1] + (rows + r0) * res
    dx = np.maximum.reduce([x0 - x, np.zeros_like(x0), x - (x0 + res)])
    dy = np.maximum.reduce([y0 - y, np.zeros_like(y0), y - (y0 + res)])
    return float(np.hypot(dx, dy).min())


def _drive(world, navs, goals, limit=400.0):
    """Run navigators in the core world; return per-robot (state, time, error, min clearance)."""
    lp = world.models[0].laser_pose
    lp = (lp[0], lp[1], lp[3])  # (x, y, yaw) of the laser in base_footprint
    obs = [None] * len(world.specs)
    now = 0.0
    for i, nav in enumerate(navs):
        nav.start(world.view(i).pose, goals[i], now)
    out = [None] * len(navs)
    minclear = [math.inf] * len(navs)
    while now < limit and any(o is None for o in out):
        for i, nav in enumerate(navs):
            if out[i] is not None:
                continue
            v = world.view(i)
            minclear[i] = min(minclear[i], _wall_distance(world, v.pose[0], v.pose[1]))
            st = nav.update(v.pose, obs[i], now)
            world.command(i, st.v, 0.0, st.w)
            if st.state != "active":
                out[i] = (st.state, now, math.hypot(v.pose[0] - goals[i][0],
                                                    v.pose[1] - goals[i][1]), v.pose)
        for _ in range(10):
            for s in world.step(1):
                obs[s.robot] = obstacles_in_base(s.ranges, s.angle_min, s.angle_increment,
                                                 s.range_max, lp)
        now += 0.1
    return out, minclear


def test_two_robots_meeting_head_on_in_the_office_corridor_both_arrive():
    cfg = load_world_config(resolve_world("office", worlds_dir()))
    world = World(cfg, seed=3)
    try:
        grid = PlanningGrid(world.fmap)
        navs = [Navigator(grid), Navigator(grid)]
        # robot1 (3, 10) east into office 7; robot2 (12, 10) west to the corridor's end
        goals = [(10.9, 15.0, 0.0), (2.0, 10.0, 0.0)]
        out, minclear = _drive(world, navs, goals)
        for i in range(2):
            state, t, err, pose = out[i]
            assert state == "succeeded", out
            assert err <= 0.15
            assert abs((pose[2] - goals[i][2] + math.pi) % (2 * math.pi) - math.pi) <= 0.16
            # the body (circumradius 0.32) never touched a wall
            assert minclear[i] > 0.32
        assert navs[0].replans + navs[1].replans >= 1  # they did have to get past each other
    finally:
        world.close()


def test_navigator_aborts_when_blocked_for_good():
    cfg = load_world_config(resolve_world("simple", worlds_dir()))
    robots = [dataclasses.replace(cfg.robots[0], pose=(1.0, 2.0, 0.0)),
              dataclasses.replace(cfg.robots[0], name="wall", pose=(2.4, 2.0, 0.0))]
    world = World(dataclasses.replace(cfg, robots=robots), seed=1)
    try:
        grid = PlanningGrid(world.fmap)
        from bullet_floor_sim.nav.planner import NavigatorConfig
        nav = Navigator(grid, config=NavigatorConfig(blocked_timeout=5.0, sidestep=0.0))
        # the goal is right behind the parked robot, in a 4 m tall room: the path goes around
        # it, so block the way round with the goal itself inside the parked robot's reach
        out, _ = _drive(world, [nav], [(2.4, 2.0, None)], limit=60.0)
        state, t, err, _ = out[0]
        assert state == "aborted" and t < 30.0
    finally:
        world.close()


@pytest.mark.parametrize("parked, outcome", [((3.3, 2.0), "aborted"),
                                              ((3.0, 3.2), "succeeded")])
def test_a_goal_something_stands_on_is_given_up_after_deadlock_time(parked, outcome):
    """A robot parked 0.3 m from the goal (its body over it): no progress for deadlock_time
    (10 s), then "the goal is taken", well before blocked_timeout (30 s) and short of it; one
    parked 1.2 m beside the goal leaves room, and the goal is reached."""
    cfg = load_world_config(resolve_world("simple", worlds_dir()))
    robots = [dataclasses.replace(cfg.robots[0], pose=(1.0, 2.0, 0.0)),
              dataclasses.replace(cfg.robots[0], name="parked", pose=parked + (0.0,))]
    world = World(dataclasses.replace(cfg, robots=robots), seed=1)
    try:
        nav = Navigator(PlanningGrid(world.fmap))
        out, _ = _drive(world, [nav], [(3.0, 2.0, None)], limit=60.0)
        state, t, err, _ = out[0]
        assert state == outcome, out
        if outcome == "aborted":
            assert 0.6 < err < 1.5 and t < 25.0, out
        else:
            assert err <= 0.15
    finally:
        world.close()


def _first_end(x, on_goal, limit=20.0):
    """A robot held at (x, 2) facing a goal at (8, 2) in a 10 m x 4 m room; ``on_goal(t)``:
    whether a scan point (not on the map) lies on the goal at time t. The first (t, state,
    message) that is not active, or None."""
    g = np.zeros((80, 200), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    nav = Navigator(PlanningGrid(map_from_grid(g, 0.05)))
    nav.start((x, 2.0, 0.0), (8.0, 2.0, 0.0), 0.0)
    for k in range(int(limit * 10)):
        t = 0.1 * k
        pts = np.array([[8.0 - x, 0.0]]) if on_goal(t) else None
        st = nav.update((x, 2.0, 0.0), pts, t)
        if st.state != "active":
            return round(t, 1), st.state, st.message
    return None


def test_a_goal_is_taken_only_near_it_and_only_when_something_stays_on_it():
    end = _first_end(7.0, lambda t: True)       # 1 m short, something on it all along
    assert end is not None and end[1] == "aborted" and 9.9 <= end[0] <= 10.5, end
    assert end[2].startswith("the goal is taken")
    crossed = _first_end(7.0, lambda t: 10.5 <= t < 10.7)   # someone crossing it
    assert crossed is None or not crossed[2].startswith("the goal is taken"), crossed
    far = _first_end(5.0, lambda t: True)       # 3 m short: blocked, not taken
    assert far is None or not far[2].startswith("the goal is taken"), far


def test_navigator_notices_a_stall_and_plans_again():
    """Commanded to move but not moving (pressed against a robot its scan stop does not see
    ahead): after stall_time the navigator stops, counts a stall and plans again."""
    g = np.zeros((80, 200), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    from bullet_floor_sim.nav.planner import NavigatorConfig
    nav = Navigator(PlanningGrid(map_from_grid(g, 0.05)), config=NavigatorConfig(stall_time=1.5))
    nav.start((1.0, 2.0, 0.0), (8.0, 2.0, 0.0), 0.0)
    states = []
    for k in range(25):                          # the pose never changes
        st = nav.update((1.0, 2.0, 0.0), None, 0.1 * k)
        states.append((round(0.1 * k, 1), st.message, st.v))
    stalled = [t for t, m, _ in states if m == "stalled"]
    assert stalled and 1.5 <= stalled[0] <= 1.7, states
    assert nav.stalls == 1 and states[0][2] > 0.0
    # moving as commanded is no stall
    nav.start((1.0, 2.0, 0.0), (8.0, 2.0, 0.0), 0.0)
    x = 1.0
    for k in range(30):
        st = nav.update((x, 2.0, 0.0), None, 0.1 * k)
        x += st.v * 0.1
        assert st.message != "stalled"
    assert nav.stalls == 1


def test_points_on_the_map_walls_slow_but_never_stop_the_follower():
    # a corridor 1.2 m wide along x; a wall point 0.35 m to the left and 0.5 m ahead lies in the
    # stop corridor (half-width 0.37) but on a wall the plan keeps clear of: the robot goes on
    grid_map = np.full((40, 100), 100, dtype=np.int8)
    grid_map[14:26, :] = 0
    fmap = map_from_grid(grid_map, 0.05)
    grid = PlanningGrid(fmap)
    y_wall = 26 * 0.05                        # the upper wall's surface
    robot_y = y_wall - 0.36
    seen = np.array([[1.5, y_wall + 0.01], [1.0, y_wall + 0.01]])
    assert grid.on_walls(seen).all()
    assert not grid.on_walls(np.array([[1.5, robot_y]])).any()   # a robot in mid-corridor
    f = PathFollower()
    f.set_path(np.array([[1.0 + 0.1 * k, robot_y] for k in range(20)]))
    base = seen - np.array([1.0, robot_y])    # in the base frame of a robot at (1.0, robot_y, 0)
    base = np.vstack([base, [[0.5, 0.35]]])
    known = grid.on_walls(base + np.array([1.0, robot_y]))
    cmd = f.compute((1.0, robot_y, 0.0), base, known)
    assert cmd.state == "following" and cmd.v > 0
    # without the map's word the same point stops it, and an unknown point stops it always
    f.set_path(np.array([[1.0 + 0.1 * k, robot_y] for k in range(20)]))
    assert f.compute((1.0, robot_y, 0.0), base).state == "blocked"
    robot_ahead = np.array([[0.6, 0.0]])
    f.set_path(np.array([[1.0 + 0.1 * k, robot_y] for k in range(20)]))
    assert f.compute((1.0, robot_y, 0.0), robot_ahead, np.array([False])).state == "blocked"


def _drive_unicycle(nav, pose, obstacles_map, t, seconds, until="", dt=0.1):
    """Run the navigator on a unicycle that does what it is told, against fixed map-frame
    obstacle points, until the goal ends or the status message is ``until``; returns the pose,
    the time and the last status."""
    x, y, yaw = pose
    st = None
    for _ in range(int(round(seconds / dt))):
        c, s = math.cos(yaw), math.sin(yaw)
        pts = None
        if len(obstacles_map):
            d = obstacles_map - np.array([x, y])
            pts = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)
        st = nav.update((x, y, yaw), pts, t)
        if st.state != "active" or (until and st.message == until):
            break
        x, y, yaw = x + st.v * dt * math.cos(yaw), y + st.v * dt * math.sin(yaw), yaw + st.w * dt
        t += dt
    return (x, y, yaw), t, st


def test_a_yielding_robot_backs_out_of_a_narrow_corridor_then_goes_on():
    # a corridor 1.2 m wide (y 1.0..2.2) from x 0 to 12: no room for two robots side by side
    g = np.full((int(3.2 / 0.05), int(12.0 / 0.05)), 100, dtype=np.int8)
    g[int(1.0 / 0.05):int(2.2 / 0.05), 1:-1] = 0
    grid = PlanningGrid(map_from_grid(g, 0.05))
    other = np.array([[5.0 + 0.35 * math.cos(a), 1.6 + 0.35 * math.sin(a)]
                      for a in np.linspace(0, 2 * math.pi, 40, endpoint=False)])
    stubborn = Navigator(grid, PathFollower(), NavigatorConfig())
    stubborn.start((4.0, 1.6, 0.0), (10.0, 1.6), 0.0)
    pose, t, st = _drive_unicycle(stubborn, (4.0, 1.6, 0.0), other, 0.0, 10.0)
    assert st.state == "active" and pose[0] > 3.9 and stubborn.retreats == 0   # it waits
    nav = Navigator(grid, PathFollower(), NavigatorConfig(give_way=True, give_way_clear=1.2))
    nav.start((4.0, 1.6, 0.0), (10.0, 1.6), 0.0)
    pose, t, st = _drive_unicycle(nav, (4.0, 1.6, 0.0), other, 0.0, 30.0, "giving way")
    assert nav.retreats == 1 and st.state == "active" and st.message == "giving way"
    # out of the way: at least 1.2 m from the other robot's body, on the near side
    assert np.min(np.hypot(other[:, 0] - pose[0], other[:, 1] - pose[1])) >= 1.2 - 0.15
    assert pose[0] < 5.0 - 0.35 - 1.2 + 0.15
    # the other robot has gone: after the wait it goes on to its goal
    pose, t, st = _drive_unicycle(nav, pose, np.zeros((0, 2)), t, 60.0)
    assert st.state == "succeeded" and math.hypot(pose[0] - 10.0, pose[1] - 1.6) < 0.2


def test_a_robot_blocked_on_a_loop_waits_before_taking_the_long_way_round():
    """A ring corridor 1.2 m wide round a 9.5 x 3.5 m block; a robot parked across the south
    corridor between the robot and its goal 4 m east. The way round is ~27 m: it waits for
    ``detour_wait`` (10 s) blocked first, in case what blocks it gives way, then takes it;
    with ``detour`` 0 it takes it after ``replan_after`` (2 s)."""
    g = np.zeros((int(6.0 / 0.05), int(12.0 / 0.05)), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    g[int(1.25 / 0.05):int(4.75 / 0.05), int(1.25 / 0.05):int(10.75 / 0.05)] = 100
    grid = PlanningGrid(map_from_grid(g, 0.05))
    other = np.array([[5.0 + 0.35 * math.cos(a), 0.65 + 0.35 * math.sin(a)]
                      for a in np.linspace(0, 2 * math.pi, 40, endpoint=False)])
    start, goal = (3.0, 0.65, 0.0), (7.0, 0.65)

    def round_it(config, seconds):
        """Whether it is on the way round (back west of where it started) after ``seconds``."""
        nav = Navigator(grid, PathFollower(), config)
        nav.start(start, goal, 0.0)
        pose, _, st = _drive_unicycle(nav, start, other, 0.0, seconds)
        assert st.state == "active"
        return pose[0] < start[0] - 0.5

    assert not round_it(NavigatorConfig(), 11.0)          # up to the parked one, and waits
    assert round_it(NavigatorConfig(), 20.0)              # then the long way round
    assert round_it(NavigatorConfig(detour=0.0), 9.0)     # at once without the rule
    # the way round is that long
    way = path_length(grid.plan(start, goal, obstacles=other))
    assert way > 4.0 + 10.0 + 10.0


def test_a_robot_that_cannot_move_backs_off_unless_something_is_behind_it():
    g = np.zeros((60, 100), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    grid = PlanningGrid(map_from_grid(g, 0.05))
    for behind, expect in ((None, True), (np.array([[-0.45, 0.0]]), False)):
        nav = Navigator(grid, PathFollower())
        nav.start((1.0, 1.5, 0.0), (4.0, 1.5), 0.0)
        backed = []
        for k in range(80):            # 8 s pressed against something: it never moves
            st = nav.update((1.0, 1.5, 0.0), behind, 0.1 * k)
            if st.message == "backing up":
                backed.append(st.v)
        assert bool(backed) == expect
        assert all(v < 0 for v in backed)


def test_a_stalled_robot_backs_off_a_cell_nearer_a_wall_but_not_into_it():
    """aces_austin: an observer wedged on a wall's corner (0.339 m of clearance, a bump in the
    wall behind it) could only back off to 0.325 m; refused that, it stood for good."""
    for end, backs in ((13, True), (15, False)):
        g = np.zeros((60, 100), dtype=np.int8)
        g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
        g[35, 8:end] = 100           # a wall stub behind and below the robot, y = 1.2 m
        grid = PlanningGrid(map_from_grid(g, 0.05))
        now, back = (float(grid._fine[tuple(np.array(grid.fmap.world_to_cell(
            np.array([x]), np.array([1.5])))[::-1, 0])]) for x in (1.0, 0.85))
        r = PathFollower().config.robot_radius
        # the back-off ends nearer the wall than the robot's radius: by less than a cell
        # (13), by more (15)
        assert back < min(r, now) and (back >= min(r, now) - 0.05) == backs
        nav = Navigator(grid, PathFollower())
        nav.start((1.0, 1.5, 0.0), (4.0, 1.5), 0.0)
        said = [nav.update((1.0, 1.5, 0.0), None, 0.1 * k).message for k in range(80)]
        moves = [m for m in said if m in ("backing up", "nudging forward")]
        # back first where it may; else only forward is clear (and a back-off that did
        # not move it is followed by a nudge forward)
        assert moves[0] == ("backing up" if backs else "nudging forward")
        assert ("backing up" in moves) == backs


def test_a_robot_boxed_in_by_cautious_checks_eases_out_the_roomier_way():
    """aces_austin: wedged on a wall corner, the observer could not turn; backing off ended
    nearer a wall, and a wall alongside ahead (0.33-0.37 m to the side) filled the strip
    that a nudge forward sweeps. It stood for good; now, stalled twice more with neither way
    clear, it moves off the way with more room on the map."""
    g = np.zeros((60, 100), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    g[35, 8:15] = 100                # backing off would end 0.27 m from this stub
    grid = PlanningGrid(map_from_grid(g, 0.05))
    alongside = np.array([[0.3 + 0.02 * k, 0.35] for k in range(15)])   # base frame
    nav = Navigator(grid, PathFollower())
    nav.start((1.0, 1.5, 0.0), (4.0, 1.5), 0.0)
    said = []
    for k in range(120):             # it never moves nor turns, whatever it is told
        st = nav.update((1.0, 1.5, 0.0), alongside, 0.1 * k)
        said.append((0.1 * k, st.message, st.v))
    eased = [(t, v) for t, m, v in said if m == "nudging forward"]
    assert eased and all(v > 0 for _, v in eased)
    assert not any(m == "backing up" for _, m, _ in said)   # nearer the stub: not that way
    stalls = [t for t, m, _ in said if m == "stalled"]
    assert len([t for t in stalls if t < eased[0][0]]) == 2   # a plan again, twice, first


def test_a_back_off_that_did_not_move_the_robot_is_followed_by_a_nudge_forward():
    """Pressed against something the scan does not show (behind it: the lidar looks ahead),
    a back-off does not move the robot; the next move off is forward, and they alternate."""
    g = np.zeros((60, 100), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    grid = PlanningGrid(map_from_grid(g, 0.05))
    nav = Navigator(grid, PathFollower())
    nav.start((1.5, 1.5, 0.0), (1.5, 2.5), 0.0)    # to its left: it turns first
    said = [nav.update((1.5, 1.5, 0.0), None, 0.1 * k).message for k in range(200)]
    moves = [m for k, m in enumerate(said) if m != said[k - 1]
             and m in ("backing up", "nudging forward")]
    assert moves[:4] == ["backing up", "nudging forward"] * 2
    # a back-off that moved it is not refused: pressed against something unseen ahead
    # again after driving back, it backs off again
    nav = Navigator(grid, PathFollower())
    nav.start((1.0, 1.5, 0.0), (4.0, 1.5), 0.0)
    x, said = 1.0, []
    for k in range(120):
        st = nav.update((x, 1.5, 0.0), None, 0.1 * k)
        said.append(st.message)
        x = min(1.0, x + st.v * 0.1)       # free behind, blocked ahead at x = 1 m
    assert "backing up" in said and "nudging forward" not in said


def test_two_robots_backed_into_each_other_nudge_forward_apart_and_arrive():
    """mit_csail: the observer backed blind into the walker; the two octagons touching could
    neither turn (a corner would press in) nor back off (into each other, unseen behind), and
    each backed off again and again until both gave up, three legs in a row. Back to back and
    touching, each turning to a goal behind the other: both now nudge forward and arrive."""
    for a0 in (0.0, 0.4):
        world = World.from_name("simple", seed=1, physics_rate=100.0)
        try:
            for i, pose in enumerate([(2.5, 2.5, a0), (1.9, 2.5, math.pi + 0.3)]):
                world.pose[i] = world.spawn[i] = pose
            world.reset()
            assert world.radius[0] + world.radius[1] > 0.6 + 0.05   # pressed together
            grid = PlanningGrid(world.fmap)
            navs = [Navigator(grid, PathFollower()), Navigator(grid, PathFollower())]
            goals = [(1.2, 3.4, None), (3.5, 0.6, None)]
            out, _ = _drive(world, navs, goals, limit=60.0)
            for state, t, err, _pose in out:
                assert state == "succeeded" and err < 0.2 and t < 30.0, out
        finally:
            world.close()


def test_a_wedged_robot_nudges_forward_when_behind_is_not_clear_then_gives_up():
    g = np.zeros((60, 100), dtype=np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    grid = PlanningGrid(map_from_grid(g, 0.05))
    nav = Navigator(grid, PathFollower(), NavigatorConfig(blocked_timeout=30.0))
    nav.start((1.0, 1.5, 0.0), (4.0, 1.5), 0.0)
    behind = np.array([[-0.45, 0.0]])
    messages, st = [], None
    for k in range(400):               # 40 s: it never moves nor turns, whatever it is told
        st = nav.update((1.0, 1.5, 0.0), behind, 0.1 * k)
        messages.append((st.message, st.v))
        if st.state != "active":
            break
    assert any(m == "nudging forward" and v > 0 for m, v in messages)
    assert not any(m == "backing up" for m, _ in messages)
    # it waited in place for ever before; now it gives the goal up once stalled 30 s
    assert st.state == "aborted" and st.message.startswith("stalled for 3")
    assert 30.0 < 0.1 * (len(messages) - 1) < 36.0


def test_the_look_ahead_chord_keeps_off_a_door_corner_that_the_path_clears():
    """malaga_corridor's lab door: a path down a channel 1-5 cm wider than the robot, then
    diagonally out. From a heading 30 degrees off the path, a 0.6 m look-ahead chord cut the
    corner 1.5 cm into the wall; the walker stalled there, backed up and tried again until
    it gave up (all six legs malaga_corridor gave up in 200 at seed 1 were here)."""
    goal = (4.16, -10.49, 0.0)
    outcomes = []
    for safe_chord in (True, False):
        world = World.from_name("malaga_corridor", seed=1, physics_rate=100.0)
        try:
            for i, pose in enumerate([(2.64, -8.95, -1.04), (-20.0, -11.3, 0.0)]):
                world.pose[i] = world.spawn[i] = pose
            world.reset()
            grid = PlanningGrid(world.fmap, handling=world.config.map_handling)
            nav = Navigator(grid, PathFollower())
            if not safe_chord:
                nav.follower.clearance = None   # plain pure pursuit
            path = nav.start(world.view(0).pose, goal, 0.0)
            if safe_chord:
                start, f = np.array([2.64, -8.95]), nav.follower
                j = f._safe_target(2.64, -8.95, f.path, 8)
                assert 0 < j < 8
                target = f.path[j]
                t = np.linspace(0.0, 1.0, 50)[:, None]
                chord = grid.clearance_along(start * (1 - t) + target * t).min()
                assert chord >= grid.clearance_along(path[:9]).min() - 0.01
            outcomes.append(_drive(world, [nav], [goal], limit=30.0)[0][0])
        finally:
            world.close()
    assert outcomes[0][0] == "succeeded" and outcomes[0][1] < 15.0
    assert outcomes[1] is None or outcomes[1][0] != "succeeded"   # stuck at the corner


def _compiled_office_grid() -> PlanningGrid:
    """office's planning grid, for the tests that hold nav/grid's numba-compiled functions to
    their plain Python (skipped where numba is not installed)."""
    if not G._JIT:
        pytest.skip("numba is not installed: only the plain Python functions run")
    world = World.from_name("office", seed=0)
    try:
        return PlanningGrid(world.fmap)
    finally:
        world.close()


def test_compiled_astar_takes_the_same_cells_as_plain_python():
    """nav/grid._search compiled by numba and run as plain Python (lists, as without numba)
    expand alike: the same cells from the start to the goal on the real office, walls and a
    blocked disc included, and the same answer for an unreachable goal; buffers left by
    earlier searches (a search's own number marks its cells) answer as fresh ones do."""
    grid = _compiled_office_grid()
    W = grid.width + 2
    flat = grid._padded()
    py = G._search.py_func
    free = np.argwhere(np.isfinite(grid.cost))
    rng = np.random.default_rng(3)
    walled = flat.copy()
    walled[(np.arange(grid.height) + 1) * W + grid.width // 2 + 1] = np.inf  # a wall across

    def buffers(n, arr):
        if arr:
            return np.full(n, np.inf), np.full(n, -1, dtype=np.int64), np.zeros(n, np.int64)
        return [math.inf] * n, [-1] * n, [0] * n

    kept = {arr: buffers(len(flat), arr) for arr in (True, False)}
    gen = 0
    for cells in (flat, walled):
        for _ in range(6):
            (r0, c0), (r1, c1) = free[rng.integers(len(free), size=2)]
            s, g = (r0 + 1) * W + c0 + 1, (r1 + 1) * W + c1 + 1
            out = []
            gen += 1
            for search, arr in ((G._search, True), (py, False)):
                moves = G._moves(W) if arr else tuple(m.tolist() for m in G._moves(W))
                for (best, parent, seen), number in ((buffers(len(cells), arr), 1),
                                                     (kept[arr], gen)):
                    found = search(cells if arr else cells.tolist(), W, s, g, 1.5, *moves,
                                   best, parent, seen, number)
                    chain, u = [], g
                    while found and u != -1:
                        chain.append(int(u))
                        u = parent[u]
                    out.append((found, chain, float(best[g]) if found else None))
            assert out[0] == out[1] == out[2] == out[3]
            if cells is walled and out[0][0]:   # never across the wall
                assert (c0 < grid.width // 2) == (c1 < grid.width // 2)
            assert not out[0][0] or (out[0][2] < math.inf and out[0][1][-1] == s)


def test_compiled_segment_check_and_shortcut_match_plain_python():
    """nav/grid._segment_worst and _shortcut_keep compiled by numba give what they give as
    plain Python: the same worst cost (inf through walls) on random segments of the real
    office, and the same points kept of a path through a door."""
    grid = _compiled_office_grid()
    b = grid.fmap.bounds()
    rng = np.random.default_rng(5)
    args = (grid._fine, grid.cost, grid.factor, grid._frame(), grid.config.robot_radius)
    finite = 0
    for _ in range(400):
        a = rng.uniform(b[:2], b[2:])
        c = a + rng.normal(0.0, 3.0, 2)
        got = G._segment_worst(a[0], a[1], c[0], c[1], *args)
        assert got == G._segment_worst.py_func(a[0], a[1], c[0], c[1], *args)
        finite += math.isfinite(got)
    assert 20 < finite < 400   # both kinds of segment were tried
    fmap = two_rooms()
    g2 = PlanningGrid(fmap)
    path = g2.plan((1.0, 0.6), (7.0, 3.4))
    dense = np.array([g2.to_world(c, r) for c, r in
                      g2._astar(set(), g2.to_cell(1.0, 0.6), g2.to_cell(7.0, 3.4))])
    col, row = fmap.world_to_cell(dense[:, 0], dense[:, 1])
    cc = g2.cost[row // g2.factor, col // g2.factor]
    a2 = (g2._fine, g2.cost, g2.factor, g2._frame(), g2.config.robot_radius)
    keep = G._shortcut_keep(dense[:, 0].copy(), dense[:, 1].copy(), cc, *a2)
    assert list(keep) == G._shortcut_keep.py_func(dense[:, 0], dense[:, 1], cc, *a2)
    assert 2 < len(keep) < len(dense) / 4 and len(path) > len(keep)   # a door: a bend kept
