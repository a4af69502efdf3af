#!/usr/bin/env python3
"""Simulator-core benchmark: real-time factor, ray cost, load time, memory.

Prints a table and ends with one machine-readable line:

    BENCH sim rtf_1=<x> rtf_10=<x> rtf_50=<x> ray_overhead=<ratio> load_s=<x> rss_mb_10=<x>
    BENCH sim_real world=malaga_campus rtf_10=<x> office_rtf_10=<x> ratio=<x> load_s=<x>

The second line is the 10-robot case on the largest real SLAM map beside office's, run one
after the other in this run (a world loads from the map cache, sim/mapcache.py, as every
load after the first does).

Setup of every case: the office world, physics at 100 Hz, every robot with one 360-beam lidar
(360 degrees, 1 degree) at 10 Hz, robots spread over free space and driven by random
commands. Each case runs in its own process so its peak RSS is its own. ``ray_overhead`` is
the lidar's cost per beam (a whole scan tick: building rays, casting, ranges) divided by the
cost of bare ``rayTestBatch`` calls casting the same beams naively (each from its laser origin
to range_max in the full scene), timed alternately in the same process (see _ray_overhead).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))


def _world(n_robots: int, seed: int = 7, name: str = "office"):
    """A world (office by default) with n robots at free, spread-out poses."""
    import dataclasses

    import numpy as np

    from bullet_floor_sim.sim.config import LaserConfig, RobotSpec, load_world_config, resolve_world
    from bullet_floor_sim.sim.floormap import load_map
    from bullet_floor_sim.paths import worlds_dir
    from bullet_floor_sim.sim.world import World

    cfg = load_world_config(resolve_world(name, worlds_dir()))
    fmap = load_map(cfg.map_yaml)
    from scipy.ndimage import distance_transform_edt

    clear = distance_transform_edt(fmap.grid == 0) * fmap.resolution
    rows, cols = np.nonzero(clear > 0.7)
    rng = np.random.default_rng(seed)
    poses = []
    for k in rng.permutation(len(rows)):
        x, y = fmap.cell_to_world(cols[k], rows[k])
        if all((x - px) ** 2 + (y - py) ** 2 > 1.2 ** 2 for px, py, _ in poses):
            poses.append((float(x), float(y), float(rng.uniform(-np.pi, np.pi))))
        if len(poses) == n_robots:
            break
    laser = LaserConfig(fov=360.0, resolution=1.0, rate=10.0)
    robots = [RobotSpec(name="robot%d" % (i + 1), pose=p, laser=laser) for i, p in enumerate(poses)]
    cfg = dataclasses.replace(cfg, robots=robots)
    t0 = time.perf_counter()
    world = World(cfg, physics_rate=100.0, seed=seed)
    return world, time.perf_counter() - t0


class Wanderer:
    """Robots as reactive wanderers: cruise, turn away from what is ahead (call with the
    readings of each step)."""

    def __init__(self, world, rng) -> None:
        import numpy as np

        self.world, self.rng = world, rng
        self.turn = np.zeros(world.n)
        self.front = np.abs(world.lidar.angles[0]) < 0.6

    def __call__(self, readings) -> None:
        import numpy as np

        from bullet_floor_sim.sim.sensors import Scan

        world, turn = self.world, self.turn
        for scan in readings:
            if not isinstance(scan, Scan):
                continue
            i = scan.robot
            if np.min(scan.ranges[self.front]) < 1.0 or world.stalled[i]:
                turn[i] = turn[i] or float(self.rng.choice((-1.2, 1.2)))
                world.command(i, 0.0, 0.0, turn[i])
            else:
                turn[i] = 0.0
                world.command(i, 0.6, 0.0, float(self.rng.uniform(-0.3, 0.3)))


def run_case(n_robots: int, sim_seconds: float, name: str = "office") -> dict:
    """Run one case in this process and return its numbers."""
    import numpy as np

    t_imports = time.perf_counter()
    world, load_s = _world(n_robots, name=name)
    load_total = time.perf_counter() - t_imports
    rng = np.random.default_rng(1)
    steps = int(round(sim_seconds / world.clock.dt))
    wander = Wanderer(world, rng)
    t0 = time.perf_counter()
    for _ in range(steps):
        wander(world.step())
    wall = time.perf_counter() - t0
    out = {"robots": n_robots, "sim_s": sim_seconds, "wall_s": wall, "rtf": sim_seconds / wall,
           "load_s": load_s, "load_with_imports_s": load_total,
           "stalls": int(world.stall_count.sum()),
           "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}
    out.update(_ray_overhead(world))
    from bullet_floor_sim.sim import bullet_capi
    out["ray_path"] = ("walls on the grid, " if world.walls_on_grid else "") + bullet_capi.status()
    return out


def _ray_overhead(world, reps: int = 20) -> dict:
    """Lidar cost per beam vs bare rayTestBatch on the same beams, timed alternately.

    "Raw" casts every beam of every robot once, from its laser origin to range_max (clipped to
    the map bounds), in the scene as it is: the naive lidar, one rayTestBatch per 16,383 beams,
    no post-processing. "Lidar" is a whole scan tick of ``Lidar.read`` (ray set-up, the wall
    pass with the robots moved out, the pass at other robots, ranges with noise), in steady
    state (it shortens rays from its previous scan) with every robot turning by 1e-4 rad
    between scans (an unmoved lidar would reuse its wall distances). Both produce the same
    ranges; a ratio below 1 means the lidar costs less than casting its beams naively.
    """
    import numpy as np

    from bullet_floor_sim.sim.sensors import MAX_RAYS_PER_BATCH as B

    due = np.arange(world.n)
    plan = world.lidar.plan(due, world.pose, world.bounds)
    froms = plan.origins
    tos = froms.copy()
    tos[:, :2] += plan.dirs * plan.full[:, None]
    n_rays = len(froms)
    world.lidar.next_scan_ns[due] = world.clock.now_ns
    world.lidar.read(world)                     # steady state: it has a previous scan
    t_scan = t_raw = 0.0
    cast0 = world.rays_cast
    for _ in range(reps):
        world._sync_bodies()
        t = time.perf_counter()
        for s in range(0, n_rays, B):
            world.client.rayTestBatch(froms[s:s + B], tos[s:s + B], numThreads=world.ray_threads)
        t_raw += time.perf_counter() - t
        world.lidar.next_scan_ns[due] = world.clock.now_ns
        world.pose[:, 2] += 1e-4                   # moving lidars: nothing to reuse
        t = time.perf_counter()
        world.lidar.read(world)
        t_scan += time.perf_counter() - t
    return {"rays_per_scan_batch": n_rays, "raw_rays_per_s": n_rays * reps / t_raw,
            "lidar_rays_per_s": n_rays * reps / t_scan, "ray_overhead": t_scan / t_raw,
            "rays_cast_per_beam": (world.rays_cast - cast0) / (n_rays * reps)}


def _case(n_robots: int, sim_seconds: float, env: dict, name: str = "office") -> dict:
    """One case in a process of its own (its peak RSS is its own)."""
    proc = subprocess.run([sys.executable, __file__, "--case", str(n_robots), "--sim-seconds",
                           str(sim_seconds), "--world", name], stdout=subprocess.PIPE,
                          stderr=subprocess.DEVNULL,
                          universal_newlines=True, check=True, env=env)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", type=int, help="(internal) run one case with N robots")
    ap.add_argument("--sim-seconds", type=float, default=None)
    ap.add_argument("--world", default="office", help="(internal) the world of --case")
    ap.add_argument("--real", default="malaga_campus",
                    help="the real SLAM world measured beside office ('' = none)")
    args = ap.parse_args()
    if args.case:
        print(json.dumps(run_case(args.case, args.sim_seconds, args.world)))
        return 0
    cases = [(1, 60.0), (10, 20.0), (50, 5.0)]
    results = {}
    # every case with a model cache of its own (sim/robot.py): the first load of the run
    # expands the xacro (cold, as on the first launch after an install or a model edit), the
    # cases load it from the cache (warm, as every launch after that)
    with tempfile.TemporaryDirectory(prefix="bfs-bench-") as cache:
        env = dict(os.environ, BULLET_FLOOR_SIM_CACHE=cache)
        load_cold = _case(1, 0.1, env)["load_s"]
        for n, sim_s in cases:
            results[n] = _case(n, args.sim_seconds or sim_s, env)
        real = None
        if args.real:
            _case(1, 0.1, env, args.real)            # its first load fills the map cache
            real = _case(10, args.sim_seconds or 20.0, env, args.real)
    print("%-7s %8s %8s %9s %10s %12s %12s %9s %8s %7s" % (
        "robots", "sim_s", "wall_s", "rtf", "load_s", "raw_rays/s", "lidar_rays/s", "ray_ovh",
        "rss_mb", "stalls"))
    for n, r in sorted(results.items()):
        print("%-7d %8.1f %8.2f %9.1f %10.3f %12.0f %12.0f %9.2f %8.1f %7d" % (
            n, r["sim_s"], r["wall_s"], r["rtf"], r["load_s"], r["raw_rays_per_s"],
            r["lidar_rays_per_s"], r["ray_overhead"], r["rss_mb"], r["stalls"]))
    print("load_s: office world, model from the cache; the first load (xacro expanded, "
          "xacro and yourdfpy imported): load_cold_s=%.3f" % load_cold)
    print("lidar ray tests through: %s; raw = pybullet.rayTestBatch" % results[10]["ray_path"])
    print("ray_overhead in the BENCH line is the worst of the three cases")
    print("targets: rtf_1 >= 150, rtf_10 >= 30, rtf_50 >= 4, ray_overhead <= 1.3, "
          "load_s < 0.5 (office, 2 robots' worth of model loading included), rss_mb_10 < 250")
    print("BENCH sim rtf_1=%.1f rtf_10=%.1f rtf_50=%.2f ray_overhead=%.2f load_s=%.3f rss_mb_10=%.1f"
          % (results[1]["rtf"], results[10]["rtf"], results[50]["rtf"],
             max(r["ray_overhead"] for r in results.values()), results[1]["load_s"],
             results[10]["rss_mb"]))
    if real is not None:
        print("%s, 10 robots: rtf %.1f (office %.1f, ratio %.2f; target >= 0.67), load_s %.3f"
              % (args.real, real["rtf"], results[10]["rtf"], real["rtf"] / results[10]["rtf"],
                 real["load_s"]))
        print("BENCH sim_real world=%s rtf_10=%.1f office_rtf_10=%.1f ratio=%.2f load_s=%.3f"
              % (args.real, real["rtf"], results[10]["rtf"], real["rtf"] / results[10]["rtf"],
                 real["load_s"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
