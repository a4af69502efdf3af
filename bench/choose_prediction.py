#!/usr/bin/env python3
"""Choose the prediction parameters across worlds, leaving the scored world out.

Runs the evaluation (people/evaluation.py, what ``make eval`` runs) once per shipped world with
the default parameters and keeps, for every completed leg, the moments the predictor was asked
at (start region, start, position, velocity at 10/25/50/75/90 % of the leg, from tracker and
ground-truth tracks). Each candidate parameter set then scores those same moments
(:func:`~bullet_floor_sim.people.evaluation.rescore`: the posterior the predictor would have
given). For each world, the set with the best score on the *other* worlds is chosen and its
score on the left-out world reported; the parameter set shipped is the one the folds agree
on (each parameter's value most folds chose). The score is the mean top-1 accuracy over
25/50/75 % observed and both pipelines. Last, the chosen set's top-1 on every world beside the
baselines at 25 % (the earliest fraction the issue's targets name).

    .venv/bin/python bench/choose_prediction.py --legs 100 --seed 2
    .venv/bin/python bench/choose_prediction.py --cache /tmp/moments   # reuse the runs
    .venv/bin/python bench/choose_prediction.py --resume OUT.txt ...     # go on after a cut
    .venv/bin/python bench/choose_prediction.py --grid goal_spacing=0.5,1,2 ...  # other values

``--grid FIELD=V1,V2,...`` (repeatable) searches those values of the PredictionConfig fields
the rescoring sees (BUILT and SET below) instead of GRID; each field's shipped default is
added to its values when not among them, and a tie goes to the shipped defaults. The
calibration's (temperature, prior_mix) is bench/calibrate_prediction.py's.

``--resume`` reads the candidate lines an earlier run printed (same worlds, legs and seed) and
scores only the candidates they lack; the scores of the earlier lines are taken as printed
(only the sets the tables below need are scored again in full).

Use another seed than ``make eval``'s (1), so the table it reports is not the data the
parameters were chosen on.
"""
from __future__ import annotations

import argparse
import itertools
import json
import os
import re
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, HERE)

from bullet_floor_sim.people.evaluation import (FRACTIONS, PIPELINES, EvalConfig,  # noqa: E402
                                              EvalResult, LegScore, rescore, run, world_model)
from bullet_floor_sim.people.prediction import PredictionConfig  # noqa: E402
from bullet_floor_sim.sim.config import world_label  # noqa: E402
from eval_worlds import checked, shipped  # noqa: E402

GRID = {"beta": (2.0, 3.0, 5.0, 8.0), "length_exponent": (0.0, 0.5, 1.0, 1.5),
        "max_goals_per_region": (12, 24)}
# the parameters before this study (no leg-length term)
BEFORE = {"beta": 3.0, "length_exponent": 0.0, "max_goals_per_region": 12}
# the fields a rescore sees (the posterior of S and Q): those that shape the model's goal
# points and distances are built into a model of their own, the others set on it
BUILT = ("max_goals_per_region", "goal_spacing", "clearance", "margin")
SET = ("beta", "length_exponent", "snap_distance")
COLUMNS = ("trk25", "trk50", "trk75", "trk_markov25", "trk_heading25", "gt25", "gt50", "gt75",
           "gt_markov25", "gt_heading25")
SCORED = tuple(FRACTIONS.index(f) for f in (0.25, 0.5, 0.75))


def cache_path(cache: str, world: str, legs: int, seed: int) -> str:
    """Where a run's moments are kept (bench/eval_worlds.py --save writes there too)."""
    return os.path.join(cache, "%s_legs%d_seed%d.json" % (world_label(world), legs, seed))


def save_moments(result: EvalResult, path: str) -> None:
    """A run's legs and their moments, as :func:`recorded` reads them."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path + ".tmp", "w") as f:
        json.dump({"failed": result.failed_legs,
                   "legs": [dict({"number": s.number, "start": s.start_region,
                                  "target": s.target_region, "duration": s.duration},
                                 **{p: s.moments[p] for p in PIPELINES})
                            for s in result.legs]}, f)
    os.replace(path + ".tmp", path)


def recorded(world: str, legs: int, seed: int, cache: str) -> EvalResult:
    """The run's legs with their moments: from the cache file, else run and save."""
    path = cache_path(cache, world, legs, seed)
    cfg = EvalConfig(legs=legs, seed=seed, world=world)
    if os.path.isfile(path):
        with open(path) as f:
            data = json.load(f)
        scored = [LegScore(d["number"], d["start"], d["target"], d["duration"],
                           moments={p: [None if m is None else tuple(m) for m in d[p]]
                                    for p in PIPELINES}) for d in data["legs"]]
        return EvalResult(config=cfg, legs=scored, failed_legs=data["failed"], sim_time=0.0,
                          wall_time=0.0, ticks=0, visible_ticks=0, recalled_ticks=0,
                          tracked_ticks=0, false_track_ticks=0, id_switches=0,
                          mean_track_error=0.0, follow_modes={})
    t0 = time.time()
    last = [t0]

    def progress(line: str) -> None:
        if time.time() - last[0] > 30.0:
            last[0] = time.time()
            print("  %s: %s" % (world, line), file=sys.stderr, flush=True)

    r = run(cfg, progress)
    save_moments(r, path)
    print("  %s: %d legs recorded in %.0f s" % (world, len(r.legs), time.time() - t0),
          file=sys.stderr, flush=True)
    return r


def score(result: EvalResult) -> dict:
    """Top-1 per pipeline and fraction, the mean over the scored fractions, the baselines."""
    tab = result.table()
    out = {"score": sum(tab[p]["predictor"][k][0] for p in PIPELINES for k in SCORED)
           / (len(PIPELINES) * len(SCORED))}
    for p, short in (("tracker", "trk"), ("ground_truth", "gt")):
        for k in SCORED:
            out["%s%d" % (short, round(100 * FRACTIONS[k]))] = tab[p]["predictor"][k][0]
    return out


def resumed(path: str, worlds, grid: dict) -> dict:
    """(name, world) -> {"score": s} from the candidate lines of an earlier run's output
    (a world's name may hold spaces: each world of this run is looked for in the line)."""
    out = {}
    with open(path) as f:
        for line in f:
            words = line.split()
            lead = [w.partition("=") for w in words[:len(grid) + 1]]
            lead = lead[:next((i for i, (_, eq, _) in enumerate(lead) if not eq), len(lead))]
            if not lead or not line.startswith(lead[0][0] + "="):
                continue
            keys = [k for k, _, _ in lead]
            if keys != sorted(grid) or any(float(v) not in grid[k] for k, _, v in lead):
                raise SystemExit("choose_prediction: --resume %s: a candidate line is not of "
                                 "this grid (%s): %s" % (path, ", ".join(sorted(grid)),
                                                         line.strip()[:80]))
            params = " ".join(words[:len(grid)])
            for w in worlds:
                m = re.search(r"(?:^|\s)%s (\S+)" % re.escape(w), line[len(params):])
                if m is None:
                    raise SystemExit("choose_prediction: %s: a candidate line does not score "
                                     "%s: %s" % (path, w, line.strip()[:80]))
                out[params, w] = {"score": float(m.group(1))}
    return out


def candidates(grid: dict):
    keys = sorted(grid)
    for values in itertools.product(*(grid[k] for k in keys)):
        yield dict(zip(keys, values))


def parse_grid(specs) -> dict:
    """{field: values} from ``FIELD=V1,V2,...`` strings; SystemExit naming a bad one."""
    from bullet_floor_sim.errors import BulletFloorSimError

    grid = {}
    for spec in specs:
        field, _, values = spec.partition("=")
        if field not in BUILT + SET:
            raise SystemExit("choose_prediction: --grid %s: %r is not a field the rescoring "
                             "sees (one of %s; temperature and prior_mix are "
                             "calibrate_prediction.py's)" % (spec, field, ", ".join(BUILT + SET)))
        if field in grid:
            raise SystemExit("choose_prediction: --grid %s: %s is given twice" % (spec, field))
        default = getattr(PredictionConfig, field)
        try:
            typed = [type(default)(v) for v in values.split(",")]
            for v in typed:
                PredictionConfig(**{field: v}).check()
        except ValueError:
            raise SystemExit("choose_prediction: --grid %s: values must be %s numbers, "
                             "comma-separated" % (spec, type(default).__name__)) from None
        except BulletFloorSimError as e:
            raise SystemExit("choose_prediction: --grid %s: %s" % (spec, e)) from None
        # the shipped default is always a candidate: the folds may keep it
        grid[field] = tuple(dict.fromkeys(typed + [default]))
    return grid


def name(params: dict) -> str:
    return " ".join("%s=%g" % kv for kv in sorted(params.items()))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--legs", type=int, default=100)
    p.add_argument("--seed", type=int, default=2)
    p.add_argument("--worlds", nargs="*", default=None, help="default: every shipped world")
    p.add_argument("--cache", default=os.path.join(os.environ.get("ROS_HOME", os.path.expanduser(
        "~/.ros")), "bullet_floor_sim", "choose_prediction"))
    p.add_argument("--resume", default=None, metavar="OUT",
                   help="an earlier run's output: its candidates are not scored again")
    p.add_argument("--grid", action="append", default=[], metavar="FIELD=V1,V2",
                   help="search these values (of %s) instead of the study's grid, beside "
                        "the shipped defaults; repeatable" % ", ".join(BUILT + SET))
    args = p.parse_args()
    grid = parse_grid(args.grid) or GRID
    default = {k: getattr(PredictionConfig, k) for k in grid}
    before = default if args.grid else BEFORE
    # of the default list, a world the map check refuses is left out with a line saying so
    worlds, notes = checked(args.worlds or shipped(), bool(args.worlds), False)
    for line in notes:
        print("note: %s" % line, file=sys.stderr)
    runs = {w: recorded(w, args.legs, args.seed, args.cache) for w in worlds}
    scores = resumed(args.resume, worlds, grid) if args.resume else {}  # (name, world) -> dict
    models = {}  # (world, BUILT values) -> model: the SET parameters leave V as it is

    def full(params: dict, w: str) -> dict:
        """The score dict of ``params`` on ``w``: scored now unless already in full."""
        if "trk50" not in scores.get((name(params), w), {}):
            built = tuple((k, params[k]) for k in BUILT if k in params)
            if (w, built) not in models:
                models[w, built] = world_model(w, PredictionConfig(**dict(built)))
            model = models[w, built]
            for k in SET:
                setattr(model.config, k, params.get(k, getattr(PredictionConfig, k)))
            scores[name(params), w] = score(rescore(runs[w], model))
        return scores[name(params), w]

    for params in candidates(grid):
        if all((name(params), w) in scores for w in worlds):
            continue
        for w in worlds:
            full(params, w)
        print("%-36s %s" % (name(params), "  ".join(
            "%s %.3f" % (w, scores[name(params), w]["score"]) for w in worlds)), flush=True)
    names = [name(c) for c in candidates(grid)]
    as_shipped = {name(c): sum(c[k] == default[k] for k in grid) for c in candidates(grid)}
    print()
    print("| left out | chosen on the others | score | trk50 | gt50 | %s: trk50 | gt50 |"
          % ("default" if args.grid else "before"))
    print("|---|---|---|---|---|---|---|")
    picks = []
    for w in worlds:
        others = [o for o in worlds if o != w]
        # to the 3 decimals a resumed line holds, so a resumed run picks as a whole one would;
        # of candidates that tie, the one with most shipped defaults
        best = max(names, key=lambda n: (sum(round(scores[n, o]["score"], 3) for o in others),
                                         as_shipped.get(n, 0)))
        picks.append(next(c for c in candidates(grid) if name(c) == best))
        s, b = full(picks[-1], w), full(before, w)
        print("| %s | %s | %.3f | %.3f | %.3f | %.3f | %.3f |" % (
            w, best, s["score"], s["trk50"], s["gt50"], b["trk50"], b["gt50"]))
    # each parameter: the value most folds chose (the shipped default on a tie, else the
    # first in grid order)
    chosen = {k: max(grid[k], key=lambda v: (sum(1 for c in picks if c[k] == v),
                                             v == default[k])) for k in grid}
    print("\nCHOOSE folds=%d chosen=\"%s\" default=\"%s\"" % (
        len(worlds), name(chosen), name(default)))
    print("\n| world | %s |" % " | ".join(COLUMNS))
    print("|---|" + "---|" * len(COLUMNS))
    for w in worlds:
        model = world_model(w, PredictionConfig(**chosen))
        tab = rescore(runs[w], model).table()
        print("| %s | %s |" % (w, " | ".join("%.1f" % (100 * tab[p][m][k][0])
                                             for p, m, k in _cells())))
    return 0


def _cells():
    """(pipeline, method, fraction index) of the COLUMNS."""
    for col in COLUMNS:
        pipe = "ground_truth" if col.startswith("gt") else "tracker"
        method = col.split("_")[1][:-2] if "_" in col else "predictor"
        yield pipe, method, FRACTIONS.index(int(col[-2:]) / 100.0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
