"""Every launch file parses with roslaunch's own loader, for every nav choice, and the parameter
files it loads arrive under the right names with frame names that tf2 accepts.

The stock navigation stack is not packaged for Debian 12, so CI cannot run nav:=stock; this is
the check that those launch files (and config/*.yaml) are at least well formed and wired to the
right namespaces and frames. Needs the ROS environment (``$(find bullet_floor_sim)``), no roscore.
"""
import os

import pytest

roslaunch = pytest.importorskip("roslaunch")
from roslaunch.config import ROSLaunchConfig  # noqa: E402
from roslaunch.xmlloader import XmlLoader  # noqa: E402

LAUNCH = os.path.join(os.path.dirname(__file__), "..", "..", "launch")


def load(name, *args):
    config = ROSLaunchConfig()
    XmlLoader().load(os.path.join(LAUNCH, name), config, argv=["roslaunch"] + list(args),
                     verbose=False)
    nodes = {(n.namespace.rstrip("/") + "/" + n.name): n for n in config.nodes}
    params = {k: p.value for k, p in config.params.items()}
    return nodes, params


def frame_params(params):
    return {k: v for k, v in params.items()
            if isinstance(v, str) and (k.endswith("frame_id") or k.endswith("_frame"))}


@pytest.mark.parametrize("name,args", [
    ("sim.launch", ()),
    ("navigation.launch", ("nav:=auto",)),
    ("two_robots.launch", ("nav:=auto",)),
    ("rois.launch", ("rviz:=true",)),
    ("trajectories.launch", ()),
    ("markov_walker.launch", ("robot:=robot1",)),
    ("demo.launch", ("nav:=auto",)),
    ("observer.launch", ()),
    ("mapping.launch", ()),
    ("mapping.launch", ("slam:=embedded", "explore:=true", "nav:=builtin", "rviz:=true")),
    ("mapping.launch", ("slam:=gmapping", "explore:=true", "nav:=stock")),
])
def test_every_launch_file_parses(name, args):
    nodes, _ = load(name, *args)
    assert nodes


def test_navigation_stock_single_robot_bare_names():
    nodes, params = load("navigation.launch", "nav:=stock")
    assert {"/simulator", "/map_server", "/amcl", "/move_base"} <= set(nodes)
    assert params["/amcl/odom_frame_id"] == "odom"
    assert params["/amcl/base_frame_id"] == "base_footprint"
    assert params["/amcl/laser_model_type"] == "beam"
    assert params["/move_base/local_costmap/global_frame"] == "odom"
    assert params["/move_base/global_costmap/robot_base_frame"] == "base_footprint"
    assert params["/move_base/base_global_planner"] == "global_planner/GlobalPlanner"
    assert params["/simulator/ground_truth_tf"] is False
    assert params["/simulator/publish_initialpose"] is True
    assert params["/simulator/single_robot"] is True


def test_two_robots_stock_prefixed_frames_without_leading_slash():
    nodes, params = load("two_robots.launch", "nav:=stock")
    for robot in ("robot1", "robot2"):
        assert {"/%s/amcl" % robot, "/%s/move_base" % robot} <= set(nodes)
        assert params["/%s/amcl/odom_frame_id" % robot] == robot + "/odom"
        assert params["/%s/move_base/local_costmap/robot_base_frame" % robot] == \
            robot + "/base_footprint"
    frames = frame_params(params)
    assert frames and not [k for k, v in frames.items() if v.startswith("/")]


def test_builtin_navigation_runs_path_followers_only():
    nodes, params = load("two_robots.launch", "nav:=builtin")
    assert {"/robot1/path_follower", "/robot2/path_follower"} <= set(nodes)
    assert not [n for n in nodes if n.endswith(("/amcl", "/move_base"))]
    assert params["/simulator/ground_truth_tf"] is True


def test_demo_stock_walker_on_ground_truth_observer_on_amcl():
    nodes, params = load("demo.launch", "nav:=stock", "record:=true", "rviz:=false")
    assert {"/robot1/path_follower", "/robot1/markov_walker", "/robot2/amcl",
            "/robot2/move_base", "/soma_roi_manager", "/trajectory_recorder",
            "/trajectory_viewer", "/demo_record", "/map_server"} <= set(nodes)
    assert "/rviz" not in nodes
    assert params["/simulator/ground_truth_tf"] == ["robot1"]
    assert params["/trajectory_recorder/pose_topic"] == "/robot1/pose"
    assert "/robot1/pose" in nodes["/demo_record"].args
    # the observer localises its scans with amcl under stock navigation
    assert {"/robot2/people_tracker", "/robot2/destination_predictor",
            "/robot2/follower"} <= set(nodes)
    assert params["/robot2/people_tracker/pose_source"] == "amcl"
    assert params["/robot2/follower/base_frame"] == "robot2/base_footprint"


def test_demo_builtin_and_auto():
    nodes, params = load("demo.launch", "nav:=builtin")
    assert {"/robot1/path_follower", "/robot2/path_follower", "/rviz"} <= set(nodes)
    assert params["/simulator/ground_truth_tf"] is True
    assert params["/robot2/people_tracker/pose_source"] == "ground_truth"
    assert params["/robot2/follower/pose_source"] == "ground_truth"
    # the observer backs up to give way as the study's does; the walker never backs up
    from bullet_floor_sim.people.evaluation.scenario import OBSERVER_REVERSE, OBSERVER_REVERSE_PATH
    assert float(params["/robot2/path_follower/reverse_within"]) == OBSERVER_REVERSE
    assert float(params["/robot2/path_follower/reverse_path"]) == OBSERVER_REVERSE_PATH
    assert float(params.get("/robot1/path_follower/reverse_within", 0.0)) == 0.0
    assert float(params.get("/robot1/path_follower/reverse_path", 0.0)) == 0.0
    # ... and drives as the study's observer does (config/observer_drive.yaml); the walker
    # keeps the path_follower's defaults
    from bullet_floor_sim.people.evaluation.scenario import OBSERVER_DRIVE
    by_param = {("xy_goal_tolerance" if k == "xy_tolerance" else k): v
                for k, v in OBSERVER_DRIVE.items()}
    assert {k: float(params["/robot2/path_follower/" + k]) for k in by_param} == by_param
    assert not any("/robot1/path_follower/" + k in params for k in by_param)
    nodes, _ = load("demo.launch", "nav:=builtin", "observe:=false")
    assert not any("people_tracker" in n or "follower" == n.rsplit("/", 1)[-1] for n in nodes)
    nodes, _ = load("demo.launch")  # nav:=auto: nav_bringup decides at run time
    assert set(nodes) == {"/nav_bringup"}
    assert "demo.launch" in nodes["/nav_bringup"].args


@pytest.mark.parametrize("name", ["demo.launch", "navigation.launch", "two_robots.launch",
                                  "mapping.launch"])
def test_nav_bringup_forwards_every_launch_arg(name):
    """nav:=auto re-runs the file through nav_bringup: every arg the user can give must be in
    its args (an arg left out would silently fall back to its default)."""
    import re
    import xml.etree.ElementTree as ET

    root = ET.parse(os.path.join(LAUNCH, name)).getroot()
    declared = {a.get("name") for a in root.findall("arg") if a.get("value") is None}
    bringup = [n for n in root.iter("node") if n.get("type") == "nav_bringup"]
    assert len(bringup) == 1
    forwarded = dict(re.findall(r"(\w+):=(\$\(arg \w+\)|\S+)", bringup[0].get("args")))
    # nav:=auto (the navigation files), or the user's nav and slam (mapping.launch: either
    # may be auto)
    assert forwarded.pop("nav") in ("auto", "$(arg nav)")
    assert set(forwarded) == declared - {"nav"}
    assert all(v == "$(arg %s)" % k for k, v in forwarded.items())


def test_nav_bringup_keeps_the_launch_args_roslaunch_gives_it():
    """What roslaunch runs: the args attribute, then __name:= and __log:= (rospy.myargv
    drops every arg:=value: the user's world:=, people:= and the rest were lost)."""
    pytest.importorskip("rospy")
    from bullet_floor_sim.ros.nav_bringup import launch_args

    argv = ["/opt/nav_bringup", "/x/demo.launch", "nav:=auto", "world:=malaga_corridor",
            "people:=20", "__name:=nav_bringup", "__log:=/tmp/nav_bringup-2.log"]
    assert launch_args(argv) == ["/x/demo.launch", "nav:=auto", "world:=malaga_corridor",
                                 "people:=20"]


def test_mapping_embedded_explore_namespaced_and_single():
    """mapping.launch's nodes and frames: no /map and no ground-truth tf from the simulator,
    the mapper on the robot's scan and odometry frame, the explorer and the path follower in
    the robot's namespace, the follower localising by tf and planning through unknown space;
    with single_robot:=true the same with bare names."""
    nodes, params = load("mapping.launch", "slam:=embedded", "explore:=true", "nav:=builtin")
    assert {"/simulator", "/mapper", "/robot1/explorer", "/robot1/path_follower"} <= set(nodes)
    assert params["/simulator/publish_map"] is False
    assert params["/simulator/ground_truth_tf"] is False
    assert dict(nodes["/mapper"].remap_args)["scan"] == "/robot1/base_scan"
    assert params["/mapper/odom_frame"] == "robot1/odom"
    assert params["/robot1/explorer/base_frame"] == "robot1/base_footprint"
    assert dict(nodes["/robot1/explorer"].remap_args)["map"] == "/map"
    assert params["/robot1/path_follower/localisation"] == "tf"
    assert params["/robot1/path_follower/allow_unknown"] is True
    nodes, params = load("mapping.launch", "slam:=embedded", "explore:=true", "nav:=builtin",
                         "single_robot:=true")
    assert {"/mapper", "/explorer", "/path_follower"} <= set(nodes)
    assert dict(nodes["/mapper"].remap_args)["scan"] == "/base_scan"
    assert params["/mapper/odom_frame"] == "odom"
    assert params["/explorer/base_frame"] == "base_footprint"
    assert params["/simulator/single_robot"] is True
    nodes, _ = load("mapping.launch", "slam:=embedded", "rviz:=true", "single_robot:=true")
    assert nodes["/rviz"].args.endswith("rviz/mapping_single.rviz")
    nodes, _ = load("mapping.launch", "slam:=embedded", "rviz:=true")
    assert nodes["/rviz"].args.endswith("rviz/mapping.rviz")


def test_mapping_gmapping_and_stock_move_base_without_amcl():
    nodes, params = load("mapping.launch", "slam:=gmapping", "explore:=true", "nav:=stock")
    assert {"/slam_gmapping", "/robot1/move_base", "/robot1/explorer"} <= set(nodes)
    assert "/robot1/amcl" not in nodes and "/mapper" not in nodes
    assert params["/slam_gmapping/odom_frame"] == "robot1/odom"
    assert params["/slam_gmapping/base_frame"] == "robot1/base_footprint"
    assert params["/slam_gmapping/map_frame"] == "map"
    assert dict(nodes["/slam_gmapping"].remap_args)["scan"] == "/robot1/base_scan"
    assert params["/robot1/move_base/global_costmap/robot_base_frame"] == \
        "robot1/base_footprint"
    assert params["/robot1/move_base/GlobalPlanner/allow_unknown"] is True
    nodes, params = load("mapping.launch", "slam:=slam_toolbox")
    assert {"/slam_toolbox", "/simulator"} <= set(nodes)
    assert params["/slam_toolbox/scan_topic"] == "/robot1/base_scan"
    assert not any(n.endswith(("explorer", "move_base", "path_follower")) for n in nodes)
    nodes, _ = load("mapping.launch")             # slam:=auto: the bringup decides
    assert set(nodes) == {"/mapping_bringup"}


def test_slam_auto_takes_the_first_slam_package_installed():
    pytest.importorskip("rospy")
    from bullet_floor_sim.ros.nav_bringup import resolve_slam

    def finder(*installed):
        def find(pkg):
            if pkg not in installed:
                raise LookupError(pkg)
            return "/opt/" + pkg
        return find

    assert resolve_slam("auto", finder("gmapping", "slam_toolbox"))[0] == "gmapping"
    assert resolve_slam("auto", finder("slam_toolbox"))[0] == "slam_toolbox"
    choice, why = resolve_slam("auto", finder())
    assert choice == "embedded" and "gmapping or slam_toolbox" in why
    assert resolve_slam("embedded", finder("gmapping"))[0] == "embedded"
    with pytest.raises(ValueError, match="slam:='cartographer'"):
        resolve_slam("cartographer")
