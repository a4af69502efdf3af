"""robot_state_publisher children, one per robot, started and stopped by the simulator node.
"""
from __future__ import annotations

import os
import signal
import subprocess
import time
from typing import Dict, List


import rospy

from ...errors import BulletFloorSimError
from ...sim.robot import expand_xacro
from ...sim.world import World

__all__ = ["RobotStatePublishers"]


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
                                      "(set ~robot_state_publishers false to run without it)")
        self.exe = exe[0]
        self.log_dir = os.path.join(rospkg.get_log_dir(), str(rospy.get_param("/run_id", "")))
        os.makedirs(self.log_dir, exist_ok=True)
        self.procs: Dict[str, subprocess.Popen] = {}
        for spec in world.specs:
            self.start(spec)

    def start(self, spec) -> None:
        """A robot_state_publisher for the robot of ``spec`` (its robot_description set)."""
        ns = "/" + spec.name if spec.name else "/"
        rospy.set_param((ns.rstrip("/") or "") + "/robot_description",
                        expand_xacro(spec.model, spec.prefix))
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
        try:
            rospy.delete_param(("/" + name if name else "") + "/robot_description")
        except KeyError:
            pass

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
