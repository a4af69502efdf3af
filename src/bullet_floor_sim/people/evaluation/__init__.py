"""The destination-prediction study: how much of a leg must be seen before its goal is right.

:func:`run` plays the demo's observer scenario in one process, headless and as fast as the CPU
allows: the world's first robot walks region to region by the Markov chain (people/walker.py,
driven by the embedded navigator, as ``markov_walker`` + ``path_follower`` do), the second
robot detects and tracks it with its own lidar (people/tracking.py, localised from ground truth),
follows it and searches the predicted region when it loses it (people/follow.py), and the
predictor (people/prediction.py) estimates the destination of the current leg on every track
update. The same predictor also runs on the walker's ground-truth trajectory, so that tracking
error and prediction error can be told apart.

The walker, tracker, predictor and follower are people/agents.py's agents, the objects the
ROS nodes drive, and the navigation is path_follower's Navigator: the nodes' code without the
transport. A run is deterministic for a seed and takes minutes instead of the hours that 200
legs would take through roslaunch.

Modules: result.py (EvalConfig, LegScore, EvalResult), scenario.py (:func:`run`: the world
and the agents, one control tick at a time), scoring.py (a leg's scores, :func:`rescore`),
report.py (:func:`format_table`, :func:`plot`).

For each leg the walker completes, at 10/25/50/75/90 % of its duration, the latest prediction
of each pipeline (tracker, ground truth) is scored against the leg's destination region for
the predictor and two baselines (the Markov prior alone; the nearest region along the current
heading): top-1 accuracy and log-loss. A prediction of the current leg is one made since the
leg began, or the last one made while the walker stood before it, if that one predicts the
leg to come (scoring.carried: the observer saw it stand, then lost it before it set off). A leg
moment without any prediction of the current leg counts as a miss, with the uniform
distribution over the chain's regions for the log-loss.

Tracking is scored on every control tick: recall while the walker is visible to the observer
(at least ``visible_beams`` beams of the observer's scan end on the walker's body), the share
of the whole run during which the walker is tracked (a confirmed track within
``match_distance`` of it), and confirmed tracks matching nothing (false tracks).
"""
from .report import format_table, plot
from .result import (FRACTIONS, LEG_KINDS, METHODS, PIPELINES, EvalConfig, EvalResult,
                     EvaluationError, LegScore)
from .scenario import run, world_model
from .scoring import Record, carried, rescore, score_leg

__all__ = ["EvalConfig", "EvalResult", "LegScore", "EvaluationError", "run", "world_model",
           "rescore", "score_leg", "carried", "Record", "format_table", "plot", "FRACTIONS",
           "METHODS", "PIPELINES", "LEG_KINDS"]
