"""The sensor registry: a new kind is one file (config section + model) and one SENSORS entry.

A toy kind, registered the way sim/sensors/__init__.py registers the shipped ones, must be read
from world.yaml with its defaults and checks, built by the world over every robot, read at its
own rate by ``World.step`` (its readings returned with the lidar's) and told of resets.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import List, NamedTuple

import pytest

from bullet_floor_sim.errors import ConfigError
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim import sensors
from bullet_floor_sim.sim.checks import check_numbers
from bullet_floor_sim.sim.config import load_world_config
from bullet_floor_sim.sim.sensors import NEVER, Scan, SensorKind
from bullet_floor_sim.sim.world import World


@dataclass(frozen=True)
class TickerConfig:
    rate: float = 4.0

    def validate(self, where: str) -> None:
        check_numbers(self, ("rate",), where)


class Tick(NamedTuple):
    robot: int
    stamp_ns: int
    x: float


class Ticker:
    """Every robot's x position at its rate (the slowest robot's schedule for all)."""

    def __init__(self, world, cfgs: List[TickerConfig]) -> None:
        self.period_ns = int(round(1e9 / min(c.rate for c in cfgs))) if cfgs else 0
        self.next_ns = world.clock.now_ns + self.period_ns if cfgs else NEVER
        self.resets: List[List[int]] = []

    def read(self, world) -> List[Tick]:
        self.next_ns += self.period_ns
        return [Tick(i, world.clock.now_ns, float(world.pose[i, 0])) for i in range(world.n)]

    def reset(self, world, rows) -> None:
        self.resets.append(list(rows))

    def restart(self, now_ns: int) -> None:
        self.next_ns = now_ns + self.period_ns if self.period_ns else NEVER


@pytest.fixture
def ticker(monkeypatch):
    monkeypatch.setitem(sensors.SENSORS, "ticker", SensorKind(TickerConfig, Ticker))


def _world_yaml(tmp_path, robot_extra: str) -> str:
    simple = os.path.join(worlds_dir(), "simple", "map.yaml")
    path = tmp_path / "world.yaml"
    path.write_text("map: %s\nrobots:\n  - name: a\n    pose: [1.5, 2.0, 0.0]\n%s"
                    "  - name: b\n    pose: [3.5, 2.0, 3.14]\n" % (simple, robot_extra))
    return str(path)


def test_a_registered_kind_is_read_from_world_yaml_with_defaults_and_checks(tmp_path, ticker):
    cfg = load_world_config(_world_yaml(tmp_path, "    ticker: {rate: 2.0}\n"))
    a, b = cfg.robots
    assert a.ticker == TickerConfig(rate=2.0) and a.sensors["ticker"] is a.ticker
    assert b.ticker == TickerConfig()          # no section: the defaults
    assert hash(a) != hash(b) and {a, a} == {a}
    with pytest.raises(ConfigError, match=r"robots\[0\] \(a\): ticker: rate must be a finite "
                                          r"number > 0, got -1\.0"):
        load_world_config(_world_yaml(tmp_path, "    ticker: {rate: -1.0}\n"))
    with pytest.raises(ConfigError, match=r"ticker: unknown key\(s\) 'hz'"):
        load_world_config(_world_yaml(tmp_path, "    ticker: {hz: 3}\n"))


def test_an_unregistered_section_is_refused(tmp_path):
    with pytest.raises(ConfigError, match=r"robots\[0\]: unknown key\(s\) 'ticker' "
                                          r"\(known: name, model, pose, drive, odometry, laser, "
                                          r"battery\)"):
        load_world_config(_world_yaml(tmp_path, "    ticker: {rate: 2.0}\n"))


def test_the_world_builds_reads_and_resets_a_registered_kind(tmp_path, ticker):
    cfg = load_world_config(_world_yaml(tmp_path, "    ticker: {rate: 2.0}\n"))
    world = World(cfg, physics_rate=100.0, seed=3)
    try:
        t0 = world.clock.now_ns
        world.command(0, 0.5)
        out = world.step(100)                           # 1 s: the ticker is due at 0.5 and 1.0 s
        ticks = [r for r in out if isinstance(r, Tick)]
        scans = [r for r in out if isinstance(r, Scan)]
        assert [(r.robot, r.stamp_ns - t0) for r in ticks] == [
            (0, 500_000_000), (1, 500_000_000), (0, 1_000_000_000), (1, 1_000_000_000)]
        # robot a drives at 0.5 m/s from rest (its acceleration limit first): it moved on
        assert 1.5 < ticks[0].x < ticks[2].x < 2.0 and ticks[1].x == ticks[3].x == 3.5
        assert len(scans) == 2 * 10                     # the lidars at 10 Hz all the while
        assert world.sensors["ticker"] is not None and math.isclose(
            world.clock.now_ns - t0, 1e9)
        world.reset([0])
        assert world.sensors["ticker"].resets == [[0]]
    finally:
        world.close()
