"""The flat-MultiArray fast encoder gives exactly the general path's bytes and errors.

The transport's tests (tests/transport/test_fast_paths.py) hold String and the numbers to the
same rule; ``pub`` agents use these encoders too (tests/ros/test_raw_path.py compares their
messages with the class path's).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64MultiArray

from pyconnect.codecs import default_registry, wire
from pyconnect.codecs.fast_paths import fast_encoder
from pyconnect.codecs.multi_array import DTYPES, MultiArrayCodec

FLAT_TYPES = [f"std_msgs/msg/{name}" for name in DTYPES if name != "ByteMultiArray"]

arrays = st.one_of(
    hnp.arrays(
        dtype=st.sampled_from(sorted({*DTYPES.values(), ">f8", ">i4", "bool", "complex64"})),
        shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=9),
    ),
    # Views that are not C-contiguous (every other element) or are offset into a buffer.
    hnp.arrays(dtype="float64", shape=st.integers(0, 20)).map(lambda a: a[::2]),
    hnp.arrays(dtype="int32", shape=st.integers(1, 20)).map(lambda a: a[1:]),
)
others = st.one_of(
    st.none(), st.text(max_size=3), st.lists(st.floats(), max_size=4), st.integers(), st.binary()
)


def encoders(type_name: str) -> tuple[Any, Any]:
    """(the fast encoder, the general one: the natural codec's fields -> from_dict)."""
    codec = wire.wire_codec(type_name)

    def general(value: Any) -> bytes:
        return codec.encode(value)

    fast = fast_encoder(default_registry.value_codec(type_name), general)
    assert fast is not None, type_name
    return fast, general


def outcome(encode: Any, value: Any) -> tuple[str, Any]:
    try:
        return "bytes", encode(value)
    except Exception as error:
        return type(error).__name__, str(error)


@pytest.mark.parametrize("type_name", FLAT_TYPES)
@settings(max_examples=150, deadline=None)
@given(value=st.one_of(arrays, others))
def test_encode_equals_the_general_path(type_name: str, value: Any) -> None:
    fast, general = encoders(type_name)
    assert outcome(fast, value) == outcome(general, value)


@pytest.mark.parametrize("type_name", FLAT_TYPES)
@pytest.mark.parametrize("size", [1, 2, 3, 5, 12, 1001])
def test_every_flat_array_of_the_own_dtype_is_encoded_straight(type_name: str, size: int) -> None:
    fast, general = encoders(type_name)
    value = np.arange(size).astype(DTYPES[type_name.rsplit("/", 1)[1]])
    calls: list[Any] = []

    def counted(candidate: Any) -> bytes:
        calls.append(candidate)
        return general(candidate)

    straight = fast_encoder(default_registry.value_codec(type_name), counted)
    assert straight is not None
    assert straight(value) == general(value) == fast(value)
    assert calls == []  # the fast path wrote it, not the general one


def test_rclpy_reads_the_layout_and_the_data() -> None:
    fast, _ = encoders("std_msgs/msg/Float64MultiArray")
    value = np.linspace(-1.0, 1.0, 7)
    msg = deserialize_message(fast(value), Float64MultiArray)
    assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == [("", 7, 7)]
    assert msg.layout.data_offset == 0
    assert list(msg.data) == value.tolist()


def test_only_the_stock_codec_of_a_numeric_multi_array_has_one() -> None:
    def general(value: Any) -> bytes:
        raise AssertionError

    assert fast_encoder(MultiArrayCodec("ByteMultiArray"), general) is None  # data are bytes

    class Scaled(MultiArrayCodec):
        """A user's codec: its to_fields may differ, so it is never bypassed."""

    assert fast_encoder(Scaled("Float64MultiArray"), general) is None
    assert fast_encoder(MultiArrayCodec("Float64MultiArray"), general) is not None
