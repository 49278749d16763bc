"""VALUE parsing for ``topic pub``, ``service call`` and ``action send_goal`` (no ROS graph)."""

from __future__ import annotations

import json
import math
import sys
from typing import Any

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Path
from std_msgs.msg import (
    Float32,
    Float32MultiArray,
    Float64,
    Float64MultiArray,
    Int8MultiArray,
    Int32MultiArray,
    String,
    UInt8MultiArray,
)
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci
from test_msgs.msg import Arrays, BasicTypes, Builtins, Strings, WStrings

from pyconnect.cli import main
from pyconnect.commands import value_input
from pyconnect.commands.graph import CommandFailed
from pyconnect.commands.value_input import (
    OverflowedFloat,
    Yaml12Loader,
    message_from_text,
    message_template,
)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("1e-3", 0.001),
        ("1E-2", 0.01),
        ("2.5e3", 2500.0),
        ("-1e3", -1000.0),
        ("+.5e1", 5.0),
        ("1.0", 1.0),
        (".5", 0.5),
        ("1_000.5", 1000.5),
        (".inf", math.inf),
        ("-.inf", -math.inf),
    ],
)
def test_yaml_1_2_floats(text: str, expected: float) -> None:
    value = yaml.load(text, Loader=Yaml12Loader)
    assert type(value) is float
    assert value == expected


@pytest.mark.parametrize(
    ("text", "expected"),
    [("12", 12), ("-3", -3), ("0x1F", 31), ("e3", "e3"), ("1e", "1e"), (".", "."), ("now", "now")],
)
def test_what_is_no_float_stays_as_it_was(text: str, expected: object) -> None:
    value = yaml.load(text, Loader=Yaml12Loader)
    assert (type(value), value) == (type(expected), expected)


def test_nan_is_a_float() -> None:
    assert math.isnan(yaml.load(".nan", Loader=Yaml12Loader))


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("017", 17),  # YAML 1.1: octal 15
        ("0o17", 15),  # YAML 1.1: a string
        ("0x1F", 31),
        ("0", 0),
        ("-017", -17),
        ("+12", 12),
        ("1_000", 1000),
        ("1:30", "1:30"),  # YAML 1.1: base 60, 90
        ("12:30", "12:30"),
        ("0b11", "0b11"),  # YAML 1.1: binary 3
        ("-0x1F", "-0x1F"),
        ("0o8", "0o8"),
        ("0x", "0x"),
    ],
)
def test_yaml_1_2_ints(text: str, expected: object) -> None:
    value = yaml.load(text, Loader=Yaml12Loader)
    assert (type(value), value) == (type(expected), expected)


@pytest.mark.parametrize(("text", "expected"), [("yes", True), ("off", False), ("~", None)])
def test_other_scalars_stay_as_ros2_reads_them(text: str, expected: object) -> None:
    # Only numbers are YAML 1.2's: ros2 topic pub reads `yes` as true (PyYAML's YAML 1.1).
    assert yaml.load(text, Loader=Yaml12Loader) is expected


def test_yaml_1_2_ints_in_fields() -> None:
    basic = message_from_text("{int32_value: 017, uint16_value: 0o17}", BasicTypes)
    assert (basic.int32_value, basic.uint16_value) == (17, 15)
    assert message_from_text("{string_value: 12:30}", Strings).string_value == "12:30"
    assert message_from_text("{data: 0b11}", String) == String(data="0b11")
    with pytest.raises(CommandFailed) as caught:
        message_from_text("{int32_value: 1:30}", BasicTypes)
    assert str(caught.value) == "BasicTypes.int32_value: expected int (int32), got str"


def test_a_json_surrogate_pair_is_the_character_it_escapes() -> None:
    # json.dumps (and so `--json`) writes U+1F600 as the escape pair \ud83d\ude00.
    text = json.dumps({"data": "a\U0001f600b\U0010ffff"})
    assert "\\ud83d\\ude00" in text
    assert message_from_text(text, String) == String(data="a\U0001f600b\U0010ffff")
    nested = json.dumps({"string_values": ["\U0001f600", "x", "\U0001f600\U0001f600"]})
    arrays = message_from_text(nested, Arrays)
    assert list(arrays.string_values) == ["\U0001f600", "x", "\U0001f600\U0001f600"]
    wide = message_from_text(json.dumps({"wstring_value": "\U0001f600"}), WStrings)
    assert wide.wstring_value == "\U0001f600"


@pytest.mark.parametrize(
    "escaped", ["\\ud83d", "a\\ude00", "\\ude00\\ud83d", "\\ud83d\\ude00\\ud83d"]
)
def test_a_lone_surrogate_is_still_refused(escaped: str) -> None:
    with pytest.raises(CommandFailed) as caught:
        message_from_text(f'{{"data": "{escaped}"}}', String)
    assert str(caught.value) == "String.data: cannot encode as UTF-8 (surrogates not allowed)"


def test_exponents_in_fields_and_natural_values() -> None:
    assert message_from_text('{"data": 1e-3}', Float64) == Float64(data=0.001)
    assert message_from_text("1e-3", Float64) == Float64(data=0.001)
    twist = message_from_text('{"linear": {"x": 1E-2}, "angular": {"z": 2.5e3}}', Twist)
    assert (twist.linear.x, twist.angular.z) == (0.01, 2500.0)


_BEYOND_FLOAT64 = (
    "expected a number within float64's range (|x| <= 1.7976931348623157e+308; "
    ".inf and -.inf are infinity), got "
)


@pytest.mark.parametrize(
    ("text", "msg_class", "error"),
    [
        ("data: 1e400", Float32, "Float32.data: " + _BEYOND_FLOAT64 + "1e400"),
        ("data: 1e400", Float64, "Float64.data: " + _BEYOND_FLOAT64 + "1e400"),
        ("data: -1e999", Float64, "Float64.data: " + _BEYOND_FLOAT64 + "-1e999"),
        ("data: 1.8e308", Float64, "Float64.data: " + _BEYOND_FLOAT64 + "1.8e308"),
        ("data: !!float 1e400", Float64, "Float64.data: " + _BEYOND_FLOAT64 + "1e400"),
        ('{"data": 1e400}', Float64, "Float64.data: " + _BEYOND_FLOAT64 + "1e400"),
        ("-1E+400", Float64, "Float64: " + _BEYOND_FLOAT64 + "-1E+400"),
        ("{linear: {x: 1, y: 2e400}}", Twist, "Twist.linear.y: " + _BEYOND_FLOAT64 + "2e400"),
        ("[1, 1e400]", Float64MultiArray, "Float64MultiArray[1]: " + _BEYOND_FLOAT64 + "1e400"),
        ("{data: [0.5, -1_0e400]}", Float32MultiArray,
         "Float32MultiArray.data[1]: " + _BEYOND_FLOAT64 + "-1_0e400"),
    ],
)  # fmt: skip
def test_a_float_beyond_float64_is_refused_not_infinity(
    text: str, msg_class: Any, error: str
) -> None:
    # Python's float("1e400") is inf, which a float64 field took while float32 refused 1e40.
    with pytest.raises(CommandFailed) as caught:
        message_from_text(text, msg_class)
    assert str(caught.value) == error


def test_only_inf_spells_infinity() -> None:
    assert message_from_text("data: .inf", Float64) == Float64(data=math.inf)
    assert message_from_text("data: -.Inf", Float32) == Float32(data=-math.inf)
    assert message_from_text("data: !!float -.INF", Float64) == Float64(data=-math.inf)
    largest = message_from_text("data: 1.7976931348623157e308", Float64)
    assert largest == Float64(data=1.7976931348623157e308)
    overflowed = yaml.load("1e400", Loader=Yaml12Loader)
    assert (type(overflowed), overflowed, overflowed.text) == (OverflowedFloat, math.inf, "1e400")


def test_a_float_beyond_float64_is_one_line_from_topic_pub(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # Refused before any ROS graph is joined, with the status of every other bad VALUE.
    argv = ["topic", "pub", "--once", "--timeout", "1", "/x", "std_msgs/msg/Float64"]
    argv.append('{"data": -1e400}')
    assert main(argv) == 1
    error = "pyconnect: error: Float64.data: " + _BEYOND_FLOAT64 + "-1e400\n"
    assert capsys.readouterr().err == error


@pytest.mark.parametrize(
    ("text", "msg_class", "error"),
    [
        ("&a [*a]", String, "alias *a is inside the node &a names in \"<unicode string>\", "
         "line 1, column 5: &a [*a] ^"),
        ("&a {data: *a}", String, "alias *a is inside the node &a names in \"<unicode string>\", "
         "line 1, column 11: &a {data: *a} ^"),
        ("{data: &a [*a]}", String, "alias *a is inside the node &a names in \"<unicode string>\", "
         "line 1, column 12: {data: &a [*a]} ^"),
        ("{linear: &v {x: 1, y: [*v]}}", Twist, "alias *v is inside the node &v names in "
         "\"<unicode string>\", line 1, column 24: {linear: &v {x: 1, y: [*v]}} ^"),
        ("{data: &b [1, &a [*b]]}", SetBool.Request, "alias *b is inside the node &b names in "
         "\"<unicode string>\", line 1, column 19: {data: &b [1, &a [*b]]} ^"),
    ],
)  # fmt: skip
def test_a_value_that_holds_itself_is_refused(text: str, msg_class: Any, error: str) -> None:
    # PyYAML builds a list that holds itself, and every walk over it ran into RecursionError.
    with pytest.raises(CommandFailed) as caught:
        message_from_text(text, msg_class)
    assert str(caught.value) == "VALUE cannot hold itself: " + error


def test_an_alias_beside_its_anchor_still_repeats_the_value() -> None:
    twist = message_from_text("{linear: &v {x: 1, y: 2}, angular: *v}", Twist)
    assert (twist.linear.y, twist.angular.x, twist.angular.y) == (2.0, 1.0, 2.0)
    arrays = message_from_text("{int32_values: &n [1, 2, 3], uint8_values: *n}", Arrays)
    assert (list(arrays.int32_values), list(arrays.uint8_values)) == ([1, 2, 3], [1, 2, 3])


@pytest.mark.parametrize("depth", [101, 400, 900, 5000])
@pytest.mark.parametrize("opening", ["[", "{a: ["])
@pytest.mark.parametrize("recursion_limit", [1000, 20_000])
def test_a_value_nested_too_deeply_is_refused(
    opening: str, depth: int, recursion_limit: int
) -> None:
    # 900 levels overflowed PyYAML's composer and 400 the walks after it, at Python's default
    # limit; where something had raised it (hypothesis does) they passed: the bound is ours.
    before = sys.getrecursionlimit()
    sys.setrecursionlimit(recursion_limit)
    try:
        closing = "]" if opening == "[" else "]}"
        with pytest.raises(CommandFailed) as caught:
            message_from_text(opening * depth + closing * depth, String)
    finally:
        sys.setrecursionlimit(before)
    assert str(caught.value) == (
        "VALUE is nested too deeply: more than 100 levels of lists and mappings"
    )


@pytest.mark.parametrize(
    ("text", "got"),
    [("[" * 100 + "1" + "]" * 100, "tuple"), ("{data: " + "{a: " * 99 + "1" + "}" * 100, "dict")],
)
def test_a_value_nested_as_deep_as_allowed_is_read(text: str, got: str) -> None:
    # 100 levels holding a scalar: the scalar counted as a 101st level.
    with pytest.raises(CommandFailed) as caught:
        message_from_text(text, String)
    assert str(caught.value) == f"String.data: expected str, got {got}"


@pytest.mark.parametrize(
    "argv",
    [
        [
            "topic",
            "pub",
            "--once",
            "--timeout",
            "1",
            "/x",
            "std_msgs/msg/String",
            "{data: &a [*a]}",
        ],
        ["service", "call", "--timeout", "1", "/s", "std_srvs/srv/SetBool", "{data: &a [*a]}"],
        [
            "action",
            "send_goal",
            "--timeout",
            "1",
            "/f",
            "test_msgs/action/Fibonacci",
            "{order: &a [*a]}",
        ],
    ],
)
def test_a_value_that_holds_itself_is_one_line_from_the_commands(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith("pyconnect: error: VALUE cannot hold itself: alias *a is inside ")
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    "argv",
    [
        [
            "topic",
            "pub",
            "--once",
            "--timeout",
            "1",
            "/x",
            "std_msgs/msg/String",
            "[" * 900 + "]" * 900,
        ],
        ["service", "call", "--timeout", "1", "/s", "std_srvs/srv/SetBool", "[" * 900 + "]" * 900],
    ],
)
def test_a_value_nested_too_deeply_is_one_line_from_the_commands(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 1
    assert capsys.readouterr().err == (
        "pyconnect: error: VALUE is nested too deeply: more than 100 levels of lists and mappings\n"
    )


def test_a_multi_array_takes_its_natural_value_as_a_list() -> None:
    floats = message_from_text("[1.0, 2.0, 3.0]", Float64MultiArray)
    assert list(floats.data) == [1.0, 2.0, 3.0]
    ints = message_from_text("[1, 2, 3]", Int32MultiArray)
    assert list(ints.data) == [1, 2, 3]
    grid = message_from_text("[[1, 2, 3], [4, 5, 6]]", Float64MultiArray)
    assert [(d.size, d.stride) for d in grid.layout.dim] == [(2, 6), (3, 3)]
    assert list(grid.data) == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    # The fields as a dict still work.
    assert list(message_from_text("{data: [4.0]}", Float64MultiArray).data) == [4.0]


@pytest.mark.parametrize("msg_class", [Int32MultiArray, UInt8MultiArray, Float32MultiArray])
def test_an_empty_list_is_an_empty_multi_array(msg_class: Any) -> None:
    message = message_from_text("[]", msg_class)
    assert len(message.data) == 0
    assert [(d.size, d.stride) for d in message.layout.dim] == [(0, 0)]


def test_an_empty_list_is_an_empty_polygon() -> None:
    # An (N, 3) codec takes [] itself: numpy's empty array would be of shape (0,).
    from geometry_msgs.msg import Polygon

    assert list(message_from_text("[]", Polygon).points) == []


@pytest.mark.parametrize(
    ("text", "msg_class", "error"),
    [
        ("[1, 300]", Int8MultiArray, "Int8MultiArray.data[1]: expected int8 in [-128, 127], got 300"),
        ("[1, -200]", Int8MultiArray, "Int8MultiArray.data[1]: expected int8 in [-128, 127], got -200"),
        ("[1, 2, 300]", UInt8MultiArray, "UInt8MultiArray.data[2]: expected uint8 in [0, 255], got 300"),
        ("[[1, 2], [3, -1]]", UInt8MultiArray, "UInt8MultiArray.data[1][1]: expected uint8 in [0, 255], got -1"),
        ("[1, 2.5]", Int32MultiArray, "Int32MultiArray.data[1]: expected int (int32), got float"),
        ("[true, 2]", Int32MultiArray, "Int32MultiArray.data[0]: expected int (int32), got bool"),
        ("[1, 'a']", Float32MultiArray, "Float32MultiArray.data[1]: expected float, got str"),
        ("[1, 1e40]", Float32MultiArray, "Float32MultiArray.data[1]: expected float32 (|x| < 3.4028235677973366e+38), got 1e+40"),
    ],
)  # fmt: skip
def test_a_multi_array_element_that_does_not_fit_is_named(
    text: str, msg_class: Any, error: str
) -> None:
    with pytest.raises(CommandFailed) as caught:
        message_from_text(text, msg_class)
    assert str(caught.value) == error


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("[[1, 2], [3]]", "Int32MultiArray.data: ragged nested list: row 1 has 1 elements, row 0 has 2"),
        ("[[1, 2], 3]", "Int32MultiArray.data: ragged nested list: row 1 is not a list, row 0 is a list of 2 elements"),
        ("[1, [2]]", "Int32MultiArray.data: ragged nested list: row 1 is a list of 1 elements, row 0 is not a list"),
        ("[[[1], [2]], [[3], []]]", "Int32MultiArray.data[1]: ragged nested list: row 1 has 0 elements, row 0 has 1"),
    ],
)  # fmt: skip
def test_a_ragged_multi_array_list_is_refused_with_its_path(text: str, error: str) -> None:
    with pytest.raises(CommandFailed) as caught:
        message_from_text(text, Int32MultiArray)
    assert str(caught.value) == error


def test_a_bad_multi_array_list_is_one_line_from_topic_pub(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # The value is refused before any ROS graph is joined.
    argv = ["topic", "pub", "--once", "/x", "std_msgs/msg/Int8MultiArray", "[1, -200]"]
    assert main(argv) == 1
    assert capsys.readouterr().err == (
        "pyconnect: error: Int8MultiArray.data[1]: expected int8 in [-128, 127], got -200\n"
    )


def test_now_in_a_time_field_and_auto_in_a_header(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(value_input.time, "time_ns", lambda: 1_700_000_000_123_456_789)
    pose = message_from_text("{header: {stamp: now, frame_id: map}}", PoseStamped)
    assert (pose.header.stamp, pose.header.frame_id) == (
        Time(sec=1_700_000_000, nanosec=123_456_789),
        "map",
    )
    pose = message_from_text("{header: auto, pose: {position: {x: 1.5}}}", PoseStamped)
    assert (pose.header.stamp.sec, pose.header.frame_id, pose.pose.position.x) == (
        1_700_000_000,
        "",
        1.5,
    )
    builtins = message_from_text("{time_value: now}", Builtins)
    assert builtins.time_value == Time(sec=1_700_000_000, nanosec=123_456_789)
    assert message_from_text("now", Time) == Time(sec=1_700_000_000, nanosec=123_456_789)


def test_auto_in_a_sequence_of_messages(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(value_input.time, "time_ns", lambda: 5_000_000_007)
    path = message_from_text(
        "{header: auto, poses: [{header: {frame_id: a}}, {header: auto}]}", Path
    )
    assert [p.header.stamp.sec for p in path.poses] == [0, 5]
    assert (path.header.stamp.sec, path.header.stamp.nanosec) == (5, 7)
    assert path.poses[0].header.frame_id == "a"


def test_each_publish_takes_the_time_again(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = iter([1_000_000_000, 2_000_000_000])
    monkeypatch.setattr(value_input.time, "time_ns", lambda: next(clock))
    template = message_template("{header: auto}", PoseStamped)
    assert template.stamped().header.stamp.sec == 1
    assert template.stamped().header.stamp.sec == 2


def test_now_and_auto_elsewhere_are_plain_strings() -> None:
    assert message_from_text("{data: now}", String) == String(data="now")
    assert message_from_text("auto", String) == String(data="auto")
    assert message_template("{data: now}", String).now_paths == []


@pytest.mark.parametrize(
    ("text", "msg_class", "error"),
    [
        (
            "{header: {stamp: soon}}",
            PoseStamped,
            "PoseStamped.header.stamp: expected dict, got str",
        ),
        ("{header: now}", PoseStamped, "PoseStamped.header: expected dict, got str"),
    ],
)
def test_other_words_in_time_fields_are_refused(text: str, msg_class: Any, error: str) -> None:
    with pytest.raises(CommandFailed) as caught:
        message_from_text(text, msg_class)
    assert str(caught.value) == error


def test_a_natural_value_list_elsewhere_still_becomes_tuples() -> None:
    twist = message_from_text("[[0.2, 0, 0], [0, 0, 0.5]]", Twist)
    assert (twist.linear.x, twist.angular.z) == (0.2, 0.5)
    assert isinstance(value_input._natural([1.0], Float64MultiArray), np.ndarray)


def test_parts_of_services_and_actions_take_values_too() -> None:
    # They have no importable name of their own (test_msgs/action/Fibonacci_Goal).
    assert message_from_text("{order: 3}", Fibonacci.Goal) == Fibonacci.Goal(order=3)
    assert message_from_text("{data: true}", SetBool.Request) == SetBool.Request(data=True)


@pytest.mark.parametrize(
    ("text", "msg_class", "error"),
    [
        ("{linaer: {x: 0.2}}", "geometry_msgs/msg/Twist", "Twist: unknown field 'linaer' (fields: angular, linear)"),
        ("{daat: hi}", "std_msgs/msg/String", "String: unknown field 'daat' (fields: data)"),
        ("{header: {stamp: now}, twist: {linaer: {x: 1}}}", "geometry_msgs/msg/TwistStamped",
         "TwistStamped.twist: unknown field 'linaer' (fields: angular, linear)"),
    ],
)  # fmt: skip
def test_a_misspelt_field_is_named(text: str, msg_class: str, error: str) -> None:
    # A dict for a type whose natural value is no mapping holds fields: the natural codec's
    # "expected ((x, y, z), (x, y, z)) or (v, w), got dict" did not say which key was wrong.
    from pyconnect.ros.interfaces import interface_class

    with pytest.raises(CommandFailed) as caught:
        message_from_text(text, interface_class(msg_class, kind="msg"))
    assert str(caught.value) == error


def test_a_dict_of_joints_is_still_a_joint_state() -> None:
    from sensor_msgs.msg import JointState

    message = message_from_text("{j1: {position: 1.0}}", JointState)
    assert (list(message.name), list(message.position)) == (["j1"], [1.0])
