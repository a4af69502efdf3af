"""The embedded mapper's pose estimate: odometry corrected by scan matching (gmapping's
scan-matcher step, without its particle filter).

:class:`ScanMatchingMapper` takes each scan with the laser's odometry pose. Once the robot
has moved ``linear_update`` metres or turned ``angular_update`` radians since the last scan it
took (gmapping's ``linearUpdate``/``angularUpdate``), the scan is matched against the map so
far (mapping/matcher.py, starting from odometry carried by the last correction)
and added at the matched pose. The correction is the map frame's transform to the odometry
frame (``map -> odom``, what gmapping broadcasts); the map frame is where odometry started.

Poses are (x, y, yaw) tuples (geometry.compose and inverse are their algebra).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple, Union

import numpy as np

from ..geometry import compose, inverse
from .matcher import MatcherConfig, match
from .occupancy import MapperConfig, OccupancyMapper

__all__ = ["SlamConfig", "ScanMatchingMapper"]

Pose = Tuple[float, float, float]


@dataclass(frozen=True)
class SlamConfig:
    """When scans are taken and how they are placed.

    Attributes:
        linear_update, angular_update: a scan is taken once the robot has moved this far (m)
            or turned this much (rad) since the last one (the first scan is always taken).
        match: place scans by scan matching (False: at the odometry pose, no correction).
    """

    linear_update: float = 0.25
    angular_update: float = 0.25
    match: bool = True


class ScanMatchingMapper:
    """An occupancy grid and the ``map -> odom`` correction, from scans at odometry poses.

    Args:
        config: update thresholds and whether to match.
        mapper_config: the grid's parameters.
        matcher_config: the scan matcher's.
    """

    def __init__(self, config: SlamConfig = SlamConfig(),
                 mapper_config: MapperConfig = MapperConfig(),
                 matcher_config: MatcherConfig = MatcherConfig()) -> None:
        self.config = config
        self.mapper_config = mapper_config
        self.matcher_config = matcher_config
        self.mapper: Optional[OccupancyMapper] = None
        self.correction: Pose = (0.0, 0.0, 0.0)
        self.last: Optional[Pose] = None        # odometry pose of the last scan taken
        self.taken = 0

    def in_map(self, odom_pose: Sequence[float]) -> Pose:
        """An odometry-frame pose in the map frame (the current estimate)."""
        return compose(self.correction, odom_pose)

    def due(self, odom_laser: Sequence[float]) -> bool:
        """Whether a scan from ``odom_laser`` would be taken (the robot moved enough)."""
        if self.last is None:
            return True
        d = compose(inverse(self.last), odom_laser)
        return (math.hypot(d[0], d[1]) >= self.config.linear_update
                or abs(d[2]) >= self.config.angular_update)

    def place(self, odom_laser: Sequence[float], ranges: Union[np.ndarray, Sequence[float]],
              angle_min: float, angle_increment: float, range_max: float) -> Optional[Pose]:
        """Where the scan from the laser at ``odom_laser`` (odometry frame) goes in the map,
        or None when it is not due. Reads the map only (a node can run it outside the lock
        that guards the map's readers)."""
        if not self.due(odom_laser):
            return None
        guess = self.in_map(odom_laser)
        if self.mapper is None or not self.config.match:
            return guess
        return match(self.mapper, guess, ranges, angle_min, angle_increment, range_max,
                     self.matcher_config)

    def commit(self, odom_laser: Sequence[float], pose: Sequence[float],
               ranges: Union[np.ndarray, Sequence[float]], angle_min: float,
               angle_increment: float, range_max: float) -> None:
        """Add the scan at ``pose`` (from :meth:`place`): the correction and the map."""
        if self.mapper is None:
            self.mapper = OccupancyMapper(self.mapper_config, centre=pose[:2])
        self.correction = compose(pose, inverse(odom_laser))
        self.mapper.update(pose, ranges, angle_min, angle_increment, range_max)
        self.last = (float(odom_laser[0]), float(odom_laser[1]), float(odom_laser[2]))
        self.taken += 1

    def add(self, odom_laser: Sequence[float], ranges: Union[np.ndarray, Sequence[float]],
            angle_min: float, angle_increment: float, range_max: float) -> bool:
        """:meth:`place` and :meth:`commit` the scan if it is due; whether it was taken."""
        pose = self.place(odom_laser, ranges, angle_min, angle_increment, range_max)
        if pose is None:
            return False
        self.commit(odom_laser, pose, ranges, angle_min, angle_increment, range_max)
        return True
