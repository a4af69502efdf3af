"""Stored trajectories in the formats other tools read (``trajectories export --format``).

Every writer takes chunks in export order (trajectory after trajectory, each in
``sequence_id`` order, as :func:`~.documents.iter_documents` yields them) and writes each
pose once: a chunk's first pose is left out when it repeats the last pose of the chunk before
it (the boundary pose two chunks share).

* ``csv``: ``uuid,t,x,y,yaw``, one row per pose, t in seconds with 9 decimals, coordinates
  as Python writes them (they read back exactly).
* ``trajnet`` (TrajNet++ ndjson) and ``ethucy`` (the ETH/UCY text): trajnet.py.
* ``mcap``: one MCAP file of ROS 1 messages (profile ``ros1``, schemas ``ros1msg``,
  messages ``ros1``: what mcap-ros1-support and Foxglove read as ROS 1), each trajectory on
  its own topic ``/trajectories/t_<uuid hex>`` as ``geometry_msgs/PoseStamped`` in ``map``,
  one message per pose at its stamp (header seq counting from 0 per topic). The messages are
  serialised by rosbags' ROS 1 typestore and written with the mcap library.
* ``mcap-ros2``: the same topics in a ROS 2 bag directory (rosbag2, MCAP storage, CDR
  encoding, ``geometry_msgs/msg/PoseStamped``; no ROS 2 install needed).
"""
from __future__ import annotations

from typing import IO, Any, Dict, Iterable, List, Literal, Optional

from ...errors import BulletFloorSimError
from .chunks import Chunk, Pose, poses_once, yaw_of
from .trajnet import RATE as TRAJNET_RATE

__all__ = ["FORMATS", "ROS2_BAG_VERSION", "poses_once", "write_csv", "write_mcap",
           "write_ros2_bag", "TRAJNET_RATE", "mcap_topic"]

FORMATS = ("jsonl", "csv", "trajnet", "ethucy", "mcap", "mcap-ros2")
_NS = 1_000_000_000


def write_csv(chunks: Iterable[Chunk], out: IO[str]) -> int:
    """Write ``uuid,t,x,y,yaw`` rows; returns how many poses."""
    out.write("uuid,t,x,y,yaw\n")
    n = 0
    for uuid, p in poses_once(chunks):
        s, ns = divmod(p[0], _NS)
        out.write("%s,%d.%09d,%r,%r,%r\n" % (uuid, s, ns, p[1], p[2], yaw_of(p)))
        n += 1
    return n


#: The rosbag2 metadata version our ROS 2 bags carry. Humble's rosbag2 (metadata version 5)
#: reads any version's file by its own rules, and from version 9 on ``offered_qos_profiles``
#: is a YAML list where Humble parses a string ("yaml-cpp: bad conversion"); version 8 keeps
#: the string, and Jazzy reads it too (test_trajectory_formats.py checks both readers' rules).
ROS2_BAG_VERSION: Literal[8] = 8


def mcap_topic(uuid: str) -> str:
    """The topic a trajectory goes on in the mcap and mcap-ros2 exports."""
    return "/trajectories/t_" + "".join(ch for ch in uuid if ch.isalnum())


def write_mcap(chunks: Iterable[Chunk], out: IO[bytes], frame_id: str = "map") -> int:
    """Write ROS 1 MCAP (see the module doc) to the binary file ``out``; returns how many
    poses.

    Raises:
        BulletFloorSimError: rosbags or mcap is missing.
    """
    try:
        from mcap.writer import Writer as McapWriter
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise BulletFloorSimError("mcap export needs the rosbags and mcap packages (Python "
                                  ">= 3.10; make setup installs them)") from None
    store = get_typestore(Stores.ROS1_NOETIC)
    types = store.types
    msgtype = "geometry_msgs/msg/PoseStamped"
    definition, md5sum = store.generate_msgdef(msgtype, ros_version=1)
    writer = McapWriter(out)
    writer.start(profile="ros1", library="bullet_floor_sim")
    schema = writer.register_schema(name="geometry_msgs/PoseStamped", encoding="ros1msg",
                                    data=definition.encode())
    channels: Dict[str, List[int]] = {}   # uuid -> [channel id, next header seq]
    n = 0
    for uuid, p in poses_once(chunks):
        if uuid not in channels:
            channels[uuid] = [writer.register_channel(
                topic=mcap_topic(uuid), message_encoding="ros1", schema_id=schema,
                metadata={"md5sum": md5sum}), 0]
        channel = channels[uuid]
        s, ns = divmod(p[0], _NS)
        msg = _pose_stamped(types, channel[1], s, ns, frame_id, p)
        writer.add_message(channel_id=channel[0], log_time=p[0], publish_time=p[0],
                           data=bytes(store.serialize_ros1(msg, msgtype)), sequence=channel[1])
        channel[1] += 1
        n += 1
    writer.finish()
    return n


def _pose_stamped(types: Any, seq: Optional[int], sec: int, nanosec: int, frame_id: str,
                  p: Pose) -> Any:
    """A rosbags PoseStamped of pose ``p``: ROS 1's (a header seq) or ROS 2's (``seq`` None)."""
    stamp = types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
    header = (types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id) if seq is None
              else types["std_msgs/msg/Header"](seq=seq, stamp=stamp, frame_id=frame_id))
    return types["geometry_msgs/msg/PoseStamped"](
        header=header,
        pose=types["geometry_msgs/msg/Pose"](
            position=types["geometry_msgs/msg/Point"](x=p[1], y=p[2], z=p[3]),
            orientation=types["geometry_msgs/msg/Quaternion"](x=p[4], y=p[5], z=p[6], w=p[7])))


def write_ros2_bag(chunks: Iterable[Chunk], path: str, frame_id: str = "map") -> int:
    """Write a ROS 2 bag directory ``path`` (MCAP storage); returns how many poses.

    Raises:
        BulletFloorSimError: rosbags is missing, or ``path`` exists.
    """
    try:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise BulletFloorSimError("mcap-ros2 export needs the rosbags package (Python >= "
                                  "3.10; make setup installs it)") from None
    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    msgtype = "geometry_msgs/msg/PoseStamped"
    conns: Dict[str, Any] = {}
    n = 0
    try:
        writer = Writer(path, version=ROS2_BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
    except Exception as e:   # rosbags' WriterError: the directory exists
        raise BulletFloorSimError("%s: %s" % (path, e)) from None
    with writer:
        for uuid, p in poses_once(chunks):
            if uuid not in conns:
                conns[uuid] = writer.add_connection(mcap_topic(uuid), msgtype, typestore=store)
            s, ns = divmod(p[0], _NS)
            msg = _pose_stamped(types, None, s, ns, frame_id, p)
            writer.write(conns[uuid], p[0], store.serialize_cdr(msg, msgtype))
            n += 1
    return n
