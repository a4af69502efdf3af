"""The run: the demo's observer scenario in one process (see the package's doc). The agents are
people/agents.py's, the ones the ROS nodes drive; :class:`_Scenario` does per control tick what
the nodes do per message."""
from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ...sim.sensors import Scan
from ...nav.planner import (FollowerConfig, Navigator, NavigatorConfig, PathFollower, PlanError,
                            obstacles_in_base)
from ..agents import FollowerAgent, PredictorAgent, TrackerAgent, WalkerAgent
from ..follow import FollowBehaviour, FollowConfig
from ..markov import MarkovChain
from ..prediction import DestinationModel, OnlinePredictor, PredictionConfig
from ..tracking import TrackerConfig
from ..walker import Walker, WalkerConfig, WalkerError
from ...building import Building, robot_footprint
from .result import EvalConfig, EvalResult, EvaluationError, LegScore
from .scoring import Record, carried, score_leg

__all__ = ["run", "world_model", "ObserverDrive", "refuse_unreachable", "study_world",
           "study_building"]


def run(config: Optional[EvalConfig] = None,
        progress: Optional[Callable[[str], None]] = None) -> EvalResult:
    """Run the study (see the module docstring).

    Args:
        config: parameters.
        progress: called with a line of text after each leg.

    Raises:
        EvaluationError: the world has fewer than two robots or no usable ROIs.
    """
    cfg = config or EvalConfig()
    cfg.check()
    say = progress or (lambda _s: None)
    t_wall = time.time()
    world = study_world(cfg, cfg.seed)
    try:
        return _run(cfg, world, say, t_wall)
    finally:
        world.close()


def study_world_config(cfg: EvalConfig):
    """The WorldConfig of a study: ``cfg.world``'s, with ``cfg.clean``'s changes to its own
    map handling (each value typed as MapHandling's field). Its regions stay the world's
    (its rois file, or ``rois: auto``'s rooms found with the world's own handling), so that
    every map handling is scored against the same destinations."""
    from ...overrides import with_changes
    from ...paths import worlds_dir
    from ...sim.config import load_world_config, resolve_world
    from ...sim.solidmap import MapHandling

    config = load_world_config(resolve_world(cfg.world, worlds_dir()))
    if not cfg.clean:
        return config
    typed = with_changes(MapHandling(), cfg.clean, "clean.")
    handling = replace(config.map_handling, **{k: getattr(typed, k) for k in cfg.clean})
    handling.check("%s: clean" % cfg.world)
    return replace(config, map_handling=handling)


def study_world(cfg: EvalConfig, seed: int):
    """The sim World of a study (study_world_config): the simulator's walls, and so the
    planner's and the tracker's, as ``cfg.clean`` says."""
    from ...sim.world import World

    return World(study_world_config(cfg), seed=seed, physics_rate=100.0)


def study_building(cfg: EvalConfig) -> Building:
    """The Building a study of ``cfg`` plans on (its map handling and planner), without a
    simulator: what the map check before any run looks at."""
    return Building(study_world_config(cfg), planner=cfg.planner_config)


def _regions(world, building=None):
    """The planning grid, the walker's goal sampler, the regions the walker can reach, their
    chain, and the warnings about the map and the regions left out."""
    b = building or Building(world.config, world.fmap)
    fp = robot_footprint()
    sampler = b.sampler(fp)
    rois, warnings = b.regions()
    rois, unreachable = b.walkable(fp)
    chain = MarkovChain.from_rois(rois)
    return (sampler.grid, sampler, rois, chain,
            world.solid.report + warnings + unreachable + chain.warnings)


def refuse_unreachable(world, cfg: EvalConfig, building=None) -> List[str]:
    """The map check of a study (building/check.py) of ``world`` (a sim World, or anything
    with its ``config``, such as a Building): raises EvaluationError naming what the
    walker cannot reach (and the passages, and the fixes) unless ``cfg.allow_unreachable``;
    then returns it as warnings that say the run went on, and the check's own warnings (a
    start close to a wall, one region that is most of the building)."""
    from ...building.check import check_building, refusal, world_study_problems

    b = building or Building(world.config, world.fmap)
    n = len(world.config.robots)
    if max(cfg.walker, cfg.observer) >= n:
        raise EvaluationError("evaluate: world %s has %d robot(s); robots %d and %d are needed"
                              % (cfg.world, n, cfg.walker, cfg.observer))
    report = check_building(b)
    problems = world_study_problems(report, world.config, cfg.walker, cfg.observer)
    if problems and not cfg.allow_unreachable:
        raise EvaluationError(refusal("evaluate: world %s" % cfg.world, problems,
                                      "--allow-unreachable"))
    return (["going on as allowed (--allow-unreachable): %s" % p for p in problems]
            + ["warning: " + w for w in report.warnings()])


def _walks_in_one_region(chain: MarkovChain, walker: Walker, pose, cfg: EvalConfig
                         ) -> List[str]:
    """Raise EvaluationError when the walker starts in a region the chain joins to no other
    (every walk would stay in it, and every prediction would be right) unless
    ``cfg.allow_unreachable``; then the warning that says the run went on."""
    here = walker.origin_region(float(pose[0]), float(pose[1]))
    part = next((p for p in chain.components() if here in p), [here])
    if len(part) > 1 or len(chain.ids) < 2:   # fewer than two: the map check says so
        return []
    why = ('the walker starts in region "%s" (%s), which the chain joins to no other region '
           "(%s): every walk would stay in it" % (here, walker.label(here), chain.isolated_reason))
    if not cfg.allow_unreachable:
        raise EvaluationError("evaluate: world %s: %s. Fixes: draw regions that share "
                              "vertices at their doors (with rois: auto, a region with "
                              "others inside it: rooms: {max_door_width: ...}, docs/rooms.md); "
                              "move the walker's start; or allow it with --allow-unreachable"
                              % (cfg.world, why))
    return ["going on as allowed (--allow-unreachable): %s" % why]


def world_model(world_name: str, prediction: Optional[PredictionConfig] = None
                ) -> DestinationModel:
    """The destination model :func:`run` builds for a world (its regions the walker can
    reach, their chain, its planning grid) with the given prediction parameters."""
    from ...sim.world import World

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
        building = Building(world.config, world.fmap, cfg.planner_config)
        allowed = refuse_unreachable(world, cfg, building)
        grid, sampler, rois, chain, self.warnings = _regions(world, building)
        self.warnings = allowed + self.warnings
        self.model = model = DestinationModel(grid, rois, chain, cfg.prediction)
        self.uniform = {r: 1.0 / len(chain.ids) for r in chain.ids}
        # the agents the nodes run: markov_walker, people_tracker (observer.launch's
        # centre_offset for the Scitos body), destination_predictor, follower
        walker = Walker(chain, rois, sampler, WalkerConfig(), seed=cfg.seed)
        self.warnings += _walks_in_one_region(chain, walker, world.pose[cfg.walker], cfg)
        self.walker = WalkerAgent(walker)
        self.tracker = TrackerAgent.for_map(world.fmap, cfg.tracker_config or study_tracker(),
                                            handling=world.config.map_handling)
        follow = cfg.follow_config or FollowConfig()
        self.predictor = PredictorAgent(model, follow)
        self.follower = FollowerAgent(FollowBehaviour(grid, follow))
        # path_follower in each namespace; the observer's yields (demo.launch's ~give_way)
        nav = cfg.nav_config or NavigatorConfig()   # each robot's role set on it, as launched
        self.nav_walker = Navigator(grid, PathFollower(), replace(nav, keep_way=True))
        self.drive = ObserverDrive(world, cfg.observer, grid, cfg.drive_config, nav)
        self.pred_gt = OnlinePredictor(model)   # the same predictor on the walker's truth
        self.laser = [world.models[i].laser_pose for i in range(world.n)]  # x, y, z, yaw
        self.body = float(world.radius[cfg.walker])  # the walker's footprint radius
        self.scans: Dict[int, object] = {}
        self.gt_records: List[Record] = []
        self.trk_records: List[Record] = []
        self.n_ticks = self.visible = self.recalled = self.tracked = 0
        self.false_ticks = self.switches = self.failed = self.short = 0
        self.err_sum = 0.0
        self.completed: List[LegScore] = []
        self.t0 = world.clock.now
        self.dwell_since = self.t0   # when the walker's last leg ended (it stands since)
        self.setup_time = time.time() - t_wall   # world, map check, the predictor's distances

    def tick(self, steps: int) -> None:
        """Step the world one control period, then the walker, the ground-truth predictor
        and the observer in turn."""
        world, cfg = self.world, self.cfg
        for s in world.step(steps):
            if isinstance(s, Scan):     # (the lidars' readings; other sensors' are not used)
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
            self.gt_records.append(Record(t, p, (x, y), vel))
        self._observe(t, (x, y), world.view(cfg.observer, refresh=False).pose)

    def _walk(self, t: float, pose: Sequence[float]) -> None:
        """The walker (markov_walker + path_follower): a leg, its navigation, its end."""
        W, agent = self.cfg.walker, self.walker
        if agent.leg is None:
            try:
                step = agent.tick(t, pose)
            except WalkerError as e:
                raise EvaluationError("evaluate: the walker cannot go on: %s" % e)
            if step.start is None or not self._send(t, pose, step.start, True):
                return
        st = self.nav_walker.update(pose, _obstacles(self.scans.get(W), self.laser[W]), t)
        result = None if st.state == "active" else (
            ("succeeded", "") if st.state == "succeeded" else ("aborted", st.message))
        step = agent.tick(t, pose, result)
        if step.finished is None and not step.regoal:
            self.world.command(W, st.v, 0.0, st.w)
            return
        self.world.command(W, 0.0, 0.0, 0.0)
        if step.regoal:
            self._send(t, pose, step.start, False)
            return
        if step.cancel:
            self.nav_walker.cancel()
        self._leg_ended(t, step)

    def _send(self, t: float, pose: Sequence[float], leg, new_leg: bool) -> bool:
        """Start the navigation to the leg's goal; a goal it cannot plan to is aborted (the
        walker may give it another goal; else the leg ends). A new leg's predictions start
        afresh, but for one of this leg made while the walker stood (scoring.carried)."""
        try:
            self.nav_walker.start(pose, leg.goal, t)
        except PlanError as e:   # path_follower aborts such a goal (a new goal may follow)
            step = self.walker.tick(t, pose, ("aborted", str(e)))
            if step.regoal:
                return self._send(t, pose, step.start, new_leg)
            self._leg_ended(t, step)
            return False
        if new_leg:
            self.gt_records = carried(self.gt_records, self.dwell_since)
            self.trk_records = carried(self.trk_records, self.dwell_since)
        return True

    def _leg_ended(self, t: float, step) -> None:
        leg = step.finished
        self.dwell_since = t
        if leg.outcome == "succeeded" and leg.way < self.cfg.min_leg_path:
            self.short += 1
            where = " (not scored: a way of %.2f m)" % leg.way
        elif leg.outcome == "succeeded":
            self.completed.append(score_leg(leg, self.gt_records, self.trk_records, self.model,
                                         self.uniform))
            where = ""
        else:
            self.failed += 1
            where = self._observer_line()
        self.say("%s%s  [%d/%d scored, %.0f s sim, %.0f s wall]" % (
            step.line, where, len(self.completed), self.cfg.legs, t - self.t0,
            time.time() - self.t_wall))

    def _observer_line(self) -> str:
        """Where the observer stood when a leg was given up (it is what most often blocks
        the walker): its distance from the walker, its mode and its wall clearance."""
        ow = self.world.view(self.cfg.observer, refresh=False).pose
        ww = self.world.view(self.cfg.walker, refresh=False).pose
        return "; the observer %.2f m away at (%.2f, %.2f), %s, %.2f m from walls" % (
            math.hypot(ow[0] - ww[0], ow[1] - ww[1]), ow[0], ow[1], self.follower.behaviour.mode,
            self.drive.nav.grid.clearance_at(ow[0], ow[1]))

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
            near: Union[np.ndarray, List[bool]]
            near = np.hypot(pts[:, 0] - x, pts[:, 1] - y) < self.body + 0.1 if len(pts) else []
            visible = int(np.count_nonzero(near)) >= cfg.visible_beams
        pstep = self.predictor.tick(t, [(tr.id, tr.x, tr.y, tr.vx, tr.vy) for tr in tracks])
        lost = self.follower.target_id
        if cfg.follow:
            plans = {tid: plan for tid, (_p, plan) in pstep.destinations.items()}
            fstep = self.follower.tick(t, pose_o, tracks, plans, self.drive.goal_done)
            self.drive(t, pose_o, fstep.decision, scan_o)
        else:
            fstep = self.follower.pick(tracks)
            self.world.command(OBS, 0.0, 0.0, 0.0)
        target = fstep.target
        self.predictor.follower_switched(lost, fstep)
        self.switches += 1 if fstep.switched else 0
        if target is not None and target.id in pstep.destinations:
            self.trk_records.append(Record(t, pstep.destinations[target.id][0],
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

    def result(self) -> EvalResult:
        tracked = self.tracked
        return EvalResult(config=self.cfg, legs=self.completed, failed_legs=self.failed,
                          sim_time=self.world.clock.now - self.t0,
                          wall_time=time.time() - self.t_wall, ticks=self.n_ticks,
                          visible_ticks=self.visible, recalled_ticks=self.recalled,
                          tracked_ticks=tracked, false_track_ticks=self.false_ticks,
                          id_switches=self.switches, handovers=self.predictor.handovers,
                          mean_track_error=self.err_sum / tracked if tracked else float("nan"),
                          follow_modes=self.drive.modes, warnings=self.warnings,
                          short_legs=self.short,
                          setup_time=self.setup_time)


#: The tracker's centre offset for the Scitos A5 body that stands in for the person
#: (TrackerConfig.centre_offset; as observer.launch's people_tracker).
SCITOS_CENTRE_OFFSET = 0.25


def study_tracker() -> TrackerConfig:
    """The people tracker as the study runs it (observer.launch's people_tracker)."""
    return TrackerConfig(centre_offset=SCITOS_CENTRE_OFFSET)


#: The observer backs up to a goal this close behind it (FollowerConfig.reverse_within; as
#: demo.launch's observer, ``~reverse_within``): it gives way facing the target.
OBSERVER_REVERSE = 2.0
#: ... and along a path this long to a goal that faces back the way there
#: (FollowerConfig.reverse_path, ``~reverse_path``): round a corner too (docs/defaults.md).
OBSERVER_REVERSE_PATH = 6.0


#: ... and it is less fussy than FollowerConfig's defaults (which the walker keeps): it
#: counts a goal reached 0.25 m off, turns on the spot only beyond 1.3 rad (which also
#: lets it back up to a goal whose heading is that far off its own), slows within 0.5 m of
#: a goal, and stops for what is 0.15 m ahead, within its footprint's radius (demo.launch:
#: config/observer_drive.yaml, by the path_follower's parameter names; chosen together by
#: folds over the corpus, docs/defaults.md section 3c).
OBSERVER_DRIVE = {"xy_tolerance": 0.25, "rotate_in_place": 1.3, "slow_radius": 0.5,
                  "stop_distance": 0.15, "side_margin": 0.0}


def observer_follower() -> FollowerConfig:
    """The observer's path following as shipped (demo.launch's robot2 path_follower)."""
    return FollowerConfig(reverse_within=OBSERVER_REVERSE, reverse_path=OBSERVER_REVERSE_PATH,
                          **OBSERVER_DRIVE)


class ObserverDrive:
    """The observer's navigation (its path_follower, yielding as demo.launch's ~give_way)
    towards the follower's goals, and the follower node's ``goal_done`` (the last goal sent
    is over, until the next); ``modes`` counts the follower's decisions by mode.
    ``config``: its path following (default: :func:`observer_follower`); ``nav``: its
    recovery (default: NavigatorConfig()), with ``give_way`` set on it."""

    def __init__(self, world, observer: int, grid, config: Optional[FollowerConfig] = None,
                 nav: Optional[NavigatorConfig] = None) -> None:
        self.world, self.observer = world, observer
        self.laser = world.models[observer].laser_pose
        self.nav = Navigator(grid, PathFollower(config or observer_follower()),
                             replace(nav or NavigatorConfig(), give_way=True))
        self.goal_active = self.goal_done = False
        self.modes: Dict[str, int] = {}

    def __call__(self, t: float, pose_o: Sequence[float], dec, scan_o) -> None:
        OBS = self.observer
        self.modes[dec.mode] = self.modes.get(dec.mode, 0) + 1
        if dec.goal is not None:
            try:
                self.nav.start(pose_o, dec.goal, t)
                self.goal_active, self.goal_done = True, False
            except PlanError:
                self.goal_active, self.goal_done = False, True
        if not self.goal_active:
            self.world.command(OBS, 0.0, 0.0, 0.0)
            return
        st = self.nav.update(pose_o, _obstacles(scan_o, self.laser), t)
        if st.state == "active":
            self.world.command(OBS, st.v, 0.0, st.w)
        else:
            self.world.command(OBS, 0.0, 0.0, 0.0)
            self.goal_active, self.goal_done = False, True


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
