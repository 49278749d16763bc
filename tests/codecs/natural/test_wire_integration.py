"""Natural values through the CDR wire codecs: ``to_fields`` encodes, ``decode`` reads views."""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np
import pytest

from pyconnect import codecs
from pyconnect.codecs import wire
from pyconnect.codecs.builtin_time import RosDuration, RosTime
from pyconnect.codecs.laser_scan import LaserScanValue
from pyconnect.codecs.occupancy_grid import OccupancyGridValue
from tests.codecs.natural.helpers import same

serialization = pytest.importorskip("rclpy.serialization")

CLOUD = np.zeros(
    3,
    np.dtype(
        {
            "names": ["x", "rgb"],
            "formats": [">f4", (">u2", (2,))],
            "offsets": [4, 8],
            "itemsize": 16,
        }
    ),
)
CLOUD["x"] = [1.0, np.nan, -2.0]
CASES: list[tuple[str, Any]] = [
    ("sensor_msgs/msg/Image", np.arange(24, dtype=np.uint16).reshape(2, 3, 4)),
    ("sensor_msgs/msg/Image", np.arange(6, dtype=">u2").reshape(2, 3)),
    ("sensor_msgs/msg/Image", np.arange(60, dtype=np.uint8).reshape(4, 5, 3)[:, ::2]),
    ("sensor_msgs/msg/CompressedImage", np.zeros((4, 4, 3), np.uint8)),
    ("sensor_msgs/msg/PointCloud2", np.ones((4, 3), np.float32)),
    ("sensor_msgs/msg/PointCloud2", CLOUD),
    (
        "sensor_msgs/msg/LaserScan",
        LaserScanValue(np.array([1.0, np.inf], np.float32), angle_min=0.5),
    ),
    (
        "sensor_msgs/msg/JointState",
        {"a": {"position": 1.0, "velocity": 2.0}, "b": {"position": 3.0, "velocity": 4.0}},
    ),
    (
        "nav_msgs/msg/OccupancyGrid",
        OccupancyGridValue(np.ones((2, 3), np.int8), 0.5, map_load_time=RosTime(3, 4)),
    ),
    ("nav_msgs/msg/Path", [((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))]),
    ("geometry_msgs/msg/Twist", (0.5, 0.1)),
    ("geometry_msgs/msg/TransformStamped", ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))),
    ("geometry_msgs/msg/Polygon", np.ones((3, 3), np.float32)),
    ("geometry_msgs/msg/Pose2D", (1.0, 2.0, 0.5)),
    ("std_msgs/msg/Float32MultiArray", np.ones((2, 3), np.float32)),
    ("std_msgs/msg/ByteMultiArray", np.arange(4, dtype=np.uint8)),
    ("std_msgs/msg/Byte", 7),
    ("std_msgs/msg/Char", 65),
    ("std_msgs/msg/UInt64", 2**64 - 1),
    ("std_msgs/msg/String", "héllo"),
    ("std_msgs/msg/Empty", None),
    ("std_msgs/msg/ColorRGBA", (1.0, 0.0, 0.0, 1.0)),
    ("builtin_interfaces/msg/Time", RosTime(1, 2)),
    ("builtin_interfaces/msg/Duration", RosDuration(-1, 5)),
]


def message_class(type_name: str) -> Any:
    package, namespace, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.{namespace}"), name)


@pytest.mark.parametrize(
    ("type_name", "value"), CASES, ids=[f"{t}-{i}" for i, (t, _) in enumerate(CASES)]
)
def test_wire_and_rclpy_agree_on_natural_values(type_name: str, value: Any) -> None:
    codec = codecs.lookup(type_name)
    expected = codec.decode(codec.encode(value))
    # natural value -> CDR without rclpy (to_fields), read back by rclpy
    from_wire = serialization.deserialize_message(
        bytes(wire.encode(value, type_name)), message_class(type_name)
    )
    assert same(codec.decode(from_wire), expected)
    # rclpy's CDR -> natural value without rclpy (decode on the wire's views)
    assert same(
        wire.decode(serialization.serialize_message(codec.encode(value)), type_name), expected
    )
