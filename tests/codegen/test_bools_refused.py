"""Generated encoders refuse bools where numbers go (Python and array() take True as 1 and 1.0).

Both generated paths, the dict codec (to an rclpy message) and the wire codec (to CDR), for single
fields (the wire encoder's struct runs) and numeric lists (the dict codec's array() fast path).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from rclpy.serialization import deserialize_message

from pyconnect import codecs
from pyconnect.codecs import wire
from pyconnect.errors import EncodeError

REFUSED = [
    ("geometry_msgs/msg/Twist", {"linear": {"x": True}}, "Twist.linear.x: expected float, got bool"),
    ("std_msgs/msg/UInt32", {"data": False}, "UInt32.data: expected int (uint32), got bool"),
    ("std_msgs/msg/Byte", {"data": True}, "Byte.data: expected int (byte), got bool"),
    ("sensor_msgs/msg/Imu", {"orientation_covariance": [True] * 9},
     "Imu.orientation_covariance[0]: expected float, got bool"),
    ("std_msgs/msg/Int32MultiArray", {"data": [1, True]},
     "Int32MultiArray.data[1]: expected int (int32), got bool"),
    ("std_msgs/msg/Float64MultiArray", {"data": [0.5, np.bool_(False)]},
     "Float64MultiArray.data[1]: expected float, got numpy.bool"),
]  # fmt: skip


def _from_wire(value: dict[str, Any], full_name: str, like: Any) -> Any:
    """What rclpy reads from the wire codec's CDR (rclpy's own CDR has unset padding bytes)."""
    return deserialize_message(bytes(wire.from_dict(value, full_name)), type(like))


@pytest.mark.parametrize(("full_name", "value", "message"), REFUSED)
def test_a_bool_where_a_number_goes_is_refused_on_both_paths(
    full_name: str, value: dict[str, Any], message: str
) -> None:
    with pytest.raises(EncodeError) as by_wire:
        wire.from_dict(value, full_name)
    assert str(by_wire.value) == message
    with pytest.raises(EncodeError) as by_dict:
        codecs.from_dict(value, full_name)
    assert str(by_dict.value) == message


def test_plain_numbers_ints_for_floats_and_numpy_scalars_still_encode_as_the_dict_codec_does() -> (
    None
):
    value = {"linear": {"x": 1, "y": np.float32(2.5), "z": 3.0}, "angular": {"z": np.int64(-4)}}
    expected = {
        "linear": {"x": 1.0, "y": 2.5, "z": 3.0},
        "angular": {"x": 0.0, "y": 0.0, "z": -4.0},
    }
    message = codecs.from_dict(value, "geometry_msgs/msg/Twist")
    assert codecs.to_dict(message) == expected
    assert _from_wire(value, "geometry_msgs/msg/Twist", message) == message
    flags = {"bool_value": True, "float64_value": 2.0, "int32_value": 7, "uint8_value": 255}
    built = codecs.from_dict(flags, "test_msgs/msg/BasicTypes")
    assert _from_wire(flags, "test_msgs/msg/BasicTypes", built) == built
    layout = {"dim": [], "data_offset": 0}
    for full_name, data in (("std_msgs/msg/Int32MultiArray", [1, -2, 3]),
                            ("std_msgs/msg/Float32MultiArray", [1, 2.5, np.float64(3)])):  # fmt: skip
        value = {"layout": layout, "data": data}
        built = codecs.from_dict(value, full_name)
        assert list(built.data) == [float(x) if "Float" in full_name else x for x in data]
        assert _from_wire(value, full_name, built) == built
