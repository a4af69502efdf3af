"""``rosrun bullet_floor_sim evaluate_prediction --legs N --seed S``: the prediction study.

Runs the demo's observer scenario headless and faster than real time (people/evaluation.py: the
walker robot walks N legs by the Markov chain, the observer robot tracks it with its lidar,
follows it, and predicts where each leg ends), then prints, for the predictor and the two
baselines (Markov prior alone; nearest region along the current heading), the top-1 accuracy
and the log-loss of the destination at 10/25/50/75/90 % of each leg observed, from the
tracker's tracks and from ground-truth tracks, plus the tracking scores; and writes the
accuracy-vs-fraction plot as a PNG (``--plot``, default
``$ROS_HOME/bullet_floor_sim/prediction_<world>_<legs>_<seed>.png``).

No roscore is needed: the nodes' core code runs in one process, deterministically for a seed.
The last line is machine-readable::

    EVAL legs=<n> acc50=<predictor, tracker> acc50_gt=<...> markov50=<...> heading50=<...> \
recall=<...> tracked=<...>

With ``--people N`` (and ``--seconds``, ``--chosen``) N people walk the regions instead
(people/evaluation/crowd_run.py): the table has a row per person and one overall, with the
CLEAR MOT scores of the tracker; the plot (default ``people_<world>_<N>_<seed>.png``) the
accuracy vs fraction of every person's legs and of the followed one's; the last line is
``EVAL people=<n> legs=<n> mota=... motp=... switches=... acc50=... ...``.
"""
from __future__ import annotations

import os
import sys
from typing import List, Optional

from ..errors import BulletFloorSimError
from ..people.evaluation import EvalConfig, FRACTIONS, format_table, plot, run
from .cli import Parser, UsageError

__all__ = ["main"]


def _default_plot(world: str, count: int, seed: int, kind: str = "prediction") -> str:
    """$ROS_HOME/bullet_floor_sim/<kind>_<world>_<legs or people>_<seed>.png"""
    home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    from ..sim.config import world_label

    name = world_label(world)
    return os.path.join(home, "bullet_floor_sim", "%s_%s_%d_%d.png" % (kind, name, count, seed))


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point; returns the exit status (2 for bad arguments or input)."""
    p = Parser(prog="evaluate_prediction", description=__doc__.split("\n\n")[1])
    p.add_argument("--legs", type=int, default=200, help="walker legs to complete (200)")
    p.add_argument("--seed", type=int, default=1, help="seed of the whole run (1)")
    p.add_argument("--world", default="office", help="world name or world.yaml (office)")
    p.add_argument("--plot", default=None, help="PNG path ('' = no plot)")
    p.add_argument("--no-follow", action="store_true",
                   help="the observer stays where it is (tracker-only baseline)")
    p.add_argument("--quiet", action="store_true", help="no line per leg")
    p.add_argument("--allow-unreachable", action="store_true",
                   help="run even when the walker cannot reach a region or the observer the "
                        "walker (check_world); the output says so")
    p.add_argument("--people", type=int, default=0,
                   help="N > 0: N people walk the regions instead of the walker robot; the "
                        "observer tracks them all and follows --chosen (0: the walker robot)")
    p.add_argument("--seconds", type=float, default=600.0,
                   help="with --people: sim seconds to run (600)")
    p.add_argument("--chosen", type=int, default=1, help="with --people: the person followed (1)")
    try:
        args = p.parse_args(sys.argv[1:] if argv is None else argv)
        if args.legs < 1:
            raise UsageError("--legs must be >= 1, got %d" % args.legs)
    except UsageError as e:
        print("evaluate_prediction: %s" % e, file=sys.stderr)
        return 2
    say = None if args.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
    if args.people:
        return _people(args, say)
    cfg = EvalConfig(legs=args.legs, seed=args.seed, world=args.world,
                     follow=not args.no_follow, allow_unreachable=args.allow_unreachable)
    try:
        result = run(cfg, say)
    except BulletFloorSimError as e:
        print("evaluate_prediction: %s" % e, file=sys.stderr)
        return 2
    print(format_table(result))
    path = _default_plot(args.world, args.legs, args.seed) if args.plot is None else args.plot
    if path:
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        plot(result, path)
        print("plot: %s" % path)
    tab, change = result.table(), result.table("change")
    k = FRACTIONS.index(0.50)
    print("EVAL legs=%d acc50=%.3f acc50_gt=%.3f markov50=%.3f heading50=%.3f "
          "change_legs=%d change_acc50=%.3f change_markov50=%.3f change_heading50=%.3f "
          "recall=%.3f tracked=%.3f" % (
              len(result.legs), tab["tracker"]["predictor"][k][0],
              tab["ground_truth"]["predictor"][k][0], tab["tracker"]["markov"][k][0],
              tab["tracker"]["heading"][k][0], len(result.legs_of("change")),
              change["tracker"]["predictor"][k][0], change["tracker"]["markov"][k][0],
              change["tracker"]["heading"][k][0], result.recall, result.tracked_share))
    return 0


def _people(args, say) -> int:
    """``--people N``: the people run, a row per person and overall."""
    from ..people.evaluation.crowd_run import (CrowdEvalConfig, format_crowd, plot_crowd,
                                               run_crowd)

    try:
        cfg = CrowdEvalConfig(people=args.people, sim_time=args.seconds, seed=args.seed,
                              world=args.world, chosen=args.chosen - 1,
                              follow=not args.no_follow)
        result = run_crowd(cfg, say)
    except BulletFloorSimError as e:
        print("evaluate_prediction: %s" % e, file=sys.stderr)
        return 2
    print(format_crowd(result))
    path = (_default_plot(args.world, args.people, args.seed, "people") if args.plot is None
            else args.plot)
    if path:
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        plot_crowd(result, path)
        print("plot: %s" % path)
    m = result.mot
    print("EVAL people=%d legs=%d mota=%.3f motp=%.3f switches=%d acc50=%.3f acc50_seen=%.3f "
          "acc50_gt=%.3f chosen_acc50=%.3f seen50=%.3f" % (
              args.people, sum(len(v) for v in result.legs.values()), m.mota, m.motp,
              m.switches, result.accuracy(), result.accuracy(seen=True),
              result.accuracy(pipeline="ground_truth"),
              result.accuracy(result.names[cfg.chosen]), result.seen_share()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
