#!/usr/bin/env python3
"""The map check (check_world) of every shipped building and every corpus building built,
as one markdown table and one picture (``--plot PNG``: each building's robot panel).

    .venv/bin/python bench/corpus_report.py --plot docs/img/corpus_check.png
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, HERE)

from bullet_floor_sim.building import Building  # noqa: E402
from bullet_floor_sim.building.check import check_building, study_problems  # noqa: E402
from bullet_floor_sim.sim.config import world_label  # noqa: E402
from eval_worlds import shipped  # noqa: E402


HEADER = ("building", "size (m)", "floor not solid (m²)", "robot1's part of the robot's floor",
          "regions", "reached by robot1", "reached by robot2", "reached by a person",
          "narrowest passage between regions (robot)", "map handling changed", "study", "check")


def _reached(fc, name: str) -> str:
    """How many regions the start ``name`` of a footprint's check reaches ("-": no such)."""
    s = next((s for s in fc.starts if s.name == name), None)
    return "-" if s is None else "%d" % len(s.reachable)


def row(world: str) -> tuple:
    """(building, its check, the table cells: :data:`HEADER`)."""
    t0 = time.time()
    b = Building.load(world)
    rep = check_building(b)
    robot, person = rep.footprint("robot"), rep.footprint("person")
    r1 = robot.starts[0]
    names = [r.name for r in b.config.robots]
    problems = study_problems(rep, names[0], names[1] if len(names) > 1 else None)
    ways = [p for p in robot.passages if p.at is not None and not p.no_route]
    narrow = min(ways, key=lambda p: p.width) if ways else None
    cells = [world_label(world), "%.0f x %.0f" % (b.fmap.width * b.fmap.resolution,
                                                  b.fmap.height * b.fmap.resolution),
             "%.0f" % rep.free, "%.0f %%" % (100 * r1.share), "%d" % len(rep.regions),
             "%d" % len(r1.reachable),
             _reached(robot, names[1]) if len(names) > 1 else "-",
             "%d" % max((len(s.reachable) for s in person.starts), default=0),
             "-" if narrow is None else "%.2f m" % narrow.width,
             "; ".join(rep.handling) or "nothing",
             "ok" if not problems else "refuses", "%.0f s" % (time.time() - t0)]
    return b, rep, cells


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--worlds", nargs="*", default=None)
    ap.add_argument("--plot", default=None)
    args = ap.parse_args()
    print("| " + " | ".join(HEADER) + " |")
    print("|" + "---|" * len(HEADER))
    rows = []
    for w in args.worlds or shipped():
        rows.append(row(w))
        print("| " + " | ".join(rows[-1][2]) + " |", flush=True)
    if args.plot:
        montage(rows, args.plot)
        print("plot: %s" % args.plot)
    return 0


def montage(rows: list, path: str) -> None:
    """The robot panel of each building's check, in a grid."""
    from bullet_floor_sim.building.plot import floor_box, draw_panel
    from bullet_floor_sim.people.plotting import pyplot, save_figure

    plt = pyplot("--plot")
    n = len(rows)
    cols = min(4, n)
    nrows = math.ceil(n / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(4.2 * cols, 4.2 * nrows), squeeze=False)
    for ax, (b, rep, cells) in zip(axes.ravel(), rows):
        draw_panel(ax, b, rep, rep.footprint("robot"))
        x0, x1, y0, y1 = floor_box(b)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_title("%s: %s reached, %s" % (cells[0], cells[3], cells[HEADER.index("study")]),
                     fontsize=8)
        ax.tick_params(labelsize=6)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    save_figure(plt, fig, path, "check_world on every building (robot footprint): green "
                "connected to robot1, orange cut off,\nmagenta cleared and blue closed by the "
                "map handling, regions outlined, passage widths in m", 10)


if __name__ == "__main__":
    sys.exit(main())
