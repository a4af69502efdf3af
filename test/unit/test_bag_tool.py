"""bag convert (ros/bag_tool.py): a ROS 1 bag written by rosbag (the real one) as a ROS 2 bag,
read back with rosbags and compared message by message."""
from __future__ import annotations

import pytest

rosbag = pytest.importorskip("rosbag")
pytest.importorskip("rosbags")


def ros1_bag(path):
    """Stamped poses, scans and our People (a type of this package) on three topics."""
    import rospy
    from geometry_msgs.msg import Point, PoseStamped
    from sensor_msgs.msg import LaserScan

    from bullet_floor_sim.msg import People, Person

    sent = []
    with rosbag.Bag(path, "w") as bag:
        for k in range(20):
            t = rospy.Time(100, k * 50_000_000)
            ps = PoseStamped()
            ps.header.stamp, ps.header.frame_id = t, "map"
            ps.pose.position.x, ps.pose.position.y = 0.1 * k, 2.0 - 0.05 * k
            ps.pose.orientation.w = 1.0
            bag.write("/robot1/pose", ps, t)
            sent.append(("/robot1/pose", t.to_nsec(), (ps.pose.position.x, ps.pose.position.y)))
            if k % 2 == 0:
                scan = LaserScan(angle_min=-1.5, angle_increment=0.5, range_max=30.0,
                                 ranges=[1.0 + k, 2.0, float("inf")])
                scan.header.stamp, scan.header.frame_id = t, "robot1/base_laser_link"
                bag.write("/robot1/base_scan", scan, t)
                sent.append(("/robot1/base_scan", t.to_nsec(), (1.0 + k, 2.0)))
            if k % 5 == 0:
                people = People(people=[Person(name="person_1", position=Point(k, 1.0, 0.0),
                                               reliability=1.0, tagnames=["state"],
                                               tags=["walk"])])
                people.header.stamp, people.header.frame_id = t, "map"
                bag.write("/ground_truth/people", people, t)
                sent.append(("/ground_truth/people", t.to_nsec(), (float(k), 1.0)))
    return sent


def read_ros2(path):
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    got, types = [], {}
    with Reader(path) as reader:
        for conn in reader.connections:
            types[conn.topic] = conn.msgtype
            if conn.msgtype.startswith("bullet_floor_sim/"):
                store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        for conn, stamp, raw in reader.messages():
            m = store.deserialize_cdr(raw, conn.msgtype)
            if conn.topic == "/robot1/pose":
                v = (m.pose.position.x, m.pose.position.y)
            elif conn.topic == "/robot1/base_scan":
                v = (float(m.ranges[0]), float(m.ranges[1]))
            else:
                v = (m.people[0].position.x, m.people[0].position.y)
                assert (m.people[0].name, list(m.people[0].tags)) == ("person_1", ["walk"])
            stamp_msg = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
            assert stamp_msg == stamp
            got.append((conn.topic, stamp, v))
    return got, types


def _by_time(row):
    return row[1], row[0]


def test_convert_a_ros1_bag_to_ros2(tmp_path, capsys):
    from bullet_floor_sim.ros import bag_tool

    src = str(tmp_path / "demo.bag")
    sent = ros1_bag(src)
    out = str(tmp_path / "ros2")
    assert bag_tool.main(["convert", src, "--out", out]) == 0
    assert "%d messages" % len(sent) in capsys.readouterr().err
    got, types = read_ros2(out)
    assert types == {"/robot1/pose": "geometry_msgs/msg/PoseStamped",
                     "/robot1/base_scan": "sensor_msgs/msg/LaserScan",
                     "/ground_truth/people": "bullet_floor_sim/msg/People"}
    assert sorted(got, key=_by_time) == sorted(sent, key=_by_time)
    import rosbag2_readers

    meta = rosbag2_readers.load(out)
    assert meta["version"] == 8
    assert rosbag2_readers.humble_problems(meta) == [] == rosbag2_readers.jazzy_problems(meta)
    # one topic only, and the errors
    only = str(tmp_path / "poses")
    assert bag_tool.main(["convert", src, "--out", only, "--topic", "/robot1/pose"]) == 0
    assert [r[0] for r in read_ros2(only)[0]] == ["/robot1/pose"] * 20
    capsys.readouterr()
    assert bag_tool.main(["convert", src, "--out", out]) == 2
    assert "exists" in capsys.readouterr().err
    assert bag_tool.main(["convert", str(tmp_path / "none.bag"), "--out", str(tmp_path / "x")]) == 2
    assert "no such bag" in capsys.readouterr().err
