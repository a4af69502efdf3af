"""The planning grid: the floor map inflated by a robot's footprint, with a wall cost, and A*.

:class:`PlanningGrid` turns a :class:`~bullet_floor_sim.sim.floormap.FloorMap` into a coarser
planning grid. A cell is *lethal* when the robot's footprint circle centred on the cell's
centre could touch a wall (or unknown space); free cells near walls carry a cost that decays
exponentially with clearance, as costmap_2d's inflation layer does, so paths keep away from
walls and pass through the middle of doors. :meth:`PlanningGrid.plan` runs 8-connected A* (no
corner cutting), then shortcuts the cell path where a straight segment is no closer to walls
than the cells it replaces, and resamples it. Bad goals raise :class:`PlanError` naming the
goal and the reason.
"""
from __future__ import annotations

import heapq
import math
import threading
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..errors import BulletFloorSimError
from ..sim.floormap import FloorMap
from ..sim.solidmap import MapHandling, solid_map, while_mapping

__all__ = ["PlanError", "PlannerConfig", "PlanningGrid", "disc_points", "path_length"]

_SQRT2 = math.sqrt(2.0)
_NEIGHBOURS = ((1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0),
               (1, 1, _SQRT2), (1, -1, _SQRT2), (-1, 1, _SQRT2), (-1, -1, _SQRT2))


def _moves(W: int) -> Tuple[Any, Any, Any]:
    """The 8 neighbours of a cell in a flat grid ``W`` cells wide: their offsets, their step
    lengths (cells), and for a diagonal the offsets of the two cells beside the step (0, 0
    for a straight one), as arrays for the compiled search, else as lists."""
    deltas = [dr * W + dc for dc, dr, _ in _NEIGHBOURS]
    steps = [step for _, _, step in _NEIGHBOURS]
    corners = [[dc, dr * W] if dc and dr else [0, 0] for dc, dr, _ in _NEIGHBOURS]
    if not _JIT:
        return deltas, steps, corners
    return (np.array(deltas, dtype=np.int64), np.array(steps),
            np.array(corners, dtype=np.int64))


def _search(flat, W, s, g, half_weight, deltas, steps, corners, best, parent,  # type: ignore
            seen, gen):
    """8-connected A* from flat cell ``s`` to ``g`` of a grid ``W`` cells wide with a lethal
    border (``flat``: cell costs, inf lethal). A step costs its length in cells times 1 +
    cost_weight x the mean of the two cells' costs; the heuristic is the octile distance. A
    heap entry is (f, g, cell): equal f go to the larger g, then to the lower cell. Fills
    ``best`` (cost so far) and ``parent`` (the previous cell, -1 none) of the cells it
    reaches, marking each ``seen`` = ``gen`` (the search's number: a cell marked by an
    earlier search counts as not reached, so the buffers serve every search of the grid
    unwiped); True when ``g`` was reached. Compiled by numba when it is installed (the same
    steps, the same path)."""
    inf = math.inf
    gr, gc = g // W, g % W
    diag = _SQRT2 - 2.0
    best[s] = 0.0
    parent[s] = -1
    seen[s] = gen
    heap = [(0.0, 0.0, s)]
    while heap:
        _, d, u = heapq.heappop(heap)
        if u == g:
            return True
        if d > best[u]:
            continue
        cu = flat[u]
        for k in range(8):
            v = u + deltas[k]
            cv = flat[v]
            if cv == inf:
                continue
            if k >= 4 and (flat[u + corners[k][0]] == inf or flat[u + corners[k][1]] == inf):
                continue  # no corner cutting past a lethal cell
            nd = d + steps[k] * (1.0 + half_weight * (cu + cv))
            if seen[v] != gen or nd < best[v]:
                best[v] = nd
                parent[v] = u
                seen[v] = gen
                hx, hy = abs(v % W - gc), abs(v // W - gr)
                heapq.heappush(heap, (nd + ((hx + hy) + diag * min(hx, hy)), nd, v))
    return False


def _segment_worst(ax, ay, bx, by, fine, cost, factor, frame, radius):  # type: ignore
    """Highest planning-cell cost along the segment (ax, ay)-(bx, by), sampled every half
    planning cell; inf when it leaves the grid or passes a map cell closer than ``radius`` to
    a wall (``fine``: the map cells' clearance). ``frame``: the map's origin x, y, the
    cosine and sine of its yaw, its resolution and the planning cell size (as
    FloorMap.world_to_cell)."""
    ox, oy, c, s, res, cell = frame
    n = max(2, int(math.ceil(np.hypot(bx - ax, by - ay) / (0.5 * cell))) + 1)
    t = np.linspace(0.0, 1.0, n)
    dx = ax * (1 - t) + bx * t - ox
    dy = ay * (1 - t) + by * t - oy
    col = np.floor((c * dx + s * dy) / res).astype(np.int64)
    row = np.floor((-s * dx + c * dy) / res).astype(np.int64)
    h, w = fine.shape
    near = fine.ravel()[np.minimum(np.maximum(row, 0), h - 1) * w
                        + np.minimum(np.maximum(col, 0), w - 1)]
    col, row = col // factor, row // factor
    if (col.min() < 0 or row.min() < 0 or col.max() >= cost.shape[1]
            or row.max() >= cost.shape[0] or near.min() < radius):
        return math.inf
    return cost.ravel()[row * cost.shape[1] + col].max()


def _shortcut_keep(px, py, cell_cost, fine, cost, factor, frame, radius):  # type: ignore
    """The points a greedy line-of-sight pass keeps of a path (px, py), as indices: from
    each kept point, on to the farthest next point reachable by a straight segment no
    costlier (:func:`_segment_worst`) than the worst cell it replaces."""
    out = [0]
    i = 0
    while i < len(px) - 1:
        j = i + 1
        worst = max(cell_cost[i], cell_cost[j])
        while j + 1 < len(px):
            worst_next = max(worst, cell_cost[j + 1])
            if _segment_worst(px[i], py[i], px[j + 1], py[j + 1], fine, cost, factor, frame,
                              radius) <= worst_next + 1e-9:
                j += 1
                worst = worst_next
            else:
                break
        out.append(j)
        i = j
    return out


# numba compiles the search (22x faster on office, 9x on a 1448 x 770 hall) and the
# shortcuts (34x, 47x); without it the same functions run as plain Python
try:
    import numba
    _search = numba.njit(cache=True)(_search)
    _segment_worst = numba.njit(cache=True)(_segment_worst)
    _shortcut_keep = numba.njit(cache=True)(_shortcut_keep)
    _JIT = True
except ImportError:
    _JIT = False


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
            1.5 and 6.0 scored within 0.5 points of 3.0's trk50 over 16 worlds (two seeds;
            the folds split, no held-out gain), and 6.0 gave up 8 % of aces_austin's legs
            (docs/evaluation.md, session 54). Every fold keeps 3.0 against 1.5 on 18
            worlds (session 83).
        resolution: planning cell size (m); rounded to a multiple of the map resolution.
            0.1 m: with 0.15 m the map check refuses 7 of 18 corpus worlds (ways in read
            as shut) and with 0.05 m one; every fold of the other 10 keeps 0.1 m
            (docs/evaluation.md, session 81).
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

    def check(self) -> None:
        """Raise PlanError naming the first bad parameter."""
        from ..sim.checks import check_numbers

        check_numbers(self, ("robot_radius", "cost_scaling", "resolution", "path_spacing"),
                      "planner", error=PlanError)
        check_numbers(self, ("inflation_radius", "cost_weight"), "planner", strict=False,
                      error=PlanError)


def largest_part(mask: np.ndarray) -> np.ndarray:
    """The largest 4-connected part of a boolean grid (the first of equal ones; all False
    when ``mask`` has no True cell)."""
    from scipy import ndimage as ndi

    parts, n = ndi.label(mask)
    if n <= 1:
        return mask.astype(bool) if n else np.zeros_like(mask, dtype=bool)
    sizes = np.bincount(parts.ravel())
    sizes[0] = 0
    return parts == int(np.argmax(sizes))


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
        cfg.check()
        k = max(1, int(round(cfg.resolution / fmap.resolution)))
        self.factor = k
        self.resolution = fmap.resolution * k
        # what is solid is decided as the simulator decides it (sim/solidmap.py): occupied
        # cells, unknown areas but not the unseen slivers of an open hall, slits closed
        if handling is None:
            handling = MapHandling() if cfg.unknown_is_obstacle else while_mapping()
        self.handling = handling
        # Distance from each fine cell centre to the nearest solid cell centre, minus half a
        # fine cell (the wall cell's extent): exact for a wall along the grid. A coarse cell's
        # clearance is that of its centre point, as costmap_2d judges a cell by its centre:
        # for an even factor the mean of the four fine cells around it (exact beside a flat
        # wall, at most 2 mm high at a corner). A 0.8 m door is open to a 0.34 m footprint
        # (the worst point of each cell, as before, closed it: 0.9 m was the narrowest).
        dist = solid_map(fmap, handling).distance
        assert dist is not None   # solid_map's answer always has it
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
        self._flat: Any = None   # the padded costs (_padded)
        self._graph: Optional[Tuple[Any, np.ndarray]] = None
        self._node_cells: Optional[np.ndarray] = None   # node_cells()
        self._roomiest: Optional[np.ndarray] = None
        self._narrow: Dict[Tuple[float, float], np.ndarray] = {}   # narrow_axis()
        self._search_buffers: Optional[Tuple[Any, Any, Any]] = None   # _buffers()
        self._searches = 0   # the number of the last A* search (_search's gen)
        self._search_lock = threading.Lock()

    def __getstate__(self) -> dict:
        """A copy or a pickle leaves out the search's lock and buffers (made anew)."""
        state = self.__dict__.copy()
        state["_search_lock"] = None
        state["_search_buffers"] = None
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._search_lock = threading.Lock()

    def narrow_axis(self, other_radius: float, margin: float) -> np.ndarray:
        """nav/passing.narrow_axis on this grid (read-only): worked out once for each
        (other_radius, margin) and shared by every Navigator that plans on the grid."""
        from .passing import narrow_axis

        key = (float(other_radius), float(margin))
        axis = self._narrow.get(key)
        if axis is None:
            axis = narrow_axis(self, *key)
            axis.setflags(write=False)
            self._narrow[key] = axis
        return axis

    # -- coordinates -----------------------------------------------------------------------
    def to_cell(self, x: float, y: float) -> Tuple[int, int]:
        """(col, row) of the planning cell containing a map-frame point (may be out of range)."""
        col, row = self.fmap.world_to_cell(x, y)
        return int(col) // self.factor, int(row) // self.factor

    def to_world(self, col: float, row: float) -> Tuple[float, float]:
        """Map-frame centre of a planning cell."""
        x, y = self.centres(col, row)
        return float(x), float(y)

    def centres(self, cols: Any, rows: Any) -> Tuple[np.ndarray, np.ndarray]:
        """Map-frame centres (x, y) of planning cells (arrays or scalars)."""
        u = (np.asarray(cols, dtype=float) + 0.5) * self.factor - 0.5
        v = (np.asarray(rows, dtype=float) + 0.5) * self.factor - 0.5
        return self.fmap.cell_to_world(u, v)

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

    def free_cell_near(self, x: float, y: float, max_cells: int = 6) -> Optional[Tuple[int, int]]:
        """(col, row) of the passable cell of (x, y), else of the nearest passable one within
        ``max_cells`` cells (None when there is none)."""
        c, r = self.to_cell(x, y)
        return self._nearest_free(self.cost, c, r, max_cells)

    def line_of_sight(self, a: Sequence[float], b: Sequence[float]) -> bool:
        """The straight segment a-b (map frame) stays on passable cells."""
        return math.isfinite(self._segment_cost(self.cost, np.asarray(a[:2], dtype=float),
                                                np.asarray(b[:2], dtype=float)))

    def in_sight(self, xy: np.ndarray, target: Sequence[float]) -> np.ndarray:
        """Which map-frame points (N, 2) see ``target``: the straight line between them
        crosses no solid cell of the map (sampled every half map cell), as a lidar beam
        from one to the other would."""
        pts = np.asarray(xy, dtype=float).reshape(-1, 2)
        tx, ty = float(target[0]), float(target[1])
        span = np.hypot(pts[:, 0] - tx, pts[:, 1] - ty)
        n = max(2, int(math.ceil(float(span.max(initial=0.0)) / (0.5 * self.fmap.resolution))) + 1)
        s = np.linspace(0.0, 1.0, n)[None, :]
        x = pts[:, :1] + s * (tx - pts[:, :1])
        y = pts[:, 1:] + s * (ty - pts[:, 1:])
        # the solid cells themselves: on_walls within 0 m (a solid cell's _fine is -half a
        # cell, a free one's at least +half a cell); off the map counts as solid
        solid = self.on_walls(np.column_stack([x.ravel(), y.ravel()]),
                              tolerance=-self.fmap.resolution)
        return ~solid.reshape(x.shape).any(axis=1)

    def graph(self) -> Tuple[Any, np.ndarray]:
        """The passable cells as an undirected scipy sparse graph, with A*'s step costs (8
        neighbours, a diagonal only where both cells beside it are passable, each step its
        length in cells times 1 + cost_weight x the mean of the two cells' costs), and the
        node of each cell (-1: not passable). Built once."""
        if self._graph is None:
            self._graph = _grid_graph(self.cost, self.config.cost_weight)
        return self._graph

    def node_cells(self) -> np.ndarray:
        """The (row, col) of each node of :meth:`graph` (node k is the k-th passable cell in
        row-major order), (N, 2). Found once."""
        if self._node_cells is None:
            self._node_cells = np.argwhere(self.graph()[1] >= 0)
        return self._node_cells

    # -- planning --------------------------------------------------------------------------
    def plan(self, start: Sequence[float],
             goal: Union[Sequence[float], Tuple[float, float, Optional[float]]],
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
        cr = np.array(cells)
        pts = np.stack(self.centres(cr[:, 0], cr[:, 1]), axis=1)
        pts = self._shortcut(cost, pts)
        pts[0] = (sx, sy)
        pts[-1] = (gx, gy)
        return _resample(pts, self.config.path_spacing)

    def _stamp_obstacles(self, cost: np.ndarray, pts: np.ndarray, start: Tuple[float, float],
                         corner: Tuple[int, int] = (0, 0)) -> set:
        """Make the cells within the robot radius (and half a cell) of each point lethal;
        returns their flat indices (row * width + col). ``cost`` is the grid's costs or a
        window of them whose first cell is ``corner`` (col, row); cells outside it are left
        alone. A point inside the robot's own footprint (about ``start``) is noise and blocks
        nothing."""
        rad = self.config.robot_radius + 0.5 * self.resolution
        pts = np.asarray(pts, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise PlanError("obstacles: (N, 2) map-frame points expected, got an array of "
                            "shape %s" % (pts.shape,))
        pts = pts[np.hypot(pts[:, 0] - start[0], pts[:, 1] - start[1])
                  >= self.config.robot_radius]
        if not len(pts):
            return set()
        n = int(math.ceil(rad / self.resolution))
        dr, dc = np.divmod(np.arange((2 * n + 1) ** 2), 2 * n + 1)
        col, row = self.fmap.world_to_cell(pts[:, 0], pts[:, 1])
        c = (col // self.factor)[:, None] + (dc - n)[None, :]
        r = (row // self.factor)[:, None] + (dr - n)[None, :]
        (c_lo, r_lo), (h, w) = corner, cost.shape
        wx, wy = self.centres(c, r)
        hit = ((c >= c_lo) & (c < c_lo + w) & (r >= r_lo) & (r < r_lo + h)
               & (np.hypot(wx - pts[:, :1], wy - pts[:, 1:]) <= rad))
        c, r = c[hit], r[hit]
        cost[r - r_lo, c - c_lo] = np.inf
        return set((r * self.width + c).tolist())

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

    def _padded(self) -> Any:
        """The cost grid, flat, with a lethal border one cell wide so that A* needs no bounds
        checks: a float64 array for the compiled search, else a list (a list index is the
        fastest in Python); built once."""
        if self._flat is None:
            flat = np.pad(self.cost, 1, constant_values=np.inf).ravel()
            self._flat = flat if _JIT else flat.tolist()
        return self._flat

    def _astar(self, blocked: set, start: Tuple[int, int],
               goal: Tuple[int, int]) -> Optional[List[Tuple[int, int]]]:
        """A* (:func:`_search`) over the grid's costs, the ``blocked`` cells (flat indices)
        lethal too; the cells from start to goal, or None when the goal cannot be reached."""
        W = self.width + 2
        flat = self._padded()
        if blocked:
            flat = flat.copy() if _JIT else list(flat)
            for k in blocked:
                r, c = divmod(k, self.width)
                flat[(r + 1) * W + c + 1] = math.inf
        s = (start[1] + 1) * W + start[0] + 1
        g = (goal[1] + 1) * W + goal[0] + 1
        with self._search_lock:   # one search at a time uses the buffers
            best, parent, seen = self._buffers(len(flat))
            self._searches += 1
            if not _search(flat, W, s, g, 0.5 * self.config.cost_weight, *_moves(W), best,
                           parent, seen, self._searches):
                return None
            out = []
            u = g
            while u != -1:
                r, c = divmod(int(u), W)
                out.append((c - 1, r - 1))
                u = parent[u]
        out.reverse()
        return out

    def _buffers(self, n: int) -> Tuple[Any, Any, Any]:
        """The A* search's cost-so-far, parent and seen arrays of ``n`` cells, made once and
        kept while the grid lives (24 bytes a cell: 27 MB on a 1448 x 770 hall), as wiping
        grid-sized arrays for every plan cost more than the search on a large map: arrays
        for the compiled search, else lists."""
        if self._search_buffers is None or len(self._search_buffers[0]) != n:
            if _JIT:
                self._search_buffers = (np.full(n, np.inf), np.full(n, -1, dtype=np.int64),
                                        np.zeros(n, dtype=np.int64))
            else:
                self._search_buffers = ([math.inf] * n, [-1] * n, [0] * n)
        return self._search_buffers

    def roomiest(self, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The largest wall clearance (m) of a map cell centre within each planning cell,
        plus half a map cell: twice it is a passage's width through that cell to a map cell
        (exact for an even number of free cells between walls along the grid)."""
        if self._roomiest is None:
            k, (h, w) = self.factor, self._fine.shape
            pad = np.full((self.height * k, self.width * k), -np.inf)
            pad[:h, :w] = self._fine
            self._roomiest = pad.reshape(self.height, k, self.width, k).max(axis=(1, 3)) \
                + 0.5 * self.fmap.resolution
        return self._roomiest[rows, cols]

    def clearance_along(self, pts: np.ndarray) -> np.ndarray:
        """Wall clearance (m) at map-frame points (N, 2), from the map's own cells (finer
        than :meth:`clearance_at`); points off the map read the edge's."""
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        return self._fine_at(*self.fmap.world_to_cell(pts[:, 0], pts[:, 1]))

    def _fine_at(self, col: np.ndarray, row: np.ndarray) -> np.ndarray:
        h, w = self._fine.shape   # (np.clip costs several times minimum and maximum)
        return self._fine[np.minimum(np.maximum(row, 0), h - 1), np.minimum(np.maximum(col, 0), w - 1)]

    def _frame(self) -> Tuple[float, float, float, float, float, float]:
        """The map frame as :func:`_segment_worst` reads it."""
        ox, oy, yaw = self.fmap.origin
        return (float(ox), float(oy), math.cos(yaw), math.sin(yaw), float(self.fmap.resolution),
                float(self.resolution))

    def _segment_cost(self, cost: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
        """Highest cell cost along the straight segment a-b (inf if it crosses a lethal cell)."""
        return float(_segment_worst(float(a[0]), float(a[1]), float(b[0]), float(b[1]),
                                    self._fine, cost, self.factor, self._frame(),
                                    self.config.robot_radius))

    def _shortcut(self, cost: np.ndarray, pts: np.ndarray) -> np.ndarray:
        """Greedy line-of-sight shortcuts that never bring the path closer to a wall
        (:func:`_shortcut_keep`)."""
        if len(pts) <= 2:
            return pts
        col, row = self.fmap.world_to_cell(pts[:, 0], pts[:, 1])
        cell_cost = cost[row // self.factor, col // self.factor]
        keep = _shortcut_keep(pts[:, 0].copy(), pts[:, 1].copy(), cell_cost, self._fine, cost,
                              self.factor, self._frame(), float(self.config.robot_radius))
        return pts[np.asarray(keep)]


def _resample(pts: np.ndarray, spacing: float) -> np.ndarray:
    """Points along a polyline every ``spacing`` metres, keeping both ends."""
    out = [pts[0]]
    for a, b in zip(pts[:-1], pts[1:]):
        seg = float(np.hypot(*(b - a)))
        n = max(1, int(math.ceil(seg / spacing)))
        for k in range(1, n + 1):
            out.append(a + (b - a) * (k / n))
    return np.array(out)


def disc_points(x: float, y: float, radius: float) -> np.ndarray:
    """A robot or person as :meth:`PlanningGrid.plan`'s ``obstacles``: 12 points on the
    circle of ``radius`` round (x, y), (12, 2)."""
    a = np.linspace(0.0, 2.0 * math.pi, 12, endpoint=False)
    return np.column_stack([x + radius * np.cos(a), y + radius * np.sin(a)])


def path_length(path: np.ndarray) -> float:
    """Length (m) of a polyline."""
    if len(path) < 2:
        return 0.0
    return float(np.hypot(*np.diff(path, axis=0).T).sum())


def _grid_graph(cost: np.ndarray, weight: float) -> Tuple[Any, np.ndarray]:
    """PlanningGrid.graph's graph and node index of a cost grid."""
    from scipy.sparse import coo_matrix

    ok = np.isfinite(cost)
    node = np.full(ok.shape, -1, dtype=np.int64)
    node[ok] = np.arange(int(ok.sum()))

    h, w = ok.shape
    rows, cols, vals = [], [], []
    for dr, dc, step in ((0, 1, 1.0), (1, 0, 1.0), (1, 1, _SQRT2), (1, -1, _SQRT2)):
        a = (slice(0, h - dr), slice(max(0, -dc), w - max(0, dc)))
        b = (slice(dr, h), slice(max(0, dc), w + min(0, dc)))
        both = ok[a] & ok[b]
        if dr and dc:   # no corner cutting
            both &= ok[(a[0], b[1])] & ok[(b[0], a[1])]
        ca, cb = np.where(both, cost[a], 0.0), np.where(both, cost[b], 0.0)
        rows.append(node[a][both])
        cols.append(node[b][both])
        vals.append(step * (1.0 + weight * 0.5 * (ca[both] + cb[both])))
    n = int(ok.sum())
    graph = coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(n, n)).tocsr()
    return graph, node
