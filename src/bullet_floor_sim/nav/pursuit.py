"""Pure pursuit along a planned path, with an obstacle stop from the robot's own scan.

:class:`PathFollower` is a pure-pursuit controller for a differential (or omni) base with
rotate-in-place, slow-down near the goal, final heading alignment and an obstacle stop from
the robot's own scan points (:func:`obstacles_in_base`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Callable, Iterable, Optional, Sequence, Tuple

import numpy as np

from ..errors import BulletFloorSimError
from ..geometry import wrap_angle
from ..sim.checks import check_numbers

__all__ = ["FollowerCommand", "FollowerConfig", "PathFollower", "obstacles_in_base", "to_map"]

#: How much nearer (m) than now the path must take the robot to a point it already stands
#: within the stop corridor's half-width of for that point to block it (free_along_path).
_NEARER = 0.01
#: How far ahead of the robot's centre (m, along its heading) such a point may lie.
_BESIDE = 0.05


@dataclass
class FollowerConfig:
    """Pure-pursuit parameters (defaults suit a Scitos A5 at walking pace).

    Attributes:
        lookahead: pure-pursuit look-ahead distance (m).
        short_lookahead: look-ahead (m) used within 1 m of an obstacle ahead.
        max_linear, max_angular: velocity limits (m/s, rad/s), within the drive's.
        min_linear: slowest forward speed while following (m/s).
        rotate_in_place: heading error (rad) above which the robot turns on the spot.
        xy_tolerance: goal position tolerance (m).
        yaw_tolerance: goal heading tolerance (rad); the goal yaw is ignored if it is None.
        slow_radius: distance to the goal (m) where the speed starts to fall.
        stop_distance: free space (m) needed ahead of the footprint to keep driving.
        side_margin: extra half-width (m) of the stop corridor beyond the footprint radius.
        robot_radius: footprint circumradius (m).
        sweep: how far along the path (m) the stop check looks for obstacles.
        reverse_within: a goal at most this far (m) behind the robot, on a straight way (as
            clear of walls as the robot stands, by the Navigator's clearance), whose heading
            is within ``rotate_in_place`` of the robot's present heading, is reached backing
            up at ``reverse_speed``, facing as it faces, instead of turning round to it and
            back again (two half turns with the lidar, which looks forward, the wrong way).
            0 (the default): never. The observer backs up so to give way (demo.launch): turned
            round, it lost the target it gave way to. Backing up, the robot sees nothing
            behind it but what its path avoids on the map.
        reverse_path: a goal at most this far along its path (m), whose heading is within
            ``rotate_in_place`` of the path's last metre turned round (the robot arrives
            facing back the way it came), is reached backing up along the path: pure pursuit
            on the robot's back, at most ``reverse_speed``, after a turn on the spot that
            points its back along the path; unless the path comes nearer than 1 m to a
            point of the scan (at the first command for the path) off the map's walls that
            the robot stands further from, which it could not see backing up (without a
            scan, no such check). ``reverse_within`` decides first. 0 (the default): never.
            For the observer that gives way round a corner or further than
            ``reverse_within``, its front to the target it gives way to.
        reverse_speed: the speed (m/s) of backing up.
    """

    lookahead: float = 0.6
    short_lookahead: float = 0.3
    max_linear: float = 0.6
    max_angular: float = 1.2
    min_linear: float = 0.08
    rotate_in_place: float = 0.9
    xy_tolerance: float = 0.15
    yaw_tolerance: float = 0.15
    slow_radius: float = 1.0
    stop_distance: float = 0.3
    side_margin: float = 0.03
    robot_radius: float = 0.34
    sweep: float = 1.5
    reverse_within: float = 0.0
    reverse_path: float = 0.0
    reverse_speed: float = 0.25

    def check(self) -> None:
        """Raises BulletFloorSimError naming the first field that is not a finite number
        > 0 (>= 0 for the margins, ``min_linear``, ``reverse_within`` and ``reverse_path``;
        ``yaw_tolerance`` may also be None)."""
        zero_ok = ("reverse_within", "reverse_path", "side_margin", "stop_distance", "min_linear")
        check_numbers(self, [f.name for f in fields(self) if f.name not in zero_ok
                             and not (f.name == "yaw_tolerance" and self.yaw_tolerance is None)],
                      "path follower", error=BulletFloorSimError)
        check_numbers(self, zero_ok, "path follower", strict=False, error=BulletFloorSimError)


#: Farthest (m) a path to back up along may stray from the straight line to its goal (a
#: grid path to a goal off its axes zigzags up to about a cell and a half).
_STRAIGHT = 0.3
#: The length (m) of the end of a path whose direction the robot arrives in (reverse_path).
_LAST = 1.0
#: How near (m) a path backed along (reverse_path) may come to what the scan shows and the
#: map lacks (a person, a robot) when that is nearer than the robot stands to it now (less
#: _NEARER_BACK): backing, the robot cannot see it.
_BACK_CLEAR, _NEARER_BACK = 1.0, 0.1


@dataclass
class FollowerCommand:
    """One control output: body velocities and the follower's state.

    ``state`` is ``following``, ``rotating`` (turning on the spot towards the path),
    ``reversing`` (backing up: to a goal close behind, or along the path, see
    ``FollowerConfig.reverse_within`` and ``reverse_path``), ``aligning`` (at the goal, turning to
    its heading), ``blocked`` (an obstacle ahead) or ``done``.
    """

    v: float
    w: float
    state: str
    distance_to_goal: float


class PathFollower:
    """Pure pursuit along a planned path.

    Args:
        config: controller parameters.
    """

    def __init__(self, config: Optional[FollowerConfig] = None) -> None:
        self.config = config or FollowerConfig()
        self.path = np.zeros((0, 2))
        self.goal_yaw: Optional[float] = None
        self._index = 0
        self._aligning = False
        self._reverse: Optional[bool] = None   # backing up to this path's goal (decided once)
        self._back_along = False   # ... along the path (reverse_path), decided with it
        # no backing up: it stalled doing so (the Navigator sets it for the goal, and for
        # each new goal that starts within 0.25 m of where that stall was)
        self.no_reverse = False
        # wall clearance (m) at map-frame points (N, 2) (the Navigator gives its grid's): the
        # look-ahead chord then never runs nearer a wall than the path itself does
        self.clearance: Optional[Callable[[np.ndarray], np.ndarray]] = None
        self._path_clear: Optional[np.ndarray] = None

    def set_path(self, path: np.ndarray, goal_yaw: Optional[float] = None) -> None:
        """Follow a new (M, 2) map-frame path; ``goal_yaw`` is the final heading (or None)."""
        self.path = np.asarray(path, dtype=float).reshape(-1, 2)
        self.goal_yaw = goal_yaw
        self._index = 0
        self._aligning = False
        self._reverse = None
        self._back_along = False
        self._path_clear = (self.clearance(self.path) if self.clearance is not None
                            and len(self.path) else None)

    def _safe_target(self, x: float, y: float, rest: np.ndarray, k: int) -> int:
        """The index of the farthest path point up to ``rest[k]`` (the look-ahead point)
        that the robot reaches in a straight line no nearer a wall than the path gets on the
        way (nor than radius + side margin, nor than it stands now); ``k`` itself when its
        chord is safe or when none is. Pure pursuit cuts the chord: in a door with a bend,
        the chord to a 0.6 m look-ahead ran 1.5 cm into the wall corner."""
        # the caller checks _path_clear, which set_path computes only with a clearance
        assert self._path_clear is not None and self.clearance is not None
        cfg = self.config
        clear = self._path_clear[self._index:]
        here = float(self.clearance(np.array([[x, y]]))[0])
        start = np.array([x, y])
        for j in range(k, 0, -1):
            need = min(cfg.robot_radius + cfg.side_margin, here, float(clear[:j + 1].min()))
            if self._line_clearance(start, rest[j]) >= need - 0.01:
                return j
        return k   # no chord is safe (off the path): pure pursuit as it is

    def _line_clearance(self, a: np.ndarray, b: np.ndarray) -> float:
        """The least wall clearance along the straight line from ``a`` to ``b`` (every
        2.5 cm)."""
        assert self.clearance is not None
        n = max(2, int(math.hypot(*(b - a)) / 0.025) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        return float(self.clearance(a * (1.0 - t) + b * t).min())

    def _backs_up(self, x: float, y: float, yaw: float) -> bool:
        """Whether this path's goal is reached backing up (``reverse_within``): close
        behind, on a straight way, its heading about the robot's own."""
        cfg = self.config
        goal = self.path[-1]
        dx, dy = goal[0] - x, goal[1] - y
        d = math.hypot(dx, dy)
        if cfg.reverse_within <= 0 or self.goal_yaw is None or d > cfg.reverse_within:
            return False
        behind = abs(wrap_angle(math.atan2(dy, dx) - yaw)) > math.pi - cfg.rotate_in_place
        if not behind or abs(wrap_angle(self.goal_yaw - yaw)) > cfg.rotate_in_place:
            return False
        # every path point within _STRAIGHT of the line from here to the goal (a way round
        # something is not backed up along), and the line as clear of walls as the path
        off = np.abs((self.path[:, 0] - x) * dy - (self.path[:, 1] - y) * dx) / max(d, 1e-9)
        if not np.all(off <= _STRAIGHT):
            return False
        if self.clearance is None or self._path_clear is None:
            return True
        need = min(cfg.robot_radius + cfg.side_margin, float(self._path_clear.min()))
        return self._line_clearance(np.array([x, y]), goal) >= need - 0.01

    def _backs_along(self, pose: Tuple[float, float, float], obstacles: Optional[np.ndarray],
                     known: Optional[np.ndarray]) -> bool:
        """Whether this path's goal is reached backing up along it (``reverse_path``): at
        most that far along, its heading within ``rotate_in_place`` of the way the path's
        last ``_LAST`` metres arrive, turned round, and the path no nearer than _BACK_CLEAR
        to a scan point off the map's walls (all, without ``known``) that the robot stands
        further from (the target a give-way passes by, behind the robot backing up)."""
        cfg = self.config
        if cfg.reverse_path <= 0 or self.goal_yaw is None or len(self.path) < 2:
            return False
        steps = np.hypot(*np.diff(self.path, axis=0).T)
        if float(steps.sum()) > cfg.reverse_path:
            return False
        to_end = np.cumsum(steps[::-1])[::-1]     # from each point but the last to the goal
        start = self.path[int(np.flatnonzero(to_end >= min(_LAST, to_end[0]))[-1])]
        goal = self.path[-1]
        arrive = math.atan2(goal[1] - start[1], goal[0] - start[0])
        if abs(wrap_angle(self.goal_yaw - arrive - math.pi)) > cfg.rotate_in_place:
            return False
        if obstacles is None or not len(obstacles):
            return True
        pts = np.asarray(obstacles, dtype=float).reshape(-1, 2)
        if known is not None:
            pts = pts[~np.asarray(known, dtype=bool)]
        if not len(pts):
            return True
        seen = to_map(pose, pts)
        now = np.hypot(seen[:, 0] - pose[0], seen[:, 1] - pose[1])
        along = np.hypot(seen[:, None, 0] - self.path[None, :, 0],
                         seen[:, None, 1] - self.path[None, :, 1]).min(axis=1)
        return bool(np.all(along >= np.minimum(_BACK_CLEAR, now - _NEARER_BACK)))

    def _back_up(self, x: float, y: float, yaw: float, goal: np.ndarray, dist_goal: float,
                 obstacles: Optional[np.ndarray]) -> Optional[FollowerCommand]:
        """Back up towards ``goal``, the robot's back turned to it; ``blocked`` by a scan
        point in the footprint's way behind (a lidar that sees behind); None once the goal
        lies off behind (pushed, or past it): then forward, as any goal."""
        cfg = self.config
        alpha = wrap_angle(math.atan2(goal[1] - y, goal[0] - x) - (yaw + math.pi))
        if abs(alpha) > cfg.rotate_in_place:
            self._reverse = False
            return None
        if obstacles is not None and len(obstacles):
            pts = np.asarray(obstacles)
            half = cfg.robot_radius + cfg.side_margin
            ahead = -pts[:, 0] - cfg.robot_radius   # free space behind the footprint
            if np.any((ahead >= -half) & (ahead < cfg.stop_distance) & (np.abs(pts[:, 1]) < half)):
                return FollowerCommand(0.0, 0.0, "blocked", dist_goal)
        w = _clip(1.5 * alpha, cfg.max_angular)
        if abs(alpha) > 0.5:
            return FollowerCommand(0.0, w, "reversing", dist_goal)
        v = min(cfg.reverse_speed, cfg.max_linear) * min(1.0, dist_goal / cfg.slow_radius)
        return FollowerCommand(-max(v, cfg.min_linear), w, "reversing", dist_goal)

    def remaining(self) -> np.ndarray:
        """The part of the path not yet passed."""
        return self.path[self._index:]

    def free_ahead(self, obstacles: Optional[np.ndarray]) -> float:
        """Distance (m) from the footprint's front to the nearest point in its swept corridor."""
        if obstacles is None or len(obstacles) == 0:
            return math.inf
        cfg = self.config
        pts = np.asarray(obstacles, dtype=float)
        sel = (pts[:, 0] > 0.0) & (np.abs(pts[:, 1]) < cfg.robot_radius + cfg.side_margin)
        if not sel.any():
            return math.inf
        return float(pts[sel, 0].min()) - cfg.robot_radius

    def free_along_path(self, pose: Sequence[float], obstacles: Optional[np.ndarray]) -> float:
        """Distance (m) from the footprint's front, along the path ahead (from the robot to the
        path's next points, ``sweep`` metres of it), to the first base-frame point in front of
        the robot within ``robot_radius + side_margin`` of that line: what the footprint would
        sweep. A point it already stands that near beside it (less than ``_BESIDE`` m ahead
        of its centre and at least the footprint's radius to the side: driving on along its
        heading, or along the line, takes it a few mm nearer at most) counts only where the
        line comes more than ``_NEARER`` m nearer to it than the robot is now: else a robot
        that stopped within the margin of something beside it stayed blocked for good,
        though going on takes it no nearer (a SLAM map's door jamb 0.2 m off, seen as new,
        held the explorer there for 1100 s in CI, we think). A point further ahead, or
        nearer the side, counts within the half-width however near: pure pursuit's arc
        leaves along the heading, not the line. inf when there is none. (All segments at
        once: the same as walking them in turn to the last bit but for the dot product's
        rounding.)"""
        if obstacles is None or len(obstacles) == 0:
            return math.inf
        cfg = self.config
        base = np.asarray(obstacles, dtype=float).reshape(-1, 2)
        base = base[base[:, 0] > 0.0]
        if not len(base):
            return math.inf
        here = np.asarray(pose[:2], dtype=float)
        line = np.vstack([here[None, :], self.path[self._index + 1:]])
        ab = np.diff(line, axis=0)
        seg = np.hypot(ab[:, 0], ab[:, 1])
        s0 = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
        # the segments that begin within the sweep (a prefix; the first always), but
        # zero-length ones
        n = max(1, int(np.count_nonzero(s0 < cfg.sweep)))
        long = np.flatnonzero(seg[:n] > 1e-9)
        ab, seg, s0, a = ab[long], seg[long], s0[long], line[long]
        if not len(seg):
            return math.inf
        # a point further from the robot than the path's length to the last one's end, plus
        # the half-width, is near none of them
        dist = np.hypot(base[:, 0], base[:, 1])
        half = cfg.robot_radius + cfg.side_margin
        keep = dist < s0[-1] + seg[-1] + half + 1e-6
        base, dist = base[keep], dist[keep]
        if not len(base):
            return math.inf
        pts = to_map(pose, base)
        beside = (base[:, 0] < _BESIDE) & (np.abs(base[:, 1]) >= cfg.robot_radius)
        near = np.where(beside, np.minimum(half, dist - _NEARER), half)
        # each point (rows) against each segment (columns): where along it it comes nearest
        px = pts[:, :1] - a[None, :, 0]
        py = pts[:, 1:] - a[None, :, 1]
        t = np.minimum(np.maximum((px * ab[:, 0] + py * ab[:, 1]) / (seg * seg), 0.0), 1.0)
        hit = np.hypot(px - t * ab[:, 0], py - t * ab[:, 1]) < near[:, None]
        first = np.flatnonzero(hit.any(axis=0))
        if not len(first):
            return math.inf
        j = first[0]    # the first segment something is near: what is on it comes first
        return float(s0[j] + (t[hit[:, j], j] * seg[j]).min()) - cfg.robot_radius

    def compute(self, pose: Sequence[float], obstacles: Optional[np.ndarray] = None,
                known: Optional[np.ndarray] = None) -> FollowerCommand:
        """Velocity command for the current ground-truth pose.

        Args:
            pose: (x, y, yaw) in the map frame.
            obstacles: (N, 2) scan points in the robot's base frame (x forward), or None.
            known: optional (N,) bool, the points on the map's walls. The path already keeps
                the footprint clear of them, so they shorten the look-ahead and slow the robot
                but never stop it: only what the map does not know (a robot, a person) can
                block the way, and only when it is on the path ahead
                (:meth:`free_along_path`): beside a bend it is not. Without it every point can.

        Returns:
            The command; ``state == "done"`` once within tolerance of the goal.
        """
        cfg = self.config
        if len(self.path) == 0:
            return FollowerCommand(0.0, 0.0, "done", 0.0)
        x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
        goal = self.path[-1]
        dist_goal = math.hypot(goal[0] - x, goal[1] - y)
        if self._aligning or dist_goal <= cfg.xy_tolerance:
            self._aligning = True
            self._index = len(self.path) - 1
            if self.goal_yaw is None:
                return FollowerCommand(0.0, 0.0, "done", dist_goal)
            err = wrap_angle(self.goal_yaw - yaw)
            if abs(err) <= cfg.yaw_tolerance:
                return FollowerCommand(0.0, 0.0, "done", dist_goal)
            w = _clip(2.0 * err, cfg.max_angular)
            if abs(w) < 0.3:
                w = math.copysign(0.3, err)
            return FollowerCommand(0.0, w, "aligning", dist_goal)
        # progress: the closest path point within a window ahead of the last one
        window = self.path[self._index:self._index + 60]
        d = np.hypot(window[:, 0] - x, window[:, 1] - y)
        self._index += int(np.argmin(d))
        if self._reverse is None:
            self._reverse = self._backs_up(x, y, yaw)
            self._back_along = not self._reverse and self._backs_along((x, y, yaw), obstacles,
                                                                        known)
        if self._reverse and not self.no_reverse:
            back = self._back_up(x, y, yaw, goal, dist_goal, obstacles)
            if back is not None:
                return back
        if self._back_along and not self.no_reverse:
            return self._pursue_backwards(x, y, yaw, dist_goal, obstacles, known)
        return self._pursue(x, y, yaw, dist_goal, obstacles, known, cfg.max_linear)

    def _pursue_backwards(self, x: float, y: float, yaw: float, dist_goal: float,
                          obstacles: Optional[np.ndarray], known: Optional[np.ndarray]
                          ) -> FollowerCommand:
        """Pure pursuit along the path with the robot's back as its front (reverse_path):
        the same command for the robot turned round (scan points too), backwards. The turn
        rate is the same either way round."""
        back = None if obstacles is None else -np.asarray(obstacles, dtype=float)
        cmd = self._pursue(x, y, wrap_angle(yaw + math.pi), dist_goal, back, known,
                           min(self.config.reverse_speed, self.config.max_linear))
        state = "reversing" if cmd.state == "following" else cmd.state
        return FollowerCommand(-cmd.v, cmd.w, state, cmd.distance_to_goal)

    def _pursue(self, x: float, y: float, yaw: float, dist_goal: float,
                obstacles: Optional[np.ndarray], known: Optional[np.ndarray],
                max_linear: float) -> FollowerCommand:
        """Pure pursuit from (x, y, yaw) to the look-ahead point, at most ``max_linear``:
        turning on the spot, stopped (``blocked``) or following."""
        cfg = self.config
        goal = self.path[-1]
        # look-ahead point: first point at least `lookahead` away, else the goal; close to an
        # obstacle the look-ahead shrinks so that the robot follows the path's detours tightly
        free = self.free_ahead(obstacles)
        lookahead = cfg.lookahead if free > 1.0 else cfg.short_lookahead
        unknown = obstacles
        if known is not None and obstacles is not None and len(obstacles):
            unknown = np.asarray(obstacles)[~np.asarray(known, dtype=bool)]
        free_new = self.free_along_path((x, y, yaw), unknown)
        rest = self.path[self._index:]
        dr = np.hypot(rest[:, 0] - x, rest[:, 1] - y)
        far = np.nonzero(dr >= lookahead)[0]
        target = rest[far[0]] if len(far) else goal
        tight = False
        if self._path_clear is not None and len(rest) > 1:
            k = int(far[0]) if len(far) else len(rest) - 1
            j = self._safe_target(x, y, rest, k)
            tight, target = j < k, rest[j]
        dx, dy = target[0] - x, target[1] - y
        c, s = math.cos(yaw), math.sin(yaw)
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        alpha = math.atan2(ly, lx)
        blocked = free_new < cfg.stop_distance
        if abs(alpha) > cfg.rotate_in_place or ((blocked or tight) and abs(alpha) > 0.25):
            # turning on the spot is always safe for a round footprint (and where the
            # look-ahead was cut short, an arc would leave the safe chord)
            return FollowerCommand(0.0, _clip(1.5 * alpha, cfg.max_angular), "rotating", dist_goal)
        if blocked:
            return FollowerCommand(0.0, 0.0, "blocked", dist_goal)
        ld = max(math.hypot(lx, ly), 1e-6)
        curvature = 2.0 * ly / (ld * ld)
        v = max_linear * min(1.0, dist_goal / cfg.slow_radius)
        v *= max(0.2, math.cos(alpha))
        v = max(v, cfg.min_linear)
        # slow down when something is ahead, to stop in time (scan and control lag)
        v = min(v, max_linear * max(0.2, min(1.0, (free - cfg.stop_distance) / 0.8)))
        if abs(curvature) * v > cfg.max_angular:
            v = cfg.max_angular / abs(curvature)
        return FollowerCommand(v, _clip(curvature * v, cfg.max_angular), "following", dist_goal)


def to_map(pose: Sequence[float], pts: np.ndarray) -> np.ndarray:
    """Base-frame points (N, 2) in the map frame, for a robot at ``pose`` (x, y, yaw)."""
    x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.stack([x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]], axis=1)




def _clip(v: float, limit: float) -> float:
    return max(-limit, min(limit, v))


def obstacles_in_base(ranges: Iterable[float], angle_min: float, angle_increment: float,
                      range_max: float, laser_pose: Tuple[float, float, float]) -> np.ndarray:
    """Scan points (valid ranges only) in the base frame, given the laser's (x, y, yaw) there.

    Returns:
        (N, 2) array of points; +-inf, NaN and max-range readings are dropped.
    """
    r = np.asarray(list(ranges), dtype=float)
    a = angle_min + angle_increment * np.arange(len(r))
    ok = np.isfinite(r) & (r < range_max) & (r > 0)
    r, a = r[ok], a[ok] + laser_pose[2]
    return np.stack([laser_pose[0] + r * np.cos(a), laser_pose[1] + r * np.sin(a)], axis=1)
