"""What the world measures of its robots' bodies once, at load, with rays that see one robot.

The circle each body fits in (collision candidates), its radius at every laser's height (which
beams may reach it), its convex cross-section at those heights (beams clipped to it in numpy,
sections.py), where each beam leaves its own robot (Lidar.set_self_exit), and each lidar's
beam layout. ``world`` is the :class:`~.world.World` being built; rays see one robot through
:meth:`World.only` and the collision filter groups below.
"""
from __future__ import annotations

import math
from typing import Any, List, Optional, Sequence, Tuple

import numpy as np

from .sections import Section, check_section, measure_section, pad_sections
from .sensors import MAX_RAYS_PER_BATCH, Lidar, cast_rays

__all__ = ["ROBOT_GROUP", "ROBOT_MASK", "SELF_GROUP", "beam_table", "body_radius",
           "radius_at_lasers", "section_of", "section_radius", "sections", "self_exit"]

#: Collision filter group and mask of every robot body (PyBullet's for dynamic bodies, set
#: explicitly); SELF_GROUP briefly marks one robot for rays that must see only it.
ROBOT_GROUP, ROBOT_MASK, SELF_GROUP = 1, -1, 4
_SELF_EXIT_EPS = 1e-4


def section_radius(world: Any, i: int, heights: Sequence[float], far: float,
                    directions: int = 720) -> List[float]:
    """Radius about base_footprint of robot i's horizontal cross-section at each height:
    rays from ``far`` away toward the footprint that see only this robot (collision
    filter group), the farthest hit. Exact up to the angle between two rays."""
    p = world.client
    x, y, _ = world.pose[i]
    a = np.linspace(-np.pi, np.pi, directions, endpoint=False)
    u = np.column_stack((np.cos(a), np.sin(a), np.zeros_like(a)))
    out = []
    with world.only(i):
        for z in heights:
            c = np.array([x, y, z])
            frac, ids = cast_rays(p, c + u * far, np.broadcast_to(c, u.shape), 1,
                                  mask=SELF_GROUP)
            out.append(float(np.where(ids == world.bodies[i], far * (1.0 - frac), 0.0).max()))
    return out



def body_radius(world: Any, i: int, cache: dict) -> float:
    """Radius about base_footprint, in xy, of a circle containing the whole body: the
    largest cross-section radius every 5 cm of height (180 directions), plus 3 cm (what
    can lie between two rays or two heights; robot bodies are upright prisms and boxes,
    whose sections do not change between heights). The Scitos: 0.35 m, where the
    bounding box (PyBullet's is the box of the compound's local box) gave 0.46-0.65 m.
    Never more than the bounding box's. Once per model."""
    model = world.specs[i].model
    if model not in cache:
        p = world.client
        boxes = np.array([p.getAABB(world.bodies[i], j)
                          for j in range(-1, p.getNumJoints(world.bodies[i]))])
        lo, hi = boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)
        box = float(math.hypot(max(abs(lo[0] - world.pose[i, 0]), abs(hi[0] - world.pose[i, 0])),
                               max(abs(lo[1] - world.pose[i, 1]), abs(hi[1] - world.pose[i, 1]))))
        heights = np.append(np.arange(lo[2], hi[2], 0.05), hi[2]).tolist()
        r = max(section_radius(world, i, heights, 2.0 * box + 1.0, 180))
        cache[model] = min(box, r + 0.03)
    return cache[model]



def sections(world: Any) -> Tuple[np.ndarray, np.ndarray, np.ndarray, List[str]]:
    """For every (lidar robot, other robot) pair, the other's cross-section at the
    lidar's height as a checked convex polygon (sections.py), or -1 where there is none
    (its beams at that robot are cast in Bullet). Once per (model, laser height).

    Returns:
        (section index (N, N), the padded half-planes' normals and offsets (sections.py), one
        report line per (model, height) saying what was measured and how it compared with
        Bullet).
    """
    n = world.n
    index = np.full((n, n), -1, dtype=np.int64)
    found: list = []
    keys: dict = {}
    report: List[str] = []
    for i in world.lidar.robots.tolist():
        z = float(world.lidar.offsets[i, 2])
        for j in range(n):
            if j == i:
                continue
            key = (world.specs[j].model, z)
            if key not in keys:
                sec, line = section_of(world, j, z)
                keys[key] = -1 if sec is None else len(found)
                if sec is not None:
                    found.append(sec)
                report.append("model %r at %.3f m: %s"
                                            % (world.specs[j].model, z, line))
            index[i, j] = keys[key]
    normals, offsets = pad_sections(found)
    return index, normals, offsets, report



def section_of(world: Any, j: int, z: float) -> Tuple[Optional[Section], str]:
    """Robot j's cross-section at height z, measured with rays that see only robot j
    (all its links), at its pose now; None when it is not a convex polygon Bullet agrees
    with. Returns (section, a line for ``sections_report``)."""
    p = world.client
    b = world.bodies[j]
    x, y, yaw = (float(v) for v in world.pose[j])
    c, s = math.cos(yaw), math.sin(yaw)
    world._set_body(j, world.pose[j])

    def probe(starts: np.ndarray, dirs: np.ndarray, length: float):
        m = len(starts)
        froms = np.column_stack((x + c * starts[:, 0] - s * starts[:, 1],
                                 y + s * starts[:, 0] + c * starts[:, 1], np.full(m, z)))
        wd = np.column_stack((c * dirs[:, 0] - s * dirs[:, 1], s * dirs[:, 0] + c * dirs[:, 1]))
        tos = froms.copy()
        tos[:, :2] += wd * length
        dist = np.full(m, np.inf)
        normal = np.zeros((m, 2))
        for a in range(0, m, MAX_RAYS_PER_BATCH):
            e = min(m, a + MAX_RAYS_PER_BATCH)
            res = p.rayTestBatch(froms[a:e], tos[a:e], numThreads=1,
                                 collisionFilterMask=SELF_GROUP)
            for k, r in enumerate(res, a):
                if r[0] == b:
                    nx, ny = r[4][0], r[4][1]
                    h = math.hypot(nx, ny)
                    if h > 1e-9:
                        dist[k] = r[2] * length
                        normal[k] = ((c * nx + s * ny) / h, (c * ny - s * nx) / h)
        return dist, normal

    with world.only(j, all_links=True):   # the section is the whole robot's
        reach = float(world.radius[j])
        sec = measure_section(probe, reach)
        if sec is None:
            return None, "no convex section found: beams cast in Bullet"
        ok, summary = check_section(sec, probe, reach)
    if not ok:
        return None, "section disagrees with Bullet (%s): beams cast in Bullet" % summary
    return sec, "convex section, %s" % summary



def radius_at_lasers(world: Any) -> np.ndarray:
    """(N, N): row i, the radius about base_footprint of every robot's cross-section at
    robot i's laser height (:func:`section_radius`, 720 directions) plus 2 cm (what can lie
    between two rays). Lidar rays are horizontal, so this is the circle that
    robot_beams.candidates may use: 0.34 m for the Scitos at its laser height."""
    n = world.n
    heights = sorted({float(world.lidar.offsets[i, 2]) for i in range(n)})
    cache: dict = {}
    table = {}
    for j in range(n):
        key = world.specs[j].model
        if key not in cache:
            cache[key] = dict(zip(heights, section_radius(world,
                j, heights, 2.0 * float(world.radius[j]) + 1.0)))
        for z in heights:
            table[j, z] = cache[key][z] + 0.02
    return np.array([[table[j, float(world.lidar.offsets[i, 2])] for j in range(n)]
                     for i in range(n)]).reshape(n, n)



def beam_table(lidar: Lidar) -> np.ndarray:
    """Per robot: (first beam angle, increment, beams, beams in a full circle); the last is
    0 when 2 pi is not a whole number of increments (then every beam is a candidate)."""
    rows = []
    for i, a in enumerate(lidar.angles):
        inc = math.radians(lidar.cfgs[i].resolution)
        circle = 2.0 * math.pi / inc
        if len(a) and abs(circle - round(circle)) < 1e-6 and round(circle) >= len(a):
            rows.append((float(a[0]), inc, len(a), round(circle)))
        else:   # circle 0: every beam is a candidate (exact, just slower)
            rows.append((float(a[0]) if len(a) else 0.0, inc, len(a), 0))
    return np.array(rows, dtype=float).reshape(len(rows), 4)



def self_exit(world: Any) -> None:
    """Where each beam of each lidar leaves its own robot's body (see Lidar.set_self_exit).

    A ray starting inside a convex shape may or may not report a hit at distance 0
    (Bullet leaves it undefined): with the laser inside the base hull, half of the beams of
    a robot heading about +-90 degrees came back as -inf. Measured once per robot from
    outside, with rays that only see that robot (collision filter groups), at the spawn
    pose: the beams are fixed in the robot frame. Once per model and lidar geometry.
    """
    p = world.client
    done: dict = {}
    for i in world.lidar.robots.tolist():
        c = world.specs[i].laser
        key = (world.specs[i].model, c.fov, c.resolution, c.beams)
        if key in done:
            world.lidar.set_self_exit(i, done[key])
            continue
        plan = world.lidar.plan([i], world.pose, (-np.inf, -np.inf, np.inf, np.inf))
        reach = 2.0 * float(world.radius[i]) + 1.0
        outside = plan.origins.copy()
        outside[:, :2] += plan.dirs * reach
        with world.only(i):
            frac, ids = cast_rays(p, outside, plan.origins, 1, mask=SELF_GROUP)
        exit_dist = np.where(ids == world.bodies[i], reach * (1.0 - frac) + _SELF_EXIT_EPS, 0.0)
        done[key] = exit_dist
        world.lidar.set_self_exit(i, exit_dist)
