"""bench/stage_bench.py's Stage side, without stageros: the .world it writes puts office's
map image where map_server puts the map and each robot at sim_bench's pose, and with no
stageros the bench says it skips."""
from __future__ import annotations

import math
import os
import re
import sys

import pytest

BENCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench")
sys.path.insert(0, BENCH)
import sim_bench  # noqa: E402
import stage_bench  # noqa: E402

from bullet_floor_sim.sim.floormap import load_map  # noqa: E402


def _numbers(text):
    return [float(v) for v in text.split()]


@pytest.mark.parametrize("rate, interval", [(100.0, 10), (10.0, 100)])
def test_the_stage_world_has_office_map_and_the_benchs_robots(tmp_path, rate, interval):
    path = stage_bench.stage_world(3, rate, str(tmp_path))
    text = open(path).read()
    world, _ = sim_bench._world(3)
    poses = [tuple(s.pose) for s in world.specs]
    fmap = load_map(world.config.map_yaml)
    world.close()
    assert re.search(r"^interval_sim %d$" % interval, text, re.M)
    h, w = fmap.grid.shape
    size, pose = re.search(r'floorplan \( name "map" bitmap "(?:[^"]+)" size \[([^\]]+)\] '
                           r'pose \[([^\]]+)\]', text).groups()
    sx, sy, _ = _numbers(size)
    assert (sx, sy) == pytest.approx((w * fmap.resolution, h * fmap.resolution))
    cx, cy = _numbers(pose)[:2]     # Stage places a model by its centre
    assert (cx - 0.5 * sx, cy - 0.5 * sy) == pytest.approx(fmap.origin[:2])
    assert os.path.getsize(os.path.join(str(tmp_path), "map.pgm")) == os.path.getsize(
        fmap.image_path)
    bots = re.findall(r'bot \( name "robot(\d+)" pose \[([^\]]+)\] \)', text)
    assert [int(k) for k, _ in bots] == [1, 2, 3]
    for (_, p), (x, y, yaw) in zip(bots, poses):
        bx, by, _, deg = _numbers(p)
        assert (bx, by) == pytest.approx((x, y), abs=1e-4)
        assert math.radians(deg) == pytest.approx(yaw, abs=1e-4)
    assert "samples 360" in text and "fov 360" in text and "range [ 0.1 30.0 ]" in text


def test_stage_topics_are_bare_for_one_robot_and_numbered_from_zero_for_more():
    subs, cmds = stage_bench.stage_topics(1)
    assert cmds == ["/cmd_vel"] and "/base_scan" in subs and "/tf" in subs
    subs, cmds = stage_bench.stage_topics(2)
    assert cmds == ["/robot_0/cmd_vel", "/robot_1/cmd_vel"]
    assert "/robot_1/base_pose_ground_truth" in subs


def test_without_stageros_the_bench_skips(monkeypatch, capsys):
    monkeypatch.delenv("STAGEROS", raising=False)
    monkeypatch.setenv("PATH", "/nonexistent")
    assert stage_bench.main([]) == 0
    assert capsys.readouterr().out.startswith("BENCH vs_stage skipped: stageros not found")


def test_the_10_hz_preset_is_stages_rates():
    params = dict(p.lstrip("_").split(":=") for p in stage_bench.rate_params(10.0))
    assert {k: float(v) for k, v in params.items()} == {
        "physics_rate": 10.0, "clock_rate": 10.0, "odom_rate": 10.0, "pose_rate": 10.0,
        "state_rate": 10.0, "people_rate": 10.0}
    assert stage_bench.rate_params(100.0) == []
