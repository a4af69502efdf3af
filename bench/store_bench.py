#!/usr/bin/env python3
"""Document-store benchmark: insert rate and the "newest version of each ROI of a map" query.

Prints a table and ends with one machine-readable line:

    BENCH store insert_per_s_embedded=<x> query_ms_embedded=<x> insert_per_s_mongo=<x|na> \
query_ms_mongo=<x|na> mongo_server=<mongod|mongoeco|na> mongo_versions=<n|na>

Data: 10,000 ROI versions shaped like SOMA's SOMAROIObject in mongodb_store's layout (id,
map_name, config, type, logtimestamp, posearray of 8 poses, _meta): 2 maps x 50 ROIs x 100
versions, inserted one ``Store.insert()`` at a time in shuffled order, as ROI edits arrive.
Query: ``Store.latest(group_by=[config, id], order_by=logtimestamp, filter={map_name})`` with
an index on (map_name, config, id, logtimestamp -1) -> 50 documents; median of 20 runs.
Target: < 20 ms.

* embedded: this package's embedded store (SQLite + montydb's query engine); the query is one
  SQL ``GROUP BY`` with ``max()`` walking the index.
* mongo: a MongoDB wire-protocol server through pymongo (mongoeco from $BFS_MONGO_PYTHON or
  .venv-mongo, else mongod from PATH; see test/unit/mongo_server.py); the query is an
  aggregation ($match, $sort, $group/$first). mongod gets the full 10,000 versions. mongoeco
  is a MongoDB emulator in Python whose inserts scan the whole collection (about 20 s per
  1,000 documents at 10,000), so it gets 1,000 versions (2 x 50 x 10, in memory) and its
  numbers say nothing about MongoDB's speed; ``mongo_versions`` in the BENCH line says which.
* the journal's cost per operation during an outage at 10^3, 10^4 and 10^5 journalled writes
  (bench/journal_cost.py; ``BENCH journal n=...`` lines).
* montydb-sqlite (reference, not in the BENCH line; ``--no-montydb`` skips it): montydb
  2.5.6's own sqlite storage, which has no indexes and no aggregation: find(map) sorted +
  dedupe in Python.
"""
from __future__ import annotations

import argparse
import os
import random
import shutil
import statistics
import sys
import tempfile
import time
from typing import Any, Callable, Dict, List, Optional, Tuple

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, os.path.join(HERE, "..", "test", "unit"))

DB, COLL = "message_store", "soma_roi"
MAPS, ROIS, VERSIONS = ("office", "lab"), 50, 100
MONGOECO_VERSIONS = 10
INDEX = [("map_name", 1), ("config", 1), ("id", 1), ("logtimestamp", -1)]
TARGET_MS = 20.0


def roi_documents(versions: int = VERSIONS, seed: int = 3) -> List[Dict[str, Any]]:
    """len(MAPS) x ROIS x versions SOMA ROI versions as mongodb_store stores them, shuffled."""
    from bullet_floor_sim.data.store import message_document

    rng = random.Random(seed)
    docs = []
    for map_name in MAPS:
        for roi in range(ROIS):
            for version in range(versions):
                poses = [{"position": {"x": rng.uniform(0, 20), "y": rng.uniform(0, 20),
                                       "z": 0.0},
                          "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
                         for _ in range(8)]
                fields = {"id": str(roi), "map_name": map_name, "map_unique_id": "",
                          "config": "default", "type": rng.choice(["Office", "Kitchen"]),
                          "logtimestamp": 1700000000 + version * 60 + roi,
                          "posearray": {"header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0},
                                                   "frame_id": "map"}, "poses": poses}}
                docs.append(message_document(fields, "soma_msgs/SOMAROIObject",
                                             meta={"map": map_name}, inserted_by="/bench",
                                             now=1700000000.0 + len(docs)))
    rng.shuffle(docs)
    return docs


def timed_query(query: Callable[[], List[Dict[str, Any]]], versions: int, runs: int) -> float:
    """Median wall time of query() in ms; the first (warm-up) result is checked: the newest
    version of each of the 50 ROIs of "office"."""
    found = query()
    newest = {str(r): 1700000000 + (versions - 1) * 60 + r for r in range(ROIS)}
    got = {d["id"]: d["logtimestamp"] for d in found if d["map_name"] == "office"}
    if len(found) != ROIS or got != newest:
        raise SystemExit("store_bench: wrong query result (%d documents)" % len(found))
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        query()
        times.append((time.perf_counter() - t0) * 1000.0)
    return statistics.median(times)


def bench_store(uri: str, journal_dir: str, versions: int, runs: int = 20) -> Tuple[float, float]:
    """(inserts per second, query ms) through this package's Store."""
    from bullet_floor_sim.data.store import open_store

    docs = roi_documents(versions)
    with open_store(uri, journal_dir=journal_dir) as store:
        store.create_index(DB, COLL, INDEX)
        t0 = time.perf_counter()
        for doc in docs:
            store.insert(DB, COLL, doc)
        rate = len(docs) / (time.perf_counter() - t0)
        if store.pending:
            raise SystemExit("store_bench: %d writes were journalled" % store.pending)
        ms = timed_query(lambda: store.latest(DB, COLL, ["config", "id"], "logtimestamp",
                                              filter={"map_name": "office"}), versions, runs)
    return rate, ms


def bench_montydb(directory: str) -> Tuple[float, float]:
    """(inserts per second, query ms) on montydb's own sqlite storage (reference)."""
    from montydb import MontyClient, set_storage

    docs = roi_documents()
    set_storage(directory, storage="sqlite", use_bson=True)
    client = MontyClient(directory)
    coll = client[DB][COLL]
    t0 = time.perf_counter()
    for doc in docs:
        coll.insert_one(dict(doc))
    rate = len(docs) / (time.perf_counter() - t0)

    def query() -> List[Dict[str, Any]]:
        seen, out = set(), []
        for d in coll.find({"map_name": "office"}, sort=[("logtimestamp", -1)]):
            if (d["config"], d["id"]) not in seen:
                seen.add((d["config"], d["id"]))
                out.append(d)
        return out

    ms = timed_query(query, VERSIONS, runs=3)
    client.close()
    return rate, ms


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-montydb", action="store_true",
                        help="skip the montydb-sqlite reference row (about 20 s)")
    parser.add_argument("--journal-sizes", type=int, nargs="*", default=[1000, 10000, 100000],
                        help="journal lengths for the outage cost table (none: skip it)")
    args = parser.parse_args()
    from mongo_server import MongoServer, find_launcher

    n = len(MAPS) * ROIS * VERSIONS
    tmp = tempfile.mkdtemp(prefix="store_bench-")
    rows = []  # (backend, query, versions, inserts/s, query ms, note)
    mongo: Tuple[Optional[float], Optional[float]] = (None, None)
    mongo_kind, mongo_versions = "na", "na"
    try:
        rate, ms = bench_store(os.path.join(tmp, "embedded"), os.path.join(tmp, "j"), VERSIONS)
        rows.append(("embedded", "SQL GROUP BY max()", n, rate, ms, ""))
        launcher, why = find_launcher()
        if launcher is not None:
            server = MongoServer(launcher, os.path.join(tmp, "mongo"),
                                 memory=launcher[0] == "mongoeco").start()
            versions = MONGOECO_VERSIONS if server.kind == "mongoeco" else VERSIONS
            try:
                mongo = bench_store(server.uri, os.path.join(tmp, "j"), versions,
                                    runs=5 if server.kind == "mongoeco" else 20)
            finally:
                server.stop()
            mongo_kind, mongo_versions = server.kind, str(len(MAPS) * ROIS * versions)
            rows.append(("mongo (%s)" % server.kind, "aggregate $group/$first",
                         int(mongo_versions), mongo[0], mongo[1],
                         "in-memory emulator, not MongoDB's speed"
                         if server.kind == "mongoeco" else ""))
        else:
            rows.append(("mongo", "-", 0, None, None, why))
        if not args.no_montydb:
            rate_m, ms_m = bench_montydb(os.path.join(tmp, "montydb"))
            rows.append(("montydb-sqlite (ref)", "find sorted + dedupe", n, rate_m, ms_m, ""))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    print("store benchmark: newest version of each of the %d ROIs of a map, %d maps x %d ROIs "
          "x N versions, target < %.0f ms" % (ROIS, len(MAPS), ROIS, TARGET_MS))
    print("%-22s %-24s %8s %10s %9s" % ("backend", "query", "versions", "inserts/s",
                                        "query ms"))
    for name, how, count, rate, ms, note in rows:
        print("%-22s %-24s %8s %10s %9s  %s" % (
            name, how, count or "-", "na" if rate is None else "%.0f" % rate,
            "na" if ms is None else "%.2f" % ms, note))

    def fmt(x: Optional[float], digits: int) -> str:
        return "na" if x is None else "%.*f" % (digits, x)

    if args.journal_sizes:
        import journal_cost

        journal_cost.main(["--sizes"] + [str(n) for n in args.journal_sizes])
    print("BENCH store insert_per_s_embedded=%s query_ms_embedded=%s insert_per_s_mongo=%s "
          "query_ms_mongo=%s mongo_server=%s mongo_versions=%s" % (
              fmt(rows[0][3], 0), fmt(rows[0][4], 2), fmt(mongo[0], 0), fmt(mongo[1], 2),
              mongo_kind, mongo_versions))
    return 0


if __name__ == "__main__":
    sys.exit(main())
