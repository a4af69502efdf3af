"""Each robot's robot_state_publisher output: built in (the default), or children.

``~robot_state_publishers`` (``state_publisher_mode``): ``builtin`` publishes from the
simulator node what one robot_state_publisher per robot publishes for the simulator's
joint_states (each robot's ``robot_description``; its fixed joints on /tf_static; its wheel
joints on /tf, packed by the node at the state rate); ``process`` starts one Debian
robot_state_publisher per robot instead; ``none`` publishes neither.
"""
from __future__ import annotations

import os
import signal
import subprocess
import time
from typing import Dict, List


import rospy
from tf2_msgs.msg import TFMessage

from ...errors import BulletFloorSimError, ConfigError
from ...sim.robot import expand_xacro
from ...sim.world import World
from .wire import ros_time, static_links_message

__all__ = ["BuiltinStatePublisher", "RobotStatePublishers", "STATE_PUBLISHERS",
           "state_publisher_mode"]

#: The values of ``~robot_state_publishers``.
STATE_PUBLISHERS = ("builtin", "process", "none")


def state_publisher_mode(value) -> str:
    """``~robot_state_publishers`` as one of ``STATE_PUBLISHERS`` (true means builtin, false
    none: the same transforms as before either way).

    Raises:
        ConfigError: any other value.
    """
    v = str(value).strip().lower()
    v = {"true": "builtin", "1": "builtin", "false": "none", "0": "none"}.get(v, v)
    if v not in STATE_PUBLISHERS:
        raise ConfigError("~robot_state_publishers: %r is none of %s (or true, false)"
                          % (value, ", ".join(STATE_PUBLISHERS)))
    return v


def _describe(spec) -> None:
    """Set ``robot_description`` in the robot's namespace: its prefixed URDF."""
    rospy.set_param(("/" + spec.name if spec.name else "") + "/robot_description",
                    expand_xacro(spec.model, spec.prefix))


def _forget(name: str) -> None:
    try:
        rospy.delete_param(("/" + name if name else "") + "/robot_description")
    except KeyError:
        pass


class BuiltinStatePublisher:
    """robot_state_publisher's output for every robot, from the simulator node.

    Each robot's ``robot_description`` is set, and the fixed joints of all robots go out in
    one latched /tf_static message (a latched topic keeps one message per publisher), sent
    again whenever a robot comes or goes. The wheels' transforms go on /tf with each
    joint_states tick (the node's ``wheel_tf``). Called from the main thread.
    """

    def __init__(self, world: World) -> None:
        self.world = world
        self.pub = rospy.Publisher("/tf_static", TFMessage, queue_size=1, latch=True)
        for spec in world.specs:
            _describe(spec)
        self.publish()

    def publish(self) -> None:
        """The fixed joints of every robot now, stamped with the sim time now."""
        w = self.world
        links = [x.prefixed(s.prefix) for s, m in zip(w.specs, w.models) for x in m.fixed_links]
        self.pub.publish(static_links_message(links, ros_time(w.clock.now_ns)))

    def start(self, spec) -> None:
        """A robot came (``spec``, already in the world)."""
        _describe(spec)
        self.publish()

    def stop_robot(self, name: str, timeout: float = 1.0) -> None:
        """Robot ``name`` went: drop its ``robot_description`` and its fixed joints."""
        _forget(name)
        self.publish()

    def stop(self, timeout: float = 1.0) -> None:
        """Nothing runs apart from the node."""


class RobotStatePublishers:
    """One robot_state_publisher per robot, in its namespace, with the prefixed URDF.

    Plain child processes in the simulator's process group (what roslaunch and a terminal
    signal), so they stop with it, and stopped here within ``timeout`` when it stops. Not
    roslaunch's scriptapi: that installs signal handlers doing the whole shutdown inside the
    handler and waits up to 15 s per child.
    """

    def __init__(self, world: World) -> None:
        import rospkg
        from roslib.packages import find_node

        exe = find_node("robot_state_publisher", "robot_state_publisher")
        if not exe:
            raise BulletFloorSimError("robot_state_publisher is not installed "
                                      "(set ~robot_state_publishers builtin, or none)")
        self.exe = exe[0]
        self.log_dir = os.path.join(rospkg.get_log_dir(), str(rospy.get_param("/run_id", "")))
        os.makedirs(self.log_dir, exist_ok=True)
        self.procs: Dict[str, subprocess.Popen] = {}
        for spec in world.specs:
            self.start(spec)

    def start(self, spec) -> None:
        """A robot_state_publisher for the robot of ``spec`` (its robot_description set)."""
        ns = "/" + spec.name if spec.name else "/"
        _describe(spec)
        tag = (spec.name or "") + ("-" if spec.name else "") + "robot_state_publisher"
        env = dict(os.environ, ROS_NAMESPACE=ns)
        with open(os.path.join(self.log_dir, tag + "-stdout.log"), "ab") as out:
            self.procs[spec.name] = subprocess.Popen(
                [self.exe, "__name:=robot_state_publisher",
                 "__log:=" + os.path.join(self.log_dir, tag + ".log")],
                env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                close_fds=True)

    def stop_robot(self, name: str, timeout: float = 1.0) -> None:
        """Stop the robot_state_publisher of robot ``name`` and drop its robot_description."""
        proc = self.procs.pop(name, None)
        if proc is not None:
            _stop([proc], timeout)
        _forget(name)

    def stop(self, timeout: float = 1.0) -> None:
        """SIGINT every child still running, SIGKILL what is left after ``timeout`` s."""
        _stop(list(self.procs.values()), timeout)


def _stop(procs: List[subprocess.Popen], timeout: float) -> None:
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
    deadline = time.monotonic() + timeout
    for p in procs:
        try:
            p.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
