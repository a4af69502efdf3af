"""The simulator core against known geometry and commanded motion (no ROS).

``worlds/simple`` is a 6 m x 4 m room: free interior x in [0.10, 5.90], y in [0.10, 3.90], and a
pillar over x in [4.00, 4.50], y in [1.00, 1.50]. The Scitos A5 laser sits at (0.3, 0, 0.437)
in base_footprint; its base hull is an octagon of circumradius 0.32 m with a vertex ahead.
"""
from __future__ import annotations

import dataclasses
import math
import os
import sys

import numpy as np
import pytest

from bullet_floor_sim.sim.config import (DriveConfig, LaserConfig, OdometryConfig, RobotSpec,
                                          load_world_config, resolve_world)
from bullet_floor_sim.errors import CommandError, ConfigError
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim.sensors import cast_rays
from bullet_floor_sim.sim.clock import SimClock
from bullet_floor_sim.sim.world import World

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from simple_room import (SCITOS_R, expected_range, near_corner, octagon_offset,  # noqa: E402
                         octagon_range)

EXACT = LaserConfig(fov=360.0, resolution=1.0, noise_std=0.0)
STILL = OdometryConfig(noise_trans=0.0, noise_rot=0.0, noise_rot_per_m=0.0)


def simple_world(robots, **kwargs):
    cfg = load_world_config(resolve_world("simple", worlds_dir()))
    return World(dataclasses.replace(cfg, robots=robots), seed=kwargs.pop("seed", 5), **kwargs)


@pytest.fixture
def one_robot():
    w = simple_world([RobotSpec(name="r", pose=(1.5, 2.0, 0.0), laser=EXACT, odometry=STILL)])
    yield w
    w.close()


def test_rays_from_known_points_hit_walls_at_exact_distances():
    w = simple_world([])
    try:
        points = [(1.0, 1.0), (3.0, 2.0), (5.0, 3.5), (4.25, 0.5), (0.5, 3.0)]
        angles = np.radians(np.arange(0.3, 360.0, 7.5))  # no ray grazes a corner
        froms, tos, want = [], [], []
        for x, y in points:
            for a in angles:
                froms.append((x, y, 0.4))
                tos.append((x + 20 * math.cos(a), y + 20 * math.sin(a), 0.4))
                want.append(expected_range(x, y, a))
        frac, ids = cast_rays(w.client, np.array(froms), np.array(tos))
        assert (ids >= 0).all()
        np.testing.assert_allclose(frac * 20.0, want, atol=0.01)
    finally:
        w.close()


def test_scan_matches_room_geometry(one_robot):
    scans = one_robot.step(10)  # first scan after one laser period (0.1 s)
    assert len(scans) == 1
    scan = scans[0]
    assert scan.ranges.shape == (360,) and scan.angle_min == pytest.approx(-math.pi)
    angles = scan.angle_min + scan.angle_increment * np.arange(360)
    want = [expected_range(1.8, 2.0, a) for a in angles]
    np.testing.assert_allclose(scan.ranges, want, atol=0.01)
    assert scan.ranges[180] == pytest.approx(4.1, abs=0.01)   # ahead: east wall at 5.9
    assert scan.ranges[0] == pytest.approx(1.7, abs=0.01)     # behind: west wall at 0.1


def test_scan_of_a_turned_robot():
    w = simple_world([RobotSpec(name="r", pose=(3.0, 2.5, 2.0), laser=EXACT, odometry=STILL)])
    try:
        scan = w.step(10)[0]
        ox, oy = 3.0 + 0.3 * math.cos(2.0), 2.5 + 0.3 * math.sin(2.0)
        angles = 2.0 + scan.angle_min + scan.angle_increment * np.arange(360)
        np.testing.assert_allclose(scan.ranges, [expected_range(ox, oy, a) for a in angles],
                                   atol=0.01)
    finally:
        w.close()


def test_robot_sees_other_robot_but_not_itself():
    w = simple_world([RobotSpec(name="a", pose=(1.5, 2.0, 0.0), laser=EXACT, odometry=STILL),
                      RobotSpec(name="b", pose=(3.5, 2.0, math.pi), laser=EXACT, odometry=STILL)])
    try:
        scans = {s.robot: s for s in w.step(10)}
        # b's hull vertex faces a at x = 3.5 - 0.32; a's laser is at x = 1.8
        assert scans[0].ranges[180] == pytest.approx(3.18 - 1.8, abs=0.01)
        # b's laser at x = 3.2 looking west sees a's rear hull vertex at 1.5 + 0.32
        assert scans[1].ranges[180] == pytest.approx(3.2 - 1.82, abs=0.01)
        for s in scans.values():
            assert np.isfinite(s.ranges).all() and s.ranges.min() > 0.3
    finally:
        w.close()


def test_range_limits_and_noise():
    laser = LaserConfig(fov=360.0, resolution=1.0, noise_std=0.05, range_max=3.0, range_min=0.1)
    w = simple_world([RobotSpec(name="r", pose=(1.5, 2.0, 0.0), laser=laser, odometry=STILL)],
                     seed=11)
    try:
        scans = w.step(200)  # 20 scans, robot still
        r = np.array([s.ranges for s in scans])
        angles = scans[0].angle_min + scans[0].angle_increment * np.arange(360)
        want = np.array([expected_range(1.8, 2.0, a) for a in angles])
        assert (want > 3.3).sum() > 50
        assert np.isposinf(r[:, want > 3.3]).all()           # beyond range_max: no return
        near = want < 2.7
        err = r[:, near] - want[near]
        assert abs(err.mean()) < 0.005
        assert err.std() == pytest.approx(0.05, rel=0.08)
    finally:
        w.close()


def drive(w, robot, cmd, seconds, every=0.1):
    """Re-send a command every ``every`` s (as a planner does) for ``seconds`` of sim time."""
    steps = int(round(seconds / w.clock.dt))
    k_every = int(round(every / w.clock.dt))
    for k in range(steps):
        if k % k_every == 0:
            w.command(robot, *cmd)
        w.step(1)


def ramp_distance(v, acc, dt, steps):
    """Distance covered from rest under the drive's per-step acceleration limit."""
    d, cur = 0.0, 0.0
    for _ in range(steps):
        cur = min(v, cur + acc * dt)
        d += cur * dt
    return d


def test_diff_straight_line_and_odometry(one_robot):
    w = one_robot
    drive(w, 0, (0.5, 0.0, 0.0), 2.0)
    view = w.view(0)
    dist = ramp_distance(0.5, 1.0, 0.01, 200)
    assert dist == pytest.approx(0.8775)
    assert view.pose == pytest.approx((1.5 + dist, 2.0, 0.0), abs=1e-9)
    assert view.odom_pose == pytest.approx((dist, 0.0, 0.0), abs=1e-9)
    assert view.velocity == pytest.approx((0.5, 0.0, 0.0))
    # wheels: both turned dist / radius
    assert view.wheel_positions == pytest.approx((dist / 0.09, dist / 0.09))


def test_diff_arc_follows_commanded_curvature(one_robot):
    w = one_robot
    w.pose[0] = (2.0, 1.2, 0.0)  # room for a circle of radius 1 m
    w.spawn[0] = (2.0, 1.2, 0.0)
    drive(w, 0, (0.5, 0.0, 0.5), 1.0)   # ramps are over by now (0.5 s for v, 0.17 s for w)
    x0, y0, th0 = w.view(0).pose
    o0 = w.view(0).odom_pose
    drive(w, 0, (0.5, 0.0, 0.5), 2.0)
    x1, y1, th1 = w.view(0).pose
    t = 2.0
    assert th1 == pytest.approx(th0 + 0.5 * t, abs=1e-9)
    assert x1 == pytest.approx(x0 + (math.sin(th0 + 0.5 * t) - math.sin(th0)), abs=1e-6)
    assert y1 == pytest.approx(y0 - (math.cos(th0 + 0.5 * t) - math.cos(th0)), abs=1e-6)
    # noise-free odometry is the same rigid motion expressed in the odom frame
    o1 = w.view(0).odom_pose
    assert math.hypot(o1[0] - o0[0], o1[1] - o0[1]) == pytest.approx(math.hypot(x1 - x0, y1 - y0))
    assert o1[2] - o0[2] == pytest.approx(th1 - th0)


def test_diff_ignores_lateral_and_omni_moves_sideways():
    omni = DriveConfig(type="omni")
    w = simple_world([RobotSpec(name="d", pose=(1.5, 1.0, 0.0), laser=EXACT, odometry=STILL),
                      RobotSpec(name="o", pose=(1.5, 3.0, 0.0), laser=EXACT, odometry=STILL,
                                drive=omni)])
    try:
        for k in range(150):
            if k % 10 == 0:
                w.command(0, 0.0, 0.3, 0.0)
                w.command(1, 0.2, -0.3, 0.0)
            w.step(1)
        assert w.view(0).pose == pytest.approx((1.5, 1.0, 0.0), abs=1e-12)
        assert w.view(1).pose[0] == pytest.approx(1.5 + ramp_distance(0.2, 1.0, 0.01, 150))
        assert w.view(1).pose[1] == pytest.approx(3.0 - ramp_distance(0.3, 1.0, 0.01, 150))
    finally:
        w.close()


def test_limits_clamp_and_bad_commands_are_rejected(one_robot):
    w = one_robot
    drive(w, 0, (5.0, 0.0, 0.0), 1.5)       # above max_linear 0.8, not absurd: clamped
    assert w.view(0).velocity[0] == pytest.approx(0.8)
    with pytest.raises(CommandError, match=r"robot 'r': cmd_vel linear.x is nan; command rejected"):
        w.command(0, float("nan"), 0.0, 0.0)
    with pytest.raises(CommandError, match=r"cmd_vel angular.z is inf"):
        w.command(0, 0.1, 0.0, float("inf"))
    with pytest.raises(CommandError, match=r"cmd_vel linear.x = 100 is absurd \(limit 0.8\)"):
        w.command(0, 100.0, 0.0, 0.0)
    assert np.isfinite(w.pose).all()
    assert tuple(w.target[0]) == (5.0, 0.0, 0.0)   # the last good command stands


def test_watchdog_stops_robot(one_robot):
    w = one_robot
    w.command(0, 0.5, 0.0, 0.0)
    w.step(50)                                  # 0.5 s: at speed, command still fresh
    assert w.view(0).velocity[0] == pytest.approx(0.5)
    w.step(1)                                   # this step starts 0.5 s after: still valid
    assert w.target[0].tolist() == [0.5, 0.0, 0.0]
    w.step(1)                                   # starts 0.51 s after the command: stopped
    assert w.target[0].tolist() == [0.0, 0.0, 0.0]
    w.step(60)                                  # decelerates at 1 m/s^2
    assert w.view(0).velocity == (0.0, 0.0, 0.0)
    x = w.view(0).pose[0]
    w.step(100)
    assert w.view(0).pose[0] == x


def test_wall_stops_robot_without_penetration(one_robot):
    w = one_robot
    w.pose[0] = (1.0, 2.0, math.pi)             # facing the west wall (inner face x = 0.1)
    w.spawn[0] = (1.0, 2.0, math.pi)
    w._check_due_ns = 0
    drive(w, 0, (0.5, 0.0, 0.0), 4.0)
    view = w.view(0)
    assert view.stalled or w.stall_count[0] > 0
    # the hull's rear vertex... the front vertex (0.32 ahead) touches x = 0.1 at most 1 step deep
    assert view.pose[0] - 0.32 >= 0.1 - 0.006
    assert view.pose[0] - 0.32 < 0.1 + 0.02
    assert view.velocity[0] == 0.0


def test_robots_do_not_drive_through_each_other():
    w = simple_world([RobotSpec(name="a", pose=(1.5, 2.0, 0.0), laser=EXACT, odometry=STILL),
                      RobotSpec(name="b", pose=(3.5, 2.0, math.pi), laser=EXACT, odometry=STILL)])
    try:
        for k in range(400):
            if k % 10 == 0:
                w.command(0, 0.5, 0.0, 0.0)
                w.command(1, 0.5, 0.0, 0.0)
            w.step(1)
        xa, xb = w.view(0).pose[0], w.view(1).pose[0]
        assert w.stall_count.sum() > 0
        # two 0.32 m vertices meet; the bumpers give 3 cm between robots (collision._ROBOT_CONTACT_SLACK)
        assert xb - xa >= 0.64 - 0.03 - 0.012
        assert xb - xa < 0.64 + 0.03
    finally:
        w.close()


def test_a_robot_pushed_by_another_can_still_turn_and_back_away():
    """Two robots in contact, one pushing: the other must not be frozen by the push (the
    walker and the observer stayed locked together for good in a 200-leg evaluation)."""
    w = simple_world([RobotSpec(name="a", pose=(1.5, 2.0, 0.0), laser=EXACT, odometry=STILL),
                      RobotSpec(name="b", pose=(2.6, 2.0, math.pi), laser=EXACT, odometry=STILL)])
    try:
        def run(steps, cmd_a, cmd_b):
            for k in range(steps):
                if k % 10 == 0:
                    w.command(0, *cmd_a)
                    w.command(1, *cmd_b)
                w.step(1)
        run(200, (0.5, 0.0, 0.0), (0.0, 0.0, 0.0))          # a drives into b and pushes
        xa, xb = w.view(0).pose[0], w.view(1).pose[0]
        assert w.stall_count[0] > 0 and 0.64 - 0.03 - 0.012 <= xb - xa < 0.64 + 0.012
        yaw0 = w.view(1).pose[2]
        run(200, (0.5, 0.0, 0.0), (0.0, 0.0, 1.0))          # b turns while a pushes
        turned = abs(math.atan2(math.sin(w.view(1).pose[2] - yaw0),
                                math.cos(w.view(1).pose[2] - yaw0)))
        assert turned > 0.3, "b turned only %.2f rad" % turned
        b0 = w.view(1).pose[:2]
        run(200, (0.5, 0.0, 0.0), (0.0, 0.0, 0.0))          # a keeps pushing
        yaw = w.view(1).pose[2]
        run(200, (0.5, 0.0, 0.0), (-0.3, 0.0, 0.0))         # b backs away (its -x is away)
        moved = math.hypot(*(np.asarray(w.view(1).pose[:2]) - np.asarray(b0)))
        assert moved > 0.2, "b moved only %.2f m (yaw %.2f)" % (moved, yaw)
    finally:
        w.close()


def test_odometry_error_statistics():
    from bullet_floor_sim.sim.sensors import Odometry

    n = 4000
    cfg = OdometryConfig(noise_trans=0.02, noise_rot=0.0, noise_rot_per_m=0.01, drift_yaw=0.0)
    odo = Odometry([cfg] * n, np.random.default_rng(0))
    pose = np.zeros((n, 3))
    for _ in range(100):                        # 1 m straight in 1 cm steps
        new = pose.copy()
        new[:, 0] += 0.01
        odo.update(pose, new)
        pose = new
    # heading noise also bends the path, but over 1 m its effect on x is second order
    assert odo.pose[:, 0].std() == pytest.approx(0.02, rel=0.08)
    assert abs(odo.pose[:, 0].mean() - 1.0) < 0.002
    assert odo.pose[:, 2].std() == pytest.approx(0.01, rel=0.08)


def test_odometry_drift_is_systematic():
    from bullet_floor_sim.sim.sensors import Odometry

    cfg = OdometryConfig(noise_trans=0.0, noise_rot=0.0, noise_rot_per_m=0.0, drift_yaw=0.02)
    odo = Odometry([cfg], np.random.default_rng(0))
    old = np.zeros((1, 3))
    new = np.array([[2.0, 0.0, 0.0]])
    odo.update(old, new)
    assert odo.pose[0, 2] == pytest.approx(0.04)


def test_battery_discharges_linearly(one_robot):
    pct, volt, charge = one_robot.battery.state(0, one_robot.clock.now_ns + 3600 * 10 ** 9)
    assert pct == pytest.approx(0.9)
    assert volt == pytest.approx(22.0 + 6.8 * 0.9)
    assert charge == pytest.approx(54.0)


def test_reset_returns_robots_and_odometry(one_robot):
    w = one_robot
    drive(w, 0, (0.5, 0.0, 0.3), 1.0)
    assert w.view(0).pose != pytest.approx((1.5, 2.0, 0.0))
    t = w.clock.now_ns
    w.reset()
    v = w.view(0)
    assert v.pose == (1.5, 2.0, 0.0) and v.odom_pose == (0.0, 0.0, 0.0)
    assert v.velocity == (0.0, 0.0, 0.0) and w.clock.now_ns == t   # time never goes back


def test_set_pose_teleports_without_odometry_seeing_the_jump(one_robot):
    w = one_robot
    drive(w, 0, (0.5, 0.0, 0.0), 2.0)
    odom = w.view(0).odom_pose
    assert odom[0] == pytest.approx(0.8775)
    w.set_pose(0, (3.0, 3.0, math.pi / 2))
    v = w.view(0)
    assert v.pose == pytest.approx((3.0, 3.0, math.pi / 2)) and v.velocity == (0.0, 0.0, 0.0)
    assert v.odom_pose == pytest.approx(odom, abs=1e-12)
    scan = w.step(10)[-1]   # the scan from there: the laser 0.3 m ahead, facing +y
    k = int(round(-scan.angle_min / scan.angle_increment))        # the beam straight ahead
    assert float(scan.ranges[k]) == pytest.approx(expected_range(3.0, 3.3, math.pi / 2), abs=1e-3)
    drive(w, 0, (0.3, 0.0, 0.0), 1.0)   # odometry goes on from where it was, along +x of odom
    assert w.view(0).odom_pose[0] > odom[0] + 0.1


def test_set_pose_into_a_wall_or_a_robot_is_refused_and_the_robot_stays():
    w = simple_world([RobotSpec(name="a", pose=(1.5, 2.0, 0.0)),
                      RobotSpec(name="b", pose=(3.0, 2.0, 0.0))])
    try:
        with pytest.raises(ConfigError, match=r"robot 'a' would stand inside a wall at \(4\.250"):
            w.set_pose(0, (4.25, 1.25, 0.0))
        with pytest.raises(ConfigError, match="robot 'a' would stand overlapping robot 'b'"):
            w.set_pose(0, (3.4, 2.0, 0.0))
        with pytest.raises(ConfigError, match="not finite"):
            w.set_pose(0, (float("nan"), 2.0, 0.0))
        with pytest.raises(ConfigError, match=r"robot 'a' would stand off the map at \(7\.000"):
            w.set_pose(0, (7.0, 2.0, 0.0))
        assert w.view(0).pose == (1.5, 2.0, 0.0)
        w.command(0, 0.5)       # and its body is back where it stands: it drives on
        w.step(100)
        assert w.view(0).pose[0] > 1.7
    finally:
        w.close()


def test_restart_with_a_seed_repeats_the_run_whatever_ran_before():
    def run(w, seed):
        w.restart(seed)
        out = []
        for _ in range(30):
            w.command(0, 0.4, 0.0, 0.2)
            out += [s.ranges.copy() for s in w.step(5)]
        return np.array(out), w.view(0).odom_pose

    w = simple_world([RobotSpec(name="r", pose=(1.5, 2.0, 0.0))])  # noisy lidar and odometry
    try:
        a, odom_a = run(w, 7)
        drive(w, 0, (0.2, 0.0, -0.5), 1.37)      # something else in between, off the period
        b, odom_b = run(w, 7)
        assert a.shape == b.shape and len(a) == 15
        np.testing.assert_array_equal(a, b)
        assert odom_a == odom_b and odom_a[0] > 0.2
        c, odom_c = run(w, 8)                    # another seed: other noise
        assert not np.array_equal(a, c) and odom_c != odom_a
        np.testing.assert_allclose(a, c, atol=0.1)
    finally:
        w.close()


def test_sim_clock_never_zero_and_fixed_step():
    c = SimClock(100.0)
    assert c.now_ns == 10 ** 9 and c.step_ns == 10 ** 7
    for _ in range(3):
        c.tick()
    assert c.now_ns == 10 ** 9 + 3 * 10 ** 7 and c.steps == 3
    with pytest.raises(Exception, match="start time must be > 0"):
        SimClock(100.0, start=0.0)


def test_scans_at_laser_rate(one_robot):
    scans = one_robot.step(100)
    stamps = [s.stamp_ns for s in scans]
    assert len(stamps) == 10
    assert set(np.diff(stamps)) == {10 ** 8}


def test_scans_over_the_ray_limit_are_split_and_exact():
    from bullet_floor_sim.sim.sensors import rays

    # 3 robots x 7200 beams = 21,600 rays: split into calls of the world's chunk size (4000
    # through the C API, 1000 through rayTestBatch); every scan still exact
    fine = LaserConfig(fov=360.0, resolution=0.05, noise_std=0.0)
    poses = [(1.0, 1.0, 0.0), (2.5, 3.0, 1.0), (5.0, 2.5, -2.0)]
    w = simple_world([RobotSpec(name="r%d" % i, pose=p, laser=fine, odometry=STILL)
                      for i, p in enumerate(poses)])
    w._grid_rays = None      # the walls through Bullet's ray test (the grid needs no batches)
    try:
        calls = []
        orig = rays._cast_batch

        def counting(client, froms, *a):
            calls.append(len(froms))
            return orig(client, froms, *a)

        rays._cast_batch = counting
        try:
            scans = w.step(10)
        finally:
            rays._cast_batch = orig
        k = rays.ray_chunk()
        assert k in (1000, 4000)
        assert calls[:21600 // k + 1] == [k] * (21600 // k) + [21600 % k]
        # beams at the other robots are clipped to their sections, not cast
        assert sum(calls) == w.rays_cast == 21600 and 0 < w.rays_at_robots < 21600 / 4
        assert max(calls) <= rays.MAX_RAYS_PER_BATCH
        for scan, (x, y, yaw) in zip(scans, poses):
            ox, oy = x + 0.3 * math.cos(yaw), y + 0.3 * math.sin(yaw)
            angles = yaw + scan.angle_min + scan.angle_increment * np.arange(7200)
            sel = slice(None, None, 37)   # a spread of beams across both batches
            want = [expected_range(ox, oy, a) for a in angles[sel]]
            got = scan.ranges[sel]
            ok = np.abs(got - want) < 0.01
            # beams that end on another robot are the only ones allowed to differ (shorter)
            assert (ok | (got < np.array(want))).all() and ok.mean() > 0.9
    finally:
        w.close()


def test_own_body_is_never_seen_at_any_heading():
    # the laser sits inside the base hull; a ray starting inside a convex shape may report a
    # hit at 0 depending on its direction (half the beams were -inf near +-90 degrees)
    w = simple_world([RobotSpec(name="r", pose=(2.5, 2.0, 0.0), laser=EXACT, odometry=STILL)])
    try:
        for yaw in np.radians(np.arange(-180.0, 180.0, 5.0)):
            w.pose[0] = (2.5, 2.0, yaw)
            w.lidar.forget()
            w.lidar.next_scan_ns[:] = w.clock.now_ns
            scan = w.lidar.read(w)[0]
            ox, oy = 2.5 + 0.3 * math.cos(yaw), 2.0 + 0.3 * math.sin(yaw)
            angles = yaw + scan.angle_min + scan.angle_increment * np.arange(360)
            np.testing.assert_allclose(scan.ranges, [expected_range(ox, oy, a) for a in angles],
                                       atol=0.01, err_msg="yaw %.0f deg" % math.degrees(yaw))
    finally:
        w.close()


#: the corners of worlds/simple's walls: the room's inside and the pillar's
WALL_CORNERS = [(0.1, 0.1), (5.9, 0.1), (0.1, 3.9), (5.9, 3.9), (4.0, 1.0), (4.5, 1.0),
                (4.0, 1.5), (4.5, 1.5)]


def near_wall_corner(px, py, tol=2e-3):
    return any(math.hypot(px - cx, py - cy) < tol for cx, cy in WALL_CORNERS)


@pytest.mark.parametrize("lift, grid", [(True, False), (True, True), (False, False)],
                         ids=["walls-then-robots", "grid-walls-then-robots", "full-scene"])
def test_scans_equal_every_beam_cast_in_the_full_scene(lift, grid):
    # the lidar casts at the walls with the robots moved out (reusing the wall distances of a
    # lidar that has not moved), then again only the beams that may meet a robot, and shortens
    # rays from the previous scan: none of it may change a range. With gui=True it casts every
    # beam in the full scene (lift=False), still shortening rays. With the walls walked on the
    # solid grid (sim/grid_rays.py, the default where numba is), a beam that grazes a wall's
    # corner may pass it where Bullet's edge tolerance meets it.
    from bullet_floor_sim.sim import grid_rays
    if grid and not grid_rays.available():
        pytest.skip("numba not installed")
    from bullet_floor_sim.sim.sensors import cast_rays as cast

    poses = [(1.0, 1.0, 0.3), (1.0, 3.0, -0.5), (2.5, 2.0, 2.0), (3.5, 3.2, 3.0), (5.2, 1.0, 1.6),
             (5.2, 3.0, -2.0)]
    fan = LaserConfig(fov=180.0, resolution=0.5, noise_std=0.0)   # a second beam geometry
    w = simple_world([RobotSpec(name="r%d" % i, pose=p, laser=EXACT if i % 2 else fan,
                                odometry=STILL) for i, p in enumerate(poses)])
    w._lift_for_rays = lift
    if not grid:
        w._grid_rays = None
    assert (w._grid_rays is not None) == grid
    rng = np.random.default_rng(2)
    try:
        checked = grazing = pressed = 0
        for k in range(300):
            if k % 20 == 0:
                for i in range(1, w.n):                      # robot 0 stands still
                    w.command(i, float(rng.uniform(0.0, 0.6)), 0.0, float(rng.uniform(-1, 1)))
            scans = w.step(1)
            if not scans:
                continue
            plan = w.lidar.plan([s.robot for s in scans], w.pose, w.bounds)
            tos = plan.origins.copy()
            tos[:, :2] += plan.dirs * plan.full[:, None]
            w._sync_bodies()                                 # every body where its robot is
            frac, ids = cast(w.client, plan.froms, tos)      # every beam, robots in place
            want = np.where(ids >= 0, plan.start + frac * (plan.full - plan.start), np.inf)
            want[want < 0.1] = -np.inf                       # range_min
            got = np.concatenate([s.ranges for s in scans])
            np.testing.assert_array_equal(np.isposinf(got), np.isposinf(want))
            np.testing.assert_array_equal(np.isneginf(got), np.isneginf(want))
            on_robot = np.isin(ids, w.bodies) & np.isfinite(want)
            got, want = np.where(np.isfinite(want), got, 0.0), np.where(np.isfinite(want), want, 0.0)
            # walls: the same float32; robots: Bullet's convex ray cast agrees to a few mm,
            # except where a beam grazes a corner: Bullet rounds corners up to 0.5 mm wider
            # than the hull and its margin, which moves a beam almost along an edge by cm
            # corner (or, for robots pressed together, a beam leaving its own robot inside
            # the other: Bullet's ray starting inside a convex shape passes through, the
            # lidar sees the other robot at once)
            off = np.abs(got - want) > np.where(on_robot, 5e-3, 1e-5)
            for k in np.flatnonzero(off):
                ox, oy = plan.origins[k, :2]
                dx, dy = plan.dirs[k]
                gx, gy = ox + dx * got[k], oy + dy * got[k]
                if (min(octagon_offset(gx, gy, p) for p in w.pose) < 1e-3
                        and got[k] == np.float32(plan.start[k])):
                    pressed += 1
                    continue
                assert (near_corner(ox + dx * want[k], oy + dy * want[k], w.pose)
                        or near_corner(gx, gy, w.pose)
                        or (grid and near_wall_corner(ox + dx * want[k], oy + dy * want[k]))), \
                    "beam %d: %.4f, full scene %.4f" % (k, got[k], want[k])
                grazing += 1
            checked += on_robot.sum()
        assert checked > 500 and grazing <= 0.005 * checked, (grazing, pressed, checked)
        if lift:
            assert w.rays_at_robots > 0 and w.rays_reused >= 28 * 361
    finally:
        w.close()


def test_small_worlds_step_in_floats_exactly_as_numpy_does(monkeypatch):
    # up to small.SMALL_N robots, drives, integration, wheels and odometry step in plain
    # floats or compiled loops, and collision windows of up to collision._SMALL_PAIRS pairs
    # are computed in floats; the result must be the numpy paths' (same formulas, same
    # random draws)
    from bullet_floor_sim.sim import collision, small

    noisy = OdometryConfig(noise_trans=0.05, noise_rot=0.05, noise_rot_per_m=0.02, drift_yaw=0.01)
    specs = [RobotSpec(name="d", pose=(1.5, 1.0, 0.0), laser=EXACT, odometry=noisy),
             RobotSpec(name="o", pose=(1.5, 3.0, 0.5), laser=EXACT, odometry=noisy,
                       drive=DriveConfig(type="omni")),
             RobotSpec(name="w", pose=(0.8, 2.0, 3.0), laser=EXACT, odometry=noisy)]

    def run():
        w = simple_world(specs, seed=9)
        rng = np.random.default_rng(4)
        try:
            for k in range(400):
                if k % 25 == 0:
                    for i in range(3):
                        w.command(i, *rng.uniform([-0.3, -0.3, -1.0], [0.9, 0.3, 1.0]))
                w.step(1)
            w.update_odometry()
            return (w.pose.copy(), w.vel.copy(), w._travel.copy(), w.odometry.pose.copy(),
                    w.stall_count.copy())
        finally:
            w.close()

    floats = run()
    monkeypatch.setattr(small, "SMALL_N", 0)
    monkeypatch.setattr(collision, "_SMALL_PAIRS", 0)   # the numpy collision window too
    arrays = run()
    for a, b in zip(floats, arrays):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
    assert floats[0][:, :2].std() > 0.1     # they did move


def test_other_robots_are_seen_at_their_octagons():
    # beams at another robot are clipped to its measured cross-section: every range must be
    # that of the octagon (or of the wall before it), beams grazing a corner aside
    poses = [(1.0, 2.0, 0.0), (2.2, 2.3, 0.4), (1.4, 3.1, -2.0), (2.0, 1.0, 1.0)]
    fine = LaserConfig(fov=360.0, resolution=0.25, noise_std=0.0)
    w = simple_world([RobotSpec(name="r%d" % i, pose=p, laser=fine, odometry=STILL)
                      for i, p in enumerate(poses)])
    try:
        assert (w.section_index[~np.eye(4, dtype=bool)] >= 0).all(), w.sections_report
        scans = w.step(10)
        assert len(scans) == 4
        on_robots = 0
        for scan in scans:
            x, y, yaw = poses[scan.robot]
            ox, oy = x + 0.3 * math.cos(yaw), y + 0.3 * math.sin(yaw)
            others = [p for k, p in enumerate(poses) if k != scan.robot]
            angles = yaw + scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
            for a, got in zip(angles.tolist(), scan.ranges.tolist()):
                robot = min(octagon_range(ox, oy, a, p) for p in others)
                wall = expected_range(ox, oy, a)
                px, py = ox + got * math.cos(a), oy + got * math.sin(a)
                if robot < wall - 1e-3:
                    # the beam ends on that octagon: 1 mm across its surface (along a beam
                    # almost parallel to an edge, 0.1 mm across is centimetres along)
                    assert min(abs(octagon_offset(px, py, p)) for p in others) < 1e-3, \
                        (scan.robot, math.degrees(a), got, robot)
                    on_robots += 1
                elif min(octagon_range(ox, oy, a, p, SCITOS_R + 2e-3) for p in others) > wall:
                    assert abs(got - wall) < 1e-3, (scan.robot, math.degrees(a), got, wall)
        assert on_robots > 300
        assert w.rays_at_robots > 0
    finally:
        w.close()


@pytest.mark.parametrize("rate", [10.0, 100.0])
def test_an_arc_ends_where_the_circle_says_at_any_step_rate(rate):
    """At full speed on a circle of radius 1 m (0.5 m/s, 0.5 rad/s, ramps over), 2 s at a
    10 Hz step (Stage's default) and at 100 Hz end on the circle, 1 rad further round, to
    1e-9: the step integrates the arc exactly, not by Euler (which misses by 1-5 cm) or a
    truncated series."""
    w = simple_world([RobotSpec(name="r", pose=(2.0, 1.2, 0.0), laser=EXACT, odometry=STILL)],
                     physics_rate=rate)
    try:
        drive(w, 0, (0.5, 0.0, 0.5), 1.0)
        assert w.view(0).velocity == pytest.approx((0.5, 0.0, 0.5))
        x0, y0, th0 = w.view(0).pose
        drive(w, 0, (0.5, 0.0, 0.5), 2.0)
        x1, y1, th1 = w.view(0).pose
    finally:
        w.close()
    assert th1 == pytest.approx(th0 + 1.0, abs=1e-9)
    assert x1 == pytest.approx(x0 + math.sin(th0 + 1.0) - math.sin(th0), abs=1e-9)
    assert y1 == pytest.approx(y0 - math.cos(th0 + 1.0) + math.cos(th0), abs=1e-9)


@pytest.mark.parametrize("grid", [True, False])
def test_lidar_loops_compiled_equal_their_plain_python(monkeypatch, grid):
    # the lidar's per-scan loops (sensors/lidar.py) are compiled by numba where it is
    # installed and run as plain Python where not: both must give the same scans, stamps
    # and ranges to the bit, with two beam geometries, a robot without a lidar, noise, a
    # lidar that stops moving (reuse), and the Bullet caster's cut rays (grid=False)
    from bullet_floor_sim.sim import grid_rays
    from bullet_floor_sim.sim.sensors import lidar

    kernels = ["_beams", "_laser_origins", "_unmoved", "_remember", "_rep117", "_take_due"]
    if not all(hasattr(getattr(lidar, k), "py_func") for k in kernels) or not grid_rays.available():
        pytest.skip("numba not installed")
    fan = LaserConfig(fov=180.0, resolution=0.5, noise_std=0.02)
    off = dataclasses.replace(EXACT, enabled=False)
    specs = [RobotSpec(name="a", pose=(1.0, 1.0, 0.3), laser=EXACT, odometry=STILL),
             RobotSpec(name="b", pose=(2.5, 2.0, 2.0), laser=off, odometry=STILL),
             RobotSpec(name="c", pose=(5.2, 3.0, -2.0), laser=fan, odometry=STILL)]

    def run():
        w = simple_world(specs, seed=5)
        if not grid:
            w._grid_rays = None
        try:
            scans = []
            for k in range(60):
                if k == 30:    # robot c stands still from here: its walls' distances reused
                    w.command(2, 0.0, 0.0, 0.0)
                elif k % 10 == 0:
                    for i in range(3):
                        w.command(i, 0.3, 0.0, 0.8 - 0.4 * i)
                scans += w.step(1)
            return scans
        finally:
            w.close()

    compiled = run()
    for k in kernels:
        monkeypatch.setattr(lidar, k, getattr(lidar, k).py_func)
    plain = run()
    assert [(s.robot, s.stamp_ns) for s in compiled] == [(s.robot, s.stamp_ns) for s in plain]
    assert {s.robot for s in compiled} == {0, 2} and len(compiled) >= 10
    for a, b in zip(compiled, plain):
        assert a.ranges.dtype == np.float32 and np.array_equal(a.ranges, b.ranges), a.robot
    assert any(np.isfinite(s.ranges).sum() > 100 for s in compiled)


def test_robots_spawned_and_deleted_while_running_keep_the_others_state():
    from bullet_floor_sim.sim.roster import add_robot, remove_robot, robot_index

    w = simple_world([RobotSpec(name="a", pose=(1.0, 1.0, 0.0), odometry=STILL),
                      RobotSpec(name="b", pose=(1.0, 3.0, 0.0), odometry=STILL)])
    try:
        drive(w, 0, (0.5, 0.0, 0.0), 2.0)
        a_pose, a_odom = w.view(0).pose, w.view(0).odom_pose
        i = add_robot(w, RobotSpec(name="c", pose=(3.0, 2.0, math.pi), laser=EXACT))
        assert i == 2 and w.n == 3 and [s.name for s in w.specs] == ["a", "b", "c"]
        assert w.view(0).pose == a_pose and w.view(0).odom_pose == a_odom
        scans = {s.robot: s for s in w.step(10)}
        assert set(scans) == {0, 1, 2}       # the new robot scans from its first period
        c = scans[2]                          # facing -x from (3, 2): the laser at x = 2.7
        k = int(round(-c.angle_min / c.angle_increment))
        assert float(c.ranges[k]) == pytest.approx(2.7 - 0.1, abs=1e-3)
        drive(w, 2, (0.4, 0.0, 0.0), 1.0)    # it drives: towards -x
        assert w.view(2).pose[0] < 2.9
        with pytest.raises(ConfigError, match="already in the world"):
            add_robot(w, RobotSpec(name="b", pose=(5.0, 3.0, 0.0)))
        with pytest.raises(ConfigError, match="would spawn overlapping robot 'c'"):
            add_robot(w, RobotSpec(name="d", pose=(w.view(2).pose[0] - 0.3, 2.0, 0.0)))
        assert w.n == 3                       # a refused spawn leaves nothing behind
        b_pose = w.view(1).pose
        remove_robot(w, robot_index(w, "a"))
        assert [s.name for s in w.specs] == ["b", "c"] and w.view(0).pose == b_pose
        assert len(w.bodies) == 2 and w.client.getNumBodies() == len(w.wall_bodies) + 2
        with pytest.raises(ConfigError, match=r"no robot 'a' \(robots: b, c\)"):
            robot_index(w, "a")
        drive(w, 0, (0.3, 0.0, 0.0), 1.0)   # b (now row 0) answers its commands
        assert w.view(0).pose[0] > b_pose[0] + 0.1
    finally:
        w.close()
