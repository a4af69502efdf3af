"""rviz markers: the Markov chain (the walker publishes them on ``chain``) and the people
(the simulator, on ``/ground_truth/people_markers``)."""
from __future__ import annotations

import math
from typing import Any, Sequence

from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..data.rois import Roi
from ..people.markov import MarkovChain
from ..people.walker import anchor, region_label

__all__ = ["chain_markers", "people_markers"]


def chain_markers(chain: MarkovChain, rois: Sequence[Roi], frame_id: str, stamp: Any,
                  width_per_probability: float = 0.4) -> MarkerArray:
    """The chain for rviz: DELETEALL, then an arrow per transition i -> j (i != j) from region
    anchor to region anchor, shaft diameter ``width_per_probability * P(i -> j)`` (offset to
    its right so that i -> j and j -> i are both seen), and a label per region with P(stay).
    """
    by_id = {r.id: r for r in rois}
    anchors = {r: anchor(by_id[r]) for r in chain.ids}
    out = MarkerArray()
    clear = Marker()
    clear.header.frame_id = frame_id
    clear.header.stamp = stamp
    clear.action = Marker.DELETEALL
    out.markers.append(clear)
    n = 0
    for i in chain.ids:
        for j, p in chain.row(i).items():
            if j == i:
                continue
            (x0, y0), (x1, y1) = anchors[i], anchors[j]
            length = math.hypot(x1 - x0, y1 - y0)
            if length < 1e-6:
                continue
            ux, uy = (x1 - x0) / length, (y1 - y0) / length
            side = 0.15  # metres to the right of the line i -> j
            trim = min(0.5, 0.25 * length)
            m = _marker(frame_id, stamp, "chain_arrows", n, Marker.ARROW)
            m.points = [Point(x0 + ux * trim + uy * side, y0 + uy * trim - ux * side, 0.3),
                        Point(x1 - ux * trim + uy * side, y1 - uy * trim - ux * side, 0.3)]
            shaft = max(0.01, width_per_probability * p)
            m.scale.x, m.scale.y, m.scale.z = shaft, shaft + 0.15, 0.3
            m.color = ColorRGBA(1.0, 0.45, 0.0, 0.85)
            out.markers.append(m)
            n += 1
    for k, r in enumerate(chain.ids):
        m = _marker(frame_id, stamp, "chain_labels", k, Marker.TEXT_VIEW_FACING)
        m.pose.position.x, m.pose.position.y = anchors[r]
        m.pose.position.z = 0.8
        m.scale.z = 0.4
        m.color = ColorRGBA(1.0, 1.0, 1.0, 1.0)
        m.text = "%s\nstay %.2f" % (region_label(by_id[r]), chain.probability(r, r))
        out.markers.append(m)
    return out


def people_markers(truth: Sequence[Any], legs: Any, leg_radius: float, leg_height: float,
                   frame_id: str, stamp: Any) -> MarkerArray:
    """Each person as a figure: its two legs where the lidar sees them (cylinders up to
    ``leg_height``), a torso 0.5 m wide turned to its heading, a head, and a label with its
    name, the region it is in and the one it walks to. ``truth``: Crowd.ground_truth rows
    (with regions); ``legs``: Crowd.legs (2 rows per person). Ids are the person's number,
    so each update replaces the last."""
    out = MarkerArray()
    for k, t in enumerate(truth):
        color = _hue(t.track_id)
        for side in (0, 1):
            m = _marker(frame_id, stamp, "people_legs", 2 * k + side, Marker.CYLINDER)
            m.pose.position.x, m.pose.position.y = legs[2 * k + side]
            m.pose.position.z = 0.5 * leg_height
            m.scale.x = m.scale.y = 2.0 * leg_radius
            m.scale.z = leg_height
            m.color = color
            out.markers.append(m)
        m = _marker(frame_id, stamp, "people_torso", k, Marker.CYLINDER)
        m.pose.position.x, m.pose.position.y, m.pose.position.z = t.x, t.y, leg_height + 0.35
        m.pose.orientation.z, m.pose.orientation.w = math.sin(0.5 * t.yaw), math.cos(0.5 * t.yaw)
        m.scale.x, m.scale.y, m.scale.z = 0.28, 0.5, 0.7
        m.color = color
        out.markers.append(m)
        m = _marker(frame_id, stamp, "people_head", k, Marker.SPHERE)
        m.pose.position.x, m.pose.position.y, m.pose.position.z = t.x, t.y, leg_height + 0.85
        m.scale.x = m.scale.y = m.scale.z = 0.22
        m.color = color
        out.markers.append(m)
        m = _marker(frame_id, stamp, "people_labels", k, Marker.TEXT_VIEW_FACING)
        m.pose.position.x, m.pose.position.y, m.pose.position.z = t.x, t.y, leg_height + 1.25
        m.scale.z = 0.3
        m.color = ColorRGBA(1.0, 1.0, 1.0, 1.0)
        m.text = "%s\n%s -> %s" % (t.name, t.region or "-", t.goal_region or "-")
        out.markers.append(m)
    return out


def _hue(n: int) -> ColorRGBA:
    """A colour per person, hues spread by the golden angle."""
    import colorsys

    r, g, b = colorsys.hsv_to_rgb((n * 0.618034) % 1.0, 0.65, 0.95)
    return ColorRGBA(r, g, b, 1.0)


def _marker(frame_id: str, stamp: Any, ns: str, mid: int, kind: int) -> Marker:
    m = Marker()
    m.header.frame_id = frame_id
    m.header.stamp = stamp
    m.ns, m.id, m.type, m.action = ns, mid, kind, Marker.ADD
    m.pose.orientation.w = 1.0
    return m
