"""A NUL in a string is refused on encode, on the class path and the wire path alike.

rclpy's C conversion ends a string at its first NUL (and so does every C or C++ reader of the
CDR), while pyconnect's wire decoder would keep it whole: accepting it meant losing data on
some paths and not others.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from rclpy.serialization import deserialize_message
from std_msgs.msg import String

from pyconnect import codecs
from pyconnect.codecs import default_registry, wire
from pyconnect.codecs.fast_paths import fast_encoder
from pyconnect.codecs.stamped import Stamped
from pyconnect.errors import EncodeError

VALUE = "left\0right"
REFUSED = "expected str without NUL characters, got 'left\\x00right' (NUL at index 4)"
STRINGS = "test_msgs/msg/Strings"
SEQUENCES = "test_msgs/msg/UnboundedSequences"
WSTRINGS = "test_msgs/msg/WStrings"


@pytest.mark.parametrize(
    ("encode", "path"),
    [
        (lambda: codecs.from_dict({"string_value": VALUE}, STRINGS), "Strings.string_value"),
        (lambda: wire.encode({"string_value": VALUE}, STRINGS), "Strings.string_value"),
        (lambda: codecs.from_dict({"bounded_string_value": VALUE}, STRINGS),
         "Strings.bounded_string_value"),
        (lambda: wire.encode({"bounded_string_value": VALUE}, STRINGS),
         "Strings.bounded_string_value"),
        (lambda: codecs.from_dict({"string_values": ["a", VALUE]}, SEQUENCES),
         "UnboundedSequences.string_values[1]"),
        (lambda: wire.encode({"string_values": ["a", VALUE]}, SEQUENCES),
         "UnboundedSequences.string_values[1]"),
        (lambda: codecs.from_dict({"wstring_value": VALUE}, WSTRINGS), "WStrings.wstring_value"),
        (lambda: wire.encode({"wstring_value": VALUE}, WSTRINGS), "WStrings.wstring_value"),
        (lambda: wire.encode({"array_of_wstrings": ["", VALUE, ""]}, WSTRINGS),
         "WStrings.array_of_wstrings[1]"),
        (lambda: codecs.encode(VALUE, String), "String.data"),
        (lambda: wire.encode(VALUE, "std_msgs/msg/String"), "String.data"),
        (lambda: codecs.from_dict({"header": {"frame_id": VALUE}}, "sensor_msgs/msg/Imu"),
         "Imu.header.frame_id"),
        (lambda: wire.encode({"header": {"frame_id": VALUE}}, "sensor_msgs/msg/Imu"),
         "Imu.header.frame_id"),
        (lambda: codecs.encode({"a": 1.0, VALUE: 2.0}, "sensor_msgs/msg/JointState"),
         "JointState.name"),
        (lambda: wire.encode({"a": 1.0, VALUE: 2.0}, "sensor_msgs/msg/JointState"),
         "JointState.name"),
        (lambda: codecs.encode(Stamped(np.zeros((2, 2), np.uint8), 0, VALUE),
                               "sensor_msgs/msg/Image"), "Stamped.frame_id"),
    ],
)  # fmt: skip
def test_a_nul_is_refused_naming_the_field(encode: Callable[[], Any], path: str) -> None:
    with pytest.raises(EncodeError) as caught:
        encode()
    assert str(caught.value) == f"{path}: {REFUSED}"


def test_the_string_fast_path_leaves_a_nul_to_the_general_path() -> None:
    def general(value: Any) -> bytes:
        return wire.encode(value, "std_msgs/msg/String")

    encode = fast_encoder(default_registry.value_codec(String), general)
    assert encode is not None
    assert deserialize_message(encode("fine"), String).data == "fine"
    with pytest.raises(EncodeError) as caught:
        encode(VALUE)
    assert str(caught.value) == f"String.data: {REFUSED}"


def test_long_values_are_shortened_in_the_error() -> None:
    with pytest.raises(EncodeError) as caught:
        wire.encode("x" * 100 + "\0", "std_msgs/msg/String")
    assert str(caught.value) == (
        "String.data: expected str without NUL characters, got 'xxxxxxxxxxxx...xxxxxxxxx\\x00' "
        "(NUL at index 100)"
    )
