"""The observer scenario's agents: what the walker, tracker, predictor and follower nodes
decide, as plain objects with ``tick(...)``.

The ROS nodes (ros/markov_walker.py, people_tracker.py, destination_predictor.py,
follower.py) and the in-process evaluation (people/evaluation.py) drive these same objects,
so the evaluation measures the code that ships; the nodes add the transport (topics, the
move_base action, tf, logging) and nothing else.

* :class:`WalkerAgent`: pose and the goal's result in; the next leg to send, or the leg that
  ended with its log line and the pause that follows, out.
* :class:`TrackerAgent`: a scan and the laser's pose in the map in; tracks out.
* :class:`PredictorAgent`: tracks in; per track the destination prediction and the search plan
  (where to look for it if it is lost) out.
* :class:`FollowerAgent`: the observer's pose, tracks and those search plans in; the target
  picked and the follow decision (mode, a navigation goal) out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..data.rois import RoiError
from ..errors import BulletFloorSimError
from .follow import FollowBehaviour, FollowConfig, FollowDecision
from .search import SearchPlan, TrackLike, lookout_points, pick_target, search_plan
from .prediction import DestinationModel, Prediction, PredictorPool
from .tracking import StaticMap, Track, Tracker, TrackerConfig, scan_detections
from .walker import GoalSampler, Leg, Walker, WalkerError

__all__ = ["WalkerAgent", "WalkerStep", "REGOAL_WITHIN", "MAX_REGOALS", "TrackerAgent",
           "TrackerStep", "PredictorAgent", "PredictorStep", "FollowerAgent", "FollowerStep",
           "GOAL_RESULTS"]

TrackTuple = Tuple[int, float, float, float, float]   # id, x, y, vx, vy

GOAL_RESULTS = ("succeeded", "aborted", "rejected", "preempted", "lost")


# -------------------------------------------------------------------------------------------
# the walker
# -------------------------------------------------------------------------------------------


@dataclass
class WalkerStep:
    """What the walker does after one tick.

    Attributes:
        start: a new leg, or the current one with a new goal (``regoal``): send its goal now.
        regoal: ``start`` is the current leg, given a new goal in its region.
        finished: the leg that ended this tick (its outcome, duration and detail are set).
        line: the finished leg's log line.
        pause: the dwell (after a success) or retry delay (after a failure) that follows it.
        cancel: the navigation goal must be cancelled (the leg timed out).
        notes: the walker's warnings of this tick (a region with no acceptable goal).
        info: what this tick did about a goal someone stands on (another goal in its region,
            or stopping short in it): the everyday ends a log shows as information.
    """

    start: Optional[Leg] = None
    regoal: bool = False
    finished: Optional[Leg] = None
    line: str = ""
    pause: float = 0.0
    cancel: bool = False
    notes: List[str] = field(default_factory=list)
    info: List[str] = field(default_factory=list)


#: WalkerAgent's defaults (the markov_walker node's too): see its doc.
REGOAL_WITHIN, MAX_REGOALS = 1.5, 1
#: m between two ticks: more is a jump (a teleport), not driven
_MAX_STEP = 2.0


def _short_of(leg: Leg, pose: Sequence[float]) -> float:
    """Metres from ``pose`` to ``leg``'s goal."""
    return math.hypot(float(pose[0]) - leg.goal[0], float(pose[1]) - leg.goal[1])


class WalkerAgent:
    """Legs one after the other: draw a leg, wait for its goal's result or its timeout
    (:meth:`limit`: the leg's own, longer when the robot drives further than planned), dwell
    or back off, draw the next.

    A goal the navigation gives up on with the robot within ``regoal_within`` of it (someone
    stands on or beside it: the observer, waiting near the walker) is replaced, up to
    ``max_regoals`` times a leg, by another goal in the same region at least that far from
    it, as a person would stop at another free spot; the leg goes on under its own timeout.
    With no new goal (none that far, or none left) and the robot in that region, the leg
    ends there, as reached (its detail says how far short), and the next leg's goal keeps
    ``regoal_within`` from the one it stopped short of (a region with no other free goal
    is not drawn for it, unless no region drawn has one).

    Args:
        walker: the walk (chain, regions, goal sampler, random streams).
        regoal_within: metres: the follower's stand-off distance (1.5 m), since the observer
            waiting that far from a stopped walker is what most often stands on its goal (with
            1.0 m, a full-demo leg was given up 1.02 m from a goal the observer stood on).
        max_regoals: new goals a leg may get.
    """

    def __init__(self, walker: Walker, regoal_within: float = REGOAL_WITHIN,
                 max_regoals: int = MAX_REGOALS) -> None:
        if not (math.isfinite(regoal_within) and regoal_within >= 0):
            raise BulletFloorSimError("walker: regoal_within must be a finite number >= 0, "
                                      "got %r" % (regoal_within,))
        self.walker = walker
        self.regoal_within, self.max_regoals = float(regoal_within), int(max_regoals)
        self.leg: Optional[Leg] = None
        self.resume_at = -math.inf   # no leg starts before this time
        self._last_xy: Optional[Tuple[float, float]] = None   # the pose at the last tick
        # (x, y, r): the goal a leg stopped short of, kept clear of by the next leg's goal
        self._taken: Optional[Tuple[float, float, float]] = None

    def tick(self, t: float, pose: Sequence[float],
             result: Optional[Tuple[str, str]] = None) -> WalkerStep:
        """One decision at time ``t`` with the robot at ``pose`` (x, y, yaw).

        Args:
            result: the current leg's navigation result, (outcome, detail) with outcome one of
                GOAL_RESULTS, or None while its goal is under way.

        Raises:
            WalkerError: no leg could be drawn (no acceptable goal in the regions drawn); the
                caller may set ``resume_at`` and try again (:meth:`take_notes` says why).
        """
        step = WalkerStep()
        if self.leg is None:
            if t >= self.resume_at:
                self.leg = step.start = self._next_leg(pose, t)
                self._last_xy = (float(pose[0]), float(pose[1]))
                step.notes = self.take_notes()
            return step
        leg = self.leg
        if result is not None and result[0] not in GOAL_RESULTS:
            raise ValueError("walker: unknown goal result %r (one of %s)"
                             % (result[0], ", ".join(GOAL_RESULTS)))
        self._drive(leg, pose)
        limit = self.limit(leg)
        timed_out = t - leg.started > limit
        short: Optional[str] = None   # the note of a leg that stops short of a taken goal
        if result is not None and result[0] == "succeeded":
            outcome, detail = "succeeded", ""
        elif timed_out:
            outcome, detail = "timeout", ("no result within %.0f s (~goal_timeout, "
                                          "~timeout_per_m)" % limit)
            if limit > (leg.timeout or self.walker.config.goal_timeout):
                detail += "; %.0f m driven on a planned way of %.0f m" % (leg.driven, leg.way)
            step.cancel = True
        elif result is not None:
            outcome, detail = result
            if outcome == "aborted" and self._regoal(leg, pose, detail, step):
                return step
            stop = (self._stops_short(leg, pose, detail)
                    if outcome == "aborted" and t > leg.started else None)  # (not refused at once)
            if stop is not None:
                outcome, (short, detail) = "succeeded", stop
        else:
            return step
        step.line = self.walker.finish(leg, outcome, t, self.walker.region_at(pose[0], pose[1]),
                                       detail)
        step.pause = self.walker.dwell() if outcome == "succeeded" else self.walker.retry_delay()
        step.finished, self.leg, self.resume_at = leg, None, t + step.pause
        step.info = [short] if short else []
        step.notes = self.take_notes()
        return step

    def _next_leg(self, pose: Sequence[float], t: float) -> Leg:
        """The next leg, its goal clear of the one the last leg stopped short of; when no
        region drawn has such a goal, any goal (the spot may have been left meanwhile)."""
        avoid, self._taken = self._taken, None
        try:
            return self.walker.next_leg(pose, t, avoid)
        except WalkerError:
            if avoid is None:
                raise
            self.take_notes()   # (the draws that kept clear of the spot: not this leg's)
            return self.walker.next_leg(pose, t)

    def limit(self, leg: Leg) -> float:
        """Seconds ``leg`` may run: its timeout, plus ``timeout_per_m`` for each metre driven
        beyond its planned way (the long way round something that blocks it), at most
        ``max_extension`` times its timeout more (WalkerConfig)."""
        cfg = self.walker.config
        base = leg.timeout or cfg.goal_timeout
        more = cfg.timeout_per_m * max(0.0, leg.driven - leg.way)
        return base + min(more, cfg.max_extension * base)

    def _drive(self, leg: Leg, pose: Sequence[float]) -> None:
        """Add the way from the last pose to ``leg.driven`` (a jump of more than
        ``_MAX_STEP`` m between two ticks, a teleport, is not driven)."""
        x, y = float(pose[0]), float(pose[1])
        if self._last_xy is not None:
            step = math.hypot(x - self._last_xy[0], y - self._last_xy[1])
            if step <= _MAX_STEP:
                leg.driven += step
        self._last_xy = (x, y)

    def _stops_short(self, leg: Leg, pose: Sequence[float],
                     why: str) -> Optional[Tuple[str, str]]:
        """A goal given up within ``regoal_within`` of it, in its region, with no new goal
        to go to (none free there, or the leg had its new goals): the robot stops where it
        is, in the region it was going to, as a person whose spot is taken would (aces_austin:
        the observer stood on the only free spot of a small room, and the walker gave up
        eleven legs in a row there). Returns the note that says so and the leg's detail, or
        None."""
        gx, gy, _ = leg.goal
        near = _short_of(leg, pose)
        w = self.walker
        if near > self.regoal_within or w.region_at(pose[0], pose[1]) != leg.target_region:
            return None
        self._taken = (gx, gy, self.regoal_within)   # the next leg's goal keeps clear of it
        return ("leg %d: goal given up %.2f m short (%s), no other goal: it stops there, in %s"
                % (leg.number, near, why, w.label(leg.target_region)),
                "stopped %.2f m short (%s)" % (near, why))

    def _regoal(self, leg: Leg, pose: Sequence[float], why: str, step: WalkerStep) -> bool:
        """Give ``leg`` another goal in its region when it was given up near its goal."""
        gx, gy, _ = leg.goal
        near = _short_of(leg, pose)
        if leg.regoals >= self.max_regoals or near > self.regoal_within:
            return False
        w = self.walker
        roi = w.index.by_id.get(leg.target_region)
        for _ in range(20 if roi is not None else 0):   # draws away from the blocked goal
            assert roi is not None   # (no draw without a region)
            try:
                x, y = w.sampler.sample(roi, w.rng_goal, (pose[0], pose[1]))
            except RoiError:
                return False
            if math.hypot(x - gx, y - gy) >= self.regoal_within:
                yaw = math.atan2(y - pose[1], x - pose[0])
                leg.goal, leg.regoals = (x, y, yaw), leg.regoals + 1
                step.start, step.regoal = leg, True
                step.info = ["leg %d: goal given up %.2f m short (%s): new goal (%.2f, %.2f) "
                             "in %s" % (leg.number, near, why, x, y,
                                        w.label(leg.target_region))]
                return True
        return False

    def take_notes(self) -> List[str]:
        """The walker's log lines since the last call other than the legs' own (those are a
        step's ``line``): after a WalkerError, what the draws ran into."""
        notes = [s for s in self.walker.log if not s.startswith("leg ")]
        del self.walker.log[:]
        return notes


# -------------------------------------------------------------------------------------------
# the tracker
# -------------------------------------------------------------------------------------------


@dataclass
class TrackerStep:
    """The tracks after one scan, the scan's points in the map, and why the tracker started
    afresh ("" when it did not)."""

    tracks: List[Track]
    points: np.ndarray
    restarted: str = ""


class TrackerAgent:
    """Moving entities in one lidar: the scan placed in the map, points the static map
    explains dropped, clusters of person/robot size tracked (people/tracking).

    Args:
        static: the static map the scan is checked against (``static`` may be replaced when
            the map changes; the tracks go on).
        config: the tracker's parameters.
    """

    def __init__(self, static: StaticMap, config: Optional[TrackerConfig] = None) -> None:
        self.config = config or TrackerConfig()
        self.static = static
        self.tracker = Tracker(self.config)

    @classmethod
    def for_map(cls, fmap, config: Optional[TrackerConfig] = None,
                handling=None) -> "TrackerAgent":
        """An agent whose static map is ``fmap`` (a FloorMap) with the config's tolerance."""
        cfg = config or TrackerConfig()
        return cls(StaticMap(fmap, cfg.static_tolerance, handling=handling), cfg)

    def tick(self, t: float, scan, laser_pose: Sequence[float]) -> TrackerStep:
        """Track on one scan (anything with ``ranges``, ``angle_min``, ``angle_increment``)
        taken at time ``t`` from ``laser_pose`` (x, y, yaw in the map). A scan older than the
        tracker's last (a bag looped, the simulation restarted) starts it afresh."""
        dets, pts = scan_detections(scan.ranges, scan.angle_min, scan.angle_increment,
                                    laser_pose, self.static, self.config)
        try:
            return TrackerStep(self.tracker.update(dets, t), pts)
        except BulletFloorSimError as e:   # time went backwards
            self.tracker = Tracker(self.config)
            return TrackerStep([], pts, str(e))


# -------------------------------------------------------------------------------------------
# the predictor
# -------------------------------------------------------------------------------------------


@dataclass
class PredictorStep:
    """Per track id, its prediction and search plan (most likely region first); the
    predictor's complaints about tracks it could not use; the seconds time went back when the
    predictor started afresh (0 when it did not)."""

    destinations: Dict[int, Tuple[Prediction, SearchPlan]]
    errors: List[str] = field(default_factory=list)
    went_back: float = 0.0


class PredictorAgent:
    """Where each track is heading: a predictor per track (people/prediction's PredictorPool:
    legs cut at dwells, a track that appears near where another was lost takes over its leg),
    and where to look for it if it is lost (people/search.search_plan).

    Args:
        model: the destination model (regions, chain, cost-to-go fields).
        follow: where the search plans come from (``search_regions``,
            ``search_min_probability``).
    """

    def __init__(self, model: DestinationModel, follow: Optional[FollowConfig] = None) -> None:
        self.model = model
        self.follow = follow or FollowConfig()
        self.follow.check()
        self.pool = PredictorPool(model)
        self.last_t = -math.inf
        # each region's lookouts, made here (the ROS node builds the agent in its model
        # thread, not in a track callback): 24 goal points take about 4 ms a region; and
        # those of each part of the floor its goal points lie in (a wall can cut a region
        # in two, and its lookouts lie on the side with more points)
        self._floor = GoalSampler(model.grid)
        self._lookouts: Dict[str, np.ndarray] = {}
        self._part_lookouts: Dict[str, Dict[int, np.ndarray]] = {}
        for region in model.chain.ids:
            self._lookouts[region], self._part_lookouts[region] = self._region_lookouts(
                model.goals(region))

    def _region_lookouts(self, goals: np.ndarray) -> Tuple[np.ndarray, Dict[int, np.ndarray]]:
        """A region's lookouts (people/search.lookout_points of its goal points), and per
        part of the floor (GoalSampler.component_at) the lookouts of its points there."""
        grid, sight = self.model.grid, self.follow.search_sight
        every = lookout_points(grid, goals, sight)
        every.setflags(write=False)
        part = np.array([self._floor.component_at(float(x), float(y)) for x, y in goals],
                        dtype=np.int64)
        by_part = {}
        for k in np.unique(part[part > 0]).tolist():
            pts = every if (part == k).all() else lookout_points(grid, goals[part == k], sight)
            pts.setflags(write=False)
            by_part[k] = pts
        return every, by_part

    def _lookouts_from(self, x: float, y: float):
        """The lookouts a search from (x, y) uses: each region's in the part of the floor
        (x, y) is in, where the region has goal points there (else all its lookouts). A
        lookout across a wall, nearest as the crow flies, sent the observer to a place it
        had no way to (mit_csail)."""
        part = self._floor.component_at(x, y)
        return lambda region: self._part_lookouts.get(region, {}).get(
            part, self.lookouts(region))

    def tick(self, t: float, tracks: Sequence[TrackTuple]) -> PredictorStep:
        """Predict on one track update: ``tracks`` as (id, x, y, vx, vy) at time ``t``."""
        went_back = 0.0
        if t < self.last_t:   # a bag looped or the simulation was reset: legs forgotten
            went_back, self.pool = self.last_t - t, PredictorPool(self.model)
        self.last_t = t
        preds = self.pool.update(t, tracks)
        out: Dict[int, Tuple[Prediction, SearchPlan]] = {}
        fc = self.follow
        for tid, x, y, _vx, _vy in tracks:
            p = preds.get(tid)
            if p is not None:
                out[tid] = (p, search_plan(p.probabilities, self._search_points(p, x, y),
                                           (x, y), fc.search_regions,
                                           fc.search_min_probability, p.best, rest=True))
        return PredictorStep(out, list(self.pool.errors.values()), went_back)

    def _search_points(self, p: Prediction, x: float, y: float):
        """Each region's candidate search points for a track at (x, y) whose leg ``p`` is:
        its lookouts (:meth:`_lookouts_from`), or with ``search_at`` ``likely_goal`` and the
        leg under way, its goal point the leg makes most likely."""
        lookouts = self._lookouts_from(x, y)
        if self.follow.search_at != "likely_goal" or not p.under_way:
            return lookouts
        likely = self.model.likely_goals(p.start_xy, (x, y))
        return lambda region: [likely[region]] if region in likely else lookouts(region)

    def lookouts(self, region: str) -> np.ndarray:
        """Of ``region``'s goal points, those with the most of them in view
        (people/search.lookout_points, within ``search_sight``); read-only. A search from
        a point takes those of the part of the floor it is in (_lookouts_from).

        Raises:
            PredictionError: an unknown region (as DestinationModel.goals)."""
        pts = self._lookouts.get(region)
        return pts if pts is not None else self.model.goals(region)

    def same_entity(self, old: int, new: int) -> bool:
        """The follower took track ``new`` for the target ``old`` it lost: ``new`` takes over
        ``old``'s leg (PredictorPool.same_entity). Returns whether it did."""
        return self.pool.same_entity(old, new)

    def follower_switched(self, lost: Optional[int], step: "FollowerStep") -> bool:
        """After the follower's tick: when it switched from target ``lost`` to another
        track, that track takes over ``lost``'s leg (:meth:`same_entity`, as
        destination_predictor does on ``target_id``). Returns whether it did."""
        if not step.switched or lost is None or step.target is None:
            return False
        return self.same_entity(lost, step.target.id)

    @property
    def handovers(self) -> int:
        """Legs a new track took over from a lost one (PredictorPool.handovers)."""
        return self.pool.handovers


# -------------------------------------------------------------------------------------------
# the follower
# -------------------------------------------------------------------------------------------


@dataclass
class FollowerStep:
    """The target picked this tick (None: nothing tracked), whether it differs from the one
    followed before (``switched``: another id replaced a followed one; ``new``: any change,
    the first pick included), and the decision (None when the agent only picked)."""

    target: Optional[TrackLike] = None
    switched: bool = False
    new: bool = False
    decision: Optional[FollowDecision] = None


class FollowerAgent:
    """The observer follows one track: it keeps the id it follows while it lives, takes the
    search plan of that track, and decides (people/follow.FollowBehaviour) where to go.

    Args:
        behaviour: the follow / search decisions on the observer's planning grid.
    """

    def __init__(self, behaviour: FollowBehaviour) -> None:
        self.behaviour = behaviour
        self.target_id: Optional[int] = None
        self.destination: Optional[SearchPlan] = None   # the followed track's search plan

    def pick(self, tracks: Sequence) -> FollowerStep:
        """Pick the target among ``tracks`` (objects with id, x, y, vx, vy): the one
        followed while it lives, else the nearest to where the target was last seen."""
        target = pick_target(tracks, self.target_id, self.behaviour.last_target)
        step = FollowerStep(target)
        if target is not None:
            step.new = target.id != self.target_id
            step.switched = step.new and self.target_id is not None
            self.target_id = target.id
        return step

    def tick(self, t: float, robot: Sequence[float], tracks: Sequence,
             destinations: Mapping[int, SearchPlan], goal_done: bool = False) -> FollowerStep:
        """Pick the target, take its search plan from ``destinations`` (by track id) when
        there is one, and decide. ``goal_done``: the last goal sent has finished."""
        step = self.pick(tracks)
        target = step.target
        if target is not None and destinations.get(target.id):
            self.destination = destinations[target.id]
        step.decision = self.behaviour.update(
            t, robot, None if target is None else (target.x, target.y, target.vx, target.vy),
            self.destination, goal_done)
        return step
