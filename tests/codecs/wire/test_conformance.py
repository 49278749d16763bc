"""Wire codecs against rclpy's serializer, both directions, for every generated message type."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

from pyconnect import codecs
from pyconnect.codecs import wire
from tests.codecs.wire.normalise import plain
from tests.strategies import default_packages, message_dicts, same_value

PACKAGES, TYPES = default_packages()
ALL_TYPES = sorted(m.full_name for p in PACKAGES.values() for m in p.all_messages)
# MultiNested nests arrays of every sequence kind three deep: hypothesis spends seconds on each
# example, so it gets few (its parts are covered in depth one level down).
HEAVY_TYPES = {"test_msgs/msg/MultiNested"}
CORNER_TYPES = [n for n in ALL_TYPES if n.startswith("test_msgs/msg/") and n not in HEAVY_TYPES]
_QUICK = settings(
    max_examples=4, deadline=None, database=None, suppress_health_check=list(HealthCheck)
)
_DEEP = settings(
    max_examples=60, deadline=None, database=None, suppress_health_check=list(HealthCheck)
)


def check_both_directions(full_name: str, data: dict[str, Any]) -> None:
    dict_codec = codecs.default_registry.lookup_dict(full_name)
    msg = dict_codec.from_dict(data)
    expected = dict_codec.to_dict(msg)
    # rclpy -> wire
    decoded = wire.to_dict(serialize_message(msg), full_name)
    assert same_value(plain(decoded), expected), (plain(decoded), expected)
    # wire -> rclpy
    back = deserialize_message(wire.from_dict(data, full_name), dict_codec.msg_class)
    assert same_value(dict_codec.to_dict(back), expected)
    # our own big-endian writer and reader agree with the little-endian ones
    big = wire.wire_codec(full_name).from_dict(data, big_endian=True)
    assert same_value(plain(wire.to_dict(big, full_name)), expected)


def test_every_package_type_is_covered() -> None:
    assert len(ALL_TYPES) > 250
    assert "sensor_msgs/msg/Image" in ALL_TYPES and "test_msgs/msg/WStrings" in ALL_TYPES


@pytest.mark.parametrize("full_name", ALL_TYPES)
def test_every_type_both_directions(full_name: str) -> None:
    @(_QUICK if full_name not in HEAVY_TYPES else settings(_QUICK, max_examples=1))
    @given(message_dicts(TYPES.get(full_name), TYPES))
    def run(data: dict[str, Any]) -> None:
        check_both_directions(full_name, data)

    run()


@pytest.mark.parametrize("full_name", CORNER_TYPES)
def test_corner_types_in_depth(full_name: str) -> None:
    @_DEEP
    @given(message_dicts(TYPES.get(full_name), TYPES))
    def run(data: dict[str, Any]) -> None:
        check_both_directions(full_name, data)

    run()


@pytest.mark.parametrize(
    "full_name", ["test_msgs/msg/UnboundedSequences", "sensor_msgs/msg/JointState"]
)
@_DEEP
@given(st.data())
def test_views_hold_the_dict_values(full_name: str, data: st.DataObject) -> None:
    value = data.draw(message_dicts(TYPES.get(full_name), TYPES))
    cdr = wire.from_dict(value, full_name)
    as_dict = wire.to_dict(cdr, full_name)
    view = wire.wire_codec(full_name).decode_view(cdr)
    assert type(view).__slots__ == tuple(as_dict)
    assert same_value(plain(view_to_dict(view)), plain(as_dict))


def view_to_dict(view: Any) -> Any:
    if isinstance(view, list):
        return [view_to_dict(v) for v in view]
    if hasattr(type(view), "__msgtype__") and hasattr(type(view), "__slots__"):
        return {name: view_to_dict(getattr(view, name)) for name in type(view).__slots__}
    return view


def test_empty_struct_is_one_byte() -> None:
    from std_msgs.msg import Empty

    assert wire.from_dict({}, "std_msgs/msg/Empty") == b"\x00\x01\x00\x00\x00\x00\x00\x00"
    assert wire.to_dict(serialize_message(Empty()), "std_msgs/Empty") == {}
    assert deserialize_message(wire.from_dict({}, "test_msgs/msg/Empty"), Empty) == Empty()


def test_wstrings_are_utf16_units_in_four_byte_wchars() -> None:
    from test_msgs.msg import WStrings

    cdr = serialize_message(WStrings(wstring_value="a\U0001f600"))
    # count 3 (a, and the surrogate pair), then each unit as a little-endian uint32
    assert bytes(cdr[4:20]).hex() == "03000000610000003dd8000000de0000"
    assert wire.to_dict(cdr, "test_msgs/msg/WStrings")["wstring_value"] == "a\U0001f600"
    ours = wire.from_dict({"wstring_value": "a\U0001f600"}, "test_msgs/msg/WStrings")
    assert deserialize_message(ours, WStrings).wstring_value == "a\U0001f600"


def test_empty_sequences_of_doubles_are_not_aligned() -> None:
    from test_msgs.msg import UnboundedSequences

    msg = UnboundedSequences(float64_values=[], int8_values=[7])
    decoded = wire.to_dict(serialize_message(msg), "test_msgs/msg/UnboundedSequences")
    assert decoded["int8_values"] == [7]
    ours = wire.from_dict({"int8_values": [7]}, "test_msgs/msg/UnboundedSequences")
    assert list(deserialize_message(ours, UnboundedSequences).int8_values) == [7]


def test_missing_keys_take_the_defaults() -> None:
    from test_msgs.msg import Defaults

    cdr = wire.from_dict({}, "test_msgs/msg/Defaults")
    dict_codec = codecs.default_registry.lookup_dict("test_msgs/msg/Defaults")
    assert dict_codec.to_dict(deserialize_message(cdr, Defaults)) == dict_codec.to_dict(Defaults())


@pytest.mark.parametrize("full_name", ["sensor_msgs/msg/PointCloud2", "test_msgs/msg/Arrays"])
@_QUICK
@given(st.data())
def test_views_encode_like_their_dicts(full_name: str, data: st.DataObject) -> None:
    cdr = wire.from_dict(data.draw(message_dicts(TYPES.get(full_name), TYPES)), full_name)
    codec = wire.wire_codec(full_name)
    again = codec.from_dict(codec.decode_view(cdr))
    assert same_value(plain(codec.to_dict(again)), plain(codec.to_dict(cdr)))
