"""What a sensor is to the world: the :class:`Sensor` protocol and a :class:`SensorKind` entry."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, List, NamedTuple, Protocol, Sequence

if TYPE_CHECKING:
    from ..world import World

__all__ = ["NEVER", "Sensor", "SensorKind"]

#: ``next_ns`` of a sensor that is only read on demand.
NEVER = 2 ** 62


class Sensor(Protocol):
    """One kind of sensor on every robot of a world at once (row i is robot i).

    Attributes:
        next_ns: sim time (ns) of its next reading; ``World.step`` calls ``read`` when the
            clock reaches it (``NEVER``: read on demand only).
    """

    next_ns: int

    def read(self, world: "World") -> List[Any]:
        """Take the readings due at ``world.clock.now_ns`` and set ``next_ns``; what it
        returns (e.g. lidar Scans, each with a ``robot`` index) ``World.step`` returns."""

    def reset(self, world: "World", rows: Sequence[int]) -> None:
        """Robots ``rows`` were put back at their spawn poses (``World.reset``)."""

    def restart(self, now_ns: int) -> None:
        """The run starts afresh at ``now_ns`` (``World.restart``): readings first due one
        period on, as when built."""


class SensorKind(NamedTuple):
    """A registry entry (``sensors.SENSORS``).

    Attributes:
        config: the robot's world.yaml section: a frozen dataclass whose fields are the keys
            with their defaults, with ``validate(where)`` raising ConfigError.
        build: ``build(world, configs)`` -> the Sensor, from one config per robot (called
            once the world's robots are loaded).
    """

    config: type
    build: Callable[["World", list], Sensor]
