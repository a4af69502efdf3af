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


#: The Scitos A5 base at laser height: a regular octagon with a vertex ahead, circumradius
#: 0.32 m (urdf/meshes/scitos_a5_base.obj), grown by Bullet's 1 mm collision margin.
SCITOS_R = 0.321


def octagon(pose, r=SCITOS_R):
    """Corners of a Scitos base at ``pose`` (x, y, yaw), counter-clockwise."""
    x, y, yaw = pose
    return [(x + r * math.cos(yaw + k * math.pi / 4), y + r * math.sin(yaw + k * math.pi / 4))
            for k in range(8)]


def octagon_range(ox, oy, angle, pose, r=SCITOS_R):
    """Distance from (ox, oy) along ``angle`` into the octagon (inf when the beam misses)."""
    dx, dy = math.cos(angle), math.sin(angle)
    pts = octagon(pose, r)
    t_in, t_out = -math.inf, math.inf
    for (ax, ay), (bx, by) in zip(pts, pts[1:] + pts[:1]):
        nx, ny = by - ay, -(bx - ax)                 # outward: the corners run counter-clockwise
        nd = nx * dx + ny * dy
        num = nx * (ax - ox) + ny * (ay - oy)
        if abs(nd) < 1e-15:
            if num < 0:
                return math.inf
            continue
        t = num / nd
        if nd < 0:
            t_in = max(t_in, t)
        else:
            t_out = min(t_out, t)
    return max(t_in, 0.0) if t_in <= t_out and t_out > 0 else math.inf


def near_corner(px, py, poses, tol=2e-3, r=SCITOS_R):
    """Whether (px, py) lies within ``tol`` of a corner of one of the octagons."""
    return any(math.hypot(px - cx, py - cy) < tol for pose in poses for cx, cy in octagon(pose, r))


def octagon_offset(px, py, pose, r=SCITOS_R):
    """How far (px, py) lies outside the octagon's edges (negative inside): near the
    boundary, the distance to it."""
    pts = octagon(pose, r)
    out = -math.inf
    for (ax, ay), (bx, by) in zip(pts, pts[1:] + pts[:1]):
        e = math.hypot(bx - ax, by - ay)
        out = max(out, ((by - ay) * (px - ax) - (bx - ax) * (py - ay)) / e)
    return out
