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

The world descriptions are in ``world_specs.py``; how their ROIs are shaped (so that the
seed project's adjacency rule gives exactly the door connectivity) and checked is in
``world_rois.py``.

The output is deterministic: running the script twice gives byte-identical
files. Usage::

    python tools/make_worlds.py [--out worlds]
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from world_rois import build_rois, rois_yaml_text, validate
from world_specs import (FREE, OCCUPIED, RESOLUTION, UNKNOWN, WALL_HEIGHT, Rect, World,
                         all_doors, all_worlds, door_gap, num, num_list, office_world)

__all__ = ["all_doors", "door_gap", "generate", "office_world", "rasterise", "world_files"]


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
            % (num(RESOLUTION), num_list(world.origin)))


def world_yaml_text(world: World) -> str:
    """Return the ``world.yaml`` file contents."""
    lines = [
        "# %s" % world.description,
        "map: map.yaml          # map_server map file, relative to this file",
        "wall_height: %s       # metres the walls are extruded to"
        % num(WALL_HEIGHT),
        "rois: rois.yaml        # relative path",
        "robots:",
    ]
    for robot in world.robots:
        lines += [
            "  - name: %s" % robot.name,
            "    model: %s   # urdf/<model>.urdf.xacro" % robot.model,
            "    pose: %s  # map frame, metres / radians"
            % num_list(robot.pose),
        ]
    return "\n".join(lines) + "\n"

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
