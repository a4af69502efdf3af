"""``rosrun bullet_floor_sim compare_maps BUILT.yaml --world WORLD [--robot NAME] [--plot PNG]``:
score a map built by mapping.launch (saved with save_map or map_saver) against the world's.

The built map's frame is where the mapping robot started (gmapping's and the embedded
mapper's ``map`` is the odometry origin), so it is placed at that robot's spawn pose in the
world (``--robot``, default the world's first robot). Prints the free and occupied IoU, the
occupied F1 within a cell and the share of the reachable free space mapped
(mapping/compare.py). ``--plot`` draws the world's map, the built one in the world's frame,
and where they agree and differ.
"""
from __future__ import annotations

import sys
from typing import Any, List, Optional

import numpy as np

from ..errors import BulletFloorSimError
from .cli import Parser, UsageError

__all__ = ["main", "plot"]


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point; 0 on success, 2 on any error (one line on stderr)."""
    p = Parser(prog="compare_maps", description=__doc__.split("\n\n")[1])
    p.add_argument("built", help="the built map's map_server YAML")
    p.add_argument("--world", required=True, help="world name under worlds/ or a world.yaml")
    p.add_argument("--robot", help="the robot that mapped (default: the world's first)")
    p.add_argument("--plot", metavar="PNG", help="draw both maps and their agreement")
    try:
        args = p.parse_args(sys.argv[1:] if argv is None else argv)
        from ..mapping.compare import agreement, reachable
        from ..paths import worlds_dir
        from ..sim.config import load_world_config, resolve_world
        from ..sim.floormap import load_map

        cfg = load_world_config(resolve_world(args.world, worlds_dir()))
        robots = {r.name: r for r in cfg.robots}
        if args.robot is not None and args.robot not in robots:
            raise UsageError("--robot %s: the world has %s" % (args.robot, ", ".join(robots)))
        spec = robots[args.robot] if args.robot else cfg.robots[0]
        world, built = load_map(cfg.map_yaml), load_map(args.built)
        frame = tuple(float(v) for v in spec.pose)
        region = reachable(world, frame[0], frame[1])
        a = agreement(built, world, frame, region)
        if args.plot:
            plot(built, world, frame, region, args.plot,
                 "%s against %s (%s's start): %s" % (args.built, args.world, spec.name,
                                                      a.line()))
    except (UsageError, BulletFloorSimError, ValueError) as e:
        print("compare_maps: %s" % e, file=sys.stderr)
        return 2
    print("compare_maps: %s" % a.line())
    return 0


def plot(built: Any, world: Any, frame: Any, region: np.ndarray, path: str, title: str) -> None:
    """Three panels: the world's map, the built map in the world's frame (both shaded as
    people/plotting.draw_map shades a map), and their
    agreement (white: free in both; black: a wall face both have, within a cell; red: a
    face the built map lacks; blue: built occupied where the world has no wall near; grey:
    free in the world, unknown in the built map)."""
    from scipy.ndimage import binary_dilation

    from ..mapping.compare import sample
    from ..people.plotting import pyplot, save_figure, shade

    plt = pyplot("--plot")
    ours, truth = sample(built, world, frame), np.asarray(world.grid)
    faces = (truth == 100) & binary_dilation(region, structure=np.ones((3, 3), dtype=bool))
    near_wall = binary_dilation(truth == 100)
    near_ours = binary_dilation(ours == 100)
    rgb = np.full(truth.shape + (3,), 0.85)
    rgb[region & (ours != 0)] = (0.6, 0.6, 0.6)
    rgb[region & (ours == 0)] = (1.0, 1.0, 1.0)
    rgb[faces & ~near_ours] = (0.85, 0.1, 0.1)
    rgb[faces & near_ours] = (0.0, 0.0, 0.0)
    rgb[(ours == 100) & ~near_wall] = (0.1, 0.3, 0.9)
    fig, axes = plt.subplots(1, 3, figsize=(18, 1.0 + 6.0 * truth.shape[0] / truth.shape[1]))
    try:
        for ax, img, name in zip(axes, (shade(truth), shade(ours), rgb),
                                 ("the world's map", "the built map", "agreement")):
            ax.imshow(img, cmap="gray", vmin=0.0, vmax=1.0, origin="lower",
                      interpolation="nearest")
            ax.set_title(name)
            ax.set_xticks([])
            ax.set_yticks([])
    except BaseException:
        plt.close(fig)
        raise
    save_figure(plt, fig, path, title)


if __name__ == "__main__":
    sys.exit(main())
