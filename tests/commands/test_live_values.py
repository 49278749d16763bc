"""What the live tools print of a value, and the names they take (no ROS graph)."""

from __future__ import annotations

import array
import json
import math

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CompressedImage, Image, LaserScan
from std_msgs.msg import MultiArrayDimension, String
from stereo_msgs.msg import DisparityImage
from test_msgs.action import Fibonacci
from test_msgs.msg import Arrays, BasicTypes, Nested

from pyconnect import codecs
from pyconnect.commands.common import UsageError
from pyconnect.commands.graph import expand_name, message_class
from pyconnect.commands.live_values import echo_json, echo_value, shown_text
from pyconnect.commands.topic_subscribe import echo_field
from pyconnect.commands.value_text import format_value


def test_json_of_a_dataclass_natural_value() -> None:
    scan = LaserScan(angle_min=-1.0, angle_max=1.0, range_max=10.0, ranges=[1.0, math.inf])
    assert json.loads(echo_json(echo_value(scan))) == {
        "ranges": [1.0, "inf"],
        "intensities": [],
        "angle_min": -1.0,
        "angle_max": 1.0,
        "angle_increment": 0.0,
        "time_increment": 0.0,
        "scan_time": 0.0,
        "range_min": 0.0,
        "range_max": 10.0,
    }
    info = {"width": 2, "height": 1, "resolution": 0.5}
    grid = codecs.from_dict({"info": info, "data": [0, 100]}, "nav_msgs/msg/OccupancyGrid")
    assert json.loads(echo_json(echo_value(grid))) == {
        "cells": [[0, 100]],
        "resolution": 0.5,
        "origin": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
        "map_load_time": [0, 0],
    }


def test_json_of_sequence_fields_and_what_json_does_not_know() -> None:
    assert echo_json(array.array("d", [1.0, 2.5])) == "[1.0, 2.5]"
    assert echo_json(array.array("i", [])) == "[]"
    assert echo_json([MultiArrayDimension(label="x", size=2, stride=2)]) == (
        '[{"label": "x", "size": 2, "stride": 2}]'
    )
    assert echo_json({"when": np.float32("nan"), "bits": b"\x01\x02"}) == (
        '{"when": "nan", "bits": [1, 2]}'
    )

    class Odd:
        def __repr__(self) -> str:
            return "Odd()"

    assert echo_json({"odd": Odd()}) == '{"odd": "Odd()"}'


def test_a_message_its_codec_cannot_decode_is_shown_by_its_fields() -> None:
    bad = CompressedImage(format="jpeg", data=b"notajpeg")
    assert shown_text(bad) == (
        "{'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': ''}, 'format': 'jpeg', "
        "'data': b'notajpeg'}",
        "CompressedImage.data: cannot decode 8 bytes as jpeg",
    )
    text, problem = shown_text(bad, as_json=True)
    assert json.loads(text or "")["data"] == list(b"notajpeg")
    assert problem == "CompressedImage.data: cannot decode 8 bytes as jpeg"
    assert shown_text(String(data="hi")) == ("'hi'", None)


@pytest.mark.parametrize(
    ("name", "full"),
    [
        ("chatter", "/chatter"),
        ("/chatter", "/chatter"),
        ("robot/cmd_vel", "/robot/cmd_vel"),
        ("~/state", "/_pyconnect_cli/state"),
    ],
)
def test_names_are_expanded_as_rclpy_does(name: str, full: str) -> None:
    assert expand_name(name) == full


@pytest.mark.parametrize(
    ("name", "error"),
    [
        (
            "bad name",
            "topic name 'bad name' is invalid: topic name must not contain characters other "
            "than alphanumerics, '_', '~', '{', or '}'",
        ),
        ("/a//b", "Invalid topic name: topic name must not contain repeated '/': '/a//b'"),
    ],
)
def test_a_name_rcl_refuses_is_a_usage_error(name: str, error: str) -> None:
    with pytest.raises(UsageError) as caught:
        expand_name(name)
    assert str(caught.value) == error


def test_a_long_sequence_field_is_summarised_as_a_list() -> None:
    # rclpy holds numeric sequences as array.array: a 640x480 image's data was one 2.7 MB line.
    assert format_value(array.array("B", bytes(921_600))) == (
        f"[{', '.join(['0'] * 16)}, ... 921584 more]"
    )
    assert format_value({"ranges": array.array("f", [1.0, 2.5])}) == "{'ranges': [1.0, 2.5]}"


def test_a_field_is_shown_as_the_whole_message_shows_it() -> None:
    basic = BasicTypes(byte_value=b"\x07", uint8_value=7)
    whole = json.loads(shown_text(basic, as_json=True)[0] or "")
    for name in ("byte_value", "uint8_value"):
        assert shown_text(echo_field(basic, name), as_json=True) == (str(whole[name]), None)
        assert shown_text(echo_field(basic, name)) == ("7", None)
    arrays = Arrays(byte_values=[b"\x01", b"\x02", b"\x03"])
    assert json.loads(shown_text(arrays, as_json=True)[0] or "")["byte_values"] == [1, 2, 3]
    assert shown_text(echo_field(arrays, "byte_values"), as_json=True) == ("[1, 2, 3]", None)
    assert shown_text(echo_field(Nested(), "basic_types_value.byte_value")) == ("0", None)
    image = Image(height=480, width=640, encoding="rgb8", step=1920, data=bytes(921_600))
    assert shown_text(echo_field(image, "data")) == ("<921600 bytes>", None)
    # A message field keeps its field names, as bag echo and ros2 show it (Time's natural
    # tuple and Point's dropped them).
    assert shown_text(echo_field(image, "header.stamp")) == ("{'sec': 0, 'nanosec': 0}", None)
    odometry = Odometry()
    odometry.pose.pose.position.x = 1.0
    assert shown_text(echo_field(odometry, "pose.pose.position"), as_json=True) == (
        '{"x": 1.0, "y": 0.0, "z": 0.0}',
        None,
    )
    assert json.loads(shown_text(odometry, as_json=True)[0] or "")["pose"]["pose"]["position"] == {
        "x": 1.0,
        "y": 0.0,
        "z": 0.0,
    }
    disparity = DisparityImage()  # an image field stays an image, shown by its summary
    assert isinstance(echo_field(disparity, "image"), Image)


def test_the_type_of_an_action_topic_is_a_message_class() -> None:
    feedback = message_class("test_msgs/action/Fibonacci_FeedbackMessage")
    assert feedback is Fibonacci.Impl.FeedbackMessage
    assert message_class("std_msgs/String") is String
    with pytest.raises(Exception) as caught:
        message_class("std_msgs/msg/Nope")
    assert str(caught.value) == (
        "std_msgs/msg/Nope: no such interface is installed (module 'std_msgs.msg' has no "
        "attribute 'Nope')"
    )
