#!/usr/bin/env python3
"""One observer or predictor default chosen by leaving each world out (issue 33's folds).

Runs the study (bench/eval_worlds.py's tasks, the code ``make eval`` runs) on every world
and seed once with the shipped default and once with each candidate value
(``eval_worlds.py --set SECTION.FIELD=VALUE``), then for each world left out keeps the value
with the best mean score (trk50 by default, pooled over the seeds) on the *other* worlds
(ties: the shipped default, then the first value given) and scores that value on the world
left out. Prints one markdown table: each value's score and tracked share per world, the
fold's pick and its held-out score, the means, and each value's worst share of legs given
up; then a ``FOLDS`` line.

The runs' EVAL lines are kept in ``--out DIR`` (one file per value, a line as each task
ends): a run cut short, or run again with more values or seeds, runs only what is missing.
The default's runs (``default.log``) serve every parameter chosen into the same DIR: use
one DIR per commit.

    .venv/bin/python bench/choose_by_folds.py follow.pass_detour 1 3 --legs 100 --seed 12 13
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Dict, List, Optional, Sequence, Tuple

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, HERE)

from bullet_floor_sim.errors import BulletFloorSimError  # noqa: E402
from bullet_floor_sim.sim.config import world_label  # noqa: E402
import eval_worlds  # noqa: E402

Scores = Dict[str, Dict[str, float]]   # value -> world -> score


def leave_one_out(scores: Scores, worlds: Sequence[str]) -> Dict[str, str]:
    """For each world, the value (a key of ``scores``, in order of preference on a tie)
    with the best summed score over the other worlds."""
    values = list(scores)
    picks = {}
    for w in worlds:
        others = [o for o in worlds if o != w] or [w]
        picks[w] = max(values, key=lambda v: (sum(scores[v][o] for o in others),
                                              -values.index(v)))
    return picks


def parse_eval_line(line: str) -> Optional[dict]:
    """The fields of an ``EVAL key=value ...`` line (numbers as floats), or None."""
    text = line.strip()
    if text.startswith("done: "):
        text = text[len("done: "):]
    if not text.startswith("EVAL "):
        return None
    out: dict = {}
    for item in text.split()[1:]:
        k, _, v = item.partition("=")
        try:
            out[k] = float(v.rstrip("sx"))
        except ValueError:
            out[k] = v
    return out


def read_runs(path: str) -> Dict[Tuple[str, int], dict]:
    """(world, seed) -> the last EVAL line's fields of each task in ``path`` (none: {})."""
    runs: Dict[Tuple[str, int], dict] = {}
    if os.path.exists(path):
        with open(path) as f:
            for line in f:
                r = parse_eval_line(line)
                if r is not None:
                    runs[str(r["world"]), int(r["seed"])] = r
    return runs


def run_value(path: str, sets: dict, worlds: List[str], seeds: List[int], legs: int,
              workers: int) -> Dict[Tuple[str, int], dict]:
    """The EVAL fields of every (world, seed) with ``sets``: those in ``path`` already as
    they are (of ``legs`` legs only), the others run now, each appended as it ends."""
    have = {k: r for k, r in read_runs(path).items() if int(r["legs_asked"]) == legs}
    todo = [(w, s) for w in worlds for s in seeds if (world_label(w), s) not in have]
    if todo:
        print("== %s: %d task(s) to run, %d kept from %s" % (
            os.path.basename(path), len(todo), len(worlds) * len(seeds) - len(todo), path),
            file=sys.stderr, flush=True)

        def keep(r: dict) -> None:
            with open(path, "a") as f:
                f.write(eval_worlds._eval_line(r, None) + " legs_asked=%d\n" % legs)

        eval_worlds.run_tasks(todo, legs, workers=workers, on_row=keep, sets=sets)
    return {k: r for k, r in read_runs(path).items() if int(r["legs_asked"]) == legs}


def pooled(runs: Dict[Tuple[str, int], dict], key: str, world: str, seeds: List[int]) -> float:
    return sum(float(runs[world, s][key]) for s in seeds) / len(seeds)


def table(runs: Dict[str, Dict[Tuple[str, int], dict]], labels: List[str], worlds: List[str],
          seeds: List[int], score: str) -> List[str]:
    """The markdown lines of the folds (``runs``: label -> its EVAL fields)."""
    scores = {v: {w: pooled(runs[v], score, w, seeds) for w in worlds} for v in labels}
    tracked = {v: {w: pooled(runs[v], "tracked", w, seeds) for w in worlds} for v in labels}
    picks = leave_one_out(scores, worlds)
    head = (["world"] + ["%s %s" % (score, v) for v in labels]
            + ["tracked %s" % v for v in labels] + ["fold's pick", "held out %s" % score])
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for w in worlds:
        out.append("| " + " | ".join([w] + ["%.1f" % (100 * scores[v][w]) for v in labels]
                                     + ["%.1f" % (100 * tracked[v][w]) for v in labels]
                                     + [picks[w], "%.1f" % (100 * scores[picks[w]][w])]) + " |")
    n = len(worlds)
    counts = ", ".join("%s: %d" % (v, sum(1 for p in picks.values() if p == v))
                       for v in labels if v in picks.values())
    held = sum(scores[picks[w]][w] for w in worlds) / n
    out.append("| **mean** | " + " | ".join(
        ["%.1f" % (100 * sum(scores[v].values()) / n) for v in labels]
        + ["%.1f" % (100 * sum(tracked[v].values()) / n) for v in labels]
        + [counts, "%.1f" % (100 * held)]) + " |")
    worst = {v: max((float(r["given_up"]), k[0]) for k, r in runs[v].items()) for v in labels}
    out.append("")
    out += ["given up, worst run: %s" % ", ".join("%s %.1f %% (%s)" % (v, 100 * g, w)
                                                  for v, (g, w) in worst.items())]
    out.append("FOLDS score=%s held_out=%.4f default=%.4f picks=\"%s\"" % (
        score, held, sum(scores[labels[0]].values()) / n, counts))
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("param", help="SECTION.FIELD, as eval_worlds.py --set takes it")
    p.add_argument("values", nargs="+", help="the candidates beside the shipped default")
    p.add_argument("--legs", type=int, default=100)
    p.add_argument("--seed", type=int, nargs="+", default=[12])
    p.add_argument("--worlds", nargs="*", default=None,
                   help="names or world.yaml paths (default: as eval_worlds.py)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--score", default="trk50", help="the EVAL field the folds maximise")
    p.add_argument("--out", default="", metavar="DIR",
                   help="where the runs' EVAL lines are kept (default: "
                        "~/.ros/bullet_floor_sim/folds)")
    args = p.parse_args()
    section, _, field = args.param.partition(".")
    try:
        default = set_notes_default(args.param)
        for v in args.values:
            eval_worlds.parse_sets(["%s=%s" % (args.param, v)])
    except BulletFloorSimError as e:
        p.error(str(e))
    out = args.out or os.path.join(os.environ.get("ROS_HOME", os.path.expanduser("~/.ros")),
                                   "bullet_floor_sim", "folds")
    os.makedirs(out, exist_ok=True)
    worlds, notes = eval_worlds.checked(args.worlds or eval_worlds.shipped(),
                                        bool(args.worlds), False)
    for n in notes:
        print("note: %s" % n, file=sys.stderr, flush=True)
    labels = ["%s (default)" % default] + [v for v in args.values if not same(v, default)]
    runs = {}
    for label in labels:
        value = label.split()[0]
        sets = {} if label.endswith("(default)") else {section: {field: value}}
        name = "default" if not sets else "%s=%s" % (args.param, value)
        runs[label] = run_value(os.path.join(out, name + ".log"), sets, worlds, args.seed,
                                args.legs, args.workers)
    print("%s, %d legs, seed(s) %s; each fold keeps the value with the best mean %s on the "
          "other worlds\n" % (args.param, args.legs, " ".join(map(str, args.seed)), args.score))
    names = [world_label(w) for w in worlds]
    for line in table(runs, labels, names, args.seed, args.score):
        print(line)
    return 0


def same(value: str, default: str) -> bool:
    """Whether the text ``value`` is the default's value (as a number when both are)."""
    try:
        return float(value) == float(default)
    except ValueError:
        return value == default


def set_notes_default(param: str) -> str:
    """The shipped default of ``param`` (SECTION.FIELD) as text."""
    section, _, field = param.partition(".")
    cfg = eval_worlds.eval_config("office", 1, 1, False, {})
    config = {"follow": cfg.follower, "prediction": cfg.prediction}.get(section)
    if config is None or not hasattr(config, field):
        eval_worlds.parse_sets(["%s=0" % param])   # raises, naming the section or field
    return repr(getattr(config, field))


if __name__ == "__main__":
    sys.exit(main())
