#!/usr/bin/env python3
"""Trajectory benchmark: poses/s the recorder sustains, and the export of a simulated day.

Prints a table and ends with one machine-readable line:

    BENCH trajectory record_poses_per_s=<x> record_region_poses_per_s=<x> \
record_msgs_poses_per_s=<x> chunk_insert_max_ms=<x> export_day_s=<x> export_day_cpu_s=<x> \
export_day_poses=<n> export_day_chunks=<n>

* record: the recorder's path without the ROS transport: per walker a core ``Chunker``
  (period 30 s), and every closed chunk turned into mongodb_store's document
  (``chunk_fields``) and inserted into the embedded store (``insert_message``, the same call
  the node makes, SQLite synchronous=NORMAL as the node opens it). 100 walkers at 200 Hz for
  30 s of sim time (600,000 poses; each chunk 6,001 poses), plus each walker's last chunk.
  Target: >= 20,000 poses/s (100 walkers at 200 Hz).
  ``region``: the same with ``split="region"`` over worlds/office's 15 ROIs.
  ``msgs``: the same starting from geometry_msgs/PoseStamped messages (the node's conversion
  to pose tuples included; needs the ROS Python packages, else "na").
  ``chunk_insert_max_ms``: the slowest single chunk store (it blocks the pose callback).
* export_day: one walker at 10 Hz for 24 h of sim time (864,000 poses, 2,880 chunks of 30 s)
  in the embedded store, exported by ``trajectories export --db DIR --out FILE`` in a fresh
  process (interpreter start-up and imports included). Target: < 5 s.

Wall-clock rates depend on what else runs on the machine; the table also gives poses per
CPU-second of this process (and the export's CPU time) and the load average.
"""
from __future__ import annotations

import argparse
import gc
import importlib.util
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from typing import Callable, List, Optional, Tuple

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, ".."))
if importlib.util.find_spec("bullet_floor_sim") is None:  # else the workspace's (with msgs)
    sys.path.insert(0, os.path.join(REPO, "src"))

from bullet_floor_sim.data.rois import load_rois  # noqa: E402
from bullet_floor_sim.data.store import insert_message, open_store  # noqa: E402
from bullet_floor_sim.data.trajectory import (  # noqa: E402
    COLLECTION, DATABASE, STORED_TYPE, Chunker, RegionLocator, chunk_fields, ensure_indexes)

NS = 1000000000
TARGET_POSES_PER_S = 20000.0
TARGET_EXPORT_S = 5.0
OFFICE_ROIS = os.path.join(REPO, "worlds", "office", "rois.yaml")


def walker_pose(w: int, k: int, hz: float, t0: int = 10 * NS) -> Tuple:
    """Walker w's k-th pose: a slow loop through the office (x 2..28, y 2..18)."""
    t = t0 + int(k * NS / hz)
    s = k / hz
    x = 15.0 + 12.0 * math.sin(0.02 * s + w)
    y = 10.0 + 7.0 * math.sin(0.031 * s + 2 * w)
    yaw = 0.02 * s + w
    return (t, x, y, 0.0, 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def open_bench_store(path: str):
    store = open_store(path, journal_dir=os.path.join(path, "journal"))
    ensure_indexes(store)  # as the recorder does
    return store


def record(store, streams: List[List], split: str = "period",
           convert: Optional[Callable] = None) -> Tuple[float, float, int, float, int]:
    """Feed interleaved walker streams through chunker + store.

    Returns:
        (wall seconds, CPU seconds, poses, slowest chunk insert in ms, chunks stored)
    """
    region_of = RegionLocator(load_rois(OFFICE_ROIS)) if split == "region" else None
    chunkers = [Chunker(period=30.0, split=split, region_of=region_of) for _ in streams]
    slowest = 0.0
    stored = 0
    seq = 0

    def put(chunk) -> None:
        nonlocal slowest, stored, seq
        t = time.perf_counter()
        seq += 1
        insert_message(store, DATABASE, COLLECTION, chunk_fields(chunk, chunk.end_ns, seq),
                       STORED_TYPE, meta={"map": "office", "taken": "online",
                                          "closed_by": chunk.closed_by},
                       inserted_by="/bench", now=chunk.end_ns / 1e9, stamp_ns=chunk.end_ns)
        slowest = max(slowest, time.perf_counter() - t)
        stored += 1

    n = len(streams[0])
    gc.collect()
    gc.freeze()  # the pre-built input is not the recorder's: keep it out of the collector
    t0 = time.perf_counter()
    c0 = time.process_time()
    for k in range(n):
        for ch, stream in zip(chunkers, streams):
            item = stream[k]
            for chunk in ch.add(convert(item) if convert else item):
                put(chunk)
    for ch in chunkers:
        last = ch.finish()
        if last is not None:
            put(last)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    gc.unfreeze()
    return wall, cpu, n * len(streams), slowest * 1000.0, stored


def pose_messages(streams: List[List]) -> Optional[Tuple[List[List], Callable]]:
    try:
        import rospy
        from geometry_msgs.msg import PoseStamped

        from bullet_floor_sim.ros.convert import pose_of_msg
    except ImportError:
        return None
    out = []
    for stream in streams:
        msgs = []
        for t, x, y, z, qx, qy, qz, qw in stream:
            m = PoseStamped()
            m.header.frame_id = "map"
            m.header.stamp = rospy.Time(t // NS, t % NS)
            p, q = m.pose.position, m.pose.orientation
            p.x, p.y, p.z, q.x, q.y, q.z, q.w = x, y, z, qx, qy, qz, qw
            msgs.append(m)
        out.append(msgs)
    return out, pose_of_msg


def export_day(workdir: str, hours: float) -> Tuple[float, float, int, int, float]:
    """Store a day of one walker at 10 Hz, export it in a fresh process.

    Returns:
        (export wall seconds, export CPU seconds, poses, chunks, store seconds)
    """
    db = os.path.join(workdir, "day")
    store = open_bench_store(db)
    stream = [walker_pose(0, k, 10.0) for k in range(int(hours * 3600 * 10))]
    fill, _, poses, _, chunks = record(store, [stream])
    store.close()
    out = os.path.join(workdir, "day.jsonl")
    env = dict(os.environ, ROS_HOME=os.path.join(workdir, "ros_home"))
    env["PYTHONPATH"] = os.path.join(REPO, "src") + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, os.path.join(REPO, "nodes", "trajectories"), "export", "--db", db,
           "--out", out]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    seconds = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if res.returncode != 0:
        raise SystemExit("export failed: %s" % res.stderr.decode())
    with open(out) as f:
        lines = sum(1 for _ in f)
    if lines != chunks:
        raise SystemExit("export wrote %d lines for %d stored chunks" % (lines, chunks))
    return seconds, cpu, len(stream), chunks, fill


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walkers", type=int, default=100)
    ap.add_argument("--hz", type=float, default=200.0)
    ap.add_argument("--seconds", type=float, default=30.0, help="sim seconds per walker")
    ap.add_argument("--hours", type=float, default=24.0, help="export: sim hours")
    args = ap.parse_args()
    work = tempfile.mkdtemp(prefix="bfs_traj_bench_")
    try:
        n = int(args.seconds * args.hz)
        streams = [[walker_pose(w, k, args.hz) for k in range(n)] for w in range(args.walkers)]
        rows = []

        def run(name, split="period", convert=None, data=streams):
            store = open_bench_store(os.path.join(work, name))
            secs, cpu, poses, slowest, chunks = record(store, data, split, convert)
            store.close()
            rows.append((name, poses, chunks, secs, poses / secs, poses / cpu, slowest))
            return poses / secs, slowest

        rate, slowest = run("period")
        region_rate, slowest_r = run("region", split="region")
        msgs = pose_messages(streams)
        msgs_rate = None
        slowest_m = 0.0
        if msgs is not None:
            msgs_rate, slowest_m = run("msgs", convert=msgs[1], data=msgs[0])
        print("record: %d walkers x %.0f Hz x %.0f s, period 30 s, embedded store (target "
              ">= %.0f poses/s)" % (args.walkers, args.hz, args.seconds, TARGET_POSES_PER_S))
        print("%-8s %10s %7s %8s %12s %14s %14s" % ("input", "poses", "chunks", "wall s",
                                                    "poses/s", "poses/CPU-s", "max insert ms"))
        for name, poses, chunks, secs, r, rc, slow in rows:
            print("%-8s %10d %7d %8.2f %12.0f %14.0f %14.1f" % (name, poses, chunks, secs, r,
                                                                 rc, slow))
        exp_s, exp_cpu, day_poses, day_chunks, fill = export_day(work, args.hours)
        print("export: %.0f h of one walker at 10 Hz: %d poses in %d chunks (stored in %.1f s);"
              " trajectories export in a fresh process: %.2f s wall, %.2f s CPU (target < %.0f s)"
              % (args.hours, day_poses, day_chunks, fill, exp_s, exp_cpu, TARGET_EXPORT_S))
        print("load average while running: %.2f (%d cores)" % (os.getloadavg()[0],
                                                              os.cpu_count() or 0))
        print("BENCH trajectory record_poses_per_s=%.0f record_region_poses_per_s=%.0f "
              "record_msgs_poses_per_s=%s chunk_insert_max_ms=%.1f export_day_s=%.2f "
              "export_day_cpu_s=%.2f export_day_poses=%d export_day_chunks=%d"
              % (rate, region_rate, "na" if msgs_rate is None else "%.0f" % msgs_rate,
                 max(slowest, slowest_r, slowest_m), exp_s, exp_cpu, day_poses, day_chunks))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
