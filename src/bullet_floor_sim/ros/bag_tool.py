"""``rosrun bullet_floor_sim bag convert IN.bag [IN.bag ...] --out DIR``: ROS 1 bags (a
recorded demo: ``demo.launch record:=true``) as one ROS 2 bag, for ROS 2 tools.

A plain command-line tool (no ROS master, no ROS 2 install): rosbags converts in pure Python.
Every message is converted, our own types too (a ROS 1 bag carries each type's definition);
messages keep their stamps, topics and order. ``--storage`` mcap (default) or sqlite3 (the
rosbag2 default of older ROS 2 releases); ``--topic`` (repeatable) keeps only those topics.
A summary goes to stderr; any error is one line on stderr and exit code 2.
"""
from __future__ import annotations

import os
import sys
from typing import Optional, Sequence

from ..errors import BulletFloorSimError
from ..data.trajectory.formats import ROS2_BAG_VERSION
from .cli import Parser, UsageError

__all__ = ["main", "convert"]

PROG = "bag"


def convert(sources: Sequence[str], out: str, storage: str = "mcap",
            topics: Sequence[str] = ()) -> int:
    """Convert ROS 1 bags into the ROS 2 bag directory ``out``; returns the messages written.

    Raises:
        BulletFloorSimError: rosbags is missing, a source cannot be read, ``out`` exists.
    """
    try:
        from rosbags.convert import ConverterError, convert as rb_convert
        from rosbags.rosbag2 import Reader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise BulletFloorSimError("bag convert needs the rosbags package (Python >= 3.10; "
                                  "make setup installs it)") from None
    from pathlib import Path

    for s in sources:
        if not os.path.isfile(s):
            raise BulletFloorSimError("%s: no such bag" % s)
    if os.path.exists(out):
        raise BulletFloorSimError("%s exists: give a new directory for the ROS 2 bag" % out)
    try:
        rb_convert([Path(s) for s in sources], Path(out), storage, ROS2_BAG_VERSION, None, "file",
                   get_typestore(Stores.ROS2_HUMBLE), None, [], list(topics), [], [])
    except ConverterError as e:
        raise BulletFloorSimError("bag convert: %s" % e) from None
    with Reader(out) as reader:
        return int(reader.message_count)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point; 0 on success, 2 on any error (one line on stderr)."""
    p = Parser(prog=PROG, description="ROS 1 bags as a ROS 2 bag")
    sub = p.add_subparsers(dest="command", parser_class=Parser)
    c = sub.add_parser("convert", help="ROS 1 bag(s) -> one ROS 2 bag directory")
    c.add_argument("bags", nargs="+", metavar="IN.bag")
    c.add_argument("--out", required=True, help="the ROS 2 bag directory to create")
    c.add_argument("--storage", default="mcap", choices=("mcap", "sqlite3"))
    c.add_argument("--topic", action="append", default=[], help="only this topic (repeatable)")
    args_in = [a for a in (sys.argv[1:] if argv is None else argv) if ":=" not in a]
    try:
        args = p.parse_args(args_in)
        if not args.command:
            raise UsageError("give a command: convert")
        n = convert(args.bags, args.out, args.storage, args.topic)
    except (UsageError, BulletFloorSimError, OSError) as e:
        print("%s: %s" % (PROG, e), file=sys.stderr)
        return 2
    print("%s: %d messages from %s to the ROS 2 bag %s (%s)" % (
        PROG, n, ", ".join(args.bags), args.out, args.storage), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
