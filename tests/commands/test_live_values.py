"""What the live tools print of a value, and the names they take (no ROS graph)."""

from __future__ import annotations

import array
import json
import math

import numpy as np
import pytest
from sensor_msgs.msg import CompressedImage, LaserScan
from std_msgs.msg import MultiArrayDimension, String

from pyconnect import codecs
from pyconnect.commands.common import UsageError
from pyconnect.commands.graph import expand_name
from pyconnect.commands.live_values import echo_json, echo_value, shown_text


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
