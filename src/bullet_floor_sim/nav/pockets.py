"""Pockets: dead ends of the floor behind a passage too snug for a robot to turn in.

A *part* of the floor is a connected area (8-connected planning cells) where the wall
clearance is at least the robot's radius + ``snug``; the free cells between parts are
*passages*. A *pocket* is a part smaller than a disc of radius ``size`` with exactly one
passage into it from another part. Every free cell is labelled with a part: its own, the
nearest one, or, in a passage between a pocket and one other part (a doorway, not a narrow
corridor past several), that pocket. The observer's follower keeps out of pockets it is not
in when asked to (people/follow.py, ``FollowConfig.snug``).
"""
from __future__ import annotations

import math
from typing import Set, Tuple

import numpy as np

from .grid import PlanningGrid

__all__ = ["floor_pockets"]

_EIGHT = np.ones((3, 3), dtype=bool)


def floor_pockets(grid: PlanningGrid, snug: float, size: float
                  ) -> Tuple[np.ndarray, np.ndarray]:
    """(labels, pocket): every planning cell's part label (0 where the grid has no part)
    and, indexed by label, whether that part is a pocket (see the module doc)."""
    from scipy.ndimage import binary_dilation, distance_transform_edt, label

    free = np.isfinite(grid.cost)
    roomy = free & (grid.clearance >= grid.config.robot_radius + snug)
    raw = label(roomy, structure=_EIGHT)[0]
    area = np.bincount(raw.ravel()) * grid.resolution ** 2
    pocket = area < math.pi * size ** 2
    pocket[0] = False
    passages = label(free & ~roomy, structure=_EIGHT)[0]
    for p in np.nonzero(pocket)[0]:     # a dead end: one way in from another part
        ways = [q for q in _touching(raw, passages, int(p))
                if len(_touching(passages, raw, q)) > 1]
        pocket[p] = len(ways) == 1
    lab = raw
    if roomy.any():
        lab = raw[tuple(distance_transform_edt(raw == 0, return_distances=False,
                                               return_indices=True))]
    in_pocket = pocket[raw]
    if in_pocket.any():
        entries = np.unique(passages[binary_dilation(in_pocket, structure=_EIGHT)])
        doors = [e for e in entries[entries > 0] if len(_touching(passages, raw, int(e))) == 2]
        nearest = raw[tuple(distance_transform_edt(~in_pocket, return_distances=False,
                                                   return_indices=True))]
        lab = np.where(np.isin(passages, doors), nearest, lab)
    return lab, pocket


def _touching(labels: np.ndarray, others: np.ndarray, which: int) -> Set[int]:
    """The labels of ``others`` next to (8-connected) the cells labelled ``which``."""
    from scipy.ndimage import binary_dilation

    ring = binary_dilation(labels == which, structure=_EIGHT)
    found = np.unique(others[ring])
    return set(int(v) for v in found[found > 0])
