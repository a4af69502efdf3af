"""Node parameters onto core config dataclasses."""
from __future__ import annotations

import dataclasses
from typing import Any, Dict, Optional, Sequence, TypeVar

import rospy

from ..errors import BulletFloorSimError, ConfigError
from ..overrides import convert, with_changes
from ..sim.checks import check_integers, check_numbers
from ..sim.solidmap import MapHandling

__all__ = ["config_from_params", "check_params", "check_int_params", "map_handling",
           "set_map_handling", "MAP_HANDLING_PARAM"]

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
    for f in dataclasses.fields(config):   # type: ignore[arg-type]
        name = prefix + names.get(f.name, f.name)
        if rospy.has_param(name):
            changes[f.name] = convert(name, rospy.get_param(name), getattr(config, f.name))
    return with_changes(config, changes)   # (a frozen dataclass too)


def check_params(params: Any, node: str, names: Sequence[str], strict: bool = True,
                 least: Optional[float] = 0.0) -> None:
    """Raise BulletFloorSimError ``<node>: ~<name> must be a finite number > 0, got <value>``
    for the first of ``names``, attributes of a node's parameter dataclass, that is not a
    finite number above ``least`` (at it too unless ``strict``; any finite number when None):
    sim/checks.check_numbers with the ``~``."""
    check_numbers(params, names, node, least=least, strict=strict, error=BulletFloorSimError,
                  prefix="~")


def check_int_params(params: Any, node: str, names: Sequence[str], least: int = 1) -> None:
    """As :func:`check_params` for integer parameters: ``~<name> must be an integer >=
    <least>`` (sim/checks.check_integers with the ``~``)."""
    check_integers(params, names, node, least=least, error=BulletFloorSimError, prefix="~")


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
