"""World files (``worlds/<name>/world.yaml``) and per-robot settings, with defaults.

Each section reads its own keys, fills defaults and rejects unknown keys with a message that
names the file, the section and the key (as flatland's EnsureAccessedAllKeys does)::

    map: map.yaml            # map_server map, relative to world.yaml
    wall_height: 2.0
    rois: rois.yaml          # or auto: the map's rooms, found automatically (building/autorois.py)
    unknown: wall            # wall | free: what unknown map cells are (sim/solidmap.py)
    clean: {close_gaps: 0.15, speckle: 0.005, unknown_slivers: 0.3}   # sim/solidmap.py
    rooms: {max_door_width: 2.0, ...}   # with rois: auto, the segmentation's RoomConfig
    robots:
      - name: robot1
        model: scitos_a5     # urdf/<model>.urdf.xacro
        pose: [x, y, yaw]
        drive: {type: diff, max_linear: 0.8, ...}       # DriveConfig
        laser: {range_max: 30.0, ...}                     # sensors/lidar.py LaserConfig
        odometry: {noise_trans: 0.005, ...}               # sensors/odometry.py
        battery: {discharge_per_hour: 0.1, ...}           # sensors/battery.py
    people: {count: 20, dwell: [5, 20], speed: [0.8, 1.5], ...}  # people/crowd/config.py

A robot's sensor sections are those of the sensor registry (``sensors.SENSORS``).
"""
from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field, replace
from typing import Any, Dict, List, Optional, Tuple

from ..errors import ConfigError
from ..people.crowd.config import PeopleConfig, parse_people
from ..roomconfig import RoomConfig
from .checks import (finite_positive as _finite_positive, is_number as _is_number,
                     check_numbers as _check_numbers, reject_unknown as _reject_unknown,
                     section as _section)
from .sensors import SENSORS, BatteryConfig, LaserConfig, OdometryConfig
from .solidmap import MapHandling
from ..yamlio import read_yaml

__all__ = [
    "DriveConfig",
    "LaserConfig",
    "OdometryConfig",
    "BatteryConfig",
    "RobotSpec",
    "WorldConfig",
    "load_world_config",
    "resolve_world",
    "world_label",
]



_NAME_RE = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)?$")


@dataclass(frozen=True)
class DriveConfig:
    """Drive kinematics and limits.

    ``type`` is ``diff`` (v, w) or ``omni`` (vx, vy, w, as MORSE's MotionXYW). Velocities are
    clamped to ``max_*``; accelerations to ``max_acc_*``. After ``cmd_timeout`` seconds of sim
    time without a command the watchdog sets the target to zero. A command component larger
    than ``absurd_factor`` times its limit is rejected, not clamped.
    """

    type: str = "diff"
    max_linear: float = 0.8
    max_lateral: float = 0.5
    max_angular: float = 1.5
    max_acc_linear: float = 1.0
    max_acc_lateral: float = 1.0
    max_acc_angular: float = 3.0
    cmd_timeout: float = 0.5
    absurd_factor: float = 10.0

    def validate(self, where: str) -> None:
        """Raise ConfigError if a value is out of range."""
        from .robot import DRIVES  # the registry lives with the drives

        if self.type not in DRIVES:
            raise ConfigError("%s: drive type %r unknown, expected one of %s"
                              % (where, self.type, ", ".join(sorted(DRIVES))))
        _check_numbers(self, ("max_linear", "max_lateral", "max_angular", "max_acc_linear",
                              "max_acc_lateral", "max_acc_angular", "cmd_timeout",
                              "absurd_factor"), where)


@dataclass(frozen=True, init=False)
class RobotSpec:
    """One robot of a world: name (namespace and frame prefix), model, spawn pose, drive, and
    one config per sensor kind of the registry, as ``spec.sensors[kind]`` and ``spec.<kind>``
    (``RobotSpec(name, laser=LaserConfig(...))``; a kind not given gets its defaults)."""

    name: str
    model: str = "scitos_a5"
    pose: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    drive: DriveConfig = field(default_factory=DriveConfig)
    sensors: Dict[str, Any] = field(default_factory=dict)

    def __init__(self, name: str, model: str = "scitos_a5",
                 pose: Tuple[float, float, float] = (0.0, 0.0, 0.0),
                 drive: Optional[DriveConfig] = None, sensors: Optional[Dict[str, Any]] = None,
                 **kinds: Any) -> None:
        given = dict(sensors or {}, **kinds)
        unknown = sorted(set(given) - set(SENSORS))
        if unknown:
            raise TypeError("RobotSpec: no sensor kind(s) %s (known: %s)"
                            % (", ".join(unknown), ", ".join(SENSORS)))
        for k, v in (("name", name), ("model", model), ("pose", tuple(pose)),
                     ("drive", drive if drive is not None else DriveConfig()),
                     ("sensors", {k: given.get(k) or kind.config()
                                  for k, kind in SENSORS.items()})):
            object.__setattr__(self, k, v)

    def __hash__(self) -> int:
        return hash((self.name, self.model, self.pose, self.drive,
                     tuple(sorted(self.sensors.items()))))

    def __getattr__(self, name: str) -> Any:
        sensors = self.__dict__.get("sensors", {})
        if name in sensors:
            return sensors[name]
        raise AttributeError("RobotSpec has no attribute or sensor kind %r" % name)

    @property
    def prefix(self) -> str:
        """Frame prefix: ``name/``, or empty for a robot with an empty name."""
        return self.name + "/" if self.name else ""


@dataclass(frozen=True)
class WorldConfig:
    """A parsed world.yaml; paths are absolute."""

    path: str
    map_yaml: str
    wall_height: float = 2.0
    rois: Optional[str] = None
    robots: List[RobotSpec] = field(default_factory=list)
    map_handling: MapHandling = MapHandling()
    people: PeopleConfig = PeopleConfig()
    rooms: RoomConfig = RoomConfig()    # how rois: auto finds the rooms

    @property
    def name(self) -> str:
        """The world's name: its directory name."""
        return os.path.basename(os.path.dirname(self.path))


_WORLD_KEYS = ("map", "wall_height", "rois", "robots", "unknown", "clean", "people", "rooms")
_CLEAN_KEYS = ("close_gaps", "speckle", "unknown_slivers")
_ROBOT_KEYS = ("name", "model", "pose", "drive")   # and a section per sensor kind


def resolve_world(world: str, worlds_dir: str) -> str:
    """Turn ``world:=`` (a name under worlds/ or a path to a world.yaml) into a file path.

    Raises:
        ConfigError: nothing by that name or path exists.
    """
    if world.endswith((".yaml", ".yml")) or os.sep in world:
        path = os.path.abspath(os.path.expanduser(world))
    else:
        path = os.path.join(worlds_dir, world, "world.yaml")
    if not os.path.isfile(path):
        known = sorted(d for d in os.listdir(worlds_dir)
                       if os.path.isfile(os.path.join(worlds_dir, d, "world.yaml"))) \
            if os.path.isdir(worlds_dir) else []
        raise ConfigError("world %r: no such world file %s (known worlds: %s)"
                          % (world, path, ", ".join(known) or "none"))
    return path


def world_label(world: str) -> str:
    """A short name for ``world:=`` (a name, or a world.yaml path: its directory's name, or
    the file's stem when it is not called world.yaml), safe in a file name."""
    if not (world.endswith((".yaml", ".yml")) or os.sep in world):
        return world
    path = os.path.abspath(os.path.expanduser(world))
    stem = os.path.splitext(os.path.basename(path))[0]
    name = os.path.basename(os.path.dirname(path)) if stem == "world" else stem
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name) or "world"


def load_world_config(path: str) -> WorldConfig:
    """Parse and validate a world.yaml.

    Args:
        path: the world.yaml.

    Returns:
        The WorldConfig with absolute map/rois paths.

    Raises:
        ConfigError: the file is missing, malformed, has unknown keys or bad values.
    """
    doc = read_yaml(path, "world", ConfigError)
    if not isinstance(doc, dict):
        raise ConfigError("%s: expected a mapping with keys %s" % (path, ", ".join(_WORLD_KEYS)))
    _reject_unknown(doc, _WORLD_KEYS, path)
    if "map" not in doc or not isinstance(doc["map"], str):
        raise ConfigError("%s: missing required key 'map' (a map_server map.yaml)" % path)
    base = os.path.dirname(os.path.abspath(path))
    map_yaml = _rel(base, doc["map"])
    wall_height = doc.get("wall_height", 2.0)
    if not _finite_positive(wall_height):
        raise ConfigError("%s: wall_height must be a positive number of metres, got %r"
                          % (path, wall_height))
    rois = doc.get("rois")
    if rois is not None and not isinstance(rois, str):
        raise ConfigError("%s: rois must be a file name or auto, got %r" % (path, rois))
    if doc.get("rooms") is not None and rois != "auto":
        raise ConfigError("%s: rooms sets how rois: auto finds the rooms; this world has %s "
                          "(drop rooms, or set rois: auto)"
                          % (path, "no rois" if rois is None else "rois: %s" % rois))
    robots_doc = doc.get("robots", [])
    if not isinstance(robots_doc, list):
        raise ConfigError("%s: robots must be a list, got %s" % (path, type(robots_doc).__name__))
    robots = [_parse_robot(r, "%s: robots[%d]" % (path, i)) for i, r in enumerate(robots_doc)]
    names = [r.name for r in robots]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError("%s: duplicate robot name(s): %s" % (path, ", ".join(repr(d) for d in dup)))
    cfg = WorldConfig(path=os.path.abspath(path), map_yaml=map_yaml, wall_height=float(wall_height),
                      rois=rois if rois in (None, "auto") else _rel(base, rois), robots=robots,
                      map_handling=_parse_map_handling(doc, path),
                      people=parse_people(doc.get("people"), path, base),
                      rooms=_section(RoomConfig, doc.get("rooms"), "%s: rooms" % path))
    if cfg.rois == "auto":   # rooms found automatically (building/autorois.py)
        from ..building.autorois import auto_rois_path

        cfg = replace(cfg, rois=auto_rois_path(cfg))
    return cfg


def _parse_map_handling(doc: Dict[str, Any], path: str) -> MapHandling:
    """The ``unknown`` key and the ``clean`` section (sim/solidmap.py says what they do)."""
    default = MapHandling()
    clean = doc.get("clean", {}) or {}
    if not isinstance(clean, dict):
        raise ConfigError("%s: clean must be a mapping with keys %s, got %r"
                          % (path, ", ".join(_CLEAN_KEYS), clean))
    _reject_unknown(clean, _CLEAN_KEYS, "%s: clean" % path)
    handling = MapHandling(unknown=doc.get("unknown", default.unknown),
                           close_gaps=clean.get("close_gaps", default.close_gaps),
                           speckle=clean.get("speckle", default.speckle),
                           unknown_slivers=clean.get("unknown_slivers",
                                                     default.unknown_slivers))
    handling.check(path)
    return handling


def _parse_robot(doc: Any, where: str) -> RobotSpec:
    if not isinstance(doc, dict):
        raise ConfigError("%s: expected a mapping with keys %s"
                          % (where, ", ".join(_ROBOT_KEYS + tuple(SENSORS))))
    _reject_unknown(doc, _ROBOT_KEYS + tuple(SENSORS), where)
    name = doc.get("name")
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise ConfigError("%s: name must be empty or a ROS name ([A-Za-z][A-Za-z0-9_]*), got %r"
                          % (where, name))
    where = "%s (%s)" % (where, name or "<empty name>")
    model = doc.get("model", "scitos_a5")
    if not isinstance(model, str) or not model:
        raise ConfigError("%s: model must be a model name, got %r" % (where, model))
    pose = doc.get("pose", [0.0, 0.0, 0.0])
    if (not isinstance(pose, (list, tuple)) or len(pose) != 3
            or not all(_is_number(v) and math.isfinite(v) for v in pose)):
        raise ConfigError("%s: pose must be [x, y, yaw] (3 finite numbers), got %r" % (where, pose))
    sections: Dict[str, Any] = {"drive": _section(DriveConfig, doc.get("drive"), "%s: drive" % where)}
    for key, kind in SENSORS.items():
        sections[key] = _section(kind.config, doc.get(key), "%s: %s" % (where, key))
    return RobotSpec(name=name, model=model, pose=(float(pose[0]), float(pose[1]), float(pose[2])),
                     **sections)


def _rel(base: str, p: str) -> str:
    p = os.path.expanduser(p)
    return p if os.path.isabs(p) else os.path.normpath(os.path.join(base, p))
