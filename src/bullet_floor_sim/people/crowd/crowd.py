"""The crowd: every person's state, and one step of all of them.

Each person dwells at a goal point, then walks a leg to the next region its group's Markov
chain draws, along a path to that region (routes.py). The legs are decided by the robot
walker's own agent (people/agents.py's WalkerAgent: the same regions, goal points, dwell
times, timeout, new-goal rule and log lines), to which the crowd is the navigation: it tells
the agent a walk "succeeded" or was "aborted". The step, at the section's ``rate``:

1. legs start, end and are re-planned (a person pushed far off its path, or without
   progress for ``STUCK_AFTER`` seconds, gets a new path; one without progress for
   ``GIVE_UP_AFTER`` seconds gives the walk up: "aborted"); a party member sets off for its
   leader's goal when the leader does (groups.py);
2. each walking person steers at the point of its path ``LOOKAHEAD`` ahead, at its preferred
   speed, slowing within ``SLOW_WITHIN`` of the goal; the social forces (forces.py) of the
   walls, the people within the cutoff (found with a k-d tree) and the robots are added, and
   the velocity integrated;
3. a move that would bring a person's centre within ``MIN_CLEARANCE`` of a wall is cut to
   its slide along the wall, or refused: no one ever walks into or through a wall.

A person's legs, for the lidar, are two circles beside its centre that swing fore and aft
with the distance walked (``BodyConfig``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, List, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from ...data.rois import Roi, RoiError
from ...nav.grid import PlanError
from ..agents import WalkerAgent
from ..walker import WalkerError
from .config import BodyConfig
from .forces import ForceConfig, driving, limit_speed, repulsion, wall_repulsion
from .groups import SPACING, coherence
from .routes import Routes

__all__ = ["Person", "PersonTruth", "Crowd", "MIN_CLEARANCE"]

#: A person's centre never comes nearer a wall than this (m): its hips.
MIN_CLEARANCE = 0.2
#: How far along its path a walking person steers at (m).
LOOKAHEAD = 0.8
#: A goal within this is reached (m); within SLOW_WITHIN the person slows down.
ARRIVE_WITHIN = 0.25
SLOW_WITHIN = 0.8
#: Farther than this from the point it steers at, a person gets a new path (m).
OFF_PATH = 2.0
#: Seconds without getting 0.5 m nearer the goal before a new path, and before giving up.
STUCK_AFTER = 8.0
GIVE_UP_AFTER = 20.0

Clearance = Callable[[np.ndarray], np.ndarray]


@dataclass
class Person:
    """One person's plan (the crowd keeps positions and velocities as arrays).

    Attributes:
        name: e.g. "person_3".
        agent: the leg decisions, people/agents.py's WalkerAgent as the robot walker uses
            it: the crowd is its navigation (None: the person walks only where
            ``Crowd.walk_to`` sends it).
        speed: preferred walking speed, m/s.
        state: "walk", or "idle" (dwelling, backing off, or arrived).
        path: the points walked along; ``k`` the one steered at.
        goal, roi: where the walk ends, and its region (None for a bare ``walk_to``).
        best, best_t: the nearest it has been to the goal, and when.
        replanned: it got a new path since it last came nearer.
        result: the walk's outcome for the agent, (outcome, detail), until it is told.
        leader, rank: a party member's leader (index) and its rank (1, 2, ...; groups.py);
            ``following`` is the leader's goal it walks to.
    """

    name: str
    agent: Optional[WalkerAgent]
    speed: float
    state: str = "idle"
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    k: int = 0
    goal: Optional[Tuple[float, float]] = None
    roi: Optional[Roi] = None
    best: float = math.inf
    best_t: float = 0.0
    replanned: bool = False
    result: Optional[Tuple[str, str]] = None
    leader: Optional[int] = None
    rank: int = 0
    following: Optional[Tuple[float, float]] = None


class PersonTruth(NamedTuple):
    """One person's ground truth (map frame, m, m/s, rad); ``goal_region`` is the region of
    the leg walked or last walked ("" before the first), ``region`` the one it is in ("":
    none, or not asked for)."""

    name: str
    track_id: int
    x: float
    y: float
    vx: float
    vy: float
    yaw: float
    state: str
    goal_region: str
    region: str = ""


class Crowd:
    """All people of a world, stepped together.

    Args:
        people: the people, in order (index i is row i of the arrays).
        start: (N, 2) where they stand.
        routes: paths to regions (and the grid whose clearance keeps them off the walls).
        body, forces: the people's bodies and the social-force parameters.
        rate: steps per second of sim time.
        now_ns: sim time (ns) now; the first step is due one period on.
    """

    def __init__(self, people: Sequence[Person], start: np.ndarray, routes: Routes,
                 body: BodyConfig, forces: ForceConfig, rate: float, now_ns: int) -> None:
        self.people = list(people)
        n = len(self.people)
        self.n = n
        self.pos = np.asarray(start, dtype=float).reshape(n, 2).copy()
        self.vel = np.zeros((n, 2))
        self.heading = np.zeros(n)
        self.phase = np.zeros(n)
        self.v0 = np.array([p.speed for p in self.people], dtype=float)
        self.radius = np.full(n, body.radius)
        self.routes = routes
        self.clearance: Clearance = routes.grid.clearance_along
        self.body, self.forces = body, forces
        self.period_ns = int(round(1e9 / rate))
        self.dt = self.period_ns * 1e-9
        self.next_ns = int(now_ns) + self.period_ns
        self.log: List[str] = []
        self._target = self.pos.copy()
        self._slow = np.ones(n)
        leaders = sorted({p.leader for p in self.people if p.leader is not None})
        self.parties = [np.array([k] + [i for i, p in enumerate(self.people) if p.leader == k])
                        for k in leaders]

    # ------------------------------------------------------------------------------ commands
    def walk_to(self, i: int, goal: Sequence[float], roi: Optional[Roi], now: float) -> None:
        """Send person i to ``goal``, in region ``roi`` (None: a point anywhere on the
        floor, planned with A*).

        Raises:
            PlanError: no path.
        """
        p = self.people[i]
        p.path = self._path(i, goal, roi)
        p.k, p.goal, p.roi, p.state = 0, (float(goal[0]), float(goal[1])), roi, "walk"
        p.best, p.best_t, p.replanned = math.inf, now, False

    # ------------------------------------------------------------------------------ stepping
    def advance(self, now_ns: int, robot_xy: np.ndarray, robot_radius: np.ndarray) -> None:
        """One step at sim time ``now_ns`` (the world calls it when ``next_ns`` is due)."""
        now = now_ns * 1e-9
        for i, p in enumerate(self.people):
            if p.agent is not None:
                self._decide(i, p, now)
            elif p.leader is not None:
                self._join(i, p, now)
            self._steer(i, p, now)
        self._move(np.asarray(robot_xy, dtype=float).reshape(-1, 2),
                   np.asarray(robot_radius, dtype=float).reshape(-1))
        self.next_ns = int(now_ns) + self.period_ns

    def _decide(self, i: int, p: Person, now: float) -> None:
        """Tell person i's agent how its walk went (if it ended) and act on its answer."""
        assert p.agent is not None
        result, p.result = p.result, None
        pose = (float(self.pos[i, 0]), float(self.pos[i, 1]), float(self.heading[i]))
        try:
            step = p.agent.tick(now, pose, result)
        except WalkerError as e:
            self.log.append("%s: %s" % (p.name, e))
            p.agent.resume_at = now + max(1.0, p.agent.walker.config.max_retry_delay)
            return
        self.log.extend("%s: %s" % (p.name, line) for line in step.notes + step.info
                        + [step.line] if line)
        if step.cancel:
            p.state = "idle"
        if step.start is not None:
            leg = step.start
            try:
                self.walk_to(i, leg.goal, p.agent.walker.index.by_id.get(leg.target_region), now)
            except (PlanError, RoiError) as e:
                p.state, p.result = "idle", ("aborted", str(e))

    def _join(self, i: int, p: Person, now: float) -> None:
        """A party member sets off for its leader's goal when the leader does."""
        lead = self.people[p.leader]   # type: ignore[index]
        if lead.state != "walk" or lead.goal is None or p.following == lead.goal:
            return
        p.following = lead.goal
        try:
            self.walk_to(i, lead.goal, lead.roi, now)
        except (PlanError, RoiError) as e:
            self.log.append("%s: cannot follow %s: %s" % (p.name, lead.name, e))

    def _steer(self, i: int, p: Person, now: float) -> None:
        """Where person i steers at (``_target``) and how fast (``_slow``); a walk that
        arrived or was given up ends here (its result goes to the agent)."""
        if p.state == "walk":
            self._follow(i, p, now)
        if p.state != "walk":
            self._target[i] = self.pos[i]
            self._slow[i] = 0.0
            if p.result is not None and p.agent is not None:
                self._decide(i, p, now)

    def _follow(self, i: int, p: Person, now: float) -> None:
        pos = self.pos[i]
        assert p.goal is not None
        remaining = math.hypot(p.goal[0] - pos[0], p.goal[1] - pos[1])
        if remaining < ARRIVE_WITHIN + SPACING * p.rank:     # a party member stops short
            p.state, p.result = "idle", ("succeeded", "")
            return
        if remaining < p.best - 0.5:
            p.best, p.best_t, p.replanned = remaining, now, False
        elif now - p.best_t > GIVE_UP_AFTER:
            p.state, p.result = "idle", ("aborted", "no progress for %g s" % GIVE_UP_AFTER)
            return
        path, k = p.path, p.k
        while k < len(path) - 1 and math.hypot(*(path[k] - pos)) < LOOKAHEAD:
            k += 1
        if math.hypot(*(path[k] - pos)) > OFF_PATH or (
                now - p.best_t > STUCK_AFTER and not p.replanned):
            self._replan(i, p)
            path, k = p.path, min(1, len(p.path) - 1)
        p.k = k
        self._target[i] = path[k]
        self._slow[i] = min(1.0, remaining / SLOW_WITHIN)

    def _replan(self, i: int, p: Person) -> None:
        """A new path from here to the same goal (once per stretch without progress)."""
        assert p.goal is not None
        p.replanned = True
        try:
            p.path = self._path(i, p.goal, p.roi)
        except (PlanError, RoiError):
            return
        p.k = 0

    def _path(self, i: int, goal: Sequence[float], roi: Optional[Roi]) -> np.ndarray:
        """Person i's path to ``goal``: by its region's tree, or by A* (no region)."""
        if roi is None:
            return self.routes.grid.plan(self.pos[i], goal)
        return self.routes.route(self.pos[i], roi, goal)

    def _move(self, robot_xy: np.ndarray, robot_r: np.ndarray) -> None:
        """Forces, integration and the wall rule (module doc, steps 2-3)."""
        if not self.n:
            return
        cfg, dt = self.forces, self.dt
        to = self._target - self.pos
        dist = np.hypot(to[:, 0], to[:, 1])
        e = np.where(dist[:, None] > 1e-6, to / np.maximum(dist, 1e-6)[:, None], 0.0)
        force = driving(self.vel, e * (self.v0 * self._slow)[:, None], cfg.tau)
        speed = np.hypot(self.vel[:, 0], self.vel[:, 1])
        heading = np.column_stack((np.cos(self.heading), np.sin(self.heading)))
        heading[speed < 0.1] = 0.0      # someone standing weighs others all round alike
        force += self._people_force(heading)
        if len(robot_xy):
            ii, jj = np.meshgrid(np.arange(self.n), np.arange(len(robot_xy)), indexing="ij")
            ii, jj = ii.ravel(), jj.ravel()
            near = np.hypot(*(self.pos[ii] - robot_xy[jj]).T) < cfg.cutoff + robot_r[jj]
            force += repulsion(self.pos, heading, self.radius, robot_xy, robot_r,
                               ii[near], jj[near], cfg, self.vel)
        if self.parties:
            force += coherence(self.pos, self.parties)
        clear, normal = self._wall_field(self.pos)
        force += wall_repulsion(clear, normal, self.radius, cfg)
        vel, _ = limit_speed(self.vel + force * dt, self.v0 * cfg.max_speed_factor)
        new = self._keep_off_walls(self.pos, self.pos + vel * dt)
        moved = new - self.pos
        self.vel = moved / dt
        step = np.hypot(moved[:, 0], moved[:, 1])
        walking = step > 0.1 * dt       # faster than 0.1 m/s: face the way walked
        self.heading[walking] = np.arctan2(moved[walking, 1], moved[walking, 0])
        self.phase = np.remainder(self.phase + math.pi * step / self.body.step_length,
                                  2.0 * math.pi)
        self.pos = new

    def _people_force(self, heading: np.ndarray) -> np.ndarray:
        """The repulsion between people within the cutoff (k-d tree pairs, both ways)."""
        if self.n < 2:
            return np.zeros((self.n, 2))
        from scipy.spatial import cKDTree

        pairs = cKDTree(self.pos).query_pairs(self.forces.cutoff, output_type="ndarray")
        i = np.concatenate((pairs[:, 0], pairs[:, 1]))
        j = np.concatenate((pairs[:, 1], pairs[:, 0]))
        return repulsion(self.pos, heading, self.radius, self.pos, self.radius, i, j,
                         self.forces, self.vel, self.vel)

    def _wall_field(self, xy: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Clearance at each point and the unit direction in which it grows (central
        differences one map cell either side; zero where flat)."""
        h = self.routes.grid.fmap.resolution
        probe = np.concatenate((xy, xy + (h, 0.0), xy - (h, 0.0), xy + (0.0, h), xy - (0.0, h)))
        c = self.clearance(probe).reshape(5, -1)
        grad = np.column_stack((c[1] - c[2], c[3] - c[4]))
        norm = np.hypot(grad[:, 0], grad[:, 1])
        normal = np.where(norm[:, None] > 1e-9, grad / np.maximum(norm, 1e-9)[:, None], 0.0)
        return c[0], normal

    def _keep_off_walls(self, old: np.ndarray, new: np.ndarray) -> np.ndarray:
        """``new``, except where it is within MIN_CLEARANCE of a wall: there the move along
        x alone or y alone (whichever is allowed and longer), else no move."""
        bad = np.flatnonzero(self.clearance(new) < MIN_CLEARANCE)
        if not len(bad):
            return new
        out = new.copy()
        o, n = old[bad], new[bad]
        xs = np.column_stack((n[:, 0], o[:, 1]))
        ys = np.column_stack((o[:, 0], n[:, 1]))
        ok = self.clearance(np.concatenate((xs, ys))).reshape(2, -1) >= MIN_CLEARANCE
        dx, dy = np.abs(n[:, 0] - o[:, 0]), np.abs(n[:, 1] - o[:, 1])
        take_x = ok[0] & (~ok[1] | (dx >= dy))
        take_y = ok[1] & ~take_x
        out[bad] = np.where(take_x[:, None], xs, np.where(take_y[:, None], ys, o))
        return out

    # ------------------------------------------------------------------------------ views
    def legs(self) -> np.ndarray:
        """(2N, 2) leg centres: person i's left leg is row 2i, its right 2i + 1."""
        b = self.body
        c, s = np.cos(self.heading), np.sin(self.heading)
        speed = np.hypot(self.vel[:, 0], self.vel[:, 1])
        swing = b.swing * np.minimum(1.0, speed) * np.sin(self.phase)
        half = 0.5 * b.leg_spacing
        left = self.pos + np.column_stack((-s * half + c * swing, c * half + s * swing))
        right = self.pos + np.column_stack((s * half - c * swing, -c * half - s * swing))
        out = np.empty((2 * self.n, 2))
        out[0::2], out[1::2] = left, right
        return out

    def ground_truth(self, regions: bool = False) -> List[PersonTruth]:
        """Every person now, in order (``track_id`` is the row + 1, constant for a run);
        with ``regions``, also the region each is in (a polygon query per person)."""
        out = []
        for i, p in enumerate(self.people):
            leg = p.agent.leg if p.agent is not None else None
            x, y = float(self.pos[i, 0]), float(self.pos[i, 1])
            here = p.agent.walker.region_at(x, y) if regions and p.agent is not None else ""
            out.append(PersonTruth(
                p.name, i + 1, x, y, float(self.vel[i, 0]), float(self.vel[i, 1]),
                float(self.heading[i]), p.state, leg.target_region if leg is not None else "",
                here))
        return out

    def take_log(self) -> List[str]:
        """The leg lines and warnings since the last call."""
        out, self.log = self.log, []
        return out
