"""Big-endian CDR, written by an independent serializer (rosbags), decodes like little-endian."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyconnect import codecs
from pyconnect.codecs import wire
from tests.codecs.wire.normalise import plain
from tests.strategies import default_packages, message_dicts, same_value

_, TYPES = default_packages()
ROSBAGS_TYPES = [
    "sensor_msgs/msg/Image",
    "sensor_msgs/msg/JointState",
    "sensor_msgs/msg/Imu",
    "sensor_msgs/msg/PointCloud2",
    "diagnostic_msgs/msg/DiagnosticArray",
    "nav_msgs/msg/Odometry",
    "visualization_msgs/msg/Marker",
]


@pytest.fixture(scope="module")
def typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


@pytest.mark.parametrize("full_name", ROSBAGS_TYPES)
@settings(max_examples=10, deadline=None, database=None, suppress_health_check=list(HealthCheck))
@given(st.data())
def test_rosbags_big_endian_decodes_like_rclpy_little_endian(
    typestore: Any, full_name: str, data: st.DataObject
) -> None:
    dict_codec = codecs.default_registry.lookup_dict(full_name)
    value = data.draw(message_dicts(TYPES.get(full_name), TYPES))
    msg = dict_codec.from_dict(value)
    # Not serialize_message: rosbags rejects the unwritten bytes up to Fast DDS's size
    # estimate that rclpy returns (JointState with empty arrays).
    little = wire.from_dict(value, full_name)
    big = bytes(typestore.serialize_cdr(
        typestore.deserialize_cdr(little, full_name), full_name, little_endian=False
    ))  # fmt: skip
    assert big[:2] == b"\x00\x00"
    assert same_value(plain(wire.to_dict(big, full_name)), dict_codec.to_dict(msg))


def test_arrays_decode_as_views_of_the_input_in_views_and_as_lists_in_dicts() -> None:
    cdr = bytearray(wire.from_dict({"data": [1.5, 2.5]}, "std_msgs/msg/Float64MultiArray"))
    viewed = wire.wire_codec("std_msgs/msg/Float64MultiArray").decode_view(cdr).data
    assert np.shares_memory(viewed, np.frombuffer(cdr, np.uint8))
    assert viewed.tolist() == [1.5, 2.5]
    assert wire.to_dict(cdr, "std_msgs/msg/Float64MultiArray")["data"] == [1.5, 2.5]


@pytest.mark.parametrize(
    ("msg_type", "value"),
    [
        ("std_msgs/msg/Float64MultiArray", np.array([1.0, -2.5, 1e300])),
        ("std_msgs/msg/Int32MultiArray", np.array([1, -2, 2**31 - 1], np.int32)),
        ("std_msgs/msg/UInt16MultiArray", np.array([1, 65535], np.uint16)),
    ],
)
def test_natural_values_of_big_endian_cdr_equal_the_little_endian_ones(
    msg_type: str, value: Any
) -> None:
    codec = wire.wire_codec(msg_type)
    little = codec.encode(value)
    big = codec.from_dict(codec.to_dict(little), big_endian=True)
    assert big[:2] == b"\x00\x00" and big != little  # really big-endian
    decoded = codec.decode(big)
    assert decoded.dtype == value.dtype and decoded.tolist() == value.tolist()


def test_laser_scan_of_big_endian_cdr() -> None:
    from pyconnect.codecs.laser_scan import LaserScanValue

    codec = wire.wire_codec("sensor_msgs/msg/LaserScan")
    scan = LaserScanValue(ranges=np.array([1.0, 2.5], np.float32), intensities=[7.0])
    big = codec.from_dict(codec.to_dict(codec.encode(scan)), big_endian=True)
    decoded = codec.decode(big)
    assert decoded.ranges.tolist() == [1.0, 2.5] and decoded.intensities.tolist() == [7.0]
