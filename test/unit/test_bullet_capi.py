"""Ray tests through PyBullet's C API (sim/bullet_capi.py) against pybullet.rayTestBatch."""
from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import numpy as np
import pybullet
import pytest
from pybullet_utils import bullet_client

from bullet_floor_sim.sim import bullet_capi
from bullet_floor_sim.sim.config import LaserConfig, RobotSpec, load_world_config, resolve_world
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim.sensors import cast_rays
from bullet_floor_sim.sim.world import World

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "src")


@pytest.fixture(scope="module")
def room():
    cfg = load_world_config(resolve_world("simple", worlds_dir()))
    laser = LaserConfig(fov=360.0, resolution=1.0, noise_std=0.0)
    robots = [RobotSpec(name="a", pose=(1.5, 2.0, 0.0), laser=laser),
              RobotSpec(name="b", pose=(3.0, 2.0, 2.0), laser=laser)]
    w = World(dataclasses.replace(cfg, robots=robots), seed=3)
    yield w
    w.close()


def _rays(n=3000, seed=0):
    """Rays over and beyond the 6 m x 4 m room at laser height and at other heights: walls,
    the pillar, both robots, and misses."""
    rng = np.random.default_rng(seed)
    froms = np.column_stack((rng.uniform(-1.0, 7.0, n), rng.uniform(-1.0, 5.0, n),
                             rng.uniform(0.05, 1.5, n)))
    a = rng.uniform(-np.pi, np.pi, n)
    length = rng.uniform(0.1, 9.0, n)
    tos = froms + np.column_stack((np.cos(a) * length, np.sin(a) * length, np.zeros(n)))
    return froms, tos


def _reference(client, froms, tos, **kw):
    res = client.rayTestBatch(froms, tos, numThreads=1, **kw)
    return np.array([r[2] for r in res]), np.array([r[0] for r in res])


def test_the_c_api_is_in_use_here():
    # pybullet is pinned (3.2.7), whose module keeps the symbols: the fast path must be on
    assert bullet_capi.available(), bullet_capi.status()


@pytest.mark.parametrize("threads", [1, 2])
def test_c_api_gives_exactly_what_raytestbatch_gives(room, threads):
    froms, tos = _rays()
    api = bullet_capi._api()
    frac, ids, _ = api.cast(room.client._client, froms, tos, threads, None)
    ref_frac, ref_ids = _reference(room.client, froms, tos)
    # the sample covers every kind of outcome
    assert {-1, *room.wall_bodies, *room.bodies} <= set(ids.tolist())
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(frac, ref_frac)


def test_c_api_honours_the_collision_filter_mask(room):
    froms, tos = _rays(seed=1)
    group = 4
    room.client.setCollisionFilterGroupMask(room.bodies[1], -1, group, -1)
    try:
        frac, ids, _ = bullet_capi._api().cast(room.client._client, froms, tos, 1, group)
        ref_frac, ref_ids = _reference(room.client, froms, tos, collisionFilterMask=group)
    finally:
        room.client.setCollisionFilterGroupMask(room.bodies[1], -1, 1, -1)
    assert set(ids.tolist()) == {-1, room.bodies[1]}     # only that robot's base is seen
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(frac, ref_frac)


def test_cast_rays_matches_raytestbatch_over_several_calls(room):
    froms, tos = _rays(n=2500, seed=2)
    frac, ids = cast_rays(room.client, froms, tos, 1, chunk=1000)
    ref_frac, ref_ids = _reference(room.client, froms, tos)
    np.testing.assert_array_equal(ids, ref_ids)
    np.testing.assert_array_equal(frac, ref_frac)


def test_a_disconnected_client_is_refused_not_dereferenced():
    c = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
    cid = c._client
    c.disconnect()
    with pytest.raises(RuntimeError, match="client %d is not connected" % cid):
        bullet_capi._api().handle(cid)


def test_elf_symbols_reads_the_pybullet_module():
    found = bullet_capi.elf_symbols(pybullet.__file__, ["sPhysicsClients1",
                                                        "b3ConnectPhysicsDirect", "no_such_symbol"])
    assert set(found) == {"sPhysicsClients1", "b3ConnectPhysicsDirect"}
    assert all(v > 0 for v in found.values())


def test_elf_symbols_refuses_a_file_that_is_not_elf(tmp_path):
    f = tmp_path / "fake.so"
    f.write_bytes(b"not an ELF file at all, just some bytes" * 4)
    with pytest.raises(OSError, match="fake.so is not a 64-bit little-endian ELF file"):
        bullet_capi.elf_symbols(str(f), ["x"])


def test_switched_off_by_the_environment_falls_back_to_raytestbatch():
    code = (
        "import sys, numpy as np, pybullet\n"
        "from pybullet_utils import bullet_client\n"
        "from bullet_floor_sim.sim import bullet_capi\n"
        "from bullet_floor_sim.sim.sensors import cast_rays\n"
        "c = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)\n"
        "c.createMultiBody(0, c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[1, 1, 1]))\n"
        "f, i = cast_rays(c, np.array([[5.0, 0, 0]]), np.array([[-5.0, 0, 0]]), 1)\n"
        "print(bullet_capi.status()); print(round(float(f[0]), 6), int(i[0]))\n")
    env = dict(os.environ, BULLET_FLOOR_SIM_RAY_CAPI="0",
               PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert "rayTestBatch (C API switched off by BULLET_FLOOR_SIM_RAY_CAPI)" in out
    assert out[-1] == "0.4 0"      # the box's face at x = 1: 4 m of the 10 m ray
