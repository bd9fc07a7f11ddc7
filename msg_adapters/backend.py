# SPDX-License-Identifier: Apache-2.0
"""The two families of message classes the adapters build: rclpy's (nodes) and rosbags' (the bag harness).

Every adapter reads a message by its field names, so one reader serves both families. Builders differ
only in where a class comes from and how an array field is held; a `Backend` names both, and every
builder takes one (`RCLPY` by default):

- `RCLPY`: classes from the ROS packages (`sensor_msgs.msg.Image`, ...), `uint8[]` as `array.array("B")`,
  `float64[]` as a list;
- `ROSBAGS`: classes from the rosbags type store of ROS 2 Jazzy, arrays as numpy arrays (what its CDR
  serializer writes).

Neither family is imported before a class is asked for, so the bag harness (and the OpenCV benchmark
worker, whose interpreter has rosbags but no rclpy) can use the adapters without a ROS installation.
"""

from __future__ import annotations

import array
import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache, lru_cache
from typing import Any

import numpy as np

from msg_adapters.errors import MessageError

# ROS type names of the messages the adapters build or the harness writes.
HEADER = "std_msgs/msg/Header"
TIME = "builtin_interfaces/msg/Time"
IMAGE = "sensor_msgs/msg/Image"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
ROI = "sensor_msgs/msg/RegionOfInterest"
POINT32 = "geometry_msgs/msg/Point32"
POLYGON = "geometry_msgs/msg/Polygon"
POLYGON_STAMPED = "geometry_msgs/msg/PolygonStamped"
VECTOR3 = "geometry_msgs/msg/Vector3"
VECTOR3_STAMPED = "geometry_msgs/msg/Vector3Stamped"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
BOOL = "std_msgs/msg/Bool"
CLOCK = "rosgraph_msgs/msg/Clock"


@dataclass(frozen=True)
class Backend:
    """Where message classes come from and how their array fields are held."""

    name: str
    cls: Callable[[str], Any]  # ROS type name ("sensor_msgs/msg/Image") -> message class
    u8: Callable[[np.ndarray], Any]  # contiguous uint8 array -> a uint8[] field value
    f64: Callable[[Sequence[float]], Any]  # numbers -> a float64[] / float64[N] field value


@cache
def _rclpy_class(type_name: str) -> Any:
    package, kind, name = _split(type_name)
    try:
        return getattr(importlib.import_module(f"{package}.{kind}"), name)
    except (ImportError, AttributeError) as exc:
        raise MessageError(f"message type {type_name} is not installed for rclpy ({exc})") from exc


@lru_cache(maxsize=1)
def typestore() -> Any:
    """The rosbags type store of ROS 2 Jazzy (common_interfaces)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def _rosbags_class(type_name: str) -> Any:
    _split(type_name)
    try:
        return typestore().types[type_name]
    except KeyError as exc:
        raise MessageError(f"message type {type_name} is not in the rosbags ROS 2 Jazzy store") from exc


def _split(type_name: str) -> tuple[str, str, str]:
    parts = type_name.split("/")
    if len(parts) != 3 or not all(parts):
        raise MessageError(f"message type name {type_name!r} is not 'package/msg/Name'")
    return parts[0], parts[1], parts[2]


RCLPY = Backend("rclpy", _rclpy_class, lambda a: array.array("B", a.tobytes()),
                lambda v: [float(x) for x in v])
ROSBAGS = Backend("rosbags", _rosbags_class, lambda a: a.reshape(-1), lambda v: np.asarray(v, np.float64))
