"""visualization_msgs/MarkerArray packed straight to the wire, for markers with many points.

genpy builds a ``geometry_msgs/Point`` and a ``std_msgs/ColorRGBA`` object per point and packs
each one on its own: about 5 us a point, half a second for the trajectory viewer's 100 000
poses. Here a marker's points (float64 x, y, z) and colours (float32 r, g, b, a) are numpy
arrays written in one go, and the rest of the marker is genpy's own bytes. rospy publishes a
:class:`PackedMarkerArray` as any MarkerArray (same type and md5sum: the subscriber cannot
tell); test_packed_markers.py checks the bytes against genpy's serialisation of the same
markers.
"""
from __future__ import annotations

import io
import struct
from typing import Optional, Sequence

import numpy as np

from visualization_msgs.msg import Marker, MarkerArray

__all__ = ["PackedMarkerArray", "pack_marker", "time_colours"]

_U32 = struct.Struct("<I")
# a Marker ends with points[], colors[], text, mesh_resource (each a uint32 length, here 0)
# and mesh_use_embedded_materials (one byte)
_EMPTY_TAIL = 4 + 4 + 4 + 4 + 1


def _string(text: str) -> bytes:
    raw = text.encode("utf-8")
    return _U32.pack(len(raw)) + raw


def pack_marker(marker: Marker, points: Optional[np.ndarray] = None,
                colors: Optional[np.ndarray] = None) -> bytes:
    """The serialised ``marker`` with ``points`` ((n, 3) x, y, z) and ``colors`` ((n, 4) r, g,
    b, a; None: none) in place of its own ``points`` and ``colors``, which must be empty.

    Raises:
        ValueError: the marker has points or colours of its own, or an array has the wrong
            shape.
    """
    if marker.points or marker.colors:
        raise ValueError("pack_marker: give the points and colours as arrays, not in the marker")
    pts = np.ascontiguousarray(np.zeros((0, 3)) if points is None else points, dtype="<f8")
    cols = np.ascontiguousarray(np.zeros((0, 4)) if colors is None else colors, dtype="<f4")
    if pts.ndim != 2 or pts.shape[1] != 3 or cols.ndim != 2 or cols.shape[1] != 4:
        raise ValueError("pack_marker: points must be (n, 3) and colors (n, 4), not %s and %s"
                         % (pts.shape, cols.shape))
    text, mesh, embedded = marker.text, marker.mesh_resource, marker.mesh_use_embedded_materials
    marker.text, marker.mesh_resource, marker.mesh_use_embedded_materials = "", "", False
    buf = io.BytesIO()
    try:
        marker.serialize(buf)
    finally:
        marker.text, marker.mesh_resource, marker.mesh_use_embedded_materials = \
            text, mesh, embedded
    head = buf.getvalue()[:-_EMPTY_TAIL]
    return b"".join((head, _U32.pack(len(pts)), pts.tobytes(), _U32.pack(len(cols)),
                     cols.tobytes(), _string(text), _string(mesh),
                     b"\x01" if embedded else b"\x00"))


class PackedMarkerArray(MarkerArray):
    """A MarkerArray of markers packed by :func:`pack_marker`: what rospy sends is those bytes.
    Its ``markers`` list stays empty (the markers exist only as bytes)."""

    __slots__ = ("packed",)

    def __init__(self, packed: Sequence[bytes]) -> None:
        super().__init__()
        self.packed = _U32.pack(len(packed)) + b"".join(packed)

    def serialize(self, buff) -> None:
        buff.write(self.packed)


def time_colours(f: np.ndarray) -> np.ndarray:
    """(n, 4) colours for times ``f`` in [0, 1] (clipped): blue (0, oldest) through green to
    red (1, newest), fully opaque; colorsys.hsv_to_rgb(0.66 (1 - f), 1, 1), the same floats."""
    h6 = 0.66 * (1.0 - np.clip(np.asarray(f, dtype=float), 0.0, 1.0)) * 6.0
    i = h6.astype(int)                   # 0..3: the hue stays at or below 0.66
    frac = h6 - i
    q, t = 1.0 - frac, 1.0 - (1.0 - frac)    # colorsys's q and t with s = v = 1
    one, zero = np.ones_like(h6), np.zeros_like(h6)
    r = np.select([i == 0, i == 1], [one, q], zero)
    g = np.select([i == 0, i == 3], [t, q], one)
    b = np.select([i == 2, i == 3], [t, one], zero)
    return np.stack([r, g, b, one], axis=1)
