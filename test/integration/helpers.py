"""What the rostest scripts share (imported from the script's own directory)."""
from __future__ import annotations

import time

import rospy


def wait_for(condition, timeout, what):
    """Poll ``condition`` every 0.2 s for up to ``timeout`` wall seconds.

    Returns:
        The first truthy value it returns.

    Raises:
        AssertionError: naming ``what``, when it stays falsy (or ROS shuts down).
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not rospy.is_shutdown():
        value = condition()
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError("timed out after %g s waiting for %s" % (timeout, what))
