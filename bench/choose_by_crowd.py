#!/usr/bin/env python3
"""One predictor or observer default chosen by leaving each world out, on the people study
(``evaluate_prediction --people N``: people/evaluation/crowd_run.run_crowd, N people walk
the regions and the observer tracks them all and follows one).

The one-walker study (bench/choose_by_folds.py) cannot weigh a value whose cost lies in
telling people apart: with one walker, every new track is the walker. Here each world and
value runs once (``--people``, ``--seconds``, ``--seed``) with the value set on the
shipped config (``prediction.FIELD``: the predictors' PredictionConfig; ``follow.FIELD``:
the observer's FollowConfig). Each fold keeps the value with the best summed score on the
other worlds (choose_by_folds.leave_one_out; a tie: the shipped default, then the first
value given) and scores it on the world left out. The score (``--score``) is ``acc50``
by default: the share of every person's completed legs whose destination the tracker
pipeline had right at 50 % (a leg with no prediction counts as wrong, so a value gains
nothing by predicting less). Prints a markdown table and a ``FOLDS`` line.

Each run's ``CROWD`` line is kept in ``--out LOG`` as it ends: a run cut short, or run
again with more values, runs only what is missing (one LOG for one commit: the lines do
not say which code made them). The default's runs are of the config as shipped. The map
check leaves out the worlds the one-walker study leaves out, with a note.

    .venv/bin/python bench/choose_by_crowd.py prediction.handover_time 10 --people 20 \\
        --seed 13 --out /tmp/crowd13.log
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Dict, List, Optional

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, HERE)

from bullet_floor_sim.errors import BulletFloorSimError  # noqa: E402
from bullet_floor_sim.overrides import with_changes  # noqa: E402
from bullet_floor_sim.people.evaluation.crowd_run import CrowdEvalConfig, run_crowd  # noqa: E402
from bullet_floor_sim.people.follow import FollowConfig  # noqa: E402
from bullet_floor_sim.people.prediction import PredictionConfig  # noqa: E402
from bullet_floor_sim.sim.config import world_label  # noqa: E402
from choose_by_folds import leave_one_out, parse_eval_line  # noqa: E402
from eval_worlds import checked, shipped  # noqa: E402

#: --param's sections: the CrowdEvalConfig field each sets, and that config as shipped.
SECTIONS = {"prediction": ("prediction", PredictionConfig), "follow": ("follow_config",
                                                                       FollowConfig)}
SCORES = ("acc50", "acc50_seen", "mota")


def crowd_line(world: str, param: str, value: str, args, shipped: bool = False) -> str:
    """One run of the people study with ``param`` = ``value`` (``shipped``: the config as
    shipped, unchanged, ``value`` its label): its ``CROWD`` line."""
    section, field = param.split(".", 1)
    attr, cls = SECTIONS[section]
    changes = {} if shipped else {field: value}
    cfg = CrowdEvalConfig(people=args.people, sim_time=args.seconds, seed=args.seed,
                          world=world, chosen=0,
                          **{attr: with_changes(cls(), changes, section + ".")})
    r = run_crowd(cfg, None)
    return ("CROWD world=%s param=%s value=%s people=%d seconds=%g seed=%d legs=%d "
            "acc50=%.4f acc50_seen=%.4f acc50_gt=%.4f seen50=%.4f mota=%.4f switches=%d "
            "wall=%.0f" % (world_label(world), param, value, args.people, args.seconds,
                           args.seed, sum(len(v) for v in r.legs.values()), r.accuracy(),
                           r.accuracy(seen=True), r.accuracy(pipeline="ground_truth"),
                           r.seen_share(), r.mot.mota, r.mot.switches, r.wall_time))


def parse_line(line: str, args) -> Optional[dict]:
    """The fields of a CROWD line of this param, people, seconds and seed, or None."""
    d = parse_eval_line(line.replace("CROWD ", "EVAL ", 1),
                        ("world", "param", "value", "people", "seconds", "seed"))
    if d and d["param"] == args.param and (d["people"], "%g" % d["seconds"], d["seed"]) == (
            args.people, "%g" % args.seconds, args.seed):
        return d
    return None


def kept(path: str, args) -> Dict[tuple, dict]:
    """(world, value) -> the fields of a CROWD line of this param, people, seconds and seed."""
    out = {}
    if os.path.isfile(path):
        with open(path) as f:
            for d in filter(None, (parse_line(line, args) for line in f)):
                out[d["world"], "%g" % d["value"]] = d
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("param", help="SECTION.FIELD, a number (sections: %s)" % ", ".join(SECTIONS))
    p.add_argument("values", nargs="+", help="the candidates beside the shipped default")
    p.add_argument("--people", type=int, default=20)
    p.add_argument("--seconds", type=float, default=600.0, help="sim seconds a run")
    p.add_argument("--seed", type=int, default=13)
    p.add_argument("--worlds", nargs="*", default=None)
    p.add_argument("--score", choices=SCORES, default="acc50")
    p.add_argument("--out", required=True, help="the runs' CROWD lines (kept, appended)")
    args = p.parse_args()
    section = args.param.split(".", 1)[0]
    if section not in SECTIONS or "." not in args.param:
        sys.exit("choose_by_crowd: %s: expected SECTION.FIELD, SECTION one of %s"
                 % (args.param, ", ".join(SECTIONS)))
    try:
        shipped_value = getattr(SECTIONS[section][1](), args.param.split(".", 1)[1])
    except AttributeError:
        sys.exit("choose_by_crowd: %s: no such field" % args.param)
    try:
        values = ["%g" % shipped_value] + [v for v in ("%g" % float(x) for x in args.values)
                                           if v != "%g" % shipped_value]
    except (TypeError, ValueError):
        sys.exit("choose_by_crowd: %s: numbers only (got %s)" % (args.param, args.values))
    worlds, notes = checked(args.worlds or shipped(), bool(args.worlds), False)
    for line in notes:
        print("note: %s" % line, file=sys.stderr)
    runs = kept(args.out, args)
    for w in worlds:
        for v in values:
            if (world_label(w), v) in runs:
                continue
            try:
                line = crowd_line(w, args.param, v, args, shipped=v == values[0])
            except BulletFloorSimError as e:
                sys.exit("choose_by_crowd: %s, %s=%s: %s" % (world_label(w), args.param, v, e))
            print(line, flush=True)
            with open(args.out, "a") as f:
                f.write(line + "\n")
            runs[world_label(w), v] = parse_line(line, args)
    report([world_label(w) for w in worlds], values, runs, args)
    return 0


def report(worlds: List[str], values: List[str], runs: Dict[tuple, dict], args) -> None:
    """The fold table and the FOLDS line."""
    scores = {v: {w: runs[w, v][args.score] for w in worlds} for v in values}
    blank = ["%s %s=%s" % (w, args.param, v) for v in values for w in worlds
             if math.isnan(scores[v][w])]
    if blank:   # nan: no leg completed, none seen, or nobody in view
        sys.exit("choose_by_crowd: no %s for %s: more people or seconds, or another score"
                 % (args.score, ", ".join(blank)))
    picks = leave_one_out(scores, worlds)
    print("\n%s, people study (%d people, %g s, seed %d); each fold keeps the value with the "
          "best summed %s on the other worlds\n" % (args.param, args.people, args.seconds,
                                                    args.seed, args.score))
    print("| world | %s | %s | fold's pick | held out |" % (
        " | ".join("%s %s" % (args.score, v) for v in values),
        " | ".join("seen50 %s" % v for v in values)))
    print("|---|" + "---|" * (2 * len(values) + 2))
    for w in worlds:
        print("| %s | %s | %s | %s | %.1f |" % (
            w, " | ".join("%.1f" % (100 * scores[v][w]) for v in values),
            " | ".join("%.1f" % (100 * runs[w, v]["seen50"]) for v in values), picks[w],
            100 * scores[picks[w]][w]))
    held = sum(scores[picks[w]][w] for w in worlds) / len(worlds)
    mean = {v: sum(scores[v].values()) / len(worlds) for v in values}
    cells = ["%.1f" % (100 * mean[v]) for v in values] + [""] * (len(values) + 1)
    print("| **mean** | %s | %.1f |" % (" | ".join(cells), 100 * held))
    votes = {v: sum(1 for w in worlds if picks[w] == v) for v in values}
    print("\nFOLDS score=%s held_out=%.4f default=%.4f picks=\"%s\"" % (
        args.score, held, mean[values[0]], ", ".join("%s: %d" % (v, n) for v, n in votes.items()
                                                     if n)))


if __name__ == "__main__":
    sys.exit(main())
