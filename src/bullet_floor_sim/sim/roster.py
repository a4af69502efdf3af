"""Robots added to and removed from a running World (the simulator's ``spawn`` and ``delete``
services), and people put elsewhere (``set_pose`` of a person).

A World keeps its robots as rows of arrays, and much of what it measured at load (beam
tables, body sections, collision windows) is per row. Adding or removing a robot builds all of
that again for the new list of robots (World._init_robots) and then puts back what the robots
that stay had: pose, velocity, command, wheel travel, stalls, spawn pose, odometry, battery
and each lidar's schedule. Their sensor noise goes on from the world's generator; a kept
robot's next scan is due when it was.
"""
from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, List, Sequence

import numpy as np

from ..errors import ConfigError
from .config import RobotSpec
from .robot import RobotModel, load_model

if TYPE_CHECKING:
    from .world import World

__all__ = ["add_robot", "remove_robot", "robot_index", "place_person"]

#: World arrays with one row per robot that a roster change keeps for the robots that stay.
_KEPT = ("pose", "vel", "target", "last_cmd_ns", "_travel", "stalled", "stall_count", "spawn")


def robot_index(world: "World", name: str) -> int:
    """The row of the robot called ``name``.

    Raises:
        ConfigError: no robot has that name (the message lists them).
    """
    names = [s.name for s in world.specs]
    if name not in names:
        raise ConfigError("no robot %r (robots: %s)" % (name, ", ".join(
            n or "<empty>" for n in names) or "none"))
    return names.index(name)


def add_robot(world: "World", spec: RobotSpec) -> int:
    """Add a robot of ``spec`` (model, name, spawn pose) at its pose; returns its row (the
    last).

    Raises:
        ConfigError: the name is in use or not a ROS name, the pose is in a wall, unknown
            space or another robot (the world is as before).
        RobotModelError: no such model.
    """
    names = [s.name for s in world.specs]
    if spec.name in names:
        raise ConfigError("a robot called %r is already in the world" % spec.name)
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", spec.name or ""):
        raise ConfigError("robot name %r is not a ROS name (letters, digits and _, not "
                          "starting with a digit)" % spec.name)
    model = load_model(spec.model)
    _rebuild(world, world.specs + [spec], world.models + [model], list(range(world.n)))
    i = world.n - 1
    try:
        world._check_place(i, "would spawn")
    except ConfigError:
        remove_robot(world, i)
        raise
    return i


def remove_robot(world: "World", robot: int) -> None:
    """Take robot ``robot`` out of the world; the rows after it move up by one."""
    keep = [k for k in range(world.n) if k != robot]
    _rebuild(world, [world.specs[k] for k in keep], [world.models[k] for k in keep], keep)


def _rebuild(world: "World", specs: Sequence[RobotSpec], models: Sequence[RobotModel],
             keep: List[int]) -> None:
    """Load ``specs`` afresh (their first ``len(keep)`` rows are the world's rows ``keep``)
    and put back the state of the kept robots."""
    world.update_odometry()
    saved = {a: np.asarray(getattr(world, a))[keep].copy() for a in _KEPT}
    odom = world.odometry.pose[keep].copy()
    charged = world.battery.t0[keep].copy()
    next_scan = world.lidar.next_scan_ns[keep].copy()
    for body in world.bodies:
        world.client.removeBody(body)
    world.specs, world.models = list(specs), list(models)
    world._init_robots()
    k = len(keep)
    for a, v in saved.items():
        getattr(world, a)[:k] = v
    world.odometry.pose[:k] = odom
    world.odometry.moved(world, range(world.n))
    world.battery.t0[:k] = charged
    world.lidar.next_scan_ns[:k] = next_scan
    world.lidar.reschedule()
    world.schedule_sensors()
    world._body_at = [None] * world.n
    world._sync_bodies()
    world._idle = False          # the next step looks at every robot's command again
    world._expiry_ns = 0


def place_person(crowd, name: str, x: float, y: float, now: float) -> int:
    """Put the person called ``name`` at (x, y), standing; a walk it was on goes on from
    there along a new path. Returns its row.

    Args:
        now: sim time (s): its progress towards its goal is timed afresh from then.

    Raises:
        ConfigError: no such person, or (x, y) is not floor a person fits on.
    """
    names = [p.name for p in crowd.people]
    if name not in names:
        raise ConfigError("no robot or person %r (people: %s)" % (name, ", ".join(names)))
    if not crowd.routes.grid.is_free(x, y):
        raise ConfigError("person %r cannot stand at (%.3f, %.3f): not floor a person fits on "
                          "(a wall, unknown space, or too near one)" % (name, x, y))
    i = names.index(name)
    crowd.pos[i] = (x, y)
    crowd.vel[i] = 0.0
    p = crowd.people[i]
    p.best, p.best_t = math.inf, now
    if p.goal is not None and p.state == "walk":
        crowd._replan(i, p)
    return i
