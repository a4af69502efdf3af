#!/usr/bin/env python3
"""Full simulator node benchmark: real-time factor with everything published and subscribed.

For 1, 10 and 50 robots (the sim_bench set-up: office world, 360-beam 10 Hz lidars, robots at
free poses) the simulator node runs as fast as it can (``real_time_factor: 0``) under its own
roscore, and one subscriber (rospy.AnyMsg, so it does not deserialise) is attached to every
topic it publishes. The real-time factor is sim time gained on /clock over a wall-clock
window. robot_state_publishers are not started (they publish nothing per step). The node waits
neither for its subscribers nor for late commands here (``~wait_for_subscribers:=false``,
``~max_command_lag:=0``; this process, subscribed to every topic, is itself the slowest
node, and its 5 Hz commands are further apart than the 0.15 s lag: with the waits, 10 robots
ran at 4.5x instead of 30.4x): this measures what the node can send; what a real graph of
nodes holds is bench/demo_legs.py's measure.

Per robot count, three runs, each in its own process:

* "moving": every robot turns in place at 0.5 rad/s (cmd_vel from this process at 5 Hz of
  sim time), so every lidar, odometry and pose changes every step, as in sim_bench; printed
  as ``BENCH ros rtf_1=<x> rtf_10=<x> rtf_50=<x>``. The node's own publishing overhead (wall
  time building and sending messages over wall time stepping the world, which the node
  measures and publishes on ``~publishing_share``, averaged over the window) is printed as
  ``BENCH ros_publishing share_1=<x> share_10=<x> share_50=<x>`` (target <= 0.30).
* "core": the same robots and commands on the bare core World in this process, no ROS:
  ``core_rtf`` in the table, and ``core_rtf / rtf`` the node's total slow-down, which also
  holds what the subscribers' process and the kernel's sockets take from the two cores.
* "still": no command (the core then skips the physics and the lidars reuse their wall
  distances, so it is mostly the node's publishing); ``BENCH ros_still ...``.
* "people": office with its own two robots turning as in "moving" and 10, 50 and 200 people
  walking its regions (people/crowd), the people's ground-truth topics subscribed too:
  ``BENCH people rtf_10=... rtf_50=... rtf_200=...`` (target: rtf_50 >= 20).
* "real": the 10-robot moving case on the largest real SLAM map shipped (malaga_campus,
  62 x 69 m) beside office's: ``BENCH ros_real world=... rtf_10=... office_rtf_10=...
  ratio=...`` (target: ratio >= 0.67).
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from typing import Tuple

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def _free_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


REAL_WORLD = "malaga_campus"   # measured beside office: the largest real SLAM map shipped
PEOPLE = (10, 50, 200)          # the people cases (office, its two robots)


def _world_file(n: int, tmp: str, name: str = "office") -> str:
    import sim_bench

    world, _ = sim_bench._world(n, name=name)
    doc = {"map": world.config.map_yaml, "wall_height": world.config.wall_height,
           "robots": [{"name": s.name, "pose": [float(v) for v in s.pose],
                       "laser": {"fov": 360.0, "resolution": 1.0}} for s in world.specs]}
    world.close()
    path = os.path.join(tmp, "world%d.yaml" % n)
    with open(path, "w") as f:
        yaml.safe_dump(doc, f)
    return path


def _people_world_file(people: int, tmp: str) -> str:
    """office as its world file has it (two robots, their own lidars, its regions), with
    ``people`` people walking them."""
    from bullet_floor_sim.paths import worlds_dir

    src = os.path.join(worlds_dir(), "office", "world.yaml")
    with open(src) as f:
        doc = yaml.safe_load(f)
    doc["map"] = os.path.join(os.path.dirname(src), doc["map"])
    doc["rois"] = os.path.join(os.path.dirname(src), doc["rois"])
    doc["people"] = {"count": people, "seed": 1}
    path = os.path.join(tmp, "office_people%d.yaml" % people)
    with open(path, "w") as f:
        yaml.safe_dump(doc, f)
    return path


GROUND_TRUTH = ("/ground_truth/people", "/ground_truth/tracked_persons",
                "/ground_truth/people_markers")


def _subscribe_everything(n: int, shares: list) -> list:
    """A subscriber on every topic of n robots, /tf and the node's publishing share (appended
    to ``shares``)."""
    import rospy
    from std_msgs.msg import Float64

    subs = []
    for name in ("odom", "base_scan", "base_pose_ground_truth", "pose", "battery_state",
                 "joint_states"):
        for i in range(n):
            subs.append(rospy.Subscriber("/robot%d/%s" % (i + 1, name), rospy.AnyMsg,
                                         lambda m: None))
    subs.append(rospy.Subscriber("/tf", rospy.AnyMsg, lambda m: None))
    subs += [rospy.Subscriber(t, rospy.AnyMsg, lambda m: None) for t in GROUND_TRUTH]
    subs.append(rospy.Subscriber("/simulator/publishing_share", Float64,
                                 lambda m: shares.append(m.data)))
    return subs


def turn_on_clock(cmd_topics: list, wait: float = 60.0) -> dict:
    """Subscribe /clock; on it, every 0.2 s of sim time (5 Hz: the simulator's watchdog
    stops a robot after 0.5 s), tell each of ``cmd_topics`` to turn in place at 0.5 rad/s.
    Returns the dict whose "t" is the last /clock (sim s), once one came (up to ``wait``
    wall seconds); set its "done" to stop the commands."""
    import rospy
    from geometry_msgs.msg import Twist
    from rosgraph_msgs.msg import Clock

    last: dict = {}
    pubs = [rospy.Publisher(t, Twist, queue_size=1) for t in cmd_topics]
    turn = Twist()
    turn.angular.z = 0.5

    def on_clock(m):
        t = last["t"] = m.clock.to_sec()
        if pubs and t - last.get("cmd", -1.0) >= 0.2 and "done" not in last:
            last["cmd"] = t
            for p in pubs:
                p.publish(turn)

    rospy.Subscriber("/clock", Clock, on_clock)
    deadline = time.time() + wait
    while "t" not in last and time.time() < deadline:
        time.sleep(0.1)
    return last


def stop(*procs) -> None:
    """SIGINT each process that is not None, SIGKILL after 10 s."""
    for p in procs:
        if p is not None:
            p.send_signal(signal.SIGINT)
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()


def _seconds_to_stop(proc: subprocess.Popen) -> float:
    """Seconds a process takes to exit on SIGINT (inf after 30)."""
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(30)
        return time.monotonic() - t0
    except subprocess.TimeoutExpired:
        return float("inf")


def run_case(n: int, window: float, moving: bool = True, name: str = "office",
             people: int = -1) -> Tuple[float, float, float]:
    """Achieved real-time factor of the node with n robots (sim s per wall s), the seconds
    it took to exit on SIGINT, and its mean publishing share over the window. With
    ``people`` >= 0: office's own two robots (``n`` must be 2) and that many people."""
    import rosgraph
    import rospy

    tmp = tempfile.mkdtemp(prefix="bfs_ros_bench_")
    world = _people_world_file(people, tmp) if people >= 0 else _world_file(n, tmp, name)
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % _free_port(), ROS_HOME=tmp)
    os.environ.update(ROS_MASTER_URI=env["ROS_MASTER_URI"])
    core = subprocess.Popen(["roscore", "-p", env["ROS_MASTER_URI"].rsplit(":", 1)[1]], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    sim = None
    try:
        for _ in range(100):
            if rosgraph.is_master_online(env["ROS_MASTER_URI"]):
                break
            time.sleep(0.1)
        subprocess.call(["rosparam", "set", "/use_sim_time", "true"], env=env)
        sim = subprocess.Popen(["rosrun", "bullet_floor_sim", "simulator", "_world:=" + world,
                                "_real_time_factor:=0", "_robot_state_publishers:=false",
                                "_report_period:=1.0", "_wait_for_subscribers:=false",
                                "_max_command_lag:=0"],
                               env=env, stdout=open(os.path.join(tmp, "sim.log"), "w"),
                               stderr=subprocess.STDOUT)
        rospy.init_node("ros_bench_%d" % n, anonymous=True, disable_signals=True)
        last = turn_on_clock(["/robot%d/cmd_vel" % (i + 1) for i in range(n)] if moving else [])
        shares: list = []
        subs = _subscribe_everything(n, shares)
        time.sleep(3.0)                        # connections up
        w0, s0 = time.time(), last["t"]
        k0 = len(shares)
        time.sleep(window)
        w1, s1 = time.time(), last["t"]
        in_window = shares[k0 + 1:len(shares)] or shares[k0:] or [float("nan")]
        # how long the node takes to exit on SIGINT, subscribers still attached (it used to
        # hang now and then until roslaunch's SIGKILL)
        stop_s = _seconds_to_stop(sim)
        for s in subs:
            s.unregister()
        rospy.signal_shutdown("done")
        return (s1 - s0) / (w1 - w0), stop_s, sum(in_window) / len(in_window)
    finally:
        stop(sim, core)


def run_core(n: int, sim_seconds: float) -> float:
    """Real-time factor of the bare core World with the "moving" commands: every robot turns
    at 0.5 rad/s, commanded every 0.2 s of sim time."""
    import sim_bench

    world, _ = sim_bench._world(n)
    steps = int(round(sim_seconds / world.clock.dt))
    every = int(round(0.2 / world.clock.dt))
    t0 = time.perf_counter()
    for k in range(steps):
        if k % every == 0:
            for i in range(n):
                world.command(i, 0.0, 0.0, 0.5)
        world.step()
    rtf = steps * world.clock.dt / (time.perf_counter() - t0)
    world.close()
    return rtf


def _sub(*args: str) -> list:
    out = subprocess.run([sys.executable, __file__] + list(args), stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, universal_newlines=True)
    lines = out.stdout.strip().splitlines()
    return ([float(v) for v in lines[-1].split()] if out.returncode == 0 and lines
            else [float("nan")] * 3)


def main() -> int:
    if len(sys.argv) in (4, 5) and sys.argv[1] == "--case":
        name = sys.argv[4] if len(sys.argv) == 5 else "office"
        print("%r %r %r" % run_case(int(sys.argv[2]), 10.0, sys.argv[3] == "moving", name))
        return 0
    if len(sys.argv) == 3 and sys.argv[1] == "--people":
        print("%r %r %r" % run_case(2, 10.0, True, people=int(sys.argv[2])))
        return 0
    if len(sys.argv) == 3 and sys.argv[1] == "--core":
        n = int(sys.argv[2])
        print("%r" % run_core(n, {1: 60.0, 10: 15.0}.get(n, 3.0)))
        return 0
    sizes = (1, 10, 50)
    rtf, stop, share, core = {}, {}, {}, {}
    for n in sizes:   # each case in its own process: rospy.init_node is once per process
        core[n] = _sub("--core", str(n))[0]
        for mode in ("moving", "still"):
            rtf[n, mode], stop[n, mode], share[n, mode] = _sub("--case", str(n), mode)
    real = _sub("--case", "10", "moving", REAL_WORLD)[0]   # the largest real SLAM map
    crowd = {p: _sub("--people", str(p)) for p in PEOPLE}
    print("%-7s %10s %10s %14s %10s %10s %16s" % ("robots", "rtf", "core_rtf", "core_rtf/rtf",
                                                  "pub_share", "rtf_still", "sigint_exit_s"))
    for n in sizes:
        print("%-7d %10.1f %10.1f %14.2f %10.2f %10.1f %16s" % (
            n, rtf[n, "moving"], core[n], core[n] / rtf[n, "moving"], share[n, "moving"],
            rtf[n, "still"], "%.2f / %.2f" % (stop[n, "moving"], stop[n, "still"])))
    print("rtf, pub_share: the node with every robot moving, a subscriber on every topic; "
          "core_rtf: the same motion on the bare core World")
    print("pub_share: the node's wall time building and sending messages / its wall time "
          "stepping the world")
    print("sigint_exit_s: seconds from SIGINT to the node's exit, subscribers attached")
    print("targets: rtf_1 >= 100, rtf_10 >= 20, rtf_50 >= 3, pub_share <= 0.30")
    print("BENCH ros rtf_1=%.1f rtf_10=%.1f rtf_50=%.2f"
          % tuple(rtf[n, "moving"] for n in sizes))
    print("BENCH ros_publishing share_1=%.2f share_10=%.2f share_50=%.2f"
          % tuple(share[n, "moving"] for n in sizes))
    print("BENCH ros_still rtf_1=%.1f rtf_10=%.1f rtf_50=%.2f"
          % tuple(rtf[n, "still"] for n in sizes))
    print("BENCH ros_shutdown max_s=%.2f" % max(stop.values()))
    print("%s, 10 robots moving: rtf %.1f (office %.1f, ratio %.2f; target >= 0.67)"
          % (REAL_WORLD, real, rtf[10, "moving"], real / rtf[10, "moving"]))
    print("BENCH ros_real world=%s rtf_10=%.1f office_rtf_10=%.1f ratio=%.2f"
          % (REAL_WORLD, real, rtf[10, "moving"], real / rtf[10, "moving"]))
    print("office, its 2 robots turning, people walking, every topic and the ground truth "
          "subscribed (target: rtf_50 >= 20):")
    print("%-7s %10s %10s" % ("people", "rtf", "pub_share"))
    for p in PEOPLE:
        print("%-7d %10.1f %10.2f" % (p, crowd[p][0], crowd[p][2]))
    print("BENCH people " + " ".join("rtf_%d=%.1f" % (p, crowd[p][0]) for p in PEOPLE))
    return 0


if __name__ == "__main__":
    sys.exit(main())
