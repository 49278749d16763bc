"""The one validation module: bools never pass for numbers, and errors name path, expected, actual."""

from __future__ import annotations

import math
import struct
from array import array
from fractions import Fraction
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64MultiArray, Int32MultiArray, UInt8MultiArray

from pyconnect import codecs
from pyconnect.codecs import wire
from pyconnect.codecs.field_checks import (
    check_float,
    check_float32,
    check_kind_int,
    check_tuple,
    numeric_array,
    numeric_sequence,
)
from pyconnect.errors import EncodeError
from pyconnect.typesys.primitives import FLOAT32_MAX, FLOAT32_OVERFLOW


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


def packs_as_float32(number: float) -> bool:
    try:
        struct.pack("<f", number)
    except OverflowError:
        return False
    return True


# Around FLOAT32_MAX: the values that round down to it, the first that rounds up to inf, and beyond.
NEAR_FLOAT32_MAX = st.one_of(
    st.floats(min_value=FLOAT32_MAX * (1 - 1e-7), max_value=FLOAT32_OVERFLOW * (1 + 1e-7)),
    st.sampled_from([
        FLOAT32_MAX, 3.4028235e38, math.nextafter(FLOAT32_OVERFLOW, 0.0), FLOAT32_OVERFLOW,
        math.nextafter(FLOAT32_OVERFLOW, math.inf), 1e39, 1.7976931348623157e308,
    ]),
)  # fmt: skip


@given(magnitude=NEAR_FLOAT32_MAX, negative=st.booleans())
def test_check_float32_accepts_exactly_what_packs_as_a_float32(
    magnitude: float, negative: bool
) -> None:
    number = -magnitude if negative else magnitude
    if packs_as_float32(number):
        assert check_float32(number, "Range.range_max") == number
        assert check_float32(np.float64(number), "Range.range_max") == number
        return
    with pytest.raises(EncodeError) as caught:
        check_float32(number, "Range.range_max")
    assert str(caught.value) == (
        f"Range.range_max: expected float32 (|x| < 3.4028235677973366e+38), got {number!r}"
    )


def test_check_float32_passes_the_float32_maximum_as_numpy_prints_it() -> None:
    # rclpy's own default for `float32 x 3.4028235e38`: it packs to FLOAT32_MAX exactly.
    assert str(np.finfo(np.float32).max) == "3.4028235e+38"
    assert check_float32(3.4028235e38, "Defaults.fmax") == 3.4028235e38
    assert check_float32(-3.4028235e38, "Defaults.fmax") == -3.4028235e38
    for special in (math.inf, -math.inf):
        assert check_float32(special, "x") == special
    assert math.isnan(check_float32(math.nan, "x"))


# -- byte fields (uint8[], char[], byte[]) and memoryviews ---------------------------------------
UNBOUNDED = "test_msgs/msg/UnboundedSequences"
BYTE_FIELDS = ["uint8_values", "char_values", "byte_values"]


def byte_field(value: Any, field: str, full_name: str = UNBOUNDED) -> tuple[bytes, bytes]:
    """What from_dict and wire.encode make of ``value`` in a byte field, as bytes each."""
    stored = getattr(codecs.from_dict({field: value}, full_name), field)
    from_dict = b"".join(stored) if isinstance(stored, list) else bytes(stored)
    encoded = wire.encode({field: value}, full_name)
    return from_dict, wire.to_dict(encoded, full_name)[field]


def both_errors(value: Any, field: str, full_name: str = UNBOUNDED) -> tuple[str, str]:
    """The messages from_dict and wire.encode refuse ``value`` with."""
    with pytest.raises(EncodeError) as from_dict:
        codecs.from_dict({field: value}, full_name)
    with pytest.raises(EncodeError) as encoded:
        wire.encode({field: value}, full_name)
    return str(from_dict.value), str(encoded.value)


@pytest.mark.parametrize("field", BYTE_FIELDS)
@pytest.mark.parametrize(
    "value",
    [
        pytest.param(array("h", [1, 2]), id="array-h"),
        pytest.param(array("H", [1, 2]), id="array-H"),
        pytest.param(array("b", [1, 2]), id="array-b"),
        pytest.param(array("q", [1, 2]), id="array-q"),
        pytest.param(memoryview(np.array([1, 2], np.int16)), id="memoryview-int16"),
        pytest.param(memoryview(np.array([1, 2], np.int8)), id="memoryview-int8"),
        pytest.param(memoryview(np.array([1, 2], ">u4")), id="memoryview-big-endian"),
    ],
)
def test_typed_buffers_in_byte_fields_are_read_as_numbers_not_raw_bytes(
    value: Any, field: str
) -> None:
    assert byte_field(value, field) == (b"\x01\x02", b"\x01\x02")


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (array("H", [1, 300]), "uint8_values[1]: expected uint8 in [0, 255], got 300"),
        (array("b", [1, -1]), "uint8_values[1]: expected uint8 in [0, 255], got -1"),
        (memoryview(np.array([1, -2], np.int8)),
         "uint8_values[1]: expected uint8 in [0, 255], got -2"),
        (np.array([1, 300], np.int32), "uint8_values[1]: expected uint8 in [0, 255], got 300"),
        (array("d", [1.0]), "uint8_values[0]: expected int (uint8), got float"),
        (memoryview(np.array([1.0])),
         "uint8_values: expected bytes or uint8 values, got dtype float64"),
    ],
)  # fmt: skip
def test_typed_buffers_in_byte_fields_are_range_checked(value: Any, message: str) -> None:
    expected = f"UnboundedSequences.{message}"
    assert both_errors(value, "uint8_values") == (expected, expected)


def test_a_typed_buffer_fills_a_fixed_byte_array_by_its_elements() -> None:
    # Not "expected exactly 3 elements, got 12": array('i') holds three numbers, not 12 bytes.
    value = array("i", [1, 2, 3])
    expected = (b"\x01\x02\x03", b"\x01\x02\x03")
    assert byte_field(value, "uint8_values", "test_msgs/msg/Arrays") == expected


@pytest.mark.parametrize("field", BYTE_FIELDS)
def test_a_strided_memoryview_in_a_byte_field_is_copied(field: str) -> None:
    # rclpy takes it too; its items are the bytes it shows, not its underlying buffer.
    value = memoryview(b"\x01\x02\x03\x04")[::2]
    assert byte_field(value, field) == (b"\x01\x03", b"\x01\x03")
    image = {"format": "png", "data": value}
    assert wire.to_dict(wire.from_dict(image, "sensor_msgs/msg/CompressedImage"),
                        "sensor_msgs/msg/CompressedImage")["data"] == b"\x01\x03"  # fmt: skip


def test_a_char_memoryview_is_its_bytes() -> None:
    assert byte_field(memoryview(b"ab").cast("c"), "uint8_values") == (b"ab", b"ab")


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("float64_values", memoryview(np.zeros((2, 2)))),
        ("int32_values", memoryview(np.zeros((1, 2), np.int32))),
        ("uint8_values", memoryview(np.arange(4, dtype=np.uint8).reshape(2, 2))),
        ("byte_values", memoryview(np.arange(4, dtype=np.uint8).reshape(2, 2))),
        ("uint8_values", memoryview(np.array(7, np.uint8))),
    ],
)
def test_memoryviews_of_other_than_one_dimension_are_refused_alike(field: str, value: Any) -> None:
    expected = f"UnboundedSequences.{field}: expected a one-dimensional sequence, got memoryview"
    assert both_errors(value, field) == (expected, expected)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("float64_values", memoryview(np.array([1.5, -2.0], np.float16))),
        ("float64_values", memoryview(np.array([1.5, -2.0], ">f8"))),
        ("float32_values", memoryview(np.array([1.5, -2.0], ">f4"))),
        ("int16_values", memoryview(np.array([3, -4], ">i2"))),
    ],
)
def test_memoryviews_in_any_format_numpy_reads_encode_like_that_ndarray(
    field: str, value: Any
) -> None:
    # A memoryview iterates only native formats: these raised NotImplementedError before.
    same = np.asarray(value)
    expected = codecs.from_dict({field: same}, UNBOUNDED)
    assert codecs.from_dict({field: value}, UNBOUNDED) == expected
    assert wire.encode({field: value}, UNBOUNDED) == wire.encode({field: same}, UNBOUNDED)


def test_a_memoryview_of_pointers_is_refused_naming_its_format() -> None:
    value = memoryview(bytes(16)).cast("P")
    expected = (
        "UnboundedSequences.int64_values: "
        "expected a sequence of numbers, got memoryview of format 'P'"
    )
    assert both_errors(value, "int64_values") == (expected, expected)


@pytest.mark.parametrize(
    "full_name", ["test_msgs/msg/UnboundedSequences", "test_msgs/msg/BoundedSequences"]
)
def test_byte_sequences_take_rclpys_list_of_one_byte_bytes(full_name: str) -> None:
    value = [b"\x01", b"\x02"]
    assert byte_field(value, "byte_values", full_name) == (b"\x01\x02", b"\x01\x02")
    assert byte_field((b"\x01", 2), "byte_values", full_name) == (b"\x01\x02", b"\x01\x02")


def test_fixed_byte_arrays_take_rclpys_list_of_one_byte_bytes() -> None:
    from test_msgs.msg import Arrays

    value = Arrays().byte_values  # rosidl's own default: [b"\x00"] * 3
    expected = (b"\x00\x00\x00", b"\x00\x00\x00")
    assert byte_field(value, "byte_values", "test_msgs/msg/Arrays") == expected


def test_byte_elements_must_be_one_byte_and_only_in_byte_fields() -> None:
    expected = "UnboundedSequences.byte_values[1]: expected int (byte), got bytes"
    assert both_errors([b"\x01", b"\x02\x03"], "byte_values") == (expected, expected)
    expected = "UnboundedSequences.uint8_values[0]: expected int (uint8), got bytes"
    assert both_errors([b"\x01", b"\x02"], "uint8_values") == (expected, expected)


@pytest.mark.parametrize("field", [*BYTE_FIELDS, "int16_values"])
@pytest.mark.parametrize(
    "value",
    [
        pytest.param(np.arange(4, dtype=np.uint8).reshape(2, 2), id="2-D"),
        pytest.param(np.arange(4, dtype=np.int16).reshape(2, 2), id="2-D-int16"),
        pytest.param(np.array(7, np.uint8), id="0-d"),
        pytest.param(np.zeros((2, 0), np.uint8), id="2-D-empty"),
    ],
)
def test_byte_fields_refuse_other_than_one_dimension_like_every_sequence(
    field: str, value: Any
) -> None:
    expected = f"UnboundedSequences.{field}: expected a one-dimensional sequence, got numpy.ndarray"
    assert both_errors(value, field) == (expected, expected)


@pytest.mark.parametrize(
    ("full_name", "value", "message"),
    [
        (
            "geometry_msgs/msg/Twist",
            (np.array(0.2), np.array(0.5)),
            "Twist.linear: expected (x, y, z), got numpy.ndarray",
        ),
        ("geometry_msgs/msg/Point", np.array(1.0), "Point: expected (x, y, z), got numpy.ndarray"),
        (
            "geometry_msgs/msg/Pose",
            (np.array(1.0), (0.0, 0.0, 0.0, 1.0)),
            "Pose.position: expected (x, y, z), got numpy.ndarray",
        ),
        (
            "builtin_interfaces/msg/Time",
            np.array(1_700_000_000_000_000_000),
            "Time: expected (sec, nanosec) or int nanoseconds, got numpy.ndarray",
        ),
        (
            "std_msgs/msg/ColorRGBA",
            np.array(1.0),
            "ColorRGBA: expected (r, g, b, a), got numpy.ndarray",
        ),
    ],
)
def test_a_0d_array_where_a_tuple_goes_is_an_encode_error_on_both_paths(
    full_name: str, value: Any, message: str
) -> None:
    # A 0-d ndarray has __len__ but iterating it raises TypeError: like a scalar, it is no tuple
    # (and, as for check_float, no number either: Twist's (v, w) shorthand takes scalars only).
    with pytest.raises(EncodeError) as caught:
        codecs.default_registry.encode(value, full_name)
    assert str(caught.value) == message
    with pytest.raises(EncodeError) as caught:
        wire.encode(value, full_name)
    assert str(caught.value) == message
    with pytest.raises(EncodeError) as caught:
        check_tuple(np.array(1.0), 3, "(x, y, z)", "Point")
    assert str(caught.value) == "Point: expected (x, y, z), got numpy.ndarray"
