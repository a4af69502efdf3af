"""Fault injection on the store: database-wide refusals, poison lines, a journal that cannot be
written, the journal's cost during a long outage, set-aside writes put back.

The embedded backend is the database here (a real SQLite file, locked or damaged by the test);
the MongoDB cases run against the wire-protocol test server (see test_store.py).
"""
from __future__ import annotations

import gc
import logging
import os
import sqlite3
import sys
import time
import tracemalloc

import pytest

from bullet_floor_sim.data.store import StoreError, StoreUnavailable, open_store
from bullet_floor_sim.data.store.journal import Journal

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mongo_server import ENABLE_HINT, MongoServer, find_launcher  # noqa: E402

LOGGER = "bullet_floor_sim.store"


class Locked:
    """Another process holding an SQLite database's write lock (the database is 'down')."""

    def __init__(self, path):
        self.conn = sqlite3.connect(path, isolation_level=None)
        self.conn.execute("BEGIN EXCLUSIVE")

    def release(self):
        self.conn.execute("ROLLBACK")
        self.conn.close()


def embedded(tmp_path, **kw):
    kw.setdefault("timeout", 0.05)
    kw.setdefault("retry_interval", 0.0)
    return open_store(str(tmp_path / "db"), journal_dir=kw.pop("journal_dir",
                                                               str(tmp_path / "journal")), **kw)


def errors(caplog):
    return [r.getMessage() for r in caplog.records
            if r.name == LOGGER and r.levelno >= logging.ERROR]


# -- (a) database-wide refusals keep the journal; poison lines are set aside alone --------------

def test_locked_then_damaged_database_keeps_the_journal_and_sets_aside_only_poison(
        tmp_path, caplog):
    caplog.set_level(logging.INFO, logger=LOGGER)
    store = embedded(tmp_path)
    good = [store.insert("d", "c", {"i": 0})]
    path = str(tmp_path / "db" / "d.sqlite3")
    lock = Locked(path)
    good += [store.insert("d", "c", {"i": i}) for i in range(1, 4)]
    # poison written into the journal by hand: a bad $oid, bytes that are not UTF-8, and an
    # update whose regex the query engine rejects when it is applied
    with open(store.journal_path, "ab") as f:
        f.write(b'{"op": "insert", "db": "d", "coll": "c", "doc": {"_id": {"$oid": "zz"}}}\n')
        f.write(b'\x80\x81 not a line\n')
    assert store.update("d", "c", {"name": {"$regex": "("}}, {"$set": {"x": 1}}) is None
    good += [store.insert("d", "c", {"i": i}) for i in range(4, 6)]
    lock.release()
    store.close()                          # the last connection: the file is whole on disk
    with open(path, "r+b") as f:           # now it is damaged: not a database at all
        backup = f.read()
        f.seek(0)
        f.write(b"this is not an SQLite file" * 10)
    store = embedded(tmp_path)             # replays on open: the whole database is down
    good.append(store.insert("d", "c", {"i": 6}))
    with pytest.raises(StoreUnavailable, match=r"database d is damaged .*restore or move"):
        store.find("d", "c")
    assert store.pending == 9 and not os.path.exists(Journal(store.journal_path).rejected_path)
    with open(path, "wb") as f:            # restored from the backup
        f.write(backup)
    assert store.replay()
    docs = store.find("d", "c", sort="i")
    assert [d["i"] for d in docs] == list(range(7))
    assert sorted(d["_id"] for d in docs) == sorted(good)          # each exactly once
    rejected = open(Journal(store.journal_path).rejected_path).read().splitlines()
    assert len(rejected) == 3 and store.pending == 0
    assert ("unreadable journal line" in rejected[0] and "unreadable journal line" in rejected[1]
            and "update on d.c failed" in rejected[2])
    assert len([m for m in errors(caplog) if "set a journalled write aside" in m]) == 3
    store.close()


def test_a_refused_write_is_set_aside_and_put_back_after_the_fix(tmp_path):
    store = embedded(tmp_path)
    store.insert("d", "c", {"_id": "a", "v": "text"})
    lock = Locked(str(tmp_path / "db" / "d.sqlite3"))
    store.update("d", "c", {"_id": "a"}, {"$inc": {"v": 1}})   # refused once applied
    store.insert("d", "c", {"_id": "b"})
    lock.release()
    assert store.replay()
    assert [d["_id"] for d in store.find("d", "c", sort="_id")] == ["a", "b"]
    assert store.find_one("d", "c", {"_id": "a"})["v"] == "text"
    store.update("d", "c", {"_id": "a"}, {"$set": {"v": 41}})   # the fix
    assert store.replay_rejected() == (1, 0)
    assert store.find_one("d", "c", {"_id": "a"})["v"] == 42
    assert not os.path.exists(Journal(store.journal_path).rejected_path)
    assert store.replay_rejected() == (0, 0)
    store.close()


def test_mongodb_stopped_keeps_the_journal_and_replays_exactly_once(tmp_path):
    launcher, why = find_launcher()
    if launcher is None:
        pytest.skip("%s; %s" % (why, ENABLE_HINT))
    server = MongoServer(launcher, str(tmp_path / "server")).start()
    try:
        store = open_store(server.uri, journal_dir=str(tmp_path / "journal"), timeout=0.3,
                           retry_interval=0.0)
        ids = [store.insert("d", "c", {"i": i}) for i in range(3)]
        server.kill()
        ids += [store.insert("d", "c", {"i": i}) for i in range(3, 40)]
        with open(store.journal_path, "ab") as f:
            f.write(b'{"op": "update", "db": "d", "coll": "c", "filter": {"$bad": 1}, '
                    b'"update": {"$set": {"x": 1}}, "upsert": false, "multi": false}\n')
        ids.append(store.insert("d", "c", {"i": 40}))
        assert store.pending == 39
        server.start()
        assert store.replay()
        docs = store.find("d", "c", sort="i")
        assert [d["i"] for d in docs] == list(range(41))
        assert sorted(d["_id"] for d in docs) == sorted(ids)
        assert len(open(Journal(store.journal_path).rejected_path).readlines()) == 1
        store.close()
    finally:
        server.stop()


def test_mongodb_credentials_refused_are_database_wide():
    from pymongo import errors as pe

    from bullet_floor_sim.data.store.mongo import MongoBackend

    backend = MongoBackend("mongodb://u:secret@127.0.0.1:1/")

    def refuse(code):
        raise pe.OperationFailure("Authentication failed.", code=code)

    with pytest.raises(StoreUnavailable, match=r"u:\*\*\*@.*refused the database .*18") as e:
        backend._call(refuse, 18)
    assert "secret" not in str(e.value)
    with pytest.raises(StoreError) as e:
        backend._call(refuse, 2)    # BadValue: one write's fault
    assert not isinstance(e.value, StoreUnavailable)
    backend.close()


# -- a journal that cannot be written -----------------------------------------------------------

def test_writes_the_journal_cannot_take_wait_in_memory_in_order(tmp_path, caplog):
    caplog.set_level(logging.INFO, logger=LOGGER)
    blocked = tmp_path / "disk"
    blocked.write_text("a file where the journal directory should be")   # like a full disk
    store = embedded(tmp_path, journal_dir=str(blocked / "journal"))
    store.insert("d", "c", {"i": 0})
    lock = Locked(str(tmp_path / "db" / "d.sqlite3"))
    for i in range(1, 4):
        assert store.insert("d", "c", {"i": i})                 # held in memory
    assert store.pending == 3 and store.lost == 0
    held = [m for m in errors(caplog) if "holding writes in memory" in m]
    assert len(held) == 1 and "cannot write the journal" in held[0]
    blocked.unlink()                                            # space again
    store.insert("d", "c", {"i": 4})                            # journal: held ones first
    assert store.pending == 4 and Journal(store.journal_path).count() == 4
    assert any("takes writes again" in r.getMessage() for r in caplog.records)
    lock.release()
    assert store.replay()
    assert [d["i"] for d in store.find("d", "c", sort="i")] == [0, 1, 2, 3, 4]
    store.close()


def test_past_the_cap_and_the_memory_queue_writes_are_counted_lost(tmp_path, caplog):
    caplog.set_level(logging.INFO, logger=LOGGER)
    store = embedded(tmp_path, max_journal_bytes=4000, max_held_bytes=1000)
    store.insert("d", "c", {"i": -1})
    lock = Locked(str(tmp_path / "db" / "d.sqlite3"))
    n = 60
    for i in range(n):
        store.insert("d", "c", {"i": i, "pad": "x" * 30})
    warned = [r.getMessage() for r in caplog.records if "of its cap" in r.getMessage()]
    shares = [int(w.split(", ")[1].split(" %")[0]) for w in warned]   # one past each mark
    assert len(shares) == 3 and 50 <= shares[0] < 75 <= shares[1] < 90 <= shares[2] < 100
    journal = Journal(store.journal_path).count()
    assert 0 < store.lost < n and store.pending + store.lost == n
    assert store.pending > journal        # the rest wait in memory
    assert len([m for m in errors(caplog) if "write LOST (1 so far)" in m]) == 1
    lock.release()
    assert store.replay()
    kept = [d["i"] for d in store.find("d", "c", sort="i")]
    assert kept == list(range(-1, n - store.lost))   # the first ones, in order; the rest lost
    store.close()


# -- (b) the cost of an operation does not grow with the outage ---------------------------------

def _journal_cost(tmp_path, n):
    """Seconds and peak traced bytes of one operation of an outage (a journalled write, a
    failed read, a failed retry of the database) with ``n`` writes journalled before (the
    best of five)."""
    store = open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "journal"),
                       timeout=0.01, retry_interval=3600.0)
    store.insert("d", "c", {"i": -1})
    lock = Locked(str(tmp_path / "db" / "d.sqlite3"))
    doc = {"poses": [[float(k), 0.5, 0.25] for k in range(60)]}
    for _ in range(n):
        store.insert("d", "c", doc)
    best_t, best_mem = float("inf"), float("inf")
    for _ in range(5):
        gc.collect()
        tracemalloc.start()
        t0 = time.perf_counter()
        store.insert("d", "c", doc)
        with pytest.raises(StoreUnavailable, match=r"%d writes journalled" % (n + 1)):
            store.find("d", "c")
        assert not store.replay()
        best_t = min(best_t, time.perf_counter() - t0)
        best_mem = min(best_mem, tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        n += 1
    lock.release()
    store.close()
    return best_t, best_mem


def test_outage_cost_per_operation_is_bounded(tmp_path):
    t100, m100 = _journal_cost(tmp_path / "100", 100)
    t1000, m1000 = _journal_cost(tmp_path / "1000", 1000)
    print("journal cost per operation: 100 entries %.2f ms %.0f kB, 1000 entries %.2f ms %.0f kB"
          % (t100 * 1e3, m100 / 1e3, t1000 * 1e3, m1000 / 1e3))
    assert t1000 < 3 * t100
    assert m1000 - m100 < 20e6


def test_store_tool_shows_and_puts_back_set_aside_writes(tmp_path, capsys):
    from bullet_floor_sim.ros.store_tool import main

    store = embedded(tmp_path)
    store.insert("d", "c", {"_id": "a", "v": "text"})
    lock = Locked(str(tmp_path / "db" / "d.sqlite3"))
    store.update("d", "c", {"_id": "a"}, {"$inc": {"v": 1}})
    lock.release()
    assert store.replay()
    store.update("d", "c", {"_id": "a"}, {"$set": {"v": 1}})     # the fix
    store.close()
    where = ["--db", str(tmp_path / "db"), "--journal-dir", str(tmp_path / "journal")]
    assert main(["status"] + where) == 0
    out = capsys.readouterr().out
    assert "(embedded): answers" in out and "0 writes waiting" in out
    assert "1 writes set aside" in out
    assert main(["replay-rejected"] + where) == 0
    assert "put back 1 set-aside writes; 0 set aside again; 0 still waiting" in \
        capsys.readouterr().out
    with embedded(tmp_path) as again:
        assert again.find_one("d", "c", {"_id": "a"})["v"] == 2
    assert main(["replay-rejected", "--db", "ftp://x"]) == 2
    assert "unsupported URI scheme" in capsys.readouterr().err


# -- URIs with a password -----------------------------------------------------------------------

def test_command_line_tools_never_show_a_password(tmp_path, capsys, monkeypatch):
    from mongo_server import free_port

    from bullet_floor_sim.ros import rois, store_tool, trajectories

    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    uri = "mongodb://reader:s3cret@127.0.0.1:%d/" % free_port()     # nothing listens there
    runs = [(trajectories.main, ["export", "--db", uri]),
            (trajectories.main, ["import", "--db", uri, "--map", "office", str(tmp_path / "x")]),
            (rois.main, ["export", "--db", uri, "--map", "office"]),
            (store_tool.main, ["status", "--db", uri])]
    (tmp_path / "x").write_text("")
    for main, argv in runs:
        main(argv)
        out = capsys.readouterr()
        text = out.out + out.err
        assert "s3cret" not in text and "reader:***@127.0.0.1" in text, (argv, text)
    with open_store(uri, journal_dir=str(tmp_path), timeout=0.1) as s:
        assert s.shown_uri == uri.replace("s3cret", "***") and "s3cret" not in repr(s)


def test_an_export_that_fails_leaves_the_old_file_whole(tmp_path, capsys, monkeypatch):
    from mongo_server import free_port

    from bullet_floor_sim.ros import trajectories

    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    out = tmp_path / "trajectories.jsonl"
    out.write_text('{"an": "earlier export"}\n')
    uri = "mongodb://127.0.0.1:%d/" % free_port()               # the database is down
    assert trajectories.main(["export", "--db", uri, "--out", str(out)]) == 2
    assert "unreachable" in capsys.readouterr().err
    assert out.read_text() == '{"an": "earlier export"}\n'
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []   # no leftovers
    store = embedded(tmp_path)
    store.insert("message_store", "people_trajectory", {"x": 1})    # not a chunk: refused
    store.close()
    assert trajectories.main(["export", "--db", str(tmp_path / "db"), "--out", str(out)]) == 2
    assert out.read_text() == '{"an": "earlier export"}\n'
