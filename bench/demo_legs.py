#!/usr/bin/env python3
"""The full ROS demo, counted: how many walker legs demo.launch gives up (``make demo-legs``).

Starts ``roslaunch bullet_floor_sim demo.launch`` headless (rviz off, embedded navigation, the
observer following) under its own master and ROS_HOME, one world after the other, and listens
to the walker's ``/<walker>/markov_walker/leg`` (one JSON per leg) until LEGS legs have ended.
Prints a table and one line per world:

    DEMO world=<name> rtf_asked=<x> legs=<n> given_up=<share> rtf=<sim s per wall s>
        waited_max=<largest share of wall time the simulator held its clock for one node>

``rtf`` is sim time over wall time from the first leg's end to the last's; ``waited`` is read
from the simulator's own report lines (sim/pacing.py): the mean share of the wall time it held
its clock for the slowest controller (cmd_vel) or subscriber. The table lists the three it
waited for most. Each given-up leg is printed with its reason, each node's CPU share (cores,
from /proc, over the legs) and resident memory (first, largest and last of its samples, every
10 s), and each world's DEMO line as soon as it is done (``  done: DEMO ...`` on stderr).
``--people N`` adds N people (demo.launch people:=N); ``--memory-every S`` prints every node's
memory every S wall seconds (a soak). Interrupted (^C or a kill), it stops
the running demo and prints the table of the worlds done before it, exit code 130.

    .venv/bin/python bench/demo_legs.py --legs 200 --rtf 0 --worlds office malaga_corridor
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from typing import Tuple

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from eval_worlds import checked, shipped, world_label  # noqa: E402
from ros_bench import _free_port  # noqa: E402
from node_usage import Usage  # noqa: E402

_SAMPLE_EVERY = 10.0   # wall s between samples of the nodes' CPU time and memory

_WAIT = re.compile(r"waited for (?:cmd_vel of|subscribers) ([^;]*)")
_SHARE = re.compile(r"(\S+(?: \(\S+\))?) (\d+)%")


class _Legs:
    """The walker's legs as they end, with the sim time of each."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.legs = []  # type: list

    def add(self, msg) -> None:
        leg = json.loads(msg.data)
        with self.lock:  # (sim time the leg ended, wall time it was heard, the leg)
            self.legs.append((leg["started"] + leg["duration"], time.time(), leg))


def _master() -> Tuple[subprocess.Popen, int]:
    """A master of our own for every run (this process's listener joins it once)."""
    port = _free_port()
    proc = subprocess.Popen(["rosmaster", "--core", "-p", str(port)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 30.0
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), 1.0).close()
            return proc, port
        except OSError:
            if time.time() > deadline or proc.poll() is not None:
                raise RuntimeError("rosmaster did not start on port %d" % port)
            time.sleep(0.2)


def _stop(proc: subprocess.Popen, wait: float) -> None:
    """SIGINT to a process group, SIGKILL after ``wait`` seconds (a group already gone is
    left alone)."""
    try:
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(wait)
    except ProcessLookupError:
        return
    except subprocess.TimeoutExpired:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def _listen(port: int, walker: str, legs: _Legs) -> None:
    os.environ["ROS_MASTER_URI"] = "http://127.0.0.1:%d" % port
    import rospy
    from std_msgs.msg import String

    rospy.init_node("demo_legs", anonymous=True, disable_signals=True)
    rospy.Subscriber("/%s/markov_walker/leg" % walker, String, legs.add, queue_size=100)


def run_world(world: str, n: int, rtf: float, seed: int, timeout: float, port: int,
              legs: _Legs, people: int = -1, memory_every: float = 0.0) -> dict:
    """One demo run until ``n`` legs have ended (or ``timeout`` wall seconds), with
    ``people`` people (-1: as the world file says); every ``memory_every`` wall seconds
    (0: never) a line of each node's resident memory."""
    label = world_label(world)   # a corpus world's name, where ``world`` is its path
    home = tempfile.mkdtemp(prefix="bfs_demo_legs_")
    log = open(os.path.join(home, "launch.log"), "w")
    env = dict(os.environ, ROS_HOME=home, ROS_MASTER_URI="http://127.0.0.1:%d" % port)
    cmd = ["roslaunch", "bullet_floor_sim", "demo.launch", "world:=" + world,
           "nav:=builtin", "rviz:=false", "rtf:=%g" % rtf, "seed:=%d" % seed,
           "people:=%d" % people]
    with legs.lock:
        del legs.legs[:]
    proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    usage = Usage(proc.pid)
    try:
        t0 = time.time()
        t_end = t0 + timeout
        last = next_sample = next_memory = t0
        while time.time() < t_end and proc.poll() is None:
            with legs.lock:
                done = len(legs.legs)
            if done >= n:
                break
            now = time.time()
            if now >= next_sample:
                next_sample = now + _SAMPLE_EVERY
                usage.take()
            if memory_every > 0 and now >= next_memory:
                next_memory = now + memory_every
                print("  %s: memory at %.0f s: %s" % (label, now - t0, ", ".join(
                    "%s %.0f MB" % (k, v[1]) for k, v in sorted(usage.samples[-1][1].items()))),
                    file=sys.stderr, flush=True)
            if now - last > 30.0:
                last = now
                print("  %s: %d/%d legs" % (label, done, n), file=sys.stderr, flush=True)
            time.sleep(1.0)
        ended = proc.poll()        # demo.launch stopped by itself (a required node died)
        usage.take()
    finally:
        _stop(proc, 30.0)
        log.close()
    with legs.lock:
        got = list(legs.legs[:n])
    out = _summary(world, rtf, got, os.path.join(home, "launch.log"))
    out["cpu"] = usage.cpu_shares(got[0][1] if got else None)
    out["rss"] = {k: usage.rss(k) for k in (usage.samples[-1][1] if usage.samples else {})}
    if ended is not None and len(got) < n:
        out["ended"] = "demo.launch ended (exit code %d) after %d of %d legs: %s" % (
            ended, len(got), n, _why_ended(os.path.join(home, "launch.log")))
    kept = os.path.join(tempfile.gettempdir(),  # one name per run, so runs can go side by side
                        "bfs_demo_legs_%s_rtf%g_seed%d.log" % (label, rtf, seed))
    shutil.move(os.path.join(home, "launch.log"), kept)  # the nodes' output, for a look
    shutil.rmtree(home, ignore_errors=True)
    print("  %s: the nodes' output is in %s" % (label, kept), file=sys.stderr)
    return out


def _why_ended(log_path: str) -> str:
    """The first FATAL line of a launch's output, else its first dead required process."""
    died = None
    with open(log_path, errors="replace") as f:
        for line in f:
            if "[FATAL]" in line:
                return line.split("]: ", 1)[-1].strip()
            if died is None and "REQUIRED process" in line:
                died = line[line.index("REQUIRED process"):].strip()
    return died or "no FATAL line in its output"


def _summary(world: str, rtf: float, got: list, log_path: str) -> dict:
    failed = [leg for _, _, leg in got if leg.get("outcome") != "succeeded"]
    sim = got[-1][0] - got[0][0] if len(got) > 1 else 0.0
    wall = got[-1][1] - got[0][1] if len(got) > 1 else 0.0
    waited = {}  # type: dict
    reports = 0
    with open(log_path) as f:
        for line in f:
            if "simulator: real-time factor" in line:
                reports += 1
            for m in _WAIT.finditer(line.strip()):
                for name, pct in _SHARE.findall(m.group(1)):
                    waited[name] = waited.get(name, 0) + int(pct)
    return {"world": world_label(world), "rtf_asked": rtf, "legs": len(got),
            "given_up": len(failed) / max(1, len(got)), "rtf": sim / wall if wall > 0 else 0.0,
            "waited": {k: v / 100.0 / max(1, reports) for k, v in waited.items()},
            "failed": failed}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--legs", type=int, default=200)
    p.add_argument("--rtf", type=float, default=0.0, help="demo.launch rtf (0 = flat out)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--timeout", type=float, default=3600.0, help="wall seconds per world")
    p.add_argument("--worlds", nargs="*", default=None,
                   help="names under worlds/ or world.yaml paths (default: the buildings under "
                        "worlds/, then the corpus built: make corpus)")
    p.add_argument("--people", type=int, default=-1,
                   help="people walking the regions (-1 = as each world file says)")
    p.add_argument("--memory-every", type=float, default=0.0, metavar="S",
                   help="every S wall seconds, a line of each node's resident memory (a soak)")
    p.add_argument("--allow-unreachable", action="store_true",
                   help="run a world whose map check finds a region the walker cannot reach "
                        "or an observer cut off (check_world); the output says so")
    args = p.parse_args()
    worlds, notes = checked(args.worlds or shipped(), bool(args.worlds),
                            args.allow_unreachable)   # before any runs
    rows = []
    master, port = _master()
    legs = _Legs()
    signal.signal(signal.SIGTERM, _interrupt)   # kill: as ^C, the worlds done are kept
    cut = current = ""
    try:
        _listen(port, "robot1", legs)
        for w in worlds:
            current = world_label(w)
            print("== %s: demo.launch rtf:=%g, %d legs, seed %d%s" % (
                current, args.rtf, args.legs, args.seed, "" if current == w else " (%s)" % w),
                  file=sys.stderr, flush=True)
            rows.append(run_world(w, args.legs, args.rtf, args.seed, args.timeout, port, legs,
                                  args.people, args.memory_every))
            _report_world(rows[-1])
    except KeyboardInterrupt:
        cut = current or "its start"
    finally:
        _stop(master, 10.0)
    for n in notes:
        print("  note: %s" % n, file=sys.stderr)
    _table(rows)
    if cut:
        print("demo_legs: interrupted during %s: the table has the %d world(s) done before it"
              % (cut, len(rows)), file=sys.stderr)
        return 130
    ended = [r for r in rows if "ended" in r]
    if ended:
        print("demo_legs: %d world(s) ended before their legs: %s" % (
            len(ended), ", ".join(r["world"] for r in ended)), file=sys.stderr)
        return 1
    return 0


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _report_world(r: dict) -> None:
    """One world's result as soon as it is done (stderr, with the progress lines): why it
    ended early, each leg given up, and its DEMO line."""
    if "ended" in r:
        print("  %s: %s" % (r["world"], r["ended"]), file=sys.stderr)
    for leg in r["failed"]:
        print("  %s given up: %s -> %s, %s: %s" % (r["world"], leg.get("from"), leg.get("to"),
                                                  leg.get("outcome"), leg.get("detail")),
              file=sys.stderr)
    cpu = sorted(r["cpu"].items(), key=lambda kv: -kv[1])
    total = sum(v for _, v in cpu)
    print("  %s: CPU (cores) over the legs: %s; all nodes %.2f cores, %.0f ms of CPU per sim "
          "second (not rosmaster)" % (r["world"], ", ".join("%s %.2f" % kv for kv in cpu), total,
                                      1000.0 * total / r["rtf"] if r["rtf"] > 0 else 0.0),
          file=sys.stderr)
    grown = sorted(r["rss"].items(), key=lambda kv: -max(kv[1]))[:6]
    print("  %s: memory (MB, first / largest / last sample): %s" % (r["world"], ", ".join(
        "%s %.0f / %.0f / %.0f" % (k, next((v for v in m if v), 0.0), max(m), m[-1])
        for k, m in grown)), file=sys.stderr)
    print("  done: %s" % _demo_line(r), file=sys.stderr, flush=True)


def _demo_line(r: dict) -> str:
    return "DEMO world=%s rtf_asked=%g legs=%d given_up=%.3f rtf=%.1f waited_max=%.3f" % (
        r["world"], r["rtf_asked"], r["legs"], r["given_up"], r["rtf"],
        max(r["waited"].values(), default=0.0))


def _table(rows: list) -> None:
    """The table of the worlds done, then their DEMO lines (stdout)."""
    print("| world | rtf asked | legs | given up | rtf achieved | the clock waited most for |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        top = sorted(r["waited"].items(), key=lambda kv: -kv[1])[:3]
        waits = ", ".join("%s %.0f %%" % (k, 100 * v) for k, v in top)
        print("| %s | %g | %d | %.1f %% | %.1fx | %s |" % (
            r["world"], r["rtf_asked"], r["legs"], 100 * r["given_up"], r["rtf"], waits or "-"))
    for r in rows:
        print(_demo_line(r))


if __name__ == "__main__":
    sys.exit(main())
