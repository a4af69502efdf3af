"""A battery that discharges linearly in time (world.yaml ``battery:``)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Sequence, Tuple

import numpy as np

from ..checks import check_numbers
from ...errors import ConfigError
from .base import NEVER, SensorKind

__all__ = ["BatteryConfig", "Battery", "KIND"]


@dataclass(frozen=True)
class BatteryConfig:
    """A battery that discharges linearly in time (``discharge_per_hour``, fraction per hour)."""

    initial: float = 1.0
    discharge_per_hour: float = 0.1
    voltage_full: float = 28.8
    voltage_empty: float = 22.0
    capacity_ah: float = 60.0

    def validate(self, where: str) -> None:
        """Raise ConfigError if a value is out of range."""
        if not 0.0 <= self.initial <= 1.0:
            raise ConfigError("%s: initial must be in [0, 1], got %r" % (where, self.initial))
        check_numbers(self, ("discharge_per_hour",), where, strict=False)
        check_numbers(self, ("voltage_full", "voltage_empty", "capacity_ah"), where)


class Battery:
    """Linear discharge in time; computed on demand, so it costs nothing per step."""

    def __init__(self, cfgs: Sequence[BatteryConfig], now_ns: int) -> None:
        self.cfgs = list(cfgs)
        self.t0 = np.full(len(cfgs), now_ns, dtype=np.int64)
        self.next_ns = NEVER

    @classmethod
    def build(cls, world, cfgs: Sequence[BatteryConfig]) -> "Battery":
        """The batteries of ``world``'s robots, full from now."""
        return cls(cfgs, world.clock.now_ns)

    def read(self, world) -> List:
        """Nothing is due: ``state`` computes a battery's state when asked."""
        return []

    def state(self, robot: int, now_ns: int) -> Tuple[float, float, float]:
        """(percentage in [0, 1], voltage V, remaining charge Ah) of one robot at a time."""
        c = self.cfgs[robot]
        hours = (now_ns - int(self.t0[robot])) / 3.6e12
        pct = min(1.0, max(0.0, c.initial - c.discharge_per_hour * hours))
        volt = c.voltage_empty + (c.voltage_full - c.voltage_empty) * pct
        return pct, volt, c.capacity_ah * pct

    def restart(self, now_ns: int) -> None:
        """Nothing is ever due (the state is computed on demand)."""

    def reset(self, world, rows: Sequence[int]) -> None:
        """Recharge: start discharging again from ``initial``."""
        self.t0[list(rows)] = world.clock.now_ns


KIND = SensorKind(BatteryConfig, Battery.build)
