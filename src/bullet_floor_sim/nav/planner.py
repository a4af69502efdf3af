"""The embedded navigation default: grid A* on the inflated map, smoothing, pure pursuit.

This is what moves the simulated human (and any robot when the stock navigation stack is not
installed). It localises from ground truth: it is legs, not a SLAM system.

* :class:`PlanningGrid` turns a :class:`~bullet_floor_sim.sim.floormap.FloorMap` into a
  coarser planning grid. A cell is *lethal* when the robot's footprint circle centred on the
  cell's centre could touch a wall (or unknown space); free cells near walls carry a cost that
  decays exponentially with clearance, as costmap_2d's inflation layer does, so paths keep
  away from walls and pass through the middle of doors.
* :meth:`PlanningGrid.plan` runs 8-connected A* (no corner cutting), then shortcuts the cell
  path where a straight segment is no closer to walls than the cells it replaces, and
  resamples it. Bad goals raise :class:`PlanError` naming the goal and the reason.
* :class:`PathFollower` is a pure-pursuit controller for a differential (or omni) base with
  rotate-in-place, slow-down near the goal, final heading alignment and an obstacle stop from
  the robot's own scan points.

Everything is plain numbers in, plain numbers out; ``bullet_floor_sim.ros.path_follower``
wraps it in a move_base-compatible action server.
"""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Callable, Iterable, List, Optional, Sequence, Tuple

import numpy as np

from ..errors import BulletFloorSimError
from ..sim.floormap import FloorMap
from ..sim.solidmap import MapHandling, solid_map
from ..geometry import wrap_angle

__all__ = [
    "PlanError",
    "PlannerConfig",
    "PlanningGrid",
    "FollowerConfig",
    "FollowerCommand",
    "PathFollower",
]

_SQRT2 = math.sqrt(2.0)
_BACKUP_SPEED, _BACKUP_TIME = 0.1, 1.5   # m/s, s: a stalled robot backs off 0.15 m
_MAX_RETREATS = 3   # per goal: then it waits where it is, and the goal can time out
_NEIGHBOURS = ((1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0),
               (1, 1, _SQRT2), (1, -1, _SQRT2), (-1, 1, _SQRT2), (-1, -1, _SQRT2))


class PlanError(BulletFloorSimError):
    """No plan: the goal is outside the map, in or too near a wall, or unreachable."""


@dataclass
class PlannerConfig:
    """Planning parameters.

    Attributes:
        robot_radius: footprint circumradius (m); cells closer than this to a wall are lethal.
        inflation_radius: distance beyond ``robot_radius`` over which the wall cost decays.
        cost_scaling: exponential decay rate of the wall cost (1/m), as costmap_2d's.
        cost_weight: how much a fully inflated cell adds to the length of a step (x1 + w).
        resolution: planning cell size (m); rounded to a multiple of the map resolution.
        unknown_is_obstacle: unknown (-1) areas are walls for planning (``unknown: wall`` of
            sim/solidmap.py: unseen slivers inside an open hall are floor); False: floor.
        path_spacing: spacing (m) of the resampled output path.
    """

    robot_radius: float = 0.34
    inflation_radius: float = 0.6
    cost_scaling: float = 4.0
    cost_weight: float = 3.0
    resolution: float = 0.1
    unknown_is_obstacle: bool = True
    path_spacing: float = 0.1


class PlanningGrid:
    """An inflated cost grid over a floor map, and A* on it.

    Args:
        fmap: the floor map (as map_server publishes it).
        config: planning parameters.
    """

    def __init__(self, fmap: FloorMap, config: Optional[PlannerConfig] = None,
                 handling: Optional[MapHandling] = None) -> None:
        self.fmap = fmap
        self.config = cfg = config or PlannerConfig()
        if cfg.robot_radius <= 0 or cfg.resolution <= 0:
            raise PlanError("planner: robot_radius and resolution must be > 0")
        k = max(1, int(round(cfg.resolution / fmap.resolution)))
        self.factor = k
        self.resolution = fmap.resolution * k
        # what is solid is decided as the simulator decides it (sim/solidmap.py): occupied
        # cells, unknown areas but not the unseen slivers of an open hall, slits closed
        if handling is None:
            handling = MapHandling(unknown="wall" if cfg.unknown_is_obstacle else "free")
        self.handling = handling
        # Distance from each fine cell centre to the nearest solid cell centre, minus half a
        # fine cell (the wall cell's extent): exact for a wall along the grid. A coarse cell's
        # clearance is that of its centre point, as costmap_2d judges a cell by its centre:
        # for an even factor the mean of the four fine cells around it (exact beside a flat
        # wall, at most 2 mm high at a corner). A 0.8 m door is open to a 0.34 m footprint
        # (the worst point of each cell, as before, closed it: 0.9 m was the narrowest).
        dist = solid_map(fmap, handling).distance
        fine = dist.astype(float) * fmap.resolution - 0.5 * fmap.resolution
        self._fine = fine
        h, w = fine.shape
        H, W = -(-h // k), -(-w // k)
        pad = np.full((H * k, W * k), -1.0)
        pad[:h, :w] = fine
        if k % 2:
            self.clearance = pad[k // 2::k, k // 2::k].copy()
        else:
            a = k // 2 - 1
            self.clearance = 0.25 * (pad[a::k, a::k] + pad[a + 1::k, a::k]
                                     + pad[a::k, a + 1::k] + pad[a + 1::k, a + 1::k])
        self.height, self.width = H, W
        cost = np.exp(-cfg.cost_scaling * np.clip(self.clearance - cfg.robot_radius, 0, None))
        cost[self.clearance > cfg.robot_radius + cfg.inflation_radius] = 0.0
        cost[self.clearance < cfg.robot_radius] = np.inf
        self.cost = cost
        self._flat = None  # type: Optional[List[float]]

    # -- coordinates -----------------------------------------------------------------------
    def to_cell(self, x: float, y: float) -> Tuple[int, int]:
        """(col, row) of the planning cell containing a map-frame point (may be out of range)."""
        col, row = self.fmap.world_to_cell(x, y)
        return int(col) // self.factor, int(row) // self.factor

    def to_world(self, col: float, row: float) -> Tuple[float, float]:
        """Map-frame centre of a planning cell."""
        u = (col + 0.5) * self.factor - 0.5
        v = (row + 0.5) * self.factor - 0.5
        x, y = self.fmap.cell_to_world(u, v)
        return float(x), float(y)

    def inside(self, col: int, row: int) -> bool:
        """Whether a cell index lies on the grid."""
        return 0 <= col < self.width and 0 <= row < self.height

    def clearance_at(self, x: float, y: float) -> float:
        """Wall clearance (m) at the centre of the cell of (x, y); -inf off the map."""
        c, r = self.to_cell(x, y)
        return float(self.clearance[r, c]) if self.inside(c, r) else -math.inf

    def on_walls(self, xy: np.ndarray, tolerance: float = 0.1) -> np.ndarray:
        """Which map-frame points (N, 2) lie on the map's solid cells: in a cell whose centre
        is within ``tolerance`` + one map cell of a wall (a point itself up to about
        ``tolerance`` + 1.7 cells: 0.18 m on a 0.05 m map), what the plan already keeps clear
        of. Points off the map count as walls."""
        pts = np.asarray(xy, dtype=float).reshape(-1, 2)
        col, row = self.fmap.world_to_cell(pts[:, 0], pts[:, 1])
        col, row = np.asarray(col, dtype=np.int64), np.asarray(row, dtype=np.int64)
        h, w = self._fine.shape
        inside = (col >= 0) & (row >= 0) & (col < w) & (row < h)
        out = np.ones(len(pts), dtype=bool)
        out[inside] = self._fine[row[inside], col[inside]] <= tolerance + self.fmap.resolution
        return out

    def is_free(self, x: float, y: float) -> bool:
        """The robot fits at (x, y): on the map, in a cell whose centre is at least
        robot_radius from every wall (a point off the centre may be up to half a cell's
        diagonal nearer)."""
        c, r = self.to_cell(x, y)
        return self.inside(c, r) and math.isfinite(self.cost[r, c])

    # -- planning --------------------------------------------------------------------------
    def plan(self, start: Sequence[float], goal: Sequence[float],
             obstacles: Optional[np.ndarray] = None) -> np.ndarray:
        """Plan from ``start`` (x, y[, yaw]) to ``goal`` (x, y[, yaw]).

        Args:
            start: the robot's map-frame position.
            goal: the map-frame goal; the path ends exactly there.
            obstacles: optional (N, 2) map-frame points (e.g. another robot seen in the scan),
                inflated by the robot radius and treated as walls for this plan.

        Returns:
            (M, 2) array of map-frame points, spaced about ``path_spacing``, from start to goal.

        Raises:
            PlanError: goal outside the map, too close to a wall, or unreachable.
        """
        gx, gy = float(goal[0]), float(goal[1])
        sx, sy = float(start[0]), float(start[1])
        if not (math.isfinite(gx) and math.isfinite(gy)):
            raise PlanError("goal (%s, %s) is not a finite position" % (goal[0], goal[1]))
        cost = self.cost
        blocked = set()  # type: set
        if obstacles is not None and len(obstacles):
            cost = cost.copy()
            blocked = self._stamp_obstacles(cost, np.asarray(obstacles, dtype=float), (sx, sy))
        gc, gr = self.to_cell(gx, gy)
        if not self.inside(gc, gr):
            b = self.fmap.bounds()
            raise PlanError("goal (%.2f, %.2f) is outside the map (x %.2f..%.2f, y %.2f..%.2f)"
                            % (gx, gy, b[0], b[2], b[1], b[3]))
        if not math.isfinite(cost[gr, gc]):
            fc, fr = self.fmap.world_to_cell(gx, gy)
            clear = max(0.0, float(self._fine[int(fr), int(fc)]))
            if self.fmap.value_at(gx, gy) == 100:
                why = "inside a wall"
            elif self.fmap.value_at(gx, gy) < 0 and self.handling.unknown == "wall":
                why = "in unknown space"
            elif not math.isfinite(self.cost[gr, gc]):
                why = "too close to a wall (clearance %.2f m < robot radius %.2f m)" % (
                    clear, self.config.robot_radius)
            else:
                why = "blocked by an obstacle seen in the scan"
            raise PlanError("goal (%.2f, %.2f) is %s" % (gx, gy, why))
        sc, sr = self.to_cell(sx, sy)
        if not self.inside(sc, sr):
            raise PlanError("start (%.2f, %.2f) is outside the map" % (sx, sy))
        start_cell = self._nearest_free(cost, sc, sr)
        if start_cell is None:
            raise PlanError("start (%.2f, %.2f) is in collision and no free cell is near it"
                            % (sx, sy))
        cells = self._astar(blocked, start_cell, (gc, gr))
        if cells is None:
            raise PlanError("goal (%.2f, %.2f) is unreachable from (%.2f, %.2f)"
                            % (gx, gy, sx, sy))
        pts = np.array([self.to_world(c, r) for c, r in cells], dtype=float)
        pts = self._shortcut(cost, pts)
        pts[0] = (sx, sy)
        pts[-1] = (gx, gy)
        return _resample(pts, self.config.path_spacing)

    def _stamp_obstacles(self, cost: np.ndarray, pts: np.ndarray,
                         start: Tuple[float, float]) -> set:
        """Make the cells within the robot radius (and half a cell) of each point lethal;
        returns their flat indices (row * width + col)."""
        rad = self.config.robot_radius + 0.5 * self.resolution
        stamped = set()
        n = int(math.ceil(rad / self.resolution))
        for x, y in pts:
            if math.hypot(x - start[0], y - start[1]) < self.config.robot_radius:
                continue  # a point inside our own footprint is noise, never block the start
            c0, r0 = self.to_cell(x, y)
            for dr in range(-n, n + 1):
                for dc in range(-n, n + 1):
                    c, r = c0 + dc, r0 + dr
                    if self.inside(c, r):
                        wx, wy = self.to_world(c, r)
                        if math.hypot(wx - x, wy - y) <= rad:
                            cost[r, c] = np.inf
                            stamped.add(r * self.width + c)
        return stamped

    def _nearest_free(self, cost: np.ndarray, c: int, r: int,
                      max_cells: int = 6) -> Optional[Tuple[int, int]]:
        """The cell itself if free, else the nearest free cell within ``max_cells``."""
        best = None
        for d in range(0, max_cells + 1):
            for dr in range(-d, d + 1):
                for dc in range(-d, d + 1):
                    if max(abs(dr), abs(dc)) != d:
                        continue
                    cc, rr = c + dc, r + dr
                    if self.inside(cc, rr) and math.isfinite(cost[rr, cc]):
                        dist = math.hypot(dc, dr)
                        if best is None or dist < best[0]:
                            best = (dist, (cc, rr))
            if best is not None:
                return best[1]
        return None

    def _astar(self, blocked: set, start: Tuple[int, int],
               goal: Tuple[int, int]) -> Optional[List[Tuple[int, int]]]:
        """A* over the grid's costs, the ``blocked`` cells (flat indices) lethal too."""
        W = self.width
        if self._flat is None:  # the cost grid as a list, once: a list index is fastest
            self._flat = self.cost.ravel().tolist()
        flat = self._flat
        if blocked:
            flat = list(flat)
            for k in blocked:
                flat[k] = math.inf
        weight = self.config.cost_weight
        s = start[1] * W + start[0]
        g = goal[1] * W + goal[0]
        gc, gr = goal
        n = self.width * self.height
        best = [math.inf] * n
        parent = [-1] * n
        best[s] = 0.0
        heap = [(0.0, 0.0, s)]
        inf = math.inf
        while heap:
            _, d, u = heapq.heappop(heap)
            if u == g:
                break
            if d > best[u]:
                continue
            ur, uc = divmod(u, W)
            cu = flat[u]
            for dc, dr, step in _NEIGHBOURS:
                vc, vr = uc + dc, ur + dr
                if vc < 0 or vr < 0 or vc >= W or vr >= self.height:
                    continue
                v = vr * W + vc
                cv = flat[v]
                if cv == inf:
                    continue
                if dc and dr and (flat[ur * W + vc] == inf or flat[vr * W + uc] == inf):
                    continue  # no corner cutting past a lethal cell
                nd = d + step * (1.0 + weight * 0.5 * (cu + cv))
                if nd < best[v]:
                    best[v] = nd
                    parent[v] = u
                    hx, hy = abs(vc - gc), abs(vr - gr)
                    h = (hx + hy) + (_SQRT2 - 2.0) * min(hx, hy)
                    heapq.heappush(heap, (nd + h, nd, v))
        if best[g] == inf:
            return None
        out = []
        u = g
        while u != -1:
            r, c = divmod(u, W)
            out.append((c, r))
            u = parent[u]
        out.reverse()
        return out

    def clearance_along(self, pts: np.ndarray) -> np.ndarray:
        """Wall clearance (m) at map-frame points (N, 2), from the map's own cells (finer
        than :meth:`clearance_at`); points off the map read the edge's."""
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        return self._fine_at(*self.fmap.world_to_cell(pts[:, 0], pts[:, 1]))

    def _fine_at(self, col: np.ndarray, row: np.ndarray) -> np.ndarray:
        return self._fine[np.clip(row, 0, self._fine.shape[0] - 1),
                          np.clip(col, 0, self._fine.shape[1] - 1)]

    def _segment_cost(self, cost: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
        """Highest cell cost along the straight segment a-b (inf if it crosses a lethal cell)."""
        length = float(np.hypot(*(b - a)))
        n = max(2, int(math.ceil(length / (0.5 * self.resolution))) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        pts = a[None, :] * (1 - t) + b[None, :] * t
        col, row = self.fmap.world_to_cell(pts[:, 0], pts[:, 1])
        fine = self._fine_at(col, row)
        col, row = col // self.factor, row // self.factor
        ok = (col >= 0) & (row >= 0) & (col < self.width) & (row < self.height)
        if not ok.all() or fine.min() < self.config.robot_radius:
            return math.inf   # off the map, or cutting a corner closer than the cells allow
        return float(cost[row, col].max())

    def _shortcut(self, cost: np.ndarray, pts: np.ndarray) -> np.ndarray:
        """Greedy line-of-sight shortcuts that never bring the path closer to a wall."""
        if len(pts) <= 2:
            return pts
        cell_cost = np.array([cost[self.to_cell(x, y)[::-1]] for x, y in pts])
        out = [pts[0]]
        i = 0
        while i < len(pts) - 1:
            j = i + 1
            worst = max(cell_cost[i], cell_cost[j])
            while j + 1 < len(pts):
                worst_next = max(worst, cell_cost[j + 1])
                if self._segment_cost(cost, pts[i], pts[j + 1]) <= worst_next + 1e-9:
                    j += 1
                    worst = worst_next
                else:
                    break
            out.append(pts[j])
            i = j
        return np.array(out)


def _resample(pts: np.ndarray, spacing: float) -> np.ndarray:
    """Points along a polyline every ``spacing`` metres, keeping both ends."""
    out = [pts[0]]
    for a, b in zip(pts[:-1], pts[1:]):
        seg = float(np.hypot(*(b - a)))
        n = max(1, int(math.ceil(seg / spacing)))
        for k in range(1, n + 1):
            out.append(a + (b - a) * (k / n))
    return np.array(out)


def path_length(path: np.ndarray) -> float:
    """Length (m) of a polyline."""
    if len(path) < 2:
        return 0.0
    return float(np.hypot(*np.diff(path, axis=0).T).sum())


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


@dataclass
class FollowerCommand:
    """One control output: body velocities and the follower's state.

    ``state`` is ``following``, ``rotating`` (turning on the spot towards the path),
    ``aligning`` (at the goal, turning to its heading), ``blocked`` (an obstacle ahead) or
    ``done``.
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
        self._path_clear = (self.clearance(self.path) if self.clearance is not None
                            and len(self.path) else None)

    def _safe_target(self, x: float, y: float, rest: np.ndarray, k: int) -> int:
        """The index of the farthest path point up to ``rest[k]`` (the look-ahead point)
        that the robot reaches in a straight line no nearer a wall than the path gets on the
        way (nor than radius + side margin, nor than it stands now); ``k`` itself when its
        chord is safe or when none is. Pure pursuit cuts the chord: in a door with a bend,
        the chord to a 0.6 m look-ahead ran 1.5 cm into the wall corner."""
        cfg = self.config
        clear = self._path_clear[self._index:]
        here = float(self.clearance(np.array([[x, y]]))[0])
        start = np.array([x, y])
        for j in range(k, 0, -1):
            need = min(cfg.robot_radius + cfg.side_margin, here, float(clear[:j + 1].min()))
            n = max(2, int(math.hypot(*(rest[j] - start)) / 0.025) + 1)
            t = np.linspace(0.0, 1.0, n)[1:, None]
            if self.clearance(start * (1.0 - t) + rest[j] * t).min() >= need - 0.01:
                return j
        return k   # no chord is safe (off the path): pure pursuit as it is

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
        sweep. inf when there is none."""
        if obstacles is None or len(obstacles) == 0:
            return math.inf
        cfg = self.config
        pts = np.asarray(obstacles, dtype=float).reshape(-1, 2)
        pts = _to_map(pose, pts[pts[:, 0] > 0.0])
        if not len(pts):
            return math.inf
        line = np.vstack([np.asarray(pose[:2], dtype=float)[None, :],
                          self.path[self._index + 1:]])
        half, best, s0 = cfg.robot_radius + cfg.side_margin, math.inf, 0.0
        for a, b in zip(line[:-1], line[1:]):
            ab = b - a
            seg = float(np.hypot(*ab))
            if seg > 1e-9:
                t = np.clip(((pts - a) @ ab) / (seg * seg), 0.0, 1.0)
                d = np.hypot(*(pts - a - t[:, None] * ab).T)
                hit = d < half
                if hit.any():
                    best = min(best, s0 + float((t[hit] * seg).min()))
            s0 += seg
            if s0 >= cfg.sweep or s0 >= best:
                break
        return best - cfg.robot_radius

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
        v = cfg.max_linear * min(1.0, dist_goal / cfg.slow_radius)
        v *= max(0.2, math.cos(alpha))
        v = max(v, cfg.min_linear)
        # slow down when something is ahead, to stop in time (scan and control lag)
        v = min(v, cfg.max_linear * max(0.2, min(1.0, (free - cfg.stop_distance) / 0.8)))
        if abs(curvature) * v > cfg.max_angular:
            v = cfg.max_angular / abs(curvature)
        return FollowerCommand(v, _clip(curvature * v, cfg.max_angular), "following", dist_goal)


def _to_map(pose: Sequence[float], pts: np.ndarray) -> np.ndarray:
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


__all__ += ["path_length", "obstacles_in_base", "give_way_point"]


def give_way_point(grid: PlanningGrid, route: np.ndarray, robot: Sequence[float],
                   target: Sequence[float], clear: float, reach: float, roomy: float = 0.0,
                   obstacles: Optional[np.ndarray] = None) -> Optional[Tuple[float, float]]:
    """The free planning-cell centre nearest to ``robot`` that is at least ``clear`` metres from
    every point of ``route`` (an (N, 2) polyline sampled finely, e.g. a plan) and from the
    ``target``, within ``reach`` metres of the robot and reachable from it without passing
    ``obstacles`` (map-frame points, inflated as the planner does); one with ``roomy`` metres
    of wall clearance first. None when there is none."""
    from scipy.ndimage import label

    rx, ry = float(robot[0]), float(robot[1])
    c0, r0 = grid.to_cell(rx, ry)
    n = int(math.ceil(reach / grid.resolution))
    cols = np.arange(max(0, c0 - n), min(grid.width, c0 + n + 1))
    rows = np.arange(max(0, r0 - n), min(grid.height, r0 + n + 1))
    if not len(cols) or not len(rows):
        return None
    cost = grid.cost
    if obstacles is not None and len(obstacles):
        cost = cost.copy()
        grid._stamp_obstacles(cost, np.asarray(obstacles, dtype=float).reshape(-1, 2), (rx, ry))
    free = np.isfinite(cost[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1])
    parts, _ = label(free, structure=np.ones((3, 3)))
    r, c = r0 - rows[0], c0 - cols[0]
    near = parts[max(r - 2, 0):r + 3, max(c - 2, 0):c + 3]   # its cell, or one next to it
    near = near[near > 0]
    if not len(near):
        return None
    own = int(np.bincount(near).argmax())
    R, C = np.nonzero(parts == own)
    R, C = R + rows[0], C + cols[0]
    k = grid.factor
    x, y = grid.fmap.cell_to_world((C + 0.5) * k - 0.5, (R + 0.5) * k - 0.5)
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    d_robot = np.hypot(x - rx, y - ry)
    ok = (d_robot <= reach) & (np.hypot(x - float(target[0]), y - float(target[1])) >= clear)
    pts = np.asarray(route, dtype=float).reshape(-1, 2)
    if len(pts):
        from scipy.spatial import cKDTree

        ok &= cKDTree(pts).query(np.stack([x, y], axis=1))[0] >= clear
    if not ok.any():
        return None
    roomy_ok = ok & (grid.clearance[R, C] >= roomy)
    pick = roomy_ok if roomy_ok.any() else ok
    i = int(np.argmin(np.where(pick, d_robot, np.inf)))
    return float(x[i]), float(y[i])



@dataclass
class NavigatorConfig:
    """Recovery behaviour of :class:`Navigator` (times in sim seconds).

    Attributes:
        replan_after: blocked this long -> plan again, around the obstacles in the scan.
        blocked_timeout: blocked this long in total since the last 0.1 m of progress towards
            the goal -> abort.
        progress_timeout: no 0.1 m of progress towards the goal for this long -> abort.
        obstacle_range: scan points farther than this (m) are ignored when replanning.
        sidestep: how far (m) to step aside when no path passes an obstacle.
        stall_time: commanded to move but moved less than 2 cm and turned less than 0.05 rad
            for this long -> stalled (pressed against another robot the scan does not show
            ahead): plan again at once, around the obstacles in the scan; stalled again soon
            after (it cannot even turn): back up 0.15 m when that brings it no nearer a wall
            of the map and the scan shows nothing behind.
        give_way: when no path passes what blocks it, retreat (before stepping aside) to the
            nearest free place (a roomy one first) at least ``give_way_clear`` m from every
            point the map does not know, within ``give_way_reach`` m, wait ``give_way_wait`` s
            there and go on to the goal: the robot that yields in a passage too narrow for two
            (the observer; the walker keeps its way), at most 3 times a goal. False: wait
            where it is.
    """

    replan_after: float = 2.0
    blocked_timeout: float = 30.0
    progress_timeout: float = 60.0
    obstacle_range: float = 3.0
    sidestep: float = 0.45
    stall_time: float = 1.5
    give_way: bool = False
    give_way_clear: float = 1.2
    give_way_reach: float = 5.0
    give_way_wait: float = 3.0


@dataclass
class NavStatus:
    """What :meth:`Navigator.update` decided: a command and the goal's state.

    ``state`` is ``active``, ``succeeded`` or ``aborted`` (``message`` says why).
    """

    v: float
    w: float
    state: str
    message: str = ""
    distance_to_goal: float = 0.0


class Navigator:
    """Plan, follow, and recover: the embedded move_base.

    Args:
        grid: the planning grid.
        follower: the pure-pursuit controller.
        config: recovery parameters.
    """

    def __init__(self, grid: PlanningGrid, follower: Optional[PathFollower] = None,
                 config: Optional[NavigatorConfig] = None) -> None:
        self.grid = grid
        self.follower = follower or PathFollower()
        self.follower.clearance = grid.clearance_along
        self.config = config or NavigatorConfig()
        self.goal: Optional[Tuple[float, float, Optional[float]]] = None
        self.replans = 0
        self._blocked_since: Optional[float] = None
        self._blocked_total = 0.0
        self._best = math.inf
        self._best_t = 0.0
        self._last_t: Optional[float] = None
        self._last_cmd = (0.0, 0.0)
        self._still_since: Optional[Tuple[float, float, float, float]] = None  # t, x, y, yaw
        self.stalls = 0
        self._retreat: Optional[Tuple[float, float]] = None  # where it retreats to, out of the way
        self._backup_until: Optional[float] = None  # backing up off a contact until then
        self._last_stall = -math.inf
        self._resume_at: Optional[float] = None   # out of the way: when to go on to the goal
        self.retreats = 0
        self._seen = np.zeros((0, 2))             # the last scan's points in the map frame
        self._known = np.zeros(0, dtype=bool)     # which of them are on the map's walls

    @property
    def path(self) -> np.ndarray:
        """The path being followed (map frame)."""
        return self.follower.path

    def start(self, pose: Sequence[float], goal: Sequence[float], now: float) -> np.ndarray:
        """Plan to a new goal (x, y, yaw-or-None) and start following it.

        Raises:
            PlanError: the goal is outside the map, in a wall, or unreachable.
        """
        yaw = goal[2] if len(goal) > 2 else None
        path = self.grid.plan(pose, goal)
        self.goal = (float(goal[0]), float(goal[1]), None if yaw is None else float(yaw))
        self.follower.set_path(path, self.goal[2])
        self.replans = 0
        self._blocked_since = None
        self._blocked_total = 0.0
        self._best = math.inf
        self._best_t = now
        self._last_t = now
        self._last_cmd = (0.0, 0.0)
        self._still_since = None
        self._retreat, self._resume_at, self._backup_until = None, None, None
        self._last_stall = -math.inf
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
            self._seen = _to_map(pose, obstacles)
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
            self._retreat, self._resume_at = None, now + cfg.give_way_wait
            return NavStatus(0.0, 0.0, "active", "giving way", cmd.distance_to_goal)
        if cmd.state == "done":
            self.goal = None
            return NavStatus(0.0, 0.0, "succeeded", "goal reached", cmd.distance_to_goal)
        if self._retreat is None and cmd.distance_to_goal < self._best - 0.1:
            # (retreating, the distance is to the place it retreats to: no progress)
            self._best = cmd.distance_to_goal
            self._best_t = now
            self._blocked_total = 0.0   # the time blocked counts since the last progress
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
            return NavStatus(-_BACKUP_SPEED, 0.0, "active", "backing up", cmd.distance_to_goal)
        self._backup_until = None
        if self._stalled(pose, now):
            self.stalls += 1
            again = now - self._last_stall < 3.0 * cfg.stall_time
            self._last_stall = now
            if again and self._clear_behind(pose, obstacles):
                # pressed against another robot so that it cannot even turn: back off a little
                self._backup_until = now + _BACKUP_TIME
                return NavStatus(-_BACKUP_SPEED, 0.0, "active", "backing up",
                                 cmd.distance_to_goal)
            self._replan_around(pose, obstacles)
            return NavStatus(0.0, 0.0, "active", "stalled", cmd.distance_to_goal)
        if cmd.state not in ("aligning",) and now - self._best_t > cfg.progress_timeout:
            return self._abort("no progress for %.0f s, %.2f m from the goal"
                               % (now - self._best_t, cmd.distance_to_goal), cmd)
        return NavStatus(cmd.v, cmd.w, "active", cmd.state, cmd.distance_to_goal)

    def _clear_behind(self, pose: Sequence[float], obstacles: Optional[np.ndarray]) -> bool:
        """Backing up ``_BACKUP_TIME`` s brings the robot no nearer a wall of the map (than
        now or than its radius), and no scan point lies in the strip it sweeps (a lidar that
        sees only ahead shows nothing there: the map is the check then)."""
        x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
        back = _BACKUP_SPEED * _BACKUP_TIME
        fine = self.grid._fine
        cells = self.grid.fmap.world_to_cell(np.array([x, x - back * math.cos(yaw)]),
                                             np.array([y, y - back * math.sin(yaw)]))
        col, row = (np.asarray(v, dtype=np.int64) for v in cells)
        if not ((col >= 0) & (row >= 0) & (col < fine.shape[1]) & (row < fine.shape[0])).all():
            return False
        r = self.follower.config.robot_radius
        if fine[row[1], col[1]] < min(r, fine[row[0], col[0]]):
            return False
        if obstacles is None or not len(obstacles):
            return True
        pts = np.asarray(obstacles, dtype=float)
        reach = r + _BACKUP_SPEED * _BACKUP_TIME + 0.05
        return not ((pts[:, 0] < 0.0) & (pts[:, 0] > -reach)
                    & (np.abs(pts[:, 1]) < r + 0.03)).any()

    def _abort(self, message: str, cmd: FollowerCommand) -> NavStatus:
        self.goal = None
        return NavStatus(0.0, 0.0, "aborted", message, cmd.distance_to_goal)

    def _replan_around(self, pose: Sequence[float], obstacles: Optional[np.ndarray]) -> None:
        """Plan again with the nearby scan points as walls; keep the old path if none.

        When no path passes the obstacle (two robots nose to nose in a corridor), step aside to
        the right first, as people do: a waypoint ``sidestep`` metres to the robot's right (then
        left) that is clear of walls and of the obstacle, and on to the goal from there. Both
        robots of a head-on meeting do the same, so they pass each other.
        """
        if self.goal is None or obstacles is None or len(obstacles) == 0:
            return
        pts = np.asarray(obstacles, dtype=float)
        # points on the map's walls are already in the grid: keep only the new ones, near
        near = np.hypot(pts[:, 0], pts[:, 1]) < self.config.obstacle_range
        world = self._seen[near & ~self._known]
        try:
            path = self.grid.plan(pose, self._retreat or self.goal, obstacles=world)
        except PlanError:
            if self.config.give_way and self.retreats < _MAX_RETREATS:  # it gets out of the way
                path = self._out_of_the_way(pose, world)
                if path is not None:
                    self._retreat = (float(path[-1, 0]), float(path[-1, 1]))
                    self.retreats += 1
                    self._blocked_total = 0.0
                    self.follower.set_path(path, None)
                    return
            path = None if self._retreat else self._sidestep(pose, world)
            if path is None:
                return  # nothing better: wait for the obstacle to move
        self.replans += 1
        self.follower.set_path(path, None if self._retreat else self.goal[2])

    def _out_of_the_way(self, pose: Sequence[float], world: np.ndarray) -> Optional[np.ndarray]:
        """A path, around ``world`` (the points the map does not know), to the nearest place
        at least ``give_way_clear`` m from all of them; None when there is none."""
        cfg = self.config
        if not len(world):
            return None
        centre = world.mean(axis=0)
        point = give_way_point(self.grid, world, pose, centre, cfg.give_way_clear,
                               cfg.give_way_reach, 0.6, obstacles=world)
        if point is None:
            return None
        try:
            return self.grid.plan(pose, point, obstacles=world)
        except PlanError:
            return None

    def _wait_then_resume(self, pose: Sequence[float], now: float) -> NavStatus:
        """Out of the way: wait, then plan to the goal again (around what the scan shows)."""
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
        self.follower.set_path(path, self.goal[2])
        return NavStatus(0.0, 0.0, "active", "going on")

    def _sidestep(self, pose: Sequence[float], world: np.ndarray) -> Optional[np.ndarray]:
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
                    first = self.grid.plan(pose, (wx, wy))
                    try:
                        rest = self.grid.plan((wx, wy), self.goal, obstacles=world)
                    except PlanError:  # the other one has not stepped aside yet
                        rest = self.grid.plan((wx, wy), self.goal)
                except PlanError:
                    continue
                return np.vstack([first, rest[1:]])
        return None


__all__ += ["NavigatorConfig", "NavStatus", "Navigator"]
