"""Resolve ``nav:=auto`` and ``slam:=auto`` and launch a launch file with the choices made.

roslaunch cannot branch on whether a package is installed, so a launch file given
``nav:=auto`` (or mapping.launch given ``slam:=auto``) starts this node instead of its
navigation (SLAM) nodes::

    nav_bringup $(find bullet_floor_sim)/launch/navigation.launch nav:=auto world:=office ...

For ``nav`` it picks ``stock`` when ``rospack`` finds move_base, amcl and map_server
(ros-noetic-navigation is installed), else ``builtin`` (the embedded path follower); for
``slam``, ``gmapping`` when rospack finds it, else ``slam_toolbox``, else ``embedded`` (our
mapper). It says which and why in the log, and runs the same launch file with the choices as
its child: the launch file stays the single description of every set-up, and
``roslaunch --files``/``roslaunch-check`` see every node when the choices are given
explicitly.
"""
from __future__ import annotations

import sys
import time
from typing import List, Optional, Tuple

__all__ = ["main", "resolve_nav", "resolve_slam", "launch_args"]

STOCK_PACKAGES = ("move_base", "amcl", "map_server")
#: the SLAM packages slam:=auto looks for, in order of preference (gmapping: the tutorial's)
SLAM_PACKAGES = ("gmapping", "slam_toolbox")
SLAM_CHOICES = SLAM_PACKAGES + ("embedded",)


def _finder(find):
    if find is not None:
        return find
    import rospkg

    return rospkg.RosPack().get_path


def _installed(pkg: str, find) -> bool:
    try:
        find(pkg)
    except Exception:  # rospkg.ResourceNotFound, or anything a custom finder raises
        return False
    return True


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
    find = _finder(find)
    missing = [pkg for pkg in STOCK_PACKAGES if not _installed(pkg, find)]
    if missing:
        return "builtin", ("stock navigation not installed (rospack cannot find %s): using the "
                           "embedded path follower" % ", ".join(missing))
    return "stock", "found %s: using stock map_server + amcl + move_base" % ", ".join(
        STOCK_PACKAGES)


def resolve_slam(requested: str, find=None) -> Tuple[str, str]:
    """The mapper to use and why: ``gmapping``, ``slam_toolbox`` or ``embedded`` (as
    :func:`resolve_nav`; ``auto`` takes the first SLAM package installed).

    Raises:
        ValueError: ``requested`` is not auto or one of the three.
    """
    if requested not in SLAM_CHOICES + ("auto",):
        raise ValueError("slam:=%r: expected auto, %s" % (requested, ", ".join(SLAM_CHOICES)))
    if requested != "auto":
        return requested, "slam:=%s requested" % requested
    find = _finder(find)
    for pkg in SLAM_PACKAGES:
        if _installed(pkg, find):
            return pkg, "found %s: using it" % pkg
    return "embedded", ("no SLAM package installed (rospack cannot find %s): using the "
                        "embedded mapper" % " or ".join(SLAM_PACKAGES))


#: what each ``<arg>:=auto`` is resolved by
RESOLVERS = {"nav": resolve_nav, "slam": resolve_slam}


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
    requested = {"nav": "auto"}             # nav is always resolved; slam when it is given
    rest = []
    for a in given:
        key, _, value = a.partition(":=")
        if key in RESOLVERS:
            requested[key] = value
        else:
            rest.append(a)
    for key, value in requested.items():
        try:
            choice, why = RESOLVERS[key](value)
        except ValueError as e:
            rospy.logfatal("nav_bringup: %s", e)
            return 2
        rospy.loginfo("nav_bringup: %s:=%s (%s)", key, choice, why)
        rospy.set_param("~" + key, choice)
        rest.append("%s:=%s" % (key, choice))
    run_id = rospy.get_param("/run_id", None) or roslaunch.rlutil.get_or_generate_uuid(None, False)
    parent = roslaunch.parent.ROSLaunchParent(run_id, [(launch_file, rest)],
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
