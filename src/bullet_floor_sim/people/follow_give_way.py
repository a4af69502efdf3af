"""The observer's give-way rules (people/follow.py's **give way**): stepping off the
target's predicted way, and out of the way of a target that stands close by (``unblock``).

:class:`GiveWayRules` is a part of :class:`people.follow.FollowBehaviour`, which holds the
state it reads and sets (declared below) and makes its decisions; on its own it is nothing.
"""
from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..geometry import wrap_angle
from ..nav.planner import PlanError, PlanningGrid, disc_points, give_way_point, path_length
from .follow_config import FollowConfig, FollowDecision
from .follow_geometry import (GIVE_WAY_HYSTERESIS, distance_to, on_path, point_past,
                              target_body)

_DETOUR = 0.5               # m: stepping aside further from its place than this: a detour


class GiveWayRules:
    """The give-way part of FollowBehaviour (its state is FollowBehaviour's, see there)."""

    grid: PlanningGrid
    config: FollowConfig
    mode: str
    _goal_target: Optional[Tuple[float, float]]
    _goal_time: float
    _standing: bool
    _yield: Optional[Tuple[float, float, float]]
    _aside: Optional[Tuple[float, float, float]]
    _close_since: Optional[Tuple[float, float, float]]
    _blocked: Optional[Tuple[float, float, float, float, float, bool]]
    _route_key: Optional[Tuple[float, float, float, List[Tuple[float, float]]]]
    _route: Optional[np.ndarray]
    _route_paths: List[Optional[np.ndarray]]
    _pass_key: Optional[tuple]
    _pass_ok: bool

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
        ahead = route[distance_to(route, tx, ty) >= cfg.give_way]  # its way, not where it is
        # in the way: nearer than the clearance it goes to, less a margin (no stepping again
        # from where it stepped to, within the navigation's goal tolerance); the place it goes
        # to keeps clear of the whole of each way, from the target on
        if distance_to(ahead, rx, ry).min() >= cfg.give_way - GIVE_WAY_HYSTERESIS:
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
            self._close_since = ((t, tx, ty) if d < cfg.distance - GIVE_WAY_HYSTERESIS
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
        (nav/give_way.give_way_point: a roomy one in view first), facing the target, and hold
        there as giving way; None when there is no such place."""
        cfg = self.config
        tx, ty = target
        point = give_way_point(self.grid, keep, robot, target, cfg.give_way,
                               cfg.give_way_reach, cfg.roomy,
                               obstacles=target_body(self.grid, tx, ty), in_view=cfg.give_way_view)
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
        paths = [kept[i] if i < len(kept) and on_path(kept[i], target, radius)
                 else self._plan_or_none(target, dest) for i, dest in enumerate(dests)]
        ok = True
        for path, dest in zip(paths, dests):
            end = point_past(path, target, robot, 2.0 * (radius + self.grid.resolution),
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
