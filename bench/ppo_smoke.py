#!/usr/bin/env python3
"""Does learning happen on FloorNavEnv? A short stable-baselines3 PPO run against a random
policy, both scored on held-out seeds (``make ppo-smoke``; not a CI test).

Training episodes are seeded from ``--seed``; the evaluation's episodes use seeds 10 000 on,
which training never drew (each episode's start, goal and people come from its seed). Prints
the success rate (goal reached), collisions, mean return and mean time of each policy, and one
``PPO`` line. The actions are rescaled to [-1, 1] for PPO (RescaleAction); the env's own
action space is (v, w) in m/s and rad/s.

    .venv/bin/python bench/ppo_smoke.py [--steps 150000] [--episodes 100] [--world office]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))

import numpy as np  # noqa: E402

#: The held-out seeds start here (training draws from --seed's generator, below 2**31 but
#: gymnasium's resets after the first are unseeded: the first seed is all that is set).
EVAL_SEED = 10_000


def make_env(args):
    """The env as trained and scored (actions rescaled to [-1, 1])."""
    from gymnasium.wrappers import RescaleAction
    from bullet_floor_sim.gym import FloorNavEnv

    env = FloorNavEnv(world=args.world, people=args.people, goal_distance=tuple(args.goal),
                      goal_in_sight=True, max_time=args.max_time)
    return RescaleAction(env, np.full(2, -1.0, np.float32), np.full(2, 1.0, np.float32))


def score(env, act, episodes: int) -> dict:
    """Success rate, collision rate, mean return and time over ``episodes`` held-out seeds."""
    wins = hits = 0
    returns, times = [], []
    for k in range(episodes):
        obs, info = env.reset(seed=EVAL_SEED + k)
        total, done = 0.0, False
        while not done:
            obs, r, term, trunc, info = env.step(act(obs))
            total += r
            done = term or trunc
        wins += bool(info["is_success"])
        hits += bool(info["collision"])
        returns.append(total)
        times.append(info["time"])
    return {"success": wins / episodes, "collision": hits / episodes,
            "return": float(np.mean(returns)), "time": float(np.mean(times))}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int, default=150_000, help="PPO training steps")
    p.add_argument("--episodes", type=int, default=100, help="held-out episodes per policy")
    p.add_argument("--world", default="office")
    p.add_argument("--people", type=int, default=3)
    p.add_argument("--goal", type=float, nargs=2, default=(1.5, 4.0), metavar=("MIN", "MAX"),
                   help="goal distance range (m), the goal in sight of the start")
    p.add_argument("--max-time", type=float, default=30.0)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--envs", type=int, default=4, help="training envs (one process)")
    args = p.parse_args()
    try:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.env_util import make_vec_env
    except ImportError as e:
        sys.exit("ppo_smoke: %s: install requirements/rl.txt (make ppo-smoke does)" % e)
    torch.set_num_threads(1)
    venv = make_vec_env(lambda: make_env(args), n_envs=args.envs, seed=args.seed)
    model = PPO("MultiInputPolicy", venv, seed=args.seed, verbose=0, n_steps=512,
                batch_size=256)
    t0 = time.time()
    rollout = 512 * args.envs     # learn() collects whole rollouts: progress in whole ones
    chunk = rollout * max(1, args.steps // rollout // 10)
    while model.num_timesteps < args.steps:
        model.learn(chunk, reset_num_timesteps=False)
        print("trained %d/%d steps, %.0f s" % (model.num_timesteps, args.steps,
                                             time.time() - t0), file=sys.stderr, flush=True)
    train_s = time.time() - t0
    env = make_env(args)
    rng = np.random.default_rng(args.seed)
    rand = score(env, lambda obs: rng.uniform(-1.0, 1.0, 2).astype(np.float32), args.episodes)
    ppo = score(env, lambda obs: model.predict(obs, deterministic=True)[0], args.episodes)
    print("| policy | success | collision | mean return | mean time (s) |")
    print("|---|---|---|---|---|")
    for name, s in (("random", rand), ("PPO, %d steps" % args.steps, ppo)):
        print("| %s | %.0f %% | %.0f %% | %.2f | %.1f |" % (
            name, 100 * s["success"], 100 * s["collision"], s["return"], s["time"]))
    print("PPO world=%s people=%d steps=%d train_s=%.0f episodes=%d held_out_from=%d "
          "success=%.3f random_success=%.3f" % (args.world, args.people, args.steps, train_s,
                                                args.episodes, EVAL_SEED, ppo["success"],
                                                rand["success"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
