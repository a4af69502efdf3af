"""The destination predictor node: where is the tracked entity heading?

On every track update (``tracks``, bullet_floor_sim/TrackArray from people_tracker) it feeds
each track's position and velocity to an online predictor (people/prediction.py; a new track
that appears soon after and near where another was lost takes over that track's leg:
PredictorPool, ``~handover_time``, ``~handover_speed``; so does a new track the follower takes
for the target it lost, ``target_id`` (std_msgs/UInt32), lost up to ``~forget_after`` (30 s)
before and no farther off than ``~handover_speed`` allows): the track's legs are segmented by
its dwells, and for the current leg a posterior over destination regions
is computed: the Markov chain row of the region the leg started in (prior) times how well the
observed motion agrees with an efficient path to each region (cost-to-go on the inflated map).
It publishes ``~destination`` (bullet_floor_sim/Destination: the distribution, most likely
first, and the arg-max with its probability) for every track, and ``~markers`` (a label over
each track: best region and probability). For a track that stands with no leg under way it
predicts the leg it will start next, from where it stands (``under_way`` false).

The regions and the chain are the walker's: the ROIs of ``~config`` from the ROI manager
(``/soma/query_rois``; re-queried when ``/soma/rois_changed`` says so), or from ``~rois_yaml``
when set; the chain by the same rules (``~tol``, ``~mode`` as markov_walker's). The map comes
from ``~map_topic`` (``/map``, latched).

Parameters: ``~config`` ("1"), ``~rois_yaml`` (""), ``~tol`` (0.2), ``~mode`` (vertex),
``~robot_radius`` (0.34, planning grid inflation), ``~beta`` and the other core
PredictionConfig fields as ``~<field>``, ``~query_service``, ``~rois_changed_topic``,
``~map_topic``, ``~search_sight`` (FollowConfig.search_sight, 8 m), ``~search_at``
(FollowConfig.search_at). Every region gets a search point in ``points``
(people/search.search_plan: of its goal points with the most of them in view within
``~search_sight``, ``lookout_points``, the one nearest to the track; with ``~search_at``
likely_goal, while a leg is under way, the goal point the leg makes most likely); the
follower's ``~search_regions`` and ``~search_min_probability`` say which are the likely ones.
"""
from __future__ import annotations

import sys
import threading
from typing import List, Optional, Sequence, Tuple

import rospy
from geometry_msgs.msg import Point
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import ColorRGBA, String, UInt32
from visualization_msgs.msg import Marker, MarkerArray

from ..errors import BulletFloorSimError
from ..people.agents import PredictorAgent
from ..people.follow import FollowConfig
from ..people.markov import MarkovChain, usable_rois
from ..nav.planner import PlannerConfig, PlanningGrid
from ..people.prediction import DestinationModel, PredictionConfig
from ..data.rois import Roi, load_rois
from ..people.walker import GoalSampler, walkable_regions
from ..msg import Destination, TrackArray
from .soma import query_rois
from .params import config_from_params, map_handling
from .convert import grid_from_msg
from .node import quiet_at_shutdown, run_node

__all__ = ["main", "DestinationPredictorNode", "destination_msg"]


def destination_msg(track_id: int, prediction, header, best_point=(0.0, 0.0),
                    search=()) -> Destination:
    """A Destination message of a core Prediction (regions most likely first); ``best_point``:
    where to look for the entity in the best region; ``search``: people/search.search_plan's
    (region, point) pairs, most likely first (``points``: as far as they follow ``regions``)."""
    m = Destination()
    m.header = header
    m.track_id = track_id
    m.under_way = bool(prediction.under_way)
    m.leg_start = rospy.Time.from_sec(prediction.leg_start)
    m.start_region = prediction.start_region
    m.start = Point(prediction.start_xy[0], prediction.start_xy[1], 0.0)
    m.observed = float(prediction.observed)
    # most likely first; of equal ones the predictor's best first (regions[0] == best)
    ranked = sorted(prediction.probabilities.items(),
                    key=lambda kv: (-kv[1], kv[0] != prediction.best, kv[0]))
    m.regions = [r for r, _ in ranked]
    m.probabilities = [float(p) for _, p in ranked]
    m.best, m.best_probability = prediction.best, float(prediction.best_probability)
    m.best_point = Point(float(best_point[0]), float(best_point[1]), 0.0)
    where = dict(search)
    for region in m.regions:   # points[i] belongs to regions[i]
        if region not in where:
            break
        m.points.append(Point(float(where[region][0]), float(where[region][1]), 0.0))
    return m


class DestinationPredictorNode:
    """Tracks in, destination distributions out; the model lives in people/prediction.py."""

    def __init__(self) -> None:
        gp = rospy.get_param
        self.roi_config = str(gp("~config", "1"))
        self.rois_yaml = str(gp("~rois_yaml", ""))
        self.tol = float(gp("~tol", 0.2))
        self.mode = str(gp("~mode", "vertex"))
        self.query_service = str(gp("~query_service", "/soma/query_rois"))
        self.planner_cfg = PlannerConfig(robot_radius=float(gp("~robot_radius", PlannerConfig.robot_radius)))
        self.config = config_from_params(PredictionConfig())
        self.follow = FollowConfig(search_sight=float(gp("~search_sight",
                                                         FollowConfig.search_sight)),
                                   search_at=str(gp("~search_at", FollowConfig.search_at)))
        self.follow.check()   # a bad ~search_*: one line at start, not in the model thread
        self.lock = threading.Lock()
        self.grid: Optional[PlanningGrid] = None
        self.rois: Optional[List[Roi]] = None
        self._usable: List[Roi] = []  # the usable ROIs the model was built from
        self.agent: Optional[PredictorAgent] = None   # the model's per-track predictors
        self.rebuild = threading.Event()
        self.pub = rospy.Publisher("~destination", Destination, queue_size=10)
        self.marker_pub = rospy.Publisher("~markers", MarkerArray, queue_size=2)
        rospy.Subscriber(str(gp("~map_topic", "/map")), OccupancyGrid, self._on_map,
                         queue_size=1)
        rospy.Subscriber(str(gp("~rois_changed_topic", "/soma/rois_changed")), String,
                         lambda _m: self.rebuild.set(), queue_size=1)
        rospy.Subscriber("tracks", TrackArray, self._on_tracks, queue_size=5)
        self.target_id: Optional[int] = None
        self._pending: Optional[Tuple[int, int]] = None   # (lost, new): a hand-over to try
        rospy.Subscriber("target_id", UInt32, self._on_target_id, queue_size=5)
        rospy.loginfo("destination_predictor: the follower's new target goes on with the lost "
                      "target's leg, by %s", rospy.resolve_name("target_id"))
        threading.Thread(target=self._model_loop, daemon=True).start()

    def _on_map(self, msg: OccupancyGrid) -> None:
        try:
            self.grid = PlanningGrid(grid_from_msg(msg), self.planner_cfg, handling=map_handling())
            self._usable = []  # which regions are reachable is decided again on this map
        except BulletFloorSimError as e:
            rospy.logerr("destination_predictor: cannot use the map: %s", e)
            return
        self.rebuild.set()

    def _fetch_rois(self) -> Optional[List[Roi]]:
        if self.rois_yaml:
            return load_rois(self.rois_yaml)
        try:
            return query_rois(self.query_service, self.roi_config, 2.0)
        except (rospy.ROSException, rospy.ServiceException) as e:
            rospy.logwarn_throttle(30.0, "destination_predictor: no ROIs from %s (%s): start "
                                   "the ROI manager or set ~rois_yaml; retrying",
                                   self.query_service, " ".join(str(e).split()))
            return None

    def _model_loop(self) -> None:
        """(Re)build the model when the map or the ROIs change (the cost-to-go fields take a
        moment: never in a callback)."""
        self.rebuild.set()
        while not rospy.is_shutdown():
            if not self.rebuild.wait(2.0) and self.agent is not None:
                continue
            self.rebuild.clear()
            if self.grid is None:
                continue
            try:
                rois = self._fetch_rois()
            except BulletFloorSimError as e:
                rospy.logerr_throttle(30.0, "destination_predictor: %s", e)
                continue
            if not rois:
                continue
            good, warnings = usable_rois(rois)
            for w in warnings:
                rospy.logwarn("destination_predictor: %s", w)
            if not good or (good == self._usable and self.agent is not None):
                continue
            usable = good
            # the walker leaves out the regions it cannot reach; so must its chain here
            good, unreachable = walkable_regions(good, GoalSampler(
                self.grid, self.config.clearance, self.config.margin))
            for w in unreachable:
                rospy.logwarn("destination_predictor: %s", w)
            if not good:
                continue
            self._usable = usable
            try:
                t0 = rospy.get_time()
                chain = MarkovChain.from_rois(good, tol=self.tol, mode=self.mode)
                model = DestinationModel(self.grid, good, chain, self.config)
            except BulletFloorSimError as e:
                rospy.logerr("destination_predictor: cannot build the model: %s", e)
                continue
            with self.lock:
                self.rois, self.agent = good, PredictorAgent(model, self.follow)
            rospy.loginfo("destination_predictor: %d regions, model built (%.1f s)", len(good),
                          rospy.get_time() - t0)

    def _on_target_id(self, msg: UInt32) -> None:
        """The follower's target changed: a new track it took for the one it lost takes over
        that one's leg (PredictorPool.same_entity), now or, when the track update that brings
        the new track has not come in yet (the two topics are not in step), on that update."""
        with self.lock:
            lost, self.target_id = self.target_id, int(msg.data)
            self._pending = None if lost is None or lost == self.target_id else (
                lost, self.target_id)
            self._hand_over()

    def _hand_over(self) -> None:
        """The pending hand-over, tried once the new track has had an update (the caller
        holds the lock)."""
        if self._pending is None or self.agent is None:
            return
        lost, new = self._pending
        if not self.agent.pool.knows(new):
            return
        self._pending = None
        if self.agent.same_entity(lost, new):
            rospy.loginfo("destination_predictor: track %d goes on with track %d's leg (the "
                          "follower's target)", new, lost)

    @quiet_at_shutdown
    def _on_tracks(self, msg: TrackArray) -> None:
        with self.lock:
            agent = self.agent
            if agent is None:
                return
            step = agent.tick(msg.header.stamp.to_sec(),
                              [(tr.id, tr.position.x, tr.position.y, tr.velocity.x,
                                tr.velocity.y) for tr in msg.tracks])
            self._hand_over()
        if step.went_back:
            rospy.loginfo("destination_predictor: time went back %.1f s: legs forgotten",
                          step.went_back)
        for why in step.errors:
            rospy.logwarn_throttle(10.0, "destination_predictor: %s", why)
        markers = MarkerArray()
        for tr in msg.tracks:
            if tr.id not in step.destinations:
                continue
            p, search = step.destinations[tr.id]
            self.pub.publish(destination_msg(tr.id, p, msg.header, search[0][1], search))
            markers.markers.append(self._label(agent.model, tr, p, msg.header))
        if markers.markers:
            self.marker_pub.publish(markers)

    @staticmethod
    def _label(model, tr, p, header) -> Marker:
        m = Marker()
        m.header = header
        m.ns, m.id, m.type, m.action = "destination", tr.id, Marker.TEXT_VIEW_FACING, Marker.ADD
        m.pose.position = Point(tr.position.x, tr.position.y, 1.7)
        m.pose.orientation.w = 1.0
        m.scale.z = 0.35
        m.color = ColorRGBA(0.2, 0.9, 1.0, 1.0)
        m.lifetime = rospy.Duration(1.0)
        label = model.label(p.best) if hasattr(model, "label") else p.best
        m.text = "%s %s %.0f%%" % ("->" if p.under_way else "next ->", label,
                                   100.0 * p.best_probability)
        return m


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim destination_predictor``."""
    return run_node("destination_predictor", DestinationPredictorNode, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
