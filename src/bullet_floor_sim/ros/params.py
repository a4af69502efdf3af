"""Node parameters onto core config dataclasses."""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Dict, Optional, Sequence, TypeVar

import rospy

from ..errors import BulletFloorSimError, ConfigError
from ..sim.solidmap import MapHandling

__all__ = ["config_from_params", "check_at_least", "map_handling", "set_map_handling", "MAP_HANDLING_PARAM"]

# The world's map handling (world.yaml keys unknown and clean), set by the simulator before it
# publishes /map, so every node that plans or tracks on /map reads the map as the simulator
# built its walls.
MAP_HANDLING_PARAM = "/bullet_floor_sim/map_handling"

C = TypeVar("C")


def config_from_params(config: C, prefix: str = "~", names: Optional[Dict[str, str]] = None) -> C:
    """A copy of a config dataclass with every field that is set as a parameter
    ``<prefix><field>`` (``names`` maps a field to another parameter name) taken from it,
    converted to the field's current type; its ``check()`` run.

    Raises:
        ConfigError: a parameter that cannot be converted to its field's type (names it).
        the config's own error (a BulletFloorSimError naming the field) for a bad value.
    """
    names = names or {}
    changes: Dict[str, Any] = {}
    for f in dataclasses.fields(config):
        name = prefix + names.get(f.name, f.name)
        if rospy.has_param(name):
            changes[f.name] = _convert(name, rospy.get_param(name), getattr(config, f.name))
    config = dataclasses.replace(config, **changes)   # (a frozen dataclass too)
    check = getattr(config, "check", None)
    if check is not None:
        check()
    return config


def check_at_least(params: Any, node: str, names: Sequence[str], least: float = 0.0,
                   strict: bool = True, what: str = "") -> None:
    """Raise BulletFloorSimError ``<node>: ~<name> <value>: must be [<what> ]> <least>``
    (``>=`` unless ``strict``) for the first of ``names``, attributes of a node's parameter
    dataclass, that is not a finite number above (or at) ``least``."""
    for name in names:
        v = getattr(params, name)
        if not (math.isfinite(v) and (v > least if strict else v >= least)):
            raise BulletFloorSimError("%s: ~%s %r: must be %s%s %g" % (
                node, name, v, what + " " if what else "", ">" if strict else ">=", least))


def _convert(name: str, value: Any, current: Any) -> Any:
    """``value`` as the type of ``current`` (any value when that is None), taking what
    roslaunch makes of a ``<param value="...">`` (it types "1e3" and "inf" as strings, and
    a bool written 1 or 0 as an int), but never a word for a bool or a number ("false" is
    not True)."""
    if current is None:
        return value
    want = type(current)
    if want is bool:
        if isinstance(value, bool):
            return value
        word = str(value).strip().lower()
        if isinstance(value, (int, str)) and word in ("1", "0", "true", "false"):
            return word in ("1", "true")
        raise ConfigError("%s: expected true or false, got %r" % (name, value))
    if want in (int, float):
        number = value
        if isinstance(value, str):
            try:
                number = float(value)
            except ValueError:
                raise ConfigError("%s: expected a number, got %r" % (name, value)) from None
        if isinstance(number, bool) or not isinstance(number, (int, float)):
            raise ConfigError("%s: expected a number, got %r" % (name, value))
        if want is int and not float(number).is_integer():
            raise ConfigError("%s: expected a whole number, got %r" % (name, value))
        return want(number)
    if want is list and not isinstance(value, list):
        raise ConfigError("%s: expected a list, got %r" % (name, value))
    return want(value)


def set_map_handling(handling: MapHandling) -> None:
    """Publish the world's map handling on the parameter server (the simulator)."""
    rospy.set_param(MAP_HANDLING_PARAM, dataclasses.asdict(handling))


def map_handling() -> Optional[MapHandling]:
    """The world's map handling as the simulator set it, or None (no simulator of ours, e.g.
    a real robot or a bag: the planner's and tracker's own defaults apply).

    Raises:
        ConfigError: the parameter is set but not a valid handling (names the parameter).
    """
    doc = rospy.get_param(MAP_HANDLING_PARAM, None)
    if doc is None:
        return None
    names = {f.name for f in dataclasses.fields(MapHandling)}
    if not isinstance(doc, dict) or set(doc) - names:
        raise ConfigError("%s: expected a dict with keys %s, got %r"
                          % (MAP_HANDLING_PARAM, ", ".join(sorted(names)), doc))
    handling = MapHandling(**doc)
    handling.check(MAP_HANDLING_PARAM)
    return handling
