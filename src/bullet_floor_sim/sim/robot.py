"""Robot models (xacro -> URDF -> PyBullet) and drives (diff, omni) with limits and watchdog.

A model is expanded once through the xacro Python API, its frames and sizes are read with
yourdfpy, and the URDF (with ``package://bullet_floor_sim/`` made absolute) is what PyBullet
loads. The expanded URDF and what was read from it are cached on disk
(``$ROS_HOME/bullet_floor_sim/models``, or ``$BULLET_FLOOR_SIM_CACHE``; set it empty to turn
the cache off), keyed by the content of every file in the model's directory, the package path
and the xacro and yourdfpy versions: importing xacro (which imports all of roslaunch) and
yourdfpy (trimesh) is 0.4 of the 0.5 s a cold world load takes, so every load after the first
skips both. Drives are small plugins in the ``DRIVES`` registry; each turns a commanded body
velocity into the velocity actually applied this step, honouring velocity and acceleration
limits. They work on arrays of robots at once.
"""
from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import re
import tempfile
from dataclasses import dataclass
from typing import Any, Dict, List, Tuple, Type

import numpy as np

from .config import DriveConfig
from .links import Link, link_from_dict, link_to_dict, model_links
from ..files import atomic_file
from ..errors import CommandError, RobotModelError
from ..paths import package_root

__all__ = [
    "RobotModel",
    "load_model",
    "expand_xacro",
    "Drive",
    "DiffDrive",
    "OmniDrive",
    "DRIVES",
    "check_command",
]

_PKG_URL = "package://bullet_floor_sim/"
#: What a cache entry holds (in the key: an entry written by older code is expanded again).
_CACHE_SCHEMA = b"model-v2: laser, wheels, links\n"


@dataclass(frozen=True)
class RobotModel:
    """What the simulator needs to know of a robot model.

    Attributes:
        name: model name (urdf/<name>.urdf.xacro).
        urdf_path: an expanded URDF file (no prefix, absolute mesh paths) for PyBullet.
        laser_pose: (x, y, z, yaw) of base_laser_link in base_footprint.
        wheel_radius: drive wheel radius, metres.
        wheel_separation: distance between the drive wheels, metres.
        wheel_joints: (left, right) joint names without prefix.
        fixed_links: the fixed joints, what robot_state_publisher puts on /tf_static.
        wheel_links: the (left, right) wheel joints, what it puts on /tf from joint_states.
    """

    name: str
    urdf_path: str
    laser_pose: Tuple[float, float, float, float]
    wheel_radius: float
    wheel_separation: float
    wheel_joints: Tuple[str, str]
    fixed_links: Tuple[Link, ...] = ()
    wheel_links: Tuple[Link, ...] = ()


def expand_xacro(model: str, prefix: str = "", urdf_dir: str = "") -> str:
    """Expand ``urdf/<model>.urdf.xacro`` with the xacro Python API.

    Args:
        model: model name.
        prefix: value of the xacro ``prefix`` arg (e.g. ``robot1/``).
        urdf_dir: where the xacro files are (default: this package's urdf/).

    Returns:
        The URDF XML text.

    Raises:
        RobotModelError: no such model, or xacro failed.
    """
    import xacro  # local: xacro is slow to import and only needed here

    urdf_dir = urdf_dir or os.path.join(package_root(), "urdf")
    path = os.path.join(urdf_dir, model + ".urdf.xacro")
    if not os.path.isfile(path):
        known = sorted(f[:-len(".urdf.xacro")] for f in os.listdir(urdf_dir)
                       if f.endswith(".urdf.xacro")) if os.path.isdir(urdf_dir) else []
        raise RobotModelError("robot model %r: no file %s (known models: %s)"
                              % (model, path, ", ".join(known) or "none"))
    try:
        doc = xacro.process_file(path, mappings={"prefix": prefix})
    except Exception as e:  # xacro raises a variety of exception types
        raise RobotModelError("%s: xacro failed: %s" % (path, str(e).splitlines()[0])) from None
    return doc.toprettyxml(indent="  ")


def model_cache_dir() -> str:
    """Where expanded models are cached ("" = no cache): ``$BULLET_FLOOR_SIM_CACHE`` when
    set, else ``$ROS_HOME/bullet_floor_sim/models`` (``~/.ros`` without ROS_HOME)."""
    env = os.environ.get("BULLET_FLOOR_SIM_CACHE")
    if env is not None:
        return os.path.normpath(os.path.abspath(env)) if env else ""
    home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return os.path.join(home, "bullet_floor_sim", "models")


def _model_key(model: str, urdf_dir: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    h = hashlib.sha1()
    h.update(_CACHE_SCHEMA)
    for dist in ("xacro", "yourdfpy"):
        try:
            h.update(("%s %s\n" % (dist, version(dist))).encode())
        except PackageNotFoundError:
            h.update(("%s -\n" % dist).encode())
    h.update(("%s\n%s\n%s\n" % (model, os.path.abspath(urdf_dir), package_root())).encode())
    for name in sorted(os.listdir(urdf_dir)):
        path = os.path.join(urdf_dir, name)
        if os.path.isfile(path):
            with open(path, "rb") as f:
                h.update(name.encode() + b"\0" + f.read() + b"\0")
    return h.hexdigest()[:20]


def _cached_model(cache: str, model: str, key: str):
    try:
        with open(os.path.join(cache, "%s-%s.json" % (model, key))) as f:
            d = json.load(f)
        urdf = os.path.join(cache, "%s-%s.urdf" % (model, key))
        if not os.path.isfile(urdf):
            return None
        return RobotModel(name=model, urdf_path=urdf,
                          # the 4 values load_model wrote (mypy cannot know a JSON list's length)
                          laser_pose=tuple(float(v) for v in d["laser_pose"]),  # type: ignore[arg-type]
                          wheel_radius=float(d["wheel_radius"]),
                          wheel_separation=float(d["wheel_separation"]),
                          wheel_joints=(str(d["wheel_joints"][0]), str(d["wheel_joints"][1])),
                          fixed_links=tuple(link_from_dict(x) for x in d["fixed_links"]),
                          wheel_links=tuple(link_from_dict(x) for x in d["wheel_links"]))
    except (OSError, ValueError, KeyError, TypeError, IndexError):
        return None  # absent or unreadable: expand again


def _write_atomic(path: str, text: str) -> None:
    with atomic_file(path, fsync=False) as f:
        f.write(text)


def _store_urdf(cache: str, stem: str, xml: str) -> str:
    """Write an expanded URDF to the cache as ``<stem>.urdf`` and return its path; "" when
    the cache cannot be written."""
    try:
        os.makedirs(cache, exist_ok=True)
        path = os.path.join(cache, stem + ".urdf")
        _write_atomic(path, xml)
        return path
    except OSError:
        return ""


@functools.lru_cache(maxsize=None)
def load_model(model: str, urdf_dir: str = "") -> RobotModel:
    """Expand, parse and prepare a robot model once per process (and once per content of
    its directory while the disk cache, :func:`model_cache_dir`, is writable).

    Raises:
        RobotModelError: the model is missing, invalid or lacks base_footprint,
            base_laser_link or a pair of wheel joints.
    """
    urdf_dir = urdf_dir or os.path.join(package_root(), "urdf")
    cache = model_cache_dir()
    key = ""
    if cache and os.path.isfile(os.path.join(urdf_dir, model + ".urdf.xacro")):
        key = _model_key(model, urdf_dir)
        hit = _cached_model(cache, model, key)
        if hit is not None:
            return hit
    import yourdfpy  # local: heavy import

    xml = expand_xacro(model, "", urdf_dir)
    xml = xml.replace(_PKG_URL, package_root().rstrip("/") + "/")
    path = stored = _store_urdf(cache, "%s-%s" % (model, key), xml) if key else ""
    if not stored:
        fd, path = tempfile.mkstemp(prefix="bfs_%s_" % model, suffix=".urdf")
        with os.fdopen(fd, "w") as f:
            f.write(xml)
    try:
        urdf = yourdfpy.URDF.load(path, load_meshes=False, build_collision_scene_graph=False,
                                  load_collision_meshes=False)
    except Exception as e:
        raise RobotModelError("robot model %r: URDF does not parse: %s" % (model, e)) from None
    links = set(urdf.link_map)
    for needed in ("base_footprint", "base_laser_link"):
        if needed not in links:
            raise RobotModelError("robot model %r: has no link %r" % (model, needed))
    t = urdf.get_transform(frame_to="base_laser_link", frame_from="base_footprint")
    laser_pose = (float(t[0, 3]), float(t[1, 3]), float(t[2, 3]), math.atan2(t[1, 0], t[0, 0]))
    wheels = []
    for j in urdf.joint_map.values():
        if j.type == "continuous" and "wheel" in j.child:
            tj = urdf.get_transform(frame_to=j.child, frame_from="base_footprint")
            geo = urdf.link_map[j.child].visuals[0].geometry if urdf.link_map[j.child].visuals \
                else None
            radius = float(geo.cylinder.radius) if geo is not None and geo.cylinder else 0.0
            wheels.append((float(tj[1, 3]), j.name, radius))
    if len(wheels) != 2 or wheels[0][2] <= 0 or wheels[1][2] <= 0:
        raise RobotModelError("robot model %r: needs exactly two continuous *wheel* joints with "
                              "cylinder visuals, found %d" % (model, len(wheels)))
    wheels.sort(reverse=True)  # left (+y) first
    try:
        fixed, turning = model_links(urdf)
    except ValueError as e:
        raise RobotModelError("robot model %r: %s" % (model, e)) from None
    out = RobotModel(name=model, urdf_path=path, laser_pose=laser_pose,
                     wheel_radius=wheels[0][2], wheel_separation=wheels[0][0] - wheels[1][0],
                     wheel_joints=(wheels[0][1], wheels[1][1]), fixed_links=tuple(fixed),
                     wheel_links=(turning[wheels[0][1]], turning[wheels[1][1]]))
    if stored:
        fields: Dict[str, Any] = {
            "laser_pose": list(out.laser_pose), "wheel_radius": out.wheel_radius,
            "wheel_separation": out.wheel_separation,
            "wheel_joints": list(out.wheel_joints), "urdf_dir": os.path.abspath(urdf_dir),
            "fixed_links": [link_to_dict(x) for x in out.fixed_links],
            "wheel_links": [link_to_dict(x) for x in out.wheel_links]}
        try:   # the JSON last: its presence means the URDF beside it is whole
            _write_atomic(os.path.join(cache, "%s-%s.json" % (model, key)), json.dumps(fields))
            _prune(cache, model, key, fields["urdf_dir"])
        except OSError:
            pass
    return out


def _prune(cache: str, model: str, key: str, urdf_dir: str) -> None:
    """Remove older versions of this model from this same directory; another checkout's
    (another workspace, a source tree beside its install) stays: a process running from it
    loads its URDF from the cache later, and lost it to every load from here."""
    old = re.compile(r"%s-([0-9a-f]{20})\.json$" % re.escape(model))
    for name in os.listdir(cache):
        m = old.match(name)
        if not m or m.group(1) == key:
            continue
        try:
            with open(os.path.join(cache, name)) as f:
                same = json.load(f).get("urdf_dir") == urdf_dir
        except (OSError, ValueError, AttributeError):
            same = False
        if same:
            for ext in (".json", ".urdf"):
                path = os.path.join(cache, "%s-%s%s" % (model, m.group(1), ext))
                if os.path.exists(path):
                    os.unlink(path)


def check_command(cfg: DriveConfig, vx: float, vy: float, w: float, who: str) -> None:
    """Reject a non-finite or absurd velocity command.

    Raises:
        CommandError: a component is NaN/inf, or above ``absurd_factor`` times its limit.
    """
    for name, v, lim in (("linear.x", vx, cfg.max_linear), ("linear.y", vy, cfg.max_lateral),
                         ("angular.z", w, cfg.max_angular)):
        if not math.isfinite(v):
            raise CommandError("%s: cmd_vel %s is %r; command rejected" % (who, name, v))
        if abs(v) > cfg.absurd_factor * lim:
            raise CommandError("%s: cmd_vel %s = %g is absurd (limit %g); command rejected"
                               % (who, name, v, lim))


class Drive:
    """Base drive: clamps targets to the velocity limits, then steps toward them within the
    acceleration limits. Arrays hold one row per robot: (vx, vy, w) in the body frame."""

    holonomic = False

    def __init__(self, cfgs: List[DriveConfig]) -> None:
        self.vmax = np.array([[c.max_linear, c.max_lateral, c.max_angular] for c in cfgs])
        self.amax = np.array([[c.max_acc_linear, c.max_acc_lateral, c.max_acc_angular]
                              for c in cfgs])
        if not self.holonomic:
            self.vmax[:, 1] = 0.0

    def apply(self, target: np.ndarray, current: np.ndarray, dt: float) -> np.ndarray:
        """Velocity applied this step.

        Args:
            target: (N, 3) commanded body velocities.
            current: (N, 3) velocities applied last step.
            dt: step length, seconds.

        Returns:
            (N, 3) new velocities.
        """
        t = np.minimum(np.maximum(target, -self.vmax), self.vmax)
        step = self.amax * dt
        return np.minimum(np.maximum(t, current - step), current + step)


class DiffDrive(Drive):
    """Differential drive: (v, w); a lateral command is ignored."""

    holonomic = False


class OmniDrive(Drive):
    """Holonomic drive (vx, vy, w), like MORSE's MotionXYW."""

    holonomic = True


DRIVES: Dict[str, Type[Drive]] = {"diff": DiffDrive, "omni": OmniDrive}
