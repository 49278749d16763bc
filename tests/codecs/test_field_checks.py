"""The one validation module: bools never pass for numbers, and errors name path, expected, actual."""

from __future__ import annotations

from array import array
from fractions import Fraction
from typing import Any

import numpy as np
import pytest
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64MultiArray, Int32MultiArray, UInt8MultiArray

from pyconnect import codecs
from pyconnect.codecs import wire
from pyconnect.codecs.field_checks import (
    check_float,
    check_kind_int,
    check_tuple,
    numeric_array,
    numeric_sequence,
)
from pyconnect.errors import EncodeError


def wire_error(value: Any, full_name: str) -> str:
    with pytest.raises(EncodeError) as caught:
        wire.from_dict(value, full_name)
    return str(caught.value)


@pytest.mark.parametrize(
    ("full_name", "data", "message"),
    [
        ("std_msgs/msg/Int32MultiArray", [1, True], "data[1]: expected int (int32), got bool"),
        ("std_msgs/msg/Int32MultiArray", (False,), "data[0]: expected int (int32), got bool"),
        ("std_msgs/msg/Float64MultiArray", [0.5, True], "data[1]: expected float, got bool"),
        ("std_msgs/msg/Float32MultiArray", [True], "data[0]: expected float, got bool"),
        ("std_msgs/msg/UInt8MultiArray", [7, True], "data[1]: expected int (uint8), got bool"),
        (
            "std_msgs/msg/Int64MultiArray",
            [np.True_],
            "data[0]: expected int (int64), got numpy.bool",
        ),
    ],
)
def test_wire_encoder_refuses_bools_in_numeric_sequences(
    full_name: str, data: Any, message: str
) -> None:
    short = full_name.rsplit("/", 1)[1]
    assert wire_error({"data": data}, full_name) == f"{short}.{message}"


def test_wire_encoder_refuses_bools_in_fixed_arrays() -> None:
    value = {"float64_values": [1.0, True, 2.0]}
    assert wire_error(value, "test_msgs/msg/Arrays") == (
        "Arrays.float64_values[1]: expected float, got bool"
    )


def test_sequence_checks_the_dict_codec_calls_refuse_bools() -> None:
    with pytest.raises(EncodeError) as caught:
        numeric_sequence([1.0, True], "f", "float32", None, ".data")
    assert str(caught.value) == ".data[1]: expected float, got bool"
    with pytest.raises(EncodeError) as caught:
        numeric_array((1, 2, False), "i", "int32", "int32", 3, ".values")
    assert str(caught.value) == ".values[2]: expected int (int32), got bool"
    with pytest.raises(EncodeError) as caught:
        codecs.from_dict({"data": [1.0, True]}, "std_msgs/msg/Float32MultiArray")
    assert str(caught.value) == "Float32MultiArray.data[1]: expected float, got bool"


def test_numbers_of_every_kind_still_encode_exactly() -> None:
    # Plain ints in float sequences, numpy scalars and array('d') take the checked paths.
    cases: list[tuple[Any, str, Any]] = [
        ({"data": [1, 2.5, -3]}, "std_msgs/msg/Float64MultiArray", Float64MultiArray),
        ({"data": [np.float32(0.5), 2.0]}, "std_msgs/msg/Float64MultiArray", Float64MultiArray),
        ({"data": array("d", [0.25, 1.0])}, "std_msgs/msg/Float64MultiArray", Float64MultiArray),
        ({"data": [np.int16(-4), 5, 0, 1]}, "std_msgs/msg/Int32MultiArray", Int32MultiArray),
        ({"data": [0, 1, 255]}, "std_msgs/msg/UInt8MultiArray", UInt8MultiArray),
    ]
    for value, full_name, cls in cases:
        msg = codecs.from_dict(value, full_name)
        assert isinstance(msg, cls)
        assert list(msg.data) == [float(x) if cls is Float64MultiArray else int(x)
                                  for x in value["data"]]  # fmt: skip
        assert deserialize_message(wire.from_dict(value, full_name), cls) == msg


def test_natural_and_generated_checks_are_one_set() -> None:
    assert check_float(Fraction(1, 4), "x") == 0.25
    assert check_kind_int(np.uint8(7), "uint32", "Time.nanosec") == 7
    assert check_tuple([1, 2], 2, "(sec, nanosec)", "Time") == (1, 2)
    for call, message in [
        (lambda: check_float(True, "Twist.linear.x"), "Twist.linear.x: expected float, got bool"),
        (lambda: check_kind_int(1.5, "int32", "Int32.data"), "Int32.data: expected int, got float"),
        (lambda: check_kind_int(-1, "uint32", "Time.nanosec"),
         "Time.nanosec: expected uint32 in [0, 4294967295], got -1"),
        (lambda: check_tuple([1, 2, 3], 2, "(sec, nanosec)", "Time"),
         "Time: expected (sec, nanosec), got list of length 3"),
        (lambda: check_tuple(np.float64(1.0), 2, "(sec, nanosec)", "Time"),
         "Time: expected (sec, nanosec), got numpy.float64"),
    ]:  # fmt: skip
        with pytest.raises(EncodeError) as caught:
            call()
        assert str(caught.value) == message


def test_typed_arrays_encode_like_lists_in_both_byte_orders() -> None:
    # array.array of the field's own type is written as it is (it cannot hold a bool).
    codec = wire.wire_codec("sensor_msgs/msg/JointState")
    columns = {"name": ["a", "b"], "position": [0.5, -1.0], "effort": [2.0, 3.0]}
    typed = {**columns, "position": array("d", [0.5, -1.0]), "effort": array("d", [2.0, 3.0])}
    for big_endian in (False, True):
        expected = codec.from_dict(columns, big_endian=big_endian)
        assert codec.from_dict(typed, big_endian=big_endian) == expected
    ints = wire.wire_codec("std_msgs/msg/Int32MultiArray")
    assert ints.from_dict({"data": array("i", [1, -2])}) == ints.from_dict({"data": [1, -2]})
    swapped = ints.from_dict({"data": array("i", [1, -2])}, big_endian=True)
    assert ints.to_dict(swapped)["data"] == [1, -2]
