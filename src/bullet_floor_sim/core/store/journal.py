"""The write journal: an append-only JSON-lines file of writes the database has not seen yet.

One line per write, MongoDB canonical extended JSON (``bson.json_util``), so datetimes,
ObjectIds and int/long/double survive the round trip exactly. Every append is fsync'd before
the write call returns. Replay progress (how many leading lines are applied) lives in
``<journal>.done``; after a full replay both files are removed. Entries the database refuses
(not an outage: e.g. an invalid update) go to ``<journal minus .jsonl>.rejected.jsonl``.

Several processes may share one journal (one per database): appends and replays hold an
exclusive ``flock`` on ``<journal>.lock``.
"""
from __future__ import annotations

import contextlib
import fcntl
import json
import os
from typing import Any, Dict, Iterator, List, Optional, Tuple

from bson import json_util

from .base import StoreError

__all__ = ["Journal"]

_JSON = json_util.JSONOptions(json_mode=json_util.JSONMode.CANONICAL, tz_aware=False)


class Journal:
    """A journal file and its companions (see module doc).

    Args:
        path: the ``.jsonl`` file; its directory is created on the first append.
    """

    def __init__(self, path: str):
        self.path = path
        self.done_path = path + ".done"
        self.lock_path = path + ".lock"
        base = path[:-len(".jsonl")] if path.endswith(".jsonl") else path
        self.rejected_path = base + ".rejected.jsonl"

    def pending(self) -> bool:
        """True when the journal file exists and is not empty (a cheap stat)."""
        try:
            return os.path.getsize(self.path) > 0
        except OSError:
            return False

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

    def append(self, entry: Dict[str, Any]) -> None:
        """Append one entry durably (caller holds :meth:`locked`).

        Raises:
            StoreError: the journal cannot be written (the write is then lost: say so).
        """
        line = json_util.dumps(entry, json_options=_JSON).encode("utf-8") + b"\n"
        try:
            self._makedirs()
            created = not os.path.exists(self.path)
            if created:
                _unlink(self.done_path)  # progress of a journal that no longer exists
            with open(self.path, "ab+") as f:
                if f.tell() > 0:
                    f.seek(-1, os.SEEK_END)
                    if f.read(1) != b"\n":  # a torn last line from a crash: end it first
                        f.write(b"\n")
                f.write(line)
                f.flush()
                os.fsync(f.fileno())
            if created:
                _fsync_dir(os.path.dirname(self.path))
        except OSError as e:
            raise StoreError("store: cannot write the journal %s (%s); the write is lost"
                             % (self.path, e.strerror or e)) from None

    def read(self) -> Tuple[List[Tuple[bytes, Optional[Dict[str, Any]]]], int]:
        """All lines as (raw, entry or None when unreadable) and how many are already applied.

        A last line without its newline (a crash during an append, never acknowledged) is left
        out.
        """
        try:
            with open(self.path, "rb") as f:
                data = f.read()
        except FileNotFoundError:
            return [], 0
        raw_lines = data.split(b"\n")
        raw_lines.pop()  # after the final newline: b"", or a torn line
        lines = []
        for raw in raw_lines:
            try:
                entry = json_util.loads(raw.decode("utf-8"), json_options=_JSON)
                if not isinstance(entry, dict):
                    entry = None
            except ValueError:
                entry = None
            lines.append((raw, entry))
        return lines, min(self._done(), len(lines))

    def count(self) -> int:
        """How many journalled writes are not applied yet."""
        lines, done = self.read()
        return len(lines) - done

    def mark_done(self, n: int) -> None:
        """Record durably that the first ``n`` lines are applied."""
        fd = os.open(self.done_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            os.write(fd, b"%d\n" % n)
            os.fsync(fd)
        finally:
            os.close(fd)

    def reject(self, raw: bytes, reason: str) -> None:
        """Move one entry aside, with the reason, to the rejected file."""
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

    def _done(self) -> int:
        try:
            with open(self.done_path, "rb") as f:
                return int(f.read().strip() or 0)
        except (OSError, ValueError):
            return 0

    def _makedirs(self) -> None:
        os.makedirs(os.path.dirname(self.path) or ".", exist_ok=True)


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
