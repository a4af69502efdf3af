"""Where is it going? A posterior over the destination region of a walking entity.

Planning-based prediction (Ziebart et al. 2009, "Planning-based prediction for pedestrians";
the approximation Dragan et al. use for legibility): an entity that starts a leg at S in
region r0 draws its destination region g from the Markov chain's row of r0 (g = r0 included:
a move inside the same region, as the walker does), then a goal point p in g, and walks an
efficient path to p on the inflated map. Having seen it walk from S to its current position Q,

    P(g | S..Q)  ∝  P(g | r0) · mean_{p ∈ goals(g)} exp(−β (V_p(Q) − V_p(S))) / L_p^α

where V_p is the cost-to-go to p on the :class:`~bullet_floor_sim.nav.planner.PlanningGrid`
with the planner's step cost (step length in metres × (1 + cost_weight × mean cell cost),
lethal cells impassable, 8-connected without corner cutting). The cost of the observed path
S..Q is the same under every hypothesis and cancels. V_p(S) − V_p(Q) is the *progress* made
towards p: a goal the entity walks straight at gains exp(β·distance), one it walks away from
loses as much. β (1/m) is the rationality: how strongly progress counts.

L_p = max(V_p(S), goal_spacing) is the length of the leg to p. With α = 1 it states that the
moment Q is seen is equally likely at any fraction of the leg (the walk to p passes Q once,
and Q lies on the first L_p metres): as a leg is scored at 10-90 % of its duration, or as
anyone asks "where is it going?" once per leg. With α = 0 the moment is equally likely at any
metre walked (long legs are seen more often). Left out (α = 0), a short move inside a long
corridor region loses to the region beyond it at every moment, since only the region's
points ahead of Q stay consistent while the next region's all do.

* goals(g) is a fixed set of acceptable goal points in the region, as the walker's
  :class:`~bullet_floor_sim.people.walker.GoalSampler` accepts them (inside the polygon with a
  margin, with ``clearance`` to every wall): a lattice of ``goal_spacing``, spread-thinned to
  ``max_goals_per_region``; or, per region, the points given as ``goal_points``.
* The V fields are computed once, one Dijkstra per goal point (scipy.sparse.csgraph) over the
  planning grid's free cells; the graph is undirected, so a shortest-path tree from p is the
  cost-to-go to p. Between cell centres V is refined by one step of the grid: V(Q) = the least
  V(n) + cost of the straight step from Q to the centre of n, over Q's cell and its grid
  neighbours, so that V follows the position continuously along a straight walk. A position
  in a lethal cell (the entity brushing a wall) uses the nearest free cell within
  ``snap_distance``.
* Goal points not reachable from S are dropped; a region none of whose goal points is
  reachable gets probability 0 and a reason (:meth:`DestinationModel.posterior_details`).
  Sums are taken in log space (log-sum-exp).

Baselines for evaluation: :meth:`DestinationModel.markov_baseline` (the chain row alone) and
:meth:`DestinationModel.heading_baseline` (the region the current heading points at).

:class:`OnlinePredictor` cuts one entity's stream into legs (dwell, move, dwell) and gives the
current leg's :class:`Prediction` at every update. Everything is plain numbers in, plain
numbers out; no rospy.
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..errors import BulletFloorSimError
from .markov import MarkovChain
from ..nav.planner import PlanningGrid
from ..data.rois import Roi, roi_polygon
from ..geometry import wrap_angle
from .walker import RegionIndex, anchor

__all__ = [
    "PredictionError",
    "PredictionConfig",
    "DestinationModel",
    "Prediction",
    "OnlinePredictor",
    "PredictorPool",
    "log_loss",
    "posterior_or_prior",
    "top1",
]

_SQRT2 = math.sqrt(2.0)
_SLACK = 1e-9  # metres: 0.3 m walked in decimal steps must count as 0.3 m
# (d_col, d_row, step in cells): each undirected grid edge once
_EDGES = ((1, 0, 1.0), (0, 1, 1.0), (1, 1, _SQRT2), (-1, 1, _SQRT2))
_AROUND = tuple((dc, dr) for dr in (-1, 0, 1) for dc in (-1, 0, 1))

XY = Tuple[float, float]


_FORK_GRAPH = None   # the graph a forked Dijkstra worker reads (DestinationModel._dijkstra)


def _fields(graph, sources: np.ndarray) -> np.ndarray:
    """Shortest-path costs from each source to every node (float32 rows)."""
    from scipy.sparse.csgraph import dijkstra

    return dijkstra(graph, directed=True, indices=sources).astype(np.float32)


def _fields_in_fork(sources: np.ndarray) -> np.ndarray:
    return _fields(_FORK_GRAPH, sources)


class PredictionError(BulletFloorSimError):
    """Bad prediction input: unknown region, non-finite position or time, bad parameters, or
    a position from which no region of the row can be reached."""


@dataclass
class PredictionConfig:
    """Prediction parameters (distances in metres, times in seconds).

    Attributes:
        beta: rationality (1/m): a metre of progress towards a goal multiplies its likelihood
            by exp(beta).
        length_exponent: α, how a leg's length L_p to a goal point weighs (1 / L_p^α): 1 says
            a moment is equally likely at any fraction of a leg (the evaluation's sampling).
        goal_spacing: lattice spacing of the goal points of a region; also the shortest
            leg length L_p counted.
        max_goals_per_region: at most this many goal points per region (spread over the
            lattice), one Dijkstra each.

        beta, length_exponent and max_goals_per_region were chosen by
        bench/choose_prediction.py on 100 legs (seed 2) of each shipped world, leaving the
        scored world out: every fold chose length_exponent 1 (over 0, 0.5, 1.5), three of
        four beta 5 (over 2, 3, 8) and 24 goal points (over 12); the README gives the folds.
        clearance: a goal point keeps at least this distance from every wall (the walker's
            0.45 m).
        margin: a goal point keeps at least this distance from its region's boundary (the
            walker's 0.5 m; halved, then 0, for regions too narrow for it, as the walker does).
        stop_speed: below this speed (m/s) the entity is standing (dwelling).
        dwell_time: standing this long ends a leg. 3 s: the walker dwells 5-20 s at a goal,
            while it also stands still mid-leg for up to ~2.6 s (turning on the spot, waiting
            2 s before a replan), which must not cut a leg in two.
        min_progress: a leg starts once the entity is this far from where it stood, so that
            shuffling on the spot is no leg.
        heading_epsilon: probability mass the heading baseline spreads over the candidates it
            did not choose (so its log-loss stays finite).
        snap_distance: a position in a lethal cell uses the nearest free cell within this
            distance; farther away, the position is not on the map's free space.
        handover_time: a new track that appears within this many seconds of another track's
            last update, near enough (``handover_speed``), is the same entity seen again
            after an occlusion: it takes over that track's leg (:class:`PredictorPool`).
            4 s: shorter than the walker's shortest dwell (5 s), so the leg taken over is
            the one under way.
        handover_speed: ... near enough: within 0.5 m + this speed (m/s) x the gap.
    """

    beta: float = 5.0
    length_exponent: float = 1.0
    goal_spacing: float = 1.0
    max_goals_per_region: int = 24
    clearance: float = 0.45
    margin: float = 0.5
    stop_speed: float = 0.1
    dwell_time: float = 3.0
    min_progress: float = 0.3
    heading_epsilon: float = 0.1
    snap_distance: float = 0.6
    handover_time: float = 4.0
    handover_speed: float = 1.5

    def check(self) -> None:
        """Raise PredictionError naming the first bad parameter."""
        for name in ("goal_spacing", "min_progress"):
            v = getattr(self, name)
            if not (_is_number(v) and math.isfinite(v) and v > 0):
                raise PredictionError("prediction: %s must be a finite number > 0, got %r"
                                      % (name, v))
        for name in ("beta", "length_exponent", "clearance", "margin", "stop_speed", "dwell_time",
                     "snap_distance", "handover_time", "handover_speed"):
            v = getattr(self, name)
            if not (_is_number(v) and math.isfinite(v) and v >= 0):
                raise PredictionError("prediction: %s must be a finite number >= 0, got %r"
                                      % (name, v))
        v = self.max_goals_per_region
        if not (isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1):
            raise PredictionError("prediction: max_goals_per_region must be an integer >= 1, "
                                  "got %r" % (v,))
        v = self.heading_epsilon
        if not (_is_number(v) and 0.0 <= v < 1.0):
            raise PredictionError("prediction: heading_epsilon must be a number in [0, 1), "
                                  "got %r" % (v,))


# --------------------------------------------------------------------------------------------
# the model
# --------------------------------------------------------------------------------------------


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
        nodes = []  # type: List[int]
        for r in chain.ids:
            self._slices[r] = slice(len(nodes), len(nodes) + len(goals[r]))
            for x, y in goals[r]:
                c, row = grid.to_cell(x, y)
                nodes.append(int(self._node[row, c]))
        self._fields = self._dijkstra(np.array(nodes, dtype=np.intp))
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
            for dc, dr in _AROUND:
                cn, rn = c + dc, r + dr
                if not (grid.inside(cn, rn) and self._free[rn, cn]):
                    continue
                if dc and dr and not (self._free[r, cn] and self._free[rn, c]):
                    continue
                wx, wy = grid.to_world(cn, rn)
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
        from scipy.special import logsumexp

        prior = self.prior(r0)
        sx, sy = _check_xy(start_xy, "start_xy")
        qx, qy = _check_xy(current_xy, "current_xy")
        vs = self._values(sx, sy)
        vq = vs if (qx, qy) == (sx, sy) else self._values(qx, qy)
        beta, alpha = self.config.beta, self.config.length_exponent
        floor = self.config.goal_spacing
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
            terms = -beta * (b - a) - alpha * np.log(np.maximum(a, floor))
            logw[g] = math.log(p) + float(logsumexp(terms)) - math.log(int(ok.sum()))
        if not logw:
            where = ["%s (%.2f, %.2f)" % (what, x, y) for what, x, y
                     in (("start", sx, sy), ("current", qx, qy)) if not len(self._access(x, y)[0])]
            if where:
                raise PredictionError("prediction: %s not within %g m of the map's free space"
                                      % (" and ".join(where), self.config.snap_distance))
            raise PredictionError("prediction: no region of %s's row is reachable: %s"
                                  % (_quote(r0), "; ".join(reasons.values())))
        total = float(logsumexp(list(logw.values())))
        probs = {g: (math.exp(logw[g] - total) if g in logw else 0.0) for g in prior}
        return probs, reasons

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


@dataclass
class Prediction:
    """The destination posterior of the current leg of one entity.

    Attributes:
        t: time of the observation it is based on (s).
        leg_start: time the leg started (the last time the entity stood at ``start_xy``).
        start_region: r0, the region the leg started from.
        start_xy: S, where it stood before the leg.
        probabilities: region id -> P(g | S..Q), over r0's row, summing to 1.
        best: the most probable region.
        best_probability: its probability.
        observed: metres walked since S.
        leg: leg number of this track (1, 2, ...).
        note: why the probabilities are only the prior ("" normally): the position was off
            the map's free space.
        under_way: False when no leg is under way: the entity stands (or has not yet moved
            ``min_progress`` from where it stood), and this is the prediction of the leg it
            will start next, from where it stands (``start_xy``): the chain's row of its
            region, the posterior once it moves. ``leg`` is then that next leg's number.
    """

    t: float
    leg_start: float
    start_region: str
    start_xy: XY
    probabilities: Dict[str, float]
    best: str
    best_probability: float
    observed: float
    leg: int = 1
    note: str = ""
    under_way: bool = True

    def to_dict(self) -> Dict[str, Any]:
        """The prediction as plain data (for a JSON topic or a log)."""
        return {"t": self.t, "leg": self.leg, "under_way": self.under_way,
                "leg_start": self.leg_start,
                "start_region": self.start_region,
                "start_xy": [round(v, 3) for v in self.start_xy],
                "probabilities": {g: round(p, 6) for g, p in self.probabilities.items()},
                "best": self.best, "best_probability": round(self.best_probability, 6),
                "observed": round(self.observed, 3), "note": self.note}


@dataclass
class _Leg:
    number: int
    start: float
    region: str
    xy: XY
    observed: float = 0.0
    slow_since: Optional[float] = None


class OnlinePredictor:
    """Legs and destination posteriors from one entity's pose stream.

    One OnlinePredictor per track (entity id): it keeps that track's leg state. Legs are cut
    as the walker makes them: the entity stands (speed < stop_speed) at S; a leg starts once
    it is ``min_progress`` away from S, with r0 = the region of S (:meth:`DestinationModel.
    start_region`) and leg_start the last time it stood at S; the leg ends when it has stood
    for ``dwell_time``. Moving slower than stop_speed counts as standing.

    With no leg under way, :meth:`update` predicts the next leg from where the entity stands
    (``under_way`` False): the chain's row of its region, since nothing of that leg has been
    seen. A walker leg of 3-8 s inside one office is half over before a tracker's velocity
    and 0.3 m of progress make it a leg; saying nothing there (None) was a miss on 8 % of
    200 evaluation legs, the prior is right on most of them (offices are sticky).

    Args:
        model: the destination model (shared by all tracks of one map).
    """

    def __init__(self, model: DestinationModel) -> None:
        self.model = model
        self.legs = 0
        self.last = None  # type: Optional[Prediction]
        self.reset()

    def reset(self) -> None:
        """Forget the track's state (a new entity, or a jump in time); leg numbers go on."""
        self._leg = None  # type: Optional[_Leg]
        self._anchor = None  # type: Optional[Tuple[float, float, float]]
        self._prev = None  # type: Optional[Tuple[float, float, float]]
        self._walked = 0.0

    @property
    def in_leg(self) -> bool:
        """Whether a leg is under way."""
        return self._leg is not None

    def update(self, t: float, x: float, y: float, vx: float, vy: float) -> Prediction:
        """One observation of the entity.

        Args:
            t: time (s), not before the previous update's.
            x, y: position (map frame).
            vx, vy: velocity (m/s, map frame).

        Returns:
            The current leg's prediction, or with no leg under way (before its first move,
            and once a leg has ended) the next leg's (``under_way`` False).

        Raises:
            PredictionError: a non-finite input, or time going backwards.
        """
        for name, v in (("t", t), ("x", x), ("y", y), ("vx", vx), ("vy", vy)):
            if not (_is_number(v) and math.isfinite(v)):
                raise PredictionError("prediction: update %s must be a finite number, got %r"
                                      % (name, v))
        t, x, y = float(t), float(x), float(y)
        if self._prev is not None and t < self._prev[0]:
            raise PredictionError("prediction: update t %.3f is before the previous update's "
                                  "%.3f (reset() for a new stream)" % (t, self._prev[0]))
        cfg = self.model.config
        step = 0.0 if self._prev is None else math.hypot(x - self._prev[1], y - self._prev[2])
        self._prev = (t, x, y)
        standing = math.hypot(float(vx), float(vy)) < cfg.stop_speed
        leg = self._leg
        if leg is None:
            if self._anchor is None or standing:
                self._anchor, self._walked = (t, x, y), 0.0
                return self._next_leg(t, x, y)
            self._walked += step
            at, ax, ay = self._anchor
            if math.hypot(x - ax, y - ay) < cfg.min_progress - _SLACK:
                return self._next_leg(t, x, y)
            self.legs += 1
            leg = self._leg = _Leg(self.legs, at, self.model.start_region(ax, ay), (ax, ay),
                                   self._walked)
        else:
            leg.observed += step
            if standing:
                if leg.slow_since is None:
                    leg.slow_since = t
                if t - leg.slow_since >= cfg.dwell_time:
                    self._leg = None
                    self._anchor, self._walked = (t, x, y), 0.0
                    return self._next_leg(t, x, y)
            else:
                leg.slow_since = None
        return self._predict(t, leg, x, y, True)

    def _next_leg(self, t: float, x: float, y: float) -> Prediction:
        """The prediction of the leg that starts from the anchor (no leg under way)."""
        at, ax, ay = self._anchor
        leg = _Leg(self.legs + 1, at, self.model.start_region(ax, ay), (ax, ay), self._walked)
        return self._predict(t, leg, x, y, False)

    def _predict(self, t: float, leg: _Leg, x: float, y: float, under_way: bool) -> Prediction:
        probs, note = posterior_or_prior(self.model, leg.region, leg.xy, (x, y))
        best = top1(probs)
        self.last = Prediction(t, leg.start, leg.region, leg.xy, probs, best, probs[best],
                               leg.observed, leg.number, note, under_way)
        return self.last


def posterior_or_prior(model: DestinationModel, r0: str, start_xy: Sequence[float],
                       current_xy: Sequence[float]) -> Tuple[Dict[str, float], str]:
    """The posterior, or the chain's row of r0 with the reason when a position is off the
    map's free space (what :class:`OnlinePredictor` publishes then): (probabilities, note)."""
    try:
        return model.posterior(r0, start_xy, current_xy), ""
    except PredictionError as e:
        return model.prior(r0), str(e)


# --------------------------------------------------------------------------------------------
# evaluation
# --------------------------------------------------------------------------------------------


def log_loss(probs: Mapping[str, float], truth: str, floor: float = 1e-6) -> float:
    """-ln P(truth), with P floored at ``floor`` (a region the distribution left out counts
    as ``floor``), in nats.

    Raises:
        PredictionError: floor not in (0, 1].
    """
    if not (_is_number(floor) and 0.0 < floor <= 1.0):
        raise PredictionError("log_loss: floor must be in (0, 1], got %r" % (floor,))
    return -math.log(max(float(probs.get(truth, 0.0)), float(floor)))


def top1(probs: Mapping[str, float]) -> str:
    """The most probable region (the first one on a tie).

    Raises:
        PredictionError: no probabilities.
    """
    if not probs:
        raise PredictionError("top1: no probabilities")
    best, best_p = "", -math.inf
    for g, p in probs.items():
        if p > best_p:
            best, best_p = g, p
    return best


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def _check_xy(xy: Any, what: str) -> XY:
    try:
        x, y = (float(v) for v in xy)
        ok = math.isfinite(x) and math.isfinite(y)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise PredictionError("prediction: %s must be a finite (x, y), got %r" % (what, xy))
    return x, y


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)




def _quote(s: Any) -> str:
    return '"%s"' % s


class PredictorPool:
    """One :class:`OnlinePredictor` per track, with hand-over across occlusions.

    A tracker gives an entity a new id when it loses it for longer than its ``max_age`` (the
    walker goes behind a door jamb, or the observer turns): without hand-over the new id's
    leg would start where it was seen again, in the wrong region (the prior's row) and with
    the walked part of the leg missing. A track id seen for the first time takes over the
    predictor of a track that is gone (not in this update), last updated at most
    ``handover_time`` seconds ago within 0.5 m + ``handover_speed`` x the gap (the nearest
    such). Predictors of tracks gone for ``forget_after`` seconds are dropped.

    Args:
        model: the destination model.
        forget_after: seconds.
    """

    _NEAR = 0.5

    def __init__(self, model: DestinationModel, forget_after: float = 30.0) -> None:
        self.model = model
        self.forget_after = float(forget_after)
        self.predictors = {}  # type: Dict[int, OnlinePredictor]
        self._last = {}  # type: Dict[int, Tuple[float, float, float]]
        self.handovers = 0
        self.errors = {}  # type: Dict[int, str]

    def update(self, t: float, tracks: Sequence[Sequence[float]]
               ) -> Dict[int, Prediction]:
        """One track update: ``tracks`` as (id, x, y, vx, vy). Returns each track's
        prediction (of the next leg while it has none under way). A track whose input
        :meth:`OnlinePredictor.update` refuses (non-finite, time going back) is left out of
        the result, with the one-line reason in ``errors[id]``; the others are updated.
        """
        cfg = self.model.config
        t = float(t)
        ids = {int(tr[0]) for tr in tracks}
        out = {}  # type: Dict[int, Prediction]
        self.errors = {}  # type: Dict[int, str]
        for tr in tracks:
            k, x, y, vx, vy = int(tr[0]), float(tr[1]), float(tr[2]), tr[3], tr[4]
            pred = self.predictors.get(k)
            if pred is None:
                pred = self._take_over(t, x, y, ids, cfg) or OnlinePredictor(self.model)
                self.predictors[k] = pred
            try:
                out[k] = pred.update(t, x, y, vx, vy)
            except PredictionError as e:
                self.errors[k] = "track %d: %s" % (k, e)
                if k not in self._last:   # never updated: nothing to keep
                    del self.predictors[k]
                continue
            self._last[k] = (t, x, y)
        for k in [k for k, (tl, _, _) in self._last.items() if t - tl > self.forget_after]:
            self.predictors.pop(k, None)
            del self._last[k]
        return out

    def _take_over(self, t: float, x: float, y: float, alive: set,
                   cfg: PredictionConfig) -> Optional[OnlinePredictor]:
        best, best_d = None, math.inf
        for k, (tl, xl, yl) in self._last.items():
            gap = t - tl
            if k in alive or gap < 0.0 or gap > cfg.handover_time:
                continue
            d = math.hypot(x - xl, y - yl)
            if d <= self._NEAR + cfg.handover_speed * gap and d < best_d:
                best, best_d = k, d
        if best is None:
            return None
        del self._last[best]
        self.handovers += 1
        return self.predictors.pop(best)
