"""The life of every long-running node, in one place.

``run_node`` starts rospy, builds the node object, and then either calls its ``run()`` (a node
with a loop of its own) or spins; at the end it calls the node's ``close()`` if it has one. A
project error while building (a bad parameter, an unreadable file, a store that cannot be
opened: :class:`~bullet_floor_sim.errors.BulletFloorSimError`) is one fatal log line naming
the node, and exit status 1. The command-line tools (rois, markov_chain, trajectories, store,
evaluate_prediction) are not nodes: they exit 2 on bad arguments, as argparse does.
"""
from __future__ import annotations

import functools
import logging
import os
import sys
import time
from typing import Any, Callable, Dict, Hashable, Optional, Sequence, Tuple

import rospy

from ..errors import BulletFloorSimError
from . import sim_sleep

__all__ = ["run_node", "one_line", "forward_store_log", "RospyLogHandler", "StartupGrace",
           "TfOnDemand", "quiet_at_shutdown", "closed_at_shutdown", "STARTUP_SECONDS"]

# wall s a node waits quietly for what a system sends as it starts (the map, the first
# transforms, the robot's pose): a simulator loading a real building's map among a dozen
# starting nodes on two cores took over 5 s to publish it
STARTUP_SECONDS = 10.0


def one_line(e: BaseException) -> str:
    """An error's message with its whitespace (newlines from a YAML parser...) folded."""
    return " ".join(str(e).split())


def run_node(name: str, make: Callable[[], Any], argv: Optional[Sequence[str]] = None,
             errors: tuple = (BulletFloorSimError,), **init: Any) -> int:
    """Run node ``name`` built by ``make()`` until ROS shuts down; the process's exit status.

    Args:
        name: the node name (rospy.init_node) and the prefix of the fatal line.
        make: builds the node object; it may have ``run()`` (else rospy.spin() is used) and
            ``close()`` (called once at the end, after a failure too).
        argv: passed to rospy.init_node (remappings, __name:=).
        errors: the exceptions of ``make`` that are the user's to fix (one fatal line, 1).
        init: further rospy.init_node keywords.
    """
    rospy.init_node(name, argv=list(sys.argv if argv is None else argv), **init)
    sim_sleep.install()
    try:
        node = make()
    except errors as e:
        rospy.logfatal("%s: %s", name, one_line(e))
        return 1
    try:
        run = getattr(node, "run", None)
        if run is not None:
            run()
        else:
            rospy.spin()
    except rospy.ROSInterruptException:
        pass
    except (rospy.ROSException, AttributeError) as e:
        if not closed_at_shutdown(e):
            raise
        # (shutting down: a publish to a closed topic; nothing to report)
    finally:
        close = getattr(node, "close", None)
        if close is not None:
            close()
    return 0


class RospyLogHandler(logging.Handler):
    """Forwards Python ``logging`` records (the store's outage and replay messages) to rospy,
    so they reach the node's screen output and /rosout."""

    def emit(self, record: logging.LogRecord) -> None:
        msg = self.format(record)
        if record.levelno >= logging.ERROR:
            rospy.logerr(msg)
        elif record.levelno >= logging.WARNING:
            rospy.logwarn(msg)
        else:
            rospy.loginfo(msg)


def forward_store_log() -> None:
    """Send the store's log (logger ``bullet_floor_sim.store``, INFO and up) to rospy."""
    log = logging.getLogger("bullet_floor_sim.store")
    if not any(isinstance(h, RospyLogHandler) for h in log.handlers):
        log.addHandler(RospyLogHandler())
        log.setLevel(logging.INFO)
        log.propagate = False


class StartupGrace:
    """A condition expected while a system starts (the first scans before the map, or before
    robot_state_publisher's static transforms) is logged at debug level, and as a warning
    once it has lasted ``seconds`` of wall time since it was first seen; each ``key`` is
    throttled on its own (at most one line per ``period`` s, the first warning at once)."""

    def __init__(self, seconds: float = STARTUP_SECONDS) -> None:
        self.seconds = seconds
        self._since: Dict[Hashable, float] = {}
        self._logged: Dict[Tuple[Hashable, bool], float] = {}

    def level(self, key: Hashable, now: float) -> bool:
        """Whether ``key`` is late at ``now`` (monotonic s): logged as a warning."""
        return now - self._since.setdefault(key, now) > self.seconds

    def log(self, key: Hashable, period: float, fmt: str, *args: Any) -> None:
        now = time.monotonic()
        late = self.level(key, now)
        last = self._logged.get((key, late))
        if last is not None and now - last < period:
            return
        self._logged[(key, late)] = now
        (rospy.logwarn if late else rospy.logdebug)(fmt, *args)


def closed_at_shutdown(e: BaseException) -> bool:
    """Whether ``e`` is what a publish raises when rospy's shutdown closes its topic: a
    ROSException ("publish() to a closed topic"), or an AttributeError raised inside rospy's
    topics.py when the close lands inside the publish (_PublisherImpl.close sets the buffer
    and the lock to None, which publish, acquire and release read after their checks), once
    a shutdown has been asked for. rospy closes the topics in a pre-shutdown hook, before
    ``rospy.is_shutdown()`` turns true, so the test is ``is_shutdown_requested``."""
    if not rospy.core.is_shutdown_requested():
        return False
    if isinstance(e, rospy.ROSException):
        return True
    tb = e.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return (isinstance(e, AttributeError) and tb is not None
            and tb.tb_frame.f_code.co_filename.endswith(os.path.join("rospy", "topics.py")))


def quiet_at_shutdown(callback: Callable) -> Callable:
    """For a subscriber or timer callback that publishes: at shutdown (Ctrl-C) the node's
    publishers close under a callback still running, and rospy logs what its publish raises
    then (closed_at_shutdown) as a "bad callback" ERROR, or a Timer's thread dies with a
    traceback; this ends the callback quietly then. Any other exception, or at any other
    time, goes on."""
    @functools.wraps(callback)
    def run(*args: Any, **kwargs: Any) -> Any:
        try:
            return callback(*args, **kwargs)
        except (rospy.ROSException, AttributeError) as e:
            if not closed_at_shutdown(e):
                raise
            return None
    return run


class TfOnDemand:
    """A tf2 buffer whose listener runs only while a node needs it. A node located from
    ground truth needs tf only for a laser's offset (once) and the odd goal in another frame,
    yet a listener reads every /tf message: 50 Hz of sim time per robot kept a Python thread
    busy enough to delay the ground-truth poses by 10 ms of wall time a scan at rtf:=0.
    Transforms already received (the static ones) stay in ``buffer``."""

    def __init__(self) -> None:
        import tf2_ros

        self.buffer = tf2_ros.Buffer()
        self.listener: Optional[Any] = None
        self.listen()

    def listen(self) -> None:
        """Listen to /tf and /tf_static (again)."""
        if self.listener is None:
            import tf2_ros

            self.listener = tf2_ros.TransformListener(self.buffer)

    def stop(self) -> None:
        """Stop listening."""
        if self.listener is not None:
            self.listener.unregister()
            self.listener = None
