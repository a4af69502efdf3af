"""Gymnasium environments on the simulator's core (no ROS).

Importing this package registers ``bullet_floor_sim/FloorNav-v0`` (env.FloorNavEnv: one
robot sent to a goal among people on a building's floor; its keywords are
config.NavEnvConfig's fields)::

    import gymnasium
    env = gymnasium.make("bullet_floor_sim.gym:bullet_floor_sim/FloorNav-v0",
                         world="office", people=5)
"""
from __future__ import annotations

import gymnasium

from .config import NavEnvConfig, RewardConfig
from .env import FloorNavEnv

__all__ = ["FloorNavEnv", "NavEnvConfig", "RewardConfig", "ENV_ID"]

#: The registered id of FloorNavEnv.
ENV_ID = "bullet_floor_sim/FloorNav-v0"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="bullet_floor_sim.gym.env:FloorNavEnv",
                       disable_env_checker=False)
