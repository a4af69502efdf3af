"""The destination-prediction study: how much of a leg must be seen before its goal is right.

:func:`run` plays the demo's observer scenario in one process, headless and as fast as the CPU
allows: the world's first robot walks region to region by the Markov chain (people/walker.py,
driven by the embedded navigator, as ``markov_walker`` + ``path_follower`` do), the second
robot detects and tracks it with its own lidar (people/tracking.py, localised from ground truth),
follows it and searches the predicted region when it loses it (people/follow.py), and the
predictor (people/prediction.py) estimates the destination of the current leg on every track
update. The same predictor also runs on the walker's ground-truth trajectory, so that tracking
error and prediction error can be told apart.

It is the same code the ROS nodes run, without the transport: a run is deterministic for a
seed and takes minutes instead of the hours that 200 legs would take through roslaunch.

For each leg the walker completes, at 10/25/50/75/90 % of its duration, the latest prediction
of each pipeline (tracker, ground truth) is scored against the leg's destination region for
the predictor and two baselines (the Markov prior alone; the nearest region along the current
heading): top-1 accuracy and log-loss. A leg moment without any prediction of the current leg
(the target was not tracked since the leg began) counts as a miss, with the uniform
distribution over the chain's regions for the log-loss.

Tracking is scored on every control tick: recall while the walker is visible to the observer
(at least ``visible_beams`` beams of the observer's scan end on the walker's body), the share
of the whole run during which the walker is tracked (a confirmed track within
``match_distance`` of it), and confirmed tracks matching nothing (false tracks).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..data.rois import load_rois
from ..errors import BulletFloorSimError
from ..nav.planner import (Navigator, NavigatorConfig, PathFollower, PlanError, PlanningGrid,
                           obstacles_in_base)
from .agents import FollowerAgent, PredictorAgent, TrackerAgent, WalkerAgent
from .follow import FollowBehaviour, FollowConfig
from .markov import MarkovChain, usable_rois
from .plotting import pyplot
from .prediction import (DestinationModel, OnlinePredictor, PredictionConfig, log_loss,
                         posterior_or_prior, top1)
from .tracking import TrackerConfig
from .walker import GoalSampler, Walker, WalkerConfig, WalkerError, walkable_regions

__all__ = ["EvalConfig", "EvalResult", "LegScore", "run", "FRACTIONS", "METHODS", "PIPELINES",
           "LEG_KINDS", "format_table", "plot", "rescore",
           "world_model"]

FRACTIONS = (0.10, 0.25, 0.50, 0.75, 0.90)
METHODS = ("predictor", "markov", "heading")
PIPELINES = ("tracker", "ground_truth")
LEG_KINDS = ("all", "change", "stay")
Moment = Tuple[str, float, float, float, float, float, float]


class EvaluationError(BulletFloorSimError):
    """The evaluation cannot run (bad parameters, a world without two robots or ROIs)."""


__all__ += ["EvaluationError"]


@dataclass
class EvalConfig:
    """Evaluation parameters.

    Attributes:
        legs: walker legs to complete (successful legs are scored; failed ones are counted).
        seed: seeds the walker, the sensor noise and everything else.
        world: world name or path (two robots at least, with ROIs).
        walker: index of the walking robot; observer: index of the observing robot.
        control_rate: Hz of the navigation, tracking and prediction loop (the scan rate).
        max_sim_time: stop after this much sim time (s) even if fewer legs are done
            (default: 150 s per leg).
        follow: the observer follows (False: it stays where it is; a baseline for the tracker).
        match_distance: a track within this distance (m) of the walker tracks it.
        visible_beams: the walker is visible when this many observer beams end on its body.
        prediction: the predictor's parameters (default: PredictionConfig()).
    """

    legs: int = 200
    seed: int = 1
    world: str = "office"
    walker: int = 0
    observer: int = 1
    control_rate: float = 10.0
    max_sim_time: Optional[float] = None
    follow: bool = True
    match_distance: float = 0.5
    visible_beams: int = 3
    prediction: Optional[PredictionConfig] = None

    def check(self) -> None:
        if not (isinstance(self.legs, int) and self.legs >= 1):
            raise EvaluationError("evaluate: legs must be an integer >= 1, got %r" % self.legs)
        if self.walker == self.observer:
            raise EvaluationError("evaluate: walker and observer must be different robots")
        for name in ("control_rate", "match_distance"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise EvaluationError("evaluate: %s must be > 0, got %r" % (name, v))


@dataclass
class LegScore:
    """One completed leg's predictions at each fraction observed.

    ``scores[pipeline][method]`` = list over FRACTIONS of (correct: bool, log_loss: float,
    predicted: bool -- whether the pipeline had a prediction of this leg then).
    ``moments[pipeline]`` = list over FRACTIONS of what that prediction was made from
    (start region, start x, y, position x, y, velocity x, y), or None: :func:`rescore`
    scores them again under other prediction parameters.
    """

    number: int
    start_region: str
    target_region: str
    duration: float
    scores: Dict[str, Dict[str, List[Tuple[bool, float, bool]]]] = field(default_factory=dict)
    moments: Dict[str, List[Optional[Moment]]] = field(default_factory=dict)


@dataclass
class EvalResult:
    """What :func:`run` measured."""

    config: EvalConfig
    legs: List[LegScore]
    failed_legs: int
    sim_time: float
    wall_time: float
    ticks: int
    visible_ticks: int
    recalled_ticks: int
    tracked_ticks: int
    false_track_ticks: int
    id_switches: int
    mean_track_error: float
    follow_modes: Dict[str, int]
    handovers: int = 0
    warnings: List[str] = field(default_factory=list)  # the map's handling, regions left out

    @property
    def recall(self) -> float:
        """Tracker recall while the walker is visible to the observer."""
        return self.recalled_ticks / self.visible_ticks if self.visible_ticks else float("nan")

    @property
    def tracked_share(self) -> float:
        """Share of the run during which the walker is tracked."""
        return self.tracked_ticks / self.ticks if self.ticks else float("nan")

    def legs_of(self, kind: str = "all") -> List[LegScore]:
        """The scored legs of a kind: ``all``, ``change`` (to another region) or ``stay``
        (to another point of the region the leg started in). Under the seed's transition rule
        offices are sticky (P(stay) 0.67-0.86 in the office world), so the Markov prior is
        right on most ``stay`` legs and wrong on nearly every ``change`` leg out of an office:
        the two kinds say different things about a predictor."""
        if kind not in LEG_KINDS:
            raise EvaluationError("evaluate: leg kind must be one of %s, got %r"
                                  % (" | ".join(LEG_KINDS), kind))
        if kind == "all":
            return list(self.legs)
        change = kind == "change"
        return [leg for leg in self.legs if (leg.start_region != leg.target_region) == change]

    def table(self, kind: str = "all") -> Dict[str, Dict[str, List[Tuple[float, float, int]]]]:
        """``[pipeline][method]`` -> per fraction (accuracy, mean log-loss, legs), over the
        legs of ``kind`` (see :meth:`legs_of`)."""
        legs = self.legs_of(kind)
        out: Dict[str, Dict[str, List[Tuple[float, float, int]]]] = {}
        for p in PIPELINES:
            out[p] = {}
            for m in METHODS:
                row = []
                for k in range(len(FRACTIONS)):
                    vals = [leg.scores[p][m][k] for leg in legs]
                    n = len(vals)
                    acc = sum(1 for c, _, _ in vals if c) / n if n else float("nan")
                    ll = sum(v for _, v, _ in vals) / n if n else float("nan")
                    row.append((acc, ll, n))
                out[p][m] = row
        return out

    def coverage(self, pipeline: str) -> List[float]:
        """Per fraction, the share of legs with a prediction of the current leg."""
        n = len(self.legs)
        return [sum(1 for leg in self.legs if leg.scores[pipeline]["predictor"][k][2]) / n
                if n else float("nan") for k in range(len(FRACTIONS))]


# -------------------------------------------------------------------------------------------
# the run
# -------------------------------------------------------------------------------------------


class _Record:
    """The latest prediction of one pipeline, with the observation it was made from."""

    __slots__ = ("t", "prediction", "xy", "velocity")

    def __init__(self, t, prediction, xy, velocity) -> None:
        self.t, self.prediction, self.xy, self.velocity = t, prediction, xy, velocity


def run(config: Optional[EvalConfig] = None,
        progress: Optional[Callable[[str], None]] = None) -> EvalResult:
    """Run the study (see the module docstring).

    Args:
        config: parameters.
        progress: called with a line of text after each leg.

    Raises:
        EvaluationError: the world has fewer than two robots or no usable ROIs.
    """
    from ..sim.world import World

    cfg = config or EvalConfig()
    cfg.check()
    say = progress or (lambda _s: None)
    t_wall = time.time()
    world = World.from_name(cfg.world, seed=cfg.seed, physics_rate=100.0)
    try:
        return _run(cfg, world, say, t_wall)
    finally:
        world.close()


def _regions(world):
    """The planning grid, the walker's goal sampler, the regions the walker can reach, their
    chain, and the warnings about the map and the regions left out."""
    grid = PlanningGrid(world.fmap, handling=world.config.map_handling)
    wcfg = WalkerConfig()
    sampler = GoalSampler(grid, wcfg.clearance, wcfg.margin, wcfg.goal_tries)
    rois, warnings = usable_rois(load_rois(world.config.rois))
    rois, unreachable = walkable_regions(rois, sampler)
    chain = MarkovChain.from_rois(rois)
    return grid, sampler, rois, chain, world.solid.report + warnings + unreachable + chain.warnings


def world_model(world_name: str, prediction: Optional[PredictionConfig] = None
                ) -> DestinationModel:
    """The destination model :func:`run` builds for a world (its regions the walker can
    reach, their chain, its planning grid) with the given prediction parameters."""
    from ..sim.world import World

    world = World.from_name(world_name, seed=0, physics_rate=100.0)
    try:
        grid, _, rois, chain, _ = _regions(world)
        return DestinationModel(grid, rois, chain, prediction)
    finally:
        world.close()


class _Scenario:
    """One run's world, agents and tallies; :meth:`tick` is one control tick of all of them."""

    def __init__(self, cfg: EvalConfig, world, say: Callable[[str], None],
                 t_wall: float) -> None:
        if world.n < 2 or max(cfg.walker, cfg.observer) >= world.n:
            raise EvaluationError("evaluate: world %s has %d robot(s); robots %d and %d are "
                                  "needed" % (cfg.world, world.n, cfg.walker, cfg.observer))
        if not world.config.rois:
            raise EvaluationError("evaluate: world %s has no rois file" % cfg.world)
        self.cfg, self.world, self.say, self.t_wall = cfg, world, say, t_wall
        grid, sampler, rois, chain, self.warnings = _regions(world)
        self.model = model = DestinationModel(grid, rois, chain, cfg.prediction)
        self.uniform = {r: 1.0 / len(chain.ids) for r in chain.ids}
        # the agents the nodes run: markov_walker, people_tracker (observer.launch's
        # centre_offset for the Scitos body), destination_predictor, follower
        self.walker = WalkerAgent(Walker(chain, rois, sampler, WalkerConfig(), seed=cfg.seed))
        self.tracker = TrackerAgent.for_map(world.fmap, TrackerConfig(centre_offset=0.25),
                                            handling=world.config.map_handling)
        self.predictor = PredictorAgent(model)
        self.follower = FollowerAgent(FollowBehaviour(grid, FollowConfig()))
        # path_follower in each namespace; the observer's yields (demo.launch's ~give_way)
        self.nav_walker = Navigator(grid, PathFollower())
        self.nav_observer = Navigator(grid, PathFollower(), NavigatorConfig(give_way=True))
        self.pred_gt = OnlinePredictor(model)   # the same predictor on the walker's truth
        self.laser = [world.models[i].laser_pose for i in range(world.n)]  # x, y, z, yaw
        self.body = float(world.radius[cfg.walker])  # the walker's footprint radius
        self.scans: Dict[int, object] = {}
        self.gt_records: List[_Record] = []
        self.trk_records: List[_Record] = []
        self.obs_goal_active = self.obs_goal_done = False
        self.n_ticks = self.visible = self.recalled = self.tracked = 0
        self.false_ticks = self.switches = self.failed = 0
        self.err_sum = 0.0
        self.modes: Dict[str, int] = {}
        self.completed: List[LegScore] = []
        self.t0 = world.clock.now

    def tick(self, steps: int) -> None:
        """Step the world one control period, then the walker, the ground-truth predictor
        and the observer in turn."""
        world, cfg = self.world, self.cfg
        for s in world.step(steps):
            self.scans[s.robot] = s
        t = world.clock.now
        world.update_odometry()
        pose_w = world.view(cfg.walker, refresh=False)
        self._walk(t, pose_w.pose)
        x, y, yaw = pose_w.pose
        v = pose_w.velocity[0]
        vel = (v * math.cos(yaw), v * math.sin(yaw))
        p = self.pred_gt.update(t, x, y, vel[0], vel[1])
        if p is not None:
            self.gt_records.append(_Record(t, p, (x, y), vel))
        self._observe(t, (x, y), world.view(cfg.observer, refresh=False).pose)

    def _walk(self, t: float, pose: Sequence[float]) -> None:
        """The walker (markov_walker + path_follower): a leg, its navigation, its end."""
        W, agent = self.cfg.walker, self.walker
        if agent.leg is None:
            try:
                step = agent.tick(t, pose)
            except WalkerError as e:
                raise EvaluationError("evaluate: the walker cannot go on: %s" % e)
            if step.start is None:
                return
            try:
                self.nav_walker.start(pose, step.start.goal, t)
                self.gt_records, self.trk_records = [], []
            except PlanError as e:
                self._leg_ended(t, agent.tick(t, pose, ("rejected", str(e))))
                return
        st = self.nav_walker.update(pose, _obstacles(self.scans.get(W), self.laser[W]), t)
        result = None if st.state == "active" else (
            ("succeeded", "") if st.state == "succeeded" else ("aborted", st.message))
        step = agent.tick(t, pose, result)
        if step.finished is None:
            self.world.command(W, st.v, 0.0, st.w)
            return
        self.world.command(W, 0.0, 0.0, 0.0)
        if step.cancel:
            self.nav_walker.cancel()
        self._leg_ended(t, step)

    def _leg_ended(self, t: float, step) -> None:
        leg = step.finished
        if leg.outcome == "succeeded":
            self.completed.append(_score(leg, self.gt_records, self.trk_records, self.model,
                                         self.uniform))
        else:
            self.failed += 1
        self.say("%s  [%d/%d scored, %.0f s sim, %.0f s wall]" % (
            step.line, len(self.completed), self.cfg.legs, t - self.t0,
            time.time() - self.t_wall))

    def _observe(self, t: float, truth: Tuple[float, float], pose_o: Sequence[float]) -> None:
        """The observer: detect and track (people_tracker), predict (destination_predictor),
        pick and follow the target (follower); the tick's tracking scores."""
        cfg, OBS = self.cfg, self.cfg.observer
        scan_o = self.scans.get(OBS)
        x, y = truth
        tracks, visible = [], False
        if scan_o is not None:
            tstep = self.tracker.tick(t, scan_o, _laser_in_map(pose_o, self.laser[OBS]))
            tracks, pts = tstep.tracks, tstep.points
            near = np.hypot(pts[:, 0] - x, pts[:, 1] - y) < self.body + 0.1 if len(pts) else []
            visible = int(np.count_nonzero(near)) >= cfg.visible_beams
        pstep = self.predictor.tick(t, [(tr.id, tr.x, tr.y, tr.vx, tr.vy) for tr in tracks])
        if cfg.follow:
            plans = {tid: plan for tid, (_p, plan) in pstep.destinations.items()}
            fstep = self.follower.tick(t, pose_o, tracks, plans, self.obs_goal_done)
            self.obs_goal_done = False
            self._follow(t, pose_o, fstep.decision, scan_o)
        else:
            fstep = self.follower.pick(tracks)
            self.world.command(OBS, 0.0, 0.0, 0.0)
        target = fstep.target
        self.switches += 1 if fstep.switched else 0
        if target is not None and target.id in pstep.destinations:
            self.trk_records.append(_Record(t, pstep.destinations[target.id][0],
                                            (target.x, target.y), (target.vx, target.vy)))
        self.n_ticks += 1
        match = [tr for tr in tracks if math.hypot(tr.x - x, tr.y - y) < cfg.match_distance]
        if visible:
            self.visible += 1
            self.recalled += 1 if match else 0
        if target is not None and math.hypot(target.x - x, target.y - y) < cfg.match_distance:
            self.tracked += 1
            self.err_sum += math.hypot(target.x - x, target.y - y)
        if len(tracks) > len(match):
            self.false_ticks += 1

    def _follow(self, t: float, pose_o: Sequence[float], dec, scan_o) -> None:
        """The observer's navigation (path_follower) towards the follower's goals."""
        OBS = self.cfg.observer
        self.modes[dec.mode] = self.modes.get(dec.mode, 0) + 1
        if dec.goal is not None:
            try:
                self.nav_observer.start(pose_o, dec.goal, t)
                self.obs_goal_active = True
            except PlanError:
                self.obs_goal_active, self.obs_goal_done = False, True
        if not self.obs_goal_active:
            self.world.command(OBS, 0.0, 0.0, 0.0)
            return
        st = self.nav_observer.update(pose_o, _obstacles(scan_o, self.laser[OBS]), t)
        if st.state == "active":
            self.world.command(OBS, st.v, 0.0, st.w)
        else:
            self.world.command(OBS, 0.0, 0.0, 0.0)
            self.obs_goal_active, self.obs_goal_done = False, True

    def result(self) -> EvalResult:
        tracked = self.tracked
        return EvalResult(config=self.cfg, legs=self.completed, failed_legs=self.failed,
                          sim_time=self.world.clock.now - self.t0,
                          wall_time=time.time() - self.t_wall, ticks=self.n_ticks,
                          visible_ticks=self.visible, recalled_ticks=self.recalled,
                          tracked_ticks=tracked, false_track_ticks=self.false_ticks,
                          id_switches=self.switches, handovers=self.predictor.handovers,
                          mean_track_error=self.err_sum / tracked if tracked else float("nan"),
                          follow_modes=self.modes, warnings=self.warnings)


def _run(cfg: EvalConfig, world, say, t_wall: float) -> EvalResult:
    run = _Scenario(cfg, world, say, t_wall)
    steps = max(1, int(round(1.0 / (world.clock.dt * cfg.control_rate))))
    max_t = cfg.max_sim_time if cfg.max_sim_time is not None else 150.0 * cfg.legs
    while len(run.completed) < cfg.legs and world.clock.now - run.t0 < max_t:
        run.tick(steps)
    return run.result()


def _laser_in_map(pose: Sequence[float], laser: Sequence[float]) -> Tuple[float, float, float]:
    x, y, yaw = pose[:3]
    c, s = math.cos(yaw), math.sin(yaw)
    return x + c * laser[0] - s * laser[1], y + s * laser[0] + c * laser[1], yaw + laser[3]


def _obstacles(scan, laser) -> Optional[np.ndarray]:
    if scan is None:
        return None
    return obstacles_in_base(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_max,
                             (laser[0], laser[1], laser[3]))


def _score(leg, gt: List[_Record], trk: List[_Record], model: DestinationModel,
           uniform: Dict[str, float]) -> LegScore:
    """Score a completed leg from each pipeline's records, and keep the moments scored."""
    out = LegScore(leg.number, leg.start_region, leg.target_region, leg.duration)
    for name, records in (("ground_truth", gt), ("tracker", trk)):
        times = [r.t for r in records]
        latest = []
        for f in FRACTIONS:
            k = int(np.searchsorted(times, leg.started + f * leg.duration, side="right")) - 1
            latest.append(records[k] if k >= 0 else None)
        out.moments[name] = [None if r is None else _moment(r) for r in latest]
        seen = [None if r is None else (r.prediction.probabilities, out.moments[name][i])
                for i, r in enumerate(latest)]
        out.scores[name] = _score_pipeline(leg.target_region, seen, model, uniform)
    return out


def _moment(rec: _Record) -> Moment:
    p = rec.prediction
    return (p.start_region, float(p.start_xy[0]), float(p.start_xy[1]), float(rec.xy[0]),
            float(rec.xy[1]), float(rec.velocity[0]), float(rec.velocity[1]))


def _score_pipeline(truth: str, seen: Sequence[Optional[Tuple[Dict[str, float], Moment]]],
                    model: DestinationModel, uniform: Dict[str, float]
                    ) -> Dict[str, List[Tuple[bool, float, bool]]]:
    """Per method, per fraction (correct, log-loss, predicted) from the predictor's
    probabilities and the moment they were made at (None: no prediction of the leg)."""
    per = {m: [] for m in METHODS}  # type: Dict[str, List[Tuple[bool, float, bool]]]
    for item in seen:
        if item is None:
            for m in METHODS:
                per[m].append((False, log_loss(uniform, truth), False))
            continue
        probs, (r0, _sx, _sy, qx, qy, vx, vy) = item
        dists = {"predictor": probs, "markov": model.markov_baseline(r0),
                 "heading": model.heading_baseline(r0, (qx, qy), (vx, vy))}
        for m in METHODS:
            per[m].append((top1(dists[m]) == truth, log_loss(dists[m], truth), True))
    return per


def rescore(result: EvalResult, model: DestinationModel) -> EvalResult:
    """The same run scored with another destination model (other prediction parameters):
    each leg's moments (start region, S, Q, velocity at each fraction) get that model's
    posterior, as the live predictor computes it. The walk, the tracks and the leg cuts stay
    those of the run, so this measures the posterior alone (the follower, which searches
    where the live predictor pointed, is not re-run)."""
    uniform = {r: 1.0 / len(model.chain.ids) for r in model.chain.ids}
    legs = []
    for leg in result.legs:
        new = LegScore(leg.number, leg.start_region, leg.target_region, leg.duration,
                       moments=leg.moments)
        for name in PIPELINES:
            seen = [None if m is None else
                    (posterior_or_prior(model, m[0], m[1:3], m[3:5])[0], m)
                    for m in leg.moments[name]]
            new.scores[name] = _score_pipeline(leg.target_region, seen, model, uniform)
        legs.append(new)
    return replace(result, legs=legs)


# -------------------------------------------------------------------------------------------
# reporting
# -------------------------------------------------------------------------------------------


def format_table(result: EvalResult) -> str:
    """The result as text: one block per pipeline, accuracy and log-loss per fraction."""
    lines = ["note: %s" % w for w in result.warnings]
    head = "%-12s" % "method" + "".join("   %3d%% acc  logloss" % round(100 * f)
                                        for f in FRACTIONS)
    what = {"change": "legs to another region", "stay": "legs within the start region"}
    tables = {kind: result.table(kind) for kind in LEG_KINDS}
    for p in PIPELINES:
        cov = result.coverage(p)
        lines.append("== %s tracks (%d legs; legs with a prediction: %s)" % (
            p.replace("_", "-"), len(result.legs),
            " ".join("%.0f%%" % (100 * c) for c in cov)))
        lines.append(head)
        for kind in LEG_KINDS:
            tab = tables[kind]
            if kind != "all":
                lines.append("-- %s (%d legs)" % (what[kind], len(result.legs_of(kind))))
            for m in METHODS:
                lines.append("%-12s" % m + "".join("   %7.1f%% %8.3f" % (100 * a, ll)
                                                  for a, ll, _ in tab[p][m]))
    r = result
    lines.append("tracking: recall while visible %.1f%% (%d of %d ticks), walker tracked %.1f%% "
                 "of the run, mean track error %.3f m, target id switches %d (predictor "
                 "hand-overs %d), ticks with a false track %d"
                 % (100 * r.recall, r.recalled_ticks, r.visible_ticks, 100 * r.tracked_share,
                    r.mean_track_error, r.id_switches, r.handovers, r.false_track_ticks))
    lines.append("run: %d legs scored, %d failed, %.0f s sim in %.0f s wall (%.1fx real time); "
                 "follower modes %s" % (len(r.legs), r.failed_legs, r.sim_time, r.wall_time,
                                        r.sim_time / max(r.wall_time, 1e-9),
                                        ", ".join("%s %.0f%%" % (k, 100.0 * v / max(1, r.ticks))
                                                  for k, v in sorted(r.follow_modes.items()))))
    return "\n".join(lines)


def plot(result: EvalResult, path: str) -> None:
    """Accuracy vs fraction observed, one line per method and pipeline, as a PNG."""
    plt = pyplot("evaluate_prediction --plot")

    tab = result.table()
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    xs = [100 * f for f in FRACTIONS]
    colours = {"predictor": "tab:blue", "markov": "tab:grey", "heading": "tab:orange"}
    for p, style in (("tracker", "-"), ("ground_truth", "--")):
        for m in METHODS:
            ax.plot(xs, [100 * a for a, _, _ in tab[p][m]], style, marker="o",
                    color=colours[m], label="%s (%s tracks)" % (m, p.replace("_", "-")))
    ax.set_xlabel("% of the leg observed")
    ax.set_ylabel("top-1 destination accuracy (%)")
    ax.set_ylim(0, 100)
    ax.set_title("Destination prediction, %s world, %d legs, seed %d" % (
        result.config.world, len(result.legs), result.config.seed))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
