"""Our mirrors of upstream message types under the upstream names.

msg/ holds people_msgs' Person and People and SPENCER's TrackedPerson and TrackedPersons
field for field (test_upstream_types.py: the same md5sums), generated in this package as
``bullet_floor_sim/...``. A publisher of :func:`upstream_named` classes advertises the
upstream type name and a message definition whose dependencies carry the upstream package
names, so the master (rostopic), rosbag's connection headers and the tools that select by
type (``rosbag filter``, rqt_bag, Foxglove, a converted ROS 2 bag) see ``people_msgs/People``
and ``spencer_tracking_msgs/TrackedPersons``. The bytes and the md5sum are the same, so
subscribers typed either way connect.
"""
from __future__ import annotations

from typing import Dict, Type

__all__ = ["UPSTREAM", "upstream_named"]

#: our type -> the upstream package it mirrors
UPSTREAM = {
    "bullet_floor_sim/Person": "people_msgs",
    "bullet_floor_sim/People": "people_msgs",
    "bullet_floor_sim/TrackedPerson": "spencer_tracking_msgs",
    "bullet_floor_sim/TrackedPersons": "spencer_tracking_msgs",
}

_MADE: Dict[str, type] = {}


def upstream_named(cls: Type) -> Type:
    """The genpy class ``cls`` (one of :data:`UPSTREAM`) under its upstream name: a subclass
    with the upstream ``_type`` and a ``_full_text`` naming the upstream packages."""
    ours = cls._type
    if ours not in UPSTREAM:
        raise KeyError("%s mirrors no upstream type (known: %s)" % (ours, ", ".join(UPSTREAM)))
    if ours not in _MADE:
        name = ours.split("/", 1)[1]
        text = cls._full_text
        for mine, package in UPSTREAM.items():
            dep = mine.split("/", 1)[1]
            text = text.replace("\nMSG: %s\n" % mine, "\nMSG: %s/%s\n" % (package, dep))
        _MADE[ours] = type(name, (cls,), {"__slots__": (), "_type": UPSTREAM[ours] + "/" + name,
                                          "_full_text": text})
    return _MADE[ours]
