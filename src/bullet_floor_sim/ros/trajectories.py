"""``rosrun bullet_floor_sim trajectories list|export|import|plot --db URI``: stored
trajectories listed, as JSON lines and as pictures.

A plain command-line tool (no ROS master needed, rospy is not imported)::

    trajectories list   --db URI [--map M] [WHO] [--since T] [--until T]
    trajectories export --db URI [--map M] [WHO] [--since T] [--until T] [--out FILE]
                        [--format jsonl|csv|trajnet|ethucy|mcap|mcap-ros2] [--rate 2.5]
    trajectories import --db URI --map M [FILE ...] [--max-poses N]
    trajectories plot   --db URI --out traj.png [--map M] [WHO] [--since T] [--until T]
                        [--world W | --map-yaml MAP] [--cell 0.25]

WHO is ``--person NAME [NAME ...]`` (those people's trajectories), ``--people`` (every
person's) or ``--robots`` (the robots', which name no person); default: all.

``--db`` is ``mongodb://host:port/`` or a directory for the embedded store (default
``$ROS_HOME/bullet_floor_sim/db``). Times are seconds (ROS time, sim time in simulation): a
chunk is selected when it ends at or after ``--since`` and starts at or before ``--until``;
the recorder of a people topic names each person in the chunks' meta, the recorder of a
pose topic the robot. ``list``, ``export`` and ``plot`` only read: a ``--db`` directory that
does not exist is an error (``no such database``), as is a ``--person`` nobody stored (the
error lists who is stored).

* ``list`` prints one line per trajectory: uuid, person or robot name, map, start and end
  (s), poses and chunks.

* ``export`` prints one JSON line per stored chunk: ``{"uuid", "sequence_id", "start_time",
  "end_time", "complete", "trajectory_length", "poses": [[t, x, y, yaw], ...]}``, t in
  seconds with 9 decimals; trajectory after trajectory (in order of their first pose), each
  in sequence_id order. Memory stays bounded (the store is read a few chunks at a time).
  ``--format`` csv, trajnet (TrajNet++ ndjson, its scenes cut as TrajNet++ cuts them),
  ethucy (the ETH/UCY ``frame<TAB>id<TAB>x<TAB>y`` text), both at ``--rate`` with a sidecar
  ``FILE.meta.json`` naming each id (``--out FILE`` needed), mcap (ROS 1 MCAP: ``--out
  FILE.mcap``, exactly that file) or mcap-ros2 (a ROS 2 bag: ``--out DIR``) write every pose
  once instead (data/trajectory/formats.py, trajnet.py).
* ``import`` reads such lines (files or stdin) back into the store as the recorder stores
  chunks (meta ``map`` from ``--map``, ``taken: "imported"``). A chunk already stored (same
  uuid and sequence_id) is skipped, so importing twice changes nothing. A line with more
  than ``--max-poses`` poses is split into several chunks sharing boundary poses, and the
  later chunks of that trajectory are renumbered after it.
* ``plot`` draws every selected trajectory (one colour each) and an occupancy heat-map (the
  share of poses per ``--cell`` square) over the map image: ``--map-yaml``, else the map of
  ``--world``, else of the world named like ``--map`` when there is one.

A summary goes to stderr; any error is one line on stderr and exit code 2. A reader that
stops reading (``| head``) ends the output quietly, exit code 141 as for a C tool that
SIGPIPE ends.
"""
from __future__ import annotations

import argparse
import gc
import os
import sys
import time
from dataclasses import replace
from typing import Any, Dict, IO, Iterable, List, Optional, Sequence, Tuple

from ..errors import BulletFloorSimError
from ..files import atomic_file
from ..data.store import Store, insert_message, open_store, require_existing
from ..data.trajectory import (COLLECTION, DATABASE, DEFAULT_MAX_POSES, STORED_TYPE, Chunk,
                               check_max_poses, chunk_fields, chunk_from_document,
                               chunk_from_json, document_to_json, ensure_indexes,
                               Persons, format_time, iter_documents, parse_time,
                               split_poses, stored_people, trajectory_heads)
from ..data.trajectory import trajnet
from ..data.trajectory.formats import (FORMATS, TRAJNET_RATE, write_csv, write_mcap,
                                       write_ros2_bag)
from .cli import Parser, UsageError
from .trajectory_plot import map_for_plot, plot_trajectories

__all__ = ["main", "export_chunks", "import_lines", "list_trajectories", "plot_trajectories"]

PROG = "trajectories"
_READING = ("list", "export", "plot")


def _parser() -> argparse.ArgumentParser:
    p = Parser(prog=PROG, description="Stored trajectories (message_store.people_trajectory) "
                "as JSON lines, back into the store, or as a picture.")
    sub = p.add_subparsers(dest="command", parser_class=Parser)

    def common(q: argparse.ArgumentParser, window: bool = True) -> None:
        q.add_argument("--db", default="", help="mongodb://host:port/ or a directory (default "
                       "$ROS_HOME/bullet_floor_sim/db)")
        q.add_argument("--map", dest="map_name", default="", help="only this map")
        if window:
            who = q.add_mutually_exclusive_group()
            who.add_argument("--person", nargs="+", default=[], metavar="NAME",
                             help="only these people's trajectories (as the recorder of a "
                             "people topic names them)")
            who.add_argument("--people", action="store_true",
                             help="only people's trajectories")
            who.add_argument("--robots", action="store_true",
                             help="only robots' trajectories (no person named)")
            q.add_argument("--since", help="only chunks ending at or after this time (s)")
            q.add_argument("--until", help="only chunks starting at or before this time (s)")

    ls = sub.add_parser("list", help="one line per stored trajectory: uuid, person or robot, "
                        "map, start, end, poses, chunks")
    common(ls)
    e = sub.add_parser("export", help="print stored chunks as JSON lines, or write them as "
                       "CSV, TrajNet++ ndjson, ETH/UCY text, ROS 1 MCAP or a ROS 2 bag")
    common(e)
    e.add_argument("--out", help="write to this file (mcap-ros2: this bag directory) instead of "
                   "stdout")
    e.add_argument("--format", default="jsonl", choices=FORMATS,
                   help="jsonl (default), csv, trajnet (TrajNet++ ndjson, --out FILE), ethucy "
                   "(frame id x y, tab-separated, --out FILE), mcap (ROS 1 MCAP, --out FILE) or "
                   "mcap-ros2 (a ROS 2 bag, --out DIR)")
    e.add_argument("--rate", type=float, default=TRAJNET_RATE,
                   help="trajnet, ethucy: samples a second (%g)" % TRAJNET_RATE)
    i = sub.add_parser("import", help="store JSON lines (files or stdin)")
    common(i, window=False)
    i.add_argument("files", nargs="*", metavar="FILE", help="JSON-lines files (default stdin)")
    i.add_argument("--max-poses", dest="max_poses", type=int, default=DEFAULT_MAX_POSES,
                   help="split longer chunks (default %d)" % DEFAULT_MAX_POSES)
    g = sub.add_parser("plot", help="draw trajectories and a heat-map to a PNG")
    common(g)
    g.add_argument("--out", required=True, help="PNG file to write")
    g.add_argument("--world", help="draw over this world's map (a name or a world.yaml)")
    g.add_argument("--map-yaml", dest="map_yaml", help="draw over this map_server map.yaml")
    g.add_argument("--cell", type=float, default=0.25, help="heat-map cell size, m (0.25)")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim trajectories``.

    Args:
        argv: arguments without the program name (default ``sys.argv[1:]``); ROS remapping
            arguments (``name:=value``) are ignored.

    Returns:
        0 on success, 2 on any error (one line on stderr).
    """
    args_in = [a for a in (sys.argv[1:] if argv is None else argv) if ":=" not in a]
    try:
        args = _parser().parse_args(args_in)
        if not args.command:
            raise UsageError("give a command: list, export, import or plot")
        since = until = None
        if getattr(args, "since", None) is not None:
            since = parse_time(args.since, "--since")
        if getattr(args, "until", None) is not None:
            until = parse_time(args.until, "--until")
        if since is not None and until is not None and since > until:
            raise UsageError("--since %s is after --until %s" % (args.since, args.until))
        if args.command == "import":
            if not args.map_name:
                raise UsageError("import needs --map NAME: the map the trajectories belong to")
            if args.max_poses < 2:
                raise UsageError("--max-poses must be >= 2, got %d" % args.max_poses)
            check_max_poses(args.max_poses)
        if args.command == "plot" and not args.cell > 0:
            raise UsageError("--cell must be a positive number of metres, got %s" % args.cell)
        if args.command in _READING:
            require_existing(args.db, DATABASE)
        with open_store(args.db or None) as store:
            if args.command in _READING:
                _check_people(store, args, since, until)
            if args.command == "list":
                _list(store, args, since, until)
            elif args.command == "export":
                _export(store, args, since, until)
            elif args.command == "import":
                _import(store, args)
            else:
                _plot(store, args, since, until)
    except BrokenPipeError:
        return _reader_gone()
    except (UsageError, BulletFloorSimError, ValueError, OSError) as e:
        return _fail(str(e))
    return 0


def _reader_gone() -> int:
    """The reader of stdout stopped reading: no message, and no second error when Python
    flushes stdout at exit."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):   # (stdout is no file: nothing will be flushed to it)
        pass
    return 141


def _who(args: argparse.Namespace) -> dict:
    """The selection by person or kind of ``--person``, ``--people``, ``--robots``."""
    return {"person": args.person or None,
            "kind": "people" if args.people else "robots" if args.robots else ""}


def _check_people(store: Store, args: argparse.Namespace, since: Optional[int],
                  until: Optional[int]) -> None:
    """An error when a ``--person`` has no trajectory in the selection: naming who is stored
    at all (and whether that person is, but not on ``--map`` or in the time window)."""
    if not args.person:
        return
    ensure_indexes(store)
    heads = trajectory_heads(store, args.map_name or None, since, until, person=args.person)
    found = {str(h.meta.get("person")) for h in heads}
    missing = [n for n in args.person if n not in found]
    if not missing:
        return
    known = stored_people(store)
    elsewhere = [n for n in missing if n in known]
    shown = ", ".join(known[:20]) + (" and %d more" % (len(known) - 20)
                                     if len(known) > 20 else "")
    raise UsageError("no trajectories of %s in %s%s; stored: %s" % (
        ", ".join(missing), store.shown_uri,
        " (%s: stored, but not on this map or in this time window)" % ", ".join(elsewhere)
        if elsewhere else "", shown or "nobody's (no person named in any trajectory)"))


# -- list -------------------------------------------------------------------------------------

def list_trajectories(store: Store, map_name: str = "", since: Optional[int] = None,
                      until: Optional[int] = None, person: Persons = None,
                      kind: str = "") -> List[Dict[str, Any]]:
    """One row per selected trajectory (data/trajectory's trajectory_heads), in order of its
    first pose, of its chunks in the selection (``map_name``, ``since``, ``until``, as export
    selects them): ``uuid``, ``who`` (the person's name, or the robot's as its recorder stored
    it, or ""), ``kind`` ("person", "robot", or "" when the chunks name neither, e.g.
    imported ones), ``map``, ``start_ns`` and ``end_ns`` (of the first and last selected
    chunk), ``poses`` (each once: a pose two chunks share counts once, as in the csv export)
    and ``chunks``."""
    ensure_indexes(store)
    rows = []
    for head in trajectory_heads(store, map_name or None, since, until, person=person or None,
                                 kind=kind):
        poses = chunks = 0
        start = end = None
        last = None
        for doc in iter_documents(store, map_name or None, since, until, heads=[head]):
            c = chunk_from_document(doc)
            chunks += 1
            poses += len(c.poses) - (1 if c.poses and c.poses[0] == last else 0)
            last = c.poses[-1] if c.poses else last
            start = c.start_ns if start is None else start
            end = c.end_ns
        if not chunks:
            continue
        meta = head.meta
        kind_of = "person" if meta.get("person") else "robot" if meta.get("robot") else ""
        rows.append({"uuid": str(head.uuid), "who": str(meta.get("person") or
                                                        meta.get("robot") or ""),
                     "kind": kind_of, "map": str(meta.get("map", "")), "start_ns": start,
                     "end_ns": end, "poses": poses, "chunks": chunks})
    return rows


def _list(store: Store, args: argparse.Namespace, since: Optional[int],
          until: Optional[int]) -> None:
    rows = list_trajectories(store, args.map_name, since, until, **_who(args))
    out = sys.stdout
    out.write("uuid\twho\tkind\tmap\tstart\tend\tposes\tchunks\n")
    for r in rows:
        out.write("%s\t%s\t%s\t%s\t%s\t%s\t%d\t%d\n" % (
            r["uuid"], r["who"] or "-", r["kind"] or "-", r["map"] or "-",
            format_time(r["start_ns"]),
            format_time(r["end_ns"]), r["poses"], r["chunks"]))
    out.flush()
    _note("%d trajectories (%d poses, %d chunks) in %s" % (
        len(rows), sum(r["poses"] for r in rows), sum(r["chunks"] for r in rows),
        store.shown_uri))


# -- export -----------------------------------------------------------------------------------

def export_chunks(store: Store, out: IO[str], map_name: str = "", since: Optional[int] = None,
                  until: Optional[int] = None, person: Persons = None,
                  kind: str = "") -> Tuple[int, int]:
    """Write the selected chunks (of ``person`` or ``kind`` when given: data/trajectory's
    trajectory_heads) as JSON lines to ``out``.

    Returns:
        (chunks, poses) written.
    """
    ensure_indexes(store)  # chunks are read by indexed (uuid, sequence_id) lookups
    chunks = poses = 0
    write = out.write
    # Decoding a chunk makes thousands of dicts and the store's query engine leaves reference
    # cycles behind; the collector's automatic passes then cost a third of the export.
    # Collecting the young generations every 16 chunks instead frees the same garbage.
    enabled = gc.isenabled()
    gc.disable()
    try:
        for doc in iter_documents(store, map_name or None, since, until,
                                  person=person or None, kind=kind):
            write(document_to_json(doc))
            write("\n")
            chunks += 1
            poses += len(doc["trajectory"])
            if chunks % 16 == 0:
                gc.collect(1)
    finally:
        if enabled:
            gc.enable()
    return chunks, poses


def _export(store: Store, args: argparse.Namespace, since: Optional[int],
            until: Optional[int]) -> None:
    t0 = time.monotonic()
    if args.format != "jsonl":
        _export_as(store, args, since, until)
        _note("exported as %s in %.2f s" % (args.format, time.monotonic() - t0))
        return
    if args.out:
        try:
            with atomic_file(args.out) as f:  # an old file stays whole if the query fails
                n, poses = export_chunks(store, f, args.map_name, since, until, **_who(args))
        except OSError as e:
            raise BulletFloorSimError("%s: cannot write (%s)" % (args.out, e.strerror or e))
    else:
        n, poses = export_chunks(store, sys.stdout, args.map_name, since, until,
                                 **_who(args))
        sys.stdout.flush()
    _note("exported %d chunks (%d poses) from %s in %.2f s" % (n, poses, store.shown_uri,
                                                               time.monotonic() - t0))


def _export_as(store: Store, args: argparse.Namespace, since: Optional[int],
               until: Optional[int]) -> None:
    """The csv, trajnet, ethucy, mcap and mcap-ros2 exports (data/trajectory/formats.py,
    trajnet.py)."""
    ensure_indexes(store)
    heads = trajectory_heads(store, args.map_name or None, since, until, **_who(args))
    chunks = (chunk_from_document(d) for d in iter_documents(
        store, args.map_name or None, since, until, heads=heads))
    if args.format in ("trajnet", "ethucy"):
        _export_benchmark(args, chunks, {str(h.uuid): h.meta for h in heads})
        return
    if args.format == "mcap-ros2":
        if not args.out:
            raise UsageError("--format mcap-ros2 needs --out DIR (the ROS 2 bag directory to "
                             "create)")
        n = write_ros2_bag(chunks, args.out)
        _note("%d poses to the ROS 2 bag %s" % (n, args.out))
        return
    if args.format == "mcap":
        if not args.out:
            raise UsageError("--format mcap needs --out FILE.mcap (binary output)")
        try:
            with atomic_file(args.out, "wb") as f:
                n = write_mcap(chunks, f)
        except OSError as e:
            raise BulletFloorSimError("%s: cannot write (%s)" % (args.out, e.strerror or e))
        _note("%d poses to the ROS 1 MCAP file %s" % (n, args.out))
        return
    if args.out:
        try:
            with atomic_file(args.out) as f:
                n = write_csv(chunks, f)
        except OSError as e:
            raise BulletFloorSimError("%s: cannot write (%s)" % (args.out, e.strerror or e))
    else:
        n = write_csv(chunks, sys.stdout)
        sys.stdout.flush()
    _note("%d poses" % n)


def _export_benchmark(args: argparse.Namespace, chunks: Iterable[Chunk],
                      meta: Dict[str, Dict[str, Any]]) -> None:
    """TrajNet++ ndjson or the ETH/UCY text, and the sidecar naming each id."""
    if not args.out:
        raise UsageError("--format %s needs --out FILE (beside it FILE.meta.json says who each "
                         "id is)" % args.format)
    sampled = trajnet.sample(chunks, args.rate)
    try:
        with atomic_file(args.out) as f:
            if args.format == "trajnet":
                scenes, n = trajnet.write_trajnetpp(sampled, f)
            else:
                scenes, n = -1, trajnet.write_ethucy(sampled, f)
        trajnet.write_sidecar(args.out, trajnet.sidecar(sampled, args.format, meta))
    except OSError as e:
        raise BulletFloorSimError("%s: cannot write (%s)" % (args.out, e.strerror or e))
    if scenes < 0:
        _note("%d lines (%d trajectories at %g Hz) to %s, ids in %s.meta.json"
              % (n, len(sampled.ids), args.rate, args.out, args.out))
    else:
        _note("%d scenes, %d track lines (%d trajectories at %g Hz) to %s, ids in %s.meta.json%s"
              % (scenes, n, len(sampled.ids), args.rate, args.out, args.out,
                 "" if scenes else ": no window met TrajNet++'s rules (21 samples in a row, "
                 "8 s at 2.5 Hz, without a gap, of a person moving more than 0.45 m among others: "
                 "2 x 21 rows in the window and someone in its 5 m cell at least once); "
                 "--format ethucy keeps every track"))


# -- import -----------------------------------------------------------------------------------

def _numbered(lines: Iterable[str], name: str) -> Iterable[Tuple[str, str]]:
    for k, line in enumerate(lines, 1):
        if line.strip():
            yield line, "%s:%d" % (name, k)


def import_lines(store: Store, lines: Iterable[Tuple[str, str]], map_name: str,
                 max_poses: int = DEFAULT_MAX_POSES, inserted_by: str = "/" + PROG
                 ) -> Tuple[int, int, int]:
    """Store export lines ((text, where) pairs) as chunks of ``map_name``.

    All lines are parsed before anything is stored: a bad line stores nothing.

    Returns:
        (chunks stored, chunks skipped because already stored, lines split).

    Raises:
        TrajectoryError: a bad line (named by its ``where``).
        StoreUnavailable: the database cannot be read (to check for duplicates).
    """
    parsed = [chunk_from_json(text, where) for text, where in lines]
    chunks, split = _split_oversize(parsed, max_poses)
    ensure_indexes(store)
    stored = skipped = 0
    now = time.time()
    for c in chunks:
        if store.find_one(DATABASE, COLLECTION, {"uuid": c.uuid,
                                                 "sequence_id": c.sequence_id}) is not None:
            skipped += 1
            continue
        stamp_ns = int(now * 1e9)
        insert_message(store, DATABASE, COLLECTION, chunk_fields(c, stamp_ns), STORED_TYPE,
                       meta={"map": map_name, "taken": "imported"}, inserted_by=inserted_by,
                       now=now, stamp_ns=stamp_ns)
        stored += 1
    return stored, skipped, split


def _split_oversize(chunks: List[Chunk], max_poses: int) -> Tuple[List[Chunk], int]:
    """Chunks over ``max_poses`` as several; the later chunks of their uuid renumbered."""
    if all(len(c.poses) <= max_poses for c in chunks):
        return chunks, 0
    by_uuid: Dict[str, List[Chunk]] = {}
    for c in chunks:
        by_uuid.setdefault(c.uuid, []).append(c)
    out: List[Chunk] = []
    split = 0
    for uid, group in by_uuid.items():
        group.sort(key=lambda c: c.sequence_id)
        shift = 0
        for c in group:
            pieces = split_poses(c.poses, max_poses)
            if len(pieces) == 1:
                out.append(replace(c, sequence_id=c.sequence_id + shift) if shift else c)
                continue
            split += 1
            for k, poses in enumerate(pieces):
                out.append(Chunk.from_poses(uid, c.sequence_id + shift + k, poses,
                                            c.complete and k == len(pieces) - 1))
            shift += len(pieces) - 1
    return out, split


def _import(store: Store, args: argparse.Namespace) -> None:
    t0 = time.monotonic()
    lines: List[Tuple[str, str]] = []
    for name in args.files or ["-"]:
        if name == "-":
            lines.extend(_numbered(sys.stdin, "<stdin>"))
            continue
        try:
            with open(name) as f:
                lines.extend(_numbered(f, name))
        except OSError as e:
            raise BulletFloorSimError("%s: cannot read (%s)" % (name, e.strerror or e))
        except UnicodeDecodeError as e:
            raise BulletFloorSimError("%s: not a text file (byte 0x%02x is not UTF-8)"
                                      % (name, e.object[e.start]))
    stored, skipped, split = import_lines(store, lines, args.map_name, args.max_poses)
    _note("imported %d chunks into %s (map %s) in %.2f s; %d already stored, skipped; %d split"
          % (stored, store.shown_uri, args.map_name, time.monotonic() - t0, skipped, split))
    if store.pending:
        _note("the database is unreachable: %d writes journalled in %s, replayed when it is "
              "back" % (store.pending, store.journal_path))


# -- plot -------------------------------------------------------------------------------------

def _plot(store: Store, args: argparse.Namespace, since: Optional[int],
          until: Optional[int]) -> None:
    ensure_indexes(store)
    chunks = [chunk_from_document(d) for d in iter_documents(
        store, args.map_name or None, since, until, **_who(args))]
    fmap = map_for_plot(args.map_yaml, args.world, args.map_name)
    n = plot_trajectories(chunks, args.out, fmap, args.cell)
    _note("plotted %d trajectories (%d chunks) to %s" % (n, len(chunks), args.out))


def _note(message: str) -> None:
    sys.stderr.write("%s: %s\n" % (PROG, message))


def _fail(message: str) -> int:
    sys.stderr.write("%s: error: %s\n" % (PROG, " ".join(message.split())))
    return 2


if __name__ == "__main__":
    sys.exit(main())
