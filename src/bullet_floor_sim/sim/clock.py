"""Sim time: integer nanoseconds advanced in fixed steps, never 0."""
from __future__ import annotations

import math

from ..errors import ConfigError

__all__ = ["SimClock"]


class SimClock:
    """Sim time in integer nanoseconds, advanced in fixed steps; never 0.

    Args:
        rate: steps per second of sim time.
        start: sim time before the first step, seconds (> 0).
    """

    def __init__(self, rate: float = 100.0, start: float = 1.0) -> None:
        if not (rate > 0 and math.isfinite(rate)):
            raise ConfigError("physics_rate must be a positive number, got %r" % (rate,))
        if not start > 0:
            raise ConfigError("start time must be > 0 (ROS treats time 0 as 'no time'), got %r"
                              % (start,))
        self.step_ns = int(round(1e9 / rate))
        self.now_ns = int(round(start * 1e9))
        self.steps = 0

    @property
    def dt(self) -> float:
        """Step length, seconds."""
        return self.step_ns * 1e-9

    @property
    def now(self) -> float:
        """Sim time, seconds."""
        return self.now_ns * 1e-9

    def tick(self) -> None:
        """Advance by one step."""
        self.now_ns += self.step_ns
        self.steps += 1
