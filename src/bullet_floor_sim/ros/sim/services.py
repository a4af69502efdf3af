"""The simulator's scripting services: ``~spawn``, ``~delete``, ``~set_pose`` and ``~step``
(srv/Spawn.srv, Delete.srv, SetPose.srv, Step.srv), in the style of flatland's and Gazebo's.

A service call runs in a rospy thread; what it changes (the world's robots, the node's topics,
the steps) is done by the simulator's main loop between two steps (``MainThreadJobs``), as the
node's sends are the main thread's alone. The call waits for it and answers with success and
a one-line message saying what was done or why not (an unknown model, a name in use, a pose in
a wall, a step while the simulator runs).
"""
from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable, List, Optional, Tuple

import rospy

from ...errors import BulletFloorSimError
from ...sim.config import RobotSpec
from ...sim.roster import add_robot, place_person, remove_robot, robot_index
from .wire import ros_time

__all__ = ["RobotIO", "MainThreadJobs", "RosterServices", "MAX_STEP_TICKS"]

#: The most ticks one ``~step`` call may ask for (an hour of sim time at 100 Hz).
MAX_STEP_TICKS = 360_000
#: Wall seconds a service call waits for the main loop.
_JOB_TIMEOUT = 60.0


@dataclass
class RobotIO:
    """One robot's topics in the simulator node."""

    outputs: List[Any]
    cmd_sub: Any
    initialpose: Optional[Any]


class _Job:
    def __init__(self, fn: Callable[[], Tuple[bool, str]]) -> None:
        self.fn = fn
        self.done = threading.Event()
        self.started = False
        self.cancelled = False
        self.result: Tuple[bool, str] = (False, "not run")


class MainThreadJobs:
    """Work handed from service threads to the main loop (``run`` between steps)."""

    def __init__(self) -> None:
        self._queue: deque = deque()

    @property
    def pending(self) -> bool:
        return bool(self._queue)

    def call(self, fn: Callable[[], Tuple[bool, str]]) -> Tuple[bool, str]:
        """Have the main loop run ``fn`` and return its (success, message); a
        BulletFloorSimError it raises is a failure with its message. A call the loop has not
        started within ``_JOB_TIMEOUT`` wall seconds is withdrawn (never run); one it has
        started is waited for to the end."""
        job = _Job(fn)
        self._queue.append(job)
        if not job.done.wait(_JOB_TIMEOUT):
            job.cancelled = True
            if not job.started:
                return False, ("the simulator's main loop did not take the call in %.0f s; "
                               "withdrawn, nothing changed" % _JOB_TIMEOUT)
            job.done.wait()
        return job.result

    def run(self) -> None:
        while self._queue:
            job = self._queue.popleft()
            if job.cancelled:
                continue
            job.started = True
            try:
                job.result = job.fn()
            except BulletFloorSimError as e:
                job.result = (False, str(e))
            except Exception as e:  # noqa: BLE001  (a bug: answered and logged, the loop lives)
                rospy.logerr("simulator: a service call failed: %r", e)
                job.result = (False, "internal error: %r" % (e,))
            job.done.set()


class RosterServices:
    """``~spawn``, ``~delete``, ``~set_pose``, ``~step`` on a SimulatorNode."""

    def __init__(self, node: Any) -> None:
        from bullet_floor_sim.srv import (Delete, DeleteResponse, SetPose, SetPoseResponse,
                                          Spawn, SpawnResponse, Step, StepResponse)
        self.node = node
        self._responses = (SpawnResponse, DeleteResponse, SetPoseResponse, StepResponse)
        rospy.Service("~spawn", Spawn, self._on_spawn)
        rospy.Service("~delete", Delete, self._on_delete)
        rospy.Service("~set_pose", SetPose, self._on_set_pose)
        rospy.Service("~step", Step, self._on_step)

    # ------------------------------------------------------------------------- handlers
    def _answer(self, cls, fn: Callable[[], Tuple[bool, str]], what: str):
        ok, message = self.node.jobs.call(fn)
        (rospy.loginfo if ok else rospy.logwarn)("simulator: %s: %s", what, message)
        return cls(success=ok, message=message)

    def _on_spawn(self, req):
        pose = (req.pose.x, req.pose.y, req.pose.theta)
        return self._answer(self._responses[0], lambda: self.spawn(req.model or "scitos_a5",
                                                                  req.name, pose), "spawn")

    def _on_delete(self, req):
        return self._answer(self._responses[1], lambda: self.delete(req.name), "delete")

    def _on_set_pose(self, req):
        pose = (req.pose.x, req.pose.y, req.pose.theta)
        return self._answer(self._responses[2], lambda: self.set_pose(req.name, pose),
                            "set_pose")

    def _on_step(self, req):
        resp = self._answer(self._responses[3], lambda: self.step(int(req.ticks)), "step")
        resp.clock = ros_time(self.node.world.clock.now_ns)
        return resp

    # ------------------------------------------------------------------------- main thread
    def spawn(self, model: str, name: str, pose: Tuple[float, float, float]) -> Tuple[bool, str]:
        node, w = self.node, self.node.world
        if not all(math.isfinite(v) for v in pose):
            return False, "robot %r: pose %r is not finite" % (name, pose)
        if w.people is not None and name in [p.name for p in w.people.people]:
            return False, "a person is called %r: a robot needs a name of its own" % name
        spec = RobotSpec(name=name, model=model, pose=pose)
        with node.lock:
            add_robot(w, spec)
            try:
                node._open_robot(spec)
                node._reindex()
                if node.rsps is not None:
                    node.rsps.start(spec)
            except Exception:   # the robot goes again, with what was opened for it
                remove_robot(w, robot_index(w, name))
                if name in node.robot_io:
                    node.close_robot(name)
                node._reindex()
                if node.rsps is not None:
                    node.rsps.stop_robot(name)
                raise
        node._publish_initialposes([name])
        return True, "robot %r (%s) at (%.3f, %.3f, %.3f): topics /%s/..." % (
            name, model, pose[0], pose[1], pose[2], name)

    def delete(self, name: str) -> Tuple[bool, str]:
        node, w = self.node, self.node.world
        with node.lock:
            remove_robot(w, robot_index(w, name))
            node.close_robot(name)
            node._reindex()
        if node.rsps is not None:
            node.rsps.stop_robot(name)
        return True, "robot %r taken out; robots now: %s" % (
            name, ", ".join(s.name or "<empty>" for s in w.specs) or "none")

    def set_pose(self, name: str, pose: Tuple[float, float, float]) -> Tuple[bool, str]:
        node, w = self.node, self.node.world
        with node.lock:
            if name in node.rows:
                w.set_pose(node.rows[name], pose)
                return True, "robot %r at (%.3f, %.3f, %.3f)" % ((name,) + tuple(pose))
            if w.people is None:
                robot_index(w, name)        # raises: no such robot (and no people at all)
            if not all(math.isfinite(v) for v in pose[:2]):
                return False, "person %r: position %r is not finite" % (name, pose[:2])
            place_person(w.people, name, pose[0], pose[1], w.clock.now)
        return True, "person %r at (%.3f, %.3f)" % (name, pose[0], pose[1])

    def step(self, ticks: int) -> Tuple[bool, str]:
        node, w = self.node, self.node.world
        if not node.paused:
            return False, "step: the simulator is running; pause it first (~pause)"
        if not 0 < ticks <= MAX_STEP_TICKS:
            return False, "step: ticks must be in 1..%d, got %d" % (MAX_STEP_TICKS, ticks)
        before = w.clock.steps
        for _ in range(ticks):
            if rospy.is_shutdown():
                return False, "step: shut down after %d of %d ticks" % (
                    w.clock.steps - before, ticks)
            with node.lock:
                node.publish(w.step(1))
            node.flush()
        return True, "stepped %d ticks to %.3f s" % (w.clock.steps - before, w.clock.now)
