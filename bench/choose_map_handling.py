#!/usr/bin/env python3
"""Choose the map-handling defaults (sim/solidmap.MapHandling: ``close_gaps``, ``speckle``,
``unknown_slivers``) by leaving each corpus building out in turn.

The corpus buildings built from SLAM-corrected CARMEN logs (worlds/corpus.yaml, ``make
corpus``) come with what a real robot did in them: where it drove and what its laser read
there. For each candidate handling and building:

* ``reach``: the share of the logged path (a pose every metre) that one part of the floor
  holds for the simulated robot's footprint (nav/grid.PlanningGrid with the handling, its
  parts 4-connected as the planner's A* joins them; a pose counts within 0.3 m of a free
  cell): the real robot drove there, so the simulated one must be able to;
* ``scan``: the share of the logged beams (ranges under 30 m, the Scitos lidar's) that a ray
  marched through the solid cells (sim/solidmap.solid_map, what the simulator extrudes)
  from the logged laser pose meets within 0.15 m of the logged range: the simulated lidar
  sees what the real one saw.

The score is their mean. Each fold picks the candidate with the best mean score on the
other buildings (ties: the one that changes the map least) and is scored on the building
left out. ``unknown: free``
is not a candidate: it says what a map's unknown cells are, which only its user knows.

    .venv/bin/python bench/choose_map_handling.py [--logs DIR] [--corpus DIR]
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
os.environ["BULLET_FLOOR_SIM_CACHE"] = ""   # candidates are not worth keeping on disk

from bullet_floor_sim.errors import ConfigError  # noqa: E402
from bullet_floor_sim.mapping.carmen import flaser_angles, read_flaser  # noqa: E402
from bullet_floor_sim.nav.grid import PlannerConfig, PlanningGrid  # noqa: E402
from bullet_floor_sim.paths import corpus_dir  # noqa: E402
from bullet_floor_sim.sim.floormap import load_map  # noqa: E402
from bullet_floor_sim.sim.solidmap import MapHandling, solid_map  # noqa: E402
from bullet_floor_sim.yamlio import read_yaml  # noqa: E402

MANIFEST = os.path.join(HERE, "..", "worlds", "corpus.yaml")
VALUES = {"close_gaps": (0.0, 0.05, 0.1, 0.15, 0.2),
          "speckle": (0.0, 0.005, 0.01, 0.02, 0.05),
          "unknown_slivers": (0.0, 0.1, 0.2, 0.3, 0.4, 0.6)}
RANGE_MAX, HIT_TOLERANCE, NEAR_FREE = 30.0, 0.15, 0.3


def candidates() -> list:
    """The current defaults first; every pair of ``close_gaps`` and ``speckle`` values (the
    two act on different cells, but both on what the lidar sees); ``unknown_slivers`` one
    value at a time."""
    base = MapHandling()
    out = [base]
    for gaps in VALUES["close_gaps"]:
        out += [dataclasses.replace(base, close_gaps=gaps, speckle=sp)
                for sp in VALUES["speckle"] if (gaps, sp) != (base.close_gaps, base.speckle)]
    out += [dataclasses.replace(base, unknown_slivers=v) for v in VALUES["unknown_slivers"]
            if v != base.unknown_slivers]
    return out


def logged(path: str, step: float = 1.0, most: int = 400):
    """(poses (N, 3), scans [(angles, ranges)]) a pose every ``step`` m of the log's path,
    at most ``most`` of them spread over it."""
    poses, scans, last = [], [], None
    for ranges, pose in read_flaser(path):
        if last is None or math.hypot(pose[0] - last[0], pose[1] - last[1]) >= step:
            a0, da = flaser_angles(len(ranges))
            poses.append(pose)
            scans.append((a0 + da * np.arange(len(ranges)), ranges))
            last = pose
    keep = np.linspace(0, len(poses) - 1, min(most, len(poses))).round().astype(int)
    return np.array(poses)[keep], [scans[i] for i in keep]


def reach(fmap, handling: MapHandling, poses: np.ndarray) -> float:
    """The share of ``poses`` in the one part of the robot's floor that holds most."""
    from scipy import ndimage

    grid = PlanningGrid(fmap, PlannerConfig(), handling=handling)
    free = np.isfinite(grid.cost)
    parts, _ = ndimage.label(free)
    dist, (ir, ic) = ndimage.distance_transform_edt(~free, return_indices=True)
    ids = []
    for x, y, _ in poses:
        c, r = grid.to_cell(float(x), float(y))
        inside = 0 <= r < free.shape[0] and 0 <= c < free.shape[1]
        ids.append(parts[ir[r, c], ic[r, c]] if inside and
                   dist[r, c] * grid.resolution <= NEAR_FREE else 0)
    ids = np.array(ids)
    return float(np.bincount(ids[ids > 0]).max() / len(ids)) if (ids > 0).any() else 0.0


def scan_agreement(fmap, handling: MapHandling, poses: np.ndarray, scans) -> float:
    """The share of logged beams under RANGE_MAX that a ray through the solid cells meets
    within HIT_TOLERANCE of the logged range."""
    solid = np.asarray(solid_map(fmap, handling).fmap.grid) == 100
    res, (ox, oy) = fmap.resolution, (float(fmap.origin[0]), float(fmap.origin[1]))
    t = np.arange(0.05, RANGE_MAX + HIT_TOLERANCE, res / 2.0)
    hits = total = 0
    for (x, y, th), (angles, ranges) in zip(poses, scans):
        ok = ranges < RANGE_MAX
        if not ok.any():
            continue
        a = th + angles[ok]
        cols = np.floor((x + np.outer(np.cos(a), t) - ox) / res).astype(int)
        rows = np.floor((y + np.outer(np.sin(a), t) - oy) / res).astype(int)
        inside = (rows >= 0) & (rows < solid.shape[0]) & (cols >= 0) & (cols < solid.shape[1])
        blocked = np.zeros(rows.shape, dtype=bool)
        blocked[inside] = solid[rows[inside], cols[inside]]
        first = np.where(blocked.any(axis=1), t[np.argmax(blocked, axis=1)], np.inf)
        hits += int(np.count_nonzero(np.abs(first - ranges[ok]) <= HIT_TOLERANCE))
        total += int(np.count_nonzero(ok))
    return hits / total if total else 0.0


def change(h: MapHandling) -> float:
    """How far a candidate is from handling nothing (ties go to the least)."""
    return h.close_gaps + 10.0 * h.speckle + h.unknown_slivers


def label(h: MapHandling) -> str:
    return "close_gaps %g, speckle %g, unknown_slivers %g" % (h.close_gaps, h.speckle,
                                                             h.unknown_slivers)


def buildings(logs: str, corpus: str, only=None) -> list:
    """(name, map yaml, log path) of each CARMEN-built corpus building that is built here."""
    out = []
    for e in read_yaml(MANIFEST, "corpus manifest", ConfigError)["worlds"]:
        if e.get("format") != "carmen" or (only and e["name"] not in only):
            continue
        log = os.path.join(logs, os.path.basename(e["files"][0]["url"]))
        yaml = os.path.join(corpus, e["name"], "map.yaml")
        if os.path.isfile(log) and os.path.isfile(yaml):
            out.append((e["name"], yaml, log))
        else:
            print("note: %s left out: %s" % (e["name"], "no log %s" % log if not
                                             os.path.isfile(log) else "not built (make corpus)"),
                  file=sys.stderr)
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--corpus", default=None, help="the built corpus (default: make corpus's)")
    p.add_argument("--logs", default=None, help="the CARMEN logs (default: CORPUS/.downloads)")
    p.add_argument("--only", nargs="*", default=None, help="these buildings only")
    args = p.parse_args()
    corpus = args.corpus or corpus_dir()
    found = buildings(args.logs or os.path.join(corpus, ".downloads"), corpus, args.only)
    if len(found) < (1 if args.only else 3):
        print("choose_map_handling: %d CARMEN-built buildings found; at least 3 are needed "
              "(make corpus)" % len(found), file=sys.stderr)
        return 1
    cands = candidates()
    score = np.zeros((len(found), len(cands), 2))
    for i, (name, yaml, log) in enumerate(found):
        t0 = time.time()
        fmap = load_map(yaml)
        poses, scans = logged(log)
        for j, h in enumerate(cands):
            score[i, j] = reach(fmap, h, poses), scan_agreement(fmap, h, poses, scans)
        print("%s: %d poses, %d candidates in %.0f s" % (name, len(poses), len(cands),
                                                         time.time() - t0),
              file=sys.stderr, flush=True)
    total = score.mean(axis=2)
    print("| left out | chosen on the others | reach | scan | score | default's score |")
    print("|---|---|---|---|---|---|")
    for i, (name, _, _) in enumerate(found):
        rest = np.delete(total, i, axis=0).mean(axis=0)
        best = max(range(len(cands)), key=lambda j: (round(rest[j], 6), -change(cands[j])))
        print("| %s | %s | %.3f | %.3f | %.3f | %.3f |" % (
            name, label(cands[best]), score[i, best, 0], score[i, best, 1], total[i, best],
            total[i, 0]))
    print("\nper candidate, the mean over all buildings (reach, scan, score):")
    for j, h in enumerate(cands):
        print("  %s: %.4f %.4f %.4f" % (label(h), score[:, j, 0].mean(), score[:, j, 1].mean(),
                                        total[:, j].mean()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
