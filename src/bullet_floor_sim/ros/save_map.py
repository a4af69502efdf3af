"""``rosrun bullet_floor_sim save_map [-f NAME] [--topic /map] [--timeout S]``: save the map
being built, as ``rosrun map_server map_saver -f NAME`` does where map_server is installed.

Waits for one nav_msgs/OccupancyGrid on the map topic (latched by the simulator, map_server,
gmapping, slam_toolbox or the embedded mapper), then writes ``NAME.pgm`` and ``NAME.yaml`` in
map_saver's layout (mapping/save.py): ``load_map``, map_server and a world.yaml's ``map:``
read them back. The default NAME is ``map`` in the current directory.
"""
from __future__ import annotations

import sys
from typing import List, Optional

from ..errors import BulletFloorSimError
from .cli import Parser, UsageError

__all__ = ["main"]


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point; 0 on success, 2 on any error (one line on stderr)."""
    p = Parser(prog="save_map", description=__doc__.split("\n\n")[1])
    p.add_argument("-f", dest="name", default="map", help="file name without extension (map)")
    p.add_argument("--topic", default="/map", help="the OccupancyGrid topic (/map)")
    p.add_argument("--timeout", type=float, default=30.0,
                   help="seconds to wait for a map (30)")
    args_in = [a for a in (sys.argv[1:] if argv is None else argv) if ":=" not in a]
    try:
        args = p.parse_args(args_in)
        import rospy
        from nav_msgs.msg import OccupancyGrid

        from ..mapping.save import save_map
        from .convert import grid_from_msg

        rospy.init_node("save_map", anonymous=True, disable_signals=True)
        try:
            msg = rospy.wait_for_message(args.topic, OccupancyGrid, timeout=args.timeout)
        except rospy.ROSException:
            raise UsageError("no map on %s within %g s (is a mapper or map_server running?)"
                             % (args.topic, args.timeout))
        fmap = grid_from_msg(msg)
        pgm, yml = save_map(fmap, args.name)
    except (UsageError, BulletFloorSimError) as e:
        print("save_map: %s" % e, file=sys.stderr)
        return 2
    print("save_map: %dx%d map at %.3f m/cell from %s to %s and %s"
          % (fmap.width, fmap.height, fmap.resolution, args.topic, yml, pgm), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
