"""A robot backs up to a goal close behind it that faces its own way (FollowerConfig
.reverse_within), or along a path to a goal that faces back the way there (.reverse_path):
the observer gives way facing the target instead of turning its back on it. On the core
world's physics and by hand."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bullet_floor_sim.geometry import wrap_angle
from bullet_floor_sim.nav.planner import (FollowerConfig, Navigator, NavigatorConfig,
                                          PathFollower, PlanningGrid, obstacles_in_base)
from bullet_floor_sim.sim.floormap import map_from_grid
from bullet_floor_sim.sim.world import World


def _go(reverse_within: float, goal, other=None, reverse_path: float = 0.0,
        resend: float = 0.0):
    """robot2 of the simple room ((3, 3), facing -x) driven to ``goal`` on the physics, its
    scan given to its Navigator (robot1 moved to ``other`` first, when given; the goal sent
    again every ``resend`` s, as the observer's follower does): the end state and pose, the
    largest turn off its first heading on the way, the least forward speed."""
    world = World.from_name("simple", seed=1)
    try:
        if other is not None:
            world.set_pose(0, other)
        nav = Navigator(PlanningGrid(world.fmap),
                        PathFollower(FollowerConfig(reverse_within=reverse_within,
                                                    reverse_path=reverse_path)),
                        NavigatorConfig(give_way=True))
        lp = world.models[1].laser_pose
        lp = (lp[0], lp[1], lp[3])   # (x, y, yaw) of the laser in base_footprint
        yaw0 = world.view(1).pose[2]
        now, turned, least_v, obstacles = 0.0, 0.0, math.inf, None
        _go.messages, _go.after_stall = set(), set()
        nav.start(world.view(1).pose, goal, now)
        sent = now
        while now < 60.0:
            pose = world.view(1).pose
            if resend and now - sent >= resend - 1e-9:
                nav.start(pose, goal, now)
                sent = now
            _go.stalls = nav.stalls
            turned = max(turned, abs(wrap_angle(pose[2] - yaw0)))
            st = nav.update(pose, obstacles, now)
            _go.messages.add(st.message)
            if nav.stalls:
                _go.after_stall.add(st.message)
            if st.state != "active":
                _go.no_reverse = nav.follower.no_reverse   # backing up given up on the way
                return st.state, world.view(1).pose, turned, least_v
            least_v = min(least_v, st.v)
            world.command(1, st.v, 0.0, st.w)
            for _ in range(10):
                for sc in world.step(1):
                    if sc.robot == 1:
                        obstacles = obstacles_in_base(sc.ranges, sc.angle_min,
                                                      sc.angle_increment, sc.range_max, lp)
            now += 0.1
        return "timeout", world.view(1).pose, turned, least_v
    finally:
        world.close()


def test_a_goal_close_behind_facing_its_way_is_reached_backing_up():
    state, pose, turned, least_v = _go(2.0, (4.5, 3.0, math.pi))   # 1.5 m behind it
    assert state == "succeeded"
    assert math.hypot(pose[0] - 4.5, pose[1] - 3.0) < 0.2
    assert turned < 0.35 and least_v < -0.1   # backed up, facing as it faced
    assert "reversing" in _go.messages


def test_the_path_follower_node_logs_backing_up_to_a_goal():
    from bullet_floor_sim.nav.navigator import NavStatus
    from bullet_floor_sim.ros.path_follower import _recovery

    class _Nav:
        retreat = None

    assert _recovery(_Nav(), NavStatus(-0.25, 0.0, "active", "reversing", 1.2)) == \
        "backing up to a goal behind it (~reverse_within, ~reverse_path)"
    assert _recovery(_Nav(), NavStatus(0.3, 0.0, "active", "following", 1.2)) == ""


def test_without_it_the_robot_turns_round_twice():
    state, pose, turned, least_v = _go(0.0, (4.5, 3.0, math.pi))
    assert state == "succeeded" and math.hypot(pose[0] - 4.5, pose[1] - 3.0) < 0.2
    assert turned > 2.5 and least_v >= 0.0


@pytest.mark.parametrize("pose, goal, goal_yaw, backs", [
    ((0, 0, 0), (-1.5, 0), 0.0, True),
    ((0, 0, 0), (-1.5, 0), math.pi, False),      # to end facing the goal: turn round
    ((0, 0, 0), (-2.5, 0), 0.0, False),          # further than reverse_within
    ((0, 0, 0), (-0.75, -1.3), 0.0, False),      # 120 degrees off: not behind enough
    ((0, 0, 0), (-1.5, 0), None, False),         # no heading to keep
    ((0, 0, 0.3), (-1.5, -0.3), 0.3, True)])
def test_which_goals_are_backed_up_to(pose, goal, goal_yaw, backs):
    f = PathFollower(FollowerConfig(reverse_within=2.0))
    f.set_path(np.linspace(pose[:2], goal, 16), goal_yaw)
    cmd = f.compute(pose)
    assert (cmd.state == "reversing") == backs
    if backs:
        assert cmd.v < 0


def test_a_bent_way_behind_is_not_backed_up():
    f = PathFollower(FollowerConfig(reverse_within=2.0))
    f.set_path(np.array([[0.0, 0.0], [-0.8, 0.0], [-0.8, 0.5], [-1.2, 0.5]]), 0.0)
    assert f.compute((0.0, 0.0, 0.0)).state == "rotating"


def test_backing_into_something_it_cannot_see_it_goes_forward_round_it():
    # robot1 stands 1 m behind robot2, on its way back: backing up stalls against it, then
    # robot2 turns and goes round by the plan
    state, pose, turned, least_v = _go(2.0, (4.7, 3.0, math.pi), other=(4.0, 3.0, 0.0))
    assert state == "succeeded" and math.hypot(pose[0] - 4.7, pose[1] - 3.0) < 0.2
    assert least_v < 0 and turned > 2.5 and _go.no_reverse


def test_a_goal_sent_again_is_not_backed_into_what_stalled_it_again():
    # the same, the goal sent again every 4 s: each new goal backed into robot1 anew (28
    # stalls in the minute); now it turns once backing up stalled there, and backs up no
    # more.
    # (Each goal is planned on the map alone, through robot1, so it does not get there in
    # the minute either way: blocked, it plans round after replan_after, then the goal comes
    # again.)
    state, pose, turned, least_v = _go(2.0, (4.7, 3.0, math.pi), other=(4.0, 3.0, 0.0),
                                       resend=4.0)
    assert least_v < 0 and turned > 2.5
    assert 1 <= _go.stalls <= 6 and "reversing" not in _go.after_stall


def test_a_robot_that_got_away_from_where_backing_up_stalled_backs_up_again():
    g = np.zeros((60, 60), dtype=np.int8)   # a 6 m room, walls round it
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = 100
    nav = Navigator(PlanningGrid(map_from_grid(g, 0.1)),
                    PathFollower(FollowerConfig(reverse_within=2.0)))
    nav.backed_into = (3.0, 3.0)
    nav.start((3.2, 3.0, math.pi), (4.2, 3.0, math.pi), 0.0)   # 0.2 m off: still held
    assert nav.follower.no_reverse
    # a node's Navigator for the next goal (path_follower makes one a goal) takes it on
    then = Navigator(nav.grid, PathFollower(FollowerConfig(reverse_within=2.0)), after=nav)
    then.start((3.2, 3.0, math.pi), (4.2, 3.0, math.pi), 0.0)
    assert then.follower.no_reverse
    fresh = Navigator(nav.grid, PathFollower(FollowerConfig(reverse_within=2.0)))
    fresh.start((3.2, 3.0, math.pi), (4.2, 3.0, math.pi), 0.0)
    assert not fresh.follower.no_reverse
    nav.start((2.7, 3.0, math.pi), (3.7, 3.0, math.pi), 1.0)   # 0.3 m off: free again
    assert not nav.follower.no_reverse and nav.backed_into is None
    assert nav.update((2.7, 3.0, math.pi), None, 1.1).message == "reversing"


def test_a_way_past_a_wall_or_round_something_is_not_backed_up():
    world = World.from_name("simple", seed=1)
    try:
        grid = PlanningGrid(world.fmap)
    finally:
        world.close()
    nav = Navigator(grid, PathFollower(FollowerConfig(reverse_within=2.0)), NavigatorConfig())
    nav.start((5.3, 1.0, 0.0), (3.6, 1.0, 0.0), 0.0)   # the pillar stands on the line
    assert nav.update((5.3, 1.0, 0.0), None, 0.0).message != "reversing"
    nav.start((3.0, 3.0, math.pi), (4.5, 3.0, math.pi), 0.0)   # clear: backed up
    assert nav.update((3.0, 3.0, math.pi), None, 0.0).message == "reversing"
    f = nav.follower   # a path round something 0.55 m off the line is not
    f.set_path(np.array([[3.0, 3.0], [3.5, 3.55], [4.0, 3.55], [4.5, 3.0]]), math.pi)
    assert f.compute((3.0, 3.0, math.pi)).state != "reversing"


def test_backing_up_counts_progress_and_stops_for_what_a_scan_shows_behind():
    f = PathFollower(FollowerConfig(reverse_within=2.0))
    f.set_path(np.linspace((0.0, 0.0), (-1.5, 0.0), 16), 0.0)
    assert f.compute((0.0, 0.0, 0.0)).v < 0 and len(f.remaining()) == 16
    assert f.compute((-0.7, 0.0, 0.0)).v < 0 and len(f.remaining()) == 9   # from -0.7 m on
    behind = np.array([[-0.55, 0.05]])   # 0.21 m behind the footprint's back (stop_distance 0.3)
    assert f.compute((-0.7, 0.0, 0.0), behind).state == "blocked"
    assert f.compute((-0.7, 0.0, 0.0), np.array([[-0.55, 1.0], [-0.8, 0.0]])).state == "reversing"


def test_a_goal_round_a_pillar_facing_back_the_way_there_is_reached_backing_along_the_path():
    # from (3, 3) facing -x to (5.2, 0.6) facing +y: 3.8 m, east of the pillar, arriving
    # southwards; reverse_within (2 m, a straight way) does not reach it, reverse_path does
    goal = (5.2, 0.6, math.pi / 2)
    state, pose, turned, least_v = _go(2.0, goal, reverse_path=5.0)
    assert state == "succeeded" and math.hypot(pose[0] - 5.2, pose[1] - 0.6) < 0.2
    assert "reversing" in _go.messages and least_v < -0.1
    assert turned < 2.0    # from facing -x to facing +y: never facing the way it went
    state, pose, turned, least_v = _go(2.0, goal, reverse_path=3.0)   # too far along
    assert state == "succeeded" and turned > 2.5 and least_v >= 0.0


def _bent(goal_yaw):
    """A path 2.6 m long that goes 1.5 m along -x, then 1.1 m along +y, to ``goal_yaw``."""
    f = PathFollower(FollowerConfig(reverse_path=3.0))
    f.set_path(np.vstack([np.linspace((0.0, 0.0), (-1.5, 0.0), 16)[:-1],
                          np.linspace((-1.5, 0.0), (-1.5, 1.1), 12)]), goal_yaw)
    return f


@pytest.mark.parametrize("goal_yaw, backs", [
    (-math.pi / 2, True),            # facing back along the last metre (arriving along +y)
    (-math.pi / 2 + 0.8, True),      # within rotate_in_place (0.9 rad) of it
    (-math.pi / 2 + 1.0, False),
    (math.pi / 2, False),            # facing the way it arrives: forward
    (None, False)])
def test_which_paths_are_backed_along(goal_yaw, backs):
    cmd = _bent(goal_yaw).compute((0.0, 0.0, 0.0))   # its back to the path's start
    assert (cmd.state == "reversing") == backs
    if backs:   # the look-ahead point 0.6 m behind it, on the line: straight back, at
        assert cmd.v == -0.25 and abs(cmd.w) < 1e-9   # reverse_speed (max_linear 0.6)
    f = _bent(goal_yaw)
    f.config.reverse_path = 2.5   # shorter than the path
    assert f.compute((0.0, 0.0, 0.0)).state != "reversing"


def test_the_way_a_path_arrives_is_its_last_metre():
    # 1.5 m along -x, then 0.9 m along +y and a last 0.1 m step along -x: the last metre
    # arrives at about 96 degrees (+y, a little -x), the last step at 180
    path = np.vstack([np.linspace((0.0, 0.0), (-1.5, 0.0), 16)[:-1],
                      np.linspace((-1.5, 0.0), (-1.5, 0.9), 10), [[-1.6, 0.9]]])
    for goal_yaw, backs in ((-math.pi / 2, True), (0.0, False)):
        f = PathFollower(FollowerConfig(reverse_path=3.0))
        f.set_path(path, goal_yaw)
        assert (f.compute((0.0, 0.0, 0.0)).state == "reversing") == backs


def test_backing_along_a_path_turns_its_back_to_it_and_stops_for_a_point_behind():
    f = _bent(-math.pi / 2)
    cmd = f.compute((0.0, 0.0, -math.pi / 2))   # its back to +y, the path goes -x
    assert cmd.state == "rotating" and cmd.v == 0.0 and cmd.w > 0   # left: its back to -x
    f = _bent(-math.pi / 2)
    assert f.compute((0.0, 0.0, 0.0)).state == "reversing"   # decided with nothing seen
    behind = np.array([[-0.6, 0.0]])    # 0.26 m behind the footprint (stop_distance 0.3)
    assert f.compute((0.0, 0.0, 0.0), behind).state == "blocked"
    f = _bent(-math.pi / 2)   # ahead of it, not in its way backing up
    assert f.compute((0.0, 0.0, 0.0), np.array([[0.6, 0.0]])).state == "reversing"


@pytest.mark.parametrize("seen, known, backs", [
    ([[0.6, 0.0]], None, True),                 # ahead: the path leads away from it
    ([[-1.0, -1.1]], None, True),               # 1.1 m off the path: far enough
    ([[-1.0, -0.6]], None, False),              # 0.6 m off the path, 1.17 m off now
    ([[-1.0, -0.6]], [True], True),             # the same on the map's walls
    ([[0.6, 0.0], [-2.2, 0.5]], [False, False], False)])   # one past the path's bend
def test_a_path_is_not_backed_along_past_what_the_scan_shows_and_the_map_lacks(seen, known, backs):
    cmd = _bent(-math.pi / 2).compute((0.0, 0.0, 0.0), np.array(seen, dtype=float),
                                      None if known is None else np.array(known))
    assert (cmd.state == "reversing") == backs
