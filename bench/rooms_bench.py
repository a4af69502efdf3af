#!/usr/bin/env python3
"""Score building/rooms.segment_rooms on the ipa_room_segmentation test maps (Bormann et al.,
"Room segmentation: survey, implementation, and analysis", ICRA 2016), held out by k-fold
cross-validation.

The maps are the 20 maps of ipa320/ipa_coverage_planning, ipa_room_segmentation/common/files/
test_maps: for each name X, ``X.png`` (no furniture), ``X_furnitures.png`` and
``X_gt_segmentation.png`` (the ground truth of both), 0.05 m per pixel. Free = gray >= 250, as
ipa's evaluation node reads the input maps.

The score is ipa's EvaluationSegmentation::computePrecisionRecall: GT rooms are the 8-connected
regions of gray > 250 in the GT image with more than 100 pixels; segments are label values with
more than 100 pixels; recall = mean over GT rooms of (largest overlap with one segment / room
size), precision = mean over segments of (largest overlap with one GT room / segment size)
(ipa's "micro" pair, the main one here); the area-weighted (pooled) pair is printed as Rw/Pw.

Parameters are never scored on the maps they were chosen on: the maps are split into
``--folds`` folds; for each, the RoomConfig on a small grid with the best mean of recall and
precision (both variants) over the other folds' maps is used on the fold's maps. The table and
the means are of those held-out runs. Usage::

    bench/rooms_bench.py --maps DIR          # or ROOMS_BENCH_MAPS=DIR bench/rooms_bench.py
    bench/rooms_bench.py --maps DIR --fixed  # just the default RoomConfig, no search
    bench/rooms_bench.py --maps DIR --grid seed_height=0.05,0.1,0.2 --grid min_room_area=1,2,4
        # search these fields instead (the others at their defaults)
"""
from __future__ import annotations

import argparse
import itertools
import os
import sys
import time
from multiprocessing import Pool
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
from scipy import ndimage as ndi

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))

from bullet_floor_sim.building.rooms import (  # noqa: E402
    RoomConfig, basin_graph, rooms_from_basins)

MAPS = ("lab_ipa", "lab_c_scan", "Freiburg52_scan", "Freiburg79_scan", "lab_b_scan", "lab_intel",
        "Freiburg101_scan", "lab_d_scan", "lab_f_scan", "lab_a_scan", "NLB", "office_a",
        "office_b", "office_c", "office_d", "office_e", "office_f", "office_g", "office_h",
        "office_i")
VARIANTS = ("", "_furnitures")
RESOLUTION = 0.05
# Bormann et al. ICRA 2016, recall / precision in % (no furniture, with furniture), as quoted by
# a third-party literature note; the paper's table itself was not read.
PAPER = (("Voronoi", (95.0, 94.8, 86.6, 94.5)),
         ("morphological", (98.1, 88.5, 84.6, 90.5)),
         ("distance", (96.9, 88.4, 76.1, 88.4)))
# the search grid: graph parameters (each needs a new watershed) x merge parameters
GRAPH_GRID = {"furniture_area": (1.0, 2.0)}
MERGE_GRID = {"door_ratio": (0.6, 0.7, 0.8), "max_door_width": (1.6, 2.0, 2.5)}
#: what is searched without --grid
DEFAULT_SEARCH = {**GRAPH_GRID, **MERGE_GRID}
#: the RoomConfig fields basin_graph reads (a new watershed per value); the others only merge
GRAPH_FIELDS = ("furniture_area", "wall_length", "seed_height")

Combo = Tuple[Tuple[str, float], ...]
Score = Tuple[float, float, float, float, int, int, float]  # R, P, Rw, Pw, gt, ours, seconds


# --------------------------------------------------------------------------------------------
# the ipa metric
# --------------------------------------------------------------------------------------------


def gt_rooms(gt_gray: np.ndarray) -> Tuple[np.ndarray, int]:
    """ipa's GT rooms: 8-connected regions of gray > 250, those of <= 100 pixels dropped;
    labelled 1..n."""
    lab, n = ndi.label(gt_gray > 250, structure=np.ones((3, 3), dtype=bool))
    sizes = np.bincount(lab.ravel(), minlength=n + 1)
    keep = sizes > 100
    keep[0] = False
    lookup = np.zeros(n + 1, dtype=np.int64)
    lookup[keep] = np.arange(1, int(keep.sum()) + 1)
    return lookup[lab], int(keep.sum())


def precision_recall(gt: np.ndarray, n_gt: int, seg: np.ndarray) -> Tuple[float, float, float, float, int]:
    """ipa's recall/precision (unweighted means over GT rooms / segments) and the area-weighted
    pair, and the number of segments counted (label != 0, > 100 pixels)."""
    s = np.asarray(seg, dtype=np.int64).ravel()
    g = gt.ravel()
    n_seg = int(s.max()) + 1 if s.size else 1
    sizes = np.bincount(s, minlength=n_seg)
    keep = sizes > 100
    keep[0] = False
    overlap = np.bincount(s * (n_gt + 1) + g, minlength=n_seg * (n_gt + 1)).reshape(n_seg, n_gt + 1)
    overlap = overlap[keep][:, 1:]
    gt_size = np.bincount(g, minlength=n_gt + 1)[1:].astype(float)
    seg_size = sizes[keep].astype(float)
    best_gt = overlap.max(axis=0) if overlap.shape[0] else np.zeros(n_gt)
    best_seg = overlap.max(axis=1) if n_gt else np.zeros(len(seg_size))
    recall = float(np.mean(best_gt / gt_size)) if n_gt else 0.0
    precision = float(np.mean(best_seg / seg_size)) if len(seg_size) else 0.0
    recall_w = float(best_gt.sum() / gt_size.sum()) if n_gt else 0.0
    precision_w = float(best_seg.sum() / seg_size.sum()) if len(seg_size) else 0.0
    return recall, precision, recall_w, precision_w, int(keep.sum())


# --------------------------------------------------------------------------------------------
# runs
# --------------------------------------------------------------------------------------------


Grid = Dict[str, Tuple[float, ...]]


def parse_grid(items: Sequence[str]) -> Grid:
    """``--grid NAME=V1,V2,...`` items as {field: values}.

    Raises:
        ValueError: an item without ``=``, a field RoomConfig lacks, a value that is not a
            number, or a field given twice (named).
    """
    fields = set(RoomConfig.__dataclass_fields__)
    out: Grid = {}
    for item in items:
        name, sep, values = item.partition("=")
        if not sep or not values:
            raise ValueError("--grid %r: expected NAME=V1,V2,..." % item)
        if name not in fields:
            raise ValueError("--grid %r: RoomConfig has no field %r (fields: %s)"
                             % (item, name, ", ".join(sorted(fields))))
        if name in out:
            raise ValueError("--grid %r: %s is given twice" % (item, name))
        try:
            out[name] = tuple(float(v) for v in values.split(","))
        except ValueError:
            raise ValueError("--grid %r: values must be numbers" % item) from None
    return out


def grid(fixed: bool, search: Optional[Grid] = None) -> Tuple[List[Combo], List[Combo]]:
    """The graph and merge parameter combinations: the product of ``search`` (default:
    GRAPH_GRID and MERGE_GRID), split by whether basin_graph reads the field; just the
    defaults when fixed."""
    if fixed:
        return [()], [()]
    search = search or DEFAULT_SEARCH
    graph_grid = {k: v for k, v in search.items() if k in GRAPH_FIELDS}
    merge_grid = {k: v for k, v in search.items() if k not in GRAPH_FIELDS}
    graph = [tuple(zip(graph_grid, v)) for v in itertools.product(*graph_grid.values())]
    merge = [tuple(zip(merge_grid, v)) for v in itertools.product(*merge_grid.values())]
    return graph, merge


def read_gray(path: str) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as img:
        return np.asarray(img.convert("L"))


def score_map(job: Tuple[str, str, str, bool, Grid]) -> Tuple[str, str, Dict[Combo, Score]]:
    """Every grid combination on one map variant."""
    maps, name, variant, fixed, search = job
    free = read_gray(os.path.join(maps, name + variant + ".png")) >= 250
    gt, n_gt = gt_rooms(read_gray(os.path.join(maps, name + "_gt_segmentation.png")))
    graphs, merges = grid(fixed, search)
    out: Dict[Combo, Score] = {}
    for g in graphs:
        t0 = time.perf_counter()
        graph = basin_graph(free, RESOLUTION, RoomConfig(**dict(g)))
        t_graph = time.perf_counter() - t0
        for m in merges:
            t1 = time.perf_counter()
            labels = rooms_from_basins(graph, RoomConfig(**dict(g + m)))
            seconds = t_graph + time.perf_counter() - t1
            r, p, rw, pw, n_seg = precision_recall(gt, n_gt, labels)
            out[g + m] = (r, p, rw, pw, n_gt, n_seg, seconds)
    return name, variant, out


def mean_score(results: Dict[Tuple[str, str], Dict[Combo, Score]], names: Sequence[str],
               combo: Combo) -> float:
    """A combination's mean (recall + precision) / 2 over names, both variants."""
    return float(np.mean([(results[(n, v)][combo][0] + results[(n, v)][combo][1]) / 2.0
                          for n in names for v in VARIANTS]))


def shipped_fields(combo: Combo) -> int:
    """How many of a combination's values are RoomConfig's shipped defaults."""
    return sum(1 for k, v in combo if getattr(RoomConfig(), k) == v)


def choose(results: Dict[Tuple[str, str], Dict[Combo, Score]], names: Sequence[str]) -> Combo:
    """The combination with the best mean (recall + precision) / 2 over names, both variants;
    on a tie, the one with more shipped defaults (then the first in grid order), so a value
    that changes nothing never replaces a default."""
    combos = list(next(iter(results.values())))
    best, best_score = combos[0], -1.0
    for combo in combos:
        score = mean_score(results, names, combo)
        tie = abs(score - best_score) <= 1e-12
        if score > best_score + 1e-12 or (tie and shipped_fields(combo) > shipped_fields(best)):
            best, best_score = combo, score
    return best


def print_scores(results: Dict[Tuple[str, str], Dict[Combo, Score]], top: int = 12) -> None:
    """The grid's best combinations on all maps (not held out: to see ties and spreads)."""
    combos = list(next(iter(results.values())))
    ranked = sorted(combos, key=lambda c: -mean_score(results, MAPS, c))
    print("## the grid on all 20 maps, not held out: mean (recall + precision) / 2, %\n")
    for combo in ranked[:top]:
        print("- %.3f  %s" % (100 * mean_score(results, MAPS, combo), show(combo)))
    print("- (%d combinations; the worst %.3f)\n"
          % (len(ranked), 100 * mean_score(results, MAPS, ranked[-1])))


def median(chosen: List[Combo]) -> Combo:
    """Per parameter, the median of the folds' choices (the lower middle one for even counts)."""
    names = [k for k, _ in chosen[0]]
    return tuple((k, sorted(dict(c)[k] for c in chosen)[(len(chosen) - 1) // 2]) for k in names)


def show(combo: Combo) -> str:
    return ", ".join("%s=%g" % kv for kv in combo) if combo else "defaults"


def main(argv: Sequence[str] = ()) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--maps", default=os.environ.get("ROOMS_BENCH_MAPS", ""),
                        help="directory of the ipa test maps (or env ROOMS_BENCH_MAPS)")
    parser.add_argument("--folds", type=int, default=5, help="cross-validation folds (default 5)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes")
    parser.add_argument("--fixed", action="store_true",
                        help="score the default RoomConfig only (no search, no folds)")
    parser.add_argument("--grid", action="append", default=[], metavar="NAME=V1,V2,...",
                        help="search these values of a RoomConfig field (repeatable); the "
                             "fields not given stay at their defaults (default: the grid of "
                             "furniture_area, door_ratio and max_door_width)")
    args = parser.parse_args(list(argv) or None)
    try:
        search = parse_grid(args.grid) or DEFAULT_SEARCH
    except ValueError as err:
        print("rooms_bench: %s" % err, file=sys.stderr)
        return 2
    if args.fixed and args.grid:
        print("rooms_bench: --fixed scores the defaults only: drop --grid, or --fixed",
              file=sys.stderr)
        return 2
    if not args.maps:
        print("rooms_bench: no maps directory: pass --maps DIR or set ROOMS_BENCH_MAPS", file=sys.stderr)
        return 2
    missing = [n + s for n in MAPS for s in VARIANTS + ("_gt_segmentation",)
               if not os.path.isfile(os.path.join(args.maps, n + s + ".png"))]
    if missing:
        print("rooms_bench: %s lacks %d of the ipa test maps (e.g. %s.png); copy "
              "ipa_room_segmentation/common/files/test_maps there" % (args.maps, len(missing), missing[0]),
              file=sys.stderr)
        return 2
    if not 2 <= args.folds <= len(MAPS) and not args.fixed:
        print("rooms_bench: --folds must be 2..%d" % len(MAPS), file=sys.stderr)
        return 2

    jobs = [(args.maps, n, v, args.fixed, search) for v in VARIANTS for n in MAPS]
    with Pool(max(1, args.jobs)) as pool:
        results = {(n, v): out for n, v, out in pool.imap_unordered(score_map, jobs)}

    if args.fixed:
        folds = [list(MAPS)]
        chosen = [()]  # type: List[Combo]
    else:
        folds = [list(MAPS[k::args.folds]) for k in range(args.folds)]
        chosen = [choose(results, [n for n in MAPS if n not in fold]) for fold in folds]
    held: Dict[Tuple[str, str], Tuple[int, Score]] = {}
    for k, (fold, combo) in enumerate(zip(folds, chosen)):
        for n in fold:
            for v in VARIANTS:
                held[(n, v)] = (k + 1, results[(n, v)][combo])
    if not args.fixed:
        print("searched: %s\n" % "; ".join("%s in {%s}" % (k, ", ".join("%g" % x for x in v))
                                           for k, v in search.items()))
        print_scores(results)
    report(held, folds, chosen, args.fixed)
    return 0


def report(held: Dict[Tuple[str, str], Tuple[int, Score]], folds: List[List[str]],
           chosen: List[Combo], fixed: bool) -> None:
    """The per-map table, the parameters per fold, the means beside the paper's, the BENCH line."""
    kind = "default RoomConfig (no search)" if fixed else "held-out (%d-fold cross-validation)" % len(folds)
    print("## segment_rooms on the ipa maps, %s\n" % kind)
    print("| map | furniture | fold | recall % | precision % | recall w % | precision w % "
          "| rooms gt | rooms ours | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for v in VARIANTS:
        for n in MAPS:
            k, (r, p, rw, pw, g, o, s) = held[(n, v)]
            print("| %s | %s | %d | %.1f | %.1f | %.1f | %.1f | %d | %d | %.1f |"
                  % (n, "yes" if v else "no", k, 100 * r, 100 * p, 100 * rw, 100 * pw, g, o, s))
    print("\n## parameters per fold\n")
    for k, (fold, combo) in enumerate(zip(folds, chosen)):
        print("fold %d (held out: %s): %s" % (k + 1, ", ".join(fold), show(combo)))
    if not fixed:
        print("default (per parameter, the median of the folds' choices): %s" % show(median(chosen)))
    print("\n## means over the 20 maps (± sample std), beside Bormann et al. 2016 "
          "(as quoted by a secondary source)\n")
    print("| method | recall % | precision % | recall % furn. | precision % furn. |")
    print("|---|---|---|---|---|")
    means = []
    cells = []
    for v in VARIANTS:
        for col in (0, 1):
            x = 100 * np.array([held[(n, v)][1][col] for n in MAPS])
            means.append(float(x.mean()))
            cells.append("%.1f ± %.1f" % (x.mean(), x.std(ddof=1)))
    print("| ours (%s) | %s |" % ("default" if fixed else "held-out", " | ".join(cells)))
    weighted = []
    for v in VARIANTS:
        for col in (2, 3):
            x = 100 * np.array([held[(n, v)][1][col] for n in MAPS])
            weighted.append("%.1f ± %.1f" % (x.mean(), x.std(ddof=1)))
    print("| ours, area-weighted | %s |" % " | ".join(weighted))
    for name, figures in PAPER:
        print("| paper: %s | %s |" % (name, " | ".join("%.1f" % f for f in figures)))
    seconds = [held[key][1][6] for key in held]
    print("\nseconds per map: mean %.1f, max %.1f" % (np.mean(seconds), np.max(seconds)))
    print("BENCH rooms recall=%.1f precision=%.1f recall_furn=%.1f precision_furn=%.1f" % tuple(means))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
