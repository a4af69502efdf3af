"""Trajectories out in other formats (data/trajectory/formats.py, ``trajectories export
--format``): every pose once, read back with the format's own reader and compared."""
from __future__ import annotations

import csv
import io
import json
import math
import os

import pytest

from bullet_floor_sim.data.store import open_store
from bullet_floor_sim.data.trajectory import Chunker, join_chunks, pose_from_xy_yaw
from bullet_floor_sim.data.trajectory.formats import (ROS2_BAG_VERSION, mcap_topic,
                                                      poses_once, write_csv, write_mcap,
                                                      write_ros2_bag)
from bullet_floor_sim.data.trajectory import trajnet
from bullet_floor_sim.ros import trajectories as cli

import rosbag2_readers
from test_trajectory import record

NS = 1_000_000_000


def chunked(uuid, poses, period=1.0):
    """The chunks a recorder makes of ``poses`` (boundary poses shared)."""
    c = Chunker(period=period, new_uuid=lambda: uuid)
    out = []
    for p in poses:
        out += c.add(p)
    last = c.finish()
    return out + ([last] if last is not None else [])


def walk(t0_s, n, vx, vy, x0=0.0, y0=1.0, hz=20):
    """n poses at ``hz`` from t0 on a straight line at (vx, vy) m/s, heading along it."""
    yaw = math.atan2(vy, vx)
    return [pose_from_xy_yaw(int(round((t0_s + k / hz) * NS)), x0 + vx * k / hz,
                             y0 + vy * k / hz, yaw) for k in range(n)]


def test_every_pose_once():
    poses = walk(100.0, 70, 1.0, 0.0)
    chunks = chunked("a", poses)
    assert len(chunks) == 4 and sum(len(c.poses) for c in chunks) == 73   # 3 shared
    assert [p for _, p in poses_once(chunks)] == poses


def test_csv_reads_back_exactly():
    a, b = walk(100.0, 50, 0.7, 0.3), walk(100.5, 30, -0.5, 0.1, x0=5.0)
    chunks = chunked("ann", a) + chunked("bob", b)
    buf = io.StringIO()
    assert write_csv(chunks, buf) == 80
    rows = list(csv.reader(io.StringIO(buf.getvalue())))
    assert rows[0] == ["uuid", "t", "x", "y", "yaw"]
    want = [("ann", p) for p in a] + [("bob", p) for p in b]
    assert len(rows) == 81
    for (uuid, p), (u, t, x, y, yaw) in zip(want, rows[1:]):
        s, ns = t.split(".")
        assert (u, int(s) * NS + int(ns), float(x), float(y)) == (uuid, p[0], p[1], p[2])
        assert float(yaw) == pytest.approx(math.atan2(0.3, 0.7) if uuid == "ann"
                                           else math.atan2(0.1, -0.5), abs=1e-12)


def test_ethucy_samples_at_the_rate_by_interpolation():
    # ann from t = 100.05 s on, 20 Hz, x = 0.5 (t - 100.05), y = 1; bob from t = 100.9 s.
    # 2.5 Hz samples fall on t = 100.4, 100.8, ... : frame 0 is ann's at 100.4
    a = walk(100.05, 60, 0.5, 0.0)                 # to t = 103.0
    b = walk(100.9, 20, 0.0, -1.0, x0=2.0, y0=3.0)  # to t = 101.85
    buf = io.StringIO()
    sampled = trajnet.sample(chunked("ann", a) + chunked("bob", b), rate=2.5)
    assert sampled.ids == {1: "ann", 2: "bob"} and sampled.frame0_ns == 100_400_000_000
    n = trajnet.write_ethucy(sampled, buf)
    lines = [tuple(float(v) for v in line.split("\t")) for line in buf.getvalue().splitlines()]
    assert n == len(lines) == 7 + 2        # ann: 100.4 .. 102.8; bob: 101.2, 101.6
    assert [ln[:2] for ln in lines] == [(0, 1), (1, 1), (2, 1), (2, 2), (3, 1), (3, 2), (4, 1),
                                        (5, 1), (6, 1)]
    for frame, person, x, y in lines:
        t = 100.4 + 0.4 * frame
        if person == 1:
            assert (x, y) == pytest.approx((0.5 * (t - 100.05), 1.0), abs=6e-5)
        else:
            assert (x, y) == pytest.approx((2.0, 3.0 - (t - 100.9)), abs=6e-5)


def test_mcap_is_ros1_that_mcap_ros1_support_reads(tmp_path):
    """--format mcap: ROS 1 MCAP, read back with mcap-ros1-support's own reader (its
    decoder builds the classes from the file's ros1msg schema): every pose, stamp, frame and
    header seq, on one topic per trajectory; the md5sum is genpy's PoseStamped's."""
    pytest.importorskip("rosbags")
    reader = pytest.importorskip("mcap_ros1.reader")
    from mcap.reader import make_reader

    a, b = walk(100.0, 50, 0.7, 0.3), walk(100.5, 30, -0.5, 0.1, x0=5.0)
    path = tmp_path / "t.mcap"
    with open(str(path), "wb") as f:
        assert write_mcap(chunked("ann-1", a) + chunked("bob-2", b), f) == 80
    got, seqs = {}, {}
    for m in reader.read_ros1_messages(str(path)):
        assert m.schema.name == "geometry_msgs/PoseStamped" and m.schema.encoding == "ros1msg"
        assert m.channel.message_encoding == "ros1"
        h, q, o = m.ros_msg.header, m.ros_msg.pose.position, m.ros_msg.pose.orientation
        t = h.stamp.secs * NS + h.stamp.nsecs
        assert t == m.log_time_ns and h.frame_id == "map"
        seqs.setdefault(m.topic, []).append(h.seq)
        got.setdefault(m.topic, []).append((t, q.x, q.y, q.z, o.x, o.y, o.z, o.w))
    assert got == {mcap_topic("ann-1"): a, mcap_topic("bob-2"): b}
    assert seqs[mcap_topic("bob-2")] == list(range(30))
    with open(str(path), "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary.statistics.message_count == 80
    assert {c.metadata["md5sum"] for c in summary.channels.values()} == {
        "d3812c3cbc69362b77dc0b19b345f8f5"}      # geometry_msgs/PoseStamped's


def test_mcap_ros2_reads_back_with_rosbags(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    a, b = walk(100.0, 50, 0.7, 0.3), walk(100.5, 30, -0.5, 0.1, x0=5.0)
    path = str(tmp_path / "bag")
    assert write_ros2_bag(chunked("ann-1", a) + chunked("bob-2", b), path) == 80
    store = get_typestore(Stores.ROS2_HUMBLE)
    got = {}
    with Reader(path) as reader:
        assert reader.connections[0].msgtype == "geometry_msgs/msg/PoseStamped"
        for conn, stamp, raw in reader.messages():
            m = store.deserialize_cdr(raw, conn.msgtype)
            t = m.header.stamp.sec * NS + m.header.stamp.nanosec
            assert t == stamp and m.header.frame_id == "map"
            q, o = m.pose.position, m.pose.orientation
            got.setdefault(conn.topic, []).append((t, q.x, q.y, q.z, o.x, o.y, o.z, o.w))
    assert got == {mcap_topic("ann-1"): a, mcap_topic("bob-2"): b}
    meta = rosbag2_readers.load(path)
    assert meta["version"] == ROS2_BAG_VERSION == 8
    assert rosbag2_readers.humble_problems(meta) == []
    assert rosbag2_readers.jazzy_problems(meta) == []
    with pytest.raises(Exception, match="bag"):
        write_ros2_bag(chunked("c", a), path)      # an existing bag is not overwritten


def test_cli_formats(tmp_path, capsys):
    db = str(tmp_path / "db")
    a = walk(100.0, 50, 0.7, 0.3)
    with open_store(db) as store:
        record(store, chunked("ann", a), person="ann")
    assert cli.main(["export", "--db", db, "--format", "csv"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 51 and out[1].startswith("ann,100.000000000,0.0,1.0,")
    eth = tmp_path / "ann.txt"
    assert cli.main(["export", "--db", db, "--format", "ethucy", "--rate", "5",
                     "--out", str(eth)]) == 0
    lines = eth.read_text().splitlines()
    assert len(lines) == 13 and lines[0] == "0\t1\t0.0000\t1.0000"   # t = 100.0 .. 102.4
    assert cli.main(["export", "--db", db, "--format", "trajnet"]) == 2
    assert "--format trajnet needs --out FILE" in capsys.readouterr().err
    assert cli.main(["export", "--db", db, "--format", "mcap"]) == 2
    assert "--format mcap needs --out FILE.mcap" in capsys.readouterr().err
    if pytest.importorskip("rosbags"):
        assert cli.main(["export", "--db", db, "--format", "mcap-ros2", "--person", "ann",
                         "--out", str(tmp_path / "b")]) == 0
        assert "50 poses to the ROS 2 bag" in capsys.readouterr().err
        out = tmp_path / "t.mcap"
        assert cli.main(["export", "--db", db, "--format", "mcap", "--out", str(out)]) == 0
        assert "50 poses to the ROS 1 MCAP file" in capsys.readouterr().err
        assert out.is_file() and out.read_bytes()[:8] == b"\x89MCAP0\r\n"   # exactly that file
        assert sorted(os.listdir(str(tmp_path))) == ["ann.txt", "ann.txt.meta.json", "b", "db",
                                                     "t.mcap"]
        # both read back with their readers: the database's poses, every one
        from mcap_ros1.reader import read_ros1_messages
        from rosbags.rosbag2 import Reader
        from rosbags.typesys import Stores, get_typestore

        got = [(m.log_time_ns, m.ros_msg.pose.position.x, m.ros_msg.pose.position.y)
               for m in read_ros1_messages(str(out))]
        assert got == [p[:3] for p in a]
        store = get_typestore(Stores.ROS2_HUMBLE)
        with Reader(str(tmp_path / "b")) as reader:
            got = [(t, m.pose.position.x, m.pose.position.y) for t, m in (
                (t, store.deserialize_cdr(raw, c.msgtype)) for c, t, raw in reader.messages())]
        assert got == [p[:3] for p in a]
    assert join_chunks(chunked("ann", a))[0].poses == a


def test_a_version_9_bag_is_what_humble_cannot_read(tmp_path):
    """The readers' rules catch the issue's failure: rosbags' version 9 writes
    offered_qos_profiles as a list, which Humble's rosbag2 parses as a string."""
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    path = str(tmp_path / "v9")
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        w.add_connection("/p", "geometry_msgs/msg/PoseStamped", typestore=store)
    meta = rosbag2_readers.load(path)
    assert rosbag2_readers.humble_problems(meta) == ["/p: offered_qos_profiles is not a string"]
    assert rosbag2_readers.jazzy_problems(meta) == []


def _side_by_side(n_people, seconds, rate_hz=10):
    """People walking east side by side, 0.5 m apart, from t = 100 s."""
    return [walk(100.0, int(seconds * rate_hz), 0.8, 0.0, y0=1.0 + 0.5 * k, hz=rate_hz)
            for k in range(n_people)]


def test_trajnet_is_what_trajnetplusplus_reads(tmp_path, capsys):
    """--format trajnet: TrajNet++ ndjson that trajnetplusplustools.Reader loads, its scenes
    cut as TrajNet++ cuts them. Three people walking together for 20 s (50 samples at
    2.5 Hz): a scene every 3 samples while 21 fit, (50 - 21) // 3 + 1 = 10 per person."""
    reader = pytest.importorskip("trajnetplusplustools")
    db = str(tmp_path / "db")
    walks = _side_by_side(3, 20.0)
    with open_store(db) as store:
        for k, w in enumerate(walks):
            record(store, chunked("p%d" % k, w, period=7.0), person="person_%d" % k)
    out = tmp_path / "t.ndjson"
    assert cli.main(["export", "--db", db, "--format", "trajnet", "--out", str(out)]) == 0
    assert "30 scenes" in capsys.readouterr().err
    r = reader.Reader(str(out), scene_type="paths")
    scenes = list(r.scenes())
    assert len(scenes) == 30
    side = json.loads((tmp_path / "t.ndjson.meta.json").read_text())
    assert side["frame0_time"] == "100.000000000" and side["rate"] == 2.5
    assert {i: (v["name"], v["kind"]) for i, v in side["ids"].items()} == {
        "1": ("person_0", "person"), "2": ("person_1", "person"), "3": ("person_2", "person")}
    by_id = {int(i): v["uuid"] for i, v in side["ids"].items()}
    for scene_id, paths in scenes:
        primary = paths[0]
        assert len(primary) == 21 and len(paths) == 3          # the others in view
        k0 = primary[0].frame
        assert [row.frame for row in primary] == list(range(k0, k0 + 21))
        person = int(by_id[primary[0].pedestrian][1:])
        for row in primary:             # x = 0.8 (t - 100), y = 1 + 0.5 person, to the cm
            assert (row.x, row.y) == (round(0.8 * 0.4 * row.frame, 2), 1.0 + 0.5 * person)
    assert sorted(s.pedestrian for s in r.scenes_by_id.values()) == [1] * 10 + [2] * 10 + [3] * 10


def test_a_walker_alone_makes_no_trajnet_scene_and_is_told_so(tmp_path, capsys):
    pytest.importorskip("trajnetplusplustools")
    db = str(tmp_path / "db")
    with open_store(db) as store:
        record(store, chunked("w", _side_by_side(1, 20.0)[0]), robot="robot1")
    out = tmp_path / "w.ndjson"
    assert cli.main(["export", "--db", db, "--format", "trajnet", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "0 scenes, 0 track lines (1 trajectories" in err and "no window met" in err
    assert out.read_text() == ""
    assert json.loads((tmp_path / "w.ndjson.meta.json").read_text())["ids"]["1"]["kind"] == "robot"


def test_csv_and_jsonl_read_with_pandas_agree_with_the_database(tmp_path, capsys):
    """The csv and jsonl exports, read with pandas as an analyst would: the same poses and
    chunks as the database holds (select_chunks), to the nanosecond and the bit."""
    pd = pytest.importorskip("pandas")
    from bullet_floor_sim.data.trajectory import select_chunks

    db = str(tmp_path / "db")
    walks = _side_by_side(2, 12.0)
    with open_store(db) as store:
        for k, w in enumerate(walks):
            record(store, chunked("p%d" % k, w, period=5.0), person="person_%d" % k)
        stored = select_chunks(store)
    want = [(uuid, p) for uuid, p in poses_once(stored)]
    csv_path = tmp_path / "t.csv"
    assert cli.main(["export", "--db", db, "--format", "csv", "--out", str(csv_path)]) == 0
    frame = pd.read_csv(str(csv_path), dtype={"t": str}, float_precision="round_trip")
    assert len(frame) == len(want) == 240
    for (uuid, p), row in zip(want, frame.itertuples()):
        s, ns = row.t.split(".")
        assert (row.uuid, int(s) * NS + int(ns), row.x, row.y) == (uuid, p[0], p[1], p[2])
    jsonl_path = tmp_path / "t.jsonl"
    assert cli.main(["export", "--db", db, "--out", str(jsonl_path)]) == 0
    lines = pd.read_json(str(jsonl_path), lines=True, dtype=False)
    assert len(lines) == len(stored) == 6 and list(lines["uuid"]) == [c.uuid for c in stored]
    assert list(lines["sequence_id"]) == [c.sequence_id for c in stored]
    assert [len(p) for p in lines["poses"]] == [len(c.poses) for c in stored]
    assert [p[-1][1:3] for p in lines["poses"]] == [list(c.poses[-1][1:3]) for c in stored]


def test_trajnet_scenes_need_company_and_no_gap():
    """TrajNet++'s rules one by one: two people walking together make scenes; the same two
    20 m apart make none (nobody in a 5 m cell with them: the rows are enough); a gap of 2 s
    in a walk is no sample (not a line across it), so no window spans it."""
    a, b = _side_by_side(2, 20.0)
    together = trajnet.sample(chunked("a", a) + chunked("b", b))
    assert len(trajnet.trajnet_scenes(together)) == 2 * 10
    far = [p[:2] + (p[2] + 20.0,) + p[3:] for p in b]
    apart = trajnet.sample(chunked("a", a) + chunked("b", far))
    assert len(apart.rows) == len(together.rows) == 100
    assert trajnet.trajnet_scenes(apart) == []
    holed = [p for p in a if not 106.0 < p[0] / NS < 108.0] + [p for p in b]
    s = trajnet.sample(chunked("a", holed) + chunked("b", b))
    frames_a = [r[0] for r in s.rows if r[1] == 1]
    assert len(frames_a) == 50 - 4                   # 106.4 .. 107.6 s: no sample
    assert not {16, 17, 18, 19} & set(frames_a) and {15, 20} <= set(frames_a)
    scenes_a = [(f, e) for p, f, e in trajnet.trajnet_scenes(s) if p == 1]
    assert scenes_a and all(e <= 15 or f >= 20 for f, e in scenes_a)   # none across it
    assert trajnet.sidecar(trajnet.sample([]), "trajnet", {})["frame0_time"] is None
