"""What ROS 2 Humble's and Jazzy's rosbag2 demand of a bag's metadata.yaml, as their C++
decoders read it (yaml-cpp ``as<T>()`` on each field the metadata version brings), from
ros2/rosbag2: humble d256a5b rosbag2_storage/src/rosbag2_storage/metadata_io.cpp, jazzy
64717ee rosbag2_storage/include/rosbag2_storage/yaml.hpp. Each returns the problems a
reader would fail on (empty: it parses)."""
from __future__ import annotations

import os
from typing import Any, Dict, List

import yaml


def load(bag_dir: str) -> Dict[str, Any]:
    with open(os.path.join(bag_dir, "metadata.yaml")) as f:
        return yaml.safe_load(f)["rosbag2_bagfile_information"]


def _common(meta: Dict[str, Any], out: List[str]) -> int:
    version = meta.get("version")
    if not isinstance(version, int):
        out.append("version is not an int")
        return -1
    for key, kind in (("storage_identifier", str), ("message_count", int),
                      ("relative_file_paths", list), ("topics_with_message_count", list)):
        if not isinstance(meta.get(key), kind):
            out.append("%s is not a %s" % (key, kind.__name__))
    for key in ("duration", "starting_time"):
        if not isinstance(meta.get(key), dict):
            out.append("%s is not a map" % key)
    if version >= 3:
        for key in ("compression_format", "compression_mode"):
            if not isinstance(meta.get(key), str):
                out.append("%s is not a string" % key)
    if version >= 5:
        for f in meta.get("files") or [None]:
            if not (isinstance(f, dict) and isinstance(f.get("path"), str)
                    and isinstance(f.get("message_count"), int)
                    and isinstance(f.get("starting_time"), dict)
                    and isinstance(f.get("duration"), dict)):
                out.append("files: %r is not a file entry" % (f,))
    return version


def _topics(meta: Dict[str, Any]) -> List[Dict[str, Any]]:
    return [t.get("topic_metadata") or {} for t in meta.get("topics_with_message_count") or []]


def humble_problems(meta: Dict[str, Any]) -> List[str]:
    out: List[str] = []
    version = _common(meta, out)
    for t in _topics(meta):
        if version >= 4 and not isinstance(t.get("offered_qos_profiles"), str):
            out.append("%s: offered_qos_profiles is not a string" % t.get("name"))
    return out


def jazzy_problems(meta: Dict[str, Any]) -> List[str]:
    out: List[str] = []
    version = _common(meta, out)
    for t in _topics(meta):
        qos = t.get("offered_qos_profiles")
        if version >= 9 and not isinstance(qos, list):
            out.append("%s: offered_qos_profiles is not a list" % t.get("name"))
        elif 4 <= version < 9 and not isinstance(qos, str):
            out.append("%s: offered_qos_profiles is not a string" % t.get("name"))
        if version >= 7 and not isinstance(t.get("type_description_hash"), str):
            out.append("%s: type_description_hash is not a string" % t.get("name"))
    # (its own decoder iterates the node: a map, or null as rosbag2 itself writes "~")
    if version >= 6 and not isinstance(meta.get("custom_data", ""), (dict, type(None))):
        out.append("custom_data is not a map")
    if version >= 8 and not isinstance(meta.get("ros_distro"), str):
        out.append("ros_distro is not a string")
    return out
