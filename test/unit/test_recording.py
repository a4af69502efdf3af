"""data/recording.py: the spill file a killed recorder leaves, and the store worker."""
from __future__ import annotations

import threading
import time

from bullet_floor_sim.data.recording import ChunkQueue, ChunkSpill, PoseStream
from bullet_floor_sim.data.trajectory import Chunker

NS = 1000000000


def pose(k):
    return (1000 * NS + k * 50000000, 0.1 * k, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0)


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def record(chunker, spill, poses):
    """What the recorder does per pose; returns the chunks closed."""
    closed = []
    for p in poses:
        for c in chunker.add(p):
            spill.closed(c)
            closed.append(c)
        spill.track(chunker.uuid, chunker.sequence_id, chunker.region, chunker.open_poses)
    return closed


def test_a_killed_recorder_leaves_its_unstored_and_open_chunks(tmp_path):
    path = str(tmp_path / "spill" / "x.jsonl")
    clock = Clock()
    spill = ChunkSpill(path, flush_every=2.0, clock=clock)
    chunker = Chunker(period=1.0, new_uuid=lambda: "u1")
    closed = record(chunker, spill, [pose(k) for k in range(30)])   # chunk 0 closes at pose 20
    assert [(c.sequence_id, len(c.poses)) for c in closed] == [(0, 21)]
    spill.flush_if_due()
    assert not (tmp_path / "spill").exists()       # not due yet: nothing written
    clock.t = 2.0
    spill.flush_if_due()
    record(chunker, spill, [pose(k) for k in range(30, 35)])          # after the flush: lost
    # the process dies here; the next recorder reads the file
    back = ChunkSpill(path).recover()
    assert [(c.uuid, c.sequence_id, c.complete, c.closed_by) for c in back] == [
        ("u1", 0, False, "period"), ("u1", 1, True, "recovered")]
    assert back[0].poses == [pose(k) for k in range(21)]
    assert back[1].poses == [pose(k) for k in range(20, 30)]           # the boundary pose too
    again = ChunkSpill(path)
    assert again.recover() == back                 # kept until they are stored ...
    again.remove()
    assert ChunkSpill(path).recover() == []        # ... and then gone


def test_stored_chunks_leave_the_file_and_only_the_open_chunk_stays(tmp_path):
    path = str(tmp_path / "x.jsonl")
    spill = ChunkSpill(path, flush_every=0.0)
    chunker = Chunker(period=1.0, new_uuid=lambda: "u2")
    closed = record(chunker, spill, [pose(k) for k in range(45)])     # closes 0 and 1
    spill.flush()
    spill.stored(closed[0])
    spill.flush()
    size_before = len(open(path).read())
    spill.stored(closed[1])                                            # nothing else waits
    record(chunker, spill, [pose(45)])
    spill.flush()
    assert len(open(path).read()) < size_before
    back = ChunkSpill(path).recover()
    assert [(c.sequence_id, c.closed_by) for c in back] == [(2, "recovered")]
    assert back[0].poses == [pose(k) for k in range(40, 46)]


def test_the_open_chunk_survives_the_rewrite_when_no_pose_follows(tmp_path):
    """A database stall: the closed chunk is stored late, after the open chunk's poses were
    flushed, and no pose comes after (the walker stands): the rewrite keeps those poses."""
    path = str(tmp_path / "x.jsonl")
    spill = ChunkSpill(path, flush_every=0.0)
    chunker = Chunker(period=1.0, new_uuid=lambda: "u6")
    closed = record(chunker, spill, [pose(k) for k in range(50)])     # chunks 0, 1 closed
    spill.flush()
    for c in closed:
        spill.stored(c)                                                # then the rewrite
    back = ChunkSpill(path).recover()
    assert [(c.sequence_id, c.closed_by) for c in back] == [(2, "recovered")]
    assert back[0].poses == [pose(k) for k in range(40, 50)]
    record(chunker, spill, [pose(50)])                                 # and it goes on
    spill.flush()
    assert ChunkSpill(path).recover()[0].poses == [pose(k) for k in range(40, 51)]


def test_a_torn_last_line_is_skipped(tmp_path):
    path = str(tmp_path / "x.jsonl")
    spill = ChunkSpill(path, flush_every=0.0)
    chunker = Chunker(period=100.0, new_uuid=lambda: "u3")
    record(chunker, spill, [pose(k) for k in range(5)])
    spill.flush()
    with open(path, "a") as f:
        f.write('{"poses": [[1, 2')                                     # killed mid-write
    back = ChunkSpill(path).recover()
    assert len(back) == 1 and back[0].poses == [pose(k) for k in range(5)]


def test_a_clean_shutdown_removes_the_spill(tmp_path):
    path = tmp_path / "x.jsonl"
    spill = ChunkSpill(str(path), flush_every=0.0)
    chunker = Chunker(period=100.0, new_uuid=lambda: "u4")
    record(chunker, spill, [pose(k) for k in range(5)])
    spill.flush()
    assert path.exists()
    spill.remove()
    assert not path.exists() and ChunkSpill(str(path)).recover() == []


def test_the_queue_stores_in_order_without_blocking_the_caller():
    chunker = Chunker(period=1.0, new_uuid=lambda: "u5")
    chunks = []
    for k in range(100):
        chunks.extend(chunker.add(pose(k)))
    release = threading.Event()
    done = []

    def store(chunk, context):
        release.wait(10)                 # a stalled database
        if chunk.sequence_id == 2:
            raise RuntimeError("one bad chunk")
        done.append((chunk.sequence_id, context))

    q = ChunkQueue(store, "test")
    t0 = time.monotonic()
    for i, c in enumerate(chunks):
        q.put(c, i)
    assert time.monotonic() - t0 < 0.5 and q.waiting == len(chunks) == 4
    release.set()
    assert q.close(10.0)
    assert done == [(0, 0), (1, 1), (3, 3)]      # in order; the bad one logged, the rest went on


def test_a_chunk_is_stored_under_the_same_id_every_time(tmp_path):
    import bson

    from bullet_floor_sim.data.store import DuplicateKeyError, open_store
    from bullet_floor_sim.data.trajectory import Chunk, chunk_id

    a = Chunk.from_poses("u7", 3, [pose(k) for k in range(5)], False)
    again = Chunk.from_poses("u7", 3, [pose(k) for k in range(5)], True)    # recovered
    other = Chunk.from_poses("u7", 4, [pose(k) for k in range(4, 9)], False)
    assert chunk_id(a) == chunk_id(again) != chunk_id(other)
    assert isinstance(chunk_id(a), bson.ObjectId)
    assert chunk_id(a).generation_time.timestamp() == pose(0)[0] // NS   # its start second
    with open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "j")) as store:
        store.insert("d", "c", {"_id": chunk_id(a)})
        try:
            store.insert("d", "c", {"_id": chunk_id(again)})
        except DuplicateKeyError:
            pass
        else:
            raise AssertionError("a chunk stored twice")


def stamped(t_s):
    return (int(t_s * NS), 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def test_the_gap_is_measured_on_the_poses_clock(tmp_path):
    """max_gap 2 s. A pose that arrives just before the clock message jumping to its time
    (stamp 100 s, recorder's clock still at 1 s) is on the recorder's clock once the clock is
    there: no gap at 101 s, a gap at 102.5 s. A publisher on another clock (stamps near
    5000 s while the recorder is near 100 s, or 3 s ahead of it) is measured from its newest
    stamp and the time since it arrived."""
    def stream(name):
        return PoseStream(Chunker(max_gap=2.0, new_uuid=lambda: name),
                          ChunkSpill(str(tmp_path / (name + ".jsonl"))))

    s = stream("jump")
    s.add(stamped(100.0), rx_ns=1 * NS)
    assert not s.stamps_on_clock
    assert s.pose_clock(101 * NS) == 101 * NS
    assert s.check_gap(101 * NS) is None
    assert s.pose_clock(int(101.9 * NS)) == int(101.9 * NS)
    ended = s.check_gap(int(102.5 * NS))
    assert (ended.uuid, ended.closed_by, len(ended.poses)) == ("jump", "gap", 1)

    other = stream("wall")
    other.add(stamped(5000.0), rx_ns=100 * NS)
    assert other.pose_clock(int(101.5 * NS)) == int(5001.5 * NS)
    assert other.check_gap(int(101.5 * NS)) is None
    assert other.check_gap(int(102.5 * NS)).closed_by == "gap"

    # a publisher 3 s ahead of the recorder (within the window plus the gap of it): from
    # its second pose on its stamps are on its own clock, and its silence ends the
    # trajectory after 2 s, not after 2 s more than the skew
    ahead = stream("ahead")
    ahead.add(stamped(103.0), rx_ns=100 * NS)
    ahead.add(stamped(103.05), rx_ns=int(100.05 * NS))
    assert ahead.off_clock == 2
    assert ahead.check_gap(int(101.9 * NS)) is None
    assert ahead.check_gap(int(102.1 * NS)).closed_by == "gap"
