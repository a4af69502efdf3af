"""The static walls: Bullet meshes of the solid cells' outline, and the clearance field that
tells which robots could touch them soon."""
from __future__ import annotations

import math
from typing import Any, List

import numpy as np

from ..errors import MapError
from .floormap import outline_segments, wall_mesh, wall_outline_mesh
from .solidmap import SolidMap

__all__ = ["build_walls", "clearance_field"]

#: PyBullet accepts at most 131072 vertices per mesh shape (B3_MAX_NUM_VERTICES): 8 per
#: wall box, 4 per outline quad.
_MAX_MESH_RECTS, _MAX_MESH_QUADS = 16000, 32000


def build_walls(client: Any, solid_map: SolidMap, height: float, gui: bool,
                where: str) -> List[int]:
    """The static wall bodies: collision meshes of the solid cells' outline (what rays
    and robots meet); with the GUI, visual-only boxes of the merged rectangles too."""
    p = client
    solid = solid_map.fmap
    segments = outline_segments(solid.occupied)
    bodies = []
    for s in range(0, len(segments), _MAX_MESH_QUADS):
        verts, idx = wall_outline_mesh(solid, height, segments[s:s + _MAX_MESH_QUADS])
        col = _mesh_shape(p, where, p.createCollisionShape, verts, idx,
                          flags=p.GEOM_FORCE_CONCAVE_TRIMESH)
        bodies.append(p.createMultiBody(baseMass=0, baseCollisionShapeIndex=col))
    rects = solid.rectangles() if gui else []
    for s in range(0, len(rects), _MAX_MESH_RECTS):
        verts, idx = wall_mesh(solid, height, rects[s:s + _MAX_MESH_RECTS])
        vis = _mesh_shape(p, where, p.createVisualShape, verts, idx,
                          rgbaColor=[0.75, 0.75, 0.72, 1.0])
        p.createMultiBody(baseMass=0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=vis)
    return bodies


def _mesh_shape(client: Any, where: str, create: Any, verts: np.ndarray, idx: np.ndarray,
                **kw: Any) -> int:
    try:
        return create(client.GEOM_MESH, vertices=verts, indices=idx, **kw)
    except client.error as e:
        raise MapError("%s: PyBullet refused the wall mesh (%d vertices): %s"
                       % (where, len(verts), e)) from None


def clearance_field(solid_map: SolidMap) -> np.ndarray:
    """Lower bound of the distance (m) from each cell's points to the nearest wall."""
    assert solid_map.distance is not None   # solid_map's answer always has it
    res = solid_map.fmap.resolution
    return solid_map.distance.astype(float) * res - res * math.sqrt(2.0)
