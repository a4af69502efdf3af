"""The Navigator: one goal at a time, planned, followed, re-planned around what blocks it.

It plans on a :class:`~bullet_floor_sim.nav.grid.PlanningGrid`, drives with a
:class:`~bullet_floor_sim.nav.pursuit.PathFollower`, re-plans around other robots, backs off
when stalled and, with ``give_way``, yields to a robot it meets (nav/give_way.py's
:func:`give_way_point`, or a passing place: nav/passing.py). Its parameters and its status
are in nav/navigator_config.py.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numpy as np

from ..geometry import wrap_angle
from .give_way import give_way_point
from .grid import PlanError, PlanningGrid, path_length
from .navigator_config import NavigatorConfig, NavStatus
from .pursuit import FollowerCommand, PathFollower, to_map

__all__ = ["GOAL_TAKEN", "NavStatus", "Navigator", "NavigatorConfig", "give_way_point"]

#: how the message of a goal aborted because something stands on it begins
GOAL_TAKEN = "the goal is taken"

_BACKUP_SPEED, _BACKUP_TIME = 0.1, 1.5   # m/s, s: a stalled robot backs off 0.15 m
#: stalls in a row, neither way clear and unable to turn, before it backs off or nudges
#: forward anyway (the way with more room)
_BOXED_STALLS = 2
#: m: a back-off may end this much nearer a wall than where it starts (one map cell: a
#: robot wedged on a wall's corner at 0.339 m of clearance could only back off to 0.325 m,
#: and was refused it for good)
_BACKUP_SLACK = 0.05
_MAX_RETREATS = 3   # per goal: then it only plans round, steps aside or waits where it is
#: m beyond the robot's radius: a scan point this near the goal leaves no room to stand there
_GOAL_MARGIN = 0.1
#: s: a goal counts as taken once something stood on it in every scan this long (not a
#: person crossing it)
_TAKEN_FOR = 1.0
_MAX_REBASES = 20   # new plans a goal whose length restarts the progress count
#: m: a robot that stalled backing up (into what its scan does not show behind it) backs up
#: no more that goal, nor any goal it starts within this distance of where it stalled (the
#: move a stall must make to count as getting free, below)
_STUCK_MOVE = 0.25


def _ahead(pose: Sequence[float], world: np.ndarray) -> bool:
    """Whether the middle of ``world`` (points of what blocks it) lies ahead of ``pose``
    (x, y, yaw): not what it follows out of sight behind, not a box beside."""
    cx, cy = (float(v) for v in world.mean(axis=0))
    yaw = float(pose[2])
    return (cx - float(pose[0])) * math.cos(yaw) + (cy - float(pose[1])) * math.sin(yaw) > 0.0


class Navigator:
    """Plan, follow, and recover: the embedded move_base.

    Args:
        grid: the planning grid.
        follower: the pure-pursuit controller.
        config: recovery parameters.
        after: the Navigator of the goal before, for a node that makes one a goal
            (ros/path_follower.py): where its backing up stalled carries over, as it does
            for one Navigator given goal after goal (the study's).
    """

    def __init__(self, grid: PlanningGrid, follower: Optional[PathFollower] = None,
                 config: Optional[NavigatorConfig] = None,
                 after: Optional["Navigator"] = None) -> None:
        self.grid = grid
        self.follower = follower or PathFollower()
        self.follower.clearance = grid.clearance_along
        self.config = config or NavigatorConfig()
        self.goal: Optional[Tuple[float, float, Optional[float]]] = None
        self.replans = 0
        self._blocked_since: Optional[float] = None
        self._blocked_total = 0.0
        self._best = math.inf
        self._left = math.inf         # the way left along the path (m), last update
        self._best_t = 0.0
        self._last_t: Optional[float] = None
        self._last_cmd = (0.0, 0.0)
        self._still_since: Optional[Tuple[float, float, float, float]] = None  # t, x, y, yaw
        self.stalls = 0
        self._retreat: Optional[Tuple[float, float]] = None  # where it retreats to, out of the way
        self._backup_until: Optional[float] = None  # backing up off a contact until then
        self._last_stall = -math.inf
        self._stuck: Optional[Tuple[float, float, float, float]] = None  # first stall: t, pose
        self._nudge = -1.0                        # -1 backing up, +1 nudging forward
        self._moved_off: Optional[Tuple[float, float]] = None  # where the last one began
        self._refused = (0.0, -math.inf)   # a back-off that ended unmoved: its sign, when
        self._boxed = 0     # stalls in a row with no way clear that it may take
        self._resume_at: Optional[float] = None   # out of the way: when to go on to the goal
        self.retreats = 0
        self._seen = np.zeros((0, 2))             # the last scan's points in the map frame
        self._known = np.zeros(0, dtype=bool)     # which of them are on the map's walls
        self._rebase = False       # a new path to the goal: progress counts along it
        self._rebases = 0
        self._wait_for = self.config.give_way_wait  # at the place it retreats to
        self._taken_since: Optional[float] = None  # something stands on the goal since then
        #: where backing up last stalled (x, y), kept while goals start near it
        self.backed_into: Optional[Tuple[float, float]] = (None if after is None
                                                            else after.backed_into)

    @property
    def path(self) -> np.ndarray:
        """The path being followed (map frame)."""
        return self.follower.path

    @property
    def retreat(self) -> Optional[Tuple[float, float]]:
        """Where it retreats to, out of the way of what blocks it (None: not retreating)."""
        return self._retreat

    def start(self, pose: Sequence[float], goal: Sequence[float], now: float) -> np.ndarray:
        """Plan to a new goal (x, y, yaw-or-None) and start following it.

        Raises:
            PlanError: the goal is outside the map, in a wall, or unreachable.
        """
        yaw = goal[2] if len(goal) > 2 else None
        path = self.grid.plan(pose, goal)
        self.goal = (float(goal[0]), float(goal[1]), None if yaw is None else float(yaw))
        self.follower.set_path(path, self.goal[2])
        self.follower.no_reverse = self._held_back(pose)
        self.replans = 0
        self._blocked_since = None
        self._blocked_total = 0.0
        self._best = self._left = math.inf
        self._best_t = now
        self._last_t = now
        self._last_cmd = (0.0, 0.0)
        self._still_since = None
        self._retreat, self._resume_at, self._backup_until = None, None, None
        self._rebase, self._rebases = False, 0
        self._last_stall = -math.inf
        self._boxed = 0
        self._stuck = None
        self._taken_since = None
        self.retreats = 0
        return path

    def cancel(self) -> None:
        """Forget the goal."""
        self.goal = None
        self.follower.set_path(np.zeros((0, 2)))

    def update(self, pose: Sequence[float], obstacles: Optional[np.ndarray],
               now: float) -> NavStatus:
        """One control step.

        Args:
            pose: ground-truth (x, y, yaw) in the map frame.
            obstacles: scan points in the base frame (x forward), or None.
            now: sim time (s).

        Returns:
            The command to send and the goal's state.
        """
        if self.goal is None:
            return NavStatus(0.0, 0.0, "aborted", "no goal")
        if obstacles is not None and len(obstacles):
            obstacles = np.asarray(obstacles, dtype=float)
            self._seen = to_map(pose, obstacles)
            self._known = self.grid.on_walls(self._seen)
        else:
            self._seen, self._known = np.zeros((0, 2)), np.zeros(0, dtype=bool)
        st = self._update(pose, obstacles, now)
        self._last_cmd = (st.v, st.w)
        return st

    def _stalled(self, pose: Sequence[float], now: float) -> bool:
        """True when the last commands asked for motion and the robot has not moved for
        ``stall_time`` (then the watch starts afresh)."""
        v, w = self._last_cmd
        ref = self._still_since
        x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
        if ((abs(v) < 0.02 and abs(w) < 0.1) or ref is None
                or math.hypot(x - ref[1], y - ref[2]) > 0.02
                or abs(wrap_angle(yaw - ref[3])) > 0.05):
            self._still_since = (now, x, y, yaw)
            return False
        if now - ref[0] >= self.config.stall_time:
            self._still_since = (now, x, y, yaw)
            return True
        return False

    def _update(self, pose: Sequence[float], obstacles: Optional[np.ndarray],
                now: float) -> NavStatus:
        cfg = self.config
        dt = 0.0 if self._last_t is None else max(0.0, now - self._last_t)
        self._last_t = now
        if self._resume_at is not None:
            return self._wait_then_resume(pose, now)
        cmd = self.follower.compute(pose, obstacles, self._known)
        if cmd.state == "done" and self._retreat:
            self._retreat, self._resume_at = None, now + self._wait_for
            return NavStatus(0.0, 0.0, "active", "giving way", cmd.distance_to_goal)
        if cmd.state == "done":
            self.goal = None
            return NavStatus(0.0, 0.0, "succeeded", "goal reached", cmd.distance_to_goal)
        left = (self._path_left(pose, cmd.distance_to_goal) if self.config.passing
                else cmd.distance_to_goal)
        if self._rebase and self._retreat is None and self.config.passing:
            # a new path (the long way round what blocks it, round a wall just seen):
            # progress is along it now; at most _MAX_REBASES a goal (sidesteps back and
            # forth must not reset the count for ever)
            if self._rebases < _MAX_REBASES:
                self._best, self._rebases = left, self._rebases + 1
            self._rebase = False
        self._left = left
        if self._retreat is None and left < self._best - 0.1:
            # (retreating, the distance is to the place it retreats to: no progress)
            self._best = left
            self._best_t = now
            self._blocked_total = 0.0   # the time blocked counts since the last progress
            self._stuck = None          # and the time stalled
        if self._goal_taken(now, cmd.distance_to_goal):
            return self._abort(GOAL_TAKEN + " (something the map does not show stands on "
                               "it), no progress for %.0f s, %.2f m from it"
                               % (now - self._best_t, cmd.distance_to_goal), cmd)
        if cmd.state == "blocked":
            self._blocked_total += dt
            if self._blocked_since is None:
                self._blocked_since = now
            if self._blocked_total > cfg.blocked_timeout:
                return self._abort("blocked by an obstacle for %.0f s, %.2f m from the goal"
                                   % (self._blocked_total, cmd.distance_to_goal), cmd)
            if now - self._blocked_since >= cfg.replan_after:
                self._blocked_since = now  # again after another replan_after if still blocked
                self._replan_around(pose, obstacles)
            return NavStatus(0.0, 0.0, "active", "blocked", cmd.distance_to_goal)
        self._blocked_since = None
        if self._backup_until is not None and now < self._backup_until:
            return NavStatus(self._nudge * _BACKUP_SPEED, 0.0, "active",
                             "backing up" if self._nudge < 0 else "nudging forward",
                             cmd.distance_to_goal)
        if self._backup_until is not None:
            self._back_off_ended(pose, now)
        self._backup_until = None
        if self._stalled(pose, now):
            return self._on_stall(pose, obstacles, now, cmd)
        if cmd.state not in ("aligning",) and now - self._best_t > cfg.progress_timeout:
            return self._abort("no progress for %.0f s, %.2f m from the goal"
                               % (now - self._best_t, cmd.distance_to_goal), cmd)
        return NavStatus(cmd.v, cmd.w, "active", cmd.state, cmd.distance_to_goal)

    def _held_back(self, pose: Sequence[float]) -> bool:
        """Whether a new goal is followed forwards only: backing up stalled within
        _STUCK_MOVE of ``pose`` (what it backed into may still be there: the same goal sent
        every 2 or 4 s, each backed into it anew, stalled 28-29 times a minute)."""
        spot = self.backed_into
        if spot is not None and math.hypot(float(pose[0]) - spot[0],
                                           float(pose[1]) - spot[1]) > _STUCK_MOVE:
            self.backed_into = spot = None
        return spot is not None

    def _on_stall(self, pose: Sequence[float], obstacles: Optional[np.ndarray], now: float,
                  cmd: FollowerCommand) -> NavStatus:
        """Stalled: plan again around what the scan shows; stalled again soon after (it cannot
        even turn: pressed against a robot, or wedged on a wall corner), back off a little, or
        nudge forward when only that is clear or the last back-off did not move it; stalled
        without getting 0.25 m away (more than a back-off or nudge) or turning 0.3 rad, and
        without progress to the goal, for blocked_timeout, abort (it waited in place for ever
        before)."""
        cfg = self.config
        self.stalls += 1
        backing = cmd.state == "reversing"   # FollowerConfig.reverse_within / reverse_path
        x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
        if backing:   # into something it cannot see: forward, by the plan (_held_back)
            self.follower.no_reverse = True
            self.backed_into = (x, y)
        st = self._stuck
        if st is None or math.hypot(x - st[1], y - st[2]) > _STUCK_MOVE \
                or abs(wrap_angle(yaw - st[3])) > 0.3:
            self._stuck = (now, x, y, yaw)
        elif now - st[0] > cfg.blocked_timeout:
            return self._abort("stalled for %.0f s (it can neither move nor turn), %.2f m from "
                               "the goal" % (now - st[0], cmd.distance_to_goal), cmd)
        again = now - self._last_stall < 3.0 * cfg.stall_time
        self._last_stall = now
        # back off, or nudge forward first when it stalled backing up (into what it cannot
        # see behind it); not the way its last move off went without moving it
        refused = self._refused_way(now)
        for sign in ((1.0, -1.0) if backing or refused < 0 else (-1.0, 1.0)):
            if again and sign != refused and self._clear_behind(pose, obstacles, sign):
                self._boxed = 0
                return self._back_off(sign, pose, now, cmd)
        if again:
            self._boxed += 1
            if self._boxed >= _BOXED_STALLS:
                # neither way passed the checks, which are cautious (a wall alongside, a
                # cell nearer a wall), or the one that did was just refused, and it cannot
                # turn: off the way with more room on the map; a move that would press into
                # something is refused as ever
                self._boxed = 0
                return self._back_off(self._roomier_way(pose), pose, now, cmd)
        self._replan_around(pose, obstacles)
        return NavStatus(0.0, 0.0, "active", "stalled", cmd.distance_to_goal)

    def _goal_taken(self, now: float, distance: float) -> bool:
        """Within ``goal_taken_within`` of the goal (``distance``), a scan point the map
        does not show within the robot's radius (and ``_GOAL_MARGIN``) of the goal in every
        scan for ``_TAKEN_FOR`` s, and no progress for ``deadlock_time``: it cannot stand
        there (the observer, waiting by the walker, stood on the walker's goal and the walker
        turned to and fro 1.1 m short of it until its leg timed out)."""
        cfg = self.config
        if (self.goal is None or self._retreat is not None or not cfg.passing
                or distance > cfg.goal_taken_within):
            self._taken_since = None
            return False
        world = self._seen[~self._known]
        reach = self.grid.config.robot_radius + _GOAL_MARGIN
        if not (len(world) and (np.hypot(world[:, 0] - self.goal[0],
                                         world[:, 1] - self.goal[1]) < reach).any()):
            self._taken_since = None
            return False
        if self._taken_since is None:
            self._taken_since = now
        return (now - self._taken_since >= _TAKEN_FOR
                and now - self._best_t >= cfg.deadlock_time)

    def _back_off(self, sign: float, pose: Sequence[float], now: float,
                  cmd: FollowerCommand) -> NavStatus:
        """Back up (``sign`` -1) or nudge forward (+1) for ``_BACKUP_TIME``."""
        self._backup_until, self._nudge = now + _BACKUP_TIME, sign
        self._moved_off = (float(pose[0]), float(pose[1]))
        return NavStatus(sign * _BACKUP_SPEED, 0.0, "active",
                         "backing up" if sign < 0 else "nudging forward", cmd.distance_to_goal)

    def _back_off_ended(self, pose: Sequence[float], now: float) -> None:
        """A back-off or nudge has run its time: refused, when it did not move the robot
        2 cm (_refused_way)."""
        if self._moved_off is not None:
            x, y = self._moved_off
            moved = math.hypot(float(pose[0]) - x, float(pose[1]) - y)
            self._refused = (self._nudge if moved < 0.02 else 0.0, now)
            self._moved_off = None

    def _refused_way(self, now: float) -> float:
        """The sign of the last back-off or nudge when it ended without moving the robot and
        this stall came within ``3 * stall_time`` of its end (0: none such). What it pressed
        into lies that way, unseen (a robot whose lidar looks ahead is blind behind): the
        way out is the other. Two robots that had backed into each other backed again and
        again, each into the other, until both gave up (mit_csail, three legs in a row)."""
        sign, ended = self._refused
        return sign if 0.0 <= now - ended <= 3.0 * self.config.stall_time else 0.0

    def _roomier_way(self, pose: Sequence[float]) -> float:
        """-1 (back) or +1 (forward): the way whose back-off ends further from the map's
        walls."""
        x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
        dx, dy = _BACKUP_SPEED * _BACKUP_TIME * math.cos(yaw), \
            _BACKUP_SPEED * _BACKUP_TIME * math.sin(yaw)
        back, ahead = self.grid.clearance_along(np.array([[x - dx, y - dy], [x + dx, y + dy]]))
        return -1.0 if back >= ahead else 1.0

    def _clear_behind(self, pose: Sequence[float], obstacles: Optional[np.ndarray],
                      sign: float = -1.0) -> bool:
        """Backing up (``sign`` -1; +1: moving forward) ``_BACKUP_TIME`` s brings the robot no
        nearer a wall of the map (than now or than its radius, less ``_BACKUP_SLACK``), and no
        scan point lies in the
        strip it sweeps (a lidar that sees only ahead shows nothing behind: the map is the
        check then)."""
        x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
        back = -sign * _BACKUP_SPEED * _BACKUP_TIME
        fine = self.grid._fine
        cells = self.grid.fmap.world_to_cell(np.array([x, x - back * math.cos(yaw)]),
                                             np.array([y, y - back * math.sin(yaw)]))
        col, row = (np.asarray(v, dtype=np.int64) for v in cells)
        if not ((col >= 0) & (row >= 0) & (col < fine.shape[1]) & (row < fine.shape[0])).all():
            return False
        r = self.follower.config.robot_radius
        if fine[row[1], col[1]] < min(r, fine[row[0], col[0]]) - _BACKUP_SLACK:
            return False
        if obstacles is None or not len(obstacles):
            return True
        pts = np.asarray(obstacles, dtype=float)
        reach = r + _BACKUP_SPEED * _BACKUP_TIME + 0.05
        along = sign * pts[:, 0]
        return not ((along > 0.0) & (along < reach) & (np.abs(pts[:, 1]) < r + 0.03)).any()

    def _abort(self, message: str, cmd: FollowerCommand) -> NavStatus:
        self.goal = None
        return NavStatus(0.0, 0.0, "aborted", message, cmd.distance_to_goal)

    def _replan_around(self, pose: Sequence[float], obstacles: Optional[np.ndarray]) -> None:
        """Plan again with the nearby scan points as walls; keep the old path if none.

        When no path passes the obstacle (two robots nose to nose in a corridor), the robot
        the rules make yield (``_yields``) gets out of the way (``_yield_to``); else it steps
        aside to the right first, as people do: a waypoint ``sidestep`` metres to the robot's
        right (then left) that is clear of walls and of the obstacle, and on to the goal from
        there. Both robots of a head-on meeting do the same, so they pass each other. A way
        round found again and again without progress (``_deadlocked``) is given up for a
        yield, when one is possible.
        """
        if self.goal is None or obstacles is None or len(obstacles) == 0:
            return
        pts = np.asarray(obstacles, dtype=float)
        # points on the map's walls are already in the grid: keep only the new ones, near
        near = np.hypot(pts[:, 0], pts[:, 1]) < self.config.obstacle_range
        world = self._seen[near & ~self._known]
        path: Optional[np.ndarray]
        try:
            path = self.grid.plan(pose, self._retreat or self.goal, obstacles=world)
            if self._waits_for_detour(path):
                return   # blocked: what blocks it may give way before the long way round
            if (self._retreat is None and self.retreats < _MAX_RETREATS and len(world)
                    and self._deadlocked(pose, world)
                    and self._yield_to(pose, world, aside=True)):
                # a way round each time, and stopped on it each time (the scan shows only
                # the near side of what blocks it: two robots nose to nose in a corridor
                # each planned past the other's unseen far side): it yields as when there
                # is no way round; when it cannot, it takes the way round
                return
        except PlanError:
            if (self.retreats < _MAX_RETREATS and len(world) and self._yields(pose, world)
                    and self._yield_to(pose, world)):
                return
            path = None if self._retreat else self._sidestep(pose, world)
            if path is None:
                return  # nothing better: wait for the obstacle to move
        self.replans += 1
        self._rebase = self._retreat is None
        self.follower.set_path(path, None if self._retreat else self.goal[2])

    def _yield_to(self, pose: Sequence[float], world: np.ndarray, aside: bool = False) -> bool:
        """Get out of the way of ``world`` (the points of what blocks it) and wait there, if
        it can; whether it does. The observer first steps out of the way nearby (it keeps its
        target in sight), unless that is still in the narrow passage (it backed 0.5 m along a
        corridor, three times) and a passing place is in reach; a robot yielding in a narrow
        passage goes to a passing place. With ``aside`` (a deadlock with a way round), when
        that place is where it stands (a corridor wide enough for two, the other in its
        middle), it steps ``sidestep`` m aside instead (right first; not into a narrow
        passage, not nearer what blocks it) and waits there."""
        path = self._out_of_the_way(pose, world) if self.config.give_way else None
        if self.config.passing and (path is None or self._in_narrow(path[-1])):
            to_place = self._to_passing_place(pose, world)
            path = to_place if to_place is not None else path
        if aside and (path is None or math.hypot(path[-1, 0] - pose[0],
                                                 path[-1, 1] - pose[1]) < 0.3):
            near = float(np.min(np.hypot(world[:, 0] - pose[0], world[:, 1] - pose[1])))
            path = next((p for p in self._side_paths(pose, world)
                         if not self._in_narrow(p[-1]) and float(np.min(np.hypot(
                             world[:, 0] - p[-1, 0], world[:, 1] - p[-1, 1]))) >= near), None)
        if path is None:
            return False
        self._retreat = (float(path[-1, 0]), float(path[-1, 1]))
        self._wait_for = self._pass_wait(world, self._retreat)
        self.retreats += 1
        self._blocked_total = 0.0
        self._best_t = self._last_t or 0.0   # yielding is not a lack of progress
        self.follower.set_path(path, None)
        return True

    def _waits_for_detour(self, path: np.ndarray) -> bool:
        """Whether to keep waiting instead of taking ``path``, a way round what blocks it more
        than ``detour`` m longer than the way left, before ``detour_wait`` s blocked."""
        cfg = self.config
        return (cfg.passing and cfg.detour > 0 and self._retreat is None
                and self._blocked_total < cfg.detour_wait
                and path_length(path) > self._left + cfg.detour)

    def _deadlocked(self, pose: Sequence[float], world: np.ndarray) -> bool:
        """No progress for the deadlock time, with something ahead of it (see
        NavigatorConfig): once that long when the bearing to what blocks it heads west or
        south (the heading rule's loser: the bearings of two robots nose to nose are
        opposite, their headings, each turned to its way round, need not be); twice as long
        otherwise (and with ``keep_way`` or without the heading rule). Never with
        ``give_way``: the observer, blocked by the walker it keeps in view, stepped out of
        the way and lost it (mit_csail, seed 3: tracked 74 -> 69 %); its follower has its
        own way out (people/follow_give_way.py's unblock)."""
        from .passing import heads_west_or_south

        cfg = self.config
        if not cfg.passing or cfg.give_way or self._last_t is None or not _ahead(pose, world):
            return False
        cx, cy = (float(v) for v in world.mean(axis=0))
        first = (cfg.heading_rule and not cfg.keep_way
                 and heads_west_or_south(math.atan2(cy - float(pose[1]), cx - float(pose[0]))))
        return self._last_t - self._best_t >= cfg.deadlock_time * (1.0 if first else 2.0)

    def _yields(self, pose: Sequence[float], world: np.ndarray) -> bool:
        """Whether this robot gives way to what blocks it (``world``, the points of it):
        always with ``give_way``; else only to what stands ahead of it (not what it follows
        out of sight behind, not a box beside), by nav/passing.gives_way's rule, or after
        the deadlock times (see NavigatorConfig)."""
        from .passing import gives_way

        cfg = self.config
        if cfg.give_way or not cfg.passing:
            return cfg.give_way
        if not _ahead(pose, world):
            return False
        rule = (not cfg.keep_way and cfg.heading_rule
                and gives_way(self.grid, self._narrow_axis(), pose, world,
                              self._other_radius(), cfg.passing_reach, cfg.passing_margin))
        stuck = 0.0 if self._last_t is None else self._last_t - self._best_t
        return rule or stuck >= cfg.deadlock_time * (2.0 if cfg.keep_way or not
                                                     cfg.heading_rule else 1.0)

    def _other_radius(self) -> float:
        r = self.config.other_radius
        return self.grid.config.robot_radius if r is None else r

    def _narrow_axis(self) -> np.ndarray:
        """The grid's narrow axis for this robot and the other (PlanningGrid.narrow_axis)."""
        return self.grid.narrow_axis(self._other_radius(), self.config.passing_margin)

    def _in_narrow(self, point: Sequence[float]) -> bool:
        """Whether ``point`` is where what it meets must pass (nav/passing.on_the_way)."""
        from .passing import on_the_way

        return on_the_way(self.grid, self._narrow_axis(), point, self._other_radius(),
                          self.config.passing_margin)

    def _to_passing_place(self, pose: Sequence[float], world: np.ndarray
                          ) -> Optional[np.ndarray]:
        """A path around ``world`` to the nearest passing place (nav/passing.py), or None."""
        from .passing import passing_place

        return self._plan_aside(pose, world, passing_place(
            self.grid, self._narrow_axis(), pose, world, self._other_radius(),
            self.config.passing_reach, self.config.passing_margin))

    def _plan_aside(self, pose: Sequence[float], world: np.ndarray,
                    point: Optional[Tuple[float, float]]) -> Optional[np.ndarray]:
        """A path around ``world`` to ``point``; None without a point or a path."""
        if point is None:
            return None
        try:
            return self.grid.plan(pose, point, obstacles=world)
        except PlanError:
            return None

    def _pass_wait(self, world: np.ndarray, place: Tuple[float, float]) -> float:
        """How long to wait at ``place`` for what it yields to (at ``world``) to come by."""
        cfg = self.config
        d = float(np.min(np.hypot(world[:, 0] - place[0], world[:, 1] - place[1])))
        return min(cfg.pass_wait_max, max(cfg.give_way_wait, d / 0.4))

    def _path_left(self, pose: Sequence[float], fallback: float) -> float:
        """The length (m) of the path still to drive (``fallback`` with no path)."""
        left = self.follower.remaining()
        if not len(left):
            return fallback
        return float(math.hypot(left[0, 0] - pose[0], left[0, 1] - pose[1])
                     + path_length(left))

    def _out_of_the_way(self, pose: Sequence[float], world: np.ndarray) -> Optional[np.ndarray]:
        """A path, around ``world`` (the points the map does not know), to the nearest place
        at least ``give_way_clear`` m from all of them; None when there is none."""
        cfg = self.config
        if not len(world):
            return None
        centre = world.mean(axis=0)
        return self._plan_aside(pose, world, give_way_point(
            self.grid, world, pose, centre, cfg.give_way_clear, cfg.give_way_reach, 0.6,
            obstacles=world))

    def _wait_then_resume(self, pose: Sequence[float], now: float) -> NavStatus:
        """Out of the way: wait, then plan to the goal again (around what the scan shows)."""
        assert self._resume_at is not None and self.goal is not None   # as _update calls it
        if now < self._resume_at:
            return NavStatus(0.0, 0.0, "active", "giving way")
        world = self._seen[~self._known]
        try:
            path = self.grid.plan(pose, self.goal, obstacles=world)
        except PlanError:
            try:
                path = self.grid.plan(pose, self.goal)
            except PlanError as e:
                return self._abort("cannot go on after giving way: %s" % e,
                                   FollowerCommand(0.0, 0.0, "blocked", 0.0))
        self._resume_at = None
        self._rebase = True
        self._best_t = now   # the time it gave way is not time without progress
        self.follower.set_path(path, self.goal[2])
        return NavStatus(0.0, 0.0, "active", "going on")

    def _sidestep(self, pose: Sequence[float], world: np.ndarray) -> Optional[np.ndarray]:
        assert self.goal is not None   # _replan_around checks it
        for first in self._side_paths(pose, world):
            wx, wy = (float(v) for v in first[-1])
            try:
                try:
                    rest = self.grid.plan((wx, wy), self.goal, obstacles=world)
                except PlanError:  # the other one has not stepped aside yet
                    rest = self.grid.plan((wx, wy), self.goal)
            except PlanError:
                continue
            return np.vstack([first, rest[1:]])
        return None

    def _side_paths(self, pose: Sequence[float], world: np.ndarray):
        """Paths to a place ``sidestep`` (or half of it) m to the robot's right, then left,
        that is free and clear of ``world``, in that order (a generator)."""
        x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
        r = self.grid.config.robot_radius
        for side in (-1.0, 1.0):  # right first
            for dist in (self.config.sidestep, 0.5 * self.config.sidestep):
                wx = x - side * dist * math.sin(yaw)
                wy = y + side * dist * math.cos(yaw)
                if not self.grid.is_free(wx, wy):
                    continue
                if len(world) and np.min(np.hypot(world[:, 0] - wx, world[:, 1] - wy)) < r + 0.05:
                    continue
                try:
                    yield self.grid.plan(pose, (wx, wy))
                except PlanError:
                    continue
