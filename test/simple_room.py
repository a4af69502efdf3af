"""The known geometry of worlds/simple, shared by the unit and the integration tests.

Free interior x in [0.10, 5.90], y in [0.10, 3.90]; a pillar over x in [4.00, 4.50],
y in [1.00, 1.50]. Written out by hand (not read from the map) so the tests check the
simulator against an independent description.
"""
from __future__ import annotations

import math

BOXES = [  # (xmin, ymin, xmax, ymax) of every occupied region
    (0.0, 0.0, 6.0, 0.1), (0.0, 3.9, 6.0, 4.0), (0.0, 0.0, 0.1, 4.0), (5.9, 0.0, 6.0, 4.0),
    (4.0, 1.0, 4.5, 1.5),
]


def expected_range(ox, oy, angle, boxes=BOXES):
    """Distance from (ox, oy) along ``angle`` to the first box (slab method)."""
    dx, dy = math.cos(angle), math.sin(angle)
    best = math.inf
    for x0, y0, x1, y1 in boxes:
        tmin, tmax = -math.inf, math.inf
        for o, d, lo, hi in ((ox, dx, x0, x1), (oy, dy, y0, y1)):
            if abs(d) < 1e-12:
                if not lo <= o <= hi:
                    tmin, tmax = math.inf, -math.inf
                continue
            t0, t1 = (lo - o) / d, (hi - o) / d
            tmin, tmax = max(tmin, min(t0, t1)), min(tmax, max(t0, t1))
        if tmax >= max(tmin, 0.0):
            best = min(best, max(tmin, 0.0))
    return best
