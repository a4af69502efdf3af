"""What the world needs of a crowd it steps (people/crowd/crowd.py's Crowd implements it)."""
from __future__ import annotations

from typing import Any, Protocol

import numpy as np

__all__ = ["People"]


class People(Protocol):
    """What the world steps and its lidars see of a crowd (people/crowd/crowd.py's Crowd).

    Attributes:
        next_ns: sim time (ns) of its next step.
        body: its BodyConfig (the legs' ``leg_radius`` and ``leg_height``).
    """

    next_ns: int
    body: Any

    def advance(self, now_ns: int, robot_xy: np.ndarray, robot_radius: np.ndarray) -> None:
        """Step every person to ``now_ns``, the robots at ``robot_xy`` with bounding radii
        ``robot_radius`` in the way."""

    def legs(self) -> np.ndarray:
        """(K, 2) map-frame leg centres."""
