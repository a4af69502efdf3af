#!/usr/bin/env python3
"""The regions of interest of a generated world (tools/world_specs.py), and their checks.

ROI polygons are shaped so that the seed project's adjacency rule (two ROIs are connected
when a vertex of one lies within 0.2 m of a vertex of the other in both x and y) yields
exactly the door connectivity: every room polygon is inset from its walls and reaches
into each of its doors with a "tongue" whose two tip vertices lie on the door's wall
centre line; the region on the other side of the door has the very same two points on
its boundary. ``validate`` checks that, and that each ROI stays in free space.
"""
from __future__ import annotations

import math
from typing import List, NamedTuple, Sequence, Set, Tuple

from shapely.geometry import Polygon, box
from shapely.geometry.polygon import orient
from shapely.ops import unary_union

from world_specs import (ADJACENCY_TOLERANCE, GEOMETRY_EPS, ROI_CONFIG, ROI_INSET, Point, Rect,
                         Roi, Room, World, all_doors, door_gap, door_tips, num, tongue_rect)


# ---------------------------------------------------------------------------
# Regions of interest
# ---------------------------------------------------------------------------


class Region(NamedTuple):
    """An ROI before id assignment: a room or one segment of a room."""

    name: str
    kind: str
    room: str
    polygon: Polygon


def segment_ranges(room: Room) -> List[Tuple[str, float, float]]:
    """Return ``(name, x_lo, x_hi)`` of each ROI segment of a room.

    Outer ends are inset from the wall faces; inner ends are the split lines.

    Args:
        room: the room.

    Returns:
        One entry per segment, west to east; a single entry named after the
        room when it has no splits.
    """
    x0, _, x1, _ = room.rect
    bounds = [x0 + ROI_INSET] + list(room.splits) + [x1 - ROI_INSET]
    names = room.segment_names if room.splits else (room.name,)
    if len(names) != len(bounds) - 1:
        raise ValueError("room %s needs %d segment names"
                         % (room.name, len(bounds) - 1))
    return [(names[i], bounds[i], bounds[i + 1]) for i in range(len(names))]


def room_tips(world: World, room: Room) -> List[Tuple[Point, Point]]:
    """Return the door tips of every door touching a room (either side)."""
    tips = []
    for owner, door, far in all_doors(world):
        if room.name in (owner.name, far.name):
            tips.append(door_tips(owner, door))
    return tips


def region_for_tips(world: World, room: Room,
                    tips: Tuple[Point, Point]) -> str:
    """Return the name of the room region whose boundary holds door tips.

    Args:
        world: the world.
        room: a room touching the door.
        tips: the door's tip points.

    Returns:
        Name of the segment (or room) containing the tips.

    Raises:
        ValueError: if the tips are not strictly inside one segment.
    """
    del world  # the segment only depends on the room
    lo = min(tips[0][0], tips[1][0])
    hi = max(tips[0][0], tips[1][0])
    ranges = segment_ranges(room)
    for i, (name, x_lo, x_hi) in enumerate(ranges):
        # the end segments own doors in the room's end walls (tips on the wall centre line)
        x_lo = -math.inf if i == 0 else x_lo
        x_hi = math.inf if i == len(ranges) - 1 else x_hi
        if x_lo < lo and hi < x_hi:
            return name
    raise ValueError("door tips %r of %s straddle a segment boundary"
                     % (tips, room.name))


def grown(rect: Rect, margin: float) -> Polygon:
    """Return a rectangle grown by ``margin`` on every side."""
    return box(rect[0] - margin, rect[1] - margin,
               rect[2] + margin, rect[3] + margin)


def room_regions(world: World, room: Room) -> List[Region]:
    """Build the ROI polygons (one per segment) of a room.

    Args:
        world: the world.
        room: the room.

    Returns:
        The room's regions, west to east.

    Raises:
        ValueError: if a region is not a simple polygon without holes.
    """
    _, y0, _, y1 = room.rect
    tips = room_tips(world, room)
    cutouts = unary_union([grown(o, ROI_INSET) for o in world.obstacles]) \
        if world.rois_avoid_obstacles and world.obstacles else None
    regions = []
    for name, x_lo, x_hi in segment_ranges(room):
        parts = [box(x_lo, y0 + ROI_INSET, x_hi, y1 - ROI_INSET)]
        parts += [box(*tongue_rect(room, t)) for t in tips
                  if region_for_tips(world, room, t) == name]
        shape = unary_union(parts)
        if cutouts is not None:
            shape = shape.difference(cutouts)
        if shape.geom_type != "Polygon" or len(shape.interiors) != 0:
            raise ValueError("region %s is not a simple polygon" % name)
        regions.append(Region(name, room.kind, room.name, shape))
    return regions


def polygon_points(polygon: Polygon) -> Tuple[Point, ...]:
    """Return the normalised vertex list of a polygon.

    Vertices are counter-clockwise, rounded to 3 decimals, without repeated
    or collinear points, starting at the lowest (then leftmost) vertex, so
    the result does not depend on how shapely orders its output.

    Args:
        polygon: a polygon without holes.

    Returns:
        The vertices (the ring is not closed).
    """
    coords = list(orient(polygon, sign=1.0).exterior.coords)[:-1]
    points = [(round(x, 3) + 0.0, round(y, 3) + 0.0) for x, y in coords]
    points = _drop_redundant(points)
    start = min(range(len(points)), key=lambda i: (points[i][1], points[i][0]))
    return tuple(points[start:] + points[:start])


def _drop_redundant(points: List[Point]) -> List[Point]:
    """Remove duplicate and collinear vertices from a closed ring."""
    changed = True
    while changed:
        changed = False
        for i in range(len(points)):
            a, b, c = points[i - 1], points[i], points[(i + 1) % len(points)]
            cross = ((b[0] - a[0]) * (c[1] - b[1])
                     - (b[1] - a[1]) * (c[0] - b[0]))
            if b == a or abs(cross) < GEOMETRY_EPS:
                del points[i]
                changed = True
                break
    return points


def build_regions(world: World) -> List[Region]:
    """Return all regions of a world: segmented rooms first, then rooms."""
    ordered = sorted(world.rooms, key=lambda r: 0 if r.splits else 1)
    regions = []
    for room in ordered:
        regions += room_regions(world, room)
    return regions


def build_rois(world: World) -> List[Roi]:
    """Return the ROIs of a world with ids ``"1"``, ``"2"``, ..."""
    return [Roi(str(i + 1), r.kind, r.name, polygon_points(r.polygon))
            for i, r in enumerate(build_regions(world))]


def rois_yaml_text(world: World, rois: Sequence[Roi]) -> str:
    """Return the ``rois.yaml`` file contents."""
    lines = ["map_name: %s" % world.name,
             'config: "%s"' % ROI_CONFIG,
             "rois:"]
    for roi in rois:
        points = ", ".join("[%s, %s]" % (num(x), num(y))
                           for x, y in roi.points)
        lines.append('  - {id: "%s", type: %s, points: [%s]}  # %s'
                     % (roi.id, roi.kind, points, roi.name))
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------


def vertex_adjacent(a: Sequence[Point], b: Sequence[Point]) -> bool:
    """Apply the seed project's adjacency rule to two vertex lists."""
    return any(abs(p[0] - q[0]) <= ADJACENCY_TOLERANCE
               and abs(p[1] - q[1]) <= ADJACENCY_TOLERANCE
               for p in a for q in b)


def adjacency(rois: Sequence[Roi]) -> Set[Tuple[str, str]]:
    """Return the ROI graph of the vertex rule as sorted name pairs."""
    edges = set()
    for i, a in enumerate(rois):
        for b in rois[i + 1:]:
            if vertex_adjacent(a.points, b.points):
                edges.add(tuple(sorted((a.name, b.name))))
    return edges


def expected_adjacency(world: World) -> Set[Tuple[str, str]]:
    """Return the graph the ROIs must produce: doors plus segment chains."""
    edges = set()
    for owner, door, far in all_doors(world):
        tips = door_tips(owner, door)
        pair = (region_for_tips(world, owner, tips),
                region_for_tips(world, far, tips))
        edges.add(tuple(sorted(pair)))
    for room in world.rooms:
        names = [name for name, _, _ in segment_ranges(room)]
        for a, b in zip(names, names[1:]):
            edges.add(tuple(sorted((a, b))))
    return edges


def free_space(world: World) -> Polygon:
    """Return the free area of a world as a shapely geometry."""
    free = unary_union([box(*room.rect) for room in world.rooms]
                       + [box(*door_gap(room, door)) for room in world.rooms
                          for door in room.doors])
    if world.obstacles:
        free = free.difference(unary_union([box(*o) for o in world.obstacles]))
    return free


def validate(world: World, rois: Sequence[Roi]) -> None:
    """Check ROI shape, free-space containment and connectivity.

    Args:
        world: the world.
        rois: its ROIs as they will be written.

    Raises:
        ValueError: if any check fails.
    """
    free = free_space(world)
    for roi in rois:
        polygon = Polygon(roi.points)
        if not polygon.is_valid or len(roi.points) < 3:
            raise ValueError("ROI %s is not a valid polygon" % roi.name)
        outside = polygon.difference(free).area
        if world.rois_avoid_obstacles and outside > GEOMETRY_EPS:
            raise ValueError("ROI %s leaves free space (%.6f m^2)"
                             % (roi.name, outside))
    if adjacency(rois) != expected_adjacency(world):
        raise ValueError("ROI adjacency of %s differs from its doors: %r"
                         % (world.name,
                            adjacency(rois) ^ expected_adjacency(world)))
