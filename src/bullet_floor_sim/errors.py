"""One exception hierarchy for bullet_floor_sim.

Every message names the input (file, robot, key) and the problem, on one line, so that a
user who sees it in a roslaunch log knows what to fix.
"""
from __future__ import annotations

__all__ = [
    "BulletFloorSimError",
    "ConfigError",
    "MapError",
    "RobotModelError",
    "CommandError",
]


class BulletFloorSimError(Exception):
    """Base class of every error this package raises on purpose."""


class ConfigError(BulletFloorSimError):
    """A world.yaml (or a section of it) is missing, malformed or has unknown keys."""


class MapError(BulletFloorSimError):
    """A map_server map (YAML + image) cannot be loaded as map_server would load it."""


class RobotModelError(BulletFloorSimError):
    """A robot model (xacro/URDF) cannot be expanded, parsed or loaded."""


class CommandError(BulletFloorSimError):
    """A velocity command is non-finite or absurd and was rejected before the physics."""
