#!/usr/bin/env python3
"""Generate the bullet_floor_sim world files (maps, world descriptions, ROIs).

Three worlds are produced, each in its own directory below ``--out``:

* ``simple``: a 6 m x 4 m room with a single square pillar. Its geometry is
  exactly known, which makes it handy for tests.
* ``office``: an original 30 m x 20 m office floor with a straight corridor,
  nine offices, a lab and a kitchen.
* ``corridor``: two halls joined by a corridor 20 m long and 1.4 m wide, a robot at
  each end of it (the narrow-corridor passing tests).

Every world is described once, as data (rooms with their door gaps, obstacle
rectangles, robots). Both the occupancy map and the regions of interest (ROIs)
are derived from that single description, so they cannot drift apart.

For each world the script writes:

* ``map.pgm``: 8-bit binary PGM as ROS ``map_saver`` writes it
  (free = 254, occupied = 0, unknown = 205; image row 0 is the top of the map).
* ``map.yaml``: the ``map_server`` metadata file.
* ``world.yaml``: map, wall height, ROI file and robot spawn poses.
* ``rois.yaml``: one polygon per room (corridors split into segments).

ROI polygons are shaped so that the seed project's adjacency rule (two ROIs
are connected when a vertex of one lies within 0.2 m of a vertex of the other
in both x and y) yields exactly the door connectivity: every room polygon is
inset from its walls and reaches into each of its doors with a "tongue" whose
two tip vertices lie on the door's wall centre line; the region on the other
side of the door has the very same two points on its boundary.

The output is deterministic: running the script twice gives byte-identical
files. Usage::

    python tools/make_worlds.py [--out worlds]
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Dict, List, NamedTuple, Optional, Sequence, Set, Tuple

import numpy as np
from shapely.geometry import Polygon, box
from shapely.geometry.polygon import orient
from shapely.ops import unary_union

RESOLUTION = 0.05
"""Map resolution in metres per pixel."""
FREE = 254
OCCUPIED = 0
UNKNOWN = 205
WALL = 0.15
"""Thickness of the office walls in metres."""
ROI_INSET = 0.25
"""Distance between an ROI boundary and the wall faces / obstacles."""
TONGUE_MARGIN = 0.1
"""Distance between a tongue tip vertex and the door jamb."""
ADJACENCY_TOLERANCE = 0.2
"""Per-axis vertex distance of the seed project's adjacency rule."""
WALL_HEIGHT = 2.0
ROBOT_MODEL = "scitos_a5"
ROI_CONFIG = "1"
GEOMETRY_EPS = 1e-9

Rect = Tuple[float, float, float, float]
"""Axis-aligned rectangle ``(x_min, y_min, x_max, y_max)`` in metres."""
Point = Tuple[float, float]


class Door(NamedTuple):
    """A gap in one wall of a room.

    Attributes:
        side: wall of the owning room holding the gap
            (``north``, ``south``, ``east`` or ``west``).
        start: lower coordinate of the gap along the wall (x for north/south
            walls, y for east/west walls).
        end: upper coordinate of the gap along the wall.
    """

    side: str
    start: float
    end: float


class Room(NamedTuple):
    """A room of a world.

    Attributes:
        name: unique room name.
        kind: ROI type (``corridor``, ``office``, ``lab`` or ``kitchen``).
        rect: free interior of the room, i.e. bounded by the wall faces.
        doors: door gaps in the walls of this room. A door connects this
            room with the room on the other side of the wall.
        splits: x coordinates at which the room's ROI is cut into segments
            by full-width vertical lines (used for corridors).
        segment_names: one name per segment (``len(splits) + 1`` names);
            only used when ``splits`` is not empty.
    """

    name: str
    kind: str
    rect: Rect
    doors: Tuple[Door, ...] = ()
    splits: Tuple[float, ...] = ()
    segment_names: Tuple[str, ...] = ()


class Robot(NamedTuple):
    """A robot spawn entry of ``world.yaml``."""

    name: str
    pose: Tuple[float, float, float]
    model: str = ROBOT_MODEL


class World(NamedTuple):
    """Complete description of one world.

    Attributes:
        name: world (and directory) name, also the ROI ``map_name``.
        description: one-line description written to ``world.yaml``.
        size: map size in pixels ``(width, height)``.
        origin: map origin ``[x, y, yaw]`` as in ``map.yaml``.
        building: outer outline of the building. Cells outside of it are
            unknown. ``None`` means the building covers the whole map.
        rooms: the rooms; everything inside the building that is neither a
            room nor a door gap is wall.
        obstacles: occupied rectangles placed inside rooms (furniture,
            pillars).
        robots: robot spawn poses.
        rois_avoid_obstacles: cut obstacles (grown by ``ROI_INSET``) out of
            the room ROIs. Obstacles must then touch a wall, otherwise the
            ROI would get a hole.
    """

    name: str
    description: str
    size: Tuple[int, int]
    origin: Tuple[float, float, float]
    building: Optional[Rect]
    rooms: Tuple[Room, ...]
    obstacles: Tuple[Rect, ...]
    robots: Tuple[Robot, ...]
    rois_avoid_obstacles: bool


class Roi(NamedTuple):
    """A region of interest ready to be written to ``rois.yaml``."""

    id: str
    kind: str
    name: str
    points: Tuple[Point, ...]


# ---------------------------------------------------------------------------
# World data
# ---------------------------------------------------------------------------


def simple_world() -> World:
    """Return the small test room with exactly known geometry.

    Returns:
        The ``simple`` world: 6 m x 4 m, 0.10 m outer walls, one pillar.
    """
    room = Room("room", "office", (0.10, 0.10, 5.90, 3.90),
                splits=(3.0,), segment_names=("west", "east"))
    return World(
        name="simple",
        description="Simple 6 m x 4 m room with one square pillar "
                    "(exactly known geometry for tests)",
        size=(120, 80),
        origin=(0.0, 0.0, 0.0),
        building=None,
        rooms=(room,),
        obstacles=((4.00, 1.00, 4.50, 1.50),),
        robots=(Robot("robot1", (1.5, 2.0, 0.0)),
                Robot("robot2", (3.0, 3.0, math.pi))),
        rois_avoid_obstacles=False,
    )


def _office(name: str, rect: Rect, door: Door) -> Room:
    """Return an office room with a single door.

    Args:
        name: room name.
        rect: free interior of the office.
        door: its door into the corridor.

    Returns:
        The office room.
    """
    return Room(name, "office", rect, (door,))


def office_world() -> World:
    """Return the office floor.

    The building spans x 0.5..29.5 m, y 0.5..19.5 m (0.5 m unknown margin
    around it in a 30 m x 20 m map). A 2 m wide corridor runs along x at
    y 9.0..11.0; offices, the lab and the kitchen line both sides. All
    walls are 0.15 m thick; all coordinates lie on the 0.05 m grid.

    Returns:
        The ``office`` world.
    """
    south_y = (0.65, 8.85)   # rooms south of the corridor
    north_y = (11.15, 19.35)  # rooms north of the corridor
    rooms = (
        Room("corridor", "corridor", (0.65, 9.00, 29.35, 11.00),
             splits=(8.875, 17.175, 23.2),
             segment_names=("corridor_west", "corridor_centre_west",
                            "corridor_centre_east", "corridor_east")),
        _office("office_1", (0.65, south_y[0], 4.65, south_y[1]),
                Door("north", 2.05, 3.25)),
        _office("office_2", (4.80, south_y[0], 8.80, south_y[1]),
                Door("north", 6.20, 7.40)),
        _office("office_3", (8.95, south_y[0], 12.95, south_y[1]),
                Door("north", 10.35, 11.55)),
        _office("office_4", (13.10, south_y[0], 17.10, south_y[1]),
                Door("north", 14.50, 15.70)),
        Room("lab", "lab", (17.25, south_y[0], 29.35, south_y[1]),
             (Door("north", 20.00, 21.60),)),
        _office("office_5", (0.65, north_y[0], 4.65, north_y[1]),
                Door("south", 2.85, 4.05)),
        _office("office_6", (4.80, north_y[0], 8.80, north_y[1]),
                Door("south", 7.00, 8.20)),
        _office("office_7", (8.95, north_y[0], 12.95, north_y[1]),
                Door("south", 11.15, 12.35)),
        _office("office_8", (13.10, north_y[0], 17.10, north_y[1]),
                Door("south", 15.30, 16.50)),
        _office("office_9", (17.25, north_y[0], 21.25, north_y[1]),
                Door("south", 19.45, 20.65)),
        Room("kitchen", "kitchen", (21.40, north_y[0], 29.35, north_y[1]),
             (Door("south", 24.50, 25.70),)),
    )
    obstacles = (
        (20.00, 0.65, 20.80, 3.65),    # lab bench (peninsula, south wall)
        (24.00, 0.65, 24.80, 3.65),    # lab bench (peninsula, south wall)
        (28.55, 4.50, 29.35, 7.50),    # lab bench along the east wall
        (22.40, 18.70, 28.35, 19.35),  # kitchen counter along the north wall
        (26.35, 14.00, 29.35, 15.00),  # kitchen table (east wall)
    )
    return World(
        name="office",
        description="Office floor 30 m x 20 m: straight corridor, "
                    "9 offices, lab, kitchen",
        size=(600, 400),
        origin=(0.0, 0.0, 0.0),
        building=(0.5, 0.5, 29.5, 19.5),
        rooms=rooms,
        obstacles=obstacles,
        robots=(Robot("robot1", (3.0, 10.0, 0.0)),
                Robot("robot2", (12.0, 10.0, math.pi))),
        rois_avoid_obstacles=True,
    )


def corridor_world() -> World:
    """Return the narrow-corridor test world: two 4 m x 6 m halls joined by a corridor 20 m
    long and 1.4 m wide (room for one Scitos, not two side by side), a robot at each end of
    the corridor facing the other.

    Returns:
        The ``corridor`` world.
    """
    y0, y1 = 2.95, 4.35
    rooms = (
        Room("west_hall", "hall", (0.65, 0.65, 4.65, 6.65), (Door("east", y0, y1),)),
        Room("corridor", "corridor", (4.80, y0, 24.80, y1),
             splits=(9.80, 14.80, 19.80),
             segment_names=("corridor_1", "corridor_2", "corridor_3", "corridor_4")),
        Room("east_hall", "hall", (24.95, 0.65, 28.95, 6.65), (Door("west", y0, y1),)),
    )
    return World(
        name="corridor",
        description="Two halls joined by a corridor 20 m x 1.4 m, robots facing each "
                    "other in it (narrow-corridor passing tests)",
        size=(592, 146),
        origin=(0.0, 0.0, 0.0),
        building=(0.5, 0.5, 29.1, 6.8),
        rooms=rooms,
        obstacles=(),
        robots=(Robot("robot1", (6.0, 3.65, 0.0)),
                Robot("robot2", (23.6, 3.65, math.pi))),
        rois_avoid_obstacles=False,
    )


def all_worlds() -> Tuple[World, ...]:
    """Return every world generated by this script."""
    return (simple_world(), office_world(), corridor_world())


# ---------------------------------------------------------------------------
# Door geometry
# ---------------------------------------------------------------------------


def door_gap(room: Room, door: Door) -> Rect:
    """Return the rectangle of wall removed by a door.

    Args:
        room: room owning the door.
        door: the door.

    Returns:
        The gap rectangle (it spans the full wall thickness).
    """
    x0, y0, x1, y1 = room.rect
    if door.side == "north":
        return (door.start, y1, door.end, y1 + WALL)
    if door.side == "south":
        return (door.start, y0 - WALL, door.end, y0)
    if door.side == "east":
        return (x1, door.start, x1 + WALL, door.end)
    if door.side == "west":
        return (x0 - WALL, door.start, x0, door.end)
    raise ValueError("unknown door side %r" % door.side)


def door_tips(room: Room, door: Door) -> Tuple[Point, Point]:
    """Return the two tongue tip points of a door.

    They lie on the wall centre line, ``TONGUE_MARGIN`` inside the jambs.

    Args:
        room: room owning the door.
        door: the door.

    Returns:
        The two tip points, lower coordinate first.
    """
    gx0, gy0, gx1, gy1 = door_gap(room, door)
    lo, hi = door.start + TONGUE_MARGIN, door.end - TONGUE_MARGIN
    if door.side in ("north", "south"):
        yc = (gy0 + gy1) / 2.0
        return (lo, yc), (hi, yc)
    xc = (gx0 + gx1) / 2.0
    return (xc, lo), (xc, hi)


def door_far_room(world: World, room: Room, door: Door) -> Room:
    """Return the room on the other side of a door.

    Args:
        world: the world.
        room: room owning the door.
        door: the door.

    Returns:
        The unique room whose wall face touches the far side of the gap.

    Raises:
        ValueError: if no or several rooms touch the far side.
    """
    gx0, gy0, gx1, gy1 = door_gap(room, door)
    found = []
    for other in world.rooms:
        ox0, oy0, ox1, oy1 = other.rect
        if door.side == "north":
            hit = _close(oy0, gy1) and ox0 <= gx0 and gx1 <= ox1
        elif door.side == "south":
            hit = _close(oy1, gy0) and ox0 <= gx0 and gx1 <= ox1
        elif door.side == "east":
            hit = _close(ox0, gx1) and oy0 <= gy0 and gy1 <= oy1
        else:
            hit = _close(ox1, gx0) and oy0 <= gy0 and gy1 <= oy1
        if hit:
            found.append(other)
    if len(found) != 1:
        raise ValueError("door %r of %s leads into %d rooms"
                         % (door, room.name, len(found)))
    return found[0]


def _close(a: float, b: float) -> bool:
    """Return whether two coordinates are equal up to float noise."""
    return abs(a - b) < 1e-6


def tongue_rect(room: Room, tips: Tuple[Point, Point]) -> Rect:
    """Return the tongue reaching from a room's inset edge to door tips.

    Args:
        room: room the tongue belongs to (either side of the door).
        tips: tongue tip points on the wall centre line.

    Returns:
        Rectangle between the tips and the room's inset boundary.
    """
    (ax, ay), (bx, by) = tips
    x0, y0, x1, y1 = room.rect
    if _close(ay, by):  # horizontal wall: the tongue runs along y
        edge = y0 + ROI_INSET if ay < y0 else y1 - ROI_INSET
        return (ax, min(ay, edge), bx, max(ay, edge))
    edge = x0 + ROI_INSET if ax < x0 else x1 - ROI_INSET
    return (min(ax, edge), ay, max(ax, edge), by)


def all_doors(world: World) -> List[Tuple[Room, Door, Room]]:
    """Return every door as ``(owner room, door, room on the far side)``."""
    return [(room, door, door_far_room(world, room, door))
            for room in world.rooms for door in room.doors]


# ---------------------------------------------------------------------------
# Rasterisation and map files
# ---------------------------------------------------------------------------


def rect_cells(world: World, rect: Rect) -> Tuple[int, int, int, int]:
    """Convert a grid-aligned rectangle to cell index ranges.

    Args:
        world: the world (for resolution and origin).
        rect: rectangle in metres; its edges must lie on the grid.

    Returns:
        ``(col0, row0, col1, row1)`` half-open ranges, rows counted from the
        BOTTOM of the map (y up).

    Raises:
        ValueError: if an edge is not on the grid.
    """
    ox, oy = world.origin[0], world.origin[1]
    values = ((rect[0] - ox), (rect[1] - oy), (rect[2] - ox), (rect[3] - oy))
    cells = []
    for value in values:
        cell = value / RESOLUTION
        if abs(cell - round(cell)) > 1e-6:
            raise ValueError("rectangle %r is not grid aligned" % (rect,))
        cells.append(int(round(cell)))
    return cells[0], cells[1], cells[2], cells[3]


def fill_rect(grid: np.ndarray, world: World, rect: Rect, value: int) -> None:
    """Set all cells of a rectangle in a bottom-up grid to ``value``."""
    c0, r0, c1, r1 = rect_cells(world, rect)
    height, width = grid.shape
    grid[max(r0, 0):min(r1, height), max(c0, 0):min(c1, width)] = value


def rasterise(world: World) -> np.ndarray:
    """Rasterise a world into a map image.

    Args:
        world: the world.

    Returns:
        ``uint8`` array of shape ``(height, width)``; row 0 is the TOP of
        the map, as in ``map_server`` images.
    """
    width, height = world.size
    full = (world.origin[0], world.origin[1],
            world.origin[0] + width * RESOLUTION,
            world.origin[1] + height * RESOLUTION)
    background = UNKNOWN if world.building is not None else OCCUPIED
    grid = np.full((height, width), background, dtype=np.uint8)
    fill_rect(grid, world, world.building or full, OCCUPIED)
    for room in world.rooms:
        fill_rect(grid, world, room.rect, FREE)
        for door in room.doors:
            fill_rect(grid, world, door_gap(room, door), FREE)
    for obstacle in world.obstacles:
        fill_rect(grid, world, obstacle, OCCUPIED)
    return np.flipud(grid).copy()


def pgm_bytes(image: np.ndarray) -> bytes:
    """Encode an image as binary 8-bit PGM (P5), map_saver style header."""
    height, width = image.shape
    header = ("P5\n# CREATOR: make_worlds.py %.3f m/pix\n%d %d\n255\n"
              % (RESOLUTION, width, height))
    return header.encode("ascii") + image.astype(np.uint8).tobytes()


def map_yaml_text(world: World) -> str:
    """Return the ``map_server`` metadata file contents."""
    return ("image: map.pgm\n"
            "resolution: %s\n"
            "origin: %s\n"
            "negate: 0\n"
            "occupied_thresh: 0.65\n"
            "free_thresh: 0.196\n"
            "mode: trinary\n"
            % (_num(RESOLUTION), _num_list(world.origin)))


def world_yaml_text(world: World) -> str:
    """Return the ``world.yaml`` file contents."""
    lines = [
        "# %s" % world.description,
        "map: map.yaml          # map_server map file, relative to this file",
        "wall_height: %s       # metres the walls are extruded to"
        % _num(WALL_HEIGHT),
        "rois: rois.yaml        # relative path",
        "robots:",
    ]
    for robot in world.robots:
        lines += [
            "  - name: %s" % robot.name,
            "    model: %s   # urdf/<model>.urdf.xacro" % robot.model,
            "    pose: %s  # map frame, metres / radians"
            % _num_list(robot.pose),
        ]
    return "\n".join(lines) + "\n"


def _num(value: float) -> str:
    """Format a number as the shortest float literal (e.g. ``0.05``)."""
    return repr(float(value))


def _num_list(values: Sequence[float]) -> str:
    """Format numbers as a YAML flow sequence."""
    return "[" + ", ".join(_num(v) for v in values) + "]"


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
        points = ", ".join("[%s, %s]" % (_num(x), _num(y))
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


# ---------------------------------------------------------------------------
# Output
# ---------------------------------------------------------------------------


def world_files(world: World) -> Dict[str, bytes]:
    """Return the generated files of a world as ``{file name: contents}``."""
    rois = build_rois(world)
    validate(world, rois)
    return {
        "map.pgm": pgm_bytes(rasterise(world)),
        "map.yaml": map_yaml_text(world).encode("utf-8"),
        "world.yaml": world_yaml_text(world).encode("utf-8"),
        "rois.yaml": rois_yaml_text(world, rois).encode("utf-8"),
    }


def generate(out_dir: Path) -> List[Path]:
    """Write all worlds below ``out_dir``.

    Args:
        out_dir: output directory; one sub-directory per world is created.

    Returns:
        Paths of the written files.
    """
    written = []
    for world in all_worlds():
        world_dir = Path(out_dir) / world.name
        world_dir.mkdir(parents=True, exist_ok=True)
        for name, data in world_files(world).items():
            path = world_dir / name
            path.write_bytes(data)
            written.append(path)
    return written


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Command line entry point."""
    default_out = Path(__file__).resolve().parent.parent / "worlds"
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=default_out,
                        help="output directory (default: %(default)s)")
    args = parser.parse_args(argv)
    for path in generate(args.out):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
