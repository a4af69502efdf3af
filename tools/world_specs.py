#!/usr/bin/env python3
"""The generated worlds described as data (tools/make_worlds.py writes their files).

Each world is rooms with their door gaps, obstacle rectangles and robots; the occupancy
map (make_worlds.py) and the regions of interest (world_rois.py) are both derived from
that one description, so they cannot drift apart. Also here: the geometry of a door
(its gap in the wall, its tips, the room on its far side) that both derivations use.
"""
from __future__ import annotations

import math
from typing import List, NamedTuple, Optional, Sequence, Tuple


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


def num(value: float) -> str:
    """Format a number as the shortest float literal (e.g. ``0.05``)."""
    return repr(float(value))


def num_list(values: Sequence[float]) -> str:
    """Format numbers as a YAML flow sequence."""
    return "[" + ", ".join(num(v) for v in values) + "]"

