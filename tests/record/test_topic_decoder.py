"""``TopicDecoder``: when a bag's stored definition gives way to the installed type, and when not."""

from __future__ import annotations

import logging
import struct

import pytest

from pyconnect.codecs import wire
from pyconnect.errors import DecodeError
from pyconnect.record.topic_decoder import IN_A_ROW, TopicDecoder

# sensor_msgs/Range as Foxy recorded it: no `variance`, which the installed (Jazzy) type has.
FOXY_RANGE = """std_msgs/Header header
uint8 ULTRASOUND=0
uint8 INFRARED=1
uint8 radiation_type
float32 field_of_view
float32 min_range
float32 max_range
float32 range
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""
# std_msgs/String as a bag may wrongly store it: a field the installed type lacks.
TWO_STRINGS = "string data\nstring extra\n"


def foxy_range(i: int) -> bytes:
    return wire.wire_codec("sensor_msgs/msg/Range", definition=FOXY_RANGE).from_dict(
        {"header": {"stamp": {"sec": i, "nanosec": 0}, "frame_id": "sonar"}, "range": 1.0 + i}
    )


def strings_cdr(*texts: str) -> bytes:
    """Little-endian CDR of consecutive string fields."""
    out = bytearray(b"\x00\x01\x00\x00")
    for text in texts:
        out += -len(out[4:]) % 4 * b"\x00"
        raw = text.encode() + b"\x00"
        out += len(raw).to_bytes(4, "little") + raw
    return bytes(out)


def _decode(decoder: TopicDecoder, data: bytes, index: int, delivered: int) -> object:
    """What a bag read does with one message of topic /t (``index`` and ``delivered`` say
    where it stands in the topic; the decoder judges by its own messages alone)."""
    try:
        return decoder.decode(data)
    except Exception as error:
        return decoder.recover(data, error, topic="/t")


def test_one_damaged_message_amid_fitting_ones_stays_an_error() -> None:
    # Four bytes too many: the installed Range reads them as `variance`, and switching to it
    # made every intact message after this one fail (`Range.variance: truncated`).
    decoder = TopicDecoder("sensor_msgs/msg/Range", FOXY_RANGE, "ros2msg", natural=False)
    values = [_decode(decoder, foxy_range(i), i, i) for i in range(5)]
    with pytest.raises(DecodeError, match="4 bytes after the end of the message"):
        _decode(decoder, foxy_range(5) + b"\x01\x02\x03\x04", 5, 5)
    values += [_decode(decoder, foxy_range(i), i, i - 1) for i in range(6, 11)]
    assert [value["range"] for value in values] == [1.0 + i for i in range(11) if i != 5]  # type: ignore[index]
    assert not any("variance" in value for value in values)  # type: ignore[operator]
    assert decoder.codec.msg_type == "sensor_msgs/msg/Range" and not decoder.settled


def test_a_value_the_natural_codec_refuses_is_an_error_not_the_installed_layout() -> None:
    # The stored `float32 data` reads the bytes; Int32's natural codec refuses 1.5. The
    # installed int32 layout gave 1069547520, the bits of 1.5, as if it were the value.
    decoder = TopicDecoder("std_msgs/msg/Int32", "float32 data", "ros2msg", natural=True)
    data = b"\x00\x01\x00\x00" + struct.pack("<f", 1.5)
    with pytest.raises(DecodeError, match=r"Int32\.data: expected int, got float"):
        _decode(decoder, data, 0, 0)
    with pytest.raises(DecodeError, match=r"Int32\.data: expected int, got float"):
        _decode(decoder, data, 1, 0)
    assert not decoder.settled


def test_a_stored_definition_that_misfits_the_first_message_gives_way_with_a_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    decoder = TopicDecoder("std_msgs/msg/String", TWO_STRINGS, "ros2msg", natural=False)
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"):
        assert _decode(decoder, strings_cdr("a"), 0, 0) == {"data": "a"}
    assert decoder.settled
    assert _decode(decoder, strings_cdr("b"), 1, 1) == {"data": "b"}
    assert [(r.levelno, r.getMessage()) for r in caplog.records] == [
        (
            logging.WARNING,
            "/t: the definition of std_msgs/msg/String stored in the bag does not fit its first "
            "message (std_msgs/msg/String.extra: truncated: uint32 at offset 12 needs 4 bytes, "
            "0 left) and the installed type does: it decodes the rest of the topic",
        )
    ]


def test_misfits_in_a_row_after_fitting_messages_give_way() -> None:
    decoder = TopicDecoder("std_msgs/msg/String", TWO_STRINGS, "ros2msg", natural=False)
    assert _decode(decoder, strings_cdr("a", "x"), 0, 0) == {"data": "a", "extra": "x"}
    for index in range(1, IN_A_ROW):
        with pytest.raises(DecodeError, match="truncated"):
            _decode(decoder, strings_cdr("b"), index, 1)
    assert _decode(decoder, strings_cdr("c"), IN_A_ROW, 1) == {"data": "c"}
    assert decoder.settled
    assert [row[0] for row in decoder.codec.definitions["std_msgs/msg/String"][1]] == ["data"]


def test_misfits_apart_never_add_up() -> None:
    decoder = TopicDecoder("std_msgs/msg/String", TWO_STRINGS, "ros2msg", natural=False)
    delivered = 0
    for index in range(3 * IN_A_ROW):
        if index % 2 == 0:
            assert _decode(decoder, strings_cdr("a", "x"), index, delivered)
            delivered += 1
        else:
            with pytest.raises(DecodeError, match="truncated"):
                _decode(decoder, strings_cdr("b"), index, delivered)
    assert not decoder.settled


def test_a_message_neither_decodes_breaks_the_row() -> None:
    decoder = TopicDecoder("std_msgs/msg/String", TWO_STRINGS, "ros2msg", natural=False)
    assert _decode(decoder, strings_cdr("a", "x"), 0, 0)
    neither = b"\x00\x01\x00\x00\xff\xff\xff\x7f"  # a string length past the end
    # More misfits than IN_A_ROW, never IN_A_ROW of them in a row.
    for index in range(1, 2 * IN_A_ROW - 1):
        data = neither if index == IN_A_ROW - 1 else strings_cdr("b")
        with pytest.raises(DecodeError):
            _decode(decoder, data, index, 1)
    assert not decoder.settled


def test_a_decoder_judges_by_its_own_messages_not_the_topics() -> None:
    """A topic's other connections (another type, or the same type in another bag merged in)
    fit their own definitions: counting their messages as this definition's made a wrong
    stored definition keep its place, and every message of its connection was lost."""
    decoder = TopicDecoder("std_msgs/msg/String", TWO_STRINGS, "ros2msg", natural=False)
    # Messages 0, 2, 4... of the topic came from another connection; this one gets 1, 3, 5...
    assert _decode(decoder, strings_cdr("w0"), 1, 1) == {"data": "w0"}
    assert decoder.settled
    assert _decode(decoder, strings_cdr("w1"), 3, 2) == {"data": "w1"}
