"""The Markov walker's decisions, without ROS, by the seed project's rule.

A stand-in human wanders between regions of interest: from the region it is in, it draws the
next region from the :class:`~bullet_floor_sim.people.markov.MarkovChain`, drives to a random
point well inside that region, dwells there a random time, and repeats. This module decides
*where* and *how long*; ``bullet_floor_sim.ros.markov_walker`` talks to move_base.

* :class:`RegionIndex`: which region a pose is in (exactly :func:`~.rois.roi_at`'s answer:
  boundary included, the smallest region when several contain the point), fast for many ROIs.
* :class:`GoalSampler`: a uniformly random point at least ``margin`` inside a region's polygon,
  with at least ``clearance`` to every wall on the map, on the same free-space component as
  the robot (so the planner can reach it; 4-connected components of the planner's free cells
  are exactly what its 8-connected A* without corner cutting reaches).
* :class:`Walker`: the leg loop's bookkeeping: seeded random streams (regions, goal points,
  dwell times are drawn from separate streams of one seed), leg numbers, one log line per leg,
  the retry back-off after failures, the regions visited.

A "stay" transition (P(i -> i), the seed rule's candidate i) is a leg too: the walker moves to
another point of the same region, as a person moves about their office.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Set, Tuple

import numpy as np

from ..errors import BulletFloorSimError
from ..sim.checks import check_integers, check_numbers
from .markov import MarkovChain
from ..nav.planner import PlanError, PlanningGrid, path_length
from ..data.rois import Roi, RoiError, random_point_inside, roi_polygon

__all__ = [
    "WalkerError",
    "WalkerConfig",
    "RegionIndex",
    "GoalSampler",
    "Leg",
    "Walker",
    "region_label",
    "anchor",
]

#: Outcomes of a leg, as :meth:`Walker.finish` takes them.
OUTCOMES = ("succeeded", "aborted", "timeout", "rejected", "preempted", "lost")


class WalkerError(BulletFloorSimError):
    """The walker cannot go on: no region, no reachable goal, or bad parameters."""


@dataclass
class WalkerConfig:
    """Walker parameters (times in sim seconds, distances in metres).

    Attributes:
        goal_timeout: a leg not finished after this long is cancelled and counts as failed.
            The seed used 30 s, which the longest legs of the office world need already
            (14 m of planned path between adjacent regions: about 25 s at the robot's 0.6 m/s
            plus turns; 22 s measured) with no room for waiting behind the other robot. The
            default, 120 s, leaves that room and suits larger regions elsewhere; a robot that
            is really stuck is given up by the navigation first (the embedded follower aborts
            after 30 s blocked or 60 s without progress).
        timeout_per_m: a leg gets at least this many seconds per metre of its planned path
            (the robot's 0.6 m/s, with room to wait): 120 s is too short for a leg across a
            140 m hall (a third of edmonton_convention's legs timed out). The crow's
            distance would cut short a leg whose route goes round walls. A leg whose robot
            drives further than its planned way (the long way round a robot that blocks a
            corridor) gets timeout_per_m more seconds for each metre beyond it, up to
            ``max_extension`` times its limit more (people/agents.WalkerAgent): on mit_csail
            the walker, blocked by the observer 6.5 m from its goal, went 55 m round a loop
            and was cut off at 120 s just short of it.
        max_extension: see timeout_per_m.
        dwell_min, dwell_max: the dwell after a reached goal is uniform in [min, max].
        margin: a goal keeps at least this distance from its region's boundary.
        clearance: a goal keeps at least this distance from every wall (the robot's radius,
            0.34 m for the Scitos A5, plus a little).
        goal_tries: random draws per region before it counts as having no acceptable point.
        max_picks: regions drawn per leg before the walker gives up on this leg.
        min_stay_move: a stay leg (to the region the walker is in) goes to a point at least
            this far (m) from where it stands; from a region with no such point the walker
            leaves by the chain's other transitions (one with none keeps short stays). 0 (the
            default): any stay, as the chain has it. The evaluation leaves legs that hardly
            move unscored instead (EvalConfig.min_leg_path), which keeps the walks as they were:
            with 1 m, seed 2's walks changed and so did its figures, both ways, by up to
            30 points a world (edmonton_convention tracked 92 -> 58 %).
        retry_delay: wait after the first failed leg in a row; doubled for each further
            failure, up to ``max_retry_delay``.
    """

    goal_timeout: float = 120.0
    timeout_per_m: float = 8.0
    max_extension: float = 2.0
    dwell_min: float = 5.0
    dwell_max: float = 20.0
    margin: float = 0.5
    clearance: float = 0.45
    goal_tries: int = 300
    max_picks: int = 10
    min_stay_move: float = 0.0
    retry_delay: float = 1.0
    max_retry_delay: float = 30.0

    def check(self) -> None:
        """Raise WalkerError naming the first bad parameter."""
        check_numbers(self, ("goal_timeout", "timeout_per_m", "retry_delay", "max_retry_delay"),
                      "walker", error=WalkerError, unit="seconds")
        check_numbers(self, ("dwell_min", "dwell_max", "margin", "clearance", "max_extension",
                             "min_stay_move"), "walker", strict=False, error=WalkerError)
        if self.dwell_max < self.dwell_min:
            raise WalkerError("walker: dwell_max (%g s) must be >= dwell_min (%g s)"
                              % (self.dwell_max, self.dwell_min))
        check_integers(self, ("goal_tries", "max_picks"), "walker", error=WalkerError)


# --------------------------------------------------------------------------------------------
# regions
# --------------------------------------------------------------------------------------------


def region_label(roi: Roi) -> str:
    """How a region is named in log lines: "office 7", or the id alone when it already says
    what the region is ("office_3")."""
    if roi.id.lower().startswith(roi.type.lower()):
        return roi.id
    return "%s %s" % (roi.type, roi.id)


def anchor(roi: Roi) -> Tuple[float, float]:
    """Where a region is drawn: its centroid, or a point inside when the centroid is not."""
    poly = roi_polygon(roi)
    c = poly.centroid
    if not poly.contains(c):
        c = poly.representative_point()
    return (float(c.x), float(c.y))


class RegionIndex:
    """Point-in-region queries over many ROIs (an STRtree over the polygons).

    :meth:`region_at` gives exactly what ``roi_at(rois, x, y)`` gives: the ROI whose polygon
    covers the point (boundary included), the smallest by area when several do, the first in
    list order on a tie.
    """

    def __init__(self, rois: Sequence[Roi]) -> None:
        from shapely.strtree import STRtree

        self.rois = list(rois)
        import shapely

        self._polys = [roi_polygon(r) for r in self.rois]
        for poly in self._polys:   # the point tests of every tick, on an index of the edges
            shapely.prepare(poly)
        self._areas = [p.area for p in self._polys]
        self._tree = STRtree(self._polys) if self._polys else None
        self.by_id = {r.id: r for r in self.rois}

    def roi_at(self, x: float, y: float) -> Optional[Roi]:
        """The ROI containing (x, y), or None."""
        from shapely.geometry import Point

        if self._tree is None or not (math.isfinite(x) and math.isfinite(y)):
            return None
        pt = Point(float(x), float(y))
        best, best_area = None, math.inf
        for k in sorted(int(k) for k in self._tree.query(pt)):
            if self._areas[k] < best_area and self._polys[k].covers(pt):
                best, best_area = k, self._areas[k]
        return None if best is None else self.rois[best]

    def region_at(self, x: float, y: float) -> str:
        """The id of the region containing (x, y); "" when it is in none."""
        roi = self.roi_at(x, y)
        return "" if roi is None else roi.id

    def nearest(self, x: float, y: float) -> Optional[Roi]:
        """The region containing (x, y), else the one whose boundary is nearest (None if no
        regions)."""
        from shapely.geometry import Point

        roi = self.roi_at(x, y)
        if roi is not None or not self.rois:
            return roi
        pt = Point(float(x), float(y))
        k = min(range(len(self.rois)), key=lambda i: self._polys[i].distance(pt))
        return self.rois[k]


# --------------------------------------------------------------------------------------------
# goals
# --------------------------------------------------------------------------------------------


class GoalSampler:
    """Random goals well inside a region, free and reachable on the inflated map.

    Args:
        grid: the planner's grid over the map (its ``cost`` is finite where the robot fits;
            its ``clearance`` is the wall distance of each cell's centre).
        clearance: minimum wall distance of a goal (metres, >= the grid's robot radius).
        margin: minimum distance of a goal from its region's boundary.
        goal_tries: random draws per region.
    """

    def __init__(self, grid: PlanningGrid, clearance: float = 0.45, margin: float = 0.5,
                 goal_tries: int = 300) -> None:
        from scipy.ndimage import label

        self.grid = grid
        self.clearance = max(float(clearance), grid.config.robot_radius)
        self.margin = float(margin)
        self.goal_tries = int(goal_tries)
        passable = np.isfinite(grid.cost)
        self.labels, self.components = label(passable)  # 4-connected
        self.ok = passable & (grid.clearance >= self.clearance)

    def component_at(self, x: float, y: float, search: float = 1.0) -> int:
        """The free-space component of (x, y), or of the nearest passable cell within
        ``search`` metres (a robot pressed against a wall); 0 when there is none."""
        c, r = self.grid.to_cell(x, y)
        k = int(math.ceil(search / self.grid.resolution))
        r0, r1 = max(0, r - k), min(self.grid.height, r + k + 1)
        c0, c1 = max(0, c - k), min(self.grid.width, c + k + 1)
        if r0 >= r1 or c0 >= c1:
            return 0
        window = self.labels[r0:r1, c0:c1]
        rows, cols = np.nonzero(window)
        if not len(rows):
            return 0
        d2 = (rows + r0 - r) ** 2 + (cols + c0 - c) ** 2
        i = int(np.argmin(d2))
        return int(window[rows[i], cols[i]])

    def acceptable(self, x: float, y: float, component: int = 0) -> bool:
        """(x, y) has the clearance and, when ``component`` > 0, lies in that component."""
        c, r = self.grid.to_cell(x, y)
        if not self.grid.inside(c, r) or not self.ok[r, c]:
            return False
        return component <= 0 or int(self.labels[r, c]) == component

    def sample(self, roi: Roi, rng: np.random.Generator,
               start: Optional[Sequence[float]] = None,
               avoid: Optional[Tuple[float, float, float]] = None,
               away: float = 0.0) -> Tuple[float, float]:
        """A goal in ``roi``, reachable from ``start`` (x, y) when given, at least r from
        (x, y) when ``avoid`` is (x, y, r) (a spot someone stands on), and at least ``away``
        from ``start``.

        A region narrower than twice the margin gets goals with half the margin, then none.

        Raises:
            RoiError: no acceptable point was drawn (the message names the region and why).
        """
        component = self.component_at(start[0], start[1]) if start is not None else 0
        ax, ay, ar = avoid if avoid is not None else (0.0, 0.0, 0.0)
        sx, sy = (float(start[0]), float(start[1])) if start is not None else (0.0, 0.0)
        away = away if start is not None else 0.0
        error = None
        for margin in (self.margin, self.margin / 2.0, 0.0):
            try:
                return random_point_inside(
                    roi, rng, margin=margin, max_tries=self.goal_tries,
                    is_free=lambda x, y: (self.acceptable(x, y, component)
                                          and math.hypot(x - ax, y - ay) >= ar
                                          and math.hypot(x - sx, y - sy) >= away))
            except RoiError as e:
                error = e
                if "no point lies" not in str(e):
                    break  # wide enough, but nothing free and reachable in it
        # a cluttered region whose acceptable part is too small for rejection sampling: draw
        # one of its acceptable cell centres (exact, but only to the planning grid's cells)
        x, y, comp = self.cells_in(roi)
        pick = np.flatnonzero(((comp == component) if component > 0 else True)
                              & (np.hypot(x - ax, y - ay) >= ar)
                              & (np.hypot(x - sx, y - sy) >= away)
                              & (self._inner(roi, x, y) if away > 0 else True))
        if len(pick):
            k = int(pick[rng.integers(len(pick))])
            return float(x[k]), float(y[k])
        # here no acceptable cell of the region is in the robot's component: if it has any,
        # they lie in another one
        unreachable = component > 0 and len(comp) > 0 and not (comp == component).any()
        near = (["%.1f m of a spot taken" % ar] if ar > 0 else []) + (
            ["%.1f m of where it stands" % away] if away > 0 else [])
        why = (" (its free space is not connected to the robot's)" if unreachable else
               " (the rest is within %s)" % " or ".join(near) if near and len(comp) else "")
        raise RoiError("%s%s" % (error, why))

    def _inner(self, roi: Roi, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Which points are at least half the margin inside the region (a stay's goal from
        the cells would otherwise lie at its edge, often the doorway to the next region)."""
        import shapely

        if not len(x):
            return np.zeros(0, dtype=bool)
        edge = roi_polygon(roi).exterior
        return np.asarray(shapely.distance(edge, shapely.points(x, y))) >= self.margin / 2.0

    def cells_in(self, roi: Roi) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The acceptable planning-cell centres inside a region: (x, y, component) arrays."""
        import shapely

        grid = self.grid
        poly = roi_polygon(roi)
        shapely.prepare(poly)   # an index of its edges: 0.75 s -> ms for a big hall's room
        xmin, ymin, xmax, ymax = poly.bounds
        c0, r0 = grid.to_cell(xmin, ymin)
        c1, r1 = grid.to_cell(xmax, ymax)
        cs = np.arange(max(0, min(c0, c1)), min(grid.width, max(c0, c1) + 1))
        rs = np.arange(max(0, min(r0, r1)), min(grid.height, max(r0, r1) + 1))
        cc, rr = np.meshgrid(cs, rs)
        ok = self.ok[rr, cc]
        cc, rr = cc[ok], rr[ok]
        k = grid.factor  # planning cell centres, as PlanningGrid.to_world gives them
        x, y = grid.fmap.cell_to_world((cc + 0.5) * k - 0.5, (rr + 0.5) * k - 0.5)
        x, y = np.atleast_1d(x), np.atleast_1d(y)
        inside = (shapely.covers(poly, shapely.points(x, y)) if len(cc)
                  else np.zeros(0, dtype=bool))
        return x[inside], y[inside], self.labels[rr[inside], cc[inside]]


# --------------------------------------------------------------------------------------------
# legs
# --------------------------------------------------------------------------------------------


@dataclass
class Leg:
    """One move from the region the robot is in to the region drawn from the chain.

    Attributes:
        number: 1, 2, ... in the order the legs started.
        start_region: where the robot was when the leg started ("" when in no region).
        target_region: the region drawn from the chain.
        goal: (x, y, yaw) sent to move_base, map frame.
        started: sim time the goal was sent.
        ended: sim time the leg finished (None while it runs).
        outcome: one of OUTCOMES (None while it runs).
        detail: why it failed (move_base's text, the timeout).
        end_region: where the robot was when the leg finished.
        regoals: new goals the leg was given in its region (people/agents.WalkerAgent).
        timeout: seconds after which it is cancelled (goal_timeout, or timeout_per_m times
            the way to its goal when longer), before the extension for a longer way driven
            (people/agents.WalkerAgent).
        way: metres of planned path from its start to its goal when it started.
        driven: metres the robot has driven on it so far (people/agents.WalkerAgent).
    """

    number: int
    start_region: str
    target_region: str
    goal: Tuple[float, float, float]
    started: float
    ended: Optional[float] = None
    outcome: Optional[str] = None
    detail: str = ""
    end_region: str = ""
    regoals: int = 0
    timeout: float = 0.0
    way: float = 0.0
    driven: float = 0.0

    @property
    def duration(self) -> float:
        """Seconds from goal to outcome (0 while running)."""
        return 0.0 if self.ended is None else self.ended - self.started

    def to_dict(self) -> Dict[str, Any]:
        """The leg as plain data (for a JSON topic or a log)."""
        return {"leg": self.number, "from": self.start_region, "to": self.target_region,
                "goal": [round(v, 3) for v in self.goal], "started": self.started,
                "duration": round(self.duration, 3), "outcome": self.outcome,
                "detail": self.detail, "end_region": self.end_region, "regoals": self.regoals}


@dataclass
class Walker:
    """The walk: which region next, which goal, how long to dwell, what to log.

    Args:
        chain: the Markov chain over ``rois``.
        rois: the regions (the chain's ids must all be among them).
        sampler: goal sampler on the map.
        config: parameters.
        seed: one integer for the three random streams (regions, goals, dwell times); None
            draws one from the OS, below 2**31 so that it can be given back as ``~seed``
            (see ``seed_used``).
    """

    chain: MarkovChain
    rois: Sequence[Roi]
    sampler: GoalSampler
    config: WalkerConfig = field(default_factory=WalkerConfig)
    seed: Optional[int] = None
    legs: int = 0
    failures_in_a_row: int = 0
    visited: Set[str] = field(default_factory=set)
    log: List[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.config.check()
        if self.seed is None:  # a fresh seed small enough for a ROS int parameter (~seed)
            self.seed_used = int(np.random.SeedSequence().generate_state(1)[0]) & 0x7FFFFFFF
        else:
            self.seed_used = int(self.seed)
        streams = np.random.SeedSequence(self.seed_used).spawn(3)
        self.rng_region, self.rng_goal, self.rng_dwell = (np.random.default_rng(s)
                                                          for s in streams)
        self.set_regions(self.chain, self.rois)

    def set_regions(self, chain: MarkovChain, rois: Sequence[Roi]) -> None:
        """Use a rebuilt chain (the ROIs changed); the next leg draws from it.

        Raises:
            WalkerError: a region of the chain has no ROI.
        """
        index = RegionIndex(rois)
        missing = [r for r in chain.ids if r not in index.by_id]
        if missing:
            raise WalkerError("walker: chain regions without ROI: %s" % ", ".join(missing))
        self.chain, self.rois, self.index = chain, list(rois), index

    def label(self, region: str) -> str:
        """Log name of a region id ("none" for "")."""
        roi = self.index.by_id.get(region)
        return region_label(roi) if roi is not None else (region or "none")

    def region_at(self, x: float, y: float) -> str:
        """Region id at a map-frame point ("" when in none)."""
        return self.index.region_at(x, y)

    def origin_region(self, x: float, y: float) -> str:
        """The region a leg starts from: the one the robot is in, else the nearest one of the
        chain (the robot is in a doorway or outside every region)."""
        here = self.index.region_at(x, y)
        if here in self.chain.ids:
            return here
        roi = RegionIndex([self.index.by_id[r] for r in self.chain.ids]).nearest(x, y)
        if roi is None:
            raise WalkerError("walker: the chain has no regions")
        return roi.id

    def next_leg(self, pose: Sequence[float], now: float,
                 avoid: Optional[Tuple[float, float, float]] = None) -> Leg:
        """Draw the next region from the one the robot is in, and a goal inside it.

        A region without an acceptable goal is reported in ``log`` and another one is
        drawn, up to ``max_picks`` times.

        Args:
            pose: the robot's (x, y[, yaw]) in the map frame.
            now: sim time.
            avoid: (x, y, r): no goal within r of (x, y) (GoalSampler.sample).

        Raises:
            WalkerError: no region drawn had an acceptable goal.
        """
        x, y = float(pose[0]), float(pose[1])
        here = self.origin_region(x, y)
        problems = []
        stay = True     # a stay may be drawn (until it has no point far enough away)
        for k in range(self.config.max_picks + 1):
            target = self._draw(here, stay) if k < self.config.max_picks else None
            if target is None and stay:
                break
            # nothing but the stay left (a region the chain leaves for no other, or the other
            # regions drawn had no goal): a short stay rather than no leg at all
            away = self.config.min_stay_move if target == here else 0.0
            target = here if target is None else target
            try:
                gx, gy = self.sampler.sample(self.index.by_id[target], self.rng_goal, (x, y),
                                             avoid, away)
            except RoiError as e:
                if away:
                    self.log.append("no goal in %s for a stay %.1f m from where the walker "
                                    "stands (%s): drawn again without the stay"
                                    % (self.label(target), away, e))
                elif str(e) not in problems:
                    problems.append(str(e))
                    self.log.append("no goal in %s: %s" % (self.label(target), e))
                stay = stay and not away
                continue
            self.legs += 1
            yaw = math.atan2(gy - y, gx - x) if math.hypot(gx - x, gy - y) > 1e-6 else (
                float(pose[2]) if len(pose) > 2 else 0.0)
            cfg = self.config
            way = self._way((x, y), (gx, gy))
            return Leg(self.legs, self.index.region_at(x, y), target, (gx, gy, yaw), now,
                       timeout=max(cfg.goal_timeout, cfg.timeout_per_m * way), way=way)
        raise WalkerError("walker: no acceptable goal in the regions drawn from %s after %d "
                          "draws: %s" % (self.label(here), self.config.max_picks,
                                         "; ".join(problems)))

    def _draw(self, here: str, stay: bool) -> Optional[str]:
        """The next region after ``here`` by the chain; without ``stay``, by its row without
        the stay (renormalised; None when nothing else is left)."""
        if stay:
            return self.chain.sample_next(here, self.rng_region)
        row = {r: p for r, p in self.chain.row(here).items() if r != here}
        if not row:
            return None
        ids = sorted(row)
        p = np.array([row[r] for r in ids])
        return ids[int(self.rng_region.choice(len(ids), p=p / p.sum()))]

    def _way(self, start: Tuple[float, float], goal: Tuple[float, float]) -> float:
        """The planned path's length from ``start`` to ``goal`` on the sampler's grid (the
        walker's own navigation plans the same), or the crow's distance when it has none."""
        try:
            return path_length(self.sampler.grid.plan(start, goal))
        except PlanError:
            return math.hypot(goal[0] - start[0], goal[1] - start[1])

    def finish(self, leg: Leg, outcome: str, now: float, end_region: str,
               detail: str = "") -> str:
        """Record a leg's outcome and return its log line, e.g.
        ``leg 7: office 7 -> corridor 1 in 23.4 s``."""
        if outcome not in OUTCOMES:
            raise ValueError("unknown leg outcome %r (one of %s)" % (outcome, ", ".join(OUTCOMES)))
        leg.ended, leg.outcome, leg.detail, leg.end_region = now, outcome, detail, end_region
        route = "leg %d: %s -> %s" % (leg.number, self.label(leg.start_region),
                                      self.label(leg.target_region))
        if outcome == "succeeded":
            self.failures_in_a_row = 0
            self.visited.add(leg.target_region)
            line = "%s in %.1f s" % (route, leg.duration)
        else:
            self.failures_in_a_row += 1
            line = "%s %s after %.1f s%s (goal %.2f, %.2f; now in %s)" % (
                route, outcome, leg.duration, ": " + detail if detail else "", leg.goal[0],
                leg.goal[1], self.label(end_region))
        self.log.append(line)
        return line

    def dwell(self) -> float:
        """A dwell time, uniform in [dwell_min, dwell_max] (its own random stream)."""
        return float(self.rng_dwell.uniform(self.config.dwell_min, self.config.dwell_max))

    def retry_delay(self) -> float:
        """Wait before the next leg after failures: 0 after a success, then retry_delay,
        doubling for each further failure in a row, at most max_retry_delay."""
        if self.failures_in_a_row == 0:
            return 0.0
        return float(min(self.config.max_retry_delay,
                         self.config.retry_delay * 2.0 ** (self.failures_in_a_row - 1)))


# --------------------------------------------------------------------------------------------
# regions the walker can reach
# --------------------------------------------------------------------------------------------


def walkable_regions(rois: Sequence[Roi], sampler: GoalSampler) -> Tuple[List[Roi], List[str]]:
    """The regions with a goal point on the floor's main free-space component, and one
    warning per region left out.

    A goal point is a cell centre inside the region's polygon that the sampler accepts (the
    walker's clearance to every wall, on a passable cell). The main component is the one that
    holds goal points of the most regions (then the larger one): a room behind a door
    narrower than the walker's footprint, or a corner cut off by the planner's inflation, is
    another component. The answer depends only on the map and the ROIs, so the walker and the
    destination predictor leave out the same regions and build the same chain.
    """
    comps = [set(int(v) for v in sampler.cells_in(roi)[2]) for roi in rois]
    counts: Dict[int, int] = {}
    for s in comps:
        for k in s:
            counts[k] = counts.get(k, 0) + 1
    area = np.bincount(sampler.labels.ravel())
    main = max(counts, key=lambda k: (counts[k], area[k])) if counts else None
    kept, warnings = [], []
    for roi, s in zip(rois, comps):
        if main in s:
            kept.append(roi)
        elif not s:
            warnings.append('region "%s" (%s) has no point %.2f m from every wall: left out of '
                            "the walk" % (roi.id, region_label(roi), sampler.clearance))
        else:
            warnings.append('region "%s" (%s) cannot be reached: its free space is not '
                            "connected to the rest of the floor's (a passage narrower than the "
                            "walker's %.2f m footprint with clearance): left out of the walk"
                            % (roi.id, region_label(roi),
                               2 * sampler.grid.config.robot_radius))
    return kept, warnings


__all__ += ["walkable_regions"]
