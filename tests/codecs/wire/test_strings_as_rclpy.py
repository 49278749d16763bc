"""A CDR string's bytes read as rclpy reads them: up to the first NUL, bad UTF-8 as U+FFFD.

A C++ node may publish Latin-1 text or a fixed-size buffer padded with NULs; rclpy delivers
``'25�C'`` and ``'abc'`` for them, so the raw path, peers and bags must too (the same value
as the class path), through every decoder that reads strings: a generated one, the string
sequence reader, one compiled on the fly from a definition, and the ``String`` fast path.
"""

from __future__ import annotations

import struct
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message
from std_msgs.msg import String
from test_msgs.msg import UnboundedSequences

from pyconnect.codecs import Registry, wire

HEADER = b"\x00\x01\x00\x00"
ODD_TEXTS = [
    b"25\xb0C\x00",  # Latin-1
    b"\xff\x00",
    b"abc\x00\x00\x00\x00\x00",  # a NUL-padded buffer
    b"str\x00ngs\x00",
    b"a\x00",
    b"\x00",
    b"no terminating NUL",
    b"\xe2\x82",  # a cut multi-byte sequence, no NUL
]


def string_cdr(raw: bytes) -> bytes:
    """A std_msgs/String whose length word counts ``raw`` as it is."""
    return HEADER + struct.pack("<I", len(raw)) + raw + bytes(-len(raw) % 4)


def sequence_cdr(raw: bytes) -> bytes:
    """A test_msgs/UnboundedSequences whose one ``string_values`` element is ``raw``."""
    placeholder = "#" * (len(raw) - 1)
    # Written by the wire codec: exactly the message's bytes, as a publisher sends them
    # (serialize_message pads to Fast DDS's size estimate, which the decoder checks against
    # the decoded value, whose strings here may be shorter than their bytes).
    cdr = wire.from_dict({"string_values": [placeholder]}, "test_msgs/msg/UnboundedSequences")
    # The sequence's count (1), the string's length, its text and NUL: every other sequence
    # of the default message is empty.
    at = cdr.index(struct.pack("<II", 1, len(raw)) + placeholder.encode() + b"\x00") + 8
    return cdr[:at] + raw + cdr[at + len(raw) :]


@pytest.mark.parametrize("raw", ODD_TEXTS)
def test_a_string_field_reads_as_rclpy_reads_it(raw: bytes) -> None:
    cdr = string_cdr(raw)
    expected = deserialize_message(cdr, String).data
    assert wire.to_dict(cdr, "std_msgs/msg/String") == {"data": expected}
    assert wire.decode(cdr, "std_msgs/msg/String") == expected  # the natural value's fast path


@pytest.mark.parametrize("raw", ODD_TEXTS)
def test_a_string_sequence_element_reads_as_rclpy_reads_it(raw: bytes) -> None:
    cdr = sequence_cdr(raw)
    expected = list(deserialize_message(cdr, UnboundedSequences).string_values)
    assert wire.to_dict(cdr, "test_msgs/msg/UnboundedSequences")["string_values"] == expected


@pytest.mark.parametrize("raw", ODD_TEXTS)
def test_a_string_of_a_type_compiled_on_the_fly_reads_as_rclpy_reads_it(raw: bytes) -> None:
    # A bag's own definition of the same layout, compiled from its text.
    codec = wire.register_definition("bag_pkg/msg/Note", "string text\n", registry=Registry())
    assert codec.to_dict(string_cdr(raw)) == {"text": deserialize_message(string_cdr(raw), String).data}


@settings(max_examples=200, deadline=None)
@given(raw=st.binary(max_size=24))
def test_any_string_bytes_read_as_rclpy_reads_them(raw: bytes) -> None:
    cdr = string_cdr(raw)
    expected: Any = deserialize_message(cdr, String).data
    assert wire.to_dict(cdr, "std_msgs/msg/String") == {"data": expected}
    assert wire.decode(cdr, "std_msgs/msg/String") == expected
    if raw:  # a sequence element counts at least its NUL
        cdr = sequence_cdr(raw)
        element = wire.to_dict(cdr, "test_msgs/msg/UnboundedSequences")["string_values"]
        assert element == list(deserialize_message(cdr, UnboundedSequences).string_values)


def test_a_decoded_string_encodes_again() -> None:
    # A value read from a NUL-padded buffer holds no NUL, so sending it on is not refused.
    value = wire.decode(string_cdr(b"abc\x00\x00\x00\x00\x00"), "std_msgs/msg/String")
    assert deserialize_message(wire.encode(value, "std_msgs/msg/String"), String).data == "abc"
