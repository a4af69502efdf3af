#!/usr/bin/env python3
"""Fetch and build the corpus of real buildings listed in worlds/corpus.yaml (``make corpus``).

For each building: download its source files (or take them from ``--from DIR``, by file
name), check each one's sha256, build a map_server map (a CARMEN log through
mapping/carmen.py; a map_server map as it is), and write a world beside it:

    <out>/<name>/map.pgm, map.yaml     the map
    <out>/<name>/world.yaml            rois: auto, two robots at the roomiest places apart
    <out>/<name>/SOURCE.md             where it came from, its licence, how it was built

``<out>`` is ``--out``, else $BFS_CORPUS, else ~/.cache/bullet_floor_sim/corpus. A building
already built is kept (``--force`` builds it again). Any failure (offline, a checksum that
differs, a malformed file) is one line naming the building and the file, and the exit status
is 1; the others are still built.

    .venv/bin/python tools/corpus.py                     # everything
    .venv/bin/python tools/corpus.py --only intel_lab --from ~/Downloads   # DIR/<name>/ too
"""
from __future__ import annotations

import argparse
import hashlib
import os
import re
import shutil
import sys
import urllib.request
from typing import Dict, List, Optional

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))

from bullet_floor_sim.errors import BulletFloorSimError  # noqa: E402
from bullet_floor_sim.paths import corpus_dir  # noqa: E402
from bullet_floor_sim.yamlio import read_yaml  # noqa: E402

MANIFEST = os.path.join(HERE, "..", "worlds", "corpus.yaml")


class CorpusError(BulletFloorSimError):
    """A building that could not be fetched or built."""


def manifest(path: str = MANIFEST) -> dict:
    doc = read_yaml(path, "corpus manifest", CorpusError)
    if not isinstance(doc, dict) or not isinstance(doc.get("worlds"), list):
        raise CorpusError("%s: expected a mapping with a list 'worlds'" % path)
    return doc


def fetch(entry: dict, downloads: str, source: Optional[str]) -> List[str]:
    """The building's files, checked: taken from ``source`` or downloaded into ``downloads``.

    Raises:
        CorpusError: a file cannot be had or its sha256 differs (the line names it).
    """
    out = []
    for f in entry["files"]:
        url, want = f["url"], f["sha256"]
        name = os.path.basename(url)
        path = os.path.join(downloads, entry["name"] + "__" + name)
        if source:   # SOURCE/<building>/<file>, else SOURCE/<file>
            given = os.path.join(source, entry["name"], name)
            given = given if os.path.isfile(given) else os.path.join(source, name)
            if not os.path.isfile(given):
                raise CorpusError("%s: %s is in neither %s nor %s" % (
                    entry["name"], name, os.path.join(source, entry["name"]), source))
            shutil.copyfile(given, path)
        elif not os.path.isfile(path) or _sha256(path) != want:
            _download(entry["name"], url, path)
        got = _sha256(path)
        if got != want:
            raise CorpusError("%s: %s has sha256 %s, the manifest says %s (a changed or "
                              "corrupt file)" % (entry["name"], name, got, want))
        out.append(path)
    return out


def _download(name: str, url: str, path: str) -> None:
    try:
        with urllib.request.urlopen(url, timeout=30) as r, open(path + ".part", "wb") as f:
            shutil.copyfileobj(r, f)
    except OSError as e:   # URLError is an OSError: offline, refused, 404
        raise CorpusError("%s: cannot download %s (%s); offline? give the files with "
                          "--from DIR" % (name, url, getattr(e, "reason", e))) from None
    os.replace(path + ".part", path)


def _sha256(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def build(entry: dict, files: List[str], out: str) -> str:
    """Write the building's map, world.yaml and SOURCE.md under ``out``/name; the world.yaml
    path."""
    from bullet_floor_sim.mapping.save import save_map
    from bullet_floor_sim.sim.floormap import load_map

    d = os.path.join(out, entry["name"])
    os.makedirs(d, exist_ok=True)
    if entry["format"] == "carmen":
        from bullet_floor_sim.mapping.carmen import map_from_log

        fmap = map_from_log(files[0])
    elif entry["format"] == "map_server":
        yml = next(f for f in files if f.endswith(".yaml"))
        img = next(f for f in files if not f.endswith(".yaml"))
        staged = os.path.join(d, "source")
        os.makedirs(staged, exist_ok=True)
        image = os.path.basename(img).split("__", 1)[1]
        shutil.copyfile(img, os.path.join(staged, image))
        with open(yml) as f:   # its image is the file fetched (some name it otherwise)
            text = re.sub(r"(?m)^image:.*$", "image: %s" % image, f.read())
        with open(os.path.join(staged, "map.yaml"), "w") as f:
            f.write(text)
        fmap = load_map(os.path.join(staged, "map.yaml"))
    else:
        raise CorpusError("%s: format %r unknown (carmen | map_server)"
                          % (entry["name"], entry["format"]))
    save_map(fmap, os.path.join(d, "map"))
    world = os.path.join(d, "world.yaml")
    _write_world(entry, world)
    with open(os.path.join(d, "SOURCE.md"), "w") as f:
        f.write("# %s (%s)\n\n%s.\n\nSource: %s\n\nsha256: %s\n\nLicence: %s\n\nBuilt by "
                "tools/corpus.py (format %s).\n" % (
                    entry["name"], entry["kind"], entry["about"],
                    ", ".join(x["url"] for x in entry["files"]),
                    ", ".join(x["sha256"] for x in entry["files"]), entry["licence"],
                    entry["format"]))
    return world


def _write_world(entry: dict, path: str) -> None:
    """world.yaml: the map, rois: auto, and two robots at the roomiest places of the floor
    the robot's footprint connects, 4-10 m apart (2-10 m in a small home) and in sight of
    each other (building.roomy_starts)."""
    from bullet_floor_sim.building import Building
    from bullet_floor_sim.sim.config import WorldConfig

    d = os.path.dirname(path)
    b = Building(WorldConfig(path=path, map_yaml=os.path.join(d, "map.yaml")))
    starts = b.roomy_starts(2, 4.0, within=10.0)   # the observer sees the walker
    if len(starts) < 2:   # a small home: closer together
        starts = b.roomy_starts(2, 2.0, within=10.0)
    if len(starts) < 2:
        raise CorpusError("%s: no room for two robots %s m apart in sight of each other on "
                          "the floor a robot connects" % (entry["name"], 2.0))
    lines = ["# %s (%s), built by tools/corpus.py from worlds/corpus.yaml: see SOURCE.md"
             % (entry["name"], entry["kind"]), "map: map.yaml", "rois: auto", "robots:"]
    for i, (x, y) in enumerate(starts, 1):
        lines.append("  - {name: robot%d, model: scitos_a5, pose: [%.2f, %.2f, 0.0]}" % (i, x, y))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main(argv: Optional[List[str]] = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=None, help="default: $BFS_CORPUS or ~/.cache/...")
    p.add_argument("--from", dest="source", default=None,
                   help="take the source files from this directory (by file name)")
    p.add_argument("--only", nargs="*", default=None, help="these buildings only")
    p.add_argument("--force", action="store_true", help="build again what is built")
    args = p.parse_args(argv)
    out = args.out or corpus_dir()
    try:
        entries = manifest()["worlds"]
    except CorpusError as e:
        print("corpus: %s" % e, file=sys.stderr)
        return 2
    names = [e["name"] for e in entries]
    unknown = sorted(set(args.only or []) - set(names))
    if unknown:
        print("corpus: unknown building(s) %s (the manifest has %s)"
              % (", ".join(unknown), ", ".join(names)), file=sys.stderr)
        return 2
    downloads = os.path.join(out, ".downloads")
    os.makedirs(downloads, exist_ok=True)
    failed: Dict[str, str] = {}
    for e in entries:
        if args.only and e["name"] not in args.only:
            continue
        world = os.path.join(out, e["name"], "world.yaml")
        if os.path.isfile(world) and not args.force:
            print("corpus: %s: built (%s)" % (e["name"], world))
            continue
        try:
            print("corpus: %s: %s" % (e["name"], build(e, fetch(e, downloads, args.source),
                                                       out)), flush=True)
        except BulletFloorSimError as err:
            failed[e["name"]] = str(err)
            print("corpus: %s" % err, file=sys.stderr, flush=True)
    if failed:
        print("corpus: %d of %d buildings not built: %s" % (
            len(failed), len(args.only or names), ", ".join(failed)), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
