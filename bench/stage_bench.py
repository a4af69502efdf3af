#!/usr/bin/env python3
"""Side by side with Stage: our simulator node's real-time factor over Stage's (stageros).

Where ``stageros`` is found (``$STAGEROS``, else on PATH: rtv/Stage 4.3.0 with
ros-simulation/stage_ros 1.8.0, built by the user outside this repo), both simulators run the
same case in turn, each under its own roscore, as fast as they can:

* the same map (office's map.yaml; Stage gets its image as a floorplan bitmap of the same size
  and place), the same robots at the same poses (bench/sim_bench's free, spread-out poses), a
  360-beam lidar of 30 m on each at the Scitos's laser offset;
* the same load: every robot turns in place at 0.5 rad/s (cmd_vel at 5 Hz of sim time), and a
  subscriber (rospy.AnyMsg: no deserialising) on every topic either publishes: each robot's
  odometry, scan and ground truth, /tf and /clock;
* two step rates: 100 Hz (ours by default: physics and /clock at 100 Hz, odometry 50 Hz,
  poses 20 Hz, scans 10 Hz; Stage's ``interval_sim 10``, position models updated every step,
  rangers every 100 ms) and 10 Hz (Stage's default ``interval_sim 100``; ours with the
  ``rates:=stage`` preset, config/rates/stage.yaml: every rate 10 Hz).

stageros publishes each robot's odometry, ground truth, tf and its last scan on every step,
so at 100 Hz it sends scans ten times as often as ours; that is how stage_ros works, and it
is measured as it is.

The real-time factor is sim time gained on /clock over a wall-clock window. Printed:
``BENCH vs_stage rate=100 n1=<ours/Stage> n10=... n50=...`` and the same for ``rate=10``,
ratios of ours over Stage's, with each side's own figures in the table above them. Without
stageros it prints ``BENCH vs_stage skipped: ...`` and exits 0.

Each case runs ``--repeats`` times (3), ours then Stage's back to back; the printed ratio is
the median of the pairs' ratios, with their range beside it (two single runs on a busy 2-core
VM differed by up to 2x in one cell).

Usage: stage_bench.py [--robots 1,10,50] [--rates 100,10] [--window 10] [--repeats 3]
"""
from __future__ import annotations

import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from typing import List, Optional, Sequence, Tuple

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

LASER_XY = (0.3, 0.0)        # the Scitos A5's laser in base_footprint (as ours)
BODY = (0.64, 0.64, 0.5)     # Stage's box for a robot: the Scitos's 0.32 m hull radius


def find_stageros() -> Optional[str]:
    """The stageros executable: ``$STAGEROS`` if set, else ``stageros`` on PATH; None if
    neither."""
    path = os.environ.get("STAGEROS") or shutil.which("stageros")
    return path if path and os.access(path, os.X_OK) else None


def stage_world(n: int, rate: float, tmp: str, name: str = "office") -> str:
    """A Stage .world file of sim_bench's n-robot world ``name``: the map image as a
    floorplan bitmap where map_server puts it, each robot a diff-drive position model with
    a 360-beam ranger; the world steps at ``rate`` Hz."""
    import sim_bench
    from bullet_floor_sim.sim.floormap import load_map

    world, _ = sim_bench._world(n, name=name)
    poses = [tuple(float(v) for v in s.pose) for s in world.specs]
    fmap = load_map(world.config.map_yaml)
    world.close()
    h, w = fmap.grid.shape
    sx, sy = w * fmap.resolution, h * fmap.resolution
    ox, oy, _ = fmap.origin
    image = os.path.join(tmp, "map" + os.path.splitext(fmap.image_path)[1])
    shutil.copyfile(fmap.image_path, image)
    lines = [
        "# made by bench/stage_bench.py from %s" % world.config.map_yaml,
        "resolution %g" % fmap.resolution,
        "interval_sim %d" % int(round(1000.0 / rate)),
        "define lidar ranger ( sensor ( range [ 0.1 30.0 ] fov 360 samples 360 )"
        " size [ 0.05 0.05 0.1 ] update_interval 100 )",
        "define bot position ( size [ %g %g %g ] drive \"diff\" update_interval %d"
        " lidar ( pose [ %g %g 0 0 ] ) )" % (BODY + (int(round(1000.0 / rate)),) + LASER_XY),
        "define floorplan model ( color \"gray30\" boundary 0 gui_nose 0 gui_grid 0"
        " gui_outline 0 gripper_return 0 fiducial_return 0 ranger_return 1 obstacle_return 1 )",
        "floorplan ( name \"map\" bitmap \"%s\" size [ %g %g 1.0 ] pose [ %g %g 0 0 ] )"
        % (os.path.basename(image), sx, sy, ox + 0.5 * sx, oy + 0.5 * sy),
    ]
    for i, (x, y, yaw) in enumerate(poses):
        lines.append("bot ( name \"robot%d\" pose [ %g %g 0 %g ] )" % (i + 1, x, y,
                                                                     math.degrees(yaw)))
    path = os.path.join(tmp, "bench%d.world" % n)
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path


def stage_topics(n: int) -> Tuple[List[str], List[str]]:
    """stageros's per-robot topics (bare for one robot, robot_<i>/ for more) to subscribe,
    and its cmd_vel topics."""
    ns = [""] if n == 1 else ["/robot_%d" % i for i in range(n)]
    subs = ["%s/%s" % (p, t) for p in ns for t in ("odom", "base_scan", "base_pose_ground_truth")]
    return subs + ["/tf"], ["%s/cmd_vel" % p for p in ns]


def our_topics(n: int) -> Tuple[List[str], List[str]]:
    """Our node's topics (as ros_bench subscribes them) and cmd_vel topics."""
    subs = ["/robot%d/%s" % (i + 1, t) for i in range(n)
            for t in ("odom", "base_scan", "base_pose_ground_truth", "pose", "battery_state",
                      "joint_states")]
    return subs + ["/tf"], ["/robot%d/cmd_vel" % (i + 1) for i in range(n)]


def rate_params(rate: float) -> List[str]:
    """Our node's private parameters for a step rate: none at 100 Hz (its defaults), the
    rates:=stage preset (config/rates/stage.yaml) at 10 Hz."""
    if rate == 100.0:
        return []
    from bullet_floor_sim.paths import package_root

    with open(os.path.join(package_root(), "config", "rates", "stage.yaml")) as f:
        preset = yaml.safe_load(f)
    if float(preset["physics_rate"]) != rate:
        raise SystemExit("stage_bench: no preset for a %g Hz step" % rate)
    return ["_%s:=%s" % (k, v) for k, v in preset.items()]


def measure(cmd: List[str], subs: Sequence[str], cmd_topics: Sequence[str], window: float,
            tmp: str) -> float:
    """Sim seconds per wall second on /clock of the simulator ``cmd`` started under its own
    roscore, every topic of ``subs`` subscribed, every robot turning at 0.5 rad/s."""
    import rosgraph
    import rospy
    from ros_bench import _free_port, stop, turn_on_clock

    uri = "http://127.0.0.1:%d" % _free_port()
    env = dict(os.environ, ROS_MASTER_URI=uri, ROS_HOME=tmp)
    os.environ.update(ROS_MASTER_URI=uri)
    core = subprocess.Popen(["roscore", "-p", uri.rsplit(":", 1)[1]], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    sim = None
    try:
        for _ in range(100):
            if rosgraph.is_master_online(uri):
                break
            time.sleep(0.1)
        subprocess.call(["rosparam", "set", "/use_sim_time", "true"], env=env)
        sim = subprocess.Popen(cmd, env=env, cwd=tmp, stdout=open(os.path.join(tmp, "sim.log"),
                                                                  "w"),
                               stderr=subprocess.STDOUT)
        rospy.init_node("stage_bench", anonymous=True, disable_signals=True)
        last = turn_on_clock(list(cmd_topics))
        if "t" not in last:
            raise RuntimeError("no /clock within 60 s from %s (log: %s/sim.log)"
                               % (cmd[0], tmp))
        handles = [rospy.Subscriber(t, rospy.AnyMsg, lambda m: None) for t in subs]
        time.sleep(3.0)
        w0, s0 = time.time(), last["t"]
        time.sleep(window)
        w1, s1 = time.time(), last["t"]
        last["done"] = 1.0    # no more commands: publishers close with the node
        for s in handles:
            s.unregister()
        rospy.signal_shutdown("done")
        return (s1 - s0) / (w1 - w0)
    finally:
        stop(sim, core)


def run_case(side: str, n: int, rate: float, window: float) -> float:
    """One side's real-time factor (``side``: ours or stage)."""
    tmp = tempfile.mkdtemp(prefix="bfs_stage_bench_")
    if side == "stage":
        world = stage_world(n, rate, tmp)
        subs, cmds = stage_topics(n)
        return measure([find_stageros() or "stageros", "-g", world], subs, cmds, window, tmp)
    from ros_bench import _world_file

    world = _world_file(n, tmp)
    subs, cmds = our_topics(n)
    cmd = ["rosrun", "bullet_floor_sim", "simulator", "_world:=" + world,
           "_real_time_factor:=0", "_robot_state_publishers:=false", "_wait_for_subscribers:=false",
           "_max_command_lag:=0"] + rate_params(rate)
    return measure(cmd, subs, cmds, window, tmp)


def _sub(side: str, n: int, rate: float, window: float) -> float:
    """run_case in its own process (rospy.init_node is once per process); nan on failure."""
    out = subprocess.run([sys.executable, __file__, "--case", side, str(n), str(rate),
                          str(window)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         universal_newlines=True)
    lines = out.stdout.strip().splitlines()
    if out.returncode != 0 or not lines:
        print("stage_bench: %s, %d robot(s), %g Hz failed: %s" % (
            side, n, rate, (out.stderr.strip().splitlines() or ["?"])[-1]), file=sys.stderr)
        return float("nan")
    return float(lines[-1])


def paired(n: int, rate: float, window: float, repeats: int) -> Tuple[float, float, float, str]:
    """``repeats`` runs of ours, each followed at once by Stage's (a busy machine's slow
    spells then fall on both sides of a pair): the medians of each side's real-time factor,
    the median of the pairs' ratios, and the ratios' range (text)."""
    import statistics

    pairs = [(_sub("ours", n, rate, window), _sub("stage", n, rate, window))
             for _ in range(repeats)]
    # a side with no /clock progress in its window (Stage once, at 10 Hz) spoils its pair
    good = [(o, s) for o, s in pairs if o > 0 and s > 0]   # (False for nan too)
    lost = "" if len(good) == len(pairs) else "; %d of %d pairs failed" % (
        len(pairs) - len(good), len(pairs))
    if not good:
        print("stage_bench: every pair of %d robot(s) at %g Hz failed: %s" % (n, rate, pairs),
              file=sys.stderr)
        return float("nan"), float("nan"), float("nan"), "all failed"
    if lost:
        print("stage_bench: %d robot(s) at %g Hz: runs (ours, Stage) %s; a side that gained no "
              "sim time is left out" % (n, rate, pairs), file=sys.stderr)
    ratios = [o / s for o, s in good]
    return (statistics.median(o for o, _ in good), statistics.median(s for _, s in good),
            statistics.median(ratios), "%.2f-%.2f%s" % (min(ratios), max(ratios), lost))


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", default="1,10,50")
    ap.add_argument("--rates", default="100,10")
    ap.add_argument("--window", type=float, default=10.0)
    ap.add_argument("--repeats", type=int, default=3,
                    help="pairs (ours, then Stage) per case; the median ratio is printed")
    ap.add_argument("--case", nargs=4, metavar=("SIDE", "N", "RATE", "WINDOW"),
                    help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.case:
        side, n, rate, window = a.case
        print(repr(run_case(side, int(n), float(rate), float(window))))
        return 0
    if find_stageros() is None:
        print("BENCH vs_stage skipped: stageros not found ($STAGEROS unset and no stageros on "
              "PATH; build rtv/Stage 4.3.0 and stage_ros 1.8.0 outside the repo to compare)")
        return 0
    robots = [int(v) for v in a.robots.split(",")]
    rates = [float(v) for v in a.rates.split(",")]
    if a.repeats < 1:
        ap.error("--repeats must be at least 1")
    print("%-6s %-7s %10s %10s %10s %14s" % ("step", "robots", "ours", "stage", "ours/stage",
                                             "pairs' range"))
    for rate in rates:
        ratios = []
        for n in robots:
            ours, stage, ratio, spread = paired(n, rate, a.window, a.repeats)
            ratios.append(ratio)
            print("%-6s %-7d %10.1f %10.1f %10.2f %14s" % ("%g Hz" % rate, n, ours, stage,
                                                            ratio, spread), flush=True)
        print("BENCH vs_stage rate=%g %s" % (rate, " ".join(
            "n%d=%.2f" % (n, r) for n, r in zip(robots, ratios))), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
