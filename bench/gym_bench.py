#!/usr/bin/env python3
"""Environment steps per second of bullet_floor_sim.gym's FloorNavEnv (``make bench``).

One env stepped in this process, then gymnasium's AsyncVectorEnv of 8 (one process each),
every env with random actions and its default world (office, 5 people); episodes reset as
they end (their resets are in the time). Each line: the envs, the steps of all of them per
wall second, the cores the machine has. A vector env of more envs than cores only shares
them: the ratio of the two lines, side by side, is what to compare between machines.

    .venv/bin/python bench/gym_bench.py [--steps 2000] [--envs 1 8] [--world office --people 5]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))

import numpy as np  # noqa: E402


def single(steps: int, kwargs: dict) -> float:
    """Steps per second of one env in this process."""
    from bullet_floor_sim.gym import FloorNavEnv

    env = FloorNavEnv(**kwargs)
    env.action_space.seed(1)
    env.reset(seed=1)
    t0 = time.perf_counter()
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    rate = steps / (time.perf_counter() - t0)
    env.close()
    return rate


def _make(kwargs: dict):
    def make():
        from bullet_floor_sim.gym import FloorNavEnv
        return FloorNavEnv(**kwargs)
    return make


def vector(n: int, steps: int, kwargs: dict) -> float:
    """Env steps per second (all envs together) of an AsyncVectorEnv of ``n``; the vector
    env resets each env as it ends (autoreset)."""
    from gymnasium.vector import AsyncVectorEnv

    vec = AsyncVectorEnv([_make(kwargs)] * n)
    vec.action_space.seed(1)
    vec.reset(seed=list(range(1, n + 1)))
    rounds = max(1, steps // n)
    t0 = time.perf_counter()
    for _ in range(rounds):
        vec.step(vec.action_space.sample())
    rate = rounds * n / (time.perf_counter() - t0)
    vec.close()
    return rate


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int, default=2000, help="env steps per line (all envs)")
    p.add_argument("--envs", type=int, nargs="+", default=[1, 8],
                   help="1: one env in this process; n > 1: an AsyncVectorEnv of n")
    p.add_argument("--world", default="office")
    p.add_argument("--people", type=int, default=5)
    args = p.parse_args()
    try:
        import gymnasium  # noqa: F401
    except ImportError:
        print("gym_bench: skipped: gymnasium is not installed (Python >= 3.10, make setup)")
        return 0
    kwargs = {"world": args.world, "people": args.people}
    cores = os.cpu_count() or 1
    rates = {}
    for n in args.envs:
        rates[n] = single(args.steps, kwargs) if n == 1 else vector(n, args.steps, kwargs)
        print("BENCH gym envs=%d world=%s people=%d steps_per_s=%.0f cores=%d%s"
              % (n, args.world, args.people, rates[n], cores,
                 "" if n == 1 or 1 not in rates else " vs_one=%.2f" % (rates[n] / rates[1])),
              flush=True)
    return 0 if all(np.isfinite(list(rates.values()))) else 1


if __name__ == "__main__":
    sys.exit(main())
