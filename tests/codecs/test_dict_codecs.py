"""Generated dict codecs: hypothesis round-trips over every generated type, and their errors."""

from __future__ import annotations

import importlib
import math
import pkgutil
from array import array
from typing import Any

import numpy as np
import pyconnect_generated
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy import serialization as rclpy_serialization

from pyconnect import codecs
from pyconnect.errors import EncodeError
from pyconnect.typesys.primitives import FLOAT32_MAX, FLOAT32_OVERFLOW
from tests.strategies import all_types, message_dicts, same_value


def _generated_entries() -> dict[str, tuple[Any, ...]]:
    entries: dict[str, tuple[Any, ...]] = {}
    for info in pkgutil.iter_modules(pyconnect_generated.__path__):
        module = importlib.import_module(f"pyconnect_generated.{info.name}.dict_codecs")
        entries.update(module.DICT_CODECS)
    return entries


GENERATED = _generated_entries()


def test_every_ir_type_is_generated() -> None:
    # Strategies come from the IR: a type the IR knows but generated/ lacks would go untested.
    assert set(all_types().messages) <= set(GENERATED)
    assert len(GENERATED) > 250


# Each example of these nests dozens of large messages: a few examples cover them.
HEAVY = {"test_msgs/msg/MultiNested"}


@pytest.mark.parametrize("full_name", sorted(set(GENERATED) - HEAVY))
@settings(max_examples=8, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_round_trip(full_name: str, data: st.DataObject) -> None:
    check_round_trip(full_name, data)


@pytest.mark.parametrize("full_name", sorted(HEAVY))
@settings(max_examples=2, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_round_trip_heavy(full_name: str, data: st.DataObject) -> None:
    check_round_trip(full_name, data)


def check_round_trip(full_name: str, data: st.DataObject) -> None:
    msg_class, to_dict, from_dict, _ = GENERATED[full_name]
    original = data.draw(message_dicts(all_types().get(full_name), all_types()))
    msg = from_dict(original)
    assert isinstance(msg, msg_class)
    assert same_value(to_dict(msg), original)
    # rclpy's own serialisation of what we built gives the same values back.
    wire = rclpy_serialization.serialize_message(msg)
    assert same_value(to_dict(rclpy_serialization.deserialize_message(wire, msg_class)), original)


# float32 values beyond FLOAT32_MAX that still round to it (rclpy's default for a field declared
# `float32 x 3.4028235e38`, as numpy prints the maximum), and those that round to inf.
ROUNDS_TO_FLOAT32_MAX = st.one_of(
    st.floats(min_value=FLOAT32_MAX, max_value=FLOAT32_OVERFLOW, exclude_max=True),
    st.sampled_from([3.4028235e38, math.nextafter(FLOAT32_OVERFLOW, 0.0)]),
)
ROUNDS_TO_INF = st.floats(min_value=FLOAT32_OVERFLOW, allow_infinity=False)


@given(magnitude=ROUNDS_TO_FLOAT32_MAX, negative=st.booleans())
def test_round_trip_at_the_float32_maximum(magnitude: float, negative: bool) -> None:
    from test_msgs.msg import BasicTypes

    value = -magnitude if negative else magnitude
    msg = BasicTypes(float32_value=value)
    assert codecs.from_dict(codecs.to_dict(msg), BasicTypes) == msg
    assert codecs.from_dict({"float32_value": value}, BasicTypes).float32_value == value
    received = rclpy_serialization.deserialize_message(
        rclpy_serialization.serialize_message(msg), BasicTypes
    )
    assert received.float32_value == math.copysign(FLOAT32_MAX, value)


@given(magnitude=ROUNDS_TO_INF, negative=st.booleans())
def test_float32_that_would_become_inf_is_refused(magnitude: float, negative: bool) -> None:
    value = -magnitude if negative else magnitude
    with pytest.raises(EncodeError) as raised:
        codecs.from_dict({"float32_value": value}, "test_msgs/msg/BasicTypes")
    assert str(raised.value) == (
        f"BasicTypes.float32_value: expected float32 (|x| < 3.4028235677973366e+38), got {value!r}"
    )


def test_from_dict_fills_defaults_and_keeps_input() -> None:
    from test_msgs.msg import Defaults, Strings

    assert codecs.from_dict({}, Defaults) == Defaults()
    assert codecs.from_dict({}, "test_msgs/msg/Strings") == Strings()
    data = {"int8_value": 5}
    built = codecs.from_dict(data, Defaults)
    assert built.int8_value == 5 and built.uint8_value == Defaults().uint8_value
    assert data == {"int8_value": 5}


def test_from_dict_accepts_numpy_values() -> None:
    from sensor_msgs.msg import JointState
    from test_msgs.msg import Arrays, BasicTypes

    msg = codecs.from_dict(
        {"position": np.array([1.0, 2.0]), "velocity": np.arange(3, dtype=np.float32)}, JointState
    )
    assert msg.position == array("d", [1.0, 2.0]) and msg.velocity == array("d", [0, 1, 2])
    basic = codecs.from_dict(
        {"float64_value": np.float32(1.5), "int16_value": np.int64(-3)}, BasicTypes
    )
    assert (basic.float64_value, basic.int16_value) == (1.5, -3)
    arrays = codecs.from_dict({"int32_values": np.array([1, 2, 3])}, Arrays)
    assert arrays.int32_values.tolist() == [1, 2, 3]


def test_uint8_data_is_bytes() -> None:
    from sensor_msgs.msg import CompressedImage

    msg = codecs.from_dict({"format": "png", "data": b"\x89PNG"}, CompressedImage)
    assert codecs.to_dict(msg)["data"] == b"\x89PNG"
    assert (
        codecs.from_dict({"data": np.frombuffer(b"ab", np.uint8)}, CompressedImage).data.tobytes()
        == b"ab"
    )


# Every form rclpy's setters and serialiser take for an octet sequence: the list of one-byte
# bytes it deserialises to, a tuple of them, and bytes-like objects assigned directly.
OCTET_FORMS = [
    pytest.param([b"a", b"\x00", b"\xff"], id="list"),
    pytest.param((b"a", b"\x00", b"\xff"), id="tuple"),
    pytest.param(b"a\x00\xff", id="bytes"),
    pytest.param(bytearray(b"a\x00\xff"), id="bytearray"),
    pytest.param(memoryview(b"a\x00\xff"), id="memoryview"),
]
OCTET_FIELDS = [
    ("std_msgs/msg/ByteMultiArray", "data"),
    ("rcl_interfaces/msg/ParameterValue", "byte_array_value"),
    ("test_msgs/msg/BoundedSequences", "byte_values"),
]  # Not fixed byte[N] arrays: rclpy serialises bytes-like ones there as garbage.


@pytest.mark.parametrize("value", OCTET_FORMS)
@pytest.mark.parametrize(("type_name", "field"), OCTET_FIELDS)
def test_octet_sequence_to_dict_takes_every_rclpy_form(
    type_name: str, field: str, value: Any
) -> None:
    msg_class = GENERATED[type_name][0]
    msg = msg_class()
    setattr(msg, field, value)
    # What rclpy itself makes of the field: its serialiser's bytes, read back as a message.
    wire = rclpy_serialization.serialize_message(msg)
    expected = rclpy_serialization.deserialize_message(wire, msg_class)
    data = codecs.to_dict(msg)
    assert type(data[field]) is bytes
    assert data[field] == b"".join(getattr(expected, field)) == b"a\x00\xff"
    assert codecs.from_dict(data, msg_class) == expected


ERRORS = [
    ("sensor_msgs/msg/JointState", {"position": [0.0, 1.0, 2.0, "x"]},
     "JointState.position[3]: expected float, got str"),
    ("sensor_msgs/msg/JointState", {"name": ["a", 3]}, "JointState.name[1]: expected str, got int"),
    ("sensor_msgs/msg/JointState", {"header": {"stamp": {"sec": "0"}}},
     "JointState.header.stamp.sec: expected int (int32), got str"),
    ("sensor_msgs/msg/JointState", {"positon": []},
     "JointState: unknown field 'positon' (fields: effort, header, name, position, velocity)"),
    ("sensor_msgs/msg/JointState", [1, 2], "JointState: expected dict, got list"),
    ("test_msgs/msg/BasicTypes", {"int8_value": 128},
     "BasicTypes.int8_value: expected int8 in [-128, 127], got 128"),
    ("test_msgs/msg/BasicTypes", {"uint64_value": -1},
     "BasicTypes.uint64_value: expected uint64 in [0, 18446744073709551615], got -1"),
    ("test_msgs/msg/BasicTypes", {"bool_value": 1}, "BasicTypes.bool_value: expected bool, got int"),
    ("test_msgs/msg/BasicTypes", {"float32_value": 1e39},
     "BasicTypes.float32_value: expected float32 (|x| < 3.4028235677973366e+38), got 1e+39"),
    ("test_msgs/msg/BasicTypes", {"float64_value": None},
     "BasicTypes.float64_value: expected float, got NoneType"),
    ("test_msgs/msg/BasicTypes", {"byte_value": 256},
     "BasicTypes.byte_value: expected byte in [0, 255], got 256"),
    ("test_msgs/msg/Arrays", {"int32_values": [1, 2]},
     "Arrays.int32_values: expected exactly 3 elements, got 2"),
    ("test_msgs/msg/Arrays", {"uint8_values": b"ab"},
     "Arrays.uint8_values: expected exactly 3 elements, got 2"),
    ("test_msgs/msg/BoundedSequences", {"int16_values": [1, 2, 3, 4]},
     "BoundedSequences.int16_values: expected at most 3 elements, got 4"),
    ("test_msgs/msg/BoundedSequences", {"int16_values": [1, 70000]},
     "BoundedSequences.int16_values[1]: expected int16 in [-32768, 32767], got 70000"),
    ("test_msgs/msg/Strings", {"bounded_string_value": "x" * 23},
     "Strings.bounded_string_value: expected at most 22 characters, got 23"),
    ("test_msgs/msg/MultiNested", {"array_of_arrays": [{}, {"bool_values": [1, 0, 1]}, {}]},
     "MultiNested.array_of_arrays[1].bool_values[0]: expected bool, got int"),
    ("test_msgs/msg/UnboundedSequences", {"float32_values": np.array(["a"])},
     "UnboundedSequences.float32_values: expected an array of float32, got dtype <U1"),
    ("geometry_msgs/msg/PoseStamped", {"pose": {"position": {"x": "1"}}},
     "PoseStamped.pose.position.x: expected float, got str"),
]  # fmt: skip


@pytest.mark.parametrize(("type_name", "data", "message"), ERRORS)
def test_errors_name_path_expected_and_actual(type_name: str, data: Any, message: str) -> None:
    with pytest.raises(EncodeError) as raised:
        codecs.from_dict(data, type_name)
    assert str(raised.value) == message


def test_slots_layout_pinned_to_rosidl() -> None:
    # Generated code reads and writes rosidl's slots directly (the fast path the issue allows
    # when pinned): every class must still store field `x` in slot `_x`, nothing else.
    from importlib.metadata import version

    assert version("ros-rosidl-generator-py").startswith("0.22.")
    for full_name, (msg_class, _, _, field_types) in GENERATED.items():
        assert msg_class.get_fields_and_field_types() == field_types, full_name
        assert list(msg_class.__slots__) == [f"_{n}" for n in field_types] + ["_check_fields"]
