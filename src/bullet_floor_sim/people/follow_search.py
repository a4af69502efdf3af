"""The observer's search for a target it lost, and its patrol (people/follow.py's
**search**, **patrol** and **idle**): where it looks first (from where it stood, turned to,
trailed, where it was), then the predicted regions, then the watches and the patrol.

:class:`SearchRules` is a part of :class:`people.follow.FollowBehaviour`, which holds the
state it reads and sets (declared below) and makes its decisions; on its own it is nothing.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numpy as np

from ..geometry import wrap_angle
from ..nav.planner import PlanningGrid, give_way_point
from .follow_config import FollowConfig, FollowDecision
from .follow_geometry import MOVING, standoff_point, target_body
from .search import PatrolTour, SearchPlan, as_plan, hub_points

_TRAIL_STEP = math.radians(15.0)  # the trail's turns round a wall that cuts it short
_AT_PLACE = 1.0             # m: a search or patrol place or hub this near is reached
_AHEAD = math.radians(75.0)  # a point this near the heading is in view (the Scitos's
                             # 180-degree lidar, less a body's width; as give_way_view)


class SearchRules:
    """The search and patrol part of FollowBehaviour (its state is FollowBehaviour's)."""

    grid: PlanningGrid
    config: FollowConfig
    mode: str
    last_seen: Optional[float]
    last_target: Optional[Tuple[float, float]]
    _search: SearchPlan
    _search_index: int
    _rounds: int
    _place: str
    _unreached: int
    _t0: Optional[float]
    _tour: PatrolTour
    _search_phase: str
    _watch: Optional[Tuple[str, int, Optional[float]]]
    _hubs: Optional[np.ndarray]
    _patrol_since: Optional[float]
    _search_since: float
    _last_velocity: Tuple[float, float]
    _looked: bool
    _aside: Optional[Tuple[float, float, float]]
    _blocked: Optional[Tuple[float, float, float, float, float, bool]]
    _goal: Optional[Tuple[float, float, bool]]

    def _lost(self, t: float, robot: Sequence[float], destination, goal_done: bool
              ) -> FollowDecision:
        """The decision with no target tracked (and no give-way step under way): wait
        ``lost_after``; a target not seen yet is looked round for once and patrolled for
        after ``patrol_after``; one lost is looked for as the module's docstring says (from
        where the observer stood, turned to, trailed, looked for where it was), then in the
        predicted regions (``destination``: see FollowBehaviour.update), then on patrol."""
        cfg = self.config
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
            self._tour.goal, self._watch, self._patrol_since = None, None, None
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
        lead = self.config.look_lead if math.hypot(vx, vy) > MOVING else 0.0
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
        first; then the patrol and the watches (:meth:`_patrol_or_watch`), and after
        ``patrol_return`` seconds of them the plan again from its most likely region."""
        cfg, plan = self.config, self._search
        rx, ry = float(robot[0]), float(robot[1])
        likely = max(1, plan.likely)
        if (cfg.patrol_return > 0 and self._patrol_since is not None
                and t - self._patrol_since >= cfg.patrol_return):
            self._search_index, self._rounds, self._patrol_since = 0, 0, None
            if self._watch is not None:   # the next patrol goes on to the next hub
                self._watch = ("patrol", self._watch[1], -math.inf)
            return self._search_go(rx, ry, "not found on %g s of patrol: back to the likely "
                                   "regions, region" % cfg.patrol_return)
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
        if self._patrol_since is None:
            self._patrol_since = t
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
        if speed <= MOVING:
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
                                   obstacles=target_body(self.grid, tx, ty))
        if point is None or self.grid.clearance_at(*point) < cfg.roomy:
            return None
        gx, gy = point
        return gx, gy, math.atan2(ty - gy, tx - gx)
