"""Trajectory chunking and metrics on synthetic pose streams (exact values), the stored
document layout, JSON lines and the trajectories command line (export -> import roundtrip on
both store backends). No ROS master."""
from __future__ import annotations

import io
import json
import math
import os
import random
import sys
import warnings

import pytest

from bullet_floor_sim.data.rois import Roi, load_rois, roi_at
from bullet_floor_sim.data.store import open_store
from bullet_floor_sim.data.trajectory import (COLLECTION, DATABASE, STORED_TYPE, Chunk,
                                              Chunker, RegionLocator, TrajectoryError,
                                              chunk_fields, chunk_from_document,
                                              chunk_from_json, chunk_to_json, displacement,
                                              document_to_json, ensure_indexes, format_time,
                                              iter_documents, join_chunks, path_length,
                                              pose_from_xy_yaw, select_chunks, split_poses,
                                              yaw_of)
from bullet_floor_sim.ros import trajectories as cli

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mongo_server import ENABLE_HINT, MongoServer, find_launcher  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
OFFICE_ROIS = os.path.join(ROOT, "worlds", "office", "rois.yaml")
NS = 1000000000
T0 = 100 * NS  # sim time never starts at 0


def pose(t_ns, x, y, yaw=0.0):
    return pose_from_xy_yaw(t_ns, x, y, yaw)


def line_stream(n, dt_ns=NS // 10, step=0.25, t0=T0):
    """n poses along +x, `step` metres apart (exact in binary), every dt_ns."""
    return [pose(t0 + k * dt_ns, k * step, 1.0) for k in range(n)]


def counter_uuids():
    n = [0]

    def make():
        n[0] += 1
        return "traj-%d" % n[0]

    return make


def feed(chunker, poses):
    out = []
    for p in poses:
        out.extend(chunker.add(p))
    return out


# -- metrics ------------------------------------------------------------------------------------

def test_metrics_of_a_3_4_5_path_are_exact():
    poses = [pose(T0, 0.0, 0.0), pose(T0 + NS, 3.0, 0.0), pose(T0 + 2 * NS, 3.0, 4.0)]
    c = Chunk.from_poses("u", 0, poses, True)
    assert c.trajectory_length == 7.0
    assert c.trajectory_displacement == 5.0
    assert c.displacement_pose_ratio == 5.0 / 3.0
    assert (c.start_ns, c.end_ns) == (T0, T0 + 2 * NS)
    assert path_length(poses[:1]) == 0.0 and displacement([]) == 0.0
    assert Chunk.from_poses("u", 0, [], True).displacement_pose_ratio == 0.0


def test_length_is_fsum_exact_and_planar():
    # 1000 steps of 0.1 m: a naive running sum drifts, fsum of the hypots does not.
    poses = [(T0 + k, 0.1 * k, 0.0, 5.0 * (k % 2), 0.0, 0.0, 0.0, 1.0) for k in range(11)]
    steps = [math.hypot(b[1] - a[1], 0.0) for a, b in zip(poses, poses[1:])]
    assert path_length(poses) == math.fsum(steps)  # z (5 m jumps) is ignored
    assert displacement(poses) == 0.1 * 10


def test_yaw_roundtrip_and_planar_quaternion():
    for yaw in (0.0, 0.5, -2.0, math.pi - 1e-9):
        p = pose_from_xy_yaw(T0, 1.0, 2.0, yaw)
        assert p[3:6] == (0.0, 0.0, 0.0) and p[6] == math.sin(yaw / 2)
        assert yaw_of(p) == pytest.approx(yaw, abs=1e-12)


# -- chunking -----------------------------------------------------------------------------------

def test_period_chunks_share_boundaries_and_end_complete():
    stream = line_stream(951)  # 95 s at 10 Hz, 0.25 m per pose
    ch = Chunker(period=30.0, new_uuid=counter_uuids())
    closed = feed(ch, stream)
    assert [len(c.poses) for c in closed] == [301, 301, 301]
    assert [c.closed_by for c in closed] == ["period"] * 3
    assert ch.open_poses == stream[900:]
    last = ch.finish()
    chunks = closed + [last]
    assert [c.sequence_id for c in chunks] == [0, 1, 2, 3]
    assert [c.complete for c in chunks] == [False, False, False, True]
    assert {c.uuid for c in chunks} == {"traj-1"} and last.closed_by == "end"
    assert len(last.poses) == 51
    for a, b in zip(chunks, chunks[1:]):
        assert a.poses[-1] is b.poses[0]  # the boundary pose is shared
        assert b.start_ns - a.start_ns == 30 * NS
    assert [c.trajectory_length for c in chunks] == [75.0, 75.0, 75.0, 12.5]
    assert [c.trajectory_displacement for c in chunks] == [75.0, 75.0, 75.0, 12.5]
    assert [c.displacement_pose_ratio for c in chunks] == [75.0 / 301] * 3 + [12.5 / 51]
    joined = join_chunks(reversed(chunks))
    assert len(joined) == 1 and joined[0].poses == stream and joined[0].complete
    assert joined[0].chunks == 4
    assert ch.finish() is None and ch.uuid is None


def test_region_split_at_each_region_change():
    west = Roi("w", "1", "office", "m", [(0, 0), (10, 0), (10, 10), (0, 10)])
    east = Roi("e", "1", "corridor", "m", [(10, 0), (20, 0), (20, 10), (10, 10)])
    # x = 0.5, 1.5, ... 24.5 at y = 5: 10 poses in w, 10 in e, 5 outside every region
    stream = [pose(T0 + k * NS, k + 0.5, 5.0) for k in range(25)]
    ch = Chunker(period=0, split="region", region_of=RegionLocator([west, east]),
                 new_uuid=counter_uuids())
    closed = feed(ch, stream)
    last = ch.finish()
    chunks = closed + [last]
    assert [(c.region, len(c.poses), c.closed_by) for c in chunks] == [
        ("w", 11, "region"), ("e", 11, "region"), (None, 5, "end")]
    assert chunks[0].poses[-1] == stream[10] == chunks[1].poses[0]  # entering e closes w
    assert [c.trajectory_length for c in chunks] == [10.0, 10.0, 4.0]
    assert join_chunks(chunks)[0].poses == stream


def test_region_split_also_closes_long_stays_with_a_period():
    room = Roi("r", "1", "office", "m", [(0, 0), (100, 0), (100, 10), (0, 10)])
    ch = Chunker(period=30.0, split="region", region_of=RegionLocator([room]))
    closed = feed(ch, line_stream(700, step=0.125))  # x < 87.5: always in the room
    assert [(c.region, len(c.poses), c.closed_by) for c in closed] == [("r", 301, "period")] * 2


def test_oversize_chunk_is_split_never_dropped():
    stream = line_stream(1000, dt_ns=NS // 1000)  # 1 s at 1 kHz: period never reached
    ch = Chunker(period=30.0, max_poses=100, new_uuid=counter_uuids())
    closed = feed(ch, stream)
    last = ch.finish()
    assert [len(c.poses) for c in closed] == [100] * 10 and len(last.poses) == 10
    assert {c.closed_by for c in closed} == {"size"}
    assert [c.sequence_id for c in closed + [last]] == list(range(11))
    assert join_chunks(closed + [last])[0].poses == stream
    pieces = split_poses(stream, 100)
    assert [p for p in pieces] == [c.poses for c in closed + [last]]
    assert split_poses(stream[:100], 100) == [stream[:100]]
    assert sum(len(p) for p in split_poses(stream, 2)) == 2 * 999  # every step its own piece
    with pytest.raises(TrajectoryError, match=r"max_poses 1: must be an integer >= 2"):
        split_poses(stream, 1)


def test_gap_and_time_jump_end_the_trajectory():
    ch = Chunker(period=30.0, max_gap=10.0, new_uuid=counter_uuids())
    a = [pose(T0 + k * NS, k, 0.0) for k in range(5)]
    b = [pose(T0 + (15 + k) * NS, k, 1.0) for k in range(3)]  # 11 s after a's last pose
    c = [pose(T0 + k * NS, k, 2.0) for k in range(2)]  # back in time: a restarted simulation
    out = feed(ch, a)
    assert out == [] and ch.uuid == "traj-1"
    out = feed(ch, b)
    assert [(x.uuid, x.complete, x.closed_by, x.poses) for x in out] == [
        ("traj-1", True, "gap", a)]
    out = feed(ch, c)
    assert [(x.uuid, x.closed_by, x.poses) for x in out] == [("traj-2", "time_jump", b)]
    assert ch.check_gap(c[-1][0] + 10 * NS) is None  # exactly max_gap: still open
    ended = ch.check_gap(c[-1][0] + 10 * NS + 1)
    assert (ended.uuid, ended.closed_by, ended.poses) == ("traj-3", "gap", c)
    assert ch.uuid is None and ch.poses_added == 10


def test_equal_stamps_are_kept():
    ch = Chunker(period=30.0)
    stream = [pose(T0, 0.0, 0.0), pose(T0, 1.0, 0.0), pose(T0 + 1, 1.0, 0.0)]
    assert feed(ch, stream) == []
    assert ch.finish().poses == stream


@pytest.mark.parametrize("kwargs, message", [
    ({"split": "room"}, r"split 'room': use one of period, region"),
    ({"period": 0}, r"period 0: must be a finite number of seconds > 0"),
    ({"period": float("nan")}, r"period nan: must be"),
    ({"max_poses": 1}, r"max_poses 1: must be an integer >= 2"),
    ({"max_gap": -1.0}, r"max_gap -1.0: must be a finite number of seconds >= 0"),
    ({"split": "region"}, r"split region needs regions"),
])
def test_bad_chunker_settings(kwargs, message):
    with pytest.raises(TrajectoryError, match=message):
        Chunker(**kwargs)


def test_region_locator_agrees_with_roi_at_on_the_office():
    rois = load_rois(OFFICE_ROIS)
    loc = RegionLocator(rois)
    rng = random.Random(5)
    points = [(rng.uniform(-1, 31), rng.uniform(-1, 21)) for _ in range(3000)]
    points += [v for r in rois for v in r.vertices]  # boundaries count as inside
    for x, y in points:
        want = roi_at(rois, x, y)
        assert loc(x, y) == (want.id if want else None), (x, y)
    assert loc(3.0, 10.0) == "1" and loc(-5.0, -5.0) is None


# -- documents and JSON lines -------------------------------------------------------------------

def sample_chunk(n=4, uuid="0b5c7c1e-1111-4a4a-8b8b-123456789abc", seq=2, complete=True):
    poses = [pose_from_xy_yaw(T0 + k * 123456789, 1.5 + 0.25 * k, -2.0 + 0.5 * k, 0.1 * k)
             for k in range(n)]
    return Chunk.from_poses(uuid, seq, poses, complete)


def test_document_has_mongodb_store_layout_of_the_message():
    c = sample_chunk(2)
    f = chunk_fields(c, stamp_ns=7 * NS + 5, seq=3)
    assert list(f) == ["header", "uuid", "trajectory", "robot", "start_time", "end_time",
                       "trajectory_length", "complete", "sequence_id",
                       "trajectory_displacement", "displacement_pose_ratio"]
    assert f["header"] == {"seq": 3, "stamp": {"secs": 7, "nsecs": 5}, "frame_id": "map"}
    assert f["trajectory"][1] == {
        "header": {"seq": 0, "stamp": {"secs": 100, "nsecs": 123456789}, "frame_id": "map"},
        "pose": {"position": {"x": 1.75, "y": -1.5, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(0.05),
                                 "w": math.cos(0.05)}}}
    assert f["start_time"] == {"secs": 100, "nsecs": 0}
    assert f["end_time"] == {"secs": 100, "nsecs": 123456789}
    assert (f["robot"], f["complete"], f["sequence_id"]) == ([], True, 2)
    assert f["trajectory_length"] == math.hypot(0.25, 0.5)
    back = chunk_from_document(dict(f, _meta={"map": "office", "region": "5"}))
    assert back == Chunk(c.uuid, 2, c.poses, True, c.trajectory_length,
                         c.trajectory_displacement, c.displacement_pose_ratio,
                         region="5", map_name="office")
    with pytest.raises(TrajectoryError, match=r"stored trajectory 42: malformed \(KeyError"):
        chunk_from_document({"_id": 42, "uuid": "u", "trajectory": [{"header": {}}]})


def test_json_line_exact_text_and_roundtrip():
    c = Chunk.from_poses("u-1", 0, [pose(12 * NS + 300000000, 1.0, 2.0, 0.5),
                                    pose(13 * NS + 5, 4.0, 6.0, 0.0)], False)
    line = chunk_to_json(c)
    assert line == ('{"uuid": "u-1", "sequence_id": 0, "start_time": 12.300000000, '
                    '"end_time": 13.000000005, "complete": false, "trajectory_length": 5.0, '
                    '"poses": [[12.300000000, 1.0, 2.0, %r], [13.000000005, 4.0, 6.0, 0.0]]}'
                    % yaw_of(c.poses[0]))
    assert json.loads(line)["poses"][1][0] == 13.000000005
    back = chunk_from_json(line)
    assert [p[0] for p in back.poses] == [12 * NS + 300000000, 13 * NS + 5]  # exact ns
    assert chunk_to_json(back) == line
    assert (back.trajectory_length, back.trajectory_displacement,
            back.displacement_pose_ratio) == (5.0, 5.0, 2.5)


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d.pop("poses"), r"where: missing key\(s\) poses"),
    (lambda d: d.update(extra=1), r"where: unknown key\(s\) extra"),
    (lambda d: d.update(sequence_id=-1), r"sequence_id must be an integer >= 0, got -1"),
    (lambda d: d.update(complete="yes"), r"complete must be true or false"),
    (lambda d: d.update(uuid=""), r"uuid must be a non-empty string"),
    (lambda d: d.update(poses=[]), r"poses must be a non-empty list"),
    (lambda d: d["poses"].append([1.0, 2.0]), r"poses\[2\] must be \[t, x, y, yaw\]"),
    (lambda d: d["poses"][1].__setitem__(0, 1.0), r"poses\[1\] t 1.000000000 is before"),
    (lambda d: d["poses"][0].__setitem__(0, -1), r"poses\[0\] t -1: must be a number of sec"),
    (lambda d: d["poses"][0].__setitem__(1, "x"), r"poses\[0\] x, y, yaw must be finite"),
    (lambda d: d.update(end_time=99), r"end_time 99 is not the last pose's time 13.000000005"),
    (lambda d: d.update(trajectory_length=-1), r"trajectory_length must be a number of metres"),
])
def test_bad_json_lines_are_named(mutate, message):
    d = json.loads(chunk_to_json(Chunk.from_poses("u", 0, [pose(12 * NS, 0, 0),
                                                           pose(13 * NS + 5, 1, 0)], True)))
    mutate(d)
    with pytest.raises(TrajectoryError, match=message):
        chunk_from_json(json.dumps(d), "where")
    with pytest.raises(TrajectoryError, match=r"^f:3: not JSON"):
        chunk_from_json("{", "f:3")


# -- store and command line ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def mongo_uri(tmp_path_factory):
    launcher, why = find_launcher()
    if launcher is None:
        message = "MongoDB backend tests SKIPPED: %s; %s" % (why, ENABLE_HINT)
        warnings.warn(message)
        pytest.skip(message)
    server = MongoServer(launcher, str(tmp_path_factory.mktemp("mongo")), memory=True).start()
    yield server.uri
    server.stop()


@pytest.fixture(params=["embedded", "mongodb"])
def db_pair(request, tmp_path, monkeypatch):
    """Two empty databases of one backend (the journal kept in tmp_path)."""
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    if request.param == "embedded":
        return str(tmp_path / "a"), str(tmp_path / "b")
    uri = request.getfixturevalue("mongo_uri")
    return uri, uri  # one server, two databases would need a db option: clear in between


def record(store, chunks, map_name="office", person=None, robot=None):
    from bullet_floor_sim.data.store import insert_message

    ensure_indexes(store)
    meta = {"map": map_name, "taken": "online"}
    if person is not None:
        meta["person"] = person
    if robot is not None:
        meta["robot"] = robot
    for c in chunks:
        insert_message(store, DATABASE, COLLECTION, chunk_fields(c, c.end_ns), STORED_TYPE,
                       meta=dict(meta), inserted_by="/test", now=c.end_ns / 1e9)


def recorded_chunks(uuid_start=0):
    """Two trajectories of the walker (4 + 2 chunks) and one of another map."""
    make = counter_uuids()
    for _ in range(uuid_start):
        make()
    ch = Chunker(period=30.0, max_gap=10.0, new_uuid=make)
    rng = random.Random(1)
    stream = [pose_from_xy_yaw(T0 + k * NS // 10, rng.uniform(0, 30), rng.uniform(0, 20),
                               rng.uniform(-3, 3)) for k in range(1000)]
    stream += [pose_from_xy_yaw(T0 + 200 * NS + k * NS // 10, 0.5 * k, 1.0, 0.0)
               for k in range(400)]
    chunks = feed(ch, stream) + [ch.finish()]
    return stream, chunks


def assert_same_lines(got, want):
    """Export lines equal field for field; yaw went through a quaternion on import, so it
    is equal to rounding (1e-12 rad), everything else exactly (times to the nanosecond)."""
    assert len(got) == len(want)
    for g, w in zip(got, want):
        g, w = json.loads(g, parse_float=str), json.loads(w, parse_float=str)
        gp, wp = g.pop("poses"), w.pop("poses")
        assert g == w
        assert [p[:3] for p in gp] == [p[:3] for p in wp]
        for a, b in zip(gp, wp):
            assert abs(math.remainder(float(a[3]) - float(b[3]), 2 * math.pi)) < 1e-12


def run_cli(args, capsys):
    code = cli.main(args)
    out, err = capsys.readouterr()
    return code, out, err


def test_select_by_map_window_and_last_n(tmp_path):
    stream, chunks = recorded_chunks()
    assert [(c.uuid, c.sequence_id, len(c.poses)) for c in chunks] == [
        ("traj-1", 0, 301), ("traj-1", 1, 301), ("traj-1", 2, 301), ("traj-1", 3, 100),
        ("traj-2", 0, 301), ("traj-2", 1, 100)]
    other = Chunk.from_poses("lab-1", 0, [pose(T0, 0, 0), pose(T0 + NS, 1, 0)], True)
    with open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "j")) as store:
        record(store, chunks)
        record(store, [other], map_name="lab")
        got = select_chunks(store, "office")
        assert [(c.uuid, c.sequence_id) for c in got] == [(c.uuid, c.sequence_id)
                                                          for c in chunks]
        assert all(c.map_name == "office" for c in got)
        assert [j.poses for j in join_chunks(got)] == [stream[:1000], stream[1000:]]
        assert len(select_chunks(store)) == 7
        # window [130 s, 170 s]: chunks 1 (130-160) and 2 (160-190) of traj-1; end/start
        # limits are inclusive, to the nanosecond
        win = select_chunks(store, "office", since_ns=130 * NS, until_ns=160 * NS)
        assert [(c.uuid, c.sequence_id) for c in win] == [("traj-1", 0), ("traj-1", 1),
                                                          ("traj-1", 2)]
        win = select_chunks(store, "office", since_ns=130 * NS + 1, until_ns=160 * NS - 1)
        assert [(c.uuid, c.sequence_id) for c in win] == [("traj-1", 1)]
        last = select_chunks(store, None, last_n=1)
        assert [(c.uuid, c.sequence_id) for c in last] == [("traj-2", 0), ("traj-2", 1)]


@pytest.mark.parametrize("page_poses", [10, 20000])
def test_iter_documents_reads_trajectory_after_trajectory(tmp_path, monkeypatch, page_poses):
    """Every selected chunk exactly once: trajectories in order of their first pose, each in
    sequence_id order; reads of one chunk (10 poses a read) or of up to 16; a trajectory with
    a sequence_id missing in the middle; map and time limits; last_n."""
    import bullet_floor_sim.data.trajectory.documents as traj

    monkeypatch.setattr(traj, "_PAGE_POSES", page_poses)
    chunks = []
    for u in (2, 0, 1):  # stored out of order; walker-u starts at T0 + u * 0.1 s
        ch = Chunker(period=0.35, new_uuid=lambda u=u: "walker-%d" % u)
        chunks += feed(ch, [pose(T0 + u * NS // 10 + k * NS // 20, k, u) for k in range(40)])
        chunks.append(ch.finish())
    holed = [c for c in chunks if c.uuid == "walker-1" and c.sequence_id != 3]
    chunks = [c for c in chunks if c.uuid != "walker-1"] + holed
    wall = Chunk.from_poses("wall", 0, [pose(1700000000 * NS + k, k, 0) for k in range(3)],
                            True)
    with open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "j")) as store:
        record(store, chunks)
        record(store, [wall], map_name="lab")
        by_walker = [("walker-%d" % u, s) for u in range(3) for s in range(6)
                     if (u, s) != (1, 3)]
        assert len(by_walker) == 17
        keys = lambda docs: [(d["uuid"], d["sequence_id"]) for d in docs]  # noqa: E731
        assert keys(iter_documents(store)) == by_walker + [("wall", 0)]
        assert [(c.uuid, c.sequence_id) for c in select_chunks(store)] == by_walker + [
            ("wall", 0)]
        assert keys(iter_documents(store, "office")) == by_walker
        assert keys(iter_documents(store, "lab")) == [("wall", 0)]
        since, until = T0 + NS // 2, T0 + 3 * NS // 2
        inside = [(c.uuid, c.sequence_id) for c in chunks
                  if c.end_ns >= since and c.start_ns <= until]
        assert 0 < len(inside) < 17
        assert keys(iter_documents(store, "office", since, until)) == sorted(inside)
        assert keys(iter_documents(store, since_ns=T0 + 86400 * NS)) == [("wall", 0)]
        assert keys(iter_documents(store, until_ns=T0 + NS // 10)) == [  # inclusive
            ("walker-0", 0), ("walker-1", 0)]
        assert list(iter_documents(store, "nowhere")) == []
        last = select_chunks(store, "office", last_n=1)
        assert {c.uuid for c in last} == {"walker-2"} and len(last) == 6
    with open_store(str(tmp_path / "empty")) as empty:
        assert list(iter_documents(empty)) == []


def test_document_to_json_is_the_general_path_faster():
    c = sample_chunk(5)
    doc = dict(chunk_fields(c, 0), _meta={"map": "m"})
    assert document_to_json(doc) == chunk_to_json(chunk_from_document(doc))
    # an unnormalised stamp (nsecs >= 1e9, as some writers leave it) takes the general path
    doc["trajectory"][0]["header"]["stamp"] = {"secs": 99, "nsecs": NS}
    assert document_to_json(doc) == chunk_to_json(chunk_from_document(doc))
    assert '"start_time": 100.000000000' in document_to_json(doc)
    with pytest.raises(TrajectoryError, match=r"stored trajectory 7: no poses"):
        document_to_json({"_id": 7, "uuid": "u", "trajectory": [], "trajectory_length": 0})


def test_export_import_roundtrip_on_both_backends(db_pair, tmp_path, capsys):
    a, b = db_pair
    stream, chunks = recorded_chunks()
    with open_store(a) as store:
        if a == b:  # the module's MongoDB server: empty the collection
            store.delete(DATABASE, COLLECTION, {})
        record(store, chunks)
    code, out, err = run_cli(["export", "--db", a, "--map", "office"], capsys)
    assert code == 0, err
    assert "exported 6 chunks (1404 poses)" in err
    lines = out.splitlines()
    assert [json.loads(x)["sequence_id"] for x in lines] == [0, 1, 2, 3, 0, 1]
    assert lines == [chunk_to_json(c) for c in chunks]
    first = json.loads(lines[0])
    assert list(first) == ["uuid", "sequence_id", "start_time", "end_time", "complete",
                           "trajectory_length", "poses"]
    assert first["poses"][0] == [100.0, stream[0][1], stream[0][2], yaw_of(stream[0])]
    dump = tmp_path / "dump.jsonl"
    dump.write_text(out)
    if a == b:  # one MongoDB server: empty it before importing
        with open_store(a) as store:
            store.delete(DATABASE, COLLECTION, {})
    code, _, err = run_cli(["import", "--db", b, "--map", "office", str(dump)], capsys)
    assert code == 0, err
    assert "imported 6 chunks" in err and "0 already stored" in err
    code, _, err = run_cli(["import", "--db", b, "--map", "office", str(dump)], capsys)
    assert "imported 0 chunks" in err and "6 already stored, skipped" in err
    code, again, err = run_cli(["export", "--db", b], capsys)
    assert code == 0
    assert_same_lines(again.splitlines(), lines)
    with open_store(b) as store:
        docs = store.find(DATABASE, COLLECTION, {}, sort=[("start_time.secs", 1)])
        assert len(docs) == 6
        assert docs[0]["_meta"]["taken"] == "imported"
        assert docs[0]["_meta"]["stored_type"] == STORED_TYPE
        back = select_chunks(store)
        assert [j.poses[0][0] for j in join_chunks(back)] == [stream[0][0], stream[1000][0]]
        assert sum(len(j.poses) for j in join_chunks(back)) == len(stream)


def test_export_window_to_a_file_and_plot(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    db = str(tmp_path / "db")
    stream, chunks = recorded_chunks()
    with open_store(db) as store:
        record(store, chunks)
    out = tmp_path / "w.jsonl"
    code, _, err = run_cli(["export", "--db", db, "--since", "130.000000001", "--until",
                            "159.999999999", "--out", str(out)], capsys)
    assert code == 0, err
    assert [json.loads(x)["start_time"] for x in out.read_text().splitlines()] == [130.0]
    png = tmp_path / "traj.png"
    code, _, err = run_cli(["plot", "--db", db, "--out", str(png), "--map", "office"], capsys)
    assert code == 0, err
    assert "plotted 2 trajectories (6 chunks)" in err
    from PIL import Image

    with Image.open(str(png)) as im:
        assert im.format == "PNG" and im.size[0] > 500


def test_export_and_plot_one_person(tmp_path, capsys, monkeypatch):
    """The recorder of a people topic names each person in the meta: --person keeps theirs
    (the walker's trajectories, which name nobody, and the other person's are left out)."""
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    db = str(tmp_path / "db")
    _, walker = recorded_chunks()
    _, ann = recorded_chunks(uuid_start=10)
    _, bob = recorded_chunks(uuid_start=20)
    with open_store(db) as store:
        record(store, walker)
        record(store, ann, person="ann")
        record(store, bob, person="bob")
        assert {c.uuid for c in select_chunks(store, person="ann")} == {c.uuid for c in ann}
        assert {c.uuid for c in select_chunks(store, "office", person="bob")} == {
            c.uuid for c in bob[:6]}
        assert len(select_chunks(store)) == 3 * len(walker)
    code, out, err = run_cli(["export", "--db", db, "--person", "ann"], capsys)
    assert code == 0, err
    assert [json.loads(x)["uuid"] for x in out.splitlines()] == [c.uuid for c in ann]
    png = tmp_path / "ann.png"
    code, _, err = run_cli(["plot", "--db", db, "--out", str(png), "--person", "bob",
                            "--map", "office"], capsys)
    assert code == 0, err
    assert "plotted 2 trajectories (6 chunks)" in err


def _three_walkers(tmp_path):
    """A robot's (robot1) and two people's (ann, bob) trajectories, 2 each (1000 + 400
    poses in 4 + 2 chunks), in an embedded database."""
    db = str(tmp_path / "db")
    _, walker = recorded_chunks()
    _, ann = recorded_chunks(uuid_start=10)
    _, bob = recorded_chunks(uuid_start=20)
    with open_store(db) as store:
        record(store, walker, robot="robot1")
        record(store, ann, person="ann")
        record(store, bob, person="bob")
    return db, walker, ann, bob


def _uuids(chunks):
    return list(dict.fromkeys(c.uuid for c in chunks))


def test_list_names_every_trajectory_and_counts_its_poses(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    db, walker, ann, bob = _three_walkers(tmp_path)
    code, out, err = run_cli(["list", "--db", db], capsys)
    assert code == 0, err
    lines = [line.split("\t") for line in out.splitlines()]
    assert lines[0] == ["uuid", "who", "kind", "map", "start", "end", "poses", "chunks"]
    rows = {r[0]: r for r in lines[1:]}
    assert len(rows) == 6
    first = rows[walker[0].uuid]
    assert first[1:4] == ["robot1", "robot", "office"]
    assert first[4:] == [format_time(walker[0].start_ns), format_time(walker[3].end_ns),
                         "1000", "4"]        # 4 chunks of 301, 301, 301, 100: 3 shared poses
    assert rows[ann[4].uuid][1:3] == ["ann", "person"] and rows[ann[4].uuid][6:] == ["400", "2"]
    assert "6 trajectories (4200 poses, 18 chunks)" in err
    code, out, _ = run_cli(["list", "--db", db, "--people"], capsys)
    assert sorted(r.split("\t")[1] for r in out.splitlines()[1:]) == ["ann", "ann", "bob", "bob"]
    code, out, _ = run_cli(["list", "--db", db, "--robots"], capsys)
    assert [r.split("\t")[0] for r in out.splitlines()[1:]] == _uuids(walker)
    # the time window as export selects it: of the first trajectory only its last chunk
    since = format_time(walker[3].start_ns + 1)
    code, out, _ = run_cli(["list", "--db", db, "--robots", "--since", since], capsys)
    rows = [r.split("\t") for r in out.splitlines()[1:]]
    assert [r[4:] for r in rows] == [
        [format_time(walker[3].start_ns), format_time(walker[3].end_ns), "100", "1"],
        [format_time(walker[4].start_ns), format_time(walker[5].end_ns), "400", "2"]]
    # imported chunks name neither a person nor a robot: listed, but in neither kind
    dump = tmp_path / "in.jsonl"
    dump.write_text(chunk_to_json(sample_chunk()) + "\n")
    assert run_cli(["import", "--db", db, "--map", "office", str(dump)], capsys)[0] == 0
    code, out, _ = run_cli(["list", "--db", db], capsys)
    row = [r.split("\t") for r in out.splitlines()[1:] if r.startswith(sample_chunk().uuid)]
    assert [r[1:3] for r in row] == [["-", "-"]]
    code, out, _ = run_cli(["list", "--db", db, "--robots"], capsys)
    assert len(out.splitlines()) == 1 + 2


def test_export_several_people_or_only_robots(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    db, walker, ann, bob = _three_walkers(tmp_path)
    for args, want in ((["--person", "ann", "bob"], ann + bob), (["--people"], ann + bob),
                       (["--robots"], walker), (["--person", "bob"], bob)):
        code, out, err = run_cli(["export", "--db", db] + args, capsys)
        assert code == 0, err
        got = [json.loads(x)["uuid"] for x in out.splitlines()]
        assert sorted(got) == sorted(c.uuid for c in want), args
    code, _, err = run_cli(["export", "--db", db, "--people", "--robots"], capsys)
    assert code == 2 and "not allowed with argument" in err


def test_an_unknown_person_is_an_error_that_lists_who_is_stored(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    db, *_ = _three_walkers(tmp_path)
    for command in (["export"], ["list"], ["plot", "--out", str(tmp_path / "x.png")]):
        code, out, err = run_cli(command + ["--db", db, "--person", "ann", "carol"], capsys)
        assert code == 2 and out == "", command
        assert "no trajectories of carol in " in err and err.rstrip().endswith(
            "stored: ann, bob"), err
    assert not os.path.exists(str(tmp_path / "x.png"))
    code, _, err = run_cli(["export", "--db", db, "--person", "ann", "--map", "lab"], capsys)
    assert code == 2 and "(ann: stored, but not on this map or in this time window)" in err


def test_reading_commands_refuse_a_database_that_does_not_exist(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    nowhere = tmp_path / "typo_db"
    for command in (["export"], ["list"], ["plot", "--out", str(tmp_path / "x.png")]):
        for db in (["--db", str(nowhere)], []):     # a mistyped --db, and the default one
            code, out, err = run_cli(command + db, capsys)
            assert code == 2 and out == ""
            assert "no such database: %s" % (nowhere if db else tmp_path / "ros_home"
                                               / "bullet_floor_sim" / "db") in err, err
    assert not nowhere.exists() and not (tmp_path / "ros_home" / "bullet_floor_sim").exists()
    other = tmp_path / "some_directory"      # there, but no database in it
    other.mkdir()
    code, _, err = run_cli(["list", "--db", str(other)], capsys)
    assert code == 2 and "holds no message_store (message_store.sqlite3)" in err
    assert os.listdir(str(other)) == []
    dump = tmp_path / "in.jsonl"
    dump.write_text(chunk_to_json(sample_chunk()) + "\n")
    code, _, err = run_cli(["import", "--db", str(nowhere), "--map", "m", str(dump)], capsys)
    assert code == 0 and "imported 1 chunks" in err     # import creates it


def test_a_reader_that_stops_reading_ends_the_export_quietly(tmp_path, monkeypatch):
    import subprocess

    db, *_ = _three_walkers(tmp_path)
    code = ("import sys; from bullet_floor_sim.ros import trajectories; "
            "sys.exit(trajectories.main(['export', '--db', %r]))" % db)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=dict(os.environ,
                                                             ROS_HOME=str(tmp_path)))
    first = proc.stdout.readline()
    proc.stdout.close()                          # as `| head -1` does
    err = proc.stderr.read()
    assert proc.wait(30) == 141 and json.loads(first)["sequence_id"] == 0
    assert err == b"", err


def test_the_recorder_names_a_pose_topic_by_its_namespace():
    pytest.importorskip("rospy")
    from bullet_floor_sim.ros.trajectory_recorder import robot_of_topic

    assert robot_of_topic("/robot1/pose") == "robot1"
    assert robot_of_topic("/site/robot2/pose") == "site/robot2"
    assert robot_of_topic("/pose") == "/pose"


def test_import_splits_an_oversize_line_and_renumbers(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    long = Chunk.from_poses("u", 0, line_stream(25), False)
    rest = [pose(long.end_ns + k * NS, 6.0 + k, 1.0) for k in (1, 2)]
    tail = Chunk.from_poses("u", 1, [long.poses[-1]] + rest, True)
    dump = tmp_path / "in.jsonl"
    dump.write_text(chunk_to_json(long) + "\n\n" + chunk_to_json(tail) + "\n")
    db = str(tmp_path / "db")
    code, _, err = run_cli(["import", "--db", db, "--map", "m", "--max-poses", "10", str(dump)],
                           capsys)
    assert code == 0, err
    assert "imported 4 chunks" in err and "1 split" in err
    with open_store(db) as store:
        got = select_chunks(store)
    assert [(c.sequence_id, len(c.poses), c.complete) for c in got] == [
        (0, 10, False), (1, 10, False), (2, 7, False), (3, 3, True)]
    assert got[0].trajectory_length == 9 * 0.25 and got[2].trajectory_length == 6 * 0.25
    assert join_chunks(got)[0].poses == long.poses + rest


@pytest.mark.parametrize("args, message", [
    ([], r"give a command: list, export, import or plot"),
    (["import", "--db", "D"], r"import needs --map NAME"),
    (["export", "--since", "5", "--until", "4"], r"--since 5 is after --until 4"),
    (["export", "--since", "soon"], r"--since 'soon': must be a number of seconds >= 0"),
    (["plot", "--db", "D"], r"the following arguments are required: --out"),
    (["export", "--db", "ftp://x"], r"unsupported URI scheme 'ftp'"),
])
def test_cli_errors_are_one_line(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    code, out, err = run_cli(args, capsys)
    assert code == 2 and out == ""
    assert err.startswith("trajectories: error: ") and err.count("\n") == 1
    assert __import__("re").search(message, err), err


def test_cli_bad_import_line_stores_nothing(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    good = chunk_to_json(sample_chunk())
    monkeypatch.setattr("sys.stdin", io.StringIO(good + "\n" + good[:-1] + "\n"))
    db = str(tmp_path / "db")
    code, _, err = run_cli(["import", "--db", db, "--map", "m"], capsys)
    assert code == 2 and "<stdin>:2: not JSON" in err
    with open_store(db) as store:
        assert store.find(DATABASE, COLLECTION) == []


def test_cli_imports_without_rospy():
    import subprocess

    code = ("import sys; import bullet_floor_sim.ros.trajectories, "
            "bullet_floor_sim.data.trajectory; sys.exit('rospy' in sys.modules)")
    assert subprocess.call([sys.executable, "-c", code]) == 0


def test_chunks_stay_under_the_byte_cap_and_longer_ones_are_refused():
    import bson

    from bullet_floor_sim.data.store import message_document
    from bullet_floor_sim.data.trajectory import (MAX_CHUNK_BYTES, check_max_poses,
                                                  max_poses_within)

    most = max_poses_within("map")
    poses = [(1795510000 * 10 ** 9 + 50000000 * k, 1.0 + k, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0)
             for k in range(most)]
    chunk = Chunk.from_poses("u" * 36, 7, poses, True)
    doc = message_document(chunk_fields(chunk, chunk.end_ns, 3), STORED_TYPE,
                           meta={"map": "office", "taken": "online", "closed_by": "size"},
                           inserted_by="/trajectory_recorder")
    size = len(bson.encode(doc))
    assert MAX_CHUNK_BYTES * 0.85 < size < MAX_CHUNK_BYTES      # tight, and under
    check_max_poses(most, "map")
    with pytest.raises(TrajectoryError, match=r"max_poses %d: .* at most %d$" % (most + 1, most)):
        check_max_poses(most + 1, "map")
    assert max_poses_within("a_much_longer_frame_name_for_the_poses") < most
    assert cli.main(["import", "--map", "office", "--max-poses", "1000000"]) == 2


def test_the_viewer_keeps_the_newest_chunks_within_its_pose_budget():
    """The chunks that end last, newest first, while they fit (the newest always): a
    trajectory as long as its walker walks loses its oldest chunks first, never grows past
    the budget; ``last_n`` picks the trajectories first."""
    from bullet_floor_sim.ros.trajectory_viewer import newest

    def traj(uuid, start_s, n):
        poses = [pose_from_xy_yaw((start_s + 0.05 * k) * 1e9, 0.1 * k, 0.0, 0.0)
                 for k in range(n)]
        half = n // 2
        return [Chunk.from_poses(uuid, 0, poses[:half + 1], False),
                Chunk.from_poses(uuid, 1, poses[half:], True)]

    chunks = {(c.uuid, c.sequence_id): c
              for c in traj("a", 0, 100) + traj("b", 100, 40) + traj("c", 200, 60)}
    sizes = {k: len(c.poses) for k, c in chunks.items()}
    assert sizes == {("a", 0): 51, ("a", 1): 50, ("b", 0): 21, ("b", 1): 20, ("c", 0): 31,
                     ("c", 1): 30}                  # the boundary pose counts twice

    def kept(last_n, max_poses):
        return sorted(newest(chunks, last_n, max_poses))

    assert kept(0, 1000) == sorted(chunks)
    assert kept(0, 102) == [("b", 0), ("b", 1), ("c", 0), ("c", 1)]   # 30 + 31 + 20 + 21
    assert kept(0, 101) == [("b", 1), ("c", 0), ("c", 1)]             # b's first no longer
    assert kept(0, 45) == [("c", 1)]                  # the newest trajectory's newest chunk
    assert kept(0, 10) == [("c", 1)]                  # the newest chunk always
    assert kept(1, 1000) == [("c", 0), ("c", 1)]
    assert kept(2, 1000) == [("b", 0), ("b", 1), ("c", 0), ("c", 1)]
    assert kept(2, 61) == [("c", 0), ("c", 1)] and kept(2, 60) == [("c", 1)]
