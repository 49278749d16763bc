"""The flat-MultiArray fast paths give exactly the general path's bytes, values and errors.

The transport's tests (tests/transport/test_fast_paths.py) hold String and the numbers to the
same rule; ``pub`` agents use these encoders too (tests/ros/test_raw_path.py compares their
messages with the class path's).
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from pyconnect.codecs import default_registry, wire
from pyconnect.codecs.fast_paths import FAST_DECODE_BYTES, fast_decoder, fast_encoder
from pyconnect.codecs.multi_array import DTYPES, MultiArrayCodec
from pyconnect.ros.raw_path import RawDecoder

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


# -- decoding: a sub agent's raw path (writable arrays over a copy) ----------------------------
def decoders(type_name: str) -> tuple[Any, Any]:
    """(the fast decoder, the raw path's general one: writable buffer -> view -> codec)."""
    general = RawDecoder(msg_type=type_name, registry=default_registry)._general_value
    fast = fast_decoder(default_registry.value_codec(type_name), general)
    assert fast is not None, type_name
    return fast, general


def decoded(decode: Any, payload: bytes) -> tuple[Any, ...]:
    try:
        value = decode(payload)
    except Exception as error:
        return type(error).__name__, str(error)
    return "array", value.dtype.str, value.shape, value.tobytes(), value.flags.writeable


def payloads(type_name: str) -> st.SearchStrategy[bytes]:
    """What a publisher sends: pyconnect's flat layout, rclpy's bare one, any layout; each
    maybe with bytes flipped, cut short or extended."""
    name = type_name.rsplit("/", 1)[1]
    dtype = DTYPES[name]
    message_class = getattr(importlib.import_module("std_msgs.msg"), name)
    elements = hnp.arrays(dtype=dtype, shape=st.integers(0, 40))
    labels = st.sampled_from(["", "x", "rows"])
    dims = st.lists(st.tuples(labels, st.integers(0, 50), st.integers(0, 50)), max_size=2)

    def by_rclpy(data: Any, layout: list[tuple[str, int, int]], offset: int) -> bytes:
        msg = message_class(data=data.tolist())
        msg.layout.dim = [MultiArrayDimension(label=t, size=n, stride=s) for t, n, s in layout]
        msg.layout.data_offset = offset
        return bytes(serialize_message(msg))

    clean = st.one_of(
        elements.map(lambda data: wire.wire_codec(type_name).encode(data)),
        st.builds(by_rclpy, elements, st.just([]), st.just(0)),
        st.builds(by_rclpy, elements, dims, st.integers(0, 3)),
    )

    def spoil(payload: bytes, where: int, byte: int, how: int) -> bytes:
        if how == 0 or not payload:
            return payload
        if how == 1:
            index = where % len(payload)
            return payload[:index] + bytes([byte]) + payload[index + 1 :]
        if how == 2:
            return payload[: where % len(payload)]
        return payload + bytes([byte]) * (where % 6)

    return st.builds(spoil, clean, st.integers(0, 10**6), st.integers(0, 255), st.integers(0, 3))


@pytest.mark.parametrize("type_name", FLAT_TYPES)
@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_decode_equals_the_general_path(type_name: str, data: st.DataObject) -> None:
    fast, general = decoders(type_name)
    payload = data.draw(payloads(type_name))
    assert decoded(fast, payload) == decoded(general, payload)


@pytest.mark.parametrize("type_name", FLAT_TYPES)
def test_both_flat_layouts_are_read_straight_into_writable_arrays(type_name: str) -> None:
    name = type_name.rsplit("/", 1)[1]
    values = np.arange(1, 8).astype(DTYPES[name])
    message_class = getattr(importlib.import_module("std_msgs.msg"), name)
    calls: list[bytes] = []
    fast = fast_decoder(default_registry.value_codec(type_name), calls.append)
    assert fast is not None
    for payload in (
        wire.wire_codec(type_name).encode(values),  # one dimension, what a pub agent sends
        bytes(serialize_message(message_class(data=values.tolist()))),  # no layout, rclpy's
    ):
        value = fast(payload)
        assert value.tolist() == values.tolist() and value.dtype == values.dtype
        value[0] = 0  # writable, and over a copy: the payload is untouched
        assert fast(payload)[0] == values[0]
    assert calls == []


def test_a_large_payload_keeps_the_general_path_which_copies_nothing() -> None:
    fast, _ = decoders("std_msgs/msg/Float64MultiArray")
    calls: list[bytes] = []
    straight = fast_decoder(default_registry.value_codec("std_msgs/msg/Float64MultiArray"),
                            calls.append)  # fmt: skip
    assert straight is not None
    payload = wire.wire_codec("std_msgs/msg/Float64MultiArray").encode(np.zeros(FAST_DECODE_BYTES))
    straight(payload)
    assert calls == [payload]
    assert fast(payload).shape == (FAST_DECODE_BYTES,)
