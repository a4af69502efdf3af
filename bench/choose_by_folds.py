#!/usr/bin/env python3
"""One observer or predictor default chosen by leaving each world out (issue 33's folds).

Runs the study (bench/eval_worlds.py's tasks, the code ``make eval`` runs) on every world
and seed once with the shipped default and once with each candidate value
(``eval_worlds.py --set SECTION.FIELD=VALUE``), then for each world left out keeps the value
with the best mean score (trk50 by default: each world's mean over the seeds, to the 3
decimals an EVAL line has) on the *other* worlds (ties: the shipped default, then the first
value given) and scores that value on the world left out. Prints one markdown table: each
value's score and tracked share per world, the fold's pick and its held-out score, the
means, each value's worst share of legs given up, which values the given-up bar kept out
of how many folds, and a ``FOLDS`` line. A value that gave up more than ``--max-given-up``
of its legs (the study's bar, 2 %) in any one run on a world a fold learns from is not that
fold's pick (the shipped default always may be). With ``--bars``, neither is a value
with a run under any other of the issue's bars there (bench/eval_bars.py: tracked, trk50,
gt50, the margins); the table names those runs.

Each world is checked before any run (eval_worlds.py's map check); for a ``clean`` or
``planner`` field, with each value too: a world that any value makes refuse is left out of
every value's runs, with a note (a world named with ``--worlds`` stops it instead).

With ``--together`` the arguments are ``SECTION.FIELD=VALUE`` changes, tried as one
candidate (all at once, labelled ``together``) against the shipped defaults: the folds then
say whether the change as a whole holds on each world left out.

The runs' EVAL lines are kept in ``--out DIR`` (default: one directory per commit under
~/.ros/bullet_floor_sim/folds; one file per value, a line as each task ends): a run cut
short, or run again with more values or seeds, runs only what is missing. The default's
runs (``default.log``) serve every parameter chosen into the same DIR. A task that fails
stops the run; the lines of the tasks done stay.

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
from bullet_floor_sim.overrides import convert  # noqa: E402
from bullet_floor_sim.sim.config import world_label  # noqa: E402
import eval_worlds  # noqa: E402
from eval_results import checkout_commit  # noqa: E402

Scores = Dict[str, Dict[str, float]]   # value -> world -> score
#: The EVAL fields a fold can maximise (higher is better in each).
SCORES = ("trk25", "trk50", "trk75", "gt25", "gt50", "gt75", "margin", "tracked", "ll_margin")
#: The --set sections that change what the map check sees (the solid map, the planner).
MAP_SECTIONS = ("clean", "planner")
#: The EVAL fields kept as text.
TEXT = ("world", "modes")


def leave_one_out(scores: Scores, worlds: Sequence[str], given_up: Optional[Scores] = None,
                  limit: float = 1.0) -> Dict[str, str]:
    """For each world, the value (a key of ``scores``, in order of preference on a tie)
    with the best summed score over the other worlds, among the first value and those whose
    ``given_up`` (value -> world -> the worst share of legs given up) is at most ``limit``
    on every other world."""
    values = list(scores)
    picks = {}
    for w in worlds:
        others = [o for o in worlds if o != w]
        allowed = [v for i, v in enumerate(values) if i == 0 or given_up is None
                   or all(given_up[v][o] <= limit for o in others)]
        # summed in millionths, so that a tie is one whatever the order of the sum
        picks[w] = max(allowed, key=lambda v: (sum(round(1e6 * scores[v][o]) for o in others),
                                               -values.index(v)))
    return picks


def parse_eval_line(line: str, required: Sequence[str] = ("world", "seed", "legs_asked")
                    ) -> Optional[dict]:
    """The fields of an ``EVAL key=value ...`` line (numbers as floats), or None (no such
    line, or one without each of the ``required`` fields)."""
    text = line.strip()
    if text.startswith("done: "):
        text = text[len("done: "):]
    if not text.startswith("EVAL "):
        return None
    out: dict = {}
    for item in text.split()[1:]:
        k, _, v = item.partition("=")
        try:
            out[k] = v if k in TEXT else float(v.rstrip("sx"))
        except ValueError:
            out[k] = v
    return out if set(required) <= set(out) else None


def read_runs(path: str, legs: int) -> Dict[Tuple[str, int], dict]:
    """(world, seed) -> the fields of the last EVAL line of ``legs`` legs asked of each task
    in ``path`` (none: {}; lines that are no such EVAL line are passed over)."""
    runs: Dict[Tuple[str, int], dict] = {}
    if os.path.exists(path):
        with open(path) as f:
            for line in f:
                r = parse_eval_line(line)
                if r is not None and r["legs_asked"] == legs:
                    runs[r["world"], int(r["seed"])] = r
    return runs


def run_value(path: str, sets: dict, worlds: List[str], seeds: List[int], legs: int,
              workers: int, save: str = "") -> Dict[Tuple[str, int], dict]:
    """The EVAL fields of every (world, seed) with ``sets``: those in ``path`` already as
    they are (of ``legs`` legs only), the others run now, each appended as it ends (and,
    with ``save``, each run's moments kept there as eval_worlds.py --save keeps them)."""
    wanted = {(world_label(w), s) for w in worlds for s in seeds}

    def kept() -> Dict[Tuple[str, int], dict]:
        return {k: r for k, r in read_runs(path, legs).items() if k in wanted}

    have = kept()
    todo = [(w, s) for w in worlds for s in seeds if (world_label(w), s) not in have]
    if todo:
        print("== %s: %d task(s) to run, %d kept from %s" % (
            os.path.basename(path), len(todo), len(worlds) * len(seeds) - len(todo), path),
            file=sys.stderr, flush=True)

        def keep(r: dict) -> None:
            lead = "" if ends_a_line(path) else "\n"   # after a line a cut run left unfinished
            with open(path, "a") as f:
                f.write(lead + eval_worlds._eval_line(r, None) + " legs_asked=%d\n" % legs)

        eval_worlds.run_tasks(todo, legs, save=save, workers=workers, on_row=keep, sets=sets)
    return kept()


def ends_a_line(path: str) -> bool:
    """Whether the file at ``path`` is empty, absent or ends with a newline."""
    if not os.path.exists(path) or os.path.getsize(path) == 0:
        return True
    with open(path, "rb") as f:
        f.seek(-1, os.SEEK_END)
        return f.read(1) == b"\n"


def pooled(runs: Dict[Tuple[str, int], dict], key: str, world: str, seeds: List[int]) -> float:
    return sum(float(runs[world, s][key]) for s in seeds) / len(seeds)


def table(runs: Dict[str, Dict[Tuple[str, int], dict]], labels: List[str], worlds: List[str],
          seeds: List[int], score: str, max_given_up: float = 1.0,
          bars: bool = False) -> List[str]:
    """The markdown lines of the folds (``runs``: label -> its EVAL fields). With ``bars``,
    a value with a run under any other of the issue's bars (eval_bars.BARS; legs given up
    stay ``max_given_up``'s) on a world a fold learns from is not that fold's pick, as one
    that gave up too many legs is not."""
    from eval_bars import BARS, misses   # here: eval_bars imports this module

    given_up_miss = BARS[0][2]

    scores = {v: {w: pooled(runs[v], score, w, seeds) for w in worlds} for v in labels}
    tracked = {v: {w: pooled(runs[v], "tracked", w, seeds) for w in worlds} for v in labels}
    lost = {v: {w: max(float(runs[v][w, s]["given_up"]) for s in seeds) for w in worlds}
            for v in labels}
    # the given-up bar is --max-given-up's, as without --bars
    under = {v: {w: sorted({m for s in seeds for m in misses(runs[v][w, s])
                            if m != given_up_miss}) if bars else []
                 for w in worlds} for v in labels}
    # a run under a bar counts as one that gave up every leg: no limit lets it through
    picks = leave_one_out(scores, worlds, {v: {w: 2.0 if under[v][w] else lost[v][w]
                                               for w in worlds} for v in labels},
                          max_given_up)
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
    worst = {v: max((float(runs[v][w, s]["given_up"]), w, s) for w in worlds for s in seeds)
             for v in labels}
    out.append("")
    out += ["given up, worst run: %s" % ", ".join(
        "%s %.1f %% (%s seed %d)" % (v, 100 * g, w, s) if g > 0 else "%s none" % v
        for v, (g, w, s) in worst.items())]
    barred = ["%s in %d" % (v, sum(1 for w in worlds if any(lost[v][o] > max_given_up
                                                          for o in worlds if o != w)))
              for v in labels[1:] if any(g > max_given_up for g in lost[v].values())]
    if barred:
        out.append("not a fold's pick for giving up more than %g %% of the legs on a world "
                   "it learns from: %s fold(s)" % (100 * max_given_up, ", ".join(barred)))
    if any(under[labels[0]].values()):
        out.append("%s (the shipped default, which any fold may keep) is under a bar on %s"
                   % (labels[0], "; ".join("%s (%s)" % (w, ", ".join(m))
                                           for w, m in under[labels[0]].items() if m)))
    for v in labels[1:]:
        if any(under[v].values()):
            out.append("%s is under a bar on %s: not the pick of the %d fold(s) that learn from "
                       "it" % (v, "; ".join("%s (%s)" % (w, ", ".join(m))
                                            for w, m in under[v].items() if m),
                               sum(1 for w in worlds if any(under[v][o] for o in worlds
                                                            if o != w))))
    out.append("FOLDS score=%s held_out=%.4f default=%.4f picks=\"%s\"" % (
        score, held, sum(scores[labels[0]].values()) / n, counts))
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("param", help="SECTION.FIELD, as eval_worlds.py --set takes it (with "
                                 "--together, the first SECTION.FIELD=VALUE change)")
    p.add_argument("values", nargs="*", help="the candidates beside the shipped default (with "
                                             "--together, the other changes)")
    p.add_argument("--legs", type=int, default=100)
    p.add_argument("--seed", type=int, nargs="+", default=[12])
    p.add_argument("--worlds", nargs="*", default=None,
                   help="names or world.yaml paths (default: as eval_worlds.py)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--score", default="trk50", choices=SCORES,
                   help="the EVAL field the folds maximise (default: trk50)")
    p.add_argument("--max-given-up", type=float, default=0.02, metavar="SHARE",
                   help="a value that gave up more than this share of its legs in any one run "
                        "on a world a fold learns from is not that fold's pick (the shipped "
                        "default always may be; default: 0.02, the study's bar)")
    p.add_argument("--bars", action="store_true",
                   help="a value with a run under any of the issue's bars (bench/eval_bars.py) "
                        "on a world a fold learns from is not that fold's pick either")
    p.add_argument("--out", default="", metavar="DIR",
                   help="where the runs' EVAL lines are kept (default: "
                        "~/.ros/bullet_floor_sim/folds/<commit>)")
    p.add_argument("--save", default="", metavar="DIR",
                   help="the default's runs done now also keep their moments in DIR, as "
                        "eval_worlds.py --save does (for choose_prediction.py and "
                        "calibrate_prediction.py --cache): one run serves both folds")
    p.add_argument("--together", action="store_true",
                   help="the arguments are SECTION.FIELD=VALUE changes, tried as one "
                        "candidate (all at once) against the shipped defaults")
    args = p.parse_args()
    if not 0.0 <= args.max_given_up <= 1.0:
        p.error("--max-given-up must be a share in [0, 1], got %g" % args.max_given_up)
    try:
        tries = (together([args.param] + args.values) if args.together
                 else one_field(args.param, args.values))
    except BulletFloorSimError as e:
        p.error(str(e))
    out = args.out or os.path.join(os.environ.get("ROS_HOME", os.path.expanduser("~/.ros")),
                                   "bullet_floor_sim", "folds", checkout_commit())
    os.makedirs(out, exist_ok=True)
    worlds, notes = eval_worlds.checked(args.worlds or eval_worlds.shipped(),
                                        bool(args.worlds), False)
    for label, sets, name in tries[1:]:   # each candidate's map check too: the same worlds
        if set(sets) & set(MAP_SECTIONS):
            worlds, more = eval_worlds.checked(worlds, bool(args.worlds), False, sets)
            notes += ["%s: %s" % (name, n) for n in more]
    for n in notes:
        print("note: %s" % n, file=sys.stderr, flush=True)
    names = [world_label(w) for w in worlds]
    if len(set(names)) < 2 or len(set(names)) < len(names):
        p.error("the folds need two worlds or more, each once (got: %s)" % " ".join(names))
    labels = [label for label, _, _ in tries]
    runs = {}
    for label, sets, name in tries:
        runs[label] = run_value(os.path.join(out, name + ".log"), sets, worlds, args.seed,
                                args.legs, args.workers, "" if sets else args.save)
    what = (" ".join([args.param] + args.values) + " together" if args.together
            else args.param)
    print("%s, %d legs, seed(s) %s; each fold keeps the value with the best mean %s on the "
          "other worlds, of those that gave up at most %g %% of the legs there%s\n"
          % (what, args.legs, " ".join(map(str, args.seed)), args.score,
             100 * args.max_given_up,
             " and met every other bar (the shipped default always may be)" if args.bars
             else ""))
    for line in table(runs, labels, names, args.seed, args.score, args.max_given_up,
                      args.bars):
        print(line)
    return 0


Try = Tuple[str, Dict[str, Dict[str, str]], str]   # label, --set changes, log file's name


def one_field(param: str, values: List[str]) -> List[Try]:
    """The shipped default and each candidate value of ``param`` (SECTION.FIELD), as
    (label, changes, log name) with the default first.

    Raises:
        BulletFloorSimError: a bad field or value, or no value beside the default.
    """
    section, _, field = param.partition(".")
    default = shipped_default(param)
    return ([("%r (default)" % default, {}, "default")]
            + [(v, {section: {field: v}}, "%s=%s" % (param, v))
               for v in candidates(param, values, default)])


def together(items: List[str]) -> List[Try]:
    """The shipped defaults and one candidate that makes every change of ``items``
    (``SECTION.FIELD=VALUE`` each, checked) at once, labelled ``together``.

    Raises:
        BulletFloorSimError: a bad item, or one that sets a field to its shipped default.
    """
    sets = eval_worlds.parse_sets(items)
    for section, changes in sets.items():
        for field, value in changes.items():
            key = "%s.%s" % (section, field)
            default = shipped_default(key)
            if convert(key, value, default) == default:
                raise BulletFloorSimError("--together %s=%s: %s is already the shipped "
                                          "default" % (key, value, key))
    name = "together_" + ",".join(sorted(i.replace(" ", "") for i in items))
    return [("default", {}, "default"), ("together", sets, name)]


def candidates(param: str, values: List[str], default: object) -> List[str]:
    """``values`` each checked (eval_worlds.parse_sets), without repeats and without the
    default's own value.

    Raises:
        BulletFloorSimError: a bad value, or none left beside the default.
    """
    out, seen = [], [default]
    for v in values:
        eval_worlds.parse_sets(["%s=%s" % (param, v)])
        typed = convert(param, v, default)
        if typed not in seen:
            seen.append(typed)
            out.append(v)
    if not out:
        raise BulletFloorSimError("%s: no value to try beside the default %r" % (param, default))
    return out


def shipped_default(param: str) -> object:
    """The shipped default of ``param`` (SECTION.FIELD).

    Raises:
        BulletFloorSimError: no such section or field (named).
    """
    section, _, field = param.partition(".")
    config = eval_worlds.shipped_sections().get(section)
    if config is None or not hasattr(config, field):
        eval_worlds.parse_sets(["%s=0" % param])   # raises, naming the section or field
    return getattr(config, field)


if __name__ == "__main__":
    sys.exit(main())
