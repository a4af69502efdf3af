"""The embedded navigation default: a move_base-compatible action server over nav/planner.py.

Run it in a robot's namespace (``<group ns="robot1">``), or at the root for a robot with an empty
name. Like move_base it serves ``move_base`` (move_base_msgs/MoveBaseAction: feedback with the
current pose, preemption by a new goal or a cancel, ABORTED with a reason when there is no
path) and turns ``move_base_simple/goal`` (PoseStamped) into an action goal. It localises from
ground truth (``base_pose_ground_truth``), or with ``~localisation:=tf`` from ``odom`` and the
tf from ``~global_frame`` to odometry's frame (a SLAM node's or amcl's correction), reads
obstacles from ``base_scan``, drives ``cmd_vel``, and plans on the map from ``~map_topic``
(``/map``: the simulator's, map_server's or a mapper's, taken again whenever it changes).
The plan is published where stock move_base with global_planner publishes it,
``move_base/GlobalPlanner/plan``, so one rviz config serves both.

Parameters (defaults suit a Scitos A5): ``~robot_radius`` 0.34, ``~inflation_radius`` 0.6,
``~planning_resolution`` 0.1, ``~max_linear`` 0.6, ``~max_angular`` 1.2,
``~xy_goal_tolerance`` 0.15, ``~yaw_goal_tolerance`` 0.15, ``~rotate_in_place`` 0.9 (rad:
turn on the spot above this heading error), ``~slow_radius`` 1 (m from the goal where the speed
starts to fall), ``~stop_distance`` 0.3 (m of free space needed ahead to keep driving; 0: none),
``~side_margin`` 0.03 (m beside the footprint in the stop check; 0: none; these four are
nav/pursuit.FollowerConfig's; demo.launch's observer sets them and ``~xy_goal_tolerance``
from config/observer_drive.yaml), ``~controller_frequency`` 10,
``~blocked_timeout`` 30, ``~progress_timeout`` 60, ``~give_way`` false (true: when blocked
where no path passes, retreat to a wider place, wait and go on: nav/planner.Navigator),
``~keep_way`` false (true: in a passage too narrow for two, never yield by the passing rule,
only after 20 s blocked: the walker, nav/navigator_config.NavigatorConfig), ``~reverse_within`` 0
(m; > 0: a goal at most this far behind, on a straight way, that faces the robot's own way is
reached backing up, nav/pursuit.FollowerConfig: demo.launch's observer, 2), ``~reverse_path`` 0
(m; > 0: a goal at most this far along its path that faces back the way it arrives is reached
backing along the path, unless the path passes nearer than 1 m to something the scan shows off
the map), ``~detour`` 10 and
``~detour_wait`` 10 (a way round what blocks it more than 10 m longer is taken only after
10 s blocked; 0: at once), ``~goal_taken_within`` 1.5 (within this of its goal, with
something not on the map standing on the goal for 1 s and no progress for 10 s, the goal is
aborted as taken; 0: never),
``~global_frame`` map, ``~map_topic`` /map, ``~localisation`` ground_truth | tf,
``~allow_unknown`` false (true: plan through unknown space, as navfn's ``allow_unknown``;
exploration needs it).
"""
from __future__ import annotations

import math
import sys
import threading
from dataclasses import dataclass, fields
from typing import List, Optional

import actionlib
import numpy as np
import rospy
import tf2_geometry_msgs  # noqa: F401  (registers PoseStamped with tf2)
import tf2_ros
from geometry_msgs.msg import PoseStamped, Twist
from move_base_msgs.msg import (MoveBaseAction, MoveBaseActionGoal, MoveBaseFeedback,
                                MoveBaseResult)
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from sensor_msgs.msg import LaserScan

from ..nav.navigator import GOAL_TAKEN
from ..nav.planner import (FollowerConfig, Navigator, NavigatorConfig, PlanError,
                            PlannerConfig, PlanningGrid, PathFollower, obstacles_in_base,
                            path_length)
from ..errors import BulletFloorSimError
from ..geometry import compose
from ..sim.floormap import crop_known
from ..sim.solidmap import while_mapping
from .convert import grid_from_msg, planar, yaw as yaw_of
from .params import check_params, config_from_params, map_handling
from .node import StartupGrace, TfOnDemand, quiet_at_shutdown, run_node

__all__ = ["main", "PathFollowerNode"]



@dataclass
class PathFollowerParams:
    """The node's parameters (``~<field>``: see the module doc), checked."""

    robot_radius: float = PlannerConfig.robot_radius
    inflation_radius: float = 0.6
    planning_resolution: float = 0.1
    max_linear: float = 0.6
    max_angular: float = 1.2
    xy_goal_tolerance: float = 0.15
    yaw_goal_tolerance: float = 0.15
    rotate_in_place: float = FollowerConfig.rotate_in_place
    slow_radius: float = FollowerConfig.slow_radius
    stop_distance: float = FollowerConfig.stop_distance
    side_margin: float = FollowerConfig.side_margin
    controller_frequency: float = 10.0
    blocked_timeout: float = NavigatorConfig.blocked_timeout
    progress_timeout: float = NavigatorConfig.progress_timeout
    give_way: bool = False
    keep_way: bool = False
    reverse_within: float = 0.0
    reverse_path: float = 0.0
    detour: float = NavigatorConfig.detour
    detour_wait: float = NavigatorConfig.detour_wait
    goal_taken_within: float = NavigatorConfig.goal_taken_within
    global_frame: str = "map"
    map_topic: str = "/map"
    localisation: str = "ground_truth"
    allow_unknown: bool = False

    def check(self) -> None:
        """Raises BulletFloorSimError naming the first parameter that is not a finite number
        > 0 (>= 0 for ``inflation_radius``, ``detour``, ``goal_taken_within``,
        ``reverse_within``, ``reverse_path``, ``stop_distance`` and ``side_margin``: 0 turns
        each off)."""
        numbers = [f.name for f in fields(self) if isinstance(getattr(self, f.name), float)]
        zero_ok = ("inflation_radius", "detour", "goal_taken_within", "reverse_within",
                   "reverse_path", "stop_distance", "side_margin")
        check_params(self, "path_follower", [n for n in numbers if n not in zero_ok])
        check_params(self, "path_follower", list(zero_ok), strict=False)
        if self.localisation not in ("ground_truth", "tf"):
            raise BulletFloorSimError("path_follower: ~localisation must be ground_truth or tf, "
                                      "got %r" % self.localisation)


class PathFollowerNode:
    """Action server + control loop; the planning itself lives in nav/planner.py."""

    def __init__(self) -> None:
        p = config_from_params(PathFollowerParams())
        self.planner_cfg = PlannerConfig(robot_radius=p.robot_radius,
                                         inflation_radius=p.inflation_radius,
                                         resolution=p.planning_resolution,
                                         unknown_is_obstacle=not p.allow_unknown)
        self.allow_unknown = p.allow_unknown
        self.follower_cfg = FollowerConfig(
            robot_radius=p.robot_radius, max_linear=p.max_linear, max_angular=p.max_angular,
            xy_tolerance=p.xy_goal_tolerance, yaw_tolerance=p.yaw_goal_tolerance,
            rotate_in_place=p.rotate_in_place, slow_radius=p.slow_radius,
            stop_distance=p.stop_distance, side_margin=p.side_margin,
            reverse_within=p.reverse_within, reverse_path=p.reverse_path)
        self.nav_cfg = NavigatorConfig(blocked_timeout=p.blocked_timeout,
                                       progress_timeout=p.progress_timeout, give_way=p.give_way,
                                       keep_way=p.keep_way, detour=p.detour,
                                       detour_wait=p.detour_wait,
                                       goal_taken_within=p.goal_taken_within,
                                       # mapping: the map is partial, so are its passing places
                                       passing=not p.allow_unknown)
        self.rate_hz = p.controller_frequency
        self.global_frame = p.global_frame
        self.grid: Optional[PlanningGrid] = None
        self._last_nav: Optional[Navigator] = None   # the last goal's
        self.pose = None  # (x, y, yaw) in map
        self.base_frame = ""
        self.obstacles: Optional[np.ndarray] = None
        self.laser = {}  # laser frame -> (x, y, yaw) in the base frame
        self.startup = StartupGrace()
        self.tf = TfOnDemand()
        self.tf_buffer = self.tf.buffer
        self.gt_only = p.localisation == "ground_truth"
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.plan_pub = rospy.Publisher("move_base/GlobalPlanner/plan", Path, queue_size=1,
                                        latch=True)
        self.goal_pub = rospy.Publisher("move_base/goal", MoveBaseActionGoal, queue_size=1)
        self.have_map = threading.Event()
        rospy.Subscriber(p.map_topic, OccupancyGrid, self._on_map,
                         queue_size=1)
        if p.localisation == "tf":
            rospy.Subscriber("odom", Odometry, self._on_odom, queue_size=1)
        else:
            rospy.Subscriber("base_pose_ground_truth", Odometry, self._on_pose, queue_size=1)
        rospy.Subscriber("base_scan", LaserScan, self._on_scan, queue_size=1)
        rospy.Subscriber("move_base_simple/goal", PoseStamped, self._on_simple_goal,
                         queue_size=1)
        self.server = actionlib.SimpleActionServer("move_base", MoveBaseAction,
                                                   execute_cb=self._execute, auto_start=False)
        self.server.start()
        rospy.loginfo("path_follower: serving %s (embedded navigation, %s localisation%s)",
                      rospy.resolve_name("move_base"), p.localisation.replace("_", "-"),
                      ", unknown space passable" if p.allow_unknown else "")

    # -- inputs ------------------------------------------------------------------------------
    def _on_map(self, msg: OccupancyGrid) -> None:
        try:
            handling = map_handling()
            if self.allow_unknown:
                handling = while_mapping(handling)
            fmap = grid_from_msg(msg)
            if self.allow_unknown:   # a map being built: plan on its known part and a margin
                fmap = crop_known(fmap, 3.0)
            self.grid = PlanningGrid(fmap, self.planner_cfg, handling=handling)
        except Exception as e:  # a broken map must not kill the node: say so and keep the old
            rospy.logerr("path_follower: cannot use the map (%s): %s", msg.header.frame_id, e)
            return
        self.have_map.set()
        rospy.loginfo("path_follower: map %dx%d at %.3f m, planning at %.2f m",
                      msg.info.width, msg.info.height, msg.info.resolution,
                      self.grid.resolution)

    def _on_pose(self, msg: Odometry) -> None:
        p = msg.pose.pose
        self.base_frame = msg.child_frame_id
        self.pose = (p.position.x, p.position.y, yaw_of(p.orientation))

    def _on_odom(self, msg: Odometry) -> None:
        """The pose in the global frame: odometry carried by the tf from the global frame to
        odometry's frame (map -> odom)."""
        try:
            t = self.tf_buffer.lookup_transform(self.global_frame, msg.header.frame_id,
                                                rospy.Time(0))
        except tf2_ros.TransformException as e:
            rospy.logwarn_throttle(10.0, "path_follower: no transform %s -> %s yet: %s",
                                   self.global_frame, msg.header.frame_id, e)
            return
        p = msg.pose.pose
        self.base_frame = msg.child_frame_id
        self.pose = compose(planar(t.transform),
                            (p.position.x, p.position.y, yaw_of(p.orientation)))

    def _on_scan(self, msg: LaserScan) -> None:
        laser = self.laser.get(msg.header.frame_id)
        if laser is None:
            if not self.base_frame:
                return
            try:
                t = self.tf_buffer.lookup_transform(self.base_frame, msg.header.frame_id,
                                                    rospy.Time(0), rospy.Duration(0.5))
            except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                    tf2_ros.ExtrapolationException, tf2_ros.TransformException) as e:
                # the first scans may come before robot_state_publisher's static transforms:
                # a warning only when the laser's stays missing
                self.startup.log(msg.header.frame_id, 10.0, "path_follower: no transform %s -> "
                                 "%s yet: %s", self.base_frame, msg.header.frame_id, e)
                return
            laser = planar(t.transform)
            self.laser[msg.header.frame_id] = laser
            if self.gt_only:   # tf only for a goal given in another frame from now on
                self.tf.stop()
        self.obstacles = obstacles_in_base(msg.ranges, msg.angle_min, msg.angle_increment,
                                           msg.range_max, laser)

    def _on_simple_goal(self, msg: PoseStamped) -> None:
        """As move_base: wrap a PoseStamped into an action goal on our own server."""
        g = MoveBaseActionGoal()
        g.header.stamp = rospy.Time.now()
        g.goal.target_pose = msg
        self.goal_pub.publish(g)

    # -- the action ---------------------------------------------------------------------------
    def _goal_in_map(self, target: PoseStamped):
        """(x, y, yaw) of a goal in the global frame, or raise PlanError with the reason."""
        q = target.pose.orientation
        vals = [target.pose.position.x, target.pose.position.y, q.x, q.y, q.z, q.w]
        if not all(math.isfinite(v) for v in vals):
            raise PlanError("goal has a non-finite value: %s" % vals)
        if abs(math.sqrt(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2) - 1.0) > 1e-2:
            raise PlanError("goal orientation is not a unit quaternion (%.3f, %.3f, %.3f, %.3f)"
                            % (q.x, q.y, q.z, q.w))
        frame = target.header.frame_id.lstrip("/")
        if frame and frame != self.global_frame:
            self.tf.listen()
            try:
                target = self.tf_buffer.transform(target, self.global_frame,
                                                  rospy.Duration(1.0))
            except tf2_ros.TransformException as e:
                raise PlanError("cannot transform the goal from %r to %r: %s"
                                % (frame, self.global_frame, e))
        p = target.pose
        return p.position.x, p.position.y, yaw_of(p.orientation)

    def _execute(self, goal) -> None:
        """The action's execute callback: the goal always ends with a terminal status (a
        shutdown while it runs aborts it; actionlib warns of a goal left open, and aborts it
        itself after any other exception). A shutdown counts from the moment it is asked
        for: rospy closes the topics in a pre-shutdown hook, before ``rospy.is_shutdown()``
        turns true, and a goal ended then by a closed topic was left open (one CI run's
        demo_log.test, session 49)."""
        try:
            # at Ctrl-C a publish to a closed topic ends the goal quietly; any other time
            # actionlib logs the exception and aborts the goal
            quiet_at_shutdown(self._run_goal)(goal)
        finally:
            if self.server.is_active() and rospy.core.is_shutdown_requested():
                # the abort first: actionlib sets the status before it publishes, so a topic
                # the shutdown closed cannot leave the goal open (a stop published first
                # could raise and skip the abort); then the stop, each quiet on its own
                quiet_at_shutdown(self.server.set_aborted)(
                    MoveBaseResult(), "path_follower stopped (shutdown) before the goal ended")
                quiet_at_shutdown(self.cmd_pub.publish)(Twist())

    def _run_goal(self, goal) -> None:
        stop = Twist()
        deadline = rospy.Time.now() + rospy.Duration(10.0)
        while (self.grid is None or self.pose is None) and not rospy.is_shutdown():
            if rospy.Time.now() > deadline:
                self.server.set_aborted(MoveBaseResult(), "no map or no ground-truth pose yet "
                                        "(is the simulator running and /map published?)")
                return
            rospy.sleep(0.1)
        if rospy.is_shutdown():   # shut down before a map or a pose came: _execute aborts
            return
        nav = Navigator(self.grid, PathFollower(self.follower_cfg), self.nav_cfg,
                        after=self._last_nav)
        self._last_nav = nav
        t0 = rospy.Time.now()
        try:
            target = self._goal_in_map(goal.target_pose)
            path = nav.start(self.pose, target, t0.to_sec())
        except PlanError as e:
            rospy.logwarn("path_follower: goal aborted: %s", e)
            self.server.set_aborted(MoveBaseResult(), str(e))
            return
        rospy.loginfo("path_follower: goal (%.2f, %.2f, %.2f): path of %.1f m", target[0],
                      target[1], target[2], path_length(path))
        self._publish_plan(path)
        replans, retreats, logged = 0, 0, ("", -math.inf)   # (last recovery logged, when)
        rate = rospy.Rate(self.rate_hz)
        fb = MoveBaseFeedback()
        fb.base_position.header.frame_id = self.global_frame
        while not rospy.is_shutdown():
            if self.server.is_preempt_requested():
                self.cmd_pub.publish(stop)
                nav.cancel()
                self.server.set_preempted(MoveBaseResult(), "preempted")
                return
            now = rospy.Time.now()
            st = nav.update(self.pose, self.obstacles, now.to_sec())
            if st.state != "active":
                self.cmd_pub.publish(stop)
                took = (now - t0).to_sec()
                if st.state == "succeeded":
                    rospy.loginfo("path_follower: goal reached in %.1f s", took)
                    self.server.set_succeeded(MoveBaseResult(), "goal reached")
                else:
                    # someone standing on the goal is an everyday end (the client is told
                    # why, and the walker picks another spot): not a warning
                    log = rospy.loginfo if st.message.startswith(GOAL_TAKEN) else rospy.logwarn
                    log("path_follower: goal aborted after %.1f s: %s", took, st.message)
                    self.server.set_aborted(MoveBaseResult(), st.message)
                return
            cmd = Twist()
            cmd.linear.x, cmd.angular.z = st.v, st.w
            self.cmd_pub.publish(cmd)
            if nav.replans != replans or nav.retreats != retreats:
                replans, retreats = nav.replans, nav.retreats
                self._publish_plan(nav.path)
            doing = _recovery(nav, st)
            if doing and (doing != logged[0] or now.to_sec() - logged[1] >= 5.0):
                logged = (doing, now.to_sec())
                rospy.loginfo("path_follower: %s, %.2f m from the goal", doing,
                              st.distance_to_goal)
            x, y, yaw = self.pose
            fb.base_position.header.stamp = now
            fb.base_position.pose.position.x, fb.base_position.pose.position.y = x, y
            fb.base_position.pose.orientation.z = math.sin(yaw / 2.0)
            fb.base_position.pose.orientation.w = math.cos(yaw / 2.0)
            self.server.publish_feedback(fb)
            try:
                rate.sleep()
            except rospy.ROSTimeMovedBackwardsException:   # (a ROSInterruptException too)
                pass
            except rospy.ROSInterruptException:
                return

    def _publish_plan(self, path: np.ndarray) -> None:
        msg = Path()
        msg.header.frame_id = self.global_frame
        msg.header.stamp = rospy.Time.now()
        for x, y in path:
            ps = PoseStamped()
            ps.header = msg.header
            ps.pose.position.x, ps.pose.position.y = float(x), float(y)
            ps.pose.orientation.w = 1.0
            msg.poses.append(ps)
        self.plan_pub.publish(msg)


def _recovery(nav: Navigator, st) -> str:
    """What the navigator does to get past something, or the controller backing up to a
    goal behind, for the log ('' when it just follows its path): a goal aborted for good in
    CI had left no trace of how it got stuck."""
    if nav.retreat is not None:
        return "giving way: out of the way to (%.2f, %.2f)" % nav.retreat
    if st.message == "blocked":
        return "blocked by something the scan shows on the path: planning around it"
    if st.message in ("stalled", "backing up", "nudging forward", "giving way"):
        return st.message
    if st.message == "reversing":   # the controller's own: ~reverse_within, ~reverse_path
        return "backing up to a goal behind it (~reverse_within, ~reverse_path)"
    return ""


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim path_follower``."""
    return run_node("path_follower", PathFollowerNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
