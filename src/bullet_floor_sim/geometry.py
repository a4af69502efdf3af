"""Plane geometry every package shares: angles wrapped into [-pi, pi), and poses (x, y, yaw)
composed and inverted (SE(2))."""
from __future__ import annotations

import math
from typing import Sequence, Tuple

import numpy as np

__all__ = ["wrap_angle", "wrap_angles", "compose", "inverse"]


def wrap_angle(a: float) -> float:
    """``a`` (radians) wrapped into [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def wrap_angles(a: np.ndarray) -> np.ndarray:
    """Element-wise :func:`wrap_angle` of an array."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def compose(a: Sequence[float], b: Sequence[float]) -> Tuple[float, float, float]:
    """Pose ``b`` (given in ``a``'s frame) in the frame ``a`` is given in."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (float(a[0] + c * b[0] - s * b[1]), float(a[1] + s * b[0] + c * b[1]),
            wrap_angle(float(a[2] + b[2])))


def inverse(a: Sequence[float]) -> Tuple[float, float, float]:
    """The transform that undoes ``a``: compose(a, inverse(a)) is the identity."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (float(-c * a[0] - s * a[1]), float(s * a[0] - c * a[1]), wrap_angle(-float(a[2])))
