#!/usr/bin/env python3
"""Each world's runs against issue 33's bars, from the EVAL lines of study logs.

Reads the ``EVAL ...`` lines (``done: EVAL ...`` too) that ``bench/eval_worlds.py`` prints
and ``bench/choose_by_folds.py`` keeps (``--out DIR``, one log a value), the last line of
each (world, seed) across the files given, and prints one markdown table: a row a world
with each seed's tracked share, trk50 and gt50, the worst share of legs given up and the
least margins, and the bars each seed misses; then a ``BARS`` line counting the world-seeds
under a bar. The bars (BARS below) are the issue's: legs given up at most 2 %, the walker
tracked at least 70 %, top-1 at 50 % at least 70 % from tracker tracks and 80 % from ground
truth, above both baselines (``margin`` > 0: the predictor's least lead in top-1 from 25 %
on) and a log-loss below the prior's from 25 % on (``ll_margin`` > 0). The real-time factor
is a bar beside office's, measured side by side: not from these logs.

    .venv/bin/python bench/eval_bars.py ~/.ros/bullet_floor_sim/folds/<commit>/default.log
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Dict, Iterable, List, Tuple

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from choose_by_folds import parse_eval_line  # noqa: E402

#: (EVAL field, the bar's test, what a miss is called), in the issue's order.
BARS = (("given_up", lambda v: v <= 0.02, "given up > 2 %"),
        ("tracked", lambda v: v >= 0.70, "tracked < 70 %"),
        ("trk50", lambda v: v >= 0.70, "trk50 < 70 %"),
        ("gt50", lambda v: v >= 0.80, "gt50 < 80 %"),
        ("margin", lambda v: v > 0.0, "margin <= 0"),
        ("ll_margin", lambda v: v > 0.0, "ll margin <= 0"))

Runs = Dict[Tuple[str, int], dict]


def read_logs(paths: Iterable[str]) -> Runs:
    """(world, seed) -> the fields of its last EVAL line in ``paths``, in order."""
    runs: Runs = {}
    for path in paths:
        with open(path) as f:
            for line in f:
                r = parse_eval_line(line, ("world", "seed"))
                if r is not None:
                    runs[str(r["world"]), int(r["seed"])] = r
    return runs


def misses(run: dict) -> List[str]:
    """The bars one run misses (a field the line lacks is a miss: it cannot be shown met)."""
    return [name for field, ok, name in BARS
            if field not in run or not isinstance(run[field], float) or not ok(run[field])]


def table(runs: Runs) -> List[str]:
    """The markdown lines: a row a world (in the logs' order), then the BARS count."""
    worlds = list(dict.fromkeys(w for w, _ in runs))
    out = ["| world | seeds | tracked | trk50 | gt50 | worst given up | least margin "
           "| least ll margin | under a bar |", "|---|---|---|---|---|---|---|---|---|"]
    under = []
    for w in worlds:
        seeds = sorted(s for v, s in runs if v == w)
        rs = [runs[w, s] for s in seeds]

        def each(field: str) -> str:
            return " / ".join("%.1f" % (100 * r[field]) if field in r else "-" for r in rs)

        def least(field: str) -> str:
            vals = [r[field] for r in rs if field in r]
            return "%.2f" % min(vals) if vals else "-"

        missed = [(s, m) for s, m in ((s, misses(r)) for s, r in zip(seeds, rs)) if m]
        bad = ["seed %d: %s" % (s, ", ".join(m)) for s, m in missed]
        under += ["%s:%d" % (w, s) for s, _ in missed]
        worst = max((r["given_up"] for r in rs if "given_up" in r), default=None)
        out.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            w, " ".join(map(str, seeds)), each("tracked"), each("trk50"), each("gt50"),
            "-" if worst is None else "%.1f %%" % (100 * worst), least("margin"),
            least("ll_margin"), "; ".join(bad) or "none"))
    out.append("")
    out.append("BARS runs=%d worlds=%d under=%d %s" % (len(runs), len(worlds), len(under),
                                                      " ".join(under)))
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("logs", nargs="+", help="study logs with EVAL lines")
    args = p.parse_args()
    for path in args.logs:
        if not os.path.isfile(path):
            p.error("%s: no such file" % path)
    runs = read_logs(args.logs)
    if not runs:
        p.error("no EVAL lines with a world and a seed in %s" % ", ".join(args.logs))
    print("\n".join(table(runs)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
