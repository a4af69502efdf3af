"""data/roi_store: SOMA-layout ROI versions, SOMA query semantics, rviz edits, debouncing.

Runs against the embedded store and, where a MongoDB wire-protocol server can be started (see
mongo_server.py), against it too.
"""
import datetime
import itertools
import json
import os
import uuid

import pytest

from bullet_floor_sim.data.roi_edits import (Debouncer, add_point, delete_point, move_vertex,
                                              new_roi, next_roi_id)
from bullet_floor_sim.data.roi_store import (COLLECTION, DATABASE, STORED_TYPE, RoiQuery,
                                              RoiStore, roi_from_document, roi_to_fields)
from bullet_floor_sim.data.rois import Roi, RoiError, load_rois

from test_store import mongo_launcher, mongo_server, store  # noqa: F401 (fixtures)

OFFICE_ROIS = os.path.join(os.path.dirname(__file__), "..", "..", "worlds", "office",
                           "rois.yaml")
T0 = 1700000000  # 2023-11-14 22:13:20 UTC, a Tuesday


def square(roi_id, x, y, size=1.0, config="1", type_="office", map_name="office"):
    h = size / 2.0
    return Roi(id=roi_id, config=config, type=type_, map_name=map_name,
               vertices=[(x - h, y - h), (x + h, y - h), (x + h, y + h), (x - h, y + h)])


class Clock:
    def __init__(self, t=T0):
        self.t = float(t)

    def __call__(self):
        return self.t


@pytest.fixture
def clock():
    return Clock()


@pytest.fixture
def rstore(store, clock):
    # a fresh database per test, so the shared MongoDB server starts empty too
    return RoiStore(store, "office", inserted_by="/test", clock=clock,
                    database="t_" + uuid.uuid4().hex[:12])


# -- documents ------------------------------------------------------------------------------------

def test_fields_are_somas_with_derived_time_fields():
    roi = square("3", 2.0, 1.0)
    f = roi_to_fields(roi, T0 + 3600 * 2 + 60 * 5)  # 2023-11-15 00:18:20 UTC, Wednesday
    assert f["id"] == "3" and f["config"] == "1" and f["type"] == "office"
    assert f["map_name"] == "office" and f["geotype"] == "Polygon"
    assert (f["logday"], f["loghour"], f["logminute"], f["logtimeminutes"]) == (3, 0, 18, 18)
    assert [(p["position"]["x"], p["position"]["y"]) for p in f["posearray"]["poses"]] == \
        [(1.5, 0.5), (2.5, 0.5), (2.5, 1.5), (1.5, 1.5)]
    assert f["posearray"]["header"]["frame_id"] == "map"
    assert roi_from_document(f) == roi


def test_the_fields_fill_the_generated_message():
    msg_mod = pytest.importorskip("bullet_floor_sim.msg")
    fields = roi_to_fields(square("1", 0, 0), T0)
    slots = set(msg_mod.SOMAROIObject.__slots__)
    assert set(fields) == slots


def test_roi_from_document_rejects_other_shapes():
    with pytest.raises(RoiError, match='stored ROI "7": not a SOMAROIObject document: missing '
                                       r'field\(s\) type, map_name, posearray'):
        roi_from_document({"id": "7", "config": "1"})


def test_a_closing_vertex_is_dropped_by_the_one_conversion():
    f = roi_to_fields(square("3", 2.0, 1.0), T0)
    f["posearray"]["poses"].append(f["posearray"]["poses"][0])      # closed by its first
    assert len(f["posearray"]["poses"]) == 5
    assert roi_from_document(f) == square("3", 2.0, 1.0)


# -- versions, history, seeding -------------------------------------------------------------------

def test_save_keeps_every_version_and_current_is_the_newest(rstore, clock):
    a = square("1", 1, 1)
    v1 = rstore.save(a)
    clock.t += 0.0001  # same millisecond: versions still increase
    moved = move_vertex(a, 2, 1.9, 1.8)
    v2 = rstore.save(moved)
    assert v2 > v1
    assert rstore.current() == [moved]
    hist = rstore.history("1", "1")
    assert [r for _, r in hist] == [a, moved]
    docs = rstore.store.find(rstore.database, COLLECTION, {"id": "1"})
    assert len(docs) == 2
    meta = docs[0]["_meta"]
    assert meta["stored_type"] == STORED_TYPE == "soma_msgs/SOMAROIObject"
    assert meta["stored_class"] == "soma_msgs.msg._SOMAROIObject.SOMAROIObject"
    assert meta["inserted_by"] == "/test" and meta["map"] == "office"
    # mongodb_store's SOMA indexing extras
    assert docs[0]["geoloc"]["type"] == "Polygon"


def test_delete_hides_the_roi_and_keeps_its_history(rstore, clock):
    rstore.save(square("1", 1, 1))
    rstore.save(square("2", 3, 1))
    clock.t += 1
    rstore.delete("1", "1")
    assert [r.id for r in rstore.current()] == ["2"]
    assert [r is None for _, r in rstore.history("1", "1")] == [False, True]
    with pytest.raises(RoiError, match='ROI "1" config "1" of map "office": cannot delete'):
        rstore.delete("1", "1")
    # a deleted ROI can come back as a new version
    clock.t += 1
    rstore.save(square("1", 5, 5))
    assert [r.id for r in rstore.current()] == ["1", "2"]


def test_seed_only_when_the_store_has_nothing_for_the_map_and_config(rstore, clock):
    rois = load_rois(OFFICE_ROIS)
    assert rstore.seed(rois) is True
    assert rstore.current("1") == rois
    edited = move_vertex(rois[4], 0, 1.0, 1.0)
    clock.t += 5
    rstore.save(edited)
    assert rstore.seed(rois) is False  # the store is the truth now
    assert rstore.current("1")[4] == edited
    # deleting everything still counts as "has ROIs": no reseed
    for r in rois:
        rstore.delete("1", r.id)
    assert rstore.seed(rois) is False and rstore.current("1") == []
    # another config of the same map is seeded separately
    other = [Roi(r.id, "2", r.type, r.map_name, r.vertices) for r in rois[:2]]
    assert rstore.seed(other) is True and rstore.configs() == ["1", "2"]


def test_seed_and_save_reject_bad_rois(rstore):
    with pytest.raises(RoiError, match='ROI "1": map "lab", but this store holds map "office"'):
        rstore.save(square("1", 0, 0, map_name="lab"))
    with pytest.raises(RoiError, match="at least 3 vertices, got 2"):
        rstore.save(Roi("1", "1", "office", "office", [(0, 0), (1, 1)]))
    with pytest.raises(RoiError, match="one config at a time"):
        rstore.seed([square("1", 0, 0), square("2", 3, 0, config="2")])
    assert rstore.current() == []


def test_replace_writes_changed_and_new_rois_and_deletes_missing_ones(rstore, clock):
    rstore.save(square("1", 1, 1))
    rstore.save(square("2", 3, 1))
    rstore.save(square("3", 5, 1))
    clock.t += 1
    written, deleted = rstore.replace([square("1", 1, 1), square("2", 3, 2), square("4", 7, 1)],
                                      "1")
    assert (written, deleted) == (2, 1)
    assert [(r.id, r.vertices[0]) for r in rstore.current()] == \
        [("1", (0.5, 0.5)), ("2", (2.5, 1.5)), ("4", (6.5, 0.5))]
    assert len(rstore.history("1", "1")) == 1  # unchanged: no new version


# -- SOMA queries ---------------------------------------------------------------------------------

def _ids(result):
    return [(d["id"], d["_meta"]["version"]) for d in result["rois"]]


def test_query_most_recent_ids_and_configs(rstore, clock):
    rstore.save(square("1", 1, 1))
    rstore.save(square("2", 3, 1))
    rstore.save(square("10", 9, 1))
    rstore.save(square("1", 1, 1, config="other"))
    clock.t += 1
    rstore.save(move_vertex(square("2", 3, 1), 0, 2.4, 0.4))
    newest = rstore.query(RoiQuery(query_type=0, returnmostrecent=True, roiconfigs=["1"]))
    assert [d["id"] for d in newest["rois"]] == ["1", "2", "10"]
    assert newest["rois"][1]["posearray"]["poses"][0]["position"]["x"] == 2.4
    assert newest["configs"] == ["1"]
    everything = rstore.query(RoiQuery(query_type=0))
    assert len(everything["rois"]) == 5 and everything["configs"] == ["1", "other"]
    by_id = rstore.query(RoiQuery(query_type=0, roiids=["2", "10"], roiconfigs=["1"],
                                  returnmostrecent=False))
    assert [d["id"] for d in by_id["rois"]] == ["2", "2", "10"]
    assert json.loads(by_id["queryjson"]) == {"map_name": "office", "config": "1",
                                              "id": {"$in": ["2", "10"]}}
    two_configs = rstore.query(RoiQuery(query_type=0, returnmostrecent=True, roiids=["1"],
                                        roiconfigs=["1", "other"]))
    assert [(d["config"], d["id"]) for d in two_configs["rois"]] == [("1", "1"), ("other", "1")]
    listing = rstore.query(RoiQuery(query_type=1))
    assert listing == {"configs": ["1", "other"], "ids": ["1", "2", "10"], "rois": [],
                       "queryjson": '{"map_name": "office"}'}
    with pytest.raises(RoiError, match="query_type must be 0 .* got 5"):
        rstore.query(RoiQuery(query_type=5))


def test_query_time_filters_as_soma(rstore, clock):
    # versions of ROI "1" at 22:13 Tue, 23:50 Tue, 00:30 Wed (UTC)
    stamps = [T0, T0 + 97 * 60, T0 + 137 * 60]
    for k, t in enumerate(stamps):
        clock.t = t
        rstore.save(square("1", 1 + k, 1))
    def xs(**q):
        res = rstore.query(RoiQuery(query_type=0, **q))
        return [d["posearray"]["poses"][0]["position"]["x"] for d in res["rois"]]
    assert xs() == [0.5, 1.5, 2.5]
    assert xs(uselowertime=True, lowerhour=23, lowerminutes=0) == [1.5]
    assert xs(useuppertime=True, upperhour=1, upperminutes=0) == [2.5]
    assert xs(usedates=True, lowerdate=T0 + 60) == [1.5, 2.5]
    assert xs(usedates=True, upperdate=T0 + 60) == [0.5]
    assert xs(usedates=True, lowerdate=0, upperdate=0) == [0.5, 1.5, 2.5]  # 0 = no limit
    assert xs(useweekday=True, weekday=3) == [2.5]
    assert xs(useweekday=True, weekday=2, returnmostrecent=True) == [1.5]
    assert datetime.datetime.utcfromtimestamp(T0).isoweekday() == 2


def test_query_from_a_request_object():
    class Req:
        query_type = 0
        returnmostrecent = True
        roiids = ["3"]
        roiconfigs = []
        weekday = 0
    q = RoiQuery.from_request(Req())
    assert q.returnmostrecent and q.roiids == ["3"] and not q.usedates
    with pytest.raises(RoiError, match="unknown field"):
        RoiQuery(querytype=0)


# -- edits ----------------------------------------------------------------------------------------

def test_edits():
    roi = square("4", 0, 0, size=2.0)
    moved = move_vertex(roi, 1, 1.5, -1.0)
    assert moved.vertices[1] == (1.5, -1.0) and roi.vertices[1] == (1.0, -1.0)
    added = add_point(roi, 3)  # between the last vertex and the first
    assert added.vertices == [(-1, -1), (1, -1), (1, 1), (-1, 1), (-1, 0)]
    assert delete_point(added, 4).vertices == roi.vertices
    with pytest.raises(RoiError, match='ROI "4": cannot delete vertex 0, a polygon needs at '
                                       'least 3 vertices'):
        delete_point(Roi("4", "1", "office", "office", [(0, 0), (1, 0), (0, 1)]), 0)
    with pytest.raises(RoiError, match='ROI "4": no vertex 4 \\(it has 4\\)'):
        move_vertex(roi, 4, 0, 0)
    with pytest.raises(RoiError, match="non-finite position"):
        move_vertex(roi, 0, float("nan"), 0)
    sq = new_roi("9", "kitchen", "office", "1", 10.0, 5.0, size=2.0)
    assert sq.vertices == [(9, 4), (11, 4), (11, 6), (9, 6)] and sq.type == "kitchen"
    assert next_roi_id([roi.id, sq.id, "x"]) == "10" and next_roi_id([]) == "1"


def test_debouncer_saves_after_quiet_time_and_after_max_wait():
    d = Debouncer(quiet=1.0, max_wait=3.0)
    d.touch("a", 0.0)
    assert d.due(0.5) == []
    d.touch("b", 0.6)
    assert d.due(1.0) == ["a"]
    assert d.pending() == ["b"]
    # a drag that never pauses is saved at max_wait
    for t in itertools.islice(itertools.count(2.0, 0.2), 10):
        d.touch("c", t)
    assert sorted(d.due(3.7)) == ["b"]
    assert d.due(5.0) == ["c"]  # first touch 2.0 + max_wait 3.0
    d.touch("e", 6.0)
    assert d.drain() == ["e"] and d.pending() == []
    with pytest.raises(ValueError, match="quiet <= max_wait"):
        Debouncer(quiet=2.0, max_wait=1.0)


def test_the_newest_rois_are_answered_from_memory_while_the_database_is_down(tmp_path, clock):
    import sqlite3

    from bullet_floor_sim.data.store import StoreUnavailable, open_store

    store = open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "j"), timeout=0.05,
                       retry_interval=0.0)
    rs = RoiStore(store, "office", inserted_by="/test", clock=clock)
    rs.save(square("1", 0, 0))
    rs.save(square("2", 2, 0))
    assert [r.id for r in rs.current("1")] == ["1", "2"] and rs.from_memory == 0
    lock = sqlite3.connect(str(tmp_path / "db" / (DATABASE + ".sqlite3")), isolation_level=None)
    lock.execute("BEGIN EXCLUSIVE")                       # the database is down
    rs.save(square("2", 5, 5))                            # journalled
    rs.delete("1", "1")                                   # journalled too
    assert [(r.id, r.vertices[0]) for r in rs.current("1")] == [("2", (4.5, 4.5))]
    newest = rs.query(RoiQuery(query_type=0, returnmostrecent=True, roiconfigs=["1"]))
    assert [d["id"] for d in newest["rois"]] == ["2"] and rs.from_memory >= 2
    with pytest.raises(StoreUnavailable):
        rs.query(RoiQuery(query_type=0))                  # the history is not in memory
    lock.execute("ROLLBACK")
    lock.close()
    assert store.replay()
    assert [(r.id, r.vertices[0]) for r in RoiStore(store, "office").current("1")] == [
        ("2", (4.5, 4.5))]
    store.close()
