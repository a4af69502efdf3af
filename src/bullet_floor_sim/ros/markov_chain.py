"""``rosrun bullet_floor_sim markov_chain ROIS_YAML``: the region Markov chain as JSON.

A plain command-line tool (no ROS master needed, rospy is not imported)::

    markov_chain ROIS_YAML [--tol 0.2] [--mode vertex|edge] [--min-shared 0.8]
                 [--map-yaml MAP] [--plot chain.png]
    markov_chain --db URI [--map NAME] [--config 1] [...]

prints ``{"map_name": ..., "transitions": {id: {id: p, ...}, ...}}`` on stdout (zeros left
out); warnings (isolated regions, separate parts, ROI vertices outside the map given with
``--map-yaml``) go to stderr. ``--plot`` draws the ROIs (over the map image with
``--map-yaml``) and an arrow per transition, width proportional to its probability (needs
matplotlib). ``--db`` reads the ROIs from the store instead of a file (``mongodb://host:port/``
or an embedded store's directory; "" for the default ``$ROS_HOME/bullet_floor_sim/db``): the
most recent version of each ROI of map ``--map`` (default: the only map stored for the config)
and config ``--config`` (default "1"), where the ROI manager keeps them (SOMA's ``somadata.roi``);
ROIs that an edit left invalid are left out with a warning. Any error is one line on stderr and
exit code 2.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Optional, Sequence

from ..errors import BulletFloorSimError
from ..people.markov import (MODES, ROI_COLLECTION, ROI_DATABASE, MarkovChain, read_rois,
                           usable_rois)
from ..people.plotting import draw_map, pyplot
from ..data.rois import Roi, check_bounds, load_rois, roi_polygon
from .cli import Parser, UsageError

__all__ = ["main", "plot_chain"]

PROG = "markov_chain"


def _parser() -> argparse.ArgumentParser:
    p = Parser(prog=PROG, description="Print the Markov chain over the regions of a rois.yaml "
                "as JSON (transitions: id -> id -> probability).")
    p.add_argument("rois", nargs="?", metavar="ROIS_YAML", help="ROI file (worlds/<name>/rois.yaml)")
    p.add_argument("--tol", type=float, default=0.2,
                   help="adjacency tolerance in metres (default 0.2)")
    p.add_argument("--mode", choices=MODES, default="vertex",
                   help="vertex: some vertices within tol in x and y (the seed rule, default); "
                        "edge: a shared wall of at least --min-shared metres")
    p.add_argument("--min-shared", type=float, default=0.8, dest="min_shared",
                   help="edge mode: shortest shared wall, metres (default 0.8)")
    p.add_argument("--map-yaml", dest="map_yaml", help="map_server map.yaml: bounds check, and "
                   "background of --plot")
    p.add_argument("--plot", metavar="PNG", help="draw the chain to this PNG (needs matplotlib)")
    p.add_argument("--db", metavar="URI", help="read the ROIs from this store instead of a "
                   "file: mongodb://host:port/ or a directory (\"\" = the default embedded "
                   "store)")
    p.add_argument("--map", dest="map_name", help="with --db: map name (default: the only map "
                   "with ROIs of the config)")
    p.add_argument("--config", help="with --db: ROI config (default \"1\")")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``rosrun bullet_floor_sim markov_chain``.

    Args:
        argv: arguments without the program name (default ``sys.argv[1:]``); ROS remapping
            arguments (``name:=value``, added by roslaunch) are ignored.

    Returns:
        0 on success, 2 on any error (one line on stderr).
    """
    args_in = list(sys.argv[1:] if argv is None else argv)
    args_in = [a for a in args_in if ":=" not in a]
    try:
        args = _parser().parse_args(args_in)
        _check_args(args)
        if args.db is not None:
            source, rois = _rois_from_store(args.db, args.map_name, args.config or "1")
        else:
            source, rois = args.rois, load_rois(args.rois)
        chain = MarkovChain.from_rois(rois, tol=args.tol, mode=args.mode,
                                      min_shared=args.min_shared)
        fmap = None
        if args.map_yaml:
            from ..sim.floormap import load_map

            fmap = load_map(args.map_yaml)
            for w in check_bounds(rois, fmap.bounds()):
                _warn("%s: %s" % (source, w))
        for w in chain.warnings:
            _warn("%s: %s" % (source, w))
        if args.plot:
            plot_chain(chain, rois, args.plot, fmap)
    except (UsageError, BulletFloorSimError, ValueError) as e:
        return _fail(str(e))
    sys.stdout.write(json.dumps(chain.to_json(), indent=2) + "\n")
    sys.stdout.flush()
    return 0


def _check_args(args: argparse.Namespace) -> None:
    if args.db is not None and args.rois:
        raise UsageError("give a ROIS_YAML file or --db, not both")
    if args.db is None and (args.map_name is not None or args.config is not None):
        raise UsageError("--map and --config select ROIs in the store: add --db URI")
    if args.db is None and not args.rois:
        raise UsageError("give a ROIS_YAML file (e.g. worlds/office/rois.yaml) or --db URI")
    if not (math.isfinite(args.tol) and args.tol >= 0.0):
        raise UsageError("--tol must be a finite number of metres >= 0, got %s" % args.tol)
    if not (math.isfinite(args.min_shared) and args.min_shared > 0.0):
        raise UsageError("--min-shared must be a finite number of metres > 0, got %s"
                          % args.min_shared)


def _rois_from_store(uri: str, map_name: Optional[str], config: str):
    """(label for messages, ROIs) of a map and config in the store; bad ROIs are warned about.

    Raises:
        StoreError: the store cannot be opened or read (StoreUnavailable when it is down).
        RoiError: no ROIs are stored for the map and config.
    """
    from ..data.rois import RoiError
    from ..data.store import open_store

    store = open_store(uri or None)
    try:
        where = "%s %s.%s" % (store.shown_uri, ROI_DATABASE, ROI_COLLECTION)
        if map_name is None:
            maps = sorted({str(d.get("map_name")) for d in store.find(
                ROI_DATABASE, ROI_COLLECTION, {"config": config})})
            if len(maps) != 1:
                raise RoiError("%s: %s: give --map NAME" % (where, (
                    "no ROIs of config %r" % config) if not maps else (
                    "ROIs of config %r on several maps (%s)" % (config, ", ".join(maps)))))
            map_name = maps[0]
        rois, warnings = usable_rois(read_rois(store, map_name, config))
    finally:
        store.close()
    label = "%s (map %s, config %s)" % (where, map_name, config)
    for w in warnings:
        _warn("%s: %s" % (label, w))
    if not rois:
        raise RoiError("%s: no usable ROIs stored" % label)
    return label, rois


def _warn(message: str) -> None:
    sys.stderr.write("%s: warning: %s\n" % (PROG, message))


def _fail(message: str) -> int:
    sys.stderr.write("%s: error: %s\n" % (PROG, " ".join(message.split())))
    return 2


def plot_chain(chain: MarkovChain, rois: Sequence[Roi], path: str, fmap=None) -> None:
    """Draw the ROIs (over the map image when given) and the transitions to a PNG.

    Each region is outlined and labelled with its id and P(stay); each transition i -> j is an
    arrow between region anchors (the centroid, or a point inside when the centroid falls
    outside a non-convex region) whose width is proportional to P(i -> j).

    Args:
        chain: the chain.
        rois: its ROIs.
        path: PNG file to write.
        fmap: optional FloorMap drawn underneath.

    Raises:
        BulletFloorSimError: matplotlib is missing or the file cannot be written.
    """
    plt = pyplot("--plot")
    from matplotlib.patches import FancyArrowPatch
    from matplotlib.patches import Polygon as PolygonPatch

    fig, ax = plt.subplots(figsize=(12, 9))
    try:
        if fmap is not None:
            draw_map(ax, fmap)
        colours = {}  # type: dict
        palette = plt.get_cmap("tab10")
        anchors = {}
        for roi in rois:
            colour = colours.setdefault(roi.type, palette(len(colours) % 10))
            ax.add_patch(PolygonPatch(roi.vertices, closed=True, facecolor=colour, alpha=0.25,
                                      edgecolor=colour, linewidth=1.5))
            poly = roi_polygon(roi)
            c = poly.centroid if poly.contains(poly.centroid) else poly.representative_point()
            anchors[roi.id] = (float(c.x), float(c.y))
            ax.text(c.x, c.y, "%s\nstay %.2f" % (roi.id, chain.probability(roi.id, roi.id)),
                    ha="center", va="center", fontsize=8)
        for i in chain.ids:
            for j, p in chain.row(i).items():
                if j == i:
                    continue
                ax.add_patch(FancyArrowPatch(anchors[i], anchors[j], arrowstyle="-|>",
                                             mutation_scale=10, linewidth=0.5 + 6.0 * p,
                                             connectionstyle="arc3,rad=0.15", color="tab:red",
                                             alpha=0.7, shrinkA=12, shrinkB=12))
        for t, colour in colours.items():
            ax.plot([], [], color=colour, linewidth=6, alpha=0.4, label=t)
        if colours:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_xlabel("x (m, map frame)")
        ax.set_ylabel("y (m)")
        ax.set_title("Markov chain of map %s (arrow width ~ probability)" % chain.map_name)
        try:
            fig.savefig(path, dpi=150, bbox_inches="tight")
        except OSError as e:
            raise BulletFloorSimError("%s: cannot write the plot: %s"
                                      % (path, e.strerror or e)) from None
    finally:
        plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
