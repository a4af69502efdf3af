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
  then patrols as long, then watches at the next hub); a track seen again ends the search.
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
"""
from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..nav.planner import (PlanError, PlanningGrid, disc_points, give_way_point,
                           path_length)
from ..geometry import wrap_angle
from ..nav.pockets import floor_pockets
from .follow_config import FollowConfig, FollowDecision, FollowError
from .search import PatrolTour, SearchPlan, as_plan, hub_points

_GIVE_WAY_HYSTERESIS = 0.2  # m: in the way below give_way less this; it steps to give_way
_MOVING = 0.15              # m/s: a target slower than this stands still
_DETOUR = 0.5               # m: stepping aside further from its place than this: a detour
_TRAIL_STEP = math.radians(15.0)  # the trail's turns round a wall that cuts it short
_AT_PLACE = 1.0             # m: a search or patrol place or hub this near is reached
_AHEAD = math.radians(75.0)  # a point this near the heading is in view (the Scitos's
                             # 180-degree lidar, less a body's width; as give_way_view)

__all__ = ["FollowError", "FollowConfig", "FollowDecision", "FollowBehaviour", "standoff_point"]


def standoff_point(grid: PlanningGrid, target: Sequence[float], robot: Sequence[float],
                   distance: float, direction: Optional[float] = None, roomy: float = 0.0,
                   sight: bool = False) -> Optional[Tuple[float, float]]:
    """A free point ``distance`` from ``target``, as close as possible to the direction of
    ``robot`` (or to the bearing ``direction`` from the target, when given; candidates within
    90 degrees of it either side, every 15 degrees, then on circles 0.75 and 0.5 times as
    big). A point with at least ``roomy`` metres of wall clearance (not in a doorway) on the
    observer's side of the target (within 90 degrees of the robot's bearing from it: the
    observer is not sent past the target) comes first. With ``sight``, only points with no
    wall between them and the target (:meth:`PlanningGrid.in_sight`) are taken, in the same
    order (the largest circle with one); when no free point is in sight (a target tracked in
    a wall's cell, or behind a corner from every candidate), the point chosen without
    ``sight``. None when no free point lies within ``distance`` of the target."""
    tx, ty = float(target[0]), float(target[1])
    own = math.atan2(float(robot[1]) - ty, float(robot[0]) - tx)
    base = own if direction is None else float(direction)
    first = first_seen = None
    for radius in (distance, 0.75 * distance, 0.5 * distance):
        for k in range(13):  # 0, +15, -15, +30, ... +-90 degrees
            a = base + math.radians(15.0 * ((k + 1) // 2) * (1 if k % 2 else -1))
            x, y = tx + radius * math.cos(a), ty + radius * math.sin(a)
            if not grid.is_free(x, y):
                continue
            seen = not sight or bool(grid.in_sight(np.array([[x, y]]), (tx, ty))[0])
            if first is None:
                first = (x, y)
            if seen and first_seen is None:
                first_seen = (x, y)
            if (seen and radius == distance and abs(wrap_angle(a - own)) <= 0.5 * math.pi + 1e-9
                    and grid.clearance_at(x, y) >= roomy):
                return x, y
        if first_seen is not None:
            return first_seen
    if sight and first is not None:   # none in sight: as without
        return standoff_point(grid, target, robot, distance, direction, roomy)
    return first


class FollowBehaviour:
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
        self._unreached = 0              # places in a row whose goal ended > _AT_PLACE off
        self._t0: Optional[float] = None   # when it first looked for a target not yet seen
        cfg = self.config
        self._tour = PatrolTour(grid, cfg.patrol_spacing, cfg.roomy, cfg.patrol_sight)
        self._search_phase = ""          # back | round | go | look | wait
        # after the plan: ("watch" | "patrol", hub index, until when; None: not begun)
        self._watch: Optional[Tuple[str, int, Optional[float]]] = None
        self._hubs: Optional[np.ndarray] = None
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
        if self.last_seen is not None and t - self.last_seen < cfg.lost_after:
            return FollowDecision(self.mode, None, "target unseen for %.1f s" % (
                t - self.last_seen))
        if self._t0 is None:
            self._t0 = t
        if self.last_seen is None and t - self._t0 < cfg.patrol_after:
            if not self._looked:   # not seen yet: look round once, then a while to see it
                self._looked = True
                rx, ry, ryaw = (float(v) for v in robot[:3])
                turn = self._first_turn(robot)
                return FollowDecision(self.mode, (rx, ry, wrap_angle(ryaw + turn)),
                                      "target not seen yet: looking round to the %s"
                                      % ("left" if turn > 0 else "right"))
            return FollowDecision(self.mode)
        plan = as_plan(destination)
        if not plan:
            return self._patrol_unseen(robot, goal_done)
        rx, ry, ryaw = (float(v) for v in robot[:3])
        if self.mode != "search" or ([r for r, _ in plan], plan.likely) != (
                [r for r, _ in self._search], self._search.likely):
            first_loss = self.mode != "search"
            self.mode, self._search, self._search_index, self._rounds = "search", plan, 0, 0
            self._unreached = 0
            self._tour.goal, self._watch = None, None
            lx, ly = self.last_target if self.last_target is not None else (rx, ry)
            # lost close by and behind: turned to where there is room to turn, else trailed
            # or looked at from a roomy place near by, else turned to (an octagonal base
            # turning in a passage 0.3 m from a wall backed and nudged for 30 s while the
            # walker it blocked stood at its side: aces_austin); close by but ahead (it
            # went behind a wall or through a door, and turning shows nothing): looked for
            # as one lost further off (with ``trail`` 0, or no sighting to tell: turned to)
            near = math.hypot(lx - rx, ly - ry)
            ahead = (cfg.trail > 0 and near > 1e-6
                     and abs(wrap_angle(math.atan2(ly - ry, lx - rx) - ryaw)) <= _AHEAD)
            close = near <= cfg.distance + cfg.slack and not ahead
            room = self.grid.clearance_at(rx, ry) >= cfg.roomy   # to turn (not in a doorway)
            through = self._through_point(t, rx, ry) if first_loss else None
            if through is not None:
                self._search_phase = "back"
                return FollowDecision("search", through, "target lost at (%.2f, %.2f) as the "
                                      "observer stepped out of its way: looking from where "
                                      "it stood, (%.2f, %.2f), the way it went through"
                                      % (lx, ly, *through[:2]))
            trail = self._trail_point() if first_loss and not (close and room) else None
            if first_loss and close and room:
                return self._look_back(rx, ry, lx, ly)
            if trail is not None:
                self._search_phase = "back"
                turn = wrap_angle(trail[2] - math.atan2(self._last_velocity[1],
                                                        self._last_velocity[0]))
                return FollowDecision("search", trail, "target lost at (%.2f, %.2f) going "
                                      "(%.2f, %.2f) m/s: trailing it to (%.2f, %.2f)%s"
                                      % (lx, ly, *self._last_velocity, *trail[:2],
                                         ", turned %+.0f degrees: a wall was in its way"
                                         % math.degrees(turn) if abs(turn) > 1e-6 else ""))
            if first_loss and close:
                spot = (self._roomy_spot(rx, ry, lx, ly)
                        if cfg.trail > 0 and self.last_target is not None else None)
                if spot is None:           # none within reach: turned to, as before
                    return self._look_back(rx, ry, lx, ly)
                self._search_phase = "back"
                return FollowDecision("search", spot, "target lost close by at (%.2f, %.2f), "
                                      "no room to turn: looking from (%.2f, %.2f)"
                                      % (lx, ly, *spot[:2]))
            seen = (self._seen_from(rx, ry) if first_loss and cfg.trail > 0
                    and self.last_target is not None else None)
            if seen is not None:
                self._search_phase = "back"
                return FollowDecision("search", seen, "target lost at (%.2f, %.2f), not "
                                      "trailed: going to look where it was, from (%.2f, %.2f)"
                                      % (lx, ly, *seen[:2]))
            return self._search_go(rx, ry, "target lost: searching predicted region")
        if self._search_phase == "back" and goal_done \
                and self.grid.clearance_at(rx, ry) >= cfg.roomy:
            # not in view from there: the other half of the view, where there is room to
            # turn (an octagonal base turning in a doorway wedged itself on its frame)
            self._search_phase = "round"
            return FollowDecision("search", (rx, ry, wrap_angle(ryaw + cfg.search_turn)),
                                  "not in view: looking round where it was lost")
        if self._search_phase in ("back", "round"):
            if goal_done:
                return self._search_go(rx, ry, "not there: searching predicted region")
            return FollowDecision("search")
        if self._search_phase == "go" and goal_done:
            return self._at_place(t, robot)
        if self._search_phase == "look" and goal_done:
            self._search_phase, self._search_since = "wait", t
        if self._search_phase == "wait" and t - self._search_since >= cfg.search_wait:
            return self._search_next(t, robot)
        return FollowDecision("search")

    def _through_point(self, t: float, rx: float, ry: float
                       ) -> Optional[Tuple[float, float, float]]:
        """With ``blocked_way``, for a target lost (the search starting within
        ``give_way_hold`` of an unblock step taken, it not seen more than ``distance`` from
        where it stood since; with ``give_way_through``, of a give-way step too, when the
        observer at (rx, ry), or the nearest ``_aside`` has it, is within _AT_PLACE of the
        place it stepped to: one it never got to was across the target's way, and going
        back put it in that way again; a step shorter than _AT_PLACE always counts, and
        where it stood is then at most that far): where the observer stood, when free,
        facing away from where the target stood (None otherwise). Used once a step."""
        cfg, blocked = self.config, self._blocked
        self._blocked = None
        if not cfg.blocked_way or blocked is None:
            return None
        tx, ty, ox, oy, since, give_way = blocked
        if give_way and (self._aside is None or min(
                self._aside[2], math.hypot(rx - self._aside[0], ry - self._aside[1])) > _AT_PLACE):
            return None
        if (t - since > cfg.give_way_hold or math.hypot(ox - tx, oy - ty) < 1e-6
                or not self.grid.is_free(ox, oy)):
            return None
        return ox, oy, math.atan2(oy - ty, ox - tx)

    def _look_back(self, rx: float, ry: float, lx: float, ly: float) -> FollowDecision:
        """Turn on the spot towards where a target lost close by at (lx, ly) would be
        ``look_lead`` seconds on at its last velocity (where it was, when it stood)."""
        self._search_phase = "back"
        vx, vy = self._last_velocity
        lead = self.config.look_lead if math.hypot(vx, vy) > _MOVING else 0.0
        ax, ay = (lx + vx * lead, ly + vy * lead) if lead else (lx, ly)
        if math.hypot(ax - rx, ay - ry) < 1e-6:   # (on the observer: where it was)
            ax, ay = lx, ly
        return FollowDecision("search", (rx, ry, math.atan2(ay - ry, ax - rx)),
                              "target lost close by at (%.2f, %.2f): looking back%s"
                              % (lx, ly, " to (%.2f, %.2f)" % (ax, ay) if lead else ""))

    def _at_place(self, t: float, robot: Sequence[float]) -> FollowDecision:
        """The goal to a search place, patrol place or hub has ended: looking round there;
        or, when it ended more than ``_AT_PLACE`` from the goal sent (no way from where it
        stands: a region's search point across a wall, mit_csail, was taken at once for
        reached and looked round from 3.5 m off, again and again), on to the next place,
        for as many places in a row as the search plan has (then it looks round where it
        is and waits as at a place reached: every way out may be shut, and a goal a tick
        is a plan a tick)."""
        cfg = self.config
        rx, ry, ryaw = (float(v) for v in robot[:3])
        gx, gy = self._goal[:2] if self._goal is not None else (rx, ry)
        short = math.hypot(gx - rx, gy - ry)
        why = "at %s: looking round" % self._place
        if short <= _AT_PLACE:
            self._unreached = 0
        elif self._unreached < max(1, len(self._search)):
            self._unreached += 1
            place, on = self._place, self._search_next(t, robot)
            return FollowDecision(on.mode, on.goal, "%s not reached (%.1f m short); %s"
                                  % (place, short, on.reason))
        else:
            why = "%s not reached (%.1f m short), %d places in a row: looking round here" % (
                self._place, short, self._unreached + 1)
            self._unreached = 0
        self._search_phase = "look"
        return FollowDecision("search", (rx, ry, wrap_angle(ryaw + cfg.search_turn)), why)

    def _search_next(self, t: float, robot: Sequence[float]) -> FollowDecision:
        """On from a region searched in vain: the next likely one, round after round, for
        ``search_rounds`` rounds; then each other region of the plan once, most likely
        first; then the patrol and the watches (:meth:`_patrol_or_watch`)."""
        cfg, plan = self.config, self._search
        rx, ry = float(robot[0]), float(robot[1])
        likely = max(1, plan.likely)
        if self._rounds < cfg.search_rounds:
            self._search_index = (self._search_index + 1) % likely
            self._rounds += 1 if self._search_index == 0 else 0
            if self._rounds < cfg.search_rounds:
                return self._search_go(rx, ry, "not found: searching region")
            self._search_index = likely - 1   # the others next, from the first after them
        if self._search_index + 1 < len(plan):
            self._search_index += 1
            return self._search_go(rx, ry, "not found in %d rounds of its likely regions: "
                                   "searching the next likeliest, region" % self._rounds)
        return self._patrol_or_watch(t, robot)

    def _patrol_or_watch(self, t: float, robot: Sequence[float]) -> FollowDecision:
        """The plan searched in vain: watch at a hub (looking round, waiting ``search_wait``,
        again and again) until ``watch`` seconds have passed since its first look and wait
        there (checked after each look and wait), then patrol until as long has passed
        (checked as each place is done), then the next hub. A hub it did not get within
        1 m of (no way there, or its way ended short) is not watched: the patrol follows.
        Searching, then patrolling alone, nearest place first, the observer went 24 minutes
        without meeting the walker in aces_austin, which kept walking its legs elsewhere
        (seed 6, a quarter of the run untracked); with watches, 9 minutes. But a
        walker that stays among a few neighbouring regions far from the hubs is found later
        (intel_lab), so ``watch`` is 0 by default (FollowConfig). Without hubs (none roomy
        enough) or with ``watch`` 0: the patrol alone, as before."""
        cfg = self.config
        rx, ry, ryaw = (float(v) for v in robot[:3])
        hubs = self._hub_places() if cfg.watch > 0 else np.zeros((0, 2))
        if not len(hubs):
            return self._patrol_go(rx, ry)
        if self._watch is None:
            return self._watch_go(rx, ry, 0)
        kind, k, until = self._watch
        if kind == "watch":
            hx, hy = float(hubs[k, 0]), float(hubs[k, 1])
            if until is None:
                # arrived (or its way there ended): the watch runs from here, at the hub only
                at_hub = math.hypot(rx - hx, ry - hy) <= _AT_PLACE
                until = t + cfg.watch if at_hub else t
                self._watch = (kind, k, until)
            if t < until:
                self._search_phase = "look"
                return FollowDecision("search", (rx, ry, wrap_angle(ryaw + cfg.search_turn)),
                                      "watching at hub %d: looking round" % (k + 1))
            self._watch = ("patrol", k, t + cfg.watch)
            self._tour.been_at(hx, hy)    # the hub is a patrol place: not the first one now
            return self._patrol_go(rx, ry)
        if until is not None and t < until:
            return self._patrol_go(rx, ry)
        return self._watch_go(rx, ry, (k + 1) % len(hubs))

    def _watch_go(self, rx: float, ry: float, k: int) -> FollowDecision:
        """On to hub ``k`` to watch there."""
        hubs = self._hub_places()
        self._watch = ("watch", k, None)
        self._place, self._tour.goal = "hub %d" % (k + 1), None
        return self._go(rx, ry, float(hubs[k, 0]), float(hubs[k, 1]),
                        "not found in %d rounds of its likely regions: watching at the place "
                        "most ways pass (hub %d of %d)" % (self._rounds, k + 1,
                                                           len(hubs)))

    def _hub_places(self) -> np.ndarray:
        """The building's hubs (:func:`hub_points` of the patrol places; made when first
        needed): room for the target to pass the observer there (three robot radii to the
        walls), at most three."""
        if self._hubs is None:
            cfg = self.config
            self._hubs = hub_points(self.grid, self._tour.places, cfg.patrol_spacing,
                                    3.0 * self.grid.config.robot_radius, 3)
        return self._hubs

    def _give_way(self, t: float, robot: Sequence[float], target: Sequence[float],
                  dests: List[Tuple[float, float]], goal_done: bool
                  ) -> Optional[FollowDecision]:
        """The decision while giving way (None: follow as usual). ``dests``: the points of
        the likely destinations (the search plan's)."""
        cfg = self.config
        tx, ty = float(target[0]), float(target[1])
        rx, ry, ryaw = (float(v) for v in robot[:3])
        if self._yield is not None and self.mode != "give_way":
            self._yield = None   # a search or follow goal replaced the give-way goal since
        if self._yield is not None:
            yx, yy, yt = self._yield
            if math.hypot(tx - yx, ty - yy) < cfg.distance and t - yt < cfg.give_way_hold:
                self.mode = "give_way"
                facing = math.atan2(ty - ry, tx - rx)
                if goal_done and abs(wrap_angle(facing - ryaw)) > 0.5:
                    return FollowDecision("give_way", (rx, ry, facing), "facing the target")
                return FollowDecision("give_way")
            self._yield = None
        if not dests or math.hypot(tx - rx, ty - ry) > cfg.distance + cfg.slack:
            return None
        route = self._target_routes(t, (tx, ty), dests)
        if not len(route):
            return None      # no destination it can be planned to from where it is seen
        ahead = route[_distance_to(route, tx, ty) >= cfg.give_way]  # its way, not where it is
        # in the way: nearer than the clearance it goes to, less a margin (no stepping again
        # from where it stepped to, within the navigation's goal tolerance); the place it goes
        # to keeps clear of the whole of each way, from the target on
        if _distance_to(ahead, rx, ry).min() >= cfg.give_way - _GIVE_WAY_HYSTERESIS:
            return None
        if cfg.pass_detour > 0 and self._passes_by((tx, ty), (rx, ry), dests):
            return None   # on its way, but it goes round: the observer keeps it in view
        way = self._step_aside(t, (rx, ry), (tx, ty), route,
                               "on the target's way to %d likely destination(s)" % len(dests))
        if way is not None and cfg.give_way_through:   # (FollowConfig.give_way_through)
            self._blocked = (tx, ty, rx, ry, t, True)
        return way

    def _stepping_aside(self, t: float, robot: Sequence[float]) -> bool:
        """Still on the way to the place it steps aside to, within ``give_way_hold`` and
        getting nearer to it (no more than _DETOUR further than it has been: not the long
        way round): a target lost from view meanwhile (behind the observer as it drives out
        of the way) is looked for once it is there. Searching at once turned it back into
        the target's way, to and fro in a narrow passage (aces_austin: the walker shut in
        for minutes)."""
        if not (self.mode == "give_way" and self._yield is not None and not self._standing
                and self._aside is not None and t - self._yield[2] < self.config.give_way_hold):
            return False
        ax, ay, nearest = self._aside
        d = math.hypot(float(robot[0]) - ax, float(robot[1]) - ay)
        self._aside = (ax, ay, min(nearest, d))
        return d <= nearest + _DETOUR

    def _unblock(self, t: float, robot: Sequence[float], target: Sequence[float],
                 dests: List[Tuple[float, float]]) -> Optional[FollowDecision]:
        """Stepping out of the way of a target that came nearer than ``distance`` - 0.2 m
        and has stayed within ``distance`` of the observer and within ``give_way`` of where
        it was for ``unblock`` seconds (see FollowConfig.unblock), or None."""
        cfg = self.config
        tx, ty = float(target[0]), float(target[1])
        rx, ry = float(robot[0]), float(robot[1])
        d = math.hypot(tx - rx, ty - ry)
        if cfg.unblock <= 0 or d >= cfg.distance:
            self._close_since = None
            return None
        if self._close_since is None or math.hypot(
                tx - self._close_since[1], ty - self._close_since[2]) > cfg.give_way:
            # close by from now (not at the stand-off distance, where the observer waits
            # for a target that dwells), or it got on its way
            self._close_since = ((t, tx, ty) if d < cfg.distance - _GIVE_WAY_HYSTERESIS
                                 else None)
            if self._close_since is None:
                return None
        if t - self._close_since[0] < cfg.unblock:
            return None
        self._close_since = None
        routes = [self._target_routes(t, (tx, ty), dests)] if dests else []
        keep = np.vstack(routes + [np.array([[tx, ty], [rx, ry]])])
        why = "the target has stood within %.1f m for %.0f s" % (cfg.distance, cfg.unblock)
        way = self._step_aside(t, (rx, ry), (tx, ty), keep, why)
        if way is None and dests:
            # no place off its ways (the observer in the doorway of a small room the target
            # heads into, where no place is give_way off the way in: seattle, 60 s blocked
            # for good): a place off the target, its destinations and where the observer
            # stands, deeper in, will do
            keep = np.array([[tx, ty], [rx, ry]] + [list(d) for d in dests])
            way = self._step_aside(t, (rx, ry), (tx, ty), keep, why + " (off its destinations)")
        if way is not None:    # it steps out of the target's way (FollowConfig.blocked_way)
            self._blocked = (tx, ty, rx, ry, t, False)
        return way

    def _step_aside(self, t: float, robot: Tuple[float, float], target: Tuple[float, float],
                    keep: np.ndarray, why: str) -> Optional[FollowDecision]:
        """Go to the nearest place ``give_way`` from the target and from the points ``keep``
        (navigator.give_way_point: a roomy one in view first), facing the target, and hold
        there as giving way; None when there is no such place."""
        cfg = self.config
        tx, ty = target
        point = give_way_point(self.grid, keep, robot, target, cfg.give_way,
                               cfg.give_way_reach, cfg.roomy, obstacles=self._body(tx, ty),
                               in_view=cfg.give_way_view)
        if point is None:
            return None
        self._yield = (tx, ty, t)
        self.mode = "give_way"
        self._goal_target, self._goal_time = (tx, ty), t
        gx, gy = point
        self._aside = (gx, gy, math.hypot(gx - robot[0], gy - robot[1]))
        return FollowDecision("give_way", (gx, gy, math.atan2(ty - gy, tx - gx)),
                              "%s: stepping to (%.2f, %.2f)" % (why, gx, gy))

    def _target_routes(self, t: float, target: Tuple[float, float],
                       dests: List[Tuple[float, float]]) -> np.ndarray:
        """The points of the target's planned paths to each of ``dests``, their first
        ``distance + slack + give_way_reach`` metres; planned again when the target moved
        ``replan_distance`` or the destinations changed, at most every ``goal_period`` s (an
        A* across a hall is 10-20 ms). The whole paths go to ``_route_paths``."""
        cfg = self.config
        key = self._route_key
        if key is not None and (t - key[2] < cfg.goal_period or (
                math.hypot(target[0] - key[0], target[1] - key[1]) < cfg.replan_distance
                and key[3] == dests)):
            assert self._route is not None   # made right after the key
            return self._route
        keep = cfg.distance + cfg.slack + cfg.give_way_reach
        parts = [np.zeros((0, 2))]
        paths = [self._plan_or_none(target, dest) for dest in dests]
        for path in paths:
            if path is None:
                continue
            steps = np.hypot(*np.diff(path, axis=0).T) if len(path) > 1 else np.zeros(0)
            parts.append(path[np.concatenate([[0.0], np.cumsum(steps)]) <= keep])
        # the key last: a plan that raises leaves the last routes and their key together
        self._route, self._route_paths = np.vstack(parts), paths
        self._route_key = (target[0], target[1], t, list(dests))
        return self._route

    def _passes_by(self, target: Tuple[float, float], robot: Tuple[float, float],
                   dests: List[Tuple[float, float]]) -> bool:
        """Whether the target gets round the observer (a disc of the grid's radius) on each of
        its paths to ``dests`` (``_route_paths`` when they are its routes' destinations and
        it is still on them, within a radius, or they found none; else planned from where
        it is) that comes within two radii and two planning cells of it, by a way at most
        ``pass_detour`` m longer than the path. Planned first only to the path's first point
        past the observer that is ``pass_detour`` + two radii from it (or the path's end):
        a plan across a big floor is 20 ms, and planned to every destination this check
        took 8 % of a hall's tick. When that stretch cannot be passed so (a way round that
        rejoins further on, e.g. down a parallel aisle, is charged for walking back to it),
        planned to the destination. Kept while the target's routes are and the observer
        stays in its planning cell, whatever the destinations (as before the stretch)."""
        key = (self._route_key[2] if self._route_key else None, self.grid.to_cell(*robot))
        if self._pass_key == key:
            return self._pass_ok
        radius, detour = self.grid.config.robot_radius, self.config.pass_detour
        body = disc_points(robot[0], robot[1], radius)
        kept = self._route_paths if self._route_key and self._route_key[3] == dests else []
        paths = [kept[i] if i < len(kept) and _on_path(kept[i], target, radius)
                 else self._plan_or_none(target, dest) for i, dest in enumerate(dests)]
        ok = True
        for path, dest in zip(paths, dests):
            end = _past(path, target, robot, 2.0 * (radius + self.grid.resolution),
                        2.0 * radius + detour)
            if end is None:
                continue
            near = self._round_within(target, end, body)
            if near is None or (not near and end != tuple(dest)):
                near = self._round_within(target, dest, body)
            if near is False:   # None: not plannable even without it, as if not its way
                ok = False
                break
        self._pass_key, self._pass_ok = key, ok
        return ok

    def _plan_or_none(self, start: Tuple[float, float],
                      goal: Sequence[float]) -> Optional[np.ndarray]:
        """The target's planned path from ``start`` to ``goal`` (None: it cannot be planned)."""
        try:
            return self.grid.plan(start, goal)
        except PlanError:
            return None

    def _round_within(self, target: Tuple[float, float], goal: Sequence[float],
                      body: np.ndarray) -> Optional[bool]:
        """Whether the target's plan to ``goal`` round ``body`` is at most ``pass_detour``
        longer than its plan without it (None: there is no plan without it either)."""
        try:
            free = path_length(self.grid.plan(target, goal))
        except PlanError:
            return None
        try:
            return path_length(self.grid.plan(target, goal, obstacles=body)) <= \
                free + self.config.pass_detour
        except PlanError:
            return False

    def _trail_point(self) -> Optional[Tuple[float, float, float]]:
        """Where a target lost while moving went: ``trail`` seconds on from where it was last
        seen at its last velocity, stopped at the first cell the observer cannot stand on, or
        short of it at the last point with ``roomy`` clearance, facing the way it went (None:
        it stood still, ``trail`` is 0, or no point on the way is that roomy: it would wait in
        a doorway). A way that a blocked cell cuts short (past the first free one: the lost
        point may lie nearer a wall than the observer can stand; a way that starts through
        a wall is not clear either) is turned, by up to ``trail_turn`` either way in steps
        of 15 degrees (left first), to the least turned way free for the whole trail with a
        roomy point on it, facing that way; with none, straight on as far as it goes."""
        if self.config.trail <= 0 or self.last_target is None:
            return None
        vx, vy = self._last_velocity
        speed = math.hypot(vx, vy)
        if speed <= _MOVING:
            return None
        lx, ly = self.last_target
        straight, clear = self._trail_along(lx, ly, vx, vy, speed)
        if clear:
            return straight
        for k in range(1, int(self.config.trail_turn / _TRAIL_STEP + 1e-9) + 1):
            for turn in (k * _TRAIL_STEP, -k * _TRAIL_STEP):
                c, s = math.cos(turn), math.sin(turn)
                point, clear = self._trail_along(lx, ly, vx * c - vy * s, vx * s + vy * c, speed)
                if clear and point is not None:
                    return point
        return straight

    def _trail_along(self, lx: float, ly: float, vx: float, vy: float, speed: float
                     ) -> Tuple[Optional[Tuple[float, float, float]], bool]:
        """The trail from (lx, ly), where the target was last seen, at velocity (vx, vy)
        of norm ``speed`` for ``trail`` seconds (see :meth:`_trail_point`; None: no free
        point on it, or none roomy) and whether it is clear: no blocked cell on it past its
        first free one, and no wall before that."""
        step = self.grid.resolution
        n = max(1, int(self.config.trail * speed / step))
        s = np.arange(n + 1) * step / speed
        free = [self.grid.is_free(lx + vx * k, ly + vy * k) for k in s]
        if not any(free):
            return None, False
        i0 = i = free.index(True)
        # clear: free on from the first free cell, and the cells before it (the target was
        # lost nearer a wall than the observer's centre may go) not in a wall: no way
        # through a thin wall
        clear = all(free[i0:]) and not (i0 and bool(self.grid.on_walls(
            np.column_stack((lx + vx * s[:i0], ly + vy * s[:i0])), 0.0).any()))
        while i + 1 <= n and free[i + 1]:
            i += 1
        roomy = self.config.roomy
        while i >= i0 and self.grid.clearance_at(lx + vx * s[i], ly + vy * s[i]) < roomy:
            i -= 1
        if i < i0:
            return None, clear
        return (lx + vx * s[i], ly + vy * s[i], math.atan2(vy, vx)), clear

    def _first_turn(self, robot: Sequence[float]) -> float:
        """The look round for a target not seen yet: ``search_turn`` (at most a little under
        a half turn, so that the way round is this one) to the side, left (> 0) or right, on
        which more of the passable floor lies. The walker is somewhere on that floor: on
        orebro and acapulco_convention the observer started 10 m from it with it at its
        side, turned the other way and lost it for 6 minutes."""
        x, y, yaw = (float(v) for v in robot[:3])
        rows, cols = np.nonzero(np.isfinite(self.grid.cost))   # once a run: not kept
        fx, fy = self.grid.centres(cols, rows)
        left = float(np.sum(np.sin(np.arctan2(fy - y, fx - x) - yaw)))
        turn = min(self.config.search_turn, math.pi - 0.05)
        return turn if left >= 0.0 else -turn

    def _seen_from(self, rx: float, ry: float) -> Optional[Tuple[float, float, float]]:
        """Where to look from at the place a target was last seen (one that stood still, or
        went where no roomy point lies on its way): the point ``look_distance`` from it on
        the observer's side, roomy first (:func:`standoff_point`; the stand-off point at
        ``distance`` when none is free that near), facing it, or, from nearer than 0.5 m,
        facing the way the observer came to it (None: no free point). Going straight to
        the predicted region instead, the observer drove 33 m off while the walker it lost
        3 m away stood in the room beside it for 120 s (orebro)."""
        assert self.last_target is not None
        cfg, (lx, ly) = self.config, self.last_target
        point = standoff_point(self.grid, (lx, ly), (rx, ry), cfg.look_distance, None, cfg.roomy,
                               cfg.standoff_sight)
        if point is None and cfg.look_distance != cfg.distance:
            point = standoff_point(self.grid, (lx, ly), (rx, ry), cfg.distance, None, cfg.roomy,
                                   cfg.standoff_sight)
        if point is None:
            return None
        px, py = point
        if math.hypot(lx - px, ly - py) >= 0.5 or math.hypot(lx - rx, ly - ry) < 1e-6:
            return px, py, math.atan2(ly - py, lx - px)
        return px, py, math.atan2(ly - ry, lx - rx)

    def _search_go(self, rx: float, ry: float, why: str) -> FollowDecision:
        region, (x, y) = self._search[self._search_index]
        self._place, self._tour.goal = "region %s's search point" % region, None
        return self._go(rx, ry, x, y, "%s %s (%d of %d)" % (
            why, region, self._search_index + 1, len(self._search)))

    def _patrol_unseen(self, robot: Sequence[float], goal_done: bool) -> FollowDecision:
        """Nothing tracked and nothing predicted (a target never seen, or lost with no leg to
        predict): patrol the building's roomy places, nearest first, one after the other; an
        observer that started out of sight of its target stood still for ever before. Idle
        only where there is nowhere to patrol."""
        rx, ry = float(robot[0]), float(robot[1])
        if len(self._tour.places) == 0:
            if self.mode != "idle":
                self.mode = "idle"
                return FollowDecision("idle", None, "target lost, no predicted destination")
            return FollowDecision("idle")
        if self.mode != "patrol" or goal_done:
            self.mode = "patrol"
            d = self._patrol_go(rx, ry)
            return FollowDecision("patrol", d.goal, "nothing tracked or predicted: patrolling "
                                  "(%s)" % self._place)
        return FollowDecision("patrol")

    def _patrol_go(self, rx: float, ry: float) -> FollowDecision:
        """On to the nearest patrol place not visited in this tour (a new tour when all are)."""
        n = len(self._tour.places)
        if n == 0:   # the likely regions again, from the most likely
            self._search_index = 0
            return self._search_go(rx, ry, "not found, nowhere to patrol: searching region")
        k, x, y = self._tour.next(rx, ry)
        self._place = "patrol place %d" % (k + 1)
        return self._go(rx, ry, x, y, "not found in %d rounds of its likely regions: patrolling "
                        "(%s of %d)" % (self._rounds, self._place, n))

    def _go(self, rx: float, ry: float, x: float, y: float, why: str) -> FollowDecision:
        self._search_phase = "go"
        yaw = math.atan2(y - ry, x - rx) if math.hypot(x - rx, y - ry) > 1e-6 else 0.0
        return FollowDecision("search", (x, y, yaw), why)

    def _body(self, tx: float, ty: float) -> np.ndarray:
        """The target as the planner's obstacles: a body of the observer's radius (as
        _passes_by has it), not a point. As a point, the place to step aside to could lie
        past the target in a 2 m corridor, where the observer could not get by it
        (aces_austin: it stood behind the walker, blocking it, until the walker went 80 m
        round the loop)."""
        return disc_points(tx, ty, self.grid.config.robot_radius)

    def _roomy_spot(self, rx: float, ry: float, tx: float, ty: float
                    ) -> Optional[Tuple[float, float, float]]:
        """A place with ``roomy`` clearance, to turn in, facing the target at (tx, ty): the
        stand-off point (:func:`standoff_point`: on the observer's side when one there is
        roomy; with ``standoff_sight``, in view of the target when one is), or when it is
        not roomy (a long narrow corridor) the nearest roomy place up to ``give_way_reach``
        away, ``give_way`` from the target and reached without passing it
        (:func:`give_way_point`); None: neither is roomy."""
        cfg = self.config
        point = standoff_point(self.grid, (tx, ty), (rx, ry), cfg.distance, None, cfg.roomy,
                               cfg.standoff_sight)
        if point is None or self.grid.clearance_at(*point) < cfg.roomy:
            point = give_way_point(self.grid, np.array([[tx, ty]]), (rx, ry), (tx, ty),
                                   cfg.give_way, cfg.give_way_reach, cfg.roomy,
                                   obstacles=self._body(tx, ty))
        if point is None or self.grid.clearance_at(*point) < cfg.roomy:
            return None
        gx, gy = point
        return gx, gy, math.atan2(ty - gy, tx - gx)

    def _follow(self, t: float, robot: Sequence[float], target: Sequence[float],
                goal_done: bool) -> FollowDecision:
        cfg = self.config
        tx, ty, vx, vy = (float(v) for v in target[:4])
        first = self.mode != "follow"
        self.mode = "follow"
        rx, ry, ryaw = (float(v) for v in robot[:3])
        dist = math.hypot(tx - rx, ty - ry)
        facing = math.atan2(ty - ry, tx - rx)
        moving = math.hypot(vx, vy) > _MOVING
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
        self._backing_off = dist < cfg.distance - _GIVE_WAY_HYSTERESIS
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
                and math.hypot(g[0] - tx, g[1] - ty) >= cfg.distance - _GIVE_WAY_HYSTERESIS)


def _on_path(path: Optional[np.ndarray], target: Sequence[float], within: float) -> bool:
    """Whether ``target`` is within ``within`` m of a point of ``path``; True for no path
    (kept: the destination could not be planned to a moment ago either)."""
    return path is None or bool(_distance_to(path, target[0], target[1]).min() <= within)


def _past(path: Optional[np.ndarray], target: Sequence[float], robot: Sequence[float],
          near: float, beyond: float) -> Optional[Tuple[float, float]]:
    """The first point of ``path`` (N, 2), from its point nearest ``target`` on, that is
    ``beyond`` metres from ``robot`` after the path's nearest approach to it, or its last
    point; None when there is no path or it never comes within ``near`` of the robot."""
    if path is None or not len(path):
        return None
    rest = path[int(np.argmin(_distance_to(path, target[0], target[1]))):]
    d = _distance_to(rest, robot[0], robot[1])
    i = int(np.argmin(d))
    if d[i] >= near:
        return None
    far = np.nonzero(d[i:] >= beyond)[0]
    x, y = rest[i + int(far[0])] if len(far) else rest[-1]
    return float(x), float(y)


def _distance_to(points: np.ndarray, x: float, y: float) -> np.ndarray:
    """Distance from (x, y) to each of the (N, 2) points (inf for none)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(pts):
        return np.array([math.inf])
    return np.hypot(pts[:, 0] - x, pts[:, 1] - y)
