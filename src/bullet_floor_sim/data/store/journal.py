"""The write journal: an append-only JSON-lines file of writes the database has not seen yet.

One line per write, MongoDB canonical extended JSON (``bson.json_util``), so datetimes,
ObjectIds and int/long/double survive the round trip exactly, after a header line with a
random id (``{"journal": ...}``: the file's identity). Every append is fsync'd before the write
call returns; one that fails is truncated away. Replay progress is the byte offset of the
first line not yet applied, in ``<journal>.done`` (fixed width, rewritten in place; journals
of 0.13 kept a line count there, which is still read); after a full replay both files are
removed. Entries set aside (refused by
the database, or unreadable) go to ``<journal minus .jsonl>.rejected.jsonl`` with the reason.

No operation reads the whole file: a replay streams the lines from the progress offset, and
the count of waiting lines is cached and brought up to date from the bytes appended or applied
since (by this or another process). The file is capped at ``max_bytes``: an append that would
pass the cap raises :class:`JournalFull`.

Several processes may share one journal (one per database): appends and replays hold an
exclusive ``flock`` on ``<journal>.lock`` (per open file: a process that holds it must not
take it again).
"""
from __future__ import annotations

import contextlib
import fcntl
import json
import logging
import os
import uuid
from typing import Any, Dict, Iterator, List, Optional, Tuple

from bson import json_util

from .base import StoreError

__all__ = ["Journal", "JournalFull", "DEFAULT_MAX_BYTES", "rejected_entries"]

LOG = logging.getLogger("bullet_floor_sim.store")

_JSON = json_util.JSONOptions(json_mode=json_util.JSONMode.CANONICAL, tz_aware=False)
#: The journal's default cap: about 60 hours of one walker's trajectory at 20 Hz (35 MB/h).
DEFAULT_MAX_BYTES = 2 * 1024 ** 3
_BLOCK = 1 << 20
_DONE_FORMAT = b"offset %020d\n"   # fixed width: progress is rewritten in place


class JournalFull(StoreError):
    """An append would take the journal past its cap (the disk budget); the message says
    "the journal <path> is full (...)" for the store to prefix."""


class Journal:
    """A journal file and its companions (see module doc).

    Args:
        path: the ``.jsonl`` file; its directory is created on the first append.
        max_bytes: the cap on the file's size.
    """

    def __init__(self, path: str, max_bytes: int = DEFAULT_MAX_BYTES):
        self.path = path
        self.done_path = path + ".done"
        self.lock_path = path + ".lock"
        base = path[:-len(".jsonl")] if path.endswith(".jsonl") else path
        self.rejected_path = base + ".rejected.jsonl"
        self.max_bytes = int(max_bytes)
        self._counted: Optional[Tuple[Any, int, int, int]] = None  # file id, done, size, count

    def pending(self) -> bool:
        """True when the journal file exists and is not empty (a cheap stat)."""
        return self.size() > 0

    def size(self) -> int:
        """The file's size in bytes (0 when there is none)."""
        try:
            return os.path.getsize(self.path)
        except OSError:
            return 0

    @contextlib.contextmanager
    def locked(self) -> Iterator[None]:
        """Hold the journal's inter-process lock."""
        self._makedirs()
        fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            yield
        finally:
            os.close(fd)  # releases the lock

    def encode(self, entry: Dict[str, Any]) -> bytes:
        """One entry as its journal line."""
        return json_util.dumps(entry, json_options=_JSON).encode("utf-8") + b"\n"

    def append(self, line: bytes) -> int:
        """Append one encoded line durably (caller holds :meth:`locked`).

        Returns:
            The file's size afterwards.

        Raises:
            JournalFull: the line would take the file past ``max_bytes``.
            OSError: the file cannot be written (disk full, read-only, ...).
        """
        self._makedirs()
        created = not os.path.exists(self.path)
        if created:   # a header naming this journal (its identity), and progress past it
            header = json.dumps({"journal": uuid.uuid4().hex}).encode("utf-8") + b"\n"
            fd = os.open(self.done_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            try:
                os.write(fd, _DONE_FORMAT % len(header))
                os.fsync(fd)
            finally:
                os.close(fd)
            line = header + line
        with open(self.path, "ab+") as f:
            size = f.tell()
            if size + len(line) + 1 > self.max_bytes:
                raise JournalFull("the journal %s is full (%d of %d bytes)"
                                  % (self.path, size, self.max_bytes))
            try:
                if size > 0:
                    f.seek(-1, os.SEEK_END)
                    if f.read(1) != b"\n":  # a torn last line from a crash: end it first
                        f.write(b"\n")
                f.write(line)
                f.flush()
                os.fsync(f.fileno())
            except OSError:   # nothing of it stays: the caller keeps the write elsewhere
                with contextlib.suppress(OSError):
                    f.truncate(size)
                raise
            size = f.tell()
        if created:
            _fsync_dir(os.path.dirname(self.path))
        return size

    def entries(self) -> Iterator[Tuple[bytes, Optional[Dict[str, Any]], int]]:
        """The lines not applied yet, streamed: (raw, entry or None when unreadable, the
        offset just past the line). A last line without its newline (a crash during an append,
        never acknowledged) is left out."""
        try:
            f = open(self.path, "rb")
        except FileNotFoundError:
            return
        with f:
            f.seek(self.done_offset())
            while True:
                raw = f.readline()
                if not raw.endswith(b"\n"):
                    return
                entry = _decode(raw[:-1])
                if entry is not None and "journal" in entry and "op" not in entry:
                    continue   # the header (read when the progress file was lost)
                yield raw[:-1], entry, f.tell()

    def count(self) -> int:
        """How many journalled lines are not applied yet; the cost is in the bytes appended or
        applied since the last count, not in the journal's length."""
        try:
            with open(self.path, "rb") as f:
                ident, size = self._identity(f)
                done = min(self.done_offset(), size)
                c = self._counted
                if c is not None and c[0] == ident and c[1] <= done <= c[2] <= size:
                    n = c[3] - _newlines(f, c[1], done) + _newlines(f, c[2], size)
                else:
                    n = _newlines(f, done, size)
        except OSError:  # no journal (or it went between two calls): nothing waits in it
            self._counted = None
            return 0
        self._counted = (ident, done, size, n)
        return n

    def done_offset(self) -> int:
        """The byte offset of the first line not applied yet."""
        try:
            with open(self.done_path, "rb") as f:
                text = f.read()
        except OSError:
            return 0
        try:
            if text.startswith(b"offset "):
                return int(text[7:].strip())
            return self._offset_of_line(int(text.strip() or 0))  # a line count (before 0.14)
        except ValueError:
            return 0

    @contextlib.contextmanager
    def progress(self) -> Iterator[Any]:
        """A function ``mark(offset)`` recording that everything before ``offset`` is applied:
        written in place at once (a crashed process's successor resumes there), fsync'd when
        the block ends."""
        fd = os.open(self.done_path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            if os.fstat(fd).st_size < len(_DONE_FORMAT % 0):
                # its full size now, before anything is applied: later marks rewrite these
                # bytes in place and need no new disk space
                os.pwrite(fd, _DONE_FORMAT % self.done_offset(), 0)
                os.fsync(fd)
            yield lambda offset: os.pwrite(fd, _DONE_FORMAT % offset, 0)
            os.fsync(fd)
        finally:
            os.close(fd)

    def reject(self, raw: bytes, reason: str) -> None:
        """Set one entry aside, with the reason, in the rejected file."""
        self._makedirs()
        line = json.dumps({"reason": reason, "entry": raw.decode("utf-8", "replace")})
        with open(self.rejected_path, "ab") as f:
            f.write(line.encode("utf-8") + b"\n")
            f.flush()
            os.fsync(f.fileno())

    def clear(self) -> None:
        """Remove the journal and its progress (everything in it is applied)."""
        _unlink(self.path)
        _unlink(self.done_path)
        self._counted = None

    @staticmethod
    def _identity(f: Any) -> Tuple[Any, int]:
        """((inode, first line), size): a journal removed and created again may get the same
        inode, but not the same first line (its header's random id)."""
        st = os.fstat(f.fileno())
        f.seek(0)
        return (st.st_ino, f.readline(4096)), st.st_size

    def _offset_of_line(self, line: int) -> int:
        try:
            with open(self.path, "rb") as f:
                for _ in range(line):
                    if not f.readline():
                        break
                return f.tell()
        except FileNotFoundError:
            return 0

    def _makedirs(self) -> None:
        os.makedirs(os.path.dirname(self.path) or ".", exist_ok=True)


def _newlines(f: Any, start: int, end: int) -> int:
    n = 0
    f.seek(start)
    left = end - start
    while left > 0:
        block = f.read(min(_BLOCK, left))
        if not block:
            break
        n += block.count(b"\n")
        left -= len(block)
    return n


def _decode(raw: bytes) -> Optional[Dict[str, Any]]:
    """A line's entry, or None for anything that is not a JSON object of BSON values (a torn
    line, a bad ``$oid``, bytes that are not UTF-8, ...)."""
    try:
        entry = json_util.loads(raw.decode("utf-8"), json_options=_JSON)
    except Exception:  # noqa: BLE001 - json_util raises many kinds; any of them: unreadable
        return None
    return entry if isinstance(entry, dict) else None


def _unlink(path: str) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def _fsync_dir(path: str) -> None:
    fd = os.open(path or ".", os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def rejected_entries(path: str) -> List[bytes]:
    """The journal lines kept in a rejected file, in order (unreadable records skipped)."""
    out = []
    try:
        with open(path, "rb") as f:
            for raw in f:
                try:
                    out.append(json.loads(raw)["entry"].encode("utf-8") + b"\n")
                except (ValueError, KeyError, TypeError, AttributeError):
                    LOG.error("store: %s: skipped a line that is not a set-aside write", path)
    except FileNotFoundError:
        pass
    return out
