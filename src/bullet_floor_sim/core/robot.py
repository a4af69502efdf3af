"""Robot models (xacro -> URDF -> PyBullet) and drives (diff, omni) with limits and watchdog.

A model is expanded once through the xacro Python API, its frames and sizes are read with
yourdfpy, and the URDF (with ``package://bullet_floor_sim/`` made absolute) is what PyBullet
loads. Drives are small plugins in the ``DRIVES`` registry; each turns a commanded body
velocity into the velocity actually applied this step, honouring velocity and acceleration
limits. They work on arrays of robots at once.
"""
from __future__ import annotations

import functools
import math
import os
import tempfile
from dataclasses import dataclass
from typing import Dict, List, Tuple, Type

import numpy as np

from .config import DriveConfig
from .errors import CommandError, RobotModelError
from .paths import package_root

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
    """

    name: str
    urdf_path: str
    laser_pose: Tuple[float, float, float, float]
    wheel_radius: float
    wheel_separation: float
    wheel_joints: Tuple[str, str]


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


@functools.lru_cache(maxsize=None)
def load_model(model: str, urdf_dir: str = "") -> RobotModel:
    """Expand, parse and prepare a robot model once per process.

    Raises:
        RobotModelError: the model is missing, invalid or lacks base_footprint,
            base_laser_link or a pair of wheel joints.
    """
    import yourdfpy  # local: heavy import

    xml = expand_xacro(model, "", urdf_dir)
    xml = xml.replace(_PKG_URL, package_root().rstrip("/") + "/")
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
    return RobotModel(name=model, urdf_path=path, laser_pose=laser_pose,
                      wheel_radius=wheels[0][2], wheel_separation=wheels[0][0] - wheels[1][0],
                      wheel_joints=(wheels[0][1], wheels[1][1]))


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
