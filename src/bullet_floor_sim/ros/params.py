"""Node parameters onto core config dataclasses."""
from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

import rospy

__all__ = ["config_from_params"]

C = TypeVar("C")


def config_from_params(config: C, prefix: str = "~") -> C:
    """Override every field of a core config dataclass that is set as a parameter
    ``<prefix><field>`` (converted to the field's current type), then run its ``check()``.

    Raises:
        the config's own error (a BulletFloorSimError naming the field) for a bad value.
    """
    for f in dataclasses.fields(config):
        name = prefix + f.name
        if rospy.has_param(name):
            current: Any = getattr(config, f.name)
            value = rospy.get_param(name)
            setattr(config, f.name, type(current)(value) if current is not None else value)
    check = getattr(config, "check", None)
    if check is not None:
        check()
    return config
