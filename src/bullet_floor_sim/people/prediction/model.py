"""The destination model: cost-to-go fields over the planning grid, goal points per region,
and the posterior over the destination region of one leg. See the package doc."""
from __future__ import annotations

import math
import os
import time
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..markov import MarkovChain
from ...nav.planner import PlanningGrid
from ...data.rois import Roi, roi_polygon
from ...geometry import wrap_angle
from ..walker import RegionIndex, anchor
from .calibration import calibrate
from ...sim.checks import is_number as _is_number
from .config import PredictionConfig, PredictionError, _check_xy, _quote

__all__ = ["DestinationModel"]

_SQRT2 = math.sqrt(2.0)
_SLACK = 1e-9  # metres: 0.3 m walked in decimal steps must count as 0.3 m
# (d_col, d_row, step in cells): each undirected grid edge once
_EDGES = ((1, 0, 1.0), (0, 1, 1.0), (1, 1, _SQRT2), (-1, 1, _SQRT2))
_AROUND = tuple((dc, dr) for dr in (-1, 0, 1) for dc in (-1, 0, 1))

_STARTS_KEPT = 8   # leg starts whose values DestinationModel keeps
_FORK_GRAPH = None   # the graph a forked Dijkstra worker reads (DestinationModel._dijkstra)


def _logsumexp(a: np.ndarray) -> float:
    """log(sum(exp(a))) of a 1-D array, the largest term taken out first, as
    scipy.special.logsumexp computes it up to scipy 1.14 (the same float; Debian 12 has
    1.10), without its checks of the input, which took a tenth of a study's time called
    for every region at every step."""
    m = a.max()
    if m == -math.inf:
        return -math.inf
    if not np.isfinite(m):
        m = 0.0
    return float(np.log(np.exp(a - m).sum()) + m)


def _fields(graph, sources: np.ndarray) -> np.ndarray:
    """Shortest-path costs from each source to every node (float32 rows)."""
    from scipy.sparse.csgraph import dijkstra

    return dijkstra(graph, directed=True, indices=sources).astype(np.float32)


def _fields_in_fork(sources: np.ndarray) -> np.ndarray:
    return _fields(_FORK_GRAPH, sources)


class DestinationModel:
    """Destination posteriors over the regions of a chain, on one planning grid.

    Args:
        grid: the planner's grid over the map (the walker's: same robot radius and costs).
        rois: the regions; every region of the chain must be among them.
        chain: the Markov chain the entity's destinations follow.
        config: parameters (checked).
        goal_points: region id -> explicit goal points (x, y), replacing the lattice for the
            regions it names (e.g. one point per region for hand-computed posteriors).

    Attributes:
        goal_problems: region id -> why the region has no goal point at all.
        precompute_seconds: wall time the goal points and V fields took.

    Raises:
        PredictionError: bad config, a chain region without ROI, or bad goal_points.
    """

    def __init__(self, grid: PlanningGrid, rois: Sequence[Roi], chain: MarkovChain,
                 config: Optional[PredictionConfig] = None,
                 goal_points: Optional[Mapping[str, Sequence[Sequence[float]]]] = None) -> None:
        t0 = time.perf_counter()
        self.grid = grid
        self.chain = chain
        self.config = cfg = config or PredictionConfig()
        cfg.check()
        self.index = RegionIndex(rois)
        missing = [r for r in chain.ids if r not in self.index.by_id]
        if missing:
            raise PredictionError("prediction: chain regions without ROI: %s"
                                  % ", ".join(missing))
        self._chain_index = RegionIndex([self.index.by_id[r] for r in chain.ids])
        explicit = dict(goal_points or {})
        for r in explicit:
            if r not in chain.ids:
                raise PredictionError("prediction: goal_points names unknown region %r "
                                      "(regions: %s)" % (r, ", ".join(chain.ids)))
        self._build_graph()
        self.goal_problems = {}  # type: Dict[str, str]
        goals = {}  # type: Dict[str, np.ndarray]
        for r in chain.ids:
            pts = (self._explicit_goals(r, explicit[r]) if r in explicit
                   else self._lattice_goals(self.index.by_id[r]))
            goals[r] = pts
            if not len(pts) and r not in self.goal_problems:
                self.goal_problems[r] = "region %s has no goal point" % _quote(r)
        self._goals = goals
        self._slices = {}  # type: Dict[str, slice]
        nodes: List[int] = []
        for r in chain.ids:
            self._slices[r] = slice(len(nodes), len(nodes) + len(goals[r]))
            for x, y in goals[r]:
                c, row = grid.to_cell(x, y)
                nodes.append(int(self._node[row, c]))
        self._fields = self._dijkstra(np.array(nodes, dtype=np.intp))
        self._start_cache: Dict[Tuple[float, float, float], np.ndarray] = {}
        self.precompute_seconds = time.perf_counter() - t0

    # ---- precomputation --------------------------------------------------------------------

    def _build_graph(self) -> None:
        from scipy.sparse import csr_matrix

        grid = self.grid
        cost = grid.cost
        free = np.isfinite(cost)
        H, W = cost.shape
        node = np.full((H, W), -1, dtype=np.intp)
        node[free] = np.arange(int(free.sum()))
        self._node, self._free = node, free
        weight = grid.config.cost_weight
        rows, cols, weights = [], [], []
        R, C = np.nonzero(free)
        for dc, dr, step in _EDGES:
            rn, cn = R + dr, C + dc
            ok = (rn >= 0) & (rn < H) & (cn >= 0) & (cn < W)
            r, c, rn, cn = R[ok], C[ok], rn[ok], cn[ok]
            ok = free[rn, cn]
            if dc and dr:  # no corner cutting past a lethal cell, as the planner
                ok &= free[r, cn] & free[rn, c]
            r, c, rn, cn = r[ok], c[ok], rn[ok], cn[ok]
            rows.append(node[r, c])
            cols.append(node[rn, cn])
            weights.append(step * grid.resolution
                           * (1.0 + weight * 0.5 * (cost[r, c] + cost[rn, cn])))
        n = int(free.sum())
        # both directions of every edge, so that Dijkstra runs directed (scipy's undirected
        # mode builds the symmetric graph on every call; the fields are the same, about 5 %
        # faster on malaga_campus)
        a, b, wt = np.concatenate(rows), np.concatenate(cols), np.concatenate(weights)
        self._graph = csr_matrix((np.concatenate([wt, wt]), (np.concatenate([a, b]),
                                                             np.concatenate([b, a]))),
                                 shape=(n, n))

    def _dijkstra(self, sources: np.ndarray) -> np.ndarray:
        """One field per source, in chunks of 32 (bounded float64 scratch). The chunks run in
        forked worker processes, one per core up to 4, when this process has no other thread
        (the evaluation; a ROS node has rospy's threads, and forking those is unsafe):
        scipy's Dijkstra holds the GIL, and on malaga_campus (274k nodes, 240 sources) it is
        16 s in one process."""
        import multiprocessing
        import threading

        n = self._graph.shape[0]
        out = np.empty((len(sources), n), dtype=np.float32)
        chunks = [sources[k:k + 32] for k in range(0, len(sources), 32)]
        workers = min(os.cpu_count() or 1, len(chunks), 4)
        if workers > 1 and threading.active_count() == 1 and hasattr(os, "fork"):
            global _FORK_GRAPH
            _FORK_GRAPH = self._graph   # the workers inherit it (copy-on-write)
            try:
                with multiprocessing.get_context("fork").Pool(workers) as pool:
                    for k, part in enumerate(pool.imap(_fields_in_fork, chunks)):
                        out[32 * k:32 * k + len(part)] = part
            finally:
                _FORK_GRAPH = None
        else:
            for k, chunk in enumerate(chunks):
                out[32 * k:32 * k + len(chunk)] = _fields(self._graph, chunk)
        return out

    def _goal_ok(self, x: np.ndarray, y: np.ndarray, clearance: float) -> np.ndarray:
        grid = self.grid
        col, row = grid.fmap.world_to_cell(x, y)
        col, row = col // grid.factor, row // grid.factor
        inside = (col >= 0) & (row >= 0) & (col < grid.width) & (row < grid.height)
        ok = np.zeros(len(x), dtype=bool)
        c, r = col[inside], row[inside]
        ok[inside] = self._free[r, c] & (grid.clearance[r, c] >= clearance)
        return ok

    def _lattice_goals(self, roi: Roi) -> np.ndarray:
        """A centred lattice inside the region, free with clearance; denser lattices and
        smaller margins for small regions; thinned evenly to the cap."""
        import shapely

        cfg = self.config
        poly = roi_polygon(roi)
        xmin, ymin, xmax, ymax = poly.bounds
        boundary = poly.exterior
        for spacing in (cfg.goal_spacing, cfg.goal_spacing / 2.0, cfg.goal_spacing / 4.0):
            nx = int(math.floor((xmax - xmin) / spacing)) + 1
            ny = int(math.floor((ymax - ymin) / spacing)) + 1
            xs = xmin + 0.5 * ((xmax - xmin) - (nx - 1) * spacing) + spacing * np.arange(nx)
            ys = ymin + 0.5 * ((ymax - ymin) - (ny - 1) * spacing) + spacing * np.arange(ny)
            gy, gx = np.meshgrid(ys, xs, indexing="ij")
            x, y = gx.ravel(), gy.ravel()
            inside = shapely.contains_xy(poly, x, y)
            x, y = x[inside], y[inside]
            if not len(x):
                continue
            depth = shapely.distance(boundary, shapely.points(x, y))
            free = self._goal_ok(x, y, max(cfg.clearance, self.grid.config.robot_radius))
            for margin in (cfg.margin, cfg.margin / 2.0, 0.0):
                ok = free & (depth >= margin)
                if ok.any():
                    pts = np.stack([x[ok], y[ok]], axis=1)
                    if len(pts) > cfg.max_goals_per_region:
                        pick = np.linspace(0, len(pts) - 1, cfg.max_goals_per_region)
                        pts = pts[np.unique(np.round(pick).astype(np.intp))]
                    return pts
        self.goal_problems[roi.id] = ("region %s has no point %g m from every wall on a %g m "
                                      "lattice" % (_quote(roi.id), cfg.clearance,
                                                   cfg.goal_spacing / 4.0))
        return np.zeros((0, 2))

    def _explicit_goals(self, region: str, points: Sequence[Sequence[float]]) -> np.ndarray:
        out = []
        dropped = []
        for k, p in enumerate(points):
            if (not isinstance(p, (list, tuple, np.ndarray)) or len(p) != 2
                    or not all(_is_number(v) and math.isfinite(v) for v in p)):
                raise PredictionError("prediction: goal_points[%r][%d] must be a finite (x, y), "
                                      "got %r" % (region, k, p))
            x, y = float(p[0]), float(p[1])
            if self._goal_ok(np.array([x]), np.array([y]), 0.0)[0]:
                out.append((x, y))
            else:
                dropped.append("(%.2f, %.2f)" % (x, y))
        if dropped and not out:
            self.goal_problems[region] = ("region %s: goal point(s) %s not in free space"
                                          % (_quote(region), ", ".join(dropped)))
        return np.array(out, dtype=float).reshape(-1, 2)

    # ---- lookups ---------------------------------------------------------------------------

    def region_at(self, x: float, y: float) -> str:
        """The id of the region containing (x, y); "" when it is in none."""
        return self.index.region_at(x, y)

    def start_region(self, x: float, y: float) -> str:
        """The region a leg starts from, as the walker decides it: the region of the chain
        containing the point, else the chain's region nearest to it."""
        _check_xy((x, y), "start position")
        here = self.index.region_at(x, y)
        if here in self.chain.ids:
            return here
        roi = self._chain_index.nearest(x, y)
        if roi is None:
            raise PredictionError("prediction: the chain has no regions")
        return roi.id

    def goals(self, region: str) -> np.ndarray:
        """The (k, 2) goal points of a region."""
        self._check_region(region)
        return self._goals[region].copy()

    def prior(self, r0: str) -> Dict[str, float]:
        """P(g | r0): the chain's row of r0 (non-zero entries, in chain order)."""
        self._check_region(r0)
        return self.chain.row(r0)

    def cost_to_go(self, region: str, x: float, y: float) -> np.ndarray:
        """V_p(x, y) (metres of weighted path) for each goal point p of a region; inf where
        a goal point cannot be reached from (x, y)."""
        self._check_region(region)
        _check_xy((x, y), "position")
        return self._values(float(x), float(y))[self._slices[region]].copy()

    def _start_values(self, x: float, y: float) -> np.ndarray:
        """:meth:`_values` at a leg's start (a leg asks at every step from the same start),
        kept for up to ``_STARTS_KEPT`` starts (all forgotten when that many are kept) and
        the ``snap_distance`` they were read with; read only."""
        cache = self._start_cache
        key = (x, y, self.config.snap_distance)
        v = cache.get(key)
        if v is None:
            if len(cache) >= _STARTS_KEPT:
                cache.clear()
            v = self._values(x, y)
            v.flags.writeable = False
            cache[key] = v
        return v

    def _values(self, x: float, y: float) -> np.ndarray:
        """V of every goal point at (x, y), refined between cell centres (float64)."""
        nodes, extra = self._access(x, y)
        if not len(nodes):
            return np.full(self._fields.shape[0], np.inf)
        v = self._fields[:, nodes].astype(float) + extra[None, :]
        return v.min(axis=1)

    def _access(self, x: float, y: float) -> Tuple[np.ndarray, np.ndarray]:
        """Graph nodes a position steps onto directly, and the cost of each step: its own
        cell and that cell's grid neighbours; the nearest free cell when its own is lethal."""
        grid = self.grid
        cost = grid.cost
        weight = grid.config.cost_weight
        c, r = grid.to_cell(x, y)
        nodes, extra = [], []
        if grid.inside(c, r) and self._free[r, c]:
            steps = []
            for dc, dr in _AROUND:
                cn, rn = c + dc, r + dr
                if not (grid.inside(cn, rn) and self._free[rn, cn]):
                    continue
                if dc and dr and not (self._free[r, cn] and self._free[rn, c]):
                    continue
                steps.append((cn, rn))
            cols, rows = np.array(steps, dtype=np.int64).reshape(-1, 2).T
            wxs, wys = grid.centres(cols, rows)   # (one call: a call per cell cost 8 times it)
            for (cn, rn), wx, wy in zip(steps, wxs.tolist(), wys.tolist()):
                nodes.append(self._node[rn, cn])
                extra.append(math.hypot(wx - x, wy - y)
                             * (1.0 + weight * 0.5 * (cost[r, c] + cost[rn, cn])))
        else:
            k = int(math.ceil(self.config.snap_distance / grid.resolution))
            best = None
            for rn in range(max(0, r - k), min(grid.height, r + k + 1)):
                for cn in range(max(0, c - k), min(grid.width, c + k + 1)):
                    if self._free[rn, cn]:
                        wx, wy = grid.to_world(cn, rn)
                        d = math.hypot(wx - x, wy - y)
                        if d <= self.config.snap_distance and (best is None or d < best[0]):
                            best = (d, rn, cn)
            if best is not None:
                d, rn, cn = best
                nodes.append(self._node[rn, cn])
                extra.append(d * (1.0 + weight * cost[rn, cn]))
        return np.array(nodes, dtype=np.intp), np.array(extra, dtype=float)

    # ---- posterior -------------------------------------------------------------------------

    def posterior(self, r0: str, start_xy: Sequence[float],
                  current_xy: Sequence[float]) -> Dict[str, float]:
        """P(g | r0, S..Q) over the regions of r0's row (chain order; sums to 1).

        Args:
            r0: the region the leg started from.
            start_xy: S, where the leg started (map frame).
            current_xy: Q, where the entity is now.

        Raises:
            PredictionError: unknown r0, non-finite position, or no region of the row
                reachable (a position off the map's free space).
        """
        return self.posterior_details(r0, start_xy, current_xy)[0]

    def posterior_details(self, r0: str, start_xy: Sequence[float],
                          current_xy: Sequence[float]) -> Tuple[Dict[str, float],
                                                                Dict[str, str]]:
        """The posterior, and why each region of the row that got 0 got it.

        Returns:
            (probabilities, reasons): reasons maps region id -> one line.

        Raises:
            PredictionError: as :meth:`posterior`.
        """
        prior = self.prior(r0)
        sx, sy = _check_xy(start_xy, "start_xy")
        qx, qy = _check_xy(current_xy, "current_xy")
        vs = self._start_values(sx, sy)
        vq = vs if (qx, qy) == (sx, sy) else self._values(qx, qy)
        logw = {}  # type: Dict[str, float]
        reasons = {}  # type: Dict[str, str]
        for g, p in prior.items():
            sl = self._slices[g]
            if sl.start == sl.stop:
                reasons[g] = self.goal_problems.get(g, "region %s has no goal point"
                                                    % _quote(g))
                continue
            a, b = vs[sl], vq[sl]
            ok = np.isfinite(a) & np.isfinite(b)
            if not ok.any():
                reasons[g] = ("no goal point of region %s is reachable from (%.2f, %.2f)"
                              % (_quote(g), sx, sy))
                continue
            a, b = a[ok], b[ok]
            terms = self._terms(a, b)
            logw[g] = math.log(p) + _logsumexp(terms) - math.log(int(ok.sum()))
        if not logw:
            where = ["%s (%.2f, %.2f)" % (what, x, y) for what, x, y
                     in (("start", sx, sy), ("current", qx, qy)) if not len(self._access(x, y)[0])]
            if where:
                raise PredictionError("prediction: %s not within %g m of the map's free space"
                                      % (" and ".join(where), self.config.snap_distance))
            raise PredictionError("prediction: no region of %s's row is reachable: %s"
                                  % (_quote(r0), "; ".join(reasons.values())))
        total = _logsumexp(np.array(list(logw.values())))
        probs = {g: (math.exp(logw[g] - total) if g in logw else 0.0) for g in prior}
        return calibrate(probs, prior, self.config.temperature, self.config.prior_mix), reasons

    def likely_goals(self, start_xy: Sequence[float], current_xy: Sequence[float]
                     ) -> Dict[str, Tuple[float, float]]:
        """Each region's goal point that the walk S..Q makes most likely: the largest term
        of :meth:`posterior`'s sum over the region's points (the most progress towards it,
        for the length of its leg). Regions with no goal point reachable from both S and Q
        are left out.

        Raises:
            PredictionError: a non-finite position.
        """
        sx, sy = _check_xy(start_xy, "start_xy")
        qx, qy = _check_xy(current_xy, "current_xy")
        with np.errstate(invalid="ignore"):   # (inf - inf: unreachable, left out)
            terms = self._terms(self._start_values(sx, sy), self._values(qx, qy))
        out = {}
        for g, sl in self._slices.items():
            t = terms[sl]
            ok = np.flatnonzero(np.isfinite(t))
            if len(ok):
                x, y = self._goals[g][int(ok[np.argmax(t[ok])])]
                out[g] = (float(x), float(y))
        return out

    def _terms(self, vs: np.ndarray, vq: np.ndarray) -> np.ndarray:
        """The log terms of the posterior's sum for goal points with cost-to-go ``vs`` from
        the leg's start and ``vq`` from where the entity is: -beta * (V_p(Q) - V_p(S)) -
        alpha * log(L_p), L_p = max(V_p(S), goal_spacing)."""
        cfg = self.config
        return -cfg.beta * (vq - vs) - cfg.length_exponent * np.log(np.maximum(vs, cfg.goal_spacing))

    # ---- baselines -------------------------------------------------------------------------

    def markov_baseline(self, r0: str) -> Dict[str, float]:
        """The chain alone: P(g | r0), whatever the motion."""
        return self.prior(r0)

    def heading_baseline(self, r0: str, xy: Sequence[float],
                         velocity: Sequence[float]) -> Dict[str, float]:
        """The region the entity is heading for: 1 - heading_epsilon to the first region of
        r0's row (other than the one it is in) that a ray from ``xy`` along ``velocity``
        enters, or, when the ray meets none, to the one whose anchor point lies closest to
        the heading; heading_epsilon shared by the row's other regions. Slower than
        stop_speed: the prior.

        Raises:
            PredictionError: unknown r0, non-finite position or velocity.
        """
        import shapely
        from shapely.geometry import LineString

        prior = self.prior(r0)
        x, y = _check_xy(xy, "xy")
        vx, vy = _check_xy(velocity, "velocity")
        speed = math.hypot(vx, vy)
        if speed < max(self.config.stop_speed, 1e-9) or len(prior) == 1:
            return dict(prior)
        ux, uy = vx / speed, vy / speed
        here = self.index.region_at(x, y)
        candidates = [g for g in prior if g != here] or list(prior)
        polys = {g: roi_polygon(self.index.by_id[g]) for g in candidates}
        bounds = np.array([p.bounds for p in polys.values()])
        reach = float(np.hypot(bounds[:, [0, 2]] - x, bounds[:, [1, 3]] - y).max()) + 1.0
        ray = LineString([(x, y), (x + ux * reach, y + uy * reach)])
        hits = {}
        for g, poly in polys.items():
            inter = ray.intersection(poly)
            if not inter.is_empty:
                pts = shapely.get_coordinates(inter)
                hits[g] = float(((pts[:, 0] - x) * ux + (pts[:, 1] - y) * uy).min())
        if hits:
            chosen = min(candidates, key=lambda g: hits.get(g, math.inf))
        else:
            heading = math.atan2(uy, ux)

            def deviation(g: str) -> float:
                ax, ay = anchor(self.index.by_id[g])
                return abs(wrap_angle(math.atan2(ay - y, ax - x) - heading))
            chosen = min(candidates, key=deviation)
        eps = self.config.heading_epsilon
        rest = eps / (len(prior) - 1)
        return {g: (1.0 - eps if g == chosen else rest) for g in prior}

    # ---- helpers ---------------------------------------------------------------------------

    def _check_region(self, region: str) -> None:
        if region not in self._slices:
            raise PredictionError("prediction: unknown region %r (regions: %s)"
                                  % (region, ", ".join(self.chain.ids)))


# --------------------------------------------------------------------------------------------
# online, per track
# --------------------------------------------------------------------------------------------
