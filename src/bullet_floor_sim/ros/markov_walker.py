"""The Markov walker node: a robot that stands in for a person wandering between ROIs.

It asks the ROI manager for the regions (``/soma/query_rois``, SOMAQueryROIs: the most recent
version of each ROI of ``~config``; the map name from ``/soma/map_info``), builds the Markov
chain by the seed rules (people/markov.py), writes it to the store (database
``markov_chain_db``, collection ``roi_proba_connexions_<map>``), and walks forever: draw the
next region from the one the robot is in, send a MoveBaseAction goal at a random point well
inside it (free on the inflated map and reachable: people/walker.py), wait up to
``~goal_timeout``, dwell a random time, repeat; a failed leg is followed by a new draw. The
chain is rebuilt when ``/soma/rois_changed`` says the ROIs changed, and from a re-query every
``~requery_period`` seconds (when the ROIs differ).

Topics (in the node's namespace, ``~`` = ``markov_walker/``):

* ``pose`` (in, geometry_msgs/PoseStamped): the robot's ground truth in the map frame.
* ``~current_region`` (std_msgs/String, latched): the id of the region the robot is in (""
  when in none), on every change and at 1 Hz.
* ``~goal_region`` (std_msgs/String, latched) and ``~goal`` (PoseStamped, latched): the leg's
  target.
* ``~leg`` (std_msgs/String): one JSON object per finished leg (number, from, to, goal,
  duration, outcome, detail, end_region).
* ``~chain`` (visualization_msgs/MarkerArray, latched): an arrow per transition between region
  anchors, shaft width proportional to its probability, and a label per region with P(stay).

Parameters: ``~seed`` (-1: random, logged so a run can be repeated), ``~goal_timeout`` (120 s
sim time, or ``~timeout_per_m`` 8 s a metre of planned path when longer, and as much
again for each metre driven beyond it, up to ``~max_extension`` (2) times the limit more;
see people.walker.WalkerConfig), ``~dwell_min``/``~dwell_max`` (5/20 s), ``~margin``
(0.5 m inside the polygon), ``~clearance`` (0.45 m from walls) and the other
people.walker.WalkerConfig fields as ``~<field>`` (``~retry_delay``, ``~max_picks``, ...),
``~robot_radius`` (0.34), ``~action`` (``move_base``, relative to the namespace), ``~config``
("1"), ``~map_name`` ("" = ask ``/soma/map_info``), ``~tol`` (0.2), ``~mode`` (vertex|edge),
``~min_shared`` (0.8), ``~query_service``, ``~map_info_service``, ``~rois_changed_topic``,
``~requery_period`` (30), ``~map_topic`` (``/map``), ``~map_yaml`` ("" = use the topic),
``~db`` (``mongodb://...`` or a directory; "" = the embedded default), ``~store_chain`` (true),
``~frame_id`` (map), ``~regoal_within`` (1.5 m) and ``~max_regoals`` (1): a goal the navigation
gives up on this close is replaced by another in its region (people/agents.WalkerAgent).

Problems (no ROIs, service missing, no map, no action server) are one line each in the log
and retried; the node does not exit. Regions it cannot reach (another part of the floor, or
no point ``~clearance`` from the walls) are different: on the first ROIs it exits with one
error naming them and the fixes (check_world says more), unless ``~allow_unreachable``
(false) lets it walk the rest, which it then logs as an error. Later ROI edits that leave a
region out are warnings.
"""
from __future__ import annotations

import json
import math
import sys
import threading
import time
from typing import Any, Dict, List, Optional, Sequence, Tuple

import actionlib
import rospy
from actionlib.action_client import CommState
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseAction
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from ..errors import BulletFloorSimError
from ..people.markov import MODES, MarkovChain, store_chain, usable_rois
from ..nav.planner import PlannerConfig, PlanningGrid
from ..data.rois import Roi, id_order
from ..people.agents import MAX_REGOALS, REGOAL_WITHIN, WalkerAgent, WalkerStep
from ..people.walker import (GoalSampler, Leg, RegionIndex, Walker, WalkerConfig, WalkerError,
                             walkable_regions)
from .convert import move_base_goal, yaw as yaw_of
from .params import config_from_params, map_handling
from .soma import query_rois
from .node import STARTUP_SECONDS, quiet_at_shutdown, run_node
from .markers import chain_markers

__all__ = ["main", "MarkovWalkerNode"]

_STATES = {GoalStatus.SUCCEEDED: "succeeded", GoalStatus.ABORTED: "aborted",
           GoalStatus.REJECTED: "rejected", GoalStatus.PREEMPTED: "preempted",
           GoalStatus.RECALLED: "preempted", GoalStatus.LOST: "lost"}


class _Complaints:
    """One log line per problem: again only when it changes or every ``every`` seconds."""

    def __init__(self, every: float = 30.0) -> None:
        self.every = every
        self._last: Dict[str, Tuple[str, float]] = {}

    def __call__(self, key: str, message: str, log: Any = None) -> None:
        now = time.monotonic()
        last = self._last.get(key)
        if last is None or last[0] != message or now - last[1] >= self.every:
            self._last[key] = (message, now)
            (log or rospy.logerr)(message)

    def clear(self, key: str, message: Optional[str] = None) -> None:
        if self._last.pop(key, None) is not None and message:
            rospy.loginfo(message)


class MarkovWalkerNode:
    """Wiring: services, topics and the action client around people.walker.Walker."""

    def __init__(self) -> None:
        gp = rospy.get_param
        self.config = config_from_params(WalkerConfig())   # ~goal_timeout, ~dwell_min, ...
        seed = int(gp("~seed", -1))
        self.seed = seed if seed >= 0 else None
        self.roi_config = str(gp("~config", "1"))
        self.map_name = str(gp("~map_name", ""))
        self.tol = float(gp("~tol", 0.2))
        self.mode = str(gp("~mode", "vertex"))
        if self.mode not in MODES:
            raise WalkerError("~mode must be one of %s, got %r" % ("/".join(MODES), self.mode))
        self.min_shared = float(gp("~min_shared", 0.8))
        self.regoal = (float(gp("~regoal_within", REGOAL_WITHIN)),
                       int(gp("~max_regoals", MAX_REGOALS)))
        if not (math.isfinite(self.regoal[0]) and self.regoal[0] >= 0 and self.regoal[1] >= 0):
            raise WalkerError("~regoal_within must be a finite number >= 0 and ~max_regoals an "
                              "integer >= 0, got %r and %r" % self.regoal)
        self.robot_radius = float(gp("~robot_radius", PlannerConfig.robot_radius))
        self.allow_unreachable = bool(gp("~allow_unreachable", False))
        self.query_service = str(gp("~query_service", "/soma/query_rois"))
        self.map_info_service = str(gp("~map_info_service", "/soma/map_info"))
        self.requery_period = float(gp("~requery_period", 30.0))
        self.map_yaml = str(gp("~map_yaml", ""))
        self.db = str(gp("~db", ""))
        self.store_enabled = bool(gp("~store_chain", True))
        self.frame_id = str(gp("~frame_id", "map"))
        self.action_name = rospy.resolve_name(str(gp("~action", "move_base")))

        self.lock = threading.Lock()
        self.refresh = threading.Event()
        self.complain = _Complaints()
        self.sampler: Optional[GoalSampler] = None
        self.chain: Optional[MarkovChain] = None
        self.rois: List[Roi] = []
        self._usable: List[Roi] = []  # the usable ROIs the chain was built from
        self.walker: Optional[Walker] = None
        self.agent: Optional[WalkerAgent] = None   # the walk's legs (people/agents.py)
        self.index: Optional[RegionIndex] = None
        self.pose: Optional[Tuple[float, float, float]] = None
        self.region: Optional[str] = None
        self.store = None
        # The plain ActionClient, polled: SimpleActionClient logs "Got a transition callback on
        # a goal handle that we're not tracking" when a fast server's status for the new goal
        # arrives before send_goal() has returned.
        self.client = actionlib.ActionClient(self.action_name, MoveBaseAction)
        self.goal_handle: Optional[Any] = None

        latched = dict(queue_size=1, latch=True)
        self.pub_current = rospy.Publisher("~current_region", String, **latched)
        self.pub_goal_region = rospy.Publisher("~goal_region", String, **latched)
        self.pub_goal = rospy.Publisher("~goal", PoseStamped, **latched)
        self.pub_leg = rospy.Publisher("~leg", String, queue_size=10)
        self.pub_chain = rospy.Publisher("~chain", MarkerArray, **latched)
        if self.map_yaml:
            self._use_map_file(self.map_yaml)
        else:
            self.map_topic = rospy.resolve_name(str(gp("~map_topic", "/map")))
            rospy.Subscriber(self.map_topic, OccupancyGrid, self._on_map, queue_size=1)
        rospy.Subscriber("pose", PoseStamped, self._on_pose, queue_size=5)
        rospy.Subscriber(str(gp("~rois_changed_topic", "/soma/rois_changed")), String,
                         self._on_rois_changed, queue_size=5)
        rospy.Timer(rospy.Duration(1.0), self._publish_region, reset=True)
        rospy.Timer(rospy.Duration(self.requery_period), lambda _: self.refresh.set(),
                    reset=True)
        rospy.on_shutdown(self._on_shutdown)
        self.refresh.set()
        threading.Thread(target=self._refresh_loop, name="rois", daemon=True).start()

    # -- map ----------------------------------------------------------------------------------

    def _planner_config(self) -> PlannerConfig:
        return PlannerConfig(robot_radius=self.robot_radius)

    def _use_map_file(self, path: str) -> None:
        from ..sim.floormap import load_map

        self._set_grid(PlanningGrid(load_map(path), self._planner_config(),
                                    handling=map_handling()), path)

    def _on_map(self, msg: OccupancyGrid) -> None:
        from .convert import grid_from_msg

        try:
            grid = PlanningGrid(grid_from_msg(msg), self._planner_config(),
                                handling=map_handling())
        except BulletFloorSimError as e:
            self.complain("map", "markov_walker: cannot use the map on %s: %s"
                          % (self.map_topic, e))
            return
        self._set_grid(grid, self.map_topic)

    def _set_grid(self, grid: PlanningGrid, source: str) -> None:
        sampler = GoalSampler(grid, self.config.clearance, self.config.margin,
                              self.config.goal_tries)
        with self.lock:
            self.sampler = sampler
            self._usable = []  # which regions are reachable is decided again on this map
            if self.walker is not None:
                self.walker.sampler = sampler
        rospy.loginfo("markov_walker: map from %s (%d x %d cells of %.2f m, %d free-space "
                      "parts)", source, grid.width, grid.height, grid.resolution,
                      sampler.components)
        self.refresh.set()

    # -- regions ------------------------------------------------------------------------------

    @quiet_at_shutdown
    def _on_rois_changed(self, msg: String) -> None:
        if not msg.data or msg.data == self.roi_config:
            self.refresh.set()

    def _refresh_loop(self) -> None:
        while not rospy.is_shutdown():
            if not self.refresh.wait(1.0):
                continue
            self.refresh.clear()
            try:
                ok = self._update_rois()
            except Exception as e:  # keep the thread alive; say what happened
                ok = False
                self.complain("rois", "markov_walker: rebuilding the chain failed: %s: %s"
                              % (type(e).__name__, e))
            if not ok and self.chain is None:
                time.sleep(2.0)  # nothing to walk on yet: try again soon
                self.refresh.set()

    def _fetch_rois(self) -> Optional[List[Roi]]:
        from ..srv import MapInfo

        if not self.map_name:
            try:
                rospy.wait_for_service(self.map_info_service, timeout=2.0)
                self.map_name = rospy.ServiceProxy(self.map_info_service, MapInfo)(0).map_name
            except (rospy.ROSException, rospy.ServiceException):
                pass  # the ROIs' own map name is used
        try:
            rois = query_rois(self.query_service, self.roi_config, 2.0)
        except rospy.ROSException:
            self.complain("rois", "markov_walker: no ROI service %s (SOMAQueryROIs): start the "
                          "ROI manager (roslaunch bullet_floor_sim rois.launch); retrying"
                          % self.query_service)
            return None
        except rospy.ServiceException as e:
            self.complain("rois", "markov_walker: %s failed: %s; retrying"
                          % (self.query_service, " ".join(str(e).split())))
            return None
        maps = sorted({r.map_name for r in rois})
        if not self.map_name and len(maps) > 1:
            self.complain("rois", "markov_walker: ROIs of config %s on several maps (%s): set "
                          "~map_name; retrying" % (self.roi_config, ", ".join(maps)))
            return None
        if self.map_name:
            rois = [r for r in rois if r.map_name == self.map_name]
        if not rois:
            self.complain("rois", "markov_walker: %s has no ROIs of config %s%s: draw some (rviz, "
                          "rois.launch) or import a rois.yaml; retrying" % (
                              self.query_service, self.roi_config,
                              " on map %s" % self.map_name if self.map_name else ""))
            return None
        return rois

    def _update_rois(self) -> bool:
        """Query the ROIs; rebuild the chain when they changed. True when a chain exists."""
        rois = self._fetch_rois()
        if rois is None:
            return self.chain is not None
        good, warnings = usable_rois(rois)
        sampler = self.sampler
        if sampler is None:  # which regions the walker reaches needs the map
            return False
        if good == self._usable and self.chain is not None:
            return True
        usable = good
        good, unreachable = walkable_regions(good, sampler)
        for w in warnings:
            rospy.logwarn("markov_walker: %s", w)
        if unreachable and self.chain is None and not self.allow_unreachable:
            from ..building.check import FIXES

            rospy.logfatal("markov_walker: refusing to walk: %s. Fixes: %s; or set "
                           "~allow_unreachable (rosrun bullet_floor_sim check_world WORLD "
                           "shows the floor)", "; ".join(unreachable), "; ".join(FIXES))
            rospy.signal_shutdown("regions cannot be reached")
            return False
        for w in unreachable:
            (rospy.logerr if self.chain is None else rospy.logwarn)(
                "markov_walker: %s%s", w, " (going on: ~allow_unreachable)"
                if self.chain is None else "")
        if not good:
            self.complain("rois", "markov_walker: none of the %d ROIs of config %s is usable "
                          "and reachable; retrying" % (len(rois), self.roi_config))
            return self.chain is not None
        self._usable = usable
        chain = MarkovChain.from_rois(good, tol=self.tol, mode=self.mode,
                                      min_shared=self.min_shared)
        for w in chain.warnings:
            rospy.logwarn("markov_walker: %s", w)
        index = RegionIndex(good)
        with self.lock:
            rebuilt = self.chain is not None
            self.chain, self.rois, self.index = chain, good, index
            if self.walker is not None:
                self.walker.set_regions(chain, good)
        self.complain.clear("rois")
        rospy.loginfo("markov_walker: %s the chain of map %s config %s: %d regions, %d "
                      "transitions", "rebuilt" if rebuilt else "built", chain.map_name,
                      self.roi_config, len(chain.ids),
                      int((chain.matrix > 0).sum()) - len(chain.ids))
        self.pub_chain.publish(chain_markers(chain, good, self.frame_id, rospy.Time.now()))
        self._store_chain(chain)
        return True

    def _store_chain(self, chain: MarkovChain) -> None:
        if not self.store_enabled:
            return
        from ..data.store import StoreError, open_store, ros_datetime

        try:
            if self.store is None:
                self.store = open_store(self.db or None)
            n = store_chain(self.store, chain, extra={"built_by": rospy.get_name(),
                                                      "built_at": ros_datetime()})
            rospy.loginfo("markov_walker: chain stored in %s (markov_chain_db.%s, %d regions)",
                          self.store.shown_uri, chain.to_documents()["collection"], n)
        except (StoreError, ValueError) as e:
            self.complain("store", "markov_walker: cannot store the chain: %s" % e)

    # -- pose ---------------------------------------------------------------------------------

    @quiet_at_shutdown
    def _on_pose(self, msg: PoseStamped) -> None:
        p = msg.pose.position
        pose = (p.x, p.y, yaw_of(msg.pose.orientation))
        with self.lock:
            self.pose = pose
            index = self.index
        if index is None:
            return
        region = index.region_at(pose[0], pose[1])
        if region != self.region:
            self.region = region
            self.pub_current.publish(String(region))

    @quiet_at_shutdown
    def _publish_region(self, _event: Any = None) -> None:
        if self.region is not None:
            self.pub_current.publish(String(self.region))

    # -- the walk -----------------------------------------------------------------------------

    def _wait(self, what: str, ready: Any, hint: str) -> bool:
        """Wait until ready() is true, saying what is missing every 10 s once it has waited
        STARTUP_SECONDS. False on shutdown."""
        start = time.monotonic()
        while not rospy.is_shutdown():
            if ready():
                return True
            if time.monotonic() - start > STARTUP_SECONDS:
                self.complain("wait", "markov_walker: waiting for %s: %s" % (what, hint),
                              rospy.logwarn)
            time.sleep(0.2)
        return False

    def _start(self) -> bool:
        if not self._wait("the map", lambda: self.sampler is not None,
                          "nothing on %s (nav_msgs/OccupancyGrid, latched): run the simulator "
                          "with publish_map or map_server, or set ~map_yaml"
                          % getattr(self, "map_topic", "/map")):
            return False
        if not self._wait("the regions", lambda: self.chain is not None,
                          "see the errors above"):
            return False
        if not self._wait("the robot's pose", lambda: self.pose is not None,
                          "nothing on %s (geometry_msgs/PoseStamped, ground truth in map)"
                          % rospy.resolve_name("pose")):
            return False
        with self.lock:
            self.walker = Walker(self.chain, self.rois, self.sampler, self.config, self.seed)
            self.agent = WalkerAgent(self.walker, *self.regoal)
        rospy.loginfo("markov_walker: seed %d (set ~seed to repeat this walk)",
                      self.walker.seed_used)
        return self._wait_for_server()

    def _wait_for_server(self) -> bool:
        while not rospy.is_shutdown():
            if self.client.wait_for_server(rospy.Duration(2.0)):
                self.complain.clear("server")
                return True
            self.complain("server", "markov_walker: no MoveBaseAction server %s: start the "
                          "navigation (navigation.launch, or path_follower in this namespace); "
                          "waiting" % self.action_name, rospy.logwarn)
        return False

    def run(self) -> None:
        """Walk until shutdown: the agent's tick at 20 Hz of sim time."""
        if not self._start():
            return
        rate = rospy.Rate(20.0)
        while not rospy.is_shutdown() and self._tick():
            try:
                rate.sleep()
            except rospy.ROSTimeMovedBackwardsException:   # (a ROSInterruptException too)
                self._time_went_back()
            except rospy.ROSInterruptException:
                break

    def _time_went_back(self) -> None:
        """Sim time jumped back (the simulator restarted, a bag looped): the pause and the
        current leg's timeout count from now, not from the old timeline."""
        now = rospy.get_time()
        agent = self.agent
        agent.resume_at = min(agent.resume_at, now)
        if agent.leg is not None:
            agent.leg.started = now
        rospy.logwarn("markov_walker: sim time went back to %.1f s: the walk goes on from now",
                      now)

    def _tick(self) -> bool:
        """One tick of people/agents.WalkerAgent: send a new leg's goal, or end the leg whose
        goal finished or timed out. False on shutdown while waiting for the action server."""
        agent, now = self.agent, rospy.get_time()
        if agent.leg is None and now >= agent.resume_at and \
                not self.client.wait_for_server(rospy.Duration(1.0)) and \
                not self._wait_for_server():
            return False
        try:
            with self.lock:   # (the ROI refresh thread swaps the walker's regions under it)
                step = agent.tick(now, self.pose, self._result())
        except WalkerError as e:
            for note in agent.take_notes():
                rospy.logwarn("markov_walker: %s", note)
            self.complain("leg", "markov_walker: %s; trying again" % e)
            agent.resume_at = now + 5.0
            return True
        for note in step.notes:
            rospy.logwarn("markov_walker: %s", note)
        for note in step.info:
            rospy.loginfo("markov_walker: %s", note)
        if step.start is not None:
            self._send(step.start)
        if step.finished is not None:
            self._finished(step)
        return True

    def _send(self, leg: Leg) -> None:
        """Send the leg's goal and say where it goes (~goal_region, ~goal)."""
        gx, gy, yaw = leg.goal
        goal = move_base_goal(gx, gy, yaw, self.frame_id)
        self.pub_goal_region.publish(String(leg.target_region))
        self.pub_goal.publish(goal.target_pose)
        self.goal_handle = self.client.send_goal(goal)

    def _result(self) -> Optional[Tuple[str, str]]:
        """The current goal's (outcome, detail) once it is done, else None."""
        gh = self.goal_handle
        if gh is None or gh.get_comm_state() != CommState.DONE:
            return None
        outcome = _STATES.get(gh.get_goal_status(), "aborted")
        return outcome, gh.get_goal_status_text() if outcome != "succeeded" else ""

    def _finished(self, step: WalkerStep) -> None:
        """A leg ended: cancel its goal when it timed out, publish it (~leg), log its line."""
        if step.cancel and self.goal_handle is not None:
            self.goal_handle.cancel()
        self.goal_handle = None
        self.pub_leg.publish(String(json.dumps(step.finished.to_dict())))
        if step.finished.outcome == "succeeded":
            rospy.loginfo("markov_walker: %s; dwelling %.1f s", step.line, step.pause)
        else:
            rospy.logwarn("markov_walker: %s%s", step.line,
                          "; next leg in %.1f s" % step.pause if step.pause > 0 else "")

    def _on_shutdown(self) -> None:
        gh = self.goal_handle
        if gh is not None:
            gh.cancel()
        walker = self.walker
        if walker is not None and walker.legs:
            rospy.loginfo("markov_walker: %d legs, %d regions reached: %s", walker.legs,
                          len(walker.visited), ", ".join(sorted(walker.visited, key=id_order)))
        if self.store is not None:
            self.store.close()


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim markov_walker``."""
    return run_node("markov_walker", MarkovWalkerNode, argv)


if __name__ == "__main__":
    sys.exit(main())
