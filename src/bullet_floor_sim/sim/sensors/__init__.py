"""Sensors, one file each, and the registry the world file and the world read.

A sensor kind is one file here: its world.yaml section (a frozen dataclass of defaults with
``validate(where)``) and a model covering every robot of a world at once that follows
:class:`~.base.Sensor`, with a ``KIND`` entry naming both. ``SENSORS`` lists the kinds by
section name; that is all there is to adding one. Robots then take ``<section>: {...}`` in
world.yaml, ``RobotSpec.<section>`` holds its config, ``World.sensors[<section>]`` its model,
``World.step`` reads it when due and returns its readings with the other kinds' (a consumer
picks its own by type: the evaluation and the simulator node take ``Scan``). The simulator
node publishes a kind that ``ros/sim/publish.py`` has an output for under the same name.
"""
from typing import Dict

from . import battery, lidar, odometry
from .base import NEVER, Sensor, SensorKind
from .battery import Battery, BatteryConfig
from .lidar import LaserConfig, Lidar, RayPlan, Scan
from .odometry import Odometry, OdometryConfig
from .rays import MAX_RAYS_PER_BATCH, cast_rays, ray_chunk

__all__ = ["SENSORS", "NEVER", "Sensor", "SensorKind", "Battery", "BatteryConfig", "LaserConfig",
           "Lidar", "RayPlan", "Scan", "Odometry", "OdometryConfig", "MAX_RAYS_PER_BATCH",
           "cast_rays", "ray_chunk"]

#: Every sensor kind by its world.yaml section. Each step reads the due ones in this order
#: (odometry first: the order of their noise draws from the world's one generator).
SENSORS: Dict[str, SensorKind] = {
    "odometry": odometry.KIND,
    "laser": lidar.KIND,
    "battery": battery.KIND,
}
