"""The observer among many people: ``evaluate_prediction --people N``.

The world keeps only its observer robot; N people walk its regions (people/crowd, the
world file's ``people:`` settings with N people). The observer's agents are the nodes' own:
the tracker on its lidar (with ``centre_offset`` for legs: the centroid of a 0.06 m leg's
near arc lies 0.047 m before the leg's centre, ``LEG_CENTRE_OFFSET``), a destination
predictor per track, and the follower, which follows the chosen person (``chosen``): it is
given the track that the scoring matches to that person, or none while there is none, and
then searches where that track was predicted to go.

Scored per control tick against the ground truth:

* tracking: CLEAR MOT (mot.py) over the people in view (``visible_beams`` of the observer's
  beams on a person's legs), with the same match distance as the one-walker study;
* prediction: every completed leg of every person, at each fraction of the leg, the latest
  prediction of the track matched to that person (the tracker pipeline; the last one from its
  stand before the leg counts, as scoring.carried says) and of the predictor run on the
  person's own ground truth, as the one-walker study scores its walker's legs.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional

import numpy as np

from ...nav.pursuit import FollowerConfig
from ...sim.sensors import Scan
from ..agents import FollowerAgent, PredictorAgent, TrackerAgent
from ..crowd.build import build_crowd
from ..follow import FollowBehaviour, FollowConfig
from ..prediction import DestinationModel, OnlinePredictor, PredictionConfig
from ..tracking import TrackerConfig
from .mot import ClearMot
from .result import FRACTIONS, EvaluationError, LegScore
from .scenario import ObserverDrive, _laser_in_map, _regions
from .scoring import Record, carried, score_leg

__all__ = ["CrowdEvalConfig", "CrowdEvalResult", "run_crowd", "format_crowd", "plot_crowd",
           "LEG_CENTRE_OFFSET"]

#: The tracker's centre_offset for people's legs (0.06 m legs: pi/4 x 0.06 m).
LEG_CENTRE_OFFSET = 0.047


@dataclass
class CrowdEvalConfig:
    """Parameters of a people run (times in sim seconds).

    Attributes:
        people: how many.
        sim_time: how long the run lasts.
        seed: seeds the people, the sensor noise and everything else.
        world: world name or path (with ROIs; its robot ``observer`` observes).
        observer: index of the observing robot in the world file (the others are left out).
        chosen: the person followed (index).
        follow: the observer follows (False: it stays where it is).
        control_rate, match_distance, visible_beams: as the one-walker study's EvalConfig.
        prediction: the predictor's parameters.
        follow_config: the observer's parameters (default: FollowConfig()).
        drive_config: the observer's path following (default: the shipped one,
            scenario.observer_follower()).
    """

    people: int = 5
    sim_time: float = 600.0
    seed: int = 1
    world: str = "office"
    observer: int = 1
    chosen: int = 0
    follow: bool = True
    control_rate: float = 10.0
    match_distance: float = 0.5
    visible_beams: int = 3
    prediction: Optional[PredictionConfig] = None
    follow_config: Optional[FollowConfig] = None
    drive_config: Optional[FollowerConfig] = None

    def check(self) -> None:
        if not (isinstance(self.people, int) and self.people >= 1):
            raise EvaluationError("evaluate: people must be an integer >= 1, got %r"
                                  % (self.people,))
        if not 0 <= self.chosen < self.people:
            raise EvaluationError("evaluate: the chosen person %d is not one of the %d"
                                  % (self.chosen, self.people))
        if not (math.isfinite(self.sim_time) and self.sim_time > 0):
            raise EvaluationError("evaluate: sim_time must be > 0, got %r" % self.sim_time)
        if self.drive_config is not None:
            self.drive_config.check()


@dataclass
class CrowdEvalResult:
    """What :func:`run_crowd` measured."""

    config: CrowdEvalConfig
    names: List[str]
    legs: Dict[str, List[LegScore]]
    failed_legs: Dict[str, int]
    mot: ClearMot
    sim_time: float
    wall_time: float
    follow_modes: Dict[str, int] = field(default_factory=dict)

    def accuracy(self, name: Optional[str] = None, pipeline: str = "tracker",
                 fraction: float = 0.5, seen: bool = False) -> float:
        """Share of completed legs (of one person, or all) whose destination the predictor
        had right at ``fraction`` of the leg; with ``seen``, of the legs the pipeline had a
        prediction of by then (the person was tracked during the leg, or predicted while it stood
        before it: scoring.carried). nan: no such leg."""
        k = FRACTIONS.index(fraction)
        legs = self.legs[name] if name is not None else [x for v in self.legs.values() for x in v]
        scores = [leg.scores[pipeline]["predictor"][k] for leg in legs]
        if seen:
            scores = [s for s in scores if s[2]]
        return sum(s[0] for s in scores) / len(scores) if scores else math.nan

    def seen_share(self, fraction: float = 0.5) -> float:
        """Share of all completed legs the tracker had a prediction of at ``fraction``."""
        k = FRACTIONS.index(fraction)
        legs = [x for v in self.legs.values() for x in v]
        return (sum(leg.scores["tracker"]["predictor"][k][2] for leg in legs) / len(legs)
                if legs else math.nan)

    def tracked_share(self, name: str) -> float:
        """Share of the ticks a person was in view that a track was matched to it."""
        stats = self.mot.per_person.get(name, {"in_view": 0, "matched": 0})
        return stats["matched"] / stats["in_view"] if stats["in_view"] else math.nan


def run_crowd(config: Optional[CrowdEvalConfig] = None,
              progress: Optional[Callable[[str], None]] = None) -> CrowdEvalResult:
    """Run the people study (see the module doc)."""
    from ...sim.config import load_world_config, resolve_world
    from ...paths import worlds_dir
    from ...sim.world import World

    cfg = config or CrowdEvalConfig()
    cfg.check()
    t_wall = time.time()
    wcfg = load_world_config(resolve_world(cfg.world, worlds_dir()))
    if cfg.observer >= len(wcfg.robots) or not wcfg.rois:
        raise EvaluationError("evaluate: world %s needs a robot %d and a rois file"
                              % (cfg.world, cfg.observer))
    wcfg = dataclasses.replace(wcfg, robots=[wcfg.robots[cfg.observer]])
    world = World(wcfg, seed=cfg.seed, physics_rate=100.0)
    try:
        run = _CrowdRun(cfg, world, progress or (lambda _s: None), t_wall)
        steps = max(1, int(round(1.0 / (world.clock.dt * cfg.control_rate))))
        while world.clock.now - run.t0 < cfg.sim_time:
            run.tick(steps)
        return run.result()
    finally:
        world.close()


class _CrowdRun:
    def __init__(self, cfg: CrowdEvalConfig, world, say, t_wall: float) -> None:
        self.cfg, self.world, self.say, self.t_wall = cfg, world, say, t_wall
        people = dataclasses.replace(world.config.people, seed=cfg.seed).with_count(cfg.people)
        crowd = build_crowd(world, people)
        assert crowd is not None
        self.crowd = crowd
        world.add_people(crowd)
        grid, _, rois, chain, _ = _regions(world)
        self.model = model = DestinationModel(grid, rois, chain, cfg.prediction)
        self.uniform = {r: 1.0 / len(chain.ids) for r in chain.ids}
        self.tracker = TrackerAgent.for_map(world.fmap,
                                            TrackerConfig(centre_offset=LEG_CENTRE_OFFSET),
                                            handling=world.config.map_handling)
        follow = cfg.follow_config or FollowConfig()
        self.predictor = PredictorAgent(model, follow)
        self.follower = FollowerAgent(FollowBehaviour(grid, follow))
        self.drive = ObserverDrive(world, 0, grid, cfg.drive_config)
        self.laser = world.models[0].laser_pose
        self.names = [p.name for p in crowd.people]
        self.gt_pred = [OnlinePredictor(model) for _ in crowd.people]
        self.gt_records: List[List[Record]] = [[] for _ in crowd.people]
        self.trk_records: List[List[Record]] = [[] for _ in crowd.people]
        self.current: List[Optional[object]] = [None] * crowd.n
        self.dwell_since = [world.clock.now] * crowd.n   # when each one's last leg ended
        self.legs: Dict[str, List[LegScore]] = {n: [] for n in self.names}
        self.failed: Dict[str, int] = {n: 0 for n in self.names}
        self.mot = ClearMot(cfg.match_distance)
        self.scan: Optional[Scan] = None
        self.t0 = world.clock.now

    def tick(self, steps: int) -> None:
        world = self.world
        for s in world.step(steps):
            if isinstance(s, Scan):
                self.scan = s
        t = world.clock.now
        world.update_odometry()
        pose_o = world.view(0, refresh=False).pose
        truth = self.crowd.ground_truth()
        tracks, pts = [], np.zeros((0, 2))
        if self.scan is not None:
            tstep = self.tracker.tick(t, self.scan, _laser_in_map(pose_o, self.laser))
            tracks, pts = tstep.tracks, tstep.points
        pstep = self.predictor.tick(t, [(tr.id, tr.x, tr.y, tr.vx, tr.vy) for tr in tracks])
        pairs = self._score_tracking(truth, tracks, pts)
        self._legs(t, truth, pairs, {tr.id: tr for tr in tracks}, pstep.destinations)
        self._follow(t, pose_o, tracks, pairs, pstep)

    def _score_tracking(self, truth, tracks, pts) -> Dict[str, int]:
        """CLEAR MOT of this tick; returns person name -> matched track id."""
        body = self.crowd.body.radius + self.crowd.body.leg_radius   # legs reach 0.31 m
        seen, hidden = {}, []
        for p in truth:
            near = np.count_nonzero(np.hypot(pts[:, 0] - p.x, pts[:, 1] - p.y) < body) \
                if len(pts) else 0
            if near >= self.cfg.visible_beams:
                seen[p.name] = (p.x, p.y)
            else:
                hidden.append((p.x, p.y))
        pairs = self.mot.update(seen, {tr.id: (tr.x, tr.y) for tr in tracks}, hidden)
        return {str(k): int(v) for k, v in pairs.items()}  # type: ignore[call-overload]

    def _legs(self, t: float, truth, pairs: Dict[str, int], tracks, destinations) -> None:
        """Each person's leg bookkeeping and its two pipelines' records."""
        for i, p in enumerate(self.crowd.people):
            assert p.agent is not None
            leg = p.agent.leg
            last = self.current[i]
            if last is not None and leg is not last:
                self._leg_ended(i, last)
                self.dwell_since[i] = t
            if leg is not None and leg is not last:
                self.gt_records[i] = carried(self.gt_records[i], self.dwell_since[i])
                self.trk_records[i] = carried(self.trk_records[i], self.dwell_since[i])
            self.current[i] = leg
            g = truth[i]
            # the predictor sees the dwells too (it cuts legs at the stops, as on a track);
            # a dwell's records are kept for the next leg's carry (scoring.carried)
            pred = self.gt_pred[i].update(t, g.x, g.y, g.vx, g.vy)
            if pred is not None:
                self.gt_records[i].append(Record(t, pred, (g.x, g.y), (g.vx, g.vy)))
            track = pairs.get(p.name)
            if track is not None and track in destinations:
                tr = tracks[track]
                self.trk_records[i].append(Record(t, destinations[track][0], (tr.x, tr.y),
                                                  (tr.vx, tr.vy)))

    def _leg_ended(self, i: int, leg) -> None:
        name = self.names[i]
        if leg.outcome == "succeeded":
            self.legs[name].append(score_leg(leg, self.gt_records[i], self.trk_records[i],
                                             self.model, self.uniform))
        else:
            self.failed[name] += 1
        done = sum(len(v) for v in self.legs.values())
        if done % 10 == 0 and leg.outcome == "succeeded":
            self.say("%d legs scored, %.0f s sim, %.0f s wall, MOTA %.3f" % (
                done, self.world.clock.now - self.t0, time.time() - self.t_wall, self.mot.mota))

    def _follow(self, t: float, pose_o, tracks, pairs: Dict[str, int], pstep) -> None:
        """The follower, given only the chosen person's track (module doc)."""
        chosen = pairs.get(self.names[self.cfg.chosen])
        mine = [tr for tr in tracks if tr.id == chosen]
        if not self.cfg.follow:
            self.world.command(0, 0.0, 0.0, 0.0)
            return
        plans = {tid: plan for tid, (_p, plan) in pstep.destinations.items()}
        lost = self.follower.target_id
        fstep = self.follower.tick(t, pose_o, mine, plans, self.drive.goal_done)
        self.predictor.follower_switched(lost, fstep)
        self.drive(t, pose_o, fstep.decision, self.scan)

    def result(self) -> CrowdEvalResult:
        return CrowdEvalResult(config=self.cfg, names=self.names, legs=self.legs,
                               failed_legs=self.failed, mot=self.mot,
                               sim_time=self.world.clock.now - self.t0,
                               wall_time=time.time() - self.t_wall,
                               follow_modes=self.drive.modes)


def format_crowd(result: CrowdEvalResult) -> str:
    """The people run as text: a row per person and one for all, then the MOT line."""
    r, m = result, result.mot
    lines = ["%-14s %5s %6s %9s %9s %9s %10s %9s" % (
        "person", "legs", "failed", "tracked", "switches", "acc50", "acc50seen", "acc50gt")]

    def row(name: str, legs: int, failed: int, tracked: float, switches: int,
            who: Optional[str]) -> str:
        return "%-14s %5d %6d %8.1f%% %9d %8.1f%% %9.1f%% %8.1f%%" % (
            name, legs, failed, 100 * tracked, switches, 100 * r.accuracy(who),
            100 * r.accuracy(who, seen=True), 100 * r.accuracy(who, "ground_truth"))

    for k, name in enumerate(r.names):
        stats = m.per_person.get(name, {"switches": 0})
        label = name + (" *" if k == r.config.chosen else "")
        lines.append(row(label, len(r.legs[name]), r.failed_legs[name], r.tracked_share(name),
                         stats["switches"], name))
    seen = m.matches / m.truths if m.truths else math.nan
    lines.append(row("all", sum(len(v) for v in r.legs.values()),
                     sum(r.failed_legs.values()), seen, m.switches, None))
    lines.append("* followed. tracked: share of the ticks in view with a track matched; "
                 "acc50: legs whose destination was right at 50 %; acc50seen: of the legs "
                 "predicted by then; acc50gt: the predictor on the person's own ground truth")
    lines.append("MOTA %.3f  MOTP %.3f m  misses %d  false positives %d  switches %d  "
                 "in view %d person-ticks of %d ticks" % (m.mota, m.motp, m.misses,
                                                          m.false_positives, m.switches,
                                                          m.truths, m.frames))
    return "\n".join(lines)


def plot_crowd(result: CrowdEvalResult, path: str) -> None:
    """Destination accuracy vs fraction of the leg observed, as a PNG: every person's legs
    from the tracks (all legs, and the legs predicted by then), from ground truth, and the
    followed person's from the tracks."""
    from ..plotting import pyplot

    plt = pyplot("evaluate_prediction --plot")
    r = result
    chosen = r.names[r.config.chosen]
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    xs = [100 * f for f in FRACTIONS]
    for label, style, acc in (
            ("all people, tracks (all legs)", "-", lambda f: r.accuracy(fraction=f)),
            ("all people, tracks (legs predicted by then)", "-.",
             lambda f: r.accuracy(fraction=f, seen=True)),
            ("all people, ground truth", "--",
             lambda f: r.accuracy(pipeline="ground_truth", fraction=f)),
            ("%s (followed), tracks" % chosen, ":", lambda f: r.accuracy(chosen, fraction=f))):
        ax.plot(xs, [100 * acc(f) for f in FRACTIONS], style, marker="o", label=label)
    ax.set_xlabel("% of the leg observed")
    ax.set_ylabel("top-1 destination accuracy (%)")
    ax.set_ylim(0, 100)
    ax.set_title("%d people, %s world, %d legs, seed %d, MOTA %.3f" % (
        len(r.names), r.config.world, sum(len(v) for v in r.legs.values()), r.config.seed,
        r.mot.mota))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
