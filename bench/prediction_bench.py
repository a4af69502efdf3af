#!/usr/bin/env python3
"""The destination model's build time (people/prediction: the cost-to-go field of every goal
point of every region), on office and on the largest real map, the worlds one after the other
in this process. It is what destination_predictor and evaluate_prediction wait for before
their first prediction, and again whenever the ROIs change.

Prints a table and one machine-readable line:

    BENCH prediction world=<largest real> model_s=<x> goals=<n> office_model_s=<x> office_goals=<n> ratio=<x>

(``ratio``: the real map's build time over office's, measured side by side.)
"""
from __future__ import annotations

import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))

from bullet_floor_sim.people.evaluation import world_model  # noqa: E402

REAL = "malaga_campus"   # the largest real map shipped (54 x 59 m)


def build(world: str) -> tuple:
    """Seconds to build the world's destination model as the evaluation does (loading the
    world, the regions the walker can reach, their chain, the planning grid and the model's
    fields), and the goal points it holds."""
    t0 = time.perf_counter()
    model = world_model(world)
    took = time.perf_counter() - t0
    return took, sum(len(model.goals(r)) for r in model.chain.ids)


def main() -> int:
    rows = [(w,) + build(w) for w in ("office", REAL)]
    print("%-16s %10s %8s" % ("world", "model s", "goals"))
    for w, took, goals in rows:
        print("%-16s %10.2f %8d" % (w, took, goals))
    (_, o_s, o_n), (w, r_s, r_n) = rows
    print("BENCH prediction world=%s model_s=%.2f goals=%d office_model_s=%.2f office_goals=%d "
          "ratio=%.2f" % (w, r_s, r_n, o_s, o_n, r_s / o_s))
    return 0


if __name__ == "__main__":
    sys.exit(main())
