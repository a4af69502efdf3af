"""Keyboard teleop (Debian packages no teleop node), like MORSE's Keyboard actuator.

``rosrun bullet_floor_sim teleop_keyboard _robot:=robot1`` publishes ``/robot1/cmd_vel``
(``_robot:=""`` publishes ``/cmd_vel``). Keys: arrows or W/S (forward/back), A/D (turn left/
right), Q/E (strafe left/right, omni drives), +/- (speed up/down by 10 %), space = stop,
Ctrl-C or X = quit. The command is re-sent at ``~rate`` Hz (10) so the simulator's 0.5 s
watchdog does not stop the robot while a motion is selected.
"""
from __future__ import annotations

import select
import sys
from typing import Optional, Tuple

__all__ = ["Teleop", "main"]

_KEYS = {
    "w": (1, 0, 0), "\x1b[A": (1, 0, 0),
    "s": (-1, 0, 0), "\x1b[B": (-1, 0, 0),
    "a": (0, 0, 1), "\x1b[D": (0, 0, 1),
    "d": (0, 0, -1), "\x1b[C": (0, 0, -1),
    "q": (0, 1, 0), "e": (0, -1, 0),
}


class Teleop:
    """Key presses -> body velocity command (vx, vy, w); pure, no ROS.

    Args:
        linear: speed of a linear key press, m/s.
        angular: speed of a turn key press, rad/s.
    """

    def __init__(self, linear: float = 0.3, angular: float = 0.6) -> None:
        self.linear = linear
        self.angular = angular
        self.direction: Tuple[int, int, int] = (0, 0, 0)

    def key(self, k: str) -> bool:
        """Apply one key; returns False when the user asked to quit."""
        k = k.lower() if len(k) == 1 else k
        if k in ("x", "\x03"):
            return False
        if k == " ":
            self.direction = (0, 0, 0)
        elif k in ("+", "="):
            self.linear *= 1.1
            self.angular *= 1.1
        elif k in ("-", "_"):
            self.linear /= 1.1
            self.angular /= 1.1
        elif k in _KEYS:
            self.direction = _KEYS[k]
        return True

    def command(self) -> Tuple[float, float, float]:
        """Current (vx, vy, w)."""
        fx, fy, fw = self.direction
        return (fx * self.linear, fy * self.linear, fw * self.angular)


def _read_key(timeout: float) -> Optional[str]:
    r, _, _ = select.select([sys.stdin], [], [], timeout)
    if not r:
        return None
    k = sys.stdin.read(1)
    if k == "\x1b":  # arrow keys: ESC [ A..D
        k += sys.stdin.read(2)
    return k


def main(argv=None) -> int:
    """Entry point of ``rosrun bullet_floor_sim teleop_keyboard``."""
    import termios
    import tty

    import rospy
    from geometry_msgs.msg import Twist

    rospy.init_node("teleop_keyboard", anonymous=True)
    robot = str(rospy.get_param("~robot", "robot1"))
    topic = "/%s/cmd_vel" % robot if robot else "/cmd_vel"
    pub = rospy.Publisher(topic, Twist, queue_size=1)
    period = 1.0 / float(rospy.get_param("~rate", 10.0))
    tele = Teleop(float(rospy.get_param("~linear", 0.3)), float(rospy.get_param("~angular", 0.6)))
    if not sys.stdin.isatty():
        rospy.logfatal("teleop_keyboard: needs a terminal (run it with rosrun, not in a launch "
                       "file without launch-prefix)")
        return 1
    print("teleop_keyboard -> %s\n  W/up S/down: forward/back  A/left D/right: turn  Q/E: "
          "strafe\n  +/-: speed  space: stop  X or Ctrl-C: quit" % topic)
    saved = termios.tcgetattr(sys.stdin)
    try:
        tty.setraw(sys.stdin.fileno())
        while not rospy.is_shutdown():
            k = _read_key(period)
            if k is not None and not tele.key(k):
                break
            vx, vy, w = tele.command()
            msg = Twist()
            msg.linear.x, msg.linear.y, msg.angular.z = vx, vy, w
            pub.publish(msg)
    finally:
        termios.tcsetattr(sys.stdin, termios.TCSADRAIN, saved)
        pub.publish(Twist())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
