"""The wire encoders' slow path: a run of fields packed together blames the field that fails."""

from __future__ import annotations

import math
import struct
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from nav_msgs.msg import MapMetaData
from rclpy.serialization import deserialize_message, serialize_message

from pyconnect import codecs
from pyconnect.codecs import cdr_write, wire
from pyconnect.codecs.cdr_write import slow_pack
from pyconnect.errors import EncodeError
from pyconnect.typesys.primitives import FLOAT32_MAX, FLOAT32_OVERFLOW

# MapMetaData packs map_load_time, resolution (float32), width and height as one run.
MAP_META_DATA = "nav_msgs/msg/MapMetaData"
ROUNDS_TO_FLOAT32_MAX = st.one_of(
    st.floats(min_value=FLOAT32_MAX, max_value=FLOAT32_OVERFLOW, exclude_max=True),
    st.sampled_from([3.4028235e38, math.nextafter(FLOAT32_OVERFLOW, 0.0)]),
)


def wire_error(value: Any, full_name: str) -> str:
    with pytest.raises(EncodeError) as caught:
        wire.from_dict(value, full_name)
    return str(caught.value)


@given(magnitude=ROUNDS_TO_FLOAT32_MAX, negative=st.booleans())
def test_a_float32_that_rounds_to_the_maximum_encodes_as_rclpy_does(
    magnitude: float, negative: bool
) -> None:
    resolution = -magnitude if negative else magnitude
    data = {"resolution": resolution, "width": 3}
    msg = codecs.from_dict(data, MAP_META_DATA)
    assert msg.resolution == resolution
    # rclpy as the oracle, by value (it leaves its padding bytes unset).
    expected = deserialize_message(serialize_message(msg), MapMetaData)
    assert expected.resolution == math.copysign(FLOAT32_MAX, resolution)
    encoded = wire.from_dict(data, MAP_META_DATA)
    assert deserialize_message(encoded, MapMetaData) == expected
    assert wire.to_dict(encoded, MAP_META_DATA) == codecs.to_dict(expected)


@given(magnitude=ROUNDS_TO_FLOAT32_MAX)
def test_a_bad_field_is_blamed_not_its_float32_neighbour(magnitude: float) -> None:
    # The uint32 fails the run's fast pack; the slow path must not then refuse the float32.
    assert wire_error({"resolution": magnitude, "width": -1}, MAP_META_DATA) == (
        "MapMetaData.width: expected uint32 in [0, 4294967295], got -1"
    )


def test_a_float32_that_rounds_to_inf_is_refused_like_from_dict() -> None:
    message = "MapMetaData.resolution: expected float32 (|x| < 3.4028235677973366e+38), got {}"
    for resolution in (FLOAT32_OVERFLOW, -1e39):
        data = {"resolution": resolution, "width": 3}
        assert wire_error(data, MAP_META_DATA) == message.format(repr(resolution))
        with pytest.raises(EncodeError) as caught:
            codecs.from_dict(data, MAP_META_DATA)
        assert str(caught.value) == message.format(repr(resolution))


def test_slow_pack_names_the_value_that_does_not_pack(monkeypatch: pytest.MonkeyPatch) -> None:
    # Were a check ever laxer than struct, the error must still name the value struct refused,
    # not the first field of the run.
    monkeypatch.setattr(cdr_write, "check_scalar", lambda kind, value, segment: value)
    label = ((".resolution", "float32", 4), (".width", "uint32", 8))
    with pytest.raises(EncodeError) as caught:
        slow_pack(struct.Struct("<fI"), label, (0.5, -1))
    assert str(caught.value) == ".width: cannot encode (argument out of range)"


# The byte fields' zero-copy path takes only what it can hand on as it is.
UNBOUNDED = "test_msgs/msg/UnboundedSequences"


def test_a_strided_byte_memoryview_is_encoded_by_its_items() -> None:
    value = memoryview(b"\x01\x02\x03\x04")[::2]
    encoded = wire.encode({"uint8_values": value}, UNBOUNDED)
    assert wire.to_dict(encoded, UNBOUNDED)["uint8_values"] == b"\x01\x03"
    assert encoded == wire.encode({"uint8_values": b"\x01\x03"}, UNBOUNDED)


def test_a_two_dimensional_uint8_ndarray_is_not_flattened() -> None:
    for value in (np.arange(4, dtype=np.uint8).reshape(2, 2), np.array(7, np.uint8)):
        assert wire_error({"uint8_values": value}, UNBOUNDED) == (
            "UnboundedSequences.uint8_values: expected a one-dimensional sequence, "
            "got numpy.ndarray"
        )


def test_byte_sequences_take_one_byte_bytes_as_rclpy_stores_them() -> None:
    encoded = wire.encode({"byte_values": [b"\x01", b"\x02"]}, UNBOUNDED)
    assert encoded == wire.encode({"byte_values": b"\x01\x02"}, UNBOUNDED)
    fixed = wire.encode({"byte_values": [b"\x01", 2, b"\x03"]}, "test_msgs/msg/Arrays")
    assert wire.to_dict(fixed, "test_msgs/msg/Arrays")["byte_values"] == b"\x01\x02\x03"
