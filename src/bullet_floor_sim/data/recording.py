"""What keeps a recorder's chunks safe between the pose and the store.

* :class:`ChunkQueue`: closed chunks are stored by a worker thread, in order, never by the
  thread that receives poses (a slow or stalled store then delays storing, not reception).
* :class:`ChunkSpill`: the open chunk's poses, and every closed chunk until the worker has
  stored (or journalled) it, appended to a local file every ``flush_every`` seconds. A
  recorder killed outright (SIGKILL, the OOM killer) leaves them there; the next recorder on
  the same database and topic stores them (:meth:`ChunkSpill.recover`), so a kill loses at
  most the poses of the last flush window. The writes are not fsync'd: they survive the
  process, not a power cut.

Spill file: JSON lines, ``{"chunk": [uuid, seq, region]}`` opens a chunk, ``{"poses": [...]}``
adds poses to the chunk opened last, ``{"closed": [uuid, seq, closed_by, complete]}`` marks it
handed to the store, ``{"stored": [uuid, seq]}`` marks it stored. Once every closed chunk is
stored, the file is rewritten with the open chunk alone.
"""
from __future__ import annotations

import contextlib
import json
import logging
import os
import queue
import threading
import time
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from ..files import atomic_file
from .trajectory import Chunk, Pose

__all__ = ["ChunkQueue", "ChunkSpill"]

LOG = logging.getLogger("bullet_floor_sim.recording")
_Key = Tuple[str, int]


class ChunkSpill:
    """The spill file of one recorder (see module doc). Thread-safe.

    Args:
        path: the file (its directory is created).
        flush_every: seconds between writes of the buffered poses.
        clock: monotonic seconds (for tests).
    """

    def __init__(self, path: str, flush_every: float = 2.0,
                 clock: Callable[[], float] = time.monotonic):
        self.path = path
        self.flush_every = float(flush_every)
        self._clock = clock
        self._lock = threading.Lock()
        self._lines: List[str] = []      # written at the next flush
        self._open: Optional[_Key] = None
        self._open_region: Optional[str] = None
        self._open_poses: Sequence[Pose] = ()   # the open chunk's poses (the chunker's list)
        self._written = 0                # poses of the open chunk already in _lines or the file
        self._unstored: Dict[_Key, Tuple[List[Pose], Optional[str], str, bool]] = {}
        self._last_flush = clock()
        self.failed: Optional[str] = None

    # -- recording ------------------------------------------------------------------------------
    def track(self, uuid: Optional[str], seq: int, region: Optional[str],
              poses: Sequence[Pose]) -> None:
        """Note the open chunk after a pose was added (its poses so far)."""
        with self._lock:
            if uuid is None:
                self._open = None
                return
            self._open_poses = poses
            if self._open != (uuid, seq):
                self._open, self._open_region, self._written = (uuid, seq), region, 0
                self._lines.append(json.dumps({"chunk": [uuid, seq, region]}))
            if len(poses) > self._written:
                self._lines.append(json.dumps({"poses": [list(p) for p in
                                                         poses[self._written:]]}))
                self._written = len(poses)

    def flush_if_due(self) -> None:
        """:meth:`flush` when ``flush_every`` seconds have passed since the last."""
        if self._clock() - self._last_flush >= self.flush_every:
            self.flush()

    def closed(self, chunk: Chunk) -> None:
        """A chunk was handed to the store queue: keep it until :meth:`stored`."""
        key = (chunk.uuid, chunk.sequence_id)
        with self._lock:
            if self._open != key:   # never tracked as open (e.g. finished at once): its poses
                self._lines.append(json.dumps({"chunk": [chunk.uuid, chunk.sequence_id,
                                                         chunk.region]}))
                self._lines.append(json.dumps({"poses": [list(p) for p in chunk.poses]}))
            elif len(chunk.poses) > self._written:
                self._lines.append(json.dumps({"poses": [list(p) for p in
                                                         chunk.poses[self._written:]]}))
            if self._open == key:
                self._open = None
            self._lines.append(json.dumps({"closed": [chunk.uuid, chunk.sequence_id,
                                                      chunk.closed_by, chunk.complete]}))
            self._unstored[key] = (chunk.poses, chunk.region, chunk.closed_by, chunk.complete)

    def stored(self, chunk: Chunk) -> None:
        """The worker stored (or journalled) a chunk; rewrite the file when nothing else
        waits."""
        key = (chunk.uuid, chunk.sequence_id)
        with self._lock:
            self._unstored.pop(key, None)
            self._lines.append(json.dumps({"stored": list(key)}))
            if not self._unstored:
                self._rewrite_open()

    def flush(self) -> None:
        """Write what is buffered (the timer calls this every ``flush_every`` seconds)."""
        with self._lock:
            self._last_flush = self._clock()
            if not self._lines:
                return
            text = ("\n".join(self._lines) + "\n").encode("utf-8")
            try:
                _append_whole(self.path, text)
            except OSError as e:
                self._failed(e)
                return
            self._lines = []
            self.failed = None

    def remove(self) -> None:
        """Everything is stored (a clean shutdown): no spill is left."""
        with self._lock:
            self._lines, self._unstored, self._open = [], {}, None
            try:
                os.unlink(self.path)
            except FileNotFoundError:
                pass
            except OSError as e:
                self._failed(e)

    # -- recovery -------------------------------------------------------------------------------
    def recover(self) -> List[Chunk]:
        """The chunks a previous recorder left unstored, in order: those it had closed as
        they were, its open one complete and closed by "recovered". The file stays until
        :meth:`remove` (call it once they are stored: a recorder killed while recovering
        leaves them for the next). Unreadable lines are skipped (a line torn by a kill)."""
        chunks: Dict[_Key, Dict[str, Any]] = {}
        order: List[_Key] = []
        current: Optional[_Key] = None
        try:
            with open(self.path) as f:
                for line in f:
                    current = _read_line(line, chunks, order, current)
        except FileNotFoundError:
            return []
        out = []
        for key in order:
            c = chunks[key]
            if c["stored"] or not c["poses"]:
                continue
            closed_by, complete = c["closed"] or ("recovered", True)
            out.append(Chunk.from_poses(key[0], key[1], c["poses"], complete,
                                        region=c["region"], closed_by=closed_by))
        return out

    # -- internals ------------------------------------------------------------------------------
    def _rewrite_open(self) -> None:
        """The file holds what is not stored yet: here, at most the open chunk, with its poses
        so far (lock held)."""
        self._lines = []
        if self._open is not None:
            poses = list(self._open_poses)
            self._lines.append(json.dumps({"chunk": [self._open[0], self._open[1],
                                                     self._open_region]}))
            if poses:
                self._lines.append(json.dumps({"poses": [list(p) for p in poses]}))
            self._written = len(poses)
        try:
            _makedirs(self.path)
            with atomic_file(self.path, fsync=False) as f:
                f.write("\n".join(self._lines) + "\n" if self._lines else "")
            self._lines = []
        except OSError as e:
            self._failed(e)

    def _failed(self, error: OSError) -> None:
        if self.failed is None:
            LOG.error("recorder: cannot write the spill file %s (%s): a kill now would lose "
                      "the open chunk", self.path, error.strerror or error)
        self.failed = str(error)


def _read_line(line: str, chunks: Dict[_Key, Dict[str, Any]], order: List[_Key],
               current: Optional[_Key]) -> Optional[_Key]:
    try:
        rec = json.loads(line)
        if "chunk" in rec:
            uuid, seq, region = rec["chunk"]
            current = (str(uuid), int(seq))
            if current not in chunks:
                chunks[current] = {"poses": [], "region": region, "closed": None,
                                   "stored": False}
                order.append(current)
        elif "poses" in rec and current is not None:
            chunks[current]["poses"].extend(tuple(p) for p in rec["poses"])
        elif "closed" in rec:
            uuid, seq, closed_by, complete = rec["closed"]
            if (uuid, seq) in chunks:
                chunks[(uuid, seq)]["closed"] = (str(closed_by), bool(complete))
        elif "stored" in rec:
            key = (str(rec["stored"][0]), int(rec["stored"][1]))
            if key in chunks:
                chunks[key]["stored"] = True
    except (ValueError, KeyError, TypeError):
        pass
    return current


def _append_whole(path: str, data: bytes) -> None:
    """Append ``data``, or (on an error part-way, a full disk) leave the file as it was."""
    _makedirs(path)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    try:
        size = os.fstat(fd).st_size
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
        except OSError:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, size)
            raise
    finally:
        os.close(fd)


def _makedirs(path: str) -> None:
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)


class ChunkQueue:
    """Closed chunks stored in order by one worker thread.

    Args:
        store: ``store(chunk, context)`` stores one chunk; what it raises is logged (the chunk
            is then left to the spill file).
        name: for the thread and the log.
    """

    def __init__(self, store: Callable[[Chunk, Any], None], name: str = "recorder"):
        self._store = store
        self._name = name
        self._queue: "queue.Queue[Optional[Tuple[Chunk, Any]]]" = queue.Queue()
        self._abandoned = False
        self._thread = threading.Thread(target=self._run, name=name + "-store", daemon=True)
        self._thread.start()

    def put(self, chunk: Chunk, context: Any = None) -> None:
        """Queue a chunk (never blocks)."""
        self._queue.put((chunk, context))

    @property
    def waiting(self) -> int:
        """Chunks queued and not yet stored."""
        return self._queue.unfinished_tasks

    def close(self, timeout: float = 30.0) -> bool:
        """Store what is queued, then stop the worker; True when it finished in time. After a
        timeout the worker stores no further chunk (the one in hand it finishes)."""
        self._queue.put(None)
        self._thread.join(timeout)
        self._abandoned = self._thread.is_alive()
        return not self._abandoned

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            try:
                if item is None:
                    return
                if self._abandoned:
                    continue
                try:
                    self._store(*item)
                except Exception:  # noqa: BLE001 - the worker must outlive one bad chunk
                    LOG.exception("%s: storing chunk %d of %s failed", self._name,
                                  item[0].sequence_id, item[0].uuid)
            finally:
                self._queue.task_done()


_NS = 1_000_000_000


class PoseStream:
    """One trajectory source of a recorder (a pose topic, or one person of a People topic):
    its chunker, its spill file, and which clock its stamps are on. Not thread-safe: the
    recorder calls it under its lock.

    Args:
        chunker: cuts the poses into chunks.
        spill: the stream's own spill file.
        person: the person's name (stored in each chunk's meta), None for a pose topic.
    """

    def __init__(self, chunker: Any, spill: ChunkSpill, person: Optional[str] = None) -> None:
        self.chunker, self.spill, self.person = chunker, spill, person
        self.received = 0
        self.last_rx_ns: Optional[int] = None
        self.stamps_on_clock = False   # the newest pose's stamp is on the recorder's clock
        self.off_clock = 0             # poses in a row whose stamps were not, on arrival

    def add(self, pose: Pose, rx_ns: int) -> List[Chunk]:
        """Record a pose received at ``rx_ns`` (the recorder's clock); the chunks it closed."""
        self.received += 1
        self.last_rx_ns = rx_ns
        # the silence that ends a trajectory is measured on the stamps when they are on the
        # recorder's clock (within the gap of it)
        self.stamps_on_clock = abs(rx_ns - pose[0]) <= self._window_ns()
        self.off_clock = 0 if self.stamps_on_clock else self.off_clock + 1
        closed = self.chunker.add(pose)
        c = self.chunker
        self.spill.track(c.uuid, c.sequence_id, c.region, c.open_poses)
        return closed

    def pose_clock(self, now_ns: int) -> int:
        """Now on the poses' clock: the recorder's clock when the stamps are on it (at the
        newest pose's arrival; or now, when that pose is the first in a row that was not
        and the clock has come to its stamp since: it arrived just before the clock
        message that jumps to its time), else (a publisher on another clock) the newest
        stamp plus the time since it arrived."""
        if self.stamps_on_clock or self.last_rx_ns is None:
            return now_ns
        newest = self.chunker.open_poses[-1][0]
        if self.off_clock == 1 and abs(now_ns - newest) <= self._window_ns():
            return now_ns
        return newest + (now_ns - self.last_rx_ns)

    def _window_ns(self) -> float:
        """How far a stamp may be from the recorder's clock and still be on it."""
        return max(self.chunker.max_gap, 1.0) * _NS

    def check_gap(self, now_ns: int) -> Optional[Chunk]:
        """The trajectory that a silence of ``max_gap`` has ended, if any."""
        if self.last_rx_ns is None or self.last_rx_ns == 0 or self.chunker.uuid is None:
            return None
        return self.chunker.check_gap(self.pose_clock(now_ns))


__all__ += ["PoseStream"]
