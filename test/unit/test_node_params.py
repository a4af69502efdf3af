"""Node parameters: one way in (``config_from_params`` onto a dataclass with ``check()``).

The conversion refuses what rospy's typed parameters would otherwise turn into nonsense (a
string "false" as True, 2.5 as 2), and each node's parameter dataclass names the bad one.
"""
from __future__ import annotations

import re

import pytest

from bullet_floor_sim.errors import BulletFloorSimError, ConfigError
from bullet_floor_sim.overrides import convert
from bullet_floor_sim.ros.path_follower import PathFollowerParams
from bullet_floor_sim.ros.roi_manager import RoiManagerParams
from bullet_floor_sim.ros.trajectory_recorder import RecorderParams
from bullet_floor_sim.ros.trajectory_viewer import ViewerParams


@pytest.mark.parametrize("value, current, expected", [
    (3, 1.5, 3.0), (2.0, 7, 2), (True, False, True), ("x", "", "x"), (5, "", "5"),
    ([1, 2], [], [1, 2]), ({"a": 1}, None, {"a": 1}),
    # what roslaunch makes of <param value="...">: "1e3" and "inf" stay strings, 1/0 ints
    ("1e3", 1.0, 1000.0), ("inf", 1.0, float("inf")), ("4", 7, 4), (1, False, True),
    (0, True, False), ("false", True, False), ("True", False, True)])
def test_values_convert_to_the_fields_type(value, current, expected):
    got = convert("~p", value, current)
    assert got == expected and type(got) is type(expected)


@pytest.mark.parametrize("value, current, problem", [
    ("no", False, "expected true or false"), (2, True, "expected true or false"),
    (0.0, True, "expected true or false"), ("0.5x", 1.0, "expected a number"),
    (True, 1.0, "expected a number"), ([1], 1.0, "expected a number"),
    (2.5, 3, "expected a whole number"), ("2.5", 3, "expected a whole number"),
    ("a,b", [], "expected a list")])
def test_a_value_of_the_wrong_kind_is_one_error_naming_the_parameter(value, current, problem):
    with pytest.raises(ConfigError, match=r"^~p: %s, got %s$" % (problem, re.escape(repr(value)))):
        convert("~p", value, current)


_GT, _GE = " must be a finite number > 0, got ", " must be a finite number >= 0, got "


@pytest.mark.parametrize("params, message", [
    (PathFollowerParams(max_linear=-0.5), r"^path_follower: ~max_linear" + _GT + r"-0\.5$"),
    (PathFollowerParams(reverse_within=-1.0), r"~reverse_within" + _GE + r"-1\.0"),
    (PathFollowerParams(reverse_path=-1.0), r"~reverse_path" + _GE + r"-1\.0"),
    (PathFollowerParams(rotate_in_place=0.0), r"~rotate_in_place" + _GT + r"0\.0"),
    (PathFollowerParams(slow_radius=float("inf")), r"~slow_radius" + _GT + "inf"),
    (PathFollowerParams(stop_distance=-0.1), r"~stop_distance" + _GE + r"-0\.1"),
    (PathFollowerParams(side_margin=-0.1), r"~side_margin" + _GE + r"-0\.1"),
    (PathFollowerParams(controller_frequency=float("nan")), r"~controller_frequency" + _GT + "nan"),
    (PathFollowerParams(inflation_radius=-0.1), r"~inflation_radius" + _GE + r"-0\.1"),
    (PathFollowerParams(detour=-1.0), r"~detour" + _GE + r"-1\.0"),
    (PathFollowerParams(detour_wait=0.0), r"~detour_wait" + _GT + r"0\.0"),
    (PathFollowerParams(goal_taken_within=-1.0), r"~goal_taken_within" + _GE + r"-1\.0"),
    (RecorderParams(db_timeout=0.0), r"^trajectory_recorder: ~db_timeout" + _GT + r"0\.0$"),
    (RecorderParams(flush_every=-1.0), r"trajectory_recorder: ~flush_every" + _GE + r"-1\.0"),
    (RecorderParams(path_rate=-1.0), r"trajectory_recorder: ~path_rate" + _GE + r"-1\.0"),
    (RoiManagerParams(save_quiet=-0.5), r"roi_manager: ~save_quiet" + _GE + r"-0\.5"),
    (RoiManagerParams(new_roi_size=0.0), r"roi_manager: ~new_roi_size" + _GT + r"0\.0"),
    (ViewerParams(max_points=1), r"^trajectory_viewer: ~max_points must be an integer >= 2, got 1$"),
    (ViewerParams(refresh_period=-2.0), r"~refresh_period" + _GE + r"-2\.0")])
def test_each_nodes_parameters_check_names_the_bad_one(params, message):
    with pytest.raises(BulletFloorSimError, match=message):
        params.check()


def test_the_defaults_and_the_documented_zeros_pass_their_checks():
    for cls in (PathFollowerParams, RecorderParams, RoiManagerParams, ViewerParams):
        cls().check()
    PathFollowerParams(inflation_radius=0.0, goal_taken_within=0.0).check()   # none; never
    PathFollowerParams(stop_distance=0.0, side_margin=0.0).check()   # no stop check; none beside
    RoiManagerParams(sync_period=0.0, save_quiet=0.0).check()         # no sync; save at once
    RecorderParams(flush_every=0.0, path_rate=0.0).check()            # every pose; no path
    assert PathFollowerParams().robot_radius == 0.34 and ViewerParams().max_poses == 100000


def _closed_inside_a_publish() -> AttributeError:
    """What rospy's publish raises when its topic is closed between its closed check and
    its use of the buffer: a real _PublisherImpl, closed, caught in that window."""
    import rospy.topics
    from std_msgs.msg import String

    impl = rospy.topics._PublisherImpl("/bfs_test", String)
    impl.close()
    impl.closed, impl.connections = False, [object()]   # (the check passed before the close)
    try:
        impl.publish(String("x"))
    except AttributeError as e:
        return e
    raise AssertionError("rospy's publish did not fail on a closed buffer")


def test_a_callback_that_publishes_ends_quietly_only_at_shutdown(monkeypatch):
    """ros/node.quiet_at_shutdown: a ROSException (a publish to a closed topic) or an
    AttributeError raised inside rospy's topics.py (the topic closed inside the publish) is
    dropped once a shutdown has been asked for (rospy closes its topics in a pre-shutdown
    hook, before is_shutdown() is true), and raised before; an AttributeError of our own and
    any other exception always go on."""
    import rospy

    from bullet_floor_sim.ros.node import quiet_at_shutdown

    calls = []

    @quiet_at_shutdown
    def callback(msg, error=rospy.ROSException("publish() to a closed topic")):
        calls.append(msg)
        raise error

    closed_inside = _closed_inside_a_publish()
    monkeypatch.setattr(rospy, "is_shutdown", lambda: False)
    monkeypatch.setattr(rospy.core, "is_shutdown_requested", lambda: False)
    with pytest.raises(rospy.ROSException, match="closed topic"):
        callback(1)
    with pytest.raises(AttributeError):
        callback(2, closed_inside)
    monkeypatch.setattr(rospy.core, "is_shutdown_requested", lambda: True)  # the hooks run
    assert callback(3) is None and callback(4, closed_inside) is None
    assert calls == [1, 2, 3, 4]
    with pytest.raises(AttributeError, match="ours"):
        callback(5, AttributeError("ours"))          # not raised in rospy: a real fault
    with pytest.raises(ValueError):
        callback(6, ValueError("a real fault"))


def test_startup_grace_debug_first_then_a_warning_per_key(monkeypatch):
    """ros/node.StartupGrace: each key is debug for its first ``seconds``, then a warning;
    each key and level is throttled on its own (one key's lines never hold back another's)."""
    import rospy

    from bullet_floor_sim.ros import node

    clock = [100.0]
    monkeypatch.setattr(node.time, "monotonic", lambda: clock[0])
    got = []
    monkeypatch.setattr(rospy, "logdebug", lambda fmt, *a: got.append(("debug", fmt % a)))
    monkeypatch.setattr(rospy, "logwarn", lambda fmt, *a: got.append(("warn", fmt % a)))
    grace = node.StartupGrace(seconds=5.0)
    grace.log("map", 10.0, "no %s", "map")
    grace.log("tf", 10.0, "no %s", "tf")
    clock[0] = 103.0
    grace.log("map", 10.0, "no %s", "map")          # throttled (3 s after its last)
    clock[0] = 105.5
    grace.log("map", 10.0, "no %s", "map")          # late: its first warning at once
    grace.log("tf", 10.0, "no %s", "tf")            # and the other key's too
    clock[0] = 110.0
    grace.log("map", 10.0, "no %s", "map")          # throttled warning
    assert got == [("debug", "no map"), ("debug", "no tf"), ("warn", "no map"),
                   ("warn", "no tf")]


@pytest.mark.parametrize("value, mode", [
    ("builtin", "builtin"), ("process", "process"), ("none", "none"), (True, "builtin"),
    (False, "none"), ("true", "builtin"), ("False", "none"), (1, "builtin"), (" Process ", "process")])
def test_robot_state_publishers_modes(value, mode):
    from bullet_floor_sim.ros.sim.rsp import state_publisher_mode

    assert state_publisher_mode(value) == mode


def test_an_unknown_robot_state_publishers_mode_is_named():
    from bullet_floor_sim.ros.sim.rsp import state_publisher_mode

    with pytest.raises(ConfigError, match=r"~robot_state_publishers: 'kdl' is none of builtin, "
                                          r"process, none \(or true, false\)"):
        state_publisher_mode("kdl")
