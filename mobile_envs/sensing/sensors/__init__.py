"""Sensors: per-robot measurements that the environment's observation carries.

:mod:`~mobile_envs.sensing.sensors.sensor` defines the interface (:class:`Sensor`, what it
may read: :class:`SensorWorld`) and the catalogue (:data:`SENSORS`); every other module here
is one sensor, which registers itself. Importing the package imports them all, so adding a
sensor is adding its module.
"""

from mobile_envs.catalogue import import_package_modules
from mobile_envs.sensing.sensors.range import RANGE_MAX, RANGE_RAYS, RangeSensor
from mobile_envs.sensing.sensors.sensor import (
    SENSORS,
    Array,
    Generators,
    Indices,
    Sensor,
    SensorSpec,
    SensorWorld,
    make_sensor,
    make_sensors,
    register_sensor,
)

import_package_modules(__name__, __path__)

__all__ = [
    "RANGE_MAX",
    "RANGE_RAYS",
    "SENSORS",
    "Array",
    "Generators",
    "Indices",
    "RangeSensor",
    "Sensor",
    "SensorSpec",
    "SensorWorld",
    "make_sensor",
    "make_sensors",
    "register_sensor",
]
