"""What a codec is (pyconnect.codecs.base): a dict codec handed a message of another type."""

from __future__ import annotations

import pytest

from pyconnect import codecs
from pyconnect.codecs.base import wrong_message
from pyconnect.errors import DecodeError


def test_a_dict_codec_given_a_message_of_another_type_names_both_types() -> None:
    # It raised the generated code's bare "'Point' object has no attribute '_key'".
    from diagnostic_msgs.msg import KeyValue
    from geometry_msgs.msg import Point

    codec = codecs.lookup(KeyValue)
    with pytest.raises(DecodeError) as raised:
        codec.decode(Point())
    assert str(raised.value) == "expected diagnostic_msgs/msg/KeyValue, got geometry_msgs/msg/Point"
    assert codec.decode(KeyValue(key="k", value="v")) == {"key": "k", "value": "v"}


def test_wrong_message_names_a_class_and_a_non_message() -> None:
    from geometry_msgs.msg import Point

    assert str(wrong_message(Point, "a message")) == (
        "expected a message, got the class Point; did you mean Point()?"
    )
    assert str(wrong_message({"x": 1}, "geometry_msgs/msg/Point")) == (
        "expected geometry_msgs/msg/Point, got dict"
    )


def test_wrong_message_names_the_type_expected_for_the_class_of_another_type() -> None:
    # "did you mean Point()?" is only right when a Point is what the codec wants.
    from geometry_msgs.msg import Point

    assert str(wrong_message(Point, "geometry_msgs/msg/Point")) == (
        "expected a message, got the class Point; did you mean Point()?"
    )
    assert str(wrong_message(Point, "std_msgs/msg/String")) == (
        "expected std_msgs/msg/String, got the class Point"
    )
    assert str(wrong_message("geometry_msgs/msg/Point", "std_msgs/msg/String")) == (
        "expected std_msgs/msg/String, got str"
    )
