#!/usr/bin/env python3
"""Crowd benchmark: the simulator core with people, 10, 50 and 200 of them.

Prints a table and ends with one machine-readable line:

    BENCH people_core rtf_10=<x> rtf_50=<x> rtf_200=<x> us_per_person_10=<x> ...

Setup of every case: the office world with its two robots (their world-file lidars, driven
as sim_bench's reactive wanderers), N people walking office's regions (people/crowd, seed 1,
stepped at 20 Hz), physics at 100 Hz, 60 s of sim time, in this process. ``us_per_person``
is the wall time of the crowd's steps (legs, forces, walls) per person and step: flat in N
means the people's cost grows linearly. The lidars' extra cost for the legs is in the rtf.
No ROS messages are built here: the simulator node's figure with its topics published is
bench/ros_bench.py's.
"""
from __future__ import annotations

import dataclasses
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, HERE)


def run_case(n_people: int, sim_seconds: float = 60.0) -> dict:
    import numpy as np

    from bullet_floor_sim.people.crowd.build import build_crowd
    from bullet_floor_sim.sim.world import World
    from sim_bench import Wanderer

    world = World.from_name("office", seed=1)
    try:
        crowd = build_crowd(world, dataclasses.replace(world.config.people, seed=1)
                            .with_count(n_people))
        assert crowd is not None
        spent = [0.0, 0]
        advance = crowd.advance

        def timed(*args):
            t = time.perf_counter()
            advance(*args)
            spent[0] += time.perf_counter() - t
            spent[1] += 1

        crowd.advance = timed     # type: ignore[method-assign]
        world.add_people(crowd)
        wander = Wanderer(world, np.random.default_rng(1))
        steps = int(round(sim_seconds / world.clock.dt))
        t0 = time.perf_counter()
        for _ in range(steps):
            wander(world.step())
        wall = time.perf_counter() - t0
        legs = sum(": leg " in s and s.endswith(" s") for s in crowd.take_log())
        return {"people": n_people, "rtf": sim_seconds / wall,
                "us_per_person": 1e6 * spent[0] / max(1, spent[1]) / n_people,
                "crowd_share": spent[0] / wall, "legs_done": legs,
                "leg_hits": world.rays_at_legs}
    finally:
        world.close()


def main() -> int:
    rows = [run_case(n) for n in (10, 50, 200)]
    print("%8s %8s %14s %12s %10s %10s" % ("people", "rtf", "us/person/step", "crowd share",
                                            "legs done", "leg hits"))
    for r in rows:
        print("%8d %8.1f %14.1f %12.2f %10d %10d" % (r["people"], r["rtf"], r["us_per_person"],
                                                    r["crowd_share"], r["legs_done"],
                                                    r["leg_hits"]))
    print("BENCH people_core " + " ".join(
        "rtf_%d=%.1f" % (r["people"], r["rtf"]) for r in rows) + " " + " ".join(
        "us_per_person_%d=%.1f" % (r["people"], r["us_per_person"]) for r in rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
