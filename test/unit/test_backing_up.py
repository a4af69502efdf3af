"""A robot backs up to a goal close behind it that faces its own way (FollowerConfig
.reverse_within): the observer gives way facing the target instead of turning its back on it.
On the core world's physics and by hand."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bullet_floor_sim.geometry import wrap_angle
from bullet_floor_sim.nav.planner import (FollowerConfig, Navigator, NavigatorConfig,
                                          PathFollower, PlanningGrid)
from bullet_floor_sim.sim.world import World


def _go(reverse_within: float, goal):
    """robot2 of the simple room ((3, 3), facing -x) driven to ``goal`` on the physics: the
    end pose, the largest turn off its first heading on the way, the least forward speed."""
    world = World.from_name("simple", seed=1)
    try:
        nav = Navigator(PlanningGrid(world.fmap),
                        PathFollower(FollowerConfig(reverse_within=reverse_within)),
                        NavigatorConfig(give_way=True))
        yaw0 = world.view(1).pose[2]
        now, turned, least_v = 0.0, 0.0, math.inf
        nav.start(world.view(1).pose, goal, now)
        while now < 60.0:
            pose = world.view(1).pose
            turned = max(turned, abs(wrap_angle(pose[2] - yaw0)))
            st = nav.update(pose, None, now)
            if st.state != "active":
                return st.state, world.view(1).pose, turned, least_v
            least_v = min(least_v, st.v)
            world.command(1, st.v, 0.0, st.w)
            for _ in range(10):
                world.step()
            now += 0.1
        return "timeout", world.view(1).pose, turned, least_v
    finally:
        world.close()


def test_a_goal_close_behind_facing_its_way_is_reached_backing_up():
    state, pose, turned, least_v = _go(2.0, (4.5, 3.0, math.pi))   # 1.5 m behind it
    assert state == "succeeded"
    assert math.hypot(pose[0] - 4.5, pose[1] - 3.0) < 0.2
    assert turned < 0.35 and least_v < -0.1   # backed up, facing as it faced


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
