"""Stopping the simulator from its main loop, and owning rospy's clock.
"""
from __future__ import annotations

import os
import signal
from typing import Optional




__all__ = ["StopSignals", "set_rostime", "stop_listening_to_own_clock"]


try:   # rospy internals: the setter of rospy's time, used when this node owns the clock
    from rospy.rostime import _set_rostime as set_rostime
except ImportError:
    set_rostime = None


def stop_listening_to_own_clock() -> bool:
    """Under /use_sim_time, rospy subscribes every node to /clock, the simulator included:
    each /clock message would cross a TCP connection back into this process (a thread hand-off
    and a deserialisation per step). The simulator owns the clock, so it drops that
    subscription and sets rospy's time itself each step (rospy internals, checked here).

    Returns:
        True when rospy's time is now set by this node.
    """
    try:
        from rospy.impl import simtime
    except ImportError:
        return False
    sub = getattr(simtime, "_clock_sub", None)
    if sub is None or set_rostime is None:
        return False
    sub.unregister()
    simtime._clock_sub = None
    return True


class StopSignals:
    """SIGINT/SIGTERM handlers that only record the request; the main loop acts on it.

    rospy's own handlers (and roslaunch's ``rl_signal``, which any roslaunch ``Process`` made in
    this process installs) run the whole shutdown inside the handler: in the main thread, at
    whatever bytecode it was interrupted. The simulator's main thread spends much of its time in
    ``Publisher.publish`` -> ``QueuedConnection.write_data``, holding that connection's
    non-reentrant lock; rospy's shutdown then closes all topics and waits for the topic
    manager's lock, which rospy's registration thread holds while it waits for the connection
    lock the interrupted main thread still has: a deadlock (2-3 runs in 20 of sim.launch in
    worlds/simple with scan subscribers; the rostests and nav_bench saw it too). Both rospy and
    roslaunch ignore every later signal once shutdown has begun, so roslaunch's SIGTERM did
    nothing either and only SIGKILL ended the node.

    Here the first signal sets ``signum``; the loop sees it between steps, where it holds no
    lock, and shuts down from there. A second signal exits at once (shutdown itself is stuck).
    """

    def __init__(self) -> None:
        self.signum: Optional[int] = None

    def install(self) -> "StopSignals":
        """Take over SIGINT and SIGTERM (call from the main thread, after rospy.init_node
        with ``disable_signals=True``)."""
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, self._handle)
        return self

    def _handle(self, signum: int, _frame) -> None:
        if self.signum is not None:
            os.write(2, b"simulator: second signal during shutdown, exiting now\n")
            os._exit(128 + signum)
        self.signum = signum  # a plain assignment: safe whatever the main thread holds

    def __call__(self) -> bool:
        """True once a stop signal arrived."""
        return self.signum is not None
