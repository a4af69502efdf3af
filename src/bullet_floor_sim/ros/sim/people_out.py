"""The crowd's ground truth on ROS topics, in the formats people-tracking research reads.

* ``/ground_truth/people``: ``people_msgs/People`` (our msg/People.msg, the same definition
  and md5sum): name, position, velocity, reliability 1, tags ``state`` and ``goal_region``;
* ``/ground_truth/tracked_persons``: SPENCER's ``spencer_tracking_msgs/TrackedPersons``
  (msg/TrackedPersons.msg): track id = the person's number, never occluded, always matched,
  pose with the heading, and the unused z and rotations marked by a variance of 1e6 as
  SPENCER does.

* ``/ground_truth/people_markers``: a figure per person for rviz (ros/markers.py), at most
  ten times a wall-clock second.

All in the ``map`` frame, built only when someone subscribes. The first two are packed here
straight to the wire (as wire.py packs the robots' topics; genpy took a third of the node's
time with 50 people); test_upstream_types.py checks the bytes against genpy's.
"""
from __future__ import annotations

import io
import math
import struct
import time
from typing import Any, Sequence

import numpy as np

import rospy
from visualization_msgs.msg import MarkerArray

from bullet_floor_sim.msg import People, TrackedPersons
from ..markers import people_markers
from ..upstream import upstream_named
from .wire import U32

__all__ = ["PeopleOutput", "pack_people", "pack_tracked"]

def _bytes(msg) -> bytes:
    buf = io.BytesIO()
    msg.serialize(buf)
    data = buf.getvalue()
    return U32.pack(len(data)) + data


#: One TrackedPerson on the wire (ROS 1 serialisation: little-endian, no padding).
TRACK = np.dtype([("track_id", "<u8"), ("is_occluded", "u1"), ("is_matched", "u1"),
                  ("detection_id", "<u8"), ("age", "<i4", (2,)), ("pose", "<f8", (7,)),
                  ("pose_cov", "<f8", (36,)), ("twist", "<f8", (6,)),
                  ("twist_cov", "<f8", (36,))])
_POSE_COV = np.zeros(36)
_POSE_COV[[14, 21, 28]] = 1e6             # z, rotation about x, about y: not set
_TWIST_COV = _POSE_COV.copy()
_TWIST_COV[35] = 1e6                      # the yaw rate: not set
_PERSON = struct.Struct("<7d")            # position, velocity, reliability
_TAGNAMES = b"".join((U32.pack(2), U32.pack(5), b"state", U32.pack(11), b"goal_region"))


def _string(text: str) -> bytes:
    raw = text.encode("utf-8")
    return U32.pack(len(raw)) + raw


def _header(seq: int, secs: int, nsecs: int, frame: str) -> bytes:
    return struct.pack("<3I", seq, secs, nsecs) + _string(frame)


def pack_people(truth: Sequence[Any], seq: int, secs: int, nsecs: int, frame: str) -> bytes:
    """people_msgs/People of ground-truth rows, serialised as genpy would (with the length
    prefix): name, position, velocity, reliability 1, tags state and goal_region."""
    parts = [_header(seq, secs, nsecs, frame), U32.pack(len(truth))]
    for t in truth:
        parts += [_string(t.name), _PERSON.pack(t.x, t.y, 0.0, t.vx, t.vy, 0.0, 1.0), _TAGNAMES,
                  U32.pack(2), _string(t.state), _string(t.goal_region)]
    body = b"".join(parts)
    return U32.pack(len(body)) + body


def pack_tracked(truth: Sequence[Any], age_ns: int, seq: int, secs: int, nsecs: int,
                 frame: str) -> bytes:
    """SPENCER TrackedPersons of ground-truth rows, serialised as genpy would: track and
    detection id = the person's number, never occluded, matched, pose with the heading,
    variance 1e6 on z and the rotations (and the rates) not set."""
    tracks = np.zeros(len(truth), dtype=TRACK)
    if len(truth):
        rows = np.array([(t.x, t.y, math.sin(0.5 * t.yaw), math.cos(0.5 * t.yaw), t.vx, t.vy)
                         for t in truth])
        ids = np.array([t.track_id for t in truth], dtype=np.uint64)
        tracks["track_id"] = tracks["detection_id"] = ids
        tracks["is_matched"] = 1
        tracks["age"] = divmod(max(0, age_ns), 1_000_000_000)
        tracks["pose"][:, [0, 1, 5, 6]] = rows[:, :4]
        tracks["twist"][:, :2] = rows[:, 4:]
        tracks["pose_cov"] = _POSE_COV
        tracks["twist_cov"] = _TWIST_COV
    body = _header(seq, secs, nsecs, frame) + U32.pack(len(truth)) + tracks.tobytes()
    return U32.pack(len(body)) + body


class PeopleOutput:
    """The two ground-truth topics of a crowd.

    Args:
        publisher: ``Outbox.publisher``.
        crowd: people/crowd's Crowd.
        start_ns: sim time the people appeared (a track's age counts from it).
        frame: their frame.
        markers_wall_period: wall seconds between marker updates at least (they are for the
            eye: 10 a second suffice, and faster than real time they cost the most).
        upstream: advertise the upstream type names (people_msgs/People,
            spencer_tracking_msgs/TrackedPersons; ros/upstream.py), else this package's.
    """

    def __init__(self, publisher, crowd, start_ns: int, frame: str = "map",
                 markers_wall_period: float = 0.1, upstream: bool = True) -> None:
        self.crowd = crowd
        self.start_ns = start_ns
        self.frame = frame
        # advertised under the upstream names (ros/upstream.py): people_msgs/People, SPENCER's
        named = upstream_named if upstream else (lambda cls: cls)
        self.people_pub = publisher("/ground_truth/people", named(People), 10)
        self.tracked_pub = publisher("/ground_truth/tracked_persons", named(TrackedPersons), 10)
        self.markers_pub = publisher("/ground_truth/people_markers", MarkerArray, 2)
        self.markers_wall_period = float(markers_wall_period)
        self._markers_wall = -math.inf
        self.seq = 0

    def put(self, out, secs: int, nsecs: int) -> None:
        """Queue both messages for the crowd's state now."""
        self.seq += 1
        wall = time.perf_counter()
        markers = (wall - self._markers_wall >= self.markers_wall_period
                   and out.wanted(self.markers_pub))
        want_people, want_tracked = out.wanted(self.people_pub), out.wanted(self.tracked_pub)
        if not (markers or want_people or want_tracked):
            return
        truth = self.crowd.ground_truth(regions=markers)   # the regions for the labels only
        if markers:
            self._markers_wall = wall
            body = self.crowd.body
            out.put(self.markers_pub, _bytes(people_markers(
                truth, self.crowd.legs(), body.leg_radius, body.leg_height, self.frame,
                rospy.Time(secs, nsecs))))
        if want_people:
            out.put(self.people_pub, pack_people(truth, self.seq, secs, nsecs, self.frame))
        if want_tracked:
            age_ns = secs * 1_000_000_000 + nsecs - self.start_ns
            out.put(self.tracked_pub,
                    pack_tracked(truth, age_ns, self.seq, secs, nsecs, self.frame))
