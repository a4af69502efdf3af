"""``rois: auto`` in a world.yaml: the regions are the map's rooms, found automatically
(building/rooms.py), the ones the world's first robot can reach.

The ROI file is written once per map, map handling, robot start and ``rooms:`` section
(the segmentation's RoomConfig), to
``$ROS_HOME/bullet_floor_sim/rois/<world>_<digest>.yaml`` (beside the map cache; a temporary
directory when BULLET_FLOOR_SIM_CACHE is empty), and the world's ``rois`` points at it, so the
simulator, the ROI manager, the walker and the evaluation all read the same regions. Rooms
the robot's footprint cannot reach from the first robot's start (behind a door narrower than
it, a corner cut off by furniture) are left out; the file's first lines name them. It is an
ordinary SOMA ROI file: copy it, edit it in rviz, and point ``rois:`` at the copy.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import replace
from typing import List, Tuple

from ..data.rois import Roi
from ..roomconfig import RoomConfig
from ..sim.config import WorldConfig
from ..sim.floormap import load_map
from ..sim.mapcache import map_cache_dir, map_key

__all__ = ["auto_rois_path", "write_auto_rois", "AUTO"]

#: The world.yaml value that asks for rooms found automatically.
AUTO = "auto"
#: Changes when the segmentation or the filter does (old files are then not reused).
_VERSION = "rooms-1"


def auto_rois_path(cfg: WorldConfig) -> str:
    """The ROI file of a world whose ``rois`` is ``auto`` (written when missing)."""
    fmap = load_map(cfg.map_yaml)
    h = hashlib.sha1()
    h.update(map_key(fmap.grid, fmap.resolution, fmap.origin, cfg.map_handling).encode())
    h.update(repr((_VERSION, [r.pose[:2] for r in cfg.robots[:1]])).encode())
    if cfg.rooms != RoomConfig():   # the default keeps the digest files written before rooms:
        h.update(repr(cfg.rooms).encode())
    cache = map_cache_dir()
    base = os.path.join(os.path.dirname(cache), "rois") if cache else \
        os.path.join(tempfile.gettempdir(), "bullet_floor_sim_rois")
    path = os.path.join(base, "%s_%s.yaml" % (cfg.name or "world", h.hexdigest()[:16]))
    if not os.path.isfile(path):
        os.makedirs(base, exist_ok=True)
        write_auto_rois(cfg, path, fmap)
    return path


def write_auto_rois(cfg: WorldConfig, path: str, fmap=None) -> Tuple[int, List[str]]:
    """Write the rooms of ``cfg``'s map that its first robot reaches (with no robot, those on
    the part of the floor most rooms are on) to ``path`` as a SOMA ROI file, whatever
    ``cfg.rois`` says (``rosrun bullet_floor_sim rois auto``); return how many and one line
    per room left out."""
    kept, left_out = _reachable_rooms(replace(cfg, rois=None),
                                      fmap if fmap is not None else load_map(cfg.map_yaml))
    _write(kept, left_out, path)
    return len(kept), left_out


def _reachable_rooms(cfg: WorldConfig, fmap) -> Tuple[List[Roi], List[str]]:
    """The rooms of the map, renumbered 1..n, that a robot's footprint reaches from the first
    robot's start (from the part of the floor most rooms are on, without robots); and one line
    per room left out."""
    from ..people.walker import walkable_regions, region_label
    from . import Building, robot_footprint
    from .rooms import auto_rois

    rooms = auto_rois(fmap, cfg.map_handling, map_name=cfg.name or "world", rooms=cfg.rooms)
    b = Building(cfg, fmap)
    sampler = b.sampler(robot_footprint())
    if cfg.robots:
        start = sampler.component_at(*cfg.robots[0].pose[:2])
        comps = [set(int(v) for v in sampler.cells_in(r)[2]) for r in rooms]
        kept = [r for r, s in zip(rooms, comps) if start and start in s]
        left = ['room %s (%s): not reachable from %s for a %.2f m footprint'
                % (r.id, region_label(r), cfg.robots[0].name or "the robot",
                   2 * sampler.grid.config.robot_radius)
                for r, s in zip(rooms, comps) if not (start and start in s)]
    else:
        kept, left = walkable_regions(rooms, sampler)
    return [replace(r, id=str(i)) for i, r in enumerate(kept, 1)], left


def _write(rois: List[Roi], left_out: List[str], path: str) -> None:
    from .rooms import write_rois

    tmp = path + ".tmp%d" % os.getpid()
    write_rois(rois, tmp)
    with open(tmp) as f:
        body = f.read()
    head = ["# rois: auto (building/autorois.py): %d rooms found automatically" % len(rois)]
    head += ["# left out: %s" % line for line in left_out]
    with open(tmp, "w") as f:
        f.write("\n".join(head) + "\n" + body)
    os.replace(tmp, path)
