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


def goal_outcome(client, goal, timeout):
    """Send ``goal`` through ``client`` (an actionlib.ActionClient) and wait up to ``timeout``
    wall seconds for it to end: (status, status text), or None when it does not.

    actionlib's SimpleActionClient can miss a goal the server ends at once: its send_goal
    assigns the goal handle after publishing the goal, and a result that arrives before that
    is dropped as "a goal handle that we're not tracking" (actionlib issue #206). The plain
    ActionClient's goal handle sees every transition."""
    from actionlib import CommState

    gh = client.send_goal(goal)
    deadline = time.monotonic() + timeout
    while gh.get_comm_state() != CommState.DONE:
        if time.monotonic() > deadline or rospy.is_shutdown():
            return None
        time.sleep(0.02)
    return gh.get_goal_status(), gh.get_goal_status_text()
