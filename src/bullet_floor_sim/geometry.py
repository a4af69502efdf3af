"""Plane geometry every package shares: angles wrapped into [-pi, pi)."""
from __future__ import annotations

import math

import numpy as np

__all__ = ["wrap_angle", "wrap_angles"]


def wrap_angle(a: float) -> float:
    """``a`` (radians) wrapped into [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def wrap_angles(a: np.ndarray) -> np.ndarray:
    """Element-wise :func:`wrap_angle` of an array."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi
