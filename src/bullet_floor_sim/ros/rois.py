"""``rosrun bullet_floor_sim rois export|import|auto``: ROIs between the store and rois.yaml files,
and rooms found automatically.

    rois export [--db URI] [--map NAME] [--config C] [-o FILE]
        the newest version of every ROI of a map and config, as a rois.yaml (stdout or FILE)
    rois import FILE [--db URI] [--replace]
        store the file's ROIs as new versions (only those that changed); with --replace, ROIs
        of that map and config missing from the file are deleted (their history stays)
    rois auto MAP_OR_WORLD -o FILE
        the rooms of a map_server map.yaml (or a world.yaml's map, with its map handling and
        rooms: section), found automatically (building/rooms.py), as a rois.yaml: the ones the
        world's first robot reaches (for a bare map, those on the part of the floor most rooms
        are on); edit it in rviz like any ROI file

``--db`` is ``mongodb://host:port/`` or a directory (default ``$ROS_HOME/bullet_floor_sim/db``),
as ``rois.launch db:=``. A running ROI manager picks imported changes up within seconds.
No roscore needed. Exit status 0 on success, 1 with a one-line error otherwise.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from typing import List, Optional

from bullet_floor_sim.errors import BulletFloorSimError
from bullet_floor_sim.data.roi_store import COLLECTION, DATABASE, RoiStore
from bullet_floor_sim.data.rois import load_rois, save_rois
from bullet_floor_sim.data.store import open_store, require_existing


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rois", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    ex = sub.add_parser("export", help="write the stored ROIs of a map and config as rois.yaml")
    ex.add_argument("--db", default="", help="mongodb://host:port/ or a directory")
    ex.add_argument("--map", default="", help="map name (default: the only map in the store)")
    ex.add_argument("--config", default="", help="ROI config (default: the only one of the map)")
    ex.add_argument("-o", "--output", default="-", help="file to write (default: stdout)")
    im = sub.add_parser("import", help="store the ROIs of a rois.yaml as new versions")
    im.add_argument("file", help="a rois.yaml")
    im.add_argument("--db", default="", help="mongodb://host:port/ or a directory")
    im.add_argument("--replace", action="store_true",
                    help="delete stored ROIs of that map and config that the file lacks")
    au = sub.add_parser("auto", help="write the rooms of a map, found automatically, as rois.yaml")
    au.add_argument("source", help="a map_server map.yaml or a world.yaml")
    au.add_argument("-o", "--output", required=True, help="the rois.yaml to write")
    return p


def auto(args: argparse.Namespace) -> int:
    from bullet_floor_sim.building.autorois import write_auto_rois
    from bullet_floor_sim.sim.config import WorldConfig, load_world_config
    from bullet_floor_sim.yamlio import read_yaml

    doc = read_yaml(args.source, "map or world", BulletFloorSimError)
    if isinstance(doc, dict) and "image" in doc:      # a map_server map.yaml
        cfg = WorldConfig(path=os.path.abspath(args.source), map_yaml=os.path.abspath(args.source))
    else:
        cfg = load_world_config(args.source)
    n, left_out = write_auto_rois(cfg, args.output)
    for line in left_out:
        print("left out %s" % line, file=sys.stderr)
    print("wrote %d rooms of %s to %s" % (n, cfg.map_yaml, args.output), file=sys.stderr)
    return 0


def _only(kind: str, values: List[str], option: str, where: str) -> str:
    if len(values) == 1:
        return values[0]
    if not values:
        raise BulletFloorSimError("%s: no ROIs stored" % where)
    raise BulletFloorSimError("%s holds several %ss (%s): choose one with %s"
                              % (where, kind, ", ".join(values), option))


def export(args: argparse.Namespace) -> int:
    require_existing(args.db, DATABASE)
    with open_store(args.db or None) as store:
        map_name = args.map
        if not map_name:
            maps = sorted({d["map_name"] for d in store.find(DATABASE, COLLECTION, {})
                           if "map_name" in d})
            map_name = _only("map", maps, "--map", "store %s" % store.shown_uri)
        rdb = RoiStore(store, map_name)
        config = args.config or _only("config", rdb.configs(), "--config",
                                      "map %s in store %s" % (map_name, store.shown_uri))
        rois = rdb.current(config)
        if not rois:
            raise BulletFloorSimError("map %s config %s in store %s: no ROIs (deleted or never "
                                      "stored)" % (map_name, config, store.shown_uri))
    if args.output == "-":
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "rois.yaml")
            save_rois(rois, path)
            with open(path) as f:
                sys.stdout.write(f.read())
    else:
        save_rois(rois, args.output)
        print("exported %d ROIs of map %s config %s to %s"
              % (len(rois), map_name, config, args.output), file=sys.stderr)
    return 0


def import_(args: argparse.Namespace) -> int:
    rois = load_rois(args.file)
    if not rois:
        raise BulletFloorSimError("%s: no ROIs to import" % args.file)
    map_name, config = rois[0].map_name, rois[0].config
    with open_store(args.db or None) as store:
        rdb = RoiStore(store, map_name, inserted_by="rois import")
        if args.replace:
            written, deleted = rdb.replace(rois, config)
        else:
            current = {r.id: r for r in rdb.current(config)}
            merged = [r for i, r in current.items() if i not in {x.id for x in rois}] + rois
            written, deleted = rdb.replace(merged, config)
        pending = store.pending
    print("imported %s: %d ROIs of map %s config %s, %d new versions, %d deleted%s"
          % (args.file, len(rois), map_name, config, written, deleted,
             " (database down: %d writes journalled, replayed when it is back)" % pending
             if pending else ""), file=sys.stderr)
    return 0


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim rois``."""
    args = _parser().parse_args(argv)
    try:
        return {"export": export, "import": import_, "auto": auto}[args.command](args)
    except (BulletFloorSimError, OSError) as e:
        print("rois %s: error: %s" % (args.command, e), file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
