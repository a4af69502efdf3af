"""SOMA on the wire: one client of ``/soma/query_rois``, one SOMAROIObject -> Roi conversion
and the one stored document -> SOMAROIObject conversion (what roi_manager serves).

The walker, the destination predictor and the trajectory recorder all read their regions
through here, so they agree on what a region message means.
"""
from __future__ import annotations

from typing import Any, Dict, List

import rospy
from geometry_msgs.msg import Point, Pose, PoseArray, Quaternion
from std_msgs.msg import Header

from ..data.roi_store import roi_from_document
from ..data.rois import Roi
from ..msg import SOMAROIObject

__all__ = ["roi_from_msg", "query_rois", "document_to_msg"]


def roi_from_msg(msg: Any) -> Roi:
    """A Roi from a SOMAROIObject message, by data/roi_store.roi_from_document (the one
    conversion: a closing vertex equal to the first is dropped). Not validated (see
    people/markov.usable_rois)."""
    return roi_from_document({
        "id": msg.id, "config": msg.config, "type": msg.type, "map_name": msg.map_name,
        "posearray": {"poses": [{"position": {"x": p.position.x, "y": p.position.y}}
                                for p in msg.posearray.poses]}}, "ROI message")


def query_rois(service: str, config: str, wait: float) -> List[Roi]:
    """The most recent ROIs of ``config`` (every config when empty) from a SOMAQueryROIs
    service, in the order it answers.

    Raises:
        rospy.ROSException: the service did not appear within ``wait`` seconds.
        rospy.ServiceException: the call failed.
    """
    from ..srv import SOMAQueryROIs, SOMAQueryROIsRequest

    rospy.wait_for_service(service, timeout=wait)
    answer = rospy.ServiceProxy(service, SOMAQueryROIs)(SOMAQueryROIsRequest(
        query_type=0, returnmostrecent=True, roiconfigs=[config] if config else []))
    return [roi_from_msg(m) for m in answer.rois if not config or m.config == config]


def _header(d: Dict[str, Any]) -> Header:
    stamp = d.get("stamp", {})
    return Header(seq=int(d.get("seq", 0)), frame_id=str(d.get("frame_id", "")),
                  stamp=rospy.Time(int(stamp.get("secs", 0)), int(stamp.get("nsecs", 0))))


def _pose_array(d: Dict[str, Any]) -> PoseArray:
    poses = []
    for p in d.get("poses", []):
        pos, ori = p["position"], p["orientation"]
        poses.append(Pose(Point(pos["x"], pos["y"], pos["z"]),
                          Quaternion(ori["x"], ori["y"], ori["z"], ori["w"])))
    return PoseArray(header=_header(d.get("header", {})), poses=poses)


def document_to_msg(doc: Dict[str, Any]) -> SOMAROIObject:
    """A stored ROI document as a SOMAROIObject message."""
    msg = SOMAROIObject()
    msg.header = _header(doc.get("header", {}))
    for name in ("id", "map_name", "map_unique_id", "config", "type", "geotype"):
        setattr(msg, name, str(doc.get(name, "")))
    for name in ("logtimestamp", "logday", "loghour", "logminute", "logtimeminutes"):
        setattr(msg, name, int(doc.get(name, 0)))
    msg.posearray = _pose_array(doc.get("posearray", {}))
    msg.geoposearray = _pose_array(doc.get("geoposearray", {}))
    return msg
