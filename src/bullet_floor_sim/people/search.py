"""Where the observer looks: which track to follow (:func:`pick_target`), where to search for
a lost target (:func:`search_plan`, :func:`search_point`: the destinations' points, the likely
ones first; :func:`lookout_points`: the points of a region with the widest view of it),
where to patrol when those gave nothing (:func:`patrol_points`, :class:`PatrolTour`), where
most ways across the building pass (:func:`hub_points`), and whether a point is in the
lidar's view (:func:`in_view`). people/follow.FollowBehaviour and
people/agents use them."""
from __future__ import annotations

import math
from typing import Callable, List, Mapping, Optional, Protocol, Sequence, Tuple, Union

import numpy as np

from ..geometry import wrap_angle, wrap_angles
from ..nav.planner import PlanningGrid

__all__ = ["pick_target", "search_point", "search_points", "search_plan", "SearchPlan", "likely_count",
           "lookout_points",
           "patrol_points", "hub_points", "PatrolTour", "in_view", "as_plan"]

#: points (N, 2): a list of (x, y) or an array (DestinationModel.goals)
Points = Union[Sequence[Sequence[float]], np.ndarray]


class TrackLike(Protocol):
    """What the observer reads of a track (a tracking.Track, for one)."""

    id: int
    x: float
    y: float
    vx: float
    vy: float


def pick_target(tracks: Sequence, current: Optional[int],
                last_xy: Optional[Sequence[float]]) -> Optional[TrackLike]:
    """The track to follow among ``tracks`` (objects with ``id``, ``x``, ``y``): the one being
    followed (id ``current``) while it lives; else the one nearest to where the target was last
    seen; else the oldest (lowest id). None when there is no track."""
    if not tracks:
        return None
    for tr in tracks:
        if tr.id == current:
            return tr
    if last_xy is not None:
        return min(tracks, key=lambda tr: math.hypot(tr.x - last_xy[0], tr.y - last_xy[1]))
    return min(tracks, key=lambda tr: tr.id)


def search_point(points: Points, xy: Sequence[float]) -> Tuple[float, float]:
    """Where to look for a lost target heading for a region: of the region's candidate
    points (``points``: its goal points, DestinationModel.goals, or their lookouts,
    PredictorAgent.lookouts), the one nearest to where it was last seen (``xy`` itself when
    the region has none)."""
    return search_points([points], xy)[0]


def search_points(regions: Sequence[Points], xy: Sequence[float]
                  ) -> List[Tuple[float, float]]:
    """:func:`search_point` of each region's points, with one distance computation for all
    of them (a plan of every region is made on every track update)."""
    x, y = float(xy[0]), float(xy[1])
    arrays = [np.asarray(p, dtype=float).reshape(-1, 2) for p in regions]
    counts = [len(a) for a in arrays]
    if not sum(counts):
        return [(x, y)] * len(arrays)
    pts = np.concatenate(arrays)
    d = np.hypot(pts[:, 0] - x, pts[:, 1] - y)
    seg = np.repeat(np.arange(len(arrays)), counts)
    first = np.lexsort((np.arange(len(d)), d, seg))    # by region, nearest first
    starts = np.cumsum([0] + counts[:-1])
    out = []
    for k, s in zip(counts, starts.tolist()):
        if k:
            i = int(first[s])
            out.append((float(pts[i, 0]), float(pts[i, 1])))
        else:
            out.append((x, y))
    return out


def lookout_points(grid: PlanningGrid, points: Points, sight: float) -> np.ndarray:
    """Of a region's points (its goal points, DestinationModel.goals), those from which the
    most of them are in view: within ``sight`` metres (and a micrometre, so that points of
    a lattice exactly ``sight`` apart count whatever the rounding) with no wall between
    (PlanningGrid.in_sight), each counting itself; (M, 2), in the given order. All of them
    where every two are within ``sight`` of each other with no wall between (a small
    room); in a corridor longer than ``sight``, not the points within ``sight`` of one end
    while it runs on past that the other way (from there the observer looks down one way
    of it only: aces_austin, docs/evaluation.md session 47); in a room wider than
    ``sight``, the point or few with the widest view; in a region a wall cuts in two,
    those of the side that has more of them. The most seen is often one point alone: on
    the six corpus worlds of session 47, a long region keeps 1-3 of its 24 goal points."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(pts) < 3:   # (one or two: each sees all the others or none, so all are kept)
        return pts
    seen = np.zeros(len(pts), dtype=np.int64)
    for i in range(len(pts)):
        d = np.hypot(pts[:, 0] - pts[i, 0], pts[:, 1] - pts[i, 1])
        near = np.flatnonzero(d <= sight + 1e-6)
        seen[i] = int(np.count_nonzero(grid.in_sight(pts[near], pts[i])))
    return pts[seen == seen.max()]


class SearchPlan(list):
    """Where to search for a lost target: (region, (x, y)) pairs, most likely first; its
    first ``likely`` are searched in turn, round after round, the rest once each after them
    (FollowBehaviour)."""

    def __init__(self, pairs=(), likely: Optional[int] = None) -> None:
        super().__init__(pairs)
        self.likely = len(self) if likely is None else max(0, min(int(likely), len(self)))


def likely_count(ranked: Sequence[float], count: int, min_probability: float) -> int:
    """How many of the probabilities ``ranked`` (most likely first) make the likely regions
    of a search: at most ``count``, each at least ``min_probability``, the first always."""
    n = 0
    for k, p in enumerate(list(ranked)[:max(1, int(count))]):
        if k > 0 and float(p) < min_probability:
            break
        n += 1
    return n


def search_plan(probabilities: Mapping[str, float], goals: Callable[[str], Points],
                xy: Sequence[float], count: int = 3, min_probability: float = 0.05,
                best: Optional[str] = None, rest: bool = False) -> SearchPlan:
    """Where to search for a lost target: the ``count`` most likely destination regions with
    probability at least ``min_probability`` (the most likely one always), most likely first
    (of equal ones ``best`` first, e.g. the predictor's arg-max, then by region id), each with
    its :func:`search_point` (``goals(region)``: the region's candidate points, e.g.
    PredictorAgent.lookouts) nearest to ``xy``,
    where the target was last seen; with ``rest``, every other region after them: those of
    at least ``min_probability`` in the same order, then the unlikelier ones nearest first
    (their search point's distance from ``xy``: near-nil probabilities order nothing, and by
    id the observer crossed the building to and fro). SearchPlan.likely: how many are the
    likely ones."""
    ranked = sorted(probabilities.items(),
                    key=lambda kv: (-float(kv[1]), kv[0] != best, kv[0]))
    n = likely_count([p for _, p in ranked], count, min_probability)
    regions = [region for region, _ in (ranked if rest else ranked[:n])]
    points = list(zip(regions, search_points([goals(r) for r in regions], xy)))
    plan = points[:n]
    if rest:
        more = points[n:]
        likely = {region for region, p in ranked[n:] if float(p) >= min_probability}
        far = [m for m in more if m[0] not in likely]
        far.sort(key=lambda m: (math.hypot(m[1][0] - float(xy[0]), m[1][1] - float(xy[1])),
                                m[0]))
        plan += [m for m in more if m[0] in likely] + far
    return SearchPlan(plan, n)


def as_plan(destination) -> SearchPlan:
    """``destination`` (None, one (region, (x, y)) pair, a list of them, or a SearchPlan) as
    a SearchPlan (a plain list: all of it likely)."""
    if destination is None:
        return SearchPlan()
    likely = getattr(destination, "likely", None)
    if len(destination) == 2 and isinstance(destination[0], str):
        destination = [destination]
    return SearchPlan([(str(r), (float(p[0]), float(p[1]))) for r, p in destination], likely)


def patrol_points(grid: PlanningGrid, spacing: float, clearance: float) -> np.ndarray:
    """Where to patrol for a target lost for good: the roomiest place of every ``spacing`` x
    ``spacing`` block of the planning grid that has at least ``clearance`` to the walls, as an
    (N, 2) array of map points (row by row)."""
    k = max(1, int(round(spacing / grid.resolution)))
    out = []
    for r0 in range(0, grid.height, k):
        for c0 in range(0, grid.width, k):
            block = grid.clearance[r0:r0 + k, c0:c0 + k]
            i = int(np.argmax(block))
            if block.flat[i] >= clearance:
                r, c = divmod(i, block.shape[1])
                out.append(grid.to_world(c0 + c, r0 + r))
    return np.array(out, dtype=float).reshape(-1, 2)


def hub_points(grid: PlanningGrid, places: np.ndarray, spacing: float, clearance: float,
               count: int) -> np.ndarray:
    """The places most ways across the building pass, busiest first: up to ``count`` of
    ``places`` (:func:`patrol_points`) with at least ``clearance`` to the walls, each at least
    2 ``spacing`` from every busier hub chosen, as a (K, 2) array.

    The places are joined where they lie within 2 ``spacing`` of each other with no wall
    between (PlanningGrid.in_sight); a place's business is how many of the shortest ways
    between two other places go through it (its betweenness): one shortest way per ordered
    pair (so each pair counts twice), of equal ones the one scipy's shortest_path gives.
    Places no way goes through are never hubs."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import shortest_path

    pts = np.asarray(places, dtype=float).reshape(-1, 2)
    n, reach = len(pts), 2.0 * spacing
    rows, cols, weights = [], [], []
    for i in range(n):
        d = np.hypot(pts[:, 0] - pts[i, 0], pts[:, 1] - pts[i, 1])
        near = np.flatnonzero((d <= reach) & (np.arange(n) > i))
        if len(near):
            near = near[grid.in_sight(pts[near], pts[i])]
            rows += [i] * len(near)
            cols += near.tolist()
            weights += d[near].tolist()
    if not rows:
        return np.zeros((0, 2))
    graph = coo_matrix((weights, (rows, cols)), shape=(n, n)).tocsr()
    dist, pred = shortest_path(graph, directed=False, return_predecessors=True)
    ways = np.zeros(n)
    for i in range(n):
        # the shortest-path tree from i: a node lies on the way to each node of its subtree
        below = np.ones(n)
        reached = np.flatnonzero(np.isfinite(dist[i]))
        for v in reached[np.argsort(-dist[i, reached], kind="stable")]:
            if pred[i, v] >= 0:
                below[pred[i, v]] += below[v]
        below[i] = 1.0
        ways[reached] += below[reached] - 1.0
    out: List[np.ndarray] = []
    for i in sorted(range(n), key=lambda k: (-ways[k], k)):
        if ways[i] <= 0 or len(out) >= count:
            break
        if grid.clearance_at(float(pts[i, 0]), float(pts[i, 1])) < clearance:
            continue
        if all(math.hypot(pts[i, 0] - o[0], pts[i, 1] - o[1]) >= reach for o in out):
            out.append(pts[i])
    return np.array(out, dtype=float).reshape(-1, 2)


class PatrolTour:
    """A tour of the building's patrol places (:func:`patrol_points`, made when first
    needed): the nearest not visited first, each once a tour. A place seen on the way
    (within ``sight`` metres, within 90 degrees of the heading, no wall between:
    PlanningGrid.in_sight) counts as visited; 0: only the places gone to count. The place
    it drives to is gone to even when seen from afar: passing it over for the next, the
    observer in a small office turned on the spot from one seen place to the next and
    never left it (a crowd of 3 went untracked for 90 s).

    Attributes:
        visited: the indices of the places visited (or seen) in this tour.
        goal: the index of the place it drives to, or None.
    """

    def __init__(self, grid: PlanningGrid, spacing: float, clearance: float,
                 sight: float) -> None:
        self.grid, self.spacing, self.clearance, self.sight = grid, spacing, clearance, sight
        self._places: Optional[np.ndarray] = None
        self.visited: List[int] = []
        self.goal: Optional[int] = None
        self._looked = -math.inf   # when it last looked over the places in view

    @property
    def places(self) -> np.ndarray:
        """The patrol places, (N, 2)."""
        if self._places is None:
            self._places = patrol_points(self.grid, self.spacing, self.clearance)
        return self._places

    def next(self, x: float, y: float) -> Tuple[int, float, float]:
        """The nearest place to (x, y) not visited in this tour (a new tour when all are,
        but not the place it stands at), marked visited and made the goal: (index, x, y).
        There must be places."""
        places = self.places
        d = np.hypot(places[:, 0] - x, places[:, 1] - y)
        if len(self.visited) >= len(places):
            self.visited = []
            self.been_at(x, y)      # a new tour, but not the place it stands at
            if len(self.visited) >= len(places):
                self.visited = []
        d[self.visited] = np.inf
        k = int(np.argmin(d))
        self.visited.append(k)
        self.goal = k
        return k, float(places[k, 0]), float(places[k, 1])

    def been_at(self, x: float, y: float) -> None:
        """Mark the places within 1 m of (x, y) visited (it has looked round there)."""
        places = self.places
        near = np.flatnonzero(np.hypot(places[:, 0] - x, places[:, 1] - y) < 1.0)
        self.visited.extend(int(k) for k in near if int(k) not in self.visited)

    def look_over(self, t: float, pose: Sequence[float]) -> None:
        """Mark the places in view from ``pose`` (x, y, yaw) as visited, at most once a
        second."""
        if self.sight <= 0 or t - self._looked < 1.0:
            return
        self._looked = t
        places = self.places
        rx, ry, ryaw = (float(v) for v in pose[:3])
        d = np.hypot(places[:, 0] - rx, places[:, 1] - ry)
        ahead = np.abs(wrap_angles(np.arctan2(places[:, 1] - ry, places[:, 0] - rx) - ryaw))
        near = (d <= self.sight) & (ahead <= 0.5 * math.pi)
        near[self.visited] = False
        idx = np.flatnonzero(near)
        if len(idx):
            self.visited.extend(int(k) for k in idx[self.grid.in_sight(places[idx], (rx, ry))])


def in_view(observer: Sequence[float], laser_offset: Sequence[float], point: Sequence[float],
            fov: float, max_range: float) -> bool:
    """Whether ``point`` lies within a laser's field of view (radians, centred ahead) and range
    (occlusion not checked). ``laser_offset``: (x, y, yaw) of the laser in the base frame."""
    x, y, yaw = (float(v) for v in observer[:3])
    lx = x + math.cos(yaw) * laser_offset[0] - math.sin(yaw) * laser_offset[1]
    ly = y + math.sin(yaw) * laser_offset[0] + math.cos(yaw) * laser_offset[1]
    dx, dy = float(point[0]) - lx, float(point[1]) - ly
    if math.hypot(dx, dy) > max_range:
        return False
    return abs(wrap_angle(math.atan2(dy, dx) - yaw - laser_offset[2])) <= 0.5 * fov + 1e-9
