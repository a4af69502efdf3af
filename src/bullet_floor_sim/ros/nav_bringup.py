"""Resolve ``nav:=auto`` and launch a navigation launch file with the choice made.

roslaunch cannot branch on whether a package is installed, so a launch file given
``nav:=auto`` starts this node instead of its navigation nodes::

    nav_bringup $(find bullet_floor_sim)/launch/navigation.launch nav:=auto world:=office ...

It picks ``stock`` when ``rospack`` finds move_base, amcl and map_server (ros-noetic-navigation
is installed), else ``builtin`` (the embedded path follower), says which and why in the log,
and runs the same launch file with ``nav:=<choice>`` as its child: the launch file stays the
single description of both set-ups, and ``roslaunch --files``/``roslaunch-check`` see every node
when ``nav`` is given explicitly.
"""
from __future__ import annotations

import sys
import time
from typing import List, Optional, Tuple

__all__ = ["main", "resolve_nav", "launch_args"]

STOCK_PACKAGES = ("move_base", "amcl", "map_server")


def resolve_nav(requested: str, find=None) -> Tuple[str, str]:
    """The navigation to use and why.

    Args:
        requested: ``auto``, ``stock`` or ``builtin``.
        find: package -> path, raising on a missing package (default: rospkg's get_path).

    Returns:
        (``stock`` | ``builtin``, reason).

    Raises:
        ValueError: ``requested`` is none of the three.
    """
    if requested not in ("auto", "stock", "builtin"):
        raise ValueError("nav:=%r: expected auto, stock or builtin" % requested)
    if requested != "auto":
        return requested, "nav:=%s requested" % requested
    if find is None:
        import rospkg

        find = rospkg.RosPack().get_path
    missing = []
    for pkg in STOCK_PACKAGES:
        try:
            find(pkg)
        except Exception:  # rospkg.ResourceNotFound, or anything a custom finder raises
            missing.append(pkg)
    if missing:
        return "builtin", ("stock navigation not installed (rospack cannot find %s): using the "
                           "embedded path follower" % ", ".join(missing))
    return "stock", "found %s: using stock map_server + amcl + move_base" % ", ".join(
        STOCK_PACKAGES)


def launch_args(argv: List[str]) -> List[str]:
    """The launch file and its ``arg:=value`` pairs from the node's command line, without
    what roslaunch adds (``__name:=``, ``__log:=``) or a private parameter (``_x:=``).
    (rospy.myargv would drop every ``arg:=value`` too: it takes them all for remappings.)"""
    return [a for a in argv[1:] if not a.startswith("_")]


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point: ``nav_bringup LAUNCH_FILE [arg:=value ...]``."""
    import rospy
    import roslaunch

    rospy.init_node("nav_bringup")
    args = launch_args(argv if argv is not None else sys.argv)
    if not args:
        rospy.logfatal("nav_bringup: usage: nav_bringup LAUNCH_FILE [arg:=value ...]")
        return 2
    launch_file, given = args[0], args[1:]
    requested = "auto"
    rest = []
    for a in given:
        if a.startswith("nav:="):
            requested = a.split(":=", 1)[1]
        else:
            rest.append(a)
    try:
        mode, why = resolve_nav(requested)
    except ValueError as e:
        rospy.logfatal("nav_bringup: %s", e)
        return 2
    rospy.loginfo("nav_bringup: nav:=%s (%s)", mode, why)
    rospy.set_param("~nav", mode)
    run_id = rospy.get_param("/run_id", None) or roslaunch.rlutil.get_or_generate_uuid(None, False)
    parent = roslaunch.parent.ROSLaunchParent(run_id, [(launch_file, rest + ["nav:=" + mode])],
                                              is_core=False)
    parent.start()
    try:
        while not rospy.is_shutdown() and not parent.pm.is_shutdown:
            parent.spin_once()
            time.sleep(0.2)  # wall time: /clock may not run yet
    finally:
        parent.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
