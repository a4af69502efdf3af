"""The crowd (people/crowd): social forces against hand-computed values, legs in a scan at
their exact range, two people passing in a corridor, no one through a wall, the people:
section of world.yaml."""
from __future__ import annotations

import dataclasses
import math
import os
import sys

import numpy as np
import pytest

from bullet_floor_sim.errors import ConfigError
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.people.crowd.build import build_crowd, routes_for
from bullet_floor_sim.people.crowd.config import BodyConfig, parse_people
from bullet_floor_sim.people.crowd.crowd import MIN_CLEARANCE, Crowd, Person
from bullet_floor_sim.people.crowd.forces import (ForceConfig, driving, limit_speed, repulsion,
                                                   wall_repulsion)
from bullet_floor_sim.sim.config import (LaserConfig, OdometryConfig, RobotSpec,
                                         load_world_config, resolve_world)
from bullet_floor_sim.sim.leg_beams import ray_circle
from bullet_floor_sim.sim.world import World

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from simple_room import expected_range  # noqa: E402

EXACT = LaserConfig(fov=360.0, resolution=1.0, noise_std=0.0)
STILL = OdometryConfig(noise_trans=0.0, noise_rot=0.0, noise_rot_per_m=0.0)
STILL_FORCES = ForceConfig(strength=0.0, wall_strength=0.0, contact=0.0)
CFG = ForceConfig(strength=2.0, range=0.4, anisotropy=0.3, pass_angle=0.35, contact=60.0,
                  wall_strength=3.0, wall_range=0.15, horizon=1.5)


def world(name, robots, **kw):
    cfg = load_world_config(resolve_world(name, worlds_dir()))
    return World(dataclasses.replace(cfg, robots=robots), seed=3, **kw)


def crowd(w, starts, heading=0.0, body=BodyConfig(), forces=CFG):
    """People without walkers (they walk only where walk_to sends them)."""
    people = [Person("p%d" % i, None, 1.2) for i in range(len(starts))]
    c = Crowd(people, np.array(starts, dtype=float), routes_for(w, body), body, forces, 20.0,
              w.clock.now_ns)
    c.heading[:] = heading
    w.add_people(c)
    return c


# ------------------------------------------------------------------------------- forces
def one(i_pos, i_heading, j_pos, cfg=CFG):
    pos = np.array([i_pos, j_pos], dtype=float)
    heading = np.array([i_heading, (0.0, 0.0)], dtype=float)
    radius = np.array([0.25, 0.25])
    return repulsion(pos, heading, radius, pos, radius, np.array([0]), np.array([1]), cfg)[0]


def test_repulsion_of_someone_ahead_is_turned_to_the_right():
    # d = 1, r = 0.5: 2 exp(-0.5 / 0.4) = 0.573010; straight ahead: weight 1, turned by
    # 0.35 rad counter-clockwise from (-1, 0): (-cos 0.35, -sin 0.35) = (-0.939373, -0.342898)
    np.testing.assert_allclose(one((0, 0), (1, 0), (1, 0)), (-0.538270, -0.196484), atol=1e-6)


def test_repulsion_from_behind_and_beside_is_weaker():
    # behind: weight lambda = 0.3, not turned: 0.3 x 0.573010
    np.testing.assert_allclose(one((0, 0), (1, 0), (-1, 0)), (0.171903, 0.0), atol=1e-6)
    # beside (to the left): weight 0.3 + 0.7 x 0.5 = 0.65, pushed to the right
    np.testing.assert_allclose(one((0, 0), (1, 0), (0, 1)), (0.0, -0.372456), atol=1e-6)
    # someone standing (no heading) weighs everyone 0.65, whatever the side
    np.testing.assert_allclose(one((0, 0), (0, 0), (1, 0)), (-0.372456, 0.0), atol=1e-6)


def test_repulsion_acts_where_they_will_be_closest():
    # i at the origin walking +x at 1 m/s, j at (2, 0.3) walking -x: relative velocity
    # (2, 0), closest after 1 s (within the 1.5 s horizon) at (0, -0.3): 2 exp(0.2 / 0.4)
    # = 3.297443 along (0, -1); the weight and the turn to the right come from the present
    # bearing: n = (-2, -0.3) / 2.022375, cos phi = 0.988936: weight 0.996128, turned by
    # 0.346128 rad: (sin, -cos) of it x 3.284678
    pos = np.array([(0.0, 0.0), (2.0, 0.3)])
    vel = np.array([(1.0, 0.0), (-1.0, 0.0)])
    heading = np.array([(1.0, 0.0), (-1.0, 0.0)])
    r = np.array([0.25, 0.25])
    f = repulsion(pos, heading, r, pos, r, np.array([0]), np.array([1]), CFG, vel, vel)[0]
    np.testing.assert_allclose(f, (1.114351, -3.089871), atol=1e-6)
    # beyond the horizon the prediction stops at 1.5 s: j at (6, 0.3) is at (3, 0.3) then
    pos[1] = (6.0, 0.3)
    f = repulsion(pos, heading, r, pos, r, np.array([0]), np.array([1]), CFG, vel, vel)[0]
    d = math.hypot(3.0, 0.3)
    assert np.hypot(*f) == pytest.approx(2 * math.exp((0.5 - d) / 0.4)
                                         * (0.3 + 0.35 * (1 + 6 / math.hypot(6, 0.3))), rel=1e-9)


def test_bodies_that_overlap_push_apart():
    # d = 0.4 (0.1 m overlap), someone behind: 0.3 x 2 exp(0.1 / 0.4) + 60 x 0.1
    np.testing.assert_allclose(one((0, 0), (1, 0), (-0.4, 0)), (0.3 * 2.568051 + 6.0, 0.0),
                               atol=1e-6)


def test_wall_driving_and_speed_limit():
    f = wall_repulsion(np.array([0.35, 0.2]), np.array([[0.0, 1.0], [1.0, 0.0]]),
                       np.array([0.25, 0.25]), CFG)
    # 3 exp(-0.1 / 0.15) = 1.540251; at 0.2: 3 exp(0.05 / 0.15) + 60 x 0.05 = 4.186837 + 3
    np.testing.assert_allclose(f, [[0.0, 1.540251], [7.186837, 0.0]], atol=1e-6)
    np.testing.assert_allclose(driving(np.array([[0.5, 0.0]]), np.array([[1.2, 0.0]]), 0.5),
                               [[1.4, 0.0]])
    v, speed = limit_speed(np.array([[3.0, 4.0], [0.3, 0.4]]), np.array([1.3, 1.3]))
    np.testing.assert_allclose(v, [[0.78, 1.04], [0.3, 0.4]])
    np.testing.assert_allclose(speed, [1.3, 0.5])


def test_ray_circle():
    o = np.zeros((4, 2))
    d = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]])
    c = np.array([[2.0, 0.0], [2.0, 0.06], [2.0, 0.0], [0.0, 0.0]])
    t = ray_circle(o, d, c, 0.06, np.array([0.0, 0.0, 0.0, 0.1]))
    assert t[0] == pytest.approx(1.94)
    assert t[1] == pytest.approx(2.0)          # grazes the circle's edge
    assert t[2] == math.inf                     # points away
    assert t[3] == math.inf                     # the circle lies before the ray starts


# ------------------------------------------------------------------------------- legs in a scan
def test_legs_in_a_scan_at_their_exact_range():
    w = world("simple", [RobotSpec(name="r", pose=(1.5, 2.0, 0.0), laser=EXACT, odometry=STILL)])
    try:
        # facing +y: legs at x 2.9 and 3.1; no forces, so that standing means standing still
        c = crowd(w, [(3.0, 2.0)], heading=math.pi / 2, forces=STILL_FORCES)
        np.testing.assert_allclose(c.legs(), [[2.9, 2.0], [3.1, 2.0]], atol=1e-12)
        scan = w.step(10)[0]
        angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
        # beam 180 points along +x from the laser at (1.8, 2.0): the near leg's edge
        assert scan.ranges[180] == pytest.approx(2.9 - 0.06 - 1.8, abs=1e-6)
        want = []
        for a in angles:
            d = (math.cos(a), math.sin(a))
            t = min(expected_range(1.8, 2.0, a), *(_circle(1.8, 2.0, d, leg) for leg in c.legs()))
            want.append(t)
        np.testing.assert_allclose(scan.ranges, want, atol=2e-6)
        seen = np.flatnonzero(np.abs(scan.ranges - [expected_range(1.8, 2.0, a) for a in angles])
                              > 1e-3)
        assert list(seen) == [177, 178, 179, 180, 181, 182, 183]   # atan(0.06 / 1.1) = 3.1 deg
    finally:
        w.close()


def _circle(ox, oy, d, centre, r=0.06):
    """Hand-written ray-circle meeting: solve |o + t d - c| = r for the smaller t."""
    fx, fy = ox - centre[0], oy - centre[1]
    b = fx * d[0] + fy * d[1]
    disc = b * b - (fx * fx + fy * fy - r * r)
    return -b - math.sqrt(disc) if disc >= 0 and -b - math.sqrt(disc) > 0 else math.inf


def test_a_laser_above_the_legs_sees_none():
    w = world("simple", [RobotSpec(name="r", pose=(1.5, 2.0, 0.0), laser=EXACT, odometry=STILL)])
    try:
        crowd(w, [(3.0, 2.0)], body=BodyConfig(leg_height=0.4))   # the laser is at 0.437 m
        scan = w.step(10)[0]
        assert scan.ranges[180] == pytest.approx(5.9 - 1.8, abs=1e-6)
    finally:
        w.close()


# ------------------------------------------------------------------------------- walking
def corridor_world(tmp_path, width=1.5):
    """A straight corridor ``width`` m wide (y 0.2 to 0.2 + width) and 13.6 m long (x 0.2 to
    13.8)."""
    from PIL import Image

    n = int(round(width / 0.05))
    img = np.zeros((n + 8, 280), dtype=np.uint8)
    img[4:4 + n, 4:276] = 254
    Image.fromarray(img).save(str(tmp_path / "corridor.pgm"))
    (tmp_path / "map.yaml").write_text("image: corridor.pgm\nresolution: 0.05\n"
                                       "origin: [0.0, 0.0, 0.0]\nnegate: 0\n"
                                       "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    (tmp_path / "world.yaml").write_text("map: map.yaml\nrobots: []\n")
    return World.from_name(str(tmp_path / "world.yaml"), seed=3)


@pytest.mark.parametrize("speeds,width", [((1.2, 1.2), 1.5), ((1.5, 0.8), 1.5),
                                          ((1.2, 1.2), 1.2), ((1.5, 0.8), 1.2)])
def test_two_people_pass_in_a_corridor_without_touching(tmp_path, speeds, width):
    """They meet head on in the middle of a corridor 1.5 or 1.2 m wide."""
    w = corridor_world(tmp_path, width)
    mid = 0.2 + width / 2.0
    try:
        c = crowd(w, [(1.0, mid), (13.0, mid)])
        c.v0[:] = speeds
        c.walk_to(0, (13.0, mid), None, w.clock.now)
        c.walk_to(1, (1.0, mid), None, w.clock.now)
        closest, sides = math.inf, []
        for _ in range(400):                 # 20 s
            w.step(5)
            gap = float(np.hypot(*(c.pos[0] - c.pos[1])))
            if gap < closest:
                closest, sides = gap, (c.pos[0, 1], c.pos[1, 1])
        # shoulders never touch at 1.5 m; at 1.2 m they brush (0.483 m apart at the
        # closest, the walls' push against the other's), and neither waits for the other
        assert closest >= (2 * 0.25 if width >= 1.5 else 0.45)
        if width >= 1.5:   # at 1.2 m the faster one may pass on its left: no room to choose
            assert sides[0] < mid < sides[1]     # each kept to its right
        assert [p.state for p in c.people] == ["idle", "idle"]   # both arrived
        np.testing.assert_allclose(c.pos, [[13.0, mid], [1.0, mid]], atol=0.25)
    finally:
        w.close()


def test_a_person_never_walks_through_a_wall():
    """Sent straight at the office corridor's south wall (its face at y 9.0; no door near
    x 9) and through it, a person stops: its centre stays MIN_CLEARANCE off the wall."""
    w = world("office", [])
    try:
        c = crowd(w, [(9.0, 10.0)])
        p = c.people[0]
        p.path = np.array([[9.0, 10.0], [9.0, 7.0]])   # through the wall into office 3
        p.goal, p.state = (9.0, 7.0), "walk"
        lowest = math.inf
        for _ in range(200):
            w.step(5)
            lowest = min(lowest, float(c.pos[0, 1]))
            assert c.clearance(c.pos)[0] >= MIN_CLEARANCE
        # the wall is the map's cells y 8.85 to 9.0; clearance is measured to the wall cells'
        # centres less half a cell, so it may read up to 0.025 m short
        assert 9.0 + MIN_CLEARANCE - 0.001 <= lowest < 9.0 + MIN_CLEARANCE + 0.05
        assert abs(c.pos[0, 0] - 9.0) < 0.05          # pressed against it, not sliding off
    finally:
        w.close()


def test_a_crowd_on_a_real_map_keeps_off_the_walls():
    w = World.from_name("malaga_corridor", seed=2)
    try:
        cfg = dataclasses.replace(w.config.people, seed=4).with_count(15)
        c = build_crowd(w, cfg)
        assert c is not None and c.n == 15
        w.add_people(c)
        for _ in range(600):        # 60 s
            w.step(10)
            assert c.clearance(c.pos).min() >= MIN_CLEARANCE
        lines = c.take_log()
        assert sum(" in " in s and "succeeded" not in s and "s" == s.split()[-1][-1]
                   for s in lines) >= 10       # legs were walked to the end
    finally:
        w.close()


# ------------------------------------------------------------------------------- config
def test_people_section(tmp_path):
    cfg = parse_people({"count": 3, "speed": [1.0, 1.2], "seed": 7}, "w.yaml", str(tmp_path))
    assert cfg.count == 3 and cfg.groups[0].speed == (1.0, 1.2) and cfg.seed == 7
    cfg = parse_people({"dwell": [1, 2], "groups": [{"count": 2}, {"count": 1, "name": "guest",
                                                                    "rois": "r.yaml"}]},
                       "w.yaml", str(tmp_path))
    assert [(g.count, g.name, g.dwell) for g in cfg.groups] == [(2, "person", (1.0, 2.0)),
                                                               (1, "guest", (1.0, 2.0))]
    assert cfg.groups[1].rois == str(tmp_path / "r.yaml")
    assert cfg.with_count(5).groups == (dataclasses.replace(cfg.groups[0], count=5),)
    assert parse_people(None, "w.yaml", ".").count == 0


@pytest.mark.parametrize("doc, says", [
    ({"count": -1}, "count must be an integer >= 0"),
    ({"speed": [1.5, 0.8]}, "speed must be [min, max]"),
    ({"count": 2, "groups": []}, "either count or groups"),
    ({"cuont": 2}, "unknown key(s) 'cuont'"),
    ({"rate": 0}, "rate must be a number of Hz > 0"),
    ({"body": {"radius": 0.1}}, "the legs"),
    ({"forces": {"tau": "x"}}, "tau must be a finite number"),
    ({"groups": [{"name": "a b"}]}, "name must be a word"),
    ({"groups": [{"count": 2, "together": "yes"}]}, "together must be true or false"),
])
def test_people_section_errors_name_the_key(doc, says):
    with pytest.raises(ConfigError) as e:
        parse_people(doc, "w.yaml", ".")
    assert says in str(e.value) and "w.yaml: people" in str(e.value)


# ------------------------------------------------------------------------------- tracking
@pytest.mark.parametrize("a0, a1, b0, b1", [
    ((2.6, 0.6), (3.8, 3.4), (3.8, 0.6), (2.6, 3.4)),    # their paths cross 1.4 m ahead
    ((1.6, 2.5), (5.5, 2.5), (5.5, 2.9), (1.6, 2.9)),    # they meet head on, 0.4 m aside
])
def test_the_tracker_keeps_one_track_per_person_through_a_crossing(a0, a1, b0, b1):
    """A robot at the west end of worlds/simple watches two people cross in front of it:
    its tracker (the leg centre_offset of the people evaluation) keeps each person's track,
    scored with CLEAR MOT against the ground truth."""
    from bullet_floor_sim.people.agents import TrackerAgent
    from bullet_floor_sim.people.evaluation.crowd_run import LEG_CENTRE_OFFSET
    from bullet_floor_sim.people.evaluation.mot import ClearMot
    from bullet_floor_sim.people.tracking import TrackerConfig
    from bullet_floor_sim.sim.sensors import Scan

    w = world("simple", [RobotSpec(name="r", pose=(0.6, 2.0, 0.0))])
    try:
        c = crowd(w, [a0, b0], forces=ForceConfig())
        c.walk_to(0, a1, None, w.clock.now)
        c.walk_to(1, b1, None, w.clock.now)
        tracker = TrackerAgent.for_map(w.fmap, TrackerConfig(centre_offset=LEG_CENTRE_OFFSET))
        mot, closest = ClearMot(0.5), math.inf
        for _ in range(80):                                  # 8 s
            scan = [s for s in w.step(10) if isinstance(s, Scan)][-1]
            tracks = tracker.tick(w.clock.now, scan, (0.9, 2.0, 0.0)).tracks  # laser 0.3 ahead
            mot.update({"a": tuple(c.pos[0]), "b": tuple(c.pos[1])},
                       {t.id: (t.x, t.y) for t in tracks})
            closest = min(closest, float(np.hypot(*(c.pos[0] - c.pos[1]))))
        assert closest < 0.9                                 # they did come close
        assert mot.switches == 0 and mot.false_positives <= 4
        for name in ("a", "b"):
            assert mot.per_person[name]["matched"] >= 0.75 * 80, mot.per_person
    finally:
        w.close()



# ------------------------------------------------------------------------------- parties
def test_coherence_pulls_the_far_members_to_the_centre():
    from bullet_floor_sim.people.crowd.groups import coherence

    # three members: centre (4/3, 0.1); threshold (3 - 1) / 2 = 1 m. Member 0 is 1.337 m
    # away, member 1 1.670 m: pulled towards it at 1 m/s^2; member 2 (at (1, 0.3)) 0.389 m:
    # left alone, as is the one outside the party
    pos = np.array([(0.0, 0.0), (3.0, 0.0), (1.0, 0.3), (9.0, 9.0)])
    f = coherence(pos, [np.array([0, 1, 2])], strength=1.0)
    np.testing.assert_allclose(f, [(0.997199, 0.074790), (-0.998205, 0.059892), (0.0, 0.0),
                                   (0.0, 0.0)],
                               atol=1e-6)


def test_a_party_walks_together():
    """Three people walking together (the first leads by the chain, the others follow) and
    four on their own, office, 120 s: the party's members stay within 3 m of their leader
    and go where it goes."""
    w = World.from_name("office", seed=1)
    try:
        cfg = parse_people({"seed": 2, "groups": [{"count": 3, "name": "party",
                                                     "together": True}, {"count": 4}]},
                           "w.yaml", ".")
        c = build_crowd(w, cfg)
        assert c is not None
        w.add_people(c)
        assert [(p.leader, p.rank, p.agent is None) for p in c.people[:3]] == [
            (None, 0, False), (0, 1, True), (0, 2, True)]
        assert c.people[1].speed == c.people[2].speed == c.people[0].speed
        start = c.pos[:3].copy()
        far = 0.0
        for _ in range(1200):
            w.step(10)
            far = max(far, float(np.hypot(*(c.pos[1:3] - c.pos[0]).T).max()))
        legs = [s for s in c.take_log() if s.startswith("party_1: leg ") and s.endswith(" s")]
        assert len(legs) >= 3                  # the leader walked its legs
        assert far < 3.0
        assert (np.hypot(*(c.pos[:3] - start).T) > 2.0).all()   # and they all went along
    finally:
        w.close()
