"""Walking together: a party of people follows its leader to the leader's goals and keeps
together by the group coherence force of Moussaid et al. (2010, "The walking behaviour of
pedestrian social groups and its impact on crowd dynamics", PLoS ONE 5(4): e10047).

The leader walks its chain (WalkerAgent); each other member walks to the leader's goal and
stops ``SPACING`` metres per rank short of it, so the party stands together. While they move,
a member farther than ``(n - 1) / 2`` metres from the party's centre of mass (n members) is
pulled towards it with ``strength`` (the attraction term ``q_A alpha U_i`` of Moussaid et al.,
alpha the threshold switch); the members' mutual repulsion is the crowd's person repulsion.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["SPACING", "COHERENCE", "coherence"]

#: A follower of rank k stops this many metres times k short of the leader's goal.
SPACING = 0.6
#: The coherence force's strength (m/s^2).
COHERENCE = 1.0


def coherence(pos: np.ndarray, parties: Sequence[np.ndarray], strength: float = COHERENCE
              ) -> np.ndarray:
    """(N, 2) group forces: each party's member farther than (n - 1) / 2 m from the party's
    centre of mass is pulled towards it with ``strength``.

    Args:
        pos: (N, 2) everyone's positions.
        parties: index arrays of the parties' members (everyone else feels nothing).
    """
    out = np.zeros_like(pos, dtype=float)
    for idx in parties:
        if len(idx) < 2:
            continue
        to = pos[idx].mean(axis=0) - pos[idx]
        dist = np.hypot(to[:, 0], to[:, 1])
        far = dist > 0.5 * (len(idx) - 1)
        out[idx[far]] = strength * to[far] / dist[far, None]
    return out
