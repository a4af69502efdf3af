"""The picture ``trajectories plot`` draws: every trajectory (one colour each) and an
occupancy heat-map (the share of poses per cell) over the map image."""
from __future__ import annotations

import os
from typing import Optional, Sequence

from ..errors import BulletFloorSimError
from ..people.plotting import draw_map, pyplot
from ..data.trajectory import Chunk, join_chunks

__all__ = ["map_for_plot", "plot_trajectories"]


def map_for_plot(map_yaml: Optional[str], world: Optional[str], map_name: str = ""):
    """The FloorMap to draw under the trajectories: ``map_yaml``, else the map of ``world``,
    else of the shipped world named ``map_name`` when there is one; None: no map."""
    from ..sim.config import load_world_config, resolve_world
    from ..sim.floormap import load_map
    from ..paths import worlds_dir

    if map_yaml:
        return load_map(map_yaml)
    if not world and map_name and os.path.isfile(
            os.path.join(worlds_dir(), map_name, "world.yaml")):
        world = map_name
    if not world:
        return None
    return load_map(load_world_config(resolve_world(world, worlds_dir())).map_yaml)


def plot_trajectories(chunks: Sequence[Chunk], path: str, fmap=None, cell: float = 0.25) -> int:
    """Draw the trajectories (joined from ``chunks``) and the pose heat-map to a PNG.

    Args:
        chunks: stored chunks.
        path: PNG file to write.
        fmap: optional FloorMap drawn underneath.
        cell: heat-map cell size, metres.

    Returns:
        How many trajectories were drawn.

    Raises:
        BulletFloorSimError: matplotlib is missing or the file cannot be written.
    """
    plt = pyplot("plot")
    import numpy as np

    joined = join_chunks(chunks)
    fig, ax = plt.subplots(figsize=(12, 9))
    try:
        bounds = draw_map(ax, fmap) if fmap is not None else None
        xy = np.array([(p[1], p[2]) for j in joined for p in j.poses], dtype=float)
        if len(xy):
            x0, x1, y0, y1 = bounds or (xy[:, 0].min(), xy[:, 0].max(), xy[:, 1].min(),
                                        xy[:, 1].max())
            nx = max(1, int(np.ceil((x1 - x0) / cell)))
            ny = max(1, int(np.ceil((y1 - y0) / cell)))
            hist, _, _ = np.histogram2d(xy[:, 0], xy[:, 1], bins=(nx, ny),
                                        range=((x0, x0 + nx * cell), (y0, y0 + ny * cell)))
            share = np.ma.masked_equal(hist.T / len(xy), 0.0)
            im = ax.imshow(share, origin="lower", cmap="inferno", alpha=0.6,
                           extent=(x0, x0 + nx * cell, y0, y0 + ny * cell),
                           interpolation="nearest")
            fig.colorbar(im, ax=ax, fraction=0.03, label="share of poses per %.2f m cell"
                         % cell)
        palette = plt.get_cmap("tab10")
        for k, j in enumerate(joined):
            ax.plot([p[1] for p in j.poses], [p[2] for p in j.poses], linewidth=0.8,
                    color=palette(k % 10), alpha=0.8)
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_xlabel("x (m, map frame)")
        ax.set_ylabel("y (m)")
        ax.set_title("%d trajectories, %d poses" % (len(joined), sum(len(j.poses)
                                                                      for j in joined)))
        try:
            fig.savefig(path, dpi=120, bbox_inches="tight")
        except OSError as e:
            raise BulletFloorSimError("%s: cannot write the plot: %s"
                                      % (path, e.strerror or e)) from None
    finally:
        plt.close(fig)
    return len(joined)
