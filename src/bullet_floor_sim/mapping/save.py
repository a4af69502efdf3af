"""A map saved as ``rosrun map_server map_saver`` saves it: ``<name>.pgm`` (binary P5, top row
first; occupied 0, free 254, unknown 205) and ``<name>.yaml`` (image, resolution, origin,
negate 0, occupied_thresh 0.65, free_thresh 0.196), map_saver's thresholds on the grid's
values (occupied from 65, free up to 25: map_server's defaults read back the same cells)."""
from __future__ import annotations

import os
from typing import Tuple

import numpy as np

from ..errors import MapError
from ..files import atomic_file
from ..sim.floormap import FloorMap

__all__ = ["save_map", "OCCUPIED_FROM", "FREE_UP_TO"]

#: map_saver's thresholds on the occupancy values (0..100; -1 unknown).
OCCUPIED_FROM = 65
FREE_UP_TO = 25


def save_map(fmap: FloorMap, name: str) -> Tuple[str, str]:
    """Write ``name``.pgm and ``name``.yaml; returns their paths.

    Raises:
        MapError: a file cannot be written (the message names it).
    """
    grid = np.asarray(fmap.grid)
    img = np.full(grid.shape, 205, dtype=np.uint8)
    img[(grid >= 0) & (grid <= FREE_UP_TO)] = 254
    img[grid >= OCCUPIED_FROM] = 0
    pgm, yml = name + ".pgm", name + ".yaml"
    h, w = img.shape
    ox, oy, yaw = fmap.origin
    try:
        d = os.path.dirname(os.path.abspath(pgm))
        os.makedirs(d, exist_ok=True)
        with atomic_file(pgm, "wb") as f:
            f.write(b"P5\n# CREATOR: bullet_floor_sim save_map %.3f m/pix\n%d %d\n255\n"
                    % (fmap.resolution, w, h))
            f.write(np.flipud(img).tobytes())
        with atomic_file(yml) as f:
            f.write("image: %s\nresolution: %f\norigin: [%f, %f, %f]\nnegate: 0\n"
                    "occupied_thresh: 0.65\nfree_thresh: 0.196\n\n"
                    % (os.path.basename(pgm), fmap.resolution, ox, oy, yaw))
    except OSError as e:
        raise MapError("save_map %s: cannot write (%s)" % (name, e.strerror or e)) from None
    return pgm, yml
