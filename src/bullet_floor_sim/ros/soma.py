"""SOMA on the wire: one client of ``/soma/query_rois`` and one SOMAROIObject -> Roi conversion.

The walker, the destination predictor and the trajectory recorder all read their regions
through here, so they agree on what a region message means.
"""
from __future__ import annotations

from typing import Any, List

import rospy

from ..data.roi_store import roi_from_document
from ..data.rois import Roi

__all__ = ["roi_from_msg", "query_rois"]


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
