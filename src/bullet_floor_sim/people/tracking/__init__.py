"""Detect and track moving entities (people, robots, boxes) in one robot's laser scans.

No ground truth of the targets is used: only the scans, the laser's pose and the floor map.

1. :func:`scan_points` turns REP 117 ranges into map-frame points (finite returns only).
2. :class:`StaticMap` says which points the floor map explains (near an occupied or unknown
   cell); those are dropped.
3. :func:`detect` clusters the rest along the scan (consecutive points closer than
   ``cluster_gap``), keeps clusters of a plausible size and estimates each one's centre: the
   centroid pushed ``centre_offset`` away from the sensor (a lidar sees only the near surface);
   unless ``edge_cut`` is ``use``, a cluster on the first or last beam that reads of a scan
   that is not a full circle is ``cut`` (the view's edge cuts it; ``edge_cut`` says what it
   counts for). :func:`scan_detections` does 1-3 for a scan.
4. :class:`Tracker` runs one constant-velocity Kalman filter per track in the map frame
   (state x, y, vx, vy), gates detections by the chi-square distance of the innovation and
   associates by global nearest neighbour (``scipy.optimize.linear_sum_assignment``). A new
   track is tentative until ``confirm_hits`` hits and is deleted after ``max_age`` seconds
   without one (``tentative_max_age`` for a tentative track). With ``edge_cut``
   ``position``, a cut detection corrects the position of the track it is assigned, not its
   velocity (a track it starts stands until a whole body is seen).

Anything not on the map is tracked, moving or not (a parked robot gives a still track);
``Track.speed`` tells them apart. Everything is plain numbers in, plain numbers out.
"""
from __future__ import annotations

from .config import TrackerConfig, TrackingError
from .detection import (Detection, StaticMap, cluster, detect, detect_scan, scan_detections,
                        scan_points, view_edge)
from .tracker import PoseHistory, Track, Tracker

__all__ = ["TrackingError", "TrackerConfig", "StaticMap", "Detection", "Track", "Tracker",
           "scan_points", "cluster", "detect", "detect_scan", "scan_detections", "view_edge",
           "PoseHistory"]
