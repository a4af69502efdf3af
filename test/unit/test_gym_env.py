"""The Gymnasium environment (bullet_floor_sim.gym) against gymnasium's own checker, known
geometry, commanded motion and rewards worked out by hand."""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")   # (Python >= 3.10: requirements/venv.txt)

from gymnasium.utils.env_checker import check_env  # noqa: E402

from bullet_floor_sim.errors import ConfigError  # noqa: E402
from bullet_floor_sim.gym import ENV_ID, FloorNavEnv, NavEnvConfig, RewardConfig  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from simple_room import expected_range  # noqa: E402


@pytest.fixture
def simple():
    """worlds/simple (a 6 x 4 m room with a pillar), no people."""
    env = FloorNavEnv(world="simple", people=0, goal_distance=(1.0, 3.0))
    yield env
    env.close()


def test_check_env_passes_with_people():
    env = FloorNavEnv(world="office", people=3, max_time=5.0)
    try:
        check_env(env, skip_render_check=True)
    finally:
        env.close()


def test_registered_id_makes_the_env_with_keywords():
    env = gymnasium.make(ENV_ID, world="simple", people=0)
    try:
        assert isinstance(env.unwrapped, FloorNavEnv)
        assert env.unwrapped.config.world == "simple"
        obs, _ = env.reset(seed=3)
        assert env.observation_space.contains(obs)
    finally:
        env.close()


def test_observation_is_the_scan_goal_and_velocity_of_known_geometry(simple):
    obs, info = simple.reset(seed=1, options={"start": (1.5, 2.0, 0.0), "goal": (3.5, 3.0)})
    assert info["pose"] == (1.5, 2.0, 0.0) and info["distance"] == pytest.approx(math.hypot(2, 1))
    np.testing.assert_allclose(obs["goal"], (2.0, 1.0), atol=1e-6)   # robot frame = map frame
    np.testing.assert_array_equal(obs["velocity"], (0.0, 0.0))
    lidar = simple.world.specs[0].laser     # 181 beams over 180 degrees, the laser 0.3 m ahead
    angles = math.radians(-90.0) + np.radians(lidar.resolution) * np.arange(lidar.beams)
    want = [expected_range(1.8, 2.0, a) for a in angles]
    np.testing.assert_allclose(obs["scan"], want, atol=0.05)   # 0.01 m noise
    obs, _, _, _, info = simple.step(np.array([0.0, 0.5], np.float32))    # a turn on the spot
    assert info["pose"][2] > 0.0
    w = min(0.5, simple.world.specs[0].drive.max_acc_angular * 0.1)   # the ramp's first 0.1 s
    assert obs["velocity"][1] == pytest.approx(w) and abs(obs["velocity"][0]) < 1e-9
    c, s = math.cos(info["pose"][2]), math.sin(info["pose"][2])
    np.testing.assert_allclose(obs["goal"], (c * 2.0 + s * 1.0, -s * 2.0 + c * 1.0), atol=1e-5)


def test_reward_sums_progress_time_and_arrival_by_hand(simple):
    r = RewardConfig()
    obs, info = simple.reset(seed=2, options={"start": (1.0, 1.0, 0.0), "goal": (2.5, 1.0)})
    d0, total, steps = info["distance"], 0.0, 0
    while True:
        obs, reward, terminated, truncated, info = simple.step(np.array([0.5, 0.0], np.float32))
        total += reward
        steps += 1
        if terminated or truncated:
            break
    assert terminated and info["is_success"] and info["collision"] == ""
    assert info["distance"] <= 0.3 and info["pose"][1] == pytest.approx(1.0, abs=1e-9)
    want = r.progress * (d0 - info["distance"]) + r.time * 0.1 * steps + r.arrival
    assert total == pytest.approx(want, abs=1e-9)
    # 1.2 m at 0.5 m/s after a 0.5 s ramp (1 m/s^2): 2.65 s, arrival is checked every 0.1 s
    assert steps == 27


def test_a_wall_ends_the_episode_with_the_collision_penalty(simple):
    simple.reset(seed=3, options={"start": (5.2, 2.0, 0.0), "goal": (2.0, 2.0)})
    total = 0.0
    for k in range(100):
        obs, reward, terminated, truncated, info = simple.step(np.array([0.8, 0.0], np.float32))
        total += reward
        if terminated:
            break
    assert terminated and info["collision"] == "wall" and not info["is_success"]
    assert info["pose"][0] < 5.9 - 0.3       # stopped by the wall at x = 5.9, not in it
    assert reward < -9.0 and obs["scan"][90] < 0.35


def test_personal_space_costs_by_depth_and_touching_a_person_ends_it():
    env = FloorNavEnv(world="office", people=1, max_time=10.0)
    try:
        _, info = env.reset(seed=4)
        x, y, yaw = info["pose"]
        crowd = env.world.people
        gap = 0.2                      # 0.25 m into the 0.45 m personal space
        crowd.pos[0] = (x + env.radius + crowd.radius[0] + gap, y)
        crowd.vel[0] = 0.0
        crowd.people[0].agent.resume_at = 1e9     # it stands (dwells) where it was put
        crowd.people[0].state = "dwell"
        _, reward, terminated, _, info = env.step(np.zeros(2, np.float32))
        assert not terminated
        assert info["intrusion"] == pytest.approx(0.45 - gap, abs=0.03)
        want = -0.1 * 0.1 - 1.0 * info["intrusion"] * 0.1   # standing: no progress
        assert reward == pytest.approx(want, abs=1e-9)
        crowd.pos[0] = (x + env.radius + crowd.radius[0] - 0.05, y)
        _, reward, terminated, _, info = env.step(np.zeros(2, np.float32))
        assert terminated and info["collision"] == "person" and reward < -10.0
    finally:
        env.close()


def test_the_same_seed_gives_the_same_episode():
    def episode(env, seed):
        obs, _ = env.reset(seed=seed)
        out = [obs["scan"].copy()]
        rng = np.random.default_rng(0)
        for _ in range(40):
            obs, reward, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            out += [obs["scan"].copy(), np.array([reward, *info["pose"]])]
            if term or trunc:
                break
        return out

    a, b = FloorNavEnv(world="office", people=4), FloorNavEnv(world="office", people=4)
    try:
        first = episode(a, 11)
        episode(a, 12)                 # another episode between
        again, other = episode(a, 11), episode(b, 11)
        assert len(first) == len(again) == len(other)
        for x, y, z in zip(first, again, other):
            np.testing.assert_array_equal(x, y)
            np.testing.assert_array_equal(x, z)
        assert a.world.people.n == 4
        assert not all(np.array_equal(x, y) for x, y in zip(first, episode(b, 13)))
    finally:
        a.close()
        b.close()


def test_async_vector_env_steps_as_the_single_envs_do():
    from gymnasium.vector import AsyncVectorEnv

    make = [lambda: FloorNavEnv(world="simple", people=0, goal_distance=(1.0, 3.0))] * 2
    vec = AsyncVectorEnv(make)
    single = FloorNavEnv(world="simple", people=0, goal_distance=(1.0, 3.0))
    try:
        obs, _ = vec.reset(seed=[5, 6])
        one, _ = single.reset(seed=6)
        np.testing.assert_array_equal(obs["scan"][1], one["scan"])
        act = np.array([[0.2, 0.1], [0.3, -0.2]], np.float32)
        for _ in range(5):
            obs, reward, term, trunc, _ = vec.step(act)
            one, r1, t1, u1, _ = single.step(act[1])
            if t1 or u1:
                break
            assert reward[1] == pytest.approx(r1)
            np.testing.assert_array_equal(obs["goal"][1], one["goal"])
    finally:
        vec.close()
        single.close()


def test_bad_settings_are_refused_with_the_setting_named():
    with pytest.raises(ConfigError, match="robot 5 is not one of the world's 2 robots"):
        FloorNavEnv(world="simple", robot=5, people=0)
    with pytest.raises(ConfigError, match="goal_distance"):
        FloorNavEnv(world="simple", people=0, goal_distance=(3.0, 1.0))
    with pytest.raises(ConfigError, match="gym: control_rate must be a finite number > 0, got 0.0"):
        FloorNavEnv(NavEnvConfig(world="simple", people=0, control_rate=0.0))
    with pytest.raises(ConfigError, match="reward: arrival must be a finite number"):
        FloorNavEnv(world="simple", people=0, reward=RewardConfig(arrival=float("nan")))
    env = FloorNavEnv(world="simple", people=0, goal_distance=(20.0, 30.0))
    try:
        with pytest.raises(ConfigError, match="no start and goal 20.0-30.0 m apart"):
            env.reset(seed=1)
    finally:
        env.close()
    with pytest.raises(ConfigError, match=r"an action holds 1\.00 s \(control_rate 1 Hz\), as "
                       "long as the drive's cmd_timeout"):
        FloorNavEnv(world="simple", people=0, control_rate=1.0)
    env = FloorNavEnv(world="simple", people=0)
    try:
        env.reset(seed=1)
        with pytest.raises(ValueError, match="not finite"):
            env.step(np.array([math.nan, 0.0], np.float32))
        with pytest.raises(ValueError, match=r"goal \(x, y\) must be 2 finite numbers"):
            env.reset(seed=1, options={"goal": (1.0, math.inf)})
        with pytest.raises(ValueError, match="unknown option"):
            env.reset(seed=1, options={"gaol": (1.0, 1.0)})
    finally:
        env.close()


def test_episode_seed_decides_the_people_even_where_the_world_file_seeds_them(tmp_path):
    import shutil
    world = tmp_path / "seeded"
    shutil.copytree(os.path.join(os.path.dirname(__file__), "..", "..", "worlds", "office"), world)
    with open(world / "world.yaml", "a") as f:
        f.write("people: {count: 3, seed: 123}\n")
    env = FloorNavEnv(world=str(world / "world.yaml"), people=3)
    try:
        def starts(seed):
            env.reset(seed=seed, options={"start": (3.0, 10.0, 0.0), "goal": (6.0, 10.0)})
            return env.world.people.pos.copy()
        a, b, a2 = starts(1), starts(2), starts(1)
        np.testing.assert_array_equal(a, a2)
        assert not np.array_equal(a, b)
    finally:
        env.close()
