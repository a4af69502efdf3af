"""ros/packed_markers.py writes the bytes genpy writes for the same MarkerArray, and rospy
sends them as such; its time colours are colorsys's."""
from __future__ import annotations

import colorsys
import io

import numpy as np
import pytest

rospy = pytest.importorskip("rospy")
from geometry_msgs.msg import Point, Pose, Quaternion  # noqa: E402
from std_msgs.msg import ColorRGBA, Header  # noqa: E402
from visualization_msgs.msg import Marker, MarkerArray  # noqa: E402

from bullet_floor_sim.ros.packed_markers import (PackedMarkerArray, pack_marker,  # noqa: E402
                                                 time_colours)


def _genpy(msg) -> bytes:
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def _marker(rng, k: int, text: str = "", mesh: str = "", embedded: bool = False) -> Marker:
    header = Header(11, rospy.Time(1234, 5678), "map")
    m = Marker(header=header, ns="trajectories", id=k, type=Marker.LINE_STRIP,
               action=Marker.ADD, pose=Pose(orientation=Quaternion(0, 0, 0.6, 0.8)))
    m.scale.x = float(rng.uniform(0.01, 1.0))
    m.color = ColorRGBA(*rng.uniform(0, 1, 4))
    m.lifetime = rospy.Duration(3, 14)
    m.frame_locked = bool(k % 2)
    m.text, m.mesh_resource, m.mesh_use_embedded_materials = text, mesh, embedded
    return m


@pytest.mark.parametrize("n_points, with_colours", [(0, False), (1, True), (500, True),
                                                    (37, False)])
def test_marker_bytes_are_genpys(n_points, with_colours):
    rng = np.random.default_rng(n_points)
    xyz = rng.normal(0.0, 30.0, (n_points, 3))
    rgba = rng.uniform(0.0, 1.0, (n_points, 4)) if with_colours else None
    m = _marker(rng, n_points, text="a-uuid é", mesh="package://x/y.dae", embedded=True)
    packed = pack_marker(m, xyz, rgba)
    assert m.points == [] and m.text == "a-uuid é" and m.mesh_use_embedded_materials
    m.points = [Point(*p) for p in xyz]
    if rgba is not None:
        m.colors = [ColorRGBA(*c) for c in rgba]
    assert packed == _genpy(m)


def test_array_bytes_and_what_a_subscriber_reads():
    rng = np.random.default_rng(3)
    parts, plain = [], MarkerArray()
    delete = Marker(header=Header(0, rospy.Time(9, 1), "map"), ns="t", action=Marker.DELETEALL)
    parts.append(pack_marker(delete))
    plain.markers.append(delete)
    for k in range(4):
        xyz = rng.uniform(-5, 5, (10 + k, 3))
        m = _marker(rng, k, text="t%d" % k)
        parts.append(pack_marker(m, xyz))
        m.points = [Point(*p) for p in xyz]
        plain.markers.append(m)
    packed = PackedMarkerArray(parts)
    assert _genpy(packed) == _genpy(plain)
    assert packed._type == MarkerArray._type and packed._md5sum == MarkerArray._md5sum
    # what rospy puts on the wire (length, then the message), read back as a subscriber does
    from rospy.msg import serialize_message
    wire = io.BytesIO()
    serialize_message(wire, 1, packed)
    back = MarkerArray()
    back.deserialize(wire.getvalue()[4:])
    assert len(back.markers) == 5 and back.markers[0].action == Marker.DELETEALL
    assert [len(m.points) for m in back.markers[1:]] == [10, 11, 12, 13]
    assert back.markers[4].points[12].x == plain.markers[4].points[12].x
    assert back.markers[2].text == "t1"


def test_refuses_points_in_the_marker_and_bad_shapes():
    m = _marker(np.random.default_rng(0), 1)
    with pytest.raises(ValueError, match="(n, 3)"):
        pack_marker(m, np.zeros((4, 2)))
    m.points = [Point(1, 2, 3)]
    with pytest.raises(ValueError, match="arrays"):
        pack_marker(m, np.zeros((1, 3)))


def test_time_colours_are_colorsys():
    f = np.concatenate([np.linspace(-0.5, 1.5, 2001), np.random.default_rng(1).uniform(0, 1, 5000),
                        [k / 6.0 / 0.66 for k in range(7)], [1.0 - k / 6.0 / 0.66 for k in range(7)]])
    got = time_colours(f)
    for fi, row in zip(f, got):
        want = colorsys.hsv_to_rgb(0.66 * (1.0 - min(max(fi, 0.0), 1.0)), 1.0, 1.0)
        assert tuple(row[:3]) == want and row[3] == 1.0
    newest, oldest = time_colours(np.array([1.0, 0.0]))
    assert tuple(newest) == (1.0, 0.0, 0.0, 1.0)                 # red
    assert oldest[0] == 0.0 and oldest[2] == 1.0 and oldest[1] == pytest.approx(0.04)  # blue
