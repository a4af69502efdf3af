"""The document store: the same roundtrips on both backends, outages, the journal, errors.

MongoDB tests run against a throwaway wire-protocol server (mongoeco in .venv-mongo, or mongod;
see mongo_server.py); they are skipped, with a warning saying how to enable them, where none
is available. Every test uses its own database (random name) or its own temp dir.
"""
from __future__ import annotations

import datetime
import logging
import os
import sqlite3
import sys
import threading
import time
import uuid
import warnings

import bson
import pytest

from bullet_floor_sim.data.store import (DuplicateKeyError, StoreError, StoreUnavailable,
                                         default_db_dir, default_journal_path, insert_message,
                                         message_document, open_store, stored_class_for)
from bullet_floor_sim.data.store.journal import Journal

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mongo_server import ENABLE_HINT, MongoServer, find_launcher, free_port  # noqa: E402

LOGGER = "bullet_floor_sim.store"


# -- fixtures -----------------------------------------------------------------------------------

@pytest.fixture(scope="session")
def mongo_launcher():
    launcher, why = find_launcher()
    if launcher is None:
        if os.environ.get("BFS_MONGO_PYTHON"):
            pytest.fail(why)
        message = "MongoDB backend tests SKIPPED: %s; %s" % (why, ENABLE_HINT)
        warnings.warn(message)
        pytest.skip(message)
    return launcher


@pytest.fixture(scope="module")
def mongo_server(mongo_launcher, tmp_path_factory):
    server = MongoServer(mongo_launcher, str(tmp_path_factory.mktemp("mongo"))).start()
    yield server
    server.stop()


@pytest.fixture
def own_server(mongo_launcher, tmp_path):
    """A server of this test's own, which the test may kill and restart."""
    server = MongoServer(mongo_launcher, str(tmp_path / "server"))
    yield server
    server.stop()


@pytest.fixture(params=["embedded", "mongodb"])
def store(request, tmp_path):
    if request.param == "embedded":
        uri = str(tmp_path / "db")
    else:
        uri = request.getfixturevalue("mongo_server").uri
    s = open_store(uri, journal_dir=str(tmp_path / "journal"))
    yield s
    s.close()


@pytest.fixture
def db():
    return "t_" + uuid.uuid4().hex[:12]


def ids(docs):
    return sorted(str(d["_id"]) for d in docs)


# -- the same roundtrips on both backends -------------------------------------------------------

def test_insert_and_find_back_nested_documents_and_datetimes(store, db):
    when = datetime.datetime(2024, 5, 6, 7, 8, 9, 123000)
    doc = {"name": "Küche", "n": {"x": [1, 2, {"y": 3.5}], "e": {}}, "when": when,
           "big": bson.Int64(2 ** 40), "flag": True, "nothing": None, "f": 0.25}
    _id = store.insert(db, "things", doc)
    assert isinstance(_id, bson.ObjectId) and "_id" not in doc  # caller's dict left alone
    [back] = store.find(db, "things", {"_id": _id})
    assert back == dict(doc, _id=_id)
    assert back["when"] == when and back["when"].tzinfo is None
    assert store.find_one(db, "things", {"n.x.y": 3.5})["_id"] == _id
    assert store.find(db, "other") == [] and store.find_one(db, "things", {"name": "x"}) is None


def test_own_id_and_duplicate_id(store, db):
    assert store.insert(db, "c", {"_id": "roi-1", "v": 1}) == "roi-1"
    with pytest.raises(DuplicateKeyError, match=r"duplicate _id"):
        store.insert(db, "c", {"_id": "roi-1", "v": 2})
    assert store.find(db, "c") == [{"_id": "roi-1", "v": 1}]


@pytest.mark.parametrize("indexed", [False, True])
def test_find_with_filter_sort_and_limit(store, db, indexed):
    if indexed:
        store.create_index(db, "c", [("k", 1), ("tag", 1)])
        store.create_index(db, "c", "tags")
    for k in range(10):
        store.insert(db, "c", {"k": k, "tag": "even" if k % 2 == 0 else "odd",
                               "tags": ["all", "k%d" % k], "sub": {"v": -k}})
    store.insert(db, "c", {"k": "text", "tag": "even", "tags": "all"})
    store.insert(db, "c", {"tag": "even"})  # no k at all

    def ks(docs):
        return [d.get("k") for d in docs]

    assert ks(store.find(db, "c", {"k": {"$gte": 3}, "tag": "odd"}, sort=[("k", -1)])) == \
        [9, 7, 5, 3]
    assert ks(store.find(db, "c", {"tag": "even"}, sort=[("k", -1)], limit=2)) == ["text", 8]
    assert ks(store.find(db, "c", {"tag": "even"}, sort=[("k", 1)], limit=3)) == [None, 0, 2]
    assert ks(store.find(db, "c", {"k": {"$in": [1, 5, "text", 42]}}, sort="k")) == \
        [1, 5, "text"]
    assert ks(store.find(db, "c", {"k": {"$lt": 2}, "tag": {"$in": ["odd"]}}, sort="k")) == [1]
    assert ks(store.find(db, "c", {"tags": "k3"})) == [3]  # array membership
    assert len(store.find(db, "c", {"tags": "all"})) == 11
    assert ks(store.find(db, "c", {"sub.v": {"$lte": -8}}, sort=[("sub.v", 1)])) == [9, 8]
    assert ks(store.find(db, "c", {"$or": [{"k": 0}, {"k": 9}]}, sort=[("k", -1)])) == [9, 0]
    assert ks(store.find(db, "c", {"tag": "odd"}, sort=[("tag", 1), ("k", -1)], limit=2)) == \
        [9, 7]
    assert ks(store.find(db, "c", {"k": None})) == [None]
    assert len(store.find(db, "c", limit=4)) == 4


@pytest.mark.parametrize("indexed", [False, True])
def test_embedded_comparisons_are_type_bracketed_as_in_mongodb(tmp_path, indexed):
    """MongoDB compares only within a type bracket ({$gt: 3} never matches a string) and
    sorts null/missing < numbers < strings < ObjectId < bool < date; with and without the
    index pushdown. (mongoeco does not bracket comparisons, so this runs on the embedded
    backend only.)"""
    with open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "j")) as s:
        if indexed:
            s.create_index("d", "c", "k")
        oid = bson.ObjectId("5f0000000000000000000000")
        when = datetime.datetime(2020, 1, 1)
        values = [5, "text", None, "MISSING", [1, 9], True, 2.5, oid, when, {"a": 1}]
        for v in values:
            s.insert("d", "c", {} if v == "MISSING" else {"k": v})

        def ks(f, **kw):
            return [d.get("k", "MISSING") for d in s.find("d", "c", f, **kw)]

        assert ks({"k": {"$gte": 3}}) == [5, [1, 9]]
        assert ks({"k": {"$lt": 2}}) == [[1, 9]]
        assert ks({"k": {"$gt": "a"}}) == ["text"]
        assert ks({"k": {"$gt": oid}}) == [] and ks({"k": {"$gte": oid}}) == [oid]
        assert ks({"k": {"$lt": datetime.datetime(2021, 1, 1)}}) == [when]
        assert ks({"k": {"$gt": False}}) == [True]
        assert ks({"k": None}, sort="k") == [None, "MISSING"]
        assert ks({"k": 9}) == [[1, 9]] and ks({"k": {"a": 1}}) == [{"a": 1}]
        assert ks({}, sort="k") == [None, "MISSING", [1, 9], 2.5, 5, "text", {"a": 1}, oid,
                                    True, when]
        assert ks({}, sort=[("k", -1)], limit=3) == [when, True, oid]
        # latest(): the filter must be exact before SQL picks each group's maximum
        if indexed:
            s.create_index("d", "v", [("g", 1), ("v", 1), ("t", -1)])
        for g, t, v in (("a", 1, 4), ("a", 2, 5), ("a", 3, "text"), ("b", 1, 4),
                        ("b", 2, [0, 1])):
            s.insert("d", "v", {"g": g, "v": v, "t": t})
        for g in ("a", "b"):
            found = s.latest("d", "v", "g", "t", filter={"g": g, "v": {"$gte": 3}})
            assert [(d["g"], d["t"]) for d in found] == [(g, 2 if g == "a" else 1)]


def test_update_replace_and_upsert(store, db):
    a = store.insert(db, "c", {"name": "a", "n": {"x": 1}, "v": 1})
    b = store.insert(db, "c", {"name": "b", "v": 1})
    assert store.update(db, "c", {"name": "a"}, {"$set": {"n.y": 2}, "$inc": {"v": 10}}) == 1
    assert store.find_one(db, "c", {"_id": a}) == {"_id": a, "name": "a", "n": {"x": 1, "y": 2},
                                                   "v": 11}
    assert store.update(db, "c", {"_id": b}, {"name": "b2", "w": [1]}) == 1  # replacement
    assert store.find_one(db, "c", {"_id": b}) == {"_id": b, "name": "b2", "w": [1]}
    assert store.update(db, "c", {"name": "zz"}, {"$set": {"v": 0}}) == 0
    assert store.update(db, "c", {}, {"$set": {"all": True}}, multi=True) == 2
    assert store.update(db, "c", {"name": "c", "map": "office"}, {"$set": {"v": 3}},
                        upsert=True) == 1
    up = store.find_one(db, "c", {"name": "c"})
    assert {k: v for k, v in up.items() if k != "_id"} == {"name": "c", "map": "office", "v": 3}
    assert store.update(db, "c", {"_id": "fixed"}, {"name": "d"}, upsert=True) == 1
    assert store.find_one(db, "c", {"name": "d"}) == {"_id": "fixed", "name": "d"}
    assert len(store.find(db, "c")) == 4


def test_delete(store, db):
    for k in range(5):
        store.insert(db, "c", {"k": k})
    assert store.delete(db, "c", {"k": {"$gte": 3}}) == 2
    assert store.delete(db, "c", {"k": 42}) == 0
    assert sorted(d["k"] for d in store.find(db, "c")) == [0, 1, 2]
    assert store.delete(db, "c", {}) == 3 and store.find(db, "c") == []


def test_delete_and_update_on_a_collection_never_written(store, db):
    # not an outage: nothing to delete or update, nothing journalled, the store stays usable
    assert store.delete(db, "never_written", {}) == 0
    assert store.update(db, "never_written2", {"k": 1}, {"$set": {"k": 2}}) == 0
    assert store.pending == 0 and store.available
    store.insert(db, "never_written", {"k": 1})
    assert [d["k"] for d in store.find(db, "never_written")] == [1]


def soma_roi(roi_id, version, map_name="office", config="default"):
    return {"header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0}, "frame_id": "map"},
            "id": roi_id, "map_name": map_name, "map_unique_id": "", "config": config,
            "type": "Office", "logtimestamp": 1700000000 + version,
            "posearray": {"header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0},
                                     "frame_id": "map"},
                          "poses": [{"position": {"x": float(i), "y": float(version), "z": 0.0},
                                     "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
                                    for i in range(4)]},
            "geotype": "", "geoposearray": {"header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0},
                                                       "frame_id": ""}, "poses": []}}


def test_mongodb_store_message_layout(store, db):
    fields = soma_roi("3", 1)
    _id = insert_message(store, db, "soma_roi", fields, "soma_msgs/SOMAROIObject",
                         meta={"map": "office", "taken": "2024"}, inserted_by="/soma_roi",
                         now=1700000123.4567, stamp_ns=1700000000250000000)
    [doc] = store.find(db, "soma_roi", {"_meta.stored_type": "soma_msgs/SOMAROIObject",
                                        "_meta.map": "office"})
    meta = doc["_meta"]
    assert list(meta) == ["map", "taken", "inserted_at", "inserted_by", "published_at",
                          "timestamp", "stored_class", "stored_type"]
    assert meta["inserted_at"] == datetime.datetime(2023, 11, 14, 22, 15, 23, 456000)
    assert meta["published_at"] == datetime.datetime(2023, 11, 14, 22, 13, 20, 250000)
    assert meta["timestamp"] == 1700000000250000000
    assert meta["inserted_by"] == "/soma_roi"
    assert meta["stored_class"] == "soma_msgs.msg._SOMAROIObject.SOMAROIObject"
    assert doc["_id"] == _id and doc["posearray"] == fields["posearray"]
    # mongodb_store's add_soma_fields extras
    assert doc["timestamp"] == datetime.datetime(2023, 11, 14, 22, 13, 21)
    assert doc["geotype"] == "Polygon" and doc["geoloc"] == {"type": "Polygon",
                                                             "coordinates": [[]]}
    assert message_document(fields, "soma_msgs/SOMAROIObject", now=0)["_meta"][
        "stored_class"] == stored_class_for("soma_msgs/SOMAROIObject")
    assert "_meta" not in fields and fields["geotype"] == ""


@pytest.mark.parametrize("indexed", [True, False])
def test_latest_version_of_each_roi_of_a_map(store, db, indexed):
    if indexed:
        store.create_index(db, "soma_roi", [("map_name", 1), ("config", 1), ("id", 1),
                                            ("logtimestamp", -1)])
    for version in (3, 1, 2):
        for roi in ("1", "2", "3"):
            insert_message(store, db, "soma_roi", soma_roi(roi, version + int(roi) * 10),
                           "soma_msgs/SOMAROIObject")
    insert_message(store, db, "soma_roi", soma_roi("1", 99, map_name="lab"),
                   "soma_msgs/SOMAROIObject")
    insert_message(store, db, "soma_roi", soma_roi("1", 50, config="alt"),
                   "soma_msgs/SOMAROIObject")
    odd = dict(soma_roi("1", 0, config="alt"), logtimestamp=[1, 2])  # sorts as 2 (descending)
    store.insert(db, "soma_roi", odd)
    newest = store.latest(db, "soma_roi", ["config", "id"], "logtimestamp",
                          filter={"map_name": "office"})
    assert [(d["config"], d["id"], d["logtimestamp"] - 1700000000) for d in newest] == [
        ("alt", "1", 50), ("default", "1", 13), ("default", "2", 23), ("default", "3", 33)]


def test_bad_arguments(store, db):
    with pytest.raises(StoreError, match=r"bad database name 'a/b'"):
        store.insert("a/b", "c", {})
    with pytest.raises(StoreError, match=r"bad collection name 'system.x'"):
        store.find(db, "system.x")
    with pytest.raises(StoreError, match=r"mixes \$-operators and plain fields: \$set, x"):
        store.update(db, "c", {}, {"$set": {"a": 1}, "x": 2})
    with pytest.raises(StoreError, match=r"bad sort"):
        store.find(db, "c", sort=[("k", 2)])
    with pytest.raises(StoreError, match=r"cannot store insert on t_\w+\.c \(Invalid document: "
                                         r"cannot encode object: \{1, 2\}"):
        store.insert(db, "c", {"k": {1, 2}})
    store.insert(db, "c", {"k": 1})
    with pytest.raises(StoreError, match=r"\$bogus"):
        store.find(db, "c", {"k": {"$bogus": 1}})


# -- errors, paths, journal file ----------------------------------------------------------------

def test_bad_uris(tmp_path):
    with pytest.raises(StoreError, match=r"store mongodb://\[bad: invalid MongoDB URI"):
        open_store("mongodb://[bad", journal_dir=str(tmp_path))
    with pytest.raises(StoreError, match=r"invalid MongoDB URI \(Port must be an integer"):
        open_store("mongodb://localhost:99999/", journal_dir=str(tmp_path))
    with pytest.raises(StoreError, match=r"unsupported URI scheme 'http' \(use mongodb://"):
        open_store("http://localhost:62345/", journal_dir=str(tmp_path))
    (tmp_path / "file").write_text("")
    with pytest.raises(StoreError, match=r"file: not a directory"):
        open_store(str(tmp_path / "file"), journal_dir=str(tmp_path))


def test_store_imports_without_rospy():
    import subprocess

    code = ("import sys, bullet_floor_sim.data.store as s; s.open_store; "
            "bad = [m for m in ('rospy', 'rosgraph', 'genpy') if m in sys.modules]; "
            "print(bad); sys.exit(1 if bad else 0)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    out = subprocess.run([sys.executable, "-c", code], stdout=subprocess.PIPE, env=env,
                         stderr=subprocess.STDOUT, universal_newlines=True)
    assert out.returncode == 0, out.stdout


def test_default_paths_and_port(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "roshome"))
    assert default_db_dir() == str(tmp_path / "roshome" / "bullet_floor_sim" / "db")
    journal = default_journal_path("mongodb://db:1/")
    assert os.path.dirname(journal) == str(tmp_path / "roshome" / "bullet_floor_sim" / "journal")
    assert journal.endswith(".jsonl") and journal != default_journal_path("mongodb://db:2/")
    with open_store() as s:  # no URI: the embedded store under ROS_HOME
        assert s.kind == "embedded" and s.uri == default_db_dir()
        s.insert("d", "c", {"x": 1})
    assert os.path.isfile(os.path.join(default_db_dir(), "d.sqlite3"))
    with open_store("mongodb://localhost/") as s:  # nothing is contacted before the first call
        assert s.kind == "mongodb"
        topology = s._backend._client.topology_description
        assert list(topology.server_descriptions()) == [("localhost", 62345)]


def test_journal_roundtrips_bson_types_and_skips_a_torn_line(tmp_path):
    j = Journal(str(tmp_path / "j" / "x.jsonl"))
    entry = {"op": "insert", "db": "d", "coll": "c",
             "doc": {"_id": bson.ObjectId(), "t": datetime.datetime(2024, 1, 2, 3, 4, 5, 678000),
                     "i": 1, "l": bson.Int64(1), "f": 1.0, "n": {"a": [None, True, "s"]}}}
    delete = {"op": "delete", "db": "d", "coll": "c", "filter": {"i": {"$gt": 0}}}
    with j.locked():
        j.append(j.encode(entry))
        size = j.append(j.encode(delete))
    assert size == os.path.getsize(j.path) and j.count() == 2
    with open(j.path, "ab") as f:
        f.write(b'{"op": "ins')  # a crash in the middle of an append
    lines = list(j.entries())
    assert [e for _, e, _ in lines] == [entry, delete] and lines[1][2] == size
    back = lines[0][1]["doc"]
    assert type(back["l"]) is bson.Int64 and type(back["f"]) is float and back["t"].tzinfo is None
    with j.progress() as mark:
        mark(lines[0][2])
    assert j.done_offset() == lines[0][2] and j.count() == 1
    with j.locked():
        j.append(j.encode({"op": "delete", "db": "d", "coll": "c", "filter": {}}))
    lines = list(j.entries())
    assert len(lines) == 3 and lines[1][1] is None  # the torn line, now complete: unreadable
    assert j.count() == 3
    j.clear()
    assert not j.pending() and list(j.entries()) == [] and j.count() == 0


def test_journal_count_follows_appends_and_progress_of_other_processes(tmp_path):
    path = str(tmp_path / "x.jsonl")
    mine, other = Journal(path), Journal(path)
    line = mine.encode({"op": "delete", "db": "d", "coll": "c", "filter": {}})
    with mine.locked():
        for _ in range(5):
            mine.append(line)
    assert mine.count() == 5
    with other.locked():
        other.append(line)                       # another process appends ...
    second_end = [end for _, _, end in other.entries()][1]
    with other.progress() as mark:
        mark(second_end)                         # ... and applies two lines
    assert mine.count() == 4
    other.clear()                                # a full replay elsewhere, then a new outage:
    with other.locked():                         # same path, maybe the same inode
        other.append(other.encode({"op": "insert", "db": "d", "coll": "c",
                                   "doc": {"_id": bson.ObjectId()}}))
    assert mine.count() == 1


def test_journal_reads_the_line_count_progress_of_earlier_versions(tmp_path):
    j = Journal(str(tmp_path / "x.jsonl"))
    line = j.encode({"op": "delete", "db": "d", "coll": "c", "filter": {}})
    with open(j.path, "wb") as f:                 # as 0.13 wrote it: no header ...
        f.write(line * 3)
    with open(j.done_path, "w") as f:
        f.write("2\n")                           # ... and the lines applied
    assert j.done_offset() == 2 * len(line) and j.count() == 1
    with j.progress() as mark:                    # rewritten as a byte offset
        mark(3 * len(line))
    assert j.done_offset() == 3 * len(line) and j.count() == 0


def test_journal_refuses_an_append_past_its_cap(tmp_path):
    j = Journal(str(tmp_path / "x.jsonl"), max_bytes=200)
    line = j.encode({"op": "delete", "db": "d", "coll": "c", "filter": {}})
    n = 0
    with pytest.raises(StoreError, match=r"journal .*x\.jsonl is full \(\d+ of 200 bytes\)"):
        with j.locked():
            while True:
                j.append(line)
                n += 1
    size = os.path.getsize(j.path)
    assert n >= 1 and j.count() == n and size <= 200 < size + len(line) + 1


# -- outages ------------------------------------------------------------------------------------

def outage_warnings(caplog):
    return [r for r in caplog.records
            if r.name == LOGGER and r.levelno == logging.WARNING and "unreachable" in r.message]


def test_mongodb_outage_mid_writes_journal_then_replay(own_server, tmp_path, caplog):
    """A writer keeps inserting while the server is killed and restarted: every insert that
    returned an _id is in the database exactly once, in the end."""
    caplog.set_level(logging.INFO, logger=LOGGER)
    own_server.start()
    store = open_store(own_server.uri, journal_dir=str(tmp_path / "journal"), timeout=0.3,
                       retry_interval=0.2)
    written, errors = [], []
    halfway = threading.Event()

    def writer():
        try:
            for i in range(300):
                written.append(store.insert("d", "c", {"i": i, "at": datetime.datetime(2024, 1,
                                                                                      1)}))
                if i == 100:
                    halfway.set()
                time.sleep(0.002)
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)
            halfway.set()

    thread = threading.Thread(target=writer)
    thread.start()
    assert halfway.wait(30)
    own_server.kill()  # mid-write: the writer is between inserts or inside one
    time.sleep(0.8)
    with pytest.raises(StoreUnavailable, match=r"^store mongodb://127\.0\.0\.1:%d/: MongoDB "
                                                r"unreachable .*writes journalled in "
                       % own_server.port):
        store.find("d", "c")
    assert not store.available and store.pending > 0
    own_server.start()
    thread.join(60)
    assert not errors and len(written) == 300
    assert store.replay()
    assert store.available and store.pending == 0 and not os.path.exists(store.journal_path)
    docs = store.find("d", "c")
    assert sorted(d["i"] for d in docs) == list(range(300))
    assert ids(docs) == sorted(str(i) for i in written)
    assert len(outage_warnings(caplog)) == 1  # one warning per outage, not per write
    assert any("reachable again" in r.message for r in caplog.records)
    store.close()


def test_mongodb_restarted_store_replays_the_previous_journal(own_server, tmp_path):
    journal_dir = str(tmp_path / "journal")
    first = open_store(own_server.uri, journal_dir=journal_dir, timeout=0.3)  # server down
    a = first.insert("d", "c", {"name": "a", "v": 1})
    b = first.insert("d", "c", {"name": "b"})
    assert first.update("d", "c", {"name": "a"}, {"$set": {"v": 2}}) is None  # journalled
    assert first.pending == 3
    first.close()
    own_server.start()
    import pymongo

    client = pymongo.MongoClient(own_server.uri)
    client.d.c.insert_one({"_id": a, "name": "a", "v": 1})  # as if a's first try got through
    second = open_store(own_server.uri, journal_dir=journal_dir)  # replays on open
    assert second.pending == 0
    assert sorted((d["name"], d.get("v")) for d in second.find("d", "c")) == [("a", 2),
                                                                               ("b", None)]
    assert ids(second.find("d", "c")) == sorted([str(a), str(b)])
    assert not os.path.exists(Journal(second.journal_path).rejected_path)  # skipped, not refused
    client.close()
    second.close()


def test_embedded_locked_database_journals_then_replays(tmp_path, caplog):
    """Another process holding the SQLite write lock past the timeout is an outage too."""
    caplog.set_level(logging.INFO, logger=LOGGER)
    store = open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "journal"), timeout=0.1,
                       retry_interval=0.5)
    first = store.insert("d", "c", {"i": 0})
    blocker = sqlite3.connect(str(tmp_path / "db" / "d.sqlite3"), isolation_level=None)
    blocker.execute("BEGIN EXCLUSIVE")
    t0 = time.monotonic()
    journalled = [store.insert("d", "c", {"i": i}) for i in range(1, 6)]
    assert store.update("d", "c", {"i": 0}, {"$set": {"seen": True}}) is None
    assert time.monotonic() - t0 < 0.5  # only the first write waited; the rest went straight in
    with pytest.raises(StoreUnavailable, match=r"database d unavailable \(database is locked\); "
                                                r"6 writes journalled"):
        store.find("d", "c")
    blocker.execute("ROLLBACK")
    blocker.close()
    time.sleep(0.6)  # retry_interval: the next operation tries the database again
    # ... and replays the journal first, so this update finds the journalled insert:
    assert store.update("d", "c", {"i": 5}, {"$set": {"last": True}}) == 1
    assert store.pending == 0
    docs = store.find("d", "c", sort="i")
    assert [d["i"] for d in docs] == list(range(6)) and docs[0]["seen"] is True
    assert docs[5]["last"] is True
    assert ids(docs) == sorted(str(i) for i in [first] + journalled)
    assert len(outage_warnings(caplog)) == 0  # embedded says "unavailable"
    warned = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warned) == 2 and "journalling writes to" in warned[0].message
    store.close()


def test_embedded_restarted_store_replays_and_skips_inserts_already_applied(tmp_path, caplog):
    caplog.set_level(logging.INFO, logger=LOGGER)
    journal_dir = str(tmp_path / "journal")
    first = open_store(str(tmp_path / "db"), journal_dir=journal_dir, timeout=0.1)
    first.insert("d", "c", {"i": 0})
    blocker = sqlite3.connect(str(tmp_path / "db" / "d.sqlite3"), isolation_level=None)
    blocker.execute("BEGIN EXCLUSIVE")
    kept = [first.insert("d", "c", {"i": i}) for i in (1, 2)]
    assert first.delete("d", "c", {"i": 0}) is None
    first.close()
    blocker.execute("ROLLBACK")
    blocker.execute("INSERT INTO \"docs:c\" (id, doc) VALUES (?, ?)",  # i=1 got through before
                    (bson.encode({"": kept[0]}), bson.encode({"_id": kept[0], "i": 1})))
    blocker.close()
    with open_store(str(tmp_path / "db"), journal_dir=journal_dir) as second:
        assert second.pending == 0
        docs = second.find("d", "c", sort="i")
        assert [d["i"] for d in docs] == [1, 2] and ids(docs) == sorted(map(str, kept))
        assert not os.path.exists(Journal(second.journal_path).rejected_path)
    assert [r.levelname for r in caplog.records if "already applied" in r.message] == ["INFO"]
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR]


def test_an_interrupted_replay_resumes_after_the_last_applied_write(tmp_path, monkeypatch):
    store = open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "journal"), timeout=0.1,
                       retry_interval=0)
    store.insert("d", "c", {"_id": "counter", "v": 0})
    blocker = sqlite3.connect(str(tmp_path / "db" / "d.sqlite3"), isolation_level=None)
    blocker.execute("BEGIN EXCLUSIVE")
    store.update("d", "c", {"_id": "counter"}, {"$inc": {"v": 1}})  # not idempotent
    store.insert("d", "c", {"_id": "x"})
    store.insert("d", "c", {"_id": "y"})
    blocker.execute("ROLLBACK")
    blocker.close()
    backend_insert = store._backend.insert
    calls = []

    def insert_fails_once(*args):
        calls.append(args)
        if len(calls) == 1:
            raise StoreUnavailable("store: gone again")
        return backend_insert(*args)

    monkeypatch.setattr(store._backend, "insert", insert_fails_once)
    assert not store.replay()  # the $inc went through, then the database went away again
    assert store.pending == 2
    assert store.replay()
    assert [(d["_id"], d.get("v")) for d in store.find("d", "c", sort="_id")] == [
        ("counter", 1), ("x", None), ("y", None)]
    store.close()


def test_reads_fail_fast_with_the_uri_when_mongodb_is_down(tmp_path):
    uri = "mongodb://127.0.0.1:%d/" % free_port()
    with open_store(uri, journal_dir=str(tmp_path), timeout=0.2) as s:
        t0 = time.monotonic()
        with pytest.raises(StoreUnavailable, match=r"^store %s: MongoDB unreachable \(" % uri):
            s.find("d", "c")
        with pytest.raises(StoreUnavailable, match=r"0 writes journalled"):
            s.latest("d", "c", "id", "t")  # within retry_interval: no second wait
        assert time.monotonic() - t0 < 1.0
        assert "\n" not in str(pytest.raises(StoreUnavailable, s.find, "d", "c").value)
