"""Where the observer looks: which track to follow (:func:`pick_target`), where to search for
a lost target (:func:`search_plan`, :func:`search_point`: the likely destinations' points),
where to patrol when those gave nothing (:func:`patrol_points`), where to wait for a target not
seen yet (:func:`watch_places`: the floor's crossroads), and whether a point is in the lidar's
view (:func:`in_view`). people/follow.FollowBehaviour and people/agents use them."""
from __future__ import annotations

import math
from typing import Callable, List, Mapping, Optional, Protocol, Sequence, Tuple, Union

import numpy as np

from ..geometry import wrap_angle
from ..nav.planner import PlanningGrid

__all__ = ["pick_target", "search_point", "search_plan", "patrol_points", "watch_places",
           "Watch", "in_view", "as_plan"]

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
    """Where to look for a lost target heading for a region: of the region's goal points
    (``points``, e.g. DestinationModel.goals), the one nearest to where it was last seen
    (``xy`` itself when the region has none)."""
    best, best_d = (float(xy[0]), float(xy[1])), math.inf
    for p in points:
        d = math.hypot(float(p[0]) - float(xy[0]), float(p[1]) - float(xy[1]))
        if d < best_d:
            best, best_d = (float(p[0]), float(p[1])), d
    return best


def search_plan(probabilities: Mapping[str, float], goals: Callable[[str], Points],
                xy: Sequence[float], count: int = 3, min_probability: float = 0.05,
                best: Optional[str] = None) -> List[Tuple[str, Tuple[float, float]]]:
    """Where to search for a lost target: the ``count`` most likely destination regions with
    probability at least ``min_probability`` (the most likely one always), most likely first
    (of equal ones ``best`` first, e.g. the predictor's arg-max, then by region id), each with
    its :func:`search_point` (``goals(region)``: the region's goal points) nearest to ``xy``,
    where the target was last seen."""
    ranked = sorted(probabilities.items(),
                    key=lambda kv: (-float(kv[1]), kv[0] != best, kv[0]))
    out = []
    for k, (region, p) in enumerate(ranked[:max(1, int(count))]):
        if k > 0 and float(p) < min_probability:
            break
        out.append((region, search_point(goals(region), xy)))
    return out


def as_plan(destination) -> List[Tuple[str, Tuple[float, float]]]:
    """``destination`` (None, one (region, (x, y)) pair, or a list of them) as a list."""
    if destination is None:
        return []
    if len(destination) == 2 and isinstance(destination[0], str):
        destination = [destination]
    return [(str(r), (float(p[0]), float(p[1]))) for r, p in destination]




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


def watch_places(grid: PlanningGrid, places: np.ndarray, count: int, spread: float,
                 sources: int = 24) -> np.ndarray:
    """The floor's crossroads among ``places`` ((N, 2) map points, e.g. :func:`patrol_points`):
    the ``count`` places that most shortest paths between the places pass near (within
    ``spread`` / 2), at least ``spread`` apart, busiest first, as an (M, 2) array. The paths run
    on the planner's graph from up to ``sources`` of the places (evenly chosen) to all of them;
    places off the graph are left out. Someone walking between rooms passes these most often."""
    from scipy.ndimage import maximum_filter
    from scipy.sparse.csgraph import dijkstra

    places = np.asarray(places, dtype=float).reshape(-1, 2)
    g, node = grid.graph()
    cells = [grid.to_cell(x, y) for x, y in places]
    ids = np.array([node[r, c] if grid.inside(c, r) else -1 for c, r in cells], dtype=int)
    places, ids = places[ids >= 0], ids[ids >= 0]
    if len(ids) == 0 or count <= 0:
        return np.zeros((0, 2))
    src = np.unique(np.linspace(0, len(ids) - 1, min(sources, len(ids))).round().astype(int))
    dist, pred = dijkstra(g, directed=False, indices=ids[src], return_predecessors=True)
    through = np.zeros(g.shape[0])
    for k in range(len(src)):
        cur = ids[np.isfinite(dist[k, ids])]
        while len(cur):                    # every path back to its source, one step a round
            np.add.at(through, cur, 1.0)
            cur = pred[k, cur]
            cur = cur[cur >= 0]
    image = np.where(node >= 0, through[np.maximum(node, 0)], 0.0)
    k = max(1, int(round(spread / 2.0 / grid.resolution)))
    busy = maximum_filter(image, size=2 * k + 1)
    score = np.array([busy[grid.to_cell(x, y)[::-1]] for x, y in places])
    chosen: List[int] = []
    for i in np.argsort(-score, kind="stable"):
        if all(math.hypot(*(places[i] - places[j])) >= spread for j in chosen):
            chosen.append(int(i))
            if len(chosen) >= count:
                break
    return places[chosen]


class Watch:
    """Waiting for a target not seen yet at ``places`` (:func:`watch_places`), in turn: go
    there, look round (turn ``turn`` radians), wait ``wait`` / 2 s, look round again, wait
    again, then on to the next place."""

    def __init__(self, places: np.ndarray, wait: float, turn: float) -> None:
        self.places = np.asarray(places, dtype=float).reshape(-1, 2)
        self.wait, self.turn = float(wait), float(turn)
        self.index, self.phase, self.since, self.looks = 0, "", 0.0, 0

    @property
    def done(self) -> bool:
        """Every place watched from."""
        return self.index >= len(self.places)

    def step(self, t: float, robot: Sequence[float], goal_done: bool
             ) -> Optional[Tuple[Optional[Tuple[float, float, float]], str]]:
        """While watching, (a new goal (x, y, yaw) or None to keep the current one, why);
        None once every place was watched from. ``goal_done``: the last goal finished."""
        if self.done:
            return None
        rx, ry, ryaw = (float(v) for v in robot[:3])
        if self.phase == "go" and goal_done:
            self.phase, self.looks = "look", self.looks + 1
            return (rx, ry, wrap_angle(ryaw + self.turn)), "at crossroads %d of %d: looking " \
                "round" % (self.index + 1, len(self.places))
        if self.phase == "look" and goal_done:
            self.phase, self.since = "wait", t
        if self.phase == "wait" and t - self.since >= self.wait / 2.0:
            if self.looks < 2:
                self.phase = "go"        # no move: the turn, then the wait again
                return self.step(t, robot, True)
            self.index, self.looks = self.index + 1, 0
            if self.done:
                return None
            self.phase = ""
        if self.phase == "":
            self.phase = "go"
            x, y = (float(v) for v in self.places[self.index])
            yaw = math.atan2(y - ry, x - rx) if math.hypot(x - rx, y - ry) > 1e-6 else ryaw
            return (x, y, yaw), "target not seen yet: waiting at the floor's crossroads %d " \
                "of %d (%.2f, %.2f)" % (self.index + 1, len(self.places), x, y)
        return None, ""


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
