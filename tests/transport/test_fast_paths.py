"""The transport's fast paths give exactly the general path's bytes, values and errors."""

from __future__ import annotations

import importlib
import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyconnect.codecs import wire
from pyconnect.transport.conversion import WireConversion
from tests.codecs.test_fast_paths import FLAT_TYPES, decoded, payloads

FAST_TYPES = [
    "std_msgs/msg/String",
    "std_msgs/msg/Int8",
    "std_msgs/msg/UInt8",
    "std_msgs/msg/Int16",
    "std_msgs/msg/UInt16",
    "std_msgs/msg/Int32",
    "std_msgs/msg/UInt32",
    "std_msgs/msg/Int64",
    "std_msgs/msg/UInt64",
    "std_msgs/msg/Float32",
    "std_msgs/msg/Float64",
]

values = st.one_of(
    st.text(),
    st.text(alphabet=st.characters(min_codepoint=0xD800, max_codepoint=0xDFFF), min_size=1),
    st.integers(min_value=-(2**65), max_value=2**65),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(width=32),
    st.sampled_from([3.4028235e38, 3.5e38, -3.5e38, 2**64, -(2**63) - 1, True, None]),
    st.binary(),
)


def conversions(type_name: str) -> tuple[WireConversion, WireConversion]:
    codec = wire.wire_codec(type_name)
    registry: Any = codec._registry
    made = [
        WireConversion(describe="sub 'x'", codec=codec, registry=registry, fast=fast)
        for fast in (True, False)
    ]
    return made[0], made[1]


def outcome(function: Any, argument: Any) -> tuple[str, Any]:
    try:
        result = function(argument)
    except Exception as error:
        return type(error).__name__, str(error)
    if isinstance(result, float) and math.isnan(result):
        return "nan", None
    return "value", (type(result), result)


def test_the_small_types_take_a_fast_path() -> None:
    for type_name in FAST_TYPES:
        fast, general = conversions(type_name)
        assert fast.encode is not general.encode, type_name
        assert fast.encode.__qualname__.split(".")[0] in ("_string", "_scalar_encode"), type_name


def test_a_user_function_is_never_bypassed() -> None:
    codec = wire.wire_codec("std_msgs/msg/String")
    conversion = WireConversion(
        describe="sub 'x'", codec=codec, registry=codec._registry, decode_func=lambda msg: 7
    )
    assert conversion.decode(conversion.encode("hi")) == 7


@pytest.mark.parametrize("type_name", FAST_TYPES)
@settings(max_examples=300, deadline=None)
@given(value=values)
def test_encode_equals_the_general_path(type_name: str, value: Any) -> None:
    fast, general = conversions(type_name)
    assert outcome(fast.encode, value) == outcome(general.encode, value)


@pytest.mark.parametrize("type_name", FAST_TYPES)
@settings(max_examples=300, deadline=None)
@given(value=values, tail=st.binary(max_size=6), cut=st.integers(0, 12), data=st.binary())
def test_decode_equals_the_general_path(
    type_name: str, value: Any, tail: bytes, cut: int, data: bytes
) -> None:
    fast, general = conversions(type_name)
    try:
        payload = general.encode(value)
    except Exception:
        payload = data
    for candidate in (payload, payload + tail, payload[: max(0, len(payload) - cut)], data):
        assert outcome(fast.decode, candidate) == outcome(general.decode, candidate)
        big = candidate[:1] + b"\x00" + candidate[2:]  # the big-endian header: general path
        assert outcome(fast.decode, big) == outcome(general.decode, big)


@pytest.mark.parametrize("text", ["", "a", "ab", "abc", "abcd", "héllo wörld ✓"])
def test_strings_match_rclpy(text: str) -> None:
    serialization = importlib.import_module("rclpy.serialization")
    string_class = importlib.import_module("std_msgs.msg").String
    fast, _ = conversions("std_msgs/msg/String")
    # rclpy pads short messages to Fast DDS's size estimate: compare values, not bytes.
    assert serialization.deserialize_message(fast.encode(text), string_class).data == text
    assert fast.decode(serialization.serialize_message(string_class(data=text))) == text


@pytest.mark.parametrize("type_name", FLAT_TYPES)
@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_flat_multi_arrays_decode_as_the_general_path(type_name: str, data: Any) -> None:
    """Read-only views over the payload, as a peer's general path gives; same errors."""
    fast, general = conversions(type_name)
    assert fast.decode is not general.decode
    payload = data.draw(payloads(type_name))
    assert decoded(fast.decode, payload) == decoded(general.decode, payload)
