"""Calibration of the destination posterior: how sure it may be.

The planning-based posterior is sharp: a few metres of progress towards one region's points
give it odds of exp(beta x metres). When the walk is ambiguous (a corridor with doors on both
sides, a tracker's jittery position) it is often confidently wrong, and its log-loss grows
beyond the chain's prior's. Two standard remedies, applied in this order:

* ``temperature`` T >= 1 tempers the evidence: P(g) ∝ prior(g) · (likelihood(g))^(1/T),
  computed from the posterior as prior(g)^(1 - 1/T) · P(g)^(1/T) (T = 1: unchanged);
* ``prior_mix`` ε in [0, 1) mixes the prior back in: (1 - ε) P(g) + ε prior(g), over the
  regions the posterior left possible (so no region is ever certain, and the log-loss of a
  wrong answer among them is bounded by -ln(ε prior(truth)); a region the posterior ruled
  out, none of its goal points reachable, stays at 0).

Both are chosen by cross-validation across worlds (bench/calibrate_prediction.py); the
defaults, temperature 1 and prior_mix 0.05 (with beta 3), are what all 16 folds chose.
"""
from __future__ import annotations

import math
from typing import Dict, Mapping

__all__ = ["calibrate", "brier"]


def calibrate(probs: Mapping[str, float], prior: Mapping[str, float], temperature: float = 1.0,
              prior_mix: float = 0.0) -> Dict[str, float]:
    """The calibrated distribution (see the module doc); regions with probability 0 stay 0.

    Args:
        probs: the posterior (sums to 1).
        prior: the chain's row it was computed from (every region of ``probs``).
        temperature: T >= 1.
        prior_mix: ε in [0, 1).
    """
    live = [g for g, p in probs.items() if p > 0.0]
    if not live or (temperature == 1.0 and prior_mix == 0.0):
        return dict(probs)
    inv = 1.0 / temperature
    logw = {g: (1.0 - inv) * math.log(max(prior[g], 1e-300)) + inv * math.log(probs[g])
            for g in live}
    top = max(logw.values())
    w = {g: math.exp(v - top) for g, v in logw.items()}
    total = sum(w.values())
    prior_total = sum(prior[g] for g in live) or 1.0
    return {g: ((1.0 - prior_mix) * w[g] / total + prior_mix * prior[g] / prior_total)
            if g in w else 0.0 for g in probs}


def brier(probs: Mapping[str, float], truth: str) -> float:
    """The multi-class Brier score: sum over regions of (P(g) - [g = truth])^2 (0 best, 2
    worst)."""
    regions = set(probs) | {truth}
    return float(sum((probs.get(g, 0.0) - (1.0 if g == truth else 0.0)) ** 2 for g in regions))
