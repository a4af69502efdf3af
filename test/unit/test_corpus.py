"""The corpus: maps from SLAM-corrected CARMEN logs (mapping/carmen.py), tools/corpus.py's
checked fetch and build, and ``rois: auto`` worlds (building/autorois.py)."""
from __future__ import annotations

import gzip
import hashlib
import importlib.util
import math
import os
import socket

import numpy as np
import pytest

from bullet_floor_sim.building.autorois import auto_rois_path
from bullet_floor_sim.errors import MapError
from bullet_floor_sim.mapping.carmen import flaser_angles, map_from_log, read_flaser
from bullet_floor_sim.paths import package_root
from bullet_floor_sim.people.markov import MarkovChain
from bullet_floor_sim.sim.config import load_world_config
from bullet_floor_sim.data.rois import load_rois

from test_building import two_rooms


def _corpus_tool():
    spec = importlib.util.spec_from_file_location(
        "corpus_tool", os.path.join(package_root(), "tools", "corpus.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _box_log(path, poses, n=181, half=(3.0, 2.0)):
    """A CARMEN log of a laser in a 6 x 4 m box (walls at x = +-3, y = +-2): exact ranges."""
    a0, da = flaser_angles(n)
    lines = []
    for x, y, th in poses:
        a = th + a0 + da * np.arange(n)
        c, s = np.cos(a), np.sin(a)
        with np.errstate(divide="ignore"):
            tx = np.where(c > 0, (half[0] - x) / c, np.where(c < 0, (-half[0] - x) / c, np.inf))
            ty = np.where(s > 0, (half[1] - y) / s, np.where(s < 0, (-half[1] - y) / s, np.inf))
        r = np.minimum(tx, ty)
        lines.append("FLASER %d %s %.4f %.4f %.4f 0 0 0 0.0 host 0.0"
                     % (n, " ".join("%.3f" % v for v in r), x, y, th))
    with gzip.open(path, "wt") as f:
        f.write("PARAM robot_front_laser_max 81.9\n" + "\n".join(lines) + "\nODOM 0 0 0 0 0 0\n")


def test_flaser_angles_span_180_degrees():
    assert flaser_angles(181) == pytest.approx((-math.pi / 2, math.radians(1.0)))
    assert flaser_angles(361) == pytest.approx((-math.pi / 2, math.radians(0.5)))
    assert flaser_angles(180) == pytest.approx((-math.pi / 2, math.radians(1.0)))


def test_a_corrected_log_of_a_box_maps_its_walls(tmp_path):
    path = str(tmp_path / "box-corrected.log.gz")
    _box_log(path, [(0.0, 0.0, th) for th in (0.0, math.pi / 2, math.pi, -math.pi / 2)]
             + [(1.0, 0.5, 0.3), (-1.0, -0.5, 2.5)])
    assert len(list(read_flaser(path))) == 6
    m = map_from_log(path, margin=0.5)
    g = np.asarray(m.grid)
    ys, xs = np.nonzero(g == 100)
    wx, wy = m.cell_to_world(xs, ys)
    # every occupied cell lies on a wall of the box (within a cell), and all four are there
    on = np.minimum.reduce([np.abs(np.abs(wx) - 3.0), np.abs(np.abs(wy) - 2.0)])
    assert np.all(on <= 0.08)
    for side in (wx > 2.9, wx < -2.9, wy > 1.9, wy < -1.9):
        assert side.sum() > 20
    # the inside is free, and nothing beyond the walls is known
    assert m.value_at(0.0, 0.0) == 0 and m.value_at(2.5, 1.5) == 0
    assert m.value_at(3.4, 0.0) == -1


def test_a_malformed_or_empty_log_is_one_line(tmp_path):
    bad = tmp_path / "bad.log"
    bad.write_text("FLASER 3 1.0 2.0\n")
    with pytest.raises(MapError, match=r"bad.log:1: malformed FLASER line"):
        map_from_log(str(bad))
    empty = tmp_path / "empty.log"
    empty.write_text("ODOM 0 0 0\n")
    with pytest.raises(MapError, match="no FLASER line"):
        map_from_log(str(empty))
    blind = tmp_path / "blind.log"
    blind.write_text("FLASER 3 81.9 81.9 81.9 0 0 0 0 0 0 0 h 0\n")
    with pytest.raises(MapError, match="blind.log: no beam returns within 40 m"):
        map_from_log(str(blind))


def _closed_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def test_the_corpus_tool_builds_a_checked_world_and_fails_clearly(tmp_path, capsys):
    tool = _corpus_tool()
    log = tmp_path / "src" / "box-corrected.log.gz"
    log.parent.mkdir()
    _box_log(str(log), [(x, 0.0, th) for x in (-3.0, 0.0, 3.0)
                        for th in np.linspace(-3.0, 3.0, 8)], half=(5.0, 2.0))
    sha = hashlib.sha256(log.read_bytes()).hexdigest()
    entry = {"name": "box", "kind": "lab", "format": "carmen", "about": "a box",
             "licence": "test", "files": [{"url": "http://127.0.0.1:%d/box-corrected.log.gz"
                                           % _closed_port(), "sha256": sha}]}
    out = tmp_path / "out"
    (out / ".downloads").mkdir(parents=True)
    files = tool.fetch(entry, str(out / ".downloads"), str(log.parent))
    world = tool.build(entry, files, str(out))
    cfg = load_world_config(world)          # rois: auto, two robots placed on the floor
    assert len(cfg.robots) == 2 and "a box" in (out / "box" / "SOURCE.md").read_text()
    (x1, y1), (x2, y2) = (r.pose[:2] for r in cfg.robots)
    assert 4.0 - 1e-9 <= math.hypot(x1 - x2, y1 - y2) <= 10.0
    # offline: the download fails with the building, the URL and what to do
    with pytest.raises(tool.CorpusError, match=r"box: cannot download http://127.0.0.1:\d+/"
                                               r"box-corrected.log.gz .*--from DIR"):
        tool.fetch(entry, str(tmp_path), None)
    # a file that is not the one the manifest names
    entry["files"][0]["sha256"] = "0" * 64
    with pytest.raises(tool.CorpusError, match="box: box-corrected.log.gz has sha256 " + sha):
        tool.fetch(entry, str(out / ".downloads"), str(log.parent))


def test_rois_auto_finds_the_two_rooms_joined_by_their_door(tmp_path, monkeypatch):
    monkeypatch.setenv("BULLET_FLOOR_SIM_CACHE", str(tmp_path / "cache"))
    path = two_rooms(tmp_path, door=1.0)
    text = open(path).read().replace("rois: rois.yaml", "rois: auto")
    open(path, "w").write(text)
    cfg = load_world_config(path)
    assert cfg.rois == auto_rois_path(cfg) and cfg.rois.startswith(str(tmp_path / "cache"))
    rois = load_rois(cfg.rois)
    assert sorted(r.id for r in rois) == ["1", "2"]
    xs = sorted(np.mean([v[0] for v in r.vertices]) for r in rois)
    assert xs[0] < 4.1 < xs[1]                     # one room each side of the wall
    assert MarkovChain.from_rois(rois).neighbours("1") == ["2"]
    # a door too narrow for the robot: the far room is left out, and the file says why
    narrow = tmp_path / "narrow"
    narrow.mkdir()
    p2 = two_rooms(narrow, door=0.6)
    text = open(p2).read().replace("rois: rois.yaml", "rois: auto")
    open(p2, "w").write(text)
    cfg2 = load_world_config(p2)
    assert len(load_rois(cfg2.rois)) == 1
    assert "# left out: room" in open(cfg2.rois).read()
