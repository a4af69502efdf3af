"""``rosrun bullet_floor_sim check_world WORLD [--plot PNG] [--write-cleaned NAME]``: what the
robots and people can reach on a world's floor, before a study runs on it.

Reports, for the robot's footprint (the planner's robot_radius) and a person's: the floor
each can plan on and the share connected to each start, the regions reached and cut off,
the narrowest passage on the route between each pair of neighbouring regions, what each
map-handling rule changed, the regions' sizes, and warnings: a robot that starts closer to a
wall than the footprint's radius, one region over half of the regions' area
(building/check.py). Then the
study's verdict for the walker (the
first robot) and the observer (the second): ``study: ok`` or ``study: would refuse: ...``.
``--write-cleaned NAME`` writes the map with the handling's changes made (NAME.pgm,
NAME.yaml) for map_server, so that amcl and move_base see the building the simulator does.

Exit status: 0 when a study could run, 1 when it would refuse, 2 on a bad world or option.
"""
from __future__ import annotations

import sys
from typing import List, Optional

from ..errors import BulletFloorSimError
from .cli import Parser, UsageError

__all__ = ["main"]


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point (see the module doc)."""
    p = Parser(prog="check_world", description=__doc__.split("\n\n")[0])
    p.add_argument("world", help="world name under worlds/ or a world.yaml path")
    p.add_argument("--plot", metavar="PNG", help="draw the check on the map")
    p.add_argument("--write-cleaned", metavar="NAME",
                   help="write the cleaned map as NAME.pgm and NAME.yaml")
    try:
        args = p.parse_args(sys.argv[1:] if argv is None else argv)
        from ..building import Building
        from ..building.check import FIXES, check_building, world_study_problems

        b = Building.load(args.world)
        report = check_building(b)
        for line in report.lines():
            print(line)
        problems = world_study_problems(report, b.config)
        if args.plot:
            from ..building.plot import plot_check

            plot_check(b, report, args.plot)
            print("plot: %s" % args.plot)
        if args.write_cleaned:
            from ..mapping.save import save_map
            from ..sim.solidmap import cleaned_map

            _, yml = save_map(cleaned_map(b.fmap, b.config.map_handling), args.write_cleaned)
            print("cleaned map: %s (serve it with map_server, or serve_cleaned:=true)" % yml)
    except (UsageError, BulletFloorSimError) as e:
        print("check_world: %s" % e, file=sys.stderr)
        return 2
    if problems:
        print("study: would refuse: %s. Fixes to try: %s" % ("; ".join(problems),
                                                               "; ".join(FIXES)))
        return 1
    print("study: ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
