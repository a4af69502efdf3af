"""A world's crowd from its ``people:`` section: the people's planning grid, their groups'
regions and chains, a walker per person, and where each starts."""
from __future__ import annotations

from typing import Any, Dict, Iterator, List, Optional, Tuple

import numpy as np

from ...data.rois import Roi, RoiError, load_rois
from ...errors import ConfigError
from ...nav.grid import PlannerConfig, PlanningGrid
from ..markov import MarkovChain, usable_rois
from ..agents import WalkerAgent
from ..walker import GoalSampler, Walker, WalkerConfig, walkable_regions
from .config import BodyConfig, GroupConfig, PeopleConfig
from .crowd import Crowd, Person
from .routes import Routes

__all__ = ["build_crowd", "routes_for"]

#: A goal or start point keeps this much more than a person's radius from every wall (m).
GOAL_CLEARANCE = 0.1
#: Tries for a start point clear of everyone placed before.
START_TRIES = 200


def build_crowd(world: Any, config: Optional[PeopleConfig] = None,
                routes: Optional[Routes] = None) -> Optional[Crowd]:
    """The crowd of ``world`` (a sim World), from ``config`` or its world file's section;
    None when it has no people. The warnings about regions left out are its first log lines.
    ``routes``: the people's ``routes_for`` when already built (a crowd built again and again
    on one world).

    Raises:
        ConfigError: a group has no regions to walk, or no room to start in.
    """
    cfg = config if config is not None else world.config.people
    if not cfg.count:
        return None
    routes = routes if routes is not None else routes_for(world, cfg.body)
    sampler = routes.sampler
    warnings: List[str] = []
    people: List[Person] = []
    files = set()
    for g, group in enumerate(cfg.groups):
        path, (chain, rois, notes) = _chain(world, group, sampler, routes.chains)
        if path not in files:   # the warnings of each ROI file once
            files.add(path)
            warnings.extend(notes)
        wcfg = WalkerConfig(dwell_min=group.dwell[0], dwell_max=group.dwell[1],
                            clearance=sampler.clearance)
        leader = len(people)
        for k in range(group.count):
            name = "%s_%d" % (group.name, len(people) + 1)
            if group.together and k > 0:   # a party member: the leader's pace, no chain
                people.append(Person(name, None, people[leader].speed, leader=leader, rank=k))
                continue
            walker = Walker(chain, rois, sampler, wcfg, seed=_seed(group, cfg, g, k))
            speed = float(walker.rng_dwell.uniform(*group.speed))
            people.append(Person(name, WalkerAgent(walker), speed))
    start = _starts(world, people, sampler, cfg.body.radius)
    crowd = Crowd(people, start, routes, cfg.body, cfg.forces, cfg.rate, world.clock.now_ns)
    now = world.clock.now_ns * 1e-9
    for p in people:    # the first legs start at random within one longest dwell
        if p.agent is not None:
            w = p.agent.walker
            p.agent.resume_at = now + float(w.rng_dwell.uniform(0.0, w.config.dwell_max))
    crowd.log.extend(warnings)
    return crowd


def routes_for(world: Any, body: BodyConfig) -> Routes:
    """Paths for people of ``body`` on ``world``'s floor: a planning grid whose footprint
    is the body's radius (walls as the simulator makes them solid), and a goal sampler on it
    that keeps ``GOAL_CLEARANCE`` more than that from every wall."""
    grid = PlanningGrid(world.fmap, PlannerConfig(robot_radius=body.radius),
                        handling=world.config.map_handling)
    return Routes(grid, GoalSampler(grid, clearance=body.radius + GOAL_CLEARANCE))


def _chain(world: Any, group: GroupConfig, sampler: GoalSampler,
           chains: Dict[str, Tuple[MarkovChain, List[Roi], List[str]]]
           ) -> Tuple[str, Tuple[MarkovChain, List[Roi], List[str]]]:
    """A group's ROI file, and its chain, regions and warnings (built once per file into
    ``chains``, the routes' cache)."""
    path = group.rois or world.config.rois
    if not path:
        raise ConfigError("%s: people: the %s group has no regions to walk (give rois: in the "
                          "people section or the world)" % (world.config.path, group.name))
    if path not in chains:
        try:
            rois, bad = usable_rois(load_rois(path))
        except RoiError as e:
            raise ConfigError("%s: people: %s" % (world.config.path, e)) from None
        rois, left_out = walkable_regions(rois, sampler)
        if len(rois) < 2:
            raise ConfigError("%s: people: %s has %d region(s) people can reach; a walk needs 2"
                              % (world.config.path, path, len(rois)))
        chain = MarkovChain.from_rois(rois)
        chains[path] = (chain, rois, bad + left_out + chain.warnings)
    return path, chains[path]


def _seed(group: GroupConfig, cfg: PeopleConfig, g: int, k: int) -> Optional[int]:
    """Person k of group g's walker seed: from the group's seed, else the section's (None:
    fresh)."""
    base = group.seed if group.seed is not None else cfg.seed
    if base is None:
        return None
    key = [base, k] if group.seed is not None else [base, g, k]
    return int(np.random.SeedSequence(key).generate_state(1)[0]) & 0x7FFFFFFF


def _starts(world: Any, people: List[Person], sampler: GoalSampler, radius: float) -> np.ndarray:
    """Where each person starts (``_candidates``), clear of the robots and of the people
    placed before."""
    robots = world.pose[:, :2] if world.n else np.zeros((0, 2))
    robot_r = world.radius if world.n else np.zeros(0)
    out = np.zeros((len(people), 2))
    for i, p in enumerate(people):
        for x, y in _candidates(p, out, sampler):
            clear_people = i == 0 or np.hypot(*(out[:i] - (x, y)).T).min() > 2 * radius + 0.1
            clear_robots = not len(robots) or bool(
                (np.hypot(*(robots - (x, y)).T) > robot_r + radius + 0.2).all())
            if clear_people and clear_robots:
                out[i] = (x, y)
                break
        else:
            raise ConfigError("%s: people: no room for %s (too many people for the regions?)"
                              % (world.config.path, p.name))
    return out


def _candidates(p: Person, placed: np.ndarray, sampler: GoalSampler) -> Iterator[Tuple[float, float]]:
    """Start points to try for ``p``: goal points of regions drawn at random from its walker;
    for a party member, free points around its leader (already placed), nearest first."""
    if p.agent is None:
        assert p.leader is not None
        lx, ly = placed[p.leader]
        for r in (0.6, 1.0, 1.4, 1.8):
            for a in np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False):
                x, y = lx + r * np.cos(a), ly + r * np.sin(a)
                if sampler.acceptable(x, y):
                    yield float(x), float(y)
        return
    w = p.agent.walker
    for _ in range(START_TRIES):
        roi = w.index.by_id[w.chain.ids[int(w.rng_region.integers(len(w.chain.ids)))]]
        try:
            yield sampler.sample(roi, w.rng_goal)
        except RoiError:
            continue
