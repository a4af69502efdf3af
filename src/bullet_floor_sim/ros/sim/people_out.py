"""The crowd's ground truth on ROS topics, in the formats people-tracking research reads.

* ``/ground_truth/people``: ``people_msgs/People`` (our msg/People.msg, the same definition
  and md5sum): name, position, velocity, reliability 1, tags ``state`` and ``goal_region``;
* ``/ground_truth/tracked_persons``: SPENCER's ``spencer_tracking_msgs/TrackedPersons``
  (msg/TrackedPersons.msg): track id = the person's number, never occluded, always matched,
  pose with the heading, and the unused z and rotations marked by a variance of 1e6 as
  SPENCER does.

Both in the ``map`` frame, built only when someone subscribes.
"""
from __future__ import annotations

import io
import math

from geometry_msgs.msg import Point

from bullet_floor_sim.msg import People, Person, TrackedPerson, TrackedPersons
from .wire import U32

__all__ = ["PeopleOutput"]

#: Variance of a pose or twist component the ground truth does not set (SPENCER's convention).
UNSET = 1e6


def _bytes(msg) -> bytes:
    buf = io.BytesIO()
    msg.serialize(buf)
    data = buf.getvalue()
    return U32.pack(len(data)) + data


class PeopleOutput:
    """The two ground-truth topics of a crowd.

    Args:
        publisher: ``Outbox.publisher``.
        crowd: people/crowd's Crowd.
        start_ns: sim time the people appeared (a track's age counts from it).
        frame: their frame.
    """

    def __init__(self, publisher, crowd, start_ns: int, frame: str = "map") -> None:
        self.crowd = crowd
        self.start_ns = start_ns
        self.frame = frame
        self.people_pub = publisher("/ground_truth/people", People, 10)
        self.tracked_pub = publisher("/ground_truth/tracked_persons", TrackedPersons, 10)
        self.seq = 0

    def put(self, out, secs: int, nsecs: int) -> None:
        """Queue both messages for the crowd's state now."""
        want_people, want_tracked = out.wanted(self.people_pub), out.wanted(self.tracked_pub)
        if not (want_people or want_tracked):
            return
        truth = self.crowd.ground_truth()
        self.seq += 1
        if want_people:
            msg = People()
            self._header(msg.header, secs, nsecs)
            msg.people = [Person(name=t.name, position=Point(t.x, t.y, 0.0),
                                 velocity=Point(t.vx, t.vy, 0.0), reliability=1.0,
                                 tagnames=["state", "goal_region"],
                                 tags=[t.state, t.goal_region]) for t in truth]
            out.put(self.people_pub, _bytes(msg))
        if want_tracked:
            msg = TrackedPersons()
            self._header(msg.header, secs, nsecs)
            age_ns = secs * 1_000_000_000 + nsecs - self.start_ns
            msg.tracks = [self._track(t, age_ns) for t in truth]
            out.put(self.tracked_pub, _bytes(msg))

    def _header(self, header, secs: int, nsecs: int) -> None:
        header.seq = self.seq
        header.stamp.secs, header.stamp.nsecs = secs, nsecs
        header.frame_id = self.frame

    @staticmethod
    def _track(t, age_ns: int) -> TrackedPerson:
        tr = TrackedPerson(track_id=t.track_id, is_occluded=False, is_matched=True,
                           detection_id=t.track_id)
        tr.age.secs, tr.age.nsecs = divmod(max(0, age_ns), 1_000_000_000)
        p = tr.pose.pose
        p.position.x, p.position.y = t.x, t.y
        p.orientation.z, p.orientation.w = math.sin(0.5 * t.yaw), math.cos(0.5 * t.yaw)
        tr.twist.twist.linear.x, tr.twist.twist.linear.y = t.vx, t.vy
        for cov in (tr.pose.covariance, tr.twist.covariance):
            for k in (2, 3, 4):          # z, roll, pitch (rotation about x and y)
                cov[7 * k] = UNSET
        tr.twist.covariance[35] = UNSET   # the yaw rate
        return tr
