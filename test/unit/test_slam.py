"""The embedded mapper's pose estimate (mapping/slam.py), the pose algebra it uses
(geometry.py) and the built-map-against-world comparison (mapping/compare.py)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from bullet_floor_sim.geometry import compose, inverse
from bullet_floor_sim.mapping.compare import agreement, reachable, sample
from bullet_floor_sim.mapping.slam import ScanMatchingMapper, SlamConfig
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim.config import OdometryConfig, load_world_config, resolve_world
from bullet_floor_sim.sim.floormap import map_from_grid
from bullet_floor_sim.sim.world import World


def test_compose_and_inverse_by_hand():
    # (1, 2) facing +y; a point 1 m ahead of it and 0.5 m to its left is at (0.5, 3)
    assert compose((1.0, 2.0, math.pi / 2), (1.0, 0.5, 0.0)) == pytest.approx(
        (0.5, 3.0, math.pi / 2))
    a = (3.0, -1.0, 2.5)
    assert compose(a, inverse(a)) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert compose(inverse(a), a) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert compose((0.0, 0.0, 3.0), (0.0, 0.0, 0.5))[2] == pytest.approx(3.5 - 2 * math.pi)


def test_a_scan_is_taken_once_the_robot_moved_or_turned_enough():
    s = ScanMatchingMapper(SlamConfig(linear_update=0.25, angular_update=0.25))
    assert s.due((5.0, 5.0, 1.0))                      # the first scan always
    s.last = (0.0, 0.0, 0.5)
    assert not s.due((0.2, 0.1, 0.5))                  # 0.224 m
    assert s.due((0.2, 0.2, 0.5))                      # 0.283 m
    assert not s.due((0.0, 0.0, 0.74))
    assert s.due((0.0, 0.0, 0.76))
    assert s.due((0.0, 0.0, 0.5 - 0.26))


def _drive(match: bool):
    """robot1 of office, its odometry's heading drifting 0.01 rad per metre, drives 18 m
    east along the corridor, turns about and drives back to its start; the largest and the
    last error (m) of the estimated pose."""
    cfg = load_world_config(resolve_world("office", worlds_dir()))
    spec = dataclasses.replace(cfg.robots[0], odometry=OdometryConfig(drift_yaw=0.01))
    w = World(dataclasses.replace(cfg, robots=[spec]), seed=2)
    lp = w.models[0].laser_pose
    laser = (float(lp[0]), float(lp[1]), float(lp[3]))
    slam = ScanMatchingMapper(SlamConfig(match=match))
    errors = []
    try:
        for k in range(700):
            turning = 30.0 <= k * 0.1 < 35.3
            w.command(0, 0.0 if turning else 0.6, 0.0, 0.6 if turning else 0.0)
            for s in w.step(10):
                w.update_odometry()
                slam.add(compose(w.odometry.pose[0], laser), s.ranges, s.angle_min,
                         s.angle_increment, s.range_max)
            est = compose(tuple(w.spawn[0]), slam.in_map(w.odometry.pose[0]))
            errors.append(math.hypot(est[0] - w.pose[0, 0], est[1] - w.pose[0, 1]))
        assert w.pose[0, 0] < 4.0                      # it did come back
        return max(errors), errors[-1], slam
    finally:
        w.close()


def test_scan_matching_holds_the_pose_that_odometry_loses():
    """Odometry alone ends 3 m off (the heading drifts 0.3 rad over 36 m); matched against
    the map being built, the estimate stays within 0.3 m all the way."""
    worst_odom, last_odom, _ = _drive(False)
    worst, last, slam = _drive(True)
    assert last_odom > 1.5
    assert worst < 0.3 and last < 0.2
    assert slam.taken > 100
    # the correction is what turns odometry into the estimate
    assert slam.correction != (0.0, 0.0, 0.0)


def _grid(rows):
    return map_from_grid(np.array(rows[::-1], dtype=np.int8), 1.0, (0.0, 0.0, 0.0))


def test_agreement_by_hand():
    """A 4 x 5 world: a free 2 x 3 room inside walls. The built map has the room's top row
    free, its bottom row unknown but one cell that it reads occupied, and the top wall."""
    world = _grid([[100, 100, 100, 100, 100],
                   [100, 0, 0, 0, 100],
                   [100, 0, 0, 0, 100],
                   [100, 100, 100, 100, 100]])
    built = _grid([[-1, 100, 100, 100, -1],
                   [-1, 0, 0, 0, -1],
                   [-1, -1, 100, -1, -1],
                   [-1, -1, -1, -1, -1]])
    a = agreement(built, world)
    assert a.iou_free == pytest.approx(3 / 6)
    assert a.free_covered == pytest.approx(3 / 6)
    # faces: every wall cell touches the room (the corners diagonally): 14; the built map's
    # occupied cells: the 3 of the top wall and one free cell of the world
    assert a.iou_occupied == pytest.approx(3 / (14 + 1))
    # within a cell: all 4 built ones (the wrong one is beside the bottom wall); of the
    # faces, those within one cell (4-neighbourhood) of a built occupied cell: the top 5
    # and the bottom-middle one
    assert a.occupied_f1_1cell == pytest.approx((4 + 6) / (4 + 14))
    # the built map's frame one cell to the right in the world: each world cell reads the
    # built cell one to its left
    shifted = sample(built, world, (1.0, 0.0, 0.0))
    assert shifted[3].tolist() == [-1, -1, 100, 100, 100]


def test_reachable_is_the_component_of_the_point():
    world = _grid([[100, 100, 100, 100, 100],
                   [100, 0, 100, 0, 100],
                   [100, 100, 100, 100, 100]])
    assert reachable(world, 1.5, 1.5).sum() == 1
    with pytest.raises(ValueError, match="not a free cell"):
        reachable(world, 2.5, 1.5)


def test_compare_maps_scores_a_saved_map_placed_at_the_robots_start(tmp_path, capsys):
    """office's own map, re-framed at robot1's start (3, 10) as a SLAM node would save it:
    compare_maps finds it equal to the world's; placed at robot2's start instead, it is not.
    Bad input is one line and status 2."""
    from PIL import Image

    from bullet_floor_sim.mapping.save import save_map
    from bullet_floor_sim.ros.compare_maps import main
    from bullet_floor_sim.sim.floormap import load_map

    world = load_map(load_world_config(resolve_world("office", worlds_dir())).map_yaml)
    ox, oy, _ = world.origin
    save_map(map_from_grid(world.grid, world.resolution, (ox - 3.0, oy - 10.0, 0.0)),
             str(tmp_path / "built"))
    built = str(tmp_path / "built.yaml")
    assert main([built, "--world", "office", "--plot", str(tmp_path / "cmp.png")]) == 0
    out = capsys.readouterr().out
    assert "free IoU 1.000," in out and "(F1 within a cell 1.000), 100.0 %" in out
    # occupied IoU: every wall face found, but the map's own wall interiors and blocks of
    # furniture are occupied cells no lidar sees: faces / occupied cells
    from scipy.ndimage import binary_dilation

    free = reachable(world, 3.0, 10.0)
    walls = world.grid == 100
    faces = walls & binary_dilation(free, structure=np.ones((3, 3), dtype=bool))
    assert "occupied IoU %.3f" % (faces.sum() / walls.sum()) in out
    with Image.open(tmp_path / "cmp.png") as png:
        assert png.size[0] == 1980 and png.size[1] > 400
    assert main([built, "--world", "office", "--robot", "robot2"]) == 0
    free_iou = float(capsys.readouterr().out.split("free IoU ")[1].split(",")[0])
    assert free_iou < 0.5                   # turned about and 9 m off
    assert main([built, "--world", "office", "--robot", "robot9"]) == 2
    assert "--robot robot9: the world has robot1, robot2" in capsys.readouterr().err
    assert main([str(tmp_path / "missing.yaml"), "--world", "office"]) == 2
    assert "missing.yaml" in capsys.readouterr().err
