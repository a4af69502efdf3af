"""Every type we mirror has the md5sum of the original: people_msgs and SPENCER's people
types, SOMA's ROI object and services (soma_msgs, soma_manager, soma_map_manager) and
human_trajectory's Trajectory. Also: the simulator's People and TrackedPersons bytes are
genpy's.

Each upstream definition is kept as a test fixture (test/fixtures/upstream_msgs, with its
source commit); genmsg computes its md5sum the way ROS does, resolving std_msgs and
geometry_msgs from the installed packages, and it must equal the md5sum of the type this
package generates from msg/ and srv/. Equal md5sums are what a ROS 1 client or subscriber
checks on connect.
"""
from __future__ import annotations

import os
import subprocess

import pytest

genmsg = pytest.importorskip("genmsg")
from genmsg import gentools, msg_loader  # noqa: E402

FIXTURES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fixtures",
                        "upstream_msgs")


def _msg_dir(package: str) -> str:
    out = subprocess.run(["rospack", "find", package], stdout=subprocess.PIPE, text=True,
                         check=True)
    return os.path.join(out.stdout.strip(), "msg")


def upstream_md5(full_type: str) -> str:
    """The md5sum ROS gives ``full_type`` (a message or a service) as defined in the
    fixtures."""
    search = {"std_msgs": [_msg_dir("std_msgs")], "geometry_msgs": [_msg_dir("geometry_msgs")]}
    for pkg in os.listdir(FIXTURES):
        if os.path.isdir(os.path.join(FIXTURES, pkg)):
            search[pkg] = [os.path.join(FIXTURES, pkg, d) for d in ("msg", "srv")]
    ctx = genmsg.MsgContext.create_default()
    pkg, name = full_type.split("/")
    if os.path.isfile(os.path.join(FIXTURES, pkg, "srv", name + ".srv")):
        spec = msg_loader.load_srv_by_type(ctx, full_type, search)
    else:
        spec = msg_loader.load_msg_by_type(ctx, full_type, search)
    msg_loader.load_depends(ctx, spec, search)
    return gentools.compute_md5(ctx, spec)


@pytest.mark.parametrize("ours, upstream", [
    ("msg/People", "people_msgs/People"), ("msg/Person", "people_msgs/Person"),
    ("msg/TrackedPersons", "spencer_tracking_msgs/TrackedPersons"),
    ("msg/TrackedPerson", "spencer_tracking_msgs/TrackedPerson"),
    ("msg/SOMAROIObject", "soma_msgs/SOMAROIObject"),
    ("srv/SOMAQueryROIs", "soma_manager/SOMAQueryROIs"),
    ("srv/MapInfo", "soma_map_manager/MapInfo"),
    ("msg/Trajectory", "human_trajectory/Trajectory")])
def test_md5sum_equals_the_upstream_definitions(ours, upstream):
    import importlib

    kind, name = ours.split("/")
    ours_type = getattr(importlib.import_module("bullet_floor_sim." + kind), name)
    expected = upstream_md5(upstream)
    assert len(expected) == 32
    assert ours_type._md5sum == expected, (ours, upstream)


def test_a_changed_field_changes_the_md5sum(tmp_path):
    # the check can fail: the same computation over an edited copy gives another md5sum
    src = os.path.join(FIXTURES, "people_msgs", "msg", "Person.msg")
    edited = tmp_path / "people_msgs" / "msg"
    edited.mkdir(parents=True)
    (edited / "Person.msg").write_text(open(src).read().replace("float64", "float32"))
    ctx = genmsg.MsgContext.create_default()
    search = {"people_msgs": [str(edited)], "geometry_msgs": [_msg_dir("geometry_msgs")],
              "std_msgs": [_msg_dir("std_msgs")]}
    spec = msg_loader.load_msg_by_type(ctx, "people_msgs/Person", search)
    msg_loader.load_depends(ctx, spec, search)
    assert gentools.compute_md5(ctx, spec) != upstream_md5("people_msgs/Person")


# ------------------------------------------------------------------------------- the wire
def _truth():
    from bullet_floor_sim.people.crowd.crowd import PersonTruth

    return [PersonTruth("person_1", 1, 1.5, -2.25, 0.5, -1.0, 0.7, "walk", "7"),
            PersonTruth("visitor_2", 2, 10.0, 3.0, 0.0, 0.0, -3.0, "idle", "")]


def test_people_packed_as_genpy_would():
    """The simulator packs /ground_truth/people itself: the bytes genpy makes of the same
    message, and genpy reads them back."""
    import io
    import struct

    pytest.importorskip("rospy")
    from geometry_msgs.msg import Point

    from bullet_floor_sim.msg import People, Person
    from bullet_floor_sim.ros.sim.people_out import pack_people

    truth = _truth()
    data = pack_people(truth, 7, 12, 500, "map")
    msg = People()
    msg.header.seq, msg.header.stamp.secs, msg.header.stamp.nsecs = 7, 12, 500
    msg.header.frame_id = "map"
    msg.people = [Person(name=t.name, position=Point(t.x, t.y, 0.0),
                         velocity=Point(t.vx, t.vy, 0.0), reliability=1.0,
                         tagnames=["state", "goal_region"], tags=[t.state, t.goal_region])
                  for t in truth]
    buf = io.BytesIO()
    msg.serialize(buf)
    assert data == struct.pack("<I", len(buf.getvalue())) + buf.getvalue()
    back = People().deserialize(data[4:])
    assert [(p.name, p.position.x, p.velocity.y, p.tags) for p in back.people] == [
        ("person_1", 1.5, -1.0, ["walk", "7"]), ("visitor_2", 10.0, 0.0, ["idle", ""])]


def test_tracked_persons_packed_as_genpy_would():
    import io
    import math
    import struct

    pytest.importorskip("rospy")
    from bullet_floor_sim.msg import TrackedPerson, TrackedPersons
    from bullet_floor_sim.ros.sim.people_out import pack_tracked

    truth = _truth()
    data = pack_tracked(truth, 3_250_000_000, 7, 12, 500, "map")
    msg = TrackedPersons()
    msg.header.seq, msg.header.stamp.secs, msg.header.stamp.nsecs = 7, 12, 500
    msg.header.frame_id = "map"
    for t in truth:
        tr = TrackedPerson(track_id=t.track_id, is_occluded=False, is_matched=True,
                           detection_id=t.track_id)
        tr.age.secs, tr.age.nsecs = 3, 250_000_000
        tr.pose.pose.position.x, tr.pose.pose.position.y = t.x, t.y
        tr.pose.pose.orientation.z = math.sin(0.5 * t.yaw)
        tr.pose.pose.orientation.w = math.cos(0.5 * t.yaw)
        tr.twist.twist.linear.x, tr.twist.twist.linear.y = t.vx, t.vy
        pc, tc = [0.0] * 36, [0.0] * 36
        for k in (14, 21, 28):      # z, roll, pitch unset (SPENCER: a huge variance)
            pc[k] = tc[k] = 1e6
        tc[35] = 1e6                # yaw rate unset
        tr.pose.covariance, tr.twist.covariance = pc, tc
        msg.tracks.append(tr)
    buf = io.BytesIO()
    msg.serialize(buf)
    assert data == struct.pack("<I", len(buf.getvalue())) + buf.getvalue()
    back = TrackedPersons().deserialize(data[4:])
    assert [(t.track_id, t.is_matched, t.pose.pose.position.y) for t in back.tracks] == [
        (1, True, -2.25), (2, True, 3.0)]


def test_the_upstream_named_classes_parse_as_the_upstream_types():
    """ros/upstream.py: the simulator's People and TrackedPersons publishers advertise the
    upstream names; a tool that reads the message definition from a connection header (as
    rosbags does for a bag) gets the upstream types, whose md5sum is the upstream one."""
    pytest.importorskip("rospy")
    typesys = pytest.importorskip("rosbags.typesys")
    from bullet_floor_sim.msg import People, TrackedPersons
    from bullet_floor_sim.ros.upstream import upstream_named

    for ours, theirs in ((People, "people_msgs/People"),
                         (TrackedPersons, "spencer_tracking_msgs/TrackedPersons")):
        cls = upstream_named(ours)
        assert cls._type == theirs and cls._md5sum == ours._md5sum == upstream_md5(theirs)
        assert "bullet_floor_sim" not in cls._full_text
        assert issubclass(cls, ours) and upstream_named(ours) is cls
        store = typesys.get_typestore(typesys.Stores.EMPTY)
        pkg, name = theirs.split("/")
        store.register(typesys.get_types_from_msg(cls._full_text, "%s/msg/%s" % (pkg, name)))
        text, md5 = store.generate_msgdef("%s/msg/%s" % (pkg, name), ros_version=1)
        assert md5 == upstream_md5(theirs)
    with pytest.raises(KeyError, match="mirrors no upstream type"):
        from bullet_floor_sim.msg import Track
        upstream_named(Track)
