#!/usr/bin/env python3
"""The write journal's cost per operation during an outage, by how much it already holds.

For each size N (10^3, 10^4, 10^5 journalled writes of about 1 kB, trajectory chunks of 8
poses), an embedded store whose SQLite file another connection holds locked (the database is
down) is given a journal of N lines, then timed, best of ``reps``:

* write: one insert, journalled (append + fsync);
* read: one find, refused with the count of journalled writes;
* retry: one replay attempt that finds the database still down;
* pending: the count of waiting writes;

with the peak of Python allocations over one write + read + retry (tracemalloc). Then the
database comes back and the whole journal is replayed (sizes up to ``replay_max``): seconds per
replayed write. Prints a table and ``BENCH journal n=<N> write_ms=... read_ms=... retry_ms=...
pending_ms=... peak_mb=... replay_us=...`` per size.

    .venv/bin/python bench/journal_cost.py [--sizes 1000 10000 100000] [--replay-max 10000]

Only public store calls are timed, and the journal is built with the JSON the store writes,
so the same script measures an earlier commit's store (``PYTHONPATH=<its src>``).
"""
from __future__ import annotations

import argparse
import datetime
import gc
import os
import shutil
import sqlite3
import sys
import tempfile
import time
import tracemalloc
from typing import Callable, Dict

HERE = os.path.dirname(os.path.abspath(__file__))
if not os.environ.get("PYTHONPATH"):
    sys.path.insert(0, os.path.join(HERE, "..", "src"))


def _chunk(i: int) -> dict:
    import bson

    t0 = datetime.datetime(2026, 1, 1) + datetime.timedelta(seconds=i)
    return {"_id": bson.ObjectId(), "uuid": "walker-%06d" % (i // 100), "chunk": i,
            "poses": [{"t": t0 + datetime.timedelta(milliseconds=50 * k),
                       "x": 1.0 + 0.01 * k, "y": 2.0 - 0.01 * k, "theta": 0.1 * k}
                      for k in range(8)]}


def _journal_lines(n: int) -> bytes:
    from bson import json_util

    opts = json_util.JSONOptions(json_mode=json_util.JSONMode.CANONICAL, tz_aware=False)
    return b"".join(json_util.dumps({"op": "insert", "db": "d", "coll": "c", "doc": _chunk(i)},
                                    json_options=opts).encode("utf-8") + b"\n"
                    for i in range(n))


def _best(fn: Callable[[], None], reps: int) -> float:
    best = float("inf")
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def measure(n: int, reps: int, replay_max: int, tmp: str) -> Dict[str, float]:
    from bullet_floor_sim.data.store import StoreUnavailable, open_store

    root = os.path.join(tmp, str(n))
    store = open_store(os.path.join(root, "db"), journal_dir=os.path.join(root, "j"),
                       timeout=0.01, retry_interval=3600.0)
    store.insert("d", "c", {"i": -1})
    lock = sqlite3.connect(os.path.join(root, "db", "d.sqlite3"), isolation_level=None)
    lock.execute("BEGIN EXCLUSIVE")
    store.insert("d", "c", _chunk(-1))               # down: the journal starts
    with open(store.journal_path, "ab") as f:
        f.write(_journal_lines(n - 1))
    i = [n]

    def write() -> None:
        store.insert("d", "c", _chunk(i[0]))
        i[0] += 1

    def read() -> None:
        try:
            store.find("d", "c")
        except StoreUnavailable:
            return
        raise RuntimeError("the database answered while locked")

    def retry() -> None:
        if store.replay():
            raise RuntimeError("the replay went through while the database was locked")

    out = {"n": n, "journal_mb": os.path.getsize(store.journal_path) / 1e6}
    out["write_ms"] = _best(write, reps) * 1e3
    out["read_ms"] = _best(read, reps) * 1e3
    out["retry_ms"] = _best(retry, reps) * 1e3
    out["pending_ms"] = _best(lambda: store.pending, reps) * 1e3
    gc.collect()
    tracemalloc.start()
    write()
    read()
    retry()
    out["peak_mb"] = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    lock.execute("ROLLBACK")
    lock.close()
    if n <= replay_max:
        waiting = store.pending
        t0 = time.perf_counter()
        if not store.replay():
            raise RuntimeError("the replay did not finish")
        out["replay_us"] = (time.perf_counter() - t0) / waiting * 1e6
    store.close()
    shutil.rmtree(root, ignore_errors=True)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000, 100000])
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--replay-max", type=int, default=10000,
                   help="replay the whole journal (timed) up to this size")
    args = p.parse_args(argv)
    tmp = tempfile.mkdtemp(prefix="journal_cost-")
    rows = []
    try:
        for n in args.sizes:
            rows.append(measure(n, args.reps, args.replay_max, tmp))
            print("  journal of %d writes measured" % n, file=sys.stderr, flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("journal cost per operation, database down (best of %d)" % args.reps)
    print("%8s %8s %9s %8s %9s %10s %8s %10s" % ("entries", "MB", "write ms", "read ms",
                                               "retry ms", "pending ms", "peak MB",
                                               "replay us"))
    for r in rows:
        print("%8d %8.1f %9.2f %8.2f %9.2f %10.3f %8.2f %10s" % (
            r["n"], r["journal_mb"], r["write_ms"], r["read_ms"], r["retry_ms"],
            r["pending_ms"], r["peak_mb"], "%.0f" % r["replay_us"] if "replay_us" in r else "-"))
    for r in rows:
        print("BENCH journal n=%d write_ms=%.2f read_ms=%.2f retry_ms=%.2f pending_ms=%.3f "
              "peak_mb=%.2f replay_us=%s" % (
                  r["n"], r["write_ms"], r["read_ms"], r["retry_ms"], r["pending_ms"],
                  r["peak_mb"], "%.0f" % r["replay_us"] if "replay_us" in r else "na"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
