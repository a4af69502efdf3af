"""Detection and tracking of moving entities in lidar scans (no ROS): scan geometry, the static
map, clustering and detection on hand-made numbers, the Kalman tracker on synthetic detection
streams, and the whole pipeline on the real PyBullet ``simple`` world."""
from __future__ import annotations

import dataclasses
import math
import os
import sys

import numpy as np
import pytest

from bullet_floor_sim.sim.config import load_world_config, resolve_world
from bullet_floor_sim.sim.floormap import map_from_grid
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim.solidmap import MapHandling
from bullet_floor_sim.people.tracking import (Detection, PoseHistory, StaticMap, Tracker, TrackerConfig,
                                            TrackingError, cluster, detect, detect_scan,
                                            scan_detections, scan_points, view_edge)
from bullet_floor_sim.sim.world import World

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from simple_room import BOXES, expected_range  # noqa: E402

RES = 0.05


# --------------------------------------------------------------------------------------------
# scan geometry, static map, clustering, detection
# --------------------------------------------------------------------------------------------


def test_scan_points_drop_non_finite_returns_and_rotate_into_the_map_frame():
    ranges = np.array([2.0, np.inf, np.nan, 1.0, -np.inf], dtype=np.float32)
    pts, beams = scan_points(ranges, 0.0, math.pi / 6, (1.0, 2.0, math.pi / 3),
                             return_beams=True)
    assert beams.tolist() == [0, 3]
    # beam 0 looks along 60 degrees in the map, beam 3 along 60 + 90 = 150 degrees
    np.testing.assert_allclose(pts, [[2.0, 2.0 + math.sqrt(3.0)],
                                     [1.0 - math.sqrt(3.0) / 2.0, 2.5]], atol=1e-6)
    np.testing.assert_array_equal(scan_points(ranges, 0.0, math.pi / 6,
                                              (1.0, 2.0, math.pi / 3)), pts)
    pts, beams = scan_points([np.inf, np.nan], -1.0, 0.1, (0.0, 0.0, 0.0), return_beams=True)
    assert pts.shape == (0, 2) and beams.shape == (0,)


def test_scan_points_reject_bad_input_naming_it():
    with pytest.raises(TrackingError, match=r"scan_points: ranges must be 1-D, got shape \(2, 2\)"):
        scan_points(np.ones((2, 2)), 0.0, 0.1, (0.0, 0.0, 0.0))
    with pytest.raises(TrackingError, match=r"scan_points: laser_pose must be 3 finite numbers"):
        scan_points([1.0], 0.0, 0.1, (0.0, float("nan"), 0.0))


def synthetic_map():
    """2 m x 2 m at 0.1 m, origin (10, -5): an occupied column over x in [10.5, 10.6) and one
    unknown cell over x in [11.5, 11.6), y in [-3.5, -3.4)."""
    g = np.zeros((20, 20), dtype=np.int8)
    g[:, 5] = 100
    g[15, 15] = -1
    return map_from_grid(g, 0.1, (10.0, -5.0, 0.0))


def test_static_map_explains_points_near_occupied_and_unknown_cells_and_outside():
    static = StaticMap(synthetic_map(), tolerance=0.2, handling=MapHandling(unknown_slivers=0.0))
    pts = np.array([
        (10.74, -4.0),   # cell 7: 0.2 m from the wall column's cell 5 -> explained
        (10.86, -4.0),   # cell 8: 0.3 m -> not
        (10.30, -4.0),   # cell 3, the other side: 0.2 m -> explained
        (11.55, -3.68),  # row 13: 0.2 m below the unknown cell (row 15) -> explained
        (11.55, -3.75),  # row 12: 0.3 m -> not
        (9.0, -4.0),     # outside the map -> explained (ignored)
        (10.5, 0.0),     # outside the map
    ])
    np.testing.assert_allclose(static.distance(pts), [0.2, 0.3, 0.2, 0.2, 0.3, 0.0, 0.0],
                               atol=1e-9)
    assert static.explained(pts).tolist() == [True, False, True, True, False, True, True]
    # by default a lone unknown cell amid free cells is an unseen sliver of floor, not a wall:
    # the two points near it are 1.0 m from the wall column (cell 5 vs cell 15)
    default = StaticMap(synthetic_map(), tolerance=0.2)
    np.testing.assert_allclose(default.distance(pts[3:5]), [1.0, 1.0], atol=1e-9)
    assert StaticMap(synthetic_map(), tolerance=0.25).explained(pts[[1]]).tolist() == [False]
    with pytest.raises(TrackingError, match=r"static map: tolerance must be a finite number "
                                            r">= 0, got -0.1"):
        StaticMap(synthetic_map(), tolerance=-0.1)


def test_cluster_splits_separated_blobs_and_keeps_a_contiguous_one():
    a = np.column_stack((np.full(5, 2.0), np.arange(5) * 0.05))          # y 0 .. 0.2
    b = np.column_stack((np.full(5, 2.0), 1.0 + np.arange(5) * 0.05))    # y 1.0 .. 1.2
    groups = cluster(np.vstack((a, b)), 0.3)
    assert [g.tolist() for g in groups] == [[0, 1, 2, 3, 4], [5, 6, 7, 8, 9]]
    line = np.column_stack((np.arange(10) * 0.1, np.zeros(10)))          # 0.1 m apart
    assert [g.tolist() for g in cluster(line, 0.3)] == [list(range(10))]
    assert [g.tolist() for g in cluster(line, 0.09)] == [[i] for i in range(10)]
    assert cluster(np.zeros((0, 2)), 0.3) == []


def test_cluster_wraps_around_a_full_circle_scan():
    ring = np.array([(0.0, 1.0), (0.1, 1.0), (5.0, 5.0), (5.1, 5.0), (-0.1, 1.0)])
    assert [g.tolist() for g in cluster(ring, 0.3)] == [[0, 1], [2, 3], [4]]
    assert [g.tolist() for g in cluster(ring, 0.3, wrap=True)] == [[4, 0, 1], [2, 3]]


def simple_room_map():
    """worlds/simple rasterised from its hand-written boxes (independent of map.pgm)."""
    g = np.zeros((80, 120), dtype=np.int8)
    for x0, y0, x1, y1 in BOXES:
        g[int(round(y0 / RES)):int(round(y1 / RES)), int(round(x0 / RES)):int(round(x1 / RES))] \
            = 100
    return map_from_grid(g, RES)


def ray_circle(ox, oy, a, cx, cy, r):
    """Distance along ``a`` from (ox, oy) to a circle, inf when missed."""
    dx, dy = math.cos(a), math.sin(a)
    fx, fy = ox - cx, oy - cy
    b = fx * dx + fy * dy
    disc = b * b - (fx * fx + fy * fy - r * r)
    if disc < 0.0:
        return math.inf
    t = -b - math.sqrt(disc)
    return t if t > 0.0 else math.inf


def synthetic_scan(laser, circles, segments=(), n=181, inc=math.radians(1.0)):
    """Exact ranges of a 180-degree fan in the simple room with extra circles (cx, cy, r) and
    thin wall segments ((x0, y0), (x1, y1)) that the map does not know."""
    ox, oy, yaw = laser
    amin = -math.pi / 2
    out = []
    for k in range(n):
        a = yaw + amin + k * inc
        r = expected_range(ox, oy, a)
        for c in circles:
            r = min(r, ray_circle(ox, oy, a, *c))
        for (x0, y0), (x1, y1) in segments:
            # ray o + t d against segment p0 + s (p1 - p0)
            dx, dy, ex, ey = math.cos(a), math.sin(a), x1 - x0, y1 - y0
            den = dx * ey - dy * ex
            if abs(den) > 1e-12:
                t = ((x0 - ox) * ey - (y0 - oy) * ex) / den
                s = ((x0 - ox) * dy - (y0 - oy) * dx) / den
                if t > 0.0 and 0.0 <= s <= 1.0:
                    r = min(r, t)
        out.append(r)
    return np.array(out), amin, inc


def test_detect_finds_round_bodies_at_their_centres_and_ignores_walls_and_long_objects():
    static = StaticMap(simple_room_map(), 0.2)
    laser = (3.0, 2.0, math.pi)                         # looking at -x, the west wall
    bodies = [(1.5, 1.2, 0.25), (1.2, 3.0, 0.25)]      # 0.5 m wide, 1.7 m and 2.1 m away
    board = ((1.0, 0.4), (2.3, 0.4))                  # 1.3 m long, 0.3 m off the wall
    ranges, amin, inc = synthetic_scan(laser, bodies, [board])
    dets = detect_scan(ranges, amin, inc, laser, static, TrackerConfig())
    assert len(dets) == 2, dets                        # the 1.3 m board is too long
    for (cx, cy, r) in bodies:
        d = min(dets, key=lambda q: math.hypot(q.x - cx, q.y - cy))
        # centroid of the near arc + 0.2 m: within 2 cm of the true centre
        assert math.hypot(d.x - cx, d.y - cy) < 0.02, (d, cx, cy)
        assert 0.4 < d.size <= 0.5 and d.n_points >= 12
    # the walls alone: nothing
    ranges, amin, inc = synthetic_scan(laser, [])
    assert detect_scan(ranges, amin, inc, laser, static) == []
    # min_points: a thin post (3 cm) at 2.5 m gives 1 point
    ranges, amin, inc = synthetic_scan(laser, [(0.5, 2.0, 0.015)])
    assert detect_scan(ranges, amin, inc, laser, static) == []


def test_view_edge_marks_the_first_and_last_beam_that_reads_of_a_fan_and_none_of_a_circle():
    inc = math.radians(1.0)
    ranges = np.full(181, 3.0)
    wrap, edge = view_edge(ranges, np.array([0, 5, 179, 180]), inc)
    assert not wrap and edge.tolist() == [True, False, False, True]
    # NaN and -inf do not say where the view ends: the edge is the next beam in; +inf does
    ranges[[0, 1, 180]] = [np.nan, -np.inf, np.inf]
    wrap, edge = view_edge(ranges, np.array([2, 3, 179]), inc)
    assert edge.tolist() == [True, False, False]
    wrap, edge = view_edge(np.ones(360), np.array([0, 359]), inc)
    assert wrap and edge is None


def test_a_body_the_view_edge_cuts_is_a_cut_detection_off_its_centre_or_none_with_drop():
    static = StaticMap(simple_room_map(), 0.2)
    laser = (3.0, 2.0, math.pi)              # beam 0 points north (+y), beam 180 south
    whole = (1.5, 1.2, 0.25)
    # across beam 0 (only its west part in view), and across beam 180, after the wall
    # points the map explains in beam order (only its west part in view)
    for cut in ((3.12, 3.2, 0.25), (3.12, 0.9, 0.25)):
        ranges, amin, inc = synthetic_scan(laser, [cut, whole])
        for mode in ("use", "position"):
            dets = detect_scan(ranges, amin, inc, laser, static, TrackerConfig(edge_cut=mode))
            assert len(dets) == 2
            d = min(dets, key=lambda q: math.hypot(q.x - cut[0], q.y - cut[1]))
            # the points left lie west of the body's centre: over 0.1 m off
            assert cut[0] - d.x > 0.1, d
            assert d.cut == (mode == "position") and not any(q.cut for q in dets if q is not d)
        dets, pts = scan_detections(ranges, amin, inc, laser, static,
                                    TrackerConfig(edge_cut="drop"))
        assert len(dets) == 1 and not dets[0].cut
        assert math.hypot(dets[0].x - whole[0], dets[0].y - whole[1]) < 0.02
    with pytest.raises(TrackingError, match="edge_cut must be one of use, position, drop"):
        TrackerConfig(edge_cut="hold").check()


def test_a_cut_detection_corrects_its_track_s_position_not_its_velocity():
    tracker = Tracker(TrackerConfig(edge_cut="position"))
    for k in range(6):                       # walking +x at 0.5 m/s, 0.1 s scans
        tracker.update([Detection(0.05 * k, 0.0, 0.4, 10)], 0.1 * k)
    (tr,) = tracker.confirmed()
    assert tr.vx == pytest.approx(0.5, abs=0.15)
    vx, vy = tr.vx, tr.vy
    # 2 s of cut detections standing at x = 0.4 (the body stopped across the edge): the
    # track lives on, its velocity untouched, its position kept near them (not coasting)
    for k in range(1, 21):
        (out,) = tracker.update([Detection(0.4, 0.0, 0.3, 5, cut=True)], 0.5 + 0.1 * k)
        assert out.id == tr.id and (out.vx, out.vy) == pytest.approx((vx, vy))
    assert 0.4 < out.x < 0.4 + 0.5 * vx and abs(out.y) < 0.05
    # a plain detection there corrects the velocity again, towards standing
    (out,) = tracker.update([Detection(0.4, 0.0, 0.4, 10)], 2.6)
    assert out.vx < vx - 0.05
    # once nothing comes, it dies after max_age
    tracker.update([], 3.7)
    assert tracker.tracks == []
    # a track a cut detection starts stands while cut ones slide (a body entering the view)
    for k in range(5):
        tracker.update([Detection(5.0 + 0.05 * k, 5.0, 0.3, 5, cut=True)], 3.8 + 0.1 * k)
    (new_tr,) = tracker.confirmed()
    assert (new_tr.vx, new_tr.vy) == (0.0, 0.0) and new_tr.x > 5.1


def test_detect_pushes_the_centroid_away_from_the_sensor():
    static = StaticMap(simple_room_map(), 0.2)
    pts = np.array([(2.0, 1.9), (2.0, 2.0), (2.0, 2.1)])   # a flat face seen from (1, 2)
    (d,) = detect(pts, static, (1.0, 2.0), TrackerConfig(centre_offset=0.25))
    assert (d.x, d.y) == pytest.approx((2.25, 2.0)) and d.size == pytest.approx(0.2)
    assert d.n_points == 3
    (d,) = detect(pts, static, (1.0, 2.0), TrackerConfig(centre_offset=0.0))
    assert (d.x, d.y) == pytest.approx((2.0, 2.0))


# --------------------------------------------------------------------------------------------
# tracker on synthetic detection streams
# --------------------------------------------------------------------------------------------


def det(x, y):
    return Detection(x=float(x), y=float(y), size=0.4, n_points=10)


def test_kalman_filter_converges_on_a_constant_velocity_target():
    rng = np.random.default_rng(3)
    tracker = Tracker(TrackerConfig())
    v = np.array([0.8, -0.3])
    for k in range(61):                                 # 6 s at 10 Hz
        t = 1.0 + 0.1 * k
        p = np.array([1.0, 2.0]) + v * (t - 1.0) + rng.normal(0.0, 0.02, 2)
        out = tracker.update([det(*p)], t)
    (tr,) = out
    assert tr.id == 1 and tr.confirmed and tr.hits == 61
    assert math.hypot(tr.vx - v[0], tr.vy - v[1]) < 0.05, (tr.vx, tr.vy)
    assert math.hypot(tr.x - (1.0 + 0.8 * 6.0), tr.y - (2.0 - 0.3 * 6.0)) < 0.05
    assert tr.speed == pytest.approx(math.hypot(tr.vx, tr.vy))
    assert np.allclose(tr.cov, tr.cov.T) and np.all(np.linalg.eigvalsh(tr.cov) > 0)
    d = tr.to_dict()
    assert d["id"] == 1 and d["confirmed"] is True and len(d["cov"]) == 4


def test_two_crossing_targets_keep_their_ids():
    """A and B cross at (2, 1) at t = 2.5 s; while they are closer than 0.3 m the lidar would
    see one merged cluster, so one detection at their midpoint is given."""
    tracker = Tracker(TrackerConfig())
    first = {}
    for k in range(51):
        t = 0.1 * k
        a = np.array([0.0, 0.0]) + t * np.array([0.8, 0.4])
        b = np.array([0.0, 2.0]) + t * np.array([0.8, -0.4])
        if np.linalg.norm(a - b) < 0.3:
            dets = [det(*(a + b) / 2.0)]
        else:
            dets = [det(*a), det(*b)] if k % 2 else [det(*b), det(*a)]
        out = tracker.update(dets, t)
        if len(out) == 2 and not first:
            first = {"a": min(out, key=lambda q: np.hypot(q.x - a[0], q.y - a[1])).id,
                     "b": min(out, key=lambda q: np.hypot(q.x - b[0], q.y - b[1])).id}
    assert len(out) == 2 and first["a"] != first["b"]
    by_id = {q.id: q for q in out}
    assert set(by_id) == set(first.values())
    assert math.hypot(by_id[first["a"]].x - a[0], by_id[first["a"]].y - a[1]) < 0.05
    assert math.hypot(by_id[first["b"]].x - b[0], by_id[first["b"]].y - b[1]) < 0.05
    assert [q.id for q in tracker.tracks] == sorted(first.values())   # no extra births


def test_a_target_that_disappears_is_deleted_after_max_age():
    cfg = TrackerConfig(max_age=1.0)
    tracker = Tracker(cfg)
    for k in range(10):
        tracker.update([det(1.0 + 0.05 * k, 1.0)], 0.1 * k)
    assert [q.id for q in tracker.confirmed()] == [1]
    last = 0.9
    assert [q.id for q in tracker.predict_only(last + 0.5)] == [1]
    (coasting,) = tracker.update([], last + 0.95)
    assert coasting.misses == 2 and coasting.last_seen == pytest.approx(last)
    assert coasting.x == pytest.approx(1.45 + 0.5 * 0.95, abs=0.05)   # moved on at 0.5 m/s
    assert tracker.update([], last + 1.05) == [] and tracker.tracks == []


def test_births_need_confirm_hits_and_tentative_tracks_die_fast():
    tracker = Tracker(TrackerConfig(confirm_hits=3, tentative_max_age=0.25))
    assert tracker.update([det(1.0, 1.0)], 0.0) == []
    assert [(q.id, q.confirmed, q.hits) for q in tracker.tracks] == [(1, False, 1)]
    assert tracker.update([det(1.0, 1.0)], 0.1) == []
    (tr,) = tracker.update([det(1.0, 1.0)], 0.2)
    assert (tr.id, tr.confirmed, tr.hits, tr.born) == (1, True, 3, 0.0)
    # clutter: one detection far away, then nothing: tentative, gone after 0.25 s
    tracker.update([det(1.0, 1.0), det(3.0, 3.0)], 0.3)
    assert [q.id for q in tracker.tracks] == [1, 2]
    tracker.update([det(1.0, 1.0)], 0.5)
    assert [q.id for q in tracker.tracks] == [1, 2]
    tracker.update([det(1.0, 1.0)], 0.6)
    assert [q.id for q in tracker.tracks] == [1]
    # ids are never reused
    tracker.update([det(1.0, 1.0), det(3.0, 3.0)], 0.7)
    assert [q.id for q in tracker.tracks] == [1, 3]
    assert [q.id for q in Tracker(TrackerConfig(confirm_hits=1)).update([det(0, 0)], 1.0)] == [1]


def test_time_must_not_go_backwards():
    tracker = Tracker()
    tracker.update([det(1.0, 1.0)], 2.0)
    tracker.update([det(1.0, 1.0)], 2.0)               # the same time is fine (dt = 0)
    with pytest.raises(TrackingError, match=r"update time t=1.900000000 s is before the "
                                            r"previous update \(2.000000000 s\)"):
        tracker.update([det(1.0, 1.0)], 1.9)
    with pytest.raises(TrackingError, match=r"update time t must be a finite number .* got nan"):
        tracker.update([], float("nan"))
    assert tracker.time == 2.0 and [q.hits for q in tracker.tracks] == [2]


@pytest.mark.parametrize("field, value, match", [
    ("cluster_gap", 0.0, r"cluster_gap must be a finite number > 0, got 0.0"),
    ("static_tolerance", -0.1, r"static_tolerance must be a finite number >= 0, got -0.1"),
    ("measurement_noise", float("inf"), r"measurement_noise must be a finite number > 0"),
    ("gate", "9.21", r"gate must be a finite number > 0, got '9.21'"),
    ("min_points", 0, r"min_points must be an integer >= 1, got 0"),
    ("confirm_hits", 2.5, r"confirm_hits must be an integer >= 1, got 2.5"),
    ("max_age", -1.0, r"max_age must be a finite number > 0, got -1.0"),
    ("max_size", 0.01, r"max_size \(0.01 m\) must be >= min_size \(0.05 m\)"),
])
def test_bad_config_raises_naming_the_field(field, value, match):
    with pytest.raises(TrackingError, match="tracker: " + match):
        Tracker(TrackerConfig(**{field: value}))


# --------------------------------------------------------------------------------------------
# the real world
# --------------------------------------------------------------------------------------------

#: robot1 (the moving target, a Scitos A5: an octagonal prism 0.64 m across) drives these
#: corners of a 1.2 m x 2.4 m rectangle in front of robot2, turning in place at each.
ROUTE = [(2.0, 2.0), (2.0, 0.8), (0.8, 0.8), (0.8, 3.2), (2.0, 3.2)]
SPEED = 0.5
#: the Scitos wants a larger centre offset than the default (see TrackerConfig.centre_offset):
#: measured 0.252 +- 0.003 m from robot2's scans.
SCITOS = TrackerConfig(centre_offset=0.25)


def laser_pose(world, i):
    """(x, y, yaw) of robot i's base_laser_link in the map frame, from its true pose."""
    x, y, yaw = world.view(i).pose
    ox, oy, _, lyaw = world.models[i].laser_pose
    c, s = math.cos(yaw), math.sin(yaw)
    return (x + c * ox - s * oy, y + s * ox + c * oy, yaw + lyaw)


def drive_route(world, i, route, k):
    """Command robot i toward route[k]: turn in place, then drive straight at SPEED (slowing
    to stop on the corner). Returns the index of the corner it is heading for."""
    x, y, yaw = world.view(i).pose
    gx, gy = route[k]
    d = math.hypot(gx - x, gy - y)
    if d < 0.02:
        world.command(i, 0.0)
        return k + 1
    e = (math.atan2(gy - y, gx - x) - yaw + math.pi) % (2.0 * math.pi) - math.pi
    w = max(-1.0, min(1.0, 3.0 * e))
    if abs(e) > 0.03 and d > 0.1:
        world.command(i, 0.0, 0.0, w)
    else:
        world.command(i, min(SPEED, math.sqrt(1.6 * max(d - 0.01, 0.0))), 0.0, w)
    return k


def test_tracker_follows_a_moving_robot_in_simple_with_one_id_and_no_wall_tracks():
    """The headline test: robot2 (at (3, 3), facing -x, 180-degree lidar at 10 Hz) watches
    robot1 drive a rectangle at 0.5 m/s (about 25 s of sim time). Only robot2's scans, its
    laser pose and the map are given to the tracker; robot1's true pose only scores it.

    The moving "box" is robot1 itself: ``World`` casts an unmoved lidar's beams at the walls
    once and then only recasts the beams that can reach one of its own robots, so a foreign
    PyBullet body would look frozen in robot2's scans.
    """
    world = World.from_name("simple", seed=0)
    try:
        static = StaticMap(world.fmap, SCITOS.static_tolerance)
        tracker = Tracker(SCITOS)
        k, ids, pos_err, vel_err, truth_v, confirmed_at, gaps = 0, set(), [], [], [], None, 0
        while k < len(ROUTE):
            k = drive_route(world, 0, ROUTE, k)
            for scan in world.step(1):
                if scan.robot != 1:
                    continue
                t = scan.stamp_ns * 1e-9
                out = tracker.update(detect_scan(scan.ranges, scan.angle_min,
                                                 scan.angle_increment, laser_pose(world, 1),
                                                 static, SCITOS), t)
                view = world.view(0)
                tx, ty, tyaw = view.pose
                v = np.array([view.velocity[0] * math.cos(tyaw), view.velocity[0] * math.sin(tyaw)])
                truth_v.append(v)
                if confirmed_at is None and out:
                    confirmed_at = t
                gaps += confirmed_at is not None and not out
                ids |= {q.id for q in out}
                for q in out:
                    pos_err.append(math.hypot(q.x - tx, q.y - ty))
                    # settled: driving straight at full speed for the last second
                    if (len(truth_v) > 10 and view.velocity[0] > 0.45
                            and max(np.linalg.norm(u - v) for u in truth_v[-11:]) < 0.01):
                        vel_err.append(math.hypot(q.vx - v[0], q.vy - v[1]))
        duration = t - 1.0
        assert duration > 20.0 and world.view(0).pose[0] == pytest.approx(2.0, abs=0.03)
        assert confirmed_at is not None and confirmed_at <= 1.0 + 0.45, confirmed_at
        assert len(ids) == 1 and gaps == 0, "ids %s, scans without the track %d" % (ids, gaps)
        assert max(pos_err) < 0.15, "max position error %.3f m" % max(pos_err)
        assert len(vel_err) >= 40, len(vel_err)
        assert max(vel_err) < 0.15, "max velocity error %.3f m/s (mean %.3f)" % (
            max(vel_err), float(np.mean(vel_err)))
    finally:
        world.close()


def test_no_tracks_from_walls_and_pillar_seen_by_a_moving_lidar():
    """robot2 alone in ``simple`` drives a circle (0.25 m/s, 0.5 rad/s, 13 s: more than one
    turn), so its lidar sweeps every wall and the pillar from many viewpoints: no detection,
    no track."""
    cfg = load_world_config(resolve_world("simple", worlds_dir()))
    world = World(dataclasses.replace(cfg, robots=[r for r in cfg.robots if r.name == "robot2"]),
                  seed=1)
    try:
        static = StaticMap(world.fmap, SCITOS.static_tolerance)
        tracker = Tracker(SCITOS)
        scans = detections = 0
        born = set()
        for _ in range(1300):
            world.command(0, 0.25, 0.0, 0.5)
            for scan in world.step(1):
                dets = detect_scan(scan.ranges, scan.angle_min, scan.angle_increment,
                                   laser_pose(world, 0), static, SCITOS)
                tracker.update(dets, scan.stamp_ns * 1e-9)
                scans += 1
                detections += len(dets)
                born |= {q.id for q in tracker.tracks}
        assert scans == 130
        assert detections == 0 and born == set(), (detections, born)
    finally:
        world.close()


def test_min_travel_keeps_standing_clutter_out_but_reports_a_mover():
    cfg = TrackerConfig(min_travel=0.5)
    tr = Tracker(cfg)
    out = []
    for k in range(40):  # 4 s: a post standing at (1, 1); a body walking from (3, 1) at 0.5 m/s
        t = 0.1 * k
        out.append(tr.update([Detection(1.0, 1.0, 0.3, 6), Detection(3.0 + 0.05 * k, 1.0, 0.4, 8)],
                             t))
    ids = {t.id for tracks in out for t in tracks}
    assert len(ids) == 1
    final = out[-1][0]
    assert final.x == pytest.approx(3.0 + 0.05 * 39, abs=0.1)
    # confirmed only after 0.5 m of travel: not before 1 s (10 scans) into the run
    first = next(k for k, tracks in enumerate(out) if tracks)
    assert 9 <= first <= 14
    # with min_travel 0 the post is reported too
    tr = Tracker(TrackerConfig())
    assert len(tr.update([Detection(1.0, 1.0, 0.3, 6)], 0.0) or
               tr.update([Detection(1.0, 1.0, 0.3, 6)], 0.1) or
               tr.update([Detection(1.0, 1.0, 0.3, 6)], 0.2)) == 1


def test_pose_history_gives_the_pose_at_a_stamp_and_never_extrapolates():
    h = PoseHistory(horizon=5.0, max_gap=0.2)
    assert h.at(1.0) is None and h.latest is None
    h.add(1.0, 0.0, 0.0, 3.0)
    h.add(1.1, 1.0, 2.0, -3.0)          # yaw crosses +-pi: interpolate the short way
    assert h.at(1.0) == (0.0, 0.0, 3.0)
    assert h.at(1.1) == (1.0, 2.0, -3.0)
    x, y, a = h.at(1.05)
    assert (x, y) == pytest.approx((0.5, 1.0))
    short = 2.0 * math.pi - 6.0          # the short way from 3.0 to -3.0 is +0.283 rad
    assert a == pytest.approx(3.0 + short / 2.0)
    assert h.at(0.99) is None and h.at(1.11) is None     # outside: no extrapolation
    h.add(1.5, 5.0, 5.0, 0.0)            # a 0.4 s gap is not interpolated across
    assert h.at(1.3) is None and h.at(1.5) == (5.0, 5.0, 0.0)
    assert h.latest == 1.5 and len(h) == 3
    h.add(0.5, 9.0, 9.0, 0.0)            # time went back (bag loop): afresh
    assert len(h) == 1 and h.at(1.0) is None and h.at(0.5) == (9.0, 9.0, 0.0)


def test_pose_history_keeps_only_its_horizon():
    h = PoseHistory(horizon=1.0)
    for k in range(1000):
        h.add(k * 0.01, float(k), 0.0, 0.0)
    assert len(h) <= 100 + 65
    assert h.at(9.99) == (999.0, 0.0, 0.0)
    assert h.at(0.0) is None
