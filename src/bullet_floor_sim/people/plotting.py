"""matplotlib for the PNG writers (headless Agg backend), with a one-line error when missing."""
from __future__ import annotations

from typing import Any, Tuple

from ..errors import BulletFloorSimError

__all__ = ["pyplot", "draw_map", "shade", "save_figure"]


def pyplot(what: str) -> Any:
    """``matplotlib.pyplot`` on the Agg backend.

    Args:
        what: the option or command that needs it, for the error (e.g. ``--plot``).

    Raises:
        BulletFloorSimError: matplotlib is not installed.
    """
    try:
        import matplotlib
    except ImportError:
        raise BulletFloorSimError("%s needs matplotlib, which is not installed "
                                  "(apt install python3-matplotlib)" % what) from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def shade(grid: Any) -> Any:
    """A trinary map grid as grey levels: walls black, free white, unknown grey."""
    import numpy as np

    g = np.asarray(grid)
    return np.where(g == 100, 0.0, np.where(g == 0, 1.0, 0.8))


def draw_map(ax: Any, fmap: Any) -> Tuple[float, float, float, float]:
    """Draw a floor map on matplotlib axes in map coordinates (walls black, free white,
    unknown grey, rotated by the origin's yaw) and return its unrotated extent
    (x0, x1, y0, y1)."""
    from matplotlib.transforms import Affine2D

    ox, oy, yaw = fmap.origin
    w, h = fmap.width * fmap.resolution, fmap.height * fmap.resolution
    ax.imshow(shade(fmap.grid), cmap="gray", vmin=0.0, vmax=1.0, origin="lower",
              extent=(ox, ox + w, oy, oy + h), interpolation="nearest",
              transform=Affine2D().rotate_around(ox, oy, yaw) + ax.transData)
    return ox, ox + w, oy, oy + h


def save_figure(plt: Any, fig: Any, path: str, title: str, fontsize: int = 9) -> None:
    """Title, lay out and write a figure as ``--plot PATH`` asks, then close it.

    Raises:
        BulletFloorSimError: the file cannot be written.
    """
    try:
        fig.suptitle(title, fontsize=fontsize)
        # the title's lines (and a little room) kept clear of the panels' own titles
        top = (1.2 * (title.count("\n") + 1) + 1.0) * fontsize / 72.0 / fig.get_figheight()
        fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - top))
        fig.savefig(path, dpi=110)
    except OSError as e:
        raise BulletFloorSimError("--plot %s: cannot write it: %s" % (path, e)) from None
    finally:
        plt.close(fig)
