"""The evaluation's parameters and what a run measured: EvalConfig, LegScore, EvalResult, and
the fractions, methods and pipelines it scores."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

from ...errors import BulletFloorSimError
from ...sim.checks import check_integers, check_numbers
from ...nav.grid import PlannerConfig
from ...nav.navigator import NavigatorConfig
from ...nav.pursuit import FollowerConfig
from ..follow_config import FollowConfig
from ..prediction import PredictionConfig
from ..tracking import TrackerConfig

__all__ = ["EvalConfig", "EvalResult", "LegScore", "EvaluationError", "FRACTIONS", "METHODS",
           "PIPELINES", "LEG_KINDS", "Moment"]

FRACTIONS = (0.10, 0.25, 0.50, 0.75, 0.90)
METHODS = ("predictor", "markov", "heading")
PIPELINES = ("tracker", "ground_truth")
LEG_KINDS = ("all", "change", "stay")
Moment = Tuple[str, float, float, float, float, float, float]


class EvaluationError(BulletFloorSimError):
    """The evaluation cannot run (bad parameters, a world without two robots or ROIs)."""


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
        follow_config: the observer's parameters, the follower's and the search plan's the
            predictor makes (default: FollowConfig(), what the follower and
            destination_predictor nodes run with).
        drive_config: the observer's path following (default: the shipped one,
            scenario.observer_follower(), as demo.launch's robot2 path_follower).
        tracker_config: the people tracker's parameters (default: scenario.study_tracker(),
            observer.launch's people_tracker: the centre offset of the Scitos body).
        nav_config: both robots' navigation: recovery, replanning and passing (default:
            NavigatorConfig()); each robot's role is set on it as demo.launch does (the
            walker ``keep_way``, the observer ``give_way``).
        planner_config: the planning grid of both robots and of the predictor's distances
            (default: PlannerConfig(), what the nodes plan with); its ``robot_radius`` is
            the robots' footprint.
        clean: changes to each world's own map handling (MapHandling fields, world.yaml's
            ``clean`` keys: field -> value), for the simulator, the planner and the
            tracker alike (default: none, the world as its world.yaml says). The regions
            stay the world's: ``rois: auto`` rooms are found with its own handling.
        allow_unreachable: run even when the map check (building/check.py) finds a region
            the walker cannot reach or an observer cut off from it (else the run refuses);
            what it found is then among the result's warnings.
        min_leg_path: a leg whose planned way is shorter than this (m, about a body's
            width) is not scored (nor counted as given up): a stay a few centimetres off has
            nothing to observe at any fraction, and in a small room of seattle 17 of 40 legs
            (seed 1) were such stays of 0 s, each scored a miss by every method. With 1 m,
            stays of 0.3-1 m that take seconds (the prior's easy hits) went unscored too, and
            trk50 fell by up to 15 points a world (acapulco_convention, seed 2).
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
    follow_config: Optional[FollowConfig] = None
    drive_config: Optional[FollowerConfig] = None
    tracker_config: Optional[TrackerConfig] = None
    nav_config: Optional[NavigatorConfig] = None
    planner_config: Optional[PlannerConfig] = None
    clean: Optional[Dict[str, object]] = None
    allow_unreachable: bool = False
    min_leg_path: float = 0.25

    def check(self) -> None:
        check_integers(self, ("legs",), "evaluate", error=EvaluationError)
        if self.walker == self.observer:
            raise EvaluationError("evaluate: walker and observer must be different robots")
        check_numbers(self, ("control_rate", "match_distance"), "evaluate", error=EvaluationError)
        check_numbers(self, ("min_leg_path",), "evaluate", strict=False, error=EvaluationError)
        for config in (self.drive_config, self.tracker_config, self.nav_config,
                       self.planner_config):
            if config is not None:
                config.check()
        if self.clean:   # each name a field of the map handling, each value of its type
            from ...overrides import with_changes
            from ...sim.solidmap import MapHandling

            with_changes(MapHandling(), self.clean, "clean.")


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
    short_legs: int = 0   # legs done but not scored (planned way under min_leg_path)
    warnings: List[str] = field(default_factory=list)  # the map's handling, regions left out
    setup_time: float = 0.0   # wall s of wall_time before the first tick (world, check, model)

    @property
    def rtf(self) -> float:
        """Sim seconds per wall second of the run's ticks (its setup not counted)."""
        return self.sim_time / max(self.wall_time - self.setup_time, 1e-9)

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
