"""The map check (``check_world``): what a footprint can reach on a world's floor.

For each footprint (the robot's, a person's) :func:`check_building` reports

* the floor it can plan on (cells where the disc fits), and for each start (a robot's spawn
  pose; for a person, the part of the floor most regions lie on) the share of that floor
  connected to it;
* which regions have a goal point in that part, which lie in another part, and which have no
  point with the goal clearance at all;
* the narrowest passage on the route between each pair of neighbouring regions (the chain's
  edges): the least width of the floor (to a map cell) along the cheapest path the planner gives,
  and where it is;

what each map-handling rule changed (sim/solidmap.py), and how the regions share the
floor: one region that is most of it (over :data:`ONE_REGION_SHARE` of their area) gets a
warning line, as a walk "to" it goes almost anywhere, and so does a robot that starts closer
to a wall than the footprint's radius (:meth:`WorldCheck.warnings`). :func:`study_problems`
turns the report into what would make a study degrade silently: a region the walker cannot
reach, an observer that cannot reach the walker's floor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
from shapely.geometry import Polygon

from ..data.rois import Roi
from ..people.walker import region_label
from . import Building, Footprint, person_footprint, robot_footprint

__all__ = ["Passage", "StartReach", "FootprintCheck", "WorldCheck", "check_building",
           "study_problems", "world_study_problems", "refusal", "robot_label", "FIXES",
           "ONE_REGION_SHARE"]

#: Above this share of the regions' area, one region is most of the building: a warning.
ONE_REGION_SHARE = 0.5

#: What a user can do about a region or a start cut off, in the order worth trying.
FIXES = ("remove furniture specks from the map (world.yaml clean: {speckle: 0.05}, in m^2)",
         "close one-cell slits (clean: {close_gaps: ...})",
         "a smaller footprint (the planner's robot_radius)",
         "move the robot's start pose, or the region, onto the connected floor")


@dataclass
class Passage:
    """The route between two neighbouring regions: ``width`` (m, the floor's least width
    along it; 0 when there is no route) at ``at`` (x, y; None: no route)."""

    a: str
    b: str
    width: float
    at: Optional[Tuple[float, float]]
    path: Optional[np.ndarray] = field(default=None, repr=False)
    no_route: bool = False              # the footprint cannot pass: ``at`` is where it narrows

    def describe(self) -> str:
        if self.at is None:
            return "no route"
        return "%s%.2f m wide at (%.1f, %.1f)" % ("blocked: narrows to " if self.no_route else "",
                                                   self.width, self.at[0], self.at[1])


@dataclass
class StartReach:
    """What one start reaches: its part of the floor (``area``, m^2; ``share`` of the floor
    the footprint can plan on), and the region ids in it and not."""

    name: str
    xy: Tuple[float, float]
    component: int
    area: float
    share: float
    reachable: List[str]
    unreachable: List[str]
    wall: float = math.inf              # m from the start to the nearest solid cell (robots)

    def too_close(self, radius: float) -> str:
        """The warning for a start closer to a wall than ``radius``."""
        return ("%s at (%.2f, %.2f) starts %.2f m from a wall, inside its %.2f m footprint "
                "radius: if the robot's body overlaps the wall, the simulator refuses to spawn "
                "it; give it room" % (self.name, self.xy[0], self.xy[1], self.wall, radius))


@dataclass
class FootprintCheck:
    """One footprint's report."""

    footprint: Footprint
    passable: float                     # m^2 where the disc fits
    starts: List[StartReach]
    no_goal: List[str]                  # regions with no point of the goal clearance
    passages: List[Passage]
    component_mask: Optional[np.ndarray] = field(default=None, repr=False)


@dataclass
class WorldCheck:
    """The whole report of one world."""

    world: str
    path: str
    free: float                         # m^2 of floor that is not solid
    handling: List[str]                 # one line per change the map handling made
    regions: Dict[str, str]             # id -> label
    footprints: List[FootprintCheck]
    region_areas: Dict[str, float] = field(default_factory=dict)   # id -> polygon area, m^2

    def lines(self) -> List[str]:
        """The report as text, one fact a line."""
        out = ["world %s (%s): %.0f m^2 of floor not solid" % (self.world, self.path, self.free)]
        out += ["map handling: %s" % h for h in self.handling] or ["map handling: changed nothing"]
        out += self._region_lines()
        for fc in self.footprints:
            fp = fc.footprint
            out.append("%s footprint (radius %.2f m, goals %.2f m from walls): %.0f m^2 to plan "
                       "on" % (fp.name, fp.radius, fp.clearance, fc.passable))
            for s in fc.starts:
                out.append("  from %s at (%.1f, %.1f): %.0f m^2 connected (%.0f %%); regions "
                           "reached %d of %d%s" % (
                               s.name, s.xy[0], s.xy[1], s.area, 100 * s.share,
                               len(s.reachable), len(self.regions),
                               "" if not s.unreachable else
                               "; cut off: " + ", ".join(self._names(s.unreachable))))
                if s.wall < fp.radius:
                    out.append("  warning: %s" % s.too_close(fp.radius))
            if fc.no_goal:
                out.append("  no goal point in: " + ", ".join(self._names(fc.no_goal)))
            for p in sorted(fc.passages, key=lambda p: p.width):
                out.append("  passage %s - %s: %s" % (self.regions[p.a], self.regions[p.b],
                                                     p.describe()))
        return out

    def largest_region(self) -> Tuple[str, float]:
        """The largest region's id and its share of all regions' area ("", 0 without any)."""
        total = sum(self.region_areas.values())
        if not total:
            return "", 0.0
        rid = max(self.region_areas, key=lambda i: self.region_areas[i])
        return rid, self.region_areas[rid] / total

    def one_region_warning(self) -> str:
        """A warning when one region is over ONE_REGION_SHARE of the regions' area ("" if
        not)."""
        rid, share = self.largest_region()
        if share <= ONE_REGION_SHARE + 1e-9 or len(self.region_areas) < 2:   # float noise
            return ""
        return ("region %s is %.0f %% of the regions' area: a walk to it may end almost "
                "anywhere, so predicting it says little. With rois: auto, rooms joined by "
                "openings at least rooms.max_door_width wide merge: set it above their width "
                "(world.yaml rooms: {max_door_width: 4.0}, docs/rooms.md), or draw the regions"
                % (self._names([rid])[0], 100 * share))

    def warnings(self) -> List[str]:
        """What the report warns of: robot starts closer to a wall than the footprint's
        radius, and one region that is most of the building."""
        fc = self.footprint("robot")
        out = [s.too_close(fc.footprint.radius) for s in fc.starts
               if s.wall < fc.footprint.radius]
        region = self.one_region_warning()
        return out + ([region] if region else [])

    def _region_lines(self) -> List[str]:
        rid, share = self.largest_region()
        if not rid:
            return []
        warning = self.one_region_warning()
        return (["regions: %d; the largest, %s, is %.0f m^2, %.0f %% of their area"
                 % (len(self.region_areas), self._names([rid])[0], self.region_areas[rid],
                    100 * share)]
                + (["  warning: " + warning] if warning else []))

    def _names(self, ids: Sequence[str]) -> List[str]:
        return ['"%s" (%s)' % (i, self.regions[i]) for i in ids]

    def footprint(self, name: str) -> FootprintCheck:
        return next(fc for fc in self.footprints if fc.footprint.name == name)


def check_building(b: Building, robots: Optional[Sequence[str]] = None) -> WorldCheck:
    """The report of a building (see the module doc) for its robots (all of them, or those
    named) and a person."""
    rois, _ = b.regions()
    specs = [r for r in b.config.robots if robots is None or r.name in robots]
    starts = [(robot_label(r), (float(r.pose[0]), float(r.pose[1]))) for r in specs]
    fps = [_footprint_check(b, robot_footprint(), rois, starts)]
    fps.append(_footprint_check(b, person_footprint(b.config), rois, []))
    solid = b.solid
    free = float((np.asarray(solid.fmap.grid) == 0).sum()) * b.fmap.resolution ** 2
    return WorldCheck(b.name, b.config.path, free, list(solid.report),
                      {r.id: region_label(r) for r in rois}, fps,
                      {r.id: float(Polygon(r.vertices).area) for r in rois})


def _footprint_check(b: Building, fp: Footprint, rois: List[Roi],
                     starts: List[Tuple[str, Tuple[float, float]]]) -> FootprintCheck:
    sampler = b.sampler(fp)
    grid = sampler.grid
    cell = grid.resolution ** 2
    area = np.bincount(sampler.labels.ravel()).astype(float) * cell
    area[0] = 0.0
    passable = float(area.sum())
    comps = {r.id: set(int(v) for v in sampler.cells_in(r)[2]) for r in rois}
    no_goal = [i for i, s in comps.items() if not s]
    robots = bool(starts)
    if not starts:   # a person starts where most regions are (walkable_regions' main part)
        counts: Dict[int, int] = {}
        for s in comps.values():
            for k in s:
                counts[k] = counts.get(k, 0) + 1
        if counts:
            main = max(counts, key=lambda k: (counts[k], area[k]))
            r, c = np.argwhere(sampler.labels == main)[0]
            starts = [("the regions' floor", grid.to_world(c, r))]
    reach = []
    for name, xy in starts:
        k = sampler.component_at(*xy)
        got = [i for i, s in comps.items() if k and k in s]
        reach.append(StartReach(name, xy, k, float(area[k]) if k else 0.0,
                                float(area[k]) / passable if k and passable else 0.0, got,
                                [i for i, s in comps.items() if s and i not in got],
                                _wall_distance(b, xy) if robots else math.inf))
    mask = np.isin(sampler.labels, [s.component for s in reach if s.component])
    return FootprintCheck(fp, passable, reach, no_goal, _passages(b, sampler, rois, comps),
                          mask)


def _wall_distance(b: Building, xy: Tuple[float, float], search: float = 1.0) -> float:
    """m from the point (x, y) to the nearest solid cell (its square) within ``search`` m;
    inf when none is that near."""
    fmap = b.solid.fmap
    res = fmap.resolution
    cells = fmap.world_to_cell(*xy)
    col, row, k = int(cells[0]), int(cells[1]), int(math.ceil(search / res))
    r0, c0 = max(0, row - k), max(0, col - k)
    rows, cols = np.nonzero(np.asarray(fmap.grid)[r0:row + k + 1, c0:col + k + 1] == 100)
    if not len(rows):
        return math.inf
    cx, cy = fmap.cell_to_world(cols + c0, rows + r0)
    yaw = fmap.origin[2]
    dx, dy = xy[0] - cx, xy[1] - cy       # to each cell's centre, turned into the grid's axes
    du = np.abs(math.cos(yaw) * dx + math.sin(yaw) * dy) - res / 2.0
    dv = np.abs(-math.sin(yaw) * dx + math.cos(yaw) * dy) - res / 2.0
    return float(np.hypot(np.maximum(du, 0.0), np.maximum(dv, 0.0)).min())


#: The disc radius (m) of the fallback route that shows where a cut-off region's way narrows.
THIN = 0.05


def _passages(b: Building, sampler, rois: List[Roi], comps: Dict[str, set]) -> List[Passage]:
    """The narrowest passage between each pair of neighbouring regions (the chain's rule):
    the cheapest path between their roomiest goal points (one Dijkstra per region over the
    planner's graph), and where the floor along it is narrowest (to a map cell). A pair the
    footprint cannot pass between gets the route of a THIN disc instead, with ``no_route``:
    where the way is too narrow for it."""
    from ..people.markov import MarkovChain

    if len(rois) < 2:
        return []
    chain = MarkovChain.from_rois(rois)
    pairs = sorted({(min(i, j), max(i, j)) for i in chain.ids for j in chain.neighbours(i)})
    best = {}  # type: Dict[str, Tuple[float, float]]
    for roi in rois:   # the region's goal point with most clearance
        x, y, _ = sampler.cells_in(roi)
        if len(x):
            k = int(np.argmax(sampler.grid.clearance_along(np.column_stack([x, y]))))
            best[roi.id] = (float(x[k]), float(y[k]))
    out = _routes(sampler.grid, pairs, best)
    cut = [(p.a, p.b) for p in out if p.at is None]
    if cut:
        thin = {(p.a, p.b): p for p in _routes(b.grid(THIN), cut, _centres(rois))}
        for p in out:
            q = thin.get((p.a, p.b))
            if q is not None and q.at is not None:
                p.width, p.at, p.path, p.no_route = q.width, q.at, q.path, True
    return out


def _centres(rois: List[Roi]) -> Dict[str, Tuple[float, float]]:
    """A point inside each region (its polygon's representative point)."""
    from ..data.rois import roi_polygon

    out = {}
    for r in rois:
        p = roi_polygon(r).representative_point()
        out[r.id] = (float(p.x), float(p.y))
    return out


def _routes(grid, pairs: Sequence[Tuple[str, str]],
            at: Dict[str, Tuple[float, float]]) -> List[Passage]:
    """The cheapest route on ``grid`` between the points of each pair, as Passages."""
    from scipy.sparse.csgraph import dijkstra

    graph, node = grid.graph()
    cells = {}
    for i, xy in at.items():
        c = grid.free_cell_near(*xy)
        if c is not None:
            cells[i] = int(node[c[1], c[0]])
    valid = np.flatnonzero(node.ravel() >= 0)   # node id -> flat cell index
    out = []
    for a in sorted({p[0] for p in pairs}):
        pred = None
        if a in cells:
            _, pred = dijkstra(graph, directed=False, indices=cells[a],
                               return_predecessors=True)
        for _, t in [p for p in pairs if p[0] == a]:
            u = cells.get(t, -9999)
            if pred is None or u < 0 or (u != cells[a] and pred[u] < 0):
                out.append(Passage(a, t, 0.0, None))
                continue
            nodes = [u]
            while pred[nodes[-1]] >= 0:
                nodes.append(int(pred[nodes[-1]]))
            flat = valid[np.array(nodes[::-1])]
            rows, cols = flat // grid.width, flat % grid.width
            clear = grid.roomiest(cols, rows)
            k = int(np.argmin(clear))
            path = np.array([grid.to_world(c, r) for c, r in zip(cols, rows)])
            out.append(Passage(a, t, 2.0 * max(0.0, float(clear[k])),
                               (float(path[k, 0]), float(path[k, 1])), path))
    return out


def study_problems(report: WorldCheck, walker: str, observer: Optional[str]) -> List[str]:
    """Why a study of ``walker`` (observed by ``observer``) would degrade: regions the
    walker cannot reach (with the narrowest passage on their way), fewer than two it can, an
    observer on another part of the floor. Empty when there is nothing."""
    fc = report.footprint("robot")
    starts = {s.name: s for s in fc.starts}
    w = starts[walker]
    out = []
    if w.unreachable:
        cut = []
        for i in w.unreachable:
            # the way in that is too narrow (a passage from a reached region), widest first
            ways = [p for p in fc.passages if i in (p.a, p.b) and p.no_route
                    and ({p.a, p.b} - {i}) <= set(w.reachable)]
            way = max(ways, key=lambda p: p.width) if ways else None
            cut.append('"%s" (%s)%s' % (i, report.regions[i], "" if way is None else
                                        " (its widest way in: %s)" % way.describe()))
        out.append("%s at (%.1f, %.1f) cannot reach region(s) %s: they lie on another part of "
                   "the floor than its start for a %.2f m wide footprint"
                   % (walker, w.xy[0], w.xy[1], ", ".join(cut), 2 * fc.footprint.radius))
    if fc.no_goal:
        out.append("region(s) %s have no point %.2f m from every wall for %s"
                   % (", ".join('"%s" (%s)' % (i, report.regions[i]) for i in fc.no_goal),
                      fc.footprint.clearance, walker))
    if len(report.regions) < 2:
        out.append("the world has %d region(s) in all%s: a walk between regions needs 2; draw "
                   "more (a rois file; with rois: auto, only parts of the floor that doorways "
                   "close off and the robot reaches are rooms: copy the ROI file it wrote and "
                   "edit it in rviz, docs/rooms.md)"
                   % (len(report.regions), "".join(' ("%s")' % i for i in report.regions)))
    elif len(w.reachable) < 2:
        out.append("%s reaches %d region(s) (%s): a walk between regions needs 2"
                   % (walker, len(w.reachable), ", ".join(w.reachable) or "none"))
    if observer is not None and observer in starts:
        o = starts[observer]
        if o.component != w.component:
            out.append("%s at (%.1f, %.1f) starts on a part of the floor (%.0f m^2) that %s's "
                       "(%.0f m^2) is not connected to: it can never reach the walker"
                       % (observer, o.xy[0], o.xy[1], o.area, walker, w.area))
    return out


def robot_label(spec) -> str:
    """A robot's name in the report ("robot" for the empty name of a one-robot world)."""
    return spec.name or "robot"


def world_study_problems(report: WorldCheck, config, walker: int = 0,
                         observer: int = 1) -> List[str]:
    """:func:`study_problems` for a world's robots by index (the first walks, the second
    observes, as the demo and the evaluation run them); a world without a robot is one."""
    names = [robot_label(r) for r in config.robots]
    if walker >= len(names):
        return ["the world has no robot %d (it has %d)" % (walker, len(names))]
    return study_problems(report, names[walker], names[observer] if observer < len(names)
                          else None)


def refusal(what: str, problems: Sequence[str], allow: str) -> str:
    """The one-line error of a study that :func:`study_problems` says would degrade:
    ``what`` (who refuses, which world), the problems, :data:`FIXES`, and ``allow`` (how the
    user lets it go on anyway: ``--allow-unreachable``, ``allow_unreachable:=true``)."""
    return "%s: %s. Fixes: %s; or allow it with %s" % (what, "; ".join(problems),
                                                       "; ".join(FIXES), allow)
