"""Passing in narrow corridors (nav/passing.py, the Navigator's yielding): the ``corridor``
world, a corridor 20 m x 1.4 m between two halls, robots facing each other in it."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bullet_floor_sim.errors import BulletFloorSimError
from bullet_floor_sim.nav.passing import narrow_axis, passing_place
from bullet_floor_sim.nav.planner import Navigator, NavigatorConfig, PlanningGrid, obstacles_in_base
from bullet_floor_sim.sim.world import World

from bullet_floor_sim.sim.floormap import map_from_grid
from test_planner import _drive, _drive_unicycle

CORRIDOR_Y = (2.95, 4.35)   # the corridor's wall faces; it runs x 4.80 .. 24.80


def test_the_narrow_axis_is_the_corridor_and_passing_places_are_in_the_halls():
    world = World.from_name("corridor", seed=1)
    try:
        grid = PlanningGrid(world.fmap)
        axis = narrow_axis(grid, 0.34, 0.1)
        # the corridor's middle line (clearance 0.7 < 0.34 + 0.34 + 0.05), nothing in the halls
        assert len(axis) > 150
        assert np.all(np.abs(axis[:, 1] - 3.65) <= 0.1)
        assert axis[:, 0].min() < 5.0 and axis[:, 0].max() > 24.6
        assert not np.any((axis[:, 0] < 4.4) | (axis[:, 0] > 25.2))
        # a robot at x 8 facing one at x 10 in the corridor: the nearest place is in the west
        # hall, 0.78 m (two radii and the margin) off the corridor's line
        blocker = np.array([[9.7, 3.65], [9.75, 3.4], [9.75, 3.9]])
        p = passing_place(grid, axis, (8.0, 3.65), blocker, 0.34, 25.0, 0.1)
        assert p is not None and p[0] < 4.65
        d = np.min(np.hypot(axis[:, 0] - p[0], axis[:, 1] - p[1]))
        assert 0.78 - 0.01 <= d <= 0.78 + 0.2
        # out of reach, or cut off by the blocker: none
        assert passing_place(grid, axis, (8.0, 3.65), blocker, 0.34, 3.0, 0.1) is None
        assert passing_place(grid, axis, (12.0, 3.65), blocker, 0.34, 25.0, 0.1)[0] > 24.95
    finally:
        world.close()


def test_the_navigators_passing_margin_sets_its_narrow_axis():
    world = World.from_name("corridor", seed=1)
    try:
        grid = PlanningGrid(world.fmap)
        axes = [Navigator(grid, config=NavigatorConfig(passing_margin=m))._narrow_axis()
                for m in (0.1, 3.0)]
        # 0.1 m: the corridor alone (x 4.80 .. 24.80, its mouths a disc's radius on);
        # 3 m (two discs need 4.36 m): the halls' middles within 2.18 m of a wall too
        assert not np.any((axes[0][:, 0] < 4.4) | (axes[0][:, 0] > 25.2))
        assert len(axes[1]) > len(axes[0]) + 50
        assert axes[1][:, 0].min() < 3.0 and axes[1][:, 0].max() > 26.5
        # worked out once a grid: a second robot (the ROS node: a Navigator a goal) shares it
        again = Navigator(grid, config=NavigatorConfig(passing_margin=0.1))._narrow_axis()
        assert again is axes[0] and not again.flags.writeable
        assert np.array_equal(again, narrow_axis(grid, 0.34, 0.1))
    finally:
        world.close()
    with pytest.raises(BulletFloorSimError,
                       match=r"navigator: passing_margin must be a finite number >= 0, got -0.1"):
        NavigatorConfig(passing_margin=-0.1).check()


def _meet(configs, seed=2):
    world = World.from_name("corridor", seed=seed)
    try:
        grid = PlanningGrid(world.fmap)
        navs = [Navigator(grid, config=c) for c in configs]
        goals = [(27.0, 3.65, 0.0), (2.6, 3.65, math.pi)]
        return _drive(world, navs, goals, limit=300.0) + (navs,)
    finally:
        world.close()


def test_two_robots_facing_each_other_in_a_narrow_corridor_both_arrive():
    out, minclear, navs = _meet([NavigatorConfig(), NavigatorConfig()])
    for i in range(2):
        state, t, err, pose = out[i]
        assert state == "succeeded", out
        assert err <= 0.15 and minclear[i] > 0.3
    # the one heading west (robot2) yielded into the east hall; robot1 never did
    assert navs[1].retreats >= 1 and navs[0].retreats == 0


def test_the_observer_yields_to_the_walker_whichever_way_the_rule_points():
    # the evaluation's and demo.launch's pair: the observer (give_way) heading east, the
    # walker (keep_way, a stand-in person) heading west, the way the heading rule would
    # have yield: the observer backs out of the corridor, the walker never yields
    out, minclear, navs = _meet([NavigatorConfig(give_way=True),
                                 NavigatorConfig(keep_way=True)])
    for i in range(2):
        state, t, err, pose = out[i]
        assert state == "succeeded", out
        assert err <= 0.15 and minclear[i] > 0.3
    assert navs[0].retreats >= 1 and navs[1].retreats == 0
    # 23 m at 0.5 m/s: the walker was held up little (213 s when the observer backed off
    # along the corridor 0.5 m at a time, until the walker's deadlock fallback yielded)
    assert out[1][1] < 100.0, out


def test_a_robot_and_a_person_meeting_in_the_corridor_both_arrive():
    # robot1 heads east, a person (the crowd's social forces, body radius 0.25) walks west
    # from the east hall; 0.68 m of robot and 0.5 m of shoulders fit the 1.4 m side by side:
    # the person squeezes past, and neither waits (measured: both arrive in 37.7 s, centres
    # 0.50 m apart at the closest, shoulders 0.09 m into the robot's planning footprint)
    import dataclasses

    from bullet_floor_sim.people.crowd.build import routes_for
    from bullet_floor_sim.people.crowd.config import BodyConfig
    from bullet_floor_sim.people.crowd.crowd import Crowd, Person
    from bullet_floor_sim.people.crowd.forces import ForceConfig

    world = World.from_name("corridor", seed=2)
    world.close()
    world = World(dataclasses.replace(world.config, robots=world.config.robots[:1]), seed=2)
    try:
        body = BodyConfig()
        crowd = Crowd([Person("p0", None, 1.2)], np.array([[26.0, 3.65]]),
                      routes_for(world, body), body, ForceConfig(), 20.0, world.clock.now_ns)
        world.add_people(crowd)
        crowd.walk_to(0, (2.6, 3.65), None, world.clock.now)
        grid = PlanningGrid(world.fmap)
        nav = Navigator(grid)
        goal = (27.0, 3.65, 0.0)
        nav.start(world.view(0).pose, goal, 0.0)
        lp = world.models[0].laser_pose
        obs, now, closest, st = None, 0.0, math.inf, None
        while now < 200.0:
            pose = world.view(0).pose
            closest = min(closest, float(np.hypot(*(crowd.pos[0] - pose[:2]))))
            st = nav.update(pose, obs, now)
            if st.state != "active" and crowd.people[0].state == "idle":
                break
            world.command(0, st.v if st.state == "active" else 0.0, 0.0,
                          st.w if st.state == "active" else 0.0)
            for _ in range(10):
                for sc in world.step(1):
                    obs = obstacles_in_base(sc.ranges, sc.angle_min, sc.angle_increment,
                                            sc.range_max, (lp[0], lp[1], lp[3]))
            now += 0.1
        assert st.state == "succeeded", (st, now)
        assert crowd.people[0].state == "idle"
        np.testing.assert_allclose(crowd.pos[0], (2.6, 3.65), atol=0.3)
        assert now < 60.0          # 21 m at the robot's 0.6 m/s is 35 s: hardly held up
        assert closest >= 0.45     # not through each other (0.34 + 0.25 - 0.14)
    finally:
        world.close()


def test_a_robot_parked_in_a_loop_corridor_is_passed_the_long_way_round():
    # a ring corridor 1.4 m wide round a 21 x 7 m block; a robot parked on the short way
    g = np.full((int(10.0 / 0.05), int(24.0 / 0.05)), 100, dtype=np.int8)
    g[2:-2, 2:-2] = 0
    g[int(1.5 / 0.05):int(8.5 / 0.05), int(1.5 / 0.05):int(22.5 / 0.05)] = 100
    grid = PlanningGrid(map_from_grid(g, 0.05))
    parked = np.array([[12.0 + 0.35 * math.cos(a), 0.8 + 0.35 * math.sin(a)]
                       for a in np.linspace(0, 2 * math.pi, 40, endpoint=False)])
    nav = Navigator(grid)
    nav.start((6.0, 0.8, 0.0), (18.0, 0.8), 0.0)
    pose, t, st = _drive_unicycle(nav, (6.0, 0.8, 0.0), parked, 0.0, 400.0)
    # about 55 m round: more than progress_timeout (60 s) with the goal getting no nearer
    # as the crow flies, which aborted it before progress counted along the path
    assert st.state == "succeeded", (st, pose, t)
    assert math.hypot(pose[0] - 18.0, pose[1] - 0.8) < 0.2 and t > 80.0
    assert nav.retreats == 0


def test_the_robot_nearer_its_passing_place_yields_whatever_its_heading():
    world = World.from_name("corridor", seed=1)
    try:
        grid = PlanningGrid(world.fmap)
        face = np.array([[10.0 - 0.35 * math.cos(a), 3.65 + 0.35 * math.sin(a)]
                         for a in np.linspace(-1.2, 1.2, 9)])   # the side of it facing west
        near_west = Navigator(grid)
        near_west.start((8.0, 3.65, 0.0), (27.0, 3.65), 0.0)
        assert near_west._yields((8.0, 3.65, 0.0), face)   # 4 m to its hall, the other 15 m
        far = Navigator(grid)
        far.start((20.0, 3.65, 0.0), (27.0, 3.65), 0.0)
        blocker = np.array([[21.7, 3.65], [21.75, 3.4], [21.75, 3.9]])
        # heading east, 15 m from the west hall, the other 3 m from the east one: it waits
        assert not far._yields((20.0, 3.65, 0.0), blocker)
        # something behind it is not met head-on: no yielding to it
        assert not near_west._yields((8.0, 3.65, math.pi), face)
        # mid-corridor, each about 10 m from its hall: the heading rule, the one heading west
        mid = Navigator(grid)
        mid.start((15.2, 3.65, math.pi), (2.0, 3.65), 0.0)
        tie = np.array([[14.55, 3.65], [14.6, 3.4], [14.6, 3.9]])
        assert mid._yields((15.2, 3.65, math.pi), tie)
        east = np.array([[15.05, 3.65], [15.0, 3.4], [15.0, 3.9]])
        assert not mid._yields((14.4, 3.65, 0.0), east)
        # keep_way (the walker): not by the rule
        keeper = Navigator(grid, config=NavigatorConfig(keep_way=True))
        keeper.start((8.0, 3.65, 0.0), (27.0, 3.65), 0.0)
        assert not keeper._yields((8.0, 3.65, 0.0), face)
    finally:
        world.close()


def test_the_heading_rule_picks_exactly_one_of_two_robots_facing_each_other():
    from bullet_floor_sim.nav.passing import heads_west_or_south

    for yaw in np.linspace(-math.pi, math.pi, 721) + 1e-3:   # all but 110 degrees exactly
        other = yaw + math.pi
        assert heads_west_or_south(yaw) != heads_west_or_south(other), yaw
    assert heads_west_or_south(math.pi) and not heads_west_or_south(0.0)
    assert heads_west_or_south(math.radians(-135)) and not heads_west_or_south(math.radians(45))
    # a north-south passage: the one heading south, whatever a little noise in x
    assert heads_west_or_south(-math.pi / 2 + 0.01) and heads_west_or_south(-math.pi / 2 - 0.01)
    assert not heads_west_or_south(math.pi / 2 + 0.01)
    assert not heads_west_or_south(math.pi / 2 - 0.01)



def _meet_late(seed, period, scan_lag, cmd_lag, pose_lag, limit=150.0):
    """office's CI meeting (robot1 from the west corridor to room 12, robot2 from the
    centre to room 5, nose to nose in the 2 m corridor) with a ROS graph's delays: each
    navigator runs every ``period`` s on a pose ``pose_lag`` steps (10 ms) and a scan
    ``scan_lag`` scans old, and its command takes effect ``cmd_lag`` s later. Returns each
    robot's (state, time)."""
    world = World.from_name("office", seed=seed)
    try:
        grid = PlanningGrid(world.fmap)
        navs = [Navigator(grid), Navigator(grid)]
        goals = [(10.96, 15.20, 0.0), (2.65, 4.80, 0.0)]
        lp = world.models[0].laser_pose
        scans, poses, queued = [[None], [None]], [[], []], [[], []]
        out, now, due = [None, None], 0.0, [0.0, 0.0]
        while now < limit and None in out:
            for i in range(2):
                poses[i].append(world.view(i).pose)
                while queued[i] and queued[i][0][0] <= now + 1e-9:
                    world.command(i, queued[i][0][1], 0.0, queued[i].pop(0)[2])
                if out[i] is not None or now + 1e-9 < due[i]:
                    continue
                pose = poses[i][-min(len(poses[i]), 1 + pose_lag)]
                if due[i] == 0.0:
                    navs[i].start(pose, goals[i], now)
                due[i] += period
                scan = scans[i][max(0, len(scans[i]) - 1 - scan_lag)]
                st = navs[i].update(pose, scan, now)
                queued[i].append((now + cmd_lag, st.v, st.w))
                if st.state != "active":
                    out[i] = (st.state, round(now, 1), st.message)
            for sc in world.step(1):
                scans[sc.robot].append(obstacles_in_base(sc.ranges, sc.angle_min,
                                                         sc.angle_increment, sc.range_max,
                                                         (lp[0], lp[1], lp[3])))
            now += 0.01
        return out
    finally:
        world.close()


def test_two_robots_nose_to_nose_with_a_ros_graphs_delays_break_the_deadlock():
    """With the delays of a ROS graph (5 Hz control, commands 0.2 s late), the two robots of
    nav_builtin_two.test each planned past the other's unseen far side and stopped on it,
    again and again: both goals were aborted, blocked 30 s (as in a CI run). A deadlock with
    a way round each time is now broken as one with none: after deadlock_time (10 s)
    without progress, the robot the heading rule makes yield (robot2, heading west) steps
    aside to its right and waits; both arrive."""
    out = _meet_late(16, 0.2, 1, 0.2, 2)
    assert [o[0] for o in out] == ["succeeded", "succeeded"], out
    assert max(o[1] for o in out) < 80.0, out
