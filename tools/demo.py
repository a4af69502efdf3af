#!/usr/bin/env python3
"""`make demo` (until the ROS bridge and the Markov demo land): run the office world.

With a display, the PyBullet window shows the floor and the robots wandering; headless, the
same run prints each robot's pose, the closest obstacle its lidar sees and the real-time
factor once per simulated second. Ctrl-C stops it.

Usage: tools/demo.py [--world office] [--seconds 60] [--rtf 1.0] [--gui|--no-gui]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))

import numpy as np  # noqa: E402

from bullet_floor_sim.errors import BulletFloorSimError  # noqa: E402
from bullet_floor_sim.sim.world import World  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description="Run a bullet_floor_sim world with wandering robots.")
    ap.add_argument("--world", default="office", help="world name under worlds/ or a world.yaml")
    ap.add_argument("--seconds", type=float, default=60.0, help="sim seconds to run (0 = forever)")
    ap.add_argument("--rtf", type=float, default=1.0, help="real-time factor (0 = as fast as possible)")
    gui = ap.add_mutually_exclusive_group()
    gui.add_argument("--gui", dest="gui", action="store_true", help="PyBullet window")
    gui.add_argument("--no-gui", dest="gui", action="store_false", help="headless")
    ap.set_defaults(gui=bool(os.environ.get("DISPLAY")) and not os.environ.get("CI"))
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    try:
        world = World.from_name(args.world, gui=args.gui, seed=args.seed)
    except BulletFloorSimError as e:
        print("demo: %s" % e, file=sys.stderr)
        return 2
    names = [s.name or "<robot>" for s in world.specs]
    print("demo: world %s, robots %s, %s" % (world.config.path, ", ".join(names),
                                            "PyBullet window" if args.gui else "headless"))
    rng = np.random.default_rng(args.seed)
    turn = np.zeros(world.n)
    last_min = np.full(world.n, np.inf)
    t_wall0 = time.perf_counter()
    t_sim0 = world.clock.now
    next_report = t_sim0 + 1.0
    try:
        while args.seconds <= 0 or world.clock.now - t_sim0 < args.seconds:
            for scan in world.step():
                i = scan.robot
                ahead = np.abs(world.lidar.angles[i]) < 0.6
                last_min[i] = float(np.min(scan.ranges[ahead]))
                if last_min[i] < 1.0 or world.stalled[i]:
                    turn[i] = turn[i] or float(rng.choice((-1.0, 1.0)))
                    world.command(i, 0.0, 0.0, turn[i])
                else:
                    turn[i] = 0.0
                    world.command(i, 0.5, 0.0, float(rng.uniform(-0.3, 0.3)))
            elapsed_sim = world.clock.now - t_sim0
            if args.rtf > 0:
                lag = elapsed_sim / args.rtf - (time.perf_counter() - t_wall0)
                if lag > 0:
                    time.sleep(lag)
            if world.clock.now >= next_report:
                next_report += 1.0
                rtf = elapsed_sim / max(1e-9, time.perf_counter() - t_wall0)
                poses = "  ".join("%s (%.2f, %.2f, %+.2f) closest %.2f m" % (
                    names[i], *world.view(i).pose, last_min[i]) for i in range(world.n))
                print("t=%7.2f s  rtf %6.1f  %s" % (world.clock.now, rtf, poses), flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        world.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
