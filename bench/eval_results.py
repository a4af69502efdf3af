"""The evaluation's rows in a database, so that runs on many machines fill one table
(``bench/eval_worlds.py --results URI`` and ``--show-results URI``).

Each row is one document of ``bullet_floor_sim.eval_results``: the row's fields (world, seed,
legs, the scores, rtf, setup, modes, notes) and where it came from: ``commit`` (the checkout's
git HEAD, "+" when it has changes), ``host`` and ``finished`` (Unix time). The store is the
package's (data/store): a MongoDB that is down keeps the rows in its journal until it is back.
"""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from typing import List, Optional

HERE = os.path.dirname(os.path.abspath(__file__))

DB, COLLECTION = "bullet_floor_sim", "eval_results"


def checkout_commit() -> str:
    """This checkout's git HEAD ("+" when files differ from it), or "unknown"."""
    repo = os.path.join(HERE, "..")
    try:
        head = subprocess.run(["git", "-C", repo, "rev-parse", "--short=12", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", repo, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+" if dirty else "")


class ResultSink:
    """Stores rows in the database at ``uri`` as they come (``add``).

    Raises:
        StoreError: the URI is malformed (a database that is down is not an error: the rows
            wait in the journal).
    """

    def __init__(self, uri: str, journal_dir: Optional[str] = None) -> None:
        from bullet_floor_sim.data.store import open_store

        self.store = open_store(uri, journal_dir=journal_dir)
        self.uri = self.store.shown_uri
        self.source = {"commit": checkout_commit(), "host": socket.gethostname()}
        self.count = 0
        self._waiting_before = self.store.pending   # (the journal of earlier runs, if any)

    def add(self, row: dict) -> None:
        doc = dict(row, finished=time.time(), **self.source)
        self.store.insert(DB, COLLECTION, doc)
        self.count += 1

    def close(self) -> List[str]:
        """Close the store; the notes for the run's output (where the rows went, and how many
        still wait in the journal for a database that is down)."""
        waiting = min(self.count, max(0, self.store.pending - self._waiting_before))
        self.store.close()
        notes = ["%d row(s) stored in %s (%s.%s)" % (self.count - waiting, self.uri, DB,
                                                      COLLECTION)]
        if waiting:
            notes.append("%d row(s) wait in the journal: %s was down; they are written the next "
                         "time the store is opened (e.g. --show-results)" % (waiting, self.uri))
        return notes


def show_results(uri: str, journal_dir: Optional[str] = None) -> int:
    """Print the table of every row stored at ``uri`` (by commit, world, seed, legs)."""
    from bullet_floor_sim.data.store import open_store, require_existing
    from bullet_floor_sim.errors import BulletFloorSimError
    from eval_worlds import print_table

    try:
        require_existing(uri, DB)
        store = open_store(uri, journal_dir=journal_dir)
        try:
            rows = list(store.find(DB, COLLECTION, {}))
        finally:
            store.close()
    except BulletFloorSimError as e:
        sys.exit("eval_worlds: --show-results: %s" % e)
    if not rows:
        sys.exit("eval_worlds: --show-results: %s holds no rows (%s.%s)" % (uri, DB, COLLECTION))
    rows.sort(key=lambda r: (r.get("commit", ""), r["world"], r["seed"], r["legs"]))
    print_table(rows)
    for commit in sorted({r.get("commit", "unknown") for r in rows}):
        hosts = sorted({r.get("host", "?") for r in rows if r.get("commit") == commit})
        print("note: commit %s: %d row(s) from %s" % (
            commit, sum(r.get("commit") == commit for r in rows), ", ".join(hosts)))
    return 0
