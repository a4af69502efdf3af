"""The observer's behaviour: keep a tracked entity in view at a set distance, search when lost.

:class:`FollowBehaviour` turns (the observer's pose, the target track, the predicted destination)
into navigation goals, as plain numbers; a ROS node (``bullet_floor_sim.ros.follower``) sends
them to ``<robot>/move_base`` and the evaluation sends them to the embedded navigator.

* **follow**: the goal is a *stand-off point* ``distance`` metres from the target, on the line
  from the target back towards the observer (so the observer trails it through doors rather
  than overtaking it), snapped to the nearest free planning cell on that circle, facing the
  target. A target coming towards the observer gets room: the stand-off point goes to the side
  of its path (the side nearer the observer), not backwards in front of it into a dead end. A
  new goal is sent when the target has moved ``replan_distance`` from where it was when the
  last goal was sent, or at least every ``goal_period`` seconds while it moves; a stand-off
  point nearer than ``replan_distance`` is not driven to, only turned at.
  Within ``distance + slack`` of a target that stands still, the observer only turns to face
  it (a lidar sees 180 degrees ahead).
* **give way**: near the target (within ``distance + slack``), the observer plans the target's
  routes to its likely destinations (the search plan's regions: up to ``search_regions`` of
  at least ``search_min_probability``; a leg's first prediction is often wrong) and, when it
  stands within ``give_way`` - 0.2 metres of one and the target cannot go round it (by a way
  at most ``pass_detour`` longer), goes to the nearest free point at least that far from it
  (a roomy one first, up to ``give_way_reach`` away: a wider spot of the corridor, a doorway's
  side, or back along the way; of those, one with no wall between it and the target and
  whose way there sets off towards the target first, so that it stays in view), and waits
  there, facing the target,
  until the target has moved ``distance`` metres or ``give_way_hold`` seconds have passed.
  Standing on the route of a target that turned back, the observer blocked it for good in
  narrow corridors. A target that comes nearer than ``distance`` - 0.2 m and stays within
  ``distance`` of the observer, and within ``give_way`` of where it was, for ``unblock``
  seconds is stepped away from, on no prediction (it may be going where the observer
  stands), and waited for the same way.
* **search**: when no track has been seen for ``lost_after`` seconds, a target lost while
  the observer stepped out of its way so (``blocked_way``: within ``give_way_hold`` of the
  step, not seen more than ``distance`` from where it stood since; with ``give_way_through``,
  a step off its predicted way too, once the observer got within 1 m of the place it stepped
  to) is looked for first
  from where the observer stood, facing the way from the target through it. Otherwise the observer
  first turns to where a target lost within ``distance + slack`` and more than 75 degrees off its
  heading was last seen, moving or not (a moving one: where it would be ``look_lead``
  seconds on at its last velocity), where it has ``roomy`` clearance to turn (one lost as
  near in front went behind something, and is looked for as one lost further off; turning
  towards its own goal, the observer had turned its back on it; most targets lost so
  walked past behind the observer at a leg's start, when their velocity is seldom the way
  they go on; turning in a doorway instead of trailing, it blocked the walker: seattle).
  A target lost further off while moving, or close by with no room to turn, is trailed:
  the observer drives to the point ``trail`` seconds on from where it was last seen, at
  its last velocity, short of a wall, facing that way (it had stood in a room while the
  walker it lost in the doorway went off down the corridor); a trail a wall cuts short
  is turned the least that frees it, up to ``trail_turn`` (pi/2) either way. One that
  stood still, or is not trailed (no roomy point on its way), is looked for from where it
  was last seen (``look_distance`` 0; from the stand-off point when that is not free),
  facing the way the observer came; one lost close by with no room to turn, from a roomy place
  (the stand-off point, or the nearest roomy place within ``give_way_reach``), else turned
  to where it stands (turning 0.3 m from a wall, an octagonal base wedged: aces_austin).
  Then it goes to the predicted destination region (the
  predictor's arg-max; of the region's goal points with the most of them in view within
  the predictor's ``search_sight`` (:func:`lookout_points`), in the part of the floor where
  the target was last seen, the one nearest to where it was; with ``search_at``
  likely_goal, while the leg is under way, the region's goal point the leg makes most
  likely), turns on the spot to look
  around, waits ``search_wait`` seconds (a place whose goal ended more than a metre off is
  not reached: on to the next at once, for as many in a row as the plan has), then goes
  on to the next most likely region (up to ``search_regions`` of them, each at least
  ``search_min_probability``: :func:`search_plan`) and round the list again; after
  ``search_rounds`` rounds, each other region of the plan once, most likely first, and then
  the patrol (with ``watch`` set, by turns with watches at the building's hubs: the places
  most ways across it pass, :func:`hub_points`; it looks round there for ``watch`` seconds,
  then patrols as long, then watches at the next hub; with ``patrol_return`` set, after
  that long on patrol the plan again, and so on); a track seen again ends the search.
  (Looking in one region only, the observer sat for good where the walker was not: a
  fifth of a 200-leg evaluation. Patrolling nearest first straight after the likely
  regions, it went the length of office while the walker dwelt in a room 6 m from where it
  was lost: a 255 s search.)
* **patrol**: nothing tracked and nothing predicted (the target never seen, or lost with no
  leg to predict): the building's roomy places in turn, nearest first; a place seen on the
  way (``patrol_sight``) counts as visited (:class:`PatrolTour`).
  A target not seen yet is first looked round for on the spot (``search_turn``), once,
  turning first to the side where more of the floor lies, and patrolled for after
  ``patrol_after`` seconds.
* **idle**: as patrol, on a floor with nowhere to patrol: stay.

Everything is plain numbers in, plain numbers out. The parameters, and why each is what it
is, are in people/follow_config.py; the patrol's tour and the search points in people/search.py.
This module decides which rule acts and follows; the give-way rules are in
people/follow_give_way.py, the search and patrol in people/follow_search.py, and the geometry
they share (the stand-off point, the target as a body) in people/follow_geometry.py.
"""
from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..geometry import wrap_angle
from ..nav.planner import PlanningGrid
from ..nav.pockets import floor_pockets
from .follow_config import FollowConfig, FollowDecision, FollowError
from .follow_geometry import GIVE_WAY_HYSTERESIS, MOVING, standoff_point
from .follow_give_way import GiveWayRules
from .follow_search import SearchRules
from .search import PatrolTour, SearchPlan, as_plan

__all__ = ["FollowError", "FollowConfig", "FollowDecision", "FollowBehaviour", "standoff_point"]


class FollowBehaviour(GiveWayRules, SearchRules):
    """Follow / search decisions for one observer and one target.

    Args:
        grid: the observer's planning grid (free cells are where it can stand).
        config: parameters.
    """

    def __init__(self, grid: PlanningGrid, config: Optional[FollowConfig] = None) -> None:
        self.grid = grid
        self.config = config or FollowConfig()
        self.config.check()
        self.mode = "idle"
        self.last_seen: Optional[float] = None
        self.last_target: Optional[Tuple[float, float]] = None
        self._goal_target: Optional[Tuple[float, float]] = None
        self._goal_time = -math.inf
        self._search = SearchPlan()
        self._search_index = 0
        self._rounds = 0                 # rounds of the search plan gone without a sight
        self._place = ""                 # what the current search goal is (for the log)
        self._unreached = 0              # places in a row whose goal ended short (_at_place)
        self._t0: Optional[float] = None   # when it first looked for a target not yet seen
        cfg = self.config
        self._tour = PatrolTour(grid, cfg.patrol_spacing, cfg.roomy, cfg.patrol_sight)
        self._search_phase = ""          # back | round | go | look | wait
        # after the plan: ("watch" | "patrol", hub index, until when; None: not begun)
        self._watch: Optional[Tuple[str, int, Optional[float]]] = None
        self._hubs: Optional[np.ndarray] = None
        self._patrol_since: Optional[float] = None   # when the patrol after the plan began
        self._search_since = -math.inf
        # (target x, y, time, destinations) of self._route
        self._route_key: Optional[Tuple[float, float, float, List[Tuple[float, float]]]] = None
        self._pass_key: Optional[tuple] = None   # _passes_by's last answer, and for what
        self._pass_ok = False
        self._route: Optional[np.ndarray] = None
        # the target's whole path to each destination of self._route_key, in its order
        # (None: no path)
        self._route_paths: List[Optional[np.ndarray]] = []
        self._yield: Optional[Tuple[float, float, float]] = None  # target x, y, t when it began
        self._standing = True            # no goal under way (the last one finished)
        self._last_velocity = (0.0, 0.0)  # the target's, when last seen
        self._looked = False             # looked round for a target not seen yet
        # (t, x, y): the target within distance since t, within give_way of (x, y) since
        self._close_since: Optional[Tuple[float, float, float]] = None
        # where it steps aside to (x, y) and the nearest it has been to it since: at the
        # step, then each tick _stepping_aside runs (the target unseen, under way there)
        self._aside: Optional[Tuple[float, float, float]] = None
        # (target x, y, observer x, y, t, whether a give-way step) of the last unblock step
        # (or, with give_way_through, give-way step) taken, until the target is seen more
        # than ``distance`` from where it stood or the step is used for a search
        # (FollowConfig.blocked_way)
        self._blocked: Optional[Tuple[float, float, float, float, float, bool]] = None
        self._parts: Optional[np.ndarray] = None    # _pockets(): the floor's parts
        self._pocket: Optional[np.ndarray] = None   # ... and which of them are pockets
        # the last goal sent: (x, y, whether it is a back-off _keeps_goal keeps)
        self._goal: Optional[Tuple[float, float, bool]] = None
        self._backing_off = False      # the goal _follow returns now is a back-off

    def update(self, t: float, robot: Sequence[float], target: Optional[Sequence[float]],
               destination=None, goal_done: bool = False) -> FollowDecision:
        """One decision.

        Args:
            t: time (s).
            robot: the observer's (x, y, yaw), map frame.
            target: the tracked target's (x, y, vx, vy) or None when not tracked now.
            destination: where the target is predicted to head: a list of (region id, search
                point (x, y)), most likely first (:func:`search_plan`), or one such pair, or
                None.
            goal_done: the navigation finished (reached or gave up) the last goal sent.
        """
        if goal_done:
            self._standing = True
        if target is not None:
            self._tour.goal = None
        if target is None and self._tour.goal is not None:
            self._tour.look_over(t, robot)   # patrolling: the places in view are seen
        decision = self._decide(t, robot, target, destination, goal_done)
        if decision.goal is not None and decision.mode != "give_way":
            decision = self._outside_pockets(robot, decision)
        if decision.goal is not None:
            self._standing = False
            self._goal = (decision.goal[0], decision.goal[1], self._backing_off)
        self._backing_off = False
        return decision

    def _outside_pockets(self, robot: Sequence[float], decision: FollowDecision
                         ) -> FollowDecision:
        """A goal in a pocket (see FollowConfig.snug) the observer is not in, moved to the
        nearest place within ``give_way_reach`` of it that is in no pocket (or in the
        observer's own part of the floor), facing the goal."""
        cfg = self.config
        if cfg.snug <= 0:
            return decision
        parts, pocket = self._pockets()
        assert decision.goal is not None
        gx, gy, gyaw = decision.goal
        own, there = self._part_at(parts, robot[0], robot[1]), self._part_at(parts, gx, gy)
        if there == own or not pocket[there]:
            return decision
        k = int(math.ceil(cfg.give_way_reach / self.grid.resolution))
        c, r = self.grid.to_cell(gx, gy)
        r0, c0 = max(r - k, 0), max(c - k, 0)
        window = parts[r0:r + k + 1, c0:c + k + 1]
        ok = np.isfinite(self.grid.cost[r0:r + k + 1, c0:c + k + 1]) & (
            (window == own) | ~pocket[window])
        rows, cols = np.nonzero(ok)
        if not len(rows):
            return decision
        x, y = (np.asarray(v, dtype=float) for v in self.grid.centres(cols + c0, rows + r0))
        d = np.hypot(x - gx, y - gy)
        i = int(np.argmin(d))
        if d[i] > cfg.give_way_reach:
            return decision
        px, py = float(x[i]), float(y[i])
        facing = math.atan2(gy - py, gx - px) if d[i] > 1e-6 else gyaw
        return FollowDecision(decision.mode, (px, py, facing), "%s; (%.2f, %.2f) is in a "
                              "pocket behind a snug passage: waiting at (%.2f, %.2f)"
                              % (decision.reason, gx, gy, px, py))

    def _pockets(self) -> Tuple[np.ndarray, np.ndarray]:
        """The floor's part labels and which are pockets (nav/pockets.py), made once."""
        if self._parts is None:
            self._parts, self._pocket = floor_pockets(self.grid, self.config.snug,
                                                      self.config.distance)
        assert self._pocket is not None
        return self._parts, self._pocket

    def _part_at(self, parts: np.ndarray, x: float, y: float) -> int:
        """The label of the part of the floor at (x, y) (0: off the grid)."""
        c, r = self.grid.to_cell(x, y)
        return int(parts[r, c]) if self.grid.inside(c, r) else 0

    def _decide(self, t: float, robot: Sequence[float], target: Optional[Sequence[float]],
                destination, goal_done: bool) -> FollowDecision:
        cfg = self.config
        if target is not None:
            # where it was seen and how fast it went, whatever the observer does about it
            # (the trail of a target lost after a give-way spell went by the velocity from
            # before it: mit_csail, searched for 200 s 8 m the wrong way)
            self.last_seen, self.last_target = t, (float(target[0]), float(target[1]))
            self._last_velocity = (float(target[2]), float(target[3]))
            if self._blocked is not None and math.hypot(
                    target[0] - self._blocked[0], target[1] - self._blocked[1]) > cfg.distance:
                self._blocked = None     # seen on its way from where it stood: not blocked
            plan = as_plan(destination)
            dests = [p for _, p in plan[:plan.likely]]
            way = self._give_way(t, robot, target, dests, goal_done)
            if way is None:
                way = self._unblock(t, robot, target, dests)
            return way if way is not None else self._follow(t, robot, target, goal_done)
        self._close_since = None    # (a target seen again starts its count afresh)
        if self._stepping_aside(t, robot):
            return FollowDecision("give_way")
        return self._lost(t, robot, destination, goal_done)

    def _follow(self, t: float, robot: Sequence[float], target: Sequence[float],
                goal_done: bool) -> FollowDecision:
        cfg = self.config
        tx, ty, vx, vy = (float(v) for v in target[:4])
        first = self.mode != "follow"
        self.mode = "follow"
        rx, ry, ryaw = (float(v) for v in robot[:3])
        dist = math.hypot(tx - rx, ty - ry)
        facing = math.atan2(ty - ry, tx - rx)
        moving = math.hypot(vx, vy) > MOVING
        moved = (math.inf if self._goal_target is None else
                 math.hypot(tx - self._goal_target[0], ty - self._goal_target[1]))
        cramped = self.grid.clearance_at(rx, ry) < cfg.roomy
        if not first and dist <= cfg.distance + cfg.slack and not moving and cramped \
                and self._standing:
            spot = self._roomy_spot(rx, ry, tx, ty)
            if spot is not None:
                self._goal_target, self._goal_time = (tx, ty), t
                self._backing_off = True
                return FollowDecision("follow", spot,
                                      "out of the narrow passage at (%.2f, %.2f)" % (rx, ry))
        if not first and dist <= cfg.distance + cfg.slack and not moving:
            if abs(wrap_angle(facing - ryaw)) > 0.5 and (goal_done or moved > cfg.replan_distance) \
                    and not self._keeps_goal(rx, ry, tx, ty, goal_done):
                self._goal_target, self._goal_time = (tx, ty), t
                return FollowDecision("follow", (rx, ry, facing), "turning to face the target")
            return FollowDecision("follow")
        # coming towards the observer: step aside (to the side of its heading nearer the
        # observer) instead of backing away in front of it into a dead end
        approaching = moving and (vx * (rx - tx) + vy * (ry - ty)) > 0.1 * dist
        due = (first or goal_done or moved > cfg.replan_distance
               or (moving and t - self._goal_time >= cfg.goal_period))
        if not due:
            return FollowDecision("follow")
        direction = None
        if approaching and dist < cfg.distance + cfg.slack:
            heading = math.atan2(vy, vx)
            side = 1.0 if wrap_angle(facing + math.pi - heading) >= 0 else -1.0
            direction = heading + side * math.pi / 2
        point = standoff_point(self.grid, (tx, ty), (rx, ry), cfg.distance, direction,
                               cfg.roomy, cfg.standoff_sight)
        self._goal_target, self._goal_time = (tx, ty), t
        if point is None:
            return FollowDecision("follow", (rx, ry, facing), "no free stand-off point: turning")
        gx, gy = point
        if math.hypot(gx - rx, gy - ry) < cfg.replan_distance:
            # a step shorter than the track's own jitter: turned to face it, not driven (a
            # blocked walker tracked 0.4 m to and fro had the observer turn from its goal
            # to the walker and back every 2 s in a narrow corridor: aces_austin); a goal
            # under way from before (a search's, a patrol's) is replaced all the same, but
            # not a follow goal still the stand-off distance from the target (out of a
            # narrow passage, back from a target too close): turned back to the target each
            # time it was seen again, the observer never got there and shut the walker in
            # (aces_austin, seattle, seed 1: 6 legs given up)
            if self._keeps_goal(rx, ry, tx, ty, goal_done):
                return FollowDecision("follow")
            if (abs(wrap_angle(facing - ryaw)) > 0.5 or goal_done or first
                    or not self._standing):
                return FollowDecision("follow", (rx, ry, facing), "stand-off point %.2f m "
                                      "off: turning to face the target"
                                      % math.hypot(gx - rx, gy - ry))
            return FollowDecision("follow")
        self._backing_off = dist < cfg.distance - GIVE_WAY_HYSTERESIS
        return FollowDecision("follow", (gx, gy, math.atan2(ty - gy, tx - gx)),
                              "target at (%.2f, %.2f)" % (tx, ty))

    def _keeps_goal(self, rx: float, ry: float, tx: float, ty: float, goal_done: bool) -> bool:
        """A back-off is under way (a follow goal sent out of a narrow passage, or back from
        a target nearer than ``distance`` - 0.2 m), still ``replan_distance`` or more from the
        observer at (rx, ry) and at least ``distance`` - 0.2 m from the target at (tx, ty):
        still a stand-off point (one the target came near is not)."""
        g, cfg = self._goal, self.config
        return (not goal_done and not self._standing and g is not None and g[2]
                and math.hypot(g[0] - rx, g[1] - ry) >= cfg.replan_distance
                and math.hypot(g[0] - tx, g[1] - ty) >= cfg.distance - GIVE_WAY_HYSTERESIS)
