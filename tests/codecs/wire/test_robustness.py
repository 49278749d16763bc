"""Malformed CDR: truncated, over-long, random and hostile buffers raise DecodeError with a path."""

from __future__ import annotations

import struct
import tracemalloc
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyconnect.codecs import wire
from pyconnect.errors import DecodeError
from tests.strategies import default_packages, message_dicts

_, TYPES = default_packages()
FUZZED = [
    "sensor_msgs/msg/Image",
    "sensor_msgs/msg/JointState",
    "sensor_msgs/msg/PointCloud2",
    "diagnostic_msgs/msg/DiagnosticArray",
    "test_msgs/msg/Arrays",
    "test_msgs/msg/BoundedSequences",
    "test_msgs/msg/UnboundedSequences",
    "test_msgs/msg/Strings",
    "test_msgs/msg/WStrings",
]
_FUZZ = settings(max_examples=40, deadline=None, database=None,
                 suppress_health_check=list(HealthCheck))  # fmt: skip
IMAGE = {
    "header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "cam"},
    "height": 1, "width": 2, "encoding": "mono8", "step": 2, "data": b"ab",
}  # fmt: skip


def decode_all_ways(data: bytes, full_name: str) -> None:
    codec = wire.wire_codec(full_name)
    codec.to_dict(data)
    codec.decode_view(data)


def decodes_or_names_the_type(data: bytes, full_name: str) -> None:
    """Decoding either works or raises a DecodeError whose text starts with the type's path."""
    try:
        decode_all_ways(data, full_name)
    except DecodeError as error:
        assert str(error).startswith(full_name), str(error)


def error_of(data: Any, full_name: str) -> str:
    with pytest.raises(DecodeError) as caught:
        wire.to_dict(data, full_name)
    return str(caught.value)


# -- exact messages ------------------------------------------------------------------------------
def test_length_prefix_beyond_the_buffer_names_the_field() -> None:
    cdr = bytearray(wire.from_dict(IMAGE, "sensor_msgs/msg/Image"))
    cdr[-8:-4] = struct.pack("<I", 0xFFFFFFFF)  # the length of `data`
    assert error_of(cdr, "sensor_msgs/msg/Image") == (
        "sensor_msgs/msg/Image.data: length 4294967295 exceeds the 4 bytes left"
    )


def test_truncated_run_names_the_first_missing_field() -> None:
    cdr = wire.from_dict(IMAGE, "sensor_msgs/msg/Image")
    assert error_of(cdr[:10], "sensor_msgs/msg/Image") == (
        "sensor_msgs/msg/Image.header.stamp.nanosec: truncated: uint32 at offset 8 needs "
        "4 bytes, 2 left"
    )


def test_trailing_bytes_beyond_padding_are_rejected() -> None:
    cdr = wire.from_dict(IMAGE, "sensor_msgs/msg/Image")
    # 50 bytes of message, 2 of padding: one more byte is still padding, four are not
    assert wire.to_dict(cdr + b"\x00", "sensor_msgs/msg/Image")["height"] == 1
    assert error_of(cdr + bytes(4), "sensor_msgs/msg/Image") == (
        "sensor_msgs/msg/Image: 6 bytes after the end of the message "
        "(at most 3 bytes of padding may follow it)"
    )


def test_rclpy_size_estimate_padding_is_accepted() -> None:
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    # rmw_serialize returns Fast DDS's size estimate, 8 bytes more than it writes here.
    cdr = serialize_message(JointState())
    assert len(cdr) - len(wire.from_dict({}, "sensor_msgs/msg/JointState")) == 8
    assert wire.to_dict(cdr, "sensor_msgs/msg/JointState")["name"] == []
    with pytest.raises(DecodeError, match="bytes after the end of the message"):
        wire.to_dict(cdr + bytes(4), "sensor_msgs/msg/JointState")


def test_bad_headers() -> None:
    assert error_of(b"\x00", "std_msgs/msg/String") == (
        "std_msgs/msg/String: 1 bytes is too short for a CDR encapsulation header"
    )
    assert error_of(b"\x00\x03\x00\x00\x00\x00\x00\x00", "std_msgs/msg/String") == (
        "std_msgs/msg/String: unsupported CDR encapsulation 0003 (expected 0001 little-endian or "
        "0000 big-endian XCDR1)"
    )


def test_sequence_over_its_bound() -> None:
    cdr = b"\x00\x01\x00\x00" + struct.pack("<I", 4) + bytes(4)
    assert error_of(cdr, "test_msgs/msg/BoundedSequences") == (
        "test_msgs/msg/BoundedSequences.bool_values: length 4 exceeds the bound 3"
    )


def test_index_of_a_bad_element_is_in_the_path() -> None:
    value = {"status": [{"name": "a"}, {"name": "b", "values": [{"key": "k"}]}]}
    cdr = bytearray(wire.from_dict(value, "diagnostic_msgs/msg/DiagnosticArray"))
    at = cdr.index(b"\x02\x00\x00\x00k\x00")  # the length of status[1].values[0].key
    cdr[at : at + 4] = struct.pack("<I", 1000)
    assert error_of(cdr, "diagnostic_msgs/msg/DiagnosticArray") == (
        "diagnostic_msgs/msg/DiagnosticArray.status[1].values[0].key: length 1000 exceeds the "
        "12 bytes left"
    )


@pytest.mark.parametrize("full_name", ["std_msgs/msg/Empty", "test_msgs/msg/Constants"])
def test_an_empty_message_without_its_byte(full_name: str) -> None:
    for decode in (wire.wire_codec(full_name).to_dict, wire.wire_codec(full_name).decode_view):
        with pytest.raises(DecodeError) as caught:
            decode(b"\x00\x01\x00\x00")
        assert str(caught.value) == f"{full_name}: truncated at offset 4 (0 bytes left)"


def test_huge_counts_never_allocate() -> None:
    # Image: the `data` count ends the buffer; PointCloud2: the `fields` count follows the
    # header (16 bytes), height and width.
    for full_name, count_at in (("sensor_msgs/msg/Image", 40), ("sensor_msgs/msg/PointCloud2", 28)):
        cdr = bytearray(wire.from_dict({}, full_name))
        cdr[count_at : count_at + 4] = b"\xff\xff\xff\xff"
        tracemalloc.start()
        with pytest.raises(DecodeError, match="length 4294967295"):
            wire.to_dict(cdr, full_name)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 100_000


# -- fuzzing -------------------------------------------------------------------------------------
@pytest.mark.parametrize("full_name", FUZZED)
@settings(_FUZZ, max_examples=15)
@given(st.data())
def test_every_truncation_raises(full_name: str, data: st.DataObject) -> None:
    cdr = wire.from_dict(data.draw(message_dicts(TYPES.get(full_name), TYPES)), full_name)
    lengths = range(len(cdr) - 3)
    if len(lengths) > 64:
        lengths = sorted(data.draw(st.sets(st.sampled_from(lengths), min_size=64, max_size=64)))
    for length in lengths:
        with pytest.raises(DecodeError):
            decode_all_ways(cdr[:length], full_name)


@pytest.mark.parametrize("full_name", FUZZED)
@_FUZZ
@given(st.data())
def test_corrupted_words_raise_only_decode_errors(full_name: str, data: st.DataObject) -> None:
    cdr = bytearray(
        wire.from_dict(data.draw(message_dicts(TYPES.get(full_name), TYPES)), full_name)
    )
    for _ in range(data.draw(st.integers(1, 4))):
        at = data.draw(st.integers(4, max(4, len(cdr) - 4)))
        cdr[at : at + 4] = data.draw(st.binary(min_size=4, max_size=4))
    decodes_or_names_the_type(bytes(cdr), full_name)


@pytest.mark.parametrize("full_name", FUZZED)
@_FUZZ
@given(header=st.sampled_from([b"\x00\x01\x00\x00", b"\x00\x00\x00\x00"]), body=st.binary())
def test_random_bytes_raise_only_decode_errors(full_name: str, header: bytes, body: bytes) -> None:
    decodes_or_names_the_type(header + body, full_name)


@pytest.mark.parametrize("full_name", FUZZED[:3])
@_FUZZ
@given(st.data())
def test_over_long_buffers_raise(full_name: str, data: st.DataObject) -> None:
    cdr = wire.from_dict(data.draw(message_dicts(TYPES.get(full_name), TYPES)), full_name)
    extra = data.draw(st.integers(100, 4096))
    with pytest.raises(DecodeError, match="bytes after the end of the message"):
        wire.to_dict(cdr + bytes(extra), full_name)


def test_every_input_kind_decodes(tmp_path: Any) -> None:
    import mmap

    cdr = wire.from_dict(IMAGE, "sensor_msgs/msg/Image")
    path = tmp_path / "image.cdr"
    path.write_bytes(cdr)
    with path.open("rb") as file, mmap.mmap(file.fileno(), 0, access=mmap.ACCESS_READ) as mapped:
        for data in (cdr, bytearray(cdr), memoryview(cdr), mapped):
            value = wire.to_dict(data, "sensor_msgs/msg/Image")
            assert value["data"] == b"ab"
            del value


@pytest.mark.parametrize(
    ("msg_type", "field"),
    [
        ("std_msgs/msg/String", "data"),  # the fast path
        ("std_msgs/msg/Header", "frame_id"),  # the generated decoder
        ("test_msgs/msg/UnboundedSequences", "string_values"),  # read_strings
    ],
)
def test_a_string_without_its_nul_reads_as_rclpy_reads_it(msg_type: str, field: str) -> None:
    """CDR counts the NUL that ends a string; Fast CDR keeps a last byte that is not NUL."""
    import importlib

    from rclpy.serialization import deserialize_message

    package, _, name = msg_type.split("/")
    cls = getattr(importlib.import_module(f"{package}.msg"), name)
    values: Any = ["ab"] if field == "string_values" else "ab"
    cdr = wire.from_dict({field: values}, msg_type)
    unterminated = cdr.replace(b"\x03\x00\x00\x00ab\x00", b"\x03\x00\x00\x00abc")
    assert unterminated != cdr
    expected = ["abc"] if field == "string_values" else "abc"
    assert getattr(deserialize_message(unterminated, cls), field) == expected
    assert wire.to_dict(unterminated, msg_type)[field] == expected
    if msg_type == "std_msgs/msg/String":  # its natural value is the str, read by the fast path
        assert wire.decode(unterminated, msg_type) == expected
