"""``rosrun bullet_floor_sim store status|replay|replay-rejected --db URI``: the write journal
of a database, from the command line.

A plain command-line tool (no ROS master needed, rospy is not imported)::

    store status          --db URI [--journal-dir DIR]
    store replay          --db URI [--journal-dir DIR]
    store replay-rejected --db URI [--journal-dir DIR]

* ``status`` prints the database, whether it answers, the journal's path, size and writes
  waiting, and how many writes are set aside in the rejected file.
* ``replay`` tries the database now and replays what the journal holds.
* ``replay-rejected`` puts the writes set aside (refused by the database, or failing on their
  own: each line of ``<journal>.rejected.jsonl`` has its reason) back behind the journal and
  replays; those refused again are set aside again. Run it after the fix (a restored
  database, a corrected document, restored rights).

``--db`` is ``mongodb://host:port/`` or a directory for the embedded store (default
``$ROS_HOME/bullet_floor_sim/db``); the journal directory defaults to
``$ROS_HOME/bullet_floor_sim/journal``, as the nodes use. Output goes to stdout; any error is
one line on stderr and exit code 2; exit code 1 when writes are still waiting.
"""
from __future__ import annotations

import os
import sys
from typing import Optional, Sequence

from ..errors import BulletFloorSimError
from ..data.store import Store, open_store
from ..data.store.journal import Journal
from .cli import Parser, UsageError

__all__ = ["main"]

PROG = "store"


def _parser() -> Parser:
    p = Parser(prog=PROG, description="The write journal of a database: status and replays.")
    sub = p.add_subparsers(dest="command", parser_class=Parser)
    for name, what in (("status", "the journal and the rejected writes"),
                       ("replay", "replay the journal now"),
                       ("replay-rejected", "put the set-aside writes back and replay")):
        q = sub.add_parser(name, help=what)
        q.add_argument("--db", default="", help="mongodb://host:port/ or a directory (default "
                       "$ROS_HOME/bullet_floor_sim/db)")
        q.add_argument("--journal-dir", dest="journal_dir", default=None,
                       help="default $ROS_HOME/bullet_floor_sim/journal")
    return p


def _status(store: Store) -> str:
    journal = Journal(store.journal_path)
    rejected = 0
    if os.path.exists(journal.rejected_path):
        with open(journal.rejected_path, "rb") as f:
            rejected = sum(1 for _ in f)
    return ("database %s (%s): %s\njournal %s: %d writes waiting, %.1f MB\nrejected %s: %d "
            "writes set aside" % (store.shown_uri, store.kind,
                                  "answers" if store.available else "DOWN",
                                  store.journal_path, store.pending, journal.size() / 1048576.0,
                                  journal.rejected_path, rejected))


def main(argv: Optional[Sequence[str]] = None) -> int:
    try:
        args = _parser().parse_args(argv)
        if not args.command:
            raise UsageError("give a command: status, replay or replay-rejected")
        with open_store(args.db or None, journal_dir=args.journal_dir) as store:
            if args.command == "replay":
                store.replay()
                print("replayed: %d writes still waiting" % store.pending)
            elif args.command == "replay-rejected":
                back, again = store.replay_rejected()
                print("put back %d set-aside writes; %d set aside again; %d still waiting"
                      % (back, again, store.pending))
            print(_status(store))
            return 1 if store.pending else 0
    except (UsageError, BulletFloorSimError, OSError) as e:
        print("%s: %s" % (PROG, e), file=sys.stderr)
        return 2
