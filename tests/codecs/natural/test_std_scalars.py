"""std_msgs scalars, String, Empty, ColorRGBA and builtin_interfaces Time/Duration."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyconnect import codecs
from pyconnect.codecs.builtin_time import RosDuration, RosTime
from pyconnect.errors import EncodeError
from pyconnect.typesys.primitives import INTEGER_RANGES
from tests.codecs.natural.helpers import EXAMPLES, same, wire_view

INTS = {
    "Int8": "int8",
    "Int16": "int16",
    "Int32": "int32",
    "Int64": "int64",
    "UInt8": "uint8",
    "UInt16": "uint16",
    "UInt32": "uint32",
    "UInt64": "uint64",
    "Char": "char",
    "Byte": "byte",
}
float32s = st.floats(width=32)
VALUES: dict[str, st.SearchStrategy[Any]] = {
    **{f"std_msgs/msg/{name}": st.integers(*INTEGER_RANGES[kind]) for name, kind in INTS.items()},
    "std_msgs/msg/Float32": float32s,
    "std_msgs/msg/Float64": st.floats(),
    "std_msgs/msg/Bool": st.booleans(),
    "std_msgs/msg/String": st.text(
        st.characters(exclude_categories=["Cs"], exclude_characters="\x00")
    ),
    "std_msgs/msg/Empty": st.none(),
    "std_msgs/msg/ColorRGBA": st.tuples(float32s, float32s, float32s, float32s),
    "builtin_interfaces/msg/Time": st.builds(
        RosTime, st.integers(-(2**31), 2**31 - 1), st.integers(0, 2**32 - 1)
    ),
    "builtin_interfaces/msg/Duration": st.builds(
        RosDuration, st.integers(-(2**31), 2**31 - 1), st.integers(0, 2**32 - 1)
    ),
}


@EXAMPLES
@given(st.sampled_from(sorted(VALUES)).flatmap(lambda t: st.tuples(st.just(t), VALUES[t])))
def test_round_trip(case: tuple[str, Any]) -> None:
    type_name, value = case
    codec = codecs.lookup(type_name)
    assert codec.lossless is True
    msg = codec.encode(value)
    assert same(codec.decode(msg), value)
    assert same(codec.decode(wire_view(msg)), value)
    assert same(codec.decode(codecs.from_dict(codec.to_fields(value), type_name)), value)


@pytest.mark.parametrize(
    ("type_name", "value", "message"),
    [
        ("std_msgs/Int8", 300, "Int8.data: expected int8 in [-128, 127], got 300"),
        (
            "std_msgs/UInt64",
            -1,
            "UInt64.data: expected uint64 in [0, 18446744073709551615], got -1",
        ),
        ("std_msgs/Int32", 1.5, "Int32.data: expected int, got float"),
        ("std_msgs/Int32", True, "Int32.data: expected int, got bool"),
        ("std_msgs/Byte", 256, "Byte.data: expected byte in [0, 255], got 256"),
        (
            "std_msgs/Float32",
            1e39,
            "Float32.data: expected float32 (|x| < 3.4028235677973366e+38), got 1e+39",
        ),
        ("std_msgs/Float64", "1.0", "Float64.data: expected float, got str"),
        ("std_msgs/Bool", 1, "Bool.data: expected bool, got int"),
        ("std_msgs/String", b"x", "String.data: expected str, got bytes"),
        ("std_msgs/Empty", {}, "Empty: expected None, got dict"),
        ("std_msgs/ColorRGBA", {"r": 1.0}, "ColorRGBA: expected (r, g, b, a), got dict"),
        (
            "builtin_interfaces/Time",
            (1, 2**32),
            ("Time.nanosec: expected uint32 in [0, 4294967295], got 4294967296"),
        ),
        (
            "builtin_interfaces/Duration",
            1.5,
            ("Duration: expected (sec, nanosec) or int nanoseconds, got float"),
        ),
    ],
)
def test_range_and_type_errors(type_name: str, value: Any, message: str) -> None:
    with pytest.raises(EncodeError) as error:
        codecs.encode(value, type_name)
    assert str(error.value) == message


def test_numpy_scalars_and_conveniences() -> None:
    assert codecs.decode(codecs.encode(np.int16(-3), "std_msgs/Int16")) == -3
    assert codecs.decode(codecs.encode(np.float32(0.5), "std_msgs/Float64")) == 0.5
    assert codecs.decode(codecs.encode(np.True_, "std_msgs/Bool")) is True
    assert codecs.decode(codecs.encode(None, "std_msgs/Empty")) is None
    assert codecs.decode(codecs.encode(200, "std_msgs/Byte")) == 200
    time = codecs.decode(codecs.encode(1_500_000_000, "builtin_interfaces/Time"))
    assert time == RosTime(1, 500_000_000) and time.nanoseconds == 1_500_000_000
    # nanosec >= 1e9 is kept: the reason the value is not int nanoseconds.
    odd = codecs.decode(codecs.encode((1, 1_500_000_000), "builtin_interfaces/Time"))
    assert odd == (1, 1_500_000_000)
    assert RosDuration.from_nanoseconds(-1) == (-1, 999_999_999)
