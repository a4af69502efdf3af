"""The room segmentation's parameters (building/rooms.py), and a world.yaml's ``rooms:``
section, which sets them for ``rois: auto``::

    rois: auto
    rooms: {max_door_width: 4.0}   # halls joined by openings up to 4 m wide stay apart

This module imports nothing heavy, so sim/config.py reads the section without the
segmentation's scipy, scikit-image and shapely.
"""
from __future__ import annotations

from dataclasses import dataclass

from .errors import ConfigError
from .sim.checks import check_numbers

__all__ = ["RoomConfig"]


@dataclass(frozen=True)
class RoomConfig:
    """Parameters of :func:`building.rooms.segment_rooms`, in metres and square metres (never
    cells).

    Attributes:
        furniture_area: m²; obstacle blobs (8-connected) up to this area, touching no other
            obstacle, are looked through when rooms are found (their cells get no label),
            unless they are wall pieces.
        wall_length: m; a blob at least this long (major axis) and four times longer than
            its mean width is a piece of wall (between two doors), never furniture.
        seed_height: m; a clearance maximum seeds a basin when it rises this much above every
            path to a higher one (h-maximum); smaller wobbles of a wall do not.
        door_ratio: a pass whose clearance is below this fraction of the smaller of the two
            sides' largest clearances separates them (a door); wider passes merge them.
        max_door_width: m; passes at least this wide always merge (open-plan openings).
        min_room_area: m²; smaller rooms join the neighbour with the longest common border.
    """

    furniture_area: float = 1.0
    wall_length: float = 1.0
    seed_height: float = 0.1
    door_ratio: float = 0.7
    max_door_width: float = 2.0
    min_room_area: float = 2.0

    def validate(self, where: str) -> None:
        """Raise ConfigError naming the first bad value (a world.yaml's ``rooms:``)."""
        check_numbers(self, ("wall_length", "seed_height"), where)
        check_numbers(self, ("furniture_area", "door_ratio", "max_door_width",
                             "min_room_area"), where, strict=False)
        if self.door_ratio > 1.0:
            raise ConfigError("%s: door_ratio must be at most 1 (a fraction of the rooms' "
                              "clearance), got %r" % (where, self.door_ratio))
