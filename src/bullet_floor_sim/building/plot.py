"""The map check drawn on the map (``check_world --plot``): one panel per footprint."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..data.rois import roi_polygon
from . import Building
from .check import WorldCheck

__all__ = ["plot_check", "draw_panel", "floor_box"]


def plot_check(b: Building, report: WorldCheck, path: str) -> None:
    """Write a PNG: for each footprint, the solid map (black), the floor connected to the
    starts (green) and the rest it could plan on (orange), what the map handling changed
    (magenta: occupied cells it cleared, blue: free cells it made solid), the regions
    (outlined green when reached, red when cut off, grey with no goal point), the starts, and
    each route's narrowest point with its width (red where the footprint cannot pass).

    Raises:
        BulletFloorSimError: matplotlib is missing or the file cannot be written.
    """
    from ..people.plotting import pyplot, save_figure

    plt = pyplot("--plot")
    n = len(report.footprints)
    x0, x1, y0, y1 = floor_box(b)
    wide = (x1 - x0) > 1.5 * (y1 - y0)   # wide maps: panels one above the other
    size = (12.0, 1.0 + n * 12.0 * (y1 - y0) / (x1 - x0)) if wide else \
        (7.0 * n, 1.2 + 7.0 * (y1 - y0) / (x1 - x0))
    fig, axes = plt.subplots(n if wide else 1, 1 if wide else n, figsize=size, squeeze=False)
    try:
        for ax, fc in zip(axes.ravel(), report.footprints):
            draw_panel(ax, b, report, fc)
            ax.set_xlim(x0, x1)
            ax.set_ylim(y0, y1)
    except BaseException:
        plt.close(fig)
        raise
    save_figure(plt, fig, path, "check_world %s" % report.world, 10)


def floor_box(b: Building, margin: float = 1.5):
    """The map-frame box (x0, x1, y0, y1) of the floor that is not solid, plus a margin."""
    rows, cols = np.nonzero(np.asarray(b.solid.fmap.grid) != 100)
    if not len(rows):
        x0, y0, x1, y1 = b.fmap.bounds()
        return x0, x1, y0, y1
    xs, ys = b.fmap.cell_to_world(np.array([cols.min(), cols.max()]),
                                  np.array([rows.min(), rows.max()]))
    return (float(min(xs)) - margin, float(max(xs)) + margin, float(min(ys)) - margin,
            float(max(ys)) + margin)


def draw_panel(ax: Any, b: Building, report: WorldCheck, fc: Any) -> None:
    """One footprint's check on matplotlib axes (see :func:`plot_check`)."""
    grid = b.grid(fc.footprint.radius)
    solid = np.asarray(b.solid.fmap.grid) == 100
    ox, oy, _ = b.fmap.origin
    ext = (ox, ox + b.fmap.width * b.fmap.resolution, oy, oy + b.fmap.height * b.fmap.resolution)
    rgb = np.ones(solid.shape + (3,))
    k = grid.factor
    passable = np.repeat(np.repeat(np.isfinite(grid.cost), k, 0), k, 1)[:solid.shape[0],
                                                                          :solid.shape[1]]
    reached = np.repeat(np.repeat(fc.component_mask, k, 0), k, 1)[:solid.shape[0],
                                                                   :solid.shape[1]]
    rgb[passable] = (1.0, 0.75, 0.45)
    rgb[reached] = (0.75, 0.93, 0.75)
    rgb[solid] = (0.0, 0.0, 0.0)
    raw = np.asarray(b.fmap.grid)
    rgb[(raw == 100) & ~solid] = (1.0, 0.0, 1.0)     # cleared: specks, thin clutter
    rgb[(raw == 0) & solid] = (0.2, 0.4, 1.0)        # made solid: gaps closed
    ax.imshow(rgb, origin="lower", extent=ext, interpolation="nearest")
    rois = {r.id: r for r in b.regions()[0]}
    reached_ids = {i for s in fc.starts for i in s.reachable}
    for i, roi in rois.items():
        colour = ("0.5" if i in fc.no_goal else "green" if i in reached_ids else "red")
        x, y = roi_polygon(roi).exterior.xy
        ax.plot(x, y, color=colour, lw=1.0)
        c = roi_polygon(roi).representative_point()
        ax.text(c.x, c.y, i, color=colour, fontsize=6, ha="center", va="center")
    for s in fc.starts:
        ax.plot(*s.xy, marker="*", ms=10, color="blue")
        ax.text(s.xy[0], s.xy[1], " " + s.name, color="blue", fontsize=7)
    for p in fc.passages:
        if p.at is None:
            continue
        bad = p.no_route
        if p.path is not None:
            ax.plot(p.path[:, 0], p.path[:, 1], color="red" if bad else "tab:blue", lw=0.5,
                    alpha=0.6)
        ax.plot(*p.at, marker="o", ms=3, color="red" if bad else "tab:blue")
        ax.text(p.at[0], p.at[1], "%.2f" % p.width, fontsize=5, color="red" if bad else "navy")
    ax.set_title("%s (radius %.2f m): green reached, orange cut off; magenta cleared, blue "
                 "closed by the map handling; passages in m"
                 % (fc.footprint.name, fc.footprint.radius), fontsize=8)
    ax.set_aspect("equal")
