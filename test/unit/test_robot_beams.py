"""sim/robot_beams.py: the beams that may meet another robot before their reach are all listed
(checked pair by pair against the line-circle geometry), with the circle's entry and exit,
and the compiled loops give what the same loops give in plain Python."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim import robot_beams, sections
from bullet_floor_sim.sim.config import (LaserConfig, OdometryConfig, RobotSpec,
                                         load_world_config, resolve_world)
from bullet_floor_sim.sim.world import World

EXACT = LaserConfig(fov=360.0, resolution=1.0, noise_std=0.0)
FAN = LaserConfig(fov=180.0, resolution=0.5, noise_std=0.0)      # a second beam geometry
STILL = OdometryConfig(noise_trans=0.0, noise_rot=0.0, noise_rot_per_m=0.0)
POSES = [(1.0, 1.0), (1.0, 3.0), (2.5, 2.0), (3.5, 3.2), (5.2, 1.0), (5.2, 3.0), (3.3, 2.4)]


@pytest.fixture
def world():
    cfg = load_world_config(resolve_world("simple", worlds_dir()))
    robots = [RobotSpec(name="r%d" % i, pose=(x, y, 0.0), laser=EXACT if i % 2 else FAN,
                        odometry=STILL) for i, (x, y) in enumerate(POSES)]
    w = World(dataclasses.replace(cfg, robots=robots), seed=3)
    yield w
    w.close()


def _scans(w, rng):
    """A plan of every robot's scan at random headings, and random reaches along its rays."""
    w.pose[:, 2] = rng.uniform(-math.pi, math.pi, w.n)
    plan = w.lidar.plan(np.arange(w.n), w.pose, w.bounds, predict=False)
    return plan, rng.uniform(0.3, 6.0, len(plan.full))


def _meets(plan, reach, q, k, centre, r):
    """Ray k of scan q (from its laser, along its direction) passes within the circle, which
    begins nearer than the ray's reach and not wholly behind the laser."""
    o, d = plan.origins[k, :2], plan.dirs[k]
    rel = np.asarray(centre) - o
    along = float(rel @ d)
    dist = math.hypot(*rel)
    across2 = dist * dist - along * along
    return across2 < r * r * (1.0 - 1e-9) and along + r > 0.0 and dist - r < reach[k]


def test_every_beam_that_can_meet_another_robot_is_listed(world):
    w, rng = world, np.random.default_rng(11)
    found = 0
    for _ in range(20):
        plan, reach = _scans(w, rng)
        g, j, t_in, t_out = robot_beams.candidates(w, plan, reach)
        listed = set(zip(g.tolist(), j.tolist()))
        assert len(listed) == len(g)                        # a pair at most once
        owner = robot_beams.ray_owner(plan, np.arange(len(plan.full)))
        for k in range(len(plan.full)):
            q = int(owner[k])
            for other in range(w.n):
                if other == plan.robots[q]:
                    continue
                r = float(w._ray_radius[plan.robots[q], other])
                if _meets(plan, reach, q, k, w.pose[other, :2], r):
                    found += 1
                    assert (k, other) in listed, (k, other)
        # each listed pair: the circle's entry and exit, and never the scan's own robot
        centre = w.pose[j, :2]
        dist = np.hypot(*(centre - plan.origins[g, :2]).T)
        r = w._ray_radius[plan.robots[owner[g]], j]
        np.testing.assert_allclose(t_in, dist - r, rtol=0, atol=1e-12)
        np.testing.assert_allclose(t_out, dist + r, rtol=0, atol=1e-12)
        assert (plan.robots[owner[g]] != j).all()
        assert (reach[g] > t_in).all()
    assert found > 500


def test_the_compiled_loops_give_what_plain_python_gives(world):
    if not hasattr(robot_beams._circle_pairs, "py_func"):
        pytest.skip("numba not installed")
    w, rng = world, np.random.default_rng(12)
    for _ in range(5):
        plan, reach = _scans(w, rng)
        own = plan.robots[:, None] == np.arange(w.n)[None, :]
        args = (plan.origins, plan.first, np.ascontiguousarray(w.pose[:, :2]),
                np.ascontiguousarray(w._ray_radius[plan.robots]), own, reach,
                w._beam_geometry[plan.robots], w.pose[plan.robots, 2] + w.lidar.yaw[plan.robots])
        compiled = robot_beams._circle_pairs(*args)
        plain = robot_beams._circle_pairs.py_func(*args)
        assert len(compiled[0]) > 50
        for a, b in zip(compiled, plain):
            np.testing.assert_array_equal(a, b)
        g, j = compiled[0], compiled[1]
        sec = w.section_index[plan.robots[robot_beams.ray_owner(plan, g)], j]
        ok = sec >= 0
        assert ok.any()
        out = []
        for clip in (sections.clip_to_sections, sections.clip_to_sections.py_func):
            dist, hit = reach.copy(), np.zeros(len(reach), dtype=bool)
            tyaw = w.pose[:, 2]
            clip(g[ok], j[ok], sec[ok], w.pose, np.cos(tyaw), np.sin(tyaw), plan.origins,
                 plan.dirs, plan.start, reach, w._section_normals, w._section_offsets, dist, hit)
            out.append((dist, hit))
        assert out[0][1].sum() > 10                          # beams do meet robots
        np.testing.assert_array_equal(out[0][0], out[1][0])
        np.testing.assert_array_equal(out[0][1], out[1][1])
